//! The sweep kernel: exact lower envelope of a tool moving along a straight
//! line, intersected with every column it passes over.
//!
//! For each column the swept tool covers `[z_env, +∞)`, where `z_env` is the
//! lowest point of the swept solid on the column's vertical line:
//! * ball end: the swept ball is a capsule; `z_env` is a closed-form
//!   ray–capsule intersection (cylinder body or one of the end spheres);
//! * flat end: the lowest tip height over the parameter interval in which the
//!   column lies under the tool's disc (closed form);
//! * bull nose: the tool's lower surface height at horizontal distance ρ from
//!   the axis, `f(ρ)`, is convex and non-decreasing, and ρ(t) is convex along
//!   the move, so `f(ρ(t)) + z_tip(t)` is convex in t: its minimum is at an
//!   end of the column's interval or at its slope's root, found by Newton's
//!   steps kept in a bracket, to 1e-9 mm along the move (no sub-sampling of
//!   positions); on a level move it is where ρ is least, on a plunge at the
//!   lower end.
//!
//! Before the exact envelope, a ball end rules out columns with a square-root
//! free bound (z ≥ z_min + R − √(R² − ρ²), ρ the XY distance to the move's
//! axis, tested as ρ² ≥ δ(2R − δ)): per row against the row's highest top,
//! then per column against its own top. A bull nose uses the same bound
//! moved out by its ring (one square root per column instead of a search).
//! The bound skips only columns that the envelope would not cut, so results
//! are the same with or without it.
//!
//! Removed material of a column is credited to the tool height band it falls
//! in, measured from the tool tip at the parameter where the envelope is
//! attained. Architecture invariants: no allocation per move or column (the
//! only allocations are per batch of moves and per strip), and per-step sums
//! are reduced in a fixed strip order, so results do not depend on the number
//! of threads.

mod arcsine;
mod ball;
mod batch;
mod bull;
mod flat;
mod strip;

pub use batch::{sweep, sweep_tools, Sweep};

use crate::grid::CentreBounds;
use crate::Grid;

/// One straight tool move, tip positions in mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Tool tip at the start of the move, mm.
    pub from_mm: [f64; 3],
    /// Tool tip at the end of the move, mm.
    pub to_mm: [f64; 3],
    /// A rapid (G0) move: any material it removes is a collision.
    pub rapid: bool,
}

/// The steps a sweep takes, by index: a list held whole (`[Step]`), or steps
/// made when the sweep asks for them ([`StepFn`], e.g. from the stations of
/// a path), so a long program's list of 56 B a step need not be held beside
/// its record. The sweep asks for each step a few times (to
/// prepare its move, for the smoothing shares and for a plunge's lattice
/// bias), in order, one batch at a time; a step must be the same each time.
pub trait StepSource {
    /// Number of steps.
    fn len(&self) -> usize;
    /// Step `i` (`i < len()`).
    fn step(&self, i: usize) -> Step;
    /// No steps.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl StepSource for [Step] {
    fn len(&self) -> usize {
        <[Step]>::len(self)
    }
    #[inline]
    fn step(&self, i: usize) -> Step {
        self[i]
    }
}

impl StepSource for Vec<Step> {
    fn len(&self) -> usize {
        Vec::len(self)
    }
    #[inline]
    fn step(&self, i: usize) -> Step {
        self[i]
    }
}

/// `len` steps made by a function of their index.
pub struct StepFn<F> {
    len: usize,
    step: F,
}

impl<F: Fn(usize) -> Step> StepFn<F> {
    /// Steps `0..len`, step `i` being `step(i)`.
    pub fn new(len: usize, step: F) -> Self {
        StepFn { len, step }
    }
}

impl<F: Fn(usize) -> Step> StepSource for StepFn<F> {
    fn len(&self) -> usize {
        self.len
    }
    #[inline]
    fn step(&self, i: usize) -> Step {
        debug_assert!(i < self.len);
        (self.step)(i)
    }
}

/// Steps `start .. start + len` of a source, as steps `0 .. len`.
pub(crate) struct SubSteps<'s, S: ?Sized> {
    steps: &'s S,
    start: usize,
    len: usize,
}

impl<'s, S: StepSource + ?Sized> SubSteps<'s, S> {
    fn new(steps: &'s S, range: std::ops::Range<usize>) -> Self {
        debug_assert!(range.end <= steps.len());
        SubSteps {
            steps,
            start: range.start,
            len: range.end - range.start,
        }
    }
}

impl<S: StepSource + ?Sized> StepSource for SubSteps<'_, S> {
    fn len(&self) -> usize {
        self.len
    }
    #[inline]
    fn step(&self, i: usize) -> Step {
        debug_assert!(i < self.len);
        self.steps.step(self.start + i)
    }
}

/// Tuning of a sweep; the defaults suit grids from 0.01 to 1 mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepOptions {
    /// Height of one tool band, mm (band k spans [k·h, (k+1)·h) above the tip).
    pub band_height_mm: f64,
    /// Rows of columns per parallel strip.
    pub strip_rows: usize,
    /// Steps handled per batch at most (progress is reported after each batch).
    pub batch_steps: usize,
    /// Bound on a batch's partial sums, bytes: a batch ends before its moves'
    /// strip entries (a move joins every strip its footprint's rows touch)
    /// would need more, with at least one move per batch. (The entries'
    /// ranges of lateral offsets, 8 B a band, come beside it.) Batches change no
    /// result (each strip cuts its moves in order, each step's sums are
    /// reduced in strip order), only the memory and how often progress is
    /// reported.
    pub batch_bytes: usize,
    /// Credit a column's removal to the neighbouring steps by the share of its
    /// cell that the tool's edge sweeps in each (MODEL.md §1.5), so per-step
    /// removal does not alias with the grid. Totals are unchanged.
    pub smooth: bool,
}

impl Default for SweepOptions {
    /// Strips of 8 rows; batches of up to 8 192 steps and 8 MiB of partial
    /// sums: each batch ends with its last strip while the other threads
    /// wait (the costliest are taken first), so fewer, larger batches keep
    /// both cores busier (the long real program B's optimize 36.8 → 33.7 s
    /// against 2 048 steps and 4 MiB, BENCHMARKS.md) while the raster at grid
    /// 0.05 stays at its 89 MB.
    fn default() -> Self {
        SweepOptions {
            band_height_mm: 1.0,
            strip_rows: 8,
            batch_steps: 8_192,
            batch_bytes: 8 << 20,
            smooth: true,
        }
    }
}

