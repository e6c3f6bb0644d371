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
    /// `<f8`: little-endian float64.
    F64(&'a [f64]),
    /// `<u4`: little-endian uint32.
    U32(&'a [u32]),
    /// `|u1`: bytes (uint8).
    U8(&'a [u8]),
}

impl NpyValues<'_> {
    /// NumPy type string of the values.
    pub fn descr(&self) -> &'static str {
        self.dtype().descr()
    }

    /// Type of the values.
    pub fn dtype(&self) -> NpyType {
        match self {
            NpyValues::F32(_) => NpyType::F32,
            NpyValues::I32(_) => NpyType::I32,
            NpyValues::F64(_) => NpyType::F64,
            NpyValues::U32(_) => NpyType::U32,
            NpyValues::U8(_) => NpyType::U8,
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            NpyValues::F32(v) => v.len(),
            NpyValues::I32(v) => v.len(),
            NpyValues::F64(v) => v.len(),
            NpyValues::U32(v) => v.len(),
            NpyValues::U8(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Write the values, little-endian: on a little-endian machine the
    /// values' own bytes in one write (no copy); elsewhere byte-swapped in
    /// blocks ([`NpyValues::write_le_in_blocks`], no copy of the whole array).
    fn write_data(&self, out: &mut dyn Write) -> std::io::Result<()> {
        if cfg!(target_endian = "little") {
            out.write_all(self.native_bytes())
        } else {
            self.write_le_in_blocks(out)
        }
    }

    /// Write the values little-endian whatever the machine's order: each
    /// value's `to_le_bytes`, a block of values at a time (the writer of a
    /// big-endian machine; on a little-endian one the same bytes as
    /// [`NpyValues::native_bytes`], test `values_in_blocks_are_the_native_little_endian_bytes`).
    fn write_le_in_blocks(&self, out: &mut dyn Write) -> std::io::Result<()> {
        const BLOCK: usize = 16 * 1024;
        let mut buf = Vec::with_capacity(self.dtype().size() * BLOCK);
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
            NpyValues::F64(v) => blocks!(v),
            NpyValues::U32(v) => blocks!(v),
            NpyValues::U8(v) => out.write_all(v)?,
        }
        Ok(())
    }

    /// The values' bytes in the machine's own order.
    fn native_bytes(&self) -> &[u8] {
        match self {
            NpyValues::F32(v) => bytemuck::cast_slice(v),
            NpyValues::I32(v) => bytemuck::cast_slice(v),
            NpyValues::F64(v) => bytemuck::cast_slice(v),
            NpyValues::U32(v) => bytemuck::cast_slice(v),
            NpyValues::U8(v) => v,
        }
    }
}

/// The element types written and read: NumPy's little-endian `float32`,
/// `int32`, `float64`, `uint32` and `uint8`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NpyType {
    /// `<f4`.
    F32,
    /// `<i4`.
    I32,
    /// `<f8`.
    F64,
    /// `<u4`.
    U32,
    /// `|u1`.
    U8,
}

impl NpyType {
    const ALL: [NpyType; 5] = [
        NpyType::F32,
        NpyType::I32,
        NpyType::F64,
        NpyType::U32,
        NpyType::U8,
    ];

    /// NumPy type string (`descr` of the header).
    pub fn descr(self) -> &'static str {
        match self {
            NpyType::F32 => "<f4",
            NpyType::I32 => "<i4",
            NpyType::F64 => "<f8",
            NpyType::U32 => "<u4",
            NpyType::U8 => "|u1",
        }
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        match self {
            NpyType::F64 => 8,
            NpyType::F32 | NpyType::I32 | NpyType::U32 => 4,
            NpyType::U8 => 1,
        }
    }

    /// The type of a NumPy type string, if it is one of these.
    pub fn from_descr(descr: &str) -> Option<NpyType> {
        NpyType::ALL.into_iter().find(|t| t.descr() == descr)
    }
}

