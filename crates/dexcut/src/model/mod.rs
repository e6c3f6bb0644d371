//! Data only: the serde schema types of summary.json ([`summary`], the run's
//! own numbers in [`Summary`]) and the typed list of warnings ([`warnings`])
//! that a run, the commands and the report share.

mod run_summary;
pub mod summary;
pub mod warnings;

pub use run_summary::*;
