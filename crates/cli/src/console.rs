//! What the commands print: their typed results formatted for a terminal.
//! stdout carries the results, stderr the warnings; a closed stdout
//! (`dexcut calibrate m.csv | true`) ends the output quietly instead of
//! aborting the command.

use std::io::Write;
use std::path::Path;

use dexcut::commands::{DesignInfo, LimitsOut, Ran, Simulated};
use dexcut::optimize::ToolChipLoad;
use dexcut::summary::OperationsSummary;
use dexcut::{DriveEvaluation, Optimized, StepsFormat, Warnings};

/// Write one line to stdout; a closed or failing stdout is ignored (the
/// results are in files, the console only repeats them).
pub fn line(args: std::fmt::Arguments) {
    let mut out = std::io::stdout().lock();
    let _ = out.write_fmt(args).and_then(|()| out.write_all(b"\n"));
}

/// `println!` that does not panic on a closed pipe.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::console::line(format_args!($($arg)*))
    };
}

/// A warning told at once, before or during the work.
pub fn warning(w: &dyn std::fmt::Display) {
    eprintln!("warning: {w}");
}

/// The warnings found by the work (those of the set-up were told before it),
/// each prefixed by `label` when given.
pub fn warnings_after_work(warnings: &Warnings, label: &str) {
    for w in warnings.iter().filter(|w| !w.of_setup()) {
        if label.is_empty() {
            eprintln!("warning: {w}");
        } else {
            eprintln!("warning ({label}): {w}");
        }
    }
}

/// How a stock too large for the memory budget was swept, if it was.
fn banded(banded: Option<&dexcut::commands::Banded>) {
    if let Some(b) = banded {
        outln!(
            "the stock's {}×{} columns exceed the memory budget of {:.0} MB: swept in {} bands of {} rows",
            b.nx, b.ny, b.budget_mb, b.bands, b.band_rows
        );
    }
}

/// The simulate results: the bands of a large stock, the design comparison,
/// the headline line, then the warnings.
/// What `simulate` made: one program's results, or each operation's and the
/// job's totals.
pub fn simulated(ran: &Ran<Simulated>, out: &Path, asked: StepsFormat) {
    match ran {
        Ran::Program(simulated) => simulate(simulated, out, asked),
        Ran::Operations(seq) => {
            for (folder, simulated) in &seq.operations {
                outln!("{folder}:");
                simulate(simulated, &out.join(folder), asked);
            }
            operations(&seq.summary, out);
        }
    }
    if let Some(stock) = saved_stock(ran, |s| s.summary.saved_stock.as_ref()) {
        saved_stock_line(stock, out);
    }
}

/// What `optimize` made: one program's results, or each operation's and the
/// job's totals.
pub fn optimized(ran: &Ran<Optimized>, out: &Path, asked: StepsFormat) {
    match ran {
        Ran::Program(optimized) => optimize(optimized, out, asked),
        Ran::Operations(seq) => {
            for (folder, optimized) in &seq.operations {
                outln!("{folder}:");
                optimize(optimized, &out.join(folder), asked);
            }
            operations(&seq.summary, out);
        }
    }
    if let Some(stock) = saved_stock(ran, |o| o.summary.saved_stock.as_ref()) {
        saved_stock_line(stock, out);
    }
}

/// The saved stock's document of a run that wrote one (`--save-stock`).
fn saved_stock<'a, T>(
    ran: &'a Ran<T>,
    of: impl Fn(&'a T) -> Option<&'a dexcut::saved_stock::SavedStockDoc>,
) -> Option<&'a dexcut::saved_stock::SavedStockDoc> {
    match ran {
        Ran::Program(t) => of(t),
        Ran::Operations(seq) => seq.operations.last().and_then(|(_, t)| of(t)),
    }
}

