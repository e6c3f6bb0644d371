//! `dexcut`: cutting simulation and feed optimisation for 3-axis milling.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[macro_use]
mod console;
mod progress;

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
        /// Job file (TOML).
        job: PathBuf,
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
    },
    /// Re-time the program so MRR, force and deflection stay under [limits]
    /// while running as fast as the machine allows; with no job, runs the
    /// built-in boss_contour example.
    Optimize {
        /// Job file (TOML); default: the built-in boss_contour example.
        job: Option<PathBuf>,
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
    /// Fit the force law F = a·V^n to measurements: a CSV with columns v_mm3 (volume per tooth) and force_n.
    Calibrate {
        /// Measurements CSV.
        csv: PathBuf,
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
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.chain_message());
            ExitCode::FAILURE
        }
    }
}

/// Run one command through the library and print its results.
fn run(command: Command) -> Result<(), dexcut::Error> {
    let on_warning: dexcut::commands::OnWarning = &console::warning;
    match command {
        Command::Simulate {
            job,
            out,
            grid,
            actual_path,
            force,
            columns_csv,
            steps_format,
            memory_budget_mb,
        } => {
            let doc = dexcut::commands::simulate(
                &job,
                &out,
                grid,
                actual_path,
                force,
                columns_csv,
                steps_format.into(),
                memory_budget_mb,
                on_warning,
            )?;
            console::simulate(&doc, &out, steps_format.into());
        }
        Command::Optimize {
            job,
            out,
            grid,
            force,
            columns_csv,
            steps_format,
            settings,
        } => {
            if job.is_none() {
                eprintln!(
                    "no job given: running the built-in boss_contour example (inputs written to {})",
                    out.join("input").display()
                );
            }
            let optimized = dexcut::commands::optimize(
                job.as_deref(),
                &out,
                grid,
                force,
                columns_csv,
                steps_format.into(),
                settings.as_deref(),
                on_warning,
            )?;
            console::optimize(&optimized, &out, steps_format.into());
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
        Command::Calibrate { csv } => console::calibrate(&dexcut::commands::calibrate(&csv)?),
        Command::Example { out, force } => {
            let job = dexcut::commands::example(&out, force)?;
            console::example(&out, &job);
        }
    }
    Ok(())
}
