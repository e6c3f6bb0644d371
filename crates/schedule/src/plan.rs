//! Time-optimal speed profile along the stations, and servo sampling of it.

use nalgebra::{Point3, Vector3};

use crate::stations::{CapKind, Stations};

/// A speed within this share below the cap counts as running at the cap.
const AT_CAP_SHARE: f64 = 0.005;

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
        .map(|w| (w[1].pos - w[0].pos) / (w[1].t_s - w[0].t_s))
        .collect()
}

/// Motion from one stop to the next.
#[derive(Clone, Copy, Debug)]
struct Run {
    /// First and last station (both stops).
    first: usize,
    last: usize,
    /// Time the run leaves `first`, s from the program start.
    start_s: f64,
    /// Duration of the planned (unfiltered) motion, s.
    duration_s: f64,
    /// ∫ (s − s_first) dt over the whole planned run, mm·s.
    integral_mm_s: f64,
}

/// A planned speed profile over [`Stations`].
///
/// Without a jerk limit the motion is piecewise constant acceleration: between stations k and
/// k+1, v² is linear in s, so the time is Δt = 2Δs/(v_k + v_k+1) and s(t) is an exact
/// quadratic. With a jerk limit the planned motion of each run between stops is passed
/// through a moving average of width W in time (see [`plan`]).
#[derive(Clone, Debug)]
pub struct Profile<'a> {
    stations: &'a Stations,
    speed_mm_s: Vec<f64>,
    interval_start_s: Vec<f64>,
    interval_dt_s: Vec<f64>,
    /// ∫ (s − s_first of the run) dt from the run start to the start of each interval, mm·s.
    interval_integral_mm_s: Vec<f64>,
    runs: Vec<Run>,
    window_s: f64,
    cycle_time_s: f64,
}

/// Plans the time-optimal speed profile over `stations`.
///
/// Speed at each station is at most its cap; between stations the tangential acceleration is
/// at most the interval's limit (min_i a_i/|t_i|); the tool rests at every stop. The classic
/// forward pass (v_k+1² ≤ v_k² + 2 a Δs from the start) and backward pass (the same from the
/// end) give the largest such speed at every station, hence the least time: this is exact for
/// profiles made of constant-acceleration pieces between stations.
///
/// Jerk limit: each run between stops is planned as above and its speed v(t) is then averaged
/// over a sliding window W = max_k 2·a_k/j_k (a_k, j_k the interval's tangential acceleration
/// and jerk limits). Averaging keeps |a| ≤ max a and bounds the jerk by 2·max a/W ≤ j, keeps
/// the path geometry exact (the filter acts on s(t), not on the axes), keeps stops and dwells
/// exact, and costs W per run. To keep the averaged speed under the caps, the run is first
/// planned with eroded caps (each station's cap lowered to the smallest cap within the distance
/// W·v + Δs that the window can span at that speed; see `erode`), which makes the caps hold
/// exactly at every station at the price of slowing down a little early and late around a
/// dip. Exact on straight lines; on curved paths the jerk bound is tangential only (the normal
/// jerk d(v²κ)/dt is not limited) and corners still step per the corner rule.
pub fn plan(stations: &Stations) -> Profile<'_> {
    let n = stations.len();
    let s = stations.s_mm();
    let accel = stations.interval_accel_mm_s2();
    let mut limit_mm_s: Vec<f64> = stations.cap_mm_min().iter().map(|c| c / 60.0).collect();

    let window_s = accel
        .iter()
        .zip(stations.interval_jerk_mm_s3())
        .map(|(a, j)| 2.0 * a / j)
        .fold(0.0, f64::max);
    let stops = stations.stops();
    if window_s > 0.0 {
        let caps = limit_mm_s.clone();
        for pair in stops.windows(2) {
            erode(
                &caps,
                s,
                pair[0].station,
                pair[1].station,
                window_s,
                &mut limit_mm_s,
            );
        }
    }

    // Forward and backward passes; the tool rests at every stop.
    let mut v = limit_mm_s;
    for stop in stops {
        v[stop.station] = 0.0;
    }
    for k in 0..n.saturating_sub(1) {
        let reach = (v[k] * v[k] + 2.0 * accel[k] * (s[k + 1] - s[k])).sqrt();
        v[k + 1] = v[k + 1].min(reach);
    }
    for k in (0..n.saturating_sub(1)).rev() {
        let reach = (v[k + 1] * v[k + 1] + 2.0 * accel[k] * (s[k + 1] - s[k])).sqrt();
        v[k] = v[k].min(reach);
    }

    // Time line: dwell at a stop, then the run to the next stop (stretched by W if filtered).
    let intervals = n.saturating_sub(1);
    let mut interval_start_s = Vec::with_capacity(intervals);
    let mut interval_dt_s = Vec::with_capacity(intervals);
    let mut interval_integral_mm_s = Vec::with_capacity(if window_s > 0.0 { intervals } else { 0 });
    let mut runs = Vec::with_capacity(stops.len().saturating_sub(1));
    let mut t_s = stops[0].dwell_s;
    for pair in stops.windows(2) {
        let (first, last) = (pair[0].station, pair[1].station);
        let start_s = t_s;
        let mut integral_mm_s = 0.0;
        for k in first..last {
            let ds = s[k + 1] - s[k];
            let dt = 2.0 * ds / (v[k] + v[k + 1]);
            interval_start_s.push(t_s);
            interval_dt_s.push(dt);
            if window_s > 0.0 {
                interval_integral_mm_s.push(integral_mm_s);
                let a = (v[k + 1] - v[k]) / dt;
                integral_mm_s += integral_over_mm_s(s[k] - s[first], v[k], a, dt);
            }
            t_s += dt;
        }
        runs.push(Run {
            first,
            last,
            start_s,
            duration_s: t_s - start_s,
            integral_mm_s,
        });
        t_s += window_s + pair[1].dwell_s;
    }

    Profile {
        stations,
        speed_mm_s: v,
        interval_start_s,
        interval_dt_s,
        interval_integral_mm_s,
        runs,
        window_s,
        cycle_time_s: t_s,
    }
}

