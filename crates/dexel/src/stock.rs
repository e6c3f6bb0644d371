//! Z-dexel stock: per column a sorted list of material intervals.

use crate::top::Top;
use crate::{Error, Grid};

/// Marker for "no step has cut this column".
pub const NEVER_CUT: u32 = u32::MAX;

/// The intervals below the top one of the columns of one row that hold more
/// than one: per such column its index in the row and those intervals,
/// ascending and disjoint, sorted by column index. Empty (no allocation) for
/// the usual row of single intervals.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct RowBelow(Vec<(u32, Vec<[f32; 2]>)>);

impl RowBelow {
    /// The intervals below the top one of column `ix`, ascending.
    #[inline]
    pub(crate) fn of(&self, ix: usize) -> &[[f32; 2]] {
        if self.0.is_empty() {
            return &[];
        }
        match self.0.binary_search_by_key(&(ix as u32), |e| e.0) {
            Ok(k) => &self.0[k].1,
            Err(_) => &[],
        }
    }

    /// Take the highest interval below the top one of column `ix` (its new
    /// top once the top one is cut away), `None` where there is none.
    #[inline]
    pub(crate) fn pop(&mut self, ix: usize) -> Option<[f32; 2]> {
        if self.0.is_empty() {
            return None;
        }
        let k = self.0.binary_search_by_key(&(ix as u32), |e| e.0).ok()?;
        let below = &mut self.0[k].1;
        let iv = below.pop();
        if below.is_empty() {
            self.0.remove(k);
        }
        iv
    }
}

/// One column's material: sorted, disjoint intervals, read from a stock
/// ([`Stock::column`]) or a closed form ([`Solid::column`]): the top
/// interval and the intervals below it. An empty column has no interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column<'a> {
    top: Top,
    below: &'a [[f32; 2]],
}

impl<'a> Column<'a> {
    /// A column with no material.
    pub const EMPTY: Column<'static> = Column {
        top: Top::EMPTY,
        below: &[],
    };

    /// Column holding exactly `intervals` (sorted ascending, disjoint, lo < hi each).
    pub fn from_intervals(intervals: &'a [[f32; 2]]) -> Column<'a> {
        match intervals {
            [] => Column::EMPTY,
            [below @ .., top] => Column {
                top: Top {
                    lo: top[0],
                    hi: top[1],
                },
                below,
            },
        }
    }

    /// No material in the column.
    #[inline]
    pub fn is_empty(&self) -> bool {
        !(self.top.lo < self.top.hi)
    }

    /// Highest material z, or `None` for an empty column.
    #[inline]
    pub fn top(&self) -> Option<f32> {
        (!self.is_empty()).then_some(self.top.hi)
    }

    /// Highest material z, NaN for an empty column (a height field's "no
    /// material", as [`Stock::top_heights`] gives it).
    #[inline]
    pub fn top_or_nan(&self) -> f32 {
        self.top().unwrap_or(f32::NAN)
    }

    /// Total material length, mm (f64 sum, lowest interval first).
    pub fn length_mm(&self) -> f64 {
        let mut intervals = self.intervals();
        let Some([lo, hi]) = intervals.next() else {
            return 0.0;
        };
        let mut sum = (hi - lo) as f64;
        for [lo, hi] in intervals {
            sum += (hi - lo) as f64;
        }
        sum
    }

    /// Number of material intervals.
    pub fn interval_count(&self) -> usize {
        if self.is_empty() {
            0
        } else {
            1 + self.below.len()
        }
    }

    /// All intervals, lowest first.
    pub fn intervals(&self) -> impl Iterator<Item = [f32; 2]> + 'a {
        let top = (!self.is_empty()).then_some([self.top.lo, self.top.hi]);
        self.below.iter().copied().chain(top)
    }
}

