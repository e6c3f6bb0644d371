//! Time-optimal speed profile along the stations, and servo sampling of it.

use nalgebra::{Point3, Vector3};

use crate::machine::ScheduleError;
use crate::range_min::RangeMin;
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
    /// Width of the run's jerk filter, s (0 without a jerk limit).
    window_s: f64,
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
    cycle_time_s: f64,
}

/// Most servo samples one profile may produce (about 60 bytes each, 1.2 GB at the bound).
pub const MAX_SAMPLES: usize = 20_000_000;

/// Runs with at most this many stations get the jerk-limited search over the acceleration
/// share λ (short moves, where the time-optimal profile does not reach the full acceleration);
/// longer runs plan at λ = 1.
const LAMBDA_SEARCH_MAX_STATIONS: usize = 4000;

/// Plans the time-optimal speed profile over `stations` (MODEL.md §6.1).
///
/// Speed at each station is at most its cap; between stations the tangential acceleration is
/// at most the interval's limit (min_i a_i/|t_i|); the tool rests at every stop. The classic
/// forward pass (v_k+1² ≤ v_k² + 2 a Δs from the start) and backward pass (the same from the
/// end) give the largest such speed at every station, hence the least time: this is exact for
/// profiles made of constant-acceleration pieces between stations.
///
/// Jerk limit (MODEL.md §6.1): each run between stops is planned with the acceleration limits
/// scaled by λ ≤ 1 and its speed v(t) is then averaged over a sliding window
/// W = λ·max_k a_k/j_k. The filtered jerk is (a(t) − a(t−W))/W, at most λ·a/W ≤ j as long as
/// the planned acceleration never changes sign within W. The plan makes sure of that:
/// * every local minimum of the speed is a cap; the cap c of each corner and of each
///   station the plan without holds touches is extended over c·W/2 on either side
///   (c·(W + 3T)/2 at a corner), so the plan rests at that speed for W (W + 3T at a
///   corner: the filtered speed is then constant for 3T around the corner, the sampling
///   stencil of its velocity step); caps the plan without holds stays below need no hold;
/// * every local maximum that is held for less than W is cut flat at the highest level c
///   where it is held for c·W.
///
/// A trapezoid with accelerations of at least W filtered this way is exactly the 7-segment
/// S-curve, so a rest-to-rest move is time-optimal for the best λ; λ is searched on short
/// runs (golden section), λ = 1 elsewhere. Averaging keeps the path geometry exact (the
/// filter acts on s(t), not on the axes), keeps stops and dwells exact, and costs W per run.
/// On curved paths the jerk bound is tangential only (the normal jerk d(v²κ)/dt is not
/// limited).
pub fn plan(stations: &Stations) -> Profile<'_> {
    let n = stations.len();
    let s = stations.s_mm();
    let caps_mm_s: Vec<f64> = stations.cap_mm_min().iter().map(|c| c / 60.0).collect();
    let base_window_s = stations
        .interval_accel_mm_s2()
        .iter()
        .zip(stations.interval_jerk_mm_s3())
        .map(|(a, j)| a / j)
        .fold(0.0, f64::max);
    let stops = stations.stops();
    let mut planner = RunPlanner::new(stations, &caps_mm_s);

    let mut v = vec![0.0; n];
    let mut windows = Vec::with_capacity(stops.len());
    for pair in stops.windows(2) {
        let (first, last) = (pair[0].station, pair[1].station);
        let lambda = if base_window_s > 0.0 && last - first <= LAMBDA_SEARCH_MAX_STATIONS {
            planner.best_lambda(first, last, base_window_s)
        } else {
            1.0
        };
        let window_s = lambda * base_window_s;
        planner.plan_run(first, last, lambda, window_s, &mut v);
        windows.push(window_s);
    }

    // Time line: dwell at a stop, then the run to the next stop (stretched by W if filtered).
    let intervals = n.saturating_sub(1);
    let mut interval_start_s = Vec::with_capacity(intervals);
    let mut interval_dt_s = Vec::with_capacity(intervals);
    let mut interval_integral_mm_s = Vec::with_capacity(intervals);
    let mut runs = Vec::with_capacity(stops.len().saturating_sub(1));
    let mut t_s = stops[0].dwell_s;
    for (pair, &window_s) in stops.windows(2).zip(&windows) {
        let (first, last) = (pair[0].station, pair[1].station);
        let start_s = t_s;
        let mut integral_mm_s = 0.0;
        for k in first..last {
            let ds = s[k + 1] - s[k];
            let dt = 2.0 * ds / (v[k] + v[k + 1]);
            interval_start_s.push(t_s);
            interval_dt_s.push(dt);
            interval_integral_mm_s.push(integral_mm_s);
            let a = (v[k + 1] - v[k]) / dt;
            integral_mm_s += integral_over_mm_s(s[k] - s[first], v[k], a, dt);
            t_s += dt;
        }
        runs.push(Run {
            first,
            last,
            start_s,
            duration_s: t_s - start_s,
            integral_mm_s,
            window_s,
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
        cycle_time_s: t_s,
    }
}

/// Plans single runs; reuses its buffers between runs and between trials of λ.
struct RunPlanner<'a> {
    stations: &'a Stations,
    caps_mm_s: &'a [f64],
    /// Largest station spacing of the path, mm.
    ds_max_mm: f64,
    is_corner: Vec<bool>,
    trial: Vec<f64>,
}

