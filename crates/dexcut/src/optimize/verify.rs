//! The verification of a written program: its periods over a limit, the caps
//! they lower, and whether the program as given is within every limit.

use schedule::CapKind;

use super::blocks::Blocks;
use crate::input::job::LimitsSpec;
use crate::input::tools::ToolSet;
use crate::run::Run;

/// A period counts as above a limit in the result when it exceeds it by more than this.
pub const LIMIT_TOLERANCE: f64 = 0.02;

/// One servo period of the written program above a limit: where it lies on
/// the path, its feed and the factor the feed must fall by.
#[derive(Clone, Copy, Debug)]
pub struct Excess {
    pub s_from_mm: f64,
    pub s_to_mm: f64,
    pub feed_mm_min: f64,
    /// The feed the period may run at: its feed times the factor the limit
    /// asks for, or the chip-load feed.
    pub cap_mm_min: f64,
    pub kind: CapKind,
    /// By how much the period exceeds its limit: value / limit − 1 (the
    /// largest over the limits it exceeds).
    pub over_limit: f64,
    /// It exceeds a limit by more than that limit's tolerance:
    /// [`LIMIT_TOLERANCE`] for removal, force, deflection, power and stress
    /// per period, [`CHIP_LOAD_TOLERANCE`] for a feed cap of a cutting step
    /// (its chip-load feed, S3's angle rule: [`FeedRules`]).
    pub beyond_tolerance: bool,
    /// Program line the period ends in.
    pub line: u32,
    /// The path the MRR is measured over covers at least one grid cell
    /// (MODEL.md §2.3; not so only in a cut shorter than that). Periods left
    /// over a limit that are not resolved are named as a coarse grid.
    pub resolved: bool,
    /// The period itself advanced less than a grid cell (its MRR is measured
    /// over the periods around it, MODEL.md §2.3).
    pub sub_cell: bool,
    /// The period runs on a feed held as programmed (G84/G74 tapping): its
    /// cap is infinite, nothing is slowed, and it is told apart.
    pub held: bool,
}

/// A step that removes material may run above a feed cap (its chip-load
/// feed, S3's angle rule) by this fraction (the feed of a servo step is a
/// mean over a chord; F words are rounded down, so the plan itself never
/// exceeds the cap).
pub const CHIP_LOAD_TOLERANCE: f64 = 1e-3;

/// Margin kept under a limit when a period over it is corrected.
pub const LIMIT_MARGIN: f64 = 0.01;

