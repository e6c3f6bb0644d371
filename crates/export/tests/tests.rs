//! Read-back tests of every writer: decode the PNG with `image`, parse the GLB
//! with `gltf`, read the CSV back, check the HTML's structure.

mod common;

use std::path::Path;

use export::{ColorScale, Error, Grid, HeatMapStyle, HeightField, ScalarMap, NAN_RGBA};

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn decode(path: &Path) -> image::RgbaImage {
    image::open(path).unwrap().to_rgba8()
}

mod heat_map {
    use super::*;

    #[test]
    fn pixels_match_the_scale_and_nan_is_grey() {
        let dir = tmp();
        let path = dir.path().join("err.png");
        let map = common::error_map();
        let style = HeatMapStyle::new("Shape error", "µm", true);
        export::write_heat_map_png(&path, &map, &style).unwrap();
        let img = decode(&path);
        let (_, layout) = export::heat_map_image(&map, &style).unwrap();
        assert_eq!((img.width(), img.height()), (layout.width, layout.height));
        assert!(img.width() >= 600);
        assert_eq!(layout.px_per_cell, 8, "80 columns upscaled to 640 px");

        // Symmetric scale around zero from the largest |value|.
        let max_abs = map
            .values
            .iter()
            .filter(|v| v.is_finite())
            .fold(0f32, |m, v| m.max(v.abs()));
        assert_eq!(
            layout.scale,
            ColorScale {
                min: -f64::from(max_abs),
                max: f64::from(max_abs),
                palette: export::Palette::Diverging
            }
        );

        for (ix, iy) in [(0, 0), (10, 20), (40, 10), (79, 0), (60, 49)] {
            let v = map.values[map.grid.index(ix, iy)];
            let (px, py) = layout.pixel_of_column(ix, iy).unwrap();
            let expected = layout.scale.rgb(f64::from(v)).unwrap();
            assert_eq!(
                &img.get_pixel(px, py).0[..3],
                &expected,
                "column ({ix},{iy}) value {v}"
            );
        }
        // Positive (material left) is red, negative blue.
        let p = img
            .get_pixel(
                layout.pixel_of_column(0, 5).unwrap().0,
                layout.pixel_of_column(0, 5).unwrap().1,
            )
            .0;
        assert!(p[0] > p[2] + 50, "positive is red: {p:?}");
        let (qx, qy) = layout.pixel_of_column(69, 5).unwrap();
        let q = img.get_pixel(qx, qy).0;
        assert!(q[2] > q[0] + 50, "negative is blue: {q:?}");
        // The hole is NaN grey; +Y is up, so the hole is at the top right.
        let (hx, hy) = layout.pixel_of_column(75, 45).unwrap();
        assert_eq!(img.get_pixel(hx, hy).0, NAN_RGBA);
        assert!(hy < layout.pixel_of_column(75, 5).unwrap().1);
    }

    #[test]
    fn colour_bar_runs_from_max_to_min_with_labels() {
        let map = common::error_map();
        let (img, l) = export::heat_map_image(&map, &HeatMapStyle::new("e", "µm", true)).unwrap();
        let cx = l.bar_left + l.bar_width / 2;
        let top = img.get_pixel(cx, l.bar_top + 1).0;
        let bottom = img.get_pixel(cx, l.bar_top + l.bar_height - 2).0;
        assert_eq!(
            &top[..3],
            &l.scale.rgb_at(1.0 - 1.5 / f64::from(l.bar_height))
        );
        assert!(top[0] > top[2] + 50, "top of bar is red: {top:?}");
        assert!(
            bottom[2] > bottom[0] + 50,
            "bottom of bar is blue: {bottom:?}"
        );
        // Tick labels: dark ink to the right of the bar.
        let ink = (l.bar_left + l.bar_width + 6..l.width)
            .flat_map(|x| (l.bar_top..l.bar_top + l.bar_height).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0[0] < 60)
            .count();
        assert!(ink > 100, "tick labels drawn ({ink} dark pixels)");
    }

    #[test]
    fn large_grids_are_reduced_keeping_the_worst_value() {
        let g = common::grid_at_origin(5000, 300, 0.1);
        let mut values = vec![0.0f32; g.len()];
        values[g.index(2501, 150)] = -30.0;
        values[g.index(10, 10)] = 5.0;
        let map = ScalarMap {
            grid: g,
            values,
            unit: "µm".into(),
        };
        let (img, l) = export::heat_map_image(&map, &HeatMapStyle::new("", "", true)).unwrap();
        assert_eq!(l.cols_per_cell, 3);
        assert!(img.width() <= 2400 + 200);
        let (x, y) = l.pixel_of_column(2501, 150).unwrap();
        assert_eq!(&img.get_pixel(x, y).0[..3], &l.scale.rgb(-30.0).unwrap());
    }

