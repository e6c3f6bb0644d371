//! Closed-loop drive models and their exact discrete simulation.

use nalgebra::Matrix4;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Dynamics of the closed position loop of one axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DriveOrder {
    /// First-order lag, `dx/dt = Kp·(c − x) + ff·ċ` (S4's model). Steady ramp lag
    /// `v·(1 − ff)/Kp`.
    First,
    /// Second-order loop, `ẍ + 2ζω·ẋ + ω²·x = ω²·c + 2ζω·ff·ċ`: a standard second-order
    /// closed loop (e.g. a P position loop around a first-order velocity loop) with velocity
    /// feed-forward scaled so that `ff = 1` again removes the ramp lag. Steady ramp lag
    /// `2ζ·v·(1 − ff)/ω`, i.e. it behaves like a first-order loop of gain `ω/(2ζ)` at low
    /// frequency. [`Drive::kp_per_s`] is not used by this model.
    Second {
        /// Damping ratio ζ (dimensionless, > 0).
        zeta: f64,
        /// Natural frequency ω, rad/s.
        omega_n_rad_s: f64,
    },
}

/// Model of a feed drive, the same on every axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Drive {
    /// Position loop gain Kp, 1/s (first-order model).
    pub kp_per_s: f64,
    /// Velocity feed-forward fraction ff, 0..=1 (0: none, 1: full).
    pub feedforward: f64,
    /// Loop dynamics.
    pub order: DriveOrder,
}

/// A drive parameter out of range.
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum DriveError {
    /// The position loop gain must be positive and finite.
    #[error("position loop gain {0} 1/s must be positive")]
    Gain(f64),
    /// The feed-forward fraction must lie in 0..=1.
    #[error("velocity feed-forward {0} must lie in 0..=1")]
    FeedForward(f64),
    /// Damping ratio and natural frequency must be positive and finite.
    #[error("second-order loop needs ζ > 0 and ω > 0, got ζ = {zeta}, ω = {omega_n_rad_s} rad/s")]
    SecondOrder {
        /// Damping ratio given.
        zeta: f64,
        /// Natural frequency given, rad/s.
        omega_n_rad_s: f64,
    },
}

impl Drive {
    /// First-order lag of gain `kp_per_s` without feed-forward.
    pub fn first_order(kp_per_s: f64) -> Drive {
        Drive {
            kp_per_s,
            feedforward: 0.0,
            order: DriveOrder::First,
        }
    }

    /// Checks the parameters; the simulation of an invalid drive is meaningless.
    pub fn validate(&self) -> Result<(), DriveError> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !(0.0..=1.0).contains(&self.feedforward) {
            return Err(DriveError::FeedForward(self.feedforward));
        }
        match self.order {
            DriveOrder::First if !positive(self.kp_per_s) => Err(DriveError::Gain(self.kp_per_s)),
            DriveOrder::Second {
                zeta,
                omega_n_rad_s,
            } if !positive(zeta) || !positive(omega_n_rad_s) => Err(DriveError::SecondOrder {
                zeta,
                omega_n_rad_s,
            }),
            _ => Ok(()),
        }
    }
}

/// Actual positions (mm) of the axes following `commanded` (mm, one sample per `period_s`),
/// starting at rest at the first command. Same length as `commanded`.
///
/// See [`simulate_actual_from`] for the discretisation.
pub fn simulate_actual(commanded: &[[f64; 3]], period_s: f64, drive: &Drive) -> Vec<[f64; 3]> {
    match commanded.first() {
        Some(&start_mm) => simulate_actual_from(commanded, period_s, drive, start_mm),
        None => Vec::new(),
    }
}

/// Actual positions (mm) of the axes following `commanded` and then holding its last sample,
/// until they stay within `settle_mm` of it (S2: the machining time of the estimated actual
/// motion). The command is held for at least as many periods again as were needed to settle
/// (64 at least), and never past 2²² extra periods; the result stops one sample after the
/// last one farther than `settle_mm`, or at the command's end if it settled before.
pub fn simulate_until_settled(
    commanded: &[[f64; 3]],
    period_s: f64,
    drive: &Drive,
    settle_mm: f64,
) -> Vec<[f64; 3]> {
    let Some(&end) = commanded.last() else {
        return Vec::new();
    };
    let far =
        |p: &[f64; 3]| (0..3).map(|k| (p[k] - end[k]).powi(2)).sum::<f64>() > settle_mm * settle_mm;
    let mut hold = 64usize;
    loop {
        let mut cmd = commanded.to_vec();
        cmd.resize(commanded.len() + hold, end);
        let mut actual = simulate_actual(&cmd, period_s, drive);
        let last_far = actual.iter().rposition(far);
        let settled_at = last_far.map_or(0, |k| k + 1);
        // Settled for at least as long again as it took after the command's end.
        let tail = cmd.len() - settled_at;
        if tail > settled_at.saturating_sub(commanded.len()).max(32) || hold >= 1 << 22 {
            actual.truncate(settled_at.max(commanded.len()).min(actual.len()));
            return actual;
        }
        hold *= 2;
    }
}

