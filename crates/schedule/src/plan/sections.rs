//! Sections of a run (MODEL.md §6.1, "Sections"): the run cut at its held caps, each
//! section given the quickest of its values whose samples verify, made ahead in parallel.

use std::ops::Range;

use rayon::prelude::*;

use super::profile::Profile;
use super::run_planner::RunPlanner;
use super::shapes::{Programmed, SectionScratch, SectionValue, SectionValues, Shape, EXACT_SHARES};
use crate::direct;

/// A section that verifies at none of its values is merged with the next, at most this
/// many times (MODEL.md §6.1, "Sections").
pub(super) const SECTION_MERGES: usize = 8;

/// A section that verifies at none of its values (after its merges) has the section
/// before it planned again at its next value that verifies, at most this many times a run
/// (MODEL.md §6.1, "Direct sections").
pub(super) const SECTION_BACKTRACKS: usize = 64;

/// The end of the section kept last: the next section's planned motion starts from it.
#[derive(Clone, Copy, Debug)]
pub(super) struct SectionEnd {
    /// When its planned motion reaches its last cut, s.
    pub(super) end_s: f64,
    /// Its filter's width, s.
    pub(super) window_s: f64,
}

/// A section kept by [`RunPlanner::sectioned`], to plan it again.
#[derive(Clone, Copy, Debug)]
pub(super) struct KeptSection {
    /// Index of its first cut.
    pub(super) first_cut: usize,
    /// The previous section's planned end and window before it.
    pub(super) previous: Option<SectionEnd>,
    /// The rank of its value among its values.
    pub(super) rank: usize,
    /// Index of its last cut.
    pub(super) last_cut: usize,
}

/// A section planned again (the one after it verified at none of its values).
#[derive(Clone, Copy, Debug)]
pub(super) struct Resume {
    /// Index of its first cut.
    pub(super) first_cut: usize,
    /// Index of its last cut.
    pub(super) last_cut: usize,
    /// How many of its values to pass over.
    pub(super) skip: usize,
}

/// The value a section's samples verified at ([`RunPlanner::verified_value`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct KeptValue {
    /// When its planned motion reaches the section's last cut, s.
    pub(super) end_s: f64,
    /// Its filter's width, s.
    pub(super) window_s: f64,
    /// Its rank among the section's values.
    pub(super) rank: usize,
}

