//! The column grid: where the dexels stand in XY.

use crate::Error;

/// Bytes one column costs in a [`crate::Stock`] (top interval and last-cut
/// index; the rare intervals below a top one are held apart).
pub const BYTES_PER_COLUMN: usize =
    std::mem::size_of::<crate::stock::Top>() + std::mem::size_of::<u32>();

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

#[inline]
fn centre_range(origin: f64, g: f64, n: usize, lo: f64, hi: f64) -> Option<(usize, usize)> {
    // centre i at origin + (i + 0.5) g  ⇒ i ≥ (lo - origin)/g - 0.5
    let first = ((lo - origin) / g - 0.5).ceil().max(0.0);
    let last = ((hi - origin) / g - 0.5).floor().min(n as f64 - 1.0);
    if first > last || last < 0.0 || first.is_nan() || last.is_nan() {
        None
    } else {
        Some((first as usize, last as usize))
    }
}