/// An array read back from a `.npy` file.
#[derive(Clone, Debug, PartialEq)]
pub enum NpyArray {
    /// `<f4` values.
    F32(Vec<f32>),
    /// `<i4` values.
    I32(Vec<i32>),
    /// `<f8` values.
    F64(Vec<f64>),
    /// `<u4` values.
    U32(Vec<u32>),
    /// `|u1` values.
    U8(Vec<u8>),
}

impl NpyArray {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            NpyArray::F32(v) => v.len(),
            NpyArray::I32(v) => v.len(),
            NpyArray::F64(v) => v.len(),
            NpyArray::U32(v) => v.len(),
            NpyArray::U8(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Type of the values.
    pub fn dtype(&self) -> NpyType {
        match self {
            NpyArray::F32(_) => NpyType::F32,
            NpyArray::I32(_) => NpyType::I32,
            NpyArray::F64(_) => NpyType::F64,
            NpyArray::U32(_) => NpyType::U32,
            NpyArray::U8(_) => NpyType::U8,
        }
    }

    /// The values as f64 (exact for every type read).
    pub fn to_f64(&self) -> Vec<f64> {
        match self {
            NpyArray::F32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyArray::I32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyArray::F64(v) => v.clone(),
            NpyArray::U32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyArray::U8(v) => v.iter().map(|&x| f64::from(x)).collect(),
        }
    }
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

/// Parse a `.npy` file of version 1.0–3.0 holding values of an [`NpyType`] in C order.
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
    let dtype = NpyType::from_descr(descr).ok_or_else(|| {
        bad(format!(
            "dtype {descr} is not read (only {})",
            NpyType::ALL.map(NpyType::descr).join(", ")
        ))
    })?;
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
    let size = dtype.size();
    if Some(data.len()) != n.checked_mul(size) {
        return Err(bad(format!(
            "shape {dims} of {size}-byte values needs {} data bytes, the file has {}",
            n.saturating_mul(size),
            data.len()
        )));
    }
    let words = || data.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]);
    let data = match dtype {
        NpyType::F32 => NpyArray::F32(words().map(f32::from_le_bytes).collect()),
        NpyType::I32 => NpyArray::I32(words().map(i32::from_le_bytes).collect()),
        NpyType::U32 => NpyArray::U32(words().map(u32::from_le_bytes).collect()),
        NpyType::F64 => NpyArray::F64(
            data.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect(),
        ),
        NpyType::U8 => NpyArray::U8(data.to_vec()),
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

/// `.npy` files that share their first axis (rows), written block of rows by
/// block of rows in row order: each file is its header then the rows as they
/// come (C order), and appears only when [`NpyRowsWriter::finish`] finds every
/// row written (dropped before: no file appears).
pub(crate) struct NpyRowsWriter {
    /// What the arrays are, for messages (`"grid array"`, `"step array"`).
    kind: &'static str,
    /// Per file: its path, array name, type and values per row.
    arrays: Vec<(std::path::PathBuf, String, NpyType, usize)>,
    files: Vec<crate::atomic::PendingFile>,
    rows: usize,
    rows_written: usize,
}

impl NpyRowsWriter {
    /// Start one file per `(path, name, type, trailing shape)`, each of shape
    /// `(rows, ..trailing)`; `kind` names the arrays in messages.
    pub(crate) fn begin(
        kind: &'static str,
        rows: usize,
        arrays: &[(std::path::PathBuf, String, NpyType, Vec<usize>)],
    ) -> Result<Self, Error> {
        let mut files = Vec::with_capacity(arrays.len());
        let mut kept = Vec::with_capacity(arrays.len());
        for (path, name, dtype, tail) in arrays {
            let io = |source| Error::Io {
                path: path.clone(),
                source,
            };
            let mut shape = vec![rows];
            shape.extend_from_slice(tail);
            let mut file = crate::atomic::PendingFile::create(path).map_err(io)?;
            file.write_all(&npy_header(dtype.descr(), &shape))
                .map_err(io)?;
            files.push(file);
            kept.push((path.clone(), name.clone(), *dtype, tail.iter().product()));
        }
        Ok(NpyRowsWriter {
            kind,
            arrays: kept,
            files,
            rows,
            rows_written: 0,
        })
    }

    /// Append the next rows: one value slice per file, in the order and of
    /// the types given to [`NpyRowsWriter::begin`], each of the same whole
    /// number of rows.
    pub(crate) fn write_rows(&mut self, values: &[NpyValues]) -> Result<(), Error> {
        if values.len() != self.files.len() {
            return Err(Error::Invalid {
                what: format!("{}s", self.kind),
                reason: format!("{} arrays for {}", values.len(), self.files.len()),
            });
        }
        let rows = match (values.first(), self.arrays.first()) {
            (Some(v), Some(a)) => v.len() / a.3.max(1),
            _ => 0,
        };
        for ((path, name, dtype, width), v) in self.arrays.iter().zip(values) {
            let invalid = |reason: String| {
                Err(Error::Invalid {
                    what: format!("{} {name:?}", self.kind),
                    reason,
                }
                .at(path))
            };
            if v.dtype() != *dtype || v.len() != rows * width {
                return invalid(format!(
                    "{} values of {} for {rows} rows of {width} {}",
                    v.len(),
                    v.descr(),
                    dtype.descr()
                ));
            }
            if self.rows_written + rows > self.rows {
                return invalid(format!(
                    "{} rows past the {} of the array",
                    self.rows_written + rows,
                    self.rows
                ));
            }
        }
        for (file, (v, (path, ..))) in self.files.iter_mut().zip(values.iter().zip(&self.arrays)) {
            v.write_data(file).map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
        }
        self.rows_written += rows;
        Ok(())
    }

    /// Check that every row was written, then let the files appear.
    /// `what` and `at` name the whole set in the message of rows missing.
    pub(crate) fn finish(self, what: &str, at: &Path) -> Result<(), Error> {
        if self.rows_written != self.rows {
            return Err(Error::Invalid {
                what: what.into(),
                reason: format!("{} of {} rows written", self.rows_written, self.rows),
            }
            .at(at));
        }
        for (file, (path, ..)) in self.files.into_iter().zip(&self.arrays) {
            file.commit().map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
        }
        Ok(())
    }
}

/// A column grid written block of rows by block of rows, in row order (the
/// bands of a stock too large for memory): each `.npy` file is its header
/// then the rows as they come (C order), and appears, with `columns.json`,
/// only when [`ColumnGridWriter::finish`] finds every row written.
pub struct ColumnGridWriter {
    dir: std::path::PathBuf,
    info: ColumnGridInfo,
    rows: NpyRowsWriter,
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
        let files: Vec<_> = arrays
            .iter()
            .zip(&info.arrays)
            .map(|(a, i)| {
                (
                    dir.join(&i.file),
                    a.name.to_string(),
                    a.values.dtype(),
                    vec![grid.nx],
                )
            })
            .collect();
        Ok(ColumnGridWriter {
            dir: dir.to_path_buf(),
            info,
            rows: NpyRowsWriter::begin("grid array", grid.ny, &files)?,
        })
    }

    /// Append the next rows: one value slice per array, in the order and of
    /// the types given to [`ColumnGridWriter::begin`], each of the same whole
    /// number of rows.
    pub fn write_rows(&mut self, values: &[NpyValues]) -> Result<(), Error> {
        self.rows.write_rows(values)
    }

    /// Check that every row was written, then let the files and `columns.json` appear.
    pub fn finish(self) -> Result<(), Error> {
        self.rows.finish("column grid", &self.dir)?;
        let json = serde_json::to_vec_pretty(&self.info).map_err(|e| Error::Invalid {
            what: COLUMN_GRID_JSON.into(),
            reason: e.to_string(),
        })?;
        crate::render_and_write(&self.dir.join(COLUMN_GRID_JSON), || Ok(json))
    }
}