/// The stock: a grid of columns plus, per column, the step that last cut it.
///
/// A stock holds either every row of its grid or one band of rows
/// (`rows()`, a tile band of a stock too large for memory): the grid stays
/// the whole stock's, so a band's columns stand exactly where the whole
/// stock's do, and sweeping the bands one after the other with one
/// [`crate::sweep::Sweep`] gives the whole stock's columns and removal record.
#[derive(Clone, Debug)]
pub struct Stock {
    grid: Grid,
    /// First grid row held.
    row0: usize,
    /// Each column's top interval's top (its `hi`), row-major: −∞ where the
    /// column is empty.
    pub(crate) tops: Vec<f32>,
    /// The bottoms of the top intervals (their `lo`): one for all, or one a column.
    pub(crate) bottoms: Bottoms,
    /// Per row held, the intervals below the top ones (undercuts, voids).
    pub(crate) below: Vec<RowBelow>,
    pub(crate) last_cut: Vec<u32>,
}

/// The bottoms of a stock's top intervals. A stock made of a box
/// or a vertical cylinder, or of any columns that hold one interval each
/// with the same bottom, keeps that bottom once: a column costs its top and
/// its last cut, 8 B. A cut never raises a bottom (it removes the column's
/// material at and above a height, `sweep::strip::cut_above`), and with no
/// intervals below the top ones it only empties a column (top −∞), so the
/// stock stays uniform through every sweep. Other stocks (a mesh stock's
/// undercuts, bottoms that differ) keep one a column.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Bottoms {
    /// Every non-empty column's top interval starts here, and no column
    /// holds an interval below its top one.
    Uniform(f32),
    /// Each column's own (+∞ where empty), row-major.
    Columns(Vec<f32>),
}

impl Bottoms {
    /// The bottoms of the columns whose tops are `tops` and whose bottoms
    /// `lo_bits` holds (f32 bits; a column's with top −∞ is not read), rows'
    /// intervals below the tops `below`: [`Bottoms::Uniform`] where no
    /// column holds an interval below its top and every non-empty column's
    /// bottom is the same bits, else [`Bottoms::Columns`] (in the memory of
    /// `reuse`'s where it keeps one a column).
    fn of(tops: &[f32], lo_bits: &[u32], below: &[RowBelow], reuse: Bottoms) -> Bottoms {
        let mut filled = tops
            .iter()
            .zip(lo_bits)
            .filter(|&(&hi, _)| hi != Top::EMPTY.hi)
            .map(|(_, &lo)| lo);
        let first = filled.next().unwrap_or(Top::EMPTY.lo.to_bits());
        if below.iter().all(|b| b.0.is_empty()) && filled.all(|lo| lo == first) {
            return Bottoms::Uniform(f32::from_bits(first));
        }
        let mut lo = match reuse {
            Bottoms::Columns(v) => v,
            Bottoms::Uniform(_) => Vec::new(),
        };
        lo.clear();
        lo.extend(lo_bits.iter().map(|&b| f32::from_bits(b)));
        Bottoms::Columns(lo)
    }
}

/// A stock's [`Bottoms`] as the sweep kernel's strip cuts them: the one
/// bottom, or the strip's columns'.
pub(crate) enum BottomsMut<'a> {
    Uniform(f32),
    Columns(&'a mut [f32]),
}

impl BottomsMut<'_> {
    /// The pieces of its rows `len` columns long from the front, and the rest.
    pub(crate) fn split_at_mut(self, len: usize) -> (Self, Self) {
        match self {
            BottomsMut::Uniform(lo) => (BottomsMut::Uniform(lo), BottomsMut::Uniform(lo)),
            BottomsMut::Columns(c) => {
                let (a, b) = c.split_at_mut(len);
                (BottomsMut::Columns(a), BottomsMut::Columns(b))
            }
        }
    }
}

/// Refuse grids that would need more than this share of physical memory.
pub(crate) const DEFAULT_MEMORY_LIMIT_BYTES: f64 = 16.0e9;

impl Stock {
    /// Check that a grid fits in `limit_bytes` before allocating it.
    pub fn check_memory(grid: &Grid, limit_bytes: f64) -> Result<(), Error> {
        let bytes = grid.memory_bytes();
        if bytes > limit_bytes {
            return Err(Error::TooLarge {
                columns: grid.len() as f64,
                bytes,
            });
        }
        Ok(())
    }

