//! `dexcut report DIR`: the HTML report, heat maps and 3D stock of a
//! `simulate` or `optimize` output folder, rebuilt from its files.

use std::collections::HashMap;
use std::path::Path;

use anyhow::{bail, Context, Result};
use export::{
    HeatMapStyle, HeightField, PlotGroup, Report, ReportImage, ScalarMap, Series, SummaryRow,
};

use crate::simulate::{GridInfo, Summary, ToolPeaks};
use crate::summary::SummaryDoc;

/// Named numeric columns of a CSV file (empty fields read as NaN).
/// Every wanted column must be in the header, and at least one data row must follow.
fn read_csv_columns(
    path: &Path,
    wanted: &[&str],
    optional: &[&str],
) -> Result<HashMap<String, Vec<f64>>> {
    let mut reader = csv::Reader::from_reader(crate::bounds::open(
        path,
        "results file",
        crate::bounds::MAX_CSV_BYTES,
    )?);
    let headers = reader
        .headers()
        .with_context(|| format!("{}: no header", path.display()))?
        .clone();
    if headers.is_empty() {
        bail!("{}: empty file, no header", path.display());
    }
    let mut index: Vec<(String, usize)> = Vec::new();
    for w in wanted {
        let Some(i) = headers.iter().position(|h| h == *w) else {
            bail!(
                "{}:1: no column {w} in the header (not a dexcut results file, or damaged)",
                path.display()
            );
        };
        index.push((w.to_string(), i));
    }
    for w in optional {
        if let Some(i) = headers.iter().position(|h| h == *w) {
            index.push((w.to_string(), i));
        }
    }
    let mut cols: HashMap<String, Vec<f64>> =
        index.iter().map(|(n, _)| (n.clone(), Vec::new())).collect();
    for (row, record) in reader.records().enumerate() {
        let record = record.with_context(|| format!("{}: bad row {}", path.display(), row + 2))?;
        for (name, i) in &index {
            let raw = record.get(*i).unwrap_or("");
            let v = if raw.is_empty() {
                f64::NAN
            } else {
                raw.parse().with_context(|| {
                    format!(
                        "{}:{}: {name} is not a number: {raw:?}",
                        path.display(),
                        row + 2
                    )
                })?
            };
            cols.get_mut(name).expect("column").push(v);
        }
    }
    if cols.values().all(Vec::is_empty) {
        bail!("{}: no data rows", path.display());
    }
    Ok(cols)
}

/// Per-column maps from columns.csv (results without the `.npy` grid), laid out on the grid.
fn read_maps(
    path: &Path,
    grid: &GridInfo,
    names: &[&str],
    optional: &[&str],
) -> Result<HashMap<String, Vec<f32>>> {
    let mut wanted = vec!["ix", "iy"];
    wanted.extend_from_slice(names);
    let cols = read_csv_columns(path, &wanted, optional)?;
    let rows = cols.get("ix").map_or(0, Vec::len);
    if rows > grid.nx * grid.ny {
        bail!(
            "{}: {rows} rows for a {}×{} grid",
            path.display(),
            grid.nx,
            grid.ny
        );
    }
    let (Some(ix), Some(iy)) = (cols.get("ix"), cols.get("iy")) else {
        bail!("{}: missing ix/iy columns", path.display())
    };
    let mut maps = HashMap::new();
    for name in names.iter().chain(optional) {
        let Some(values) = cols.get(*name) else {
            continue;
        };
        let mut map = vec![f32::NAN; grid.nx * grid.ny];
        for ((x, y), v) in ix.iter().zip(iy).zip(values) {
            let (x, y) = (*x as usize, *y as usize);
            if x < grid.nx && y < grid.ny {
                map[y * grid.nx + x] = *v as f32;
            }
        }
        maps.insert(name.to_string(), map);
    }
    Ok(maps)
}

