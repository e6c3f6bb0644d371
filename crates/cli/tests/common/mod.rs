//! Helpers shared by the CLI test binaries.

use std::collections::HashMap;
use std::path::Path;
use std::process::{Command, Output};

/// Run the dexcut binary with `args` in `cwd` (CI set: no progress bars).
pub fn run(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dexcut"))
        .args(args)
        .current_dir(cwd)
        .env("CI", "1")
        .output()
        .expect("run dexcut")
}

/// Run dexcut with `args` in `dir` and check that it refused: exit status 1,
/// no panic, every one of `needles` in the error, and no output folder `out`
/// (when given). Returns stderr for further checks.
pub fn assert_refused(dir: &Path, args: &[&str], needles: &[&str], out: Option<&str>) -> String {
    let o = run(args, dir);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "dexcut {args:?} exit: {err}");
    assert!(!err.contains("panicked"), "dexcut {args:?} panicked: {err}");
    for n in needles {
        assert!(err.contains(n), "dexcut {args:?}: no {n:?} in: {err}");
    }
    if let Some(out) = out {
        assert!(
            !dir.join(out).exists(),
            "dexcut {args:?} wrote {out} on error"
        );
    }
    err
}

/// The per-column results of an output folder read from its `.npy` grid
/// (`columns.json`), laid out as columns.csv's rows: one per column where any
/// value is set, with ix, iy, x_mm, y_mm and one entry per array (NaN and the
/// integer arrays' −1 read as NaN).
#[allow(dead_code)] // not every test binary reads a grid
pub fn grid_columns(out: &Path) -> HashMap<String, Vec<f64>> {
    let info = export::read_column_grid_info(out, 1 << 20).unwrap();
    let arrays: Vec<(String, Vec<f64>)> = info
        .arrays
        .iter()
        .map(|a| {
            let npy = export::parse_npy(&std::fs::read(out.join(&a.file)).unwrap()).unwrap();
            assert_eq!(npy.shape, vec![info.ny, info.nx], "{}", a.file);
            let values = match npy.data {
                export::NpyArray::F32(v) => v.iter().map(|&x| x as f64).collect(),
                export::NpyArray::I32(v) => v
                    .iter()
                    .map(|&i| if i < 0 { f64::NAN } else { i as f64 })
                    .collect(),
                other => panic!("{}: {:?} in the grid", a.file, other.dtype()),
            };
            (a.name.clone(), values)
        })
        .collect();
    let grid = info.grid();
    let mut cols: HashMap<String, Vec<f64>> = HashMap::new();
    for iy in 0..grid.ny {
        for ix in 0..grid.nx {
            let i = grid.index(ix, iy);
            if arrays.iter().all(|(_, v)| v[i].is_nan()) {
                continue;
            }
            let fixed = [
                ("ix", ix as f64),
                ("iy", iy as f64),
                ("x_mm", grid.x_mm(ix)),
                ("y_mm", grid.y_mm(iy)),
            ];
            for (name, v) in fixed {
                cols.entry(name.into()).or_default().push(v);
            }
            for (name, v) in &arrays {
                cols.entry(name.clone()).or_default().push(v[i]);
            }
        }
    }
    cols
}
