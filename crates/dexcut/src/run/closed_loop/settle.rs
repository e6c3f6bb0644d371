//! Whether the closed loop can change the rigid sweep's answer by more than
//! its tolerance at all (MODEL.md §5.1, "A tool that barely bends: the loop
//! settled from the rigid sweep", eq. 5.1e), decided from the rigid sweep
//! alone, before any trial is swept.

use cutting::StepLoad;
use dexel::{RemovalRecord, ToolShape};

use super::{loop_direction, within, LOOP_TOL_UM};
use crate::motion::TimedStep;
use crate::run::StepTools;

/// What the rigid sweep tells of every step the loop would seek: the
/// largest change its deflection could make to any such step's deflection,
/// µm (eq. 5.1e), where every one is within the loop's tolerance of its
/// rigid deflection; `None` where some step's could be more.
///
/// A step's load follows the cross-section of its cut, A = V/L (its volume
/// over its XY advance). Moving the tool across its path by x, while the
/// steps that left the material it meets moved by x′, changes that section
/// by the sliver |x − x′|·h, h the height of the engaged edge (from the
/// lowest to the highest band the step removed in). Every root lies in
/// [0, δ₀] along its own direction (g − x falls with x), so |x − x′| ≤ X,
/// the largest rigid deflection across the path of the tool's steps in the
/// loop. Where the engaged edge is vertical (a flat end's side, a bull
/// nose's above its corner, a ball's above its equator) the grid resolves a
/// sideways move only by whole rows of columns: a move of less than a cell
/// can take or leave a row, so the sliver is (X + grid)·h there. The force
/// (Kienzle: ∝ b·h^(1−mc), mc ≥ 0) changes by no more than its section, and
/// the deflection it causes anywhere on the edge by no more than the tip's
/// (the tip is where the tool is most compliant), so
///
///   |g(x) − g(0)| ≤ B = δ_tip · (X + w)·h / A,  w = grid or 0   (5.1e)
///
/// and the root x* = g(x*) lies within B of the rigid deflection. Steps
/// with shank contact, a section under one cell of advance (their load
/// comes in whole columns, MODEL.md §1.5) or no volume are never settled
/// so (unless the rigid tool hardly bends there at all: δ_tip ≤ the
/// tolerance, where x* ∈ [0, δ₀] is within it of δ₀ whatever the cut).
pub(crate) fn settled_bound_um(
    steps: &[TimedStep],
    of_step: StepTools,
    (step_loads, record): (&[StepLoad], &RemovalRecord),
    in_loop: &[bool],
    inherited: &[bool],
    rigid: &[f64],
    grid_mm: f64,
) -> Option<f64> {
    let n = steps.len();
    if record.len() != n {
        return None;
    }
    // X: per tool, the largest rigid deflection across the path, mm.
    let mut largest_mm = vec![0.0_f64; of_step.tools.entries.len()];
    for i in (0..n).filter(|&i| in_loop[i] && !inherited[i]) {
        let t = &mut largest_mm[of_step.tool_of_step[i]];
        *t = t.max(1e-3 * rigid[i]);
    }
    let mut bound_um = 0.0_f64;
    for i in (0..n).filter(|&i| in_loop[i]) {
        // A step that took its direction starts where the step before it
        // ended: with every step of its tool left put, at 0 (eq. 5.1a).
        if inherited[i] {
            continue;
        }
        let largest = largest_mm[of_step.tool_of_step[i]];
        let b = step_bound_um(steps, of_step, record, i, &step_loads[i], largest, grid_mm)?;
        if !within(b, rigid[i]) {
            return None;
        }
        bound_um = bound_um.max(b);
    }
    Some(bound_um)
}

/// Step i's bound B of eq. 5.1e with its load `load` and X = `largest_mm`
/// (mm); `None` where its section is one the grid does not resolve and the
/// tool bends there by more than the tolerance (never settled so), else,
/// for such a section, the tip's deflection.
fn step_bound_um(
    steps: &[TimedStep],
    of_step: StepTools,
    record: &RemovalRecord,
    i: usize,
    load: &StepLoad,
    largest_mm: f64,
    grid_mm: f64,
) -> Option<f64> {
    let tip_um = load.tip_deflection_um.abs();
    let Some(Section {
        advance_mm,
        volume_mm3,
        lowest,
        highest,
    }) = section(steps, of_step.tool_of_step, record, i, grid_mm)
    else {
        // (A section the grid does not resolve: settled only where the
        // tool hardly bends at all.)
        return (tip_um <= LOOP_TOL_UM).then_some(tip_um);
    };
    let band_mm = record.band_height_mm;
    let engaged_mm = (highest + 1 - lowest) as f64 * band_mm;
    let top_mm = (highest + 1) as f64 * band_mm;
    let tool = &of_step.tools.entries[of_step.tool_of_step[i]].tool;
    let rounded_mm = match tool.shape {
        ToolShape::Ball => 0.5 * tool.diameter_mm,
        ToolShape::Flat => 0.0,
        ToolShape::Bull { corner_radius_mm } => corner_radius_mm,
    };
    // (The band holding the corner's top counts as vertical.)
    let vertical = top_mm > rounded_mm;
    let sliver_mm = largest_mm + if vertical { grid_mm } else { 0.0 };
    let section_mm2 = volume_mm3 / advance_mm;
    Some(tip_um * sliver_mm * engaged_mm / section_mm2)
}

