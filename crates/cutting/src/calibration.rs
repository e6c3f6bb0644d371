//! Calibration of the force laws from measurements: S4's `F = a · V^n` from measured forces
//! ([`fit_force_law`]), and Kienzle's `kc1_1`, `mc` and force ratios from the spindle power and
//! mean forces of straight flat end mill cuts ([`fit_kienzle`], MODEL.md §3.2 "Calibration").

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::kienzle::{mean_chip_thickness_mm, Kienzle};
use crate::tooth::{self, BandArc, Coefficients, EdgeShape};

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
    /// A calibration cut is not a cut ([`Cut::check`]).
    #[error("cut {} (counted from 1): {reason}", .index + 1)]
    BadCut {
        /// 0-based index of the cut.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// Fewer than two distinct mean chip thicknesses: mc is undetermined.
    #[error(
        "the {cuts} cuts have {distinct} distinct mean chip thickness(es) h_m; fitting kc1_1 and mc needs at least 2 (vary fz or ae)"
    )]
    SameChip {
        /// Cuts given.
        cuts: usize,
        /// Distinct mean chips among them.
        distinct: usize,
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
    // MODEL.md §3.1 (S4) force law in logs, ln F = ln a + n ln V
    let line = log_line(points).ok_or(FitError::SameVolume {
        points: points.len(),
    })?;
    Ok(Fit {
        a: line.intercept.exp(),
        n: line.slope,
        rms_log_error: line.rms_log_error,
        rms_rel_error: line.rms_rel_error,
        points: points.len(),
    })
}

/// Which side of the tool the material is on in a straight calibration cut (M3, clockwise
/// spindle, feed along +x, +y to its left).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Milling {
    /// Material on the left (+y): the tooth enters at φ = 0, the chip thickens.
    Up,
    /// Material on the right (−y): the tooth leaves at φ = π, the chip thins.
    Down,
    /// A full slot, `a_e = D`: φ from 0 to π.
    Slot,
}

/// One straight cut of a flat end mill at constant depths, feed and speed, with what was
/// measured on it (MODEL.md §3.2, "Calibration").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    /// Tool diameter D, mm.
    pub diameter_mm: f64,
    /// Number of flutes N.
    pub flutes: u32,
    /// Axial depth of cut, mm.
    pub ap_mm: f64,
    /// Radial depth of cut (width), mm; `D` for a slot.
    pub ae_mm: f64,
    /// Feed per tooth, mm.
    pub fz_mm: f64,
    /// Spindle speed, rev/min.
    pub rpm: f64,
    /// Up, down or slot.
    pub milling: Milling,
    /// Mean spindle cutting power (idle power subtracted), W.
    pub power_w: Option<f64>,
    /// Mean force on the tool in the feed frame [x along the feed, y to its left, z up], N.
    pub force_n: Option<[f64; 3]>,
}

