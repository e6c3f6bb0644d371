//! The simulate engine's unit tests.

use super::closed_loop::search::{Bracketed, Fraction, Relaxed};
use super::closed_loop::{
    loop_direction, residual_terms, sub_cell_windows, window_residual, WindowSums,
    LOOP_AT_POINT_SIDE_LOAD_UM, LOOP_NO_SIDE_LOAD_UM, LOOP_RELAX_START, LOOP_REL_TOL, LOOP_TOL_UM,
};
use super::error_map::{material_along_mm, Before};
use super::loads::breaking_step;
use super::metrics::Period;
use super::*;

/// A closed bracket whose lower bound the sweep measured is held there
/// (eq. 5.1c): the trials stay at the lower bound sweep after sweep, and
/// the bracket counts as closed though its upper bound grows old. Trying
/// the bound measured longer ago (the rule before eq. 5.1c) would go to
/// the upper bound at the first sweep.
#[test]
fn a_closed_bracket_measured_at_its_lower_bound_is_held_there() {
    let (lo, hi, from_um, x_um) = (0.5, 0.5 + 1e-7, 10.0, 5.0);
    let mut f = Fraction {
        phi: lo,
        lo,
        hi,
        w_lo: 3.0,
        w_hi: -3.0,
        lo_pass: 4,
        hi_pass: 5,
        replaced: 1,
        width_mark: 1e-7,
        since_halved: 0,
    };
    // A residual well out of tolerance, of the lower bound's sign.
    let r_um = 3.0;
    assert!(r_um > LOOP_TOL_UM + LOOP_REL_TOL * x_um);
    for pass in 6..12 {
        f.observe(r_um, from_um, pass);
        assert_eq!(f.next(r_um, x_um, from_um, pass), lo, "sweep {pass}");
        assert!(f.closed(from_um, pass), "sweep {pass}");
    }
    // An open bracket is not held: its next trial lies inside it.
    let mut wide = Fraction { hi: 0.9, ..f };
    wide.observe(r_um, from_um, 12);
    let next = wide.next(r_um, x_um, from_um, 12);
    assert!(next > lo && next < 0.9, "{next}");
}

/// The offset cap of the brackets' tests, µm: far beyond their roots.
const CAP_UM: f64 = 5000.0;

/// Two tools: an HSS one (σ_R 3000 MPa) at 4000 MPa, 1.33× its rupture
/// strength, and a carbide one (3500 MPa) at 4200 MPa, 1.2×. The warning's
/// value is the highest stress, 4200 MPa: the step it describes is the
/// carbide tool's, with its ratio 1.2 (it named the HSS tool's step, 1.3×
/// of 3000 MPa, beside 4200 MPa, a stress that tool never reached).
#[test]
fn the_breaking_step_named_is_the_one_of_the_highest_stress() {
    let load = |stress_mpa| StepLoad {
        stress_mpa,
        ..StepLoad::default()
    };
    let loads = [load(100.0), load(4000.0), load(4200.0), load(4200.0)];
    let ruptures = [3000.0, 3000.0, 3500.0, 3500.0];
    let rupture = |i: usize| ruptures[i];
    assert_eq!(breaking_step(&loads, rupture), Some((2, 1.2)));
    assert_eq!(breaking_step(&loads[..2], rupture), Some((1, 4.0 / 3.0)));
    assert_eq!(breaking_step(&loads[..1], rupture), None);
    assert_eq!(breaking_step(&[], rupture), None);
}

#[test]
fn loop_direction_drops_the_component_along_the_motion() {
    // Deflection (3, 4) on a move along +x: only +y is left.
    assert_eq!(loop_direction(3.0, 4.0, [2.0, 0.0]), [0.0, 1.0]);
    // Along a diagonal, (1, 0) keeps its part across it: (1, −1)/√2.
    let d = loop_direction(1.0, 0.0, [1.0, 1.0]);
    let r = std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        (d[0] - r).abs() < 1e-12 && (d[1] + r).abs() < 1e-12,
        "{d:?}"
    );
    // A plunge (no XY motion) keeps the whole deflection; nothing left: zero.
    assert_eq!(loop_direction(0.0, -2.0, [0.0, 0.0]), [0.0, -1.0]);
    assert_eq!(loop_direction(5.0, 0.0, [1.0, 0.0]), [0.0, 0.0]);
    // An even plunge's round-off (blendercam_Op_Cutout_Layers: 2e-15 µm)
    // has no direction; a nanometre and a half has one where the step
    // moves in XY.
    assert_eq!(loop_direction(1.2e-15, -1.5e-15, [0.0, 0.0]), [0.0, 0.0]);
    assert_eq!(
        loop_direction(0.0, LOOP_NO_SIDE_LOAD_UM, [1.0, 0.0]),
        [0.0, 0.0]
    );
    assert_eq!(loop_direction(0.0, 1.5e-3, [1.0, 0.0]), [0.0, 1.0]);
    // At one point (no XY motion, eq. 5.1d) up to the loop's tolerance
    // has none: fusion_led_floor_light_holes' plunges at 0.11…0.14 µm.
    assert_eq!(loop_direction(0.0, 0.135, [0.0, 0.0]), [0.0, 0.0]);
    assert_eq!(
        loop_direction(0.0, LOOP_AT_POINT_SIDE_LOAD_UM, [0.0, 0.0]),
        [0.0, 0.0]
    );
    assert_eq!(loop_direction(0.0, 0.6, [0.0, 0.0]), [0.0, 1.0]);
}

