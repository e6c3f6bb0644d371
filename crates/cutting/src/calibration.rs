//! Calibration of the force law `F = a · V^n` from measured forces.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Result of [`fit_force_law`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    /// Fitted `a`, N at V = 1 mm³ per tooth per revolution.
    pub a: f64,
    /// Fitted exponent `n`, dimensionless.
    pub n: f64,
    /// Root mean square of `ln F_measured − ln F_fitted` (dimensionless, ≈ relative error).
    pub rms_log_error: f64,
    /// Root mean square of `(F_fitted − F_measured) / F_measured` (dimensionless).
    pub rms_rel_error: f64,
    /// Number of points used.
    pub points: usize,
}

/// Why a force law could not be fitted.
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum FitError {
    /// A volume or force is zero, negative or not finite (the law lives in log space).
    #[error(
        "point {} (counted from 1): volume {v_mm3} mm³ and force {force_n} N must both be positive and finite",
        .index + 1
    )]
    NonPositive {
        /// 0-based index of the point.
        index: usize,
        /// Its volume per tooth pass, mm³.
        v_mm3: f64,
        /// Its measured force, N.
        force_n: f64,
    },
    /// Fewer than two points were given.
    #[error("need at least 2 points to fit F = a·V^n, got {points}")]
    TooFewPoints {
        /// Points given.
        points: usize,
    },
    /// All volumes are equal, so the exponent is undetermined.
    #[error("all {points} points have the same volume; the exponent n is undetermined")]
    SameVolume {
        /// Points given.
        points: usize,
    },
}

/// Least-squares fit of `ln F = ln a + n · ln V` to `(v_mm3, measured_force_n)` pairs.
///
/// Fitting in log space weighs every point by its relative error, which suits forces that span
/// decades. Every point must be positive and finite.
pub fn fit_force_law(points: &[(f64, f64)]) -> Result<Fit, FitError> {
    let valid = |x: f64| x.is_finite() && x > 0.0;
    if let Some((index, &(v_mm3, force_n))) = points
        .iter()
        .enumerate()
        .find(|(_, (v, f))| !valid(*v) || !valid(*f))
    {
        return Err(FitError::NonPositive {
            index,
            v_mm3,
            force_n,
        });
    }
    if points.len() < 2 {
        return Err(FitError::TooFewPoints {
            points: points.len(),
        });
    }
    let count = points.len() as f64;
    let mean_x = points.iter().map(|(v, _)| v.ln()).sum::<f64>() / count;
    let mean_y = points.iter().map(|(_, f)| f.ln()).sum::<f64>() / count;
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |(sxx, sxy), (v, f)| {
        let dx = v.ln() - mean_x;
        (sxx + dx * dx, sxy + dx * (f.ln() - mean_y))
    });
    if sxx.is_nan() || sxx <= 1e-24 * count {
        return Err(FitError::SameVolume {
            points: points.len(),
        });
    }
    // MODEL.md §3.1 (S4) force law in logs, ln F = ln a + n ln V; normal equations:
    // n = Sxy / Sxx, ln a = ȳ − n x̄
    let n = sxy / sxx;
    let ln_a = mean_y - n * mean_x;
    let (sum_log2, sum_rel2) = points.iter().fold((0.0, 0.0), |(sl, sr), (v, f)| {
        let ln_fit = ln_a + n * v.ln();
        let rel = ln_fit.exp() / f - 1.0;
        (sl + (f.ln() - ln_fit).powi(2), sr + rel * rel)
    });
    Ok(Fit {
        a: ln_a.exp(),
        n,
        rms_log_error: (sum_log2 / count).sqrt(),
        rms_rel_error: (sum_rel2 / count).sqrt(),
        points: points.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_exact_law() {
        let data: Vec<_> = [0.01, 0.05, 0.2, 0.7, 2.0]
            .iter()
            .map(|&v| (v, 800.0 * f64::powf(v, 0.72)))
            .collect();
        let fit = fit_force_law(&data).unwrap();
        assert!(
            (fit.a - 800.0).abs() < 1e-9 && (fit.n - 0.72).abs() < 1e-12,
            "{fit:?}"
        );
        assert!(fit.rms_log_error < 1e-12 && fit.rms_rel_error < 1e-12);
        assert_eq!(fit.points, 5);
    }

    #[test]
    fn recovers_law_approximately_with_noise() {
        // Deterministic ±5 % multiplicative noise from a small LCG.
        let mut state: u64 = 12345;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1
        };
        let data: Vec<_> = (0..200)
            .map(|i| {
                let v = 0.01 * 1.03f64.powi(i);
                (v, 250.0 * v.powf(0.7) * (1.0 + noise()))
            })
            .collect();
        let fit = fit_force_law(&data).unwrap();
        assert!((fit.a / 250.0 - 1.0).abs() < 0.02, "{fit:?}");
        assert!((fit.n - 0.7).abs() < 0.01, "{fit:?}");
        // Uniform noise on ±5 % has an rms of 0.05/√3 ≈ 0.029.
        assert!(
            fit.rms_rel_error > 0.02 && fit.rms_rel_error < 0.04,
            "{fit:?}"
        );
    }

    #[test]
    fn rejects_bad_input() {
        assert_eq!(
            fit_force_law(&[(1.0, 10.0)]),
            Err(FitError::TooFewPoints { points: 1 })
        );
        assert_eq!(
            fit_force_law(&[]),
            Err(FitError::TooFewPoints { points: 0 })
        );
        assert!(matches!(
            fit_force_law(&[(1.0, 10.0), (0.0, 5.0), (2.0, 20.0)]),
            Err(FitError::NonPositive { index: 1, .. })
        ));
        assert!(matches!(
            fit_force_law(&[(1.0, -10.0), (2.0, 5.0)]),
            Err(FitError::NonPositive { index: 0, .. })
        ));
        assert!(matches!(
            fit_force_law(&[(1.0, f64::NAN), (2.0, 5.0)]),
            Err(FitError::NonPositive { .. })
        ));
        assert_eq!(
            fit_force_law(&[(1.0, 10.0), (1.0, 12.0)]),
            Err(FitError::SameVolume { points: 2 })
        );
    }
}
