//! The closed loop between removal and deflection (MODEL.md §5.1): each
//! step's search for its offset ([`search`]), the moved path ([`path`]),
//! the sub-cell windows ([`windows`]), and the loop's passes over a
//! [`LoopState`].

use cutting::StepLoad;
use dexel::{RemovalRecord, Stock, SweepOptions};

use super::loads::Removals;
use super::{sweep_pass, Initial, StepTools, SUB_CELL_WINDOW_CELLS};
use crate::error::Result;
use crate::motion::TimedStep;

pub(crate) mod path;
pub(crate) mod search;
pub(crate) mod settle;
pub(crate) mod windows;

pub(crate) use path::{applied_offsets_um, inherit_directions, loop_direction, offset_step};
use search::{Bracketed, Fraction};
pub(crate) use windows::{residual_terms, sub_cell_windows, window_residual, WindowSums};

/// Closed loop (MODEL.md §5.1): at most this many sweeps...
pub const LOOP_MAX_PASSES: usize = 16;
/// ... until every step's deflection agrees with its applied offset within
/// this many µm plus [`LOOP_REL_TOL`] of the offset...
pub const LOOP_TOL_UM: f64 = 0.5;
pub const LOOP_REL_TOL: f64 = 0.02;
/// ... or until it stalls: neither the steps out of tolerance nor the largest
/// residual fell below this share of their value two sweeps before.
pub const LOOP_STALL_RATIO: f64 = 0.8;
/// A step the rigid tool bends across its path by no more than this, µm, has
/// no sideways load: the loop leaves it where the program puts it (offset 0).
/// An even plunge's resultant is zero but for round-off (f64 sums of the
/// contact vectors: 10⁻¹⁵…10⁻¹⁴ µm on blendercam_Op_Cutout_Layers' Ø3 plunges;
/// f32 heights: ≤ 10⁻⁶ of the load, MODEL.md §1.4), and a unit direction made
/// from it is noise. By the bracket of [`Bracketed`], a step with g(0) ≥ 0 no
/// larger than this has its root within this of 0, 500× inside the tolerance.
pub const LOOP_NO_SIDE_LOAD_UM: f64 = 1e-3;
/// The same for a feed step at one point (no XY motion: a plunge, a lift):
/// the loop's tolerance, µm (MODEL.md §5.1, eq. 5.1d). Its rigid sideways
/// load is the lattice's bias (§1.4); moved, its only sideways cut is the
/// sweep of its own offset change, a few µm that the grid removes as whole
/// columns or none, so its g measures the grid. By the bracket, the root of
/// a step with 0 ≤ g(0) ≤ this lies within the tolerance of 0.
pub const LOOP_AT_POINT_SIDE_LOAD_UM: f64 = LOOP_TOL_UM;
/// Relaxation factor of a step's offset update: first, largest and smallest.
pub(crate) const LOOP_RELAX_START: f64 = 0.4;
pub(crate) const LOOP_RELAX_MAX: f64 = 1.0;
pub(crate) const LOOP_RELAX_MIN: f64 = 0.02;
/// Where every step's deflection g has a slope s = Δg/Δx in this range
/// between the rigid sweep and the first trial (g nearly flat: the relaxed
/// trials would creep up on the root), the first update is the secant's root
/// `x + (g − x)/(1 − s)` instead of the relaxed one (MODEL.md §5.1); a rising
/// g (s > 0, the neighbours' offsets) is taken as flat.
pub(crate) const LOOP_SECANT_SLOPES: std::ops::RangeInclusive<f64> = -0.2..=0.25;

/// How the closed loop ended (summary.json `closed_loop_*`).
#[derive(Clone, Debug, Default)]
pub struct LoopReport {
    /// The job asked for the closed loop (`[cutting] closed_loop`).
    pub enabled: bool,
    /// Sweeps, the rigid one included.
    pub passes: usize,
    /// Largest |g − x| after the last sweep, µm (open loop: the rigid sweep's
    /// largest deflection across the path, which nothing compensated).
    pub residual_um: f64,
    /// Every step within tolerance.
    pub converged: bool,
    /// Steps left out of tolerance, with their |g − x| in µm.
    pub unconverged: Vec<(usize, f64)>,
    /// Some tool's steps were kept rigid: its rigid cut overloaded it
    /// (MODEL.md §5.1).
    pub rigid_kept: bool,
    /// The loop was settled from the rigid sweep (MODEL.md §5.1, eq. 5.1e):
    /// no step's deflection could change its load by more than the
    /// tolerance, so no trial was swept; `residual_um` is that bound.
    pub settled: bool,
}

