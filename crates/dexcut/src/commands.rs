//! The commands behind the CLI. Each checks every input before work starts
//! and writes its outputs only at the end, each file atomically. None prints:
//! each returns its results as typed values, and what must be told before or
//! during the work (warnings) goes to the caller's `on_warning`; the `dexcut`
//! binary formats both.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::{fail, Context as _, Error, Result, ResultExt as _};
use cutting::CuttingModel;
use dexel::{Stock, Tool, NEVER_CUT};
use schedule::Machine;
use serde::{Deserialize, Serialize};

use crate::job::Job;
use crate::motion::{self, TimedStep};
use crate::optimize::{self};
use crate::outdir::OutDir;
use crate::program::{self, Program};
use crate::simulate::{self, GridInfo, Run, Summary};
use crate::steps_out::StepsFormat;
use crate::tools::ToolSet;

pub use crate::evaluate::evaluate;
pub use crate::example::write as example;

/// Everything read and checked from a job before any work.
pub struct Setup {
    /// The job file it was loaded from.
    pub job_path: PathBuf,
    /// The job file's sections, checked.
    pub job: Job,
    /// The first tool the program uses and its model (the single [tool]).
    pub tool: Tool,
    /// The program, read into a path of moves.
    pub program: Program,
    /// The stock before any cut (with `tiling`, an empty stock on the whole grid).
    pub stock: Stock,
    /// How the stock is made band by band when it does not fit the memory
    /// budget (only `simulate` runs such a stock).
    pub tiling: Option<crate::stock::Tiling>,
    /// The cutting model of the first tool.
    pub model: CuttingModel,
    /// Every tool of the job; each step is cut by its own (MODEL.md §9.1).
    pub tools: ToolSet,
    /// Axis limits, servo period and feeds (`[machine]`).
    pub machine: Machine,
    /// The `[design]` model, read and checked before any work.
    pub design: Option<(PathBuf, mesh::DesignModel)>,
    /// What the set-up warns of before any work (see [`Setup::load`]): the
    /// commands print them at once and put them first in summary.json.
    pub warnings: Vec<crate::warnings::Warning>,
}

/// Most segments a program may have once its arcs are linearised (`arcs_as_lines`): the
/// interpreter's own limit on moves.
pub const MAX_LINEARISED_SEGMENTS: usize = 5_000_000;

/// `path` as the machine reads the program: with `[machine] arcs_as_lines`,
/// each arc as chords within the chord tolerance of its feed and block time
/// (MODEL.md §6.2, S0).
fn as_the_machine_reads(job: &Job, path: nc::Path) -> Result<nc::Path> {
    let (true, Some(tb)) = (job.machine.arcs_as_lines, job.machine.block_time_ms) else {
        return Ok(path);
    };
    let path = schedule::linearise_arcs(&path, tb, 1.0);
    if path.segments.len() > MAX_LINEARISED_SEGMENTS {
        fail!(limits,
            "{}: machine.arcs_as_lines writes the arcs as {} blocks, more than {MAX_LINEARISED_SEGMENTS}",
            job.name,
            path.segments.len()
        );
    }
    Ok(path)
}

impl Setup {
    /// The program's path as [`Setup::load`] made it, read again from the
    /// G-code program's text ([`program::Program::read_path`]: the same text
    /// read with the same options makes the same path bit for bit), for
    /// `optimize`, which does not hold it through the written program's run
    /// (126 MB for a million blocks, issue 16). A point list is not read
    /// again: it fails.
    pub fn program_path_again(&self) -> Result<nc::Path> {
        let Some(path) = self.program.read_path() else {
            fail!(
                run,
                "{}: a point list's path is not read again",
                self.program.file
            );
        };
        as_the_machine_reads(&self.job, path?)
    }

    /// Load the job (with an optional grid override) and everything it names.
    pub fn load(job_path: &Path, grid_mm: Option<f64>) -> Result<Setup> {
        Setup::load_with(job_path, grid_mm, None)
    }

    /// [`Setup::load`] with the machine and drive settings of a fragment
    /// written by `evaluate --sweep` (`--settings FILE`) put over the job's.
    pub fn load_with(
        job_path: &Path,
        grid_mm: Option<f64>,
        settings: Option<&Path>,
    ) -> Result<Setup> {
        Setup::load_within(job_path, grid_mm, settings, None)
    }

    /// [`Setup::load_with`] with a memory budget for the stock in MB
    /// (`--memory-budget-mb`; by default what this process may use): a box or
    /// cylinder stock whose columns exceed it is made band by band
    /// ([`Setup::tiling`]).
    pub fn load_within(
        job_path: &Path,
        grid_mm: Option<f64>,
        settings: Option<&Path>,
        budget_mb: Option<f64>,
    ) -> Result<Setup> {
        let budget_bytes = crate::stock::budget_bytes(budget_mb)?;
        let mut job = Job::load(job_path)?;
        if let Some(g) = grid_mm {
            job.set_grid(g)?;
        }
        if let Some(path) = settings {
            crate::evaluate::Settings::load(path)?.apply(&mut job, path)?;
        }
        let mut program = program::load(&job)?;
        program.path = as_the_machine_reads(&job, std::mem::take(&mut program.path))?;
        let tools = ToolSet::from_job(&job, &program)?;
        // Every move's tool is in the table (an error names the line).
        tools.indices::<u16>(program.path.segments.iter().map(|s| (s.tool, s.line)))?;
        let first = tools.entry(program.path.segments.first().map_or(1, |s| s.tool));
        let (tool, model) = (first.tool, first.model);
        // Checked with the job (Job::validate, through schedule::MACHINE_RANGES).
        let machine = motion::machine(&job);
        if program.gcode.is_some() {
            // Stations and samples are bounded before planning (2 runs: optimize's before and after).
            let estimate =
                crate::bounds::estimate_motion(&program.path, &machine, motion::STATION_DS_MM);
            let flute_mm = tools
                .entries
                .iter()
                .map(|e| e.tool.flute_length_mm)
                .fold(0.0, f64::max);
            let bands = (flute_mm / job.cutting.band_height).ceil() as usize;
            crate::bounds::check_motion(
                &estimate,
                &program.file,
                machine.period_ms,
                2.0,
                crate::bounds::bytes_per_sample(bands),
            )?;
        }
        let (stock, tiling) = crate::stock::build_within(&job, budget_bytes)?;
        let design = match &job.design {
            Some(d) => {
                let path = job.resolve(&d.path);
                crate::bounds::check_input_file(
                    &path,
                    "design model",
                    crate::bounds::MAX_MESH_BYTES,
                )?;
                let (mesh, _) = mesh::load_solid(&path)?;
                let model = mesh::DesignModel::new(&mesh)
                    .map_err(|e| Error::Mesh(e.into()))
                    .context_with(|| format!("{}: design model", path.display()))?;
                Some((path, model))
            }
            None => None,
        };
        let mut setup = Setup {
            job_path: job_path.to_path_buf(),
            job,
            tool,
            program,
            stock,
            tiling,
            model,
            tools,
            machine,
            design,
            warnings: Vec::new(),
        };
        setup.warnings = setup.setup_warnings();
        Ok(setup)
    }

