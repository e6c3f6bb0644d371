//! Time of building the stations of a program (each corner passed, and each judged), best
//! of 5, and a fingerprint of what each build made (its arc lengths, caps, cap kinds and
//! interval accelerations, bit for bit), so two builds of the code compare for speed and
//! sameness.
//!
//! `cargo run --release -p schedule --example build_time -- FILE PERIOD_MS [JERK_MM_S3 [programmed]]`
//! (`programmed`: at the program's feeds, as `simulate`; else at `feed_max`, as `optimize`).
use schedule::*;
fn main() {
    let file = std::env::args().nth(1).expect("a program");
    let period_ms: f64 = std::env::args()
        .nth(2)
        .map_or(16.0, |s| s.parse().expect("a period"));
    let text = String::from_utf8_lossy(&std::fs::read(&file).expect("readable")).to_string();
    let path = nc::parse(&text, &file, &nc::Options::default()).path;
    let jerk: Option<f64> = std::env::args()
        .nth(3)
        .map(|s| s.parse().expect("a jerk limit"));
    let policy = match std::env::args().nth(4).as_deref() {
        Some("programmed") => FeedPolicy::Programmed,
        _ => FeedPolicy::MachineMax,
    };
    let machine = Machine {
        period_ms,
        jerk_mm_s3: jerk.map(|j| [j; 3]),
        feed_max_mm_min: 3000.0,
        rapid_mm_min: 10000.0,
        accel_mm_s2: [1000.0; 3],
        ..Machine::default()
    };
    // What callers pay to bound the stations before building them.
    let t = std::time::Instant::now();
    let counted = station_count(&path, &machine, 0.05, policy);
    println!(
        "station_count: {:.3} ms, {counted} stations",
        t.elapsed().as_secs_f64() * 1e3
    );
    for corners in [Corners::Passed, Corners::Judged] {
        let best = (0..5)
            .map(|_| {
                let t = std::time::Instant::now();
                let st = Stations::with_corners(&path, &machine, 0.05, policy, corners)
                    .expect("stations");
                (t.elapsed().as_secs_f64(), st.len(), fingerprint(&st))
            })
            .fold((f64::INFINITY, 0, 0), |a, b| if b.0 < a.0 { b } else { a });
        println!(
            "{corners:?}: {:.3} s, {} stations, fingerprint {:016x}",
            best.0, best.1, best.2
        );
    }
}

/// A hash of the stations' arrays, bit for bit.
fn fingerprint(st: &Stations) -> u64 {
    use std::hash::{Hash, Hasher};
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
    h.finish()
}