    /// Stock whose columns are produced by `fill(ix, iy, out)`, which pushes
    /// the column's intervals into `out` (sorted ascending, disjoint).
    /// Columns are filled in parallel.
    pub fn from_columns<F>(grid: Grid, fill: F) -> Result<Stock, Error>
    where
        F: Fn(usize, usize, &mut Vec<[f32; 2]>) + Sync,
    {
        Stock::from_columns_in_rows(grid, 0..grid.ny, fill, None)
    }

    /// The band of grid rows `rows` of the stock whose columns `fill` makes
    /// (see [`Stock::from_columns`]; `iy` is the grid row). With `reuse`, a
    /// stock no longer needed (the previous band), its memory holds the new
    /// one: no fresh pages are mapped and faulted in for each band.
    pub fn from_columns_in_rows<F>(
        grid: Grid,
        rows: std::ops::Range<usize>,
        fill: F,
        reuse: Option<Stock>,
    ) -> Result<Stock, Error>
    where
        F: Fn(usize, usize, &mut Vec<[f32; 2]>) + Sync,
    {
        use rayon::prelude::*;
        if !(rows.start <= rows.end && rows.end <= grid.ny) {
            return Err(Error::InvalidParameter(format!(
                "rows {}..{} of a grid of {} rows",
                rows.start, rows.end, grid.ny
            )));
        }
        let band = Grid {
            ny: rows.len(),
            ..grid
        };
        Stock::check_memory(&band, DEFAULT_MEMORY_LIMIT_BYTES)?;
        let (mut tops, bottoms, mut below, mut last_cut) = reuse.map_or(
            (
                Vec::new(),
                Bottoms::Uniform(f32::INFINITY),
                Vec::new(),
                Vec::new(),
            ),
            |s| (s.tops, s.bottoms, s.below, s.last_cut),
        );
        tops.clear();
        tops.resize(band.len(), Top::EMPTY.hi);
        below.clear();
        below.resize(rows.len(), RowBelow::default());
        // The bottoms are filled into the last-cut marks' memory (as f32
        // bits) and kept once where they are all one: no column's bottom is
        // held beside the stock to find out.
        last_cut.clear();
        last_cut.resize(band.len(), Top::EMPTY.lo.to_bits());
        let nx = grid.nx.max(1);
        tops.par_chunks_mut(nx)
            .zip(last_cut.par_chunks_mut(nx))
            .zip(below.par_iter_mut())
            .enumerate()
            .for_each_init(Vec::new, |buf, (j, ((row, row_lo), row_below))| {
                for (ix, (hi, lo)) in row.iter_mut().zip(row_lo).enumerate() {
                    buf.clear();
                    fill(ix, rows.start + j, buf);
                    if let [lower @ .., top] = buf.as_slice() {
                        (*lo, *hi) = (top[0].to_bits(), top[1]);
                        if !lower.is_empty() {
                            row_below.0.push((ix as u32, lower.to_vec()));
                        }
                    }
                }
            });
        let bottoms = Bottoms::of(&tops, &last_cut, &below, bottoms);
        last_cut.fill(NEVER_CUT);
        Ok(Stock {
            grid,
            row0: rows.start,
            tops,
            bottoms,
            below,
            last_cut,
        })
    }

    /// Axis-aligned box `[min, max]` (mm); the grid covers its XY extent.
    pub fn new_box(min: [f64; 3], max: [f64; 3], spacing_mm: f64) -> Result<Stock, Error> {
        Stock::new_box_in_rows(min, max, spacing_mm, None, None)
    }

    /// [`Stock::new_box`], only the grid rows `rows` (all with `None`), in
    /// the memory of `reuse` (see [`Stock::from_columns_in_rows`]).
    pub fn new_box_in_rows(
        min: [f64; 3],
        max: [f64; 3],
        spacing_mm: f64,
        rows: Option<std::ops::Range<usize>>,
        reuse: Option<Stock>,
    ) -> Result<Stock, Error> {
        Solid::Box { min, max }.stock_in_rows(spacing_mm, rows, reuse)
    }

