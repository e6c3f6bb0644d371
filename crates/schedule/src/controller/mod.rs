//! The control that runs the program (`[machine] controller`): dexcut's own time-optimal
//! planner ([`Controller::Ideal`], [`crate::plan`]) or a model of a real control's planner,
//! each giving servo samples like [`crate::Profile::sample`] (MODEL.md §6.4).
//!
//! * [`grbl`]: grbl 1.1's planner (junction deviation, look-ahead buffer, trapezoids);
//! * [`linuxcnc`]: LinuxCNC's trajectory planner.

pub mod grbl;
pub mod linuxcnc;

pub use grbl::GrblSettings;
pub use linuxcnc::LinuxCncSettings;

/// Which planner runs the program, with its settings.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Controller {
    /// dexcut's time-optimal planner under the machine's limits (MODEL.md §6.1); the default.
    #[default]
    Ideal,
    /// grbl 1.1's planner (MODEL.md §6.4).
    Grbl(GrblSettings),
    /// LinuxCNC's trajectory planner.
    LinuxCnc(LinuxCncSettings),
}

impl Controller {
    /// The controller's name as the job file writes it (`ideal`, `grbl`, `linuxcnc`).
    pub fn name(&self) -> &'static str {
        match self {
            Controller::Ideal => "ideal",
            Controller::Grbl(_) => "grbl",
            Controller::LinuxCnc(_) => "linuxcnc",
        }
    }
}
