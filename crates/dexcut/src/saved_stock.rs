//! The stock a run leaves, saved losslessly and read again: `--save-stock`
//! writes it into `DIR/stock/`, and `[stock] kind = "saved"`, `path =
//! "DIR/stock"` starts a job from it (docs/guide/job.md, "Saved stock").
//!
//! The folder holds
//!
//! * `stock.json`: `format` ("dexcut saved stock"), `version` (1), `units`
//!   ("mm"), the grid (`x0_mm`, `y0_mm`, `spacing_mm`, `nx`, `ny`: column
//!   `(ix, iy)` stands at `x0 + (ix + ½)·spacing`, `y0 + (iy + ½)·spacing`),
//!   the number of columns and intervals, and the material volume, mm³;
//! * `counts.npy`: `<u4`, shape `(ny, nx)`: the intervals of each column, row-major;
//! * `intervals.npy`: `<f4`, shape `(n, 2)`: every column's intervals
//!   `[lo, hi]`, mm, lowest first, the columns in the order of `counts`;
//! * `stock.stl`: the material's closed surface ([`mesh::StockSurface`]), for a
//!   CAM system to import as in-process stock.
//!
//! The heights are the stock's own f32 values, so a stock read back is the
//! stock written, column for column and bit for bit. Reading checks the
//! format and version, the shapes, that every interval is finite, ascending
//! and apart from the next, and the volume.

use std::path::{Path, PathBuf};

use dexel::{Grid, Stock};
use export::{NpyArray, NpyValues};
use serde::{Deserialize, Serialize};

use crate::error::{fail, Error, Result};

/// `format` of stock.json.
pub const FORMAT: &str = "dexcut saved stock";
/// `version` of stock.json this build writes and reads.
pub const VERSION: u32 = 1;
/// The folder's files.
pub const JSON: &str = "stock.json";
const COUNTS: &str = "counts.npy";
const INTERVALS: &str = "intervals.npy";
/// The closed surface of the stock.
pub const STL: &str = "stock.stl";
/// Largest array file read, bytes (the memory checks bound the grid first).
const MAX_ARRAY_BYTES: u64 = 1 << 36;

/// stock.json.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SavedStockDoc {
    /// [`FORMAT`].
    pub format: String,
    /// [`VERSION`].
    pub version: u32,
    /// Lengths' unit: "mm".
    pub units: String,
    /// The column grid.
    pub grid: SavedGrid,
    /// Columns, `nx · ny`.
    pub columns: usize,
    /// Intervals in all (rows of intervals.npy).
    pub intervals: usize,
    /// Material volume, mm³ (as [`Stock::volume_mm3`] sums it).
    pub volume_mm3: f64,
    /// Triangles of stock.stl.
    pub stl_triangles: usize,
    /// Where intervals of neighbouring columns touched along an edge and
    /// stock.stl separates them by four f32 steps ([`mesh::StockSurface`]).
    pub stl_separated: usize,
}

/// The grid of stock.json.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SavedGrid {
    /// Left edge of the covered area, mm.
    pub x0_mm: f64,
    /// Bottom edge of the covered area, mm.
    pub y0_mm: f64,
    /// Column spacing, mm.
    pub spacing_mm: f64,
    /// Columns along X.
    pub nx: usize,
    /// Columns along Y.
    pub ny: usize,
}

impl SavedGrid {
    fn grid(&self) -> Grid {
        Grid {
            x0_mm: self.x0_mm,
            y0_mm: self.y0_mm,
            spacing_mm: self.spacing_mm,
            nx: self.nx,
            ny: self.ny,
        }
    }
}

/// Write `stock` (every row of its grid) into the folder `dir` (made if
/// missing): its arrays, stock.json and stock.stl, each atomically.
pub fn write(dir: &Path, stock: &Stock) -> Result<SavedStockDoc> {
    let g = *stock.grid();
    if stock.rows() != (0..g.ny) {
        fail!(request, "--save-stock needs every column of the stock at once; a stock swept band by band (larger than the memory budget) is not saved: use a coarser grid or a larger --memory-budget-mb");
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io("cannot create", dir, e))?;
    let mut counts = Vec::with_capacity(g.len());
    let mut flat = Vec::with_capacity(2 * g.len());
    for c in stock.columns() {
        counts.push(c.interval_count() as u32);
        flat.extend(c.intervals().flatten());
    }
    export::write_npy(&dir.join(COUNTS), &[g.ny, g.nx], NpyValues::U32(&counts))?;
    export::write_npy(
        &dir.join(INTERVALS),
        &[flat.len() / 2, 2],
        NpyValues::F32(&flat),
    )?;
    let surface = mesh::StockSurface::of(stock);
    let stl = dir.join(STL);
    let mut triangles = 0;
    export::atomic::write_file(&stl, |mut w| {
        triangles = surface.write_stl(&mut w)?;
        Ok(())
    })
    .map_err(|e| Error::io("cannot write", &stl, e))?;
    let doc = SavedStockDoc {
        format: FORMAT.into(),
        version: VERSION,
        units: "mm".into(),
        grid: SavedGrid {
            x0_mm: g.x0_mm,
            y0_mm: g.y0_mm,
            spacing_mm: g.spacing_mm,
            nx: g.nx,
            ny: g.ny,
        },
        columns: g.len(),
        intervals: flat.len() / 2,
        volume_mm3: stock.volume_mm3(),
        stl_triangles: triangles,
        stl_separated: surface.separated,
    };
    let json = dir.join(JSON);
    let text = serde_json::to_string_pretty(&doc)
        .map_err(|e| Error::run(format!("cannot encode {}: {e}", json.display())))?;
    export::atomic::write_bytes(&json, text.as_bytes())
        .map_err(|e| Error::io("cannot write", &json, e))?;
    Ok(doc)
}

