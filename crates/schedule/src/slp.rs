//! A section's speeds shaped by sequential linear programs (MODEL.md §6.1, "Sections by
//! linear programs"): the motion of `scripts/jerk_optimum.py` between two held speeds,
//! followed exactly.
//!
//! Unknowns b_k = v_k² and the tangential acceleration a_k at each station, a linear in s
//! between stations, so b_k+1 − b_k = (a_k + a_k+1)·Δs_k; b_k ≤ cap_k²; |a_k| within the
//! limits of the intervals beside station k; b_k + a_k·Δs_k at most the larger cap² of the
//! interval (so that b stays under it between the stations); the ends at their speeds with
//! a = 0; and the
//! jerk a′(s)·v within the interval's limit J at both its stations,
//! |a_k+1 − a_k| ≤ J·Δs_k·b_j^(−1/2), j = k, k + 1, with b^(−1/2) replaced by its tangent at
//! the last iterate (it is convex, so the tangent lies below it and every solution keeps
//! the jerk). Each iterate minimises the first-order change of the time Σ 2Δs/(v_k + v_k+1)
//! in a trust region b ≤ (1 + ρ)·b_last. The motion is followed as the programs state it
//! ([`Piece`]): b quadratic in s over each interval, so the acceleration is continuous and
//! the jerk a′(s)·v is bounded at every instant, not only at the servo period.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

/// The section's stations and limits.
pub(crate) struct Limits<'a> {
    /// Arc length of each station, mm.
    pub(crate) s_mm: &'a [f64],
    /// Each station's cap, mm/s.
    pub(crate) caps_mm_s: &'a [f64],
    /// Each interval's tangential acceleration limit, mm/s².
    pub(crate) accel_mm_s2: &'a [f64],
    /// Each interval's tangential jerk limit as shaped (σ·j), mm/s³.
    pub(crate) jerk_mm_s3: &'a [f64],
}

/// Linear programs solved per section shaped (on 3D_Chips with a jerk limit, a third of
/// the sections took all of 8 without changing the plan's time by 10⁻⁶: MODEL.md §6.1,
/// "Sections by linear programs").
const ITERATIONS: usize = 4;
/// The programs stop once an iterate that keeps the limits changes the best time by at
/// most this share.
const CONVERGED: f64 = 1e-3;
/// Interior-point iterations per program (they take about 16 where it is feasible).
const MAX_SOLVER_ITERATIONS: u32 = 50;
/// The duality gap, relative and absolute, each program is solved to: ten times finer
/// than [`CONVERGED`], the share by which the programs' best time must still change for
/// another to be solved; each iterate is checked against the limits by its own motion
/// whatever the gap. At 10⁻⁶ the interior point's last iterations bought 3D_Chips' plan
/// with a jerk limit nothing (its cycle 170.9571 s at 10⁻⁶, 170.9335 s at 10⁻⁴) for a
/// quarter of its CPU (10.35 → 7.62 s; MODEL.md §6.1, "A coarser duality gap"). Test
/// `the_planners_duality_gap_costs_a_section_less_than_a_tenth_of_converged`.
const GAP_TOL: f64 = 1e-4;
/// Iterative refinement steps per linear solve of the interior point method (clarabel's
/// default is 10; the programs' equalities hold to about 10⁻⁸ with 2, and the refinement
/// took half of the planner's time).
const REFINEMENT_STEPS: u32 = 2;
/// The first trust region: b may rise to (1 + ρ) times the last iterate's.
const TRUST: f64 = 0.5;
/// The share of the jerk limits the first program's jerk rows take.
const JERK_FIRST: f64 = 1.0;
/// Where an iterate's motion breaks a jerk limit by a ratio r > 1 (its speed inside an
/// interval above both stations'), the next ones' jerk rows are scaled by this over r.
const JERK_STEP: f64 = 0.99;
/// The speeds, accelerations and jerks the programs may use, as shares of the limits: room for the
/// interior-point solution's residuals (its equalities hold to about 10⁻⁸).
const MARGIN: f64 = 1.0 - 1e-6;

/// Shapes the section `lim` from the speeds `v` (the first iterate, with the end speeds at
/// its first and last station, held with no acceleration over its first `held.0` and last
/// `held.1` stations): on return `v` and `accel` hold the quickest iterate's speeds and
/// accelerations at the stations, whose motion ([`Piece`]) keeps the caps, the
/// acceleration limits and the jerk limits at every instant ([`ratio`] at most 1).
/// Returns `false` (and `v`, `accel` unspecified) where no iterate does.
pub(crate) fn shape(lim: &Limits, held: (usize, usize), v: &mut [f64], accel: &mut [f64]) -> bool {
    shape_to_gap(lim, held, v, accel, GAP_TOL)
}