/// [`Run::for_each_period`] as it was before its own removal and time
/// were summed again from the steps (held in columns, `first` as usize).
fn periods_of_held_columns(run: &Run, mut f: impl FnMut(Period)) {
    let g = run.stock.grid().spacing_mm;
    let window_mm = SUB_CELL_WINDOW_CELLS * g;
    // Own values per period p: steps first[p]..first[p + 1], path
    // s_at[p]..s_at[p + 1].
    let mut first: Vec<usize> = Vec::new();
    let mut s_at: Vec<f64> = vec![0.0];
    let (mut volume, mut dt_s, mut cutting) = (Vec::new(), Vec::new(), Vec::new());
    for std::ops::Range { start: i, end: j } in crate::motion::periods(&run.steps) {
        let cuts = !run.steps[i..j].iter().all(|s| s.step.rapid);
        // A period that is part feed, part rapid counts its feed parts'
        // removal: what a rapid removes is a collision (rapid_cut warning).
        let (volume_mm3, period_dt_s) = (i..j).fold((0.0, 0.0), |(v, t), k| {
            let counted = !cuts || !run.steps[k].step.rapid;
            let dv = if counted {
                run.record.volume_mm3(k)
            } else {
                0.0
            };
            (v + dv, t + run.steps[k].dt_s)
        });
        first.push(i);
        s_at.push(run.steps[j - 1].s_end_mm);
        volume.push(volume_mm3);
        dt_s.push(period_dt_s);
        cutting.push(cuts);
    }
    first.push(run.steps.len());
    // Prefix sums of volume and time over periods.
    let n = volume.len();
    let (mut volume_sum, mut dt_sum) = (vec![0.0; n + 1], vec![0.0; n + 1]);
    for p in 0..n {
        volume_sum[p + 1] = volume_sum[p] + volume[p];
        dt_sum[p + 1] = dt_sum[p] + dt_s[p];
    }
    let advance: Vec<f64> = (0..n).map(|p| s_at[p + 1] - s_at[p]).collect();
    let mut windows = Vec::new();
    sub_cell_windows(
        |p| advance[p],
        &cutting,
        |p| cutting[p - 1],
        g,
        window_mm,
        |_, w| windows.push(w),
    );
    for (p, &(a, b)) in windows.iter().enumerate() {
        let own = Period {
            first_step: first[p],
            last_step: first[p + 1] - 1,
            s_from_mm: s_at[p],
            s_to_mm: s_at[p + 1],
            volume_mm3: volume[p],
            dt_s: dt_s[p],
            cutting: cutting[p],
            window: (p, p),
        };
        f(if !cutting[p] || advance[p] >= g {
            own
        } else {
            Period {
                s_from_mm: s_at[a],
                s_to_mm: s_at[b + 1],
                volume_mm3: volume_sum[b + 1] - volume_sum[a],
                dt_s: dt_sum[b + 1] - dt_sum[a],
                window: (a, b),
                ..own
            }
        });
    }
}

/// The periods made from their prefix sums, each one's own removal and
/// time summed again from its steps (`Run::for_each_period`), are those
/// of the columns held before, bit for bit: a G-code cut at a feed whose
/// periods advance less than a grid cell (windowed) and more, with
/// rapids between that split their periods.
#[test]
fn periods_summed_again_are_those_of_the_held_columns() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
            dir.path().join("p.nc"),
            "G0 X-8 Y0 Z5\nG1 Z-1 F300\nG1 X5 F40\nG1 X12 F900\nG0 Z5\nG0 X20\nG1 Z-0.5 F200\nG1 X30 Y3 F60\nG0 Z5\nM2\n",
        )
        .unwrap();
    let job = "[stock]\nkind = \"box\"\nmin = [0, -10, -3]\nmax = [40, 10, 0]\ngrid = 0.1\n\
             [tool]\nkind = \"ball\"\ndiameter = 6\n[program]\npath = \"p.nc\"\n[machine]\nfeed_max = 3000\n";
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let setup = crate::setup::Setup::load(&dir.path().join("job.toml"), None).unwrap();
    let steps = setup.machine_steps().unwrap();
    assert!(steps.iter().any(|s| s.continues), "no split period");
    let run = run_on(
        StockSource::Whole(setup.stock.clone()),
        &setup.tools,
        steps,
        "p",
    )
    .unwrap();
    let (mut now, mut held) = (Vec::new(), Vec::new());
    run.for_each_period(|p| now.push(p));
    periods_of_held_columns(&run, |p| held.push(p));
    assert_eq!(now.len(), held.len());
    assert!(
        now.iter().any(|p| p.window.0 < p.window.1),
        "no windowed period"
    );
    assert!(now
        .iter()
        .any(|p| p.volume_mm3 > 0.0 && p.window.0 == p.window.1));
    for (a, b) in now.iter().zip(&held) {
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(
            [a.s_from_mm, a.s_to_mm, a.volume_mm3, a.dt_s].map(f64::to_bits),
            [b.s_from_mm, b.s_to_mm, b.volume_mm3, b.dt_s].map(f64::to_bits)
        );
    }
}

/// A run keeps its tools' allowable stresses and rupture strengths by
/// tool number, not per step: each step's are its tool's entry's, bit
/// for bit (what the per-step columns held), for three tools of
/// different strengths (one breaking where it cuts, one overloaded);
/// the run's lowest allowable stress is the lowest of the tools it uses
/// (not of the table's, whose fourth tool it does not use).
#[test]
fn a_runs_strengths_are_each_steps_tools() {
    let dir = tempfile::tempdir().unwrap();
    let tool = |n: u32, d: f64, strengths: &str| {
        format!("[[tools]]\nnumber = {n}\nkind = \"flat\"\ndiameter = {d}\nflute_length = 12\nstickout = 30\n{strengths}\n")
    };
    let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n{}{}{}{}\
             [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\n[machine]\nfeed_max = 3000\n",
            tool(1, 6.0, "stress_limit_mpa = 700"),
            tool(2, 4.0, "stress_limit_mpa = 50\nrupture_strength_mpa = 70"),
            tool(3, 3.0, ""),
            tool(4, 2.0, "stress_limit_mpa = 1"),
        );
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    std::fs::write(
        dir.path().join("p.ngc"),
        "G21 G90 G17\nT1 M6 S9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z18 F1200\nG1 X30 Y20\nG0 Z25\n\
             T2 M6 S12000 M3\nG0 X50 Y8\nG1 Z18 F200\nG1 X12 Y10 F1000\nG0 Z25\n\
             T3 M6 S15000 M3\nG0 X20 Y15\nG1 Z19 F250\nG1 X35 F800\nG0 Z25\nM2\n",
    )
    .unwrap();
    let setup = crate::setup::Setup::load(&dir.path().join("job.toml"), None).unwrap();
    let tools = &setup.tools;
    let run = run_on(
        setup.stock_source(),
        tools,
        setup.machine_steps().unwrap(),
        "t",
    )
    .unwrap();
    assert_eq!(run.strengths_mpa.len(), 3);
    for (i, s) in run.steps.iter().enumerate() {
        let entry = &tools.entries[tools.index_of(s.tool).unwrap()];
        assert_eq!(
            [run.stress_limit_mpa_at(i), run.rupture_strength_mpa_at(i)].map(f64::to_bits),
            [entry.stress_limit_mpa, entry.rupture_strength_mpa].map(f64::to_bits),
            "step {i}"
        );
    }
    assert!((1..run.steps.len()).any(|i| run.steps[i].tool != run.steps[i - 1].tool));
    assert!(run.steps.iter().enumerate().any(|(i, _)| run.breaks(i)));
    let lowest = [1, 2, 3].map(|t| tools.entries[tools.index_of(t).unwrap()].stress_limit_mpa);
    assert_eq!(
        run.stress_limit_mpa(),
        lowest.into_iter().fold(f64::INFINITY, f64::min)
    );
    assert_eq!(run.stress_limit_mpa(), 50.0);
}

