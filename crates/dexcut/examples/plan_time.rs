//! CPU time of `schedule::plan` on a job's program (its machine, then the same machine
//! with a jerk limit of 20 000 mm/s³): the best of 5 plans, and one plan with its servo
//! samples; then one `schedule::lower_bound_time_s` and the bound; thread CPU time from
//! `/proc/thread-self/schedstat` (Linux).
//!
//! `cargo run --release -p dexcut --example plan_time -- JOB.toml`

fn thread_cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").expect("schedstat");
    let ns: f64 = stat
        .split_whitespace()
        .next()
        .and_then(|x| x.parse().ok())
        .expect("ns");
    ns * 1e-9
}

fn main() {
    let job = std::env::args().nth(1).expect("usage: plan_time JOB.toml");
    let setup = dexcut::commands::Setup::load(std::path::Path::new(&job), None).expect("job");
    for jerk_mm_s3 in [setup.machine.jerk_mm_s3, Some([20_000.0; 3])] {
        let machine = schedule::Machine {
            jerk_mm_s3,
            ..setup.machine
        };
        let st = schedule::Stations::new(
            &setup.program.path,
            &machine,
            0.05, // the planner's station spacing (motion::STATION_DS_MM)
            schedule::FeedPolicy::Programmed,
        )
        .expect("stations");
        let (mut best_s, mut cycle_s) = (f64::INFINITY, 0.0);
        for _ in 0..5 {
            let t0 = thread_cpu_s();
            cycle_s = schedule::plan(&st).cycle_time_s();
            best_s = best_s.min(thread_cpu_s() - t0);
        }
        let t0 = thread_cpu_s();
        let samples = schedule::plan(&st)
            .sample(machine.period_ms)
            .expect("samples");
        let sampled_s = thread_cpu_s() - t0;
        let t0 = thread_cpu_s();
        let bound_s = schedule::lower_bound_time_s(&st);
        let bound_cpu_s = thread_cpu_s() - t0;
        println!(
            "{job}, jerk {jerk_mm_s3:?}: {} stations, plan {best_s:.3} s CPU (best of 5), plan + samples {sampled_s:.3} s ({} samples), cycle {cycle_s:.4} s; lower bound {bound_s:.4} s in {bound_cpu_s:.3} s CPU",
            st.len(),
            samples.len()
        );
    }
}
