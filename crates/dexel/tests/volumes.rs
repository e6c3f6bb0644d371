//! Removed volumes against exact answers.

use std::f64::consts::PI;

use dexel::{sweep, RemovalRecord, Step, Stock, SweepOptions, Tool};

const R: f64 = 5.0;

fn line(from: [f64; 3], to: [f64; 3]) -> Step {
    Step {
        from_mm: from,
        to_mm: to,
        rapid: false,
    }
}

fn run(stock: &mut Stock, tool: &Tool, steps: &[Step], band_mm: f64) -> RemovalRecord {
    let options = SweepOptions {
        band_height_mm: band_mm,
        ..SweepOptions::default()
    };
    sweep(stock, tool, steps, &options, &|_| {}).expect("sweep")
}

/// Area of the region of a ball-end slot cross-section below height `h` above
/// the tip: circular segment up to R, then a rectangle 2R wide (the shank).
fn slot_area_below(h: f64) -> f64 {
    let h = h.max(0.0);
    if h <= R {
        R * R * ((R - h) / R).acos() - (R - h) * (2.0 * R * h - h * h).sqrt()
    } else {
        PI * R * R / 2.0 + 2.0 * R * (h - R)
    }
}

fn assert_rel(actual: f64, exact: f64, tol: f64, what: &str) {
    let rel = (actual - exact).abs() / exact;
    assert!(
        rel < tol,
        "{what}: {actual} vs exact {exact} (relative error {rel:.2e}, allowed {tol:.1e})"
    );
}

/// Ball slot straight through a 100 mm box at depth `depth`: volume and bands.
fn check_ball_slot(depth: f64, grid: f64) -> f64 {
    let mut stock = Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], grid).unwrap();
    let before = stock.volume_mm3();
    let z = 30.0 - depth;
    let record = run(
        &mut stock,
        &Tool::ball(2.0 * R),
        &[line([-10.0, 0.0, z], [110.0, 0.0, z])],
        1.0,
    );
    let exact = slot_area_below(depth) * 100.0;
    assert_rel(
        record.volume_mm3(0),
        exact,
        3e-3,
        &format!("slot depth {depth} at grid {grid}"),
    );
    assert!(
        (before - stock.volume_mm3() - record.volume_mm3(0)).abs() < 1e-6 * exact,
        "removed = initial − final"
    );
    for (k, band) in record.band_volumes_mm3(0).iter().enumerate() {
        let (a, b) = (k as f64, (k as f64 + 1.0).min(depth));
        let exact_band = (slot_area_below(b) - slot_area_below(a)).max(0.0) * 100.0;
        if exact_band > 0.0 {
            assert_rel(
                *band,
                exact_band,
                1.5e-2,
                &format!("band {k} of slot depth {depth}"),
            );
        } else {
            assert_eq!(*band, 0.0, "band {k} above the stock");
        }
    }
    (record.volume_mm3(0) - exact).abs() / exact
}

#[test]
fn ball_slot_shallower_than_radius() {
    check_ball_slot(2.0, 0.1);
    check_ball_slot(3.7, 0.1);
}

#[test]
fn ball_slot_deeper_than_radius() {
    check_ball_slot(7.3, 0.1);
}

#[test]
fn slot_error_falls_with_grid() {
    let errors: Vec<f64> = [0.4, 0.2, 0.1, 0.05]
        .iter()
        .map(|&g| check_ball_slot(2.0, g))
        .collect();
    eprintln!("ball slot depth 2: relative volume error at grid 0.4/0.2/0.1/0.05 mm = {errors:?}");
    assert!(
        errors[3] < errors[0],
        "error should fall with the grid: {errors:?}"
    );
}

#[test]
fn diagonal_slot_matches_section_times_axis_length() {
    // 30° to X, crossing only the x = 0 and x = 100 walls.
    let mut stock = Stock::new_box([0.0, -80.0, 0.0], [100.0, 80.0, 30.0], 0.1).unwrap();
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let z = 27.0;
    let (from, to) = (
        [-20.0 * c, -20.0 * s - 25.0, z],
        [140.0 * c, 140.0 * s - 25.0, z],
    );
    let record = run(&mut stock, &Tool::ball(2.0 * R), &[line(from, to)], 1.0);
    assert_rel(
        record.volume_mm3(0),
        slot_area_below(3.0) * 100.0 / c,
        3e-3,
        "diagonal slot",
    );
}

#[test]
fn plunge_removes_ball_cap_and_cylinder() {
    for depth in [3.0, 8.0] {
        let mut stock = Stock::new_box([-20.0, -20.0, 0.0], [20.0, 20.0, 30.0], 0.05).unwrap();
        let record = run(
            &mut stock,
            &Tool::ball(2.0 * R),
            &[line([0.0, 0.0, 40.0], [0.0, 0.0, 30.0 - depth])],
            1.0,
        );
        let exact = if depth <= R {
            PI * depth * depth * (3.0 * R - depth) / 3.0
        } else {
            2.0 / 3.0 * PI * R.powi(3) + PI * R * R * (depth - R)
        };
        assert_rel(
            record.volume_mm3(0),
            exact,
            5e-3,
            &format!("plunge depth {depth}"),
        );
    }
}

