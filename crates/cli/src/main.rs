//! `dexcut`: cutting simulation and feed optimisation for 3-axis milling.
//!
//! A thin binary over the `dexcut` library: it parses the command line
//! (clap), calls `dexcut::commands` (simulate, optimize, report, evaluate,
//! calibrate, example), which do the work (the pipeline job → stock + program
//! → motion → sweep → loads → outputs) and write the output files, and prints
//! their typed results, warnings and progress bars (`console`, `progress`).
//! No pipeline logic lives here.

use std::path::{Path, PathBuf};

use dexcut::fitted_job;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[macro_use]
mod console;
mod progress;

/// With the `heap-marks` feature: every allocation counted, for the heap
/// marks between optimize's phases (BENCHMARKS.md).
#[cfg(feature = "heap-marks")]
#[global_allocator]
static HEAP: heapmarks::Counting = heapmarks::Counting;

/// jemalloc, built to give freed pages back to the system at once
/// (`dirty_decay_ms:0,muzzy_decay_ms:0`, set where jemalloc is built:
/// `.cargo/config.toml`'s `JEMALLOC_SYS_WITH_MALLOC_CONF`): glibc's malloc
/// keeps freed memory resident over the live heap (its moving mmap
/// threshold; up to 94 MB on a 1 M-block optimize), jemalloc so built keeps
/// the peak RSS at the heap's peak (BENCHMARKS.md). jemalloc reads
/// `_RJEM_MALLOC_CONF` at run time over the built-in settings.
#[cfg(not(feature = "heap-marks"))]
#[global_allocator]
static JEMALLOC: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

