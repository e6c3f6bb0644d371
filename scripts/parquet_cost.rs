//! The dependency cost of writing steps as Parquet (arrow + parquet crates)
//! against the project's own `.npy` writer, measured for issue 16 (BENCHMARKS.md,
//! "Steps in binary form"). Not part of the workspace: build it as a scratch
//! crate outside the repository, e.g.
//!
//! ```sh
//! cargo new /tmp/pqbench && cp scripts/parquet_cost.rs /tmp/pqbench/src/main.rs && cd /tmp/pqbench
//! cargo add parquet --no-default-features --features arrow && cargo add arrow-array arrow-schema
//! /usr/bin/time -v cargo build --release     # the clean build's CPU time
//! ./target/release/pqbench /tmp/pqout         # write times and sizes (1 M rows × 30 f64 columns)
//! ```
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::file::properties::WriterProperties;

const ROWS: usize = 1_000_000;
const COLS: usize = 30;

/// CPU time of this process so far (user + system), s.
fn cpu_s() -> f64 {
    let t = proc_times();
    t.0 + t.1
}

/// User and system time from /proc/self/stat (clock ticks of 1/100 s).
fn proc_times() -> (f64, f64) {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap();
    let f: Vec<&str> = s.rsplit(')').next().unwrap().split_whitespace().collect();
    let tick = 100.0;
    (f[11].parse::<f64>().unwrap() / tick, f[12].parse::<f64>().unwrap() / tick)
}

fn main() {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap());
    std::fs::create_dir_all(&dir).unwrap();
    // Columns like steps.csv: smooth positions/time, half the band columns zero.
    let mut seed = 1u64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let cols: Vec<Vec<f64>> = (0..COLS)
        .map(|c| {
            (0..ROWS)
                .map(|i| match c {
                    0 => i as f64,
                    1 => i as f64 * 0.004,
                    _ if c % 3 == 0 => 0.0,
                    _ => rnd() * 100.0,
                })
                .collect()
        })
        .collect();
    // npy: one file per column, streamed through BufWriter, synced.
    let (c0, t0) = (cpu_s(), Instant::now());
    for (k, v) in cols.iter().enumerate() {
        let mut f = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("c{k}.npy"))).unwrap());
        let mut hdr = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({ROWS},), }}");
        while (10 + hdr.len() + 1) % 64 != 0 { hdr.push(' '); }
        hdr.push('\n');
        f.write_all(b"\x93NUMPY\x01\x00").unwrap();
        f.write_all(&(hdr.len() as u16).to_le_bytes()).unwrap();
        f.write_all(hdr.as_bytes()).unwrap();
        let mut buf = Vec::with_capacity(8 * 16384);
        for ch in v.chunks(16384) {
            buf.clear();
            for x in ch { buf.extend_from_slice(&x.to_le_bytes()); }
            f.write_all(&buf).unwrap();
        }
        f.into_inner().unwrap().sync_all().unwrap();
    }
    println!("npy: wall {:.3} s cpu {:.3} s", t0.elapsed().as_secs_f64(), cpu_s() - c0);
    for (label, props) in [
        ("parquet plain", WriterProperties::builder().set_dictionary_enabled(false).build()),
        ("parquet default (dict)", WriterProperties::builder().build()),
    ] {
        let schema = Arc::new(Schema::new(
            (0..COLS).map(|k| Field::new(format!("c{k}"), DataType::Float64, false)).collect::<Vec<_>>(),
        ));
        let (c0, t0) = (cpu_s(), Instant::now());
        let path = dir.join(format!("{}.parquet", label.replace(' ', "_").replace(['(', ')'], "")));
        let file = std::fs::File::create(&path).unwrap();
        let mut w = ArrowWriter::try_new(file, schema.clone(), Some(props)).unwrap();
        // Streamed in batches of 65 536 rows, as steps would be.
        let batch = 65_536;
        let mut start = 0;
        while start < ROWS {
            let end = (start + batch).min(ROWS);
            let arrays: Vec<ArrayRef> = cols
                .iter()
                .map(|v| Arc::new(Float64Array::from(v[start..end].to_vec())) as ArrayRef)
                .collect();
            w.write(&RecordBatch::try_new(schema.clone(), arrays).unwrap()).unwrap();
            start = end;
        }
        let file = w.into_inner().unwrap();
        file.sync_all().unwrap();
        println!("{label}: wall {:.3} s cpu {:.3} s size {} B", t0.elapsed().as_secs_f64(), cpu_s() - c0, std::fs::metadata(&path).unwrap().len());
    }
}
