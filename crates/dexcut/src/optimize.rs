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
    let tool_index = interval_tools(stations, tools)?;
    let n = tool_index.len();
    let (mut area_mm2, mut reference_loads) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let swept = sweep_engagement(
        stations,
        stock,
        tools,
        &tool_index,
        surface,
        &mut |_, a, l| {
            area_mm2.push(a);
            reference_loads.push(l);
        },
    )?;
    let surface_angle_deg = surface_angles_deg(
        stations,
        swept.as_ref(),
        stock.grid().spacing_mm,
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

/// The caps [`interval_caps`] gives for [`engagement_on`]'s engagement,
/// made as the sweep makes each interval's engagement final: neither the
/// sweep's record nor the reference loads are held (about 74 and 32 B an
/// interval, issue 16), only the caps, and the windowed areas where S3 takes
/// its angles (after the sweep, from them). The same caps bit for bit.
pub fn engagement_caps_on(
    stations: &Stations,
    stock: &StockSource,
    tools: &ToolSet,
    limits: &LimitsSpec,
    surface: SurfaceFrom,
) -> Result<Vec<(f64, CapKind)>> {
    let tool_index = interval_tools(stations, tools)?;
    let n = tool_index.len();
    // S3's angles need every interval's area once the sweep is done.
    let angles = !matches!(surface, SurfaceFrom::Nothing);
    let mut caps = Vec::with_capacity(n);
    let mut area_mm2 = Vec::with_capacity(if angles { n } else { 0 });
    let swept = sweep_engagement(
        stations,
        stock,
        tools,
        &tool_index,
        surface,
        &mut |k, a, l| {
            let cap = limit_cap(k, a, &l, tool_index[k], stations, limits, tools);
            caps.push(if angles {
                area_mm2.push(a);
                cap
            } else {
                angle_and_floor(cap, k, a, f64::NAN, stations, limits)
            });
        },
    )?;
    if angles {
        let theta = surface_angles_deg(
            stations,
            swept.as_ref(),
            stock.grid().spacing_mm,
            tools,
            &tool_index,
            &area_mm2,
            surface,
        );
        for (k, cap) in caps.iter_mut().enumerate() {
            *cap = angle_and_floor(*cap, k, area_mm2[k], theta[k], stations, limits);
        }
    }
    Ok(caps)
}

/// Per interval k (station k → k + 1), the index into the tool set of the
/// tool cutting it (2 B an interval, issue 16).
fn interval_tools(stations: &Stations, tools: &ToolSet) -> Result<Vec<u16>> {
    let segs = stations.segments();
    tools.indices(stations.segment().iter().skip(1).map(|&s| {
        let seg = &segs[s as usize];
        (seg.tool, seg.line)
    }))
}

/// The engagement sweep along the stations: each interval's windowed area
/// and reference load given to `each(k, area, load)`, interval after
/// interval, as the sweep makes its rows final ([`EngagementRows`]; the
/// record is not held, issue 16). Gives the swept stock where S3 takes its
/// angles from its surface.
fn sweep_engagement(
    stations: &Stations,
    stock: &StockSource,
    tools: &ToolSet,
    tool_index: &[u16],
    surface: SurfaceFrom,
    each: &mut dyn FnMut(usize, f64, ReferenceLoad),
) -> Result<Option<Stock>> {
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
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    let dexel_tools = tools.tools();
    let sweep = dexel::Sweep::new(&dexel_tools, tool_index, &steps, &options)?;
    let spacing_mm = stock.grid().spacing_mm;
    let window_mm = (ENGAGEMENT_WINDOW_CELLS * spacing_mm).max(2.0 * STATION_DS_MM);
    let mut rows = EngagementRows {
        area: WindowedArea::new(stations.s_mm(), window_mm),
        loads: ReferenceLoads::new(stations.s_mm(), sweep.n_bands(), |k| {
            &tools.entries[usize::from(tool_index[k])].model
        }),
        each,
    };
    let (swept, _) = crate::simulate::sweep_through(
        &stock.initial(),
        None,
        sweep,
        "engagement",
        Some(&mut |k, row| rows.row(k, row)),
    )?;
    rows.finish();
    // The swept stock only where S3 takes its angles from its surface.
    Ok(swept.filter(|_| matches!(surface, SurfaceFrom::Stock)))
}

/// The engagement sweep's sink: each interval's row as the sweep makes it
/// final, in order; each interval's windowed area and reference load given
/// to `each` once the rows they read are in (two half windows ahead).
struct EngagementRows<'a, 'e, M> {
    area: WindowedArea<'a>,
    loads: ReferenceLoads<'a, M>,
    each: &'e mut dyn FnMut(usize, f64, ReferenceLoad),
}

impl<'a, M: Fn(usize) -> &'a CuttingModel> EngagementRows<'a, '_, M> {
    fn row(&mut self, k: usize, row: dexel::RecordRow<'_>) {
        let (loads, each) = (&mut self.loads, &mut *self.each);
        loads.row(k, row);
        self.area
            .push(row.volume_mm3(), &mut |j, a| each(j, a, loads.load(j, a)));
    }

    fn finish(self) {
        let (mut loads, each) = (self.loads, self.each);
        self.area.finish(&mut |j, a| each(j, a, loads.load(j, a)));
    }
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
/// first that did); made interval after interval as the sweep's rows and
/// the windowed areas come, holding only the rows of the cutting intervals
/// that a load not yet made may take its shape from (not the record, issue
/// 16).
struct ReferenceLoads<'a, M> {
    s_mm: &'a [f64],
    /// The tool's model of interval k.
    model_of: M,
    /// Cutting intervals' rows, oldest first: the first is the last cut at
    /// or before the next load to make (else the first cut of all).
    sources: std::collections::VecDeque<Source>,
    /// Their bands, `n_bands` each (zero above a row's own).
    bands: std::collections::VecDeque<f64>,
    n_bands: usize,
    /// One load's bands.
    scaled: Vec<f64>,
}

/// What a reference load takes of a cutting interval's row.
struct Source {
    k: usize,
    volume_mm3: f64,
    contact: [f64; 2],
    chip_edge_area_mm2: f64,
    volume_over_radius_mm2: f64,
    /// Bands up to the highest not zero.
    bands: usize,
}

impl<'a, M: Fn(usize) -> &'a CuttingModel> ReferenceLoads<'a, M> {
    /// Loads along stations at `s_mm`, each band list `n_bands` long (the
    /// record's: that of the tool with the most).
    fn new(s_mm: &'a [f64], n_bands: usize, model_of: M) -> Self {
        ReferenceLoads {
            s_mm,
            model_of,
            sources: Default::default(),
            bands: Default::default(),
            n_bands,
            scaled: vec![0.0; n_bands],
        }
    }

    /// Interval k's row, before its area.
    fn row(&mut self, k: usize, row: dexel::RecordRow<'_>) {
        if row.volume_mm3() > 0.0 {
            let bands = row.band_volumes_mm3();
            self.sources.push_back(Source {
                k,
                volume_mm3: row.volume_mm3(),
                contact: row.contact_resultant(),
                chip_edge_area_mm2: row.chip_edge_area_mm2(),
                volume_over_radius_mm2: row.volume_over_radius_mm2(),
                bands: bands.len(),
            });
            self.bands.extend(bands);
            self.bands
                .extend(std::iter::repeat_n(0.0, self.n_bands - bands.len()));
        }
    }

    /// Interval k's load, given its windowed area (intervals in order, each
    /// after its row). An area above zero is a mean of volumes in whose
    /// rows one cut at least, so its first cut is among the rows in.
    fn load(&mut self, k: usize, area_mm2: f64) -> ReferenceLoad {
        // The last cut at or before k (the rows before it are not taken again).
        while self.sources.get(1).is_some_and(|s| s.k <= k) {
            self.sources.pop_front();
            self.bands.drain(..self.n_bands);
        }
        debug_assert!(!(area_mm2 > 0.0 && self.sources.is_empty()), "interval {k}");
        let load = match self.sources.front() {
            Some(j) if area_mm2 > 0.0 => {
                let s_mm = self.s_mm;
                let len_mm = s_mm[k + 1] - s_mm[k];
                let volume = area_mm2 * len_mm;
                let scale = volume / j.volume_mm3;
                // The record keeps a step's bands up to its highest nonzero one.
                self.scaled.fill(0.0);
                for (b, v) in self.scaled.iter_mut().zip(self.bands.range(..j.bands)) {
                    *b = v * scale;
                }
                let [cx, cy] = j.contact;
                (self.model_of)(k).step_load(&cutting::StepRemoval {
                    volume_mm3: volume,
                    band_volumes_mm3: &self.scaled,
                    contact_resultant: [cx * scale, cy * scale],
                    // The chip edge area is per step: for the interval's own length, scaled
                    // by the ratio of lengths (thickness per mm of path is what is kept).
                    chip_edge_area_mm2: j.chip_edge_area_mm2 * scale * (s_mm[j.k + 1] - s_mm[j.k])
                        / len_mm,
                    volume_over_radius_mm2: j.volume_over_radius_mm2 * scale,
                    dt_s: len_mm * 60.0 / REFERENCE_FEED_MM_MIN,
                })
            }
            _ => cutting::StepLoad::default(),
        };
        load.into()
    }
}

