//! The readers on real libraries (toolpaths/tool_libraries, SOURCES.md
//! there): the tools read against the values in the files, read by eye;
//! and their errors on malformed ones.

use super::*;
use crate::input::job::Job;
use ToolKind::{Ball, Bull, Flat};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../toolpaths/tool_libraries")
        .join(rel)
}

fn spec(path: PathBuf, units: Option<TableUnits>) -> ToolLibrarySpec {
    ToolLibrarySpec {
        path,
        format: None,
        units,
    }
}

fn read(rel: &str, units: Option<TableUnits>) -> Library {
    read_tool_library(&spec(data(rel), units), Path::new(""))
        .unwrap_or_else(|e| panic!("{rel}: {}", e.chain_message()))
}

/// The error reading `text` as a library file named `name`.
fn error_of(name: &str, text: &str, units: Option<TableUnits>) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), text).unwrap();
    let e = read_tool_library(&spec(PathBuf::from(name), units), dir.path())
        .expect_err("a malformed library");
    e.chain_message()
}

fn numbers(lib: &Library) -> Vec<u32> {
    let mut n: Vec<u32> = lib.tools.iter().map(|t| t.number).collect();
    n.sort_unstable();
    n
}

fn skipped(lib: &Library) -> Vec<(Option<u32>, String)> {
    lib.skipped
        .iter()
        .map(|s| (s.number, s.reason.clone()))
        .collect()
}

/// Tool `n`: its shape, diameter, corner radius, flute length and
/// stick-out (mm), to 1e-9.
#[track_caller]
fn check(lib: &Library, n: u32, kind: ToolKind, d: f64, r: Option<f64>, flute: f64, stickout: f64) {
    let t = lib
        .tool(n)
        .unwrap_or_else(|| panic!("no T{n} in {}", lib.file_name()));
    let s = &t.spec;
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
    assert_eq!(s.kind, kind, "T{n} kind");
    assert!(near(s.diameter, d), "T{n} diameter {} ≠ {d}", s.diameter);
    match (s.corner_radius, r) {
        (Some(a), Some(b)) => assert!(near(a, b), "T{n} corner radius {a} ≠ {b}"),
        (a, b) => assert_eq!(a, b, "T{n} corner radius"),
    }
    assert!(
        near(s.flute_length.unwrap(), flute),
        "T{n} flute length {:?} ≠ {flute}",
        s.flute_length
    );
    assert!(
        near(s.stickout.unwrap(), stickout),
        "T{n} stickout {:?} ≠ {stickout}",
        s.stickout
    );
    assert_eq!(s.number, Some(n));
}

const IN: f64 = 25.4;

#[test]
fn linuxcnc_ncam_demo_table() {
    // LinuxCNC's configs/sim/axis/ncam_demo/mill_mm.tbl: D only, the shape
    // in the comment ("2mm end mill", "Drill 1/16 - 1/8", "Center drill").
    let lib = read("linuxcnc/linuxcnc_ncam_demo_mill_mm.tbl", None);
    assert_eq!(
        numbers(&lib),
        [1, 2, 3, 4, 5, 6, 7, 8, 21, 22, 23, 24, 25, 31, 32, 33, 41, 42, 43]
    );
    // Flute length 2 × D and stick-out 8 × D, defaulted and said.
    check(&lib, 1, Flat, 2.0, None, 4.0, 16.0);
    check(&lib, 3, Flat, 6.0, None, 12.0, 48.0);
    check(&lib, 8, Flat, 20.0, None, 40.0, 160.0);
    check(&lib, 21, Flat, 2.5, None, 5.0, 20.0);
    check(&lib, 43, Flat, 10.5, None, 21.0, 84.0);
    let t1 = lib.tool(1).unwrap();
    assert_eq!(t1.place, format!("{}:1", lib.file_name()));
    assert_eq!(
        t1.defaulted,
        ["flute_length", "stickout", "shank_diameter", "flutes"]
    );
    assert!(t1.notes.iter().any(|n| n == "flat end from the comment"));
    assert!(lib.tool(21).unwrap().notes[0].starts_with("a drill"));
    assert_eq!(skipped(&lib), [(Some(20), "a center drill".to_string())]);
}

