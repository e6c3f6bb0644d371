//! One strip of rows: every move of a batch that reaches it, column by column
//! (envelope, removal, bands, contact and smoothing shares).

use super::arcsine::{asin_small, AsinDiff, DiffForm};
use super::slot::{CHIP_AREA, CONTACT_X, CONTACT_Y, OVER_RADIUS, SHANK, VOLUME};
use super::{
    column_hit, ArcsineMean, Envelope, EnvelopeHit, Prepared, RowBounds, RowHits, HEAD, PLUNGE_H2,
};
use crate::stock::RowBelow;
use crate::top::Top;
use crate::Grid;

/// The body of a dispatching method: `$avx2` (its compilation for AVX2 and
/// FMA, a `#[target_feature]` method) where the processor has them, else
/// `$portable`; each lane of the two is the same IEEE operation, so they give
/// the same bits.
macro_rules! with_avx2 {
    ($avx2:expr, $portable:expr) => {{
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor running this has AVX2 and FMA (just checked).
            #[allow(unsafe_code)]
            return unsafe { $avx2 };
        }
        $portable
    }};
}

/// Per-(strip, move) accumulator width and band bookkeeping shared by the strip loop.
pub(super) struct Banding {
    pub(super) n_bands: usize,
    pub(super) band_h: f64,
    pub(super) inv_band_h: f64,
    pub(super) flute_len: f64,
}

impl Banding {
    /// Credit the removed piece [a, b] (absolute z) of a column to the bands
    /// above a tip at `z_tip` and to the shank; `acc` is [volume, shank, cx, cy,
    /// chip area, volume over radius, bands…] in mm. Each band credited takes
    /// the column's lateral offset `e` into its range in `ranges` (one
    /// [min, max] a band; MODEL.md §1.7); a NaN `e` (a plunge) changes no
    /// range. Returns the piece's length (the caller adds it to the volume).
    #[inline]
    fn credit(
        &self,
        acc: &mut [f64],
        ranges: &mut [[f32; 2]],
        e: f32,
        z_tip: f64,
        a: f64,
        b: f64,
    ) -> f64 {
        let mut lo = (a - z_tip).max(0.0);
        let hi = (b - z_tip).max(lo);
        let length = hi - lo;
        // Band indices and tops through i64 (one conversion instruction each
        // way; band counts are small) and plain compares for the minima
        // (nothing here is NaN): the same values as usize and `f64::min`.
        let mut k = (lo * self.inv_band_h) as i64;
        let n_bands = self.n_bands as i64;
        let ranges = &mut ranges[..self.n_bands];
        while lo < hi && k < n_bands {
            let mut top = ((k + 1) as f64) * self.band_h;
            if self.flute_len < top {
                top = self.flute_len;
            }
            if hi < top {
                top = hi;
            }
            if top > lo {
                acc[HEAD + k as usize] += top - lo;
                // Plain compares (one minimum and one maximum instruction):
                // false for a NaN `e`.
                let range = &mut ranges[k as usize];
                if e < range[0] {
                    range[0] = e;
                }
                if e > range[1] {
                    range[1] = e;
                }
                lo = top;
            }
            k += 1;
        }
        if lo < hi {
            acc[SHANK] += hi - lo;
        }
        length
    }
}

/// Remove everything at and above `z` from column `ix` of a row (its top
/// interval `lo..hi`, the intervals below in `below`), reporting each removed
/// piece from the top down.
#[inline]
fn cut_above(
    hi: &mut f32,
    lo: &mut f32,
    below: &mut RowBelow,
    ix: usize,
    z: f32,
    mut piece: impl FnMut(f32, f32),
) {
    while *hi > z && *lo < *hi {
        if *lo >= z {
            piece(*lo, *hi);
            let top = match below.pop(ix) {
                Some([lo, hi]) => Top { lo, hi },
                None => Top::EMPTY,
            };
            (*lo, *hi) = (top.lo, top.hi);
        } else {
            piece(z, *hi);
            *hi = z;
            return;
        }
    }
}

/// The bottoms of a strip's top intervals as its loop cuts them
/// ([`crate::stock::Bottoms`]): the strip loop is made for each kind, so
/// that a uniform stock's column reads and writes its top alone.
pub(super) trait CutBottoms {
    /// [`cut_above`] of the column at index `i` of the strip (column `ix`
    /// of its row, whose intervals below the tops are `below`), top `hi`.
    fn cut_above(
        &mut self,
        i: usize,
        hi: &mut f32,
        below: &mut RowBelow,
        ix: usize,
        z: f32,
        piece: impl FnMut(f32, f32),
    );
}

/// One bottom for all: a uniform stock holds nothing below its tops, and a
/// column cut whole is left empty (top −∞), its bottom unchanged.
impl CutBottoms for f32 {
    #[inline]
    fn cut_above(
        &mut self,
        _: usize,
        hi: &mut f32,
        below: &mut RowBelow,
        ix: usize,
        z: f32,
        piece: impl FnMut(f32, f32),
    ) {
        cut_above(hi, &mut { *self }, below, ix, z, piece)
    }
}

/// A bottom a column.
impl CutBottoms for &mut [f32] {
    #[inline]
    fn cut_above(
        &mut self,
        i: usize,
        hi: &mut f32,
        below: &mut RowBelow,
        ix: usize,
        z: f32,
        piece: impl FnMut(f32, f32),
    ) {
        cut_above(hi, &mut self[i], below, ix, z, piece)
    }
}

/// Floor of the edge's advance normal to itself per unit of path when
/// spreading a column over steps (on a flank it runs nearly along itself).
const MIN_EDGE_SPEED: f64 = 0.1;

/// CDF at `x` of the sum of two uniform variables on [0, a] and [0, b]: the
/// share of a square cell that a straight boundary has passed, a and b being
/// the projections of the cell's sides on the boundary's normal.
#[inline]
fn trapezoid_cdf(x: f64, a: f64, b: f64) -> f64 {
    let (a, b) = if a >= b { (a, b) } else { (b, a) };
    // Every piece's value, then the one that applies.
    let two_ab = 2.0 * a * b;
    let r = a + b - x;
    let thin = x / a;
    let rising = x * x / two_ab;
    let middle = (x - 0.5 * b) / a;
    let falling = 1.0 - r * r / two_ab;
    if x <= 0.0 {
        0.0
    } else if x >= a + b {
        1.0
    } else if b <= 1e-9 * a {
        thin
    } else if x < b {
        rising
    } else if x <= a {
        middle
    } else {
        falling
    }
}

/// The columns cut by one move, row after row, and their contacts (MODEL.md
/// §1.4, §1.5, §3.2), column by column in arrays of a row's length (allocated
/// once per strip and batch: arrays of `nx`), taken until the next row
/// might not fit or the move ends. The contacts are computed in phases over
/// every cut taken (a few columns a row where a step is short against the
/// cell, so the phases run over many rows at once), each a loop of independent arithmetic free of the
/// cut's branches (square roots and divisions of many columns in flight, in
/// vector registers where the compiler packs them); the columns whose
/// chip thickness needs a mean over the cell take their arcsines in a phase
/// of their own (`asin_small` in lanes), with those that need one over a
/// thick piece's heights (a ball's). Every value is the same expression of the
/// same inputs whichever way the phases are compiled (the portable and the
/// AVX2 build agree bit for bit).
#[cfg_attr(test, derive(Clone))]
struct MoveCuts {
    /// Cuts taken so far.
    n: usize,
    /// Column centre's X and Y, mm, and the move parameter where it was cut.
    x: Vec<f64>,
    y: Vec<f64>,
    t: Vec<f64>,
    /// Heights above the tip of the column's top before the cut and of the cut, mm.
    h_top: Vec<f64>,
    h_bot: Vec<f64>,
    /// Material removed, mm.
    removed: Vec<f64>,
    /// The edge where it reached the column: radius, 1/radius, 1/sin κ.
    r_mm: Vec<f64>,
    inv_r: Vec<f64>,
    inv_sin_k: Vec<f64>,
    /// sin θ and cos θ of the angle from the feed direction where the edge
    /// circle first reaches the column.
    sin_t: Vec<f64>,
    cos_t: Vec<f64>,
    /// 1 / thickness the edge cut there during the whole step, normal to the
    /// tool surface, 1/mm: first the floor and the bottom's cut, then with
    /// the side's.
    inv_h: Vec<f64>,
    /// 1 / the side's chip thickness L_xy sin κ cos θ (or its mean), 1/mm.
    inv_side: Vec<f64>,
    /// Unit XY vector from the tool axis to the column when the edge reached it.
    r_hat: Vec<[f64; 2]>,
    /// Shares of the column credited to the previous and the next step.
    shares: Vec<[f64; 2]>,
    /// The thick pieces away from the flank (their side thickness a mean
    /// over their heights): their bottom and top above the tip and their
    /// lateral offset e, mm, and their means as the tool makes them.
    thick: Vec<u32>,
    side_bot: Vec<f64>,
    side_top: Vec<f64>,
    side_e: Vec<f64>,
    sides: SidePieces,
    /// The cuts near the flank (their cell's mean of 1/cos θ), half the
    /// cell over the edge's radius, and the form of their difference of
    /// arcsines.
    flank: Vec<u32>,
    halves: Vec<f64>,
    forms: Vec<DiffForm>,
    /// The near-flank cuts' sin θ as they are listed, then their arcsines'
    /// arguments, followed by the thick pieces'; then the arcsines.
    asin_args: Vec<f64>,
}