/// [`sub_cell_windows`] as it was before its windows were given one by
/// one: a list of them, with a list of each item's run end.
fn sub_cell_windows_listed(
    advance: impl Fn(usize) -> f64,
    member: &[bool],
    joins: impl Fn(usize) -> bool,
    cell_mm: f64,
    window_mm: f64,
) -> Vec<(usize, usize)> {
    let n = member.len();
    let mut adv = vec![0.0; n + 1];
    for p in 0..n {
        adv[p + 1] = adv[p] + advance(p);
    }
    // Last item of the run each item lies in.
    let mut run_ends = vec![0; n];
    for p in (0..n).rev() {
        run_ends[p] = if p + 1 < n && member[p + 1] && member[p] && joins(p + 1) {
            run_ends[p + 1]
        } else {
            p
        };
    }
    let mut out: Vec<(usize, usize)> = (0..n).map(|p| (p, p)).collect();
    let mut run_start = 0;
    for p in 0..n {
        if !member[p] {
            run_start = p + 1;
            continue;
        }
        if p > run_start && !joins(p) {
            run_start = p;
        }
        if advance(p) >= cell_mm {
            continue;
        }
        let run_end = run_ends[p];
        let window = |k: usize| (p.saturating_sub(k).max(run_start), (p + k).min(run_end));
        let covers = |k: usize| {
            let (a, b) = window(k);
            adv[b + 1] - adv[a] >= window_mm
        };
        // Smallest half-width that covers the window (or the whole run).
        let k_max = (p - run_start).max(run_end - p);
        let (mut lo, mut hi) = (0, k_max);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if covers(mid) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        out[p] = window(lo);
    }
    out
}

/// A small linear congruential generator from `seed`: the same draws, each
/// below its argument, every run.
fn lcg(seed: u64) -> impl FnMut(u64) -> u64 {
    let mut state = seed;
    move |m: u64| {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        (state >> 33) % m
    }
}

/// The windows given one by one, each run's end found by walking it, are
/// the list's, in item order: runs of every length that start at a
/// non-member or where an item does not join, items of a whole cell and
/// of none among them, runs shorter than the window.
#[test]
fn sub_cell_windows_given_in_order_are_the_lists() {
    let mut next = lcg(12_345);
    for n in [0, 1, 2, 7, 64, 1000] {
        let advance: Vec<f64> = (0..n)
            .map(|_| match next(4) {
                0 => 0.0,
                1 => 1.5,
                _ => next(100) as f64 / 100.0,
            })
            .collect();
        let member: Vec<bool> = (0..n).map(|_| next(8) != 0).collect();
        let joins: Vec<bool> = (0..n).map(|_| next(10) != 0).collect();
        let listed = sub_cell_windows_listed(|p| advance[p], &member, |p| joins[p], 1.0, 3.0);
        let mut given = Vec::new();
        sub_cell_windows(
            |p| advance[p],
            &member,
            |p| joins[p],
            1.0,
            3.0,
            |p, w| {
                assert_eq!(p, given.len(), "in item order");
                given.push(w);
            },
        );
        assert_eq!(given, listed, "{n} items");
        let searched = (0..n).filter(|&p| member[p] && advance[p] < 1.0);
        let starts: Vec<usize> = searched.map(|p| given[p].0).collect();
        assert!(
            starts.windows(2).all(|s| s[0] <= s[1]),
            "the windows of items under a cell start in order"
        );
        assert!(n < 64 || given.iter().enumerate().any(|(p, &w)| w != (p, p)));
    }
}

