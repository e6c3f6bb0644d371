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

/// The tool as a stepped cantilever (MODEL.md §4.2): a fluted section of effective diameter
/// `flute_diameter_mm` from the tip up to `flute_length_mm`, then a solid shank of
/// `shank_diameter_mm` up to the holder face at `stickout_mm`, clamped there in a holder
/// that gives laterally like a spring of `holder_stiffness_n_per_um` (rigid when `None`).
///
/// Positions are measured from the tip, as for [`Cantilever`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteppedBeam {
    /// Length from the tip to the holder face, mm.
    pub stickout_mm: f64,
    /// Length of the fluted section from the tip, mm (the whole stick-out if longer).
    pub flute_length_mm: f64,
    /// Effective diameter of the fluted section, mm.
    pub flute_diameter_mm: f64,
    /// Diameter of the solid shank, mm.
    pub shank_diameter_mm: f64,
    /// Young's modulus E, MPa.
    pub youngs_modulus_mpa: f64,
    /// Lateral stiffness of holder and spindle at the holder face, N/µm; `None`: rigid.
    pub holder_stiffness_n_per_um: Option<f64>,
}

/// Flexural rigidity E·π d⁴/64 of a round section, N·mm².
fn rigidity(e_mpa: f64, d_mm: f64) -> f64 {
    e_mpa * std::f64::consts::PI * d_mm.powi(4) / 64.0
}

impl SteppedBeam {
    /// A uniform beam (the S4 model of [`Cantilever`]) on a rigid holder.
    pub fn uniform(c: &Cantilever) -> SteppedBeam {
        SteppedBeam {
            stickout_mm: c.stickout_mm,
            flute_length_mm: c.stickout_mm,
            flute_diameter_mm: c.effective_diameter_mm,
            shank_diameter_mm: c.effective_diameter_mm,
            youngs_modulus_mpa: c.youngs_modulus_mpa,
            holder_stiffness_n_per_um: None,
        }
    }

    /// Distance from the holder face to where the flutes begin, mm (0 when they reach it).
    fn shank_span_mm(&self) -> f64 {
        (self.stickout_mm - self.flute_length_mm).max(0.0)
    }

    /// Lateral deflection in mm at `at_from_tip_mm` caused by a point load `load_n` at
    /// `load_from_tip_mm` (both clamped to [0, L]).
    ///
    /// Unit-load method with s measured from the holder face, load at b = L − a, point at
    /// u = L − x: `δ = F ∫₀^min(u,b) (b − s)(u − s) / EI(s) ds + F / k_holder`, where EI(s)
    /// is the shank's for s < L − L_f and the flutes' beyond. With
    /// `G(s) = b·u·s − (b + u) s²/2 + s³/3` the integral is `ΔG/EI` per section (closed form).
    pub fn deflection_mm(&self, load_n: f64, load_from_tip_mm: f64, at_from_tip_mm: f64) -> f64 {
        let l = self.stickout_mm;
        let b = l - load_from_tip_mm.clamp(0.0, l);
        let u = l - at_from_tip_mm.clamp(0.0, l);
        let m = u.min(b);
        let g = |s: f64| b * u * s - 0.5 * (b + u) * s * s + s * s * s / 3.0;
        let s_b = self.shank_span_mm().min(m);
        let e = self.youngs_modulus_mpa;
        // MODEL.md §4.2: two sections by superposition, plus the holder's spring.
        let bending = (g(s_b) - g(0.0)) / rigidity(e, self.shank_diameter_mm)
            + (g(m) - g(s_b)) / rigidity(e, self.flute_diameter_mm);
        let holder = self
            .holder_stiffness_n_per_um
            .map_or(0.0, |k| 1.0 / (1000.0 * k));
        load_n * (bending + holder)
    }

    /// Deflection at `at_from_tip_mm` under loads `(height_from_tip_mm, load_n)` along one
    /// direction (superposition).
    pub fn deflection_from_band_loads(&self, loads: &[(f64, f64)], at_from_tip_mm: f64) -> f64 {
        loads
            .iter()
            .map(|&(a, f)| self.deflection_mm(f, a, at_from_tip_mm))
            .sum()
    }

