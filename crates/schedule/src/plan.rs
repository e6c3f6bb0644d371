//! Time-optimal speed profile along the stations, and servo sampling of it.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::direct;
use crate::kinematics::{integral_over_mm_s, interval_accel_mm_s2, interval_time_s};
use crate::machine::ScheduleError;
use crate::range_min::RangeMin;
use crate::slp;
use crate::stations::{CapKind, Stations, Stop};

/// A speed within this share below the cap counts as running at the cap.
const AT_CAP_SHARE: f64 = 0.005;

/// A stencil of servo samples whose second or third difference broke an axis' limit.
#[derive(Clone, Copy, Debug)]
struct Violation {
    /// Arc lengths of its first and last sample, mm.
    s_mm: (f64, f64),
    /// Highest sampled speed in it, mm/s.
    speed_mm_s: f64,
    /// Its difference over the limit.
    ratio: f64,
    /// Whether its newest sample's feed is over its cap.
    over_cap: bool,
}

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

/// Motion from one stop to the next, or a section of it ([`RunPlanner::sectioned`]).
#[derive(Clone, Copy, Debug)]
struct Run {
    /// First and last station (stops, or a section's cuts at held caps).
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
    /// Rest added before the run by the slowed fallback (see [`plan`]), s.
    pause_s: f64,
    /// From when the sampler takes this run's filtered motion, s: `start_s` for a run
    /// leaving a stop; for a section of a run leaving a held cap c at speed c
    /// ([`RunPlanner::sectioned`]), `start_s` + W/2, when the filtered motion is at its
    /// first station (MODEL.md §6.1, "Sections").
    switch_s: f64,
    /// Whether the plan is shaped directly (MODEL.md §6.1, "Direct sections").
    direct: bool,
    /// The range of [`Profile::gaps`] whose exact jerk-limited motion the run follows
    /// between their stations (MODEL.md §6.1, "Exact direct sections"); empty for a plan
    /// of constant accelerations between stations.
    gaps: (usize, usize),
}

/// A gap of a section shaped directly and followed exactly (MODEL.md §6.1, "Exact direct
/// sections"): its motion, its first and last station and the time it leaves the first.
#[derive(Clone, Copy, Debug)]
struct ExactGap {
    first: usize,
    last: usize,
    start_s: f64,
    motion: Followed,
}

/// The motion a run follows exactly over some of its stations.
#[derive(Clone, Copy, Debug)]
enum Followed {
    /// A gap of a section shaped directly (MODEL.md §6.1, "Exact direct sections").
    Gap(direct::Gap),
    /// One interval of a section shaped by linear programs (MODEL.md §6.1, "Sections by
    /// linear programs").
    Piece(slp::Piece),
}

impl Followed {
    /// Time from the first station to `x_mm` past it, s.
    #[cfg(test)]
    fn time_at_s(&self, x_mm: f64) -> f64 {
        match self {
            Followed::Gap(g) => g.time_at_s(x_mm),
            Followed::Piece(p) => p.time_at_s(x_mm),
        }
    }

    /// Distance from the first station, mm, and speed, mm/s, `t_s` after leaving it.
    fn state_s(&self, t_s: f64) -> (f64, f64) {
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
/// through a moving average of width W in time (see [`plan`]).
#[derive(Clone, Debug)]
pub struct Profile<'a> {
    stations: &'a Stations,
    speed_mm_s: Vec<f64>,
    interval_start_s: Vec<f64>,
    /// Each interval's time, held only with a jerk limit (a gap followed exactly takes
    /// its own): without one it is made where it is read from the speeds, the same bits
    /// (a run's speeds are not changed once it is pushed; 8 B a station, issue 16).
    interval_dt_s: Vec<f64>,
    /// ∫ (s − s_first of the run) dt from the run start to the start of each interval, mm·s:
    /// read by the jerk filter alone, so held only with a jerk limit (8 B a station).
    interval_integral_mm_s: Vec<f64>,
    /// Whether the two columns above are held (the stations have a jerk limit).
    timed: bool,
    runs: Vec<Run>,
    /// The gaps the runs shaped directly follow exactly, in time order.
    gaps: Vec<ExactGap>,
    cycle_time_s: f64,
    /// The first run whose samples still broke a limit after the slowed fallback's last
    /// try: [`Profile::sample_count`] and [`Profile::sample`] refuse the profile.
    unverified: Option<ScheduleError>,
}

/// Most servo samples one profile may produce (about 60 bytes each, 1.2 GB at the bound).
pub const MAX_SAMPLES: usize = 20_000_000;

/// Runs with at most this many stations get the jerk-limited search over the acceleration
/// share λ (short moves, where the time-optimal profile does not reach the full acceleration);
/// longer runs plan at λ = 1.
const LAMBDA_SEARCH_MAX_STATIONS: usize = 4000;
/// The values of λ planned on longer runs, tried by the time of their plans.
const LAMBDA_GRID: [f64; 5] = [1.0, 0.85, 0.7, 0.55, 0.4];
/// Runs with more stations than this plan at λ = 1 only: each λ tried plans and checks the
/// whole run again (the 1 M-block raster's run of 3 M stations took 10.9 s of plan CPU
/// with the grid against about 1.8 s, for the same cycle).
const LAMBDA_GRID_MAX_STATIONS: usize = 500_000;

/// The plan `v` stays at the held end speed `c` over the stations from `end` on (in the
/// order `stations` gives) until they are c·W/2 from it (MODEL.md §6.1, "Sections"): the
/// filtered motion is then at `end`'s station with speed `c` when the next section takes
/// over.
fn held_at(
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

/// The filter window at λ = 1, s: the largest a/j over the stations'
/// intervals (0 without a jerk limit; MODEL.md §6.1).
fn base_window_s(stations: &Stations) -> f64 {
    stations.interval_jerk_mm_s3().map_or(0.0, |jerk| {
        stations
            .interval_accel_mm_s2()
            .iter()
            .zip(jerk)
            .map(|(a, j)| a / j)
            .fold(0.0, f64::max)
    })
}

/// What the jerk filter's paths say if the stations have no jerk limit: a filter (W > 0)
/// and sections need one.
const FILTER_NEEDS_JERK: &str = "a jerk filter needs a jerk limit";

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
///   station the plan without holds touches is extended over c·W/2 on either side, so
///   the plan rests at that speed for W and the filtered speed is at most c there; a
///   corner whose samples need it gets c·(W + 3T)/2 (the filtered speed is then
///   constant for 3T around the corner, the sampling stencil of its velocity step; see
///   [`RunPlanner::restore_holds`]); caps the plan without holds stays below need no
///   hold;
/// * every local maximum that is held for less than W is cut flat at the highest level c
///   where it is held for c·W;
/// * except where the accelerations on both sides are so small that the filter's jerk
///   across the sign change, at most (A₁ + A₂)/W, is within j/2: such a peak is not cut,
///   and such a cap is lowered to a V at its station instead of held (slow dips and
///   peaks, see [`RunPlanner::extend_caps`] and [`RunPlanner::cut_peaks`]).
///
/// A trapezoid with accelerations of at least W filtered this way is exactly the 7-segment
/// S-curve, so a rest-to-rest move is time-optimal for the best λ; λ is searched on short
/// runs (golden section), λ = 1 elsewhere. Averaging keeps the path geometry exact (the
/// filter acts on s(t), not on the axes), keeps stops and dwells exact, and costs W per run.
/// On curved paths the jerk bound is tangential only (the normal jerk d(v²κ)/dt is not
/// limited).
///
/// Verified runs (MODEL.md §6.1): these rules bound the sampled axis differences only
/// approximately, so each run is kept only once its servo samples (those
/// [`Profile::sample`] makes at the machine's period) have every per-axis second difference
/// within a_i and third difference within j_i, and every feed within its cap: the
/// candidate λ values in order (the first one with the full holds restored at the corners
/// near failing stencils), then the first
/// one repaired (filter widened, or caps lowered around the failing stencils), then
/// slowed in time until it verifies.
pub fn plan(stations: &Stations) -> Profile<'_> {
    plan_ahead(stations, AHEAD_STATIONS)
}

/// [`plan`], with the values of a run's sections made ahead, in parallel, up to about
/// `ahead_stations` stations at a time (0: one section at a time, where it is reached;
/// the profile is the same bit for bit).
fn plan_ahead(stations: &Stations, ahead_stations: usize) -> Profile<'_> {
    let base_window_s = base_window_s(stations);
    let stops = stations.stops();
    let mut planner = RunPlanner::new(stations);
    planner.ahead_stations = ahead_stations;
    let mut profile = Profile::empty(stations);
    let mut candidates = Vec::new();
    for pair in stops.windows(2) {
        let (first, last) = (pair[0].station, pair[1].station);
        candidates.clear();
        if base_window_s > 0.0 && last - first <= LAMBDA_SEARCH_MAX_STATIONS {
            planner.lambda_candidates(first, last, base_window_s, &mut candidates);
        } else if base_window_s > 0.0 && last - first <= LAMBDA_GRID_MAX_STATIONS {
            planner.lambda_grid(first, last, base_window_s, &mut candidates);
        } else {
            candidates.push(1.0);
        }
        let (mut end_s, verified, kept) = planner.verified_run(
            &mut profile,
            (pair[0], pair[1]),
            base_window_s,
            &candidates,
            (REPAIR_MAX_TRIES, SLOW_MAX_TRIES),
        );
        // Sections on runs the grid of λ is tried on, or the search (not on longer runs:
        // each value plans the whole run once more, for little on the 1 M-block raster).
        if base_window_s > 0.0
            && last - first <= LAMBDA_GRID_MAX_STATIONS
            && !matches!(verified, Verified::Slowed { .. })
        {
            if let Some(sectioned_end_s) = planner.sectioned(&mut profile, base_window_s, kept) {
                end_s = sectioned_end_s;
            }
        }
        let window_s = profile.runs.last().map_or(0.0, |run| run.window_s);
        profile.cycle_time_s = end_s + (window_s + pair[1].dwell_s);
    }
    profile
}

