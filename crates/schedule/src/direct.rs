//! Jerk-limited speed profiles shaped directly, without the filter (MODEL.md §6.1,
//! "Direct sections"): between the dips of the acceleration-limited envelope the speed
//! rises from one dip's speed (no acceleration) to a peak (no acceleration) and falls to
//! the next dip's, each change the time-optimal jerk-limited one (an S-curve of up to
//! three phases: jerk ±J, acceleration ±A, jerk ∓J).

use crate::kinematics::{interval_accel_mm_s2, interval_time_s};

/// A jerk-limited change of speed from (`v0`, `a0`) to (`v1`, `a1`) (speed, acceleration):
/// jerk g·J for `t1` (the acceleration from a0 to the peak `ap`), `ap` held for `t2`, jerk
/// −g·J for `t3` (from `ap` to a1), g = ±1 (MODEL.md §6.1, "Changes between accelerated
/// states"). With a0 = a1 = 0 it is the S-curve from v0 to v1: A is reached where
/// |v1 − v0| ≥ A²/J, else the acceleration peaks at √(J·|v1 − v0|).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Change {
    v0: f64,
    a0: f64,
    v1: f64,
    a1: f64,
    /// g: the sign of the first phase's jerk.
    sign: f64,
    /// Jerk magnitude J, mm/s³.
    jerk: f64,
    /// The held acceleration, signed (g times its magnitude), mm/s².
    ap: f64,
    t1: f64,
    t2: f64,
    t3: f64,
    /// Length, mm.
    length: f64,
}

impl Change {
    /// The time-optimal change from `v0` to `v1` (mm/s) with no acceleration at either end,
    /// under acceleration `a` and jerk `j`.
    pub(crate) fn new(v0: f64, v1: f64, a: f64, j: f64) -> Self {
        let dv = (v1 - v0).abs();
        let (tj, ta, accel) = if dv * j >= a * a {
            (a / j, dv / a - a / j, a)
        } else {
            let tj = (dv / j).sqrt();
            (tj, 0.0, j * tj)
        };
        let sign = if v1 >= v0 { 1.0 } else { -1.0 };
        Change {
            v0,
            a0: 0.0,
            v1,
            a1: 0.0,
            sign,
            jerk: j,
            ap: sign * accel,
            t1: tj,
            t2: ta,
            t3: tj,
            // The speed is point-symmetric about the middle, so it averages (v0 + v1)/2.
            length: 0.5 * (v0 + v1) * (2.0 * tj + ta),
        }
    }

    /// The time-optimal change from (`v0`, `a0`) to (`v1`, `a1`) under acceleration `a` and
    /// jerk `j` (MODEL.md §6.1, eqs. 6.1a–b): of the two first jerks g = ±1, those whose
    /// held acceleration ap, ap² = g·J·Δv + (a0² + a1²)/2 (clamped to ±A, the rest of Δv
    /// at ±A), lies beyond both ends (g·ap ≥ g·a0, g·a1), the quicker; `None` where
    /// |a0| or |a1| is over `a`, or the speed would go below 0 inside it.
    pub(crate) fn between(v0: f64, a0: f64, v1: f64, a1: f64, a: f64, j: f64) -> Option<Self> {
        if a0 == 0.0 && a1 == 0.0 {
            return Some(Self::new(v0, v1, a, j));
        }
        if a0.abs() > a || a1.abs() > a {
            return None;
        }
        let dv = v1 - v0;
        let mean_sq = 0.5 * (a0 * a0 + a1 * a1);
        let mut best: Option<Change> = None;
        for sign in [1.0, -1.0] {
            let sq = sign * j * dv + mean_sq;
            if sq < 0.0 {
                continue;
            }
            let mut mag = sq.sqrt();
            // Slack for rounding where an end is at the held acceleration.
            let tol = 1e-12 * (a + mag);
            if mag + tol < sign * a0 || mag + tol < sign * a1 {
                continue;
            }
            let mut t2 = 0.0;
            if mag > a {
                mag = a;
                // Δv = g(2A² − a0² − a1²)/(2J) + g·A·t2.
                t2 = (sign * dv - (2.0 * a * a - a0 * a0 - a1 * a1) / (2.0 * j)) / a;
            }
            let ap = sign * mag;
            let t1 = ((mag - sign * a0) / j).max(0.0);
            let t3 = ((mag - sign * a1) / j).max(0.0);
            let mut c = Change {
                v0,
                a0,
                v1,
                a1,
                sign,
                jerk: j,
                ap,
                t1,
                t2: t2.max(0.0),
                t3,
                length: 0.0,
            };
            // Length: the first two phases forward, the third from its start.
            let (x2, v2, _) = c.forward(t1 + c.t2);
            c.length = x2 + v2 * t3 + ap * t3 * t3 / 2.0 - sign * j * t3 * t3 * t3 / 6.0;
            if c.min_speed() < 0.0 {
                continue;
            }
            if best.is_none_or(|b| c.duration_s() < b.duration_s()) {
                best = Some(c);
            }
        }
        best
    }

    /// Distance, speed and acceleration `t` into the first two phases (t ≤ t1 + t2).
    fn forward(&self, t: f64) -> (f64, f64, f64) {
        let (sg, j, t1) = (self.sign, self.jerk, self.t1);
        if t <= t1 {
            return (
                self.v0 * t + self.a0 * t * t / 2.0 + sg * j * t * t * t / 6.0,
                self.v0 + self.a0 * t + sg * j * t * t / 2.0,
                self.a0 + sg * j * t,
            );
        }
        let h = t - t1;
        let v_t1 = self.v0 + self.a0 * t1 + sg * j * t1 * t1 / 2.0;
        let x_t1 = self.v0 * t1 + self.a0 * t1 * t1 / 2.0 + sg * j * t1 * t1 * t1 / 6.0;
        (
            x_t1 + v_t1 * h + self.ap * h * h / 2.0,
            v_t1 + self.ap * h,
            self.ap,
        )
    }

    /// Where it holds its acceleration (its middle phase; the peak's point where it has
    /// none), as distances from its start plus `offset_mm`, mm.
    fn held_span_mm(&self, offset_mm: f64) -> (f64, f64) {
        let (x0, _, _) = self.forward(self.t1);
        let (x1, _, _) = self.forward(self.t1 + self.t2);
        (offset_mm + x0, offset_mm + x1)
    }

    /// The least speed inside the change (at its ends or where the acceleration passes 0
    /// in its first or last phase).
    fn min_speed(&self) -> f64 {
        let mut least = self.v0.min(self.v1);
        // First phase: a0 + gJt = 0.
        let t = -self.a0 * self.sign / self.jerk;
        if t > 0.0 && t < self.t1 {
            least = least.min(self.state(t).1);
        }
        // Last phase, r before the end: a1 + gJr = 0.
        let r = -self.a1 * self.sign / self.jerk;
        if r > 0.0 && r < self.t3 {
            least = least.min(self.state(self.duration_s() - r).1);
        }
        least
    }

