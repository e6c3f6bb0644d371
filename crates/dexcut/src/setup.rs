//! The set-up of a run: the job file and everything it names (program,
//! stock, tools, machine, design model), read and checked before any work,
//! and what the set-up warns of before any work starts; the drive model of
//! `[servo]` and the settings fragment of `evaluate --sweep` put over a job.

use std::path::{Path, PathBuf};

use crate::error::{fail, Context as _, Error, Result, ResultExt as _};
use crate::model::warnings::{tally, LineTally, Warning, WarningKind, Warnings};
use cutting::CuttingModel;
use dexel::{Stock, Tool};
use schedule::Machine;
use serde::Serialize;
use servo::{Drive, DriveOrder};

use crate::input::job::Job;
use crate::input::program::{self, Program};
use crate::input::tools::ToolSet;
use crate::motion::{self, TimedStep};

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
    pub tiling: Option<crate::input::stock::Tiling>,
    /// The cutting model of the first tool.
    pub model: CuttingModel,
    /// Every tool of the job; each step is cut by its own (MODEL.md §9.1).
    pub tools: ToolSet,
    /// Axis limits, servo period and feeds (`[machine]`).
    pub machine: Machine,
    /// The control whose planner runs the program (`[machine] controller`, MODEL.md §6.4).
    pub controller: schedule::Controller,
    /// The `[design]` model, read and checked before any work.
    pub design: Option<(PathBuf, mesh::DesignModel)>,
    /// The stock was handed over ([`Setup::of_job`]): the stock an operation
    /// before left, not the job's `[stock]`.
    pub handed_over: bool,
    /// What the set-up warns of before any work (see [`Setup::load`]): the
    /// commands print them at once and put them first in summary.json.
    pub warnings: Vec<crate::model::warnings::Warning>,
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
    /// (126 MB for a million blocks). A point list is not read
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
        let budget_bytes = crate::input::stock::budget_bytes(budget_mb)?;
        let mut job = Job::load(job_path)?;
        if let Some(g) = grid_mm {
            job.set_grid(g)?;
        }
        if let Some(path) = settings {
            Settings::load(path)?.apply(&mut job, path)?;
        }
        if !job.operations.is_empty() {
            fail!(request, "{}: a job of {} [[operations]] runs operation by operation (`dexcut simulate` and `dexcut optimize` do; the library's Setup is one operation's: Setup::of_job with Job::operation_jobs)", job.name, job.operations.len());
        }
        Setup::of_job(job_path, job, budget_bytes, None)
    }

    /// The set-up of `job` (read from `job_path`, checked): its program,
    /// tools and machine, and its stock made within `budget_bytes` or, with
    /// `handed`, that stock (the stock an operation before left, its cuts
    /// forgotten: [`dexel::Stock::clear_cuts`]).
    pub fn of_job(
        job_path: &Path,
        job: Job,
        budget_bytes: f64,
        handed: Option<Stock>,
    ) -> Result<Setup> {
        // A tool the program calls that the library skipped: why.
        let mut program = program::load(&job).map_err(|e| match &job.library {
            Some(library) => crate::input::tool_library::explain_program_error(library, e),
            None => e,
        })?;
        program.path = as_the_machine_reads(&job, std::mem::take(&mut program.path))?;
        if let Some(library) = &job.library {
            // A point list's tool column is not checked by the reader: a
            // tool the library skipped, why.
            let own: Vec<u32> = job.own_tools().iter().filter_map(|t| t.number).collect();
            crate::input::tool_library::check_used(
                library,
                &own,
                program.path.segments.iter().map(|s| (s.tool, s.line)),
            )?;
        }
        let tools = ToolSet::from_job(&job, &program)?;
        // Every move's tool is in the table (an error names the line).
        tools.indices::<u16>(program.path.segments.iter().map(|s| (s.tool, s.line)))?;
        let first = tools.entry(program.path.segments.first().map_or(1, |s| s.tool));
        let (tool, model) = (first.tool, first.model);
        // Checked with the job (Job::validate, through schedule::MACHINE_RANGES).
        let machine = crate::input::job::machine(&job);
        let controller = crate::input::job::controller(&job)?;
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
        let handed_over = handed.is_some();
        let (stock, tiling) = match handed {
            Some(mut stock) => {
                stock.clear_cuts();
                (stock, None)
            }
            None => crate::input::stock::build_within(&job, budget_bytes)?,
        };
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
            controller,
            design,
            handed_over,
            warnings: Vec::new(),
        };
        setup.warnings = setup.setup_warnings();
        Ok(setup)
    }

    /// The stock as a closed form (a box or a cylinder the job's `[stock]`
    /// names and not a stock handed over): made again for each pass.
    pub fn solid(&self) -> Option<dexel::Solid> {
        if self.handed_over {
            return None;
        }
        crate::input::stock::solid(&self.job.stock)
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
    pub fn info(&self) -> crate::model::summary::SetupInfo {
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
        crate::model::summary::SetupInfo {
            material: self.job.cutting.material.clone(),
            spindle_rpm: self.model.spindle_rpm,
            tools: self
                .tools
                .entries
                .iter()
                .map(|e| crate::model::summary::ToolInfo {
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

    /// Every file the run reads: the job, its program, stock mesh, design model
    /// and tool library (with a FreeCAD library's bits).
    pub fn input_files(&self, job_path: &Path) -> Vec<PathBuf> {
        let mut files = vec![
            job_path.to_path_buf(),
            self.job.resolve(&self.job.program().path),
        ];
        match &self.job.stock {
            crate::input::job::StockSpec::Mesh { path, .. } => files.push(self.job.resolve(path)),
            crate::input::job::StockSpec::Saved { path, .. } => {
                files.extend(crate::saved_stock::input_files(&self.job.resolve(path)))
            }
            _ => {}
        }
        files.extend(self.design.as_ref().map(|(p, _)| p.clone()));
        if let Some(library) = &self.job.library {
            files.extend(library.files.iter().cloned());
        }
        files
    }

    /// What the job's set-up warns of before any work, in this order: the
    /// program's file form ([`nc::FileForm::Tolerant`]), a tool change the
    /// single `[tool]` cannot follow, spindle speeds not used, and the grid
    /// check. Computed once, into [`Setup::warnings`].
    fn setup_warnings(&self) -> Vec<crate::model::warnings::Warning> {
        use crate::model::warnings::{Warning, WarningKind};
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
        out.extend(self.library_notes());
        out.extend(self.ignored_tool_change());
        out.extend(spindle_check(&self.program.path, &self.tools));
        out.extend(self.grid_warning());
        out
    }

    /// What `[tool_library]` gave: each tool the program uses, with what was
    /// inferred and defaulted, and the entries skipped.
    fn library_notes(&self) -> Vec<crate::model::warnings::Warning> {
        let Some(library) = &self.job.library else {
            return Vec::new();
        };
        let mut used: Vec<u32> = self.program.path.segments.iter().map(|s| s.tool).collect();
        used.sort_unstable();
        used.dedup();
        crate::input::tool_library::notes(library, &used)
            .into_iter()
            .map(|message| crate::model::warnings::Warning {
                kind: crate::model::warnings::WarningKind::ToolLibrary,
                line: None,
                value: 0.0,
                unit: String::new(),
                steps: 0,
                lines: Vec::new(),
                message,
            })
            .collect()
    }

    /// With a single `[tool]`, every move is cut by it: a program that loads
    /// several tools (T… M6) is simulated with one, which the user must know.
    fn ignored_tool_change(&self) -> Option<crate::model::warnings::Warning> {
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
        Some(crate::model::warnings::Warning {
            kind: crate::model::warnings::WarningKind::IgnoredTool,
            line: Some(first[1].1),
            value: first.len() as f64,
            unit: "tools".into(),
            steps: 0,
            lines: first.iter().map(|&(_, l)| l).take(crate::model::warnings::MAX_LINES).collect(),
            message: format!(
                "the program uses {} tools ({listed}) but the job gives one [tool]: every move is simulated with it; give a tool table ([[tools]] with number = …) to follow the tool changes",
                first.len()
            ),
        })
    }

    /// The grid check of [`grid_check`] for this job.
    fn grid_warning(&self) -> Option<crate::model::warnings::Warning> {
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
        let w = grid_check(
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
            let samples =
                motion::machine_motion(&self.program.path, &self.machine, &self.controller)?;
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
        let (samples, path) = motion::machine_motion_of(path, &self.machine, &self.controller);
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
            let drive = drive(&self.job)?;
            let commanded: Vec<[f64; 3]> = samples.iter().map(|s| s.pos.coords.into()).collect();
            let actual = servo::simulate_actual(&commanded, self.machine.period_s(), &drive);
            for (s, a) in samples.iter_mut().zip(actual) {
                s.pos = nalgebra::Point3::from(a);
            }
        }
        Ok(motion::steps_from_samples(&self.program.path, &samples))
    }
}

/// The drive model from [servo].
pub fn drive(job: &Job) -> Result<Drive> {
    let s = &job.servo;
    let order = match (s.zeta, s.omega_n) {
        (Some(zeta), Some(omega_n_rad_s)) => DriveOrder::Second {
            zeta,
            omega_n_rad_s,
        },
        _ => DriveOrder::First,
    };
    let drive = Drive {
        kp_per_s: s.kp,
        feedforward: s.feedforward,
        order,
    };
    drive
        .validate()
        .or_job(|| format!("{}: invalid [servo]", job.name))?;
    Ok(drive)
}

/// The machine and drive settings that `evaluate --sweep` varies, as a job
/// fragment (`best.toml`): `[machine] accel`, `jerk` (absent: no jerk limit)
/// and `[servo] kp`. `optimize` and `evaluate` take it with `--settings FILE`,
/// over the job's own values (MODEL.md §7.2).
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    pub machine: MachineSettings,
    pub servo: ServoSettings,
}

/// `[machine]` of a [`Settings`] fragment.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineSettings {
    /// Per-axis acceleration limit, mm/s².
    pub accel: [f64; 3],
    /// Per-axis jerk limit, mm/s³; none when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jerk: Option<[f64; 3]>,
}

/// `[servo]` of a [`Settings`] fragment.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoSettings {
    /// Position loop gain, 1/s.
    pub kp: f64,
}

impl Settings {
    /// Read a fragment; errors name the file, line and column, or the key.
    pub fn load(path: &Path) -> Result<Settings> {
        let text = crate::bounds::read_text(path, "settings", crate::bounds::MAX_JOB_BYTES)?;
        let name = path.display().to_string();
        toml::from_str(&text).map_err(|e| {
            let at = e.span().map_or_else(
                || name.clone(),
                |s| crate::input::job::location(&name, &text, s.start),
            );
            Error::job(format!("{at}: {}", e.message()))
        })
    }

    /// Put these settings into `job` and check it again.
    pub fn apply(&self, job: &mut Job, source: &Path) -> Result<()> {
        job.machine.accel = self.machine.accel;
        job.machine.jerk = self.machine.jerk;
        job.servo.kp = self.servo.kp;
        job.validate()
            .context_with(|| format!("{}: invalid settings for {}", source.display(), job.name))
    }

    /// The fragment as TOML text.
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(self).or_run(|| "cannot write the settings as TOML".into())
    }
}