/// Erodes the caps of stations `first..=last` for the jerk filter, writing into `out` where
/// lower: c'_k is the largest c ≤ cap_k with c ≤ cap_j for every station j within
/// W·c + Δs_max of station k in s.
///
/// Why that suffices: the filtered position s_f(t) is the mean of s over [t − W, t], so it lies
/// within W·v_f(t) of every planned position in the window, v_f(t) being the window's mean
/// speed. If v_f(t) exceeded the cap at s_f(t), some planned speed in the window would be
/// ≥ v_f(t), hence some station m there has v_m ≥ v_f(t) and a reach W·c'_m + Δs_max that
/// covers s_f(t); so v_m ≤ c'_m ≤ cap at s_f(t) < v_f(t), a contradiction.
///
/// Cost: per station, the stations within its reach (found nearest first).
fn erode(caps: &[f64], s: &[f64], first: usize, last: usize, window_s: f64, out: &mut [f64]) {
    let ds_max = s[first..=last]
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0, f64::max);
    for k in first..=last {
        let mut cap = caps[k];
        let (mut lo, mut hi) = (k, k);
        loop {
            let reach_mm = window_s * cap + ds_max;
            let left = (lo > first).then(|| (s[k] - s[lo - 1], lo - 1));
            let right = (hi < last).then(|| (s[hi + 1] - s[k], hi + 1));
            let nearest = match (left, right) {
                (Some(l), Some(r)) => Some(if l.0 <= r.0 { l } else { r }),
                (l, r) => l.or(r),
            };
            match nearest {
                Some((distance_mm, j)) if distance_mm <= reach_mm => {
                    cap = cap.min(caps[j]);
                    lo = lo.min(j);
                    hi = hi.max(j);
                }
                _ => break,
            }
        }
        out[k] = out[k].min(cap);
    }
}

/// ∫ (s − s_first) dt over the first `h_s` seconds of an interval that starts `offset_mm` past
/// the run's first station at speed `v0_mm_s` with constant acceleration `a_mm_s2`, mm·s.
fn integral_over_mm_s(offset_mm: f64, v0_mm_s: f64, a_mm_s2: f64, h_s: f64) -> f64 {
    offset_mm * h_s + v0_mm_s * h_s * h_s / 2.0 + a_mm_s2 * h_s * h_s * h_s / 6.0
}

/// Where a planned run is at a time: arc length, speed and ∫ (s − s_first) dt.
#[derive(Clone, Copy, Debug)]
struct RunState {
    s_mm: f64,
    v_mm_s: f64,
    integral_mm_s: f64,
}

