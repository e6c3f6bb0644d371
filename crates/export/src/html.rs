//! The HTML report: one self-contained file that works offline. Plots are
//! inline SVG, images are `data:` URIs, the 3D stock is the embedded GLB drawn
//! by a small hand-written WebGL viewer. Nothing is loaded from the network.
//!
//! The page reports its own health for tests and CI: `<body data-status>` is
//! `"loading"` until the last script ran, then `"ok"`, or `"error: <message>"`
//! as soon as any script error reaches `window.onerror`. The viewer element
//! `#stock-view` gets `data-viewer` (`webgl2`, `webgl1`, `no-webgl`, `empty`)
//! and `data-mesh-pixels` (pixels drawn that differ from the background).

use std::fmt::Write as _;
use std::path::Path;

use crate::svg::{plot_svg, PlotGroup};
use crate::{b64, escape_html as esc, render_and_write, Error};

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
}

/// Everything in a report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// Page title.
    pub title: String,
    /// Summary table rows.
    pub summary: Vec<SummaryRow>,
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

    if !report.summary.is_empty() {
        let with_after = report.summary.iter().any(|r| r.after.is_some());
        h.push_str("<h2>Summary</h2><table class=\"summary\"><thead><tr><th></th><th>before</th>");
        if with_after {
            h.push_str("<th>after</th>");
        }
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

    if !report.plots.is_empty() {
        h.push_str("<h2>Over time</h2><div class=\"plots\">\n");
        for (k, p) in report.plots.iter().enumerate() {
            let _ = writeln!(h, "<div class=\"plot-box\">{}</div>", plot_svg(p, k));
        }
        h.push_str("</div>\n");
    }

    if !report.images.is_empty() {
        h.push_str("<h2>Maps</h2><div class=\"images\">\n");
        for img in &report.images {
            let _ = writeln!(
                h,
                "<figure><img alt=\"{name}\" src=\"data:image/png;base64,{data}\"><figcaption>{name}</figcaption></figure>",
                name = esc(&img.name),
                data = b64::encode(&img.png)
            );
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