    #[test]
    fn degenerate_maps_still_give_pngs() {
        let dir = tmp();
        let cases = [
            ScalarMap {
                grid: common::grid_at_origin(0, 0, 1.0),
                values: vec![],
                unit: "µm".into(),
            },
            ScalarMap {
                grid: common::grid_at_origin(3, 2, 1.0),
                values: vec![f32::NAN; 6],
                unit: "µm".into(),
            },
            ScalarMap {
                grid: common::grid_at_origin(1, 1, 0.0),
                values: vec![2.0],
                unit: "mm".into(),
            },
            ScalarMap {
                grid: common::grid_at_origin(2, 3000, 1.0),
                values: vec![1.0; 6000],
                unit: "mm".into(),
            },
        ];
        for (k, map) in cases.iter().enumerate() {
            for symmetric in [false, true] {
                let path = dir.path().join(format!("{k}-{symmetric}.png"));
                export::write_heat_map_png(
                    &path,
                    map,
                    &HeatMapStyle::new("degenerate", "", symmetric),
                )
                .unwrap();
                let img = decode(&path);
                assert!(
                    img.width() >= 600 && img.height() >= 200,
                    "{k}: {}×{}",
                    img.width(),
                    img.height()
                );
            }
        }
    }

    #[test]
    fn wrong_length_is_an_error_naming_the_file() {
        let dir = tmp();
        let path = dir.path().join("bad.png");
        let map = ScalarMap {
            grid: common::grid(),
            values: vec![0.0; 3],
            unit: "µm".into(),
        };
        let err =
            export::write_heat_map_png(&path, &map, &HeatMapStyle::new("", "", true)).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("bad.png") && msg.contains("4000") && msg.contains("got 3"),
            "{msg}"
        );
        assert!(!path.exists());
    }
}

mod glb {
    use super::*;

    #[test]
    fn reads_back_with_counts_bounds_and_colours() {
        let dir = tmp();
        let path = dir.path().join("stock.glb");
        let h = common::height_field();
        let map = common::error_map();
        let opts = export::GlbOptions {
            side_walls: false,
            ..Default::default()
        };
        let stats = export::write_stock_glb_with(&path, &h, Some(&map), &opts).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (doc, buffers, _) = gltf::import_slice(&bytes).unwrap();
        let material = h.z_mm.iter().filter(|z| z.is_finite()).count();
        assert_eq!(stats.vertices, material);
        let mesh = doc.meshes().next().unwrap();
        let prim = mesh.primitives().next().unwrap();
        let reader = prim.reader(|b| Some(&buffers[b.index()]));
        let pos: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(pos.len(), material);
        let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        // Full cells: 79×49 minus the cells touching the 10×10 hole (11×11 minus the outside ones).
        let cells = (0..49)
            .flat_map(|j| (0..79).map(move |i| (i, j)))
            .filter(|&(i, j)| {
                [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)]
                    .iter()
                    .all(|&(a, b)| h.z_mm[h.grid.index(a, b)].is_finite())
            });
        assert_eq!(idx.len(), cells.count() * 6);
        assert!(idx.iter().all(|&i| (i as usize) < pos.len()));

        let bb = prim.bounding_box();
        let zs = h.z_mm.iter().copied().filter(|z| z.is_finite());
        let (zlo, zhi) = zs.fold((f32::MAX, f32::MIN), |(a, b), z| (a.min(z), b.max(z)));
        assert_eq!(bb.min, [10.0, -5.0, zlo]);
        assert_eq!(bb.max, [10.0 + 79.0 * 0.5, -5.0 + 49.0 * 0.5, zhi]);

