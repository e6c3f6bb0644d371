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
//!   the move, so `f(ρ(t)) + z_tip(t)` is convex in t: a golden-section search
//!   finds the minimum to 1e-10 of the move (no sub-sampling of positions).
//!
//! Before the exact envelope, a ball end rules out columns with a square-root
//! free bound (z ≥ z_min + ρ²/2R, ρ the XY distance to the move's axis): per
//! row against the row's highest top, then per column against its own top.
//! The bound skips only columns that the envelope would not cut, so results
//! are the same with or without it.
//!
//! Removed material of a column is credited to the tool height band it falls
//! in, measured from the tool tip at the parameter where the envelope is
//! attained. Architecture invariants: no allocation per move or column (the
//! only allocations are per batch of moves and per strip), and per-step sums
//! are reduced in a fixed strip order, so results do not depend on the number
//! of threads.

use rayon::prelude::*;

use crate::{Column, Error, Grid, Stock, Tool, ToolShape};

/// One straight tool move, tip positions in mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub from_mm: [f64; 3],
    pub to_mm: [f64; 3],
    /// A rapid (G0) move: any material it removes is a collision.
    pub rapid: bool,
}

/// Tuning of a sweep; the defaults suit grids from 0.01 to 1 mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepOptions {
    /// Height of one tool band, mm (band k spans [k·h, (k+1)·h) above the tip).
    pub band_height_mm: f64,
    /// Rows of columns per parallel strip.
    pub strip_rows: usize,
    /// Steps handled per batch (bounds the memory of partial sums; progress is
    /// reported after each batch).
    pub batch_steps: usize,
    /// Credit a column's removal to the neighbouring steps by the share of its
    /// cell that the tool's edge sweeps in each (MODEL.md §1.5), so per-step
    /// removal does not alias with the grid. Totals are unchanged.
    pub smooth: bool,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            band_height_mm: 1.0,
            strip_rows: 8,
            batch_steps: 16_384,
            smooth: true,
        }
    }
}

/// Values stored per step before the band volumes: volume, shank volume, contact x, contact y,
/// chip edge area, volume over edge radius.
const HEAD: usize = 6;

/// What a sweep removed, per step.
#[derive(Clone, Debug, PartialEq)]
pub struct RemovalRecord {
    pub band_height_mm: f64,
    pub n_bands: usize,
    /// Per step: [volume, shank volume, contact x, contact y, chip edge area,
    /// volume over radius, band 0 … band K−1].
    data: Vec<f64>,
    /// Columns visited (inside a step's footprint) over the whole sweep.
    pub columns_evaluated: u64,
}

impl RemovalRecord {
    fn new(steps: usize, n_bands: usize, band_height_mm: f64) -> Self {
        RemovalRecord {
            band_height_mm,
            n_bands,
            data: vec![0.0; steps * (HEAD + n_bands)],
            columns_evaluated: 0,
        }
    }

    fn stride(&self) -> usize {
        HEAD + self.n_bands
    }

    fn row(&self, step: usize) -> &[f64] {
        let s = self.stride();
        &self.data[step * s..(step + 1) * s]
    }

    /// Number of steps recorded.
    pub fn len(&self) -> usize {
        self.data.len() / self.stride()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Total volume removed by `step`, mm³ (bands plus shank).
    pub fn volume_mm3(&self, step: usize) -> f64 {
        self.row(step)[0]
    }

    /// Volume removed above the flute length (shank contact), mm³.
    pub fn shank_volume_mm3(&self, step: usize) -> f64 {
        self.row(step)[1]
    }

    /// Volume removed per tool height band, mm³.
    pub fn band_volumes_mm3(&self, step: usize) -> &[f64] {
        &self.row(step)[HEAD..]
    }

    /// S4's contact-direction resultant in XY: Σ over cut columns of the unit
    /// horizontal vector from the tool axis towards the column, weighted by the
    /// removed volume (mm³). The cutting force on the tool points the other way.
    pub fn contact_resultant(&self, step: usize) -> [f64; 2] {
        let r = self.row(step);
        [r[2], r[3]]
    }

    /// Σ over removed volume of dV / h, where h is the thickness the edge cut
    /// during the step at that point, normal to the tool surface (mm², MODEL.md
    /// §3.2). The step's mean chip thickness is `volume / this`; divided by the
    /// tooth passes of the step it is the mean chip thickness per tooth.
    pub fn chip_edge_area_mm2(&self, step: usize) -> f64 {
        self.row(step)[4]
    }

    /// Σ over removed volume of dV / r, r the tool's radius where the edge cut
    /// it (mm²): turns specific cutting energy into mean tangential force
    /// (MODEL.md §3.2).
    pub fn volume_over_radius_mm2(&self, step: usize) -> f64 {
        self.row(step)[5]
    }

    /// Sum of all step volumes, mm³.
    pub fn total_volume_mm3(&self) -> f64 {
        (0..self.len()).map(|i| self.volume_mm3(i)).sum()
    }
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
}

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
        }
    }

    /// X-interval of the move's footprint (stadium of radius `r`) on the row at `y`.
    #[inline]
    fn row_span(&self, y: f64, r: f64) -> Option<(f64, f64)> {
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
        (lo <= hi).then_some((lo, hi))
    }

    /// Grid rows `[first, last]` the move's footprint (radius `r`) can touch.
    #[inline]
    fn row_range(&self, grid: &Grid, r: f64) -> Option<(usize, usize)> {
        let (y0, y1) = (self.p0[1], self.p0[1] + self.d[1]);
        grid.iy_range(y0.min(y1) - r, y0.max(y1) + r)
    }
}

/// Values of x with `lo ≤ coef·x + c0 ≤ hi`, as an interval (possibly empty or unbounded).
#[inline]
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

/// Lower envelope of a swept tool on one vertical line.
trait Envelope: Sync {
    /// `(z_env, t)`: the lowest point of the swept tool above `(x, y)` and the
    /// move parameter t ∈ [0, 1] where it is attained; `None` if the tool never
    /// passes over the point.
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<(f64, f64)>;

