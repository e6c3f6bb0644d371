//! The commands behind the CLI. Each checks every input before work starts
//! and writes its outputs only at the end, each file atomically. None prints:
//! each returns its results as typed values, and what must be told before or
//! during the work (warnings) goes to the caller's `on_warning`; the `dexcut`
//! binary formats both.

pub mod calibrate;
pub mod sequence;

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::{fail, Error, Result};
use dexel::Stock;

use crate::model::summary::{GridInfo, Summary};
use crate::model::warnings::{self, LineTally, Warning, WarningKind};
use crate::motion::{self, TimedStep};
use crate::optimize::{self};
use crate::output::outdir::OutDir;
use crate::output::steps::StepsFormat;
use crate::run::{self, Run};

pub use crate::evaluate::evaluate;
pub use crate::input::example::write as example;
/// The summary.json schema types, at the paths they had here.
pub use crate::model::summary::{
    DesignInfo, DeviationKind, LimitsOut, LineDeviation, OptimizeSummary, SimulateSummary,
};
pub use crate::setup::{Setup, MAX_LINEARISED_SEGMENTS};
pub use calibrate::{calibrate, read_calibration, Calibration};

/// Write the steps (steps.csv and/or the steps' `.npy` arrays, as
/// `steps_format` says) and the per-column results of a run (the `.npy` grid,
/// and columns.csv when `columns_csv`); returns the design comparison.
fn write_run(
    setup: &Setup,
    run: &Run,
    out: &Path,
    steps_format: StepsFormat,
    columns_csv: bool,
) -> Result<Option<DesignInfo>> {
    let design = crate::design::design_comparison(setup, run)?;
    crate::output::run_files::write_run_files(
        run,
        design.as_ref(),
        out,
        steps_format,
        columns_csv,
    )?;
    Ok(design.map(|d| d.1))
}

/// A simulated program: the run, its headline numbers and the comparison with
/// the `[design]` model. Made by [`simulate_setup`].
pub struct Simulation {
    /// Steps, loads and final stock.
    pub run: Run,
    /// Headline numbers and warnings (summary.json's `run` part).
    pub summary: Summary,
    /// Signed distance of each column's top to the design model, µm
    /// (positive = stock left), and the per-line comparison.
    pub design: Option<(Vec<f32>, DesignInfo)>,
}

impl Simulation {
    /// Write the steps (steps.csv, or for [`StepsFormat::Npy`] steps.json
    /// and one `.npy` array per column; [`StepsFormat::Auto`] chooses by the
    /// number of steps) and the per-column results (the `.npy` grid with
    /// columns.json, and columns.csv when `columns_csv`) into `out`, an
    /// existing folder. Returns the steps' format written.
    pub fn write_files(
        &self,
        out: &Path,
        columns_csv: bool,
        steps_format: StepsFormat,
    ) -> Result<StepsFormat> {
        crate::output::run_files::write_run_files(
            &self.run,
            self.design.as_ref(),
            out,
            steps_format,
            columns_csv,
        )
    }

    /// The per-column results whole: the values of the column grid
    /// [`Simulation::write_files`] writes, bit for bit, with the design
    /// comparison's `design_um` and `line` where the job has a `[design]`.
    pub fn column_grid(&self) -> crate::run::ColumnGrid {
        let mut grid = self.run.column_grid();
        if let Some((diff, _)) = &self.design {
            grid.design_um = Some(diff.clone());
            grid.line = Some(crate::output::run_files::last_cut_lines(&self.run));
        }
        grid
    }
}

/// Sweep the job's program through its stock (the commanded path, or with
/// `actual_path` the drive model's estimate of it): removal, loads, the closed
/// loop, warnings and the design comparison. Writes nothing.
pub fn simulate_setup(setup: &Setup, actual_path: bool) -> Result<Simulation> {
    setup.require_whole_stock("the simulation API (it keeps every column in memory; `dexcut simulate` writes a tiled stock's grid band by band)")?;
    let steps = setup.steps(actual_path)?;
    simulate_steps(setup, setup.stock.clone(), steps)
}

/// [`simulate_setup`] of the program's timed steps through `stock` (the
/// job's stock, or a copy of it). A box or a cylinder is made again from its
/// closed form for each pass, in the memory of the stock handed over, so the
/// run holds one stock; a mesh stock is copied for each pass.
fn simulate_steps(setup: &Setup, stock: Stock, steps: Vec<TimedStep>) -> Result<Simulation> {
    let (run, design) = run_steps(setup, stock, steps)?;
    Simulation::of(setup, run, design)
}

/// The run of [`simulate_steps`] and its design comparison, without the
/// summary.
fn run_steps(
    setup: &Setup,
    stock: Stock,
    steps: Vec<TimedStep>,
) -> Result<(Run, Option<crate::design::Comparison>)> {
    let stock = match setup.solid() {
        Some(solid) => run::StockSource::Made(stock, solid),
        None => run::StockSource::Whole(stock),
    };
    let run = run::run_on(stock, &setup.tools, steps, "simulate")?;
    let design = crate::design::design_comparison(setup, &run)?;
    Ok((run, design))
}

