//! [`RunPlanner`]: one run between stops planned at (λ, W, σ): the forward and backward
//! passes, the holds and cut peaks the jerk filter needs (with the slow dips' and peaks'
//! exceptions), and the choice of λ.

use super::profile::FILTER_NEEDS_JERK;
use crate::direct;
use crate::kinematics::{interval_accel_mm_s2, interval_time_s};
use crate::range_min::RangeMin;
use crate::stations::Stations;

/// Runs with at most this many stations get the jerk-limited search over the acceleration
/// share λ (short moves, where the time-optimal profile does not reach the full acceleration);
/// longer runs plan at λ = 1.
pub(super) const LAMBDA_SEARCH_MAX_STATIONS: usize = 4000;
/// The values of λ planned on longer runs, tried by the time of their plans.
pub(super) const LAMBDA_GRID: [f64; 5] = [1.0, 0.85, 0.7, 0.55, 0.4];
/// Runs with more stations than this plan at λ = 1 only: each λ tried plans and checks the
/// whole run again (the 1 M-block raster's run of 3 M stations took 10.9 s of plan CPU
/// with the grid against about 1.8 s, for the same cycle).
pub(super) const LAMBDA_GRID_MAX_STATIONS: usize = 500_000;

/// [`RunPlanner::sectioned`] makes the values of the sections after the one it reaches
/// ahead, in parallel, up to about this many stations at a time (the memory the values
/// ahead hold: their speeds shaped by linear programs, 24 B a station at most).
pub(super) const AHEAD_STATIONS: usize = 1 << 15;

/// Plans single runs; reuses its buffers between runs and between trials of λ.
pub(super) struct RunPlanner<'a> {
    pub(super) stations: &'a Stations,
    /// The stations' caps, mm/s; lowered where a run's samples broke a limit.
    pub(super) caps_mm_s: Vec<f64>,
    /// Largest station spacing of the path, mm.
    pub(super) ds_max_mm: f64,
    pub(super) is_corner: Vec<bool>,
    /// Corners held over c·(W + 3T)/2 (the others over c·W/2, as touched caps): set where
    /// a run's samples broke a limit (MODEL.md §6.1, "Local corner holds").
    pub(super) full_hold: Vec<bool>,
    /// Stations planned by the plain rules (a hold at every held cap, every short peak
    /// cut), not by the slow dips' and peaks' exceptions: set where a run's sample near
    /// them was over its cap (MODEL.md §6.1, "Slow dips and peaks").
    pub(super) plain: Vec<bool>,
    /// A plan tried beside the profile's (λ searched, sections): made at the first
    /// ([`RunPlanner::take_trial`]), none without a jerk limit (8 B a station saved).
    pub(super) trial: Vec<f64>,
    /// The gaps of a section shaped directly and followed exactly.
    pub(super) gaps: Vec<direct::Gap>,
    /// How many stations of sections [`RunPlanner::sectioned`] makes the values of ahead,
    /// in parallel ([`AHEAD_STATIONS`]).
    pub(super) ahead_stations: usize,
}

