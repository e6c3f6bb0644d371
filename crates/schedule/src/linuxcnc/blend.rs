//! Corners in G64: blend arcs between lines (blendmath.c's line–line case,
//! tp.c's `tpCreateLineLineBlend`), parabolic blends and the choice between
//! them (`tpChooseBestBlend`, `tpComputeBlendVelocity`); MODEL.md §6.4.

use super::queue::{remove_kink, set_term_cond, Tp};
use super::tc::{acc_ratio_normal, v_peak, Shape, SphericalArc, Tc, TermCond, BLEND_DIST_FRACTION};
use super::LinuxCncIni as Settings;
use nalgebra::{Point3, Vector3};
use std::f64::consts::PI;

/// `TP_ANGLE_EPSILON`.
const ANGLE_EPSILON: f64 = 1e-6;
/// `TP_MIN_ARC_ANGLE`.
const MIN_ARC_ANGLE: f64 = 1e-3;

/// The blend `tpChooseBestBlend` picked (the order of its `perf` array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Best {
    Parabolic,
    Tangent,
    Arc,
    None,
}

/// A blend arc made for a corner, before it is chosen.
pub(super) struct Made {
    pub tc: Tc,
    pub arc_start: Point3<f64>,
    pub arc_end: Point3<f64>,
    /// The previous line is so short that the arc takes it whole.
    pub consume: bool,
}

/// `calculateInscribedDiameter`: the largest circle of the box of per-axis
/// `bounds` cut by the plane of unit `normal` (the limit in any direction of
/// that plane).
fn inscribed_diameter(normal: &Vector3<f64>, bounds: &[f64; 3]) -> Option<f64> {
    if (1.0 - normal.norm_squared()).abs() > 1e-6 {
        return None;
    }
    let mut extent = [0.0; 3];
    for i in 0..3 {
        let mut planar = -normal * normal[i];
        planar[i] += 1.0;
        let mut planar = planar.abs();
        planar[i] = planar[i].max(1e-12);
        if bounds[i] != 0.0 {
            extent[i] = bounds[i] / planar.norm();
        }
    }
    let mut d = extent[0].max(extent[1]).max(extent[2]);
    for i in 0..3 {
        if bounds[i] != 0.0 {
            d = d.min(extent[i]);
        }
    }
    Some(d)
}

/// `findIntersectionAngle`: half the supplement of the angle between two
/// unit vectors (π/2 when they point the same way).
fn intersection_angle(u1: &Vector3<f64>, u2: &Vector3<f64>) -> f64 {
    (-u1.dot(u2)).clamp(-1.0, 1.0).acos() / 2.0
}

/// `tcFindBlendTolerance`: the program's tolerance (a quarter of the moves'
/// lengths where it is 0, G64 without P), within a quarter of each move.
fn blend_tolerance(prev: &Tc, tc: &Tc) -> f64 {
    let ratio = 0.25;
    let t1 = if prev.tolerance == 0.0 {
        prev.nominal_length * ratio
    } else {
        prev.tolerance
    };
    let t2 = if tc.tolerance == 0.0 {
        tc.nominal_length * ratio
    } else {
        tc.tolerance
    };
    t1.min(t2)
        .min(prev.nominal_length * ratio)
        .min(tc.nominal_length * ratio)
}

/// What blendmath.c's kinematics and `blendComputeParameters` give a
/// corner: the blend's speeds, radius and how far it starts from the corner.
struct Plan {
    tolerance: f64,
    a_max: f64,
    v_req: f64,
    v_plan: f64,
    r_plan: f64,
    d_plan: f64,
}

