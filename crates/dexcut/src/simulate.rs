//! `dexcut simulate`: sweep the program through the stock and record what
//! every step removed, the load it puts on the tool and the error it leaves.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::error::{Error, Result};
pub use crate::model::{GridInfo, Summary, ToolPeaks};
pub use crate::util::{fmt, write_json};
use cutting::StepLoad;
use dexel::{RemovalRecord, Stock, SweepOptions, NEVER_CUT};
use rayon::prelude::*;

use crate::motion::TimedStep;
use crate::progress;
use crate::warnings::{self, LineTally, WarningKind, Warnings};

/// Volume below which a step counts as removing nothing, mm³ (f32 column
/// heights round at about 1e-7 mm; this is a 0.1 µm layer over 10 × 10 cells of 0.1 mm).
pub const NOTHING_MM3: f64 = 1e-6;
use crate::input::tools::ToolSet;

/// Window of the smoothed MRR in summaries, s (three 16 ms periods).
pub const MRR_WINDOW_S: f64 = 0.048;
/// ... and at least this many grid cells of path: removal per unit length is
/// resolved only to about one column, so shorter windows show the column phase.
pub const MRR_WINDOW_CELLS: f64 = 10.0;

/// A servo period in which the tool advances less than one grid cell has its
/// MRR measured over this many cells of path around it (MODEL.md §2.3): over
/// one cell the column quantisation still gives ±40 % (Ø1.6 mm tool, 0.1 mm
/// grid, camotics_tiny_cat_outline), over six it is within the 2 % that
/// `optimize` holds the limit to.
pub const SUB_CELL_WINDOW_CELLS: f64 = 6.0;

/// One servo period of a run, with the removal it is measured by
/// ([`Run::for_each_period`]).
#[derive(Clone, Copy, Debug)]
pub struct Period {
    /// Its steps, `first_step..=last_step`.
    pub first_step: usize,
    pub last_step: usize,
    /// Path and removal the MRR is measured over (the period itself, or the
    /// run of periods covering [`SUB_CELL_WINDOW_CELLS`] grid cells around
    /// it; in a period part feed, part rapid only the feed parts' removal),
    /// mm, mm³, s.
    pub s_from_mm: f64,
    pub s_to_mm: f64,
    pub volume_mm3: f64,
    pub dt_s: f64,
    /// Not every part of it is a rapid.
    pub cutting: bool,
    /// The periods (indices) measured: the period itself when it covers a grid cell.
    pub window: (usize, usize),
}

impl Period {
    /// MRR, mm³/s.
    pub fn mrr_mm3_s(&self) -> f64 {
        if self.dt_s > 0.0 {
            self.volume_mm3 / self.dt_s
        } else {
            0.0
        }
    }
}

/// Everything a run produced, in memory.
pub struct Run {
    /// The steps, timed, each with its program line and tool.
    pub steps: Vec<TimedStep>,
    /// What the (deflected) tool removed, per step.
    pub record: RemovalRecord,
    /// Force, power, deflection and stress per step.
    pub loads: Vec<StepLoad>,
    /// Per step, the lateral offset of the tool in the final pass, µm: its converged
    /// deflection at the contact height (MODEL.md §5.1).
    pub offsets_um: Vec<[f64; 2]>,
    /// Predicted shape error per column, µm, clamped to the stock (MODEL.md
    /// §5): held, or made where it is read ([`Run::error_map_um`],
    /// [`Run::error_map_at`]).
    error_map: ErrorMap,
    /// Stock volume before the run, mm³.
    pub initial_volume_mm3: f64,
    /// Stock volume after the run, mm³.
    pub final_volume_mm3: f64,
    /// The stock the deflected tool leaves (for a tiled stock, none of its
    /// rows: [`write_tiled_columns`] makes the bands again).
    pub stock: Stock,
    /// Per step, the deflection across the path its final removal causes, µm
    /// (the error map's model, MODEL.md §5).
    pub model_um: Vec<[f64; 2]>,
    /// Least and greatest error of the map when it is not held: made where
    /// it is read (a stock made of its closed form, by [`run_on`]) or a tiled
    /// stock's (set by [`write_tiled_columns`]), µm.
    pub error_range_um: Option<[f64; 2]>,
    /// Wall-clock time of the sweeps, s.
    pub sweep_s: f64,
    /// How the closed loop between removal and deflection ended.
    pub closed_loop: LoopReport,
    /// Largest deflection at the contact height of the rigid tool's removal, µm.
    pub rigid_peak_deflection_um: f64,
    /// Allowable stress and rupture strength of each tool the steps carry,
    /// by tool number, MPa: a step's are its tool's
    /// ([`Run::stress_limit_mpa_at`], [`Run::rupture_strength_mpa_at`]; not
    /// two per step, 16 MB for a million steps).
    pub strengths_mpa: BTreeMap<u32, [f64; 2]>,
    /// Each tool number the steps carry as messages name it
    /// ([`ToolSet::name`]: a single `[tool]` is "the job's tool").
    pub tool_names: BTreeMap<u32, String>,
}

/// A run's error map (MODEL.md §5).
enum ErrorMap {
    /// Every column's error, µm (empty for a tiled stock: its bands' are
    /// written by [`write_tiled_columns`]).
    Held(Vec<f32>),
    /// Made of the final stock and the initial stock's closed form (a box
    /// or a cylinder) on its grid where it is read, block of rows by block
    /// of rows as it is written: 4 B a column less held beside the steps and
    /// loads while the outputs are written.
    Made(dexel::Solid, dexel::Grid),
}

/// Closed loop (MODEL.md §5.1): at most this many sweeps...
pub const LOOP_MAX_PASSES: usize = 16;
/// ... until every step's deflection agrees with its applied offset within
/// this many µm plus [`LOOP_REL_TOL`] of the offset...
pub const LOOP_TOL_UM: f64 = 0.5;
pub const LOOP_REL_TOL: f64 = 0.02;
/// ... or until it stalls: neither the steps out of tolerance nor the largest
/// residual fell below this share of their value two sweeps before.
pub const LOOP_STALL_RATIO: f64 = 0.8;
/// A step the rigid tool bends across its path by no more than this, µm, has
/// no sideways load: the loop leaves it where the program puts it (offset 0).
/// An even plunge's resultant is zero but for round-off (f64 sums of the
/// contact vectors: 10⁻¹⁵…10⁻¹⁴ µm on blendercam_Op_Cutout_Layers' Ø3 plunges;
/// f32 heights: ≤ 10⁻⁶ of the load, MODEL.md §1.4), and a unit direction made
/// from it is noise. By the bracket of [`Bracketed`], a step with g(0) ≥ 0 no
/// larger than this has its root within this of 0, 500× inside the tolerance.
pub const LOOP_NO_SIDE_LOAD_UM: f64 = 1e-3;
/// The same for a feed step at one point (no XY motion: a plunge, a lift):
/// the loop's tolerance, µm (MODEL.md §5.1, eq. 5.1d). Its rigid sideways
/// load is the lattice's bias (§1.4); moved, its only sideways cut is the
/// sweep of its own offset change, a few µm that the grid removes as whole
/// columns or none, so its g measures the grid. By the bracket, the root of
/// a step with 0 ≤ g(0) ≤ this lies within the tolerance of 0.
pub const LOOP_AT_POINT_SIDE_LOAD_UM: f64 = LOOP_TOL_UM;
/// Relaxation factor of a step's offset update: first, largest and smallest.
const LOOP_RELAX_START: f64 = 0.4;
const LOOP_RELAX_MAX: f64 = 1.0;
const LOOP_RELAX_MIN: f64 = 0.02;
/// Where every step's deflection g has a slope s = Δg/Δx in this range
/// between the rigid sweep and the first trial (g nearly flat: the relaxed
/// trials would creep up on the root), the first update is the secant's root
/// `x + (g − x)/(1 − s)` instead of the relaxed one (MODEL.md §5.1); a rising
/// g (s > 0, the neighbours' offsets) is taken as flat.
const LOOP_SECANT_SLOPES: std::ops::RangeInclusive<f64> = -0.2..=0.25;

/// The stock a run sweeps: whole in memory, or too large for the memory
/// budget and made band of rows by band of rows for each sweep (ARCHITECTURE.md
/// "Large stocks").
pub enum StockSource<'a> {
    /// The whole stock.
    Whole(Stock),
    /// The whole stock, lent: every pass sweeps a copy of it (`optimize`'s
    /// runs, whose job stock stays for the next one: one stock fewer held
    /// than a copy handed over).
    Lent(&'a Stock),
    /// The whole stock of a box or a cylinder (`dexel::Solid`), handed over:
    /// every pass sweeps the stock made again from its closed form, in the
    /// memory of the one before (the stock handed over, then the last
    /// pass's), and the error map asks the closed form what material was
    /// there, so one stock is held, not two.
    Made(Stock, dexel::Solid),
    /// The bands of a tiled stock.
    Tiled(&'a crate::input::stock::Tiling),
}

impl StockSource<'_> {
    /// The grid of the stock's columns (a tiled stock's whole grid).
    pub fn grid(&self) -> &dexel::Grid {
        match self {
            StockSource::Whole(s) | StockSource::Made(s, _) => s.grid(),
            StockSource::Lent(s) => s.grid(),
            StockSource::Tiled(t) => &t.grid,
        }
    }

    /// What a sweep of this stock starts from, the stock borrowed.
    pub(crate) fn initial(&self) -> Initial<'_> {
        match self {
            StockSource::Whole(s) => Initial::Held(std::borrow::Cow::Borrowed(s)),
            StockSource::Lent(s) => Initial::Held(std::borrow::Cow::Borrowed(s)),
            StockSource::Made(s, solid) => Initial::Made(*solid, *s.grid()),
            StockSource::Tiled(t) => Initial::Tiled(t),
        }
    }
}

/// What each pass of a run starts from (a [`StockSource`] once its stock
/// handed over is taken as the first pass's memory).
pub(crate) enum Initial<'a> {
    /// A stock held whole (handed over or lent): each pass sweeps a copy.
    Held(std::borrow::Cow<'a, Stock>),
    /// A closed form on its grid: each pass sweeps the stock made of it.
    Made(dexel::Solid, dexel::Grid),
    /// The bands of a tiled stock.
    Tiled(&'a crate::input::stock::Tiling),
}

impl Initial<'_> {
    /// The initial stock's columns as the error map reads them; None for a
    /// tiled stock.
    fn columns(&self) -> Option<Before<'_>> {
        match self {
            Initial::Held(stock) => Some(Before::Stock(stock)),
            Initial::Made(solid, grid) => Some(Before::Solid(solid, grid)),
            Initial::Tiled(_) => None,
        }
    }
}

/// One sweep of `steps` through a copy of the initial stock (made in the
/// memory of `spare` where it is a closed form), each step with its tool;
/// with a tiled stock, band by band in row order (the record is the whole
/// stock's bit for bit, no stock is kept). The steps are a list or made as
/// the sweep asks for them ([`dexel::StepSource`]).
pub(crate) fn sweep_pass<S: dexel::StepSource + ?Sized, T: Copy + Into<usize>>(
    initial: &Initial,
    spare: Option<Stock>,
    tools: &ToolSet,
    tool_of_step: &[T],
    steps: &S,
    options: &SweepOptions,
    label: &str,
) -> Result<(Option<Stock>, RemovalRecord)> {
    let tools = tools.tools();
    let sweep = dexel::Sweep::new(&tools, tool_of_step, steps, options)?;
    let (work, record) = sweep_through(initial, spare, sweep, label, None)?;
    Ok((work, record.expect("a record where no sink is given")))
}

/// [`sweep_pass`]'s sweep made: its record, or with a `sink` each step's
/// row given to it as the sweep makes it final, in order, and no record
/// (`dexel::Sweep::whole_into`; a tiled stock makes no row final before its
/// last band, so its record is made whole first and then given row by row).
pub(crate) fn sweep_through<S: dexel::StepSource + ?Sized>(
    initial: &Initial,
    spare: Option<Stock>,
    mut sweep: dexel::Sweep<'_, S>,
    label: &str,
    sink: Option<&mut dexel::RowSink<'_>>,
) -> Result<(Option<Stock>, Option<RemovalRecord>)> {
    let n = sweep.len();
    let mut work = match initial {
        Initial::Held(stock) => {
            drop(spare);
            stock.as_ref().clone()
        }
        Initial::Made(solid, grid) => solid.stock_in_rows(grid.spacing_mm, None, spare)?,
        Initial::Tiled(tiling) => {
            // Each band made in the memory of the one before.
            let mut previous = None;
            for rows in tiling.bands() {
                let label = format!(
                    "{label} rows {}..{} of {}",
                    rows.start, rows.end, tiling.grid.ny
                );
                let mut band = tiling.band(rows, previous.take())?;
                let bar = progress::bar(n as u64, &label);
                sweep.band(&mut band, &|done| bar.set_position(done as u64));
                bar.finish_and_clear();
                previous = Some(band);
            }
            return Ok(match sink {
                Some(sink) => {
                    sweep.finish_into(sink);
                    (None, None)
                }
                None => (None, Some(sweep.finish())),
            });
        }
    };
    // The record made final and compact batch by batch, or its rows given away.
    let bar = progress::bar(n as u64, label);
    let progress = |done: usize| bar.set_position(done as u64);
    let record = match sink {
        Some(sink) => {
            sweep.whole_into(&mut work, &progress, sink);
            None
        }
        None => Some(sweep.whole(&mut work, &progress)),
    };
    bar.finish_and_clear();
    Ok((Some(work), record))
}

/// Each step's tool and the sweep options of a run.
pub(crate) fn sweep_setup(
    tools: &ToolSet,
    steps: &[TimedStep],
) -> Result<(Vec<usize>, SweepOptions)> {
    let tool_of_step = tools.indices(steps.iter().map(|s| (s.tool, s.line)))?;
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    Ok((tool_of_step, options))
}

/// Step `i` of `steps` with the tool moved sideways by `offsets_mm` (per
/// step, at its end; a step that continues the previous one starts at the
/// previous offset, so the offset path stays continuous). Made where a sweep
/// asks for it (`dexel::StepFn`): the closed loop's passes hold no list of
/// the moved steps (56 B a step).
fn offset_step(steps: &[TimedStep], offsets_mm: &[[f64; 2]], i: usize) -> dexel::Step {
    let s = &steps[i];
    let o = offsets_mm[i];
    let start = if i > 0 && steps[i - 1].step.to_mm == s.step.from_mm {
        offsets_mm[i - 1]
    } else {
        o
    };
    let [fx, fy, fz] = s.step.from_mm;
    let [tx, ty, tz] = s.step.to_mm;
    dexel::Step {
        from_mm: [fx + start[0], fy + start[1], fz],
        to_mm: [tx + o[0], ty + o[1], tz],
        rapid: s.step.rapid,
    }
}

/// The tool's offset per step, µm: `magnitude · direction` for feed steps; a
/// rapid keeps the offset of the feed step before it (the tool leaves the cut
/// where it was, and no rapid cuts what the bent tool left).
fn applied_offsets_um(steps: &[TimedStep], magnitude: &[f64], dirs: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut carried = [0.0, 0.0];
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            if !s.step.rapid {
                carried = [magnitude[i] * dirs[i][0], magnitude[i] * dirs[i][1]];
            }
            carried
        })
        .collect()
}

/// Per-step relaxed update of the closed loop's offset (MODEL.md §5.1): the
/// next trial is `x + ω (g − x)`; ω halves when the step's residual g − x
/// changes sign (it overshot) and grows by 30 % while it keeps its sign.
#[derive(Clone, Copy, Debug)]
struct Relaxed {
    omega: f64,
    /// The last residual was negative (its sign, starting positive).
    negative: bool,
}

impl Relaxed {
    const START: Relaxed = Relaxed {
        omega: LOOP_RELAX_START,
        negative: false,
    };

    /// Record g at x and return the next x to try (µm).
    fn next(&mut self, x: f64, g: f64) -> f64 {
        let r = g - x;
        let negative = r < 0.0;
        self.omega = if negative == self.negative {
            (1.3 * self.omega).min(LOOP_RELAX_MAX)
        } else {
            (0.5 * self.omega).max(LOOP_RELAX_MIN)
        };
        self.negative = negative;
        x + self.omega * r
    }
}

/// One bound of a step's bracket: the offset, and its residual g − x where
/// a sweep measured it (NaN where the bound is only inferred). The sweep
/// that gave it is kept beside it ([`Bracketed`]'s `lo_pass`, `hi_pass`).
#[derive(Clone, Copy, Debug)]
struct Bound {
    at: f64,
    r: f64,
}

impl Bound {
    fn measured(&self) -> bool {
        self.r.is_finite()
    }
}

/// One step's search for its offset x = g(x) in the closed loop (MODEL.md
/// §5.1), kept inside a bracket. g falls as x grows (a tool moved out of the
/// material cuts less), so r = g − x falls strictly: a trial with r ≥ 0 is a
/// lower bound of the root, one with r < 0 an upper bound. The relaxed update
/// is taken where it lands inside the bracket or the step is within the
/// tolerance (so a loop that converged before takes the same trials);
/// otherwise (it overshot: a slender tool, g' ≪ −1, where x ← g(x) diverges)
/// the Illinois variant of false position between two measured bounds, or
/// the middle of the bracket; the middle too where the bracket has not
/// halved in three sweeps (a root at a jump of g, where the edge crosses a
/// column centre). The other steps' offsets move g too (a step starts where
/// the one before it ended): a bound a trial contradicts gives way to g(x)
/// (with the other steps as they are the root lies between x and g(x)), and
/// a bracket closed around a bound measured more than two sweeps before
/// drops that bound.
///
/// One a step of the loop: 80 B (sweeps as u8, at most
/// [`LOOP_MAX_PASSES`]; the relaxed update's sign beside them, not padded in
/// a [`Relaxed`]; the offset's cap, the tool's radius, passed in rather than
/// held).
#[derive(Clone, Copy, Debug)]
struct Bracketed {
    /// The relaxed update's factor ω ([`Relaxed`], its sign `negative`).
    omega: f64,
    lo: Bound,
    hi: Bound,
    /// Residuals false position weighs the measured bounds with (Illinois: a
    /// bound kept twice in a row has its weight halved).
    w_lo: f64,
    w_hi: f64,
    /// Bracket width when it last halved.
    width_mark: f64,
    /// The rigid sweep's g = δ₀ at x = 0, until the first update takes it
    /// (`first`).
    rigid_g: f64,
    /// Sweeps that gave the bounds.
    lo_pass: u8,
    hi_pass: u8,
    /// Sweeps since the bracket last halved.
    since_halved: u8,
    /// The bound the last trial replaced: −1 lower, 1 upper, 0 none.
    replaced: i8,
    /// No update taken yet: `rigid_g` is the rigid sweep's.
    first: bool,
    /// The relaxed update's last residual was negative ([`Relaxed`]).
    negative: bool,
}