impl Simulation {
    /// The simulation of `run` (with its design comparison `design`): its
    /// summary, with the set-up's warnings first.
    fn of(
        setup: &Setup,
        run: Run,
        design: Option<crate::design::Comparison>,
    ) -> Result<Simulation> {
        let mut summary = run.summary();
        summary.check_finite()?;
        summary
            .warnings
            .0
            .splice(0..0, setup.warnings.iter().cloned());
        Ok(Simulation {
            run,
            summary,
            design,
        })
    }
}

/// Told at once, before or during a command's work: a warning the caller
/// shows without waiting for the results (the `dexcut` binary prints
/// `warning: …` on stderr).
pub type OnWarning<'a> = &'a dyn Fn(&dyn std::fmt::Display);

/// The set-up warnings of a job, told at once before the work.
fn announce_setup_warnings(setup: &Setup, on_warning: OnWarning) {
    for w in &setup.warnings {
        on_warning(w);
    }
}

/// A stock too large for memory (ARCHITECTURE.md "Large stocks"): the program
/// is swept band by band (the closed loop's passes too), then the bands are
/// made and swept once more to write steps.csv and the `.npy` grid row block
/// by row block. The design comparison and columns.csv need every column at
/// once and are refused.
fn simulate_tiled(
    setup: &Setup,
    tiling: &crate::input::stock::Tiling,
    actual_path: bool,
    columns_csv: bool,
    steps_format: StepsFormat,
    out: &Path,
) -> Result<(Simulation, StepsFormat)> {
    refuse_whole_stock_outputs(setup, tiling, columns_csv)?;
    let steps = setup.steps(actual_path)?;
    let mut run = run::run_on(
        run::StockSource::Tiled(tiling),
        &setup.tools,
        steps,
        "simulate",
    )?;
    let steps_format = run.write_steps(out, "steps", steps_format)?;
    run::write_tiled_columns(&mut run, tiling, &setup.tools, Some(out))?;
    let mut summary = run.summary();
    summary.check_finite()?;
    summary
        .warnings
        .0
        .splice(0..0, setup.warnings.iter().cloned());
    Ok((
        Simulation {
            run,
            summary,
            design: None,
        },
        steps_format,
    ))
}

/// What a run on a stock too large for memory cannot give (the design
/// comparison and columns.csv need every column at once): refused before the
/// run.
fn refuse_whole_stock_outputs(
    setup: &Setup,
    tiling: &crate::input::stock::Tiling,
    columns_csv: bool,
) -> Result<()> {
    if setup.design.is_some() {
        fail!(limits, "{}: [design] with a stock too large for the memory budget ({} rows in bands of {}): the design comparison needs every column at once; use a coarser grid or a larger --memory-budget-mb", setup.job.name, tiling.grid.ny, tiling.band_rows);
    }
    if columns_csv {
        fail!(limits, "{}: --columns-csv with a stock too large for the memory budget ({} rows in bands of {}): the .npy grid is written band by band, columns.csv is not", setup.job.name, tiling.grid.ny, tiling.band_rows);
    }
    Ok(())
}

/// How a stock too large for the memory budget was swept: band by band.
#[derive(Clone, Debug)]
pub struct Banded {
    /// Columns along X.
    pub nx: usize,
    /// Rows along Y.
    pub ny: usize,
    /// The memory budget, MB.
    pub budget_mb: f64,
    /// Bands swept.
    pub bands: usize,
    /// Rows per band.
    pub band_rows: usize,
}

impl Banded {
    /// How `tiling` sweeps its stock.
    pub fn of(tiling: &crate::input::stock::Tiling) -> Banded {
        Banded {
            nx: tiling.grid.nx,
            ny: tiling.grid.ny,
            budget_mb: tiling.budget_bytes / 1e6,
            bands: tiling.bands().count(),
            band_rows: tiling.band_rows,
        }
    }
}

/// What `dexcut simulate` made.
#[derive(Clone, Debug)]
pub struct Simulated {
    /// The document written as summary.json.
    pub summary: SimulateSummary,
    /// Set when the stock was swept band by band.
    pub banded: Option<Banded>,
    /// How the steps were written ([`StepsFormat::Auto`] resolved).
    pub steps_format: StepsFormat,
}

/// What the user asked of a `simulate` or `optimize` run.
#[derive(Clone, Copy)]
pub struct RunOptions<'a> {
    /// `--grid`: the stock's column spacing over the job's, mm.
    pub grid_mm: Option<f64>,
    /// `--force`: use an output folder that holds the run's inputs.
    pub force: bool,
    /// `--columns-csv`: also write columns.csv.
    pub columns_csv: bool,
    /// `--steps-format`.
    pub steps_format: StepsFormat,
    /// `--memory-budget-mb`: memory for the stock, MB.
    pub memory_budget_mb: Option<f64>,
    /// `--save-stock`: write the stock the run leaves into `OUT/stock/`
    /// ([`crate::saved_stock`]).
    pub save_stock: bool,
    /// Told at once: the warnings before and during the work.
    pub on_warning: OnWarning<'a>,
}

