//! Each planned block run as the trapezoid grbl's stepper.c executes between its entry and
//! exit speeds (`st_prep_buffer`'s ramp types), and the servo samples of those trapezoids.

use nalgebra::Point3;

use super::PlannedBlock;
use crate::{ScheduleError, ServoSample, MAX_SAMPLES};

/// A block's speed over time: accelerate from `v0` to `vp` in `t1`, hold `vp` for `t2`,
/// decelerate to `v2` in `t3` (mm/s, s); a stop is a `t2` at speed 0.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ramp {
    v0: f64,
    vp: f64,
    v2: f64,
    a: f64,
    t1: f64,
    t2: f64,
    t3: f64,
}

impl Ramp {
    /// stepper.c's profile of a block of `length` mm at acceleration `a` (mm/s²) from
    /// `v0` to `v2` under `vn` (mm/s): with d the distance left, the acceleration line
    /// meets the deceleration line at d = (L + (v0² − v2²)/2a)/2 (`intersect_distance`);
    /// past the block's start it decelerates only, before its end it accelerates only,
    /// else it is a triangle, or a trapezoid where deceleration from vn starts before that
    /// point (MODEL.md eq. 6.4.5).
    fn of(length: f64, a: f64, v0: f64, v2: f64, vn: f64) -> Ramp {
        let inv_2a = 0.5 / a;
        let intersect = 0.5 * (length + inv_2a * (v0 * v0 - v2 * v2));
        let ramp = |v0: f64, vp: f64, v2: f64, t2: f64| Ramp {
            v0,
            vp,
            v2,
            a,
            t1: (vp - v0).max(0.0) / a,
            t2,
            t3: (vp - v2).max(0.0) / a,
        };
        if v0 > vn {
            // Only under a feed override in grbl: decelerate to vn at once.
            let down = inv_2a * (v0 * v0 - vn * vn);
            let decel = inv_2a * (vn * vn - v2 * v2);
            let cruise = (length - down - decel).max(0.0);
            let t0 = (v0 - vn) / a;
            let r = ramp(vn, vn, v2, cruise / vn);
            return Ramp { v0, t1: t0, ..r };
        }
        if intersect <= 0.0 {
            // Acceleration only.
            let v_end = (v0 * v0 + 2.0 * a * length).sqrt();
            return ramp(v0, v_end, v_end, 0.0);
        }
        if intersect >= length {
            // Deceleration only.
            let v_end = (v0 * v0 - 2.0 * a * length).max(0.0).sqrt();
            return ramp(v0, v0, v_end, 0.0);
        }
        let decelerate_after = inv_2a * (vn * vn - v2 * v2);
        if decelerate_after < intersect {
            let accel = inv_2a * (vn * vn - v0 * v0);
            let cruise = (length - accel - decelerate_after).max(0.0);
            ramp(v0, vn, v2, cruise / vn)
        } else {
            let vp = (2.0 * a * intersect + v2 * v2).sqrt();
            ramp(v0, vp, v2, 0.0)
        }
    }

    fn duration_s(&self) -> f64 {
        self.t1 + self.t2 + self.t3
    }

    /// Distance (mm) and speed (mm/s) at `t` s into the ramp.
    fn at(&self, t: f64) -> (f64, f64) {
        let d1 = 0.5 * (self.v0 + self.vp) * self.t1;
        let d2 = self.vp * self.t2;
        if t <= self.t1 {
            // v0 > vp only on an override's initial deceleration.
            let a = if self.vp >= self.v0 { self.a } else { -self.a };
            return (self.v0 * t + 0.5 * a * t * t, self.v0 + a * t);
        }
        let t = t - self.t1;
        if t <= self.t2 {
            return (d1 + self.vp * t, self.vp);
        }
        let t = (t - self.t2).min(self.t3);
        (
            d1 + d2 + self.vp * t - 0.5 * self.a * t * t,
            self.vp - self.a * t,
        )
    }
}

