//! Per-column values as CSV: `ix,iy,x_mm,y_mm,<names...>`.

use std::path::Path;

use crate::{Error, Grid};

/// CSV bytes with one row per column of `grid` in which at least one of
/// `columns` is not NaN; NaN values are written as empty fields. Each named
/// column must have one value per grid column.
pub fn column_csv_bytes(grid: &Grid, columns: &[(&str, &[f32])]) -> Result<Vec<u8>, Error> {
    check_columns(grid, columns)?;
    let mut bytes = Vec::new();
    write_rows(&mut bytes, grid, columns)?;
    Ok(bytes)
}

fn check_columns(grid: &Grid, columns: &[(&str, &[f32])]) -> Result<(), Error> {
    for (name, values) in columns {
        grid.check_len(&format!("CSV column {name:?}"), values.len())?;
    }
    Ok(())
}

/// The rows of [`column_csv_bytes`], streamed to `out`.
fn write_rows(
    out: &mut dyn std::io::Write,
    grid: &Grid,
    columns: &[(&str, &[f32])],
) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    let mut header = vec!["ix".to_string(), "iy".into(), "x_mm".into(), "y_mm".into()];
    header.extend(columns.iter().map(|(n, _)| n.to_string()));
    w.write_record(&header)?;
    let mut record: Vec<String> = Vec::with_capacity(header.len());
    for iy in 0..grid.ny {
        for ix in 0..grid.nx {
            let i = grid.index(ix, iy);
            if columns.iter().all(|(_, v)| v[i].is_nan()) {
                continue;
            }
            record.clear();
            record.push(ix.to_string());
            record.push(iy.to_string());
            record.push(format!("{}", grid.x_mm(ix)));
            record.push(format!("{}", grid.y_mm(iy)));
            record.extend(columns.iter().map(|(_, v)| {
                if v[i].is_nan() {
                    String::new()
                } else {
                    format!("{}", v[i])
                }
            }));
            w.write_record(&record)?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Write per-column values of `grid` to the CSV file `path`, streamed (the
/// file is far larger than the grid's memory); see [`column_csv_bytes`].
pub fn write_column_csv(path: &Path, grid: &Grid, columns: &[(&str, &[f32])]) -> Result<(), Error> {
    check_columns(grid, columns).map_err(|e| e.at(path))?;
    crate::atomic::write_file(path, |w| {
        write_rows(w, grid, columns).map_err(|e| match e.into_kind() {
            csv::ErrorKind::Io(io) => io,
            other => std::io::Error::other(format!("{other:?}")),
        })
    })
    .map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}