/// `blendParamKinematics` and `blendComputeParameters` for a corner of
/// half-supplement `theta` between directions `u1`, `u2` (in the plane of
/// unit `binormal`), within lengths `l1`, `l2` of the moves.
#[allow(clippy::too_many_arguments)]
fn plan(
    s: &Settings,
    prev: &Tc,
    tc: &Tc,
    (u1, u2, binormal): (Vector3<f64>, Vector3<f64>, Vector3<f64>),
    theta: f64,
    (l1, l2): (f64, f64),
) -> Option<Plan> {
    let phi = PI - theta * 2.0;
    let tolerance = blend_tolerance(prev, tc);
    let a_max = inscribed_diameter(&binormal, &s.axis_max_acc_mm_s2)?;
    let a_n_max = a_max * acc_ratio_normal();
    let v_req = prev.max_target_vel(1.0).max(tc.max_target_vel(1.0));
    let mut v_goal = prev
        .max_target_vel(s.max_feed_scale)
        .max(tc.max_target_vel(s.max_feed_scale));
    let v_planar_max = inscribed_diameter(&binormal, &s.axis_max_vel_mm_s)?;
    let phi_eff = phi.min(PI * 0.49);
    let v_max1 = prev.maxvel.min(tc.maxvel / phi_eff.cos());
    let v_max2 = tc.maxvel.min(prev.maxvel / phi_eff.cos());
    let v_area = v_max1 * v_max2 / 2.0 * phi.sin();
    let base = (u2 * v_max2 - u1 * v_max1).norm();
    // No altitude-based speed where an arc takes part.
    let v_max_alt = if prev.is_line() && tc.is_line() {
        2.0 * v_area / base
    } else {
        0.0
    };
    v_goal = v_goal.min(v_max_alt.max(v_planar_max));
    let h_tol = tolerance / (1.0 - theta.sin());
    let d_tol = theta.cos() * h_tol;
    let d_geom = l1.min(l2).min(d_tol);
    let r_geom = theta.tan() * d_geom;
    let v_normal = (a_n_max * r_geom).sqrt();
    let v_plan = v_normal.min(v_goal);
    let a_parabolic = a_max * 0.5;
    let v_triangle = (2.0 * a_parabolic * d_geom).sqrt();
    let t_blend = v_triangle.min(v_plan) / a_parabolic;
    let s_blend = t_blend * v_plan;
    let r_blend = (s_blend / phi).min(r_geom);
    let r_plan = (v_plan * v_plan / a_n_max).max(r_blend);
    let d_plan = r_plan / theta.tan();
    if r_plan < super::tc::POS_EPSILON || r_plan * phi < 1e-6 {
        return None;
    }
    Some(Plan {
        tolerance,
        a_max,
        v_req,
        v_plan,
        r_plan,
        d_plan,
    })
}

/// `tpInitBlendArcFromPrev`: the blend arc as a move (requested speed v_req,
/// limit v_plan, acceleration a_max), finalised.
fn blend_tc(tp: &Tp, prev: &Tc, arc: SphericalArc, plan: &Plan) -> Tc {
    let length = arc.length();
    let mut blend = Tc::new(
        Shape::Blend(arc),
        prev.segment_at(prev.target),
        length,
        (plan.v_req, plan.v_plan, plan.a_max),
        (tp.term_cond, tp.tolerance),
        prev.traverse,
        tp.settings.period_s,
    );
    set_term_cond(&mut blend, None, TermCond::Tangent);
    super::queue::finalize_length(&mut blend);
    blend
}

/// `tpCreateLineLineBlend` up to the choice: the blend arc between the
/// line `prev` and the line `tc`, or `None` where LinuxCNC makes none.
pub(super) fn line_line(tp: &Tp, prev: &Tc, tc: &Tc) -> Option<Made> {
    let s = tp.settings;
    // blendGeom3Init.
    let u1 = prev.end_tangent();
    let u2 = tc.start_tangent();
    let p = tc.start();
    let theta = intersection_angle(&u1, &u2);
    if PI / 2.0 - theta < ANGLE_EPSILON || theta < ANGLE_EPSILON {
        return None;
    }
    let binormal = u1.cross(&u2).normalize();
    let normal = (u2 - u1).normalize();
    // blendInit3FromLineLine.
    let l1 = prev.target.min(prev.nominal_length * BLEND_DIST_FRACTION);
    let l2 = tc.target * BLEND_DIST_FRACTION;
    let pl = plan(s, prev, tc, (u1, u2, binormal), theta, (l1, l2))?;
    // blendFindPoints3.
    let center = p + normal * (pl.r_plan / theta.sin());
    let arc_start = p - u1 * pl.d_plan;
    let arc_end = p + u2 * pl.d_plan;
    // blendCheckConsume.
    let l_prev = prev.target - pl.d_plan;
    let can_consume = !prev.blend_prev;
    let consume = l_prev / pl.v_plan < s.arc_blend_gap_cycles * prev.cycle_time && can_consume;
    let line_length = if consume { l_prev } else { 0.0 };
    let arc = SphericalArc::from_points(arc_start, arc_end, center, u1, line_length)?;
    Some(Made {
        tc: blend_tc(tp, prev, arc, &pl),
        arc_start,
        arc_end,
        consume,
    })
}

