//! S4's pre-compensation of the command for the drive's motion error.

use serde::{Deserialize, Serialize};

use crate::drive::{simulate_actual, Drive};

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

/// S4's loop: simulate the drive on the command, add the error `target − actual` to the
/// command, repeat until the largest sample-wise error is below `threshold_mm` or after
/// `max_iterations` corrections. Starts from `command = target`.
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
}