impl Profile<'_> {
    /// Planned speed at each station, mm/s (before the jerk filter, if any).
    pub fn speed_mm_s(&self) -> &[f64] {
        &self.speed_mm_s
    }

    /// Time at which the planned motion leaves station k towards k+1, s.
    pub fn interval_start_s(&self) -> &[f64] {
        &self.interval_start_s
    }

    /// Width of the jerk filter's moving average, s (0 without a jerk limit).
    pub fn filter_window_s(&self) -> f64 {
        self.window_s
    }

    /// Total time from program start to the end of the last dwell, s.
    pub fn cycle_time_s(&self) -> f64 {
        self.cycle_time_s
    }

    /// Share of the cycle time spent at each kind of cap, in [`CapKind::ALL`] order, summing
    /// to 1. A station counts as at its cap when its speed is within 0.5 % of it; otherwise,
    /// and for the jerk filter's extra time, the time counts as [`CapKind::Acceleration`].
    /// Each interval's time is split evenly between its two stations.
    pub fn time_at_cap_share(&self) -> Vec<(CapKind, f64)> {
        let caps = self.stations.cap_mm_min();
        let kinds = self.stations.cap_kind();
        let binding = |k: usize| {
            if self.speed_mm_s[k] * 60.0 >= (1.0 - AT_CAP_SHARE) * caps[k] {
                kinds[k]
            } else {
                CapKind::Acceleration
            }
        };
        let mut time_s = [0.0; CapKind::ALL.len()];
        for (k, dt) in self.interval_dt_s.iter().enumerate() {
            time_s[binding(k).index()] += dt / 2.0;
            time_s[binding(k + 1).index()] += dt / 2.0;
        }
        time_s[CapKind::Acceleration.index()] += self.window_s * self.runs.len() as f64;
        time_s[CapKind::Dwell.index()] +=
            self.stations.stops().iter().map(|s| s.dwell_s).sum::<f64>();
        let total: f64 = time_s.iter().sum();
        CapKind::ALL
            .iter()
            .map(|&kind| {
                (
                    kind,
                    if total > 0.0 {
                        time_s[kind.index()] / total
                    } else {
                        0.0
                    },
                )
            })
            .collect()
    }

    /// Servo samples every `period_ms` from t = 0, plus one at the cycle end.
    ///
    /// Inside a station interval s(t) is the exact quadratic of constant acceleration (with a
    /// jerk limit: the exact moving average of it); s is then mapped onto the segment's own
    /// geometry, so positions lie exactly on lines and arcs.
    pub fn sample(&self, period_ms: f64) -> Vec<ServoSample> {
        let period_s = period_ms * 1e-3;
        let count = (self.cycle_time_s / period_s).ceil() as usize + 1;
        let mut samples = Vec::with_capacity(count);
        let mut sampler = Sampler {
            profile: self,
            run: 0,
            now: 0,
            lagged: 0,
            place: 0,
        };
        for j in 0..count {
            let t_s = j as f64 * period_s;
            if t_s >= self.cycle_time_s {
                break;
            }
            samples.push(sampler.at(t_s));
        }
        samples.push(sampler.at(self.cycle_time_s));
        samples
    }

    /// State of run `run` at time `t_s`, searching intervals from `*cursor` on (monotone).
    fn run_state(&self, run: &Run, t_s: f64, cursor: &mut usize) -> RunState {
        let s = self.stations.s_mm();
        let s_first = s[run.first];
        if t_s <= run.start_s {
            return RunState {
                s_mm: s_first,
                v_mm_s: 0.0,
                integral_mm_s: 0.0,
            };
        }
        let end_s = run.start_s + run.duration_s;
        if t_s >= end_s {
            let s_last = s[run.last];
            let integral_mm_s = run.integral_mm_s + (s_last - s_first) * (t_s - end_s);
            return RunState {
                s_mm: s_last,
                v_mm_s: 0.0,
                integral_mm_s,
            };
        }
        let mut k = (*cursor).max(run.first);
        while k + 1 < run.last && self.interval_start_s[k + 1] <= t_s {
            k += 1;
        }
        *cursor = k;
        let (v0, v1) = (self.speed_mm_s[k], self.speed_mm_s[k + 1]);
        let dt = self.interval_dt_s[k];
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
struct Sampler<'p, 'a> {
    profile: &'p Profile<'a>,
    run: usize,
    /// Interval cursors for t and for t − W.
    now: usize,
    lagged: usize,
    /// Interval cursor for mapping s to a position.
    place: usize,
}

impl Sampler<'_, '_> {
    fn at(&mut self, t_s: f64) -> ServoSample {
        let profile = self.profile;
        let stations = profile.stations;
        let runs = &profile.runs;
        while self.run + 1 < runs.len() && t_s >= runs[self.run + 1].start_s {
            self.run += 1;
        }
        let (s_mm, v_mm_s) = match runs.get(self.run) {
            None => (0.0, 0.0),
            Some(run) if profile.window_s > 0.0 => {
                let w = profile.window_s;
                let now = profile.run_state(run, t_s, &mut self.now);
                let lagged = profile.run_state(run, t_s - w, &mut self.lagged);
                let s_first = stations.s_mm()[run.first];
                (
                    s_first + (now.integral_mm_s - lagged.integral_mm_s) / w,
                    (now.s_mm - lagged.s_mm) / w,
                )
            }
            Some(run) => {
                let state = profile.run_state(run, t_s, &mut self.now);
                (state.s_mm, state.v_mm_s)
            }
        };
        let (pos, segment) = if stations.len() < 2 {
            (stations.position()[0], stations.segment()[0])
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
