//! Canned cycle lines written out as G0/G1/G4 blocks of their moves, each
//! feed move split as planned, and per run where a cycle line runs more
//! than once.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use super::tables::{named_parameters, RunTable, TABLE_PARAMS};
use super::words::{
    coord, eol_or_newline, lowest, piece_values, pieces_values, trim_number, words_text,
};
use super::{LineSegments, WrittenPlan};
use crate::expr::Expr;
use crate::interp::{self, Executed};
use crate::path::{Geometry, Motion, Segment};
use crate::syntax::{self, ItemKind, LineKind};

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
pub(super) fn cycle_lines(
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
                && !t.rotated
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
pub(super) struct CycleRuns {
    /// Parameter counting the runs (from [`TABLE_PARAMS`], after the tables).
    pub(super) counter: u32,
    /// Label of the `if` chain (above every numbered label of the program).
    pub(super) label: i64,
    /// Each run's segments, in the order the runs ran.
    pub(super) runs: Vec<std::ops::Range<usize>>,
}

/// Per line of `expanded` run more than once, its runs ([`CycleRuns`]).
/// None when such a line has no counter to tell its runs apart: the program
/// names a parameter of [`TABLE_PARAMS`], or the tables leave none, or a
/// run's moves were made by another line.
pub(super) fn cycle_runs(
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
pub(super) fn write_expanded(
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
