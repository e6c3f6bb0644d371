//! The run's error map (MODEL.md §5): the deflection projected on the final
//! surface, clamped to the stock that was there; held, or made where it is
//! read.

use dexel::{RemovalRecord, Stock, NEVER_CUT};
use rayon::prelude::*;

use super::columns::row_blocks;
use super::{Initial, Run};
use crate::error::Result;
use crate::motion::TimedStep;

/// The error map's model (MODEL.md §5, §5.2): per step and per band of its
/// removal, the deflection [x, y] (µm) at the band's mid-height when a tooth
/// there passes the flank on the left of the feed (φ = 0, the wall up milling
/// leaves) and on the right (φ = π, down milling's), `[left, right]`; once a
/// run is done, across the step's path only. A column takes the side of the
/// step's line it lies on, over the face it stands for above the step's tip
/// ([`FlankDeflections::face_error_um`]). Held compact, as the record's
/// bands: each step as many bands as its removal keeps (at least one), 16 B
/// a band.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlankDeflections {
    /// Height of a band above the tip, mm.
    pub band_height_mm: f64,
    /// Step i's bands are `bands[start[i]..start[i + 1]]`.
    start: Vec<usize>,
    bands: Vec<[[f32; 2]; 2]>,
}

impl FlankDeflections {
    /// The bands step `i` of `record` has here: as many as the record keeps,
    /// at least one.
    pub(crate) fn bands_of(record: &RemovalRecord, i: usize) -> usize {
        record.band_volumes_mm3(i).len().max(1)
    }

    /// Zeros for each of `record`'s steps ([`FlankDeflections::bands_of`]).
    pub(crate) fn sized(record: &RemovalRecord, steps: usize) -> FlankDeflections {
        let mut start = Vec::with_capacity(steps + 1);
        start.push(0);
        for i in 0..steps {
            start.push(start[i] + Self::bands_of(record, i));
        }
        FlankDeflections {
            band_height_mm: record.band_height_mm,
            bands: vec![[[0.0; 2]; 2]; start[steps]],
            start,
        }
    }

    /// Step `i`'s bands, band k at index k.
    pub fn of_step(&self, i: usize) -> &[[[f32; 2]; 2]] {
        &self.bands[self.start[i]..self.start[i + 1]]
    }

    /// Step `i`'s bands, to be written.
    pub(crate) fn of_step_mut(&mut self, i: usize) -> &mut [[[f32; 2]; 2]] {
        &mut self.bands[self.start[i]..self.start[i + 1]]
    }

    /// The bands of the steps in blocks of `block` steps, in order, to be
    /// written (one slice a block).
    pub(crate) fn blocks_mut(&mut self, block: usize) -> Vec<&mut [[[f32; 2]; 2]]> {
        let steps = self.start.len() - 1;
        let mut rest = self.bands.as_mut_slice();
        let mut out = Vec::with_capacity(steps.div_ceil(block));
        for b in (0..steps).step_by(block) {
            let len = self.start[(b + block).min(steps)] - self.start[b];
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(len);
            out.push(head);
            rest = tail;
        }
        out
    }

    /// Step `i`'s deflections times `s` (the load scaled by the loop, or
    /// capped at rupture: MODEL.md §4.4, §5.1).
    pub(crate) fn scale(&mut self, i: usize, s: f64) {
        if s != 1.0 {
            for v in &mut self.bands[self.start[i]..self.start[i + 1]] {
                *v = v.map(|xy| xy.map(|c| (f64::from(c) * s) as f32));
            }
        }
    }

    /// Each step's deflections projected on its direction across the path
    /// `dirs[i]` (unit, MODEL.md §5.1): the component along the path changes
    /// where a point of the surface is made, not how deep (§5).
    pub(crate) fn across(&mut self, dirs: &[[f64; 2]]) {
        for (i, d) in dirs.iter().enumerate() {
            for v in &mut self.bands[self.start[i]..self.start[i + 1]] {
                *v = v.map(|[x, y]| {
                    let g = f64::from(x) * d[0] + f64::from(y) * d[1];
                    [(g * d[0]) as f32, (g * d[1]) as f32]
                });
            }
        }
    }

