//! Lower bound on the time of any motion along the stations (MODEL.md §6.1, "Lower bound").

use crate::stations::Stations;

/// Acceleration bins a dip's unknown acceleration is first split into, and how many times
/// the most promising bin is then halved (see [`dip_piece_s`]).
const DIP_ACCEL_BINS: usize = 6;
const DIP_ACCEL_REFINEMENTS: usize = 8;

/// The chain of dips ([`dip_chain_s`]) splits each dip's unknown acceleration in [−A, A]
/// into this many equal bins (even: 0 is an edge). On 3D_Chips with jerk 20 000 mm/s³
/// (from Z60, MODEL.md §6.1) 24 / 32 / 80 bins give 171.37 / 171.51 / 171.78 s; the pairs
/// of bins compared at each gap grow with the square.
const CHAIN_ACCEL_BINS: usize = 32;

/// A lower bound on the time in s of any motion along the stations that keeps every station
/// at or under its cap, the speed inside an interval at or under the larger cap of its two
/// stations, the tangential acceleration and jerk within each interval's limits, and rests
/// at every stop for its dwell (MODEL.md §6.1):
///
/// * the forward/backward passes give, at every station, the highest speed u_k any such
///   motion can have there (v_k+1² ≤ v_k² + 2 a Δs holds for every motion, not only for the
///   plan);
/// * inside an interval the speed is at most min(√(u_k² + 2a·x), √(u_k+1² + 2a·(Δs − x)), cap),
///   whose time integral t_k is closed form;
/// * with a jerk limit, each run is split at the local maxima of u into pieces around one
///   dip each, and the time in a piece is bounded with the jerk the motion needs to turn
///   at the dip ([`dip_piece_s`]); a run also takes at least the rest-to-rest time of the
///   7-segment S-curve ([`rest_to_rest_time_s`]) with its highest cap, acceleration and jerk.
///
/// The planned profile is never faster, so `cycle / bound − 1` is an upper bound on how far
/// the plan is from the optimum.
pub fn lower_bound_time_s(stations: &Stations) -> f64 {
    let s = stations.s_mm();
    // Station k's cap, mm/s (made where it is read: not a list beside `u`,
    // 8 B a station saved).
    let cap_mm_min = stations.cap_mm_min();
    let caps = |k: usize| cap_mm_min[k] / 60.0;
    let accel = stations.interval_accel_mm_s2();
    let jerk = stations.interval_jerk_mm_s3();
    let mut u: Vec<f64> = (0..cap_mm_min.len()).map(caps).collect();
    let stops = stations.stops();
    for stop in stops {
        u[stop.station] = 0.0;
    }
    let n = u.len();
    for k in 0..n.saturating_sub(1) {
        u[k + 1] = u[k + 1].min((u[k] * u[k] + 2.0 * accel[k] * (s[k + 1] - s[k])).sqrt());
    }
    for k in (0..n.saturating_sub(1)).rev() {
        u[k] = u[k].min((u[k + 1] * u[k + 1] + 2.0 * accel[k] * (s[k + 1] - s[k])).sqrt());
    }
    // Interval k's closed-form time and the highest speed allowed inside, made where
    // they are read: without a jerk limit only the times are summed, with one each
    // run's list of its intervals is made for its dips (not a list of every interval,
    // 40 B a station saved).
    let time_s = |k: usize| {
        let cap = caps(k).max(caps(k + 1));
        interval_bound_s(s[k + 1] - s[k], u[k], u[k + 1], accel[k], cap)
    };
    let interval = |k: usize| {
        let cap = caps(k).max(caps(k + 1));
        let len_mm = s[k + 1] - s[k];
        Interval {
            len_mm,
            time_s: time_s(k),
            peak_mm_s: interval_peak_mm_s(len_mm, u[k], u[k + 1], accel[k], cap),
            accel_mm_s2: accel[k],
            jerk_mm_s3: jerk.map_or(f64::INFINITY, |j| j[k]),
        }
    };
    let mut total_s: f64 = stops.iter().map(|s| s.dwell_s).sum();
    for pair in stops.windows(2) {
        let (first, last) = (pair[0].station, pair[1].station);
        if jerk.is_none() {
            total_s += (first..last).map(time_s).sum::<f64>();
            continue;
        }
        let run: Vec<Interval> = (first..last).map(interval).collect();
        let mut run_s: f64 = run.iter().map(|i| i.time_s).sum();
        let v_max = (first..last).fold(0.0f64, |m, k| m.max(caps(k).max(caps(k + 1))));
        let a_max = run.iter().fold(0.0f64, |m, i| m.max(i.accel_mm_s2));
        let j_max = run.iter().fold(0.0f64, |m, i| m.max(i.jerk_mm_s3));
        if j_max.is_finite() && last > first {
            run_s = run_s.max(rest_to_rest_time_s(s[last] - s[first], v_max, a_max, j_max));
            run_s = run_s.max(dip_pieces_s(&u[first..=last], &run));
        }
        total_s += run_s;
    }
    total_s
}

