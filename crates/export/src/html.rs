//! The HTML report: one self-contained file that works offline. Plots are
//! inline SVG, images are `data:` URIs, the 3D stock is the embedded GLB drawn
//! by a small hand-written WebGL viewer. Nothing is loaded from the network.
//!
//! The page reports its own health for tests and CI: `<body data-status>` is
//! `"loading"` until the last script ran, then `"ok"`, or `"error: <message>"`
//! as soon as any script error reaches `window.onerror`. The viewer element
//! `#stock-view` gets `data-viewer` (`webgl2`, `webgl1`, `no-webgl`, `empty`)
//! and `data-mesh-pixels` (pixels drawn that differ from the background).
//! The time plots share one range (`#plot-range`, `data-range="A,B"` in s):
//! drag across a plot, type it, or open the page at `#t=A,B` or `#t=T`; the
//! hot-spot table's times link there.

use std::fmt::Write as _;
use std::path::Path;

use crate::svg::{plot_svg, PlotGroup};
use crate::ticks::{format_tick, nice_ticks};
use crate::{b64, escape_html as esc, render_and_write, Error, Grid, HeatMapLayout};

/// One row of the summary table, values already formatted with units.
#[derive(Clone, Debug, PartialEq)]
pub struct SummaryRow {
    /// What, e.g. `"machining time"`.
    pub key: String,
    /// Value for the original program, e.g. `"42.1 s"`.
    pub before: String,
    /// Value after re-timing, if there is one.
    pub after: Option<String>,
}

/// A PNG shown in the report.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportImage {
    /// Caption.
    pub name: String,
    /// PNG file content.
    pub png: Vec<u8>,
    /// Where the map's columns lie in the image: with it the page draws X/Y
    /// axes in mm and marks the hot spots over the image.
    pub frame: Option<MapFrame>,
}

/// Where a heat map's columns and colour bar lie in its image, in pixels and
/// in mm, with the bar's labels: the page writes them as text over the image.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFrame {
    /// Image width and height, px.
    pub size_px: [u32; 2],
    /// The map area in the image: left, top, width, height, px.
    pub map_px: [u32; 4],
    /// The map area in the machine XY plane: x_min, x_max, y_min, y_max, mm.
    pub extent_mm: [f64; 4],
    /// The colour bar in the image: left, top, width, height, px.
    pub bar_px: [u32; 4],
    /// The colour bar's ticks: image row (px) and label, top to bottom.
    pub bar_ticks: Vec<(f64, String)>,
    /// Unit written above the colour bar, e.g. `"µm"`.
    pub unit: String,
}

impl MapFrame {
    /// The frame of a heat map drawn by [`crate::heat_map_image`] over `grid`,
    /// its colour bar labelled in `unit`.
    pub fn of(layout: &HeatMapLayout, grid: &Grid, unit: &str) -> MapFrame {
        let cell_mm = layout.cols_per_cell as f64 * grid.spacing_mm;
        let x_min = grid.x0_mm - 0.5 * grid.spacing_mm;
        let y_min = grid.y0_mm - 0.5 * grid.spacing_mm;
        MapFrame {
            size_px: [layout.width, layout.height],
            map_px: [
                layout.map_left,
                layout.map_top,
                layout.cells_x as u32 * layout.px_per_cell,
                layout.cells_y as u32 * layout.px_per_cell,
            ],
            extent_mm: [
                x_min,
                x_min + layout.cells_x as f64 * cell_mm,
                y_min,
                y_min + layout.cells_y as f64 * cell_mm,
            ],
            bar_px: [
                layout.bar_left,
                layout.bar_top,
                layout.bar_width,
                layout.bar_height,
            ],
            bar_ticks: {
                let scale = &layout.scale;
                let (ticks, step) = nice_ticks(scale.min, scale.max, 6);
                ticks
                    .iter()
                    .map(|&v| {
                        // The row the image's colour for `v` is drawn at.
                        let row = f64::from(layout.bar_top)
                            + (1.0 - scale.fraction(v)) * f64::from(layout.bar_height - 1);
                        (row, format_tick(v, step))
                    })
                    .collect()
            },
            unit: unit.to_string(),
        }
    }

