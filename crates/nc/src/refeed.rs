//! Re-feeding: the original program with new F words, feed blocks split
//! where the feed must change inside them, every other byte as it was.
//!
//! Input is a *plan*: per path segment (as [`crate::parse`] returns them),
//! pieces `(fraction_end, feed_mm_min)` in increasing fraction, the last
//! ending at 1. Rapids and dwells take an empty plan.
//!
//! * A line that made exactly one feed segment (and nothing else) gets the
//!   first piece in place (its axis, centre and F words rewritten) and one
//!   new block per further piece right after it, in the line's own modes
//!   (units, G90/G91, G90.1/G91.1, G93/G94, plane, work offset). A line in
//!   polar coordinates (`@` radius, `^` angle) is written with the Cartesian
//!   X and Y of each piece in place of its polar words.
//! * A line run several times by a loop or subprogram, one plain feed move
//!   per run, gets a record per run: a counter parameter counts its runs and
//!   its words read a table set at the top of the program (numbered
//!   parameters 1000–4999). Where every run is one block, the record is its
//!   F; where a run needs pieces, every run is split into as many blocks as
//!   the run that needs most (the longest pieces of the others halved) and
//!   the record holds each block's end point, arc centre and F. A run that
//!   does not move keeps its record (any F; blocks to where the tool is).
//! * Where the records do not fit, the o-word loops around those lines are
//!   written out in full ([`crate::unroll`]), and every line of them runs
//!   once; a line in no loop to unroll is split into fewer blocks per run
//!   (the cheapest neighbouring pieces merged at the lower feed) until its
//!   records fit.
//! * Canned cycles whose feed moves need more than one feed are written out
//!   as G0/G1/G4 blocks of their moves (all cycle lines of the program, or
//!   none; see `cycle_lines`). A line repeated by L (under G91 each repeat a
//!   step in X/Y and polar `@`/`^`) is written as every repeat's moves in
//!   X Y Z, after a block with the modal G codes of the line (G17, G20/G21,
//!   G90/G91, G98/G99: its moves are written in them, and they stay in force
//!   after it). A cycle line run more than once (a loop, a subroutine called
//!   several times) is written out per run: a counter parameter (after the
//!   tables) counts its runs and an o-word `if`/`elseif` chain on it runs
//!   each run's own moves.
//! * Other lines that made several feed segments (a canned cycle run more
//!   than once in a program that names a parameter of that range) cannot be
//!   split: their F becomes the lowest feed any of their pieces asks for.
//! * Lines that cannot be split safely (G53, a dwell or a program stop in the
//!   block, multi-turn arcs) are treated the same way.
//!
//! * A file read tolerantly ([`crate::FileForm::Tolerant`]) is written as
//!   every control reads it, with the reader's amendments ([`crate::amend`]):
//!   no byte-order mark, `M2` where it had no program end, and the dialect
//!   words LinuxCNC refuses written as it reads them.
//!
//! The output is parsed again and checked against the plan (same end points
//! and lengths, feeds never above the plan) before it is returned.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use nalgebra::Point3;
use thiserror::Error;

use crate::expr::Expr;
use crate::interp::{self, Executed, Options, Parsed, SegmentTrace};
use crate::path::{Geometry, Motion, Segment};
use crate::syntax::{self, Item, ItemKind, LineKind};

/// Why a program could not be re-fed.
#[derive(Debug, Error)]
pub enum RefeedError {
    /// The source program has an error (the first one).
    #[error("{0}")]
    Program(crate::Diagnostic),
    /// The plan does not have one entry per segment of the program.
    #[error("the feed plan has {plan} entries but the program has {segments} segments")]
    PlanLength {
        /// Entries in the plan.
        plan: usize,
        /// Segments in the program's path.
        segments: usize,
    },
    /// A feed segment's pieces are not (fraction, feed) pairs with fractions
    /// rising to 1 and positive feeds.
    #[error("{file}:{line}: feed plan for segment {segment} is not pieces with increasing fractions ending at 1 and positive feeds")]
    BadPlan {
        /// Program file name.
        file: String,
        /// 1-based program line of the segment.
        line: u32,
        /// 0-based segment index.
        segment: usize,
    },
    /// The written program, read back, does not give the same path or feeds.
    #[error("{file}: the re-fed program does not reproduce the original path: {detail}")]
    Verification {
        /// Program file name.
        file: String,
        /// The first difference found.
        detail: String,
    },
}

/// Writes `source` with the feeds of `plan` (see the module docs).
pub fn refeed(
    source: &str,
    file: &str,
    options: &Options,
    plan: &[Vec<(f64, f64)>],
) -> Result<String, RefeedError> {
    refeed_read(source, file, options, plan).map(|(text, _)| text)
}

/// [`refeed`], and the written text as it was read back to be checked: what
/// [`crate::parse`] returns for it with `file` and `options` (a caller that
/// needs the written program's path need not read it once more).
pub fn refeed_read(
    source: &str,
    file: &str,
    options: &Options,
    plan: &[Vec<(f64, f64)>],
) -> Result<(String, Parsed), RefeedError> {
    refeed_read_lent(source, file, options, plan, None)
}

/// [`refeed_read`] of a program whose path the caller has read: `path`,
/// what [`crate::parse`] returns for `source` with `file` and `options`,
/// handed over. The source's reading is checked against it segment by
/// segment as it is made, and where it makes it bit for bit, `path` is the
/// path the text is written against (no second copy of it: a million-block
/// program's path is 126 MB); otherwise the reading keeps its own, as
/// [`refeed_read`] does. Either is dropped before the written text is read
/// back to be checked. The text and its reading are [`refeed_read`]'s.
pub fn refeed_read_along(
    source: &str,
    file: &str,
    options: &Options,
    plan: &[Vec<(f64, f64)>],
    path: crate::Path,
) -> Result<(String, Parsed), RefeedError> {
    refeed_read_lent(source, file, options, plan, Some(path.segments))
}

/// [`refeed_read`], along the caller's path where one is handed over.
fn refeed_read_lent(
    source: &str,
    file: &str,
    options: &Options,
    plan: &[Vec<(f64, f64)>],
    mut lent: Option<Vec<Segment>>,
) -> Result<(String, Parsed), RefeedError> {
    let run = |source: &str, lent: Option<&[Segment]>| match lent {
        Some(path) => interp::run_recorded_along(source, file, options, path),
        None => interp::run_recorded(source, file, options),
    };
    let (mut parsed, mut trace, mut executed) = run(source, lent.as_deref());
    // A file read as most controls read it is written as every control reads
    // it ([`crate::amend`]); the amended source is what is re-fed and checked.
    let amended;
    let mut source = source;
    if !parsed.amendments.is_empty() && !parsed.diagnostics.iter().any(|d| d.is_error()) {
        amended = crate::amend(source, &parsed.amendments);
        source = &amended;
        (parsed, trace, executed) = run(source, lent.as_deref());
    }
    if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
        return Err(RefeedError::Program(d.clone()));
    }
    // The caller's path where the reading made it, else the reading's own
    // (and the caller's let go).
    let segments = match lent.take() {
        Some(path) if trace.on_lent_path => path,
        _ => std::mem::take(&mut parsed.path.segments),
    };
    if plan.len() != segments.len() {
        return Err(RefeedError::PlanLength {
            plan: plan.len(),
            segments: segments.len(),
        });
    }
    for (i, (seg, pieces)) in segments.iter().zip(plan).enumerate() {
        if matches!(seg.motion, Motion::Feed { .. }) && !valid_pieces(pieces) {
            return Err(RefeedError::BadPlan {
                file: file.to_owned(),
                line: seg.line,
                segment: i,
            });
        }
    }
    let by_line = lines_segments(&trace);
    let (tables, unfit) = run_tables(source, &by_line, &segments, &trace, &executed, plan);
    let recorded = Recorded {
        segments,
        trace,
        executed,
        by_line,
    };
    drop(parsed);
    let mut recorded = Some(recorded);
    if !unfit.is_empty() {
        // Records that do not fit the table: the loops around those lines
        // written out in full, if the result makes the same path.
        let r = recorded.as_ref().expect("the source's reading");
        if let Some(unrolled) = crate::unroll::unroll(source, &r.trace.lines, &r.executed, &unfit) {
            let (p, t, e) = interp::run_recorded(&unrolled, file, options);
            if same_path(&r.segments, &p.path.segments)
                && !p.diagnostics.iter().any(|d| d.is_error())
            {
                drop(p);
                let by_line = lines_segments(&t);
                let (tables, _) = run_tables(&unrolled, &by_line, &r.segments, &t, &e, plan);
                // The unrolled text is written against the source's path
                // (the source's reading is read again if it is needed after).
                let source_read = recorded.take().expect("the source's reading");
                let unrolled_read = Recorded {
                    segments: source_read.segments,
                    trace: t,
                    executed: e,
                    by_line,
                };
                if let Ok(out) = write_checked(
                    &unrolled,
                    Some(source),
                    file,
                    options,
                    unrolled_read,
                    plan,
                    tables,
                ) {
                    return Ok(out);
                }
            }
        }
    }
    let recorded = recorded.unwrap_or_else(|| Recorded::read(source, None, file, options));
    write_checked(source, None, file, options, recorded, plan, tables)
}