fn saved_stock_line(stock: &dexcut::saved_stock::SavedStockDoc, out: &Path) {
    outln!(
        "stock saved in {}: {} columns, {} intervals, {:.1} mm³; stock.stl {} triangles (a job reads it back with [stock] kind = \"saved\")",
        out.join("stock").display(),
        stock.columns,
        stock.intervals,
        stock.volume_mm3,
        stock.stl_triangles
    );
}

/// The whole job's lines of a job of operations.
fn operations(doc: &OperationsSummary, out: &Path) {
    outln!("operations ({}):", doc.ran);
    outln!(
        "{:<4}{:<24}{:>12}{:>12}{:>14}{:>11}{:>10}",
        "",
        "operation",
        "as given s",
        "cycle s",
        "removed mm³",
        "force N",
        "defl µm"
    );
    for op in &doc.operations {
        outln!(
            "{:<4}{:<24}{:>12}{:>12.3}{:>14.1}{:>11.1}{:>10.1}",
            op.number,
            op.name,
            op.cycle_time_before_s
                .map_or("-".into(), |t| format!("{t:.3}")),
            op.cycle_time_s,
            op.removed_volume_mm3,
            op.peak_force_n,
            op.peak_deflection_um
        );
    }
    outln!(
        "{:<4}{:<24}{:>12}{:>12.3}{:>14.1}",
        "",
        "total",
        doc.cycle_time_before_s
            .map_or("-".into(), |t| format!("{t:.3}")),
        doc.cycle_time_s,
        doc.removed_volume_mm3
    );
    outln!(
        "stock {:.1} mm³ before, {:.1} mm³ after; results in {}",
        doc.initial_volume_mm3,
        doc.final_volume_mm3,
        out.display()
    );
}

pub fn simulate(simulated: &Simulated, out: &Path, asked: StepsFormat) {
    banded(simulated.banded.as_ref());
    let doc = &simulated.summary;
    if let Some(info) = &doc.design {
        line_deviations(info);
    }
    let summary = &doc.run;
    outln!(
        "removed {:.1} mm³ of {:.1} mm³ in {} steps; cycle {:.2} s; peak MRR {:.2} mm³/s, force {:.1} N, power {:.3} kW, deflection {:.1} µm{}; error {:.1}…{:.1} µm; results in {}",
        summary.removed_volume_mm3,
        summary.initial_volume_mm3,
        summary.steps,
        summary.cycle_time_s,
        summary.peak_mrr_mm3_s,
        summary.peak_force_n,
        summary.peak_power_w / 1000.0,
        summary.peak_deflection_um,
        at_rupture(summary),
        summary.min_error_um,
        summary.max_error_um,
        out.display()
    );
    if let Some(exact_stop_s) = doc.exact_stop_time_s {
        outln!(
            "{}",
            exact_stop_line(exact_stop_s, summary.cycle_time_s, "the program")
        );
    }
    steps_format(asked, simulated.steps_format, summary.steps, &["steps"]);
    warnings_after_work(&summary.warnings, "");
}

/// The exact-stop time beside a run's cycle time (MODEL.md §6.1, "Exact stop").
fn exact_stop_line(exact_stop_s: f64, cycle_s: f64, what: &str) -> String {
    // Rounding's −0.0 % read as 0.0 %.
    let change_pct = 100.0 * (cycle_s / exact_stop_s - 1.0);
    let change_pct = if change_pct.abs() < 0.05 {
        0.0
    } else {
        change_pct
    };
    format!(
        "Stopping at every corner (exact stop: every segment from rest to rest at its feed and acceleration), {what} would take {exact_stop_s:.3} s; it takes {cycle_s:.3} s ({change_pct:+.1} %)."
    )
}

/// What the console adds to a peak deflection capped where the tool breaks
/// (MODEL.md §4.4).
fn at_rupture(summary: &dexcut::summary::Summary) -> String {
    if summary.peak_deflection_at_rupture {
        format!(
            " (capped at breaking: the tool breaks at {} steps, tool_breaks)",
            summary.tool_breaks_steps
        )
    } else {
        String::new()
    }
}

