//! Engagement per band (MODEL.md §1.7): the range of lateral offsets of the
//! columns each band of a step was cut from, against exact answers.

use dexel::{sweep, Grid, RemovalRecord, Step, Stock, SweepOptions, Tool, EMPTY_OFFSETS};

const R: f64 = 5.0;
/// Grid spacing, mm.
const G: f64 = 0.05;

fn line(from: [f64; 3], to: [f64; 3]) -> Step {
    Step {
        from_mm: from,
        to_mm: to,
        rapid: false,
    }
}

/// Steps of 1 mm from `from` to `to` (a whole number of mm apart).
fn steps_mm(from: [f64; 3], to: [f64; 3]) -> Vec<Step> {
    let d: Vec<f64> = (0..3).map(|i| to[i] - from[i]).collect();
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let n = len.round() as usize;
    let at = |k: usize| {
        let s = k as f64 / n as f64;
        [from[0] + s * d[0], from[1] + s * d[1], from[2] + s * d[2]]
    };
    (0..n).map(|k| line(at(k), at(k + 1))).collect()
}

fn run(stock: &mut Stock, tool: &Tool, steps: &[Step], options: &SweepOptions) -> RemovalRecord {
    sweep(stock, tool, steps, options, &|_| {}).expect("sweep")
}

fn bands_1mm() -> SweepOptions {
    SweepOptions {
        band_height_mm: 1.0,
        ..SweepOptions::default()
    }
}

/// `range` is `[lo, hi]` within one grid cell inside: lo ∈ [lo_exact, lo_exact + G)
/// and hi ∈ (hi_exact − G, hi_exact] (f32 rounding allowed).
fn assert_within_a_cell(range: Option<[f32; 2]>, exact: [f64; 2], what: &str) {
    let [lo, hi] = range.unwrap_or_else(|| panic!("{what}: no range"));
    let (lo, hi) = (lo as f64, hi as f64);
    let eps = 1e-5;
    assert!(
        lo >= exact[0] - eps && lo < exact[0] + G && hi <= exact[1] + eps && hi > exact[1] - G,
        "{what}: [{lo}, {hi}] vs exact [{}, {}] (within one cell of {G} mm inside)",
        exact[0],
        exact[1]
    );
}

/// The steady steps of a 40 mm cut of 1 mm steps starting 10 mm before the
/// stock: those fully inside (the tool's whole front in the material).
const STEADY: std::ops::Range<usize> = 17..40;

#[test]
fn a_flat_full_slot_spans_the_diameter() {
    let mut stock = Stock::new_box([0.0, -10.0, 0.0], [40.0, 10.0, 10.0], G).unwrap();
    let steps = steps_mm([-10.0, 0.0, 8.0], [50.0, 0.0, 8.0]);
    let record = run(&mut stock, &Tool::flat(2.0 * R), &steps, &bands_1mm());
    for i in STEADY {
        assert_eq!(
            record.band_offsets_mm(i).len(),
            2,
            "step {i}: bands 0 and 1 kept"
        );
        for k in 0..2 {
            assert_within_a_cell(
                record.band_offset_mm(i, k),
                [-R, R],
                &format!("step {i} band {k}"),
            );
        }
        assert_eq!(record.band_offset_mm(i, 2), None, "above the cut");
    }
    eprintln!("flat slot step 20: {:?}", record.band_offsets_mm(20));
    // Before the stock: nothing cut, nothing recorded.
    assert!(record.band_offsets_mm(0).is_empty());
}

/// A flat side cut of ae = 2 mm along +X with the material on `side` (+1: left, +Y).
fn flat_side_cut(side: f64, feed_x: f64) -> RemovalRecord {
    let (y0, y1) = if side > 0.0 {
        (R - 2.0, 20.0)
    } else {
        (-20.0, -(R - 2.0))
    };
    let mut stock = Stock::new_box([0.0, y0, 0.0], [40.0, y1, 10.0], G).unwrap();
    let (a, b) = if feed_x > 0.0 {
        (-10.0, 50.0)
    } else {
        (50.0, -10.0)
    };
    let steps = steps_mm([a, 0.0, 8.0], [b, 0.0, 8.0]);
    run(&mut stock, &Tool::flat(2.0 * R), &steps, &bands_1mm())
}