/// Slots of a step's row in a [`RemovalRecord`] (and of the sweep's per-step
/// sums) before the band volumes.
mod slot {
    /// Total volume removed (bands plus shank).
    pub(super) const VOLUME: usize = 0;
    /// Volume removed above the flute length.
    pub(super) const SHANK: usize = 1;
    /// Contact-direction resultant, x and y.
    pub(super) const CONTACT_X: usize = 2;
    pub(super) const CONTACT_Y: usize = 3;
    /// Σ dV / h (chip edge area).
    pub(super) const CHIP_AREA: usize = 4;
    /// Σ dV / r (volume over edge radius).
    pub(super) const OVER_RADIUS: usize = 5;
}

/// Values stored per step before the band volumes (the [`slot`]s).
const HEAD: usize = 6;

/// The range of lateral offsets of a band that received no removal from a
/// side cut (MODEL.md §1.7): `[+∞, −∞]`, the neutral element of the min/max
/// merge, whose lower end lies above its upper end.
pub const EMPTY_OFFSETS: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];

/// The range `[e_min, e_max]` of a band's offsets, or `None` where it is
/// [`EMPTY_OFFSETS`] (any range whose lower end lies above its upper end).
#[inline]
fn offsets_or_none(range: Option<&[f32; 2]>) -> Option<[f32; 2]> {
    range.copied().filter(|r| r[0] <= r[1])
}

/// What a sweep removed, per step.
///
/// Stored in compact columns: per step the [`slot`] values, and the
/// band volumes of all steps end to end without each step's trailing zero
/// bands (a finishing cut touches one or two of a tool's bands), so a long
/// program keeps about 60 bytes per step instead of 8 per band. The values are
/// the sweep's own f64 sums, unchanged. Beside each kept band volume, the
/// range of the lateral offsets of the columns it was cut from (two f32, 8 B
/// per kept band: [`band_offsets_mm`](Self::band_offsets_mm)).
#[derive(Clone, Debug, PartialEq)]
pub struct RemovalRecord {
    /// Height of one tool band above the tip, mm (band k spans k·h to (k+1)·h).
    pub band_height_mm: f64,
    /// Bands over the flute length; removal above them is shank volume.
    pub n_bands: usize,
    /// Per step: [volume, shank volume, contact x, contact y, chip edge area,
    /// volume over radius], then while the sweep runs band 0 … band K−1.
    data: Vec<f64>,
    /// Once the sweep is done: the band volumes, step after step, each without
    /// its trailing zero bands.
    bands: Vec<f64>,
    /// Step i's bands are `bands[band_start[i]..band_start[i + 1]]`; empty
    /// while the sweep runs (full rows in `data`).
    band_start: Vec<usize>,
    /// Per band value: the range [e_min, e_max] of the lateral offsets (mm,
    /// left of the feed) of the columns whose removal that band holds, or
    /// [`EMPTY_OFFSETS`]. While the sweep runs, every band of every step
    /// (`n_bands` a step); once done, beside `bands` (the same indices).
    offsets: Vec<[f32; 2]>,
    /// Columns visited (inside a step's footprint) over the whole sweep.
    pub columns_evaluated: u64,
}

/// A record of no steps: a placeholder where a record is dropped before the
/// next one is swept.
impl Default for RemovalRecord {
    fn default() -> Self {
        RemovalRecord::compact_empty(0, 1.0)
    }
}

impl RemovalRecord {
    fn new(steps: usize, n_bands: usize, band_height_mm: f64) -> Self {
        RemovalRecord {
            band_height_mm,
            n_bands,
            data: vec![0.0; steps * (HEAD + n_bands)],
            bands: Vec::new(),
            band_start: Vec::new(),
            offsets: vec![EMPTY_OFFSETS; steps * n_bands],
            columns_evaluated: 0,
        }
    }

    /// An empty record in compact form, to append compact records to.
    fn compact_empty(n_bands: usize, band_height_mm: f64) -> Self {
        RemovalRecord {
            band_height_mm,
            n_bands,
            data: Vec::new(),
            bands: Vec::new(),
            band_start: vec![0],
            offsets: Vec::new(),
            columns_evaluated: 0,
        }
    }

    fn is_compact(&self) -> bool {
        !self.band_start.is_empty()
    }

    fn stride(&self) -> usize {
        if self.is_compact() {
            HEAD
        } else {
            HEAD + self.n_bands
        }
    }

    fn row(&self, step: usize) -> &[f64] {
        let s = self.stride();
        &self.data[step * s..(step + 1) * s]
    }

