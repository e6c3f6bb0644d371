//! Data only: the serde schema types of summary.json.

mod run_summary;

pub use run_summary::*;