/// The per-column maps `top_mm`, `error_um` (and `design_um` when written) of
/// a results folder: from the `.npy` grid (`columns.json`), or from
/// columns.csv when the folder has no grid (older results).
fn read_column_maps(dir: &Path, grid: &GridInfo) -> Result<HashMap<String, Vec<f32>>> {
    let json = dir.join(export::COLUMN_GRID_JSON);
    if !json.exists() {
        let csv = dir.join("columns.csv");
        if !csv.exists() {
            bail!(
                "{}: no {} (nor columns.csv): the per-column results are missing",
                dir.display(),
                export::COLUMN_GRID_JSON
            );
        }
        return read_maps(&csv, grid, &["top_mm", "error_um"], &["design_um"]);
    }
    let info = export::read_column_grid_info(dir, crate::bounds::MAX_SUMMARY_BYTES)?;
    if info.grid() != grid.export() {
        bail!(
            "{}: grid {}×{} at {} mm from ({}, {}) differs from summary.json's {}×{} at {} mm from ({}, {})",
            json.display(),
            info.nx,
            info.ny,
            info.spacing_mm,
            info.x0_mm,
            info.y0_mm,
            grid.nx,
            grid.ny,
            grid.spacing_mm,
            grid.x0_mm,
            grid.y0_mm
        );
    }
    let mut maps = HashMap::new();
    for (name, required) in [("top_mm", true), ("error_um", true), ("design_um", false)] {
        match export::read_grid_array_f32(dir, &info, name)? {
            Some(values) => {
                maps.insert(name.to_string(), values);
            }
            None if required => bail!("{}: lists no array {name}", json.display()),
            None => {}
        }
    }
    Ok(maps)
}

fn series(name: &str, unit: &str, cols: &HashMap<String, Vec<f64>>, key: &str) -> Series {
    Series {
        name: name.into(),
        unit: unit.into(),
        t_s: cols.get("t_s").cloned().unwrap_or_default(),
        values: cols.get(key).cloned().unwrap_or_default(),
    }
}

const STEP_COLUMNS: [&str; 5] = [
    "t_s",
    "mrr_mm3_s",
    "feed_mm_min",
    "force_n",
    "deflection_um",
];

/// A summary row: label, unit, decimals and the value it shows.
type Row<T> = (&'static str, &'static str, usize, fn(&T) -> f64);

/// Summary rows of a run.
const ROWS: [Row<Summary>; 10] = [
    ("cycle time", "s", 3, |s| s.cycle_time_s),
    ("peak MRR (≥ 48 ms, ≥ 10 cells)", "mm³/s", 2, |s| {
        s.peak_mrr_windowed_mm3_s
    }),
    ("peak MRR per period", "mm³/s", 2, |s| s.peak_mrr_mm3_s),
    ("peak force", "N", 1, |s| s.peak_force_n),
    ("peak deflection", "µm", 1, |s| s.peak_deflection_um),
    ("removed volume", "mm³", 1, |s| s.removed_volume_mm3),
    ("initial volume", "mm³", 1, |s| s.initial_volume_mm3),
    ("steps", "", 0, |s| s.steps as f64),
    ("shank contact steps", "", 0, |s| {
        s.shank_contact_steps as f64
    }),
    ("rapid collision steps", "", 0, |s| {
        s.rapid_collision_steps as f64
    }),
];

/// Rows per tool (summary `tools`).
const TOOL_ROWS: [Row<ToolPeaks>; 4] = [
    ("removed volume", "mm³", 1, |t| t.removed_volume_mm3),
    ("peak MRR per period", "mm³/s", 2, |t| t.peak_mrr_mm3_s),
    ("peak force", "N", 1, |t| t.peak_force_n),
    ("peak deflection", "µm", 1, |t| t.peak_deflection_um),
];

fn cell(x: f64, unit: &str, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$} {unit}").trim_end().to_string()
    } else {
        "–".into()
    }
}