impl<'a> RunPlanner<'a> {
    /// Sections of the run the profile holds last, planned as that run was (`kept` =
    /// (λ, W)), with a window of their own (MODEL.md §6.1, "Sections"): the run is cut at
    /// the stations where its plan runs at the station's cap c and is flat at c over
    /// c·W/2 on either side ([`RunPlanner::cuts`]); each section between two cuts (or a
    /// stop) is planned by [`RunPlanner::plan_section`] at each λ of
    /// [`SECTION_GRID`](super::shapes::SECTION_GRID) (W = λ·`base_window_s`) and at
    /// `kept`, a section between speeds > 0 also shaped directly
    /// ([`RunPlanner::direct_window`] at each of
    /// [`DIRECT_SHARES`](super::shapes::DIRECT_SHARES)) and followed exactly
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
    /// ahead, `ahead_stations` at a time, in parallel (rayon,
    /// [`RunPlanner::values_ahead`]), and verified in order as before; the profile is the
    /// same bit for bit at any thread count.
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
        let saved = profile.speed_mm_s[first..=last].to_vec();
        let v = |k: usize| saved[k - first];
        let cuts = self.cuts((first, last), &saved, window0_s)?;
        profile.pop_run();
        let runs_before = profile.runs.len();
        let mut gaps = std::mem::take(&mut self.gaps);
        // The speeds and accelerations shaped by linear programs at the share tried.
        let mut programmed = Programmed::default();
        // The values of the sections between two neighbouring cuts, made ahead of the loop
        // in parallel, a run of them at a time: those of `cuts[done.start + k]..=cuts[
        // done.start + k + 1]` at `ahead[k]`, for `done.start + k` < `done.end`; those of
        // merged sections and of sections before `done.start` (planned again) are made
        // where they are needed.
        let mut ahead: Vec<SectionValues> = Vec::new();
        let mut done: Range<usize> = 0..0;
        let mut scratch = SectionScratch::default();
        let own = (base_window_s, (lambda0, window0_s));
        // The previous section's planned end and window (a run leaving at speed: its
        // start and window, so that its first section's filtered motion reaches the
        // first station when the run's did).
        let mut previous: Option<SectionEnd> = (v(first) > 0.0).then_some(SectionEnd {
            end_s: run.start_s,
            window_s: run.window_s,
        });
        let mut verified = true;
        let mut i = 0;
        // The sections kept, to plan one again.
        let mut pushed: Vec<KeptSection> = Vec::new();
        // A section planned again (the one after it verified at none of its values).
        let mut resume: Option<Resume> = None;
        let mut backtracks = 0;
        while i + 1 < cuts.len() {
            let a = cuts[i];
            let mut kept = None;
            let (mut j, mut skip) = match resume.take() {
                Some(again) if again.first_cut == i => (again.last_cut, again.skip),
                _ => (i + 1, 0),
            };
            // A section that verifies at none of its values is merged with the next one.
            while j < cuts.len() && j <= i + SECTION_MERGES {
                let b = cuts[j];
                let ends = (v(a), v(b));
                if j == i + 1 && i >= done.end {
                    let end;
                    (ahead, end) = self.values_ahead(&cuts, i, (first, &saved), own);
                    done = i..end;
                }
                let made;
                let values = if j == i + 1 && done.contains(&i) {
                    &ahead[i - done.start]
                } else {
                    made = self.section_values((a, b), ends, own, &mut scratch);
                    &made
                };
                kept = self.verified_value(
                    profile,
                    ((a, b), ends),
                    (values, skip),
                    (run.start_s, previous),
                    (&mut gaps, &mut programmed),
                );
                if kept.is_some() {
                    break;
                }
                j += 1;
                skip = 0;
            }
            match kept {
                Some(KeptValue {
                    end_s,
                    window_s,
                    rank,
                }) => {
                    pushed.push(KeptSection {
                        first_cut: i,
                        previous,
                        rank,
                        last_cut: j,
                    });
                    previous = Some(SectionEnd { end_s, window_s });
                    i = j;
                }
                // The section before planned again at its next value that verifies.
                None if backtracks < SECTION_BACKTRACKS && !pushed.is_empty() => {
                    backtracks += 1;
                    let before = pushed.pop().expect("a section");
                    profile.pop_run();
                    resume = Some(Resume {
                        first_cut: before.first_cut,
                        last_cut: before.last_cut,
                        skip: before.rank + 1,
                    });
                    previous = before.previous;
                    i = before.first_cut;
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
        let quicker = previous.filter(|&SectionEnd { end_s, window_s: w }| {
            verified && handover(end_s, w) < handover(run.start_s + run.duration_s, run.window_s)
        });
        if quicker.is_none() {
            while profile.runs.len() > runs_before {
                profile.pop_run();
            }
            profile.speed_mm_s[first..=last].copy_from_slice(&saved);
            profile.push_run(first, last, run.start_s, run.window_s, run.pause_s);
        }
        quicker.map(|SectionEnd { end_s, .. }| end_s)
    }

    /// The cuts of the run `first..=last` planned as `saved` (its stations' speeds, from
    /// `first`) at the window `window0_s` ([`RunPlanner::sectioned`]): `first`, the
    /// stations where the plan runs at the station's cap c, is flat at c over c·W/2 (plus
    /// the largest station spacing) on either side and is c·W from the cut before and
    /// from `last`, and `last`; `None` where no station inside is one.
    fn cuts(
        &self,
        (first, last): (usize, usize),
        saved: &[f64],
        window0_s: f64,
    ) -> Option<Vec<usize>> {
        let s = self.stations.s_mm();
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
        Some(cuts)
    }

    /// The values of the sections between neighbouring `cuts` from the `i`-th on, as
    /// many as hold about `ahead_stations` stations, made in parallel (rayon), in order,
    /// each between the speeds of `saved` (the run's stations' speeds, from `first`) at
    /// its cuts; and the index of the cut after the last of them.
    fn values_ahead(
        &self,
        cuts: &[usize],
        i: usize,
        (first, saved): (usize, &[f64]),
        own: (f64, (f64, f64)),
    ) -> (Vec<SectionValues>, usize) {
        let v = |k: usize| saved[k - first];
        let a = cuts[i];
        // The next sections, as many as hold about `ahead_stations` stations.
        let mut end = i + 1;
        while end + 1 < cuts.len() && cuts[end] - a < self.ahead_stations {
            end += 1;
        }
        let ahead = (i..end)
            .into_par_iter()
            .map_init(SectionScratch::default, |scratch, k| {
                let section = (cuts[k], cuts[k + 1]);
                let ends = (v(section.0), v(section.1));
                self.section_values(section, ends, own, scratch)
            })
            .collect();
        (ahead, end)
    }

    /// The first of the section `a..=b`'s `values` (between the speeds `ends`), past the
    /// first `skip`, whose samples verify, pushed onto `profile` after the previous
    /// section's end (`previous`; `None`: the run's start, `run_start_s`); `None`
    /// (nothing pushed) where none does. A value shaped by linear programs is tried at
    /// each of [`EXACT_SHARES`] while it is quicker than the next value. `gaps` and
    /// `programmed` are the buffers the values are planned into.
    fn verified_value(
        &self,
        profile: &mut Profile<'_>,
        ((a, b), ends): ((usize, usize), (f64, f64)),
        (values, skip): (&SectionValues, usize),
        (run_start_s, previous): (f64, Option<SectionEnd>),
        (gaps, programmed): (&mut Vec<direct::Gap>, &mut Programmed),
    ) -> Option<KeptValue> {
        let timed = &values.timed;
        for (
            rank,
            &SectionValue {
                value: lambda,
                window_s,
                shape,
                ..
            },
        ) in timed.iter().enumerate().skip(skip)
        {
            // A value shaped by linear programs whose samples do not verify is shaped
            // again at the next shares of the jerk limit, each while it is quicker
            // than the next value.
            let next_s = timed.get(rank + 1).map_or(f64::INFINITY, |x| x.time_s);
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
                            Some(&mut *gaps),
                        );
                    }
                    Shape::Programmed => {
                        if share == 0 {
                            programmed
                                .speed_mm_s
                                .clone_from(&values.programmed.speed_mm_s);
                            programmed
                                .accel_mm_s2
                                .clone_from(&values.programmed.accel_mm_s2);
                        } else {
                            programmed.speed_mm_s.clone_from(&values.seed);
                            let quicker = self
                                .plan_programmed(
                                    (a, b),
                                    ends,
                                    sigma,
                                    (&mut programmed.speed_mm_s, &mut programmed.accel_mm_s2),
                                )
                                .is_some_and(|d| d <= next_s);
                            if !quicker {
                                break;
                            }
                        }
                        profile.speed_mm_s[a..=b].copy_from_slice(&programmed.speed_mm_s);
                    }
                }
                let start_s = match previous {
                    None => run_start_s,
                    Some(SectionEnd { end_s, window_s: w }) => end_s + (w - window_s) / 2.0,
                };
                let end_s = profile.push_exact_run(
                    a,
                    b,
                    start_s,
                    (window_s, 0.0),
                    gaps,
                    (shape == Shape::Programmed).then_some(&programmed.accel_mm_s2[..]),
                );
                if let Some(pushed) = profile.runs.last_mut() {
                    pushed.direct = shape != Shape::Filtered;
                }
                if profile.last_run_axis_ratio(None) <= 1.0 {
                    return Some(KeptValue {
                        end_s,
                        window_s,
                        rank,
                    });
                }
                profile.pop_run();
            }
        }
        None
    }
}
