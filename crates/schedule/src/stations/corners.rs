//! The corners' choice (MODEL.md §6.1, "Stop or pass"): each corner passed at the corner
//! rule's speed, its velocity step taken out of the acceleration budgets beside it, or made
//! a stop of no dwell, and the stations limited so ([`Stations::limit_with`]).

use std::sync::Mutex;

use nalgebra::Vector3;
use rayon::prelude::*;

use super::{
    partition_point_near, CapKind, RecentTangents, SampledMemo, Stations, Stop, PARALLEL_CHUNK,
};
use crate::machine::along;
use crate::range_min::RangeMin;

/// The corners' choice on the envelope ([`Stations`]' `stop_or_pass_corners`), kept
/// with a jerk limit for the planner to check (`crate::corner_check`).
pub(crate) struct CornerChoice {
    /// Caps before any corner was judged, mm/min, and their kinds.
    base_caps_mm_min: Vec<f64>,
    base_kinds: Vec<CapKind>,
    /// Whether each corner is judged; the others are passed in every pass of the
    /// envelope's choice, stopped only where the jerk check stops every corner of a run
    /// (`crate::corner_check`).
    judged: Vec<bool>,
    /// The interval accelerations with every corner that is not judged passed: the
    /// tangential limits ([`Stations::tangential_limits`]) with those corners' budgets
    /// taken out ([`Stations::share_corner_budgets`]), mm/s². A choice that passes them
    /// all starts from here and shares the budgets of its judged corners only.
    base_accel_mm_s2: Vec<f64>,
    /// The program's own stops (start, dwells, end).
    stops: Vec<Stop>,
    /// Each corner's station and tangent jump.
    corners: Vec<(usize, Vector3<f64>)>,
    /// Whether the envelope passes each corner.
    pub(crate) pass: Vec<bool>,
    /// The choice's first sampled-geometry limiting, kept for its later ones (each
    /// of its limitings starts from its caps; [`SampledMemo`]).
    sampled: Mutex<Option<SampledMemo>>,
}

impl CornerChoice {
    /// The stations of the program's own stops, ascending.
    pub(crate) fn own_stops(&self) -> Vec<usize> {
        self.stops.iter().map(|stop| stop.station).collect()
    }

    /// The station of corner `index`.
    pub(crate) fn corner_station(&self, index: usize) -> usize {
        self.corners[index].0
    }
}

/// A judged corner's two segments: the junctions beside it with every judged corner a stop.
struct JudgedWindow {
    /// First and last station.
    before: usize,
    after: usize,
}

impl Stations {
    /// The stops and limits of the stations with the `corners` that `passed` says
    /// (indices into `corners`) passed, their steps taken out of the budgets beside them
    /// (except those of the corners `shared` says the interval accelerations hold
    /// already), and the others stops of no dwell beside `own_stops` (the program's);
    /// then the sampled-geometry rule over all of it (`kept`: a choice's first limiting,
    /// [`Stations::limit_sampled_geometry`]).
    pub(super) fn limit_corners(
        &mut self,
        own_stops: &[Stop],
        corners: &[(usize, Vector3<f64>)],
        passed: &dyn Fn(usize) -> bool,
        shared: &dyn Fn(usize) -> bool,
        kept: Option<&mut Option<SampledMemo>>,
    ) {
        self.stops = with_stops(
            own_stops,
            (0..corners.len())
                .filter(|&i| !passed(i))
                .map(|i| corners[i].0),
        );
        self.share_corner_budgets(corners, &|i| passed(i) && !shared(i));
        self.corners = (0..corners.len())
            .filter(|&i| passed(i))
            .map(|i| corners[i].0)
            .collect();
        self.limit_sampled_geometry(kept);
    }