/// What a run of a job made: one program's results, or for a job of
/// `[[operations]]` each operation's and the whole job's.
#[allow(clippy::large_enum_variant)] // one per command run, moved once
pub enum Ran<T> {
    /// A job of one program.
    Program(T),
    /// A job of operations.
    Operations(crate::commands::sequence::Sequence<T>),
}

/// The stock the run leaves saved into `staged/stock` (`--save-stock`).
pub(crate) fn save_stock(
    staged: &Path,
    stock: &Stock,
) -> Result<crate::saved_stock::SavedStockDoc> {
    crate::saved_stock::write(&staged.join("stock"), stock)
}

/// Refuse `--save-stock` for a stock swept band by band, before the work.
fn refuse_tiled_save(setup: &Setup, save: bool) -> Result<()> {
    if let (true, Some(t)) = (save, &setup.tiling) {
        fail!(request, "{}: --save-stock needs every column of the stock at once; this stock ({}×{} columns) is swept band by band to fit the memory budget: use a coarser grid or a larger --memory-budget-mb", setup.job.name, t.grid.nx, t.grid.ny);
    }
    Ok(())
}

/// `dexcut simulate JOB --out DIR`.
///
/// Memory: on a stock that fits, what the sweep does not need is let go
/// before it ([`simulate_whole`]).
pub fn simulate(
    job: JobArg,
    out: &Path,
    actual_path: bool,
    opts: &RunOptions,
) -> Result<Ran<Simulated>> {
    if let Some(doc) = crate::commands::sequence::operations_of(job, opts)? {
        return Ok(Ran::Operations(crate::commands::sequence::simulate(
            doc,
            out,
            actual_path,
            opts,
        )?));
    }
    let started = Instant::now();
    let (mut setup, out_dir) = begin_run(job, out, opts.force, &[], |p| {
        Setup::load_within(p, opts.grid_mm, None, opts.memory_budget_mb)
    })?;
    refuse_tiled_save(&setup, opts.save_stock)?;
    announce_setup_warnings(&setup, opts.on_warning);
    // Before the path is lent to the planner and let go.
    let exact_stop_time_s = exact_stop_time_s(&setup);
    let (sim, steps_format) = match &setup.tiling {
        None => simulate_whole(
            &mut setup,
            actual_path,
            out_dir.path(),
            opts.columns_csv,
            opts.steps_format,
        )?,
        Some(tiling) => simulate_tiled(
            &setup,
            tiling,
            actual_path,
            opts.columns_csv,
            opts.steps_format,
            out_dir.path(),
        )?,
    };
    let mut doc = simulate_summary(&setup, &sim, exact_stop_time_s, out_dir.run_id());
    if opts.save_stock {
        doc.saved_stock = Some(save_stock(out_dir.path(), &sim.run.stock)?);
    }
    doc.run_time_s = started.elapsed().as_secs_f64();
    crate::model::summary::write_simulate(&out_dir.path().join("summary.json"), &doc)?;
    out_dir.commit("simulate")?;
    Ok(Ran::Program(Simulated {
        summary: doc,
        banded: setup.tiling.as_ref().map(Banded::of),
        steps_format,
    }))
}

/// summary.json of a simulation of `setup` (its `run_time_s` 0, set by the caller).
pub(crate) fn simulate_summary(
    setup: &Setup,
    sim: &Simulation,
    exact_stop_time_s: Option<f64>,
    run_id: String,
) -> SimulateSummary {
    SimulateSummary {
        run: sim.summary.clone(),
        job: setup.job.name.clone(),
        program: setup.program.file.clone(),
        exact_stop_time_s,
        grid: GridInfo::of(sim.run.stock.grid()),
        design: sim.design.as_ref().map(|d| d.1.clone()),
        setup: Some(setup.info()),
        saved_stock: None,
        run_time_s: 0.0,
        run_id,
    }
}