    /// Vertical cylinder with axis through `(cx, cy)`, radius `r`, z from `z_lo` to `z_hi`.
    /// A column belongs to it when its centre lies inside the circle.
    pub fn new_cylinder(
        center_xy: [f64; 2],
        radius_mm: f64,
        z_lo: f64,
        z_hi: f64,
        spacing_mm: f64,
    ) -> Result<Stock, Error> {
        Stock::new_cylinder_in_rows(center_xy, radius_mm, z_lo, z_hi, spacing_mm, None, None)
    }

    /// [`Stock::new_cylinder`], only the grid rows `rows` (all with `None`),
    /// in the memory of `reuse` (see [`Stock::from_columns_in_rows`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new_cylinder_in_rows(
        center_xy: [f64; 2],
        radius_mm: f64,
        z_lo: f64,
        z_hi: f64,
        spacing_mm: f64,
        rows: Option<std::ops::Range<usize>>,
        reuse: Option<Stock>,
    ) -> Result<Stock, Error> {
        Solid::Cylinder {
            center_xy,
            radius_mm,
            z_lo,
            z_hi,
        }
        .stock_in_rows(spacing_mm, rows, reuse)
    }

    /// The grid the columns stand on (the whole stock's, also for a band).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The grid rows this stock holds (all of them unless it is a band).
    pub fn rows(&self) -> std::ops::Range<usize> {
        self.row0..self.row0 + self.tops.len() / self.grid.nx.max(1)
    }

    /// Column at `(ix, iy)` (`iy` a grid row this stock holds).
    pub fn column(&self, ix: usize, iy: usize) -> Column<'_> {
        self.column_at((iy - self.row0) * self.grid.nx + ix)
    }

    /// The column at index `i` of [`Stock::columns`].
    pub fn column_at(&self, i: usize) -> Column<'_> {
        let nx = self.grid.nx.max(1);
        Column {
            top: self.top_at(i),
            below: self.below[i / nx].of(i % nx),
        }
    }

    /// The top interval of the column at index `i` ([`Top::EMPTY`] where
    /// the column is empty, whatever its bottoms keep).
    #[inline]
    fn top_at(&self, i: usize) -> Top {
        let hi = self.tops[i];
        match &self.bottoms {
            Bottoms::Uniform(_) if hi == Top::EMPTY.hi => Top::EMPTY,
            &Bottoms::Uniform(lo) => Top { lo, hi },
            Bottoms::Columns(lo) => Top { lo: lo[i], hi },
        }
    }

    /// The columns held, row-major (of the rows in [`Stock::rows`]).
    pub fn columns(&self) -> impl ExactSizeIterator<Item = Column<'_>> + '_ {
        (0..self.tops.len()).map(|i| self.column_at(i))
    }

    /// Per column held, the index of the step that last removed material
    /// there ([`NEVER_CUT`] if none).
    pub fn last_cut(&self) -> &[u32] {
        &self.last_cut
    }

    /// Forget which steps cut the columns (every mark [`NEVER_CUT`]): a
    /// stock handed from one run to the next (an operation of a job on the
    /// stock the previous one left) starts with no step of the new run's.
    pub fn clear_cuts(&mut self) {
        self.last_cut.fill(NEVER_CUT);
    }

    /// The top, bottoms, intervals below and last-cut marks of the columns,
    /// for the sweep kernel to cut.
    pub(crate) fn parts_mut(
        &mut self,
    ) -> (&mut [f32], BottomsMut<'_>, &mut [RowBelow], &mut [u32]) {
        let bottoms = match &mut self.bottoms {
            Bottoms::Uniform(lo) => BottomsMut::Uniform(*lo),
            Bottoms::Columns(lo) => BottomsMut::Columns(lo),
        };
        (&mut self.tops, bottoms, &mut self.below, &mut self.last_cut)
    }

    /// Bytes its columns hold: tops, bottoms (none where they are one,
    /// [`Bottoms::Uniform`]), last cuts and the intervals below the tops (4 B
    /// of column index and 8 B an interval; the side table's own vectors and
    /// their headers are not counted, so a stock with undercuts holds more).
    pub fn memory_bytes(&self) -> usize {
        let f = std::mem::size_of::<f32>();
        let bottoms = match &self.bottoms {
            Bottoms::Uniform(_) => 0,
            Bottoms::Columns(lo) => lo.len() * f,
        };
        let below: usize = (self.below.iter().flat_map(|r| &r.0))
            .map(|(_, v)| 4 + v.len() * 2 * f)
            .sum();
        self.tops.len() * f + bottoms + self.last_cut.len() * std::mem::size_of::<u32>() + below
    }

    /// Material volume held, mm³ (f64, summed row by row in a fixed order).
    pub fn volume_mm3(&self) -> f64 {
        self.add_row_lengths_mm(self.rows(), 0.0) * self.grid.cell_area_mm2()
    }

    /// `sum` plus the material length of each grid row in `rows` (rows this
    /// stock holds), row by row in order, mm: carried from band to band it
    /// gives the whole stock's [`Stock::volume_mm3`] (times the cell area) bit
    /// for bit.
    pub fn add_row_lengths_mm(&self, rows: std::ops::Range<usize>, sum: f64) -> f64 {
        let nx = self.grid.nx.max(1);
        (rows.start - self.row0..rows.end - self.row0)
            .map(|j| {
                (j * nx..(j + 1) * nx)
                    .map(|i| self.column_at(i).length_mm())
                    .sum::<f64>()
            })
            .fold(sum, |a, r| a + r)
    }

    /// Top surface height per column held (NaN where empty), row-major.
    pub fn top_heights(&self) -> Vec<f32> {
        self.top_heights_at(0..self.tops.len())
    }

    /// [`Stock::top_heights`] of the columns held at the indices `at` (of
    /// [`Stock::columns`]): a block of rows of the height field.
    pub fn top_heights_at(&self, at: std::ops::Range<usize>) -> Vec<f32> {
        at.map(|i| self.top_or_nan_at(i)).collect()
    }

    /// The top of the column at index `i` of [`Stock::columns`], NaN where
    /// it holds no material (read from the top interval alone).
    #[inline]
    pub fn top_or_nan_at(&self, i: usize) -> f32 {
        let top = self.top_at(i);
        if top.lo < top.hi {
            top.hi
        } else {
            f32::NAN
        }
    }
}

