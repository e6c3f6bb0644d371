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
//!
//! Both read the same tool table ([`tool_length_mm`]; rs274's standalone
//! table is in inches). rs274 prints positions without the tool length
//! offset (USE_TOOL_LENGTH_OFFSET separately); the tool tip is that gauge
//! point minus the gauge length of the tool in the spindle, which is what
//! dexcut's path holds. A tool change that moves the tip is a rapid on both
//! sides, and the first tool loaded is in the spindle from the start.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use nc::{FileForm, Geometry, Motion, Options, Plane};

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
    tool: u32,
}

/// Gauge length (mm) of tool `t` in the tables of both readers: T1–T20
/// from 38.1 to 279.4 mm, the higher numbers as the one of their rank in
/// 1–20 (T212 as T12).
fn tool_length_mm(t: u32) -> f64 {
    if t == 0 {
        0.0
    } else {
        12.7 * rank(t) as f64 + 25.4
    }
}

/// Diameter (mm) of tool `t`.
fn tool_diameter_mm(t: u32) -> f64 {
    1.27 * rank(t) as f64 + 2.54
}

/// `t` (≥ 1) folded into 1–20.
fn rank(t: u32) -> u32 {
    (t - 1) % 20 + 1
}

/// The tools of both tables: T1–T20, T212 that Mastercam posts call
/// (tests/data/real/mastercam_*) and T112, T501, T606 of Carbide Copper's
/// library (tests/data/real/carbidecopper_*).
fn tools() -> impl Iterator<Item = u32> {
    (1..=20).chain([112, 212, 501, 606])
}

fn tool_table() -> BTreeMap<u32, f64> {
    tools().map(|t| (t, tool_length_mm(t))).collect()
}

/// The tool table for rs274 (inches), written once.
fn rs274_tool_table() -> PathBuf {
    static TABLE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    TABLE
        .get_or_init(|| {
            let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rs274-tools.tbl");
            let text: String = tools()
                .map(|t| {
                    format!(
                        "T{t} P{t} Z{} D{}\n",
                        tool_length_mm(t) / 25.4,
                        tool_diameter_mm(t) / 25.4
                    )
                })
                .collect();
            let partial = path.with_extension(format!("{}", std::process::id()));
            std::fs::write(&partial, text).expect("write tool table");
            std::fs::rename(&partial, &path).expect("rename tool table");
            path
        })
        .clone()
}

fn numbers(args: &str) -> Vec<f64> {
    args.split(',')
        .filter_map(|a| a.trim().parse().ok())
        .collect()
}

/// rs274 instances running at once interfere (shared parameter file), so
/// the tests of this file take turns.
static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// rs274's moves, the first tool it loads, and its error message if it stopped on one.
fn rs274_moves(file: &Path) -> (Vec<Move>, u32, Option<String>) {
    let out = {
        let _turn = RS274.lock().unwrap_or_else(|e| e.into_inner());
        // LinuxCNC 2.9 keeps tool data in shared memory: rs274 runs of other
        // processes (other checkouts' tests) can swap the table under us.
        // Take a lock all checkouts share, and run again when the table
        // was lost anyway (a run without our lock).
        let lock = std::fs::File::create(std::env::temp_dir().join("dexcut-rs274.lock"))
            .expect("rs274 lock file");
        lock.lock().expect("lock rs274");
        let run = || {
            Command::new("rs274")
                .arg("-t")
                .arg(rs274_tool_table())
                .arg("-g")
                .arg(file)
                .output()
                .expect("run rs274")
        };
        // Now and then rs274 prints no canonical commands at all and no error
        // (seen once in about 40 runs on cds.ngc, with nothing else running):
        // that run says nothing about the program, so it is run again too.
        // A program without motion is run twice more, a lost tool table up to 20 times.
        let lost = |out: &std::process::Output, attempt: usize| {
            let stderr = String::from_utf8_lossy(&out.stderr);
            let stdout = String::from_utf8_lossy(&out.stdout);
            stderr.contains("not found in the tool table")
                || (attempt < 2
                    && stderr
                        .lines()
                        .all(|l| l.trim().is_empty() || l.trim() == "executing")
                    && !stdout.contains("STRAIGHT_")
                    && !stdout.contains("ARC_FEED"))
        };
        let mut out = run();
        for attempt in 0..20 {
            if !lost(&out, attempt) {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
            out = run();
        }
        out
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let error = stderr
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && *l != "executing")
        .map(|l| format!("{l} (at: {})", stderr.lines().last().unwrap_or("").trim()));
    let (mut scale, mut g5x, mut g92) = (1.0, [0.0; 3], [0.0; 3]);
    let (mut plane, mut feed, mut pos) = (Plane::XY, 0.0, [0.0; 3]);
    let mut tlo = [0.0; 3];
    let mut rotation_deg = 0.0_f64;
    let first_tool = first_tool(&text);
    let mut tool = first_tool;
    pos[2] = -tool_length_mm(first_tool);
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
        let length = tool_length_mm(tool);
        // Tool tip: program point + offsets + tool length offset − gauge length.
        // Tool tip of program point p (program units), as LinuxCNC's canon
        // (rotate_and_offset_pos): G92 added, the XY rotation, then the
        // work and tool length offsets.
        let machine = |p: [f64; 3]| -> [f64; 3] {
            let q: [f64; 3] = std::array::from_fn(|i| p[i] * scale + g92[i]);
            let (sin, cos) = rotation_deg.to_radians().sin_cos();
            let q = [q[0] * cos - q[1] * sin, q[0] * sin + q[1] * cos, q[2]];
            std::array::from_fn(|i| q[i] + g5x[i] + tlo[i] - if i == 2 { length } else { 0.0 })
        };
        match name {
            "USE_TOOL_LENGTH_OFFSET" => {
                let v: Vec<f64> = args
                    .split([',', ' '])
                    .filter_map(|a| a.trim().parse().ok())
                    .collect();
                tlo = [v[0] * scale, v[1] * scale, v[2] * scale];
            }
            "CHANGE_TOOL" | "CHANGE_TOOL_NUMBER" => {
                let new = tool_changed_to(name, v[0] as u32);
                let jump = tool_length_mm(tool) - tool_length_mm(new);
                if jump != 0.0 {
                    let mut end = pos;
                    end[2] += jump;
                    moves.push(Move {
                        kind: Kind::Rapid,
                        end,
                        arc: None,
                        value: 0.0,
                        tol,
                        tool: new,
                    });
                    pos = end;
                }
                tool = new;
            }
            "USE_LENGTH_UNITS" => scale = if args.contains("INCHES") { 25.4 } else { 1.0 },
            "SET_G5X_OFFSET" => g5x = [v[1] * scale, v[2] * scale, v[3] * scale],
            "SET_XY_ROTATION" => rotation_deg = v[0],
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
                tool,
            }),
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => {
                let end = machine([v[0], v[1], v[2]]);
                if (0..3).any(|i| (end[i] - pos[i]).abs() > SUB_RESOLUTION_MM) {
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
                        tool,
                    });
                    pos = end;
                }
            }
            "ARC_FEED" => {
                let (a, b, n) = plane.axes();
                let mut end_p = [0.0; 3];
                let mut centre_p = [0.0; 3];
                end_p[a] = v[0];
                end_p[b] = v[1];
                end_p[n] = v[5];
                centre_p[a] = v[2];
                centre_p[b] = v[3];
                let end = machine(end_p);
                let mut centre = pos;
                let c = machine(centre_p);
                centre[a] = c[a];
                centre[b] = c[b];
                moves.push(Move {
                    kind: Kind::Feed,
                    end,
                    arc: Some((centre, v[4] as i64)),
                    value: feed,
                    tol,
                    tool,
                });
                pos = end;
            }
            _ => {}
        }
    }
    (moves, first_tool, error)
}