    /// Each corner either passed at the speed the corner rule allows, its velocity step
    /// taken out of the acceleration budget beside it (the step and the tangential
    /// acceleration share each axis' limit within one period of it), or stopped at, as
    /// exact stop does (MODEL.md §6.1, "Stop or pass"): a stop has no velocity step, so
    /// the motion reaches it with the whole tangential acceleration and leaves it the
    /// same way. Only corners whose rule sets their station's cap are judged (the others
    /// are passed at their segments' speed). Each is judged with both its judged
    /// neighbours stopped, where its two segments are planned apart from the rest: the
    /// stations are limited with every other judged corner passed (even, then odd) and
    /// with every judged corner a stop, and a corner is passed where the
    /// acceleration-limited envelope over its two segments is no slower so. The stations
    /// are limited once more with the corners so chosen (not where that stops every
    /// judged corner: they are so already), and kept so only where their envelope is no
    /// slower than with every corner passed and with every judged corner a stop (else
    /// the quicker of those). Each limiting resets every array it sets, so the stations
    /// are what the last one made, whatever came before. With a jerk limit a stop
    /// is judged W dearer and the choice is returned for the planner to check
    /// (`crate::corner_check`), which limits the stations as it keeps it.
    pub(super) fn stop_or_pass_corners(
        &mut self,
        own_stops: Vec<Stop>,
        corners: Vec<(usize, Vector3<f64>)>,
    ) -> Option<CornerChoice> {
        // A corner whose rule does not set its station's cap (a shallow one, or one on a
        // slow segment) is passed at the speed of the segments beside it: a stop there
        // could only be slower, so it is not judged. Where no corner's rule binds (as on
        // smooth finishing paths) nothing is judged, and nothing copied.
        let judged: Vec<usize> = (0..corners.len())
            .filter(|&index| self.cap_kind[corners[index].0] == CapKind::Corner)
            .collect();
        if judged.is_empty() {
            self.limit_corners(&own_stops, &corners, &|_| true, &|_| false, None);
            return None;
        }
        let mut is_judged = vec![false; corners.len()];
        for &index in &judged {
            is_judged[index] = true;
        }
        // The budgets of the corners passed in every choice, shared once (from the
        // tangential limits, as `limit_with` starts where it shares them all).
        let base_caps_mm_min = self.cap_mm_min.clone();
        self.set_tangential_accels();
        self.share_corner_budgets(&corners, &|index| !is_judged[index]);
        let mut choice = CornerChoice {
            base_caps_mm_min,
            base_kinds: self.cap_kind.clone(),
            base_accel_mm_s2: self.interval_accel_mm_s2.clone(),
            judged: is_judged,
            stops: own_stops,
            // (Set below where the choice is returned.)
            pass: Vec::new(),
            corners,
            sampled: Mutex::new(None),
        };
        let free = |index: usize| !choice.judged[index];
        let time = |st: &Stations, v: &[f32], lo: usize, hi: usize| {
            (lo..hi)
                .map(|k| 2.0 * (st.s_mm[k + 1] - st.s_mm[k]) / (v[k] as f64 + v[k + 1] as f64))
                .sum::<f64>()
        };
        // Each judged corner's window: its neighbouring junctions with every judged corner
        // a stop (the stops `limit_with` sets so, made here before it runs).
        let junctions: Vec<usize> = with_stops(
            &choice.stops,
            judged.iter().map(|&index| choice.corners[index].0),
        )
        .iter()
        .map(|stop| stop.station)
        .collect();
        let windows: Vec<JudgedWindow> = judged
            .iter()
            .map(|&index| {
                let c = choice.corners[index].0;
                let at = junctions.partition_point(|&x| x < c);
                JudgedWindow {
                    before: junctions[..at].last().copied().unwrap_or(0),
                    after: junctions.get(at + 1).copied().unwrap_or(self.len() - 1),
                }
            })
            .collect();
        drop(junctions);
        let n = self.len() - 1;
        let jerk = self.machine.jerk_mm_s3.is_some();
        // The stations are limited with every corner passed (without a jerk limit), with
        // every other judged corner passed (even, then odd) and last with every judged
        // corner a stop, so that where the choice stops them all (as it does where every
        // judged corner is a reversal) the stations are limited so already. Each envelope
        // is timed (the whole path's, or each judged corner's window where it is passed)
        // and let go before the next one is made (4 B a station).
        let all_passed = (!jerk).then(|| {
            let envelope = self.limit_with(&choice, &|_| true);
            time(self, &envelope, 0, n)
        });
        // Position of each judged corner among the judged ones.
        let mut rank = vec![0; choice.corners.len()];
        for (r, &index) in judged.iter().enumerate() {
            rank[index] = r;
        }
        let mut passed_s = vec![0.0; judged.len()];
        for parity in 0..2 {
            let envelope =
                self.limit_with(&choice, &|index| free(index) || rank[index] % 2 == parity);
            for r in (parity..judged.len()).step_by(2) {
                let w = &windows[r];
                passed_s[r] = time(self, &envelope, w.before, w.after);
            }
        }
        let (all_stopped, stopped_s) = {
            let envelope = self.limit_with(&choice, &free);
            let stopped_s: Vec<f64> = windows
                .iter()
                .map(|w| time(self, &envelope, w.before, w.after))
                .collect();
            (time(self, &envelope, 0, n), stopped_s)
        };
        // With a jerk limit each stop adds a run, and each run its filter's width W
        // (MODEL.md §6.1, "Jerk limit"): a stop costs W more than its envelope says.
        let stop_cost_s = self.machine.jerk_mm_s3.map_or(0.0, |_| {
            (0..self.len() - 1)
                .map(|k| self.interval_accel_mm_s2[k] / self.interval_jerk_mm_s3[k])
                .fold(0.0, f64::max)
        });
        // Every corner not judged passed; each judged one where no slower so.
        let mut pass: Vec<bool> = (0..choice.corners.len()).map(free).collect();
        for (r, &index) in judged.iter().enumerate() {
            pass[index] = passed_s[r] <= stopped_s[r] + stop_cost_s;
        }
        let Some(all_passed) = all_passed else {
            // The check limits the stations itself, first as chosen (not done twice here).
            choice.pass = pass;
            return Some(choice);
        };
        // The choice, kept only where its envelope is no slower than with every corner
        // passed and with every judged corner a stop (the corners interact through the
        // speeds between them); else the quicker of those two. The stations are limited
        // as stopped now; a choice that stops every judged corner is that one.
        let stops_all = judged.iter().all(|&index| !pass[index]);
        let chosen = if stops_all {
            all_stopped
        } else {
            let envelope = self.limit_with(&choice, &|index| pass[index]);
            time(self, &envelope, 0, n)
        };
        if all_passed < chosen.min(all_stopped) {
            self.limit_with(&choice, &|_| true);
        } else if all_stopped < chosen {
            self.limit_with(&choice, &free);
        }
        None
    }