/// Read `columns.json` of the folder `dir`; `max_bytes` bounds the file size.
pub fn read_column_grid_info(dir: &Path, max_bytes: u64) -> Result<ColumnGridInfo, Error> {
    read_description(
        &dir.join(COLUMN_GRID_JSON),
        max_bytes,
        "column grid",
        COLUMN_GRID_FORMAT,
        |info: &ColumnGridInfo| &info.format,
    )
}

/// A JSON description of arrays (`columns.json`, `steps.json`) at `path`, at
/// most `max_bytes`, whose `format` field (read by `format_of`) must be
/// `format`; `kind` names it in errors ("not a {kind} description").
pub(crate) fn read_description<T: serde::de::DeserializeOwned>(
    path: &Path,
    max_bytes: u64,
    kind: &str,
    format: &str,
    format_of: impl Fn(&T) -> &str,
) -> Result<T, Error> {
    let bytes = read_bounded(path, max_bytes)?;
    let info: T = serde_json::from_slice(&bytes).map_err(|e| Error::Invalid {
        what: path.display().to_string(),
        reason: format!("not a {kind} description: {e}"),
    })?;
    let found = format_of(&info);
    if found != format {
        return Err(Error::Invalid {
            what: path.display().to_string(),
            reason: format!("format is {found:?}, not {format:?}"),
        });
    }
    Ok(info)
}

