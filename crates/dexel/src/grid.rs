//! The column grid: where the dexels stand in XY.

use crate::Error;

/// Bytes one column costs in a [`crate::Stock`] at most (top interval and
/// last-cut index; the rare intervals below a top one are held apart; a
/// stock whose top intervals share their bottom holds 8, `stock::Bottoms`).
pub const BYTES_PER_COLUMN: usize =
    std::mem::size_of::<crate::top::Top>() + std::mem::size_of::<u32>();

/// A regular grid of vertical columns. Column `(ix, iy)` stands at
/// `(x0 + (ix + ½)·spacing, y0 + (iy + ½)·spacing)` and represents the
/// `spacing × spacing` cell around it. Columns are stored row-major (x fastest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Left edge (lowest x) of the covered area, mm.
    pub x0_mm: f64,
    /// Bottom edge (lowest y) of the covered area, mm.
    pub y0_mm: f64,
    /// Column spacing, mm.
    pub spacing_mm: f64,
    /// Columns along x.
    pub nx: usize,
    /// Columns along y.
    pub ny: usize,
}

impl Grid {
    /// Grid covering `[min_x, max_x] × [min_y, max_y]` with cells of `spacing_mm`
    /// (the count is rounded so that cells tile the area; the area is then
    /// re-centred so the grid is symmetric about the requested rectangle).
    pub fn covering(
        min_x: f64,
        min_y: f64,
        max_x: f64,
        max_y: f64,
        spacing_mm: f64,
    ) -> Result<Grid, Error> {
        if !(spacing_mm > 0.0 && spacing_mm.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "grid spacing must be a positive number of mm, got {spacing_mm}"
            )));
        }
        if !(max_x > min_x
            && max_y > min_y
            && [min_x, min_y, max_x, max_y].iter().all(|v| v.is_finite()))
        {
            return Err(Error::InvalidParameter(format!(
                "grid area must have positive size, got x {min_x}..{max_x}, y {min_y}..{max_y}"
            )));
        }
        let nxf = ((max_x - min_x) / spacing_mm).round().max(1.0);
        let nyf = ((max_y - min_y) / spacing_mm).round().max(1.0);
        if nxf * nyf > 4.0e9 {
            return Err(Error::TooLarge {
                columns: nxf * nyf,
                bytes: nxf * nyf * BYTES_PER_COLUMN as f64,
            });
        }
        let (nx, ny) = (nxf as usize, nyf as usize);
        let cx = 0.5 * (min_x + max_x) - 0.5 * nx as f64 * spacing_mm;
        let cy = 0.5 * (min_y + max_y) - 0.5 * ny as f64 * spacing_mm;
        Ok(Grid {
            x0_mm: cx,
            y0_mm: cy,
            spacing_mm,
            nx,
            ny,
        })
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// No columns (zero extent along x or y).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Area of one column's cell, mm².
    pub fn cell_area_mm2(&self) -> f64 {
        self.spacing_mm * self.spacing_mm
    }

    /// Bytes the stock on this grid needs (without overflow intervals).
    pub fn memory_bytes(&self) -> f64 {
        self.len() as f64 * BYTES_PER_COLUMN as f64
    }

    /// X of column `ix`'s centre.
    #[inline]
    pub fn x_mm(&self, ix: usize) -> f64 {
        self.x0_mm + (ix as f64 + 0.5) * self.spacing_mm
    }

    /// Y of row `iy`'s centre.
    #[inline]
    pub fn y_mm(&self, iy: usize) -> f64 {
        self.y0_mm + (iy as f64 + 0.5) * self.spacing_mm
    }

    /// Index range `[first, last]` of columns whose centres lie in `[lo, hi]` along x;
    /// `None` when no centre does.
    #[inline]
    pub fn ix_range(&self, lo: f64, hi: f64) -> Option<(usize, usize)> {
        centre_range(self.x0_mm, self.spacing_mm, self.nx, lo, hi)
    }

    /// Same as [`Grid::ix_range`] along y.
    #[inline]
    pub fn iy_range(&self, lo: f64, hi: f64) -> Option<(usize, usize)> {
        centre_range(self.y0_mm, self.spacing_mm, self.ny, lo, hi)
    }
}

/// The columns (or rows) whose centres lie in `[lo, hi]`: first and last
/// index as whole numbers in f64, and whether there are any (first ≤ last).
/// The f64 form is what the sweep's lanes compute in
/// ([`Grid::ix_bounds_in_lanes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CentreBounds {
    pub(crate) first: f64,
    pub(crate) last: f64,
    pub(crate) any: bool,
}