        let colors: Vec<[u8; 4]> = reader.read_colors(0).unwrap().into_rgba_u8().collect();
        // Vertex 0 is column (0, 0): positive error (material left), so red,
        // and the same colour as in the PNG heat map of the same map.
        assert_eq!(pos[0], [10.0, -5.0, h.z_mm[0]]);
        assert!(map.values[0] > 0.0);
        let c = colors[0];
        assert!(c[0] > c[2] + 50 && c[3] == 255, "positive is red: {c:?}");
        let (img, layout) = export::heat_map_image(&map, &HeatMapStyle::new("", "", true)).unwrap();
        let (px, py) = layout.pixel_of_column(0, 0).unwrap();
        assert_eq!(c, img.get_pixel(px, py).0, "GLB and PNG agree on colours");
        let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
        assert!(normals
            .iter()
            .all(|n| (n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0).abs() < 1e-4 && n[2] > 0.0));
    }

    #[test]
    fn walls_reach_the_base_and_face_outwards() {
        let g = common::grid_at_origin(3, 3, 1.0);
        let h = HeightField {
            grid: g,
            z_mm: vec![5.0; 9],
        };
        let opts = export::GlbOptions {
            base_z_mm: Some(-2.0),
            ..Default::default()
        };
        let (bytes, stats) = export::stock_glb_bytes(&h, None, &opts).unwrap();
        // 9 top vertices, 8 boundary edges × 4 wall vertices; 8 + 16 triangles.
        assert_eq!((stats.vertices, stats.triangles), (9 + 32, 8 + 16));
        assert_eq!(stats.min_mm, Some([0.0, 0.0, -2.0]));
        let (doc, buffers, _) = gltf::import_slice(&bytes).unwrap();
        let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
        let r = prim.reader(|b| Some(&buffers[b.index()]));
        let pos: Vec<[f32; 3]> = r.read_positions().unwrap().collect();
        let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
        for t in idx.chunks(3) {
            let [a, b, c] = [pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]];
            let (u, v) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let centre = [
                (a[0] + b[0] + c[0]) / 3.0 - 1.0,
                (a[1] + b[1] + c[1]) / 3.0 - 1.0,
            ];
            let outward = n[0] * centre[0] + n[1] * centre[1] + n[2];
            assert!(outward > 0.0, "triangle {t:?} faces inwards");
        }
    }

    #[test]
    fn big_grids_are_decimated() {
        let g = common::grid_at_origin(1501, 1001, 0.1);
        let h = HeightField {
            grid: g,
            z_mm: vec![1.0; g.len()],
        };
        let opts = export::GlbOptions {
            max_vertices: 100_000,
            side_walls: false,
            ..Default::default()
        };
        let (bytes, stats) = export::stock_glb_bytes(&h, None, &opts).unwrap();
        assert!(
            stats.vertices <= 100_000 && stats.vertices > 50_000,
            "{stats:?}"
        );
        assert!(stats.step > 1);
        assert_eq!(stats.max_mm, Some([150.0, 100.0, 1.0]), "outline kept");
        gltf::Gltf::from_slice(&bytes).unwrap();
    }

    #[test]
    fn empty_stock_is_a_valid_glb() {
        for z in [vec![], vec![f32::NAN; 4], vec![1.0]] {
            let n = (z.len() as f64).sqrt() as usize;
            let h = HeightField {
                grid: common::grid_at_origin(n, n, 1.0),
                z_mm: z,
            };
            let (bytes, stats) =
                export::stock_glb_bytes(&h, None, &export::GlbOptions::default()).unwrap();
            assert_eq!(stats.triangles, 0);
            let (doc, _, _) = gltf::import_slice(&bytes).unwrap();
            assert_eq!(doc.meshes().count(), 0);
        }
    }

    #[test]
    fn mismatched_colour_grid_is_an_error() {
        let h = common::height_field();
        let map = ScalarMap {
            grid: common::grid_at_origin(2, 2, 1.0),
            values: vec![0.0; 4],
            unit: "µm".into(),
        };
        let err =
            export::write_stock_glb(Path::new("/nonexistent/x.glb"), &h, Some(&map)).unwrap_err();
        assert!(
            matches!(&err, Error::AtPath { .. }) && err.to_string().contains("x.glb"),
            "{err}"
        );
    }
}

mod csv_columns {
    use super::*;

    #[test]
    fn rows_skip_all_nan_columns() {
        let dir = tmp();
        let path = dir.path().join("cols.csv");
        let g = Grid {
            nx: 3,
            ny: 2,
            x0_mm: 1.0,
            y0_mm: 2.0,
            spacing_mm: 0.5,
        };
        let z = [1.0, f32::NAN, 3.0, 4.0, f32::NAN, 6.0];
        let e = [0.5, f32::NAN, f32::NAN, -1.0, f32::NAN, 2.0];
        export::write_column_csv(&path, &g, &[("z_mm", &z), ("error_um", &e)]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "ix,iy,x_mm,y_mm,z_mm,error_um",
                "0,0,1,2,1,0.5",
                "2,0,2,2,3,",
                "0,1,1,2.5,4,-1",
                "2,1,2,2.5,6,2"
            ]
        );
    }

    #[test]
    fn empty_and_mismatched() {
        let dir = tmp();
        let path = dir.path().join("empty.csv");
        let g = common::grid_at_origin(0, 0, 1.0);
        export::write_column_csv(&path, &g, &[]).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "ix,iy,x_mm,y_mm\n");
        let err =
            export::write_column_csv(&path, &common::grid(), &[("z_mm", &[1.0][..])]).unwrap_err();
        assert!(
            err.to_string().contains("empty.csv") && err.to_string().contains("z_mm"),
            "{err}"
        );
    }
}