/// A blend arc between an arc and a line (`tpCreateArcLineBlend`,
/// `tpCreateLineArcBlend`): the arc loses `trim_rad` at the corner, the line
/// `trim_mm`; `consume`: the line before is taken whole into the blend.
pub(super) struct ArcLine {
    pub tc: Tc,
    pub trim_rad: f64,
    pub trim_mm: f64,
    pub consume: bool,
}

/// A circle move's geometry as blendmath.c reads it.
struct Circle<'a> {
    segment: &'a nc::Segment,
    center: Point3<f64>,
    /// Unit normal of the turn.
    normal: Vector3<f64>,
    /// End radius less start radius, mm.
    spiral: f64,
    sweep_rad: f64,
}

/// The circle of `tc`.
fn circle(tc: &Tc) -> Option<Circle<'_>> {
    let Shape::Circle {
        segment,
        center,
        normal,
        radius_mm,
        ..
    } = &tc.shape
    else {
        return None;
    };
    let nc::Geometry::Arc {
        sweep_rad, plane, ..
    } = segment.geometry
    else {
        return None;
    };
    let (a, b, _) = plane.axes();
    let r1 = ((segment.end[a] - center[a]).powi(2) + (segment.end[b] - center[b]).powi(2)).sqrt();
    Some(Circle {
        segment,
        center: *center,
        normal: normal.normalize(),
        spiral: r1 - radius_mm,
        sweep_rad,
    })
}

/// `pmUnitCartsColinear`.
fn colinear(u: &Vector3<f64>, v: &Vector3<f64>) -> bool {
    let tol = ANGLE_EPSILON * ANGLE_EPSILON;
    (u - v).norm_squared() < tol || (u + v).norm_squared() < tol
}

/// `blendLineArcPostProcess` / `blendArcLinePostProcess`: the blend's centre
/// for the line through `p` along `u` (`sign` −1 where the arc comes after
/// the line) and the circle of centre `c`, radius `radius`; `None` where it
/// leaves the tolerance. Returns the centre and the line's trim.
#[allow(clippy::too_many_arguments)]
fn post_process(
    p: Point3<f64>,
    u: Vector3<f64>,
    sign: f64,
    binormal: Vector3<f64>,
    (c, radius, convex): (Point3<f64>, f64, bool),
    r: f64,
    tolerance: f64,
) -> Option<(Point3<f64>, f64)> {
    let d = if convex { -r } else { r } + radius;
    let n = binormal.cross(&u).normalize();
    let r_pc0 = c - p;
    let (c_u, c_n) = (r_pc0.dot(&u), r_pc0.dot(&n));
    let (qb, qc) = (2.0 * c_u, c_u * c_u - d * d + (r - c_n).powi(2));
    let disc = qb * qb - 4.0 * qc;
    if disc < 0.0 {
        return None;
    }
    let d_l = ((-qb + disc.sqrt()) / 2.0)
        .abs()
        .min(((-qb - disc.sqrt()) / 2.0).abs());
    let r_pc = u * (sign * d_l) + n * r;
    if r_pc.norm() - r > tolerance {
        return None;
    }
    Some((p + r_pc, d_l))
}

/// `findTrimAngle`.
fn trim_angle(p: &Point3<f64>, arc_center: &Point3<f64>, center: &Point3<f64>) -> f64 {
    (p - center)
        .normalize()
        .dot(&(arc_center - center).normalize())
        .clamp(-1.0, 1.0)
        .acos()
}