impl Cut {
    /// Why the cut cannot be used, if it cannot: every length, the feed and the speed positive
    /// and finite, `a_e ≤ D` (`= D` for a slot), at least one flute, the measured power
    /// positive and the forces finite.
    pub fn check(&self) -> Result<(), String> {
        for (what, v) in [
            ("diameter (mm)", self.diameter_mm),
            ("ap (mm)", self.ap_mm),
            ("ae (mm)", self.ae_mm),
            ("fz (mm)", self.fz_mm),
            ("rpm", self.rpm),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("{what} must be a positive, finite number, got {v}"));
            }
        }
        if self.flutes == 0 {
            return Err("flutes must be at least 1".into());
        }
        let d = self.diameter_mm;
        if self.ae_mm > d * (1.0 + 1e-9) {
            return Err(format!(
                "ae ({} mm) is wider than the tool's diameter ({d} mm)",
                self.ae_mm
            ));
        }
        if self.milling == Milling::Slot && (self.ae_mm - d).abs() > 1e-9 * d {
            return Err(format!(
                "a slot cuts ae = D ({d} mm), got ae = {} mm: give up or down milling",
                self.ae_mm
            ));
        }
        if let Some(p) = self.power_w {
            if !(p > 0.0 && p.is_finite()) {
                return Err(format!(
                    "power must be a positive, finite number, got {p} W"
                ));
            }
        }
        if let Some(f) = self.force_n {
            if f.iter().any(|v| !v.is_finite()) {
                return Err(format!("forces must be finite numbers, got {f:?} N"));
            }
        }
        Ok(())
    }

    /// The cut's engaged arc: the tool's flank from the tip to `a_p`, from φ_st to φ_ex (rad, φ
    /// clockwise from +y, the feed's left): up milling `(0, arccos(1 − a_e/R))`, down milling
    /// `(π − arccos(1 − a_e/R), π)`, a slot `(0, π)` ([`BandArc::side_cut`]).
    pub fn arc(&self) -> BandArc {
        let up = self.milling != Milling::Down;
        BandArc::side_cut(0.5 * self.diameter_mm, self.ae_mm, 0.0, self.ap_mm, up)
    }

    /// The immersion (φ_st, φ_ex), rad ([`Cut::arc`]).
    pub fn engagement_rad(&self) -> (f64, f64) {
        let arc = self.arc();
        (arc.phi_st_rad, arc.phi_ex_rad)
    }

    /// The mean chip thickness h_m over the immersion, mm (MODEL.md §3.2).
    pub fn mean_chip_mm(&self) -> f64 {
        let (st, ex) = self.engagement_rad();
        mean_chip_thickness_mm(self.fz_mm, st, ex)
    }

    /// Material removal rate `Q = a_e a_p v_f`, mm³/s (`v_f = f_z N n / 60` mm/s).
    pub fn mrr_mm3_s(&self) -> f64 {
        self.ae_mm * self.ap_mm * self.fz_mm * f64::from(self.flutes) * self.rpm / 60.0
    }

    /// The specific cutting force the measured power gives, `kc = 1000 P / Q` N/mm² (P in W =
    /// 1000 N·mm/s, Q in mm³/s); `None` without a power.
    pub fn kc_from_power_mpa(&self) -> Option<f64> {
        self.power_w.map(|p| 1000.0 * p / self.mrr_mm3_s())
    }

    /// The spindle power of this cut under `law`, W: `P = kc(h_m) Q / 1000`.
    pub fn power_w_of(&self, law: &Kienzle) -> f64 {
        law.specific_force_mpa(self.mean_chip_mm()) * self.mrr_mm3_s() / 1000.0
    }

    /// The mean force on the tool under `law`, N, feed frame: `K_t (B_t + k_r B_r + k_a B_a)`
    /// with `K_t = kc(h_m)` ([`Cut::force_basis`]).
    pub fn force_n_of(&self, law: &Kienzle) -> [f64; 3] {
        let [bt, br, ba] = self.force_basis();
        let kt = law.specific_force_mpa(self.mean_chip_mm());
        std::array::from_fn(|i| kt * (bt[i] + law.radial_ratio * br[i] + law.axial_ratio * ba[i]))
    }

    /// The cut's mean force on the tool per unit tangential coefficient, N per N/mm²:
    /// `[B_t, B_r, B_a]`, so that `F̄ = K_t B_t + K_t k_r B_r + K_t k_a B_a`.
    pub fn force_basis(&self) -> [[f64; 3]; 3] {
        let t = self.mean_force_n(1.0, 0.0, 0.0);
        let r = self.mean_force_n(1.0, 1.0, 0.0);
        let a = self.mean_force_n(1.0, 0.0, 1.0);
        [
            t,
            std::array::from_fn(|i| r[i] - t[i]),
            std::array::from_fn(|i| a[i] - t[i]),
        ]
    }

    /// The mean force on the tool over one revolution, N, for the coefficients `kt_mpa`, `kr`,
    /// `ka`: [`tooth::mean_cut`] of the flat end's flank over the cut's arc.
    fn mean_force_n(&self, kt_mpa: f64, kr: f64, ka: f64) -> [f64; 3] {
        let coefficients = Coefficients {
            kt_mpa,
            radial_ratio: kr,
            axial_ratio: ka,
        };
        let shape = EdgeShape::flat(0.5 * self.diameter_mm);
        tooth::mean_cut(&shape, self.flutes, &self.arc(), self.fz_mm, &coefficients).force_n
    }

    /// The tangential coefficient K_t that, with some k_r, gives the measured x and y forces
    /// exactly (`None` without forces).
    fn kt_from_forces(&self) -> Option<f64> {
        let f = self.force_n?;
        let [bt, br, _] = self.force_basis();
        // [bt.x br.x; bt.y br.y] (K_t, K_t k_r)ᵀ = (Fx, Fy)ᵀ by Cramer's rule; the determinant is
        // (N a_p f_z / 2π)² (I_sc² + I_ss²) > 0 on any immersion.
        let det = bt[0] * br[1] - bt[1] * br[0];
        Some((f[0] * br[1] - f[1] * br[0]) / det)
    }
}

