//! A shop's job (issue 40): `[[operations]]` run in order on one stock, the
//! stock saved (`--save-stock`) and resumed (`[stock] kind = "saved"`), and
//! its STL. On examples/three_operations (a Ø8 flat end's trochoidal
//! roughing, a Ø6 bull nose's semi-finish and a Ø6 ball end's finish of one
//! trough, 64 000 blocks).

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{assert_refused, run};

fn example_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/three_operations")
        .canonicalize()
        .unwrap()
}

/// The example job's text with its programs' paths made absolute and only
/// the operations `keep` (by name) left, its stock replaced by `stock` when given.
fn job_text(keep: &[&str], stock: Option<&str>) -> String {
    let text = std::fs::read_to_string(example_dir().join("job.toml")).unwrap();
    let dir = example_dir();
    let (head, ops) = text.split_at(text.find("[[operations]]").unwrap());
    let mut head = head.to_string();
    if let Some(stock) = stock {
        let start = head.find("[stock]").unwrap();
        let end = start + head[start..].find("\n\n").unwrap();
        head.replace_range(start..end, stock);
    }
    let ops: String = ops
        .split("[[operations]]")
        .filter(|op| keep.iter().any(|k| op.contains(&format!("name = \"{k}\""))))
        .map(|op| {
            let op = op.replace("program = \"", &format!("program = \"{}/", dir.display()));
            format!("[[operations]]{op}")
        })
        .collect();
    format!("{head}{ops}")
}

fn run_ok(args: &[&str], cwd: &Path) -> String {
    let o = run(args, cwd);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "dexcut {args:?}: {err}");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The whole example simulated once with its stock saved, shared by the tests.
fn simulated_example() -> &'static Path {
    static RUN: OnceLock<tempfile::TempDir> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let job = example_dir().join("job.toml");
        let out = dir.path().join("out");
        run_ok(
            &[
                "simulate",
                job.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--save-stock",
            ],
            dir.path(),
        );
        dir
    })
    .path()
    .join("out")
    .leak()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn f32s(path: &Path) -> Vec<f32> {
    let npy = export::parse_npy(&std::fs::read(path).unwrap()).unwrap();
    npy.data.to_f64().into_iter().map(|v| v as f32).collect()
}

/// Every file of `a` equals `b`'s byte for byte, but summary.json and
/// manifest.json, which are compared without their run id, run time and job path.
fn assert_same_files(a: &Path, b: &Path) {
    let mut names: Vec<_> = std::fs::read_dir(a)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    let mut b_names: Vec<_> = std::fs::read_dir(b)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    b_names.sort();
    assert_eq!(names, b_names, "{} and {}", a.display(), b.display());
    for name in names {
        let (pa, pb) = (a.join(&name), b.join(&name));
        if name == "summary.json" || name == "manifest.json" {
            let strip = |mut v: serde_json::Value| {
                // The timings, the run id, the job's path, and the manifest's
                // size of summary.json (its timings' digits).
                for k in [
                    "run_id",
                    "run_time_s",
                    "job",
                    "sweep_time_s",
                    "time_engagement_s",
                    "time_plan_s",
                    "time_simulate_s",
                    "summary.json",
                ] {
                    strip_key(&mut v, k);
                }
                v
            };
            assert_eq!(strip(json(&pa)), strip(json(&pb)), "{}", pa.display());
        } else {
            assert!(
                std::fs::read(&pa).unwrap() == std::fs::read(&pb).unwrap(),
                "{} differs from {}",
                pa.display(),
                pb.display()
            );
        }
    }
}

fn strip_key(v: &mut serde_json::Value, key: &str) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove(key);
            m.values_mut().for_each(|v| strip_key(v, key));
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(|v| strip_key(v, key)),
        _ => {}
    }
}

