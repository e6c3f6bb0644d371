//! Verified runs (MODEL.md §6.1): the check of a run's servo samples against the axis
//! limits and the caps, and the fallbacks for a run whose samples break one (corner holds
//! restored, caps lowered or the filter widened, the plan slowed in time).

use super::profile::Profile;
use super::run_planner::{RunPlanner, LAMBDA_SEARCH_MAX_STATIONS};
use super::sample::{Sampler, ServoSample, MAX_SAMPLES};
use crate::machine::ScheduleError;
use crate::stations::Stop;

/// A stencil of servo samples whose second or third difference broke an axis' limit.
#[derive(Clone, Copy, Debug)]
pub(super) struct Violation {
    /// Arc lengths of its first and last sample, mm.
    pub(super) s_mm: (f64, f64),
    /// Highest sampled speed in it, mm/s.
    pub(super) speed_mm_s: f64,
    /// Its difference over the limit.
    pub(super) ratio: f64,
    /// Whether its newest sample's feed is over its cap.
    pub(super) over_cap: bool,
}

/// Which plan of a run [`RunPlanner::verified_run`] kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Verified {
    /// The candidate λ of this index.
    Candidate(usize),
    /// The first candidate with the full corner holds restored around the failing
    /// stencils this many times.
    Restored(usize),
    /// The first candidate repaired (filter widened or caps lowered) this many times.
    Repaired(usize),
    /// That plan slowed in time by σ, after this many tries.
    Slowed {
        /// Tries.
        tries: usize,
        /// σ.
        slow: f64,
    },
}

// The fallbacks of a run whose samples break a limit ([`RunPlanner::verified_run`]), in
// order: (1) the full corner holds restored, (2) the filter widened or the caps lowered,
// (3) the plan slowed in time. Their tries and steps:

/// Tries of the first fallback (full corner holds restored where samples break a limit).
pub(super) const RESTORE_MAX_TRIES: usize = 4;
/// Tries of the second fallback (caps lowered where samples break a limit).
pub(super) const REPAIR_MAX_TRIES: usize = 8;

/// The second fallback divides the filter's width by this (its jerk then at most 0.98·j) where more
/// than [`FEW_VIOLATIONS`] stencils break a limit, and lowers the caps around them where
/// no more do.
pub(super) const WIDEN: f64 = 0.98;
/// See [`WIDEN`].
pub(super) const FEW_VIOLATIONS: usize = 3;
/// The slowed fallback multiplies σ by at most this each try (and the first fallback a
/// cap over the speed of the samples that break a limit).
pub(super) const SLOW_STEP: f64 = 0.95;
/// ... and by this over the worst ratio of a sampled difference to its limit, if that is
/// less than [`SLOW_STEP`].
pub(super) const SLOW_MARGIN: f64 = 0.99;
/// Guard on the slowed fallback's tries: σ = 0.95^300 ≈ 2·10⁻⁷ (MODEL.md §6.1 argues that
/// σ ≤ 1/K verifies, K the run's own bound). A run still unverified then makes the
/// profile refuse to be sampled ([`ScheduleError::UnverifiedRun`]).
pub(super) const SLOW_MAX_TRIES: usize = 300;

/// A run [`RunPlanner::verified_run`] planned into the profile.
#[derive(Clone, Copy, Debug)]
pub(super) struct VerifiedRun {
    /// When its planned motion reaches the run's last stop, s.
    pub(super) end_s: f64,
    /// Which plan was kept.
    pub(super) verified: Verified,
    /// The λ the kept plan was planned at.
    pub(super) lambda: f64,
    /// The kept plan's filter width W, s.
    pub(super) window_s: f64,
}