#[test]
fn a_flat_side_cut_spans_its_engagement_on_its_side() {
    // Feed +X: the material at +Y lies to the left (e > 0), at −Y to the right.
    for (side, exact) in [(1.0, [R - 2.0, R]), (-1.0, [-R, -(R - 2.0)])] {
        let record = flat_side_cut(side, 1.0);
        for i in STEADY {
            for k in 0..2 {
                assert_within_a_cell(
                    record.band_offset_mm(i, k),
                    exact,
                    &format!("side {side} step {i} band {k}"),
                );
            }
        }
        eprintln!("side cut {side} step 20: {:?}", record.band_offsets_mm(20));
    }
    // Feed −X with the material at +Y: on the right.
    let record = flat_side_cut(1.0, -1.0);
    let steady = 60 - STEADY.end..60 - STEADY.start;
    for i in steady {
        assert_within_a_cell(
            record.band_offset_mm(i, 0),
            [-R, -(R - 2.0)],
            &format!("−X step {i}"),
        );
    }
    eprintln!("side cut −X step 30: {:?}", record.band_offsets_mm(30));
}

/// Along a diagonal: the material left of a move along (1, 1)/√2 (e = (y − x)/√2 ≥ 3)
/// gives e in [3, 5]; the same move backwards has it on the right.
#[test]
fn a_diagonal_side_cut_keeps_the_sign_convention() {
    let s2 = std::f64::consts::SQRT_2;
    let grid = Grid::covering(-10.0, -10.0, 40.0, 40.0, G).unwrap();
    let make = || {
        Stock::from_columns(grid, |ix, iy, out| {
            let (x, y) = (grid.x_mm(ix), grid.y_mm(iy));
            if (y - x) / s2 >= R - 2.0 && (-5.0..=35.0).contains(&x) {
                out.push([0.0, 10.0]);
            }
        })
        .unwrap()
    };
    let tool = Tool::flat(2.0 * R);
    // 30 steps of √2 mm from (−5, −5) to (25, 25).
    let diag: Vec<Step> = (0..30)
        .map(|k| {
            let (a, b) = (k as f64 - 5.0, k as f64 - 4.0);
            line([a, a, 8.0], [b, b, 8.0])
        })
        .collect();
    let record = run(&mut make(), &tool, &diag, &bands_1mm());
    let back: Vec<Step> = diag
        .iter()
        .rev()
        .map(|s| line(s.to_mm, s.from_mm))
        .collect();
    let record_back = run(&mut make(), &tool, &back, &bands_1mm());
    eprintln!(
        "diagonal step 15: {:?}, backwards: {:?}",
        record.band_offsets_mm(15),
        record_back.band_offsets_mm(15)
    );
    for i in 10..25 {
        for k in 0..2 {
            assert_within_a_cell(
                record.band_offset_mm(i, k),
                [R - 2.0, R],
                &format!("step {i} band {k}"),
            );
            assert_within_a_cell(
                record_back.band_offset_mm(i, k),
                [-R, -(R - 2.0)],
                &format!("back step {i} band {k}"),
            );
        }
    }
}

/// The ball's radius at height z above its tip.
fn ball_r(z: f64) -> f64 {
    (R * R - (R - z) * (R - z)).sqrt()
}

#[test]
fn a_ball_slot_spans_the_ball_radius_at_each_band_top() {
    let depth = 3.0;
    let mut stock = Stock::new_box([0.0, -10.0, 0.0], [40.0, 10.0, 10.0], G).unwrap();
    let steps = steps_mm([-10.0, 0.0, 10.0 - depth], [50.0, 0.0, 10.0 - depth]);
    let record = run(&mut stock, &Tool::ball(2.0 * R), &steps, &bands_1mm());
    for i in STEADY {
        assert_eq!(record.band_offsets_mm(i).len(), 3, "step {i}");
        for k in 0..3 {
            let r = ball_r(((k + 1) as f64).min(depth));
            assert_within_a_cell(
                record.band_offset_mm(i, k),
                [-r, r],
                &format!("step {i} band {k}"),
            );
        }
        assert_eq!(
            record.band_offset_mm(i, 3),
            None,
            "step {i}: band 3 lies above the cut"
        );
    }
    let i = STEADY.start + 5;
    eprintln!("ball slot step {i}: {:?}", record.band_offsets_mm(i));
    eprintln!(
        "exact: {:?}",
        (1..=3).map(|k| ball_r(k as f64)).collect::<Vec<_>>()
    );
}

