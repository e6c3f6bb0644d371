//! Building the initial stock from the job, after checking it fits in memory.

use anyhow::{Context, Result};
use dexel::{Grid, Stock};

use crate::job::{Job, StockKind};

/// Bytes of memory the machine can still give, from /proc/meminfo (Linux),
/// else a conservative 4 GiB.
pub fn available_memory_bytes() -> f64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(4.0 * 1024.0 * 1024.0 * 1024.0, |kb| kb * 1024.0)
}

/// Refuse a grid that would need more than half the available memory
/// (the sweep needs room for a second copy in `optimize`).
fn check_fits(grid: &Grid, what: &str) -> Result<()> {
    Stock::check_memory(grid, 0.5 * available_memory_bytes()).with_context(|| {
        format!(
            "{what}: {}×{} columns at grid {} mm do not fit in memory",
            grid.nx, grid.ny, grid.spacing_mm
        )
    })
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
            let (mesh, _info) = mesh::load_solid(&path)?;
            let (lo, hi) = mesh
                .bounds_mm()
                .with_context(|| format!("{}: the stock mesh is empty", path.display()))?;
            let grid = Grid::covering(lo[0], lo[1], hi[0], hi[1], s.grid)?;
            check_fits(&grid, &what)?;
            let (stock, _stats) = mesh::stock_on_grid(&mesh, grid)?;
            Ok(stock)
        }
    }
}