/// [`shape`] with each program solved to the duality gap `gap` (relative and absolute).
fn shape_to_gap(
    lim: &Limits,
    held: (usize, usize),
    v: &mut [f64],
    accel: &mut [f64],
    gap: f64,
) -> bool {
    let n = lim.s_mm.len();
    let m = n - 1;
    let s = lim.s_mm;
    let mut bb: Vec<f64> = v
        .iter()
        .zip(lim.caps_mm_s)
        .map(|(x, c)| (x * x).min(c * c))
        .collect();
    bb[0] = v[0] * v[0];
    bb[m] = v[m] * v[m];
    let a_lim: Vec<f64> = (0..n)
        .map(|k| {
            let before = if k > 0 {
                lim.accel_mm_s2[k - 1]
            } else {
                f64::INFINITY
            };
            let after = lim.accel_mm_s2.get(k).copied().unwrap_or(f64::INFINITY);
            MARGIN * before.min(after)
        })
        .collect();
    let Ok(settings) = DefaultSettingsBuilder::default()
        .verbose(false)
        .presolve_enable(false)
        .max_iter(MAX_SOLVER_ITERATIONS)
        .tol_gap_rel(gap)
        .tol_gap_abs(gap)
        .iterative_refinement_max_iter(REFINEMENT_STEPS)
        .build()
    else {
        return false;
    };
    let mut best: Option<(f64, Vec<f64>, Vec<f64>)> = None;
    let mut trust = TRUST;
    let mut jerk_scale = JERK_FIRST;
    let mut speeds = vec![0.0; n];
    for _ in 0..ITERATIONS {
        let root: Vec<f64> = bb.iter().map(|b| b.max(1e-12).sqrt()).collect();
        // The time's gradient in b, and the rows A·x + z = h, z in the cones (x = b, a).
        let mut q = vec![0.0; 2 * n];
        for k in 0..m {
            let sum = (root[k] + root[k + 1]).max(1e-9);
            let d = -(s[k + 1] - s[k]) / (sum * sum);
            q[k] += d / root[k];
            q[k + 1] += d / root[k + 1];
        }
        let mut rows = Rows::default();
        for k in 0..m {
            let ds = s[k + 1] - s[k];
            rows.push(
                &[(k + 1, 1.0), (k, -1.0), (n + k, -ds), (n + k + 1, -ds)],
                0.0,
            );
        }
        for k in (0..held.0).chain(n - held.1..n) {
            rows.push(&[(k, 1.0)], if k < held.0 { bb[0] } else { bb[m] });
            rows.push(&[(n + k, 1.0)], 0.0);
        }
        let zeros = rows.h.len();
        for k in held.0..n - held.1 {
            let cap = MARGIN * lim.caps_mm_s[k];
            let hi = (cap * cap).min(bb[k] * (1.0 + trust) + 1e-3);
            rows.push(&[(k, 1.0)], hi);
            rows.push(&[(k, -1.0)], 0.0);
            rows.push(&[(n + k, 1.0)], a_lim[k]);
            rows.push(&[(n + k, -1.0)], a_lim[k]);
        }
        for k in 0..m {
            // Inside the interval b is at most where the tangents at its ends meet (at
            // its middle, b_k + a_k·Δs), if it is concave, and at an end otherwise (no
            // margin beside a held station: b is the end speed's square there).
            let free = k >= held.0 && k + 1 < n - held.1;
            let cap = lim.caps_mm_s[k].max(lim.caps_mm_s[k + 1]) * if free { MARGIN } else { 1.0 };
            rows.push(&[(k, 1.0), (n + k, s[k + 1] - s[k])], cap * cap);
        }
        for k in 0..m {
            let jd = MARGIN * jerk_scale * lim.jerk_mm_s3[k] * (s[k + 1] - s[k]);
            for j in [k, k + 1] {
                let (b, r) = (bb[j], root[j]);
                if b <= 0.0 {
                    continue;
                }
                // ±(a_k+1 − a_k) ≤ J·Δs·(1.5/√b_j⁰ − b_j/(2·b_j⁰^1.5))
                let (c0, c1) = (jd * 1.5 / r, jd / (2.0 * b * r));
                rows.push(&[(n + k + 1, 1.0), (n + k, -1.0), (j, c1)], c0);
                rows.push(&[(n + k + 1, -1.0), (n + k, 1.0), (j, c1)], c0);
            }
        }
        let count = rows.h.len();
        let a = CscMatrix::new_from_triplets(count, 2 * n, rows.i, rows.j, rows.x);
        let p = CscMatrix::zeros((2 * n, 2 * n));
        let cones = [
            SupportedConeT::ZeroConeT(zeros),
            SupportedConeT::NonnegativeConeT(count - zeros),
        ];
        let Ok(mut solver) = DefaultSolver::new(&p, &q, &a, &rows.h, &cones, settings.clone())
        else {
            return false;
        };
        solver.solve();
        if !matches!(solver.solution.status, SolverStatus::Solved) {
            // Infeasible at this tangent: the next program would be as well.
            break;
        }
        let x = &solver.solution.x;
        let b_new: Vec<f64> = x[..n].iter().map(|b| b.max(0.0)).collect();
        for (k, speed) in speeds.iter_mut().enumerate() {
            *speed = b_new[k].sqrt().min(lim.caps_mm_s[k]);
        }
        speeds[..held.0].fill(v[0]);
        speeds[n - held.1..].fill(v[m]);
        let mut accels = x[n..].to_vec();
        accels[..held.0].fill(0.0);
        accels[n - held.1..].fill(0.0);
        let ratio = ratio(lim, &speeds, &accels);
        if ratio <= 1.0 {
            let t: f64 = (0..m)
                .map(|k| Piece::of(s, &speeds, &accels, k).duration_s())
                .sum();
            let previous = best.as_ref().map_or(f64::INFINITY, |x| x.0);
            if t < previous {
                best = Some((t, speeds.clone(), accels));
            } else {
                trust *= 0.8;
            }
            if (previous - t).abs() <= CONVERGED * t {
                break;
            }
        } else if ratio.is_finite() {
            // The jerk rows hold at the stations; inside an interval the speed may rise
            // above both: tighten the rows by what the motion's check found.
            jerk_scale *= JERK_STEP / ratio;
        }
        bb = b_new;
        bb[0] = v[0] * v[0];
        bb[m] = v[m] * v[m];
    }
    match best {
        Some((_, speeds, accels)) => {
            v.copy_from_slice(&speeds);
            accel.copy_from_slice(&accels);
            true
        }
        None => false,
    }
}