    /// Its duration, s: t1 + t2 + t3 (Δv/A + A/J, or 2√(Δv/J), between states at rest).
    pub(crate) fn duration_s(&self) -> f64 {
        // t1 + t3 first: 2·tj + ta exactly where t1 = t3.
        self.t1 + self.t3 + self.t2
    }

    /// Its length, mm.
    pub(crate) fn length_mm(&self) -> f64 {
        self.length
    }

    /// Distance, speed and acceleration `t_s` into the change (clamped to it): the first
    /// two phases from the start, the last one from the end, r = duration − t before it:
    /// x = L − (v1·r − a1·r²/2 − g·J·r³/6), v = v1 − a1·r − g·J·r²/2, a = a1 + g·J·r.
    pub(crate) fn state(&self, t_s: f64) -> (f64, f64, f64) {
        let (sg, j) = (self.sign, self.jerk);
        let total = self.duration_s();
        let t = t_s.clamp(0.0, total);
        if t <= self.t1 + self.t2 {
            return self.forward(t);
        }
        let r = total - t;
        (
            self.length - (self.v1 * r - self.a1 * r * r / 2.0 - sg * j * r * r * r / 6.0),
            self.v1 - self.a1 * r - sg * j * r * r / 2.0,
            self.a1 + sg * j * r,
        )
    }

    /// Time, s, at which the change has covered `x_mm` (clamped to it), by Newton's method
    /// on the distance, kept inside a bracket (bisection where a step leaves it).
    pub(crate) fn time_at_distance(&self, x_mm: f64) -> f64 {
        let total = self.duration_s();
        let length = self.length_mm();
        if x_mm <= 0.0 || total <= 0.0 {
            return 0.0;
        }
        if x_mm >= length {
            return total;
        }
        let (mut lo, mut hi) = (0.0, total);
        let mean = 0.5 * (self.v0 + self.v1);
        let mut t = (x_mm / mean).clamp(0.0, total);
        for _ in 0..100 {
            let (x, v, _) = self.state(t);
            let err = x - x_mm;
            if err > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            if err.abs() <= 1e-13 * (1.0 + length) || hi - lo <= 1e-15 * (1.0 + total) {
                break;
            }
            let next = if v > 0.0 { t - err / v } else { f64::NAN };
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        t
    }

    /// Speed and acceleration where the change has covered `x_mm` (clamped to it).
    pub(crate) fn at_distance(&self, x_mm: f64) -> (f64, f64) {
        let (_, v, a) = self.state(self.time_at_distance(x_mm));
        (v, a)
    }
}

/// Limits a piece of a run is shaped under: arc lengths, the acceleration-limited envelope
/// (the highest speed any motion can have at each station), and each interval's
/// tangential acceleration and jerk limits (the latter times the share to use).
pub(crate) struct Limits<'a> {
    pub(crate) s_mm: &'a [f64],
    pub(crate) envelope_mm_s: &'a [f64],
    pub(crate) accel_mm_s2: &'a [f64],
    pub(crate) jerk_mm_s3: &'a [f64],
}

/// The motion between two dips `i < k` (stations of the piece): a change from speed
/// `d.0` at station i up to (or down to) `peak`, constant `peak`, a change to `d.1` at
/// station k, under the gap's least acceleration and jerk limits.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gap {
    /// Its first and last station, of the piece shaped.
    pub(crate) i: usize,
    pub(crate) k: usize,
    first: Change,
    second: Change,
    /// Where the second change starts, from station i, mm.
    second_from_mm: f64,
}

impl Gap {
    /// The gap's motion, or `None` where the two changes do not fit between the stations.
    /// Each change takes the least acceleration limit of the intervals it crosses (the
    /// largest A that is at most the least limit over the change made with it: from the
    /// gap's largest limit down, a few rounds) and the gap's least jerk limit. `acc` are
    /// the accelerations at the two ends (0 at a dip held flat; a dip that follows the
    /// envelope has its first or last interval's: MODEL.md §6.1, "Dips that follow the
    /// envelope").
    fn new(
        lim: &Limits,
        (i, k): (usize, usize),
        d: (f64, f64),
        acc: (f64, f64),
        peak: f64,
    ) -> Option<Self> {
        let accel = &lim.accel_mm_s2[i..k];
        let j = lim.jerk_mm_s3[i..k]
            .iter()
            .fold(f64::INFINITY, |m, &x| m.min(x));
        let s = &lim.s_mm[i..=k];
        let len = s[s.len() - 1] - s[0];
        // The change from (v0, a0) to (v1, a1) over the first (`forward`) or last intervals.
        let change = |(v0, a0): (f64, f64), (v1, a1): (f64, f64), forward: bool| {
            // An end that follows the envelope keeps its acceleration (MODEL.md §6.1, "Dips
            // that follow the envelope").
            let floor = a0.abs().max(a1.abs());
            let mut a = accel.iter().fold(floor, |m, &x| m.max(x));
            let mut c = Change::between(v0, a0, v1, a1, a, j)?;
            for _ in 0..8 {
                let reach = c.length_mm();
                let least = if forward {
                    let end = s.partition_point(|&x| x - s[0] < reach).min(accel.len());
                    accel[..end.max(1)].iter().fold(a, |m, &x| m.min(x))
                } else {
                    let from = s.partition_point(|&x| len - (x - s[0]) > reach);
                    let from = from.saturating_sub(1).min(accel.len() - 1);
                    accel[from..].iter().fold(a, |m, &x| m.min(x))
                };
                let least = least.max(floor);
                if least >= a {
                    break;
                }
                a = least;
                c = Change::between(v0, a0, v1, a1, a, j)?;
            }
            Some(c)
        };
        let first = change((d.0, acc.0), (peak, 0.0), true)?;
        let second = change((peak, 0.0), (d.1, acc.1), false)?;
        let used = first.length_mm() + second.length_mm();
        (used <= len).then_some(Gap {
            i,
            k,
            first,
            second,
            second_from_mm: len - second.length_mm(),
        })
    }

    /// Time the motion takes from station i to `x_mm` past it, s: the first change, the
    /// peak held, the second change (MODEL.md §6.1, "Exact direct sections").
    pub(crate) fn time_at_s(&self, x_mm: f64) -> f64 {
        let first_mm = self.first.length_mm();
        if x_mm <= first_mm {
            return self.first.time_at_distance(x_mm);
        }
        let held_mm = (self.second_from_mm - first_mm).max(0.0);
        let peak = self.first.v1;
        let after_first = self.first.duration_s();
        if x_mm <= self.second_from_mm {
            return after_first + (x_mm - first_mm) / peak;
        }
        after_first
            + if peak > 0.0 { held_mm / peak } else { 0.0 }
            + self.second.time_at_distance(x_mm - self.second_from_mm)
    }

