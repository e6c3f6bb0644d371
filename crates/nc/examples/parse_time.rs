//! Wall time of `nc::parse` on a program (the syntax read, the run and its
//! path): the best of RUNS readings (5 by default), and the path's segments.
//!
//! `cargo run --release -p nc --example parse_time -- PROGRAM.ngc [RUNS]`

fn main() {
    let file = std::env::args()
        .nth(1)
        .expect("usage: parse_time PROGRAM.ngc [RUNS]");
    let runs: usize = std::env::args()
        .nth(2)
        .map_or(5, |x| x.parse().expect("RUNS: a count"));
    let source = std::fs::read_to_string(&file).expect("program");
    let options = nc::Options::default();
    let mut best = f64::INFINITY;
    let mut segments = 0;
    for _ in 0..runs {
        let t0 = std::time::Instant::now();
        let parsed = nc::parse(&source, &file, &options);
        best = best.min(t0.elapsed().as_secs_f64());
        segments = parsed.path.segments.len();
    }
    println!("{file}: {segments} segments, parse {best:.3} s (best of {runs})");
}
