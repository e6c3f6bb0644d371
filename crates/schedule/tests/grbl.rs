//! dexcut's grbl planner (`schedule::controller::grbl`) against the real one: recordings
//! of grbl 1.1's `planner.c` (gnea/grbl bfb67f0, compiled on the host with the stepper's
//! profile arithmetic, `scripts/grbl_reference`) planning the very blocks dexcut plans,
//! for each program of `scripts/grbl_reference/programs.txt` (README.md in
//! `tests/data/grbl_reference`), and closed forms for single corners.

mod grbl_io;

use flate2::read::GzDecoder;
use schedule::controller::grbl::{blocks, cycle_time_s, plan_blocks, samples, GrblSettings};
use std::io::Read;
use std::path::{Path, PathBuf};

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/grbl_reference")
}

/// One block as the real planner planned and the stepper ran it (speeds mm/min).
#[derive(Clone, Copy, Debug)]
struct RealBlock {
    block: usize,
    entry: f64,
    exit: f64,
    nominal: f64,
    max_entry: f64,
    mm: f64,
    accel: f64,
    time_s: f64,
}

/// A recording: the blocks in the order they ran (syncs as their dwell), the blocks grbl
/// dropped, and the totals (as the step ISR times the segments; the segments' planned
/// times, which can hold seconds for the last fraction of a step of a stop).
#[derive(Debug, Default)]
struct Recording {
    program: String,
    blocks: Vec<RealBlock>,
    syncs: Vec<(usize, f64)>,
    dropped: Vec<usize>,
    total_s: f64,
    profile_s: f64,
}

fn parse(text: &str) -> Recording {
    let mut r = Recording::default();
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let num = |i: usize| -> f64 { f[i].parse().expect("number") };
        match f[0] {
            "#" => r.program = f[2].to_string(),
            "B" => r.blocks.push(RealBlock {
                block: f[1].parse().expect("index"),
                entry: num(2),
                exit: num(3),
                nominal: num(4),
                max_entry: num(5),
                mm: num(6),
                accel: num(7),
                time_s: num(8),
            }),
            "S" => r.syncs.push((f[1].parse().expect("index"), num(2))),
            "E" => r.dropped.push(f[1].parse().expect("index")),
            "total" => {
                r.total_s = num(1);
                r.profile_s = num(2);
            }
            other => panic!("recording line `{other}`"),
        }
    }
    r
}

fn recording(name: &str) -> Recording {
    let mut text = String::new();
    GzDecoder::new(std::fs::File::open(data_dir().join(format!("{name}.txt.gz"))).expect(name))
        .read_to_string(&mut text)
        .expect("gzip text");
    parse(&text)
}

/// The recordings' names, programs and settings (the dump, and the planner blocks:
/// grbl's `BLOCK_BUFFER_SIZE` − 1), from `programs.txt`.
fn names() -> Vec<(String, PathBuf, GrblSettings)> {
    let list = grbl_io::root().join("scripts/grbl_reference/programs.txt");
    std::fs::read_to_string(list)
        .expect("programs.txt")
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let mut f = l.split_whitespace();
            let name = f.next().expect("name").to_string();
            let program = grbl_io::root().join(f.next().expect("program"));
            let size: usize = f.next().map_or(16, |n| n.parse().expect("buffer size"));
            let dump = f.next().unwrap_or("settings.txt");
            let settings = GrblSettings {
                planner_blocks: size - 1,
                ..grbl_io::settings_from(&grbl_io::root().join("scripts/grbl_reference").join(dump))
            };
            (name, program, settings)
        })
        .collect()
}

/// Relative difference of a speed, mm/min, with grbl's `MINIMUM_FEED_RATE` (1 mm/min) as
/// the floor of the scale.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1.0)
}

/// The real planner's speed, mm/min, `x` mm into a block: the trapezoid stepper.c runs
/// between its entry and exit under its nominal speed.
fn speed_at(b: &RealBlock, x: f64) -> f64 {
    let a = b.accel * 3600.0;
    let x = x.clamp(0.0, b.mm);
    let up = (b.entry * b.entry + 2.0 * a * x).sqrt();
    let down = (b.exit * b.exit + 2.0 * a * (b.mm - x)).sqrt();
    up.min(down).min(b.nominal.max(b.entry))
}

/// The largest relative difference of an entry, exit or junction speed: dexcut computes
/// the blocks' junction speeds in f32 as grbl does, its passes in f64.
const ENTRY_REL: f64 = 1e-6;

/// One program compared.
struct Compared {
    name: String,
    segments: usize,
    blocks: usize,
    model_s: f64,
    real_s: f64,
    profile_s: f64,
    entry_max_rel: f64,
    within_2pct: f64,
    /// Blocks whose exit speed the buffer's depth lowers (below the plan with 1023 blocks).
    depth_bound: usize,
}