    /// A cheap test, made before `eval`, that the swept tool stays at or above
    /// `top` over `(x, y)` (so the column cannot be cut); `false` when unsure.
    #[inline]
    fn stays_above(&self, _m: &Prepared, _x: f64, _y: f64, _top: f64) -> bool {
        false
    }

    /// XY distance from the move's axis segment beyond which the swept tool
    /// stays above `m.zmin + depth` (so a row's columns no higher than that
    /// can be cut only within it); `None` when the tool has no such bound.
    #[inline]
    fn reach(&self, _m: &Prepared, _depth: f64) -> Option<f64> {
        None
    }

    /// The cutting edge at height `h` ≥ 0 above the tip: its radius r, 1/r and
    /// 1/sin κ, κ the angle between the tool surface's normal there and the
    /// axis (90° on a cylindrical flank). r is at least [`MIN_EDGE_RADIUS`]·R.
    fn side(&self, h: f64) -> (f64, f64, f64);

    /// cos κ of the tool surface at height `h` ≥ 0 above the tip, where the
    /// lowest point of a removed piece lies (1 on a flat bottom).
    fn bottom_cos(&self, h: f64) -> f64;
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

struct BallEnd {
    r: f64,
}

impl Envelope for BallEnd {
    /// The points of the vertical line inside the ball at parameter t form a
    /// segment whose lower end m(t) = c_z(t) − √(R² − ρ(t)²) is convex in t
    /// (ρ² is a convex quadratic). Over all t the balls fill the infinite
    /// cylinder around the centre line, whose lowest point on the line (the
    /// body root ζ*, attained at t*) minimises m; so the envelope is the body
    /// root when t* ∈ [0, 1], else the end sphere on t*'s side — one square
    /// root for the body and at most one for a sphere, no comparison of
    /// candidates. If the line misses the cylinder it misses every ball.
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<(f64, f64)> {
        let r2 = self.r * self.r;
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let [dx, dy, dz] = m.d;
        // ζ: height relative to the first ball centre C0 = p0 + (0, 0, R).
        let at_end = if m.h2 > PLUNGE_H2 {
            // Capsule body: |W − (W·D)D/|D|²|² = R² with W = (wx, wy, ζ) — quadratic in ζ.
            let rho0 = wx * wx + wy * wy;
            let k = wx * dx + wy * dy;
            let c = m.dd * rho0 - k * k - r2 * m.dd;
            let disc = k * k * dz * dz - m.h2 * c;
            if disc < 0.0 {
                return None;
            }
            let zeta = (k * dz - disc.sqrt()) * m.inv_h2;
            // t*·|D|², compared with [0, |D|²] without dividing.
            let t_dd = k + zeta * dz;
            if t_dd < 0.0 {
                false
            } else if t_dd > m.dd {
                true
            } else {
                return Some((m.p0[2] + self.r + zeta, t_dd * m.inv_dd));
            }
        } else {
            // Plunge: the lower of the two (coaxial) end balls.
            dz < 0.0
        };
        let (ex, ey, ez, t) = if at_end {
            (wx - dx, wy - dy, dz, 1.0)
        } else {
            (wx, wy, 0.0, 0.0)
        };
        let rho = ex * ex + ey * ey;
        (rho <= r2).then(|| (m.p0[2] + self.r + (ez - (r2 - rho).sqrt()), t))
    }

    /// No square root: with ρ the XY distance from the column to the move's
    /// axis segment, the ball's lower surface over the column is at least
    /// z_min + R − √(R² − ρ²) ≥ z_min + ρ²/(2R).
    #[inline]
    fn stays_above(&self, m: &Prepared, x: f64, y: f64, top: f64) -> bool {
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let t = ((wx * m.d[0] + wy * m.d[1]) * m.inv_h2).clamp(0.0, 1.0);
        let (ex, ey) = (wx - t * m.d[0], wy - t * m.d[1]);
        ex * ex + ey * ey >= 2.0 * self.r * (top - m.zmin + ABOVE_MARGIN_MM)
    }

    /// The same bound for a whole row: ρ² ≥ 2R·(depth + margin) stays above.
    #[inline]
    fn reach(&self, _m: &Prepared, depth: f64) -> Option<f64> {
        Some((2.0 * self.r * (depth + ABOVE_MARGIN_MM)).sqrt())
    }

    #[inline]
    fn side(&self, h: f64) -> (f64, f64, f64) {
        if h >= self.r {
            (self.r, 1.0 / self.r, 1.0)
        } else {
            // r = √(h (2R − h)), sin κ = r / R
            let r = (h * (2.0 * self.r - h))
                .sqrt()
                .max(MIN_EDGE_RADIUS * self.r);
            let inv_r = 1.0 / r;
            (r, inv_r, self.r * inv_r)
        }
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        ((self.r - h) / self.r).max(0.0)
    }
}

/// Parameter interval in which the point `(x, y)` lies within `r` of the tool
/// axis (XY), clipped to [0, 1].
#[inline]
fn disc_interval(m: &Prepared, x: f64, y: f64, r: f64) -> Option<(f64, f64)> {
    let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
    let rho0 = wx * wx + wy * wy;
    if m.h2 <= PLUNGE_H2 {
        return (rho0 <= r * r).then_some((0.0, 1.0));
    }
    // |w − t·d_xy|² ≤ r²: quadratic in t.
    let k = wx * m.d[0] + wy * m.d[1];
    let disc = k * k - m.h2 * (rho0 - r * r);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (ta, tb) = (((k - s) / m.h2).max(0.0), ((k + s) / m.h2).min(1.0));
    (ta <= tb).then_some((ta, tb))
}

struct FlatEnd {
    r: f64,
}

impl Envelope for FlatEnd {
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<(f64, f64)> {
        let (ta, tb) = disc_interval(m, x, y, self.r)?;
        // Tip height is linear in t: lowest at one end of the interval.
        let t = if m.d[2] >= 0.0 { ta } else { tb };
        Some((m.p0[2] + t * m.d[2], t))
    }

