//! LinuxCNC's trajectory planner (`[machine] controller = "linuxcnc"`).
//!
//! Not built yet: [`samples`] refuses every path. The linuxcnc work (issue 41) replaces it.

use crate::{Machine, ScheduleError, ServoSample};

/// The settings of LinuxCNC's trajectory planner that the program does not set itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinuxCncSettings {
    /// The INI's default blending tolerance (G64 P), mm; `None`: blend without a tolerance.
    pub blend_tolerance_mm: Option<f64>,
}

/// Servo samples of `path` as LinuxCNC's trajectory planner runs it: not built yet, so
/// always [`ScheduleError::Controller`].
pub fn samples(
    _path: &nc::Path,
    _machine: &Machine,
    _settings: &LinuxCncSettings,
) -> Result<Vec<ServoSample>, ScheduleError> {
    Err(ScheduleError::Controller {
        controller: "linuxcnc",
        what: "controller linuxcnc is not built yet".into(),
    })
}