mod report {
    use super::*;

    #[test]
    fn is_self_contained_and_complete() {
        let dir = tmp();
        let path = dir.path().join("report.html");
        export::write_report_html(&path, &common::report()).unwrap();
        let html = std::fs::read_to_string(&path).unwrap();
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert_eq!(html.matches("<svg class=\"plot\"").count(), 4);
        assert_eq!(html.matches("<img ").count(), 1);
        assert!(
            html.contains("src=\"data:image/png;base64,iVBORw0KGgo"),
            "PNG data URI"
        );
        assert!(
            html.contains("id=\"stock-glb\">Z2xURg"),
            "GLB magic in base64"
        );
        assert!(html.contains("&lt;b&gt;escaped&lt;/b&gt; &amp; safe"));
        assert!(html.contains("data-status=\"loading\"") && html.contains("dataset.status='ok'"));
        for banned in ["http://", "https://", "//cdn", "<link"] {
            let without_svg_ns = html.replace("http://www.w3.org/2000/svg", "");
            assert!(
                !without_svg_ns.contains(banned),
                "report references {banned}"
            );
        }
        // The 200 000-sample series is decimated.
        let longest = html
            .split("<path class=\"series\" d=\"")
            .skip(1)
            .map(|p| p.split('"').next().unwrap().matches('L').count())
            .max()
            .unwrap();
        assert!(longest < export::MAX_PLOT_POINTS + 10, "{longest} segments");
        assert!(html.len() < 2_000_000, "{} bytes", html.len());
    }

    #[test]
    fn output_depends_only_on_the_input() {
        let report = common::report();
        let html = export::report_html(&report);
        assert_eq!(
            html,
            export::report_html(&report),
            "same report, same bytes"
        );
        // Each plot clips to its own clip path.
        for k in 0..report.plots.len() {
            assert_eq!(html.matches(&format!("id=\"plot-clip-{k}\"")).count(), 1);
        }
    }

    /// The report's heat map image holds no text: the colour bar's unit,
    /// ticks and labels are page text (SVG) at the rows of their colours,
    /// while the standalone PNG keeps them in the image.
    #[test]
    fn colour_bar_labels_are_page_text() {
        let map = common::error_map();
        let style = HeatMapStyle::new("", "µm", true);
        let (png, frame) = export::heat_map_png_framed(&map, &style).unwrap();
        let [bar_left, bar_top, bar_w, bar_h] = frame.bar_px;
        // Right of the bar (its frame included) the image is blank.
        let right_of_bar = |img: &image::RgbaImage| {
            img.enumerate_pixels()
                .filter(|(x, _, p)| *x > bar_left + bar_w && p.0 != [255, 255, 255, 255])
                .count()
        };
        let framed = image::load_from_memory(&png).unwrap().to_rgba8();
        assert_eq!(right_of_bar(&framed), 0, "text in the report's image");
        let standalone =
            image::load_from_memory(&export::heat_map_png_bytes(&map, &style).unwrap())
                .unwrap()
                .to_rgba8();
        assert!(
            right_of_bar(&standalone) > 50,
            "the PNG file keeps its labels"
        );
        assert_eq!(
            (framed.width(), framed.height()),
            (standalone.width(), standalone.height())
        );
        // Ticks at the rows of their colours inside the bar, each label in the page.
        assert!(frame.bar_ticks.len() >= 3, "{:?}", frame.bar_ticks);
        assert!(
            frame.bar_ticks.windows(2).all(|w| w[0].0 > w[1].0),
            "ascending values, rising rows"
        );
        for (row, _) in &frame.bar_ticks {
            assert!(*row >= f64::from(bar_top) && *row <= f64::from(bar_top + bar_h));
        }
        let mut report = export::Report::default();
        report.images.push(export::ReportImage {
            name: "error".into(),
            png,
            frame: Some(frame.clone()),
        });
        let html = export::report_html(&report);
        let bar = html.split("<g class=\"colour-bar\">").nth(1).unwrap();
        let bar = &bar[..bar.find("</g>").unwrap()];
        assert!(bar.contains(">µm</text>"), "{bar}");
        for (_, label) in &frame.bar_ticks {
            assert!(bar.contains(&format!(">{label}</text>")), "{label}: {bar}");
        }
    }

    #[test]
    fn empty_report_is_valid() {
        let html = export::report_html(&export::Report::default());
        assert!(html.contains("<h1>dexcut report</h1>") && html.ends_with("</html>\n"));
        assert!(!html.contains("id=\"stock-view\""));
    }
}

mod npy {
    use super::*;
    use export::{GridArray, Npy, NpyArray, NpyValues};

