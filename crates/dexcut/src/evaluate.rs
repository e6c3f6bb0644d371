//! `dexcut evaluate`: what the axes really do (S2, S4 motion error). The
//! commanded servo data go through a drive model; the estimated actual motion
//! is scored by trajectory error, time and jerk, pre-compensated, and
//! optionally a grid of machine settings is searched for the best score.

use std::path::Path;

use crate::error::{fail, Error, Result, ResultExt as _};
use schedule::Machine;
use serde::Serialize;
use servo::{Drive, Evaluation, Weights};

use crate::input::job::Job;
use crate::motion;
use crate::setup::{drive, MachineSettings, ServoSettings, Settings, Setup};
use crate::util::{fmt, write_json};

fn weights(job: &Job, reference_time_s: f64) -> Weights {
    let s = &job.servo;
    Weights {
        ka: s.ka,
        kb: s.kb,
        kc: s.kc,
        tolerance_mm: s.tolerance_mm,
        reference_time_s: reference_time_s.max(1e-9),
        jerk_reference_mm_s3: s.jerk_reference,
    }
}

/// Commanded positions every period of the program as `machine` runs it.
fn commanded(setup: &Setup, machine: &Machine) -> Result<Vec<[f64; 3]>> {
    let samples = motion::machine_motion(&setup.program.path, machine, &setup.controller)?;
    Ok(samples.iter().map(|s| s.pos.coords.into()).collect())
}

/// Commanded positions from a servo.csv (`t_s,x,y,z,…`), e.g. from `optimize`
/// (its corner rows, `sample` = 0, left out).
fn read_servo_csv(path: &Path, period_ms: f64) -> Result<Vec<[f64; 3]>> {
    let size = crate::bounds::check_input_file(path, "servo data", crate::bounds::MAX_CSV_BYTES)?;
    // A row is at least 8 bytes ("0,0,0,0\n"); each costs about BYTES_PER_SAMPLE while evaluated.
    crate::bounds::check_memory(
        size as f64 / 8.0 * crate::bounds::BYTES_PER_SAMPLE,
        &format!("{}: servo data of {size} bytes", path.display()),
    )?;
    let mut reader = csv::Reader::from_reader(crate::bounds::open(
        path,
        "servo data",
        crate::bounds::MAX_CSV_BYTES,
    )?);
    // optimize's corner rows (`sample` = 0: where a period changes between
    // rapid and feed) are not servo samples.
    let sample_column = reader.headers().ok().and_then(|h| {
        h.iter()
            .position(|c| c.trim().eq_ignore_ascii_case("sample"))
    });
    let mut out = Vec::new();
    // Interval before each sample, ms, with its line (checked once the last row is known).
    let mut intervals: Vec<(usize, f64)> = Vec::new();
    let mut last_t: Option<f64> = None;
    for (i, rec) in reader.records().enumerate() {
        let line = i + 2;
        let rec = rec.or_input(&path.display().to_string(), line as u64, 1, || {
            "bad row".into()
        })?;
        if sample_column.is_some_and(|k| rec.get(k).is_some_and(|v| v.trim() == "0")) {
            continue;
        }
        let num = |k: usize| -> Result<f64> {
            let raw = rec.get(k).unwrap_or("");
            let (file, line, col) = (path.display().to_string(), line as u64, k as u64 + 1);
            let v: f64 = raw
                .parse()
                .or_input(&file, line, col, || format!("not a number: {raw:?}"))?;
            if !(v.abs() <= 1e9) {
                let message = format!("{raw:?} is not a finite number within ±1e9");
                return Err(Error::input(&file, line, col, message));
            }
            Ok(v)
        };
        let t = num(0)?;
        if let Some(prev) = last_t {
            intervals.push((line, (t - prev) * 1000.0));
        }
        last_t = Some(t);
        out.push([num(1)?, num(2)?, num(3)?]);
    }
    // Every period_ms; the program's end may fall inside the last period (that
    // sample is then taken as one period later, as the planner's own samples are).
    let tol = 1e-6 * period_ms.max(1.0);
    for (k, &(line, dt_ms)) in intervals.iter().enumerate() {
        let last = k + 1 == intervals.len();
        let ok = (dt_ms - period_ms).abs() <= tol || (last && dt_ms > 0.0 && dt_ms < period_ms);
        if !ok {
            let message = format!(
                "samples must be every {period_ms} ms (the job's period_ms), got {dt_ms:.6} ms"
            );
            return Err(Error::input(
                &path.display().to_string(),
                line as u64,
                1,
                message,
            ));
        }
    }
    if out.len() < 2 {
        fail!(request, "{}: need at least two samples", path.display());
    }
    Ok(out)
}

