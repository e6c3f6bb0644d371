//! A table of named columns as NumPy `.npy` arrays (the binary form of a long
//! CSV file such as steps.csv): `<stem>.json` describes the table (rows, and
//! per column its file, type, shape, unit and meaning), and each column is the
//! file `<stem>_<name>.npy` beside it, of shape `(rows,)`, or `(rows, width)`
//! for a column that holds `width` values per row (C order, a row's values
//! together). `numpy.load("steps_force_n.npy")` reads a column.
//!
//! The files are written block of rows by block of rows (no copy of the whole
//! table) and appear, the description last, only when every row is written.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::npy::{parse_npy, read_bounded, Npy, NpyRowsWriter, NpyType, NpyValues};
use crate::Error;

/// `format` value of a table description.
pub const NPY_TABLE_FORMAT: &str = "dexcut npy table";

/// One column of a table to write.
#[derive(Clone, Copy, Debug)]
pub struct TableColumn<'a> {
    /// Column name (letters, digits and `_`); the file is `<stem>_<name>.npy`.
    pub name: &'a str,
    /// Unit of the values (`"mm"`, `"1"` for counts, indices and flags).
    pub unit: &'a str,
    /// What a value means.
    pub meaning: &'a str,
    /// Type of the values.
    pub dtype: NpyType,
    /// `None`: one value per row, shape `(rows,)`; `Some(k)`: `k` values per
    /// row, shape `(rows, k)`.
    pub width: Option<usize>,
}

/// One entry of a table description's `columns`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableColumnInfo {
    /// Column name.
    pub name: String,
    /// File name beside the description.
    pub file: String,
    /// NumPy type string (`<f8`, `<u4`, `|u1`, …).
    pub dtype: String,
    /// Array shape: `[rows]` or `[rows, width]`.
    pub shape: Vec<usize>,
    /// Unit of the values.
    pub unit: String,
    /// What a value means.
    pub meaning: String,
}

/// `<stem>.json`: the rows of a table and its columns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableInfo {
    /// Always [`NPY_TABLE_FORMAT`].
    pub format: String,
    /// Layout version (1).
    pub version: u32,
    /// Number of rows: every array's first axis.
    pub rows: usize,
    /// How rows map to what they describe.
    pub layout: String,
    /// The columns, one `.npy` file each.
    pub columns: Vec<TableColumnInfo>,
}

fn plain_name(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
}

/// File name of the description of the table `stem`.
pub fn npy_table_json(stem: &str) -> String {
    format!("{stem}.json")
}

/// A table written block of rows by block of rows: see the module notes.
pub struct NpyTableWriter {
    json: std::path::PathBuf,
    info: TableInfo,
    rows: NpyRowsWriter,
}

impl NpyTableWriter {
    /// Start the files of the table `stem` of `rows` rows in the folder
    /// `dir`: `<stem>_<name>.npy` per column, `<stem>.json` at the end.
    /// `layout` says what a row is.
    pub fn begin(
        dir: &Path,
        stem: &str,
        rows: usize,
        layout: &str,
        columns: &[TableColumn],
    ) -> Result<Self, Error> {
        let json = dir.join(npy_table_json(stem));
        if let Some(bad) = std::iter::once(stem)
            .chain(columns.iter().map(|c| c.name))
            .find(|n| !plain_name(n))
        {
            return Err(Error::Invalid {
                what: format!("table {stem:?}"),
                reason: format!("name {bad:?} is not letters, digits and _"),
            }
            .at(&json));
        }
        let info = TableInfo {
            format: NPY_TABLE_FORMAT.into(),
            version: 1,
            rows,
            layout: layout.into(),
            columns: columns
                .iter()
                .map(|c| TableColumnInfo {
                    name: c.name.into(),
                    file: format!("{stem}_{}.npy", c.name),
                    dtype: c.dtype.descr().into(),
                    shape: std::iter::once(rows).chain(c.width).collect(),
                    unit: c.unit.into(),
                    meaning: c.meaning.into(),
                })
                .collect(),
        };
        let files: Vec<_> = columns
            .iter()
            .zip(&info.columns)
            .map(|(c, i)| {
                (
                    dir.join(&i.file),
                    c.name.to_string(),
                    c.dtype,
                    c.width.into_iter().collect(),
                )
            })
            .collect();
        Ok(NpyTableWriter {
            rows: NpyRowsWriter::begin("table column", rows, &files)?,
            json,
            info,
        })
    }

    /// Append the next rows: one value slice per column, in the order and of
    /// the types given to [`NpyTableWriter::begin`], each of the same number
    /// of rows (`width` values per row for a column of width).
    pub fn write_rows(&mut self, values: &[NpyValues]) -> Result<(), Error> {
        self.rows.write_rows(values)
    }

    /// Check that every row was written, then let the files and the
    /// description appear.
    pub fn finish(self) -> Result<(), Error> {
        self.rows.finish("npy table", &self.json)?;
        let json = serde_json::to_vec_pretty(&self.info).map_err(|e| Error::Invalid {
            what: self.json.display().to_string(),
            reason: e.to_string(),
        })?;
        crate::render_and_write(&self.json, || Ok(json))
    }
}

/// Read the description `<stem>.json` of a table in the folder `dir`;
/// `max_bytes` bounds its size.
pub fn read_npy_table_info(dir: &Path, stem: &str, max_bytes: u64) -> Result<TableInfo, Error> {
    crate::npy::read_description(
        &dir.join(npy_table_json(stem)),
        max_bytes,
        "table",
        NPY_TABLE_FORMAT,
        |info: &TableInfo| &info.format,
    )
}

/// The column `name` of the table in `dir` described by `info`, checked
/// against the description (a plain file name, its type, shape `[rows]` or
/// `[rows, width]`); `max_bytes` bounds the file. `Ok(None)` when `info`
/// lists no such column.
pub fn read_npy_table_column(
    dir: &Path,
    info: &TableInfo,
    name: &str,
    max_bytes: u64,
) -> Result<Option<Npy>, Error> {
    let Some(entry) = info.columns.iter().find(|c| c.name == name) else {
        return Ok(None);
    };
    let invalid = |what: &Path, reason: String| Error::Invalid {
        what: what.display().to_string(),
        reason,
    };
    if !crate::npy::is_plain_file_name(&entry.file) {
        return Err(invalid(
            dir,
            format!(
                "the table lists column file {:?}, not a plain file name",
                entry.file
            ),
        ));
    }
    let path = dir.join(&entry.file);
    if entry.shape.first() != Some(&info.rows) || entry.shape.len() > 2 {
        return Err(invalid(
            &path,
            format!(
                "listed with shape {:?} in a table of {} rows",
                entry.shape, info.rows
            ),
        ));
    }
    let bytes = read_bounded(&path, max_bytes)?;
    let npy = parse_npy(&bytes).map_err(|e| e.at(&path))?;
    if npy.shape != entry.shape {
        return Err(invalid(
            &path,
            format!("shape {:?}, the table lists {:?}", npy.shape, entry.shape),
        ));
    }
    if npy.data.dtype().descr() != entry.dtype {
        return Err(invalid(
            &path,
            format!(
                "dtype {}, the table lists {}",
                npy.data.dtype().descr(),
                entry.dtype
            ),
        ));
    }
    Ok(Some(npy))
}