/// One interval k → k+1 as the bound sees it.
#[derive(Clone, Copy, Debug)]
struct Interval {
    len_mm: f64,
    /// Least time over the interval (acceleration limit only), s.
    time_s: f64,
    /// Highest speed any motion can have inside the interval, mm/s.
    peak_mm_s: f64,
    accel_mm_s2: f64,
    jerk_mm_s3: f64,
}

/// Least time of a run with a jerk limit: the run (stations `u`, ends at rest, intervals
/// `run`) split into pieces, each bounded by [`dip_piece_s`] around its lowest station.
/// Any split gives a valid bound, so the larger of two is taken: splits in the middle of
/// each local maximum (plateau) of `u`, which leave each dip room to turn on both sides,
/// and splits at the last station before every fall of `u`, which also cut descending
/// staircases at each step.
fn dip_pieces_s(u: &[f64], run: &[Interval]) -> f64 {
    let last = u.len() - 1;
    let mut middles = vec![0];
    let mut k = 1;
    while k < last {
        let a = k;
        let mut b = k;
        while b + 1 < last && u[b + 1] == u[a] {
            b += 1;
        }
        if u[a] > u[a - 1] && u[b] > u[b + 1] {
            middles.push((a + b) / 2);
        }
        k = b + 1;
    }
    middles.push(last);
    let mut falls = vec![0];
    falls.extend((1..last).filter(|&k| u[k] >= u[k - 1] && u[k] > u[k + 1]));
    falls.push(last);
    // The run's stops are dips of the chain whatever the pieces' lowest stations are.
    let mut dips = vec![0];
    dips.extend(middles.windows(2).map(|w| lowest(u, w[0], w[1])));
    dips.push(last);
    dips.dedup();
    pieces_s(u, run, &middles)
        .max(pieces_s(u, run, &falls))
        .max(dip_chain_s(u, run, &dips))
        .max(dip_chain_s(u, run, &without_shallow_dips(u, &dips)))
}

/// `dips` less every dip whose u is above those of both dips beside it (the run's stops
/// stay). A chain over fewer dips is as valid (it uses fewer of the caps), and where a
/// higher dip lies between two low ones, its bins of acceleration let the motion turn
/// faster than the low ones allow.
fn without_shallow_dips(u: &[f64], dips: &[usize]) -> Vec<usize> {
    let shallow = |i: usize| {
        i > 0 && i + 1 < dips.len() && u[dips[i]] > u[dips[i - 1]] && u[dips[i]] > u[dips[i + 1]]
    };
    (0..dips.len())
        .filter(|&i| !shallow(i))
        .map(|i| dips[i])
        .collect()
}

/// The station of least u in `p..=q` (the first of equals).
fn lowest(u: &[f64], p: usize, q: usize) -> usize {
    (p..=q).fold(p, |m, k| if u[k] < u[m] { k } else { m })
}

/// What bounds a side's speed in [`Side`]: the run's highest interval peak (mm/s), highest
/// acceleration and jerk limits and least jerk limit.
#[derive(Clone, Copy, Debug)]
struct RunLimits {
    v_max: f64,
    a_max: f64,
    j_min: f64,
    j_max: f64,
}

