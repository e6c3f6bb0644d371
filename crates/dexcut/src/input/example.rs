//! The built-in boss_contour example (after S4's experiment), embedded in the
//! binary so `dexcut optimize` runs with no arguments.

use std::path::{Path, PathBuf};

use crate::error::{fail, Error, Result};

/// (file name, content) of the example's files.
pub const FILES: [(&str, &[u8]); 3] = [
    (
        "job.toml",
        include_bytes!("../../../../examples/boss_contour/job.toml"),
    ),
    (
        "boss_contour.nc",
        include_bytes!("../../../../examples/boss_contour/boss_contour.nc"),
    ),
    (
        "boss_contour_stock.stl",
        include_bytes!("../../../../examples/boss_contour/boss_contour_stock.stl"),
    ),
];

/// Write the example into `dir`; returns the job file's path.
pub fn write_files(dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io("cannot create", dir, e))?;
    for (name, bytes) in FILES {
        export::atomic::write_bytes(&dir.join(name), bytes)
            .map_err(|e| Error::io("cannot write", &dir.join(name), e))?;
    }
    Ok(dir.join("job.toml"))
}

/// `dexcut example`: write the example to edit and run. A file of the folder
/// that differs from the example (an edited job) is overwritten only with `force`.
/// Returns the job file's path.
pub fn write(dir: &Path, force: bool) -> Result<PathBuf> {
    let edited: Vec<String> = FILES
        .iter()
        .map(|(name, _)| dir.join(name))
        .filter(|p| std::fs::symlink_metadata(p).is_ok())
        .filter(|p| {
            !FILES.iter().any(|(n, bytes)| {
                p.ends_with(n) && std::fs::read(p).ok().as_deref() == Some(*bytes)
            })
        })
        .map(|p| p.display().to_string())
        .collect();
    if !edited.is_empty() && !force {
        fail!(request,
            "{} already exist(s) and differ(s) from the example (edited?); not overwritten: choose another --out or give --force",
            edited.join(", ")
        );
    }
    write_files(dir)
}