    /// The job's stock as a run sweeps it: lent whole, or band by band where
    /// it is too large for the memory budget ([`Setup::tiling`]).
    pub fn stock_source(&self) -> simulate::StockSource<'_> {
        match &self.tiling {
            Some(tiling) => simulate::StockSource::Tiled(tiling),
            None => simulate::StockSource::Lent(&self.stock),
        }
    }

    /// Refuse a stock too large for the memory budget for `what`, which needs
    /// every column at once (`simulate` and `optimize` run such a stock band by band).
    pub fn require_whole_stock(&self, what: &str) -> Result<()> {
        if let Some(t) = &self.tiling {
            fail!(
                limits,
                "{}: [stock] {}×{} columns at grid {} mm need about {:.0} MB of memory, more than the {:.0} MB this process may use (available memory, cgroup memory.max and ulimit, or --memory-budget-mb): `dexcut simulate` and `dexcut optimize` run such a stock band by band; {what} needs every column at once: use a coarser grid",
                self.job.name,
                t.grid.nx,
                t.grid.ny,
                t.grid.spacing_mm,
                t.grid.len() as f64 * crate::bounds::BYTES_PER_COLUMN / 1e6,
                t.budget_bytes / 1e6
            );
        }
        Ok(())
    }

    /// Material, tools, machine and limits, as summary.json records them.
    pub fn info(&self) -> crate::summary::SetupInfo {
        let l = &self.job.limits;
        let limits = [
            ("mrr_max", l.mrr_max, "mm³/s"),
            ("force_max", l.force_max, "N"),
            ("deflection_max_um", l.deflection_max_um, "µm"),
            ("power_max_kw", l.power_max_kw, "kW"),
            ("feed_min", l.feed_min, "mm/min"),
            ("feed_max", l.feed_max, "mm/min"),
            ("feed_scale_max", l.feed_scale_max, "×"),
        ]
        .into_iter()
        .chain([(
            "stress_limit_mpa",
            // The weakest tool's allowable stress, held when `[limits] stress`.
            l.stress
                .then(|| {
                    self.tools
                        .entries
                        .iter()
                        .map(|e| e.stress_limit_mpa)
                        .reduce(f64::min)
                })
                .flatten(),
            "MPa",
        )])
        .filter_map(|(k, v, u)| v.map(|v| (k.to_string(), v, u.to_string())))
        .collect();
        crate::summary::SetupInfo {
            material: self.job.cutting.material.clone(),
            spindle_rpm: self.model.spindle_rpm,
            tools: self
                .tools
                .entries
                .iter()
                .map(|e| crate::summary::ToolInfo {
                    number: e.number,
                    shape: match e.tool.shape {
                        dexel::ToolShape::Ball => "ball".into(),
                        dexel::ToolShape::Flat => "flat".into(),
                        dexel::ToolShape::Bull { corner_radius_mm } => {
                            format!("bull r={corner_radius_mm}")
                        }
                    },
                    diameter_mm: e.tool.diameter_mm,
                    flutes: e.tool.flutes,
                    stickout_mm: e.tool.stickout_mm,
                    fz_max_mm: e.fz_max_mm,
                    stress_limit_mpa: Some(e.stress_limit_mpa),
                })
                .collect(),
            period_ms: self.machine.period_ms,
            feed_max_mm_min: self.machine.feed_max_mm_min,
            rapid_mm_min: self.machine.rapid_mm_min,
            accel_mm_s2: self.machine.accel_mm_s2,
            jerk_mm_s3: self.machine.jerk_mm_s3,
            limits,
        }
    }

    /// Every file the run reads: the job, its program, stock mesh and design model.
    pub fn input_files(&self, job_path: &Path) -> Vec<PathBuf> {
        let mut files = vec![
            job_path.to_path_buf(),
            self.job.resolve(&self.job.program.path),
        ];
        if let crate::job::StockSpec::Mesh { path, .. } = &self.job.stock {
            files.push(self.job.resolve(path));
        }
        files.extend(self.design.as_ref().map(|(p, _)| p.clone()));
        files
    }

    /// What the job's set-up warns of before any work, in this order: the
    /// program's file form ([`nc::FileForm::Tolerant`]), a tool change the
    /// single `[tool]` cannot follow, spindle speeds not used, and the grid
    /// check. Computed once, into [`Setup::warnings`].
    fn setup_warnings(&self) -> Vec<crate::warnings::Warning> {
        use crate::warnings::{Warning, WarningKind};
        let mut out: Vec<Warning> = self
            .program
            .read_warnings
            .iter()
            .map(|d| Warning {
                kind: WarningKind::ProgramForm,
                line: Some(d.line),
                value: 0.0,
                unit: String::new(),
                steps: 0,
                lines: vec![d.line],
                message: d.message.clone(),
            })
            .collect();
        out.extend(self.ignored_tool_change());
        out.extend(crate::warnings::spindle_check(
            &self.program.path,
            &self.tools,
        ));
        out.extend(self.grid_warning());
        out
    }

    /// With a single `[tool]`, every move is cut by it: a program that loads
    /// several tools (T… M6) is simulated with one, which the user must know.
    fn ignored_tool_change(&self) -> Option<crate::warnings::Warning> {
        if !self.tools.single || self.program.gcode.is_none() {
            return None;
        }
        // First line of each tool number the program cuts with, in order.
        let mut first: Vec<(u32, u32)> = Vec::new();
        for s in &self.program.path.segments {
            if s.tool != 0 && !first.iter().any(|&(t, _)| t == s.tool) {
                first.push((s.tool, s.line));
            }
        }
        if first.len() < 2 {
            return None;
        }
        let listed = first
            .iter()
            .map(|(t, l)| format!("T{t} from line {l}"))
            .collect::<Vec<_>>()
            .join(", ");
        Some(crate::warnings::Warning {
            kind: crate::warnings::WarningKind::IgnoredTool,
            line: Some(first[1].1),
            value: first.len() as f64,
            unit: "tools".into(),
            steps: 0,
            lines: first.iter().map(|&(_, l)| l).take(crate::warnings::MAX_LINES).collect(),
            message: format!(
                "the program uses {} tools ({listed}) but the job gives one [tool]: every move is simulated with it; give a tool table ([[tools]] with number = …) to follow the tool changes",
                first.len()
            ),
        })
    }

    /// The grid check of [`crate::warnings::grid_check`] for this job.
    fn grid_warning(&self) -> Option<crate::warnings::Warning> {
        let slowest = self
            .program
            .path
            .segments
            .iter()
            .filter_map(|s| match s.motion {
                // Moves mostly across the columns (plunges are resolved in Z).
                nc::Motion::Feed { feed_mm_min, .. }
                    if (s.end - s.start).xy().norm() >= 0.5 * (s.end - s.start).norm() =>
                {
                    Some(feed_mm_min.min(self.machine.feed_max_mm_min))
                }
                _ => None,
            })
            .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.min(f))));
        let w = crate::warnings::grid_check(
            // The smallest tool the job uses is the hardest to resolve.
            self.tools
                .entries
                .iter()
                .map(|e| e.tool.diameter_mm)
                .fold(self.tool.diameter_mm, f64::min),
            self.stock.grid().spacing_mm,
            if self.program.gcode.is_some() {
                slowest
            } else {
                None
            },
            self.machine.period_ms,
        )?;
        Some(w)
    }

    /// The job's stock, handed over: a run that sweeps it needs no copy. A
    /// stock of one column on the same grid spacing is left in its place
    /// (what [`Setup`] reads of it afterwards is the spacing).
    pub fn take_stock(&mut self) -> Result<Stock> {
        let spacing = self.stock.grid().spacing_mm;
        let one = Stock::new_box([0.0; 3], [spacing; 3], spacing)?;
        Ok(std::mem::replace(&mut self.stock, one))
    }

    /// The program as the machine runs it: servo periods for G-code, one step
    /// per move for CSV point lists.
    pub fn machine_steps(&self) -> Result<Vec<TimedStep>> {
        self.steps(false)
    }

    /// As [`Setup::machine_steps`]; with `actual_path`, the positions are the
    /// drive model's estimate of where the axes really are (G-code only).
    pub fn steps(&self, actual_path: bool) -> Result<Vec<TimedStep>> {
        if self.program.gcode.is_some() {
            let samples = motion::machine_motion(&self.program.path, &self.machine)?;
            self.steps_of(samples, actual_path)
        } else if actual_path {
            fail!(
                request,
                "--actual-path needs a G-code program (CSV point lists have no servo timing)"
            )
        } else {
            Ok(motion::direct_steps(
                &self.program.path,
                self.program.stream.as_ref(),
            ))
        }
    }

    /// [`Setup::steps`] with the program's path lent to the planner rather than copied
    /// (its stations hold it while the servo samples are made, then give it back).
    pub fn steps_lending_path(&mut self, actual_path: bool) -> Result<Vec<TimedStep>> {
        if self.program.gcode.is_none() {
            return self.steps(actual_path);
        }
        let path = std::mem::take(&mut self.program.path);
        let (samples, path) = motion::machine_motion_of(path, &self.machine);
        self.program.path = path;
        self.steps_of(samples?, actual_path)
    }

    /// The timed steps of the program's servo samples (`actual_path`: moved to where
    /// the drive model says the machine is).
    fn steps_of(
        &self,
        mut samples: Vec<schedule::ServoSample>,
        actual_path: bool,
    ) -> Result<Vec<TimedStep>> {
        if actual_path {
            let drive = crate::evaluate::drive(&self.job)?;
            let commanded: Vec<[f64; 3]> = samples.iter().map(|s| s.pos.coords.into()).collect();
            let actual = servo::simulate_actual(&commanded, self.machine.period_s(), &drive);
            for (s, a) in samples.iter_mut().zip(actual) {
                s.pos = nalgebra::Point3::from(a);
            }
        }
        Ok(motion::steps_from_samples(&self.program.path, &samples))
    }
}

