//! A job of `[[operations]]` run in order on one stock (ARCHITECTURE.md,
//! "Operations"): each operation is a run of its own job
//! ([`crate::input::job::Job::operation_jobs`]) on the stock the operations
//! before it left, its cuts forgotten ([`Setup::of_job`]). Each writes a
//! results folder of its own (`op1_roughing/`, as `simulate` or `optimize`
//! writes one) inside the job's, beside the whole job's summary.json
//! ([`OperationsSummary`]) and, with `--save-stock`, the final stock
//! (`stock/`). `optimize` re-times each operation on the stock the written
//! programs before it leave.

use std::path::{Path, PathBuf};
use std::time::Instant;

use dexel::Stock;

use super::{
    exact_stop_time_s, optimize_in, simulate_summary, simulate_whole, JobArg, Optimized,
    RunOptions, Simulated,
};
use crate::error::{fail, Error, Result};
use crate::input::job::{Job, Operation};
use crate::model::summary::{GridInfo, OperationLine, OperationsSummary, Summary};
use crate::output::outdir::OutDir;
use crate::setup::Setup;

/// What a job of operations made: each operation's results (by its folder)
/// and the whole job's summary.json document.
pub struct Sequence<T> {
    /// Each operation's results folder (relative to the job's) and what its run made.
    pub operations: Vec<(String, T)>,
    /// The document written as the job's summary.json.
    pub summary: OperationsSummary,
}

/// The job of `job` when it is one of operations (its `--grid` applied);
/// `None` for a job of one program, the example and a fitted job.
pub(crate) fn operations_of(job: JobArg, opts: &RunOptions) -> Result<Option<(Job, PathBuf)>> {
    let JobArg::File(path) = job else {
        return Ok(None);
    };
    let mut doc = Job::load(path)?;
    if doc.operations.is_empty() {
        return Ok(None);
    }
    if let Some(g) = opts.grid_mm {
        doc.set_grid(g)?;
    }
    Ok(Some((doc, path.to_path_buf())))
}

/// Every file the operations read: the job, each program, the stock's files
/// and the design model.
fn input_files(doc: &Job, job_path: &Path) -> Vec<PathBuf> {
    let mut files = vec![job_path.to_path_buf()];
    match &doc.stock {
        crate::input::job::StockSpec::Mesh { path, .. } => files.push(doc.resolve(path)),
        crate::input::job::StockSpec::Saved { path, .. } => {
            files.extend(crate::saved_stock::input_files(&doc.resolve(path)))
        }
        _ => {}
    }
    files.extend(doc.design.as_ref().map(|d| doc.resolve(&d.path)));
    for op in &doc.operation_jobs {
        files.push(op.job.resolve(&op.job.program().path));
    }
    files
}

/// One operation's set-up on the stock the operations before left (the
/// job's own stock for the first), its warnings told with its folder.
fn operation_setup(
    op: &Operation,
    job_path: &Path,
    budget_bytes: f64,
    stock: Option<Stock>,
    out_dir: &OutDir,
    opts: &RunOptions,
) -> Result<Setup> {
    let first = stock.is_none();
    let setup = Setup::of_job(job_path, op.job.clone(), budget_bytes, stock)?;
    if let Some(t) = &setup.tiling {
        fail!(limits, "{}: [stock] of {}×{} columns does not fit the memory budget: a job of operations hands the whole stock from one operation to the next; use a coarser grid or a larger --memory-budget-mb", setup.job.name, t.grid.nx, t.grid.ny);
    }
    if first {
        crate::commands::check_output_disk_for(&setup, out_dir, op_count(&setup))?;
    }
    for w in &setup.warnings {
        (opts.on_warning)(&format_args!("{}: {w}", op.folder));
    }
    Ok(setup)
}

/// Operations whose column grids the disk must hold (checked with the first).
fn op_count(setup: &Setup) -> usize {
    setup.job.operations.len().max(1)
}

/// The job's summary line of one operation.
fn line(
    op: &Operation,
    program: &str,
    run: &Summary,
    before: Option<&Summary>,
    kept_original: Option<bool>,
) -> OperationLine {
    OperationLine {
        number: op.number,
        name: op.name.clone(),
        folder: op.folder.clone(),
        program: program.to_string(),
        cycle_time_s: run.cycle_time_s,
        cycle_time_before_s: before.map(|b| b.cycle_time_s),
        kept_original,
        removed_volume_mm3: run.removed_volume_mm3,
        peak_mrr_mm3_s: run.peak_mrr_mm3_s,
        peak_force_n: run.peak_force_n,
        peak_power_w: run.peak_power_w,
        peak_deflection_um: run.peak_deflection_um,
        min_error_um: run.min_error_um,
        max_error_um: run.max_error_um,
        warnings: run.warnings.0.len(),
        tools: run.tools.clone(),
    }
}