/// A sweep of the closed loop as [`Bracketed`] holds it.
fn pass_u8(pass: usize) -> u8 {
    const _: () = assert!(LOOP_MAX_PASSES <= u8::MAX as usize);
    u8::try_from(pass).expect("at most LOOP_MAX_PASSES sweeps")
}

impl Bracketed {
    /// A step whose rigid sweep (offset 0, sweep 1) gave the deflection
    /// `rigid` ≥ 0 across the path; its offsets stay within ± `cap` (its
    /// tool's radius), µm.
    fn new(rigid: f64, cap: f64) -> Bracketed {
        let hi = cap;
        Bracketed {
            omega: Relaxed::START.omega,
            lo: Bound { at: 0.0, r: rigid },
            hi: Bound {
                at: hi,
                r: f64::NAN,
            },
            w_lo: rigid,
            w_hi: f64::NAN,
            width_mark: hi,
            rigid_g: rigid,
            lo_pass: 1,
            hi_pass: 0,
            since_halved: 0,
            replaced: 0,
            first: true,
            negative: Relaxed::START.negative,
        }
    }

    /// Record the residual `r` = g − x of the trial `x` measured by sweep
    /// `pass` (offsets within ± `cap`, as in [`Bracketed::new`]).
    fn observe(&mut self, x: f64, r: f64, pass: usize, cap: f64) {
        let pass = pass_u8(pass);
        if r >= 0.0 {
            if x >= self.hi.at {
                // The upper bound no longer holds (the steps before moved):
                // the root is now in [x, g(x)].
                self.hi = Bound {
                    at: (x + r).min(cap),
                    r: f64::NAN,
                };
                self.hi_pass = pass;
            }
            (self.lo, self.lo_pass) = (Bound { at: x, r }, pass);
            if self.replaced == -1 {
                self.w_hi *= 0.5;
            }
            (self.w_lo, self.replaced) = (r, -1);
        } else {
            if x <= self.lo.at {
                // In [g(x), x].
                self.lo = Bound {
                    at: (x + r).max(-cap),
                    r: f64::NAN,
                };
                self.lo_pass = pass;
            }
            (self.hi, self.hi_pass) = (Bound { at: x, r }, pass);
            if self.replaced == 1 {
                self.w_lo *= 0.5;
            }
            (self.w_hi, self.replaced) = (r, 1);
        }
        if self.hi.at - self.lo.at <= LOOP_TOL_UM {
            // Closed around a bound measured long ago: it may be stale.
            if self.lo_pass + 2 < pass {
                (self.lo, self.lo_pass) = (
                    Bound {
                        at: -cap,
                        r: f64::NAN,
                    },
                    pass,
                );
            }
            if self.hi_pass + 2 < pass {
                (self.hi, self.hi_pass) = (
                    Bound {
                        at: cap,
                        r: f64::NAN,
                    },
                    pass,
                );
            }
        }
        if !self.lo.measured() {
            self.w_lo = f64::NAN;
        }
        if !self.hi.measured() {
            self.w_hi = f64::NAN;
        }
        let width = self.hi.at - self.lo.at;
        if width <= 0.5 * self.width_mark || width > self.width_mark {
            (self.width_mark, self.since_halved) = (width, 0);
        } else {
            self.since_halved += 1;
        }
    }

    /// Both bounds measured in the last two sweeps and within the tolerance
    /// of each other: the root lies between them, at a jump of g if the
    /// residual there is larger.
    fn closed(&self, pass: usize) -> bool {
        let pass = pass_u8(pass);
        let tol = LOOP_TOL_UM + LOOP_REL_TOL * self.lo.at.abs().max(self.hi.at.abs());
        self.lo.measured()
            && self.hi.measured()
            && self.hi.at - self.lo.at <= tol
            && self.lo_pass + 2 >= pass
            && self.hi_pass + 2 >= pass
    }

    /// After the first trial `x` gave `g`: the slope s = Δg/Δx of g between
    /// the rigid sweep (x = 0) and this one, where they lie more than the
    /// tolerance apart (None after the first update).
    fn first_slope(&self, x: f64, g: f64) -> Option<f64> {
        if !self.first {
            return None;
        }
        let (x0, g0) = (0.0, self.rigid_g);
        ((x - x0).abs() > LOOP_TOL_UM).then(|| (g - g0) / (x - x0))
    }

    /// The next offset to try after `x` gave `g` (observed first). `secant`:
    /// at the first update, take the secant's root where the slope of g is
    /// in [`LOOP_SECANT_SLOPES`] (the loop allows it where every step's is).
    fn next(&mut self, x: f64, g: f64, secant: bool) -> f64 {
        let mut update = Relaxed {
            omega: self.omega,
            negative: self.negative,
        };
        let relaxed = update.next(x, g);
        (self.omega, self.negative) = (update.omega, update.negative);
        let p = match self.first_slope(x, g) {
            Some(s) if secant && LOOP_SECANT_SLOPES.contains(&s) => {
                x + (g - x) / (1.0 - s.min(0.0))
            }
            _ => relaxed,
        };
        self.first = false;
        let (lo, hi) = (self.lo, self.hi);
        let middle = 0.5 * (lo.at + hi.at);
        // A step within the tolerance takes the relaxed update (it moves
        // little, and x may sit on a bound: g = x there).
        if (g - x).abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() {
            return p;
        }
        let measured = lo.measured() && hi.measured();
        if measured && self.since_halved >= 3 {
            return middle;
        }
        let above = p > lo.at || (!lo.measured() && p >= lo.at);
        let below = p < hi.at || (!hi.measured() && p <= hi.at);
        if above && below {
            return p;
        }
        if measured {
            // Illinois: false position on the weighted residuals.
            let t = self.w_lo / (self.w_lo - self.w_hi);
            if t.is_finite() && t > 0.0 && t < 1.0 {
                return lo.at + t * (hi.at - lo.at);
            }
        }
        middle
    }
}

/// Unit direction in which the closed loop moves a step's tool: the rigid
/// deflection `(dx, dy)` without its component along the step's XY motion
/// `m` (MODEL.md §5.1); zero when no more than [`LOOP_NO_SIDE_LOAD_UM`] is
/// left (an even plunge's round-off has no direction), or at one point (no
/// XY motion) no more than [`LOOP_AT_POINT_SIDE_LOAD_UM`] (eq. 5.1d).
fn loop_direction(dx: f64, dy: f64, m: [f64; 2]) -> [f64; 2] {
    let m2 = m[0] * m[0] + m[1] * m[1];
    let along = if m2 > 0.0 {
        (dx * m[0] + dy * m[1]) / m2
    } else {
        0.0
    };
    let (px, py) = (dx - along * m[0], dy - along * m[1]);
    let len = (px * px + py * py).sqrt();
    let floor = if m2 > 0.0 {
        LOOP_NO_SIDE_LOAD_UM
    } else {
        LOOP_AT_POINT_SIDE_LOAD_UM
    };
    if len > floor && len.is_finite() {
        [px / len, py / len]
    } else {
        [0.0, 0.0]
    }
}

/// Which steps take the direction of the step before them: each feed step
/// without a direction of its own (`dirs`, from [`loop_direction`]: the
/// rigid tool removes nothing in it, or pushes it along its path only) that
/// continues a feed step with one, its own or taken (same tool, starting
/// where it ended), that the loop moves (`in_loop`), along the chain of
/// such steps (MODEL.md §5.1, eq. 5.1a); plunges (down, with no XY motion)
/// excepted: a plunge moved sideways by a fraction of a µm is no longer a
/// plunge to the removal, whose resultant keeps the lattice's bias (§1.4):
/// a few µm of false side load, the size of the offsets it would relax.
/// Such a step starts where that step's offset left the tool, so the loop
/// seeks its own offset as the equilibrium along that direction (a fraction
/// of the offset it starts at, [`Fraction`]): the offset relaxes with the
/// load that sustains it instead of the tool sweeping back to the
/// programmed path within one step. `dirs` gets the directions taken.
fn inherit_directions(
    steps: &[TimedStep],
    tool_of_step: &[usize],
    dirs: &mut [[f64; 2]],
    in_loop: &[bool],
) -> Vec<bool> {
    let mut inherited = vec![false; steps.len()];
    for i in 1..steps.len() {
        let (before, s) = (&steps[i - 1], &steps[i]);
        let [fx, fy, fz] = s.step.from_mm;
        let [tx, ty, tz] = s.step.to_mm;
        let plunge = fx == tx && fy == ty && tz < fz;
        if dirs[i] == [0.0, 0.0]
            && !plunge
            && (in_loop[i - 1] || inherited[i - 1])
            && !s.step.rapid
            && !before.step.rapid
            && before.step.to_mm == s.step.from_mm
            && tool_of_step[i - 1] == tool_of_step[i]
        {
            dirs[i] = dirs[i - 1];
            inherited[i] = true;
        }
    }
    inherited
}

/// The closed loop's search for the offset of a step that took its direction
/// from the step before it ([`inherit_directions`], MODEL.md §5.1, eq. 5.1a):
/// the fraction φ of the offset x₋ the step starts at, x = φ x₋, with the
/// root in 0 ≤ φ ≤ 1. At φ = 0 the step sweeps back to the programmed path
/// (the offset of a step with no direction, its first trial: a step whose
/// sweep back removes nothing keeps it); at φ = 1 it is the rigid step moved
/// by x₋, which pushes the tool across its path by nothing (its second
/// trial). g − x falls with x, so a trial whose residual puts the root at a
/// larger |x| is a lower bound of φ, otherwise an upper one (a bound a trial
/// contradicts, x₋ having moved, gives way to 0 or 1), and the next trial is
/// the Illinois false position between the two ([`Bracketed`]'s rule; its
/// bounds are absolute offsets, these move with x₋), or the middle where the
/// bracket has not halved in three sweeps. A short step's g is steep (the
/// sweep back of 1 µm of wall in 0.1 ms loads the tool as 200 µm of it in
/// a 25 ms step would), and its root lies within a µm of x₋: false position
/// from φ = 0 and 1 finds it in one or two sweeps, where halving 0…1 takes
/// seven.
#[derive(Clone, Copy, Debug)]
struct Fraction {
    phi: f64,
    lo: f64,
    hi: f64,
    /// The residuals g − x at the bounds, signed so that the lower one is
    /// ≥ 0 and the upper one < 0 (Illinois: halved when the other bound
    /// moved twice in a row).
    w_lo: f64,
    w_hi: f64,
    /// Sweeps that measured the bounds (0: not measured).
    lo_pass: usize,
    hi_pass: usize,
    /// The bound the last trial replaced: −1 lower, 1 upper, 0 none.
    replaced: i8,
    /// Bracket width when it last halved, and sweeps since.
    width_mark: f64,
    since_halved: u32,
}

impl Fraction {
    const START: Fraction = Fraction {
        phi: 0.0,
        lo: 0.0,
        hi: 1.0,
        w_lo: f64::NAN,
        w_hi: f64::NAN,
        lo_pass: 0,
        hi_pass: 0,
        replaced: 0,
        width_mark: 1.0,
        since_halved: 0,
    };

    /// Record the residual `r` = g − x of the trial φ measured by sweep
    /// `pass`, the step having started at the offset `from`.
    fn observe(&mut self, r: f64, from: f64, pass: usize) {
        let phi = self.phi;
        let was_measured = self.lo_pass > 0 && self.hi_pass > 0;
        let w = if from < 0.0 { -r } else { r };
        if w >= 0.0 {
            if phi >= self.hi {
                (self.hi, self.hi_pass) = (1.0, 0);
            }
            (self.lo, self.lo_pass) = (phi, pass);
            if self.replaced == -1 {
                self.w_hi *= 0.5;
            }
            (self.w_lo, self.replaced) = (w, -1);
        } else {
            if phi <= self.lo {
                (self.lo, self.lo_pass) = (0.0, 0);
            }
            (self.hi, self.hi_pass) = (phi, pass);
            if self.replaced == 1 {
                self.w_lo *= 0.5;
            }
            (self.w_hi, self.replaced) = (w, 1);
        }
        // (Counted from the sweep that measured both bounds: the first
        // trials, φ = 0 and 1, halve nothing.)
        let width = self.hi - self.lo;
        if !was_measured || width <= 0.5 * self.width_mark || width > self.width_mark {
            (self.width_mark, self.since_halved) = (width, 0);
        } else {
            self.since_halved += 1;
        }
    }

    /// Both bounds measured in the last two sweeps (or the lower one, if
    /// measured after the upper one: a bracket held at its lower bound,
    /// [`Fraction::next`]) and, as offsets from `from`, within the tolerance
    /// of each other.
    fn closed(&self, from: f64, pass: usize) -> bool {
        self.lo_pass > 0
            && self.hi_pass > 0
            && self.lo_pass + 2 >= pass
            && (self.hi_pass + 2 >= pass || self.lo_pass > self.hi_pass)
            && self.width_um(from) <= LOOP_TOL_UM + LOOP_REL_TOL * (self.hi * from).abs()
    }

    /// The bracket's width as offsets from `from`, µm.
    fn width_um(&self, from: f64) -> f64 {
        (self.hi - self.lo) * from.abs()
    }

    /// The root lies outside 0 ≤ φ ≤ 1, and the step's offset is the bound
    /// it lies beyond (MODEL.md §5.1, eq. 5.1b): even at φ = 1 the bent
    /// tool's removal pushes the step further than the offset it starts at
    /// (material its neighbours' offsets left), and the step goes on at that
    /// offset; or even at φ = 0 it pushes the tool back across the path
    /// (the step's own cut, of material the other steps' offsets left, loads
    /// it the other way), and the step ends on the path. Its load is
    /// reported as swept.
    fn held(&self) -> bool {
        (self.lo >= 1.0 && self.lo_pass > 0) || (self.hi <= 0.0 && self.hi_pass > 0)
    }

    /// The next fraction to try (observed first), the step having started at
    /// the offset `from`: the trial kept where its residual `r` at the
    /// offset `x` is within the tolerance; where the bracket is, the bound
    /// measured longer ago again (x₋ may have moved since), except that a
    /// closed bracket whose lower bound this sweep `pass` measured is held
    /// there (MODEL.md §5.1, eq. 5.1c): trying its bounds in turn cut a row
    /// of columns at one sweep and not at the next, and the step after it,
    /// starting there, found the row cut or not and never settled.
    fn next(&mut self, r: f64, x: f64, from: f64, pass: usize) -> f64 {
        if r.abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() {
            return self.phi;
        }
        let narrow = self.width_um(from) <= LOOP_TOL_UM + LOOP_REL_TOL * (self.hi * from).abs();
        self.phi = if self.hi_pass == 0 {
            self.hi
        } else if self.lo_pass == 0 {
            self.lo
        } else if narrow {
            let held = self.lo_pass == pass && self.closed(from, pass);
            if held || self.lo_pass < self.hi_pass {
                self.lo
            } else {
                self.hi
            }
        } else {
            let t = self.w_lo / (self.w_lo - self.w_hi);
            if self.since_halved < 3 && t.is_finite() && t > 0.0 && t < 1.0 {
                self.lo + t * (self.hi - self.lo)
            } else {
                0.5 * (self.lo + self.hi)
            }
        };
        self.phi
    }
}

/// How the closed loop ended (summary.json `closed_loop_*`).
#[derive(Clone, Debug, Default)]
pub struct LoopReport {
    /// The job asked for the closed loop (`[cutting] closed_loop`).
    pub enabled: bool,
    /// Sweeps, the rigid one included.
    pub passes: usize,
    /// Largest |g − x| after the last sweep, µm (open loop: the rigid sweep's
    /// largest deflection across the path, which nothing compensated).
    pub residual_um: f64,
    /// Every step within tolerance.
    pub converged: bool,
    /// Steps left out of tolerance, with their |g − x| in µm.
    pub unconverged: Vec<(usize, f64)>,
    /// Some tool's steps were kept rigid: its rigid cut overloaded it
    /// (MODEL.md §5.1).
    pub rigid_kept: bool,
}