/// The first tool rs274 loads (0 if none): in the spindle from the start.
fn first_tool(rs274_output: &str) -> u32 {
    rs274_output
        .lines()
        .find_map(|l| {
            let (_, rest) = l.split_once("CHANGE_TOOL")?;
            let (name, rest) = match rest.strip_prefix("_NUMBER") {
                Some(rest) => ("CHANGE_TOOL_NUMBER", rest),
                None => ("CHANGE_TOOL", rest),
            };
            let n = rest
                .trim_start_matches('(')
                .split(')')
                .next()?
                .trim()
                .parse()
                .ok()?;
            Some(tool_changed_to(name, n))
        })
        .unwrap_or(0)
}

/// The tool number of rs274's `CHANGE_TOOL(n)`, which prints the tool's
/// index in its table (1-based, in [`tools`] order: T212 is 22), or of
/// `CHANGE_TOOL_NUMBER(n)`, which prints the number.
fn tool_changed_to(command: &str, n: u32) -> u32 {
    match command {
        "CHANGE_TOOL" if n > 0 => tools().nth(n as usize - 1).unwrap_or(n),
        _ => n,
    }
}

/// Options of both readers: the tool table, and the first tool's tip where
/// rs274 starts its gauge point (the origin).
fn options(first_tool: u32) -> Options {
    options_as(first_tool, FileForm::LinuxCnc)
}

/// [`options`] with another [`FileForm`] (ours only: rs274 reads as LinuxCNC).
fn options_as(first_tool: u32, file_form: FileForm) -> Options {
    Options {
        tool_lengths_mm: tool_table(),
        tool_diameters_mm: tools().map(|t| (t, tool_diameter_mm(t))).collect(),
        initial_position_mm: [0.0, 0.0, -tool_length_mm(first_tool)],
        max_blocks: 1_000_000,
        file_form,
        ..Options::default()
    }
}

/// Straight moves that end within this distance (mm, on every axis) of the
/// last move kept are dropped on both sides: rs274 prints 4 decimals, so
/// moves below its resolution (0.0001 in) may print as zero-length.
const SUB_RESOLUTION_MM: f64 = 0.0016;

fn our_moves(source: &str, name: &str, options: &Options) -> Vec<Move> {
    let parsed = nc::parse(source, name, options);
    if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
        panic!("{d}");
    }
    let mut last = parsed
        .path
        .segments
        .first()
        .map_or([0.0; 3], |s| [s.start.x, s.start.y, s.start.z]);
    parsed
        .path
        .segments
        .iter()
        .filter(|s| {
            let end = [s.end.x, s.end.y, s.end.z];
            let keep = !matches!(s.geometry, Geometry::Line)
                || matches!(s.motion, Motion::Dwell { .. })
                || (0..3).any(|i| (end[i] - last[i]).abs() > SUB_RESOLUTION_MM);
            if keep {
                last = end;
            }
            keep
        })
        .map(|s| {
            let (kind, value) = match s.motion {
                Motion::Rapid => (Kind::Rapid, 0.0),
                Motion::Feed { feed_mm_min, .. } => (Kind::Feed, feed_mm_min),
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
                tool: s.tool,
            }
        })
        .collect()
}

fn compare(file: &Path) -> Result<usize, String> {
    let source = std::fs::read_to_string(file).map_err(|e| e.to_string())?;
    compare_as(&source, FileForm::LinuxCnc, file)
}

