//! A section's values (MODEL.md §6.1, "Sections"): planned with holds and a filter,
//! shaped directly, followed exactly, or shaped by sequential linear programs.

use super::profile::FILTER_NEEDS_JERK;
use super::run_planner::RunPlanner;
use crate::direct;
use crate::kinematics::interval_time_s;
use crate::slp;

/// The plan `v` stays at the held end speed `c` over the stations from `end` on (in the
/// order `stations` gives) until they are c·W/2 from it (MODEL.md §6.1, "Sections"): the
/// filtered motion is then at `end`'s station with speed `c` when the next section takes
/// over.
pub(super) fn held_at(
    v: &[f64],
    s: &[f64],
    stations: impl IntoIterator<Item = usize>,
    end: usize,
    c: f64,
    window_s: f64,
) -> bool {
    let reach = c * window_s / 2.0;
    for k in stations {
        if v[k] != c {
            return false;
        }
        if (s[k] - s[end]).abs() >= reach {
            break;
        }
    }
    true
}

/// The values of λ each section of a run tries (MODEL.md §6.1, "Sections"): 0.8^k,
/// k = 0..14, from 1 to 0.055.
pub(super) const SECTION_GRID: [f64; 14] = [
    1.0,
    0.8,
    0.64,
    0.512,
    0.4096,
    0.32768,
    0.262144,
    0.2097152,
    0.16777216,
    0.134217728,
    0.1073741824,
    0.08589934592,
    0.068719476736,
    0.0549755813888,
];

/// The shares σ of the jerk limit a section shaped directly is tried at, each with a
/// filter of at least σ/(1 − σ) times the plan's longest station interval in time, so
/// that the filtered jerk is at most the limit (MODEL.md §6.1, "Direct sections").
pub(super) const DIRECT_SHARES: [f64; 3] = [0.5, 0.75, 0.9];
/// The shares σ of the jerk limit a section shaped directly and followed exactly, without
/// a filter, is tried at (MODEL.md §6.1, "Exact direct sections"): its motion's jerk is
/// within σ·J at every instant, so σ = 1 keeps the tangential limit; the lower shares
/// leave room for the path's curvature in the sampled axis differences.
pub(super) const EXACT_SHARES: [f64; 3] = [1.0, 0.9, 0.75];

/// How a section's value is planned ([`RunPlanner::sectioned`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Shape {
    /// The passes with holds and cut peaks, then the filter ([`RunPlanner::plan_section`]).
    Filtered,
    /// Shaped directly, then a filter ([`RunPlanner::direct_window`]).
    Direct,
    /// Shaped directly and followed exactly, without a filter.
    Exact,
    /// As `Exact`, with the dips widened over the envelope they can follow (MODEL.md §6.1,
    /// "Dips that follow the envelope").
    Following,
    /// Shaped by sequential linear programs and followed exactly, without a filter
    /// ([`slp::shape`], [`slp::Piece`]; MODEL.md §6.1, "Sections by linear programs"): at
    /// the first of [`EXACT_SHARES`], and at the next ones where its samples do not verify.
    Programmed,
}

/// A section is also shaped by linear programs ([`Shape::Programmed`]) only where its
/// quickest value so far takes more than this over the acceleration floor of its stations
/// (the passes at the full acceleration between its end speeds), s ...
pub(super) const PROGRAMMED_EXCESS_MIN_S: f64 = 0.01;
/// ... and it has at most this many stations.
pub(super) const PROGRAMMED_MAX_STATIONS: usize = 1_000;

/// Time of a plan `v` over stations `s` that follows `gaps` (counted from `s[0]`) exactly
/// and has constant accelerations elsewhere, s (MODEL.md §6.1, "Exact direct sections").
pub(super) fn exact_time_s(s: &[f64], v: &[f64], gaps: &[direct::Gap]) -> f64 {
    let inside: f64 = gaps.iter().map(|g| g.time_at_s(s[g.k] - s[g.i])).sum();
    let mut outside = 0.0;
    let mut next = gaps.iter().peekable();
    for k in 0..s.len() - 1 {
        while next.peek().is_some_and(|g| g.k <= k) {
            next.next();
        }
        if next.peek().is_some_and(|g| g.i <= k) {
            continue;
        }
        outside += interval_time_s(s, v, k);
    }
    inside + outside
}

