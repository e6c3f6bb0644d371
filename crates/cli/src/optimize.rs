//! `dexcut optimize`: feed caps from the engagement along the path, the
//! time-optimal re-timing under them, and a verification re-simulation.
//!
//! Engagement is feed-independent (MODEL.md §2): one geometric sweep along
//! fine stations gives the removed volume per unit length A(s) (mm³/mm).
//! Every limit then becomes a cap on the feed at that station:
//! * MRR: MRR = A·F/60 ≤ Q  ⇒  F ≤ 60·Q/A;
//! * force: V = A·F/(z·n) per tooth and F_c = a·V^n ≤ F_max ⇒ F ≤ (F_max/a)^(1/n)·z·n/A;
//! * deflection: δ = F_c·c(s), c from the band distribution ⇒ a force cap F_max = δ_max/c;
//! * S3's angle rule on ball-end mills; feed_min/feed_max; S0's block time.

use anyhow::{bail, Result};
use cutting::CuttingModel;
use dexel::{Stock, SweepOptions, Tool};
use nc::Motion;
use schedule::{CapKind, FeedPolicy, Machine, Stations};
use serde::Serialize;

use crate::job::LimitsSpec;
use crate::motion::STATION_DS_MM;

/// Engagement along the stations: removed volume per interval.
pub struct Engagement {
    /// Per interval k (station k → k+1): removed volume per unit length, mm³/mm.
    pub area_mm2: Vec<f64>,
    /// Per interval: tip deflection per newton of cutting force, mm/N (band distribution).
    pub compliance_mm_n: Vec<f64>,
}

/// Sweep a copy of the stock along the stations (geometry only, no time).
pub fn engagement(
    stations: &Stations,
    stock: &Stock,
    tool: &Tool,
    model: &CuttingModel,
) -> Result<Engagement> {
    let pos = stations.position();
    let segs = stations.segments();
    let seg_of = stations.segment();
    let steps: Vec<dexel::Step> = (1..pos.len())
        .map(|k| dexel::Step {
            from_mm: pos[k - 1].coords.into(),
            to_mm: pos[k].coords.into(),
            rapid: matches!(segs[seg_of[k] as usize].motion, Motion::Rapid),
        })
        .collect();
    let mut stock = stock.clone();
    let options = SweepOptions {
        band_height_mm: model.band_height_mm,
        ..SweepOptions::default()
    };
    let bar = crate::progress::bar(steps.len() as u64, "engagement");
    let record = dexel::sweep(&mut stock, tool, &steps, &options, &|d| {
        bar.set_position(d as u64)
    })?;
    bar.finish_and_clear();
    let volumes: Vec<f64> = (0..steps.len()).map(|k| record.volume_mm3(k)).collect();
    let window_mm = (ENGAGEMENT_WINDOW_CELLS * stock.grid().spacing_mm).max(2.0 * STATION_DS_MM);
    let area_mm2 = windowed_area(stations.s_mm(), &volumes, window_mm);
    let compliance_mm_n = (0..steps.len())
        .map(|k| model.tip_compliance_mm_per_n(record.band_volumes_mm3(k)))
        .collect();
    Ok(Engagement {
        area_mm2,
        compliance_mm_n,
    })
}

/// Engagement is averaged over this many grid cells of path: a dexel grid
/// resolves removal per unit length only to about one column, so finer
/// station intervals see the column phase, not the cut.
pub const ENGAGEMENT_WINDOW_CELLS: f64 = 2.0;