    /// Largest bending stress in MPa under lateral loads `(height_from_tip_mm, load_n)`
    /// and torque `torque_nmm` (N·mm), as von Mises `√(σ² + 3τ²)` with `σ = M / (π d³/32)`,
    /// `τ = T / (π d³/16)`: checked at the holder face (shank section) and where the flutes
    /// end (fluted section), the two places a tool breaks (MODEL.md §4.4).
    pub fn peak_stress_mpa(&self, loads: &[(f64, f64)], torque_nmm: f64) -> f64 {
        let moment_at = |x: f64| -> f64 {
            loads
                .iter()
                .map(|&(a, f)| f * (x - a.clamp(0.0, self.stickout_mm)).max(0.0))
                .sum()
        };
        let von_mises = |m: f64, d: f64| {
            let z = std::f64::consts::PI * d.powi(3) / 32.0;
            let sigma = m / z;
            let tau = torque_nmm / (2.0 * z);
            (sigma * sigma + 3.0 * tau * tau).sqrt()
        };
        let flute_end = self.flute_length_mm.min(self.stickout_mm);
        von_mises(moment_at(self.stickout_mm), self.shank_diameter_mm)
            .max(von_mises(moment_at(flute_end), self.flute_diameter_mm))
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

    /// Deflection of a two-section cantilever by integrating the curvature M/EI twice
    /// numerically (trapezoid rule, fine steps): an independent check of the closed form.
    fn integrated(beam: &SteppedBeam, a: f64, x: f64) -> f64 {
        let l = beam.stickout_mm;
        let n = 200_000;
        let ds = l / n as f64;
        let (mut slope, mut defl) = (0.0f64, 0.0f64);
        let curvature = |s: f64| {
            // s from the clamp; moment of a unit load at b = L − a.
            let m = ((l - a) - s).max(0.0);
            let d = if s < l - beam.flute_length_mm {
                beam.shank_diameter_mm
            } else {
                beam.flute_diameter_mm
            };
            m / super::rigidity(beam.youngs_modulus_mpa, d)
        };
        let target = l - x;
        let mut s = 0.0;
        for _ in 0..n {
            if s >= target {
                break;
            }
            let h = ds.min(target - s);
            let k0 = curvature(s);
            let k1 = curvature(s + h);
            let new_slope = slope + 0.5 * (k0 + k1) * h;
            defl += 0.5 * (slope + new_slope) * h;
            slope = new_slope;
            s += h;
        }
        defl
    }

    const STEPPED: SteppedBeam = SteppedBeam {
        stickout_mm: 80.0,
        flute_length_mm: 20.0,
        flute_diameter_mm: 8.0,
        shank_diameter_mm: 10.0,
        youngs_modulus_mpa: 600_000.0,
        holder_stiffness_n_per_um: None,
    };

    #[test]
    fn stepped_beam_tip_load_closed_form() {
        // Two-section cantilever, tip load: δ_tip = F/3 · (L_f³/EI_f + (L³ − L_f³)/EI_s).
        let (l, lf) = (80.0f64, 20.0f64);
        let ei_f = 600_000.0 * std::f64::consts::PI * 8f64.powi(4) / 64.0;
        let ei_s = 600_000.0 * std::f64::consts::PI * 10f64.powi(4) / 64.0;
        let expected = (lf.powi(3) / ei_f + (l.powi(3) - lf.powi(3)) / ei_s) / 3.0;
        assert!(close(STEPPED.deflection_mm(1.0, 0.0, 0.0), expected, 1e-12));
        // The stepped tool is stiffer than S4's uniform 0.8·D beam over the whole stick-out.
        let uniform = SteppedBeam {
            shank_diameter_mm: 8.0,
            ..STEPPED
        };
        let gain = uniform.deflection_mm(1.0, 0.0, 0.0) / STEPPED.deflection_mm(1.0, 0.0, 0.0);
        assert!(gain > 2.0 && gain < 2.5, "{gain}");
        // A uniform stepped beam is the uniform cantilever.
        let c = Cantilever {
            stickout_mm: 80.0,
            effective_diameter_mm: 8.0,
            youngs_modulus_mpa: 600_000.0,
        };
        for (a, x) in [(0.0, 0.0), (3.0, 10.0), (30.0, 5.0), (70.0, 75.0)] {
            assert!(close(
                SteppedBeam::uniform(&c).deflection_mm(1.0, a, x),
                c.deflection_mm(1.0, a, x),
                1e-12
            ));
        }
    }

    #[test]
    fn stepped_beam_matches_integrated_curvature() {
        for beam in [
            STEPPED,
            SteppedBeam {
                flute_length_mm: 50.0,
                shank_diameter_mm: 12.0,
                ..STEPPED
            },
        ] {
            for a in [0.0, 2.5, 15.0, 35.0] {
                for x in [0.0, 1.0, 10.0, 20.0, 40.0, 79.0] {
                    let closed = beam.deflection_mm(1.0, a, x);
                    let numeric = integrated(&beam, a, x);
                    assert!(
                        close(closed, numeric, 5e-3),
                        "load at {a}, point at {x}: {closed} vs {numeric}"
                    );
                }
            }
            // Maxwell–Betti reciprocity.
            assert!(close(
                beam.deflection_mm(1.0, 4.0, 33.0),
                beam.deflection_mm(1.0, 33.0, 4.0),
                1e-12
            ));
        }
    }

    #[test]
    fn holder_spring_adds_a_translation_and_stress_by_hand() {
        let soft = SteppedBeam {
            holder_stiffness_n_per_um: Some(20.0),
            ..STEPPED
        };
        // 100 N on a 20 N/µm holder: 5 µm more everywhere.
        for x in [0.0, 30.0, 80.0] {
            let extra = soft.deflection_mm(100.0, 0.0, x) - STEPPED.deflection_mm(100.0, 0.0, x);
            assert!((extra - 0.005).abs() < 1e-12);
        }
        // 100 N at the tip: M = 100·80 at the holder on Ø10 (Z = 98.17 mm³) → 81.49 MPa;
        // M = 100·20 at the flute end on Ø8 (Z = 50.27 mm³) → 39.79 MPa.
        let s = STEPPED.peak_stress_mpa(&[(0.0, 100.0)], 0.0);
        assert!((s - 8000.0 / (std::f64::consts::PI * 1000.0 / 32.0)).abs() < 1e-9);
        // Torque alone: τ = T / (π d³/16) on the thinner section, √3 τ.
        let s = STEPPED.peak_stress_mpa(&[], 1000.0);
        let tau = 1000.0 / (std::f64::consts::PI * 512.0 / 16.0);
        assert!((s - 3f64.sqrt() * tau).abs() < 1e-9);
    }
}