#[test]
fn flat_slot_is_a_rectangle() {
    let mut stock = Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], 0.1).unwrap();
    let record = run(
        &mut stock,
        &Tool::flat(10.0),
        &[line([-10.0, 0.0, 26.0], [110.0, 0.0, 26.0])],
        1.0,
    );
    assert_rel(record.volume_mm3(0), 10.0 * 4.0 * 100.0, 1e-6, "flat slot");
    let bands = record.band_volumes_mm3(0);
    for &band in &bands[..4] {
        assert_rel(band, 1000.0, 1e-6, "flat slot band");
    }
}

#[test]
fn bull_nose_slot_matches_its_section() {
    // Section below height h: bottom flat 2(R−r) wide plus two quarter discs of radius r, then 2R wide.
    let (rc, depth) = (2.0, 3.0);
    let mut stock = Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], 0.05).unwrap();
    let record = run(
        &mut stock,
        &Tool::bull(10.0, rc),
        &[line([-10.0, 0.0, 27.0], [110.0, 0.0, 27.0])],
        1.0,
    );
    let exact = (2.0 * R * depth - (4.0 - PI) * rc * rc / 2.0) * 100.0;
    assert_rel(record.volume_mm3(0), exact, 3e-3, "bull-nose slot");
}

#[test]
fn same_move_twice_removes_nothing_the_second_time() {
    let mut stock = Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], 0.1).unwrap();
    let step = line([5.0, -3.0, 26.5], [93.0, 7.0, 24.0]);
    let record = run(&mut stock, &Tool::ball(10.0), &[step, step], 1.0);
    assert!(record.volume_mm3(0) > 100.0);
    assert_eq!(record.volume_mm3(1), 0.0);
}

#[test]
fn removed_equals_initial_minus_final_and_last_cut_is_set() {
    let mut stock = Stock::new_box([0.0, 0.0, 0.0], [50.0, 50.0, 20.0], 0.1).unwrap();
    let before = stock.volume_mm3();
    let steps: Vec<Step> = (0..10)
        .map(|i| {
            let y = 5.0 + 4.0 * i as f64;
            line([-6.0, y, 17.0 - 0.2 * i as f64], [56.0, y + 1.0, 16.0])
        })
        .collect();
    let record = run(&mut stock, &Tool::bull(8.0, 1.5), &steps, 0.5);
    assert!((before - stock.volume_mm3() - record.total_volume_mm3()).abs() < 1e-6 * before);
    let grid = *stock.grid();
    let (ix, iy) = (
        grid.ix_range(25.0, 25.1).unwrap().0,
        grid.iy_range(41.5, 41.6).unwrap().0,
    );
    assert_eq!(
        stock.last_cut()[iy * grid.nx + ix],
        9,
        "the last pass cut y ≈ 41.5"
    );
}

/// Short steps along X, as servo steps are: the resultant of a steady step.
fn steady_resultant(tool: &Tool, stock_y_min: f64) -> [f64; 2] {
    let mut stock = Stock::new_box([0.0, stock_y_min, 0.0], [100.0, 20.0, 30.0], 0.05).unwrap();
    let steps: Vec<Step> = (0..100)
        .map(|i| {
            line(
                [i as f64 * 0.5, 0.0, 27.0],
                [(i + 1) as f64 * 0.5, 0.0, 27.0],
            )
        })
        .collect();
    let record = run(&mut stock, tool, &steps, 1.0);
    record.contact_resultant(60)
}

#[test]
fn contact_resultant_points_to_the_material() {
    for tool in [Tool::flat(10.0), Tool::ball(10.0)] {
        // Wall on the +y side (radial depth 2 mm): contact in the front-left quadrant.
        let [cx, cy] = steady_resultant(&tool, 3.0);
        assert!(
            cx > 0.0 && cy > 0.0,
            "{:?}: resultant {cx}, {cy}",
            tool.shape
        );
        // Full-width slot: symmetric about the path, resultant along the feed.
        let [cx, cy] = steady_resultant(&tool, -20.0);
        assert!(
            cx > 0.0 && cy.abs() < 1e-3 * cx,
            "{:?}: slot resultant {cx}, {cy}",
            tool.shape
        );
    }
}

#[test]
fn shank_contact_is_reported() {
    let mut tool = Tool::ball(10.0);
    tool.flute_length_mm = 4.0;
    let mut stock = Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], 0.1).unwrap();
    let record = run(
        &mut stock,
        &tool,
        &[line([-10.0, 0.0, 24.0], [110.0, 0.0, 24.0])],
        1.0,
    );
    let exact_shank = (slot_area_below(6.0) - slot_area_below(4.0)) * 100.0;
    assert_rel(
        record.shank_volume_mm3(0),
        exact_shank,
        5e-3,
        "shank volume",
    );
}

