//! Servo drive model and motion evaluation (S2; S4 "motion error").
//!
//! * [`drive`]: a per-axis closed-loop model of the feed drive (first-order lag with velocity
//!   feed-forward, or a second-order loop) simulated exactly at the servo period.
//! * [`path_error`]: trajectory error, the largest distance of actual samples to the commanded
//!   polyline.
//! * [`evaluation`]: S2's score `V = Ka·Va + Kb·Vb + Kc·Vc` from trajectory error, machining time
//!   and the largest jerk.
//! * [`precomp`]: S4's iterative pre-compensation of the command for the drive's lag.
//!
//! Positions are in mm in the machine frame, one `[x, y, z]` sample per servo period (s).
//! Pure: values in, values out.
//!
//! In: the commanded servo samples that the motion stage (`schedule`) makes from the program,
//! and a [`Drive`]. Out: the actual motion those samples give, its [`Evaluation`] and a
//! pre-compensated command ([`Precomp`]). In the pipeline of the `dexcut` library
//! (job → stock (`dexel`, `mesh`) + program (`nc`) → motion (`schedule`) → sweep (`dexel`) →
//! loads (`cutting`) → outputs (`export`)) it works on the motion: the `evaluate` command,
//! the compensated servo CSV and, where asked, the sweep's steps moved onto the drive's actual
//! path use it. It depends on no other crate of the workspace. S2 and S4 are sources listed in docs/MODEL.md.
#![warn(missing_docs)]

pub mod drive;
pub mod evaluation;
pub mod path_error;
pub mod precomp;

pub use drive::{
    simulate_actual, simulate_actual_from, simulate_until_settled, Drive, DriveError, DriveOrder,
};
pub use evaluation::{
    evaluate, max_jerk_mm_s3, primary_score, settled_time_s, Evaluation, Weights,
};
pub use path_error::trajectory_error_mm;
pub use precomp::{first_order_inverse, precompensate, Precomp};
