//! Differential test against LinuxCNC's `rs274` (Debian `linuxcnc-uspace`).
//!
//! rs274 prints canonical commands with 4 decimals in program units (inch
//! after G20) and positions in program coordinates (work offset and G92
//! printed separately); arcs as `ARC_FEED(first_end, second_end,
//! first_centre, second_centre, rotation, axis_end, …)` where |rotation| is
//! the turn count and its sign the direction (negative = clockwise). Both
//! sides are converted to mm in the machine frame; zero-length moves are
//! dropped on both sides. Tolerance: half a unit of rs274's last printed
//! digit (5e-5 program units) plus rounding of the offsets.

use std::path::{Path, PathBuf};
use std::process::Command;

use nc::{Geometry, Motion, Options, Plane};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Rapid,
    Feed,
    Dwell,
}

#[derive(Debug, Clone, Copy)]
struct Move {
    kind: Kind,
    end: [f64; 3],
    /// Centre and signed turn count of an arc (negative = clockwise).
    arc: Option<([f64; 3], i64)>,
    /// Feed (mm/min) or dwell time (s).
    value: f64,
    /// Tolerance of lengths in mm (depends on the units rs274 printed in).
    tol: f64,
}

fn numbers(args: &str) -> Vec<f64> {
    args.split(',')
        .filter_map(|a| a.trim().parse().ok())
        .collect()
}

/// rs274 instances running at once interfere (shared parameter file), so
/// the tests of this file take turns.
static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn rs274_moves(file: &Path) -> Vec<Move> {
    let out = {
        let _turn = RS274.lock().unwrap_or_else(|e| e.into_inner());
        Command::new("rs274")
            .arg("-g")
            .arg(file)
            .output()
            .expect("run rs274")
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let (mut scale, mut g5x, mut g92) = (1.0, [0.0; 3], [0.0; 3]);
    let (mut plane, mut feed, mut pos) = (Plane::XY, 0.0, [0.0; 3]);
    let mut moves = Vec::new();
    for line in text.lines() {
        // "   12 N30    CMD(args)": sequence number, N field, command.
        let mut fields = line.trim_start().splitn(3, ' ');
        let (Some(_), Some(n), Some(cmd)) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        if !n.starts_with('N') {
            continue;
        }
        let cmd = cmd.trim_start();
        let (name, args) = cmd.split_once('(').unwrap_or((cmd, ""));
        let args = args.trim_end_matches(')');
        let v = numbers(args);
        let tol = 6e-5 * scale + 1e-9;
        let machine = |i: usize, p: f64| p * scale + g5x[i] + g92[i];
        match name {
            "USE_LENGTH_UNITS" => scale = if args.contains("INCHES") { 25.4 } else { 1.0 },
            "SET_G5X_OFFSET" => g5x = [v[1] * scale, v[2] * scale, v[3] * scale],
            "SET_G92_OFFSET" => g92 = [v[0] * scale, v[1] * scale, v[2] * scale],
            "SELECT_PLANE" => {
                plane = if args.contains("XZ") {
                    Plane::ZX
                } else if args.contains("YZ") {
                    Plane::YZ
                } else {
                    Plane::XY
                }
            }
            "SET_FEED_RATE" => feed = v[0] * scale,
            "DWELL" => moves.push(Move {
                kind: Kind::Dwell,
                end: pos,
                arc: None,
                value: v[0],
                tol,
            }),
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => {
                let end = [machine(0, v[0]), machine(1, v[1]), machine(2, v[2])];
                if (0..3).any(|i| (end[i] - pos[i]).abs() > 1e-12) {
                    let kind = if name == "STRAIGHT_FEED" {
                        Kind::Feed
                    } else {
                        Kind::Rapid
                    };
                    moves.push(Move {
                        kind,
                        end,
                        arc: None,
                        value: feed,
                        tol,
                    });
                }
                pos = end;
            }
            "ARC_FEED" => {
                let (a, b, n) = plane.axes();
                let mut end = [0.0; 3];
                let mut centre = pos;
                end[a] = machine(a, v[0]);
                end[b] = machine(b, v[1]);
                end[n] = machine(n, v[5]);
                centre[a] = machine(a, v[2]);
                centre[b] = machine(b, v[3]);
                moves.push(Move {
                    kind: Kind::Feed,
                    end,
                    arc: Some((centre, v[4] as i64)),
                    value: feed,
                    tol,
                });
                pos = end;
            }
            _ => {}
        }
    }
    moves
}

fn our_moves(source: &str, name: &str) -> Vec<Move> {
    let parsed = nc::parse(source, name, &Options::default());
    if let Some(d) = parsed.diagnostics.first() {
        panic!("{d}");
    }
    parsed
        .path
        .segments
        .iter()
        .map(|s| {
            let (kind, value) = match s.motion {
                Motion::Rapid => (Kind::Rapid, 0.0),
                Motion::Feed { feed_mm_min } => (Kind::Feed, feed_mm_min),
                Motion::Dwell { seconds } => (Kind::Dwell, seconds),
            };
            let arc = match s.geometry {
                Geometry::Line => None,
                Geometry::Arc {
                    center,
                    clockwise,
                    sweep_rad,
                    ..
                } => {
                    let turns = ((sweep_rad - 1e-9) / std::f64::consts::TAU).floor() as i64 + 1;
                    Some((
                        [center.x, center.y, center.z],
                        if clockwise { -turns } else { turns },
                    ))
                }
            };
            Move {
                kind,
                end: [s.end.x, s.end.y, s.end.z],
                arc,
                value,
                tol: 0.0,
            }
        })
        .collect()
}

fn compare(file: &Path) -> Result<usize, String> {
    let source = std::fs::read_to_string(file).map_err(|e| e.to_string())?;
    let ours = our_moves(&source, &file.display().to_string());
    let theirs = rs274_moves(file);
    if ours.len() != theirs.len() {
        return Err(format!(
            "{}: {} moves vs rs274's {}",
            file.display(),
            ours.len(),
            theirs.len()
        ));
    }
    for (i, (o, t)) in ours.iter().zip(&theirs).enumerate() {
        let close = |x: f64, y: f64| (x - y).abs() <= t.tol;
        let same_arc = match (o.arc, t.arc) {
            (None, None) => true,
            (Some((c1, r1)), Some((c2, r2))) => r1 == r2 && (0..3).all(|k| close(c1[k], c2[k])),
            _ => false,
        };
        let value_ok = match o.kind {
            Kind::Rapid => true,
            Kind::Dwell => (o.value - t.value).abs() <= 6e-5,
            Kind::Feed => (o.value - t.value).abs() <= t.tol,
        };
        if o.kind != t.kind || !(0..3).all(|k| close(o.end[k], t.end[k])) || !same_arc || !value_ok
        {
            return Err(format!(
                "{}: move {i} differs:\n ours   {o:?}\n rs274  {t:?}",
                file.display()
            ));
        }
    }
    Ok(ours.len())
}

/// False (after checking CI does not require it) when rs274 is missing.
fn have_rs274() -> bool {
    if Command::new("rs274").arg("-h").output().is_err() {
        assert!(
            std::env::var_os("CI").is_none(),
            "rs274 not installed (apt-get install linuxcnc-uspace) but CI is set"
        );
        println!("skipped: rs274 not installed");
        return false;
    }
    true
}

fn corpus() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../toolpaths");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("toolpaths/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "corpus missing");
    files
}