    /// Distance from station i, mm, and speed, mm/s, `t_s` after the motion leaves station
    /// i (clamped to the gap): s(t) of jerk ±J, 0 or ∓J in each phase, so the acceleration
    /// is continuous and the jerk within J at every instant.
    pub(crate) fn state_s(&self, t_s: f64) -> (f64, f64) {
        let first_mm = self.first.length_mm();
        let after_first = self.first.duration_s();
        if t_s <= after_first {
            let (x, v, _) = self.first.state(t_s);
            return (x, v);
        }
        let peak = self.first.v1;
        let held_s = if peak > 0.0 {
            (self.second_from_mm - first_mm).max(0.0) / peak
        } else {
            0.0
        };
        if t_s <= after_first + held_s {
            return (first_mm + peak * (t_s - after_first), peak);
        }
        let (x, v, _) = self.second.state(t_s - after_first - held_s);
        (self.second_from_mm + x, v)
    }

    /// Speed and acceleration at station m of the gap.
    fn at(&self, lim: &Limits, m: usize) -> (f64, f64) {
        let x = lim.s_mm[m] - lim.s_mm[self.i];
        if x >= self.second_from_mm {
            self.second.at_distance(x - self.second_from_mm)
        } else {
            self.first.at_distance(x)
        }
    }

    /// Whether every station strictly inside the gap is at or under the envelope (the
    /// intervals' own acceleration limits are kept by the passes after the shape, and the
    /// jerk by the check of the samples). A gap with an accelerated end, whose changes may
    /// hold an acceleration over the least limit of the intervals they cross (up to the
    /// end's), also keeps each interval's limit: the largest |a| over an interval is at
    /// its stations or, where a change's held acceleration lies in it, that one (MODEL.md
    /// §6.1, eq. 6.1d).
    fn fits(&self, lim: &Limits) -> bool {
        let accelerated = self.accelerated_ends();
        let from = lim.s_mm[self.i];
        // Where each change holds its acceleration, from station i, mm.
        let held = [
            (self.first.held_span_mm(0.0), self.first.ap.abs()),
            (
                self.second.held_span_mm(self.second_from_mm),
                self.second.ap.abs(),
            ),
        ];
        let mut a_before = self.first.a0;
        (self.i + 1..=self.k).all(|m| {
            let (v, a) = if m < self.k {
                self.at(lim, m)
            } else {
                (0.0, self.second.a1)
            };
            if m < self.k && v > lim.envelope_mm_s[m] * (1.0 + 1e-12) {
                return false;
            }
            if accelerated {
                let (lo, hi) = (lim.s_mm[m - 1] - from, lim.s_mm[m] - from);
                let peak = held
                    .iter()
                    .filter(|((x0, x1), _)| *x0 <= hi && *x1 >= lo)
                    .fold(0.0f64, |p, (_, ap)| p.max(*ap));
                if a_before.abs().max(a.abs()).max(peak) > lim.accel_mm_s2[m - 1] * (1.0 + 1e-9) {
                    return false;
                }
            }
            a_before = a;
            true
        })
    }

    /// Whether it starts or ends with an acceleration (beside an envelope followed).
    pub(crate) fn accelerated_ends(&self) -> bool {
        self.first.a0 != 0.0 || self.second.a1 != 0.0
    }
}

/// Whether the gap `(i, k)` has a motion from (`d.0`, `acc.0`) to (`d.1`, `acc.1`)
/// through the peak `peak`.
fn feasible(lim: &Limits, gap: (usize, usize), d: (f64, f64), acc: (f64, f64), peak: f64) -> bool {
    Gap::new(lim, gap, d, acc, peak).is_some_and(|g| g.fits(lim))
}

/// The lowest peak a gap from (`d.0`, `acc.0`) to (`d.1`, `acc.1`) is shaped through: where
/// each end levels off at full jerk, v + a·|a|/2J at its start and v − a·|a|/2J at its
/// end (the higher of the two; the higher end speed between ends at rest).
fn least_peak(lim: &Limits, (i, k): (usize, usize), d: (f64, f64), acc: (f64, f64)) -> f64 {
    let j = lim.jerk_mm_s3[i..k.max(i + 1)]
        .iter()
        .fold(f64::INFINITY, |m, &x| m.min(x));
    let start = d.0 + acc.0 * acc.0.abs() / (2.0 * j);
    let end = d.1 - acc.1 * acc.1.abs() / (2.0 * j);
    start.max(end)
}

/// Grid of peaks below [`least_peak`] a gap between accelerated ends is tried at, where
/// that peak has no motion: a gap that decelerates (accelerates) through its hold.
const PEAK_GRID: usize = 16;

/// The highest peak, at least the lowest found (from [`least_peak`] up to the highest
/// envelope speed of the gap, bisection), the gap `(i, k)` has a motion through from
/// (`d.0`, `acc.0`) to (`d.1`, `acc.1`), or `None`. Between accelerated ends where
/// [`least_peak`] has none, peaks down to half the lower end speed are tried on a grid
/// first (MODEL.md §6.1, "Dips that follow the envelope").
fn gap_peak(lim: &Limits, (i, k): (usize, usize), d: (f64, f64), acc: (f64, f64)) -> Option<f64> {
    let ok = |p: f64| feasible(lim, (i, k), d, acc, p);
    let top = lim.envelope_mm_s[i..=k]
        .iter()
        .fold(0.0f64, |m, &x| m.max(x));
    let low = least_peak(lim, (i, k), d, acc);
    if ok(low) {
        return Some(highest(low, top.max(low), ok));
    }
    if acc == (0.0, 0.0) {
        return None;
    }
    let floor = 0.5 * d.0.min(d.1);
    let mut above = low;
    for step in 1..=PEAK_GRID {
        let p = low - (low - floor) * step as f64 / PEAK_GRID as f64;
        if ok(p) {
            return Some(highest(p, above, ok));
        }
        above = p;
    }
    None
}

/// How many stations before (after) a dip the lowest station of an envelope falling into
/// it (rising out of it) that is followed is looked for (MODEL.md §6.1, "Dips that follow
/// the envelope").
const FOLLOW_SCAN: usize = 48;

/// Bisection steps of the searches over a speed.
const BISECTIONS: usize = 40;