/// The closed loop's windowed residuals from `WindowSums` (one pass over
/// the steps, holding the running sums between the window last read and
/// the furthest end reached) are those of the whole prefix sums it
/// replaced, kept here as the oracle, bit for bit: sub-cell windows that
/// overlap (6 cells of path around steps of under a cell), steps the loop
/// does not weigh, runs cut short; and windows asked for out of order
/// sum again from the first step, to the same bits.
#[test]
fn window_sums_are_the_whole_prefix_sums_differences() {
    let mut next = lcg(4_242);
    let grid_mm = 0.1;
    for n in [1, 2, 40, 3000] {
        let advance_mm: Vec<f64> = (0..n)
            .map(|_| match next(6) {
                0 => 0.0,
                1 => 0.15,
                _ => (1 + next(99)) as f64 * 1e-3,
            })
            .collect();
        let in_loop: Vec<bool> = (0..n).map(|_| next(12) != 0).collect();
        let inherited: Vec<bool> = (0..n).map(|_| next(9) == 0).collect();
        let g: Vec<f64> = (0..n).map(|_| next(20_000) as f64 * 1e-3 - 4.0).collect();
        let x: Vec<f64> = (0..n).map(|_| next(15_000) as f64 * 1e-3).collect();
        let joins: Vec<bool> = (0..n).map(|_| next(50) != 0).collect();
        let mut windows = Vec::new();
        sub_cell_windows(
            |p| advance_mm[p],
            &in_loop,
            |p| joins[p],
            grid_mm,
            SUB_CELL_WINDOW_CELLS * grid_mm,
            |p, w| {
                if in_loop[p] && !inherited[p] && advance_mm[p] < grid_mm && w != (p, p) {
                    windows.push(w);
                }
            },
        );
        assert!(
            n < 3000 || windows.windows(2).filter(|w| w[1].0 <= w[0].1).count() > 1000,
            "windows that overlap"
        );
        // The oracle: the loop's prefix sums and residuals as prefix sums held whole.
        let mut sum_r = vec![0.0; n + 1];
        let mut sum_x = vec![0.0; n + 1];
        let mut sum_g = vec![0.0; n + 1];
        let mut sum_w = vec![0.0; n + 1];
        let mut path = vec![0.0; n + 1];
        for i in 0..n {
            let w = if in_loop[i] && !inherited[i] {
                advance_mm[i]
            } else {
                0.0
            };
            sum_r[i + 1] = sum_r[i] + w * (g[i] - x[i]);
            sum_x[i + 1] = sum_x[i] + w * x[i];
            sum_g[i + 1] = sum_g[i] + w * g[i];
            sum_w[i + 1] = sum_w[i] + w;
            path[i + 1] = path[i] + advance_mm[i];
        }
        let oracle = |(a, b): (usize, usize)| {
            let w = sum_w[b + 1] - sum_w[a];
            (w > 0.0).then(|| {
                let resolution =
                    ((sum_g[b + 1] - sum_g[a]) / w).abs() * grid_mm / (path[b + 1] - path[a]);
                let rw = (((sum_r[b + 1] - sum_r[a]) / w).abs() - resolution).max(0.0);
                let xw = ((sum_x[b + 1] - sum_x[a]) / w).abs();
                (rw, xw)
            })
        };
        let bits = |v: Option<(f64, f64)>| v.map(|(r, x)| (r.to_bits(), x.to_bits()));
        let term = |j: usize| {
            let w = if in_loop[j] && !inherited[j] {
                advance_mm[j]
            } else {
                0.0
            };
            residual_terms(w, g[j], x[j], advance_mm[j])
        };
        let mut sums = WindowSums::new(term);
        let mut furthest = 0;
        for &(a, b) in &windows {
            let got = window_residual(sums.over(a, b), grid_mm);
            assert_eq!(bits(got), bits(oracle((a, b))), "window {a}..={b} of {n}");
            furthest = furthest.max(b + 1);
            assert_eq!(sums.first, a, "nothing before the window held");
            assert_eq!(
                sums.held.len(),
                furthest + 1 - a,
                "nor past the furthest end"
            );
        }
        // Out of order: from the last window back.
        let mut sums = WindowSums::new(term);
        for &(a, b) in windows.iter().rev() {
            let got = window_residual(sums.over(a, b), grid_mm);
            assert_eq!(bits(got), bits(oracle((a, b))), "window {a}..={b} of {n}");
        }
    }
}

#[test]
fn sub_cell_windows_cover_the_path_within_their_run() {
    // Cell 1, window 3: a step of 0.5 takes the fewest steps centred on it
    // that cover 3 mm of path; a whole step keeps itself; a run ends
    // before an item that does not join (index 6) and at a non-member
    // (index 9).
    let advance = [0.5, 0.5, 0.5, 0.5, 2.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5];
    let member = [
        true, true, true, true, true, true, true, true, true, false, true,
    ];
    let mut w = Vec::new();
    sub_cell_windows(
        |p| advance[p],
        &member,
        |p| p != 6,
        1.0,
        3.0,
        |p, window| {
            assert_eq!(p, w.len(), "in item order");
            w.push(window)
        },
    );
    assert_eq!(w[0], (0, 4), "the run's start bounds the window");
    assert_eq!(w[2], (0, 4), "(1, 3) covers 1.5 mm");
    assert_eq!(w[3], (2, 4));
    assert_eq!(w[4], (4, 4), "a step of a whole cell is its own window");
    assert_eq!(w[5], (3, 5), "index 6 starts a new run");
    assert_eq!(w[6], (6, 8));
    assert_eq!(
        w[7],
        (6, 8),
        "the run 6..=8 is shorter than the window: all of it"
    );
    assert_eq!(w[9], (9, 9), "not a member");
    assert_eq!(w[10], (10, 10), "a run of one");
}

/// A step's search of the closed loop, one a step: 80 B.
#[test]
fn a_steps_search_takes_80_bytes() {
    assert_eq!(std::mem::size_of::<Bracketed>(), 80);
}

#[test]
fn relaxed_update_halves_on_overshoot() {
    let mut r = Relaxed::START;
    // g above x: move towards it by ω = 0.4 · 1.3.
    let x1 = r.next(0.0, 100.0);
    assert!((x1 - 52.0).abs() < 1e-12, "{x1}");
    // Overshoot (g below x): ω halves to 0.26.
    let x2 = r.next(x1, 40.0);
    assert!((x2 - (52.0 - 0.26 * 12.0)).abs() < 1e-12, "{x2}");
}