/// Simulate a stock that fits in memory and write its files into `out`.
///
/// Memory: what the sweep does not need is let go before it, in this
/// order: the job's stock is taken out of the setup ([`Setup::take_stock`])
/// and, for a box or a cylinder, dropped (made again of its closed form
/// after the planning); the program's path is lent to the planner
/// ([`Setup::steps_lending_path`]); then the path and a G-code program's
/// text are emptied (the steps carry what the run needs of them).
pub(crate) fn simulate_whole(
    setup: &mut Setup,
    actual_path: bool,
    out: &Path,
    columns_csv: bool,
    steps_format: StepsFormat,
) -> Result<(Simulation, StepsFormat)> {
    // The run sweeps the job's stock itself, not a copy (one stock
    // fewer held). A box or a cylinder is let go while the program is
    // planned and made again of its closed form after, the same
    // columns bit for bit (`stock::build`): planning and the stock
    // were the peak of the raster at 0.05.
    let solid = setup.solid();
    let held = setup.take_stock()?;
    let held = match solid {
        Some(_) => {
            drop(held);
            None
        }
        None => Some(held),
    };
    // The planner borrows the path instead of a copy (the peak of a long program).
    let steps = setup.steps_lending_path(actual_path)?;
    // The steps carry what the run needs of the program (lines, tools, spindle
    // speeds); nothing after this reads the path: freed before the sweep.
    setup.program.path = nc::Path::default();
    // Nor its text (a G-code program stays marked as one).
    if let Some(text) = setup.program.gcode.as_mut() {
        *text = String::new();
    }
    let stock = match held {
        Some(stock) => stock,
        None => crate::input::stock::build(&setup.job)?,
    };
    let (run, design) = run_steps(setup, stock, steps)?;
    let written = crate::output::run_files::write_run_files(
        &run,
        design.as_ref(),
        out,
        steps_format,
        columns_csv,
    )?;
    // The summary after the columns: a map made as it is written gives its
    // range on the way (`Run::error_range_um`), not in a pass of its own.
    Ok((Simulation::of(setup, run, design)?, written))
}

/// The job a run reads: a job file, the built-in example, or a job fitted to
/// a program ([`crate::input::fitted_job`]).
#[derive(Clone, Copy)]
pub enum JobArg<'a> {
    /// A job file (TOML).
    File(&'a Path),
    /// The built-in boss_contour example.
    Example,
    /// A job fitted to a G-code program.
    Fitted(&'a crate::input::fitted_job::FittedJob),
}

/// Load the job and begin the output folder. A job file is read where it is;
/// the example's files and a fitted job are written into the results'
/// `input/` folder (staged with the results) and read from there, and the
/// setup names them where they will be once the results are in place.
/// `extra_inputs`: files the run reads beside the job's.
fn begin_run(
    job: JobArg,
    out: &Path,
    force: bool,
    extra_inputs: &[PathBuf],
    load: impl Fn(&Path) -> Result<Setup>,
) -> Result<(Setup, OutDir)> {
    let written = match job {
        JobArg::File(p) => {
            let setup = load(p)?;
            let mut inputs = setup.input_files(p);
            inputs.extend_from_slice(extra_inputs);
            let out_dir = OutDir::begin(out, &inputs, force)?;
            check_output_disk(&setup, &out_dir)?;
            return Ok((setup, out_dir));
        }
        JobArg::Example => None,
        JobArg::Fitted(f) => Some(f),
    };
    let mut inputs = extra_inputs.to_vec();
    inputs.extend(written.map(|f| f.program.clone()));
    let out_dir = OutDir::begin(out, &inputs, force)?;
    let dir = out.join("input");
    let staged = out_dir.path().join("input");
    let job_file = match written {
        None => crate::input::example::write_files(&staged)?,
        Some(f) => {
            std::fs::create_dir_all(&staged).map_err(|e| Error::io("cannot create", &staged, e))?;
            let path = staged.join("job.toml");
            export::atomic::write_bytes(&path, f.toml.as_bytes())
                .map_err(|e| Error::io("cannot write", &path, e))?;
            path
        }
    };
    let mut setup = load(&job_file)?;
    setup.job.name = dir.join("job.toml").display().to_string();
    setup.program.file = setup
        .program
        .file
        .replace(&staged.display().to_string(), &dir.display().to_string());
    check_output_disk(&setup, &out_dir)?;
    Ok((setup, out_dir))
}

/// Refuse a run whose column grid alone would not fit the disk of its
/// results folder (a 1 m × 1 m stock at 0.02 mm writes 30 GB of `.npy`
/// arrays), before the work.
fn check_output_disk(setup: &Setup, out_dir: &OutDir) -> Result<()> {
    check_output_disk_for(setup, out_dir, 1)
}

/// [`check_output_disk`] for `runs` column grids of the stock (a job of
/// operations writes one an operation).
pub(crate) fn check_output_disk_for(setup: &Setup, out_dir: &OutDir, runs: usize) -> Result<()> {
    let grid = match &setup.tiling {
        Some(t) => t.grid,
        None => *setup.stock.grid(),
    };
    let bytes =
        runs as f64 * grid.nx as f64 * grid.ny as f64 * run::run_grid_bytes_per_column() as f64;
    crate::bounds::check_disk(
        out_dir.path(),
        out_dir.target(),
        bytes,
        &format!(
            "{}: the column grid ({}×{} columns at grid {} mm)",
            setup.job.name, grid.nx, grid.ny, grid.spacing_mm
        ),
    )
}

/// `dexcut optimize [JOB] --out DIR` (`settings`: `--settings`).
/// With no job, the built-in boss_contour example, its inputs written into the
/// results' `input/` folder.
pub fn optimize(
    job: JobArg,
    out: &Path,
    settings: Option<&Path>,
    opts: &RunOptions,
) -> Result<Ran<Optimized>> {
    if let Some(doc) = crate::commands::sequence::operations_of(job, opts)? {
        if settings.is_some() {
            fail!(request, "--settings is for a job of one program: give each operation's [machine] keys in its [[operations]] entry");
        }
        return Ok(Ran::Operations(crate::commands::sequence::optimize(
            doc, out, opts,
        )?));
    }
    let started = Instant::now();
    let settings_input: Vec<PathBuf> = settings.map(Path::to_path_buf).into_iter().collect();
    let (mut setup, out_dir) = begin_run(job, out, opts.force, &settings_input, |p| {
        Setup::load_within(p, opts.grid_mm, settings, opts.memory_budget_mb)
    })?;
    refuse_tiled_save(&setup, opts.save_stock)?;
    check_optimizable(&setup, opts.on_warning)?;
    announce_setup_warnings(&setup, opts.on_warning);
    // The setup is dropped after: its path is not read again.
    optimize_committed(
        &mut setup,
        out_dir,
        started,
        opts.columns_csv,
        opts.steps_format,
        opts.save_stock,
        PathAfter::Dropped,
        opts.on_warning,
    )
    .map(Ran::Program)
}

/// What becomes of the setup's program path, lent to the re-timing, when
/// [`optimize_in`] returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PathAfter {
    /// Back in the setup: read again from its text where it was handed
    /// to the re-feed ([`optimize::FreeStations::Given`]).
    Back,
    /// Not read again where it was handed over (the setup's path left
    /// empty): for a caller that drops the setup next (a million-block
    /// program's reading, about 0.8 s on one thread, saved).
    Dropped,
}

