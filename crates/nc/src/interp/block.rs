//! One block: its words evaluated and checked (modal groups, words with
//! nothing to use them), then executed in LinuxCNC's order.

use super::state::Spindle;
use super::{fail, Fail, Interp};
use crate::gcode::integer_value;
use crate::gcode::GCode;
use crate::path::{Geometry, Motion, PathControl, PathControlChange, Plane};
use crate::syntax::{Item, ItemKind, PlainWordValue};

/// A block after evaluation of its words.
#[derive(Default)]
pub(super) struct Block {
    /// G codes with columns.
    pub(super) g: Vec<(GCode, u32)>,
    pub(super) m: Vec<(i32, u32)>,
    /// Letter values and columns, indexed by [`slot`], where `present`
    /// has the slot's bit (side by side rather than as options: a block is
    /// made and moved for every line run).
    values: [f64; 28],
    cols: [u32; 28],
    present: u32,
    pub(super) first_col: u32,
}

/// Index of a word letter: a–z, then `@` (polar radius) and `^` (polar angle).
fn slot(letter: char) -> usize {
    match letter {
        '@' => 26,
        '^' => 27,
        l => (l as u8 - b'a') as usize,
    }
}

impl Block {
    pub(super) fn get(&self, letter: char) -> Option<f64> {
        let i = slot(letter);
        (self.present & (1 << i) != 0).then(|| self.values[i])
    }
    pub(super) fn col(&self, letter: char) -> u32 {
        let i = slot(letter);
        if self.present & (1 << i) != 0 {
            self.cols[i]
        } else {
            self.first_col
        }
    }
    pub(super) fn has_g(&self, code: GCode) -> Option<u32> {
        self.g.iter().find(|g| g.0 == code).map(|g| g.1)
    }
    pub(super) fn has_m(&self, code: i32) -> bool {
        self.m.iter().any(|m| m.0 == code)
    }
    /// Word `letter` (lower case) of value `v` at column `col` put in the
    /// block: a G or M code, or a letter's value (T, H and L whole
    /// numbers, as LinuxCNC reads them); a malformed code or a letter given
    /// twice is an error.
    fn put_word(&mut self, letter: char, v: f64, col: u32) -> Result<(), Fail> {
        match letter {
            'g' => {
                let Some(code) = GCode::from_value(v) else {
                    return fail(col, format!("G{v} is not a valid code"));
                };
                self.g.push((code, col));
            }
            'm' => {
                let Some(code) = integer_value(v).filter(|c| c.abs() <= 100_000) else {
                    return fail(col, format!("M{v} is not a valid code"));
                };
                self.m.push((code as i32, col));
            }
            l => {
                let v = match l {
                    't' | 'h' | 'l' => match integer_value(v) {
                        Some(n) => n as f64,
                        None => {
                            return fail(
                                col,
                                format!("{}{v} is not a whole number", l.to_ascii_uppercase()),
                            )
                        }
                    },
                    _ => v,
                };
                let i = slot(l);
                if self.present & (1 << i) != 0 {
                    return fail(
                        col,
                        format!("more than one {} word in the block", l.to_ascii_uppercase()),
                    );
                }
                self.present |= 1 << i;
                self.values[i] = v;
                self.cols[i] = col;
            }
        }
        Ok(())
    }
    /// The column of the block's first axis word (its first column if none).
    pub(super) fn first_axis_col(&self) -> u32 {
        ['x', 'y', 'z', '@', '^']
            .iter()
            .filter(|&&c| self.get(c).is_some())
            .map(|&c| self.col(c))
            .min()
            .unwrap_or(self.first_col)
    }

    pub(super) fn has_axes(&self) -> bool {
        ['x', 'y', 'z', '@', '^']
            .iter()
            .any(|&c| self.get(c).is_some())
    }
    /// Sets a two-state mode from the block's G code for it, if any (the two
    /// codes share a modal group, so at most one is present).
    fn set_mode(&self, mode: &mut bool, off_code: GCode, on_code: GCode) {
        if self.has_g(on_code).is_some() {
            *mode = true;
        } else if self.has_g(off_code).is_some() {
            *mode = false;
        }
    }
}