/// `checkTangentAngle`: the blend may meet the trimmed arc at an angle one
/// period can take (`findMaxTangentAngle`).
fn tangent_ok(tp: &Tp, pl: &Plan, u_circ: Vector3<f64>, u_arc: Vector3<f64>) -> bool {
    let blend_angle = u_circ.normalize().dot(&u_arc).clamp(-1.0, 1.0).acos();
    let angle_max = acc_ratio_normal() * 0.25 * pl.a_max / (pl.v_plan / tp.settings.period_s);
    blend_angle <= angle_max
}

/// `arcTangent` of a blend arc about `binormal`, at its start or end.
fn arc_tangent(arc: &SphericalArc, binormal: &Vector3<f64>, at_end: bool) -> Vector3<f64> {
    let r = if at_end { arc.r_end } else { arc.r_start };
    let dr = (arc.r_end.norm() - arc.radius) / arc.angle;
    (binormal.cross(&r) + r.normalize() * dr).normalize()
}

/// `tpCreateLineArcBlend` up to the choice (blendInit3FromLineArc,
/// blendLineArcPostProcess, blendCheckConsume, checkTangentAngle).
pub(super) fn line_arc(tp: &Tp, prev: &Tc, tc: &Tc) -> Option<ArcLine> {
    let s = tp.settings;
    let Circle {
        segment,
        center,
        normal,
        spiral,
        sweep_rad,
    } = circle(tc)?;
    let point_at = |angle: f64| segment.point_at_fraction(angle / sweep_rad);
    let u_tan1 = prev.end_tangent();
    let u_tan2 = tc.start_tangent();
    let p = prev.end();
    let theta_tan = intersection_angle(&u_tan1, &u_tan2);
    if PI / 2.0 - theta_tan < ANGLE_EPSILON || theta_tan < ANGLE_EPSILON {
        return None;
    }
    let binormal = u_tan1.cross(&u_tan2).normalize();
    let center2 = center + u_tan2 * (spiral / sweep_rad);
    let radius2 = (p - center2).norm();
    let convex = (p - center2).dot(&u_tan1) >= 0.0;
    let phi2_max = (sweep_rad / 3.0).min(if convex { theta_tan } else { PI / 2.0 });
    let mut theta = theta_tan;
    let mut u2 = u_tan2;
    if convex {
        u2 = (point_at(phi2_max / 2.0) - p).normalize();
        theta = theta.min(theta_tan - phi2_max / 4.0);
    }
    let l1 = prev.target.min(prev.nominal_length / 2.0);
    let l2 = if convex {
        (phi2_max / 4.0).sin() * radius2
    } else {
        phi2_max * radius2
    };
    if !colinear(&binormal, &normal) {
        return None;
    }
    let pl = plan(s, prev, tc, (u_tan1, u2, binormal), theta, (l1, l2))?;
    let (arc_center, trim_mm) = post_process(
        p,
        u_tan1,
        -1.0,
        binormal,
        (center2, radius2, convex),
        pl.r_plan,
        pl.tolerance,
    )?;
    let trim_rad = trim_angle(&p, &arc_center, &center2);
    if trim_rad > phi2_max || sweep_rad - trim_rad <= 0.0 || prev.target - trim_mm <= 0.0 {
        return None;
    }
    let l_prev = prev.target - trim_mm;
    let consume = l_prev / pl.v_plan < s.arc_blend_gap_cycles * prev.cycle_time && !prev.blend_prev;
    let arc_start = p - u_tan1 * trim_mm;
    let arc_end = point_at(trim_rad);
    let arc = SphericalArc::from_points(
        arc_start,
        arc_end,
        arc_center,
        u_tan1,
        if consume { l_prev } else { 0.0 },
    )?;
    let u_circ = segment.tangent_at_fraction(trim_rad / sweep_rad);
    if !tangent_ok(tp, &pl, u_circ, arc_tangent(&arc, &binormal, true)) {
        return None;
    }
    Some(ArcLine {
        tc: blend_tc(tp, prev, arc, &pl),
        trim_rad,
        trim_mm,
        consume,
    })
}