impl RunLimits {
    fn new(run: &[Interval]) -> Self {
        RunLimits {
            v_max: run.iter().fold(0.0f64, |m, i| m.max(i.peak_mm_s)),
            a_max: run.iter().fold(0.0f64, |m, i| m.max(i.accel_mm_s2)),
            j_min: run.iter().fold(f64::INFINITY, |m, i| m.min(i.jerk_mm_s3)),
            j_max: run.iter().fold(0.0f64, |m, i| m.max(i.jerk_mm_s3)),
        }
    }

    /// The ceiling of a side whose `inside` first intervals (of `intervals`, in the order
    /// the comparison motion crosses them) are its own: the highest interval peak on it and
    /// within v_max·A/J_min beyond it (how far a motion travels while its acceleration falls
    /// back to zero).
    fn ceiling(&self, intervals: &mut dyn Iterator<Item = &Interval>, inside: usize) -> f64 {
        let reach_mm = self.v_max * self.a_max / self.j_min;
        let mut peak = 0.0f64;
        let mut beyond_mm = 0.0;
        for (i, interval) in intervals.enumerate() {
            if i >= inside {
                if beyond_mm > reach_mm {
                    break;
                }
                beyond_mm += interval.len_mm;
            }
            peak = peak.max(interval.peak_mm_s);
        }
        peak
    }
}

