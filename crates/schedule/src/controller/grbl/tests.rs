//! Closed forms of grbl's planner: one corner's junction speed, one block's trapezoid,
//! `mc_arc`'s chord count, and a `$$` dump.

use super::*;

fn line_path(points: &[[f64; 3]], feed_mm_min: f64) -> nc::Path {
    let segments = points
        .windows(2)
        .enumerate()
        .map(|(k, w)| nc::Segment {
            start: w[0].into(),
            end: w[1].into(),
            geometry: nc::Geometry::Line,
            motion: nc::Motion::feed(feed_mm_min),
            line: k as u32 + 1,
            spindle_rpm: 0.0,
            tool: 1,
        })
        .collect();
    nc::Path::from_segments(segments)
}

fn settings() -> GrblSettings {
    GrblSettings {
        junction_deviation_mm: 0.01,
        arc_tolerance_mm: 0.002,
        steps_per_mm: [1000.0; 3],
        max_rate_mm_min: [5000.0; 3],
        accel_mm_s2: [500.0; 3],
        planner_blocks: 15,
    }
}

/// A 90° corner in XY: θ/2 = 45°, the junction direction (1, −1)/√2 limits the
/// acceleration to a·√2, so v² = a√2·δ·sin45°/(1 − sin45°) (grbl's planner.c), with
/// blocks long enough that neither the feed nor the distance limits it.
/// Within f32's precision: dexcut computes the junction as grbl does, in single precision.
#[test]
fn right_angle_junction_speed_is_grbls_closed_form() {
    let path = line_path(&[[0.0; 3], [100.0, 0.0, 0.0], [100.0, 100.0, 0.0]], 20000.0);
    let s = settings();
    let b = blocks(&path, &s);
    let planned = plan_blocks([0.0; 3], &b, &s);
    assert_eq!(planned.len(), 2);
    let a_mm_min2 = 500.0 * 3600.0 * 2f64.sqrt();
    let sin = (0.5f64).sqrt();
    let expected = (a_mm_min2 * 0.01 * sin / (1.0 - sin)).sqrt();
    let got = planned[1].max_entry_mm_min;
    assert!(
        (got - expected).abs() < 1e-6 * expected,
        "{got} vs {expected}"
    );
    assert!((planned[1].entry_mm_min - expected).abs() < 1e-6 * expected);
    assert!((planned[0].exit_mm_min - expected).abs() < 1e-6 * expected);
    // The nominal speed is the feed capped by the axis' maximum rate.
    assert_eq!(planned[0].nominal_mm_min, 5000.0);
}

/// A nearly reversing corner (the second line back along (−10, 0.2)): 1 − cos θ is 2·10⁻⁴,
/// and grbl's single-precision arithmetic puts its junction speed 4·10⁻⁵ above the exact
/// closed form. dexcut gives grbl's value: 13.4838839 mm/min is what grbl's planner.c
/// computes (`scripts/grbl_reference/harness.c` with these settings and the two blocks
/// `F 10 0 0 20000`, `F 0 0.2 0 20000`); the exact form gives 13.4833130.
#[test]
fn near_reversal_junction_is_grbls_single_precision_value() {
    let path = line_path(&[[0.0; 3], [10.0, 0.0, 0.0], [0.0, 0.2, 0.0]], 20000.0);
    let s = settings();
    let planned = plan_blocks([0.0; 3], &blocks(&path, &s), &s);
    let got = planned[1].max_entry_mm_min;
    assert!((got - 13.4838839).abs() < 1e-7 * got, "{got}");
    assert!((got - 13.4833130).abs() > 1e-5 * got, "{got}");
    // The nominal speed along (−10, 0.2): the feed capped by X's rate along it.
    assert!((planned[1].nominal_mm_min - 5001.0).abs() < 1e-3);
}

