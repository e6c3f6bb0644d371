//! G-code reading into a motion path (lines, exact arcs, dwells) with the
//! source line of every segment.
//!
//! Entry points: [`parse`], and [`refeed`] to write a program back with new feeds. The reader never stops at the first problem and
//! never panics; every problem is a [`Diagnostic`] with file, line and column.
#![warn(missing_docs)]
mod amend;
mod cursor;
mod cycles;
mod diag;
mod expr;
mod gcode;
mod interp;
mod path;
mod refeed;
mod syntax;
mod text;
mod unroll;

pub use amend::{amend, Amendment};
pub use diag::{Diagnostic, Severity};
pub use gcode::GCode;
pub use interp::{FileForm, Options, Parsed};
pub use path::{Geometry, Motion, Path, PathControl, PathControlChange, Plane, Segment};
pub use refeed::{refeed, refeed_read, refeed_read_along, RefeedError};
pub use text::decode;

/// Reads a program (`file_name` only labels diagnostics) into a path.
/// Positions are tool-tip positions in mm in the machine frame.
pub fn parse(source: &str, file_name: &str, options: &Options) -> Parsed {
    interp::parse(source, file_name, options)
}

/// A program read once and run from more than one start: its lines are
/// read once ([`Reader::parse_from`] runs them again from another place).
/// As [`parse`], it keeps no block's items: each run reads a block's words
/// from `source` where it runs (a million-block program's lines hold 32 MB,
/// not about 190, and its runs are quicker than from the items held).
pub struct Reader<'a> {
    file_name: &'a str,
    source: &'a str,
    options: Options,
    read: interp::Read,
}

impl<'a> Reader<'a> {
    /// Reads `source` as [`parse`] does with `options` (only labels diagnostics with `file_name`).
    pub fn new(source: &'a str, file_name: &'a str, options: &Options) -> Self {
        Reader {
            file_name,
            source,
            options: options.clone(),
            read: interp::read_unkept(source, file_name, options),
        }
    }

    /// What [`parse`] returns for the source and options read.
    pub fn parse(&self) -> Parsed {
        self.run(&self.options, interp::PathRoom::default())
    }

    /// A run of the text read with `options`, its path made in `room`.
    fn run(&self, options: &Options, room: interp::PathRoom) -> Parsed {
        let (source, file) = (self.source, self.file_name);
        interp::run_read_and_record(&self.read, source, file, options, false, None, room).0
    }

    /// [`Reader::parse`], then, where `start` picks a start from that run
    /// (`Some`), the run from there ([`Reader::parse_from`]) made in the first
    /// run's memory (a million segments are 120 MB of pages new to the process
    /// otherwise); where it picks none, the first run. The same paths,
    /// diagnostics and amendments as those two calls.
    pub fn parse_then_from(&self, start: impl FnOnce(&Parsed) -> Option<[f64; 3]>) -> Parsed {
        let keep_room = interp::PathRoom {
            segments: Vec::new(),
            shrink: false,
        };
        let mut first = self.run(&self.options, keep_room);
        let Some(initial_position_mm) = start(&first) else {
            first.path.segments.shrink_to_fit();
            return first;
        };
        let segments = std::mem::take(&mut first.path.segments);
        drop(first);
        let options = Options {
            initial_position_mm,
            ..self.options.clone()
        };
        let room = interp::PathRoom {
            segments,
            shrink: true,
        };
        self.run(&options, room)
    }

    /// [`Reader::parse`] with the tool starting at `initial_position_mm`
    /// ([`Options::initial_position_mm`]) instead.
    pub fn parse_from(&self, initial_position_mm: [f64; 3]) -> Parsed {
        let options = Options {
            initial_position_mm,
            ..self.options.clone()
        };
        self.run(&options, interp::PathRoom::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A program read once and run twice gives what two readings give: the
    /// path (incremental moves follow the start), the warnings of the tolerant
    /// form and the amendments, the tool loaded first.
    #[test]
    fn a_reader_runs_as_parse_does_from_any_start() {
        let source = "\u{feff}G21 G90 (a (nested) comment)\nT2 M6\nG0 X1 Y2 Z3\nG91 G1 X1 F100\nG2 X2 Y0 I1 J0\n";
        let options = Options {
            file_form: FileForm::Tolerant,
            ..Options::default()
        };
        let reader = Reader::new(source, "p.nc", &options);
        assert_eq!(reader.parse(), parse(source, "p.nc", &options));
        let start = [5.0, -4.0, 12.5];
        let moved = Options {
            initial_position_mm: start,
            ..options.clone()
        };
        let from = reader.parse_from(start);
        assert_eq!(from, parse(source, "p.nc", &moved));
        // The second run made in the first's memory: the same runs.
        let mut seen = None;
        let then = reader.parse_then_from(|first| {
            seen = Some(first.clone());
            Some(start)
        });
        assert_eq!(then, from);
        assert_eq!(seen, Some(reader.parse()));
        assert_eq!(reader.parse_then_from(|_| None), reader.parse());
        assert_ne!(from.path, reader.parse().path);
        assert!(from.diagnostics.iter().any(|d| !d.is_error()));
        assert!(!from.amendments.is_empty());
    }

    /// A path is held at its length, not at the capacity its pushes grew it
    /// to (up to twice its segments): read once, or by a reader from two
    /// starts.
    #[test]
    fn a_path_is_read_without_spare_capacity() {
        let source: String = std::iter::once("G21 G90 G0 X0 Y0 Z5\n".to_string())
            .chain((1..=1500).map(|i| format!("G1 X{i} Y{} F900\n", i % 7)))
            .chain(std::iter::once("M2\n".to_string()))
            .collect();
        let options = Options::default();
        let parsed = parse(&source, "p.nc", &options);
        assert_eq!(parsed.path.segments.len(), 1501);
        let reader = Reader::new(&source, "p.nc", &options);
        for path in [
            parsed.path,
            reader.parse().path,
            reader.parse_from([1.0, 2.0, 9.0]).path,
            reader.parse_then_from(|_| Some([1.0, 2.0, 9.0])).path,
            reader.parse_then_from(|_| None).path,
        ] {
            assert_eq!(path.segments.capacity(), path.segments.len());
        }
    }
}