/// A recorded run of the text the writer writes from: the path it is
/// written against, its trace, the lines as they ran and the segments of
/// each line.
struct Recorded {
    /// The path of the program as read (for unrolled loops, the path of the
    /// text they were unrolled from).
    segments: Vec<Segment>,
    trace: interp::Trace,
    executed: Vec<Executed>,
    by_line: LineSegments,
}

impl Recorded {
    /// `source` run and recorded again (as it was the first time: the
    /// interpreter gives the same run of the same text and options), with
    /// the path of `path_from` where the text is written against another's
    /// path (unrolled loops: the text they were unrolled from).
    fn read(source: &str, path_from: Option<&str>, file: &str, options: &Options) -> Recorded {
        let (parsed, trace, executed) = interp::run_recorded(source, file, options);
        let segments = match path_from {
            None => parsed.path.segments,
            Some(from) => {
                drop(parsed);
                interp::run_recorded(from, file, options).0.path.segments
            }
        };
        let by_line = lines_segments(&trace);
        Recorded {
            segments,
            trace,
            executed,
            by_line,
        }
    }
}

/// What the check of a written program needs of each segment of the path
/// it must make: where it ends, how long it is, its motion and its line
/// (56 B a segment, not the 120 of a [`Segment`]: for a million-block
/// program the path need not be held while the written text is read back).
struct Expected {
    end: Point3<f64>,
    length_mm: f64,
    motion: Motion,
    line: u32,
}

impl Expected {
    fn of(seg: &Segment) -> Expected {
        Expected {
            end: seg.end,
            length_mm: seg.length_mm(),
            motion: seg.motion,
            line: seg.line,
        }
    }
}

/// The segments made by each line, ascending, in two flat columns (a
/// million-line program's map of one `Vec` per line took 53 MB; this takes
/// 16): where each line's segments begin in `segments`, and the segments.
struct LineSegments {
    /// Per line index, where its segments begin; one more entry at the end.
    start: Vec<usize>,
    segments: Vec<usize>,
}

impl LineSegments {
    /// The segments of the line at `index`; None when it made none.
    fn get(&self, index: usize) -> Option<&[usize]> {
        let (&from, &to) = (self.start.get(index)?, self.start.get(index + 1)?);
        (to > from).then(|| &self.segments[from..to])
    }

    /// The segments of the line at `index`, which made some.
    fn of(&self, index: usize) -> &[usize] {
        self.get(index).expect("a line that made segments")
    }

    /// Line `index` runs as more than one segment, so it may get a table of
    /// runs ([`run_tables`]); only such lines have their runs kept.
    fn tabled(&self, index: usize) -> bool {
        self.get(index).is_some_and(|segs| segs.len() >= 2)
    }

    /// Every line that made segments, ascending, with its segments.
    fn iter(&self) -> impl Iterator<Item = (usize, &[usize])> + '_ {
        (0..self.start.len().saturating_sub(1)).filter_map(|index| Some((index, self.get(index)?)))
    }
}

/// Segments made by each line.
fn lines_segments(trace: &interp::Trace) -> LineSegments {
    let lines = trace
        .segments
        .iter()
        .map(|t| t.line_index + 1)
        .max()
        .unwrap_or(0);
    // Counted, then placed in segment order (each line's ascending).
    let mut start = vec![0usize; lines + 1];
    for t in &trace.segments {
        start[t.line_index + 1] += 1;
    }
    for i in 0..lines {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut segments = vec![0usize; trace.segments.len()];
    for (i, t) in trace.segments.iter().enumerate() {
        segments[next[t.line_index]] = i;
        next[t.line_index] += 1;
    }
    LineSegments { start, segments }
}

/// The same moves: kind, end point and length of every segment.
fn same_path(a: &[Segment], b: &[Segment]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            std::mem::discriminant(&x.motion) == std::mem::discriminant(&y.motion)
                && (x.end - y.end).norm() <= 1e-9
                && (x.length_mm() - y.length_mm()).abs() <= 1e-9
        })
}

/// Writes the program with `tables` and the canned cycles written out where
/// needed, dropping either when the result does not read back as planned.
/// The recorded run (for a million-line program its path, lines without
/// their items, trace and executed lines, about 220 MB) is dropped once the
/// text is written,
/// before the text is read back to be checked against what the path needs
/// ([`Expected`], made of the path then, not held through the writing); a
/// check that fails and is tried again runs the source (and `path_from`,
/// [`Recorded::read`]) again.
#[allow(clippy::too_many_arguments)]
fn write_checked(
    source: &str,
    path_from: Option<&str>,
    file: &str,
    options: &Options,
    recorded: Recorded,
    plan: &[Vec<(f64, f64)>],
    mut tables: BTreeMap<usize, RunTable>,
) -> Result<(String, Parsed), RefeedError> {
    let mut expected: Option<Vec<Expected>> = None;
    let mut expanded = cycle_lines(
        source,
        &recorded.by_line,
        &recorded.segments,
        &recorded.trace,
        plan,
    );
    let mut recorded = Some(recorded);
    loop {
        let Recorded {
            segments,
            trace,
            executed,
            by_line,
        } = recorded
            .take()
            .unwrap_or_else(|| Recorded::read(source, path_from, file, options));
        let Some(per_run) = cycle_runs(source, &expanded, &executed, &trace, &tables) else {
            // A cycle run more than once with no counter to tell its runs
            // apart: the cycles as written.
            expanded.clear();
            recorded = Some(Recorded {
                segments,
                trace,
                executed,
                by_line,
            });
            continue;
        };
        // Runs of a line split into more blocks than they need: their pieces as written.
        let mut coarse = BTreeMap::new();
        for (index, t) in &tables {
            for &i in by_line.of(*index) {
                if t.blocks() > 1 {
                    coarse.insert(i, padded(&coarsened(&plan[i], t.blocks()), t.blocks()));
                }
            }
        }
        let plan = WrittenPlan { plan, coarse };
        let (out, written_pieces) = write(
            source, &segments, &trace, &by_line, &plan, &tables, &expanded, &per_run,
        );
        // Every try writes against the same path (the source's, read again).
        let expected = expected.get_or_insert_with(|| segments.iter().map(Expected::of).collect());
        drop((segments, trace, executed, by_line, per_run));
        match verify(&out, file, options, expected, &plan, &written_pieces) {
            Ok(parsed) => return Ok((out, parsed)),
            // Cycles written out that do not read back: keep them as written.
            Err(_) if !expanded.is_empty() => expanded.clear(),
            // A run that should stay still moves after all (its point as
            // written is not quite where the tool is): those lines at their
            // lowest feed, then every line.
            Err(_) if tables.values().any(|t| t.idle) => tables.retain(|_, t| !t.idle),
            Err(_) if !tables.is_empty() => tables.clear(),
            Err(e) => return Err(e),
        }
    }
}