/// Sweep `steps` through `stock` and compute the loads, closing the loop between
/// removal and deflection (MODEL.md §5.1): the rigid tool's removal gives each
/// step's deflection; the program is swept again with the tool moved across its
/// path by a trial offset, and each step's offset is relaxed towards the
/// deflection the removal causes until they agree. Each step is cut by its own
/// tool (MODEL.md §9.1). The error map is then clamped to the stock (MODEL.md §5).
/// The stock is held whole (handed over, lent or made of its closed form) or
/// in bands. With a tiled stock the run keeps no stock, no error map and no
/// volumes (NaN): [`write_tiled_columns`] makes them band by band.
pub fn run_on(
    stock: StockSource,
    tools: &ToolSet,
    steps: Vec<TimedStep>,
    label: &str,
) -> Result<Run> {
    let (initial_volume_mm3, grid_mm) = match &stock {
        StockSource::Whole(s) | StockSource::Made(s, _) => (s.volume_mm3(), s.grid().spacing_mm),
        StockSource::Lent(s) => (s.volume_mm3(), s.grid().spacing_mm),
        StockSource::Tiled(t) => (f64::NAN, t.grid.spacing_mm),
    };
    // The stock handed over with its closed form is the first pass's memory.
    let (initial, spare) = match stock {
        StockSource::Whole(s) => (Initial::Held(std::borrow::Cow::Owned(s)), None),
        StockSource::Lent(s) => (Initial::Held(std::borrow::Cow::Borrowed(s)), None),
        StockSource::Made(s, solid) => (Initial::Made(solid, *s.grid()), Some(s)),
        StockSource::Tiled(t) => (Initial::Tiled(t), None),
    };
    // The rigid tool's moves made as the sweep asks for them, not a list of
    // them beside the steps (56 B a step, issue 16).
    let rigid_steps = dexel::StepFn::new(steps.len(), |i| steps[i].step);
    let (tool_of_step, options) = sweep_setup(tools, &steps)?;
    let started = Instant::now();
    let (rigid_stock, mut record) = sweep_pass(
        &initial,
        spare,
        tools,
        &tool_of_step,
        &rigid_steps,
        &options,
        label,
    )?;
    // At most two stocks at a time: the initial one (none where it is made
    // of its closed form) and the last pass's.
    let mut final_stock = rigid_stock;
    let mut step_loads = loads(tools, &tool_of_step, &record, &steps, grid_mm);
    let n = steps.len();
    // Each step's tool's allowable stress and rupture strength.
    let stress_limit_mpa = |i: usize| tools.entries[tool_of_step[i]].stress_limit_mpa;
    let rupture_strength_mpa = |i: usize| tools.entries[tool_of_step[i]].rupture_strength_mpa;
    let strengths_mpa: BTreeMap<u32, [f64; 2]> = steps
        .iter()
        .enumerate()
        .map(|(i, s)| (s.tool, [stress_limit_mpa(i), rupture_strength_mpa(i)]))
        .collect();
    let tool_names: BTreeMap<u32, String> = steps
        .iter()
        .map(|s| s.tool)
        .collect::<std::collections::BTreeSet<u32>>()
        .into_iter()
        .map(|t| (t, tools.name(t)))
        .collect();
    // The rigid sweep's loads as reported: a step that breaks its tool
    // deflects by its elastic deflection at rupture (MODEL.md §4.4). Such a
    // tool is overloaded (its rupture strength is at least its allowable
    // stress) and stays out of the loop below, so the steps the loop moves
    // start from the same loads with or without the cap. Made where they are
    // read, step by step (not a copy of every step's load: 104 B a step).
    let rigid_load = |i: usize| step_loads[i].at_rupture(rupture_strength_mpa(i));
    // A tool the rigid cut overloads beyond its allowable stress anywhere would
    // break there: no elastic balance exists, so the loop leaves that tool's
    // steps rigid (the open-loop estimate, which the force warning names)
    // rather than mixing bent and unbent steps along its path (MODEL.md §5.1).
    let mut overloaded = vec![false; tools.entries.len()];
    for (i, l) in step_loads.iter().enumerate() {
        if !steps[i].step.rapid && l.stress_mpa > stress_limit_mpa(i) {
            overloaded[tool_of_step[i]] = true;
        }
    }
    // Directions of the loop's offsets (unit, fixed from the rigid sweep):
    // across the path; rapids are not moved (a collision's load means nothing).
    let mut dirs: Vec<[f64; 2]> = step_loads
        .iter()
        .zip(&steps)
        .map(|(l, s)| {
            if s.step.rapid {
                return [0.0, 0.0];
            }
            let m = [
                s.step.to_mm[0] - s.step.from_mm[0],
                s.step.to_mm[1] - s.step.from_mm[1],
            ];
            loop_direction(l.dx_um, l.dy_um, m)
        })
        .collect();
    // Steps whose offset the loop seeks (the others keep offset 0: rapids,
    // steps not pushed across the path, and every step of an overloaded tool,
    // whose error map is the rigid tool's as with the loop off).
    let mut in_loop: Vec<bool> = (0..steps.len())
        .map(|i| dirs[i] != [0.0, 0.0] && !overloaded[tool_of_step[i]])
        .collect();
    // With the loop, a feed step with no direction that continues one the
    // loop moves takes its direction; its offset is sought as a fraction of
    // the one it starts at (MODEL.md §5.1, eq. 5.1a).
    let inherited = if tools.closed_loop {
        inherit_directions(&steps, &tool_of_step, &mut dirs, &in_loop)
    } else {
        vec![false; n]
    };
    for (l, &h) in in_loop.iter_mut().zip(&inherited) {
        *l |= h;
    }
    let along =
        |load: &StepLoad, i: usize| -> f64 { load.dx_um * dirs[i][0] + load.dy_um * dirs[i][1] };
    // (A step that took its direction was not pushed across its own path.)
    let mut rigid: Vec<f64> = (0..n)
        .map(|i| {
            if inherited[i] {
                0.0
            } else {
                along(&rigid_load(i), i).max(0.0)
            }
        })
        .collect();
    // The largest offset a step may be tried at (MODEL.md §5.1): its tool's
    // radius. A trial beyond it would sweep the tool into stock it cannot
    // reach and feed the loop ever larger loads.
    // (Made where it is read: one a tool, not a copy a step.)
    let offset_cap_um = |i: usize| 500.0 * tools.entries[tool_of_step[i]].tool.diameter_mm;
    let rigid_peak_deflection_um = (0..n)
        .map(|i| rigid_load(i).deflection_um)
        .fold(0.0, f64::max);
    // Open loop: the largest deflection across the path nothing compensated;
    // closed loop: that of the steps the loop moves (none moved: nothing to do).
    let rigid_across_peak_um = (0..n)
        .filter(|&i| !tools.closed_loop || in_loop[i])
        .map(|i| rigid[i])
        .fold(0.0, f64::max);
    let mut report = LoopReport {
        enabled: tools.closed_loop,
        passes: 1,
        residual_um: rigid_across_peak_um,
        converged: rigid_across_peak_um <= LOOP_TOL_UM,
        unconverged: Vec::new(),
        rigid_kept: tools.closed_loop && overloaded.iter().any(|&o| o),
    };
    // The loop's passes run (below).
    let looping = tools.closed_loop && !report.converged;
    // Where a step advances less than one grid cell its load comes in whole
    // columns (MODEL.md §1.5) and g jumps from step to step by the load of a
    // row of columns; the grid resolves it over [`SUB_CELL_WINDOW_CELLS`]
    // cells of path (§2.3). Such a step is also within tolerance where the
    // residual over its window of the loop's steps is (MODEL.md §5.1).
    // (Made only where the loop runs: only its passes read them. An open
    // loop's run of a million steps made them beside its loads, 41 MB.)
    let (sub_cells, advance_mm) = if looping {
        let advance_mm: Vec<f64> = steps
            .iter()
            .map(|s| {
                let [fx, fy, _] = s.step.from_mm;
                let [tx, ty, _] = s.step.to_mm;
                (tx - fx).hypot(ty - fy)
            })
            .collect();
        // Windows over the feed steps of one cut (the steps out of the loop in
        // it, such as cuts by the tool's bottom alone, weigh nothing below).
        let feed: Vec<bool> = steps.iter().map(|s| !s.step.rapid).collect();
        // The steps of the loop that advance less than a grid cell, in order,
        // with their windows' first and last steps (not a window a step, and
        // as u32, 12 B each, where usize took 24: issue 16; a run's steps are
        // counted in u32, as the stock's last cuts are).
        let index = |i: usize| u32::try_from(i).expect("a run's steps counted in u32");
        let mut sub_cells: Vec<[u32; 3]> = Vec::new();
        sub_cell_windows(
            |p| advance_mm[p],
            &feed,
            |p| {
                steps[p - 1].step.to_mm == steps[p].step.from_mm
                    && tool_of_step[p - 1] == tool_of_step[p]
            },
            grid_mm,
            SUB_CELL_WINDOW_CELLS * grid_mm,
            |i, window| {
                if in_loop[i] && !inherited[i] && advance_mm[i] < grid_mm && window != (i, i) {
                    sub_cells.push([index(i), index(window.0), index(window.1)]);
                }
            },
        );
        // The steps' advances weigh the windows' sums below: none without such steps.
        let advance_mm = if sub_cells.is_empty() {
            Vec::new()
        } else {
            advance_mm
        };
        (sub_cells, advance_mm)
    } else {
        (Vec::new(), Vec::new())
    };
    // Each step's offset: its trial, once the loop tries one.
    let mut x: Vec<f64> = vec![0.0; n];
    // The loads of the steps the loop scales (below) and by how much, once
    // it ends: the passes keep no loads, the last one's are made again
    // once the searches are let go.
    let mut scaled: Option<Vec<(usize, f64)>> = None;
    if looping {
        // The rigid sweep's record and loads are read no more (the loop
        // makes its own): freed before the searches are made.
        drop(std::mem::take(&mut record));
        drop(std::mem::take(&mut step_loads));
        let mut search: Vec<Bracketed> = (0..n)
            .map(|i| Bracketed::new(rigid[i], offset_cap_um(i)))
            .collect();
        // The steps that took their direction seek a fraction of the offset
        // they start at, first 0 (eq. 5.1a): one search each, by step
        // (a few of the steps, not one a step: issue 16).
        let with_fraction: Vec<usize> = (0..n).filter(|&i| inherited[i]).collect();
        let mut fractions = vec![Fraction::START; with_fraction.len()];
        let at = |i: usize| {
            with_fraction
                .binary_search(&i)
                .expect("a step that took its direction")
        };
        // A step that took its direction at one point (no XY motion: a lift
        // or the rest of a period at the end of a cut) keeps the offset it
        // starts at (MODEL.md §5.1, eq. 5.1d): not sought, not judged. Its
        // only sideways cut would be the sweep of its own offset change, a
        // few µm the grid removes as whole columns or none (g jumps between 0
        // and a column's load at a place the offsets before it move), so no
        // trial resolves its equilibrium better than no sweep at all.
        let at_point = |i: usize| {
            let [fx, fy, _] = steps[i].step.from_mm;
            let [tx, ty, _] = steps[i].step.to_mm;
            inherited[i] && fx == tx && fy == ty
        };
        for i in 0..n {
            if at_point(i) {
                x[i] = x[i - 1];
            } else if in_loop[i] {
                x[i] = (LOOP_RELAX_START * rigid[i]).min(offset_cap_um(i));
            }
        }
        // The rigid deflections are in the searches now.
        drop(std::mem::take(&mut rigid));
        // Steps out of tolerance after each sweep, to see the loop stall.
        let mut out_counts: Vec<usize> = Vec::new();
        let mut residuals: Vec<f64> = Vec::new();
        loop {
            // The last pass's stock and record are replaced by this pass's:
            // freed before its steps are made and it is swept (the stock's
            // memory holds this pass's where it is made of its closed form).
            let spare = final_stock.take();
            drop(std::mem::take(&mut record));
            // (Made again after the sweep.)
            report.unconverged = Vec::new();
            // The offsets, mm (16 B a step); the moved steps are made from
            // them as the sweep asks for them.
            let offsets_mm: Vec<[f64; 2]> = applied_offsets_um(&steps, &x, &dirs)
                .into_iter()
                .map(|[x, y]| [1e-3 * x, 1e-3 * y])
                .collect();
            let shifted = dexel::StepFn::new(n, |i| offset_step(&steps, &offsets_mm, i));
            let (pass_stock, pass_record) = sweep_pass(
                &initial,
                spare,
                tools,
                &tool_of_step,
                &shifted,
                &options,
                label,
            )?;
            // (The offsets swept are not needed after the sweep.)
            drop(offsets_mm);
            (final_stock, record) = (pass_stock, pass_record);
            report.passes += 1;
            // g: the deflection the removal at the trial offset causes, across
            // the path (of the loads as `loads` makes them).
            let g: Vec<f64> = loads_as(tools, &tool_of_step, &record, &steps, grid_mm, along);
            let pass = report.passes;
            for i in (0..n).filter(|&i| in_loop[i] && !at_point(i)) {
                if inherited[i] {
                    fractions[at(i)].observe(g[i] - x[i], x[i - 1], pass);
                } else {
                    search[i].observe(x[i], g[i] - x[i], pass, offset_cap_um(i));
                }
            }
            // A step's bracket closed around its root (at a jump of g), and
            // its width, µm.
            let closed = |i: usize| -> Option<f64> {
                if at_point(i) {
                    None
                } else if inherited[i] {
                    let fraction = &fractions[at(i)];
                    fraction
                        .closed(x[i - 1], pass)
                        .then(|| fraction.width_um(x[i - 1]))
                } else {
                    search[i]
                        .closed(pass)
                        .then(|| search[i].hi.at - search[i].lo.at)
                }
            };
            // Where a step advances less than a grid cell, g jumps from step to
            // step by the load of a row of columns (MODEL.md §1.5), and the grid
            // measures the load over the step's window of path only: such a step
            // is also within tolerance where its window's path-weighted mean
            // residual r̄ = mean(g − x) is within the tolerance of the mean offset
            // once the grid's resolution of r̄ is taken off. That mean is known
            // to ± |ḡ|·grid/path: the window's removal counts the rows of
            // columns whose centres its path crosses, ± one row of the path/grid
            // rows it covers (MODEL.md §5.1).
            // (Sums made only where a step has such a window, in one pass over
            // the steps in order, holding only the running sums from the
            // window last read to the furthest end reached, not a prefix sum
            // of every step: issue 16.)
            let mut window_sums = WindowSums::new(|j: usize| {
                let w = if in_loop[j] && !inherited[j] {
                    advance_mm[j]
                } else {
                    0.0
                };
                residual_terms(w, g[j], x[j], advance_mm[j])
            });
            let mut windows = sub_cells.iter().peekable();
            let within = |r: f64, x: f64| r <= LOOP_TOL_UM + LOOP_REL_TOL * x;
            // A step's residual and the offset its tolerance scales with: |g −
            // x|, or where its bracket has closed around a jump of g, the
            // bracket's width (how far x is from the root); a sub-cell step out
            // of tolerance so but within it over its window, the window's.
            // (Asked in step order, so their windows' starts do not decrease:
            // `sub_cell_windows`.)
            let mut residual = |i: usize| -> (f64, f64) {
                let window = windows
                    .next_if(|&&[j, _, _]| j as usize <= i)
                    .map(|&[j, a, b]| {
                        debug_assert_eq!(
                            j as usize, i,
                            "every sub-cell step is a step of the loop"
                        );
                        (a as usize, b as usize)
                    });
                if at_point(i) || (inherited[i] && fractions[at(i)].held()) {
                    return (0.0, x[i].abs());
                }
                let r = (g[i] - x[i]).abs();
                let own = closed(i).map_or(r, |width| r.min(width));
                if let Some((a, b)) = window {
                    if !within(own, x[i].abs()) {
                        if let Some((rw, xw)) = window_residual(window_sums.over(a, b), grid_mm) {
                            if within(rw, xw) {
                                return (rw, xw);
                            }
                        }
                    }
                }
                (own, x[i].abs())
            };
            // Both from one pass in step order (the same fold).
            let mut unconverged = Vec::new();
            let mut residual_um = 0.0;
            for i in (0..n).filter(|&i| in_loop[i]) {
                let (r, xr) = residual(i);
                if !within(r, xr) {
                    unconverged.push((i, r));
                }
                residual_um = f64::max(residual_um, r);
            }
            (report.unconverged, report.residual_um) = (unconverged, residual_um);
            report.converged = report.unconverged.is_empty();
            out_counts.push(report.unconverged.len());
            residuals.push(report.residual_um);
            // Stalled: the best of the last three sweeps is no better than 0.8 of
            // the best before them, both in steps out and in residual (from the
            // ninth sweep on: the first ones may leave every step out while the
            // offsets grow, and a step whose g jumps where a column centre is
            // crossed closes in slowly).
            let k = out_counts.len();
            let stalled = k >= 8 && {
                let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
                let counts: Vec<f64> = out_counts.iter().map(|&c| c as f64).collect();
                best(&counts[k - 3..]) > LOOP_STALL_RATIO * best(&counts[..k - 3])
                    && best(&residuals[k - 3..]) > LOOP_STALL_RATIO * best(&residuals[..k - 3])
            };
            if report.converged || stalled || report.passes >= LOOP_MAX_PASSES {
                // A root at a jump of g (the edge crossing a column centre):
                // the sweep's load is that of one side of the jump, the
                // equilibrium's lies between. Where the sweep's is the larger
                // one (g > x) it is scaled down so that the deflection across
                // the path is the offset (MODEL.md §5.1); a load is never
                // scaled up beyond what a sweep removed.
                scaled = Some(
                    (0..n)
                        .filter(|&i| in_loop[i])
                        .filter(|&i| {
                            let off = g[i] - x[i] > LOOP_TOL_UM + LOOP_REL_TOL * x[i].abs();
                            off && closed(i).is_some() && x[i] > 0.0
                        })
                        .map(|i| (i, x[i] / g[i]))
                        .collect(),
                );
                break;
            }
            // The secant's root at the first update where every step's g
            // fell or rose gently between the rigid sweep and the first
            // trial (g nearly flat: the steps move together, and the
            // relaxed trials would creep up on the root); otherwise none
            // takes it (steps coupled to their neighbours move alike).
            let secant = (0..n).filter(|&i| in_loop[i] && !inherited[i]).all(|i| {
                search[i]
                    .first_slope(x[i], g[i])
                    .is_none_or(|s| LOOP_SECANT_SLOPES.contains(&s))
            });
            // In step order: a step that took its direction moves with the
            // offset it starts at, the trial of the step before (x[i − 1],
            // already the next one; `measured_before` the one swept).
            let mut measured_before = 0.0;
            for i in 0..n {
                let measured = x[i];
                if at_point(i) {
                    x[i] = x[i - 1];
                } else if inherited[i] {
                    x[i] =
                        (fractions[at(i)].next(g[i] - measured, measured, measured_before, pass)
                            * x[i - 1])
                            .clamp(-offset_cap_um(i), offset_cap_um(i));
                } else if in_loop[i] {
                    x[i] = search[i]
                        .next(measured, g[i], secant)
                        .clamp(-offset_cap_um(i), offset_cap_um(i));
                }
                measured_before = measured;
            }
        }
    }
    // What only the loop read, let go before the last pass's loads, the
    // offsets and the model's deflections are made (the offsets' trials once
    // they are; the sub-cell windows and advances, 20 MB of a million-step
    // run, were held beside the loads: issue 16).
    drop((rigid, in_loop, inherited, sub_cells, advance_mm));
    // The last pass's loads, those at a jump of g scaled.
    if let Some(scaled) = scaled {
        step_loads = loads(tools, &tool_of_step, &record, &steps, grid_mm);
        for (i, s) in scaled {
            step_loads[i] = step_loads[i].scaled(s);
        }
    }
    let sweep_s = started.elapsed().as_secs_f64();
    // The final loads as reported (MODEL.md §4.4): where a step breaks its
    // tool, the deflections at rupture; the error map takes them below.
    for (i, l) in step_loads.iter_mut().enumerate() {
        *l = l.at_rupture(rupture_strength_mpa(i));
    }
    let offsets_um = applied_offsets_um(&steps, &x, &dirs);
    drop(x);
    // The deflection across the path that the final removal causes (rapids:
    // the offset they carry).
    let model_um: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            if steps[i].step.rapid {
                offsets_um[i]
            } else {
                let g = along(&step_loads[i], i);
                [g * dirs[i][0], g * dirs[i][1]]
            }
        })
        .collect();
    let (final_stock, error_map, error_range, final_volume_mm3) = match (&initial, final_stock) {
        (Initial::Tiled(tiling), _) => {
            (tiling.empty()?, ErrorMap::Held(Vec::new()), None, f64::NAN)
        }
        (Initial::Made(solid, grid), Some(last)) => {
            // The map's range, block of rows by block of rows in order (the
            // same fold as over the whole map); the map is made again where
            // it is written.
            let before = initial.columns().expect("a whole stock");
            let mut range = [0.0, 0.0];
            for at in row_blocks(last.grid()) {
                let error = clamped_error_map_um(before, &last, &offsets_um, &model_um, at);
                range = error_range_um(&error, range);
            }
            let volume = last.volume_mm3();
            (last, ErrorMap::Made(*solid, *grid), Some(range), volume)
        }
        (Initial::Held(_), Some(last)) => {
            let before = initial.columns().expect("a whole stock");
            let all = 0..last.last_cut().len();
            let error_um = clamped_error_map_um(before, &last, &offsets_um, &model_um, all);
            let volume = last.volume_mm3();
            (last, ErrorMap::Held(error_um), None, volume)
        }
        (_, None) => unreachable!("a whole stock's pass keeps its stock"),
    };
    Ok(Run {
        steps,
        record,
        loads: step_loads,
        offsets_um,
        error_map,
        initial_volume_mm3,
        final_volume_mm3,
        model_um,
        error_range_um: error_range,
        stock: final_stock,
        sweep_s,
        closed_loop: report,
        rigid_peak_deflection_um,
        strengths_mpa,
        tool_names,
    })
}