    /// Step `step`'s values as one row (what [`Sweep::whole_into`] gives a
    /// sink for it).
    pub fn step_row(&self, step: usize) -> RecordRow<'_> {
        if self.is_compact() {
            RecordRow {
                head: self.row(step),
                bands: self.band_volumes_mm3(step),
                offsets: self.band_offsets_mm(step),
            }
        } else {
            RecordRow::of_full(self.row(step), self.band_offsets_mm(step))
        }
    }

    /// Turn the full rows the sweep filled into the compact columns, in place:
    /// the head values move down, the bands up to the last nonzero one (bit
    /// pattern not +0.0) are copied out. Nothing else changes.
    fn compact(&mut self) {
        if self.is_compact() {
            return;
        }
        let stride = HEAD + self.n_bands;
        let n = self.data.len() / stride;
        let mut bands = Vec::new();
        let mut offsets = Vec::new();
        let mut band_start = Vec::with_capacity(n + 1);
        band_start.push(0);
        for i in 0..n {
            let row = &self.data[i * stride..(i + 1) * stride];
            let kept = kept_bands(row);
            bands.extend_from_slice(&row[HEAD..HEAD + kept]);
            let nb = self.n_bands;
            offsets.extend_from_slice(&self.offsets[i * nb..i * nb + kept]);
            band_start.push(bands.len());
            self.data
                .copy_within(i * stride..i * stride + HEAD, i * HEAD);
        }
        self.data.truncate(n * HEAD);
        self.data.shrink_to_fit();
        bands.shrink_to_fit();
        offsets.shrink_to_fit();
        self.bands = bands;
        self.offsets = offsets;
        self.band_start = band_start;
    }

    /// Append one step's full row (head values, then every band) and its
    /// bands' offset ranges (every band) to a compact record, as
    /// [`compact`](Self::compact) keeps them.
    fn push_row(&mut self, row: &[f64], offsets: &[[f32; 2]]) {
        debug_assert!(self.is_compact() && row.len() == HEAD + self.n_bands);
        debug_assert_eq!(offsets.len(), self.n_bands);
        self.data.extend_from_slice(&row[..HEAD]);
        let kept = kept_bands(row);
        self.bands.extend_from_slice(&row[HEAD..HEAD + kept]);
        self.offsets.extend_from_slice(&offsets[..kept]);
        self.band_start.push(self.bands.len());
    }

    /// Append the compact record `other` (its steps after this one's).
    fn append(&mut self, other: &RemovalRecord) {
        debug_assert!(self.is_compact() && other.is_compact());
        let base = self.bands.len();
        self.data.extend_from_slice(&other.data);
        self.bands.extend_from_slice(&other.bands);
        self.offsets.extend_from_slice(&other.offsets);
        self.band_start
            .extend(other.band_start[1..].iter().map(|&s| base + s));
        self.columns_evaluated += other.columns_evaluated;
    }

    /// Number of steps recorded.
    pub fn len(&self) -> usize {
        self.data.len() / self.stride()
    }

    /// No steps recorded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Total volume removed by `step`, mm³ (bands plus shank).
    pub fn volume_mm3(&self, step: usize) -> f64 {
        self.row(step)[slot::VOLUME]
    }

    /// Volume removed above the flute length (shank contact), mm³.
    pub fn shank_volume_mm3(&self, step: usize) -> f64 {
        self.row(step)[slot::SHANK]
    }

    /// Volume removed per tool height band, mm³, from band 0 up to the
    /// highest band that is not zero (the bands above it, up to
    /// [`n_bands`](Self::n_bands), removed nothing; see
    /// [`band_volume_mm3`](Self::band_volume_mm3)).
    pub fn band_volumes_mm3(&self, step: usize) -> &[f64] {
        if self.is_compact() {
            &self.bands[self.band_start[step]..self.band_start[step + 1]]
        } else {
            let s = self.stride();
            &self.data[step * s + HEAD..(step + 1) * s]
        }
    }

    /// Per band of [`band_volumes_mm3`](Self::band_volumes_mm3) (the same
    /// length, index k = band k): the range `[e_min, e_max]` (mm) of the
    /// signed lateral offsets of the cut columns whose removal the band
    /// holds, e the column centre's offset to the left of the move's XY
    /// direction (MODEL.md §1.7). [`EMPTY_OFFSETS`] (`[+∞, −∞]`) where the
    /// band received no removal from a side cut: a plunge's bands, a band
    /// above the cut. Ranges are merged over strips and batches by min/max;
    /// smoothing (§1.5) does not move them. See
    /// [`band_offset_mm`](Self::band_offset_mm) for one band as an `Option`.
    pub fn band_offsets_mm(&self, step: usize) -> &[[f32; 2]] {
        if self.is_compact() {
            &self.offsets[self.band_start[step]..self.band_start[step + 1]]
        } else {
            &self.offsets[step * self.n_bands..(step + 1) * self.n_bands]
        }
    }

    /// Band `k`'s range of lateral offsets (see
    /// [`band_offsets_mm`](Self::band_offsets_mm)); `None` where the band
    /// received no side cut's removal (or lies above the bands stored).
    pub fn band_offset_mm(&self, step: usize, k: usize) -> Option<[f32; 2]> {
        offsets_or_none(self.band_offsets_mm(step).get(k))
    }

    /// Volume removed by `step` in band `k` (0 for a band above the ones
    /// stored), mm³.
    pub fn band_volume_mm3(&self, step: usize, k: usize) -> f64 {
        self.band_volumes_mm3(step).get(k).copied().unwrap_or(0.0)
    }

    /// S4's contact-direction resultant in XY: Σ over cut columns of the unit
    /// horizontal vector from the tool axis towards the column, weighted by the
    /// removed volume (mm³). The cutting force on the tool points the other way.
    pub fn contact_resultant(&self, step: usize) -> [f64; 2] {
        let r = self.row(step);
        [r[slot::CONTACT_X], r[slot::CONTACT_Y]]
    }

    /// Σ over removed volume of dV / h, where h is the thickness the edge cut
    /// during the step at that point, normal to the tool surface (mm², MODEL.md
    /// §3.2). The step's mean chip thickness is `volume / this`; divided by the
    /// tooth passes of the step it is the mean chip thickness per tooth.
    pub fn chip_edge_area_mm2(&self, step: usize) -> f64 {
        self.row(step)[slot::CHIP_AREA]
    }

    /// Σ over removed volume of dV / r, r the tool's radius where the edge cut
    /// it (mm²): turns specific cutting energy into mean tangential force
    /// (MODEL.md §3.2).
    pub fn volume_over_radius_mm2(&self, step: usize) -> f64 {
        self.row(step)[slot::OVER_RADIUS]
    }

    /// Bytes the record holds on the heap (its vectors' capacities).
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.data.capacity() * size_of::<f64>()
            + self.bands.capacity() * size_of::<f64>()
            + self.band_start.capacity() * size_of::<usize>()
            + self.offsets.capacity() * size_of::<[f32; 2]>()
    }

    /// Sum of all step volumes, mm³.
    pub fn total_volume_mm3(&self) -> f64 {
        (0..self.len()).map(|i| self.volume_mm3(i)).sum()
    }
}

/// What [`Sweep::whole_into`] gives each step's row to, as `sink(step, row)`.
pub type RowSink<'s> = dyn FnMut(usize, RecordRow<'_>) + 's;

/// One step's values in a [`RemovalRecord`], or given to a sink by
/// [`Sweep::whole_into`] as the sweep makes them final (the same accessors
/// and the same values bit for bit).
#[derive(Clone, Copy, Debug)]
pub struct RecordRow<'r> {
    /// The [`slot`] values.
    head: &'r [f64],
    /// Band 0 up to the highest whose bit pattern is not +0.0.
    bands: &'r [f64],
    /// Each band's range of lateral offsets.
    offsets: &'r [[f32; 2]],
}

impl<'r> RecordRow<'r> {
    /// A full row of the sweep (head values, then every band of its tool)
    /// and the offset ranges of every band.
    fn of_full(row: &'r [f64], offsets: &'r [[f32; 2]]) -> Self {
        let kept = kept_bands(row);
        RecordRow {
            head: &row[..HEAD],
            bands: &row[HEAD..HEAD + kept],
            offsets: &offsets[..kept],
        }
    }

    /// [`RemovalRecord::volume_mm3`].
    pub fn volume_mm3(&self) -> f64 {
        self.head[slot::VOLUME]
    }

