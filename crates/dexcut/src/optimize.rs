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

use crate::error::{fail, Result, ResultExt as _};
use cutting::CuttingModel;
use dexel::{Stock, SweepOptions};
use nc::Motion;
use schedule::{CapKind, FeedPolicy, Machine, Stations};
use serde::Serialize;

use crate::commands::Setup;
use crate::job::LimitsSpec;
use crate::motion::STATION_DS_MM;
use crate::simulate::{Run, StockSource};
use crate::tools::ToolSet;

/// Engagement along the stations: removed volume per interval.
pub struct Engagement {
    /// Per interval k (station k → k+1): removed volume per unit length, mm³/mm.
    pub area_mm2: Vec<f64>,
    /// Per interval: index into the tool set of the tool cutting it (2 B an
    /// interval, issue 16).
    pub tool_index: Vec<u16>,
    /// Per interval: the load at [`REFERENCE_FEED_MM_MIN`] with the windowed engagement.
    pub reference_loads: Vec<ReferenceLoad>,
    /// Per interval: S3's cutting-surface angle of a ball-end mill, degrees
    /// (NaN where not asked for, not a ball, no cut or no surface within reach).
    pub surface_angle_deg: Vec<f64>,
}

/// What the caps take of a load at [`REFERENCE_FEED_MM_MIN`] (a
/// `cutting::StepLoad`'s force, deflection, power and stress; 32 B per
/// interval instead of the whole load's 104 B, issue 16).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReferenceLoad {
    pub force_n: f64,
    pub deflection_um: f64,
    pub power_w: f64,
    pub stress_mpa: f64,
}

impl From<cutting::StepLoad> for ReferenceLoad {
    fn from(l: cutting::StepLoad) -> Self {
        ReferenceLoad {
            force_n: l.force_n,
            deflection_um: l.deflection_um,
            power_w: l.power_w,
            stress_mpa: l.stress_mpa,
        }
    }
}

/// Where S3's surface normal comes from (MODEL.md §6.3).
#[derive(Clone, Copy)]
pub enum SurfaceFrom<'a> {
    /// Not needed (no angle rule).
    Nothing,
    /// The `[design]` model's surface nearest to the ball centre.
    Design(&'a mesh::DesignModel),
    /// The stock surface that the removal leaves, nearest to the ball centre.
    Stock,
}

/// Feed at which [`Engagement::reference_loads`] are computed, mm/min.
pub const REFERENCE_FEED_MM_MIN: f64 = 1000.0;

/// Sweep a copy of the stock along the stations (geometry only, no time).
pub fn engagement(
    stations: &Stations,
    stock: &Stock,
    tools: &ToolSet,
    surface: SurfaceFrom,
) -> Result<Engagement> {
    engagement_on(stations, &StockSource::Lent(stock), tools, surface)
}

/// [`engagement`] through `stock`: a copy of a stock held whole, or a stock
/// too large for memory band by band (ARCHITECTURE.md "Large stocks"; the
/// record is the whole stock's bit for bit). The stock surface S3 may take
/// its angles from needs every column at once: refused on a tiled stock.
pub fn engagement_on(
    stations: &Stations,
    stock: &StockSource,
    tools: &ToolSet,
    surface: SurfaceFrom,
) -> Result<Engagement> {
    if let (StockSource::Tiled(t), SurfaceFrom::Stock) = (stock, surface) {
        fail!(limits, "[limits] angle_rule with a stock too large for the memory budget ({} rows in bands of {}): the surface angles come from the swept stock's surface, which needs every column at once; give a [design] model, use a coarser grid or a larger --memory-budget-mb", t.grid.ny, t.band_rows);
    }
    let segs = stations.segments();
    let seg_of = stations.segment();
    let n = stations.len();
    // Interval k's move, made when the sweep asks for it from the stations'
    // positions (a list of them held 56 B an interval beside the record:
    // issue 16).
    let steps = dexel::StepFn::new(n.saturating_sub(1), |i| {
        let k = i + 1;
        dexel::Step {
            from_mm: stations.position_at(k - 1).coords.into(),
            to_mm: stations.position_at(k).coords.into(),
            rapid: matches!(segs[seg_of[k] as usize].motion, Motion::Rapid),
        }
    });
    let tool_index: Vec<u16> = tools.indices((1..n).map(|k| {
        let seg = &segs[seg_of[k] as usize];
        (seg.tool, seg.line)
    }))?;
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    let (swept, record) = crate::simulate::sweep_pass(
        &stock.initial(),
        None,
        tools,
        &tool_index,
        &steps,
        &options,
        "engagement",
    )?;
    // The swept stock only where S3 takes its angles from its surface.
    let swept = swept.filter(|_| matches!(surface, SurfaceFrom::Stock));
    let volumes: Vec<f64> = (0..record.len()).map(|k| record.volume_mm3(k)).collect();
    let spacing_mm = stock.grid().spacing_mm;
    let window_mm = (ENGAGEMENT_WINDOW_CELLS * spacing_mm).max(2.0 * STATION_DS_MM);
    let area_mm2 = windowed_area(stations.s_mm(), &volumes, window_mm);
    drop(volumes);

    let reference_loads = reference_loads(&record, &area_mm2, stations.s_mm(), |k| {
        &tools.entries[usize::from(tool_index[k])].model
    });
    // The record is not needed again (about 70 B an interval, issue 16).
    drop(record);
    let surface_angle_deg = surface_angles_deg(
        stations,
        swept.as_ref(),
        spacing_mm,
        tools,
        &tool_index,
        &area_mm2,
        surface,
    );
    Ok(Engagement {
        area_mm2,
        reference_loads,
        tool_index,
        surface_angle_deg,
    })
}