    /// Bit patterns, so NaN and −0 compare exactly.
    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn header_is_the_documented_v1_layout() {
        let h = export::npy_header("<f4", &[2, 3]);
        // Magic, version 1.0, little-endian u16 header length.
        assert_eq!(&h[..8], b"\x93NUMPY\x01\x00");
        let len = u16::from_le_bytes([h[8], h[9]]) as usize;
        assert_eq!(h.len(), 10 + len);
        assert_eq!(h.len() % 64, 0, "data starts 64-byte aligned");
        let dict = std::str::from_utf8(&h[10..]).unwrap();
        assert!(dict.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }"));
        assert!(dict.ends_with('\n'));
        // A 1-D shape is written as a one-element tuple.
        let h1 = export::npy_header("<i4", &[5]);
        assert!(std::str::from_utf8(&h1[10..])
            .unwrap()
            .contains("'shape': (5,), }"));
        // 1.0f32 is 0x3f800000, stored little-endian after the header.
        let b = export::npy_bytes(&[1], NpyValues::F32(&[1.0])).unwrap();
        assert_eq!(&b[b.len() - 4..], &[0x00, 0x00, 0x80, 0x3f]);
        assert_eq!(b.len(), 128 + 4, "a 68-byte header pads to 128");
    }

    #[test]
    fn f32_and_i32_round_trip_bit_exactly() {
        let f = [
            0.0,
            -0.0,
            1.5,
            -3.25e-7,
            f32::MIN_POSITIVE / 4.0,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            12.345_679,
        ];
        let b = export::npy_bytes(&[2, 5], NpyValues::F32(&f)).unwrap();
        let Npy { shape, data } = export::parse_npy(&b).unwrap();
        assert_eq!(shape, vec![2, 5]);
        let NpyArray::F32(back) = data else {
            panic!("not f32")
        };
        assert_eq!(bits(&back), bits(&f));
        let i = [i32::MIN, -1, 0, 1, 16_777_217, i32::MAX];
        let b = export::npy_bytes(&[6], NpyValues::I32(&i)).unwrap();
        assert_eq!(
            export::parse_npy(&b).unwrap(),
            Npy {
                shape: vec![6],
                data: NpyArray::I32(i.to_vec())
            }
        );
    }

    #[test]
    fn reads_a_header_padded_to_16_bytes_as_older_numpy_wrote_it() {
        let dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (3,), }";
        let mut text = dict.to_string();
        while (10 + text.len() + 1) % 16 != 0 {
            text.push(' ');
        }
        text.push('\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&(text.len() as u16).to_le_bytes());
        b.extend_from_slice(text.as_bytes());
        for v in [1.0f32, 2.0, -4.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        assert_eq!(
            export::parse_npy(&b).unwrap().data,
            NpyArray::F32(vec![1.0, 2.0, -4.0])
        );
    }

    #[test]
    fn damaged_files_are_refused_not_panicked_on() {
        let good = export::npy_bytes(&[2, 2], NpyValues::F32(&[1.0, 2.0, 3.0, 4.0])).unwrap();
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (good[..good.len() - 1].to_vec(), "data bytes"),
            (good[..5].to_vec(), "magic"),
            (b"PK\x03\x04 not npy at all".to_vec(), "magic"),
            (
                {
                    let mut b = good.clone();
                    let s = b.windows(5).position(|w| w == b"False").unwrap();
                    b[s..s + 5].copy_from_slice(b"True ");
                    b
                },
                "Fortran",
            ),
            (
                {
                    let mut b = good.clone();
                    let s = b.windows(3).position(|w| w == b"<f4").unwrap();
                    b[s..s + 3].copy_from_slice(b"<c8");
                    b
                },
                "dtype <c8",
            ),
            (
                {
                    let mut b = good.clone();
                    b[8] = 0xff;
                    b[9] = 0xff;
                    b
                },
                "past the end",
            ),
            (
                {
                    let mut b = good.clone();
                    let s = b.windows(6).position(|w| w == b"(2, 2)").unwrap();
                    b[s..s + 6].copy_from_slice(b"(2, x)");
                    b
                },
                "tuple of sizes",
            ),
            (
                // Read as 8-byte values, the 16 data bytes are two, not four.
                {
                    let mut b = good.clone();
                    let s = b.windows(3).position(|w| w == b"<f4").unwrap();
                    b[s..s + 3].copy_from_slice(b"<f8");
                    b
                },
                "8-byte values needs 32 data bytes, the file has 16",
            ),
        ];
        for (bytes, needle) in cases {
            let e = export::parse_npy(&bytes).unwrap_err().to_string();
            assert!(e.contains(needle), "{e:?} should mention {needle:?}");
        }
        assert!(export::npy_bytes(&[3], NpyValues::F32(&[1.0])).is_err());
    }