impl<'a> RunPlanner<'a> {
    /// Plans the run between the stops `stops` into `profile` (appended, leaving at the
    /// profile's current end) so that its servo samples keep every axis' limits
    /// ([`Profile::last_run_axis_ratio`]; MODEL.md §6.1): the first of `candidates` (values
    /// of λ) that verifies; else the first candidate with its caps lowered around the
    /// samples that break a limit, up to `repair_tries` times; else that plan slowed in time
    /// by σ, σ lowered each try, after a rest that keeps the samples' stencils off the run
    /// before. `tries` = (repairs, slowed tries) at most. Returns when the planned motion
    /// reaches the run's last stop, s, which plan was kept and its (λ, W). A run that still breaks a
    /// limit after the last slowed try is kept, and marks the profile unverified: its
    /// samples are refused ([`ScheduleError::UnverifiedRun`]).
    pub(super) fn verified_run(
        &mut self,
        profile: &mut Profile<'_>,
        stops: (Stop, Stop),
        base_window_s: f64,
        candidates: &[f64],
        (repair_tries, slow_tries): (usize, usize),
    ) -> VerifiedRun {
        let (first, last) = (stops.0.station, stops.1.station);
        let start_s = profile.cycle_time_s;
        let runs_before = profile.runs.len();
        // Plans the run into the profile (replacing a trial), returns its end and ratio.
        let plan = |planner: &Self,
                    profile: &mut Profile<'_>,
                    (lambda, window_s, slow, pause_s): (f64, f64, f64, f64),
                    violations: Option<&mut Vec<Violation>>| {
            if profile.runs.len() > runs_before {
                profile.pop_run();
            }
            planner.plan_run(first, last, lambda, window_s, slow, &mut profile.speed_mm_s);
            let end_s = profile.push_run(first, last, start_s + pause_s, window_s, pause_s);
            (end_s, profile.last_run_axis_ratio(violations))
        };
        // Where the stencils of the first candidate break a limit.
        let mut violations = Vec::new();
        // A long run's candidates are its grid of λ (see [`plan`]): each gets the restores.
        let restore_every = last - first > LAMBDA_SEARCH_MAX_STATIONS;
        let mut later = Vec::new();
        for (index, &lambda) in candidates.iter().enumerate() {
            let found = if index == 0 {
                &mut violations
            } else {
                later.clear();
                &mut later
            };
            let (end_s, ratio) = plan(
                self,
                profile,
                (lambda, lambda * base_window_s, 1.0, 0.0),
                Some(&mut *found),
            );
            if ratio <= 1.0 {
                return VerifiedRun {
                    end_s,
                    verified: Verified::Candidate(index),
                    lambda,
                    window_s: lambda * base_window_s,
                };
            }
            if index > 0 && !restore_every {
                continue;
            }
            // Fallback 1, on the first candidate (on every one of a long run): the corners
            // near the stencils that break a limit get the 3T of their hold back (constant
            // speed around the corner).
            for restores in 1..=RESTORE_MAX_TRIES.min(repair_tries) {
                if !self.restore_holds(first, last, lambda * base_window_s, found) {
                    // Every corner near them held in full: a few stencils left get their
                    // caps lowered (as the repairs below do), more end the restores.
                    if found.len() > FEW_VIOLATIONS {
                        break;
                    }
                    self.lower_caps(first, last, found);
                }
                found.clear();
                let (end_s, ratio) = plan(
                    self,
                    profile,
                    (lambda, lambda * base_window_s, 1.0, 0.0),
                    Some(&mut *found),
                );
                if ratio <= 1.0 {
                    return VerifiedRun {
                        end_s,
                        verified: Verified::Restored(restores),
                        lambda,
                        window_s: lambda * base_window_s,
                    };
                }
            }
        }
        let lambda = candidates[0];
        let mut window_s = lambda * base_window_s;
        // Fallback 2, from the first candidate: where many stencils break a limit (the
        // filter's jerk meeting corners along the run), widen the filter by 2 % (a jerk
        // margin); where a few do, lower the caps around them.
        for repairs in 1..=repair_tries {
            if violations.len() > FEW_VIOLATIONS {
                window_s /= WIDEN;
            } else {
                self.lower_caps(first, last, &violations);
            }
            violations.clear();
            let (end_s, ratio) = plan(
                self,
                profile,
                (lambda, window_s, 1.0, 0.0),
                Some(&mut violations),
            );
            if ratio <= 1.0 {
                return VerifiedRun {
                    end_s,
                    verified: Verified::Repaired(repairs),
                    lambda,
                    window_s,
                };
            }
        }
        // Fallback 3: that plan slowed in time by σ.
        let pause_s = if runs_before > 0 {
            (3.0 * self.stations.machine().period_s() - stops.0.dwell_s).max(0.0)
        } else {
            0.0
        };
        let mut slow = 1.0;
        for tries in 1.. {
            let (end_s, ratio) = plan(
                self,
                profile,
                (lambda, window_s / slow, slow, pause_s),
                None,
            );
            if ratio <= 1.0 || tries >= slow_tries {
                if ratio > 1.0 && profile.unverified.is_none() {
                    profile.unverified = Some(ScheduleError::UnverifiedRun {
                        first,
                        last,
                        ratio,
                        tries,
                        slow,
                    });
                }
                return VerifiedRun {
                    end_s,
                    verified: Verified::Slowed { tries, slow },
                    lambda,
                    window_s: window_s / slow,
                };
            }
            slow *= (SLOW_MARGIN / ratio).min(SLOW_STEP);
        }
        unreachable!("the loop returns")
    }