/// Our moves of `source` read as `form` against rs274's moves of `file`.
fn compare_as(source: &str, form: FileForm, file: &Path) -> Result<usize, String> {
    let (theirs, first_tool, error) = rs274_moves(file);
    if let Some(e) = error {
        return Err(format!("{}: rs274 refuses it: {e}", file.display()));
    }
    let ours = our_moves(
        source,
        &file.display().to_string(),
        &options_as(first_tool, form),
    );
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
        if o.kind != t.kind
            || o.tool != t.tool
            || !(0..3).all(|k| close(o.end[k], t.end[k]))
            || !same_arc
            || !value_ok
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

/// Canned cycles repeated by L under G91 and polar ones (`@`, `^`, under G20),
/// each repeat needing its own feeds: written out as G0/G1/G4 blocks of
/// their moves, the programs read the same in rs274 as in our interpreter,
/// move for move.
#[test]
fn repeated_and_polar_cycles_written_out_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let peck = dir.path().join("peck_g91.ngc");
    std::fs::write(
        &peck,
        "G21 G90 G17\nG0 X0 Y0 Z12.7\nG20 G91 G99 G83 X0.4 Y0.1 R-0.4 Z-0.3 Q0.08 L3 F6\nG80\nG0 X0.1 Z0.2\nG90 G0 Z1\nM2\n",
    )
    .expect("write");
    let mut failures = Vec::new();
    for f in [
        peck,
        here.join("../../toolpaths/drill_g93.ngc"),
        here.join("tests/data/real/linuxcnc_hole_circle.ngc"),
        here.join("tests/data/real/linuxcnc_polar.ngc"),
    ] {
        let source = std::fs::read_to_string(&f).expect("read");
        let path = nc::parse(&source, "in.ngc", &Options::default()).path;
        let plan: Vec<Vec<(f64, f64)>> = path
            .segments
            .iter()
            .enumerate()
            .map(|(i, s)| match s.motion {
                Motion::Feed { .. } if s.length_mm() > 1.0 => {
                    vec![(0.3, 2000.0 - i as f64), (1.0, 150.0 + i as f64)]
                }
                Motion::Feed { .. } => vec![(1.0, 300.0 + i as f64)],
                _ => vec![],
            })
            .collect();
        let out = nc::refeed(&source, "in.ngc", &Options::default(), &plan)
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let cycle = out.lines().find(|l| {
            !l.starts_with('(') && ["G73", "G81", "G82", "G83"].iter().any(|g| l.contains(g))
        });
        assert!(cycle.is_none(), "{}: {cycle:?} kept:\n{out}", f.display());
        let written = dir.path().join(format!(
            "refed_{}",
            f.file_name().expect("name").to_string_lossy()
        ));
        std::fs::write(&written, out).expect("write");
        match compare(&written) {
            Ok(n) => println!("{} re-fed: {n} moves agree", f.display()),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The boring cycles G85 (feed in, feed out to R) and G89 (dwell at the
/// bottom, feed out to the clear height), under G98 and G99, with L repeats
/// under G91 and an R plane above the start: rs274 reads the program as our
/// interpreter does, move for move, and so it reads the re-fed program, whose
/// cycles are written out as moves where a feed move gets two feeds.
#[test]
fn boring_cycles_match_linuxcnc_rs274_as_written_and_written_out() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let source = "G21 G90 G17\nS1000 M3\nG0 X0 Y0 Z5\nG98 G85 X1 Y1 Z-2 R1 F100\nX3\n\
        G99 G89 X5 Y2 Z-3 R2 P0.5\nG98 X7 Y4 P0.25\nG80\nG0 Z4\nG91 G98 G85 X2 Y1 R-2 Z-3 L3 F120\n\
        G90 G80\nG99 G89 X0 Y0 Z-1 R7 P1\nG80\nG0 Z10\nM2\n";
    let file = dir.path().join("boring.ngc");
    std::fs::write(&file, source).expect("write");
    let n = compare(&file).unwrap_or_else(|e| panic!("{e}"));
    // 2 + 2 + 3 + 1 holes of 3 moves each at least.
    assert!(n >= 24, "{n} moves");
    let path = nc::parse(source, "in.ngc", &Options::default()).path;
    let dwells = path
        .segments
        .iter()
        .filter(|s| matches!(s.motion, Motion::Dwell { .. }))
        .count();
    assert_eq!(dwells, 3);
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .enumerate()
        .map(|(i, s)| match s.motion {
            Motion::Feed { .. } => vec![(0.5, 900.0 - i as f64), (1.0, 80.0 + i as f64)],
            _ => vec![],
        })
        .collect();
    let out = nc::refeed(source, "in.ngc", &Options::default(), &plan).expect("re-fed");
    let cycle = out
        .lines()
        .find(|l| !l.starts_with('(') && ["G85", "G89"].iter().any(|g| l.contains(g)));
    assert!(cycle.is_none(), "{cycle:?} kept:\n{out}");
    let written = dir.path().join("boring_refed.ngc");
    std::fs::write(&written, out).expect("write");
    let m = compare(&written).unwrap_or_else(|e| panic!("{e}"));
    assert!(m > n, "{m} moves written out, {n} before");
}

/// Canned cycle lines run more than once (in an o-word loop, in a subroutine
/// called twice under G91 with L), each run written out as its own moves
/// behind an `if` chain on a run counter: rs274 reads the written program
/// as our interpreter does, move for move.
#[test]
fn cycles_run_more_than_once_written_out_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let source = "o100 sub\nG91 G98 G81 X6 Y0 R-8 Z-5 L2 F150\nG90 G80\no100 endsub\n\
        G21 G90 G17\nG0 X0 Y0 Z10\n#1 = 0\no1 repeat [3]\nG99 G81 X[10 + 10 * #1] Y5 Z-3 R2 F150\nX[15 + 10 * #1]\n\
        G80\n#1 = [#1 + 1]\no1 endrepeat\nG0 X0 Y20 Z10\no100 call\nG0 X30 Y20 Z10\no100 call\nM2\n";
    let path = nc::parse(source, "in.ngc", &Options::default()).path;
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .enumerate()
        .map(|(i, s)| match s.motion {
            Motion::Feed { .. } => vec![(0.4, 2000.0 - i as f64), (1.0, 150.0 + i as f64)],
            _ => vec![],
        })
        .collect();
    let out = nc::refeed(source, "in.ngc", &Options::default(), &plan).expect("re-fed");
    assert!(!out.contains("G81"), "a cycle kept:\n{out}");
    let dir = tempfile::tempdir().expect("temp dir");
    let written = dir.path().join("cycles_per_run.ngc");
    std::fs::write(&written, out).expect("write");
    let n = compare(&written).unwrap_or_else(|e| panic!("{e}"));
    assert!(n >= 40, "{n} moves");
}

/// Feed lines in polar coordinates (`G1 @ ^`, under G90 and G91, in inches,
/// in a loop reading a table) split into Cartesian pieces: rs274 reads the
/// written program as our interpreter does, move for move.
#[test]
fn polar_feed_lines_split_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let source = "G21 G90 G17\nG0 X0 Y0 Z1\nG1 @20 ^30 F600\nG1 @20 ^75 Z-1\nG91 G1 @-5 ^15\n\
        G1 ^-40\nG90 G20 G1 @0.5 ^200\nG21\n#1 = 0\no1 repeat [3]\nG1 @[10 + 3 * #1] ^[100 + 20 * #1] F500\n#1 = [#1 + 1]\no1 endrepeat\nM2\n";
    let path = nc::parse(source, "in.ngc", &Options::default()).path;
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .enumerate()
        .map(|(i, s)| match s.motion {
            Motion::Feed { .. } => vec![(0.4, 2000.0 - i as f64), (1.0, 150.0 + i as f64)],
            _ => vec![],
        })
        .collect();
    let out = nc::refeed(source, "in.ngc", &Options::default(), &plan).expect("re-fed");
    assert!(
        !out.contains('@') && !out.contains('^'),
        "polar words kept:\n{out}"
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let written = dir.path().join("polar_split.ngc");
    std::fs::write(&written, out).expect("write");
    let n = compare(&written).unwrap_or_else(|e| panic!("{e}"));
    assert!(n >= 17, "{n} moves");
}

/// A loop whose records do not fit the table of numbered parameters is
/// written out in full (unrolled): rs274 reads the written program as our
/// interpreter does, move for move, with every run's own pieces.
#[test]
fn unrolled_loops_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let source = "G21 G90\nG0 X0 Y0 Z1\n#1 = 0\no1 repeat [700]\no2 if [[#1 MOD 2] EQ 0]\n\
        G1 X[#1 / 10] Y1 Z-1 F500\no2 else\nG1 X[#1 / 10] Y0 Z-1 F500\no2 endif\n#1 = [#1 + 1]\n\
        o1 endrepeat\nG0 Z5\nM2\n";
    let path = nc::parse(source, "in.ngc", &Options::default()).path;
    let mut run = 0;
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .map(|s| match s.motion {
            Motion::Feed { .. } => {
                run += 1;
                let k = run as f64;
                vec![(0.25 + 0.01 * (k % 40.0), 3000.0 - k), (1.0, 200.0 + k)]
            }
            _ => vec![],
        })
        .collect();
    let out = nc::refeed(source, "in.ngc", &Options::default(), &plan).expect("re-fed");
    assert!(!out.contains("repeat"), "not unrolled");
    let dir = tempfile::tempdir().expect("temp dir");
    let written = dir.path().join("unrolled.ngc");
    std::fs::write(&written, out).expect("write");
    let n = compare(&written).unwrap_or_else(|e| panic!("{e}"));
    assert!(n >= 1400, "{n} moves");
}

/// LinuxCNC's output and input codes (M62–M68), spindle orientation (M19)
/// and override switches (M50–M53), with their words used and misused: each
/// block is read by both interpreters (the same moves) or refused by both.
#[test]
fn io_orient_and_override_codes_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let blocks = [
        "M62 P0",
        "M63 P1 G1 X2 F100",
        "M64 P0 M5",
        "M65 P0 M3 S100",
        "M66 P0",
        "M66 E0",
        "M66 P0 L1 Q2",
        "M67 E0 Q5 G1 X3 F100",
        "M68 E0 Q1",
        "M19",
        "M19 R90 Q2 P1",
        "M50",
        "M50 P1",
        "M51 P0",
        "M52 P1",
        "M53 P1",
        // Misused: refused by both.
        "M62",
        "M66",
        "M66 P0 E0 L0",
        "M66 P0 L1",
        "M66 E0 L3 Q1",
        "M67 Q1",
        "M19 P3",
        "M48 M50 P1",
        "G1 X1 E2 F100",
        "M63 P0 E1",
        "M19 M3",
        "M62 P0 M63 P1",
        "M101",
    ];
    assert_eq!(read_alike_or_refused_by_both(&blocks, "G21 G90"), (16, 13));
}