/// The plan as written: the caller's, but for the segments whose pieces a
/// run table coarsens, held apart (not a copy of the whole plan).
struct WrittenPlan<'a> {
    plan: &'a [Vec<(f64, f64)>],
    coarse: BTreeMap<usize, Vec<(f64, f64)>>,
}

impl std::ops::Index<usize> for WrittenPlan<'_> {
    type Output = [(f64, f64)];

    /// The pieces segment `i` is written in.
    fn index(&self, i: usize) -> &[(f64, f64)] {
        self.coarse.get(&i).unwrap_or(&self.plan[i])
    }
}

/// The re-fed text and how many blocks each segment became.
#[allow(clippy::too_many_arguments)]
fn write(
    source: &str,
    segments: &[Segment],
    trace: &interp::Trace,
    by_line: &LineSegments,
    plan: &WrittenPlan<'_>,
    tables: &BTreeMap<usize, RunTable>,
    expanded: &BTreeSet<usize>,
    per_run: &BTreeMap<usize, CycleRuns>,
) -> (String, Vec<usize>) {
    // How many blocks each segment becomes (for the verification).
    let mut written_pieces = vec![1usize; segments.len()];
    let mut out = String::with_capacity(source.len() + source.len() / 8);
    // A block's items, parsed again from its text (the reading keeps none).
    let mut again = Vec::new();
    for (index, (text, eol)) in syntax::split_lines(source).enumerate() {
        if index == 0 && !(tables.is_empty() && per_run.is_empty()) {
            // The tables are set before anything runs (after a leading `%`).
            let nl = eol_or_newline(eol);
            let header = table_header(tables, per_run, nl);
            if text.trim() == "%" {
                out.push_str(text);
                out.push_str(nl);
                out.push_str(&header);
                continue;
            }
            out.push_str(&header);
        }
        if let Some(t) = tables.get(&index) {
            let Some(items) = trace.lines.block_items(index, source, &mut again) else {
                unreachable!("a table line is a block")
            };
            let _ = write!(
                out,
                "#{c} = [#{c} + 1]{}",
                eol_or_newline(eol),
                c = t.counter
            );
            if t.blocks() == 1 {
                let f = format!("F{}", t.reference(0));
                out.push_str(&with_f_word(text, items, &f));
                out.push_str(eol);
            } else {
                let segs = by_line.of(index);
                for &i in segs {
                    written_pieces[i] = t.blocks();
                }
                let mut j = 0;
                let blocks: Vec<String> = t
                    .letters
                    .iter()
                    .map(|letters| {
                        words_text(letters.iter().map(|&l| {
                            j += 1;
                            (l, t.reference(j - 1))
                        }))
                    })
                    .collect();
                write_blocks(
                    &mut out,
                    text,
                    eol,
                    items,
                    &segments[segs[0]].geometry,
                    &blocks,
                );
            }
            continue;
        }
        let Some(segs) = by_line.get(index) else {
            out.push_str(text);
            out.push_str(eol);
            continue;
        };
        if expanded.contains(&index) {
            write_expanded(
                &mut out,
                source,
                index,
                eol,
                segs,
                per_run.get(&index),
                segments,
                trace,
                plan,
                &mut written_pieces,
            );
            continue;
        }
        let feeds: Vec<usize> = segs
            .iter()
            .copied()
            .filter(|&i| matches!(segments[i].motion, Motion::Feed { .. }))
            .collect();
        if feeds.is_empty() {
            out.push_str(text);
            out.push_str(eol);
            continue;
        }
        let Some(items) = trace.lines.block_items(index, source, &mut again) else {
            out.push_str(text);
            out.push_str(eol);
            continue;
        };
        let single = segs.len() == 1
            && splittable(items, &segments[feeds[0]])
            && !trace.segments[feeds[0]].compensated;
        if single && plan[feeds[0]].len() > 1 {
            let i = feeds[0];
            written_pieces[i] = plan[i].len();
            split_line(
                &mut out,
                text,
                eol,
                items,
                &segments[i],
                &trace.segments[i],
                &plan[i],
            );
        } else {
            // The lowest F any execution of the line asks for (G93: per segment length).
            let f = feeds
                .iter()
                .map(|&i| {
                    f_word(
                        &trace.segments[i],
                        lowest(&plan[i]),
                        segments[i].length_mm(),
                        true,
                    )
                })
                .min_by(|a, b| f_value(a).total_cmp(&f_value(b)))
                .expect("at least one feed segment");
            out.push_str(&with_f_word(text, items, &f));
            out.push_str(eol);
        }
    }
    (out, written_pieces)
}

/// Parameters that hold the feeds of lines run more than once: one counter
/// per line and a table of its feeds, one per run, in this range of numbered
/// parameters (LinuxCNC's free globals; Fanuc macro B reads the same).
const TABLE_PARAMS: std::ops::RangeInclusive<u32> = 1000..=4999;

/// Words of a line run more than once, one record per run in the order they
/// run: its F (one block per run), or the axis, centre and F words of each of
/// its blocks when its runs need pieces (every run split into the same number
/// of blocks, each run at its own points and feeds).
struct RunTable {
    /// Parameter counting the runs.
    counter: u32,
    /// Parameter holding the first run's first value.
    first: u32,
    /// Per block, the letters of the words read from the table (F last).
    letters: Vec<Vec<char>>,
    /// Values, `width()` per run, in the order the runs run.
    values: Vec<f64>,
    /// Some run of the line does not move (its record keeps it still).
    idle: bool,
}

impl RunTable {
    /// Values per run.
    fn width(&self) -> usize {
        self.letters.iter().map(Vec::len).sum()
    }

    /// The expression reading value `j` of the current run (the counter
    /// counts from 1).
    fn reference(&self, j: usize) -> String {
        let w = self.width() as u32;
        if w == 1 {
            format!("#[#{} + {}]", self.counter, self.first - 1 + j as u32)
        } else {
            format!("#[#{} * {w} + {}]", self.counter, self.first - w + j as u32)
        }
    }

    /// Blocks each run is written as.
    fn blocks(&self) -> usize {
        self.letters.len()
    }
}

/// Numbers of the numbered parameters a program names literally (`#12`).
fn named_parameters(source: &str) -> Vec<u32> {
    let bytes = source.as_bytes();
    let mut out = Vec::new();
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'#' {
            let digits: String = source[i + 1..]
                .chars()
                .skip_while(|c| *c == ' ')
                .take_while(char::is_ascii_digit)
                .collect();
            if let Ok(n) = digits.parse() {
                out.push(n);
            }
        }
    }
    out
}

/// What one run (execution) of a line made.
#[derive(Clone, Copy, Debug)]
enum Run {
    /// One segment.
    Moved(usize),
    /// Nothing: a move to where the tool already was (at this point, `None`
    /// before any move).
    Idle(Option<Point3<f64>>),
    /// More than one segment.
    Several,
}