/// Design comparison (S1): the final surface against the design model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DesignInfo {
    /// Design model file.
    pub path: String,
    /// Largest stock left (distance outside the design model), µm.
    pub max_stock_left_um: f64,
    /// Deepest gouge (negative distance), µm; 0 if none.
    pub worst_gouge_um: f64,
    /// Program line of the step that last cut the worst gouge.
    pub worst_gouge_line: Option<u32>,
    /// Column centre of the worst gouge, mm.
    pub worst_gouge_xy_mm: Option<[f64; 2]>,
    /// Tolerances the per-line lists use, µm.
    pub gouge_tolerance_um: f64,
    /// Stock above the design beyond this is listed, µm.
    pub stock_tolerance_um: f64,
    /// Every program line whose cut left a gouge deeper than `gouge_tolerance_um` or stock
    /// above `stock_tolerance_um` (S1, MODEL.md §8), by line, gouges first.
    pub lines: Vec<LineDeviation>,
    /// Columns no step cut that stand above the design by more than `stock_tolerance_um`.
    pub uncut_stock_columns: usize,
}

/// Which side of the design a deviation lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeviationKind {
    /// Below the design surface: material cut that the part needs.
    Gouge,
    /// Above the design surface: material left.
    Stock,
}

impl std::fmt::Display for DeviationKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DeviationKind::Gouge => "gouge",
            DeviationKind::Stock => "stock",
        })
    }
}

