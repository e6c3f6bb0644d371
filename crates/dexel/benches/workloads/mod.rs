//! The two benchmark workloads, shared by `benches/sweep.rs` and
//! `examples/sweep_stats.rs` (included there with `#[path]`).
//!
//! Both use an R5 ball (diameter 10 mm) on a 0.05 mm grid over a
//! 100 × 100 × 30 mm box (2000 × 2000 = 4 M columns).

use dexel::{Step, Stock, Tool};

/// Grid spacing, mm.
pub const GRID_MM: f64 = 0.05;
/// Stock top, mm.
pub const TOP_MM: f64 = 30.0;

pub fn tool() -> Tool {
    Tool::ball(10.0)
}

pub fn box_stock() -> Stock {
    Stock::new_box([0.0, 0.0, 0.0], [100.0, 100.0, TOP_MM], GRID_MM).expect("box stock")
}

/// Straight path through `points`, cut into steps no longer than `step_mm`
/// (the last step of each segment may be shorter), as a servo loop would emit.
fn polyline(points: &[[f64; 3]], step_mm: f64) -> Vec<Step> {
    let mut steps = Vec::new();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let n = (len / step_mm).ceil().max(1.0) as usize;
        let at = |i: usize| {
            let t = i as f64 / n as f64;
            [
                a[0] + t * (b[0] - a[0]),
                a[1] + t * (b[1] - a[1]),
                a[2] + t * (b[2] - a[2]),
            ]
        };
        steps.extend((0..n).map(|i| Step {
            from_mm: at(i),
            to_mm: at(i + 1),
            rapid: false,
        }));
    }
    steps
}

/// Zig-zag roughing of one layer: passes along X at 0.4 mm below the top,
/// 3 mm stepover, entering and leaving 5 mm outside the stock; 0.8 mm per
/// step (3000 mm/min at a 16 ms servo period).
pub fn roughing_steps() -> Vec<Step> {
    let z = TOP_MM - 0.4;
    let mut points = Vec::new();
    let mut y = 0.0;
    let mut forward = true;
    while y <= 100.0 + 1e-9 {
        let (xa, xb) = if forward {
            (-5.0, 105.0)
        } else {
            (105.0, -5.0)
        };
        points.push([xa, y, z]);
        points.push([xb, y, z]);
        y += 3.0;
        forward = !forward;
    }
    polyline(&points, 0.8)
}

/// Design surface of the finishing pass: tip height over (x, y), mm.
pub fn surface_mm(x: f64, y: f64) -> f64 {
    25.0 + 3.0 * (x / 15.0).sin() * (y / 15.0).cos()
}

/// Stock left by roughing for the finishing pass: the design surface plus a
/// 0.3 mm allowance (columns end there instead of at the box top).
pub fn semi_finished_stock() -> Stock {
    let grid = *box_stock().grid();
    Stock::from_columns(grid, |ix, iy, out| {
        let top = surface_mm(grid.x_mm(ix), grid.y_mm(iy)) + 0.3;
        out.push([0.0, top as f32]);
    })
    .expect("semi-finished stock")
}

/// Ball raster finishing along X over a 30 × 6 mm patch in the middle of the
/// stock: tip on the design surface, 0.3 mm stepover, 0.2 mm steps (zig-zag).
pub fn finishing_steps() -> Vec<Step> {
    let (x0, x1, y0, y1) = (35.0, 65.0, 47.0, 53.0);
    let mut steps = Vec::new();
    let mut y = y0;
    let mut forward = true;
    let mut prev: Option<[f64; 3]> = None;
    while y <= y1 + 1e-9 {
        let n = ((x1 - x0) / 0.2f64).round() as usize;
        let pts: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let s = i as f64 / n as f64;
                let x = if forward {
                    x0 + s * (x1 - x0)
                } else {
                    x1 - s * (x1 - x0)
                };
                [x, y, surface_mm(x, y)]
            })
            .collect();
        if let Some(p) = prev {
            // Stepover move between passes.
            steps.push(Step {
                from_mm: p,
                to_mm: pts[0],
                rapid: false,
            });
        }
        steps.extend(pts.windows(2).map(|w| Step {
            from_mm: w[0],
            to_mm: w[1],
            rapid: false,
        }));
        prev = pts.last().copied();
        y += 0.3;
        forward = !forward;
    }
    steps
}
