//! From a motion path to sweep steps with times: servo periods for G-code
//! (through the `schedule` planner), one step per move for CSV point lists.

use anyhow::Result;
use nc::Motion;
use schedule::{FeedPolicy, Machine, ServoSample, Stations};

use crate::job::Job;

/// Arc-length resolution of the planner's stations, mm: finer than one servo
/// period at any feed, so caps are respected between samples.
pub const STATION_DS_MM: f64 = 0.05;

/// One sweep step with its timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedStep {
    pub step: dexel::Step,
    /// Time at the end of the step from the program start, s.
    pub t_end_s: f64,
    /// Duration, s.
    pub dt_s: f64,
    /// Mean path speed over the step, mm/min.
    pub feed_mm_min: f64,
    /// Source line of the block the step ends in.
    pub line: u32,
}

/// The machine limits from the job.
pub fn machine(job: &Job) -> Machine {
    let m = &job.machine;
    Machine {
        period_ms: m.period_ms,
        feed_max_mm_min: m.feed_max,
        rapid_mm_min: m.rapid,
        accel_mm_s2: m.accel,
        jerk_mm_s3: m.jerk,
        block_time_ms: m.block_time_ms,
    }
}

/// Steps between consecutive servo samples.
pub fn steps_from_samples(path: &nc::Path, samples: &[ServoSample]) -> Vec<TimedStep> {
    samples
        .windows(2)
        .map(|w| {
            let seg = &path.segments[w[1].segment as usize];
            let dt = w[1].t_s - w[0].t_s;
            TimedStep {
                step: dexel::Step {
                    from_mm: w[0].pos.coords.into(),
                    to_mm: w[1].pos.coords.into(),
                    rapid: matches!(seg.motion, Motion::Rapid),
                },
                t_end_s: w[1].t_s,
                dt_s: dt,
                feed_mm_min: if dt > 0.0 {
                    (w[1].s_mm - w[0].s_mm) / dt * 60.0
                } else {
                    0.0
                },
                line: seg.line,
            }
        })
        .collect()
}

/// How the machine runs the program as written: servo samples every period.
pub fn machine_motion(path: &nc::Path, machine: &Machine) -> Result<Vec<ServoSample>> {
    let stations = Stations::new(path, machine, STATION_DS_MM, FeedPolicy::Programmed)?;
    let profile = schedule::plan(&stations);
    crate::bounds::check_samples(profile.cycle_time_s(), machine.period_ms, "the program")?;
    Ok(profile.sample(machine.period_ms)?)
}

/// CSV point lists: one step per move, time = length / feed (no acceleration).
pub fn direct_steps(path: &nc::Path) -> Vec<TimedStep> {
    let mut t = 0.0;
    path.segments
        .iter()
        .map(|seg| {
            let feed = match seg.motion {
                Motion::Feed { feed_mm_min } => feed_mm_min,
                _ => 0.0,
            };
            let dt = if feed > 0.0 {
                seg.length_mm() / feed * 60.0
            } else {
                0.0
            };
            t += dt;
            TimedStep {
                step: dexel::Step {
                    from_mm: seg.start.coords.into(),
                    to_mm: seg.end.coords.into(),
                    rapid: false,
                },
                t_end_s: t,
                dt_s: dt,
                feed_mm_min: feed,
                line: seg.line,
            }
        })
        .collect()
}