    /// Step `i`'s deflection [x, y] (µm) where the flank on `side` (0 left,
    /// 1 right) leaves a wall `z_mm` above the tip: linear between its bands'
    /// mid-heights, the nearest band's below the lowest and above the highest
    /// (MODEL.md §5.2).
    pub fn at(&self, i: usize, side: usize, z_mm: f64) -> [f64; 2] {
        let bands = self.of_step(i);
        let u = (z_mm / self.band_height_mm - 0.5).max(0.0);
        let k = (u.floor() as usize).min(bands.len() - 1);
        let a = bands[k][side].map(f64::from);
        match bands.get(k + 1) {
            Some(next) => {
                let t = u - k as f64;
                let b = next[side].map(f64::from);
                [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
            }
            None => a,
        }
    }

    /// The error (µm) of the face step `i` leaves with its flank on `side`
    /// from `face_mm[0]` to `face_mm[1]` above its tip (a column's top and
    /// its highest neighbour's), on the surface normal `n`: of the
    /// deflections ([`FlankDeflections::at`]) at both ends and at the bands'
    /// mid-heights between them, within the step's bands, the one of the
    /// largest error in size (MODEL.md §5.2).
    pub fn face_error_um(&self, i: usize, side: usize, face_mm: [f64; 2], n: [f64; 3]) -> f64 {
        let h = self.band_height_mm;
        let [lo, hi] = face_mm;
        let hi = hi.min(self.of_step(i).len() as f64 * h).max(lo);
        let error = |z: f64| cutting::surface_error_um(self.at(i, side, z), n);
        let mut worst = error(lo);
        let mut take = |e: f64| {
            if e.abs() > worst.abs() {
                worst = e;
            }
        };
        take(error(hi));
        // The mid-heights strictly inside the face.
        let first = (lo / h - 0.5).floor() + 1.0;
        let mut k = first.max(0.0);
        while (k + 0.5) * h < hi {
            take(error((k + 0.5) * h));
            k += 1.0;
        }
        worst
    }

    /// The largest deflection of any step's band and side, µm.
    pub(crate) fn largest_um(&self) -> f64 {
        self.bands
            .iter()
            .flatten()
            .map(|&[x, y]| f64::from(x).hypot(f64::from(y)))
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max)
    }
}