/// The highest `x` in [lo, hi] with `ok(x)`, `ok(lo)` taken as true (bisection).
fn highest(lo: f64, hi: f64, ok: impl Fn(f64) -> bool) -> f64 {
    if ok(hi) {
        return hi;
    }
    let (mut lo, mut hi) = (lo, hi);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// A dip of the envelope: the stations `l..=r` around a local minimum, over which the
/// motion follows the envelope under the speed `d` (its lowest envelope speed at first,
/// lowered where the gaps beside it need).
#[derive(Clone, Copy, Debug)]
struct Dip {
    l: usize,
    r: usize,
    d: f64,
    /// The end of a slow corner's intervals (kept: the gaps beside it take their
    /// accelerations from either side of it).
    edge: bool,
    /// A stretch of the envelope the motion follows (MODEL.md §6.1, "Dips that follow the
    /// envelope"): never lowered, but narrowed or dropped where a gap beside it has no
    /// motion.
    follow: bool,
    /// The accelerations the gaps before and after it end and start with: the
    /// envelope's over its first and last interval where it follows the envelope, else 0.
    a_l: f64,
    a_r: f64,
}

/// Acceleration of the stations' plan `u` over interval `k`.
fn interval_accel(lim: &Limits, u: &[f64], k: usize) -> f64 {
    interval_accel_mm_s2(lim.s_mm, u, k)
}

/// Whether following the envelope over the stations `l..=r` by constant accelerations
/// between them, entered with the acceleration of interval `l` and left with that of
/// interval r − 1, keeps every change of acceleration over a time `period_s` within
/// `jerk`·`period_s` (MODEL.md §6.1, eq. 6.1c: a third difference
/// at that period is a weighted mean of such changes over the period, divided by it).
fn followable(lim: &Limits, (l, r): (usize, usize), period_s: f64, jerk: f64) -> bool {
    let u = lim.envelope_mm_s;
    let mut times = Vec::with_capacity(r - l);
    let mut t = 0.0;
    for k in l..r {
        let dt = interval_time_s(lim.s_mm, u, k);
        if !(dt.is_finite() && dt > 0.0) {
            return false;
        }
        let a = interval_accel(lim, u, k);
        if a.abs() > lim.accel_mm_s2[k] * (1.0 + 1e-9) {
            return false;
        }
        times.push((t, t + dt, a));
        t += dt;
    }
    let limit = jerk * period_s;
    for (p, &(_, end_p, a_p)) in times.iter().enumerate() {
        for &(start_q, _, a_q) in &times[p + 1..] {
            if start_q - end_p >= period_s {
                break;
            }
            if (a_q - a_p).abs() > limit {
                return false;
            }
        }
    }
    true
}

/// The dips of the envelope `lim.envelope_mm_s`, at least 3 stations ([`shape`]): its
/// strict local minima (a flat bottom whole) and the ends, and the ends of the slow
/// intervals beside each (acceleration limit at most `slow_share` times the jerk limit)
/// as dips of their own.
fn dips_of(lim: &Limits, slow_share: f64) -> Vec<Dip> {
    let u = lim.envelope_mm_s;
    let n = u.len();
    let slow = |k: usize| lim.accel_mm_s2[k] <= slow_share * lim.jerk_mm_s3[k];
    // Cores: the flat stretches of u that are local minima, and the ends.
    let mut cores: Vec<(usize, usize)> = Vec::new();
    let mut m = 0;
    while m < n {
        let mut e = m;
        while e + 1 < n && u[e + 1] == u[m] {
            e += 1;
        }
        let low = (m == 0 || u[m - 1] > u[m]) && (e == n - 1 || u[e + 1] > u[e]);
        if low {
            cores.push((m, e));
        } else if m == 0 {
            cores.push((0, 0));
        } else if e == n - 1 {
            cores.push((n - 1, n - 1));
        }
        m = e + 1;
    }
    let dip = |l: usize, r: usize, edge: bool| Dip {
        l,
        r,
        d: u[l],
        edge,
        follow: false,
        a_l: 0.0,
        a_r: 0.0,
    };
    // Each core, and the ends of the slow intervals beside it as dips of their own.
    let mut dips: Vec<Dip> = Vec::with_capacity(cores.len());
    for (l, r) in cores {
        let (mut ll, mut rr) = (l, r);
        while ll > 0 && slow(ll - 1) {
            ll -= 1;
        }
        while rr + 1 < n && slow(rr) {
            rr += 1;
        }
        // An edge that reaches back over the edges before it replaces them.
        while ll < l && dips.last().is_some_and(|d| d.r >= ll && d.edge) {
            dips.pop();
        }
        if ll < l && dips.last().is_none_or(|d| d.r < ll) {
            dips.push(dip(ll, ll, true));
        }
        if dips.last().is_some_and(|d| d.r >= l) {
            dips.pop();
        }
        dips.push(dip(l, r, false));
        if rr > r {
            dips.push(dip(rr, rr, true));
        }
    }
    dips
}

/// The envelope with the stretches rising out of its dips lowered where the motion
/// cannot leave the dip at rest onto it but can onto a pass below it (MODEL.md §6.1, "Dips
/// that follow the envelope"): where the envelope is the forward pass at the intervals'
/// own limits and those grow with the distance from the dip (a sharp corner's exit), a
/// change from the dip's speed x at rest to a state on it would hold an acceleration over
/// the limits of the intervals before it. The pass from below leaves station l at
/// w_l = x + a²/2J with a = min(a_l−1, a_l) (a single phase of jerk J from the dip at
/// rest ends there, with an acceleration every interval before it allows), and goes on at
/// the intervals' limits under the envelope, w²_k+1 = min(u²_k+1, w²_k + 2·a_k·Δs_k)
/// (MODEL.md §6.1, eq. 6.1e), as far as [`followable`] allows; l is the first station (at most [`FOLLOW_SCAN`] after
/// the dip) where the envelope itself cannot be left onto and that pass can.
fn passes_from_below(lim: &Limits, dips: &[Dip], period_s: f64) -> Vec<f64> {
    let u = lim.envelope_mm_s;
    let mut env = u.to_vec();
    let jerk = lim.jerk_mm_s3.iter().fold(f64::INFINITY, |m, &x| m.min(x));
    let accel = lim.accel_mm_s2;
    let fits = |lim: &Limits, gap: (usize, usize), d: (f64, f64), acc: (f64, f64)| {
        gap_peak(lim, gap, d, acc).is_some()
    };
    let mut w = Vec::new();
    for pair in dips.windows(2) {
        let (r0, next) = (pair[0].r, pair[1].l);
        let x = u[r0];
        for l in r0 + 2..=r0 + FOLLOW_SCAN {
            if l + 3 >= next {
                break;
            }
            if !(u[l + 1] > u[l]) {
                continue;
            }
            let on_u = (interval_accel(lim, u, l), u[l]);
            if on_u.0.abs() <= accel[l] * (1.0 + 1e-9)
                && fits(lim, (r0, l), (x, u[l]), (0.0, on_u.0))
            {
                break;
            }
            let a = accel[l - 1].min(accel[l]);
            let w_l = x + a * a / (2.0 * jerk);
            if !(w_l < u[l]) {
                continue;
            }
            w.clear();
            w.push(w_l);
            // The first interval at a, the others at their limits, under the envelope.
            let mut k = l;
            while k + 3 < next {
                let a_k = if k == l { a } else { accel[k] };
                let s = lim.s_mm;
                let next_w = (w[w.len() - 1].powi(2) + 2.0 * a_k * (s[k + 1] - s[k])).sqrt();
                if next_w >= u[k + 1] {
                    break;
                }
                w.push(next_w);
                k += 1;
            }
            if w.len() < 2 {
                continue;
            }
            let a_l = interval_accel_mm_s2(&lim.s_mm[l..], &w, 0);
            if !fits(lim, (r0, l), (x, w_l), (0.0, a_l)) {
                continue;
            }
            env[l..l + w.len()].copy_from_slice(&w);
            // Only as far as it is followed.
            let probe = Limits {
                envelope_mm_s: &env,
                ..*lim
            };
            let mut r = l + 1;
            while r + 1 < l + w.len() && followable(&probe, (l, r + 1), period_s, jerk) {
                r += 1;
            }
            env[r + 1..l + w.len()].copy_from_slice(&u[r + 1..l + w.len()]);
            break;
        }
    }
    env
}

/// Shapes a section (MODEL.md §6.1, "Direct sections"): `v` gets the speed at each
/// station of `lim`, from the envelope's first speed to its last. The dips are the envelope's strict
/// local minima (a flat bottom whole) and the run's ends, each widened over the intervals
/// beside it whose acceleration limit is at most `slow_share` times their jerk limit
/// (the slow corners' intervals: there the motion follows the envelope, whose
/// acceleration is then too small to matter for the jerk). With `follow` = Some(T), the
/// dips inside the section are also widened over the envelope on either side as far as
/// following it keeps the changes of acceleration over T within the jerk limit times T
/// ([`followable`]; MODEL.md §6.1, "Dips that follow the envelope"; where a change at
/// rest cannot leave a dip onto the envelope, onto a pass below it,
/// [`passes_from_below`]), and the gaps beside
/// such a dip end and start with the envelope's acceleration there. Between two dips the
/// motion changes speed from the first dip's state to a peak (no acceleration) and on to
/// the next dip's, each change the time-optimal jerk-limited one ([`Change`]). Each dip's
/// speed is lowered until the gaps on either side have such a motion under the envelope
/// (the higher end of a gap lowered, sweeping forwards then backwards; a widened dip is
/// narrowed first, station by station); dips that were lowered and whose neighbours have
/// a motion through them are dropped; then each gap takes the highest peak it has a
/// motion through (bisection). Returns `false` (nothing usable) where a gap still has no
/// motion or a speed inside the run comes out as 0.
pub(crate) fn shape(
    lim: &Limits,
    slow_share: f64,
    follow: Option<f64>,
    v: &mut [f64],
    mut gaps: Option<&mut Vec<Gap>>,
) -> bool {
    let u = lim.envelope_mm_s;
    let n = u.len();
    debug_assert_eq!(v.len(), n);
    if n < 3 {
        v.copy_from_slice(u);
        return true;
    }
    let mut dips = dips_of(lim, slow_share);
    // With `follow`, the envelope lowered to the passes from below it follows out of dips.
    let lowered: Vec<f64>;
    let below: Limits;
    let lim = match follow {
        Some(period_s) => {
            lowered = passes_from_below(lim, &dips, period_s);
            below = Limits {
                envelope_mm_s: &lowered,
                ..*lim
            };
            &below
        }
        None => lim,
    };
    let u = lim.envelope_mm_s;
    let shaping = Shaping { lim, follow };
    if let Some(period_s) = follow {
        dips = shaping.with_followed(&dips, period_s);
    }
    shaping.lower_dips(&mut dips);
    shaping.drop_lowered(&mut dips);
    if (0..dips.len() - 1).any(|g| !shaping.ok(&dips, g)) {
        return false;
    }
    for dip in &dips {
        for k in dip.l..=dip.r {
            v[k] = u[k].min(dip.d);
        }
    }
    for g in 0..dips.len() - 1 {
        let (i, k) = Shaping::gap(&dips, g);
        if k <= i + 1 {
            continue;
        }
        let (d, acc) = shaping.ends(&dips, g);
        let Some(peak) = gap_peak(lim, (i, k), d, acc) else {
            return false;
        };
        let motion = Gap::new(lim, (i, k), d, acc, peak).expect("a feasible peak");
        for (m, vm) in v.iter_mut().enumerate().take(k).skip(i + 1) {
            *vm = motion.at(lim, m).0.min(u[m]);
        }
        if let Some(gaps) = gaps.as_deref_mut() {
            gaps.push(motion);
        }
    }
    v[1..n - 1].iter().all(|&x| x > 0.0)
}

/// The steps of [`shape`] over its dips: the limits, with the envelope lowered to the
/// passes from below where `follow` = Some(T) ([`passes_from_below`]), and `follow`.
#[derive(Clone, Copy)]
struct Shaping<'l> {
    lim: &'l Limits<'l>,
    follow: Option<f64>,
}