#[derive(Parser)]
#[command(
    name = "dexcut",
    version,
    about = "Z-dexel cutting simulation, feed optimisation and error prediction for CNC milling"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Sweep the program through the stock: removed volume, MRR, force and
    /// deflection per step (steps.csv), final surface and predicted error per
    /// column (columns.json and .npy arrays), summary.json.
    Simulate {
        /// Job file (TOML), or a G-code program: a job is then fitted to it
        /// (stock around its feed moves, tool from --tool or the program's
        /// comments) and written to OUT/input/job.toml.
        job: PathBuf,
        /// With a G-code program instead of a job: the cutter, KIND:DIAMETER in
        /// mm (flat:6, ball:3.175, bull:10:1 with a 1 mm corner radius);
        /// default: the one the program's comments name.
        #[arg(long, value_name = "KIND:MM")]
        tool: Option<String>,
        /// Output folder (created if missing).
        #[arg(long, default_value = "out/simulate")]
        out: PathBuf,
        /// Override the stock's column spacing, mm.
        #[arg(long, value_name = "MM")]
        grid: Option<f64>,
        /// Sweep the estimated actual path of the axes (servo lag model from [servo])
        /// instead of the commanded one, so contour errors show in the removal and maps.
        #[arg(long)]
        actual_path: bool,
        /// Use an output folder that holds this run's inputs (they are kept in the new results).
        #[arg(long)]
        force: bool,
        /// Also write the per-column results as columns.csv (one text row per
        /// column: large on fine grids; the .npy arrays are always written).
        #[arg(long)]
        columns_csv: bool,
        /// How to write the per-step results (one row per servo period):
        /// `csv`: steps.csv, one text row per step (for a spreadsheet);
        /// `npy`: steps.json and one NumPy .npy array per column of steps.csv
        /// (float64 in the CSV's units, line and tool uint32, rapid and breaks
        /// uint8, the band volumes one (steps, K) array), faster to write and read; `both`; `auto`: csv up to 200 000 steps,
        /// npy above.
        #[arg(long, value_enum, default_value_t = StepsFormatArg::Auto, value_name = "FORMAT")]
        steps_format: StepsFormatArg,
        /// Memory for the stock, MB (default: what this process may use). A box
        /// or cylinder stock whose columns need more is swept band of rows by
        /// band of rows, with the same results, and its .npy grid streamed.
        #[arg(long, value_name = "MB")]
        memory_budget_mb: Option<f64>,
        /// Also write the stock the run leaves into OUT/stock/: every column's
        /// material intervals (stock.json, .npy arrays), which a job reads back
        /// with [stock] kind = "saved", and stock.stl, a closed mesh for a CAM
        /// system's in-process stock.
        #[arg(long)]
        save_stock: bool,
    },
    /// Re-time the program so MRR, force and deflection stay under [limits]
    /// while running as fast as the machine allows; with no job, runs the
    /// built-in boss_contour example.
    Optimize {
        /// Job file (TOML), or a G-code program (a job is fitted to it, as for
        /// simulate); default: the built-in boss_contour example.
        job: Option<PathBuf>,
        /// With a G-code program instead of a job: the cutter, KIND:DIAMETER in
        /// mm (flat:6, ball:3.175, bull:10:1); default: the one the program's comments name.
        #[arg(long, value_name = "KIND:MM")]
        tool: Option<String>,
        #[arg(long, default_value = "out/optimize")]
        out: PathBuf,
        /// Override the stock's column spacing, mm.
        #[arg(long, value_name = "MM")]
        grid: Option<f64>,
        /// Use an output folder that holds this run's inputs (they are kept in the new results).
        #[arg(long)]
        force: bool,
        /// Also write the per-column results as columns.csv (one text row per
        /// column: large on fine grids; the .npy arrays are always written).
        #[arg(long)]
        columns_csv: bool,
        /// How to write the per-step results, after and before (steps, steps_before):
        /// `csv`: steps.csv, one text row per step (for a spreadsheet);
        /// `npy`: steps.json and one NumPy .npy array per column of steps.csv
        /// (float64 in the CSV's units, line and tool uint32, rapid and breaks
        /// uint8, the band volumes one (steps, K) array), faster to write and read; `both`; `auto`: csv up to 200 000 steps,
        /// npy above.
        #[arg(long, value_enum, default_value_t = StepsFormatArg::Auto, value_name = "FORMAT")]
        steps_format: StepsFormatArg,
        /// Machine and drive settings written by `evaluate --sweep` (best.toml), over the job's.
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
        /// Memory for the stock, MB (default: what this process may use). A box
        /// or cylinder stock whose columns need more is swept band of rows by
        /// band of rows in every run, with the same results, and its .npy grid streamed.
        #[arg(long, value_name = "MB")]
        memory_budget_mb: Option<f64>,
        /// Also write the stock the run leaves into OUT/stock/: every column's
        /// material intervals (stock.json, .npy arrays), which a job reads back
        /// with [stock] kind = "saved", and stock.stl, a closed mesh for a CAM
        /// system's in-process stock.
        #[arg(long)]
        save_stock: bool,
    },
    /// Write report.html, error_map.png and stock.glb from a simulate or optimize output folder.
    Report {
        /// Folder written by `simulate` or `optimize`.
        dir: PathBuf,
    },
    /// Estimate what the axes really do (servo lag model), score the motion
    /// (S2: trajectory error, time, jerk), pre-compensate it (S4).
    Evaluate {
        /// Job file (TOML) with a G-code program and [servo].
        job: PathBuf,
        #[arg(long, default_value = "out/evaluate")]
        out: PathBuf,
        /// Evaluate this servo.csv (e.g. from `optimize`) instead of the program as written.
        #[arg(long, value_name = "FILE")]
        servo: Option<PathBuf>,
        /// Try a grid of acceleration, jerk and gain settings; the best by V goes to best.toml.
        #[arg(long)]
        sweep: bool,
        /// Machine and drive settings written by `evaluate --sweep` (best.toml), over the job's.
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
        /// Use an output folder that holds this run's inputs (they are kept in the new results).
        #[arg(long)]
        force: bool,
    },
    /// Fit the force law to measurements; print the job's [cutting] keys.
    ///
    /// The CSV's header picks the law. Kienzle (kc1_1, mc, and radial_ratio and
    /// axial_ratio when forces are given): one row per straight cut of a flat end
    /// mill, columns tool (flat), diameter_mm, flutes, ap_mm, ae_mm, fz_mm (feed per
    /// tooth), rpm, milling (up, down or slot; a slot has ae_mm = diameter_mm), and
    /// what was measured, averaged over the cut: power_w (spindle cutting power, W,
    /// idle power subtracted) and/or force_x_n, force_y_n, force_z_n (mean force on
    /// the tool, N: x along the feed, y to its left, z up, M3 spindle; up milling has
    /// the material on the left). S4's power law F = a·V^n: columns v_mm3 (volume
    /// per tooth, mm³) and force_n (N).
    Calibrate {
        /// Measurements CSV.
        csv: PathBuf,
        /// Also write the [cutting] fragment (TOML) to this file.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// Replace the --out file if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Write a job fitted to a G-code program, to edit: a box stock around its
    /// feed moves, the tool from --tool or the program's comments, aluminium,
    /// the machine defaults.
    Job {
        /// G-code program.
        program: PathBuf,
        /// The cutter, KIND:DIAMETER in mm (flat:6, ball:3.175, bull:10:1);
        /// default: the one the program's comments name.
        #[arg(long, value_name = "KIND:MM")]
        tool: Option<String>,
        /// Column spacing, mm (default: about 20 columns across the tool).
        #[arg(long, value_name = "MM")]
        grid: Option<f64>,
        /// Job file to write.
        #[arg(long, default_value = "job.toml")]
        out: PathBuf,
        /// Overwrite the job file if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Write the built-in example (job, stock mesh, program) to a folder to edit.
    Example {
        #[arg(long, default_value = "boss_contour")]
        out: PathBuf,
        /// Overwrite files of the folder that differ from the example (edited ones).
        #[arg(long)]
        force: bool,
    },
}

/// `--steps-format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum StepsFormatArg {
    /// steps.csv up to 200 000 steps, the .npy arrays above.
    Auto,
    /// steps.csv.
    Csv,
    /// steps.json and steps_<column>.npy.
    Npy,
    /// Both.
    Both,
}