    /// [`RemovalRecord::shank_volume_mm3`].
    pub fn shank_volume_mm3(&self) -> f64 {
        self.head[slot::SHANK]
    }

    /// [`RemovalRecord::band_volumes_mm3`]: band 0 up to the highest that
    /// is not zero.
    pub fn band_volumes_mm3(&self) -> &'r [f64] {
        self.bands
    }

    /// [`RemovalRecord::band_offsets_mm`]: as many as
    /// [`band_volumes_mm3`](Self::band_volumes_mm3), [`EMPTY_OFFSETS`] where
    /// a band received no side cut's removal.
    pub fn band_offsets_mm(&self) -> &'r [[f32; 2]] {
        self.offsets
    }

    /// [`RemovalRecord::band_offset_mm`].
    pub fn band_offset_mm(&self, k: usize) -> Option<[f32; 2]> {
        offsets_or_none(self.offsets.get(k))
    }

    /// [`RemovalRecord::contact_resultant`].
    pub fn contact_resultant(&self) -> [f64; 2] {
        [self.head[slot::CONTACT_X], self.head[slot::CONTACT_Y]]
    }

    /// [`RemovalRecord::chip_edge_area_mm2`].
    pub fn chip_edge_area_mm2(&self) -> f64 {
        self.head[slot::CHIP_AREA]
    }

    /// [`RemovalRecord::volume_over_radius_mm2`].
    pub fn volume_over_radius_mm2(&self) -> f64 {
        self.head[slot::OVER_RADIUS]
    }
}

/// Bands of a full row (head values, then every band) that a compact record
/// keeps: up to the last one whose bit pattern is not +0.0.
fn kept_bands(row: &[f64]) -> usize {
    row[HEAD..]
        .iter()
        .rposition(|v| v.to_bits() != 0)
        .map_or(0, |k| k + 1)
}

/// Per-move values computed once.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    p0: [f64; 3],
    d: [f64; 3],
    /// |d_xy|² and |d|².
    h2: f64,
    dd: f64,
    /// 1/|d_xy|² and 1/|d|² (0 for a plunge).
    inv_h2: f64,
    inv_dd: f64,
    /// Unit XY direction and XY length (zero for a plunge).
    u: [f64; 2],
    len_xy: f64,
    /// 1 / XY length (0 for a plunge).
    inv_len_xy: f64,
    /// 1 / the floor of the cut thickness ([`MIN_THICKNESS_SHARE`] of the length).
    inv_floor: f64,
    /// Lowest tip z along the move: nothing at or below this top can be cut.
    zmin: f64,
    /// The sweep's previous move (same tool) ended exactly where this one
    /// starts, so its end tool has already cut every column down to this
    /// move's start tool at most.
    follows: bool,
}

/// Floor of the cut thickness as a share of the step length (flanks, where
/// the edge runs along the material: the chip there is thin but not zero).
/// It biases the mean chip thickness of a full slot up by about 1 %.
const MIN_THICKNESS_SHARE: f64 = 0.03;

/// Horizontal moves shorter than this (mm²) are treated as pure plunges.
const PLUNGE_H2: f64 = 1e-18;

impl Prepared {
    fn new(step: &Step) -> Prepared {
        let p0 = step.from_mm;
        let d = [
            step.to_mm[0] - p0[0],
            step.to_mm[1] - p0[1],
            step.to_mm[2] - p0[2],
        ];
        let h2 = d[0] * d[0] + d[1] * d[1];
        let len_xy = h2.sqrt();
        let u = if h2 > PLUNGE_H2 {
            [d[0] / len_xy, d[1] / len_xy]
        } else {
            [0.0, 0.0]
        };
        let dd = h2 + d[2] * d[2];
        let (inv_h2, inv_dd) = if h2 > PLUNGE_H2 {
            (1.0 / h2, 1.0 / dd)
        } else {
            (0.0, 0.0)
        };
        Prepared {
            p0,
            d,
            h2,
            dd,
            inv_h2,
            inv_dd,
            u,
            len_xy,
            inv_len_xy: if h2 > PLUNGE_H2 { 1.0 / len_xy } else { 0.0 },
            inv_floor: 1.0 / (MIN_THICKNESS_SHARE * dd.sqrt()).max(1e-12),
            zmin: p0[2].min(step.to_mm[2]),
            follows: false,
        }
    }

    /// X-interval of the row at `y` less than `behind_mm` behind the move's
    /// start (w · u ≥ −behind_mm, w from the start to the column, u the unit
    /// XY direction), widened by a nanometre (a column on the boundary is
    /// evaluated, not skipped); `None` for a plunge.
    /// (The kernel takes it in lanes: [`Prepared::row_bounds`].)
    #[cfg(test)]
    fn ahead_span(&self, y: f64, behind_mm: f64) -> Option<Span> {
        if self.h2 <= PLUNGE_H2 {
            return None;
        }
        let [ux, uy] = self.u;
        let (a, b) = linear_range(ux, uy * (y - self.p0[1]), -behind_mm - 1e-9, f64::INFINITY);
        (a <= b).then_some(Span {
            lo: self.p0[0] + a,
            hi: self.p0[0] + b,
        })
    }