    #[test]
    fn column_grid_folder_round_trips() {
        let dir = tmp();
        let grid = Grid {
            nx: 7,
            ny: 3,
            x0_mm: -1.25,
            y0_mm: 40.0,
            spacing_mm: 0.05,
        };
        let top: Vec<f32> = (0..21)
            .map(|i| if i % 5 == 0 { f32::NAN } else { i as f32 * 0.1 })
            .collect();
        let last: Vec<i32> = (0..21).map(|i| i * 1000 - 1).collect();
        export::write_column_grid(
            dir.path(),
            &grid,
            &[
                GridArray {
                    name: "top_mm",
                    unit: "mm",
                    meaning: "top",
                    values: NpyValues::F32(&top),
                },
                GridArray {
                    name: "last_step",
                    unit: "1",
                    meaning: "step",
                    values: NpyValues::I32(&last),
                },
            ],
        )
        .unwrap();
        let info = export::read_column_grid_info(dir.path(), 1 << 20).unwrap();
        assert_eq!(info.grid(), grid);
        assert_eq!(info.arrays.len(), 2);
        assert_eq!(info.arrays[1].dtype, "<i4");
        let back = export::read_grid_array_f32(dir.path(), &info, "top_mm")
            .unwrap()
            .unwrap();
        assert_eq!(bits(&back), bits(&top));
        assert!(export::read_grid_array_f32(dir.path(), &info, "design_um")
            .unwrap()
            .is_none());
        // The int array is refused as f32, and read back exactly from its file.
        assert!(export::read_grid_array_f32(dir.path(), &info, "last_step").is_err());
        let raw = std::fs::read(dir.path().join("last_step.npy")).unwrap();
        assert_eq!(export::parse_npy(&raw).unwrap().data, NpyArray::I32(last));
        assert_eq!(export::parse_npy(&raw).unwrap().shape, vec![3, 7]);

        // An array of the wrong shape for the grid is refused, naming the file.
        let mut other = info.clone();
        other.nx = 3;
        other.ny = 7;
        let e = export::read_grid_array_f32(dir.path(), &other, "top_mm")
            .unwrap_err()
            .to_string();
        assert!(e.contains("top_mm.npy") && e.contains("shape"), "{e}");
        // A wrong-length array is refused before anything is written.
        let empty = tmp();
        assert!(export::write_column_grid(
            empty.path(),
            &grid,
            &[GridArray {
                name: "x",
                unit: "mm",
                meaning: "",
                values: NpyValues::F32(&[1.0]),
            }],
        )
        .is_err());
        assert_eq!(std::fs::read_dir(empty.path()).unwrap().count(), 0);
    }

    /// A grid written band by band of rows is the same files, byte for byte,
    /// as written at once; a grid with rows missing or too many leaves nothing.
    #[test]
    fn column_grid_written_by_rows_equals_written_at_once() {
        let grid = Grid {
            nx: 5,
            ny: 7,
            x0_mm: 0.5,
            y0_mm: -3.0,
            spacing_mm: 0.1,
        };
        let top: Vec<f32> = (0..35).map(|i| i as f32 * 0.25 - 3.0).collect();
        let last: Vec<i32> = (0..35).map(|i| 7 * i - 10).collect();
        let arrays = |top: &'static [f32], last: &'static [i32]| {
            [
                GridArray {
                    name: "top_mm",
                    unit: "mm",
                    meaning: "top",
                    values: NpyValues::F32(top),
                },
                GridArray {
                    name: "last_step",
                    unit: "1",
                    meaning: "step",
                    values: NpyValues::I32(last),
                },
            ]
        };
        let (top, last): (&'static [f32], &'static [i32]) = (top.leak(), last.leak());
        let whole = tmp();
        export::write_column_grid(whole.path(), &grid, &arrays(top, last)).unwrap();
        let banded = tmp();
        let mut w =
            export::ColumnGridWriter::begin(banded.path(), &grid, &arrays(&[], &[])).unwrap();
        for rows in [0..2, 2..3, 3..7] {
            let r = rows.start * 5..rows.end * 5;
            w.write_rows(&[NpyValues::F32(&top[r.clone()]), NpyValues::I32(&last[r])])
                .unwrap();
        }
        // Nothing appears before the end.
        assert_eq!(
            std::fs::read_dir(banded.path())
                .unwrap()
                .filter(|e| !e
                    .as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with('.'))
                .count(),
            0
        );
        w.finish().unwrap();
        for name in ["top_mm.npy", "last_step.npy", "columns.json"] {
            assert_eq!(
                std::fs::read(whole.path().join(name)).unwrap(),
                std::fs::read(banded.path().join(name)).unwrap(),
                "{name}"
            );
        }
        // Rows missing, too many rows or a wrong type: refused, no file left.
        let short = tmp();
        let mut w =
            export::ColumnGridWriter::begin(short.path(), &grid, &arrays(&[], &[])).unwrap();
        w.write_rows(&[NpyValues::F32(&top[..10]), NpyValues::I32(&last[..10])])
            .unwrap();
        assert!(w
            .write_rows(&[NpyValues::I32(&last[..10]), NpyValues::I32(&last[..10])])
            .is_err());
        assert!(w
            .write_rows(&[NpyValues::F32(&top[..30]), NpyValues::I32(&last[..30])])
            .is_err());
        assert!(w.finish().unwrap_err().to_string().contains("2 of 7 rows"));
        assert_eq!(std::fs::read_dir(short.path()).unwrap().count(), 0);
    }