/// Before any work: whether the grid can measure the tool's removal honestly
/// (MODEL.md §10). Two checks, each with a grid that would do:
/// * the tool spans fewer than [`TOOL_CELLS`] columns across its diameter,
///   so its footprint, and the removal of one step, is coarse;
/// * at the slowest programmed cutting feed the tool advances less than one
///   column per servo period, so removal per period comes in whole columns
///   and the per-period MRR shows the grid rather than the cut (the MRR over
///   ≥ 48 ms is still resolved).
pub fn grid_check(
    diameter_mm: f64,
    grid_mm: f64,
    slowest_feed_mm_min: Option<f64>,
    period_ms: f64,
) -> Option<Warning> {
    let mut reasons = Vec::new();
    let mut suggest = grid_mm;
    if diameter_mm / grid_mm < TOOL_CELLS {
        suggest = suggest.min(diameter_mm / TOOL_CELLS);
        reasons.push(format!(
            "the {diameter_mm} mm tool spans only {:.1} columns of {grid_mm} mm",
            diameter_mm / grid_mm
        ));
    }
    if let Some(f) = slowest_feed_mm_min {
        let advance_mm = f * period_ms / 60_000.0;
        if advance_mm < grid_mm {
            suggest = suggest.min(advance_mm);
            reasons.push(format!(
                "at F{f} the tool advances {advance_mm:.3} mm per {period_ms} ms period, less than one column, so the MRR per period comes in whole columns (the MRR over ≥ 48 ms is resolved)"
            ));
        }
    }
    if reasons.is_empty() {
        return None;
    }
    // Round the suggestion down to two significant digits.
    let scale = 10f64.powf(suggest.log10().floor() - 1.0);
    let suggest = (suggest / scale).floor() * scale;
    Some(Warning {
        kind: WarningKind::CoarseGrid,
        line: None,
        value: grid_mm,
        unit: "mm".into(),
        steps: 0,
        lines: Vec::new(),
        message: format!(
            "the grid is too coarse to measure this tool's removal per period: {}; a grid of {} mm (--grid {}) would resolve it",
            reasons.join("; "),
            crate::util::short(suggest),
            crate::util::short(suggest)
        ),
    })
}

