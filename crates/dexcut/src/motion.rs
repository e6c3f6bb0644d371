//! From a motion path to sweep steps with times: servo periods for G-code
//! (through the `schedule` planner), one step per move for CSV point lists.

use crate::error::Result;
use nc::Motion;
use schedule::{Controller, FeedPolicy, Machine, ServoSample, Stations};

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
    /// Arc length along the path at the end of the step, mm.
    pub s_end_mm: f64,
    /// This step is the second (or later) part of a servo period split where
    /// the motion changes between rapid and feed.
    pub continues: bool,
    /// The step's period runs on a feed held as programmed (G84/G74
    /// tapping, `nc::Motion::Feed`'s `held`): optimize does not slow it.
    pub held: bool,
    /// Number (T word) of the tool cutting the step.
    pub tool: u32,
    /// Spindle speed of the block the step ends in (its S word), rev/min; 0 when none was given.
    pub spindle_rpm: f64,
}

/// The servo periods of `steps`, as ranges of steps: each period is a step
/// and every following one that continues it ([`TimedStep::continues`]).
pub fn periods(steps: &[TimedStep]) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let mut first = 0;
    std::iter::from_fn(move || {
        if first >= steps.len() {
            return None;
        }
        let mut end = first + 1;
        while end < steps.len() && steps[end].continues {
            end += 1;
        }
        let period = first..end;
        first = end;
        Some(period)
    })
}

// The machine limits from the job live with the job (input::job::machine);
// the upper layers still name them here.

/// Steps between consecutive servo samples. A period that crosses the start
/// or end of a rapid move is split there (at the path's corner), so material a
/// rapid removes is told apart from what the moves before or after it removed,
/// and each part is blamed on its own line. The parts share the period's time
/// by their lengths at the speeds sampled at the period's ends;
/// [`TimedStep::continues`] marks the second part.
pub fn steps_from_samples(path: &nc::Path, samples: &[ServoSample]) -> Vec<TimedStep> {
    let is_rapid = |seg: usize| matches!(path.segments[seg].motion, Motion::Rapid);
    let mut steps = Vec::with_capacity(samples.len());
    for w in samples.windows(2) {
        let (a, b) = (w[0].segment as usize, w[1].segment as usize);
        let dt = w[1].t_s - w[0].t_s;
        let feed_mm_min = if dt > 0.0 {
            (w[1].s_mm - w[0].s_mm) / dt * 60.0
        } else {
            0.0
        };
        let held = (a..=b).any(|k| path.segments[k].motion.held_feed_mm_min().is_some());
        let splits = |k: usize| is_rapid(k) || is_rapid(k + 1);
        // A part of the period from `from_mm` to `to_mm` on segment `seg`: what
        // it takes of the segment (its times are the caller's).
        let on_segment = |from_mm: [f64; 3], to_mm: [f64; 3], seg: usize| TimedStep {
            step: dexel::Step {
                from_mm,
                to_mm,
                rapid: is_rapid(seg),
            },
            t_end_s: 0.0,
            dt_s: 0.0,
            feed_mm_min: 0.0,
            line: path.segments[seg].line,
            s_end_mm: 0.0,
            continues: false,
            held,
            tool: path.segments[seg].tool,
            spindle_rpm: path.segments[seg].spindle_rpm,
        };
        if !(a..b).any(splits) {
            // One part, the whole period (most periods): what the parts below
            // make of it, without their lists.
            steps.push(TimedStep {
                t_end_s: w[1].t_s,
                dt_s: w[1].t_s - w[0].t_s,
                feed_mm_min,
                s_end_mm: w[1].s_mm,
                ..on_segment(w[0].pos.coords.into(), w[1].pos.coords.into(), b)
            });
            continue;
        }
        // Ends of segments inside the period where a rapid starts or ends.
        let cuts: Vec<usize> = (a..b).filter(|&k| splits(k)).collect();
        let mut points: Vec<([f64; 3], usize)> = vec![(w[0].pos.coords.into(), a)];
        points.extend(
            cuts.iter()
                .map(|&k| (path.segments[k].end.coords.into(), k)),
        );
        points.push((w[1].pos.coords.into(), b));
        let lengths: Vec<f64> = points
            .windows(2)
            .map(|p| {
                let d: f64 = (0..3).map(|i| (p[1].0[i] - p[0].0[i]).powi(2)).sum();
                d.sqrt()
            })
            .collect();
        // Each part's time from its length at the speed of the sample at its
        // end of the period (the middle parts at the faster one), scaled to
        // the period; its speed never shows above that sample's.
        let n_parts = lengths.len();
        let part_speed: Vec<f64> = (0..n_parts)
            .map(|j| match (j == 0, j + 1 == n_parts) {
                (true, true) => feed_mm_min,
                (true, false) => w[0].feed_mm_min,
                (false, true) => w[1].feed_mm_min,
                (false, false) => w[0].feed_mm_min.max(w[1].feed_mm_min),
            })
            .collect();
        let estimate: Vec<f64> = (0..n_parts)
            .map(|j| lengths[j] / part_speed[j].max(1e-9))
            .collect();
        let total: f64 = estimate.iter().sum();
        let (mut t, mut s) = (w[0].t_s, w[0].s_mm);
        for (j, p) in points.windows(2).enumerate() {
            let last = j + 2 == points.len();
            let part_dt = if last {
                w[1].t_s - t
            } else if total > 0.0 {
                dt * estimate[j] / total
            } else {
                0.0
            };
            t = if last { w[1].t_s } else { t + part_dt };
            s = if last { w[1].s_mm } else { s + lengths[j] };
            // The part up to a corner lies on the corner's segment (or, without
            // a rapid, on segments of its kind).
            steps.push(TimedStep {
                t_end_s: t,
                dt_s: part_dt,
                feed_mm_min: if n_parts == 1 {
                    feed_mm_min
                } else if part_dt > 0.0 {
                    (lengths[j] / part_dt * 60.0).min(part_speed[j])
                } else {
                    0.0
                },
                s_end_mm: s,
                continues: j > 0,
                ..on_segment(p[0].0, p[1].0, p[1].1)
            });
        }
    }
    steps
}

