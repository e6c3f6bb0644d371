//! `[tool_library]` end to end: a G-code program that calls its tools by
//! number (T… M6) run against FreeCAD's own tool library
//! (toolpaths/tool_libraries/freecad/freecad_cam, SOURCES.md there), read
//! from the real files. The same job with the library's tools written out by
//! hand as `[[tools]]` entries (the values read off the bit files, the
//! defaults worked out as docs/guide/job.md says) gives the same run, byte
//! for byte; each tool's removal is its slot's cross-section times its
//! length.

use std::path::{Path, PathBuf};

use serde_json::Value;

// Only its `run` is used here.
#[allow(dead_code)]
mod common;

use common::run as dexcut;

/// FreeCAD's Default.fctl, its bits in ../Bit.
fn library() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../toolpaths/tool_libraries/freecad/freecad_cam/Library/Default.fctl")
        .canonicalize()
        .unwrap()
}

/// A 100 × 40 × 30 mm box on a 0.1 mm grid: T1 (5mm Endmill) cuts a slot 2
/// mm deep along X at Y−8, T3 (6mm Ball End) a groove 1 mm deep at Y8, both
/// through the whole length. No G43: the bits have no gauge length.
const PROGRAM: &str =
    "%\nG21 G90 G17\nS10000 M3\nT1 M6\nG0 X-10 Y-8 Z40\nG0 Z28\nG1 X110 F600\nG0 Z40\n\
T3 M6\nG0 X-10 Y8\nG0 Z29\nG1 X110 F600\nG0 Z40\nM30\n%\n";

const STOCK: &str = "[stock]\nkind = \"box\"\nmin = [0, -20, 0]\nmax = [100, 20, 30]\ngrid = 0.1\n\
[program]\npath = \"p.nc\"\n";

/// The library's tools 1 and 3 by hand. 5mm_Endmill.fctb: Diameter 5,
/// CuttingEdgeHeight 30, Length 50, ShankDiameter 3, no flutes: stick-out
/// 50 − 3 × 3 = 41 (overall length less a grip of three shank diameters),
/// 2 flutes. 6mm_Ball_End.fctb: Diameter 6, CuttingEdgeHeight 40, Length 50,
/// ShankDiameter 3: stick-out 41, 2 flutes. Gauge length 0.
const BY_HAND: &str = "[[tools]]\nnumber = 1\nkind = \"flat\"\ndiameter = 5\nflute_length = 30\n\
stickout = 41\nshank_diameter = 3\nflutes = 2\nlength = 0\n\
[[tools]]\nnumber = 3\nkind = \"ball\"\ndiameter = 6\nflute_length = 40\nstickout = 41\n\
shank_diameter = 3\nflutes = 2\nlength = 0\n";

fn simulate(dir: &Path, job: &str, out: &str) -> (Value, String) {
    std::fs::write(dir.join("job.toml"), job).unwrap();
    std::fs::write(dir.join("p.nc"), PROGRAM).unwrap();
    let o = dexcut(&["simulate", "job.toml", "--out", out], dir);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    let summary =
        serde_json::from_str(&std::fs::read_to_string(dir.join(out).join("summary.json")).unwrap())
            .unwrap();
    (summary, stderr)
}

/// Cross-section of a groove cut h deep by a ball of radius r, mm².
fn ball_groove_mm2(r: f64, h: f64) -> f64 {
    r * r * ((r - h) / r).acos() - (r - h) * (2.0 * r * h - h * h).sqrt()
}