/// The narrowest filter a section shaped directly starts from, s.
pub(super) const DIRECT_WINDOW_MIN_S: f64 = 1e-3;

/// Intervals whose acceleration limit is at most this times the period T times their jerk
/// limit as shaped (σ·j: a ≤ σ·j·T/3, slow corners' intervals) widen a dip of a section
/// shaped directly ([`direct::shape`]'s `slow_share`).
pub(super) const DIRECT_SLOW_PERIODS: f64 = 1.0 / 3.0;

/// A section's values before any is verified ([`RunPlanner::section_values`]): a function
/// of its stations, their caps and the speeds at its ends alone, so the sections of a run
/// can be made in parallel ([`RunPlanner::sectioned`]).
#[derive(Default)]
pub(super) struct SectionValues {
    /// Its values, quickest first.
    pub(super) timed: Vec<SectionValue>,
    /// The linear programs' first iterate: the quickest exact value's speeds, else the
    /// floor's passes (empty where `timed` holds no value shaped by them).
    pub(super) seed: Vec<f64>,
    /// The speeds and accelerations shaped by linear programs at the first of
    /// [`EXACT_SHARES`] (empty where `timed` holds no value shaped by them).
    pub(super) programmed: Programmed,
}

/// One value of a section ([`SectionValues`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct SectionValue {
    /// Its time, s.
    pub(super) time_s: f64,
    /// λ (a plan with holds) or σ (a share of the jerk limit) it is planned at.
    pub(super) value: f64,
    /// Its filter's width W, s (0: followed exactly).
    pub(super) window_s: f64,
    /// How it is shaped.
    pub(super) shape: Shape,
}

/// A section's speeds and accelerations at its stations as shaped by linear programs
/// ([`RunPlanner::plan_programmed`]).
#[derive(Default)]
pub(super) struct Programmed {
    /// Speeds, mm/s.
    pub(super) speed_mm_s: Vec<f64>,
    /// Accelerations, mm/s².
    pub(super) accel_mm_s2: Vec<f64>,
}

/// Buffers [`RunPlanner::section_values`] plans into: one speed a station of the section,
/// and the gaps of a section followed exactly.
#[derive(Default)]
pub(super) struct SectionScratch {
    pub(super) trial: Vec<f64>,
    pub(super) gaps: Vec<direct::Gap>,
}

impl<'a> RunPlanner<'a> {
    /// Plans the section `first..=last` of a run into `v` (its stations' speeds, from
    /// `first`; MODEL.md §6.1, "Sections"): as
    /// [`RunPlanner::plan_run`] at σ = 1, but from the speed `ends.0` at `first` to
    /// `ends.1` at `last` (0: a stop), each end at speed a held cap (c·W/2 of hold into the
    /// section, never a slow dip). Returns the planned time, s, or `None` where the plan is
    /// not flat at the end's speed over c·W/2 from a flying end: the filtered motion of
    /// the section is then not at that end's station with the end's speed when the next
    /// section takes over.
    pub(super) fn plan_section(
        &self,
        (first, last): (usize, usize),
        (lambda, window_s): (f64, f64),
        ends: (f64, f64),
        v: &mut [f64],
    ) -> Option<f64> {
        let s = &self.stations.s_mm()[first..=last];
        debug_assert_eq!(v.len(), s.len());
        v.copy_from_slice(&self.caps_mm_s[first..=last]);
        let mut free = v.to_vec();
        self.passes_between(first, lambda, &mut free, ends);
        self.extend_caps(first, last, (lambda, window_s, 1.0), &free, v, true);
        self.passes_between(first, lambda, v, ends);
        self.cut_peaks(first, last, window_s, 1.0, v);
        let n = last - first;
        if ends.0 > 0.0 && !held_at(v, s, 1..=n, 0, ends.0, window_s) {
            return None;
        }
        if ends.1 > 0.0 && !held_at(v, s, (0..n).rev(), n, ends.1, window_s) {
            return None;
        }
        Some((0..n).map(|k| interval_time_s(s, v, k)).sum())
    }

    /// Each interval's jerk limit of the section `first..=last` times `share`, mm/s³.
    pub(super) fn shared_jerk(&self, (first, last): (usize, usize), share: f64) -> Vec<f64> {
        self.stations
            .interval_jerk_mm_s3()
            .expect(FILTER_NEEDS_JERK)[first..last]
            .iter()
            .map(|j| j * share)
            .collect()
    }