    /// X-interval of the move's footprint (stadium of radius `r`) on the row at
    /// `y`. (The kernel takes it in lanes: [`Prepared::footprint_in_lanes`].)
    #[cfg(test)]
    fn row_span(&self, y: f64, r: f64) -> Option<Span> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (cx, cy) in [
            (self.p0[0], self.p0[1]),
            (self.p0[0] + self.d[0], self.p0[1] + self.d[1]),
        ] {
            let dy = y - cy;
            if dy.abs() <= r {
                let w = (r * r - dy * dy).sqrt();
                lo = lo.min(cx - w);
                hi = hi.max(cx + w);
            }
        }
        if self.h2 > PLUNGE_H2 {
            // Band: |u × w| ≤ r and 0 ≤ u·w ≤ len, with w = (x − x0, y − y0); both linear in x.
            let wy = y - self.p0[1];
            let [ux, uy] = self.u;
            let (a0, a1) = linear_range(-uy, ux * wy, -r, r);
            let (b0, b1) = linear_range(ux, uy * wy, 0.0, self.len_xy);
            let (s0, s1) = (a0.max(b0), a1.min(b1));
            if s0 <= s1 {
                lo = lo.min(self.p0[0] + s0);
                hi = hi.max(self.p0[0] + s1);
            }
        }
        (lo <= hi).then_some(Span { lo, hi })
    }

    /// For the rows `iy0, iy0 + 1, …` (`rows` of them): the
    /// columns whose centres lie in the move's footprint of radius `r`
    /// (`Prepared::row_span`, [`Grid::ix_range`]) and, with `behind_mm`,
    /// ahead of its start (`Prepared::ahead_span`; none on a plunge), into
    /// `bounds` (first > last where none). Returns the footprint's columns
    /// summed over the rows before the second narrowing (the columns
    /// visited). In lanes, free of branches: each value the expression of
    /// those functions, the one that applies taken by a select, so the same
    /// columns as row by row (test `row_bounds_in_lanes_are_row_by_rows`).
    #[inline(always)]
    pub(super) fn row_bounds(
        &self,
        grid: &Grid,
        iy0: usize,
        rows: usize,
        r: f64,
        behind_mm: Option<f64>,
        bounds: &mut RowBounds,
    ) -> u64 {
        debug_assert!(iy0 + rows <= i32::MAX as usize);
        debug_assert!(grid.nx <= i32::MAX as usize);
        let plunge = self.h2 <= PLUNGE_H2;
        let [ux, uy] = self.u;
        // Whether to narrow to the start, and how far behind it (loop-invariant
        // choices taken as selects, so the loop is one of lanes).
        let (narrow, behind_mm) = match behind_mm {
            Some(behind_mm) => (true, behind_mm),
            None => (false, 0.0),
        };
        // (Summed as i64 from i32 differences: conversions the lanes have.)
        let mut visited = 0i64;
        let RowBounds { first, last } = bounds;
        let (first, last) = (&mut first[..rows], &mut last[..rows]);
        for (i, (first, last)) in first.iter_mut().zip(last.iter_mut()).enumerate() {
            let y = grid.y_mm_in_lanes(iy0 + i);
            let CentreBounds {
                first: f,
                last: l,
                any: covered,
            } = self.footprint_in_lanes(grid, y, r);
            let wy = y - self.p0[1];
            // (Wrapping where the row has no columns: that count is not taken.)
            let count = (l as i32).wrapping_sub(f as i32).wrapping_add(1);
            visited += if covered { count as i64 } else { 0 };
            // `ahead_span` over the footprint's columns.
            let (a, b) = linear_range_in_lanes(ux, uy * wy, -behind_mm - 1e-9, f64::INFINITY);
            let ahead = grid.ix_bounds_in_lanes(self.p0[0] + a, self.p0[0] + b);
            let (nf, nl) = (f.max(ahead.first), l.min(ahead.last));
            let ahead = !plunge && a <= b && ahead.any && nf <= nl;
            let (f, l) = if narrow { (nf, nl) } else { (f, l) };
            let cut = covered && (!narrow || ahead);
            *first = if cut { f as i32 } else { 1 };
            *last = if cut { l as i32 } else { 0 };
        }
        visited as u64
    }

    /// `Prepared::row_span` of radius `r` on the row at `y` and its columns
    /// ([`Grid::ix_bounds_in_lanes`]): first, last and whether there are any, free of
    /// branches (each value the expression of those functions, the one that
    /// applies taken by a select) for [`Prepared::row_bounds`] and the reach's
    /// narrowing, whose lanes are rows.
    #[inline(always)]
    pub(super) fn footprint_in_lanes(&self, grid: &Grid, y: f64, r: f64) -> CentreBounds {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (cx, cy) in [
            (self.p0[0], self.p0[1]),
            (self.p0[0] + self.d[0], self.p0[1] + self.d[1]),
        ] {
            let dy = y - cy;
            let inside = dy.abs() <= r;
            let w = (r * r - dy * dy).sqrt();
            lo = if inside { lo.min(cx - w) } else { lo };
            hi = if inside { hi.max(cx + w) } else { hi };
        }
        let wy = y - self.p0[1];
        let [ux, uy] = self.u;
        let (a0, a1) = linear_range_in_lanes(-uy, ux * wy, -r, r);
        let (b0, b1) = linear_range_in_lanes(ux, uy * wy, 0.0, self.len_xy);
        let (s0, s1) = (a0.max(b0), a1.min(b1));
        let band = self.h2 > PLUNGE_H2 && s0 <= s1;
        lo = if band { lo.min(self.p0[0] + s0) } else { lo };
        hi = if band { hi.max(self.p0[0] + s1) } else { hi };
        let columns = grid.ix_bounds_in_lanes(lo, hi);
        CentreBounds {
            any: lo <= hi && columns.any,
            ..columns
        }
    }

    /// Grid rows `[first, last]` the move's footprint (radius `r`) can touch.
    #[inline]
    fn row_range(&self, grid: &Grid, r: f64) -> Option<(usize, usize)> {
        let (y0, y1) = (self.p0[1], self.p0[1] + self.d[1]);
        grid.iy_range(y0.min(y1) - r, y0.max(y1) + r)
    }
}

/// Values of x with `lo ≤ coef·x + c0 ≤ hi`, as an interval (possibly empty or
/// unbounded). (The kernel takes it in lanes: [`linear_range_in_lanes`].)
#[cfg(test)]
fn linear_range(coef: f64, c0: f64, lo: f64, hi: f64) -> (f64, f64) {
    if coef.abs() < 1e-12 {
        if c0 >= lo && c0 <= hi {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        }
    } else {
        let (a, b) = ((lo - c0) / coef, (hi - c0) / coef);
        (a.min(b), a.max(b))
    }
}

/// `linear_range` free of branches (both of its cases, one selected): the
/// same values.
#[inline(always)]
fn linear_range_in_lanes(coef: f64, c0: f64, lo: f64, hi: f64) -> (f64, f64) {
    let (a, b) = ((lo - c0) / coef, (hi - c0) / coef);
    let inside = c0 >= lo && c0 <= hi;
    let (flat_lo, flat_hi) = if inside {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        (f64::INFINITY, f64::NEG_INFINITY)
    };
    if coef.abs() < 1e-12 {
        (flat_lo, flat_hi)
    } else {
        (a.min(b), a.max(b))
    }
}

/// The columns of each of a run of rows a move can reach
/// ([`Prepared::row_bounds`]): `first[i]..=last[i]` on row `iy0 + i`, first >
/// last where none. Allocated once per strip.
#[derive(Clone, Debug)]
pub(super) struct RowBounds {
    pub(super) first: Vec<i32>,
    pub(super) last: Vec<i32>,
}

impl RowBounds {
    /// Room for `n` rows.
    pub(super) fn new(n: usize) -> RowBounds {
        RowBounds {
            first: vec![1; n],
            last: vec![0; n],
        }
    }