/// Where a canned cycle's later block enters its hole: LinuxCNC rises to R
/// at the tool's place only when the cycle's initial level is below R, and
/// enters each hole from the clear height (the first from the tool's Z where
/// that is above R). Before, under G99 an R raised above the tool's Z on a
/// later block made a rise where the tool was, which rs274 does not make.
#[test]
fn later_cycle_blocks_enter_their_holes_as_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let programs = [
        "G99 G81 X1 Y1 Z-2 R1 F100\nX2 R1.5\nX3 R0.5\nG80",
        "G99 G83 X1 Y1 Z-2 R1 Q0.5 F100\nX2 R1.5 Q0.4\nG80",
        "G98 G81 X1 Y1 Z-2 R1 F100\nX2 R6\nX3 R1\nG80",
        "G0 Z0.5\nG99 G81 X1 Y1 Z-2 R1 F100\nX2 R2\nG98 X3 R1.5\nG80",
        "G0 Z0.5\nG98 G82 X1 Y1 Z-2 R1 P0.2 F100\nG91 X1 R0.5 L2\nG90 G80",
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    for (i, program) in programs.iter().enumerate() {
        let file = dir.path().join(format!("c{i}.ngc"));
        std::fs::write(
            &file,
            format!("G21 G90 G17\nS1000 M3\nG0 X0 Y0 Z5\n{program}\nG0 Z10\nM2\n"),
        )
        .expect("write");
        let n = compare(&file).unwrap_or_else(|e| panic!("{program}: {e}"));
        assert!(n >= 8, "{program}: {n} moves");
    }
}

/// P, Q, L and R words where something in the block uses them, and stray
/// ones (a block whose motion or codes use no such word): read with the same
/// moves by both, or refused by both (LinuxCNC's check_other_codes). Before,
/// a stray Q, L or R was read and ignored, so a program LinuxCNC refuses was
/// simulated and written out as it was.
#[test]
fn p_q_l_r_words_used_or_refused_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let blocks = [
        "G83 X1 Y1 Z-2 R1 Q0.5 F100\nX2 R1.5 Q0.4 L1\nG80",
        "G73 X1 Y1 Z-2 R1 Q0.5 F100\nG80",
        "G91 G81 X1 Z-2 R-1 L3 F100\nG90 G80",
        "G82 X1 Y1 Z-2 R1 P0.5 L2 F100\nG80",
        "G2 X2 Y0 R1 F100",
        "G3 X0 Y0 I-1 J0 P2 F100",
        "G64 P0.1 Q0.05",
        "G10 L2 P1 R30",
        "M19 R10 Q2",
        "M66 P0 L0",
        "M61 Q1",
        "G4 P0.5",
        // Stray: refused by both.
        "G1 X1 Q5 F100",
        "G1 X1 L2 F100",
        "G1 X1 R2 F100",
        "G0 X1 R2",
        "M3 Q1",
        "G4 P1 Q1",
        "G81 X1 Y1 Z-1 R1 Q1 F100\nG80",
        "G64 R1",
        "G0 X1 L1",
        "M5 P1",
    ];
    assert_eq!(
        read_alike_or_refused_by_both(&blocks, "G21 G90 G17\nS1000 M3"),
        (12, 10)
    );
}

/// Coordinate systems rotated by `G10 L2 … R` (issue 39): LinuxCNC turns
/// every later move of the system about its origin (lines, arcs in centre
/// and radius form, incremental, polar, canned cycles, cutter
/// compensation), keeps the rotation per system (G55 has its own, G54 gets
/// its own back), takes G92 and G52 in the frame before the rotation, and
/// carries the program point into a rotated active system. Read with the
/// same moves by both, or refused by both. Before, the R word was dropped:
/// `G10 L2 P1 R45` then `G1 X10` ended at X10 Y0, not at X7.07 Y7.07.
#[test]
fn rotated_coordinate_systems_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let blocks = [
        "G10 L2 P1 X0 Y0 R45\nG1 X10",
        "G10 L2 P1 X5 Y-3 R30\nG0 X10 Y0\nG1 X20 Y5 Z-1\nG91 X2 Y2\nG90",
        "G10 L2 P0 X2 R-20\nG1 X5 Y5",
        "G10 L2 P1 X5 R30\nG0 X0 Y0\nG2 X10 Y0 I5 J0\nG3 X0 Y0 R5\nG2 X0 Y0 I5 J0 P2",
        "G10 L2 P1 X5 R30\nG0 X0 Y0\nG90.1 G2 X10 Y0 I5 J0\nG91.1",
        "G10 L2 P1 X5 R30\nG0 X0 Y0 Z1\nG2 X10 Y0 Z-1 I5 J0 F100",
        "G10 L2 P1 X5 R30\nG1 @10 ^20\nG91 G1 ^10\nG90",
        "G10 L2 P2 X10 Y5 R60\nG55 G1 X5 Y0\nG54 G1 X5 Y0\nG55 G1 X0 Y5",
        "G10 L2 P1 R15\nG92 X1 Y2\nG1 X5 Y5\nG92.2\nG1 X6\nG92.3\nG1 Y7\nG92.1\nG1 X3",
        "G10 L2 P1 R15\nG52 X3 Y-2\nG1 X5 Y5\nG52 X0 Y0\nG1 X4",
        "G92 X2 Y1\nG10 L2 P1 X3 R25\nG1 X5 Y5",
        "G0 X4 Y3\nG10 L2 P1 X1 Y1 R40\nG91 G1 X2\nG90",
        "G10 L2 P1 X5 R30\nG99 G81 X5 Y5 Z-2 R1 F100\nX10\nG91 X2 Y1 L3\nG90 G80",
        "G10 L2 P1 X5 R30\nG98 G87 X10 Y10 Z-3 R2 I3 J1 K-1 F100\nG80",
        "G10 L2 P1 X5 R30\nT3 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0\nX20\nG3 X25 Y5 R5\nG1 Y20\nG40 G1 X30 Y30",
        "G10 L2 P1 R30\nG52 X1\nG10 L2 P1 R50\nG1 X3 Y2",
        "G10 L2 P1 R30\nG20 G1 X0.2 Y0.1\nG21",
        "G10 L2 P1 R30\nG43.1 X1 Y2\nG1 X3 Y4\nG49",
        "G10 L2 P1 R30\nG0 X3\nG28 X0 Y0\nG1 X1",
        "G10 L2 P1 R30\nG53 G1 X3 Y4\nG1 X1",
        // Refused by both.
        "G10 L20 P1 X1 R30",
        "G10 L2 P1 R30 I1",
        "T3 M6\nG41 G1 X5 Y5\nG10 L2 P1 R30\nG40",
    ];
    assert_eq!(
        read_alike_or_refused_by_both(&blocks, "G21 G90 G17\nS1000 M3 F100"),
        (20, 3)
    );
    // Re-fed with two feeds per move: lines placed by a rotated system are
    // not split (their pieces' coordinates would need the rotation), and
    // rs274 reads the written program with the same moves.
    let source =
        "G21 G90 G17\nG0 X0 Y0 Z1\nG1 X20 F300\nG10 L2 P1 X5 R30\nG1 X10 Y5\nG2 X20 Y5 I5 J0\n\
        G91 G1 X3\nG90 G81 X2 Y2 Z-1 R1\nG91 X1 L2\nG90 G80\nG10 L2 P1 X0 R0\nG1 X0 Y0\nM2\n";
    let path = nc::parse(source, "in.ngc", &Options::default()).path;
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .enumerate()
        .map(|(i, s)| match s.motion {
            Motion::Feed { .. } => vec![(0.5, 900.0 - i as f64), (1.0, 200.0 + i as f64)],
            _ => vec![],
        })
        .collect();
    let out = nc::refeed(source, "in.ngc", &Options::default(), &plan).expect("re-fed");
    let dir = tempfile::tempdir().expect("temp dir");
    let written = dir.path().join("rotated_refed.ngc");
    std::fs::write(&written, &out).expect("write");
    let n = compare(&written).unwrap_or_else(|e| panic!("{e}\n{out}"));
    assert!(n >= 10, "{n} moves");
}