    /// The caps of the section `first..=last` for the plan of a filter of width `window_s`
    /// whose jerk is `share` σ of the limits (MODEL.md §6.1, "Direct sections"), under the
    /// passes between the speeds `ends`, mm/s.
    pub(super) fn filter_envelope(
        &self,
        (first, last): (usize, usize),
        ends: (f64, f64),
        share: f64,
        window_s: f64,
    ) -> Vec<f64> {
        let s = &self.stations.s_mm()[first..=last];
        // The caps' minima lowered by J·W²/12 (twice what a plan of jerk J gains in its
        // average over W around a minimum; elsewhere the plan is under the envelope, or
        // flat at its cap); the ends at their speeds over c·W/2 + Δs_max (W at most the
        // run's window: its plan was flat at c there, so the caps are at least c).
        let j_max = self
            .stations
            .interval_jerk_mm_s3()
            .expect(FILTER_NEEDS_JERK)[first..last]
            .iter()
            .fold(0.0f64, |m, &x| m.max(x));
        let margin = share * j_max * window_s * window_s / 12.0;
        let caps = &self.caps_mm_s[first..=last];
        let mut envelope: Vec<f64> = (0..caps.len())
            .map(|k| {
                let before = if k > 0 { caps[k - 1] } else { f64::INFINITY };
                let after = caps.get(k + 1).copied().unwrap_or(f64::INFINITY);
                let c = caps[k];
                if c <= before && c <= after && (c < before || c < after) {
                    (c - margin).max(0.5 * c)
                } else {
                    c
                }
            })
            .collect();
        for (end, c) in [(0, ends.0), (s.len() - 1, ends.1)] {
            let reach = c * window_s / 2.0 + self.ds_max_mm;
            let lo = s.partition_point(|&x| x < s[end] - reach);
            let hi = s.partition_point(|&x| x <= s[end] + reach);
            for e in &mut envelope[lo..hi] {
                *e = c;
            }
        }
        self.passes_between(first, 1.0, &mut envelope, ends);
        envelope
    }

    /// Plans the section `first..=last` into `v` (its stations' speeds, from `first`)
    /// shaped directly, as the plan of a filter
    /// of width `window_s` (MODEL.md §6.1, "Direct sections"): from the speed `ends.0` at
    /// `first` to `ends.1` at `last` (held caps, both > 0, each with no acceleration,
    /// each held over c·W/2 + Δs_max into the section), under the caps with their local
    /// minima lowered by σ·J·W²/12 (so that the filtered speed, an average over W of the
    /// plan, is at most the cap where it passes the station), each interval's
    /// acceleration limit and `share` σ of its jerk
    /// limit ([`direct::shape`]). With `gaps`, the shape's gaps are put there (stations
    /// counted from `first`), for a section followed exactly (`window_s` = 0: MODEL.md
    /// §6.1, "Exact direct sections"); with `follow`, the dips get stretches of the
    /// envelope beside them that the motion follows (MODEL.md §6.1, "Dips that follow the
    /// envelope"). Returns the planned time (of the stations' constant
    /// accelerations) and the longest time the plan takes over one station interval, s, or
    /// `None` where the shape has no motion between the ends or is not flat at an end's
    /// speed over c·W/2 from it.
    pub(super) fn plan_direct(
        &self,
        (first, last): (usize, usize),
        ends: (f64, f64),
        (share, window_s, follow): (f64, f64, bool),
        v: &mut [f64],
        gaps: Option<&mut Vec<direct::Gap>>,
    ) -> Option<(f64, f64)> {
        let s = &self.stations.s_mm()[first..=last];
        let envelope = self.filter_envelope((first, last), ends, share, window_s);
        let jerk = self.shared_jerk((first, last), share);
        let limits = direct::Limits {
            s_mm: s,
            envelope_mm_s: &envelope,
            accel_mm_s2: &self.stations.interval_accel_mm_s2()[first..last],
            jerk_mm_s3: &jerk,
        };
        let slow_share = self.stations.machine().period_s() * DIRECT_SLOW_PERIODS;
        let follow = follow.then(|| self.stations.machine().period_s());
        if !direct::shape(&limits, slow_share, follow, v, gaps) {
            return None;
        }
        let n = s.len() - 1;
        if !((ends.0 == 0.0 || held_at(v, s, 1..=n, 0, ends.0, window_s))
            && (ends.1 == 0.0 || held_at(v, s, (0..n).rev(), n, ends.1, window_s)))
        {
            return None;
        }
        // The planned time and the longest time over one interval, in one pass.
        Some((0..n).fold((0.0, 0.0), |(sum, longest): (f64, f64), k| {
            let dt = interval_time_s(s, v, k);
            (sum + dt, longest.max(dt))
        }))
    }

