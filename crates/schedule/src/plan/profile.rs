//! The planned profile: its runs between stops (or sections), the gaps they follow
//! exactly, their intervals' times, and what the profile reports of itself.

use crate::direct;
use crate::kinematics::{integral_over_mm_s, interval_time_s};
use crate::machine::ScheduleError;
use crate::slp;
use crate::stations::{CapKind, Stations};

/// A speed within this share below the cap counts as running at the cap.
pub(super) const AT_CAP_SHARE: f64 = 0.005;

/// Motion from one stop to the next, or a section of it ([`RunPlanner::sectioned`](super::run_planner::RunPlanner::sectioned)).
#[derive(Clone, Copy, Debug)]
pub(super) struct Run {
    /// First and last station (stops, or a section's cuts at held caps).
    pub(super) first: usize,
    pub(super) last: usize,
    /// Time the run leaves `first`, s from the program start.
    pub(super) start_s: f64,
    /// Duration of the planned (unfiltered) motion, s.
    pub(super) duration_s: f64,
    /// ∫ (s − s_first) dt over the whole planned run, mm·s.
    pub(super) integral_mm_s: f64,
    /// Width of the run's jerk filter, s (0 without a jerk limit).
    pub(super) window_s: f64,
    /// Rest added before the run by the slowed fallback (see [`plan`](super::plan)), s.
    pub(super) pause_s: f64,
    /// From when the sampler takes this run's filtered motion, s: `start_s` for a run
    /// leaving a stop; for a section of a run leaving a held cap c at speed c
    /// ([`RunPlanner::sectioned`](super::run_planner::RunPlanner::sectioned)), `start_s` + W/2, when the filtered motion is at its
    /// first station (MODEL.md §6.1, "Sections").
    pub(super) switch_s: f64,
    /// Whether the plan is shaped directly (MODEL.md §6.1, "Direct sections").
    pub(super) direct: bool,
    /// The range of [`Profile::gaps`] whose exact jerk-limited motion the run follows
    /// between their stations (MODEL.md §6.1, "Exact direct sections"); empty for a plan
    /// of constant accelerations between stations.
    pub(super) gaps: (usize, usize),
}

/// A gap of a section shaped directly and followed exactly (MODEL.md §6.1, "Exact direct
/// sections"): its motion, its first and last station and the time it leaves the first.
#[derive(Clone, Copy, Debug)]
pub(super) struct ExactGap {
    pub(super) first: usize,
    pub(super) last: usize,
    pub(super) start_s: f64,
    pub(super) motion: Followed,
}

/// The motion a run follows exactly over some of its stations.
#[derive(Clone, Copy, Debug)]
pub(super) enum Followed {
    /// A gap of a section shaped directly (MODEL.md §6.1, "Exact direct sections").
    Gap(direct::Gap),
    /// One interval of a section shaped by linear programs (MODEL.md §6.1, "Sections by
    /// linear programs").
    Piece(slp::Piece),
}

impl Followed {
    /// Time from the first station to `x_mm` past it, s.
    #[cfg(test)]
    pub(super) fn time_at_s(&self, x_mm: f64) -> f64 {
        match self {
            Followed::Gap(g) => g.time_at_s(x_mm),
            Followed::Piece(p) => p.time_at_s(x_mm),
        }
    }

    /// Distance from the first station, mm, and speed, mm/s, `t_s` after leaving it.
    pub(super) fn state_s(&self, t_s: f64) -> (f64, f64) {
        match self {
            Followed::Gap(g) => g.state_s(t_s),
            Followed::Piece(p) => p.state_s(t_s),
        }
    }
}