/// Least time of a run with a jerk limit from the chain of its dips `dips` (stations, the
/// first and last the run's stops), each dip's unknown acceleration shared by the gaps on
/// both sides of it (MODEL.md §6.1, "Chain of dips").
///
/// Between consecutive dips k and k+1 any motion needs, for every station x of the gap, at
/// least the forward comparison time from dip k to x ([`Side::excess_s`], with the highest
/// acceleration of dip k's bin) plus the backward one from dip k+1 to x (with the lowest of
/// dip k+1's bin): the gap's bound for that pair of bins is the largest such sum over x.
/// Summed over the gaps it holds for the motion's own bins, so the least sum over all
/// sequences of bins (a shortest path through the bins, dip by dip) bounds the run. The
/// per-piece bound ([`pieces_s`]) splits each gap at one fixed station and lets each dip
/// pick its acceleration alone; here the split moves to where the two dips' envelopes
/// meet, so a high dip between two low ones 17 ms apart no longer lets the speed rise to
/// its own cap.
fn dip_chain_s(u: &[f64], run: &[Interval], dips: &[usize]) -> f64 {
    let last = u.len() - 1;
    let limits = RunLimits::new(run);
    // Bins of a dip's acceleration: a stop has 0 only.
    let bins = |m: usize| -> Vec<(f64, f64)> {
        let a_dip = [m.checked_sub(1).map(|k| &run[k]), run.get(m)]
            .into_iter()
            .flatten()
            .fold(0.0f64, |a, i| a.max(i.accel_mm_s2));
        if m == 0 || m == last || a_dip == 0.0 {
            return vec![(0.0, 0.0)];
        }
        let width = 2.0 * a_dip / CHAIN_ACCEL_BINS as f64;
        (0..CHAIN_ACCEL_BINS)
            .map(|i| (-a_dip + i as f64 * width, -a_dip + (i + 1) as f64 * width))
            .collect()
    };
    let mut cost: Vec<f64> = bins(dips[0]).iter().map(|_| 0.0).collect();
    let (mut forward, mut backward) = (Vec::new(), Vec::new());
    for pair in dips.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let gap = &run[a..b];
        let reversed: Vec<Interval> = gap.iter().rev().copied().collect();
        let floors_s: f64 = gap.iter().map(|i| i.time_s).sum();
        let len = b - a;
        let ahead = Side::new(gap, limits.ceiling(&mut run[a..].iter(), len), limits.j_max);
        let behind = Side::new(
            &reversed,
            limits.ceiling(&mut run[..b].iter().rev(), len),
            limits.j_max,
        );
        let (bins_a, bins_b) = (bins(a), bins(b));
        forward.clear();
        for &(_, hi) in &bins_a {
            let mut excess = Vec::new();
            ahead.excess_s(u[a], hi, &mut excess);
            forward.push(excess);
        }
        backward.clear();
        for &(lo, _) in &bins_b {
            let mut excess = Vec::new();
            behind.excess_s(u[b], -lo, &mut excess);
            backward.push(excess);
        }
        let next: Vec<f64> = backward
            .iter()
            .map(|back| {
                forward
                    .iter()
                    .zip(&cost)
                    .map(|(ahead, cost)| cost + floors_s + meeting_excess_s(ahead, back, len))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        cost = next;
    }
    cost.into_iter().fold(f64::INFINITY, f64::min)
}

/// Largest over the stations x = 0..=len of a gap of `ahead`(x) + `behind`(len − x): the
/// excess times over the closed-form floors of the forward comparison motion from the dip
/// at the gap's start to x and of the backward one from the dip at its end (each constant
/// past its last entry, where its envelope no longer binds; both never fall).
fn meeting_excess_s(ahead: &[f64], behind: &[f64], len: usize) -> f64 {
    let at = |excess: &[f64], x: usize| excess[x.min(excess.len() - 1)];
    let (from, to) = (
        len.saturating_sub(behind.len() - 1),
        (ahead.len() - 1).min(len),
    );
    if from > to {
        // The envelopes do not meet: each binds only where the other does not.
        return at(ahead, len) + at(behind, len);
    }
    (from..=to)
        .map(|x| at(ahead, x) + at(behind, len - x))
        .fold(0.0, f64::max)
}

/// Sum of [`dip_piece_s`] over the pieces between consecutive `splits` (station indices).
fn pieces_s(u: &[f64], run: &[Interval], splits: &[usize]) -> f64 {
    let last = u.len() - 1;
    let limits = RunLimits::new(run);
    splits
        .windows(2)
        .map(|w| {
            let (p, q) = (w[0], w[1]);
            let m = lowest(u, p, q);
            let at_rest = m == 0 || m == last;
            let ceilings = [
                limits.ceiling(&mut run[..m].iter().rev(), m - p),
                limits.ceiling(&mut run[m..].iter(), q - m),
            ];
            dip_piece_s(
                u[m],
                at_rest,
                &run[p..m],
                &run[m..q],
                ceilings,
                limits.j_max,
            )
        })
        .sum()
}

/// Least time over the stations on both sides of a dip: a station where the speed is at
/// most `c` (mm/s), with the intervals `left` before it (in path order) and `right` after.
///
/// Whatever the motion's acceleration a_m at the dip, the jerk limit J bounds its
/// acceleration σ later by a_m + J·σ (and by A), and σ earlier by −(a_m − J·σ): so σ after
/// the dip the speed is at most c + ∫₀^σ min(A, a_m + Jρ) dρ, and σ before it at most
/// c + ∫₀^σ min(A, −a_m + Jρ) dρ. With the speed also under each interval's peak, a
/// comparison motion that always moves at the smaller of the two reaches every station no
/// later than the real one, station by station (if the real motion enters an interval
/// later, it has less time at speeds no higher). Each interval also takes at least its
/// closed-form time. a_m is unknown within ±A (0 at rest): the bound is the least over bins
/// of a_m, each bin bounded with its extremes (the highest a_m for the side after the dip,
/// the lowest for the side before), so it holds for every a_m.
fn dip_piece_s(
    c: f64,
    at_rest: bool,
    left: &[Interval],
    right: &[Interval],
    ceilings_mm_s: [f64; 2],
    jerk_fall_mm_s3: f64,
) -> f64 {
    let left: Vec<Interval> = left.iter().rev().copied().collect();
    let sides = [
        Side::new(&left, ceilings_mm_s[0], jerk_fall_mm_s3),
        Side::new(right, ceilings_mm_s[1], jerk_fall_mm_s3),
    ];
    let a_dip = [left.first(), right.first()]
        .into_iter()
        .flatten()
        .fold(0.0f64, |m, i| m.max(i.accel_mm_s2));
    let bin = |lo: f64, hi: f64| sides[0].time_s(c, -lo) + sides[1].time_s(c, hi);
    if at_rest || a_dip == 0.0 {
        return bin(0.0, 0.0);
    }
    let width = 2.0 * a_dip / DIP_ACCEL_BINS as f64;
    let mut bins: Vec<(f64, f64, f64)> = (0..DIP_ACCEL_BINS)
        .map(|i| {
            let lo = -a_dip + i as f64 * width;
            let hi = lo + width;
            (lo, hi, bin(lo, hi))
        })
        .collect();
    for _ in 0..DIP_ACCEL_REFINEMENTS {
        let best = (0..bins.len())
            .min_by(|&x, &y| bins[x].2.total_cmp(&bins[y].2))
            .unwrap_or(0);
        let (lo, hi, _) = bins.swap_remove(best);
        let mid = 0.5 * (lo + hi);
        bins.push((lo, mid, bin(lo, mid)));
        bins.push((mid, hi, bin(mid, hi)));
    }
    bins.iter().map(|b| b.2).fold(f64::INFINITY, f64::min)
}

/// The intervals on one side of a dip, in the order the comparison motion crosses them.
struct Side<'a> {
    intervals: &'a [Interval],
    /// Highest interval peak from each interval on, mm/s.
    peak_after: Vec<f64>,
    /// Sum of closed-form times from each interval on, s.
    time_after: Vec<f64>,
    accel_mm_s2: f64,
    jerk_mm_s3: f64,
    /// Highest speed the motion may reach while on this side or within its reach beyond.
    ceiling_mm_s: f64,
    /// Highest jerk limit of the run: the fastest a motion can level off, mm/s³.
    jerk_fall_mm_s3: f64,
}