    /// Image pixel of the machine position (x, y) mm, if it lies on the map.
    pub fn pixel_of_mm(&self, x_mm: f64, y_mm: f64) -> Option<(f64, f64)> {
        let [x0, x1, y0, y1] = self.extent_mm;
        let [left, top, w, h] = self.map_px.map(f64::from);
        if !(x_mm >= x0 && x_mm <= x1 && y_mm >= y0 && y_mm <= y1) {
            return None;
        }
        Some((
            left + (x_mm - x0) / (x1 - x0) * w,
            top + (y1 - y_mm) / (y1 - y0) * h,
        ))
    }
}

/// Render a heat map as PNG bytes without text (title, colour-bar labels,
/// scale bar), with the frame the report needs to draw its axes in mm, the
/// colour bar's labels and the hot-spot marks over it as page text.
pub fn heat_map_png_framed(
    map: &crate::ScalarMap,
    style: &crate::HeatMapStyle,
) -> Result<(Vec<u8>, MapFrame), Error> {
    let (img, layout) = crate::heatmap::draw_heat_map(map, style, false)?;
    let unit = if style.unit.is_empty() {
        &map.unit
    } else {
        &style.unit
    };
    Ok((
        crate::heatmap::encode_png(&img)?,
        MapFrame::of(&layout, &map.grid, unit),
    ))
}

/// A step or program line worth a look: listed in the hot-spot table (anchor
/// `hot-K`), marked on the maps, linked to its program line (anchor `line-N`).
#[derive(Clone, Debug, PartialEq)]
pub struct HotSpot {
    /// What is worst here, e.g. `"peak force"`.
    pub what: String,
    /// The value with its unit, e.g. `"17.5 N"`.
    pub value: String,
    /// Program line (1-based), if known.
    pub line: Option<u32>,
    /// Time in the program, s.
    pub t_s: Option<f64>,
    /// Tool position or column centre, mm.
    pub xy_mm: Option<[f64; 2]>,
}

/// Program lines quoted in the report (those of the hot spots and their
/// neighbours), each with the anchor `line-N`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProgramExcerpt {
    /// The program file.
    pub file: String,
    /// (line number, text), ascending; a gap in the numbers is shown as "…".
    pub lines: Vec<(u32, String)>,
}

