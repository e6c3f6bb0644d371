//! One piece of a job's program (its segments FROM..TO, a run from rest to rest) planned
//! with a jerk limit of 20 000 mm/s³: prints its plan and lower bound, and writes its
//! stations (arc length, cap, the interval's tangential acceleration and jerk limits, stop,
//! planned speed before the filter) to a CSV for `scripts/jerk_optimum.py`, which finds a
//! jerk-limited motion under the same limits (MODEL.md §6.1, "Which side is loose").
//!
//! `cargo run --release -p dexcut --example jerk_piece -- JOB.toml FROM TO OUT.csv`

use std::io::Write;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, job, from, to, out] = &args[..] else {
        panic!("usage: jerk_piece JOB.toml FROM TO OUT.csv");
    };
    let setup = dexcut::commands::Setup::load(std::path::Path::new(job), None).expect("job");
    let segments = &setup.program.path.segments;
    let from: usize = from.parse().expect("FROM");
    let to = to.parse::<usize>().expect("TO").min(segments.len());
    let path = nc::Path {
        segments: segments[from..to].to_vec(),
        ..Default::default()
    };
    let machine = schedule::Machine {
        jerk_mm_s3: Some([20_000.0; 3]),
        ..setup.machine
    };
    let st = schedule::Stations::new(
        &path,
        &machine,
        0.05, // the planner's station spacing (motion::STATION_DS_MM)
        schedule::FeedPolicy::Programmed,
    )
    .expect("stations");
    let profile = schedule::plan(&st);
    let cycle_s = profile.cycle_time_s();
    let bound_s = schedule::lower_bound_time_s(&st);
    let mut stop = vec![false; st.len()];
    for s in st.stops() {
        stop[s.station] = true;
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(out).expect("OUT.csv"));
    writeln!(f, "s,cap,accel,jerk,stop,plan_v").expect("write");
    for (k, &at_stop) in stop.iter().enumerate() {
        // The interval after station k (the last station has none).
        let accel = st.interval_accel_mm_s2().get(k).copied().unwrap_or(0.0);
        let jerk = match st.interval_jerk_mm_s3() {
            Some(jerk) => jerk.get(k).copied().unwrap_or(0.0),
            // Without a jerk limit every interval's is infinite.
            None if k + 1 < st.len() => f64::INFINITY,
            None => 0.0,
        };
        writeln!(
            f,
            "{},{},{},{},{},{}",
            st.s_mm()[k],
            st.cap_mm_min()[k] / 60.0,
            accel,
            jerk,
            u8::from(at_stop),
            profile.speed_mm_s()[k]
        )
        .expect("write");
    }
    println!(
        "{job} segments {from}..{to}: {} stations, {} stops, window {:.4} s, plan {cycle_s:.4} s, lower bound {bound_s:.4} s, gap {:.2} %",
        st.len(),
        st.stops().len(),
        profile.filter_window_s(),
        100.0 * (cycle_s / bound_s - 1.0)
    );
}