/// S4's pre-compensation of planned servo data (MODEL.md §7.3): the commands that make the
/// `[servo]` drive model follow the samples at `target` to within `precomp_threshold_mm`, written as
/// `t_s,x,y,z` every period to `path`. The last sample (the cycle end, off the period grid)
/// is taken at the next period, where the plan rests at the end point anyway.
/// The commands are written in the machine's own Z (`z_sign` −1 where its Z points
/// down): the drive model is the same on every axis direction, so they are the
/// mirror of those compensated in dexcut's frame.
pub fn write_compensated_servo(
    job: &Job,
    target: Vec<[f64; 3]>,
    period_ms: f64,
    z_sign: f64,
    path: &Path,
) -> Result<servo::Precomp> {
    let drive = drive(job)?;
    let period_s = period_ms * 1e-3;
    let pre = servo::precompensate(
        &target,
        period_s,
        &drive,
        job.servo.precomp_threshold_mm,
        job.servo.precomp_iterations,
    );
    let command: Vec<[f64; 3]> = pre
        .command
        .iter()
        .map(|&[x, y, z]| [x, y, z_sign * z])
        .collect();
    write_positions_csv(path, &command, period_s)?;
    Ok(pre)
}

fn write_positions_csv(path: &Path, positions: &[[f64; 3]], period_s: f64) -> Result<()> {
    export::atomic::write_file(path, |w| {
        let mut out = csv::Writer::from_writer(w);
        out.write_record(["t_s", "x", "y", "z"])?;
        for (i, p) in positions.iter().enumerate() {
            out.write_record([i as f64 * period_s, p[0], p[1], p[2]].map(fmt))?;
        }
        out.flush()
    })
    .map_err(|e| Error::io("cannot write", path, e))
}

/// One set of machine settings tried by `evaluate --sweep`, with its score.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepRow {
    /// Per-axis acceleration limit, mm/s².
    pub accel_mm_s2: [f64; 3],
    /// Per-axis jerk limit, mm/s³; `None`: no jerk limit.
    pub jerk_mm_s3: Option<[f64; 3]>,
    /// Position loop gain, 1/s.
    pub kp_per_s: f64,
    /// The score of the program planned and run with these settings.
    #[serde(flatten)]
    pub evaluation: Evaluation,
}

/// What the axes do with a program's servo data (MODEL.md §7.2, S2 and S4),
/// as [`crate::evaluate`] returns it.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveEvaluation {
    /// The drive model of the job's `[servo]`.
    pub drive: Drive,
    /// S2's weights and references; Vb's reference time is that of the
    /// program as written, so the program as written scores Vb = 1/2.
    pub weights: Weights,
    /// Trajectory error, machining time, jerk and S2's V of the commanded data.
    pub evaluation: Evaluation,
    /// The estimated actual tool position every servo period, mm.
    pub actual_mm: Vec<[f64; 3]>,
    /// S4's pre-compensated command and its sample-wise errors.
    pub precomp: servo::Precomp,
    /// Trajectory error of the pre-compensated command's actual motion, mm.
    pub precomp_trajectory_error_mm: f64,
    /// With `sweep`: every setting tried (accel ×0.5/1/2, with and without
    /// jerk, kp ×0.5/1/2).
    pub sweep: Vec<SweepRow>,
    /// Index in [`DriveEvaluation::sweep`] of the largest V.
    pub best: Option<usize>,
}

#[derive(Serialize)]
struct EvaluationDoc<'a> {
    job: String,
    drive: String,
    weights: Weights,
    #[serde(flatten)]
    evaluation: Evaluation,
    /// Pre-compensation (S4): largest sample-wise error before and after, mm.
    precomp_error_before_mm: f64,
    precomp_error_after_mm: f64,
    precomp_iterations: usize,
    /// Trajectory error of the compensated command's actual motion, mm.
    precomp_trajectory_error_mm: f64,
    sweep: &'a [SweepRow],
    best: Option<usize>,
}

