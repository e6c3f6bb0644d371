//! Kienzle's specific cutting force and the mean chip thickness of milling (MODEL.md §3.2).

use serde::{Deserialize, Serialize};

/// Kienzle's law `kc = kc1_1 · h^(−mc)`: the cutting force per mm² of chip section
/// at chip thickness h, with the ratios of the radial and axial force to it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Kienzle {
    /// Specific cutting force at h = 1 mm (and b = 1 mm), N/mm².
    pub kc1_1_mpa: f64,
    /// Exponent mc (dimensionless, typically 0.14–0.3).
    pub mc: f64,
    /// Radial force / tangential force (dimensionless).
    pub radial_ratio: f64,
    /// Axial force / tangential force (dimensionless).
    pub axial_ratio: f64,
}

impl Kienzle {
    /// Specific cutting force in N/mm² at chip thickness `h_mm` (> 0).
    pub fn specific_force_mpa(&self, h_mm: f64) -> f64 {
        // MODEL.md §3.2: kc = kc1_1 · h^(−mc)
        self.kc1_1_mpa * h_mm.powf(-self.mc)
    }
}

/// Mean chip thickness of a milling cut between the engagement angles `phi_start` and
/// `phi_exit` (rad, measured from the feed normal so that the chip is `f_z · sin φ`):
/// `h_m = f_z (cos φ_st − cos φ_ex) / (φ_ex − φ_st)` (MODEL.md §3.2). A full slot
/// (0…π) and a half-immersion side cut (0…π/2 or π/2…π) both give `2 f_z / π`.
pub fn mean_chip_thickness_mm(fz_mm: f64, phi_start: f64, phi_exit: f64) -> f64 {
    fz_mm * (phi_start.cos() - phi_exit.cos()) / (phi_exit - phi_start)
}

/// Engagement angles (rad) of a side cut of radial depth `ae_mm` with a tool of radius
/// `r_mm`, up-milling from φ = 0: `(0, arccos(1 − ae/r))`.
pub fn side_cut_angles(ae_mm: f64, r_mm: f64) -> (f64, f64) {
    (0.0, (1.0 - (ae_mm / r_mm).min(2.0)).acos())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn mean_chip_thickness_by_hand() {
        let fz = 0.1;
        let slot = mean_chip_thickness_mm(fz, 0.0, PI);
        assert!((slot - 2.0 * fz / PI).abs() < 1e-15);
        let (a, b) = side_cut_angles(5.0, 5.0);
        assert!((b - PI / 2.0).abs() < 1e-15 && a == 0.0);
        assert!((mean_chip_thickness_mm(fz, a, b) - 2.0 * fz / PI).abs() < 1e-15);
        // Down-milling half: π/2 … π.
        assert!((mean_chip_thickness_mm(fz, PI / 2.0, PI) - 2.0 * fz / PI).abs() < 1e-15);
        // a_e = R/2: φ = arccos(0.5) = π/3, h_m = f · 0.5 / (π/3).
        let (a, b) = side_cut_angles(2.5, 5.0);
        assert!((mean_chip_thickness_mm(fz, a, b) - fz * 0.5 * 3.0 / PI).abs() < 1e-15);
    }

    #[test]
    fn specific_force() {
        let k = Kienzle {
            kc1_1_mpa: 1500.0,
            mc: 0.22,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        assert_eq!(k.specific_force_mpa(1.0), 1500.0);
        // 1500 · 0.1^−0.22 = 1500 · 10^0.22 = 1500 · 1.659587 = 2489.38
        assert!((k.specific_force_mpa(0.1) - 2489.3805).abs() < 1e-3);
    }
}