/// Say so when `--steps-format auto` wrote the steps as `.npy` arrays.
fn steps_format(asked: StepsFormat, written: StepsFormat, steps: usize, stems: &[&str]) {
    if asked == StepsFormat::Auto && written == StepsFormat::Npy {
        let files: Vec<String> = stems
            .iter()
            .map(|s| format!("{s}.json and {s}_*.npy"))
            .collect();
        outln!(
            "{steps} steps, more than {}: the per-step results are written as NumPy arrays ({}, one array per column) instead of CSV; --steps-format csv writes the CSV",
            dexcut::AUTO_NPY_STEPS,
            files.join("; ")
        );
    }
}

/// The evaluate results: the score, the pre-compensation, the sweep table.
pub fn evaluate(ev: &DriveEvaluation, out: &Path) {
    let e = &ev.evaluation;
    let (pre, precomp_traj) = (&ev.precomp, ev.precomp_trajectory_error_mm);
    outln!(
        "trajectory error {:.4} mm, time {:.3} s, max jerk [{:.0}, {:.0}, {:.0}] mm/s³, V = {:.4} (Va {:.3}, Vb {:.3}, Vc {:.3})",
        e.trajectory_error_mm, e.machining_time_s, e.max_jerk_mm_s3[0], e.max_jerk_mm_s3[1], e.max_jerk_mm_s3[2], e.evaluation, e.va, e.vb, e.vc
    );
    outln!(
        "pre-compensation: sample error {:.4} → {:.4} mm in {} iterations (trajectory error {:.4} mm)",
        pre.error_before_mm, pre.error_after_mm, pre.iterations, precomp_traj
    );
    if !ev.sweep.is_empty() {
        outln!(
            "{:>10} {:>10} {:>7} {:>10} {:>9} {:>12} {:>8}",
            "accel",
            "jerk",
            "kp",
            "error_mm",
            "time_s",
            "jerk_mm_s3",
            "V"
        );
        for (i, r) in ev.sweep.iter().enumerate() {
            let e = &r.evaluation;
            outln!(
                "{:>10.0} {:>10} {:>7.1} {:>10.4} {:>9.3} {:>12.0} {:>8.4}{}",
                r.accel_mm_s2[0],
                r.jerk_mm_s3
                    .map_or("none".to_string(), |j| format!("{:.0}", j[0])),
                r.kp_per_s,
                e.trajectory_error_mm,
                e.machining_time_s,
                e.max_jerk_mm_s3.iter().fold(0.0f64, |m, v| m.max(*v)),
                e.evaluation,
                if Some(i) == ev.best { "  <- best" } else { "" }
            );
        }
    }
    outln!("results in {}", out.display());
}

/// The fit of `calibrate`: its quality, then the `[cutting]` fragment.
pub fn calibrate(fit: &dexcut::commands::Calibration, out: Option<&Path>) {
    use dexcut::commands::Calibration;
    match fit {
        Calibration::PowerLaw(fit) => {
            outln!("F = a·V^n fitted to {} points:", fit.points);
            outln!("  force_a = {:.6}", fit.a);
            outln!("  force_n = {:.6}", fit.n);
            outln!(
                "  rms error: {:.4} (log), {:.2} % (relative)",
                fit.rms_log_error,
                100.0 * fit.rms_rel_error
            );
        }
        Calibration::Kienzle(fit) => {
            let q = &fit.kc_quality;
            let source = match fit.kc_source {
                cutting::calibration::KcSource::Power => "the spindle power",
                cutting::calibration::KcSource::Forces => "the x and y forces",
            };
            outln!(
                "kc = kc1_1·h_m^-mc fitted to {} cuts (kc from {source}): rms error {:.2} %, R² {:.4}",
                q.points,
                100.0 * q.rms_rel_error,
                q.r_squared
            );
            if let Some(q) = &fit.force_quality {
                outln!(
                    "mean forces fitted on {} cuts: rms error {:.2} % of |F|, R² {:.4}",
                    q.points,
                    100.0 * q.rms_rel_error,
                    q.r_squared
                );
            }
        }
    }
    outln!("put these keys into the job's [cutting] section:");
    for line in fit.fragment().lines() {
        outln!("{line}");
    }
    if let Some(out) = out {
        outln!("wrote {}", out.display());
    }
}

