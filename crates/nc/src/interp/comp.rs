//! Cutter radius compensation (G40, G41, G42, G41.1, G42.1) in the XY
//! plane, as LinuxCNC's interpreter does it (MODEL.md §9.3): the tool centre
//! keeps the radius to the left or right of the programmed contour; convex
//! corners get an arc about the programmed corner, concave corners pull the
//! end of the moves not yet final back to where the tool touches both
//! elements, and a corner the tool cannot reach without gouging is an error.
//!
//! Moves stay "queued" (their end may still move) until the next move's
//! corner is resolved, like LinuxCNC's canon queue.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::Point3;

use super::{fail, Block, Fail, Interp};
use crate::gcode::GCode;
use crate::path::{Geometry, Motion, Plane};

/// Which side of the contour the tool runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    Left,
    Right,
}

/// Compensation state.
#[derive(Clone, Debug, Default)]
pub(super) struct Comp {
    pub side: Option<Side>,
    pub radius_mm: f64,
    /// The next move is the entry move.
    pub first: bool,
    /// Programmed (uncompensated) point, gauge frame, mm.
    pub program: [f64; 3],
    /// Path segments whose end may still move, with each straight move's
    /// programmed XY direction.
    pub queue: Vec<(usize, [f64; 2])>,
    /// Start of the queued moves (LinuxCNC's `endpoint`), if valid.
    pub endpoint: Option<[f64; 2]>,
    /// The move after G40 must be straight.
    pub arc_not_allowed: bool,
}

/// Concave-corner angle tolerance, rad (LinuxCNC's TOLERANCE_CONCAVE_CORNER).
const SMALL: f64 = 0.05;

/// LinuxCNC's `find_turn`: signed angle from (x1, y1) to (x2, y2) about the
/// centre, `turn` > 0 counter-clockwise, |turn| − 1 full turns added.
fn find_turn(p1: [f64; 2], c: [f64; 2], turn: i32, p2: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let mut alpha = (p1[1] - c[1]).atan2(p1[0] - c[0]);
    let mut beta = (p2[1] - c[1]).atan2(p2[0] - c[0]);
    if turn > 0 {
        if beta <= alpha {
            beta += TAU;
        }
        beta - alpha + f64::from(turn - 1) * TAU
    } else {
        if alpha <= beta {
            alpha += TAU;
        }
        beta - alpha + f64::from(turn + 1) * TAU
    }
}

fn tool_inside_arc(side: Side, turn: i32) -> bool {
    (side == Side::Left && turn > 0) || (side == Side::Right && turn < 0)
}

