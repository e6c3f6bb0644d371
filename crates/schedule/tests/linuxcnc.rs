//! dexcut's LinuxCNC planner against the real one: recordings of LinuxCNC
//! 2.9 running each program of `tests/data/linuxcnc_reference/programs` on
//! the simulated machine of `scripts/linuxcnc_reference/sim.ini`
//! (README.md there), and closed forms for single moves and corners.

use flate2::read::GzDecoder;
use nalgebra::Point3;
use schedule::linuxcnc::{ini::settings_from_ini, samples_with as samples, LinuxCncIni};
use schedule::ServoSample;
use std::io::Read;
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/linuxcnc_reference")
}

fn sim_settings() -> LinuxCncIni {
    let file =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scripts/linuxcnc_reference/sim.ini");
    let text = std::fs::read_to_string(&file).expect("sim.ini");
    settings_from_ini(&text, "sim.ini").expect("sim.ini reads")
}

/// A recording: the commanded positions (mm), one per servo period, from
/// the one before the motion to the last that moves.
struct Recording {
    period_s: f64,
    pos: Vec<Point3<f64>>,
}

fn recording(name: &str) -> Recording {
    recording_at(&data_dir().join(format!("{name}.txt.gz")))
}

fn recording_at(file: &std::path::Path) -> Recording {
    let mut text = String::new();
    GzDecoder::new(std::fs::File::open(file).expect("recording"))
        .read_to_string(&mut text)
        .expect("gzip text");
    let mut period_ns = 0.0;
    let mut pos = Vec::new();
    let (mut p, mut d) = ([0i64; 3], [0i64; 3]);
    let mut k = 0;
    for line in text.lines() {
        if line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        match f[0] {
            "name" | "samples" => continue,
            "period_ns" => {
                period_ns = f[1].parse().expect("period");
                continue;
            }
            _ => {}
        }
        let v: Vec<i64> = f[..3].iter().map(|x| x.parse().expect("nm")).collect();
        for i in 0..3 {
            match k {
                0 => p[i] = v[i],
                1 => d[i] = v[i],
                _ => d[i] += v[i],
            }
            if k > 0 {
                p[i] += d[i];
            }
        }
        k += 1;
        pos.push(Point3::new(p[0] as f64, p[1] as f64, p[2] as f64) * 1e-6);
    }
    Recording {
        period_s: period_ns * 1e-9,
        pos,
    }
}

/// The program as LinuxCNC starts it: at the origin, homed.
fn program(name: &str) -> nc::Path {
    let file = data_dir().join(format!("programs/{name}.ngc"));
    let text = std::fs::read_to_string(&file).expect("program");
    let parsed = nc::Reader::new(&text, name, &nc::Options::default()).parse_from([0.0; 3]);
    let errors: Vec<_> = parsed
        .diagnostics
        .iter()
        .filter(|d| d.severity == nc::Severity::Error)
        .collect();
    assert!(errors.is_empty(), "{name}: {errors:?}");
    parsed.path
}

/// LinuxCNC's joints get the cubic interpolation of the planner's
/// positions one period late: (p[k−2] + 4·p[k−1] + p[k])/6.
fn as_joints(samples: &[ServoSample]) -> Vec<Point3<f64>> {
    let at = |k: isize| {
        samples[k.clamp(0, samples.len() as isize - 1) as usize]
            .pos
            .coords
    };
    (0..=samples.len() as isize)
        .map(|k| Point3::from((at(k - 2) + at(k - 1) * 4.0 + at(k)) / 6.0))
        .collect()
}

/// Speed (mm/s) against distance run (mm), from positions a period apart.
fn speed_by_distance(pos: &[Point3<f64>], period_s: f64) -> (Vec<f64>, Vec<f64>) {
    let mut s = vec![0.0];
    let mut v = vec![0.0];
    for w in pos.windows(2) {
        let d = (w[1] - w[0]).norm();
        s.push(s.last().copied().unwrap_or(0.0) + d);
        v.push(d / period_s);
    }
    (s, v)
}

/// dexcut's ideal planner (MODEL.md §6.1) on the recorded machine: its
/// period, axes' accelerations, and the rapid rate as the feed limit.
fn ideal_s(name: &str) -> f64 {
    let machine = schedule::Machine {
        period_ms: 1.0,
        feed_max_mm_min: 12000.0,
        rapid_mm_min: 12000.0,
        accel_mm_s2: [1000.0, 1000.0, 800.0],
        jerk_mm_s3: None,
        block_time_ms: None,
    };
    let stations = schedule::Stations::new(
        &program(name),
        &machine,
        0.05,
        schedule::FeedPolicy::Programmed,
    )
    .expect("stations");
    schedule::plan(&stations).cycle_time_s()
}