/// The time, s, stepper.c takes for a block of `length_mm` at `accel_mm_s2` from
/// `entry_mm_min` to `exit_mm_min` with nominal speed `nominal_mm_min` (closed form of the
/// trapezoid or triangle; MODEL.md eq. 6.4.5).
pub fn trapezoid_time_s(
    length_mm: f64,
    accel_mm_s2: f64,
    entry_mm_min: f64,
    exit_mm_min: f64,
    nominal_mm_min: f64,
) -> f64 {
    Ramp::of(
        length_mm,
        accel_mm_s2,
        entry_mm_min / 60.0,
        exit_mm_min / 60.0,
        nominal_mm_min / 60.0,
    )
    .duration_s()
}

fn ramp_of(b: &PlannedBlock) -> Ramp {
    if b.length_mm == 0.0 {
        return Ramp {
            v0: 0.0,
            vp: 0.0,
            v2: 0.0,
            a: 1.0,
            t1: 0.0,
            t2: b.dwell_s,
            t3: 0.0,
        };
    }
    Ramp::of(
        b.length_mm,
        b.accel_mm_s2,
        b.entry_mm_min / 60.0,
        b.exit_mm_min / 60.0,
        b.nominal_mm_min / 60.0,
    )
}

/// The cycle time, s, of the planned blocks: their trapezoids and dwells one after another.
pub fn cycle_time_s(planned: &[PlannedBlock]) -> f64 {
    planned.iter().map(|b| ramp_of(b).duration_s()).sum()
}

/// Servo samples every `period_ms` from t = 0 and one at the end, along the planned blocks
/// (positions on each block's line between its start and target, mm; `s_mm` the distance
/// run along the blocks).
pub(super) fn sample(
    path: &nc::Path,
    blocks: &[super::Block],
    planned: &[PlannedBlock],
    period_ms: f64,
) -> Result<Vec<ServoSample>, ScheduleError> {
    if !(period_ms.is_finite() && period_ms > 0.0) {
        return Err(ScheduleError::InvalidMachine {
            name: "period_ms",
            value: period_ms,
        });
    }
    let ramps: Vec<Ramp> = planned.iter().map(ramp_of).collect();
    let total_s: f64 = ramps.iter().map(Ramp::duration_s).sum();
    let period_s = period_ms * 1e-3;
    let count = (total_s / period_s).ceil() + 1.0;
    if count > MAX_SAMPLES as f64 {
        return Err(ScheduleError::TooManySamples {
            needed: count,
            limit: MAX_SAMPLES,
            cycle_time_s: total_s,
            period_ms,
        });
    }
    let start = path.segments[0].start;
    let mut samples = Vec::with_capacity(count as usize);
    let (mut k, mut t_start, mut s_start) = (0, 0.0, 0.0);
    let mut at = |t_s: f64| {
        while k + 1 < ramps.len() && t_s >= t_start + ramps[k].duration_s() {
            t_start += ramps[k].duration_s();
            s_start += planned[k].length_mm;
            k += 1;
        }
        let Some(b) = planned.get(k) else {
            return ServoSample {
                t_s,
                pos: start,
                feed_mm_min: 0.0,
                s_mm: 0.0,
                segment: 0,
            };
        };
        let (s, v) = ramps[k].at(t_s - t_start);
        let target = blocks[b.block].target_mm;
        let u = if b.length_mm > 0.0 {
            (s / b.length_mm).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let pos = Point3::from(std::array::from_fn(|i| {
            b.start_mm[i] + (target[i] - b.start_mm[i]) * u
        }));
        ServoSample {
            t_s,
            pos,
            feed_mm_min: v.max(0.0) * 60.0,
            s_mm: s_start + s.min(b.length_mm),
            segment: blocks[b.block].segment,
        }
    };
    for j in 0..count as usize {
        let t_s = j as f64 * period_s;
        if t_s >= total_s {
            break;
        }
        samples.push(at(t_s));
    }
    samples.push(at(total_s));
    Ok(samples)
}