#[test]
fn linuxcnc_table_of_a_metric_mill() {
    // gardnervickers/mymill: Z offsets, shapes and flutes in the comments.
    let lib = read("linuxcnc/gardnervickers_mymill.tbl", None);
    assert_eq!(lib.tools.len(), 24);
    // T12 Z+89.064367 D+6.350000 ; 2Fl 1/4in Ball End Mill (Purple)
    check(&lib, 12, Ball, 6.35, None, 12.7, 50.8);
    let t12 = lib.tool(12).unwrap();
    assert_eq!(t12.spec.length, Some(89.064367));
    assert_eq!(t12.spec.flutes, 2);
    assert_eq!(
        t12.defaulted,
        ["flute_length", "stickout", "shank_diameter"]
    );
    // T13 ; 2Fl 1/8in HSS Flat End Mill
    check(&lib, 13, Flat, 3.175, None, 6.35, 25.4);
    // T26 D+4.762500 ; … 2 Flute Ball Nose, 5/8 LOC
    check(&lib, 26, Ball, 4.7625, None, 9.525, 38.1);
    // T25: "with Corner Radius" but no size: flat, said.
    check(&lib, 25, Flat, 3.175, None, 6.35, 25.4);
    assert!(lib.tool(25).unwrap().notes[0].contains("corner radius but not its size"));
    // T22 "1/4 3flt", T31 "1FL": flutes from the comment.
    assert_eq!(lib.tool(22).unwrap().spec.flutes, 3);
    assert_eq!(lib.tool(31).unwrap().spec.flutes, 1);
    // T1 "150 Series High-Speed Steel Jobber": no shape named, flat, said.
    check(&lib, 1, Flat, 1.0, None, 2.0, 8.0);
    assert!(lib.tool(1).unwrap().notes[0].contains("names no shape"));
    assert_eq!(
        skipped(&lib),
        [
            (Some(14), "a face mill".to_string()),
            (Some(15), "a chamfer, spot or engraving tool".to_string()),
            (Some(17), "a thread mill".to_string()),
            (
                Some(21),
                "no diameter (D absent or not above 0)".to_string()
            ),
            (Some(99), "a probe".to_string()),
        ]
    );
}

#[test]
fn linuxcnc_table_in_inches_with_a_qtpyvcp_header() {
    // KurtJacobson/RF45-config (LINEAR_UNITS = inch): a QtPyVCP header
    // before the entries, a negative and a zero D, X/Y words.
    let lib = read("linuxcnc/kurtjacobson_rf45.tbl", Some(TableUnits::Inch));
    assert_eq!(numbers(&lib), [4, 5, 6, 7, 8, 9]);
    check(&lib, 4, Flat, 2.5 * IN, None, 5.0 * IN, 20.0 * IN);
    check(&lib, 7, Ball, 0.25 * IN, None, 0.5 * IN, 2.0 * IN);
    check(&lib, 9, Flat, 0.125 * IN, None, 0.25 * IN, IN);
    assert!(lib.tool(9).unwrap().notes[0].starts_with("a drill"));
    assert_eq!(
        skipped(&lib),
        [
            (Some(1), "no diameter (D absent or not above 0)".to_string()),
            (Some(2), "no diameter (D absent or not above 0)".to_string()),
            (Some(3), "a face mill".to_string()),
        ]
    );
    assert_eq!(lib.notes.len(), 1);
    assert!(
        lib.notes[0].contains("6 line(s) that are no tool entry"),
        "{:?}",
        lib.notes
    );
    // The same table read in mm is 25.4 times smaller.
    let mm = read("linuxcnc/kurtjacobson_rf45.tbl", None);
    check(&mm, 4, Flat, 2.5, None, 5.0, 20.0);
}

#[test]
fn linuxcnc_tables_of_a_hackspace_and_an_inch_mill() {
    // bristolhackspace/cnc-mill: T10 D+2 ;2mm endmill, T12 D+3 Z+25.961501 ;3mm drill.
    let lib = read("linuxcnc/bristolhackspace_cnc_mill.tbl", None);
    assert_eq!(numbers(&lib), [10, 11, 12]);
    check(&lib, 10, Flat, 2.0, None, 4.0, 16.0);
    check(&lib, 12, Flat, 3.0, None, 6.0, 24.0);
    assert_eq!(lib.tool(12).unwrap().spec.length, Some(25.961501));
    assert_eq!(lib.skipped.len(), 6);
    // MrNinefinger/IH-12Z-MILL (inch): T10 D0.5 Z-21.777532 ;1/2" endmill
    // holder, 2 flute 1/2" endmill hss.
    let lib = read("linuxcnc/mrninefinger_ih12z.tbl", Some(TableUnits::Inch));
    assert_eq!(numbers(&lib), [3, 6, 10, 14, 16, 18]);
    check(&lib, 10, Flat, 12.7, None, 25.4, 101.6);
    let t10 = lib.tool(10).unwrap();
    assert!((t10.spec.length.unwrap() - -21.777532 * IN).abs() < 1e-9);
    assert_eq!(t10.spec.flutes, 2);
    check(&lib, 3, Flat, 0.125 * IN, None, 0.25 * IN, IN);
}