impl<'a> Side<'a> {
    fn new(intervals: &'a [Interval], ceiling_mm_s: f64, jerk_fall_mm_s3: f64) -> Self {
        let n = intervals.len();
        let (mut peak_after, mut time_after) = (vec![0.0f64; n + 1], vec![0.0f64; n + 1]);
        for k in (0..n).rev() {
            peak_after[k] = peak_after[k + 1].max(intervals[k].peak_mm_s);
            time_after[k] = time_after[k + 1] + intervals[k].time_s;
        }
        Side {
            intervals,
            peak_after,
            time_after,
            accel_mm_s2: intervals.iter().fold(0.0f64, |m, i| m.max(i.accel_mm_s2)),
            jerk_mm_s3: intervals.iter().fold(0.0f64, |m, i| m.max(i.jerk_mm_s3)),
            ceiling_mm_s,
            jerk_fall_mm_s3,
        }
    }

    /// Time for the comparison motion to cross the side from the dip at speed `c` with
    /// acceleration at most `a0` there, s.
    fn time_s(&self, c: f64, a0: f64) -> f64 {
        let mut excess = Vec::new();
        self.excess_s(c, a0, &mut excess);
        excess.last().copied().unwrap_or(0.0) + self.time_after[0]
    }

    /// The comparison motion's time from the dip (speed `c`, acceleration at most `a0`) to
    /// each station of the side, less the closed-form times of the intervals crossed, into
    /// `out`: out[0] = 0 at the dip, then one entry per interval until the envelope no longer
    /// binds (from there on every interval takes its closed-form time, so the excess stays
    /// at the last entry). It never falls.
    fn excess_s(&self, c: f64, a0: f64, out: &mut Vec<f64>) {
        out.clear();
        out.push(0.0);
        if self.intervals.is_empty() {
            return;
        }
        let env = Envelope::new(
            c,
            a0.min(self.accel_mm_s2),
            self.accel_mm_s2,
            self.jerk_mm_s3,
            self.jerk_fall_mm_s3.max(self.jerk_mm_s3),
            self.ceiling_mm_s.max(c),
        );
        let (mut t, mut floors) = (0.0, 0.0);
        for (k, interval) in self.intervals.iter().enumerate() {
            if t >= env.rising_from_s() && env.speed(t) >= self.peak_after[k] {
                // The envelope no longer binds: the closed-form times from here on.
                return;
            }
            let step = if t >= env.rising_from_s() && env.speed(t) >= interval.peak_mm_s {
                interval.len_mm / interval.peak_mm_s
            } else {
                env.time_to_cover_s(t, interval.len_mm, interval.peak_mm_s)
            };
            t += step.max(interval.time_s);
            floors += interval.time_s;
            out.push(t - floors);
        }
    }
}