/// Thick pieces' [`Envelope::mean_inv_side`], field by field (so that a
/// loop of them runs in lanes): `kept` where the tool has the closed form.
#[cfg_attr(test, derive(Clone))]
struct SidePieces {
    kept: Vec<bool>,
    form: Vec<DiffForm>,
    scale: Vec<f64>,
    add: Vec<f64>,
    span: Vec<f64>,
}

impl SidePieces {
    fn new(n: usize) -> SidePieces {
        SidePieces {
            kept: Vec::with_capacity(n),
            form: Vec::with_capacity(n),
            scale: Vec::with_capacity(n),
            add: Vec::with_capacity(n),
            span: Vec::with_capacity(n),
        }
    }

    /// Room for `n` pieces (none kept until written).
    fn resize(&mut self, n: usize) {
        let none = ArcsineMean::NONE;
        self.kept.resize(n, false);
        self.form.resize(n, none.diff.form);
        self.scale.resize(n, none.scale);
        self.add.resize(n, none.add);
        self.span.resize(n, none.span);
    }

    /// Piece `j`'s mean, given `asin_arg`, the arcsine of its argument:
    /// (scale · d + add) / span ([`ArcsineMean`]).
    #[inline]
    fn value(&self, j: usize, asin_arg: f64) -> f64 {
        (self.scale[j] * self.form[j].difference(asin_arg) + self.add[j]) / self.span[j]
    }
}

impl MoveCuts {
    fn new(nx: usize) -> MoveCuts {
        let v = || vec![0.0; nx];
        MoveCuts {
            n: 0,
            x: v(),
            y: v(),
            t: v(),
            h_top: v(),
            h_bot: v(),
            removed: v(),
            r_mm: v(),
            inv_r: v(),
            inv_sin_k: v(),
            sin_t: v(),
            cos_t: v(),
            inv_h: v(),
            inv_side: v(),
            r_hat: vec![[0.0; 2]; nx],
            shares: vec![[0.0; 2]; nx],
            thick: Vec::with_capacity(nx),
            flank: Vec::with_capacity(nx),
            halves: Vec::with_capacity(nx),
            forms: Vec::with_capacity(nx),
            sides: SidePieces::new(nx),
            side_bot: Vec::with_capacity(nx),
            side_top: Vec::with_capacity(nx),
            side_e: Vec::with_capacity(nx),
            asin_args: Vec::with_capacity(nx),
        }
    }

    /// Whether a row of `columns` more columns fits.
    #[inline]
    fn fits(&self, columns: usize) -> bool {
        self.n + columns <= self.x.len()
    }

    /// Record a cut column (at most one per column of a row; room for the row
    /// checked with [`MoveCuts::fits`]).
    #[inline]
    fn push(&mut self, x: f64, y: f64, t: f64, h_top: f64, h_bot: f64, removed: f64) {
        let i = self.n;
        self.x[i] = x;
        self.y[i] = y;
        self.t[i] = t;
        self.h_top[i] = h_top;
        self.h_bot[i] = h_bot;
        self.removed[i] = removed;
        self.n = i + 1;
    }
}

/// Everything one strip needs to run its moves.
pub(super) struct StripJob<'a, E> {
    pub(super) env: &'a E,
    pub(super) grid: &'a Grid,
    pub(super) radius: f64,
    pub(super) banding: &'a Banding,
    pub(super) moves: &'a [Prepared],
    /// The program's index of the first move (a run of one tool starts
    /// where its tool is loaded): the last-cut marks are the program's.
    pub(super) first_step: usize,
    pub(super) smooth: bool,
}

/// Columns per tile of a strip whose highest top is kept (air skip).
const TILE_COLS: usize = 64;

/// Height span of a column's piece above which its chip thickness is
/// averaged over the heights it spans (MODEL.md §3.2), mm.
const THICK_PIECE_MM: f64 = 0.02;

/// Whether a piece from `h_bot` to `h_top` is credited over its heights
/// (more than [`THICK_PIECE_MM`]) rather than at its top.
#[inline(always)]
fn is_thick(h_top: f64, h_bot: f64) -> bool {
    h_top - h_bot > THICK_PIECE_MM
}

/// Accumulator width per strip entry of a move: its sums, then (smoothing)
/// the head values moved to the previous and to the next step.
pub(super) fn partial_width(banding: &Banding, smooth: bool) -> usize {
    let stride = HEAD + banding.n_bands;
    if smooth {
        stride + 2 * HEAD
    } else {
        stride
    }
}

