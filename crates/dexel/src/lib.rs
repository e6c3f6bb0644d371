//! Z-dexel stock, cutting tools and the exact sweep kernel.
//!
//! The stock is a grid of vertical columns ([`Grid`]), each holding sorted
//! material intervals ([`Column`]). A tool step is a straight move of the tool
//! tip; [`sweep`] removes, per column, the material at and above the lower
//! envelope of the swept tool and records the removed volume per step and per
//! tool height band. No I/O happens here.
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
    SweepOptions,
};
pub use tool::{Tool, ToolShape};
