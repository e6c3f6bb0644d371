//! Feed caps: each limit as a cap on the feed at every interval, put on the
//! stations, and the words and shares of the caps in the result.

use crate::error::Result;
use nc::Motion;
use schedule::{CapKind, Machine, Stations};

use super::engagement::{Engagement, ReferenceLoad, REFERENCE_FEED_MM_MIN};
use crate::input::job::LimitsSpec;
use crate::input::tools::ToolSet;
use crate::model::summary::CapShare;

/// Feed caps per interval from the limits, with the kind that sets each.
/// Cutting intervals (engagement above zero) are also held to the chip load
/// `fz_max_mm` (F ≤ f_z·z·n with the segment's spindle speed, MODEL.md §2.1)
/// and to `feed_scale_max` times the programmed feed; air runs free.
pub fn interval_caps(
    engagement: &Engagement,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
) -> Vec<(f64, CapKind)> {
    engagement
        .area_mm2
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            let at_ref = &engagement.reference_loads[k];
            let cap = limit_cap(
                k,
                a,
                at_ref,
                engagement.tool_index[k],
                stations,
                limits,
                tools,
            );
            let theta_deg = engagement.surface_angle_deg[k];
            angle_and_floor(cap, k, a, theta_deg, stations, limits)
        })
        .collect()
}

/// Interval k's cap by the limits but S3's angle rule and the floor
/// ([`angle_and_floor`] next): `a` its windowed area, `at_ref` its
/// reference load, `tool` the index of its tool.
pub(super) fn limit_cap(
    k: usize,
    a: f64,
    at_ref: &ReferenceLoad,
    tool: u16,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
) -> (f64, CapKind) {
    limit_cap_of(k, a, at_ref, tool, stations, limits, tools, true)
}

/// Whether interval k's [`limit_cap`] can be its force or stress cap,
/// given a reference load `bounded` whose `force_peak_n` and `stress_mpa`
/// are upper bounds of its own (`CuttingModel::step_load_bounded`, MODEL.md
/// §3.4; the rest its own bit for bit): their caps are then lower bounds of
/// the load's own. Where both lie above the cap of every other limit (by a
/// relative 1e-9, for the rounding of `powf`), neither is the least nor
/// ties it, so the cap and its kind are those of the other limits, which
/// `bounded` gives bit for bit: `false`, and the peak is not needed.
pub(super) fn peak_can_bind(
    k: usize,
    a: f64,
    bounded: &ReferenceLoad,
    tool: u16,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
) -> bool {
    if !(a > 1e-12) {
        return false;
    }
    let (others, _) = limit_cap_of(k, a, bounded, tool, stations, limits, tools, false);
    let entry = &tools.entries[usize::from(tool)];
    let cap = |q_ref: f64, limit: f64| {
        entry
            .model
            .feed_for_limit(q_ref, REFERENCE_FEED_MM_MIN, limit)
    };
    let binds = |v: f64| !(v > others * (1.0 + 1e-9));
    limits
        .force_max
        .is_some_and(|f| binds(cap(bounded.force_peak_n, f)))
        || (limits.stress && binds(cap(bounded.stress_mpa, entry.stress_limit_mpa)))
}

/// [`limit_cap`], with the caps of the load's peak (force and stress) where
/// `with_peak`, else without them.
#[allow(clippy::too_many_arguments)]
fn limit_cap_of(
    k: usize,
    a: f64,
    at_ref: &ReferenceLoad,
    tool: u16,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
    with_peak: bool,
) -> (f64, CapKind) {
    // The model of the tool cutting this interval.
    let entry = &tools.entries[usize::from(tool)];
    let model = &entry.model;
    let mut cap = (f64::INFINITY, CapKind::FeedMax);
    let mut lower = |v: f64, kind: CapKind| {
        if v < cap.0 {
            cap = (v, kind);
        }
    };
    if a > 1e-12 {
        let seg = &stations.segments()[stations.segment()[k + 1] as usize];
        if let Some(f) = entry.chip_load_feed_mm_min(seg.spindle_rpm) {
            lower(f, CapKind::ChipLoad);
        }
        if let (Some(scale), Motion::Feed { feed_mm_min, .. }) = (limits.feed_scale_max, seg.motion)
        {
            lower(scale * feed_mm_min, CapKind::FeedScale);
        }
        if let Some(q) = limits.mrr_max {
            lower(60.0 * q / a, CapKind::Removal); // MRR = A·F/60 ≤ Q
        }
        // Load ∝ F^p at fixed engagement (MODEL.md §3): F ≤ F_ref·(limit/Q_ref)^(1/p).
        let cap =
            |q_ref: f64, limit: f64| model.feed_for_limit(q_ref, REFERENCE_FEED_MM_MIN, limit);
        if let (Some(f), true) = (limits.force_max, with_peak) {
            lower(cap(at_ref.force_peak_n, f), CapKind::Force);
        }
        if let Some(d_um) = limits.deflection_max_um {
            lower(cap(at_ref.deflection_um, d_um), CapKind::Deflection);
        }
        if let Some(p_kw) = limits.power_max_kw {
            lower(cap(at_ref.power_w, 1000.0 * p_kw), CapKind::Power);
        }
        // The stress grows with the step's load (force and torque) at its
        // contact height (MODEL.md §4.4): a force limit of F·σ_limit/σ.
        if limits.stress && with_peak {
            lower(
                cap(at_ref.stress_mpa, entry.stress_limit_mpa),
                CapKind::Stress,
            );
        }
    }
    cap
}

