//! Unrolling: an o-word loop written out in full, as the lines it ran in
//! the order they ran, so that every line of it runs once.
//!
//! [`crate::refeed`] gives a line run more than once a record per run in a
//! table of numbered parameters. Where the records do not fit, the loops
//! around such a line are unrolled instead: the loop's control lines
//! (`do`/`while`/`endwhile`/`repeat`/`endrepeat`/`if`/`elseif`/`else`/
//! `endif`/`break`/`continue`) are dropped, and every other line it executed
//! (assignments, blocks, comments, subroutine calls) is written once per time
//! it ran. Expressions have no side effects in RS274/NGC, so the lines left
//! compute the same values in the same order and the program makes the same
//! moves (checked by the caller against the original path). MODEL.md §2.2.

use std::collections::HashMap;

use crate::interp::Executed;
use crate::syntax::{self, LineKind, OKeyword, OLabel};

/// Most bytes an unrolled program may have (the written file must stay a
/// file a controller loads).
pub const MAX_UNROLLED_BYTES: usize = 64 << 20;

/// A loop: its opening and closing lines (0-based, inclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Loop {
    open: usize,
    close: usize,
}

fn oword(lines: &[Option<syntax::Line>], i: usize) -> Option<&syntax::OStmt> {
    match &lines[i] {
        Some(syntax::Line {
            kind: LineKind::OWord(s),
            ..
        }) => Some(s),
        _ => None,
    }
}

/// The program's loops, paired as the interpreter pairs them: `do` with the
/// next `while` of its label, a `while` with a later `endwhile` of its label
/// with that `endwhile`, `repeat` with the next `endrepeat`.
fn loops(lines: &[Option<syntax::Line>]) -> Vec<Loop> {
    let mut at: HashMap<&OLabel, Vec<usize>> = HashMap::new();
    for i in 0..lines.len() {
        if let Some(s) = oword(lines, i) {
            at.entry(&s.label).or_default().push(i);
        }
    }
    let mut out = Vec::new();
    for list in at.values() {
        let next = |from: usize, keyword: OKeyword| {
            list.iter()
                .copied()
                .find(|&j| j > from && oword(lines, j).is_some_and(|s| s.keyword == keyword))
        };
        for &i in list {
            let close = match oword(lines, i).map(|s| s.keyword) {
                Some(OKeyword::Do) => next(i, OKeyword::While),
                Some(OKeyword::While) => next(i, OKeyword::EndWhile),
                Some(OKeyword::Repeat) => next(i, OKeyword::EndRepeat),
                _ => None,
            };
            if let Some(close) = close {
                out.push(Loop { open: i, close });
            }
        }
    }
    out.sort();
    out
}

/// Where in `executed` the loop ran, when it was entered once and holds no
/// subroutine definition or return: the range of entries and the depth.
fn single_entry(
    lines: &[Option<syntax::Line>],
    executed: &[Executed],
    l: Loop,
) -> Option<(std::ops::RangeInclusive<usize>, u32)> {
    let defines = (l.open..=l.close).any(|i| {
        oword(lines, i).is_some_and(|s| {
            matches!(
                s.keyword,
                OKeyword::Sub | OKeyword::EndSub | OKeyword::Return
            )
        })
    });
    if defines {
        return None;
    }
    let inside = |e: &Executed| (l.open..=l.close).contains(&(e.line_index as usize));
    let first = executed.iter().position(inside)?;
    let last = executed.iter().rposition(inside)?;
    let depth = executed[first].depth;
    let contiguous = executed[first..=last]
        .iter()
        .all(|e| e.depth > depth || (e.depth == depth && inside(e)));
    contiguous.then_some((first..=last, depth))
}

/// `source` with the outermost loop around each line of `wanted` that can
/// be unrolled written out in full; `None` when none can, or the result
/// would exceed [`MAX_UNROLLED_BYTES`].
pub fn unroll(
    source: &str,
    lines: &[Option<syntax::Line>],
    executed: &[Executed],
    wanted: &[usize],
) -> Option<String> {
    let all = loops(lines);
    // Per wanted line, the outermost loop around it that ran once as a whole.
    let mut chosen: Vec<(Loop, std::ops::RangeInclusive<usize>, u32)> = Vec::new();
    for &w in wanted {
        if chosen.iter().any(|(l, ..)| l.open < w && w < l.close) {
            continue;
        }
        let found = all
            .iter()
            .filter(|l| l.open < w && w < l.close)
            .find_map(|&l| single_entry(lines, executed, l).map(|(r, d)| (l, r, d)));
        if let Some(c) = found {
            chosen.retain(|(l, ..)| !(c.0.open < l.open && l.close < c.0.close));
            chosen.push(c);
        }
    }
    if chosen.is_empty() {
        return None;
    }
    chosen.sort_by_key(|c| c.0.open);
    let texts: Vec<(&str, &str)> = syntax::split_lines(source).collect();
    let line_text = |i: usize, out: &mut String| {
        let (text, eol) = texts[i];
        out.push_str(text);
        out.push_str(if eol.is_empty() { "\n" } else { eol });
    };
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    let mut next = chosen.iter().peekable();
    while i < texts.len() {
        match next.peek() {
            Some((l, range, depth)) if l.open == i => {
                for e in &executed[range.clone()] {
                    let index = e.line_index as usize;
                    let control = oword(lines, index).is_some_and(|s| s.keyword != OKeyword::Call);
                    if e.depth == *depth && !control {
                        line_text(index, &mut out);
                        if out.len() > MAX_UNROLLED_BYTES {
                            return None;
                        }
                    }
                }
                i = l.close + 1;
                next.next();
            }
            _ => {
                let (text, eol) = texts[i];
                out.push_str(text);
                out.push_str(eol);
                i += 1;
            }
        }
    }
    Some(out)
}
