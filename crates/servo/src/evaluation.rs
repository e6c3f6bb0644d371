//! S2's evaluation of a motion: trajectory error, machining time, jerk, and the weighted score.

use serde::{Deserialize, Serialize};

use crate::path_error::trajectory_error_mm;

/// Largest |jerk| per axis in mm/s³ of positions sampled every `period_s`, from the third
/// difference `|x[k+3] − 3x[k+2] + 3x[k+1] − x[k]| / T³`. Zero with fewer than 4 samples.
pub fn max_jerk_mm_s3(actual: &[[f64; 3]], period_s: f64) -> [f64; 3] {
    let t3 = period_s.powi(3);
    let mut max = [0.0f64; 3];
    for w in actual.windows(4) {
        for axis in 0..3 {
            // MODEL.md §7.2 (S2) (largest |jerk| per axis): j ≈ (x₃ − 3x₂ + 3x₁ − x₀) / T³
            let third = w[3][axis] - 3.0 * w[2][axis] + 3.0 * w[1][axis] - w[0][axis];
            max[axis] = max[axis].max(third.abs() / t3);
        }
    }
    max
}

/// User weights and the references that make S2's primary scores dimensionless.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Weights {
    /// Ka, weight of the trajectory-error score.
    pub ka: f64,
    /// Kb, weight of the machining-time score.
    pub kb: f64,
    /// Kc, weight of the jerk score.
    pub kc: f64,
    /// Trajectory error that scores Va = 1/2, mm (e.g. the part tolerance); the motion is
    /// also done when the axes are this close to the end point.
    pub tolerance_mm: f64,
    /// Machining time that scores Vb = 1/2, s (e.g. the time of the program as it stands).
    pub reference_time_s: f64,
    /// Jerk that scores Vc = 1/2, mm/s³ (e.g. the machine's jerk limit).
    pub jerk_reference_mm_s3: f64,
}

/// S2's evaluation of one motion; a larger V is better (S2 keeps the set with the largest).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// Largest distance of an actual sample to the commanded path, mm.
    pub trajectory_error_mm: f64,
    /// Index of the sample where [`Evaluation::trajectory_error_mm`] occurs.
    pub worst_sample: usize,
    /// Time until the estimated actual motion has settled at the end point, s.
    pub machining_time_s: f64,
    /// Largest |jerk| of the actual motion per axis, mm/s³.
    pub max_jerk_mm_s3: [f64; 3],
    /// Va = tolerance / (tolerance + trajectory error), in (0, 1].
    pub va: f64,
    /// Vb = reference time / (reference time + machining time), in (0, 1].
    pub vb: f64,
    /// Vc = jerk reference / (jerk reference + largest per-axis jerk), in (0, 1].
    pub vc: f64,
    /// V = Ka·Va + Kb·Vb + Kc·Vc.
    pub evaluation: f64,
}

/// S2's primary score of a quantity `x` ≥ 0 against its reference `r` > 0: `r / (r + x)`,
/// 1 at zero, 1/2 at the reference, falling towards 0 (MODEL.md §7.2).
pub fn primary_score(x: f64, reference: f64) -> f64 {
    reference / (reference + x)
}

/// Time in s until the `actual` samples (every `period_s`) stay within `settle_mm` of
/// `end_mm`: the sample after the last one farther away, times the period.
pub fn settled_time_s(actual: &[[f64; 3]], end_mm: [f64; 3], settle_mm: f64, period_s: f64) -> f64 {
    let far = |p: &[f64; 3]| {
        let d2: f64 = (0..3).map(|k| (p[k] - end_mm[k]).powi(2)).sum();
        d2 > settle_mm * settle_mm
    };
    actual
        .iter()
        .rposition(far)
        .map_or(0.0, |k| (k + 1) as f64 * period_s)
}

