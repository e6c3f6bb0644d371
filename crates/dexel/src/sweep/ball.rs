//! Ball end: the swept ball is a capsule, its lower envelope a closed-form
//! ray–capsule intersection, with a square-root-free skip bound.

use super::arcsine::AsinDiff;
use super::{
    row_hits_by_column, sphere_reach2, torus_edge, torus_mean_inv_sin_k, ArcsineMean, Edge,
    Envelope, EnvelopeHit, Prepared, RowHits, ABOVE_MARGIN_MM, PLUNGE_H2,
};

pub(super) struct BallEnd {
    pub(super) r: f64,
}

/// The root of the capsule body's quadratic over a column (MODEL.md §1.2).
struct BodyRoot {
    /// Its discriminant: negative where the column misses the cylinder.
    disc: f64,
    /// ζ, the lowest height on the column relative to the first ball centre
    /// p0 + (0, 0, R) (NaN where `disc` < 0).
    zeta: f64,
    /// t*·|D|², where along the move it is attained.
    t_dd: f64,
}

impl BallEnd {
    /// The capsule body over the column at `(wx, wy)` from the move's start:
    /// |W − (W·D)D/|D|²|² = R² with W = (wx, wy, ζ), a quadratic in ζ (not a
    /// plunge). One expression for [`BallEnd::eval`] and the row in lanes.
    #[inline(always)]
    fn body_root(&self, m: &Prepared, wx: f64, wy: f64) -> BodyRoot {
        let [dx, dy, dz] = m.d;
        let rho0 = wx * wx + wy * wy;
        let k = wx * dx + wy * dy;
        let c = m.dd * rho0 - k * k - self.r * self.r * m.dd;
        let disc = k * k * dz * dz - m.h2 * c;
        let zeta = (k * dz - disc.sqrt()) * m.inv_h2;
        BodyRoot {
            disc,
            zeta,
            t_dd: k + zeta * dz,
        }
    }

    /// [`Envelope::stays_above`] of the column at `(wx, wy)` from the move's
    /// start: one expression for it and the row in lanes.
    #[inline(always)]
    fn clears(&self, m: &Prepared, wx: f64, wy: f64, top: f64) -> bool {
        let t = ((wx * m.d[0] + wy * m.d[1]) * m.inv_h2).clamp(0.0, 1.0);
        let (ex, ey) = (wx - t * m.d[0], wy - t * m.d[1]);
        ex * ex + ey * ey >= sphere_reach2(self.r, top - m.zmin + ABOVE_MARGIN_MM)
    }
}

impl Envelope for BallEnd {
    /// The points of the vertical line inside the ball at parameter t form a
    /// segment whose lower end m(t) = c_z(t) − √(R² − ρ(t)²) is convex in t
    /// (ρ² is a convex quadratic). Over all t the balls fill the infinite
    /// cylinder around the centre line, whose lowest point on the line (the
    /// body root ζ*, attained at t*) minimises m; so the envelope is the body
    /// root when t* ∈ [0, 1], else the end sphere on t*'s side — one square
    /// root for the body and at most one for a sphere, no comparison of
    /// candidates. If the line misses the cylinder it misses every ball.
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<EnvelopeHit> {
        let r2 = self.r * self.r;
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let [dx, dy, dz] = m.d;
        let at_end = if m.h2 > PLUNGE_H2 {
            let BodyRoot { disc, zeta, t_dd } = self.body_root(m, wx, wy);
            if disc < 0.0 {
                return None;
            }
            // t*·|D|², compared with [0, |D|²] without dividing.
            if t_dd < 0.0 {
                false
            } else if t_dd > m.dd {
                true
            } else {
                return Some(EnvelopeHit {
                    z_mm: m.p0[2] + self.r + zeta,
                    t: t_dd * m.inv_dd,
                });
            }
        } else {
            // Plunge: the lower of the two (coaxial) end balls.
            dz < 0.0
        };
        let (ex, ey, ez, t) = if at_end {
            (wx - dx, wy - dy, dz, 1.0)
        } else {
            (wx, wy, 0.0, 0.0)
        };
        let rho = ex * ex + ey * ey;
        (rho <= r2).then(|| EnvelopeHit {
            z_mm: m.p0[2] + self.r + (ez - (r2 - rho).sqrt()),
            t,
        })
    }