/// A guess, from step i's rigid load `load` alone, that the closed loop
/// will run (MODEL.md §5.1): a feed step pushed across its path by more
/// than the tolerance whose own deflection, as X, already puts eq. 5.1e's
/// bound beyond it (X is at least that). It neither converges nor settles
/// there unless its tool is left rigid (overloaded elsewhere) or its
/// direction is another's (the plan decides those); a guess decides only
/// how the rigid pass's loads are made, not what they are.
pub(crate) fn loop_likely(
    steps: &[TimedStep],
    of_step: StepTools,
    record: &RemovalRecord,
    i: usize,
    load: &StepLoad,
    grid_mm: f64,
) -> bool {
    let step = &steps[i].step;
    if step.rapid {
        return false;
    }
    let motion = [
        step.to_mm[0] - step.from_mm[0],
        step.to_mm[1] - step.from_mm[1],
    ];
    let [dx, dy] = loop_direction(load.dx_um, load.dy_um, motion);
    let rigid_um = (load.dx_um * dx + load.dy_um * dy).max(0.0);
    rigid_um > LOOP_TOL_UM
        && step_bound_um(steps, of_step, record, i, load, 1e-3 * rigid_um, grid_mm)
            .is_none_or(|b| !within(b, rigid_um))
}

/// The cut of a step over the path the grid resolves: its XY advance, mm,
/// its volume, mm³, and the lowest and highest bands it removed in.
struct Section {
    advance_mm: f64,
    volume_mm3: f64,
    lowest: usize,
    highest: usize,
}

/// Longest run of steps a section is taken over.
const SECTION_STEPS: usize = 64;

/// Step `i`'s [`Section`]: where it advances less than a grid cell, over the
/// feed steps of the same cut around it that advance a cell together (its
/// load comes from the removal per unit length over such a window, MODEL.md
/// §1.6); `None` where that takes more than [`SECTION_STEPS`] steps, where
/// it removed nothing or where it touched the stock with the shank.
fn section(
    steps: &[TimedStep],
    tool_of_step: &[usize],
    record: &RemovalRecord,
    i: usize,
    grid_mm: f64,
) -> Option<Section> {
    let advance = |p: usize| {
        let [fx, fy, _] = steps[p].step.from_mm;
        let [tx, ty, _] = steps[p].step.to_mm;
        (tx - fx).hypot(ty - fy)
    };
    // Step p continues step p − 1: a feed step of the same tool starting
    // where it ended.
    let continues = |p: usize| {
        p > 0
            && p < steps.len()
            && !steps[p].step.rapid
            && !steps[p - 1].step.rapid
            && steps[p - 1].step.to_mm == steps[p].step.from_mm
            && tool_of_step[p - 1] == tool_of_step[p]
    };
    let (mut a, mut b) = (i, i);
    let mut advance_mm = advance(i);
    while advance_mm < grid_mm && b - a < SECTION_STEPS {
        if continues(b + 1) {
            b += 1;
            advance_mm += advance(b);
        } else if continues(a) {
            a -= 1;
            advance_mm += advance(a);
        } else {
            return None;
        }
        if advance_mm < grid_mm && continues(a) {
            a -= 1;
            advance_mm += advance(a);
        }
    }
    if advance_mm < grid_mm {
        return None;
    }
    let mut volume_mm3 = 0.0;
    let (mut lowest, mut highest) = (usize::MAX, 0);
    for p in a..=b {
        if record.shank_volume_mm3(p) > 0.0 {
            return None;
        }
        volume_mm3 += record.volume_mm3(p);
        let bands = record.band_volumes_mm3(p);
        if let Some(k) = bands.iter().position(|&v| v > 0.0) {
            lowest = lowest.min(k);
        }
        if let Some(k) = bands.iter().rposition(|&v| v > 0.0) {
            highest = highest.max(k);
        }
    }
    (volume_mm3 > 0.0 && lowest <= highest).then_some(Section {
        advance_mm,
        volume_mm3,
        lowest,
        highest,
    })
}