/// The comparison of one program.
struct Compared {
    /// Time in motion, s.
    real_s: f64,
    /// From the first motion to the last, waits included, s.
    real_total_s: f64,
    dexcut_s: f64,
    /// Share of the real path's length where dexcut's speed at the same
    /// distance is within 2 % of the real speed.
    within_2pct: f64,
    /// Largest distance between a real position and dexcut's at the same
    /// distance run, mm.
    max_gap_mm: f64,
}

fn compare(name: &str) -> Compared {
    compare_with(name, recording(name))
}

fn compare_with(name: &str, real: Recording) -> Compared {
    let settings = sim_settings();
    assert_eq!(real.period_s, settings.period_s);
    let ours = samples(&program(name), &settings).expect("plan");
    let joints = as_joints(&ours);
    // Both end where their last movement ends.
    let moving_end = |p: &[Point3<f64>]| {
        (1..p.len())
            .rev()
            .find(|&k| (p[k] - p[k - 1]).norm() > 1e-9)
            .unwrap_or(0)
    };
    let n_real = moving_end(&real.pos);
    let n_ours = moving_end(&joints);
    let (s_real, v_real) = speed_by_distance(&real.pos[..=n_real], real.period_s);
    let (s_ours, v_ours) = speed_by_distance(&joints[..=n_ours], settings.period_s);
    let total: f64 = s_real.last().copied().unwrap_or(0.0);
    let mut good = 0.0;
    let mut j = 0;
    let mut dump = Vec::new();
    for k in 1..s_real.len() {
        let ds = s_real[k] - s_real[k - 1];
        if ds <= 0.0 {
            continue;
        }
        // dexcut's speed over the period covering the same mid-distance.
        let mid = 0.5 * (s_real[k] + s_real[k - 1]);
        while j + 1 < s_ours.len() && s_ours[j + 1] < mid {
            j += 1;
        }
        let v = v_ours.get(j + 1).copied().unwrap_or(0.0);
        if (v - v_real[k]).abs() <= 0.02 * v_real[k] {
            good += ds;
        }
        dump.push(format!(
            "{k},{mid},{},{v},{},{},{}",
            v_real[k], real.pos[k].x, real.pos[k].y, real.pos[k].z
        ));
    }
    if std::env::var("DEXCUT_LCNC_DUMP").is_ok_and(|n| n == name) {
        std::fs::write(format!("/tmp/lcnc_{name}.csv"), dump.join("\n")).expect("dump");
    }
    // The paths themselves: each real position against dexcut's at the same
    // distance run (linear between its samples).
    let mut max_gap_mm: f64 = 0.0;
    let mut j = 0;
    for (k, &at) in s_real.iter().enumerate() {
        while j + 2 < s_ours.len() && s_ours[j + 1] < at {
            j += 1;
        }
        let (s0, s1) = (s_ours[j], s_ours[(j + 1).min(s_ours.len() - 1)]);
        let u = if s1 > s0 {
            ((at - s0) / (s1 - s0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = joints[j] + (joints[(j + 1).min(n_ours)] - joints[j]) * u;
        max_gap_mm = max_gap_mm.max((real.pos[k] - p).norm());
    }
    // Time in motion: LinuxCNC's task waits for its I/O (spindle, tool
    // changes) at its own pace, which is not the planner's.
    let moving = |p: &[Point3<f64>]| p.windows(2).filter(|w| (w[1] - w[0]).norm() > 1e-7).count();
    Compared {
        real_s: moving(&real.pos) as f64 * real.period_s,
        dexcut_s: moving(&joints) as f64 * settings.period_s,
        real_total_s: n_real as f64 * real.period_s,
        within_2pct: if total > 0.0 { good / total } else { 1.0 },
        max_gap_mm,
    }
}

const PROGRAMS: &[&str] = &[
    "corner_g61",
    "corner_g64",
    "corner_g64_p005",
    "corner_g64_p005_q002_obtuse",
    "zigzag_short_g64",
    "zigzag_short_g64_p002",
    "collinear_short_g64_p01_q005",
    "arcs_g64_p001",
    "line_arc_corners_g64_p002",
    "arc_arc_corner_g64_p002",
    "adaptive_corner",
    "adaptive_hole",
    "engrave_locket",
    "engrave_tiny_cat_g61",
    "finish_bear",
    "finish_flower_mold",
    "finish_tiger",
    "finish_wave",
    "pcb_carbide_copper",
    "pcb_flatcam_isolation",
    "pocket_medial",
];

/// Programs dexcut does not yet run within the targets, with the reason:
/// printed in the table, not asserted.
const KNOWN_GAPS: &[(&str, &str)] = &[];
#[test]
fn dexcut_runs_the_recorded_programs_as_linuxcnc_does() {
    let mut failed = Vec::new();
    println!(
        "program                          real s   dexcut s   diff %   within 2 %   path gap mm   real with waits s"
    );
    for name in PROGRAMS {
        if !data_dir().join(format!("{name}.txt.gz")).exists() {
            failed.push(format!("{name}: no recording"));
            continue;
        }
        let c = compare(name);
        let ideal = if std::env::var_os("DEXCUT_LCNC_IDEAL").is_some() {
            format!("{:10.3}", ideal_s(name))
        } else {
            String::new()
        };
        let diff = (c.dexcut_s - c.real_s) / c.real_s * 100.0;
        println!(
            "{name:32} {:8.3} {:9.3} {:8.3} {:11.1}% {:11.4} {:12.3}{ideal}",
            c.real_s,
            c.dexcut_s,
            diff,
            c.within_2pct * 100.0,
            c.max_gap_mm,
            c.real_total_s
        );
        let known = KNOWN_GAPS.iter().find(|g| g.0 == *name);
        if let Some((_, why)) = known {
            println!("{:32} (known gap: {why})", "");
        }
        if (diff.abs() > 1.0 || c.within_2pct < 0.95) && known.is_none() {
            failed.push(format!(
                "{name}: cycle time {:.3} s against {:.3} s ({diff:+.2} %), {:.1} % of the path within 2 % of the real speed",
                c.dexcut_s, c.real_s, c.within_2pct * 100.0
            ));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

fn ini(name: &str) -> Result<LinuxCncIni, schedule::ScheduleError> {
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/linuxcnc_ini")
        .join(name);
    settings_from_ini(&std::fs::read_to_string(&file).expect("ini"), name)
}

#[test]
fn settings_come_from_the_installed_sample_configurations() {
    let mm = ini("axis_mm.ini").unwrap();
    assert_eq!(mm.period_s, 0.001);
    assert_eq!(mm.axis_max_vel_mm_s, [30.48; 3]);
    assert_eq!(mm.axis_max_acc_mm_s2, [508.0; 3]);
    assert_eq!(mm.max_linear_vel_mm_s, 53.34);
    assert_eq!(mm.max_feed_scale, 1.2);
    assert_eq!(mm.startup_tolerance_mm, 0.0);
    assert_eq!(
        (
            mm.arc_blend_enable,
            mm.arc_blend_opt_depth,
            mm.arc_blend_gap_cycles
        ),
        (true, 50, 4.0)
    );
    // Inch: [AXIS_n] and [TRAJ] values are in inches.
    let inch = ini("axis_inch.ini").unwrap();
    assert_eq!(inch.axis_max_vel_mm_s, [4.0 * 25.4; 3]);
    assert_eq!(inch.axis_max_acc_mm_s2, [100.0 * 25.4; 3]);
    assert_eq!(inch.max_linear_vel_mm_s, 4.0 * 25.4);
    // COORDINATES = XYZ, metric, and the start-up code's G64 P.
    let qt = ini("qtdragon_hd_xyz.ini").unwrap();
    assert_eq!(qt.axis_max_vel_mm_s, [60.0, 60.0, 40.0]);
    assert_eq!(qt.axis_max_acc_mm_s2, [500.0; 3]);
    assert_eq!(qt.max_linear_vel_mm_s, 60.0);
    assert_eq!(qt.startup_tolerance_mm, 0.0127);
}

#[test]
fn ini_errors_name_the_file_and_line() {
    let bad = |text: &str| settings_from_ini(text, "m.ini").unwrap_err().to_string();
    let axes = "[AXIS_X]\nMAX_VELOCITY = 10\nMAX_ACCELERATION = 100\n[AXIS_Y]\nMAX_VELOCITY = 10\n\
                MAX_ACCELERATION = 100\n[AXIS_Z]\nMAX_VELOCITY = 10\nMAX_ACCELERATION = 100\n";
    assert!(settings_from_ini(axes, "m.ini").is_ok());
    assert_eq!(
        bad(&format!("{axes}[EMCMOT]\nSERVO_PERIOD = fast\n")),
        "m.ini:11: [EMCMOT] SERVO_PERIOD = fast: not a number"
    );
    assert_eq!(
        bad(&format!("{axes}[EMCMOT]\nSERVO_PERIOD = -1\n")),
        "m.ini:11: [EMCMOT] SERVO_PERIOD must be > 0, got -1"
    );
    assert_eq!(
        bad("[AXIS_X\n"),
        "m.ini:1: section header `[AXIS_X` has no closing ]"
    );
    assert_eq!(
        bad("KEY = 1\n"),
        "m.ini:1: `KEY = 1` comes before any [SECTION]"
    );
    assert_eq!(
        bad("[AXIS_X]\nMAX_VELOCITY = 1\n"),
        "m.ini:0: no [AXIS_X] MAX_ACCELERATION (nor [JOINT_0] MAX_ACCELERATION)"
    );
    // A joint stands in for its axis.
    let joints = axes.replace("AXIS_Y", "JOINT_1");
    assert_eq!(
        settings_from_ini(&joints, "m.ini")
            .unwrap()
            .axis_max_vel_mm_s,
        [10.0; 3]
    );
}

/// Closed forms of one 90° corner in the XY plane on the recorded machine
/// (every axis 1000 mm/s²): G64 P0.05 blends with an arc of radius
/// R = P·cos θ/(1 − sin θ)·tan θ (θ = 45°, blendmath.c's d_tol), run at
/// v = √(a_n·R) with a_n = a·√(1 − 0.5²); its middle passes P from the corner.
#[test]
fn a_blended_corner_runs_at_the_speed_and_distance_of_its_arc() {
    let settings = sim_settings();
    let name = "corner_g64_p005";
    let ours = samples(&program(name), &settings).unwrap();
    let theta = std::f64::consts::FRAC_PI_4;
    let p = 0.05;
    let radius = p * theta.cos() / (1.0 - theta.sin()) * theta.tan();
    let v = (1000.0 * 0.75f64.sqrt() * radius).sqrt();
    let corner = Point3::new(20.0, 0.0, 0.0);
    let center =
        corner + nalgebra::Vector3::new(-1.0, 1.0, 0.0).normalize() * (radius / theta.sin());
    // Samples on the arc, but its first (the speed of its period's start).
    let on_arc: Vec<&ServoSample> = ours
        .windows(2)
        .filter(|w| {
            let on = |s: &ServoSample| {
                ((s.pos - center).norm() - radius).abs() < 1e-9
                    && s.pos.y > 1e-9
                    && s.pos.x < 20.0 - 1e-9
            };
            on(&w[0]) && on(&w[1])
        })
        .map(|w| &w[1])
        .collect();
    assert!(on_arc.len() >= 10, "{}", on_arc.len());
    // It enters at the line's final speed, a hair lower, then holds v.
    let at_v = on_arc
        .iter()
        .filter(|s| (s.feed_mm_min / 60.0 - v).abs() < 1e-9)
        .count();
    assert!(at_v + 1 >= on_arc.len(), "{at_v} of {}", on_arc.len());
    assert!(on_arc.iter().all(|s| s.feed_mm_min / 60.0 <= v + 1e-9));
    let closest = ours
        .iter()
        .map(|s| (s.pos - corner).norm())
        .fold(f64::MAX, f64::min);
    assert!((closest - p).abs() < 2e-4, "{closest}");
    // The real planner ran the arc at the same speed (its samples are µm
    // apart in nm, so 1e-3 mm/s).
    let real = recording(name);
    let on_real: Vec<f64> = real
        .pos
        .windows(2)
        .filter(|w| (w[1] - corner).norm() < 0.1 && w[1].y > 0.0 && w[0].y > 0.0)
        .map(|w| (w[1] - w[0]).norm() / real.period_s)
        .collect();
    // Seen through chords of the joints' cubic interpolation, which runs a
    // circle on the radius (2 + cos Δφ)/3·R.
    let dphi = v * real.period_s / radius;
    let seen = v * (dphi / 2.0).sin() / (dphi / 2.0) * (2.0 + dphi.cos()) / 3.0;
    let at_v = on_real.iter().filter(|r| (*r - seen).abs() < 2e-3).count();
    assert!(
        at_v + 2 >= on_real.len() && at_v >= 5,
        "{on_real:?} against {seen}"
    );
}

/// G61 stops at the corner: a sample lies on it at rest.
#[test]
fn exact_path_stops_at_the_corner() {
    let ours = samples(&program("corner_g61"), &sim_settings()).unwrap();
    let corner = Point3::new(20.0, 0.0, 0.0);
    let at = ours
        .iter()
        .find(|s| (s.pos - corner).norm() < 1e-9)
        .expect("a sample on the corner");
    assert_eq!(at.feed_mm_min, 0.0);
    assert!(ours.iter().all(|s| s.pos.y == 0.0 || s.pos.x == 20.0));
}

/// The real LinuxCNC, live where it is installed (CI installs it): two unit
/// cases run again and compared as the recordings are.
#[test]
fn live_linuxcnc_runs_as_dexcut_plans() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    if !std::path::Path::new("/usr/bin/linuxcnc").exists() {
        assert!(
            std::env::var_os("CI").is_none(),
            "linuxcnc not installed (apt-get install linuxcnc-uspace) but CI is set"
        );
        println!("skipped: linuxcnc not installed");
        return;
    }
    let out = std::env::temp_dir().join(format!("dexcut-lcnc-live-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    for name in ["corner_g64_p005", "zigzag_short_g64_p002"] {
        let raw = out.join(format!("{name}.txt"));
        let packed = out.join(format!("{name}.txt.gz"));
        let program = data_dir().join(format!("programs/{name}.ngc"));
        let run = std::process::Command::new("bash")
            .arg(root.join("scripts/linuxcnc_reference/run.sh"))
            .arg(&program)
            .arg(&raw)
            .status()
            .expect("run.sh");
        assert!(run.success(), "{name}: LinuxCNC did not run");
        let pack = std::process::Command::new("python3")
            .arg(root.join("scripts/linuxcnc_reference/pack.py"))
            .args([&raw, &packed])
            .arg(name)
            .arg("1000000")
            .status()
            .expect("pack.py");
        assert!(pack.success());
        let c = compare_with(name, recording_at(&packed));
        println!(
            "{name}: live {:.3} s, dexcut {:.3} s, {:.1} % within 2 %",
            c.real_s,
            c.dexcut_s,
            c.within_2pct * 100.0
        );
        // The live task hands the moves to motion in real time: on a loaded
        // machine the first ones may reach it a period or two late, which
        // shifts the speeds at the same distance (36.5 % within 2 % seen
        // under a full test run; 100 % alone) but not the path or the time
        // in motion. Those are asserted; the recordings above hold the
        // per-period speeds to 2 %.
        assert!(
            (c.dexcut_s - c.real_s).abs() <= 0.01 * c.real_s,
            "{name}: live {} s, dexcut {} s",
            c.real_s,
            c.dexcut_s
        );
        assert!(
            c.max_gap_mm <= 0.01,
            "{name}: paths {} mm apart",
            c.max_gap_mm
        );
    }
    std::fs::remove_dir_all(&out).ok();
}

/// The samples dexcut's sweep needs: from the path's start to its end, one
/// per period, segments in order, the distance run growing.
#[test]
fn samples_run_from_start_to_end_in_order() {
    let machine = schedule::Machine {
        period_ms: 2.0,
        ..schedule::Machine::default()
    };
    for name in ["zigzag_short_g64", "engrave_locket", "arcs_g64_p001"] {
        let path = program(name);
        let s = schedule::linuxcnc::samples(&path, &machine, &Default::default()).unwrap();
        assert_eq!(s[0].pos, path.segments[0].start);
        // Positions add up each period's move, as tp.c's do.
        assert!((s.last().unwrap().pos - path.segments.last().unwrap().end).norm() < 1e-9);
        for (k, w) in s.windows(2).enumerate() {
            assert!((w[1].t_s - (k + 1) as f64 * 0.002).abs() < 1e-12);
            assert!(w[1].segment >= w[0].segment && w[1].s_mm >= w[0].s_mm);
            // Within the machine's rapid rate (every axis at it, the path too).
            assert!((w[1].pos - w[0].pos).norm() <= machine.rapid_mm_min / 60.0 * 0.002 + 1e-9);
        }
    }
}