/// `tpCreateArcLineBlend` up to the choice (blendInit3FromArcLine,
/// blendArcLinePostProcess, checkTangentAngle), or `None` where LinuxCNC
/// makes no blend arc.
pub(super) fn arc_line(tp: &Tp, prev: &Tc, tc: &Tc) -> Option<ArcLine> {
    let s = tp.settings;
    let Circle {
        segment,
        center,
        normal,
        spiral,
        sweep_rad,
    } = circle(prev)?;
    let point_at = |angle: f64| segment.point_at_fraction(angle / sweep_rad);
    // blendGeom3Init.
    let u_tan1 = prev.end_tangent();
    let u_tan2 = tc.start_tangent();
    let p = tc.start();
    let theta_tan = intersection_angle(&u_tan1, &u_tan2);
    if PI / 2.0 - theta_tan < ANGLE_EPSILON || theta_tan < ANGLE_EPSILON {
        return None;
    }
    let binormal = u_tan1.cross(&u_tan2).normalize();
    // blendInit3FromArcLine: the spiral as a circle near its end.
    let center1 = center + u_tan1 * (spiral / sweep_rad);
    let radius1 = (p - center1).norm();
    let convex = (p - center1).dot(&u_tan2) < 0.0;
    let phi1_max = (sweep_rad * 2.0 / 3.0).min(if convex { theta_tan } else { PI / 2.0 });
    let mut theta = theta_tan;
    let mut u1 = u_tan1;
    if convex {
        u1 = (p - point_at(sweep_rad - phi1_max / 2.0)).normalize();
        theta = theta.min(theta_tan - phi1_max / 4.0);
    }
    let l1 = if convex {
        (phi1_max / 4.0).sin() * radius1
    } else {
        phi1_max * radius1
    };
    let l2 = tc.nominal_length / 2.0;
    if !colinear(&binormal, &normal) {
        return None;
    }
    let pl = plan(s, prev, tc, (u1, u_tan2, binormal), theta, (l1, l2))?;
    // blendArcLinePostProcess.
    let (arc_center, trim_mm) = post_process(
        p,
        u_tan2,
        1.0,
        binormal,
        (center1, radius1, convex),
        pl.r_plan,
        pl.tolerance,
    )?;
    let trim_rad = trim_angle(&p, &arc_center, &center1);
    if trim_rad > phi1_max || sweep_rad - trim_rad <= 0.0 || tc.target - trim_mm <= 0.0 {
        return None;
    }
    let arc_start = point_at(sweep_rad - trim_rad);
    let arc_end = p + u_tan2 * trim_mm;
    let arc = SphericalArc::from_points(arc_start, arc_end, arc_center, u_tan1, 0.0)?;
    // checkTangentAngle: the trimmed arc's end against the blend's start.
    let u_circ = segment.tangent_at_fraction((sweep_rad - trim_rad) / sweep_rad);
    if !tangent_ok(tp, &pl, u_circ, arc_tangent(&arc, &binormal, false)) {
        return None;
    }
    Some(ArcLine {
        tc: blend_tc(tp, prev, arc, &pl),
        trim_rad,
        trim_mm,
        consume: false,
    })
}

/// A blend arc between two arcs (`tpCreateArcArcBlend`): the first loses
/// `trim1_rad` of its end, the second `trim2_rad` of its start.
pub(super) struct ArcArc {
    pub tc: Tc,
    pub trim1_rad: f64,
    pub trim2_rad: f64,
}