    /// The columns `first..=last` of row `i` of the run, `None` where it has none.
    #[inline]
    pub(super) fn row(&self, i: usize) -> Option<(usize, usize)> {
        let (first, last) = (self.first[i], self.last[i]);
        (first <= last).then_some((first as usize, last as usize))
    }

    /// Row `i` of the run left without columns.
    #[inline]
    pub(super) fn clear(&mut self, i: usize) {
        (self.first[i], self.last[i]) = (1, 0);
    }
}

/// An interval `[lo, hi]`: of x on a grid row, or of the move parameter t.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    lo: f64,
    hi: f64,
}

/// Where the swept tool's lower envelope meets a column's vertical line.
#[derive(Clone, Copy, Debug, PartialEq)]
struct EnvelopeHit {
    /// Height of the envelope, mm.
    z_mm: f64,
    /// Move parameter t ∈ [0, 1] where it is attained.
    t: f64,
}

/// The cutting edge at a height above the tip.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    /// Radius of the edge, mm: at least [`MIN_EDGE_RADIUS`]·(corner radius).
    r_mm: f64,
    /// 1 / `r_mm`.
    inv_r: f64,
    /// 1 / sin κ, κ the angle between the tool surface's normal there and the
    /// axis (90° on a cylindrical flank).
    inv_sin_k: f64,
}

/// The edge at height `h` ≥ 0 above the tip of a tool of radius `r` whose
/// corner is a torus of radius `rc` around a ring of radius `ring` = r − rc
/// (MODEL.md §3.2): r(h) = ring + √(h (2 rc − h)), sin κ = (r(h) − ring) / rc,
/// and the flank (r, κ = 90°) from h = rc up. A ball is the torus with
/// `ring` = 0 and `rc` = R; a flat end has no corner below the flank.
#[inline]
fn torus_edge(h: f64, r: f64, rc: f64, ring: f64) -> Edge {
    // Both the flank's edge and the corner's, the one that applies taken by a
    // select: the contacts' loop over a move's cuts runs in lanes.
    let flank = h >= rc;
    let e = (h * (2.0 * rc - h)).sqrt().max(MIN_EDGE_RADIUS * rc);
    let inv_e = 1.0 / e;
    // On a ball the edge radius is e itself: no second division.
    let (r_mm, inv_r) = if ring == 0.0 {
        (e, inv_e)
    } else {
        let r_mm = ring + e;
        (r_mm, 1.0 / r_mm)
    };
    Edge {
        r_mm: if flank { r } else { r_mm },
        inv_r: if flank { 1.0 / r } else { inv_r },
        inv_sin_k: if flank { 1.0 } else { rc * inv_e },
    }
}

/// Lower envelope of a swept tool on one vertical line.
trait Envelope: Sync {
    /// The lowest point of the swept tool above `(x, y)` and the move
    /// parameter where it is attained; `None` if the tool never passes over
    /// the point.
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<EnvelopeHit>;

    /// Whether the strip loop makes a row's hits with [`Envelope::row_hits`]
    /// before cutting (a tool whose row is made in lanes) rather than column
    /// by column as it cuts ([`column_hit`]); the same values either way.
    #[inline(always)]
    fn row_in_lanes(&self) -> bool {
        false
    }

    /// The columns `ix0, ix0 + 1, …` of the row at `y` (their tops `tops`)
    /// that the move cuts, into the first `tops.len()` of `hits` (see
    /// [`RowHits`]). Column by column by default ([`column_hit`]); a tool
    /// may make the row in lanes, each the same arithmetic.
    #[inline(always)]
    fn row_hits(
        &self,
        m: &Prepared,
        grid: &crate::Grid,
        y: f64,
        ix0: usize,
        tops: &[f32],
        hits: &mut RowHits,
    ) {
        row_hits_by_column(self, m, grid, y, ix0, tops, hits)
    }

    /// A cheap test, made before `eval`, that the swept tool stays at or above
    /// `top` over `(x, y)` (so the column cannot be cut); `false` when unsure.
    #[inline]
    fn stays_above(&self, _m: &Prepared, _x: f64, _y: f64, _top: f64) -> bool {
        false
    }

    /// Whether [`Envelope::reach`] gives a bound (a constant per tool shape,
    /// so the strip loop does not ask `reach` per row).
    #[inline]
    fn has_reach(&self) -> bool {
        false
    }

    /// XY distance from the move's axis segment beyond which the swept tool
    /// stays above `m.zmin + depth` (so a row's columns no higher than that
    /// can be cut only within it); `None` when the tool has no such bound.
    #[inline]
    fn reach(&self, _m: &Prepared, _depth: f64) -> Option<f64> {
        None
    }

    /// For a move that follows the previous one (same tool, starting where it
    /// ended): the distance behind its start, along its XY direction, beyond
    /// which the swept tool is lowest at its start over every column, so the
    /// previous move's end tool has already cut there (MODEL.md §1.2); `None`
    /// where there is no such region. Any tool on a move that does not
    /// descend: 0 (behind the start the distance to the axis and the tip
    /// height both grow along the move); a plunge that does not descend
    /// cuts nothing new anywhere.
    #[inline]
    fn behind_mm(&self, m: &Prepared) -> Option<f64> {
        (m.d[2] >= 0.0).then_some(0.0)
    }

    /// The cutting edge at height `h` ≥ 0 above the tip.
    fn side(&self, h: f64) -> Edge;

    /// cos κ of the tool surface at height `h` ≥ 0 above the tip, where the
    /// lowest point of a removed piece lies (1 on a flat bottom).
    fn bottom_cos(&self, h: f64) -> f64;

    /// Mean of 1/sin κ over the heights `[h_bot, h_top]` above the tip that a
    /// piece was cut across (MODEL.md §3.2): each height is cut at its own
    /// chip thickness L sin κ cos θ; 1/sin κ at `h_top` where κ does not vary.
    #[inline]
    fn mean_inv_sin_k(&self, _h_bot: f64, h_top: f64) -> f64 {
        self.side(h_top).inv_sin_k
    }

    /// Mean of 1/(sin κ cos θ) over the heights `[h_bot, h_top]` of a column at
    /// signed offset `e` from the move's line, where θ too varies with the
    /// height (sin θ = e / r(h)), as the arcsine that makes it ([`ArcsineMean`]:
    /// the strip takes many such arcsines in one loop); `None` where no closed
    /// form is used.
    #[inline]
    fn mean_inv_side(&self, _h_bot: f64, _h_top: f64, _e: f64) -> Option<ArcsineMean> {
        None
    }
}

