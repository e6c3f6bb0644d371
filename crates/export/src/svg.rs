//! Line plots of time series as inline SVG (axes, ticks, labels, legend,
//! optional limit line), with min/max decimation so spikes survive.
//!
//! Each plot carries its time range and plot area (`data-t0`, `data-t1`,
//! `data-x`, `data-w`), its series in a `g.zoom` group and its time ticks in
//! `g.xticks`, so the report's script (`plots.js`) can zoom all plots to a
//! time range by scaling the series group and writing new ticks.

use std::fmt::Write as _;

use crate::ticks::{format_tick, nice_ticks};
use crate::{escape_html as esc, Series};

/// Most points drawn per series in one plot: about 6 per pixel of the plot's
/// width, so a range zoomed 6× still shows every bucket's minimum and maximum
/// at one per pixel.
pub const MAX_PLOT_POINTS: usize = 4000;

/// Series colours, in order: "before", "after", then others.
const COLORS: [&str; 6] = [
    "#4c78a8", "#f58518", "#54a24b", "#b279a2", "#e45756", "#72b7b2",
];
const WIDTH: f64 = 720.0;
const HEIGHT: f64 = 300.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 16.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 46.0;

/// One plot: several series over time on a shared axis, e.g. MRR before and
/// after re-timing.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotGroup {
    /// Plot title, e.g. `"Material removal rate"`.
    pub title: String,
    /// Quantity on the Y axis, e.g. `"MRR"`.
    pub y_label: String,
    /// Unit of the Y axis, e.g. `"mm³/s"`.
    pub unit: String,
    /// The series, overlaid; the first is drawn first (below the others).
    pub series: Vec<Series>,
    /// A horizontal limit line (the threshold the schedule keeps to), in `unit`.
    pub limit: Option<f64>,
}

/// Reduce `(t, v)` to at most `max_points` points (about) by keeping, for each
/// of `max_points / 2` equal index buckets, the samples with the smallest and
/// the largest value, in time order. Non-finite values are dropped but a
/// bucket holding one leaves a gap (a NaN point) so lines break there.
/// Series at or under the limit are returned unchanged.
pub fn decimate_min_max(t_s: &[f64], values: &[f64], max_points: usize) -> Vec<(f64, f64)> {
    let n = t_s.len().min(values.len());
    if n <= max_points.max(2) {
        return (0..n).map(|i| (t_s[i], values[i])).collect();
    }
    let buckets = (max_points / 2).max(1);
    let mut out = Vec::with_capacity(buckets * 2 + 8);
    for b in 0..buckets {
        let (lo, hi) = (b * n / buckets, (b + 1) * n / buckets);
        let (mut imin, mut imax, mut gap) = (None::<usize>, None::<usize>, None::<usize>);
        for i in lo..hi {
            let v = values[i];
            if !(v.is_finite() && t_s[i].is_finite()) {
                gap = gap.or(Some(i));
                continue;
            }
            if imin.is_none_or(|j| v < values[j]) {
                imin = Some(i);
            }
            if imax.is_none_or(|j| v > values[j]) {
                imax = Some(i);
            }
        }
        let mut keep: Vec<usize> = [imin, imax, gap].into_iter().flatten().collect();
        keep.sort_unstable();
        keep.dedup();
        for i in keep {
            if Some(i) == gap {
                // A NaN point breaks the line; its time keeps the output ordered.
                let t = if t_s[i].is_finite() {
                    t_s[i]
                } else {
                    out.last().map_or(t_s[lo], |p: &(f64, f64)| p.0)
                };
                out.push((t, f64::NAN));
            } else {
                out.push((t_s[i], values[i]));
            }
        }
    }
    out
}

