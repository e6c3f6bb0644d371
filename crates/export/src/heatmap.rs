//! PNG heat maps of per-column scalars (shape error in µm, removed depth, ...),
//! with a colour bar and a scale bar, drawn with the built-in bitmap font.

use std::path::Path;

use image::{ImageEncoder, Rgba, RgbaImage};

use crate::color::ColorScale;
use crate::font::{draw_text, text_height, text_width};
use crate::ticks::{format_tick, nice_floor, nice_ticks};
use crate::{render_and_write, Error, ScalarMap};

/// Colour of columns without a value (NaN): opaque mid grey, distinct from
/// every colour of both palettes.
pub const NAN_RGBA: [u8; 4] = [150, 150, 150, 255];
const BACKGROUND: Rgba<u8> = Rgba([255, 255, 255, 255]);
const INK: Rgba<u8> = Rgba([30, 30, 30, 255]);

/// Smallest width of the map area; small grids are upscaled to reach it.
const MIN_MAP_WIDTH_PX: usize = 600;
/// Largest width or height of the map area; larger grids are reduced.
const MAX_MAP_PX: usize = 2400;
const MARGIN: u32 = 16;
const TEXT_SCALE: u32 = 2;
const BAR_WIDTH: u32 = 24;
const MIN_BAR_HEIGHT: u32 = 200;

/// How a heat map is titled and coloured.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatMapStyle {
    /// Title drawn above the map.
    pub title: String,
    /// Unit shown on the colour bar; when empty, the map's own unit is used.
    pub unit: String,
    /// Diverging palette centred on 0 (signed errors) instead of a sequential one.
    pub symmetric: bool,
    /// Fixed colour range `(min, max)`, e.g. to compare two maps; `None` fits the data.
    pub range: Option<(f64, f64)>,
}

impl HeatMapStyle {
    /// A style fitted to the data.
    pub fn new(title: impl Into<String>, unit: impl Into<String>, symmetric: bool) -> Self {
        HeatMapStyle {
            title: title.into(),
            unit: unit.into(),
            symmetric,
            range: None,
        }
    }
}

/// Where things are in a rendered heat map (image pixels, origin top left).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeatMapLayout {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Left edge of the map area.
    pub map_left: u32,
    /// Top edge of the map area.
    pub map_top: u32,
    /// Map cells along X (grid columns / `cols_per_cell`, rounded up).
    pub cells_x: usize,
    /// Map cells along Y.
    pub cells_y: usize,
    /// Image pixels per map cell side (upscaling of small grids).
    pub px_per_cell: u32,
    /// Grid columns per map cell side (reduction of large grids; 1 = none).
    pub cols_per_cell: usize,
    /// Left edge of the colour bar.
    pub bar_left: u32,
    /// Top edge of the colour bar (the scale's maximum).
    pub bar_top: u32,
    /// Colour bar width.
    pub bar_width: u32,
    /// Colour bar height.
    pub bar_height: u32,
    /// The colour scale used.
    pub scale: ColorScale,
}

impl HeatMapLayout {
    /// Centre pixel of the map cell showing grid column `(ix, iy)`; `+Y` points up
    /// in the image. `None` outside the grid.
    pub fn pixel_of_column(&self, ix: usize, iy: usize) -> Option<(u32, u32)> {
        let (cx, cy) = (ix / self.cols_per_cell, iy / self.cols_per_cell);
        if cx >= self.cells_x || cy >= self.cells_y {
            return None;
        }
        let half = self.px_per_cell / 2;
        let x = self.map_left + cx as u32 * self.px_per_cell + half;
        let y = self.map_top + (self.cells_y - 1 - cy) as u32 * self.px_per_cell + half;
        Some((x, y))
    }
}

/// Render the heat map into an image (no file I/O).
///
/// Grids wider or taller than 2400 columns are reduced: each pixel shows a
/// block of columns, the value of largest magnitude for symmetric maps (so
/// the worst error stays visible) or the mean otherwise.
pub fn heat_map_image(
    map: &ScalarMap,
    style: &HeatMapStyle,
) -> Result<(RgbaImage, HeatMapLayout), Error> {
    draw_heat_map(map, style, true)
}