/// Highest speed σ after the dip: c + ∫₀^σ a(ρ) dρ with a(ρ) = min(A, a0 + Jρ), until the
/// speed plus the a²/2J_fall it still gains while its acceleration falls back to zero (at a
/// jerk of at most J_fall, the run's highest limit) reaches the ceiling V; from there a falls
/// at rate J_fall and the speed levels off at V. Every motion that never exceeds V is at or
/// below it (it can gain no more speed than the all-out one, and above the switch it would
/// pass V).
#[derive(Clone, Copy, Debug)]
struct Envelope {
    /// Pieces of constant jerk: start time, speed, acceleration, jerk and distance there.
    phases: [Phase; 4],
    len: usize,
    rising_from_s: f64,
}

#[derive(Clone, Copy, Debug, Default)]
struct Phase {
    t0: f64,
    v0: f64,
    a0: f64,
    j: f64,
    x0: f64,
}

impl Phase {
    fn speed(&self, t: f64) -> f64 {
        let h = t - self.t0;
        self.v0 + self.a0 * h + self.j * h * h / 2.0
    }

    fn distance(&self, t: f64) -> f64 {
        let h = t - self.t0;
        self.x0 + self.v0 * h + self.a0 * h * h / 2.0 + self.j * h * h * h / 6.0
    }

    fn accel(&self, t: f64) -> f64 {
        self.a0 + self.j * (t - self.t0)
    }

    /// The phase continued to time `t` with jerk `j`.
    fn then(&self, t: f64, j: f64) -> Phase {
        Phase {
            t0: t,
            v0: self.speed(t),
            a0: self.accel(t),
            j,
            x0: self.distance(t),
        }
    }
}

impl Envelope {
    /// From speed `c` with acceleration at most `a0` (≤ `a`), jerk at most `j` while the
    /// envelope rises, and a ceiling `ceiling` (≥ c; infinite: none) that the motion cannot
    /// pass while its acceleration falls back to zero at a jerk of at most `j_fall` (≥ j).
    fn new(c: f64, a0: f64, a: f64, j: f64, j_fall: f64, ceiling: f64) -> Self {
        // A motion accelerating at a0 > 0 gains at least a0²/2J_fall before it levels off.
        let a0 = if a0 > 0.0 && ceiling.is_finite() {
            a0.min((2.0 * j_fall * (ceiling - c).max(0.0)).sqrt())
        } else {
            a0
        };
        let rise = Phase {
            t0: 0.0,
            v0: c,
            a0,
            j,
            x0: 0.0,
        };
        let t_full = (a - a0) / j;
        let full = rise.then(t_full, 0.0);
        let mut phases = [Phase::default(); 4];
        let len = if ceiling.is_finite() {
            // v + a²/2J_fall = V, from where the acceleration is no longer negative:
            // α h² + β h + γ = 0 with α = J/2·(1 + J/J_fall), β = a(1 + J/J_fall).
            let t_start = (-a0 / j).max(0.0);
            let start = rise.then(t_start, j);
            let ratio = 1.0 + j / j_fall;
            let (alpha, beta) = (j / 2.0 * ratio, start.a0 * ratio);
            let gamma = start.v0 + start.a0 * start.a0 / (2.0 * j_fall) - ceiling;
            let h = (-beta + (beta * beta - 4.0 * alpha * gamma).max(0.0).sqrt()) / (2.0 * alpha);
            let t_rise = t_start + h.max(0.0);
            let (t_switch, before) = if t_rise <= t_full {
                (t_rise, rise)
            } else {
                (
                    t_full + (ceiling - a * a / (2.0 * j_fall) - full.v0) / a,
                    full,
                )
            };
            let fall = before.then(t_switch, -j_fall);
            let level = fall.then(t_switch + fall.a0 / j_fall, 0.0);
            let level = Phase {
                v0: ceiling,
                a0: 0.0,
                ..level
            };
            if t_rise <= t_full {
                phases[..3].copy_from_slice(&[rise, fall, level]);
                3
            } else {
                phases.copy_from_slice(&[rise, full, fall, level]);
                4
            }
        } else {
            phases[..2].copy_from_slice(&[rise, full]);
            2
        };
        Envelope {
            phases,
            len,
            rising_from_s: (-a0 / j).max(0.0),
        }
    }

