//! One sampled-geometry limiting kept for the next ones of the same stations
//! ([`Stations::limit_sampled_geometry`] in a corner choice, [`super::CornerChoice`]): each
//! later one judges again only the stations whose inputs differ from the kept one's.

use std::collections::BTreeSet;

use rayon::prelude::*;

use super::{CapKind, Cursor, LoweredCap, RecentTangents, SampledLimit, Stations, Stop};

/// A later limiting judges every station again where more than one in this many differ
/// (its ranges would cost more than the whole).
const MOST_AGAIN: usize = 4;

/// The first sampled-geometry limiting of a corner choice, kept.
///
/// Station k's limit (MODEL.md §6.1, "Sampled geometry") reads its cap, its speed on
/// the envelope, whether it is a stop, whether a turn starts or ends within 2·v·T of it
/// and whether a run ends within its samples (s − v·T to s + 2·v·T); the path and the
/// machine are the same in every limiting of a choice, and so are the caps it starts
/// from (the choice's caps before any corner was judged). A later limiting of the choice
/// differs in its stops and its intervals' accelerations: its stations whose envelope
/// speed differs, and those within that reach of a stop one of the two has and the other
/// has not, are judged again; every other station's lowered cap and every interval
/// between two of them are the kept ones, bit for bit.
pub(crate) struct SampledMemo {
    /// The stations of the stops it was made with.
    pub(super) stops: BTreeSet<usize>,
    /// The envelope its stations were judged at, mm/s.
    pub(super) envelope: Vec<f32>,
    /// Whether the path turns over each interval, stops or not: one bit an interval
    /// (interval k is bit k % 64 of word k / 64).
    pub(super) turns: Vec<u64>,
    /// The caps it lowered, ascending.
    pub(super) lowered: Vec<LoweredCap>,
    /// Each interval's least limit from its two stations' budgets, mm/s² (∞ where
    /// neither gives one).
    pub(super) interval_limits: Vec<f64>,
    /// What it kept of the caps it started from: a later limiting from other caps is
    /// made anew.
    pub(super) start: CapsStart,
    /// How many stations the last limiting from it judged again (the tests' check that
    /// the ranges were taken; `usize::MAX` where it was made anew).
    #[cfg(test)]
    pub(super) judged_last: std::sync::atomic::AtomicUsize,
}

impl SampledMemo {
    /// The limiting of `stations` judged at `envelope` (the turning intervals that do
    /// not start at a stop `turning`) that lowered the caps `lowered` and limited the
    /// intervals to `interval_limits`, kept; it started from the caps of `start`.
    pub(super) fn new(
        stations: &Stations,
        envelope: Vec<f32>,
        turning: &[u32],
        lowered: Vec<LoweredCap>,
        interval_limits: Vec<f64>,
        start: CapsStart,
    ) -> SampledMemo {
        SampledMemo {
            stops: stations.stops.iter().map(|stop| stop.station).collect(),
            envelope,
            turns: turns_with_stops(stations, turning),
            lowered,
            interval_limits,
            start,
            #[cfg(test)]
            judged_last: Default::default(),
        }
    }