/// One servo sample as servo.csv writes it: time, tool-tip position and path
/// speed, and the tool and spindle speed of the block it lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleRow {
    /// Time from the program start, s.
    pub t_s: f64,
    /// Tool-tip position, mm.
    pub pos: nalgebra::Point3<f64>,
    /// Path speed at that instant, mm/min.
    pub feed_mm_min: f64,
    /// Number (T word) of the tool of its block.
    pub tool: u32,
    /// Spindle speed of its block, rev/min (0 where none was set).
    pub spindle_rpm: f64,
}

impl SampleRow {
    /// `sample`, on `path`'s block it lies on.
    pub fn of(sample: &ServoSample, path: &nc::Path) -> SampleRow {
        let seg = &path.segments[sample.segment as usize];
        SampleRow {
            t_s: sample.t_s,
            pos: sample.pos,
            feed_mm_min: sample.feed_mm_min,
            tool: seg.tool,
            spindle_rpm: seg.spindle_rpm,
        }
    }
}

/// Servo samples kept as what their steps ([`steps_from_samples`]) do not
/// hold of them: the first sample, and each sample's path speed (8 B a
/// sample instead of the sample's 56 and its block's tool and spindle
/// speed's 16). Every later sample ends its period's last step:
/// that step ends at the sample's time and position and lies on the
/// sample's block.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleFeeds {
    first: Option<SampleRow>,
    feeds_mm_min: Vec<f64>,
}

impl SampleFeeds {
    /// What the rows of `samples` on `path` need beside their steps.
    pub fn of(samples: &[ServoSample], path: &nc::Path) -> SampleFeeds {
        SampleFeeds {
            first: samples.first().map(|s| SampleRow::of(s, path)),
            feeds_mm_min: samples.iter().skip(1).map(|s| s.feed_mm_min).collect(),
        }
    }