/// The component of a step's deflection along its loop direction, µm
/// (`dirs`: each step's unit direction of the loop's offsets).
pub(crate) fn along(dirs: &[[f64; 2]], [dx_um, dy_um]: [f64; 2], i: usize) -> f64 {
    dx_um * dirs[i][0] + dy_um * dirs[i][1]
}

/// What the rigid sweep decides for the closed loop (MODEL.md §5.1): each
/// step's direction, whether the loop seeks its offset, its rigid
/// deflection across the path, and where the loop runs, its sub-cell
/// windows.
pub(crate) struct LoopPlan {
    /// Directions of the loop's offsets (unit, fixed from the rigid sweep).
    pub dirs: Vec<[f64; 2]>,
    /// Steps whose offset the loop seeks.
    pub in_loop: Vec<bool>,
    /// Steps that took their direction from the step before them.
    pub inherited: Vec<bool>,
    /// Each step's rigid deflection across its path, µm (≥ 0).
    pub rigid: Vec<f64>,
    /// Largest deflection at the contact height of the rigid tool's removal, µm.
    pub rigid_peak_deflection_um: f64,
    /// The loop as the rigid sweep leaves it (one sweep).
    pub report: LoopReport,
    /// The loop's passes run.
    pub looping: bool,
    /// The loop's steps that advance less than a grid cell, with their
    /// windows' first and last steps (empty where the loop does not run).
    pub sub_cells: Vec<[u32; 3]>,
    /// Each step's XY advance, mm (empty without sub-cell steps).
    pub advance_mm: Vec<f64>,
}

impl LoopPlan {
    /// The plan of the rigid sweep's loads `step_loads` of `steps` (its
    /// removal `record`, on a grid of `grid_mm`).
    pub(crate) fn new(
        steps: &[TimedStep],
        of_step: StepTools,
        step_loads: &[StepLoad],
        record: &RemovalRecord,
        grid_mm: f64,
    ) -> LoopPlan {
        let n = steps.len();
        let tools = of_step.tools;
        // The rigid sweep's loads as reported: a step that breaks its tool
        // deflects by its elastic deflection at rupture (MODEL.md §4.4). Such a
        // tool is overloaded (its rupture strength is at least its allowable
        // stress) and stays out of the loop below, so the steps the loop moves
        // start from the same loads with or without the cap. Made where they are
        // read, step by step (not a copy of every step's load: 104 B a step).
        let rigid_load = |i: usize| step_loads[i].at_rupture(of_step.rupture_strength_mpa(i));
        // A tool the rigid cut overloads beyond its allowable stress anywhere would
        // break there: no elastic balance exists, so the loop leaves that tool's
        // steps rigid (the open-loop estimate, which the force warning names)
        // rather than mixing bent and unbent steps along its path (MODEL.md §5.1).
        let mut overloaded = vec![false; tools.entries.len()];
        for (i, l) in step_loads.iter().enumerate() {
            if !steps[i].step.rapid && l.stress_mpa > of_step.stress_limit_mpa(i) {
                overloaded[of_step.tool_of_step[i]] = true;
            }
        }
        let (dirs, in_loop, inherited) = directions(steps, of_step, step_loads, &overloaded);
        // (A step that took its direction was not pushed across its own path.)
        let rigid: Vec<f64> = (0..n)
            .map(|i| {
                if inherited[i] {
                    0.0
                } else {
                    let l = rigid_load(i);
                    along(&dirs, [l.dx_um, l.dy_um], i).max(0.0)
                }
            })
            .collect();
        let rigid_peak_deflection_um = (0..n)
            .map(|i| rigid_load(i).deflection_um)
            .fold(0.0, f64::max);
        // Open loop: the largest deflection across the path nothing compensated;
        // closed loop: that of the steps the loop moves (none moved: nothing to do).
        let rigid_across_peak_um = (0..n)
            .filter(|&i| !tools.closed_loop || in_loop[i])
            .map(|i| rigid[i])
            .fold(0.0, f64::max);
        let mut report = LoopReport {
            enabled: tools.closed_loop,
            passes: 1,
            residual_um: rigid_across_peak_um,
            converged: rigid_across_peak_um <= LOOP_TOL_UM,
            unconverged: Vec::new(),
            rigid_kept: tools.closed_loop && overloaded.iter().any(|&o| o),
            settled: false,
        };
        // A tool that barely bends: where no step's deflection can change
        // its load by more than the tolerance, the rigid sweep's answer is
        // the loop's (MODEL.md §5.1, eq. 5.1e): no trial is swept.
        if tools.closed_loop && !report.converged {
            let bound = settle::settled_bound_um(
                steps,
                of_step,
                (step_loads, record),
                &in_loop,
                &inherited,
                &rigid,
                grid_mm,
            );
            if let Some(bound_um) = bound {
                report.residual_um = bound_um;
                report.converged = true;
                report.settled = true;
            }
        }
        // The loop's passes run (below).
        let looping = tools.closed_loop && !report.converged;
        // Where a step advances less than one grid cell its load comes in whole
        // columns (MODEL.md §1.5) and g jumps from step to step by the load of a
        // row of columns; the grid resolves it over [`SUB_CELL_WINDOW_CELLS`]
        // cells of path (§2.3). Such a step is also within tolerance where the
        // residual over its window of the loop's steps is (MODEL.md §5.1).
        // (Made only where the loop runs: only its passes read them. An open
        // loop's run of a million steps made them beside its loads, 41 MB.)
        let (sub_cells, advance_mm) = if looping {
            sub_cell_steps(steps, of_step.tool_of_step, &in_loop, &inherited, grid_mm)
        } else {
            (Vec::new(), Vec::new())
        };
        LoopPlan {
            dirs,
            in_loop,
            inherited,
            rigid,
            rigid_peak_deflection_um,
            report,
            looping,
            sub_cells,
            advance_mm,
        }
    }
}