/// A sparse matrix's rows and their right-hand sides, built row by row.
#[derive(Default)]
struct Rows {
    i: Vec<usize>,
    j: Vec<usize>,
    x: Vec<f64>,
    h: Vec<f64>,
}

impl Rows {
    fn push(&mut self, entries: &[(usize, f64)], rhs: f64) {
        let row = self.h.len();
        for &(j, x) in entries {
            self.i.push(row);
            self.j.push(j);
            self.x.push(x);
        }
        self.h.push(rhs);
    }
}

/// The largest ratio, over the motion of the stations' speeds `v` and accelerations `a`
/// ([`Piece`]), of each interval's jerk |a′(s)|·v (its highest speed) to its limit;
/// infinite where a station's acceleration breaks the limit of an interval beside it
/// (1 + 10⁻⁹), or an interval's speed rises over the larger cap of its stations or comes
/// to rest. At most 1: the motion keeps the limits at every instant.
pub(crate) fn ratio(lim: &Limits, v: &[f64], a: &[f64]) -> f64 {
    let s = lim.s_mm;
    let mut worst: f64 = 0.0;
    for k in 0..s.len() - 1 {
        let limit = lim.accel_mm_s2[k] * (1.0 + 1e-9);
        let piece = Piece::of(s, v, a, k);
        let cap = lim.caps_mm_s[k].max(lim.caps_mm_s[k + 1]);
        let (low, high) = piece.speed_range();
        if a[k].abs() > limit || a[k + 1].abs() > limit || high > cap * (1.0 + 1e-9) || low <= 0.0 {
            return f64::INFINITY;
        }
        worst = worst.max(piece.jerk_mm_s3() / lim.jerk_mm_s3[k]);
    }
    worst
}

/// The motion over one station interval as the programs state it: b = v² quadratic in the
/// distance x from the first station, b(0) = v₀², b(Δs) = v₁², b″ = 2q with
/// q = (a₁ − a₀)/Δs, so the acceleration b′/2 runs linearly from a₀ to a₁ (exactly where
/// b₁ − b₀ = (a₀ + a₁)·Δs, as the programs' equalities hold) and the jerk is q·v.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Piece {
    b0: f64,
    /// b(x) = b0 + slope·x + q·x².
    slope: f64,
    q: f64,
    ds: f64,
}