#[test]
fn fusion_library_of_a_bt30_mill() {
    // kmhbg/centroid-fusion-tool-sync "Library 260122.json", millimeters.
    let lib = read("fusion/kmhbg_library_260122.json", None);
    assert_eq!(
        numbers(&lib),
        [1, 2, 3, 4, 5, 8, 9, 12, 13, 14, 15, 16, 17, 20, 22, 23]
    );
    // "4mm 2F R2 round", ball end mill: DC 4, LCF 4, LB 29.5, NOF 2, SFDM 6.
    check(&lib, 12, Ball, 4.0, None, 4.0, 29.5);
    let t12 = &lib.tool(12).unwrap().spec;
    assert_eq!((t12.flutes, t12.shank_diameter), (2, Some(6.0)));
    check(&lib, 13, Ball, 8.0, None, 14.0, 26.0);
    // "12mm 2F end mill": DC 12, LCF 35.15, LB 38.35.
    check(&lib, 5, Flat, 12.0, None, 35.15, 38.35);
    // "22mm 5f flat end mill": NOF 5, SFDM 20.
    check(&lib, 23, Flat, 22.0, None, 38.0, 57.0);
    assert_eq!(lib.tool(23).unwrap().spec.flutes, 5);
    // "Drill chuck 1-6mm", a drill: DC 2.5, LCF 30, LB 30.
    check(&lib, 20, Flat, 2.5, None, 30.0, 30.0);
    assert!(lib.tool(20).unwrap().notes[0].starts_with("a drill"));
    // Everything given: nothing defaulted.
    assert!(lib.tools.iter().all(|t| t.defaulted.is_empty()));
    assert_eq!(
        skipped(&lib),
        [
            (Some(11), "a chamfer mill".to_string()),
            (Some(21), "a face mill".to_string()),
        ]
    );
    // Its .tools export (a zip of tools.json) reads to the same tools.
    let zipped = read("fusion/kmhbg_library_260122.tools", None);
    assert_eq!(zipped.tools.len(), lib.tools.len());
    for (a, b) in zipped.tools.iter().zip(&lib.tools) {
        assert_eq!(format!("{:?}", a.spec), format!("{:?}", b.spec));
    }
    assert!(zipped.tools[0].place.contains(".tools!tools.json: data["));
}

#[test]
fn fusion_library_of_a_datron() {
    // tckaland/Github-Shared-CNC-Tool-Library "IPD Datron.json".
    let lib = read("fusion/tckaland_ipd_datron.json", None);
    assert_eq!(
        numbers(&lib),
        [2, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 22, 23, 24, 25, 26, 27, 28, 29]
    );
    check(&lib, 7, Ball, 2.0, None, 7.0, 25.0);
    check(&lib, 14, Flat, 12.0, None, 6.0, 19.0);
    check(&lib, 6, Flat, 1.0, None, 1.0, 18.0);
    assert_eq!(lib.tool(6).unwrap().spec.flutes, 3);
    // "Superlang ball-nose…": DC 3, LCF 20, LB 65, SFDM 8.
    check(&lib, 29, Ball, 3.0, None, 20.0, 65.0);
    assert_eq!(lib.tool(29).unwrap().spec.shank_diameter, Some(8.0));
    assert_eq!(
        skipped(&lib),
        [
            (Some(21), "a slot mill".to_string()),
            (Some(4), "a chamfer mill".to_string()),
            (Some(3), "a chamfer mill".to_string()),
            (Some(20), "a thread mill".to_string()),
            (None, "a holder".to_string()),
        ]
    );
}

