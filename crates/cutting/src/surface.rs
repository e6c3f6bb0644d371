//! Error map: the tool's deflection projected on the final surface (MODEL.md §5).

/// Predicted shape error in µm at a surface point cut while the tool was deflected by
/// `deflection_xy_um` (µm, machine frame), given the **outward** normal of the final stock there
/// (pointing from material into air; need not be unit length).
///
/// Sign: **positive = material left** (undercut), negative = gouge (overcut). The outward normal
/// points from the finished surface towards the tool's side. A tool pushed away from the wall it
/// is cutting moves into free space, i.e. along the outward normal, stops short of the nominal
/// surface and leaves material. So the error is `+ deflection · n̂` (the deflection has no Z
/// component, so a flat floor with n̂ = +Z gets zero error from lateral bending).
///
/// Returns NaN when the normal has no direction (zero or NaN, e.g. an empty column).
pub fn surface_error_um(deflection_xy_um: [f64; 2], surface_normal: [f64; 3]) -> f64 {
    let [nx, ny, nz] = surface_normal;
    let len = (nx * nx + ny * ny + nz * nz).sqrt();
    if len.is_nan() || len == 0.0 {
        return f64::NAN;
    }
    // MODEL.md §5: e = δ · n̂ (positive: material left)
    (deflection_xy_um[0] * nx + deflection_xy_um[1] * ny) / len
}

/// Unit outward normals of a height field `z = h(x, y)` sampled on an `nx × ny` grid with
/// `spacing_mm` between columns, stored row-major (`heights[iy * nx + ix]`, x fastest): each
/// column's [`surface_normal_at`].
///
/// # Panics
/// If `heights.len() != nx * ny`.
pub fn surface_normals_from_heights(
    heights: &[f32],
    nx: usize,
    ny: usize,
    spacing_mm: f64,
) -> Vec<[f32; 3]> {
    assert_eq!(heights.len(), nx * ny, "height field is not nx × ny");
    let height = |ix: usize, iy: usize| heights[iy * nx + ix];
    (0..ny)
        .flat_map(|iy| (0..nx).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| surface_normal_at(height, nx, ny, ix, iy, spacing_mm))
        .collect()
}