/// Actual positions (mm) of the axes following `commanded`, starting at rest (zero velocity) at
/// `start_mm`. Sample k of the result is the position at time `k·period_s`, so
/// `result[0] == start_mm`.
///
/// Discretisation: **exact for a first-order hold**, i.e. the command is taken as piecewise
/// linear between samples (constant velocity within a period, as interpolated servo data are),
/// and the linear ODE is solved exactly over each period. The only error is the model itself,
/// none from the time step: a ramp shows exactly the continuous lag, a sampled sine exactly the
/// response to its linear interpolation.
/// * First order: with `e = x − c` and slope `s` over the period, `ė = −Kp·e − (1 − ff)·s`,
///   so `e(T) = e(0)·e^{−Kp T} − (1 − ff)·s·(1 − e^{−Kp T})/Kp`.
/// * Second order: state `[x, ẋ, c, s]` with `ċ = s`, `ṡ = 0`; the transition over one period
///   is the matrix exponential `exp(A·T)` of that augmented linear system (Padé, computed once).
pub fn simulate_actual_from(
    commanded: &[[f64; 3]],
    period_s: f64,
    drive: &Drive,
    start_mm: [f64; 3],
) -> Vec<[f64; 3]> {
    if commanded.is_empty() {
        return Vec::new();
    }
    let mut actual = Vec::with_capacity(commanded.len());
    actual.push(start_mm);
    let ff = drive.feedforward;
    match drive.order {
        DriveOrder::First => {
            let decay = (-drive.kp_per_s * period_s).exp();
            let mut x = start_mm;
            for pair in commanded.windows(2) {
                for axis in 0..3 {
                    let (c0, c1) = (pair[0][axis], pair[1][axis]);
                    let slope = (c1 - c0) / period_s;
                    // MODEL.md §7.1 (S4) first-order lag, solved over one period:
                    // e(T) = e(0)·e^{−Kp T} − (1 − ff)·s·(1 − e^{−Kp T})/Kp
                    let e = (x[axis] - c0) * decay
                        - (1.0 - ff) * slope * (1.0 - decay) / drive.kp_per_s;
                    x[axis] = c1 + e;
                }
                actual.push(x);
            }
        }
        DriveOrder::Second {
            zeta,
            omega_n_rad_s: w,
        } => {
            // Not in S4 (MODEL.md §7.1, an extension of its lag): ẋ = v, v̇ = ω²(c − x) − 2ζω v + 2ζω ff s,
            // ċ = s, ṡ = 0
            #[rustfmt::skip]
            let a = Matrix4::new(
                0.0,    1.0,               0.0,   0.0,
                -w * w, -2.0 * zeta * w,   w * w, 2.0 * zeta * w * ff,
                0.0,    0.0,               0.0,   1.0,
                0.0,    0.0,               0.0,   0.0,
            );
            let phi = (a * period_s).exp();
            let mut x = start_mm;
            let mut v = [0.0; 3];
            for pair in commanded.windows(2) {
                for axis in 0..3 {
                    let (c0, c1) = (pair[0][axis], pair[1][axis]);
                    let z = [x[axis], v[axis], c0, (c1 - c0) / period_s];
                    let row = |r: usize| (0..4).map(|j| phi[(r, j)] * z[j]).sum::<f64>();
                    x[axis] = row(0);
                    v[axis] = row(1);
                }
                actual.push(x);
            }
        }
    }
    actual
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 0.001;

    fn ramp(v_mm_s: f64, samples: usize) -> Vec<[f64; 3]> {
        (0..samples)
            .map(|k| [v_mm_s * k as f64 * T, 0.0, 0.0])
            .collect()
    }

    #[test]
    fn first_order_ramp_lag_is_v_over_kp() {
        // 25 mm/s (1500 mm/min) with Kp = 30/s: lag 25/30 mm once e^{−30 t} has died out.
        let cmd = ramp(25.0, 2001);
        for ff in [0.0, 0.4, 1.0] {
            let drive = Drive {
                feedforward: ff,
                ..Drive::first_order(30.0)
            };
            let act = simulate_actual(&cmd, T, &drive);
            let lag = cmd[2000][0] - act[2000][0];
            assert!(
                (lag - 25.0 * (1.0 - ff) / 30.0).abs() < 1e-12,
                "ff {ff}: lag {lag}"
            );
            assert_eq!(act[0], cmd[0]);
        }
    }

    #[test]
    fn first_order_step_response() {
        // Held command 1 mm, starting at rest at 0: x(t) = 1 − e^{−Kp t} at every sample.
        let cmd = vec![[1.0, -2.0, 0.5]; 500];
        let act = simulate_actual_from(&cmd, T, &Drive::first_order(40.0), [0.0; 3]);
        for (k, x) in act.iter().enumerate() {
            let g = 1.0 - (-40.0 * k as f64 * T).exp();
            assert!(
                (x[0] - g).abs() < 1e-14
                    && (x[1] + 2.0 * g).abs() < 1e-14
                    && (x[2] - 0.5 * g).abs() < 1e-14
            );
        }
    }

    #[test]
    fn first_order_circle_radius() {
        // r/√(1 + (ω/Kp)²) after transients; ωT = 1e-3 keeps the chord effect ≈ (ωT)²/12 ≈ 1e-7.
        let (r, w, kp, dt) = (10.0, 5.0, 30.0, 2e-4);
        let cmd: Vec<_> = (0..10_000)
            .map(|k| {
                let t = k as f64 * dt;
                [r * (w * t).cos(), r * (w * t).sin(), 0.0]
            })
            .collect();
        let act = simulate_actual(&cmd, dt, &Drive::first_order(kp));
        let expected = r / (1.0 + (w / kp).powi(2)).sqrt();
        for x in &act[5000..] {
            let radius = x[0].hypot(x[1]);
            assert!(
                (radius / expected - 1.0).abs() < 1e-6,
                "{radius} vs {expected}"
            );
        }
    }

    #[test]
    fn second_order_step_and_ramp() {
        let (zeta, w) = (0.5, 200.0);
        let drive = Drive {
            kp_per_s: 0.0,
            feedforward: 0.0,
            order: DriveOrder::Second {
                zeta,
                omega_n_rad_s: w,
            },
        };
        assert_eq!(drive.validate(), Ok(()));
        // Under-damped step: 1 − e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t), ω_d = ω√(1−ζ²).
        let cmd = vec![[1.0, 0.0, 0.0]; 200];
        let act = simulate_actual_from(&cmd, T, &drive, [0.0; 3]);
        let wd = w * (1.0 - zeta * zeta).sqrt();
        for (k, x) in act.iter().enumerate() {
            let t = k as f64 * T;
            let g = 1.0
                - (-zeta * w * t).exp()
                    * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin());
            assert!((x[0] - g).abs() < 1e-12, "t = {t}: {} vs {g}", x[0]);
        }
        // Ramp lag 2ζ·v·(1 − ff)/ω.
        let cmd = ramp(25.0, 1001);
        for ff in [0.0, 0.5] {
            let act = simulate_actual(
                &cmd,
                T,
                &Drive {
                    feedforward: ff,
                    ..drive
                },
            );
            let lag = cmd[1000][0] - act[1000][0];
            assert!(
                (lag - 2.0 * zeta * 25.0 * (1.0 - ff) / w).abs() < 1e-11,
                "ff {ff}: {lag}"
            );
        }
    }

    #[test]
    fn validation() {
        assert_eq!(
            Drive::first_order(0.0).validate(),
            Err(DriveError::Gain(0.0))
        );
        assert_eq!(
            Drive {
                feedforward: 1.5,
                ..Drive::first_order(30.0)
            }
            .validate(),
            Err(DriveError::FeedForward(1.5))
        );
        let bad = Drive {
            order: DriveOrder::Second {
                zeta: 0.0,
                omega_n_rad_s: 100.0,
            },
            ..Drive::first_order(30.0)
        };
        assert!(matches!(
            bad.validate(),
            Err(DriveError::SecondOrder { .. })
        ));
        assert!(simulate_actual(&[], T, &Drive::first_order(30.0)).is_empty());
    }
}