    /// The samples' rows, given `steps`, the steps made of the samples by
    /// [`steps_from_samples`] (the same values as [`SampleRow::of`] each
    /// sample, bit for bit).
    pub fn rows<'a>(&'a self, steps: &'a [TimedStep]) -> impl Iterator<Item = SampleRow> + 'a {
        let ends = periods(steps).map(|period| &steps[period.end - 1]);
        self.first
            .into_iter()
            .chain(
                ends.zip(&self.feeds_mm_min)
                    .map(|(s, &feed_mm_min)| SampleRow {
                        t_s: s.t_end_s,
                        pos: s.step.to_mm.into(),
                        feed_mm_min,
                        tool: s.tool,
                        spindle_rpm: s.spindle_rpm,
                    }),
            )
    }
}

/// How the machine runs the program as written: servo samples every period, planned by
/// `controller` (MODEL.md §6.1 for the ideal planner, §6.4 for the controls').
pub fn machine_motion(
    path: &nc::Path,
    machine: &Machine,
    controller: &Controller,
) -> Result<Vec<ServoSample>> {
    match controller {
        Controller::Ideal => {
            let stations = Stations::new(path, machine, STATION_DS_MM, FeedPolicy::Programmed)?;
            samples(&stations, machine)
        }
        _ => controlled(path, machine, controller),
    }
}

/// [`machine_motion`] with the path handed to the planner's stations rather than
/// copied into them; the path comes back in every case.
pub fn machine_motion_of(
    path: nc::Path,
    machine: &Machine,
    controller: &Controller,
) -> (Result<Vec<ServoSample>>, nc::Path) {
    if !matches!(controller, Controller::Ideal) {
        return (controlled(&path, machine, controller), path);
    }
    match Stations::from_path(path, machine, STATION_DS_MM, FeedPolicy::Programmed) {
        Ok(stations) => {
            let samples = samples(&stations, machine);
            (samples, stations.into_path())
        }
        Err((e, path)) => (Err(e.into()), path),
    }
}

/// The servo samples of a real control's planner (MODEL.md §6.4).
fn controlled(
    path: &nc::Path,
    machine: &Machine,
    controller: &Controller,
) -> Result<Vec<ServoSample>> {
    let samples = match controller {
        Controller::Grbl(settings) => schedule::controller::grbl::samples(path, machine, settings),
        Controller::LinuxCnc(settings) => {
            schedule::controller::linuxcnc::samples(path, machine, settings)
        }
        Controller::Ideal => unreachable!("the ideal planner plans through its stations"),
    }?;
    let cycle_time_s = samples.last().map_or(0.0, |s| s.t_s);
    crate::bounds::check_samples(cycle_time_s, machine.period_ms, "the program")?;
    Ok(samples)
}

/// The servo samples of the time-optimal plan along `stations`.
fn samples(stations: &Stations, machine: &Machine) -> Result<Vec<ServoSample>> {
    let profile = schedule::plan(stations);
    crate::bounds::check_samples(profile.cycle_time_s(), machine.period_ms, "the program")?;
    Ok(profile.sample(machine.period_ms)?)
}