/// One program line's worst deviation from the design of one kind.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LineDeviation {
    /// Program line of the step that last cut the columns.
    pub line: u32,
    /// Below the design (gouge) or above it (stock).
    pub kind: DeviationKind,
    /// Worst signed distance, µm (negative for a gouge).
    pub worst_um: f64,
    /// Column centre of the worst one, mm.
    pub x_mm: f64,
    /// Column centre, y, mm.
    pub y_mm: f64,
    /// Number of columns beyond the tolerance whose last cut was on this line.
    pub columns: usize,
}

/// Per program line, the columns beyond tolerance (MODEL.md §8): `deviations` is
/// `(line of the last cut or None, signed distance µm, x mm, y mm)` for each column.
fn line_deviations(
    deviations: impl Iterator<Item = (Option<u32>, f64, f64, f64)>,
    gouge_tolerance_um: f64,
    stock_tolerance_um: f64,
) -> (Vec<LineDeviation>, usize) {
    let mut by_line: std::collections::BTreeMap<(u32, u8), LineDeviation> = Default::default();
    let mut uncut = 0;
    for (line, d_um, x_mm, y_mm) in deviations {
        let kind = if d_um < -gouge_tolerance_um {
            (0u8, DeviationKind::Gouge)
        } else if d_um > stock_tolerance_um {
            (1u8, DeviationKind::Stock)
        } else {
            continue;
        };
        let Some(line) = line else {
            uncut += usize::from(kind.0 == 1);
            continue;
        };
        let entry = by_line.entry((line, kind.0)).or_insert(LineDeviation {
            line,
            kind: kind.1,
            worst_um: d_um,
            x_mm,
            y_mm,
            columns: 0,
        });
        entry.columns += 1;
        if d_um.abs() > entry.worst_um.abs() {
            (entry.worst_um, entry.x_mm, entry.y_mm) = (d_um, x_mm, y_mm);
        }
    }
    (by_line.into_values().collect(), uncut)
}

/// Signed distance (µm) of each column's top (the final stock's top heights) to the design model; positive = stock left.
fn design_comparison(setup: &Setup, run: &Run) -> Result<Option<(Vec<f32>, DesignInfo)>> {
    let Some((path, model)) = &setup.design else {
        return Ok(None);
    };
    let tops = run.stock.top_heights();
    let grid = *run.stock.grid();
    let point = |i: usize| {
        [
            grid.x_mm(i % grid.nx),
            grid.y_mm(i / grid.nx),
            tops[i] as f64,
        ]
    };
    let valid: Vec<usize> = (0..tops.len()).filter(|&i| tops[i].is_finite()).collect();
    let distances = model.signed_distances_mm(&valid.iter().map(|&i| point(i)).collect::<Vec<_>>());
    let mut diff_um = vec![f32::NAN; tops.len()];
    for (&i, d) in valid.iter().zip(&distances) {
        diff_um[i] = (d * 1000.0) as f32;
    }
    let last_cut = run.stock.last_cut();
    let line_of = |i: usize| {
        let step = last_cut[i];
        (step != NEVER_CUT).then(|| run.steps[step as usize].line)
    };
    let spec = setup.job.design.as_ref();
    let gouge_tolerance_um = spec.map_or(10.0, |d| d.gouge_tolerance_um);
    let stock_tolerance_um = spec.map_or(50.0, |d| d.stock_tolerance_um);
    let (lines, uncut_stock_columns) = line_deviations(
        valid.iter().zip(&distances).map(|(&i, d)| {
            let [x, y, _] = point(i);
            (line_of(i), d * 1000.0, x, y)
        }),
        gouge_tolerance_um,
        stock_tolerance_um,
    );
    let mut info = DesignInfo {
        path: path.display().to_string(),
        max_stock_left_um: distances.iter().copied().fold(0.0, f64::max) * 1000.0,
        worst_gouge_um: 0.0,
        worst_gouge_line: None,
        worst_gouge_xy_mm: None,
        gouge_tolerance_um,
        stock_tolerance_um,
        lines,
        uncut_stock_columns,
    };
    if let Some((j, d)) = distances
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
    {
        if *d < 0.0 {
            let i = valid[j];
            let [x, y, _] = point(i);
            info.worst_gouge_um = d * 1000.0;
            info.worst_gouge_xy_mm = Some([x, y]);
            info.worst_gouge_line = line_of(i);
        }
    }
    Ok(Some((diff_um, info)))
}

/// summary.json of `simulate` (schema in [`crate::summary`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SimulateSummary {
    /// Headline numbers of the run.
    #[serde(flatten)]
    pub run: Summary,
    /// Job file.
    pub job: String,
    /// Program file.
    pub program: String,
    /// Stock grid, so `report` can rebuild the maps.
    pub grid: GridInfo,
    /// The final surface against the `[design]` model.
    pub design: Option<DesignInfo>,
    /// Material, tools, machine and limits of the job.
    #[serde(default)]
    pub setup: Option<crate::summary::SetupInfo>,
    /// Wall time of the command, s.
    pub run_time_s: f64,
    /// The run that wrote the folder (as in manifest.json).
    pub run_id: String,
}

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
    let design = design_comparison(setup, run)?;
    write_run_files(run, design.as_ref(), out, steps_format, columns_csv)?;
    Ok(design.map(|d| d.1))
}