/// Tapping (G84 under M3, G74 under M4: in and out at the feed, to the
/// clear height), boring with the spindle stopped for a rapid out (G86) and
/// back boring (G87, through the hole beside it by I J, up to K and back):
/// read with LinuxCNC's moves, under G98 and G99, G90 and G91, in inches,
/// with repeats; refused by both where LinuxCNC refuses them (the spindle
/// turning the wrong way or not at all, a missing P, I, J, K, R or Z when
/// the cycle is entered from another mode). The tapping feeds are held.
#[test]
fn tapping_and_boring_cycles_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let clockwise = [
        "G98 G84 X1 Y1 Z-2 R1 F100\nX3 Y2\nG80",
        "G99 G84 X1 Y1 Z-2 R1 P0.5 F100\nX2\nG80",
        "G91 G98 G84 X2 Y1 Z-3 R-2 L3 F100\nG90 G80",
        "G20 G99 G84 X0.1 Y0.1 Z-0.2 R0.05 F4\nG80 G21",
        "G99 G86 X1 Y1 Z-2 R1 P0.5 F100\nX3 P0\nG98 X4\nG80",
        "G91 G99 G86 X1 Z-2 R-1 P1 L2 F100\nG90 G80",
        "G99 G87 X10 Y10 Z-3 R2 I3 J1 K-1 F100\nX20\nG80",
        "G98 G87 X10 Y10 Z-3 R2 I-2 J0 K-1.5 F100\nG91 X5 Z-4 R-1 K2\nG90 G80",
        "G81 X1 Y1 Z-2 R1 F100\nG84 X2 R1 Z-2\nG80",
        // Refused by both.
        "G81 X1 Y1 Z-2 R1 F100\nG84 X2\nG80",
        "G74 X1 Y1 Z-2 R1 F100\nG80",
        "G86 X1 Y1 Z-2 R1 F100\nG80",
        "G87 X1 Y1 Z-3 R1 I1 K-1 F100\nG80",
        "G82 X1 Y1 Z-2 R1 F100\nG80",
        "G84 X1 Y1 R1 F100\nG80",
        "G84 X1 Y1 Z-1 R1 Q1 F100\nG80",
        "G1 X1 I1 F100",
    ];
    assert_eq!(
        read_alike_or_refused_by_both(&clockwise, "G21 G90 G17\nS500 M3"),
        (9, 8)
    );
    let counterclockwise = [
        "G98 G74 X1 Y1 Z-2 R1 F100\nX3 Y2\nG80",
        "G99 G86 X1 Y1 Z-2 R1 P0.2 F100\nG80",
        "G84 X1 Y1 Z-2 R1 F100\nG80",
    ];
    assert_eq!(
        read_alike_or_refused_by_both(&counterclockwise, "G21 G90 G17\nS500 M4"),
        (2, 1)
    );
    assert_eq!(
        read_alike_or_refused_by_both(&["G84 X1 Y1 Z-2 R1 F100\nG80"], "G21 G90 G17\nS500 M5"),
        (0, 1)
    );
    // The tapping feeds are held, the others not; G86's rapid out and G87's
    // passes through the hole run with the spindle stopped.
    let tapped = nc::parse(
        "G21 G90 S500 M3\nG0 X0 Y0 Z5\nG99 G84 X1 Y1 Z-2 R1 F100\nG80\n\
         G86 X2 Y1 Z-2 R1 P0 F80\nG80\nG87 X10 Y10 Z-3 R2 I3 J1 K-1 F60\nG80\nG1 X0 F200\nM2\n",
        "t.ngc",
        &Options::default(),
    )
    .path;
    let feeds: Vec<(u32, Option<f64>, f64)> = tapped
        .segments
        .iter()
        .filter(|s| matches!(s.motion, Motion::Feed { .. }))
        .map(|s| (s.line, s.motion.held_feed_mm_min(), s.spindle_rpm))
        .collect();
    assert_eq!(
        feeds,
        [
            (3, Some(100.0), 500.0),
            (3, Some(100.0), 500.0),
            (5, None, 500.0),
            (7, None, 500.0),
            (7, None, 500.0),
            (9, None, 500.0)
        ]
    );
    let stopped: Vec<(u32, [f64; 3])> = tapped
        .segments
        .iter()
        .filter(|s| s.spindle_rpm == 0.0)
        .map(|s| (s.line, [s.end.x, s.end.y, s.end.z]))
        .collect();
    assert_eq!(
        stopped,
        [
            (5, [2.0, 1.0, 1.0]),
            (7, [13.0, 11.0, -3.0]),
            (7, [10.0, 10.0, -3.0]),
            (7, [13.0, 11.0, -3.0]),
            (7, [13.0, 11.0, 2.0]),
            (7, [10.0, 10.0, 2.0])
        ]
    );
}