#[test]
fn identical_results_for_one_and_many_threads() {
    let steps: Vec<Step> = (0..400)
        .map(|i| {
            let a = i as f64 * 0.07;
            line(
                [
                    30.0 + 20.0 * a.cos(),
                    30.0 + 20.0 * a.sin(),
                    18.0 - 0.01 * i as f64,
                ],
                [
                    30.0 + 19.0 * (a + 0.07).cos(),
                    30.0 + 19.0 * (a + 0.07).sin(),
                    17.5,
                ],
            )
        })
        .collect();
    // Every envelope: ball, flat, bull nose (the torus edge with a ring).
    for tool in [Tool::ball(6.0), Tool::flat(6.0), Tool::bull(6.0, 1.0)] {
        let run_with = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut stock = Stock::new_box([0.0, 0.0, 0.0], [60.0, 60.0, 20.0], 0.1).unwrap();
                let opts = SweepOptions {
                    band_height_mm: 0.5,
                    strip_rows: 4,
                    batch_steps: 97,
                    ..SweepOptions::default()
                };
                let record = sweep(&mut stock, &tool, &steps, &opts, &|_| {}).unwrap();
                (record, stock.top_heights(), stock.last_cut().to_vec())
            })
        };
        let (r1, h1, l1) = run_with(1);
        assert!(r1.total_volume_mm3() > 100.0, "{tool:?} cuts");
        // Bit for bit: every per-step value, every top, every last cut. (The
        // strips are taken costliest first by the time each took before, by
        // whichever thread is free: each run takes them in an order of its own.)
        for threads in [2, 3, 4] {
            let (r, h, l) = run_with(threads);
            assert_eq!(
                record_bits(&r1),
                record_bits(&r),
                "{tool:?}, {threads} threads"
            );
            assert_eq!(
                h1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                h.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
            assert_eq!(l1, l);
        }
    }
}

#[test]
fn voids_give_several_intervals_and_cutting_through_them_works() {
    // Column material [0,5] and [10,20]; a flat tool at z = 7 removes only [10,20].
    let grid = dexel::Grid::covering(0.0, 0.0, 20.0, 20.0, 0.5).unwrap();
    let mut stock =
        Stock::from_columns(grid, |_, _, out| out.extend([[0.0, 5.0], [10.0, 20.0]])).unwrap();
    assert_eq!(stock.column(3, 3).interval_count(), 2);
    let record = run(
        &mut stock,
        &Tool::flat(4.0),
        &[line([10.0, -5.0, 7.0], [10.0, 25.0, 7.0])],
        1.0,
    );
    // Footprint: 4 mm wide stripe over 20 mm = 80 mm² (8 columns of 0.5 mm).
    assert_rel(
        record.volume_mm3(0),
        80.0 * 10.0,
        1e-9,
        "cut through the upper interval",
    );
    assert_eq!(stock.column(20, 3).interval_count(), 1);
}

#[test]
fn rejects_bad_parameters() {
    assert!(Stock::new_box([0.0, 0.0, 0.0], [-1.0, 1.0, 1.0], 0.1).is_err());
    assert!(Stock::new_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 0.0).is_err());
    let err = Stock::new_box([0.0, 0.0, 0.0], [1e5, 1e5, 1.0], 0.001).unwrap_err();
    assert!(err.to_string().contains("coarser grid"), "{err}");
    let mut stock = Stock::new_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 0.1).unwrap();
    let mut tool = Tool::ball(1.0);
    tool.diameter_mm = -1.0;
    assert!(sweep(&mut stock, &tool, &[], &SweepOptions::default(), &|_| {}).is_err());
    let nan = line([f64::NAN, 0.0, 0.0], [1.0, 1.0, 1.0]);
    assert!(sweep(
        &mut stock,
        &Tool::ball(1.0),
        &[nan],
        &SweepOptions::default(),
        &|_| {}
    )
    .is_err());
}

/// Steps cut by two tools: the same as two sweeps in turn on one stock, row
/// for row, with the shorter tool's missing bands zero.
#[test]
fn sweep_tools_equals_sweeps_in_turn() {
    let tools = [
        Tool {
            flute_length_mm: 4.0,
            ..Tool::flat(6.0)
        },
        Tool::ball(10.0),
    ];
    let steps = [
        line([-10.0, -8.0, 28.0], [110.0, -8.0, 28.0]),
        line([110.0, -8.0, 28.0], [110.0, 8.0, 28.0]),
        line([110.0, 8.0, 27.0], [-10.0, 8.0, 27.0]),
        line([-10.0, 0.0, 26.0], [110.0, 0.0, 26.0]),
    ];
    let which = [0, 0, 1, 0];
    let options = SweepOptions::default();
    let fresh = || Stock::new_box([0.0, -20.0, 0.0], [100.0, 20.0, 30.0], 0.25).unwrap();
    let mut together = fresh();
    let all = dexel::sweep_tools(&mut together, &tools, &which, &steps, &options, &|_| {}).unwrap();
    let mut apart = fresh();
    let mut rows = Vec::new();
    for (range, t) in [(0..2, 0), (2..3, 1), (3..4, 0)] {
        let r = sweep(&mut apart, &tools[t], &steps[range], &options, &|_| {}).unwrap();
        for j in 0..r.len() {
            rows.push((r.volume_mm3(j), r.band_volumes_mm3(j).to_vec()));
        }
    }
    assert_eq!(all.len(), 4);
    assert_eq!(all.n_bands, 20, "the ball's 20 bands");
    for (i, (v, bands)) in rows.iter().enumerate() {
        assert_eq!(all.volume_mm3(i), *v, "step {i}");
        let b = all.band_volumes_mm3(i);
        assert_eq!(&b[..bands.len()], &bands[..], "step {i}");
        assert!(b[bands.len()..].iter().all(|&x| x == 0.0));
    }
    assert_eq!(together.volume_mm3(), apart.volume_mm3());
    assert!(all.volume_mm3(0) > 0.0 && all.volume_mm3(2) > 0.0);
    // The last-cut marks are the program's step indices, in every run of one
    // tool (the column at y = 0 last cut by step 3, the tool's second run; y =
    // 8 by step 2, the ball's run; y = −8 by step 0).
    let grid = *together.grid();
    let at = |x: f64, y: f64| {
        let (ix, iy) = (
            grid.ix_range(x, x + 0.25).unwrap().0,
            grid.iy_range(y, y + 0.25).unwrap().0,
        );
        together.last_cut()[iy * grid.nx + ix]
    };
    assert_eq!([at(50.0, -8.0), at(50.0, 8.0), at(50.0, 0.2)], [0, 2, 3]);
    // A step without a tool is an error, not a panic.
    assert!(dexel::sweep_tools(
        &mut fresh(),
        &tools,
        &[0, 2, 0, 0],
        &steps,
        &options,
        &|_| {}
    )
    .is_err());
}