/// `tpCreateArcArcBlend` up to the choice (blendInit3FromArcArc,
/// blendArcArcPostProcess, checkTangentAngle at both ends).
pub(super) fn arc_arc(tp: &Tp, prev: &Tc, tc: &Tc) -> Option<ArcArc> {
    let s = tp.settings;
    let c1 = circle(prev)?;
    let c2 = circle(tc)?;
    if !colinear(&c1.normal, &c2.normal) {
        return None;
    }
    let point1 = |angle: f64| c1.segment.point_at_fraction(angle / c1.sweep_rad);
    let point2 = |angle: f64| c2.segment.point_at_fraction(angle / c2.sweep_rad);
    let u_tan1 = prev.end_tangent();
    let u_tan2 = tc.start_tangent();
    let p = tc.start();
    let theta_tan = intersection_angle(&u_tan1, &u_tan2);
    if PI / 2.0 - theta_tan < ANGLE_EPSILON || theta_tan < ANGLE_EPSILON {
        return None;
    }
    let binormal = u_tan1.cross(&u_tan2).normalize();
    let normal = (u_tan2 - u_tan1).normalize();
    let center1 = c1.center + u_tan1 * (c1.spiral / c1.sweep_rad);
    let radius1 = (p - center1).norm();
    let center2 = c2.center + u_tan2 * (c2.spiral / c2.sweep_rad);
    let radius2 = (p - center2).norm();
    let convex1 = (p - center1).dot(&u_tan2) < 0.0;
    let convex2 = (p - center2).dot(&u_tan1) >= 0.0;
    let phi1_max = (c1.sweep_rad * 2.0 / 3.0).min(if convex1 { theta_tan } else { PI / 2.0 });
    let phi2_max = (c2.sweep_rad / 3.0).min(if convex2 { theta_tan } else { PI / 2.0 });
    let (mut theta, mut u1, mut u2) = (theta_tan, u_tan1, u_tan2);
    if convex1 {
        u1 = (p - point1(c1.sweep_rad - phi1_max / 2.0)).normalize();
        theta = theta.min(theta_tan - phi1_max / 4.0);
    }
    if convex2 {
        u2 = (point2(phi2_max / 2.0) - p).normalize();
        theta = theta.min(theta_tan - phi2_max / 4.0);
    }
    if theta < PI / 12.0 {
        return None;
    }
    let l1 = if convex1 {
        (phi1_max / 4.0).sin() * radius1
    } else {
        phi1_max * radius1
    };
    let l2 = if convex2 {
        (phi2_max / 4.0).sin() * radius2
    } else {
        phi2_max * radius2
    };
    if !colinear(&binormal, &c1.normal) || !colinear(&binormal, &c2.normal) {
        return None;
    }
    let pl = plan(s, prev, tc, (u1, u2, binormal), theta, (l1, l2))?;
    // blendArcArcPostProcess: the blend circle at R ± r from both centres.
    let r = pl.r_plan;
    let d1 = if convex1 { -r } else { r } + radius1;
    let d2 = if convex2 { -r } else { r } + radius2;
    let r_c1c2 = center2 - center1;
    let c2x = r_c1c2.norm();
    if c2x <= 0.0 {
        return None;
    }
    let cx = (-d1 * d1 + d2 * d2 - c2x * c2x) / (-2.0 * c2x);
    let cy = (d1 * d1 - cx * cx).max(0.0).sqrt();
    let uc = r_c1c2 / c2x;
    let mut n = binormal.cross(&uc);
    if normal.dot(&n) < 0.0 {
        n = -n;
    }
    let n = n.normalize();
    let (c_x, mut c_y) = (uc * cx, n * cy);
    let r_pc1 = center1 - p;
    if (r_pc1 + c_x - c_y).norm() < (r_pc1 + c_x + c_y).norm() {
        c_y = -c_y;
    }
    let arc_center = center1 + c_x + c_y;
    if (arc_center - p).norm() - r > pl.tolerance {
        return None;
    }
    let trim1_rad = trim_angle(&p, &arc_center, &center1);
    let trim2_rad = trim_angle(&p, &arc_center, &center2);
    if trim1_rad > phi1_max
        || trim2_rad > phi2_max
        || c1.sweep_rad - trim1_rad <= 0.0
        || c2.sweep_rad - trim2_rad <= 0.0
    {
        return None;
    }
    let arc_start = point1(c1.sweep_rad - trim1_rad);
    let arc_end = point2(trim2_rad);
    let arc = SphericalArc::from_points(arc_start, arc_end, arc_center, u_tan1, 0.0)?;
    let u_circ1 = c1
        .segment
        .tangent_at_fraction((c1.sweep_rad - trim1_rad) / c1.sweep_rad);
    let u_circ2 = c2.segment.tangent_at_fraction(trim2_rad / c2.sweep_rad);
    if !tangent_ok(tp, &pl, u_circ1, arc_tangent(&arc, &binormal, false))
        || !tangent_ok(tp, &pl, u_circ2, arc_tangent(&arc, &binormal, true))
    {
        return None;
    }
    Some(ArcArc {
        tc: blend_tc(tp, prev, arc, &pl),
        trim1_rad,
        trim2_rad,
    })
}

