//! `dexcut`: Z-dexel cutting simulation and feed optimisation for 3-axis
//! milling, as a library. The `dexcut` binary (crate `dexcut-cli`) is a thin
//! layer of command-line arguments over it.
//!
//! Data flow: job → stock (dexel, mesh) + program (nc) → motion (schedule)
//! → sweep (dexel) → loads (cutting) → outputs (export). The models are stated
//! in `docs/MODEL.md`.
//!
//! The pipeline, each step returning typed results:
//!
//! * [`load`] a job file and everything it names, checked before any work ([`Setup`]);
//! * [`simulate`] it: removal, loads, closed loop, warnings, design comparison
//!   ([`Simulation`], its numbers in a [`Summary`]); nothing is written until
//!   [`Simulation::write_files`];
//! * [`optimize`] it: re-time the program under the job's `[limits]` and write
//!   the results folder ([`Optimized`], its summary.json document an
//!   [`summary::OptimizeSummary`]);
//! * [`report`] a results folder: report.html, heat maps, stock.glb ([`ReportFiles`]);
//! * read any summary.json back through the same types: [`summary::read`].
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A 100 mm slot, 2 mm deep, cut by a Ø10 ball end mill in a box.
//! let dir = std::env::temp_dir().join(format!("dexcut-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! std::fs::write(dir.join("slot.csv"), "x,y,z\n-10,0,28\n110,0,28\n")?;
//! std::fs::write(
//!     dir.join("job.toml"),
//!     r#"
//! [stock]
//! kind = "box"
//! min = [0, -20, 0]
//! max = [100, 20, 30]
//! grid = 0.1
//! [tool]
//! kind = "ball"
//! diameter = 10
//! [program]
//! path = "slot.csv"
//! feed = 1200
//! [limits]
//! mrr_max = 100
//! "#,
//! )?;
//! let mut setup = dexcut::load(&dir.join("job.toml"), None)?;
//! let sim = dexcut::simulate(&setup, false)?;
//! // The cross-section is a circular segment of r = 5, h = 2.
//! let (r, h) = (5.0f64, 2.0f64);
//! let exact = (r * r * ((r - h) / r).acos() - (r - h) * (2.0 * r * h - h * h).sqrt()) * 100.0;
//! assert!((sim.summary.removed_volume_mm3 - exact).abs() < 3e-3 * exact);
//! // 120 mm at 1200 mm/min.
//! assert!((sim.summary.cycle_time_s - 6.0).abs() < 1e-12);
//!
//! // Re-time it under mrr_max = 100 mm³/s into the folder out (servo.csv,
//! // steps.csv, summary.json; a G-code program also gets optimized.nc, read
//! // back and simulated for the numbers after). Nothing is printed.
//! let optimized = dexcut::optimize(&mut setup, &dir.join("out"), false)?;
//! let after = &optimized.summary.after;
//! assert!(after.peak_mrr_mm3_s <= 1.02 * 100.0);
//! // No schedule removes the volume faster than mrr_max allows.
//! assert!(after.cycle_time_s >= sim.summary.removed_volume_mm3 / 100.0);
//! assert!(after.cycle_time_s >= optimized.summary.lower_bound_time_s * (1.0 - 1e-9));
//! // summary.json reads back through the same types.
//! match dexcut::summary::read(&dir.join("out/summary.json"))? {
//!     dexcut::summary::SummaryDoc::Optimize(doc) => assert_eq!(doc.after.cycle_time_s, after.cycle_time_s),
//!     _ => unreachable!("optimize wrote it"),
//! }
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok(())
//! # }
//! ```
#![warn(missing_docs)]

use std::path::Path;
use std::time::Instant;

mod bounds;
pub mod commands;
mod design;
mod error;
mod evaluate;
mod input;
mod model;
mod motion;
/// Building blocks of the optimisation (engagement, caps, re-feed). Not part
/// of the stable API: public only for the S3 integration tests
/// (`tests/source_methods.rs`).
#[doc(hidden)]
pub mod optimize;
mod output;
pub mod progress;
mod report;
mod run;
pub mod saved_stock;

mod setup;
mod util;

pub use commands::{Optimized, Simulation};
pub use error::{Error, Result, Source};
pub use evaluate::{DriveEvaluation, SweepRow};
pub use input::fitted_job;
pub use input::variant::variant as job_variant;
pub use model::summary;
pub use model::warnings::{Warning, WarningKind, Warnings};
pub use model::Summary;
pub use output::steps::{StepColumns, StepsFormat, AUTO_NPY_STEPS};
pub use report::ReportFiles;
pub use run::{ColumnGrid, Run};
pub use setup::Setup;

/// Load a job file (TOML) and everything it names (program, stock mesh, design
/// model, tool table), each checked before any work. `grid_mm` overrides the
/// stock's column spacing.
pub fn load(job: &Path, grid_mm: Option<f64>) -> Result<Setup, Error> {
    Setup::load(job, grid_mm)
}

/// Simulate the job's program as written (`actual_path`: along the drive
/// model's estimate of the axes' path instead). Writes nothing.
pub fn simulate(setup: &Setup, actual_path: bool) -> Result<Simulation, Error> {
    commands::simulate_setup(setup, actual_path)
}

/// Re-time the job's program under its `[limits]` and write the results into
/// the folder `out` (whole, at the end; `force` allows a folder that holds the
/// job's inputs). Column results are the `.npy` grid with columns.json; the
/// steps are steps.csv and steps_before.csv, or above [`AUTO_NPY_STEPS`] steps
/// their `.npy` arrays ([`StepsFormat::Auto`]). The numbers after optimisation
/// are those of optimized.nc read back and simulated. The setup's program
/// path is lent to the planner while the program is re-timed (not copied)
/// and is back in the setup when this returns, with an error too.
pub fn optimize(setup: &mut Setup, out: &Path, force: bool) -> Result<Optimized, Error> {
    let started = Instant::now();
    let out_dir = output::outdir::OutDir::begin(out, &setup.input_files(&setup.job_path), force)?;
    commands::optimize_setup(setup, out_dir, started, false, StepsFormat::Auto, &|_| {})
}

/// Run the job's program, as planned, through its drive model (`[servo]`) and
/// score the estimated actual motion by S2's trajectory error, time and jerk,
/// with S4's pre-compensation (MODEL.md §7.2); with `sweep`, also a grid of
/// acceleration, jerk and gain settings. Writes nothing.
pub fn evaluate(setup: &Setup, sweep: bool) -> Result<DriveEvaluation, Error> {
    evaluate::evaluate_setup(setup, None, sweep)
}

/// Build the report (report.html, error_map.png, stock.glb) of a folder written
/// by `simulate` or [`optimize`], from its files alone.
pub fn report(dir: &Path) -> Result<ReportFiles, Error> {
    report::write_report(dir)
}
