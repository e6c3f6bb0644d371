//! Helpers shared by the CLI test binaries.

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