#[test]
fn fusion_library_in_inches_of_a_router_bit_vendor() {
    // IDC Woodcraft's library (radclifferr/websocket-trial), inches.
    let lib = read("fusion/idc_woodcraft_sampledata.json", None);
    assert_eq!(
        numbers(&lib),
        [
            1, 2, 3, 4, 5, 8, 9, 10, 13, 15, 16, 18, 19, 20, 32, 33, 34, 35, 36, 46, 51, 52, 53,
            56, 66, 67
        ]
    );
    // "1" Bowl Bit, 1/4" Shank", bull nose end mill: DC 1, RE 0.375, LCF 0.75, LB 1.
    check(&lib, 56, Bull, IN, Some(0.375 * IN), 0.75 * IN, IN);
    assert_eq!(lib.tool(56).unwrap().spec.shank_diameter, Some(0.25 * IN));
    // "1/8" Ball Nose": DC 0.125, LCF 0.5, LB 0.9.
    check(&lib, 32, Ball, 0.125 * IN, None, 0.5 * IN, 0.9 * IN);
    // "1/32" Downcut": DC 0.03125, LCF 0.1875, LB 0.4.
    check(&lib, 1, Flat, 0.03125 * IN, None, 0.1875 * IN, 0.4 * IN);
    // "1/8" Acrylic O Flute": NOF 1.
    assert_eq!(lib.tool(52).unwrap().spec.flutes, 1);
    check(&lib, 66, Flat, 0.125 * IN, None, 0.75 * IN, 1.25 * IN);
    let reasons: Vec<String> = lib.skipped.iter().map(|s| s.reason.clone()).collect();
    assert_eq!(lib.skipped.len(), 18);
    for r in [
        "a chamfer mill",
        "a tapered mill",
        "a slot mill",
        "a radius mill",
    ] {
        assert!(reasons.iter().any(|x| x == r), "{r}");
    }
}

#[test]
fn freecad_default_library_and_its_bits() {
    // FreeCAD's src/Mod/CAM/Tools/Library/Default.fctl, bits in ../Bit.
    let lib = read("freecad/freecad_cam/Library/Default.fctl", None);
    assert_eq!(numbers(&lib), [1, 2, 3, 4]);
    // 5mm_Endmill: Diameter 5, CuttingEdgeHeight 30, Length 50,
    // ShankDiameter 3: stick-out 50 − 3 × 3 = 41 (defaulted).
    check(&lib, 1, Flat, 5.0, None, 30.0, 41.0);
    assert_eq!(lib.tool(1).unwrap().defaulted, ["stickout", "flutes"]);
    // 5mm_Drill: Diameter 5, Length 50; flute 2 × D, shank D, stick-out 50 − 15.
    check(&lib, 2, Flat, 5.0, None, 10.0, 35.0);
    // 6mm_Ball_End: Diameter 6, CuttingEdgeHeight 40, Length 50, shank 3.
    check(&lib, 3, Ball, 6.0, None, 40.0, 41.0);
    assert_eq!(lib.tool(3).unwrap().spec.shank_diameter, Some(3.0));
    // 6mm_Bullnose: CornerRadius 1.5.
    check(&lib, 4, Bull, 6.0, Some(1.5), 40.0, 41.0);
    assert_eq!(lib.files.len(), 13);
    let shapes: Vec<String> = lib.skipped.iter().map(|s| s.reason.clone()).collect();
    assert_eq!(
        shapes,
        [
            "shape v-bit",
            "shape v-bit",
            "shape v-bit",
            "shape v-bit",
            "shape chamfer",
            "shape slittingsaw",
            "shape probe",
            "shape thread-mill"
        ]
    );
    // A single bit is tool 1.
    let bit = read("freecad/freecad_cam/Bit/6mm_Bullnose.fctb", None);
    assert_eq!(numbers(&bit), [1]);
    check(&bit, 1, Bull, 6.0, Some(1.5), 40.0, 41.0);
}

