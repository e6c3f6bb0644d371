//! One servo period of LinuxCNC's trajectory planner (tp.c's `tpRunCycle`
//! and what it calls): the head move's trapezoidal (or ramped) speed update,
//! the split cycle where a move ends inside the period, parabolic blends;
//! MODEL.md §6.4.

use super::blend::parabolic_velocity;
use super::queue::Tp;
use super::tc::{Tc, TermCond, POS_EPSILON, TIME_EPSILON, VEL_EPSILON};

/// What the planner's speed was in a period (`emcmotStatus->current_vel`).
pub(super) struct Status {
    pub vel_mm_s: f64,
    /// Program segment the planner reports.
    pub segment: usize,
}

impl Tp<'_> {
    /// `tpGetRealTargetVel` at feed override 1.
    fn real_target_vel(&self, tc: &Tc) -> f64 {
        tc.reqvel.min(self.max_target_vel(tc))
    }

    /// `tpGetRealFinalVel`: 0 unless the move ends tangent.
    fn real_final_vel(&self, tc: &Tc, next: Option<&Tc>) -> f64 {
        if tc.term_cond != TermCond::Tangent {
            return 0.0;
        }
        let next_vel = next.map_or(0.0, |n| self.real_target_vel(n));
        tc.finalvel.min(self.real_target_vel(tc).min(next_vel))
    }

    /// `tpRunCycle`: one period; `None` once the queue is empty.
    pub fn run_cycle(&mut self) -> Option<Status> {
        if self.queue.is_empty() {
            return None;
        }
        self.activate();
        self.queue[0].is_blending = false;
        if let Some(n) = self.queue.get_mut(1) {
            n.is_blending = false;
        }
        let status = if self.queue[0].splitting {
            self.split_cycle()
        } else {
            self.regular_cycle()
        };
        if self.queue[0].remove {
            self.queue.pop_front();
        }
        Some(status)
    }

    /// `tpActivateSegment`: short tangent moves ramp their speed instead of
    /// the trapezoid (`ARC_BLEND_RAMP_FREQ`).
    fn activate(&mut self) {
        let cutoff_time = 1.0 / self.settings.arc_blend_ramp_freq_hz.max(TIME_EPSILON);
        let tc = &self.queue[0];
        if tc.active {
            return;
        }
        let length = tc.target - tc.progress;
        let segment_time =
            2.0 * length / (tc.currentvel + tc.finalvel.min(self.real_target_vel(tc)));
        let ramp = segment_time < cutoff_time
            && !tc.traverse
            && tc.term_cond == TermCond::Tangent
            && length != 0.0;
        let tc = &mut self.queue[0];
        tc.ramp |= ramp;
        tc.active = true;
        tc.blending_next = false;
        tc.on_final_decel = false;
    }

    /// `tpHandleRegularCycle`.
    fn regular_cycle(&mut self) -> Status {
        let period = self.settings.period_s;
        if self.queue[0].remove {
            return self.status(0);
        }
        self.queue[0].cycle_time = period;
        self.update_cycle(0);
        let this_vel = self.real_target_vel(&self.queue[0]);
        let Some(next) = self.queue.get(1) else {
            self.queue[0].blend_vel = 0.0;
            return self.status(0);
        };
        let next_vel = self.real_target_vel(next);
        let (v_this, v_next, _) = parabolic_velocity(&self.queue[0], next, this_vel, next_vel);
        self.queue[0].blend_vel = v_this;
        self.queue[1].blend_vel = v_next;
        let tc = &mut self.queue[0];
        // tcIsBlending.
        let starts = tc.term_cond == TermCond::Parabolic
            && tc.on_final_decel
            && tc.currentvel < tc.blend_vel;
        tc.blending_next |= starts;
        if !tc.blending_next {
            return self.status(0);
        }
        // tpDoParabolicBlending / tpUpdateBlend: the next move starts while
        // this one slows down (its target speed is its own when it is not
        // synchronised, so only its state changes here).
        self.queue[1].is_blending = true;
        self.update_cycle(1);
        let (a, b) = (&self.queue[0], &self.queue[1]);
        Status {
            vel_mm_s: a.currentvel + b.currentvel,
            segment: if a.currentvel > b.currentvel {
                a.segment_at(a.progress)
            } else {
                b.segment_at(b.progress)
            },
        }
    }

    /// `tpHandleSplitCycle`: the head move ends within this period; the next
    /// one runs the rest of it.
    fn split_cycle(&mut self) -> Status {
        let period = self.settings.period_s;
        if self.queue[0].remove {
            return self.status(0);
        }
        let tc = &mut self.queue[0];
        let before = tc.point(tc.progress);
        tc.progress = tc.target;
        let after = tc.point(tc.progress);
        tc.remove = true;
        self.current_pos += after - before;
        if self.queue.len() < 2 {
            return self.status(0);
        }
        let (cycle, term_vel, term) = {
            let tc = &self.queue[0];
            (tc.cycle_time, tc.term_vel, tc.term_cond)
        };
        if term == TermCond::Tangent {
            let next = &mut self.queue[1];
            next.cycle_time = period - cycle;
            next.currentvel = term_vel;
        }
        self.update_cycle(1);
        let next_cycle = self.queue[1].cycle_time;
        if cycle > next_cycle && term == TermCond::Tangent {
            self.status(0)
        } else {
            self.status(1)
        }
    }

    fn status(&self, k: usize) -> Status {
        let tc = &self.queue[k];
        Status {
            vel_mm_s: tc.currentvel,
            segment: tc.segment_at(tc.progress),
        }
    }

    /// `tpUpdateCycle` of queue item `k`, with item `k + 1` as its next.
    fn update_cycle(&mut self, k: usize) {
        let (acc, vel_desired) = {
            let tc = &self.queue[k];
            let next = self.queue.get(k + 1);
            let ramp = if tc.ramp && tc.term_cond == TermCond::Tangent {
                self.ramp_accel(tc, next)
            } else {
                None
            };
            ramp.unwrap_or_else(|| self.trapezoidal_accel(tc, next))
        };
        let tc = &mut self.queue[k];
        let before = tc.point(tc.progress);
        if !tc.blending_next {
            tc.vel_at_blend_start = tc.currentvel;
        }
        // tcUpdateDistFromAccel.
        let v_next = tc.currentvel + acc * tc.cycle_time;
        if v_next < 0.0 {
            if tc.target - tc.progress < tc.currentvel * tc.cycle_time {
                tc.progress = tc.target;
            }
            tc.currentvel = 0.0;
        } else {
            let displacement = (v_next + tc.currentvel) * 0.5 * tc.cycle_time;
            tc.progress = (tc.progress + displacement).clamp(0.0, tc.target);
            tc.currentvel = v_next;
        }
        tc.on_final_decel = (vel_desired - tc.currentvel).abs() < VEL_EPSILON && acc < 0.0;
        self.check_end_condition(k);
        let tc = &self.queue[k];
        self.current_pos += tc.point(tc.progress) - before;
    }

    /// `tpCalculateTrapezoidalAccel`: the speed that can still stop (or
    /// reach the final speed) at the end, within the target speed.
    fn trapezoidal_accel(&self, tc: &Tc, next: Option<&Tc>) -> (f64, f64) {
        let target_vel = self.real_target_vel(tc);
        let final_vel = self.real_final_vel(tc, next);
        let dx = tc.target - tc.progress;
        let maxaccel = tc.tangential_max_accel();
        let term1 = final_vel * final_vel;
        let term2 = maxaccel * (2.0 * dx - tc.currentvel * tc.cycle_time);
        let half_adt = maxaccel * tc.cycle_time * 0.5;
        let term3 = half_adt * half_adt;
        let discr = term1 + term2 + term3;
        let mut maxnewvel = -half_adt;
        if discr > term3 {
            maxnewvel += discr.sqrt();
        }
        let newvel = saturate(maxnewvel, target_vel);
        let dt = tc.cycle_time.max(TIME_EPSILON);
        let acc = saturate((newvel - tc.currentvel) / dt, maxaccel);
        (acc, maxnewvel)
    }

    /// `tpCalculateRampAccel`: a constant acceleration to the final speed
    /// over the rest of the move; `None` where the final speed is 0.
    fn ramp_accel(&self, tc: &Tc, next: Option<&Tc>) -> Option<(f64, f64)> {
        let dx = tc.target - tc.progress;
        let vel_final = self.real_final_vel(tc, next);
        if vel_final < VEL_EPSILON {
            return None;
        }
        let vel_avg = (tc.currentvel + vel_final) / 2.0;
        let dt = if vel_avg > VEL_EPSILON {
            (dx / vel_avg).max(1e-16)
        } else {
            1e-16
        };
        let acc_final = (vel_final - tc.currentvel) / dt;
        Some((saturate(acc_final, tc.tangential_max_accel()), vel_final))
    }

    /// `tpCheckEndCondition`: does the move end within the next period?
    /// Then it splits that period with the next move.
    fn check_end_condition(&mut self, k: usize) {
        let period = self.settings.period_s;
        let v_f0 = {
            let tc = &self.queue[k];
            self.real_final_vel(tc, self.queue.get(k + 1))
        };
        let tc = &mut self.queue[k];
        tc.cycle_time = period;
        let dx = tc.target - tc.progress;
        if dx <= POS_EPSILON {
            tc.progress = tc.target;
            set_split(tc, 0.0, tc.currentvel);
            if matches!(tc.term_cond, TermCond::Stop | TermCond::Exact) {
                tc.remove = true;
            }
            return;
        }
        if matches!(tc.term_cond, TermCond::Stop | TermCond::Exact) {
            return;
        }
        let mut v_f = v_f0;
        let v_avg = (tc.currentvel + v_f) / 2.0;
        let mut dt = TIME_EPSILON / 2.0;
        if v_avg > VEL_EPSILON {
            dt = dt.max(dx / v_avg);
        } else if dx > v_avg * period && dx > POS_EPSILON {
            return;
        }
        let a_f = (v_f - tc.currentvel) / dt;
        let a_max = tc.tangential_max_accel();
        let a = saturate(a_f, a_max);
        if a != a_f {
            let disc = (tc.currentvel / a).powi(2) + 2.0 / a * dx;
            if disc < 0.0 {
                return;
            }
            dt = if disc < TIME_EPSILON * TIME_EPSILON {
                -tc.currentvel / a
            } else if a > 0.0 {
                -tc.currentvel / a + disc.sqrt()
            } else {
                -tc.currentvel / a - disc.sqrt()
            };
            v_f = tc.currentvel + dt * a;
        }
        if dt < TIME_EPSILON {
            tc.progress = tc.target;
            set_split(tc, 0.0, v_f);
        } else if dt < period {
            set_split(tc, dt, v_f);
        }
    }
}

/// `tcSetSplitCycle`.
fn set_split(tc: &mut Tc, split_time: f64, v_f: f64) {
    if tc.splitting && split_time > 0.0 {
        return;
    }
    tc.splitting = true;
    tc.cycle_time = split_time;
    tc.term_vel = v_f;
}

/// `saturate`: `x` within ±`max` (no panic on a negative or NaN `max`).
fn saturate(x: f64, max: f64) -> f64 {
    if x > max {
        max
    } else if x < -max {
        -max
    } else {
        x
    }
}