/// Per line that made more than one segment (the only lines a table of runs
/// can be written for, [`run_tables`]), its runs in the order they ran: not
/// one list per line of a program whose lines each move once (a `Vec` and a
/// map entry a line, 192 MB for a million lines). `None` when a
/// segment was made while another line ran (moves held back by cutter
/// compensation): then every segment is taken for a run.
fn line_runs(
    executed: &[Executed],
    trace: &interp::Trace,
    segments: &[Segment],
    by_line: &LineSegments,
) -> Option<BTreeMap<usize, Vec<Run>>> {
    let mut runs: BTreeMap<usize, Vec<Run>> = BTreeMap::new();
    let mut at: Option<Point3<f64>> = None;
    for (k, e) in executed.iter().enumerate() {
        let line = e.line_index as usize;
        let from = e.segments_before as usize;
        let to = executed
            .get(k + 1)
            .map_or(segments.len(), |n| n.segments_before as usize);
        if (from..to).any(|j| trace.segments[j].line_index != line) {
            return None;
        }
        if by_line.tabled(line) {
            runs.entry(line).or_default().push(match to - from {
                0 => Run::Idle(at),
                1 => Run::Moved(from),
                _ => Run::Several,
            });
        }
        if to > from {
            at = Some(segments[to - 1].end);
        }
    }
    Some(runs)
}

/// Lines that run more than once as one plain feed move per run, with runs
/// that need different feeds or more than one block: each gets a counter and
/// a table, one record per run ([`RunTable`]), instead of the lowest feed of
/// all runs. A run that needs fewer blocks than another has its longest
/// pieces halved (same feed) until it has as many; a run that does not move
/// gets a record that keeps it still (its F, or its point when the line is
/// split). None when the program names a parameter of [`TABLE_PARAMS`]
/// itself. Also returns the lines whose records did not fit (in line
/// order), to be unrolled ([`crate::unroll`]).
fn run_tables(
    source: &str,
    by_line: &LineSegments,
    segments: &[Segment],
    trace: &interp::Trace,
    executed: &[Executed],
    plan: &[Vec<(f64, f64)>],
) -> (BTreeMap<usize, RunTable>, Vec<usize>) {
    let mut tables = BTreeMap::new();
    let mut unfit = Vec::new();
    if named_parameters(source)
        .iter()
        .any(|n| TABLE_PARAMS.contains(n))
    {
        return (tables, unfit);
    }
    let all_runs = line_runs(executed, trace, segments, by_line);
    let mut next = *TABLE_PARAMS.start();
    let mut again = Vec::new();
    for (index, segs) in by_line.iter() {
        // A line of one segment has no table (and no entry in `all_runs`).
        if !by_line.tabled(index) {
            continue;
        }
        let runs: Vec<Run> = match &all_runs {
            Some(r) => r[&index].clone(),
            None => segs.iter().map(|&i| Run::Moved(i)).collect(),
        };
        let all_feeds = segs
            .iter()
            .all(|&i| matches!(segments[i].motion, Motion::Feed { .. }));
        let Some(items) = trace.lines.block_items(index, source, &mut again) else {
            continue;
        };
        if runs.iter().any(|r| matches!(r, Run::Several))
            || !all_feeds
            || segs
                .iter()
                .any(|&i| !splittable(items, &segments[i]) || trace.segments[i].compensated)
        {
            continue;
        }
        let idle = runs.len() > segs.len();
        let blocks = segs.iter().map(|&i| plan[i].len()).max().unwrap_or(1);
        let (letters, values) = if blocks == 1 {
            let moved: Vec<f64> = segs
                .iter()
                .map(|&i| {
                    f_value(&f_word(
                        &trace.segments[i],
                        lowest(&plan[i]),
                        segments[i].length_mm(),
                        true,
                    ))
                })
                .collect();
            let lo = moved.iter().copied().fold(f64::INFINITY, f64::min);
            if moved.iter().all(|v| *v <= lo * 1.001) {
                continue;
            }
            let mut k = 0;
            let values = runs
                .iter()
                .map(|r| match r {
                    Run::Moved(_) => {
                        k += 1;
                        moved[k - 1]
                    }
                    _ => lo,
                })
                .collect();
            (vec![vec!['f']], values)
        } else {
            // Every run the same kind of move (a line may take its motion mode from before it).
            let first = &segments[segs[0]];
            let same_kind = segs.iter().all(|&i| {
                motion_word(&segments[i].geometry) == motion_word(&first.geometry)
                    && plane_of(&segments[i].geometry) == plane_of(&first.geometry)
            });
            // A run that stays still is written as straight moves to where the tool is.
            let still = !idle
                || (matches!(first.geometry, Geometry::Line)
                    && segs.iter().all(|&i| !trace.segments[i].inverse_time)
                    && runs.iter().all(|r| !matches!(r, Run::Idle(None))));
            if !same_kind || !still {
                continue;
            }
            let axes: [bool; 3] =
                std::array::from_fn(|a| segs.iter().any(|&i| block_axes(items, &segments[i])[a]));
            // Values per block: the axes, an arc's centre, F.
            let per_block = axes.iter().filter(|&&a| a).count()
                + if plane_of(&first.geometry).is_some() {
                    2
                } else {
                    0
                }
                + 1;
            let available = (*TABLE_PARAMS.end() - next) as usize;
            let mut blocks = blocks;
            if runs.len() * blocks * per_block > available {
                // Too many records: the loops around the line may be written
                // out instead; failing that, every run in fewer blocks.
                unfit.push(index);
                blocks = available / (runs.len() * per_block);
                if blocks < 2 {
                    continue;
                }
            }
            let mut letters: Vec<Vec<char>> = Vec::new();
            let mut values = Vec::new();
            // The run whose modes a still run is written in: the last that moved, else the first.
            let mut reference = segs[0];
            for r in &runs {
                let words = match *r {
                    Run::Moved(i) => {
                        reference = i;
                        let pieces = padded(&coarsened(&plan[i], blocks), blocks);
                        block_values(&segments[i], &trace.segments[i], axes, &pieces)
                    }
                    Run::Idle(Some(at)) => {
                        let seg = Segment {
                            start: at,
                            end: at,
                            ..segments[reference]
                        };
                        let pieces = padded(&[(1.0, lowest(&plan[reference]))], blocks);
                        block_values(&seg, &trace.segments[reference], axes, &pieces)
                    }
                    Run::Idle(None) | Run::Several => unreachable!("checked above"),
                };
                if letters.is_empty() {
                    letters = words
                        .iter()
                        .map(|b| b.iter().map(|w| w.0).collect())
                        .collect();
                }
                values.extend(words.iter().flatten().map(|w| w.1));
            }
            (letters, values)
        };
        let needed = values.len() as u32 + 1;
        if next + needed - 1 > *TABLE_PARAMS.end() {
            if !unfit.contains(&index) {
                unfit.push(index);
            }
            continue;
        }
        tables.insert(
            index,
            RunTable {
                counter: next,
                first: next + 1,
                letters,
                values,
                idle,
            },
        );
        next += needed;
    }
    (tables, unfit)
}

/// The canned cycles' G codes.
const CYCLE_CODES: [f64; 6] = [73.0, 81.0, 82.0, 83.0, 85.0, 89.0];

/// Modal G codes a cycle line written out may carry: they are written in a
/// block of their own before its moves (G17, G20/G21, G90/G91, G98/G99).
const CYCLE_MODES: [f64; 7] = [17.0, 20.0, 21.0, 90.0, 91.0, 98.0, 99.0];

