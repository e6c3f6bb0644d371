//! The simulate engine: sweep the program through the stock and record what
//! every step removed, the load it puts on the tool and the error it leaves.
//! This module holds the run ([`Run`]), the stock it sweeps
//! ([`StockSource`]) and the sweep driver ([`run_on`], [`sweep_pass`]); the
//! closed loop of removal and deflection, the loads, the error map, the
//! run's numbers, its warnings and its column files are in its submodules.

use std::collections::BTreeMap;
use std::time::Instant;

use cutting::StepLoad;
use dexel::{RemovalRecord, Stock, SweepOptions};

use crate::error::Result;
use crate::input::tools::ToolSet;
use crate::motion::TimedStep;
use crate::progress;

mod closed_loop;
mod columns;
mod error_map;
mod loads;
mod metrics;
mod subcell;
#[cfg(test)]
mod tests;
mod warnings;

use closed_loop::{applied_offsets_um, close_loop, LoopInputs, LoopPlan};
pub use error_map::FlankDeflections;
use error_map::{final_error_map, Before, ErrorMap};
use loads::Removals;

pub use closed_loop::{LoopReport, LOOP_TOL_UM};
pub(crate) use columns::run_grid_bytes_per_column;
pub use columns::{write_tiled_columns, ColumnGrid};
pub(crate) use loads::{feed_dir, len_xy_mm};
pub use subcell::SUB_CELL_WINDOW_CELLS;

/// Volume below which a step counts as removing nothing, mm³ (f32 column
/// heights round at about 1e-7 mm; this is a 0.1 µm layer over 10 × 10 cells of 0.1 mm).
pub const NOTHING_MM3: f64 = 1e-6;
/// Window of the smoothed MRR in summaries, s (three 16 ms periods).
pub const MRR_WINDOW_S: f64 = 0.048;
/// ... and at least this many grid cells of path: removal per unit length is
/// resolved only to about one column, so shorter windows show the column phase.
pub const MRR_WINDOW_CELLS: f64 = 10.0;

/// Everything a run produced, in memory.
pub struct Run {
    /// The steps, timed, each with its program line and tool.
    pub steps: Vec<TimedStep>,
    /// What the (deflected) tool removed, per step.
    pub record: RemovalRecord,
    /// Force, power, deflection and stress per step.
    pub loads: Vec<StepLoad>,
    /// Per step, the lateral offset of the tool in the final pass, µm: its converged
    /// deflection at the contact height (MODEL.md §5.1).
    pub offsets_um: Vec<[f64; 2]>,
    /// Predicted shape error per column, µm, clamped to the stock (MODEL.md
    /// §5): held, or made where it is read ([`Run::error_map_um`],
    /// [`Run::error_map_at`]).
    error_map: ErrorMap,
    /// Stock volume before the run, mm³.
    pub initial_volume_mm3: f64,
    /// Stock volume after the run, mm³.
    pub final_volume_mm3: f64,
    /// The stock the deflected tool leaves (for a tiled stock, none of its
    /// rows: [`write_tiled_columns`] makes the bands again).
    pub stock: Stock,
    /// Per step and band, the deflection across the path its final removal
    /// causes at the instants a tooth at the band's mid-height passes the
    /// flank on the left of the feed and on the right, µm: the error map's
    /// model (MODEL.md §5, §5.2) for the walls left on either side.
    pub model_um: FlankDeflections,
    /// Least and greatest error of the map, µm ([`Run::error_range_um`]):
    /// found by the first that goes through the whole map, in order (the
    /// summary, or [`Run::write_columns`] as it makes and writes the map of a
    /// stock made of its closed form), or a tiled stock's (set by
    /// [`write_tiled_columns`]).
    error_range_um: std::sync::OnceLock<[f64; 2]>,
    /// Wall-clock time of the sweeps, s.
    pub sweep_s: f64,
    /// How the closed loop between removal and deflection ended.
    pub closed_loop: LoopReport,
    /// Largest deflection at the contact height of the rigid tool's removal, µm.
    pub rigid_peak_deflection_um: f64,
    /// Allowable stress and rupture strength of each tool the steps carry,
    /// by tool number, MPa: a step's are its tool's
    /// ([`Run::stress_limit_mpa_at`], [`Run::rupture_strength_mpa_at`]; not
    /// two per step, 16 MB for a million steps).
    pub strengths_mpa: BTreeMap<u32, [f64; 2]>,
    /// Each tool number the steps carry as messages name it
    /// ([`ToolSet::name`]: a single `[tool]` is "the job's tool").
    pub tool_names: BTreeMap<u32, String>,
}

