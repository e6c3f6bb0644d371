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

use crate::interp::{self, Executed, Options, Parsed};
use crate::path::{Motion, Segment};
use crate::syntax;

mod expanded;
mod tables;
#[cfg(test)]
mod tests;
mod verify;
mod words;

use expanded::{cycle_lines, cycle_runs, write_expanded, CycleRuns};
use tables::{coarsened, padded, run_tables, RunTable};
use verify::verify;
use words::{
    eol_or_newline, f_value, f_word, lowest, split_line, splittable, trim_number, valid_pieces,
    with_f_word, words_text, write_blocks,
};

/// Why a program could not be re-fed.
#[derive(Debug, Error)]
pub enum RefeedError {
    /// The source program has an error (the first one).
    #[error("{0}")]
    Program(crate::diag::Diagnostic),
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
    path: crate::path::Path,
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
        amended = crate::amend::amend(source, &parsed.amendments);
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
            && !trace.segments[feeds[0]].compensated
            && !trace.segments[feeds[0]].rotated;
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