/// A mean that is one difference of arcsines d = asin(a) − asin(b)
/// ([`arcsine::asin_diff`]): (scale · d + add) / span (made by the strip's
/// `SidePieces::value`, many at a time).
#[derive(Clone, Copy, Debug)]
struct ArcsineMean {
    diff: arcsine::AsinDiff,
    scale: f64,
    add: f64,
    span: f64,
}

impl ArcsineMean {
    /// A placeholder (never a mean read).
    const NONE: ArcsineMean = ArcsineMean {
        diff: arcsine::AsinDiff {
            arg: 0.0,
            form: arcsine::DiffForm::Sin,
        },
        scale: 0.0,
        add: 0.0,
        span: 1.0,
    };
}

/// What a move does to each column of a row ([`Envelope::row_hits`]): the
/// height it leaves (f32, as the tops), +∞ where it does not reach below the
/// column's top (a top at or below the move's lowest tip,
/// [`Envelope::stays_above`], no [`Envelope::eval`] hit), so that a column
/// is cut where its top lies above `z_mm`; and the move parameter where the
/// tool is lowest over it (0 where it is not cut). Allocated once per strip.
#[derive(Clone, Debug)]
struct RowHits {
    z_mm: Vec<f32>,
    t: Vec<f64>,
}

impl RowHits {
    /// Room for `n` columns.
    fn new(n: usize) -> RowHits {
        RowHits {
            z_mm: vec![0.0; n],
            t: vec![0.0; n],
        }
    }
}

/// [`Envelope::row_hits`] column by column ([`column_hit`]).
#[inline(always)]
fn row_hits_by_column<E: Envelope + ?Sized>(
    env: &E,
    m: &Prepared,
    grid: &crate::Grid,
    y: f64,
    ix0: usize,
    tops: &[f32],
    hits: &mut RowHits,
) {
    for (i, &top) in tops.iter().enumerate() {
        (hits.z_mm[i], hits.t[i]) = match column_hit(env, m, grid.x_mm(ix0 + i), y, top) {
            Some(EnvelopeHit { z_mm, t }) => (z_mm as f32, t),
            None => (f32::INFINITY, 0.0),
        };
    }
}

/// One column's [`Envelope::row_hits`]: where the move's envelope lies over
/// `(x, y)`, or `None` where it cannot cut a column whose top is `top` (a top
/// at or below the lowest tip, [`Envelope::stays_above`], no
/// [`Envelope::eval`] hit).
#[inline(always)]
fn column_hit<E: Envelope + ?Sized>(
    env: &E,
    m: &Prepared,
    x: f64,
    y: f64,
    top: f32,
) -> Option<EnvelopeHit> {
    if top <= m.zmin as f32 || env.stays_above(m, x, y, top as f64) {
        None
    } else {
        env.eval(m, x, y)
    }
}

/// [`Envelope::mean_inv_sin_k`] of a torus corner of radius `rc` (a ball: rc =
/// R) below its flank: with h = rc (1 − cos κ), ∫ dh / sin κ = rc dκ, so the
/// mean over `[h_bot, h_top]` is rc Δκ / Δh on the corner plus 1 per mm of flank.
#[inline]
fn torus_mean_inv_sin_k(h_bot: f64, h_top: f64, rc: f64) -> Option<f64> {
    let (lo, hi) = (h_bot.max(0.0), h_top.max(0.0));
    let span = hi - lo;
    if span <= 1e-6 * rc || lo >= rc {
        return None;
    }
    // κ = acos u with u = 1 − h/rc: κ(hi) − κ(lo) = asin u(lo) − asin u(hi).
    let u = |h: f64| 1.0 - h.min(rc) / rc;
    let corner = rc * arcsine::asin_diff(u(lo), u(hi));
    let flank = (hi - rc).max(0.0);
    Some((corner + flank) / span)
}

/// Squared XY distance from a sphere's axis beyond which its lower surface
/// (radius `r`) lies at least `depth` above its lowest point:
/// r − √(r² − ρ²) ≥ δ ⟺ ρ² ≥ δ (2r − δ) for δ ≤ r. Used up to δ = r/2, where
/// the rounding of ρ² moves the height by far less than the margin; deeper, the
/// parabola's 2rδ (the sphere lies above the parabola ρ²/2r).
#[inline]
fn sphere_reach2(r: f64, depth: f64) -> f64 {
    if depth <= 0.5 * r {
        depth * (2.0 * r - depth)
    } else {
        2.0 * r * depth
    }
}

/// Heights above the tip below this (mm) count as the tool's flat bottom.
const BOTTOM_MM: f64 = 1e-6;

/// Smallest edge radius used for chip sums, as a share of the tool radius
/// (the very tip of a ball has r → 0).
const MIN_EDGE_RADIUS: f64 = 1e-3;

/// Margin of [`Envelope::stays_above`], mm: far below an f32 height's
/// resolution, far above the f64 rounding of the bound (and the ≤ 1e-9 mm a
/// plunge's tiny horizontal part can shift the closest axis point).
const ABOVE_MARGIN_MM: f64 = 1e-7;

/// Parameter interval in which the point `(x, y)` lies within `r` of the tool
/// axis (XY), clipped to [0, 1].
#[inline]
fn disc_interval(m: &Prepared, x: f64, y: f64, r: f64) -> Option<Span> {
    let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
    if m.h2 <= PLUNGE_H2 {
        let rho0 = wx * wx + wy * wy;
        return (rho0 <= r * r).then_some(Span { lo: 0.0, hi: 1.0 });
    }
    let roots = disc_roots(m, wx, wy, r * r);
    roots.hit().then_some(roots.span)
}

/// [`disc_interval`] of the column at `(wx, wy)` from the start of a move
/// that is not a plunge, with the disc's radius squared `r2`: one expression
/// for it and a row in lanes (which take its parts whether or not it hits).
#[derive(Clone, Copy)]
struct DiscRoots {
    /// w · d_xy.
    k: f64,
    /// The quadratic's discriminant: negative where the column misses.
    disc: f64,
    /// Its roots clipped to [0, 1] (NaN where `disc` < 0).
    span: Span,
}

impl DiscRoots {
    /// The column lies under the disc somewhere along the move.
    #[inline(always)]
    fn hit(&self) -> bool {
        self.disc >= 0.0 && self.span.lo <= self.span.hi
    }
}