/// Read the array `name` of the saved stock in `dir`.
fn read_array(dir: &Path, name: &str) -> Result<export::Npy> {
    let path = dir.join(name);
    crate::bounds::check_input_file(&path, "saved stock array", MAX_ARRAY_BYTES)?;
    let bytes = std::fs::read(&path).map_err(|e| Error::io("cannot read", &path, e))?;
    export::parse_npy(&bytes).map_err(|e| Error::job(format!("{}: {e}", path.display())))
}

/// Read stock.json of the saved stock in the folder `dir`, checked (its
/// format, version, units and grid); `what` names the job key in messages.
pub fn read_doc(dir: &Path, what: &str) -> Result<SavedStockDoc> {
    let json = dir.join(JSON);
    if !json.is_file() {
        fail!(job, "{what}: {} is not a saved stock folder (no {JSON}; `dexcut simulate --save-stock` or `optimize --save-stock` writes one into DIR/stock)", dir.display());
    }
    let text = crate::bounds::read_text(&json, "saved stock", crate::bounds::MAX_JOB_BYTES)?;
    let doc: SavedStockDoc = serde_json::from_str(&text).map_err(|e| {
        Error::job(format!(
            "{}:{}:{}: not a saved stock of version {VERSION}: {e}",
            json.display(),
            e.line(),
            e.column()
        ))
    })?;
    let bad = |m: String| Error::job(format!("{what}: {}: {m}", json.display()));
    if doc.format != FORMAT || doc.version != VERSION || doc.units != "mm" {
        return Err(bad(format!(
            "format {:?} version {} in {:?}; this build reads {FORMAT:?} version {VERSION} in \"mm\"",
            doc.format, doc.version, doc.units
        )));
    }
    let g = doc.grid;
    if !(g.spacing_mm > 0.0
        && g.spacing_mm.is_finite()
        && g.x0_mm.is_finite()
        && g.y0_mm.is_finite())
        || g.nx == 0
        || g.ny == 0
        || g.nx.checked_mul(g.ny) != Some(doc.columns)
    {
        return Err(bad(format!(
            "a grid of {}×{} columns at {} mm from ({}, {}) does not hold {} columns",
            g.nx, g.ny, g.spacing_mm, g.x0_mm, g.y0_mm, doc.columns
        )));
    }
    Ok(doc)
}

/// Read the saved stock in the folder `dir` (written by [`write`]), checked;
/// `what` names the job key in messages.
pub fn read(dir: &Path, what: &str) -> Result<(Stock, SavedStockDoc)> {
    let doc = read_doc(dir, what)?;
    let json = dir.join(JSON);
    let bad = |m: String| Error::job(format!("{what}: {}: {m}", json.display()));
    let g = doc.grid;
    crate::bounds::check_columns(g.nx, g.ny, g.spacing_mm, what)?;
    let counts = read_array(dir, COUNTS)?;
    let NpyArray::U32(counts_v) = &counts.data else {
        return Err(bad(format!("{COUNTS} must hold <u4 values")));
    };
    if counts.shape != [g.ny, g.nx] {
        return Err(bad(format!(
            "{COUNTS} has shape {:?}, the grid is ({}, {})",
            counts.shape, g.ny, g.nx
        )));
    }
    let intervals = read_array(dir, INTERVALS)?;
    let NpyArray::F32(flat) = &intervals.data else {
        return Err(bad(format!("{INTERVALS} must hold <f4 values")));
    };
    let total: u64 = counts_v.iter().map(|&c| u64::from(c)).sum();
    if intervals.shape != [doc.intervals, 2] || total != doc.intervals as u64 {
        return Err(bad(format!(
            "{INTERVALS} has shape {:?} and {COUNTS} counts {total} intervals; {JSON} says {}",
            intervals.shape, doc.intervals
        )));
    }
    // Where each column's intervals begin, and their check.
    let mut starts = Vec::with_capacity(counts_v.len() + 1);
    let mut at = 0usize;
    for (i, &c) in counts_v.iter().enumerate() {
        starts.push(at);
        let column = &flat[2 * at..2 * (at + c as usize)];
        let mut below = f32::NEG_INFINITY;
        for iv in column.chunks_exact(2) {
            let (lo, hi) = (iv[0], iv[1]);
            if !(lo.is_finite() && hi.is_finite() && below < lo && lo < hi) {
                return Err(bad(format!(
                    "column {} (ix {}, iy {}) holds the interval [{lo}, {hi}] mm: intervals must be finite, ascending and apart",
                    i,
                    i % g.nx,
                    i / g.nx
                )));
            }
            below = hi;
        }
        at += c as usize;
    }
    starts.push(at);
    let grid = g.grid();
    let stock = Stock::from_columns(grid, |ix, iy, out| {
        let i = iy * grid.nx + ix;
        out.extend(
            flat[2 * starts[i]..2 * starts[i + 1]]
                .chunks_exact(2)
                .map(|c| [c[0], c[1]]),
        );
    })?;
    let volume = stock.volume_mm3();
    if volume != doc.volume_mm3 {
        return Err(bad(format!(
            "its columns hold {volume} mm³, {JSON} says {} mm³: the files are not of one stock",
            doc.volume_mm3
        )));
    }
    Ok((stock, doc))
}

/// The files of the saved stock in `dir` that a run reads (its inputs).
pub fn input_files(dir: &Path) -> Vec<PathBuf> {
    [JSON, COUNTS, INTERVALS].map(|n| dir.join(n)).to_vec()
}