    /// The stations limited with the corners of `choice` that `passed` says (indices
    /// into its corners) passed and the others stops, from its caps before any corner
    /// was judged and its interval accelerations with the corners that are not judged
    /// (or, where one of those is stopped, the tangential limits); their envelope.
    pub(crate) fn limit_with(
        &mut self,
        choice: &CornerChoice,
        passed: &dyn Fn(usize) -> bool,
    ) -> Vec<f32> {
        // Into the arrays there (no second copy of them at once).
        self.cap_mm_min.clone_from(&choice.base_caps_mm_min);
        self.cap_kind.clone_from(&choice.base_kinds);
        let judged = &choice.judged;
        let free_passed = (0..judged.len()).all(|index| judged[index] || passed(index));
        let mut kept = choice.sampled.lock().unwrap_or_else(|e| e.into_inner());
        if free_passed {
            // The corners that are not judged, shared already (the min over budgets is
            // the same taken in two steps).
            self.interval_accel_mm_s2
                .clone_from(&choice.base_accel_mm_s2);
            self.limit_corners(
                &choice.stops,
                &choice.corners,
                passed,
                &|index| !judged[index],
                Some(&mut kept),
            );
        } else {
            self.set_tangential_accels();
            self.limit_corners(
                &choice.stops,
                &choice.corners,
                passed,
                &|_| false,
                Some(&mut kept),
            );
        }
        self.envelope_mm_s(&self.cap_mm_min, &self.interval_accel_mm_s2)
    }