/// Engagement is averaged over this many grid cells of path: a dexel grid
/// resolves removal per unit length only to about one column, so finer
/// station intervals see the column phase, not the cut.
pub const ENGAGEMENT_WINDOW_CELLS: f64 = 2.0;

/// Removed volume per unit length at each interval: the mean over a window of
/// `window_mm` centred on it, then the largest such mean within ±window/2, so
/// a cap is in force from one window before a rise in engagement.
pub fn windowed_area(s_mm: &[f64], volumes_mm3: &[f64], window_mm: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(volumes_mm3.len());
    let mut area = WindowedArea::new(&s_mm[..=volumes_mm3.len()], window_mm);
    for &v in volumes_mm3 {
        area.push(v, &mut |_, a| out.push(a));
    }
    area.finish(&mut |_, a| out.push(a));
    out
}

/// [`windowed_area`] made as the volumes come, interval after interval:
/// interval k's area is given once the volumes up to about a window beyond
/// it are in, and only the volumes and means of the intervals between are
/// held (not every interval's, issue 16). Each value is made by the same
/// operations on the same values as over whole lists.
struct WindowedArea<'s> {
    s_mm: &'s [f64],
    /// Intervals.
    n: usize,
    half: f64,
    /// Volumes in, from interval `base` on, and the cumulative volume at
    /// each one's start.
    base: usize,
    volumes: std::collections::VecDeque<f64>,
    cum: std::collections::VecDeque<f64>,
    /// Cumulative volume at the end of the last volume in.
    total: f64,
    /// Forward cursors of the windows' lower and upper ends.
    lo: usize,
    hi: usize,
    /// Mean over the window of intervals `mean_base ..` (those made).
    mean_base: usize,
    means: std::collections::VecDeque<f64>,
    /// Sliding maximum: next interval to enter the monotone deque, the
    /// deque, next interval to give.
    next: usize,
    deque: std::collections::VecDeque<usize>,
    k: usize,
}

