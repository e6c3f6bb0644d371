//! Building the initial stock from the job, after checking it fits in memory.

use anyhow::{Context, Result};
use dexel::{Grid, Stock};

use crate::job::{Job, StockKind};

/// Refuse a grid whose columns would not fit in the memory this process may use.
fn check_fits(grid: &Grid, what: &str) -> Result<()> {
    crate::bounds::check_columns(grid.nx, grid.ny, grid.spacing_mm, what)
}

/// The job's stock.
pub fn build(job: &Job) -> Result<Stock> {
    let s = &job.stock;
    let what = format!("{}: [stock]", job.name);
    match s.kind {
        StockKind::Box => {
            let (min, max) = (s.min.unwrap_or_default(), s.max.unwrap_or_default());
            check_fits(
                &Grid::covering(min[0], min[1], max[0], max[1], s.grid)?,
                &what,
            )?;
            Ok(Stock::new_box(min, max, s.grid)?)
        }
        StockKind::Cylinder => {
            let ([cx, cy], r) = (s.center.unwrap_or_default(), s.radius.unwrap_or_default());
            check_fits(
                &Grid::covering(cx - r, cy - r, cx + r, cy + r, s.grid)?,
                &what,
            )?;
            Ok(Stock::new_cylinder(
                [cx, cy],
                r,
                s.z_min.unwrap_or_default(),
                s.z_max.unwrap_or_default(),
                s.grid,
            )?)
        }
        StockKind::Mesh => {
            let path = job.resolve(s.path.as_deref().unwrap_or(std::path::Path::new("")));
            crate::bounds::check_input_file(&path, "stock mesh", crate::bounds::MAX_MESH_BYTES)?;
            let (mesh, _info) = mesh::load_solid(&path)?;
            let (lo, hi) = mesh
                .bounds_mm()
                .with_context(|| format!("{}: the stock mesh is empty", path.display()))?;
            let extent_mm = (hi[0] - lo[0]).min(hi[1] - lo[1]);
            if s.grid * 4.0 > extent_mm {
                anyhow::bail!(
                    "{what}: grid ({} mm) is too coarse for the mesh's {extent_mm} mm XY extent: at least 4 columns across are needed",
                    s.grid
                );
            }
            let grid = Grid::covering(lo[0], lo[1], hi[0], hi[1], s.grid)?;
            check_fits(&grid, &what)?;
            let (stock, _stats) = mesh::stock_on_grid(&mesh, grid)?;
            Ok(stock)
        }
    }
}