/// Steady flat-end slot in servo-sized steps: per-step volumes of the steady part.
fn slot_step_volumes(
    smooth: bool,
    grid: f64,
    step_mm: f64,
    width_y: (f64, f64),
) -> (Vec<f64>, f64, f64) {
    let mut stock = Stock::new_box([0.0, width_y.0, 0.0], [60.0, width_y.1, 10.0], grid).unwrap();
    let before = stock.volume_mm3();
    let n = (70.0 / step_mm) as usize;
    let steps: Vec<Step> = (0..n)
        .map(|i| {
            let x = -6.0 + i as f64 * step_mm;
            line([x, 0.0, 8.0], [x + step_mm, 0.0, 8.0])
        })
        .collect();
    let options = SweepOptions {
        band_height_mm: 1.0,
        smooth,
        ..SweepOptions::default()
    };
    let record = sweep(&mut stock, &Tool::flat(10.0), &steps, &options, &|_| {}).unwrap();
    let removed = before - stock.volume_mm3();
    // Steady: the whole tool inside the stock, from x = 10 to x = 45.
    let steady: Vec<f64> = (0..n)
        .filter(|&i| {
            let x = -6.0 + i as f64 * step_mm;
            x > 10.0 && x < 45.0
        })
        .map(|i| record.volume_mm3(i))
        .collect();
    (steady, removed, record.total_volume_mm3())
}

/// Largest relative change of removal from one step to the next.
fn step_to_step(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    v.windows(2)
        .map(|w| (w[1] - w[0]).abs() / mean)
        .fold(0.0, f64::max)
}

#[test]
fn smoothed_step_removal_does_not_alias_with_the_grid() {
    // Full slot, Ø10 flat end, 0.1 mm grid, 0.08 mm per step (0.8 cells per period).
    let (raw, _, _) = slot_step_volumes(false, 0.1, 0.08, (-20.0, 20.0));
    let (smooth, removed, recorded) = slot_step_volumes(true, 0.1, 0.08, (-20.0, 20.0));
    // Exact volume per step: D · depth · step = 10 · 2 · 0.08 = 1.6 mm³.
    let mean = smooth.iter().sum::<f64>() / smooth.len() as f64;
    assert_rel(mean, 1.6, 5e-3, "mean steady removal");
    let (raw_var, smooth_var) = (step_to_step(&raw), step_to_step(&smooth));
    eprintln!("full slot step-to-step: raw {raw_var:.4}, smoothed {smooth_var:.4}");
    assert!(raw_var > 0.05, "unsmoothed removal should alias: {raw_var}");
    assert!(
        smooth_var < 0.02,
        "smoothed removal varies {smooth_var} step to step (raw {raw_var})"
    );
    // Totals are kept: Σ steps = initial − final.
    assert_rel(recorded, removed, 1e-9, "smoothed total");
    // Half-immersion side cut and a step that is not a simple fraction of the grid.
    for step_mm in [0.08, 0.137, 0.3] {
        let (side, removed, recorded) = slot_step_volumes(true, 0.1, step_mm, (0.0, 20.0));
        let v = step_to_step(&side);
        eprintln!("side cut {step_mm} mm/step: smoothed {v:.4}");
        let mean = side.iter().sum::<f64>() / side.len() as f64;
        assert_rel(mean, 5.0 * 2.0 * step_mm, 5e-3, "mean side-cut removal");
        assert!(v < 0.02, "side cut at {step_mm} mm per step varies {v}");
        assert_rel(recorded, removed, 1e-9, "side-cut total");
    }
}