/// Canned cycles to write out as plain moves: when a cycle's feed moves need
/// more than one feed (a piece in air above the stock, another in it), every
/// line that makes rapid and feed moves in one block (the cycle lines up to
/// G80) is written as G0/G1/G4 blocks of its moves, each feed move split as
/// planned. All of them or none: a cycle line left as written would read its
/// modal cycle from a line now written out. Every repeat of an L count and
/// every hole of polar words (`@`, `^`, incremental too) is written as the
/// moves it made, in X Y Z. None when a cycle line carries other words than
/// the cycle's (G73, G81–G83, G85, G89, [`CYCLE_MODES`], X Y Z @ ^ R Q P L F, N), stops or reverses the spindle (G74, G84, G86, G87), runs
/// under cutter compensation or G93, or (found when the result does not read
/// back) runs more than once.
fn cycle_lines(
    source: &str,
    by_line: &LineSegments,
    segments: &[Segment],
    trace: &interp::Trace,
    plan: &[Vec<(f64, f64)>],
) -> BTreeSet<usize> {
    let mut lines = BTreeSet::new();
    let mut needed = false;
    let mut again = Vec::new();
    for (index, segs) in by_line.iter() {
        let feeds: Vec<usize> = segs
            .iter()
            .copied()
            .filter(|&i| matches!(segments[i].motion, Motion::Feed { .. }))
            .collect();
        let rapid = segs
            .iter()
            .any(|&i| matches!(segments[i].motion, Motion::Rapid));
        if feeds.is_empty() || !rapid {
            continue;
        }
        let Some(items) = trace.lines.block_items(index, source, &mut again) else {
            return BTreeSet::new();
        };
        let cycle_words = items.iter().all(|it| match &it.kind {
            ItemKind::Word {
                letter: 'g',
                value: Expr::Num(v),
            } => CYCLE_CODES.contains(v) || CYCLE_MODES.contains(v),
            ItemKind::Word { letter, .. } => matches!(
                letter,
                'x' | 'y' | 'z' | '@' | '^' | 'r' | 'q' | 'p' | 'l' | 'f' | 'n'
            ),
            ItemKind::Assign { .. } => false,
        });
        let plain = segs.iter().all(|&i| {
            let t = &trace.segments[i];
            !t.compensated
                && !t.inverse_time
                && !t.spindle_cycle
                && matches!(segments[i].geometry, Geometry::Line)
        });
        if !cycle_words || !plain {
            return BTreeSet::new();
        }
        // The line's own moves need more than one F.
        let lo = feeds
            .iter()
            .map(|&i| lowest(&plan[i]))
            .fold(f64::INFINITY, f64::min);
        needed |= feeds
            .iter()
            .any(|&i| plan[i].len() > 1 || lowest(&plan[i]) > lo * 1.001);
        lines.insert(index);
    }
    if needed {
        lines
    } else {
        BTreeSet::new()
    }
}

/// A canned cycle line run more than once (in a loop, or a subroutine
/// called several times), written out per run: a counter parameter counts
/// its runs and an o-word `if`/`elseif` chain on it runs each run's own
/// moves.
struct CycleRuns {
    /// Parameter counting the runs (from [`TABLE_PARAMS`], after the tables).
    counter: u32,
    /// Label of the `if` chain (above every numbered label of the program).
    label: i64,
    /// Each run's segments, in the order the runs ran.
    runs: Vec<std::ops::Range<usize>>,
}

/// Per line of `expanded` run more than once, its runs ([`CycleRuns`]).
/// None when such a line has no counter to tell its runs apart: the program
/// names a parameter of [`TABLE_PARAMS`], or the tables leave none, or a
/// run's moves were made by another line.
fn cycle_runs(
    source: &str,
    expanded: &BTreeSet<usize>,
    executed: &[Executed],
    trace: &interp::Trace,
    tables: &BTreeMap<usize, RunTable>,
) -> Option<BTreeMap<usize, CycleRuns>> {
    let mut runs: BTreeMap<usize, Vec<std::ops::Range<usize>>> = BTreeMap::new();
    for (k, e) in executed.iter().enumerate() {
        let index = e.line_index as usize;
        if !expanded.contains(&index) {
            continue;
        }
        let from = e.segments_before as usize;
        let to = executed
            .get(k + 1)
            .map_or(trace.segments.len(), |n| n.segments_before as usize);
        if (from..to).any(|j| trace.segments[j].line_index != index) {
            return None;
        }
        runs.entry(index).or_default().push(from..to);
    }
    runs.retain(|_, r| r.len() > 1);
    if runs.is_empty() {
        return Some(BTreeMap::new());
    }
    if named_parameters(source)
        .iter()
        .any(|n| TABLE_PARAMS.contains(n))
    {
        return None;
    }
    let first = tables
        .values()
        .map(|t| t.first + t.values.len() as u32)
        .max()
        .unwrap_or(*TABLE_PARAMS.start());
    if first + runs.len() as u32 - 1 > *TABLE_PARAMS.end() {
        return None;
    }
    let last_label = trace
        .lines
        .iter()
        .filter_map(|l| match l {
            Some(syntax::Line {
                kind: LineKind::OWord(s),
                ..
            }) => match s.label {
                syntax::OLabel::Number(n) => Some(n),
                syntax::OLabel::Name(_) => None,
            },
            _ => None,
        })
        .max()
        .unwrap_or(0)
        .max(9000);
    Some(
        runs.into_iter()
            .enumerate()
            .map(|(k, (index, runs))| {
                (
                    index,
                    CycleRuns {
                        counter: first + k as u32,
                        label: last_label + 1 + k as i64,
                        runs,
                    },
                )
            })
            .collect(),
    )
}

/// A canned cycle line written out ([`cycle_lines`]): a comment, then per
/// run (one, or each of [`CycleRuns`] in its branch of an `if` chain on the
/// run counter) the modal G codes of the line in a block of their own
/// ([`CYCLE_MODES`]: the moves are written in the distance mode and units
/// the line sets, and the modes stay in force after it as they did), then
/// one block per move (G0, G1 per planned piece, G4 for a dwell) with every
/// axis. Under G91 each block's increments run from where the block before
/// ends as written, so rounding never accumulates over the line's repeats.
#[allow(clippy::too_many_arguments)]
fn write_expanded(
    out: &mut String,
    source: &str,
    index: usize,
    eol: &str,
    segs: &[usize],
    per_run: Option<&CycleRuns>,
    segments: &[Segment],
    trace: &interp::Trace,
    plan: &WrittenPlan<'_>,
    written_pieces: &mut [usize],
) {
    let nl = eol_or_newline(eol);
    let _ = write!(
        out,
        "(dexcut: the canned cycle of line {}, written out{}){nl}",
        index + 1,
        if per_run.is_some() { " per run" } else { "" }
    );
    let text_of = |words: Vec<(char, f64)>| {
        words_text(words.into_iter().map(|(l, v)| {
            let text = if l == 'f' {
                trim_number(&format!("{v:.8}"))
            } else {
                coord(v)
            };
            (l, text)
        }))
    };
    let mut modes = String::new();
    if let Some(items) = trace.lines.block_items(index, source, &mut Vec::new()) {
        let codes: Vec<String> = items
            .iter()
            .filter_map(|it| match &it.kind {
                ItemKind::Word {
                    letter: 'g',
                    value: Expr::Num(v),
                } if CYCLE_MODES.contains(v) => Some(format!("G{}", trim_number(&v.to_string()))),
                _ => None,
            })
            .collect();
        modes = codes.join(" ");
    }
    // The blocks of one run.
    let mut run_blocks = |segs: &mut dyn Iterator<Item = usize>, blocks: &mut Vec<String>| {
        if !modes.is_empty() {
            blocks.push(modes.clone());
        }
        // Program coordinates as written so far (the increments under G91).
        let mut written: Option<[f64; 3]> = None;
        for i in segs {
            let (seg, t) = (&segments[i], &trace.segments[i]);
            let written = written.get_or_insert_with(|| {
                std::array::from_fn(|a| (seg.start[a] - t.offset_mm[a]) / t.scale)
            });
            match seg.motion {
                Motion::Rapid => {
                    let words =
                        piece_values(seg, t, [true; 3], seg.start.into(), seg.end.into(), written);
                    blocks.push(format!("G0 {}", text_of(words)));
                }
                Motion::Feed { .. } => {
                    written_pieces[i] = plan[i].len();
                    for words in pieces_values(seg, t, [true; 3], &plan[i], written, false) {
                        blocks.push(format!("G1 {}", text_of(words)));
                    }
                }
                Motion::Dwell { seconds } => {
                    blocks.push(format!("G4 P{}", trim_number(&format!("{seconds:.6}"))));
                }
            }
        }
    };
    let mut blocks: Vec<String> = Vec::new();
    match per_run {
        None => run_blocks(&mut segs.iter().copied(), &mut blocks),
        Some(c) => {
            blocks.push(format!("#{n} = [#{n} + 1]", n = c.counter));
            for (k, r) in c.runs.iter().enumerate() {
                blocks.push(format!(
                    "o{} {} [#{} EQ {}]",
                    c.label,
                    if k == 0 { "if" } else { "elseif" },
                    c.counter,
                    k + 1
                ));
                run_blocks(&mut r.clone(), &mut blocks);
            }
            blocks.push(format!("o{} endif", c.label));
        }
    }
    for (k, b) in blocks.iter().enumerate() {
        out.push_str(b);
        out.push_str(if k + 1 == blocks.len() { eol } else { nl });
    }
    if blocks.is_empty() {
        out.push_str(eol);
    }
}

