//! Machine motion and time-optimal re-timing along a toolpath.
//!
//! One planner serves two uses:
//! * **machine motion**: how a control runs a program: programmed feeds, acceleration limits,
//!   corners, block processing time ([`FeedPolicy::Programmed`]);
//! * **optimize**: re-time under extra per-position feed caps (removal rate, force,
//!   deflection, surface angle) with every feed block allowed `feed_max_mm_min`
//!   ([`FeedPolicy::MachineMax`] plus [`Stations::apply_caps`]). Engagement is
//!   feed-independent, so every such limit is a cap on the feed along the arc length s.
//!
//! Flow: [`Stations::new`] discretises the path and sets the caps, the caller may lower caps,
//! [`plan`] computes the time-optimal speed profile, [`Profile::sample`] gives servo data.
//! [`lower_bound_time_s`] bounds every profile from below, for the optimality gap;
//! [`exact_stop_time_s`] is the time of stopping at every corner, the simplest feasible timing.
#![warn(missing_docs)]

mod bound;
pub mod controller;
mod corner_check;
mod direct;
mod exact_stop;
mod kinematics;
pub mod linuxcnc;
mod machine;
mod plan;
mod range_min;
mod rules;
mod slp;
mod stations;

pub use bound::{lower_bound_time_s, rest_to_rest_time_s};
pub use controller::Controller;
pub use exact_stop::exact_stop_time_s;
pub use machine::{Machine, ScheduleError, MACHINE_RANGES};
pub use plan::{
    axis_velocity_between_mm_s, axis_velocity_mm_s, plan, Profile, ServoSample, MAX_SAMPLES,
};
pub use rules::{
    angle_rule_feed_mm_min, block_feed_cap_mm_min, chord_count, chord_tolerance_mm, linearise_arcs,
};
pub use stations::{
    station_count, CapKind, Corners, FeedPolicy, Stations, Stop, BYTES_PER_STATION, MAX_STATIONS,
};