/// Modal group of a G code, `None` when unknown (LinuxCNC's table, keyed by
/// the code ×10).
pub(super) fn g_group(code: GCode) -> Option<u8> {
    Some(match code.tenths() {
        40 | 100 | 280 | 281 | 300 | 301 | 520 | 920 | 921 | 922 | 923 => 0,
        530 => 99,
        0 | 10 | 20 | 30 | 330 | 382 | 383 | 384 | 385 | 730 | 740 | 760 | 800..=890 => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 420 | 411 | 421 => 7,
        430 | 431 | 432 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        960 | 970 => 14,
        _ => return None,
    })
}

fn m_group(code: i32) -> Option<u8> {
    Some(match code {
        0 | 1 | 2 | 30 | 60 => 4,
        // Digital and analog outputs, waiting on an input: they move nothing.
        62..=68 => 5,
        6 | 61 => 6,
        3..=5 | 19 | 70..=73 => 7,
        7..=9 => 8,
        // Override switches: the run is simulated at 100 %.
        48..=53 => 10,
        98 | 99 => 11,
        _ => return None,
    })
}

impl Interp<'_> {
    fn eval_block(&mut self, items: &[Item]) -> Result<Block, Fail> {
        let mut b = Block {
            first_col: items.first().map_or(1, |i| i.col),
            ..Block::default()
        };
        let mut assignments = Vec::new();
        for item in items {
            let err = |msg| Fail { col: item.col, msg };
            match &item.kind {
                ItemKind::Assign(assign) => {
                    let (target, value) = &**assign;
                    let t = self.params.resolve(target).map_err(err)?;
                    let v = self.params.eval(value).map_err(err)?;
                    assignments.push((t, v));
                }
                ItemKind::Word { letter, value } => {
                    let v = self.params.eval(value).map_err(err)?;
                    b.put_word(*letter, v, item.col)?;
                }
            }
        }
        self.check_block(&mut b, assignments)?;
        Ok(b)
    }

    /// [`Interp::eval_block`] of a plain line's words
    /// ([`syntax::Lines::plain_block_words`](crate::syntax::Lines::plain_block_words)):
    /// the same block, or the same error, as its items give.
    fn eval_plain_block(&mut self, words: &[PlainWordValue]) -> Result<Block, Fail> {
        let mut b = Block {
            first_col: words.first().map_or(1, |w| w.col),
            ..Block::default()
        };
        for &PlainWordValue {
            letter,
            col,
            value: v,
        } in words
        {
            // As `Params::eval` refuses a number too large for an f64.
            if !v.is_finite() {
                return fail(col, "expression result is not a finite number");
            }
            b.put_word(letter, v, col)?;
        }
        self.check_block(&mut b, Vec::new())?;
        Ok(b)
    }

    /// The checks of a block whose words are in (modal groups, axes, E
    /// words), then its parameter assignments made: the end of
    /// [`Interp::eval_block`].
    fn check_block(
        &mut self,
        b: &mut Block,
        assignments: Vec<(crate::expr::Target, f64)>,
    ) -> Result<(), Fail> {
        for &(code, col) in &b.g {
            if g_group(code).is_none() {
                return fail(col, format!("unknown G code {code}"));
            }
        }
        // As in LinuxCNC, G80 gives way to another motion code in the block.
        if b.g
            .iter()
            .any(|g| g_group(g.0) == Some(1) && g.0 != GCode::G80)
        {
            b.g.retain(|g| g.0 != GCode::G80);
        } else if let Some(i) = b.g.iter().position(|g| g.0 == GCode::G80) {
            let mut k = 0;
            b.g.retain(|g| {
                k += 1;
                g.0 != GCode::G80 || k - 1 == i
            });
        }
        for (i, &(code, col)) in b.g.iter().enumerate() {
            let group = g_group(code);
            if let Some(&(other, _)) = b.g[..i].iter().find(|g| g_group(g.0) == group) {
                return fail(
                    col,
                    format!("{other} and {code} are in the same modal group"),
                );
            }
        }
        for (i, &(code, col)) in b.m.iter().enumerate() {
            let Some(group) = m_group(code) else {
                return fail(col, format!("unknown M code M{code}"));
            };
            if b.m[..i].iter().any(|m| m_group(m.0) == Some(group)) {
                return fail(
                    col,
                    format!("two M codes of the same modal group (M{code})"),
                );
            }
        }
        // The other axes start at 0; a word of 0 keeps one there in every
        // distance mode and offset (only 0 is read anywhere), so it moves
        // nothing: 4-axis posts park the rotary with it (Mastercam's
        // `G0 G90 G54 X… Y… A0.`). Any other value would move it.
        for l in ['a', 'b', 'c', 'u', 'v', 'w'] {
            if b.get(l).is_some_and(|v| v != 0.0) {
                return fail(
                    b.col(l),
                    format!(
                        "axis {} is not supported (3-axis X Y Z only; {}0, which keeps it at 0, is read)",
                        l.to_ascii_uppercase(),
                        l.to_ascii_uppercase()
                    ),
                );
            }
        }
        if b.get('e').is_some() && !(66..=68).any(|m| b.has_m(m)) {
            return fail(b.col('e'), "E word with no M66, M67 or M68 to use it");
        }
        for (t, v) in assignments {
            self.params.assign(&t, v);
        }
        Ok(())
    }

    /// Executes line `pc`'s block (`items`) in LinuxCNC's order; the line to
    /// run next, `None` at the program's end.
    pub(super) fn block(&mut self, pc: usize, items: &[Item]) -> Result<Option<usize>, Fail> {
        let b = self.eval_block(items)?;
        self.run_block(pc, &b)
    }

    /// [`Interp::block`] of a plain line's words
    /// ([`syntax::Lines::plain_block_words`](crate::syntax::Lines::plain_block_words)).
    pub(super) fn plain_block(
        &mut self,
        pc: usize,
        words: &[PlainWordValue],
    ) -> Result<Option<usize>, Fail> {
        let b = self.eval_plain_block(words)?;
        self.run_block(pc, &b)
    }

    /// Executes block `b` of line `pc`, its words evaluated and checked.
    fn run_block(&mut self, pc: usize, b: &Block) -> Result<Option<usize>, Fail> {
        self.feed_scale = self.scale;
        let g_col = |code| b.has_g(code);
        self.feed_spindle_and_tool(b, pc)?;
        self.motion_wait(b);
        self.inputs_and_outputs(b)?;
        self.m70_m73(b)?;
        self.dwell_and_modes(b, pc)?;
        // Non-modal group 0.
        let axis_user = b.g.iter().find(|g| {
            matches!(
                g.0,
                GCode::G10
                    | GCode::G28
                    | GCode::G30
                    | GCode::G52
                    | GCode::G92
                    | GCode::G43_1
                    | GCode::G43_2
            )
        });
        let motion_code = b.g.iter().find(|g| g_group(g.0) == Some(1)).copied();
        // As LinuxCNC (its check_other_codes): a P, Q, L or R word needs
        // something in the block to use it (Snapmaker's `M3 P100`, a spindle
        // power in percent, is refused there and by GRBL; a stray word would
        // make the written program one the control refuses). The motion it
        // would serve is the block's own, or the modal one when the block
        // has axis words.
        let motion = motion_code
            .map(|m| m.0)
            .or(b.has_axes().then_some(self.motion));
        let cycle = motion.is_some_and(GCode::is_canned_cycle);
        let in_block = |codes: &[GCode]| codes.iter().any(|&g| g_col(g).is_some());
        let m_in = |used: fn(i32) -> bool| b.m.iter().any(|m| used(m.0));
        // Whether the block uses its P, Q, L or R word (asked only where it has one).
        let used = |letter: char| match letter {
            'p' => {
                matches!(
                    motion,
                    Some(
                        GCode::G2
                            | GCode::G3
                            | GCode::G74
                            | GCode::G82
                            | GCode::G84
                            | GCode::G86
                            | GCode::G89
                    )
                ) || in_block(&[GCode::G4, GCode::G10, GCode::G64])
                    || m_in(|m| matches!(m, 19 | 50..=53 | 62..=66 | 98))
            }
            'q' => {
                matches!(motion, Some(GCode::G73 | GCode::G83))
                    || in_block(&[GCode::G10, GCode::G64])
                    || m_in(|m| matches!(m, 19 | 61 | 66..=68))
            }
            'l' => {
                cycle
                    || in_block(&[
                        GCode::G10,
                        GCode::G41,
                        GCode::G41_1,
                        GCode::G42,
                        GCode::G42_1,
                    ])
                    || m_in(|m| matches!(m, 66 | 98))
            }
            _ => {
                matches!(motion, Some(GCode::G2 | GCode::G3))
                    || cycle
                    || in_block(&[GCode::G10])
                    || m_in(|m| m == 19)
            }
        };
        let words = [
            ('p', "P word with no G2, G3, G4, G10, G64, G74, G82, G84, G86, G89, M19, M50-M53, M62-M66 or M98 to use it"),
            ('q', "Q word with no G10, G64, G73, G83, M19, M61, M66, M67 or M68 to use it"),
            ('l', "L word with no G10, cutter compensation, canned cycle, M66 or M98 to use it"),
            ('r', "R word with no G2, G3, G10, canned cycle or M19 to use it"),
        ];
        if let Some(&(letter, message)) = words
            .iter()
            .find(|&&(letter, _)| b.get(letter).is_some() && !used(letter))
        {
            return fail(b.col(letter), message);
        }
        if let (Some(&(a, col)), Some((m, _))) = (axis_user, motion_code) {
            if m != GCode::G80 && b.has_axes() {
                return fail(col, format!("{a} and {m} both use axis words"));
            }
        }
        if let Some(&(code, col)) =
            axis_user.filter(|g| !matches!(g.0, GCode::G43_1 | GCode::G43_2))
        {
            self.modal0(code, col, b, pc)?;
        } else if g_col(GCode::G92_1).is_some() {
            // LinuxCNC's convert_axis_offsets: the machine does not move;
            // G92.1 clears the saved offset too, G92.2 keeps it for G92.3.
            self.g92 = [0.0; 3];
            self.g92_saved = [0.0; 3];
        } else if let Some(col) = g_col(GCode::G28_1).or(g_col(GCode::G30_1)) {
            // LinuxCNC's convert_savehome: the current point is the home.
            if self.comp.side.is_some() {
                return fail(
                    col,
                    "cannot set reference point with cutter compensation in effect",
                );
            }
            self.homes_mm[usize::from(g_col(GCode::G30_1).is_some())] = self.pos;
        } else if g_col(GCode::G92_2).is_some() {
            self.g92 = [0.0; 3];
        } else if g_col(GCode::G92_3).is_some() {
            self.g92 = self.g92_saved;
        }
        self.previous_motion = self.motion;
        if let Some((code, _)) = motion_code {
            self.motion = code;
            self.tolerated.lone_arc = None;
            if matches!(code, GCode::G0 | GCode::G1 | GCode::G2 | GCode::G3) {
                self.tolerated.plain_motion = Some(code);
            }
            if !code.is_canned_cycle() {
                self.cycle_initial_z = None;
            }
        }
        let use_motion = axis_user.is_none() && (motion_code.is_some() || b.has_axes());
        if use_motion {
            if self.motion == GCode::G80 && b.has_axes() {
                self.axis_words_after_g80(b, pc)?;
            }
            if self.motion == GCode::G80 {
                self.cycle_r = None;
                self.cycle_z = None;
            } else if let Some((code, _)) = motion_code.filter(|_| self.lone_arc_mode(b, pc)) {
                // Nothing moves: the arc mode waits for the next axis words.
                self.tolerated.lone_arc = Some(code);
            } else if b.has_axes() || matches!(self.motion, GCode::G2 | GCode::G3) {
                if motion_code.is_none() {
                    self.arc_mode_written_here(b, pc);
                }
                self.motion_block(b, pc)?;
            }
        }
        if !matches!(self.motion, GCode::G2 | GCode::G3 | GCode::G87) || !use_motion {
            for l in ['i', 'j', 'k'] {
                if b.get(l).is_some() {
                    return fail(
                        b.col(l),
                        format!(
                            "{} word with no G2, G3 or G87 to use it",
                            l.to_ascii_uppercase()
                        ),
                    );
                }
            }
        }
        self.program_flow(b, pc)
    }

    /// The block's feed mode (G93/G94; G95 refused), F and S words, T word,
    /// tool change (M6, M61) and spindle (M3, M4, M5, M19): the first of
    /// [`Interp::block`]'s steps.
    fn feed_spindle_and_tool(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let g_col = |code| b.has_g(code);
        // Feed mode, feed, speed, tool, spindle.
        if let Some(col) = g_col(GCode::G95) {
            return fail(col, "G95 feed per revolution is not supported");
        }
        b.set_mode(&mut self.inverse_time, GCode::G94, GCode::G93);
        if let Some(f) = b.get('f') {
            if f < 0.0 {
                return fail(b.col('f'), "negative feed rate");
            }
            if !self.inverse_time {
                self.feed_mm_min = f * self.scale;
            }
        }
        if let Some(s) = b.get('s') {
            if s < 0.0 {
                return fail(b.col('s'), "negative spindle speed");
            }
            self.spindle_rpm = s;
        }
        if let Some(t) = b.get('t') {
            self.selected_tool = Some(self.tool_number(t, b.col('t'), 'T')?);
        }
        if (b.has_m(6) || b.has_m(61)) && self.comp.side.is_some() {
            return fail(
                b.first_col,
                "cannot change tools with cutter radius compensation on",
            );
        }
        if b.has_m(6) {
            self.load_tool(self.selected_tool.unwrap_or(self.tool), pc);
        }
        if b.has_m(61) {
            let q = b.get('q').ok_or(Fail {
                col: b.first_col,
                msg: "M61 needs a Q word (tool number)".into(),
            })?;
            // LinuxCNC rounds M61's Q to the nearest whole number (round_to_int).
            let t = self.tool_number(q.round_ties_even(), b.col('q'), 'Q')?;
            self.load_tool(t, pc);
        }
        if b.has_m(3) {
            self.spindle = Spindle::Clockwise;
        }
        if b.has_m(4) {
            self.spindle = Spindle::Counterclockwise;
        }
        // M19 orients the spindle: it stops turning until the next M3 or M4.
        if b.has_m(5) || b.has_m(19) {
            self.spindle = Spindle::Stopped;
        }
        Ok(())
    }

    /// The block's dwell (G4), plane, units, cutter compensation, tool length
    /// offset, work offset, refused codes, and distance and retract modes, in
    /// that order (after the spindle, outputs and M70-M73 of
    /// [`Interp::block`]).
    fn dwell_and_modes(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let g_col = |code| b.has_g(code);
        if let Some(col) = g_col(GCode::G4) {
            let p = b.get('p').ok_or(Fail {
                col,
                msg: "G4 needs a P word (seconds)".into(),
            })?;
            if p < 0.0 {
                return fail(b.col('p'), "negative dwell time");
            }
            self.push(
                self.pos,
                Geometry::Line,
                Motion::Dwell { seconds: p },
                pc,
                true,
            );
        }
        for (code, plane) in [
            (GCode::G17, Plane::XY),
            (GCode::G18, Plane::ZX),
            (GCode::G19, Plane::YZ),
        ] {
            if g_col(code).is_some() {
                self.plane = plane;
            }
        }
        if g_col(GCode::G20).is_some() {
            self.scale = 25.4;
        }
        if g_col(GCode::G21).is_some() {
            self.scale = 1.0;
        }
        if g_col(GCode::G40).is_some() {
            self.comp_off()?;
        }
        let comp_code = [GCode::G41, GCode::G42, GCode::G41_1, GCode::G42_1]
            .into_iter()
            .find_map(|c| g_col(c).map(|col| (c, col)));
        match comp_code {
            Some((code, col)) => self.comp_on(code, b, col)?,
            None if b.get('d').is_some() => {
                return fail(b.col('d'), "D word with no G41 or G42 to use it")
            }
            None => {}
        }
        self.tool_length_offset(b)?;
        for (i, code) in [
            GCode::G54,
            GCode::G55,
            GCode::G56,
            GCode::G57,
            GCode::G58,
            GCode::G59,
        ]
        .into_iter()
        .enumerate()
        {
            if g_col(code).is_some() {
                self.coord = i;
            }
        }
        self.path_control(b);
        for code in [
            GCode::G59_1,
            GCode::G59_2,
            GCode::G59_3,
            GCode::G96,
            GCode::G33,
            GCode::G38_2,
            GCode::G38_3,
            GCode::G38_4,
            GCode::G38_5,
            GCode::G76,
            GCode::G88,
        ] {
            if let Some(col) = g_col(code) {
                return fail(col, format!("{code} is not supported"));
            }
        }
        b.set_mode(&mut self.incremental, GCode::G90, GCode::G91);
        b.set_mode(&mut self.arc_incremental, GCode::G90_1, GCode::G91_1);
        b.set_mode(&mut self.retract_to_start, GCode::G99, GCode::G98);
        Ok(())
    }

    /// The block's G61, G61.1 or G64 (P, Q in the block's units), recorded on
    /// the path for the moves made after it (LinuxCNC's
    /// `convert_control_mode`: a negative or missing P or Q is no P or Q).
    fn path_control(&mut self, b: &Block) {
        let mode = if b.has_g(GCode::G61).is_some() {
            PathControl::ExactPath
        } else if b.has_g(GCode::G61_1).is_some() {
            PathControl::ExactStop
        } else if b.has_g(GCode::G64).is_some() {
            let mm = |w: char| b.get(w).filter(|v| *v >= 0.0).map(|v| v * self.scale);
            PathControl::Blend {
                tolerance_mm: mm('p'),
                naive_cam_mm: mm('q'),
            }
        } else {
            return;
        };
        let first_segment = self
            .lent
            .as_ref()
            .map_or(self.path.segments.len(), |l| l.matched);
        let changes = &mut self.path.path_control;
        if changes
            .last()
            .is_some_and(|c| c.first_segment == first_segment)
        {
            changes.pop();
        }
        changes.push(PathControlChange {
            first_segment,
            mode,
        });
    }

    /// Records where a control waits for motion to stop before the block:
    /// spindle (M3, M4, M5, M19, an S word), coolant (M7, M8, M9), tool
    /// change (M6, M61) and pauses (M0, M1), as LinuxCNC's task does.
    fn motion_wait(&mut self, b: &Block) {
        let waits =
            b.get('s').is_some() || b.m.iter().any(|m| matches!(m.0, 0 | 1 | 3..=9 | 19 | 61));
        if !waits {
            return;
        }
        let at = self
            .lent
            .as_ref()
            .map_or(self.path.segments.len(), |l| l.matched);
        if self.path.motion_waits.last() != Some(&at) {
            self.path.motion_waits.push(at);
        }
    }

    /// M19's words, and the outputs and input waits (M62–M68) as LinuxCNC
    /// checks them. None moves an axis; a wait (M66 with L1–L4) takes the
    /// run no time, since the input's change cannot be known: a warning.
    fn inputs_and_outputs(&mut self, b: &Block) -> Result<(), Fail> {
        if b.has_m(19) && b.get('p').is_some_and(|p| ![0.0, 1.0, 2.0].contains(&p)) {
            return fail(b.col('p'), "P value must be 0, 1 or 2 with M19");
        }
        let col = |m: i32| b.m.iter().find(|c| c.0 == m).map_or(b.first_col, |c| c.1);
        if let Some(m) = (62..=65).find(|&m| b.has_m(m)) {
            if b.get('p').is_none() {
                return fail(col(m), format!("M{m} needs a P word (the output's number)"));
            }
        }
        if b.has_m(66) {
            let (p, e) = (b.get('p'), b.get('e'));
            let wait = b.get('l').unwrap_or(0.0);
            match (p, e) {
                (None, None) => {
                    return fail(
                        col(66),
                        "M66 needs a P word (digital input) or an E word (analog input)",
                    )
                }
                (Some(_), Some(_)) => {
                    return fail(
                        b.col('e'),
                        "M66 selects a digital (P) or an analog (E) input, not both",
                    )
                }
                (None, Some(_)) if wait != 0.0 => {
                    return fail(
                        b.col('l'),
                        "M66 waits on an analog input (E) only with L0 (immediate)",
                    )
                }
                _ => {}
            }
            if wait != 0.0 {
                let timeout_s = b.get('q').unwrap_or(0.0);
                if timeout_s <= 0.0 {
                    return fail(
                        col(66),
                        "M66 with a wait (L1-L4) needs a Q word (timeout, seconds)",
                    );
                }
                self.warn(
                    col(66),
                    format!("M66 waits for an input (up to {timeout_s} s): the run is simulated without the wait"),
                );
            }
        }
        if let Some(m) = [67, 68].into_iter().find(|&m| b.has_m(m)) {
            if b.get('e').is_none() {
                return fail(
                    col(m),
                    format!("M{m} needs an E word (the analog output's number)"),
                );
            }
        }
        Ok(())
    }
}
