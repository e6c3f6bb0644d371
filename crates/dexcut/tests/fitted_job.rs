//! Jobs fitted to the real programs of the corpus (crates/nc/tests/data/real):
//! the cutter each program's comments name, read as its post wrote it, and
//! a stock that holds every feed move.

use std::path::PathBuf;

use dexcut::fitted_job::{fit, tools_in_comments, Shape};

fn real(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../nc/tests/data/real")
        .join(name)
}

/// The fitted job's `[stock]` corners `min` and `max`, mm.
fn stock_corners(job: &toml::Table) -> (Vec<f64>, Vec<f64>) {
    let v = |k: &str| -> Vec<f64> {
        job["stock"][k]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_float().unwrap())
            .collect()
    };
    (v("min"), v("max"))
}

/// The first cutter each program's comments name, against the comment read
/// by hand (its post, the unit it is written in, the value in mm).
#[test]
fn real_programs_name_their_cutters_in_their_posts_forms() {
    let inch = 25.4;
    let expected: [(&str, Option<u32>, Shape, f64); 43] = [
        // Fusion 360: (T1 D=… CR=… - ZMIN=… - kind), in the program's units.
        ("fusion_led_floor_block.nc", Some(1), Shape::Flat, 1.4),
        (
            "fusion_led_floor_1022_block2x2_17bit.nc",
            Some(1),
            Shape::Flat,
            1.7,
        ),
        (
            "fusion_led_floor_1072_face_otherside.nc",
            Some(1),
            Shape::Flat,
            40.0,
        ),
        ("fusion_led_floor_bore.nc", Some(1), Shape::Flat, 2.7),
        (
            "fusion_led_floor_light_holder.nc",
            Some(1),
            Shape::Flat,
            2.7,
        ),
        ("fusion_led_floor_surface.nc", Some(1), Shape::Flat, 40.0),
        (
            "fusion_haas_rebels5_trimmed.nc",
            Some(1),
            Shape::Flat,
            0.125 * inch,
        ),
        (
            "fusion_haas_sprayer_face_inch.nc",
            Some(1),
            Shape::Flat,
            6.0 * inch,
        ),
        (
            "fusion_sprayer_working.tap",
            Some(1),
            Shape::Bull(0.125 * inch),
            2.0 * inch,
        ),
        (
            "fusion_mpcnc_wiggler_door_mill.gcode",
            Some(2),
            Shape::Flat,
            3.175,
        ),
        ("fusion_proxxon_key_pockets.nc", Some(1), Shape::Flat, 1.587),
        ("fusion_tap_heatsink_drill.tap", Some(1), Shape::Flat, 1.0),
        (
            "fusion_tap_heatsink_mill_trimmed.tap",
            Some(2),
            Shape::Flat,
            3.175,
        ),
        // CamBam: ( T0 : 3.175 ), in the program's units (G20 for the engraving).
        (
            "cambam_communicator_trimmed.nc",
            Some(0),
            Shape::Flat,
            3.175,
        ),
        ("cambam_piezagopro.nc", Some(3), Shape::Flat, 3.0),
        (
            "cambam_shapeoko_engrave.txt",
            Some(0),
            Shape::Flat,
            0.0394 * inch,
        ),
        // BlenderCAM, Mastercam, drl2gcode, gcodekit4, OpenBuilds, pygen, SketchUCam, UGS.
        ("blendercam_Op_Cutout_Layers.gcode", None, Shape::Flat, 3.0),
        (
            "mastercam_helix_bores_trimmed.gcode",
            Some(212),
            Shape::Flat,
            3.0,
        ),
        ("drl2gcode_kicad_T02.gcode", Some(2), Shape::Flat, 0.4),
        ("gcodekit4_designer.gcode", None, Shape::Flat, 3.175),
        ("openbuilds_cam_ps2cnc_004.nc", None, Shape::Flat, 1.0),
        ("pygen_norn93_peck_pockets.gcode", None, Shape::Flat, 3.0),
        ("sketchucam_arc_rword_test.gcode", None, Shape::Flat, 3.175),
        ("ugs_designer.gcode", None, Shape::Flat, 3.0),
        // Estlcam's and FreeCAD's tool names.
        ("estlcam11_ps2cnc_004.nc", None, Shape::Flat, 3.0),
        ("estlcam_backplate.nc", None, Shape::Flat, 3.175),
        ("estlcam_enclosure.nc", None, Shape::Flat, 2.0),
        ("estlcam_spool_fixture.nc", None, Shape::Flat, 2.0),
        ("freecad_corner_20_20_adaptive.nc", None, Shape::Flat, 3.0),
        ("freecad_hole_7mm_adaptive.nc", None, Shape::Flat, 6.0),
        // Shop and generator comments in inches.
        (
            "haas_enier_slot_assembly.nc",
            Some(1),
            Shape::Flat,
            0.5 * inch,
        ),
        (
            "camotics_genes_encoder.ngc",
            None,
            Shape::Flat,
            0.049 * inch,
        ),
        (
            "uccnc_sensor_v4_mill_015.nc",
            None,
            Shape::Flat,
            inch / 64.0,
        ),
        (
            "uccnc_sensor_v4_dimension.nc",
            None,
            Shape::Flat,
            inch / 32.0,
        ),
        ("pcb2gcode_outline.ngc", None, Shape::Flat, 0.05906 * inch),
        (
            "pcb2gcode_back_trimmed.ngc",
            None,
            Shape::Flat,
            0.00787 * inch,
        ),
        ("pcb2gcode_drill.ngc", None, Shape::Flat, 0.0157 * inch),
        ("pcb2gcode_milldrill.ngc", None, Shape::Flat, 1.0),
        // FlatCAM, pcb-gcode's drill table (mm beside inches), Fusion's LinuxCNC post.
        (
            "flatcam_kroneum_isolation_trimmed.nc",
            None,
            Shape::Flat,
            0.24,
        ),
        ("flatcam_kroneum_cutout.nc", None, Shape::Flat, 1.5),
        ("pcbgcode_cr78_drill.nc", Some(1), Shape::Flat, 0.8),
        (
            "fusion_linuxcnc_kroneum_base_cutout.nc",
            Some(4),
            Shape::Flat,
            1.5,
        ),
        (
            "fusion_linuxcnc_kroneum_usb_holes.nc",
            Some(2),
            Shape::Flat,
            0.9,
        ),
    ];
    for (name, number, shape, d) in expected {
        let text = String::from_utf8_lossy(&std::fs::read(real(name)).unwrap()).into_owned();
        let found = tools_in_comments(&text);
        let first = found
            .first()
            .unwrap_or_else(|| panic!("{name}: no cutter found"));
        assert_eq!(
            (first.number, first.shape),
            (number, shape),
            "{name}: {}",
            first.source
        );
        assert!(
            (first.diameter_mm - d).abs() < 1e-9,
            "{name}: {} mm against {d} ({})",
            first.diameter_mm,
            first.source
        );
    }
    // Programs that name no cutter give none (the user is asked for --tool).
    for name in [
        "camotics_heart.ngc",
        "linuxcnc_hole_circle.ngc",
        "haas_smiley.nc",
    ] {
        let text = std::fs::read_to_string(real(name)).unwrap();
        assert!(tools_in_comments(&text).is_empty(), "{name}");
    }
}

