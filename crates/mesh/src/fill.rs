//! Rasterising a mesh onto the vertical lines through the column centres.
//!
//! Each triangle that is not vertical is projected onto XY and tested against
//! the column centres under its footprint with three edge functions. A centre
//! exactly on an edge counts for the triangle on the edge's left only when the
//! edge points down (−y), or along +x when horizontal: the half-open rule of
//! rasterisers, which equals moving the centre by an infinitesimal (1, δ). To
//! make the two triangles of a shared edge agree exactly, the edge function is
//! always evaluated from the lexicographically smaller end point and negated
//! as needed, so both get the same number with opposite signs. A centre on a
//! vertex has all incident edge functions exactly zero, so the tie rule alone
//! decides and exactly one triangle of a fan around the vertex takes it.
//! Triangles facing up and down are treated alike (made counter-clockwise in
//! XY first), so a column grazing a silhouette gets both or neither crossing.

use dexel::{Grid, Stock};
use rayon::prelude::*;

use crate::solid::check_indices;
use crate::triangle::Prepared;
use crate::{MeshError, TriMesh};

/// What [`stock_from_mesh`] found while filling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FillStats {
    /// Triangles skipped because they are vertical (no area seen from above).
    pub vertical_triangles: usize,
    /// Crossings of column lines with the mesh, all columns.
    pub crossings: usize,
    /// Columns whose crossings did not balance (as many entries as exits):
    /// an open or degenerate mesh. Their crossings were paired in z order and
    /// an odd last one dropped.
    pub unpaired_columns: usize,
    /// Columns where more than one shell was entered at once or a shell was
    /// exited before being entered: overlapping shells (filled as their
    /// union) or a void shell wound like an outer one ([`crate::validate_solid`]
    /// fixes the latter).
    pub overlap_columns: usize,
    /// The mesh faced inward (negative signed volume) and was filled as if flipped.
    pub flipped: bool,
}

/// Fill a dexel stock from `mesh` on a grid of `spacing_mm` covering the
/// mesh's XY bounds ([`Grid::covering`]); see [`stock_on_grid`].
pub fn stock_from_mesh(mesh: &TriMesh, spacing_mm: f64) -> Result<(Stock, FillStats), MeshError> {
    check_indices(mesh)?;
    let Some((lo, hi)) = mesh.bounds_mm() else {
        return Err(crate::SolidError::Empty.into());
    };
    fill_checked(
        mesh,
        Grid::covering(lo[0], lo[1], hi[0], hi[1], spacing_mm)?,
    )
}

/// Fill a dexel stock from `mesh` on `grid` (which may be larger or smaller
/// than the mesh). Each column holds the material between where its vertical
/// line through the column centre enters the mesh (down-facing triangle) and
/// leaves it (up-facing triangle), so undercuts and voids give several
/// intervals. Heights are computed in f64 (mm) and stored as f32.
///
/// The mesh should be a closed solid ([`crate::validate_solid`]); anything
/// else still fills without panicking, with problems counted in [`FillStats`].
pub fn stock_on_grid(mesh: &TriMesh, grid: Grid) -> Result<(Stock, FillStats), MeshError> {
    check_indices(mesh)?;
    fill_checked(mesh, grid)
}

/// [`stock_on_grid`] for a mesh that passed `check_indices`.
fn fill_checked(mesh: &TriMesh, grid: Grid) -> Result<(Stock, FillStats), MeshError> {
    let flipped = mesh.signed_volume_mm3() < 0.0;
    let raster = Raster::new(mesh, &grid, flipped);
    let rows: Vec<RowIntervals> = (0..grid.ny)
        .into_par_iter()
        .map_init(Vec::new, |crossings, iy| {
            raster.row_crossings(iy, crossings);
            RowIntervals::from_crossings(grid.nx, crossings)
        })
        .collect();
    let mut stats = FillStats {
        vertical_triangles: raster.vertical_triangles,
        flipped,
        ..FillStats::default()
    };
    for row in &rows {
        stats.crossings += row.crossings;
        stats.unpaired_columns += row.unpaired_columns;
        stats.overlap_columns += row.overlap_columns;
    }
    let stock = Stock::from_columns(grid, |ix, iy, out| {
        let row = &rows[iy];
        out.extend_from_slice(
            &row.intervals[row.offsets[ix] as usize..row.offsets[ix + 1] as usize],
        );
    })?;
    Ok((stock, stats))
}

/// Highest crossing of each column's centre line with `mesh` on `grid`, mm,
/// row-major; NaN where the line misses the mesh. For a design model this is
/// its top surface as seen by the tool.
pub fn top_heights(mesh: &TriMesh, grid: &Grid) -> Result<Vec<f32>, MeshError> {
    check_indices(mesh)?;
    let raster = Raster::new(mesh, grid, false);
    let mut tops = vec![f32::NAN; grid.len()];
    tops.par_chunks_mut(grid.nx.max(1))
        .enumerate()
        .for_each_init(Vec::new, |crossings, (iy, row)| {
            raster.row_crossings(iy, crossings);
            for c in crossings.iter() {
                // Rounding to f32 is monotone, so the max of the rounded
                // heights is the rounded max; `!(>=)` replaces the NaN start.
                let (top, z) = (&mut row[c.ix as usize], c.z as f32);
                if !(*top >= z) {
                    *top = z;
                }
            }
        });
    Ok(tops)
}

/// One crossing of a column line with a triangle.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    ix: u32,
    /// The line enters material here (the triangle faces down).
    enter: bool,
    z: f64,
}