/// How well a fit reproduces what it was fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitQuality {
    /// Measurements used.
    pub points: usize,
    /// Root mean square of the relative residual (fitted − measured) / measured.
    pub rms_rel_error: f64,
    /// Coefficient of determination `1 − SS_res / SS_tot` (1 where SS_tot is 0).
    pub r_squared: f64,
}

/// What the specific cutting force of each cut was taken from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KcSource {
    /// The spindle power: `kc = 1000 P / Q`.
    Power,
    /// The mean x and y forces (no power measured): `K_t` solved with `k_r` from them.
    Forces,
}

/// Result of [`fit_kienzle`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct KienzleFit {
    /// Fitted kc1_1, N/mm².
    pub kc1_1_mpa: f64,
    /// Fitted mc.
    pub mc: f64,
    /// Fitted radial / tangential force; `None` where no cut has forces.
    pub radial_ratio: Option<f64>,
    /// Fitted axial / tangential force; `None` where no cut has forces.
    pub axial_ratio: Option<f64>,
    /// Where each cut's kc came from.
    pub kc_source: KcSource,
    /// The kc fit: relative error of kc(h_m) against each cut's kc, R² of `ln kc` on `ln h_m`.
    pub kc_quality: FitQuality,
    /// The force fit over the cuts with forces: relative error `|F_fit − F| / |F|` per cut,
    /// R² over all components.
    pub force_quality: Option<FitQuality>,
}