impl Shaping<'_> {
    /// Gap g: from dip g's last station to dip g+1's first.
    fn gap(dips: &[Dip], g: usize) -> (usize, usize) {
        (dips[g].r, dips[g + 1].l)
    }

    /// Gap g's end speeds and accelerations.
    fn ends(&self, dips: &[Dip], g: usize) -> ((f64, f64), (f64, f64)) {
        let u = self.lim.envelope_mm_s;
        let (i, k) = Self::gap(dips, g);
        (
            (u[i].min(dips[g].d), u[k].min(dips[g + 1].d)),
            (dips[g].a_r, dips[g + 1].a_l),
        )
    }

    /// Whether the gap `i..=k` has a motion between the end speeds `d` and accelerations
    /// `acc` under the envelope.
    fn fits_between(&self, (i, k): (usize, usize), d: (f64, f64), acc: (f64, f64)) -> bool {
        let lim = self.lim;
        if acc == (0.0, 0.0) {
            feasible(lim, (i, k), d, acc, least_peak(lim, (i, k), d, acc))
        } else {
            gap_peak(lim, (i, k), d, acc).is_some()
        }
    }

    /// Whether gap g has a motion through it (or no interval).
    fn ok(&self, dips: &[Dip], g: usize) -> bool {
        let (i, k) = Self::gap(dips, g);
        let (d, acc) = self.ends(dips, g);
        k <= i || self.fits_between((i, k), d, acc)
    }

    /// A stretch l..=r of the envelope followed: its accelerations at either end.
    fn following(&self, l: usize, r: usize) -> Dip {
        let (lim, u) = (self.lim, self.lim.envelope_mm_s);
        Dip {
            l,
            r,
            d: f64::INFINITY,
            edge: false,
            follow: true,
            a_l: interval_accel(lim, u, l),
            a_r: interval_accel(lim, u, r - 1),
        }
    }

    /// `dips` with the stretches of the envelope beside each that the motion follows at
    /// the period `period_s` ([`followable`]) as dips of their own.
    fn with_followed(&self, dips: &[Dip], period_s: f64) -> Vec<Dip> {
        let (lim, u) = (self.lim, self.lim.envelope_mm_s);
        let jerk = lim.jerk_mm_s3.iter().fold(f64::INFINITY, |m, &x| m.min(x));
        let can_follow = |l: usize, r: usize| followable(lim, (l, r), period_s, jerk);
        let mut with: Vec<Dip> = Vec::with_capacity(3 * dips.len());
        for g in 0..dips.len() {
            let dip = dips[g];
            // Before the dip: the envelope falling into it, followed down to the lowest
            // station whose change into the dip fits (at most FOLLOW_SCAN stations up),
            // and up as far as it can be followed.
            if let Some(before) = with.last().map(|d| d.r) {
                let bottom = (dip.l.saturating_sub(FOLLOW_SCAN)..=dip.l.saturating_sub(2))
                    .rev()
                    .filter(|&r| r > before + 3)
                    .find(|&r| {
                        u[r - 1] > u[r]
                            && can_follow(r - 1, r)
                            && self.fits_between(
                                (r, dip.l),
                                (u[r], u[dip.l].min(dip.d)),
                                (interval_accel(lim, u, r - 1), dip.a_l),
                            )
                    });
                if let Some(r) = bottom {
                    let mut l = r - 1;
                    while l > before + 2 && u[l - 1] > u[l] && can_follow(l - 1, r) {
                        l -= 1;
                    }
                    with.push(self.following(l, r));
                }
            }
            with.push(dip);
            // After it: the envelope rising out of it, the same way.
            if let Some(next) = dips.get(g + 1).map(|d| d.l) {
                let foot = (dip.r + 2..=dip.r + FOLLOW_SCAN)
                    .filter(|&l| l + 3 < next)
                    .find(|&l| {
                        u[l + 1] > u[l]
                            && can_follow(l, l + 1)
                            && self.fits_between(
                                (dip.r, l),
                                (u[dip.r].min(dip.d), u[l]),
                                (dip.a_r, interval_accel(lim, u, l)),
                            )
                    });
                if let Some(l) = foot {
                    let mut r = l + 1;
                    while r + 2 < next && u[r + 1] > u[r] && can_follow(l, r + 1) {
                        r += 1;
                    }
                    with.push(self.following(l, r));
                }
            }
        }
        with
    }

    /// The higher end of gap g lowered until the gap has a motion through it (the run's
    /// ends keep their speeds). A stretch followed at either end is narrowed instead, from
    /// that end, station by station, to the widest that has one, or dropped.
    fn lower(&self, dips: &mut Vec<Dip>, g: usize) {
        let follow = self.follow;
        let (i, k) = Self::gap(dips, g);
        let ((a, b), acc) = self.ends(dips, g);
        let last_dip = dips.len() - 1;
        let higher = if a > b && g > 0 {
            Some(g)
        } else if a <= b && g + 1 < last_dip {
            Some(g + 1)
        } else {
            None
        };
        if let Some(at) = higher.filter(|&at| !dips[at].follow) {
            dips[at].d = if at == g {
                highest(b, a, |x| self.fits_between((i, k), (x, b), acc))
            } else {
                highest(a, b, |x| self.fits_between((i, k), (a, x), acc))
            };
            if follow.is_none() || self.ok(dips, g) {
                return;
            }
        }
        for (at, from_right) in [(g + 1, false), (g, true)] {
            if !dips[at].follow {
                continue;
            }
            while dips[at].l + 1 < dips[at].r {
                if from_right {
                    dips[at].r -= 1;
                } else {
                    dips[at].l += 1;
                }
                dips[at] = self.following(dips[at].l, dips[at].r);
                if self.ok(dips, g) {
                    return;
                }
            }
            dips.remove(at);
            return;
        }
        // The higher end is the section's: the lower one lowered (the envelope rises or
        // falls too steeply beside it for a change from no acceleration).
        let ((a, b), acc) = self.ends(dips, g);
        if follow.is_some() && a <= b && g > 0 {
            dips[g].d = highest(0.0, a, |x| self.fits_between((i, k), (x, b), acc));
        } else if follow.is_some() && a > b && g + 1 < last_dip {
            dips[g + 1].d = highest(0.0, b, |x| self.fits_between((i, k), (a, x), acc));
        }
    }

    /// Each gap without a motion through it has an end lowered ([`Shaping::lower`]),
    /// sweeping forwards then backwards, at most 4 times.
    fn lower_dips(&self, dips: &mut Vec<Dip>) {
        for _ in 0..4 {
            let mut changed = false;
            let mut g = 0;
            while g + 1 < dips.len() {
                let ((a, b), _) = self.ends(dips, g);
                if (b > a || dips[g].follow || dips[g + 1].follow) && !self.ok(dips, g) {
                    self.lower(dips, g);
                    changed = true;
                }
                g += 1;
            }
            let mut g = dips.len() - 1;
            while g > 0 {
                g -= 1;
                if g + 1 >= dips.len() {
                    continue;
                }
                let ((a, b), _) = self.ends(dips, g);
                if a >= b && !self.ok(dips, g) {
                    self.lower(dips, g);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
    }

    /// Lowered dips of one station the motion need not stop its acceleration at, dropped.
    fn drop_lowered(&self, dips: &mut Vec<Dip>) {
        let u = self.lim.envelope_mm_s;
        let mut g = 1;
        while g + 1 < dips.len() {
            let dip = dips[g];
            let lowered = dip.l == dip.r && !dip.edge && dip.d < u[dip.l];
            let (i, k) = (dips[g - 1].r, dips[g + 1].l);
            let d = (u[i].min(dips[g - 1].d), u[k].min(dips[g + 1].d));
            let acc = (dips[g - 1].a_r, dips[g + 1].a_l);
            if lowered && self.fits_between((i, k), d, acc) {
                dips.remove(g);
            } else {
                g += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change's distance, speed and acceleration are continuous across its phases and
    /// its distance matches the closed form; at_distance inverts the distance.
    #[test]
    fn changes_are_continuous_and_invert() {
        for (v0, v1, a, j) in [
            (10.0, 30.0, 1000.0, 20000.0),
            (30.0, 10.0, 1000.0, 20000.0),
            (0.0, 50.0, 200.0, 20000.0),
            (50.0, 49.0, 1000.0, 5000.0),
        ] {
            let c = Change::new(v0, v1, a, j);
            let total = c.duration_s();
            let dv: f64 = (v1 - v0).abs();
            let expected = if dv * j >= a * a {
                dv / a + a / j
            } else {
                2.0 * (dv / j).sqrt()
            };
            assert!((total - expected).abs() <= 1e-12 * expected);
            let (x_end, v_end, a_end) = c.state(total);
            assert!((x_end - c.length_mm()).abs() <= 1e-9 * x_end);
            assert!((v_end - v1).abs() <= 1e-9 && a_end.abs() <= 1e-9);
            let steps = 1000;
            let mut last = c.state(0.0);
            for i in 1..=steps {
                let t = total * i as f64 / steps as f64;
                let now = c.state(t);
                let h = total / steps as f64;
                assert!(now.0 >= last.0);
                assert!((now.1 - last.1).abs() <= a * h * (1.0 + 1e-9));
                assert!((now.2 - last.2).abs() <= j * h * (1.0 + 1e-9));
                assert!(now.2.abs() <= a * (1.0 + 1e-12));
                let (v, _) = c.at_distance(now.0);
                assert!(
                    (v - now.1).abs() <= 1e-7 * (1.0 + v1.max(v0)),
                    "{v} {}",
                    now.1
                );
                last = now;
            }
        }
    }

    /// Changes between states with accelerations ≠ 0 (MODEL.md §6.1, eqs. 6.1a–b) against
    /// their closed forms: duration t1 + t2 + t3 with the held acceleration
    /// ap² = g·J·Δv + (a0² + a1²)/2 (or ±A, the rest of Δv at A), t1 = |ap − a0|/J,
    /// t3 = |ap − a1|/J; and against the jerk profile (g·J, 0, −g·J over those phases)
    /// integrated exactly step by step: the end state (v1, a1), the length and every
    /// sample's distance, speed and acceleration; at every sample |a| ≤ A and the jerk
    /// between samples within J. A change whose end acceleration is over A has none.
    #[test]
    fn changes_between_accelerated_states_are_the_closed_form() {
        let j = 20000.0;
        // (v0, a0, v1, a1, A, first jerk's sign g, whether A is held).
        for (v0, a0, v1, a1, a, g, held) in [
            // Falling onto a cap ramp (a = −k·v) from a peak at rest.
            (50.0, 0.0, 20.0, -600.0, 1000.0, -1.0, false),
            (50.0, 0.0, 5.0, -300.0, 800.0, -1.0, true),
            // Rising out of an envelope followed, to a peak at rest.
            (10.0, 300.0, 40.0, 0.0, 1000.0, 1.0, false),
            // Leaving a ramp into a dip at rest: harder first, then easing off.
            (14.6, -480.0, 4.4, 0.0, 1000.0, -1.0, false),
            // Both ends accelerating.
            (10.0, 200.0, 30.0, 500.0, 1000.0, 1.0, false),
            (10.0, 200.0, 60.0, 500.0, 700.0, 1.0, true),
        ] {
            let c = Change::between(v0, a0, v1, a1, a, j).expect("a change");
            let dv = v1 - v0;
            let mut ap = (g * j * dv + 0.5 * (a0 * a0 + a1 * a1)).sqrt();
            let mut t2 = 0.0;
            assert_eq!(ap > a, held, "{v0} {a0} {v1} {a1}");
            if held {
                ap = a;
                t2 = (g * dv - (2.0 * a * a - a0 * a0 - a1 * a1) / (2.0 * j)) / a;
            }
            let (t1, t3) = ((ap - g * a0) / j, (ap - g * a1) / j);
            let total = t1 + t2 + t3;
            assert!(t1 >= 0.0 && t2 >= 0.0 && t3 >= 0.0);
            assert!(
                (c.duration_s() - total).abs() <= 1e-12 * total,
                "{} vs {total}",
                c.duration_s()
            );
            // The jerk profile integrated exactly (constant jerk in each step).
            let steps = 2000;
            let (mut x, mut v, mut acc) = (0.0, v0, a0);
            let mut last = c.state(0.0);
            let mut t = 0.0;
            for (len, jerk) in [(t1, g * j), (t2, 0.0), (t3, -g * j)] {
                let h = len / steps as f64;
                for _ in 0..steps {
                    x += v * h + acc * h * h / 2.0 + jerk * h * h * h / 6.0;
                    v += acc * h + jerk * h * h / 2.0;
                    acc += jerk * h;
                    t += h;
                    let now = c.state(t);
                    assert!(
                        (now.0 - x).abs() <= 1e-9 * (1.0 + x),
                        "{t}: {} vs {x}",
                        now.0
                    );
                    assert!((now.1 - v).abs() <= 1e-9 * (1.0 + v.abs()));
                    assert!((now.2 - acc).abs() <= 1e-9 * (1.0 + acc.abs()));
                    assert!(now.2.abs() <= a * (1.0 + 1e-12));
                    if h > 0.0 {
                        assert!((now.2 - last.2).abs() <= j * h * (1.0 + 1e-6));
                    }
                    last = now;
                }
            }
            assert!((v - v1).abs() <= 1e-9 * v1 && (acc - a1).abs() <= 1e-9 * (1.0 + a1.abs()));
            assert!((c.length_mm() - x).abs() <= 1e-9 * x);
            assert!(
                (c.time_at_distance(0.5 * x) - {
                    // The time at half the length, by bisection on the integrated distance.
                    let (mut lo, mut hi) = (0.0, total);
                    for _ in 0..100 {
                        let mid = 0.5 * (lo + hi);
                        if c.state(mid).0 < 0.5 * x {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    lo
                })
                .abs()
                    <= 1e-9
            );
        }
        assert!(Change::between(50.0, 0.0, 20.0, -1200.0, 1000.0, j).is_none());
        assert!(Change::between(50.0, 1200.0, 60.0, 0.0, 1000.0, j).is_none());
    }

    /// A sharp corner's exit (MODEL.md §6.1, "Dips that follow the envelope"): a dip of
    /// 4 mm/s 3 mm along (a cap ramp falls into it, 3 + 31.25·d mm/s), the envelope
    /// after it the forward pass at the intervals' own limits, which grow with the
    /// distance d from the dip, 130 + 600·d mm/s² (up to 1 000), to 50 mm/s. A change from
    /// the dip at rest onto the envelope would hold an acceleration over the limits before
    /// it; the pass from below leaves station l at w_l = 4 + a²/2J, a = min(a_l−1, a_l),
    /// and goes on as w²_k+1 = w²_k + 2·a_k·Δs (closed form, within 10⁻⁹). The shape is
    /// under the envelope, every interval of its stations' plan within its limit, and the
    /// gaps' motions, sampled every 10 µs, keep each interval's limit at every sample
    /// (eq. 6.1d); the shape with its dips at rest has none (or a slower one).
    #[test]
    fn a_corner_exit_is_followed_on_a_pass_from_below() {
        let (j, period) = (20000.0, 0.016);
        let n = 160;
        let dip = 60;
        let ds = 0.05;
        let s: Vec<f64> = (0..n).map(|k| k as f64 * ds).collect();
        let accel: Vec<f64> = (0..n - 1)
            .map(|k| {
                if k < dip {
                    1000.0
                } else {
                    (130.0 + 600.0 * (s[k] - s[dip])).min(1000.0)
                }
            })
            .collect();
        let mut u = vec![0.0; n];
        u[dip] = 4.0;
        for k in dip..n - 1 {
            u[k + 1] = (u[k] * u[k] + 2.0 * accel[k] * ds).sqrt().min(50.0);
        }
        for k in (0..dip).rev() {
            u[k] = (3.0 + 31.25 * (s[dip] - s[k])).min(50.0);
        }
        u[dip] = 4.0;
        let jerk = vec![j; n - 1];
        let lim = Limits {
            s_mm: &s,
            envelope_mm_s: &u,
            accel_mm_s2: &accel,
            jerk_mm_s3: &jerk,
        };
        // The pass from below, against its closed form.
        let dips = dips_of(&lim, period / 3.0);
        let env = passes_from_below(&lim, &dips, period);
        let l = (dip + 1..n)
            .find(|&k| env[k] < u[k])
            .expect("a pass from below");
        let a = accel[l - 1].min(accel[l]);
        assert!((env[l] - (4.0 + a * a / (2.0 * j))).abs() <= 1e-9);
        let mut r = l;
        while env[r + 1] < u[r + 1] {
            let a_r = if r == l { a } else { accel[r] };
            let w = (env[r] * env[r] + 2.0 * a_r * ds).sqrt();
            assert!((env[r + 1] - w).abs() <= 1e-9, "{r}: {} vs {w}", env[r + 1]);
            r += 1;
        }
        assert!(r > l + 2, "{l}..{r}");
        let time = |v: &[f64]| (0..n - 1).map(|k| interval_time_s(&s, v, k)).sum::<f64>();
        let (mut v, mut gaps) = (vec![0.0; n], Vec::new());
        assert!(shape(
            &lim,
            period / 3.0,
            Some(period),
            &mut v,
            Some(&mut gaps)
        ));
        let mut at_rest = vec![0.0; n];
        let rest_s = shape(&lim, period / 3.0, None, &mut at_rest, None).then(|| time(&at_rest));
        let followed_s = time(&v);
        println!("corner exit: followed {followed_s:.5} s, dips at rest {rest_s:?}");
        assert!(rest_s.is_none_or(|rest_s| followed_s < rest_s));
        for k in 0..n - 1 {
            assert!(v[k] <= u[k] * (1.0 + 1e-12));
            let a_k = interval_accel_mm_s2(&s, &v, k).abs();
            assert!(a_k <= accel[k] * (1.0 + 1e-9), "{k}: {a_k} vs {}", accel[k]);
        }
        assert!(gaps.iter().any(|g| g.accelerated_ends()));
        for g in &gaps {
            let span = g.time_at_s(s[g.k] - s[g.i]);
            let h = 1e-5;
            let steps = (span / h) as usize;
            for step in 1..steps {
                let t = step as f64 * h;
                let (x, v0) = g.state_s(t - h);
                let (_, v1) = g.state_s(t);
                let m = s.partition_point(|&y| y <= s[g.i] + x).clamp(1, n - 1) - 1;
                let a_t = ((v1 - v0) / h).abs();
                assert!(
                    a_t <= accel[m] * (1.0 + 1e-3) + j * h,
                    "gap {}..{}: {a_t} at {} mm over {}",
                    g.i,
                    g.k,
                    s[g.i] + x,
                    accel[m]
                );
            }
        }
    }

    /// Two dips 2 mm apart on a line (20 and 15 mm/s, no acceleration at either), the
    /// envelope 50 mm/s between them: the shape rises to the highest peak p whose two
    /// S-curve changes fit, ℓ(20 → p) + ℓ(p → 15) = 2 mm with ℓ(v0 → v1) =
    /// (v0 + v1)/2·τ(|v1 − v0|), τ(Δv) = 2√(Δv/J) (the acceleration is not reached); its
    /// station speeds are those of the two changes (closed form, by their time), and the
    /// stations' time, Σ 2Δs/(v_k + v_k+1), is within 0.1 % of the closed form's
    /// 2√((p − 20)/J) + 2√((p − 15)/J).
    #[test]
    fn two_close_dips_get_the_closed_form_rise_and_fall() {
        let (a, j, len) = (1000.0, 20000.0, 2.0);
        let n = 41;
        let s: Vec<f64> = (0..n).map(|k| len * k as f64 / (n - 1) as f64).collect();
        let mut u = vec![50.0; n];
        (u[0], u[n - 1]) = (20.0, 15.0);
        let accel = vec![a; n - 1];
        let jerk = vec![j; n - 1];
        let lim = Limits {
            s_mm: &s,
            envelope_mm_s: &u,
            accel_mm_s2: &accel,
            jerk_mm_s3: &jerk,
        };
        let mut v = vec![0.0; n];
        assert!(shape(&lim, 0.0, None, &mut v, None));
        // The closed form's peak: ℓ(20 → p) + ℓ(p → 15) = len, by bisection.
        let length = |p: f64| {
            (20.0 + p) / 2.0 * 2.0 * ((p - 20.0) / j).sqrt()
                + (15.0 + p) / 2.0 * 2.0 * ((p - 15.0) / j).sqrt()
        };
        let (mut lo, mut hi) = (20.0, 50.0);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if length(mid) <= len {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let peak = lo;
        assert!(peak * peak < 2.0 * a * a, "the acceleration stays under a");
        let top = v.iter().fold(0.0f64, |m, &x| m.max(x));
        assert!((top - peak).abs() <= 1e-3 * peak, "{top} vs {peak}");
        let closed_s = 2.0 * ((peak - 20.0) / j).sqrt() + 2.0 * ((peak - 15.0) / j).sqrt();
        let stations_s: f64 = (0..n - 1).map(|k| interval_time_s(&s, &v, k)).sum();
        assert!(
            (stations_s - closed_s).abs() <= 1e-3 * closed_s,
            "{stations_s} vs {closed_s}"
        );
        // Station by station, the speed of the changes at that distance (by time).
        let rise = Change::new(20.0, peak, a, j);
        let fall = Change::new(peak, 15.0, a, j);
        for (k, &x) in s.iter().enumerate() {
            let expected = if x <= rise.length_mm() {
                rise.at_distance(x).0
            } else {
                fall.at_distance(x - (len - fall.length_mm())).0
            };
            assert!(
                (v[k] - expected).abs() <= 1e-6 * expected,
                "{k}: {} vs {expected}",
                v[k]
            );
        }
    }
}
