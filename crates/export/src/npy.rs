//! Per-column values as a compact binary grid: one NumPy `.npy` array per
//! quantity plus `columns.json`, the grid geometry and the list of arrays.
//!
//! `.npy` format version 1.0 (numpy.org, "A simple file format for NumPy
//! arrays"): the magic `\x93NUMPY`, version bytes `1 0`, a little-endian u16
//! header length, then an ASCII Python dict literal
//! `{'descr': '<f4', 'fortran_order': False, 'shape': (ny, nx), }` padded with
//! spaces and ended by `\n` so that the data starts at a multiple of 64 bytes,
//! then the values, little-endian, C order (row-major, `ix` fastest: row `iy`
//! of the array is the grid row at `y0_mm + iy · spacing_mm`).
//! `numpy.load("top_mm.npy")` reads it as an `(ny, nx)` array.

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::{Error, Grid};

/// Values of one array to write, borrowed.
#[derive(Clone, Copy, Debug)]
pub enum NpyValues<'a> {
    /// `<f4`: little-endian float32.
    F32(&'a [f32]),
    /// `<i4`: little-endian int32.
    I32(&'a [i32]),
}

impl NpyValues<'_> {
    /// NumPy type string of the values.
    pub fn descr(&self) -> &'static str {
        match self {
            NpyValues::F32(_) => "<f4",
            NpyValues::I32(_) => "<i4",
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            NpyValues::F32(v) => v.len(),
            NpyValues::I32(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Stream the values, little-endian, in blocks (no copy of the whole array).
    fn write_data(&self, out: &mut dyn Write) -> std::io::Result<()> {
        const BLOCK: usize = 16 * 1024;
        let mut buf = Vec::with_capacity(4 * BLOCK);
        macro_rules! blocks {
            ($v:expr) => {
                for chunk in $v.chunks(BLOCK) {
                    buf.clear();
                    for x in chunk {
                        buf.extend_from_slice(&x.to_le_bytes());
                    }
                    out.write_all(&buf)?;
                }
            };
        }
        match self {
            NpyValues::F32(v) => blocks!(v),
            NpyValues::I32(v) => blocks!(v),
        }
        Ok(())
    }
}

/// An array read back from a `.npy` file.
#[derive(Clone, Debug, PartialEq)]
pub enum NpyArray {
    /// `<f4` values.
    F32(Vec<f32>),
    /// `<i4` values.
    I32(Vec<i32>),
}

/// A parsed `.npy` file: its shape and values (C order).
#[derive(Clone, Debug, PartialEq)]
pub struct Npy {
    /// Array shape, e.g. `[ny, nx]`.
    pub shape: Vec<usize>,
    /// The values.
    pub data: NpyArray,
}

const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// Data starts at a multiple of this (what NumPy itself writes).
const ALIGN: usize = 64;

/// The `.npy` v1.0 header (magic, version, length, padded dict) for `descr` and `shape`.
pub fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let dims = match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {dims}, }}");
    // 6 magic + 2 version + 2 length, then the dict and its '\n'.
    let unpadded = 10 + dict.len() + 1;
    dict.extend(std::iter::repeat_n(
        ' ',
        unpadded.next_multiple_of(ALIGN) - unpadded,
    ));
    dict.push('\n');
    let mut out = Vec::with_capacity(10 + dict.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

fn check_shape(shape: &[usize], values: &NpyValues) -> Result<(), Error> {
    let n: usize = shape.iter().product();
    if n == values.len() {
        Ok(())
    } else {
        Err(Error::Invalid {
            what: "npy array".into(),
            reason: format!("shape {shape:?} needs {n} values, got {}", values.len()),
        })
    }
}

/// The bytes of a `.npy` file holding `values` with `shape`.
pub fn npy_bytes(shape: &[usize], values: NpyValues) -> Result<Vec<u8>, Error> {
    check_shape(shape, &values)?;
    let mut out = npy_header(values.descr(), shape);
    values
        .write_data(&mut out)
        .expect("writing to a Vec cannot fail");
    Ok(out)
}

/// Write `values` with `shape` to the `.npy` file `path`, streamed and atomically.
pub fn write_npy(path: &Path, shape: &[usize], values: NpyValues) -> Result<(), Error> {
    check_shape(shape, &values).map_err(|e| e.at(path))?;
    crate::atomic::write_file(path, |w| {
        w.write_all(&npy_header(values.descr(), shape))?;
        values.write_data(w)
    })
    .map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn bad(reason: impl Into<String>) -> Error {
    Error::Invalid {
        what: "npy file".into(),
        reason: reason.into(),
    }
}

/// The value of `key` in the header dict (the text after `'key':` up to the
/// next top-level comma or the closing brace).
fn dict_value<'a>(dict: &'a str, key: &str) -> Result<&'a str, Error> {
    let pat = format!("'{key}':");
    let start = dict
        .find(&pat)
        .ok_or_else(|| bad(format!("header has no '{key}'")))?
        + pat.len();
    let rest = dict[start..].trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')').map(|i| i + 1)
    } else {
        rest.find([',', '}'])
    }
    .ok_or_else(|| bad(format!("header value of '{key}' does not end")))?;
    Ok(rest[..end].trim())
}