/// Steady flat-end cut, radial immersion from the +y side: (Σ volume, Σ chip edge area,
/// Σ volume / radius, resultant) over the steady steps.
fn steady_chip_sums(y_min: f64, step_mm: f64, tool: Tool) -> (f64, f64, f64, [f64; 2]) {
    let mut stock = Stock::new_box([0.0, y_min, 0.0], [60.0, 20.0, 10.0], 0.05).unwrap();
    let n = (70.0 / step_mm) as usize;
    let steps: Vec<Step> = (0..n)
        .map(|i| {
            let x = -6.0 + i as f64 * step_mm;
            line([x, 0.0, 8.0], [x + step_mm, 0.0, 8.0])
        })
        .collect();
    let record = run(&mut stock, &tool, &steps, 1.0);
    let mut sums = (0.0, 0.0, 0.0, [0.0, 0.0]);
    for i in (0..n).filter(|&i| (10.0..45.0).contains(&(-6.0 + i as f64 * step_mm))) {
        sums.0 += record.volume_mm3(i);
        sums.1 += record.chip_edge_area_mm2(i);
        sums.2 += record.volume_over_radius_mm2(i);
        let [cx, cy] = record.contact_resultant(i);
        sums.3 = [sums.3[0] + cx, sums.3[1] + cy];
    }
    sums
}

#[test]
fn mean_chip_thickness_of_side_cuts() {
    // h_m / f = (cos φ_st − cos φ_ex) / (φ_ex − φ_st) (MODEL.md §3.2): full slot and half
    // immersion 2/π, quarter immersion (a_e = D/4, φ = 0…π/3) 0.5 / (π/3).
    let step = 0.2;
    for (y_min, expected) in [(-20.0, 2.0 / PI), (0.0, 2.0 / PI), (2.5, 0.5 / (PI / 3.0))] {
        let (v, edge, v_over_r, _) = steady_chip_sums(y_min, step, Tool::flat(10.0));
        let ratio = v / edge / step;
        eprintln!("y_min {y_min}: h_m/f = {ratio:.4}, expected {expected:.4}");
        assert_rel(ratio, expected, 0.02, "mean chip thickness per feed");
        assert_rel(v_over_r, v / R, 1e-9, "flat end: volume over radius");
    }
}

/// Every per-step value of a record, as bits.
fn record_bits(r: &RemovalRecord) -> Vec<u64> {
    let bits = (0..r.len()).flat_map(|i| {
        let [cx, cy] = r.contact_resultant(i);
        [
            r.volume_mm3(i),
            r.shank_volume_mm3(i),
            cx,
            cy,
            r.chip_edge_area_mm2(i),
            r.volume_over_radius_mm2(i),
        ]
        .into_iter()
        .chain(r.band_volumes_mm3(i).iter().copied())
        .map(f64::to_bits)
        .chain(offset_bits(r.band_offsets_mm(i)))
        .collect::<Vec<_>>()
    });
    let bits: Vec<u64> = bits.collect();
    // A record's rows as a sink is given them: the same values.
    let rows: Vec<u64> = (0..r.len()).flat_map(|i| row_bits(r.step_row(i))).collect();
    assert_eq!(rows, bits);
    bits
}

/// A row's values (as [`record_bits`] lists a step's), as bits.
fn row_bits(row: dexel::RecordRow<'_>) -> Vec<u64> {
    let [cx, cy] = row.contact_resultant();
    [
        row.volume_mm3(),
        row.shank_volume_mm3(),
        cx,
        cy,
        row.chip_edge_area_mm2(),
        row.volume_over_radius_mm2(),
    ]
    .into_iter()
    .chain(row.band_volumes_mm3().iter().copied())
    .map(f64::to_bits)
    .chain(offset_bits(row.band_offsets_mm()))
    .collect()
}

/// A step's ranges of lateral offsets per band, as bits.
fn offset_bits(offsets: &[[f32; 2]]) -> impl Iterator<Item = u64> + '_ {
    offsets
        .iter()
        .map(|r| (u64::from(r[0].to_bits()) << 32) | u64::from(r[1].to_bits()))
}

