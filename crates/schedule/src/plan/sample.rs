//! Servo samples of a profile: a run's state at a time, and the sampler that walks the
//! runs forward in time (the filtered motion, mapped onto the path).

use nalgebra::{Point3, Vector3};

use super::profile::{Profile, Run};
use crate::kinematics::integral_over_mm_s;
use crate::machine::ScheduleError;

/// One servo sample: where the tool tip is commanded at time `t_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoSample {
    /// Time from the program start, s.
    pub t_s: f64,
    /// Tool-tip position, mm.
    pub pos: Point3<f64>,
    /// Path speed at that instant, mm/min.
    pub feed_mm_min: f64,
    /// Arc length from the path start, mm.
    pub s_mm: f64,
    /// Index of the path segment the tool is on.
    pub segment: u32,
}

/// Per-axis velocity in mm/s over each pair of consecutive samples (one fewer than samples).
pub fn axis_velocity_mm_s(samples: &[ServoSample]) -> Vec<Vector3<f64>> {
    samples
        .windows(2)
        .map(|w| axis_velocity_between_mm_s((w[0].pos, w[0].t_s), (w[1].pos, w[1].t_s)))
        .collect()
}

/// Per-axis mean velocity in mm/s from position `from.0` (mm) at time
/// `from.1` (s) to `to.0` at `to.1`.
pub fn axis_velocity_between_mm_s(
    from: (Point3<f64>, f64),
    to: (Point3<f64>, f64),
) -> Vector3<f64> {
    (to.0 - from.0) / (to.1 - from.1)
}

/// Most servo samples one profile may produce (about 60 bytes each, 1.2 GB at the bound).
pub const MAX_SAMPLES: usize = 20_000_000;

/// Where a planned run is at a time: arc length, speed and ∫ (s − s_first) dt.
#[derive(Clone, Copy, Debug)]
pub(super) struct RunState {
    pub(super) s_mm: f64,
    pub(super) v_mm_s: f64,
    pub(super) integral_mm_s: f64,
}

impl<'a> Profile<'a> {
    /// Servo samples every `period_ms` from t = 0, plus one at the cycle end.
    ///
    /// Inside a station interval s(t) is the exact quadratic of constant acceleration (with a
    /// jerk limit: the exact moving average of it); s is then mapped onto the segment's own
    /// geometry, so positions lie exactly on lines and arcs.
    ///
    /// More than [`MAX_SAMPLES`] samples (see [`Profile::sample_count`]) is an error,
    /// checked before allocating; so is a period that is not finite and > 0, and a run
    /// whose samples break an axis limit after every fallback.
    pub fn sample(&self, period_ms: f64) -> Result<Vec<ServoSample>, ScheduleError> {
        let count = self.sample_count(period_ms)?;
        if count > MAX_SAMPLES as f64 {
            return Err(ScheduleError::TooManySamples {
                needed: count,
                limit: MAX_SAMPLES,
                cycle_time_s: self.cycle_time_s,
                period_ms,
            });
        }
        let period_s = period_ms * 1e-3;
        let count = count as usize;
        let mut samples = Vec::with_capacity(count);
        let mut sampler = Sampler::starting_at(self, 0.0);
        for j in 0..count {
            let t_s = j as f64 * period_s;
            if t_s >= self.cycle_time_s {
                break;
            }
            samples.push(sampler.at(t_s));
        }
        samples.push(sampler.at(self.cycle_time_s));
        Ok(samples)
    }

    /// Number of samples [`Profile::sample`] makes at `period_ms` (as f64: it may be
    /// astronomically large), so callers can check memory before sampling. An error also
    /// where a run's samples break an axis limit after every fallback
    /// ([`ScheduleError::UnverifiedRun`]): such a profile is never sampled.
    pub fn sample_count(&self, period_ms: f64) -> Result<f64, ScheduleError> {
        if let Some(error) = &self.unverified {
            return Err(error.clone());
        }
        if !(period_ms.is_finite() && period_ms > 0.0) {
            return Err(ScheduleError::InvalidMachine {
                name: "period_ms",
                value: period_ms,
            });
        }
        Ok((self.cycle_time_s / (period_ms * 1e-3)).ceil() + 1.0)
    }

