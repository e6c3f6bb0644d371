//! Write the benchmark programs and jobs of `scripts/bench_runs.sh` into a folder:
//! `raster.csv` / `raster.ngc` (200 rows × 202 points: 40 399 moves) and
//! `finish_1m.ngc` (1000 rows × 1000 points: 999 999 G1 blocks), each with a
//! job at grid 0.1 mm (the script overrides it with `--grid`), and
//! `free_path.ngc` (240 G1 moves over an 80 × 60 mm block, Ø6 ball) with its
//! job at grid 0.05 mm.
//!
//! `cargo run --release -p dexcut --example bench_programs -- DIR`

#[path = "../benches/programs/mod.rs"]
mod programs;

fn main() -> std::io::Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or("bench_runs".into()));
    std::fs::create_dir_all(&dir)?;
    let files = [
        ("raster.csv", programs::raster_csv(200, 202)),
        ("raster.ngc", programs::raster_gcode(200, 202)),
        ("finish_1m.ngc", programs::raster_gcode(1000, 1000)),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text)?;
        let stem = name.replace('.', "_");
        std::fs::write(
            dir.join(format!("{stem}.toml")),
            programs::job_toml(name, 0.1),
        )?;
        println!("{}", dir.join(name).display());
    }
    std::fs::write(dir.join("free_path.ngc"), programs::free_path_gcode(240))?;
    std::fs::write(
        dir.join("free_path_ngc.toml"),
        programs::free_path_job_toml("free_path.ngc", 0.05),
    )?;
    println!("{}", dir.join("free_path.ngc").display());
    Ok(())
}