/// Evaluates the `actual` motion (e.g. from [`crate::simulate_until_settled`]) against the
/// `commanded` samples, both taken every `period_s` (MODEL.md §7.2, S2): the machining time is
/// when the actual motion has settled within `tolerance_mm` of the commanded end point.
pub fn evaluate(
    commanded: &[[f64; 3]],
    actual: &[[f64; 3]],
    period_s: f64,
    weights: &Weights,
) -> Evaluation {
    let (error_mm, worst_sample) = trajectory_error_mm(commanded, actual);
    let end = commanded.last().copied().unwrap_or_default();
    let machining_time_s = settled_time_s(actual, end, weights.tolerance_mm, period_s);
    let jerk = max_jerk_mm_s3(actual, period_s);
    let va = primary_score(error_mm, weights.tolerance_mm);
    let vb = primary_score(machining_time_s, weights.reference_time_s);
    let vc = primary_score(
        jerk.iter().fold(0.0f64, |m, j| m.max(*j)),
        weights.jerk_reference_mm_s3,
    );
    Evaluation {
        trajectory_error_mm: error_mm,
        worst_sample,
        machining_time_s,
        max_jerk_mm_s3: jerk,
        va,
        vb,
        vc,
        // MODEL.md §7.2 (S2): V = Ka·Va + Kb·Vb + Kc·Vc
        evaluation: weights.ka * va + weights.kb * vb + weights.kc * vc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::Drive;

    #[test]
    fn jerk_of_a_cubic() {
        // x = c t³ has jerk 6c; y = −2 t³ → 12; z a parabola → 0.
        let (c, t) = (7.5, 0.01);
        let xs: Vec<_> = (0..50)
            .map(|k| {
                let s = k as f64 * t;
                [c * s.powi(3), -2.0 * s.powi(3), 3.0 * s * s]
            })
            .collect();
        let j = max_jerk_mm_s3(&xs, t);
        assert!(
            (j[0] - 6.0 * c).abs() < 1e-6 && (j[1] - 12.0).abs() < 1e-6 && j[2] < 1e-6,
            "{j:?}"
        );
        assert_eq!(max_jerk_mm_s3(&xs[..3], t), [0.0; 3]);
    }

    #[test]
    fn score_by_hand() {
        // Ramp at 25 mm/s for 1 s from rest, Kp = 30/s, then held: the lagging actual stays on
        // the line (error 0). The lag at the stop, e0 = (v/Kp)(1 − e^{−Kp·1 s}), decays as
        // e^{−Kp t}; the motion is done when it falls under the 0.01 mm tolerance.
        let t = 0.001;
        let (v, kp) = (25.0, 30.0);
        let cmd: Vec<_> = (0..=1000).map(|k| [v * k as f64 * t, 0.0, 0.0]).collect();
        let act = crate::simulate_until_settled(&cmd, t, &Drive::first_order(kp), 0.01);
        let w = Weights {
            ka: 2.0,
            kb: 1.0,
            kc: 0.5,
            tolerance_mm: 0.01,
            reference_time_s: 2.0,
            jerk_reference_mm_s3: 1e5,
        };
        let e = evaluate(&cmd, &act, t, &w);
        assert!(e.trajectory_error_mm < 1e-12);
        let e0 = v / kp * (1.0 - (-kp * 1.0f64).exp());
        let settle_s = 1.0 + (e0 / 0.01).ln() / kp;
        let expected = (settle_s / t).ceil() * t;
        assert!(
            (e.machining_time_s - expected).abs() < 1e-9,
            "{} vs {expected}",
            e.machining_time_s
        );
        assert!((e.vb - 2.0 / (2.0 + expected)).abs() < 1e-12);
        // Starting from rest, x_k = v·k·T − (v/Kp)(1 − d^k) with d = e^{−Kp T}, so the third
        // difference of the ramp is largest in the first window: (v/Kp)(1 − d)³/T³ ≈ v·Kp²
        // = 22 500 mm/s³. The stop (a velocity step of the command) jerks harder.
        let j = v / kp * (1.0 - (-kp * t).exp()).powi(3) / t.powi(3);
        let ramp = max_jerk_mm_s3(&act[..=1000], t);
        assert!((ramp[0] / j - 1.0).abs() < 1e-6, "{ramp:?} vs {j}");
        assert!(e.max_jerk_mm_s3[0] > ramp[0]);
        assert_eq!(&e.max_jerk_mm_s3[1..], &[0.0, 0.0]);
        assert!((e.vc - 1e5 / (1e5 + e.max_jerk_mm_s3[0])).abs() < 1e-12);
        assert!((e.va - 1.0).abs() < 1e-12);
        assert!((e.evaluation - (2.0 * e.va + e.vb + 0.5 * e.vc)).abs() < 1e-12);

        // Same motion with a constant 0.01 mm offset in y (= the tolerance): Va = 1/2.
        let off: Vec<_> = act.iter().map(|p| [p[0], p[1] + 0.01, p[2]]).collect();
        let e = evaluate(&cmd, &off, t, &w);
        assert!((e.va - 0.5).abs() < 1e-9);
    }
}
