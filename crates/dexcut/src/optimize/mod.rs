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
//! The pieces, in the order a run uses them:
//! * `stations.rs`: the free stations, and their path while they are let go;
//! * `engagement.rs`: the engagement sweep along them, the reference loads,
//!   the surface angles and the windowed areas;
//! * `caps.rs`: each limit as a feed cap per interval, put on the stations;
//! * `blocks.rs`: the re-feed plan under the caps and its blocks;
//! * `rounds.rs`: write, re-simulate and correct ([`caps_and_rounds`](rounds::caps_and_rounds),
//!   [`write_verified`](rounds::write_verified));
//! * `verify.rs`: the written program's periods over a limit and the caps
//!   they lower;
//! * `chip_load.rs`: each tool's chip-load cap and its warning.

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
