//! Differences of arcsines for the contact's means (MODEL.md §3.2): the chip
//! thickness of a ball's thick piece, the flank's cell mean of 1/cos θ and a
//! torus corner's Δκ are each a difference asin(a) − asin(b). Each is taken
//! with one arcsine of a well-conditioned argument and two square roots
//! instead of two arcsines: `asin` is a large share of the free path's CPU
//! time, and two square roots cost less than one `asin`.

/// asin(a) − asin(b) for −1 ≤ b ≤ a ≤ 1 (arguments outside are clamped), in
/// [0, π]. With α = asin a, β = asin b, the difference d = α − β has
/// sin d = a √(1 − b²) − b √(1 − a²) and cos d = √(1 − a²) √(1 − b²) + a b;
/// d is the arcsine of whichever of the two is at most 1/√2 (up to rounding),
/// so the arcsine's argument is never where its slope grows without bound:
///
/// * d ≤ π/4 (sin d ≤ cos d): d = asin(sin d);
/// * π/4 < d ≤ 3π/4: d = π/2 − asin(cos d);
/// * d > 3π/4: d = π − asin(sin d).
///
/// Error: sin d and cos d carry a few ulps of 1 (≲ 5·10⁻¹⁶ absolute) and the
/// arcsine's slope there is at most √2, so |error| ≲ 10⁻¹⁵ rad, the same order
/// as the rounding of asin(a) − asin(b) itself (test
/// `asin_diff_matches_two_arcsines`: ≤ 10⁻¹⁵ (4.4·10⁻¹⁶ measured) against the C library's
/// asin(a) − asin(b) over 10⁶ random pairs and the ends ±1, 0).
#[inline]
pub(super) fn asin_diff(a: f64, b: f64) -> f64 {
    let (a, b) = (a.clamp(-1.0, 1.0), b.clamp(-1.0, 1.0));
    let ca = ((1.0 - a) * (1.0 + a)).sqrt();
    let cb = ((1.0 - b) * (1.0 + b)).sqrt();
    // b ≤ a: d ≥ 0, so sin d ≥ 0 (a rounding below is 0).
    let sin_d = (a * cb - b * ca).clamp(0.0, 1.0);
    let cos_d = (ca * cb + a * b).clamp(-1.0, 1.0);
    if cos_d >= sin_d {
        sin_d.asin()
    } else if cos_d >= -sin_d {
        FRAC_PI_2_HI - (cos_d.asin() - FRAC_PI_2_LO)
    } else {
        PI_HI - (sin_d.asin() - PI_LO)
    }
}

/// π/2 and π as a high part (the f64 nearest) and the low part of the rest.
const FRAC_PI_2_HI: f64 = std::f64::consts::FRAC_PI_2;
const FRAC_PI_2_LO: f64 = f64::from_bits(0x3C91_A626_3314_5C07); // 6.123e-17
const PI_HI: f64 = std::f64::consts::PI;
const PI_LO: f64 = 2.0 * FRAC_PI_2_LO;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::testing::lcg;

    #[test]
    fn asin_diff_matches_two_arcsines() {
        let mut seed = 11;
        let mut worst: f64 = 0.0;
        let mut check = |a: f64, b: f64| {
            let (a, b) = if a >= b { (a, b) } else { (b, a) };
            let want = a.asin() - b.asin();
            let got = asin_diff(a, b);
            assert!(
                (0.0..=std::f64::consts::PI).contains(&got),
                "{a} {b}: {got}"
            );
            worst = worst.max((got - want).abs());
        };
        for i in 0..1_000_000 {
            let (u, v) = (lcg(&mut seed), lcg(&mut seed));
            match i % 4 {
                0 => check(2.0 * u - 1.0, 2.0 * v - 1.0),
                // Close pairs (thin pieces, the flank's cell), and pairs at the ends.
                1 => {
                    let a = 2.0 * u - 1.0;
                    check(a, (a - 10f64.powf(-12.0 * v)).max(-1.0));
                }
                2 => check(1.0 - 10f64.powf(-16.0 * u), -1.0 + 10f64.powf(-16.0 * v)),
                _ => check(-(10f64.powf(-16.0 * u)), -1.0 + 10f64.powf(-16.0 * v)),
            }
        }
        for (a, b) in [
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (0.5, -0.5),
        ] {
            check(a, b);
        }
        assert!(worst <= 1e-15, "worst {worst:e} rad");
        assert_eq!(asin_diff(1.0, -1.0), std::f64::consts::PI);
        assert_eq!(asin_diff(0.3, 0.3), 0.0);
    }
}
