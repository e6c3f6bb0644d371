//! The run's column files: the `.npy` grid (`top_mm`, `last_step`,
//! `error_um`, with a design model `design_um` and `line`) and
//! columns.csv, written block of rows by block of rows; a tiled stock's
//! written band by band.

use std::path::Path;

use dexel::NEVER_CUT;

use super::closed_loop::offset_step;
use super::error_map::{clamped_error_map_um, error_range_um, Before, ErrorMap};
use super::{sweep_setup, Run};
use crate::error::{Error, Result};
use crate::input::tools::ToolSet;
use crate::model::GridInfo;
use crate::progress;

/// The per-column results of a run on a tiled stock, written band by band
/// into the `.npy` grid in `dir` (ARCHITECTURE.md "Large stocks"). Each band
/// of the initial stock is made again with halo rows on each side (the error
/// map's surface normals and its clamp to the stock look that far), swept
/// with the final pass's steps (a column's material depends only on the
/// steps, so it is the whole stock's column), and its own rows of `top_mm`,
/// `last_step` and `error_um` are appended to the files. Sets the run's
/// volumes (summed row by row in order, as the whole stock's) and error range.
/// With no `dir` nothing is written: the bands are made and swept for the
/// volumes and the error range alone (`optimize`'s program as given).
pub fn write_tiled_columns(
    run: &mut Run,
    tiling: &crate::input::stock::Tiling,
    tools: &ToolSet,
    dir: Option<&Path>,
) -> Result<()> {
    let grid = tiling.grid;
    let (tool_of_step, options) = sweep_setup(tools, &run.steps)?;
    // The final pass's steps: the rigid ones, or moved by the loop's offsets.
    let steps: Vec<dexel::Step> = if run.closed_loop.passes > 1 {
        let offsets_mm: Vec<[f64; 2]> = run
            .offsets_um
            .iter()
            .map(|&[x, y]| [1e-3 * x, 1e-3 * y])
            .collect();
        (0..run.steps.len())
            .map(|i| offset_step(&run.steps, &offsets_mm, i))
            .collect()
    } else {
        run.steps.iter().map(|s| s.step).collect()
    };
    let largest_offset_um = run
        .offsets_um
        .iter()
        .map(|&[x, y]| x.hypot(y))
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    let reach_mm = 1e-3 * (run.model_um.largest_um() + largest_offset_um);
    let halo = (reach_mm / grid.spacing_mm).ceil() as usize + 2;
    let mut writer = match dir {
        None => None,
        Some(dir) => Some(
            export::ColumnGridWriter::begin(dir, &GridInfo::of(&grid).export(), &run_grid_arrays())
                .map_err(grid_error(dir))?,
        ),
    };
    let tools_list = tools.tools();
    let (mut initial_mm, mut final_mm) = (0.0, 0.0);
    let mut range = [0.0, 0.0];
    // The bands are made in the memory of the ones before.
    let (mut previous_initial, mut previous_last) = (None, None);
    for rows in tiling.bands() {
        let held = rows.start.saturating_sub(halo)..(rows.end + halo).min(grid.ny);
        let initial = tiling.band(held.clone(), previous_initial.take())?;
        let mut last = tiling.band(held.clone(), previous_last.take())?;
        let mut sweep = dexel::Sweep::new(&tools_list, &tool_of_step, &steps, &options)?;
        let label = format!("columns rows {}..{} of {}", rows.start, rows.end, grid.ny);
        let bar = progress::bar(steps.len() as u64, &label);
        sweep.band(&mut last, &|done| bar.set_position(done as u64));
        bar.finish_and_clear();
        drop(sweep);
        let error = clamped_error_map_um(
            Before::Stock(&initial),
            &last,
            &run.offsets_um,
            &run.model_um,
            &run.steps,
            0..last.last_cut().len(),
        );
        initial_mm = initial.add_row_lengths_mm(rows.clone(), initial_mm);
        final_mm = last.add_row_lengths_mm(rows.clone(), final_mm);
        previous_initial = Some(initial);
        let own = (rows.start - held.start) * grid.nx..(rows.end - held.start) * grid.nx;
        let error = &error[own.clone()];
        range = error_range_um(error, range);
        if let (Some(writer), Some(dir)) = (writer.as_mut(), dir) {
            let tops = last.top_heights_at(own.clone());
            let steps_cut = last_steps(&last.last_cut()[own]);
            writer
                .write_rows(&[
                    export::NpyValues::F32(&tops),
                    export::NpyValues::I32(&steps_cut),
                    export::NpyValues::F32(error),
                ])
                .map_err(grid_error(dir))?;
        }
        previous_last = Some(last);
    }
    if let (Some(writer), Some(dir)) = (writer, dir) {
        writer.finish().map_err(grid_error(dir))?;
    }
    let area = grid.cell_area_mm2();
    run.initial_volume_mm3 = initial_mm * area;
    run.final_volume_mm3 = final_mm * area;
    run.error_range_um = std::sync::OnceLock::from(range);
    Ok(())
}