/// The whole job's document: the lines summed, the volumes of the first and last.
#[allow(clippy::too_many_arguments)]
fn summary(
    ran: &str,
    doc: &Job,
    grid: GridInfo,
    lines: Vec<OperationLine>,
    initial_volume_mm3: f64,
    final_volume_mm3: f64,
    saved_stock: bool,
    started: Instant,
    run_id: String,
) -> OperationsSummary {
    let cycle_time_s = lines.iter().map(|l| l.cycle_time_s).sum();
    let cycle_time_before_s = lines
        .iter()
        .map(|l| l.cycle_time_before_s)
        .sum::<Option<f64>>();
    let removed_volume_mm3 = lines.iter().map(|l| l.removed_volume_mm3).sum();
    OperationsSummary {
        ran: ran.into(),
        job: doc.name.clone(),
        grid,
        operations: lines,
        cycle_time_s,
        cycle_time_before_s,
        initial_volume_mm3,
        final_volume_mm3,
        removed_volume_mm3,
        saved_stock: saved_stock.then(|| "stock".to_string()),
        run_time_s: started.elapsed().as_secs_f64(),
        run_id,
    }
}

/// The folder of an operation's results inside the staging folder, made.
fn op_dir(out_dir: &OutDir, op: &Operation) -> Result<PathBuf> {
    let dir = out_dir.path().join(&op.folder);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io("cannot create", &dir, e))?;
    Ok(dir)
}

/// An operation's folder's manifest: a results folder of its own, which
/// `dexcut report` reads alone too.
fn manifest(dir: &Path, run_id: &str, command: &str) -> Result<()> {
    export::atomic::write_manifest(dir, run_id, command)
        .map_err(|e| Error::io("cannot write the manifest of", dir, e))
}

/// A run of the operations begun: its start, the stock's memory budget
/// (bytes) and its results folder, staged.
fn begin(
    doc: &Job,
    job_path: &Path,
    out: &Path,
    opts: &RunOptions,
) -> Result<(Instant, f64, OutDir)> {
    let started = Instant::now();
    let budget_bytes = crate::input::stock::budget_bytes(opts.memory_budget_mb)?;
    let out_dir = OutDir::begin(out, &input_files(doc, job_path), opts.force)?;
    Ok((started, budget_bytes, out_dir))
}

/// `dexcut simulate` of a job of operations.
pub(crate) fn simulate(
    (doc, job_path): (Job, PathBuf),
    out: &Path,
    actual_path: bool,
    opts: &RunOptions,
) -> Result<Sequence<Simulated>> {
    let (started, budget_bytes, out_dir) = begin(&doc, &job_path, out, opts)?;
    let run_id = out_dir.run_id();
    let mut done = Done::default();
    for op in &doc.operation_jobs {
        let stock = done.stock.take();
        let mut setup = operation_setup(op, &job_path, budget_bytes, stock, &out_dir, opts)?;
        let dir = op_dir(&out_dir, op)?;
        let exact_stop = exact_stop_time_s(&setup);
        let (sim, steps_format) = simulate_whole(
            &mut setup,
            actual_path,
            &dir,
            opts.columns_csv,
            opts.steps_format,
        )?;
        let mut summary = simulate_summary(&setup, &sim, exact_stop, run_id.clone());
        summary.run_time_s = started.elapsed().as_secs_f64();
        crate::model::summary::write_simulate(&dir.join("summary.json"), &summary)?;
        manifest(&dir, &run_id, "simulate")?;
        let line = line(op, &summary.program, &summary.run, None, None);
        let initial = summary.run.initial_volume_mm3;
        let grid = summary.grid.clone();
        let simulated = Simulated {
            summary,
            banded: None,
            steps_format,
        };
        done.push(op, line, initial, grid, sim.run.stock, simulated);
    }
    finish("simulate", &doc, out_dir, done, started, opts)
}

/// `dexcut optimize` of a job of operations: each re-timed on the stock the
/// programs written before it leave.
pub(crate) fn optimize(
    (doc, job_path): (Job, PathBuf),
    out: &Path,
    opts: &RunOptions,
) -> Result<Sequence<Optimized>> {
    let (started, budget_bytes, out_dir) = begin(&doc, &job_path, out, opts)?;
    let run_id = out_dir.run_id();
    let mut done = Done::default();
    for op in &doc.operation_jobs {
        let stock = done.stock.take();
        let mut setup = operation_setup(op, &job_path, budget_bytes, stock, &out_dir, opts)?;
        crate::commands::check_optimizable(&setup, opts.on_warning)?;
        let dir = op_dir(&out_dir, op)?;
        let (mut optimized, left) = optimize_in(
            &mut setup,
            &dir,
            run_id.clone(),
            opts.columns_csv,
            opts.steps_format,
            crate::commands::PathAfter::Dropped,
            opts.on_warning,
        )?;
        let summary = &mut optimized.summary;
        summary.run_time_s = started.elapsed().as_secs_f64();
        crate::model::summary::write_optimize(&dir.join("summary.json"), summary)?;
        manifest(&dir, &run_id, "optimize")?;
        let line = line(
            op,
            &summary.program,
            &summary.after,
            Some(&summary.before),
            Some(summary.kept_original),
        );
        let (initial, grid) = (summary.before.initial_volume_mm3, summary.grid.clone());
        done.push(op, line, initial, grid, left, optimized);
    }
    finish("optimize", &doc, out_dir, done, started, opts)
}

