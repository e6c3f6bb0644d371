//! Building the initial stock from the job, after checking it fits in memory;
//! a box or cylinder that does not fit the memory budget is made band of rows
//! by band of rows instead ([`Tiling`], ARCHITECTURE.md "Large stocks").

use std::ops::Range;

use crate::error::{fail, Error, Result};
use dexel::{Grid, Solid, Stock};

use crate::input::job::{Job, StockSpec};

/// Refuse a grid whose columns would not fit in the memory this process may use.
fn check_fits(grid: &Grid, what: &str) -> Result<()> {
    crate::bounds::check_columns(grid.nx, grid.ny, grid.spacing_mm, what)
}

/// A stock too large for the memory budget, held band of rows by band of
/// rows: `band_rows` grid rows at a time (a multiple of the sweep's strip
/// rows, so the banded record equals the whole stock's bit for bit).
#[derive(Clone, Debug)]
pub struct Tiling {
    solid: Solid,
    /// The whole stock's grid.
    pub grid: Grid,
    /// Grid rows per band.
    pub band_rows: usize,
    /// The memory budget the bands were sized for, bytes.
    pub budget_bytes: f64,
}

impl Tiling {
    /// The bands' row ranges, in order.
    pub fn bands(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        (0..self.grid.ny)
            .step_by(self.band_rows)
            .map(|r0| r0..(r0 + self.band_rows).min(self.grid.ny))
    }

    /// The initial stock's grid rows `rows`, made in the memory of `reuse`
    /// (a band no longer needed) when given.
    pub fn band(&self, rows: Range<usize>, reuse: Option<Stock>) -> Result<Stock> {
        Ok(self
            .solid
            .stock_in_rows(self.grid.spacing_mm, Some(rows), reuse)?)
    }

    /// A stock holding no row of the grid (what a tiled run keeps as its stock).
    pub fn empty(&self) -> Result<Stock> {
        self.band(0..0, None)
    }
}

/// The job's stock as a closed form of its grid (`dexel::Solid`): a box or a
/// cylinder; `None` for a mesh, whose columns are only known once filled.
pub fn solid(spec: &StockSpec) -> Option<Solid> {
    match *spec {
        StockSpec::Box { min, max, .. } => Some(Solid::Box { min, max }),
        StockSpec::Cylinder {
            center,
            radius,
            z_min,
            z_max,
            ..
        } => Some(Solid::Cylinder {
            center_xy: center,
            radius_mm: radius,
            z_lo: z_min,
            z_hi: z_max,
        }),
        StockSpec::Mesh { .. } | StockSpec::Saved { .. } => None,
    }
}

/// The memory budget of the stock, bytes: `budget_mb` (`--memory-budget-mb`)
/// or by default the share of the memory this process may use that the
/// checks allow, never more than that share.
pub fn budget_bytes(budget_mb: Option<f64>) -> Result<f64> {
    let room = crate::bounds::usable_memory_bytes();
    match budget_mb {
        None => Ok(room),
        Some(mb) if mb > 0.0 && mb.is_finite() => Ok((mb * 1e6).min(room)),
        Some(mb) => fail!(
            job,
            "--memory-budget-mb must be a positive number of MB, got {mb}"
        ),
    }
}

/// The job's stock, whole when its columns fit `budget_bytes`; else, for a
/// box or a cylinder, an empty stock on the whole grid and the [`Tiling`]
/// that makes it band by band. Refused when even one band of the sweep's
/// strip rows does not fit.
pub fn build_within(job: &Job, budget_bytes: f64) -> Result<(Stock, Option<Tiling>)> {
    let what = format!("{}: [stock]", job.name);
    let Some(solid) = solid(&job.stock) else {
        return Ok((build(job)?, None));
    };
    let grid = solid.grid(job.stock.grid_mm())?;
    let row_bytes = grid.nx as f64 * crate::bounds::BYTES_PER_COLUMN;
    if grid.ny as f64 * row_bytes <= budget_bytes {
        return Ok((build(job)?, None));
    }
    let strip = dexel::SweepOptions::default().strip_rows;
    let band_rows = ((budget_bytes / row_bytes) as usize / strip) * strip;
    if band_rows == 0 {
        fail!(
            limits,
            "{what}: {}×{} columns at grid {} mm: even one band of {strip} rows needs about {:.0} MB of memory, more than the {:.0} MB this process may use (available memory, cgroup memory.max and ulimit, or --memory-budget-mb); use a coarser grid",
            grid.nx,
            grid.ny,
            grid.spacing_mm,
            strip as f64 * row_bytes / 1e6,
            budget_bytes / 1e6
        );
    }
    let tiling = Tiling {
        solid,
        grid,
        band_rows,
        budget_bytes,
    };
    Ok((tiling.empty()?, Some(tiling)))
}

/// The job's stock, refused when it does not fit in memory.
pub fn build(job: &Job) -> Result<Stock> {
    let s = &job.stock;
    let what = format!("{}: [stock]", job.name);
    if let Some(solid) = solid(s) {
        check_fits(&solid.grid(s.grid_mm())?, &what)?;
        return Ok(solid.stock_in_rows(s.grid_mm(), None, None)?);
    }
    let (path, grid) = match s {
        StockSpec::Mesh { path, grid } => (path, grid),
        StockSpec::Saved { path, .. } => {
            return Ok(crate::saved_stock::read(&job.resolve(path), &what)?.0);
        }
        StockSpec::Box { .. } | StockSpec::Cylinder { .. } => {
            unreachable!("a box or a cylinder is a solid")
        }
    };
    let grid_mm = *grid;
    let path = job.resolve(path);
    crate::bounds::check_input_file(&path, "stock mesh", crate::bounds::MAX_MESH_BYTES)?;
    let (mesh, _info) = mesh::load_solid(&path)?;
    let (lo, hi) = mesh
        .bounds_mm()
        .ok_or_else(|| Error::job(format!("{}: the stock mesh is empty", path.display())))?;
    let extent_mm = (hi[0] - lo[0]).min(hi[1] - lo[1]);
    if grid_mm * 4.0 > extent_mm {
        fail!(job,
                "{what}: grid ({} mm) is too coarse for the mesh's {extent_mm:.3} mm XY extent: at least 4 columns across are needed",
                grid_mm
            );
    }
    let grid = Grid::covering(lo[0], lo[1], hi[0], hi[1], grid_mm)?;
    check_fits(&grid, &what)?;
    let (stock, stats) = mesh::stock_on_grid(&mesh, grid)?;
    // A self-intersecting mesh has overlapping shells (or unbalanced
    // crossings), and its signed volume counts the overlap twice.
    let (filled, signed) = (stock.volume_mm3(), mesh.signed_volume_mm3().abs());
    let area_mm2: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| nalgebra::Vector3::from(mesh.vertices[i as usize]));
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum();
    let discretisation_mm3 = area_mm2 * grid_mm;
    if stats.overlap_columns > 0
        || stats.unpaired_columns > 0
        || (filled - signed).abs() > discretisation_mm3 + 1e-9 * signed
    {
        fail!(job,
                "{what}: the stock mesh {} intersects itself or overlaps ({} columns with overlapping shells, {} unbalanced; filled {filled:.1} mm³ against {signed:.1} mm³ enclosed): a stock must be one clean solid",
                path.display(),
                stats.overlap_columns,
                stats.unpaired_columns
            );
    }
    Ok(stock)
}
