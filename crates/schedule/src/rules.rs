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

/// S0: how many equal chords an arc of radius `radius_mm` sweeping `sweep_rad` is written
/// as, for chord tolerance `chord_tolerance_mm` (from [`chord_tolerance_mm`]). MODEL.md §6.2:
/// the most chords whose sagitta is still at least the tolerance, `⌊sweep / θ⌋` with
/// `θ = 2·acos(1 − Ce/r)` the angle of one chord on the chord-error surface, so each block is
/// at least `kf·F·Tb/60000` long and the control reads the next in time. At least 1.
pub fn chord_count(radius_mm: f64, sweep_rad: f64, chord_tolerance_mm: f64) -> usize {
    let ratio = (1.0 - chord_tolerance_mm / radius_mm).clamp(-1.0, 1.0);
    let theta = 2.0 * ratio.acos();
    if !(theta > 0.0) {
        return 1;
    }
    // A hair of slack so that an exact multiple is not lost to rounding.
    ((sweep_rad / theta) * (1.0 + 1e-12)).floor().max(1.0) as usize
}

/// S0: the path with every feed arc written as equal chords within S0's chord tolerance
/// for its programmed feed (MODEL.md §6.2, [`chord_count`]), as a CAM or a control
/// without arc interpolation would run it. Other segments are kept, and so is the
/// program's path control and its motion waits (each at the first chord of its
/// segment).
pub fn linearise_arcs(path: &nc::Path, block_time_ms: f64, kf: f64) -> nc::Path {
    let mut segments = Vec::with_capacity(path.segments.len());
    // Where each segment's first piece lands in the new list.
    let mut first_piece = Vec::with_capacity(path.segments.len() + 1);
    for seg in &path.segments {
        first_piece.push(segments.len());
        match (seg.geometry, seg.motion) {
            (nc::Geometry::Arc { sweep_rad, .. }, nc::Motion::Feed { feed_mm_min, .. }) => {
                let r = seg.radius_mm();
                let ce = chord_tolerance_mm(r, feed_mm_min, block_time_ms, kf);
                let n = chord_count(r, sweep_rad, ce);
                let mut from = seg.start;
                for i in 1..=n {
                    let to = if i == n {
                        seg.end
                    } else {
                        seg.point_at_fraction(i as f64 / n as f64)
                    };
                    segments.push(nc::Segment {
                        start: from,
                        end: to,
                        geometry: nc::Geometry::Line,
                        ..*seg
                    });
                    from = to;
                }
            }
            _ => segments.push(*seg),
        }
    }
    first_piece.push(segments.len());
    let path_control = path
        .path_control
        .iter()
        .map(|c| nc::PathControlChange {
            first_segment: first_piece[c.first_segment.min(path.segments.len())],
            mode: c.mode,
        })
        .collect();
    let motion_waits = path
        .motion_waits
        .iter()
        .map(|&k| first_piece[k.min(path.segments.len())])
        .collect();
    nc::Path {
        segments,
        path_control,
        motion_waits,
    }
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