/// Parse a `.npy` file of version 1.0–3.0 holding `<f4` or `<i4` values in C order.
pub fn parse_npy(bytes: &[u8]) -> Result<Npy, Error> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err(bad("not a .npy file (no \\x93NUMPY magic)"));
    }
    let (header_len, dict_start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10usize),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(bad(format!("unsupported .npy version {v}"))),
    };
    let data_start = dict_start
        .checked_add(header_len)
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| bad("header runs past the end of the file"))?;
    let dict = std::str::from_utf8(&bytes[dict_start..data_start])
        .map_err(|_| bad("header is not text"))?;
    let descr = dict_value(dict, "descr")?.trim_matches(['\'', '"']);
    if dict_value(dict, "fortran_order")? != "False" {
        return Err(bad("Fortran-ordered arrays are not read"));
    }
    let dims = dict_value(dict, "shape")?;
    let inner = dims
        .strip_prefix('(')
        .and_then(|d| d.strip_suffix(')'))
        .ok_or_else(|| bad(format!("shape {dims} is not a tuple")))?;
    let shape = inner
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| d.parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| bad(format!("shape {dims} is not a tuple of sizes")))?;
    let n = shape
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or_else(|| bad(format!("shape {dims} overflows")))?;
    let data = &bytes[data_start..];
    if Some(data.len()) != n.checked_mul(4) {
        return Err(bad(format!(
            "shape {dims} of 4-byte values needs {} data bytes, the file has {}",
            n.saturating_mul(4),
            data.len()
        )));
    }
    let words = data.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]);
    let data = match descr {
        "<f4" => NpyArray::F32(words.map(f32::from_le_bytes).collect()),
        "<i4" => NpyArray::I32(words.map(i32::from_le_bytes).collect()),
        other => return Err(bad(format!("dtype {other} is not read (only <f4 and <i4)"))),
    };
    Ok(Npy { shape, data })
}

/// Name of the grid description written beside the arrays.
pub const COLUMN_GRID_JSON: &str = "columns.json";

/// `format` value of `columns.json`.
pub const COLUMN_GRID_FORMAT: &str = "dexcut column grid";

/// One array of a column grid to write.
#[derive(Clone, Copy, Debug)]
pub struct GridArray<'a> {
    /// Quantity name; the file is `<name>.npy`.
    pub name: &'a str,
    /// Unit of the values (`"mm"`, `"µm"`, `"1"` for counts and indices).
    pub unit: &'a str,
    /// What a value means, and what marks "no value" (NaN, −1).
    pub meaning: &'a str,
    /// One value per column, row-major with `ix` fastest.
    pub values: NpyValues<'a>,
}

/// One entry of `columns.json`'s `arrays`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridArrayInfo {
    /// Quantity name.
    pub name: String,
    /// File name beside `columns.json`.
    pub file: String,
    /// NumPy type string: `<f4` or `<i4`.
    pub dtype: String,
    /// Unit of the values.
    pub unit: String,
    /// What a value means.
    pub meaning: String,
}

/// `columns.json`: the geometry of a column grid and its arrays.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ColumnGridInfo {
    /// Always [`COLUMN_GRID_FORMAT`].
    pub format: String,
    /// Layout version (1).
    pub version: u32,
    /// Length unit of the geometry.
    pub units: String,
    /// Columns along X (the arrays' second axis).
    pub nx: usize,
    /// Columns along Y (the arrays' first axis).
    pub ny: usize,
    /// X of the centre of column (0, 0) \[mm\].
    pub x0_mm: f64,
    /// Y of the centre of column (0, 0) \[mm\].
    pub y0_mm: f64,
    /// Distance between neighbouring column centres \[mm\].
    pub spacing_mm: f64,
    /// How values map to columns.
    pub layout: String,
    /// The arrays, one `.npy` file each.
    pub arrays: Vec<GridArrayInfo>,
}