impl Interp<'_> {
    /// Compensation is active and moves are offset.
    pub(super) fn comp_active(&self) -> bool {
        self.comp.side.is_some() && self.comp.radius_mm > 0.0
    }

    /// G41/G42 (radius from the D tool's diameter, or the tool in the
    /// spindle) and G41.1/G42.1 (D is the diameter).
    pub(super) fn comp_on(&mut self, code: GCode, b: &Block, col: u32) -> Result<(), Fail> {
        if self.plane != Plane::XY {
            return fail(
                col,
                "cutter radius compensation is supported in the G17 (XY) plane only",
            );
        }
        if self.comp.side.is_some() {
            return fail(
                col,
                "cannot turn cutter radius compensation on when it is already on",
            );
        }
        let mut side = if code == GCode::G41 || code == GCode::G41_1 {
            Side::Left
        } else {
            Side::Right
        };
        let radius_mm = if code == GCode::G41_1 || code == GCode::G42_1 {
            let d = b.get('d').ok_or(Fail {
                col,
                msg: format!("{code} with no D word"),
            })?;
            d * self.scale / 2.0
        } else {
            let tool = match b.get('d') {
                None => self.tool,
                Some(d) => {
                    if (d - d.round()).abs() >= 1e-4 || d < -0.5 {
                        return fail(
                            b.col('d'),
                            format!("{code} requires D word to be a whole number"),
                        );
                    }
                    let t = self.tool_number(d.round(), b.col('d'), 'D')?;
                    if t == 0 {
                        self.tool
                    } else {
                        t
                    }
                }
            };
            self.diameter_of(tool) / 2.0
        };
        let radius_mm = if radius_mm < 0.0 {
            side = if side == Side::Left {
                Side::Right
            } else {
                Side::Left
            };
            -radius_mm
        } else {
            radius_mm
        };
        self.comp.side = Some(side);
        self.comp.radius_mm = radius_mm;
        Ok(())
    }

    /// G40: the queued moves end where the tool is; the next move starts
    /// from there towards its programmed point (the exit move).
    pub(super) fn comp_off(&mut self) -> Result<(), Fail> {
        if self.comp_active() && !self.comp.first {
            let [cx, cy, _] = self.pos;
            self.move_endpoint_and_flush(cx, cy, 1)?;
            self.comp.queue.clear();
            self.comp.endpoint = None;
            self.pos = self.comp.program;
            self.comp.arc_not_allowed = true;
        }
        self.comp.side = None;
        self.comp.first = true;
        Ok(())
    }

    /// Moves every queued move's end to (x, y) (LinuxCNC's
    /// `move_endpoint_and_flush`), refusing a move that would run backwards.
    fn move_endpoint_and_flush(&mut self, x: f64, y: f64, col: u32) -> Result<(), Fail> {
        let queue = std::mem::take(&mut self.comp.queue);
        let endpoint = self.comp.endpoint;
        let arc_tolerance = if self.scale == 1.0 { 0.0254 } else { 0.001 };
        for (k, &(i, dir)) in queue.iter().enumerate() {
            let prev_end = (k > 0).then(|| self.path.segments[queue[k - 1].0].end);
            let seg = &mut self.path.segments[i];
            if let Some(p) = prev_end {
                seg.start.x = p.x;
                seg.start.y = p.y;
            }
            match (&mut seg.geometry, seg.motion) {
                (
                    Geometry::Arc {
                        center,
                        clockwise,
                        sweep_rad,
                        ..
                    },
                    _,
                ) => {
                    let c = [center.x, center.y];
                    let r1 = (seg.end.x - c[0]).hypot(seg.end.y - c[1]);
                    let r2 = (x - c[0]).hypot(y - c[1]);
                    if (r1 - r2).abs() > 0.01 {
                        return fail(col, "cutter compensation made an arc with mismatched radii");
                    }
                    let turn = if *clockwise { -1 } else { 1 };
                    let from = endpoint.unwrap_or([seg.start.x, seg.start.y]);
                    let l1 = *sweep_rad;
                    let l2 = find_turn(from, c, turn, [x, y]);
                    if endpoint.is_some() && l1 != 0.0 && l2.abs() > l1.abs() + arc_tolerance {
                        return fail(
                            col,
                            "arc move in concave corner cannot be reached by the tool without gouging",
                        );
                    }
                    *sweep_rad = find_turn([seg.start.x, seg.start.y], c, turn, [x, y]).abs();
                }
                (Geometry::Line, motion) => {
                    if let (Some(e), Motion::Rapid | Motion::Feed { .. }) = (endpoint, motion) {
                        let dot = dir[0] * (x - e[0]) + dir[1] * (y - e[1]);
                        if dot < 0.0 {
                            let what = if motion == Motion::Rapid {
                                "straight traverse"
                            } else {
                                "straight feed"
                            };
                            return fail(
                                col,
                                format!("{what} in concave corner cannot be reached by the tool without gouging"),
                            );
                        }
                    }
                }
            }
            seg.end.x = x;
            seg.end.y = y;
            if matches!(seg.motion, Motion::Dwell { .. }) {
                seg.start = seg.end;
            }
        }
        if !queue.is_empty() {
            self.last_tip.x = x;
            self.last_tip.y = y;
        }
        self.comp.endpoint = Some([x, y]);
        Ok(())
    }

    /// Forgets the queue (its moves are final).
    fn dequeue(&mut self) {
        self.comp.queue.clear();
        self.comp.endpoint = None;
    }

    /// Appends a queued straight move to gauge point `to`.
    fn queue_line(&mut self, to: [f64; 3], motion: Motion, dir: [f64; 2], pc: usize) {
        // The queue holds indices into the run's own path.
        self.own_path();
        let before = self.path.segments.len();
        self.push(to, Geometry::Line, motion, pc, false);
        if self.path.segments.len() > before {
            self.comp.queue.push((before, dir));
        }
    }

    /// Appends a queued arc about `center` (gauge frame) to `to`.
    fn queue_arc(&mut self, to: [f64; 3], center: [f64; 2], turn: i32, motion: Motion, pc: usize) {
        let start = [self.last_tip.x, self.last_tip.y];
        let sweep = find_turn(start, center, turn, [to[0], to[1]]).abs();
        self.own_path();
        let before = self.path.segments.len();
        let c = [center[0], center[1], self.pos[2]];
        self.push(
            to,
            Geometry::Arc {
                center: Point3::from(c),
                plane: Plane::XY,
                clockwise: turn < 0,
                sweep_rad: sweep,
            },
            motion,
            pc,
            false,
        );
        if self.path.segments.len() > before {
            self.comp.queue.push((before, [0.0; 2]));
        }
    }

    /// The front of the queue is an arc: its centre (tip frame XY), radius
    /// and turn sign.
    fn queued_arc(&self) -> Option<([f64; 2], f64, i32)> {
        let &(i, _) = self.comp.queue.first()?;
        let s = &self.path.segments[i];
        match s.geometry {
            Geometry::Arc {
                center, clockwise, ..
            } => Some((
                [center.x, center.y],
                (s.end.x - center.x).hypot(s.end.y - center.y),
                if clockwise { -1 } else { 1 },
            )),
            Geometry::Line => None,
        }
    }

    /// A straight move (G0/G1) to programmed gauge point `p` under
    /// compensation (LinuxCNC's convert_straight_comp1 and comp2).
    pub(super) fn straight_comp(
        &mut self,
        b: &Block,
        p: [f64; 3],
        motion: Motion,
        pc: usize,
    ) -> Result<(), Fail> {
        self.comp.arc_not_allowed = false;
        let side = self.comp.side.expect("compensation on");
        let radius = self.comp.radius_mm;
        let [cx, cy, cz] = self.pos;
        let col = b.first_col;
        if self.comp.first {
            let distance = (p[0] - cx).hypot(p[1] - cy);
            if distance <= radius {
                return fail(
                    col,
                    "length of cutter compensation entry move is not greater than the tool radius",
                );
            }
            let alpha = (p[1] - cy).atan2(p[0] - cx)
                + if side == Side::Left {
                    FRAC_PI_2
                } else {
                    -FRAC_PI_2
                };
            let end = [
                p[0] + radius * alpha.cos(),
                p[1] + radius * alpha.sin(),
                p[2],
            ];
            self.comp.endpoint = Some([cx, cy]);
            self.queue_line(end, motion, [alpha.cos(), alpha.sin()], pc);
            self.comp.first = false;
            self.pos = end;
            self.comp.program = p;
            return Ok(());
        }
        let [opx, opy, opz] = self.comp.program;
        if p[0] == opx && p[1] == opy {
            // No XY motion.
            self.queue_line([cx, cy, p[2]], motion, [p[0] - opx, p[1] - opy], pc);
            let _ = opz;
            self.comp.program = p;
            return Ok(());
        }
        let mut theta = (cy - opy).atan2(cx - opx);
        let mut alpha = (p[1] - opy).atan2(p[0] - opx);
        let (beta, gamma) = if side == Side::Left {
            if theta < alpha {
                theta += TAU;
            }
            (theta - alpha - FRAC_PI_2, FRAC_PI_2)
        } else {
            if alpha < theta {
                alpha += TAU;
            }
            (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
        };
        let end = [
            p[0] + radius * (alpha + gamma).cos(),
            p[1] + radius * (alpha + gamma).sin(),
            p[2],
        ];
        let (mid_x, mid_y) = (
            opx + radius * (alpha + gamma).cos(),
            opy + radius * (alpha + gamma).sin(),
        );
        let queued_arc = self.queued_arc();
        let concave = !(-SMALL..=PI + SMALL).contains(&beta)
            || (beta > PI - SMALL
                && queued_arc.is_some_and(|(_, _, turn)| {
                    (side == Side::Right && turn > 0) || (side == Side::Left && turn < 0)
                }));
        if !concave && beta > SMALL {
            // Convex corner: an arc about the programmed corner (a straight
            // traverse for G0).
            self.move_endpoint_and_flush(cx, cy, col)?;
            self.dequeue();
            let corner_end = [mid_x, mid_y, cz];
            if motion == Motion::Rapid {
                self.push(corner_end, Geometry::Line, motion, pc, false);
            } else {
                let turn = if side == Side::Left { -1 } else { 1 };
                let feed = self.feed_motion(b, 0.0)?;
                self.queue_arc(corner_end, [opx, opy], turn, feed, pc);
                self.dequeue();
            }
            self.comp.endpoint = Some([mid_x, mid_y]);
        } else if concave {
            match queued_arc {
                None => {
                    // line → line
                    let halfcorner = (beta + PI) / 2.0;
                    if halfcorner == 0.0 {
                        return fail(
                            col,
                            "zero degree inside corner is invalid for cutter compensation",
                        );
                    }
                    let retreat = radius / halfcorner.tan();
                    let mx = cx + retreat * (theta + gamma).cos();
                    let my = cy + retreat * (theta + gamma).sin();
                    self.move_endpoint_and_flush(mx, my, col)?;
                }
                Some((center, oldrad, turn)) => {
                    // arc → line
                    let base_dir = (p[1] - opy).atan2(p[0] - opx);
                    let theta = if turn > 0 {
                        base_dir + FRAC_PI_2
                    } else {
                        base_dir - FRAC_PI_2
                    };
                    let phi = (center[1] - opy).atan2(center[0] - opx);
                    let inside = tool_inside_arc(side, turn);
                    let oldrad_uncomp = if inside {
                        oldrad + radius
                    } else {
                        oldrad - radius
                    };
                    let d = oldrad_uncomp * (theta - phi).cos();
                    let (d2, sign) = if inside {
                        (d - radius, if turn > 0 { -1.0 } else { 1.0 })
                    } else {
                        (d + radius, if turn > 0 { 1.0 } else { -1.0 })
                    };
                    let l = d2 / oldrad;
                    if !(-1.0..=1.0).contains(&l) {
                        return fail(col, "arc to straight motion makes a corner the compensated tool can't fit in without gouging");
                    }
                    let angle = sign * l.acos() + theta + PI;
                    let mx = center[0] + oldrad * angle.cos();
                    let my = center[1] + oldrad * angle.sin();
                    self.move_endpoint_and_flush(mx, my, col)?;
                }
            }
        } else {
            // Colinear, or tangent arc → line.
            self.dequeue();
            self.comp.endpoint = Some([cx, cy]);
        }
        self.queue_line(end, motion, [p[0] - opx, p[1] - opy], pc);
        self.pos = end;
        self.comp.program = p;
        Ok(())
    }

    /// An arc (G2/G3) to programmed gauge point `p` about programmed centre
    /// `center` under compensation (LinuxCNC's convert_arc_comp2).
    pub(super) fn arc_comp(
        &mut self,
        b: &Block,
        p: [f64; 3],
        center: [f64; 2],
        turns: i32,
        motion: Motion,
        pc: usize,
    ) -> Result<(), Fail> {
        let col = b.first_col;
        if self.comp.first {
            return self.arc_comp_entry(b, p, center, turns, motion, pc);
        }
        let side = self.comp.side.expect("compensation on");
        let tool_radius = self.comp.radius_mm;
        let [opx, opy, _] = self.comp.program;
        let [cx, cy, cz] = self.pos;
        let ccw = self.motion == GCode::G3;
        let turn = if ccw { turns } else { -turns };
        let arc_radius = (center[0] - p[0]).hypot(center[1] - p[1]);
        let mut theta = (cy - opy).atan2(cx - opx);
        theta = if side == Side::Left {
            theta - FRAC_PI_2
        } else {
            theta + FRAC_PI_2
        };
        let mut delta = (center[1] - opy).atan2(center[0] - opx);
        let alpha = if ccw {
            delta - FRAC_PI_2
        } else {
            delta + FRAC_PI_2
        };
        let mut beta = if side == Side::Left {
            theta - alpha
        } else {
            alpha - theta
        };
        if beta > 1.5 * PI {
            beta -= TAU;
        } else if beta < -FRAC_PI_2 {
            beta += TAU;
        }
        let gamma = if (side == Side::Left && ccw) || (side == Side::Right && !ccw) {
            if arc_radius <= tool_radius {
                return fail(
                    col,
                    "tool radius not less than arc radius with cutter radius compensation",
                );
            }
            (center[1] - p[1]).atan2(center[0] - p[0])
        } else {
            delta += PI;
            (p[1] - center[1]).atan2(p[0] - center[0])
        };
        let new_end = [
            p[0] + tool_radius * gamma.cos(),
            p[1] + tool_radius * gamma.sin(),
            p[2],
        ];
        let inside = tool_inside_arc(side, turn);
        if !(-SMALL..=PI + SMALL).contains(&beta) || ((beta - PI).abs() < SMALL && !inside) {
            // Concave corner.
            let (mx, my) = match self.queued_arc() {
                None => {
                    let cyy = arc_radius * (beta - FRAC_PI_2).sin();
                    let (dist, l, angle_of) = if inside {
                        let dist = arc_radius - tool_radius;
                        let l = (cyy + tool_radius) / dist;
                        (dist, l, if turn > 0 { 1.0 } else { -1.0 })
                    } else {
                        let dist = arc_radius + tool_radius;
                        let l = (cyy - tool_radius) / dist;
                        (dist, l, if turn > 0 { -1.0 } else { 1.0 })
                    };
                    if !(-1.0..=1.0).contains(&l) {
                        return fail(
                            col,
                            "arc move in concave corner cannot be reached by the tool without gouging",
                        );
                    }
                    let angle = if inside {
                        theta + angle_of * l.asin()
                    } else {
                        theta + PI + angle_of * l.asin()
                    };
                    (
                        center[0] + dist * angle.cos(),
                        center[1] + dist * angle.sin(),
                    )
                }
                Some((prev_center, oldrad, prev_turn)) => {
                    let newrad = if inside {
                        arc_radius - tool_radius
                    } else {
                        arc_radius + tool_radius
                    };
                    let arc_cc = (prev_center[1] - center[1]).hypot(prev_center[0] - center[0]);
                    if oldrad == 0.0 || arc_cc == 0.0 {
                        return fail(
                            col,
                            "arc to arc motion is invalid because the arcs have the same center",
                        );
                    }
                    let a = (oldrad * oldrad + arc_cc * arc_cc - newrad * newrad)
                        / (2.0 * oldrad * arc_cc);
                    if !(-1.0..=1.0).contains(&a) {
                        return fail(col, "arc to arc motion makes a corner the compensated tool can't fit in without gouging");
                    }
                    let pullback = a.acos();
                    let cc_dir = (center[1] - prev_center[1]).atan2(center[0] - prev_center[0]);
                    let plus = tool_inside_arc(side, prev_turn) == (turn > 0);
                    let dir = if plus {
                        cc_dir + pullback
                    } else {
                        cc_dir - pullback
                    };
                    (
                        prev_center[0] + oldrad * dir.cos(),
                        prev_center[1] + oldrad * dir.sin(),
                    )
                }
            };
            self.move_endpoint_and_flush(mx, my, col)?;
        } else if beta > SMALL {
            // Convex: an arc about the programmed corner, then the arc.
            let mid = [
                opx + tool_radius * delta.cos(),
                opy + tool_radius * delta.sin(),
                cz,
            ];
            self.dequeue();
            let corner_turn = if side == Side::Left { -1 } else { 1 };
            self.queue_arc(mid, [opx, opy], corner_turn, motion, pc);
            self.dequeue();
            self.comp.endpoint = Some([mid[0], mid[1]]);
        } else {
            self.dequeue();
            self.comp.endpoint = Some([cx, cy]);
        }
        self.queue_arc(new_end, center, turn, motion, pc);
        self.pos = new_end;
        self.comp.program = p;
        Ok(())
    }

    /// An arc as the entry move (LinuxCNC's convert_arc_comp1): the arc from
    /// the current point to the programmed end, shifted by the radius at its
    /// end, with the centre moved so both ends stay on one circle.
    fn arc_comp_entry(
        &mut self,
        b: &Block,
        p: [f64; 3],
        center: [f64; 2],
        turns: i32,
        motion: Motion,
        pc: usize,
    ) -> Result<(), Fail> {
        let col = b.first_col;
        let side = self.comp.side.expect("compensation on");
        let tool_radius = self.comp.radius_mm;
        let [cx, cy, _] = self.pos;
        let ccw = self.motion == GCode::G3;
        let turn = if ccw { turns } else { -turns };
        let arc_radius = (center[0] - cx).hypot(center[1] - cy);
        if arc_radius <= tool_radius && tool_inside_arc(side, turn) {
            return fail(
                col,
                "tool radius not less than arc radius with cutter radius compensation",
            );
        }
        if (p[0] - cx).hypot(p[1] - cy) <= tool_radius {
            return fail(
                col,
                "radius of cutter compensation entry arc is not greater than the tool radius",
            );
        }
        let gamma = if tool_inside_arc(side, turn) {
            (center[1] - p[1]).atan2(center[0] - p[0])
        } else {
            (p[1] - center[1]).atan2(p[0] - center[0])
        };
        let end = [
            p[0] + tool_radius * gamma.cos(),
            p[1] + tool_radius * gamma.sin(),
            p[2],
        ];
        let b_len = (cy - end[1]).hypot(cx - end[0]) / 2.0;
        let ab_ang = (center[1] - end[1]).atan2(center[0] - end[0]);
        let a_ang = (cy - end[1]).atan2(cx - end[0]) - ab_ang;
        if a_ang.cos().abs() < 1e-4 {
            return fail(
                col,
                "tool radius not less than arc radius with cutter radius compensation",
            );
        }
        let c_len = b_len / a_ang.cos();
        let new_center = [end[0] + c_len * ab_ang.cos(), end[1] + c_len * ab_ang.sin()];
        self.comp.first = false;
        self.comp.program = p;
        self.queue_arc(end, new_center, turn, motion, pc);
        self.pos = end;
        Ok(())
    }
}