    /// State of run `run` at time `t_s`, searching intervals from `*cursor` on (monotone).
    pub(super) fn run_state(&self, run: &Run, t_s: f64, cursor: &mut usize) -> RunState {
        let s = self.stations.s_mm();
        let s_first = s[run.first];
        // Before and after the run the motion goes on at the run's end speeds: 0 at a
        // stop, a section's held cap where it joins the next section (MODEL.md §6.1,
        // "Sections").
        let (v_first, v_last) = (self.speed_mm_s[run.first], self.speed_mm_s[run.last]);
        if t_s <= run.start_s {
            if v_first == 0.0 {
                return RunState {
                    s_mm: s_first,
                    v_mm_s: 0.0,
                    integral_mm_s: 0.0,
                };
            }
            let h = run.start_s - t_s;
            return RunState {
                s_mm: s_first - v_first * h,
                v_mm_s: v_first,
                integral_mm_s: v_first * h * h / 2.0,
            };
        }
        let end_s = run.start_s + run.duration_s;
        if t_s >= end_s {
            let s_last = s[run.last];
            let h = t_s - end_s;
            let integral_mm_s = run.integral_mm_s + (s_last - s_first) * h;
            if v_last == 0.0 {
                return RunState {
                    s_mm: s_last,
                    v_mm_s: 0.0,
                    integral_mm_s,
                };
            }
            return RunState {
                s_mm: s_last + v_last * h,
                v_mm_s: v_last,
                integral_mm_s: integral_mm_s + v_last * h * h / 2.0,
            };
        }
        let mut k = (*cursor).max(run.first);
        while k + 1 < run.last && self.interval_start_s[k + 1] <= t_s {
            k += 1;
        }
        *cursor = k;
        // An interval of a gap followed exactly: s(t) of the gap's motion.
        let gaps = &self.gaps[run.gaps.0..run.gaps.1];
        if let Some(gap) = gaps
            .get(gaps.partition_point(|g| g.last <= k))
            .filter(|g| g.first <= k)
        {
            let (x, v_mm_s) = gap.motion.state_s(t_s - gap.start_s);
            return RunState {
                s_mm: (s[gap.first] + x).clamp(s[k], s[k + 1]),
                v_mm_s,
                integral_mm_s: 0.0,
            };
        }
        let (v0, v1) = (self.speed_mm_s[k], self.speed_mm_s[k + 1]);
        let dt = self.interval_dt_s(k);
        let h = (t_s - self.interval_start_s[k]).clamp(0.0, dt);
        let a = (v1 - v0) / dt;
        let s_mm = (s[k] + v0 * h + a * h * h / 2.0).min(s[k + 1]);
        let integral_mm_s = match self.interval_integral_mm_s.get(k) {
            Some(i0) => i0 + integral_over_mm_s(s[k] - s_first, v0, a, h),
            None => 0.0,
        };
        RunState {
            s_mm,
            v_mm_s: v0 + a * h,
            integral_mm_s,
        }
    }
}

/// Walks a profile forward in time; every cursor only moves ahead.
pub(super) struct Sampler<'p, 'a> {
    profile: &'p Profile<'a>,
    run: usize,
    /// Interval cursors for t and for t − W.
    now: usize,
    lagged: usize,
    /// Interval cursor for mapping s to a position.
    place: usize,
}

impl<'p, 'a> Sampler<'p, 'a> {
    /// A sampler whose first sample is at `t_s` or later; its cursors stand where a sampler
    /// walked from t = 0 would stand, so the samples are the same, bit for bit. O(log n).
    pub(super) fn starting_at(profile: &'p Profile<'a>, t_s: f64) -> Self {
        let runs = &profile.runs;
        let run = runs
            .partition_point(|r| r.switch_s <= t_s)
            .saturating_sub(1);
        let (now, lagged, place) = match runs.get(run) {
            None => (0, 0, 0),
            Some(r) => {
                // The interval the run is in at t (and t − W), as run_state would walk to it.
                let starts = &profile.interval_start_s[r.first..r.last];
                let interval =
                    |t: f64| r.first + starts.partition_point(|&x| x <= t).saturating_sub(1);
                // The place cursor stops at the first station interval whose end reaches s;
                // s is at least the run's first station's.
                let s = profile.stations.s_mm();
                let place = s[1.min(s.len())..].partition_point(|&x| x < s[r.first]);
                (
                    interval(t_s),
                    interval(t_s - r.window_s),
                    place.min(s.len().saturating_sub(2)),
                )
            }
        };
        Sampler {
            profile,
            run,
            now,
            lagged,
            place,
        }
    }

    pub(super) fn at(&mut self, t_s: f64) -> ServoSample {
        let profile = self.profile;
        let stations = profile.stations;
        let runs = &profile.runs;
        while self.run + 1 < runs.len() && t_s >= runs[self.run + 1].switch_s {
            self.run += 1;
        }
        let (s_mm, v_mm_s) = match runs.get(self.run) {
            None => (0.0, 0.0),
            Some(run)
                if run.window_s > 0.0
                    && profile.speed_mm_s[run.last] == 0.0
                    && t_s >= run.start_s + run.duration_s + run.window_s =>
            {
                (stations.s_mm()[run.last], 0.0)
            }
            Some(run) if run.window_s > 0.0 => {
                let w = run.window_s;
                let now = profile.run_state(run, t_s, &mut self.now);
                let lagged = profile.run_state(run, t_s - w, &mut self.lagged);
                let (s_first, s_last) = (stations.s_mm()[run.first], stations.s_mm()[run.last]);
                let average = s_first + (now.integral_mm_s - lagged.integral_mm_s) / w;
                // The average never passes a stop; rounding could by 1e-12 mm. A section
                // joins the next one at speed (MODEL.md §6.1, "Sections").
                let s_mm = if profile.speed_mm_s[run.last] == 0.0 {
                    average.min(s_last)
                } else {
                    average
                };
                (s_mm, (now.s_mm - lagged.s_mm) / w)
            }
            Some(run) => {
                let state = profile.run_state(run, t_s, &mut self.now);
                (state.s_mm, state.v_mm_s)
            }
        };
        let (pos, segment) = if stations.len() < 2 {
            (stations.position_at(0), stations.segment()[0])
        } else {
            let s = stations.s_mm();
            while self.place + 2 < stations.len() && s[self.place + 1] < s_mm {
                self.place += 1;
            }
            stations.locate(self.place, s_mm)
        };
        ServoSample {
            t_s,
            pos,
            feed_mm_min: v_mm_s * 60.0,
            s_mm,
            segment,
        }
    }
}
