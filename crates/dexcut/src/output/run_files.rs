//! A run's files: its steps and its per-column results (the `.npy` grid,
//! columns.csv), with the program line that last cut each column where the
//! run has a design comparison.

use std::path::Path;

use dexel::NEVER_CUT;

use crate::error::Result;
use crate::model::summary::DesignInfo;
use crate::output::steps::StepsFormat;
use crate::run::Run;

/// The steps (`steps.csv` and/or `steps.json` with its `.npy` arrays, as
/// `steps_format` says) and the per-column results of a run (the `.npy` grid,
/// and columns.csv when `columns_csv`) into `out`.
pub fn write_run_files(
    run: &Run,
    design: Option<&(Vec<f32>, DesignInfo)>,
    out: &Path,
    steps_format: StepsFormat,
    columns_csv: bool,
) -> Result<StepsFormat> {
    let steps_format = run.write_steps(out, "steps", steps_format)?;
    // With a design model each column also names the program line that last cut it (S1).
    let lines: Option<Vec<i32>> = design.as_ref().map(|_| last_cut_lines(run));
    run.write_columns(
        out,
        design.map(|d| d.0.as_slice()),
        lines.as_deref(),
        columns_csv,
    )?;
    Ok(steps_format)
}

/// Per column, the program line of the step that last cut it; -1 if never cut.
pub fn last_cut_lines(run: &Run) -> Vec<i32> {
    run.stock
        .last_cut()
        .iter()
        .map(|&s| {
            if s == NEVER_CUT {
                -1
            } else {
                run.steps[s as usize].line as i32
            }
        })
        .collect()
}