/// Every file of the folder comes from the run its manifest names: the files
/// it lists have their recorded sizes, and summary.json carries its run id.
fn check_one_run(dir: &Path, summary: &SummaryDoc) -> Result<()> {
    let manifest_path = dir.join(export::atomic::MANIFEST);
    let text =
        crate::bounds::read_text(&manifest_path, "manifest", crate::bounds::MAX_SUMMARY_BYTES)
            .with_context(|| {
                format!(
            "{} is not a complete dexcut results folder (written by an older or interrupted run?)",
            dir.display()
        )
            })?;
    /// manifest.json as `export::atomic::Staging` writes it.
    #[derive(serde::Deserialize)]
    struct Manifest {
        run_id: String,
        files: std::collections::BTreeMap<String, u64>,
    }
    let Manifest { run_id, files } = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not a manifest with run_id and files",
            manifest_path.display()
        )
    })?;
    if summary.run_id() != run_id {
        bail!(
            "{}: summary.json is not from run {run_id} of the manifest: the folder mixes runs",
            dir.display()
        );
    }
    for (name, size) in files {
        let path = dir.join(&name);
        let actual = std::fs::metadata(&path).map(|m| m.len()).ok();
        if actual != Some(size) {
            bail!(
                "{}: {name} is not the file run {run_id} wrote (size {actual:?}, manifest {size}): the folder mixes runs or was changed",
                dir.display()
            );
        }
    }
    Ok(())
}

/// Bytes per column while the report is built (CSV columns as f64, three
/// f32 maps, heat-map pixels), an upper estimate.
const REPORT_BYTES_PER_COLUMN: f64 = 96.0;

/// The grid of summary.json must describe a real grid that fits in memory.
fn check_grid(grid: &GridInfo, path: &Path) -> Result<()> {
    if grid.nx == 0 || grid.ny == 0 {
        bail!(
            "{}: grid nx and ny must be at least 1, got {}×{}",
            path.display(),
            grid.nx,
            grid.ny
        );
    }
    if !(grid.spacing_mm > 0.0 && grid.spacing_mm.is_finite()) {
        bail!(
            "{}: grid spacing_mm must be a positive number, got {}",
            path.display(),
            grid.spacing_mm
        );
    }
    if !(grid.x0_mm.is_finite() && grid.y0_mm.is_finite()) {
        bail!("{}: grid x0_mm and y0_mm must be finite", path.display());
    }
    let Some(columns) = grid.nx.checked_mul(grid.ny) else {
        bail!("{}: grid {}×{} overflows", path.display(), grid.nx, grid.ny);
    };
    crate::bounds::check_memory(
        columns as f64 * REPORT_BYTES_PER_COLUMN,
        &format!(
            "{}: a report of {}×{} columns",
            path.display(),
            grid.nx,
            grid.ny
        ),
    )
}

/// The files [`write_report`] wrote into a results folder.
#[derive(Clone, Debug)]
pub struct ReportFiles {
    /// report.html: tables, plots, maps and the 3D view in one page.
    pub html: std::path::PathBuf,
    /// error_map.png: the predicted shape error.
    pub error_map_png: std::path::PathBuf,
    /// design_map.png, when the run has a `[design]` model.
    pub design_map_png: Option<std::path::PathBuf>,
    /// stock.glb: the final stock coloured by the error.
    pub stock_glb: std::path::PathBuf,
}