/// Per item (a servo period, or a step of the closed loop) with path advance
/// `advance(p)`, the window `(a, b)` of items its value is resolved over
/// (MODEL.md §2.3): an item of a run (`member[p]`; item p continues the run of
/// p − 1 where `joins(p)`) that advances less than one grid cell `cell_mm`
/// gets the shortest run of items centred on it, within its run, that covers
/// `window_mm` of path (or the whole run); every other item, itself. Each
/// item's window is given to `each` in item order, not held as a list (16 B
/// an item), nor is each item's run end (8 B: found by walking the run
/// once); item p advances `advance(p)` (made where it is read, not a list
/// beside the caller's: 8 B an item).
fn sub_cell_windows(
    advance: impl Fn(usize) -> f64,
    member: &[bool],
    joins: impl Fn(usize) -> bool,
    cell_mm: f64,
    window_mm: f64,
    mut each: impl FnMut(usize, (usize, usize)),
) {
    let n = member.len();
    let mut adv = vec![0.0; n + 1];
    for p in 0..n {
        adv[p + 1] = adv[p] + advance(p);
    }
    // The last item of the run the item last looked at lies in (items up to
    // it are members that join the item before).
    let mut known_end: Option<usize> = None;
    let mut run_start = 0;
    for p in 0..n {
        if !member[p] {
            run_start = p + 1;
            each(p, (p, p));
            continue;
        }
        if p > run_start && !joins(p) {
            run_start = p;
        }
        if advance(p) >= cell_mm {
            each(p, (p, p));
            continue;
        }
        let run_end = match known_end {
            Some(end) if p <= end => end,
            _ => {
                let mut end = p;
                while end + 1 < n && member[end + 1] && joins(end + 1) {
                    end += 1;
                }
                *known_end.insert(end)
            }
        };
        let window = |k: usize| (p.saturating_sub(k).max(run_start), (p + k).min(run_end));
        let covers = |k: usize| {
            let (a, b) = window(k);
            adv[b + 1] - adv[a] >= window_mm
        };
        // Smallest half-width that covers the window (or the whole run).
        // (So the windows these items are given start in order: a later
        // item q of the run is covered at p's half-width k plus q − p, a
        // window that holds p's, and one of a later run starts past p's.)
        let k_max = (p - run_start).max(run_end - p);
        let (mut lo, mut hi) = (0, k_max);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if covers(mid) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        each(p, window(lo));
    }
}

/// Sums of a sequence's terms over windows of it, each the difference of two
/// running sums from the first term, `prefix[b + 1] − prefix[a]` a component:
/// the same numbers as from prefix sums held whole, made in one pass over the
/// terms in order that holds only the running sums from the start of the
/// window last asked for to the furthest end reached (the closed
/// loop's windows of sub-cell steps span a few steps of a million). Windows
/// are asked for in order of their starts; one that starts before the window
/// before sums again from the first term (the same numbers, at that cost).
struct WindowSums<const K: usize, T: Fn(usize) -> [f64; K]> {
    /// Term `j` of the sequence.
    term: T,
    /// The index of `held[0]` among the running sums (running sum `j`: the
    /// terms before `j`).
    first: usize,
    /// Running sums `first..first + held.len()`, never empty.
    held: std::collections::VecDeque<[f64; K]>,
}

impl<const K: usize, T: Fn(usize) -> [f64; K]> WindowSums<K, T> {
    /// Before any term is summed.
    fn new(term: T) -> Self {
        WindowSums {
            term,
            first: 0,
            held: std::collections::VecDeque::from([[0.0; K]]),
        }
    }

    /// The sums of terms `a..=b`.
    fn over(&mut self, a: usize, b: usize) -> [f64; K] {
        if a < self.first {
            self.first = 0;
            self.held.clear();
            self.held.push_back([0.0; K]);
        }
        loop {
            // Running sums before `a` are read no more (the last one made is
            // kept: the next is made from it).
            while self.first < a && self.held.len() > 1 {
                self.held.pop_front();
                self.first += 1;
            }
            let last = self.first + self.held.len() - 1;
            if last > b {
                break;
            }
            let sum = *self.held.back().expect("never empty");
            let term = (self.term)(last);
            self.held
                .push_back(std::array::from_fn(|c| sum[c] + term[c]));
        }
        let (lo, hi) = (self.held[a - self.first], self.held[b + 1 - self.first]);
        std::array::from_fn(|c| hi[c] - lo[c])
    }
}

/// A step's terms of the closed loop's window sums (`WindowSums`): its
/// weight `w` (its advance where the loop seeks its offset, else 0) times
/// its residual g − x, its offset x and g; `w`; and its advance.
fn residual_terms(w: f64, g: f64, x: f64, advance_mm: f64) -> [f64; 5] {
    [w * (g - x), w * x, w * g, w, advance_mm]
}

/// A sub-cell step's window's path-weighted mean residual |r̄| less the
/// grid's resolution of it, |ḡ|·grid/path, and mean offset |x̄| (MODEL.md
/// §5.1), from the window's sums of `residual_terms`; `None` where no step
/// of the window is weighed.
fn window_residual(sums: [f64; 5], grid_mm: f64) -> Option<(f64, f64)> {
    let [sum_r, sum_x, sum_g, w, path] = sums;
    (w > 0.0).then(|| {
        let resolution = (sum_g / w).abs() * grid_mm / path;
        let rw = ((sum_r / w).abs() - resolution).max(0.0);
        let xw = (sum_x / w).abs();
        (rw, xw)
    })
}

/// `range` widened to the finite values of `error_um` (a map's least and
/// greatest error from `[0, 0]`).
fn error_range_um(error_um: &[f32], range: [f64; 2]) -> [f64; 2] {
    error_um
        .iter()
        .filter(|e| e.is_finite())
        .map(|&e| f64::from(e))
        .fold(range, |[lo, hi], e| {
            [if e < lo { e } else { lo }, if e > hi { e } else { hi }]
        })
}

/// The per-column results of a run on a tiled stock, written band by band
/// into the `.npy` grid in `dir` (ARCHITECTURE.md "Large stocks"). Each band
/// of the initial stock is made again with halo rows on each side (the error
/// map's surface normals and its clamp to the stock look that far), swept
/// with the final pass's steps (a column's material depends only on the
/// steps, so it is the whole stock's column), and its own rows of `top_mm`,
/// `last_step` and `error_um` are appended to the files. Sets the run's
/// volumes (summed row by row in order, as the whole stock's) and error range.
/// With no `dir` nothing is written: the bands are made and swept for the
/// volumes and the error range alone (`optimize`'s program as given).
pub fn write_tiled_columns(
    run: &mut Run,
    tiling: &crate::input::stock::Tiling,
    tools: &ToolSet,
    dir: Option<&Path>,
) -> Result<()> {
    let grid = tiling.grid;
    let (tool_of_step, options) = sweep_setup(tools, &run.steps)?;
    // The final pass's steps: the rigid ones, or moved by the loop's offsets.
    let steps: Vec<dexel::Step> = if run.closed_loop.passes > 1 {
        let offsets_mm: Vec<[f64; 2]> = run
            .offsets_um
            .iter()
            .map(|&[x, y]| [1e-3 * x, 1e-3 * y])
            .collect();
        (0..run.steps.len())
            .map(|i| offset_step(&run.steps, &offsets_mm, i))
            .collect()
    } else {
        run.steps.iter().map(|s| s.step).collect()
    };
    let largest_um = |v: &[[f64; 2]]| {
        v.iter()
            .map(|&[x, y]| x.hypot(y))
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max)
    };
    let reach_mm = 1e-3 * (largest_um(&run.model_um) + largest_um(&run.offsets_um));
    let halo = (reach_mm / grid.spacing_mm).ceil() as usize + 2;
    let mut writer = match dir {
        None => None,
        Some(dir) => Some(
            export::ColumnGridWriter::begin(dir, &GridInfo::of(&grid).export(), &run_grid_arrays())
                .map_err(grid_error(dir))?,
        ),
    };
    let tools_list = tools.tools();
    let (mut initial_mm, mut final_mm) = (0.0, 0.0);
    let mut range = [0.0, 0.0];
    // The bands are made in the memory of the ones before.
    let (mut previous_initial, mut previous_last) = (None, None);
    for rows in tiling.bands() {
        let held = rows.start.saturating_sub(halo)..(rows.end + halo).min(grid.ny);
        let initial = tiling.band(held.clone(), previous_initial.take())?;
        let mut last = tiling.band(held.clone(), previous_last.take())?;
        let mut sweep = dexel::Sweep::new(&tools_list, &tool_of_step, &steps, &options)?;
        let label = format!("columns rows {}..{} of {}", rows.start, rows.end, grid.ny);
        let bar = progress::bar(steps.len() as u64, &label);
        sweep.band(&mut last, &|done| bar.set_position(done as u64));
        bar.finish_and_clear();
        drop(sweep);
        let error = clamped_error_map_um(
            Before::Stock(&initial),
            &last,
            &run.offsets_um,
            &run.model_um,
            0..last.last_cut().len(),
        );
        initial_mm = initial.add_row_lengths_mm(rows.clone(), initial_mm);
        final_mm = last.add_row_lengths_mm(rows.clone(), final_mm);
        previous_initial = Some(initial);
        let own = (rows.start - held.start) * grid.nx..(rows.end - held.start) * grid.nx;
        let error = &error[own.clone()];
        range = error_range_um(error, range);
        if let (Some(writer), Some(dir)) = (writer.as_mut(), dir) {
            let tops = last.top_heights_at(own.clone());
            let steps_cut = last_steps(&last.last_cut()[own]);
            writer
                .write_rows(&[
                    export::NpyValues::F32(&tops),
                    export::NpyValues::I32(&steps_cut),
                    export::NpyValues::F32(error),
                ])
                .map_err(grid_error(dir))?;
        }
        previous_last = Some(last);
    }
    if let (Some(writer), Some(dir)) = (writer, dir) {
        writer.finish().map_err(grid_error(dir))?;
    }
    let area = grid.cell_area_mm2();
    run.initial_volume_mm3 = initial_mm * area;
    run.final_volume_mm3 = final_mm * area;
    run.error_range_um = Some(range);
    Ok(())
}

/// The arrays of the column grid every run writes (`top_mm`, `last_step`,
/// `error_um`), as [`export::ColumnGridWriter::begin`] takes them (no values).
fn run_grid_arrays() -> Vec<export::GridArray<'static>> {
    let meta = |name, unit, meaning, values| export::GridArray {
        name,
        unit,
        meaning,
        values,
    };
    vec![
        meta("top_mm", "mm", TOP_MEANING, export::NpyValues::F32(&[])),
        meta(
            "last_step",
            "1",
            LAST_STEP_MEANING,
            export::NpyValues::I32(&[]),
        ),
        meta("error_um", "µm", ERROR_MEANING, export::NpyValues::F32(&[])),
    ]
}

/// An error of writing the column grid into `dir`, with the folder named.
fn grid_error(dir: &Path) -> impl Fn(export::Error) -> Error + Copy + '_ {
    move |e| Error::from(e).context(format!("cannot write the column grid in {}", dir.display()))
}

/// `last_step` of the column grid: the step that last cut each column, −1 if none.
fn last_steps(last_cut: &[u32]) -> Vec<i32> {
    last_cut
        .iter()
        .map(|&s| if s == NEVER_CUT { -1 } else { s as i32 })
        .collect()
}

const TOP_MEANING: &str = "top of the material after the run; NaN where the column holds none";
const LAST_STEP_MEANING: &str =
    "index of the step (row of steps.csv) that last cut the column; -1 if never cut";
const ERROR_MEANING: &str =
    "predicted shape error from tool deflection, + material left; NaN where not cut";
const DESIGN_MEANING: &str =
    "final surface minus the design model, + stock left, - gouge; NaN outside the design";
const LINE_MEANING: &str = "program line of the step that last cut the column; -1 if never cut";

/// The initial stock's columns as the error map reads them: a stock (or a
/// band of rows) held, or the closed form it was made of, on its grid.
#[derive(Clone, Copy)]
enum Before<'a> {
    Stock(&'a Stock),
    Solid(&'a dexel::Solid, &'a dexel::Grid),
}

impl Before<'_> {
    fn grid(&self) -> &dexel::Grid {
        match self {
            Before::Stock(stock) => stock.grid(),
            Before::Solid(_, grid) => grid,
        }
    }

    /// Whether the point `p` (mm) lies in the material (the column whose
    /// cell holds its XY; outside the grid or the rows held: no).
    fn in_material(&self, p: [f64; 3]) -> bool {
        let g = self.grid();
        let fx = ((p[0] - g.x0_mm) / g.spacing_mm).floor();
        let fy = ((p[1] - g.y0_mm) / g.spacing_mm).floor();
        let rows = match self {
            Before::Stock(stock) => stock.rows(),
            Before::Solid(_, grid) => 0..grid.ny,
        };
        if !(fx >= 0.0 && fy >= rows.start as f64 && fx < g.nx as f64 && fy < rows.end as f64) {
            return false;
        }
        let z = p[2] as f32;
        let (ix, iy) = (fx as usize, fy as usize);
        let inside = |c: dexel::Column| c.intervals().any(|[lo, hi]| lo <= z && z <= hi);
        match self {
            Before::Stock(stock) => inside(stock.column(ix, iy)),
            Before::Solid(solid, grid) => inside(solid.column(grid, ix, iy)),
        }
    }
}

/// Thickness of `initial`'s material from `p` along the unit direction `n`,
/// mm, looked for up to `max_mm` (returned when the material goes on): the
/// stock that was there outside the final surface point `p` (MODEL.md §5).
/// Marches in quarter cells, then bisects the crossing to 1e-6 mm.
fn material_along_mm(initial: Before, p: [f64; 3], n: [f64; 3], max_mm: f64) -> f64 {
    let at = |t: f64| [p[0] + t * n[0], p[1] + t * n[1], p[2] + t * n[2]];
    if !initial.in_material(p) {
        return 0.0;
    }
    let ds = 0.25 * initial.grid().spacing_mm;
    let mut t_in = 0.0;
    while t_in < max_mm {
        let t_next = (t_in + ds).min(max_mm);
        if !initial.in_material(at(t_next)) {
            let mut t_out = t_next;
            while t_out - t_in > 1e-6 {
                let mid = 0.5 * (t_in + t_out);
                if initial.in_material(at(mid)) {
                    t_in = mid;
                } else {
                    t_out = mid;
                }
            }
            return t_in;
        }
        t_in = t_next;
    }
    max_mm
}