/// The stock a run sweeps: whole in memory, or too large for the memory
/// budget and made band of rows by band of rows for each sweep (ARCHITECTURE.md
/// "Large stocks").
pub enum StockSource<'a> {
    /// The whole stock.
    Whole(Stock),
    /// The whole stock, lent: every pass sweeps a copy of it (`optimize`'s
    /// runs, whose job stock stays for the next one: one stock fewer held
    /// than a copy handed over).
    Lent(&'a Stock),
    /// The whole stock of a box or a cylinder (`dexel::Solid`), handed over:
    /// every pass sweeps the stock made again from its closed form, in the
    /// memory of the one before (the stock handed over, then the last
    /// pass's), and the error map asks the closed form what material was
    /// there, so one stock is held, not two.
    Made(Stock, dexel::Solid),
    /// The bands of a tiled stock.
    Tiled(&'a crate::input::stock::Tiling),
}

impl crate::setup::Setup {
    /// The job's stock as a run sweeps it: lent whole, or band by band where
    /// it is too large for the memory budget ([`Setup::tiling`](crate::setup::Setup::tiling)).
    pub fn stock_source(&self) -> StockSource<'_> {
        match &self.tiling {
            Some(tiling) => StockSource::Tiled(tiling),
            None => StockSource::Lent(&self.stock),
        }
    }
}

impl StockSource<'_> {
    /// The grid of the stock's columns (a tiled stock's whole grid).
    pub fn grid(&self) -> &dexel::Grid {
        match self {
            StockSource::Whole(s) | StockSource::Made(s, _) => s.grid(),
            StockSource::Lent(s) => s.grid(),
            StockSource::Tiled(t) => &t.grid,
        }
    }

    /// What a sweep of this stock starts from, the stock borrowed.
    pub(crate) fn initial(&self) -> Initial<'_> {
        match self {
            StockSource::Whole(s) => Initial::Held(std::borrow::Cow::Borrowed(s)),
            StockSource::Lent(s) => Initial::Held(std::borrow::Cow::Borrowed(s)),
            StockSource::Made(s, solid) => Initial::Made(*solid, *s.grid()),
            StockSource::Tiled(t) => Initial::Tiled(t),
        }
    }
}

/// What each pass of a run starts from (a [`StockSource`] once its stock
/// handed over is taken as the first pass's memory).
pub(crate) enum Initial<'a> {
    /// A stock held whole (handed over or lent): each pass sweeps a copy.
    Held(std::borrow::Cow<'a, Stock>),
    /// A closed form on its grid: each pass sweeps the stock made of it.
    Made(dexel::Solid, dexel::Grid),
    /// The bands of a tiled stock.
    Tiled(&'a crate::input::stock::Tiling),
}

impl Initial<'_> {
    /// The initial stock's columns as the error map reads them; None for a
    /// tiled stock.
    fn columns(&self) -> Option<Before<'_>> {
        match self {
            Initial::Held(stock) => Some(Before::Stock(stock)),
            Initial::Made(solid, grid) => Some(Before::Solid(solid, grid)),
            Initial::Tiled(_) => None,
        }
    }
}

/// One sweep of `steps` through a copy of the initial stock (made in the
/// memory of `spare` where it is a closed form), each step with its tool;
/// with a tiled stock, band by band in row order (the record is the whole
/// stock's bit for bit, no stock is kept). The steps are a list or made as
/// the sweep asks for them ([`dexel::StepSource`]).
pub(crate) fn sweep_pass<S: dexel::StepSource + ?Sized, T: Copy + Into<usize>>(
    initial: &Initial,
    spare: Option<Stock>,
    tools: &ToolSet,
    tool_of_step: &[T],
    steps: &S,
    options: &SweepOptions,
    label: &str,
) -> Result<(Option<Stock>, RemovalRecord)> {
    let tools = tools.tools();
    let sweep = dexel::Sweep::new(&tools, tool_of_step, steps, options)?;
    let (work, record) = sweep_through(initial, spare, sweep, label, None)?;
    Ok((work, record.expect("a record where no sink is given")))
}