impl<'s> WindowedArea<'s> {
    /// Areas of the intervals between the stations at `s_mm`.
    fn new(s_mm: &'s [f64], window_mm: f64) -> Self {
        WindowedArea {
            s_mm,
            n: s_mm.len().saturating_sub(1),
            half: 0.5 * window_mm,
            base: 0,
            volumes: Default::default(),
            cum: Default::default(),
            total: 0.0,
            lo: 0,
            hi: 0,
            mean_base: 0,
            means: Default::default(),
            next: 0,
            deque: Default::default(),
            k: 0,
        }
    }

    fn mid(&self, k: usize) -> f64 {
        0.5 * (self.s_mm[k] + self.s_mm[k + 1])
    }

    /// The next interval's volume; `out(k, area)` for each interval whose
    /// area it completes, in order.
    fn push(&mut self, volume_mm3: f64, out: &mut dyn FnMut(usize, f64)) {
        self.cum.push_back(self.total);
        self.volumes.push_back(volume_mm3);
        self.total += volume_mm3;
        self.make(out);
    }

    /// Every volume in: the areas not given yet.
    fn finish(mut self, out: &mut dyn FnMut(usize, f64)) {
        self.make(out);
        assert_eq!(
            self.k,
            self.n,
            "{} volumes for {} intervals",
            self.base + self.volumes.len(),
            self.n
        );
    }