/// Everything in a report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// Page title.
    pub title: String,
    /// The set-up: job, tools, material, machine, limits, as (what, value).
    pub setup: Vec<(String, String)>,
    /// Summary table rows.
    pub summary: Vec<SummaryRow>,
    /// The worst steps and lines, linked to the program and marked on the maps.
    pub hot_spots: Vec<HotSpot>,
    /// The program lines the hot spots link to.
    pub program: Option<ProgramExcerpt>,
    /// Plots: MRR, feed, force, deflection vs time, before and after overlaid.
    pub plots: Vec<PlotGroup>,
    /// Images, e.g. error heat maps.
    pub images: Vec<ReportImage>,
    /// GLB of the final stock for the 3D view; `None` leaves the view out.
    /// It is embedded as base64 (4/3 of its size): build it with
    /// `GlbOptions { max_vertices: 250_000, .. }` or so to keep the page
    /// around 10–15 MB (a 250 000-vertex stock draws in under a second with
    /// software WebGL).
    pub glb: Option<Vec<u8>>,
    /// Free-text notes (warnings, model assumptions), one paragraph each.
    pub notes: Vec<String>,
}

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0 auto;max-width:1500px;padding:16px 24px;color:#222;background:#fff}\
h1{font-size:1.6em;margin:.2em 0 .6em}h2{font-size:1.2em;margin:1.4em 0 .5em;border-bottom:1px solid #ddd;padding-bottom:.2em}\
table.summary{border-collapse:collapse}table.summary th,table.summary td{padding:4px 14px;border-bottom:1px solid #e4e4e4;text-align:left}\
table.summary td.v{text-align:right;font-variant-numeric:tabular-nums}\
.plots{display:grid;grid-template-columns:repeat(auto-fit,minmax(560px,1fr));gap:12px}\
.images{display:flex;flex-wrap:wrap;gap:16px}figure{margin:0}figure img{max-width:100%;height:auto;border:1px solid #ddd;image-rendering:pixelated}\
figcaption{font-size:.9em;color:#555;margin-top:4px}\
svg.map{max-width:100%;height:auto;font-size:13px}svg.map text{fill:#222}svg.map .mark circle{fill:none;stroke:#000;stroke-width:2.5}svg.map .mark text{font-weight:bold;paint-order:stroke;stroke:#fff;stroke-width:3px}\
pre.program{background:#fafafa;border:1px solid #e4e4e4;padding:6px 0;overflow-x:auto;line-height:1.45}pre.program span.pl{display:block;padding:0 10px}pre.program span.ln{display:inline-block;min-width:5em;color:#888}pre.program span.gap{display:block;padding:0 10px;color:#aaa}\
:target{background:#ffe14d !important;outline:2px solid #c9a800}\
.plot-range{margin:0 0 8px}.plot-range input{width:7em}svg.plot{cursor:crosshair;user-select:none}\
#stock-view canvas{width:100%;height:520px;display:block;border:1px solid #ddd;background:#f5f7fa;cursor:grab;touch-action:none}\
.viewer-note{font-size:.9em;color:#555;margin:4px 0}.notes p{margin:.4em 0}";

/// Render the report as one HTML string.
pub fn report_html(report: &Report) -> String {
    let mut h = String::with_capacity(
        64 * 1024
            + report.glb.as_ref().map_or(0, |g| g.len() * 4 / 3)
            + report
                .images
                .iter()
                .map(|i| i.png.len() * 4 / 3)
                .sum::<usize>(),
    );
    let title = if report.title.is_empty() {
        "dexcut report"
    } else {
        report.title.as_str()
    };
    let _ = write!(h, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width,initial-scale=1\"><title>{}</title><style>{STYLE}</style></head>\n", esc(title));
    h.push_str("<body data-status=\"loading\">\n<script>window.__dexcutErrors=[];window.onerror=function(m,s,l,c){var t='error: '+m+(l?' (line '+l+')':'');window.__dexcutErrors.push(t);document.body.dataset.status=t;};</script>\n");
    let _ = writeln!(h, "<h1>{}</h1>", esc(title));

    if !report.setup.is_empty() {
        h.push_str("<h2>Set-up</h2><table class=\"summary setup\"><tbody>");
        for (k, v) in &report.setup {
            let _ = write!(h, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(v));
        }
        h.push_str("</tbody></table>\n");
    }

    if !report.summary.is_empty() {
        let with_after = report.summary.iter().any(|r| r.after.is_some());
        // A simulation has one column of values, not a lone "before".
        h.push_str(if with_after {
            "<h2>Summary</h2><table class=\"summary\"><thead><tr><th></th><th>before</th><th>after</th>"
        } else {
            "<h2>Summary</h2><table class=\"summary\"><thead><tr><th></th><th>value</th>"
        });
        h.push_str("</tr></thead><tbody>");
        for r in &report.summary {
            let _ = write!(
                h,
                "<tr><th>{}</th><td class=\"v\">{}</td>",
                esc(&r.key),
                esc(&r.before)
            );
            if with_after {
                let _ = write!(
                    h,
                    "<td class=\"v\">{}</td>",
                    esc(r.after.as_deref().unwrap_or("–"))
                );
            }
            h.push_str("</tr>");
        }
        h.push_str("</tbody></table>\n");
    }

    let quoted = |line: u32| {
        report
            .program
            .as_ref()
            .is_some_and(|p| p.lines.iter().any(|(n, _)| *n == line))
    };
    if !report.hot_spots.is_empty() {
        h.push_str("<h2>Hot spots</h2><table class=\"summary hot\"><thead><tr><th>#</th><th>what</th><th>value</th><th>program line</th><th>time</th><th>X, Y (mm)</th></tr></thead><tbody>");
        for (k, s) in report.hot_spots.iter().enumerate() {
            let line = match s.line {
                Some(l) if quoted(l) => format!("<a href=\"#line-{l}\">{l}</a>"),
                Some(l) => l.to_string(),
                None => "–".into(),
            };
            // A time links to the plots zoomed around it.
            let time = match s.t_s {
                Some(t) if !report.plots.is_empty() => {
                    format!("<a href=\"#t={t:.3}\">{t:.3} s</a>")
                }
                Some(t) => format!("{t:.3} s"),
                None => "–".into(),
            };
            let _ = write!(
                h,
                "<tr id=\"hot-{n}\"><td>{n}</td><td>{}</td><td class=\"v\">{}</td><td class=\"v\">{line}</td><td class=\"v\">{time}</td><td class=\"v\">{}</td></tr>",
                esc(&s.what),
                esc(&s.value),
                s.xy_mm
                    .map_or("–".into(), |[x, y]| format!("{x:.2}, {y:.2}")),
                n = k + 1,
            );
        }
        h.push_str("</tbody></table>\n");
    }

    if !report.plots.is_empty() {
        h.push_str("<h2>Over time</h2><div id=\"plot-range\" class=\"plot-range\">time from <input id=\"range-from\" type=\"number\" step=\"any\"> to <input id=\"range-to\" type=\"number\" step=\"any\"> s <button id=\"range-reset\" type=\"button\">whole program</button> <span class=\"viewer-note\">drag across a plot to zoom all plots to a time range; double-click to zoom out</span></div><div class=\"plots\">\n");
        for (k, p) in report.plots.iter().enumerate() {
            let _ = writeln!(h, "<div class=\"plot-box\">{}</div>", plot_svg(p, k));
        }
        h.push_str("</div>\n");
        let _ = writeln!(h, "<script>\n{}\n</script>", include_str!("plots.js"));
    }

    if !report.images.is_empty() {
        h.push_str("<h2>Maps</h2><div class=\"images\">\n");
        for img in &report.images {
            match &img.frame {
                Some(frame) => {
                    let _ = writeln!(
                        h,
                        "<figure>{}<figcaption>{}</figcaption></figure>",
                        map_svg(img, frame, &report.hot_spots),
                        esc(&img.name)
                    );
                }
                None => {
                    let _ = writeln!(
                        h,
                        "<figure><img alt=\"{name}\" src=\"data:image/png;base64,{data}\"><figcaption>{name}</figcaption></figure>",
                        name = esc(&img.name),
                        data = b64::encode(&img.png)
                    );
                }
            }
        }
        h.push_str("</div>\n");
    }

    if let Some(glb) = &report.glb {
        h.push_str("<h2>Final stock</h2><div id=\"stock-view\"><canvas></canvas><p class=\"viewer-note\">Loading the 3D view…</p></div>\n");
        let _ = writeln!(
            h,
            "<script type=\"application/octet-stream;base64\" id=\"stock-glb\">{}</script>",
            b64::encode(glb)
        );
        let _ = writeln!(h, "<script>\n{}\n</script>", include_str!("viewer.js"));
    }

    if let Some(p) = report.program.as_ref().filter(|p| !p.lines.is_empty()) {
        let _ = write!(
            h,
            "<h2>Program lines</h2><p class=\"viewer-note\">{} (the lines of the hot spots and their neighbours)</p><pre class=\"program\">",
            esc(&p.file)
        );
        let mut last = None;
        for (n, text) in &p.lines {
            if last.is_some_and(|l: u32| *n > l + 1) {
                h.push_str("<span class=\"gap\">…</span>");
            }
            let _ = write!(
                h,
                "<span class=\"pl\" id=\"line-{n}\"><span class=\"ln\">{n}</span>{}</span>",
                esc(text)
            );
            last = Some(*n);
        }
        h.push_str("</pre>\n");
    }

    if !report.notes.is_empty() {
        h.push_str("<h2>Notes</h2><div class=\"notes\">");
        for n in &report.notes {
            let _ = write!(h, "<p>{}</p>", esc(n));
        }
        h.push_str("</div>\n");
    }

    h.push_str("<script>if(!window.__dexcutErrors.length){document.body.dataset.status='ok';}</script>\n</body></html>\n");
    h
}

/// Write the report to the HTML file `path`.
pub fn write_report_html(path: &Path, report: &Report) -> Result<(), Error> {
    render_and_write(path, || Ok(report_html(report)))
}

/// Axis margins around a map image in its SVG, px.
const MAP_LEFT: f64 = 64.0;
const MAP_BOTTOM: f64 = 46.0;
const MAP_TOP: f64 = 8.0;

/// A heat map as SVG: the image, X and Y axes in mm with ticks, and the hot
/// spots that lie on it as numbered marks linking to their table rows.
fn map_svg(img: &ReportImage, frame: &MapFrame, spots: &[HotSpot]) -> String {
    let [w, hgt] = frame.size_px.map(f64::from);
    let [left, top, mw, mh] = frame.map_px.map(f64::from);
    let [x0, x1, y0, y1] = frame.extent_mm;
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg class=\"map\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{} {} {} {}\" width=\"{}\" role=\"img\" aria-label=\"{}\">",
        -MAP_LEFT,
        -MAP_TOP,
        w + MAP_LEFT,
        hgt + MAP_TOP + MAP_BOTTOM,
        w + MAP_LEFT,
        esc(&img.name)
    );
    let _ = write!(
        s,
        "<image x=\"0\" y=\"0\" width=\"{w}\" height=\"{hgt}\" href=\"data:image/png;base64,{}\"/>",
        b64::encode(&img.png)
    );
    // X axis under the map, Y axis left of it, ticks in mm.
    let bottom = top + mh;
    let _ = write!(
        s,
        "<g stroke=\"#444\" fill=\"none\"><path d=\"M{left} {bottom}H{}M{left} {top}V{bottom}\"/></g>",
        left + mw
    );
    let (ticks, step) = nice_ticks(x0, x1, 6);
    for t in ticks {
        let px = left + (t - x0) / (x1 - x0) * mw;
        let _ = write!(
            s,
            "<path d=\"M{px:.1} {bottom}v6\" stroke=\"#444\"/><text x=\"{px:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            // Under the whole image (its scale bar sits under the map).
            hgt + 16.0,
            format_tick(t, step)
        );
    }
    let (ticks, step) = nice_ticks(y0, y1, 6);
    for t in ticks {
        let py = top + (y1 - t) / (y1 - y0) * mh;
        let _ = write!(
            s,
            "<path d=\"M{left} {py:.1}h-6\" stroke=\"#444\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            left - 9.0,
            py + 4.0,
            format_tick(t, step)
        );
    }
    let _ = write!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">X (mm)</text><text transform=\"translate({:.1} {:.1}) rotate(-90)\" text-anchor=\"middle\">Y (mm)</text>",
        left + 0.5 * mw,
        hgt + 36.0,
        -MAP_LEFT + 14.0,
        top + 0.5 * mh
    );
    // The colour bar's unit above it, ticks and labels right of it.
    let [bl, bt, bw, _] = frame.bar_px.map(f64::from);
    let _ = write!(
        s,
        "<g class=\"colour-bar\"><text x=\"{bl:.1}\" y=\"{:.1}\">{}</text>",
        bt - 8.0,
        esc(&frame.unit)
    );
    for (row, label) in &frame.bar_ticks {
        let _ = write!(
            s,
            "<path d=\"M{:.1} {row:.1}h5\" stroke=\"#222\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            bl + bw,
            bl + bw + 8.0,
            row + 4.5,
            esc(label)
        );
    }
    s.push_str("</g>");
    for (k, spot) in spots.iter().enumerate() {
        let Some((px, py)) = spot.xy_mm.and_then(|[x, y]| frame.pixel_of_mm(x, y)) else {
            continue;
        };
        let _ = write!(
            s,
            "<a class=\"mark\" href=\"#hot-{n}\"><title>{n}: {}</title><circle cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"9\"/><text x=\"{:.1}\" y=\"{:.1}\">{n}</text></a>",
            esc(&format!("{} {}", spot.what, spot.value)),
            px + 10.0,
            py - 8.0,
            n = k + 1
        );
    }
    s.push_str("</svg>");
    s
}