/// S3's cutting-surface angle per interval (MODEL.md §6.3): the angle between
/// the tool axis and the normal of the surface nearest to the ball centre at
/// the interval's middle, from the design model or from the stock after the
/// sweep (`swept`, on a grid of `g` mm; none for a tiled stock, which takes
/// no angles from its surface). NaN on intervals that cut nothing or not
/// with a ball.
fn surface_angles_deg(
    stations: &Stations,
    swept: Option<&Stock>,
    g: f64,
    tools: &ToolSet,
    tool_index: &[u16],
    area_mm2: &[f64],
    surface: SurfaceFrom,
) -> Vec<f64> {
    use rayon::prelude::*;
    (0..area_mm2.len())
        .into_par_iter()
        .map(|k| {
            let tool = &tools.entries[usize::from(tool_index[k])].tool;
            if area_mm2[k] <= 1e-12 || tool.shape != dexel::ToolShape::Ball {
                return f64::NAN;
            }
            let r = tool.radius_mm();
            let (from, to) = (stations.position_at(k), stations.position_at(k + 1));
            let mid = nalgebra::center(&from, &to);
            let centre = [mid.x, mid.y, mid.z + r];
            let along: [f64; 3] = (to - from).into();
            let normal = match surface {
                SurfaceFrom::Nothing => None,
                SurfaceFrom::Design(model) => model.normal_towards_mm(centre),
                // Points within half a column of the nearest are touched; look up to 4 radii away.
                SurfaceFrom::Stock => swept.and_then(|stock| {
                    dexel::surface_normal_near(stock, centre, along, 0.5 * g, 4.0 * r)
                }),
            };
            normal.map_or(f64::NAN, dexel::angle_to_axis_deg)
        })
        .collect()
}