    #[inline]
    fn side(&self, _h: f64) -> (f64, f64, f64) {
        (self.r, 1.0 / self.r, 1.0)
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        if h < BOTTOM_MM {
            1.0
        } else {
            0.0
        }
    }
}

struct BullNose {
    r: f64,
    /// Corner radius and the radius of the torus centre circle (R − r_c).
    rc: f64,
    ring: f64,
}

impl BullNose {
    /// Height of the tool's lower surface above its tip at horizontal distance ρ.
    #[inline]
    fn profile(&self, rho: f64) -> f64 {
        let e = rho - self.ring;
        if e <= 0.0 {
            0.0
        } else {
            self.rc - (self.rc * self.rc - (e * e).min(self.rc * self.rc)).sqrt()
        }
    }

    #[inline]
    fn height(&self, m: &Prepared, x: f64, y: f64, t: f64) -> f64 {
        let (ax, ay) = (m.p0[0] + t * m.d[0], m.p0[1] + t * m.d[1]);
        let rho = ((x - ax) * (x - ax) + (y - ay) * (y - ay)).sqrt();
        self.profile(rho) + m.p0[2] + t * m.d[2]
    }
}

impl Envelope for BullNose {
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<(f64, f64)> {
        let (mut a, mut b) = disc_interval(m, x, y, self.r)?;
        // Golden-section search of a convex function on [a, b].
        const INV_PHI: f64 = 0.618_033_988_749_894_8;
        let mut c = b - INV_PHI * (b - a);
        let mut d = a + INV_PHI * (b - a);
        let (mut fc, mut fd) = (self.height(m, x, y, c), self.height(m, x, y, d));
        while b - a > 1e-10 {
            if fc <= fd {
                b = d;
                d = c;
                fd = fc;
                c = b - INV_PHI * (b - a);
                fc = self.height(m, x, y, c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + INV_PHI * (b - a);
                fd = self.height(m, x, y, d);
            }
        }
        let t = 0.5 * (a + b);
        // The interval ends are candidates too (the minimum may sit on one).
        let mut best = (self.height(m, x, y, t), t);
        for t in [a, b] {
            let h = self.height(m, x, y, t);
            if h < best.0 {
                best = (h, t);
            }
        }
        Some(best)
    }

    #[inline]
    fn side(&self, h: f64) -> (f64, f64, f64) {
        if h >= self.rc {
            (self.r, 1.0 / self.r, 1.0)
        } else {
            // Torus: r = ring + √(rc² − (rc − h)²), sin κ = (r − ring) / rc
            let e = (h * (2.0 * self.rc - h))
                .sqrt()
                .max(MIN_EDGE_RADIUS * self.rc);
            let r = self.ring + e;
            (r, 1.0 / r, self.rc / e)
        }
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        if h < BOTTOM_MM {
            1.0
        } else {
            ((self.rc - h) / self.rc).max(0.0)
        }
    }
}

/// Per-(strip, move) accumulator width and band bookkeeping shared by the strip loop.
struct Banding {
    n_bands: usize,
    band_h: f64,
    inv_band_h: f64,
    flute_len: f64,
}

impl Banding {
    /// Credit the removed piece [a, b] (absolute z) of a column to the bands
    /// above a tip at `z_tip` and to the shank; `acc` is [volume, shank, cx, cy,
    /// chip area, volume over radius, bands…] in mm. Returns the piece's length
    /// (the caller adds it to the volume).
    #[inline]
    fn credit(&self, acc: &mut [f64], z_tip: f64, a: f64, b: f64) -> f64 {
        let mut lo = (a - z_tip).max(0.0);
        let hi = (b - z_tip).max(lo);
        let length = hi - lo;
        let mut k = (lo * self.inv_band_h) as usize;
        while lo < hi && k < self.n_bands {
            let top = (((k + 1) as f64) * self.band_h).min(self.flute_len).min(hi);
            if top > lo {
                acc[HEAD + k] += top - lo;
                lo = top;
            }
            k += 1;
        }
        if lo < hi {
            acc[1] += hi - lo;
        }
        length
    }
}

/// Remove everything at and above `z` from a column, reporting each removed piece.
#[inline]
fn cut_above(col: &mut Column, z: f32, mut piece: impl FnMut(f32, f32)) {
    if let Some(upper) = col.upper.as_mut() {
        while let Some(&[lo, hi]) = upper.last() {
            if hi <= z {
                return;
            }
            if lo >= z {
                piece(lo, hi);
                upper.pop();
            } else {
                piece(z, hi);
                if let Some(last) = upper.last_mut() {
                    last[1] = z;
                }
                return;
            }
        }
        col.upper = None;
    }
    if col.hi > z && col.lo < col.hi {
        if col.lo >= z {
            piece(col.lo, col.hi);
            *col = Column::EMPTY;
        } else {
            piece(z, col.hi);
            col.hi = z;
        }
    }
}

/// Where and how the edge met a cut column (MODEL.md §1.4, §1.5, §3.2).
struct Contact {
    /// Unit XY vector from the tool axis to the column when the edge reached it.
    r_hat: [f64; 2],
    /// 1 / radius of the edge there, 1/mm.
    inv_r: f64,
    /// 1 / thickness the edge cut there during the whole step, normal to the
    /// tool surface, 1/mm.
    inv_h: f64,
    /// Shares of the column credited to the previous and the next step.
    shares: [f64; 2],
}

/// Floor of the cut thickness as a share of the step length (flanks, where
/// the edge runs along the material: the chip there is thin but not zero).
/// It biases the mean chip thickness of a full slot up by about 1 %.
const MIN_THICKNESS_SHARE: f64 = 0.03;

/// Floor of the edge's advance normal to itself per unit of path when
/// spreading a column over steps (on a flank it runs nearly along itself).
const MIN_EDGE_SPEED: f64 = 0.1;

/// CDF at `x` of the sum of two uniform variables on [0, a] and [0, b]: the
/// share of a square cell that a straight boundary has passed, a and b being
/// the projections of the cell's sides on the boundary's normal.
#[inline]
fn trapezoid_cdf(x: f64, a: f64, b: f64) -> f64 {
    let (a, b) = if a >= b { (a, b) } else { (b, a) };
    if x <= 0.0 {
        0.0
    } else if x >= a + b {
        1.0
    } else if b <= 1e-9 * a {
        x / a
    } else if x < b {
        x * x / (2.0 * a * b)
    } else if x <= a {
        (x - 0.5 * b) / a
    } else {
        let r = a + b - x;
        1.0 - r * r / (2.0 * a * b)
    }
}

/// Everything one strip needs to run its moves.
struct StripJob<'a, E> {
    env: &'a E,
    grid: &'a Grid,
    radius: f64,
    banding: &'a Banding,
    moves: &'a [Prepared],
    first_step: usize,
    smooth: bool,
}

impl<E: Envelope> StripJob<'_, E> {
    /// Accumulator width per entry: this step's sums, then (smoothing) the head
    /// values moved to the previous and to the next step.
    fn width(&self) -> usize {
        let stride = HEAD + self.banding.n_bands;
        if self.smooth {
            stride + 2 * HEAD
        } else {
            stride
        }
    }

