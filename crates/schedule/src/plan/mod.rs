//! Time-optimal speed profile along the stations, and servo sampling of it.
//!
//! * [`planner`]: the entry, [`plan`]: the runs between stops one after another;
//! * [`run_planner`]: one run planned at (λ, W, σ): passes, holds, cut peaks, the choice
//!   of λ;
//! * [`verify`]: the check of a run's servo samples, and the fallbacks where they break
//!   a limit;
//! * [`sections`] and [`shapes`]: a run cut into sections, and each section's values
//!   (filtered, shaped directly, followed exactly, by linear programs);
//! * [`profile`]: the planned [`Profile`] and its runs;
//! * [`sample`]: the servo samples of a profile ([`ServoSample`]).

mod planner;
mod profile;
mod run_planner;
mod sample;
mod sections;
mod shapes;
mod verify;

#[cfg(test)]
mod tests;

pub use planner::plan;
pub use profile::Profile;
pub use sample::{axis_velocity_between_mm_s, axis_velocity_mm_s, ServoSample, MAX_SAMPLES};
