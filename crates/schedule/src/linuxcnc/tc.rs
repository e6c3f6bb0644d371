//! One queued move of LinuxCNC's trajectory planner (`TC_STRUCT`, tc.c):
//! its geometry, its limits and its state while it runs.

use nalgebra::{Point3, Vector3};

/// `BLEND_ACC_RATIO_TANGENTIAL` (blendmath.h): the share of a curved move's
/// acceleration left to the tangential direction.
pub(super) const ACC_RATIO_TANGENTIAL: f64 = 0.5;
/// `TP_POS_EPSILON`.
pub(super) const POS_EPSILON: f64 = 1e-12;
/// `TP_VEL_EPSILON`.
pub(super) const VEL_EPSILON: f64 = 1e-8;
/// `TP_TIME_EPSILON`.
pub(super) const TIME_EPSILON: f64 = 1e-12;
/// `BLEND_DIST_FRACTION` (tc_types.h).
pub(super) const BLEND_DIST_FRACTION: f64 = 0.5;

/// `BLEND_ACC_RATIO_NORMAL`: √(1 − 0.5²).
pub(super) fn acc_ratio_normal() -> f64 {
    (1.0 - ACC_RATIO_TANGENTIAL * ACC_RATIO_TANGENTIAL).sqrt()
}

/// How a move ends (`TC_TERM_COND_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum TermCond {
    /// G61.1, and wherever blending is impossible: stop.
    Stop,
    /// G61: stop unless the next move is tangent.
    Exact,
    /// G64: a parabolic blend (or a blend arc replaces the corner).
    Parabolic,
    /// Pass into the next move without stopping (tangent, or a blend arc).
    Tangent,
}

/// The shape of a move.
#[derive(Clone, Debug)]
pub(super) enum Shape {
    /// A straight line (`TC_LINEAR`), possibly several program lines the
    /// naive CAM detector joined: `pieces` are the program segments it runs
    /// and the distance along the line where each ends.
    Line {
        start: Point3<f64>,
        unit: Vector3<f64>,
        pieces: Vec<(usize, f64)>,
    },
    /// A circle or helix (`TC_CIRCULAR`): the program's arc segment.
    Circle {
        segment: nc::Segment,
        /// `pmCircleEffectiveMinRadius`, mm.
        effective_radius_mm: f64,
        /// Start radius, mm.
        radius_mm: f64,
        /// Centre, mm.
        center: Point3<f64>,
        /// Unit normal of the turn (right-handed with the motion).
        normal: Vector3<f64>,
    },
    /// A blend arc (`TC_SPHERICAL`, spherical_arc.c), with the rest of a
    /// consumed line before it.
    Blend(SphericalArc),
}

/// A circular arc through three points (spherical_arc.c's `SphericalArc`).
#[derive(Clone, Debug)]
pub(super) struct SphericalArc {
    pub start: Point3<f64>,
    pub center: Point3<f64>,
    pub r_start: Vector3<f64>,
    pub r_end: Vector3<f64>,
    pub radius: f64,
    pub angle: f64,
    pub sin_angle: f64,
    /// Direction of the consumed line before the arc.
    pub u_tan: Vector3<f64>,
    /// Length of the consumed line before the arc, mm.
    pub line_length: f64,
}

impl SphericalArc {
    /// `arcInitFromPoints`; `None` where LinuxCNC refuses the arc.
    pub fn from_points(
        start: Point3<f64>,
        end: Point3<f64>,
        center: Point3<f64>,
        u_tan: Vector3<f64>,
        line_length: f64,
    ) -> Option<SphericalArc> {
        let r_start = start - center;
        let r_end = end - center;
        let (r0, r1) = (r_start.norm(), r_end.norm());
        // ARC_MIN_RADIUS, ARC_MIN_ANGLE (spherical_arc.h).
        if r0 < 1e-12 || r1 < 1e-12 {
            return None;
        }
        let dot = (r_start / r0).dot(&(r_end / r1));
        let angle = dot.acos();
        if !(angle >= 1e-6) {
            return None;
        }
        Some(SphericalArc {
            start,
            center,
            r_start,
            r_end,
            radius: r0,
            angle,
            sin_angle: angle.sin(),
            u_tan,
            line_length,
        })
    }

    /// `arcLength`, mm.
    pub fn length(&self) -> f64 {
        self.radius * self.angle + self.line_length
    }

    /// `arcPoint`: the point `progress` mm along.
    pub fn point(&self, progress: f64) -> Point3<f64> {
        let net = progress - self.line_length;
        if net <= 0.0 && self.line_length > 0.0 {
            return self.start + self.u_tan * net;
        }
        let a = net / self.radius;
        let s0 = (self.angle - a).sin() / self.sin_angle;
        let s1 = a.sin() / self.sin_angle;
        self.center + self.r_start * s0 + self.r_end * s1
    }
}