impl<E: Envelope> StripJob<'_, E> {
    /// Accumulator width per entry: this step's sums, then (smoothing) the head
    /// values moved to the previous and to the next step.
    pub(super) fn width(&self) -> usize {
        partial_width(self.banding, self.smooth)
    }

    /// How the edge met each column cut (`cuts`, cut by `m`; MODEL.md §1.4,
    /// §1.5, §3.2), in phases over the cuts (see [`MoveCuts`]): `r_hat`,
    /// `inv_r`, `inv_side`, `inv_h` and `shares` of each cut.
    ///
    /// On an x86-64 processor with AVX2 and FMA the same code compiled for
    /// them ([`StripJob::contacts_avx2`]): the phases take four columns an
    /// instruction instead of two. Each lane's arithmetic is the same IEEE
    /// operation (Rust never fuses a multiply and an add unless asked), so
    /// the results are the same bit for bit.
    fn contacts(&self, m: &Prepared, cuts: &mut MoveCuts) {
        with_avx2!(self.contacts_avx2(m, cuts), self.contacts_body(m, cuts))
    }

    /// [`Envelope::row_hits`] of the columns `ix0, ix0 + 1, …` (tops `tops`)
    /// of the row at `y`; on an x86-64 processor with AVX2 and FMA compiled
    /// for them ([`StripJob::hits_avx2`]), the same values bit for bit (as
    /// [`StripJob::contacts`]).
    #[inline]
    fn hits(&self, m: &Prepared, y: f64, ix0: usize, tops: &[f32], hits: &mut RowHits) {
        with_avx2!(
            self.hits_avx2(m, y, ix0, tops, hits),
            self.env.row_hits(m, self.grid, y, ix0, tops, hits)
        )
    }

    /// [`Prepared::row_bounds`] of `m` over the rows `iy0..iy0 + rows` with the
    /// tool's radius; on an x86-64 processor with AVX2 and FMA compiled for
    /// them ([`StripJob::row_bounds_avx2`]), the same values (as
    /// [`StripJob::contacts`]).
    #[inline]
    fn row_bounds(
        &self,
        m: &Prepared,
        iy0: usize,
        rows: usize,
        behind_mm: Option<f64>,
        bounds: &mut RowBounds,
    ) -> u64 {
        with_avx2!(
            self.row_bounds_avx2(m, iy0, rows, behind_mm, bounds),
            m.row_bounds(self.grid, iy0, rows, self.radius, behind_mm, bounds)
        )
    }

    /// [`Prepared::row_bounds`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn row_bounds_avx2(
        &self,
        m: &Prepared,
        iy0: usize,
        rows: usize,
        behind_mm: Option<f64>,
        bounds: &mut RowBounds,
    ) -> u64 {
        m.row_bounds(self.grid, iy0, rows, self.radius, behind_mm, bounds)
    }

    /// The reach's narrowing (`StripJob::reachable`) of the rows `iy0, iy0 +
    /// 1, …` of move `m` whose highest tops over their columns (`bounds`) are
    /// `tops`: a row whose top is at or below the move's lowest tip is left
    /// without columns, and one the tool reaches less than its radius from
    /// its axis segment narrowed to that reach's footprint. In lanes as
    /// [`Prepared::row_bounds`]; on an x86-64 processor with AVX2 and FMA
    /// compiled for them ([`StripJob::reach_bounds_avx2`]). The same columns
    /// as `reachable` row by row (test `reach_bounds_in_lanes_are_row_by_rows`).
    #[inline]
    fn reach_bounds(&self, m: &Prepared, iy0: usize, tops: &[f32], bounds: &mut RowBounds) {
        with_avx2!(
            self.reach_bounds_avx2(m, iy0, tops, bounds),
            self.reach_bounds_body(m, iy0, tops, bounds)
        )
    }

    /// [`StripJob::reach_bounds_body`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn reach_bounds_avx2(&self, m: &Prepared, iy0: usize, tops: &[f32], bounds: &mut RowBounds) {
        self.reach_bounds_body(m, iy0, tops, bounds)
    }

    /// The body of [`StripJob::reach_bounds`], inlined into each of its compilations.
    #[inline(always)]
    fn reach_bounds_body(&self, m: &Prepared, iy0: usize, tops: &[f32], bounds: &mut RowBounds) {
        let zmin = m.zmin as f32;
        let rows = tops.len();
        let RowBounds { first, last } = bounds;
        let rows_bounds = first[..rows].iter_mut().zip(&mut last[..rows]);
        for (i, ((first, last), &top)) in rows_bounds.zip(tops).enumerate() {
            let y = self.grid.y_mm_in_lanes(iy0 + i);
            let (narrow, r) = match self.env.reach(m, top as f64 - m.zmin) {
                Some(r) => (r < self.radius, r),
                None => (false, 0.0),
            };
            let reach = m.footprint_in_lanes(self.grid, y, r);
            let (nf, nl) = (reach.first.max(*first as f64), reach.last.min(*last as f64));
            let keep = *first <= *last && top > zmin && (!narrow || reach.any && nf <= nl);
            let (f, l) = if narrow {
                (nf as i32, nl as i32)
            } else {
                (*first, *last)
            };
            *first = if keep { f } else { 1 };
            *last = if keep { l } else { 0 };
        }
    }

    /// [`Envelope::row_hits`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn hits_avx2(&self, m: &Prepared, y: f64, ix0: usize, tops: &[f32], hits: &mut RowHits) {
        self.env.row_hits(m, self.grid, y, ix0, tops, hits)
    }

    /// [`StripJob::contacts_body`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn contacts_avx2(&self, m: &Prepared, cuts: &mut MoveCuts) {
        self.contacts_body(m, cuts)
    }

    /// The phases of [`StripJob::contacts`], inlined into each of its compilations.
    #[inline(always)]
    fn contacts_body(&self, m: &Prepared, cuts: &mut MoveCuts) {
        if self.edges(m, cuts) {
            self.means(m, cuts);
            self.shares(m, cuts);
        }
    }

    /// The edge at each cut's top, the floor's and the bottom's thickness,
    /// and (not a plunge) the angle θ where the edge reached it and the
    /// side's thickness of a thin piece away from the flank; false on a
    /// plunge, whose contacts are then made.
    #[inline(always)]
    fn edges(&self, m: &Prepared, cuts: &mut MoveCuts) -> bool {
        let n = cuts.n;
        let MoveCuts {
            x,
            y,
            t,
            h_top,
            h_bot,
            r_mm,
            inv_r,
            inv_sin_k,
            sin_t,
            cos_t,
            inv_h,
            inv_side,
            r_hat,
            shares,
            ..
        } = cuts;
        let (x, y, t) = (&x[..n], &y[..n], &t[..n]);
        let (h_top, h_bot) = (&h_top[..n], &h_bot[..n]);
        let (r_mm, inv_r, inv_sin_k) = (&mut r_mm[..n], &mut inv_r[..n], &mut inv_sin_k[..n]);
        let (sin_t, cos_t) = (&mut sin_t[..n], &mut cos_t[..n]);
        let (inv_h, inv_side) = (&mut inv_h[..n], &mut inv_side[..n]);
        let (r_hat, shares) = (&mut r_hat[..n], &mut shares[..n]);
        // The edge at the column's top, and 1/h of the floor and of the
        // bottom's cut (descending moves only).
        for i in 0..n {
            let edge = self.env.side(h_top[i].max(0.0));
            r_mm[i] = edge.r_mm;
            inv_r[i] = edge.inv_r;
            inv_sin_k[i] = edge.inv_sin_k;
        }
        inv_h.fill(m.inv_floor);
        if m.d[2] < 0.0 {
            for (inv_h, &h_bot) in inv_h.iter_mut().zip(h_bot) {
                let down = -m.d[2] * self.env.bottom_cos(h_bot.max(0.0));
                if down * *inv_h > 1.0 {
                    *inv_h = 1.0 / down;
                }
            }
        }
        if m.h2 <= PLUNGE_H2 {
            // A plunge: from the axis at the cut to the column; no side cut.
            for i in 0..n {
                let (ax, ay) = (
                    x[i] - (m.p0[0] + t[i] * m.d[0]),
                    y[i] - (m.p0[1] + t[i] * m.d[1]),
                );
                let dist = ax.hypot(ay);
                r_hat[i] = if dist > 1e-12 {
                    [ax / dist, ay / dist]
                } else {
                    [0.0, 0.0]
                };
                shares[i] = [0.0, 0.0];
            }
            return false;
        }
        // The edge circle of radius r at the column's top first reaches it at
        // the angle θ from the feed direction with sin θ = e / r (e: the
        // column's signed offset to the left of the move's line).
        let [ux, uy] = m.u;
        for i in 0..n {
            let (wx, wy) = (x[i] - m.p0[0], y[i] - m.p0[1]);
            let s = ((ux * wy - uy * wx) * inv_r[i]).clamp(-1.0, 1.0);
            let c = (1.0 - s * s).sqrt();
            sin_t[i] = s;
            cos_t[i] = c;
            r_hat[i] = [c * ux - s * uy, c * uy + s * ux];
            // MODEL.md §3.2: h = f · n̂, the step's feed vector on the tool
            // surface's normal, h_side = L_xy sin κ cos θ; a thin piece away
            // from the flank (the others are taken below).
            inv_side[i] = (1.0 / c) * inv_sin_k[i] * m.inv_len_xy;
        }
        true
    }

    /// The side's thickness of the cuts whose chip needs a mean: near the
    /// flank, over the cell; a thick piece, over its heights (MODEL.md §3.2).
    #[inline(always)]
    fn means(&self, m: &Prepared, cuts: &mut MoveCuts) {
        let n = cuts.n;
        let g = self.grid.spacing_mm;
        let MoveCuts {
            x,
            y,
            h_top,
            h_bot,
            inv_r,
            inv_sin_k,
            sin_t,
            cos_t,
            inv_side,
            thick,
            flank,
            halves,
            forms,
            sides,
            side_bot,
            side_top,
            side_e,
            asin_args,
            ..
        } = cuts;
        let (x, y) = (&x[..n], &y[..n]);
        let (h_top, h_bot) = (&h_top[..n], &h_bot[..n]);
        let (inv_r, inv_sin_k) = (&inv_r[..n], &inv_sin_k[..n]);
        let (sin_t, cos_t) = (&sin_t[..n], &cos_t[..n]);
        let inv_side = &mut inv_side[..n];
        let [ux, uy] = m.u;
        // Near the flanks 1/cos θ varies fast across the cell: take its mean
        // over the cell's offsets, [e − g/2, e + g/2] ∩ [−r, r] (mean of
        // 1/cos = Δ arcsin · r / Δe); away from the flank the cell mean is
        // 1/cos θ to O(half²). A piece across more than THICK_PIECE_MM of
        // height is credited over its heights (MODEL.md §3.2); a thinner one
        // at its top, as the sliver it is. The cuts that take a mean are
        // listed without a branch (those near the flank, with their sin θ
        // and cell; the thick pieces away from it), then taken in phases.
        let (mut kf, mut ks) = (0, 0);
        flank.resize(n, 0);
        thick.resize(n, 0);
        asin_args.resize(n, 0.0);
        halves.resize(n, 0.0);
        for i in 0..n {
            let half = 0.5 * g * inv_r[i];
            let near_flank = 1.0 - sin_t[i].abs() <= 4.0 * half;
            let thick_piece = is_thick(h_top[i], h_bot[i]);
            // (The flank's sin θ, its arcsine's argument below.)
            (flank[kf], asin_args[kf], halves[kf]) = (i as u32, sin_t[i], half);
            kf += usize::from(near_flank);
            thick[ks] = i as u32;
            ks += usize::from(thick_piece && !near_flank);
        }
        // The means' arcsines are taken in a loop of their own (vector lanes:
        // `asin_small`), between their arguments and the means they give
        // (93 % of the 1 M-block program's cuts take one near the flank; most of
        // a roughing pass's, over a thick piece's heights): first the flank's
        // arguments, in lanes too.
        let (flank, halves) = (&flank[..kf], &halves[..kf]);
        forms.resize(kf, DiffForm::Sin);
        for ((arg, &half), form) in asin_args[..kf].iter_mut().zip(halves).zip(&mut forms[..kf]) {
            let sin_t = *arg;
            let (lo, hi) = ((sin_t - half).max(-1.0), (sin_t + half).min(1.0));
            AsinDiff {
                arg: *arg,
                form: *form,
            } = AsinDiff::of(hi, lo);
        }
        // The mean of 1/sin κ, times the mean of 1/cos θ below.
        for &i in flank {
            let i = i as usize;
            inv_side[i] = if is_thick(h_top[i], h_bot[i]) {
                self.env.mean_inv_sin_k(h_bot[i], h_top[i])
            } else {
                inv_sin_k[i]
            };
        }
        // Away from the flank, a closed form over the piece's heights where
        // the tool has one (a ball: κ and θ both vary with the height), in
        // lanes too; where it has none (`None`), 1/cos θ at the top times the
        // mean of 1/sin κ. (Their heights and lateral offsets e first side by
        // side: few cuts on a finishing pass, where copying them in the
        // listing above cost more than it saved.)
        side_bot.resize(ks, 0.0);
        side_top.resize(ks, 0.0);
        side_e.resize(ks, 0.0);
        for (j, &i) in thick[..ks].iter().enumerate() {
            let i = i as usize;
            let (wx, wy) = (x[i] - m.p0[0], y[i] - m.p0[1]);
            (side_bot[j], side_top[j], side_e[j]) = (h_bot[i], h_top[i], ux * wy - uy * wx);
        }
        sides.resize(ks);
        let SidePieces {
            kept,
            form,
            scale,
            add,
            span,
        } = &mut *sides;
        let lanes = kept
            .iter_mut()
            .zip(form.iter_mut())
            .zip(scale.iter_mut())
            .zip(add.iter_mut())
            .zip(span.iter_mut())
            .zip(&mut asin_args[kf..kf + ks]);
        let inputs = side_bot[..ks]
            .iter()
            .zip(&side_top[..ks])
            .zip(&side_e[..ks]);
        for ((((((kept, form), scale), add), span), arg), ((&h_bot, &h_top), &e)) in
            lanes.zip(inputs)
        {
            let mean = self.env.mean_inv_side(h_bot, h_top, e);
            *kept = mean.is_some();
            let mean = mean.unwrap_or(ArcsineMean::NONE);
            (*arg, *form) = (mean.diff.arg, mean.diff.form);
            (*scale, *add, *span) = (mean.scale, mean.add, mean.span);
        }
        for (&i, &kept) in thick[..ks].iter().zip(&sides.kept) {
            if !kept {
                let i = i as usize;
                inv_side[i] =
                    (1.0 / cos_t[i]) * self.env.mean_inv_sin_k(h_bot[i], h_top[i]) * m.inv_len_xy;
            }
        }
        let args = &mut asin_args[..kf + ks];
        for a in args.iter_mut() {
            *a = asin_small(*a);
        }
        let (flank_asin, side_asin) = args.split_at(kf);
        for (((&i, &asin_arg), &form), &half) in
            flank.iter().zip(flank_asin).zip(&forms[..kf]).zip(halves)
        {
            let i = i as usize;
            let inv_cos = form.difference(asin_arg) / (2.0 * half);
            inv_side[i] = inv_cos * inv_side[i] * m.inv_len_xy;
        }
        for (j, (&i, &asin_arg)) in thick[..ks].iter().zip(side_asin).enumerate() {
            if sides.kept[j] {
                inv_side[i as usize] = sides.value(j, asin_arg) * m.inv_len_xy;
            }
        }
    }

    /// The side's thickness where it is the thinner, and the shares of each
    /// cut for the neighbouring steps (MODEL.md §1.5).
    #[inline(always)]
    fn shares(&self, m: &Prepared, cuts: &mut MoveCuts) {
        let n = cuts.n;
        let g = self.grid.spacing_mm;
        let MoveCuts {
            x,
            y,
            r_mm,
            cos_t,
            inv_h,
            inv_side,
            r_hat,
            shares,
            ..
        } = cuts;
        let (x, y) = (&x[..n], &y[..n]);
        let (r_mm, cos_t) = (&r_mm[..n], &cos_t[..n]);
        let (inv_h, inv_side) = (&mut inv_h[..n], &inv_side[..n]);
        let (r_hat, shares) = (&r_hat[..n], &mut shares[..n]);
        let [ux, uy] = m.u;
        // The side's thickness where it is the thinner, and then (MODEL.md
        // §1.5) the shares: the edge, locally straight with normal r̂, passes
        // the column's centre at s_c along the move and advances cos θ per mm
        // of path; the cell's share passed by s is the trapezoid CDF.
        for i in 0..n {
            let side_cut = inv_side[i] <= inv_h[i];
            inv_h[i] = inv_h[i].min(inv_side[i]);
            let (wx, wy) = (x[i] - m.p0[0], y[i] - m.p0[1]);
            let c = cos_t[i];
            let s_c = ((wx * ux + wy * uy) - r_mm[i] * c).clamp(0.0, m.len_xy);
            let (a, b) = (g * r_hat[i][0].abs(), g * r_hat[i][1].abs());
            let speed = c.max(MIN_EDGE_SPEED);
            let reach = 0.5 * (a + b);
            let passed = |s: f64| trapezoid_cdf((s - s_c) * speed + reach, a, b);
            let within = s_c * speed >= reach && (m.len_xy - s_c) * speed >= reach;
            // The whole cell is passed within the step where `within`.
            shares[i] = if self.smooth && side_cut && !within {
                [passed(0.0), 1.0 - passed(m.len_xy)]
            } else {
                [0.0, 0.0]
            };
        }
    }

    /// Run the moves `entries` (batch-local indices, ascending) over the rows
    /// `row0..row0 + rows` whose columns are `cols`; write per-entry sums into `out`
    /// (per entry: this step's sums, then with smoothing the shares for the
    /// previous and the next step) and per-entry ranges of lateral offsets
    /// into `ranges` (one [min, max] a band, [`super::EMPTY_OFFSETS`] on entry).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run(
        &self,
        row0: usize,
        cols: &mut [f32],
        mut bottoms: impl CutBottoms,
        below: &mut [RowBelow],
        last_cut: &mut [u32],
        entries: &[u32],
        out: &mut [f64],
        ranges: &mut [[f32; 2]],
    ) -> u64 {
        let nx = self.grid.nx;
        let n_bands = self.banding.n_bands;
        let rows = cols.len() / nx;
        let width = self.width();
        let area = self.grid.cell_area_mm2();
        let mut visited = 0u64;
        // Cut columns of the current move, awaiting their contact (allocated once per strip).
        let mut cuts = MoveCuts::new(nx);
        // The height each column of a row is cut to and where (`Envelope::row_hits`).
        let in_lanes = self.env.row_in_lanes();
        let mut hits = RowHits::new(if in_lanes { nx } else { 0 });
        // The columns each row of a move's can reach (`Prepared::row_bounds`).
        let mut bounds = RowBounds::new(rows);
        // The highest top over each row's columns (`reach_bounds`).
        let mut row_tops = vec![f32::NEG_INFINITY; rows];
        let has_reach = self.env.has_reach();
        // Highest top per tile of TILE_COLS columns across the strip's rows, taken
        // once: cuts only lower tops, so it bounds them for all the moves. A row
        // whose tiles all lie at or below a move's lowest tip is air to it.
        let mut tile_top = vec![f32::NEG_INFINITY; nx.div_ceil(TILE_COLS)];
        for row in cols.chunks_exact(nx) {
            for (t, tile) in tile_top.iter_mut().zip(row.chunks(TILE_COLS)) {
                let top = row_top(tile);
                if top > *t {
                    *t = top;
                }
            }
        }
        for (j, &mi) in entries.iter().enumerate() {
            let m = &self.moves[mi as usize];
            let all = &mut out[j * width..(j + 1) * width];
            let band_ranges = &mut ranges[j * n_bands..(j + 1) * n_bands];
            // The lateral offset e = û × w of a column (MODEL.md §1.7, the
            // expression of `contacts`); NaN on a plunge, whose cuts are
            // not side cuts (no range).
            let side = m.h2 > PLUNGE_H2;
            let [ux, uy] = m.u;
            let step_index = (self.first_step + mi as usize) as u32;
            let Some((iy0, iy1)) = m.row_range(self.grid, self.radius) else {
                continue;
            };
            let (iy0, iy1) = (iy0.max(row0), iy1.min(row0 + rows - 1));
            let zmin = m.zmin as f32;
            // Rows the move can reach below the strip's highest top over its
            // footprint's X extent (the tiles bound every column it meets):
            // further from its axis segment the tool stays above that top
            // (`Envelope::reach`), where each row would be passed below
            // (`reachable`, `stays_above`), so skipping them changes no result.
            let Some((iy0, iy1)) = self.reachable_rows(m, &tile_top, iy0, iy1) else {
                continue;
            };
            let behind = if m.follows {
                self.env.behind_mm(m)
            } else {
                None
            };
            // The footprint's columns on each row, ahead of the start where
            // the previous move's end tool has cut already behind it.
            let move_rows = iy1 - iy0 + 1;
            visited += self.row_bounds(m, iy0, move_rows, behind, &mut bounds);
            // Rows of air to the move (its tiles at or below its lowest tip) are
            // left out; with a reach, the others narrowed to where the tool can
            // reach below the row's highest top (`reach_bounds`).
            for (i, top) in row_tops[..move_rows].iter_mut().enumerate() {
                *top = f32::NEG_INFINITY;
                let Some((ix0, ix1)) = bounds.row(i) else {
                    continue;
                };
                let tiles = &tile_top[ix0 / TILE_COLS..=ix1 / TILE_COLS];
                if tiles.iter().all(|&t| t <= zmin) {
                    bounds.clear(i);
                    continue;
                }
                if has_reach {
                    let base = (iy0 + i - row0) * nx;
                    *top = row_top(&cols[base + ix0..=base + ix1]);
                }
            }
            if has_reach {
                self.reach_bounds(m, iy0, &row_tops[..move_rows], &mut bounds);
            }
            for iy in iy0..=iy1 {
                let Some((ix0, ix1)) = bounds.row(iy - iy0) else {
                    continue;
                };
                if !cuts.fits(ix1 - ix0 + 1) {
                    self.credit_cuts(m, &mut cuts, all);
                }
                let y = self.grid.y_mm(iy);
                let wy = y - m.p0[1];
                let base = (iy - row0) * nx;
                // Each column's cut from the tops before the move: a cut
                // changes its own column alone.
                if in_lanes {
                    self.hits(m, y, ix0, &cols[base + ix0..=base + ix1], &mut hits);
                }
                for ix in ix0..=ix1 {
                    let col = &mut cols[base + ix];
                    // (−∞ where the column is empty; +∞ as z where it is not cut.)
                    let top = *col;
                    let x = self.grid.x_mm(ix);
                    let (z, t) = if in_lanes {
                        (hits.z_mm[ix - ix0], hits.t[ix - ix0])
                    } else {
                        let Some(EnvelopeHit { z_mm, t }) = column_hit(self.env, m, x, y, top)
                        else {
                            continue;
                        };
                        (z_mm as f32, t)
                    };
                    if top <= z {
                        continue;
                    }
                    let z_tip = m.p0[2] + t * m.d[2];
                    let e = if side {
                        (ux * wy - uy * (x - m.p0[0])) as f32
                    } else {
                        f32::NAN
                    };
                    let mut removed = 0.0;
                    bottoms.cut_above(base + ix, col, &mut below[iy - row0], ix, z, |a, b| {
                        removed +=
                            self.banding
                                .credit(all, band_ranges, e, z_tip, a as f64, b as f64);
                    });
                    if removed > 0.0 {
                        last_cut[base + ix] = step_index;
                        cuts.push(x, y, t, top as f64 - z_tip, z as f64 - z_tip, removed);
                    }
                }
            }
            self.credit_cuts(m, &mut cuts, all);
            for v in all.iter_mut() {
                *v *= area;
            }
        }
        visited
    }

    /// The contacts of the cuts taken (`cuts`, cut by `m`), then their sums
    /// into the move's head values `all` and (smoothing) the shares for the
    /// previous and the next step, in the order they were cut: the same sums in
    /// the same order as one pass, however the cuts are taken. Leaves `cuts`
    /// empty.
    #[inline]
    fn credit_cuts(&self, m: &Prepared, cuts: &mut MoveCuts, all: &mut [f64]) {
        if cuts.n == 0 {
            return;
        }
        let stride = HEAD + self.banding.n_bands;
        // The contacts after the cuts (the bands and shank credited
        // as they were cut are other slots).
        self.contacts(m, cuts);
        // The sums held in registers over the cuts: the same additions
        // in the same order. (The three slots written out: a loop over
        // them kept the sums in memory, 6 % slower on `sweep_stats`
        // ball roughing.)
        let mut sums = [[0.0; HEAD]; 3];
        sums[0].copy_from_slice(&all[..HEAD]);
        if self.smooth {
            sums[1].copy_from_slice(&all[stride..stride + HEAD]);
            sums[2].copy_from_slice(&all[stride + HEAD..stride + 2 * HEAD]);
        }
        for i in 0..cuts.n {
            let removed = cuts.removed[i];
            let r_hat = cuts.r_hat[i];
            let mut column = [0.0; HEAD];
            column[VOLUME] = removed;
            column[CONTACT_X] = removed * r_hat[0];
            column[CONTACT_Y] = removed * r_hat[1];
            column[CHIP_AREA] = removed * cuts.inv_h[i];
            column[OVER_RADIUS] = removed * cuts.inv_r[i];
            for (d, v) in sums[0].iter_mut().zip(column) {
                *d += v;
            }
            // Shares for the neighbours: head values only; bands and shank
            // follow in proportion when the strips are reduced.
            for k in 0..2 {
                let share = cuts.shares[i][k];
                if share > 0.0 {
                    for (d, v) in sums[1 + k].iter_mut().zip(column) {
                        *d += share * v;
                    }
                }
            }
        }
        all[..HEAD].copy_from_slice(&sums[0]);
        if self.smooth {
            all[stride..stride + HEAD].copy_from_slice(&sums[1]);
            all[stride + HEAD..stride + 2 * HEAD].copy_from_slice(&sums[2]);
        }
        cuts.n = 0;
    }

    /// The rows `iy0..=iy1` of the strip that the move can cut, given the
    /// highest top `tile_top` of each tile of the strip: those within the
    /// tool's reach, below the highest top of the tiles under the move's
    /// footprint, of the move's axis segment in Y (the stadium of that reach
    /// spans the segment's Y range ± it). None where no tile under the
    /// footprint rises above the move's lowest tip.
    #[inline]
    fn reachable_rows(
        &self,
        m: &Prepared,
        tile_top: &[f32],
        iy0: usize,
        iy1: usize,
    ) -> Option<(usize, usize)> {
        if !self.env.has_reach() {
            return Some((iy0, iy1));
        }
        let (x0, x1) = (m.p0[0], m.p0[0] + m.d[0]);
        let (ix0, ix1) = self
            .grid
            .ix_range(x0.min(x1) - self.radius, x0.max(x1) + self.radius)?;
        let max = |a: f32, b: f32| if b > a { b } else { a };
        let top = tile_top[ix0 / TILE_COLS..=ix1 / TILE_COLS]
            .iter()
            .fold(f32::NEG_INFINITY, |a, &t| max(a, t));
        if top <= m.zmin as f32 {
            return None;
        }
        match self.env.reach(m, top as f64 - m.zmin) {
            Some(r) if r < self.radius => {
                let (y0, y1) = (m.p0[1], m.p0[1] + m.d[1]);
                let (a, b) = self.grid.iy_range(y0.min(y1) - r, y0.max(y1) + r)?;
                let (a, b) = (a.max(iy0), b.min(iy1));
                (a <= b).then_some((a, b))
            }
            _ => Some((iy0, iy1)),
        }
    }

    /// The columns `ix0..=ix1` of the row at `y` (`row` holds them) that the
    /// move can cut: those within the tool's reach below the row's highest
    /// top. Columns left out pass neither `stays_above` nor the zmin test, so
    /// narrowing changes no result. (The kernel takes it in lanes:
    /// [`StripJob::reach_bounds`].)
    #[cfg(test)]
    fn reachable(
        &self,
        m: &Prepared,
        y: f64,
        row: &[f32],
        ix0: usize,
        ix1: usize,
    ) -> Option<(usize, usize)> {
        if !self.env.has_reach() {
            return Some((ix0, ix1));
        }
        let top = row_top(row);
        if top <= m.zmin as f32 {
            return None;
        }
        match self.env.reach(m, top as f64 - m.zmin) {
            Some(r) if r < self.radius => {
                let span = m.row_span(y, r)?;
                let (a, b) = self.grid.ix_range(span.lo, span.hi)?;
                let (a, b) = (a.max(ix0), b.min(ix1));
                (a <= b).then_some((a, b))
            }
            _ => Some((ix0, ix1)),
        }
    }
}