/// The example's first `n` programs joined into one by their tool changes,
/// with a [[tools]] table, simulated into `dir/joined{n}` with its stock saved.
fn joined_program(dir: &Path, n: usize) -> PathBuf {
    let ex = example_dir();
    let mut joined = String::new();
    let names = ["rough.nc", "semi.nc", "finish.nc"];
    for (i, name) in names[..n].iter().enumerate() {
        for line in std::fs::read_to_string(ex.join(name)).unwrap().lines() {
            if line == "%" || (line == "M30" && i + 1 < n) {
                continue;
            }
            joined.push_str(line);
            joined.push('\n');
        }
    }
    std::fs::write(dir.join(format!("joined{n}.nc")), joined).unwrap();
    let text = std::fs::read_to_string(ex.join("job.toml")).unwrap();
    let head = &text[..text.find("[[operations]]").unwrap()];
    let tools = [
        "[[tools]]\nnumber = 1\nkind = \"flat\"\ndiameter = 8\nflute_length = 20\nstickout = 35\nflutes = 3\n",
        "[[tools]]\nnumber = 2\nkind = \"bull\"\ndiameter = 6\ncorner_radius = 1\nflute_length = 15\nstickout = 30\nflutes = 4\n",
        "[[tools]]\nnumber = 3\nkind = \"ball\"\ndiameter = 6\nflute_length = 12\nstickout = 30\nflutes = 2\n",
    ];
    let job = format!(
        "{head}[program]\npath = \"joined{n}.nc\"\n{}",
        tools[..n].concat()
    );
    let name = format!("joined{n}.toml");
    std::fs::write(dir.join(&name), job).unwrap();
    let out = format!("joined{n}");
    run_ok(&["simulate", &name, "--out", &out, "--save-stock"], dir);
    dir.join(out)
}

/// Three operations give the removal, final stock and error map of one
/// program with the three parts joined by tool changes (T2 M6, T3 M6) and a
/// [[tools]] table. The first operation runs the joined program's first
/// steps and is its first tool's to 1e-4; the later ones start from
/// their own programs' start, so their servo samples fall elsewhere on the
/// same path: the stocks differ by the chords of samples across the path's
/// corners, at most a few µm.
#[test]
fn three_operations_equal_one_program_joined_by_tool_changes() {
    let ops = simulated_example();
    let dir = tempfile::tempdir().unwrap();
    let one = joined_program(dir.path(), 3);

    let (jo, jp) = (
        json(&ops.join("summary.json")),
        json(&one.join("summary.json")),
    );
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    let removed = (
        jo["removed_volume_mm3"].as_f64().unwrap(),
        jp["removed_volume_mm3"].as_f64().unwrap(),
    );
    let finals = (
        jo["final_volume_mm3"].as_f64().unwrap(),
        jp["final_volume_mm3"].as_f64().unwrap(),
    );
    eprintln!("removed {removed:?} final {finals:?}");
    assert!(rel(removed.0, removed.1) < 1e-7, "removed {removed:?}");
    assert!(rel(finals.0, finals.1) < 1e-7, "final {finals:?}");
    // Per operation and tool: the roughing is the joined program's T1
    // to 1e-4; the others within 2 % (their samples fall elsewhere).
    let op_lines = jo["operations"].as_array().unwrap();
    let tools = jp["tools"].as_array().unwrap();
    assert_eq!(op_lines.len(), 3);
    for (i, (op, tool)) in op_lines.iter().zip(tools).enumerate() {
        assert_eq!(tool["tool"].as_u64(), Some(i as u64 + 1));
        for key in ["removed_volume_mm3", "peak_force_n", "peak_deflection_um"] {
            let (a, b) = (op[key].as_f64().unwrap(), tool[key].as_f64().unwrap());
            eprintln!(
                "operation {} {key}: {a} vs the joined program's T{} {b}",
                i + 1,
                i + 1
            );
            if i == 0 {
                // (The same steps; the closed loop sweeps the joined program
                // as a whole, so its first tool's offsets converge over the
                // passes the whole program takes: equal to 1e-4 (a column
                // more or less), no longer bit for bit since the forces
                // through the tooth period, §3.4.)
                assert!(rel(a, b) < 1e-4, "operation 1 {key}: {a} vs {b}");
            } else {
                // (2 %: a step's arcs, MODEL.md §3.4, move with where its
                // samples fall.)
                assert!(rel(a, b) < 0.02, "operation {} {key}: {a} vs {b}", i + 1);
            }
        }
    }
    // The final stock: the same columns, the same count of intervals, tops
    // within 5 µm.
    let counts = |d: &Path| std::fs::read(d.join("stock/counts.npy")).unwrap();
    assert!(counts(ops) == counts(&one), "intervals per column");
    let (a, b) = (
        f32s(&ops.join("stock/intervals.npy")),
        f32s(&one.join("stock/intervals.npy")),
    );
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    eprintln!("final stock: largest difference of an interval's end {worst} mm");
    assert!(worst < 0.005, "{worst} mm");
    // The error map: the job's (each column as the operation that last cut
    // it left it) is cut where the joined program's is, and agrees with it
    // in its size; a column's error follows its last step's load, which the
    // sampling moves (largest differences below).
    let compare = |a: &Path, b: &Path, what: &str| {
        let (a, b) = (f32s(&a.join("error_um.npy")), f32s(&b.join("error_um.npy")));
        assert_eq!(a.len(), b.len());
        let (mut worst, mut sum_d, mut sum_a, mut sum_b, mut n) = (0.0f64, 0.0, 0.0, 0.0, 0.0);
        for (&x, &y) in a.iter().zip(&b) {
            assert_eq!(x.is_finite(), y.is_finite());
            if x.is_finite() {
                let (x, y) = (f64::from(x), f64::from(y));
                worst = worst.max((x - y).abs());
                sum_d += (x - y).abs();
                sum_a += x * x;
                sum_b += y * y;
                n += 1.0;
            }
        }
        let (rms_a, rms_b) = ((sum_a / n).sqrt(), (sum_b / n).sqrt());
        eprintln!(
            "{what}: error map rms {rms_a:.4} µm against the joined program's {rms_b:.4} µm; per column mean difference {:.4} µm, largest {worst:.4} µm",
            sum_d / n
        );
        (rms_a, rms_b, sum_d / n)
    };
    let (rms_a, rms_b, mean_d) = compare(ops, &one, "three operations");
    assert!(
        (rms_a - rms_b).abs() <= 0.05 * rms_b + 1e-3,
        "{rms_a} vs {rms_b}"
    );
    assert!(mean_d <= 0.5 * rms_b + 1e-3, "{mean_d}");
    // The first two operations, whose errors are larger (the bull nose's).
    std::fs::write(
        dir.path().join("two.toml"),
        job_text(&["roughing", "semi-finish"], None),
    )
    .unwrap();
    run_ok(&["simulate", "two.toml", "--out", "two"], dir.path());
    let joined2 = joined_program(dir.path(), 2);
    let (rms_a, rms_b, mean_d) = compare(&dir.path().join("two"), &joined2, "two operations");
    assert!(rms_b > 0.1, "the semi-finish leaves errors: rms {rms_b} µm");
    assert!((rms_a - rms_b).abs() <= 0.05 * rms_b, "{rms_a} vs {rms_b}");
    // (0.2: the wall errors are the deflections when a tooth passes the
    // flank, MODEL.md §5.2, which move more than the mean's with where the
    // samples fall: 0.040 µm a column against an rms of 0.231 µm.)
    assert!(mean_d <= 0.2 * rms_b, "{mean_d}");
    // The job's grid says which operation last cut each column: the finish, everywhere.
    let last = export::parse_npy(&std::fs::read(ops.join("last_operation.npy")).unwrap())
        .unwrap()
        .data
        .to_f64();
    assert!(last.iter().all(|&o| o == 3.0));
}