#[test]
fn a_program_runs_on_the_tools_of_freecads_library() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lib = library();
    let job = format!(
        "{STOCK}[tool_library]\npath = {:?}\n",
        lib.display().to_string()
    );
    let (s, stderr) = simulate(d, &job, "lib");

    // The tools used, each with what was defaulted, said on the console;
    // tool 2 (unused) is not, and the skipped entries are counted.
    let said: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning: ") && l.contains("Default.fctl"))
        .collect();
    let t1 = said
        .iter()
        .find(|l| l.contains("T1 ("))
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(
        t1.contains("\"5mm Endmill\"): flat Ø5 mm, flute length 30 mm, stickout 41 mm, 2 flutes"),
        "{t1}"
    );
    assert!(
        t1.contains("stickout 41 mm (overall length less a grip of 3 shank diameters"),
        "{t1}"
    );
    assert!(t1.contains("2 flutes (not in the library)"), "{t1}");
    let t3 = said.iter().find(|l| l.contains("T3 (")).unwrap();
    assert!(
        t3.contains("\"6mm Ball End\"): ball Ø6 mm, flute length 40 mm, stickout 41 mm"),
        "{t3}"
    );
    assert!(!said.iter().any(|l| l.contains("T2 (")), "{said:?}");
    assert!(
        said.iter().any(|l| l.contains("8 entries skipped")),
        "{said:?}"
    );
    let kinds: Vec<&Value> = s["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|w| w["kind"] == "tool_library")
        .collect();
    assert_eq!(kinds.len(), said.len(), "{kinds:?}");

    // Each tool's removal: 5 × 2 × 100 = 1000 mm³ for the flat slot (its
    // edges fall between grid columns), the circular segment × 100 for the
    // ball's groove (to the grid's 0.3 %).
    let tools = s["tools"].as_array().unwrap();
    assert_eq!(
        (tools[0]["tool"].as_u64(), tools[1]["tool"].as_u64()),
        (Some(1), Some(3))
    );
    let removed = |k: usize| tools[k]["removed_volume_mm3"].as_f64().unwrap();
    assert!(
        (removed(0) - 1000.0).abs() < 1e-3 * 1000.0,
        "T1 {}",
        removed(0)
    );
    let groove = ball_groove_mm2(3.0, 1.0) * 100.0;
    assert!(
        (removed(1) - groove).abs() < 3e-3 * groove,
        "T3 {} vs {groove}",
        removed(1)
    );

    // The same tools by hand: the same run.
    let (by_hand, _) = simulate(d, &format!("{STOCK}{BY_HAND}"), "hand");
    for key in [
        "removed_volume_mm3",
        "cycle_time_s",
        "peak_force_n",
        "peak_deflection_um",
        "tools",
    ] {
        assert_eq!(s[key], by_hand[key], "{key}");
    }
    assert_eq!(
        std::fs::read(d.join("lib/steps.csv")).unwrap(),
        std::fs::read(d.join("hand/steps.csv")).unwrap()
    );

    // A [[tools]] entry of a library tool's number replaces it, and is said.
    let job = format!(
        "{STOCK}[tool_library]\npath = {:?}\n[[tools]]\nnumber = 3\nkind = \"ball\"\ndiameter = 8\n",
        lib.display().to_string()
    );
    let (s, stderr) = simulate(d, &job, "replaced");
    assert!(
        stderr.contains("T3 replaced by the job's [[tools]] entries"),
        "{stderr}"
    );
    let removed = s["tools"][1]["removed_volume_mm3"].as_f64().unwrap();
    let groove = ball_groove_mm2(4.0, 1.0) * 100.0;
    assert!(
        (removed - groove).abs() < 3e-3 * groove,
        "T3 Ø8 {removed} vs {groove}"
    );
}

#[test]
fn a_tool_the_library_skips_is_an_error_at_the_program_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = format!(
        "{STOCK}[tool_library]\npath = {:?}\n",
        library().display().to_string()
    );
    std::fs::write(d.join("job.toml"), job).unwrap();
    // T5 is the 30° V-bit: skipped, which the error says.
    std::fs::write(d.join("p.nc"), "G21 G90\nT5 M6\nG0 X-10 Y0 Z40\nM30\n").unwrap();
    let err = common::assert_refused(
        d,
        &["simulate", "job.toml", "--out", "o"],
        &[
            "p.nc:2:1: tool T5 is not in the job's tool table (it has T1, T2, T3, T4); the tool library",
            "but skipped it: shape v-bit, which the simulator cannot model",
        ],
        Some("o"),
    );
    assert!(err.contains("30degree_Vbit.fctb"), "{err}");
}