/// Predicted shape error of the columns `columns` (indices into `last`'s
/// columns), µm (MODEL.md §5), positive = material left, NaN where no step
/// cut; each column's is its own (a map made block by block is the whole
/// one bit for bit). `applied_um` is the offset each step was swept
/// with, `model_um` the deflection its removal causes. The error is the model
/// deflection projected on the outward normal of the final surface; where it
/// says more material is left than the sweep's offset made (`model > applied`
/// along the normal), the excess is clamped to the stock that was there: the
/// initial stock's thickness outside the final surface along the normal.
fn clamped_error_map_um(
    initial: Before,
    last: &Stock,
    applied_um: &[[f64; 2]],
    model_um: &[[f64; 2]],
    columns: std::ops::Range<usize>,
) -> Vec<f32> {
    let grid = *last.grid();
    let rows = last.rows();
    // The tops and normals of the final surface asked column by column, not
    // held (12 B + 4 B a column, 77 MB at 2 200 × 2 200 columns).
    let top = |ix: usize, iy: usize| last.top_or_nan_at(iy * grid.nx + ix);
    columns
        .into_par_iter()
        .map(|c| {
            let step = last.last_cut()[c];
            if step == NEVER_CUT {
                return f32::NAN;
            }
            let (ix, iy) = (c % grid.nx, c / grid.nx);
            let n = cutting::surface_normal_at(top, grid.nx, rows.len(), ix, iy, grid.spacing_mm)
                .map(f64::from);
            if n.iter().any(|v| v.is_nan()) {
                return f32::NAN;
            }
            let step = step as usize;
            let applied = cutting::surface_error_um(applied_um[step], n);
            let model = cutting::surface_error_um(model_um[step], n);
            if model <= applied {
                return model as f32;
            }
            let p = [
                grid.x_mm(ix),
                grid.y_mm(rows.start + iy),
                f64::from(top(ix, iy)),
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let unit = n.map(|v| v / len);
            let room_um = 1e3 * material_along_mm(initial, p, unit, 1e-3 * (model - applied));
            (applied + room_um.min(model - applied)) as f32
        })
        .collect()
}

/// Per-step force, power and deflection (MODEL.md §3, §4), each step with
/// its tool's model; a step shorter than a grid cell (`grid_mm`) has the
/// load of the steady cut around it (MODEL.md §1.6).
pub fn loads(
    tools: &ToolSet,
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
    grid_mm: f64,
) -> Vec<StepLoad> {
    loads_as(tools, tool_of_step, record, steps, grid_mm, |l, _| *l)
}

/// What `of(load, step)` makes of each step's load of [`loads`] (the
/// closed loop's passes keep each step's deflection across its path, 8 B,
/// not its load, 104 B).
fn loads_as<T>(
    tools: &ToolSet,
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
    grid_mm: f64,
    of: impl Fn(&StepLoad, usize) -> T,
) -> Vec<T> {
    let mut out: Vec<T> = steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let model = &tools.entries[tool_of_step[i]].model;
            let load = model.step_load(&cutting::StepRemoval {
                volume_mm3: record.volume_mm3(i),
                band_volumes_mm3: record.band_volumes_mm3(i),
                contact_resultant: record.contact_resultant(i),
                chip_edge_area_mm2: record.chip_edge_area_mm2(i),
                volume_over_radius_mm2: record.volume_over_radius_mm2(i),
                dt_s: s.dt_s,
            });
            of(&load, i)
        })
        .collect();
    crate::subcell::window_loads(
        |i, load| out[i] = of(&load, i),
        tools,
        tool_of_step,
        record,
        steps,
        grid_mm,
    );
    out
}

/// The step the `tool_breaks` warning describes (MODEL.md §4.4): of the steps
/// whose stress exceeds their tool's rupture strength (`ruptures_mpa`, per
/// step), the one of the highest stress (the warning's value; the first of
/// equals), with its stress over its rupture strength. Its tool, line, force
/// and rupture strength are the message's, so that with tools of different
/// strengths the message speaks of one step. `None` when no step breaks.
fn breaking_step(loads: &[StepLoad], rupture_mpa: impl Fn(usize) -> f64) -> Option<(usize, f64)> {
    let mut worst: Option<usize> = None;
    for (i, l) in loads.iter().enumerate() {
        if l.breaks(rupture_mpa(i)) && worst.is_none_or(|w| l.stress_mpa > loads[w].stress_mpa) {
            worst = Some(i);
        }
    }
    worst.map(|w| (w, loads[w].stress_mpa / rupture_mpa(w)))
}

impl Run {
    /// Each servo period in turn (a period split where the motion changes
    /// between rapid and feed counts as a whole), with its MRR resolved to
    /// the grid (MODEL.md §2.3): a period in which the tool advances less
    /// than one grid cell is measured over the shortest run of periods
    /// centred on it (of the same cut, no all-rapid period) that covers
    /// [`SUB_CELL_WINDOW_CELLS`] cells of path, since a column's removal
    /// comes whole in the period in which the edge crosses the column's
    /// centre. The periods are made from per-period columns (their first
    /// step, end of path, prefix sums of removal and time; 37 B a period
    /// with the windows' path sums; a period's own removal and time
    /// summed again from its steps) and handed to `f` one by one as its
    /// window is found, never held as a list (72 B a period more), nor are
    /// the windows (16 B).
    pub fn for_each_period(&self, mut f: impl FnMut(Period)) {
        let g = self.stock.grid().spacing_mm;
        let window_mm = SUB_CELL_WINDOW_CELLS * g;
        // Whether the period of steps i..j cuts, and its own removal and
        // time: summed for the prefix sums, and again (the same sums in the
        // same order) where the period is handed over, not held.
        let own = |i: usize, j: usize| {
            let cuts = !self.steps[i..j].iter().all(|s| s.step.rapid);
            // A period that is part feed, part rapid counts its feed parts'
            // removal: what a rapid removes is a collision (rapid_cut warning).
            let (volume_mm3, dt_s) = (i..j).fold((0.0, 0.0), |(v, t), k| {
                let counted = !cuts || !self.steps[k].step.rapid;
                let dv = if counted {
                    self.record.volume_mm3(k)
                } else {
                    0.0
                };
                (v + dv, t + self.steps[k].dt_s)
            });
            (cuts, volume_mm3, dt_s)
        };
        // Per period p: steps first[p]..first[p + 1] (u32), path
        // s_at[p]..s_at[p + 1], whether it cuts, and the prefix sums of
        // removal and time over the periods before it; 29 B a period, each
        // column reserved at its size (8 B more while the windows are found:
        // their path sums; a period's advance is made where it is read).
        let n = crate::motion::periods(&self.steps).count();
        let mut first: Vec<u32> = Vec::with_capacity(n + 1);
        let mut s_at: Vec<f64> = Vec::with_capacity(n + 1);
        let mut cutting: Vec<bool> = Vec::with_capacity(n);
        let (mut volume_sum, mut dt_sum) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        s_at.push(0.0);
        volume_sum.push(0.0);
        dt_sum.push(0.0);
        for std::ops::Range { start: i, end: j } in crate::motion::periods(&self.steps) {
            let (cuts, volume_mm3, dt_s) = own(i, j);
            first.push(u32::try_from(i).expect("fewer than 2³² steps"));
            s_at.push(self.steps[j - 1].s_end_mm);
            cutting.push(cuts);
            volume_sum.push(volume_sum[volume_sum.len() - 1] + volume_mm3);
            dt_sum.push(dt_sum[dt_sum.len() - 1] + dt_s);
        }
        first.push(u32::try_from(self.steps.len()).expect("fewer than 2³² steps"));
        let advance = |p: usize| s_at[p + 1] - s_at[p];
        let each = |p: usize, (a, b): (usize, usize)| {
            let (i, j) = (first[p] as usize, first[p + 1] as usize);
            let (_, volume_mm3, dt_s) = own(i, j);
            let own = Period {
                first_step: i,
                last_step: j - 1,
                s_from_mm: s_at[p],
                s_to_mm: s_at[p + 1],
                volume_mm3,
                dt_s,
                cutting: cutting[p],
                window: (p, p),
            };
            f(if !cutting[p] || advance(p) >= g {
                own
            } else {
                Period {
                    s_from_mm: s_at[a],
                    s_to_mm: s_at[b + 1],
                    volume_mm3: volume_sum[b + 1] - volume_sum[a],
                    dt_s: dt_sum[b + 1] - dt_sum[a],
                    window: (a, b),
                    ..own
                }
            });
        };
        sub_cell_windows(advance, &cutting, |p| cutting[p - 1], g, window_mm, each);
    }