/// Per interval, the load at [`REFERENCE_FEED_MM_MIN`] of a cut with the
/// windowed volume per length and the interval's own shape of removal (chip
/// thickness per feed, contact direction, bands), taken where this one
/// removed none from the last interval before it that did (before any, the
/// first that did).
fn reference_loads<'a>(
    record: &dexel::RemovalRecord,
    area_mm2: &[f64],
    s_mm: &[f64],
    model_of: impl Fn(usize) -> &'a CuttingModel,
) -> Vec<ReferenceLoad> {
    let n = area_mm2.len();
    // Interval k's source: the last interval up to k that removed material,
    // else (none before it) the first that did (not a list of the sources:
    // 16 B an interval, issue 16).
    let first_cut = (0..n).find(|&k| record.volume_mm3(k) > 0.0);
    let mut last = None;
    let mut bands = vec![0.0; record.n_bands];
    (0..n)
        .map(|k| {
            if record.volume_mm3(k) > 0.0 {
                last = Some(k);
            }
            let (Some(j), true) = (last.or(first_cut), area_mm2[k] > 0.0) else {
                return cutting::StepLoad::default().into();
            };
            let len_mm = s_mm[k + 1] - s_mm[k];
            let volume = area_mm2[k] * len_mm;
            let scale = volume / record.volume_mm3(j);
            // The record keeps a step's bands up to its highest nonzero one.
            bands.fill(0.0);
            for (b, v) in bands.iter_mut().zip(record.band_volumes_mm3(j)) {
                *b = v * scale;
            }
            let [cx, cy] = record.contact_resultant(j);
            let load = model_of(k).step_load(&cutting::StepRemoval {
                volume_mm3: volume,
                band_volumes_mm3: &bands,
                contact_resultant: [cx * scale, cy * scale],
                // The chip edge area is per step: for the interval's own length, scaled
                // by the ratio of lengths (thickness per mm of path is what is kept).
                chip_edge_area_mm2: record.chip_edge_area_mm2(j) * scale * (s_mm[j + 1] - s_mm[j])
                    / len_mm,
                volume_over_radius_mm2: record.volume_over_radius_mm2(j) * scale,
                dt_s: len_mm * 60.0 / REFERENCE_FEED_MM_MIN,
            });
            ReferenceLoad::from(load)
        })
        .collect()
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
/// Cutting intervals (engagement above zero) are also held to the chip load
/// `fz_max_mm` (F ≤ f_z·z·n with the segment's spindle speed, MODEL.md §2.1)
/// and to `feed_scale_max` times the programmed feed; air runs free.
pub fn interval_caps(
    engagement: &Engagement,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
) -> Vec<(f64, CapKind)> {
    let (segs, seg_of) = (stations.segments(), stations.segment());
    engagement
        .area_mm2
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            // The model of the tool cutting this interval.
            let entry = &tools.entries[usize::from(engagement.tool_index[k])];
            let model = &entry.model;
            let mut cap = (f64::INFINITY, CapKind::FeedMax);
            let mut lower = |v: f64, kind: CapKind| {
                if v < cap.0 {
                    cap = (v, kind);
                }
            };
            if a > 1e-12 {
                let seg = &segs[seg_of[k + 1] as usize];
                if let Some(f) = entry.chip_load_feed_mm_min(seg.spindle_rpm) {
                    lower(f, CapKind::ChipLoad);
                }
                if let (Some(scale), Motion::Feed { feed_mm_min }) =
                    (limits.feed_scale_max, seg.motion)
                {
                    lower(scale * feed_mm_min, CapKind::FeedScale);
                }
                if let Some(q) = limits.mrr_max {
                    lower(60.0 * q / a, CapKind::Removal); // MRR = A·F/60 ≤ Q
                }
                // Load ∝ F^p at fixed engagement (MODEL.md §3): F ≤ F_ref·(limit/Q_ref)^(1/p).
                let at_ref = &engagement.reference_loads[k];
                let cap = |q_ref: f64, limit: f64| {
                    model.feed_for_limit(q_ref, REFERENCE_FEED_MM_MIN, limit)
                };
                if let Some(f) = limits.force_max {
                    lower(cap(at_ref.force_n, f), CapKind::Force);
                }
                if let Some(d_um) = limits.deflection_max_um {
                    lower(cap(at_ref.deflection_um, d_um), CapKind::Deflection);
                }
                if let Some(p_kw) = limits.power_max_kw {
                    lower(cap(at_ref.power_w, 1000.0 * p_kw), CapKind::Power);
                }
                // The stress grows with the step's load (force and torque) at its
                // contact height (MODEL.md §4.4): a force limit of F·σ_limit/σ.
                if limits.stress {
                    lower(
                        cap(at_ref.stress_mpa, entry.stress_limit_mpa),
                        CapKind::Stress,
                    );
                }
                // S3 (MODEL.md §6.3): θ between the surface normal at the contact and the
                // tool axis, applied to the programmed (set) feed.
                let theta_deg = engagement.surface_angle_deg[k];
                if let (true, Some(v0), false, Motion::Feed { feed_mm_min }) =
                    (limits.angle_rule, limits.v0, theta_deg.is_nan(), seg.motion)
                {
                    lower(
                        schedule::angle_rule_feed_mm_min(theta_deg, feed_mm_min, v0),
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
/// Feeds within this ratio are first merged into one block (the lower one is
/// written); [`write_verified`] lowers it (down to [`MERGE_RATIO_MIN`]) when
/// the written program is slower than the plan by more than [`PLAN_TOLERANCE`].
pub const MERGE_RATIO: f64 = 1.05;
/// The written program's cycle time may exceed the plan's by this fraction.
pub const PLAN_TOLERANCE: f64 = 0.01;
/// The finest merge ratio tried.
pub const MERGE_RATIO_MIN: f64 = 1.01;
/// A period counts as above a limit in the result when it exceeds it by more than this.
pub const LIMIT_TOLERANCE: f64 = 0.02;

/// Per path segment, the feed pieces `(fraction_end, feed_mm_min)` to write:
/// piecewise-constant feeds that never exceed the limit caps (`interval_caps`,
/// and feed_max) in the piece. Feeds within `merge_ratio` share a block; a
/// block is at least [`MIN_BLOCK_MM`] long. A short last piece takes its length
/// from the piece before it rather than lowering that whole piece to its feed.
/// Corner, curvature and acceleration limits are left to the control, as with
/// any program.
pub fn refeed_plan(
    stations: &Stations,
    interval_caps: &[(f64, CapKind)],
    machine: &Machine,
    merge_ratio: f64,
) -> Vec<Vec<(f64, f64)>> {
    let segs = stations.segments();
    let mut plan: Vec<Vec<(f64, f64)>> = vec![Vec::new(); segs.len()];
    let (seg_of, frac, s) = (stations.segment(), stations.fraction(), stations.s_mm());
    let tb_ms = machine.block_time_ms.unwrap_or(0.0);
    let min_len = |feed: f64| MIN_BLOCK_MM.max(feed * tb_ms / 60_000.0);
    let mut k = 1;
    while k < stations.len() {
        let seg = seg_of[k] as usize;
        // Intervals of this segment: (s_end, fraction_end, cap).
        let first = k;
        while k < stations.len() && seg_of[k] as usize == seg {
            k += 1;
        }
        if !matches!(segs[seg].motion, Motion::Feed { .. }) {
            continue;
        }
        let cap = |i: usize| interval_caps[i - 1].0.min(machine.feed_max_mm_min);
        let min_cap = |a: usize, b: usize| (a..b).map(cap).fold(f64::INFINITY, f64::min);
        // Piece boundaries as station indices: piece j covers intervals bounds[j]+1 ..= bounds[j+1].
        let mut bounds = vec![first - 1];
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for i in first..k {
            let c = cap(i);
            let (new_lo, new_hi) = (lo.min(c), hi.max(c));
            let start = *bounds.last().expect("a start");
            let long_enough = s[i - 1] - s[start] >= min_len(lo);
            if lo.is_finite() && new_hi > merge_ratio * new_lo && long_enough {
                bounds.push(i - 1);
                (lo, hi) = (c, c);
            } else {
                (lo, hi) = (new_lo, new_hi);
            }
        }
        bounds.push(k - 1);
        // A last piece too short to be read in time takes length from the piece
        // before it, or joins it when that one would become too short.
        while bounds.len() > 2 {
            let n = bounds.len();
            let last_feed = min_cap(bounds[n - 2] + 1, bounds[n - 1] + 1);
            if s[bounds[n - 1]] - s[bounds[n - 2]] >= min_len(last_feed) {
                break;
            }
            let mut b = bounds[n - 2];
            while b > bounds[n - 3] + 1 && s[bounds[n - 1]] - s[b] < min_len(last_feed) {
                b -= 1;
            }
            let prev_feed = min_cap(bounds[n - 3] + 1, b + 1);
            if s[bounds[n - 1]] - s[b] >= min_len(last_feed)
                && s[b] - s[bounds[n - 3]] >= min_len(prev_feed)
            {
                bounds[n - 2] = b;
                break;
            }
            bounds.remove(n - 2);
        }
        plan[seg] = bounds
            .windows(2)
            .map(|w| {
                let f = if w[1] == k - 1 { 1.0 } else { frac[w[1]] };
                (f, min_cap(w[0] + 1, w[1] + 1))
            })
            .collect();
    }
    // Feed moves too short for a station (below the planner's shortest segment) keep their feed.
    for (seg, pieces) in segs.iter().zip(plan.iter_mut()) {
        if let (Motion::Feed { feed_mm_min }, true) = (seg.motion, pieces.is_empty()) {
            pieces.push((1.0, feed_mm_min));
        }
    }
    plan
}

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
    /// [`LIMIT_TOLERANCE`] for removal, force, deflection and power per
    /// period, [`CHIP_LOAD_TOLERANCE`] for the chip-load feed of a cutting step.
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
}

/// A step that removes material may run above its chip-load feed by this
/// fraction (the feed of a servo step is a mean over a chord; F words are
/// rounded down, so the plan itself never exceeds the cap).
pub const CHIP_LOAD_TOLERANCE: f64 = 1e-3;

/// Margin kept under a limit when a period over it is corrected.
pub const LIMIT_MARGIN: f64 = 0.01;

/// Servo periods of `run` (per period, as the summary prints them) whose MRR,
/// force, deflection, spindle power or tool stress exceeds the limits, and steps that
/// remove material (however little: any step in contact with the stock is a
/// cutting move) above their tool's chip-load feed f_z,max·z·n at the block's
/// spindle speed (MODEL.md §2.1). MRR scales with the feed; force, deflection
/// and power with the feed to the power p of the step's tool's force model
/// (n of S4's law, 1 − mc of Kienzle's, MODEL.md §3).
pub fn excesses(run: &Run, limits: &LimitsSpec, tools: &ToolSet) -> Vec<Excess> {
    let mut out = Vec::new();
    let grid_mm = run.stock.grid().spacing_mm;
    // The periods one by one (a million periods held as a list were 72 MB
    // beside the run at the verification's peak, issue 16).
    run.for_each_period(|period| {
        if !period.cutting {
            return;
        }
        // Per load: the largest value / limit in the period, and the feed exponent of its tool.
        let mut worst = [(0.0f64, 1.0f64); 4];
        // Largest step feed / its chip-load feed among the steps that cut.
        let mut chip: Option<(f64, f64)> = None;
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
                (load.force_n, limits.force_max),
                // Where the tool breaks, the linear deflection: the one at
                // rupture does not scale with the feed (MODEL.md §4.4).
                (run.linear_deflection_um(k), limits.deflection_max_um),
                (load.power_w, limits.power_max_kw.map(|kw| 1000.0 * kw)),
                (
                    load.stress_mpa,
                    limits.stress.then_some(run.stress_limits_mpa[k]),
                ),
            ]) {
                if let Some(limit) = limit {
                    if value / limit > w.0 {
                        *w = (value / limit, p);
                    }
                }
            }
            if run.record.volume_mm3(k) > crate::simulate::NOTHING_MM3 {
                if let Some(cap) = entry.chip_load_feed_mm_min(step.spindle_rpm) {
                    if chip.is_none_or(|(r, _)| step.feed_mm_min / cap > r) {
                        chip = Some((step.feed_mm_min / cap, cap));
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
                CapKind::ChipLoad => CHIP_LOAD_TOLERANCE,
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
        if let Some((ratio, cap)) = chip {
            if ratio > 1.0 + 0.5 * CHIP_LOAD_TOLERANCE {
                lower(cap * (1.0 - 1e-6), CapKind::ChipLoad, ratio - 1.0);
            }
        }
        if let (Some((cap, kind)), true) = (found, feed > 0.0) {
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
            });
        }
    });
    out
}

/// Lower the interval caps over each excess (± `margin_mm`) to the feed it
/// may run at, never below `feed_min`. A removal excess where the tool
/// advances less than a grid cell per period ([`Excess::sub_cell`]) lowers
/// the whole written block it lies in (`blocks`: per interval, the block it
/// is written in): its removal per period varies with the column phase
/// along the block, and a change of timing anywhere shifts that phase, so
/// the block's feed is what sets its peak.
pub fn lower_caps(
    caps: &mut [(f64, CapKind)],
    s_mm: &[f64],
    blocks: &[u32],
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
            while from > 0 && blocks[from - 1] == blocks[from] {
                from -= 1;
            }
            while to + 1 < caps.len() && blocks[to + 1] == blocks[to] {
                to += 1;
            }
        }
        for c in &mut caps[from..=to] {
            if cap < c.0 {
                *c = (cap, e.kind);
            }
        }
    }
}

/// Per interval, the block of the written program it lies in (an index
/// counting the refeed plan's pieces over all segments; u32, 4 B an interval:
/// there are fewer pieces than segments, u32-indexed, and stations together).
pub fn interval_blocks(stations: &Stations, plan: &[Vec<(f64, f64)>]) -> Vec<u32> {
    let (seg_of, frac) = (stations.segment(), stations.fraction());
    let mut first_piece = Vec::with_capacity(plan.len());
    let mut n = 0;
    for pieces in plan {
        first_piece.push(n);
        n += pieces.len().max(1);
    }
    (0..stations.len() - 1)
        .map(|k| {
            let seg = seg_of[k + 1] as usize;
            let f = frac[k + 1];
            let piece = plan[seg].iter().position(|p| p.0 >= f - 1e-9).unwrap_or(0);
            u32::try_from(first_piece[seg] + piece).expect("fewer than 2^32 blocks")
        })
        .collect()
}

/// Per interval, the feed of the block (refeed plan piece) it lies in, with the
/// kind of cap that set the interval.
pub fn block_caps(
    stations: &Stations,
    plan: &[Vec<(f64, f64)>],
    caps: &[(f64, CapKind)],
) -> Vec<(f64, CapKind)> {
    let (seg_of, frac) = (stations.segment(), stations.fraction());
    (0..caps.len())
        .map(|k| {
            let pieces = &plan[seg_of[k + 1] as usize];
            let f = frac[k + 1];
            match pieces.iter().find(|p| p.0 >= f - 1e-9) {
                Some(&(_, feed)) => (feed, caps[k].1),
                None => caps[k],
            }
        })
        .collect()
}

/// Most rounds of writing, re-simulating and correcting the program.
pub const MAX_ROUNDS: usize = 12;

/// The program optimize writes, re-simulated as a program of its own.
pub struct Written {
    /// The written program simulated (the program as given where it is
    /// kept).
    pub run: Run,
    /// What its servo samples (servo.csv's rows) hold beside the run's steps
    /// ([`crate::motion::SampleFeeds::rows`]: 8 B a sample held beside the
    /// run instead of 72, issue 16).
    pub samples: crate::motion::SampleFeeds,
    /// Cycle time of the plan as written (each block at its feed, the
    /// machine's acceleration), s.
    pub plan_time_s: f64,
    /// Cycle time of the time-optimal timing under the final caps (feeds free
    /// to change at every station), s.
    pub time_optimal_s: f64,
    /// Σ Δs / cap under the final caps, s.
    pub lower_bound_time_s: f64,
    pub cap_shares: Vec<CapShare>,
    /// Rounds of write → re-simulate → correct.
    pub rounds: usize,
    /// Feeds within this ratio share a block in the written program.
    pub merge_ratio: f64,
    /// Servo periods still above a limit by more than its tolerance after the
    /// last round, where the tool advanced at least a grid cell.
    pub excesses_left: usize,
    /// The original program was within every limit and faster: it is written unchanged.
    pub kept_original: bool,
    /// Periods above a limit by more than its tolerance after the last round,
    /// where the tool advanced less than a grid cell (see [`Excess::resolved`]).
    pub unresolved: Vec<Excess>,
}

/// Whether a run (of the program as written) is within every limit: no
/// period above mrr_max, force_max, deflection_max_um, power_max_kw or the tool's
/// stress_limit_mpa (with `stress`) by more
/// than [`LIMIT_TOLERANCE`], no cutting step above its tool's chip-load feed
/// by more than [`CHIP_LOAD_TOLERANCE`].
pub fn within_limits(run: &Run, limits: &LimitsSpec, tools: &ToolSet) -> bool {
    excesses(run, limits, tools)
        .iter()
        .all(|e| !e.beyond_tolerance)
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
    out: &mut crate::warnings::Warnings,
) {
    if !limits.stress {
        return;
    }
    let mut tally = crate::warnings::LineTally::new();
    let mut fastest = 0.0f64;
    for (k, s) in run.steps.iter().enumerate() {
        let limit = run.stress_limits_mpa[k];
        if !s.step.rapid && run.loads[k].stress_mpa > limit * (1.0 + LIMIT_TOLERANCE) {
            crate::warnings::tally(&mut tally, s.line, run.loads[k].stress_mpa);
            fastest = fastest.max(s.feed_mm_min);
        }
    }
    let limit = run.stress_limit_mpa();
    let held = limits
        .feed_min
        .filter(|&lo| fastest <= lo * (1.0 + LIMIT_TOLERANCE));
    out.from_lines(
        crate::warnings::WarningKind::LimitExceeded,
        &tally,
        "MPa",
        false,
        |v, lines| match held {
            Some(lo) => format!("optimized.nc still stresses the tool to {v:.0} MPa at {lines}, above its allowable {limit:.0} MPa ([tool] stress_limit_mpa), at feed_min ({lo} mm/min), the lowest feed optimize may write: the depth and width of cut the program gives these lines are too much for the tool at that feed (the stress falls only as the feed to the power 1 − mc, docs/MODEL.md §4.4); lower [limits] feed_min, or cut shallower or narrower there"),
            None => format!("optimized.nc still stresses the tool to {v:.0} MPa at {lines}, above its allowable {limit:.0} MPa ([tool] stress_limit_mpa), after {rounds} rounds of slowing them (docs/MODEL.md §4.4)"),
        },
    );
}

/// What [`write_verified`] needs of the program as given (its run need not
/// be held through the rounds).
#[derive(Clone, Copy, Debug)]
pub struct Given {
    /// Its cycle time, s.
    pub cycle_s: f64,
    /// It is within every limit ([`within_limits`]).
    pub within_limits: bool,
}

impl Given {
    /// What the rounds need of `run`, the program as given.
    pub fn of(run: &Run, limits: &LimitsSpec, tools: &ToolSet) -> Given {
        Given {
            cycle_s: run.steps.last().map_or(0.0, |s| s.t_end_s),
            within_limits: within_limits(run, limits, tools),
        }
    }
}

/// Write the re-timed program, simulate it as a program of its own (parsed
/// again and planned by the machine model), and correct it until every servo
/// period is within the limits and its cycle time is within
/// [`PLAN_TOLERANCE`] of the plan: periods over a limit lower the caps there,
/// a written program slower than the plan gets finer blocks (down to
/// [`MERGE_RATIO_MIN`]; what remains comes from lines `nc::refeed` cannot
/// split per run, which take one feed: MODEL.md §2.2). When the
/// original program is within every limit and the result would be slower,
/// the original is kept. The program's path is read from `free`'s
/// ([`FreeStations::path`]): the setup's may be lent to them. `free`'s
/// arrays are let go while the written program is verified and made again
/// (by `machine`) for a next round. A G-code program's text is written to
/// `out_dir`'s optimized.nc as each round makes it (the original's where it
/// is kept), not held through the verification: `out_dir` is a staging
/// folder, committed whole when every file is written.
pub fn write_verified(
    setup: &Setup,
    machine: &Machine,
    free: &mut FreeStations,
    mut caps: Vec<(f64, CapKind)>,
    before: Given,
    out_dir: &std::path::Path,
) -> Result<Written> {
    let write_text = |text: &str| {
        let file = out_dir.join("optimized.nc");
        export::atomic::write_bytes(&file, text.as_bytes())
            .map_err(|e| crate::error::Error::io("cannot write", &file, e))
    };
    let limits = &setup.job.limits;
    let margin_mm = 2.0 * setup.stock.grid().spacing_mm;
    let mut merge_ratio = MERGE_RATIO;
    let mut round = 0;
    loop {
        round += 1;
        let stations = free.stations(machine, setup)?;
        // The two plans are made one after the other on the stations
        // themselves, their caps put back after each (no copy of the
        // stations), and dropped before the written program is simulated:
        // what the rounds keep of them is their times, the refeed plan, the
        // cap shares and, for a point list, the servo samples.
        let (plan, time_optimal_s, lower_bound_time_s) =
            stations.with_caps_restored(|stations| {
                apply_interval_caps(stations, &caps)?;
                let optimum = schedule::plan(stations);
                let time_optimal_s = optimum.cycle_time_s();
                let lower_bound_time_s = schedule::lower_bound_time_s(stations);
                let plan = refeed_plan(stations, &caps, machine, merge_ratio);
                Ok::<_, crate::error::Error>((plan, time_optimal_s, lower_bound_time_s))
            })?;
        // The plan as written: every interval at its block's feed.
        let written_caps = block_caps(stations, &plan, &caps);
        let (plan_time_s, shares) = stations.with_caps_restored(|blocks| {
            apply_interval_caps(blocks, &written_caps)?;
            let profile = schedule::plan(blocks);
            Ok::<_, crate::error::Error>((profile.cycle_time_s(), cap_shares(&profile)))
        })?;
        drop(written_caps);
        // Caps from tiny limits (mrr_max 1e-4) would make the written program run for days.
        crate::bounds::check_samples(
            plan_time_s.max(time_optimal_s),
            machine.period_ms,
            "the re-timed program ([limits] caps: mrr_max, force_max, deflection_max_um, the tool's stress_limit_mpa)",
        )?;
        // A point list is written as the optimum's servo samples: that plan again.
        let optimum_samples = match &setup.program.gcode {
            Some(_) => None,
            None => Some(stations.with_caps_restored(|stations| {
                apply_interval_caps(stations, &caps)?;
                Ok::<_, crate::error::Error>(schedule::plan(stations).sample(machine.period_ms)?)
            })?),
        };
        // What a next round needs of the refeed plan is each interval's
        // block: kept instead of the plan (a million segments' pieces, one
        // `Vec` each, 40 MB), which is dropped before the sweep.
        let blocks = interval_blocks(stations, &plan);
        // Nor are the stations' arrays needed while the program is written,
        // read back and verified (3 M stations: 143 MB beside the re-feed's
        // readings and the run): only their path is kept, and a next round
        // makes them again (the same stations: their caps are always put
        // back as made).
        free.release();
        // The written program's path is lent to its planner, and dropped
        // once its steps and what servo.csv needs of the samples beside
        // them (their feeds) are made, with the samples (before the sweep).
        let (sample_feeds, steps) = match &setup.program.gcode {
            Some(src) => {
                // The written program as the re-feed writer read it back to
                // check it (with the program's options, as `nc::parse` reads
                // it): not read once more.
                // The program's path handed to the re-feed (the stations are
                // let go): the source's reading makes it again, and holds
                // it, not a second copy, where it makes it bit for bit (126
                // MB for a million blocks); it is let go before the written
                // text is read back, and read again from the program's text
                // where a next round or the caller needs it (0.7 s CPU for a
                // million blocks). The path is in dexcut's frame, the text
                // reads in its own: mirrored for a Z that points down.
                let (file, options) = (&setup.program.file, &setup.program.nc_options);
                let mut path = free.give(setup)?;
                if setup.program.z_down {
                    path.mirror_z();
                }
                let read = nc::refeed_read_along(src, file, options, &plan, path);
                // Read by the re-feed alone (40 MB of pieces for a million
                // segments, not held while the samples and steps are made).
                drop(plan);
                let (text, parsed) =
                    read.or_run(|| format!("{file}: cannot write the re-fed program"))?;
                // Written now and let go (60 MB for a million blocks).
                write_text(&text)?;
                drop(text);
                let parsed = setup.program.in_frame(parsed);
                if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
                    fail!(run, "the re-fed program does not read back: {d}");
                }
                let path = parsed.path;
                let (samples, path) = crate::motion::machine_motion_of(path, &setup.machine);
                let samples = samples?;
                let steps = crate::motion::steps_from_samples(&path, &samples);
                let feeds = crate::motion::SampleFeeds::of(&samples, &path);
                (feeds, steps)
            }
            None => {
                drop(plan);
                let samples = optimum_samples.expect("sampled for a point list");
                free.with_path(setup, |path| {
                    let steps = crate::motion::steps_from_samples(path, &samples);
                    (crate::motion::SampleFeeds::of(&samples, path), steps)
                })?
            }
        };
        let run = crate::simulate::run_on(
            setup.stock_source(),
            &setup.tools,
            steps,
            &format!("verify {round}"),
        )?;
        let over = excesses(&run, limits, &setup.tools);
        let gcode = setup.program.gcode.as_deref();
        let slow = gcode.is_some()
            && run.steps.last().map_or(0.0, |s| s.t_end_s) > plan_time_s * (1.0 + PLAN_TOLERANCE);
        let refine_blocks = slow && merge_ratio > MERGE_RATIO_MIN;
        // Every period over a limit lowers its caps; the rounds end when none
        // is over by more than its tolerance.
        // (An excess without a finite cap has nothing to lower.)
        let done = (!over
            .iter()
            .any(|e| e.beyond_tolerance && e.cap_mm_min.is_finite())
            && !refine_blocks)
            || round >= MAX_ROUNDS;
        if done {
            let cycle = run.steps.last().map_or(0.0, |s| s.t_end_s);
            let kept_original = gcode.is_some() && cycle > before.cycle_s && before.within_limits;
            let (left, unresolved): (Vec<Excess>, Vec<Excess>) = over
                .into_iter()
                .filter(|e| e.beyond_tolerance)
                .partition(|e| e.resolved);
            let (run, sample_feeds) = match (kept_original, gcode) {
                (true, Some(original)) => {
                    write_text(original)?;
                    // The program as given, simulated again (its run was
                    // not held through the rounds): the written one is let
                    // go first.
                    drop((run, sample_feeds));
                    let (steps, feeds) = free.with_path(setup, |path| {
                        let samples = crate::motion::machine_motion(path, &setup.machine)?;
                        Ok::<_, crate::error::Error>((
                            crate::motion::steps_from_samples(path, &samples),
                            crate::motion::SampleFeeds::of(&samples, path),
                        ))
                    })??;
                    let run = crate::simulate::run_on(
                        setup.stock_source(),
                        &setup.tools,
                        steps,
                        "as given",
                    )?;
                    (run, feeds)
                }
                _ => (run, sample_feeds),
            };
            return Ok(Written {
                run,
                samples: sample_feeds,
                plan_time_s,
                time_optimal_s,
                lower_bound_time_s,
                cap_shares: shares,
                rounds: round,
                merge_ratio,
                excesses_left: left.len(),
                unresolved,
                kept_original,
            });
        }
        // The run is let go before the stations are made again (their
        // path read again from the program's text).
        drop(run);
        lower_caps(
            &mut caps,
            free.stations(machine, setup)?.s_mm(),
            &blocks,
            &over,
            margin_mm,
            limits.feed_min,
        );
        if refine_blocks {
            merge_ratio = (1.0 + (merge_ratio - 1.0) / 2.5).max(MERGE_RATIO_MIN);
        }
    }
}