impl From<StepsFormatArg> for dexcut::StepsFormat {
    fn from(f: StepsFormatArg) -> Self {
        match f {
            StepsFormatArg::Auto => dexcut::StepsFormat::Auto,
            StepsFormatArg::Csv => dexcut::StepsFormat::Csv,
            StepsFormatArg::Npy => dexcut::StepsFormat::Npy,
            StepsFormatArg::Both => dexcut::StepsFormat::Both,
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    dexcut::progress::set_progress(progress::bar);
    // SIGTERM, SIGINT (and SIGHUP): the staging folder and pending files go
    // as they do when a run fails, and the previous results stay.
    if let Err(e) = ctrlc::set_handler(|| {
        let removed = export::atomic::remove_unfinished();
        let what: Vec<String> = removed.iter().map(|p| p.display().to_string()).collect();
        eprintln!(
            "error: stopped by a signal; nothing written{}",
            if what.is_empty() {
                String::new()
            } else {
                format!(" (removed {})", what.join(", "))
            }
        );
        std::process::exit(130);
    }) {
        eprintln!("warning: cannot handle SIGTERM/SIGINT ({e}): a stopped run leaves its staging folder, removed by the next run into the same folder");
    }
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.chain_message());
            ExitCode::FAILURE
        }
    }
}

/// The job a command reads from `path`: the file itself, or the job fitted to it.
fn job_arg<'a>(
    path: &'a Path,
    fitted: Option<&'a fitted_job::FittedJob>,
) -> dexcut::commands::JobArg<'a> {
    fitted.map_or(
        dexcut::commands::JobArg::File(path),
        dexcut::commands::JobArg::Fitted,
    )
}