/// Which plan of a run [`RunPlanner::verified_run`] kept.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Verified {
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

/// The values of λ each section of a run tries (MODEL.md §6.1, "Sections"): 0.8^k,
/// k = 0..14, from 1 to 0.055.
const SECTION_GRID: [f64; 14] = [
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
const DIRECT_SHARES: [f64; 3] = [0.5, 0.75, 0.9];
/// The shares σ of the jerk limit a section shaped directly and followed exactly, without
/// a filter, is tried at (MODEL.md §6.1, "Exact direct sections"): its motion's jerk is
/// within σ·J at every instant, so σ = 1 keeps the tangential limit; the lower shares
/// leave room for the path's curvature in the sampled axis differences.
const EXACT_SHARES: [f64; 3] = [1.0, 0.9, 0.75];

/// How a section's value is planned ([`RunPlanner::sectioned`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
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
const PROGRAMMED_EXCESS_MIN_S: f64 = 0.01;
/// ... and it has at most this many stations.
const PROGRAMMED_MAX_STATIONS: usize = 1_000;

/// Time of a plan `v` over stations `s` that follows `gaps` (counted from `s[0]`) exactly
/// and has constant accelerations elsewhere, s (MODEL.md §6.1, "Exact direct sections").
fn exact_time_s(s: &[f64], v: &[f64], gaps: &[direct::Gap]) -> f64 {
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
const DIRECT_WINDOW_MIN_S: f64 = 1e-3;

/// Intervals whose acceleration limit is at most this times the period T times their jerk
/// limit as shaped (σ·j: a ≤ σ·j·T/3, slow corners' intervals) widen a dip of a section
/// shaped directly ([`direct::shape`]'s `slow_share`).
const DIRECT_SLOW_PERIODS: f64 = 1.0 / 3.0;

/// A section that verifies at none of its values is merged with the next, at most this
/// many times (MODEL.md §6.1, "Sections").
const SECTION_MERGES: usize = 8;

/// A section kept by [`RunPlanner::sectioned`]: its first cut, the previous section's
/// planned end and window before it, the rank of its value among its values, its last cut.
type KeptSection = (usize, Option<(f64, f64)>, usize, usize);

/// A section's values before any is verified ([`RunPlanner::section_values`]): a function
/// of its stations, their caps and the speeds at its ends alone, so the sections of a run
/// can be made in parallel ([`RunPlanner::sectioned`]).
#[derive(Default)]
struct SectionValues {
    /// (time, λ or σ, W, how it is shaped), quickest first.
    timed: Vec<(f64, f64, f64, Shape)>,
    /// The linear programs' first iterate: the quickest exact value's speeds, else the
    /// floor's passes (empty where `timed` holds no value shaped by them).
    seed: Vec<f64>,
    /// The speeds and accelerations shaped by linear programs at the first of
    /// [`EXACT_SHARES`] (empty where `timed` holds no value shaped by them).
    programmed: (Vec<f64>, Vec<f64>),
}

/// Buffers [`RunPlanner::section_values`] plans into: one speed a station of the section,
/// and the gaps of a section followed exactly.
#[derive(Default)]
struct SectionScratch {
    trial: Vec<f64>,
    gaps: Vec<direct::Gap>,
}

/// [`RunPlanner::sectioned`] makes the values of the sections after the one it reaches
/// ahead, in parallel, up to about this many stations at a time (the memory the values
/// ahead hold: their speeds shaped by linear programs, 24 B a station at most).
const AHEAD_STATIONS: usize = 1 << 15;

/// A section that verifies at none of its values (after its merges) has the section
/// before it planned again at its next value that verifies, at most this many times a run
/// (MODEL.md §6.1, "Direct sections").
const SECTION_BACKTRACKS: usize = 64;

/// Tries of the first fallback (full corner holds restored where samples break a limit).
const RESTORE_MAX_TRIES: usize = 4;
/// Tries of the second fallback (caps lowered where samples break a limit).
const REPAIR_MAX_TRIES: usize = 8;

/// ... which divides the filter's width by this (its jerk then at most 0.98·j) where more
/// than [`FEW_VIOLATIONS`] stencils break a limit, and lowers the caps around them where
/// no more do.
const WIDEN: f64 = 0.98;
/// See [`WIDEN`].
const FEW_VIOLATIONS: usize = 3;
/// The slowed fallback multiplies σ by at most this each try (and the first fallback a
/// cap over the speed of the samples that break a limit).
const SLOW_STEP: f64 = 0.95;
/// ... and by this over the worst ratio of a sampled difference to its limit, if less.
const SLOW_MARGIN: f64 = 0.99;
/// Guard on the slowed fallback's tries: σ = 0.95^300 ≈ 2·10⁻⁷ (MODEL.md §6.1 argues that
/// σ ≤ 1/K verifies, K the run's own bound). A run still unverified then makes the
/// profile refuse to be sampled ([`ScheduleError::UnverifiedRun`]).
const SLOW_MAX_TRIES: usize = 300;

/// Plans single runs; reuses its buffers between runs and between trials of λ.
struct RunPlanner<'a> {
    stations: &'a Stations,
    /// The stations' caps, mm/s; lowered where a run's samples broke a limit.
    caps_mm_s: Vec<f64>,
    /// Largest station spacing of the path, mm.
    ds_max_mm: f64,
    is_corner: Vec<bool>,
    /// Corners held over c·(W + 3T)/2 (the others over c·W/2, as touched caps): set where
    /// a run's samples broke a limit (MODEL.md §6.1, "Local corner holds").
    full_hold: Vec<bool>,
    /// Stations planned by the plain rules (a hold at every held cap, every short peak
    /// cut), not by the slow dips' and peaks' exceptions: set where a run's sample near
    /// them was over its cap (MODEL.md §6.1, "Slow dips and peaks").
    plain: Vec<bool>,
    /// A plan tried beside the profile's (λ searched, sections): made at the first
    /// ([`RunPlanner::take_trial`]), none without a jerk limit (8 B a station, issue 16).
    trial: Vec<f64>,
    /// The gaps of a section shaped directly and followed exactly.
    gaps: Vec<direct::Gap>,
    /// How many stations of sections [`RunPlanner::sectioned`] makes the values of ahead,
    /// in parallel ([`AHEAD_STATIONS`]).
    ahead_stations: usize,
}

impl<'a> RunPlanner<'a> {
    fn new(stations: &'a Stations) -> Self {
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
    fn take_trial(&mut self) -> Vec<f64> {
        let mut trial = std::mem::take(&mut self.trial);
        trial.resize(self.stations.len(), 0.0);
        trial
    }

    /// Plans the run between the stops `stops` into `profile` (appended, leaving at the
    /// profile's current end) so that its servo samples keep every axis' limits
    /// ([`Profile::last_run_axis_ratio`]; MODEL.md §6.1): the first of `candidates` (values
    /// of λ) that verifies; else the first candidate with its caps lowered around the
    /// samples that break a limit, up to `repair_tries` times; else that plan slowed in time
    /// by σ, σ lowered each try, after a rest that keeps the samples' stencils off the run
    /// before. `tries` = (repairs, slowed tries) at most. Returns when the planned motion
    /// reaches the run's last stop, s, and which plan was kept. A run that still breaks a
    /// limit after the last slowed try is kept, and marks the profile unverified: its
    /// samples are refused ([`ScheduleError::UnverifiedRun`]).
    fn verified_run(
        &mut self,
        profile: &mut Profile<'_>,
        stops: (Stop, Stop),
        base_window_s: f64,
        candidates: &[f64],
        (repair_tries, slow_tries): (usize, usize),
    ) -> (f64, Verified, (f64, f64)) {
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
                return (
                    end_s,
                    Verified::Candidate(index),
                    (lambda, lambda * base_window_s),
                );
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
                    return (
                        end_s,
                        Verified::Restored(restores),
                        (lambda, lambda * base_window_s),
                    );
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
                return (end_s, Verified::Repaired(repairs), (lambda, window_s));
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
                return (
                    end_s,
                    Verified::Slowed { tries, slow },
                    (lambda, window_s / slow),
                );
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
    fn restore_holds(
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
    fn lower_caps(&mut self, first: usize, last: usize, violations: &[Violation]) {
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

    /// The candidate λ values of a run too long for the search: those of [`LAMBDA_GRID`],
    /// by the time of their plans (planned time + W, before any check), quickest first.
    fn lambda_grid(
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
    fn lambda_candidates(
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
    /// filter needs (see [`plan`]). Returns the planned (unfiltered) time, s.
    ///
    /// `slow` = σ ≤ 1 slows the run in time: caps σ·c, accelerations σ²·λ·a, the corners'
    /// 3T of hold 3T/σ; with `window_s` = W/σ the planned and filtered motions are the σ = 1
    /// ones run σ times slower (speeds σ·v, accelerations σ², jerks σ³).
    fn plan_run(
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

    /// Plans the section `first..=last` of a run into `v` (its stations' speeds, from
    /// `first`; MODEL.md §6.1, "Sections"): as
    /// [`RunPlanner::plan_run`] at σ = 1, but from the speed `ends.0` at `first` to
    /// `ends.1` at `last` (0: a stop), each end at speed a held cap (c·W/2 of hold into the
    /// section, never a slow dip). Returns the planned time, s, or `None` where the plan is
    /// not flat at the end's speed over c·W/2 from a flying end: the filtered motion of
    /// the section is then not at that end's station with the end's speed when the next
    /// section takes over.
    fn plan_section(
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
    fn shared_jerk(&self, (first, last): (usize, usize), share: f64) -> Vec<f64> {
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
    fn filter_envelope(
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
    fn plan_direct(
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
    fn plan_programmed(
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
    fn direct_window(
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
    fn section_values(
        &self,
        (a, b): (usize, usize),
        ends: (f64, f64),
        (base_window_s, own): (f64, (f64, f64)),
        scratch: &mut SectionScratch,
    ) -> SectionValues {
        let s = &self.stations.s_mm()[a..=b];
        let window0_s = own.1;
        let mut timed: Vec<(f64, f64, f64, Shape)> = Vec::with_capacity(
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
        let mut programmed = (Vec::new(), Vec::new());
        for (lambda, window_s) in values {
            if let Some(d) = self.plan_section((a, b), (lambda, window_s), ends, trial) {
                timed.push((
                    d + rests * window_s / 2.0,
                    lambda,
                    window_s,
                    Shape::Filtered,
                ));
            }
        }
        // Shaped directly (not from or to a stop: there the plan's first interval is long
        // in time).
        if ends.0 > 0.0 && ends.1 > 0.0 {
            let bounds = (DIRECT_WINDOW_MIN_S, window0_s);
            for &share in &DIRECT_SHARES {
                if let Some((d, window_s)) = self.direct_window((a, b), ends, share, bounds, trial)
                {
                    timed.push((d, share, window_s, Shape::Direct));
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
                        timed.push((d, share, 0.0, shape));
                    }
                }
            }
            // Shaped by linear programs, from the quickest exact value (else from the
            // floor's passes), where the values leave enough over the floor.
            if b - a < PROGRAMMED_MAX_STATIONS {
                let best = timed.iter().fold(f64::INFINITY, |m, x| m.min(x.0));
                let floor = &mut trial[..];
                floor.copy_from_slice(&self.caps_mm_s[a..=b]);
                self.passes_between(a, 1.0, floor, ends);
                let floor_s: f64 = (0..b - a).map(|k| interval_time_s(s, floor, k)).sum();
                if seed.is_empty() {
                    seed.extend_from_slice(floor);
                }
                if best - floor_s > PROGRAMMED_EXCESS_MIN_S {
                    let (speeds, accels) = &mut programmed;
                    speeds.extend_from_slice(&seed);
                    accels.resize(speeds.len(), 0.0);
                    let share = EXACT_SHARES[0];
                    if let Some(d) = self.plan_programmed((a, b), ends, share, (speeds, accels)) {
                        timed.push((d, share, 0.0, Shape::Programmed));
                    }
                }
            }
        }
        timed.sort_by(|x, y| x.0.total_cmp(&y.0));
        if !timed.iter().any(|x| x.3 == Shape::Programmed) {
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

    /// Sections of the run the profile holds last, planned as that run was (`kept` =
    /// (λ, W)), with a window of their own (MODEL.md §6.1, "Sections"): the run is cut at
    /// the stations where its plan runs at the station's cap c and is flat at c over
    /// c·W/2 on either side; each section between two cuts (or a stop) is planned by
    /// [`RunPlanner::plan_section`] at each λ of [`SECTION_GRID`] (W = λ·`base_window_s`)
    /// and at `kept`, a section between speeds > 0 also shaped directly
    /// ([`RunPlanner::direct_window`] at each of [`DIRECT_SHARES`]) and followed exactly
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
    fn sectioned(
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

    /// The forward/backward passes over stations `first..first + v.len()` (a run: rest at
    /// both ends), accelerations scaled by `lambda`: v becomes the highest speed profile
    /// under the caps it holds.
    fn passes(&self, first: usize, lambda: f64, v: &mut [f64]) {
        self.passes_between(first, lambda, v, (0.0, 0.0));
    }

    /// [`RunPlanner::passes`] with the speeds `ends` at the first and last station
    /// instead of rest (a section, [`RunPlanner::sectioned`]).
    fn passes_between(&self, first: usize, lambda: f64, v: &mut [f64], ends: (f64, f64)) {
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
    fn extend_caps(
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
        for (j, vj) in v.iter_mut().enumerate() {
            *vj = vj.min(tree.get(j)[0]);
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
    fn cut_peaks(&self, first: usize, last: usize, window_s: f64, slow: f64, v: &mut [f64]) {
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
const JERK_SHARE: f64 = 0.5;

/// A slow dip's lowered cap (see [`RunPlanner::extend_caps`]), mm/s, or `None` where the
/// station is to be held: the cap `cap` (mm/s) of a station whose hold reaches `reach_mm`
/// before and after it over intervals of tangential acceleration and jerk limits
/// `limits`, planned with (λ, W, σ) = `plan`. A = λ·max a_k over those intervals; a dip
/// needs 2A ≤ j·σ³·W/2 (j their least jerk limit), a lowered cap c − 1.1·A·W/4 > 0, and a
/// V from it at A crossing the hold's reach in less time than the hold at c does.
fn slow_dip_mm_s(
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

/// Where a planned run is at a time: arc length, speed and ∫ (s − s_first) dt.
#[derive(Clone, Copy, Debug)]
struct RunState {
    s_mm: f64,
    v_mm_s: f64,
    integral_mm_s: f64,
}

impl<'a> Profile<'a> {
    /// A profile of no run yet, ending after the first stop's dwell.
    fn empty(stations: &'a Stations) -> Self {
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
    fn push_run(
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
    fn push_exact_run(
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

    /// Removes the run [`Profile::push_run`] appended last.
    fn pop_run(&mut self) {
        if let Some(run) = self.runs.pop() {
            self.gaps.truncate(run.gaps.0);
            let intervals = self.interval_start_s.len() - (run.last - run.first);
            self.interval_start_s.truncate(intervals);
            self.interval_dt_s.truncate(intervals);
            self.interval_integral_mm_s.truncate(intervals);
        }
    }

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
    fn last_run_axis_ratio(&self, mut violations: Option<&mut Vec<Violation>>) -> f64 {
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

    /// The time over interval `k` (pushed), s: held with a jerk limit, else made again
    /// from the speeds as [`Profile::push_exact_run`] made it (no gap is followed
    /// exactly without a jerk limit).
    fn interval_dt_s(&self, k: usize) -> f64 {
        if self.timed {
            self.interval_dt_s[k]
        } else {
            interval_time_s(self.stations.s_mm(), &self.speed_mm_s, k)
        }
    }

    /// State of run `run` at time `t_s`, searching intervals from `*cursor` on (monotone).
    fn run_state(&self, run: &Run, t_s: f64, cursor: &mut usize) -> RunState {
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
struct Sampler<'p, 'a> {
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
    fn starting_at(profile: &'p Profile<'a>, t_s: f64) -> Self {
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

    fn at(&mut self, t_s: f64) -> ServoSample {
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

#[cfg(test)]
mod tests {
    use nalgebra::Point3;
    use nc::{Geometry, Motion, Path, Segment};

    use super::*;
    use crate::machine::Machine;
    use crate::stations::FeedPolicy;

    fn line(start: Point3<f64>, end: Point3<f64>, motion: Motion) -> Segment {
        Segment {
            start,
            end,
            geometry: Geometry::Line,
            motion,
            line: 1,
            spindle_rpm: 10000.0,
            tool: 1,
        }
    }

    /// Without a jerk limit a profile holds neither its intervals' times nor their
    /// integrals (issue 16): each interval's time, made again from the speeds, is the one
    /// its run was timed with when it was pushed, bit for bit (every interval's start is
    /// the one before's plus it), though later runs were planned after it; its samples
    /// then follow the plan, and its time shares add up to the cycle.
    #[test]
    fn a_profile_without_a_jerk_limit_makes_its_intervals_times_again() {
        let feed = Motion::feed(3000.0);
        let points: Vec<Point3<f64>> = (0..=200)
            .map(|i| {
                let x = i as f64 * 0.2;
                Point3::new(x, 5.0 * (x / 4.0).sin(), 0.0)
            })
            .collect();
        let mut segments: Vec<Segment> =
            points.windows(2).map(|w| line(w[0], w[1], feed)).collect();
        // A dwell in the middle: two runs.
        let middle = segments[100].start;
        let mut dwell = line(middle, middle, Motion::Dwell { seconds: 0.5 });
        dwell.geometry = Geometry::Line;
        segments.insert(100, dwell);
        let st = Stations::new(
            &Path { segments },
            &Machine::default(),
            0.05,
            FeedPolicy::Programmed,
        )
        .unwrap();
        assert!(st.interval_jerk_mm_s3().is_none());
        let profile = plan(&st);
        assert_eq!(profile.runs.len(), 2);
        assert!(profile.interval_dt_s.is_empty() && profile.interval_integral_mm_s.is_empty());
        assert_eq!(profile.interval_start_s.len(), st.len() - 1);
        for run in &profile.runs {
            let mut t_s = run.start_s;
            for k in run.first..run.last {
                assert_eq!(
                    profile.interval_start_s[k].to_bits(),
                    t_s.to_bits(),
                    "interval {k}"
                );
                t_s += profile.interval_dt_s(k);
            }
            assert_eq!((t_s - run.start_s).to_bits(), run.duration_s.to_bits());
        }
        let shares: f64 = profile
            .time_at_cap_share()
            .iter()
            .map(|(_, share)| share)
            .sum();
        assert!((shares - 1.0).abs() < 1e-12, "{shares}");
        let samples = profile.sample(st.machine().period_ms).unwrap();
        assert_eq!(samples.last().unwrap().s_mm, *st.s_mm().last().unwrap());
        let t = st.machine().period_s();
        for w in samples[..samples.len() - 1].windows(3) {
            let second = (w[2].pos.coords - 2.0 * w[1].pos.coords + w[0].pos.coords) / (t * t);
            assert!(second.amax() <= 1000.0 * (1.0 + 1e-6) + 1e-6, "{second:?}");
        }
    }

    /// The sine of the integration test `chord_approximated_sine_keeps_axis_limits` (0.2 mm
    /// chords) at F3000, jerk 20 000 mm/s³.
    fn sine() -> Stations {
        let points: Vec<Point3<f64>> = (0..=500)
            .map(|i| {
                let x = i as f64 * 0.2;
                Point3::new(x, 5.0 * (x / 4.0).sin(), 0.0)
            })
            .collect();
        let feed = Motion::feed(3000.0);
        let segments = points.windows(2).map(|w| line(w[0], w[1], feed)).collect();
        let machine = Machine {
            jerk_mm_s3: Some([20000.0; 3]),
            feed_max_mm_min: 10000.0,
            ..Machine::default()
        };
        Stations::new(&Path { segments }, &machine, 0.05, FeedPolicy::Programmed).unwrap()
    }

    /// `chords` chords of 0.25 mm turning by 1.5° and 6° in turn, the turns changing side
    /// every 20 chords (corner caps of 790–3 000 mm/min), at F1500, jerk 20 000 mm/s³.
    fn zigzag(chords: usize) -> Stations {
        zigzag_turning_every(chords, 20)
    }

    /// [`zigzag`] with the turns changing side every `every` chords.
    fn zigzag_turning_every(chords: usize, every: usize) -> Stations {
        let mut points = vec![Point3::new(0.0, 0.0, 0.0)];
        let mut heading: f64 = 0.0;
        for i in 0..chords {
            let turn: f64 = if i % 2 == 0 { 1.5 } else { 6.0 };
            heading += turn.to_radians()
                * if (i / every).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
            let last = *points.last().unwrap();
            points.push(last + 0.25 * Vector3::new(heading.cos(), heading.sin(), 0.0));
        }
        let feed = Motion::feed(1500.0);
        let segments = points.windows(2).map(|w| line(w[0], w[1], feed)).collect();
        let machine = Machine {
            jerk_mm_s3: Some([20000.0; 3]),
            feed_max_mm_min: 3000.0,
            ..Machine::default()
        };
        Stations::new(&Path { segments }, &machine, 0.05, FeedPolicy::Programmed).unwrap()
    }

    /// Largest ratio of a sampled per-axis second or third difference to its limit over
    /// `samples` on the grid (the last one, at the cycle end, left out), computed here
    /// from the samples [`Profile::sample`] makes, not by the planner's check.
    fn worst_ratio(machine: &Machine, samples: &[ServoSample]) -> f64 {
        let t = machine.period_s();
        let on_grid = &samples[..samples.len() - 1];
        let mut worst: f64 = 0.0;
        for i in 0..3 {
            let x: Vec<f64> = on_grid.iter().map(|s| s.pos[i]).collect();
            for w in x.windows(3) {
                worst =
                    worst.max((w[2] - 2.0 * w[1] + w[0]).abs() / t / t / machine.accel_mm_s2[i]);
            }
            for w in x.windows(4) {
                let third = (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs() / t / t / t;
                worst = worst.max(third / machine.jerk_mm_s3.unwrap()[i]);
            }
        }
        worst
    }

    /// One run planned by [`RunPlanner::verified_run`] from `candidates` (λ values).
    fn run<'a>(
        st: &'a Stations,
        candidates: &[f64],
        tries: (usize, usize),
    ) -> (Profile<'a>, Verified) {
        run_with(RunPlanner::new(st), st, candidates, tries)
    }

    /// [`run`] by a planner set up by the test (full holds, plain rules).
    fn run_with<'a>(
        mut planner: RunPlanner,
        st: &'a Stations,
        candidates: &[f64],
        tries: (usize, usize),
    ) -> (Profile<'a>, Verified) {
        let window_s =
            st.interval_accel_mm_s2()[0] / st.interval_jerk_mm_s3().expect("a jerk limit")[0];
        let stops = st.stops();
        let mut profile = Profile::empty(st);
        let (end_s, verified, _) = planner.verified_run(
            &mut profile,
            (stops[0], stops[1]),
            window_s,
            candidates,
            tries,
        );
        profile.cycle_time_s = end_s + profile.runs[0].window_s;
        (profile, verified)
    }

    /// At λ = 1 the sine's samples break the jerk limit; the check sees it, and both
    /// fallbacks give a plan whose samples keep every limit. The slowed one is the λ = 1
    /// plan run σ times slower: speeds σ·v, duration and window over σ.
    #[test]
    fn fallbacks_keep_the_limits_where_lambda_one_breaks_them() {
        let st = sine();
        let machine = *st.machine();
        let (at_one, verified) = run(&st, &[1.0], (0, SLOW_MAX_TRIES));
        let Verified::Slowed { tries, slow } = verified else {
            panic!("{verified:?}");
        };
        assert!(tries >= 2 && slow < 1.0, "{verified:?}");
        assert!(worst_ratio(&machine, &at_one.sample(machine.period_ms).unwrap()) <= 1.0 + 1e-6);

        // The λ = 1 plan itself, at σ = 1: it breaks the limit.
        let planner = RunPlanner::new(&st);
        let mut plain = Profile::empty(&st);
        let window_s = at_one.runs[0].window_s * slow;
        let last = st.len() - 1;
        planner.plan_run(0, last, 1.0, window_s, 1.0, &mut plain.speed_mm_s);
        let end_s = plain.push_run(0, last, 0.0, window_s, 0.0);
        plain.cycle_time_s = end_s + window_s;
        let ratio = plain.last_run_axis_ratio(None);
        assert!(ratio > 1.0, "{ratio}");
        // The planner's check measures what the samples show (up to its tolerance).
        let measured = worst_ratio(&machine, &plain.sample(machine.period_ms).unwrap());
        assert!(
            (measured - ratio).abs() <= 2e-6 * measured,
            "{measured} vs {ratio}"
        );
        for (slowed, v) in at_one.speed_mm_s.iter().zip(&plain.speed_mm_s) {
            assert!(
                (slowed - slow * v).abs() <= 1e-9 * v,
                "{slowed} vs {slow}·{v}"
            );
        }
        let (a, b) = (at_one.runs[0], plain.runs[0]);
        assert!((a.duration_s * slow - b.duration_s).abs() <= 1e-9 * b.duration_s);
        assert!((a.window_s * slow - b.window_s).abs() <= 1e-12 * b.window_s);

        // Lowering the caps where the samples break a limit verifies too, and is quicker.
        let (lowered, verified) = run(&st, &[1.0], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
        assert!(matches!(verified, Verified::Repaired(_)), "{verified:?}");
        assert!(worst_ratio(&machine, &lowered.sample(machine.period_ms).unwrap()) <= 1.0 + 1e-6);
        assert!(lowered.cycle_time_s < at_one.cycle_time_s);
        println!(
            "λ = 1: ratio {ratio:.4}, cycle {:.4} s; lowered caps {verified:?}: {:.4} s; slowed σ = {slow:.4} ({tries} tries): {:.4} s",
            plain.cycle_time_s, lowered.cycle_time_s, at_one.cycle_time_s
        );
    }

    /// A run that still breaks a limit when the slowed fallback gives up is refused: the
    /// profile is not sampled, and the error names the run and its ratio. (On the sine at
    /// λ = 1 without repairs the first slowed try, σ = 1 after a rest, still breaks the jerk
    /// limit; the second verifies, see the test above.)
    #[test]
    fn a_run_unverified_after_the_last_try_is_refused() {
        let st = sine();
        let machine = *st.machine();
        let last = st.len() - 1;
        let (gave_up, verified) = run(&st, &[1.0], (0, 1));
        assert_eq!(
            verified,
            Verified::Slowed {
                tries: 1,
                slow: 1.0
            }
        );
        let error = gave_up.sample(machine.period_ms).unwrap_err();
        let ScheduleError::UnverifiedRun {
            first: 0,
            last: l,
            ratio,
            tries: 1,
            slow,
        } = error
        else {
            panic!("{error:?}");
        };
        assert!(l == last && ratio > 1.0 && slow == 1.0, "{error}");
        assert_eq!(gave_up.sample_count(machine.period_ms), Err(error));
        // Given its tries, the same run verifies and is sampled.
        let (kept, verified) = run(&st, &[1.0], (0, SLOW_MAX_TRIES));
        assert!(
            matches!(verified, Verified::Slowed { tries: 2.., .. }),
            "{verified:?}"
        );
        assert!(kept.sample(machine.period_ms).is_ok());
    }

    /// A run that ends past [`MAX_SAMPLES`] periods is not checked (its samples are never
    /// made: [`Profile::sample`] refuses the profile), so a program whose caps make it run
    /// for months is refused at once instead of being checked sample by sample.
    #[test]
    fn runs_past_the_sample_limit_are_not_checked() {
        let st = sine();
        let machine = *st.machine();
        let last = st.len() - 1;
        let window_s =
            st.interval_accel_mm_s2()[0] / st.interval_jerk_mm_s3().expect("a jerk limit")[0];
        let planner = RunPlanner::new(&st);
        let ratio_from = |start_s: f64| {
            let mut profile = Profile::empty(&st);
            planner.plan_run(0, last, 1.0, window_s, 1.0, &mut profile.speed_mm_s);
            let end_s = profile.push_run(0, last, start_s, window_s, 0.0);
            profile.cycle_time_s = end_s + window_s;
            (
                profile.last_run_axis_ratio(None),
                profile.sample(machine.period_ms).is_err(),
            )
        };
        // The sine at λ = 1 breaks the jerk limit (see the test above) ...
        let (ratio, refused) = ratio_from(0.0);
        assert!(ratio > 1.0 && !refused, "{ratio}");
        // ... but started after MAX_SAMPLES periods it is not checked, and not sampled.
        let (ratio, refused) = ratio_from(MAX_SAMPLES as f64 * machine.period_s());
        assert!(ratio == 0.0 && refused, "{ratio}");
    }

    /// A sampler started anywhere makes the samples of one started at t = 0, bit for bit
    /// (the check's samples are the servo samples), on a path of several runs and dwells.
    #[test]
    fn a_sampler_started_late_makes_the_same_samples() {
        let feed = Motion::feed(2000.0);
        let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
        let segments = vec![
            line(p(0.0, 0.0), p(10.0, 0.0), feed),
            line(p(10.0, 0.0), p(10.0, 5.0), feed),
            line(p(10.0, 5.0), p(10.0, 5.0), Motion::Dwell { seconds: 0.1 }),
            line(p(10.0, 5.0), p(0.0, 7.0), feed),
            line(p(0.0, 7.0), p(0.0, 7.0), Motion::Dwell { seconds: 0.01 }),
            line(p(0.0, 7.0), p(3.0, 0.0), feed),
        ];
        for jerk_mm_s3 in [None, Some([20000.0; 3])] {
            let machine = Machine {
                jerk_mm_s3,
                period_ms: 4.0,
                ..Machine::default()
            };
            let st = Stations::new(
                &Path {
                    segments: segments.clone(),
                },
                &machine,
                0.05,
                FeedPolicy::Programmed,
            )
            .unwrap();
            let profile = plan(&st);
            assert!(profile.runs.len() >= 3);
            let samples = profile.sample(4.0).unwrap();
            let period_s = machine.period_s();
            for from in (0..samples.len() - 1).step_by(7) {
                let mut sampler = Sampler::starting_at(&profile, from as f64 * period_s);
                for (j, expected) in samples
                    .iter()
                    .enumerate()
                    .take(samples.len() - 1)
                    .skip(from)
                {
                    assert_eq!(
                        sampler.at(j as f64 * period_s),
                        *expected,
                        "from {from}, sample {j}"
                    );
                }
            }
        }
    }

    /// Local corner holds (MODEL.md §6.1): a run of short chords, 0.25 mm each, turning by
    /// 1.5° to 6° in turn (caps of 790–3 000 mm/min from the corner rule), at F1500 with
    /// jerk 20 000 mm/s³. Every corner held over c·W/2 only breaks no limit where the speed
    /// changes little, and the samples decide: the plan keeps every limit at every sample,
    /// restores the full hold c·(W + 3T)/2 only at corners near a failing stencil, and is
    /// faster than the plan with every corner's full hold.
    #[test]
    fn corners_get_their_full_hold_only_where_the_samples_need_it() {
        let st = zigzag(160);
        let machine = *st.machine();
        let (local, verified) = run(&st, &[1.0], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
        assert!(
            matches!(verified, Verified::Candidate(0) | Verified::Restored(_)),
            "{verified:?}"
        );
        assert!(worst_ratio(&machine, &local.sample(machine.period_ms).unwrap()) <= 1.0 + 1e-6);

        // Every corner with its full hold: the rule before, slower here.
        let mut planner = RunPlanner::new(&st);
        for &c in st.corners() {
            planner.full_hold[c] = true;
        }
        let (full, _) = run_with(planner, &st, &[1.0], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
        println!(
            "{} corners, local holds {verified:?}: {:.4} s; full holds: {:.4} s",
            st.corners().len(),
            local.cycle_time_s,
            full.cycle_time_s
        );
        assert!(local.cycle_time_s < full.cycle_time_s);
    }

    /// Slow dips and peaks (MODEL.md §6.1): a raster's row end, 10 mm along X, a 0.5 mm
    /// step along Y and 10 mm back, at F3000 with T = 4 ms and jerk 20 000 mm/s³. The two
    /// 90° corners are capped at j·T²/2 = 0.16 mm/s and the step's intervals limited to
    /// j·T/12 = 6.67 mm/s² (MODEL.md §6.1, sampled geometry), so the filter's jerk at the
    /// corners' dips and the step's peak, at most 2·6.67/W, is far under j: the corners
    /// dip instead of being held over whole 0.05 mm intervals at 0.16 mm/s, and the peak
    /// is not cut. Every sample keeps the axis limits and the caps, and the run is quicker
    /// than with every station planned by the plain rules.
    #[test]
    fn slow_corners_dip_instead_of_being_held() {
        let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
        let feed = Motion::feed(3000.0);
        let segments = vec![
            line(p(0.0, 0.0), p(10.0, 0.0), feed),
            line(p(10.0, 0.0), p(10.0, 0.5), feed),
            line(p(10.0, 0.5), p(0.0, 0.5), feed),
        ];
        let machine = Machine {
            jerk_mm_s3: Some([20000.0; 3]),
            period_ms: 4.0,
            ..Machine::default()
        };
        let st = Stations::new(&Path { segments }, &machine, 0.05, FeedPolicy::Programmed).unwrap();
        let (dips, verified) = run(&st, &[1.0], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
        let samples = dips.sample(machine.period_ms).unwrap();
        assert!(worst_ratio(&machine, &samples) <= 1.0 + 1e-6);
        let (s, caps) = (st.s_mm(), st.cap_mm_min());
        for sample in &samples {
            let k = s
                .partition_point(|&x| x <= sample.s_mm)
                .clamp(1, s.len() - 1);
            assert!(sample.feed_mm_min <= caps[k - 1].max(caps[k]) * (1.0 + 1e-9));
        }

        // Every station by the plain rules: the corners held, the peak cut.
        let mut planner = RunPlanner::new(&st);
        planner.plain.fill(true);
        let (plain, _) = run_with(planner, &st, &[1.0], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
        println!(
            "slow dips {verified:?}: {:.4} s; plain rules: {:.4} s",
            dips.cycle_time_s, plain.cycle_time_s
        );
        assert!(dips.cycle_time_s < plain.cycle_time_s - 0.5);
    }

    /// The filtered motion of run `run` at `t_s` (arc length, speed), by the run's own
    /// plan and window, whichever run the sampler would take there.
    fn filtered(profile: &Profile<'_>, run: &Run, t_s: f64) -> (f64, f64) {
        let (mut now, mut lagged) = (run.first, run.first);
        // A section followed exactly has no filter (MODEL.md §6.1, "Exact direct sections").
        if run.window_s == 0.0 {
            let state = profile.run_state(run, t_s, &mut now);
            return (state.s_mm, state.v_mm_s);
        }
        let a = profile.run_state(run, t_s, &mut now);
        let b = profile.run_state(run, t_s - run.window_s, &mut lagged);
        let s_first = profile.stations.s_mm()[run.first];
        (
            s_first + (a.integral_mm_s - b.integral_mm_s) / run.window_s,
            (a.s_mm - b.s_mm) / run.window_s,
        )
    }

    /// Sections (MODEL.md §6.1): a long run of dense corners is cut where its plan is flat
    /// at a cap, each section with its own window. The sections' plan is quicker than the
    /// run planned whole, every servo sample keeps the axes' acceleration and jerk and
    /// its cap, and at each join both sections' filtered motions are at the join's
    /// station with its cap as speed.
    #[test]
    fn sections_are_quicker_keep_the_limits_and_join_at_their_stations() {
        for st in [zigzag(1200), zigzag(300)] {
            let machine = *st.machine();
            let base_window_s = base_window_s(&st);
            let last = st.len() - 1;
            // The run planned whole, as before sections.
            let mut planner = RunPlanner::new(&st);
            let mut candidates = Vec::new();
            if last <= LAMBDA_SEARCH_MAX_STATIONS {
                planner.lambda_candidates(0, last, base_window_s, &mut candidates);
            } else {
                planner.lambda_grid(0, last, base_window_s, &mut candidates);
            }
            let (whole, _) = run(&st, &candidates, (REPAIR_MAX_TRIES, SLOW_MAX_TRIES));
            let profile = plan(&st);
            println!(
                "{} stations: whole {:.4} s, {} sections {:.4} s",
                st.len(),
                whole.cycle_time_s,
                profile.runs.len(),
                profile.cycle_time_s
            );
            assert!(profile.runs.len() > 2, "{}", profile.runs.len());
            assert!(profile.cycle_time_s < whole.cycle_time_s);
            let samples = profile.sample(machine.period_ms).unwrap();
            assert!(worst_ratio(&machine, &samples) <= 1.0 + 1e-6);
            let (s, caps) = (st.s_mm(), st.cap_mm_min());
            for x in &samples {
                let k = s.partition_point(|&y| y <= x.s_mm).clamp(1, last);
                assert!(x.feed_mm_min <= caps[k - 1].max(caps[k]) * (1.0 + 1e-9));
            }
            for pair in profile.runs.windows(2) {
                let (before, after) = (&pair[0], &pair[1]);
                let m = after.first;
                let c = profile.speed_mm_s[m];
                assert!(c > 0.0 && c <= caps[m] / 60.0 * (1.0 + 1e-12), "{c}");
                for run in [before, after] {
                    let (s_mm, v_mm_s) = filtered(&profile, run, after.switch_s);
                    assert!((s_mm - s[m]).abs() <= 1e-9, "{s_mm} vs {}", s[m]);
                    assert!((v_mm_s - c).abs() <= 1e-9 * c, "{v_mm_s} vs {c}");
                }
            }
        }
    }

    /// A run longer than the golden-section search takes tries the λ of [`LAMBDA_GRID`]
    /// by the time of their plans and keeps the first that verifies: on 1 200 chords of
    /// the zigzag above (6 001 stations) a λ below 1, quicker than λ = 1, every sample
    /// within the limits.
    #[test]
    fn long_runs_plan_at_a_quicker_lambda_of_the_grid() {
        let st = zigzag(1200);
        let machine = *st.machine();
        assert!(st.len() > LAMBDA_SEARCH_MAX_STATIONS);
        let base_window_s = base_window_s(&st);
        let profile = plan(&st);
        let lambda = profile.runs[0].window_s / base_window_s;
        assert!(worst_ratio(&machine, &profile.sample(machine.period_ms).unwrap()) <= 1.0 + 1e-6);
        // Each λ of the grid planned alone (verified, repaired where needed).
        let times: Vec<f64> = LAMBDA_GRID
            .iter()
            .map(|&l| {
                run(&st, &[l], (REPAIR_MAX_TRIES, SLOW_MAX_TRIES))
                    .0
                    .cycle_time_s
            })
            .collect();
        println!(
            "λ {lambda:.4}: {:.4} s; grid {LAMBDA_GRID:?}: {times:?}",
            profile.cycle_time_s
        );
        assert!(lambda < 1.0, "{lambda}");
        assert!(profile.cycle_time_s < times[0]);
    }

    /// Sections shaped directly (MODEL.md §6.1, "Direct sections"). On 600 chords of the
    /// zigzag turning side every 7 chords (dense corners) some sections are kept shaped
    /// directly and every servo
    /// sample keeps the axes' limits and its cap. On a 40 mm line at F3000 whose caps are
    /// 1 150 mm/min over [16, 24] mm but 900, 1 000 and 850 mm/min at 19.5, 20 and
    /// 20.5 mm, the section from 16 to 24 mm (at 1 150 mm/min at both ends), shaped
    /// directly at each share and planned alone, keeps the acceleration and jerk limits at
    /// samples every 1 ms (its filter of at least σ/(1 − σ)·Δt bounds the jerk in
    /// continuous time, not only at the machine period of 16 ms) and its caps.
    #[test]
    fn sections_made_ahead_in_parallel_are_those_made_one_at_a_time() {
        // The oracle: each section's values made where the loop reaches it, on the
        // calling thread's pool of one, as before they were made ahead.
        let pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
        };
        let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        // (stations, whether sections shaped by linear programs are kept).
        for (st, programmed) in [(zigzag_turning_every(600, 7), true), (zigzag(400), false)] {
            let machine = *st.machine();
            let oracle = pool(1).install(|| plan_ahead(&st, 0));
            let samples = oracle.sample(machine.period_ms).unwrap();
            let pieces = oracle
                .gaps
                .iter()
                .filter(|g| matches!(g.motion, Followed::Piece(_)))
                .count();
            println!(
                "{} sections, {pieces} intervals shaped by linear programs, {:.6} s",
                oracle.runs.len(),
                oracle.cycle_time_s
            );
            assert!(oracle.runs.len() > 10 && (pieces > 0) == programmed);
            for (threads, ahead) in [(1, AHEAD_STATIONS), (3, AHEAD_STATIONS), (3, 200)] {
                let profile = pool(threads).install(|| plan_ahead(&st, ahead));
                assert_eq!(
                    profile.cycle_time_s.to_bits(),
                    oracle.cycle_time_s.to_bits()
                );
                assert_eq!(bits(&profile.speed_mm_s), bits(&oracle.speed_mm_s));
                assert_eq!(profile.runs.len(), oracle.runs.len());
                for (x, y) in profile.runs.iter().zip(&oracle.runs) {
                    assert_eq!((x.first, x.last, x.gaps), (y.first, y.last, y.gaps));
                    let times = |r: &Run| bits(&[r.start_s, r.duration_s, r.window_s]);
                    assert_eq!(times(x), times(y));
                }
                let again = profile.sample(machine.period_ms).unwrap();
                assert_eq!(again.len(), samples.len());
                for (x, y) in again.iter().zip(&samples) {
                    assert_eq!(
                        bits(&[x.t_s, x.s_mm, x.feed_mm_min]),
                        bits(&[y.t_s, y.s_mm, y.feed_mm_min])
                    );
                    assert_eq!(bits(x.pos.coords.as_slice()), bits(y.pos.coords.as_slice()));
                }
            }
        }
    }

    #[test]
    fn sections_shaped_directly_keep_the_limits() {
        let st = zigzag_turning_every(600, 7);
        let machine = *st.machine();
        let profile = plan(&st);
        let direct = profile.runs.iter().filter(|r| r.direct).count();
        println!(
            "zigzag every 7: {} sections, {direct} shaped directly, {:.4} s",
            profile.runs.len(),
            profile.cycle_time_s
        );
        assert!(direct > 0);
        let samples = profile.sample(machine.period_ms).unwrap();
        assert!(worst_ratio(&machine, &samples) <= 1.0 + 1e-6);
        let under_caps = |st: &Stations, samples: &[ServoSample]| {
            let (s, caps) = (st.s_mm(), st.cap_mm_min());
            samples.iter().all(|x| {
                let k = s.partition_point(|&y| y <= x.s_mm).clamp(1, s.len() - 1);
                x.feed_mm_min <= caps[k - 1].max(caps[k]) * (1.0 + 1e-9)
            })
        };
        assert!(under_caps(&st, &samples));

        let (machine, mut st) = forty_mm_line_with_jerk();
        let caps: Vec<f64> = st
            .s_mm()
            .iter()
            .map(|&x| {
                let dip = (0..3).position(|i| (x - 19.5 - 0.5 * i as f64).abs() < 1e-9);
                match dip {
                    Some(i) => [900.0, 1000.0, 850.0][i],
                    None if (16.0..=24.0).contains(&x) => 1150.0,
                    None => 3000.0,
                }
            })
            .collect();
        st.apply_caps(&caps, CapKind::Removal).unwrap();
        let (first, last) = (320, 480);
        assert!((st.s_mm()[first] - 16.0).abs() < 1e-9 && (st.s_mm()[last] - 24.0).abs() < 1e-9);
        let ends = (1150.0 / 60.0, 1150.0 / 60.0);
        let planner = RunPlanner::new(&st);
        let fine = Machine {
            period_ms: 1.0,
            ..machine
        };
        // The line's start planned as a section from rest to the cut, the
        // section's own speeds kept: its duration and filter width.
        let lead_in = |profile: &mut Profile| {
            let before = profile.speed_mm_s[first..=last].to_vec();
            let base = base_window_s(&st);
            let lead_s = planner
                .plan_section(
                    (0, first),
                    (1.0, base),
                    (0.0, ends.0),
                    &mut profile.speed_mm_s[..=first],
                )
                .unwrap();
            profile.speed_mm_s[first..=last].copy_from_slice(&before);
            (lead_s, base)
        };
        let mut shaped = 0;
        for share in DIRECT_SHARES {
            let mut profile = Profile::empty(&st);
            let Some((_, window_s)) = planner.direct_window(
                (first, last),
                ends,
                share,
                (DIRECT_WINDOW_MIN_S, base_window_s(&st)),
                &mut profile.speed_mm_s[first..=last],
            ) else {
                continue;
            };
            shaped += 1;
            let (lead_s, base) = lead_in(&mut profile);
            profile.push_run(0, first, 0.0, base, 0.0);
            let start_s = lead_s + (base - window_s) / 2.0;
            let end_s = profile.push_run(first, last, start_s, window_s, 0.0);
            profile.cycle_time_s = end_s + window_s;
            let samples = profile.sample(fine.period_ms).unwrap();
            let ratio = worst_ratio(&fine, &samples);
            println!("share {share}: W {window_s:.5} s, 1 ms ratio {ratio:.4}");
            assert!(ratio <= 1.0 + 1e-6, "share {share}: {ratio}");
            assert!(under_caps(&st, &samples));
        }
        assert!(shaped > 0);

        // Followed exactly, without a filter (MODEL.md §6.1, "Exact direct sections"):
        // its jerk is within σ·J at every instant, so at every share the 1 ms samples keep
        // the limits and the caps.
        for share in EXACT_SHARES {
            let (mut profile, start_s, mut gaps) = (Profile::empty(&st), 0.0, Vec::new());
            let time_s = planner
                .plan_direct(
                    (first, last),
                    ends,
                    (share, 0.0, false),
                    &mut profile.speed_mm_s[first..=last],
                    Some(&mut gaps),
                )
                .map(|_| {
                    exact_time_s(
                        &st.s_mm()[first..=last],
                        &profile.speed_mm_s[first..=last],
                        &gaps,
                    )
                })
                .expect("a shape at every share");
            assert!(gaps.len() >= 2, "{}", gaps.len());
            let (lead_s, base) = lead_in(&mut profile);
            profile.push_run(0, first, start_s, base, 0.0);
            let end_s =
                profile.push_exact_run(first, last, lead_s + base / 2.0, (0.0, 0.0), &gaps, None);
            assert!((end_s - (lead_s + base / 2.0) - time_s).abs() <= 1e-9);
            profile.cycle_time_s = end_s + 0.1;
            let samples = profile.sample(fine.period_ms).unwrap();
            let ratio = worst_ratio(&fine, &samples);
            println!("exact, share {share}: {time_s:.5} s, 1 ms ratio {ratio:.4}");
            assert!(ratio <= 1.0 + 1e-6, "share {share}: {ratio}");
            assert!(under_caps(&st, &samples));
        }
    }

    /// [`forty_mm_line_with_jerk`] with its caps falling as 3 + 31.25·|x − 20| mm/s over
    /// 16..24 mm (a sharp corner's cap ramp, k ≈ 1/(2T)).
    fn forty_mm_line_with_a_cap_ramp() -> (Machine, Stations) {
        let (machine, mut st) = forty_mm_line_with_jerk();
        let (c0, k) = (3.0, 31.25);
        let caps: Vec<f64> = st
            .s_mm()
            .iter()
            .map(|&x| {
                if (16.0..=24.0).contains(&x) {
                    (60.0 * (c0 + k * (x - 20.0).abs())).min(3000.0)
                } else {
                    3000.0
                }
            })
            .collect();
        st.apply_caps(&caps, CapKind::Removal).unwrap();
        (machine, st)
    }

    /// The stations (0.05 mm apart) of a 40 mm line along X at F3000 on the
    /// default machine with a jerk limit of 20 000 mm/s³ per axis, and that
    /// machine: the sections' tests' setup.
    fn forty_mm_line_with_jerk() -> (Machine, Stations) {
        let machine = Machine {
            jerk_mm_s3: Some([20000.0; 3]),
            ..Machine::default()
        };
        let feed = Motion::feed(3000.0);
        let segments = vec![line(Point3::origin(), Point3::new(40.0, 0.0, 0.0), feed)];
        let st = Stations::new(&Path { segments }, &machine, 0.05, FeedPolicy::Programmed).unwrap();
        (machine, st)
    }

    /// [`forty_mm_line_with_jerk`] capped at 1 150 mm/min at the stations at 16 and
    /// 24 mm (320 and 480): the flying move's setup, a section between them entered and
    /// left at that speed.
    fn flying_move_line() -> (Machine, Stations) {
        let (machine, mut st) = forty_mm_line_with_jerk();
        let caps: Vec<f64> = st
            .s_mm()
            .iter()
            .map(|&x| {
                if (x - 16.0).abs() < 1e-9 || (x - 24.0).abs() < 1e-9 {
                    1150.0
                } else {
                    3000.0
                }
            })
            .collect();
        st.apply_caps(&caps, CapKind::Removal).unwrap();
        (machine, st)
    }

    /// Plans the line from rest to station `first` (entered at `entry_mm_s`) as a section
    /// at λ = 1 and the base window, then pushes the section `first..=last` at `speeds`,
    /// followed exactly (its `gaps`, or the linear programs' accelerations) from where the
    /// lead-in's filtered motion ends, as the planner joins them. Returns the section's
    /// start and end, s.
    fn push_after_a_lead_in(
        planner: &RunPlanner,
        profile: &mut Profile,
        (first, last): (usize, usize),
        entry_mm_s: f64,
        speeds: &[f64],
        (gaps, accel): (&[direct::Gap], Option<&[f64]>),
    ) -> (f64, f64) {
        let base = base_window_s(planner.stations);
        let lead_s = planner
            .plan_section(
                (0, first),
                (1.0, base),
                (0.0, entry_mm_s),
                &mut profile.speed_mm_s[..=first],
            )
            .unwrap();
        profile.speed_mm_s[first..=last].copy_from_slice(speeds);
        profile.push_run(0, first, 0.0, base, 0.0);
        let start_s = lead_s + base / 2.0;
        let end_s = profile.push_exact_run(first, last, start_s, (0.0, 0.0), gaps, accel);
        (start_s, end_s)
    }

    /// Every sample `h` s apart (the last, the cycle's end, is off the period's grid) is
    /// at or under the larger cap of the stations around it, and its second difference
    /// along X within the machine's acceleration (1 + 10⁻⁶).
    fn assert_samples_keep_the_caps_and_accel(
        samples: &[ServoSample],
        st: &Stations,
        machine: &Machine,
        h: f64,
    ) {
        let (s, caps) = (st.s_mm(), st.cap_mm_min());
        for w in samples[..samples.len() - 1].windows(3) {
            let k = s.partition_point(|&y| y <= w[1].s_mm).clamp(1, s.len() - 1);
            assert!(w[1].feed_mm_min <= caps[k - 1].max(caps[k]) * (1.0 + 1e-9));
            let second = (w[2].pos[0] - 2.0 * w[1].pos[0] + w[0].pos[0]) / h / h;
            assert!(
                second.abs() <= machine.accel_mm_s2[0] * (1.0 + 1e-6),
                "{second} at {} mm, {} s",
                w[1].s_mm,
                w[1].t_s
            );
        }
    }

    /// A section followed exactly (MODEL.md §6.1, "Exact direct sections") against the
    /// closed form of the flying jerk-limited move: on a line at F3000 (50 mm/s, a = 1 000
    /// mm/s², j = 20 000 mm/s³) the stations from 16 to 24 mm, entered and left at
    /// c = 1 150 mm/min with no acceleration, rise to 50 mm/s and fall back. A rise of
    /// Δ = 50 − c < a²/j takes τ = 2√(Δ/j) over (c + 50)·τ/2, so the section takes
    /// 2Δs/c (its first and last station interval, held at c) + 2τ + the rest at 50 mm/s.
    /// Its samples every 0.25 ms have second differences within a and third differences
    /// within j (1 + 10⁻³), and the speed of every sample is the closed form's.
    #[test]
    fn a_section_followed_exactly_is_the_closed_form_flying_move() {
        let (_, st) = flying_move_line();
        let (first, last) = (320, 480);
        let c = 1150.0 / 60.0;
        let (j, top) = (20000.0, 50.0);
        let planner = RunPlanner::new(&st);
        let mut profile = Profile::empty(&st);
        let mut gaps = Vec::new();
        planner
            .plan_direct(
                (first, last),
                (c, c),
                (1.0, 0.0, false),
                &mut profile.speed_mm_s[first..=last],
                Some(&mut gaps),
            )
            .expect("a shape");
        // After the line's start, planned as a section from rest to the first station.
        let before = profile.speed_mm_s[first..=last].to_vec();
        let base = base_window_s(&st);
        let lead_s = planner
            .plan_section(
                (0, first),
                (1.0, base),
                (0.0, c),
                &mut profile.speed_mm_s[..=first],
            )
            .unwrap();
        profile.speed_mm_s[first..=last].copy_from_slice(&before);
        profile.push_run(0, first, 0.0, base, 0.0);
        let start_s = lead_s + base / 2.0;
        let end_s = profile.push_exact_run(first, last, start_s, (0.0, 0.0), &gaps, None) - start_s;
        // The closed form: Δ < a²/j = 50 mm/s, so the acceleration peaks at √(jΔ).
        let dv: f64 = top - c;
        let tau = 2.0 * (dv / j).sqrt();
        let ds = 0.05;
        let rise_mm = (c + top) / 2.0 * tau;
        let expected = 2.0 * ds / c + 2.0 * tau + (8.0 - 2.0 * ds - 2.0 * rise_mm) / top;
        println!("followed exactly {end_s:.9} s, closed form {expected:.9} s");
        assert!(
            (end_s - expected).abs() <= 1e-9 * expected,
            "{end_s} vs {expected}"
        );
        // The speed of the closed form at time t into the rise (jerk j for τ/2, then −j).
        let rise = |h: f64| {
            if h <= tau / 2.0 {
                c + j * h * h / 2.0
            } else {
                top - j * (tau - h).powi(2) / 2.0
            }
        };
        let t0 = ds / c;
        let period_s = 0.25e-3;
        let count = (end_s / period_s) as usize;
        let mut cursor = first;
        let run = profile.runs[1];
        let states: Vec<RunState> = (0..=count)
            .map(|i| profile.run_state(&run, start_s + i as f64 * period_s, &mut cursor))
            .collect();
        for (i, state) in states.iter().enumerate() {
            let t = i as f64 * period_s;
            let expected_v = if t <= t0 {
                c
            } else if t <= t0 + tau {
                rise(t - t0)
            } else if t <= end_s - t0 - tau {
                top
            } else if t <= end_s - t0 {
                rise(end_s - t0 - t)
            } else {
                c
            };
            assert!(
                (state.v_mm_s - expected_v).abs() <= 1e-6,
                "t {t}: {} vs {expected_v}",
                state.v_mm_s
            );
        }
        for w in states.windows(4) {
            let x: Vec<f64> = w.iter().map(|state| state.s_mm).collect();
            let second = (x[2] - 2.0 * x[1] + x[0]) / period_s.powi(2);
            let third = (x[3] - 3.0 * x[2] + 3.0 * x[1] - x[0]) / period_s.powi(3);
            assert!(second.abs() <= 1000.0, "{second}");
            assert!(third.abs() <= j * (1.0 + 1e-3), "{third}");
        }
        // The same station speeds with constant accelerations between stations (the plan a
        // filter would take) step their acceleration at every station: their third
        // differences at 0.25 ms are far over j, which the check above would catch.
        profile.pop_run();
        profile.push_run(first, last, start_s, 0.0, 0.0);
        let run = profile.runs[1];
        let mut cursor = first;
        let x: Vec<f64> = (0..=count)
            .map(|i| {
                profile
                    .run_state(&run, start_s + i as f64 * period_s, &mut cursor)
                    .s_mm
            })
            .collect();
        let worst = x
            .windows(4)
            .map(|x| ((x[3] - 3.0 * x[2] + 3.0 * x[1] - x[0]) / period_s.powi(3)).abs())
            .fold(0.0, f64::max);
        println!("station-based: third differences up to {worst:.0} mm/s³");
        assert!(worst > 2.0 * j, "{worst}");
    }

    /// A section before and after a cap ramp (MODEL.md §6.1, "Dips that follow the
    /// envelope"): a line at F3000 whose caps fall linearly to the middle of 16..24 mm,
    /// c = c₀ + k·|x − 20| (c₀ = 3 mm/s, k = 31.25 s⁻¹, as the sampled geometry's caps
    /// before a sharp corner at T = 16 ms), entered and left at 50 mm/s. A motion that
    /// reaches the dip with no acceleration crosses the ramp (it rises as J·r²/2 over its
    /// last r seconds against c₀ + k·v·r), so the shape with dips at rest lowers the dip;
    /// the shape whose dips follow the ramp (a = −k·v, jerk k²·v ≤ J below 20.5 mm/s) is
    /// quicker. Planned from rest into the section as the planner does, its samples at
    /// the machine period keep every axis' acceleration and jerk, and every 1 ms sample
    /// the acceleration and the caps (the stretches followed are constant accelerations
    /// between stations, so their jerk is kept at the period, not at every instant).
    #[test]
    fn a_cap_ramp_is_followed_within_the_caps_at_every_sample() {
        let (machine, st) = forty_mm_line_with_a_cap_ramp();
        let (first, last) = (320, 480);
        let ends = (50.0, 50.0);
        let planner = RunPlanner::new(&st);
        let plan = |follow: bool, share: f64| {
            let (mut profile, mut gaps) = (Profile::empty(&st), Vec::new());
            planner
                .plan_direct(
                    (first, last),
                    ends,
                    (share, 0.0, follow),
                    &mut profile.speed_mm_s[first..=last],
                    Some(&mut gaps),
                )
                .map(|_| {
                    let s = &st.s_mm()[first..=last];
                    let time_s = exact_time_s(s, &profile.speed_mm_s[first..=last], &gaps);
                    (profile, gaps, time_s)
                })
        };
        let at_rest = plan(false, 1.0).map(|x| x.2);
        // What the planner kept before: the quickest filtered value; and the floor, the
        // stations' time at the passes' speeds under the caps (no jerk limit).
        let mut v = vec![0.0; st.len()];
        let filtered_s = SECTION_GRID
            .iter()
            .filter_map(|&lambda| {
                let window_s = lambda * base_window_s(&st);
                planner.plan_section(
                    (first, last),
                    (lambda, window_s),
                    ends,
                    &mut v[first..=last],
                )
            })
            .fold(f64::INFINITY, f64::min);
        let mut floor = st.cap_mm_min()[first..=last]
            .iter()
            .map(|c| c / 60.0)
            .collect::<Vec<f64>>();
        planner.passes_between(first, 1.0, &mut floor, ends);
        let floor_s: f64 = (0..last - first)
            .map(|k| interval_time_s(&st.s_mm()[first..=last], &floor, k))
            .sum();
        let fine = Machine {
            period_ms: 1.0,
            ..machine
        };
        for share in EXACT_SHARES {
            let (mut profile, gaps, time_s) = plan(true, share).expect("a shape");
            // The ramp is followed: some gap ends or starts accelerating.
            assert!(gaps.iter().any(|g| g.accelerated_ends()), "share {share}");
            if let Some(rest_s) = at_rest {
                assert!(time_s < rest_s, "share {share}: {time_s} vs {rest_s}");
            }
            assert!(
                time_s > floor_s && time_s < filtered_s,
                "{floor_s} {time_s} {filtered_s}"
            );
            let before = profile.speed_mm_s[first..=last].to_vec();
            let (start_s, end_s) = push_after_a_lead_in(
                &planner,
                &mut profile,
                (first, last),
                ends.0,
                &before,
                (&gaps, None),
            );
            assert!((end_s - start_s - time_s).abs() <= 1e-9);
            // The planner keeps it where its samples at the period verify.
            let ratio = profile.last_run_axis_ratio(None);
            println!(
                "ramp followed, share {share}: {time_s:.5} s (dips at rest: {at_rest:?}, filtered {filtered_s:.5} s, floor {floor_s:.5} s), ratio {ratio:.4}"
            );
            assert!(ratio <= 1.0, "share {share}: {ratio}");
            profile.cycle_time_s = end_s + 0.1;
            let samples = profile.sample(machine.period_ms).unwrap();
            assert!(worst_ratio(&machine, &samples) <= 1.0 + 1e-6);
            let samples = profile.sample(fine.period_ms).unwrap();
            let s = st.s_mm();
            let h = fine.period_s();
            assert_samples_keep_the_caps_and_accel(&samples, &st, &machine, h);
            // Inside the gaps, the changes' jerk: every 1 ms third difference whose
            // stencil lies in one is within the share of J.
            let j = share * machine.jerk_mm_s3.unwrap()[0];
            let mut inside = 0;
            for gap in &profile.gaps {
                let span = gap.motion.time_at_s(s[gap.last] - s[gap.first]);
                let (from, to) = (gap.start_s, gap.start_s + span);
                for w in samples.windows(4) {
                    if w[0].t_s >= from && w[3].t_s <= to {
                        let x = w.iter().map(|p| p.pos[0]).collect::<Vec<f64>>();
                        let third = (x[3] - 3.0 * x[2] + 3.0 * x[1] - x[0]) / h / h / h;
                        assert!(third.abs() <= j * (1.0 + 1e-6), "share {share}: {third}");
                        inside += 1;
                    }
                }
            }
            assert!(inside > 50, "{inside}");
        }
    }

    /// Sections shaped by sequential linear programs (MODEL.md §6.1, "Sections by linear
    /// programs"), on the 40 mm line at F3000 (a = 1 000 mm/s², j = 20 000 mm/s³, T = 16 ms)
    /// between the stations at 16 and 24 mm:
    ///
    /// * the flying move from c = 1 150 mm/min to 50 mm/s and back, entered and left with
    ///   no acceleration, whose optimum is the closed form 2τ + (8 − (c + 50)·τ)/50 with
    ///   τ = 2√((50 − c)/j): the programs' motion (at σ = 1, from the caps' passes) takes
    ///   it within 2 % (their jerk rows start at 0.97·j) and no less than it less 10⁻³, and
    ///   less than the section followed exactly (whose ends are held at c over a station);
    /// * the cap ramp of `a_cap_ramp_is_followed_within_the_caps_at_every_sample` (caps
    ///   3 + 31.25·|x − 20| mm/s): the programs' motion, from the followed ramp at that
    ///   share, is slower than the floor (the passes under the caps, no jerk limit) and at
    ///   σ = 1 and 0.9 quicker than the followed ramp (0.28623 against 0.28979 s at σ = 1;
    ///   at 0.75, 0.29854 against 0.29331 s: the planner keeps the quickest); planned from rest into the section as the planner
    ///   does, its samples at the period keep every axis' acceleration and jerk, and every
    ///   1 ms sample the acceleration and the caps.
    #[test]
    fn sections_shaped_by_linear_programs_meet_the_closed_form_and_keep_the_limits() {
        let (first, last) = (320, 480);
        // The flying move.
        let (machine, st) = flying_move_line();
        let c = 1150.0 / 60.0;
        let planner = RunPlanner::new(&st);
        let mut v = planner.caps_mm_s[first..=last].to_vec();
        planner.passes_between(first, 1.0, &mut v, (c, c));
        let mut accel = vec![0.0; v.len()];
        let time_s = planner
            .plan_programmed((first, last), (c, c), 1.0, (&mut v, &mut accel))
            .expect("a motion");
        let (j, top) = (machine.jerk_mm_s3.unwrap()[0], 50.0);
        let tau = 2.0 * ((top - c) / j).sqrt();
        let expected = 2.0 * tau + (8.0 - (c + top) * tau) / top;
        let mut exact = vec![0.0; st.len()];
        let mut gaps = Vec::new();
        planner
            .plan_direct(
                (first, last),
                (c, c),
                (1.0, 0.0, false),
                &mut exact[first..=last],
                Some(&mut gaps),
            )
            .expect("a shape");
        let exact_s = exact_time_s(&st.s_mm()[first..=last], &exact[first..=last], &gaps);
        println!(
            "flying move by linear programs {time_s:.6} s, closed form {expected:.6} s, followed exactly {exact_s:.6} s"
        );
        assert!(time_s <= expected * 1.03 && time_s >= expected);
        assert!(exact_s >= expected);
        // The cap ramp.
        let (machine, st) = forty_mm_line_with_a_cap_ramp();
        let ends = (50.0, 50.0);
        let planner = RunPlanner::new(&st);
        let s = &st.s_mm()[first..=last];
        let mut floor = planner.caps_mm_s[first..=last].to_vec();
        planner.passes_between(first, 1.0, &mut floor, ends);
        let floor_s: f64 = (0..last - first)
            .map(|k| interval_time_s(s, &floor, k))
            .sum();
        let fine = Machine {
            period_ms: 1.0,
            ..machine
        };
        for share in EXACT_SHARES {
            let mut profile = Profile::empty(&st);
            let mut gaps = Vec::new();
            planner
                .plan_direct(
                    (first, last),
                    ends,
                    (share, 0.0, true),
                    &mut profile.speed_mm_s[first..=last],
                    Some(&mut gaps),
                )
                .expect("a followed shape");
            let followed_s = exact_time_s(s, &profile.speed_mm_s[first..=last], &gaps);
            let mut v = profile.speed_mm_s[first..=last].to_vec();
            let mut accel = vec![0.0; v.len()];
            let time_s = planner
                .plan_programmed((first, last), ends, share, (&mut v, &mut accel))
                .expect("a motion");
            println!(
                "ramp by linear programs, share {share}: {time_s:.5} s (followed {followed_s:.5} s, floor {floor_s:.5} s)"
            );
            assert!(time_s > floor_s && (share < 0.9 || time_s < followed_s));
            let (start_s, end_s) = push_after_a_lead_in(
                &planner,
                &mut profile,
                (first, last),
                ends.0,
                &v,
                (&[], Some(&accel)),
            );
            assert!((end_s - start_s - time_s).abs() <= 1e-9);
            let ratio = profile.last_run_axis_ratio(None);
            assert!(ratio <= 1.0, "share {share}: {ratio}");
            profile.cycle_time_s = end_s + 0.1;
            let samples = profile.sample(machine.period_ms).unwrap();
            assert!(worst_ratio(&machine, &samples) <= 1.0 + 1e-6);
            let samples = profile.sample(fine.period_ms).unwrap();
            let h = fine.period_s();
            assert_samples_keep_the_caps_and_accel(&samples, &st, &machine, h);
            // The motion's jerk at every instant: every 1 ms third difference whose
            // stencil lies in the section is within σ·J.
            let j = share * machine.jerk_mm_s3.unwrap()[0];
            let mut inside = 0;
            for w in samples.windows(4) {
                if w[0].t_s >= start_s && w[3].t_s <= end_s {
                    inside += 1;
                    let third = (w[3].pos[0] - 3.0 * w[2].pos[0] + 3.0 * w[1].pos[0] - w[0].pos[0])
                        / (h * h * h);
                    assert!(third.abs() <= j * (1.0 + 1e-3), "share {share}: {third}");
                }
            }
            assert!(inside > 200, "{inside}");
        }
    }
}