/// The steps (`steps.csv` and/or `steps.json` with its `.npy` arrays, as
/// `steps_format` says) and the per-column results of a run (the `.npy` grid,
/// and columns.csv when `columns_csv`) into `out`.
fn write_run_files(
    run: &Run,
    design: Option<&(Vec<f32>, DesignInfo)>,
    out: &Path,
    steps_format: StepsFormat,
    columns_csv: bool,
) -> Result<StepsFormat> {
    let steps_format = run.write_steps(out, "steps", steps_format)?;
    // With a design model each column also names the program line that last cut it (S1).
    let lines: Option<Vec<i32>> = design.as_ref().map(|_| {
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
    });
    run.write_columns(
        out,
        design.map(|d| d.0.as_slice()),
        lines.as_deref(),
        columns_csv,
    )?;
    Ok(steps_format)
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
        write_run_files(
            &self.run,
            self.design.as_ref(),
            out,
            steps_format,
            columns_csv,
        )
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
/// run holds one stock (issue 16); a mesh stock is copied for each pass.
fn simulate_steps(setup: &Setup, stock: Stock, steps: Vec<TimedStep>) -> Result<Simulation> {
    let stock = match crate::stock::solid(&setup.job.stock) {
        Some(solid) => simulate::StockSource::Made(stock, solid),
        None => simulate::StockSource::Whole(stock),
    };
    let run = simulate::run_on(stock, &setup.tools, steps, "simulate")?;
    let mut summary = run.summary();
    summary.check_finite()?;
    summary
        .warnings
        .0
        .splice(0..0, setup.warnings.iter().cloned());
    let design = design_comparison(setup, &run)?;
    Ok(Simulation {
        run,
        summary,
        design,
    })
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
    tiling: &crate::stock::Tiling,
    actual_path: bool,
    columns_csv: bool,
    steps_format: StepsFormat,
    out: &Path,
) -> Result<(Simulation, StepsFormat)> {
    refuse_whole_stock_outputs(setup, tiling, columns_csv)?;
    let steps = setup.steps(actual_path)?;
    let mut run = simulate::run_on(
        simulate::StockSource::Tiled(tiling),
        &setup.tools,
        steps,
        "simulate",
    )?;
    let steps_format = run.write_steps(out, "steps", steps_format)?;
    simulate::write_tiled_columns(&mut run, tiling, &setup.tools, Some(out))?;
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
    tiling: &crate::stock::Tiling,
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
    pub fn of(tiling: &crate::stock::Tiling) -> Banded {
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

/// `dexcut simulate JOB --out DIR` (`memory_budget_mb`: `--memory-budget-mb`;
/// `steps_format`: `--steps-format`).
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    job: JobArg,
    out: &Path,
    grid_mm: Option<f64>,
    actual_path: bool,
    force: bool,
    columns_csv: bool,
    steps_format: StepsFormat,
    memory_budget_mb: Option<f64>,
    on_warning: OnWarning,
) -> Result<Simulated> {
    let started = Instant::now();
    let (mut setup, out_dir) = begin_run(job, out, force, &[], |p| {
        Setup::load_within(p, grid_mm, None, memory_budget_mb)
    })?;
    announce_setup_warnings(&setup, on_warning);
    let (sim, steps_format) = match &setup.tiling {
        None => {
            // The run sweeps the job's stock itself, not a copy (one stock
            // fewer held). A box or a cylinder is let go while the program is
            // planned and made again of its closed form after, the same
            // columns bit for bit (`stock::build`): planning and the stock
            // were the peak of the raster at 0.05 (issue 16).
            let solid = crate::stock::solid(&setup.job.stock);
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
                None => crate::stock::build(&setup.job)?,
            };
            let sim = simulate_steps(&setup, stock, steps)?;
            let written = sim.write_files(out_dir.path(), columns_csv, steps_format)?;
            (sim, written)
        }
        Some(tiling) => simulate_tiled(
            &setup,
            tiling,
            actual_path,
            columns_csv,
            steps_format,
            out_dir.path(),
        )?,
    };
    let summary = &sim.summary;
    let doc = SimulateSummary {
        run: summary.clone(),
        job: setup.job.name.clone(),
        program: setup.program.file.clone(),
        grid: GridInfo::of(sim.run.stock.grid()),
        design: sim.design.as_ref().map(|d| d.1.clone()),
        setup: Some(setup.info()),
        run_time_s: started.elapsed().as_secs_f64(),
        run_id: out_dir.run_id(),
    };
    crate::summary::write_simulate(&out_dir.path().join("summary.json"), &doc)?;
    out_dir.commit("simulate")?;
    Ok(Simulated {
        summary: doc,
        banded: setup.tiling.as_ref().map(Banded::of),
        steps_format,
    })
}

/// summary.json of `optimize` (schema in [`crate::summary`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OptimizeSummary {
    /// Job file.
    pub job: String,
    /// Program file.
    pub program: String,
    /// Stock grid, so `report` can rebuild the maps.
    pub grid: GridInfo,
    /// The program as given.
    pub before: Summary,
    /// optimized.nc read back and simulated.
    pub after: Summary,
    /// The limits it worked to.
    pub limits: LimitsOut,
    /// Share of the re-timed program's time spent at each cap.
    pub cap_time_share: Vec<optimize::CapShare>,
    /// Σ Δs / cap: no schedule under these caps can be faster.
    pub lower_bound_time_s: f64,
    /// (after − bound) / bound.
    #[serde(deserialize_with = "crate::summary::f64_or_nan")]
    pub optimality_gap: f64,
    /// Planner stations along the path.
    pub stations: usize,
    /// Spacing of the planner stations, mm.
    pub station_spacing_mm: f64,
    /// Peak MRR per servo period of the written program / mrr_max (≤ 1.02 is the target).
    pub peak_mrr_ratio: Option<f64>,
    /// Cycle time of the plan as written (each block at its feed), s.
    pub plan_time_s: f64,
    /// Cycle time with feeds free to change every 0.05 mm under the same caps, s.
    pub time_optimal_s: f64,
    /// (written program's cycle time − plan's) / plan's.
    #[serde(deserialize_with = "crate::summary::f64_or_nan")]
    pub written_vs_plan: f64,
    /// Rounds of writing, re-simulating and correcting the program.
    pub rounds: usize,
    /// Feeds within this ratio share a block in optimized.nc.
    pub merge_ratio: f64,
    /// The program as given was within every limit and faster: optimized.nc is the original.
    pub kept_original: bool,
    /// Largest feed per tooth on cutting moves, mm/tooth.
    pub fz_max_mm: Option<f64>,
    /// The final surface against the `[design]` model.
    pub design: Option<DesignInfo>,
    /// Material, tools, machine and limits of the job.
    #[serde(default)]
    pub setup: Option<crate::summary::SetupInfo>,
    /// Wall time of the command, s.
    pub run_time_s: f64,
    /// Wall time of the engagement sweep, s.
    pub time_engagement_s: f64,
    /// Wall time of planning and writing the program, s.
    pub time_plan_s: f64,
    /// Wall time of simulating the program as given, s.
    pub time_simulate_s: f64,
    /// The run that wrote the folder (as in manifest.json).
    pub run_id: String,
}