/// |w − t·d_xy|² ≤ r²: quadratic in t ([`DiscRoots`]).
#[inline(always)]
fn disc_roots(m: &Prepared, wx: f64, wy: f64, r2: f64) -> DiscRoots {
    let rho0 = wx * wx + wy * wy;
    let k = wx * m.d[0] + wy * m.d[1];
    let disc = k * k - m.h2 * (rho0 - r2);
    let s = disc.sqrt();
    DiscRoots {
        k,
        disc,
        span: Span {
            lo: ((k - s) / m.h2).max(0.0),
            hi: ((k + s) / m.h2).min(1.0),
        },
    }
}

/// Shared test references: dense sampling of the swept tool, a small
/// pseudo-random sequence, the move's point at t.
#[cfg(test)]
pub(super) mod testing {
    use super::*;

    /// Lowest point of the tool's lower surface above (x, y) by dense sampling of t.
    pub(super) fn brute_force(
        profile: &dyn Fn(f64) -> Option<f64>,
        step: &Step,
        x: f64,
        y: f64,
    ) -> Option<f64> {
        let n = 200_000;
        let mut best: Option<f64> = None;
        for i in 0..=n {
            let p = m_at(step, i as f64 / n as f64);
            let rho = ((x - p[0]).powi(2) + (y - p[1]).powi(2)).sqrt();
            if let Some(h) = profile(rho) {
                let z = p[2] + h;
                best = Some(best.map_or(z, |b: f64| b.min(z)));
            }
        }
        best
    }

    /// A small deterministic pseudo-random sequence (no test dependency on rand).
    pub(super) fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    pub(super) fn check_against_brute_force(
        env: &dyn Envelope,
        profile: &dyn Fn(f64) -> Option<f64>,
        tol: f64,
    ) {
        let mut seed = 7;
        for case in 0..300 {
            let mut r = || lcg(&mut seed) * 20.0 - 10.0;
            let step = Step {
                from_mm: [r(), r(), r()],
                to_mm: [r(), r(), r()],
                rapid: false,
            };
            let step = if case % 10 == 0 {
                Step {
                    to_mm: [step.from_mm[0], step.from_mm[1], step.to_mm[2]],
                    ..step
                }
            } else {
                step
            };
            let m = Prepared::new(&step);
            let (x, y) = (r() * 0.8, r() * 0.8);
            let exact = env.eval(&m, x, y).map(|e| e.z_mm);
            let sampled = brute_force(profile, &step, x, y);
            match (exact, sampled) {
                (Some(e), Some(s)) => {
                    assert!(
                        e <= s + 1e-9,
                        "case {case}: envelope {e} above sampled minimum {s}"
                    );
                    assert!(
                        e >= s - tol,
                        "case {case}: envelope {e} far below sampled minimum {s}"
                    );
                }
                (None, None) => {}
                // Sampling can miss a footprint only a hair wide.
                (Some(_), None) | (None, Some(_)) => {
                    let near = (0..=1000).any(|i| {
                        let p = m_at(&step, i as f64 / 1000.0);
                        (((x - p[0]).powi(2) + (y - p[1]).powi(2)).sqrt() - 5.0).abs() < 1e-2
                    });
                    assert!(
                        near,
                        "case {case}: footprint disagreement {exact:?} vs {sampled:?}"
                    );
                }
            }
        }
    }

    pub(super) fn m_at(step: &Step, t: f64) -> [f64; 3] {
        std::array::from_fn(|k| step.from_mm[k] + t * (step.to_mm[k] - step.from_mm[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compact columns give back every value of the full rows, bit for
    /// bit: trailing +0.0 bands dropped (read as 0), a trailing −0.0 kept;
    /// appending compact records equals compacting the rows together.
    #[test]
    fn compact_record_keeps_every_value() {
        let rows: [[f64; HEAD + 4]; 4] = [
            [1.0, 0.0, 0.5, -0.5, 2.0, 3.0, 0.75, 0.25, 0.0, 0.0],
            [0.0; HEAD + 4],
            [2.0, 0.1, 0.0, 1.0, 4.0, 5.0, 0.0, 1.0, 0.0, 0.9],
            [1e-9, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-9, 0.0, -0.0, 0.0],
        ];
        let full = |rows: &[[f64; HEAD + 4]]| {
            let mut r = RemovalRecord::new(rows.len(), 4, 1.0);
            for (i, row) in rows.iter().enumerate() {
                r.data[i * (HEAD + 4)..(i + 1) * (HEAD + 4)].copy_from_slice(row);
            }
            r
        };
        let mut r = full(&rows);
        let before = r.clone();
        r.compact();
        assert_eq!(r.len(), 4);
        assert_eq!(r.data.len(), 4 * HEAD);
        assert_eq!(r.band_volumes_mm3(0), &[0.75, 0.25]);
        assert!(r.band_volumes_mm3(1).is_empty());
        assert_eq!(r.band_volumes_mm3(2).len(), 4);
        assert_eq!(r.band_volumes_mm3(3).len(), 3, "−0.0 is kept");
        for i in 0..4 {
            assert_eq!(r.row(i), &before.row(i)[..HEAD]);
            for k in 0..4 {
                assert_eq!(
                    r.band_volume_mm3(i, k).to_bits(),
                    before.band_volumes_mm3(i)[k].to_bits(),
                    "step {i} band {k}"
                );
            }
        }
        let mut joined = RemovalRecord::compact_empty(4, 1.0);
        for part in [&rows[..1], &rows[1..3], &rows[3..]] {
            let mut p = full(part);
            p.compact();
            joined.append(&p);
        }
        assert_eq!(joined, r);
    }

    #[test]
    fn row_span_is_the_stadium() {
        let m = Prepared::new(&Step {
            from_mm: [0.0, 0.0, 0.0],
            to_mm: [10.0, 10.0, 0.0],
            rapid: false,
        });
        let Span { lo, hi } = m.row_span(5.0, 1.0).unwrap();
        let h = 2f64.sqrt();
        assert!(
            (lo - (5.0 - h)).abs() < 1e-12 && (hi - (5.0 + h)).abs() < 1e-12,
            "{lo} {hi}"
        );
        assert!(m.row_span(11.5, 1.0).is_none());
        // Near the end the band still reaches further left than the end circle.
        let Span { lo, hi } = m.row_span(10.5, 1.0).unwrap();
        let w = (1.0f64 - 0.25).sqrt();
        assert!(
            (lo - (10.5 - h)).abs() < 1e-12 && (hi - (10.0 + w)).abs() < 1e-12,
            "{lo} {hi}"
        );
    }
}
