//! The path → grbl's line blocks, and grbl 1.1's planner over them (planner.c:
//! `plan_buffer_line`, `planner_recalculate`; MODEL.md §6.4).

use nc::{Geometry, Motion};

use super::GrblSettings;

/// grbl's `MINIMUM_FEED_RATE`, mm/min: no block is planned slower.
const MINIMUM_FEED_RATE_MM_MIN: f32 = 1.0;
/// grbl's `SOME_LARGE_VALUE`: the junction speed² of a straight junction.
const SOME_LARGE_VALUE: f32 = 1.0e38;

/// What a block asks of the planner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BlockKind {
    /// A feed move (G1, or a chord of G2/G3) at the programmed feed, mm/min.
    Feed {
        /// Programmed feed, mm/min.
        feed_mm_min: f64,
    },
    /// A rapid (G0) at the axes' maximum rates.
    Rapid,
    /// The buffer runs empty (the moves before it end at rest), then the control waits
    /// `dwell_s`: a G4 dwell, or a spindle or tool change (grbl's `protocol_buffer_synchronize`).
    Sync {
        /// Time waited once at rest, s.
        dwell_s: f64,
    },
}

/// One block as the G-code interpreter hands it to grbl's planner (`mc_line`'s target).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// Where the block ends, mm, machine frame (before rounding to steps).
    pub target_mm: [f64; 3],
    /// Feed, rapid or a stop.
    pub kind: BlockKind,
    /// Index of the path segment it comes from.
    pub segment: u32,
}

/// The line blocks grbl plans for `path`: each line one block, each arc the chords of
/// `mc_arc` at `settings.arc_tolerance_mm`, each dwell and each change of spindle speed or
/// tool a [`BlockKind::Sync`].
pub fn blocks(path: &nc::Path, settings: &GrblSettings) -> Vec<Block> {
    let mut out = Vec::with_capacity(path.segments.len());
    let mut targets = Vec::new();
    for (k, seg) in path.segments.iter().enumerate() {
        let segment = k as u32;
        if let Some(before) = k.checked_sub(1).map(|j| &path.segments[j]) {
            let changed = before.tool != seg.tool || before.spindle_rpm != seg.spindle_rpm;
            if changed && !matches!(seg.motion, Motion::Dwell { .. }) {
                out.push(Block {
                    target_mm: seg.start.coords.into(),
                    kind: BlockKind::Sync { dwell_s: 0.0 },
                    segment,
                });
            }
        }
        let kind = match seg.motion {
            Motion::Dwell { seconds } => {
                out.push(Block {
                    target_mm: seg.end.coords.into(),
                    kind: BlockKind::Sync { dwell_s: seconds },
                    segment,
                });
                continue;
            }
            Motion::Rapid => BlockKind::Rapid,
            Motion::Feed { feed_mm_min, .. } => BlockKind::Feed { feed_mm_min },
        };
        targets.clear();
        match seg.geometry {
            Geometry::Line => targets.push(seg.end.coords.into()),
            Geometry::Arc {
                center,
                plane,
                clockwise,
                sweep_rad,
            } => super::arc::chords(
                &seg.start,
                &seg.end,
                &center,
                plane.axes(),
                clockwise,
                sweep_rad,
                settings.arc_tolerance_mm,
                &mut targets,
            ),
        }
        out.extend(targets.iter().map(|&target_mm| Block {
            target_mm,
            kind,
            segment,
        }));
    }
    out
}

/// A block as grbl's planner planned and the stepper runs it. Blocks of no whole step are
/// dropped by grbl (`PLAN_EMPTY_BLOCK`) and have none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedBlock {
    /// Index of the block in [`blocks`]' list.
    pub block: usize,
    /// Where the motion starts, mm (the previous planned block's target).
    pub start_mm: [f64; 3],
    /// Length between the whole-step positions, mm (grbl's `millimeters`); 0 for a stop.
    pub length_mm: f64,
    /// Acceleration along the block, mm/s² (the axes' limits along its direction).
    pub accel_mm_s2: f64,
    /// Speed it runs at when nothing slows it, mm/min (grbl's nominal speed).
    pub nominal_mm_min: f64,
    /// Largest entry speed the junction allows, mm/min (`max_entry_speed_sqr`'s root).
    pub max_entry_mm_min: f64,
    /// Planned entry speed, mm/min, fixed when the block starts to run.
    pub entry_mm_min: f64,
    /// Exit speed, mm/min: the next block's entry as planned when this one started.
    pub exit_mm_min: f64,
    /// For a [`BlockKind::Sync`]: the time waited at rest, s; 0 for a move.
    pub dwell_s: f64,
}