/// The stock saved after two operations and resumed by a job of the third
/// gives the third's results byte for byte (steps, column grid, summary but
/// its run id and time), and the same saved final stock; so does a job of one
/// `[program]` on the saved stock.
#[test]
fn saved_and_resumed_equals_one_job_byte_for_byte() {
    let whole = simulated_example();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("first.toml"),
        job_text(&["roughing", "semi-finish"], None),
    )
    .unwrap();
    run_ok(
        &["simulate", "first.toml", "--out", "first", "--save-stock"],
        dir.path(),
    );
    let saved = "[stock]\nkind = \"saved\"\npath = \"first/stock\"";
    std::fs::write(
        dir.path().join("rest.toml"),
        job_text(&["finish"], Some(saved)),
    )
    .unwrap();
    let stdout = run_ok(
        &["simulate", "rest.toml", "--out", "rest", "--save-stock"],
        dir.path(),
    );
    assert!(stdout.contains("op1_finish"), "{stdout}");
    assert_same_files(
        &whole.join("op3_finish"),
        &dir.path().join("rest/op1_finish"),
    );
    assert_same_files(&whole.join("stock"), &dir.path().join("rest/stock"));
    // The saved stock is what the first two left: the whole job's volume
    // after them.
    let first = json(&dir.path().join("first/summary.json"));
    let all = json(&whole.join("summary.json"));
    let after_two = all["initial_volume_mm3"].as_f64().unwrap()
        - all["operations"][0]["removed_volume_mm3"].as_f64().unwrap()
        - all["operations"][1]["removed_volume_mm3"].as_f64().unwrap();
    let first_final = first["final_volume_mm3"].as_f64().unwrap();
    assert!(
        (first_final - after_two).abs() < 1e-6 * after_two,
        "{first_final} vs {after_two}"
    );

    // One [program] and [tool] on the saved stock: the finish's steps and grid.
    let finish = example_dir().join("finish.nc");
    let head = job_text(&[], Some(saved));
    std::fs::write(
        dir.path().join("program.toml"),
        format!(
            "{head}[program]\npath = \"{}\"\n[tool]\nkind = \"ball\"\ndiameter = 6\nflute_length = 12\nstickout = 30\nflutes = 2\n",
            finish.display()
        ),
    )
    .unwrap();
    run_ok(
        &["simulate", "program.toml", "--out", "program"],
        dir.path(),
    );
    for name in ["steps.csv", "top_mm.npy", "last_step.npy", "error_um.npy"] {
        let (a, b) = (
            whole.join("op3_finish").join(name),
            dir.path().join("program").join(name),
        );
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
            "{name}"
        );
    }
}