    #[test]
    fn f64_u32_and_u8_round_trip_bit_exactly() {
        let f = [
            0.0,
            -0.0,
            0.1 + 0.2,
            -1.234_567_890_123_456_7e-300,
            f64::MIN_POSITIVE / 8.0,
            f64::MAX,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let b = export::npy_bytes(&[4, 2], NpyValues::F64(&f)).unwrap();
        let dict = std::str::from_utf8(&b[10..128]).unwrap();
        assert!(dict.starts_with("{'descr': '<f8', 'fortran_order': False, 'shape': (4, 2), }"));
        // 1.0f64 is 0x3ff0000000000000, little-endian.
        let one = export::npy_bytes(&[1], NpyValues::F64(&[1.0])).unwrap();
        assert_eq!(&one[128..], &[0, 0, 0, 0, 0, 0, 0xf0, 0x3f]);
        let Npy { shape, data } = export::parse_npy(&b).unwrap();
        assert_eq!(shape, vec![4, 2]);
        let NpyArray::F64(back) = data else {
            panic!("not f64")
        };
        assert_eq!(
            back.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            f.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let u = [0, 1, 7, u32::MAX];
        let b = export::npy_bytes(&[4], NpyValues::U32(&u)).unwrap();
        assert!(std::str::from_utf8(&b[10..128])
            .unwrap()
            .contains("'descr': '<u4'"));
        assert_eq!(
            export::parse_npy(&b).unwrap().data,
            NpyArray::U32(u.to_vec())
        );
        let bytes = [0u8, 1, 255];
        let b = export::npy_bytes(&[3], NpyValues::U8(&bytes)).unwrap();
        // NumPy writes one-byte types without byte order: '|u1'.
        assert!(std::str::from_utf8(&b[10..128])
            .unwrap()
            .contains("'descr': '|u1'"));
        assert_eq!(b.len(), 128 + 3);
        let back = export::parse_npy(&b).unwrap().data;
        assert_eq!(back, NpyArray::U8(bytes.to_vec()));
        assert_eq!(back.to_f64(), vec![0.0, 1.0, 255.0]);
    }

    fn table_columns(width: usize) -> Vec<export::TableColumn<'static>> {
        use export::{NpyType, TableColumn};
        vec![
            TableColumn {
                name: "t_s",
                unit: "s",
                meaning: "time",
                dtype: NpyType::F64,
                width: None,
            },
            TableColumn {
                name: "band_mm3",
                unit: "mm³",
                meaning: "bands",
                dtype: NpyType::F64,
                width: Some(width),
            },
            TableColumn {
                name: "line",
                unit: "1",
                meaning: "line",
                dtype: NpyType::U32,
                width: None,
            },
            TableColumn {
                name: "rapid",
                unit: "1",
                meaning: "flag",
                dtype: NpyType::U8,
                width: None,
            },
        ]
    }

    /// Files of a folder, without the writers' temporary files.
    fn visible(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.'))
            .collect();
        v.sort();
        v
    }

    /// A table written in blocks of rows reads back value for value, its
    /// files are those written at once, and one with rows missing, too many
    /// rows or a wrong type leaves nothing.
    #[test]
    fn npy_table_round_trips_block_by_block() {
        let rows = 7;
        let t: Vec<f64> = (0..rows).map(|i| i as f64 * 0.004 - 1e-17).collect();
        let bands: Vec<f64> = (0..rows * 3)
            .map(|i| if i % 4 == 0 { 0.0 } else { 1.0 / i as f64 })
            .collect();
        let line: Vec<u32> = (0..rows as u32).map(|i| 10 * i + 3).collect();
        let rapid: Vec<u8> = (0..rows).map(|i| u8::from(i % 3 == 0)).collect();
        let values = |r: std::ops::Range<usize>| {
            [
                NpyValues::F64(&t[r.clone()]),
                NpyValues::F64(&bands[3 * r.start..3 * r.end]),
                NpyValues::U32(&line[r.clone()]),
                NpyValues::U8(&rapid[r]),
            ]
        };
        let layout = "row i is step i";
        let whole = tmp();
        let mut w =
            export::NpyTableWriter::begin(whole.path(), "steps", rows, layout, &table_columns(3))
                .unwrap();
        w.write_rows(&values(0..rows)).unwrap();
        w.finish().unwrap();
        let blocks = tmp();
        let mut w =
            export::NpyTableWriter::begin(blocks.path(), "steps", rows, layout, &table_columns(3))
                .unwrap();
        for r in [0..2, 2..2, 2..3, 3..7] {
            w.write_rows(&values(r)).unwrap();
        }
        assert!(
            visible(blocks.path()).is_empty(),
            "nothing appears before the end"
        );
        w.finish().unwrap();
        let names = visible(whole.path());
        assert_eq!(
            names,
            [
                "steps.json",
                "steps_band_mm3.npy",
                "steps_line.npy",
                "steps_rapid.npy",
                "steps_t_s.npy"
            ]
        );
        assert_eq!(visible(blocks.path()), names);
        for n in &names {
            assert_eq!(
                std::fs::read(whole.path().join(n)).unwrap(),
                std::fs::read(blocks.path().join(n)).unwrap(),
                "{n}"
            );
        }
        let info = export::read_npy_table_info(blocks.path(), "steps", 1 << 20).unwrap();
        assert_eq!((info.rows, info.layout.as_str()), (rows, layout));
        assert_eq!(info.columns[1].shape, vec![rows, 3]);
        assert_eq!(info.columns[3].dtype, "|u1");
        let read = |name: &str| {
            export::read_npy_table_column(blocks.path(), &info, name, 1 << 20)
                .unwrap()
                .unwrap()
        };
        assert_eq!(read("t_s").data, NpyArray::F64(t.clone()));
        assert_eq!(read("band_mm3").shape, vec![rows, 3]);
        assert_eq!(read("band_mm3").data, NpyArray::F64(bands.clone()));
        assert_eq!(read("line").data, NpyArray::U32(line.clone()));
        assert_eq!(read("rapid").data, NpyArray::U8(rapid.clone()));
        assert!(
            export::read_npy_table_column(blocks.path(), &info, "force_n", 1 << 20)
                .unwrap()
                .is_none()
        );
        // A description that does not match its files is refused, naming the file.
        let mut other = info.clone();
        other.rows = 6;
        other.columns[0].shape = vec![6];
        let e = export::read_npy_table_column(blocks.path(), &other, "t_s", 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("steps_t_s.npy") && e.contains("shape [7]"),
            "{e}"
        );
        let mut other = info.clone();
        other.columns[2].dtype = "<i4".into();
        let e = export::read_npy_table_column(blocks.path(), &other, "line", 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("dtype <u4, the table lists <i4"), "{e}");
        other.columns[2].file = "../steps_line.npy".into();
        assert!(
            export::read_npy_table_column(blocks.path(), &other, "line", 1 << 20)
                .unwrap_err()
                .to_string()
                .contains("not a plain file name")
        );
        assert!(export::read_npy_table_column(blocks.path(), &info, "t_s", 100).is_err());

        // Rows missing, too many rows, a wrong type or width: refused, nothing left.
        let short = tmp();
        let mut w =
            export::NpyTableWriter::begin(short.path(), "steps", rows, layout, &table_columns(3))
                .unwrap();
        w.write_rows(&values(0..2)).unwrap();
        let mut wrong = values(2..4);
        wrong[2] = NpyValues::I32(&[1, 2]);
        assert!(w.write_rows(&wrong).is_err());
        let mut narrow = values(2..4);
        narrow[1] = NpyValues::F64(&bands[..4]);
        assert!(w
            .write_rows(&narrow)
            .unwrap_err()
            .to_string()
            .contains("band_mm3"));
        assert!(w
            .write_rows(&values(0..7))
            .unwrap_err()
            .to_string()
            .contains("9 rows past the 7"));
        assert!(w.finish().unwrap_err().to_string().contains("2 of 7 rows"));
        assert_eq!(std::fs::read_dir(short.path()).unwrap().count(), 0);
        // Names that are not plain are refused before any file is made.
        let mut bad = table_columns(3);
        bad[0].name = "../t";
        assert!(export::NpyTableWriter::begin(short.path(), "steps", rows, layout, &bad).is_err());
        assert!(export::NpyTableWriter::begin(
            short.path(),
            "a/b",
            rows,
            layout,
            &table_columns(3)
        )
        .is_err());
        assert_eq!(std::fs::read_dir(short.path()).unwrap().count(), 0);
    }
}
