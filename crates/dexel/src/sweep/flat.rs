//! Flat end: the lowest tip height over the parameter interval in which the
//! column lies under the tool's disc (closed form).

use super::{disc_interval, Edge, Envelope, EnvelopeHit, Prepared, BOTTOM_MM};

pub(super) struct FlatEnd {
    r: f64,
    /// 1 / r, once (the edge of every cut column).
    inv_r: f64,
}

impl FlatEnd {
    pub(super) fn new(r: f64) -> FlatEnd {
        FlatEnd { r, inv_r: 1.0 / r }
    }
}

impl Envelope for FlatEnd {
    #[inline]
    fn eval(&self, m: &Prepared, x: f64, y: f64) -> Option<EnvelopeHit> {
        let span = disc_interval(m, x, y, self.r)?;
        // Tip height is linear in t: lowest at one end of the interval.
        let t = if m.d[2] >= 0.0 { span.lo } else { span.hi };
        Some(EnvelopeHit {
            z_mm: m.p0[2] + t * m.d[2],
            t,
        })
    }

    #[inline]
    fn side(&self, _h: f64) -> Edge {
        Edge {
            r_mm: self.r,
            inv_r: self.inv_r,
            inv_sin_k: 1.0,
        }
    }

    #[inline]
    fn bottom_cos(&self, h: f64) -> f64 {
        if h < BOTTOM_MM {
            1.0
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::testing::*;

    #[test]
    fn flat_envelope_matches_brute_force() {
        let r = 5.0;
        let profile = move |rho: f64| (rho <= r).then_some(0.0);
        check_against_brute_force(&FlatEnd::new(r), &profile, 1e-3);
    }
}