    /// Cumulative volume at arc length x (linear inside an interval) by the
    /// cursor `upper` or not; None until the interval it lies in is in.
    fn cum_at(&mut self, x: f64, upper: bool) -> Option<f64> {
        let (s, n) = (self.s_mm, self.n);
        let x = x.clamp(s[0], s[n]);
        let i = if upper { &mut self.hi } else { &mut self.lo };
        while *i + 1 < n && s[*i + 1] < x {
            *i += 1;
        }
        let i = *i;
        let at = i
            .checked_sub(self.base)
            .filter(|&j| j < self.volumes.len())?;
        let (a, b) = (s[i], s[i + 1]);
        let f = if b > a {
            ((x - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        Some(self.cum[at] + f * self.volumes[at])
    }

    fn make(&mut self, out: &mut dyn FnMut(usize, f64)) {
        let (n, half) = (self.n, self.half);
        if n == 0 {
            return;
        }
        let (s_first, s_last) = (self.s_mm[0], self.s_mm[n]);
        // Each interval's mean over the window centred on it.
        while self.mean_base + self.means.len() < n {
            let k = self.mean_base + self.means.len();
            let mid = self.mid(k);
            let (a, b) = ((mid - half).max(s_first), (mid + half).min(s_last));
            let mean = if b > a {
                let Some(upper) = self.cum_at(b, true) else {
                    break;
                };
                let lower = self
                    .cum_at(a, false)
                    .expect("the lower end is in before the upper");
                (upper - lower) / (b - a)
            } else {
                0.0
            };
            self.means.push_back(mean);
            // No window reads an interval before the lower cursor again.
            while self.base < self.lo {
                self.base += 1;
                self.volumes.pop_front();
                self.cum.pop_front();
            }
        }
        // Sliding maximum over ±half (monotone deque).
        let mean = |w: &Self, j: usize| w.means.get(j - w.mean_base).copied();
        while self.k < n {
            let mid = self.mid(self.k);
            while self.next < n && self.mid(self.next) <= mid + half {
                let Some(m) = mean(self, self.next) else {
                    return;
                };
                while self
                    .deque
                    .back()
                    .is_some_and(|&b| mean(self, b).expect("held") <= m)
                {
                    self.deque.pop_back();
                }
                self.deque.push_back(self.next);
                self.next += 1;
            }
            while self
                .deque
                .front()
                .is_some_and(|&f| self.mid(f) < mid - half)
            {
                self.deque.pop_front();
            }
            let j = self.deque.front().copied().unwrap_or(self.k);
            out(self.k, mean(self, j).expect("made"));
            self.k += 1;
            // Means before the deque's and the next interval's are not read again.
            let keep = self.deque.front().map_or(self.k, |&f| f.min(self.k));
            while self.mean_base < keep {
                self.mean_base += 1;
                self.means.pop_front();
            }
        }
    }
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
fn limit_cap(
    k: usize,
    a: f64,
    at_ref: &ReferenceLoad,
    tool: u16,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
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
    }
    cap
}

/// Interval k's cap `cap` ([`limit_cap`]) lowered by S3's angle rule where
/// it cuts (`a` its windowed area, `theta_deg` its surface angle, NaN for
/// none), then raised to `feed_min`.
fn angle_and_floor(
    mut cap: (f64, CapKind),
    k: usize,
    a: f64,
    theta_deg: f64,
    stations: &Stations,
    limits: &LimitsSpec,
) -> (f64, CapKind) {
    // S3 (MODEL.md §6.3): θ between the surface normal at the contact and the
    // tool axis, applied to the programmed (set) feed.
    if a > 1e-12 {
        let seg = &stations.segments()[stations.segment()[k + 1] as usize];
        if let (true, Some(v0), false, Motion::Feed { feed_mm_min, .. }) =
            (limits.angle_rule, limits.v0, theta_deg.is_nan(), seg.motion)
        {
            let v = schedule::angle_rule_feed_mm_min(theta_deg, feed_mm_min, v0);
            if v < cap.0 {
                cap = (v, CapKind::SurfaceAngle);
            }
        }
    }
    if let Some(lo) = limits.feed_min {
        cap.0 = cap.0.max(lo);
    }
    cap
}

/// Apply interval caps to both end stations of each interval, so the speed
/// (v² linear between stations) respects the cap over the whole interval.
pub fn apply_interval_caps(stations: &mut Stations, caps: &[(f64, CapKind)]) -> Result<()> {
    apply_interval_caps_from(stations, 0, caps)
}

/// [`apply_interval_caps`] with `caps` those of the intervals from `first` on.
fn apply_interval_caps_from(
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
        // A held feed (tapping) is written as programmed, in one piece.
        if let Some(feed) = segs[seg].motion.held_feed_mm_min() {
            plan[seg].push((1.0, feed));
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
        if let (Motion::Feed { feed_mm_min, .. }, true) = (seg.motion, pieces.is_empty()) {
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
    /// The period runs on a feed held as programmed (G84/G74 tapping): its
    /// cap is infinite, nothing is slowed, and it is told apart.
    pub held: bool,
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
                    limits.stress.then_some(run.stress_limit_mpa_at(k)),
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

/// Where the written program's blocks begin among the intervals (station k
/// → k + 1): each interval that lies in another block (refeed plan piece)
/// than the interval before it, ascending. 4 B a block, not a block index an
/// interval (4 B an interval, 12 MB for 3 M free stations, held through a
/// round's re-feed and verification: issue 16).
#[derive(Clone, Debug, PartialEq)]
pub struct Blocks {
    starts: Vec<u32>,
    intervals: usize,
}

impl Blocks {
    /// The blocks of the stations' intervals under the refeed plan `plan`:
    /// an interval lies in the piece of its end station's segment whose end
    /// fraction is at or past the station's (the first piece if none is).
    pub fn of(stations: &Stations, plan: &[Vec<(f64, f64)>]) -> Blocks {
        let (seg_of, frac) = (stations.segment(), stations.fraction());
        Blocks::where_they_change((1..stations.len()).map(|k| {
            let seg = seg_of[k] as usize;
            let f = frac[k];
            (
                seg,
                plan[seg].iter().position(|p| p.0 >= f - 1e-9).unwrap_or(0),
            )
        }))
    }

    /// The blocks of intervals whose blocks are `blocks`, in order: one
    /// begins wherever an interval's differs from the one before's.
    fn where_they_change<T: PartialEq>(blocks: impl Iterator<Item = T>) -> Blocks {
        let mut starts = Vec::new();
        let mut before: Option<T> = None;
        let mut intervals = 0;
        for block in blocks {
            if before.as_ref().is_some_and(|b| *b != block) {
                starts.push(u32::try_from(intervals).expect("fewer than 2^32 intervals"));
            }
            before = Some(block);
            intervals += 1;
        }
        Blocks { starts, intervals }
    }

    /// The first and last interval of the block interval `k` lies in.
    pub fn around(&self, k: usize) -> (usize, usize) {
        let next = self.starts.partition_point(|&s| s as usize <= k);
        let first = next.checked_sub(1).map_or(0, |i| self.starts[i] as usize);
        let last = self
            .starts
            .get(next)
            .map_or(self.intervals.saturating_sub(1), |&s| s as usize - 1);
        (first, last)
    }
}

/// Apply to each interval the feed of the block (refeed plan piece) it lies
/// in, with the kind of cap that set the interval ([`apply_interval_caps`]),
/// a chunk of intervals at a time: not a list of every interval's (16 B an
/// interval beside the plan, issue 16). The same caps applied in the same
/// order.
pub fn apply_block_caps(
    stations: &mut Stations,
    plan: &[Vec<(f64, f64)>],
    caps: &[(f64, CapKind)],
) -> Result<()> {
    const CHUNK: usize = 1 << 16;
    let mut chunk = Vec::with_capacity(CHUNK.min(caps.len()));
    for first in (0..caps.len()).step_by(CHUNK) {
        let (seg_of, frac) = (stations.segment(), stations.fraction());
        chunk.clear();
        chunk.extend((first..caps.len().min(first + CHUNK)).map(|k| {
            let pieces = &plan[seg_of[k + 1] as usize];
            let f = frac[k + 1];
            match pieces.iter().find(|p| p.0 >= f - 1e-9) {
                Some(&(_, feed)) => (feed, caps[k].1),
                None => caps[k],
            }
        }));
        apply_interval_caps_from(stations, first, &chunk)?;
    }
    Ok(())
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
        let limit = run.stress_limit_mpa_at(k);
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
                // Only its time is kept: the profile (32 B a station) is let
                // go before the bound and the refeed plan are made.
                let time_optimal_s = schedule::plan(stations).cycle_time_s();
                let lower_bound_time_s = schedule::lower_bound_time_s(stations);
                let plan = refeed_plan(stations, &caps, machine, merge_ratio);
                Ok::<_, crate::error::Error>((plan, time_optimal_s, lower_bound_time_s))
            })?;
        // The plan as written: every interval at its block's feed.
        let as_written = |blocks: &mut Stations| {
            apply_block_caps(blocks, &plan, &caps)?;
            let profile = schedule::plan(blocks);
            Ok::<_, crate::error::Error>((profile.cycle_time_s(), cap_shares(&profile)))
        };
        // A G-code program's stations are let go after it (below) without
        // their caps put back (no copy of them, 9 B a station, issue 16); a
        // point list's optimum is planned on them again.
        let (plan_time_s, shares) = match setup.program.gcode {
            Some(_) => as_written(stations)?,
            None => stations.with_caps_restored(as_written)?,
        };
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
        // What a next round needs of the refeed plan is where its blocks
        // begin among the intervals: kept instead of the plan (a million segments' pieces, one
        // `Vec` each, 40 MB), which is dropped before the sweep.
        let blocks = Blocks::of(stations, &plan);
        // Nor are the caps read again before the verification's excesses
        // lower them for a next round: held as two columns meanwhile (9 B an
        // interval, not 16: 27 MB for 3 M free stations, not 48), made again
        // as they were where a next round needs them.
        let (cap_feeds, cap_kinds): (Vec<f64>, Vec<CapKind>) =
            std::mem::take(&mut caps).into_iter().unzip();
        crate::heap_mark(format_args!("round {round}: plans"));
        // Nor are the stations' arrays needed while the program is written,
        // read back and verified (3 M stations: 143 MB beside the re-feed's
        // readings and the run): only their path is kept, and a next round
        // makes them again (the same stations, their caps as made).
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
                crate::heap_mark(format_args!("round {round}: re-feed"));
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
        crate::heap_mark(format_args!("round {round}: servo samples and steps"));
        let run = crate::simulate::run_on(
            setup.stock_source(),
            &setup.tools,
            steps,
            &format!("verify {round}"),
        )?;
        crate::heap_mark(format_args!("round {round}: verification run"));
        let over = excesses(&run, limits, &setup.tools);
        crate::heap_mark(format_args!("round {round}: excesses"));
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
        caps = cap_feeds.into_iter().zip(cap_kinds).collect();
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

    /// [`windowed_area`] over whole lists as it was before the areas were
    /// made as the volumes come (the oracle of the tests below).
    fn windowed_area_of_lists(s_mm: &[f64], volumes_mm3: &[f64], window_mm: f64) -> Vec<f64> {
        let n = volumes_mm3.len();
        let mut cum = Vec::with_capacity(n + 1);
        cum.push(0.0);
        for v in volumes_mm3 {
            cum.push(cum[cum.len() - 1] + v);
        }
        let half = 0.5 * window_mm;
        let (s_first, s_last) = (s_mm[0], s_mm[n]);
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

    /// The reference loads from the record held whole, as they were made
    /// before the sweep gave its rows to them (the oracle).
    fn reference_loads_of_record<'a>(
        record: &dexel::RemovalRecord,
        area_mm2: &[f64],
        s_mm: &[f64],
        model_of: impl Fn(usize) -> &'a CuttingModel,
    ) -> Vec<ReferenceLoad> {
        let n = area_mm2.len();
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
                bands.fill(0.0);
                for (b, v) in bands.iter_mut().zip(record.band_volumes_mm3(j)) {
                    *b = v * scale;
                }
                let [cx, cy] = record.contact_resultant(j);
                let load = model_of(k).step_load(&cutting::StepRemoval {
                    volume_mm3: volume,
                    band_volumes_mm3: &bands,
                    contact_resultant: [cx * scale, cy * scale],
                    chip_edge_area_mm2: record.chip_edge_area_mm2(j)
                        * scale
                        * (s_mm[j + 1] - s_mm[j])
                        / len_mm,
                    volume_over_radius_mm2: record.volume_over_radius_mm2(j) * scale,
                    dt_s: len_mm * 60.0 / REFERENCE_FEED_MM_MIN,
                });
                ReferenceLoad::from(load)
            })
            .collect()
    }

    /// The caps as [`interval_caps`] made them in one piece (the oracle).
    fn caps_in_one_piece(
        engagement: &Engagement,
        stations: &Stations,
        limits: &LimitsSpec,
        tools: &ToolSet,
    ) -> Vec<(f64, CapKind)> {
        let (segs, seg_of) = (stations.segments(), stations.segment());
        (0..engagement.area_mm2.len())
            .map(|k| {
                let a = engagement.area_mm2[k];
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
                    if let (Some(scale), Motion::Feed { feed_mm_min, .. }) =
                        (limits.feed_scale_max, seg.motion)
                    {
                        lower(scale * feed_mm_min, CapKind::FeedScale);
                    }
                    if let Some(q) = limits.mrr_max {
                        lower(60.0 * q / a, CapKind::Removal);
                    }
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
                    if limits.stress {
                        lower(
                            cap(at_ref.stress_mpa, entry.stress_limit_mpa),
                            CapKind::Stress,
                        );
                    }
                    let theta_deg = engagement.surface_angle_deg[k];
                    if let (true, Some(v0), false, Motion::Feed { feed_mm_min, .. }) =
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

    /// Each interval's block from where the blocks begin is the run of equal
    /// block indices around it in the list of every interval's (walked as
    /// [`lower_caps`] walked that list): blocks of one interval and of many,
    /// at both ends, a block index that comes back after another.
    /// The first and last index of the run of equal entries of `list` that
    /// holds index `k`: the oracle of [`Blocks::around`].
    fn run_around<T: PartialEq>(list: &[T], k: usize) -> (usize, usize) {
        let (mut from, mut to) = (k, k);
        while from > 0 && list[from - 1] == list[from] {
            from -= 1;
        }
        while to + 1 < list.len() && list[to + 1] == list[to] {
            to += 1;
        }
        (from, to)
    }

    #[test]
    fn blocks_from_where_they_begin_are_the_runs_of_the_list() {
        let lists: [&[u32]; 5] = [
            &[0],
            &[3, 3, 3],
            &[0, 1, 1, 2, 2, 2, 3, 4, 4],
            &[0, 0, 1, 0, 0, 7, 7],
            &[5, 6, 7, 8],
        ];
        for list in lists {
            let blocks = Blocks::where_they_change(list.iter());
            assert_eq!(blocks.intervals, list.len());
            for k in 0..list.len() {
                assert_eq!(blocks.around(k), run_around(list, k), "{list:?} at {k}");
            }
        }
    }

    /// Per interval, the block of the written program it lies in, as
    /// `interval_blocks` made it before the blocks were held as where they
    /// begin (the oracle of the test below).
    fn interval_blocks_listed(stations: &Stations, plan: &[Vec<(f64, f64)>]) -> Vec<u32> {
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
                u32::try_from(first_piece[seg] + piece).unwrap()
            })
            .collect()
    }

    /// The blocks of a program's free stations under its refeed plans (at
    /// the merge ratios the rounds use, and 1: one block per cap change)
    /// are, around every interval, the runs of equal block indices of the
    /// list every interval's block was held in before (which
    /// [`lower_caps`] widens a sub-cell removal excess to).
    #[test]
    fn blocks_of_a_refeed_plan_are_those_of_the_list() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("job.toml"),
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n\
             [tool]\nkind = \"ball\"\ndiameter = 6\n\
             [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\n\
             [machine]\nfeed_max = 3000\naccel = [1000, 1000, 1000]\n\
             [limits]\nmrr_max = 40\nforce_max = 150\nfeed_min = 30\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("p.ngc"),
            "G21 G90 G17\nS9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z19 F1200\nG1 X30 Y20 Z18.5\n\
             G2 X40 Y30 I10 J0 F900\nG0 Z25\nG0 X10 Y30\nG1 Z17 F300\nG1 X50 Y32 F1500\n\
             G1 X52 F1500\nG1 X12 Y10 Z18.8 F1000\nG0 Z25\nM2\n",
        )
        .unwrap();
        let setup = Setup::load(&dir.path().join("job.toml"), None).unwrap();
        let limits = &setup.job.limits;
        let machine = optimising_machine(&setup.machine, limits);
        let stations = free_stations(&setup.program.path, &machine).unwrap();
        let caps = engagement_caps_on(
            &stations,
            &setup.stock_source(),
            &setup.tools,
            limits,
            SurfaceFrom::Nothing,
        )
        .unwrap();
        for merge_ratio in [1.0, MERGE_RATIO_MIN, MERGE_RATIO] {
            let plan = refeed_plan(&stations, &caps, &machine, merge_ratio);
            let list = interval_blocks_listed(&stations, &plan);
            let blocks = Blocks::of(&stations, &plan);
            assert_eq!(blocks.intervals, list.len());
            // Blocks of one interval and of many: the plan splits segments.
            assert!(blocks.starts.len() > plan.iter().filter(|p| !p.is_empty()).count());
            for k in 0..list.len() {
                assert_eq!(
                    blocks.around(k),
                    run_around(&list, k),
                    "ratio {merge_ratio} at {k}"
                );
            }
        }
    }

    /// Areas made as the volumes come equal those of whole lists, bit for
    /// bit: stations of uneven spacing with repeated ones (zero-length
    /// intervals), windows from under one interval to many, volumes of
    /// every size, zero and NaN.
    #[test]
    fn windowed_areas_as_the_volumes_come_are_those_of_whole_lists() {
        let mut s = vec![0.0];
        for i in 0..400u32 {
            let ds = match i % 7 {
                0 => 0.0,
                3 => 0.013,
                5 => 0.21,
                _ => 0.05,
            };
            s.push(s[s.len() - 1] + ds);
        }
        let v: Vec<f64> = (0..400u32)
            .map(|i| match i % 11 {
                0..=2 => 0.0,
                4 if i == 202 => f64::NAN,
                _ => f64::from(i * 37 % 19) * 0.3 + 1e-3 * f64::from(i),
            })
            .collect();
        for window in [0.01, 0.1, 0.2, 0.37, 2.0, 50.0] {
            for n in [0, 1, 2, 5, 400] {
                let (s, v) = (&s[..=n], &v[..n]);
                let bits = |a: Vec<f64>| a.into_iter().map(f64::to_bits).collect::<Vec<_>>();
                assert_eq!(
                    bits(windowed_area(s, v, window)),
                    bits(windowed_area_of_lists(s, v, window)),
                    "window {window}, {n} intervals"
                );
            }
        }
    }

    /// The engagement and caps made as the sweep gives its rows (no record
    /// held) equal those made from the record held whole (the computation
    /// before, kept above), bit for bit: three tools of 24, 16 and 12 bands,
    /// rapids, plunges, an arc, air before the first cut (intervals there
    /// take the first cut's shape), every limit and S3's angles from the
    /// swept stock; and on the same stock held in bands (its rows given
    /// once the record is finished).
    #[test]
    fn engagement_from_the_sweeps_rows_is_the_records() {
        let dir = tempfile::tempdir().unwrap();
        let tool = |n: u32, kind: &str, d: f64| {
            format!("[[tools]]\nnumber = {n}\nkind = \"{kind}\"\ndiameter = {d}\n")
        };
        let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n\
             {}{}corner_radius = 1\n{}\
             [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\nband_height = 0.5\n\
             [machine]\nfeed_max = 3000\naccel = [1000, 1000, 1000]\n\
             [limits]\nmrr_max = 40\nforce_max = 150\ndeflection_max_um = 20\npower_max_kw = 0.4\n\
             feed_min = 30\nfeed_scale_max = 1.5\nangle_rule = true\nv0 = 300\n",
            tool(1, "ball", 6.0),
            tool(2, "bull", 4.0),
            tool(3, "flat", 3.0),
        );
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        std::fs::write(
            dir.path().join("p.ngc"),
            "G21 G90 G17\nT1 M6 S9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z19 F1200\nG1 X30 Y20 Z18.5\n\
             G2 X40 Y30 I10 J0 F900\nG0 Z25\nG0 X10 Y30\nG1 Z17 F300\nG1 X50 Y32 F1500\n\
             T2 M6 S12000 M3\nG0 Z25\nG0 X50 Y8\nG1 Z18 F200\nG1 X12 Y10 Z18.8 F1000\nG0 Z25\n\
             T3 M6 S15000 M3\nG0 X20 Y15\nG1 Z19 F250\nG1 X35 F800\nG1 Y35 Z18.5\nG0 Z25\nM2\n",
        )
        .unwrap();
        for budget_mb in [None, Some(1.0)] {
            let setup =
                Setup::load_within(&dir.path().join("job.toml"), None, None, budget_mb).unwrap();
            assert_eq!(setup.tiling.is_some(), budget_mb.is_some());
            let limits = &setup.job.limits;
            let machine = optimising_machine(&setup.machine, limits);
            let stations = free_stations(&setup.program.path, &machine).unwrap();
            let stock = setup.stock_source();
            // A tiled stock takes no angles from its surface.
            let surface = match stock {
                StockSource::Tiled(_) => SurfaceFrom::Nothing,
                _ => SurfaceFrom::Stock,
            };
            let tools = &setup.tools;
            let engagement = engagement_on(&stations, &stock, tools, surface).unwrap();
            // The record held whole, and what was made of it.
            let options = SweepOptions {
                band_height_mm: tools.entries[0].model.band_height_mm,
                ..SweepOptions::default()
            };
            let (segs, seg_of) = (stations.segments(), stations.segment());
            let steps: Vec<dexel::Step> = (1..stations.len())
                .map(|k| dexel::Step {
                    from_mm: stations.position_at(k - 1).coords.into(),
                    to_mm: stations.position_at(k).coords.into(),
                    rapid: matches!(segs[seg_of[k] as usize].motion, Motion::Rapid),
                })
                .collect();
            let (swept, record) = crate::simulate::sweep_pass(
                &stock.initial(),
                None,
                tools,
                &engagement.tool_index,
                &steps,
                &options,
                "engagement",
            )
            .unwrap();
            let n = record.len();
            let volumes: Vec<f64> = (0..n).map(|k| record.volume_mm3(k)).collect();
            let window_mm =
                (ENGAGEMENT_WINDOW_CELLS * stock.grid().spacing_mm).max(2.0 * STATION_DS_MM);
            let area_mm2 = windowed_area_of_lists(stations.s_mm(), &volumes, window_mm);
            let reference_loads =
                reference_loads_of_record(&record, &area_mm2, stations.s_mm(), |k| {
                    &tools.entries[usize::from(engagement.tool_index[k])].model
                });
            let swept = swept.filter(|_| matches!(surface, SurfaceFrom::Stock));
            let surface_angle_deg = surface_angles_deg(
                &stations,
                swept.as_ref(),
                stock.grid().spacing_mm,
                tools,
                &engagement.tool_index,
                &area_mm2,
                surface,
            );
            let held = Engagement {
                area_mm2,
                reference_loads,
                tool_index: engagement.tool_index.clone(),
                surface_angle_deg,
            };
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let load_bits = |l: &[ReferenceLoad]| {
                l.iter()
                    .flat_map(|r| [r.force_n, r.deflection_um, r.power_w, r.stress_mpa])
                    .map(f64::to_bits)
                    .collect::<Vec<_>>()
            };
            let cap_bits = |c: &[(f64, CapKind)]| {
                c.iter()
                    .map(|&(v, kind)| (v.to_bits(), kind))
                    .collect::<Vec<_>>()
            };
            let what = format!("memory budget {budget_mb:?}");
            assert_eq!(bits(&engagement.area_mm2), bits(&held.area_mm2), "{what}");
            assert_eq!(
                load_bits(&engagement.reference_loads),
                load_bits(&held.reference_loads),
                "{what}"
            );
            assert_eq!(
                bits(&engagement.surface_angle_deg),
                bits(&held.surface_angle_deg),
                "{what}"
            );
            let caps = caps_in_one_piece(&held, &stations, limits, tools);
            assert_eq!(
                cap_bits(&interval_caps(&engagement, &stations, limits, tools)),
                cap_bits(&caps),
                "{what}"
            );
            assert_eq!(
                cap_bits(&engagement_caps_on(&stations, &stock, tools, limits, surface).unwrap()),
                cap_bits(&caps),
                "{what}"
            );
            // What the comparison covers: every tool cuts, with its own
            // band count; intervals before the first cut take its shape;
            // the limits and S3 each set caps.
            assert_eq!(tools.entries.len(), 3);
            for t in 0..3u16 {
                assert!(
                    (0..n).any(|k| held.tool_index[k] == t && record.volume_mm3(k) > 0.0),
                    "tool {t} cuts ({what})"
                );
            }
            assert_eq!(record.n_bands, 24);
            let first_cut = (0..n).position(|k| record.volume_mm3(k) > 0.0).unwrap();
            assert!(held.area_mm2[first_cut - 1] > 0.0, "{what}");
            assert!(held.reference_loads[first_cut - 1].force_n > 0.0, "{what}");
            assert!(steps.iter().any(|s| s.rapid));
            assert!(steps
                .iter()
                .any(|s| s.from_mm[..2] == s.to_mm[..2] && s.from_mm[2] != s.to_mm[2]));
            let kinds: std::collections::BTreeSet<String> =
                caps.iter().map(|c| format!("{:?}", c.1)).collect();
            for kind in ["Removal", "Deflection", "ChipLoad", "FeedScale", "FeedMax"] {
                assert!(kinds.contains(kind), "{kind} in {kinds:?} ({what})");
            }
            if budget_mb.is_none() {
                assert!(kinds.contains("SurfaceAngle"), "{kinds:?}");
            }
        }
    }

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