/// Least-squares fit of Kienzle's law to straight flat end mill cuts (MODEL.md §3.2,
/// "Calibration").
///
/// Each cut's kc at its mean chip h_m comes from its power (`kc = 1000 P / Q`) when every cut
/// has one, else from its x and y forces; `ln kc = ln kc1_1 − mc ln h_m` is fitted by least
/// squares over the cuts. Then, on the cuts with forces, `k_r` and `k_a` are fitted by linear
/// least squares of the measured components on the basis `K_t B_r`, `K_t B_a` after taking away
/// `K_t B_t`, with `K_t = kc1_1 h_m^−mc` from the fit.
pub fn fit_kienzle(cuts: &[Cut]) -> Result<KienzleFit, FitError> {
    for (index, cut) in cuts.iter().enumerate() {
        cut.check()
            .map_err(|reason| FitError::BadCut { index, reason })?;
    }
    let all_power = cuts.iter().all(|c| c.power_w.is_some());
    if let Some(index) = cuts.iter().position(|c| !all_power && c.force_n.is_none()) {
        return Err(FitError::BadCut {
            index,
            reason: "neither a power nor forces were measured (give every cut a power, or forces)"
                .into(),
        });
    }
    let kc_source = if all_power {
        KcSource::Power
    } else {
        KcSource::Forces
    };
    let mut points = Vec::with_capacity(cuts.len());
    for (index, cut) in cuts.iter().enumerate() {
        let kc = match kc_source {
            KcSource::Power => cut.kc_from_power_mpa(),
            KcSource::Forces => cut.kt_from_forces(),
        }
        .unwrap_or(f64::NAN);
        if !(kc > 0.0 && kc.is_finite()) {
            return Err(FitError::BadCut {
                index,
                reason: format!(
                    "its measurements give kc = {kc} N/mm², not a positive number (forces on the tool in the feed frame: x along the feed, y to its left, M3 spindle)"
                ),
            });
        }
        points.push((cut.mean_chip_mm(), kc));
    }
    if points.len() < 2 {
        return Err(FitError::SameChip {
            cuts: points.len(),
            distinct: points.len(),
        });
    }
    let Some(line) = log_line(&points) else {
        let mut chips: Vec<f64> = points.iter().map(|p| p.0).collect();
        chips.sort_by(f64::total_cmp);
        chips.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
        return Err(FitError::SameChip {
            cuts: points.len(),
            distinct: chips.len(),
        });
    };
    // MODEL.md §3.2: ln kc = ln kc1_1 − mc ln h_m
    let mut law = Kienzle {
        kc1_1_mpa: line.intercept.exp(),
        mc: -line.slope,
        radial_ratio: 0.0,
        axial_ratio: 0.0,
    };
    let kc_quality = FitQuality {
        points: points.len(),
        rms_rel_error: line.rms_rel_error,
        r_squared: line.r_squared,
    };
    let forced: Vec<&Cut> = cuts.iter().filter(|c| c.force_n.is_some()).collect();
    if forced.is_empty() {
        return Ok(KienzleFit {
            kc1_1_mpa: law.kc1_1_mpa,
            mc: law.mc,
            radial_ratio: None,
            axial_ratio: None,
            kc_source,
            kc_quality,
            force_quality: None,
        });
    }
    // Normal equations of F − K_t B_t = k_r (K_t B_r) + k_a (K_t B_a) over every component.
    let (mut m, mut v) = ([[0.0; 2]; 2], [0.0; 2]);
    for cut in &forced {
        let f = cut.force_n.unwrap_or_default();
        let kt = law.specific_force_mpa(cut.mean_chip_mm());
        let [bt, br, ba] = cut.force_basis();
        for i in 0..3 {
            let cols = [kt * br[i], kt * ba[i]];
            let rhs = f[i] - kt * bt[i];
            for (j, cj) in cols.iter().enumerate() {
                v[j] += cj * rhs;
                for (k, ck) in cols.iter().enumerate() {
                    m[j][k] += cj * ck;
                }
            }
        }
    }
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    law.radial_ratio = (v[0] * m[1][1] - v[1] * m[0][1]) / det;
    law.axial_ratio = (m[0][0] * v[1] - m[1][0] * v[0]) / det;
    if !(law.radial_ratio.is_finite() && law.axial_ratio.is_finite()) {
        return Err(FitError::BadCut {
            index: 0,
            reason: "the cuts' forces do not determine the radial and axial ratios".into(),
        });
    }
    Ok(KienzleFit {
        kc1_1_mpa: law.kc1_1_mpa,
        mc: law.mc,
        radial_ratio: Some(law.radial_ratio),
        axial_ratio: Some(law.axial_ratio),
        kc_source,
        kc_quality,
        force_quality: Some(force_quality(&forced, &law)),
    })
}

/// The force fit's quality on `cuts` (each with forces) under `law`.
fn force_quality(cuts: &[&Cut], law: &Kienzle) -> FitQuality {
    let measured: Vec<[f64; 3]> = cuts.iter().map(|c| c.force_n.unwrap_or_default()).collect();
    let count = cuts.len() as f64;
    let mean: [f64; 3] =
        std::array::from_fn(|i| measured.iter().map(|f| f[i]).sum::<f64>() / count);
    let (mut ss_res, mut ss_tot, mut rel2) = (0.0, 0.0, 0.0);
    for (cut, f) in cuts.iter().zip(&measured) {
        let fit = cut.force_n_of(law);
        let res2: f64 = (0..3).map(|i| (fit[i] - f[i]).powi(2)).sum();
        ss_res += res2;
        ss_tot += (0..3).map(|i| (f[i] - mean[i]).powi(2)).sum::<f64>();
        let norm2: f64 = f.iter().map(|v| v * v).sum();
        rel2 += res2 / norm2;
    }
    FitQuality {
        points: cuts.len(),
        rms_rel_error: (rel2 / count).sqrt(),
        r_squared: r_squared(ss_res, ss_tot),
    }
}

fn r_squared(ss_res: f64, ss_tot: f64) -> f64 {
    if ss_tot > 0.0 {
        1.0 - ss_res / ss_tot
    } else {
        1.0
    }
}