/// Programs written by `nc::refeed` (every feed block longer than 1 mm split
/// in three) read the same in LinuxCNC as in our interpreter.
#[test]
fn refed_programs_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    for f in corpus() {
        let source = std::fs::read_to_string(&f).expect("read");
        let path = nc::parse(&source, "in.ngc", &Options::default()).path;
        let plan: Vec<Vec<(f64, f64)>> = path
            .segments
            .iter()
            .map(|s| match s.motion {
                Motion::Feed { .. } if s.length_mm() > 1.0 => {
                    vec![(0.3, 444.0), (0.6, 1234.0), (1.0, 777.0)]
                }
                Motion::Feed { .. } => vec![(1.0, 555.0)],
                _ => vec![],
            })
            .collect();
        let out = nc::refeed(&source, "in.ngc", &Options::default(), &plan)
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let written = dir.path().join(f.file_name().expect("name"));
        std::fs::write(&written, out).expect("write");
        match compare(&written) {
            Ok(n) => println!("{} re-fed: {n} moves agree", f.display()),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// LinuxCNC's own sample programs (installed with the package): every one
/// our interpreter accepts without a diagnostic must read the same in rs274.
/// Those it rejects (lathe cycles, cutter compensation, probing, remaps, …)
/// are listed with the reason.
#[test]
fn installed_samples_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    // The package installs them in /usr/share/linuxcnc/ncfiles, linked from
    // /usr/share/doc/linuxcnc/examples/nc_files.
    let dirs = [
        "/usr/share/linuxcnc/ncfiles",
        "/usr/share/doc/linuxcnc/examples/nc_files",
    ];
    let Some(entries) = dirs.iter().find_map(|d| std::fs::read_dir(d).ok()) else {
        assert!(
            std::env::var_os("CI").is_none(),
            "{dirs:?} missing but CI is set"
        );
        println!("skipped: no LinuxCNC sample programs in {dirs:?}");
        return;
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    files.sort();
    let (mut accepted, mut failures, mut with_motion) = (Vec::new(), Vec::new(), 0);
    for f in &files {
        let Ok(source) = std::fs::read_to_string(f) else {
            continue;
        };
        let parsed = nc::parse(
            &source,
            &f.display().to_string(),
            &Options {
                max_blocks: 1_000_000,
                ..Options::default()
            },
        );
        if let Some(d) = parsed.diagnostics.first() {
            println!("not supported: {d}");
            continue;
        }
        match compare(f) {
            Ok(n) => {
                with_motion += usize::from(n > 0);
                accepted.push(format!("{} ({n} moves)", f.display()));
            }
            Err(e) => failures.push(e),
        }
    }
    println!(
        "{} of {} samples accepted and agree:\n  {}",
        accepted.len(),
        files.len(),
        accepted.join("\n  ")
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(with_motion >= 5, "too few samples with motion accepted");
}

#[test]
fn matches_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let files = corpus();
    let mut failures = Vec::new();
    for f in &files {
        match compare(f) {
            Ok(n) => println!("{}: {n} moves agree", f.display()),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