/// One move in the queue (`TC_STRUCT`), with the fields the planner reads.
#[derive(Clone, Debug)]
pub(super) struct Tc {
    pub shape: Shape,
    /// Program segment of a circle or a blend (a line keeps its pieces).
    pub segment: usize,
    /// Length, mm.
    pub target: f64,
    pub nominal_length: f64,
    pub progress: f64,
    /// Requested speed (the feed, within the axes' limits), mm/s.
    pub reqvel: f64,
    /// Highest speed (the axes' limit along the move), mm/s.
    pub maxvel: f64,
    /// Acceleration along the move within the axes' limits, mm/s².
    pub maxaccel: f64,
    pub finalvel: f64,
    pub currentvel: f64,
    pub term_vel: f64,
    pub blend_vel: f64,
    pub vel_at_blend_start: f64,
    pub kink_vel: f64,
    pub kink_accel_reduce: f64,
    pub kink_accel_reduce_prev: f64,
    pub term_cond: TermCond,
    pub tolerance: f64,
    pub blend_prev: bool,
    pub acc_ratio_tan: f64,
    pub cycle_time: f64,
    pub traverse: bool,
    pub finalized: bool,
    pub active: bool,
    pub remove: bool,
    pub splitting: bool,
    pub blending_next: bool,
    pub on_final_decel: bool,
    pub is_blending: bool,
    pub ramp: bool,
    pub at_max: bool,
}

impl Tc {
    /// `tcInit`, `tcSetupState` and `tcSetupMotion`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        shape: Shape,
        segment: usize,
        target: f64,
        (reqvel, maxvel, maxaccel): (f64, f64, f64),
        (term_cond, tolerance): (TermCond, f64),
        traverse: bool,
        cycle_time: f64,
    ) -> Tc {
        Tc {
            shape,
            segment,
            target,
            nominal_length: target,
            progress: 0.0,
            reqvel,
            maxvel,
            maxaccel,
            finalvel: 0.0,
            currentvel: 0.0,
            term_vel: 0.0,
            blend_vel: 0.0,
            vel_at_blend_start: 0.0,
            kink_vel: -1.0,
            kink_accel_reduce: 0.0,
            kink_accel_reduce_prev: 0.0,
            term_cond,
            tolerance,
            blend_prev: false,
            acc_ratio_tan: ACC_RATIO_TANGENTIAL,
            cycle_time,
            traverse,
            finalized: false,
            active: false,
            remove: false,
            splitting: false,
            blending_next: false,
            on_final_decel: false,
            is_blending: false,
            ramp: false,
            at_max: false,
        }
    }

    pub fn is_line(&self) -> bool {
        matches!(self.shape, Shape::Line { .. })
    }

    pub fn is_circle(&self) -> bool {
        matches!(self.shape, Shape::Circle { .. })
    }

    /// `tcGetMaxTargetVel` with no spindle synchronisation.
    pub fn max_target_vel(&self, max_scale: f64) -> f64 {
        (self.reqvel * max_scale).min(self.maxvel)
    }

    /// `tcGetOverallMaxAccel`: less what a near-tangent kink takes, halved
    /// on both sides of a parabolic blend.
    pub fn overall_max_accel(&self) -> f64 {
        let mut a_scale = 1.0 - self.kink_accel_reduce.max(self.kink_accel_reduce_prev);
        if self.blend_prev || self.term_cond == TermCond::Parabolic {
            a_scale *= 0.5;
        }
        self.maxaccel * a_scale
    }

    /// `tcGetTangentialMaxAccel`: curved moves keep part of it for the normal
    /// acceleration (MODEL.md §6.4).
    pub fn tangential_max_accel(&self) -> f64 {
        let a = self.overall_max_accel();
        match self.shape {
            Shape::Line { .. } => a,
            _ => a * self.acc_ratio_tan,
        }
    }

    /// The point `progress` mm along the move (`tcGetPos`).
    pub fn point(&self, progress: f64) -> Point3<f64> {
        match &self.shape {
            Shape::Line { start, unit, .. } => start + unit * progress,
            Shape::Circle { segment, .. } => {
                let u = if self.target > 0.0 {
                    (progress / self.target).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                segment.point_at_fraction(u)
            }
            Shape::Blend(arc) => arc.point(progress),
        }
    }

    /// Start point.
    pub fn start(&self) -> Point3<f64> {
        self.point(0.0)
    }

    /// End point.
    pub fn end(&self) -> Point3<f64> {
        self.point(self.target)
    }

    /// Unit tangent at the start (`tcGetStartTangentUnitVector`).
    pub fn start_tangent(&self) -> Vector3<f64> {
        match &self.shape {
            Shape::Line { unit, .. } => *unit,
            Shape::Circle { segment, .. } => segment.tangent_at_fraction(0.0).normalize(),
            Shape::Blend(arc) => arc.u_tan,
        }
    }

    /// Unit tangent at the end (`tcGetEndTangentUnitVector`).
    pub fn end_tangent(&self) -> Vector3<f64> {
        match &self.shape {
            Shape::Line { unit, .. } => *unit,
            Shape::Circle { segment, .. } => segment.tangent_at_fraction(1.0).normalize(),
            Shape::Blend(arc) => {
                let t = arc.r_end.cross(&arc.r_start.cross(&arc.r_end));
                t.normalize()
            }
        }
    }

    /// `tcGetStartAccelUnitVector`: a circle's leans towards its centre.
    pub fn start_accel_unit(&self) -> Vector3<f64> {
        match &self.shape {
            Shape::Circle {
                center, radius_mm, ..
            } => {
                let p = self.start();
                let tan = self.start_tangent_planar() * self.overall_max_accel();
                let perp = (center - p).normalize() * (0.5 * self.reqvel).powi(2) / *radius_mm;
                (tan + perp).normalize()
            }
            _ => self.start_tangent(),
        }
    }

    /// `tcGetEndAccelUnitVector`.
    pub fn end_accel_unit(&self) -> Vector3<f64> {
        match &self.shape {
            Shape::Circle { center, normal, .. } => {
                let r = self.end() - center;
                normal.cross(&r).normalize()
            }
            _ => self.end_tangent(),
        }
    }

    /// A circle's planar tangent at its start (normal × radius).
    fn start_tangent_planar(&self) -> Vector3<f64> {
        match &self.shape {
            Shape::Circle { center, normal, .. } => {
                normal.cross(&(self.start() - center)).normalize()
            }
            _ => self.start_tangent(),
        }
    }

    /// The program segment at `progress` mm along the move.
    pub fn segment_at(&self, progress: f64) -> usize {
        match &self.shape {
            Shape::Line { pieces, .. } => pieces
                .iter()
                .find(|p| progress <= p.1 + 1e-9)
                .or(pieces.last())
                .map_or(self.segment, |p| p.0),
            _ => self.segment,
        }
    }
}