/// Each step's direction of the loop's offsets, whether the loop seeks its
/// offset, and whether it took its direction from the step before it
/// (`overloaded`: per tool, the rigid cut overloads it).
fn directions(
    steps: &[TimedStep],
    of_step: StepTools,
    step_loads: &[StepLoad],
    overloaded: &[bool],
) -> (Vec<[f64; 2]>, Vec<bool>, Vec<bool>) {
    let n = steps.len();
    let (tools, tool_of_step) = (of_step.tools, of_step.tool_of_step);
    // Directions of the loop's offsets (unit, fixed from the rigid sweep):
    // across the path; rapids are not moved (a collision's load means nothing).
    let mut dirs: Vec<[f64; 2]> = step_loads
        .iter()
        .zip(steps)
        .map(|(l, s)| {
            if s.step.rapid {
                return [0.0, 0.0];
            }
            let m = [
                s.step.to_mm[0] - s.step.from_mm[0],
                s.step.to_mm[1] - s.step.from_mm[1],
            ];
            loop_direction(l.dx_um, l.dy_um, m)
        })
        .collect();
    // Steps whose offset the loop seeks (the others keep offset 0: rapids,
    // steps not pushed across the path, and every step of an overloaded tool,
    // whose error map is the rigid tool's as with the loop off).
    let mut in_loop: Vec<bool> = (0..steps.len())
        .map(|i| dirs[i] != [0.0, 0.0] && !overloaded[tool_of_step[i]])
        .collect();
    // With the loop, a feed step with no direction that continues one the
    // loop moves takes its direction; its offset is sought as a fraction of
    // the one it starts at (MODEL.md §5.1, eq. 5.1a).
    let inherited = if tools.closed_loop {
        inherit_directions(steps, tool_of_step, &mut dirs, &in_loop)
    } else {
        vec![false; n]
    };
    for (l, &h) in in_loop.iter_mut().zip(&inherited) {
        *l |= h;
    }
    (dirs, in_loop, inherited)
}