/// The highest top of `row` (−∞ if all columns are empty). Heights are never
/// NaN, so a plain compare replaces `f32::max`, and four running maxima break
/// the dependency chain of one: the maximum is exact in any order.
#[inline]
fn row_top(row: &[f32]) -> f32 {
    let max = |a: f32, b: f32| if b > a { b } else { a };
    let mut acc = [f32::NEG_INFINITY; 4];
    let mut quads = row.chunks_exact(4);
    for q in &mut quads {
        for (a, &c) in acc.iter_mut().zip(q) {
            *a = max(*a, c);
        }
    }
    let rest = quads
        .remainder()
        .iter()
        .fold(f32::NEG_INFINITY, |a, &c| max(a, c));
    max(max(acc[0], acc[1]), max(max(acc[2], acc[3]), rest))
}

#[cfg(test)]
mod tests {
    use super::super::EMPTY_OFFSETS;
    use super::*;

    #[test]
    fn cut_above_handles_several_intervals() {
        // Column 3 of a stock row: [0, 1], [2, 3], [4, 5]; column 1 beside it [6, 7], [8, 9].
        let stock = crate::Stock::from_columns(
            crate::Grid::covering(0.0, 0.0, 0.5, 0.1, 0.1).unwrap(),
            |ix, _, out| match ix {
                3 => out.extend([[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]),
                1 => out.extend([[6.0, 7.0], [8.0, 9.0]]),
                _ => {}
            },
        )
        .unwrap();
        let mut stock = stock;
        let (tops, bottoms, below, _) = stock.parts_mut();
        let crate::stock::BottomsMut::Columns(bottoms) = bottoms else {
            panic!("columns of several intervals keep a bottom each");
        };
        let (mut hi, mut lo, mut below) = (tops[3], bottoms[3], below[0].clone());
        let mut pieces = Vec::new();
        cut_above(&mut hi, &mut lo, &mut below, 3, 2.5, |a, b| {
            pieces.push((a, b))
        });
        assert_eq!(pieces, vec![(4.0, 5.0), (2.5, 3.0)]);
        assert_eq!((lo, hi), (2.0, 2.5));
        assert_eq!(below.of(3), &[[0.0, 1.0]]);
        pieces.clear();
        cut_above(&mut hi, &mut lo, &mut below, 3, -1.0, |a, b| {
            pieces.push((a, b))
        });
        assert_eq!(pieces, vec![(2.0, 2.5), (0.0, 1.0)]);
        assert_eq!(Top { lo, hi }, Top::EMPTY);
        assert_eq!(below.of(3), &[] as &[[f32; 2]]);
        assert_eq!(
            below.of(1),
            &[[6.0, 7.0]],
            "the column beside kept its intervals"
        );
    }

    #[test]
    fn banding_splits_pieces_and_shank() {
        let b = Banding {
            n_bands: 3,
            band_h: 1.0,
            inv_band_h: 1.0,
            flute_len: 2.5,
        };
        let mut acc = vec![0.0; HEAD + 3];
        let mut ranges = [EMPTY_OFFSETS; 3];
        assert_eq!(b.credit(&mut acc, &mut ranges, 1.5, 10.0, 10.5, 14.0), 3.5);
        assert_eq!(&acc[HEAD..], &[0.5, 1.0, 0.5]);
        assert_eq!(acc[1], 1.5, "above the flute length is shank contact");
        assert_eq!(ranges, [[1.5, 1.5]; 3]);
        // Another column, in band 0 only; then a plunge's (NaN) changes nothing.
        b.credit(&mut acc, &mut ranges, -2.0, 10.0, 10.0, 10.25);
        b.credit(&mut acc, &mut ranges, f32::NAN, 10.0, 10.0, 14.0);
        assert_eq!(ranges, [[-2.0, 1.5], [1.5, 1.5], [1.5, 1.5]]);
        // A piece above the cut's bands leaves them empty.
        let mut ranges = [EMPTY_OFFSETS; 3];
        b.credit(&mut acc, &mut ranges, 0.5, 10.0, 11.2, 11.4);
        assert_eq!(ranges, [EMPTY_OFFSETS, [0.5, 0.5], EMPTY_OFFSETS]);
    }

    /// A 20 × 20 mm grid of 0.1 mm cells centred on the origin.
    fn test_grid() -> Grid {
        Grid::covering(-10.0, -10.0, 10.0, 10.0, 0.1).unwrap()
    }

    /// One band of 10 mm.
    fn one_band() -> Banding {
        Banding {
            n_bands: 1,
            band_h: 10.0,
            inv_band_h: 0.1,
            flute_len: 10.0,
        }
    }

    /// A strip job of tool `env` (radius `r`) without moves of its own.
    fn test_job<'a, E: Envelope>(
        env: &'a E,
        grid: &'a Grid,
        banding: &'a Banding,
        r: f64,
    ) -> StripJob<'a, E> {
        StripJob {
            env,
            grid,
            radius: r,
            banding,
            moves: &[],
            first_step: 0,
            smooth: false,
        }
    }

    /// A row made in lanes ([`Envelope::row_hits`], portable and, where the
    /// processor has them, compiled for AVX2 and FMA) is the column-by-column
    /// one bit for bit, for a ball and a bull nose (whose level moves take
    /// lanes): level, climbing, descending, steep, short and plunging moves;
    /// tops empty, below the tip, near the envelope and far above it; rows
    /// through the body, the end spheres or corners and past the tool.
    #[test]
    fn a_row_in_lanes_is_its_columns_bit_for_bit() {
        use super::super::{ball::BallEnd, bull::BullNose};
        let r = 3.0;
        let (cut, passed, _) = row_in_lanes_against_columns(&BallEnd { r }, r);
        // Both kinds of column are compared, many of each.
        assert!(
            cut > 2_000 && passed > 10_000,
            "ball: {cut} cut, {passed} passed"
        );
        let bull = BullNose {
            r,
            rc: 1.0,
            ring: 2.0,
        };
        // (Its lanes take level moves only: many of those cut too.)
        let (cut, passed, level_cut) = row_in_lanes_against_columns(&bull, r);
        assert!(
            cut > 2_000 && passed > 10_000 && level_cut > 1_000,
            "bull nose: {cut} cut ({level_cut} by level moves), {passed} passed"
        );
    }

    /// The columns cut and passed of rows of `env` (radius `r`) compared in
    /// lanes and column by column, and the columns level moves cut.
    fn row_in_lanes_against_columns<E: Envelope>(env: &E, r: f64) -> (usize, usize, usize) {
        use super::super::row_hits_by_column;
        use crate::sweep::testing::lcg;
        assert!(env.row_in_lanes());
        let (grid, banding) = (test_grid(), one_band());
        let job = test_job(env, &grid, &banding, r);
        let mut seed = 11;
        let (mut cut, mut passed, mut level_cut) = (0, 0, 0);
        for to in [
            [5.0, 1.0, 0.0],
            [4.0, -2.0, 1.5],
            [-3.0, 2.0, -1.5],
            [0.5, 0.2, -4.0],
            [0.01, 0.0, 0.0],
            [0.0, 0.0, -2.0],
            [0.0, 0.0, 0.0],
            [-0.3, 2.2, 0.0],
            [0.0, -0.15, 0.0],
            [0.2, 0.0, 0.0],
        ] {
            let step = crate::Step {
                from_mm: [-1.0, 0.5, 0.0],
                to_mm: [to[0] - 1.0, to[1] + 0.5, to[2]],
                rapid: false,
            };
            let m = Prepared::new(&step);
            for _ in 0..40 {
                // Rows at −5 to 5 mm.
                let y = grid.y_mm(50 + (100.0 * lcg(&mut seed)) as usize);
                let ix0 = (lcg(&mut seed) * 20.0) as usize;
                let tops: Vec<f32> = (0..150)
                    .map(|i| match i % 5 {
                        0 => f32::NEG_INFINITY,
                        1 => (m.zmin - 0.5 * lcg(&mut seed)) as f32,
                        _ => (m.zmin + (2.0 * r + 1.0) * lcg(&mut seed)) as f32,
                    })
                    .collect();
                let mut expected = RowHits::new(150);
                row_hits_by_column(env, &m, &grid, y, ix0, &tops, &mut expected);
                let mut portable = RowHits::new(150);
                env.row_hits(&m, &grid, y, ix0, &tops, &mut portable);
                let mut dispatched = RowHits::new(150);
                job.hits(&m, y, ix0, &tops, &mut dispatched);
                let bits = |h: &RowHits| {
                    let z = h.z_mm.iter().map(|v| v.to_bits() as u64);
                    z.chain(h.t.iter().map(|v| v.to_bits())).collect::<Vec<_>>()
                };
                assert_eq!(bits(&portable), bits(&expected));
                assert_eq!(bits(&dispatched), bits(&expected));
                for (&top, &z) in tops.iter().zip(&expected.z_mm) {
                    if top > z {
                        cut += 1;
                        level_cut += usize::from(to[2] == 0.0 && to[..2] != [0.0, 0.0]);
                    } else {
                        passed += 1;
                    }
                }
            }
        }
        (cut, passed, level_cut)
    }

    /// The rows' columns in lanes ([`Prepared::row_bounds`], portable and as
    /// dispatched) are those of the footprint and the start taken row by row
    /// ([`Prepared::row_span`], [`Prepared::ahead_span`], [`Grid::ix_range`]),
    /// with the columns visited: level, inclined, descending, axis-aligned and
    /// diagonal moves, plunges, a move of one nanometre, footprints reaching
    /// past the grid and ends on column centres, without and with the start's
    /// narrowing.
    #[test]
    fn row_bounds_in_lanes_are_row_by_rows() {
        use super::super::{ball::BallEnd, RowBounds};
        let r = 3.0;
        let env = BallEnd { r };
        let (grid, banding) = (test_grid(), one_band());
        let job = test_job(&env, &grid, &banding, r);
        let (mut rows_cut, mut rows_narrowed, mut rows_none) = (0, 0, 0);
        for (from, to) in [
            ([0.05, 0.05, 0.0], [3.05, 0.05, 0.0]),
            ([0.05, 0.05, 0.0], [0.05, -4.95, -1.0]),
            ([-1.0, 0.5, 0.0], [4.0, 1.5, 0.0]),
            ([-1.0, 0.5, 1.0], [-4.0, 2.5, -1.5]),
            ([2.0, -3.0, 0.0], [2.0 + 1e-7, -3.0 + 3e-7, 0.0]),
            ([1.0, 1.0, 0.0], [1.0 + 1e-9, 1.0, 0.0]),
            ([1.0, 1.0, 0.0], [1.0, 1.0, -2.0]),
            ([1.0, 1.0, 0.0], [1.0, 1.0, 2.0]),
            ([0.05, 0.05, 0.0], [0.05, 0.05, -1.0]),
            ([-9.0, 8.5, 0.0], [9.5, 9.9, -0.5]),
            ([-0.35, -0.35, 0.0], [2.65, 2.65, 0.0]),
        ] {
            let m = Prepared::new(&crate::Step {
                from_mm: from,
                to_mm: to,
                rapid: false,
            });
            let Some((iy0, iy1)) = m.row_range(&grid, r) else {
                panic!("the move is on the grid");
            };
            let rows = iy1 - iy0 + 1;
            for behind in [None, Some(0.0), Some(0.37)] {
                // Row by row, as the strip loop took them.
                let mut visited = 0u64;
                let mut expected = Vec::new();
                for iy in iy0..=iy1 {
                    let y = grid.y_mm(iy);
                    let footprint = m
                        .row_span(y, r)
                        .and_then(|span| grid.ix_range(span.lo, span.hi));
                    let Some((ix0, ix1)) = footprint else {
                        expected.push(None);
                        continue;
                    };
                    visited += (ix1 - ix0 + 1) as u64;
                    expected.push(match behind {
                        None => Some((ix0, ix1)),
                        Some(behind_mm) => m
                            .ahead_span(y, behind_mm)
                            .and_then(|s| grid.ix_range(s.lo, s.hi))
                            .map(|(a, b)| (a.max(ix0), b.min(ix1)))
                            .filter(|(a, b)| a <= b),
                    });
                }
                let columns =
                    |bounds: &RowBounds| (0..rows).map(|i| bounds.row(i)).collect::<Vec<_>>();
                let mut portable = RowBounds::new(rows + 3);
                let portable_visited = m.row_bounds(&grid, iy0, rows, r, behind, &mut portable);
                let mut dispatched = RowBounds::new(rows + 3);
                let dispatched_visited = job.row_bounds(&m, iy0, rows, behind, &mut dispatched);
                assert_eq!(columns(&portable), expected, "{from:?} {to:?} {behind:?}");
                assert_eq!(columns(&dispatched), expected, "{from:?} {to:?} {behind:?}");
                assert_eq!((portable_visited, dispatched_visited), (visited, visited));
                for (i, row) in expected.iter().enumerate() {
                    let footprint = m
                        .row_span(grid.y_mm(iy0 + i), r)
                        .and_then(|span| grid.ix_range(span.lo, span.hi));
                    match (footprint, row) {
                        (None, _) => rows_none += 1,
                        (Some(f), Some(c)) if f != *c => rows_narrowed += 1,
                        (Some(_), Some(_)) => rows_cut += 1,
                        (Some(_), None) => rows_narrowed += 1,
                    }
                }
            }
        }
        // Every kind of row is compared, many of each.
        assert!(
            rows_cut > 500 && rows_narrowed > 300 && rows_none > 5,
            "{rows_cut} whole, {rows_narrowed} narrowed, {rows_none} without columns"
        );
    }

    /// The reach's narrowing in lanes ([`StripJob::reach_bounds`], portable
    /// and as dispatched) is `reachable` taken row by row: rows of air, rows
    /// whose top is just above the lowest tip, deep rows the tool reaches with
    /// its whole radius, for a ball and a bull nose on level, inclined and
    /// plunging moves.
    #[test]
    fn reach_bounds_in_lanes_are_row_by_rows() {
        use super::super::{ball::BallEnd, bull::BullNose, Envelope, RowBounds};
        use crate::sweep::testing::lcg;
        fn check<E: Envelope>(env: &E, r: f64, counts: &mut [usize; 3]) {
            let (grid, banding) = (test_grid(), one_band());
            let job = test_job(env, &grid, &banding, r);
            let mut seed = 5;
            for (from, to) in [
                ([-1.0, 0.5, 0.0], [4.0, 1.5, 0.0]),
                ([-1.0, 0.5, 1.0], [-4.0, 2.5, -1.5]),
                ([0.05, 0.05, 0.0], [0.05, -4.95, -1.0]),
                ([1.0, 1.0, 0.0], [1.0, 1.0, -2.0]),
            ] {
                let m = Prepared::new(&crate::Step {
                    from_mm: from,
                    to_mm: to,
                    rapid: false,
                });
                let (iy0, iy1) = m.row_range(&grid, r).unwrap();
                let rows = iy1 - iy0 + 1;
                for k in 0..20 {
                    // Half of them narrowed to the start first (a move that follows).
                    let behind = (k % 2 == 1).then_some(0.0);
                    let mut bounds = RowBounds::new(rows);
                    m.row_bounds(&grid, iy0, rows, r, behind, &mut bounds);
                    // Each row's columns' tops, and their highest.
                    let row_cols: Vec<Vec<f32>> = (0..rows)
                        .map(|i| {
                            let n = bounds.row(i).map_or(0, |(first, last)| last - first + 1);
                            let kind = lcg(&mut seed);
                            (0..n)
                                .map(|_| {
                                    let depth = if kind < 0.2 {
                                        -0.5 * lcg(&mut seed)
                                    } else if kind < 0.6 {
                                        0.05 * lcg(&mut seed)
                                    } else {
                                        (2.0 * r + 1.0) * lcg(&mut seed)
                                    };
                                    (m.zmin + depth) as f32
                                })
                                .collect()
                        })
                        .collect();
                    let tops: Vec<f32> = row_cols.iter().map(|c| row_top(c)).collect();
                    let expected: Vec<Option<(usize, usize)>> = (0..rows)
                        .map(|i| {
                            let (ix0, ix1) = bounds.row(i)?;
                            job.reachable(&m, grid.y_mm(iy0 + i), &row_cols[i], ix0, ix1)
                        })
                        .collect();
                    let columns =
                        |bounds: &RowBounds| (0..rows).map(|i| bounds.row(i)).collect::<Vec<_>>();
                    let mut portable = bounds.clone();
                    job.reach_bounds_body(&m, iy0, &tops, &mut portable);
                    let mut dispatched = bounds.clone();
                    job.reach_bounds(&m, iy0, &tops, &mut dispatched);
                    assert_eq!(columns(&portable), expected, "{from:?} {to:?}");
                    assert_eq!(columns(&dispatched), expected, "{from:?} {to:?}");
                    for (i, row) in expected.iter().enumerate() {
                        counts[match (bounds.row(i), row) {
                            (Some(_), None) => 0,
                            (Some(b), Some(a)) if b != *a => 1,
                            _ => 2,
                        }] += 1;
                    }
                }
            }
        }
        // Rows left out, narrowed, and kept whole (or without columns before).
        let mut counts = [0; 3];
        check(&BallEnd { r: 3.0 }, 3.0, &mut counts);
        check(
            &BullNose {
                r: 3.0,
                rc: 1.0,
                ring: 2.0,
            },
            3.0,
            &mut counts,
        );
        assert!(
            counts.iter().all(|&c| c > 300),
            "{counts:?} rows left out, narrowed, kept"
        );
    }

    /// The contacts compiled for AVX2 and FMA are the portable ones bit for
    /// bit (each tool, level, descending and plunging moves, thin and thick
    /// pieces, columns near the flank and away from it), so a processor
    /// without them gets the same results.
    #[test]
    fn contacts_for_avx2_are_the_portable_ones_bit_for_bit() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            use super::super::{ball::BallEnd, bull::BullNose, flat::FlatEnd, Envelope};
            use crate::sweep::testing::lcg;
            let banding = Banding {
                n_bands: 4,
                band_h: 1.0,
                inv_band_h: 1.0,
                flute_len: 4.0,
            };
            let r = 3.0;
            let grid = Grid::covering(-10.0, -10.0, 10.0, 10.0, 0.1).unwrap();
            fn compare<E: Envelope>(env: &E, grid: &Grid, banding: &Banding, r: f64) -> usize {
                let mut seed = 5;
                let mut compared = 0;
                for (case, to) in [[4.0, 1.0, 0.0], [3.0, -2.0, -1.5], [0.0, 0.0, -2.0]]
                    .into_iter()
                    .enumerate()
                {
                    let step = crate::Step {
                        from_mm: [0.0, 0.0, 0.0],
                        to_mm: to,
                        rapid: false,
                    };
                    let m = Prepared::new(&step);
                    for smooth in [false, true] {
                        let job = StripJob {
                            env,
                            grid,
                            radius: r,
                            banding,
                            moves: &[],
                            first_step: 0,
                            smooth,
                        };
                        let mut cuts = MoveCuts::new(200);
                        for i in 0..200 {
                            // Cuts of several rows, as a move takes them.
                            let y = 2.9 * (2.0 * lcg(&mut seed) - 1.0);
                            let h_top = 5.0 * lcg(&mut seed);
                            // Thin pieces (slivers) and thick ones.
                            let depth = if i % 3 == 0 { 0.01 } else { 2.0 } * lcg(&mut seed);
                            let x = -3.0 + 0.05 * i as f64 + case as f64;
                            cuts.push(x, y, lcg(&mut seed), h_top, h_top - depth, depth);
                        }
                        let mut portable = cuts.clone();
                        job.contacts_body(&m, &mut portable);
                        // SAFETY: the processor has AVX2 and FMA (checked above).
                        #[allow(unsafe_code)]
                        unsafe {
                            job.contacts_avx2(&m, &mut cuts)
                        };
                        for (a, b) in [
                            (&portable.inv_r, &cuts.inv_r),
                            (&portable.inv_h, &cuts.inv_h),
                            (&portable.inv_side, &cuts.inv_side),
                        ] {
                            assert!(a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits()));
                        }
                        for (a, b) in [
                            (&portable.r_hat, &cuts.r_hat),
                            (&portable.shares, &cuts.shares),
                        ] {
                            assert!(a
                                .iter()
                                .flatten()
                                .zip(b.iter().flatten())
                                .all(|(a, b)| a.to_bits() == b.to_bits()));
                        }
                        compared += cuts.n;
                    }
                }
                compared
            }
            let bull = BullNose {
                r,
                rc: 1.0,
                ring: r - 1.0,
            };
            let n = compare(&BallEnd { r }, &grid, &banding, r)
                + compare(&bull, &grid, &banding, r)
                + compare(&FlatEnd::new(r), &grid, &banding, r);
            assert_eq!(n, 3 * 3 * 2 * 200);
        }
    }

    /// The means' phases (lists, lanes, arguments side by side) give each
    /// cut the side thickness it has alone: the expressions of MODEL.md §3.2
    /// made one cut at a time. The cuts buffer is used again with fewer
    /// cuts and another move, so that a list left from the last call shows.
    #[test]
    fn means_are_each_cuts_own_one_at_a_time() {
        use super::super::arcsine::{asin_small, AsinDiff};
        use super::super::{ball::BallEnd, bull::BullNose, flat::FlatEnd, Envelope};
        use crate::sweep::testing::lcg;
        fn check<E: Envelope>(env: &E, r: f64) -> [usize; 3] {
            let grid = Grid::covering(-10.0, -10.0, 10.0, 10.0, 0.1).unwrap();
            let banding = Banding {
                n_bands: 4,
                band_h: 1.0,
                inv_band_h: 1.0,
                flute_len: 4.0,
            };
            let g = grid.spacing_mm;
            let mut seed = 9;
            // Near the flank, thick away from it, thin away from it.
            let mut kinds = [0; 3];
            let mut cuts = MoveCuts::new(300);
            for (to, count) in [([4.0, 1.0, 0.0], 300), ([-1.0, 3.0, -0.5], 170)] {
                let step = crate::Step {
                    from_mm: [0.0, 0.0, 0.0],
                    to_mm: to,
                    rapid: false,
                };
                let m = Prepared::new(&step);
                let job = StripJob {
                    env,
                    grid: &grid,
                    radius: r,
                    banding: &banding,
                    moves: &[],
                    first_step: 0,
                    smooth: true,
                };
                cuts.n = 0;
                for i in 0..count {
                    let (x, y) = (
                        3.0 * (2.0 * lcg(&mut seed) - 1.0),
                        3.0 * (2.0 * lcg(&mut seed) - 1.0),
                    );
                    let h_top = 0.05 + 4.0 * lcg(&mut seed);
                    let depth = if i % 3 == 0 { 0.01 } else { 1.5 } * lcg(&mut seed);
                    cuts.push(x, y, lcg(&mut seed), h_top, h_top - depth, depth);
                }
                job.contacts_body(&m, &mut cuts);
                let [ux, uy] = m.u;
                for i in 0..cuts.n {
                    let (h_top, h_bot) = (cuts.h_top[i], cuts.h_bot[i]);
                    let (sin_t, cos_t) = (cuts.sin_t[i], cuts.cos_t[i]);
                    let half = 0.5 * g * cuts.inv_r[i];
                    let thick = h_top - h_bot > THICK_PIECE_MM;
                    let e = ux * (cuts.y[i] - m.p0[1]) - uy * (cuts.x[i] - m.p0[0]);
                    let alone = if 1.0 - sin_t.abs() <= 4.0 * half {
                        kinds[0] += 1;
                        let (lo, hi) = ((sin_t - half).max(-1.0), (sin_t + half).min(1.0));
                        let d = AsinDiff::of(hi, lo);
                        let inv_cos = d.form.difference(asin_small(d.arg)) / (2.0 * half);
                        let k = if thick {
                            env.mean_inv_sin_k(h_bot, h_top)
                        } else {
                            cuts.inv_sin_k[i]
                        };
                        inv_cos * k * m.inv_len_xy
                    } else if thick {
                        kinds[1] += 1;
                        match env.mean_inv_side(h_bot, h_top, e) {
                            Some(mean) => {
                                let d = mean.diff.form.difference(asin_small(mean.diff.arg));
                                (mean.scale * d + mean.add) / mean.span * m.inv_len_xy
                            }
                            None => (1.0 / cos_t) * env.mean_inv_sin_k(h_bot, h_top) * m.inv_len_xy,
                        }
                    } else {
                        kinds[2] += 1;
                        (1.0 / cos_t) * cuts.inv_sin_k[i] * m.inv_len_xy
                    };
                    assert_eq!(
                        cuts.inv_side[i].to_bits(),
                        alone.to_bits(),
                        "cut {i}: {} against {alone}",
                        cuts.inv_side[i]
                    );
                }
            }
            kinds
        }
        let r = 3.0;
        let bull = BullNose {
            r,
            rc: 1.0,
            ring: r - 1.0,
        };
        for kinds in [
            check(&BallEnd { r }, r),
            check(&bull, r),
            check(&FlatEnd::new(r), r),
        ] {
            assert!(kinds.iter().all(|&k| k > 10), "{kinds:?}");
        }
    }
}