    /// The intervals where the path turns that do not start at a stop (`is_stop`),
    /// ascending ([`Stations::turning_intervals`]).
    pub(super) fn turns_but_stops(&self, is_stop: &[bool]) -> Vec<u32> {
        let mut turning = Vec::new();
        for (w, &word) in self.turns.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let k = 64 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if !is_stop[k] {
                    turning.push(k as u32);
                }
            }
        }
        turning
    }

    /// The stations a limiting with `stops`, its stations judged at `envelope`, judges
    /// again (arc lengths `s_mm`): those whose envelope speed differs from the kept one's
    /// and those within the reach of a stop that one of the two has and the other has
    /// not, each range widened by a station on both sides (so that every interval beside
    /// a station judged again has both its stations judged), merged; first and last
    /// station of each, ascending. None where they are more than a quarter of the
    /// stations.
    fn judged_again(
        &self,
        s_mm: &[f64],
        stops: &[Stop],
        envelope: &[f32],
    ) -> Option<Vec<(usize, usize)>> {
        let n = s_mm.len();
        debug_assert_eq!(envelope.len(), self.envelope.len());
        let differs = |k: usize| envelope[k].to_bits() != self.envelope[k].to_bits();
        let mut marked: Vec<(usize, usize)> = Vec::new();
        let mut k = 0;
        while k < n {
            if !differs(k) {
                k += 1;
                continue;
            }
            let first = k;
            while k < n && differs(k) {
                k += 1;
            }
            marked.push((first, k - 1));
        }
        let stops: BTreeSet<usize> = stops.iter().map(|stop| stop.station).collect();
        for &j in self.stops.symmetric_difference(&stops) {
            // Interval j turns or not as station j is a stop or not; station j is in
            // the runs either side of it.
            let reach_mm = self.start.reach_mm;
            let (lo, hi) = (s_mm[j] - reach_mm, s_mm[(j + 1).min(n - 1)] + reach_mm);
            let first = s_mm.partition_point(|&s| s < lo);
            let last = s_mm.partition_point(|&s| s <= hi) - 1;
            marked.push((first, last));
        }
        marked.sort_unstable();
        let mut again: Vec<(usize, usize)> = Vec::new();
        for (first, last) in marked {
            let (first, last) = (first.saturating_sub(1), (last + 1).min(n - 1));
            match again.last_mut() {
                Some((_, end)) if first <= *end + 1 => *end = (*end).max(last),
                _ => again.push((first, last)),
            }
        }
        let count: usize = again.iter().map(|&(first, last)| last - first + 1).sum();
        (count * MOST_AGAIN <= n).then_some(again)
    }

    /// The stations limited as [`Stations::limit_stations_in_chunks`] limits them, the
    /// ranges `again` judged by `station` (the turns `turning`) and every other station
    /// as kept: `caps` (the choice's caps before any corner; `kinds` theirs) lowered, and
    /// each interval's acceleration (`interval_accel`, before the sampled geometry)
    /// limited.
    ///
    /// The ranges are those [`SampledMemo::judged_again`] finds for the stations' stops
    /// and `envelope`; where there are none (too many stations differ) nothing is done
    /// and false returned.
    pub(super) fn limit(
        &self,
        stations: &Stations,
        envelope: &[f32],
        turning: &[u32],
        limited: Limited,
        station: &(dyn Fn(usize, f64, &mut Cursor) -> Option<SampledLimit> + Sync),
    ) -> bool {
        let Limited {
            caps,
            kinds,
            interval_accel,
        } = limited;
        let again = (fingerprint(caps) == self.start.caps_fingerprint)
            .then(|| self.judged_again(&stations.s_mm, &stations.stops, envelope))
            .flatten();
        let Some(again) = again else {
            #[cfg(test)]
            self.judged_last
                .store(usize::MAX, std::sync::atomic::Ordering::Relaxed);
            return false;
        };
        let again = &again[..];
        // Each range judged again: the caps it lowers, and the accelerations of the
        // intervals between its stations (the one after its last station has a station
        // outside it, one as kept).
        #[cfg(test)]
        self.judged_last.store(
            again.iter().map(|&(first, last)| last - first + 1).sum(),
            std::sync::atomic::Ordering::Relaxed,
        );
        let judged: Vec<(Vec<LoweredCap>, Vec<f64>)> = again
            .par_iter()
            .map(|&(first, last)| {
                let mut lowered = Vec::new();
                let mut limits = vec![f64::INFINITY; last - first + 1];
                stations.limit_station_range(
                    first,
                    &caps[first..=last],
                    turning,
                    station,
                    &mut lowered,
                    &mut limits,
                );
                limits.pop();
                for (limit, &a) in limits.iter_mut().zip(&interval_accel[first..last]) {
                    *limit = a.min(*limit);
                }
                (lowered, limits)
            })
            .collect();
        interval_accel
            .par_iter_mut()
            .zip(&self.interval_limits)
            .for_each(|(a, &limit)| *a = a.min(limit));
        for cap in &self.lowered {
            let k = cap.station as usize;
            let at = again.partition_point(|&(_, last)| last < k);
            if again.get(at).is_none_or(|&(first, _)| first > k) {
                caps[k] = cap.cap_mm_min;
                kinds[k] = CapKind::Curvature;
            }
        }
        for (&(first, last), (lowered, limits)) in again.iter().zip(judged) {
            for cap in lowered {
                caps[cap.station as usize] = cap.cap_mm_min;
                kinds[cap.station as usize] = CapKind::Curvature;
            }
            interval_accel[first..last].copy_from_slice(&limits);
        }
        true
    }
}

/// The arrays a limiting sets, station by station and interval by interval: the caps
/// (mm/min) it lowers and their kinds, and the intervals' accelerations (mm/s²) it limits.
pub(super) struct Limited<'a> {
    pub(super) caps: &'a mut [f64],
    pub(super) kinds: &'a mut [CapKind],
    pub(super) interval_accel: &'a mut [f64],
}

/// What a kept limiting keeps of the caps it started from.
pub(super) struct CapsStart {
    /// How far along the path a station's sampled limit reads the stops and turns, mm:
    /// 2·v·T at the highest cap (MODEL.md §6.1 "Sampled geometry"), and a margin for the
    /// arc lengths' rounding.
    reach_mm: f64,
    /// Their [`fingerprint`].
    caps_fingerprint: u64,
}

impl CapsStart {
    /// Of the caps `caps` (mm/min) at the period `period_s`.
    pub(super) fn of(caps: &[f64], period_s: f64) -> CapsStart {
        let max_cap_mm_min = caps.iter().copied().fold(0.0, f64::max);
        CapsStart {
            reach_mm: 2.0 * max_cap_mm_min / 60.0 * period_s * (1.0 + 1e-9) + 1e-6,
            caps_fingerprint: fingerprint(caps),
        }
    }
}

/// A fingerprint of `caps` (FNV-1a over their bits): the kept limiting is the one of
/// these caps only where they have the same one.
fn fingerprint(caps: &[f64]) -> u64 {
    caps.iter().fold(0xcbf2_9ce4_8422_2325, |h, c| {
        (h ^ c.to_bits()).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Whether the path of `stations` turns over each interval, one bit an interval
/// ([`SampledMemo::turns`]): those of `turning` (the turning intervals that do not start
/// at a stop) and those of the stops that turn.
fn turns_with_stops(stations: &Stations, turning: &[u32]) -> Vec<u64> {
    let intervals = stations.len() - 1;
    let mut turns = vec![0u64; intervals.div_ceil(64)];
    let mut set = |k: usize| turns[k / 64] |= 1 << (k % 64);
    turning.iter().for_each(|&k| set(k as usize));
    let mut tangents = RecentTangents::new();
    for stop in &stations.stops {
        if stop.station < intervals && stations.turns(&mut tangents, stop.station) {
            set(stop.station);
        }
    }
    turns
}
