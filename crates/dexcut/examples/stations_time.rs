//! Wall time of `schedule::Stations::new` (the planner's stations, caps and corner
//! choice) on a job's program: the best of RUNS builds (3 by default), and a
//! fingerprint of what they made (the stations' arc lengths, caps, cap kinds and
//! interval accelerations, bit for bit), so two builds of the code can be compared
//! for speed and sameness.
//!
//! `cargo run --release -p dexcut --example stations_time -- JOB.toml [RUNS]`

use std::hash::{Hash, Hasher};

fn main() {
    let job = std::env::args()
        .nth(1)
        .expect("usage: stations_time JOB.toml [RUNS]");
    let runs: usize = std::env::args()
        .nth(2)
        .map_or(3, |x| x.parse().expect("RUNS: a count"));
    let setup = dexcut::commands::Setup::load(std::path::Path::new(&job), None).expect("job");
    let (mut best_s, mut fingerprint, mut stations) = (f64::INFINITY, 0, 0);
    for _ in 0..runs {
        let wall = std::time::Instant::now();
        let st = schedule::Stations::new(
            &setup.program.path,
            &setup.machine,
            0.05, // the planner's station spacing (motion::STATION_DS_MM)
            schedule::FeedPolicy::Programmed,
        )
        .expect("stations");
        best_s = best_s.min(wall.elapsed().as_secs_f64());
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for x in st
            .s_mm()
            .iter()
            .chain(st.cap_mm_min())
            .chain(st.interval_accel_mm_s2())
        {
            x.to_bits().hash(&mut h);
        }
        for kind in st.cap_kind() {
            format!("{kind:?}").hash(&mut h);
        }
        (fingerprint, stations) = (h.finish(), st.len());
    }
    println!(
        "{job}: {stations} stations, build {best_s:.3} s wall (best of {runs}), fingerprint {fingerprint:016x}"
    );
}