    /// How the edge met the column at (x, y), cut at parameter t from the
    /// heights `h_top` (its top before the cut) down to `h_bot` above the tip.
    #[inline]
    fn contact(&self, m: &Prepared, x: f64, y: f64, t: f64, h_top: f64, h_bot: f64) -> Contact {
        let (r_mm, inv_r, inv_sin_k) = self.env.side(h_top.max(0.0));
        // 1/h of the floor and of the bottom's cut (descending moves only).
        let mut inv_h = m.inv_floor;
        if m.d[2] < 0.0 {
            let down = -m.d[2] * self.env.bottom_cos(h_bot.max(0.0));
            if down * inv_h > 1.0 {
                inv_h = 1.0 / down;
            }
        }
        if m.h2 <= PLUNGE_H2 {
            let (ax, ay) = (x - (m.p0[0] + t * m.d[0]), y - (m.p0[1] + t * m.d[1]));
            let dist = ax.hypot(ay);
            let r_hat = if dist > 1e-12 {
                [ax / dist, ay / dist]
            } else {
                [0.0, 0.0]
            };
            return Contact {
                r_hat,
                inv_r,
                inv_h,
                shares: [0.0, 0.0],
            };
        }
        // The edge circle of radius r at the column's top first reaches it at
        // the angle θ from the feed direction with sin θ = e / r (e: the
        // column's signed offset to the left of the move's line).
        let [ux, uy] = m.u;
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let sin_t = ((ux * wy - uy * wx) * inv_r).clamp(-1.0, 1.0);
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let r_hat = [cos_t * ux - sin_t * uy, cos_t * uy + sin_t * ux];
        // MODEL.md §3.2: h = f · n̂, the step's feed vector on the tool surface's normal,
        // h_side = L_xy sin κ cos θ. Near the flanks 1/cos θ varies fast across the cell:
        // take its mean over the cell's offsets, [e − g/2, e + g/2] ∩ [−r, r]
        // (mean of 1/cos = Δ arcsin · r / Δe).
        let half = 0.5 * self.grid.spacing_mm * inv_r;
        let inv_cos = if 1.0 - sin_t.abs() > 4.0 * half {
            // Away from the flank the cell mean is 1/cos θ to O(half²).
            1.0 / cos_t
        } else {
            let (lo, hi) = ((sin_t - half).max(-1.0), (sin_t + half).min(1.0));
            (hi.asin() - lo.asin()) / (2.0 * half)
        };
        let inv_side = inv_cos * inv_sin_k * m.inv_len_xy;
        let side_cut = inv_side <= inv_h;
        inv_h = inv_h.min(inv_side);
        let shares = if self.smooth && side_cut {
            // MODEL.md §1.5: the edge, locally straight with normal r̂, passes the
            // column's centre at s_c along the move and advances cos θ per mm of path;
            // the cell's share passed by s is the trapezoid CDF.
            let s_c = ((wx * ux + wy * uy) - r_mm * cos_t).clamp(0.0, m.len_xy);
            let g = self.grid.spacing_mm;
            let (a, b) = (g * r_hat[0].abs(), g * r_hat[1].abs());
            let speed = cos_t.max(MIN_EDGE_SPEED);
            let reach = 0.5 * (a + b);
            if s_c * speed >= reach && (m.len_xy - s_c) * speed >= reach {
                // The whole cell is passed within the step.
                [0.0, 0.0]
            } else {
                let passed = |s: f64| trapezoid_cdf((s - s_c) * speed + reach, a, b);
                [passed(0.0), 1.0 - passed(m.len_xy)]
            }
        } else {
            [0.0, 0.0]
        };
        Contact {
            r_hat,
            inv_r,
            inv_h,
            shares,
        }
    }