    /// Within one period of a corner, each axis' velocity step there (v·|Δt_i|, at most
    /// a_i·T/2 by the corner rule) is taken out of that axis' acceleration budget, so the
    /// step and the ramps beside it together stay within a_i in the sampled positions.
    /// Only the corners `include` says (indices into `corners`) share their budgets.
    ///
    /// Where their reaches together cover no more intervals than the path has, each
    /// corner's budgets are applied to its intervals one by one; else through a
    /// range-minimum tree over the intervals, so the cost is O((stations + corners)·log
    /// stations) however many corners fall within one reach (very short segments). The
    /// two give the same limits: each is the minimum over the corners reaching an
    /// interval of b_i/|t_i|, and dividing by |t_i| keeps the order of the budgets.
    fn share_corner_budgets(
        &mut self,
        corners: &[(usize, Vector3<f64>)],
        include: &dyn Fn(usize) -> bool,
    ) {
        let intervals = self.s_mm.len().saturating_sub(1);
        let covered: usize = (0..corners.len())
            .filter(|&index| include(index))
            .map(|index| self.corner_budget(&corners[index]).intervals.len())
            .sum();
        let by = if covered <= intervals {
            Sharing::OneByOne
        } else if covered <= PAINTED_MAX * intervals {
            Sharing::Painted
        } else {
            Sharing::Tree
        };
        self.share_budgets(corners, include, by, PARALLEL_CHUNK);
    }

    /// Corner `(c, jump)`'s budgets and the intervals k → k+1 overlapping [s_c − reach,
    /// s_c + reach]: from the last station at or before s_c − reach to the last one
    /// before s_c + reach.
    fn corner_budget(&self, &(c, jump): &(usize, Vector3<f64>)) -> CornerBudget {
        let period_s = self.machine.period_s();
        let a = self.machine.accel_mm_s2;
        let a_max = a.iter().copied().fold(0.0, f64::max);
        let v_c = self.cap_mm_min[c] / 60.0;
        let (s_c, reach) = (self.s_mm[c], (v_c + a_max * period_s) * period_s);
        let lo = partition_point_near(&self.s_mm[..=c], c, |s| s <= s_c - reach).saturating_sub(1);
        let hi = c + partition_point_near(&self.s_mm[c..], 0, |s| s < s_c + reach);
        CornerBudget {
            intervals: lo..hi.min(self.s_mm.len().saturating_sub(1)),
            accel_mm_s2: std::array::from_fn(|i| {
                (a[i] - v_c * jump[i].abs() / period_s).max(0.5 * a[i])
            }),
        }
    }

    /// [`Stations::share_corner_budgets`] as `by` says, its intervals `chunk` a parallel
    /// task (the same values for any `chunk` and either way).
    fn share_budgets(
        &mut self,
        corners: &[(usize, Vector3<f64>)],
        include: &dyn Fn(usize) -> bool,
        by: Sharing,
        chunk: usize,
    ) {
        let intervals = self.s_mm.len().saturating_sub(1);
        let mut accel = std::mem::take(&mut self.interval_accel_mm_s2);
        let shared = || {
            (0..corners.len())
                .filter(|&index| include(index))
                .map(|index| self.corner_budget(&corners[index]))
        };
        if by == Sharing::OneByOne {
            let mut tangents = RecentTangents::new();
            for c in shared() {
                for k in c.intervals {
                    for t in [tangents.get(self, k), tangents.get(self, k + 1)] {
                        accel[k] = accel[k].min(along(&t, c.accel_mm_s2));
                    }
                }
            }
        } else {
            // along(t, b) = min over the moving axes of b_i/|t_i|: the limit of an interval
            // is the minimum over the axes of each axis' share, so the axes are taken one at
            // a time, each axis' budgets one value per interval (a third of the memory of
            // three), in the same minima (a minimum is one of its arguments, whatever the
            // order). An interval is limited where a corner reaches it.
            let mut reached: Vec<bool> = Vec::new();
            let mut budgets: Vec<f64> = Vec::new();
            for axis in 0..3 {
                axis_budgets(shared(), axis, intervals, by, &mut budgets);
                if axis == 0 {
                    reached = budgets.iter().map(|b| b.is_finite()).collect();
                }
                self.lower_by_axis(&mut accel[..intervals], &budgets, &reached, axis, chunk);
            }
        }
        self.interval_accel_mm_s2 = accel;
    }