fn compare(name: &str, program: &Path, settings: &GrblSettings) -> Compared {
    let rec = recording(name);
    let run_s: f64 = rec.blocks.iter().map(|b| b.time_s).sum::<f64>()
        + rec.syncs.iter().map(|s| s.1).sum::<f64>();
    assert!(
        (run_s - rec.total_s).abs() < 1e-6 * rec.total_s.max(1.0),
        "{name}: total"
    );
    let path = grbl_io::program(program);
    let blocks = blocks(&path, settings);
    let planned = plan_blocks(path.segments[0].start.coords.into(), &blocks, settings);
    // The same blocks in the same order: moves, syncs, and the ones of no whole step.
    let moves: Vec<_> = planned.iter().filter(|p| p.length_mm > 0.0).collect();
    assert_eq!(moves.len(), rec.blocks.len(), "{name}: blocks run");
    let syncs = planned.len() - moves.len();
    assert_eq!(syncs, rec.syncs.len(), "{name}: syncs");
    assert_eq!(
        planned.len() + rec.dropped.len(),
        blocks.len(),
        "{name}: dropped"
    );
    let deep = plan_blocks(
        path.segments[0].start.coords.into(),
        &blocks,
        &GrblSettings {
            planner_blocks: 1023,
            ..*settings
        },
    );
    let depth_bound = planned
        .iter()
        .zip(&deep)
        .filter(|(p, d)| p.exit_mm_min < d.exit_mm_min * (1.0 - 1e-6))
        .count();
    let mut entry_max_rel: f64 = 0.0;
    for (d, r) in moves.iter().zip(&rec.blocks) {
        assert_eq!(d.block, r.block, "{name}: block order");
        let ctx = || format!("{name}: block {} dexcut {d:?} real {r:?}", r.block);
        assert!(rel(d.length_mm, r.mm) < 1e-6, "{}", ctx());
        assert!(rel(d.accel_mm_s2, r.accel) < 1e-6, "{}", ctx());
        assert!(rel(d.nominal_mm_min, r.nominal) < 1e-6, "{}", ctx());
        assert!(
            rel(d.max_entry_mm_min, r.max_entry) < ENTRY_REL,
            "{}",
            ctx()
        );
        let e = rel(d.entry_mm_min, r.entry).max(rel(d.exit_mm_min, r.exit));
        assert!(e < ENTRY_REL, "{}", ctx());
        entry_max_rel = entry_max_rel.max(e);
    }
    // Per-sample feed against the real planner's speed at the same distance along the
    // blocks, weighted by the path each sample covers.
    let machine = schedule::Machine {
        period_ms: 1.0,
        ..Default::default()
    };
    let samples = samples(&path, &machine, settings).expect("samples");
    let mut starts = Vec::with_capacity(rec.blocks.len());
    let mut s = 0.0;
    for b in &rec.blocks {
        starts.push(s);
        s += b.mm;
    }
    let (mut within, mut total) = (0.0, 0.0);
    let mut k = 0;
    for w in samples.windows(2) {
        let ds = w[1].s_mm - w[0].s_mm;
        if ds <= 0.0 {
            continue;
        }
        let at = w[0].s_mm;
        while k + 1 < starts.len() && starts[k + 1] <= at {
            k += 1;
        }
        let real = speed_at(&rec.blocks[k], at - starts[k]);
        total += ds;
        if (w[0].feed_mm_min - real).abs() <= 0.02 * real {
            within += ds;
        }
    }
    Compared {
        name: name.to_string(),
        segments: path.segments.len(),
        blocks: blocks.len(),
        model_s: cycle_time_s(&planned),
        real_s: rec.total_s,
        profile_s: rec.profile_s,
        entry_max_rel,
        depth_bound,
        within_2pct: if total > 0.0 { within / total } else { 1.0 },
    }
}

/// Every recording: the blocks' entry, exit and junction speeds within 1e-6,
/// lengths, accelerations and nominal speeds within 1e-6, the cycle time within 1 % of
/// the real stepper's, the feed within 2 % of the real planner's speed over ≥ 95 % of the
/// path.
#[test]
fn dexcut_plans_as_the_real_grbl_planner() {
    let all: Vec<Compared> = names()
        .iter()
        .map(|(name, program, settings)| compare(name, program, settings))
        .collect();
    println!("| program | segments/blocks | depth-bound blocks | dexcut grbl model s | real grbl planner s (Σ segments' dt) | diff % | max entry-speed rel diff | % of path within 2 % |");
    println!("|---|---|---|---|---|---|---|---|");
    for c in &all {
        println!(
            "| {} | {}/{} | {} | {:.4} | {:.4} ({:.4}) | {:+.4} | {:.2e} | {:.2} |",
            c.name,
            c.segments,
            c.blocks,
            c.depth_bound,
            c.model_s,
            c.real_s,
            c.profile_s,
            100.0 * (c.model_s / c.real_s - 1.0),
            c.entry_max_rel,
            100.0 * c.within_2pct
        );
    }
    for c in &all {
        assert!(
            (c.model_s / c.real_s - 1.0).abs() < 0.01,
            "{}: {} s against {} s",
            c.name,
            c.model_s,
            c.real_s
        );
        assert!(c.within_2pct >= 0.95, "{}: {}", c.name, c.within_2pct);
    }
    assert!(all.len() >= 30);
}