/// Gauss–Legendre nodes on [0, 1] and weights (8 points).
const GAUSS: [(f64, f64); 8] = [
    (0.019_855_071_751_231_856, 0.050_614_268_145_188_13),
    (0.101_666_761_293_186_63, 0.111_190_517_226_687_24),
    (0.237_233_795_041_835_5, 0.156_853_322_938_943_64),
    (0.408_282_678_752_175_1, 0.181_341_891_689_181),
    (0.591_717_321_247_825, 0.181_341_891_689_181),
    (0.762_766_204_958_164_5, 0.156_853_322_938_943_64),
    (0.898_333_238_706_813_4, 0.111_190_517_226_687_24),
    (0.980_144_928_248_768_1, 0.050_614_268_145_188_13),
];

impl Piece {
    /// Interval `k` of the stations `s` with speeds `v` and accelerations `a`.
    pub(crate) fn of(s: &[f64], v: &[f64], a: &[f64], k: usize) -> Self {
        let ds = s[k + 1] - s[k];
        let (b0, b1) = (v[k] * v[k], v[k + 1] * v[k + 1]);
        let q = (a[k + 1] - a[k]) / ds;
        Self {
            b0,
            slope: (b1 - b0) / ds - q * ds,
            q,
            ds,
        }
    }

    fn b(&self, x: f64) -> f64 {
        self.b0 + x * (self.slope + self.q * x)
    }

    /// The lowest and highest speed over the interval, mm/s.
    fn speed_range(&self) -> (f64, f64) {
        let (b0, b1) = (self.b(0.0), self.b(self.ds));
        let (mut lo, mut hi) = (b0.min(b1), b0.max(b1));
        if self.q != 0.0 {
            let vertex = -self.slope / (2.0 * self.q);
            if vertex > 0.0 && vertex < self.ds {
                lo = lo.min(self.b(vertex));
                hi = hi.max(self.b(vertex));
            }
        }
        (lo.max(0.0).sqrt(), hi.max(0.0).sqrt())
    }

    /// The largest jerk over the interval, |q|·v_max, mm/s³.
    fn jerk_mm_s3(&self) -> f64 {
        self.q.abs() * self.speed_range().1
    }

    /// Time over the whole interval, s.
    pub(crate) fn duration_s(&self) -> f64 {
        self.time_at_s(self.ds)
    }

    /// Time from the first station to `x_mm` past it, s: ∫ dx/√b (8-point Gauss–Legendre;
    /// b stays away from 0, [`ratio`]).
    pub(crate) fn time_at_s(&self, x_mm: f64) -> f64 {
        let x = x_mm.clamp(0.0, self.ds);
        x * GAUSS
            .iter()
            .map(|&(u, w)| w / self.b(u * x).sqrt())
            .sum::<f64>()
    }

