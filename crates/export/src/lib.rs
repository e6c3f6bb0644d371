//! Output writers: everything a user looks at.
//!
//! The last stage of the `dexcut` library's pipeline
//! (job → stock (`dexel`, `mesh`) + program (`nc`) → motion (`schedule`) →
//! sweep (`dexel`) → loads (`cutting`) → outputs (`export`)): plain data in,
//! files out.
//!
//! This crate is deliberately independent of the simulation crates: its inputs
//! are the plain data structs defined here ([`Grid`], [`HeightField`],
//! [`ScalarMap`], [`Series`], [`Report`]). The `dexcut` library converts
//! simulation results into them.
//!
//! | writer | output |
//! | --- | --- |
//! | [`write_heat_map_png`] | PNG heat map with colour bar (µm) and scale bar (mm) |
//! | [`write_stock_glb`] | binary glTF of the stock's top surface with vertex colours |
//! | [`write_column_grid`] | `columns.json` and one NumPy `.npy` array per quantity (the default column output) |
//! | [`write_column_csv`] | one CSV row per grid column (on request) |
//! | [`write_csv_records`] | a header and numbered records, formatted on rayon's threads, written in order |
//! | [`NpyTableWriter`] | a table of named columns as `.npy` arrays and a JSON description (steps in binary form) |
//! | [`write_report_html`] | one self-contained offline HTML report (SVG plots, PNG maps, WebGL 3D view) |
//!
//! Every `write_*` function has a pure counterpart returning bytes or a string
//! (`heat_map_png_bytes`, `stock_glb_bytes`, `column_csv_bytes`,
//! `report_html`) and writes through [`atomic`], so a failed run never leaves a
//! half-written file.
//!
//! Architecture invariants:
//! * no function panics on empty input: empty series, 0×0 grids and all-NaN
//!   maps still give valid (if empty-looking) files;
//! * no text rendering depends on system fonts (PNG text uses the built-in
//!   5×8 bitmap font of the private `font` module); the HTML report loads
//!   nothing from the network.
#![warn(missing_docs)]

pub mod atomic;
mod b64;
mod color;
mod csv_out;
mod font;
mod glb;
mod heatmap;
mod html;
mod npy;
mod npy_table;
mod svg;
mod ticks;

use std::path::{Path, PathBuf};

pub use color::{ColorScale, Palette};
pub use csv_out::{column_csv_bytes, write_column_csv, write_csv_records};
pub use glb::{stock_glb_bytes, write_stock_glb, write_stock_glb_with, GlbOptions, GlbStats};
pub use heatmap::{
    heat_map_image, heat_map_png_bytes, write_heat_map_png, HeatMapLayout, HeatMapStyle, NAN_RGBA,
};
pub use html::{
    heat_map_png_framed, report_html, write_report_html, HotSpot, MapFrame, ProgramExcerpt, Report,
    ReportImage, SummaryRow,
};
pub use npy::{
    npy_bytes, npy_header, parse_npy, read_column_grid_info, read_grid_array_f32,
    write_column_grid, write_npy, ColumnGridInfo, ColumnGridWriter, GridArray, GridArrayInfo, Npy,
    NpyArray, NpyType, NpyValues, COLUMN_GRID_FORMAT, COLUMN_GRID_JSON,
};
pub use npy_table::{
    npy_table_json, read_npy_table_column, read_npy_table_info, NpyTableWriter, TableColumn,
    TableColumnInfo, TableInfo, NPY_TABLE_FORMAT,
};
pub use svg::{PlotGroup, MAX_PLOT_POINTS};

/// A regular grid of vertical columns (dexels) in the machine XY plane.
///
/// Column `(ix, iy)` has its centre at
/// `(x0_mm + ix · spacing_mm, y0_mm + iy · spacing_mm)`; values of a grid are
/// stored row-major with `ix` fastest: `index = iy · nx + ix`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Columns along X.
    pub nx: usize,
    /// Columns along Y.
    pub ny: usize,
    /// X of the centre of column `ix = 0` \[mm\].
    pub x0_mm: f64,
    /// Y of the centre of column `iy = 0` \[mm\].
    pub y0_mm: f64,
    /// Distance between neighbouring column centres \[mm\].
    pub spacing_mm: f64,
}