/// Interval k's cap `cap` ([`limit_cap`]) lowered by S3's angle rule where
/// it cuts ([`angle_cap`]), then raised to `feed_min`.
pub(super) fn angle_and_floor(
    mut cap: (f64, CapKind),
    k: usize,
    a: f64,
    theta_deg: f64,
    stations: &Stations,
    limits: &LimitsSpec,
) -> (f64, CapKind) {
    if let Some(v) = angle_cap(k, a, theta_deg, stations, limits) {
        if v < cap.0 {
            cap = (v, CapKind::SurfaceAngle);
        }
    }
    if let Some(lo) = limits.feed_min {
        cap.0 = cap.0.max(lo);
    }
    cap
}

/// S3's angle rule on interval k (MODEL.md §6.3), where it cuts (`a` its
/// windowed area) with a surface angle (`theta_deg`, NaN for none) on a
/// feed move: F(θ) of the programmed (set) feed and `v0`. None where the
/// rule is off or does not apply.
pub(super) fn angle_cap(
    k: usize,
    a: f64,
    theta_deg: f64,
    stations: &Stations,
    limits: &LimitsSpec,
) -> Option<f64> {
    if a <= 1e-12 {
        return None;
    }
    let seg = &stations.segments()[stations.segment()[k + 1] as usize];
    match (limits.angle_rule, limits.v0, theta_deg.is_nan(), seg.motion) {
        (true, Some(v0), false, Motion::Feed { feed_mm_min, .. }) => {
            Some(schedule::angle_rule_feed_mm_min(theta_deg, feed_mm_min, v0))
        }
        _ => None,
    }
}

/// Apply interval caps to both end stations of each interval, so the speed
/// (v² linear between stations) respects the cap over the whole interval.
pub fn apply_interval_caps(stations: &mut Stations, caps: &[(f64, CapKind)]) -> Result<()> {
    apply_interval_caps_from(stations, 0, caps)
}

/// [`apply_interval_caps`] with `caps` those of the intervals from `first` on.
pub(super) fn apply_interval_caps_from(
    stations: &mut Stations,
    first: usize,
    caps: &[(f64, CapKind)],
) -> Result<()> {
    for (k, &(cap, kind)) in (first..).zip(caps) {
        if cap.is_finite() {
            let seg = stations.segment()[k + 1] as usize;
            // Rapids keep the rapid rate, a held feed its own (tapping).
            let motion = stations.segments()[seg].motion;
            if matches!(motion, Motion::Rapid) || motion.held_feed_mm_min().is_some() {
                continue;
            }
            stations.apply_cap(k, cap, kind)?;
            stations.apply_cap(k + 1, cap, kind)?;
        }
    }
    Ok(())
}

pub fn cap_shares(profile: &schedule::Profile<'_>) -> Vec<CapShare> {
    profile
        .time_at_cap_share()
        .into_iter()
        .filter(|(_, share)| *share > 0.0)
        .map(|(kind, share)| CapShare {
            cap: cap_words(kind).into(),
            share,
        })
        .collect()
}

/// What holds the feed, in a user's words.
pub fn cap_words(kind: CapKind) -> &'static str {
    match kind {
        CapKind::Programmed => "programmed feed",
        CapKind::Held => "held feed (G84/G74 tapping)",
        CapKind::FeedMax => "highest feed (feed_max)",
        CapKind::Rapid => "rapid moves",
        CapKind::Curvature => "arcs (axis acceleration on the curve)",
        CapKind::Corner => "corners (axis acceleration)",
        CapKind::BlockTime => "block processing time",
        CapKind::Removal => "removal-rate limit (mrr_max)",
        CapKind::Force => "force limit (force_max)",
        CapKind::Deflection => "deflection limit (deflection_max_um)",
        CapKind::Power => "spindle power limit (power_max_kw)",
        CapKind::Stress => "tool stress limit (stress_limit_mpa)",
        CapKind::SurfaceAngle => "surface-angle rule (S3)",
        CapKind::ChipLoad => "chip-load limit (fz_max)",
        CapKind::FeedScale => "programmed feed × feed_scale_max",
        CapKind::Acceleration => "speeding up or slowing down",
        CapKind::Dwell => "dwells",
    }
}

/// The machine the optimiser plans for: the job's, with [limits] feed_max.
pub fn optimising_machine(machine: &Machine, limits: &LimitsSpec) -> Machine {
    Machine {
        feed_max_mm_min: limits.feed_max.unwrap_or(machine.feed_max_mm_min),
        ..*machine
    }
}
