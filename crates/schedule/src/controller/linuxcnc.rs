//! LinuxCNC's trajectory planner (`[machine] controller = "linuxcnc"`): the
//! transcription of LinuxCNC 2.9's planner in [`crate::linuxcnc`] (MODEL.md §6.4).

pub use crate::linuxcnc::{samples, LinuxCncSettings};
