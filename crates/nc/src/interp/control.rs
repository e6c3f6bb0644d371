//! Program flow: the run over the lines, o-word subroutines, branches and
//! loops, and the call frames of o-word and Fanuc (M98/M99) calls.

use std::rc::Rc;

use super::{fail, Block, Executed, Fail, FileForm, Interp};
use crate::amend::Amendment;
use crate::gcode::integer_value;
use crate::syntax::{self, LineKind, OKeyword, OLabel, OStmt};

pub(super) enum Frame {
    Fanuc {
        return_pc: usize,
        start: usize,
        remaining: u32,
        /// Segments made before the first run (`None` after it).
        first_run_from: Option<usize>,
    },
    OSub {
        return_pc: usize,
        saved: Box<[f64; 30]>,
    },
}

/// What the tolerant form writes for a closing '%' the program did not open.
const PERCENT_CLOSE_AS_END: &str =
    "M2 (program end: the original closed with a '%' it did not open)";

impl Interp<'_> {
    pub(super) fn execute(&mut self) {
        let mut pc = 0usize;
        let mut executed = 0u64;
        let mut seen_percent = false;
        let lines = Rc::clone(&self.lines);
        // A block's items parsed again where they are not kept.
        let mut again = Vec::new();
        let mut plain = syntax::PlainBlockWords::default();
        while pc < lines.len() {
            executed += 1;
            if executed > self.options.max_blocks {
                self.line_index = pc;
                self.report(
                    1,
                    format!(
                        "more than {} blocks executed; endless loop?",
                        self.options.max_blocks
                    ),
                );
                return;
            }
            if self.segment_count() > self.options.max_segments {
                let message = match self.last_loop {
                    Some((line, col)) => {
                        self.line_index = line;
                        (col, format!(
                            "this loop made the program more than {} moves (the limit) before its end",
                            self.options.max_segments
                        ))
                    }
                    None => (
                        1,
                        format!(
                            "the program makes more than {} moves (the limit)",
                            self.options.max_segments
                        ),
                    ),
                };
                self.report(message.0, message.1);
                return;
            }
            self.line_index = pc;
            if self.toolchange_pending {
                // LinuxCNC's refresh_actual_position after a tool change:
                // the program point is the canon's, which ignores a tool
                // length offset changed since the last move (rs274 does so).
                self.toolchange_pending = false;
                self.pos = std::array::from_fn(|i| self.canon_mm[i] + self.tlo_mm[i]);
            }
            let Some(line) = &lines[pc] else {
                if let Some(e) = self.syntax_errors.get(&pc) {
                    let e = e.clone();
                    self.report(e.col, e.message);
                }
                pc += 1;
                continue;
            };
            if line.block_delete && self.options.block_delete {
                pc += 1;
                continue;
            }
            let segments_before = self.segment_count() as u32;
            if let Some(executed) = &mut self.executed {
                executed.push(Executed {
                    line_index: pc as u32,
                    depth: self.frames.len() as u32,
                    segments_before,
                });
            }
            let next = match &line.kind {
                LineKind::Empty | LineKind::ProgramNumber(_) => Ok(Some(pc + 1)),
                // As LinuxCNC: '%' opens a program on the first line and
                // then closes it; anywhere else it is an error.
                LineKind::Percent { .. } if seen_percent => Ok(None),
                LineKind::Percent { .. } if pc == 0 => {
                    seen_percent = true;
                    Ok(Some(pc + 1))
                }
                // CAMotics' sample programs close with a '%' they never
                // opened; CAMotics and GRBL read them. The tolerant form
                // reads that '%' as the program's end and writes M2 there.
                LineKind::Percent { at, col } if self.closes_unopened(&lines, pc, *at, *col) => Ok(None),
                LineKind::Percent { col, .. } => Err(Fail {
                    col: *col,
                    msg: "'%' is allowed only on the first line and to close a program opened with it".into(),
                }),
                LineKind::OWord(stmt) => self.oword(pc, stmt),
                LineKind::Block(_) if lines.plain_block_words(pc, self.source, &mut plain) => {
                    self.plain_block(pc, plain.words())
                }
                LineKind::Block(_) => {
                    let items = lines.block_items(pc, self.source, &mut again);
                    self.block(pc, items.expect("a block's items"))
                }
            };
            match next {
                Ok(Some(n)) => pc = n,
                Ok(None) => {
                    self.ended = true;
                    return;
                }
                Err(f) => {
                    self.report(f.col, f.msg);
                    if self.halted {
                        return;
                    }
                    pc += 1;
                }
            }
        }
        // As LinuxCNC: a program ends with M2, M30 or a closing '%'.
        self.line_index = lines.len().saturating_sub(1);
        match self.options.file_form {
            FileForm::Fragment => {}
            FileForm::LinuxCnc => self.report(
                1,
                "file ended with no program end (M2 or M30) or closing '%'".into(),
            ),
            FileForm::Tolerant => {
                self.tolerated.amendments.push(Amendment::AppendProgramEnd);
                self.warn(
                    1,
                    "file ended with no program end (M2 or M30) or closing '%': the program ends at its last line (LinuxCNC would refuse the file)".into(),
                )
            }
        }
    }

    /// In the tolerant form, whether the '%' of line `pc`, not on the first
    /// line, is the file's last line but blank ones: then it is read as the
    /// program's end and written as `M2`, with a warning.
    fn closes_unopened(&mut self, lines: &syntax::Lines, pc: usize, at: u32, col: u32) -> bool {
        let last = (pc + 1..lines.len()).all(|i| {
            matches!(
                &lines[i],
                Some(syntax::Line {
                    kind: LineKind::Empty,
                    ..
                })
            )
        });
        last && self.tolerate(
            at as usize..at as usize + 1,
            PERCENT_CLOSE_AS_END.into(),
            col,
            "'%' closes a program it did not open (CAMotics' and GRBL's form): read as the program's end, written as M2".into(),
        )
    }

    /// Column of the o-word statement on line `line` (1 if none).
    fn o_col(&self, line: usize) -> u32 {
        match &self.lines[line] {
            Some(syntax::Line {
                kind: LineKind::OWord(stmt),
                ..
            }) => stmt.col,
            _ => 1,
        }
    }

    /// Column of the M98 word on line `line` (1 if not found).
    fn m98_col(&self, line: usize) -> u32 {
        let mut again = Vec::new();
        self.lines
            .block_items(line, self.source, &mut again)
            .and_then(|items| {
                items.iter().find_map(|i| match &i.kind {
                    syntax::ItemKind::Word { letter: 'm', value }
                        if self.params.eval(value).ok() == Some(98.0) =>
                    {
                        Some(i.col)
                    }
                    _ => None,
                })
            })
            .unwrap_or(1)
    }

    /// After the first of a loop's `runs` runs, which made `per_run`
    /// segments: where the runs would take the program past the limit of
    /// moves, the run stops with an error at the loop's line and column
    /// (before the moves are made: `o1 repeat [1000000000]` around two lines
    /// would otherwise fill memory).
    fn foresee(
        &mut self,
        line: usize,
        col: u32,
        per_run: usize,
        runs: f64,
        what: &str,
    ) -> Result<(), Fail> {
        let made = self.segment_count() as f64;
        let total = made + per_run as f64 * (runs - 1.0);
        if total <= self.options.max_segments as f64 {
            return Ok(());
        }
        self.line_index = line;
        self.halted = true;
        fail(
            col,
            format!(
                "this {what} would make the program {total:.4e} moves ({per_run} a run, {runs:.0} runs), more than the limit of {}",
                self.options.max_segments
            ),
        )
    }

    /// Finds the next (or previous) o-word with `label` and one of `keywords`.
    fn find_o(
        &self,
        from: usize,
        label: &OLabel,
        keywords: &[OKeyword],
        forward: bool,
    ) -> Option<usize> {
        let matches = |i: &usize| {
            matches!(&self.lines[*i], Some(syntax::Line { kind: LineKind::OWord(s), .. })
                if keywords.contains(&s.keyword))
        };
        let at = self.olines.get(label)?;
        if forward {
            let k = at.partition_point(|&i| i <= from);
            at[k..].iter().copied().find(matches)
        } else {
            let k = at.partition_point(|&i| i < from);
            at[..k].iter().rev().copied().find(matches)
        }
    }

    fn cond(&self, stmt: &OStmt) -> Result<bool, Fail> {
        let e = stmt.args.first().ok_or(Fail {
            col: stmt.col,
            msg: "missing [condition]".into(),
        })?;
        Ok(self
            .params
            .eval(e)
            .map_err(|msg| Fail { col: stmt.col, msg })?
            != 0.0)
    }

    fn oword(&mut self, pc: usize, s: &OStmt) -> Result<Option<usize>, Fail> {
        use OKeyword as K;
        let missing = |what: &str| Fail {
            col: s.col,
            msg: format!("no matching '{what}' for this o-word"),
        };
        let after =
            |r: Option<usize>, what: &str| r.map(|i| Some(i + 1)).ok_or_else(|| missing(what));
        match s.keyword {
            K::Sub => after(self.find_o(pc, &s.label, &[K::EndSub], true), "endsub"),
            K::EndSub | K::Return => match self.frames.pop() {
                Some(Frame::OSub { return_pc, saved }) => {
                    if let Some(e) = s.args.first() {
                        let v = self
                            .params
                            .eval(e)
                            .map_err(|msg| Fail { col: s.col, msg })?;
                        self.params.pop_scope(&saved);
                        self.params.set_named("_value", v);
                    } else {
                        self.params.pop_scope(&saved);
                    }
                    self.leave_call_level();
                    Ok(Some(return_pc))
                }
                Some(other) => {
                    self.frames.push(other);
                    fail(s.col, "endsub/return inside an M98 subprogram")
                }
                None => fail(s.col, "endsub/return outside a subroutine"),
            },
            K::Call => {
                let start = self
                    .olines
                    .get(&s.label)
                    .and_then(|at| {
                        at.iter().copied().find(|&i| {
                            matches!(&self.lines[i], Some(syntax::Line { kind: LineKind::OWord(d), .. })
                                if d.keyword == K::Sub)
                        })
                    })
                    .ok_or_else(|| Fail {
                        col: s.col,
                        msg: "called subroutine is not defined".into(),
                    })?;
                if self.frames.len() >= 64 {
                    return fail(s.col, "subroutine calls nested too deeply");
                }
                let args = s
                    .args
                    .iter()
                    .map(|e| self.params.eval(e))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|msg| Fail { col: s.col, msg })?;
                let saved = self.params.push_scope(&args);
                self.frames.push(Frame::OSub {
                    return_pc: pc + 1,
                    saved: Box::new(saved),
                });
                self.enter_call_level();
                Ok(Some(start + 1))
            }
            K::If => {
                let mut i = pc;
                let mut stmt = s;
                loop {
                    if self.cond(stmt)? {
                        return Ok(Some(i + 1));
                    }
                    i = self
                        .find_o(i, &s.label, &[K::ElseIf, K::Else, K::EndIf], true)
                        .ok_or_else(|| missing("endif"))?;
                    match &self.lines[i] {
                        Some(syntax::Line {
                            kind: LineKind::OWord(next),
                            ..
                        }) if next.keyword == K::ElseIf => stmt = next,
                        _ => return Ok(Some(i + 1)),
                    }
                }
            }
            K::ElseIf | K::Else => after(self.find_o(pc, &s.label, &[K::EndIf], true), "endif"),
            K::EndIf | K::Do => Ok(Some(pc + 1)),
            K::While => {
                let end = self.find_o(pc, &s.label, &[K::EndWhile], true);
                match end {
                    Some(end) => Ok(Some(if self.cond(s)? {
                        pc + 1
                    } else {
                        self.last_loop = None;
                        end + 1
                    })),
                    None => {
                        let d = self
                            .find_o(pc, &s.label, &[K::Do], false)
                            .ok_or_else(|| missing("endwhile"))?;
                        if self.cond(s)? {
                            self.last_loop = Some((d, self.o_col(d)));
                            Ok(Some(d + 1))
                        } else {
                            self.last_loop = None;
                            Ok(Some(pc + 1))
                        }
                    }
                }
            }
            K::EndWhile => {
                let w = self
                    .find_o(pc, &s.label, &[K::While], false)
                    .ok_or_else(|| missing("while"))?;
                self.last_loop = Some((w, self.o_col(w)));
                Ok(Some(w))
            }
            K::Repeat => {
                let e = s.args.first().ok_or(Fail {
                    col: s.col,
                    msg: "missing [count]".into(),
                })?;
                let n = self
                    .params
                    .eval(e)
                    .map_err(|msg| Fail { col: s.col, msg })?
                    .round() as i64;
                if n > 0 {
                    self.repeats.insert(pc, n);
                    self.repeat_runs.insert(pc, (n, self.segment_count()));
                    Ok(Some(pc + 1))
                } else {
                    after(
                        self.find_o(pc, &s.label, &[K::EndRepeat], true),
                        "endrepeat",
                    )
                }
            }
            K::EndRepeat => {
                let start = self
                    .find_o(pc, &s.label, &[K::Repeat], false)
                    .ok_or_else(|| missing("repeat"))?;
                let left = self.repeats.entry(start).or_insert(1);
                *left -= 1;
                let left = *left;
                if left <= 0 {
                    self.last_loop = None;
                    return Ok(Some(pc + 1));
                }
                let col = self.o_col(start);
                self.last_loop = Some((start, col));
                if let Some(&(n, before)) = self.repeat_runs.get(&start) {
                    if left == n - 1 {
                        let per_run = self.segment_count() - before;
                        self.foresee(start, col, per_run, n as f64, "repeat")?;
                    }
                }
                Ok(Some(start + 1))
            }
            K::Break => {
                let end = self
                    .find_o(pc, &s.label, &[K::EndWhile, K::EndRepeat, K::While], true)
                    .ok_or_else(|| missing("endwhile/endrepeat"))?;
                Ok(Some(end + 1))
            }
            K::Continue => {
                if let Some(w) = self.find_o(pc, &s.label, &[K::While, K::Repeat], false) {
                    if matches!(&self.lines[w], Some(syntax::Line { kind: LineKind::OWord(t), .. }) if t.keyword == K::While)
                    {
                        return Ok(Some(w));
                    }
                }
                self.find_o(pc, &s.label, &[K::EndRepeat, K::While], true)
                    .map(Some)
                    .ok_or_else(|| missing("loop end"))
            }
        }
    }

    /// The block's program end (M2, M30) and Fanuc subprogram call and return
    /// (M98, M99), the last of [`Interp::block`]'s steps: the line to run next,
    /// `None` at the program's end.
    pub(super) fn program_flow(&mut self, b: &Block, pc: usize) -> Result<Option<usize>, Fail> {
        // Stop and flow.
        if b.has_m(2) || b.has_m(30) {
            return Ok(None);
        }
        if b.has_m(98) {
            let p = b.get('p').ok_or(Fail {
                col: b.first_col,
                msg: "M98 needs a P word (program number)".into(),
            })?;
            let l = b.get('l').unwrap_or(1.0);
            if l < 1.0 || l.fract() != 0.0 || l > 1e6 {
                return fail(
                    b.col('l'),
                    "L repeat count must be an integer from 1 to 1000000",
                );
            }
            let target = integer_value(p).ok_or(Fail {
                col: b.col('p'),
                msg: format!("M98 P{p} is not a program number (a whole number)"),
            })?;
            let start = *self.programs.get(&target).ok_or(Fail {
                col: b.col('p'),
                msg: format!("subprogram O{target} not found"),
            })?;
            if self.frames.len() >= 64 {
                return fail(b.first_col, "subprogram calls nested too deeply");
            }
            self.frames.push(Frame::Fanuc {
                return_pc: pc + 1,
                start,
                remaining: l as u32 - 1,
                first_run_from: Some(self.segment_count()),
            });
            self.enter_call_level();
            return Ok(Some(start + 1));
        }
        if b.has_m(99) {
            return match self.frames.pop() {
                Some(Frame::Fanuc {
                    return_pc,
                    start,
                    remaining,
                    first_run_from,
                }) => {
                    if remaining > 0 {
                        let call = return_pc - 1;
                        let col = self.lines[call].as_ref().map_or(1, |_| self.m98_col(call));
                        self.last_loop = Some((call, col));
                        if let Some(before) = first_run_from {
                            let per_run = self.segment_count() - before;
                            self.foresee(call, col, per_run, f64::from(remaining) + 1.0, "M98 L")?;
                        }
                        self.frames.push(Frame::Fanuc {
                            return_pc,
                            start,
                            remaining: remaining - 1,
                            first_run_from: None,
                        });
                        Ok(Some(start + 1))
                    } else {
                        self.last_loop = None;
                        self.leave_call_level();
                        Ok(Some(return_pc))
                    }
                }
                Some(other) => {
                    self.frames.push(other);
                    fail(b.first_col, "M99 inside an o-word subroutine")
                }
                None => Ok(None),
            };
        }
        Ok(Some(pc + 1))
    }
}