/// Build report.html, error_map.png (design_map.png) and stock.glb in `dir`, a
/// folder written by `simulate` or `optimize`, from its files alone.
pub fn write_report(dir: &Path) -> Result<ReportFiles> {
    let summary_path = dir.join("summary.json");
    let summary = crate::summary::read(&summary_path).with_context(|| {
        format!(
            "is {} a `dexcut simulate` or `optimize` output folder?",
            dir.display()
        )
    })?;
    check_one_run(dir, &summary)?;
    let grid = summary.grid().clone();
    check_grid(&grid, &summary_path)?;
    let (before_run, after_run, optimize) = match &summary {
        SummaryDoc::Simulate(s) => (&s.run, None, None),
        SummaryDoc::Optimize(o) => (&o.before, Some(&o.after), Some(o.as_ref())),
    };
    let optimized = optimize.is_some();

    // Time series.
    let after_cols = read_csv_columns(&dir.join("steps.csv"), &STEP_COLUMNS, &[])?;
    let before_cols = if optimized {
        Some(read_csv_columns(
            &dir.join("steps_before.csv"),
            &STEP_COLUMNS,
            &[],
        )?)
    } else {
        None
    };
    let limits = optimize.map(|o| &o.limits);
    let plot = |title: &str, label: &str, unit: &str, key: &str, limit: Option<f64>| {
        let mut group = PlotGroup {
            title: title.into(),
            y_label: label.into(),
            unit: unit.into(),
            series: Vec::new(),
            limit,
        };
        match &before_cols {
            Some(b) => {
                group.series.push(series("before", unit, b, key));
                group
                    .series
                    .push(series("optimised", unit, &after_cols, key));
            }
            None => group
                .series
                .push(series("simulated", unit, &after_cols, key)),
        }
        group
    };
    let plots = vec![
        plot(
            "Material removal rate",
            "MRR",
            "mm³/s",
            "mrr_mm3_s",
            limits.and_then(|l| l.mrr_max_mm3_s),
        ),
        plot("Feed", "feed", "mm/min", "feed_mm_min", None),
        plot(
            "Cutting force",
            "force",
            "N",
            "force_n",
            limits.and_then(|l| l.force_max_n),
        ),
        plot(
            "Tool tip deflection",
            "deflection",
            "µm",
            "deflection_um",
            limits.and_then(|l| l.deflection_max_um),
        ),
    ];

    // Maps and the 3D stock.
    let maps = read_column_maps(dir, &grid)?;
    let egrid = grid.export();
    let error = ScalarMap {
        grid: egrid,
        values: maps.get("error_um").cloned().unwrap_or_default(),
        unit: "µm".into(),
    };
    let error_style = HeatMapStyle {
        title: "Predicted error (+ material left)".into(),
        unit: "µm".into(),
        symmetric: true,
        range: None,
    };
    let mut images = Vec::new();
    let mut design_map_png = None;
    let error_png = export::heat_map_png_bytes(&error, &error_style)?;
    export::atomic::write_bytes(&dir.join("error_map.png"), &error_png)
        .context("cannot write error_map.png")?;
    images.push(ReportImage {
        name: "Predicted shape error from tool deflection (µm, positive = material left)".into(),
        png: error_png,
    });
    if let Some(design) = maps
        .get("design_um")
        .filter(|m| m.iter().any(|v| v.is_finite()))
    {
        let map = ScalarMap {
            grid: egrid,
            values: design.clone(),
            unit: "µm".into(),
        };
        let style = HeatMapStyle {
            title: "Distance to design (+ stock left, - gouge)".into(),
            unit: "µm".into(),
            symmetric: true,
            range: None,
        };
        let png = export::heat_map_png_bytes(&map, &style)?;
        export::atomic::write_bytes(&dir.join("design_map.png"), &png)
            .context("cannot write design_map.png")?;
        design_map_png = Some(dir.join("design_map.png"));
        images.push(ReportImage {
            name: "Final surface against the design model (µm)".into(),
            png,
        });
    }
    let height = HeightField {
        grid: egrid,
        z_mm: maps.get("top_mm").cloned().unwrap_or_default(),
    };
    // 250k vertices keep the embedded GLB near 10 MB (the page stays quick in software WebGL).
    let glb_options = export::GlbOptions {
        max_vertices: 250_000,
        ..export::GlbOptions::default()
    };
    let (glb, _) = export::stock_glb_bytes(&height, Some(&error), &glb_options)?;
    export::atomic::write_bytes(&dir.join("stock.glb"), &glb).context("cannot write stock.glb")?;

    // Summary table and notes.
    let mut rows: Vec<SummaryRow> = ROWS
        .iter()
        .map(|(label, unit, d, value)| SummaryRow {
            key: label.to_string(),
            before: cell(value(before_run), unit, *d),
            after: after_run.map(|a| cell(value(a), unit, *d)),
        })
        .collect();
    // Peaks per tool when more than one tool cuts (summary `tools`).
    if before_run.tools.len() > 1 {
        for (k, t) in before_run.tools.iter().enumerate() {
            for (label, unit, d, value) in TOOL_ROWS {
                rows.push(SummaryRow {
                    key: format!("T{} {label}", t.tool),
                    before: cell(value(t), unit, d),
                    after: after_run
                        .and_then(|a| a.tools.get(k))
                        .map(|a| cell(value(a), unit, d)),
                });
            }
        }
    }
    rows.push(SummaryRow {
        key: "grid".into(),
        before: format!(
            "{} × {} columns at {} mm",
            grid.nx, grid.ny, grid.spacing_mm
        ),
        after: None,
    });
    let mut notes = vec![
        "Force and spindle power from Kienzle's specific cutting force at the mean chip thickness the removal record gives (or S4's F = a·V^n with [cutting] model = \"power_law\"); deflection of the tool as a stepped cantilever (flutes, shank, holder spring) at the contact height, with the band loads superposed; the tool swept again offset by its deflection until removal and deflection agree, so the error map shows what the bent tool left (docs/MODEL.md §3.2, §4.2–4.3, §5.1). Material coefficients are published starting points: calibrate them for the machine at hand.".to_string(),
    ];
    for (label, run) in [
        ("program", Some(before_run)),
        ("optimised program", after_run),
    ] {
        let Some(run) = run else {
            continue;
        };
        for w in run.warnings.iter() {
            notes.push(match w.line {
                Some(l) => format!("Warning ({label}), line {l}: {}", w.message),
                None => format!("Warning ({label}): {}", w.message),
            });
        }
    }
    if let Some(o) = optimize {
        let parts: Vec<String> = o
            .cap_time_share
            .iter()
            .map(|s| format!("{} {:.1} %", s.cap, 100.0 * s.share))
            .collect();
        notes.push(format!(
            "Time at each cap after optimisation: {}.",
            parts.join(", ")
        ));
    }
    if let Some(d) = summary.design() {
        notes.push(format!(
            "Design comparison: largest stock left {:.1} µm, worst gouge {:.1} µm{}.",
            d.max_stock_left_um,
            d.worst_gouge_um,
            d.worst_gouge_line
                .map_or(String::new(), |l| format!(" at program line {l}"))
        ));
        // S1 (MODEL.md §8): every program line beyond tolerance.
        let text: Vec<String> = d
            .lines
            .iter()
            .map(|l| {
                format!(
                    "line {} {} {:.1} µm at ({:.2}, {:.2}) mm over {} columns",
                    l.line, l.kind, l.worst_um, l.x_mm, l.y_mm, l.columns
                )
            })
            .collect();
        if !text.is_empty() {
            notes.push(format!(
                "Program lines beyond tolerance (gouge > {} µm, stock > {} µm): {}.",
                d.gouge_tolerance_um,
                d.stock_tolerance_um,
                text.join("; ")
            ));
        }
    }
    let title = format!(
        "dexcut {} report: {}",
        if optimized {
            "optimisation"
        } else {
            "simulation"
        },
        summary.program()
    );
    let report = Report {
        title,
        summary: rows,
        plots,
        images,
        glb: Some(glb),
        notes,
    };
    export::write_report_html(&dir.join("report.html"), &report)?;
    Ok(ReportFiles {
        html: dir.join("report.html"),
        error_map_png: dir.join("error_map.png"),
        design_map_png,
        stock_glb: dir.join("stock.glb"),
    })
}
