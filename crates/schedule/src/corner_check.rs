//! The public constructors of [`Stations`]: the stations built, their corners stopped at
//! or passed, and with a jerk limit that choice checked by the planner (MODEL.md §6.1,
//! "Stop or pass"). Above both `stations` and [`crate::plan`](mod@crate::plan).

use nc::Path;

use crate::machine::{Machine, ScheduleError};
use crate::plan::plan;
use crate::stations::{CornerChoice, Corners, FeedPolicy, Stations};

impl Stations {
    /// Discretises `path` at station spacing `ds_mm` and sets the caps that follow from the
    /// program and the machine:
    ///
    /// * the programmed feed (or `feed_max_mm_min` under [`FeedPolicy::MachineMax`]), never
    ///   above `feed_max_mm_min`; rapids at `rapid_mm_min`;
    /// * curvature: v ≤ sqrt(a_n · r) on arcs, a_n the smaller acceleration limit of the
    ///   arc plane's two axes, r the arc radius (conservative on a helix), then the sampled
    ///   geometry rule below, which takes half of it;
    /// * corners: where the unit tangent jumps by Δt between segments, the control crosses
    ///   the corner within one period T, so each axis' velocity steps by v·|Δt_i|; the
    ///   corner rule keeps that step within half of what the axis reaches in one period,
    ///   v·|Δt_i| ≤ a_i·T/2 for every axis i, so that the step plus the ramps on either
    ///   side stay within a_i in the sampled positions (second differences / T²);
    /// * block time (S0): with block time Tb, a segment of length L is capped at
    ///   60000·L/Tb mm/min.
    /// * with a jerk limit j the corner step also obeys v·|Δt_i| ≤ j_i·T²/2 (the step's third
    ///   difference is at most v·|Δt_i|/T²); the planner holds the speed constant around the
    ///   corner (see [`crate::plan`]), so the other half covers the sampling phase.
    ///
    /// * sampled geometry (MODEL.md §6.1): wherever the path turns (arcs, corners, runs of
    ///   short chords), the second (and third) differences of samples at the fastest speed
    ///   a plan can have there stay within half the axis limits, and the tangential
    ///   acceleration gets the rest;
    /// * each corner stopped at or passed, whichever is quicker (MODEL.md §6.1, "Stop or
    ///   pass"), with a jerk limit checked by the planner run by run.
    ///
    /// Dwells become stops. Zero-length moves are skipped. More than [`MAX_STATIONS`](crate::MAX_STATIONS)
    /// stations is an error ([`ScheduleError::TooManyStations`]), checked before allocating.
    pub fn new(
        path: &Path,
        machine: &Machine,
        ds_mm: f64,
        policy: FeedPolicy,
    ) -> Result<Self, ScheduleError> {
        Self::with_corners(path, machine, ds_mm, policy, Corners::Judged)
    }

    /// [`Stations::new`] with every corner passed at the corner rule's speed
    /// ([`Corners::Passed`]), every corner a stop ([`Corners::Stopped`]) or each judged
    /// ([`Corners::Judged`], what [`Stations::new`] does).
    pub fn with_corners(
        path: &Path,
        machine: &Machine,
        ds_mm: f64,
        policy: FeedPolicy,
        corners: Corners,
    ) -> Result<Self, ScheduleError> {
        let estimate = Self::check(path, machine, ds_mm, policy)?;
        let built = Self::build_with(
            path.segments.clone(),
            machine,
            ds_mm,
            policy,
            estimate,
            corners,
        );
        built.map(checked).map_err(|(e, _)| e)
    }

    /// [`Stations::new`] on a path handed to the stations rather than copied (a
    /// million-block path is about 120 MB); [`Stations::into_path`] gives it back, and an
    /// error comes with it.
    pub fn from_path(
        path: Path,
        machine: &Machine,
        ds_mm: f64,
        policy: FeedPolicy,
    ) -> Result<Self, (ScheduleError, Path)> {
        match Self::check(&path, machine, ds_mm, policy) {
            Ok(estimate) => Self::build_with(
                path.segments,
                machine,
                ds_mm,
                policy,
                estimate,
                Corners::Judged,
            )
            .map(checked)
            .map_err(|(e, segments)| (e, Path::from_segments(segments))),
            Err(e) => Err((e, path)),
        }
    }
}

/// Built stations with their corners' choice checked where there is one to check.
fn checked((mut stations, choice): (Stations, Option<CornerChoice>)) -> Stations {
    if let Some(choice) = choice {
        choose_runs_by_plan(&mut stations, &choice);
    }
    stations
}

/// With a jerk limit the envelope does not see the filter (its holds at passed corners,
/// its width W at every stop), so the envelope's choice is checked by the planner itself
/// (MODEL.md §6.1, "Stop or pass"): the path is planned with the corners as the envelope
/// chose and with every corner a stop, and each run between the program's own stops
/// keeps the quicker of the two (runs plan apart: each starts and ends at rest).
fn choose_runs_by_plan(stations: &mut Stations, choice: &CornerChoice) {
    let own_stops = choice.own_stops();
    let mut leave_times = |passed: &dyn Fn(usize) -> bool| {
        stations.limit_with(choice, passed);
        plan(stations).leave_times_s(&own_stops)
    };
    let judged = leave_times(&|index| choice.pass[index]);
    let stopped = leave_times(&|_| false);
    // Run r goes from own stop r to r + 1: as judged where no slower so.
    let keep_judged: Vec<bool> = (0..own_stops.len().saturating_sub(1))
        .map(|r| judged[r + 1] - judged[r] <= stopped[r + 1] - stopped[r])
        .collect();
    let run_of = |station: usize| own_stops.partition_point(|&x| x <= station) - 1;
    stations.limit_with(choice, &|index| {
        choice.pass[index] && keep_judged.get(run_of(choice.corner_station(index))) != Some(&false)
    });
}
