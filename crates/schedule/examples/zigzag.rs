//! Issue 43's paths: the plan, exact stop and the lower bound side by side, at 1 and
//! 16 ms, with and without a jerk limit (20 000 mm/s³), accelerations 1000 mm/s².
//!
//! `cargo run --release -p schedule --example zigzag`

use nalgebra::Point3;
use nc::{Geometry, Motion, Path, Segment};
use schedule::*;

fn line(a: Point3<f64>, b: Point3<f64>, feed_mm_min: f64) -> Segment {
    Segment {
        start: a,
        end: b,
        geometry: Geometry::Line,
        motion: Motion::feed(feed_mm_min),
        line: 1,
        spindle_rpm: 10000.0,
        tool: 1,
    }
}

fn polyline(points: &[Point3<f64>], feed_mm_min: f64) -> Path {
    Path {
        segments: points
            .windows(2)
            .map(|w| line(w[0], w[1], feed_mm_min))
            .collect(),
        ..Default::default()
    }
}

/// X10, Y10, X20, Y0, …: 20 segments of 10 mm at F3000.
fn zigzag() -> Path {
    let mut points = vec![Point3::origin()];
    for k in 0..20 {
        let last = *points.last().expect("a point");
        points.push(if k % 2 == 0 {
            Point3::new(last.x + 10.0, last.y, 0.0)
        } else {
            Point3::new(last.x, 10.0 - last.y, 0.0)
        });
    }
    polyline(&points, 3000.0)
}

/// 100 segments of 0.3–2 mm turning by 60–160° either way, at F3000 (a fixed
/// pseudo-random sequence): short segments, sharp corners, as an engraving.
fn engraving() -> Path {
    let mut points = vec![Point3::origin()];
    let mut heading: f64 = 0.0;
    let mut seed: u64 = 12345;
    let mut uniform = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    for _ in 0..100 {
        let len = 0.3 + 1.7 * uniform();
        let turn = (60.0 + 100.0 * uniform()).to_radians();
        heading += if uniform() < 0.5 { turn } else { -turn };
        let last = *points.last().expect("a point");
        points.push(Point3::new(
            last.x + len * heading.cos(),
            last.y + len * heading.sin(),
            0.0,
        ));
    }
    polyline(&points, 3000.0)
}

fn main() {
    println!("path       period jerk   plan s   exact stop s   bound s");
    for (name, path) in [("zigzag", zigzag()), ("engraving", engraving())] {
        for period_ms in [1.0, 16.0] {
            for jerk in [None, Some([20000.0; 3])] {
                let machine = Machine {
                    period_ms,
                    accel_mm_s2: [1000.0; 3],
                    jerk_mm_s3: jerk,
                    ..Machine::default()
                };
                let stations = Stations::new(&path, &machine, 0.05, FeedPolicy::Programmed)
                    .expect("valid stations");
                let profile = plan(&stations);
                println!(
                    "{name:10} {period_ms:>4} ms {:5} {:>8.4} {:>12.4} {:>11.4}",
                    jerk.is_some(),
                    profile.cycle_time_s(),
                    exact_stop_time_s(&path, &machine, FeedPolicy::Programmed),
                    lower_bound_time_s(&stations),
                );
            }
        }
    }
}
