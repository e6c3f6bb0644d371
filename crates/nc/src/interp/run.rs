//! Reading a program's lines and running them, and what a run returns: the
//! parse result, the per-segment trace and the lines executed.

use std::collections::HashMap;
use std::rc::Rc;

use super::diagnostics::Tolerated;
use super::state::{interp, Lent};
use super::{FileForm, Options};
use crate::amend::{self, Amendment};
use crate::cursor::SyntaxError;
use crate::diag::{Diagnostic, Severity};
use crate::path::{Path, Segment};
use crate::syntax::{self, LineKind, OLabel, BYTE_ORDER_MARK};

/// Result of [`crate::parse`]: the path and every diagnostic found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Parsed {
    /// The motion, as far as the program could be read (a block with an
    /// error adds no motion; later blocks start where it meant to end).
    pub path: Path,
    /// Errors and warnings, in program order.
    pub diagnostics: Vec<Diagnostic>,
    /// The program ended with M2, M30, a closing `%` (or M99 outside any
    /// subprogram), rather than at the end of the file.
    pub has_program_end: bool,
    /// What makes a tolerantly read file one LinuxCNC reads with the same
    /// moves ([`crate::amend`]); empty in the other file forms.
    pub amendments: Vec<Amendment>,
}

/// Per-segment facts the re-feed writer needs (modes in force at the block).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentTrace {
    /// 0-based line index.
    pub line_index: usize,
    /// mm per program unit (1 or 25.4) of the block's coordinates.
    pub scale: f64,
    /// mm per program unit of the block's F word: the units in force before
    /// the block, as F is read before a G20/G21 in the same block takes effect.
    pub feed_scale: f64,
    pub incremental: bool,
    pub arc_incremental: bool,
    pub inverse_time: bool,
    /// Work offset + G92 in force (mm): machine = program·scale + offset.
    pub offset_mm: [f64; 3],
    /// Cutter radius compensation shaped the segment: its block cannot be
    /// split (the pieces would be compensated again).
    pub compensated: bool,
    /// A coordinate system rotated by `G10 L2 R` placed the segment: its
    /// block is never split or written out (the pieces' program
    /// coordinates would need the rotation, which `offset_mm` lacks).
    pub rotated: bool,
    /// A canned cycle that stops or reverses the spindle made the segment
    /// (G74, G84, G86, G87): its line is never written out as plain moves.
    pub spindle_cycle: bool,
}

/// What a run returns besides the parse result.
pub struct Trace {
    /// One per path segment of a recorded run ([`run_recorded`], the re-feed
    /// writer's); empty otherwise.
    pub segments: Vec<SegmentTrace>,
    /// Every source line as parsed (`None`: syntax error), split as
    /// [`syntax::split_lines`] splits them, keeping no block's items (a
    /// million-line program's are about 190 MB):
    /// [`syntax::Lines::block_items`] parses a block again from the source.
    pub lines: Rc<syntax::Lines>,
    /// The run made the path it was lent ([`run_recorded_along`]) bit for
    /// bit, segment for segment: its [`Parsed::path`] holds no segments.
    pub on_lent_path: bool,
}

/// A line as executed: its 0-based index and the call depth it ran at
/// (0 in the main program, +1 per o-word or M98 call).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Executed {
    pub line_index: u32,
    pub depth: u32,
    /// Segments made before the line ran (the line made those up to the next
    /// entry's count).
    pub segments_before: u32,
}

/// Parses and runs a program ([`crate::parse`]). Without an initial tool,
/// the first tool the program loads is taken to be in the spindle from the
/// start. Its lines' items are not held through the run: each block is
/// parsed again where it runs ([`syntax::Lines::push_parsed_unkept`]), for
/// a million-block program 24 + 8 MB for its lines instead of about 200.
/// The lines are parsed twice; the result is that of a run of
/// the lines held ([`run_read_and_record`] of [`read`]).
pub(crate) fn parse(source: &str, file: &str, options: &Options) -> Parsed {
    read_and_run(source, file, options, false, None).0
}

/// `source` read keeping no block's items, then run (`record`: with the
/// trace and the lines executed; `lent`: along the caller's path) in fresh
/// memory: what [`parse`], [`run_recorded`] and [`run_recorded_along`] do.
fn read_and_run(
    source: &str,
    file: &str,
    options: &Options,
    record: bool,
    lent: Option<&[Segment]>,
) -> (Parsed, Trace, Vec<Executed>) {
    let read = read_lines(source, file, options, false);
    run_read_and_record(
        &read,
        source,
        file,
        options,
        record,
        lent,
        PathRoom::default(),
    )
}

/// [`parse`], with the trace of a recorded run and every line executed in
/// the order it ran (for unrolling loops). The trace's lines keep no
/// block's items: [`syntax::Lines::block_items`] with `source` gives them.
pub fn run_recorded(source: &str, file: &str, options: &Options) -> (Parsed, Trace, Vec<Executed>) {
    read_and_run(source, file, options, true, None)
}