/// One tool's chip-load cap (MODEL.md §2.1) against what the program asks
/// of it: summary.json's `limits.chip_load`, one per tool of the job.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ToolChipLoad {
    /// T number (1 for the single `[tool]`).
    pub tool: u32,
    /// Nominal diameter, mm.
    pub diameter_mm: f64,
    pub flutes: u32,
    /// Largest feed per tooth, mm/tooth.
    pub fz_max_mm: f64,
    /// Where `fz_max_mm` comes from, in words (the job's `fz_max`, or the
    /// default for the material and diameter).
    pub fz_max_from: String,
    /// Spindle speed the cap is taken at, rev/min (that of the tool's
    /// fastest cutting step, or of a block without S where it cuts nothing).
    pub spindle_rpm: f64,
    /// Where `spindle_rpm` comes from, in words.
    pub spindle_from: String,
    /// The cap f_z,max · z · n, mm/min.
    pub feed_mm_min: f64,
    /// Highest programmed feed of a step the tool cuts, mm/min; None where it cuts nothing.
    pub programmed_feed_mm_min: Option<f64>,
    /// That feed per tooth at `spindle_rpm`, mm/tooth.
    pub programmed_fz_mm: Option<f64>,
    /// Program line of that step.
    pub line: Option<u32>,
}