/// The planner's state between blocks (grbl's `planner_t`). Like grbl's (an ATmega328p's
/// `double` is a `float`), the block's length, direction, acceleration, rates and
/// junction speed are computed in single precision, in grbl's order of operations: the
/// junction speed of a nearly straight or nearly reversing corner depends on it (its
/// 1 − sin(θ/2) or 1 − cos θ cancels), by up to 3·10⁻⁴ of the speed on real programs.
struct Planner {
    accel_mm_min2: [f32; 3],
    max_rate_mm_min: [f32; 3],
    steps_per_mm: [f32; 3],
    position_steps: [i64; 3],
    position_mm: [f64; 3],
    previous_unit: [f32; 3],
    previous_nominal_mm_min: f32,
    buffer_empty: bool,
}

/// `limit_value_by_axis_maximum`: the largest value along `unit` that keeps every axis
/// within `max` (grbl's nuts_bolts.c).
fn limit_by_axis(max: &[f32; 3], unit: &[f32; 3]) -> f32 {
    (0..3)
        .filter(|&i| unit[i] != 0.0)
        .map(|i| (max[i] / unit[i]).abs())
        .fold(SOME_LARGE_VALUE, f32::min)
}

/// `convert_delta_vector_to_unit_vector`: `v` made a unit vector; returns its length.
fn to_unit(v: &mut [f32; 3]) -> f32 {
    let magnitude = v
        .iter()
        .filter(|&&x| x != 0.0)
        .fold(0.0f32, |m, x| m + x * x)
        .sqrt();
    let inv = 1.0 / magnitude;
    v.iter_mut().for_each(|x| *x *= inv);
    magnitude
}

/// `lround(target·steps_per_mm)` with grbl's single-precision product.
fn to_steps(target_mm: f64, steps_per_mm: f32) -> i64 {
    (target_mm as f32 * steps_per_mm).round() as i64
}

impl Planner {
    fn new(start_mm: [f64; 3], s: &GrblSettings) -> Planner {
        let steps_per_mm = s.steps_per_mm.map(|v| v as f32);
        Planner {
            accel_mm_min2: s.accel_mm_s2.map(|a| a as f32 * 60.0 * 60.0),
            max_rate_mm_min: s.max_rate_mm_min.map(|v| v as f32),
            steps_per_mm,
            position_steps: [0, 1, 2].map(|i| to_steps(start_mm[i], steps_per_mm[i])),
            position_mm: start_mm,
            previous_unit: [0.0; 3],
            previous_nominal_mm_min: 0.0,
            buffer_empty: true,
        }
    }

    /// `plan_buffer_line` without the replanning: the block's length, acceleration, nominal
    /// speed and junction limit (MODEL.md eqs. 6.4.1–6.4.2); `None` for a block of no step.
    fn add(&mut self, block: &Block, index: usize, s: &GrblSettings) -> Option<PlannedBlock> {
        let mut target_steps = [0i64; 3];
        let mut unit = [0.0f32; 3];
        let mut step_events = 0;
        for i in 0..3 {
            target_steps[i] = to_steps(block.target_mm[i], self.steps_per_mm[i]);
            let steps = target_steps[i] - self.position_steps[i];
            step_events = step_events.max(steps.abs());
            unit[i] = steps as f32 / self.steps_per_mm[i];
        }
        if step_events == 0 {
            return None;
        }
        let length_mm = to_unit(&mut unit);
        let accel_mm_min2 = limit_by_axis(&self.accel_mm_min2, &unit);
        let rapid_mm_min = limit_by_axis(&self.max_rate_mm_min, &unit);
        // plan_compute_profile_nominal_speed, overrides at 100 %.
        let nominal_mm_min = match block.kind {
            BlockKind::Rapid => rapid_mm_min,
            BlockKind::Feed { feed_mm_min } => (feed_mm_min as f32).min(rapid_mm_min),
            BlockKind::Sync { .. } => unreachable!("a stop is no line"),
        }
        .max(MINIMUM_FEED_RATE_MM_MIN);
        let junction_sqr = if self.buffer_empty {
            0.0
        } else {
            self.junction_speed_sqr(&unit, s.junction_deviation_mm as f32)
        };
        // plan_compute_profile_parameters.
        let max_entry_sqr = if nominal_mm_min > self.previous_nominal_mm_min {
            self.previous_nominal_mm_min * self.previous_nominal_mm_min
        } else {
            nominal_mm_min * nominal_mm_min
        }
        .min(junction_sqr);
        let planned = PlannedBlock {
            block: index,
            start_mm: self.position_mm,
            length_mm: f64::from(length_mm),
            accel_mm_s2: f64::from(accel_mm_min2) / 3600.0,
            nominal_mm_min: f64::from(nominal_mm_min),
            max_entry_mm_min: f64::from(max_entry_sqr).sqrt(),
            entry_mm_min: 0.0,
            exit_mm_min: 0.0,
            dwell_s: 0.0,
        };
        self.previous_nominal_mm_min = nominal_mm_min;
        self.previous_unit = unit;
        self.position_steps = target_steps;
        self.position_mm = block.target_mm;
        self.buffer_empty = false;
        Some(planned)
    }