/// `pieces` in at most `blocks` pieces: the two neighbours whose merge at the
/// lower of their feeds costs least time merged, until there are no more.
fn coarsened(pieces: &[(f64, f64)], blocks: usize) -> Vec<(f64, f64)> {
    let mut out = pieces.to_vec();
    while out.len() > blocks.max(1) {
        let start = |k: usize, out: &[(f64, f64)]| if k == 0 { 0.0 } else { out[k - 1].0 };
        let (k, _) = (0..out.len() - 1)
            .map(|k| {
                let (a, b) = (out[k], out[k + 1]);
                let f = a.1.min(b.1);
                let (la, lb) = (a.0 - start(k, &out), b.0 - a.0);
                (k, (la + lb) / f - la / a.1 - lb / b.1)
            })
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .expect("two pieces");
        out[k] = (out[k + 1].0, out[k].1.min(out[k + 1].1));
        out.remove(k + 1);
    }
    out
}

/// `pieces` in `blocks` pieces: the longest halved (same feed) until there are as many.
fn padded(pieces: &[(f64, f64)], blocks: usize) -> Vec<(f64, f64)> {
    let mut out = pieces.to_vec();
    while out.len() < blocks {
        let (k, _) = out
            .iter()
            .enumerate()
            .map(|(k, p)| (k, p.0 - if k == 0 { 0.0 } else { out[k - 1].0 }))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a piece");
        let start = if k == 0 { 0.0 } else { out[k - 1].0 };
        out.insert(k, (0.5 * (start + out[k].0), out[k].1));
    }
    out
}

/// Lines that set every counter to 0 and every table entry to its feed.
fn table_header(
    tables: &BTreeMap<usize, RunTable>,
    per_run: &BTreeMap<usize, CycleRuns>,
    nl: &str,
) -> String {
    let mut h = String::new();
    if !per_run.is_empty() {
        let _ = write!(
            h,
            "(dexcut: counters of the canned cycles run more than once, written out per run){nl}"
        );
        for c in per_run.values() {
            let _ = write!(h, "#{} = 0{nl}", c.counter);
        }
    }
    if tables.is_empty() {
        return h;
    }
    let _ = write!(
        h,
        "(dexcut: feeds of lines run more than once, one per run){nl}"
    );
    if tables.values().any(|t| t.blocks() > 1) {
        let _ = write!(
            h,
            "(dexcut: and the end points and feeds of the blocks they are split into){nl}"
        );
    }
    for t in tables.values() {
        let _ = write!(h, "#{} = 0{nl}", t.counter);
        for (k, v) in t.values.iter().enumerate() {
            let _ = write!(
                h,
                "#{} = {}{nl}",
                t.first + k as u32,
                trim_number(&format!("{v:.8}"))
            );
        }
    }
    h
}

fn valid_pieces(pieces: &[(f64, f64)]) -> bool {
    let mut prev = 0.0;
    for &(frac, feed) in pieces {
        if !(frac > prev && frac <= 1.0 && feed > 0.0 && feed.is_finite()) {
            return false;
        }
        prev = frac;
    }
    prev == 1.0
}

fn lowest(pieces: &[(f64, f64)]) -> f64 {
    pieces.iter().map(|p| p.1).fold(f64::INFINITY, f64::min)
}

fn word_letter(item: &Item) -> Option<char> {
    match &item.kind {
        ItemKind::Word { letter, .. } => Some(*letter),
        ItemKind::Assign { .. } => None,
    }
}

/// A line may be split when its one feed segment is a plain G1/G2/G3 move:
/// no G53 (machine coordinates), no dwell or program stop in the block, G and
/// M codes written as numbers, no multi-turn arc. Polar words (`@`, `^`) are
/// written as the X and Y of each piece ([`block_axes`]).
fn splittable(items: &[Item], seg: &Segment) -> bool {
    let plain_codes = items.iter().all(|it| match &it.kind {
        ItemKind::Word {
            letter: 'g',
            value: Expr::Num(v),
        } => ![4.0, 53.0].contains(v),
        ItemKind::Word {
            letter: 'm',
            value: Expr::Num(v),
        } => ![0.0, 1.0, 2.0, 30.0, 60.0].contains(v),
        ItemKind::Word {
            letter: 'g' | 'm', ..
        } => false,
        _ => true,
    });
    let multi_turn = matches!(seg.geometry, Geometry::Arc { sweep_rad, .. } if sweep_rad > std::f64::consts::TAU + 1e-9);
    plain_codes && !multi_turn
}

/// `F` word for a feed in mm/min over a piece `length_mm` long, six significant
/// digits (at least three decimals) rounded down, so the feed never exceeds it. `in_original_line`: the F word is read with
/// the units in force before the line (a G20/G21 in it comes after F).
fn f_word(t: &SegmentTrace, feed_mm_min: f64, length_mm: f64, in_original_line: bool) -> String {
    let scale = if in_original_line {
        t.feed_scale
    } else {
        t.scale
    };
    let value = if t.inverse_time {
        feed_mm_min / length_mm
    } else {
        feed_mm_min / scale
    };
    // Six significant digits (at least three decimals), rounded down.
    let magnitude = value.abs().log10().floor() as i32;
    let decimals = (5 - magnitude).clamp(3, 8);
    let unit = 10f64.powi(decimals);
    let v = ((value * unit * (1.0 + 1e-12)).floor() / unit).max(1.0 / unit);
    format!("F{}", trim_number(&format!("{v:.*}", decimals as usize)))
}

fn f_value(word: &str) -> f64 {
    word[1..].parse().unwrap_or(f64::INFINITY)
}

fn trim_number(s: &str) -> String {
    if s.contains('.') {
        let t = s.trim_end_matches('0').trim_end_matches('.');
        if t.is_empty() || t == "-" || t == "-0" {
            "0".into()
        } else {
            t.into()
        }
    } else {
        s.into()
    }
}

fn coord(v: f64) -> String {
    trim_number(&format!("{v:.6}"))
}

/// The line with its F word replaced by (or, without one, followed by) `f`.
fn with_f_word(text: &str, items: &[Item], f: &str) -> String {
    if let Some(it) = items.iter().find(|it| word_letter(it) == Some('f')) {
        format!(
            "{}{}{}",
            &text[..it.span().start],
            f,
            &text[it.span().end..]
        )
    } else {
        let end = items.last().map_or(text.len(), |it| it.span().end);
        format!("{} {}{}", &text[..end], f, &text[end..])
    }
}