/// A planned speed profile over [`Stations`].
///
/// Without a jerk limit the motion is piecewise constant acceleration: between stations k and
/// k+1, v² is linear in s, so the time is Δt = 2Δs/(v_k + v_k+1) and s(t) is an exact
/// quadratic. With a jerk limit the planned motion of each run between stops is passed
/// through a moving average of width W in time (see [`plan`](super::plan)).
#[derive(Clone, Debug)]
pub struct Profile<'a> {
    pub(super) stations: &'a Stations,
    pub(super) speed_mm_s: Vec<f64>,
    pub(super) interval_start_s: Vec<f64>,
    /// Each interval's time, held only with a jerk limit (a gap followed exactly takes
    /// its own): without one it is made where it is read from the speeds, the same bits
    /// (a run's speeds are not changed once it is pushed; 8 B a station saved).
    pub(super) interval_dt_s: Vec<f64>,
    /// ∫ (s − s_first of the run) dt from the run start to the start of each interval, mm·s:
    /// read by the jerk filter alone, so held only with a jerk limit (8 B a station).
    pub(super) interval_integral_mm_s: Vec<f64>,
    /// Whether the two columns above are held (the stations have a jerk limit).
    pub(super) timed: bool,
    pub(super) runs: Vec<Run>,
    /// The gaps the runs shaped directly follow exactly, in time order.
    pub(super) gaps: Vec<ExactGap>,
    pub(super) cycle_time_s: f64,
    /// The first run whose samples still broke a limit after the slowed fallback's last
    /// try: [`Profile::sample_count`] and [`Profile::sample`] refuse the profile.
    pub(super) unverified: Option<ScheduleError>,
}

/// What the jerk filter's paths say if the stations have no jerk limit: a filter (W > 0)
/// and sections need one.
pub(super) const FILTER_NEEDS_JERK: &str = "a jerk filter needs a jerk limit";

impl<'a> Profile<'a> {
    /// A profile of no run yet, ending after the first stop's dwell.
    pub(super) fn empty(stations: &'a Stations) -> Self {
        let n = stations.len();
        let intervals = n.saturating_sub(1);
        let timed = stations.interval_jerk_mm_s3().is_some();
        let timed_intervals = if timed { intervals } else { 0 };
        Profile {
            stations,
            speed_mm_s: vec![0.0; n],
            interval_start_s: Vec::with_capacity(intervals),
            interval_dt_s: Vec::with_capacity(timed_intervals),
            interval_integral_mm_s: Vec::with_capacity(timed_intervals),
            timed,
            runs: Vec::with_capacity(stations.stops().len().saturating_sub(1)),
            gaps: Vec::new(),
            // Time line: dwell at a stop, then the run to the next stop (stretched by W if
            // filtered); the profile's end while it is being built.
            cycle_time_s: stations.stops()[0].dwell_s,
            unverified: None,
        }
    }

    /// Appends the run `first..=last` planned into `speed_mm_s`, leaving its first station at
    /// `start_s`: its intervals' times and integrals, and the run. Returns the time the
    /// planned (unfiltered) motion reaches `last`, s.
    pub(super) fn push_run(
        &mut self,
        first: usize,
        last: usize,
        start_s: f64,
        window_s: f64,
        pause_s: f64,
    ) -> f64 {
        self.push_exact_run(first, last, start_s, (window_s, pause_s), &[], None)
    }

