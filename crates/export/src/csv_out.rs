//! Per-column values as CSV: `ix,iy,x_mm,y_mm,<names...>`.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use crate::{Error, Grid};

/// Records a block of [`write_csv_records`] holds: one task's work.
const RECORDS_A_BLOCK: usize = 1024;
/// Blocks [`write_csv_records`] formats at once before it writes them (about
/// 1.3 MB of text for steps.csv's rows).
const BLOCKS_AT_ONCE: usize = 4;

/// Write `header` (if any) and then `n` records to `w` as CSV: record `i`'s fields
/// are those `record(i, fields)` pushes (`fields` empty before). The records
/// are made and formatted on rayon's threads, [`RECORDS_A_BLOCK`] to a block
/// and [`BLOCKS_AT_ONCE`] blocks at a time, and written in order: the bytes
/// one `csv::Writer` writing them in turn writes (formatting numbers is most
/// of writing a long table, and it needs nothing of the rows before).
pub fn write_csv_records(
    w: &mut dyn Write,
    header: Option<&[&str]>,
    n: usize,
    record: impl Fn(usize, &mut Vec<String>) + Sync,
) -> std::io::Result<()> {
    let into_io = |e: csv::Error| match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => std::io::Error::other(format!("{other:?}")),
    };
    let block = |records: std::ops::Range<usize>| -> std::io::Result<Vec<u8>> {
        let mut out = csv::Writer::from_writer(Vec::new());
        let mut fields = Vec::new();
        for i in records {
            fields.clear();
            record(i, &mut fields);
            out.write_record(&fields).map_err(into_io)?;
        }
        out.into_inner().map_err(|e| e.into_error())
    };
    if let Some(header) = header {
        let mut head = csv::Writer::from_writer(Vec::new());
        head.write_record(header).map_err(into_io)?;
        w.write_all(&head.into_inner().map_err(|e| e.into_error())?)?;
    }
    let blocks = n.div_ceil(RECORDS_A_BLOCK);
    for first in (0..blocks).step_by(BLOCKS_AT_ONCE) {
        let texts: Vec<Vec<u8>> = (first..(first + BLOCKS_AT_ONCE).min(blocks))
            .into_par_iter()
            .map(|b| block(b * RECORDS_A_BLOCK..((b + 1) * RECORDS_A_BLOCK).min(n)))
            .collect::<std::io::Result<_>>()?;
        for text in texts {
            w.write_all(&text)?;
        }
    }
    Ok(())
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// The records formatted in parallel blocks are the bytes of one writer
    /// writing them in turn: no records, fewer than a block, a block's end
    /// either side, several groups of blocks; with and without a header.
    #[test]
    fn records_in_parallel_are_one_writers_bytes() {
        let record = |i: usize, fields: &mut Vec<String>| {
            fields.push(i.to_string());
            fields.push(format!("{}", 0.1 * i as f64));
            fields.push(if i % 3 == 0 {
                String::new()
            } else {
                "a,b".into()
            });
        };
        let n_group = RECORDS_A_BLOCK * BLOCKS_AT_ONCE;
        for n in [
            0,
            1,
            RECORDS_A_BLOCK - 1,
            RECORDS_A_BLOCK,
            RECORDS_A_BLOCK + 1,
            2 * n_group + 5,
        ] {
            for header in [None, Some(&["i", "x", "text"][..])] {
                let mut want = csv::Writer::from_writer(Vec::new());
                if let Some(h) = header {
                    want.write_record(h).unwrap();
                }
                let mut fields = Vec::new();
                for i in 0..n {
                    fields.clear();
                    record(i, &mut fields);
                    want.write_record(&fields).unwrap();
                }
                let want = want.into_inner().unwrap();
                let mut got = Vec::new();
                write_csv_records(&mut got, header, n, record).unwrap();
                assert!(got == want, "{n} records, header {header:?}");
            }
        }
    }
}
