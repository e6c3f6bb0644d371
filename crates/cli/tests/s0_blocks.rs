//! S0 wired in (MODEL.md §6.2): with `arcs_as_lines` the control runs each arc as
//! chords within S0's chord tolerance for its feed and block time, so the blocks are
//! long enough to be read in time and the feed holds.

use std::f64::consts::PI;
use std::path::Path;

use serde_json::Value;

mod common;

use common::run as dexcut;

/// Cycle time of `simulate` on `program` with block time `tb_ms`, optionally arcs as lines.
fn cycle_s(dir: &Path, program: &str, tb_ms: f64, arcs_as_lines: bool) -> f64 {
    std::fs::write(dir.join("p.ngc"), program).unwrap();
    std::fs::write(
        dir.join("job.toml"),
        format!(
            "[stock]\nkind = \"box\"\nmin = [-60, -60, -10]\nmax = [60, 60, -5]\ngrid = 1\n\
             [tool]\nkind = \"ball\"\ndiameter = 10\n[program]\npath = \"p.ngc\"\n\
             [machine]\nfeed_max = 10000\naccel = [100000, 100000, 100000]\n\
             block_time_ms = {tb_ms}\narcs_as_lines = {arcs_as_lines}\n"
        ),
    )
    .unwrap();
    let out = dexcut(&["simulate", "job.toml", "--out", "o", "--force"], dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("o/summary.json")).unwrap())
            .unwrap();
    s["cycle_time_s"].as_f64().unwrap()
}

const HEAD: &str = "G21 G90 G17\nG0 X50 Y0 Z0\nG1 F10000\n";

/// S0's circle (r = 50 mm, F = 10 000 mm/min) as an n-gon of G1 blocks.
fn polygon(n: usize) -> String {
    let mut s = HEAD.to_string();
    for i in 1..=n {
        let a = 2.0 * PI * i as f64 / n as f64;
        s.push_str(&format!(
            "G1 X{:.9} Y{:.9}\n",
            50.0 * a.cos(),
            50.0 * a.sin()
        ));
    }
    s + "M2\n"
}

#[test]
fn arcs_as_lines_runs_the_arc_as_s0_chords() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let arc = format!("{HEAD}G3 X50 Y0 I-50 J0\nM2\n");
    // Tb = 4 ms: S0's chord tolerance 0.00111 mm gives 471 chords (case 2);
    // Tb = 12 ms: 157 chords of 2 mm, the longest the control needs at F.
    for (tb, sides) in [(4.0, 471), (12.0, 157)] {
        let linearised = cycle_s(d, &arc, tb, true);
        let written = cycle_s(d, &polygon(sides), tb, false);
        assert!(
            (linearised - written).abs() < 1e-6,
            "{tb} ms: {linearised} vs {written}"
        );
    }
    // Written as the 471-gon, the program starves a 12 ms control: 0.667 mm blocks are read
    // at most at 60000·Lb/12 = 3 335 mm/min, against 10 000 for S0's chords.
    let starved = cycle_s(d, &polygon(471), 12.0, false);
    let s0 = cycle_s(d, &arc, 12.0, true);
    let lb = 100.0 * (PI / 471.0).sin();
    let slow = 471.0 * lb / (1000.0 * lb / 12.0); // path / (mm/s at the block cap)
    assert!(
        starved > slow && starved < slow + 0.05,
        "{starved} vs {slow}"
    );
    assert!(s0 < 0.6 * starved);
    // optimize refuses the key (it re-feeds the program's own blocks), before any output.
    common::assert_refused(
        d,
        &["optimize", "job.toml", "--out", "opt"],
        &["arcs_as_lines"],
        Some("opt"),
    );
    // The key needs a block time.
    std::fs::write(
        d.join("job.toml"),
        "[stock]\nkind = \"box\"\nmin = [-60, -60, -10]\nmax = [60, 60, -5]\ngrid = 1\n\
         [tool]\nkind = \"ball\"\ndiameter = 10\n[program]\npath = \"p.ngc\"\n\
         [machine]\narcs_as_lines = true\n",
    )
    .unwrap();
    common::assert_refused(
        d,
        &["simulate", "job.toml", "--out", "o2"],
        &["block_time_ms"],
        Some("o2"),
    );
}
