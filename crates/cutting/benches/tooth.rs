//! The force through one tooth period (`tooth::peak_cut`, MODEL.md §3.4):
//! what every step's load and every engagement interval's reference load pay
//! for their peak and flank forces. Cuts of the size the benchmark programs
//! make (BENCHMARKS.md): a Ø2 ball finishing a relief and cutting 5 mm up its wall (real program A), a Ø10
//! ball's raster pass 1 mm deep, and a Ø10 four-flute flat end's side cut over
//! two bands.
use criterion::{criterion_group, criterion_main, Criterion};
use cutting::tooth::{peak_bound, peak_cut, PeakScratch};
use cutting::{BandArc, Coefficients, EdgeShape, Teeth};
use std::f64::consts::PI;
use std::hint::black_box;

const C: Coefficients = Coefficients {
    kt_mpa: 2100.0,
    radial_ratio: 0.35,
    axial_ratio: 0.2,
};

struct Case {
    name: &'static str,
    shape: EdgeShape,
    teeth: Teeth,
    band_height_mm: f64,
    bands: Vec<(BandArc, f64)>,
}

fn arc(z_lo_mm: f64, z_hi_mm: f64, phi_st_rad: f64, phi_ex_rad: f64) -> BandArc {
    BandArc {
        z_lo_mm,
        z_hi_mm,
        phi_st_rad,
        phi_ex_rad,
    }
}

fn cases() -> Vec<Case> {
    let two = Teeth {
        flutes: 2,
        helix_deg: 30.0,
    };
    vec![
        Case {
            name: "ball_d2_finish",
            shape: EdgeShape::ball(1.0),
            teeth: two,
            band_height_mm: 1.0,
            bands: vec![(arc(0.0, 0.35, 0.2, 1.9), 0.004)],
        },
        Case {
            // Real program A's deepest passes: the relief's wall, 5 mm up a Ø2 ball.
            name: "ball_d2_deep",
            shape: EdgeShape::ball(1.0),
            teeth: two,
            band_height_mm: 1.0,
            bands: (0..5)
                .map(|k| {
                    let z = f64::from(k);
                    (arc(z, z + 1.0, 0.3, PI - 0.1 * z), 0.01)
                })
                .collect(),
        },
        Case {
            name: "ball_d10_raster",
            shape: EdgeShape::ball(5.0),
            teeth: two,
            band_height_mm: 1.0,
            bands: vec![
                (arc(0.0, 1.0, 0.4, 2.6), 0.03),
                (arc(1.0, 1.4, 1.2, 2.2), 0.01),
            ],
        },
        Case {
            name: "flat_d10_side",
            shape: EdgeShape::flat(5.0),
            teeth: Teeth {
                flutes: 4,
                helix_deg: 35.0,
            },
            band_height_mm: 2.0,
            bands: vec![
                (arc(0.0, 2.0, PI - 1.2, PI), 0.05),
                (arc(2.0, 3.5, PI - 1.2, PI), 0.05),
            ],
        },
    ]
}

fn bench(c: &mut Criterion) {
    for case in cases() {
        let mut scratch = PeakScratch::default();
        let mut flanks = vec![[[0.0; 2]; 2]; case.bands.len()];
        c.bench_function(&format!("peak_cut_{}", case.name), |b| {
            b.iter(|| {
                peak_cut(
                    black_box(&case.shape),
                    &case.teeth,
                    black_box(&case.bands),
                    &C,
                    case.band_height_mm,
                    &mut flanks,
                    &mut scratch,
                )
            })
        });
        // What the closed loop's plan takes instead (MODEL.md §3.4, "A bound on the peak").
        c.bench_function(&format!("peak_bound_{}", case.name), |b| {
            b.iter(|| {
                peak_bound(
                    black_box(&case.shape),
                    &case.teeth,
                    black_box(&case.bands),
                    &C,
                )
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