/// [`sweep_pass`]'s sweep made: its record, or with a `sink` each step's
/// row given to it as the sweep makes it final, in order, and no record
/// (`dexel::Sweep::whole_into`; a tiled stock makes no row final before its
/// last band, so its record is made whole first and then given row by row).
pub(crate) fn sweep_through<S: dexel::StepSource + ?Sized>(
    initial: &Initial,
    spare: Option<Stock>,
    mut sweep: dexel::Sweep<'_, S>,
    label: &str,
    sink: Option<&mut dexel::RowSink<'_>>,
) -> Result<(Option<Stock>, Option<RemovalRecord>)> {
    let n = sweep.len();
    let mut work = match initial {
        Initial::Held(stock) => {
            drop(spare);
            stock.as_ref().clone()
        }
        Initial::Made(solid, grid) => solid.stock_in_rows(grid.spacing_mm, None, spare)?,
        Initial::Tiled(tiling) => {
            // Each band made in the memory of the one before.
            let mut previous = None;
            for rows in tiling.bands() {
                let label = format!(
                    "{label} rows {}..{} of {}",
                    rows.start, rows.end, tiling.grid.ny
                );
                let mut band = tiling.band(rows, previous.take())?;
                let bar = progress::bar(n as u64, &label);
                sweep.band(&mut band, &|done| bar.set_position(done as u64));
                bar.finish_and_clear();
                previous = Some(band);
            }
            return Ok(match sink {
                Some(sink) => {
                    sweep.finish_into(sink);
                    (None, None)
                }
                None => (None, Some(sweep.finish())),
            });
        }
    };
    // The record made final and compact batch by batch, or its rows given away.
    let bar = progress::bar(n as u64, label);
    let progress = |done: usize| bar.set_position(done as u64);
    let record = match sink {
        Some(sink) => {
            sweep.whole_into(&mut work, &progress, sink);
            None
        }
        None => Some(sweep.whole(&mut work, &progress)),
    };
    bar.finish_and_clear();
    Ok((Some(work), record))
}

/// Each step's tool and the sweep options of a run.
pub(crate) fn sweep_setup(
    tools: &ToolSet,
    steps: &[TimedStep],
) -> Result<(Vec<usize>, SweepOptions)> {
    let tool_of_step = tools.indices(steps.iter().map(|s| (s.tool, s.line)))?;
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    Ok((tool_of_step, options))
}

/// Each step's tool's numbers, made where they are read (one a tool, not a
/// copy a step).
#[derive(Clone, Copy)]
pub(crate) struct StepTools<'a> {
    /// The run's tools.
    pub tools: &'a ToolSet,
    /// Each step's entry of `tools`.
    pub tool_of_step: &'a [usize],
}

impl StepTools<'_> {
    /// Allowable stress of step `i`'s tool, MPa.
    pub(crate) fn stress_limit_mpa(&self, i: usize) -> f64 {
        self.tools.entries[self.tool_of_step[i]].stress_limit_mpa
    }

    /// Rupture strength of step `i`'s tool, MPa.
    pub(crate) fn rupture_strength_mpa(&self, i: usize) -> f64 {
        self.tools.entries[self.tool_of_step[i]].rupture_strength_mpa
    }

    /// The largest offset step `i` may be tried at (MODEL.md §5.1): its
    /// tool's radius, µm. A trial beyond it would sweep the tool into stock
    /// it cannot reach and feed the loop ever larger loads.
    pub(crate) fn offset_cap_um(&self, i: usize) -> f64 {
        500.0 * self.tools.entries[self.tool_of_step[i]].tool.diameter_mm
    }
}