/// A stock swept band of rows by band of rows (a tiled stock too large for
/// memory) gives the whole stock's record bit for bit when the bands start on
/// strip boundaries, and the same columns, last cuts and volume, with moves
/// that cross the band edges in every direction, two tools and smoothing.
#[test]
fn banded_sweep_equals_the_whole_stock() {
    let tools = [Tool::bull(6.0, 1.0), Tool::ball(4.0)];
    let mut steps: Vec<Step> = (0..300)
        .map(|i| {
            let a = i as f64 * 0.05;
            line(
                [
                    30.0 + 22.0 * a.cos(),
                    30.0 + 22.0 * a.sin(),
                    18.0 - 0.01 * i as f64,
                ],
                [
                    30.0 + 21.0 * (a + 0.05).cos(),
                    30.0 + 21.0 * (a + 0.05).sin(),
                    17.0,
                ],
            )
        })
        .collect();
    // Long passes across every band: along y, diagonal, and a plunge on an edge.
    steps.push(line([10.0, -5.0, 16.0], [12.0, 65.0, 15.5]));
    steps.push(line([12.0, 65.0, 15.5], [55.0, 2.0, 14.0]));
    steps.push(line([55.0, 2.0, 14.0], [55.0, 2.0, 20.0]));
    steps.push(line([40.0, 16.0, 25.0], [40.0, 16.0, 12.0]));
    let which: Vec<usize> = (0..steps.len()).map(|i| usize::from(i >= 150)).collect();
    let options = SweepOptions {
        band_height_mm: 0.5,
        strip_rows: 4,
        batch_steps: 53,
        ..SweepOptions::default()
    };
    let (min, max, g) = ([0.0, 0.0, 0.0], [60.0, 60.0, 20.0], 0.2);
    let mut whole = Stock::new_box(min, max, g).unwrap();
    let all = dexel::sweep_tools(&mut whole, &tools, &which, &steps, &options, &|_| {}).unwrap();
    assert!(all.total_volume_mm3() > 1000.0);
    let ny = whole.grid().ny;
    assert_eq!(ny, 300);
    // Bands of 8 and 36 rows (strip-aligned), and a last band shorter than the others.
    for band_rows in [8usize, 36, 296] {
        let mut sweep = dexel::Sweep::new(&tools, &which, &steps, &options).unwrap();
        let (mut tops, mut last, mut length_mm) = (Vec::new(), Vec::new(), 0.0);
        // Each band made in the memory of the swept band before it.
        let mut previous = None;
        for r0 in (0..ny).step_by(band_rows) {
            let rows = r0..(r0 + band_rows).min(ny);
            let mut band =
                Stock::new_box_in_rows(min, max, g, Some(rows.clone()), previous.take()).unwrap();
            assert_eq!(band.rows(), rows);
            assert_eq!(band.columns().len(), rows.len() * whole.grid().nx);
            sweep.band(&mut band, &|_| {});
            tops.extend(band.top_heights());
            last.extend_from_slice(band.last_cut());
            length_mm = band.add_row_lengths_mm(band.rows(), length_mm);
            previous = Some(band);
        }
        let banded = sweep.finish();
        assert_eq!(
            record_bits(&banded),
            record_bits(&all),
            "bands of {band_rows}"
        );
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&tops),
            bits(&whole.top_heights()),
            "bands of {band_rows}"
        );
        assert_eq!(last, whole.last_cut(), "bands of {band_rows}");
        assert_eq!(
            (length_mm * whole.grid().cell_area_mm2()).to_bits(),
            whole.volume_mm3().to_bits()
        );
    }
    // A band that does not start on a strip boundary: the same columns, the
    // per-step sums equal within rounding (a strip's sum is then added in two parts).
    let mut sweep = dexel::Sweep::new(&tools, &which, &steps, &options).unwrap();
    let mut tops = Vec::new();
    for rows in [0..7, 7..150, 150..300] {
        let mut band = Stock::new_box_in_rows(min, max, g, Some(rows), None).unwrap();
        sweep.band(&mut band, &|_| {});
        tops.extend(band.top_heights());
    }
    let banded = sweep.finish();
    assert_eq!(tops, whole.top_heights());
    for i in 0..all.len() {
        let (a, b) = (all.volume_mm3(i), banded.volume_mm3(i));
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(1e-9),
            "step {i}: {a} vs {b}"
        );
    }
    // Rows beyond the grid are refused.
    assert!(Stock::new_box_in_rows(min, max, g, Some(290..301), None).is_err());
}

/// A whole-stock sweep keeps its record compact while it runs (each batch's
/// steps made final as soon as their neighbours are swept, `Sweep::whole`):
/// the same record bit for bit, and the same columns, as sweeping the stock
/// as one band and finishing the record at the end, with and without
/// smoothing, for batches of 1, 2, 53 and every step and batches bounded by
/// the bytes of their partial sums (`SweepOptions::batch_bytes`), two tools,
/// plunges, rapids and moves that do not continue each other; and every
/// batching gives the record, tops and last cuts of one batch of every step.
#[test]
fn whole_sweep_record_equals_the_finished_band() {
    let tools = [Tool::bull(6.0, 1.0), Tool::ball(4.0)];
    let mut steps: Vec<Step> = (0..240)
        .map(|i| {
            let a = i as f64 * 0.05;
            let from = [30.0 + 20.0 * a.cos(), 30.0 + 20.0 * a.sin(), 18.0];
            let b = a + 0.05;
            let to = [30.0 + 20.0 * b.cos(), 30.0 + 20.0 * b.sin(), 18.0];
            Step {
                from_mm: from,
                to_mm: to,
                rapid: i % 97 == 96,
            }
        })
        .collect();
    steps.push(line([55.0, 2.0, 14.0], [55.0, 2.0, 20.0]));
    steps.push(line([40.0, 16.0, 25.0], [40.0, 16.0, 12.0]));
    steps.push(line([40.0, 16.0, 12.0], [40.0, 30.0, 12.0]));
    steps.push(line([40.0, 30.0, 12.0], [40.0, 16.0, 12.0]));
    let which: Vec<usize> = (0..steps.len()).map(|i| usize::from(i >= 120)).collect();
    let new = || Stock::new_box([0.0; 3], [60.0, 60.0, 20.0], 0.2).unwrap();
    for smooth in [true, false] {
        // Every step in one batch.
        let options = |batch_steps, batch_bytes| SweepOptions {
            band_height_mm: 0.5,
            strip_rows: 4,
            batch_steps,
            batch_bytes,
            smooth,
        };
        let mut one_batch = new();
        let reference = dexel::sweep_tools(
            &mut one_batch,
            &tools,
            &which,
            &steps,
            &options(100_000, usize::MAX),
            &|_| {},
        )
        .unwrap();
        // Batches of a number of steps, and batches bounded by the bytes of
        // their partial sums (1 byte: one move per batch; 40 000 bytes: a few
        // moves, as many as their strips allow).
        for (batch_steps, batch_bytes) in [
            (1, usize::MAX),
            (2, usize::MAX),
            (53, usize::MAX),
            (100_000, 1),
            (100_000, 40_000),
            (100_000, SweepOptions::default().batch_bytes),
        ] {
            let options = options(batch_steps, batch_bytes);
            let mut whole = new();
            let streamed =
                dexel::sweep_tools(&mut whole, &tools, &which, &steps, &options, &|_| {}).unwrap();
            let mut one = new();
            let mut sweep = dexel::Sweep::new(&tools, &which, &steps, &options).unwrap();
            sweep.band(&mut one, &|_| {});
            let finished = sweep.finish();
            assert!(finished.total_volume_mm3() > 1000.0);
            assert_eq!(streamed.len(), steps.len());
            let what = format!("smooth {smooth}, batches of {batch_steps} steps, {batch_bytes} B");
            assert_eq!(record_bits(&streamed), record_bits(&finished), "{what}");
            assert_eq!(record_bits(&streamed), record_bits(&reference), "{what}");
            assert_eq!(streamed.columns_evaluated, finished.columns_evaluated);
            assert_eq!(streamed.columns_evaluated, reference.columns_evaluated);
            assert_eq!(whole.top_heights(), one.top_heights());
            assert_eq!(whole.top_heights(), one_batch.top_heights());
            assert_eq!(whole.last_cut(), one_batch.last_cut());
        }
    }
}