impl ColumnGridInfo {
    /// The grid these arrays lie on.
    pub fn grid(&self) -> Grid {
        Grid {
            nx: self.nx,
            ny: self.ny,
            x0_mm: self.x0_mm,
            y0_mm: self.y0_mm,
            spacing_mm: self.spacing_mm,
        }
    }
}

/// Write `columns.json` and one `<name>.npy` per array (shape `(ny, nx)`) into
/// the folder `dir`. Each array must have one value per grid column.
pub fn write_column_grid(dir: &Path, grid: &Grid, arrays: &[GridArray]) -> Result<(), Error> {
    for a in arrays {
        grid.check_len(&format!("grid array {:?}", a.name), a.values.len())
            .map_err(|e| e.at(&dir.join(format!("{}.npy", a.name))))?;
    }
    let mut writer = ColumnGridWriter::begin(dir, grid, arrays)?;
    let values: Vec<NpyValues> = arrays.iter().map(|a| a.values).collect();
    writer.write_rows(&values)?;
    writer.finish()
}

/// A column grid written block of rows by block of rows, in row order (the
/// bands of a stock too large for memory): each `.npy` file is its header
/// then the rows as they come (C order), and appears, with `columns.json`,
/// only when [`ColumnGridWriter::finish`] finds every row written.
pub struct ColumnGridWriter {
    dir: std::path::PathBuf,
    grid: Grid,
    info: ColumnGridInfo,
    files: Vec<crate::atomic::PendingFile>,
    rows_written: usize,
}

impl ColumnGridWriter {
    /// Start the files of `arrays` (their names, units, meanings and types;
    /// their values are not written here) on `grid` in the folder `dir`.
    pub fn begin(dir: &Path, grid: &Grid, arrays: &[GridArray]) -> Result<Self, Error> {
        let info = ColumnGridInfo {
            format: COLUMN_GRID_FORMAT.into(),
            version: 1,
            units: "mm".into(),
            nx: grid.nx,
            ny: grid.ny,
            x0_mm: grid.x0_mm,
            y0_mm: grid.y0_mm,
            spacing_mm: grid.spacing_mm,
            layout: "each array has shape (ny, nx), C order: element [iy, ix] is the column centred at (x0_mm + ix·spacing_mm, y0_mm + iy·spacing_mm)".into(),
            arrays: arrays
                .iter()
                .map(|a| GridArrayInfo {
                    name: a.name.into(),
                    file: format!("{}.npy", a.name),
                    dtype: a.values.descr().into(),
                    unit: a.unit.into(),
                    meaning: a.meaning.into(),
                })
                .collect(),
        };
        let mut files = Vec::with_capacity(arrays.len());
        for a in &info.arrays {
            let path = dir.join(&a.file);
            let io = |source| Error::Io {
                path: path.clone(),
                source,
            };
            let mut file = crate::atomic::PendingFile::create(&path).map_err(io)?;
            file.write_all(&npy_header(&a.dtype, &[grid.ny, grid.nx]))
                .map_err(io)?;
            files.push(file);
        }
        Ok(ColumnGridWriter {
            dir: dir.to_path_buf(),
            grid: *grid,
            info,
            files,
            rows_written: 0,
        })
    }

    /// Append the next rows: one value slice per array, in the order and of
    /// the types given to [`ColumnGridWriter::begin`], each of the same whole
    /// number of rows.
    pub fn write_rows(&mut self, values: &[NpyValues]) -> Result<(), Error> {
        let nx = self.grid.nx.max(1);
        let rows = values.first().map_or(0, |v| v.len() / nx);
        for (a, v) in self.info.arrays.iter().zip(values) {
            let path = self.dir.join(&a.file);
            if v.descr() != a.dtype || v.len() != rows * nx {
                return Err(Error::Invalid {
                    what: format!("grid array {:?}", a.name),
                    reason: format!(
                        "{} values of {} for rows of {nx} {}",
                        v.len(),
                        v.descr(),
                        a.dtype
                    ),
                }
                .at(&path));
            }
            if self.rows_written + rows > self.grid.ny {
                return Err(Error::Invalid {
                    what: format!("grid array {:?}", a.name),
                    reason: format!(
                        "{} rows past the grid's {}",
                        self.rows_written + rows,
                        self.grid.ny
                    ),
                }
                .at(&path));
            }
        }
        if values.len() != self.files.len() {
            return Err(Error::Invalid {
                what: "column grid".into(),
                reason: format!("{} arrays for {}", values.len(), self.files.len()),
            });
        }
        for ((file, v), a) in self.files.iter_mut().zip(values).zip(&self.info.arrays) {
            v.write_data(file).map_err(|source| Error::Io {
                path: self.dir.join(&a.file),
                source,
            })?;
        }
        self.rows_written += rows;
        Ok(())
    }