impl<'a> RunPlanner<'a> {
    fn new(stations: &'a Stations, caps_mm_s: &'a [f64]) -> Self {
        let n = stations.len();
        let mut is_corner = vec![false; n];
        for &c in stations.corners() {
            is_corner[c] = true;
        }
        RunPlanner {
            stations,
            caps_mm_s,
            ds_max_mm: stations
                .s_mm()
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(0.0, f64::max),
            is_corner,
            trial: vec![0.0; n],
        }
    }

    /// λ in (0, 1] that minimises the run's time (planned time + W): golden section, with
    /// λ = 1 kept when nothing beats it.
    fn best_lambda(&mut self, first: usize, last: usize, base_window_s: f64) -> f64 {
        let mut trial = std::mem::take(&mut self.trial);
        let mut time = |lambda: f64| {
            let w = lambda * base_window_s;
            self.plan_run(first, last, lambda, w, &mut trial) + w
        };
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        let (mut lo, mut hi) = (0.02, 1.0);
        let mut x1 = hi - ratio * (hi - lo);
        let mut x2 = lo + ratio * (hi - lo);
        let (mut f1, mut f2) = (time(x1), time(x2));
        for _ in 0..24 {
            if f1 <= f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - ratio * (hi - lo);
                f1 = time(x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + ratio * (hi - lo);
                f2 = time(x2);
            }
        }
        let (best, best_time) = if f1 <= f2 { (x1, f1) } else { (x2, f2) };
        let at_one = time(1.0);
        self.trial = trial;
        if at_one <= best_time {
            1.0
        } else {
            best
        }
    }

    /// Plans stations `first..=last` (a run between two stops) into `v`, with the
    /// acceleration limits scaled by `lambda` and, when `window_s` > 0, the plateaus the jerk
    /// filter needs (see [`plan`]). Returns the planned (unfiltered) time, s.
    fn plan_run(
        &self,
        first: usize,
        last: usize,
        lambda: f64,
        window_s: f64,
        v: &mut [f64],
    ) -> f64 {
        let s = self.stations.s_mm();
        v[first..=last].copy_from_slice(&self.caps_mm_s[first..=last]);
        if window_s > 0.0 {
            // The plan without holds: only the caps it touches need them.
            let mut free = self.caps_mm_s[first..=last].to_vec();
            self.passes(first, lambda, &mut free);
            self.extend_caps(first, last, window_s, &free, v);
        }
        self.passes(first, lambda, &mut v[first..=last]);
        if window_s > 0.0 {
            self.cut_peaks(first, last, window_s, v);
        }
        (first..last)
            .map(|k| 2.0 * (s[k + 1] - s[k]) / (v[k] + v[k + 1]))
            .sum()
    }

    /// The forward/backward passes over stations `first..first + v.len()` (a run: rest at
    /// both ends), accelerations scaled by `lambda`: v becomes the highest speed profile
    /// under the caps it holds.
    fn passes(&self, first: usize, lambda: f64, v: &mut [f64]) {
        let s = &self.stations.s_mm()[first..first + v.len()];
        let accel = &self.stations.interval_accel_mm_s2()[first..];
        let last = v.len() - 1;
        v[0] = 0.0;
        v[last] = 0.0;
        for k in 0..last {
            let reach = (v[k] * v[k] + 2.0 * lambda * accel[k] * (s[k + 1] - s[k])).sqrt();
            v[k + 1] = v[k + 1].min(reach);
        }
        for k in (0..last).rev() {
            let reach = (v[k + 1] * v[k + 1] + 2.0 * lambda * accel[k] * (s[k + 1] - s[k])).sqrt();
            v[k] = v[k].min(reach);
        }
    }