/// The first update of a step whose g falls gently is the secant's root,
/// exact for a linear g (g = 100 − 0.1 x: root 100/1.1), where the
/// relaxed update moves 0.52 of the residual; not where the loop does
/// not allow it, nor where g falls faster (g = 100 − 0.3 x: the relaxed
/// update, since g may be far from linear there).
#[test]
fn the_first_update_is_the_secants_root_where_g_is_nearly_flat() {
    let first = |g: &dyn Fn(f64) -> f64, secant: bool| {
        let mut s = Bracketed::new(g(0.0), CAP_UM);
        let x = LOOP_RELAX_START * g(0.0);
        s.observe(x, g(x) - x, 2, CAP_UM);
        (x, s.next(x, g(x), secant))
    };
    let gentle = |x: f64| 100.0 - 0.1 * x;
    let (x, p) = first(&gentle, true);
    assert!((p - 100.0 / 1.1).abs() < 1e-9, "{p}");
    let relaxed = |x: f64, g: f64| {
        let mut r = Relaxed::START;
        r.next(x, g)
    };
    let (_, p) = first(&gentle, false);
    assert!((p - relaxed(x, gentle(x))).abs() < 1e-9, "{p}");
    let steep = |x: f64| 100.0 - 0.3 * x;
    let (x, p) = first(&steep, true);
    assert!((p - relaxed(x, steep(x))).abs() < 1e-9, "{p}");
    // A rising g (the neighbours moved it) is taken as flat: x ← g.
    let rising = |x: f64| 100.0 + 0.1 * x;
    let (x, p) = first(&rising, true);
    assert!((p - rising(x)).abs() < 1e-9, "{p}");
}

/// The bracketed search on g(x) = c (a − x)⁺/k alone (no other steps):
/// root c a/(k + c). For c/k = 25 plain iteration x ← g(x) jumps between
/// 0 and 5 000 µm; the search converges within the loop's tolerance in
/// under 16 sweeps, for c/k from 0.01 to 25 (c/k = 100 takes more: the
/// relaxed trials creep down the side where g = 0), and at a jump of g (a
/// staircase of 10 µm steps) its bracket closes around the jump.
#[test]
fn bracketed_search_converges_where_plain_iteration_diverges() {
    let a = 200.0;
    for ratio in [0.01, 1.0, 4.9, 25.0] {
        let g = |x: f64| ratio * (a - x).max(0.0);
        let root = ratio * a / (1.0 + ratio);
        let mut s = Bracketed::new(g(0.0), CAP_UM);
        let mut x = (LOOP_RELAX_START * g(0.0)).min(CAP_UM);
        let mut passes = 1;
        loop {
            passes += 1;
            s.observe(x, g(x) - x, passes, CAP_UM);
            // The loop's test: within tolerance, or bracketed as closely.
            if (g(x) - x).abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() || s.closed(passes) {
                break;
            }
            assert!(
                passes < 16,
                "c/k {ratio}: x {x} after {passes} sweeps, root {root}"
            );
            x = s.next(x, g(x), true).clamp(-CAP_UM, CAP_UM);
        }
        assert!(
            (x - root).abs() <= 1.0 + 0.03 * root,
            "c/k {ratio}: {x} vs {root}"
        );
    }
    // Staircase: g = 4.9 · (a − 10 ⌈x/10⌉): 196 up to x = 160, 147 beyond,
    // so the root is the jump at x = 160.
    let g = |x: f64| 4.9 * (a - 10.0 * (x / 10.0).ceil()).max(0.0);
    let mut s = Bracketed::new(g(0.0), CAP_UM);
    let mut x = LOOP_RELAX_START * g(0.0);
    let mut passes = 1;
    loop {
        passes += 1;
        s.observe(x, g(x) - x, passes, CAP_UM);
        if s.closed(passes) {
            break;
        }
        assert!(passes < 16, "staircase: x {x} after {passes} sweeps");
        x = s.next(x, g(x), true);
    }
    assert!(
        (s.lo.at - 160.0).abs() < 4.0 && s.lo.at <= 160.0 && s.hi.at >= 160.0,
        "{s:?}"
    );
}

/// The stock outside a point along a direction, on a box held and on its
/// closed form: vertical, across a wall and diagonal, each against its
/// exact length.
#[test]
fn material_along_a_direction_matches_the_box() {
    let solid = dexel::Solid::Box {
        min: [0.0, 0.0, 0.0],
        max: [10.0, 10.0, 5.0],
    };
    let stock = solid.stock_in_rows(0.1, None, None).unwrap();
    for before in [Before::Stock(&stock), Before::Solid(&solid, stock.grid())] {
        // Up from z = 2 at a column centre: 3 mm to the top.
        let up = material_along_mm(before, [5.05, 5.05, 2.0], [0.0, 0.0, 1.0], 10.0);
        assert!((up - 3.0).abs() < 1e-5, "{up}");
        // Along +y from y = 9.85 to the face at 10: 0.15 mm.
        let side = material_along_mm(before, [5.05, 9.85, 2.0], [0.0, 1.0, 0.0], 10.0);
        assert!((side - 0.15).abs() < 1e-5, "{side}");
        // Diagonal in x–z from 1 mm below the top: √2 mm.
        let r = std::f64::consts::FRAC_1_SQRT_2;
        let diag = material_along_mm(before, [5.05, 5.05, 4.0], [r, 0.0, r], 10.0);
        assert!((diag - 2f64.sqrt()).abs() < 1e-5, "{diag}");
        // Capped at max_mm, and zero from a point in the air.
        assert_eq!(
            material_along_mm(before, [5.05, 5.05, 2.0], [0.0, 0.0, 1.0], 0.5),
            0.5
        );
        assert_eq!(
            material_along_mm(before, [5.05, 5.05, 6.0], [0.0, 0.0, 1.0], 1.0),
            0.0
        );
    }
}