/// Every tool's chip-load cap, at the spindle speed of its fastest cutting
/// step in `run` (the program as given); empty without chip-load limits.
pub fn chip_loads(
    run: &Run,
    tools: &ToolSet,
    program: &crate::program::Program,
    material: &str,
) -> Vec<ToolChipLoad> {
    let top = run.top_cutting_step_by_tool(tools);
    tools
        .entries
        .iter()
        .zip(top)
        .filter_map(|(e, top)| {
            let fz_max_mm = e.fz_max_mm?;
            let step = top.map(|i| &run.steps[i]);
            let block_rpm = step.map_or(0.0, |s| s.spindle_rpm);
            let rpm = e.spindle_rpm(block_rpm);
            let fallback = match program.spindle_rpm_for(e.tool.diameter_mm) {
                p if p > 0.0 => format!("taken from the program's highest plausible S{p}"),
                _ => "assumed 10000 rev/min, the default".to_string(),
            };
            let spindle_from = if e.job_rpm.is_some() {
                "[cutting] spindle_rpm".to_string()
            } else if crate::tools::plausible_rpm(e.tool.diameter_mm, block_rpm) {
                format!("S{block_rpm}")
            } else if block_rpm > 0.0 {
                format!(
                    "S{block_rpm} is {:.2} m/min at the edge, not a spindle speed: {fallback}",
                    crate::tools::cutting_speed_m_min(e.tool.diameter_mm, block_rpm)
                )
            } else {
                format!("no S word: {fallback}")
            };
            let feed_mm_min = e.chip_load_feed_mm_min(block_rpm)?;
            let programmed = step.map(|s| s.feed_mm_min);
            Some(ToolChipLoad {
                tool: e.number,
                diameter_mm: e.tool.diameter_mm,
                flutes: e.model.flutes,
                fz_max_mm,
                fz_max_from: if e.fz_max_given {
                    "fz_max".into()
                } else {
                    format!("default for {material}, Ø{} mm", e.tool.diameter_mm)
                },
                spindle_rpm: rpm,
                spindle_from,
                feed_mm_min,
                programmed_feed_mm_min: programmed,
                programmed_fz_mm: programmed.map(|f| f / (f64::from(e.model.flutes) * rpm)),
                line: step.map(|s| s.line),
            })
        })
        .collect()
}