    /// The section `first..=last` shaped by sequential linear programs ([`slp::shape`]) at
    /// the share σ = `share` of each interval's jerk limit, to be followed exactly, without
    /// a filter (MODEL.md §6.1, "Sections by linear programs"), from the speeds `v` (of the
    /// section's stations): under the caps, held at the speeds `ends` with no acceleration
    /// over Δs_max from each end, `v` and `accel` (the accelerations at the stations)
    /// become the quickest iterate whose motion ([`slp::Piece`]) keeps the caps, the
    /// acceleration limits and σ of the jerk limits at every instant. Returns its time, s.
    pub(super) fn plan_programmed(
        &self,
        (first, last): (usize, usize),
        ends: (f64, f64),
        share: f64,
        (v, accel): (&mut [f64], &mut [f64]),
    ) -> Option<f64> {
        let s = &self.stations.s_mm()[first..=last];
        let envelope = self.filter_envelope((first, last), ends, share, 0.0);
        let jerk = self.shared_jerk((first, last), share);
        let limits = slp::Limits {
            s_mm: s,
            caps_mm_s: &envelope,
            accel_mm_s2: &self.stations.interval_accel_mm_s2()[first..last],
            jerk_mm_s3: &jerk,
        };
        let n = s.len() - 1;
        let held = (
            s.partition_point(|&x| x <= s[0] + self.ds_max_mm),
            n + 1 - s.partition_point(|&x| x < s[n] - self.ds_max_mm),
        );
        if held.0 + held.1 > n {
            return None;
        }
        v[0] = ends.0;
        v[n] = ends.1;
        slp::shape(&limits, held, v, accel).then(|| {
            (0..n)
                .map(|k| slp::Piece::of(s, v, accel, k).duration_s())
                .sum()
        })
    }

    /// The section `first..=last` shaped directly ([`RunPlanner::plan_direct`]) at the
    /// share σ = `share` of the jerk limit, with the narrowest filter of at least
    /// σ/(1 − σ) times the longest time the plan takes over one station interval, Δt
    /// (MODEL.md §6.1, "Direct sections": the filtered jerk is then at most the jerk
    /// limit), found by widening from `window_s` (to 1.05 times what the last plan needed)
    /// in at most 4 plans, and no wider than
    /// `max_window_s`. Returns the planned time and the window, s.
    pub(super) fn direct_window(
        &self,
        section: (usize, usize),
        ends: (f64, f64),
        share: f64,
        (mut window_s, max_window_s): (f64, f64),
        v: &mut [f64],
    ) -> Option<(f64, f64)> {
        for _ in 0..4 {
            let (d, dt_max) = self.plan_direct(section, ends, (share, window_s, false), v, None)?;
            let needed = dt_max * share / (1.0 - share);
            if window_s >= needed {
                return Some((d, window_s));
            }
            // A little wider than needed: the wider filter's margins change the plan.
            window_s = needed * 1.05;
            if window_s > max_window_s {
                return None;
            }
        }
        None
    }