/// A box or a cylinder made again from its closed form for each pass
/// (one stock held, `StockSource::Made`) gives the run of the stock held
/// and copied for each pass (`StockSource::Whole`) bit for bit: record,
/// loads, offsets, error map (clamped to the initial stock through the
/// closed form) and final stock, over a closed loop of several passes.
#[test]
fn a_stock_made_of_its_closed_form_runs_as_the_stock_held() {
    let dir = tempfile::tempdir().unwrap();
    // A Ø6 ball on a long stickout cutting 2 mm deep along a wall 1 mm
    // inside the stock's edge, then across it.
    std::fs::write(
        dir.path().join("part.nc"),
        "G21 G90\nG0 X-5 Y4 Z25\nG0 Z18\nG1 X45 F1200\nG1 Y16\nG1 X-5\nG0 Z25\nM2\n",
    )
    .unwrap();
    for stock in [
        "kind = \"box\"\nmin = [0, 2, 0]\nmax = [40, 30, 20]\ngrid = 0.2",
        "kind = \"cylinder\"\ncenter = [20, 15]\nradius = 13\nz_min = 0\nz_max = 20\ngrid = 0.2",
    ] {
        let job = format!(
            "[stock]\n{stock}\n[tool]\nkind = \"ball\"\ndiameter = 6\nstickout = 60\n\
                 [program]\npath = \"part.nc\"\n[cutting]\nmaterial = \"al6061\"\n\
                 [machine]\nfeed_max = 3000\nrapid = 10000\naccel = [1000, 1000, 1000]\n"
        );
        let path = dir.path().join("job.toml");
        std::fs::write(&path, job).unwrap();
        let setup = crate::setup::Setup::load(&path, None).unwrap();
        let solid = crate::input::stock::solid(&setup.job.stock).unwrap();
        let steps = setup.machine_steps().unwrap();
        let held = run_on(
            StockSource::Whole(setup.stock.clone()),
            &setup.tools,
            steps.clone(),
            "held",
        )
        .unwrap();
        let made = run_on(
            StockSource::Made(setup.stock.clone(), solid),
            &setup.tools,
            steps.clone(),
            "made",
        )
        .unwrap();
        assert!(
            held.closed_loop.passes > 2,
            "{stock}: {} passes",
            held.closed_loop.passes
        );
        assert!(
            held.final_volume_mm3 < held.initial_volume_mm3 - 100.0,
            "{stock}"
        );
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert!(
            held.error_map_um()
                .iter()
                .any(|e| e.is_finite() && *e != 0.0),
            "{stock}"
        );
        assert_eq!(
            bits(&held.error_map_um()),
            bits(&made.error_map_um()),
            "{stock}"
        );
        // The map's range: the held map's, and the made one's found block by
        // block (the summary first) or as the columns are written.
        let range_bits = |r: [f64; 2]| r.map(f64::to_bits);
        let held_range = held.error_range_um();
        assert!(held_range[0] < 0.0 || held_range[1] > 0.0, "{stock}");
        assert_eq!(
            range_bits(held_range),
            range_bits(made.error_range_um()),
            "{stock}"
        );
        let written = run_on(
            StockSource::Made(setup.stock.clone(), solid),
            &setup.tools,
            steps.clone(),
            "made, written",
        )
        .unwrap();
        assert!(written.error_range_um.get().is_none(), "{stock}");
        written
            .write_columns(dir.path(), None, None, false)
            .unwrap();
        assert_eq!(
            written.error_range_um.get().map(|&r| range_bits(r)),
            Some(range_bits(held_range)),
            "{stock}"
        );
        assert_eq!(held.closed_loop.passes, made.closed_loop.passes);
        assert_eq!(held.offsets_um, made.offsets_um);
        assert_eq!(held.model_um, made.model_um);
        assert_eq!(
            held.initial_volume_mm3.to_bits(),
            made.initial_volume_mm3.to_bits()
        );
        assert_eq!(
            held.final_volume_mm3.to_bits(),
            made.final_volume_mm3.to_bits()
        );
        assert!(held.stock.columns().eq(made.stock.columns()), "{stock}");
        assert_eq!(held.stock.last_cut(), made.stock.last_cut(), "{stock}");
        for i in 0..held.steps.len() {
            assert_eq!(
                held.record.volume_mm3(i).to_bits(),
                made.record.volume_mm3(i).to_bits()
            );
            assert_eq!(
                held.record.band_volumes_mm3(i),
                made.record.band_volumes_mm3(i)
            );
            assert_eq!(
                held.loads[i].deflection_um.to_bits(),
                made.loads[i].deflection_um.to_bits()
            );
        }
    }
}

/// The closed-form wall of the closed-loop tests: a Ø10 flat end mill on
/// a 0.1 N/µm holder, S4's linear law (100 N per mm³ a tooth), a box
/// from y = −`depth_mm` to −4.8 mm at grid 0.01, the points `csv` at
/// F1200.
fn wall_setup(dir: &std::path::Path, csv: &str, depth_mm: f64) -> crate::setup::Setup {
    std::fs::write(dir.join("wall.csv"), csv).unwrap();
    let job = format!(
        "[stock]\nkind = \"box\"\nmin = [0, -{depth_mm}, 0]\nmax = [30, -4.8, 30]\ngrid = 0.01\n\
             [tool]\nkind = \"flat\"\ndiameter = 10\nflute_length = 20\nstickout = 40\n\
             holder_stiffness_n_per_um = 0.1\n[program]\npath = \"wall.csv\"\nfeed = 1200\n\
             [cutting]\nband_height = 1.0\nspindle_rpm = 6000\nmodel = \"power_law\"\n\
             force_a = 100\nforce_n = 1\n"
    );
    let path = dir.join("job.toml");
    std::fs::write(&path, job).unwrap();
    crate::setup::Setup::load(&path, None).unwrap()
}