/// [`run_recorded`] lent the path the caller read the same text to
/// (`path`): where the run makes that path bit for bit
/// ([`Trace::on_lent_path`]) the returned [`Parsed::path`] holds no
/// segments, and the path is `path`; otherwise it holds the run's own, as
/// [`run_recorded`] returns it.
pub fn run_recorded_along(
    source: &str,
    file: &str,
    options: &Options,
    path: &[Segment],
) -> (Parsed, Trace, Vec<Executed>) {
    read_and_run(source, file, options, true, Some(path))
}

/// A run of a program already read (its lines parsed once, or where `read`
/// keeps no block's items, again from `source`, the text it read).
/// The memory a run makes its path in: `segments` (emptied; taken where it
/// has room for a segment a line, else let go), and whether the path is
/// held at its length once made (`shrink`) or at the room it was made in,
/// for another run of the program to make its path in again rather than in
/// pages new to the process (a million segments are 120 MB).
pub(crate) struct PathRoom {
    pub(crate) segments: Vec<Segment>,
    pub(crate) shrink: bool,
}

impl Default for PathRoom {
    fn default() -> Self {
        PathRoom {
            segments: Vec::new(),
            shrink: true,
        }
    }
}

/// A run of a program already read (its lines parsed once, or where `read`
/// keeps no block's items, again from `source`, the text it read), its path
/// made in `room` ([`PathRoom::default`]: fresh memory, held at its length).
pub(crate) fn run_read_and_record(
    read: &Read,
    source: &str,
    file: &str,
    options: &Options,
    record: bool,
    lent: Option<&[Segment]>,
    room: PathRoom,
) -> (Parsed, Trace, Vec<Executed>) {
    let shrink = room.shrink;
    let first_room = PathRoom {
        segments: room.segments,
        shrink: options.initial_tool.is_some() && shrink,
    };
    let (mut parsed, trace, first, executed) =
        run_read(read, source, file, options, record, lent, first_room);
    match (options.initial_tool, first) {
        (None, Some(tool)) if tool != 0 => {
            // Dropped before the run again: one path at a time, the second
            // made in the first's memory.
            let segments = std::mem::take(&mut parsed.path.segments);
            drop((parsed, trace, executed));
            let options = Options {
                initial_tool: Some(tool),
                ..options.clone()
            };
            let room = PathRoom { segments, shrink };
            let (parsed, trace, _, executed) =
                run_read(read, source, file, &options, record, lent, room);
            (parsed, trace, executed)
        }
        _ => {
            if shrink {
                parsed.path.segments.shrink_to_fit();
            }
            (parsed, trace, executed)
        }
    }
}

/// A program's lines as read before it runs, and what reading them found:
/// the same for every run of the program whatever its start.
#[derive(Clone)]
pub(crate) struct Read {
    pub(super) lines: Rc<syntax::Lines>,
    pub(super) olines: HashMap<OLabel, Vec<usize>>,
    pub(super) programs: HashMap<i64, usize>,
    pub(super) syntax_errors: HashMap<usize, SyntaxError>,
    pub(super) tolerated: Tolerated,
    pub(super) diagnostics: Vec<Diagnostic>,
}

/// Reads every line of `source` (syntax, the tolerant form's amendments, o-word labels),
/// keeping every block's items (the tests' reading held).
#[cfg(test)]
pub(crate) fn read(source: &str, file: &str, options: &Options) -> Read {
    read_lines(source, file, options, true)
}

/// [`read`], keeping no block's items: runs read them from `source` again.
pub(crate) fn read_unkept(source: &str, file: &str, options: &Options) -> Read {
    read_lines(source, file, options, false)
}

