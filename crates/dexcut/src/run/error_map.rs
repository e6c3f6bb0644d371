//! The run's error map (MODEL.md §5): the deflection projected on the final
//! surface, clamped to the stock that was there; held, or made where it is
//! read.

use dexel::{Stock, NEVER_CUT};
use rayon::prelude::*;

use super::columns::row_blocks;
use super::{Initial, Run};
use crate::error::Result;
use crate::motion::TimedStep;

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
/// with, `model_um` the deflection its removal causes when it leaves a wall on
/// the left of its feed and on the right (a column takes the side it lies on
/// from the step's line in `steps`, MODEL.md §5.2). The error is the model
/// deflection projected on the outward normal of the final surface; where it
/// says more material is left than the sweep's offset made (`model > applied`
/// along the normal), the excess is clamped to the stock that was there: the
/// initial stock's thickness outside the final surface along the normal.
pub(crate) fn clamped_error_map_um(
    initial: Before,
    last: &Stock,
    applied_um: &[[f64; 2]],
    model_um: &[[[f64; 2]; 2]],
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
            let applied = cutting::surface_error_um(applied_um[step], n);
            let model =
                cutting::surface_error_um(model_um[step][flank_side(&steps[step].step, px, py)], n);
            if model <= applied {
                return model as f32;
            }
            let p = [px, py, f64::from(top(ix, iy))];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let unit = n.map(|v| v / len);
            let room_um = 1e3 * material_along_mm(initial, p, unit, 1e-3 * (model - applied));
            (applied + room_um.min(model - applied)) as f32
        })
        .collect()
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

/// The final stock, its error map, the map's range where it is not held,
/// and the final volume, of a run from `initial` whose last pass left
/// `final_stock` (none for a tiled stock: an empty one, no map, NaN).
pub(crate) fn final_error_map(
    initial: &Initial,
    final_stock: Option<Stock>,
    offsets_um: &[[f64; 2]],
    model_um: &[[[f64; 2]; 2]],
    steps: &[TimedStep],
) -> Result<(Stock, ErrorMap, Option<[f64; 2]>, f64)> {
    Ok(match (initial, final_stock) {
        (Initial::Tiled(tiling), _) => {
            (tiling.empty()?, ErrorMap::Held(Vec::new()), None, f64::NAN)
        }
        (Initial::Made(solid, grid), Some(last)) => {
            // The map's range, block of rows by block of rows in order (the
            // same fold as over the whole map); the map is made again where
            // it is written.
            let before = initial.columns().expect("a whole stock");
            let mut range = [0.0, 0.0];
            for at in row_blocks(last.grid()) {
                let error = clamped_error_map_um(before, &last, offsets_um, model_um, steps, at);
                range = error_range_um(&error, range);
            }
            let volume = last.volume_mm3();
            (last, ErrorMap::Made(*solid, *grid), Some(range), volume)
        }
        (Initial::Held(_), Some(last)) => {
            let before = initial.columns().expect("a whole stock");
            let all = 0..last.last_cut().len();
            let error_um = clamped_error_map_um(before, &last, offsets_um, model_um, steps, all);
            let volume = last.volume_mm3();
            (last, ErrorMap::Held(error_um), None, volume)
        }
        (_, None) => unreachable!("a whole stock's pass keeps its stock"),
    })
}