#[test]
fn freecad_libraries_of_better_tool_library() {
    // knipknap/better-tool-library's test libraries: decimal commas, "1 cm",
    // a torus, btl-stickout attributes.
    let lib = read("freecad/better_tool_library/Library/Default.fctl", None);
    assert_eq!(numbers(&lib), [6, 14, 23, 24, 38, 41, 46, 48]);
    // "D12,65mm L26mm S8": 12,65 mm, 26,0, Length 58,5, shank 8: 58.5 − 24.
    check(&lib, 6, Flat, 12.65, None, 26.0, 34.5);
    check(&lib, 14, Ball, 2.5, None, 12.0, 38.0 - 3.0 * 3.17);
    check(&lib, 23, Flat, 1.5, None, 4.0, 38.0);
    assert_eq!(lib.tool(23).unwrap().spec.flutes, 4);
    // btl-stickout "18 mm", Flutes "1".
    check(&lib, 24, Flat, 3.17, None, 15.0, 18.0);
    assert_eq!(lib.tool(24).unwrap().spec.flutes, 1);
    assert!(lib.tool(24).unwrap().defaulted.is_empty());
    // btl-stickout "1 cm".
    check(&lib, 38, Flat, 1.0, None, 7.0, 10.0);
    // "New Torus": TorusRadius 1,0 mm, btl-stickout 33 mm.
    check(&lib, 46, Bull, 5.0, Some(1.0), 30.0, 33.0);
    check(&lib, 41, Flat, 3.0, None, 6.0, 25.0);
    assert_eq!(lib.skipped.len(), 7);
    let other = read(
        "freecad/better_tool_library/Library/a8da3550-3879-11ee-aa8d-537499fddd29.fctl",
        None,
    );
    assert_eq!(numbers(&other), [1]);
    check(&other, 1, Flat, 1.0, None, 7.0, 10.0);
}

#[test]
fn comments_name_shapes() {
    use linuxcnc::{named, Named};
    let shape = |c: &str| match named(c) {
        Named::Shape(k, r, _) => format!("{k:?} {r:?}"),
        Named::Not(why) => why,
    };
    assert_eq!(shape("6mm bull nose R0.5"), "Bull Some(0.5)");
    assert_eq!(shape("corner radius 1,5 endmill"), "Bull Some(1.5)");
    assert_eq!(shape("#7 tap drill"), "Flat None");
    assert_eq!(shape("M6 tap"), "a tap");
    assert_eq!(shape("1/4 tapered ball nose"), "a tapered mill");
    assert_eq!(shape("ballnose 3mm"), "Ball None");
    assert_eq!(shape("touch probe"), "a probe");
    assert_eq!(shape("90 deg V-bit"), "a V-bit");
    assert_eq!(freecad::quantity("6,0 mm"), Some(6.0));
    assert_eq!(freecad::quantity("1 cm"), Some(10.0));
    assert_eq!(freecad::quantity("0.25 in"), Some(6.35));
    assert_eq!(freecad::quantity("25,0 μm"), Some(0.025));
    assert_eq!(freecad::quantity("3"), Some(3.0));
    assert_eq!(freecad::quantity("119.0 °"), None);
}