/// The height over `step`'s tool tip of the final top `top_mm` of the
/// column at (x, y), where the step passes the column (the point of the
/// step's XY line nearest it), mm (MODEL.md §5.2).
fn over_tip_mm(step: &dexel::Step, x: f64, y: f64, top_mm: f64) -> f64 {
    let [ax, ay, az] = step.from_mm;
    let [bx, by, bz] = step.to_mm;
    let (ux, uy) = (bx - ax, by - ay);
    let len2 = ux * ux + uy * uy;
    let t = if len2 > 0.0 {
        (((x - ax) * ux + (y - ay) * uy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    top_mm - (az + t * (bz - az))
}

/// A run's error map (MODEL.md §5).
pub(crate) enum ErrorMap {
    /// Every column's error, µm (empty for a tiled stock: its bands' are
    /// written by [`write_tiled_columns`]).
    Held(Vec<f32>),
    /// Made of the final stock and the initial stock's closed form (a box
    /// or a cylinder) on its grid where it is read, block of rows by block
    /// of rows as it is written: 4 B a column less held beside the steps and
    /// loads while the outputs are written.
    Made(dexel::Solid, dexel::Grid),
}

/// `range` widened to the finite values of `error_um` (a map's least and
/// greatest error from `[0, 0]`).
pub(crate) fn error_range_um(error_um: &[f32], range: [f64; 2]) -> [f64; 2] {
    error_um
        .iter()
        .filter(|e| e.is_finite())
        .map(|&e| f64::from(e))
        .fold(range, |[lo, hi], e| {
            [if e < lo { e } else { lo }, if e > hi { e } else { hi }]
        })
}

/// The initial stock's columns as the error map reads them: a stock (or a
/// band of rows) held, or the closed form it was made of, on its grid.
#[derive(Clone, Copy)]
pub(crate) enum Before<'a> {
    Stock(&'a Stock),
    Solid(&'a dexel::Solid, &'a dexel::Grid),
}

impl Before<'_> {
    pub(crate) fn grid(&self) -> &dexel::Grid {
        match self {
            Before::Stock(stock) => stock.grid(),
            Before::Solid(_, grid) => grid,
        }
    }

    /// Whether the point `p` (mm) lies in the material (the column whose
    /// cell holds its XY; outside the grid or the rows held: no).
    pub(crate) fn in_material(&self, p: [f64; 3]) -> bool {
        let g = self.grid();
        let fx = ((p[0] - g.x0_mm) / g.spacing_mm).floor();
        let fy = ((p[1] - g.y0_mm) / g.spacing_mm).floor();
        let rows = match self {
            Before::Stock(stock) => stock.rows(),
            Before::Solid(_, grid) => 0..grid.ny,
        };
        if !(fx >= 0.0 && fy >= rows.start as f64 && fx < g.nx as f64 && fy < rows.end as f64) {
            return false;
        }
        let z = p[2] as f32;
        let (ix, iy) = (fx as usize, fy as usize);
        let inside = |c: dexel::Column| c.intervals().any(|[lo, hi]| lo <= z && z <= hi);
        match self {
            Before::Stock(stock) => inside(stock.column(ix, iy)),
            Before::Solid(solid, grid) => inside(solid.column(grid, ix, iy)),
        }
    }
}

/// Thickness of `initial`'s material from `p` along the unit direction `n`,
/// mm, looked for up to `max_mm` (returned when the material goes on): the
/// stock that was there outside the final surface point `p` (MODEL.md §5).
/// Marches in quarter cells, then bisects the crossing to 1e-6 mm.
pub(crate) fn material_along_mm(initial: Before, p: [f64; 3], n: [f64; 3], max_mm: f64) -> f64 {
    let at = |t: f64| [p[0] + t * n[0], p[1] + t * n[1], p[2] + t * n[2]];
    if !initial.in_material(p) {
        return 0.0;
    }
    let ds = 0.25 * initial.grid().spacing_mm;
    let mut t_in = 0.0;
    while t_in < max_mm {
        let t_next = (t_in + ds).min(max_mm);
        if !initial.in_material(at(t_next)) {
            let mut t_out = t_next;
            while t_out - t_in > 1e-6 {
                let mid = 0.5 * (t_in + t_out);
                if initial.in_material(at(mid)) {
                    t_in = mid;
                } else {
                    t_out = mid;
                }
            }
            return t_in;
        }
        t_in = t_next;
    }
    max_mm
}

/// Predicted shape error of the columns `columns` (indices into `last`'s
/// columns), µm (MODEL.md §5), positive = material left, NaN where no step
/// cut; each column's is its own (a map made block by block is the whole
/// one bit for bit). `applied_um` is the offset each step was swept
/// with, `model` the deflection its removal causes where each of its bands
/// leaves a wall on the left of its feed and on the right (a column takes
/// the height of its final top over the step's tip and the side of the
/// step's line in `steps` it lies on, MODEL.md §5.2; a rapid: the offset it
/// was swept with).
/// The error is the model deflection projected on the outward normal of the
/// final surface; where it
/// says more material is left than the sweep's offset made (`model > applied`
/// along the normal), the excess is clamped to the stock that was there: the
/// initial stock's thickness outside the final surface along the normal.
pub(crate) fn clamped_error_map_um(
    initial: Before,
    last: &Stock,
    applied_um: &[[f64; 2]],
    model: &FlankDeflections,
    steps: &[TimedStep],
    columns: std::ops::Range<usize>,
) -> Vec<f32> {
    let grid = *last.grid();
    let rows = last.rows();
    // The tops and normals of the final surface asked column by column, not
    // held (12 B + 4 B a column, 77 MB at 2 200 × 2 200 columns).
    let top = |ix: usize, iy: usize| last.top_or_nan_at(iy * grid.nx + ix);
    columns
        .into_par_iter()
        .map(|c| {
            let step = last.last_cut()[c];
            if step == NEVER_CUT {
                return f32::NAN;
            }
            let (ix, iy) = (c % grid.nx, c / grid.nx);
            let n = cutting::surface_normal_at(top, grid.nx, rows.len(), ix, iy, grid.spacing_mm)
                .map(f64::from);
            if n.iter().any(|v| v.is_nan()) {
                return f32::NAN;
            }
            let step = step as usize;
            let (px, py) = (grid.x_mm(ix), grid.y_mm(rows.start + iy));
            let top_mm = f64::from(top(ix, iy));
            let applied = cutting::surface_error_um(applied_um[step], n);
            let s = &steps[step].step;
            let model = if s.rapid {
                applied
            } else {
                // The face the column stands for: from its top up to its
                // highest neighbour's (a wall's foot holds the wall).
                let highest = highest_neighbour_mm(top, [grid.nx, rows.len()], [ix, iy], top_mm);
                let z_mm = over_tip_mm(s, px, py, top_mm);
                let face_mm = [z_mm, z_mm + (highest - top_mm)];
                model.face_error_um(step, flank_side(s, px, py), face_mm, n)
            };
            if model <= applied {
                return model as f32;
            }
            let p = [px, py, top_mm];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let unit = n.map(|v| v / len);
            let room_um = 1e3 * material_along_mm(initial, p, unit, 1e-3 * (model - applied));
            (applied + room_um.min(model - applied)) as f32
        })
        .collect()
}

/// The highest of the finite tops `top` of the four neighbours of column
/// `[ix, iy]` on a grid of `[nx, ny]` columns, and of its own `own_mm`, mm.
fn highest_neighbour_mm(
    top: impl Fn(usize, usize) -> f32,
    [nx, ny]: [usize; 2],
    [ix, iy]: [usize; 2],
    own_mm: f64,
) -> f64 {
    [(-1, 0), (1, 0), (0, -1), (0, 1)]
        .into_iter()
        .filter_map(|(dx, dy)| {
            let (jx, jy) = (ix.checked_add_signed(dx)?, iy.checked_add_signed(dy)?);
            (jx < nx && jy < ny).then(|| f64::from(top(jx, jy)))
        })
        .filter(|t| t.is_finite())
        .fold(own_mm, f64::max)
}

/// Which flank of `step`'s tool leaves the column at (x, y): 0 where it lies
/// on the left of the step's XY line (φ = 0, up milling's wall), 1 on the
/// right (MODEL.md §5.2).
fn flank_side(step: &dexel::Step, x: f64, y: f64) -> usize {
    let (ux, uy) = (
        step.to_mm[0] - step.from_mm[0],
        step.to_mm[1] - step.from_mm[1],
    );
    let e = ux * (y - step.from_mm[1]) - uy * (x - step.from_mm[0]);
    usize::from(e < 0.0)
}

impl Run {
    /// The predicted shape error of every column, µm (MODEL.md §5): the map
    /// held, or made of the final stock (empty for a tiled stock, whose map
    /// [`write_tiled_columns`] writes band by band).
    pub fn error_map_um(&self) -> std::borrow::Cow<'_, [f32]> {
        match &self.error_map {
            ErrorMap::Held(error) => std::borrow::Cow::Borrowed(error),
            ErrorMap::Made(..) => self.error_map_at(0..self.stock.grid().len()),
        }
    }

    /// The least and greatest error of the map, µm, from `[0, 0]` (its
    /// finite values; a tiled stock's as [`write_tiled_columns`] found them).
    /// Found once: a map made where it is read is made block of rows by
    /// block of rows in order (the fold over the whole map), unless
    /// [`Run::write_columns`] went through it first.
    pub fn error_range_um(&self) -> [f64; 2] {
        *self.error_range_um.get_or_init(|| match &self.error_map {
            ErrorMap::Held(error) => error_range_um(error, [0.0, 0.0]),
            ErrorMap::Made(..) => row_blocks(self.stock.grid()).fold([0.0, 0.0], |range, at| {
                error_range_um(&self.error_map_at(at), range)
            }),
        })
    }

    /// The predicted shape error of the columns `at` (indices into the
    /// grid), µm: those of [`Run::error_map_um`].
    pub fn error_map_at(&self, at: std::ops::Range<usize>) -> std::borrow::Cow<'_, [f32]> {
        match &self.error_map {
            ErrorMap::Held(error) => std::borrow::Cow::Borrowed(&error[at]),
            ErrorMap::Made(solid, grid) => std::borrow::Cow::Owned(clamped_error_map_um(
                Before::Solid(solid, grid),
                &self.stock,
                &self.offsets_um,
                &self.model_um,
                &self.steps,
                at,
            )),
        }
    }
}