/// [`heat_map_image`], with the title, the colour bar's unit, ticks and labels
/// and the scale bar left out when `text` is false (the HTML report sets them
/// as page text over the image, [`crate::MapFrame`]); the layout is the same.
pub(crate) fn draw_heat_map(
    map: &ScalarMap,
    style: &HeatMapStyle,
    text: bool,
) -> Result<(RgbaImage, HeatMapLayout), Error> {
    let grid = map.grid;
    grid.check_len("heat map values", map.values.len())?;
    // An empty grid is drawn as one NaN cell, so title, bar and frame still appear.
    let (nx, ny) = (grid.nx.max(1), grid.ny.max(1));
    let cols_per_cell = nx.max(ny).div_ceil(MAX_MAP_PX).max(1);
    let (cells_x, cells_y) = (nx.div_ceil(cols_per_cell), ny.div_ceil(cols_per_cell));
    let px_per_cell = MIN_MAP_WIDTH_PX
        .div_ceil(cells_x)
        .min(MAX_MAP_PX / cells_y)
        .max(1) as u32;
    let cells = reduce_cells(map, cols_per_cell, cells_x, cells_y, style.symmetric);

    let scale = match style.range {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && hi > lo => ColorScale {
            min: lo,
            max: hi,
            palette: if style.symmetric {
                crate::Palette::Diverging
            } else {
                crate::Palette::Sequential
            },
        },
        _ => ColorScale::for_values(&cells, style.symmetric),
    };
    let unit = if style.unit.is_empty() {
        map.unit.as_str()
    } else {
        style.unit.as_str()
    };

    let th = text_height(TEXT_SCALE);
    let map_w = cells_x as u32 * px_per_cell;
    let map_h = cells_y as u32 * px_per_cell;
    let bar_height = map_h.max(MIN_BAR_HEIGHT);
    let (ticks, step) = nice_ticks(scale.min, scale.max, 6);
    let labels: Vec<String> = ticks.iter().map(|&v| format_tick(v, step)).collect();
    let label_w = labels
        .iter()
        .map(|l| text_width(l, TEXT_SCALE))
        .max()
        .unwrap_or(0)
        .max(text_width(unit, TEXT_SCALE));
    let title_h = if style.title.is_empty() { 0 } else { th + 12 };
    let map_left = MARGIN;
    let map_top = MARGIN + title_h + th + 8; // room for the unit label above the bar
    let bar_left = map_left + map_w + 24;
    let bar_top = map_top;
    let width = (bar_left + BAR_WIDTH + 8 + label_w + MARGIN)
        .max(text_width(&style.title, TEXT_SCALE) + 2 * MARGIN)
        .max(MIN_MAP_WIDTH_PX as u32);
    let scale_bar_h = 10 + 6 + th;
    let height = map_top + bar_height + 12 + scale_bar_h + MARGIN; // bar_height ≥ map_h

    let mut img = RgbaImage::from_pixel(width, height, BACKGROUND);
    if text && !style.title.is_empty() {
        draw_text(
            &mut img,
            i64::from(MARGIN),
            i64::from(MARGIN),
            &style.title,
            TEXT_SCALE,
            INK,
        );
    }

    // The map, +Y up.
    for cy in 0..cells_y {
        for cx in 0..cells_x {
            let v = cells[cy * cells_x + cx];
            let rgba = scale
                .rgb(f64::from(v))
                .map_or(NAN_RGBA, |[r, g, b]| [r, g, b, 255]);
            let x0 = map_left + cx as u32 * px_per_cell;
            let y0 = map_top + (cells_y - 1 - cy) as u32 * px_per_cell;
            fill_rect(&mut img, x0, y0, px_per_cell, px_per_cell, Rgba(rgba));
        }
    }
    frame(&mut img, map_left, map_top, map_w, map_h);

    // Colour bar: maximum at the top.
    for row in 0..bar_height {
        let t = 1.0 - (f64::from(row) + 0.5) / f64::from(bar_height);
        let [r, g, b] = scale.rgb_at(t);
        fill_rect(
            &mut img,
            bar_left,
            bar_top + row,
            BAR_WIDTH,
            1,
            Rgba([r, g, b, 255]),
        );
    }
    frame(&mut img, bar_left, bar_top, BAR_WIDTH, bar_height);
    let labels = if text { labels } else { Vec::new() };
    if text {
        draw_text(
            &mut img,
            i64::from(bar_left),
            i64::from(bar_top) - i64::from(th) - 6,
            unit,
            TEXT_SCALE,
            INK,
        );
    }
    for (v, label) in ticks.iter().zip(&labels) {
        let t = scale.fraction(*v);
        let y = bar_top + ((1.0 - t) * f64::from(bar_height - 1)).round() as u32;
        fill_rect(&mut img, bar_left + BAR_WIDTH, y, 5, 1, INK);
        let ty = i64::from(y) - i64::from(th / 2);
        draw_text(
            &mut img,
            i64::from(bar_left + BAR_WIDTH + 8),
            ty,
            label,
            TEXT_SCALE,
            INK,
        );
    }

    // Scale bar in mm under the map.
    let mm_per_px = grid.spacing_mm * cols_per_cell as f64 / f64::from(px_per_cell);
    if text && mm_per_px.is_finite() && mm_per_px > 0.0 {
        let len_mm = nice_floor(f64::from(map_w) * mm_per_px / 3.0);
        let len_px = (len_mm / mm_per_px).round() as u32;
        if len_px >= 2 {
            let y = map_top + map_h + 14;
            fill_rect(&mut img, map_left, y, len_px, 4, INK);
            fill_rect(&mut img, map_left, y - 4, 2, 12, INK);
            fill_rect(&mut img, map_left + len_px - 2, y - 4, 2, 12, INK);
            let label = format!("{} mm", format_tick(len_mm, len_mm));
            draw_text(
                &mut img,
                i64::from(map_left + len_px + 8),
                i64::from(y) - 6,
                &label,
                TEXT_SCALE,
                INK,
            );
        }
    }

    let layout = HeatMapLayout {
        width,
        height,
        map_left,
        map_top,
        cells_x,
        cells_y,
        px_per_cell,
        cols_per_cell,
        bar_left,
        bar_top,
        bar_width: BAR_WIDTH,
        bar_height,
        scale,
    };
    Ok((img, layout))
}