/// A stock whose columns are a closed form of the grid: a box or a vertical
/// cylinder. Its columns can be made again at any time (a band of rows, or
/// the whole stock in the memory of a swept one) and asked one by one
/// ([`Solid::column`]) without holding the stock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Solid {
    /// Axis-aligned box `[min, max]`, mm; the grid covers its XY extent.
    Box {
        /// Lowest corner, mm.
        min: [f64; 3],
        /// Highest corner, mm.
        max: [f64; 3],
    },
    /// Vertical cylinder: a column belongs to it when its centre lies inside
    /// the circle; the grid covers the circle's square.
    Cylinder {
        /// Axis position (x, y), mm.
        center_xy: [f64; 2],
        /// Radius, mm.
        radius_mm: f64,
        /// Bottom, mm.
        z_lo: f64,
        /// Top, mm.
        z_hi: f64,
    },
}

impl Solid {
    /// The grid the solid's stock stands on at `spacing_mm`, after checking
    /// the solid's sizes.
    pub fn grid(&self, spacing_mm: f64) -> Result<Grid, Error> {
        match *self {
            Solid::Box { min, max } => {
                if !(max[2] > min[2]) {
                    return Err(Error::InvalidParameter(format!(
                        "box height must be positive, got z {}..{}",
                        min[2], max[2]
                    )));
                }
                Grid::covering(min[0], min[1], max[0], max[1], spacing_mm)
            }
            Solid::Cylinder {
                center_xy: [cx, cy],
                radius_mm,
                z_lo,
                z_hi,
            } => {
                if !(radius_mm > 0.0) || !(z_hi > z_lo) {
                    return Err(Error::InvalidParameter(format!(
                        "cylinder needs a positive radius and height, got r {radius_mm}, z {z_lo}..{z_hi}"
                    )));
                }
                Grid::covering(
                    cx - radius_mm,
                    cy - radius_mm,
                    cx + radius_mm,
                    cy + radius_mm,
                    spacing_mm,
                )
            }
        }
    }

