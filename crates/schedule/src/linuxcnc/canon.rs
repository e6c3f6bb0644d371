//! From the program's path to the planner's moves, as LinuxCNC's task
//! (emccanon.cc) sends them: each move's speed and acceleration within the
//! axes' limits, the path control of its block, the naive CAM detector
//! joining short collinear feed moves within G64's Q, and the points where
//! the task waits for motion to end (dwells, spindle and tool changes).

use super::tc::{Shape, Tc, TermCond};
use super::LinuxCncIni;
use nalgebra::{Point3, Vector3};
use nc::{Geometry, Motion, PathControl, Plane};

/// `CART_FUZZ`: displacements below it do not count.
const CART_FUZZ_MM: f64 = 1e-8;
/// `linkable`'s cap on the moves the naive CAM detector joins.
const MAX_CHAINED: usize = 100;

/// What the task hands to motion, in order.
pub(super) enum Cmd {
    /// `EMC_TRAJ_SET_TERM_COND`.
    Mode(TermCond, f64),
    /// A line or circle for the queue.
    Move(Box<Tc>),
    /// The task waits until motion has stopped, then `dwell_s` more
    /// (segment `segment` is charged with the wait).
    Wait { dwell_s: f64, segment: usize },
}

/// `getStraightVelocity` and `getStraightAcceleration`: the speed and
/// acceleration along `d` that keep every axis within its limit, and the
/// time the slowest axis needs at them (`tmax`).
fn straight(d: &Vector3<f64>, limit: &[f64; 3]) -> Option<(f64, f64)> {
    let mut tmax: f64 = 0.0;
    let mut dsq = 0.0;
    for i in 0..3 {
        let di = if d[i].abs() < CART_FUZZ_MM {
            0.0
        } else {
            d[i].abs()
        };
        dsq += di * di;
        if di > 0.0 {
            tmax = tmax.max(di / limit[i]);
        }
    }
    (tmax > 0.0).then(|| (dsq.sqrt() / tmax, tmax))
}

/// The commands for `path` under `settings`.
pub(super) fn commands(path: &nc::Path, settings: &LinuxCncIni) -> Vec<Cmd> {
    let mut c = Canon {
        settings,
        out: Vec::with_capacity(path.segments.len() + 8),
        end: path.segments.first().map_or(Point3::origin(), |s| s.start),
        chain: Vec::new(),
        feed_mm_s: 0.0,
        naive_cam_mm: 0.0,
        continuous: true,
        mode: None,
    };
    c.set_mode(None);
    let mut prev: Option<&nc::Segment> = None;
    for (k, seg) in path.segments.iter().enumerate() {
        let mode = path.path_control_at(k);
        if mode != c.mode {
            c.set_mode(mode);
        }
        let waits = path.motion_waits.binary_search(&k).is_ok();
        if let Some(p) = prev {
            if waits || p.tool != seg.tool || p.spindle_rpm != seg.spindle_rpm {
                c.flush();
                c.out.push(Cmd::Wait {
                    dwell_s: 0.0,
                    segment: k,
                });
            }
        }
        prev = Some(seg);
        match seg.motion {
            Motion::Dwell { seconds } => {
                c.flush();
                c.out.push(Cmd::Wait {
                    dwell_s: seconds,
                    segment: k,
                });
            }
            Motion::Rapid => {
                c.flush();
                c.line(seg.end, None, &[(seg.end, k)]);
            }
            Motion::Feed { feed_mm_min, .. } => {
                let feed = feed_mm_min / 60.0;
                if feed != c.feed_mm_s {
                    c.flush();
                    c.feed_mm_s = feed;
                }
                match seg.geometry {
                    Geometry::Line => c.see(seg.end, k),
                    Geometry::Arc { .. } => c.arc(seg, k),
                }
            }
        }
    }
    c.flush();
    c.out
}

struct Canon<'a> {
    settings: &'a LinuxCncIni,
    out: Vec<Cmd>,
    /// `canon.endPoint`: where the last move sent ends.
    end: Point3<f64>,
    /// `chained_points`: feed moves held by the naive CAM detector.
    chain: Vec<(Point3<f64>, usize)>,
    feed_mm_s: f64,
    naive_cam_mm: f64,
    continuous: bool,
    mode: Option<PathControl>,
}

