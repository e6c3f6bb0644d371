//! One benchmark workload run outside criterion: wall time, column
//! evaluations and moves per second, and the peak resident memory per column.
//!
//! `cargo run --release -p dexel --example sweep_stats -- <roughing|finishing> [threads] [repeats] [ball|flat|bull]`
//!
//! The tool is the workloads' Ø10 ball, or a Ø10 flat end, or a Ø10 bull nose
//! with a 2 mm corner.
//!
//! Peak memory is the process's VmHWM (Linux `/proc/self/status`), read
//! before the stock is built, after it is built and after the sweeps; run one
//! workload per process so the numbers are not mixed. Repeats sweep fresh
//! clones of the stock (the clone is dropped before the next one is made).

use std::time::Instant;

use dexel::{sweep, SweepOptions, Tool};

#[path = "../benches/workloads/mod.rs"]
mod workloads;

/// `VmHWM` and `VmRSS` of this process, bytes (0 where /proc is unavailable).
fn memory_bytes() -> (u64, u64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
            .map_or(0, |kib| kib * 1024)
    };
    (field("VmHWM:"), field("VmRSS:"))
}

/// FNV-1a over 64-bit words: a fingerprint of the stock (heights, last cut)
/// and of every per-step value of the record, to see whether a change alters results.
fn fnv1a(words: impl Iterator<Item = u64>) -> u64 {
    words.fold(0xcbf2_9ce4_8422_2325, |h, w| {
        (h ^ w).wrapping_mul(0x100_0000_01b3)
    })
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let workload = args.get(1).map_or("roughing", String::as_str);
    let threads: usize = args.get(2).map_or(1, |v| v.parse().expect("threads"));
    let repeats: usize = args.get(3).map_or(1, |v| v.parse().expect("repeats"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("rayon pool");

    let (hwm0, _) = memory_bytes();
    let (prepared, steps) = match workload {
        "roughing" => (workloads::box_stock(), workloads::roughing_steps()),
        "finishing" => (
            workloads::semi_finished_stock(),
            workloads::finishing_steps(),
        ),
        other => panic!("unknown workload {other}; use roughing or finishing"),
    };
    let (hwm_stock, _) = memory_bytes();
    let n_columns = prepared.grid().len() as f64;
    let tool = match args.get(4).map_or("ball", String::as_str) {
        "ball" => workloads::tool(),
        "flat" => Tool::flat(10.0),
        "bull" => Tool::bull(10.0, 2.0),
        other => panic!("unknown tool {other}; use ball, flat or bull"),
    };
    let options = SweepOptions::default();

    let mut times = Vec::new();
    let mut columns = 0;
    let mut volume = 0.0;
    let mut hwm_sweep = 0;
    let mut fingerprint = 0;
    let mut offsets_fingerprint = 0;
    let (mut record_bytes, mut offsets_bytes, mut n_steps) = (0, 0, 0);
    for _ in 0..repeats {
        let mut stock = prepared.clone();
        let start = Instant::now();
        let record =
            pool.install(|| sweep(&mut stock, &tool, &steps, &options, &|_| {}).expect("sweep"));
        times.push(start.elapsed().as_secs_f64());
        columns = record.columns_evaluated;
        volume = record.total_volume_mm3();
        hwm_sweep = memory_bytes().0;
        n_steps = record.len();
        record_bytes = record.memory_bytes();
        offsets_bytes = (0..record.len())
            .map(|i| std::mem::size_of_val(record.band_offsets_mm(i)))
            .sum::<usize>();
        offsets_fingerprint = fnv1a((0..record.len()).flat_map(|i| {
            record
                .band_offsets_mm(i)
                .iter()
                .map(|r| ((r[0].to_bits() as u64) << 32) | r[1].to_bits() as u64)
                .collect::<Vec<_>>()
        }));
        fingerprint = fnv1a(
            stock
                .top_heights()
                .iter()
                .map(|h| h.to_bits() as u64)
                .chain(stock.last_cut().iter().map(|&s| s as u64))
                .chain((0..record.len()).flat_map(|i| {
                    let [cx, cy] = record.contact_resultant(i);
                    [
                        record.volume_mm3(i),
                        record.shank_volume_mm3(i),
                        cx,
                        cy,
                        record.chip_edge_area_mm2(i),
                        record.volume_over_radius_mm2(i),
                    ]
                    .into_iter()
                    .chain((0..record.n_bands).map(|k| record.band_volume_mm3(i, k)))
                    .map(f64::to_bits)
                    .collect::<Vec<_>>()
                })),
        );
    }
    drop(prepared);
    times.sort_by(f64::total_cmp);
    let best = times[0];
    let median = times[times.len() / 2];
    println!(
        "{workload} ({:?}), {threads} thread(s): {} moves, {columns} column evaluations, {volume:.6} mm³ removed, result fingerprint {fingerprint:016x}",
        tool.shape,
        steps.len()
    );
    println!(
        "  time best {best:.3} s, median {median:.3} s over {repeats}: {:.1} M column evals/s, {:.0} moves/s (best)",
        columns as f64 / best / 1e6,
        steps.len() as f64 / best
    );
    println!(
        "  peak RSS: {:.1} MB before stock, {:.1} MB with stock ({:.1} B/column), {:.1} MB after sweep (stock + a clone: {:.1} B/column)",
        hwm0 as f64 / 1e6,
        hwm_stock as f64 / 1e6,
        (hwm_stock - hwm0) as f64 / n_columns,
        hwm_sweep as f64 / 1e6,
        (hwm_sweep - hwm0) as f64 / n_columns,
    );
    println!(
        "  record: {:.1} B a step ({:.1} B of them the bands' offset ranges), offsets fingerprint {offsets_fingerprint:016x}",
        record_bytes as f64 / n_steps.max(1) as f64,
        offsets_bytes as f64 / n_steps.max(1) as f64,
    );
}
