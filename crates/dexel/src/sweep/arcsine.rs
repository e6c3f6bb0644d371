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
/// One at a time the arcsine is the C library's (its branches cost less than
/// [`asin_small`]'s whole expression); many in a loop, `asin_small` in lanes.
///
/// Error: sin d and cos d carry a few ulps of 1 (≲ 5·10⁻¹⁶ absolute) and the
/// arcsine's slope there is at most √2, so |error| ≲ 10⁻¹⁵ rad, the same order
/// as the rounding of asin(a) − asin(b) itself (test
/// `asin_diff_matches_two_arcsines`: ≤ 10⁻¹⁵ (4.4·10⁻¹⁶ measured) against the C library's
/// asin(a) − asin(b) over 10⁶ random pairs and the ends ±1, 0).
#[inline]
pub(super) fn asin_diff(a: f64, b: f64) -> f64 {
    let d = AsinDiff::of(a, b);
    d.form.difference(d.arg.asin())
}

/// asin(a) − asin(b) in two parts ([`asin_diff`]): the arcsine's argument,
/// and how the difference follows from its arcsine. Split so that many
/// arcsines are taken in one loop of independent lanes between the two
/// (the contacts' means near the flank and over a ball's thick pieces,
/// `StripJob::means`).
#[derive(Clone, Copy, Debug)]
pub(super) struct AsinDiff {
    /// sin d or cos d, whichever is at most 1/√2 (up to rounding).
    pub(super) arg: f64,
    pub(super) form: DiffForm,
}

/// Which of [`asin_diff`]'s three forms gives d from asin(arg).
#[derive(Clone, Copy, Debug)]
pub(super) enum DiffForm {
    /// d ≤ π/4: d = asin(sin d).
    Sin,
    /// π/4 < d ≤ 3π/4: d = π/2 − asin(cos d).
    Cos,
    /// d > 3π/4: d = π − asin(sin d).
    SinFromPi,
}

impl AsinDiff {
    /// The argument and form of asin(a) − asin(b) (see [`asin_diff`]).
    #[inline]
    pub(super) fn of(a: f64, b: f64) -> AsinDiff {
        let (a, b) = (a.clamp(-1.0, 1.0), b.clamp(-1.0, 1.0));
        let ca = ((1.0 - a) * (1.0 + a)).sqrt();
        let cb = ((1.0 - b) * (1.0 + b)).sqrt();
        // b ≤ a: d ≥ 0, so sin d ≥ 0 (a rounding below is 0).
        let sin_d = (a * cb - b * ca).clamp(0.0, 1.0);
        let cos_d = (ca * cb + a * b).clamp(-1.0, 1.0);
        // Selects, not branches: a loop of them runs in lanes.
        let (sin_form, cos_form) = (cos_d >= sin_d, cos_d >= -sin_d);
        AsinDiff {
            arg: if !sin_form && cos_form { cos_d } else { sin_d },
            form: if sin_form {
                DiffForm::Sin
            } else if cos_form {
                DiffForm::Cos
            } else {
                DiffForm::SinFromPi
            },
        }
    }
}

impl DiffForm {
    /// The difference d from `asin_arg`, the arcsine of [`AsinDiff::arg`].
    #[inline]
    pub(super) fn difference(self, asin_arg: f64) -> f64 {
        match self {
            DiffForm::Sin => asin_arg,
            DiffForm::Cos => FRAC_PI_2_HI - (asin_arg - FRAC_PI_2_LO),
            DiffForm::SinFromPi => PI_HI - (asin_arg - PI_LO),
        }
    }
}

/// asin x for |x| ≤ 1/√2 (a few ulps beyond still as close), as one
/// branch-free expression, so that a loop of them runs in vector lanes
/// (`StripJob::means`: the C library's `asin` was a third of the contacts'
/// means). The rational approximation R(z) of musl's (and FreeBSD's) `asin`,
/// for z ≤ 1/4: asin x = x + x R(x²) for |x| < 1/2, and
/// asin x = π/2 − 2 asin √z, z = (1 − |x|)/2, for 1/2 ≤ |x| (√z ≤ 0.3827),
/// the latter without musl's split of √z into two parts, which costs it up
/// to an ulp there (±0.5 gives π/6 two ulps low). Within 2 ulps (2.2·10⁻¹⁶
/// rad) of glibc's `asin` over 10⁶ random arguments in [−1/√2, 1/√2] (test
/// `asin_small_is_the_arcsine`, which allows 3: another C library may be an
/// ulp away from glibc's).
#[inline(always)]
pub(super) fn asin_small(x: f64) -> f64 {
    let ax = x.abs();
    let far = ax >= 0.5;
    let z = if far { (1.0 - ax) * 0.5 } else { ax * ax };
    let p = z * (P_S0 + z * (P_S1 + z * (P_S2 + z * (P_S3 + z * (P_S4 + z * P_S5)))));
    let q = 1.0 + z * (Q_S1 + z * (Q_S2 + z * (Q_S3 + z * Q_S4)));
    let r = p / q;
    let s = z.sqrt();
    let near_zero = ax + ax * r;
    let near_one = FRAC_PI_2_HI - (2.0 * (s + s * r) - FRAC_PI_2_LO);
    (if far { near_one } else { near_zero }).copysign(x)
}