    /// The junction's speed² limit, (mm/min)²: v² = a·δ·sin(θ/2)/(1 − sin(θ/2)) with a the
    /// acceleration along the junction's direction (MODEL.md eq. 6.4.1).
    fn junction_speed_sqr(&self, unit: &[f32; 3], deviation_mm: f32) -> f32 {
        let prev = &self.previous_unit;
        let mut cos_theta = 0.0f32;
        let mut junction = [0.0f32; 3];
        for i in 0..3 {
            cos_theta -= prev[i] * unit[i];
            junction[i] = unit[i] - prev[i];
        }
        if cos_theta > 0.999999 {
            return 0.0;
        }
        if cos_theta < -0.999999 {
            return SOME_LARGE_VALUE;
        }
        to_unit(&mut junction);
        let accel = limit_by_axis(&self.accel_mm_min2, &junction);
        let sin_half = (0.5 * (1.0 - cos_theta)).sqrt();
        (accel * deviation_mm * sin_half / (1.0 - sin_half)).max(0.0)
    }
}

/// grbl's planner over `blocks`, streamed as a fast sender streams them: the buffer holds
/// `settings.planner_blocks` blocks, the one running included; a block's exit speed is
/// planned when it starts to run, over the blocks buffered then, the last of them ending at
/// rest, and its entry speed is the exit the block before it ran with (MODEL.md §6.4,
/// "Look-ahead"). A [`BlockKind::Sync`] empties the buffer. The tool starts at `start_mm`.
pub fn plan_blocks(
    start_mm: [f64; 3],
    blocks: &[Block],
    settings: &GrblSettings,
) -> Vec<PlannedBlock> {
    let mut planner = Planner::new(start_mm, settings);
    let mut out: Vec<PlannedBlock> = Vec::with_capacity(blocks.len());
    let mut run_first = 0;
    for (index, block) in blocks.iter().enumerate() {
        match block.kind {
            BlockKind::Sync { dwell_s } => {
                plan_run(&mut out[run_first..], settings.planner_blocks);
                out.push(PlannedBlock {
                    block: index,
                    start_mm: planner.position_mm,
                    length_mm: 0.0,
                    accel_mm_s2: 0.0,
                    nominal_mm_min: 0.0,
                    max_entry_mm_min: 0.0,
                    entry_mm_min: 0.0,
                    exit_mm_min: 0.0,
                    dwell_s,
                });
                run_first = out.len();
                planner.buffer_empty = true;
            }
            _ => out.extend(planner.add(block, index, settings)),
        }
    }
    plan_run(&mut out[run_first..], settings.planner_blocks);
    out
}

/// Entry and exit speeds of a run of blocks between stops: block k runs from the exit of
/// k − 1 to the entry of k + 1 as planned over blocks k … k + depth − 1 (the buffer when k
/// starts), by grbl's reverse pass from rest at the last and forward pass from k's fixed
/// entry (MODEL.md eq. 6.4.4).
fn plan_run(run: &mut [PlannedBlock], depth: usize) {
    let n = run.len();
    let mut entry_sqr: f64 = 0.0;
    for k in 0..n {
        run[k].entry_mm_min = entry_sqr.sqrt();
        let end = (k + depth.max(1)).min(n);
        // Reverse pass: from rest at the end of the buffer's last block down to k + 1.
        let mut next_sqr = 0.0;
        for b in run[k + 1..end].iter().rev() {
            let max_sqr = b.max_entry_mm_min * b.max_entry_mm_min;
            next_sqr = max_sqr.min(next_sqr + 2.0 * accel_mm_min2(b) * b.length_mm);
        }
        // Forward pass: what block k can reach from its entry.
        let exit_sqr = if k + 1 < end {
            next_sqr.min(entry_sqr + 2.0 * accel_mm_min2(&run[k]) * run[k].length_mm)
        } else {
            0.0
        };
        run[k].exit_mm_min = exit_sqr.sqrt();
        entry_sqr = exit_sqr;
    }
}

/// A block's acceleration in grbl's unit, mm/min².
fn accel_mm_min2(b: &PlannedBlock) -> f64 {
    b.accel_mm_s2 * 3600.0
}
