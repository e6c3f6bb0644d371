//! Jerk-limited speed profiles shaped directly, without the filter (MODEL.md §6.1,
//! "Direct sections"): between the dips of the acceleration-limited envelope the speed
//! rises from one dip's speed (no acceleration) to a peak (no acceleration) and falls to
//! the next dip's, each change the time-optimal jerk-limited one (an S-curve of up to
//! three phases: jerk ±J, acceleration ±A, jerk ∓J).

/// A jerk-limited change of speed from `v0` to `v1` with no acceleration at either end:
/// jerk ±J for `tj`, acceleration ±A for `ta`, jerk ∓J for `tj`; A is reached where
/// |v1 − v0| ≥ A²/J, else the acceleration peaks at √(J·|v1 − v0|) (`ta` = 0).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Change {
    v0: f64,
    v1: f64,
    /// +1 rising, −1 falling.
    sign: f64,
    /// Jerk magnitude J, mm/s³.
    jerk: f64,
    /// Peak acceleration magnitude, mm/s².
    accel: f64,
    tj: f64,
    ta: f64,
}

impl Change {
    /// The time-optimal change from `v0` to `v1` (mm/s) under acceleration `a` and jerk `j`.
    pub(crate) fn new(v0: f64, v1: f64, a: f64, j: f64) -> Self {
        let dv = (v1 - v0).abs();
        let (tj, ta, accel) = if dv * j >= a * a {
            (a / j, dv / a - a / j, a)
        } else {
            let tj = (dv / j).sqrt();
            (tj, 0.0, j * tj)
        };
        Change {
            v0,
            v1,
            sign: if v1 >= v0 { 1.0 } else { -1.0 },
            jerk: j,
            accel,
            tj,
            ta,
        }
    }

    /// Its duration, s: 2·tj + ta (Δv/A + A/J, or 2√(Δv/J)).
    pub(crate) fn duration_s(&self) -> f64 {
        2.0 * self.tj + self.ta
    }

    /// Its length, mm: the speed is point-symmetric about the middle, so it averages
    /// (v0 + v1)/2.
    pub(crate) fn length_mm(&self) -> f64 {
        0.5 * (self.v0 + self.v1) * self.duration_s()
    }

