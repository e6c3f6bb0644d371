//! The tool as a cantilever beam (S4): clamped in the holder, free at the tip.

use serde::{Deserialize, Serialize};

/// A round tool of stick-out `L` clamped in the holder and free at the tip.
///
/// Positions along the tool are measured **from the tip** upwards (x = 0 at the tip, x = L at the
/// holder face), as in S4's `z(x)`. Deflections are lateral, in mm, in the direction of the load.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cantilever {
    /// Stick-out L: length from the tip to the holder face, mm.
    pub stickout_mm: f64,
    /// Effective diameter d of the fluted part, mm (smaller than the nominal diameter).
    pub effective_diameter_mm: f64,
    /// Young's modulus E, MPa (= N/mm²); ≈ 210 000 for HSS, ≈ 600 000 for carbide.
    pub youngs_modulus_mpa: f64,
}

impl Cantilever {
    /// Second moment of area of the round section, mm⁴.
    pub fn second_moment_mm4(&self) -> f64 {
        // MODEL.md §4.1 (S4): I = π d⁴ / 64
        std::f64::consts::PI * self.effective_diameter_mm.powi(4) / 64.0
    }

    /// Flexural rigidity E·I, N·mm².
    pub fn flexural_rigidity_n_mm2(&self) -> f64 {
        self.youngs_modulus_mpa * self.second_moment_mm4()
    }

    /// Lateral deflection in mm at `at_from_tip_mm` caused by a point load `load_n` acting at
    /// `load_from_tip_mm`, both measured from the tip and clamped to [0, L] (a load at or above
    /// the holder face bends nothing).
    ///
    /// With u = L − x the distance from the clamp and b = L − a that of the load, the standard
    /// cantilever solution is `F u² (3b − u) / (6EI)` for u ≤ b and `F b² (3u − b) / (6EI)`
    /// for u ≥ b. For a tip load (b = L) it reduces to S4's
    /// `z(x) = F/(6EI) (2L³ − 3L²x + x³)`, and at the tip to `F L³ / (3EI)`.
    pub fn deflection_mm(&self, load_n: f64, load_from_tip_mm: f64, at_from_tip_mm: f64) -> f64 {
        let l = self.stickout_mm;
        let b = l - load_from_tip_mm.clamp(0.0, l);
        let u = l - at_from_tip_mm.clamp(0.0, l);
        let six_ei = 6.0 * self.flexural_rigidity_n_mm2();
        // MODEL.md §4.1: S4's z(x) generalised to a load anywhere on the cantilever.
        if u <= b {
            // y(u) = F u² (3b − u) / (6EI), between clamp and load
            load_n * u * u * (3.0 * b - u) / six_ei
        } else {
            // y(u) = F b² (3u − b) / (6EI), between load and tip (straight part)
            load_n * b * b * (3.0 * u - b) / six_ei
        }
    }

    /// Lateral deflection in mm at `at_from_tip_mm` under several point loads
    /// `(height_from_tip_mm, load_n)` acting along one direction (superposition of
    /// [`Cantilever::deflection_mm`]).
    pub fn deflection_from_band_loads(&self, loads: &[(f64, f64)], at_from_tip_mm: f64) -> f64 {
        loads
            .iter()
            .map(|&(height_from_tip_mm, load_n)| {
                self.deflection_mm(load_n, height_from_tip_mm, at_from_tip_mm)
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// S4's case: 10 mm HSS ball-end mill, 80 mm stick-out.
    const TOOL: Cantilever = Cantilever {
        stickout_mm: 80.0,
        effective_diameter_mm: 10.0,
        youngs_modulus_mpa: 210_000.0,
    };

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-300)
    }

    #[test]
    fn second_moment_by_hand() {
        // I = π · 10⁴ / 64 = 490.873852... mm⁴
        assert!(close(TOOL.second_moment_mm4(), 490.873_852_123_405, 1e-12));
    }

    #[test]
    fn tip_load_tip_deflection_by_hand() {
        // EI = 210000 · 490.873852 = 1.030835089e8 N·mm²
        // F L³ / (3EI) = 100 · 80³ / (3 · 1.030835089e8) = 5.12e7 / 3.092505268e8 = 0.16556156...
        let tip = TOOL.deflection_mm(100.0, 0.0, 0.0);
        assert!(close(tip, 0.165_561_561_1, 1e-9), "{tip}");
    }

    #[test]
    fn general_formula_matches_s4_tip_load_curve() {
        let (f, l) = (100.0, TOOL.stickout_mm);
        let ei = TOOL.flexural_rigidity_n_mm2();
        for i in 0..=16 {
            let x = l * f64::from(i) / 16.0;
            // z(x) = F/(6EI) (2L³ − 3L²x + x³)
            let s4 = f / (6.0 * ei) * (2.0 * l.powi(3) - 3.0 * l * l * x + x.powi(3));
            assert!(
                (TOOL.deflection_mm(f, 0.0, x) - s4).abs() < 1e-15,
                "x = {x}"
            );
        }
        assert_eq!(TOOL.deflection_mm(f, 0.0, l), 0.0);
        // Loads at or above the holder are clamped there and bend nothing.
        assert_eq!(TOOL.deflection_mm(f, 90.0, 0.0), 0.0);
    }

    #[test]
    fn mid_load_by_hand() {
        // Load 100 N at 40 mm from the tip: b = 40 mm from the clamp.
        // Under the load: F b³ / (3EI) = 100 · 64000 / 3.092505268e8 = 0.0206951951 mm.
        // At the tip (u = 80): F b² (3u − b) / (6EI) = 100 · 1600 · 200 / 6.185010536e8
        //                    = 0.0517379878 mm.
        assert!(close(
            TOOL.deflection_mm(100.0, 40.0, 40.0),
            0.020_695_195_1,
            1e-8
        ));
        assert!(close(
            TOOL.deflection_mm(100.0, 40.0, 0.0),
            0.051_737_987_8,
            1e-8
        ));
        // Maxwell–Betti reciprocity: load at a, read at x equals load at x, read at a.
        assert!(close(
            TOOL.deflection_mm(100.0, 10.0, 55.0),
            TOOL.deflection_mm(100.0, 55.0, 10.0),
            1e-12
        ));
    }

    #[test]
    fn band_loads_superpose() {
        let loads = [(2.5, 60.0), (7.5, 40.0)];
        let sum = TOOL.deflection_mm(60.0, 2.5, 0.0) + TOOL.deflection_mm(40.0, 7.5, 0.0);
        assert!(close(
            TOOL.deflection_from_band_loads(&loads, 0.0),
            sum,
            1e-14
        ));
        // By hand at the tip, b₁ = 77.5, b₂ = 72.5, u = 80, 6EI = 6.185010536e8 N·mm²:
        // 60 · 77.5² · (240 − 77.5) + 40 · 72.5² · (240 − 72.5)
        //   = 60 · 6006.25 · 162.5 + 40 · 5256.25 · 167.5 = 58 560 937.5 + 35 216 875 = 93 777 812.5
        // → 93 777 812.5 / 6.185010536e8 = 0.1516211 mm.
        assert!(close(
            TOOL.deflection_from_band_loads(&loads, 0.0),
            0.151_621_1,
            1e-6
        ));
        assert_eq!(TOOL.deflection_from_band_loads(&[], 0.0), 0.0);
    }
}