/// The arrays of the column grid every run writes (`top_mm`, `last_step`,
/// `error_um`), as [`export::ColumnGridWriter::begin`] takes them (no values).
fn run_grid_arrays() -> Vec<export::GridArray<'static>> {
    let meta = |name, unit, meaning, values| export::GridArray {
        name,
        unit,
        meaning,
        values,
    };
    vec![
        meta("top_mm", "mm", TOP_MEANING, export::NpyValues::F32(&[])),
        meta(
            "last_step",
            "1",
            LAST_STEP_MEANING,
            export::NpyValues::I32(&[]),
        ),
        meta("error_um", "µm", ERROR_MEANING, export::NpyValues::F32(&[])),
    ]
}

/// Bytes of the column grid every run writes, per column.
pub(crate) fn run_grid_bytes_per_column() -> usize {
    run_grid_arrays()
        .iter()
        .map(|a| a.values.dtype().size())
        .sum()
}

/// An error of writing the column grid into `dir`, with the folder named.
fn grid_error(dir: &Path) -> impl Fn(export::Error) -> Error + Copy + '_ {
    move |e| Error::from(e).context(format!("cannot write the column grid in {}", dir.display()))
}

/// `last_step` of the column grid: the step that last cut each column, −1 if none.
fn last_steps(last_cut: &[u32]) -> Vec<i32> {
    last_cut
        .iter()
        .map(|&s| if s == NEVER_CUT { -1 } else { s as i32 })
        .collect()
}

const TOP_MEANING: &str = "top of the material after the run; NaN where the column holds none";
const LAST_STEP_MEANING: &str =
    "index of the step (row of steps.csv) that last cut the column; -1 if never cut";
const ERROR_MEANING: &str =
    "predicted shape error from tool deflection, + material left; NaN where not cut";
const DESIGN_MEANING: &str =
    "final surface minus the design model, + stock left, - gouge; NaN outside the design";
const LINE_MEANING: &str = "program line of the step that last cut the column; -1 if never cut";

/// A run's per-column results whole, as the column grid's `.npy` arrays hold
/// them bit for bit: element `iy * nx + ix` is the column centred at
/// (`x0_mm + ix·spacing_mm`, `y0_mm + iy·spacing_mm`).
#[derive(Clone, Debug)]
pub struct ColumnGrid {
    /// The grid's geometry (columns.json's).
    pub grid: GridInfo,
    /// Top of the material after the run, mm; NaN where the column holds none.
    pub top_mm: Vec<f32>,
    /// The step that last cut the column; -1 if never cut.
    pub last_step: Vec<i32>,
    /// Predicted shape error from tool deflection, µm, + material left; NaN where not cut.
    pub error_um: Vec<f32>,
    /// With a design model: final surface minus the design, µm.
    pub design_um: Option<Vec<f32>>,
    /// With a design model: program line of the step that last cut the column; -1 if never cut.
    pub line: Option<Vec<i32>>,
}

impl Run {
    /// The per-column results whole ([`ColumnGrid`], without the design
    /// comparison): the values [`Run::write_columns`] writes.
    pub fn column_grid(&self) -> ColumnGrid {
        ColumnGrid {
            grid: GridInfo::of(self.stock.grid()),
            top_mm: self.stock.top_heights(),
            last_step: last_steps(self.stock.last_cut()),
            error_um: self.error_map_um().into_owned(),
            design_um: None,
            line: None,
        }
    }