    /// Run the moves `entries` (batch-local indices, ascending) over the rows
    /// `row0..row0 + rows` whose columns are `cols`; write per-entry sums into `out`
    /// (per entry: this step's sums, then with smoothing the shares for the
    /// previous and the next step).
    fn run(
        &self,
        row0: usize,
        cols: &mut [Column],
        last_cut: &mut [u32],
        entries: &[u32],
        out: &mut [f64],
    ) -> u64 {
        let nx = self.grid.nx;
        let rows = cols.len() / nx;
        let stride = HEAD + self.banding.n_bands;
        let width = self.width();
        let area = self.grid.cell_area_mm2();
        let mut visited = 0u64;
        for (j, &mi) in entries.iter().enumerate() {
            let m = &self.moves[mi as usize];
            let all = &mut out[j * width..(j + 1) * width];
            let step_index = (self.first_step + mi as usize) as u32;
            let Some((iy0, iy1)) = m.row_range(self.grid, self.radius) else {
                continue;
            };
            let (iy0, iy1) = (iy0.max(row0), iy1.min(row0 + rows - 1));
            let zmin = m.zmin as f32;
            for iy in iy0..=iy1 {
                let y = self.grid.y_mm(iy);
                let Some((x_lo, x_hi)) = m.row_span(y, self.radius) else {
                    continue;
                };
                let Some((ix0, ix1)) = self.grid.ix_range(x_lo, x_hi) else {
                    continue;
                };
                visited += (ix1 - ix0 + 1) as u64;
                let base = (iy - row0) * nx;
                // Narrow the row to where the tool can reach below the row's highest top.
                let Some((ix0, ix1)) =
                    self.reachable(m, y, &cols[base + ix0..=base + ix1], ix0, ix1)
                else {
                    continue;
                };
                for ix in ix0..=ix1 {
                    let col = &mut cols[base + ix];
                    let top = col.top_or_neg_inf();
                    if top <= zmin {
                        continue;
                    }
                    let x = self.grid.x_mm(ix);
                    if self.env.stays_above(m, x, y, top as f64) {
                        continue;
                    }
                    let Some((z_env, t)) = self.env.eval(m, x, y) else {
                        continue;
                    };
                    let z = z_env as f32;
                    if top <= z {
                        continue;
                    }
                    let z_tip = m.p0[2] + t * m.d[2];
                    let c = self.contact(m, x, y, t, top as f64 - z_tip, z as f64 - z_tip);
                    let mut removed = 0.0;
                    cut_above(col, z, |a, b| {
                        removed += self.banding.credit(all, z_tip, a as f64, b as f64);
                    });
                    if removed > 0.0 {
                        last_cut[base + ix] = step_index;
                        let column = [
                            removed,
                            0.0,
                            removed * c.r_hat[0],
                            removed * c.r_hat[1],
                            removed * c.inv_h,
                            removed * c.inv_r,
                        ];
                        for (d, v) in all[..HEAD].iter_mut().zip(column) {
                            *d += v;
                        }
                        // Shares for the neighbours: head values only; bands and shank
                        // follow in proportion when the strips are reduced.
                        for (k, slot) in [(0, stride), (1, stride + HEAD)] {
                            let share = c.shares[k];
                            if share > 0.0 {
                                for (d, v) in all[slot..slot + HEAD].iter_mut().zip(column) {
                                    *d += share * v;
                                }
                            }
                        }
                    }
                }
            }
            for v in all.iter_mut() {
                *v *= area;
            }
        }
        visited
    }

    /// The columns `ix0..=ix1` of the row at `y` (`row` holds them) that the
    /// move can cut: those within the tool's reach below the row's highest
    /// top. Columns left out pass neither `stays_above` nor the zmin test, so
    /// narrowing changes no result.
    #[inline]
    fn reachable(
        &self,
        m: &Prepared,
        y: f64,
        row: &[Column],
        ix0: usize,
        ix1: usize,
    ) -> Option<(usize, usize)> {
        if self.env.reach(m, 0.0).is_none() {
            return Some((ix0, ix1));
        }
        // Heights are never NaN: a plain compare is cheaper than f32::max.
        let top = row
            .iter()
            .map(Column::top_or_neg_inf)
            .fold(f32::NEG_INFINITY, |a, b| if b > a { b } else { a });
        if top <= m.zmin as f32 {
            return None;
        }
        match self.env.reach(m, top as f64 - m.zmin) {
            Some(r) if r < self.radius => {
                let (x_lo, x_hi) = m.row_span(y, r)?;
                let (a, b) = self.grid.ix_range(x_lo, x_hi)?;
                let (a, b) = (a.max(ix0), b.min(ix1));
                (a <= b).then_some((a, b))
            }
            _ => Some((ix0, ix1)),
        }
    }
}

/// Sweep `tool` along `steps` through `stock`, removing material and recording
/// what each step removed. `progress(done)` is called after each batch with
/// the number of steps finished.
pub fn sweep(
    stock: &mut Stock,
    tool: &Tool,
    steps: &[Step],
    options: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<RemovalRecord, Error> {
    tool.validate()?;
    if !(options.band_height_mm > 0.0 && options.band_height_mm.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "band height must be positive, got {} mm",
            options.band_height_mm
        )));
    }
    if let Some((i, _)) = steps
        .iter()
        .enumerate()
        .find(|(_, s)| !s.from_mm.iter().chain(&s.to_mm).all(|v| v.is_finite()))
    {
        return Err(Error::InvalidParameter(format!(
            "step {i} has a non-finite coordinate"
        )));
    }
    let n_bands = ((tool.flute_length_mm / options.band_height_mm).ceil() as usize).max(1);
    if n_bands > 10_000 {
        return Err(Error::InvalidParameter(format!(
            "band height {} mm gives {n_bands} bands over the flute length; use a larger band height",
            options.band_height_mm
        )));
    }
    let banding = Banding {
        n_bands,
        band_h: options.band_height_mm,
        inv_band_h: 1.0 / options.band_height_mm,
        flute_len: tool.flute_length_mm,
    };
    let radius = tool.radius_mm();
    let mut record = RemovalRecord::new(steps.len(), n_bands, options.band_height_mm);
    match tool.shape {
        ToolShape::Ball => run_batches(
            stock,
            &BallEnd { r: radius },
            radius,
            &banding,
            steps,
            options,
            &mut record,
            progress,
        ),
        ToolShape::Flat => run_batches(
            stock,
            &FlatEnd { r: radius },
            radius,
            &banding,
            steps,
            options,
            &mut record,
            progress,
        ),
        ToolShape::Bull { corner_radius_mm } => {
            let env = BullNose {
                r: radius,
                rc: corner_radius_mm,
                ring: radius - corner_radius_mm,
            };
            run_batches(
                stock,
                &env,
                radius,
                &banding,
                steps,
                options,
                &mut record,
                progress,
            )
        }
    }
    Ok(record)
}

