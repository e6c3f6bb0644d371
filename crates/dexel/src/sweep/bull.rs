//! Bull nose (torus corner): the lower surface over a column is convex along
//! the move, so its minimum is at an end or at its slope's root (Newton's
//! steps in a bracket, MODEL.md §1.2); a level move and a plunge have it in
//! closed form.

use super::{
    disc_interval, disc_roots, row_hits_by_column, sphere_reach2, torus_edge, torus_mean_inv_sin_k,
    Edge, Envelope, EnvelopeHit, Prepared, RowHits, Span, ABOVE_MARGIN_MM, BOTTOM_MM, PLUNGE_H2,
};

/// The search for the lowest point stops when its step, or its bracket of
/// the lowest point, is this short along the move, mm (far below an f32
/// height's resolution).
const NEWTON_TOL_MM: f64 = 1e-9;

/// Most steps of that search (each halves the bracket at least where
/// Newton's step would leave it; 3.8 on average where the benchmark's
/// finishing moves take it).
const NEWTON_MAX_STEPS: usize = 200;

pub(super) struct BullNose {
    pub(super) r: f64,
    /// Corner radius and the radius of the torus centre circle (R − r_c).
    pub(super) rc: f64,
    pub(super) ring: f64,
}

impl BullNose {
    /// Height of the tool's lower surface above its tip at horizontal distance ρ
    /// (the corner's value, computed either way, taken beyond the flat
    /// bottom by a select: one expression for a column and a row in lanes).
    #[inline(always)]
    fn profile(&self, rho: f64) -> f64 {
        let e = rho - self.ring;
        let corner = self.rc - (self.rc * self.rc - (e * e).min(self.rc * self.rc)).sqrt();
        if e <= 0.0 {
            0.0
        } else {
            corner
        }
    }

    #[inline(always)]
    fn height(&self, m: &Prepared, x: f64, y: f64, t: f64) -> f64 {
        let (ax, ay) = (m.p0[0] + t * m.d[0], m.p0[1] + t * m.d[1]);
        let rho = ((x - ax) * (x - ax) + (y - ay) * (y - ay)).sqrt();
        self.profile(rho) + m.p0[2] + t * m.d[2]
    }

    /// [`Envelope::stays_above`] of the column at `(wx, wy)` from the move's
    /// start: one expression for it and the row in lanes.
    #[inline(always)]
    fn clears(&self, m: &Prepared, wx: f64, wy: f64, top: f64) -> bool {
        let t = ((wx * m.d[0] + wy * m.d[1]) * m.inv_h2).clamp(0.0, 1.0);
        let (ex, ey) = (wx - t * m.d[0], wy - t * m.d[1]);
        let reach = self.ring + sphere_reach2(self.rc, top - m.zmin + ABOVE_MARGIN_MM).sqrt();
        ex * ex + ey * ey >= reach * reach
    }

    /// The slope dh/dt of the lower surface's height over the column at
    /// `(wx, wy)` from the move's start, at t, and its curvature d²h/dt²
    /// (MODEL.md §1.2): with ρ(t) the column's XY distance from the axis and
    /// e = ρ − ring, h = z₀ + t·dz + r_c − √(r_c² − e²) on the corner (e > 0),
    /// so h′ = dz + e·ρ′/S and h″ = ρ′²·r_c²/S³ + e·ρ″/S with S = √(r_c² − e²),
    /// ρ′ = −(E·D)/ρ and ρ″ = (|D|² − ρ′²)/ρ (E the column less the axis, D
    /// the move, in XY); on the flat bottom (e ≤ 0) h′ = dz, h″ = 0. At the
    /// rim (S = 0) the slope is infinite, its sign ρ′'s.
    #[inline]
    fn slope(&self, m: &Prepared, wx: f64, wy: f64, t: f64) -> (f64, f64) {
        let [dx, dy, dz] = m.d;
        let (ex, ey) = (wx - t * dx, wy - t * dy);
        let rho = (ex * ex + ey * ey).sqrt();
        let e = rho - self.ring;
        if e <= 0.0 || rho <= 0.0 {
            return (dz, 0.0);
        }
        let d_rho = -(ex * dx + ey * dy) / rho;
        let dd_rho = (m.h2 - d_rho * d_rho) / rho;
        let s2 = self.rc * self.rc - e * e;
        if s2 <= 0.0 {
            let slope = if d_rho > 0.0 {
                f64::INFINITY
            } else if d_rho < 0.0 {
                f64::NEG_INFINITY
            } else {
                dz
            };
            return (slope, f64::INFINITY);
        }
        let s = s2.sqrt();
        (
            dz + e * d_rho / s,
            d_rho * d_rho * self.rc * self.rc / (s2 * s) + e * dd_rho / s,
        )
    }
}