/// The limits optimize worked to, as summary.json records them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LimitsOut {
    /// `mrr_max`, mm³/s.
    pub mrr_max_mm3_s: Option<f64>,
    /// `force_max`, N.
    pub force_max_n: Option<f64>,
    /// `deflection_max_um`, µm.
    pub deflection_max_um: Option<f64>,
    /// `power_max_kw`, kW.
    pub power_max_kw: Option<f64>,
    /// `feed_min`, mm/min.
    pub feed_min_mm_min: Option<f64>,
    /// The machine's highest feed, mm/min.
    pub feed_max_mm_min: f64,
    /// fz_max · flutes · spindle rpm of the first tool, mm/min (`chip_load`
    /// gives every tool's).
    pub chip_load_feed_mm_min: Option<f64>,
    /// Every tool's chip-load cap against its programmed cutting feed.
    #[serde(default)]
    pub chip_load: Vec<optimize::ToolChipLoad>,
    /// `feed_scale_max`: at most this times the programmed feed.
    pub feed_scale_max: Option<f64>,
    /// The lowest `stress_limit_mpa` of the job's tools, MPa, where `[limits]
    /// stress` holds the tools to it (each tool is held to its own); None when off.
    #[serde(default)]
    pub stress_limit_mpa: Option<f64>,
}

