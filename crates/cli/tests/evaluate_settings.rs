//! S2 as written (MODEL.md §7.2): `evaluate --sweep` keeps the set with the largest V and
//! writes it as a job fragment, which `evaluate` and `optimize` take with `--settings`.

use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

mod common;

use common::run as dexcut;

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "dexcut failed:\nstdout: {}\nstderr: {}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

const STOCK_TOOL: &str = "[stock]\nkind = \"box\"\nmin = [-30, -30, -10]\nmax = [30, 30, -1]\n\
    grid = 0.5\n[tool]\nkind = \"ball\"\ndiameter = 10\n[program]\npath = \"p.ngc\"\n\
    [cutting]\nband_height = 1.0\n[limits]\nmrr_max = 8\n";

fn job(accel: f64, jerk: Option<f64>, kp: f64) -> String {
    let jerk = jerk.map_or(String::new(), |j| format!("jerk = [{j}, {j}, {j}]\n"));
    format!(
        "{STOCK_TOOL}[machine]\nperiod_ms = 16\nfeed_max = 3000\naccel = [{accel}, {accel}, {accel}]\n\
         {jerk}[servo]\nkp = {kp}\nka = 1\nkb = 1\nkc = 1\n"
    )
}

const PROGRAM: &str = "G21 G90 G17\nG0 X-20 Y-10 Z5\nG1 Z-2 F1500\nG1 X0\n\
    G3 X10 Y0 I0 J10\nG1 Y10\nG1 X-20\nG0 Z5\nM2\n";

#[test]
fn sweep_writes_the_best_set_and_evaluate_and_optimize_take_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "job.toml", &job(1000.0, None, 30.0));
    write(d, "p.ngc", PROGRAM);
    ok(&dexcut(
        &["evaluate", "job.toml", "--sweep", "--out", "sw"],
        d,
    ));
    let e = json(&d.join("sw/evaluation.json"));
    // The program as written is the reference of Vb: it scores exactly 1/2.
    assert_eq!(e["vb"].as_f64().unwrap(), 0.5);
    // S2 keeps the largest V; each row's V is Ka·Va + Kb·Vb + Kc·Vc with r/(r + x) scores.
    let rows = e["sweep"].as_array().unwrap();
    let v = |r: &Value| r["evaluation"].as_f64().unwrap();
    let best = e["best"].as_u64().unwrap() as usize;
    assert!(rows.iter().all(|r| v(r) <= v(&rows[best])));
    let w = &e["weights"];
    for r in rows {
        let jerk = r["max_jerk_mm_s3"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j.as_f64().unwrap())
            .fold(0.0, f64::max);
        let score = |x: f64, key: &str| {
            let reference = w[key].as_f64().unwrap();
            reference / (reference + x)
        };
        let va = score(r["trajectory_error_mm"].as_f64().unwrap(), "tolerance_mm");
        let vb = score(r["machining_time_s"].as_f64().unwrap(), "reference_time_s");
        let vc = score(jerk, "jerk_reference_mm_s3");
        assert!((v(r) - (va + vb + vc)).abs() < 1e-12, "{r}");
    }

    // The fragment holds the best row's settings.
    let text = std::fs::read_to_string(d.join("sw/best.toml")).unwrap();
    let fragment: toml::Table = toml::from_str(&text).unwrap();
    let b = &rows[best];
    let accel = b["accel_mm_s2"][0].as_f64().unwrap();
    let jerk = b["jerk_mm_s3"].as_array().map(|j| j[0].as_f64().unwrap());
    let kp = b["kp_per_s"].as_f64().unwrap();
    assert_eq!(fragment["machine"]["accel"][0].as_float(), Some(accel));
    assert_eq!(fragment["servo"]["kp"].as_float(), Some(kp));
    assert_eq!(
        fragment["machine"]
            .get("jerk")
            .map(|j| j[0].as_float().unwrap()),
        jerk
    );

    // evaluate --settings runs the same motion as the best row.
    ok(&dexcut(
        &[
            "evaluate",
            "job.toml",
            "--settings",
            "sw/best.toml",
            "--out",
            "ev",
        ],
        d,
    ));
    let again = json(&d.join("ev/evaluation.json"));
    for key in [
        "trajectory_error_mm",
        "machining_time_s",
        "max_jerk_mm_s3",
        "va",
        "vc",
    ] {
        assert_eq!(again[key], b[key], "{key}");
    }

    // optimize --settings equals optimize of a job with those settings written in.
    ok(&dexcut(
        &[
            "optimize",
            "job.toml",
            "--settings",
            "sw/best.toml",
            "--out",
            "o1",
        ],
        d,
    ));
    write(d, "inline.toml", &job(accel, jerk, kp));
    ok(&dexcut(&["optimize", "inline.toml", "--out", "o2"], d));
    let (s1, s2) = (
        json(&d.join("o1/summary.json")),
        json(&d.join("o2/summary.json")),
    );
    assert_eq!(s1["after"]["cycle_time_s"], s2["after"]["cycle_time_s"]);
    assert_eq!(
        std::fs::read_to_string(d.join("o1/servo.csv")).unwrap(),
        std::fs::read_to_string(d.join("o2/servo.csv")).unwrap()
    );

    // A fragment with an unknown key is refused with its line and column, and no output.
    write(
        d,
        "bad.toml",
        "[machine]\naccel = [1, 1, 1]\nrapid = 3\n[servo]\nkp = 30\n",
    );
    let err = common::assert_refused(
        d,
        &[
            "optimize",
            "job.toml",
            "--settings",
            "bad.toml",
            "--out",
            "o3",
        ],
        &["bad.toml:3:1"],
        Some("o3"),
    );
    assert!(err.contains("rapid"), "{err}");
}