    /// The cap c of each station that the plan without holds touches (`free`, from the run's
    /// first station), and of every corner, holds over c·W/2 + Δs_max on either side
    /// (c·(W + 3T)/2 + Δs_max at a corner): c'_k = min { c_j : |s_j − s_k| ≤ r_j, j held }.
    /// A cap the plan stays below needs no hold: holding lowers the plan, so it stays below
    /// it. n·log n through a range-minimum tree.
    fn extend_caps(&self, first: usize, last: usize, window_s: f64, free: &[f64], v: &mut [f64]) {
        let s = &self.stations.s_mm()[first..=last];
        let period_s = self.stations.machine().period_s();
        let mut tree = RangeMin::<1>::new(s.len());
        for (j, &s_j) in s.iter().enumerate() {
            let cap = self.caps_mm_s[first + j];
            if !self.is_corner[first + j] && free[j] < cap * (1.0 - 1e-9) {
                continue;
            }
            let hold_s = if self.is_corner[first + j] {
                window_s + 3.0 * period_s
            } else {
                window_s
            };
            let reach = cap * hold_s / 2.0 + self.ds_max_mm;
            let lo = s[..=j].partition_point(|&x| x < s_j - reach);
            let hi = j + s[j..].partition_point(|&x| x <= s_j + reach);
            tree.lower(lo, hi, [cap]);
        }
        for (j, vj) in v[first..=last].iter_mut().enumerate() {
            *vj = vj.min(tree.get(j)[0]);
        }
    }

    /// Cuts every local maximum of `v` on `first..=last` that is held for less than W
    /// flat at the highest level c where it is held for at least W (length ≥ c·W), but
    /// not below the higher of its two neighbouring minima.
    fn cut_peaks(&self, first: usize, last: usize, window_s: f64, v: &mut [f64]) {
        let s = self.stations.s_mm();
        let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.max(b);
        let mut k = first;
        while k < last {
            // A plateau [a, b] of equal speeds.
            let a = k;
            let mut b = k;
            while b < last && same(v[b + 1], v[a]) {
                b += 1;
            }
            let is_peak = a > first && b < last && v[a - 1] < v[a] && v[b + 1] < v[b];
            if !is_peak || s[b] - s[a] >= v[a] * window_s {
                k = b + 1;
                continue;
            }
            // Walk down both sides to the neighbouring minima.
            let mut left = a;
            while left > first && v[left - 1] <= v[left] {
                left -= 1;
            }
            let mut right = b;
            while right < last && v[right + 1] <= v[right] {
                right += 1;
            }
            let floor = v[left].max(v[right]);
            // Held length at level c: outermost stations with v ≥ c on either side
            // (v rises on left..=a and falls on b..=right).
            let held = |c: f64| {
                let l = left + v[left..=a].partition_point(|&x| x < c);
                let r = b + v[b..=right].partition_point(|&x| x >= c);
                s[r.saturating_sub(1).max(b)] - s[l.min(a)]
            };
            let (mut lo, mut hi) = (floor, v[a]);
            if held(lo) >= lo * window_s {
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if held(mid) >= mid * window_s {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
            }
            for x in &mut v[left..=right] {
                *x = x.min(lo);
            }
            k = right;
        }
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

    /// Widest jerk filter of any run, s (0 without a jerk limit).
    pub fn filter_window_s(&self) -> f64 {
        self.runs.iter().map(|r| r.window_s).fold(0.0, f64::max)
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
        time_s[CapKind::Acceleration.index()] += self.runs.iter().map(|r| r.window_s).sum::<f64>();
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
    ///
    /// More than [`MAX_SAMPLES`] samples (see [`Profile::sample_count`]) is an error,
    /// checked before allocating; so is a period that is not finite and > 0.
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
        Ok(samples)
    }

    /// Number of samples [`Profile::sample`] makes at `period_ms` (as f64: it may be
    /// astronomically large), so callers can check memory before sampling.
    pub fn sample_count(&self, period_ms: f64) -> Result<f64, ScheduleError> {
        if !(period_ms.is_finite() && period_ms > 0.0) {
            return Err(ScheduleError::InvalidMachine {
                name: "period_ms",
                value: period_ms,
            });
        }
        Ok((self.cycle_time_s / (period_ms * 1e-3)).ceil() + 1.0)
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
            Some(run)
                if run.window_s > 0.0 && t_s >= run.start_s + run.duration_s + run.window_s =>
            {
                (stations.s_mm()[run.last], 0.0)
            }
            Some(run) if run.window_s > 0.0 => {
                let w = run.window_s;
                let now = profile.run_state(run, t_s, &mut self.now);
                let lagged = profile.run_state(run, t_s - w, &mut self.lagged);
                let (s_first, s_last) = (stations.s_mm()[run.first], stations.s_mm()[run.last]);
                // The average never passes the run's end; rounding could by 1e-12 mm.
                (
                    (s_first + (now.integral_mm_s - lagged.integral_mm_s) / w).min(s_last),
                    (now.s_mm - lagged.s_mm) / w,
                )
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
