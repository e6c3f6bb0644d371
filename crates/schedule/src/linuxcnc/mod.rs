//! LinuxCNC's trajectory planner (2.9, `src/emc/tp/`), transcribed: how a
//! LinuxCNC control runs a program, servo period by servo period
//! (MODEL.md §6.4, "Controllers: LinuxCNC").
//!
//! * [`canon`]: the task's moves from the path (emccanon.cc): per-move speed
//!   and acceleration within the axes' limits, path control, the naive CAM
//!   detector, waits for motion to end.
//! * [`queue`]: the planner's queue as moves arrive: tangency, blend arcs or
//!   parabolic blends ([`blend`]), the backward "rising tide" optimisation.
//! * [`cycle`]: one servo period: trapezoidal or ramped speed, split cycles.
//! * [`ini`]: the settings from a LinuxCNC INI file.

mod blend;
mod canon;
mod cycle;
pub mod ini;
mod queue;
mod tc;

use crate::{Machine, ScheduleError, ServoSample};
use nalgebra::Point3;

/// What LinuxCNC's planner reads from the machine's INI file (or dexcut's
/// machine stands in for: [`LinuxCncIni::from_machine`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinuxCncIni {
    /// `[EMCMOT] SERVO_PERIOD`, s.
    pub period_s: f64,
    /// `[AXIS_X|Y|Z] MAX_VELOCITY`, mm/s.
    pub axis_max_vel_mm_s: [f64; 3],
    /// `[AXIS_X|Y|Z] MAX_ACCELERATION`, mm/s².
    pub axis_max_acc_mm_s2: [f64; 3],
    /// `[TRAJ] MAX_LINEAR_VELOCITY`: the path speed's limit, mm/s.
    pub max_linear_vel_mm_s: f64,
    /// `[DISPLAY] MAX_FEED_OVERRIDE` (the planner plans for it; runs are at
    /// override 1).
    pub max_feed_scale: f64,
    /// The blend tolerance before the program sets any path control, mm; 0
    /// is G64 without P (no limit but the moves' lengths), which is how the
    /// recorded LinuxCNC 2.9 runs a program that sets none (emccanon.cc's
    /// 0.001 in is not what its corners show: MODEL.md §6.4). Set by
    /// `[machine] blend_tolerance_mm`, or an `[RS274NGC]
    /// RS274NGC_STARTUP_CODE` with G64 P. No naive CAM detector at start-up.
    pub startup_tolerance_mm: f64,
    /// `[TRAJ] ARC_BLEND_ENABLE` (default on).
    pub arc_blend_enable: bool,
    /// `[TRAJ] ARC_BLEND_OPTIMIZATION_DEPTH`: moves the look-ahead walks back
    /// over (default 50).
    pub arc_blend_opt_depth: usize,
    /// `[TRAJ] ARC_BLEND_GAP_CYCLES`: a line shorter than this many periods
    /// at the blend speed is taken whole into the blend arc (default 4).
    pub arc_blend_gap_cycles: f64,
    /// `[TRAJ] ARC_BLEND_RAMP_FREQ`, Hz: tangent moves shorter than one
    /// period of it ramp their speed linearly (default 100).
    pub arc_blend_ramp_freq_hz: f64,
    /// `[TRAJ] ARC_BLEND_KINK_RATIO`: corners needing less than this share of
    /// the acceleration are passed as tangent (default 0.1).
    pub arc_blend_kink_ratio: f64,
}

/// LinuxCNC's start-up blend tolerance, mm: G64 without P, as measured.
pub const STARTUP_TOLERANCE_MM: f64 = 0.0;

impl LinuxCncIni {
    /// Settings from dexcut's machine: its period and per-axis
    /// accelerations, every axis and the path at the rapid rate, LinuxCNC's
    /// defaults for the rest; `blend_tolerance_mm` is the start-up
    /// tolerance ([`STARTUP_TOLERANCE_MM`] when `None`).
    pub fn from_machine(machine: &Machine, blend_tolerance_mm: Option<f64>) -> LinuxCncIni {
        let rapid_mm_s = machine.rapid_mm_min / 60.0;
        LinuxCncIni {
            period_s: machine.period_ms / 1000.0,
            axis_max_vel_mm_s: [rapid_mm_s; 3],
            axis_max_acc_mm_s2: machine.accel_mm_s2,
            max_linear_vel_mm_s: rapid_mm_s,
            max_feed_scale: 1.0,
            startup_tolerance_mm: blend_tolerance_mm.unwrap_or(STARTUP_TOLERANCE_MM),
            arc_blend_enable: true,
            arc_blend_opt_depth: 50,
            arc_blend_gap_cycles: 4.0,
            arc_blend_ramp_freq_hz: 100.0,
            arc_blend_kink_ratio: 0.1,
        }
    }

    fn check(&self) -> Result<(), ScheduleError> {
        let positive = |name: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ScheduleError::InvalidMachine { name, value })
            }
        };
        positive("linuxcnc period_s", self.period_s)?;
        for i in 0..3 {
            positive("linuxcnc axis max velocity", self.axis_max_vel_mm_s[i])?;
            positive("linuxcnc axis max acceleration", self.axis_max_acc_mm_s2[i])?;
        }
        positive("linuxcnc max linear velocity", self.max_linear_vel_mm_s)?;
        positive("linuxcnc max feed scale", self.max_feed_scale)?;
        positive("linuxcnc ramp frequency", self.arc_blend_ramp_freq_hz)?;
        if !(self.startup_tolerance_mm >= 0.0) {
            return Err(ScheduleError::InvalidMachine {
                name: "blend_tolerance_mm",
                value: self.startup_tolerance_mm,
            });
        }
        Ok(())
    }
}

