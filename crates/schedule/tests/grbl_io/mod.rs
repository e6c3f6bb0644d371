//! What `tests/grbl.rs` and `examples/grbl_blocks.rs` share: the reference machine's
//! settings, the programs, and the block list handed to the real grbl planner's harness
//! (`scripts/grbl_reference/harness.c`; its format is in that file).
#![allow(dead_code)]

use schedule::controller::grbl::{blocks, BlockKind, GrblSettings};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The workspace's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `scripts/grbl_reference/settings.txt`, the `$$` dump both planners run with.
pub fn settings() -> GrblSettings {
    settings_from(&root().join("scripts/grbl_reference/settings.txt"))
}

/// A `$$` dump read over dexcut's defaults (it sets every setting that plans).
pub fn settings_from(file: &Path) -> GrblSettings {
    let text = std::fs::read_to_string(file).expect("settings dump");
    GrblSettings::default()
        .with_dump(&text)
        .expect("settings dump reads")
}

/// A program as the machine starts it: at the origin (a leading byte-order mark dropped). grbl's own commands (lines that
/// start with `$`, `?`, `~` or `!`: settings, homing, status) are left out; they move nothing
/// here.
pub fn program(file: &Path) -> nc::Path {
    let raw = std::fs::read_to_string(file).expect("program");
    let text: String = raw
        .trim_start_matches('\u{feff}')
        .lines()
        .map(|l| {
            if l.trim_start().starts_with(['$', '?', '~', '!']) {
                ""
            } else {
                l
            }
        })
        .flat_map(|l| [l, "\n"])
        .collect();
    let name = file.display().to_string();
    let parsed = nc::Reader::new(&text, &name, &nc::Options::default()).parse_from([0.0; 3]);
    let errors: Vec<_> = parsed
        .diagnostics
        .iter()
        .filter(|d| d.severity == nc::Severity::Error)
        .collect();
    assert!(errors.is_empty(), "{name}: {errors:?}");
    parsed.path
}

/// The harness's input for `path`: its start, then dexcut's blocks one a line.
pub fn blocks_text(path: &nc::Path, settings: &GrblSettings) -> String {
    let mut out = String::new();
    let s = path.segments[0].start;
    writeln!(out, "start {} {} {}", s.x, s.y, s.z).unwrap();
    for (k, b) in blocks(path, settings).iter().enumerate() {
        let [x, y, z] = b.target_mm;
        match b.kind {
            BlockKind::Feed { feed_mm_min } => {
                writeln!(out, "F {x} {y} {z} {feed_mm_min} {k}").unwrap()
            }
            BlockKind::Rapid => writeln!(out, "R {x} {y} {z} {k}").unwrap(),
            BlockKind::Sync { dwell_s } => writeln!(out, "S {dwell_s} {k}").unwrap(),
        }
    }
    out
}