/// The steps of the loop that advance less than a grid cell, in order, with
/// their windows' first and last steps, and each step's XY advance, mm
/// (empty where there is no such step: the advances weigh the windows' sums
/// alone).
fn sub_cell_steps(
    steps: &[TimedStep],
    tool_of_step: &[usize],
    in_loop: &[bool],
    inherited: &[bool],
    grid_mm: f64,
) -> (Vec<[u32; 3]>, Vec<f64>) {
    let advance_mm: Vec<f64> = steps
        .iter()
        .map(|s| {
            let [fx, fy, _] = s.step.from_mm;
            let [tx, ty, _] = s.step.to_mm;
            (tx - fx).hypot(ty - fy)
        })
        .collect();
    // Windows over the feed steps of one cut (the steps out of the loop in
    // it, such as cuts by the tool's bottom alone, weigh nothing below).
    let feed: Vec<bool> = steps.iter().map(|s| !s.step.rapid).collect();
    // The steps of the loop that advance less than a grid cell, in order,
    // with their windows' first and last steps (not a window a step, and
    // as u32, 12 B each, where usize took 24; a run's steps are counted in
    // u32, as the stock's last cuts are).
    let index = |i: usize| u32::try_from(i).expect("a run's steps counted in u32");
    let mut sub_cells: Vec<[u32; 3]> = Vec::new();
    sub_cell_windows(
        |p| advance_mm[p],
        &feed,
        |p| {
            steps[p - 1].step.to_mm == steps[p].step.from_mm
                && tool_of_step[p - 1] == tool_of_step[p]
        },
        grid_mm,
        SUB_CELL_WINDOW_CELLS * grid_mm,
        |i, window| {
            if in_loop[i] && !inherited[i] && advance_mm[i] < grid_mm && window != (i, i) {
                sub_cells.push([index(i), index(window.0), index(window.1)]);
            }
        },
    );
    // The steps' advances weigh the windows' sums below: none without such steps.
    let advance_mm = if sub_cells.is_empty() {
        Vec::new()
    } else {
        advance_mm
    };
    (sub_cells, advance_mm)
}

/// What the closed loop's passes read and do not change: the steps, their
/// tools, directions and membership of the loop, the sub-cell windows, and
/// how each pass is swept.
pub(crate) struct LoopInputs<'a> {
    /// The run's steps.
    pub steps: &'a [TimedStep],
    /// Each step's tool.
    pub of_step: StepTools<'a>,
    /// [`LoopPlan::dirs`].
    pub dirs: &'a [[f64; 2]],
    /// [`LoopPlan::in_loop`].
    pub in_loop: &'a [bool],
    /// [`LoopPlan::inherited`].
    pub inherited: &'a [bool],
    /// [`LoopPlan::sub_cells`].
    pub sub_cells: &'a [[u32; 3]],
    /// [`LoopPlan::advance_mm`].
    pub advance_mm: &'a [f64],
    /// Column spacing, mm.
    pub grid_mm: f64,
    /// What each pass starts from.
    pub initial: &'a Initial<'a>,
    /// The sweeps' options.
    pub options: &'a SweepOptions,
    /// The progress label of the sweeps.
    pub label: &'a str,
}

impl LoopInputs<'_> {
    /// A step that took its direction at one point (no XY motion: a lift
    /// or the rest of a period at the end of a cut) keeps the offset it
    /// starts at (MODEL.md §5.1, eq. 5.1d): not sought, not judged. Its
    /// only sideways cut would be the sweep of its own offset change, a
    /// few µm the grid removes as whole columns or none (g jumps between 0
    /// and a column's load at a place the offsets before it move), so no
    /// trial resolves its equilibrium better than no sweep at all.
    fn at_point(&self, i: usize) -> bool {
        let [fx, fy, _] = self.steps[i].step.from_mm;
        let [tx, ty, _] = self.steps[i].step.to_mm;
        self.inherited[i] && fx == tx && fy == ty
    }
}