/// The job a run reads: a job file, the built-in example, or a job fitted to
/// a program ([`crate::fitted_job`]).
#[derive(Clone, Copy)]
pub enum JobArg<'a> {
    /// A job file (TOML).
    File(&'a Path),
    /// The built-in boss_contour example.
    Example,
    /// A job fitted to a G-code program.
    Fitted(&'a crate::fitted_job::FittedJob),
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
        None => crate::example::write_files(&staged)?,
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
    Ok((setup, out_dir))
}

/// `dexcut optimize [JOB] --out DIR` (`steps_format`: `--steps-format`, for
/// steps and steps_before alike).
/// With no job, the built-in boss_contour example, its inputs written into the
/// results' `input/` folder.
#[allow(clippy::too_many_arguments)]
pub fn optimize(
    job: JobArg,
    out: &Path,
    grid_mm: Option<f64>,
    force: bool,
    columns_csv: bool,
    steps_format: StepsFormat,
    settings: Option<&Path>,
    memory_budget_mb: Option<f64>,
    on_warning: OnWarning,
) -> Result<Optimized> {
    let started = Instant::now();
    let settings_input: Vec<PathBuf> = settings.map(Path::to_path_buf).into_iter().collect();
    let (mut setup, out_dir) = begin_run(job, out, force, &settings_input, |p| {
        Setup::load_within(p, grid_mm, settings, memory_budget_mb)
    })?;
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
    announce_setup_warnings(&setup, on_warning);
    optimize_setup(
        &mut setup,
        out_dir,
        started,
        columns_csv,
        steps_format,
        on_warning,
    )
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
pub fn optimize_setup(
    setup: &mut Setup,
    out_dir: OutDir,
    started: Instant,
    columns_csv: bool,
    steps_format: StepsFormat,
    on_warning: OnWarning,
) -> Result<Optimized> {
    if let Some(tiling) = &setup.tiling {
        // A stock too large for memory is swept band by band in every run
        // (ARCHITECTURE.md "Large stocks").
        refuse_whole_stock_outputs(setup, tiling, columns_csv)?;
    }
    // Before: the program as written. Its path is lent to the planner's
    // stations, not copied into them (126 MB for a million blocks beside the
    // plan: issue 16).
    let t0 = Instant::now();
    let before_steps = setup.steps_lending_path(false)?;
    let mut before = simulate::run_on(setup.stock_source(), &setup.tools, before_steps, "before")?;
    if let Some(tiling) = &setup.tiling {
        // Its volumes and error range, band by band (nothing written).
        simulate::write_tiled_columns(&mut before, tiling, &setup.tools, None)?;
    }
    crate::heap_mark(format_args!("the program read, the program as given swept"));
    let limits = &setup.job.limits;
    let before_summary = before.summary();
    // Every tool's chip-load cap against what the program feeds it, told before the rounds.
    let chip_load = optimize::chip_loads(
        &before,
        &setup.tools,
        &setup.program,
        &setup.job.cutting.material,
    );
    let chip_warnings = crate::warnings::chip_load_check(&chip_load, &setup.tools);
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
    let staged = out_dir.path();
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
    crate::heap_mark(format_args!("steps_before written"));
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
    // program's run, nor while its outputs are written (issue 16).
    let path = std::mem::take(&mut setup.program.path);
    let (rounds, free) = match optimize::free_stations_of(path, &machine) {
        Err((e, path)) => (Err(e), optimize::FreeStations::Released(path)),
        Ok(stations) => {
            let mut free = optimize::FreeStations::Made(Box::new(stations));
            let rounds = optimize_rounds(setup, &machine, &mut free, given, t1, staged);
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
    };
    let asked = OutputsAsked {
        started,
        columns_csv,
        steps_format,
    };
    let optimized = rounds
        .and_then(|rounds| optimize_outputs(setup, &out_dir, &machine, as_given, rounds, asked))
        .and_then(|optimized| {
            out_dir.commit("optimize")?;
            Ok(optimized)
        });
    // Back in the setup (read again from its text where it was given).
    setup.program.path = match (free.into_path(setup), &optimized) {
        (Ok(path), _) => path,
        (Err(e), Ok(_)) => return Err(e),
        (Err(_), Err(_)) => nc::Path::default(),
    };
    crate::heap_mark(format_args!("summary written, the path read again"));
    optimized
}

/// What [`optimize_setup`] keeps of the program as given for the outputs.
struct AsGiven {
    summary: Summary,
    /// Its run, where steps_before is written with the written program's
    /// (its format chosen by the longer of the two); its stock let go.
    run: Option<simulate::Run>,
    /// Its number of steps.
    steps: usize,
    chip_load: Vec<optimize::ToolChipLoad>,
    chip_warnings: Vec<crate::warnings::Warning>,
    stress_limit_mpa: Option<f64>,
    time_simulate_s: f64,
}

/// What the user asked of [`optimize_setup`]'s outputs, and when it began.
struct OutputsAsked {
    started: Instant,
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
    out_dir: &OutDir,
    machine: &schedule::Machine,
    as_given: AsGiven,
    rounds: (usize, f64, optimize::Written, Instant),
    asked: OutputsAsked,
) -> Result<Optimized> {
    let limits = &setup.job.limits;
    let staged = out_dir.path();
    let (n_stations, time_engagement_s, written, t2) = rounds;
    let OutputsAsked {
        started,
        columns_csv,
        steps_format,
    } = asked;
    let fz_max_mm = setup.job.fz_max_mm();
    let time_plan_s = t2.elapsed().as_secs_f64();
    let mut after_run = written.run;
    if let Some(tiling) = &setup.tiling {
        // The `.npy` grid written band by band, which sets the volumes.
        simulate::write_tiled_columns(&mut after_run, tiling, &setup.tools, Some(staged))?;
    }
    let after = &after_run;
    let mut after_summary = after.summary();
    as_given.summary.check_finite()?;
    after_summary.check_finite()?;
    if written.excesses_left > 0 {
        after_summary.warnings.push(crate::warnings::Warning {
        kind: crate::warnings::WarningKind::LimitExceeded,
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
    let (mut unresolved, mut held) = (
        crate::warnings::LineTally::new(),
        crate::warnings::LineTally::new(),
    );
    for e in &written.unresolved {
        let tally = if e.held { &mut held } else { &mut unresolved };
        crate::warnings::tally(tally, e.line, 100.0 * e.over_limit);
    }
    after_summary.warnings.from_lines(
        crate::warnings::WarningKind::LimitExceeded,
        &held,
        "%",
        false,
        |v, lines| format!("servo periods up to {v:.0} % above a limit at {lines}, where a tapping cycle (G84/G74) runs: its feed is the tap's pitch times the spindle speed, held as programmed (LinuxCNC runs it with the feed override off), so optimize does not slow it; to lower the load there, lower the spindle speed and F together"),
    );
    after_summary.warnings.from_lines(
    crate::warnings::WarningKind::CoarseGrid,
    &unresolved,
    "%",
    false,
    |v, lines| format!("servo periods up to {v:.0} % above a limit at {lines} after {rounds} rounds of slowing them, where the tool advances less than one grid column per period: part of the removal there comes in whole columns (where the tool enters the stock or turns), which a slower feed does not lower in proportion; use a finer grid to hold the limit per period", rounds = written.rounds),
);
    let written_vs_plan = after_summary.cycle_time_s / written.plan_time_s - 1.0;
    if written_vs_plan > optimize::PLAN_TOLERANCE && !written.kept_original {
        after_summary.warnings.push(crate::warnings::Warning {
        kind: crate::warnings::WarningKind::PlanNotMet,
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
    // One format for both (Auto: by the longer), so the folder reads alike.
    let steps_format = steps_format.resolve(after.steps.len().max(as_given.steps));
    let design = match setup.tiling {
        None => write_run(setup, after, staged, steps_format, columns_csv)?,
        Some(_) => {
            after.write_steps(staged, "steps", steps_format)?;
            None
        }
    };
    if let Some(before) = as_given.run {
        before.write_steps(staged, "steps_before", steps_format)?;
    }
    // Files for the machine are in its own Z, as optimized.nc is.
    let z_sign = if setup.program.z_down { -1.0 } else { 1.0 };
    write_servo_csv(
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
    crate::heap_mark(format_args!("steps, columns and servo.csv written"));
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
        stations: n_stations,
        station_spacing_mm: motion::STATION_DS_MM,
        design,
        setup: Some(setup.info()),
        run_time_s: started.elapsed().as_secs_f64(),
        time_engagement_s,
        time_plan_s,
        time_simulate_s: as_given.time_simulate_s,
        run_id: out_dir.run_id(),
    };
    crate::summary::write_optimize(&staged.join("summary.json"), &doc)?;
    Ok(Optimized {
        summary: doc,
        precomp,
        steps_format,
        banded: setup.tiling.as_ref().map(Banded::of),
    })
}

/// [`optimize_setup`]'s engagement along the free `stations` (begun at
/// `t1`), their caps and the rounds of [`optimize::write_verified`]: the
/// number of stations, the engagement's time, what was written (optimized.nc
/// into `staged`) and when the rounds began.
fn optimize_rounds(
    setup: &Setup,
    machine: &schedule::Machine,
    free: &mut optimize::FreeStations,
    given: optimize::Given,
    t1: Instant,
    staged: &Path,
) -> Result<(usize, f64, optimize::Written, Instant)> {
    let stations = free.stations(machine, setup)?;
    let limits = &setup.job.limits;
    let surface = match (&setup.design, limits.angle_rule) {
        (_, false) => optimize::SurfaceFrom::Nothing,
        (Some((_, model)), true) => optimize::SurfaceFrom::Design(model),
        (None, true) => optimize::SurfaceFrom::Stock,
    };
    // The caps made as the sweep makes each interval's engagement final
    // (per station: loads, areas and angles not held, issue 16).
    let caps = optimize::engagement_caps_on(
        stations,
        &setup.stock_source(),
        &setup.tools,
        limits,
        surface,
    )?;
    let time_engagement_s = t1.elapsed().as_secs_f64();
    crate::heap_mark(format_args!("engagement and caps"));
    let t2 = Instant::now();
    let n_stations = stations.len();
    let written = optimize::write_verified(setup, machine, free, caps, given, staged)?;
    Ok((n_stations, time_engagement_s, written, t2))
}

/// servo.csv: commanded positions every period with path feed, axis
/// velocities, the tool and spindle speed of the block each lies on, and
/// whether the move to it is a rapid (`rapid`). A period that the run
/// `steps` (swept from these samples) splits where the motion changes between
/// rapid and feed also gets a row at each such corner, with the time the run
/// gave it and `sample` = 0 (a servo sample: 1). Read as a program (a point
/// list with `t_s`), it is simulated as the optimised run, step for step.
/// Z and its velocity are in the machine's own Z (`z_sign` −1 where it points down).
fn write_servo_csv(
    path: &Path,
    samples: impl Iterator<Item = motion::SampleRow>,
    steps: &[TimedStep],
    z_sign: f64,
) -> Result<()> {
    let mut periods = motion::periods(steps);
    export::atomic::write_file(path, |w| {
        let mut out = csv::Writer::from_writer(w);
        out.write_record([
            "t_s",
            "x",
            "y",
            "z",
            "feed_mm_min",
            "vx_mm_s",
            "vy_mm_s",
            "vz_mm_s",
            "tool",
            "spindle_rpm",
            "rapid",
            "sample",
        ])?;
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let mut before: Option<motion::SampleRow> = None;
        for (i, s) in samples.enumerate() {
            let (tool, rpm) = (s.tool, s.spindle_rpm);
            // The axis velocities over the period.
            let v = before.map_or(nalgebra::Vector3::zeros(), |b| {
                schedule::axis_velocity_between_mm_s((b.pos, b.t_s), (s.pos, s.t_s))
            });
            // The period's steps (none before the first sample).
            let period = match i {
                0 => &steps[..0],
                _ => periods.next().map_or(&steps[..0], |p| &steps[p]),
            };
            // Its corners, each where a part of positive duration ends
            // before the sample (a corner at the time of the row before it
            // or of the sample adds nothing: that part is empty). The move to
            // the sample takes the kind of its last part that moves.
            let mut t_row = before.map_or(f64::NEG_INFINITY, |b| b.t_s);
            let mut kind = steps.first().is_some_and(|p| p.step.rapid);
            let mut moved = false;
            for (j, c) in period.iter().enumerate() {
                let corner = j + 1 < period.len() && c.t_end_s > t_row && c.t_end_s < s.t_s;
                if corner {
                    let [x, y, z] = c.step.to_mm;
                    out.write_record(
                        [
                            c.t_end_s,
                            x,
                            y,
                            z_sign * z,
                            c.feed_mm_min,
                            v.x,
                            v.y,
                            z_sign * v.z,
                            c.tool as f64,
                            c.spindle_rpm,
                            flag(c.step.rapid),
                            0.0,
                        ]
                        .map(simulate::fmt),
                    )?;
                    t_row = c.t_end_s;
                    moved = false;
                } else if !moved || c.step.from_mm != c.step.to_mm {
                    kind = c.step.rapid;
                    moved = c.step.from_mm != c.step.to_mm;
                }
            }
            out.write_record(
                [
                    s.t_s,
                    s.pos.x,
                    s.pos.y,
                    z_sign * s.pos.z,
                    s.feed_mm_min,
                    v.x,
                    v.y,
                    z_sign * v.z,
                    tool as f64,
                    rpm,
                    flag(kind),
                    1.0,
                ]
                .map(simulate::fmt),
            )?;
            before = Some(s);
        }
        out.flush()
    })
    .map_err(|e| Error::io("cannot write", path, e))
}

/// `dexcut report DIR`.
pub fn report(dir: &Path) -> Result<crate::ReportFiles> {
    crate::report::write_report(dir)
}

/// `dexcut calibrate CSV`: least-squares fit of F = a·V^n in log space.
pub fn calibrate(path: &Path) -> Result<cutting::Fit> {
    let text = crate::bounds::read_text(path, "measurements", crate::bounds::MAX_CSV_BYTES)?;
    let points = read_calibration(&text, &path.display().to_string())?;
    let fit =
        cutting::fit_force_law(&points).or_run(|| format!("{}: cannot fit", path.display()))?;
    Ok(fit)
}

/// (volume per tooth mm³, force N) pairs from CSV text with columns v_mm3 and force_n.
pub fn read_calibration(text: &str, file: &str) -> Result<Vec<(f64, f64)>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .or_input(file, 1, 1, || "cannot read the header".into())?
        .clone();
    let find = |n: &str| headers.iter().position(|h| h.eq_ignore_ascii_case(n));
    let (Some(iv), Some(if_)) = (find("v_mm3"), find("force_n")) else {
        return Err(Error::input(
            file,
            1,
            1,
            "the header must name columns v_mm3 and force_n",
        ));
    };
    let mut points = Vec::new();
    for rec in reader.records() {
        let rec = rec.or_results(|| format!("{file}: bad row"))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize| -> Result<f64> {
            let raw = rec.get(i).unwrap_or("");
            let col = rec.range(i).map_or(1, |r| r.start + i + 1);
            let col = col as u64;
            let v: f64 = raw
                .parse()
                .or_input(file, line, col, || format!("not a number: {raw:?}"))?;
            // The law F = a·V^n is fitted in logs: only positive, finite values mean anything.
            if !(v > 0.0 && v.is_finite()) {
                let message = format!(
                    "{} must be a positive, finite number, got {raw}",
                    headers.get(i).unwrap_or("value")
                );
                return Err(Error::input(file, line, col, message));
            }
            Ok(v)
        };
        points.push((num(iv)?, num(if_)?));
    }
    Ok(points)
}