/// A straight line through `(ln x, ln y)` by least squares.
struct LogLine {
    intercept: f64,
    slope: f64,
    /// RMS of `ln y − (intercept + slope ln x)`.
    rms_log_error: f64,
    /// RMS of `y_fit / y − 1`.
    rms_rel_error: f64,
    r_squared: f64,
}

/// Least squares of `ln y = intercept + slope · ln x` over positive, finite points; `None` where
/// the x are all the same.
fn log_line(points: &[(f64, f64)]) -> Option<LogLine> {
    let count = points.len() as f64;
    let mean_x = points.iter().map(|(x, _)| x.ln()).sum::<f64>() / count;
    let mean_y = points.iter().map(|(_, y)| y.ln()).sum::<f64>() / count;
    let (sxx, sxy, syy) = points
        .iter()
        .fold((0.0, 0.0, 0.0), |(sxx, sxy, syy), (x, y)| {
            let dx = x.ln() - mean_x;
            let dy = y.ln() - mean_y;
            (sxx + dx * dx, sxy + dx * dy, syy + dy * dy)
        });
    if sxx.is_nan() || sxx <= 1e-24 * count {
        return None;
    }
    // Normal equations: slope = Sxy / Sxx, intercept = ȳ − slope x̄.
    let slope = sxy / sxx;
    let intercept = mean_y - slope * mean_x;
    let (sum_log2, sum_rel2) = points.iter().fold((0.0, 0.0), |(sl, sr), (x, y)| {
        let ln_fit = intercept + slope * x.ln();
        let rel = ln_fit.exp() / y - 1.0;
        (sl + (y.ln() - ln_fit).powi(2), sr + rel * rel)
    });
    Some(LogLine {
        intercept,
        slope,
        rms_log_error: (sum_log2 / count).sqrt(),
        rms_rel_error: (sum_rel2 / count).sqrt(),
        r_squared: r_squared(sum_log2, syy),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

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

    const TRUE_LAW: Kienzle = Kienzle {
        kc1_1_mpa: 1500.0,
        mc: 0.22,
        radial_ratio: 0.3,
        axial_ratio: 0.25,
    };

    /// Straight cuts of a Ø10 3-flute and a Ø12 4-flute end mill: up, down and slot, three
    /// depths, four feeds, two speeds (32 cuts); measurements left empty.
    fn plan() -> Vec<Cut> {
        let mut cuts = Vec::new();
        for (i, &(d, flutes)) in [(10.0, 3u32), (12.0, 4)].iter().enumerate() {
            for (j, &(ae_share, milling)) in [
                (0.1, Milling::Up),
                (0.3, Milling::Down),
                (0.5, Milling::Up),
                (1.0, Milling::Slot),
            ]
            .iter()
            .enumerate()
            {
                for (k, &fz) in [0.02, 0.04, 0.08, 0.15].iter().enumerate() {
                    let ap = [2.0, 5.0, 8.0][(i + j + k) % 3];
                    cuts.push(Cut {
                        diameter_mm: d,
                        flutes,
                        ap_mm: ap,
                        ae_mm: ae_share * d,
                        fz_mm: fz,
                        rpm: [3000.0, 8000.0][(j + k) % 2],
                        milling,
                        power_w: None,
                        force_n: None,
                    });
                }
            }
        }
        cuts
    }

    /// The cuts measured under `law`, each measurement times `1 + noise()`.
    fn measured(law: &Kienzle, mut noise: impl FnMut() -> f64) -> Vec<Cut> {
        plan()
            .into_iter()
            .map(|mut c| {
                c.power_w = Some(c.power_w_of(law) * (1.0 + noise()));
                c.force_n = Some(c.force_n_of(law).map(|f| f * (1.0 + noise())));
                c
            })
            .collect()
    }

    /// Uniform on ±`half` from a fixed-seed LCG.
    fn lcg(half: f64) -> impl FnMut() -> f64 {
        let mut state: u64 = 2026;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * half
        }
    }

    #[test]
    fn kienzle_round_trip_is_exact_without_noise() {
        let cuts = measured(&TRUE_LAW, || 0.0);
        let fit = fit_kienzle(&cuts).unwrap();
        eprintln!("{fit:?}");
        assert!((fit.kc1_1_mpa - 1500.0).abs() < 1e-9 * 1500.0, "{fit:?}");
        assert!((fit.mc - 0.22).abs() < 1e-9, "{fit:?}");
        assert!((fit.radial_ratio.unwrap() - 0.3).abs() < 1e-9, "{fit:?}");
        assert!((fit.axial_ratio.unwrap() - 0.25).abs() < 1e-9, "{fit:?}");
        assert_eq!(fit.kc_source, KcSource::Power);
        assert_eq!(fit.kc_quality.points, 32);
        assert!(fit.kc_quality.rms_rel_error < 1e-12 && fit.kc_quality.r_squared > 1.0 - 1e-12);
        let q = fit.force_quality.unwrap();
        assert!(
            q.rms_rel_error < 1e-12 && q.r_squared > 1.0 - 1e-12,
            "{q:?}"
        );
        // Forces alone (no power): kc from each cut's x and y forces.
        let forces_only: Vec<Cut> = cuts
            .iter()
            .map(|c| Cut {
                power_w: None,
                ..*c
            })
            .collect();
        let fit = fit_kienzle(&forces_only).unwrap();
        assert_eq!(fit.kc_source, KcSource::Forces);
        assert!((fit.kc1_1_mpa - 1500.0).abs() < 1e-9 * 1500.0, "{fit:?}");
        assert!((fit.mc - 0.22).abs() < 1e-9, "{fit:?}");
        assert!((fit.radial_ratio.unwrap() - 0.3).abs() < 1e-9, "{fit:?}");
        assert!((fit.axial_ratio.unwrap() - 0.25).abs() < 1e-9, "{fit:?}");
        // Power alone: no ratios.
        let power_only: Vec<Cut> = cuts
            .iter()
            .map(|c| Cut {
                force_n: None,
                ..*c
            })
            .collect();
        let fit = fit_kienzle(&power_only).unwrap();
        assert!(
            (fit.mc - 0.22).abs() < 1e-9
                && fit.radial_ratio.is_none()
                && fit.force_quality.is_none()
        );
    }

    #[test]
    fn kienzle_round_trip_with_two_percent_noise() {
        let half = 0.02;
        let cuts = measured(&TRUE_LAW, lcg(half));
        let fit = fit_kienzle(&cuts).unwrap();
        // Uniform noise on ±2 % is 0.02/√3 = 1.15 % rms in ln kc. The slope's standard error is
        // σ/√Sxx, the intercept's (at ln h = 0, far left of the data) σ √(1/n + x̄²/Sxx).
        let sigma = half / 3f64.sqrt();
        let ln_h: Vec<f64> = cuts.iter().map(|c| c.mean_chip_mm().ln()).collect();
        let n = ln_h.len() as f64;
        let mean = ln_h.iter().sum::<f64>() / n;
        let sxx: f64 = ln_h.iter().map(|x| (x - mean).powi(2)).sum();
        let se_mc = sigma / sxx.sqrt();
        let se_ln_kc = sigma * (1.0 / n + mean * mean / sxx).sqrt();
        eprintln!("{fit:?}\nse(mc) {se_mc:.5}, se(ln kc1_1) {se_ln_kc:.5}");
        assert!((fit.mc - 0.22).abs() < 3.0 * se_mc, "{fit:?}");
        assert!(
            (fit.kc1_1_mpa / 1500.0).ln().abs() < 3.0 * se_ln_kc,
            "{fit:?}"
        );
        // The kc residual is the noise: 1.15 % rms, within a fifth.
        assert!(
            (fit.kc_quality.rms_rel_error / sigma - 1.0).abs() < 0.2,
            "{fit:?}"
        );
        assert!(fit.kc_quality.r_squared > 0.99, "{fit:?}");
        // Each ratio is a ratio of force components, each ±2 %, over K_t (±1.2 % here): a
        // cut alone would give it to about 2 %·√2 of its value; 32 cuts to well under that.
        let kr = fit.radial_ratio.unwrap();
        let ka = fit.axial_ratio.unwrap();
        assert!((kr / 0.3 - 1.0).abs() < 0.02, "{fit:?}");
        assert!((ka / 0.25 - 1.0).abs() < 0.02, "{fit:?}");
        let q = fit.force_quality.unwrap();
        assert!(q.rms_rel_error < 0.03 && q.r_squared > 0.99, "{q:?}");
    }

    #[test]
    fn slot_by_hand() {
        // Ø10, 2 flutes, a_p 5, f_z 0.1, 6000 rpm: v_f = 0.1·2·6000 = 1200 mm/min = 20 mm/s,
        // Q = 10·5·20 = 1000 mm³/s; 1000 W gives kc = 1000·1000/1000 = 1000 N/mm².
        let cut = Cut {
            diameter_mm: 10.0,
            flutes: 2,
            ap_mm: 5.0,
            ae_mm: 10.0,
            fz_mm: 0.1,
            rpm: 6000.0,
            milling: Milling::Slot,
            power_w: Some(1000.0),
            force_n: None,
        };
        assert!((cut.mrr_mm3_s() - 1000.0).abs() < 1e-12);
        assert!((cut.kc_from_power_mpa().unwrap() - 1000.0).abs() < 1e-12);
        assert!((cut.mean_chip_mm() - 0.2 / PI).abs() < 1e-15);
        // Altintas' mean slot force: F_y = N a_p f_z K_t / 4 = 2·5·0.1·1000/4 = 250 N,
        // F_x = −k_r F_y = −75 N, and F_z = −k_a N a_p f_z K_t / π = −250/π N.
        let law = Kienzle {
            kc1_1_mpa: 1000.0,
            mc: 0.0,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let f = cut.force_n_of(&law);
        assert!((f[0] + 75.0).abs() < 1e-12, "{f:?}");
        assert!((f[1] - 250.0).abs() < 1e-12, "{f:?}");
        assert!((f[2] + 250.0 / PI).abs() < 1e-12, "{f:?}");
        assert!((cut.power_w_of(&law) - 1000.0).abs() < 1e-12);
        // Up milling at a_e = R: h_m = 2 f_z/π too, and F_y of a half immersion is half the
        // slot's tangential share.
        let half = Cut {
            ae_mm: 5.0,
            milling: Milling::Up,
            ..cut
        };
        assert!((half.mean_chip_mm() - 0.2 / PI).abs() < 1e-15);
        assert!((half.mrr_mm3_s() - 500.0).abs() < 1e-12);
    }

    #[test]
    fn kienzle_rejects_bad_cuts() {
        let good = measured(&TRUE_LAW, || 0.0);
        let with = |i: usize, edit: &dyn Fn(&mut Cut)| {
            let mut cuts = good.clone();
            edit(&mut cuts[i]);
            fit_kienzle(&cuts).unwrap_err().to_string()
        };
        let e = with(3, &|c| c.ae_mm = c.diameter_mm * 1.5);
        assert!(
            e.starts_with("cut 4 (counted from 1): ae (") && e.contains("wider"),
            "{e}"
        );
        let e = with(0, &|c| c.fz_mm = -0.1);
        assert!(e.contains("fz (mm) must be a positive"), "{e}");
        let e = with(2, &|c| c.power_w = Some(0.0));
        assert!(e.contains("power must be a positive"), "{e}");
        let e = with(0, &|c| {
            c.milling = Milling::Slot;
        });
        assert!(e.contains("a slot cuts ae = D"), "{e}");
        // One chip thickness only: mc is undetermined.
        let same: Vec<Cut> = good
            .iter()
            .take(4)
            .map(|c| Cut {
                fz_mm: 0.1,
                milling: Milling::Slot,
                ae_mm: c.diameter_mm,
                ..*c
            })
            .collect();
        let e = fit_kienzle(&same).unwrap_err();
        assert_eq!(
            e,
            FitError::SameChip {
                cuts: 4,
                distinct: 1
            }
        );
        assert_eq!(
            fit_kienzle(&good[..1]).unwrap_err(),
            FitError::SameChip {
                cuts: 1,
                distinct: 1
            }
        );
        // Neither power nor forces.
        let e = with(5, &|c| {
            c.power_w = None;
            c.force_n = None;
        });
        assert!(e.starts_with("cut 6 (counted from 1): neither"), "{e}");
    }
}
