//! Feed rules from the source documents as pure functions.

/// Floor of the S0 chord tolerance in mm: finer chords gain nothing measurable.
const CHORD_TOLERANCE_FLOOR_MM: f64 = 0.001;

/// S0 chord tolerance in mm for curvature radius `radius_mm`, feed `feed_mm_min`, block
/// processing time `block_time_ms` and safety factor `kf` (≳ 1): the chord error of a block
/// just long enough for the control to read the next one in time, floored at 0.001 mm.
/// Where the radius is too small for such a block (α F² ≥ r²) the tolerance is the radius.
pub fn chord_tolerance_mm(radius_mm: f64, feed_mm_min: f64, block_time_ms: f64, kf: f64) -> f64 {
    // MODEL.md §6.2 (S0): Ce = r − sqrt(r² − α F²), α = (kf · Tb)² / 1.44e10.
    let alpha = (kf * block_time_ms).powi(2) / 1.44e10;
    let chord2 = alpha * feed_mm_min * feed_mm_min;
    let r2 = radius_mm * radius_mm;
    let ce = if chord2 >= r2 {
        radius_mm
    } else {
        radius_mm - (r2 - chord2).sqrt()
    };
    ce.max(CHORD_TOLERANCE_FLOOR_MM)
}

/// S0 feed cap in mm/min of a block of length `len_mm` when each block takes
/// `block_time_ms` to process.
pub fn block_feed_cap_mm_min(len_mm: f64, block_time_ms: f64) -> f64 {
    // MODEL.md §6.2 (S0): F ≤ 60000 · Lb / Tb.
    60000.0 * len_mm / block_time_ms
}

/// S3 feed in mm/min of a ball-end mill cutting a surface whose normal is `theta_deg` from
/// the tool axis, with nominal feed `feed_mm_min` and floor feed `v0_mm_min`.
pub fn angle_rule_feed_mm_min(theta_deg: f64, feed_mm_min: f64, v0_mm_min: f64) -> f64 {
    // MODEL.md §6.3 (S3): F(θ) = v0 for θ < θk, F·θ/90° for θk ≤ θ ≤ 90°, θk = 90°·v0/F.
    let theta_k_deg = 90.0 * v0_mm_min / feed_mm_min;
    if theta_deg < theta_k_deg {
        v0_mm_min
    } else {
        feed_mm_min * theta_deg / 90.0
    }
}
