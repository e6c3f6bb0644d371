//! G-code reading into a motion path (lines, exact arcs, dwells) with the
//! source line of every segment.
//!
//! Entry points: [`parse`], and [`refeed`] to write a program back with new feeds. The reader never stops at the first problem and
//! never panics; every problem is a [`Diagnostic`] with file, line and column.
#![warn(missing_docs)]
mod amend;
mod cycles;
mod diag;
mod expr;
mod gcode;
mod interp;
mod path;
mod refeed;
mod syntax;
mod unroll;

pub use amend::{amend, Amendment};
pub use diag::{Diagnostic, Severity};
pub use gcode::GCode;
pub use interp::{FileForm, Options, Parsed};
pub use path::{Geometry, Motion, Path, Plane, Segment};
pub use refeed::{refeed, RefeedError};

/// Reads a program (`file_name` only labels diagnostics) into a path.
/// Positions are tool-tip positions in mm in the machine frame.
pub fn parse(source: &str, file_name: &str, options: &Options) -> Parsed {
    interp::run(source, file_name, options).0
}