impl Envelope for BullNose {
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<EnvelopeHit> {
        let Span {
            lo: mut a,
            hi: mut b,
        } = disc_interval(m, x, y, self.r)?;
        if m.d[2] == 0.0 || m.h2 <= PLUNGE_H2 {
            // Closed forms: a level move is lowest where the axis passes
            // closest to the column (the profile does not decrease with ρ; that
            // point lies in the disc interval), a plunge at its lower end.
            let t = if m.h2 <= PLUNGE_H2 {
                if m.d[2] >= 0.0 {
                    a
                } else {
                    b
                }
            } else {
                ((x - m.p0[0]) * m.d[0] + (y - m.p0[1]) * m.d[1]) * m.inv_h2
            }
            .clamp(a, b);
            return Some(EnvelopeHit {
                z_mm: self.height(m, x, y, t),
                t,
            });
        }
        // The lowest point of a convex function on [a, b]: its slope's root,
        // by Newton's steps kept inside a bracket of the root (halving it
        // where a step leaves it), to NEWTON_TOL_MM along the move.
        let tol_t = NEWTON_TOL_MM * m.inv_dd.sqrt();
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let t = if self.slope(m, wx, wy, a).0 >= 0.0 {
            a
        } else if self.slope(m, wx, wy, b).0 <= 0.0 {
            b
        } else {
            // From where the axis passes closest to the column.
            let closest = (wx * m.d[0] + wy * m.d[1]) * m.inv_h2;
            let mut t = if closest > a && closest < b {
                closest
            } else {
                0.5 * (a + b)
            };
            for _ in 0..NEWTON_MAX_STEPS {
                let (slope, curvature) = self.slope(m, wx, wy, t);
                if slope > 0.0 {
                    b = t;
                } else if slope < 0.0 {
                    a = t;
                } else {
                    break;
                }
                let newton = t - slope / curvature;
                let next = if newton > a && newton < b {
                    newton
                } else {
                    0.5 * (a + b)
                };
                let step = (next - t).abs();
                t = next;
                if step <= tol_t || b - a <= tol_t {
                    break;
                }
            }
            t
        };
        // The height at the slope's root, or at the end the slope there
        // says is lowest.
        Some(EnvelopeHit {
            z_mm: self.height(m, x, y, t),
            t,
        })
    }

    /// The ball's bound moved out by the ring: over a column at XY distance ρ
    /// from the move's axis segment the lower surface is at least
    /// z_min + profile(ρ) (the profile does not decrease), and on the corner
    /// profile(ρ) = rc − √(rc² − e²) with e = ρ − ring; so the swept tool stays
    /// above `top` where e² ≥ [`sphere_reach2`]`(rc, top − z_min + margin)`.
    #[inline]
    fn stays_above(&self, m: &Prepared, x: f64, y: f64, top: f64) -> bool {
        self.clears(m, x - m.p0[0], y - m.p0[1], top)
    }

    #[inline(always)]
    fn row_in_lanes(&self) -> bool {
        true
    }

    /// A level move's row in lanes, free of branches: for every column the
    /// closed form of [`BullNose::eval`] (the column's interval under the
    /// tool's disc, where the axis passes closest clamped into it, the
    /// height there) and the bound of [`Envelope::stays_above`], each the
    /// same expression, the one that applies taken by a select: the same
    /// values bit for bit. Other moves column by column (the search of a
    /// sloped move does not take lanes).
    #[inline(always)]
    fn row_hits(
        &self,
        m: &Prepared,
        grid: &crate::Grid,
        y: f64,
        ix0: usize,
        tops: &[f32],
        hits: &mut RowHits,
    ) {
        if m.d[2] != 0.0 || m.h2 <= PLUNGE_H2 {
            return row_hits_by_column(self, m, grid, y, ix0, tops, hits);
        }
        debug_assert!(ix0 + tops.len() <= i32::MAX as usize);
        let r2 = self.r * self.r;
        let wy = y - m.p0[1];
        let zmin = m.zmin as f32;
        let n = tops.len();
        let (z_cut, t_cut) = (&mut hits.z_mm[..n], &mut hits.t[..n]);
        for (i, ((&top, z_out), t_out)) in tops.iter().zip(z_cut).zip(t_cut).enumerate() {
            let x = grid.x_mm_in_lanes(ix0 + i);
            let wx = x - m.p0[0];
            let stays = self.clears(m, wx, wy, top as f64);
            let roots = disc_roots(m, wx, wy, r2);
            let (hit, Span { lo: a, hi: b }) = (roots.hit(), roots.span);
            // `f64::clamp` where a ≤ b (NaN elsewhere, not taken).
            let closest = roots.k * m.inv_h2;
            let t = if closest < a {
                a
            } else if closest > b {
                b
            } else {
                closest
            };
            let z = self.height(m, x, y, t);
            let cut = top > zmin && !stays && hit;
            *z_out = if cut { z as f32 } else { f32::INFINITY };
            *t_out = if cut { t } else { 0.0 };
        }
    }