/// Sweep `steps` through `stock` and compute the loads, closing the loop between
/// removal and deflection (MODEL.md §5.1): the rigid tool's removal gives each
/// step's deflection; the program is swept again with the tool moved across its
/// path by a trial offset, and each step's offset is relaxed towards the
/// deflection the removal causes until they agree. Each step is cut by its own
/// tool (MODEL.md §9.1). The error map is then clamped to the stock (MODEL.md §5).
/// The stock is held whole (handed over, lent or made of its closed form) or
/// in bands. With a tiled stock the run keeps no stock, no error map and no
/// volumes (NaN): [`write_tiled_columns`] makes them band by band.
///
/// Memory (the peak of a million-step run): the rigid sweep's record and
/// loads are freed (`std::mem::take`) before the loop's searches are made;
/// the loop frees what it holds as [`closed_loop::close_loop`] says; then
/// what only the loop read (the rigid deflections, the loop's and the
/// inherited steps, the sub-cell windows and advances) is dropped before the
/// last pass's loads are made again, and the trials `x` once the offsets
/// are made from them.
pub fn run_on(
    stock: StockSource,
    tools: &ToolSet,
    steps: Vec<TimedStep>,
    label: &str,
) -> Result<Run> {
    let (initial_volume_mm3, grid_mm) = match &stock {
        StockSource::Whole(s) | StockSource::Made(s, _) => (s.volume_mm3(), s.grid().spacing_mm),
        StockSource::Lent(s) => (s.volume_mm3(), s.grid().spacing_mm),
        StockSource::Tiled(t) => (f64::NAN, t.grid.spacing_mm),
    };
    // The stock handed over with its closed form is the first pass's memory.
    let (initial, spare) = match stock {
        StockSource::Whole(s) => (Initial::Held(std::borrow::Cow::Owned(s)), None),
        StockSource::Lent(s) => (Initial::Held(std::borrow::Cow::Borrowed(s)), None),
        StockSource::Made(s, solid) => (Initial::Made(solid, *s.grid()), Some(s)),
        StockSource::Tiled(t) => (Initial::Tiled(t), None),
    };
    // The rigid tool's moves made as the sweep asks for them, not a list of
    // them beside the steps (56 B a step).
    let rigid_steps = dexel::StepFn::new(steps.len(), |i| steps[i].step);
    let (tool_of_step, options) = sweep_setup(tools, &steps)?;
    let started = Instant::now();
    let (rigid_stock, mut record) = sweep_pass(
        &initial,
        spare,
        tools,
        &tool_of_step,
        &rigid_steps,
        &options,
        label,
    )?;
    // At most two stocks at a time: the initial one (none where it is made
    // of its closed form) and the last pass's.
    let mut final_stock = rigid_stock;
    let n = steps.len();
    let of_step = StepTools {
        tools,
        tool_of_step: &tool_of_step,
    };
    // The rigid pass's loads, with the error map's model (what a run that
    // does not loop keeps); with the closed loop, from where the loads guess
    // that it will run, as its plan reads them (the peak only where it can
    // matter to the plan; no flanks: `None`).
    let (mut step_loads, mut flanks) = if tools.closed_loop {
        let limit_mpa = |i| {
            of_step
                .stress_limit_mpa(i)
                .min(of_step.rupture_strength_mpa(i))
        };
        let likely = |i, l: &cutting::StepLoad| {
            closed_loop::settle::loop_likely(&steps, of_step, &record, i, l, grid_mm)
        };
        Removals::new(of_step, &record, &steps, grid_mm).rigid_loads(limit_mpa, likely)
    } else {
        let (loads, flanks) = Removals::new(of_step, &record, &steps, grid_mm).loads_with_flanks();
        (loads, Some(flanks))
    };
    let (strengths_mpa, tool_names) = strengths_and_names(&steps, of_step);
    let LoopPlan {
        dirs,
        in_loop,
        inherited,
        mut rigid,
        rigid_peak_deflection_um,
        mut report,
        looping,
        sub_cells,
        advance_mm,
    } = LoopPlan::new(&steps, of_step, &step_loads, &record, grid_mm);
    // Each step's offset: its trial, once the loop tries one.
    let mut x: Vec<f64> = vec![0.0; n];
    // The loads of the steps the loop scales (below) and by how much, once
    // it ends: the passes keep no loads, the last one's are made again
    // once the searches are let go.
    let mut scaled: Option<Vec<(usize, f64)>> = None;
    if looping {
        // The rigid sweep's record and loads are read no more (the loop
        // makes its own): freed before the searches are made.
        drop(std::mem::take(&mut record));
        drop(std::mem::take(&mut step_loads));
        drop(flanks.take());
        let on = LoopInputs {
            steps: &steps,
            of_step,
            dirs: &dirs,
            in_loop: &in_loop,
            inherited: &inherited,
            sub_cells: &sub_cells,
            advance_mm: &advance_mm,
            grid_mm,
            initial: &initial,
            options: &options,
            label,
        };
        let found = close_loop(
            &on,
            &mut rigid,
            &mut x,
            &mut final_stock,
            &mut record,
            &mut report,
        )?;
        scaled = Some(found);
    }
    // What only the loop read, let go before the last pass's loads, the
    // offsets and the model's deflections are made (the offsets' trials once
    // they are; the sub-cell windows and advances, 20 MB of a million-step
    // run, were held beside the loads).
    drop((rigid, in_loop, inherited, sub_cells, advance_mm));
    // The last pass's loads, those at a jump of g scaled; the rigid pass's
    // with the error map's model where the closed loop settled or converged
    // on it (its plan's let go first where they have no flanks).
    let mut flanks = match (scaled, flanks) {
        (Some(scaled), _) => {
            let (loads, mut flanks) =
                Removals::new(of_step, &record, &steps, grid_mm).loads_with_flanks();
            step_loads = loads;
            for (i, s) in scaled {
                step_loads[i] = step_loads[i].scaled(s);
                flanks.scale(i, s);
            }
            flanks
        }
        (None, Some(flanks)) => flanks,
        (None, None) => {
            drop(std::mem::take(&mut step_loads));
            let (loads, flanks) =
                Removals::new(of_step, &record, &steps, grid_mm).loads_with_flanks();
            step_loads = loads;
            flanks
        }
    };
    let sweep_s = started.elapsed().as_secs_f64();
    // The final loads as reported (MODEL.md §4.4): where a step breaks its
    // tool, the deflections at rupture; the error map takes them below.
    for (i, l) in step_loads.iter_mut().enumerate() {
        let rupture_mpa = of_step.rupture_strength_mpa(i);
        flanks.scale(i, l.rupture_scale(rupture_mpa));
        *l = l.at_rupture(rupture_mpa);
    }
    let offsets_um = applied_offsets_um(&steps, &x, &dirs);
    drop(x);
    // The deflections across the path (MODEL.md §5).
    flanks.across(&dirs);
    let model_um = flanks;
    let (final_stock, error_map, final_volume_mm3) =
        final_error_map(&initial, final_stock, &offsets_um, &model_um, &steps)?;
    Ok(Run {
        steps,
        record,
        loads: step_loads,
        offsets_um,
        error_map,
        initial_volume_mm3,
        final_volume_mm3,
        model_um,
        error_range_um: std::sync::OnceLock::new(),
        stock: final_stock,
        sweep_s,
        closed_loop: report,
        rigid_peak_deflection_um,
        strengths_mpa,
        tool_names,
    })
}

/// Each tool's allowable stress and rupture strength, and each tool number
/// the steps carry as messages name it ([`Run::strengths_mpa`],
/// [`Run::tool_names`]).
fn strengths_and_names(
    steps: &[TimedStep],
    of_step: StepTools,
) -> (BTreeMap<u32, [f64; 2]>, BTreeMap<u32, String>) {
    let strengths_mpa: BTreeMap<u32, [f64; 2]> = steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            (
                s.tool,
                [of_step.stress_limit_mpa(i), of_step.rupture_strength_mpa(i)],
            )
        })
        .collect();
    let tool_names: BTreeMap<u32, String> = steps
        .iter()
        .map(|s| s.tool)
        .collect::<std::collections::BTreeSet<u32>>()
        .into_iter()
        .map(|t| (t, of_step.tools.name(t)))
        .collect();
    (strengths_mpa, tool_names)
}