    /// Per step, the MRR of its servo period resolved to the grid ([`Run::for_each_period`]), mm³/s.
    pub fn period_mrr_by_step_mm3_s(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.steps.len()];
        self.for_each_period(|p| out[p.first_step..=p.last_step].fill(p.mrr_mm3_s()));
        out
    }

    /// Per entry of `tools`, the step of that tool with the highest mean
    /// path speed among those that removed material (not rapids): its index,
    /// or None where the tool cuts nothing.
    pub fn top_cutting_step_by_tool(&self, tools: &ToolSet) -> Vec<Option<usize>> {
        let mut top: Vec<Option<usize>> = vec![None; tools.entries.len()];
        for i in 0..self.steps.len() {
            let s = &self.steps[i];
            if s.step.rapid || self.record.volume_mm3(i) <= NOTHING_MM3 {
                continue;
            }
            let k = tools.index_of(s.tool).unwrap_or(0);
            if top[k].is_none_or(|j| s.feed_mm_min > self.steps[j].feed_mm_min) {
                top[k] = Some(i);
            }
        }
        top
    }

    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub fn peak_cutting_feed_mm_min(&self) -> f64 {
        (0..self.steps.len())
            .filter(|&i| !self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .map(|i| self.steps[i].feed_mm_min)
            .fold(0.0, f64::max)
    }

    /// Largest MRR of a servo period resolved to the grid, mm³/s, over the
    /// periods that are not all rapid: a rapid move that removes stock is a
    /// collision, told by the rapid_cut warning with its volume and line, not
    /// a removal rate the feed sets.
    pub fn peak_period_mrr_mm3_s(&self) -> f64 {
        let mut peak = 0.0;
        self.for_each_period(|p| {
            if p.cutting {
                peak = f64::max(peak, p.mrr_mm3_s());
            }
        });
        peak
    }

    /// Step `i` breaks its tool: its stress exceeds the tool's rupture
    /// strength (MODEL.md §4.4).
    pub fn breaks(&self, i: usize) -> bool {
        self.loads[i].breaks(self.rupture_strength_mpa_at(i))
    }

    /// The linear beam's deflection of step `i` at the contact height, µm:
    /// its reported deflection, or where the step breaks the tool, the one it
    /// would have if the tool did not break (what a deflection limit scales
    /// with the feed, MODEL.md §4.4).
    pub fn linear_deflection_um(&self, i: usize) -> f64 {
        self.loads[i].linear_deflection_um(self.rupture_strength_mpa_at(i))
    }

    /// The step with the largest reported deflection breaks its tool: the
    /// peak is capped at rupture.
    pub fn peak_deflection_at_rupture(&self) -> bool {
        let mut peak: Option<(usize, f64)> = None;
        for (i, l) in self.loads.iter().enumerate() {
            if peak.is_none_or(|(_, d)| l.deflection_um > d) {
                peak = Some((i, l.deflection_um));
            }
        }
        peak.is_some_and(|(i, _)| self.breaks(i))
    }

    /// The lowest allowable stress of the tools the run uses, MPa.
    pub fn stress_limit_mpa(&self) -> f64 {
        self.strengths_mpa
            .values()
            .map(|s| s[0])
            .fold(f64::INFINITY, f64::min)
    }

    /// Allowable stress of step `i`'s tool, MPa.
    pub fn stress_limit_mpa_at(&self, i: usize) -> f64 {
        self.strengths_mpa[&self.steps[i].tool][0]
    }

    /// Rupture strength of step `i`'s tool, MPa: a step whose stress
    /// exceeds it breaks the tool, and its deflections are those at rupture
    /// (MODEL.md §4.4, [`cutting::StepLoad::at_rupture`]).
    pub fn rupture_strength_mpa_at(&self, i: usize) -> f64 {
        self.strengths_mpa[&self.steps[i].tool][1]
    }

    /// Warnings of this run (MODEL.md §10): rapid moves that cut, shank or
    /// holder contact, a program that removes nothing.
    pub fn warnings(&self) -> Warnings {
        let mut out = Warnings::default();
        let (mut rapid, mut shank) = (LineTally::new(), LineTally::new());
        let (mut stress, mut breaks) = (LineTally::new(), LineTally::new());
        for (i, s) in self.steps.iter().enumerate() {
            if self.loads[i].stress_mpa > self.stress_limit_mpa_at(i) {
                warnings::tally(&mut stress, s.line, self.loads[i].stress_mpa);
            }
            if self.breaks(i) {
                warnings::tally(&mut breaks, s.line, self.loads[i].stress_mpa);
            }
            let v = self.record.volume_mm3(i);
            if s.step.rapid && v > NOTHING_MM3 {
                warnings::tally(&mut rapid, s.line, v);
            }
            let sv = self.record.shank_volume_mm3(i);
            if sv > NOTHING_MM3 {
                warnings::tally(&mut shank, s.line, sv);
            }
        }
        out.from_lines(WarningKind::RapidCut, &rapid, "mm³", true, |v, lines| {
            format!("rapid moves (G0) removed {v:.3} mm³ of stock at {lines}: a collision on a real machine")
        });
        out.from_lines(WarningKind::ShankContact, &shank, "mm³", true, |v, lines| {
            format!("the tool above its flute length (shank or holder) removed {v:.3} mm³ at {lines}: raise the flute length or stick-out, or change the program")
        });
        // The allowable stress of the step the message quotes (the highest stress over
        // its own tool's limit), not the lowest of all tools.
        let limit = (0..self.steps.len())
            .filter(|&i| self.loads[i].stress_mpa > self.stress_limit_mpa_at(i))
            .max_by(|&a, &b| {
                self.loads[a]
                    .stress_mpa
                    .total_cmp(&self.loads[b].stress_mpa)
            })
            .map_or_else(|| self.stress_limit_mpa(), |i| self.stress_limit_mpa_at(i));
        let rigid_kept = if self.closed_loop.rigid_kept {
            "; the closed loop keeps the rigid tool's force, deflection and error for it (no elastic balance, docs/MODEL.md §5.1)"
        } else {
            ""
        };
        out.from_lines(WarningKind::Force, &stress, "MPa", false, |v, lines| {
            format!("the cutting force and torque stress the tool to {v:.0} MPa at {lines}, above the allowable {limit:.0} MPa ([tool] stress_limit_mpa, docs/MODEL.md §4.4): lower the feed or the engagement, or use a shorter or stiffer tool{rigid_kept}")
        });
        if let Some((w, ratio)) = breaking_step(&self.loads, |i| self.rupture_strength_mpa_at(i)) {
            let rupture = self.rupture_strength_mpa_at(w);
            let (tool, line, force) = (
                &self.tool_names[&self.steps[w].tool],
                self.steps[w].line,
                self.loads[w].force_n,
            );
            out.from_lines(WarningKind::ToolBreaks, &breaks, "MPa", false, |v, lines| {
                format!("the tool breaks: the cutting force and torque stress {tool} to {v:.0} MPa at {lines}, {ratio:.1}× its rupture strength of {rupture:.0} MPa ([tool] rupture_strength_mpa, docs/MODEL.md §4.4; {force:.1} N at line {line}); the deflection and error of these steps are the tool's elastic ones at rupture, not the linear beam's: lower the feed or the engagement, or use a stronger tool")
            });
        }
        if self.closed_loop.enabled && !self.closed_loop.converged {
            let mut stalled = LineTally::new();
            for &(i, r) in &self.closed_loop.unconverged {
                warnings::tally(&mut stalled, self.steps[i].line, r);
            }
            let passes = self.closed_loop.passes;
            let steps = self.closed_loop.unconverged.len();
            // The columns of the final surface those steps made (their error
            // map is uncertain by their residual); none known for a tiled stock.
            let mut left = vec![false; self.steps.len()];
            for &(i, _) in &self.closed_loop.unconverged {
                left[i] = true;
            }
            let columns = self
                .stock
                .last_cut()
                .iter()
                .filter(|&&c| c != NEVER_CUT && left[c as usize])
                .count();
            let cell = self.stock.grid().spacing_mm;
            let plural = if steps == 1 { "" } else { "s" };
            let surface = if columns > 0 {
                format!(
                    " and the error map of the {columns} columns ({:.3} mm²) whose surface they made",
                    columns as f64 * cell * cell
                )
            } else {
                String::new()
            };
            out.from_lines(WarningKind::ClosedLoop, &stalled, "µm", false, |v, lines| {
                format!("the closed loop did not settle at {steps} step{plural} after {passes} sweeps, at {lines} (docs/MODEL.md §5.1): there the tool's equilibrium lies between the offset tried and the deflection it caused, up to {v:.1} µm apart, so the deflection there{surface} are uncertain by up to {v:.1} µm, and their force in proportion (elsewhere the loop met 0.5 µm + 2 %); the error map stays within the stock")
            });
        }
        if self.record.total_volume_mm3() <= NOTHING_MM3 {
            out.push(warnings::Warning {
                kind: WarningKind::NoRemoval,
                line: None,
                value: 0.0,
                unit: "mm³".into(),
                steps: self.steps.len(),
                lines: Vec::new(),
                message: "the program removes no material: check the stock position, the work offsets and [machine] start".into(),
            });
        }
        out
    }

    /// Largest mean MRR over any run of consecutive steps lasting at least
    /// `window_s` and covering at least `window_mm` of path (a run shorter than
    /// that over the whole program counts as a whole).
    pub fn peak_windowed_mrr_mm3_s(&self, window_s: f64, window_mm: f64) -> f64 {
        let lengths: Vec<f64> = self
            .steps
            .iter()
            .map(|s| nalgebra::distance(&s.step.from_mm.into(), &s.step.to_mm.into()))
            .collect();
        let (mut first, mut vol, mut time, mut len, mut peak) = (0, 0.0, 0.0, 0.0, 0.0f64);
        for (i, s) in self.steps.iter().enumerate() {
            vol += self.record.volume_mm3(i);
            time += s.dt_s;
            len += lengths[i];
            while first < i
                && time - self.steps[first].dt_s >= window_s
                && len - lengths[first] >= window_mm
            {
                vol -= self.record.volume_mm3(first);
                time -= self.steps[first].dt_s;
                len -= lengths[first];
                first += 1;
            }
            let full = time >= window_s && len >= window_mm;
            if (full || (first == 0 && i + 1 == self.steps.len())) && time > 0.0 {
                peak = peak.max(vol / time);
            }
        }
        peak
    }

    /// The headline numbers of the run.
    pub fn summary(&self) -> Summary {
        let n = self.steps.len();
        let [min_error_um, max_error_um] = self
            .error_range_um
            .unwrap_or_else(|| error_range_um(&self.error_map_um(), [0.0, 0.0]));
        let final_volume_mm3 = self.final_volume_mm3;
        let collisions: Vec<usize> = (0..n)
            .filter(|&i| self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .collect();
        Summary {
            initial_volume_mm3: self.initial_volume_mm3,
            final_volume_mm3,
            removed_volume_mm3: self.record.total_volume_mm3(),
            cycle_time_s: self.steps.last().map_or(0.0, |s| s.t_end_s),
            peak_mrr_mm3_s: self.peak_period_mrr_mm3_s(),
            peak_mrr_windowed_mm3_s: self.peak_windowed_mrr_mm3_s(
                MRR_WINDOW_S,
                MRR_WINDOW_CELLS * self.stock.grid().spacing_mm,
            ),
            peak_force_n: self.loads.iter().map(|l| l.force_n).fold(0.0, f64::max),
            peak_power_w: self.loads.iter().map(|l| l.power_w).fold(0.0, f64::max),
            peak_torque_nm: self.loads.iter().map(|l| l.torque_nm).fold(0.0, f64::max),
            peak_deflection_um: self
                .loads
                .iter()
                .map(|l| l.deflection_um)
                .fold(0.0, f64::max),
            peak_deflection_at_rupture: self.peak_deflection_at_rupture(),
            tool_breaks_steps: (0..n).filter(|&i| self.breaks(i)).count(),
            peak_cutting_feed_mm_min: self.peak_cutting_feed_mm_min(),
            peak_tip_deflection_um: self
                .loads
                .iter()
                .map(|l| l.tip_deflection_um)
                .fold(0.0, f64::max),
            rigid_peak_deflection_um: self.rigid_peak_deflection_um,
            max_error_um,
            min_error_um,
            closed_loop: self.closed_loop.enabled,
            closed_loop_converged: self.closed_loop.converged,
            closed_loop_passes: self.closed_loop.passes,
            closed_loop_residual_um: self.closed_loop.residual_um,
            closed_loop_unconverged_steps: self.closed_loop.unconverged.len(),
            peak_stress_mpa: self.loads.iter().map(|l| l.stress_mpa).fold(0.0, f64::max),
            stress_limit_mpa: self.stress_limit_mpa(),
            steps: n,
            grid_mm: self.stock.grid().spacing_mm,
            columns: self.stock.grid().len(),
            shank_contact_steps: (0..n)
                .filter(|&i| self.record.shank_volume_mm3(i) > NOTHING_MM3)
                .count(),
            rapid_collision_steps: collisions.len(),
            first_collision_line: collisions.first().map(|&i| self.steps[i].line),
            columns_evaluated: self.record.columns_evaluated,
            sweep_time_s: self.sweep_s,
            warnings: self.warnings(),
            tools: self.tool_peaks(),
        }
    }

    /// Peaks per tool, in order of first use.
    pub fn tool_peaks(&self) -> Vec<ToolPeaks> {
        let mut out: Vec<ToolPeaks> = Vec::new();
        let mrr = self.period_mrr_by_step_mm3_s();
        for (i, s) in self.steps.iter().enumerate() {
            let k = match out.iter().position(|p| p.tool == s.tool) {
                Some(k) => k,
                None => {
                    out.push(ToolPeaks {
                        tool: s.tool,
                        steps: 0,
                        removed_volume_mm3: 0.0,
                        time_s: 0.0,
                        peak_mrr_mm3_s: 0.0,
                        peak_force_n: 0.0,
                        peak_deflection_um: 0.0,
                    });
                    out.len() - 1
                }
            };
            let p = &mut out[k];
            p.steps += 1;
            p.removed_volume_mm3 += self.record.volume_mm3(i);
            p.time_s += s.dt_s;
            if !s.step.rapid {
                p.peak_mrr_mm3_s = p.peak_mrr_mm3_s.max(mrr[i]);
            }
            p.peak_force_n = p.peak_force_n.max(self.loads[i].force_n);
            p.peak_deflection_um = p.peak_deflection_um.max(self.loads[i].deflection_um);
        }
        out
    }

    /// The predicted shape error of every column, µm (MODEL.md §5): the map
    /// held, or made of the final stock (empty for a tiled stock, whose map
    /// [`write_tiled_columns`] writes band by band).
    pub fn error_map_um(&self) -> std::borrow::Cow<'_, [f32]> {
        match &self.error_map {
            ErrorMap::Held(error) => std::borrow::Cow::Borrowed(error),
            ErrorMap::Made(..) => self.error_map_at(0..self.stock.grid().len()),
        }
    }

    /// The predicted shape error of the columns `at` (indices into the
    /// grid), µm: those of [`Run::error_map_um`].
    pub fn error_map_at(&self, at: std::ops::Range<usize>) -> std::borrow::Cow<'_, [f32]> {
        match &self.error_map {
            ErrorMap::Held(error) => std::borrow::Cow::Borrowed(&error[at]),
            ErrorMap::Made(solid, grid) => std::borrow::Cow::Owned(clamped_error_map_um(
                Before::Solid(solid, grid),
                &self.stock,
                &self.offsets_um,
                &self.model_um,
                at,
            )),
        }
    }

    /// Write the per-column results into the folder `dir`: final surface
    /// (`top_mm`, the stock's top heights), last cutting step, predicted
    /// error, and with a design model the distance to it and the program line
    /// that last cut. Always as the compact grid (`columns.json` and one
    /// `.npy` array each), made and written block of rows by block of rows
    /// from the stock (no whole-grid copy of the tops or last steps: issue
    /// 16); also as `columns.csv` when `csv` is set.
    pub fn write_columns(
        &self,
        dir: &Path,
        design_diff_um: Option<&[f32]>,
        line: Option<&[i32]>,
        csv: bool,
    ) -> Result<()> {
        let last_cut = self.stock.last_cut();
        let grid = GridInfo::of(self.stock.grid()).export();
        let context = grid_error(dir);
        let meta = |name, unit, meaning, values| export::GridArray {
            name,
            unit,
            meaning,
            values,
        };
        let mut arrays = run_grid_arrays();
        if let ErrorMap::Held(error) = &self.error_map {
            grid.check_len("grid array \"error_um\"", error.len())
                .map_err(context)?;
        }
        if let Some(d) = design_diff_um {
            grid.check_len("grid array \"design_um\"", d.len())
                .map_err(context)?;
            arrays.push(meta(
                "design_um",
                "µm",
                DESIGN_MEANING,
                export::NpyValues::F32(&[]),
            ));
        }
        if let Some(l) = line {
            grid.check_len("grid array \"line\"", l.len())
                .map_err(context)?;
            arrays.push(meta("line", "1", LINE_MEANING, export::NpyValues::I32(&[])));
        }
        let mut writer = export::ColumnGridWriter::begin(dir, &grid, &arrays).map_err(context)?;
        for at in row_blocks(self.stock.grid()) {
            let tops = self.stock.top_heights_at(at.clone());
            let last = last_steps(&last_cut[at.clone()]);
            let error = self.error_map_at(at.clone());
            let mut values = vec![
                export::NpyValues::F32(&tops),
                export::NpyValues::I32(&last),
                export::NpyValues::F32(&error),
            ];
            if let Some(d) = design_diff_um {
                values.push(export::NpyValues::F32(&d[at.clone()]));
            }
            if let Some(l) = line {
                values.push(export::NpyValues::I32(&l[at.clone()]));
            }
            writer.write_rows(&values).map_err(context)?;
        }
        writer.finish().map_err(context)?;
        if !csv {
            return Ok(());
        }
        // columns.csv: integers as numbers, "no value" as an empty field.
        let as_f32 = |v: &[i32]| -> Vec<f32> {
            v.iter()
                .map(|&i| if i < 0 { f32::NAN } else { i as f32 })
                .collect()
        };
        let tops = self.stock.top_heights();
        let last_f = as_f32(&last_steps(last_cut));
        let line_f = line.map(as_f32);
        let error = self.error_map_um();
        let mut columns: Vec<(&str, &[f32])> = vec![
            ("top_mm", &tops),
            ("last_step", &last_f),
            ("error_um", &error),
        ];
        if let Some(d) = design_diff_um {
            columns.push(("design_um", d));
        }
        if let Some(l) = &line_f {
            columns.push(("line", l));
        }
        let path = dir.join("columns.csv");
        export::write_column_csv(&path, &grid, &columns)
            .map_err(|e| Error::Export(e).context(format!("cannot write {}", path.display())))
    }
}

/// Rows of the column grid made and written at a time by [`Run::write_columns`]
/// (and of an error map made where it is read, [`ErrorMap::Made`]).
const WRITE_BLOCK_ROWS: usize = 64;

