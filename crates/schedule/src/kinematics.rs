//! Constant-acceleration kinematics over one station interval, shared by the planner
//! ([`crate::plan`](mod@crate::plan)) and the sections shaped directly ([`crate::direct`]).

/// Time over the interval from station `k` to `k + 1` of a plan `v` over stations `s`
/// with a constant acceleration in it, s: 2·Δs/(v_k + v_{k+1}).
pub(crate) fn interval_time_s(s: &[f64], v: &[f64], k: usize) -> f64 {
    2.0 * (s[k + 1] - s[k]) / (v[k] + v[k + 1])
}

/// Acceleration over the interval from station `k` to `k + 1` of a plan `v` over stations
/// `s` with a constant acceleration in it, mm/s²: (v²_k+1 − v²_k)/(2·Δs).
pub(crate) fn interval_accel_mm_s2(s: &[f64], v: &[f64], k: usize) -> f64 {
    (v[k + 1] * v[k + 1] - v[k] * v[k]) / (2.0 * (s[k + 1] - s[k]))
}

/// ∫ (s − s_first) dt over the first `h_s` seconds of an interval that starts `offset_mm` past
/// the run's first station at speed `v0_mm_s` with constant acceleration `a_mm_s2`, mm·s.
pub(crate) fn integral_over_mm_s(offset_mm: f64, v0_mm_s: f64, a_mm_s2: f64, h_s: f64) -> f64 {
    offset_mm * h_s + v0_mm_s * h_s * h_s / 2.0 + a_mm_s2 * h_s * h_s * h_s / 6.0
}