/// Axis and centre words of one piece from `from` to `to` (machine mm), as
/// (letter, value as written). `axes`: which of X, Y, Z to write (the others
/// keep their value).
fn piece_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    from: [f64; 3],
    to: [f64; 3],
    written_start: &mut [f64; 3],
) -> Vec<(char, f64)> {
    let mut w = Vec::new();
    let written = |v: f64| coord(v).parse::<f64>().unwrap_or(v);
    for (i, l) in ['x', 'y', 'z']
        .into_iter()
        .enumerate()
        .filter(|&(i, _)| axes[i])
    {
        let v = if t.incremental {
            // Increments from the position written so far, so rounding never accumulates.
            let target = (to[i] - t.offset_mm[i]) / t.scale;
            let inc = written(target - written_start[i]);
            written_start[i] += inc;
            inc
        } else {
            written((to[i] - t.offset_mm[i]) / t.scale)
        };
        w.push((l, v));
    }
    if let Geometry::Arc { center, plane, .. } = seg.geometry {
        let (a, b, _) = plane.axes();
        let mut axes = [a, b];
        axes.sort_unstable();
        for axis in axes {
            let v = if t.arc_incremental {
                (center[axis] - from[axis]) / t.scale
            } else {
                (center[axis] - t.offset_mm[axis]) / t.scale
            };
            w.push((['i', 'j', 'k'][axis], written(v)));
        }
    }
    w
}

/// The words of every block a segment is split into, F last: axis and
/// centre values as written, F as [`f_word`] writes it (the first block's
/// read with the units in force before the line).
fn block_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    pieces: &[(f64, f64)],
) -> Vec<Vec<(char, f64)>> {
    // Program coordinates written so far (for increments under G91).
    let mut written: [f64; 3] = std::array::from_fn(|i| (seg.start[i] - t.offset_mm[i]) / t.scale);
    pieces_values(seg, t, axes, pieces, &mut written, true)
}

/// [`block_values`] from the position `written` so far (program
/// coordinates, updated to the last block's end as written);
/// `in_original_line`: the first block's F is read in the units in force
/// before the line ([`f_word`]), else every F in the segment's own units.
fn pieces_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    pieces: &[(f64, f64)],
    written: &mut [f64; 3],
    in_original_line: bool,
) -> Vec<Vec<(char, f64)>> {
    let fractions: Vec<f64> = std::iter::once(0.0)
        .chain(pieces.iter().map(|p| p.0))
        .collect();
    let points: Vec<[f64; 3]> = fractions
        .iter()
        .map(|&u| {
            if u >= 1.0 {
                seg.end.into()
            } else {
                seg.point_at_fraction(u).into()
            }
        })
        .collect();
    // Lines and arcs (helices included) run at constant speed in the fraction.
    let length_mm = seg.length_mm();
    (0..pieces.len())
        .map(|k| {
            let mut words = piece_values(seg, t, axes, points[k], points[k + 1], written);
            let f = f_word(
                t,
                pieces[k].1,
                length_mm * (fractions[k + 1] - fractions[k]),
                in_original_line && k == 0,
            );
            words.push(('f', f_value(&f)));
            words
        })
        .collect()
}

/// Words of one block as text, each followed by a blank but the last.
fn words_text(words: impl Iterator<Item = (char, String)>) -> String {
    let parts: Vec<String> = words
        .map(|(l, v)| format!("{}{v}", l.to_ascii_uppercase()))
        .collect();
    parts.join(" ")
}

/// G1, G2 or G3.
fn motion_word(geometry: &Geometry) -> &'static str {
    match geometry {
        Geometry::Arc {
            clockwise: true, ..
        } => "G2",
        Geometry::Arc {
            clockwise: false, ..
        } => "G3",
        Geometry::Line => "G1",
    }
}

fn plane_of(geometry: &Geometry) -> Option<crate::path::Plane> {
    match geometry {
        Geometry::Arc { plane, .. } => Some(*plane),
        Geometry::Line => None,
    }
}

/// Axes a block of the line writes: those the line names (X and Y for polar
/// `@`/`^` words, which the blocks replace), those that move, and an arc's
/// plane axes.
fn block_axes(items: &[Item], seg: &Segment) -> [bool; 3] {
    let plane_axes = plane_of(&seg.geometry).map(|p| p.axes());
    let polar = items
        .iter()
        .any(|it| matches!(word_letter(it), Some('@' | '^')));
    std::array::from_fn(|i| {
        let named = items
            .iter()
            .any(|it| word_letter(it) == Some(['x', 'y', 'z'][i]))
            || (polar && i < 2);
        named || seg.start[i] != seg.end[i] || plane_axes.is_some_and(|(a, b, _)| i == a || i == b)
    })
}

/// Writes the line carrying the first piece and one block per further piece.
fn split_line(
    out: &mut String,
    text: &str,
    eol: &str,
    items: &[Item],
    seg: &Segment,
    t: &SegmentTrace,
    pieces: &[(f64, f64)],
) {
    let blocks: Vec<String> = block_values(seg, t, block_axes(items, seg), pieces)
        .into_iter()
        .map(|b| {
            words_text(b.into_iter().map(|(l, v)| {
                let text = if l == 'f' {
                    trim_number(&format!("{v:.8}"))
                } else {
                    coord(v)
                };
                (l, text)
            }))
        })
        .collect();
    write_blocks(out, text, eol, items, &seg.geometry, &blocks);
}

/// Writes the line with its axis, centre and F words replaced by `blocks[0]`,
/// then one block per further entry of `blocks` in the line's motion mode.
fn write_blocks(
    out: &mut String,
    text: &str,
    eol: &str,
    items: &[Item],
    geometry: &Geometry,
    blocks: &[String],
) {
    let arc = matches!(geometry, Geometry::Arc { .. });
    // Words the pieces rewrite: axes (polar ones too), arc centre / radius / turns, feed.
    let replaced: Vec<&Item> = items
        .iter()
        .filter(|it| match word_letter(it) {
            Some('x' | 'y' | 'z' | 'f' | '@' | '^') => true,
            Some('i' | 'j' | 'k' | 'r' | 'p') => arc,
            _ => false,
        })
        .collect();
    let first = &blocks[0];
    let mut line = String::with_capacity(text.len() + first.len());
    let mut at = 0;
    for (k, it) in replaced.iter().enumerate() {
        let gap = &text[at..it.span().start];
        // Blanks between two rewritten words go with them.
        if k == 0 || !gap.trim().is_empty() {
            line.push_str(gap);
        }
        if k == 0 {
            line.push_str(first);
        }
        at = it.span().end;
    }
    if replaced.is_empty() {
        let end = items.last().map_or(text.len(), |it| it.span().end);
        line.push_str(&text[..end]);
        line.push(' ');
        line.push_str(first);
        at = end;
    }
    line.push_str(&text[at..]);
    out.push_str(&line);
    out.push_str(eol_or_newline(eol));
    for (k, block) in blocks.iter().enumerate().skip(1) {
        out.push_str(motion_word(geometry));
        out.push(' ');
        out.push_str(block);
        out.push_str(if k + 1 == blocks.len() {
            eol
        } else {
            eol_or_newline(eol)
        });
    }
}

fn eol_or_newline(eol: &str) -> &str {
    if eol.is_empty() {
        "\n"
    } else {
        eol
    }
}