/// Servo periods of `run` (per period, as the summary prints them) whose MRR,
/// force, deflection, spindle power or tool stress exceeds the limits, and steps that
/// remove material (however little: any step in contact with the stock is a
/// cutting move) above their tool's chip-load feed f_z,max·z·n at the block's
/// spindle speed (MODEL.md §2.1) or above a feed rule of `rules` where they
/// run (S3's angle rule, MODEL.md §6.3). MRR scales with the feed; force, deflection
/// and power with the feed to the power p of the step's tool's force model
/// (n of S4's law, 1 − mc of Kienzle's, MODEL.md §3). The one check of a
/// run against every cap that shapes the plan: of each round's written
/// program, and of the program as given ([`within_limits`]).
pub fn excesses(run: &Run, limits: &LimitsSpec, tools: &ToolSet, rules: &FeedRules) -> Vec<Excess> {
    let mut out = Vec::new();
    let grid_mm = run.stock.grid().spacing_mm;
    // The periods one by one (a million periods held as a list were 72 MB
    // beside the run at the verification's peak).
    run.for_each_period(|period| {
        if !period.cutting {
            return;
        }
        // Per load: the largest value / limit in the period, and the feed exponent of its tool.
        let mut worst = [(0.0f64, 1.0f64); 4];
        // Largest step feed / its chip-load feed among the steps that cut.
        let mut chip: Option<(f64, f64)> = None;
        // Largest step feed / its S3 cap among the steps that cut.
        let mut angle: Option<(f64, f64)> = None;
        for k in period.first_step..=period.last_step {
            let step = &run.steps[k];
            // A rapid's load is a collision (rapid_cut), not one a feed sets:
            // a period part rapid, part feed is corrected for its feed part.
            if step.step.rapid {
                continue;
            }
            let entry = tools.entry(step.tool);
            let p = entry.model.force_model.feed_exponent();
            let load = &run.loads[k];
            for (w, (value, limit)) in worst.iter_mut().zip([
                (load.force_peak_n, limits.force_max),
                // Where the tool breaks, the linear deflection: the one at
                // rupture does not scale with the feed (MODEL.md §4.4).
                (run.linear_deflection_um(k), limits.deflection_max_um),
                (load.power_w, limits.power_max_kw.map(|kw| 1000.0 * kw)),
                (
                    load.stress_mpa,
                    limits.stress.then_some(run.stress_limit_mpa_at(k)),
                ),
            ]) {
                if let Some(limit) = limit {
                    if value / limit > w.0 {
                        *w = (value / limit, p);
                    }
                }
            }
            if run.record.volume_mm3(k) > crate::run::NOTHING_MM3 {
                if let Some(cap) = entry.chip_load_feed_mm_min(step.spindle_rpm) {
                    if chip.is_none_or(|(r, _)| step.feed_mm_min / cap > r) {
                        chip = Some((step.feed_mm_min / cap, cap));
                    }
                }
                // The path the step runs over: from the end of the one before.
                let s_lo = k.checked_sub(1).map_or(0.0, |j| run.steps[j].s_end_mm);
                if let Some(cap) = rules.angle_cap(s_lo, step.s_end_mm) {
                    if angle.is_none_or(|(r, _)| step.feed_mm_min / cap > r) {
                        angle = Some((step.feed_mm_min / cap, cap));
                    }
                }
            }
        }
        // The path and time the period's MRR is measured over (MODEL.md §2.3);
        // its loads and chip load are corrected over the same stretch.
        let (s_lo, s_hi, dt) = (period.s_from_mm, period.s_to_mm, period.dt_s);
        if dt <= 0.0 {
            return;
        }
        let feed = (s_hi - s_lo) / dt * 60.0;
        let mut found: Option<(f64, CapKind)> = None;
        let (mut over_limit, mut beyond_tolerance) = (0.0f64, false);
        let mut lower = |cap: f64, kind: CapKind, over: f64| {
            over_limit = over_limit.max(over);
            let tolerance = match kind {
                CapKind::ChipLoad | CapKind::SurfaceAngle => CHIP_LOAD_TOLERANCE,
                _ => LIMIT_TOLERANCE,
            };
            beyond_tolerance |= over > tolerance;
            if found.is_none_or(|(c, _)| cap < c) {
                found = Some((cap, kind));
            }
        };
        let mrr = period.mrr_mm3_s();
        if let Some(q) = limits.mrr_max {
            if mrr > q * (1.0 + 0.5 * LIMIT_MARGIN) {
                lower(
                    feed * q * (1.0 - LIMIT_MARGIN) / mrr,
                    CapKind::Removal,
                    mrr / q - 1.0,
                );
            }
        }
        // Where the tool advances less than a grid cell per period, the loads
        // are the steady cut's at the step's feed (MODEL.md §1.6), so they
        // scale with the feed like any other.
        let sub_cell = period.window.0 != period.window.1;
        for ((ratio, p), kind) in worst.into_iter().zip([
            CapKind::Force,
            CapKind::Deflection,
            CapKind::Power,
            CapKind::Stress,
        ]) {
            if ratio > 1.0 + 0.5 * LIMIT_MARGIN {
                let cap = feed * ((1.0 - LIMIT_MARGIN) / ratio).powf(1.0 / p);
                lower(cap, kind, ratio - 1.0);
            }
        }
        for (worst, kind) in [(chip, CapKind::ChipLoad), (angle, CapKind::SurfaceAngle)] {
            if let Some((ratio, cap)) = worst {
                if ratio > 1.0 + 0.5 * CHIP_LOAD_TOLERANCE {
                    lower(cap * (1.0 - 1e-6), kind, ratio - 1.0);
                }
            }
        }
        // A held feed (tapping) is not slowed: the period is told, with
        // nothing to lower.
        let held = (period.first_step..=period.last_step).any(|k| run.steps[k].held);
        if let (Some((cap, kind)), true) = (found, feed > 0.0) {
            let cap = if held { f64::INFINITY } else { cap };
            out.push(Excess {
                s_from_mm: s_lo,
                s_to_mm: s_hi,
                feed_mm_min: feed,
                cap_mm_min: cap,
                kind,
                over_limit,
                beyond_tolerance,
                line: run.steps[period.last_step].line,
                resolved: s_hi - s_lo >= grid_mm && cap.is_finite(),
                sub_cell,
                held,
            });
        }
    });
    out
}