/// `optimize` of operations: each re-timed on the stock the written programs
/// before it leave; resumed from the stock it saved after the first, the
/// second's results are the same bytes. On the semi-finish and finish at
/// grid 0.5 mm, from the simulated roughing's stock.
#[test]
fn optimized_operations_resume_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("rough.toml"), job_text(&["roughing"], None)).unwrap();
    run_ok(
        &[
            "simulate",
            "rough.toml",
            "--out",
            "rough",
            "--save-stock",
            "--grid",
            "0.5",
        ],
        dir.path(),
    );
    let saved = |d: &str| format!("[stock]\nkind = \"saved\"\npath = \"{d}/stock\"");
    let write = |name: &str, keep: &[&str], from: &str| {
        std::fs::write(dir.path().join(name), job_text(keep, Some(&saved(from)))).unwrap()
    };
    write("both.toml", &["semi-finish", "finish"], "rough");
    write("semi.toml", &["semi-finish"], "rough");
    let out = run_ok(&["optimize", "both.toml", "--out", "both"], dir.path());
    assert!(out.contains("operations (optimize)"), "{out}");
    run_ok(
        &["optimize", "semi.toml", "--out", "semi", "--save-stock"],
        dir.path(),
    );
    write("finish.toml", &["finish"], "semi");
    run_ok(&["optimize", "finish.toml", "--out", "finish"], dir.path());
    assert_same_files(
        &dir.path().join("both/op1_semi-finish"),
        &dir.path().join("semi/op1_semi-finish"),
    );
    assert_same_files(
        &dir.path().join("both/op2_finish"),
        &dir.path().join("finish/op1_finish"),
    );
    // The job's summary sums its operations' cycle times.
    let s = json(&dir.path().join("both/summary.json"));
    let ops = s["operations"].as_array().unwrap();
    let sum: f64 = ops
        .iter()
        .map(|o| o["cycle_time_s"].as_f64().unwrap())
        .sum();
    assert_eq!(s["command"], "operations");
    assert!((s["cycle_time_s"].as_f64().unwrap() - sum).abs() < 1e-9);
    // Each operation's optimized.nc is there, and `report` writes one page
    // with every operation beside each operation's own.
    for op in ops {
        let folder = dir.path().join("both").join(op["folder"].as_str().unwrap());
        assert!(folder.join("optimized.nc").is_file());
    }
    run_ok(&["report", "both"], dir.path());
    let html = std::fs::read_to_string(dir.path().join("both/report.html")).unwrap();
    assert!(
        html.contains("op1_semi-finish/report.html") && html.contains("op2_finish/report.html")
    );
    assert!(dir.path().join("both/op2_finish/report.html").is_file());
}