/// The columns of `grid` (indices) in blocks of [`WRITE_BLOCK_ROWS`] rows, in order.
fn row_blocks(grid: &dexel::Grid) -> impl Iterator<Item = std::ops::Range<usize>> {
    let (len, block) = (grid.len(), grid.nx.max(1) * WRITE_BLOCK_ROWS);
    (0..len)
        .step_by(block)
        .map(move |start| start..(start + block).min(len))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed bracket whose lower bound the sweep measured is held there
    /// (eq. 5.1c): the trials stay at the lower bound sweep after sweep, and
    /// the bracket counts as closed though its upper bound grows old. Trying
    /// the bound measured longer ago (the rule before eq. 5.1c) would go to
    /// the upper bound at the first sweep.
    #[test]
    fn a_closed_bracket_measured_at_its_lower_bound_is_held_there() {
        let (lo, hi, from_um, x_um) = (0.5, 0.5 + 1e-7, 10.0, 5.0);
        let mut f = Fraction {
            phi: lo,
            lo,
            hi,
            w_lo: 3.0,
            w_hi: -3.0,
            lo_pass: 4,
            hi_pass: 5,
            replaced: 1,
            width_mark: 1e-7,
            since_halved: 0,
        };
        // A residual well out of tolerance, of the lower bound's sign.
        let r_um = 3.0;
        assert!(r_um > LOOP_TOL_UM + LOOP_REL_TOL * x_um);
        for pass in 6..12 {
            f.observe(r_um, from_um, pass);
            assert_eq!(f.next(r_um, x_um, from_um, pass), lo, "sweep {pass}");
            assert!(f.closed(from_um, pass), "sweep {pass}");
        }
        // An open bracket is not held: its next trial lies inside it.
        let mut wide = Fraction { hi: 0.9, ..f };
        wide.observe(r_um, from_um, 12);
        let next = wide.next(r_um, x_um, from_um, 12);
        assert!(next > lo && next < 0.9, "{next}");
    }

    /// The offset cap of the brackets' tests, µm: far beyond their roots.
    const CAP_UM: f64 = 5000.0;

    /// Two tools: an HSS one (σ_R 3000 MPa) at 4000 MPa, 1.33× its rupture
    /// strength, and a carbide one (3500 MPa) at 4200 MPa, 1.2×. The warning's
    /// value is the highest stress, 4200 MPa: the step it describes is the
    /// carbide tool's, with its ratio 1.2 (it named the HSS tool's step, 1.3×
    /// of 3000 MPa, beside 4200 MPa, a stress that tool never reached).
    #[test]
    fn the_breaking_step_named_is_the_one_of_the_highest_stress() {
        let load = |stress_mpa| StepLoad {
            stress_mpa,
            ..StepLoad::default()
        };
        let loads = [load(100.0), load(4000.0), load(4200.0), load(4200.0)];
        let ruptures = [3000.0, 3000.0, 3500.0, 3500.0];
        let rupture = |i: usize| ruptures[i];
        assert_eq!(breaking_step(&loads, rupture), Some((2, 1.2)));
        assert_eq!(breaking_step(&loads[..2], rupture), Some((1, 4.0 / 3.0)));
        assert_eq!(breaking_step(&loads[..1], rupture), None);
        assert_eq!(breaking_step(&[], rupture), None);
    }

    #[test]
    fn loop_direction_drops_the_component_along_the_motion() {
        // Deflection (3, 4) on a move along +x: only +y is left.
        assert_eq!(loop_direction(3.0, 4.0, [2.0, 0.0]), [0.0, 1.0]);
        // Along a diagonal, (1, 0) keeps its part across it: (1, −1)/√2.
        let d = loop_direction(1.0, 0.0, [1.0, 1.0]);
        let r = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (d[0] - r).abs() < 1e-12 && (d[1] + r).abs() < 1e-12,
            "{d:?}"
        );
        // A plunge (no XY motion) keeps the whole deflection; nothing left: zero.
        assert_eq!(loop_direction(0.0, -2.0, [0.0, 0.0]), [0.0, -1.0]);
        assert_eq!(loop_direction(5.0, 0.0, [1.0, 0.0]), [0.0, 0.0]);
        // An even plunge's round-off (blendercam_Op_Cutout_Layers: 2e-15 µm)
        // has no direction; a nanometre and a half has one where the step
        // moves in XY.
        assert_eq!(loop_direction(1.2e-15, -1.5e-15, [0.0, 0.0]), [0.0, 0.0]);
        assert_eq!(
            loop_direction(0.0, LOOP_NO_SIDE_LOAD_UM, [1.0, 0.0]),
            [0.0, 0.0]
        );
        assert_eq!(loop_direction(0.0, 1.5e-3, [1.0, 0.0]), [0.0, 1.0]);
        // At one point (no XY motion, eq. 5.1d) up to the loop's tolerance
        // has none: fusion_led_floor_light_holes' plunges at 0.11…0.14 µm.
        assert_eq!(loop_direction(0.0, 0.135, [0.0, 0.0]), [0.0, 0.0]);
        assert_eq!(
            loop_direction(0.0, LOOP_AT_POINT_SIDE_LOAD_UM, [0.0, 0.0]),
            [0.0, 0.0]
        );
        assert_eq!(loop_direction(0.0, 0.6, [0.0, 0.0]), [0.0, 1.0]);
    }

    /// [`Run::for_each_period`] as it was before its own removal and time
    /// were summed again from the steps (held in columns, `first` as usize).
    fn periods_of_held_columns(run: &Run, mut f: impl FnMut(Period)) {
        let g = run.stock.grid().spacing_mm;
        let window_mm = SUB_CELL_WINDOW_CELLS * g;
        // Own values per period p: steps first[p]..first[p + 1], path
        // s_at[p]..s_at[p + 1].
        let mut first: Vec<usize> = Vec::new();
        let mut s_at: Vec<f64> = vec![0.0];
        let (mut volume, mut dt_s, mut cutting) = (Vec::new(), Vec::new(), Vec::new());
        for std::ops::Range { start: i, end: j } in crate::motion::periods(&run.steps) {
            let cuts = !run.steps[i..j].iter().all(|s| s.step.rapid);
            // A period that is part feed, part rapid counts its feed parts'
            // removal: what a rapid removes is a collision (rapid_cut warning).
            let (volume_mm3, period_dt_s) = (i..j).fold((0.0, 0.0), |(v, t), k| {
                let counted = !cuts || !run.steps[k].step.rapid;
                let dv = if counted {
                    run.record.volume_mm3(k)
                } else {
                    0.0
                };
                (v + dv, t + run.steps[k].dt_s)
            });
            first.push(i);
            s_at.push(run.steps[j - 1].s_end_mm);
            volume.push(volume_mm3);
            dt_s.push(period_dt_s);
            cutting.push(cuts);
        }
        first.push(run.steps.len());
        // Prefix sums of volume and time over periods.
        let n = volume.len();
        let (mut volume_sum, mut dt_sum) = (vec![0.0; n + 1], vec![0.0; n + 1]);
        for p in 0..n {
            volume_sum[p + 1] = volume_sum[p] + volume[p];
            dt_sum[p + 1] = dt_sum[p] + dt_s[p];
        }
        let advance: Vec<f64> = (0..n).map(|p| s_at[p + 1] - s_at[p]).collect();
        let mut windows = Vec::new();
        sub_cell_windows(
            |p| advance[p],
            &cutting,
            |p| cutting[p - 1],
            g,
            window_mm,
            |_, w| windows.push(w),
        );
        for (p, &(a, b)) in windows.iter().enumerate() {
            let own = Period {
                first_step: first[p],
                last_step: first[p + 1] - 1,
                s_from_mm: s_at[p],
                s_to_mm: s_at[p + 1],
                volume_mm3: volume[p],
                dt_s: dt_s[p],
                cutting: cutting[p],
                window: (p, p),
            };
            f(if !cutting[p] || advance[p] >= g {
                own
            } else {
                Period {
                    s_from_mm: s_at[a],
                    s_to_mm: s_at[b + 1],
                    volume_mm3: volume_sum[b + 1] - volume_sum[a],
                    dt_s: dt_sum[b + 1] - dt_sum[a],
                    window: (a, b),
                    ..own
                }
            });
        }
    }

    /// The periods made from their prefix sums, each one's own removal and
    /// time summed again from its steps (`Run::for_each_period`), are those
    /// of the columns held before, bit for bit: a G-code cut at a feed whose
    /// periods advance less than a grid cell (windowed) and more, with
    /// rapids between that split their periods.
    #[test]
    fn periods_summed_again_are_those_of_the_held_columns() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("p.nc"),
            "G0 X-8 Y0 Z5\nG1 Z-1 F300\nG1 X5 F40\nG1 X12 F900\nG0 Z5\nG0 X20\nG1 Z-0.5 F200\nG1 X30 Y3 F60\nG0 Z5\nM2\n",
        )
        .unwrap();
        let job = "[stock]\nkind = \"box\"\nmin = [0, -10, -3]\nmax = [40, 10, 0]\ngrid = 0.1\n\
             [tool]\nkind = \"ball\"\ndiameter = 6\n[program]\npath = \"p.nc\"\n[machine]\nfeed_max = 3000\n";
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        let setup = crate::commands::Setup::load(&dir.path().join("job.toml"), None).unwrap();
        let steps = setup.machine_steps().unwrap();
        assert!(steps.iter().any(|s| s.continues), "no split period");
        let run = run_on(
            StockSource::Whole(setup.stock.clone()),
            &setup.tools,
            steps,
            "p",
        )
        .unwrap();
        let (mut now, mut held) = (Vec::new(), Vec::new());
        run.for_each_period(|p| now.push(p));
        periods_of_held_columns(&run, |p| held.push(p));
        assert_eq!(now.len(), held.len());
        assert!(
            now.iter().any(|p| p.window.0 < p.window.1),
            "no windowed period"
        );
        assert!(now
            .iter()
            .any(|p| p.volume_mm3 > 0.0 && p.window.0 == p.window.1));
        for (a, b) in now.iter().zip(&held) {
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
            assert_eq!(
                [a.s_from_mm, a.s_to_mm, a.volume_mm3, a.dt_s].map(f64::to_bits),
                [b.s_from_mm, b.s_to_mm, b.volume_mm3, b.dt_s].map(f64::to_bits)
            );
        }
    }

    /// A run keeps its tools' allowable stresses and rupture strengths by
    /// tool number, not per step: each step's are its tool's entry's, bit
    /// for bit (what the per-step columns held), for three tools of
    /// different strengths (one breaking where it cuts, one overloaded);
    /// the run's lowest allowable stress is the lowest of the tools it uses
    /// (not of the table's, whose fourth tool it does not use).
    #[test]
    fn a_runs_strengths_are_each_steps_tools() {
        let dir = tempfile::tempdir().unwrap();
        let tool = |n: u32, d: f64, strengths: &str| {
            format!("[[tools]]\nnumber = {n}\nkind = \"flat\"\ndiameter = {d}\nflute_length = 12\nstickout = 30\n{strengths}\n")
        };
        let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n{}{}{}{}\
             [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\n[machine]\nfeed_max = 3000\n",
            tool(1, 6.0, "stress_limit_mpa = 700"),
            tool(2, 4.0, "stress_limit_mpa = 50\nrupture_strength_mpa = 70"),
            tool(3, 3.0, ""),
            tool(4, 2.0, "stress_limit_mpa = 1"),
        );
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        std::fs::write(
            dir.path().join("p.ngc"),
            "G21 G90 G17\nT1 M6 S9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z18 F1200\nG1 X30 Y20\nG0 Z25\n\
             T2 M6 S12000 M3\nG0 X50 Y8\nG1 Z18 F200\nG1 X12 Y10 F1000\nG0 Z25\n\
             T3 M6 S15000 M3\nG0 X20 Y15\nG1 Z19 F250\nG1 X35 F800\nG0 Z25\nM2\n",
        )
        .unwrap();
        let setup = crate::commands::Setup::load(&dir.path().join("job.toml"), None).unwrap();
        let tools = &setup.tools;
        let run = run_on(
            setup.stock_source(),
            tools,
            setup.machine_steps().unwrap(),
            "t",
        )
        .unwrap();
        assert_eq!(run.strengths_mpa.len(), 3);
        for (i, s) in run.steps.iter().enumerate() {
            let entry = &tools.entries[tools.index_of(s.tool).unwrap()];
            assert_eq!(
                [run.stress_limit_mpa_at(i), run.rupture_strength_mpa_at(i)].map(f64::to_bits),
                [entry.stress_limit_mpa, entry.rupture_strength_mpa].map(f64::to_bits),
                "step {i}"
            );
        }
        assert!((1..run.steps.len()).any(|i| run.steps[i].tool != run.steps[i - 1].tool));
        assert!(run.steps.iter().enumerate().any(|(i, _)| run.breaks(i)));
        let lowest = [1, 2, 3].map(|t| tools.entries[tools.index_of(t).unwrap()].stress_limit_mpa);
        assert_eq!(
            run.stress_limit_mpa(),
            lowest.into_iter().fold(f64::INFINITY, f64::min)
        );
        assert_eq!(run.stress_limit_mpa(), 50.0);
    }

    /// [`sub_cell_windows`] as it was before its windows were given one by
    /// one: a list of them, with a list of each item's run end.
    fn sub_cell_windows_listed(
        advance: impl Fn(usize) -> f64,
        member: &[bool],
        joins: impl Fn(usize) -> bool,
        cell_mm: f64,
        window_mm: f64,
    ) -> Vec<(usize, usize)> {
        let n = member.len();
        let mut adv = vec![0.0; n + 1];
        for p in 0..n {
            adv[p + 1] = adv[p] + advance(p);
        }
        // Last item of the run each item lies in.
        let mut run_ends = vec![0; n];
        for p in (0..n).rev() {
            run_ends[p] = if p + 1 < n && member[p + 1] && member[p] && joins(p + 1) {
                run_ends[p + 1]
            } else {
                p
            };
        }
        let mut out: Vec<(usize, usize)> = (0..n).map(|p| (p, p)).collect();
        let mut run_start = 0;
        for p in 0..n {
            if !member[p] {
                run_start = p + 1;
                continue;
            }
            if p > run_start && !joins(p) {
                run_start = p;
            }
            if advance(p) >= cell_mm {
                continue;
            }
            let run_end = run_ends[p];
            let window = |k: usize| (p.saturating_sub(k).max(run_start), (p + k).min(run_end));
            let covers = |k: usize| {
                let (a, b) = window(k);
                adv[b + 1] - adv[a] >= window_mm
            };
            // Smallest half-width that covers the window (or the whole run).
            let k_max = (p - run_start).max(run_end - p);
            let (mut lo, mut hi) = (0, k_max);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if covers(mid) {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            out[p] = window(lo);
        }
        out
    }

    /// A small linear congruential generator from `seed`: the same draws, each
    /// below its argument, every run.
    fn lcg(seed: u64) -> impl FnMut(u64) -> u64 {
        let mut state = seed;
        move |m: u64| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 33) % m
        }
    }

    /// The windows given one by one, each run's end found by walking it, are
    /// the list's, in item order: runs of every length that start at a
    /// non-member or where an item does not join, items of a whole cell and
    /// of none among them, runs shorter than the window.
    #[test]
    fn sub_cell_windows_given_in_order_are_the_lists() {
        let mut next = lcg(12_345);
        for n in [0, 1, 2, 7, 64, 1000] {
            let advance: Vec<f64> = (0..n)
                .map(|_| match next(4) {
                    0 => 0.0,
                    1 => 1.5,
                    _ => next(100) as f64 / 100.0,
                })
                .collect();
            let member: Vec<bool> = (0..n).map(|_| next(8) != 0).collect();
            let joins: Vec<bool> = (0..n).map(|_| next(10) != 0).collect();
            let listed = sub_cell_windows_listed(|p| advance[p], &member, |p| joins[p], 1.0, 3.0);
            let mut given = Vec::new();
            sub_cell_windows(
                |p| advance[p],
                &member,
                |p| joins[p],
                1.0,
                3.0,
                |p, w| {
                    assert_eq!(p, given.len(), "in item order");
                    given.push(w);
                },
            );
            assert_eq!(given, listed, "{n} items");
            let searched = (0..n).filter(|&p| member[p] && advance[p] < 1.0);
            let starts: Vec<usize> = searched.map(|p| given[p].0).collect();
            assert!(
                starts.windows(2).all(|s| s[0] <= s[1]),
                "the windows of items under a cell start in order"
            );
            assert!(n < 64 || given.iter().enumerate().any(|(p, &w)| w != (p, p)));
        }
    }

    /// The closed loop's windowed residuals from `WindowSums` (one pass over
    /// the steps, holding the running sums between the window last read and
    /// the furthest end reached) are those of the whole prefix sums it
    /// replaced, kept here as the oracle, bit for bit: sub-cell windows that
    /// overlap (6 cells of path around steps of under a cell), steps the loop
    /// does not weigh, runs cut short; and windows asked for out of order
    /// sum again from the first step, to the same bits.
    #[test]
    fn window_sums_are_the_whole_prefix_sums_differences() {
        let mut next = lcg(4_242);
        let grid_mm = 0.1;
        for n in [1, 2, 40, 3000] {
            let advance_mm: Vec<f64> = (0..n)
                .map(|_| match next(6) {
                    0 => 0.0,
                    1 => 0.15,
                    _ => (1 + next(99)) as f64 * 1e-3,
                })
                .collect();
            let in_loop: Vec<bool> = (0..n).map(|_| next(12) != 0).collect();
            let inherited: Vec<bool> = (0..n).map(|_| next(9) == 0).collect();
            let g: Vec<f64> = (0..n).map(|_| next(20_000) as f64 * 1e-3 - 4.0).collect();
            let x: Vec<f64> = (0..n).map(|_| next(15_000) as f64 * 1e-3).collect();
            let joins: Vec<bool> = (0..n).map(|_| next(50) != 0).collect();
            let mut windows = Vec::new();
            sub_cell_windows(
                |p| advance_mm[p],
                &in_loop,
                |p| joins[p],
                grid_mm,
                SUB_CELL_WINDOW_CELLS * grid_mm,
                |p, w| {
                    if in_loop[p] && !inherited[p] && advance_mm[p] < grid_mm && w != (p, p) {
                        windows.push(w);
                    }
                },
            );
            assert!(
                n < 3000 || windows.windows(2).filter(|w| w[1].0 <= w[0].1).count() > 1000,
                "windows that overlap"
            );
            // The oracle: the loop's prefix sums and residuals as prefix sums held whole.
            let mut sum_r = vec![0.0; n + 1];
            let mut sum_x = vec![0.0; n + 1];
            let mut sum_g = vec![0.0; n + 1];
            let mut sum_w = vec![0.0; n + 1];
            let mut path = vec![0.0; n + 1];
            for i in 0..n {
                let w = if in_loop[i] && !inherited[i] {
                    advance_mm[i]
                } else {
                    0.0
                };
                sum_r[i + 1] = sum_r[i] + w * (g[i] - x[i]);
                sum_x[i + 1] = sum_x[i] + w * x[i];
                sum_g[i + 1] = sum_g[i] + w * g[i];
                sum_w[i + 1] = sum_w[i] + w;
                path[i + 1] = path[i] + advance_mm[i];
            }
            let oracle = |(a, b): (usize, usize)| {
                let w = sum_w[b + 1] - sum_w[a];
                (w > 0.0).then(|| {
                    let resolution =
                        ((sum_g[b + 1] - sum_g[a]) / w).abs() * grid_mm / (path[b + 1] - path[a]);
                    let rw = (((sum_r[b + 1] - sum_r[a]) / w).abs() - resolution).max(0.0);
                    let xw = ((sum_x[b + 1] - sum_x[a]) / w).abs();
                    (rw, xw)
                })
            };
            let bits = |v: Option<(f64, f64)>| v.map(|(r, x)| (r.to_bits(), x.to_bits()));
            let term = |j: usize| {
                let w = if in_loop[j] && !inherited[j] {
                    advance_mm[j]
                } else {
                    0.0
                };
                residual_terms(w, g[j], x[j], advance_mm[j])
            };
            let mut sums = WindowSums::new(term);
            let mut furthest = 0;
            for &(a, b) in &windows {
                let got = window_residual(sums.over(a, b), grid_mm);
                assert_eq!(bits(got), bits(oracle((a, b))), "window {a}..={b} of {n}");
                furthest = furthest.max(b + 1);
                assert_eq!(sums.first, a, "nothing before the window held");
                assert_eq!(
                    sums.held.len(),
                    furthest + 1 - a,
                    "nor past the furthest end"
                );
            }
            // Out of order: from the last window back.
            let mut sums = WindowSums::new(term);
            for &(a, b) in windows.iter().rev() {
                let got = window_residual(sums.over(a, b), grid_mm);
                assert_eq!(bits(got), bits(oracle((a, b))), "window {a}..={b} of {n}");
            }
        }
    }

    #[test]
    fn sub_cell_windows_cover_the_path_within_their_run() {
        // Cell 1, window 3: a step of 0.5 takes the fewest steps centred on it
        // that cover 3 mm of path; a whole step keeps itself; a run ends
        // before an item that does not join (index 6) and at a non-member
        // (index 9).
        let advance = [0.5, 0.5, 0.5, 0.5, 2.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5];
        let member = [
            true, true, true, true, true, true, true, true, true, false, true,
        ];
        let mut w = Vec::new();
        sub_cell_windows(
            |p| advance[p],
            &member,
            |p| p != 6,
            1.0,
            3.0,
            |p, window| {
                assert_eq!(p, w.len(), "in item order");
                w.push(window)
            },
        );
        assert_eq!(w[0], (0, 4), "the run's start bounds the window");
        assert_eq!(w[2], (0, 4), "(1, 3) covers 1.5 mm");
        assert_eq!(w[3], (2, 4));
        assert_eq!(w[4], (4, 4), "a step of a whole cell is its own window");
        assert_eq!(w[5], (3, 5), "index 6 starts a new run");
        assert_eq!(w[6], (6, 8));
        assert_eq!(
            w[7],
            (6, 8),
            "the run 6..=8 is shorter than the window: all of it"
        );
        assert_eq!(w[9], (9, 9), "not a member");
        assert_eq!(w[10], (10, 10), "a run of one");
    }

    /// A step's search of the closed loop, one a step: 80 B.
    #[test]
    fn a_steps_search_takes_80_bytes() {
        assert_eq!(std::mem::size_of::<Bracketed>(), 80);
    }

    #[test]
    fn relaxed_update_halves_on_overshoot() {
        let mut r = Relaxed::START;
        // g above x: move towards it by ω = 0.4 · 1.3.
        let x1 = r.next(0.0, 100.0);
        assert!((x1 - 52.0).abs() < 1e-12, "{x1}");
        // Overshoot (g below x): ω halves to 0.26.
        let x2 = r.next(x1, 40.0);
        assert!((x2 - (52.0 - 0.26 * 12.0)).abs() < 1e-12, "{x2}");
    }

    /// The first update of a step whose g falls gently is the secant's root,
    /// exact for a linear g (g = 100 − 0.1 x: root 100/1.1), where the
    /// relaxed update moves 0.52 of the residual; not where the loop does
    /// not allow it, nor where g falls faster (g = 100 − 0.3 x: the relaxed
    /// update, since g may be far from linear there).
    #[test]
    fn the_first_update_is_the_secants_root_where_g_is_nearly_flat() {
        let first = |g: &dyn Fn(f64) -> f64, secant: bool| {
            let mut s = Bracketed::new(g(0.0), CAP_UM);
            let x = LOOP_RELAX_START * g(0.0);
            s.observe(x, g(x) - x, 2, CAP_UM);
            (x, s.next(x, g(x), secant))
        };
        let gentle = |x: f64| 100.0 - 0.1 * x;
        let (x, p) = first(&gentle, true);
        assert!((p - 100.0 / 1.1).abs() < 1e-9, "{p}");
        let relaxed = |x: f64, g: f64| {
            let mut r = Relaxed::START;
            r.next(x, g)
        };
        let (_, p) = first(&gentle, false);
        assert!((p - relaxed(x, gentle(x))).abs() < 1e-9, "{p}");
        let steep = |x: f64| 100.0 - 0.3 * x;
        let (x, p) = first(&steep, true);
        assert!((p - relaxed(x, steep(x))).abs() < 1e-9, "{p}");
        // A rising g (the neighbours moved it) is taken as flat: x ← g.
        let rising = |x: f64| 100.0 + 0.1 * x;
        let (x, p) = first(&rising, true);
        assert!((p - rising(x)).abs() < 1e-9, "{p}");
    }

    /// The bracketed search on g(x) = c (a − x)⁺/k alone (no other steps):
    /// root c a/(k + c). For c/k = 25 plain iteration x ← g(x) jumps between
    /// 0 and 5 000 µm; the search converges within the loop's tolerance in
    /// under 16 sweeps, for c/k from 0.01 to 25 (c/k = 100 takes more: the
    /// relaxed trials creep down the side where g = 0), and at a jump of g (a
    /// staircase of 10 µm steps) its bracket closes around the jump.
    #[test]
    fn bracketed_search_converges_where_plain_iteration_diverges() {
        let a = 200.0;
        for ratio in [0.01, 1.0, 4.9, 25.0] {
            let g = |x: f64| ratio * (a - x).max(0.0);
            let root = ratio * a / (1.0 + ratio);
            let mut s = Bracketed::new(g(0.0), CAP_UM);
            let mut x = (LOOP_RELAX_START * g(0.0)).min(CAP_UM);
            let mut passes = 1;
            loop {
                passes += 1;
                s.observe(x, g(x) - x, passes, CAP_UM);
                // The loop's test: within tolerance, or bracketed as closely.
                if (g(x) - x).abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() || s.closed(passes) {
                    break;
                }
                assert!(
                    passes < 16,
                    "c/k {ratio}: x {x} after {passes} sweeps, root {root}"
                );
                x = s.next(x, g(x), true).clamp(-CAP_UM, CAP_UM);
            }
            assert!(
                (x - root).abs() <= 1.0 + 0.03 * root,
                "c/k {ratio}: {x} vs {root}"
            );
        }
        // Staircase: g = 4.9 · (a − 10 ⌈x/10⌉): 196 up to x = 160, 147 beyond,
        // so the root is the jump at x = 160.
        let g = |x: f64| 4.9 * (a - 10.0 * (x / 10.0).ceil()).max(0.0);
        let mut s = Bracketed::new(g(0.0), CAP_UM);
        let mut x = LOOP_RELAX_START * g(0.0);
        let mut passes = 1;
        loop {
            passes += 1;
            s.observe(x, g(x) - x, passes, CAP_UM);
            if s.closed(passes) {
                break;
            }
            assert!(passes < 16, "staircase: x {x} after {passes} sweeps");
            x = s.next(x, g(x), true);
        }
        assert!(
            (s.lo.at - 160.0).abs() < 4.0 && s.lo.at <= 160.0 && s.hi.at >= 160.0,
            "{s:?}"
        );
    }

    /// The stock outside a point along a direction, on a box held and on its
    /// closed form: vertical, across a wall and diagonal, each against its
    /// exact length.
    #[test]
    fn material_along_a_direction_matches_the_box() {
        let solid = dexel::Solid::Box {
            min: [0.0, 0.0, 0.0],
            max: [10.0, 10.0, 5.0],
        };
        let stock = solid.stock_in_rows(0.1, None, None).unwrap();
        for before in [Before::Stock(&stock), Before::Solid(&solid, stock.grid())] {
            // Up from z = 2 at a column centre: 3 mm to the top.
            let up = material_along_mm(before, [5.05, 5.05, 2.0], [0.0, 0.0, 1.0], 10.0);
            assert!((up - 3.0).abs() < 1e-5, "{up}");
            // Along +y from y = 9.85 to the face at 10: 0.15 mm.
            let side = material_along_mm(before, [5.05, 9.85, 2.0], [0.0, 1.0, 0.0], 10.0);
            assert!((side - 0.15).abs() < 1e-5, "{side}");
            // Diagonal in x–z from 1 mm below the top: √2 mm.
            let r = std::f64::consts::FRAC_1_SQRT_2;
            let diag = material_along_mm(before, [5.05, 5.05, 4.0], [r, 0.0, r], 10.0);
            assert!((diag - 2f64.sqrt()).abs() < 1e-5, "{diag}");
            // Capped at max_mm, and zero from a point in the air.
            assert_eq!(
                material_along_mm(before, [5.05, 5.05, 2.0], [0.0, 0.0, 1.0], 0.5),
                0.5
            );
            assert_eq!(
                material_along_mm(before, [5.05, 5.05, 6.0], [0.0, 0.0, 1.0], 1.0),
                0.0
            );
        }
    }

    /// A box or a cylinder made again from its closed form for each pass
    /// (one stock held, `StockSource::Made`) gives the run of the stock held
    /// and copied for each pass (`StockSource::Whole`) bit for bit: record,
    /// loads, offsets, error map (clamped to the initial stock through the
    /// closed form) and final stock, over a closed loop of several passes.
    #[test]
    fn a_stock_made_of_its_closed_form_runs_as_the_stock_held() {
        let dir = tempfile::tempdir().unwrap();
        // A Ø6 ball on a long stickout cutting 2 mm deep along a wall 1 mm
        // inside the stock's edge, then across it.
        std::fs::write(
            dir.path().join("part.nc"),
            "G21 G90\nG0 X-5 Y4 Z25\nG0 Z18\nG1 X45 F1200\nG1 Y16\nG1 X-5\nG0 Z25\nM2\n",
        )
        .unwrap();
        for stock in [
            "kind = \"box\"\nmin = [0, 2, 0]\nmax = [40, 30, 20]\ngrid = 0.2",
            "kind = \"cylinder\"\ncenter = [20, 15]\nradius = 13\nz_min = 0\nz_max = 20\ngrid = 0.2",
        ] {
            let job = format!(
                "[stock]\n{stock}\n[tool]\nkind = \"ball\"\ndiameter = 6\nstickout = 60\n\
                 [program]\npath = \"part.nc\"\n[cutting]\nmaterial = \"al6061\"\n\
                 [machine]\nfeed_max = 3000\nrapid = 10000\naccel = [1000, 1000, 1000]\n"
            );
            let path = dir.path().join("job.toml");
            std::fs::write(&path, job).unwrap();
            let setup = crate::commands::Setup::load(&path, None).unwrap();
            let solid = crate::input::stock::solid(&setup.job.stock).unwrap();
            let steps = setup.machine_steps().unwrap();
            let held = run_on(
                StockSource::Whole(setup.stock.clone()),
                &setup.tools,
                steps.clone(),
                "held",
            )
            .unwrap();
            let made = run_on(
                StockSource::Made(setup.stock.clone(), solid),
                &setup.tools,
                steps,
                "made",
            )
            .unwrap();
            assert!(held.closed_loop.passes > 2, "{stock}: {} passes", held.closed_loop.passes);
            assert!(held.final_volume_mm3 < held.initial_volume_mm3 - 100.0, "{stock}");
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(held.error_map_um().iter().any(|e| e.is_finite() && *e != 0.0), "{stock}");
            assert_eq!(bits(&held.error_map_um()), bits(&made.error_map_um()), "{stock}");
            assert_eq!(held.closed_loop.passes, made.closed_loop.passes);
            assert_eq!(held.offsets_um, made.offsets_um);
            assert_eq!(held.model_um, made.model_um);
            assert_eq!(
                held.initial_volume_mm3.to_bits(),
                made.initial_volume_mm3.to_bits()
            );
            assert_eq!(held.final_volume_mm3.to_bits(), made.final_volume_mm3.to_bits());
            assert!(held.stock.columns().eq(made.stock.columns()), "{stock}");
            assert_eq!(held.stock.last_cut(), made.stock.last_cut(), "{stock}");
            for i in 0..held.steps.len() {
                assert_eq!(
                    held.record.volume_mm3(i).to_bits(),
                    made.record.volume_mm3(i).to_bits()
                );
                assert_eq!(held.record.band_volumes_mm3(i), made.record.band_volumes_mm3(i));
                assert_eq!(
                    held.loads[i].deflection_um.to_bits(),
                    made.loads[i].deflection_um.to_bits()
                );
            }
        }
    }

    /// The closed-form wall of the closed-loop tests: a Ø10 flat end mill on
    /// a 0.1 N/µm holder, S4's linear law (100 N per mm³ a tooth), a box
    /// from y = −`depth_mm` to −4.8 mm at grid 0.01, the points `csv` at
    /// F1200.
    fn wall_setup(dir: &std::path::Path, csv: &str, depth_mm: f64) -> crate::commands::Setup {
        std::fs::write(dir.join("wall.csv"), csv).unwrap();
        let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, -{depth_mm}, 0]\nmax = [30, -4.8, 30]\ngrid = 0.01\n\
             [tool]\nkind = \"flat\"\ndiameter = 10\nflute_length = 20\nstickout = 40\n\
             holder_stiffness_n_per_um = 0.1\n[program]\npath = \"wall.csv\"\nfeed = 1200\n\
             [cutting]\nband_height = 1.0\nspindle_rpm = 6000\nmodel = \"power_law\"\n\
             force_a = 100\nforce_n = 1\n"
        );
        let path = dir.join("job.toml");
        std::fs::write(&path, job).unwrap();
        crate::commands::Setup::load(&path, None).unwrap()
    }

    /// The closed loop's passes keep each step's deflection across its path
    /// made as each load is (`loads_as`), not the loads: they are those of
    /// every load held and the windowed ones written over it (the loads
    /// `loads` gave before), bit for bit, on a cut in 4 µm steps on a
    /// 10 µm grid, whose loads are those of their windows (MODEL.md §1.6).
    #[test]
    fn deflections_made_as_the_loads_are_those_of_the_loads_held() {
        let dir = tempfile::tempdir().unwrap();
        let csv: String = std::iter::once("x,y,z\n".to_string())
            .chain((0..=1500).map(|i| format!("{},0,20\n", -6.0 + 0.004 * i as f64)))
            .collect();
        let setup = wall_setup(dir.path(), &csv, 6.0);
        let steps = setup.machine_steps().unwrap();
        let (tool_of_step, options) = sweep_setup(&setup.tools, &steps).unwrap();
        let moves: Vec<dexel::Step> = steps.iter().map(|s| s.step).collect();
        let initial = Initial::Held(std::borrow::Cow::Borrowed(&setup.stock));
        let (_, record) = sweep_pass(
            &initial,
            None,
            &setup.tools,
            &tool_of_step,
            &moves,
            &options,
            "test",
        )
        .unwrap();
        let grid_mm = setup.stock.grid().spacing_mm;
        // Every step's load held, then the windows' written over them.
        let model = &setup.tools.entries[0].model;
        let own: Vec<StepLoad> = (0..steps.len())
            .map(|i| {
                model.step_load(&cutting::StepRemoval {
                    volume_mm3: record.volume_mm3(i),
                    band_volumes_mm3: record.band_volumes_mm3(i),
                    contact_resultant: record.contact_resultant(i),
                    chip_edge_area_mm2: record.chip_edge_area_mm2(i),
                    volume_over_radius_mm2: record.volume_over_radius_mm2(i),
                    dt_s: steps[i].dt_s,
                })
            })
            .collect();
        let mut held = own.clone();
        crate::subcell::window_loads(
            |i, l| held[i] = l,
            &setup.tools,
            &tool_of_step,
            &record,
            &steps,
            grid_mm,
        );
        let windowed = (0..steps.len())
            .filter(|&i| held[i].dx_um.to_bits() != own[i].dx_um.to_bits())
            .count();
        assert!(windowed > 100, "{windowed} steps windowed");
        let along = |l: &StepLoad, i: usize| 0.6 * l.dx_um + 0.8 * l.dy_um + i as f64;
        let g = loads_as(&setup.tools, &tool_of_step, &record, &steps, grid_mm, along);
        let loads = loads(&setup.tools, &tool_of_step, &record, &steps, grid_mm);
        assert_eq!(g.len(), steps.len());
        for i in 0..steps.len() {
            assert_eq!(g[i].to_bits(), along(&held[i], i).to_bits(), "step {i}");
            assert_eq!(
                format!("{:?}", loads[i]),
                format!("{:?}", held[i]),
                "step {i}"
            );
        }
    }

    /// A cut that ends in a short step the rigid tool removes nothing in
    /// (fusion_haas_rebels5's line 1015: the rest of a servo period before a
    /// rapid, 0.117 ms and 1.5 µm up in Z, after a step the loop moved by
    /// 42 µm). Here a Ø10 flat end finishes a wall 0.2 mm deep (holder
    /// 0.1 N/µm, S4's law with n = 1: the loop moves the steady steps about
    /// 99 µm off the wall), and the cut ends with such a step, then a rapid
    /// up. With the step's offset 0 (no rigid direction) the tool swept back
    /// to the programmed path within the step: 99 µm of wall in 0.117 ms,
    /// a force many times the cut's (8 007.9 N against the wall's 10.0 N).
    /// Its offset now relaxes with the load that sustains it (MODEL.md §5.1,
    /// eq. 5.1a): the step's force is no larger than the wall's, and the
    /// loop converges.
    #[test]
    fn a_short_step_after_a_deflected_one_does_not_spike() {
        let dir = tempfile::tempdir().unwrap();
        let csv: String = std::iter::once("x,y,z\n".to_string())
            .chain((0..=100).map(|i| format!("{},0,20\n", -10.0 + 0.5 * i as f64)))
            .collect();
        let setup = wall_setup(dir.path(), &csv, 6.0);
        let mut steps = setup.machine_steps().unwrap();
        // The cut up to x = 15 mm (the steady wall), then the short step and
        // a rapid 10 mm up.
        let last = steps
            .iter()
            .rposition(|s| !s.step.rapid && s.step.to_mm[0] <= 15.0)
            .unwrap();
        steps.truncate(last + 1);
        let end = steps[last];
        let dt_s = 0.117e-3;
        let [x, y, z] = end.step.to_mm;
        let up = TimedStep {
            step: dexel::Step {
                from_mm: [x, y, z],
                to_mm: [x, y, z + 1.5e-3],
                rapid: false,
            },
            t_end_s: end.t_end_s + dt_s,
            dt_s,
            feed_mm_min: 1.5e-3 / dt_s * 60.0,
            s_end_mm: end.s_end_mm + 1.5e-3,
            ..end
        };
        let rapid = TimedStep {
            step: dexel::Step {
                from_mm: up.step.to_mm,
                to_mm: [x, y, z + 10.0],
                rapid: true,
            },
            t_end_s: up.t_end_s + 0.016,
            dt_s: 0.016,
            feed_mm_min: 10.0 / 0.016 * 60.0,
            s_end_mm: up.s_end_mm + 10.0,
            continues: true,
            ..end
        };
        steps.push(up);
        steps.push(rapid);
        let run = run_on(
            StockSource::Whole(setup.stock.clone()),
            &setup.tools,
            steps,
            "spike",
        )
        .unwrap();
        let k = last + 1;
        // The steps of the steady wall before it (x from 10 mm on).
        let before: Vec<f64> = (0..k)
            .filter(|&i| !run.steps[i].step.rapid && run.steps[i].step.to_mm[0] >= 10.0)
            .map(|i| run.loads[i].force_n)
            .collect();
        assert!(before.len() > 10, "{} steps", before.len());
        let lo = before.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = before.iter().copied().fold(0.0, f64::max);
        let offset = run.offsets_um[last][1];
        assert!(offset > 50.0, "the wall's offset {offset} µm");
        let force = run.loads[k].force_n;
        eprintln!(
            "wall {lo:.2}…{hi:.2} N at offset {offset:.1} µm; short step {force:.2} N at {:?} µm, {} sweeps",
            run.offsets_um[k], run.closed_loop.passes
        );
        assert!(
            force <= hi,
            "the short step's force {force} N above the wall's {lo}…{hi} N"
        );
        assert!(run.closed_loop.converged, "{:?}", run.closed_loop);
    }

    /// A step with no direction of its own takes the direction of the step
    /// before it (eq. 5.1a), but its own cut can push the tool the other
    /// way: then the root of eq. 5.1a lies below φ = 0, and the step ends on
    /// the path, its load as swept (eq. 5.1b). The wall of the closed form
    /// above (holder 0.1 N/µm: the loop moves the tool about 99 µm off the
    /// wall, +y) is cut to its end and beyond; the tool turns down in the
    /// air and comes back along the other face of the wall, its edge on the
    /// face the rigid tool made. The rigid tool cuts nothing there (the wall
    /// is 0.2 mm thick, the first pass took all of it), so those steps have
    /// no direction and take +y along the chain; the bent tool of the first
    /// pass left 99 µm of the wall, which the way back cuts from below and
    /// which pushes the tool to −y: g < 0 at φ = 0. Before eq. 5.1b each
    /// such step stayed out of tolerance by its whole deflection and the loop
    /// did not settle.
    #[test]
    fn a_step_whose_own_cut_pushes_against_its_taken_direction_ends_on_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let csv: String = std::iter::once("x,y,z\n".to_string())
            .chain((0..=100).map(|i| format!("{},0,20\n", -10.0 + 0.5 * i as f64)))
            .chain((0..=100).map(|i| format!("{},-9.95,20\n", 40.0 - 0.5 * i as f64)))
            .collect();
        let setup = wall_setup(dir.path(), &csv, 5.0);
        let steps = setup.machine_steps().unwrap();
        let run = run_on(
            StockSource::Whole(setup.stock.clone()),
            &setup.tools,
            steps,
            "back",
        )
        .unwrap();
        let on = |i: usize, y: f64| {
            let s = &run.steps[i].step;
            !s.rapid && s.from_mm[1] == y && s.to_mm[1] == y && (5.0..=25.0).contains(&s.to_mm[0])
        };
        // The first pass along the wall: moved off it, +y.
        let first: Vec<usize> = (0..run.steps.len()).filter(|&i| on(i, 0.0)).collect();
        assert!(first.len() > 20, "{} steps", first.len());
        for &i in &first {
            assert!(
                run.offsets_um[i][1] > 50.0,
                "step {i}: {:?} µm",
                run.offsets_um[i]
            );
        }
        // The way back cuts what the bent tool left: pushed to −y, on the path.
        let back: Vec<usize> = (0..run.steps.len()).filter(|&i| on(i, -9.95)).collect();
        assert!(back.len() > 20, "{} steps", back.len());
        for &i in &back {
            assert_eq!(run.offsets_um[i], [0.0, 0.0], "step {i}");
            assert!(
                run.model_um[i][1] < -10.0,
                "step {i}: {:?} µm",
                run.model_um[i]
            );
        }
        eprintln!(
            "first pass {:.1} µm, way back {:.1} µm, {} sweeps, residual {:.2} µm",
            run.offsets_um[first[first.len() / 2]][1],
            run.model_um[back[back.len() / 2]][1],
            run.closed_loop.passes,
            run.closed_loop.residual_um
        );
        assert!(run.closed_loop.converged, "{:?}", run.closed_loop);
    }
}