impl Grid {
    /// Number of columns, `nx · ny`.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// True when the grid has no columns.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Centre X of column `ix` \[mm\].
    pub fn x_mm(&self, ix: usize) -> f64 {
        self.x0_mm + ix as f64 * self.spacing_mm
    }

    /// Centre Y of row `iy` \[mm\].
    pub fn y_mm(&self, iy: usize) -> f64 {
        self.y0_mm + iy as f64 * self.spacing_mm
    }

    /// Index of column `(ix, iy)` into a value vector.
    pub fn index(&self, ix: usize, iy: usize) -> usize {
        iy * self.nx + ix
    }

    /// Check that `values` has one entry per column.
    pub fn check_len(&self, what: &str, got: usize) -> Result<(), Error> {
        if got == self.len() {
            Ok(())
        } else {
            Err(Error::Shape {
                what: what.to_string(),
                nx: self.nx,
                ny: self.ny,
                expected: self.len(),
                got,
            })
        }
    }
}

/// Top surface of the stock: one height per column.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightField {
    /// The column grid.
    pub grid: Grid,
    /// Top of the material in each column \[mm\]; NaN where the column holds no material.
    pub z_mm: Vec<f32>,
}

/// One scalar per column (an error map, removed depth, last-move index, ...).
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarMap {
    /// The column grid.
    pub grid: Grid,
    /// Value per column; NaN where there is none.
    pub values: Vec<f32>,
    /// Unit label shown next to the colour bar, e.g. `"µm"`.
    pub unit: String,
}

/// Smallest and largest finite value of `values`, or `None` when there is none.
pub(crate) fn finite_range(values: &[f32]) -> Option<(f32, f32)> {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// A time series, e.g. MRR over machining time.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend name, e.g. `"before"` or `"re-timed"`.
    pub name: String,
    /// Unit of `values`, e.g. `"mm³/s"`.
    pub unit: String,
    /// Sample times \[s\], non-decreasing.
    pub t_s: Vec<f64>,
    /// Sample values in `unit`; NaN marks a gap. Same length as `t_s`
    /// (samples beyond the shorter of the two are ignored).
    pub values: Vec<f64>,
}

/// Errors of the export writers. Every error that concerns a file names it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A value vector does not match its grid.
    #[error("{what}: a {nx}×{ny} grid needs {expected} values, got {got}")]
    Shape {
        /// Which input.
        what: String,
        /// Grid size along X.
        nx: usize,
        /// Grid size along Y.
        ny: usize,
        /// Expected number of values.
        expected: usize,
        /// Actual number of values.
        got: usize,
    },
    /// An input is unusable for another reason.
    #[error("{what}: {reason}")]
    Invalid {
        /// Which input.
        what: String,
        /// Why.
        reason: String,
    },
    /// PNG encoding failed.
    #[error("cannot encode PNG: {0}")]
    Png(#[from] image::ImageError),
    /// glTF JSON serialisation failed.
    #[error("cannot serialise glTF: {0}")]
    Gltf(String),
    /// CSV writing failed.
    #[error("cannot write CSV: {0}")]
    Csv(#[from] csv::Error),
    /// The file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The output file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A file could not be read back.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Producing the content of a file failed.
    #[error("{}: {source}", path.display())]
    AtPath {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        source: Box<Error>,
    },
}

impl Error {
    /// Attach the output path to an error from a pure rendering function.
    pub(crate) fn at(self, path: &Path) -> Error {
        match self {
            e @ (Error::Io { .. } | Error::Read { .. } | Error::AtPath { .. }) => e,
            e => Error::AtPath {
                path: path.to_path_buf(),
                source: Box::new(e),
            },
        }
    }
}

/// Escape `s` for HTML/SVG text and double-quoted attribute values.
pub(crate) fn escape_html(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Render with `render`, then write the bytes atomically to `path`; errors name `path`.
pub(crate) fn render_and_write<T: AsRef<[u8]>>(
    path: &Path,
    render: impl FnOnce() -> Result<T, Error>,
) -> Result<(), Error> {
    let bytes = render().map_err(|e| e.at(path))?;
    atomic::write_bytes(path, bytes.as_ref()).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}
