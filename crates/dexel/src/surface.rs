//! The normal of the stock surface next to a tool: S3's cutting-surface angle
//! taken from the stock the removal leaves (MODEL.md §6.3).

use crate::Stock;

/// Mean unit normal of the stock surface nearest to `centre_mm` (a ball
/// centre), pointing from the surface towards the centre. MODEL.md §6.3:
/// every material interval's nearest point P to the centre is a surface
/// point; those within `tolerance_mm` of the nearest distance are the points
/// the tool touches, and the mean of their unit vectors (C − P)/|C − P| is the
/// normal. Where that mean leans along the feed direction `along` by less than
/// `ALONG_BIAS`, the lean is the grid's sampling bias (the surface a moving
/// ball leaves contains the feed direction) and is removed. `None` when no
/// material lies within `max_reach_mm` of the centre.
pub fn surface_normal_near(
    stock: &Stock,
    centre_mm: [f64; 3],
    along: [f64; 3],
    tolerance_mm: f64,
    max_reach_mm: f64,
) -> Option<[f64; 3]> {
    let grid = stock.grid();
    let [cx, cy, cz] = centre_mm;
    let mut reach = (tolerance_mm + 2.0 * grid.spacing_mm).max(1e-9);
    let mut near: Vec<(f64, [f64; 3])> = Vec::new();
    loop {
        near.clear();
        let mut d_min = f64::INFINITY;
        if let (Some((x0, x1)), Some((y0, y1))) = (
            grid.ix_range(cx - reach, cx + reach),
            grid.iy_range(cy - reach, cy + reach),
        ) {
            for iy in y0..=y1 {
                let dy = cy - grid.y_mm(iy);
                for ix in x0..=x1 {
                    let dx = cx - grid.x_mm(ix);
                    if dx * dx + dy * dy > reach * reach {
                        continue;
                    }
                    for [lo, hi] in stock.column(ix, iy).intervals() {
                        let dz = cz - cz.clamp(lo as f64, hi as f64);
                        let d = (dx * dx + dy * dy + dz * dz).sqrt();
                        if d > 0.0 {
                            d_min = d_min.min(d);
                            near.push((d, [dx / d, dy / d, dz / d]));
                        }
                    }
                }
            }
        }
        if d_min + tolerance_mm <= reach {
            let mut n = [0.0; 3];
            for (_, v) in near.iter().filter(|(d, _)| *d <= d_min + tolerance_mm) {
                (0..3).for_each(|k| n[k] += v[k]);
            }
            let len = norm(n);
            if len == 0.0 {
                return None;
            }
            n = n.map(|c| c / len);
            let a = norm(along);
            if a > 0.0 {
                let u = along.map(|c| c / a);
                let dot: f64 = (0..3).map(|k| n[k] * u[k]).sum();
                if dot.abs() < ALONG_BIAS {
                    let m: [f64; 3] = std::array::from_fn(|k| n[k] - dot * u[k]);
                    let l = norm(m);
                    return (l > 0.0).then(|| m.map(|c| c / l));
                }
            }
            return Some(n);
        }
        if reach >= max_reach_mm {
            return None;
        }
        reach = (2.0 * reach).max(d_min + tolerance_mm).min(max_reach_mm);
    }
}

/// Largest component of the mean normal along the feed direction that is
/// taken as grid sampling bias (sin 10°); a larger one is a cut with the
/// tool's front (a plunge or a ramp into material) and is kept.
pub const ALONG_BIAS: f64 = 0.173_648_177_666_930_4;

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Angle in degrees between a surface normal and the tool axis (+Z), folded
/// into [0°, 90°] (MODEL.md §6.3: 0° floor, 90° wall).
pub fn angle_to_axis_deg(normal: [f64; 3]) -> f64 {
    let len = norm(normal);
    (normal[2].abs() / len)
        .clamp(0.0, 1.0)
        .acos()
        .to_degrees()
        .min(90.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Grid;

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    }

    #[test]
    fn plane_normals_are_exact() {
        // Stock whose top is the plane z = −x (45°); y symmetric about the centre's row.
        let grid = Grid::covering(-10.0, -5.0, 10.0, 5.0, 0.1).unwrap();
        let stock = Stock::from_columns(grid, |ix, _, out| {
            out.push([-20.0, -(grid.x_mm(ix) as f32)]);
        })
        .unwrap();
        // A centre 5 mm above the plane along its normal (1, 0, 1)/√2.
        let h = 5.0 / 2f64.sqrt();
        let n = surface_normal_near(
            &stock,
            [0.3 + h, 0.0, -0.3 + h],
            [1.0, 0.0, -1.0],
            0.05,
            50.0,
        )
        .unwrap();
        close(angle_to_axis_deg(n), 45.0, 1e-4);
        close(n[1], 0.0, 1e-12);
        // A vertical wall: columns at x ≥ 2 stand from 0 to 10, none elsewhere.
        let wall = Stock::from_columns(grid, |ix, _, out| {
            if grid.x_mm(ix) >= 2.0 {
                out.push([0.0, 10.0]);
            }
        })
        .unwrap();
        let n = surface_normal_near(&wall, [-3.0, 0.0, 5.0], [0.0, 1.0, 0.0], 0.05, 50.0).unwrap();
        assert_eq!(angle_to_axis_deg(n), 90.0);
        // A flat floor at z = 0 below the centre.
        let floor = Stock::from_columns(grid, |_, _, out| out.push([-5.0, 0.0])).unwrap();
        let n = surface_normal_near(&floor, [0.05, 0.0, 5.0], [1.0, 0.0, 0.0], 0.05, 50.0).unwrap();
        close(angle_to_axis_deg(n), 0.0, 1e-9);
        // Nothing within reach.
        assert!(
            surface_normal_near(&floor, [0.0, 0.0, 50.0], [1.0, 0.0, 0.0], 0.05, 10.0).is_none()
        );
    }
}