/// Share of the optimised time spent at each kind of cap.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct CapShare {
    /// The cap, in a user's words.
    pub cap: String,
    /// Share of the cycle time, 0…1.
    pub share: f64,
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

/// The free stations of the rounds ([`free_stations_of`]), or, while the
/// written program is verified, the path they are made from alone, or not
/// even that: their arrays (a million-block program's 3 M stations: 143 MB)
/// are let go from the re-feed on and made again when a next round plans,
/// and a G-code program's path is handed to the re-feed and read again from
/// its text where it is needed (126 MB, issue 16).
pub enum FreeStations {
    /// The stations, their caps as made.
    Made(Box<Stations>),
    /// Their path, the stations let go.
    Released(nc::Path),
    /// Neither: the path was handed over ([`FreeStations::give`]); it is the
    /// program's text read again ([`Setup::program_path_again`]).
    Given,
}

impl FreeStations {
    /// The program's path, taken out (read again where it was given),
    /// `self` left [`FreeStations::Given`].
    pub fn give(&mut self, setup: &Setup) -> Result<nc::Path> {
        match std::mem::replace(self, FreeStations::Given) {
            FreeStations::Made(stations) => Ok(stations.into_path()),
            FreeStations::Released(path) => Ok(path),
            FreeStations::Given => setup.program_path_again(),
        }
    }