/// A job fitted to `path` when it is a G-code program rather than a job file
/// (its guesses printed), else None; `--tool` is refused with a job file.
fn fitted_job(
    path: &Path,
    tool: Option<&str>,
    grid: Option<f64>,
    out: &Path,
) -> Result<Option<fitted_job::FittedJob>, dexcut::Error> {
    if fitted_job::is_job_file(path) {
        if tool.is_some() {
            return Err(dexcut::Error::Request {
                message: format!(
                    "--tool is for a G-code program given instead of a job; {} is a job: its [tool] gives the tool",
                    path.display()
                ),
            });
        }
        return Ok(None);
    }
    let tool = tool.map(fitted_job::parse_tool_arg).transpose()?;
    let fitted = fitted_job::fit(path, tool.as_ref(), grid)?;
    eprintln!(
        "{} is a program, not a job: fitted a job to it (written to {}):",
        path.display(),
        out.join("input/job.toml").display()
    );
    for n in &fitted.notes {
        eprintln!("  {n}");
    }
    Ok(Some(fitted))
}

/// Run one command through the library and print its results.
fn run(command: Command) -> Result<(), dexcut::Error> {
    let on_warning: dexcut::commands::OnWarning = &console::warning;
    match command {
        Command::Simulate {
            job,
            tool,
            out,
            grid,
            actual_path,
            force,
            columns_csv,
            steps_format,
            memory_budget_mb,
            save_stock,
        } => {
            let fitted = fitted_job(&job, tool.as_deref(), grid, &out)?;
            let opts = dexcut::commands::RunOptions {
                grid_mm: grid,
                force,
                columns_csv,
                steps_format: steps_format.into(),
                memory_budget_mb,
                save_stock,
                on_warning,
            };
            let ran = dexcut::commands::simulate(
                job_arg(&job, fitted.as_ref()),
                &out,
                actual_path,
                &opts,
            )?;
            console::simulated(&ran, &out, steps_format.into());
        }
        Command::Optimize {
            job,
            tool,
            out,
            grid,
            force,
            columns_csv,
            steps_format,
            settings,
            memory_budget_mb,
            save_stock,
        } => {
            let fitted = match &job {
                Some(job) => fitted_job(job, tool.as_deref(), grid, &out)?,
                None => {
                    if tool.is_some() {
                        return Err(dexcut::Error::Request {
                            message: "--tool is for a G-code program given instead of a job; the built-in example has its own tool".into(),
                        });
                    }
                    eprintln!(
                        "no job given: running the built-in boss_contour example (inputs written to {})",
                        out.join("input").display()
                    );
                    None
                }
            };
            let opts = dexcut::commands::RunOptions {
                grid_mm: grid,
                force,
                columns_csv,
                steps_format: steps_format.into(),
                memory_budget_mb,
                save_stock,
                on_warning,
            };
            let ran = dexcut::commands::optimize(
                job.as_deref()
                    .map_or(dexcut::commands::JobArg::Example, |j| {
                        job_arg(j, fitted.as_ref())
                    }),
                &out,
                settings.as_deref(),
                &opts,
            )?;
            console::optimized(&ran, &out, steps_format.into());
        }
        Command::Report { dir } => console::report(&dexcut::commands::report(&dir)?),
        Command::Evaluate {
            job,
            out,
            servo,
            sweep,
            settings,
            force,
        } => {
            let ev = dexcut::commands::evaluate(
                &job,
                &out,
                servo.as_deref(),
                sweep,
                settings.as_deref(),
                force,
            )?;
            console::evaluate(&ev, &out);
        }
        Command::Calibrate { csv, out, force } => console::calibrate(
            &dexcut::commands::calibrate(&csv, out.as_deref(), force)?,
            out.as_deref(),
        ),
        Command::Job {
            program,
            tool,
            grid,
            out,
            force,
        } => {
            let tool = tool
                .as_deref()
                .map(fitted_job::parse_tool_arg)
                .transpose()?;
            let fitted = fitted_job::fit(&program, tool.as_ref(), grid)?;
            fitted.write(&out, force)?;
            for n in &fitted.notes {
                eprintln!("  {n}");
            }
            println!(
                "wrote {}: run `dexcut simulate {0}` or `dexcut optimize {0}`",
                out.display()
            );
        }
        Command::Example { out, force } => {
            let job = dexcut::commands::example(&out, force)?;
            console::example(&out, &job);
        }
    }
    Ok(())
}