/// The closed loop's sweeps (MODEL.md §5.1), from the rigid deflections
/// `rigid`, each at the trials `x` (the offsets, µm), until every step is
/// within tolerance, the loop stalls or [`LOOP_MAX_PASSES`] sweeps are made;
/// `final_stock`, `record` and `report` are the last pass's. Returns the
/// steps whose loads are scaled (a root at a jump of g) and by how much.
///
/// Frees, in this order (for the peak memory of a million-step run): the
/// rigid deflections once the searches hold them (`rigid`, taken); in each
/// pass, the last pass's stock (its memory the sweep's spare) and record
/// before the pass's steps are made and swept, its list of unconverged
/// steps, and the offsets swept (mm) after the sweep ([`sweep_trial`]); the
/// pass's g at the end of the pass; the searches when the loop ends.
pub(crate) fn close_loop(
    on: &LoopInputs,
    rigid: &mut Vec<f64>,
    x: &mut [f64],
    final_stock: &mut Option<Stock>,
    record: &mut RemovalRecord,
    report: &mut LoopReport,
) -> Result<Vec<(usize, f64)>> {
    let mut state = LoopState::new(on, rigid, x);
    // The rigid deflections are in the searches now.
    drop(std::mem::take(rigid));
    loop {
        sweep_trial(on, x, final_stock, record, report)?;
        // g: the deflection the removal at the trial offset causes, across
        // the path (of the loads as `loads` makes them).
        let g: Vec<f64> = Removals::new(on.of_step, record, on.steps, on.grid_mm)
            .deflections_as(|d, i| along(on.dirs, d, i));
        let pass = report.passes;
        let measured = Measured { x, g: &g, pass };
        state.observe(on, measured);
        (report.unconverged, report.residual_um) = state.residuals(on, measured);
        report.converged = report.unconverged.is_empty();
        let stalled = state.stalled(report.unconverged.len(), report.residual_um);
        if report.converged || stalled || report.passes >= LOOP_MAX_PASSES {
            return Ok(state.scaled(on, measured));
        }
        state.update(on, x, &g, pass);
    }
}

/// One sweep of the closed loop, the steps moved by the trials `x` (µm):
/// the last pass's stock and record replaced by this pass's, one more pass
/// counted in `report`.
fn sweep_trial(
    on: &LoopInputs,
    x: &[f64],
    final_stock: &mut Option<Stock>,
    record: &mut RemovalRecord,
    report: &mut LoopReport,
) -> Result<()> {
    // The last pass's stock and record are replaced by this pass's:
    // freed before its steps are made and it is swept (the stock's
    // memory holds this pass's where it is made of its closed form).
    let spare = final_stock.take();
    drop(std::mem::take(record));
    // (Made again after the sweep.)
    report.unconverged = Vec::new();
    // The offsets, mm (16 B a step); the moved steps are made from
    // them as the sweep asks for them.
    let offsets_mm: Vec<[f64; 2]> = applied_offsets_um(on.steps, x, on.dirs)
        .into_iter()
        .map(|[x, y]| [1e-3 * x, 1e-3 * y])
        .collect();
    let shifted = dexel::StepFn::new(on.steps.len(), |i| offset_step(on.steps, &offsets_mm, i));
    let (pass_stock, pass_record) = sweep_pass(
        on.initial,
        spare,
        on.of_step.tools,
        on.of_step.tool_of_step,
        &shifted,
        on.options,
        on.label,
    )?;
    // (The offsets swept are not needed after the sweep.)
    drop(offsets_mm);
    (*final_stock, *record) = (pass_stock, pass_record);
    report.passes += 1;
    Ok(())
}

/// A residual `r` within the loop's tolerance of an offset `x`, µm.
fn within(r: f64, x: f64) -> bool {
    r <= LOOP_TOL_UM + LOOP_REL_TOL * x
}

/// A sweep of the closed loop: the trials `x` it swept (µm), the g it
/// measured at them (µm) and its number `pass`.
#[derive(Clone, Copy)]
struct Measured<'a> {
    x: &'a [f64],
    g: &'a [f64],
    pass: usize,
}

/// The closed loop's searches, one a step of the loop, and what it saw of
/// its sweeps.
struct LoopState {
    /// Each step's search for its offset (80 B a step).
    search: Vec<Bracketed>,
    /// The steps that took their direction, in order: they seek a fraction
    /// of the offset they start at, first 0 (eq. 5.1a), one search each in
    /// `fractions` (a few of the steps, not one a step).
    with_fraction: Vec<usize>,
    fractions: Vec<Fraction>,
    /// Steps out of tolerance after each sweep, and the largest residual,
    /// to see the loop stall.
    out_counts: Vec<usize>,
    residuals: Vec<f64>,
}