/// Removed volume per unit length at each interval: the mean over a window of
/// `window_mm` centred on it, then the largest such mean within ±window/2, so
/// a cap is in force from one window before a rise in engagement.
pub fn windowed_area(s_mm: &[f64], volumes_mm3: &[f64], window_mm: f64) -> Vec<f64> {
    let n = volumes_mm3.len();
    // Cumulative volume at each station.
    let mut cum = Vec::with_capacity(n + 1);
    cum.push(0.0);
    for v in volumes_mm3 {
        cum.push(cum[cum.len() - 1] + v);
    }
    let half = 0.5 * window_mm;
    let (s_first, s_last) = (s_mm[0], s_mm[n]);
    // Cumulative volume at arc length x (linear inside an interval); `i` is a forward cursor.
    let cum_at = |x: f64, i: &mut usize| {
        let x = x.clamp(s_first, s_last);
        while *i + 1 < n && s_mm[*i + 1] < x {
            *i += 1;
        }
        let (a, b) = (s_mm[*i], s_mm[*i + 1]);
        let f = if b > a {
            ((x - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        cum[*i] + f * volumes_mm3[*i]
    };
    let (mut lo, mut hi) = (0usize, 0usize);
    let mean: Vec<f64> = (0..n)
        .map(|k| {
            let mid = 0.5 * (s_mm[k] + s_mm[k + 1]);
            let (a, b) = ((mid - half).max(s_first), (mid + half).min(s_last));
            if b > a {
                (cum_at(b, &mut hi) - cum_at(a, &mut lo)) / (b - a)
            } else {
                0.0
            }
        })
        .collect();
    // Sliding maximum over ±half (monotone deque).
    let mut out = vec![0.0; n];
    let mut deque: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0;
    for k in 0..n {
        let mid = 0.5 * (s_mm[k] + s_mm[k + 1]);
        while next < n && 0.5 * (s_mm[next] + s_mm[next + 1]) <= mid + half {
            while deque.back().is_some_and(|&b| mean[b] <= mean[next]) {
                deque.pop_back();
            }
            deque.push_back(next);
            next += 1;
        }
        while deque
            .front()
            .is_some_and(|&f| 0.5 * (s_mm[f] + s_mm[f + 1]) < mid - half)
        {
            deque.pop_front();
        }
        out[k] = deque.front().map_or(mean[k], |&f| mean[f]);
    }
    out
}

/// Feed caps per interval from the limits, with the kind that sets each.
pub fn interval_caps(
    engagement: &Engagement,
    stations: &Stations,
    limits: &LimitsSpec,
    model: &CuttingModel,
    tool: &Tool,
) -> Vec<(f64, CapKind)> {
    let force_cap_v = |force_max_n: f64| {
        cutting::volume_per_tooth_at_force_mm3(force_max_n, model.force_coef_a, model.force_exp_n)
    };
    let per_rev = model.flutes as f64 * model.spindle_rpm;
    let tangents = stations.tangent();
    engagement
        .area_mm2
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            let mut cap = (f64::INFINITY, CapKind::FeedMax);
            let mut lower = |v: f64, kind: CapKind| {
                if v < cap.0 {
                    cap = (v, kind);
                }
            };
            if a > 1e-12 {
                if let Some(q) = limits.mrr_max {
                    lower(60.0 * q / a, CapKind::Removal); // MRR = A·F/60 ≤ Q
                }
                if let Some(f) = limits.force_max {
                    lower(force_cap_v(f) * per_rev / a, CapKind::Force); // V = A·F/(z·n), F_c = a·V^n
                }
                if let Some(d_um) = limits.deflection_max_um {
                    let f = d_um * 1e-3 / engagement.compliance_mm_n[k];
                    lower(force_cap_v(f) * per_rev / a, CapKind::Deflection); // δ = F_c·c
                }
                if let (true, Some(v0), dexel::ToolShape::Ball) =
                    (limits.angle_rule, limits.v0, tool.shape)
                {
                    // S3: θ between the surface normal and the tool axis, taken as the path's inclination.
                    let t = tangents[k + 1];
                    let theta_deg = t.z.abs().atan2((t.x * t.x + t.y * t.y).sqrt()).to_degrees();
                    let feed = stations.machine().feed_max_mm_min;
                    lower(
                        schedule::angle_rule_feed_mm_min(theta_deg, feed, v0),
                        CapKind::SurfaceAngle,
                    );
                }
            }
            if let Some(lo) = limits.feed_min {
                cap.0 = cap.0.max(lo);
            }
            cap
        })
        .collect()
}

/// Apply interval caps to both end stations of each interval, so the speed
/// (v² linear between stations) respects the cap over the whole interval.
pub fn apply_interval_caps(stations: &mut Stations, caps: &[(f64, CapKind)]) -> Result<()> {
    for (k, &(cap, kind)) in caps.iter().enumerate() {
        if cap.is_finite() {
            let seg = stations.segment()[k + 1] as usize;
            if matches!(stations.segments()[seg].motion, Motion::Rapid) {
                continue;
            }
            stations.apply_cap(k, cap, kind)?;
            stations.apply_cap(k + 1, cap, kind)?;
        }
    }
    Ok(())
}

/// Shortest block the re-feed writer emits, mm (and never shorter than the
/// control can read in its block time at the block's feed).
pub const MIN_BLOCK_MM: f64 = 0.2;
/// Feeds within this ratio are merged into one block (the lower one is written).
pub const MERGE_RATIO: f64 = 1.05;

/// Per path segment, the feed pieces `(fraction_end, feed_mm_min)` to write:
/// piecewise-constant feeds that never exceed the limit caps (`interval_caps`,
/// and feed_max) in the piece. Corner, curvature and acceleration limits are
/// left to the control, as with any program.
pub fn refeed_plan(
    stations: &Stations,
    interval_caps: &[(f64, CapKind)],
    machine: &Machine,
) -> Vec<Vec<(f64, f64)>> {
    let segs = stations.segments();
    let mut plan: Vec<Vec<(f64, f64)>> = vec![Vec::new(); segs.len()];
    let (seg_of, frac, s) = (stations.segment(), stations.fraction(), stations.s_mm());
    let tb_ms = machine.block_time_ms.unwrap_or(0.0);
    let mut k = 1;
    while k < stations.len() {
        let seg = seg_of[k] as usize;
        let mut pieces: Vec<(f64, f64, f64)> = Vec::new(); // (s_end, frac_end, feed)
        let (mut start_s, mut lo, mut hi) = (s[k - 1], f64::INFINITY, 0.0f64);
        while k < stations.len() && seg_of[k] as usize == seg {
            let c = interval_caps[k - 1].0.min(machine.feed_max_mm_min);
            let (new_lo, new_hi) = (lo.min(c), hi.max(c));
            let long_enough = s[k - 1] - start_s >= MIN_BLOCK_MM.max(lo * tb_ms / 60_000.0);
            if lo.is_finite() && new_hi > MERGE_RATIO * new_lo && long_enough {
                pieces.push((s[k - 1], frac[k - 1], lo));
                start_s = s[k - 1];
                lo = c;
                hi = c;
            } else {
                lo = new_lo;
                hi = new_hi;
            }
            k += 1;
        }
        pieces.push((s[k - 1], 1.0, lo));
        // A last piece too short to be read in time joins the one before (at the lower feed).
        if pieces.len() > 1 {
            let n = pieces.len();
            let last_len = pieces[n - 1].0 - pieces[n - 2].0;
            if last_len < MIN_BLOCK_MM.max(pieces[n - 1].2 * tb_ms / 60_000.0) {
                let f = pieces[n - 1].2.min(pieces[n - 2].2);
                pieces.pop();
                let last = pieces.last_mut().expect("two pieces");
                *last = (last.0, 1.0, f);
            }
        }
        if matches!(segs[seg].motion, Motion::Feed { .. }) {
            plan[seg] = pieces
                .iter()
                .map(|p| (p.1, (p.2.floor()).max(1.0)))
                .collect();
        }
    }
    plan
}

/// Share of the optimised time spent at each kind of cap.
#[derive(Clone, Debug, Serialize)]
pub struct CapShare {
    pub cap: String,
    pub share: f64,
}

pub fn cap_shares(profile: &schedule::Profile<'_>) -> Vec<CapShare> {
    profile
        .time_at_cap_share()
        .into_iter()
        .filter(|(_, share)| *share > 0.0)
        .map(|(kind, share)| CapShare {
            cap: format!("{kind:?}"),
            share,
        })
        .collect()
}

/// The machine the optimiser plans for: the job's, with [limits] feed_max.
pub fn optimising_machine(machine: &Machine, limits: &LimitsSpec) -> Machine {
    Machine {
        feed_max_mm_min: limits.feed_max.unwrap_or(machine.feed_max_mm_min),
        ..*machine
    }
}

/// Stations for re-timing with every feed block free up to feed_max.
pub fn free_stations(path: &nc::Path, machine: &Machine) -> Result<Stations> {
    if path
        .segments
        .iter()
        .all(|s| !matches!(s.motion, Motion::Feed { .. }))
    {
        bail!("the program has no feed moves to optimise");
    }
    Ok(Stations::new(
        path,
        machine,
        STATION_DS_MM,
        FeedPolicy::MachineMax,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windowed_area_is_conservative_and_exact_on_plateaus() {
        // 0.05 mm intervals; volume alternates 0 / 3 (quantised 30 mm³/mm) from s = 2 to 6.
        let s: Vec<f64> = (0..=200).map(|i| i as f64 * 0.05).collect();
        let v: Vec<f64> = (0..200)
            .map(|i| {
                if (40..120).contains(&i) {
                    if i % 2 == 0 {
                        3.0
                    } else {
                        0.0
                    }
                } else {
                    0.0
                }
            })
            .collect();
        let a = windowed_area(&s, &v, 0.2);
        assert!((a[80] - 30.0).abs() < 1e-9, "plateau {}", a[80]);
        // The cap starts one window (4 intervals) before the rise and ends one window after.
        assert!(a[36] > 0.0 && a[35] == 0.0, "{:?}", &a[34..42]);
        // (the last non-zero interval is 118: the pattern alternates).
        assert!(a[122] > 0.0 && a[123] == 0.0, "{:?}", &a[118..126]);
        // Never below the plain mean over any window.
        assert!(a.iter().all(|x| *x <= 30.0 + 1e-9));
    }
}