/// Each single corner of `programs/corners.ngc` (from rest, between syncs): the junction
/// speed of planner.c's closed form, v² = a·δ·sin(θ/2)/(1 − sin(θ/2)) with a the
/// acceleration along u₂ − u₁ and the directions between whole steps, within the feed;
/// dexcut's and the real planner's, which is also the speed the corner is passed at.
#[test]
fn single_corners_pass_at_grbls_junction_speed() {
    let settings = grbl_io::settings();
    let rec = recording("corners");
    let path = grbl_io::program(&data_dir().join("programs/corners.ngc"));
    let blocks = blocks(&path, &settings);
    let planned = plan_blocks(path.segments[0].start.coords.into(), &blocks, &settings);
    let normalize = |d: [f64; 3]| {
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        d.map(|x| x / n)
    };
    let steps = |p: [f64; 3]| p.map(|x| (x * 250.0).round() / 250.0);
    let unit =
        |a: [f64; 3], b: [f64; 3]| normalize(std::array::from_fn(|i| steps(b)[i] - steps(a)[i]));
    let accel = [1000.0, 1000.0, 800.0].map(|a| a * 3600.0);
    let mut corners = 0;
    for w in planned.windows(2) {
        let (p, c) = (&w[0], &w[1]);
        if p.length_mm == 0.0 || c.length_mm == 0.0 {
            continue;
        }
        let u1 = unit(p.start_mm, c.start_mm);
        let u2 = unit(c.start_mm, blocks[c.block].target_mm);
        let cos = -(0..3).map(|i| u1[i] * u2[i]).sum::<f64>();
        let j = normalize(std::array::from_fn(|i| u2[i] - u1[i]));
        let a = (0..3)
            .filter(|&i| j[i] != 0.0)
            .map(|i| accel[i] / j[i].abs())
            .fold(f64::INFINITY, f64::min);
        let sin = (0.5 * (1.0 - cos)).sqrt();
        let v = (a * 0.01 * sin / (1.0 - sin)).sqrt().min(c.nominal_mm_min);
        let real = rec.blocks.iter().find(|b| b.block == c.block).expect("run");
        for (who, got) in [
            ("dexcut junction", c.max_entry_mm_min),
            ("dexcut entry", c.entry_mm_min),
            ("real junction", real.max_entry),
            ("real entry", real.entry),
        ] {
            assert!(
                (got - v).abs() < 2e-5 * v,
                "corner at block {}: {who} {got} vs {v}",
                c.block
            );
        }
        corners += 1;
    }
    assert_eq!(corners, 9);
}

/// The harness built and run here on two unit programs gives the recordings back, value
/// for value; skipped (with the reason printed) where it cannot be built.
#[test]
fn live_harness_reproduces_the_recordings() {
    let root = grbl_io::root();
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("grbl_reference");
    let build = std::process::Command::new("sh")
        .arg(root.join("scripts/grbl_reference/build.sh"))
        .arg(&out)
        .output();
    match &build {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            println!(
                "skipped: the harness does not build here (no C compiler?): {}",
                String::from_utf8_lossy(&o.stderr)
            );
            return;
        }
        Err(e) => {
            println!("skipped: cannot run sh: {e}");
            return;
        }
    }
    let settings = grbl_io::settings();
    for name in ["corner_right", "zigzag_short"] {
        let program = data_dir().join(format!("programs/{name}.ngc"));
        let input = grbl_io::blocks_text(&grbl_io::program(&program), &settings);
        let mut child = std::process::Command::new(out.join("grbl_harness"))
            .arg(root.join("scripts/grbl_reference/settings.txt"))
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("harness runs");
        std::io::Write::write_all(&mut child.stdin.take().expect("stdin"), input.as_bytes())
            .expect("blocks written");
        let output = child.wait_with_output().expect("harness ends");
        assert!(output.status.success(), "{name}: harness failed");
        let live = parse(&String::from_utf8(output.stdout).expect("utf-8"));
        let recorded = recording(name);
        assert_eq!(
            format!("{:?}", live.blocks),
            format!("{:?}", recorded.blocks),
            "{name}"
        );
        assert_eq!(live.total_s, recorded.total_s, "{name}");
    }
}