impl LoopState {
    /// The searches from the rigid deflections `rigid`, and each step's
    /// first trial in `x`.
    fn new(on: &LoopInputs, rigid: &[f64], x: &mut [f64]) -> LoopState {
        let n = on.steps.len();
        let search: Vec<Bracketed> = (0..n)
            .map(|i| Bracketed::new(rigid[i], on.of_step.offset_cap_um(i)))
            .collect();
        let with_fraction: Vec<usize> = (0..n).filter(|&i| on.inherited[i]).collect();
        let fractions = vec![Fraction::START; with_fraction.len()];
        for i in 0..n {
            if on.at_point(i) {
                x[i] = x[i - 1];
            } else if on.in_loop[i] {
                x[i] = (LOOP_RELAX_START * rigid[i]).min(on.of_step.offset_cap_um(i));
            }
        }
        LoopState {
            search,
            with_fraction,
            fractions,
            out_counts: Vec::new(),
            residuals: Vec::new(),
        }
    }

    /// The index in `fractions` of step `i`, one that took its direction.
    fn at(&self, i: usize) -> usize {
        self.with_fraction
            .binary_search(&i)
            .expect("a step that took its direction")
    }

    /// Record each sought step's g at its trial, measured by sweep `pass`.
    fn observe(&mut self, on: &LoopInputs, m: Measured) {
        let Measured { x, g, pass } = m;
        let n = on.steps.len();
        for i in (0..n).filter(|&i| on.in_loop[i] && !on.at_point(i)) {
            if on.inherited[i] {
                let k = self.at(i);
                self.fractions[k].observe(g[i] - x[i], x[i - 1], pass);
            } else {
                self.search[i].observe(x[i], g[i] - x[i], pass, on.of_step.offset_cap_um(i));
            }
        }
    }

    /// A step's bracket closed around its root (at a jump of g), and its
    /// width, µm.
    fn closed(&self, on: &LoopInputs, m: Measured, i: usize) -> Option<f64> {
        let Measured { x, pass, .. } = m;
        if on.at_point(i) {
            None
        } else if on.inherited[i] {
            let fraction = &self.fractions[self.at(i)];
            fraction
                .closed(x[i - 1], pass)
                .then(|| fraction.width_um(x[i - 1]))
        } else {
            self.search[i]
                .closed(pass)
                .then(|| self.search[i].hi.at - self.search[i].lo.at)
        }
    }

    /// The steps out of tolerance after sweep `pass`, with their residuals,
    /// and the largest residual, µm.
    ///
    /// Where a step advances less than a grid cell, g jumps from step to
    /// step by the load of a row of columns (MODEL.md §1.5), and the grid
    /// measures the load over the step's window of path only: such a step
    /// is also within tolerance where its window's path-weighted mean
    /// residual r̄ = mean(g − x) is within the tolerance of the mean offset
    /// once the grid's resolution of r̄ is taken off. That mean is known
    /// to ± |ḡ|·grid/path: the window's removal counts the rows of
    /// columns whose centres its path crosses, ± one row of the path/grid
    /// rows it covers (MODEL.md §5.1).
    /// (Sums made only where a step has such a window, in one pass over
    /// the steps in order, holding only the running sums from the
    /// window last read to the furthest end reached, not a prefix sum
    /// of every step.)
    fn residuals(&self, on: &LoopInputs, m: Measured) -> (Vec<(usize, f64)>, f64) {
        let Measured { x, g, .. } = m;
        let mut window_sums = WindowSums::new(|j: usize| {
            let w = if on.in_loop[j] && !on.inherited[j] {
                on.advance_mm[j]
            } else {
                0.0
            };
            residual_terms(w, g[j], x[j], on.advance_mm[j])
        });
        let mut windows = on.sub_cells.iter().peekable();
        // Both from one pass in step order (the same fold); the residuals
        // asked in step order, so their windows' starts do not decrease
        // (`sub_cell_windows`).
        let mut unconverged = Vec::new();
        let mut residual_um = 0.0;
        for i in (0..on.steps.len()).filter(|&i| on.in_loop[i]) {
            let window = windows
                .next_if(|&&[j, _, _]| j as usize <= i)
                .map(|&[j, a, b]| {
                    debug_assert_eq!(j as usize, i, "every sub-cell step is a step of the loop");
                    (a as usize, b as usize)
                });
            let (r, xr) = self.residual(on, m, i, window, &mut window_sums);
            if !within(r, xr) {
                unconverged.push((i, r));
            }
            residual_um = f64::max(residual_um, r);
        }
        (unconverged, residual_um)
    }