/// `tcConnectBlendArc`'s change to the previous line: it ends at `end`.
pub(super) fn shorten_end(tc: &mut Tc, end: Point3<f64>) {
    if let Shape::Line { start, unit, .. } = &mut tc.shape {
        let d = end - *start;
        tc.target = d.norm();
        if tc.target > 0.0 {
            *unit = d / tc.target;
        }
    }
}

/// `tcConnectBlendArc`'s change to the next line: it starts at `new_start`.
pub(super) fn shorten_start(tc: &mut Tc, new_start: Point3<f64>) {
    if let Shape::Line {
        start,
        unit,
        pieces,
    } = &mut tc.shape
    {
        let end = *start + *unit * tc.target;
        let d = end - new_start;
        let cut = tc.target - d.norm();
        *start = new_start;
        tc.target = d.norm();
        if tc.target > 0.0 {
            *unit = d / tc.target;
        }
        for p in pieces.iter_mut() {
            p.1 -= cut;
        }
    }
}

/// `tpComputeBlendVelocity`: the speeds at which a parabolic blend of `tc`
/// into `next` starts on each, and the blend's net speed.
pub(super) fn parabolic_velocity(
    tc: &Tc,
    next: &Tc,
    target_vel_this: f64,
    target_vel_next: f64,
) -> (f64, f64, f64) {
    let acc_this = tc.tangential_max_accel();
    let acc_next = next.tangential_max_accel();
    let triangle = |t: &Tc| {
        let length = if t.finalized {
            t.target
        } else {
            t.target / 2.0
        };
        v_peak(t.tangential_max_accel(), length)
    };
    let v_reach_this = triangle(tc).min(target_vel_this);
    let v_reach_next = triangle(next).min(target_vel_next);
    let t_max_reachable = (tc.target / v_reach_this).min(next.target / v_reach_next);
    let t_max_blend = (v_reach_this / acc_this).max(v_reach_next / acc_next);
    let t_blend = t_max_reachable.min(t_max_blend);
    let mut v_this = v_reach_this.min(t_blend * acc_this);
    let mut v_next = v_reach_next.min(t_blend * acc_next);
    let theta = intersection_angle(&tc.end_accel_unit(), &next.start_accel_unit());
    let cos_theta = theta.cos();
    if tc.tolerance > 0.0 {
        let min_cos_theta = (PI / 2.0 - MIN_ARC_ANGLE).cos();
        if cos_theta > min_cos_theta {
            let v = 2.0 * (acc_this * tc.tolerance / cos_theta).sqrt();
            v_this = v_this.min(v);
            v_next = v_next.min(v);
        }
    }
    (v_this, v_next, theta.sin() * (v_this + v_next) / 2.0)
}

/// `tpChooseBestBlend`: a parabolic blend, passing as tangent at the kink
/// speed, or the blend arc (whose highest speed is `arc_maxvel`), by the
/// speed each allows; sets `prev`'s end and returns the choice.
pub(super) fn choose_best(
    settings: &Settings,
    prev: &mut Tc,
    tc: &mut Tc,
    arc_maxvel: Option<f64>,
) -> Best {
    if matches!(prev.term_cond, TermCond::Exact | TermCond::Stop) {
        return Best::None;
    }
    let max_target = |t: &Tc| {
        t.max_target_vel(settings.max_feed_scale)
            .min(settings.max_linear_vel_mm_s)
    };
    let (_, _, v_net) = parabolic_velocity(prev, tc, max_target(prev), max_target(tc));
    let perf = [v_net / 2.0, prev.kink_vel, arc_maxvel.unwrap_or(0.0)];
    let mut best = 0;
    for (i, p) in perf.iter().enumerate() {
        if *p > perf[best] {
            best = i;
        }
    }
    match best {
        0 => {
            remove_kink(prev, tc);
            set_term_cond(prev, Some(tc), TermCond::Parabolic);
            Best::Parabolic
        }
        1 => {
            set_term_cond(prev, Some(tc), TermCond::Tangent);
            Best::Tangent
        }
        _ => {
            remove_kink(prev, tc);
            Best::Arc
        }
    }
}