/// Unit outward normal at column `(ix, iy)` of a height field `z = h(x, y)` sampled on an
/// `nx × ny` grid with `spacing_mm` between columns, `height(ix, iy)` its heights (asked for
/// the column and its four neighbours only, so the field need not be held).
///
/// The normal is `(−∂h/∂x, −∂h/∂y, 1)` normalised, with central differences. NaN heights mark
/// columns with no material: such a column gets a NaN normal, and its neighbours fall back to
/// the one-sided difference on the side that has a height (or zero slope when neither side has).
/// The grid border is handled the same way.
#[inline]
pub fn surface_normal_at(
    height: impl Fn(usize, usize) -> f32,
    nx: usize,
    ny: usize,
    ix: usize,
    iy: usize,
    spacing_mm: f64,
) -> [f32; 3] {
    let at = |ix: usize, iy: usize| f64::from(height(ix, iy));
    // Slope along one axis from the centre height and the optional neighbours before and after.
    let slope = |before: Option<f64>, centre: f64, after: Option<f64>| -> f64 {
        match (
            before.filter(|h| !h.is_nan()),
            after.filter(|h| !h.is_nan()),
        ) {
            // ∂h ≈ (h₊ − h₋) / 2g
            (Some(b), Some(a)) => (a - b) / (2.0 * spacing_mm),
            (Some(b), None) => (centre - b) / spacing_mm,
            (None, Some(a)) => (a - centre) / spacing_mm,
            (None, None) => 0.0,
        }
    };
    let h = at(ix, iy);
    if h.is_nan() {
        return [f32::NAN; 3];
    }
    let dhdx = slope(
        (ix > 0).then(|| at(ix - 1, iy)),
        h,
        (ix + 1 < nx).then(|| at(ix + 1, iy)),
    );
    let dhdy = slope(
        (iy > 0).then(|| at(ix, iy - 1)),
        h,
        (iy + 1 < ny).then(|| at(ix, iy + 1)),
    );
    // n = (−∂h/∂x, −∂h/∂y, 1) / |…|
    let len = (dhdx * dhdx + dhdy * dhdy + 1.0).sqrt();
    [
        (-dhdx / len) as f32,
        (-dhdy / len) as f32,
        (1.0 / len) as f32,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::force_direction;

    #[test]
    fn wall_on_plus_x_pushed_away_leaves_material() {
        // The tool cuts a wall of material lying on its +x side; the finished wall faces −x.
        // Contact resultant points +x, so the force (and deflection) points −x, along the
        // outward normal: the tool backs off the wall and leaves material (positive).
        let [ux, uy] = force_direction([1.0, 0.0, 0.0]);
        let deflection_um = [20.0 * ux, 20.0 * uy];
        assert_eq!(surface_error_um(deflection_um, [-1.0, 0.0, 0.0]), 20.0);
        // Same wall, tool pulled into it (e.g. climb milling pulling the tool in): gouge.
        assert_eq!(surface_error_um([20.0, 0.0], [-1.0, 0.0, 0.0]), -20.0);
        // A wall on the −x side facing +x, tool pushed to +x: material left again.
        assert_eq!(surface_error_um([15.0, 0.0], [1.0, 0.0, 0.0]), 15.0);
    }

    #[test]
    fn floor_and_slope() {
        // Lateral bending does not change the height of a flat floor.
        assert_eq!(surface_error_um([20.0, -7.0], [0.0, 0.0, 1.0]), 0.0);
        // A 45° slope rising towards +x faces (−1, 0, 1)/√2 (normal need not be unit).
        let e = surface_error_um([-10.0, 0.0], [-1.0, 0.0, 1.0]);
        assert!((e - 10.0 / 2f64.sqrt()).abs() < 1e-12);
        assert!(surface_error_um([1.0, 1.0], [0.0, 0.0, 0.0]).is_nan());
        assert!(surface_error_um([1.0, 1.0], [f64::NAN, 0.0, 1.0]).is_nan());
    }

    #[test]
    fn plane_normals() {
        // z = 0.5 x + 0.25 y on a 0.5 mm grid: n ∝ (−0.5, −0.25, 1) everywhere, borders included.
        let (nx, ny, g) = (5, 4, 0.5);
        let heights: Vec<f32> = (0..nx * ny)
            .map(|i| (0.5 * (i % nx) as f64 * g + 0.25 * (i / nx) as f64 * g) as f32)
            .collect();
        let len = (0.25f64 + 0.0625 + 1.0).sqrt();
        let expected = [
            (-0.5 / len) as f32,
            (-0.25 / len) as f32,
            (1.0 / len) as f32,
        ];
        for n in surface_normals_from_heights(&heights, nx, ny, g) {
            for k in 0..3 {
                assert!((n[k] - expected[k]).abs() < 1e-6, "{n:?} vs {expected:?}");
            }
        }
    }

    #[test]
    fn nan_columns() {
        // Row: 1, 2, NaN, 5 (mm, spacing 1): the NaN column gets a NaN normal, its neighbours
        // use the one-sided slope on their material side; an isolated column is flat.
        let normals = surface_normals_from_heights(&[1.0, 2.0, f32::NAN, 5.0], 4, 1, 1.0);
        assert!(normals[2].iter().all(|c| c.is_nan()));
        let s = 1.0 / 2f32.sqrt();
        assert!((normals[0][0] + s).abs() < 1e-6 && (normals[0][2] - s).abs() < 1e-6);
        assert!((normals[1][0] + s).abs() < 1e-6 && (normals[1][2] - s).abs() < 1e-6);
        assert_eq!(normals[3], [0.0, 0.0, 1.0]);
    }
}
