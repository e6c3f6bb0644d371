//! Tables of runs: a line run more than once gets a counter parameter and
//! one record per run (its F, or each of its blocks' words), set at the top
//! of the program; and the pieces coarsened or padded to a run's blocks.

use std::collections::BTreeMap;

use nalgebra::Point3;

use super::words::{
    block_axes, block_values, f_value, f_word, lowest, motion_word, plane_of, splittable,
};
use super::LineSegments;
use crate::interp::{self, Executed};
use crate::path::{Geometry, Motion, Segment};

/// Parameters that hold the feeds of lines run more than once: one counter
/// per line and a table of its feeds, one per run, in this range of numbered
/// parameters (LinuxCNC's free globals; Fanuc macro B reads the same).
pub(super) const TABLE_PARAMS: std::ops::RangeInclusive<u32> = 1000..=4999;

/// Words of a line run more than once, one record per run in the order they
/// run: its F (one block per run), or the axis, centre and F words of each of
/// its blocks when its runs need pieces (every run split into the same number
/// of blocks, each run at its own points and feeds).
pub(super) struct RunTable {
    /// Parameter counting the runs.
    pub(super) counter: u32,
    /// Parameter holding the first run's first value.
    pub(super) first: u32,
    /// Per block, the letters of the words read from the table (F last).
    pub(super) letters: Vec<Vec<char>>,
    /// Values, `width()` per run, in the order the runs run.
    pub(super) values: Vec<f64>,
    /// Some run of the line does not move (its record keeps it still).
    pub(super) idle: bool,
}

impl RunTable {
    /// Values per run.
    pub(super) fn width(&self) -> usize {
        self.letters.iter().map(Vec::len).sum()
    }

    /// The expression reading value `j` of the current run (the counter
    /// counts from 1).
    pub(super) fn reference(&self, j: usize) -> String {
        let w = self.width() as u32;
        if w == 1 {
            format!("#[#{} + {}]", self.counter, self.first - 1 + j as u32)
        } else {
            format!("#[#{} * {w} + {}]", self.counter, self.first - w + j as u32)
        }
    }

    /// Blocks each run is written as.
    pub(super) fn blocks(&self) -> usize {
        self.letters.len()
    }
}

/// Numbers of the numbered parameters a program names literally (`#12`).
pub(super) fn named_parameters(source: &str) -> Vec<u32> {
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
pub(super) fn run_tables(
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
            || segs.iter().any(|&i| {
                !splittable(items, &segments[i])
                    || trace.segments[i].compensated
                    || trace.segments[i].rotated
            })
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

/// `pieces` in at most `blocks` pieces: the two neighbours whose merge at the
/// lower of their feeds costs least time merged, until there are no more.
pub(super) fn coarsened(pieces: &[(f64, f64)], blocks: usize) -> Vec<(f64, f64)> {
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
pub(super) fn padded(pieces: &[(f64, f64)], blocks: usize) -> Vec<(f64, f64)> {
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