    #[inline(always)]
    fn row_in_lanes(&self) -> bool {
        true
    }

    /// In lanes, free of branches: for every column both the body root and
    /// the end sphere on t*'s side, and the square-root-free bound, each
    /// the expression of [`BallEnd::eval`] and [`BallEnd::stays_above`] (the
    /// same IEEE operations in the same order), the one that applies taken
    /// by a select: the same values bit for bit. A plunge column by column.
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
        if m.h2 <= PLUNGE_H2 {
            // The default's loop (the trait's own body).
            return row_hits_by_column(self, m, grid, y, ix0, tops, hits);
        }
        debug_assert!(ix0 + tops.len() <= i32::MAX as usize);
        let r = self.r;
        let r2 = r * r;
        let [dx, dy, dz] = m.d;
        let wy = y - m.p0[1];
        let zmin = m.zmin as f32;
        let n = tops.len();
        let (z_cut, t_cut) = (&mut hits.z_mm[..n], &mut hits.t[..n]);
        for (i, ((&top, z_out), t_out)) in tops.iter().zip(z_cut).zip(t_cut).enumerate() {
            let x = grid.x_mm_in_lanes(ix0 + i);
            let wx = x - m.p0[0];
            let stays = self.clears(m, wx, wy, top as f64);
            // `eval`: the body root, and the end sphere on t*'s side.
            let BodyRoot { disc, zeta, t_dd } = self.body_root(m, wx, wy);
            let (before, at_end) = (t_dd < 0.0, t_dd > m.dd);
            let in_body = !before && !at_end;
            let (ex, ey, ez, t_end) = if at_end {
                (wx - dx, wy - dy, dz, 1.0)
            } else {
                (wx, wy, 0.0, 0.0)
            };
            let rho = ex * ex + ey * ey;
            let z_body = m.p0[2] + r + zeta;
            let z_end = m.p0[2] + r + (ez - (r2 - rho).sqrt());
            let missed = disc < 0.0;
            let hit = !missed && (in_body || rho <= r2);
            let (z, t) = if in_body {
                (z_body, t_dd * m.inv_dd)
            } else {
                (z_end, t_end)
            };
            let low = top <= zmin;
            let cut = !low && !stays && hit;
            *z_out = if cut { z as f32 } else { f32::INFINITY };
            *t_out = if cut { t } else { 0.0 };
        }
    }

    /// No square root: with ρ the XY distance from the column to the move's
    /// axis segment, the ball's lower surface over the column is at least
    /// z_min + R − √(R² − ρ²), which is at least z_min + δ where
    /// ρ² ≥ [`sphere_reach2`]`(R, δ)`.
    #[inline]
    fn stays_above(&self, m: &Prepared, x: f64, y: f64, top: f64) -> bool {
        self.clears(m, x - m.p0[0], y - m.p0[1], top)
    }

    #[inline]
    fn has_reach(&self) -> bool {
        true
    }

    /// The same bound for a whole row.
    #[inline]
    fn reach(&self, _m: &Prepared, depth: f64) -> Option<f64> {
        Some(sphere_reach2(self.r, depth + ABOVE_MARGIN_MM).sqrt())
    }

    /// Descending too: the lower end of the ball at t, L(t) = c_z(t) −
    /// √(R² − ρ(t)²), is convex, and L'(0) = d_z − (w · d_xy)/√(R² − ρ₀²) ≥ 0
    /// wherever w · u ≤ −|d_z| R / |d_xy| (√(R² − ρ₀²) ≤ R): there it is
    /// lowest at the start.
    #[inline]
    fn behind_mm(&self, m: &Prepared) -> Option<f64> {
        if m.d[2] >= 0.0 {
            Some(0.0)
        } else if m.h2 > PLUNGE_H2 {
            Some(-m.d[2] * self.r * m.inv_len_xy)
        } else {
            None
        }
    }

    #[inline]
    fn side(&self, h: f64) -> Edge {
        // The torus with ring 0 and corner radius R: r = √(h (2R − h)), sin κ = r / R.
        torus_edge(h, self.r, self.r, 0.0)
    }

    /// On a ball sin κ cos θ = √(r² − e²)/R and r² = R² − (R − h)², so
    /// ∫ dh / (sin κ cos θ) = R asin((h − R)/a), a = √(R² − e²), up to the
    /// equator; above it R/a per mm (MODEL.md §3.2).
    #[inline]
    fn mean_inv_side(&self, h_bot: f64, h_top: f64, e: f64) -> Option<ArcsineMean> {
        let r = self.r;
        let (lo, hi) = (h_bot.max(0.0), h_top.max(0.0));
        let span = hi - lo;
        let a2 = r * r - e * e;
        // Made whole and then kept or not (no branch: the strip takes many in
        // lanes; where it is not kept, a NaN or ∞ of it is not read).
        let a = a2.sqrt();
        // One difference of arcsines (`AsinDiff`: one arcsine, not two),
        // times R: the corner's part; the flank's above the equator.
        let x = |h: f64| (h.min(r) - r) / a;
        let mean = ArcsineMean {
            diff: AsinDiff::of(x(hi), x(lo)),
            scale: r,
            add: (hi - lo.max(r)).max(0.0) * r / a,
            span,
        };
        (!(span <= 1e-6 * r || a2 <= 0.0)).then_some(mean)
    }

    #[inline]
    fn mean_inv_sin_k(&self, h_bot: f64, h_top: f64) -> f64 {
        torus_mean_inv_sin_k(h_bot, h_top, self.r)
            .unwrap_or_else(|| self.side(h_top.max(0.0)).inv_sin_k)
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        ((self.r - h) / self.r).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::testing::*;
    use crate::sweep::Step;

    #[test]
    fn ball_envelope_matches_brute_force() {
        let r = 5.0;
        let profile = move |rho: f64| (rho <= r).then(|| r - (r * r - rho * rho).sqrt());
        check_against_brute_force(&BallEnd { r }, &profile, 1e-4);
    }

    /// Lowest point of the swept ball on the vertical line at (x, y), found
    /// without the capsule formula: the ball's lower end m(t) is convex on the
    /// parameter interval where the line meets the ball, so a dense scan
    /// followed by a golden-section refinement around the best sample gives the
    /// minimum to ~1e-12.
    fn ball_reference(step: &Step, r: f64, x: f64, y: f64) -> Option<f64> {
        let at = |t: f64| -> Option<f64> {
            let p = m_at(step, t);
            let rho2 = (x - p[0]).powi(2) + (y - p[1]).powi(2);
            (rho2 <= r * r).then(|| p[2] + r - (r * r - rho2).sqrt())
        };
        let n = 4000;
        let mut best: Option<(f64, usize)> = None;
        for i in 0..=n {
            if let Some(z) = at(i as f64 / n as f64) {
                if best.is_none_or(|b| z < b.0) {
                    best = Some((z, i));
                }
            }
        }
        let (mut z_best, i) = best?;
        // Refine on the neighbouring samples, clipped to where the line meets the ball.
        let (mut a, mut b) = (
            i.saturating_sub(1) as f64 / n as f64,
            (i + 1).min(n) as f64 / n as f64,
        );
        let f = |t: f64| at(t).unwrap_or(f64::INFINITY);
        for _ in 0..200 {
            let (c, d) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
            let (fc, fd) = (f(c), f(d));
            z_best = z_best.min(fc).min(fd);
            // Outside the ball's interval f is +∞: move towards the finite side.
            if fc <= fd {
                b = d;
            } else {
                a = c;
            }
        }
        Some(z_best.min(f(0.0)).min(f(1.0)))
    }

    #[test]
    fn ball_single_candidate_matches_refined_minimum() {
        let r = 5.0;
        let ball = BallEnd { r };
        let mut seed = 23;
        let (mut hits, mut misses, mut skipped) = (0, 0, 0);
        for case in 0..6000 {
            let mut u = || lcg(&mut seed);
            let from = [u() * 20.0 - 10.0, u() * 20.0 - 10.0, u() * 20.0 - 10.0];
            // Horizontal direction and length, vertical change, by kind of move.
            let ang = u() * std::f64::consts::TAU;
            let (len_xy, dz) = match case % 8 {
                0 => (0.0, u() * 20.0 - 10.0), // plunge / retract
                1 => (u() * 15.0, 0.0),        // horizontal
                2 => (u() * 15.0, -u() * 3.0), // ramp down
                3 => (u() * 15.0, u() * 3.0),  // ramp up
                4 => (10f64.powf(-3.0 - 4.0 * u()), u() * 20.0 - 10.0), // near-vertical
                5 => (u() * 1e-3, (u() - 0.5) * 1e-3), // tiny move
                6 => (u() * 0.8, (u() - 0.5) * 0.2), // servo-sized step
                _ => (u() * 20.0, u() * 20.0 - 10.0), // anything
            };
            let to = [
                from[0] + len_xy * ang.cos(),
                from[1] + len_xy * ang.sin(),
                from[2] + dz,
            ];
            let step = Step {
                from_mm: from,
                to_mm: to,
                rapid: false,
            };
            let m = Prepared::new(&step);
            // A point within R + 0.5 of a random point of the move's XY segment.
            let (s, a2, d2) = (u(), u() * std::f64::consts::TAU, (r + 0.5) * u().sqrt());
            let x = from[0] + s * (to[0] - from[0]) + d2 * a2.cos();
            let y = from[1] + s * (to[1] - from[1]) + d2 * a2.sin();
            let got = ball.eval(&m, x, y);
            let want = ball_reference(&step, r, x, y);
            match (got, want) {
                (Some(EnvelopeHit { z_mm: z, t }), Some(w)) => {
                    hits += 1;
                    assert!(
                        (z - w).abs() < 1e-9,
                        "case {case}: {step:?} at ({x}, {y}): eval {z}, reference {w}"
                    );
                    assert!((0.0..=1.0).contains(&t), "case {case}: t = {t}");
                    // The reported t must be where the envelope is attained.
                    let at_t = ball_reference(
                        &Step {
                            from_mm: m_at(&step, t),
                            to_mm: m_at(&step, t),
                            rapid: false,
                        },
                        r,
                        x,
                        y,
                    );
                    let at_t = at_t.unwrap_or(f64::INFINITY);
                    assert!(
                        (at_t - z).abs() < 1e-6,
                        "case {case}: height at t = {t} is {at_t}, envelope {z}"
                    );
                    // The sqrt-free bounds may only skip columns the tool cannot cut.
                    let (sx, sy) = (to[0] - from[0], to[1] - from[1]);
                    let s_len2 = sx * sx + sy * sy;
                    let s_t = if s_len2 > 0.0 {
                        (((x - from[0]) * sx + (y - from[1]) * sy) / s_len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let rho_min = (x - from[0] - s_t * sx).hypot(y - from[1] - s_t * sy);
                    for top in [z - 1.0, z - 1e-3, z - 1e-9, z + 1e-9, z + 1e-3, z + 1.0] {
                        if ball.stays_above(&m, x, y, top) {
                            skipped += 1;
                            assert!(
                                z >= top,
                                "case {case}: stays_above({top}) but the envelope is {z}"
                            );
                        }
                        let reach = ball.reach(&m, top - m.zmin).unwrap();
                        if rho_min > reach + 1e-6 {
                            assert!(z >= top, "case {case}: ρ {rho_min} beyond reach {reach} of {top}, envelope {z}");
                        }
                    }
                }
                (None, None) => misses += 1,
                (got, want) => {
                    // Only a point on the footprint's rim may disagree.
                    let near_rim = (0..=10_000).any(|i| {
                        let p = m_at(&step, i as f64 / 10_000.0);
                        (((x - p[0]).powi(2) + (y - p[1]).powi(2)).sqrt() - r).abs() < 1e-6
                    });
                    assert!(
                        near_rim,
                        "case {case}: {step:?} at ({x}, {y}): eval {got:?}, reference {want:?}"
                    );
                }
            }
        }
        assert!(
            hits > 4000 && misses > 100 && skipped > 1000,
            "{hits} hits, {misses} misses, {skipped} skipped"
        );
    }
}