impl Grid {
    /// [`Grid::x_mm`] with the index converted through i32 (exact below 2³¹
    /// columns, which a grid never reaches): a conversion the sweep's lanes
    /// have packed, where usize to f64 has none. The same value.
    #[inline(always)]
    pub(crate) fn x_mm_in_lanes(&self, ix: usize) -> f64 {
        self.x0_mm + ((ix as i32) as f64 + 0.5) * self.spacing_mm
    }

    /// [`Grid::y_mm`] as [`Grid::x_mm_in_lanes`] takes `x_mm`.
    #[inline(always)]
    pub(crate) fn y_mm_in_lanes(&self, iy: usize) -> f64 {
        self.y0_mm + ((iy as i32) as f64 + 0.5) * self.spacing_mm
    }

    /// [`Grid::ix_range`] as whole numbers in f64, free of branches, rounded
    /// by the library's `floor` and `ceil` (a rounding instruction where the
    /// caller is compiled for one): the same indices, for the sweep's rows in
    /// lanes.
    #[inline(always)]
    pub(crate) fn ix_bounds_in_lanes(&self, lo: f64, hi: f64) -> CentreBounds {
        centre_bounds(
            self.x0_mm,
            self.spacing_mm,
            self.nx,
            lo,
            hi,
            f64::floor,
            f64::ceil,
        )
    }
}

/// The one formula of the centres in `[lo, hi]` (centre i at origin + (i +
/// 0.5) g, so i ≥ (lo − origin)/g − 0.5), with the roundings given: both
/// round whole numbers the same, so the same indices whichever are given.
#[inline(always)]
fn centre_bounds(
    origin: f64,
    g: f64,
    n: usize,
    lo: f64,
    hi: f64,
    floor: impl Fn(f64) -> f64,
    ceil: impl Fn(f64) -> f64,
) -> CentreBounds {
    let first = ceil((lo - origin) / g - 0.5).max(0.0);
    let last = floor((hi - origin) / g - 0.5).min(n as f64 - 1.0);
    let none = first > last || last < 0.0 || first.is_nan() || last.is_nan();
    CentreBounds {
        first,
        last,
        any: !none,
    }
}

#[inline]
fn centre_range(origin: f64, g: f64, n: usize, lo: f64, hi: f64) -> Option<(usize, usize)> {
    let b = centre_bounds(origin, g, n, lo, hi, floor, ceil);
    b.any.then_some((b.first as usize, b.last as usize))
}

/// Magnitude from which every f64 is an integer (2⁵²).
const INTEGRAL_FROM: f64 = 4_503_599_627_370_496.0;

/// ⌊v⌋ inline: the x86-64 baseline has no rounding instruction, and
/// `f64::floor` is a call into the C library there (three per row of a
/// move in the sweep kernel). The truncation, less one where it
/// rounded up; NaN, ±∞ and magnitudes from 2⁵² on are returned as they are
/// (integers already). Equal to `f64::floor` but for the sign of a zero
/// (+0 for −0), which no caller tells apart.
#[inline]
fn floor(v: f64) -> f64 {
    if !(v.abs() < INTEGRAL_FROM) {
        return v;
    }
    let t = v as i64 as f64;
    if t > v {
        t - 1.0
    } else {
        t
    }
}

/// ⌈v⌉ inline, as [`floor`]: +0 where `f64::ceil` gives −0 (on (−1, 0]).
#[inline]
fn ceil(v: f64) -> f64 {
    if !(v.abs() < INTEGRAL_FROM) {
        return v;
    }
    let t = v as i64 as f64;
    if t < v {
        t + 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inline roundings equal the C library's on integers, halves,
    /// neighbours of integers, ±0, values near 2⁵² and 2⁶³, ±∞ and NaN
    /// (a zero's sign aside).
    #[test]
    fn inline_floor_and_ceil_match_the_library() {
        let mut values = vec![0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        for k in -60..=60 {
            let v = k as f64 * 0.5;
            values.extend([v, v.next_up(), v.next_down()]);
        }
        for e in [51, 52, 53, 62, 63, 64, 80] {
            let v = 2f64.powi(e);
            for w in [v, -v] {
                values.extend([w, w.next_up(), w.next_down(), w + 0.5, w - 0.5]);
            }
        }
        let mut seed = 1u64;
        for _ in 0..100_000 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            values.push((u - 0.5) * 10f64.powi((seed % 23) as i32 - 6));
        }
        for v in values {
            for (got, want) in [(floor(v), v.floor()), (ceil(v), v.ceil())] {
                assert!(
                    got == want || (got.is_nan() && want.is_nan()),
                    "{v:e}: {got:e} against {want:e}"
                );
            }
        }
        assert_eq!(floor(-0.5), -1.0);
        assert_eq!(ceil(0.5), 1.0);
    }
}