/// The closed loop's passes keep each step's deflection across its path
/// made as each load is (`deflections_as`), not the loads: they are those of
/// every load held and the windowed ones written over it (the loads
/// `loads` gave before), bit for bit, on a cut in 4 µm steps on a
/// 10 µm grid, whose loads are those of their windows (MODEL.md §1.6).
#[test]
fn deflections_made_as_the_loads_are_those_of_the_loads_held() {
    let dir = tempfile::tempdir().unwrap();
    let csv: String = std::iter::once("x,y,z\n".to_string())
        .chain((0..=1500).map(|i| format!("{},0,20\n", -6.0 + 0.004 * i as f64)))
        .collect();
    let setup = wall_setup(dir.path(), &csv, 6.0);
    let steps = setup.machine_steps().unwrap();
    let (tool_of_step, options) = sweep_setup(&setup.tools, &steps).unwrap();
    let moves: Vec<dexel::Step> = steps.iter().map(|s| s.step).collect();
    let initial = Initial::Held(std::borrow::Cow::Borrowed(&setup.stock));
    let (_, record) = sweep_pass(
        &initial,
        None,
        &setup.tools,
        &tool_of_step,
        &moves,
        &options,
        "test",
    )
    .unwrap();
    let grid_mm = setup.stock.grid().spacing_mm;
    // Every step's load held, then the windows' written over them.
    let model = &setup.tools.entries[0].model;
    let own: Vec<StepLoad> = (0..steps.len())
        .map(|i| model.step_load(&super::loads::step_removal(&record, i, &steps[i], grid_mm)))
        .collect();
    let mut held = own.clone();
    super::subcell::window_loads(
        |i, r| held[i] = r.map_or_else(StepLoad::default, |r| model.step_load(r)),
        &tool_of_step,
        &record,
        &steps,
        grid_mm,
    );
    let windowed = (0..steps.len())
        .filter(|&i| held[i].dx_um.to_bits() != own[i].dx_um.to_bits())
        .count();
    assert!(windowed > 100, "{windowed} steps windowed");
    // Made in parallel, in chunks of any size: the same loads.
    for chunk in [1, 7, 1024] {
        let mut made = own.clone();
        super::subcell::window_loads_in_chunks(
            chunk,
            |_: &mut (), _, r| r.map_or_else(StepLoad::default, |r| model.step_load(r)),
            |i, load| made[i] = load,
            &tool_of_step,
            &record,
            &steps,
            grid_mm,
        );
        for (m, h) in made.iter().zip(&held) {
            assert_eq!(format!("{m:?}"), format!("{h:?}"), "chunks of {chunk}");
        }
    }
    // The loop's deflections (the mean only) are the loads', bit for bit.
    let along = |[dx, dy]: [f64; 2], i: usize| 0.6 * dx + 0.8 * dy + i as f64;
    let of_step = StepTools {
        tools: &setup.tools,
        tool_of_step: &tool_of_step,
    };
    let removals = super::loads::Removals::new(of_step, &record, &steps, grid_mm);
    let g = removals.deflections_as(along);
    // The loads made with the flanks' deflections are the same loads.
    let (loads, flanks) = removals.loads_with_flanks();
    // The rigid pass's: where the loop is never guessed to run, these
    // loads and flanks; where it is (from the first step), the loads
    // without flanks (S4's law has no peak to bound: the same loads).
    let rigid = |likely: bool| removals.rigid_loads(|_| 1200.0, |_, _| likely);
    let (never, with) = rigid(false);
    assert_eq!(format!("{never:?}"), format!("{loads:?}"));
    assert_eq!(with, Some(flanks));
    let (guessed, without) = rigid(true);
    assert_eq!(format!("{guessed:?}"), format!("{loads:?}"));
    assert!(without.is_none());
    // This wall's tool bends by about 99 µm on its 0.1 N/µm holder: the
    // guess that the loop will run is made on it.
    let likely = (0..steps.len())
        .filter(|&i| {
            super::closed_loop::settle::loop_likely(&steps, of_step, &record, i, &loads[i], grid_mm)
        })
        .count();
    assert!(likely > 100, "{likely} of {}", steps.len());
    assert_eq!(g.len(), steps.len());
    for i in 0..steps.len() {
        let l = &held[i];
        assert_eq!(
            g[i].to_bits(),
            along([l.dx_um, l.dy_um], i).to_bits(),
            "step {i}"
        );
        assert_eq!(
            format!("{:?}", loads[i]),
            format!("{:?}", held[i]),
            "step {i}"
        );
    }
}

/// A cut that ends in a short step the rigid tool removes nothing in
/// (fusion_haas_rebels5's line 1015: the rest of a servo period before a
/// rapid, 0.117 ms and 1.5 µm up in Z, after a step the loop moved by
/// 42 µm). Here a Ø10 flat end finishes a wall 0.2 mm deep (holder
/// 0.1 N/µm, S4's law with n = 1: the loop moves the steady steps about
/// 99 µm off the wall), and the cut ends with such a step, then a rapid
/// up. With the step's offset 0 (no rigid direction) the tool swept back
/// to the programmed path within the step: 99 µm of wall in 0.117 ms,
/// a force many times the cut's (8 007.9 N against the wall's 10.0 N).
/// Its offset now relaxes with the load that sustains it (MODEL.md §5.1,
/// eq. 5.1a): the step's force is no larger than the wall's, and the
/// loop converges.
#[test]
fn a_short_step_after_a_deflected_one_does_not_spike() {
    let dir = tempfile::tempdir().unwrap();
    let csv: String = std::iter::once("x,y,z\n".to_string())
        .chain((0..=100).map(|i| format!("{},0,20\n", -10.0 + 0.5 * i as f64)))
        .collect();
    let setup = wall_setup(dir.path(), &csv, 6.0);
    let mut steps = setup.machine_steps().unwrap();
    // The cut up to x = 15 mm (the steady wall), then the short step and
    // a rapid 10 mm up.
    let last = steps
        .iter()
        .rposition(|s| !s.step.rapid && s.step.to_mm[0] <= 15.0)
        .unwrap();
    steps.truncate(last + 1);
    let end = steps[last];
    let dt_s = 0.117e-3;
    let [x, y, z] = end.step.to_mm;
    let up = TimedStep {
        step: dexel::Step {
            from_mm: [x, y, z],
            to_mm: [x, y, z + 1.5e-3],
            rapid: false,
        },
        t_end_s: end.t_end_s + dt_s,
        dt_s,
        feed_mm_min: 1.5e-3 / dt_s * 60.0,
        s_end_mm: end.s_end_mm + 1.5e-3,
        ..end
    };
    let rapid = TimedStep {
        step: dexel::Step {
            from_mm: up.step.to_mm,
            to_mm: [x, y, z + 10.0],
            rapid: true,
        },
        t_end_s: up.t_end_s + 0.016,
        dt_s: 0.016,
        feed_mm_min: 10.0 / 0.016 * 60.0,
        s_end_mm: up.s_end_mm + 10.0,
        continues: true,
        ..end
    };
    steps.push(up);
    steps.push(rapid);
    let run = run_on(
        StockSource::Whole(setup.stock.clone()),
        &setup.tools,
        steps,
        "spike",
    )
    .unwrap();
    let k = last + 1;
    // The steps of the steady wall before it (x from 10 mm on).
    let before: Vec<f64> = (0..k)
        .filter(|&i| !run.steps[i].step.rapid && run.steps[i].step.to_mm[0] >= 10.0)
        .map(|i| run.loads[i].force_n)
        .collect();
    assert!(before.len() > 10, "{} steps", before.len());
    let lo = before.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = before.iter().copied().fold(0.0, f64::max);
    let offset = run.offsets_um[last][1];
    assert!(offset > 50.0, "the wall's offset {offset} µm");
    let force = run.loads[k].force_n;
    eprintln!(
            "wall {lo:.2}…{hi:.2} N at offset {offset:.1} µm; short step {force:.2} N at {:?} µm, {} sweeps",
            run.offsets_um[k], run.closed_loop.passes
        );
    assert!(
        force <= hi,
        "the short step's force {force} N above the wall's {lo}…{hi} N"
    );
    assert!(run.closed_loop.converged, "{:?}", run.closed_loop);
}