/// Render `group` as a standalone `<svg>` element (scales to its container's width).
/// `id` tells the plots of one page apart (it names the clip path), so the
/// output depends only on the arguments.
pub fn plot_svg(group: &PlotGroup, id: usize) -> String {
    let decimated: Vec<Vec<(f64, f64)>> = group
        .series
        .iter()
        .map(|s| decimate_min_max(&s.t_s, &s.values, MAX_PLOT_POINTS))
        .collect();

    // Data ranges.
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let (mut t0, mut t1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in decimated.iter().flatten().filter(finite) {
        t0 = t0.min(p.0);
        t1 = t1.max(p.0);
        y0 = y0.min(p.1);
        y1 = y1.max(p.1);
    }
    let has_data = t0 <= t1;
    if let Some(l) = group.limit.filter(|l| l.is_finite()) {
        y0 = y0.min(l);
        y1 = y1.max(l);
    }
    if !has_data {
        (t0, t1) = (0.0, 1.0);
    }
    if !(y0.is_finite() && y1.is_finite()) || y0 > y1 {
        (y0, y1) = (0.0, 1.0);
    }
    if y0 > 0.0 && y0 < 0.5 * y1 {
        y0 = 0.0; // non-negative quantities read best from zero
    }
    if t1 <= t0 {
        t1 = t0 + 1.0;
    }
    if y1 <= y0 {
        let pad = if y0 == 0.0 { 1.0 } else { y0.abs() * 0.1 };
        (y0, y1) = (y0 - pad, y1 + pad);
    } else {
        let pad = 0.05 * (y1 - y0);
        y1 += pad;
        if y0 != 0.0 {
            y0 -= pad;
        }
    }

    let (pw, ph) = (WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
    let sx = |t: f64| LEFT + (t - t0) / (t1 - t0) * pw;
    let sy = |v: f64| TOP + (1.0 - (v - y0) / (y1 - y0)) * ph;

    let mut s = String::new();
    let _ = write!(
        s,
        r#"<svg class="plot" xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {WIDTH} {HEIGHT}" width="100%" role="img" aria-label="{title}" font-family="sans-serif" font-size="12" data-t0="{t0}" data-t1="{t1}" data-x="{LEFT}" data-w="{pw}" data-y="{TOP}" data-h="{ph}">"#,
        title = esc(&group.title)
    );
    let _ = write!(
        s,
        r#"<title>{}</title><rect x="0" y="0" width="{WIDTH}" height="{HEIGHT}" fill="white"/>"#,
        esc(&group.title)
    );
    let _ = write!(
        s,
        r#"<text x="{}" y="20" font-size="14" font-weight="bold">{}</text>"#,
        LEFT,
        esc(&group.title)
    );

    // Grid, ticks and labels; the time ticks in their own group (rewritten on zoom).
    s.push_str(r#"<g class="xticks">"#);
    let (xt, xstep) = nice_ticks(t0, t1, 8);
    for t in &xt {
        let x = sx(*t);
        let _ = write!(
            s,
            r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{yb}" stroke="#e6e6e6"/><line x1="{x:.1}" y1="{yb}" x2="{x:.1}" y2="{yt}" stroke="#333"/><text x="{x:.1}" y="{yl}" text-anchor="middle">{label}</text>"##,
            yb = TOP + ph,
            yt = TOP + ph + 5.0,
            yl = TOP + ph + 18.0,
            label = format_tick(*t, xstep)
        );
    }
    s.push_str("</g>");
    let (yt, ystep) = nice_ticks(y0, y1, 6);
    for v in &yt {
        let y = sy(*v);
        let _ = write!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{xr}" y2="{y:.1}" stroke="#e6e6e6"/><line x1="{xl}" y1="{y:.1}" x2="{LEFT}" y2="{y:.1}" stroke="#333"/><text x="{xt}" y="{yy:.1}" text-anchor="end">{label}</text>"##,
            xr = LEFT + pw,
            xl = LEFT - 5.0,
            xt = LEFT - 8.0,
            yy = y + 4.0,
            label = format_tick(*v, ystep)
        );
    }
    let _ = write!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##
    );
    let _ = write!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">time (s)</text>"#,
        LEFT + pw / 2.0,
        HEIGHT - 8.0
    );
    let ylabel = if group.unit.is_empty() {
        esc(&group.y_label)
    } else {
        format!("{} ({})", esc(&group.y_label), esc(&group.unit))
    };
    let _ = write!(
        s,
        r#"<text transform="translate(16 {}) rotate(-90)" text-anchor="middle">{ylabel}</text>"#,
        TOP + ph / 2.0
    );

    // Series.
    let _ = write!(
        s,
        r#"<defs><clipPath id="plot-clip-{id}"><rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}"/></clipPath></defs><g clip-path="url(#plot-clip-{id})"><g class="zoom">"#
    );
    for (k, pts) in decimated.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let mut d = String::new();
        let mut pen_down = false;
        for &(t, v) in pts {
            if !(t.is_finite() && v.is_finite()) {
                pen_down = false;
                continue;
            }
            let _ = write!(
                d,
                "{}{:.1} {:.1}",
                if pen_down { " L" } else { " M" },
                sx(t),
                sy(v)
            );
            pen_down = true;
        }
        if !d.is_empty() {
            let _ = write!(
                s,
                r#"<path class="series" d="{}" fill="none" stroke="{color}" stroke-width="1.5" stroke-linejoin="round" vector-effect="non-scaling-stroke"/>"#,
                d.trim()
            );
        }
    }
    s.push_str("</g></g>");
    // The range being selected by a drag (plots.js).
    let _ = write!(
        s,
        r##"<rect class="brush" x="{LEFT}" y="{TOP}" width="0" height="{ph}" fill="#4c78a8" fill-opacity="0.18" visibility="hidden"/>"##
    );
    if let Some(l) = group.limit.filter(|l| l.is_finite()) {
        let y = sy(l);
        let _ = write!(
            s,
            r##"<line class="limit" x1="{LEFT}" y1="{y:.1}" x2="{xr}" y2="{y:.1}" stroke="#c00" stroke-dasharray="6 4"/><text x="{xr2}" y="{yt:.1}" text-anchor="end" fill="#c00">limit {label}</text>"##,
            xr = LEFT + pw,
            xr2 = LEFT + pw - 4.0,
            yt = y - 4.0,
            label = format_tick(l, ystep / 10.0)
        );
    }
    if !has_data {
        let _ = write!(
            s,
            r##"<text x="{}" y="{}" text-anchor="middle" fill="#888">no data</text>"##,
            LEFT + pw / 2.0,
            TOP + ph / 2.0
        );
    }

    // Legend, top right.
    let mut x = WIDTH - RIGHT;
    for (k, series) in group.series.iter().enumerate().rev() {
        let name = &series.name;
        let w = 7.0 * name.chars().count() as f64 + 30.0;
        x -= w;
        let color = COLORS[k % COLORS.len()];
        let _ = write!(
            s,
            r#"<g class="legend"><line x1="{x:.1}" y1="16" x2="{x2:.1}" y2="16" stroke="{color}" stroke-width="3"/><text x="{x3:.1}" y="20">{name}</text></g>"#,
            x2 = x + 18.0,
            x3 = x + 22.0,
            name = esc(name)
        );
    }
    s.push_str("</svg>");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_spikes_and_bounds_points() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.001).collect();
        let mut v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.01).sin()).collect();
        v[54_321] = 50.0;
        v[77_777] = -40.0;
        v[1000] = f64::NAN;
        let d = decimate_min_max(&t, &v, MAX_PLOT_POINTS);
        assert!(
            d.len() <= MAX_PLOT_POINTS + MAX_PLOT_POINTS / 2,
            "{}",
            d.len()
        );
        assert!(d.iter().any(|p| p.1 == 50.0) && d.iter().any(|p| p.1 == -40.0));
        assert!(d.iter().any(|p| p.1.is_nan()), "gap kept");
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0), "time order");
        assert_eq!(decimate_min_max(&t[..10], &v[..10], 2000).len(), 10);
        assert!(decimate_min_max(&[], &[], 2000).is_empty());
    }

    #[test]
    fn empty_and_constant_plots_are_valid() {
        for series in [
            vec![],
            vec![Series {
                name: "a".into(),
                unit: "N".into(),
                t_s: vec![1.0],
                values: vec![3.0],
            }],
        ] {
            let svg = plot_svg(
                &PlotGroup {
                    title: "F <x>".into(),
                    y_label: "force".into(),
                    unit: "N".into(),
                    series,
                    limit: None,
                },
                0,
            );
            assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
            assert!(svg.contains("F &lt;x&gt;") && !svg.contains("NaN") && !svg.contains("inf"));
        }
    }
}
