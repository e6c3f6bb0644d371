//! Bull nose (torus corner): the lower surface over a column is convex along
//! the move, so a golden-section search finds its minimum; a level move and
//! a plunge have it in closed form.

use super::{
    disc_interval, sphere_reach2, torus_edge, torus_mean_inv_sin_k, Edge, Envelope, EnvelopeHit,
    Prepared, Span, ABOVE_MARGIN_MM, BOTTOM_MM, PLUNGE_H2,
};

/// The golden-section search stops when its bracket is this short along the
/// move, mm (far below an f32 height's resolution).
const GOLDEN_TOL_MM: f64 = 1e-9;

pub(super) struct BullNose {
    pub(super) r: f64,
    /// Corner radius and the radius of the torus centre circle (R − r_c).
    pub(super) rc: f64,
    pub(super) ring: f64,
}

impl BullNose {
    /// Height of the tool's lower surface above its tip at horizontal distance ρ.
    #[inline]
    fn profile(&self, rho: f64) -> f64 {
        let e = rho - self.ring;
        if e <= 0.0 {
            0.0
        } else {
            self.rc - (self.rc * self.rc - (e * e).min(self.rc * self.rc)).sqrt()
        }
    }

    #[inline]
    fn height(&self, m: &Prepared, x: f64, y: f64, t: f64) -> f64 {
        let (ax, ay) = (m.p0[0] + t * m.d[0], m.p0[1] + t * m.d[1]);
        let rho = ((x - ax) * (x - ax) + (y - ay) * (y - ay)).sqrt();
        self.profile(rho) + m.p0[2] + t * m.d[2]
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
        // Golden-section search of a convex function on [a, b], to
        // GOLDEN_TOL_MM of the move's length.
        const INV_PHI: f64 = 0.618_033_988_749_894_8;
        let tol_t = GOLDEN_TOL_MM * m.inv_dd.sqrt();
        let mut c = b - INV_PHI * (b - a);
        let mut d = a + INV_PHI * (b - a);
        let (mut fc, mut fd) = (self.height(m, x, y, c), self.height(m, x, y, d));
        while b - a > tol_t {
            if fc <= fd {
                b = d;
                d = c;
                fd = fc;
                c = b - INV_PHI * (b - a);
                fc = self.height(m, x, y, c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + INV_PHI * (b - a);
                fd = self.height(m, x, y, d);
            }
        }
        let t = 0.5 * (a + b);
        // The interval ends are candidates too (the minimum may sit on one).
        let mut best = EnvelopeHit {
            z_mm: self.height(m, x, y, t),
            t,
        };
        for t in [a, b] {
            let z_mm = self.height(m, x, y, t);
            if z_mm < best.z_mm {
                best = EnvelopeHit { z_mm, t };
            }
        }
        Some(best)
    }

    /// The ball's bound moved out by the ring: over a column at XY distance ρ
    /// from the move's axis segment the lower surface is at least
    /// z_min + profile(ρ) (the profile does not decrease), and on the corner
    /// profile(ρ) = rc − √(rc² − e²) with e = ρ − ring; so the swept tool stays
    /// above `top` where e² ≥ [`sphere_reach2`]`(rc, top − z_min + margin)`.
    #[inline]
    fn stays_above(&self, m: &Prepared, x: f64, y: f64, top: f64) -> bool {
        let (wx, wy) = (x - m.p0[0], y - m.p0[1]);
        let t = ((wx * m.d[0] + wy * m.d[1]) * m.inv_h2).clamp(0.0, 1.0);
        let (ex, ey) = (wx - t * m.d[0], wy - t * m.d[1]);
        let reach = self.ring + sphere_reach2(self.rc, top - m.zmin + ABOVE_MARGIN_MM).sqrt();
        ex * ex + ey * ey >= reach * reach
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
