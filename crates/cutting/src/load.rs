//! Per-step load of S4: force magnitude from removed volume, direction from the contact
//! resultant, deflection of the tool from the load distribution over its height bands.

use serde::{Deserialize, Serialize};

use crate::beam::Cantilever;
use crate::force::{force_n, volume_per_tooth_mm3};

/// Below this length the contact resultant is treated as zero (no defined direction).
const MIN_RESULTANT: f64 = 1e-12;

/// Unit XY direction of the cutting force **on the tool** for a step's contact resultant
/// (sum over cut columns of the horizontal unit vector from the tool axis towards the column,
/// weighted by removed volume; its Z component is ignored).
///
/// The material pushes the tool away from itself, so the force acts opposite to the resultant.
/// Returns `[0, 0]` when the horizontal resultant is (nearly) zero, e.g. a pure plunge.
pub fn force_direction(contact_resultant: [f64; 3]) -> [f64; 2] {
    // MODEL.md §1.4 (S4): the contact resultant is the force direction; the tool yields along its reaction.
    let [x, y, _] = contact_resultant;
    let len = x.hypot(y);
    if len.is_nan() || len <= MIN_RESULTANT {
        return [0.0, 0.0];
    }
    [-x / len, -y / len]
}

/// What one step of the sweep does to the tool.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepLoad {
    /// Magnitude of the cutting force, N.
    pub force_n: f64,
    /// X component of the force on the tool, N.
    pub fx_n: f64,
    /// Y component of the force on the tool, N.
    pub fy_n: f64,
    /// Lateral deflection of the tool tip, µm.
    pub deflection_um: f64,
    /// X component of the tip deflection, µm (along the force).
    pub dx_um: f64,
    /// Y component of the tip deflection, µm (along the force).
    pub dy_um: f64,
}

/// The parameters that turn a step's removed volume into force and deflection.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CuttingModel {
    /// `a` in `F = a · V^n`, N at V = 1 mm³ per tooth per revolution.
    pub force_coef_a: f64,
    /// `n` in `F = a · V^n`, dimensionless.
    pub force_exp_n: f64,
    /// Spindle speed, rev/min.
    pub spindle_rpm: f64,
    /// Number of flutes (teeth).
    pub flutes: u32,
    /// Height h of one band of the tool, mm; band k spans `[k·h, (k+1)·h)` above the tip.
    pub band_height_mm: f64,
    /// The tool as a beam.
    pub beam: Cantilever,
}

impl CuttingModel {
    /// Tip deflection in mm per newton of cutting force when the force is spread over the
    /// tool's height bands like `band_volumes_mm3`: band k carries the share
    /// `band_volumes_mm3[k] / Σ band_volumes_mm3` at its mid-height `(k + ½)·h` above the tip
    /// (MODEL.md §1.3; superposition of [`Cantilever::deflection_mm`]). With no volume in
    /// the bands the whole force acts at the tip, the largest deflection for that force.
    ///
    /// Does not allocate.
    pub fn tip_compliance_mm_per_n(&self, band_volumes_mm3: &[f64]) -> f64 {
        let band_total_mm3: f64 = band_volumes_mm3.iter().filter(|v| **v > 0.0).sum();
        if band_total_mm3 <= 0.0 {
            return self.beam.deflection_mm(1.0, 0.0, 0.0);
        }
        band_volumes_mm3
            .iter()
            .enumerate()
            .filter(|(_, v)| **v > 0.0)
            .map(|(k, v)| {
                let mid_height_mm = (k as f64 + 0.5) * self.band_height_mm;
                self.beam
                    .deflection_mm(v / band_total_mm3, mid_height_mm, 0.0)
            })
            .sum()
    }

