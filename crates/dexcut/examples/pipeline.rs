//! The dexcut pipeline called from Rust: load a job, simulate it, optimise it
//! into a results folder, build the report, and read summary.json back.
//!
//! ```text
//! cargo run --release -p dexcut --example pipeline -- examples/boss_contour/job.toml out/pipeline
//! ```

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args_os().skip(1);
    let job = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "examples/boss_contour/job.toml".into()),
    );
    let out = PathBuf::from(args.next().unwrap_or_else(|| "out/pipeline".into()));

    let mut setup = dexcut::load(&job, None)?;
    let sim = dexcut::simulate(&setup, false)?;
    let s = &sim.summary;
    println!(
        "as given: {:.3} s, {:.1} mm³ removed, peak force {:.2} N, deflection {:.2} µm",
        s.cycle_time_s, s.removed_volume_mm3, s.peak_force_n, s.peak_deflection_um
    );
    for w in sim.summary.warnings.iter() {
        println!("  warning: {w}");
    }

    let optimized = dexcut::optimize(&mut setup, &out, true)?;
    let a = &optimized.summary.after;
    println!(
        "optimized.nc: {:.3} s (lower bound {:.3} s), peak force {:.2} N",
        a.cycle_time_s, optimized.summary.lower_bound_time_s, a.peak_force_n
    );

    let files = dexcut::report(&out)?;
    println!("report: {}", files.html.display());

    // summary.json reads back through the same types it was written with.
    match dexcut::summary::read(&out.join("summary.json"))? {
        dexcut::summary::SummaryDoc::Optimize(doc) => {
            assert_eq!(doc.after.cycle_time_s, a.cycle_time_s);
            println!("summary.json: schema {}", dexcut::summary::SCHEMA_VERSION);
        }
        _ => return Err("expected an optimize summary".into()),
    }
    Ok(())
}
