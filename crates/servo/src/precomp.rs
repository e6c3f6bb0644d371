//! S4's pre-compensation of the command for the drive's motion error.

use serde::{Deserialize, Serialize};

use crate::drive::{simulate_actual, Drive, DriveOrder};

/// Result of [`precompensate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Precomp {
    /// The compensated command, mm per servo period (the best one found).
    pub command: Vec<[f64; 3]>,
    /// Number of corrections applied.
    pub iterations: usize,
    /// Largest |target − actual| with the uncompensated command, mm.
    pub error_before_mm: f64,
    /// Largest |target − actual| with [`Precomp::command`], mm.
    pub error_after_mm: f64,
    /// Largest |target − actual| in mm for the command of each iteration, starting with the
    /// uncompensated one (`history[0] == error_before_mm`).
    pub history: Vec<f64>,
}

/// Largest sample-wise distance |target − actual|, mm.
fn max_error_mm(target: &[[f64; 3]], actual: &[[f64; 3]]) -> f64 {
    target
        .iter()
        .zip(actual)
        .map(|(t, a)| {
            ((t[0] - a[0]).powi(2) + (t[1] - a[1]).powi(2) + (t[2] - a[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

/// The command that makes the first-order drive's actual positions equal `target` at every
/// sample (MODEL.md §7.3), or `None` for a second-order drive.
///
/// Over one period the exact solution of §7.1 gives
/// `x_k+1 = (1 − g)·c_k+1 + (g − d)·c_k + d·x_k` with `d = e^{−Kp T}` and
/// `g = (1 − ff)(1 − d)/(Kp T)`; solving it for `c_k+1` with `x_k+1 = target_k+1` gives the
/// command sample by sample. The recursion multiplies rounding by (g − d)/(1 − g), which lies
/// in (−1, 1) for every Kp·T > 0, so it stays bounded. Starts at rest at `target[0]`.
pub fn first_order_inverse(
    target: &[[f64; 3]],
    period_s: f64,
    drive: &Drive,
) -> Option<Vec<[f64; 3]>> {
    if drive.order != DriveOrder::First {
        return None;
    }
    let kp_t = drive.kp_per_s * period_s;
    let d = (-kp_t).exp();
    let g = (1.0 - drive.feedforward) * (1.0 - d) / kp_t;
    if !(1.0 - g > 1e-12) {
        return None;
    }
    let first = *target.first()?;
    let mut command = Vec::with_capacity(target.len());
    command.push(first);
    let (mut c, mut x) = (first, first);
    for t in &target[1..] {
        let mut next = [0.0; 3];
        for axis in 0..3 {
            next[axis] = (t[axis] - d * x[axis] - (g - d) * c[axis]) / (1.0 - g);
            x[axis] = (1.0 - g) * next[axis] + (g - d) * c[axis] + d * x[axis];
        }
        command.push(next);
        c = next;
    }
    Some(command)
}

/// S4's loop: simulate the drive on the command, add the error `target − actual` to the
/// command, repeat until the largest sample-wise error is below `threshold_mm` or after
/// `max_iterations` corrections. Starts from the exact inverse of a first-order drive
/// ([`first_order_inverse`], counted as one correction) or else from `command = target`.
///
/// The error is measured sample by sample (position at the same time), not to the path: the
/// goal is to be on time as well as on the path. Returns the best command seen.
///
/// Convergence: each pass multiplies the error's content at frequency ω by about
/// `|jω / (jω + Kp)|` (first order, no feed-forward), so a smooth target converges in a few
/// passes, while a velocity step (a ramp starting from rest) converges only slowly, because a
/// lag cannot follow it without an impulse in the command.
pub fn precompensate(
    target: &[[f64; 3]],
    period_s: f64,
    drive: &Drive,
    threshold_mm: f64,
    max_iterations: usize,
) -> Precomp {
    let mut command = target.to_vec();
    let mut actual = simulate_actual(&command, period_s, drive);
    let error_before_mm = max_error_mm(target, &actual);
    let mut history = vec![error_before_mm];
    let mut best = (error_before_mm, command.clone());
    let mut iterations = 0;
    if best.0 >= threshold_mm && max_iterations > 0 {
        if let Some(inverse) = first_order_inverse(target, period_s, drive) {
            command = inverse;
            iterations = 1;
            actual = simulate_actual(&command, period_s, drive);
            let error_mm = max_error_mm(target, &actual);
            history.push(error_mm);
            if error_mm < best.0 {
                best = (error_mm, command.clone());
            }
        }
    }
    while best.0 >= threshold_mm && iterations < max_iterations {
        for ((c, t), a) in command.iter_mut().zip(target).zip(&actual) {
            for axis in 0..3 {
                // MODEL.md §7.3 (S4) motion error: command ← command + (target − actual)
                c[axis] += t[axis] - a[axis];
            }
        }
        iterations += 1;
        actual = simulate_actual(&command, period_s, drive);
        let error_mm = max_error_mm(target, &actual);
        history.push(error_mm);
        if error_mm < best.0 {
            best = (error_mm, command.clone());
        }
    }
    Precomp {
        command: best.1,
        iterations,
        error_before_mm,
        error_after_mm: best.0,
        history,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp to 25 mm/s along (1, ½, 0) whose velocity rises smoothly over `ramp_s`
    /// (smootherstep `10u³ − 15u⁴ + 6u⁵`: acceleration and jerk start and end at zero), then
    /// constant, sampled every `t` for `samples`.
    fn smooth_ramp(ramp_s: f64, t: f64, samples: usize) -> Vec<[f64; 3]> {
        let v = 25.0;
        (0..samples)
            .map(|k| {
                let s = k as f64 * t;
                // ∫ v·(10u³ − 15u⁴ + 6u⁵) dt with u = s/ramp_s, then v·(s − ramp_s/2)
                let x = if s < ramp_s {
                    let u = s / ramp_s;
                    v * ramp_s * (2.5 * u.powi(4) - 3.0 * u.powi(5) + u.powi(6))
                } else {
                    v * (s - 0.5 * ramp_s)
                };
                [x, 0.5 * x, 0.0]
            })
            .collect()
    }

    #[test]
    fn ramp_error_drops_under_threshold_in_a_few_iterations() {
        let (t, kp) = (0.001, 30.0);
        let target = smooth_ramp(1.0, t, 3000);
        let drive = Drive::first_order(kp);
        let p = precompensate(&target, t, &drive, 1e-3, 10);
        // Before: the steady lag v/Kp along the ramp direction, √(25² + 12.5²)/30 = 0.93 mm.
        assert!(
            (p.error_before_mm - 25.0f64.hypot(12.5) / kp).abs() < 1e-3,
            "{p:?}"
        );
        assert!(
            p.error_after_mm < 1e-3 && p.iterations <= 5,
            "{:?}",
            p.history
        );
        assert_eq!(p.history.len(), p.iterations + 1);
        assert!(p.history.windows(2).all(|w| w[1] < w[0]), "{:?}", p.history);
        let check = max_error_mm(&target, &simulate_actual(&p.command, t, &drive));
        assert_eq!(check, p.error_after_mm);
    }

    #[test]
    fn already_good_or_no_iterations() {
        let target = vec![[1.0, 2.0, 3.0]; 10];
        let p = precompensate(&target, 0.001, &Drive::first_order(30.0), 1e-6, 10);
        assert_eq!(
            (p.iterations, p.error_after_mm, p.command),
            (0, 0.0, target.clone())
        );
        let ramp: Vec<_> = (0..100).map(|k| [k as f64 * 0.01, 0.0, 0.0]).collect();
        let p = precompensate(&ramp, 0.001, &Drive::first_order(30.0), 1e-6, 0);
        assert_eq!((p.iterations, p.history.len()), (0, 1));
        assert_eq!(p.error_after_mm, p.error_before_mm);
    }

    /// A velocity step from rest (a trapezoid start without jerk limit, the case S4's loop
    /// alone leaves at 0.02 mm after 20 passes): the exact inverse puts the drive on the
    /// target at every sample, for several gains, periods and feed-forward fractions.
    #[test]
    fn exact_inverse_follows_a_velocity_step() {
        for (kp, t, ff) in [
            (30.0, 0.016, 0.0),
            (30.0, 0.001, 0.0),
            (200.0, 0.016, 0.5),
            (5.0, 0.004, 1.0),
        ] {
            let target: Vec<[f64; 3]> = (0..2000)
                .map(|k| {
                    let s = (k as f64 - 100.0).max(0.0) * t;
                    [50.0 * s, -20.0 * s, 5.0 * s * s]
                })
                .collect();
            let drive = Drive {
                kp_per_s: kp,
                feedforward: ff,
                order: DriveOrder::First,
            };
            let inverse = first_order_inverse(&target, t, &drive).unwrap();
            let error = max_error_mm(&target, &simulate_actual(&inverse, t, &drive));
            assert!(error < 1e-9, "Kp {kp} T {t} ff {ff}: {error}");
            let p = precompensate(&target, t, &drive, 1e-3, 20);
            assert!(p.error_before_mm > 0.01 || ff == 1.0, "{p:?}");
            // With full feed-forward the lag follows piecewise-linear commands exactly.
            let needed = usize::from(p.error_before_mm >= 1e-3);
            assert!(
                p.error_after_mm < 1e-9 && p.iterations == needed,
                "{:?}",
                p.history
            );
        }
        let second = Drive {
            order: DriveOrder::Second {
                zeta: 0.7,
                omega_n_rad_s: 200.0,
            },
            ..Drive::first_order(30.0)
        };
        assert!(first_order_inverse(&[[0.0; 3]; 3], 0.001, &second).is_none());
    }
}
