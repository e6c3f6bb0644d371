//! An arc cut into chords as grbl 1.1's `mc_arc` (motion_control.c) cuts it
//! (MODEL.md §6.4, "Arcs").

use nalgebra::Point3;

/// Corrections of the rotated radius vector by an exact sin/cos every this many chords
/// (grbl's `N_ARC_CORRECTION`).
const N_ARC_CORRECTION: usize = 12;

/// The chord end points of the arc from `start` around `center` in the plane of axes
/// `(a0, a1)` (linear axis `al`) to `end`, turning `sweep_rad` (> 0; clockwise when
/// `clockwise`), as `mc_arc` sends them to the planner: n = ⌊|θ·r/2| / √(tol·(2r − tol))⌋
/// chords (MODEL.md eq. 6.4.3), n − 1 points by the small-angle rotation with an exact
/// correction every [`N_ARC_CORRECTION`] points, then `end` itself.
#[allow(clippy::too_many_arguments)]
pub(super) fn chords(
    start: &Point3<f64>,
    end: &Point3<f64>,
    center: &Point3<f64>,
    (a0, a1, al): (usize, usize, usize),
    clockwise: bool,
    sweep_rad: f64,
    tolerance_mm: f64,
    out: &mut Vec<[f64; 3]>,
) {
    let offset = [center[a0] - start[a0], center[a1] - start[a1]];
    let radius = offset[0].hypot(offset[1]);
    let angular_travel = if clockwise { -sweep_rad } else { sweep_rad };
    let denominator = (tolerance_mm * (2.0 * radius - tolerance_mm)).sqrt();
    let segments = if denominator > 0.0 {
        ((0.5 * angular_travel * radius).abs() / denominator).floor() as usize
    } else {
        0
    };
    if segments > 0 {
        let theta = angular_travel / segments as f64;
        let linear = (end[al] - start[al]) / segments as f64;
        // cos ≈ 1 − θ²/2, sin ≈ θ − θ³/6, as grbl computes them.
        let mut cos_t = 2.0 - theta * theta;
        let sin_t = theta * 0.16666667 * (cos_t + 4.0);
        cos_t *= 0.5;
        let (mut r0, mut r1) = (-offset[0], -offset[1]);
        let mut position: [f64; 3] = start.coords.into();
        let mut count = 0;
        for i in 1..segments {
            if count < N_ARC_CORRECTION {
                let ri = r0 * sin_t + r1 * cos_t;
                r0 = r0 * cos_t - r1 * sin_t;
                r1 = ri;
                count += 1;
            } else {
                let (sin_i, cos_i) = (i as f64 * theta).sin_cos();
                r0 = -offset[0] * cos_i + offset[1] * sin_i;
                r1 = -offset[0] * sin_i - offset[1] * cos_i;
                count = 0;
            }
            position[a0] = center[a0] + r0;
            position[a1] = center[a1] + r1;
            position[al] += linear;
            out.push(position);
        }
    }
    out.push(end.coords.into());
}
