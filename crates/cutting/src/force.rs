//! Volume per tooth and the force law of S4.

/// Removed volume per tooth per revolution in mm³ for a step that removed `step_volume_mm3`
/// in `dt_s` seconds: `V = volume / (flutes · rpm · Δt / 60)` (the denominator is the number of
/// tooth passes during the step).
///
/// `flutes`, `spindle_rpm` and `dt_s` must be positive; otherwise the result is not finite.
pub fn volume_per_tooth_mm3(step_volume_mm3: f64, flutes: u32, spindle_rpm: f64, dt_s: f64) -> f64 {
    // MODEL.md §2: V = A·fz with fz = F/(flutes·rpm); per step V = volume / (flutes·rpm·Δt/60)
    let tooth_passes = f64::from(flutes) * spindle_rpm * dt_s / 60.0;
    step_volume_mm3 / tooth_passes
}

/// Cutting force in N from volume per tooth `v_mm3` (mm³/rev/tooth) and the material's
/// coefficients `a` (N at 1 mm³) and `n`. Zero for a non-positive volume (the tool cuts air).
pub fn force_n(v_mm3: f64, a: f64, n: f64) -> f64 {
    if v_mm3 <= 0.0 {
        return 0.0;
    }
    // MODEL.md §3.1 (S4): F = a · V^n
    a * v_mm3.powf(n)
}

/// The inverse of [`force_n`]: the volume per tooth (mm³/rev/tooth) at which the force law
/// gives `force_n` (used to turn a force limit into a feed cap).
pub fn volume_per_tooth_at_force_mm3(force_n: f64, a: f64, n: f64) -> f64 {
    // MODEL.md §3.1 (S4): F = a · V^n  ⇒  V = (F / a)^(1/n)
    (force_n / a).powf(1.0 / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_per_tooth_arithmetic() {
        // 2 flutes at 6000 rpm for 16 ms: 2 · 6000 · 0.016 / 60 = 3.2 tooth passes.
        // 8 mm³ over 3.2 passes = 2.5 mm³ per tooth.
        assert!((volume_per_tooth_mm3(8.0, 2, 6000.0, 0.016) - 2.5).abs() < 1e-12);
        assert_eq!(volume_per_tooth_mm3(0.0, 4, 10000.0, 0.001), 0.0);
    }

    #[test]
    fn force_law() {
        // 800 · 0.5^0.72 = 800 · exp(0.72 · ln 0.5) = 800 · 0.607097... = 485.677...
        let f = force_n(0.5, 800.0, 0.72);
        assert!((f - 800.0 * (0.72f64 * 0.5f64.ln()).exp()).abs() < 1e-9);
        assert!((f - 485.678).abs() < 1e-3);
        assert_eq!(force_n(1.0, 250.0, 0.7), 250.0);
        assert_eq!(force_n(0.0, 250.0, 0.7), 0.0);
        assert_eq!(force_n(-1.0, 250.0, 0.7), 0.0);
    }

    #[test]
    fn force_law_inverse() {
        // (485.678 / 800)^(1/0.72) = 0.5 (to the rounding of 485.678).
        assert!((volume_per_tooth_at_force_mm3(485.677_6, 800.0, 0.72) - 0.5).abs() < 1e-6);
        for v in [0.01, 0.3, 2.0] {
            let f = force_n(v, 250.0, 0.7);
            assert!((volume_per_tooth_at_force_mm3(f, 250.0, 0.7) - v).abs() < 1e-12 * v.max(1.0));
        }
    }
}