impl Canon<'_> {
    /// `SET_MOTION_CONTROL_MODE` and `SET_NAIVECAM_TOLERANCE` for the
    /// program's mode (`None`: the start-up mode, G64 with LinuxCNC's
    /// default tolerance and no naive CAM detector).
    fn set_mode(&mut self, mode: Option<PathControl>) {
        self.flush();
        self.mode = mode;
        let (cond, tolerance, naive) = match mode {
            None => (TermCond::Parabolic, self.settings.startup_tolerance_mm, 0.0),
            Some(PathControl::ExactPath) => (TermCond::Exact, 0.0, self.naive_cam_mm),
            Some(PathControl::ExactStop) => (TermCond::Stop, 0.0, self.naive_cam_mm),
            Some(PathControl::Blend {
                tolerance_mm,
                naive_cam_mm,
            }) => (
                TermCond::Parabolic,
                tolerance_mm.unwrap_or(0.0),
                naive_cam_mm.or(tolerance_mm).unwrap_or(0.0),
            ),
        };
        self.continuous = cond == TermCond::Parabolic;
        self.naive_cam_mm = naive;
        self.out.push(Cmd::Mode(cond, tolerance));
    }

    /// `see_segment`: a feed line's end, joined to the chain if the naive
    /// CAM detector may (`linkable`).
    fn see(&mut self, p: Point3<f64>, segment: usize) {
        if !self.chain.is_empty() && !self.linkable(&p) {
            self.flush();
        }
        self.chain.push((p, segment));
    }

    fn linkable(&self, p: &Point3<f64>) -> bool {
        if !self.continuous || self.naive_cam_mm == 0.0 || self.chain.len() > MAX_CHAINED {
            return false;
        }
        if *p == self.end {
            return false;
        }
        let m = p - self.end;
        self.chain.iter().all(|(q, _)| {
            let t0 = (m.dot(&(q - self.end)) / m.dot(&m)).clamp(0.0, 1.0);
            (q - (self.end + m * t0)).norm() <= self.naive_cam_mm
        })
    }

    /// `flush_segments`: the chain as one line at the current feed.
    fn flush(&mut self) {
        let Some(&(end, _)) = self.chain.last() else {
            return;
        };
        let chain = std::mem::take(&mut self.chain);
        self.line(end, Some(self.feed_mm_s), &chain);
    }

    /// A line from the last end to `end` (`feed_mm_s`: `None` for a rapid),
    /// running the program segments of `pieces` (each with its end).
    fn line(&mut self, end: Point3<f64>, feed_mm_s: Option<f64>, pieces: &[(Point3<f64>, usize)]) {
        let s = self.settings;
        let d = end - self.end;
        let start = self.end;
        self.end = end;
        let (Some((vmax, _)), Some((acc, _))) = (
            straight(&d, &s.axis_max_vel_mm_s),
            straight(&d, &s.axis_max_acc_mm_s2),
        ) else {
            return;
        };
        let length = d.norm();
        if length < super::tc::POS_EPSILON {
            return;
        }
        let unit = d / length;
        let pieces = pieces
            .iter()
            .map(|(p, k)| (*k, (p - start).dot(&unit)))
            .collect::<Vec<_>>();
        let segment = pieces[0].0;
        let vel = feed_mm_s.map_or(vmax, |f| f.min(vmax));
        self.out.push(Cmd::Move(Box::new(Tc::new(
            Shape::Line {
                start,
                unit,
                pieces,
            },
            segment,
            length,
            (vel, vmax, acc),
            (TermCond::Parabolic, 0.0),
            feed_mm_s.is_none(),
            s.period_s,
        ))));
    }

    /// `ARC_FEED`: an arc within Q of its chord in XY becomes two lines for
    /// the naive CAM detector; any other is a circle whose speed and
    /// acceleration keep the axes of its plane within their limits.
    fn arc(&mut self, seg: &nc::Segment, k: usize) {
        let Geometry::Arc {
            center,
            plane,
            clockwise,
            sweep_rad,
        } = seg.geometry
        else {
            return;
        };
        let (a, b, n) = plane.axes();
        let r0 = ((seg.start[a] - center[a]).powi(2) + (seg.start[b] - center[b]).powi(2)).sqrt();
        if plane == Plane::XY && self.continuous {
            // chord_deviation: the arc from the last point of the chain.
            let included = sweep_rad;
            let deviation = r0 * (1.0 - (included / 2.0).cos());
            if deviation < self.naive_cam_mm {
                let mid = seg.point_at_fraction(0.5);
                self.see(mid, k);
                self.see(seg.end, k);
                return;
            }
        }
        self.flush();
        let s = self.settings;
        let r1 = ((seg.end[a] - center[a]).powi(2) + (seg.end[b] - center[b]).powi(2)).sqrt();
        let spiral = r1 - r0;
        let dr = spiral / sweep_rad;
        let min_radius = r0.min(r1);
        let effective = (dr * dr + min_radius * min_radius).sqrt();
        let v_axes = s.axis_max_vel_mm_s[a].min(s.axis_max_vel_mm_s[b]);
        let a_axes = s.axis_max_acc_mm_s2[a].min(s.axis_max_acc_mm_s2[b]);
        let v_radial = (a_axes * 3f64.sqrt() / 2.0 * effective).sqrt();
        let v_planar = v_radial.min(v_axes);
        let d = seg.end - self.end;
        let spiral_length = (min_radius * sweep_rad).hypot(spiral);
        let axis_len = d[n];
        let total = spiral_length.hypot(axis_len);
        let t_motion = straight(&d, &s.axis_max_vel_mm_s).map_or(0.0, |v| v.1);
        let v_max = total / t_motion.max(spiral_length / v_planar);
        let tt_motion = straight(&d, &s.axis_max_acc_mm_s2).map_or(0.0, |v| v.1);
        let a_max = total / tt_motion.max(spiral_length / a_axes);
        let vel = self.feed_mm_s.min(v_max);
        self.end = seg.end;
        // The target: the helix over the spiral's planar length
        // (pmCircle9Target with the mean radius for the fit).
        let target = super::tc::circle_target(seg);
        if target < super::tc::POS_EPSILON || !(vel > 0.0 && a_max > 0.0) {
            return;
        }
        // pmCircleEffectiveMinRadius: the spiral's, plus the helix's rise
        // squared over it (as LinuxCNC writes it).
        let r_spiral = {
            let n_inner = dr * dr + r0 * r0;
            n_inner.powf(1.5) / (n_inner + dr * dr)
        };
        let h2 = axis_len * axis_len;
        let mut normal = Vector3::zeros();
        normal[n] = if clockwise { -1.0 } else { 1.0 };
        self.out.push(Cmd::Move(Box::new(Tc::new(
            Shape::Circle {
                segment: *seg,
                effective_radius_mm: h2 / r_spiral + r_spiral,
                radius_mm: r0,
                center,
                normal,
            },
            k,
            target,
            (vel, v_max, a_max),
            (TermCond::Parabolic, 0.0),
            false,
            s.period_s,
        ))));
    }
}