/// S words of cutting moves that are too slow to be a spindle speed for
/// their tool ([`crate::input::tools::plausible_rpm`]), when the job gives no
/// `[cutting] spindle_rpm`: one warning with their lines.
pub fn spindle_check(path: &nc::Path, tools: &crate::input::tools::ToolSet) -> Option<Warning> {
    let mut t = LineTally::new();
    let mut worst: Option<(f64, u32, f64)> = None;
    for s in &path.segments {
        let e = tools.entry(s.tool);
        let d = e.tool.diameter_mm;
        if !matches!(s.motion, nc::Motion::Feed { .. })
            || e.job_rpm.is_some()
            || s.spindle_rpm <= 0.0
            || crate::input::tools::plausible_rpm(d, s.spindle_rpm)
        {
            continue;
        }
        let v = crate::input::tools::cutting_speed_m_min(d, s.spindle_rpm);
        tally(&mut t, s.line, v);
        if worst.is_none_or(|w| v < w.0) {
            worst = Some((v, e.number, s.spindle_rpm));
        }
    }
    let (v, number, rpm) = worst?;
    let e = tools.entry(number);
    let taken = e.model.spindle_rpm;
    let mut w = Warnings::default();
    w.from_lines(WarningKind::SpindleSpeed, &t, "m/min", false, |_, lines| {
        format!(
            "S{rpm} at {lines} gives {v:.2} m/min at the edge of {}, below {MIN} m/min and under {RPM} rev/min, slower than any milling cutter runs: it is not taken as rev/min (a spindle override in percent, or a laser's power?); forces and the chip-load cap take {taken} rev/min ({}); set [cutting] spindle_rpm to the real spindle speed",
            tools.name(number),
            if taken == 10_000.0 { "the default" } else { "the program's highest plausible S" },
            MIN = crate::input::tools::MIN_CUTTING_SPEED_M_MIN,
            RPM = crate::input::tools::MIN_SPINDLE_RPM,
        )
    });
    let mut w = w.0.pop()?;
    w.value = v;
    Some(w)
}

/// Columns a tool's diameter should span for its removal to be resolved.
pub const TOOL_CELLS: f64 = 10.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_check_names_both_reasons_and_a_grid() {
        assert!(grid_check(10.0, 0.1, Some(1000.0), 16.0).is_none());
        // 1 mm on 0.2 mm: 5 columns; F150 at 16 ms: 0.04 mm per period.
        let w = grid_check(1.0, 0.2, Some(150.0), 16.0).unwrap();
        assert_eq!(w.kind, WarningKind::CoarseGrid);
        assert!(
            w.message.contains("spans only 5.0 columns"),
            "{}",
            w.message
        );
        assert!(
            w.message.contains("advances 0.040 mm per 16 ms"),
            "{}",
            w.message
        );
        assert!(
            w.message
                .ends_with("a grid of 0.04 mm (--grid 0.04) would resolve it"),
            "{}",
            w.message
        );
        let w = grid_check(1.0, 0.2, None, 16.0).unwrap();
        assert!(w.message.contains("a grid of 0.1 mm"), "{}", w.message);
    }
}
