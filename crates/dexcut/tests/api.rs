//! The library API end to end: load → simulate → optimize → report, with
//! summary.json read back through its types, checked against exact answers.

use dexcut::summary::{self, SummaryDoc};

/// A box, a Ø6 flat end mill, a G-code slot 2 mm deep and 100 mm long.
const JOB: &str = r#"
[stock]
kind = "box"
min = [0, -20, 0]
max = [100, 20, 30]
grid = 0.1
[tool]
kind = "flat"
diameter = 6
[program]
path = "slot.nc"
[machine]
feed_max = 3000
[limits]
mrr_max = 20
"#;

const SLOT: &str = "G21 G90 G17\nG0 X-10 Y0 Z35\nG0 Z28\nG1 X110 F1200\nG0 Z35\nM2\n";

fn job_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), JOB).unwrap();
    std::fs::write(dir.path().join("slot.nc"), SLOT).unwrap();
    dir
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn simulate_returns_typed_results_and_writes_nothing() {
    let dir = job_dir();
    let setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
    let sim = dexcut::simulate(&setup, false).unwrap();
    // The tool enters at X-10 and leaves at X110: a straight slot 6 wide × 2 deep × 100 long.
    let exact = 6.0 * 2.0 * 100.0;
    assert!(
        rel(sim.summary.removed_volume_mm3, exact) < 2e-3,
        "removed {} vs {exact}",
        sim.summary.removed_volume_mm3
    );
    let s = &sim.summary;
    assert!((s.initial_volume_mm3 - 120_000.0).abs() < 1e-6);
    assert!(
        (s.initial_volume_mm3 - s.final_volume_mm3 - s.removed_volume_mm3).abs() < 1e-6 * 1.2e5
    );
    assert_eq!(sim.run.steps.len(), s.steps);
    // simulate wrote nothing.
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["job.toml", "slot.nc"]);
    // ... until asked.
    let out = dir.path().join("files");
    std::fs::create_dir(&out).unwrap();
    // Short: steps.csv (StepsFormat::Auto writes .npy arrays above AUTO_NPY_STEPS steps).
    assert_eq!(
        sim.write_files(&out, true, dexcut::StepsFormat::Auto)
            .unwrap(),
        dexcut::StepsFormat::Csv
    );
    for f in ["steps.csv", "columns.json", "columns.csv"] {
        assert!(out.join(f).is_file(), "{f}");
    }
}

#[test]
fn optimize_report_and_summary_agree() {
    let dir = job_dir();
    let mut setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
    let out = dir.path().join("out");
    let loaded = setup.program.path.clone();
    assert!(!loaded.segments.is_empty());
    let optimized = dexcut::optimize(&mut setup, &out, false).unwrap();
    // The path lent to the planner (and to the re-feed, then read again from
    // the text) is back in the setup, as loaded, bit for bit.
    assert_eq!(format!("{:?}", setup.program.path), format!("{loaded:?}"));
    let doc = &optimized.summary;
    // MRR of a full slot is width × depth × feed: 12 mm² × 20 mm/s = 240 mm³/s
    // as given; under mrr_max = 20 the feed falls to 20/12 mm/s = 100 mm/min.
    assert!(
        rel(doc.before.peak_mrr_windowed_mm3_s, 240.0) < 0.02,
        "{}",
        doc.before.peak_mrr_windowed_mm3_s
    );
    assert!(
        doc.after.peak_mrr_windowed_mm3_s <= 20.0 * 1.02,
        "{}",
        doc.after.peak_mrr_windowed_mm3_s
    );
    assert!(doc.after.cycle_time_s > doc.before.cycle_time_s);
    assert_eq!(doc.limits.mrr_max_mm3_s, Some(20.0));
    // The file says what the API returned, through the same types.
    let SummaryDoc::Optimize(back) = summary::read(&out.join("summary.json")).unwrap() else {
        panic!("not an optimize summary");
    };
    assert_eq!(back.after.cycle_time_s, doc.after.cycle_time_s);
    assert_eq!(
        back.before.removed_volume_mm3,
        doc.before.removed_volume_mm3
    );
    assert_eq!(back.run_id, doc.run_id);
    let files = dexcut::report(&out).unwrap();
    for f in [&files.html, &files.error_map_png, &files.stock_glb] {
        assert!(f.is_file(), "{}", f.display());
    }
    assert!(files.design_map_png.is_none());
    let html = std::fs::read_to_string(&files.html).unwrap();
    assert!(html.contains("slot.nc"));
}