/// [`read`]; where `keep` is false, a block's items are not kept (the line is
/// parsed again from the source where it runs); a line the tolerant form
/// mended keeps its items, which are not the source's.
pub(super) fn read_lines(source: &str, file: &str, options: &Options, keep: bool) -> Read {
    let mut it = interp(file, options, false);
    let whole = source;
    let source = match source.strip_prefix(BYTE_ORDER_MARK) {
        Some(rest) if options.file_form == FileForm::Tolerant => {
            it.tolerated.amendments.push(Amendment::DropByteOrderMark);
            it.warn(
                1,
                "UTF-8 byte-order mark before the first line skipped (LinuxCNC would refuse the file)"
                    .into(),
            );
            rest
        }
        _ => source,
    };
    let mut lines = syntax::Lines::default();
    for (i, (text, _)) in syntax::split_lines(source).enumerate() {
        let start = text.as_ptr() as usize - whole.as_ptr() as usize;
        let pushed = if keep {
            lines.push_parsed(text)
        } else {
            lines.push_parsed_unkept(text, start)
        };
        let e = match pushed {
            Ok(()) => {
                match lines.last().and_then(Option::as_ref).map(|l| &l.kind) {
                    Some(LineKind::OWord(stmt)) => {
                        it.olines.entry(stmt.label.clone()).or_default().push(i)
                    }
                    Some(LineKind::ProgramNumber(n)) => {
                        it.programs.entry(*n).or_insert(i);
                    }
                    _ => {}
                }
                continue;
            }
            Err(e) => e,
        };
        // Parentheses nested in a comment that closes on the line, or
        // a GRBL system command that neither moves nor sets anything.
        let fixed = (options.file_form == FileForm::Tolerant)
            .then(|| {
                amend::flatten_nested_comments(text)
                    .map(|(fixed, col)| (fixed, col, "parentheses nested in a comment read as one comment, written as [ ]".to_owned()))
                    .or_else(|| {
                        amend::comment_grbl_system_command(text).map(|(fixed, col)| {
                            (fixed, col, "GRBL system command skipped, as GRBL runs it outside the program (it neither moves the machine nor changes how the program reads); written as a comment".to_owned())
                        })
                    })
            })
            .flatten()
            .filter(|(fixed, _, _)| lines.push_parsed(fixed).is_ok());
        if !keep {
            lines.push_start(start);
        }
        match fixed {
            Some((fixed, col, what)) => {
                it.line_index = i;
                let start = fixed
                    .bytes()
                    .zip(text.bytes())
                    .position(|(a, b)| a != b)
                    .unwrap_or(0);
                // The common tail, not reaching back past `start`.
                let tail = fixed
                    .bytes()
                    .rev()
                    .zip(text.bytes().rev())
                    .take(fixed.len().min(text.len()) - start)
                    .take_while(|(a, b)| a == b)
                    .count();
                it.tolerate(
                    start..text.len() - tail,
                    fixed[start..fixed.len() - tail].to_owned(),
                    col,
                    what,
                );
            }
            None => {
                it.syntax_errors.insert(i, e);
                lines.push_error();
            }
        }
    }
    lines.shrink_to_fit();
    Read {
        lines: Rc::new(lines),
        olines: it.olines,
        programs: it.programs,
        syntax_errors: it.syntax_errors,
        tolerated: it.tolerated,
        diagnostics: it.diagnostics,
    }
}

/// Runs a program read by [`read`] (with the same file form) from the start `options` give.
pub(crate) fn run_read(
    read: &Read,
    source: &str,
    file: &str,
    options: &Options,
    record: bool,
    lent: Option<&[Segment]>,
    path_room: PathRoom,
) -> (Parsed, Trace, Option<u32>, Vec<Executed>) {
    let mut it = interp(file, options, record);
    it.lent = lent.map(|path| Lent { path, matched: 0 });
    // A segment a line at most in most programs: room for them (and a recorded run's
    // trace) from the start rather than grown by doubling (each step a copy of the
    // whole), within the limit of moves; the path's room left is given back below.
    let room = read.lines.len().min(options.max_segments.saturating_add(1));
    if lent.is_none() {
        let mut segments = path_room.segments;
        segments.clear();
        if segments.capacity() < room {
            // Let go before the room is made: one path's memory at a time.
            segments = Vec::new();
            segments.reserve_exact(room);
        }
        it.path.segments = segments;
    }
    if record {
        it.trace.reserve_exact(room);
    }
    it.lines = Rc::clone(&read.lines);
    it.source = source;
    it.olines = read.olines.clone();
    it.programs = read.programs.clone();
    it.syntax_errors = read.syntax_errors.clone();
    it.tolerated = read.tolerated.clone();
    it.diagnostics = read.diagnostics.clone();
    it.execute();
    if let Some((line, col)) = it.first_dropped {
        let more = it.error_count - it.options.max_errors;
        it.diagnostics.push(Diagnostic {
            file: it.file.to_owned(),
            line: line as u32 + 1,
            column: col.max(1),
            message: format!(
                "and {more} more error{} (only the first {} are listed)",
                if more == 1 { "" } else { "s" },
                it.options.max_errors
            ),
            severity: Severity::Error,
        });
    }
    // The lent path is the run's only where the run made all of it.
    let on_lent_path = it.lent.is_some_and(|l| l.matched == l.path.len());
    if !on_lent_path {
        it.own_path();
    }
    // The path is held as long as its program runs: not at the capacity its
    // pushes grew it to, up to twice its segments (125.8 MB for a million
    // segments of 120 B, not 120.0), unless another run makes its path in it.
    if path_room.shrink {
        it.path.segments.shrink_to_fit();
    }
    let trace = Trace {
        segments: it.trace,
        lines: it.lines,
        on_lent_path,
    };
    (
        Parsed {
            path: it.path,
            diagnostics: it.diagnostics,
            has_program_end: it.ended,
            amendments: it.tolerated.amendments,
        },
        trace,
        it.first_loaded,
        it.executed.unwrap_or_default(),
    )
}
