//! Engagement along the free stations: the removed volume per interval from
//! one geometric sweep, the reference loads at [`REFERENCE_FEED_MM_MIN`], the
//! surface angles, and the windowed area that the MRR cap reads.

use crate::error::{fail, Result};
use cutting::CuttingModel;
use dexel::{Stock, SweepOptions};
use nc::Motion;
use schedule::{CapKind, Stations};

use super::caps::{angle_and_floor, angle_cap, limit_cap, peak_can_bind};
use super::verify::FeedRules;
use crate::input::job::LimitsSpec;
use crate::input::tools::ToolSet;
use crate::motion::STATION_DS_MM;
use crate::run::StockSource;

/// Engagement along the stations: removed volume per interval.
pub struct Engagement {
    /// Per interval k (station k → k+1): removed volume per unit length, mm³/mm.
    pub area_mm2: Vec<f64>,
    /// Per interval: index into the tool set of the tool cutting it (2 B an
    /// interval).
    pub tool_index: Vec<u16>,
    /// Per interval: the load at [`REFERENCE_FEED_MM_MIN`] with the windowed engagement.
    pub reference_loads: Vec<ReferenceLoad>,
    /// Per interval: S3's cutting-surface angle of a ball-end mill, degrees
    /// (NaN where not asked for, not a ball, no cut or no surface within reach).
    pub surface_angle_deg: Vec<f64>,
}

/// What the caps take of a load at [`REFERENCE_FEED_MM_MIN`] (a
/// `cutting::StepLoad`'s force, deflection, power and stress; 32 B per
/// interval instead of the whole load's 104 B).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReferenceLoad {
    /// The largest lateral force of a revolution (MODEL.md §3.4), N.
    pub force_peak_n: f64,
    pub deflection_um: f64,
    pub power_w: f64,
    pub stress_mpa: f64,
}

