//! Motion: targets of axis words (work offsets, G92, polar words, G53),
//! G28/G30/G92/G10, lines and arcs (R and centre formats), and the segments
//! they append to the path.

use nalgebra::Point3;

use super::block::g_group;
use super::state::Spindle;
use super::{fail, Block, Fail, Interp, SegmentTrace};
use crate::gcode::GCode;
use crate::path::{Geometry, Motion, Segment};

/// `xy` turned `deg` degrees counterclockwise (LinuxCNC's `rotate`).
pub(super) fn rotate(xy: [f64; 2], deg: f64) -> [f64; 2] {
    let (sin, cos) = (deg * std::f64::consts::PI / 180.0).sin_cos();
    [xy[0] * cos - xy[1] * sin, xy[0] * sin + xy[1] * cos]
}

/// LinuxCNC's RADIUS_TOLERANCE (0.00005 in = 0.00127 mm): an R arc's half
/// chord may exceed R by this much, and a shorter radius is zero.
const RADIUS_TOLERANCE_MM: f64 = 0.00127;

impl Interp<'_> {
    /// Work offset + G92 + tool length offset (mm): gauge point = program·scale + this.
    pub(super) fn offset(&self) -> [f64; 3] {
        let w = self.work[self.coord];
        std::array::from_fn(|i| w[i] + self.g92[i] + self.tlo_mm[i])
    }

    /// Rotation (degrees) of the active coordinate system about Z.
    pub(super) fn rotation(&self) -> f64 {
        self.rotation_deg[self.coord]
    }

    /// Gauge point of program point `p` (mm, program units times the
    /// scale, before G92), as LinuxCNC's canon (`rotate_and_offset_pos`):
    /// G92 added, then the XY rotation of the coordinate system, then its
    /// offset and the tool length offset.
    pub(super) fn to_machine(&self, p: [f64; 3]) -> [f64; 3] {
        let off = self.offset();
        let r = self.rotation();
        if r == 0.0 {
            return std::array::from_fn(|i| p[i] + off[i]);
        }
        let [x, y] = rotate([p[0] + self.g92[0], p[1] + self.g92[1]], r);
        let (w, t) = (self.work[self.coord], self.tlo_mm);
        [x + w[0] + t[0], y + w[1] + t[1], p[2] + off[2]]
    }

    /// The program point (mm, before G92) of gauge point `m`: the inverse
    /// of [`Interp::to_machine`].
    pub(super) fn to_program(&self, m: [f64; 3]) -> [f64; 3] {
        let off = self.offset();
        let r = self.rotation();
        if r == 0.0 {
            return std::array::from_fn(|i| m[i] - off[i]);
        }
        let (w, t) = (self.work[self.coord], self.tlo_mm);
        let [x, y] = rotate([m[0] - w[0] - t[0], m[1] - w[1] - t[1]], -r);
        [x - self.g92[0], y - self.g92[1], m[2] - off[2]]
    }

    /// Target of the block's axis words (mm, machine frame, gauge point),
    /// polar `@` radius and `^` angle (degrees) included, as LinuxCNC's
    /// `find_ends`: about the program origin, incremental ones from the
    /// current point's polar coordinates. In a rotated coordinate system
    /// (G10 L2 R) the words are read in its own frame and the point rotated.
    pub(super) fn target(&self, b: &Block, machine: bool) -> Result<[f64; 3], Fail> {
        // Under compensation, words not given keep the programmed point.
        let base = if self.comp_active() && !self.comp.first {
            [self.comp.program[0], self.comp.program[1], self.pos[2]]
        } else {
            self.pos
        };
        if self.rotation() != 0.0 && !machine {
            return self.target_rotated(b, base);
        }
        let off = self.offset();
        let mut t = base;
        for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
            if let Some(v) = b.get(l) {
                t[i] = if machine {
                    v * self.scale
                } else if self.incremental {
                    base[i] + v * self.scale
                } else {
                    v * self.scale + off[i]
                };
            }
        }
        let (radius, theta) = (b.get('@'), b.get('^'));
        if radius.is_none() && theta.is_none() {
            return Ok(t);
        }
        if machine {
            let col = b.col(if radius.is_some() { '@' } else { '^' });
            return fail(col, "cannot use polar coordinates with G53");
        }
        // Current point in program units about the program origin.
        let (px, py) = (
            (base[0] - off[0]) / self.scale,
            (base[1] - off[1]) / self.scale,
        );
        let (r, a) = self.polar(b, px, py)?;
        t[0] = r * a.cos() * self.scale + off[0];
        t[1] = r * a.sin() * self.scale + off[1];
        Ok(t)
    }

    /// [`Interp::target`] in a rotated coordinate system: the point in the
    /// system's own frame, then [`Interp::to_machine`].
    fn target_rotated(&self, b: &Block, base: [f64; 3]) -> Result<[f64; 3], Fail> {
        let from = self.to_program(base);
        let mut t = from;
        for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
            if let Some(v) = b.get(l) {
                t[i] = if self.incremental {
                    from[i] + v * self.scale
                } else {
                    v * self.scale
                };
            }
        }
        if b.get('@').is_some() || b.get('^').is_some() {
            let (r, a) = self.polar(b, from[0] / self.scale, from[1] / self.scale)?;
            t[0] = r * a.cos() * self.scale;
            t[1] = r * a.sin() * self.scale;
        }
        Ok(self.to_machine(t))
    }

    /// Polar radius and angle (radians, program units) of the block's `@`
    /// and `^` words from the current point (`px`, `py`, program units).
    fn polar(&self, b: &Block, px: f64, py: f64) -> Result<(f64, f64), Fail> {
        let (radius, theta) = (b.get('@'), b.get('^'));
        let col = b.col(if radius.is_some() { '@' } else { '^' });
        if b.get('x').is_some() || b.get('y').is_some() {
            return fail(col, "cannot specify X or Y words with polar coordinates");
        }
        if self.incremental {
            if px == 0.0 && py == 0.0 {
                return fail(
                    col,
                    "incremental polar motion is indeterminate at the origin",
                );
            }
            Ok((
                px.hypot(py) + radius.unwrap_or(0.0),
                py.atan2(px) + theta.unwrap_or(0.0).to_radians(),
            ))
        } else {
            let a = match theta {
                Some(deg) => deg.to_radians(),
                None if px == 0.0 && py == 0.0 => {
                    return fail(col, "polar radius at the origin needs an angle (^)")
                }
                None => py.atan2(px),
            };
            Ok((radius.unwrap_or_else(|| px.hypot(py)), a))
        }
    }

    pub(super) fn modal0(
        &mut self,
        code: GCode,
        col: u32,
        b: &Block,
        pc: usize,
    ) -> Result<(), Fail> {
        match code {
            GCode::G28 | GCode::G30 => {
                let home = self.homes_mm[usize::from(code == GCode::G30)];
                let mid = self.target(b, false)?;
                self.rapid(mid, pc);
                let mut end = self.pos;
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if !b.has_axes() || b.get(l).is_some() {
                        end[i] = home[i];
                    }
                }
                self.rapid(end, pc);
            }
            GCode::G92 | GCode::G52
                if !['x', 'y', 'z', 'a', 'b', 'c', 'u', 'v', 'w']
                    .into_iter()
                    .any(|l| b.get(l).is_some()) =>
            {
                // As LinuxCNC's convert_axis_offsets.
                return fail(col, format!("all axes missing with {code}"));
            }
            GCode::G92 => {
                // LinuxCNC's convert_axis_offsets: the offset is taken in
                // the frame before the rotation; the machine does not move.
                let w = self.work[self.coord];
                let rotated = self.rotation() != 0.0;
                let before_g92 = {
                    let p = self.to_program(self.pos);
                    std::array::from_fn::<f64, 3, _>(|i| p[i] + self.g92[i])
                };
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if let Some(v) = b.get(l) {
                        self.g92[i] = if rotated {
                            before_g92[i] - v * self.scale
                        } else {
                            self.pos[i] - w[i] - self.tlo_mm[i] - v * self.scale
                        };
                    }
                }
                self.g92_saved = self.g92;
            }
            GCode::G52 => {
                // LinuxCNC's G52: the G92 offset set to the words given; the
                // machine does not move.
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if let Some(v) = b.get(l) {
                        self.g92[i] = v * self.scale;
                    }
                }
                self.g92_saved = self.g92;
            }
            GCode::G10 => self.set_work_offset(col, b)?,
            _ => return fail(col, format!("{code} is not supported")),
        }
        Ok(())
    }

    /// G10 L2: the offset and rotation (R, degrees about Z) of coordinate
    /// system P (P0: the active one), as LinuxCNC's `convert_setup`. Where
    /// the system is the active one, the program point is carried into the
    /// new frame as LinuxCNC carries it (the rotation of the G92 offset
    /// is not, so with G92 and a changed rotation the next move starts from
    /// where LinuxCNC's interpreter believes the tool is).
    fn set_work_offset(&mut self, col: u32, b: &Block) -> Result<(), Fail> {
        let l = b.get('l').unwrap_or(0.0);
        let p = b.get('p').unwrap_or(0.0);
        if l == 20.0 && b.get('r').is_some() {
            return fail(b.col('r'), "R not allowed in G10 L20");
        }
        if !(l == 2.0 || l == 20.0) || !(0.0..=6.0).contains(&p) || p.fract() != 0.0 {
            return fail(
                col,
                "only G10 L2 and L20 P0..P6 (set work offset and rotation) are supported",
            );
        }
        let system = if p == 0.0 { self.coord } else { p as usize - 1 };
        let active = system == self.coord;
        if active && self.comp.side.is_some() {
            return fail(
                col,
                "cannot change the active coordinate system with cutter radius compensation on",
            );
        }
        if l == 20.0 {
            // LinuxCNC's L20: the offset that makes the current point read
            // the words given in system P (the machine does not move).
            if self.rotation() != 0.0 || self.rotation_deg[system] != 0.0 {
                return fail(
                    col,
                    "G10 L20 with a rotated coordinate system (G10 L2 R) is not supported",
                );
            }
            let w = &mut self.work[system];
            for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                if let Some(v) = b.get(l) {
                    w[i] = self.pos[i] - self.g92[i] - self.tlo_mm[i] - v * self.scale;
                }
            }
            return Ok(());
        }
        let (r0, o0) = (self.rotation(), self.work[self.coord]);
        let program = self.to_program(self.pos);
        if let Some(r) = b.get('r') {
            self.rotation_deg[system] = r;
        }
        let w = &mut self.work[system];
        for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
            if let Some(v) = b.get(l) {
                w[i] = v * self.scale;
            }
        }
        let r = self.rotation();
        if active && (r0 != 0.0 || r != 0.0) {
            let o = self.work[system];
            let [x, y] = rotate([program[0], program[1]], r0);
            let [x, y] = rotate([x + o0[0] - o[0], y + o0[1] - o[1]], -r);
            self.pos = self.to_machine([x, y, program[2] + o0[2] - o[2]]);
        }
        Ok(())
    }

    pub(super) fn rapid(&mut self, to: [f64; 3], pc: usize) {
        self.push(to, Geometry::Line, Motion::Rapid, pc, false);
    }

    /// Tool tip (path frame) of gauge point `gauge`.
    fn tip(&self, gauge: [f64; 3]) -> Point3<f64> {
        Point3::new(gauge[0], gauge[1], gauge[2] - self.tool_length_mm)
    }

    /// Appends a segment from the current position to `to` (gauge points,
    /// turned into tool tips); zero-length lines are dropped. `dwell` keeps
    /// a zero-length segment.
    pub(super) fn push(
        &mut self,
        to: [f64; 3],
        geometry: Geometry,
        motion: Motion,
        pc: usize,
        dwell: bool,
    ) {
        let start = self.last_tip;
        let end = if dwell { start } else { self.tip(to) };
        self.pos = to;
        self.canon_mm = std::array::from_fn(|i| to[i] - self.tlo_mm[i]);
        if !dwell && geometry == Geometry::Line && start == end {
            return;
        }
        let geometry = match geometry {
            Geometry::Arc {
                center,
                plane,
                clockwise,
                sweep_rad,
            } => Geometry::Arc {
                center: self.tip(center.into()),
                plane,
                clockwise,
                sweep_rad,
            },
            g => g,
        };
        self.emit(start, end, geometry, motion, pc);
    }

    /// Appends a segment between two tool-tip points.
    pub(super) fn emit(
        &mut self,
        start: Point3<f64>,
        end: Point3<f64>,
        geometry: Geometry,
        motion: Motion,
        pc: usize,
    ) {
        self.last_tip = end;
        let segment = Segment {
            start,
            end,
            geometry,
            motion,
            line: pc as u32 + 1,
            spindle_rpm: if self.spindle != Spindle::Stopped {
                self.spindle_rpm
            } else {
                0.0
            },
            tool: self.tool,
        };
        let lent = self.lent.as_mut().is_some_and(|l| {
            let same = l.path.get(l.matched).is_some_and(|s| s.same_bits(&segment));
            l.matched += usize::from(same);
            same
        });
        if !lent {
            self.own_path();
            // Grown by doubling, but never past the limit of moves (checked
            // block by block): the old and the new buffer together stay
            // within the two segments a move the memory bound allows
            // (dexcut's bounds::max_path_segments). Doubling past it made a
            // 600 MB address space abort at 1 048 576 moves of a 1 155 691 limit.
            let segments = &mut self.path.segments;
            if segments.len() == segments.capacity() {
                let want = (2 * segments.len())
                    .max(64)
                    .min(self.options.max_segments.saturating_add(1))
                    .max(segments.len() + 1);
                segments.reserve_exact(want - segments.len());
            }
            segments.push(segment);
        }
        // Only the re-feed writer reads the trace, and only from a recorded
        // run: a program parsed to be simulated keeps none (56 B a segment).
        if self.executed.is_none() {
            return;
        }
        let mut offset_mm = self.offset();
        offset_mm[2] -= self.tool_length_mm;
        self.trace.push(SegmentTrace {
            line_index: pc,
            scale: self.scale,
            incremental: self.incremental,
            arc_incremental: self.arc_incremental,
            inverse_time: self.inverse_time,
            offset_mm,
            feed_scale: self.feed_scale,
            compensated: self.comp_active(),
            rotated: self.rotation() != 0.0,
            spindle_cycle: matches!(
                self.motion,
                GCode::G74 | GCode::G84 | GCode::G86 | GCode::G87
            ),
        });
    }

    /// Segments made so far (those of a lent path included).
    pub(super) fn segment_count(&self) -> usize {
        self.path.segments.len() + self.lent.map_or(0, |l| l.matched)
    }

    /// The run's path its own: the lent segments it made so far copied into
    /// it, and no more compared (before a segment's index is taken).
    pub(super) fn own_path(&mut self) {
        if let Some(l) = self.lent.take() {
            self.path.segments = l.path[..l.matched].to_vec();
        }
    }

    /// Feed motion for a G1/G2/G3 of known geometry.
    pub(super) fn feed_motion(&self, b: &Block, length_mm: f64) -> Result<Motion, Fail> {
        if self.inverse_time {
            let f = b.get('f').ok_or(Fail {
                col: b.first_col,
                msg: "F word missing with inverse time (G93) feed move".into(),
            })?;
            if f <= 0.0 {
                return fail(b.col('f'), "inverse time feed must be positive");
            }
            Ok(Motion::feed(length_mm * f))
        } else if self.feed_mm_min <= 0.0 {
            fail(b.first_col, "feed move with zero feed rate (no F word yet)")
        } else {
            Ok(Motion::feed(self.feed_mm_min))
        }
    }

    pub(super) fn motion_block(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let machine = b.has_g(GCode::G53).is_some();
        if machine && !matches!(self.motion, GCode::G0 | GCode::G1) {
            return fail(b.has_g(GCode::G53).unwrap_or(1), "G53 needs G0 or G1");
        }
        let t = self.target(b, machine)?;
        if self.comp_active() {
            if machine {
                return fail(
                    b.has_g(GCode::G53).unwrap_or(1),
                    "cannot use G53 with cutter radius compensation",
                );
            }
            if self.inverse_time {
                return fail(
                    b.first_col,
                    "inverse time feed (G93) with cutter radius compensation is not supported",
                );
            }
            match self.motion {
                GCode::G0 => return self.straight_comp(b, t, Motion::Rapid, pc),
                GCode::G1 => {
                    let m = self.feed_motion(b, 1.0)?;
                    return self.straight_comp(b, t, m, pc);
                }
                code if code.is_canned_cycle() => {
                    return fail(
                        b.first_col,
                        "cannot use canned cycles with cutter radius compensation",
                    )
                }
                _ => {}
            }
        }
        if matches!(self.motion, GCode::G0 | GCode::G1) {
            self.comp.arc_not_allowed = false;
        }
        let done = match self.motion {
            GCode::G0 => {
                self.rapid(t, pc);
                Ok(())
            }
            GCode::G1 => {
                let len = (Point3::from(t) - Point3::from(self.pos)).norm();
                if len > 0.0 {
                    let m = self.feed_motion(b, len)?;
                    self.push(t, Geometry::Line, m, pc, false);
                }
                Ok(())
            }
            GCode::G2 | GCode::G3 => self.arc(b, t, pc),
            code if code.is_canned_cycle() => return self.cycle(b, pc),
            _ => return fail(b.first_col, format!("{} is not supported", self.motion)),
        };
        if done.is_err() {
            // Later blocks start where this one meant to end: one error per
            // problem, not a cascade of follow-on errors.
            self.pos = t;
        }
        done
    }

    /// A block whose only motion word is G2 or G3, with no axis, R, I, J or
    /// K word: an error in LinuxCNC (an arc with no end or centre); read
    /// tolerantly, it sets the arc mode for the axis words of a later block,
    /// as Fanuc-style controls (UCCNC, Mach3) read it, and the word is
    /// dropped here and written on that block
    /// ([`Interp::arc_mode_written_here`]).
    pub(super) fn lone_arc_mode(&mut self, b: &Block, pc: usize) -> bool {
        let Some(&(code, col)) = b.g.iter().find(|g| g_group(g.0) == Some(1)) else {
            return false;
        };
        let words = ['r', 'i', 'j', 'k'].iter().any(|&l| b.get(l).is_some());
        if !matches!(code, GCode::G2 | GCode::G3) || b.has_axes() || words {
            return false;
        }
        let Some(span) = self.item_span(pc, col) else {
            return false;
        };
        let what = format!("{code} alone on its line sets the arc mode for the next block's axis words, as Fanuc-style controls (UCCNC, Mach3) read it; written on that block");
        self.tolerate(span, String::new(), col, what)
    }

    /// The G2 or G3 read alone on an earlier line ([`Interp::lone_arc_mode`])
    /// written before this block's first axis word, which moves in it.
    pub(super) fn arc_mode_written_here(&mut self, b: &Block, pc: usize) {
        let Some(code) = self.tolerated.lone_arc.take() else {
            return;
        };
        let col = b.first_axis_col();
        if let Some(span) = self.item_span(pc, col) {
            let what = format!("{code} from the line where it stood alone written here");
            self.tolerate(span.start..span.start, format!("{code} "), col, what);
        }
    }

    /// Axis words with G80 in force: an error, as in LinuxCNC; read
    /// tolerantly, a move in the G0/G1 mode set before the canned cycle, as
    /// Fanuc-style controls (Mach3) make it, written with that G code.
    pub(super) fn axis_words_after_g80(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let col = b.first_axis_col();
        if let (Some(code), Some(span)) = (self.tolerated.plain_motion, self.item_span(pc, col)) {
            let what = format!("axis words after G80 moved in {code}, the mode before the canned cycle, as Fanuc-style controls do; written with {code}");
            if self.tolerate(span.start..span.start, format!("{code} "), col, what) {
                self.motion = code;
                return Ok(());
            }
        }
        fail(
            b.first_col,
            "axis words without a motion mode (G80 is active)",
        )
    }

    fn arc(&mut self, b: &Block, end: [f64; 3], pc: usize) -> Result<(), Fail> {
        let clockwise = self.motion == GCode::G2;
        let (a, bb, n) = self.plane.axes();
        let letters = ['i', 'j', 'k'];
        let off_word = letters[n];
        let tolerated = b.get(off_word).is_some_and(|v| {
            let col = b.col(off_word);
            let letter = off_word.to_ascii_uppercase();
            self.item_span(pc, col).is_some_and(|span| {
                self.tolerate(span, String::new(), col, format!("{letter}{v} on an arc in this plane ignored, as GRBL does; written without it"))
            })
        });
        if b.get(off_word).is_some() && !tolerated {
            return fail(
                b.col(off_word),
                format!(
                    "{} word not allowed for an arc in this plane",
                    off_word.to_ascii_uppercase()
                ),
            );
        }
        if self.comp.arc_not_allowed {
            return fail(
                b.first_col,
                "the move just after exiting cutter compensation (G40) must be straight",
            );
        }
        if self.rotation() != 0.0 && self.plane != crate::path::Plane::XY {
            return fail(
                b.first_col,
                format!(
                    "an arc outside the XY plane (G18, G19) in a coordinate system rotated by G10 L2 R ({} degrees) is not supported",
                    self.rotation()
                ),
            );
        }
        // Under compensation the arc is defined on the programmed contour.
        let start = if self.comp_active() && !self.comp.first {
            self.comp.program
        } else {
            self.pos
        };
        let center = self.arc_center(b, start, end)?;
        let col = b.first_col;
        let r = (start[a] - center[a]).hypot(start[bb] - center[bb]);
        if r == 0.0 {
            return fail(col, "arc of zero radius");
        }
        let turns = b.get('p').unwrap_or(1.0);
        if turns < 1.0 || turns.fract() != 0.0 || turns > 1e4 {
            return fail(
                b.col('p'),
                "P (turns) of an arc must be an integer from 1 to 10000",
            );
        }
        if self.comp_active() {
            let motion = self.feed_motion(b, 0.0)?;
            return self.arc_comp(b, end, [center[a], center[bb]], turns as i32, motion, pc);
        }
        self.arc_from(b, start, end, center, clockwise, turns, pc)
    }

    /// Centre (gauge frame) of the block's arc from `start` to `end`, with
    /// LinuxCNC's R and I/J/K tolerances.
    fn arc_center(&self, b: &Block, start: [f64; 3], end: [f64; 3]) -> Result<[f64; 3], Fail> {
        let clockwise = self.motion == GCode::G2;
        let (a, bb, _) = self.plane.axes();
        let letters = ['i', 'j', 'k'];
        let mut center = start;
        let col = b.first_col;
        if let Some(r) = b.get('r') {
            if b.get(letters[a]).is_some() || b.get(letters[bb]).is_some() {
                return fail(b.col('r'), "mixed radius (R) and centre (I/J/K) format arc");
            }
            let r_mm = r * self.scale;
            let (dx, dy) = (end[a] - start[a], end[bb] - start[bb]);
            let half = 0.5 * dx.hypot(dy);
            if half == 0.0 {
                return fail(
                    b.col('r'),
                    "R format arc with end point equal to start point",
                );
            }
            // LinuxCNC's arc_data_r: a chord up to 2 × 0.00127 mm longer
            // than the diameter is a semicircle.
            let abs_r = r_mm.abs();
            if half - abs_r > RADIUS_TOLERANCE_MM || abs_r == 0.0 {
                return fail(
                    b.col('r'),
                    format!(
                        "arc radius {:.4} mm too small to reach the end point (half chord {half:.4} mm)",
                        abs_r
                    ),
                );
            }
            let half = if half / abs_r > 1.0 - 1e-12 {
                abs_r
            } else {
                half
            };
            let right = clockwise == (r_mm > 0.0);
            let theta = dy.atan2(dx)
                + if right {
                    -std::f64::consts::FRAC_PI_2
                } else {
                    std::f64::consts::FRAC_PI_2
                };
            let offset = abs_r * (half / abs_r).asin().cos();
            center[a] = 0.5 * (start[a] + end[a]) + offset * theta.cos();
            center[bb] = 0.5 * (start[bb] + end[bb]) + offset * theta.sin();
        } else {
            let (ca, cb) = (b.get(letters[a]), b.get(letters[bb]));
            if ca.is_none() && cb.is_none() {
                return fail(col, "arc needs R or centre (I/J/K) words");
            }
            let off = self.offset();
            let r = self.rotation();
            if r != 0.0 {
                // XY only (checked by the caller): I and J in the rotated frame.
                let ij = [
                    ca.unwrap_or(0.0) * self.scale,
                    cb.unwrap_or(0.0) * self.scale,
                ];
                if self.arc_incremental {
                    let [i, j] = rotate(ij, r);
                    center[a] = start[a] + i;
                    center[bb] = start[bb] + j;
                } else {
                    let c = self.to_machine([ij[0], ij[1], 0.0]);
                    center[a] = c[a];
                    center[bb] = c[bb];
                }
            }
            for (axis, v) in [(a, ca), (bb, cb)].into_iter().filter(|_| r == 0.0) {
                let v = v.unwrap_or(0.0) * self.scale;
                center[axis] = if self.arc_incremental {
                    start[axis] + v
                } else {
                    v + off[axis]
                };
            }
            // LinuxCNC's arc_data_ijk tolerances.
            let r1 = (start[a] - center[a]).hypot(start[bb] - center[bb]);
            let r2 = (end[a] - center[a]).hypot(end[bb] - center[bb]);
            if r1 < RADIUS_TOLERANCE_MM || r2 < RADIUS_TOLERANCE_MM {
                return fail(col, "arc of zero radius");
            }
            let spiral_mm = if self.scale == 1.0 {
                2.0 * 0.01 * std::f64::consts::SQRT_2
            } else {
                2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4
            };
            let abs_err = (r1 - r2).abs();
            if abs_err > 100.0 * spiral_mm || (abs_err / r1.max(r2) > 0.001 && abs_err > spiral_mm)
            {
                return fail(
                    col,
                    format!(
                        "radius to end of arc differs from radius to start ({r1:.4} vs {r2:.4} mm)"
                    ),
                );
            }
        }
        Ok(center)
    }

    /// Appends the arc from `start` about `center` to `end`.
    #[allow(clippy::too_many_arguments)]
    fn arc_from(
        &mut self,
        b: &Block,
        start: [f64; 3],
        end: [f64; 3],
        center: [f64; 3],
        clockwise: bool,
        turns: f64,
        pc: usize,
    ) -> Result<(), Fail> {
        let (a, bb, _) = self.plane.axes();
        let a0 = (start[bb] - center[bb]).atan2(start[a] - center[a]);
        let a1 = (end[bb] - center[bb]).atan2(end[a] - center[a]);
        let tau = std::f64::consts::TAU;
        let mut sweep = if clockwise { a0 - a1 } else { a1 - a0 }.rem_euclid(tau);
        if sweep < 1e-12 || (start[a] == end[a] && start[bb] == end[bb]) {
            sweep = tau;
        }
        sweep += (turns - 1.0) * tau;
        let geometry = Geometry::Arc {
            center: Point3::from(center),
            plane: self.plane,
            clockwise,
            sweep_rad: sweep,
        };
        let motion = self.feed_motion(
            b,
            geometry.length_mm(&Point3::from(start), &Point3::from(end)),
        )?;
        self.push(end, geometry, motion, pc, false);
        Ok(())
    }
}
