//! Z-dexel stock, cutting tools and the exact sweep kernel.
//!
//! The stock is a grid of vertical columns ([`Grid`]), each holding sorted
//! material intervals ([`Column`]). A tool step is a straight move of the tool
//! tip; [`sweep`] removes, per column, the material at and above the lower
//! envelope of the swept tool and records the removed volume per step and per
//! tool height band. No I/O happens here.
//!
//! * In: a [`Stock`] (a box or cylinder made here, or columns filled by the
//!   `mesh` crate), the [`Tool`]s, and the tool steps ([`Step`]s, held as a
//!   list or made by index, [`StepSource`]) with [`SweepOptions`].
//! * Out: the cut stock (its columns, top heights and last-cut steps) and a
//!   [`RemovalRecord`] (per step the removed volume, its share per tool
//!   height band, the shank's volume and the contact resultant), or the same
//!   rows given to a [`RowSink`] as they are made final ([`Sweep`]).
//!
//! In the pipeline of the `dexcut` library
//! (job → stock (`dexel`, `mesh`) + program (`nc`) → motion (`schedule`) →
//! sweep (`dexel`) → loads (`cutting`) → outputs (`export`))
//! this crate holds the stock and runs the sweep; it depends on no other
//! crate of the workspace.
#![warn(missing_docs)]
pub mod grid;
pub mod stock;
pub mod surface;

pub use grid::Grid;
pub use stock::{Column, Solid, Stock, NEVER_CUT};
pub use surface::{angle_to_axis_deg, surface_normal_near};

/// What can go wrong building a stock or running a sweep.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A size, position or count that is not finite, not positive or out of
    /// range; the message names it.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// The grid would not fit in memory.
    #[error("the grid would need {columns:.3e} columns ({:.1} GiB); use a coarser grid", bytes / 1073741824.0)]
    TooLarge {
        /// Columns the grid would have.
        columns: f64,
        /// Memory they would take, bytes.
        bytes: f64,
    },
}
pub mod sweep;
pub mod tool;
mod top;

pub use sweep::{
    sweep, sweep_tools, RecordRow, RemovalRecord, RowSink, Step, StepFn, StepSource, Sweep,
    SweepOptions, EMPTY_OFFSETS,
};
pub use tool::{Tool, ToolShape};