/// One block from rest to rest: a trapezoid of time L/v + v/a, or a triangle of 2√(L/a).
#[test]
fn one_block_runs_grbls_trapezoid() {
    let s = settings();
    let (a, v) = (500.0, 3000.0 / 60.0);
    for length in [100.0, 1.0] {
        let path = line_path(&[[0.0; 3], [length, 0.0, 0.0]], 3000.0);
        let planned = plan_blocks([0.0; 3], &blocks(&path, &s), &s);
        let expected = if length > v * v / a {
            length / v + v / a
        } else {
            2.0 * (length / a).sqrt()
        };
        let got = cycle_time_s(&planned);
        assert!(
            (got - expected).abs() < 1e-12,
            "L {length}: {got} vs {expected}"
        );
        let samples = samples(&path, &Machine::default(), &s).unwrap();
        let last = samples.last().unwrap();
        assert!((last.t_s - expected).abs() < 1e-12);
        assert!((last.pos.x - length).abs() < 1e-12);
        assert!(samples.iter().all(|p| p.feed_mm_min <= 3000.0 + 1e-9));
    }
}

/// A short buffer caps the speed: blocks of 0.1 mm in a line with 2 blocks of look-ahead
/// can enter at most at √(2·a·0.1 mm) (the next block ends at rest).
#[test]
fn look_ahead_depth_caps_short_blocks() {
    let points: Vec<[f64; 3]> = (0..=50).map(|i| [0.1 * i as f64, 0.0, 0.0]).collect();
    let path = line_path(&points, 3000.0);
    let s = GrblSettings {
        planner_blocks: 2,
        ..settings()
    };
    let planned = plan_blocks([0.0; 3], &blocks(&path, &s), &s);
    let cap = (2.0 * 500.0 * 3600.0 * 0.1f64).sqrt();
    let most = planned.iter().map(|b| b.entry_mm_min).fold(0.0, f64::max);
    assert!((most - cap).abs() < 1e-6 * cap, "{most} vs {cap}");
}

/// A full circle of r = 10 mm at $12 = 0.002: ⌊π·10 / √(0.002·19.998)⌋ = 157 chords, whose
/// ends lie on the circle within the drift of grbl's small-angle rotation.
#[test]
fn arcs_are_cut_as_mc_arc_cuts_them() {
    let path = nc::Path::from_segments(vec![nc::Segment {
        start: [10.0, 0.0, 0.0].into(),
        end: [10.0, 0.0, 0.0].into(),
        geometry: nc::Geometry::Arc {
            center: [0.0; 3].into(),
            plane: nc::Plane::XY,
            clockwise: false,
            sweep_rad: std::f64::consts::TAU,
        },
        motion: nc::Motion::feed(1000.0),
        line: 1,
        spindle_rpm: 0.0,
        tool: 1,
    }]);
    let b = blocks(&path, &settings());
    let n = (std::f64::consts::PI * 10.0 / (0.002f64 * 19.998).sqrt()).floor() as usize;
    assert_eq!(b.len(), n);
    // cos θ ≈ 1 − θ²/2 shrinks the radius by θ⁴/24 a chord, over 12 chords between
    // exact corrections (grbl's N_ARC_CORRECTION).
    let theta = std::f64::consts::TAU / n as f64;
    let drift_mm = 12.0 * theta.powi(4) / 24.0 * 10.0;
    for p in &b {
        let r = p.target_mm[0].hypot(p.target_mm[1]);
        assert!((r - 10.0).abs() <= drift_mm, "{r} (drift {drift_mm})");
    }
}

#[test]
fn dumps_are_read_and_bad_lines_named() {
    let dump = "$0=10\n$11=0.020 (junction deviation, mm)\n$12=0.001\n$100=80\n$110=8000\n\
                $111=7000\n$112=1000\n$120=300\n$121=250\n$122=50\nok\n";
    let s = GrblSettings::default().with_dump(dump).unwrap();
    assert_eq!(s.junction_deviation_mm, 0.02);
    assert_eq!(s.arc_tolerance_mm, 0.001);
    assert_eq!(s.steps_per_mm, [80.0, 250.0, 250.0]);
    assert_eq!(s.max_rate_mm_min, [8000.0, 7000.0, 1000.0]);
    assert_eq!(s.accel_mm_s2, [300.0, 250.0, 50.0]);
    let e = GrblSettings::default()
        .with_dump("$11=0.01\n$120=fast\n")
        .unwrap_err();
    assert_eq!(e.to_string(), "line 2: $120: `fast` is not a number");
    let e = GrblSettings::default().with_dump("G0 X1\n").unwrap_err();
    assert_eq!(e.line, 1);
}