/// The settings of LinuxCNC's planner that the program does not set itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinuxCncSettings {
    /// The start-up blending tolerance (G64 P before the program sets any
    /// path control), mm; over the INI's. `None`: the INI's, else G64
    /// without P.
    pub blend_tolerance_mm: Option<f64>,
    /// The INI file's settings (`[machine] linuxcnc_ini`); `None`: from the
    /// machine ([`LinuxCncIni::from_machine`]).
    pub ini: Option<LinuxCncIni>,
}

impl LinuxCncSettings {
    /// The planner's settings on `machine`.
    pub fn resolve(&self, machine: &Machine) -> LinuxCncIni {
        let mut ini = self
            .ini
            .unwrap_or_else(|| LinuxCncIni::from_machine(machine, None));
        if let Some(t) = self.blend_tolerance_mm {
            ini.startup_tolerance_mm = t;
        }
        ini
    }
}

/// [`samples_with`] on `machine` with `settings` (MODEL.md §6.4).
pub fn samples(
    path: &nc::Path,
    machine: &Machine,
    settings: &LinuxCncSettings,
) -> Result<Vec<ServoSample>, ScheduleError> {
    samples_with(path, &settings.resolve(machine))
}

/// The servo samples of `path` as LinuxCNC's planner runs it: one every
/// `settings.period_s` from t = 0 at the path's start, positions on the
/// path the planner runs (blend arcs cut corners within the tolerance).
/// A sample's speed is the planner's (`motion.current-vel`, the sum of both
/// moves' speeds during a parabolic blend), `s_mm` the distance run along
/// that path, and its segment the program segment the planner's current
/// move belongs to: on a blend arc the segment the arc leaves (MODEL.md
/// §6.4); segments never decrease from sample to sample.
/// Dwells and waits hold the position for their time.
///
/// These are the planner's positions; LinuxCNC's motion module hands the
/// joints their cubic interpolation, (p[k−1] + 4·p[k] + p[k+1])/6 one period
/// later, which moves a sample by at most a·T²/6.
pub fn samples_with(
    path: &nc::Path,
    settings: &LinuxCncIni,
) -> Result<Vec<ServoSample>, ScheduleError> {
    settings.check()?;
    let Some(first) = path.segments.first() else {
        return Err(ScheduleError::EmptyPath);
    };
    let start = first.start;
    let period = settings.period_s;
    let mut out = Run {
        samples: vec![ServoSample {
            t_s: 0.0,
            pos: start,
            feed_mm_min: 0.0,
            s_mm: 0.0,
            segment: 0,
        }],
        limit: crate::MAX_SAMPLES,
        period,
    };
    let mut tp = queue::Tp::new(settings, start);
    for cmd in canon::commands(path, settings) {
        match cmd {
            canon::Cmd::Mode(cond, tolerance) => {
                tp.term_cond = cond;
                tp.tolerance = tolerance;
            }
            canon::Cmd::Move(tc) => {
                let starts = tp.queue.is_empty();
                tp.add(*tc);
                // The task hands motion the first move of a run a period
                // before the next (as the recorded runs show): it starts
                // alone, ending in the mode's blend.
                if starts {
                    if let Some(status) = tp.run_cycle() {
                        out.push(tp.current_pos, status.vel_mm_s, status.segment)?;
                    }
                }
            }
            canon::Cmd::Wait { dwell_s, segment } => {
                out.drain(&mut tp)?;
                let n = (dwell_s / period - 1e-9).ceil().max(0.0) as usize;
                for _ in 0..n {
                    out.push(tp.current_pos, 0.0, segment)?;
                }
            }
        }
    }
    out.drain(&mut tp)?;
    Ok(out.samples)
}

/// The samples as they are made.
struct Run {
    samples: Vec<ServoSample>,
    limit: usize,
    period: f64,
}

impl Run {
    fn push(
        &mut self,
        pos: Point3<f64>,
        vel_mm_s: f64,
        segment: usize,
    ) -> Result<(), ScheduleError> {
        let last = self.samples.last().copied().expect("the first sample");
        if self.samples.len() >= self.limit {
            let t = self.samples.len() as f64 * self.period;
            return Err(ScheduleError::TooManySamples {
                needed: self.samples.len() as f64 + 1.0,
                limit: self.limit,
                cycle_time_s: t,
                period_ms: self.period * 1000.0,
            });
        }
        self.samples.push(ServoSample {
            t_s: self.samples.len() as f64 * self.period,
            pos,
            feed_mm_min: vel_mm_s * 60.0,
            s_mm: last.s_mm + (pos - last.pos).norm(),
            // Never back to an earlier segment (a parabolic blend reports the
            // faster of its two moves).
            segment: (segment as u32).max(last.segment),
        });
        Ok(())
    }

    /// Runs the planner until its queue is empty.
    fn drain(&mut self, tp: &mut queue::Tp) -> Result<(), ScheduleError> {
        while let Some(status) = tp.run_cycle() {
            self.push(tp.current_pos, status.vel_mm_s, status.segment)?;
        }
        Ok(())
    }
}
