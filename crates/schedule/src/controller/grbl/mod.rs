//! grbl 1.1's planner (`[machine] controller = "grbl"`, MODEL.md §6.4): the program cut into
//! the blocks grbl plans (arcs into chords as `mc_arc` cuts them, targets rounded to whole
//! steps), each block's junction speed from the junction deviation `$11`, a look-ahead of
//! the blocks the planner buffer holds, and each block run as the trapezoid `stepper.c`
//! executes between its planned entry and exit speeds.
//!
//! * [`blocks`]: the path → grbl's line blocks (`arc.rs`: `mc_arc`);
//! * [`plan_blocks`]: the planner (`planner.rs`: `plan_buffer_line`, `planner_recalculate`);
//! * [`samples`]: the trapezoids sampled every servo period (`trapezoid.rs`).

mod arc;
mod dump;
mod planner;
mod trapezoid;

pub use dump::{DumpError, GRBL_RANGES};
pub use planner::{blocks, plan_blocks, Block, BlockKind, PlannedBlock};
pub use trapezoid::{cycle_time_s, trapezoid_time_s};

use crate::{Machine, ScheduleError, ServoSample};

/// grbl's settings that shape the motion (its `$$` numbers in brackets). Lengths mm,
/// rates mm/min, accelerations mm/s² as grbl's own settings are written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrblSettings {
    /// `$11` junction deviation, mm (grbl's default 0.01): the distance from a corner to
    /// the circle whose centripetal acceleration limits the corner's speed.
    pub junction_deviation_mm: f64,
    /// `$12` arc tolerance, mm (default 0.002): the largest distance from an arc to the
    /// chords `mc_arc` cuts it into.
    pub arc_tolerance_mm: f64,
    /// `$100`–`$102` steps per mm of X, Y, Z (grbl's generic default 250): block targets
    /// are rounded to whole steps before planning.
    pub steps_per_mm: [f64; 3],
    /// `$110`–`$112` maximum rate of X, Y, Z, mm/min: rapids run at it, feeds are capped
    /// by it.
    pub max_rate_mm_min: [f64; 3],
    /// `$120`–`$122` acceleration of X, Y, Z, mm/s².
    pub accel_mm_s2: [f64; 3],
    /// Blocks the planner buffer holds, the one executing included (`BLOCK_BUFFER_SIZE`
    /// − 1 of grbl's ring buffer: 15 on the ATmega328p); the last is planned to end at rest.
    pub planner_blocks: usize,
}

/// grbl's default `$11`, mm.
pub const DEFAULT_JUNCTION_DEVIATION_MM: f64 = 0.01;
/// grbl's default `$12`, mm.
pub const DEFAULT_ARC_TOLERANCE_MM: f64 = 0.002;
/// grbl's generic default `$100`–`$102`, steps/mm.
pub const DEFAULT_STEPS_PER_MM: f64 = 250.0;
/// Blocks grbl 1.1's planner buffer holds on the ATmega328p (`BLOCK_BUFFER_SIZE` 16, one
/// slot of the ring always empty).
pub const DEFAULT_PLANNER_BLOCKS: usize = 15;

impl GrblSettings {
    /// grbl's defaults for `$11`, `$12`, `$100`–`$102` and the buffer, with `machine`'s
    /// rapid rate as every axis' maximum rate and its axis accelerations.
    pub fn for_machine(machine: &Machine) -> GrblSettings {
        GrblSettings {
            junction_deviation_mm: DEFAULT_JUNCTION_DEVIATION_MM,
            arc_tolerance_mm: DEFAULT_ARC_TOLERANCE_MM,
            steps_per_mm: [DEFAULT_STEPS_PER_MM; 3],
            max_rate_mm_min: [machine.rapid_mm_min; 3],
            accel_mm_s2: machine.accel_mm_s2,
            planner_blocks: DEFAULT_PLANNER_BLOCKS,
        }
    }
}

impl Default for GrblSettings {
    fn default() -> Self {
        GrblSettings::for_machine(&Machine::default())
    }
}

/// Servo samples of `path` as grbl runs it, every `machine.period_ms` from t = 0 plus one
/// at the end, with the same fields as [`crate::Profile::sample`]'s. Only
/// `machine.period_ms` is read of `machine`: grbl's own limits are in `settings`.
pub fn samples(
    path: &nc::Path,
    machine: &Machine,
    settings: &GrblSettings,
) -> Result<Vec<ServoSample>, ScheduleError> {
    settings.validate()?;
    if path.segments.is_empty() {
        return Err(ScheduleError::EmptyPath);
    }
    let blocks = blocks(path, settings);
    let planned = plan_blocks(path.segments[0].start.coords.into(), &blocks, settings);
    trapezoid::sample(path, &blocks, &planned, machine.period_ms)
}

#[cfg(test)]
mod tests;
