//! Building the initial stock from the job, after checking it fits in memory.

use anyhow::{Context, Result};
use dexel::{Grid, Stock};

use crate::job::{Job, StockSpec};

/// Refuse a grid whose columns would not fit in the memory this process may use.
fn check_fits(grid: &Grid, what: &str) -> Result<()> {
    crate::bounds::check_columns(grid.nx, grid.ny, grid.spacing_mm, what)
}

/// The job's stock.
pub fn build(job: &Job) -> Result<Stock> {
    let s = &job.stock;
    let what = format!("{}: [stock]", job.name);
    match s {
        &StockSpec::Box { min, max, grid } => {
            check_fits(
                &Grid::covering(min[0], min[1], max[0], max[1], grid)?,
                &what,
            )?;
            Ok(Stock::new_box(min, max, grid)?)
        }
        &StockSpec::Cylinder {
            center: [cx, cy],
            radius: r,
            z_min,
            z_max,
            grid,
        } => {
            check_fits(
                &Grid::covering(cx - r, cy - r, cx + r, cy + r, grid)?,
                &what,
            )?;
            Ok(Stock::new_cylinder([cx, cy], r, z_min, z_max, grid)?)
        }
        StockSpec::Mesh { path, grid } => {
            let grid_mm = *grid;
            let path = job.resolve(path);
            crate::bounds::check_input_file(&path, "stock mesh", crate::bounds::MAX_MESH_BYTES)?;
            let (mesh, _info) = mesh::load_solid(&path)?;
            let (lo, hi) = mesh
                .bounds_mm()
                .with_context(|| format!("{}: the stock mesh is empty", path.display()))?;
            let extent_mm = (hi[0] - lo[0]).min(hi[1] - lo[1]);
            if grid_mm * 4.0 > extent_mm {
                anyhow::bail!(
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
                anyhow::bail!(
                    "{what}: the stock mesh {} intersects itself or overlaps ({} columns with overlapping shells, {} unbalanced; filled {filled:.1} mm³ against {signed:.1} mm³ enclosed): a stock must be one clean solid",
                    path.display(),
                    stats.overlap_columns,
                    stats.unpaired_columns
                );
            }
            Ok(stock)
        }
    }
}