/// Render the heat map as PNG bytes.
pub fn heat_map_png_bytes(map: &ScalarMap, style: &HeatMapStyle) -> Result<Vec<u8>, Error> {
    let (img, _) = heat_map_image(map, style)?;
    encode_png(&img)
}

/// Write the heat map of `map` to the PNG file `path`.
pub fn write_heat_map_png(path: &Path, map: &ScalarMap, style: &HeatMapStyle) -> Result<(), Error> {
    render_and_write(path, || heat_map_png_bytes(map, style))
}

pub(crate) fn encode_png(img: &RgbaImage) -> Result<Vec<u8>, Error> {
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(
        img.as_raw(),
        img.width(),
        img.height(),
        image::ExtendedColorType::Rgba8,
    )?;
    Ok(out)
}

/// Reduce the grid to `cells_x × cells_y` cells of `k × k` columns.
fn reduce_cells(
    map: &ScalarMap,
    k: usize,
    cells_x: usize,
    cells_y: usize,
    symmetric: bool,
) -> Vec<f32> {
    let g = map.grid;
    if g.is_empty() {
        return vec![f32::NAN; cells_x * cells_y];
    }
    if k == 1 {
        return map.values.clone();
    }
    let mut out = vec![f32::NAN; cells_x * cells_y];
    for cy in 0..cells_y {
        for cx in 0..cells_x {
            let (mut best, mut sum, mut n) = (f32::NAN, 0.0f64, 0usize);
            for iy in cy * k..((cy + 1) * k).min(g.ny) {
                for ix in cx * k..((cx + 1) * k).min(g.nx) {
                    let v = map.values[g.index(ix, iy)];
                    if v.is_finite() {
                        if best.is_nan() || v.abs() > best.abs() {
                            best = v;
                        }
                        sum += f64::from(v);
                        n += 1;
                    }
                }
            }
            out[cy * cells_x + cx] = if n == 0 {
                f32::NAN
            } else if symmetric {
                best
            } else {
                (sum / n as f64) as f32
            };
        }
    }
    out
}

fn fill_rect(img: &mut RgbaImage, x: u32, y: u32, w: u32, h: u32, c: Rgba<u8>) {
    for py in y..(y + h).min(img.height()) {
        for px in x..(x + w).min(img.width()) {
            img.put_pixel(px, py, c);
        }
    }
}

fn frame(img: &mut RgbaImage, x: u32, y: u32, w: u32, h: u32) {
    let (x0, y0) = (x.saturating_sub(1), y.saturating_sub(1));
    fill_rect(img, x0, y0, w + 2, 1, INK);
    fill_rect(img, x0, y + h, w + 2, 1, INK);
    fill_rect(img, x0, y0, 1, h + 2, INK);
    fill_rect(img, x + w, y0, 1, h + 2, INK);
}