/// A LinuxCNC tool table as a hackspace keeps it (bristolhackspace/cnc-mill,
/// toolpaths/tool_libraries/linuxcnc, SOURCES.md): `T10 D+2 ;2mm endmill`
/// with no Z, `T12 D+3 Z+25.961501 ;3mm drill`. T10 cuts a slot 2 mm deep at
/// Y−8 (2 × 2 × 100 = 400 mm³) and retracts to Z80, above the longer T12's
/// reach (the gauge point stays at a tool change); T12, its gauge length applied by G43 H12,
/// 1 mm deep at Y0 (3 × 1 × 100 = 300 mm³), then without G43 its tip is
/// 25.961501 mm under the programmed Z: programmed at Z 29 + 25.961501 it
/// cuts 1 mm deep at Y8 (another 300 mm³).
#[test]
fn a_linuxcnc_tool_table_gives_the_tools_and_their_gauge_lengths() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let table = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../toolpaths/tool_libraries/linuxcnc/bristolhackspace_cnc_mill.tbl")
        .canonicalize()
        .unwrap();
    let job = format!(
        "{STOCK}[tool_library]\npath = {:?}\n",
        table.display().to_string()
    );
    std::fs::write(d.join("job.toml"), job).unwrap();
    std::fs::write(
        d.join("p.nc"),
        "%\nG21 G90 G17\nS10000 M3\nT10 M6\nG0 X-10 Y-8 Z40\nG0 Z28\nG1 X110 F600\nG0 Z80\n\
         T12 M6\nG43 H12\nG0 X-10 Y0 Z40\nG0 Z29\nG1 X110 F600\nG0 Z40\nG49\n\
         G0 Z80\nG0 X-10 Y8\nG0 Z54.961501\nG1 X110 F600\nG0 Z80\nM30\n%\n",
    )
    .unwrap();
    let o = dexcut(&["simulate", "job.toml", "--out", "o"], d);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("T12 ("), "{stderr}");
    assert!(
        stderr.contains("\"3mm drill\"): flat Ø3 mm, flute length 6 mm, stickout 24 mm, 2 flutes"),
        "{stderr}"
    );
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("o/summary.json")).unwrap()).unwrap();
    let tools = s["tools"].as_array().unwrap();
    let removed = |k: usize| tools[k]["removed_volume_mm3"].as_f64().unwrap();
    assert_eq!(tools[0]["tool"], 10);
    assert_eq!(tools[1]["tool"], 12);
    assert!(
        (removed(0) - 400.0).abs() < 1e-3 * 400.0,
        "T10 {}",
        removed(0)
    );
    assert!(
        (removed(1) - 600.0).abs() < 1e-3 * 600.0,
        "T12 {}",
        removed(1)
    );
}

/// `[operations.tool_library]`: a job of two operations, each with its own
/// real library (FreeCAD's T1, the 5mm Endmill, a slot 2 deep at Y−8:
/// 1000 mm³; the hackspace table's T12 by G43 H12, 1 deep at Y8: 300 mm³),
/// each operation's tools said under its name.
#[test]
fn each_operation_takes_its_own_tool_library() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let table = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../toolpaths/tool_libraries/linuxcnc/bristolhackspace_cnc_mill.tbl")
        .canonicalize()
        .unwrap();
    let job = format!(
        "[stock]\nkind = \"box\"\nmin = [0, -20, 0]\nmax = [100, 20, 30]\ngrid = 0.1\n\
         [[operations]]\nname = \"freecad\"\nprogram = \"a.nc\"\n\
         [operations.tool_library]\npath = {:?}\n\
         [[operations]]\nname = \"linuxcnc\"\nprogram = \"b.nc\"\n\
         [operations.tool_library]\npath = {:?}\n",
        library().display().to_string(),
        table.display().to_string()
    );
    std::fs::write(d.join("job.toml"), job).unwrap();
    std::fs::write(
        d.join("a.nc"),
        "%\nG21 G90 G17\nS10000 M3\nT1 M6\nG0 X-10 Y-8 Z40\nG0 Z28\nG1 X110 F600\nG0 Z80\nM30\n%\n",
    )
    .unwrap();
    std::fs::write(
        d.join("b.nc"),
        "%\nG21 G90 G17\nS10000 M3\nT12 M6\nG43 H12\nG0 X-10 Y8 Z40\nG0 Z29\nG1 X110 F600\nG0 Z80\nM30\n%\n",
    )
    .unwrap();
    let o = dexcut(&["simulate", "job.toml", "--out", "o"], d);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("warning: op1_freecad: T1 ("), "{stderr}");
    assert!(stderr.contains("warning: op2_linuxcnc: T12 ("), "{stderr}");
    for (folder, tool, volume) in [("op1_freecad", 1, 1000.0), ("op2_linuxcnc", 12, 300.0)] {
        let s: Value = serde_json::from_str(
            &std::fs::read_to_string(d.join("o").join(folder).join("summary.json")).unwrap(),
        )
        .unwrap();
        let tools = s["tools"].as_array().unwrap();
        assert_eq!(tools.len(), 1, "{folder}");
        assert_eq!(tools[0]["tool"], tool, "{folder}");
        let removed = tools[0]["removed_volume_mm3"].as_f64().unwrap();
        assert!(
            (removed - volume).abs() < 1e-3 * volume,
            "{folder}: {removed}"
        );
    }
}
