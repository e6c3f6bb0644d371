//! CPU time of `schedule::plan` on a job's program (its machine, then the same machine
//! with a jerk limit of 20 000 mm/s³): the best of 5 plans (or PLANS), and one plan with
//! its servo samples; then one `schedule::lower_bound_time_s` and the bound. CPU time is
//! the process's, every thread's (the plan's sections are made on rayon's threads), from
//! `/proc/self/task/*/schedstat` (Linux); the plan's wall time beside it (best of the
//! same plans).
//!
//! `cargo run --release -p dexcut --example plan_time -- JOB.toml [PLANS]` (PLANS: how many
//! plans the best is taken of, 5 by default)

/// CPU time of the threads running now, s (rayon's threads stay for the process).
fn process_cpu_s() -> f64 {
    let tasks = std::fs::read_dir("/proc/self/task").expect("tasks");
    let ns: f64 = tasks
        .filter_map(|task| {
            let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
            stat.split_whitespace().next()?.parse::<f64>().ok()
        })
        .sum();
    ns * 1e-9
}

fn main() {
    let job = std::env::args()
        .nth(1)
        .expect("usage: plan_time JOB.toml [PLANS]");
    let plans: usize = std::env::args()
        .nth(2)
        .map_or(5, |x| x.parse().expect("PLANS: a count"));
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
        let (mut best_s, mut best_wall_s, mut cycle_s) = (f64::INFINITY, f64::INFINITY, 0.0);
        for _ in 0..plans {
            let (t0, wall) = (process_cpu_s(), std::time::Instant::now());
            cycle_s = schedule::plan(&st).cycle_time_s();
            best_s = best_s.min(process_cpu_s() - t0);
            best_wall_s = best_wall_s.min(wall.elapsed().as_secs_f64());
        }
        let t0 = process_cpu_s();
        let samples = schedule::plan(&st)
            .sample(machine.period_ms)
            .expect("samples");
        let sampled_s = process_cpu_s() - t0;
        let t0 = process_cpu_s();
        let bound_s = schedule::lower_bound_time_s(&st);
        let bound_cpu_s = process_cpu_s() - t0;
        println!(
            "{job}, jerk {jerk_mm_s3:?}: {} stations, plan {best_s:.3} s CPU, {best_wall_s:.3} s wall (best of {plans} each), plan + samples {sampled_s:.3} s ({} samples), cycle {cycle_s:.4} s; lower bound {bound_s:.4} s in {bound_cpu_s:.3} s CPU",
            st.len(),
            samples.len()
        );
    }
}