    /// Load of one step that removed `step_volume_mm3` in `dt_s` seconds.
    ///
    /// * Force: `F = a · V^n` with V from [`volume_per_tooth_mm3`].
    /// * Deflection: `F ·` [`CuttingModel::tip_compliance_mm_per_n`] of the band volumes.
    /// * Direction: [`force_direction`] of `contact_resultant`; the tool bends along the force.
    ///
    /// Does not allocate.
    pub fn step_load(
        &self,
        step_volume_mm3: f64,
        band_volumes_mm3: &[f64],
        contact_resultant: [f64; 3],
        dt_s: f64,
    ) -> StepLoad {
        let v_mm3 = volume_per_tooth_mm3(step_volume_mm3, self.flutes, self.spindle_rpm, dt_s);
        let force = force_n(v_mm3, self.force_coef_a, self.force_exp_n);
        // The beam is linear: deflection = force · compliance.
        let tip_deflection_mm = force * self.tip_compliance_mm_per_n(band_volumes_mm3);
        let [ux, uy] = force_direction(contact_resultant);
        let deflection_um = tip_deflection_mm * 1000.0;
        StepLoad {
            force_n: force,
            fx_n: force * ux,
            fy_n: force * uy,
            deflection_um,
            dx_um: deflection_um * ux,
            dy_um: deflection_um * uy,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: CuttingModel = CuttingModel {
        force_coef_a: 800.0,
        force_exp_n: 0.72,
        spindle_rpm: 6000.0,
        flutes: 2,
        band_height_mm: 1.0,
        beam: Cantilever {
            stickout_mm: 80.0,
            effective_diameter_mm: 10.0,
            youngs_modulus_mpa: 210_000.0,
        },
    };

    #[test]
    fn direction_is_opposite_the_contact_resultant() {
        // Material on +x of the tool pushes it towards −x.
        assert_eq!(force_direction([2.0, 0.0, 0.0]), [-1.0, 0.0]);
        let [x, y] = force_direction([3.0, -4.0, 7.0]);
        assert!((x + 0.6).abs() < 1e-15 && (y - 0.8).abs() < 1e-15);
        assert_eq!(force_direction([0.0, 0.0, 5.0]), [0.0, 0.0]);
        assert_eq!(force_direction([f64::NAN, 0.0, 0.0]), [0.0, 0.0]);
    }

    #[test]
    fn step_load_by_hand() {
        // 2 flutes · 6000 rpm · 0.016 s / 60 = 3.2 tooth passes; 1.6 mm³ → V = 0.5 mm³.
        // F = 800 · 0.5^0.72 = 485.67795 N, split 3:1 over bands 0 and 2 (mid-heights 0.5, 2.5).
        let load = MODEL.step_load(1.6, &[0.3, 0.0, 0.1], [0.0, 1.0, 0.0], 0.016);
        let f = 800.0 * 0.5f64.powf(0.72);
        assert!((load.force_n - f).abs() < 1e-9);
        assert!(load.fx_n.abs() < 1e-12 && (load.fy_n + f).abs() < 1e-9);
        let expected_mm = MODEL
            .beam
            .deflection_from_band_loads(&[(0.5, 0.75 * f), (2.5, 0.25 * f)], 0.0);
        assert!((load.deflection_um - 1000.0 * expected_mm).abs() < 1e-9);
        assert!(load.dx_um.abs() < 1e-12 && (load.dy_um + load.deflection_um).abs() < 1e-12);
        // Close to the tip the bands barely shorten the lever: a bit less than F L³/(3EI).
        let tip_only_um = 1000.0 * MODEL.beam.deflection_mm(f, 0.0, 0.0);
        assert!(load.deflection_um < tip_only_um && load.deflection_um > 0.95 * tip_only_um);
        // Only the shares matter, not the volumes' scale.
        let compliance = MODEL.tip_compliance_mm_per_n(&[3.0, 0.0, 1.0]);
        assert!((1000.0 * f * compliance - load.deflection_um).abs() < 1e-9);
    }

    #[test]
    fn air_cut_and_empty_bands() {
        assert_eq!(
            MODEL.step_load(0.0, &[0.0, 0.0], [0.0; 3], 0.016),
            StepLoad::default()
        );
        // Volume but no band breakdown: the force acts at the tip.
        let load = MODEL.step_load(1.6, &[], [-1.0, 0.0, 0.0], 0.016);
        let tip_um = 1000.0 * MODEL.beam.deflection_mm(load.force_n, 0.0, 0.0);
        assert!((load.dx_um - tip_um).abs() < 1e-9);
    }
}
