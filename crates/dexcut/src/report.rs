//! `dexcut report DIR`: the HTML report, heat maps and 3D stock of a
//! `simulate` or `optimize` output folder, rebuilt from its files.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{fail, Context as _, Error, Result, ResultExt as _};
use export::{
    HeatMapStyle, HeightField, HotSpot, PlotGroup, ProgramExcerpt, Report, ReportImage, ScalarMap,
    Series, SummaryRow,
};

use crate::model::summary::{GridInfo, OptimizeSummary, Summary, SummaryDoc, ToolPeaks};

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
        .or_results(|| format!("{}: no header", path.display()))?
        .clone();
    if headers.is_empty() {
        fail!(results, "{}: empty file, no header", path.display());
    }
    let mut index: Vec<(String, usize)> = Vec::new();
    for w in wanted {
        let Some(i) = headers.iter().position(|h| h == *w) else {
            fail!(
                results,
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
        let record = record.or_results(|| format!("{}: bad row {}", path.display(), row + 2))?;
        for (name, i) in &index {
            let raw = record.get(*i).unwrap_or("");
            let v = if raw.is_empty() {
                f64::NAN
            } else {
                raw.parse().or_results(|| {
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
        fail!(results, "{}: no data rows", path.display());
    }
    Ok(cols)
}

/// Named step columns of the results table `stem` of a folder: from its
/// `.npy` arrays (`<stem>.json`, the binary form) when written, else from
/// `<stem>.csv`. Every wanted column must be there, with at least one row.
fn read_step_columns(
    dir: &Path,
    stem: &str,
    wanted: &[&str],
    optional: &[&str],
) -> Result<HashMap<String, Vec<f64>>> {
    let json = dir.join(export::npy_table_json(stem));
    let csv = dir.join(format!("{stem}.csv"));
    if !json.exists() {
        if !csv.exists() {
            fail!(
                results,
                "{}: neither {stem}.csv nor {} (the per-step results) is there",
                dir.display(),
                export::npy_table_json(stem)
            );
        }
        return read_csv_columns(&csv, wanted, optional);
    }
    let info = export::read_npy_table_info(dir, stem, crate::bounds::MAX_SUMMARY_BYTES)?;
    if info.rows == 0 {
        fail!(results, "{}: no rows", json.display());
    }
    let mut cols = HashMap::new();
    for (name, required) in wanted
        .iter()
        .map(|w| (w, true))
        .chain(optional.iter().map(|o| (o, false)))
    {
        match export::read_npy_table_column(dir, &info, name, crate::bounds::MAX_CSV_BYTES)? {
            Some(npy) if npy.shape.len() == 1 => {
                cols.insert(name.to_string(), npy.data.to_f64());
            }
            Some(npy) => fail!(
                results,
                "{}: column {name} has shape {:?}, one value per step expected",
                json.display(),
                npy.shape
            ),
            None if required => fail!(
                results,
                "{}: no column {name} (not a dexcut results table, or damaged)",
                json.display()
            ),
            None => {}
        }
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
        fail!(
            results,
            "{}: {rows} rows for a {}×{} grid",
            path.display(),
            grid.nx,
            grid.ny
        );
    }
    let (Some(ix), Some(iy)) = (cols.get("ix"), cols.get("iy")) else {
        fail!(results, "{}: missing ix/iy columns", path.display())
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
pub(crate) fn read_column_maps(dir: &Path, grid: &GridInfo) -> Result<HashMap<String, Vec<f32>>> {
    let json = dir.join(export::COLUMN_GRID_JSON);
    if !json.exists() {
        let csv = dir.join("columns.csv");
        if !csv.exists() {
            fail!(
                results,
                "{}: no {} (nor columns.csv): the per-column results are missing",
                dir.display(),
                export::COLUMN_GRID_JSON
            );
        }
        return read_maps(&csv, grid, &["top_mm", "error_um"], &["design_um"]);
    }
    let info = export::read_column_grid_info(dir, crate::bounds::MAX_SUMMARY_BYTES)?;
    if info.grid() != grid.export() {
        fail!(results,
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
            None if required => fail!(results, "{}: lists no array {name}", json.display()),
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

/// Optional step columns the hot spots need (position, program line, rapid).
const STEP_PLACES: [&str; 4] = ["x", "y", "line", "rapid"];

/// Vertices of the stock embedded in report.html (stock.glb keeps 250 000).
const PAGE_GLB_VERTICES: usize = 40_000;

/// The steps of the largest force, deflection and MRR per period, the deepest
/// gouge and the warnings' lines: what a process engineer looks at first.
fn hot_spots(
    cols: &HashMap<String, Vec<f64>>,
    run: &Summary,
    design: Option<&crate::model::summary::DesignInfo>,
) -> Vec<HotSpot> {
    let col = |k: &str| cols.get(k).map(Vec::as_slice).unwrap_or(&[]);
    let at = |i: usize| {
        let get = |k: &str| col(k).get(i).copied().filter(|v| v.is_finite());
        (
            get("line").map(|l| l as u32),
            get("t_s"),
            get("x").zip(get("y")).map(|(x, y)| [x, y]),
        )
    };
    let mut spots = Vec::new();
    for (what, key, unit, d) in [
        ("largest force", "force_n", "N", 1),
        ("largest deflection", "deflection_um", "µm", 1),
        ("largest MRR per period", "mrr_mm3_s", "mm³/s", 2),
    ] {
        let worst = col(key)
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite() && **v > 0.0)
            .max_by(|a, b| a.1.total_cmp(b.1));
        if let Some((i, v)) = worst {
            let (line, t_s, xy_mm) = at(i);
            spots.push(HotSpot {
                what: what.into(),
                value: format!("{v:.d$} {unit}"),
                line,
                t_s,
                xy_mm,
            });
        }
    }
    if let Some(d) = design.filter(|d| d.worst_gouge_um < 0.0) {
        spots.push(HotSpot {
            what: "deepest gouge".into(),
            value: format!("{:.1} µm", d.worst_gouge_um),
            line: d.worst_gouge_line,
            t_s: None,
            xy_mm: d.worst_gouge_xy_mm,
        });
    }
    // Warnings at a program line: where the line's first step is.
    let lines = col("line");
    for w in run.warnings.iter().take(MAX_WARNING_SPOTS) {
        let Some(l) = w.line else { continue };
        let first = lines.iter().position(|&v| v == f64::from(l));
        let (t_s, xy_mm) = first.map_or((None, None), |i| {
            let (_, t, xy) = at(i);
            (t, xy)
        });
        spots.push(HotSpot {
            what: format!("warning: {}", w.message),
            value: if w.value.is_finite() {
                format!("{:.1} {}", w.value, w.unit)
            } else {
                "–".into()
            },
            line: Some(l),
            t_s,
            xy_mm,
        });
    }
    spots
}

/// Warnings listed among the hot spots (all are in the notes).
const MAX_WARNING_SPOTS: usize = 8;

/// Program lines around each hot spot's line (2 either side), read from the
/// program the steps belong to: optimized.nc for `optimize`, the job's program
/// for `simulate`. None if that file cannot be read any more.
fn program_excerpt(dir: &Path, summary: &SummaryDoc, spots: &[HotSpot]) -> Option<ProgramExcerpt> {
    let file = match summary {
        SummaryDoc::Optimize(_) => dir.join("optimized.nc"),
        SummaryDoc::Simulate(s) => std::path::PathBuf::from(&s.program),
        SummaryDoc::Operations(_) => return None,
    };
    // As the run read it: bytes that are not UTF-8 as Windows-1252.
    let (text, _) = crate::input::program::read_text(&file).ok()?;
    let wanted: std::collections::BTreeSet<u32> = spots
        .iter()
        .filter_map(|s| s.line)
        .flat_map(|l| l.saturating_sub(2).max(1)..=l + 2)
        .collect();
    let lines = text
        .lines()
        .enumerate()
        .map(|(i, t)| (i as u32 + 1, t))
        .filter(|(n, _)| wanted.contains(n))
        .map(|(n, t)| (n, t.chars().take(200).collect()))
        .collect();
    Some(ProgramExcerpt {
        file: file.display().to_string(),
        lines,
    })
}

/// The set-up table: job, program, material, tools, machine, limits.
fn setup_rows(summary: &SummaryDoc) -> Vec<(String, String)> {
    let (job, program, setup) = match summary {
        SummaryDoc::Simulate(s) => (&s.job, &s.program, s.setup.as_ref()),
        SummaryDoc::Optimize(o) => (&o.job, &o.program, o.setup.as_ref()),
        SummaryDoc::Operations(j) => (&j.job, &j.job, None),
    };
    let mut rows = vec![
        ("job".to_string(), job.clone()),
        ("program".to_string(), program.clone()),
    ];
    let Some(s) = setup else {
        return rows;
    };
    rows.push((
        "material".into(),
        format!("{}, spindle {} rev/min", s.material, s.spindle_rpm),
    ));
    for t in &s.tools {
        rows.push((
            format!("tool T{}", t.number),
            format!(
                "{} Ø{} mm, {} flutes, stickout {} mm{}{}",
                t.shape,
                t.diameter_mm,
                t.flutes,
                t.stickout_mm,
                t.fz_max_mm
                    .map_or(String::new(), |f| format!(", fz_max {f} mm/tooth")),
                t.stress_limit_mpa
                    .map_or(String::new(), |s| format!(", allowable stress {s:.0} MPa"))
            ),
        ));
    }
    let axes = |v: [f64; 3]| format!("{} / {} / {}", v[0], v[1], v[2]);
    rows.push((
        "machine".into(),
        format!(
            "servo period {} ms, feed_max {} mm/min, rapid {} mm/min, accel X/Y/Z {} mm/s²{}",
            s.period_ms,
            s.feed_max_mm_min,
            s.rapid_mm_min,
            axes(s.accel_mm_s2),
            s.jerk_mm_s3
                .map_or(String::new(), |j| format!(", jerk {} mm/s³", axes(j)))
        ),
    ));
    rows.push((
        "limits".into(),
        if s.limits.is_empty() {
            "none".into()
        } else {
            s.limits
                .iter()
                .map(|(k, v, u)| format!("{k} {v} {u}"))
                .collect::<Vec<_>>()
                .join(", ")
        },
    ));
    rows
}

/// A summary row: label, unit, decimals and the value it shows.
type Row<T> = (&'static str, &'static str, usize, fn(&T) -> f64);

/// Summary rows of a run.
const ROWS: [Row<Summary>; 13] = [
    ("cycle time", "s", 3, |s| s.cycle_time_s),
    ("peak MRR (≥ 48 ms, ≥ 10 cells)", "mm³/s", 2, |s| {
        s.peak_mrr_windowed_mm3_s
    }),
    ("peak MRR per period", "mm³/s", 2, |s| s.peak_mrr_mm3_s),
    ("peak force", "N", 1, |s| s.peak_force_n),
    ("peak force over a revolution", "N", 1, |s| {
        s.peak_force_revolution_n
    }),
    ("peak deflection", "µm", 1, |s| s.peak_deflection_um),
    // Von Mises, against the tool's allowable stress (MODEL.md §4.4).
    ("peak tool stress", "MPa", 0, |s| s.peak_stress_mpa),
    ("removed volume", "mm³", 1, |s| s.removed_volume_mm3),
    ("initial volume", "mm³", 1, |s| s.initial_volume_mm3),
    ("steps", "", 0, |s| s.steps as f64),
    ("shank contact steps", "", 0, |s| {
        s.shank_contact_steps as f64
    }),
    ("rapid collision steps", "", 0, |s| {
        s.rapid_collision_steps as f64
    }),
    // Their deflection is the one at rupture (MODEL.md §4.4).
    ("steps where the tool breaks", "", 0, |s| {
        s.tool_breaks_steps as f64
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
            .context_with(|| {
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
    let Manifest { run_id, files } = serde_json::from_str(&text).or_results(|| {
        format!(
            "{}: not a manifest with run_id and files",
            manifest_path.display()
        )
    })?;
    if summary.run_id() != run_id {
        fail!(
            results,
            "{}: summary.json is not from run {run_id} of the manifest: the folder mixes runs",
            dir.display()
        );
    }
    for (name, size) in files {
        let path = dir.join(&name);
        let actual = std::fs::metadata(&path).map(|m| m.len()).ok();
        if actual != Some(size) {
            fail!(results,
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
        fail!(
            results,
            "{}: grid nx and ny must be at least 1, got {}×{}",
            path.display(),
            grid.nx,
            grid.ny
        );
    }
    if !(grid.spacing_mm > 0.0 && grid.spacing_mm.is_finite()) {
        fail!(
            results,
            "{}: grid spacing_mm must be a positive number, got {}",
            path.display(),
            grid.spacing_mm
        );
    }
    if !(grid.x0_mm.is_finite() && grid.y0_mm.is_finite()) {
        fail!(
            results,
            "{}: grid x0_mm and y0_mm must be finite",
            path.display()
        );
    }
    let Some(columns) = grid.nx.checked_mul(grid.ny) else {
        fail!(
            results,
            "{}: grid {}×{} overflows",
            path.display(),
            grid.nx,
            grid.ny
        );
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
    let summary = crate::model::summary::read(&summary_path).context_with(|| {
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
        SummaryDoc::Operations(job) => return write_operations_report(dir, job),
    };
    let optimized = optimize.is_some();

    // Time series.
    let (plots, after_cols) = time_series(dir, optimize)?;

    // Maps and the 3D stock.
    let MapsAndStock {
        images,
        design_map_png,
        page_glb,
    } = maps_and_stock(dir, &grid)?;

    // Summary table and notes.
    let rows = summary_rows(before_run, after_run, &grid);
    let notes = notes(&summary, before_run, after_run, optimize);
    let title = format!(
        "dexcut {} report: {}",
        if optimized {
            "optimisation"
        } else {
            "simulation"
        },
        summary.program()
    );
    let hot_spots = hot_spots(
        &after_cols,
        after_run.unwrap_or(before_run),
        summary.design(),
    );
    let program = program_excerpt(dir, &summary, &hot_spots);
    let report = Report {
        title,
        setup: setup_rows(&summary),
        hot_spots,
        program,
        summary: rows,
        plots,
        images,
        glb: Some(page_glb),
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

/// A run's steps by column name ([`read_step_columns`]).
type StepColumns = HashMap<String, Vec<f64>>;

/// The report's plots of the steps (MRR, feed with rapids apart, force,
/// deflection): the run's, and with `optimize` the program as given's
/// beside the optimised one's, with the limits. Also gives the steps'
/// columns of the run (after optimisation), which the hot spots read.
fn time_series(
    dir: &Path,
    optimize: Option<&OptimizeSummary>,
) -> Result<(Vec<PlotGroup>, StepColumns)> {
    let optimized = optimize.is_some();
    let after_cols = read_step_columns(dir, "steps", &STEP_COLUMNS, &STEP_PLACES)?;
    let before_cols = if optimized {
        Some(read_step_columns(
            dir,
            "steps_before",
            &STEP_COLUMNS,
            &STEP_PLACES,
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
    // Feed: cutting moves and rapids apart (a rapid's feed is the machine's, not the program's).
    let feed_plot = {
        let mut group = plot("Feed (rapids apart)", "feed", "mm/min", "feed_mm_min", None);
        let mut split = Vec::new();
        for (s, cols) in group.series.drain(..).zip(
            [before_cols.as_ref(), Some(&after_cols)]
                .into_iter()
                .flatten(),
        ) {
            let rapid = cols.get("rapid");
            let pick = |want_rapid: bool| -> Vec<f64> {
                s.values
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        let is_rapid = rapid.and_then(|r| r.get(i)).is_some_and(|&r| r > 0.5);
                        if is_rapid == want_rapid {
                            v
                        } else {
                            f64::NAN
                        }
                    })
                    .collect()
            };
            let any_rapid = rapid.is_some_and(|r| r.iter().any(|&v| v > 0.5));
            split.push(Series {
                name: s.name.clone(),
                values: pick(false),
                ..s.clone()
            });
            if any_rapid {
                split.push(Series {
                    name: format!("{} G0", s.name),
                    values: pick(true),
                    ..s
                });
            }
        }
        group.series = split;
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
        feed_plot,
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
    Ok((plots, after_cols))
}

/// What [`maps_and_stock`] made for the page.
struct MapsAndStock {
    /// The heat maps, error first.
    images: Vec<ReportImage>,
    /// design_map.png, when written.
    design_map_png: Option<std::path::PathBuf>,
    /// The lighter stock the page embeds.
    page_glb: Vec<u8>,
}

/// Write error_map.png, design_map.png (where the run has a design
/// comparison) and stock.glb into `dir` from its column grid, and make the
/// page's images and its lighter stock.
fn maps_and_stock(dir: &Path, grid: &GridInfo) -> Result<MapsAndStock> {
    let maps = read_column_maps(dir, grid)?;
    let egrid = grid.export();
    let error = ScalarMap {
        grid: egrid,
        values: maps.get("error_um").cloned().unwrap_or_default(),
        unit: "µm".into(),
    };
    // Titles are the page's captions, not the image's bitmap font.
    let error_style = HeatMapStyle {
        title: String::new(),
        unit: "µm".into(),
        symmetric: true,
        range: None,
    };
    let mut images = Vec::new();
    let mut design_map_png = None;
    let (error_png, error_frame) = export::heat_map_png_framed(&error, &error_style)?;
    export::atomic::write_bytes(&dir.join("error_map.png"), &error_png)
        .map_err(|e| Error::io("cannot write", &dir.join("error_map.png"), e))?;
    images.push(ReportImage {
        name: "Predicted shape error from tool deflection (µm, positive = material left)".into(),
        png: error_png,
        frame: Some(error_frame),
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
            title: String::new(),
            unit: "µm".into(),
            symmetric: true,
            range: None,
        };
        let (png, frame) = export::heat_map_png_framed(&map, &style)?;
        export::atomic::write_bytes(&dir.join("design_map.png"), &png)
            .map_err(|e| Error::io("cannot write", &dir.join("design_map.png"), e))?;
        design_map_png = Some(dir.join("design_map.png"));
        images.push(ReportImage {
            name: "Final surface against the design model (µm)".into(),
            png,
            frame: Some(frame),
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
    export::atomic::write_bytes(&dir.join("stock.glb"), &glb)
        .map_err(|e| Error::io("cannot write", &dir.join("stock.glb"), e))?;
    // The page embeds a lighter stock so it stays under 3 MB; stock.glb keeps the detail.
    let (page_glb, _) = export::stock_glb_bytes(
        &height,
        Some(&error),
        &export::GlbOptions {
            max_vertices: PAGE_GLB_VERTICES,
            ..export::GlbOptions::default()
        },
    )?;
    Ok(MapsAndStock {
        images,
        design_map_png,
        page_glb,
    })
}

/// The summary table: [`ROWS`] of the run (before and after optimisation),
/// the peaks per tool where more than one tool cuts, and the grid.
fn summary_rows(
    before_run: &Summary,
    after_run: Option<&Summary>,
    grid: &GridInfo,
) -> Vec<SummaryRow> {
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
    rows
}

/// The notes under the table: the model in words, the warnings of the
/// program (and of the optimised program), the time at each cap and the
/// design comparison.
fn notes(
    summary: &SummaryDoc,
    before_run: &Summary,
    after_run: Option<&Summary>,
    optimize: Option<&OptimizeSummary>,
) -> Vec<String> {
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
    notes
}

/// The report of a job of operations: each operation's own report in its
/// folder, and the job's report.html: each operation's program, cycle time
/// (before and after re-timing), removal and peaks per tool, and the totals.
/// The maps and the 3-D stock are the last operation's (the final stock).
fn write_operations_report(
    dir: &Path,
    job: &crate::model::summary::OperationsSummary,
) -> Result<ReportFiles> {
    if job.operations.is_empty() {
        fail!(
            results,
            "{}: summary.json lists no operation",
            dir.display()
        );
    }
    for op in &job.operations {
        let op_dir = dir.join(&op.folder);
        write_report(&op_dir).context_with(|| format!("operation {} {:?}", op.number, op.name))?;
    }
    let optimized = job.ran == "optimize";
    let after = |v: String| optimized.then_some(v);
    let mut setup = vec![("job".to_string(), job.job.clone())];
    let mut summary = Vec::new();
    for op in &job.operations {
        setup.push((
            format!("operation {}: {}", op.number, op.name),
            format!("{} (results and report in {}/)", op.program, op.folder),
        ));
        let key = |what: &str| format!("{} {}: {what}", op.number, op.name);
        let (before_s, after_s) = match op.cycle_time_before_s {
            Some(b) => (b, Some(op.cycle_time_s)),
            None => (op.cycle_time_s, None),
        };
        summary.push(SummaryRow {
            key: key("cycle time"),
            before: format!("{before_s:.2} s"),
            after: after_s.map(|a| {
                let kept = if op.kept_original == Some(true) {
                    " (program kept)"
                } else {
                    ""
                };
                format!("{a:.2} s{kept}")
            }),
        });
        summary.push(SummaryRow {
            key: key("removed"),
            before: format!("{:.1} mm³", op.removed_volume_mm3),
            after: None,
        });
        for t in &op.tools {
            summary.push(SummaryRow {
                key: key(&format!("T{} peak MRR / force / deflection", t.tool)),
                before: String::new(),
                after: None,
            });
            let last_row = summary.last_mut().expect("pushed");
            let peaks = format!(
                "{:.2} mm³/s, {:.1} N, {:.1} µm",
                t.peak_mrr_mm3_s, t.peak_force_n, t.peak_deflection_um
            );
            if optimized {
                last_row.before = "–".into();
                last_row.after = Some(peaks);
            } else {
                last_row.before = peaks;
            }
        }
        summary.push(SummaryRow {
            key: key("error range"),
            before: format!("{:.1} … {:.1} µm", op.min_error_um, op.max_error_um),
            after: None,
        });
    }
    let (total_before, total_after) = match job.cycle_time_before_s {
        Some(b) => (b, Some(job.cycle_time_s)),
        None => (job.cycle_time_s, None),
    };
    summary.push(SummaryRow {
        key: "all operations: cycle time".into(),
        before: format!("{total_before:.2} s"),
        after: total_after.map(|a| format!("{a:.2} s")),
    });
    summary.push(SummaryRow {
        key: "all operations: removed / stock before / stock after".into(),
        before: format!(
            "{:.1} / {:.1} / {:.1} mm³",
            job.removed_volume_mm3, job.initial_volume_mm3, job.final_volume_mm3
        ),
        after: after(String::new()).filter(|s| !s.is_empty()),
    });
    let mut notes = vec![format!(
        "{} operations run in order on one stock; each operation's own report (plots, maps, hot spots, program) is report.html in its folder: {}.",
        job.operations.len(),
        job.operations
            .iter()
            .map(|o| format!("{}/report.html", o.folder))
            .collect::<Vec<_>>()
            .join(", ")
    )];
    if let Some(s) = &job.saved_stock {
        notes.push(format!("The final stock is saved in {s}/ (stock.json, counts.npy, intervals.npy, and stock.stl for a CAM system)."));
    }
    let maps = maps_and_stock(dir, &job.grid)?;
    let mut images = maps.images;
    if let Some(map) = images.first_mut() {
        map.name = "Predicted shape error from tool deflection, each column as the operation that last cut it left it (µm, positive = material left)".into();
    }
    let report = Report {
        title: format!(
            "dexcut {} report: {} operations of {}",
            if optimized {
                "optimisation"
            } else {
                "simulation"
            },
            job.operations.len(),
            job.job
        ),
        setup,
        summary,
        hot_spots: Vec::new(),
        program: None,
        plots: Vec::new(),
        images,
        glb: Some(maps.page_glb),
        notes,
    };
    export::write_report_html(&dir.join("report.html"), &report)?;
    Ok(ReportFiles {
        html: dir.join("report.html"),
        error_map_png: dir.join("error_map.png"),
        design_map_png: None,
        stock_glb: dir.join("stock.glb"),
    })
}
