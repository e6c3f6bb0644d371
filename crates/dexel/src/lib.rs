//! Z-dexel stock, cutting tools and the exact sweep kernel.
//!
//! The stock is a grid of vertical columns ([`Grid`]), each holding sorted
//! material intervals ([`Column`]). A tool step is a straight move of the tool
//! tip; [`sweep`] removes, per column, the material at and above the lower
//! envelope of the swept tool and records the removed volume per step and per
//! tool height band. No I/O happens here.
pub mod grid;
pub mod stock;
pub mod surface;

pub use grid::Grid;
pub use stock::{Column, Stock, NEVER_CUT};
pub use surface::{angle_to_axis_deg, surface_normal_near};

/// What can go wrong building a stock or running a sweep.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    #[error("the grid would need {columns:.3e} columns ({:.1} GiB); use a coarser grid", bytes / 1073741824.0)]
    TooLarge { columns: f64, bytes: f64 },
}
pub mod sweep;
pub mod tool;

pub use sweep::{sweep, sweep_tools, RemovalRecord, Step, SweepOptions};
pub use tool::{Tool, ToolShape};