/// Parses the re-fed program and checks it against the original path and
/// plan; what it read.
fn verify(
    out: &str,
    file: &str,
    options: &Options,
    original: &[Expected],
    plan: &WrittenPlan<'_>,
    written: &[usize],
) -> Result<Parsed, RefeedError> {
    let fail = |detail: String| RefeedError::Verification {
        file: file.to_owned(),
        detail,
    };
    // Its blocks parsed where they run, not held (a million-line text's
    // items, about 190 MB).
    let parsed = interp::parse(out, file, options);
    if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
        return Err(fail(format!("it does not parse: {d}")));
    }
    let new = &parsed.path.segments;
    let expected: usize = written.iter().sum();
    if new.len() != expected {
        return Err(fail(format!(
            "{} segments instead of {expected}",
            new.len()
        )));
    }
    let mut j = 0;
    for (i, seg) in original.iter().enumerate() {
        let pieces = &new[j..j + written[i]];
        j += written[i];
        let end = pieces[pieces.len() - 1].end;
        if (end - seg.end).norm() > 1e-3 {
            return Err(fail(format!(
                "line {}: ends at {:?} instead of {:?}",
                seg.line, end, seg.end
            )));
        }
        // Same end points can hide a changed shape: a piece of an arc shorter
        // than the written digits reads back as a full circle.
        let length_mm: f64 = pieces.iter().map(Segment::length_mm).sum();
        if (length_mm - seg.length_mm).abs() > 1e-3 {
            return Err(fail(format!(
                "line {}: {length_mm:.4} mm long instead of {:.4} mm",
                seg.line, seg.length_mm
            )));
        }
        if std::mem::discriminant(&pieces[0].motion) != std::mem::discriminant(&seg.motion) {
            return Err(fail(format!("line {}: motion kind changed", seg.line)));
        }
        if let Motion::Feed { .. } = seg.motion {
            for (k, p) in pieces.iter().enumerate() {
                let allowed = if written[i] == 1 {
                    lowest(&plan[i])
                } else {
                    plan[i][k].1
                };
                let Motion::Feed { feed_mm_min, held } = p.motion else {
                    return Err(fail(format!(
                        "line {}: a piece is not a feed move",
                        seg.line
                    )));
                };
                // A held feed (tapping) reads back held, at its own feed.
                if let Some(programmed) = seg.motion.held_feed_mm_min() {
                    if !held || (feed_mm_min - programmed).abs() > 1e-4 * programmed {
                        return Err(fail(format!(
                            "line {}: the held feed {programmed:.3} mm/min reads back as {feed_mm_min:.3} mm/min{}",
                            seg.line,
                            if held { "" } else { ", not held" }
                        )));
                    }
                } else if held {
                    return Err(fail(format!("line {}: a feed reads back held", seg.line)));
                }
                if feed_mm_min > allowed * (1.0 + 1e-4) {
                    return Err(fail(format!(
                        "line {}: feed {feed_mm_min:.3} above the plan's {allowed:.3} mm/min",
                        seg.line
                    )));
                }
            }
        }
    }
    Ok(parsed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The check keeps of the source's path only its ends, lengths, motions
    /// and lines ([`Expected`]), and refuses each change of them as the
    /// path itself did: the written text read back passes; a moved end, an
    /// arc round another centre to the same end, a feed move made a rapid and
    /// a feed above the plan each fail, with the line they are on.
    #[test]
    fn the_check_refuses_each_change_the_path_would() {
        let src = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10 F600\nG2 X20 Y0 I5 J0 F600\nG0 Z5\n";
        let options = Options::default();
        let path = crate::parse(src, "t.ngc", &options).path;
        let plan: Vec<Vec<(f64, f64)>> = path
            .segments
            .iter()
            .map(|s| match s.motion {
                Motion::Feed { .. } => vec![(1.0, 500.0)],
                _ => Vec::new(),
            })
            .collect();
        let expected: Vec<Expected> = path.segments.iter().map(Expected::of).collect();
        let written = WrittenPlan {
            plan: &plan,
            coarse: BTreeMap::new(),
        };
        let pieces = vec![1; plan.len()];
        let check = |text: &str| verify(text, "t.ngc", &options, &expected, &written, &pieces);
        let good = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10 F500\nG2 X20 Y0 I5 J0 F500\nG0 Z5\n";
        assert_eq!(
            check(good).expect("the plan's feeds read back").path,
            crate::parse(good, "t.ngc", &options).path
        );
        for (text, says) in [
            (good.replace("X10 F500", "X10.01 F500"), "line 3: ends at"),
            (
                good.replace("I5 J0", "I5 J5"),
                "line 4: 33.3216 mm long instead of 15.7080 mm",
            ),
            (
                good.replace("G1 X10 F500", "G0 X10"),
                "line 3: motion kind changed",
            ),
            (
                good.replace("X10 F500", "X10 F501"),
                "line 3: feed 501.000 above the plan's 500.000",
            ),
        ] {
            let err = check(&text).expect_err(&text).to_string();
            assert!(err.contains(says), "{text}: {err}");
        }
    }

    /// A run along a lent path holds none of it where it makes it bit for
    /// bit (its own path empty, [`interp::Trace::on_lent_path`]), and is
    /// otherwise the plain recorded run: the same path (the lent one, or its
    /// own), trace and executed lines. A lent path that differs (an end moved
    /// by one ulp, one segment short or more) gives the run its own path; so
    /// does cutter compensation, which moves a segment's end after it is made.
    #[test]
    fn a_run_along_a_lent_path_holds_it_only_where_it_differs() {
        let plain = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10\nG2 X20 Y0 I5 J0\nG0 Z5\nM2\n";
        let comp =
            "T1 M6\nG0 X-5 Y-5 Z1\nG1 Z-1 F300\nG41.1 D4 X0 Y0\nG1 X10\nY10\nG40 X15 Y15\nM2\n";
        let options = Options::default();
        for (src, along) in [(plain, true), (comp, false)] {
            let (want, trace, executed) = interp::run_recorded(src, "t.ngc", &options);
            assert!(want.diagnostics.is_empty(), "{:?}", want.diagnostics);
            let path = &want.path.segments;
            let n = path.len();
            let mut moved = path.clone();
            moved[n / 2].end.y = f64::from_bits(moved[n / 2].end.y.to_bits() + 1);
            let longer: Vec<Segment> = path.iter().chain(path.last()).copied().collect();
            for (lent, same) in [
                (&path[..], along),
                (&moved[..], false),
                (&path[..n - 1], false),
                (&longer[..], false),
            ] {
                let (got, t, e) = interp::run_recorded_along(src, "t.ngc", &options, lent);
                assert_eq!(t.on_lent_path, same, "{src}");
                let made = if same { lent } else { &got.path.segments[..] };
                assert_eq!(got.path.segments.is_empty(), same);
                assert!(made.len() == n && made.iter().zip(path).all(|(a, b)| a.same_bits(b)));
                assert_eq!(
                    (&got.diagnostics, &t.segments, &e),
                    (&want.diagnostics, &trace.segments, &executed)
                );
            }
        }
    }

    /// The flat per-line columns list each line's segments as a map of one
    /// `Vec` per line does: lines run many times by a loop and a subroutine,
    /// lines that make no segment, and the last line.
    #[test]
    fn line_segments_are_each_lines_segments_ascending() {
        let src = "o100 sub\nG1 Z[#1] F100\no100 endsub\nG0 X0 Y0 Z1\n#1 = 0\n\
            o1 while [#1 LT 5]\nG1 X[#1] F500\nY[#1]\no2 if [#1 EQ 2]\no100 call [-1]\no2 endif\n\
            #1 = [#1 + 1]\no1 endwhile\nG0 Z5\n";
        let (parsed, trace, _) = interp::run_recorded(src, "t.ngc", &Options::default());
        assert!(parsed.diagnostics.is_empty(), "{:?}", parsed.diagnostics);
        let mut map: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (i, t) in trace.segments.iter().enumerate() {
            map.entry(t.line_index).or_default().push(i);
        }
        assert!(map.values().any(|s| s.len() == 4), "{map:?}");
        let flat = lines_segments(&trace);
        let listed: Vec<(usize, Vec<usize>)> = flat
            .iter()
            .map(|(line, segs)| (line, segs.to_vec()))
            .collect();
        assert_eq!(listed, map.clone().into_iter().collect::<Vec<_>>());
        for line in 0..=trace.lines.len() + 1 {
            assert_eq!(
                flat.get(line),
                map.get(&line).map(Vec::as_slice),
                "line {line}"
            );
        }
    }
}