/// A G-code program's path read again from its text
/// (`Setup::program_path_again`, what optimize does after handing the path
/// to the re-feed) is the path loaded, bit for bit (every f64 in its
/// shortest round-trip form, −0 apart from 0): a machine whose Z points
/// down, a start given or found, arcs as lines, cutter compensation and a
/// file read tolerantly (a byte-order mark, no program end).
#[test]
fn a_program_path_read_again_is_the_one_loaded_bit_for_bit() {
    let arcs = "G21 G90 G17\nG0 X-10 Y0 Z35\nG0 Z28\nG1 X50 F1200\nG2 X60 Y10 I0 J10\nG1 X110\nG0 Z35\nM2\n";
    let comp =
        "G0 X-10 Y-10 Z35\nG0 Z28\nG41 G1 X0 Y0 F1200\nX50\nY10\nG40 G1 X60 Y20\nG0 Z35\nM2\n";
    let tolerant = "\u{feff}G0 X-10 Y0 Z35\nG0 Z28\nG1 X110 F1200\nG3 X100 Y10 I-10 J0\n";
    let down = arcs.replace("Z35", "Z-35").replace("Z28", "Z-28");
    let cases = [
        (arcs, ""),
        (arcs, "start = [0, 0, 40]"),
        (arcs, "block_time_ms = 2\narcs_as_lines = true"),
        (down.as_str(), "z_axis = \"down\""),
        (comp, ""),
        (tolerant, ""),
    ];
    for (program, machine) in cases {
        let dir = job_dir();
        std::fs::write(dir.path().join("slot.nc"), program).unwrap();
        let job = JOB.replace("feed_max = 3000", &format!("feed_max = 3000\n{machine}"));
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        let setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
        let again = setup.program_path_again().unwrap();
        assert!(!again.segments.is_empty());
        assert_eq!(
            format!("{again:?}"),
            format!("{:?}", setup.program.path),
            "{machine}: {program}"
        );
    }
}

/// The process engineer's report of a 100 000-step program: under 3 MB, one
/// column of values for a simulation, the set-up table, and hot spots whose
/// program-line links reach the quoted program text.
#[test]
fn report_of_a_100k_step_program_is_small_and_linked() {
    let dir = tempfile::tempdir().unwrap();
    // A zigzag of 100 000 short moves (CSV points: one step per move), 1 mm deep.
    let mut csv = String::from("x,y,z\n");
    let n = 100_000;
    for k in 0..=n {
        let row = k / 1000;
        let along = (k % 1000) as f64 * 0.038;
        let x = if row % 2 == 0 {
            1.0 + along
        } else {
            39.0 - along
        };
        csv.push_str(&format!("{x:.4},{:.4},29\n", 1.0 + 0.38 * row as f64));
    }
    std::fs::write(dir.path().join("zigzag.csv"), csv).unwrap();
    std::fs::write(
        dir.path().join("job.toml"),
        r#"
[stock]
kind = "box"
min = [0, 0, 0]
max = [40, 40, 30]
grid = 0.25
[tool]
kind = "flat"
diameter = 2
[program]
path = "zigzag.csv"
feed = 600
[cutting]
material = "al6061"
"#,
    )
    .unwrap();
    let out = dir.path().join("out");
    let warned = std::cell::Cell::new(0);
    let on_warning = |_: &dyn std::fmt::Display| warned.set(warned.get() + 1);
    let opts = dexcut::commands::RunOptions {
        grid_mm: None,
        force: false,
        columns_csv: false,
        steps_format: dexcut::StepsFormat::Auto,
        memory_budget_mb: None,
        save_stock: false,
        on_warning: &on_warning,
    };
    let dexcut::commands::Ran::Program(simulated) = dexcut::commands::simulate(
        dexcut::commands::JobArg::File(&dir.path().join("job.toml")),
        &out,
        false,
        &opts,
    )
    .unwrap() else {
        panic!("a job of one program");
    };
    let doc = match summary::read(&out.join("summary.json")).unwrap() {
        SummaryDoc::Simulate(s) => s,
        _ => panic!("not a simulate summary"),
    };
    assert_eq!(doc.run.steps, n);
    // The command returns the document it wrote, and told each set-up warning once.
    assert_eq!(simulated.summary.run.steps, n);
    assert_eq!(simulated.summary.run_id, doc.run_id);
    assert!(simulated.banded.is_none());
    let setup_warnings = doc.run.warnings.iter().filter(|w| w.of_setup()).count();
    assert_eq!(warned.get(), setup_warnings);
    let files = dexcut::report(&out).unwrap();
    let html = std::fs::read_to_string(&files.html).unwrap();
    let size = html.len();
    eprintln!("report.html of {n} steps: {size} bytes");
    assert!(size < 3_000_000, "report.html is {size} bytes");
    // A simulation: one column of values, no lone "before".
    assert!(html.contains("<th>value</th>") && !html.contains("<th>before</th>"));
    // The set-up table names the material and the tool.
    assert!(html.contains("al6061") && html.contains("flat Ø2 mm"));
    // Hot spots: the largest force is a step of the program; its line link has
    // the quoted program line as target.
    assert!(html.contains("largest force"));
    let links: Vec<&str> = html
        .match_indices("href=\"#line-")
        .map(|(i, _)| {
            let rest = &html[i + "href=\"#line-".len()..];
            &rest[..rest.find('"').unwrap()]
        })
        .collect();
    assert!(!links.is_empty(), "no hot-spot links to program lines");
    for l in links {
        assert!(
            html.contains(&format!("id=\"line-{l}\"")),
            "line {l} not quoted"
        );
    }
    // Marks on the map link back to the hot-spot rows.
    assert!(html.contains("class=\"mark\" href=\"#hot-1\""));
    assert!(html.contains("X (mm)"));
}