/// Sweep steps cut by several tools: step `i` is cut by `tools[tool_of_step[i]]`.
/// Each run of consecutive steps with one tool is one [`sweep`] (in order, on
/// the same stock); the record has the band count of the tool with the most
/// bands, the others' higher bands are zero.
pub fn sweep_tools(
    stock: &mut Stock,
    tools: &[Tool],
    tool_of_step: &[usize],
    steps: &[Step],
    options: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<RemovalRecord, Error> {
    if tool_of_step.len() != steps.len() {
        return Err(Error::InvalidParameter(format!(
            "{} tool indices for {} steps",
            tool_of_step.len(),
            steps.len()
        )));
    }
    if let Some(&bad) = tool_of_step.iter().find(|&&t| t >= tools.len()) {
        return Err(Error::InvalidParameter(format!(
            "tool index {bad} with {} tools",
            tools.len()
        )));
    }
    let mut parts = Vec::new();
    let mut start = 0;
    while start < steps.len() {
        let t = tool_of_step[start];
        let end = start
            + tool_of_step[start..]
                .iter()
                .position(|&u| u != t)
                .unwrap_or(steps.len() - start);
        let done = start;
        parts.push((
            start,
            sweep(stock, &tools[t], &steps[start..end], options, &|d| {
                progress(done + d)
            })?,
        ));
        start = end;
    }
    if parts.len() == 1 {
        // One tool: the record as it is (no copy).
        return Ok(parts.pop().expect("one part").1);
    }
    let n_bands = parts.iter().map(|(_, r)| r.n_bands).max().unwrap_or(1);
    let mut record = RemovalRecord::new(steps.len(), n_bands, options.band_height_mm);
    let stride = record.stride();
    for (offset, part) in &parts {
        record.columns_evaluated += part.columns_evaluated;
        for j in 0..part.len() {
            let row = part.row(j);
            let at = (offset + j) * stride;
            record.data[at..at + row.len()].copy_from_slice(row);
        }
    }
    Ok(record)
}

/// Whether `b` continues `a`'s motion: it starts where `a` ends, is of the same
/// kind (a rapid must not look as if it cut) and turns by less than 90° in XY.
fn continues(a: &Step, b: &Step) -> bool {
    let da = [a.to_mm[0] - a.from_mm[0], a.to_mm[1] - a.from_mm[1]];
    let db = [b.to_mm[0] - b.from_mm[0], b.to_mm[1] - b.from_mm[1]];
    a.rapid == b.rapid
        && a.to_mm
            .iter()
            .zip(&b.from_mm)
            .all(|(p, q)| (p - q).abs() <= 1e-9)
        && da[0] * db[0] + da[1] * db[1] > 0.0
}

#[allow(clippy::too_many_arguments)]
fn run_batches<E: Envelope>(
    stock: &mut Stock,
    env: &E,
    radius: f64,
    banding: &Banding,
    steps: &[Step],
    options: &SweepOptions,
    record: &mut RemovalRecord,
    progress: &(dyn Fn(usize) + Sync),
) {
    let grid = *stock.grid();
    let strip_rows = options.strip_rows.max(1);
    let n_strips = grid.ny.div_ceil(strip_rows);
    let stride = HEAD + banding.n_bands;
    let batch = options.batch_steps.max(1);
    // Per step: head values to move to the previous and to the next step.
    let mut spill = if options.smooth {
        vec![0.0f64; steps.len() * 2 * HEAD]
    } else {
        Vec::new()
    };
    let mut done = 0;
    for (b, chunk) in steps.chunks(batch).enumerate() {
        let first_step = b * batch;
        let moves: Vec<Prepared> = chunk.iter().map(Prepared::new).collect();
        // Bin moves by strip (CSR): a move joins every strip its footprint's rows touch.
        let mut counts = vec![0u32; n_strips + 1];
        let strip_span = |m: &Prepared| {
            m.row_range(&grid, radius)
                .map(|(a, b)| (a / strip_rows, b / strip_rows))
        };
        for m in &moves {
            if let Some((s0, s1)) = strip_span(m) {
                for s in s0..=s1 {
                    counts[s + 1] += 1;
                }
            }
        }
        for s in 0..n_strips {
            counts[s + 1] += counts[s];
        }
        let mut entries = vec![0u32; counts[n_strips] as usize];
        let mut fill = counts.clone();
        for (i, m) in moves.iter().enumerate() {
            if let Some((s0, s1)) = strip_span(m) {
                for s in s0..=s1 {
                    entries[fill[s] as usize] = i as u32;
                    fill[s] += 1;
                }
            }
        }
        let job = StripJob {
            env,
            grid: &grid,
            radius,
            banding,
            moves: &moves,
            first_step,
            smooth: options.smooth,
        };
        let width = job.width();
        let mut partial = vec![0.0f64; entries.len() * width];
        // Split columns, last-cut marks and partial sums into per-strip pieces.
        let strip_len = strip_rows * grid.nx;
        let mut partial_pieces: Vec<&mut [f64]> = Vec::with_capacity(n_strips);
        let mut rest: &mut [f64] = &mut partial;
        for s in 0..n_strips {
            let n = (counts[s + 1] - counts[s]) as usize * width;
            let (head, tail) = rest.split_at_mut(n);
            partial_pieces.push(head);
            rest = tail;
        }
        let visited: u64 = stock
            .columns
            .par_chunks_mut(strip_len)
            .zip(stock.last_cut.par_chunks_mut(strip_len))
            .zip(partial_pieces.into_par_iter())
            .enumerate()
            .map(|(s, ((cols, last), out))| {
                let ents = &entries[counts[s] as usize..counts[s + 1] as usize];
                if ents.is_empty() {
                    0
                } else {
                    job.run(s * strip_rows, cols, last, ents, out)
                }
            })
            .sum();
        record.columns_evaluated += visited;
        // Reduce in strip order: the same sums whatever the thread count. The
        // shares for the neighbouring steps are summed per step and applied
        // once the whole program is swept (`apply_spill`).
        for (e, &mi) in entries.iter().enumerate() {
            let i = first_step + mi as usize;
            let src = &partial[e * width..(e + 1) * width];
            let dst = i * stride;
            for (d, s) in record.data[dst..dst + stride].iter_mut().zip(src) {
                *d += s;
            }
            if width > stride {
                for (d, s) in spill[i * 2 * HEAD..(i + 1) * 2 * HEAD]
                    .iter_mut()
                    .zip(&src[stride..])
                {
                    *d += s;
                }
            }
        }
        done += chunk.len();
        progress(done);
    }
    if options.smooth {
        apply_spill(record, steps, &spill);
    }
}

/// Move each step's shares to its neighbours (MODEL.md §1.5): head values as
/// recorded per column, the shank and the bands in proportion to the volume
/// moved. A share moves only where the motion continues into the neighbour
/// and the neighbour removes material of its own, else it stays.
fn apply_spill(record: &mut RemovalRecord, steps: &[Step], spill: &[f64]) {
    let stride = record.stride();
    let own = record.data.clone();
    let n = steps.len();
    for i in 0..n {
        let row = &own[i * stride..(i + 1) * stride];
        let volume = row[0];
        if volume <= 0.0 {
            continue;
        }
        let targets = [
            (i > 0 && continues(&steps[i - 1], &steps[i])).then(|| i - 1),
            (i + 1 < n && continues(&steps[i], &steps[i + 1])).then_some(i + 1),
        ];
        for (side, target) in targets.into_iter().enumerate() {
            let Some(t) = target.filter(|&t| own[t * stride] > 0.0) else {
                continue;
            };
            let moved = &spill[(2 * i + side) * HEAD..(2 * i + side + 1) * HEAD];
            if moved[0] <= 0.0 {
                continue;
            }
            let f = (moved[0] / volume).min(1.0);
            for k in 0..stride {
                let v = match k {
                    0 | 2..=5 => moved[k],
                    _ => f * row[k],
                };
                record.data[i * stride + k] -= v;
                record.data[t * stride + k] += v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lowest point of the tool's lower surface above (x, y) by dense sampling of t.
    fn brute_force(
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
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    fn check_against_brute_force(
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
            let exact = env.eval(&m, x, y).map(|e| e.0);
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

    #[test]
    fn ball_envelope_matches_brute_force() {
        let r = 5.0;
        let profile = move |rho: f64| (rho <= r).then(|| r - (r * r - rho * rho).sqrt());
        check_against_brute_force(&BallEnd { r }, &profile, 1e-4);
    }

    /// Lowest point of the swept ball on the vertical line at (x, y), found
    /// without the capsule formula: the ball's lower end m(t) is convex on the
    /// parameter interval where the line meets the ball, so a dense scan
    /// followed by a golden-section refinement around the best sample gives the
    /// minimum to ~1e-12.
    fn ball_reference(step: &Step, r: f64, x: f64, y: f64) -> Option<f64> {
        let at = |t: f64| -> Option<f64> {
            let p = m_at(step, t);
            let rho2 = (x - p[0]).powi(2) + (y - p[1]).powi(2);
            (rho2 <= r * r).then(|| p[2] + r - (r * r - rho2).sqrt())
        };
        let n = 4000;
        let mut best: Option<(f64, usize)> = None;
        for i in 0..=n {
            if let Some(z) = at(i as f64 / n as f64) {
                if best.is_none_or(|b| z < b.0) {
                    best = Some((z, i));
                }
            }
        }
        let (mut z_best, i) = best?;
        // Refine on the neighbouring samples, clipped to where the line meets the ball.
        let (mut a, mut b) = (
            i.saturating_sub(1) as f64 / n as f64,
            (i + 1).min(n) as f64 / n as f64,
        );
        let f = |t: f64| at(t).unwrap_or(f64::INFINITY);
        for _ in 0..200 {
            let (c, d) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
            let (fc, fd) = (f(c), f(d));
            z_best = z_best.min(fc).min(fd);
            // Outside the ball's interval f is +∞: move towards the finite side.
            if fc <= fd {
                b = d;
            } else {
                a = c;
            }
        }
        Some(z_best.min(f(0.0)).min(f(1.0)))
    }

    #[test]
    fn ball_single_candidate_matches_refined_minimum() {
        let r = 5.0;
        let ball = BallEnd { r };
        let mut seed = 23;
        let (mut hits, mut misses, mut skipped) = (0, 0, 0);
        for case in 0..6000 {
            let mut u = || lcg(&mut seed);
            let from = [u() * 20.0 - 10.0, u() * 20.0 - 10.0, u() * 20.0 - 10.0];
            // Horizontal direction and length, vertical change, by kind of move.
            let ang = u() * std::f64::consts::TAU;
            let (len_xy, dz) = match case % 8 {
                0 => (0.0, u() * 20.0 - 10.0), // plunge / retract
                1 => (u() * 15.0, 0.0),        // horizontal
                2 => (u() * 15.0, -u() * 3.0), // ramp down
                3 => (u() * 15.0, u() * 3.0),  // ramp up
                4 => (10f64.powf(-3.0 - 4.0 * u()), u() * 20.0 - 10.0), // near-vertical
                5 => (u() * 1e-3, (u() - 0.5) * 1e-3), // tiny move
                6 => (u() * 0.8, (u() - 0.5) * 0.2), // servo-sized step
                _ => (u() * 20.0, u() * 20.0 - 10.0), // anything
            };
            let to = [
                from[0] + len_xy * ang.cos(),
                from[1] + len_xy * ang.sin(),
                from[2] + dz,
            ];
            let step = Step {
                from_mm: from,
                to_mm: to,
                rapid: false,
            };
            let m = Prepared::new(&step);
            // A point within R + 0.5 of a random point of the move's XY segment.
            let (s, a2, d2) = (u(), u() * std::f64::consts::TAU, (r + 0.5) * u().sqrt());
            let x = from[0] + s * (to[0] - from[0]) + d2 * a2.cos();
            let y = from[1] + s * (to[1] - from[1]) + d2 * a2.sin();
            let got = ball.eval(&m, x, y);
            let want = ball_reference(&step, r, x, y);
            match (got, want) {
                (Some((z, t)), Some(w)) => {
                    hits += 1;
                    assert!(
                        (z - w).abs() < 1e-9,
                        "case {case}: {step:?} at ({x}, {y}): eval {z}, reference {w}"
                    );
                    assert!((0.0..=1.0).contains(&t), "case {case}: t = {t}");
                    // The reported t must be where the envelope is attained.
                    let at_t = ball_reference(
                        &Step {
                            from_mm: m_at(&step, t),
                            to_mm: m_at(&step, t),
                            rapid: false,
                        },
                        r,
                        x,
                        y,
                    );
                    let at_t = at_t.unwrap_or(f64::INFINITY);
                    assert!(
                        (at_t - z).abs() < 1e-6,
                        "case {case}: height at t = {t} is {at_t}, envelope {z}"
                    );
                    // The sqrt-free bounds may only skip columns the tool cannot cut.
                    let (sx, sy) = (to[0] - from[0], to[1] - from[1]);
                    let s_len2 = sx * sx + sy * sy;
                    let s_t = if s_len2 > 0.0 {
                        (((x - from[0]) * sx + (y - from[1]) * sy) / s_len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let rho_min = (x - from[0] - s_t * sx).hypot(y - from[1] - s_t * sy);
                    for top in [z - 1.0, z - 1e-3, z - 1e-9, z + 1e-9, z + 1e-3, z + 1.0] {
                        if ball.stays_above(&m, x, y, top) {
                            skipped += 1;
                            assert!(
                                z >= top,
                                "case {case}: stays_above({top}) but the envelope is {z}"
                            );
                        }
                        let reach = ball.reach(&m, top - m.zmin).unwrap();
                        if rho_min > reach + 1e-6 {
                            assert!(z >= top, "case {case}: ρ {rho_min} beyond reach {reach} of {top}, envelope {z}");
                        }
                    }
                }
                (None, None) => misses += 1,
                (got, want) => {
                    // Only a point on the footprint's rim may disagree.
                    let near_rim = (0..=10_000).any(|i| {
                        let p = m_at(&step, i as f64 / 10_000.0);
                        (((x - p[0]).powi(2) + (y - p[1]).powi(2)).sqrt() - r).abs() < 1e-6
                    });
                    assert!(
                        near_rim,
                        "case {case}: {step:?} at ({x}, {y}): eval {got:?}, reference {want:?}"
                    );
                }
            }
        }
        assert!(
            hits > 4000 && misses > 100 && skipped > 1000,
            "{hits} hits, {misses} misses, {skipped} skipped"
        );
    }

    fn m_at(step: &Step, t: f64) -> [f64; 3] {
        std::array::from_fn(|k| step.from_mm[k] + t * (step.to_mm[k] - step.from_mm[k]))
    }

    #[test]
    fn flat_envelope_matches_brute_force() {
        let r = 5.0;
        let profile = move |rho: f64| (rho <= r).then_some(0.0);
        check_against_brute_force(&FlatEnd { r }, &profile, 1e-3);
    }

    #[test]
    fn bull_envelope_matches_brute_force() {
        let env = BullNose {
            r: 5.0,
            rc: 2.0,
            ring: 3.0,
        };
        let profile = |rho: f64| (rho <= 5.0).then(|| env.profile(rho));
        check_against_brute_force(&env, &profile, 1e-4);
    }

    #[test]
    fn bull_nose_limits_are_ball_and_flat() {
        let mut seed = 11;
        let (ball, flat) = (BallEnd { r: 5.0 }, FlatEnd { r: 5.0 });
        let near_ball = BullNose {
            r: 5.0,
            rc: 5.0 - 1e-12,
            ring: 1e-12,
        };
        let near_flat = BullNose {
            r: 5.0,
            rc: 1e-12,
            ring: 5.0 - 1e-12,
        };
        let (mut ball_hits, mut flat_hits) = (0, 0);
        for _ in 0..500 {
            let mut r = || lcg(&mut seed) * 20.0 - 10.0;
            let step = Step {
                from_mm: [r(), r(), r()],
                to_mm: [r(), r(), r()],
                rapid: false,
            };
            let m = Prepared::new(&step);
            let (x, y) = (r() * 0.5, r() * 0.5);
            for (exact, limit, hits) in [
                (
                    ball.eval(&m, x, y),
                    near_ball.eval(&m, x, y),
                    &mut ball_hits,
                ),
                (
                    flat.eval(&m, x, y),
                    near_flat.eval(&m, x, y),
                    &mut flat_hits,
                ),
            ] {
                match (exact, limit) {
                    (Some(a), Some(b)) => {
                        *hits += 1;
                        assert!((a.0 - b.0).abs() < 1e-6, "{a:?} vs {b:?}");
                    }
                    (None, None) => {}
                    (a, b) => panic!("footprint differs: {a:?} vs {b:?}"),
                }
            }
        }
        assert!(
            ball_hits > 100 && flat_hits > 100,
            "{ball_hits} ball, {flat_hits} flat hits"
        );
    }

    #[test]
    fn cut_above_handles_several_intervals() {
        let mut col = Column::from_intervals(&[[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]);
        let mut pieces = Vec::new();
        cut_above(&mut col, 2.5, |a, b| pieces.push((a, b)));
        assert_eq!(pieces, vec![(4.0, 5.0), (2.5, 3.0)]);
        assert_eq!(
            col.intervals().collect::<Vec<_>>(),
            vec![[0.0, 1.0], [2.0, 2.5]]
        );
        pieces.clear();
        cut_above(&mut col, -1.0, |a, b| pieces.push((a, b)));
        assert_eq!(pieces, vec![(2.0, 2.5), (0.0, 1.0)]);
        assert!(col.is_empty() && col.upper.is_none());
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
        assert_eq!(b.credit(&mut acc, 10.0, 10.5, 14.0), 3.5);
        assert_eq!(&acc[HEAD..], &[0.5, 1.0, 0.5]);
        assert_eq!(acc[1], 1.5, "above the flute length is shank contact");
    }

    #[test]
    fn row_span_is_the_stadium() {
        let m = Prepared::new(&Step {
            from_mm: [0.0, 0.0, 0.0],
            to_mm: [10.0, 10.0, 0.0],
            rapid: false,
        });
        let (lo, hi) = m.row_span(5.0, 1.0).unwrap();
        let h = 2f64.sqrt();
        assert!(
            (lo - (5.0 - h)).abs() < 1e-12 && (hi - (5.0 + h)).abs() < 1e-12,
            "{lo} {hi}"
        );
        assert!(m.row_span(11.5, 1.0).is_none());
        // Near the end the band still reaches further left than the end circle.
        let (lo, hi) = m.row_span(10.5, 1.0).unwrap();
        let w = (1.0f64 - 0.25).sqrt();
        assert!(
            (lo - (10.5 - h)).abs() < 1e-12 && (hi - (10.0 + w)).abs() < 1e-12,
            "{lo} {hi}"
        );
    }
}