#[test]
fn malformed_libraries_are_refused_at_their_line() {
    let e = error_of("t.tbl", "T1 P1 D6 ;ok\nT2 P2 Dx6 ;bad\n", None);
    assert!(e.contains("t.tbl:2:7: \"Dx6\": D needs a number"), "{e}");
    let e = error_of("t.tbl", "T1 P1 D6\nT2 K3 D6\n", None);
    assert!(
        e.contains("t.tbl:2:4: \"K3\" is not a tool table word"),
        "{e}"
    );
    // A value out of a [tool] key's range: the file, line and tool.
    let e = error_of("t.tbl", "T1 P1 D6\nT7 P7 D0.001 ;end mill\n", None);
    assert!(
        e.contains("t.tbl:2: T7.diameter (mm) must lie in 0.005..500, got 0.001"),
        "{e}"
    );
    let e = error_of("t.tbl", "T1 P1 D6 ;bull R4\n", None);
    assert!(
        e.contains(
            "t.tbl:1: T1.corner_radius (mm) must lie strictly between 0 and half the diameter"
        ),
        "{e}"
    );
    let e = error_of("t.tbl", "T1 P1 D6\nT1 P2 D4\n", None);
    assert!(e.contains("tool T1 is in the library twice"), "{e}");
    let e = error_of("t.tbl", "T1 P1 ;probe\n", None);
    assert!(e.contains("has no tool the simulator can model"), "{e}");
    // JSON: the line and column of the syntax error.
    let e = error_of(
        "lib.json",
        "{\"data\": [\n  {\"type\": \"flat end mill\",,}\n]}",
        None,
    );
    assert!(
        e.contains("lib.json:2:28: not a Fusion 360 tool library (JSON)"),
        "{e}"
    );
    let e = error_of(
        "lib.json",
        r#"{"data": [{"type": "flat end mill", "unit": "millimeters", "geometry": {"DC": 6, "LCF": 30, "LB": 20}, "post-process": {"number": 3}}]}"#,
        None,
    );
    assert!(
        e.contains("lib.json: data[0]: T3.flute_length (30 mm) is longer than T3.stickout (20 mm)"),
        "{e}"
    );
    let e = error_of("lib.json", r#"{"data": []}"#, Some(TableUnits::Inch));
    assert!(
        e.contains("tool_library.units is for a LinuxCNC tool table"),
        "{e}"
    );
    let e = error_of(
        "x.fctl",
        r#"{"tools": [{"nr": 1, "path": "missing.fctb"}]}"#,
        None,
    );
    assert!(
        e.contains("x.fctl: tools[0]: the bit \"missing.fctb\" of tool 1 is not in the Bit folder"),
        "{e}"
    );
    let e = error_of(
        "x.fctb",
        "{\"shape\": \"endmill.fcstd\", \"parameter\": {\"Diameter\": \"six mm\"}}",
        None,
    );
    assert!(
        e.contains("x.fctb: parameter Diameter \"six mm\" is not a length"),
        "{e}"
    );
}

#[test]
fn a_job_takes_the_library_under_its_own_tools() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.tbl"),
        "T1 P1 D6 Z10 ;ball\nT2 P2 D4 ;end mill\n",
    )
    .unwrap();
    let job = |extra: &str| {
        format!(
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [10, 10, 10]\ngrid = 0.5\n[program]\npath = \"p.nc\"\n[tool_library]\npath = \"t.tbl\"\n{extra}"
        )
    };
    let parsed = Job::parse(&job(""), "job.toml", dir.path()).unwrap();
    assert_eq!(parsed.tools.len(), 2);
    assert_eq!(parsed.library_tools, 2);
    assert_eq!(parsed.tools[0].kind, Ball);
    assert_eq!(parsed.tools[0].length, Some(10.0));
    // A [[tools]] entry of the same number wins, and is said.
    let parsed = Job::parse(
        &job("[[tools]]\nnumber = 2\nkind = \"flat\"\ndiameter = 8\n"),
        "job.toml",
        dir.path(),
    )
    .unwrap();
    assert_eq!(parsed.tools.len(), 2);
    assert_eq!(parsed.tools[0].diameter, 8.0);
    assert_eq!(parsed.tools[1].number, Some(1));
    let lib = parsed.library.as_ref().unwrap();
    assert_eq!(lib.replaced, [2]);
    let said = notes(lib, &[1, 2]);
    assert!(said[0].contains("T1 ("), "{said:?}");
    assert!(
        said.iter()
            .any(|n| n.contains("T2 replaced by the job's [[tools]]")),
        "{said:?}"
    );
    // A single [tool] cannot be combined with a library.
    let e = Job::parse(
        &job("[tool]\nkind = \"flat\"\ndiameter = 8\n"),
        "job.toml",
        dir.path(),
    )
    .unwrap_err()
    .chain_message();
    assert!(e.contains("a single [tool] cuts every T"), "{e}");
    // The library's error at the job's [tool_library] key.
    std::fs::write(dir.path().join("t.tbl"), "T1 P1 D-x\n").unwrap();
    let e = Job::parse(&job(""), "job.toml", dir.path())
        .unwrap_err()
        .chain_message();
    assert!(e.starts_with("job.toml:9:1: tool_library: "), "{e}");
    assert!(e.contains("t.tbl:1:7"), "{e}");
}