// musl's coefficients of R(z) = p(z)/q(z) (src/math/asin.c, from FreeBSD). Written as musl writes them
// (more digits than an f64 holds; each parses to musl's value).
#[allow(clippy::excessive_precision)]
const P_S0: f64 = 1.666_666_666_666_666_574_15e-1;
#[allow(clippy::excessive_precision)]
const P_S1: f64 = -3.255_658_186_224_009_154_05e-1;
#[allow(clippy::excessive_precision)]
const P_S2: f64 = 2.012_125_321_348_629_258_81e-1;
#[allow(clippy::excessive_precision)]
const P_S3: f64 = -4.005_553_450_067_941_140_27e-2;
#[allow(clippy::excessive_precision)]
const P_S4: f64 = 7.915_349_942_898_145_321_76e-4;
#[allow(clippy::excessive_precision)]
const P_S5: f64 = 3.479_331_075_960_211_675_70e-5;
#[allow(clippy::excessive_precision)]
const Q_S1: f64 = -2.403_394_911_734_414_218_78;
#[allow(clippy::excessive_precision)]
const Q_S2: f64 = 2.020_945_760_233_505_694_71;
#[allow(clippy::excessive_precision)]
const Q_S3: f64 = -6.882_839_716_054_532_930_30e-1;
#[allow(clippy::excessive_precision)]
const Q_S4: f64 = 7.703_815_055_590_193_527_91e-2;

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

    #[test]
    fn asin_small_is_the_arcsine() {
        let mut seed = 5;
        let mut worst_ulps = 0;
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).abs();
        for _ in 0..1_000_000 {
            let x = (2.0 * lcg(&mut seed) - 1.0) * std::f64::consts::FRAC_1_SQRT_2;
            worst_ulps = worst_ulps.max(ulps(asin_small(x), x.asin()));
        }
        // The ends of each form, zeros, tiny and subnormal arguments, and
        // 1/√2 a few ulps beyond (the largest argument asin_diff gives).
        let edge = std::f64::consts::FRAC_1_SQRT_2;
        for x in [
            0.0,
            1e-300,
            5e-324,
            1e-20,
            0.25,
            0.5,
            f64::from_bits(0.5f64.to_bits() - 1),
            edge,
            f64::from_bits(edge.to_bits() + 4),
        ] {
            for x in [x, -x] {
                worst_ulps = worst_ulps.max(ulps(asin_small(x), x.asin()));
                assert_eq!(asin_small(x).is_sign_negative(), x.is_sign_negative());
            }
        }
        assert!(worst_ulps <= 3, "{worst_ulps} ulps");
        // The coefficients are musl's (fdlibm's) words, bit for bit: the
        // comparison above does not see an error of a few hundred ulps in
        // some of them.
        for (c, word) in [
            (P_S0, 0x3FC5_5555_5555_5555_u64),
            (P_S1, 0xBFD4_D612_03EB_6F7D),
            (P_S2, 0x3FC9_C155_0E88_4455),
            (P_S3, 0xBFA4_8228_B568_8F3B),
            (P_S4, 0x3F49_EFE0_7501_B288),
            (P_S5, 0x3F02_3DE1_0DFD_F709),
            (Q_S1, 0xC003_3A27_1C8A_2D4B),
            (Q_S2, 0x4000_2AE5_9C59_8AC8),
            (Q_S3, 0xBFE6_066C_1B8D_0159),
            (Q_S4, 0x3FB3_B8C5_B12E_9282),
        ] {
            assert_eq!(c.to_bits(), word, "{c:e}");
        }
    }
}