/// The typed evaluate API: the program as written is S2's time reference, so
/// it scores Vb = 1/2 exactly; the estimated motion has one sample per servo
/// period and ends at the program's end; the sweep's best row has the largest
/// V; and the command `evaluate` writes the same numbers to evaluation.json.
#[test]
fn evaluate_returns_typed_results() {
    let dir = job_dir();
    let job = dir.path().join("job.toml");
    let setup = dexcut::load(&job, None).unwrap();
    let e = dexcut::evaluate(&setup, true).unwrap();
    assert_eq!(e.evaluation.vb, 0.5);
    // The motion runs until it settles near the program's end (X110 Z35),
    // stopping at the last sample outside the tolerance.
    let end = *e.actual_mm.last().unwrap();
    let miss_mm = (end[0] - 110.0).hypot(end[1]).hypot(end[2] - 35.0);
    assert!(miss_mm < 10.0 * e.weights.tolerance_mm, "{end:?}");
    assert!(e.precomp.error_after_mm <= e.precomp.error_before_mm);
    assert_eq!(e.sweep.len(), 18);
    let best = &e.sweep[e.best.unwrap()];
    assert!(e
        .sweep
        .iter()
        .all(|r| r.evaluation.evaluation <= best.evaluation.evaluation));
    let out = dir.path().join("eval");
    dexcut::commands::evaluate(&job, &out, None, false, None, false).unwrap();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("evaluation.json")).unwrap())
            .unwrap();
    assert_eq!(
        doc["trajectory_error_mm"].as_f64(),
        Some(e.evaluation.trajectory_error_mm)
    );
    assert_eq!(doc["evaluation"].as_f64(), Some(e.evaluation.evaluation));
    let rows = std::fs::read_to_string(out.join("actual.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + e.actual_mm.len());
}

/// The API's errors are typed by kind of failure and keep their cause: a bad
/// job key is a `Job` error naming the file, line and column; a program the
/// reader refuses is a `Program` error with every diagnostic at its line and
/// column; a missing program file is an `Io` error naming the path with the
/// I/O error as its source; a folder without results is a `Results` error
/// naming summary.json, whose source is the I/O error.
#[test]
fn api_errors_name_their_kind_place_and_source() {
    let dir = job_dir();
    let job = dir.path().join("job.toml");
    std::fs::write(
        &job,
        JOB.replace("feed_max = 3000", "feed_max = 3000\nspeed = 1"),
    )
    .unwrap();
    match dexcut::load(&job, None) {
        Err(e @ dexcut::Error::Job { .. }) => {
            let at = format!(
                "{}:14:1: machine.speed: unknown field `speed`",
                job.display()
            );
            assert!(e.to_string().starts_with(&at), "{e}");
            assert_eq!(e.chain_message(), e.to_string());
        }
        other => panic!("{:?}", other.err()),
    }
    std::fs::write(&job, JOB).unwrap();
    let program = dir.path().join("slot.nc");
    let good = std::fs::read_to_string(&program).unwrap();
    std::fs::write(&program, format!("G1 X1 Q\n{good}")).unwrap();
    match dexcut::load(&job, None) {
        Err(dexcut::Error::Program { diagnostics }) => {
            assert!(!diagnostics.is_empty());
            assert!(
                diagnostics[0].to_string().contains("slot.nc:1:"),
                "{diagnostics:?}"
            );
        }
        other => panic!("{:?}", other.err()),
    }
    std::fs::remove_file(&program).unwrap();
    match dexcut::load(&job, None) {
        Err(e @ dexcut::Error::Io { .. }) => {
            let source = std::error::Error::source(&e).expect("the I/O error is kept");
            assert!(
                source.downcast_ref::<std::io::Error>().is_some(),
                "{source:?}"
            );
            assert!(e.to_string().contains("slot.nc"), "{e}");
        }
        other => panic!("{:?}", other.err()),
    }
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    match dexcut::report(&empty) {
        Err(e) => {
            assert!(e.chain_message().contains("summary.json"), "{e}");
            let mut cause: &dyn std::error::Error = &e;
            while let Some(next) = cause.source() {
                cause = next;
            }
            assert!(
                cause.downcast_ref::<std::io::Error>().is_some(),
                "{cause:?}"
            );
        }
        other => panic!("{:?}", other.err()),
    }
}