    /// Write the per-column results into the folder `dir`: final surface
    /// (`top_mm`, the stock's top heights), last cutting step, predicted
    /// error, and with a design model the distance to it and the program line
    /// that last cut. Always as the compact grid (`columns.json` and one
    /// `.npy` array each), made and written block of rows by block of rows
    /// from the stock (no whole-grid copy of the tops or last steps: issue
    /// 16); also as `columns.csv` when `csv` is set.
    pub fn write_columns(
        &self,
        dir: &Path,
        design_diff_um: Option<&[f32]>,
        line: Option<&[i32]>,
        csv: bool,
    ) -> Result<()> {
        let last_cut = self.stock.last_cut();
        let grid = GridInfo::of(self.stock.grid()).export();
        let context = grid_error(dir);
        let meta = |name, unit, meaning, values| export::GridArray {
            name,
            unit,
            meaning,
            values,
        };
        let mut arrays = run_grid_arrays();
        if let ErrorMap::Held(error) = &self.error_map {
            grid.check_len("grid array \"error_um\"", error.len())
                .map_err(context)?;
        }
        if let Some(d) = design_diff_um {
            grid.check_len("grid array \"design_um\"", d.len())
                .map_err(context)?;
            arrays.push(meta(
                "design_um",
                "µm",
                DESIGN_MEANING,
                export::NpyValues::F32(&[]),
            ));
        }
        if let Some(l) = line {
            grid.check_len("grid array \"line\"", l.len())
                .map_err(context)?;
            arrays.push(meta("line", "1", LINE_MEANING, export::NpyValues::I32(&[])));
        }
        let mut writer = export::ColumnGridWriter::begin(dir, &grid, &arrays).map_err(context)?;
        // A map made as it is written gives its range on the way (the same
        // blocks in the same order as `Run::error_range_um`'s).
        let mut range = [0.0, 0.0];
        for at in row_blocks(self.stock.grid()) {
            let tops = self.stock.top_heights_at(at.clone());
            let last = last_steps(&last_cut[at.clone()]);
            let error = self.error_map_at(at.clone());
            range = error_range_um(&error, range);
            let mut values = vec![
                export::NpyValues::F32(&tops),
                export::NpyValues::I32(&last),
                export::NpyValues::F32(&error),
            ];
            if let Some(d) = design_diff_um {
                values.push(export::NpyValues::F32(&d[at.clone()]));
            }
            if let Some(l) = line {
                values.push(export::NpyValues::I32(&l[at.clone()]));
            }
            writer.write_rows(&values).map_err(context)?;
        }
        writer.finish().map_err(context)?;
        if let ErrorMap::Made(..) = self.error_map {
            // (Set already where the summary went through the map first.)
            let _ = self.error_range_um.set(range);
        }
        if !csv {
            return Ok(());
        }
        // columns.csv: integers as numbers, "no value" as an empty field.
        let as_f32 = |v: &[i32]| -> Vec<f32> {
            v.iter()
                .map(|&i| if i < 0 { f32::NAN } else { i as f32 })
                .collect()
        };
        let tops = self.stock.top_heights();
        let last_f = as_f32(&last_steps(last_cut));
        let line_f = line.map(as_f32);
        let error = self.error_map_um();
        let mut columns: Vec<(&str, &[f32])> = vec![
            ("top_mm", &tops),
            ("last_step", &last_f),
            ("error_um", &error),
        ];
        if let Some(d) = design_diff_um {
            columns.push(("design_um", d));
        }
        if let Some(l) = &line_f {
            columns.push(("line", l));
        }
        let path = dir.join("columns.csv");
        export::write_column_csv(&path, &grid, &columns)
            .map_err(|e| Error::Export(e).context(format!("cannot write {}", path.display())))
    }
}

/// Rows of the column grid made and written at a time by [`Run::write_columns`]
/// (and of an error map made where it is read, [`ErrorMap::Made`]).
const WRITE_BLOCK_ROWS: usize = 64;

/// The columns of `grid` (indices) in blocks of [`WRITE_BLOCK_ROWS`] rows, in order.
pub(crate) fn row_blocks(grid: &dexel::Grid) -> impl Iterator<Item = std::ops::Range<usize>> {
    let (len, block) = (grid.len(), grid.nx.max(1) * WRITE_BLOCK_ROWS);
    (0..len)
        .step_by(block)
        .map(move |start| start..(start + block).min(len))
}