/// [`optimize_in`] into `out_dir`, the stock saved where asked
/// (`stock_asked`), summary.json written and the folder committed.
#[allow(clippy::too_many_arguments)]
fn optimize_committed(
    setup: &mut Setup,
    out_dir: OutDir,
    started: Instant,
    columns_csv: bool,
    steps_format: StepsFormat,
    stock_asked: bool,
    path_after: PathAfter,
    on_warning: OnWarning,
) -> Result<Optimized> {
    let (mut optimized, stock) = optimize_in(
        setup,
        out_dir.path(),
        out_dir.run_id(),
        columns_csv,
        steps_format,
        path_after,
        on_warning,
    )?;
    if stock_asked {
        optimized.summary.saved_stock = Some(save_stock(out_dir.path(), &stock)?);
    }
    drop(stock);
    optimized.summary.run_time_s = started.elapsed().as_secs_f64();
    crate::model::summary::write_optimize(
        &out_dir.path().join("summary.json"),
        &optimized.summary,
    )?;
    out_dir.commit("optimize")?;
    Ok(optimized)
}

/// What optimize refuses of a set-up, and the warning of limits that cap nothing.
pub(crate) fn check_optimizable(setup: &Setup, on_warning: OnWarning) -> Result<()> {
    if setup.job.machine.arcs_as_lines {
        fail!(request, "{}: machine.arcs_as_lines is for simulate and evaluate: optimize re-feeds the program's own blocks and writes arcs as G2/G3", setup.job.name);
    }
    let limits = &setup.job.limits;
    if limits.mrr_max.is_none()
        && limits.force_max.is_none()
        && limits.deflection_max_um.is_none()
        && limits.power_max_kw.is_none()
        && !limits.angle_rule
    {
        on_warning(&if limits.stress {
            "[limits] sets no mrr_max, force_max, deflection_max_um, power_max_kw or angle_rule: cutting runs at feed_max where the tool's stress_limit_mpa allows"
        } else {
            "[limits] sets no mrr_max, force_max, deflection_max_um, power_max_kw or angle_rule, and stress = false: cutting runs at feed_max"
        });
    }
    Ok(())
}

/// What [`optimize_setup`] made: summary.json's document, and the drive
/// pre-compensation when the job has `[servo]`.
pub struct Optimized {
    /// The document written as summary.json (before, after = optimized.nc
    /// read back and simulated, limits, caps, timings).
    pub summary: OptimizeSummary,
    /// Drive error before and after pre-compensation (servo_compensated.csv).
    pub precomp: Option<servo::Precomp>,
    /// How steps and steps_before were written ([`StepsFormat::Auto`]
    /// resolved by the longer of the two).
    pub steps_format: StepsFormat,
    /// Set when the stock was swept band by band.
    pub banded: Option<Banded>,
}