/// A sweep fed its steps one by one as it asks for them (`StepFn`: here made
/// from a path's points, as `optimize` makes them from its stations) gives
/// the record and the stock of the sweep over the list held whole, bit for
/// bit: two tools (their indices as `u16`), rapids, plunges, moves that do not
/// continue each other, with and without smoothing, in batches of 1, 7 and
/// every step, whole (the record made final as it goes) and band by band.
/// Every step is asked for, none beyond the last.
#[test]
fn a_sweep_fed_step_by_step_equals_the_sweep_of_the_list() {
    use std::cell::Cell;
    let tools = [Tool::bull(6.0, 1.0), Tool::ball(4.0), Tool::flat(3.0)];
    // A path's points; step k goes from point k to point k + 1 (a rapid
    // where `rapid[k]`), and a few steps jump (they start elsewhere).
    let mut points: Vec<[f64; 3]> = vec![[30.0, 30.0, 25.0], [30.0, 30.0, 17.0]];
    for i in 0..160 {
        let a = i as f64 * 0.06;
        let z = if i < 80 { 17.0 } else { 16.0 - 0.01 * i as f64 };
        points.push([30.0 + 18.0 * a.cos(), 30.0 + 18.0 * a.sin(), z]);
    }
    points.extend([[40.0, 16.0, 25.0], [40.0, 16.0, 12.0], [40.0, 30.0, 12.0]]);
    let n = points.len() - 1;
    let step_at = |k: usize| {
        // Every 37th step jumps 0.3 mm aside; every 29th is a rapid.
        let from = if k % 37 == 36 {
            let [x, y, z] = points[k];
            [x + 0.3, y, z]
        } else {
            points[k]
        };
        Step {
            from_mm: from,
            to_mm: points[k + 1],
            rapid: k % 29 == 28,
        }
    };
    let steps: Vec<Step> = (0..n).map(step_at).collect();
    assert!(steps.iter().filter(|s| s.rapid).count() >= 5);
    let which: Vec<usize> = (0..n).map(|k| [0, 1, 2, 1][k * 4 / n]).collect();
    let which16: Vec<u16> = which.iter().map(|&t| t as u16).collect();
    let new = || Stock::new_box([0.0; 3], [60.0, 60.0, 20.0], 0.2).unwrap();
    let ny = new().grid().ny;
    for smooth in [true, false] {
        for batch_steps in [1, 7, 100_000] {
            let options = SweepOptions {
                band_height_mm: 0.5,
                strip_rows: 4,
                batch_steps,
                smooth,
                ..SweepOptions::default()
            };
            let what = format!("smooth {smooth}, batches of {batch_steps}");
            let mut held = new();
            let reference =
                dexel::sweep_tools(&mut held, &tools, &which, &steps, &options, &|_| {}).unwrap();
            assert!(reference.total_volume_mm3() > 500.0, "{what}");
            // Steps made when asked, counted, the highest asked for kept.
            let (asked, highest) = (Cell::new(0usize), Cell::new(0usize));
            let source = dexel::StepFn::new(n, |k| {
                asked.set(asked.get() + 1);
                highest.set(highest.get().max(k));
                step_at(k)
            });
            let mut fed = new();
            let record = dexel::Sweep::new(&tools, &which16, &source, &options)
                .unwrap()
                .whole(&mut fed, &|_| {});
            assert_eq!(record_bits(&record), record_bits(&reference), "{what}");
            assert_eq!(record.columns_evaluated, reference.columns_evaluated);
            assert_eq!(fed.top_heights(), held.top_heights(), "{what}");
            assert_eq!(fed.last_cut(), held.last_cut(), "{what}");
            assert_eq!(highest.get(), n - 1, "{what}");
            assert!(asked.get() >= n, "{what}");
            // Rows given to a sink as they are made final: the record's, in order.
            let sweep = dexel::Sweep::new(&tools, &which16, &source, &options).unwrap();
            assert_eq!(sweep.n_bands(), reference.n_bands);
            let (mut sunk, mut order) = (Vec::new(), Vec::new());
            let mut given = new();
            let visited = sweep.whole_into(&mut given, &|_| {}, &mut |k, row| {
                order.push(k);
                sunk.extend(row_bits(row));
            });
            assert_eq!(order, (0..n).collect::<Vec<_>>(), "{what}");
            assert_eq!(sunk, record_bits(&reference), "{what}");
            assert_eq!(visited, reference.columns_evaluated, "{what}");
            assert_eq!(given.top_heights(), held.top_heights(), "{what}");
            // Band by band (a tiled stock), the record finished at the end.
            let mut sweep = dexel::Sweep::new(&tools, &which16, &source, &options).unwrap();
            let mut tops = Vec::new();
            for r0 in (0..ny).step_by(64) {
                let rows = r0..(r0 + 64).min(ny);
                let mut band =
                    Stock::new_box_in_rows([0.0; 3], [60.0, 60.0, 20.0], 0.2, Some(rows), None)
                        .unwrap();
                sweep.band(&mut band, &|_| {});
                tops.extend(band.top_heights());
            }
            let mut sunk = Vec::new();
            sweep.finish_into(&mut |_, row| sunk.extend(row_bits(row)));
            assert_eq!(sunk, record_bits(&reference), "{what}");
            assert_eq!(tops, held.top_heights(), "{what}");
        }
    }
}