/// The fitted stock holds every feed move with the tool's radius + 2 mm
/// around it, its top at Z0 and its floor 1 mm under the deepest feed move.
#[test]
fn fitted_stock_holds_the_feed_moves() {
    let fitted = fit(&real("fusion_led_floor_bore.nc"), None, None).unwrap();
    let job: toml::Table = toml::from_str(&fitted.toml).unwrap();
    let stock = &job["stock"];
    let (min, max) = stock_corners(&job);
    assert_eq!(job["tool"]["diameter"].as_float(), Some(2.7));
    assert_eq!(max[2], 0.0);
    // The program's deepest feed move is its ZMIN, -13.3 (its Fusion tool comment).
    assert!((min[2] - (-13.3 - 1.0)).abs() < 1e-9, "{min:?}");
    // About 20 columns across the Ø2.7 tool: 0.1 mm (the largest of 1, 2, 5 × 10^k under 0.135).
    assert_eq!(stock["grid"].as_float(), Some(0.1));
    assert!(fitted
        .notes
        .iter()
        .any(|n| n.contains("line ") && n.contains("D=2.7")));
    assert!(max[0] - min[0] > 2.7 + 4.0 && max[1] - min[1] > 2.7 + 4.0);
}

/// A program whose every X/Y rapid travels below its feed moves is written for a
/// machine whose +Z points to the table: the fitted job says `z_axis = "down"`.
/// In the corpus these are exactly Estlcam 10's three programs (safe height Z-20
/// or Z-25, cuts down to Z+2.5); Estlcam 11's post writes Z up (`G00 Z5`).
/// The stock is fitted in dexcut's Z-up frame: top Z0, 1 mm under the deepest
/// cut (backplate: Z+2.5 in its own frame).
#[test]
fn programs_whose_rapids_travel_under_their_cuts_are_fitted_z_down() {
    let dir = real("");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".md") && !n.ends_with(".txt"))
        .collect();
    names.sort();
    let tool = dexcut::fitted_job::parse_tool_arg("flat:3").unwrap();
    let mut down = Vec::new();
    let mut fitted = 0;
    for name in &names {
        // Programs dexcut refuses (as LinuxCNC does) or with no feed move are skipped.
        let Ok(job) = fit(&real(name), Some(&tool), Some(2.0)) else {
            continue;
        };
        fitted += 1;
        if job.toml.contains("z_axis = \"down\"") {
            down.push(name.clone());
        }
    }
    assert!(fitted > 70, "{fitted} programs fitted");
    assert_eq!(
        down,
        [
            "estlcam_backplate.nc",
            "estlcam_enclosure.nc",
            "estlcam_spool_fixture.nc"
        ]
    );
    let job = fit(&real("estlcam_backplate.nc"), None, None).unwrap();
    let table: toml::Table = toml::from_str(&job.toml).unwrap();
    let (min, max) = stock_corners(&table);
    assert_eq!(max[2], 0.0);
    assert!((min[2] - (-2.5 - 1.0)).abs() < 1e-9, "{}", min[2]);
    assert_eq!(table["machine"]["z_axis"].as_str(), Some("down"));
}

/// A stock too large for ~20 columns across the tool gets the finest grid of 1, 2
/// or 5 × 10^k mm that keeps it at or under 4 M columns (a 2.1 m sprayer face with
/// a Ø3 tool: 0.1 → 0.2 → 0.5 → 1 mm; the step from 0.2 once looped forever).
#[test]
fn a_large_stock_gets_the_finest_grid_under_the_column_limit() {
    let tool = dexcut::fitted_job::parse_tool_arg("flat:3").unwrap();
    let fitted = fit(&real("fusion_haas_sprayer_face_inch.nc"), Some(&tool), None).unwrap();
    let job: toml::Table = toml::from_str(&fitted.toml).unwrap();
    let (min, max) = stock_corners(&job);
    let columns = |g: f64| ((max[0] - min[0]) / g).ceil() * ((max[1] - min[1]) / g).ceil();
    let grid = job["stock"]["grid"].as_float().unwrap();
    assert_eq!(grid, 1.0);
    assert!(columns(grid) <= dexcut::fitted_job::MAX_FITTED_COLUMNS);
    assert!(columns(0.5) > dexcut::fitted_job::MAX_FITTED_COLUMNS);
}