/// stock.stl is closed and manifold (the project's own solid check and
/// parry3d's half-edge topology) and encloses the stock's volume.
#[test]
fn saved_stl_is_watertight_with_the_stocks_volume() {
    let stock = simulated_example().join("stock");
    let doc = json(&stock.join("stock.json"));
    let volume = doc["volume_mm3"].as_f64().unwrap();
    let (solid, _) = mesh::load_solid(&stock.join("stock.stl")).expect("a closed solid");
    let ours = solid.signed_volume_mm3();
    // Touching intervals of neighbours are set apart by four f32 steps
    // (under 4e-5 mm a bottom), over at most a cell each.
    let cell = doc["grid"]["spacing_mm"].as_f64().unwrap().powi(2);
    let separated = doc["stl_separated"].as_f64().unwrap();
    eprintln!("stock.stl: {ours} mm³ against the stock's {volume} mm³, {} triangles, {separated} separated", solid.triangles.len());
    assert!(
        (ours - volume).abs() <= 1e-6 * volume + separated * 4e-5 * cell,
        "{ours} vs {volume}"
    );
    let vertices: Vec<parry3d::math::Vector> = solid
        .vertices
        .iter()
        .map(|p| parry3d::math::Vector::new(p[0] as f32, p[1] as f32, p[2] as f32))
        .collect();
    let parry_volume =
        parry3d::mass_properties::MassProperties::from_trimesh(1.0, &vertices, &solid.triangles)
            .mass();
    parry3d::shape::TriMesh::with_flags(
        vertices,
        solid.triangles.clone(),
        parry3d::shape::TriMeshFlags::HALF_EDGE_TOPOLOGY | parry3d::shape::TriMeshFlags::ORIENTED,
    )
    .expect("parry3d: a manifold, oriented mesh");
    eprintln!("parry3d volume {parry_volume} mm³");
    // parry3d sums its tetrahedra in f32: over the rigid sweep's 308 050
    // triangles it comes 6.5e-4 under the f64 sum above, which is exact.
    assert!(
        (f64::from(parry_volume) - volume).abs() < 2e-3 * volume,
        "{parry_volume} vs {volume}"
    );
}

/// Bad operations and saved stocks are refused with the file, line and
/// column, and nothing written.
#[test]
fn bad_operations_and_saved_stocks_are_refused_at_their_place() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = job_text(&["roughing"], None);
    let bad = |name: &str, text: String, needles: &[&str]| {
        std::fs::write(d.join(name), text).unwrap();
        assert_refused(d, &["simulate", name, "--out", "out"], needles, Some("out"));
    };
    // Line of `[operations.limits]`: the key misspelled under it.
    let typo = job.replace("mrr_max = 300", "mrr_maxx = 300");
    let line = typo
        .lines()
        .position(|l| l.starts_with("[operations.limits]"))
        .unwrap()
        + 1;
    bad(
        "typo.toml",
        typo,
        &[&format!("typo.toml:{line}:1"), "unknown field `mrr_maxx`"],
    );
    bad(
        "negative.toml",
        job.replace("mrr_max = 300", "mrr_max = -3"),
        &["operation 1 \"roughing\"", "mrr_max", "positive"],
    );
    bad(
        "both.toml",
        format!("{job}[program]\npath = \"x.nc\"\n"),
        &["[program] and [[operations]]"],
    );
    let saved = |path: &str, grid: &str| {
        format!("[stock]\nkind = \"saved\"\npath = \"{path}\"{grid}\n[tool]\nkind = \"ball\"\ndiameter = 6\n[program]\npath = \"{}\"\n",
            example_dir().join("finish.nc").display())
    };
    bad(
        "nowhere.toml",
        saved("nowhere", ""),
        &["nowhere.toml:3:", "not a saved stock folder"],
    );
    let stock = simulated_example().join("stock");
    bad(
        "grid.toml",
        saved(stock.to_str().unwrap(), "\ngrid = 0.5"),
        &["grid.toml:4:", "must be the saved stock's, 0.25 mm"],
    );
    // A damaged array: refused with its file named.
    let copy = d.join("copy");
    std::fs::create_dir(&copy).unwrap();
    for e in std::fs::read_dir(&stock).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), copy.join(e.file_name())).unwrap();
    }
    let bytes = std::fs::read(copy.join("intervals.npy")).unwrap();
    std::fs::write(copy.join("intervals.npy"), &bytes[..1000]).unwrap();
    bad("short.toml", saved("copy", ""), &["intervals.npy"]);
    // Material outside its intervals' order: refused, not swept.
    let mut bytes = bytes.clone();
    let n = bytes.len();
    bytes[n - 8..n - 4].copy_from_slice(&100.0f32.to_le_bytes());
    std::fs::write(copy.join("intervals.npy"), &bytes).unwrap();
    bad("order.toml", saved("copy", ""), &["copy"]);
}