    /// Distance from the first station, mm, and speed, mm/s, `t_s` after the motion leaves
    /// it (clamped to the interval): the inverse of [`Piece::time_at_s`] by Newton's method,
    /// kept in a bracket.
    pub(crate) fn state_s(&self, t_s: f64) -> (f64, f64) {
        let end_s = self.duration_s();
        if t_s <= 0.0 {
            return (0.0, self.b(0.0).sqrt());
        }
        if t_s >= end_s {
            return (self.ds, self.b(self.ds).sqrt());
        }
        let (mut lo, mut hi) = (0.0, self.ds);
        let mut x = self.ds * t_s / end_s;
        for _ in 0..60 {
            let f = self.time_at_s(x) - t_s;
            let step = f * self.b(x).sqrt();
            if step.abs() <= 1e-13 * self.ds {
                break;
            }
            if f > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            let next = x - step;
            x = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        (x, self.b(x).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A section along a line between two stations at the speed `end_mm_s`: `len_mm` in
    /// stations `ds_mm` apart, the cap `cap_mm_s`, acceleration and (shaped) jerk limits,
    /// the ends held over two stations.
    struct Section {
        s: Vec<f64>,
        caps: Vec<f64>,
        accel: Vec<f64>,
        jerk: Vec<f64>,
        end_mm_s: f64,
    }

    impl Section {
        fn new(len_mm: f64, ds_mm: f64, [end_mm_s, cap_mm_s, a, j]: [f64; 4]) -> Section {
            let n = (len_mm / ds_mm).round() as usize;
            let s: Vec<f64> = (0..=n).map(|k| len_mm * k as f64 / n as f64).collect();
            Section {
                caps: vec![cap_mm_s; n + 1],
                accel: vec![a; n],
                jerk: vec![j; n],
                s,
                end_mm_s,
            }
        }

        fn limits(&self) -> Limits<'_> {
            Limits {
                s_mm: &self.s,
                caps_mm_s: &self.caps,
                accel_mm_s2: &self.accel,
                jerk_mm_s3: &self.jerk,
            }
        }

        /// The shaped motion's time with its programs solved to the duality gap `gap`,
        /// s, and its limits' ratio ([`ratio`]), from a first iterate held at the end
        /// speed.
        fn time_s(&self, gap: f64) -> (f64, f64) {
            let n = self.s.len() - 1;
            // At half the acceleration limit up to the cap and down again.
            let (len, a, cap, w0) = (self.s[n], self.accel[0], self.caps[0], self.end_mm_s);
            let mut v: Vec<f64> = (self.s.iter())
                .map(|&x| cap.min((w0 * w0 + a * x.min(len - x)).sqrt()))
                .collect();
            let mut accel = vec![0.0; n + 1];
            let lim = self.limits();
            assert!(shape_to_gap(&lim, (2, 2), &mut v, &mut accel, gap));
            let t = (0..n)
                .map(|k| Piece::of(&self.s, &v, &accel, k).duration_s())
                .sum();
            (t, ratio(&lim, &v, &accel))
        }
    }

    /// The planner's duality gap (`GAP_TOL`) costs a section's shaped time no more than
    /// a tenth of `CONVERGED` against the same programs solved to 10⁻⁹ (MODEL.md §6.1,
    /// "A coarser duality gap"), on sections that reach their cap and on one too short
    /// to, and the motion keeps its limits; both lie above the time of the jerk-limited
    /// S-curve between the end speeds that the limits allow. Measured: 1.3·10⁻⁶,
    /// 9.4·10⁻⁶ and 1.9·10⁻⁵ of the time at 10⁻⁴; at a gap of 10⁻³ the 12 mm section's
    /// is 4.6·10⁻⁴, and the test fails.
    #[test]
    fn the_planners_duality_gap_costs_a_section_less_than_a_tenth_of_converged() {
        for (len_mm, limits) in [
            (30.0, [10.0, 40.0, 500.0, 5_000.0]),
            (12.0, [5.0, 50.0, 800.0, 20_000.0]),
            (2.0, [10.0, 50.0, 500.0, 5_000.0]),
        ] {
            let section = Section::new(len_mm, 0.25, limits);
            let (coarse, coarse_ratio) = section.time_s(GAP_TOL);
            let (fine, fine_ratio) = section.time_s(1e-9);
            assert!(coarse_ratio <= 1.0 && fine_ratio <= 1.0);
            let bound = s_curve_time_s(len_mm, limits);
            // From rest, the S-curve is the planner's own closed form.
            let [_, v, a, j] = limits;
            let from_rest = s_curve_time_s(len_mm, [0.0, v, a, j]);
            let closed = crate::rest_to_rest_time_s(len_mm, v, a, j);
            assert!(
                (from_rest - closed).abs() <= 1e-9 * closed,
                "{from_rest} {closed}"
            );
            assert!(
                (coarse - fine).abs() <= 0.1 * CONVERGED * fine,
                "{len_mm} mm: {coarse} s at the planner's gap, {fine} s at 1e-9"
            );
            assert!(
                bound <= fine.min(coarse),
                "{len_mm} mm: {fine} s, the S-curve's {bound} s"
            );
        }
    }

    /// The least time over `len` from the speed `w0` back to it under the cap `v`, the
    /// acceleration `a` and the jerk `j` (an S-curve up to a peak speed and its mirror),
    /// by bisection on the peak speed: `rest_to_rest_time_s` where `w0` is 0 (checked in
    /// the test), which starts from rest only, as no section here can.
    fn s_curve_time_s(len: f64, [w0, v, a, j]: [f64; 4]) -> f64 {
        // Time and distance from w0 up to w at the limits (the mean speed of an
        // S-curve between two speeds is theirs).
        let ramp = |w: f64| {
            let dv = w - w0;
            let t = if dv * j >= a * a {
                dv / a + a / j
            } else {
                2.0 * (dv / j).sqrt()
            };
            (0.5 * (w0 + w) * t, t)
        };
        let (d, t) = ramp(v);
        if 2.0 * d <= len {
            return 2.0 * t + (len - 2.0 * d) / v;
        }
        let (mut lo, mut hi) = (w0, v);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if 2.0 * ramp(mid).0 <= len {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        2.0 * ramp(lo).1 + (len - 2.0 * ramp(lo).0) / lo
    }
}