    /// [`Profile::push_run`] for a run that follows `gaps` (stations counted from `first`)
    /// exactly between their stations (MODEL.md §6.1, "Exact direct sections"): each of
    /// their intervals takes the time of the gap's motion over it, and the sampler takes
    /// s(t) from that motion.
    pub(super) fn push_exact_run(
        &mut self,
        first: usize,
        last: usize,
        start_s: f64,
        (window_s, pause_s): (f64, f64),
        gaps: &[direct::Gap],
        accel: Option<&[f64]>,
    ) -> f64 {
        assert!(self.timed || gaps.is_empty(), "{FILTER_NEEDS_JERK}");
        let s = self.stations.s_mm();
        let v = &self.speed_mm_s;
        let mut t_s = start_s;
        let mut integral_mm_s = 0.0;
        let gaps_from = self.gaps.len();
        let mut next_gap = gaps.iter().peekable();
        let mut gap_upper_s = 0.0;
        for k in first..last {
            while next_gap.peek().is_some_and(|g| first + g.k <= k) {
                next_gap.next();
            }
            let dt = match next_gap.peek() {
                // A section shaped by linear programs: each interval its piece.
                _ if accel.is_some() => {
                    let a = accel.unwrap_or_default();
                    let piece = slp::Piece::of(&s[first..=last], &v[first..=last], a, k - first);
                    self.gaps.push(ExactGap {
                        first: k,
                        last: k + 1,
                        start_s: t_s,
                        motion: Followed::Piece(piece),
                    });
                    piece.duration_s()
                }
                Some(g) if first + g.i <= k => {
                    let (i, from_mm) = (first + g.i, s[first + g.i]);
                    if k == i {
                        self.gaps.push(ExactGap {
                            first: i,
                            last: first + g.k,
                            start_s: t_s,
                            motion: Followed::Gap(**g),
                        });
                    }
                    // The interval before's upper time is this one's lower (one Newton solve each).
                    let lower_s = if k == i {
                        g.time_at_s(s[k] - from_mm)
                    } else {
                        gap_upper_s
                    };
                    gap_upper_s = g.time_at_s(s[k + 1] - from_mm);
                    gap_upper_s - lower_s
                }
                _ => interval_time_s(s, v, k),
            };
            self.interval_start_s.push(t_s);
            if self.timed {
                self.interval_dt_s.push(dt);
                self.interval_integral_mm_s.push(integral_mm_s);
            }
            let a = (v[k + 1] - v[k]) / dt;
            integral_mm_s += integral_over_mm_s(s[k] - s[first], v[k], a, dt);
            t_s += dt;
        }
        let switch_s = if v[first] > 0.0 {
            start_s + window_s / 2.0
        } else {
            start_s
        };
        self.runs.push(Run {
            first,
            last,
            start_s,
            duration_s: t_s - start_s,
            integral_mm_s,
            window_s,
            pause_s,
            switch_s,
            direct: false,
            gaps: (gaps_from, self.gaps.len()),
        });
        t_s
    }

    /// When the motion leaves each of `stations` (stops of the profile, ascending), s from
    /// the program start: the start of the first run leaving it, its dwell included; the
    /// cycle time for the last station of the path.
    pub(crate) fn leave_times_s(&self, stations: &[usize]) -> Vec<f64> {
        let mut runs = self.runs.iter().peekable();
        stations
            .iter()
            .map(|&station| {
                while runs.peek().is_some_and(|run| run.first < station) {
                    runs.next();
                }
                runs.peek()
                    .filter(|run| run.first == station)
                    .map_or(self.cycle_time_s, |run| run.start_s - run.pause_s)
            })
            .collect()
    }

    /// Removes the run [`Profile::push_run`] appended last.
    pub(super) fn pop_run(&mut self) {
        if let Some(run) = self.runs.pop() {
            self.gaps.truncate(run.gaps.0);
            let intervals = self.interval_start_s.len() - (run.last - run.first);
            self.interval_start_s.truncate(intervals);
            self.interval_dt_s.truncate(intervals);
            self.interval_integral_mm_s.truncate(intervals);
        }
    }

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
        for k in 0..self.interval_start_s.len() {
            let dt = self.interval_dt_s(k);
            time_s[binding(k).index()] += dt / 2.0;
            time_s[binding(k + 1).index()] += dt / 2.0;
        }
        // The filter adds W/2 at each stop of a run (a section's joins add nothing).
        let v = &self.speed_mm_s;
        time_s[CapKind::Acceleration.index()] += self
            .runs
            .iter()
            .map(|r| {
                r.window_s / 2.0
                    * (f64::from(u8::from(v[r.first] == 0.0))
                        + f64::from(u8::from(v[r.last] == 0.0)))
            })
            .sum::<f64>();
        time_s[CapKind::Dwell.index()] +=
            self.stations.stops().iter().map(|s| s.dwell_s).sum::<f64>()
                + self.runs.iter().map(|r| r.pause_s).sum::<f64>();
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

    /// The time over interval `k` (pushed), s: held with a jerk limit, else made again
    /// from the speeds as [`Profile::push_exact_run`] made it (no gap is followed
    /// exactly without a jerk limit).
    pub(super) fn interval_dt_s(&self, k: usize) -> f64 {
        if self.timed {
            self.interval_dt_s[k]
        } else {
            interval_time_s(self.stations.s_mm(), &self.speed_mm_s, k)
        }
    }
}
