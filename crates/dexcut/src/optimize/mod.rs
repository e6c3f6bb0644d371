//! `dexcut optimize`: feed caps from the engagement along the path, the
//! time-optimal re-timing under them, and a verification re-simulation.
//!
//! Engagement is feed-independent (MODEL.md §2): one geometric sweep along
//! fine stations gives the removed volume per unit length A(s) (mm³/mm).
//! Every limit then becomes a cap on the feed at that station:
//! * MRR: MRR = A·F/60 ≤ Q  ⇒  F ≤ 60·Q/A;
//! * force, deflection and spindle power: at fixed engagement each grows like F^p
//!   (p = n for S4's law, 1 − mc for Kienzle's, MODEL.md §3), so the load at a
//!   reference feed gives the cap F ≤ F_ref·(limit/Q(F_ref))^(1/p);
//! * S3's angle rule on ball-end mills; feed_min/feed_max; S0's block time.
//!
//! The pieces, in the order a run uses them: [`engagement`] along the free
//! [`stations`], its [`caps`], the re-feed plan's [`blocks`], the
//! [`rounds`] of writing and re-simulating, their [`verify`]cation, and each
//! tool's [`chip_load`] cap.

mod blocks;
mod caps;
mod chip_load;
mod engagement;
mod rounds;
mod stations;
mod verify;

pub use crate::model::summary::{CapShare, ToolChipLoad};
pub use blocks::*;
pub use caps::*;
pub use chip_load::*;
pub use engagement::*;
pub use rounds::*;
pub use stations::*;
pub use verify::*;

#[cfg(test)]
mod tests;