    /// `f` of the program's path the stations are made from (read again
    /// where it was given, and then held).
    pub fn with_path<T>(&mut self, setup: &Setup, f: impl FnOnce(&nc::Path) -> T) -> Result<T> {
        if let FreeStations::Made(stations) = self {
            return Ok(f(stations.path()));
        }
        let path = self.give(setup)?;
        let out = f(&path);
        *self = FreeStations::Released(path);
        Ok(out)
    }

    /// The stations, made again from the path by `machine` (as
    /// [`free_stations_of`] made them) where they were let go.
    pub fn stations(&mut self, machine: &Machine, setup: &Setup) -> Result<&mut Stations> {
        if !matches!(self, FreeStations::Made(_)) {
            let stations = free_stations_of(self.give(setup)?, machine).map_err(|(e, path)| {
                *self = FreeStations::Released(path);
                e
            })?;
            *self = FreeStations::Made(Box::new(stations));
        }
        match self {
            FreeStations::Made(stations) => Ok(&mut **stations),
            FreeStations::Released(_) | FreeStations::Given => unreachable!("made above"),
        }
    }

    /// Lets the stations' arrays go, keeping their path.
    pub fn release(&mut self) {
        *self = match std::mem::replace(self, FreeStations::Given) {
            FreeStations::Made(stations) => FreeStations::Released(stations.into_path()),
            other => other,
        };
    }