    /// The values of the section `a..=b` between the speeds `ends` (MODEL.md §6.1,
    /// "Sections"), unverified: planned by [`RunPlanner::plan_section`] at each λ of
    /// [`SECTION_GRID`] (W = λ·`base_window_s`) and at the run's own (λ, W), and, between
    /// speeds > 0, shaped directly ([`RunPlanner::direct_window`] at each of
    /// [`DIRECT_SHARES`]), followed exactly (at each of [`EXACT_SHARES`], with and without
    /// the dips widened over the envelope they can follow) and shaped by linear programs
    /// ([`RunPlanner::plan_programmed`] at the first share) where the others leave enough
    /// over the floor. Reads the planner's caps and marks and writes only into `scratch`.
    pub(super) fn section_values(
        &self,
        (a, b): (usize, usize),
        ends: (f64, f64),
        (base_window_s, own): (f64, (f64, f64)),
        scratch: &mut SectionScratch,
    ) -> SectionValues {
        let s = &self.stations.s_mm()[a..=b];
        let window0_s = own.1;
        let mut timed: Vec<SectionValue> = Vec::with_capacity(
            SECTION_GRID.len() + DIRECT_SHARES.len() + 2 * EXACT_SHARES.len() + 2,
        );
        let grid = SECTION_GRID
            .iter()
            .map(|&lambda| (lambda, lambda * base_window_s));
        // The run's own value, unless the grid holds it already.
        let values = grid
            .clone()
            .chain((!grid.clone().any(|g| g == own)).then_some(own));
        let rests = f64::from(u8::from(ends.0 == 0.0)) + f64::from(u8::from(ends.1 == 0.0));
        let SectionScratch { trial, gaps } = scratch;
        trial.resize(b - a + 1, 0.0);
        let mut seed = Vec::new();
        let mut seed_s = f64::INFINITY;
        let mut programmed = Programmed::default();
        for (lambda, window_s) in values {
            if let Some(d) = self.plan_section((a, b), (lambda, window_s), ends, trial) {
                timed.push(SectionValue {
                    time_s: d + rests * window_s / 2.0,
                    value: lambda,
                    window_s,
                    shape: Shape::Filtered,
                });
            }
        }
        // Shaped directly (not from or to a stop: there the plan's first interval is long
        // in time).
        if ends.0 > 0.0 && ends.1 > 0.0 {
            let bounds = (DIRECT_WINDOW_MIN_S, window0_s);
            for &share in &DIRECT_SHARES {
                if let Some((d, window_s)) = self.direct_window((a, b), ends, share, bounds, trial)
                {
                    timed.push(SectionValue {
                        time_s: d,
                        value: share,
                        window_s,
                        shape: Shape::Direct,
                    });
                }
            }
            // Followed exactly, without a filter; and with the dips widened over the
            // envelope they can follow.
            for (follow, shape) in [(false, Shape::Exact), (true, Shape::Following)] {
                for &share in &EXACT_SHARES {
                    gaps.clear();
                    if self
                        .plan_direct((a, b), ends, (share, 0.0, follow), trial, Some(gaps))
                        .is_some()
                    {
                        let d = exact_time_s(s, trial, gaps);
                        if d < seed_s {
                            seed_s = d;
                            seed.clear();
                            seed.extend_from_slice(trial);
                        }
                        timed.push(SectionValue {
                            time_s: d,
                            value: share,
                            window_s: 0.0,
                            shape,
                        });
                    }
                }
            }
            // Shaped by linear programs, from the quickest exact value (else from the
            // floor's passes), where the values leave enough over the floor.
            if b - a < PROGRAMMED_MAX_STATIONS {
                let best = timed.iter().fold(f64::INFINITY, |m, x| m.min(x.time_s));
                let floor = &mut trial[..];
                floor.copy_from_slice(&self.caps_mm_s[a..=b]);
                self.passes_between(a, 1.0, floor, ends);
                let floor_s: f64 = (0..b - a).map(|k| interval_time_s(s, floor, k)).sum();
                if seed.is_empty() {
                    seed.extend_from_slice(floor);
                }
                if best - floor_s > PROGRAMMED_EXCESS_MIN_S {
                    let Programmed {
                        speed_mm_s: speeds,
                        accel_mm_s2: accels,
                    } = &mut programmed;
                    speeds.extend_from_slice(&seed);
                    accels.resize(speeds.len(), 0.0);
                    let share = EXACT_SHARES[0];
                    if let Some(d) = self.plan_programmed((a, b), ends, share, (speeds, accels)) {
                        timed.push(SectionValue {
                            time_s: d,
                            value: share,
                            window_s: 0.0,
                            shape: Shape::Programmed,
                        });
                    }
                }
            }
        }
        timed.sort_by(|x, y| x.time_s.total_cmp(&y.time_s));
        if !timed.iter().any(|x| x.shape == Shape::Programmed) {
            // Nothing will shape the section by linear programs again.
            seed = Vec::new();
            programmed = Default::default();
        }
        SectionValues {
            timed,
            seed,
            programmed,
        }
    }
}