/// Triangles binned by the grid rows their footprint spans (CSR).
struct Raster<'g> {
    grid: &'g Grid,
    triangles: Vec<Prepared>,
    row_start: Vec<u32>,
    row_triangles: Vec<u32>,
    vertical_triangles: usize,
}

impl<'g> Raster<'g> {
    fn new(mesh: &TriMesh, grid: &'g Grid, flipped: bool) -> Raster<'g> {
        let mut triangles = Vec::with_capacity(mesh.triangles.len());
        let mut rows = Vec::with_capacity(mesh.triangles.len());
        let mut vertical_triangles = 0;
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            let Some(p) = Prepared::new(a, b, c, flipped) else {
                vertical_triangles += 1;
                continue;
            };
            let (y_lo, y_hi) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
            if let Some(r) = grid.iy_range(y_lo, y_hi) {
                triangles.push(p);
                rows.push(r);
            }
        }
        let mut row_start = vec![0u32; grid.ny + 1];
        for &(first, last) in &rows {
            for iy in first..=last {
                row_start[iy + 1] += 1;
            }
        }
        for iy in 0..grid.ny {
            row_start[iy + 1] += row_start[iy];
        }
        let mut next = row_start.clone();
        let mut row_triangles = vec![0u32; row_start[grid.ny] as usize];
        for (ti, &(first, last)) in rows.iter().enumerate() {
            for iy in first..=last {
                row_triangles[next[iy] as usize] = ti as u32;
                next[iy] += 1;
            }
        }
        Raster {
            grid,
            triangles,
            row_start,
            row_triangles,
            vertical_triangles,
        }
    }

    /// All crossings of the column lines of row `iy`, unsorted.
    fn row_crossings(&self, iy: usize, out: &mut Vec<Crossing>) {
        out.clear();
        let y = self.grid.y_mm(iy);
        let bin = &self.row_triangles[self.row_start[iy] as usize..self.row_start[iy + 1] as usize];
        for &ti in bin {
            let t = &self.triangles[ti as usize];
            // The footprint's x span on this row, widened by a column against rounding;
            // the edge functions decide exactly.
            let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for x in t.edges.iter().filter_map(|e| e.x_at(y)) {
                x_lo = x_lo.min(x);
                x_hi = x_hi.max(x);
            }
            if x_lo > x_hi {
                continue;
            }
            let g = self.grid.spacing_mm;
            let Some((first, last)) = self
                .grid
                .ix_range((x_lo - g).max(t.x_range[0]), (x_hi + g).min(t.x_range[1]))
            else {
                continue;
            };
            for ix in first..=last {
                let x = self.grid.x_mm(ix);
                if t.edges.iter().all(|e| e.admits(x, y)) {
                    out.push(Crossing {
                        ix: ix as u32,
                        enter: t.enter,
                        z: t.z_at(x, y),
                    });
                }
            }
        }
    }
}

/// One row's material intervals, CSR by column.
struct RowIntervals {
    offsets: Vec<u32>,
    intervals: Vec<[f32; 2]>,
    crossings: usize,
    unpaired_columns: usize,
    overlap_columns: usize,
}

impl RowIntervals {
    /// Sort the crossings per column and turn them into intervals where the
    /// winding number (entries minus exits below) is positive.
    fn from_crossings(nx: usize, crossings: &mut [Crossing]) -> RowIntervals {
        // By column, then z, entries first at equal z so touching solids merge
        // and a grazed silhouette gives an empty interval.
        crossings.sort_unstable_by(|a, b| {
            a.ix.cmp(&b.ix)
                .then(a.z.total_cmp(&b.z))
                .then(b.enter.cmp(&a.enter))
        });
        let mut row = RowIntervals {
            offsets: vec![0; nx + 1],
            intervals: Vec::new(),
            crossings: crossings.len(),
            unpaired_columns: 0,
            overlap_columns: 0,
        };
        let mut done = 0;
        for column in crossings.chunk_by(|a, b| a.ix == b.ix) {
            let ix = column[0].ix as usize;
            row.offsets[done + 1..=ix].fill(row.intervals.len() as u32);
            let start = row.intervals.len();
            let (mut winding, mut lo, mut overlap) = (0i32, 0.0, false);
            for c in column {
                if c.enter {
                    if winding == 0 {
                        lo = c.z;
                    }
                    winding += 1;
                } else {
                    winding -= 1;
                    if winding == 0 {
                        push_merged(&mut row.intervals, start, lo, c.z);
                    }
                }
                overlap |= !(0..=1).contains(&winding);
            }
            if winding != 0 {
                // Unbalanced: pair in z order, drop an odd last crossing.
                row.intervals.truncate(start);
                for pair in column.chunks_exact(2) {
                    push_merged(&mut row.intervals, start, pair[0].z, pair[1].z);
                }
                row.unpaired_columns += 1;
            } else if overlap {
                row.overlap_columns += 1;
            }
            row.offsets[ix + 1] = row.intervals.len() as u32;
            done = ix + 1;
        }
        row.offsets[done + 1..].fill(row.intervals.len() as u32);
        row
    }
}

/// Append [lo, hi] (f64 mm) as f32 to the column whose intervals start at
/// `start`, dropping empty ones and merging with a touching predecessor.
fn push_merged(intervals: &mut Vec<[f32; 2]>, start: usize, lo: f64, hi: f64) {
    let (lo, hi) = (lo as f32, hi as f32);
    if hi <= lo {
        return;
    }
    let in_column = intervals.len() > start;
    match intervals.last_mut() {
        Some(last) if in_column && last[1] >= lo => last[1] = last[1].max(hi),
        _ => intervals.push([lo, hi]),
    }
}