/// The folder `example` wrote and how to run it.
pub fn example(dir: &Path, job: &Path) {
    outln!(
        "wrote the boss_contour example to {}; run it with: dexcut optimize {}",
        dir.display(),
        job.display()
    );
}

/// The report `report` wrote.
pub fn report(files: &dexcut::ReportFiles) {
    outln!("wrote {}", files.html.display());
}

/// Lines to print on the console before "and K more".
const PRINTED_LINES: usize = 20;

/// The per-line design comparison on the console (S1).
pub fn line_deviations(info: &DesignInfo) {
    outln!(
        "design: {} program line(s) beyond tolerance (gouge > {} µm, stock > {} µm){}",
        info.lines.len(),
        info.gouge_tolerance_um,
        info.stock_tolerance_um,
        if info.uncut_stock_columns > 0 {
            format!(", {} uncut columns with stock", info.uncut_stock_columns)
        } else {
            String::new()
        }
    );
    for l in info.lines.iter().take(PRINTED_LINES) {
        outln!(
            "  line {}: {} {:.1} µm at ({:.3}, {:.3}) mm, {} columns",
            l.line,
            l.kind,
            l.worst_um,
            l.x_mm,
            l.y_mm,
            l.columns
        );
    }
    if info.lines.len() > PRINTED_LINES {
        outln!("  and {} more", info.lines.len() - PRINTED_LINES);
    }
}