    /// Each interval `k` that a corner reaches (`reached`) lowered to each of its ends'
    /// share of `axis`' budget there, `budgets[k] / |t_axis|` (an axis that does not
    /// move there takes none), the intervals `chunk` a parallel task.
    fn lower_by_axis(
        &self,
        accel: &mut [f64],
        budgets: &[f64],
        reached: &[bool],
        axis: usize,
        chunk: usize,
    ) {
        accel
            .par_chunks_mut(chunk)
            .enumerate()
            .for_each(|(c, accel)| {
                let k0 = c * chunk;
                let mut tangents = RecentTangents::new();
                for (i, a) in accel.iter_mut().enumerate() {
                    let k = k0 + i;
                    if !reached[k] {
                        continue;
                    }
                    let (t0, t1) = (tangents.get(self, k)[axis], tangents.get(self, k + 1)[axis]);
                    // (Both ends on one line: the same share once.)
                    let ends = if t1 == t0 { 1 } else { 2 };
                    for t in &[t0, t1][..ends] {
                        if *t != 0.0 {
                            *a = a.min(budgets[k] / t.abs());
                        }
                    }
                }
            });
    }
}

/// Each of the `intervals`' least budget of `axis` over the corners `shared` (+∞ where
/// none reaches), into `budgets`: painted corner by corner over the array, which is kept
/// from axis to axis (allocated again, its pages would be cleared and faulted in again:
/// 24 MB for 3 M stations), or through a range-minimum tree (`by`).
fn axis_budgets(
    shared: impl Iterator<Item = CornerBudget>,
    axis: usize,
    intervals: usize,
    by: Sharing,
    budgets: &mut Vec<f64>,
) {
    if by == Sharing::Painted {
        budgets.clear();
        budgets.resize(intervals, f64::INFINITY);
        for c in shared {
            for b in &mut budgets[c.intervals] {
                *b = b.min(c.accel_mm_s2[axis]);
            }
        }
    } else {
        let mut tree = RangeMin::<1>::new(intervals);
        for c in shared {
            tree.lower(c.intervals.start, c.intervals.end, [c.accel_mm_s2[axis]]);
        }
        *budgets = tree.into_minima().into_iter().map(|[b]| b).collect();
    }
}

/// How [`Stations::share_budgets`] takes the corners' budgets to the intervals they
/// reach: one corner at a time, each interval's tangents and limit made for each corner
/// that reaches it (where the corners reach fewer intervals than there are); each axis'
/// budgets painted over an array of the intervals, corner by corner (where they reach at
/// most [`PAINTED_MAX`] times as many); or through a range-minimum tree (n·log n
/// however far they reach).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sharing {
    OneByOne,
    Painted,
    Tree,
}

/// The most intervals the corners may reach together, as a multiple of the path's
/// intervals, for their budgets to be painted rather than taken through the tree.
const PAINTED_MAX: usize = 32;

/// One corner's share of the axes' acceleration (MODEL.md §6.1): the budget each axis has
/// left beside its velocity step, over the intervals within its reach.
struct CornerBudget {
    /// Intervals k → k+1 within the corner's reach.
    intervals: std::ops::Range<usize>,
    /// Each axis' budget, mm/s².
    accel_mm_s2: [f64; 3],
}