/// Every real library gives the tools and skips the entries its file holds
/// (the counts read from the files by hand: a reader that loses or invents
/// an entry fails here); with `--nocapture` the tools one line each, as
/// listed in the closing note: `cargo test --release -p dexcut --lib
/// every_real_library_gives_its_tools -- --nocapture`.
#[test]
fn every_real_library_gives_its_tools() {
    let inch = Some(TableUnits::Inch);
    for (rel, units, tools, skipped) in [
        ("linuxcnc/linuxcnc_ncam_demo_mill_mm.tbl", None, 19, 1),
        ("linuxcnc/gardnervickers_mymill.tbl", None, 24, 5),
        ("linuxcnc/kurtjacobson_rf45.tbl", inch, 6, 3),
        ("linuxcnc/bristolhackspace_cnc_mill.tbl", None, 3, 6),
        ("linuxcnc/mrninefinger_ih12z.tbl", inch, 6, 17),
        ("fusion/kmhbg_library_260122.json", None, 16, 2),
        ("fusion/kmhbg_library_260122.tools", None, 16, 2),
        ("fusion/tckaland_ipd_datron.json", None, 19, 5),
        ("fusion/idc_woodcraft_sampledata.json", None, 26, 18),
        ("freecad/freecad_cam/Library/Default.fctl", None, 4, 8),
        (
            "freecad/better_tool_library/Library/Default.fctl",
            None,
            8,
            7,
        ),
        (
            "freecad/better_tool_library/Library/a8da3550-3879-11ee-aa8d-537499fddd29.fctl",
            None,
            1,
            0,
        ),
    ] {
        let lib = read(rel, units);
        assert_eq!(
            (lib.tools.len(), lib.skipped.len()),
            (tools, skipped),
            "{rel}"
        );
        println!(
            "\n### {rel}: {} tools, {} skipped",
            lib.tools.len(),
            lib.skipped.len()
        );
        let base = lib.file_name();
        for t in &lib.tools {
            let s = &t.spec;
            let shape = match s.kind {
                Bull => format!("bull r{}", mm(s.corner_radius.unwrap_or(0.0))),
                k => format!("{k:?}").to_lowercase(),
            };
            println!(
                "- T{} {:?}: {shape} Ø{} mm, flute {} mm, stickout {} mm, shank Ø{} mm, {} flutes, length {} mm{}",
                t.number,
                t.name,
                mm(s.diameter),
                mm(s.flute_length.unwrap_or(0.0)),
                mm(s.stickout.unwrap_or(0.0)),
                mm(s.shank_diameter.unwrap_or(0.0)),
                s.flutes,
                mm(s.length.unwrap_or(0.0)),
                if t.defaulted.is_empty() {
                    String::new()
                } else {
                    format!(" (defaulted: {})", t.defaulted.join(", "))
                }
            );
        }
        if !lib.skipped.is_empty() {
            println!(
                "- skipped: {}",
                skipped_list(&lib.skipped).replace(&base, "")
            );
        }
    }
}

/// `[operations.tool_library]`: an operation's library gives its tools (the
/// job's library does not reach an operation that gives its own tools), and
/// an error in it names the operation's key.
#[test]
fn an_operation_takes_its_own_tool_library() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("a.tbl"),
        "T1 P1 D6 ;ball\nT2 P2 D4 ;end mill\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("b.tbl"), "T7 P7 D10 Z5 ;end mill\n").unwrap();
    let job = |ops: &str| {
        format!(
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [10, 10, 10]\ngrid = 0.5\n\
             [tool_library]\npath = \"a.tbl\"\n{ops}"
        )
    };
    let parsed = Job::parse(
        &job("[[operations]]\nname = \"rough\"\nprogram = \"r.nc\"\n\
              [[operations]]\nname = \"finish\"\nprogram = \"f.nc\"\n\
              [operations.tool_library]\npath = \"b.tbl\"\n\
              [[operations]]\nname = \"last\"\nprogram = \"l.nc\"\n\
              [[operations.tools]]\nnumber = 3\nkind = \"flat\"\ndiameter = 2\n"),
        "job.toml",
        dir.path(),
    )
    .unwrap_or_else(|e| panic!("{}", e.chain_message()));
    let ops = &parsed.operation_jobs;
    let numbers = |j: &Job| {
        j.tools
            .iter()
            .map(|t| t.number.unwrap())
            .collect::<Vec<_>>()
    };
    // The job's library for the operation that gives no tools.
    assert_eq!(numbers(&ops[0].job), [1, 2]);
    assert_eq!(ops[0].job.library_tools, 2);
    // The operation's own library: T7, its Z the gauge length.
    assert_eq!(numbers(&ops[1].job), [7]);
    assert_eq!(ops[1].job.tools[0].length, Some(5.0));
    assert!(ops[1].job.library.as_ref().unwrap().path.ends_with("b.tbl"));
    // Its own [[tools]]: no library.
    assert_eq!(numbers(&ops[2].job), [3]);
    assert!(ops[2].job.library.is_none() && ops[2].job.own_tools().len() == 1);
    let e = Job::parse(
        &job("[[operations]]\nname = \"rough\"\nprogram = \"r.nc\"\n\
              [operations.tool_library]\npath = \"missing.tbl\"\n"),
        "job.toml",
        dir.path(),
    )
    .unwrap_err()
    .chain_message();
    assert!(e.contains("operations[0].tool_library"), "{e}");
    assert!(e.contains("missing.tbl"), "{e}");
}
