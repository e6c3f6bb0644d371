//! Real programs planned with every corner passed and with each corner judged (stop or
//! pass), against exact stop, at 1 and 16 ms, with and without a jerk limit.
//!
//! `cargo run --release -p schedule --example corner_survey -- FILE...`

use schedule::*;
use std::time::Instant;

fn main() {
    println!("program                          T   jerk   passed s   judged s  stopped s   exact s  build p/j s  plan p/j s");
    for file in std::env::args().skip(1) {
        let text = std::fs::read(&file).expect("readable");
        let text = String::from_utf8_lossy(&text);
        let parsed = nc::parse(&text, &file, &nc::Options::default());
        let path = parsed.path;
        if path.segments.is_empty() {
            continue;
        }
        let name = std::path::Path::new(&file)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .to_string();
        for period_ms in [1.0, 16.0] {
            for jerk in [None, Some([20000.0; 3])] {
                let machine = Machine {
                    period_ms,
                    feed_max_mm_min: 3000.0,
                    rapid_mm_min: 10000.0,
                    accel_mm_s2: [1000.0; 3],
                    jerk_mm_s3: jerk,
                    ..Machine::default()
                };
                let mut row = Vec::new();
                for corners in [Corners::Passed, Corners::Judged, Corners::Stopped] {
                    let t0 = Instant::now();
                    let st = match Stations::with_corners(
                        &path,
                        &machine,
                        0.05,
                        FeedPolicy::Programmed,
                        corners,
                    ) {
                        Ok(st) => st,
                        Err(e) => {
                            println!("{name}: {e}");
                            return;
                        }
                    };
                    let t1 = Instant::now();
                    let p = plan(&st);
                    let t2 = Instant::now();
                    row.push((
                        p.cycle_time_s(),
                        (t1 - t0).as_secs_f64(),
                        (t2 - t1).as_secs_f64(),
                    ));
                }
                let es = exact_stop_time_s(&path, &machine, FeedPolicy::Programmed);
                println!(
                    "{name:30} {period_ms:>4} {:5} {:>10.3} {:>10.3} {:>10.3} {:>9.3} {:>6.2}/{:<6.2} {:>6.2}/{:<6.2}{}",
                    jerk.is_some(), row[0].0, row[1].0, row[2].0, es, row[0].1, row[1].1, row[0].2, row[1].2,
                    if row[1].0 > es * 1.0001 { "  OVER-ES" } else { "" },
                );
            }
        }
    }
}