/// A stock whose top intervals share their bottom keeps it once (8 B a
/// column: top and last cut), and sweeps as the same stock keeping a bottom
/// a column: the same record and columns bit for bit, through cuts that
/// empty columns (a slot below the box) and moves over the emptied ones. The
/// second stock is the box with one corner column deeper, far from the tool.
#[test]
fn a_stock_of_one_bottom_sweeps_as_one_of_a_bottom_a_column() {
    let (min, max) = ([0.0, 0.0, -2.0], [30.0, 20.0, 0.0]);
    let uniform = Stock::new_box(min, max, 0.1).unwrap();
    let grid = *uniform.grid();
    let deeper = Stock::from_columns(grid, |ix, iy, out| {
        let lo = if (ix, iy) == (0, 0) { -3.0 } else { -2.0 };
        out.push([lo, 0.0]);
    })
    .unwrap();
    assert_eq!(uniform.memory_bytes(), 8 * grid.len());
    assert_eq!(deeper.memory_bytes(), 12 * grid.len());
    let cylinder = Stock::new_cylinder([10.0, 10.0], 8.0, -1.0, 2.0, 0.1).unwrap();
    assert_eq!(cylinder.memory_bytes(), 8 * cylinder.grid().len());
    // A slot through the bottom (z −3 at the tip: the columns under the
    // ball's middle emptied), a pass back over it, and a raster above.
    let mut steps = vec![
        line([5.0, 10.0, 1.0], [5.0, 10.0, -3.0]),
        line([5.0, 10.0, -3.0], [25.0, 12.0, -3.0]),
        line([25.0, 12.0, -1.0], [4.0, 9.0, -1.5]),
    ];
    for k in 0..12 {
        let y = 3.0 + 1.3 * k as f64;
        let (a, b) = if k % 2 == 0 { (4.0, 27.0) } else { (27.0, 4.0) };
        steps.push(line([a, y, -0.4], [b, y, -0.6]));
    }
    for tool in [Tool::ball(6.0), Tool::flat(4.0), Tool::bull(6.0, 1.0)] {
        let (mut a, mut b) = (uniform.clone(), deeper.clone());
        let (ra, rb) = (
            run(&mut a, &tool, &steps, 0.5),
            run(&mut b, &tool, &steps, 0.5),
        );
        assert!(ra.total_volume_mm3() > 100.0, "{tool:?} cuts");
        assert_eq!(record_bits(&ra), record_bits(&rb), "{tool:?}");
        assert_eq!(a.last_cut(), b.last_cut(), "{tool:?}");
        let emptied = a.columns().filter(|c| c.is_empty()).count();
        assert!(emptied > 100, "{tool:?}: {emptied} columns emptied");
        for (i, (ca, cb)) in a.columns().zip(b.columns()).enumerate().skip(1) {
            assert_eq!(ca, cb, "{tool:?}: column {i}");
            assert_eq!(ca.top_or_nan().to_bits(), a.top_or_nan_at(i).to_bits());
        }
        assert_eq!(
            b.column(0, 0).intervals().collect::<Vec<_>>(),
            [[-3.0, 0.0]]
        );
        assert_eq!(
            a.memory_bytes(),
            8 * grid.len(),
            "{tool:?}: still one bottom"
        );
    }
}