/// Lower the interval caps over each excess (± `margin_mm`) to the feed it
/// may run at, never below `feed_min`. A removal excess where the tool
/// advances less than a grid cell per period ([`Excess::sub_cell`]) lowers
/// the whole written block it lies in (`blocks`: where the blocks begin
/// among the intervals): its removal per period varies with the column phase
/// along the block, and a change of timing anywhere shifts that phase, so
/// the block's feed is what sets its peak.
pub fn lower_caps(
    caps: &mut [(f64, CapKind)],
    s_mm: &[f64],
    blocks: &Blocks,
    excesses: &[Excess],
    margin_mm: f64,
    feed_min: Option<f64>,
) {
    for e in excesses {
        let cap = e.cap_mm_min.max(feed_min.unwrap_or(0.0));
        let from = s_mm.partition_point(|&s| s < e.s_from_mm - margin_mm);
        let mut from = from.saturating_sub(1).min(caps.len().saturating_sub(1));
        let mut to = from;
        while to + 1 < caps.len() && s_mm[to + 1] <= e.s_to_mm + margin_mm {
            to += 1;
        }
        if e.sub_cell && e.kind == CapKind::Removal {
            (from, to) = (blocks.around(from).0, blocks.around(to).1);
        }
        for c in &mut caps[from..=to] {
            if cap < c.0 {
                *c = (cap, e.kind);
            }
        }
    }
}

/// Whether a run (of the program as written) is within every limit, judged
/// as each round's written program is ([`excesses`]): no
/// period above mrr_max, force_max, deflection_max_um, power_max_kw or the tool's
/// stress_limit_mpa (with `stress`) by more
/// than [`LIMIT_TOLERANCE`], no cutting step above its tool's chip-load feed
/// or a feed rule of `rules` (S3's angle rule) where it runs by more than
/// [`CHIP_LOAD_TOLERANCE`]. S0's block time needs no check here: the
/// machine model holds every block of every run to it (MODEL.md §6.2).
pub fn within_limits(run: &Run, limits: &LimitsSpec, tools: &ToolSet, rules: &FeedRules) -> bool {
    excesses(run, limits, tools, rules)
        .iter()
        .all(|e| !e.beyond_tolerance)
}

/// Feed caps by geometry along the path of the program as given that a run
/// is judged by at the feed each of its cutting steps runs at
/// ([`excesses`]): S3's angle rule (MODEL.md §6.3), known once the
/// engagement has its surface angles ([`engagement_caps_on`](super::engagement_caps_on)).
/// The chip-load feed is judged from each step's own tool and spindle speed,
/// and S0's block time is held by the machine model in every run.
#[derive(Clone, Debug, Default)]
pub struct FeedRules {
    /// S3's cap on stretches of path: (s_from_mm, s_to_mm, cap_mm_min),
    /// ascending and apart, adjacent intervals with the same cap as one
    /// stretch (24 B a stretch, only with `angle_rule`).
    pub(super) angle: Vec<(f64, f64, f64)>,
}

impl FeedRules {
    /// S3's cap `cap_mm_min` on the path from `s_from_mm` to `s_to_mm`, after
    /// every stretch pushed before.
    pub(super) fn push_angle(&mut self, s_from_mm: f64, s_to_mm: f64, cap_mm_min: f64) {
        if let Some(last) = self.angle.last_mut() {
            if last.1 == s_from_mm && last.2 == cap_mm_min {
                last.1 = s_to_mm;
                return;
            }
        }
        self.angle.push((s_from_mm, s_to_mm, cap_mm_min));
    }

    /// No rule to judge.
    pub fn is_empty(&self) -> bool {
        self.angle.is_empty()
    }