/// Each of `blocks` in a program of its own (`setup`, a rapid to Z5, the
/// block, a feed move, M2): how many both interpreters read with the same
/// moves, and how many both refuse; panics where they differ.
fn read_alike_or_refused_by_both(blocks: &[&str], setup: &str) -> (usize, usize) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    let (mut agree, mut refused) = (0, 0);
    for (i, block) in blocks.iter().enumerate() {
        let file = dir.path().join(format!("b{i}.ngc"));
        std::fs::write(
            &file,
            format!("{setup}\nG0 X0 Y0 Z5\n{block}\nG1 X1 Y1 F200\nM2\n"),
        )
        .expect("write");
        match outcome(&file) {
            Outcome::Agree(_) => agree += 1,
            Outcome::BothRefuse(..) => refused += 1,
            Outcome::Differ(e) => failures.push(format!("{block}: {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    (agree, refused)
}

/// Words LinuxCNC reads as whole numbers (rs274ngc's `read_integer_value`:
/// T, H, L and M words, O numbers, parameter numbers, M98's P) take a value
/// within 0.0001 of one, as expressions compute them (a few ulps off), and G
/// codes one within 0.001 of a tenth: rs274 rounds them, and so do we,
/// through the same moves; M61's Q is rounded to the nearest tool. Further
/// off, both refuse. Before, we refused every one of the first group.
#[test]
fn near_whole_numbers_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let read = [
        "M6 T2.00009\nG43 G0 X1 Z1",
        "M6 T1.99991\nG43 G0 X1 Z1",
        "#1 = [1/3*3*2]\nM6 T#1\nG43 G0 X1 Z1",
        "M6 T-0.00005\nG0 X1",
        "T2 M6\nG43 H2.00005\nG0 X1 Z1",
        "T2 M6\nG43 H1.99995\nG0 X1 Z1",
        "G91 G81 X5 Y0 Z-2 R1 L3.00002 F100\nG90 G80",
        "G91 G81 X5 Y0 Z-2 R1 L[0.1*30] F100\nG90 G80",
        "G10 L2.00002 P1 X5\nG0 X1",
        "M3.00005 S1000\nG1 X1 F100",
        "M2.99995",
        "G1.00005 X1 F100",
        "G0.99995 X1 F100\nG17.99995 G2 X3 Z5 I1 K0",
        "G-0.00001 X1",
        "#1.00005 = 5\nG1 X#1 F100",
        "#1 = 5\nG1 X#0.99995 F100",
        "o100.00005 sub\nG1 X1 F100\no100 endsub\no100 call",
        "G91\nM98 P8.00003 L2.99995\nM2\nO8\nG1 X1 F100\nM99",
        "M6 T3\nG0 X1 Z1\nM61 Q1.4\nG0 X2\nM61 Q1.6\nG0 X3",
    ];
    let refused = [
        "M6 T2.0002\nG0 X1",
        "T2 M6\nG43 H2.5\nG0 X1 Z1",
        "G91 G81 X5 Y0 Z-2 R1 L2.5 F100",
        "M3.5 S100",
        "G1.05 X1 F100",
        "#1.5 = 5",
        "M98 P8.3\nM2\nO8\nG1 X1 F100\nM99",
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    for (i, (text, refuse)) in read
        .iter()
        .map(|t| (t, false))
        .chain(refused.iter().map(|t| (t, true)))
        .enumerate()
    {
        let file = dir.path().join(format!("w{i}.ngc"));
        std::fs::write(&file, format!("G21 G90\nG0 X0 Y0 Z5\n{text}\nM2\n")).expect("write");
        match (outcome(&file), refuse) {
            (Outcome::Agree(n), false) if n > 0 => {}
            (Outcome::BothRefuse(..), true) => {}
            (Outcome::Agree(n), _) => failures.push(format!("{text:?}: both read it ({n} moves)")),
            (Outcome::BothRefuse(ours, theirs), false) => {
                failures.push(format!("{text:?}: both refuse it: {ours} / {theirs}"))
            }
            (Outcome::Differ(e), _) => failures.push(format!("{text:?}: {e}")),
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
        match outcome(f) {
            Outcome::Agree(n) => {
                with_motion += usize::from(n > 0);
                accepted.push(format!("{} ({n} moves)", f.display()));
            }
            Outcome::BothRefuse(ours, theirs) => {
                println!("refused by both: {ours}\n    rs274: {theirs}");
            }
            // What dexcut does not model, refused with a message although
            // rs274 reads it: other axes, lathe work, probing, threading,
            // splines, remapped codes.
            Outcome::Differ(e) if UNSUPPORTED.iter().any(|u| e.contains(u)) => {
                println!("not supported by dexcut (rs274 reads it): {e}");
            }
            Outcome::Differ(e) => failures.push(e),
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

/// Refusals of features dexcut does not model (message fragments).
const UNSUPPORTED: [&str; 9] = [
    "axis A is not supported",
    "axis B is not supported",
    "(XY) plane only",
    "unknown G code G7",
    "unknown G code G8",
    "unknown G code G5.1",
    "G38.",
    "G33 is not supported",
    "keyword 'callsub'",
];

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

/// How one program reads in both interpreters.
enum Outcome {
    /// Both read it and move through the same path (this many moves).
    Agree(usize),
    /// Both refuse it: our first error and rs274's.
    BothRefuse(String, String),
    /// They disagree.
    Differ(String),
}

fn outcome(file: &Path) -> Outcome {
    let Ok(bytes) = std::fs::read(file) else {
        return Outcome::Differ(format!("{}: unreadable", file.display()));
    };
    let source = String::from_utf8_lossy(&bytes);
    let (_, first_tool, rs274_error) = rs274_moves(file);
    let parsed = nc::parse(&source, &file.display().to_string(), &options(first_tool));
    let ours = parsed.diagnostics.iter().find(|d| d.is_error());
    match (ours, rs274_error) {
        (Some(d), Some(e)) => Outcome::BothRefuse(d.to_string(), e),
        (Some(d), None) => Outcome::Differ(format!("we refuse what rs274 reads: {d}")),
        (None, Some(e)) => Outcome::Differ(format!(
            "{}: rs274 refuses ({e}) what we read",
            file.display()
        )),
        (None, None) => match compare(file) {
            Ok(n) => Outcome::Agree(n),
            Err(e) => Outcome::Differ(e),
        },
    }
}

/// A program LinuxCNC refuses, read as most controls read it
/// ([`FileForm::Tolerant`]): where rs274 reads the file amended as our
/// reader says ([`nc::amend`]: byte-order mark dropped, `M2` added, dialect
/// words written as LinuxCNC reads them; what `optimize` writes), we read
/// the original with warnings only, through the same moves; where rs274
/// still refuses it, so do we.
fn tolerant_outcome(file: &Path, dir: &Path) -> Outcome {
    let Ok(source) = std::fs::read_to_string(file) else {
        return Outcome::Differ(format!("{}: unreadable", file.display()));
    };
    let name = file.display().to_string();
    // The first tool as rs274 reports it, from the file as written.
    let (_, first_tool, _) = rs274_moves(file);
    let parsed = nc::parse(&source, &name, &options_as(first_tool, FileForm::Tolerant));
    let amended = dir.join(file.file_name().expect("file name"));
    std::fs::write(&amended, nc::amend(&source, &parsed.amendments)).expect("write amended copy");
    let (_, _, rs274_error) = rs274_moves(&amended);
    let ours = parsed.diagnostics.iter().find(|d| d.is_error());
    match (ours, rs274_error) {
        (Some(d), Some(e)) => Outcome::BothRefuse(d.to_string(), e),
        (Some(d), None) => Outcome::Differ(format!(
            "read as most controls read it, we refuse what rs274 reads once amended: {d}"
        )),
        (None, Some(e)) => Outcome::Differ(format!(
            "{}: rs274 refuses ({e}) the amended copy of what we read with warnings",
            file.display()
        )),
        (None, None) => {
            if !parsed.diagnostics.iter().any(|d| !d.is_error()) {
                return Outcome::Differ(format!(
                    "{}: read with no warning although LinuxCNC refuses it",
                    file.display()
                ));
            }
            match compare_as(&source, FileForm::Tolerant, &amended) {
                Ok(n) => Outcome::Agree(n),
                Err(e) => Outcome::Differ(e),
            }
        }
    }
}

/// Real programs from other CAM systems and people (tests/data/real, sources
/// in its README; `DEXCUT_REAL_DIR` reads another folder): each one rs274
/// reads, we read and move through the same path; each one rs274 refuses,
/// we refuse too.
#[test]
fn real_programs_match_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let dir = std::env::var_os("DEXCUT_REAL_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/real"),
        PathBuf::from,
    );
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("real program folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.file_name().is_some_and(|n| n != "README.md"))
        .collect();
    files.sort();
    let amended_dir = tempfile::tempdir().expect("temp dir");
    let (mut read, mut tolerant, mut refused, mut failures) = (0, 0, 0, Vec::new());
    for f in &files {
        match outcome(f) {
            Outcome::Agree(n) => {
                read += 1;
                println!("read, {n} moves agree: {}", f.display());
            }
            Outcome::BothRefuse(ours, theirs) => match tolerant_outcome(f, amended_dir.path()) {
                Outcome::Agree(n) => {
                    tolerant += 1;
                    println!(
                        "read with warnings, {n} moves agree with rs274 on the amended file: {}",
                        f.display()
                    );
                }
                Outcome::BothRefuse(..) => {
                    refused += 1;
                    println!("refused by both: {ours}\n    rs274: {theirs}");
                }
                Outcome::Differ(e) => failures.push(e),
            },
            Outcome::Differ(e) => failures.push(e),
        }
    }
    println!(
        "{read} read and agree, {tolerant} read with warnings and agree on the amended file, {refused} refused by both, {} differ",
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    if std::env::var_os("DEXCUT_REAL_DIR").is_none() {
        assert!(read >= 20, "corpus too small");
    }
}

/// Concave corners the compensated tool cannot reach: rs274 and dexcut both
/// refuse them, with the same kind of error at the same line.
#[test]
fn compensation_gouges_are_refused_like_linuxcnc() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    // T3 is 6.35 mm across (radius 3.175 mm).
    let cases = [
        // A slot 5 mm wide: the pulled-back end runs past the line's start.
        (
            "slot",
            "G21 G90 G17\nT3 M6\nG0 X10 Y10 Z1\nG1 Z-1 F200\nG41 G1 X10 Y0\nX30\nY5\nX10\nY0\nG40 G1 X10 Y10\nM2\n",
            "gouging",
            8,
        ),
        // An inside arc of radius 2 mm: smaller than the tool.
        (
            "small_arc",
            "G21 G90 G17\nT3 M6\nG0 X0 Y-10 Z1\nG1 Z-1 F200\nG41 G1 X0 Y0\nX20\nG3 X22 Y2 R2\nG1 Y10\nG40 G1 X10 Y10\nM2\n",
            "tool radius not less than arc radius",
            7,
        ),
    ];
    for (name, text, what, line) in cases {
        let path = dir.path().join(format!("{name}.ngc"));
        std::fs::write(&path, text).expect("write");
        match outcome(&path) {
            Outcome::BothRefuse(ours, theirs) => {
                println!("{name}: ours {ours}\n    rs274 {theirs}");
                assert!(
                    ours.to_lowercase().contains(what) && theirs.to_lowercase().contains(what),
                    "{name}: {ours} / {theirs}"
                );
                assert!(ours.contains(&format!(".ngc:{line}:")), "{name}: {ours}");
            }
            Outcome::Agree(_) => panic!("{name}: both read it"),
            Outcome::Differ(e) => panic!("{name}: {e}"),
        }
    }
}

/// A G2 or G3 alone on its line (UCCNC's and Mach3's posts write `G03` and
/// the arc's words on the next line): rs274 refuses the line (an arc with no
/// end or centre); read as most controls read it, the arc mode is set for the
/// next block's axis words, and the amended file, the word moved onto that
/// block, reads in rs274 with the same moves: the arcs themselves, the modal
/// arcs after them, and a lone arc word that a G1 replaces before any axis
/// word (only dropped).
#[test]
fn lone_arc_words_read_as_fanuc_style_controls_and_amended_for_linuxcnc() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let amended_dir = tempfile::tempdir().expect("temp dir");
    let programs = [
        ("radius", "G21 G90 G17 F300\nG0 X0 Y2.54\nG1 Z-1\nG03\nX2.54 Y0 R2.54\nG1 X5\nM2\n", 1),
        (
            "modal",
            "G21 G90 G17\nG0 X0 Y0\nG1 Z-1 F200\nG02 F250\n(next the arcs)\nX10 Y0 I5 J0\nX0 Y0 I-5 J0\nG1 Y5\nM2\n",
            2,
        ),
        ("replaced", "G21 G90 G17 F300\nG0 X0 Y0\nG3\nG1 X4 Y4\nG03\nX8 Y0 R4\nM2\n", 1),
    ];
    for (name, source, arcs) in programs {
        let file = dir.path().join(format!("{name}.ngc"));
        std::fs::write(&file, source).expect("write");
        let (_, _, error) = rs274_moves(&file);
        assert!(error.is_some(), "{name}: rs274 reads the lone arc word");
        let linuxcnc = nc::parse(source, name, &options_as(0, FileForm::LinuxCnc));
        assert!(
            linuxcnc.diagnostics.iter().any(|d| d.is_error()),
            "{name}: read as LinuxCNC, the lone arc word is refused"
        );
        match tolerant_outcome(&file, amended_dir.path()) {
            Outcome::Agree(n) => assert!(n >= 2, "{name}: {n} moves"),
            Outcome::BothRefuse(ours, theirs) => panic!("{name}: {ours}\n    rs274: {theirs}"),
            Outcome::Differ(e) => panic!("{name}: {e}"),
        }
        let parsed = nc::parse(source, name, &options_as(0, FileForm::Tolerant));
        let n_arcs = parsed
            .path
            .segments
            .iter()
            .filter(|s| matches!(s.geometry, nc::Geometry::Arc { .. }))
            .count();
        assert_eq!(n_arcs, arcs, "{name}");
    }
}

/// Codes LinuxCNC gives a meaning to that dexcut used to refuse or read
/// otherwise (issue 39): G28.1/G30.1 store the current point as the G28/G30
/// home, G52 and G92.2/G92.3 set, suspend and restore the G92 offset, and M7,
/// M8, M9 share a modal group (a block with two of them is refused). Read with
/// the same moves by both, or refused by both.
#[test]
fn home_storing_offset_and_coolant_codes_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let blocks = [
        "G0 X3 Y2 Z4\nG28.1\nG0 X0 Y0\nG28\nG0 X1\nG28 Z0",
        "G0 X3 Y2\nG30.1\nG0 X0\nG30 X0",
        "G0 X4\nG91 G28.1\nG90 G0 X0\nG28",
        "T1 M6 G43\nG0 X2 Z3\nG28.1\nG49\nG0 X0\nG28",
        "G92 X1\nG28.1\nG0 X5\nG28",
        "G52 X3 Y1\nG0 X0 Y0\nG52 X0\nG0 X1",
        "G92 X1 Y1\nG0 X0\nG92.2\nG0 X0\nG92.3\nG0 X2\nG92.1\nG0 X2",
        "G91 G52 X2\nG0 X1\nG90",
        "M7",
        "M8\nM9",
        // Refused by both.
        "M7 M8",
        "M8 M9",
        "T3 M6\nG41 G1 X5 Y5\nG28.1\nG40",
        "G52 X1 G0 X2",
    ];
    assert_eq!(
        read_alike_or_refused_by_both(&blocks, "G21 G90 G17\nS1000 M3 F100"),
        (10, 4)
    );
}

/// A program whose comments are Windows-1252 (`(T1 D=6 CR=0 - Fräser)`
/// with byte 0xE4, as Windows editors and posts write them; issue 39):
/// rs274 reads the file as written, and we read its decoded text
/// ([`nc::decode`]) through the same moves, with a warning at the byte's
/// line and column in the tolerant form; the decoded text written out
/// (UTF-8, as optimized.nc is) reads the same in rs274. Such a byte outside
/// a comment is refused by both, at its line.
#[test]
fn windows_1252_comments_read_as_in_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let bytes = b"G21 G90 G17\n(T1 D=6 CR=0 - Fr\xe4ser)\nG0 X0 Y0 Z5 ;Fr\xe4ser \x80\n(msg,gro\xdf)\nG1 X10 Y5 Z-1 F300\nG2 X20 Y5 I5 J0\nM2\n";
    let original = dir.path().join("cp1252.ngc");
    std::fs::write(&original, bytes).expect("write");
    let (text, warning) = nc::decode(bytes.to_vec(), "cp1252.ngc", FileForm::Tolerant);
    let w = warning.expect("a warning");
    assert_eq!((w.line, w.column), (2, 18), "{w}");
    let n = compare_as(&text, FileForm::Tolerant, &original).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(n, 3);
    let written = dir.path().join("utf8.ngc");
    std::fs::write(&written, text.as_bytes()).expect("write");
    assert_eq!(compare_as(&text, FileForm::LinuxCnc, &written), Ok(3));
    // Outside a comment: rs274's "Bad character", our unexpected character.
    let bad = dir.path().join("bad.ngc");
    std::fs::write(&bad, b"G21 G90\nG0 X1\nG1 X2 F100 \xe4\nM2\n").expect("write");
    let (_, _, theirs) = rs274_moves(&bad);
    let theirs = theirs.expect("rs274 refuses the byte");
    assert!(theirs.contains("Bad character"), "{theirs}");
    let (text, _) = nc::decode(
        std::fs::read(&bad).expect("read"),
        "bad.ngc",
        FileForm::Tolerant,
    );
    let parsed = nc::parse(&text, "bad.ngc", &options_as(0, FileForm::Tolerant));
    let ours = parsed
        .diagnostics
        .iter()
        .find(|d| d.is_error())
        .expect("refused");
    assert_eq!((ours.line, ours.column), (3, 12), "{ours}");
}

/// G10 L20 (issue 39: a word LinuxCNC gives a meaning to is applied): the
/// offset of system P set so the current point reads the words given, with
/// G92, a tool length offset, inch units, the active system (P0) and another.
#[test]
fn g10_l20_sets_the_offset_from_the_current_point_as_linuxcnc_rs274() {
    if !have_rs274() {
        return;
    }
    let blocks = [
        "G10 L20 P1 X5 Y6 Z7\nG1 X1 F100",
        "G0 X3 Y4\nG10 L20 P1 X0 Y0\nG1 X1 Y1 F100",
        "G0 X3 Y4\nG10 L20 P2 X0 Y0\nG55 G1 X1 F100\nG54 G1 X2",
        "G92 X2\nG10 L20 P1 X0\nG1 X1 F100\nG92.1\nG1 X1",
        "G0 X3 Y4\nG10 L20 P0 X1\nG1 Y2 F100",
        "M6 T2\nG43 H2\nG0 Z10\nG10 L20 P1 Z0\nG1 Z-1 F100",
        "G20\nG0 X1\nG10 L20 P1 X0\nG1 X0.5 F10",
        "G91\nG0 X1\nG10 L20 P1 X0\nG1 X1 F100\nG90",
        "G10 L20 P1 R30",
    ];
    let (agree, refused) = read_alike_or_refused_by_both(&blocks, "G21 G90");
    assert_eq!((agree, refused), (8, 1));
}

/// Issue 39's G-code fuzzer against rs274: every word letter with values of
/// each kind (zero, negative, fractional, large) in blocks of each context a
/// word changes meaning in (rapid, feed, arc, dwell, G10 L2/L20, G92, G52,
/// canned cycle, spindle, path control, tool length, alone). Each program is
/// read alike by both interpreters (the same moves) or refused by both:
/// LinuxCNC gives every word a meaning or refuses it, and so does dexcut.
#[test]
fn word_value_pairs_read_alike_or_refused_by_both() {
    if !have_rs274() {
        return;
    }
    let letters = "ABCDEFHIJKLPQRSTUVWXYZ";
    let values = ["0", "-1", "2.5", "1000"];
    let contexts = [
        "G0 X1 {w}",
        "G1 X1 {w} F100",
        "G2 X2 Y0 I1 J0 {w} F100",
        "{w}",
        "G4 {w}",
        "G10 L2 P1 {w}",
        "G10 L20 P2 {w}",
        "G92 {w}",
        "G52 {w}",
        "G81 X1 Y1 Z-1 R1 F100 {w}\nG80",
        "M3 S1000 {w}",
        "G64 {w}",
        "G43 {w}",
    ];
    let mut blocks = Vec::new();
    for context in contexts {
        for letter in letters.chars() {
            for value in values {
                blocks.push(context.replace("{w}", &format!("{letter}{value}")));
            }
        }
    }
    // The differences allowed, each a class with its reason: dexcut is a
    // 3-axis simulator and refuses a rotary axis move at its line (A0, B0, C0
    // are read: they keep the axis at 0); rs274 reads Q-1 as no Q word (-1
    // is its "absent" value), which dexcut refuses where nothing uses Q; and
    // dexcut reads U0, V0, W0 as it reads A0, where rs274's XYZABC
    // configuration has no such axes.
    let allowed = |block: &str, e: &str| {
        let words: Vec<&str> = block.split_whitespace().collect();
        let has = |w: &dyn Fn(&str) -> bool| words.iter().any(|x| w(x));
        let rotary = |x: &str| {
            x.len() > 1 && "ABC".contains(&x[..1]) && x[1..].parse::<f64>().is_ok_and(|v| v != 0.0)
        };
        let zero_uvw =
            |x: &str| x.len() > 1 && "UVW".contains(&x[..1]) && x[1..].parse::<f64>() == Ok(0.0);
        (e.starts_with("we refuse what rs274 reads") && (has(&rotary) || has(&|x| x == "Q-1")))
            || (e.contains("rs274 refuses (Bad character") && has(&zero_uvw))
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let (mut agree, mut refused, mut known) = (0, 0, 0);
    let mut failures = Vec::new();
    for (i, block) in blocks.iter().enumerate() {
        let file = dir.path().join(format!("w{i}.ngc"));
        std::fs::write(
            &file,
            format!(
                "G21 G90 G17 G40 G49 G54 G80 G94 G64\nG0 X0 Y0 Z5\n{block}\nG1 X1 Y1 F200\nM2\n"
            ),
        )
        .expect("write");
        match outcome(&file) {
            Outcome::Agree(_) => agree += 1,
            Outcome::BothRefuse(..) => refused += 1,
            Outcome::Differ(e) if allowed(block, &e) => known += 1,
            Outcome::Differ(e) => failures.push(format!("{block}: {e}")),
        }
    }
    eprintln!(
        "{} blocks: {agree} read alike, {refused} refused by both, {known} of the allowed classes",
        blocks.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
