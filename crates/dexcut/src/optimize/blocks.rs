//! The re-feed plan: piecewise-constant feeds in blocks under the caps, and
//! the blocks as the rounds keep them.

use crate::error::Result;
use nc::Motion;
use schedule::{CapKind, Machine, Stations};

use super::caps::apply_interval_caps_from;

/// Shortest block the re-feed writer emits, mm (and never shorter than the
/// control can read in its block time at the block's feed).
pub const MIN_BLOCK_MM: f64 = 0.2;
/// Feeds within this ratio are first merged into one block (the lower one is
/// written); [`write_verified`](super::write_verified) lowers it (down to [`MERGE_RATIO_MIN`]) when
/// the written program is slower than the plan by more than [`PLAN_TOLERANCE`].
pub const MERGE_RATIO: f64 = 1.05;
/// The written program's cycle time may exceed the plan's by this fraction.
pub const PLAN_TOLERANCE: f64 = 0.01;
/// The finest merge ratio tried.
pub const MERGE_RATIO_MIN: f64 = 1.01;

/// Per path segment, the feed pieces `(fraction_end, feed_mm_min)` to write:
/// piecewise-constant feeds that never exceed the limit caps (`interval_caps`,
/// and feed_max) in the piece. Feeds within `merge_ratio` share a block; a
/// block is at least [`MIN_BLOCK_MM`] long. A short last piece takes its length
/// from the piece before it rather than lowering that whole piece to its feed.
/// Corner, curvature and acceleration limits are left to the control, as with
/// any program.
pub fn refeed_plan(
    stations: &Stations,
    interval_caps: &[(f64, CapKind)],
    machine: &Machine,
    merge_ratio: f64,
) -> Vec<Vec<(f64, f64)>> {
    let segs = stations.segments();
    let mut plan: Vec<Vec<(f64, f64)>> = vec![Vec::new(); segs.len()];
    let (seg_of, frac, s) = (stations.segment(), stations.fraction(), stations.s_mm());
    let tb_ms = machine.block_time_ms.unwrap_or(0.0);
    let min_len = |feed: f64| MIN_BLOCK_MM.max(feed * tb_ms / 60_000.0);
    let mut k = 1;
    while k < stations.len() {
        let seg = seg_of[k] as usize;
        // Intervals of this segment: (s_end, fraction_end, cap).
        let first = k;
        while k < stations.len() && seg_of[k] as usize == seg {
            k += 1;
        }
        if !matches!(segs[seg].motion, Motion::Feed { .. }) {
            continue;
        }
        // A held feed (tapping) is written as programmed, in one piece.
        if let Some(feed) = segs[seg].motion.held_feed_mm_min() {
            plan[seg].push((1.0, feed));
            continue;
        }
        let cap = |i: usize| interval_caps[i - 1].0.min(machine.feed_max_mm_min);
        let min_cap = |a: usize, b: usize| (a..b).map(cap).fold(f64::INFINITY, f64::min);
        // Piece boundaries as station indices: piece j covers intervals bounds[j]+1 ..= bounds[j+1].
        let mut bounds = vec![first - 1];
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for i in first..k {
            let c = cap(i);
            let (new_lo, new_hi) = (lo.min(c), hi.max(c));
            let start = *bounds.last().expect("a start");
            let long_enough = s[i - 1] - s[start] >= min_len(lo);
            if lo.is_finite() && new_hi > merge_ratio * new_lo && long_enough {
                bounds.push(i - 1);
                (lo, hi) = (c, c);
            } else {
                (lo, hi) = (new_lo, new_hi);
            }
        }
        bounds.push(k - 1);
        // A last piece too short to be read in time takes length from the piece
        // before it, or joins it when that one would become too short.
        while bounds.len() > 2 {
            let n = bounds.len();
            let last_feed = min_cap(bounds[n - 2] + 1, bounds[n - 1] + 1);
            if s[bounds[n - 1]] - s[bounds[n - 2]] >= min_len(last_feed) {
                break;
            }
            let mut b = bounds[n - 2];
            while b > bounds[n - 3] + 1 && s[bounds[n - 1]] - s[b] < min_len(last_feed) {
                b -= 1;
            }
            let prev_feed = min_cap(bounds[n - 3] + 1, b + 1);
            if s[bounds[n - 1]] - s[b] >= min_len(last_feed)
                && s[b] - s[bounds[n - 3]] >= min_len(prev_feed)
            {
                bounds[n - 2] = b;
                break;
            }
            bounds.remove(n - 2);
        }
        plan[seg] = bounds
            .windows(2)
            .map(|w| {
                let f = if w[1] == k - 1 { 1.0 } else { frac[w[1]] };
                (f, min_cap(w[0] + 1, w[1] + 1))
            })
            .collect();
    }
    // Feed moves too short for a station (below the planner's shortest segment) keep their feed.
    for (seg, pieces) in segs.iter().zip(plan.iter_mut()) {
        if let (Motion::Feed { feed_mm_min, .. }, true) = (seg.motion, pieces.is_empty()) {
            pieces.push((1.0, feed_mm_min));
        }
    }
    plan
}