    /// The path, given back (read again where it was given).
    pub fn into_path(mut self, setup: &Setup) -> Result<nc::Path> {
        self.give(setup)
    }
}

/// Stations for re-timing with every feed block free up to feed_max.
pub fn free_stations(path: &nc::Path, machine: &Machine) -> Result<Stations> {
    has_feed_moves(path)?;
    Ok(Stations::new(
        path,
        machine,
        STATION_DS_MM,
        FeedPolicy::MachineMax,
    )?)
}

/// [`free_stations`] on a path handed to the stations rather than copied
/// (a million-block path is about 120 MB; [`Stations::into_path`] gives it
/// back); on an error the path comes back with it.
pub fn free_stations_of(
    path: nc::Path,
    machine: &Machine,
) -> std::result::Result<Stations, (crate::error::Error, nc::Path)> {
    if let Err(e) = has_feed_moves(&path) {
        return Err((e, path));
    }
    Stations::from_path(path, machine, STATION_DS_MM, FeedPolicy::MachineMax)
        .map_err(|(e, path)| (e.into(), path))
}

fn has_feed_moves(path: &nc::Path) -> Result<()> {
    if path
        .segments
        .iter()
        .all(|s| !matches!(s.motion, Motion::Feed { .. }))
    {
        fail!(run, "the program has no feed moves to optimise");
    }
    Ok(())
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