    /// Distance, speed and acceleration `t_s` into the change (clamped to it).
    pub(crate) fn state(&self, t_s: f64) -> (f64, f64, f64) {
        let (sg, j, tj) = (self.sign, self.jerk, self.tj);
        let total = self.duration_s();
        let t = t_s.clamp(0.0, total);
        if t <= tj {
            return (
                self.v0 * t + sg * j * t * t * t / 6.0,
                self.v0 + sg * j * t * t / 2.0,
                sg * j * t,
            );
        }
        if t <= tj + self.ta {
            let h = t - tj;
            let v_tj = self.v0 + sg * j * tj * tj / 2.0;
            let x_tj = self.v0 * tj + sg * j * tj * tj * tj / 6.0;
            return (
                x_tj + v_tj * h + sg * self.accel * h * h / 2.0,
                v_tj + sg * self.accel * h,
                sg * self.accel,
            );
        }
        let r = total - t;
        (
            self.length_mm() - (self.v1 * r - sg * j * r * r * r / 6.0),
            self.v1 - sg * j * r * r / 2.0,
            sg * j * r,
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
    /// gap's largest limit down, a few rounds) and the gap's least jerk limit.
    fn new(lim: &Limits, (i, k): (usize, usize), d: (f64, f64), peak: f64) -> Option<Self> {
        let accel = &lim.accel_mm_s2[i..k];
        let j = lim.jerk_mm_s3[i..k]
            .iter()
            .fold(f64::INFINITY, |m, &x| m.min(x));
        let s = &lim.s_mm[i..=k];
        let len = s[s.len() - 1] - s[0];
        // The change from v0 to v1 over the first (`forward`) or last intervals.
        let change = |v0: f64, v1: f64, forward: bool| {
            let mut a = accel.iter().fold(0.0f64, |m, &x| m.max(x));
            let mut c = Change::new(v0, v1, a, j);
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
                if least >= a {
                    break;
                }
                a = least;
                c = Change::new(v0, v1, a, j);
            }
            c
        };
        let first = change(d.0, peak, true);
        let second = change(peak, d.1, false);
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
    /// jerk by the check of the samples).
    fn fits(&self, lim: &Limits) -> bool {
        (self.i + 1..self.k).all(|m| {
            let (v, _) = self.at(lim, m);
            v <= lim.envelope_mm_s[m] * (1.0 + 1e-12)
        })
    }
}

/// Whether the gap `(i, k)` has a motion from `d.0` to `d.1` through the peak `peak`.
fn feasible(lim: &Limits, gap: (usize, usize), d: (f64, f64), peak: f64) -> bool {
    Gap::new(lim, gap, d, peak).is_some_and(|g| g.fits(lim))
}

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
}

/// Shapes a section (MODEL.md §6.1, "Direct sections"): `v` gets the speed at each
/// station of `lim`, from the envelope's first speed to its last. The dips are the envelope's strict
/// local minima (a flat bottom whole) and the run's ends, each widened over the intervals
/// beside it whose acceleration limit is at most `slow_share` times their jerk limit
/// (the slow corners' intervals: there the motion follows the envelope, whose
/// acceleration is then too small to matter for the jerk). Between two dips the motion
/// changes speed from the first dip's speed (no acceleration) to a peak (no
/// acceleration) and on to the next dip's, each change the time-optimal jerk-limited one
/// ([`Change`]). Each dip's speed is lowered until the gaps on either side have such a
/// motion under the envelope (the higher end of a gap lowered, sweeping forwards then
/// backwards); dips that were lowered and whose neighbours have a motion through them are
/// dropped; then each gap takes the highest peak it has a motion through (bisection).
/// Returns `false` (nothing usable) where a gap still has no motion or a speed inside
/// the run comes out as 0.
pub(crate) fn shape(
    lim: &Limits,
    slow_share: f64,
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
            dips.push(Dip {
                l: ll,
                r: ll,
                d: u[ll],
                edge: true,
            });
        }
        if dips.last().is_some_and(|d| d.r >= l) {
            dips.pop();
        }
        dips.push(Dip {
            l,
            r,
            d: u[l],
            edge: false,
        });
        if rr > r {
            dips.push(Dip {
                l: rr,
                r: rr,
                d: u[rr],
                edge: true,
            });
        }
    }
    let last_dip = dips.len() - 1;
    // Gap g: from dip g's last station to dip g+1's first, and its end speeds.
    let gap = |dips: &[Dip], g: usize| (dips[g].r, dips[g + 1].l);
    let ends = |dips: &[Dip], g: usize| {
        let (i, k) = gap(dips, g);
        (u[i].min(dips[g].d), u[k].min(dips[g + 1].d))
    };
    let ok = |dips: &[Dip], g: usize| {
        let (i, k) = gap(dips, g);
        let (a, b) = ends(dips, g);
        k <= i || feasible(lim, (i, k), (a, b), a.max(b))
    };
    // The higher end of gap g lowered until the gap has a motion through it (the run's
    // ends keep their speeds).
    let lower = |dips: &mut [Dip], g: usize| {
        let (i, k) = gap(dips, g);
        let (a, b) = ends(dips, g);
        if a > b && g > 0 {
            dips[g].d = highest(b, a, |x| feasible(lim, (i, k), (x, b), x));
        } else if a <= b && g + 1 < last_dip {
            dips[g + 1].d = highest(a, b, |x| feasible(lim, (i, k), (a, x), x));
        }
    };
    for _ in 0..4 {
        let mut changed = false;
        for g in 0..dips.len() - 1 {
            let (a, b) = ends(&dips, g);
            if b > a && !ok(&dips, g) {
                lower(&mut dips, g);
                changed = true;
            }
        }
        for g in (0..dips.len() - 1).rev() {
            let (a, b) = ends(&dips, g);
            if a >= b && !ok(&dips, g) {
                lower(&mut dips, g);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    // Lowered dips of one station the motion need not stop its acceleration at.
    let mut g = 1;
    while g + 1 < dips.len() {
        let dip = dips[g];
        let lowered = dip.l == dip.r && !dip.edge && dip.d < u[dip.l];
        let (i, k) = (dips[g - 1].r, dips[g + 1].l);
        let (a, b) = (u[i].min(dips[g - 1].d), u[k].min(dips[g + 1].d));
        if lowered && feasible(lim, (i, k), (a, b), a.max(b)) {
            dips.remove(g);
        } else {
            g += 1;
        }
    }
    if (0..dips.len() - 1).any(|g| !ok(&dips, g)) {
        return false;
    }
    for dip in &dips {
        for k in dip.l..=dip.r {
            v[k] = u[k].min(dip.d);
        }
    }
    for g in 0..dips.len() - 1 {
        let (i, k) = gap(&dips, g);
        if k <= i + 1 {
            continue;
        }
        let (a, b) = ends(&dips, g);
        let top = u[i..=k].iter().fold(0.0f64, |m, &x| m.max(x));
        let peak = highest(a.max(b), top, |p| feasible(lim, (i, k), (a, b), p));
        let motion = Gap::new(lim, (i, k), (a, b), peak).expect("a feasible peak");
        for (m, vm) in v.iter_mut().enumerate().take(k).skip(i + 1) {
            *vm = motion.at(lim, m).0.min(u[m]);
        }
        if let Some(gaps) = gaps.as_deref_mut() {
            gaps.push(motion);
        }
    }
    v[1..n - 1].iter().all(|&x| x > 0.0)
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
        assert!(shape(&lim, 0.0, &mut v, None));
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
        let stations_s: f64 = (0..n - 1)
            .map(|k| crate::plan::interval_time_s(&s, &v, k))
            .sum();
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