/// Whether `file`, as an array description lists it, names a file in the
/// description's own folder (no separator, not hidden, not `..`).
pub(crate) fn is_plain_file_name(file: &str) -> bool {
    !(file.contains(['/', '\\']) || file.starts_with('.'))
}

pub(crate) fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>, Error> {
    let io = |source| Error::Read {
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
    if !is_plain_file_name(&entry.file) {
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
        other => Err(invalid(format!(
            "dtype {}, expected <f4",
            other.dtype().descr()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::NpyValues;

    /// The big-endian machine's writer (each value's `to_le_bytes`, in
    /// blocks) gives NumPy's little-endian bytes, across a block's end;
    /// on this little-endian machine they are the values' own bytes, as
    /// `write_data` writes them here.
    #[test]
    fn values_in_blocks_are_the_native_little_endian_bytes() {
        let n: i32 = 40_000; // more than two blocks of 16 Ki values
        let f32s: Vec<f32> = (0..n)
            .map(|i| (i as f32 - 7.5) * 1.25e-3)
            .chain([f32::NAN, f32::INFINITY, -0.0, f32::MIN_POSITIVE])
            .collect();
        let f64s: Vec<f64> = f32s.iter().map(|&x| f64::from(x) * 1.000_000_1).collect();
        let i32s: Vec<i32> = (0..n).map(|i| i.wrapping_mul(-97_531)).collect();
        let u32s: Vec<u32> = (0..n)
            .map(|i| (i as u32).wrapping_mul(2_654_435_761))
            .collect();
        let u8s: Vec<u8> = (0..n).map(|i| (i % 251) as u8).collect();
        let le = |bytes: &mut dyn Iterator<Item = u8>| bytes.collect::<Vec<u8>>();
        for (values, want) in [
            (
                NpyValues::F32(&f32s),
                le(&mut f32s.iter().flat_map(|x| x.to_le_bytes())),
            ),
            (
                NpyValues::F64(&f64s),
                le(&mut f64s.iter().flat_map(|x| x.to_le_bytes())),
            ),
            (
                NpyValues::I32(&i32s),
                le(&mut i32s.iter().flat_map(|x| x.to_le_bytes())),
            ),
            (
                NpyValues::U32(&u32s),
                le(&mut u32s.iter().flat_map(|x| x.to_le_bytes())),
            ),
            (NpyValues::U8(&u8s), u8s.clone()),
        ] {
            let mut blocks = Vec::new();
            values.write_le_in_blocks(&mut blocks).unwrap();
            assert_eq!(blocks, want, "{:?}", values.dtype());
            let mut data = Vec::new();
            values.write_data(&mut data).unwrap();
            assert_eq!(data, want, "{:?}", values.dtype());
            if cfg!(target_endian = "little") {
                assert_eq!(values.native_bytes(), &want[..], "{:?}", values.dtype());
            }
        }
    }
}
