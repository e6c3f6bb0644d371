//! The planner's queue as moves are added (tp.c's `tpAddLine`,
//! `tpAddCircle`, `tpHandleBlendArc`, `tpSetupTangent`, `tpRunOptimization`;
//! MODEL.md §6.4).

use super::blend;
use super::tc::{v_peak, Shape, Tc, TermCond, BLEND_DIST_FRACTION};
use super::LinuxCncIni as Settings;
use nalgebra::Point3;
use std::collections::VecDeque;

/// `TP_MIN_SEGMENT_CYCLES`.
const MIN_SEGMENT_CYCLES: f64 = 1.02;
/// `TP_OPTIMIZATION_CUTOFF`.
const OPTIMIZATION_CUTOFF: usize = 4;

/// The trajectory planner (`TP_STRUCT`): its queue, its modes and where it
/// stands.
pub(super) struct Tp<'a> {
    pub settings: &'a Settings,
    pub queue: VecDeque<Tc>,
    pub term_cond: TermCond,
    pub tolerance: f64,
    /// Commanded position, mm.
    pub current_pos: Point3<f64>,
}

impl<'a> Tp<'a> {
    pub fn new(settings: &'a Settings, start: Point3<f64>) -> Tp<'a> {
        Tp {
            settings,
            queue: VecDeque::new(),
            term_cond: TermCond::Parabolic,
            tolerance: 0.0,
            current_pos: start,
        }
    }

    /// `tpGetMaxTargetVel`: within the feed override and the trajectory's
    /// velocity limit.
    pub fn max_target_vel(&self, tc: &Tc) -> f64 {
        let mut scale = self.settings.max_feed_scale;
        if tc.is_blending {
            scale = scale.min(1.0);
        }
        tc.max_target_vel(scale)
            .min(self.settings.max_linear_vel_mm_s)
    }

    /// `tpAddLine` / `tpAddCircle`: a new move, blended with the last one
    /// queued as its mode asks, then the queue's final speeds optimised.
    pub fn add(&mut self, mut tc: Tc) {
        tc.term_cond = self.term_cond;
        tc.tolerance = self.tolerance;
        // tcClampVelocityByLength.
        tc.maxvel = tc.maxvel.min(tc.target / tc.cycle_time);
        if let Some(prev) = self.queue.back_mut() {
            // handleModeChange: no blend between rapid and feed.
            if prev.traverse != tc.traverse {
                set_term_cond(prev, Some(&mut tc), TermCond::Stop);
            }
        }
        // tpAddLine holds the last move's slot across the blend: a consumed
        // move's slot then holds the blend arc, already finalised.
        let last = self.queue.len().checked_sub(1);
        if self.settings.arc_blend_enable {
            self.handle_blend_arc(&mut tc);
        }
        if let Some(k) = last {
            if let Some(prev) = self.queue.get_mut(k) {
                finalize_length(prev);
            }
        }
        self.queue.push_back(tc);
        self.run_optimization();
    }

    /// `tpHandleBlendArc`.
    fn handle_blend_arc(&mut self, tc: &mut Tc) {
        let Some(prev) = self.queue.back() else {
            return;
        };
        if prev.progress > prev.target / 2.0 {
            return;
        }
        match self.setup_tangent(tc) {
            Tangent::Fail | Tangent::Ok => return,
            Tangent::NoAction => {}
        }
        let n = self.queue.len();
        let prev = &self.queue[n - 1];
        let can = prev.term_cond == TermCond::Parabolic && !tc.finalized && !prev.finalized;
        let mixed = if !can {
            None
        } else if prev.is_circle() && tc.is_line() {
            Some((blend::arc_line(self, prev, tc), true))
        } else if prev.is_line() && tc.is_circle() {
            Some((blend::line_arc(self, prev, tc), false))
        } else {
            None
        };
        if can && prev.is_circle() && tc.is_circle() {
            let made = blend::arc_arc(self, prev, tc);
            let prev = &mut self.queue[n - 1];
            let Some(made) = made else {
                blend::choose_best(self.settings, prev, tc, None);
                return;
            };
            if blend::choose_best(self.settings, prev, tc, Some(made.tc.maxvel)) != blend::Best::Arc
            {
                blend::choose_best(self.settings, prev, tc, None);
                return;
            }
            super::tc::trim_circle_end(prev, made.trim1_rad);
            super::tc::trim_circle_start(tc, made.trim2_rad);
            set_term_cond(prev, Some(tc), TermCond::Tangent);
            self.queue.push_back(made.tc);
            return;
        }
        if let Some((made, arc_first)) = mixed {
            let prev = &mut self.queue[n - 1];
            let Some(made) = made else {
                blend::choose_best(self.settings, prev, tc, None);
                return;
            };
            if blend::choose_best(self.settings, prev, tc, Some(made.tc.maxvel)) != blend::Best::Arc
            {
                blend::choose_best(self.settings, prev, tc, None);
                return;
            }
            if arc_first {
                super::tc::trim_circle_end(prev, made.trim_rad);
                let start = tc.start() + tc.start_tangent() * made.trim_mm;
                blend::shorten_start(tc, start);
                set_term_cond(prev, Some(tc), TermCond::Tangent);
            } else {
                if made.consume {
                    self.queue.pop_back();
                } else {
                    let end = prev.end() - prev.end_tangent() * made.trim_mm;
                    blend::shorten_end(prev, end);
                    set_term_cond(prev, Some(tc), TermCond::Tangent);
                }
                super::tc::trim_circle_start(tc, made.trim_rad);
                set_term_cond_next(tc, TermCond::Tangent);
            }
            self.queue.push_back(made.tc);
            return;
        }
        let arc = if can && prev.is_line() && tc.is_line() {
            blend::line_line(self, prev, tc)
        } else {
            None
        };
        let prev = &mut self.queue[n - 1];
        let Some(made) = arc else {
            blend::choose_best(self.settings, prev, tc, None);
            return;
        };
        if blend::choose_best(self.settings, prev, tc, Some(made.tc.maxvel)) != blend::Best::Arc {
            // tpCreateLineLineBlend refused its arc: tpHandleBlendArc chooses again.
            blend::choose_best(self.settings, prev, tc, None);
            return;
        }
        if made.consume {
            self.queue.pop_back();
        } else {
            blend::shorten_end(prev, made.arc_start);
            set_term_cond(prev, None, TermCond::Tangent);
        }
        blend::shorten_start(tc, made.arc_end);
        set_term_cond_next(tc, TermCond::Tangent);
        self.queue.push_back(made.tc);
    }

    /// `tpSetupTangent`: a corner within the kink ratio is passed as tangent.
    fn setup_tangent(&mut self, tc: &mut Tc) -> Tangent {
        let s = self.settings;
        let cycle = tc.cycle_time;
        let Some(prev) = self.queue.back_mut() else {
            return Tangent::Fail;
        };
        if s.arc_blend_opt_depth < 2 || prev.term_cond == TermCond::Stop {
            return Tangent::Fail;
        }
        let prev_tan = prev.end_tangent();
        let this_tan = tc.start_tangent();
        let sharp = (std::f64::consts::PI * 2.0 / 180.0).powi(2);
        if (prev_tan + this_tan).norm_squared() < sharp {
            set_term_cond(prev, Some(tc), TermCond::Stop);
            return Tangent::Fail;
        }
        let v_max = prev
            .max_target_vel(s.max_feed_scale)
            .min(tc.max_target_vel(s.max_feed_scale));
        let a_inst = v_max / cycle + tc.maxaccel;
        let acc_diff = this_tan * a_inst - prev_tan * a_inst;
        let mut acc_scale_max: f64 = (0..3)
            .map(|i| {
                if s.axis_max_acc_mm_s2[i] != 0.0 {
                    (acc_diff[i] / s.axis_max_acc_mm_s2[i]).abs()
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        if prev.is_circle() || tc.is_circle() {
            acc_scale_max /= super::tc::ACC_RATIO_TANGENTIAL;
        }
        // tpGetTangentKinkRatio: within 0.001 and 0.7071 (as written in tp.c).
        #[allow(clippy::approx_constant)]
        let kink_ratio = s.arc_blend_kink_ratio.clamp(0.001, 0.7071);
        if acc_scale_max < kink_ratio {
            set_term_cond(prev, Some(tc), TermCond::Tangent);
            set_kink(prev, tc, v_max, acc_scale_max);
            Tangent::Ok
        } else {
            set_kink(prev, tc, v_max * kink_ratio / acc_scale_max, kink_ratio);
            Tangent::NoAction
        }
    }

    /// `tpRunOptimization`: the "rising tide" pass from the queue's end back
    /// over at most `ARC_BLEND_OPTIMIZATION_DEPTH` moves.
    fn run_optimization(&mut self) {
        let len = self.queue.len();
        let mut hit_peaks = 0;
        let mut hit_non_tangent = false;
        for x in 1..self.settings.arc_blend_opt_depth + 2 {
            if x >= len {
                return;
            }
            let ind = len - x;
            let (left, right) = self.queue.make_contiguous().split_at_mut(ind);
            let (tc, prev) = (&mut right[0], &mut left[ind - 1]);
            if prev.term_cond != TermCond::Tangent {
                if hit_non_tangent {
                    return;
                }
                hit_non_tangent = true;
                continue;
            }
            if prev.progress / prev.target >= BLEND_DIST_FRACTION / 2.0 {
                return;
            }
            if prev.splitting || prev.blending_next {
                return;
            }
            if !tc.finalized {
                // tpCalculateOptimizationInitialVel.
                let triangle = v_peak(tc.tangential_max_accel(), tc.target);
                let mut scale = self.settings.max_feed_scale;
                if tc.is_blending {
                    scale = scale.min(1.0);
                }
                let max_vel = tc
                    .max_target_vel(scale)
                    .min(self.settings.max_linear_vel_mm_s);
                prev.finalvel = prev.maxvel.min(triangle.min(max_vel));
                if prev.kink_vel >= 0.0 && prev.term_cond == TermCond::Tangent {
                    prev.finalvel = prev.finalvel.min(prev.kink_vel);
                }
                tc.finalvel = 0.0;
            } else {
                // tpComputeOptimalVelocity.
                let acc_this = tc.tangential_max_accel();
                let mut vs_back = (tc.finalvel.powi(2) + 2.0 * acc_this * tc.target).sqrt();
                let mut vf_limit_prev = prev.maxvel;
                if prev.kink_vel >= 0.0 && prev.term_cond == TermCond::Tangent {
                    vf_limit_prev = vf_limit_prev.min(prev.kink_vel);
                }
                let vf_limit = tc.maxvel.min(vf_limit_prev);
                if vs_back >= vf_limit {
                    vs_back = vf_limit;
                    prev.at_max = true;
                }
                prev.finalvel = vs_back;
                let sample_maxvel = tc.target / (tc.cycle_time * MIN_SEGMENT_CYCLES);
                tc.maxvel = tc.maxvel.min(sample_maxvel);
            }
            if tc.at_max {
                hit_peaks += 1;
            }
            if hit_peaks > OPTIMIZATION_CUTOFF {
                return;
            }
        }
    }
}

/// What `tpSetupTangent` found.
enum Tangent {
    Fail,
    Ok,
    NoAction,
}

/// `tcSetTermCond(prev, next, cond)`.
pub(super) fn set_term_cond(prev: &mut Tc, next: Option<&mut Tc>, cond: TermCond) {
    if let Some(next) = next {
        set_term_cond_next(next, cond);
    }
    prev.term_cond = cond;
}

/// `tcSetTermCond`'s effect on the following move.
pub(super) fn set_term_cond_next(next: &mut Tc, cond: TermCond) {
    next.blend_prev = cond == TermCond::Parabolic;
}

/// `tcSetKinkProperties`.
pub(super) fn set_kink(prev: &mut Tc, tc: &mut Tc, kink_vel: f64, reduce: f64) {
    prev.kink_vel = kink_vel;
    prev.kink_accel_reduce = reduce.max(prev.kink_accel_reduce);
    tc.kink_accel_reduce_prev = reduce.max(tc.kink_accel_reduce_prev);
}

/// `tcRemoveKinkProperties`.
pub(super) fn remove_kink(prev: &mut Tc, tc: &mut Tc) {
    prev.kink_vel = -1.0;
    prev.kink_accel_reduce = 0.0;
    tc.kink_accel_reduce_prev = 0.0;
}

/// `tcFinalizeLength`: the move's length will not change any more.
pub(super) fn finalize_length(tc: &mut Tc) {
    if tc.finalized {
        return;
    }
    tc.maxvel = tc.maxvel.min(tc.target / tc.cycle_time);
    // tcUpdateCircleAccRatio / pmCircleActualMaxVel.
    if let Shape::Circle {
        effective_radius_mm,
        ..
    } = tc.shape
    {
        let a_max = tc.overall_max_accel();
        let a_n_cutoff = super::tc::acc_ratio_normal() * a_max;
        let a_n_vmax = tc.maxvel.powi(2) / effective_radius_mm.max(f64::EPSILON);
        if a_n_vmax > a_n_cutoff {
            tc.maxvel = (a_n_cutoff * effective_radius_mm).sqrt();
            tc.acc_ratio_tan = super::tc::ACC_RATIO_TANGENTIAL;
        } else {
            tc.acc_ratio_tan = (1.0 - (a_n_vmax / a_max).powi(2)).sqrt();
        }
    }
    tc.finalized = true;
}