/// Re-time the job's program under its `[limits]` and write the results
/// (optimized.nc, servo.csv, the steps after and before as `steps_format`
/// says: steps.csv and steps_before.csv, or steps.json and steps_before.json
/// with their `.npy` arrays; summary.json, the `.npy` column grid and with
/// `columns_csv` columns.csv) into `out_dir`, committed whole at the end.
/// `started` is when the run began (for `run_time_s`). The setup's path is
/// lent to the free stations through the rounds and is back when this
/// returns, with an error too.
///
/// Memory, in this order: the program as given is swept with its path lent
/// to the planner ([`Setup::steps_lending_path`]); its run is written out
/// (steps_before) and dropped before the rounds where the steps' format is
/// known without the written program's step count, else only its stock is
/// let go; the setup's path is then taken (`std::mem::take`) into the free
/// stations ([`optimize::FreeStations`]) for the rounds and the outputs, and
/// put back (read again from its text where it was handed over) at the end.
pub fn optimize_setup(
    setup: &mut Setup,
    out_dir: OutDir,
    started: Instant,
    columns_csv: bool,
    steps_format: StepsFormat,
    on_warning: OnWarning,
) -> Result<Optimized> {
    optimize_committed(
        setup,
        out_dir,
        started,
        columns_csv,
        steps_format,
        false,
        PathAfter::Back,
        on_warning,
    )
}

/// [`optimize_setup`] into the folder `staged` (written, not committed; its
/// summary.json not written: the document is returned with `run_time_s` 0),
/// returning the stock the written program leaves; the setup's path as
/// `path_after` says.
pub(crate) fn optimize_in(
    setup: &mut Setup,
    staged: &Path,
    run_id: String,
    columns_csv: bool,
    steps_format: StepsFormat,
    path_after: PathAfter,
    on_warning: OnWarning,
) -> Result<(Optimized, Stock)> {
    if let Some(tiling) = &setup.tiling {
        // A stock too large for memory is swept band by band in every run
        // (ARCHITECTURE.md "Large stocks").
        refuse_whole_stock_outputs(setup, tiling, columns_csv)?;
    }
    // Before: the program as written. Its path is lent to the planner's
    // stations, not copied into them (126 MB for a million blocks beside the
    // plan).
    let t0 = Instant::now();
    let before_steps = setup.steps_lending_path(false)?;
    let mut before = run::run_on(setup.stock_source(), &setup.tools, before_steps, "before")?;
    if let Some(tiling) = &setup.tiling {
        // Its volumes and error range, band by band (nothing written).
        run::write_tiled_columns(&mut before, tiling, &setup.tools, None)?;
    }
    crate::util::heap_mark(format_args!("the program read, the program as given swept"));
    let limits = &setup.job.limits;
    let before_summary = before.summary();
    // Every tool's chip-load cap against what the program feeds it, told before the rounds.
    let chip_load = optimize::chip_loads(
        &before,
        &setup.tools,
        &setup.program,
        &setup.job.cutting.material,
    );
    let chip_warnings = optimize::chip_load_check(&chip_load, &setup.tools);
    for w in &chip_warnings {
        on_warning(w);
    }
    let given = optimize::Given::of(&before, limits, &setup.tools);
    let stress_limit_mpa = limits.stress.then(|| before.stress_limit_mpa());
    // The program as given is written out now (steps_before) where the
    // format is known without the written program's step count (one format
    // for both, Auto by the longer): then its run is not held through the
    // rounds. Otherwise (Auto, at most AUTO_NPY_STEPS steps) it keeps its
    // steps and loads until the end; its stock is not needed again (if the
    // original is kept, it is simulated again).
    let before_steps = before.steps.len();
    let before_format = steps_format.resolve(before_steps);
    let before = if steps_format != StepsFormat::Auto || before_format == StepsFormat::Npy {
        before.write_steps(staged, "steps_before", before_format)?;
        // Dropped here: a binding only shadowed would hold the run (its
        // steps, loads, record and stock) to the end of the rounds.
        drop(before);
        None
    } else {
        let mut before = before;
        let spacing = setup.stock.grid().spacing_mm;
        before.stock = dexel::Stock::new_box([0.0; 3], [spacing; 3], spacing)?;
        Some(before)
    };
    crate::util::heap_mark(format_args!("steps_before written"));
    let time_simulate_s = t0.elapsed().as_secs_f64();
    // Engagement along fine stations, caps, re-timing.
    let t1 = Instant::now();
    let machine = optimize::optimising_machine(&setup.machine, limits);
    // The free stations hold the program's path, taken from the setup (not
    // copied: 120 MB for a million blocks) and put back once the outputs are
    // written, whether the rounds and the outputs succeed or not; nothing
    // reads the setup's path in between. A G-code program's is handed to the
    // re-feed and read again from its text where it is needed
    // ([`optimize::FreeStations::Given`]): not held beside the written
    // program's run, nor while its outputs are written.
    let exact_stop_time_s = exact_stop_time_s(setup);
    let path = std::mem::take(&mut setup.program.path);
    let (rounds, free) = match optimize::free_stations_of(path, &machine) {
        Err(failed) => {
            let (e, path) = *failed;
            (Err(e), optimize::FreeStations::Released(path))
        }
        Ok(stations) => {
            let mut free = optimize::FreeStations::Made(Box::new(stations));
            let rounds = optimize::caps_and_rounds(setup, &machine, &mut free, given, t1, staged);
            (rounds, free)
        }
    };
    let as_given = AsGiven {
        summary: before_summary,
        run: before,
        steps: before_steps,
        chip_load,
        chip_warnings,
        stress_limit_mpa,
        time_simulate_s,
        exact_stop_time_s,
    };
    let asked = OutputsAsked {
        run_id,
        columns_csv,
        steps_format,
    };
    let optimized = rounds
        .and_then(|rounds| optimize_outputs(setup, staged, &machine, as_given, rounds, asked));
    // Back in the setup (read again from its text where it was given and
    // the caller keeps it).
    let back = match (free, path_after) {
        (optimize::FreeStations::Given, PathAfter::Dropped) => Ok(nc::Path::default()),
        (free, _) => free.into_path(setup),
    };
    setup.program.path = match (back, &optimized) {
        (Ok(path), _) => path,
        (Err(e), Ok(_)) => return Err(e),
        (Err(_), Err(_)) => nc::Path::default(),
    };
    crate::util::heap_mark(format_args!("summary written, the path back"));
    optimized
}