/// Run the job's servo data (the program as planned, or `servo_csv`) through
/// its drive model and score it; with `sweep`, also every setting of the grid.
pub fn evaluate_setup(
    setup: &Setup,
    servo_csv: Option<&Path>,
    sweep: bool,
) -> Result<DriveEvaluation> {
    let drive = drive(&setup.job)?;
    if sweep && servo_csv.is_some() {
        fail!(
            request,
            "--sweep re-plans the program, so it cannot be combined with --servo"
        );
    }
    let period_s = setup.machine.period_s();
    let as_written = setup
        .program
        .gcode
        .is_some()
        .then(|| commanded(setup, &setup.machine))
        .transpose()?;
    let command = match (servo_csv, &as_written) {
        (Some(p), _) => read_servo_csv(p, setup.machine.period_ms)?,
        (None, Some(c)) => c.clone(),
        (None, None) => fail!(request, "evaluate needs a G-code program or --servo data"),
    };
    // MODEL.md §7.2 (S2): times of the estimated actual motion, which is done when the axes
    // settle within the tolerance of the end. Vb's reference is the program as written with
    // the job's settings, so runs of one job compare (it scores Vb = 1/2).
    let settle_mm = setup.job.servo.tolerance_mm;
    let actual_of =
        |c: &[[f64; 3]], d: &Drive| servo::simulate_until_settled(c, period_s, d, settle_mm);
    let reference = as_written.as_ref().unwrap_or(&command);
    let reference_s = servo::settled_time_s(
        &actual_of(reference, &drive),
        *reference.last().expect("samples"),
        settle_mm,
        period_s,
    );
    let w = weights(&setup.job, reference_s);
    let actual = actual_of(&command, &drive);
    let evaluation = servo::evaluate(&command, &actual, period_s, &w);
    let pre = servo::precompensate(
        &command,
        period_s,
        &drive,
        setup.job.servo.precomp_threshold_mm,
        setup.job.servo.precomp_iterations,
    );
    let compensated_actual = servo::simulate_actual(&pre.command, period_s, &drive);
    let (precomp_traj, _) = servo::trajectory_error_mm(&command, &compensated_actual);

    let mut rows = Vec::new();
    if sweep {
        let base = setup.machine;
        let kp0 = drive.kp_per_s;
        for accel_factor in [0.5, 1.0, 2.0] {
            let accel = base.accel_mm_s2.map(|a| a * accel_factor);
            for jerk in [None, Some(accel.map(|a| a * 20.0))] {
                for kp_factor in [0.5, 1.0, 2.0] {
                    let machine = Machine {
                        accel_mm_s2: accel,
                        jerk_mm_s3: jerk,
                        ..base
                    };
                    let d = Drive {
                        kp_per_s: kp0 * kp_factor,
                        ..drive
                    };
                    let c = commanded(setup, &machine)?;
                    let a = actual_of(&c, &d);
                    rows.push(SweepRow {
                        accel_mm_s2: accel,
                        jerk_mm_s3: jerk,
                        kp_per_s: d.kp_per_s,
                        evaluation: servo::evaluate(&c, &a, period_s, &w),
                    });
                }
            }
        }
    }
    // S2 keeps the parameter set with the largest V.
    let best = rows
        .iter()
        .enumerate()
        .max_by(|a, b| {
            a.1.evaluation
                .evaluation
                .total_cmp(&b.1.evaluation.evaluation)
        })
        .map(|(i, _)| i);

    for (key, v) in [
        ("trajectory error (mm)", evaluation.trajectory_error_mm),
        ("V", evaluation.evaluation),
        ("pre-compensated error (mm)", pre.error_after_mm),
    ] {
        if !v.is_finite() {
            fail!(
                run,
                "the evaluation's {key} is {v}: the inputs give no finite result"
            );
        }
    }
    Ok(DriveEvaluation {
        drive,
        weights: w,
        evaluation,
        actual_mm: actual,
        precomp: pre,
        precomp_trajectory_error_mm: precomp_traj,
        sweep: rows,
        best,
    })
}

/// `dexcut evaluate JOB --out DIR [--servo FILE] [--sweep]`.
pub fn evaluate(
    job_path: &Path,
    out: &Path,
    servo_csv: Option<&Path>,
    sweep: bool,
    settings: Option<&Path>,
    force: bool,
) -> Result<DriveEvaluation> {
    let setup = Setup::load_with(job_path, None, settings)?;
    drive(&setup.job)?;
    if sweep && servo_csv.is_some() {
        fail!(
            request,
            "--sweep re-plans the program, so it cannot be combined with --servo"
        );
    }
    let mut inputs = setup.input_files(job_path);
    inputs.extend(servo_csv.map(Path::to_path_buf));
    inputs.extend(settings.map(Path::to_path_buf));
    let out_dir = crate::output::outdir::OutDir::begin(out, &inputs, force)?;
    let period_s = setup.machine.period_s();
    let ev = evaluate_setup(&setup, servo_csv, sweep)?;
    let pre = &ev.precomp;
    write_positions_csv(&out_dir.path().join("actual.csv"), &ev.actual_mm, period_s)?;
    write_positions_csv(
        &out_dir.path().join("compensated.csv"),
        &pre.command,
        period_s,
    )?;
    let doc = EvaluationDoc {
        job: setup.job.name.clone(),
        drive: format!("{:?}", ev.drive),
        weights: ev.weights,
        evaluation: ev.evaluation,
        precomp_error_before_mm: pre.error_before_mm,
        precomp_error_after_mm: pre.error_after_mm,
        precomp_iterations: pre.iterations,
        precomp_trajectory_error_mm: ev.precomp_trajectory_error_mm,
        sweep: &ev.sweep,
        best: ev.best,
    };
    write_json(&out_dir.path().join("evaluation.json"), &doc)?;
    if let Some(b) = ev.best.map(|i| &doc.sweep[i]) {
        let fragment = Settings {
            machine: MachineSettings {
                accel: b.accel_mm_s2,
                jerk: b.jerk_mm_s3,
            },
            servo: ServoSettings { kp: b.kp_per_s },
        };
        let text = format!(
            "# The best settings of `dexcut evaluate --sweep` by S2's V = {} (largest).\n\
             # Use with `dexcut optimize JOB --settings best.toml` or `dexcut evaluate JOB --settings best.toml`.\n{}",
            fmt(b.evaluation.evaluation),
            fragment.to_toml()?
        );
        export::atomic::write_file(&out_dir.path().join("best.toml"), |w| {
            w.write_all(text.as_bytes())
        })
        .map_err(|e| Error::io("cannot write", &out_dir.path().join("best.toml"), e))?;
    }
    out_dir.commit("evaluate")?;
    Ok(ev)
}