/// Where the written program's blocks begin among the intervals (station k
/// → k + 1): each interval that lies in another block (refeed plan piece)
/// than the interval before it, ascending. 4 B a block, not a block index an
/// interval (4 B an interval, 12 MB for 3 M free stations, held through a
/// round's re-feed and verification).
#[derive(Clone, Debug, PartialEq)]
pub struct Blocks {
    pub(super) starts: Vec<u32>,
    pub(super) intervals: usize,
}

impl Blocks {
    /// The blocks of the stations' intervals under the refeed plan `plan`:
    /// an interval lies in the piece of its end station's segment whose end
    /// fraction is at or past the station's (the first piece if none is).
    pub fn of(stations: &Stations, plan: &[Vec<(f64, f64)>]) -> Blocks {
        let (seg_of, frac) = (stations.segment(), stations.fraction());
        Blocks::where_they_change((1..stations.len()).map(|k| {
            let seg = seg_of[k] as usize;
            let f = frac[k];
            (
                seg,
                plan[seg].iter().position(|p| p.0 >= f - 1e-9).unwrap_or(0),
            )
        }))
    }

    /// The blocks of intervals whose blocks are `blocks`, in order: one
    /// begins wherever an interval's differs from the one before's.
    pub(super) fn where_they_change<T: PartialEq>(blocks: impl Iterator<Item = T>) -> Blocks {
        let mut starts = Vec::new();
        let mut before: Option<T> = None;
        let mut intervals = 0;
        for block in blocks {
            if before.as_ref().is_some_and(|b| *b != block) {
                starts.push(u32::try_from(intervals).expect("fewer than 2^32 intervals"));
            }
            before = Some(block);
            intervals += 1;
        }
        Blocks { starts, intervals }
    }

    /// The first and last interval of the block interval `k` lies in.
    pub fn around(&self, k: usize) -> (usize, usize) {
        let next = self.starts.partition_point(|&s| s as usize <= k);
        let first = next.checked_sub(1).map_or(0, |i| self.starts[i] as usize);
        let last = self
            .starts
            .get(next)
            .map_or(self.intervals.saturating_sub(1), |&s| s as usize - 1);
        (first, last)
    }
}

/// Apply to each interval the feed of the block (refeed plan piece) it lies
/// in, with the kind of cap that set the interval ([`apply_interval_caps`](super::apply_interval_caps)),
/// a chunk of intervals at a time: not a list of every interval's (16 B an
/// interval beside the plan). The same caps applied in the same
/// order.
pub fn apply_block_caps(
    stations: &mut Stations,
    plan: &[Vec<(f64, f64)>],
    caps: &[(f64, CapKind)],
) -> Result<()> {
    const CHUNK: usize = 1 << 16;
    let mut chunk = Vec::with_capacity(CHUNK.min(caps.len()));
    for first in (0..caps.len()).step_by(CHUNK) {
        let (seg_of, frac) = (stations.segment(), stations.fraction());
        chunk.clear();
        chunk.extend((first..caps.len().min(first + CHUNK)).map(|k| {
            let pieces = &plan[seg_of[k + 1] as usize];
            let f = frac[k + 1];
            match pieces.iter().find(|p| p.0 >= f - 1e-9) {
                Some(&(_, feed)) => (feed, caps[k].1),
                None => caps[k],
            }
        }));
        apply_interval_caps_from(stations, first, &chunk)?;
    }
    Ok(())
}