#[test]
fn a_plunge_records_no_range() {
    for tool in [Tool::flat(2.0 * R), Tool::ball(2.0 * R)] {
        let mut stock = Stock::new_box([0.0, -10.0, 0.0], [20.0, 10.0, 10.0], G).unwrap();
        let steps = [
            line([10.0, 0.0, 12.0], [10.0, 0.0, 9.0]),
            line([10.0, 0.0, 9.0], [10.0, 0.0, 7.5]),
        ];
        let record = run(&mut stock, &tool, &steps, &bands_1mm());
        for i in 0..2 {
            assert!(record.volume_mm3(i) > 0.0);
            assert!(!record.band_offsets_mm(i).is_empty());
            assert_eq!(
                record.band_offsets_mm(i).len(),
                record.band_volumes_mm3(i).len()
            );
            for (k, &r) in record.band_offsets_mm(i).iter().enumerate() {
                assert_eq!(r, EMPTY_OFFSETS, "plunge {i} band {k}");
                assert_eq!(record.band_offset_mm(i, k), None);
            }
        }
    }
}

/// The same cuts with other strips, batches, smoothing and through a sink
/// give the same ranges bit for bit.
#[test]
fn ranges_do_not_depend_on_strips_batches_or_smoothing() {
    let grid = Grid::covering(-10.0, -10.0, 40.0, 40.0, G).unwrap();
    let make = || {
        Stock::from_columns(grid, |ix, iy, out| {
            let (x, y) = (grid.x_mm(ix), grid.y_mm(iy));
            // Stepped: deeper towards +Y, a pocket in the middle.
            let top = if y > 15.0 { 10.0 } else { 9.0 };
            if !(12.0..18.0).contains(&x) || !(0.0..6.0).contains(&y) {
                out.push([0.0, top]);
            }
        })
        .unwrap()
    };
    let mut steps = steps_mm([-5.0, 2.0, 7.5], [30.0, 2.0, 7.5]);
    steps.extend(steps_mm([30.0, 2.0, 7.5], [30.0, 20.0, 7.5]));
    steps.extend(steps_mm([30.0, 20.0, 7.5], [6.0, 12.0, 8.0]));
    steps.push(line([6.0, 12.0, 8.0], [6.0, 12.0, 6.0]));
    steps.extend(steps_mm([6.0, 12.0, 6.0], [6.0, 30.0, 6.0]));
    let ranges = |r: &RemovalRecord| -> Vec<Vec<[u32; 2]>> {
        (0..r.len())
            .map(|i| {
                r.band_offsets_mm(i)
                    .iter()
                    .map(|v| [v[0].to_bits(), v[1].to_bits()])
                    .collect()
            })
            .collect()
    };
    for tool in [
        Tool::ball(2.0 * R),
        Tool::flat(2.0 * R),
        Tool::bull(2.0 * R, 2.0),
    ] {
        let base = SweepOptions {
            band_height_mm: 0.7,
            ..SweepOptions::default()
        };
        let reference = run(&mut make(), &tool, &steps, &base);
        let expected = ranges(&reference);
        assert!(expected
            .iter()
            .flatten()
            .any(|r| r[0] != EMPTY_OFFSETS[0].to_bits()));
        for options in [
            SweepOptions {
                strip_rows: 1,
                batch_steps: 1,
                ..base
            },
            SweepOptions {
                strip_rows: 3,
                batch_steps: 7,
                batch_bytes: 4096,
                ..base
            },
            SweepOptions {
                strip_rows: 64,
                ..base
            },
        ] {
            let record = run(&mut make(), &tool, &steps, &options);
            assert_eq!(ranges(&record), expected, "{options:?}");
        }
        // Smoothing moves volumes between steps, not ranges; the kept bands
        // follow the volumes, so compare the bands both keep.
        let plain = run(
            &mut make(),
            &tool,
            &steps,
            &SweepOptions {
                smooth: false,
                ..base
            },
        );
        for (i, (a, b)) in ranges(&plain).iter().zip(&expected).enumerate() {
            let n = a.len().min(b.len());
            assert_eq!(a[..n], b[..n], "unsmoothed step {i}");
        }
        // A sink gets the record's ranges.
        let tools = [tool];
        let which = vec![0u8; steps.len()];
        let sweep = dexel::Sweep::new(&tools, &which, &steps[..], &base).unwrap();
        let mut sunk = Vec::new();
        sweep.whole_into(&mut make(), &|_| {}, &mut |_, row| {
            assert_eq!(row.band_offsets_mm().len(), row.band_volumes_mm3().len());
            sunk.push(
                row.band_offsets_mm()
                    .iter()
                    .map(|v| [v[0].to_bits(), v[1].to_bits()])
                    .collect::<Vec<_>>(),
            );
        });
        assert_eq!(sunk, expected);
    }
}