/// `stops` with a stop of no dwell added at each of `corners` (ascending, none a stop).
fn with_stops(stops: &[Stop], corners: impl Iterator<Item = usize>) -> Vec<Stop> {
    let mut all: Vec<Stop> = stops.to_vec();
    all.extend(corners.map(|station| Stop {
        station,
        dwell_s: 0.0,
    }));
    all.sort_by_key(|stop| stop.station);
    all
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Vector3};
    use nc::{Geometry, Motion, Path, Segment};

    use super::Sharing;
    use crate::machine::Machine;
    use crate::stations::{CapKind, Corners, FeedPolicy, Stations};

    /// The corner budgets shared one corner at a time equal those shared through the
    /// range-minimum tree, bit for bit, and shared in two steps (as a choice that passes
    /// every corner not judged starts from those shared once) equal those shared at
    /// once; they lower the accelerations where corners reach.
    /// A zigzag of short lines (0.07–0.6 mm, a corner at every junction, some within
    /// one reach of each other).
    fn zigzag() -> Path {
        let mut points = vec![Point3::new(0.0, 0.0, 0.0)];
        for i in 1..120 {
            let len = 0.07 + 0.53 * ((i * 37 % 11) as f64 / 10.0);
            let angle = if i % 2 == 0 { 0.4 } else { -0.7 } + 0.01 * i as f64;
            let p = points[i - 1];
            points.push(Point3::new(
                p.x + len * angle.cos(),
                p.y + len * angle.sin(),
                p.z - 0.001 * (i % 3) as f64,
            ));
        }
        let feed = Motion::feed(2400.0);
        let segment = |start, end| Segment {
            start,
            end,
            geometry: Geometry::Line,
            motion: feed,
            line: 1,
            spindle_rpm: 10000.0,
            tool: 1,
        };
        let segments: Vec<Segment> = points.windows(2).map(|w| segment(w[0], w[1])).collect();
        Path::from_segments(segments)
    }

    #[test]
    fn corner_budgets_are_the_same_one_by_one_painted_by_tree_and_in_two_steps() {
        let path = zigzag();
        let machine = Machine::default();
        let stopped = Stations::with_corners(
            &path,
            &machine,
            0.05,
            FeedPolicy::Programmed,
            Corners::Stopped,
        )
        .unwrap();
        // Every junction a corner, with its tangent jump.
        let corners: Vec<(usize, Vector3<f64>)> = (1..stopped.len() - 1)
            .filter(|&k| stopped.segment[k] != stopped.segment[k + 1] && stopped.fraction[k] == 1.0)
            .map(|k| {
                let before = &stopped.path.segments[stopped.segment[k] as usize];
                let after = &stopped.path.segments[stopped.segment[k + 1] as usize];
                (
                    k,
                    after.tangent_at_fraction(0.0) - before.tangent_at_fraction(1.0),
                )
            })
            .collect();
        assert!(corners.len() > 100, "{} corners", corners.len());
        // Shared one way (Some) or as built (None: the way picked by how much the reaches
        // cover).
        let shared = |include: &dyn Fn(usize) -> bool, by: Option<Sharing>| {
            let mut st = stopped.clone();
            match by {
                // (Tasks of 7 intervals: the chunks' ends are passed many times.)
                Some(by) => st.share_budgets(&corners, include, by, 7),
                None => st.share_corner_budgets(&corners, include),
            }
            st.interval_accel_mm_s2
        };
        let bits = |a: Vec<f64>| a.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let one_by_one = shared(&|_| true, Some(Sharing::OneByOne));
        let tree = shared(&|_| true, Some(Sharing::Tree));
        assert_eq!(bits(one_by_one.clone()), bits(tree));
        let painted = shared(&|_| true, Some(Sharing::Painted));
        assert_eq!(bits(one_by_one.clone()), bits(painted));
        let lowered = (0..one_by_one.len())
            .filter(|&k| one_by_one[k] < stopped.interval_accel_mm_s2[k])
            .count();
        assert!(lowered > stopped.len() / 2, "{lowered} intervals lowered");
        // Even corners, then odd ones on top, each step any way.
        let ways = [Sharing::OneByOne, Sharing::Painted, Sharing::Tree];
        for (first, second) in ways.into_iter().flat_map(|a| ways.map(|b| (a, b))) {
            let mut two_steps = stopped.clone();
            two_steps.share_budgets(&corners, &|i| i % 2 == 0, first, 7);
            two_steps.share_budgets(&corners, &|i| i % 2 == 1, second, 7);
            assert_eq!(
                bits(two_steps.interval_accel_mm_s2),
                bits(one_by_one.clone())
            );
        }
        // As built: the same, for all of them and for two far apart.
        assert_eq!(bits(shared(&|_| true, None)), bits(one_by_one.clone()));
        let two = |i: usize| i == 3 || i == 90;
        assert_eq!(
            bits(shared(&two, None)),
            bits(shared(&two, Some(Sharing::Tree)))
        );
        assert_eq!(
            bits(shared(&two, None)),
            bits(shared(&two, Some(Sharing::Painted)))
        );
        // None shared: nothing changes.
        assert_eq!(
            bits(shared(&|_| false, None)),
            bits(stopped.interval_accel_mm_s2.clone())
        );
    }

    /// The sampled geometry's limits made in tasks of a few stations are those made
    /// in one, bit for bit: caps, their kinds and the intervals' accelerations, on a
    /// path where they lower both.
    #[test]
    fn sampled_limits_are_the_same_in_any_chunks() {
        let machine = Machine::default();
        let passed = Stations::with_corners(
            &zigzag(),
            &machine,
            0.05,
            FeedPolicy::Programmed,
            Corners::Passed,
        )
        .unwrap();
        // From the tangential limits (the corners' budgets not shared), so that the
        // intervals hold only what the stations' budgets give them.
        let tangential: Vec<f64> = (0..passed.len() - 1)
            .map(|k| passed.tangential_limits(k).0)
            .collect();
        let limited = |chunk: usize| {
            let mut st = passed.clone();
            st.interval_accel_mm_s2.clone_from(&tangential);
            st.limit_sampled_geometry_in(chunk, None);
            st
        };
        let whole = limited(passed.len());
        assert!(
            whole.cap_kind.contains(&CapKind::Curvature),
            "a cap lowered by the differences"
        );
        let lowered = (0..tangential.len())
            .filter(|&k| whole.interval_accel_mm_s2[k] < tangential[k])
            .count();
        assert!(
            lowered > tangential.len() / 2,
            "{lowered} intervals lowered"
        );
        let bits = |a: &[f64]| a.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for chunk in [1, 2, 7, 64] {
            let st = limited(chunk);
            assert_eq!(bits(&st.cap_mm_min), bits(&whole.cap_mm_min), "{chunk}");
            assert_eq!(st.cap_kind, whole.cap_kind, "{chunk}");
            assert_eq!(
                bits(&st.interval_accel_mm_s2),
                bits(&whole.interval_accel_mm_s2),
                "{chunk}"
            );
        }
    }

    /// A corner choice's later limitings, judged again only where their inputs differ
    /// from its first one's (`SampledMemo`), are those judged anew, bit for bit: caps,
    /// kinds, interval accelerations and envelope, for choices that pass every corner,
    /// every other judged one, stop every judged one, and stop every corner (the jerk
    /// check's), on curved paths with sharp corners whose sampled geometry lowers caps:
    /// one where the ramps from a stop reach further than a station's samples, one
    /// where they reach less far (slow, so that the stops' own reach tells).
    #[test]
    fn a_choices_kept_sampled_limits_are_those_made_anew() {
        // Feed mm/min, chord mm, radius mm.
        for (feed, chord, radius) in [(3000.0, 0.2, 4.0), (600.0, 0.02, 0.4)] {
            kept_sampled_limits_are_made_anew(feed, chord, radius);
        }
    }

    /// [`a_choices_kept_sampled_limits_are_those_made_anew`] on a path of `chord` mm
    /// chords at `feed_mm_min`: a sharp turn (a judged corner) every 200 chords, 50
    /// chords straight after it, then an arc of `radius_mm` (at that feed its turns
    /// within one period, 16 ms, add up to more than half the acceleration; the corner
    /// rule at each chord allows more).
    fn kept_sampled_limits_are_made_anew(feed_mm_min: f64, chord: f64, radius_mm: f64) {
        let mut points = vec![Point3::new(0.0, 0.0, 0.0)];
        let mut heading: f64 = 0.0;
        for i in 1..2000 {
            heading += match i % 200 {
                0 => 1.9,
                1..50 => 0.0,
                _ => chord / radius_mm,
            };
            let p = points[i - 1];
            points.push(Point3::new(
                p.x + chord * heading.cos(),
                p.y + chord * heading.sin(),
                p.z - 0.0025 * chord,
            ));
        }
        let segments: Vec<Segment> = points
            .windows(2)
            .map(|w| Segment {
                start: w[0],
                end: w[1],
                geometry: Geometry::Line,
                motion: Motion::feed(feed_mm_min),
                line: 1,
                spindle_rpm: 10000.0,
                tool: 1,
            })
            .collect();
        let machine = Machine {
            accel_mm_s2: [400.0; 3],
            jerk_mm_s3: Some([1e6; 3]),
            ..Machine::default()
        };
        let (st, choice) = Stations::build_with(
            segments,
            &machine,
            chord / 4.0,
            FeedPolicy::Programmed,
            20_000,
            Corners::Judged,
        )
        .map_err(|(e, _)| e)
        .expect("stations");
        let choice = choice.expect("a choice to check (jerk limit)");
        let judged: Vec<usize> = (0..choice.judged.len())
            .filter(|&i| choice.judged[i])
            .collect();
        assert!(
            (6..=20).contains(&judged.len()),
            "{} judged corners at F{feed_mm_min}",
            judged.len()
        );
        let rank = |index: usize| judged.iter().position(|&i| i == index);
        let every_other = |index: usize| rank(index).is_none_or(|r| r % 2 == 0);
        let free = |index: usize| rank(index).is_none();
        let patterns: [(&str, &dyn Fn(usize) -> bool); 6] = [
            ("even", &every_other),
            ("all passed", &|_| true),
            ("odd", &|index| rank(index).is_none_or(|r| r % 2 == 1)),
            ("judged stopped", &free),
            ("all stopped", &|_| false),
            ("even again", &every_other),
        ];
        let bits = |a: &[f64]| a.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut judged_again = Vec::new();
        for (name, passed) in patterns {
            // Anew: the kept limiting taken out for this one, put back after (the
            // first's made anew kept).
            let kept = choice.sampled.lock().unwrap().take();
            let mut anew = st.clone();
            let anew_envelope = anew.limit_with(&choice, passed);
            if kept.is_some() {
                *choice.sampled.lock().unwrap() = kept;
            }
            let mut from_kept = st.clone();
            let kept_envelope = from_kept.limit_with(&choice, passed);
            assert_eq!(
                bits(&from_kept.cap_mm_min),
                bits(&anew.cap_mm_min),
                "{name}"
            );
            assert_eq!(from_kept.cap_kind, anew.cap_kind, "{name}");
            assert_eq!(
                bits(&from_kept.interval_accel_mm_s2),
                bits(&anew.interval_accel_mm_s2),
                "{name}"
            );
            let f32_bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(f32_bits(&kept_envelope), f32_bits(&anew_envelope), "{name}");
            let memo = choice.sampled.lock().unwrap();
            let memo = memo.as_ref().expect("kept from the first");
            judged_again.push(
                memo.judged_last
                    .swap(0, std::sync::atomic::Ordering::Relaxed),
            );
        }
        // The sampled geometry lowers caps here, and the later limitings took ranges
        // (not every station again).
        assert!(
            st.cap_kind.contains(&CapKind::Curvature),
            "a cap lowered by the differences at F{feed_mm_min}"
        );
        let n = st.len();
        assert!(
            judged_again[1..4].iter().all(|&k| k > 0 && 4 * k <= n),
            "stations judged again {judged_again:?} of {n} at F{feed_mm_min}"
        );
        assert_eq!(
            [judged_again[0], judged_again[5]],
            [0, 0],
            "the first's stops again: nothing judged again"
        );
    }
}
