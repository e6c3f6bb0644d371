//! The `dexcut` application: job files, the commands and the glue between the
//! library crates. Each command reads its inputs and checks them all before any
//! work, computes in memory, then writes every output file atomically.
//!
//! Data flow: job → stock (dexel, mesh) + program (nc) → motion (schedule)
//! → sweep (dexel) → loads (cutting) → outputs (export).

pub mod bounds;
pub mod commands;
pub mod console;
pub mod evaluate;
pub mod example;
pub mod job;
pub mod motion;
pub mod optimize;
pub mod outdir;
pub mod program;
pub mod progress;
pub mod report;
pub mod simulate;
pub mod stock;
pub mod summary;
pub mod tools;
pub mod warnings;