impl<'a> RunPlanner<'a> {
    pub(super) fn new(stations: &'a Stations) -> Self {
        let caps_mm_s = stations.cap_mm_min().iter().map(|c| c / 60.0).collect();
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
            full_hold: vec![false; n],
            plain: vec![false; n],
            trial: Vec::new(),
            gaps: Vec::new(),
            ahead_stations: AHEAD_STATIONS,
        }
    }

    /// The trial plan, one speed a station (0 until planned), taken for a trial: given
    /// back to `self.trial` after it.
    pub(super) fn take_trial(&mut self) -> Vec<f64> {
        let mut trial = std::mem::take(&mut self.trial);
        trial.resize(self.stations.len(), 0.0);
        trial
    }

    /// The candidate λ values of a run too long for the search: those of [`LAMBDA_GRID`],
    /// by the time of their plans (planned time + W, before any check), quickest first.
    pub(super) fn lambda_grid(
        &mut self,
        first: usize,
        last: usize,
        base_window_s: f64,
        candidates: &mut Vec<f64>,
    ) {
        let mut trial = self.take_trial();
        let mut timed: Vec<(f64, f64)> = LAMBDA_GRID
            .iter()
            .map(|&lambda| {
                let w = lambda * base_window_s;
                (
                    self.plan_run(first, last, lambda, w, 1.0, &mut trial) + w,
                    lambda,
                )
            })
            .collect();
        self.trial = trial;
        timed.sort_by(|a, b| a.0.total_cmp(&b.0));
        candidates.extend(timed.iter().map(|&(_, lambda)| lambda));
    }

    /// The values of λ in (0, 1] to try on a run, best first: the one that minimises the run's
    /// time (planned time + W) by golden section, λ = 1 when nothing beats it; then every
    /// other λ the search evaluated, by run time; λ = 1 among them.
    pub(super) fn lambda_candidates(
        &mut self,
        first: usize,
        last: usize,
        base_window_s: f64,
        candidates: &mut Vec<f64>,
    ) {
        let mut trial = self.take_trial();
        let mut evaluated: Vec<(f64, f64)> = Vec::with_capacity(28);
        let mut time = |lambda: f64| {
            let w = lambda * base_window_s;
            let t = self.plan_run(first, last, lambda, w, 1.0, &mut trial) + w;
            evaluated.push((t, lambda));
            t
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
        let chosen = if at_one <= best_time { 1.0 } else { best };
        evaluated.sort_by(|a, b| a.0.total_cmp(&b.0));
        candidates.push(chosen);
        for (_, lambda) in evaluated {
            if !candidates.contains(&lambda) {
                candidates.push(lambda);
            }
        }
    }

    /// Plans stations `first..=last` (a run between two stops) into `v`, with the
    /// acceleration limits scaled by `lambda` and, when `window_s` > 0, the plateaus the jerk
    /// filter needs (see [`plan`](super::plan)). Returns the planned (unfiltered) time, s.
    ///
    /// `slow` = σ ≤ 1 slows the run in time: caps σ·c, accelerations σ²·λ·a, the corners'
    /// 3T of hold 3T/σ; with `window_s` = W/σ the planned and filtered motions are the σ = 1
    /// ones run σ times slower (speeds σ·v, accelerations σ², jerks σ³).
    pub(super) fn plan_run(
        &self,
        first: usize,
        last: usize,
        lambda: f64,
        window_s: f64,
        slow: f64,
        v: &mut [f64],
    ) -> f64 {
        let s = &self.stations.s_mm()[first..=last];
        let v = &mut v[first..=last];
        for (vk, cap) in v.iter_mut().zip(&self.caps_mm_s[first..=last]) {
            *vk = cap * slow;
        }
        let lambda = lambda * slow * slow;
        if window_s > 0.0 {
            // The plan without holds: only the caps it touches need them.
            let mut free = v.to_vec();
            self.passes(first, lambda, &mut free);
            self.extend_caps(first, last, (lambda, window_s, slow), &free, v, false);
        }
        self.passes(first, lambda, v);
        if window_s > 0.0 {
            self.cut_peaks(first, last, window_s, slow, v);
        }
        (0..last - first).map(|k| interval_time_s(s, v, k)).sum()
    }

    /// The forward/backward passes over stations `first..first + v.len()` (a run: rest at
    /// both ends), accelerations scaled by `lambda`: v becomes the highest speed profile
    /// under the caps it holds.
    pub(super) fn passes(&self, first: usize, lambda: f64, v: &mut [f64]) {
        self.passes_between(first, lambda, v, (0.0, 0.0));
    }

    /// [`RunPlanner::passes`] with the speeds `ends` at the first and last station
    /// instead of rest (a section, [`RunPlanner::sectioned`]).
    pub(super) fn passes_between(
        &self,
        first: usize,
        lambda: f64,
        v: &mut [f64],
        ends: (f64, f64),
    ) {
        let s = &self.stations.s_mm()[first..first + v.len()];
        let accel = &self.stations.interval_accel_mm_s2()[first..];
        let last = v.len() - 1;
        v[0] = ends.0;
        v[last] = ends.1;
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
    /// (c·(W + 3T)/2 + Δs_max at a corner whose full hold was restored):
    /// c'_k = min { c_j : |s_j − s_k| ≤ r_j, j held }, as a cap on `v` (the speeds of the
    /// stations `first..=last`, from `first`).
    /// A cap the plan stays below needs no hold: holding lowers the plan, so it stays below
    /// it. n·log n through a range-minimum tree.
    ///
    /// A slow dip (MODEL.md §6.1, "Slow dips and peaks"): where the accelerations A the
    /// plan may use over the hold's stations (λ·a_k, `lambda` = λ) are so small that
    /// 2A ≤ j·W/2 (j the least jerk limit there), the filter's jerk stays within j/2 even
    /// though the plan's acceleration changes sign within W at the cap; the cap is then
    /// lowered at its station alone to c − 1.1·A·W/4 (a V whose average over W, centred
    /// on the station, is c − 0.1·A·W/4) instead of held, when that V crosses the hold's
    /// stations in less time than the hold does (at a slow cap the hold takes whole
    /// station intervals of Δs/c). Stations marked plain (a sample near them was over its
    /// cap) are held.
    pub(super) fn extend_caps(
        &self,
        first: usize,
        last: usize,
        (lambda, window_s, slow): (f64, f64, f64),
        free: &[f64],
        v: &mut [f64],
        ends_held: bool,
    ) {
        let s = &self.stations.s_mm()[first..=last];
        let accel = &self.stations.interval_accel_mm_s2()[first..last];
        let jerk = &self
            .stations
            .interval_jerk_mm_s3()
            .expect(FILTER_NEEDS_JERK)[first..last];
        let period_s = self.stations.machine().period_s() / slow;
        let mut tree = RangeMin::<1>::new(s.len());
        for (j, &s_j) in s.iter().enumerate() {
            let cap = self.caps_mm_s[first + j] * slow;
            // A section's ends at speed are held caps (never slow dips).
            let end = ends_held && (j == 0 || j + 1 == s.len()) && free[j] > 0.0;
            if !end && !self.is_corner[first + j] && free[j] < cap * (1.0 - 1e-9) {
                continue;
            }
            let hold_s = if self.full_hold[first + j] {
                window_s + 3.0 * period_s
            } else {
                window_s
            };
            let reach = cap * hold_s / 2.0 + self.ds_max_mm;
            let lo = s[..=j].partition_point(|&x| x < s_j - reach);
            let hi = j + s[j..].partition_point(|&x| x <= s_j + reach);
            if !end && !self.plain[first + j] && hi - lo >= 2 {
                if let Some(dip) = slow_dip_mm_s(
                    cap,
                    (s_j - s[lo], s[hi - 1] - s_j),
                    (&accel[lo..hi - 1], &jerk[lo..hi - 1]),
                    (lambda, window_s, slow),
                ) {
                    tree.lower(j, j + 1, [dip]);
                    continue;
                }
            }
            tree.lower(lo, hi, [cap]);
        }
        debug_assert_eq!(v.len(), s.len());
        for (vj, [limit]) in v.iter_mut().zip(tree.into_minima()) {
            *vj = vj.min(limit);
        }
    }

    /// Cuts every local maximum of `v` (the speeds of the stations `first..=last`, from
    /// `first`) that is held for less than W
    /// flat at the highest level c where it is held for at least W (length ≥ c·W), but
    /// not below the higher of its two neighbouring minima.
    ///
    /// A slow peak (MODEL.md §6.1, "Slow dips and peaks") is not cut: where the plan's
    /// largest acceleration A1 on the rising side and deceleration A2 on the falling side
    /// (to the neighbouring minima) have A1 + A2 ≤ j·W/2, the filter's jerk across the
    /// peak, at most (A1 + A2)/W, is within j/2 (the least jerk limit there; `slow` = σ
    /// scales it by σ³, so that the slowed plan is the σ = 1 plan run σ times slower),
    /// unless a station of the peak is marked plain.
    pub(super) fn cut_peaks(
        &self,
        first: usize,
        last: usize,
        window_s: f64,
        slow: f64,
        v: &mut [f64],
    ) {
        let s = &self.stations.s_mm()[first..=last];
        let jerk = &self
            .stations
            .interval_jerk_mm_s3()
            .expect(FILTER_NEEDS_JERK)[first..last];
        let plain = &self.plain[first..=last];
        let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.max(b);
        // From here on, stations are counted from `first`.
        let (first, last) = (0, last - first);
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
            let plan_accel = |k: usize| interval_accel_mm_s2(s, v, k);
            let rising = (left..a).map(plan_accel).fold(0.0f64, f64::max);
            let falling = (b..right).map(|k| -plan_accel(k)).fold(0.0f64, f64::max);
            let j_min = (left..right).map(|k| jerk[k]).fold(f64::INFINITY, f64::min);
            if rising + falling <= JERK_SHARE * j_min * slow.powi(3) * window_s
                && !plain[left..=right].contains(&true)
            {
                k = b + 1;
                continue;
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

/// Share of the jerk limit that a slow dip's or an uncut peak's filter jerk may take
/// (MODEL.md §6.1, "Slow dips and peaks"): the other half is a corner's, whose velocity
/// step shows as up to j/2 in the third differences (the corner rule).
pub(super) const JERK_SHARE: f64 = 0.5;

/// A slow dip's lowered cap (see [`RunPlanner::extend_caps`]), mm/s, or `None` where the
/// station is to be held: the cap `cap` (mm/s) of a station whose hold reaches `reach_mm`
/// before and after it over intervals of tangential acceleration and jerk limits
/// `limits`, planned with (λ, W, σ) = `plan`. A = λ·max a_k over those intervals; a dip
/// needs 2A ≤ j·σ³·W/2 (j their least jerk limit), a lowered cap c − 1.1·A·W/4 > 0, and a
/// V from it at A crossing the hold's reach in less time than the hold at c does.
pub(super) fn slow_dip_mm_s(
    cap: f64,
    reach_mm: (f64, f64),
    (accel, jerk): (&[f64], &[f64]),
    (lambda, window_s, slow): (f64, f64, f64),
) -> Option<f64> {
    let a = lambda * accel.iter().fold(0.0f64, |m, &x| m.max(x));
    let j = jerk.iter().fold(f64::INFINITY, |m, &x| m.min(x)) * slow.powi(3);
    let dip = cap - 1.1 * a * window_s / 4.0;
    if !(a > 0.0 && 2.0 * a <= JERK_SHARE * j * window_s && dip > 0.0) {
        return None;
    }
    let v_time = |d: f64| ((dip * dip + 2.0 * a * d).sqrt() - dip) / a;
    let (before, after) = reach_mm;
    (v_time(before) + v_time(after) < (before + after) / cap).then_some(dip)
}