    #[inline]
    fn has_reach(&self) -> bool {
        true
    }

    /// The same bound for a whole row.
    #[inline]
    fn reach(&self, _m: &Prepared, depth: f64) -> Option<f64> {
        Some(self.ring + sphere_reach2(self.rc, depth + ABOVE_MARGIN_MM).sqrt())
    }

    #[inline]
    fn side(&self, h: f64) -> Edge {
        torus_edge(h, self.r, self.rc, self.ring)
    }

    #[inline]
    fn mean_inv_sin_k(&self, h_bot: f64, h_top: f64) -> f64 {
        torus_mean_inv_sin_k(h_bot, h_top, self.rc)
            .unwrap_or_else(|| self.side(h_top.max(0.0)).inv_sin_k)
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        if h < BOTTOM_MM {
            1.0
        } else {
            ((self.rc - h) / self.rc).max(0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::ball::BallEnd;
    use crate::sweep::flat::FlatEnd;
    use crate::sweep::testing::*;
    use crate::sweep::Step;

    #[test]
    fn bull_envelope_matches_brute_force() {
        let env = BullNose {
            r: 5.0,
            rc: 2.0,
            ring: 3.0,
        };
        let profile = |rho: f64| (rho <= 5.0).then(|| env.profile(rho));
        check_against_brute_force(&env, &profile, 1e-4);
    }

    /// A move from `from` of `len` mm in XY at `dir` (rad from +X), rising
    /// `slope` mm a mm.
    fn sloped_step(from: [f64; 3], len: f64, dir: f64, slope: f64) -> Step {
        Step {
            from_mm: from,
            to_mm: [
                from[0] + len * dir.cos(),
                from[1] + len * dir.sin(),
                from[2] + len * slope,
            ],
            rapid: false,
        }
    }

    /// On sloped moves (the search's), the lowest point is a fine search's:
    /// a golden section of the height along the move to 10⁻¹³ of it, which
    /// took 70 heights a column, within 10⁻¹⁰ mm, never above it by more;
    /// the least and largest of the differences are printed.
    #[test]
    fn sloped_moves_lowest_points_are_a_fine_searchs() {
        let env = BullNose {
            r: 5.0,
            rc: 2.0,
            ring: 3.0,
        };
        let fine = |m: &Prepared, x: f64, y: f64| -> Option<f64> {
            let Span {
                lo: mut a,
                hi: mut b,
            } = disc_interval(m, x, y, env.r)?;
            const INV_PHI: f64 = 0.618_033_988_749_894_8;
            while b - a > 1e-13 {
                let (c, d) = (b - INV_PHI * (b - a), a + INV_PHI * (b - a));
                if env.height(m, x, y, c) <= env.height(m, x, y, d) {
                    b = d;
                } else {
                    a = c;
                }
            }
            let ends = [env.height(m, x, y, a), env.height(m, x, y, b)];
            let (lo, hi) = disc_interval(m, x, y, env.r).map(|s| (s.lo, s.hi))?;
            Some(
                ends.into_iter()
                    .chain([env.height(m, x, y, lo), env.height(m, x, y, hi)])
                    .fold(f64::INFINITY, f64::min),
            )
        };
        let (mut seed, mut compared) = (19, 0);
        let (mut lowest, mut highest) = (0.0f64, 0.0f64);
        for case in 0..20_000 {
            let mut r = || lcg(&mut seed) * 2.0 - 1.0;
            // Moves of 0.05–8 mm, sloped (up to 60° from level), columns
            // anywhere under the footprint.
            let len = 0.05 + 8.0 * (0.5 + 0.5 * r()).powi(2);
            let (dir, slope) = (std::f64::consts::PI * r(), 1.7 * r());
            let from = [3.0 * r(), 3.0 * r(), 2.0 * r()];
            let step = sloped_step(from, len, dir, slope);
            let m = Prepared::new(&step);
            let (x, y) = (from[0] + 6.0 * r(), from[1] + 6.0 * r());
            match (env.eval(&m, x, y), fine(&m, x, y)) {
                (Some(hit), Some(z)) => {
                    compared += 1;
                    let diff = hit.z_mm - z;
                    (lowest, highest) = (lowest.min(diff), highest.max(diff));
                    assert!(
                        (-1e-10..=1e-10).contains(&diff),
                        "case {case}: {} against the fine search's {z}",
                        hit.z_mm
                    );
                    assert_eq!(hit.z_mm, env.height(&m, x, y, hit.t), "case {case}");
                }
                (None, None) => {}
                (a, b) => panic!("case {case}: footprint differs: {a:?} vs {b:?}"),
            }
        }
        println!("{compared} columns: the search less the fine one {lowest:e} … {highest:e} mm");
        assert!(compared > 10_000, "{compared} columns compared");
    }

    /// Degenerate tools and moves (a corner of nearly the whole radius or
    /// of almost none, moves of a nanometre to 20 mm, nearly level and
    /// nearly plunging, columns on and near the rim): the search ends with
    /// a finite height on the column's interval, never above the height at
    /// any of 64 points of it by more than the height's own rounding at the
    /// rim (where dh/dρ is infinite, a rounding of ρ by 10⁻¹⁵ mm moves it by
    /// √(2 r_c·10⁻¹⁵) ≈ 10⁻⁷ mm; an f32 height's step is 5·10⁻⁷ mm at 4 mm).
    #[test]
    fn degenerate_bull_noses_and_moves_give_the_lowest_point() {
        const RIM_NOISE_MM: f64 = 1e-6;
        let mut seed = 23;
        let mut found = 0;
        for (rc, ring) in [
            (1e-9, 5.0 - 1e-9),
            (5.0 - 1e-9, 1e-9),
            (2.0, 3.0),
            (0.5, 4.5),
        ] {
            let env = BullNose {
                r: rc + ring,
                rc,
                ring,
            };
            for case in 0..4000 {
                let mut r = || lcg(&mut seed) * 2.0 - 1.0;
                let len = 10f64.powf(-9.0 + 10.3 * (0.5 + 0.5 * r()));
                let (dir, slope) = (
                    std::f64::consts::PI * r(),
                    10f64.powf(-8.0 + 11.0 * (0.5 + 0.5 * r())) * r().signum(),
                );
                let from = [r(), r(), r()];
                let step = sloped_step(from, len, dir, slope);
                let m = Prepared::new(&step);
                // Columns anywhere, some on the rim of the start's disc.
                let (x, y) = if case % 4 == 0 {
                    let a = std::f64::consts::PI * r();
                    (from[0] + env.r * a.cos(), from[1] + env.r * a.sin())
                } else {
                    (from[0] + 6.0 * r(), from[1] + 6.0 * r())
                };
                let Some(hit) = env.eval(&m, x, y) else {
                    continue;
                };
                found += 1;
                assert!(
                    hit.z_mm.is_finite() && (0.0..=1.0).contains(&hit.t),
                    "{hit:?}"
                );
                let span = disc_interval(&m, x, y, env.r).expect("a hit lies under the disc");
                for i in 0..=64 {
                    let t = span.lo + (span.hi - span.lo) * i as f64 / 64.0;
                    let z = env.height(&m, x, y, t);
                    assert!(
                        hit.z_mm <= z + RIM_NOISE_MM,
                        "case {case}: {hit:?} above {z} at t {t} (r_c {rc}, ring {ring}, move {len} mm)"
                    );
                }
            }
        }
        assert!(found > 5000, "{found} columns hit");
    }

    #[test]
    fn bull_nose_limits_are_ball_and_flat() {
        let mut seed = 11;
        let (ball, flat) = (BallEnd { r: 5.0 }, FlatEnd::new(5.0));
        let near_ball = BullNose {
            r: 5.0,
            rc: 5.0 - 1e-12,
            ring: 1e-12,
        };
        let near_flat = BullNose {
            r: 5.0,
            rc: 1e-12,
            ring: 5.0 - 1e-12,
        };
        let (mut ball_hits, mut flat_hits) = (0, 0);
        for _ in 0..500 {
            let mut r = || lcg(&mut seed) * 20.0 - 10.0;
            let step = Step {
                from_mm: [r(), r(), r()],
                to_mm: [r(), r(), r()],
                rapid: false,
            };
            let m = Prepared::new(&step);
            let (x, y) = (r() * 0.5, r() * 0.5);
            for (exact, limit, hits) in [
                (
                    ball.eval(&m, x, y),
                    near_ball.eval(&m, x, y),
                    &mut ball_hits,
                ),
                (
                    flat.eval(&m, x, y),
                    near_flat.eval(&m, x, y),
                    &mut flat_hits,
                ),
            ] {
                match (exact, limit) {
                    (Some(a), Some(b)) => {
                        *hits += 1;
                        assert!((a.z_mm - b.z_mm).abs() < 1e-6, "{a:?} vs {b:?}");
                    }
                    (None, None) => {}
                    (a, b) => panic!("footprint differs: {a:?} vs {b:?}"),
                }
            }
        }
        assert!(
            ball_hits > 100 && flat_hits > 100,
            "{ball_hits} ball, {flat_hits} flat hits"
        );
    }
}