/// A step with no direction of its own takes the direction of the step
/// before it (eq. 5.1a), but its own cut can push the tool the other
/// way: then the root of eq. 5.1a lies below φ = 0, and the step ends on
/// the path, its load as swept (eq. 5.1b). The wall of the closed form
/// above (holder 0.1 N/µm: the loop moves the tool about 99 µm off the
/// wall, +y) is cut to its end and beyond; the tool turns down in the
/// air and comes back along the other face of the wall, its edge on the
/// face the rigid tool made. The rigid tool cuts nothing there (the wall
/// is 0.2 mm thick, the first pass took all of it), so those steps have
/// no direction and take +y along the chain; the bent tool of the first
/// pass left 99 µm of the wall, which the way back cuts from below and
/// which pushes the tool to −y: g < 0 at φ = 0. Before eq. 5.1b each
/// such step stayed out of tolerance by its whole deflection and the loop
/// did not settle.
#[test]
fn a_step_whose_own_cut_pushes_against_its_taken_direction_ends_on_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let csv: String = std::iter::once("x,y,z\n".to_string())
        .chain((0..=100).map(|i| format!("{},0,20\n", -10.0 + 0.5 * i as f64)))
        .chain((0..=100).map(|i| format!("{},-9.95,20\n", 40.0 - 0.5 * i as f64)))
        .collect();
    let setup = wall_setup(dir.path(), &csv, 5.0);
    let steps = setup.machine_steps().unwrap();
    let run = run_on(
        StockSource::Whole(setup.stock.clone()),
        &setup.tools,
        steps,
        "back",
    )
    .unwrap();
    let on = |i: usize, y: f64| {
        let s = &run.steps[i].step;
        !s.rapid && s.from_mm[1] == y && s.to_mm[1] == y && (5.0..=25.0).contains(&s.to_mm[0])
    };
    // The first pass along the wall: moved off it, +y.
    let first: Vec<usize> = (0..run.steps.len()).filter(|&i| on(i, 0.0)).collect();
    assert!(first.len() > 20, "{} steps", first.len());
    for &i in &first {
        assert!(
            run.offsets_um[i][1] > 50.0,
            "step {i}: {:?} µm",
            run.offsets_um[i]
        );
    }
    // The way back cuts what the bent tool left: pushed to −y, on the path.
    let back: Vec<usize> = (0..run.steps.len()).filter(|&i| on(i, -9.95)).collect();
    assert!(back.len() > 20, "{} steps", back.len());
    for &i in &back {
        assert_eq!(run.offsets_um[i], [0.0, 0.0], "step {i}");
        assert!(
            run.model_um
                .of_step(i)
                .iter()
                .flatten()
                .all(|m| m[1] < -10.0),
            "step {i}: {:?} µm",
            run.model_um.of_step(i)
        );
    }
    eprintln!(
        "first pass {:.1} µm, way back {:.1} µm, {} sweeps, residual {:.2} µm",
        run.offsets_um[first[first.len() / 2]][1],
        run.model_um.of_step(back[back.len() / 2])[0][0][1],
        run.closed_loop.passes,
        run.closed_loop.residual_um
    );
    assert!(run.closed_loop.converged, "{:?}", run.closed_loop);
}

/// Each tool of a table takes the highest S of its own moves (MODEL.md
/// §2.1): a roughing tool at S8000 is not modelled at the finishing
/// tool's S10000; a single [tool] cutting every T takes the highest of all.
#[test]
fn each_tool_of_a_table_takes_the_s_of_its_own_moves() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.nc"),
        "G21 G90\nT1 M6\nS8000 M3\nG0 X-10 Y0 Z5\nG1 Z-1 F600\nG1 X10\nG0 Z5\n\
         T2 M6\nS10000 M3\nG0 X-10 Y5\nG1 Z-1\nG1 X10\nG0 Z5\nM30\n",
    )
    .unwrap();
    let stock = "[stock]\nkind = \"box\"\nmin = [-5, -5, -5]\nmax = [5, 10, 0]\ngrid = 0.5\n\
                 [program]\npath = \"p.nc\"\n";
    let table = "[[tools]]\nnumber = 1\nkind = \"flat\"\ndiameter = 6\n\
                 [[tools]]\nnumber = 2\nkind = \"ball\"\ndiameter = 6\n";
    let single = "[tool]\nkind = \"flat\"\ndiameter = 6\n";
    let rpms = |tools: &str| {
        let path = dir.path().join("job.toml");
        std::fs::write(&path, format!("{stock}{tools}")).unwrap();
        let setup = crate::setup::Setup::load(&path, None).unwrap();
        setup
            .tools
            .entries
            .iter()
            .map(|e| e.model.spindle_rpm)
            .collect::<Vec<_>>()
    };
    assert_eq!(rpms(table), [8000.0, 10000.0]);
    assert_eq!(rpms(single), [10000.0]);
}