    /// Gives every corner of the run `first..=last` within reach of a stencil that broke a
    /// limit its full hold c·(W + 3T)/2 back: those within the stencil's highest speed
    /// times (W + 3T), plus the largest station spacing, of its samples (MODEL.md §6.1,
    /// "Local corner holds"); where the stencil's newest sample is over its cap, every
    /// station there is also marked plain (no slow dip or uncut peak; MODEL.md §6.1, "Slow
    /// dips and peaks"). Returns whether any station changed.
    pub(super) fn restore_holds(
        &mut self,
        first: usize,
        last: usize,
        window_s: f64,
        violations: &[Violation],
    ) -> bool {
        let s = &self.stations.s_mm()[first..=last];
        let period_s = self.stations.machine().period_s();
        let mut changed = false;
        for violation in violations {
            let reach = violation.speed_mm_s * (window_s + 3.0 * period_s) + self.ds_max_mm;
            let lo = s.partition_point(|&x| x < violation.s_mm.0 - reach);
            let hi = s.partition_point(|&x| x <= violation.s_mm.1 + reach);
            for k in first + lo..first + hi {
                if self.is_corner[k] && !self.full_hold[k] {
                    self.full_hold[k] = true;
                    changed = true;
                }
                if violation.over_cap && !self.plain[k] {
                    self.plain[k] = true;
                    changed = true;
                }
            }
        }
        changed
    }

    /// Lowers the caps of the run `first..=last` around every stencil that broke a limit:
    /// each station within one period's travel of the stencil's samples gets at most the
    /// stencil's highest sampled speed times min(0.95, 0.99/ratio). The plan then touches
    /// the lowered cap, so it holds it flat there (no filter jerk) and the geometric part
    /// of the sampled differences (v²κ, v·Δt/T, ...) falls with the speed.
    pub(super) fn lower_caps(&mut self, first: usize, last: usize, violations: &[Violation]) {
        let s = &self.stations.s_mm()[first..=last];
        let period_s = self.stations.machine().period_s();
        for violation in violations {
            let target = violation.speed_mm_s * (SLOW_MARGIN / violation.ratio).min(SLOW_STEP);
            if target <= 0.0 {
                continue;
            }
            let reach = violation.speed_mm_s * period_s;
            let lo = s.partition_point(|&x| x < violation.s_mm.0 - reach);
            let hi = s.partition_point(|&x| x <= violation.s_mm.1 + reach);
            for cap in &mut self.caps_mm_s[first + lo..first + hi] {
                *cap = cap.min(target);
            }
        }
    }
}