/// Every tool's chip-load cap for the console's limits line: "chip load
/// 0.0250 mm/tooth = 500 mm/min at S10000 on cutting moves" for one tool,
/// "chip load on cutting moves: T1 …, T2 …" for several.
fn chip_load_text(limits: &LimitsOut) -> Option<String> {
    let each = |c: &ToolChipLoad| {
        format!(
            "{:.4} mm/tooth = {:.0} mm/min at {:.0} rev/min",
            c.fz_max_mm, c.feed_mm_min, c.spindle_rpm
        )
    };
    match limits.chip_load.as_slice() {
        [] => None,
        [c] => Some(format!("chip load {} on cutting moves", each(c))),
        all => Some(format!(
            "chip load on cutting moves: {}",
            all.iter()
                .map(|c| format!("T{} {}", c.tool, each(c)))
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The optimize results on the console.
pub fn optimize(optimized: &Optimized, out: &Path, asked: StepsFormat) {
    banded(optimized.banded.as_ref());
    let doc = &optimized.summary;
    if let Some(info) = &doc.design {
        line_deviations(info);
    }
    let precomp = &optimized.precomp;
    let lower_bound_time_s = doc.lower_bound_time_s;
    let (b, a) = (&doc.before, &doc.after);
    let after_label = if doc.kept_original {
        "after (kept)"
    } else {
        "optimized.nc"
    };
    outln!("{:<24}{:>12}{:>14}", "", "as given", after_label);
    let row = |name: &str, x: f64, y: f64, d: usize| {
        outln!("{name:<24}{x:>12.d$}{y:>14.d$}");
    };
    row("cycle time (s)", b.cycle_time_s, a.cycle_time_s, 3);
    row("peak MRR per period", b.peak_mrr_mm3_s, a.peak_mrr_mm3_s, 3);
    row(
        "  (mm³/s) over ≥ 48 ms",
        b.peak_mrr_windowed_mm3_s,
        a.peak_mrr_windowed_mm3_s,
        3,
    );
    row("peak force (N)", b.peak_force_n, a.peak_force_n, 2);
    row(
        "  over a revolution (N)",
        b.peak_force_revolution_n,
        a.peak_force_revolution_n,
        2,
    );
    row(
        "peak deflection (µm)",
        b.peak_deflection_um,
        a.peak_deflection_um,
        2,
    );
    for (label, s) in [("as given", b), (after_label, a)] {
        if s.peak_deflection_at_rupture {
            outln!("  {label}: peak deflection{}", at_rupture(s));
        }
    }
    row(
        "top cutting feed (mm/min)",
        b.peak_cutting_feed_mm_min,
        a.peak_cutting_feed_mm_min,
        0,
    );
    let limits_text: Vec<String> = [
        doc.limits
            .mrr_max_mm3_s
            .map(|v| format!("mrr_max {v} mm³/s")),
        doc.limits.force_max_n.map(|v| format!("force_max {v} N")),
        doc.limits
            .deflection_max_um
            .map(|v| format!("deflection_max_um {v}")),
        chip_load_text(&doc.limits),
        doc.limits
            .feed_scale_max
            .map(|v| format!("feed_scale_max {v}")),
        doc.limits
            .stress_limit_mpa
            .filter(|v| v.is_finite())
            .map(|v| format!("stress_limit_mpa {v} MPa")),
    ]
    .into_iter()
    .flatten()
    .collect();
    outln!("limits: {}", limits_text.join(", "));
    let tolerance_pct = 100.0 * dexcut::optimize::LIMIT_TOLERANCE;
    if doc.kept_original {
        outln!(
            "time change {:+.1} %. The program as given is within every limit (to their {tolerance_pct:.0} % tolerance) and faster than the re-timing, whose plan would take {:.3} s after {} round(s): optimized.nc is the original, and the numbers after are it read back and simulated as a program of its own.",
            100.0 * (a.cycle_time_s / b.cycle_time_s - 1.0),
            doc.plan_time_s,
            doc.rounds,
        );
    } else {
        outln!(
            "time change {:+.1} %. The numbers after are optimized.nc read back and simulated as a program of its own ({} round(s)); the plan it was written from takes {:.3} s ({:+.2} %); with the feed free to change every 0.05 mm it would take {:.3} s.",
            100.0 * (a.cycle_time_s / b.cycle_time_s - 1.0),
            doc.rounds,
            doc.plan_time_s,
            100.0 * doc.written_vs_plan,
            doc.time_optimal_s,
        );
    }
    let bound = format!(
        "No timing under these limits can beat {lower_bound_time_s:.3} s (every point at its highest allowed feed, no time to speed up or slow down)"
    );
    // A plan at its bound (every corner a stop, no cap) may sit a rounding below it.
    if doc.optimality_gap >= -1e-9 {
        outln!(
            "{bound}; the {:.1} % above it is acceleration, corners and arcs.",
            100.0 * doc.optimality_gap.max(0.0),
        );
    } else {
        // Only a program that runs over a limit, within its tolerance, is faster.
        outln!(
            "{bound}; optimized.nc takes {:.1} % less by running over a limit, within its {tolerance_pct:.0} % tolerance.",
            -100.0 * doc.optimality_gap,
        );
    }
    if let Some(exact_stop_s) = doc.exact_stop_time_s {
        outln!(
            "{}",
            exact_stop_line(exact_stop_s, b.cycle_time_s, "the program as given")
        );
    }
    let shares: Vec<String> = doc
        .cap_time_share
        .iter()
        .map(|c| format!("{} {:.0} %", c.cap, 100.0 * c.share))
        .collect();
    outln!("time held by: {}", shares.join(", "));
    if let Some(pre) = &precomp {
        outln!(
            "servo_compensated.csv: drive error {:.4} mm before, {:.2e} mm after pre-compensation ({} corrections)",
            pre.error_before_mm,
            pre.error_after_mm,
            pre.iterations
        );
    }
    outln!("results in {}", out.display());
    steps_format(
        asked,
        optimized.steps_format,
        doc.before.steps.max(doc.after.steps),
        &["steps", "steps_before"],
    );
    warnings_after_work(&doc.before.warnings, "program");
    warnings_after_work(&doc.after.warnings, "optimised");
}