    /// The material interval of the column at `(ix, iy)` of `grid` (the
    /// solid's grid), `None` where the column is empty of it.
    #[inline]
    fn interval(&self, grid: &Grid, ix: usize, iy: usize) -> Option<[f32; 2]> {
        match *self {
            Solid::Box { min, max } => Some([min[2] as f32, max[2] as f32]),
            Solid::Cylinder {
                center_xy: [cx, cy],
                radius_mm,
                z_lo,
                z_hi,
            } => {
                let (dx, dy) = (grid.x_mm(ix) - cx, grid.y_mm(iy) - cy);
                (dx * dx + dy * dy <= radius_mm * radius_mm).then_some([z_lo as f32, z_hi as f32])
            }
        }
    }

    /// The column at `(ix, iy)` of `grid` (the solid's grid) as the solid's
    /// stock holds it (one interval at most).
    pub fn column(&self, grid: &Grid, ix: usize, iy: usize) -> Column<'static> {
        match self.interval(grid, ix, iy) {
            Some([lo, hi]) => Column {
                top: Top { lo, hi },
                below: &[],
            },
            None => Column::EMPTY,
        }
    }

    /// The solid's stock at `spacing_mm`, only the grid rows `rows` (all
    /// with `None`), in the memory of `reuse` (see
    /// [`Stock::from_columns_in_rows`]).
    pub fn stock_in_rows(
        &self,
        spacing_mm: f64,
        rows: Option<std::ops::Range<usize>>,
        reuse: Option<Stock>,
    ) -> Result<Stock, Error> {
        let grid = self.grid(spacing_mm)?;
        Stock::from_columns_in_rows(
            grid,
            rows.unwrap_or(0..grid.ny),
            |ix, iy, out| out.extend(self.interval(&grid, ix, iy)),
            reuse,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bands of rows of a box and a cylinder, put end to end, are the whole
    /// stock: the same columns and, summed band after band, the same volume bit for bit.
    #[test]
    fn bands_of_rows_make_the_whole_stock() {
        let box_band = |rows, reuse| {
            Stock::new_box_in_rows([0.0, 0.0, -1.0], [7.0, 5.0, 2.0], 0.1, rows, reuse)
        };
        let cyl_band =
            |rows, reuse| Stock::new_cylinder_in_rows([1.0, 2.0], 3.3, 0.5, 4.0, 0.1, rows, reuse);
        for make in [&box_band as &dyn Fn(_, _) -> _, &cyl_band] {
            let whole: Stock = make(None, None).unwrap();
            let ny = whole.grid().ny;
            assert_eq!(whole.rows(), 0..ny);
            let mut columns: Vec<Vec<[f32; 2]>> = Vec::new();
            let mut length_mm = 0.0;
            // Each band in the memory of the one before (the last one shorter).
            let mut previous: Option<Stock> = None;
            for r0 in (0..ny).step_by(13) {
                let rows = r0..(r0 + 13).min(ny);
                let band: Stock = make(Some(rows.clone()), previous.take()).unwrap();
                assert_eq!(band.rows(), rows);
                assert_eq!(band.column(4, rows.start), whole.column(4, rows.start));
                columns.extend(band.columns().map(|c| c.intervals().collect()));
                length_mm = band.add_row_lengths_mm(rows, length_mm);
                previous = Some(band);
            }
            let whole_columns: Vec<Vec<[f32; 2]>> =
                whole.columns().map(|c| c.intervals().collect()).collect();
            assert_eq!(columns, whole_columns);
            assert_eq!(
                (length_mm * whole.grid().cell_area_mm2()).to_bits(),
                whole.volume_mm3().to_bits()
            );
            let empty: Stock = make(Some(3..3), None).unwrap();
            assert!(empty.columns().len() == 0 && empty.volume_mm3() == 0.0);
        }
    }

    /// Columns of none to three intervals (undercuts, voids) kept as 8 B top
    /// intervals with the intervals below them apart: each reads back as it
    /// was filled, its top and its length (summed lowest interval first, as
    /// a column of inline intervals summed them) bit for bit; the stock's
    /// bytes are the grid's estimate plus 4 B and 8 B an interval for each
    /// column with intervals below its top.
    #[test]
    fn columns_of_several_intervals_read_back_whole() {
        let grid = Grid::covering(0.0, 0.0, 1.0, 0.7, 0.1).unwrap();
        let fill = |ix: usize, iy: usize, out: &mut Vec<[f32; 2]>| {
            for k in 0..(ix + 2 * iy) % 4 {
                let z = k as f32 * 3.0 + 0.1 * ix as f32;
                out.push([z, z + 1.0 + 0.01 * iy as f32]);
            }
        };
        let stock = Stock::from_columns(grid, fill).unwrap();
        let mut buf = Vec::new();
        let mut counts = [0; 4];
        let mut below_bytes = 0;
        for iy in 0..grid.ny {
            for ix in 0..grid.nx {
                buf.clear();
                fill(ix, iy, &mut buf);
                counts[buf.len()] += 1;
                if buf.len() > 1 {
                    below_bytes += 4 + 8 * (buf.len() - 1);
                }
                let c = stock.column(ix, iy);
                assert_eq!(c.intervals().collect::<Vec<_>>(), buf);
                assert_eq!(c, Column::from_intervals(&buf));
                assert_eq!(c.interval_count(), buf.len());
                let top = buf.last().map_or(f32::NAN, |iv| iv[1]);
                assert_eq!(c.top_or_nan().to_bits(), top.to_bits());
                assert_eq!(
                    stock.top_or_nan_at(iy * grid.nx + ix).to_bits(),
                    top.to_bits()
                );
                let length = match buf.split_first() {
                    None => 0.0,
                    Some((first, rest)) => {
                        let mut sum = (first[1] - first[0]) as f64;
                        for iv in rest {
                            sum += (iv[1] - iv[0]) as f64;
                        }
                        sum
                    }
                };
                assert_eq!(c.length_mm().to_bits(), length.to_bits());
            }
        }
        assert!(counts.iter().all(|&n| n > 5), "{counts:?}");
        assert_eq!(
            stock.memory_bytes() as f64,
            grid.memory_bytes() + below_bytes as f64
        );
    }

    /// A solid's columns asked one by one are its stock's, made whole or in
    /// bands of rows in the memory of another stock: a box, and a cylinder
    /// (columns in and out of the circle).
    #[test]
    fn a_solids_columns_are_its_stocks() {
        for solid in [
            Solid::Box {
                min: [-1.0, 2.0, -3.0],
                max: [4.3, 7.1, 0.5],
            },
            Solid::Cylinder {
                center_xy: [1.0, -2.0],
                radius_mm: 3.3,
                z_lo: -2.0,
                z_hi: 1.25,
            },
        ] {
            let stock = solid.stock_in_rows(0.1, None, None).unwrap();
            let grid = *stock.grid();
            assert_eq!(grid, solid.grid(0.1).unwrap());
            let mut empty = 0;
            for iy in 0..grid.ny {
                for ix in 0..grid.nx {
                    assert_eq!(solid.column(&grid, ix, iy), stock.column(ix, iy));
                    empty += usize::from(stock.column(ix, iy).is_empty());
                }
            }
            let band = solid
                .stock_in_rows(0.1, Some(10..20), Some(stock.clone()))
                .unwrap();
            assert_eq!(band.rows(), 10..20);
            assert!(band
                .columns()
                .eq(stock.columns().skip(10 * grid.nx).take(10 * grid.nx)));
            match solid {
                Solid::Box { .. } => assert_eq!(empty, 0),
                Solid::Cylinder { .. } => assert!(empty > 100, "{empty} columns outside"),
            }
        }
    }
}