/// The final stock, its error map and the final volume of a run from
/// `initial` whose last pass left `final_stock` (none for a tiled stock: an
/// empty one, no map, NaN). The map of a stock made of its closed form is
/// made where it is read ([`ErrorMap::Made`]); the others' held.
pub(crate) fn final_error_map(
    initial: &Initial,
    final_stock: Option<Stock>,
    offsets_um: &[[f64; 2]],
    model_um: &FlankDeflections,
    steps: &[TimedStep],
) -> Result<(Stock, ErrorMap, f64)> {
    Ok(match (initial, final_stock) {
        (Initial::Tiled(tiling), _) => (tiling.empty()?, ErrorMap::Held(Vec::new()), f64::NAN),
        (Initial::Made(solid, grid), Some(last)) => {
            let volume = last.volume_mm3();
            (last, ErrorMap::Made(*solid, *grid), volume)
        }
        (Initial::Held(_), Some(last)) => {
            let before = initial.columns().expect("a whole stock");
            let all = 0..last.last_cut().len();
            let error_um = clamped_error_map_um(before, &last, offsets_um, model_um, steps, all);
            let volume = last.volume_mm3();
            (last, ErrorMap::Held(error_um), volume)
        }
        (_, None) => unreachable!("a whole stock's pass keeps its stock"),
    })
}