/// A circle's length (`pmCircle9Target`): the helix over the spiral's planar
/// length, taken at the mean radius.
pub(super) fn circle_target(seg: &nc::Segment) -> f64 {
    let nc::Geometry::Arc {
        center,
        plane,
        sweep_rad,
        ..
    } = seg.geometry
    else {
        return seg.length_mm();
    };
    let (a, b, n) = plane.axes();
    let r = |p: &Point3<f64>| ((p[a] - center[a]).powi(2) + (p[b] - center[b]).powi(2)).sqrt();
    (0.5 * (r(&seg.start) + r(&seg.end)) * sweep_rad).hypot(seg.end[n] - seg.start[n])
}

/// `tcSetCircleXYZ` after `pmCircleStretch`: the circle `tc` loses `trim_rad`
/// of its end.
pub(super) fn trim_circle_end(tc: &mut Tc, trim_rad: f64) {
    if let Shape::Circle { segment, .. } = &mut tc.shape {
        if let nc::Geometry::Arc { sweep_rad, .. } = segment.geometry {
            let end = segment.point_at_fraction((sweep_rad - trim_rad) / sweep_rad);
            if let nc::Geometry::Arc { sweep_rad, .. } = &mut segment.geometry {
                *sweep_rad -= trim_rad;
            }
            segment.end = end;
        }
        tc.target = circle_target(segment);
    }
}

/// `tcSetCircleXYZ` after `pmCircleStretch`: the circle `tc` loses `trim_rad`
/// of its start.
pub(super) fn trim_circle_start(tc: &mut Tc, trim_rad: f64) {
    if let Shape::Circle {
        segment,
        radius_mm,
        center,
        ..
    } = &mut tc.shape
    {
        if let nc::Geometry::Arc {
            sweep_rad, plane, ..
        } = segment.geometry
        {
            let start = segment.point_at_fraction(trim_rad / sweep_rad);
            if let nc::Geometry::Arc { sweep_rad, .. } = &mut segment.geometry {
                *sweep_rad -= trim_rad;
            }
            segment.start = start;
            let (a, b, _) = plane.axes();
            *radius_mm = ((start[a] - center[a]).powi(2) + (start[b] - center[b]).powi(2)).sqrt();
        }
        tc.target = circle_target(segment);
    }
}

/// `findVPeak`: the speed reached from rest over `distance` at `acc`.
pub(super) fn v_peak(acc: f64, distance: f64) -> f64 {
    (acc * distance).sqrt()
}
