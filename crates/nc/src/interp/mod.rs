//! The interpreter: modal state, block execution in LinuxCNC's order, flow
//! control (Fanuc M98/M99, LinuxCNC o-words) and motion generation.
//!
//! Internally all lengths are mm in the machine frame; program values are
//! scaled by 25.4 under G20 and shifted by the active work offset and G92.
//!
//! * [`options`]: what a run is given ([`Options`], [`FileForm`]).
//! * [`run`]: reading a program's lines and running them; what a run returns
//!   ([`Parsed`], [`Trace`], [`Executed`]).
//! * [`state`]: the interpreter's modal state and a fresh one at a run's start.
//! * [`control`]: the run over the lines, o-words, subroutines, loops, M98/M99.
//! * [`block`]: one block's words evaluated, checked and executed.
//! * [`motion`]: targets, offsets, lines and arcs, the segments appended.
//! * [`tools`]: tool changes, the tool table, tool length offsets.
//! * [`canned`]: canned cycles.
//! * [`comp`]: cutter radius compensation.
//! * [`diagnostics`]: errors, warnings and the tolerant form's amendments.

mod block;
mod canned;
mod comp;
mod control;
mod diagnostics;
mod motion;
mod options;
mod run;
mod state;
#[cfg(test)]
mod tests;
mod tools;

use block::Block;
use diagnostics::{fail, Fail};
pub use options::{FileForm, Options};
#[cfg(test)]
pub(crate) use run::read;
pub(crate) use run::{parse, read_unkept, run_read_and_record, PathRoom, Read};
pub use run::{run_recorded, run_recorded_along, Executed, Parsed, SegmentTrace, Trace};
use state::Interp;