/// What [`optimize_setup`] keeps of the program as given for the outputs.
struct AsGiven {
    summary: Summary,
    /// Its run, where steps_before is written with the written program's
    /// (its format chosen by the longer of the two); its stock let go.
    run: Option<run::Run>,
    /// Its number of steps.
    steps: usize,
    chip_load: Vec<optimize::ToolChipLoad>,
    chip_warnings: Vec<Warning>,
    stress_limit_mpa: Option<f64>,
    time_simulate_s: f64,
    /// Its time in exact stop ([`exact_stop_time_s`]).
    exact_stop_time_s: Option<f64>,
}

/// The setup's program run in exact stop on its machine (MODEL.md §6.1, "Exact stop"):
/// each segment from rest to rest at its programmed feed; `None` for an empty path.
pub(crate) fn exact_stop_time_s(setup: &Setup) -> Option<f64> {
    let path = &setup.program.path;
    (!path.segments.is_empty()).then(|| {
        schedule::exact_stop_time_s(path, &setup.machine, schedule::FeedPolicy::Programmed)
    })
}

/// What the user asked of [`optimize_setup`]'s outputs, and the run's id.
struct OutputsAsked {
    run_id: String,
    columns_csv: bool,
    steps_format: StepsFormat,
}

/// [`optimize_setup`]'s outputs after its rounds, into `out_dir`'s staging
/// folder (committed by the caller): the written program's run (the program
/// as given where it is kept) summed and written (steps, the column grid,
/// servo.csv, servo_compensated.csv), with the program as given, and
/// summary.json.
fn optimize_outputs(
    setup: &Setup,
    staged: &Path,
    machine: &schedule::Machine,
    as_given: AsGiven,
    rounds: optimize::Rounds,
    asked: OutputsAsked,
) -> Result<(Optimized, Stock)> {
    let limits = &setup.job.limits;
    let optimize::Rounds {
        stations: n_stations,
        time_engagement_s,
        written,
        plan_started: t2,
    } = rounds;
    let OutputsAsked {
        run_id,
        columns_csv,
        steps_format,
    } = asked;
    let fz_max_mm = setup.job.fz_max_mm();
    let time_plan_s = t2.elapsed().as_secs_f64();
    let mut after_run = written.run;
    if let Some(tiling) = &setup.tiling {
        // The `.npy` grid written band by band, which sets the volumes.
        run::write_tiled_columns(&mut after_run, tiling, &setup.tools, Some(staged))?;
    }
    let after = &after_run;
    // One format for both (Auto: by the longer), so the folder reads alike.
    let steps_format = steps_format.resolve(after.steps.len().max(as_given.steps));
    let design = match setup.tiling {
        None => write_run(setup, after, staged, steps_format, columns_csv)?,
        Some(_) => {
            after.write_steps(staged, "steps", steps_format)?;
            None
        }
    };
    // The summary after the columns: a map made as it is written gives its
    // range on the way (`Run::error_range_um`), not in a pass of its own.
    let mut after_summary = after.summary();
    as_given.summary.check_finite()?;
    after_summary.check_finite()?;
    if written.excesses_left > 0 {
        after_summary.warnings.push(Warning {
        kind: WarningKind::LimitExceeded,
        line: None,
        value: written.excesses_left as f64,
        unit: "periods".into(),
        steps: written.excesses_left,
        lines: Vec::new(),
        message: format!(
            "{} servo periods of optimized.nc are still more than 2 % above a limit after {} rounds (held up by feed_min, or the grid too coarse to measure the removal per period)",
            written.excesses_left, written.rounds
        ),
    });
    }
    after_summary.warnings.0.splice(
        0..0,
        setup.warnings.iter().cloned().chain(as_given.chip_warnings),
    );
    optimize::stress_left(after, limits, written.rounds, &mut after_summary.warnings);
    let (mut unresolved, mut held) = (LineTally::new(), LineTally::new());
    for e in &written.unresolved {
        let tally = if e.held { &mut held } else { &mut unresolved };
        warnings::tally(tally, e.line, 100.0 * e.over_limit);
    }
    after_summary.warnings.from_lines(
        WarningKind::LimitExceeded,
        &held,
        "%",
        false,
        |v, lines| format!("servo periods up to {v:.0} % above a limit at {lines}, where a tapping cycle (G84/G74) runs: its feed is the tap's pitch times the spindle speed, held as programmed (LinuxCNC runs it with the feed override off), so optimize does not slow it; to lower the load there, lower the spindle speed and F together"),
    );
    after_summary.warnings.from_lines(
    WarningKind::CoarseGrid,
    &unresolved,
    "%",
    false,
    |v, lines| format!("servo periods up to {v:.0} % above a limit at {lines} after {rounds} rounds of slowing them, where the tool advances less than one grid column per period: part of the removal there comes in whole columns (where the tool enters the stock or turns), which a slower feed does not lower in proportion; use a finer grid to hold the limit per period", rounds = written.rounds),
);
    let written_vs_plan = after_summary.cycle_time_s / written.plan_time_s - 1.0;
    if written_vs_plan > optimize::PLAN_TOLERANCE && !written.kept_original {
        after_summary.warnings.push(Warning {
        kind: WarningKind::PlanNotMet,
        line: None,
        value: 100.0 * written_vs_plan,
        unit: "%".into(),
        steps: 0,
        lines: Vec::new(),
        message: format!(
            "optimized.nc takes {:.1} % longer than the plan it was written from: a line that makes several moves per run (a drilling cycle run more than once) or a line the table of runs could not take (the program uses parameters 1000–4999, or a subroutine's calls need more records than fit) takes one feed, the lowest its moves need",
            100.0 * written_vs_plan
        ),
    });
    }
    if let Some(before) = as_given.run {
        before.write_steps(staged, "steps_before", steps_format)?;
    }
    // Files for the machine are in its own Z, as optimized.nc is.
    let z_sign = if setup.program.z_down { -1.0 } else { 1.0 };
    crate::output::servo_csv::write_servo_csv(
        &staged.join("servo.csv"),
        written.samples.rows(&after.steps),
        &after.steps,
        z_sign,
    )?;
    let precomp = if setup.job.servo_given {
        Some(crate::evaluate::write_compensated_servo(
            &setup.job,
            written
                .samples
                .rows(&after.steps)
                .map(|r| r.pos.coords.into())
                .collect(),
            setup.machine.period_ms,
            z_sign,
            &staged.join("servo_compensated.csv"),
        )?)
    } else {
        None
    };
    crate::util::heap_mark(format_args!("steps, columns and servo.csv written"));
    let lower_bound_time_s = written.lower_bound_time_s;
    let doc = OptimizeSummary {
        job: setup.job.name.clone(),
        program: setup.program.file.clone(),
        grid: GridInfo::of(after.stock.grid()),
        peak_mrr_ratio: limits.mrr_max.map(|q| after_summary.peak_mrr_mm3_s / q),
        optimality_gap: (after_summary.cycle_time_s - lower_bound_time_s) / lower_bound_time_s,
        plan_time_s: written.plan_time_s,
        time_optimal_s: written.time_optimal_s,
        written_vs_plan,
        rounds: written.rounds,
        merge_ratio: written.merge_ratio,
        kept_original: written.kept_original,
        fz_max_mm,
        before: as_given.summary,
        after: after_summary,
        limits: LimitsOut {
            mrr_max_mm3_s: limits.mrr_max,
            force_max_n: limits.force_max,
            deflection_max_um: limits.deflection_max_um,
            power_max_kw: limits.power_max_kw,
            feed_min_mm_min: limits.feed_min,
            feed_max_mm_min: machine.feed_max_mm_min,
            chip_load_feed_mm_min: fz_max_mm.map(|fz| {
                cutting::chipload::chip_load_feed_mm_min(
                    fz,
                    setup.model.flutes,
                    setup.model.spindle_rpm,
                )
            }),
            feed_scale_max: limits.feed_scale_max,
            chip_load: as_given.chip_load,
            stress_limit_mpa: as_given.stress_limit_mpa,
        },
        cap_time_share: written.cap_shares,
        lower_bound_time_s,
        exact_stop_time_s: as_given.exact_stop_time_s,
        stations: n_stations,
        station_spacing_mm: motion::STATION_DS_MM,
        design,
        setup: Some(setup.info()),
        saved_stock: None,
        run_time_s: 0.0,
        time_engagement_s,
        time_plan_s,
        time_simulate_s: as_given.time_simulate_s,
        run_id,
    };
    Ok((
        Optimized {
            summary: doc,
            precomp,
            steps_format,
            banded: setup.tiling.as_ref().map(Banded::of),
        },
        after_run.stock,
    ))
}

/// `dexcut report DIR`.
pub fn report(dir: &Path) -> Result<crate::report::ReportFiles> {
    crate::report::write_report(dir)
}