    /// A step's residual and the offset its tolerance scales with: |g −
    /// x|, or where its bracket has closed around a jump of g, the
    /// bracket's width (how far x is from the root); a sub-cell step out
    /// of tolerance so but within it over its `window`, the window's.
    fn residual(
        &self,
        on: &LoopInputs,
        m: Measured,
        i: usize,
        window: Option<(usize, usize)>,
        window_sums: &mut WindowSums<5, impl Fn(usize) -> [f64; 5]>,
    ) -> (f64, f64) {
        let Measured { x, g, .. } = m;
        if on.at_point(i) || (on.inherited[i] && self.fractions[self.at(i)].held()) {
            return (0.0, x[i].abs());
        }
        let r = (g[i] - x[i]).abs();
        let own = self.closed(on, m, i).map_or(r, |width| r.min(width));
        if let Some((a, b)) = window {
            if !within(own, x[i].abs()) {
                if let Some((rw, xw)) = window_residual(window_sums.over(a, b), on.grid_mm) {
                    if within(rw, xw) {
                        return (rw, xw);
                    }
                }
            }
        }
        (own, x[i].abs())
    }

    /// Record the steps out of tolerance and the largest residual of this
    /// sweep; whether the loop stalled: the best of the last three sweeps
    /// is no better than 0.8 of the best before them, both in steps out and
    /// in residual (from the ninth sweep on: the first ones may leave every
    /// step out while the offsets grow, and a step whose g jumps where a
    /// column centre is crossed closes in slowly).
    fn stalled(&mut self, out: usize, residual_um: f64) -> bool {
        self.out_counts.push(out);
        self.residuals.push(residual_um);
        let (out_counts, residuals) = (&self.out_counts, &self.residuals);
        let k = out_counts.len();
        k >= 8 && {
            let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
            let counts: Vec<f64> = out_counts.iter().map(|&c| c as f64).collect();
            best(&counts[k - 3..]) > LOOP_STALL_RATIO * best(&counts[..k - 3])
                && best(&residuals[k - 3..]) > LOOP_STALL_RATIO * best(&residuals[..k - 3])
        }
    }

    /// The loads the loop scales as it ends, and by how much. A root at a
    /// jump of g (the edge crossing a column centre): the sweep's load is
    /// that of one side of the jump, the equilibrium's lies between. Where
    /// the sweep's is the larger one (g > x) it is scaled down so that the
    /// deflection across the path is the offset (MODEL.md §5.1); a load is
    /// never scaled up beyond what a sweep removed.
    fn scaled(&self, on: &LoopInputs, m: Measured) -> Vec<(usize, f64)> {
        let Measured { x, g, .. } = m;
        (0..on.steps.len())
            .filter(|&i| on.in_loop[i])
            .filter(|&i| {
                let off = g[i] - x[i] > LOOP_TOL_UM + LOOP_REL_TOL * x[i].abs();
                off && self.closed(on, m, i).is_some() && x[i] > 0.0
            })
            .map(|i| (i, x[i] / g[i]))
            .collect()
    }

    /// The next trials `x` after sweep `pass` measured `g` at them.
    fn update(&mut self, on: &LoopInputs, x: &mut [f64], g: &[f64], pass: usize) {
        let n = on.steps.len();
        // The secant's root at the first update where every step's g
        // fell or rose gently between the rigid sweep and the first
        // trial (g nearly flat: the steps move together, and the
        // relaxed trials would creep up on the root); otherwise none
        // takes it (steps coupled to their neighbours move alike).
        let secant = (0..n)
            .filter(|&i| on.in_loop[i] && !on.inherited[i])
            .all(|i| {
                self.search[i]
                    .first_slope(x[i], g[i])
                    .is_none_or(|s| LOOP_SECANT_SLOPES.contains(&s))
            });
        // In step order: a step that took its direction moves with the
        // offset it starts at, the trial of the step before (x[i − 1],
        // already the next one; `measured_before` the one swept).
        let mut measured_before = 0.0;
        for i in 0..n {
            let measured = x[i];
            let cap = on.of_step.offset_cap_um(i);
            if on.at_point(i) {
                x[i] = x[i - 1];
            } else if on.inherited[i] {
                let k = self.at(i);
                x[i] = (self.fractions[k].next(g[i] - measured, measured, measured_before, pass)
                    * x[i - 1])
                    .clamp(-cap, cap);
            } else if on.in_loop[i] {
                x[i] = self.search[i].next(measured, g[i], secant).clamp(-cap, cap);
            }
            measured_before = measured;
        }
    }
}