impl From<cutting::StepLoad> for ReferenceLoad {
    fn from(l: cutting::StepLoad) -> Self {
        ReferenceLoad {
            force_peak_n: l.force_peak_n,
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
        None,
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

/// The caps [`interval_caps`](super::interval_caps) gives for [`engagement_on`]'s engagement,
/// made as the sweep makes each interval's engagement final: neither the
/// sweep's record nor the reference loads are held (about 74 and 32 B an
/// interval), only the caps, and the windowed areas where S3 takes
/// its angles (after the sweep, from them). The same caps bit for bit; with
/// them, the feed rules of S3's angle rule along the path (empty without
/// surface angles), which the written program's run and the program as
/// given are judged by ([`FeedRules`]).
pub fn engagement_caps_on(
    stations: &Stations,
    stock: &StockSource,
    tools: &ToolSet,
    limits: &LimitsSpec,
    surface: SurfaceFrom,
) -> Result<(Vec<(f64, CapKind)>, FeedRules)> {
    let tool_index = interval_tools(stations, tools)?;
    let n = tool_index.len();
    // S3's angles need every interval's area once the sweep is done.
    let angles = !matches!(surface, SurfaceFrom::Nothing);
    let mut caps = Vec::with_capacity(n);
    let mut area_mm2 = Vec::with_capacity(if angles { n } else { 0 });
    // The peak of a reference load only where its force or stress cap can
    // be the interval's (MODEL.md §3.4, "A bound on the peak"): the same caps.
    let needs_peak = |k: usize, a: f64, bounded: &ReferenceLoad| {
        peak_can_bind(k, a, bounded, tool_index[k], stations, limits, tools)
    };
    let swept = sweep_engagement(
        stations,
        stock,
        tools,
        &tool_index,
        surface,
        Some(&needs_peak),
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
    let mut rules = FeedRules::default();
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
        let s_mm = stations.s_mm();
        for (k, cap) in caps.iter_mut().enumerate() {
            let held = stations.segments()[stations.segment()[k + 1] as usize]
                .motion
                .held_feed_mm_min()
                .is_some();
            if let (Some(v), false) = (angle_cap(k, area_mm2[k], theta[k], stations, limits), held)
            {
                // Held to as the plan holds it: feed_min is a floor under every cap.
                rules.push_angle(s_mm[k], s_mm[k + 1], v.max(limits.feed_min.unwrap_or(0.0)));
            }
            *cap = angle_and_floor(*cap, k, area_mm2[k], theta[k], stations, limits);
        }
    }
    Ok((caps, rules))
}

/// Per interval k (station k → k + 1), the index into the tool set of the
/// tool cutting it (2 B an interval).
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
/// record is not held). Gives the swept stock where S3 takes its
/// angles from its surface. With `needs_peak`, each load is first made with
/// an upper bound of its peak (`CuttingModel::step_load_bounded`) and with
/// its own only where `needs_peak(k, area, bounded)`.
#[allow(clippy::too_many_arguments)]
fn sweep_engagement(
    stations: &Stations,
    stock: &StockSource,
    tools: &ToolSet,
    tool_index: &[u16],
    surface: SurfaceFrom,
    needs_peak: Option<&NeedsPeak<'_>>,
    each: &mut dyn FnMut(usize, f64, ReferenceLoad),
) -> Result<Option<Stock>> {
    if let (StockSource::Tiled(t), SurfaceFrom::Stock) = (stock, surface) {
        fail!(limits, "[limits] angle_rule with a stock too large for the memory budget ({} rows in bands of {}): the surface angles come from the swept stock's surface, which needs every column at once; give a [design] model, use a coarser grid or a larger --memory-budget-mb", t.grid.ny, t.band_rows);
    }
    let spacing_mm = stock.grid().spacing_mm;
    // The sweep's moves (runs of intervals along a line, MODEL.md §2 "The engagement sweep"), made
    // when the sweep asks for them from the stations' positions.
    let moves = SweepMoves::new(stations, spacing_mm);
    let steps = dexel::StepFn::new(moves.len(), |j| moves.step(stations, j));
    let move_tools = moves.tools(tool_index);
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    let dexel_tools = tools.tools();
    let sweep = dexel::Sweep::new(&dexel_tools, &move_tools, &steps, &options)?;
    let window_mm = (ENGAGEMENT_WINDOW_CELLS * spacing_mm).max(2.0 * STATION_DS_MM);
    let mut rows = EngagementRows {
        moves: &moves,
        area: WindowedArea::new(stations.s_mm(), window_mm),
        loads: ReferenceLoads::new(
            stations.s_mm(),
            sweep.n_bands(),
            |k| &tools.entries[usize::from(tool_index[k])].model,
            |k| {
                let (a, b) = (stations.position_at(k), stations.position_at(k + 1));
                let step = dexel::Step {
                    from_mm: a.coords.into(),
                    to_mm: b.coords.into(),
                    rapid: false,
                };
                (crate::run::feed_dir(&step), crate::run::len_xy_mm(&step))
            },
            spacing_mm,
            needs_peak,
        ),
        each,
    };
    let (swept, _) = crate::run::sweep_through(
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

/// The engagement sweep's moves (MODEL.md §2, "The engagement sweep"): runs of station intervals
/// along straight segments, each at most the engagement's window
/// ([`ENGAGEMENT_WINDOW_CELLS`] grid cells of path) long (one interval where a
/// segment is an arc or an interval is longer). A line's
/// stations lie on it, so a run along one sweeps what its intervals one by
/// one would; a run goes on across the junction of two lines of the same
/// tool and kind of motion where every station it passes lies within
/// [`JOIN_TOL_MM`] of its chord (the lines of a program that follows a
/// surface in short blocks). Each interval takes the run's removal by its
/// share of the length. 4 B a move.
pub(super) struct SweepMoves {
    /// Each move's first interval, then the number of intervals.
    starts: Vec<u32>,
}

impl SweepMoves {
    /// The moves along `stations` on a grid of `cell_mm`.
    pub(super) fn new(stations: &Stations, cell_mm: f64) -> Self {
        let window_mm = ENGAGEMENT_WINDOW_CELLS * cell_mm;
        let (s, seg_of, segs) = (stations.s_mm(), stations.segment(), stations.segments());
        let n = stations.len().saturating_sub(1);
        let longest_mm = window_mm * (1.0 + 1e-9);
        let mut starts = Vec::new();
        let mut k = 0;
        while k < n {
            starts.push(k as u32);
            let seg = seg_of[k + 1];
            let mut end = k + 1;
            let line = |seg: u32| matches!(segs[seg as usize].geometry, nc::Geometry::Line);
            if line(seg) {
                // (Interval end lies on seg_of[end + 1]: a junction station ends its segment.)
                let (first, rapid) = (&segs[seg as usize], is_rapid(&segs[seg as usize]));
                while end < n && s[end + 1] - s[k] <= longest_mm {
                    // Interval `end` on the move's first segment, or (across a
                    // junction) on another line whose stations keep to the chord.
                    let next = seg_of[end + 1];
                    let joins = next == seg
                        || line(next)
                            && segs[next as usize].tool == first.tool
                            && is_rapid(&segs[next as usize]) == rapid
                            && chord_holds(stations, k, end + 1);
                    if !joins {
                        break;
                    }
                    end += 1;
                }
            }
            k = end;
        }
        starts.push(n as u32);
        SweepMoves { starts }
    }

    /// Number of moves.
    pub(super) fn len(&self) -> usize {
        self.starts.len() - 1
    }

    /// Move j's station intervals.
    pub(super) fn intervals(&self, j: usize) -> std::ops::Range<usize> {
        self.starts[j] as usize..self.starts[j + 1] as usize
    }

    /// Interval k's share of move j's removal `volume_mm3`, by length (the
    /// move's own volume where it is one interval).
    pub(super) fn interval_volume_mm3(
        &self,
        s_mm: &[f64],
        j: usize,
        k: usize,
        volume_mm3: f64,
    ) -> f64 {
        let r = self.intervals(j);
        if r.len() == 1 {
            volume_mm3
        } else {
            volume_mm3 / (s_mm[r.end] - s_mm[r.start]) * (s_mm[k + 1] - s_mm[k])
        }
    }

    /// Each move's tool: that of its intervals (`tool_index`, one an interval).
    pub(super) fn tools(&self, tool_index: &[u16]) -> Vec<u16> {
        let firsts = &self.starts[..self.len()];
        firsts.iter().map(|&k| tool_index[k as usize]).collect()
    }

    /// Move j, from its first station to its last.
    pub(super) fn step(&self, stations: &Stations, j: usize) -> dexel::Step {
        let r = self.intervals(j);
        let seg = stations.segment()[r.end] as usize;
        dexel::Step {
            from_mm: stations.position_at(r.start).coords.into(),
            to_mm: stations.position_at(r.end).coords.into(),
            rapid: matches!(stations.segments()[seg].motion, Motion::Rapid),
        }
    }
}

/// The engagement sweep's sink: each interval's row as the sweep makes it
/// final, in order; each interval's windowed area and reference load given
/// to `each` once the rows they read are in (two half windows ahead).
struct EngagementRows<'a, 'e, M, D> {
    moves: &'a SweepMoves,
    area: WindowedArea<'a>,
    loads: ReferenceLoads<'a, M, D>,
    each: &'e mut dyn FnMut(usize, f64, ReferenceLoad),
}

impl<'a, M, D> EngagementRows<'a, '_, M, D>
where
    M: Fn(usize) -> &'a CuttingModel + Sync,
    D: Fn(usize) -> ([f64; 2], f64) + Sync,
{
    /// Move j's row: its intervals' volumes, each its share by length
    /// (the move's own where it is one interval).
    fn row(&mut self, j: usize, row: dexel::RecordRow<'_>) {
        let (loads, each, moves) = (&mut self.loads, &mut *self.each, self.moves);
        let (intervals, s_mm) = (moves.intervals(j), self.area.s_mm);
        loads.row(intervals.clone(), row);
        for k in intervals {
            let volume = moves.interval_volume_mm3(s_mm, j, k, row.volume_mm3());
            self.area.push(volume, &mut |k, a| loads.ask(k, a));
        }
        if loads.asked.len() >= LOAD_BATCH {
            loads.make(each);
        }
    }

    fn finish(self) {
        let (mut loads, each) = (self.loads, self.each);
        self.area.finish(&mut |j, a| loads.ask(j, a));
        loads.make(each);
    }
}

/// S3's cutting-surface angle per interval (MODEL.md §6.3): the angle between
/// the tool axis and the normal of the surface nearest to the ball centre at
/// the interval's middle, from the design model or from the stock after the
/// sweep (`swept`, on a grid of `g` mm; none for a tiled stock, which takes
/// no angles from its surface). NaN on intervals that cut nothing or not
/// with a ball.
pub(super) fn surface_angles_deg(
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
/// first that did); asked for interval after interval as the sweep's rows
/// and the windowed areas come, made [`LOAD_BATCH`] at a time in parallel
/// (between the sweep's batches its threads are idle) and given in order,
/// holding only the rows of the cutting intervals that a load not yet made
/// may take its shape from (not the record, issue 16).
struct ReferenceLoads<'a, M, D> {
    s_mm: &'a [f64],
    /// The tool's model of interval k.
    model_of: M,
    /// Cutting intervals' rows, oldest first: the first is the last cut at
    /// or before the first load asked for and not made (else the first cut
    /// of all).
    sources: std::collections::VecDeque<Source>,
    /// Their bands, `n_bands` each (zero above a row's own).
    bands: std::collections::VecDeque<f64>,
    /// Their bands' ranges of offsets (MODEL.md §1.7), `n_bands` each.
    offsets: std::collections::VecDeque<[f32; 2]>,
    /// The source of the last load asked for: its index in `sources`.
    current: usize,
    /// Loads asked for and not made.
    asked: Vec<Asked>,
    /// Those loads, made.
    made: Vec<ReferenceLoad>,
    /// Interval k's move (its unit XY direction and XY length).
    dir_of: D,
    /// The grid's cell, mm.
    cell_mm: f64,
    n_bands: usize,
    /// Where a load needs its own peak, given the one with its bound
    /// (none: everywhere).
    needs_peak: Option<&'a NeedsPeak<'a>>,
}

/// Whether interval k's reference load needs the peak over the revolution,
/// given its windowed area and the load with an upper bound of the peak
/// (`CuttingModel::step_load_bounded`).
type NeedsPeak<'f> = dyn Fn(usize, f64, &ReferenceLoad) -> bool + Sync + 'f;

/// Reference loads made at a time: a few milliseconds of the tooth model
/// (MODEL.md §3.4), a few hundred kB of sources held (fewer in the tests,
/// so that their programs take several batches).
pub(super) const LOAD_BATCH: usize = if cfg!(test) { 512 } else { 4096 };

/// A reference load asked for and not made yet.
#[derive(Clone, Copy)]
struct Asked {
    /// The interval.
    k: usize,
    /// Its windowed area, mm².
    area_mm2: f64,
    /// The row it takes its shape from: an index in `sources` (none: no cut).
    source: Option<usize>,
}

/// What a reference load takes of a cutting interval's row.
struct Source {
    /// The move's first interval.
    k: usize,
    /// The move's length of path, mm.
    len_mm: f64,
    volume_mm3: f64,
    contact: [f64; 2],
    chip_edge_area_mm2: f64,
    volume_over_radius_mm2: f64,
    /// Bands up to the highest not zero.
    bands: usize,
    /// The interval's unit XY direction (the frame of its offsets).
    feed_dir: [f64; 2],
}

impl<'a, M, D> ReferenceLoads<'a, M, D>
where
    M: Fn(usize) -> &'a CuttingModel + Sync,
    D: Fn(usize) -> ([f64; 2], f64) + Sync,
{
    /// Loads along stations at `s_mm`, each band list `n_bands` long (the
    /// record's: that of the tool with the most); interval k's direction
    /// `dir_of(k)`, on a grid of `cell_mm`.
    fn new(
        s_mm: &'a [f64],
        n_bands: usize,
        model_of: M,
        dir_of: D,
        cell_mm: f64,
        needs_peak: Option<&'a NeedsPeak<'a>>,
    ) -> Self {
        ReferenceLoads {
            s_mm,
            model_of,
            sources: Default::default(),
            bands: Default::default(),
            offsets: Default::default(),
            current: 0,
            asked: Vec::with_capacity(LOAD_BATCH),
            made: Vec::with_capacity(LOAD_BATCH),
            dir_of,
            cell_mm,
            n_bands,
            needs_peak,
        }
    }

    /// The row of the move over `intervals`, before their areas.
    fn row(&mut self, intervals: std::ops::Range<usize>, row: dexel::RecordRow<'_>) {
        if row.volume_mm3() > 0.0 {
            let bands = row.band_volumes_mm3();
            let k = intervals.start;
            self.sources.push_back(Source {
                k,
                len_mm: self.s_mm[intervals.end] - self.s_mm[k],
                volume_mm3: row.volume_mm3(),
                contact: row.contact_resultant(),
                chip_edge_area_mm2: row.chip_edge_area_mm2(),
                volume_over_radius_mm2: row.volume_over_radius_mm2(),
                bands: bands.len(),
                feed_dir: (self.dir_of)(k).0,
            });
            self.bands.extend(bands);
            self.bands
                .extend(std::iter::repeat_n(0.0, self.n_bands - bands.len()));
            let offsets = row.band_offsets_mm();
            self.offsets.extend(offsets);
            self.offsets.extend(std::iter::repeat_n(
                dexel::EMPTY_OFFSETS,
                self.n_bands - offsets.len(),
            ));
        }
    }

    /// Ask for interval k's load, given its windowed area (intervals in
    /// order, each after its row). An area above zero is a mean of volumes
    /// in whose rows one cut at least, so its first cut is among the rows in.
    fn ask(&mut self, k: usize, area_mm2: f64) {
        // The last cut at or before k.
        while self.sources.get(self.current + 1).is_some_and(|s| s.k <= k) {
            self.current += 1;
        }
        debug_assert!(!(area_mm2 > 0.0 && self.sources.is_empty()), "interval {k}");
        let source = (area_mm2 > 0.0 && self.current < self.sources.len()).then_some(self.current);
        self.asked.push(Asked {
            k,
            area_mm2,
            source,
        });
    }

    /// Make the loads asked for, in parallel, and give each to
    /// `each(k, area, load)` in order; the rows before the last one's
    /// source are not taken again.
    fn make(&mut self, each: &mut dyn FnMut(usize, f64, ReferenceLoad)) {
        use rayon::prelude::*;
        let mut made = std::mem::take(&mut self.made);
        let this = &*self;
        this.asked
            .par_iter()
            .map_init(
                || (vec![0.0; this.n_bands], Vec::with_capacity(this.n_bands)),
                |(scaled, offsets), a: &Asked| {
                    a.source.map_or_else(ReferenceLoad::default, |j| {
                        this.load(a.k, a.area_mm2, j, scaled, offsets)
                    })
                },
            )
            .collect_into_vec(&mut made);
        for (a, &load) in self.asked.iter().zip(&made) {
            each(a.k, a.area_mm2, load);
        }
        self.asked.clear();
        self.made = made;
        self.sources.drain(..self.current);
        self.bands.drain(..self.current * self.n_bands);
        self.offsets.drain(..self.current * self.n_bands);
        self.current = 0;
    }

    /// Interval k's load with the windowed area `area_mm2` (above zero) and
    /// the shape of removal of source `j`; `scaled` and `offsets` hold one
    /// load's bands and their offsets.
    fn load(
        &self,
        k: usize,
        area_mm2: f64,
        j: usize,
        scaled: &mut [f64],
        offsets: &mut Vec<[f32; 2]>,
    ) -> ReferenceLoad {
        let (source, n_bands) = (&self.sources[j], self.n_bands);
        let s_mm = self.s_mm;
        let len_mm = s_mm[k + 1] - s_mm[k];
        let volume = area_mm2 * len_mm;
        let scale = volume / source.volume_mm3;
        // The record keeps a step's bands up to its highest nonzero one.
        scaled.fill(0.0);
        let first = j * n_bands;
        for (b, v) in scaled
            .iter_mut()
            .zip(self.bands.range(first..first + source.bands))
        {
            *b = v * scale;
        }
        offsets.clear();
        offsets.extend(self.offsets.range(first..first + n_bands).copied());
        let [cx, cy] = source.contact;
        let removal = cutting::StepRemoval {
            volume_mm3: volume,
            band_volumes_mm3: scaled,
            contact_resultant: [cx * scale, cy * scale],
            // The chip edge area is per step: for the interval's own length, scaled
            // by the ratio of lengths (thickness per mm of path is what is kept).
            chip_edge_area_mm2: source.chip_edge_area_mm2 * scale * source.len_mm / len_mm,
            volume_over_radius_mm2: source.volume_over_radius_mm2 * scale,
            dt_s: len_mm * 60.0 / REFERENCE_FEED_MM_MIN,
            band_offsets_mm: offsets,
            feed_dir: source.feed_dir,
            len_xy_mm: (self.dir_of)(k).1,
            cell_mm: self.cell_mm,
        };
        let model = (self.model_of)(k);
        if let Some(needs_peak) = self.needs_peak {
            let bounded = model.step_load_bounded(&removal).into();
            if !needs_peak(k, area_mm2, &bounded) {
                return bounded;
            }
        }
        model.step_load(&removal).into()
    }
}

/// How far from its chord a station an engagement move passes may lie where
/// the move crosses the junction of two lines, mm: the closed loop's
/// tolerance (MODEL.md §5.1), the size of the last digit a program in mm
/// writes (0.1 µm) a few times over.
pub const JOIN_TOL_MM: f64 = 1e-3 * crate::run::LOOP_TOL_UM;

/// Whether every station strictly between stations `a` and `b` lies within
/// [`JOIN_TOL_MM`] of the chord from `a` to `b` (the segment: a path that
/// turns back along its line, as a tap's or a reamer's feed out, does not
/// keep to it).
fn chord_holds(stations: &Stations, a: usize, b: usize) -> bool {
    let at = |k: usize| -> [f64; 3] { stations.position_at(k).coords.into() };
    let (p, q) = (at(a), at(b));
    (a + 1..b)
        .all(|i| servo::path_error::dist2_point_segment(at(i), p, q) <= JOIN_TOL_MM * JOIN_TOL_MM)
}

/// A segment the machine moves along at its rapid rate.
fn is_rapid(seg: &nc::Segment) -> bool {
    matches!(seg.motion, Motion::Rapid)
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
/// held (not every interval's). Each value is made by the same
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