#[cfg(test)]
mod tests {
    use super::FlankDeflections;

    /// One step of three 1 mm bands whose left flank's y deflection is 1, 3
    /// and −2 µm.
    fn three_bands() -> FlankDeflections {
        FlankDeflections {
            band_height_mm: 1.0,
            start: vec![0, 3],
            bands: [1.0, 3.0, -2.0].map(|y| [[0.0, y], [0.0, 0.0]]).to_vec(),
        }
    }

    /// Linear between the bands' mid-heights, the nearest band's beyond.
    #[test]
    fn a_height_between_bands_takes_them_linearly() {
        let f = three_bands();
        let y = |z: f64| f.at(0, 0, z)[1];
        assert_eq!(y(0.0), 1.0);
        assert_eq!(y(0.5), 1.0);
        assert_eq!(y(1.0), 2.0);
        assert_eq!(y(1.5), 3.0);
        assert_eq!(y(2.25), 3.0 - 0.75 * 5.0);
        assert_eq!(y(9.0), -2.0);
        assert_eq!(f.at(0, 1, 1.0), [0.0, 0.0]);
    }

    /// A face takes its error of largest size among its ends and the bands'
    /// mid-heights inside it, within the step's bands.
    #[test]
    fn a_face_takes_its_largest_error() {
        let f = three_bands();
        let n = [0.0, 1.0, 0.0];
        // A floor column: its own height.
        assert_eq!(f.face_error_um(0, 0, [0.75, 0.75], n), 1.5);
        // Up to 1.5 mm: band 1's mid-height, 3 µm.
        assert_eq!(f.face_error_um(0, 0, [0.0, 1.2], n), 2.4);
        assert_eq!(f.face_error_um(0, 0, [0.0, 1.8], n), 3.0);
        // Up to the top of the bands (the neighbour's top higher still):
        // band 2's −2 µm is not larger in size than band 1's 3.
        assert_eq!(f.face_error_um(0, 0, [0.0, 20.0], n), 3.0);
        // Along the other normal, the overcut: −3 µm.
        assert_eq!(f.face_error_um(0, 0, [0.0, 20.0], [0.0, -1.0, 0.0]), -3.0);
    }
}