/// The operations run so far: each one's results by its folder, its line of
/// the job's summary, and the stock it left; the first one's initial volume
/// and the grid.
struct Done<T> {
    ran: Vec<(String, T)>,
    lines: Vec<OperationLine>,
    initial_volume_mm3: f64,
    grid: Option<GridInfo>,
    stock: Option<Stock>,
}

impl<T> Default for Done<T> {
    fn default() -> Self {
        Done {
            ran: Vec::new(),
            lines: Vec::new(),
            initial_volume_mm3: 0.0,
            grid: None,
            stock: None,
        }
    }
}

impl<T> Done<T> {
    /// Operation `op` run: its line, its stock's initial volume, its grid,
    /// the stock it left and what it made.
    fn push(
        &mut self,
        op: &Operation,
        line: OperationLine,
        initial: f64,
        grid: GridInfo,
        stock: Stock,
        made: T,
    ) {
        if self.lines.is_empty() {
            self.initial_volume_mm3 = initial;
            self.grid = Some(grid);
        }
        self.lines.push(line);
        self.stock = Some(stock);
        self.ran.push((op.folder.clone(), made));
    }
}

/// The whole job's column grid in `dir` from its operations' (written in
/// their folders): `top_mm` after the last operation, `error_um` of the
/// operation that last cut each column (the error map of the part as the
/// operations leave it: a column a later operation does not touch keeps the
/// error an earlier one left), and `last_operation`, that operation's number
/// (0 where none cut).
fn write_job_columns(dir: &Path, grid: &GridInfo, lines: &[OperationLine]) -> Result<()> {
    let columns = grid.nx * grid.ny;
    let (mut error_um, mut last_operation) = (vec![f32::NAN; columns], vec![0i32; columns]);
    let mut top_mm = Vec::new();
    for op in lines {
        let mut maps = crate::report::read_column_maps(&dir.join(&op.folder), grid)?;
        let op_error = maps.remove("error_um").unwrap_or_default();
        for (i, e) in op_error.into_iter().enumerate() {
            if e.is_finite() {
                error_um[i] = e;
                last_operation[i] = op.number as i32;
            }
        }
        top_mm = maps.remove("top_mm").unwrap_or_default();
    }
    let arrays = [
        export::GridArray {
            name: "top_mm",
            unit: "mm",
            meaning: "top of the material after the last operation; NaN where the column holds none",
            values: export::NpyValues::F32(&top_mm),
        },
        export::GridArray {
            name: "last_operation",
            unit: "1",
            meaning: "number of the operation that last cut the column (1 the first); 0 if none",
            values: export::NpyValues::I32(&last_operation),
        },
        export::GridArray {
            name: "error_um",
            unit: "µm",
            meaning: "predicted shape error from tool deflection left by the operation that last cut the column, + material left; NaN where not cut",
            values: export::NpyValues::F32(&error_um),
        },
    ];
    export::write_column_grid(dir, &grid.export(), &arrays).map_err(|e| {
        Error::from(e).context(format!(
            "cannot write the job's column grid in {}",
            dir.display()
        ))
    })
}

/// Save the final stock where asked, write the job's summary.json and put
/// the folder in place.
fn finish<T>(
    command: &str,
    doc: &Job,
    out_dir: OutDir,
    done: Done<T>,
    started: Instant,
    opts: &RunOptions,
) -> Result<Sequence<T>> {
    let (Some(stock), Some(grid)) = (done.stock, done.grid) else {
        fail!(job, "{}: [[operations]] is empty", doc.name);
    };
    if opts.save_stock {
        crate::commands::save_stock(out_dir.path(), &stock)?;
    }
    write_job_columns(out_dir.path(), &grid, &done.lines)?;
    let summary = summary(
        command,
        doc,
        grid,
        done.lines,
        done.initial_volume_mm3,
        stock.volume_mm3(),
        opts.save_stock,
        started,
        out_dir.run_id(),
    );
    crate::model::summary::write_operations(&out_dir.path().join("summary.json"), &summary)?;
    out_dir.commit(command)?;
    Ok(Sequence {
        operations: done.ran,
        summary,
    })
}