    /// S3's cap on a step that runs over the path from `s_lo` to `s_hi`: the
    /// highest cap of the stretches it runs over (its feed is a mean over its
    /// chord, at most the highest speed along it, which the plan holds under
    /// the cap where it is). None where part of it lies where the rule does not
    /// apply (air, no surface angle).
    pub fn angle_cap(&self, s_lo: f64, s_hi: f64) -> Option<f64> {
        let mut i = self.angle.partition_point(|r| r.1 <= s_lo);
        let (mut covered, mut cap) = (s_lo, None::<f64>);
        while let Some(&(from, to, c)) = self.angle.get(i).filter(|r| r.0 < s_hi) {
            if from > covered {
                return None;
            }
            covered = covered.max(to);
            cap = Some(cap.map_or(c, |m| m.max(c)));
            i += 1;
        }
        cap.filter(|_| covered >= s_hi)
    }
}

/// The steps of `run` (the written program) whose tool stress is still above
/// its allowable stress (`stress_limit_mpa`, MODEL.md §4.4) by more than
/// [`LIMIT_TOLERANCE`], told per line as a `limit_exceeded` warning. Force
/// and stress fall with the feed only as F^p (Kienzle's h^(1−mc), MODEL.md
/// §3.2) at the depth and width of cut the program sets, so where `feed_min`
/// holds those steps up no feed optimize may write brings them under: the
/// warning says so.
pub fn stress_left(
    run: &Run,
    limits: &LimitsSpec,
    rounds: usize,
    out: &mut crate::model::warnings::Warnings,
) {
    if !limits.stress {
        return;
    }
    let mut tally = crate::model::warnings::LineTally::new();
    let mut fastest = 0.0f64;
    for (k, s) in run.steps.iter().enumerate() {
        let limit = run.stress_limit_mpa_at(k);
        if !s.step.rapid && run.loads[k].stress_mpa > limit * (1.0 + LIMIT_TOLERANCE) {
            crate::model::warnings::tally(&mut tally, s.line, run.loads[k].stress_mpa);
            fastest = fastest.max(s.feed_mm_min);
        }
    }
    let limit = run.stress_limit_mpa();
    let held = limits
        .feed_min
        .filter(|&lo| fastest <= lo * (1.0 + LIMIT_TOLERANCE));
    out.from_lines(
        crate::model::warnings::WarningKind::LimitExceeded,
        &tally,
        "MPa",
        false,
        |v, lines| match held {
            Some(lo) => format!("optimized.nc still stresses the tool to {v:.0} MPa at {lines}, above its allowable {limit:.0} MPa ([tool] stress_limit_mpa), at feed_min ({lo} mm/min), the lowest feed optimize may write: the depth and width of cut the program gives these lines are too much for the tool at that feed (the stress falls only as the feed to the power 1 − mc, docs/MODEL.md §4.4); lower [limits] feed_min, or cut shallower or narrower there"),
            None => format!("optimized.nc still stresses the tool to {v:.0} MPa at {lines}, above its allowable {limit:.0} MPa ([tool] stress_limit_mpa), after {rounds} rounds of slowing them (docs/MODEL.md §4.4)"),
        },
    );
}

/// What [`write_verified`](super::write_verified) needs of the program as given (its run need not
/// be held through the rounds). The feed rules of [`FeedRules`] are known
/// only after the engagement: where the program would be kept, it is
/// simulated again and judged by them too, with the same check.
#[derive(Clone, Copy, Debug)]
pub struct Given {
    /// Its cycle time, s.
    pub cycle_s: f64,
    /// It is within every limit ([`within_limits`]) but the feed rules
    /// of the engagement ([`FeedRules`]).
    pub within_limits_but_feed_rules: bool,
}

impl Given {
    /// What the rounds need of `run`, the program as given.
    pub fn of(run: &Run, limits: &LimitsSpec, tools: &ToolSet) -> Given {
        Given {
            cycle_s: run.steps.last().map_or(0.0, |s| s.t_end_s),
            within_limits_but_feed_rules: within_limits(run, limits, tools, &FeedRules::default()),
        }
    }
}
