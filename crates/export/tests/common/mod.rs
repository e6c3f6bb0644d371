//! Synthetic inputs shared by the integration tests.
#![allow(dead_code)]

use export::{Grid, HeightField, PlotGroup, Report, ReportImage, ScalarMap, Series, SummaryRow};

/// A 0.5 mm grid of 80 × 50 columns starting at (10, -5) mm.
pub fn grid() -> Grid {
    Grid {
        nx: 80,
        ny: 50,
        x0_mm: 10.0,
        y0_mm: -5.0,
        spacing_mm: 0.5,
    }
}

/// An `nx` × `ny` grid of `spacing_mm` with column (0, 0) at the origin.
pub fn grid_at_origin(nx: usize, ny: usize, spacing_mm: f64) -> Grid {
    Grid {
        nx,
        ny,
        x0_mm: 0.0,
        y0_mm: 0.0,
        spacing_mm,
    }
}

/// A wavy pocket: top at z = 20 with a dish cut into it, and a hole (NaN) in one corner.
pub fn height_field() -> HeightField {
    let g = grid();
    let mut z = Vec::with_capacity(g.len());
    for iy in 0..g.ny {
        for ix in 0..g.nx {
            let (x, y) = (g.x_mm(ix) - 30.0, g.y_mm(iy) - 7.5);
            let dish = (64.0 - (x * x + y * y) / 4.0).max(0.0).sqrt() as f32;
            let hole = ix >= 70 && iy >= 40;
            z.push(if hole {
                f32::NAN
            } else {
                20.0 - dish + 0.2 * (x as f32 * 0.8).sin()
            });
        }
    }
    HeightField { grid: g, z_mm: z }
}

/// Signed shape error in µm: positive on the left half, negative on the
/// right, NaN where the height field has no material.
pub fn error_map() -> ScalarMap {
    let g = grid();
    let h = height_field();
    let values = (0..g.len())
        .map(|i| {
            let ix = i % g.nx;
            if h.z_mm[i].is_nan() {
                f32::NAN
            } else {
                (40.0 - ix as f32) * 0.5 * (1.0 + 0.3 * ((i / g.nx) as f32 * 0.3).sin())
            }
        })
        .collect();
    ScalarMap {
        grid: g,
        values,
        unit: "µm".into(),
    }
}

pub fn series(name: &str, unit: &str, n: usize, f: impl Fn(f64) -> f64) -> Series {
    let t_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.016).collect();
    let values = t_s.iter().map(|&t| f(t)).collect();
    Series {
        name: name.into(),
        unit: unit.into(),
        t_s,
        values,
    }
}

/// A report with every section filled, including a long series with spikes.
pub fn report() -> Report {
    let mrr = |scale: f64| {
        move |t: f64| {
            let base = 4.0 + 2.0 * (t * 0.7).sin().abs();
            let spike = if (t - 12.0).abs() < 0.05 || (t - 31.0).abs() < 0.05 {
                9.0 * scale
            } else {
                0.0
            };
            base * scale + spike
        }
    };
    let map = error_map();
    let png =
        export::heat_map_png_bytes(&map, &export::HeatMapStyle::new("Shape error", "µm", true))
            .unwrap();
    let (glb, _) =
        export::stock_glb_bytes(&height_field(), Some(&map), &export::GlbOptions::default())
            .unwrap();
    Report {
        title: "dexcut report: pocket.nc".into(),
        summary: vec![
            SummaryRow { key: "machining time".into(), before: "45.0 s".into(), after: Some("40.3 s".into()) },
            SummaryRow { key: "peak MRR".into(), before: "15.1 mm³/s".into(), after: Some("8.0 mm³/s".into()) },
            SummaryRow { key: "max deflection".into(), before: "12.4 µm".into(), after: None },
        ],
        plots: vec![
            PlotGroup {
                title: "Material removal rate".into(),
                y_label: "MRR".into(),
                unit: "mm³/s".into(),
                series: vec![series("before", "mm³/s", 2813, mrr(1.0)), series("after", "mm³/s", 2520, mrr(0.6))],
                limit: Some(8.0),
            },
            PlotGroup {
                title: "Feed".into(),
                y_label: "feed".into(),
                unit: "mm/min".into(),
                series: vec![
                    series("before", "mm/min", 2813, |_| 1500.0),
                    series("after", "mm/min", 2520, |t| 1500.0 + 1200.0 * (t * 0.3).cos().abs()),
                ],
                limit: None,
            },
            PlotGroup {
                title: "Cutting force (long series)".into(),
                y_label: "force".into(),
                unit: "N".into(),
                series: vec![series("before", "N", 200_000, |t| 80.0 + 20.0 * (t * 3.0).sin() + if (t - 1600.0).abs() < 0.01 { 300.0 } else { 0.0 })],
                limit: None,
            },
            PlotGroup { title: "Tool deflection".into(), y_label: "deflection".into(), unit: "µm".into(), series: vec![], limit: None },
        ],
        images: vec![ReportImage { name: "Shape error (µm)".into(), png, frame: None }],
        glb: Some(glb),
        notes: vec!["Deflection is a cantilever estimate; measured values were about half in the source study.".into(), "<b>escaped</b> & safe".into()],
        ..Report::default()
    }
}
