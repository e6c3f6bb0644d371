//! Sweep-kernel throughput: column evaluations per second for a roughing and
//! a finishing workload (see `workloads/mod.rs`), on a rayon pool of 1 thread
//! (serial) and of 2 threads (parallel). Each iteration sweeps a fresh clone
//! of a prepared stock; building and cloning the stock is not timed.
//!
//! Criterion's throughput line is column evaluations per second
//! (`RemovalRecord::columns_evaluated` per iteration); the moves per
//! iteration are printed first, so moves/s = moves / time.
//!
//! Run: `cargo bench -p dexel --bench sweep` (about 2 minutes on 2 cores).

use std::time::Duration;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, SamplingMode, Throughput};
use dexel::{sweep, Step, Stock, SweepOptions};

mod workloads;

fn bench_workload(c: &mut Criterion, name: &str, stock: &Stock, steps: &[Step]) {
    let tool = workloads::tool();
    let options = SweepOptions::default();
    let probe = sweep(&mut stock.clone(), &tool, steps, &options, &|_| {}).expect("sweep");
    let columns = probe.columns_evaluated;
    println!(
        "{name}: {} moves, {columns} column evaluations, {:.1} mm³ removed per iteration",
        steps.len(),
        probe.total_volume_mm3()
    );
    let mut group = c.benchmark_group(format!("sweep_{name}"));
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5))
        .throughput(Throughput::Elements(columns));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("rayon pool");
        let label = if threads == 1 { "serial" } else { "parallel_2" };
        group.bench_function(label, |b| {
            b.iter_batched(
                || stock.clone(),
                // Return the stock so that dropping it is not timed.
                |mut s| {
                    let record = pool
                        .install(|| sweep(&mut s, &tool, steps, &options, &|_| {}).expect("sweep"));
                    (s, record)
                },
                BatchSize::PerIteration,
            )
        });
    }
    group.finish();
}

fn roughing(c: &mut Criterion) {
    bench_workload(
        c,
        "roughing",
        &workloads::box_stock(),
        &workloads::roughing_steps(),
    );
}

fn finishing(c: &mut Criterion) {
    bench_workload(
        c,
        "finishing",
        &workloads::semi_finished_stock(),
        &workloads::finishing_steps(),
    );
}

criterion_group!(benches, roughing, finishing);
criterion_main!(benches);
