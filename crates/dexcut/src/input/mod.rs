//! What a run reads: the job file and its checks, the program, the tools
//! and their cutting models, the stock, a job fitted to a program, and the
//! example job.

pub mod example;
pub mod fitted_job;
pub mod job;
pub mod operations;
pub mod program;
pub mod stock;
pub mod toml_keys;
pub mod tool_library;
pub mod tools;
pub mod variant;
