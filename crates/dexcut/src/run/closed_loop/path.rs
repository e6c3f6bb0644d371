//! The path the closed loop sweeps: the steps moved by their offsets, and
//! the directions in which the loop moves them (MODEL.md §5.1).

use super::{LOOP_AT_POINT_SIDE_LOAD_UM, LOOP_NO_SIDE_LOAD_UM};
use crate::motion::TimedStep;

/// Step `i` of `steps` with the tool moved sideways by `offsets_mm` (per
/// step, at its end; a step that continues the previous one starts at the
/// previous offset, so the offset path stays continuous). Made where a sweep
/// asks for it (`dexel::StepFn`): the closed loop's passes hold no list of
/// the moved steps (56 B a step).
pub(crate) fn offset_step(steps: &[TimedStep], offsets_mm: &[[f64; 2]], i: usize) -> dexel::Step {
    let s = &steps[i];
    let o = offsets_mm[i];
    let start = if i > 0 && steps[i - 1].step.to_mm == s.step.from_mm {
        offsets_mm[i - 1]
    } else {
        o
    };
    let [fx, fy, fz] = s.step.from_mm;
    let [tx, ty, tz] = s.step.to_mm;
    dexel::Step {
        from_mm: [fx + start[0], fy + start[1], fz],
        to_mm: [tx + o[0], ty + o[1], tz],
        rapid: s.step.rapid,
    }
}

/// The tool's offset per step, µm: `magnitude · direction` for feed steps; a
/// rapid keeps the offset of the feed step before it (the tool leaves the cut
/// where it was, and no rapid cuts what the bent tool left).
pub(crate) fn applied_offsets_um(
    steps: &[TimedStep],
    magnitude: &[f64],
    dirs: &[[f64; 2]],
) -> Vec<[f64; 2]> {
    let mut carried = [0.0, 0.0];
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            if !s.step.rapid {
                carried = [magnitude[i] * dirs[i][0], magnitude[i] * dirs[i][1]];
            }
            carried
        })
        .collect()
}

/// Unit direction in which the closed loop moves a step's tool: the rigid
/// deflection `(dx, dy)` without its component along the step's XY motion
/// `m` (MODEL.md §5.1); zero when no more than [`LOOP_NO_SIDE_LOAD_UM`] is
/// left (an even plunge's round-off has no direction), or at one point (no
/// XY motion) no more than [`LOOP_AT_POINT_SIDE_LOAD_UM`] (eq. 5.1d).
pub(crate) fn loop_direction(dx: f64, dy: f64, m: [f64; 2]) -> [f64; 2] {
    let m2 = m[0] * m[0] + m[1] * m[1];
    let along = if m2 > 0.0 {
        (dx * m[0] + dy * m[1]) / m2
    } else {
        0.0
    };
    let (px, py) = (dx - along * m[0], dy - along * m[1]);
    let len = (px * px + py * py).sqrt();
    let floor = if m2 > 0.0 {
        LOOP_NO_SIDE_LOAD_UM
    } else {
        LOOP_AT_POINT_SIDE_LOAD_UM
    };
    if len > floor && len.is_finite() {
        [px / len, py / len]
    } else {
        [0.0, 0.0]
    }
}

/// Which steps take the direction of the step before them: each feed step
/// without a direction of its own (`dirs`, from [`loop_direction`]: the
/// rigid tool removes nothing in it, or pushes it along its path only) that
/// continues a feed step with one, its own or taken (same tool, starting
/// where it ended), that the loop moves (`in_loop`), along the chain of
/// such steps (MODEL.md §5.1, eq. 5.1a); plunges (down, with no XY motion)
/// excepted: a plunge moved sideways by a fraction of a µm is no longer a
/// plunge to the removal, whose resultant keeps the lattice's bias (§1.4):
/// a few µm of false side load, the size of the offsets it would relax.
/// Such a step starts where that step's offset left the tool, so the loop
/// seeks its own offset as the equilibrium along that direction (a fraction
/// of the offset it starts at, [`Fraction`]): the offset relaxes with the
/// load that sustains it instead of the tool sweeping back to the
/// programmed path within one step. `dirs` gets the directions taken.
pub(crate) fn inherit_directions(
    steps: &[TimedStep],
    tool_of_step: &[usize],
    dirs: &mut [[f64; 2]],
    in_loop: &[bool],
) -> Vec<bool> {
    let mut inherited = vec![false; steps.len()];
    for i in 1..steps.len() {
        let (before, s) = (&steps[i - 1], &steps[i]);
        let [fx, fy, fz] = s.step.from_mm;
        let [tx, ty, tz] = s.step.to_mm;
        let plunge = fx == tx && fy == ty && tz < fz;
        if dirs[i] == [0.0, 0.0]
            && !plunge
            && (in_loop[i - 1] || inherited[i - 1])
            && !s.step.rapid
            && !before.step.rapid
            && before.step.to_mm == s.step.from_mm
            && tool_of_step[i - 1] == tool_of_step[i]
        {
            dirs[i] = dirs[i - 1];
            inherited[i] = true;
        }
    }
    inherited
}
