//! Criterion benchmarks of the pipeline's stages other than the sweep kernel
//! (that one is `cargo bench -p dexel --bench sweep`):
//! * `interpret_1m`: `nc::parse` of the 1 M-block raster program (999 999 G1 blocks);
//! * `plan`: stations and the forward/backward speed profile of a 100 k-block raster;
//! * `engagement`: optimize's engagement sweep of the same 100 k-block raster at grid 0.1;
//! * `mesh_fill`: filling a grid with a mesh stock (`stock_models/spool_undercut.stl`, 0.1 mm).
//!
//! Run: `cargo bench -p dexcut --bench pipeline` (about 3 minutes on 2 cores).
//! Programs come from `programs/mod.rs`, the same as `scripts/bench_runs.sh`'s.

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};

mod programs;

fn slow_group<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut group = c.benchmark_group(name);
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(8));
    group
}

fn interpret(c: &mut Criterion) {
    let text = programs::raster_gcode(1000, 1000);
    let blocks = text.lines().count() as u64;
    let mut group = slow_group(c, "interpret_1m");
    group.throughput(Throughput::Elements(blocks));
    group.bench_function("nc_parse", |b| {
        b.iter(|| {
            let parsed = nc::parse(&text, "finish_1m.ngc", &nc::Options::default());
            assert!(parsed.path.segments.len() > 999_000);
            parsed
        })
    });
    group.finish();
}

/// The 100 k-block raster's job loaded from a temporary folder.
fn setup_100k(dir: &Path) -> dexcut::commands::Setup {
    std::fs::write(dir.join("p.ngc"), programs::raster_gcode(100, 1000)).expect("program");
    std::fs::write(dir.join("job.toml"), programs::job_toml("p.ngc", 0.1)).expect("job");
    dexcut::commands::Setup::load(&dir.join("job.toml"), None).expect("setup")
}

fn plan_and_engagement(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("tempdir");
    let setup = setup_100k(dir.path());
    let machine = dexcut::optimize::optimising_machine(&setup.machine, &setup.job.limits);
    let stations =
        dexcut::optimize::free_stations(&setup.program.path, &machine).expect("stations");
    let n = stations.s_mm().len() as u64;
    println!(
        "100 k-block raster: {} segments, {n} stations",
        setup.program.path.segments.len()
    );
    let mut group = slow_group(c, "plan");
    group.throughput(Throughput::Elements(n));
    group.bench_function("stations_and_profile", |b| {
        b.iter(|| {
            let st =
                dexcut::optimize::free_stations(&setup.program.path, &machine).expect("stations");
            schedule::plan(&st).cycle_time_s()
        })
    });
    group.finish();
    let mut group = slow_group(c, "engagement");
    group.throughput(Throughput::Elements(n));
    group.bench_function("raster_100k_grid_0.1", |b| {
        b.iter(|| {
            dexcut::optimize::engagement(
                &stations,
                &setup.stock,
                &setup.tools,
                dexcut::optimize::SurfaceFrom::Nothing,
            )
            .expect("engagement")
        })
    });
    group.finish();
}

fn mesh_fill(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stock_models/spool_undercut.stl");
    let mesh = mesh::load_mesh(&path).expect("mesh");
    let (stock, _) = mesh::stock_from_mesh(&mesh, 0.1).expect("fill");
    let columns = stock.grid().len() as u64;
    println!("spool_undercut.stl at 0.1 mm: {columns} columns");
    let mut group = slow_group(c, "mesh_fill");
    group.throughput(Throughput::Elements(columns));
    group.bench_function("spool_undercut_0.1", |b| {
        b.iter(|| mesh::stock_from_mesh(&mesh, 0.1).expect("fill"))
    });
    group.finish();
}

criterion_group!(benches, interpret, plan_and_engagement, mesh_fill);
criterion_main!(benches);