/// CSV point lists: one step per move, time = length / feed (no acceleration);
/// a dwell (a servo stream's row where the tool stays put) takes its time. A
/// servo stream (`stream`: servo.csv read back) times each move by its rows'
/// `t_s` and gives it its kind (rapid or feed) and whether it continues the
/// servo period before it, as the run that wrote the stream swept it.
pub fn direct_steps(
    path: &nc::Path,
    stream: Option<&crate::input::program::StreamTiming>,
) -> Vec<TimedStep> {
    let (mut t, mut s) = (0.0, 0.0);
    path.segments
        .iter()
        .enumerate()
        .map(|(k, seg)| {
            let (t_end, dt) = match stream {
                Some(timing) => {
                    let t_end = timing.t_end_s[k];
                    let t0 = if k == 0 { 0.0 } else { timing.t_end_s[k - 1] };
                    (t_end, t_end - t0)
                }
                None => {
                    let dt = match seg.motion {
                        Motion::Feed { feed_mm_min, .. } if feed_mm_min > 0.0 => {
                            seg.length_mm() / feed_mm_min * 60.0
                        }
                        Motion::Dwell { seconds } => seconds,
                        _ => 0.0,
                    };
                    (t + dt, dt)
                }
            };
            let feed = match seg.motion {
                Motion::Dwell { .. } => 0.0,
                Motion::Feed { feed_mm_min, .. } if stream.is_none() => feed_mm_min.max(0.0),
                _ if dt > 0.0 => seg.length_mm() / dt * 60.0,
                _ => 0.0,
            };
            t = t_end;
            s += seg.length_mm();
            TimedStep {
                step: dexel::Step {
                    from_mm: seg.start.coords.into(),
                    to_mm: seg.end.coords.into(),
                    rapid: matches!(seg.motion, Motion::Rapid),
                },
                t_end_s: t,
                dt_s: dt,
                feed_mm_min: feed,
                line: seg.line,
                s_end_mm: s,
                continues: stream.is_some_and(|timing| timing.continues[k]),
                held: seg.motion.held_feed_mm_min().is_some(),
                tool: seg.tool,
                spindle_rpm: seg.spindle_rpm,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::program::read_points_csv;

    /// A period is a step and the steps after it that continue it; a first
    /// step that continues nothing before it still starts one.
    #[test]
    fn periods_are_a_step_and_the_steps_that_continue_it() {
        let step = |continues| TimedStep {
            step: dexel::Step {
                from_mm: [0.0; 3],
                to_mm: [0.0; 3],
                rapid: false,
            },
            t_end_s: 0.0,
            dt_s: 0.0,
            feed_mm_min: 0.0,
            line: 0,
            s_end_mm: 0.0,
            continues,
            held: false,
            tool: 1,
            spindle_rpm: 0.0,
        };
        let steps: Vec<TimedStep> = [true, true, false, false, true, true, false]
            .into_iter()
            .map(step)
            .collect();
        let got: Vec<_> = periods(&steps).collect();
        assert_eq!(got, [0..2, 2..3, 3..6, 6..7]);
        assert_eq!(periods(&[]).count(), 0);
    }

    /// servo.csv's rows made again from the steps and the feeds equal the
    /// samples' own, bit for bit: on a program whose servo periods are split
    /// at rapids (steps that continue a period), with two tools and spindle
    /// speeds and an arc; so do the axis velocities between them.
    #[test]
    fn sample_rows_from_the_steps_are_the_samples() {
        let text = "G21 G90 G17\nT1 M6 S9000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F600\nG1 X10 Y3 F1200\n\
                    G2 X14 Y7 I0 J4 F900\nG0 Z5\nG0 X20\nG1 Z-0.5 F300\nT2 M6 S12000 M3\n\
                    G1 X25 Y-2 F1500\nG0 Z10\nG0 X0 Y0\nM2\n";
        let parsed = nc::parse(text, "t.nc", &nc::Options::default());
        assert!(parsed.diagnostics.iter().all(|d| !d.is_error()));
        let path = parsed.path;
        let machine = Machine {
            period_ms: 4.0,
            ..Machine::default()
        };
        let samples = machine_motion(&path, &machine, &Controller::Ideal).unwrap();
        let steps = steps_from_samples(&path, &samples);
        // The program splits periods at its rapids, and uses both tools.
        assert!(steps.iter().filter(|s| s.continues).count() >= 4);
        assert!(samples.len() > 100 && steps.len() > samples.len());
        let tools: std::collections::BTreeSet<u32> = samples
            .iter()
            .map(|s| SampleRow::of(s, &path).tool)
            .collect();
        assert_eq!(tools.len(), 2);

        let feeds = SampleFeeds::of(&samples, &path);
        let rows: Vec<SampleRow> = feeds.rows(&steps).collect();
        assert_eq!(rows.len(), samples.len());
        let bits = |r: &SampleRow| {
            [
                r.t_s,
                r.pos.x,
                r.pos.y,
                r.pos.z,
                r.feed_mm_min,
                r.spindle_rpm,
            ]
            .map(f64::to_bits)
        };
        for (i, (row, sample)) in rows.iter().zip(&samples).enumerate() {
            let own = SampleRow::of(sample, &path);
            assert_eq!((bits(row), row.tool), (bits(&own), own.tool), "sample {i}");
        }
        let velocity = schedule::axis_velocity_mm_s(&samples);
        for (i, w) in rows.windows(2).enumerate() {
            let v =
                schedule::axis_velocity_between_mm_s((w[0].pos, w[0].t_s), (w[1].pos, w[1].t_s));
            assert_eq!(
                v.map(f64::to_bits),
                velocity[i].map(f64::to_bits),
                "period {i}"
            );
        }
    }

    #[test]
    fn servo_streams_are_timed_by_their_times() {
        let text =
            "t_s,x,y,z,feed_mm_min\n0,0,0,1,0\n0.01,0.5,0,1,9\n0.02,0.5,0,1,0\n0.03,0.5,0.2,1,9\n";
        let (path, timing) = read_points_csv(text, "servo.csv", None, 1).unwrap();
        assert_eq!(path.segments.len(), 3);
        // 0.5 mm in 0.01 s is 3000 mm/min whatever the feed column says.
        match path.segments[0].motion {
            nc::Motion::Feed { feed_mm_min, .. } => assert!((feed_mm_min - 3000.0).abs() < 1e-9),
            m => panic!("{m:?}"),
        }
        assert_eq!(path.segments[1].motion, nc::Motion::Dwell { seconds: 0.01 });
        let steps = direct_steps(&path, timing.as_ref());
        let times: Vec<f64> = steps.iter().map(|s| s.t_end_s).collect();
        assert_eq!(times, [0.01, 0.02, 0.03]);
        assert!(steps.iter().all(|s| !s.step.rapid && !s.continues));
        let err = read_points_csv(
            "t_s,x,y,z\n0,0,0,0\n0.1,1,0,0\n0.1,2,0,0\n",
            "s.csv",
            None,
            1,
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            err,
            "s.csv:4:1: t_s must increase from row to row: 0.1 s after 0.1 s"
        );
    }

    #[test]
    fn servo_streams_keep_their_rapids_and_corners() {
        // A rapid down to a corner row inside the period ending at 0.02 s,
        // then the feed part of that period.
        let text = "t_s,x,y,z,rapid,sample\n0,0,0,5,1,1\n0.01,0,0,1,1,1\n0.015,0,0,0,1,0\n0.02,0.4,0,0,0,1\n";
        let (path, timing) = read_points_csv(text, "servo.csv", None, 1).unwrap();
        let kinds: Vec<bool> = path
            .segments
            .iter()
            .map(|s| s.motion == nc::Motion::Rapid)
            .collect();
        assert_eq!(kinds, [true, true, false]);
        let steps = direct_steps(&path, timing.as_ref());
        let rapid: Vec<bool> = steps.iter().map(|s| s.step.rapid).collect();
        let continues: Vec<bool> = steps.iter().map(|s| s.continues).collect();
        let times: Vec<f64> = steps.iter().map(|s| s.t_end_s).collect();
        assert_eq!(rapid, [true, true, false]);
        assert_eq!(continues, [false, false, true]);
        assert_eq!(times, [0.01, 0.015, 0.02]);
        // 0.4 mm in 5 ms.
        assert!((steps[2].feed_mm_min - 4800.0).abs() < 1e-9);
        let err = read_points_csv(
            "t_s,x,y,z,rapid\n0,0,0,0,0\n0.1,1,0,0,2\n",
            "s.csv",
            None,
            1,
        )
        .unwrap_err()
        .to_string();
        assert_eq!(err, "s.csv:3:11: rapid must be 0 or 1, got 2");
    }
}