    /// From this time on the speed never falls.
    fn rising_from_s(&self) -> f64 {
        self.rising_from_s
    }

    fn phase(&self, t: f64) -> &Phase {
        let phases = &self.phases[..self.len];
        let i = phases.partition_point(|p| p.t0 <= t).max(1) - 1;
        &phases[i]
    }

    fn speed(&self, t: f64) -> f64 {
        self.phase(t).speed(t)
    }

    /// ∫₀^t speed (negative speeds included).
    fn distance(&self, t: f64) -> f64 {
        self.phase(t).distance(t)
    }

    /// Times in (t0, t1) where the speed equals `level`, pushed onto `cuts`.
    fn crossings(&self, level: f64, t0: f64, t1: f64, cuts: &mut Cuts) {
        for (i, p) in self.phases[..self.len].iter().enumerate() {
            let end = self.phases[..self.len]
                .get(i + 1)
                .map_or(f64::INFINITY, |n| n.t0);
            let mut push = |h: f64| {
                let t = p.t0 + h;
                if h > 0.0 && t < end {
                    cuts.push_within(t, t0, t1);
                }
            };
            // j h²/2 + a0 h + (v0 − level) = 0.
            if p.j != 0.0 {
                let disc = p.a0 * p.a0 - 2.0 * p.j * (p.v0 - level);
                if disc >= 0.0 {
                    push((-p.a0 - disc.sqrt()) / p.j);
                    push((-p.a0 + disc.sqrt()) / p.j);
                }
            } else if p.a0 != 0.0 {
                push((level - p.v0) / p.a0);
            }
        }
    }

    /// ∫ from t0 to t1 of min(max(speed, 0), cap).
    fn covered_mm(&self, t0: f64, t1: f64, cap: f64) -> f64 {
        let mut cuts = Cuts {
            at: [0.0; 16],
            len: 0,
        };
        for p in &self.phases[1..self.len] {
            cuts.push_within(p.t0, t0, t1);
        }
        self.crossings(cap, t0, t1, &mut cuts);
        self.crossings(0.0, t0, t1, &mut cuts);
        let inner = &mut cuts.at[..cuts.len];
        inner.sort_by(f64::total_cmp);
        let mut total = 0.0;
        let mut from = t0;
        for to in inner.iter().copied().chain([t1]) {
            let speed = self.speed(0.5 * (from + to));
            total += if speed >= cap {
                cap * (to - from)
            } else if speed <= 0.0 {
                0.0
            } else {
                self.distance(to) - self.distance(from)
            };
            from = to;
        }
        total
    }

    /// Least time after `t0` to cover `len_mm` at min(max(speed, 0), cap): the lower end of a
    /// bracket on the root (the distance covered only grows with the time).
    fn time_to_cover_s(&self, t0: f64, len_mm: f64, cap: f64) -> f64 {
        let mut lo = 0.0;
        let mut hi = len_mm / cap;
        let mut g_hi = self.covered_mm(t0, t0 + hi, cap);
        let mut g_lo = 0.0;
        let mut grow = 0;
        while g_hi < len_mm {
            lo = hi;
            g_lo = g_hi;
            hi *= 2.0;
            g_hi = self.covered_mm(t0, t0 + hi, cap);
            grow += 1;
            if grow > 200 {
                return lo;
            }
        }
        // Illinois regula falsi, keeping the bracket.
        let (mut f_lo, mut f_hi) = (g_lo - len_mm, g_hi - len_mm);
        let mut side = 0;
        for _ in 0..60 {
            if hi - lo <= 1e-12 * hi || f_hi - f_lo <= 0.0 {
                break;
            }
            let mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
            let mid = if mid > lo && mid < hi {
                mid
            } else {
                0.5 * (lo + hi)
            };
            let f_mid = self.covered_mm(t0, t0 + mid, cap) - len_mm;
            if f_mid.abs() <= 1e-13 * len_mm {
                // Within rounding of the root; step back to stay below it.
                return mid * (1.0 - 1e-12);
            }
            if f_mid < 0.0 {
                lo = mid;
                f_lo = f_mid;
                if side == -1 {
                    f_hi /= 2.0;
                }
                side = -1;
            } else {
                hi = mid;
                f_hi = f_mid;
                if side == 1 {
                    f_lo /= 2.0;
                }
                side = 1;
            }
        }
        lo
    }
}

