//! Generated benchmark programs, shared by `benches/pipeline.rs` and
//! `examples/bench_programs.rs` (which writes them, with their jobs, for
//! `scripts/bench_runs.sh`).
//!
//! Both cover the square [0, 100]² mm of a 100 × 100 × 30 mm block whose top
//! is z = 0, finishing the relief [`surface_z`] with a Ø10 ball in zig-zag
//! rows along X.

use std::fmt::Write;

/// The finished relief, mm: 1 mm below the top, ±0.5 mm of sin·cos.
pub fn surface_z(x: f64, y: f64) -> f64 {
    -1.0 + 0.5 * (x / 8.0).sin() * (y / 10.0).cos()
}

/// Tip positions of a zig-zag raster: `rows` rows along X (y from 0 to
/// 100), `points` points per row from x = 0 to 100; the tip follows
/// [`surface_z`] (a tip height, so the ball stays above the relief's valleys
/// only approximately: this is a load, not a finishing strategy).
pub fn raster_points(rows: usize, points: usize) -> Vec<[f64; 3]> {
    let dy = 100.0 / (rows - 1).max(1) as f64;
    let dx = 100.0 / (points - 1).max(1) as f64;
    let mut out = Vec::with_capacity(rows * points);
    for r in 0..rows {
        let y = r as f64 * dy;
        for p in 0..points {
            let i = if r % 2 == 0 { p } else { points - 1 - p };
            let x = i as f64 * dx;
            out.push([x, y, surface_z(x, y)]);
        }
    }
    out
}

/// The raster as a CSV point list (`x,y,z`, one move per row after the first).
#[allow(dead_code)] // used by examples/bench_programs.rs, not by the bench
pub fn raster_csv(rows: usize, points: usize) -> String {
    let mut s = String::from("x,y,z\n");
    for [x, y, z] in raster_points(rows, points) {
        writeln!(s, "{x:.4},{y:.4},{z:.4}").expect("write to String");
    }
    s
}

/// The raster as G-code: approach, one modal G1 block per point, retract.
/// `rows · points` G1 blocks (1000 × 1000 is the 1 M-block program).
pub fn raster_gcode(rows: usize, points: usize) -> String {
    let pts = raster_points(rows, points);
    let mut s = String::with_capacity(pts.len() * 28 + 200);
    s.push_str("(dexcut benchmark raster)\nG21 G90 G17 G94\nG0 Z10\n");
    let [x0, y0, z0] = pts[0];
    writeln!(s, "G0 X{x0:.4} Y{y0:.4}\nG1 Z{z0:.4} F3000").expect("write to String");
    for [x, y, z] in &pts[1..] {
        writeln!(s, "X{x:.4} Y{y:.4} Z{z:.4}").expect("write to String");
    }
    s.push_str("G0 Z10\nM2\n");
    s
}

/// A job for a program file `program` (G-code or CSV) at grid `grid_mm`,
/// with MRR and force limits for `optimize`.
pub fn job_toml(program: &str, grid_mm: f64) -> String {
    format!(
        r#"# dexcut benchmark job (written by examples/bench_programs.rs)
[stock]
kind = "box"
min = [-5, -5, -30]
max = [105, 105, 0]
grid = {grid_mm}

[tool]
kind = "ball"
diameter = 10
flute_length = 20
stickout = 40
flutes = 2

[program]
path = "{program}"
feed = 3000

[cutting]
band_height = 1.0
material = "al6061"

[machine]
period_ms = 4
feed_max = 3000
accel = [1000, 1000, 1000]

[limits]
mrr_max = 500
force_max = 400
"#
    )
}

/// The free path of the benchmark table: `moves` G1 moves of a Lissajous curve
/// wandering over the 80 × 60 mm top of [`free_path_job_toml`]'s block,
/// 0.5–2 mm deep, at F1500 (240 moves: about 2.3 mm each).
#[allow(dead_code)] // used by examples/bench_programs.rs, not by the bench
pub fn free_path_gcode(moves: usize) -> String {
    let point = |i: usize| {
        let t = std::f64::consts::TAU * i as f64 / moves as f64;
        let x = 40.0 + 34.0 * (3.0 * t).sin();
        let y = 30.0 + 24.0 * (2.0 * t + 0.5).sin();
        let z = -1.25 + 0.75 * (5.0 * t).cos();
        [x, y, z]
    };
    let mut s = String::from("(dexcut benchmark free path)\nG21 G90 G17 G94\nG0 Z5\n");
    let [x0, y0, z0] = point(0);
    writeln!(s, "G0 X{x0:.4} Y{y0:.4}\nG1 Z{z0:.4} F1500").expect("write to String");
    for i in 1..=moves {
        let [x, y, z] = point(i);
        writeln!(s, "G1 X{x:.4} Y{y:.4} Z{z:.4}").expect("write to String");
    }
    s.push_str("G0 Z5\nM2\n");
    s
}

/// The job of [`free_path_gcode`]: an 80 × 60 × 20 mm block (top z = 0), a
/// Ø6 ball, at grid `grid_mm`.
#[allow(dead_code)] // used by examples/bench_programs.rs, not by the bench
pub fn free_path_job_toml(program: &str, grid_mm: f64) -> String {
    format!(
        r#"# dexcut benchmark job (written by examples/bench_programs.rs)
[stock]
kind = "box"
min = [0, 0, -20]
max = [80, 60, 0]
grid = {grid_mm}

[tool]
kind = "ball"
diameter = 6
flute_length = 18
stickout = 30
flutes = 2

[program]
path = "{program}"

[cutting]
band_height = 1.0
material = "al6061"

[machine]
period_ms = 4
feed_max = 3000
accel = [1000, 1000, 1000]

[limits]
mrr_max = 200
"#
    )
}
