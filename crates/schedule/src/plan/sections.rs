//! Sections of a run (MODEL.md §6.1, "Sections"): the run cut at its held caps, each
//! section given the quickest of its values whose samples verify, made ahead in parallel.

use rayon::prelude::*;

use super::profile::Profile;
use super::run_planner::RunPlanner;
use super::shapes::{SectionScratch, SectionValues, Shape, EXACT_SHARES};

/// A section that verifies at none of its values is merged with the next, at most this
/// many times (MODEL.md §6.1, "Sections").
pub(super) const SECTION_MERGES: usize = 8;

/// A section kept by [`RunPlanner::sectioned`]: its first cut, the previous section's
/// planned end and window before it, the rank of its value among its values, its last cut.
pub(super) type KeptSection = (usize, Option<(f64, f64)>, usize, usize);

/// A section that verifies at none of its values (after its merges) has the section
/// before it planned again at its next value that verifies, at most this many times a run
/// (MODEL.md §6.1, "Direct sections").
pub(super) const SECTION_BACKTRACKS: usize = 64;

impl<'a> RunPlanner<'a> {
    /// Sections of the run the profile holds last, planned as that run was (`kept` =
    /// (λ, W)), with a window of their own (MODEL.md §6.1, "Sections"): the run is cut at
    /// the stations where its plan runs at the station's cap c and is flat at c over
    /// c·W/2 on either side; each section between two cuts (or a stop) is planned by
    /// [`RunPlanner::plan_section`] at each λ of [`SECTION_GRID`](super::shapes::SECTION_GRID) (W = λ·`base_window_s`)
    /// and at `kept`, a section between speeds > 0 also shaped directly
    /// ([`RunPlanner::direct_window`] at each of [`DIRECT_SHARES`](super::shapes::DIRECT_SHARES)) and followed exactly
    /// (at each of [`EXACT_SHARES`], no filter: MODEL.md §6.1, "Exact direct sections"; and
    /// again with its dips widened over the envelope they can follow: "Dips that follow
    /// the envelope"),
    /// and keeps the quickest whose samples verify
    /// ([`Profile::last_run_axis_ratio`]). The sampler takes a section's filtered motion
    /// from the moment it is at the section's first station (at speed c, with no
    /// acceleration: both sections' plans are flat at c over their W/2 there). Returns the
    /// time the last section's planned motion reaches the run's end, or `None` (the run
    /// as it was) where a section verifies at none of its values or the sections are not
    /// quicker.
    ///
    /// A section's values before they are verified ([`RunPlanner::section_values`]) depend
    /// on its stations, the caps and marks (not changed here) and the speeds at its cuts
    /// alone, not on the sections before it: those between neighbouring cuts are made
    /// ahead, `ahead_stations` at a time, in parallel (rayon), and verified in order as
    /// before; the profile is the same bit for bit at any thread count.
    pub(super) fn sectioned(
        &mut self,
        profile: &mut Profile<'_>,
        base_window_s: f64,
        (lambda0, window0_s): (f64, f64),
    ) -> Option<f64> {
        let run = *profile.runs.last()?;
        if run.pause_s > 0.0 || run.window_s <= 0.0 {
            return None;
        }
        let (first, last) = (run.first, run.last);
        let s = self.stations.s_mm();
        let saved = profile.speed_mm_s[first..=last].to_vec();
        let v = |k: usize| saved[k - first];
        let mut cuts = vec![first];
        for m in first + 1..last {
            let c = v(m);
            let spacing = c * window0_s;
            let reach = spacing / 2.0;
            if !(c > 0.0 && c == self.caps_mm_s[m])
                || s[m] - s[cuts[cuts.len() - 1]] < spacing
                || s[last] - s[m] < spacing
            {
                continue;
            }
            let flat_before = (first..m)
                .rev()
                .take_while(|&k| s[m] - s[k] <= reach + self.ds_max_mm)
                .all(|k| v(k) == c);
            let flat_after = (m + 1..=last)
                .take_while(|&k| s[k] - s[m] <= reach + self.ds_max_mm)
                .all(|k| v(k) == c);
            if flat_before && flat_after {
                cuts.push(m);
            }
        }
        if cuts.len() < 2 {
            return None;
        }
        cuts.push(last);
        profile.pop_run();
        let runs_before = profile.runs.len();
        let mut gaps = std::mem::take(&mut self.gaps);
        // The speeds and accelerations shaped by linear programs at the share tried.
        let (mut programmed, mut programmed_accel): (Vec<f64>, Vec<f64>) = Default::default();
        // The values of the sections between two neighbouring cuts, made ahead of the loop
        // in parallel, a run of them at a time: those of `cuts[done.0 + k]..=cuts[done.0 +
        // k + 1]` at `ahead[k]`, for `done.0 + k` < `done.1`; those of merged sections and
        // of sections before `done.0` (planned again) are made where they are needed.
        let mut ahead: Vec<SectionValues> = Vec::new();
        let mut done = (0, 0);
        let mut scratch = SectionScratch::default();
        let own = (base_window_s, (lambda0, window0_s));
        // The previous section's planned end and window (a run leaving at speed: its
        // start and window, so that its first section's filtered motion reaches the
        // first station when the run's did).
        let mut previous: Option<(f64, f64)> =
            (v(first) > 0.0).then_some((run.start_s, run.window_s));
        let mut verified = true;
        let mut i = 0;
        // The sections kept, to plan one again (see [`KeptSection`]).
        let mut pushed: Vec<KeptSection> = Vec::new();
        // A section planned again (the one after it verified at none of its values): its
        // first cut, last cut and how many of its values to pass over.
        let mut resume: Option<(usize, usize, usize)> = None;
        let mut backtracks = 0;
        while i + 1 < cuts.len() {
            let a = cuts[i];
            let mut kept = None;
            let (mut j, mut skip) = match resume.take() {
                Some((at, j, skip)) if at == i => (j, skip),
                _ => (i + 1, 0),
            };
            // A section that verifies at none of its values is merged with the next one.
            while j < cuts.len() && j <= i + SECTION_MERGES {
                let b = cuts[j];
                let ends = (v(a), v(b));
                if j == i + 1 && i >= done.1 {
                    // The next sections, as many as hold about `ahead_stations` stations.
                    let mut end = i + 1;
                    while end + 1 < cuts.len() && cuts[end] - a < self.ahead_stations {
                        end += 1;
                    }
                    ahead = (i..end)
                        .into_par_iter()
                        .map_init(SectionScratch::default, |scratch, k| {
                            let section = (cuts[k], cuts[k + 1]);
                            let ends = (v(section.0), v(section.1));
                            self.section_values(section, ends, own, scratch)
                        })
                        .collect();
                    done = (i, end);
                }
                let made;
                let values = if j == i + 1 && (done.0..done.1).contains(&i) {
                    &ahead[i - done.0]
                } else {
                    made = self.section_values((a, b), ends, own, &mut scratch);
                    &made
                };
                let timed = &values.timed;
                for (rank, &(_, lambda, window_s, shape)) in timed.iter().enumerate().skip(skip) {
                    // A value shaped by linear programs whose samples do not verify is shaped
                    // again at the next shares of the jerk limit, each while it is quicker
                    // than the next value.
                    let next_s = timed.get(rank + 1).map_or(f64::INFINITY, |x| x.0);
                    let shares = if shape == Shape::Programmed {
                        EXACT_SHARES.len()
                    } else {
                        1
                    };
                    for (share, &sigma) in EXACT_SHARES.iter().enumerate().take(shares) {
                        gaps.clear();
                        match shape {
                            Shape::Filtered => {
                                self.plan_section(
                                    (a, b),
                                    (lambda, window_s),
                                    ends,
                                    &mut profile.speed_mm_s[a..=b],
                                );
                            }
                            Shape::Direct => {
                                self.plan_direct(
                                    (a, b),
                                    ends,
                                    (lambda, window_s, false),
                                    &mut profile.speed_mm_s[a..=b],
                                    None,
                                );
                            }
                            Shape::Exact | Shape::Following => {
                                self.plan_direct(
                                    (a, b),
                                    ends,
                                    (lambda, 0.0, shape == Shape::Following),
                                    &mut profile.speed_mm_s[a..=b],
                                    Some(&mut gaps),
                                );
                            }
                            Shape::Programmed => {
                                if share == 0 {
                                    programmed.clone_from(&values.programmed.0);
                                    programmed_accel.clone_from(&values.programmed.1);
                                } else {
                                    programmed.clone_from(&values.seed);
                                    let quicker = self
                                        .plan_programmed(
                                            (a, b),
                                            ends,
                                            sigma,
                                            (&mut programmed, &mut programmed_accel),
                                        )
                                        .is_some_and(|d| d <= next_s);
                                    if !quicker {
                                        break;
                                    }
                                }
                                profile.speed_mm_s[a..=b].copy_from_slice(&programmed);
                            }
                        }
                        let start_s = match previous {
                            None => run.start_s,
                            Some((end_s, w)) => end_s + (w - window_s) / 2.0,
                        };
                        let end_s = profile.push_exact_run(
                            a,
                            b,
                            start_s,
                            (window_s, 0.0),
                            &gaps,
                            (shape == Shape::Programmed).then_some(&programmed_accel[..]),
                        );
                        if let Some(pushed) = profile.runs.last_mut() {
                            pushed.direct = shape != Shape::Filtered;
                        }
                        if profile.last_run_axis_ratio(None) <= 1.0 {
                            kept = Some((end_s, window_s, rank));
                            break;
                        }
                        profile.pop_run();
                    }
                    if kept.is_some() {
                        break;
                    }
                }
                if kept.is_some() {
                    break;
                }
                j += 1;
                skip = 0;
            }
            match kept {
                Some((end_s, window_s, rank)) => {
                    pushed.push((i, previous, rank, j));
                    previous = Some((end_s, window_s));
                    i = j;
                }
                // The section before planned again at its next value that verifies.
                None if backtracks < SECTION_BACKTRACKS && !pushed.is_empty() => {
                    backtracks += 1;
                    let (before, previous_before, rank, end) = pushed.pop().expect("a section");
                    profile.pop_run();
                    resume = Some((before, end, rank + 1));
                    previous = previous_before;
                    i = before;
                }
                None => {
                    verified = false;
                    break;
                }
            }
        }
        self.gaps = gaps;
        // When the next run or section takes over: the filtered motion's end.
        let handover = |end_s: f64, window_s: f64| {
            end_s
                + if v(last) == 0.0 {
                    window_s
                } else {
                    window_s / 2.0
                }
        };
        let quicker = previous.filter(|&(end_s, w)| {
            verified && handover(end_s, w) < handover(run.start_s + run.duration_s, run.window_s)
        });
        if quicker.is_none() {
            while profile.runs.len() > runs_before {
                profile.pop_run();
            }
            profile.speed_mm_s[first..=last].copy_from_slice(&saved);
            profile.push_run(first, last, run.start_s, run.window_s, run.pause_s);
        }
        quicker.map(|(end_s, _)| end_s)
    }
}