/// Times inside an integration range where the integrand changes form (at most 15).
struct Cuts {
    at: [f64; 16],
    len: usize,
}

impl Cuts {
    fn push_within(&mut self, t: f64, t0: f64, t1: f64) {
        if t > t0 && t < t1 && self.len < self.at.len() {
            self.at[self.len] = t;
            self.len += 1;
        }
    }
}

/// Where, inside an interval of length `len_mm` entered at no more than `v0` and left at no
/// more than `v1` with acceleration ≤ `a`, the rising and falling limits meet, mm from its start.
fn interval_apex_mm(len_mm: f64, v0: f64, v1: f64, a: f64) -> f64 {
    ((v1 * v1 - v0 * v0 + 2.0 * a * len_mm) / (4.0 * a)).clamp(0.0, len_mm)
}

/// Highest speed inside such an interval under speed cap `cap`, mm/s.
fn interval_peak_mm_s(len_mm: f64, v0: f64, v1: f64, a: f64, cap: f64) -> f64 {
    let x = interval_apex_mm(len_mm, v0, v1, a);
    cap.min((v0 * v0 + 2.0 * a * x).sqrt()).max(v0).max(v1)
}

/// Least time over an interval of length `len_mm` entered at no more than `v0`, left at no
/// more than `v1`, with acceleration ≤ `a` and speed ≤ `cap` (mm/s).
fn interval_bound_s(len_mm: f64, v0: f64, v1: f64, a: f64, cap: f64) -> f64 {
    if len_mm <= 0.0 {
        return 0.0;
    }
    // Where the rising and falling limits meet.
    let x_peak = interval_apex_mm(len_mm, v0, v1, a);
    // Time over x ∈ [0, x_end] at speed min(√(u² + 2a·x), cap).
    let half = |u: f64, x_end: f64| {
        let x_cap = ((cap * cap - u * u) / (2.0 * a)).max(0.0);
        let x_ramp = x_end.min(x_cap);
        let ramp_s = if x_ramp > 0.0 {
            ((u * u + 2.0 * a * x_ramp).sqrt() - u) / a
        } else {
            0.0
        };
        ramp_s + (x_end - x_ramp).max(0.0) / cap
    };
    half(v0, x_peak) + half(v1, len_mm - x_peak)
}

/// Least time in s of a rest-to-rest move of length `len_mm` under speed `v`, acceleration `a`
/// and jerk `j` limits: the closed form of the 7-segment S-curve (MODEL.md §6.1).
///
/// Accelerating to a speed u and back takes τ(u) = u/a + a/j when u ≥ a²/j (the acceleration
/// limit is reached) and 2√(u/j) otherwise, and covers u·τ(u). If L ≥ v·τ(v) the move
/// cruises: T = L/v + τ(v). Otherwise it peaks at the u with u·τ(u) = L and T = 2τ(u).
pub fn rest_to_rest_time_s(len_mm: f64, v: f64, a: f64, j: f64) -> f64 {
    if len_mm <= 0.0 {
        return 0.0;
    }
    let tau = |u: f64| {
        if u * j >= a * a {
            u / a + a / j
        } else {
            2.0 * (u / j).sqrt()
        }
    };
    if len_mm >= v * tau(v) {
        return len_mm / v + tau(v);
    }
    // Peak with the acceleration limit reached: u²/a + u·a/j = L.
    let u = a * (-a / j + (a * a / (j * j) + 4.0 * len_mm / a).sqrt()) / 2.0;
    let u = if u * j >= a * a {
        u
    } else {
        // Pure jerk phases: L = 2u·√(u/j).
        (len_mm * j.sqrt() / 2.0).powf(2.0 / 3.0)
    };
    2.0 * tau(u)
}
