//! The planner's entry, [`plan`]: the runs between stops one after another, each
//! verified, then cut into sections where that is quicker.

use super::profile::Profile;
use super::run_planner::{
    RunPlanner, AHEAD_STATIONS, LAMBDA_GRID_MAX_STATIONS, LAMBDA_SEARCH_MAX_STATIONS,
};
use super::verify::{Verified, REPAIR_MAX_TRIES, SLOW_MAX_TRIES};
use crate::stations::Stations;

/// The filter window at λ = 1, s: the largest a/j over the stations'
/// intervals (0 without a jerk limit; MODEL.md §6.1).
pub(super) fn base_window_s(stations: &Stations) -> f64 {
    stations.interval_jerk_mm_s3().map_or(0.0, |jerk| {
        stations
            .interval_accel_mm_s2()
            .iter()
            .zip(jerk)
            .map(|(a, j)| a / j)
            .fold(0.0, f64::max)
    })
}

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
pub(super) fn plan_ahead(stations: &Stations, ahead_stations: usize) -> Profile<'_> {
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
        let run = planner.verified_run(
            &mut profile,
            (pair[0], pair[1]),
            base_window_s,
            &candidates,
            (REPAIR_MAX_TRIES, SLOW_MAX_TRIES),
        );
        let mut end_s = run.end_s;
        // Sections on runs the grid of λ is tried on, or the search (not on longer runs:
        // each value plans the whole run once more, for little on the 1 M-block raster).
        if base_window_s > 0.0
            && last - first <= LAMBDA_GRID_MAX_STATIONS
            && !matches!(run.verified, Verified::Slowed { .. })
        {
            let kept = (run.lambda, run.window_s);
            if let Some(sectioned_end_s) = planner.sectioned(&mut profile, base_window_s, kept) {
                end_s = sectioned_end_s;
            }
        }
        let window_s = profile.runs.last().map_or(0.0, |run| run.window_s);
        profile.cycle_time_s = end_s + (window_s + pair[1].dwell_s);
    }
    profile
}