    /// Check that every row was written, then let the files and `columns.json` appear.
    pub fn finish(self) -> Result<(), Error> {
        if self.rows_written != self.grid.ny {
            return Err(Error::Invalid {
                what: "column grid".into(),
                reason: format!("{} of {} rows written", self.rows_written, self.grid.ny),
            }
            .at(&self.dir));
        }
        for (file, a) in self.files.into_iter().zip(&self.info.arrays) {
            file.commit().map_err(|source| Error::Io {
                path: self.dir.join(&a.file),
                source,
            })?;
        }
        let json = serde_json::to_vec_pretty(&self.info).map_err(|e| Error::Invalid {
            what: COLUMN_GRID_JSON.into(),
            reason: e.to_string(),
        })?;
        crate::render_and_write(&self.dir.join(COLUMN_GRID_JSON), || Ok(json))
    }
}

/// Read `columns.json` of the folder `dir`; `max_bytes` bounds the file size.
pub fn read_column_grid_info(dir: &Path, max_bytes: u64) -> Result<ColumnGridInfo, Error> {
    let path = dir.join(COLUMN_GRID_JSON);
    let bytes = read_bounded(&path, max_bytes)?;
    let info: ColumnGridInfo = serde_json::from_slice(&bytes).map_err(|e| Error::Invalid {
        what: path.display().to_string(),
        reason: format!("not a column grid description: {e}"),
    })?;
    if info.format != COLUMN_GRID_FORMAT {
        return Err(Error::Invalid {
            what: path.display().to_string(),
            reason: format!("format is {:?}, not {COLUMN_GRID_FORMAT:?}", info.format),
        });
    }
    Ok(info)
}

fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>, Error> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > max_bytes {
        return Err(Error::Invalid {
            what: path.display().to_string(),
            reason: format!("{len} bytes, more than the {max_bytes} expected"),
        });
    }
    std::fs::read(path).map_err(io)
}

/// The float32 array `name` of the column grid in `dir` described by `info`,
/// checked against the grid: shape `(ny, nx)`, dtype `<f4`. `Ok(None)` when
/// `info` lists no such array.
pub fn read_grid_array_f32(
    dir: &Path,
    info: &ColumnGridInfo,
    name: &str,
) -> Result<Option<Vec<f32>>, Error> {
    let Some(entry) = info.arrays.iter().find(|a| a.name == name) else {
        return Ok(None);
    };
    if entry.file.contains(['/', '\\']) || entry.file.starts_with('.') {
        return Err(Error::Invalid {
            what: COLUMN_GRID_JSON.into(),
            reason: format!("array file {:?} is not a plain file name", entry.file),
        });
    }
    let path = dir.join(&entry.file);
    let expected = info.nx.checked_mul(info.ny).ok_or_else(|| Error::Invalid {
        what: COLUMN_GRID_JSON.into(),
        reason: format!("grid {}×{} overflows", info.nx, info.ny),
    })?;
    // Header (≤ a few hundred bytes) plus the data: refuse anything larger before reading.
    let bytes = read_bounded(&path, 4096 + 4 * expected as u64)?;
    let npy = parse_npy(&bytes).map_err(|e| e.at(&path))?;
    let invalid = |reason: String| Error::Invalid {
        what: path.display().to_string(),
        reason,
    };
    if npy.shape != [info.ny, info.nx] {
        return Err(invalid(format!(
            "shape {:?}, the grid is ({}, {})",
            npy.shape, info.ny, info.nx
        )));
    }
    match npy.data {
        NpyArray::F32(v) => Ok(Some(v)),
        NpyArray::I32(_) => Err(invalid("dtype <i4, expected <f4".into())),
    }
}