impl<'a> Profile<'a> {
    /// Verification of the last run appended (MODEL.md §6.1): the largest ratio, over the
    /// servo samples every machine period whose stencil reaches into the run's motion, of
    /// a per-axis second difference |P(t+T) − 2P(t) + P(t−T)|/T² to the axis' acceleration
    /// limit and (with a jerk limit) of a third difference
    /// |P(t+2T) − 3P(t+T) + 3P(t) − P(t−T)|/T³ to its jerk limit, each limit with the
    /// tests' tolerance (1 + 10⁻⁶)·limit + 10⁻⁶, and of every sample's feed to the larger
    /// cap of the two stations around it (with (1 + 10⁻⁹)). The samples are those [`Profile::sample`]
    /// makes, bit for bit: the runs before are as planned, and after the run the tool rests
    /// (the run after checks the stencils that reach into it). 0 when nothing moves, and
    /// when the run ends past [`MAX_SAMPLES`] periods: [`Profile::sample`] refuses such a
    /// profile, so its samples are never made (and checking them would take hours).
    pub(super) fn last_run_axis_ratio(&self, mut violations: Option<&mut Vec<Violation>>) -> f64 {
        let Some(run) = self.runs.last() else {
            return 0.0;
        };
        let machine = self.stations.machine();
        let period_s = machine.period_s();
        let tolerance = |limit: f64| limit * (1.0 + 1e-6) + 1e-6;
        let accel = machine.accel_mm_s2.map(tolerance);
        let jerk = machine.jerk_mm_s3.map(|j| j.map(tolerance));
        let moving_from_s = run.switch_s;
        // A section that joins the next at speed is taken until the next one's switch.
        let moving_to_s = run.start_s
            + run.duration_s
            + if self.speed_mm_s[run.last] > 0.0 {
                run.window_s / 2.0
            } else {
                run.window_s
            };
        if !(moving_to_s / period_s <= MAX_SAMPLES as f64) {
            return 0.0;
        }
        let lo = ((moving_from_s / period_s).floor() - 3.0).max(0.0) as usize;
        // A section joined at speed is checked up to the next section's switch (the
        // samples after it are the next section's, which checks every stencil reaching
        // into them); a run ending at a stop to 3 periods past its end (rest after it).
        let hi = if self.speed_mm_s[run.last] > 0.0 {
            ((moving_to_s / period_s).ceil() as usize).saturating_sub(1)
        } else {
            (moving_to_s / period_s).ceil() as usize + 3
        };
        let mut sampler = Sampler::starting_at(self, lo as f64 * period_s);
        // The last four samples, oldest first.
        let mut p = [sampler.at(lo as f64 * period_s); 4];
        // Caps, as the tests read them: a sample's feed is at or under the larger cap of
        // the two stations around it (the first station past it, clamped to 1..n).
        let (s, caps) = (self.stations.s_mm(), self.stations.cap_mm_min());
        let mut past = s.partition_point(|&x| x <= p[3].s_mm);
        let mut cap_ratio = |sample: &ServoSample| {
            while past < s.len() && s[past] <= sample.s_mm {
                past += 1;
            }
            let k = past.clamp(1, s.len().max(2) - 1);
            let cap = caps[k - 1].max(caps[k]);
            sample.feed_mm_min / (cap * (1.0 + 1e-9))
        };
        let mut worst: f64 = cap_ratio(&p[3]);
        for (count, j) in (lo + 1..=hi).enumerate() {
            p.rotate_left(1);
            p[3] = sampler.at(j as f64 * period_s);
            let over = cap_ratio(&p[3]);
            let mut ratio: f64 = over;
            for i in 0..3 {
                let x = p.map(|sample| sample.pos[i]);
                if count >= 1 {
                    let second = (x[3] - 2.0 * x[2] + x[1]) / period_s.powi(2);
                    ratio = ratio.max(second.abs() / accel[i]);
                }
                if let (Some(jerk), true) = (jerk, count >= 2) {
                    let third = (x[3] - 3.0 * x[2] + 3.0 * x[1] - x[0]) / period_s.powi(3);
                    ratio = ratio.max(third.abs() / jerk[i]);
                }
            }
            if ratio > 1.0 {
                if let Some(violations) = violations.as_deref_mut() {
                    violations.push(Violation {
                        s_mm: (p[0].s_mm, p[3].s_mm),
                        speed_mm_s: p.iter().map(|x| x.feed_mm_min / 60.0).fold(0.0, f64::max),
                        ratio,
                        over_cap: over > 1.0,
                    });
                }
            }
            worst = worst.max(ratio);
        }
        worst
    }
}
