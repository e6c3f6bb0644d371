//! Forces through a tooth period (MODEL.md §3.4) on straight cuts, end to
//! end: a box stock, one straight pass along +X, the steady steps' mean force
//! vector, power and peak from steps.csv against the closed forms of
//! `cutting::tooth` integrated over the cut's exact engagement (the arc at
//! each height, from the tool's profile and the stock's edge), with a linear
//! law (mc = 0: K_t = kc1_1) so that the comparison is of geometry alone.

#[allow(dead_code)]
mod common;

use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

use cutting::tooth::{mean_cut, BandArc, Coefficients, EdgeShape};

const KC: f64 = 1500.0;
const KR: f64 = 0.3;
const KA: f64 = 0.25;
const RPM: f64 = 6000.0;
const FLUTES: u32 = 2;
const FZ: f64 = 0.05;
const R: f64 = 5.0;
const COEFFICIENTS: Coefficients = Coefficients {
    kt_mpa: KC,
    radial_ratio: KR,
    axial_ratio: KA,
};

#[derive(Clone, Copy, Debug)]
enum Side {
    Slot,
    /// Material on the left of the feed: up milling for M3.
    Up,
    /// Material on the right: down milling.
    Down,
}

#[derive(Clone, Copy, Debug)]
struct Cut {
    name: &'static str,
    /// Corner radius: 0 flat, R ball.
    corner_mm: f64,
    ap_mm: f64,
    ae_mm: f64,
    side: Side,
}

/// The cut's exact arcs in `n` slices of its height (slices without an arc
/// left out): the stock's edge at `±(R − a_e)` from the path.
fn exact_arcs(cut: &Cut, n: usize) -> Vec<BandArc> {
    let shape = EdgeShape {
        radius_mm: R,
        corner_mm: cut.corner_mm,
    };
    (0..n)
        .filter_map(|i| {
            let (z0, z1) = (
                cut.ap_mm * i as f64 / n as f64,
                cut.ap_mm * (i + 1) as f64 / n as f64,
            );
            let r = shape.radius_at_mm(0.5 * (z0 + z1));
            let edge = (R - cut.ae_mm) / r;
            let (a, b) = match cut.side {
                Side::Slot => (0.0, PI),
                Side::Up | Side::Down if edge >= 1.0 => return None,
                Side::Up => (0.0, edge.max(-1.0).acos()),
                Side::Down => ((-edge).max(-1.0).acos(), PI),
            };
            Some(BandArc {
                z_lo_mm: z0,
                z_hi_mm: z1,
                phi_st_rad: a,
                phi_ex_rad: b,
            })
        })
        .collect()
}

/// The mean force [x, y, z] (N) and power (W) of the cut from the closed
/// forms, integrated over 400 slices of height with each slice's exact arc.
fn exact(cut: &Cut) -> ([f64; 3], f64) {
    let shape = EdgeShape {
        radius_mm: R,
        corner_mm: cut.corner_mm,
    };
    let (mut f, mut vol) = ([0.0; 3], 0.0);
    for arc in exact_arcs(cut, 400) {
        let m = mean_cut(&shape, FLUTES, &arc, FZ, &COEFFICIENTS);
        for (s, v) in f.iter_mut().zip(m.force_n) {
            *s += v;
        }
        vol += m.volume_mm3;
    }
    (f, KC * vol * RPM / 60.0 / 1000.0)
}

fn csv_columns(path: &Path) -> HashMap<String, Vec<f64>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let headers: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let mut cols: HashMap<String, Vec<f64>> =
        headers.iter().map(|h| (h.clone(), Vec::new())).collect();
    for rec in r.records() {
        let rec = rec.unwrap();
        for (h, v) in headers.iter().zip(rec.iter()) {
            cols.get_mut(h).unwrap().push(v.parse().unwrap_or(f64::NAN));
        }
    }
    cols
}

/// Simulated steady means of fx, fy, fz, power and force_peak_n, and of force_n.
fn simulated(cut: &Cut, grid_mm: f64, band_mm: f64) -> ([f64; 3], f64, f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let kind = if cut.corner_mm == 0.0 {
        "kind = \"flat\"".to_string()
    } else if cut.corner_mm == R {
        "kind = \"ball\"".to_string()
    } else {
        format!("kind = \"bull\"\ncorner_radius = {}", cut.corner_mm)
    };
    // The path at y = 0; the stock's edge at ±(R − a_e) on the material's side.
    let (y0, y1) = match cut.side {
        Side::Slot => (-20.0, 20.0),
        Side::Up => (R - cut.ae_mm, 20.0),
        Side::Down => (-20.0, -(R - cut.ae_mm)),
    };
    let top = 20.0;
    let feed = FZ * f64::from(FLUTES) * RPM;
    let job = format!(
        "[stock]\nkind = \"box\"\nmin = [0, {y0}, 0]\nmax = [60, {y1}, {top}]\ngrid = {grid_mm}\n\
         [tool]\n{kind}\ndiameter = {d}\nflutes = {FLUTES}\nflute_length = 20\nstickout = 40\n\
         youngs_modulus_mpa = 1e7\n\
         [program]\npath = \"pass.csv\"\nfeed = {feed}\n\
         [cutting]\nkc1_1 = {KC}\nmc = 0\nradial_ratio = {KR}\naxial_ratio = {KA}\n\
         band_height = {band_mm}\nspindle_rpm = {RPM}\nclosed_loop = false\n",
        d = 2.0 * R,
    );
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let z = top - cut.ap_mm;
    let csv: String = std::iter::once("x,y,z\n".to_string())
        .chain((0..=160).map(|i| format!("{},0,{z}\n", -10.0 + 0.5 * i as f64)))
        .collect();
    std::fs::write(dir.path().join("pass.csv"), csv).unwrap();
    let o = common::run(&["simulate", "job.toml", "--out", "out"], dir.path());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let steps = csv_columns(&dir.path().join("out/steps.csv"));
    let rows: Vec<usize> = (0..steps["x"].len())
        .filter(|&i| (15.0..=45.0).contains(&steps["x"][i]))
        .collect();
    let mean = |k: &str| rows.iter().map(|&i| steps[k][i]).sum::<f64>() / rows.len() as f64;
    (
        [mean("fx_n"), mean("fy_n"), mean("fz_n")],
        mean("power_w"),
        mean("force_peak_n"),
        mean("force_n"),
    )
}

const CUTS: [Cut; 11] = [
    Cut {
        name: "flat slot ap 2",
        corner_mm: 0.0,
        ap_mm: 2.0,
        ae_mm: 10.0,
        side: Side::Slot,
    },
    Cut {
        name: "flat side ae 2 up, ap 5",
        corner_mm: 0.0,
        ap_mm: 5.0,
        ae_mm: 2.0,
        side: Side::Up,
    },
    Cut {
        name: "flat side ae 2 down, ap 5",
        corner_mm: 0.0,
        ap_mm: 5.0,
        ae_mm: 2.0,
        side: Side::Down,
    },
    Cut {
        name: "flat wall ae 0.2 up, ap 10",
        corner_mm: 0.0,
        ap_mm: 10.0,
        ae_mm: 0.2,
        side: Side::Up,
    },
    Cut {
        name: "flat wall ae 0.2 down, ap 10",
        corner_mm: 0.0,
        ap_mm: 10.0,
        ae_mm: 0.2,
        side: Side::Down,
    },
    Cut {
        name: "bull r2 slot ap 1",
        corner_mm: 2.0,
        ap_mm: 1.0,
        ae_mm: 10.0,
        side: Side::Slot,
    },
    Cut {
        name: "bull r2 side ae 2 up, ap 3",
        corner_mm: 2.0,
        ap_mm: 3.0,
        ae_mm: 2.0,
        side: Side::Up,
    },
    Cut {
        name: "ball slot ap 1",
        corner_mm: R,
        ap_mm: 1.0,
        ae_mm: 10.0,
        side: Side::Slot,
    },
    Cut {
        name: "ball slot ap 3",
        corner_mm: R,
        ap_mm: 3.0,
        ae_mm: 10.0,
        side: Side::Slot,
    },
    Cut {
        name: "ball slot ap 5",
        corner_mm: R,
        ap_mm: 5.0,
        ae_mm: 10.0,
        side: Side::Slot,
    },
    Cut {
        name: "ball side ae 2 up, ap 2",
        corner_mm: R,
        ap_mm: 2.0,
        ae_mm: 2.0,
        side: Side::Up,
    },
];

/// Every straight cut's mean force within 3 % of the lateral force and
/// power within 2 % of the closed forms; the wall finishes push the tool away
/// from the wall; the peak is at least the mean. Prints the table of the
/// closing note (`cargo test --release -p dexcut-cli --test tooth_forces -- --nocapture`).
#[test]
fn straight_cuts_match_the_closed_forms() {
    eprintln!("| cut | Fx sim / exact N | Fy sim / exact N | Fz sim / exact N | power sim / exact W | mean lateral N | peak N | peak/mean |");
    eprintln!("|---|---|---|---|---|---|---|---|");
    for cut in &CUTS {
        let (f, p) = exact(cut);
        let (sf, sp, peak, mean_xy) = simulated(cut, 0.05, 0.25);
        let lateral = f[0].hypot(f[1]);
        eprintln!(
            "| {} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {:.1} / {:.1} | {:.2} | {:.2} | {:.2} |",
            cut.name, sf[0], f[0], sf[1], f[1], sf[2], f[2], sp, p, mean_xy, peak, peak / mean_xy
        );
        for d in 0..3 {
            assert!(
                (sf[d] - f[d]).abs() <= 0.03 * lateral,
                "{}: component {d}: {:.3} vs {:.3} (|F| {lateral:.3})",
                cut.name,
                sf[d],
                f[d]
            );
        }
        assert!(
            (sp - p).abs() <= 0.02 * p,
            "{}: power {sp} vs {p}",
            cut.name
        );
        assert!(
            peak >= mean_xy * 0.999,
            "{}: peak {peak} < mean {mean_xy}",
            cut.name
        );
        if cut.ae_mm < 1.0 {
            match cut.side {
                Side::Up => assert!(sf[1] < 0.0, "{}: {sf:?}", cut.name),
                Side::Down => assert!(sf[1] > 0.0, "{}: {sf:?}", cut.name),
                Side::Slot => {}
            }
        }
    }
}

/// Grid convergence: halving the cell (0.05 → 0.025 mm) moves the mean
/// force and the peak by under 1 %.
#[test]
fn forces_converge_with_the_grid() {
    for cut in [&CUTS[3], &CUTS[8]] {
        let (a, _, pa, ma) = simulated(cut, 0.05, 0.25);
        let (b, _, pb, mb) = simulated(cut, 0.025, 0.25);
        let la = a[0].hypot(a[1]);
        eprintln!(
            "{}: mean {ma:.3} → {mb:.3} N, peak {pa:.3} → {pb:.3} N",
            cut.name
        );
        for d in 0..3 {
            assert!(
                (a[d] - b[d]).abs() <= 0.01 * la,
                "{}: {a:?} vs {b:?}",
                cut.name
            );
        }
        assert!(
            (pa - pb).abs() <= 0.01 * pb,
            "{}: peak {pa} vs {pb}",
            cut.name
        );
    }
}

/// The error map of a wall finish (MODEL.md §5.2): a wall is left when a
/// tooth passes the flank, φ = 0 in up milling (material on the left of the
/// feed), φ = π in down milling, at each height of the tool. Each band's
/// deflection is the one at its mid-height at the instant a tooth there
/// passes the flank (the force through the tooth period then, of the cut's
/// exact arcs, spread over the bands by their volume on the tool's beam),
/// across the path, on the surface's outward normal; a column's error is
/// the largest in size over the face it stands for, from its top to its
/// highest neighbour's (linear between the bands' mid-heights). A flat end's
/// 0.2 mm wall stands on its lowest band's columns; a ball's lies on its
/// sphere 3.6–5 mm above the tip, in two bands, and above them. Up and down
/// milling the same wall give different errors, each of the sign and size
/// of its flank force.
#[test]
fn wall_errors_follow_the_force_when_each_band_leaves_the_wall() {
    let ball = |c: Cut, name| Cut {
        name,
        corner_mm: R,
        ..c
    };
    let cuts = [
        CUTS[3],
        CUTS[4],
        ball(CUTS[3], "ball wall ae 0.2 up, ap 10"),
        ball(CUTS[4], "ball wall ae 0.2 down, ap 10"),
    ];
    // Per cut, the mean error of each band's columns.
    let mut by_cut: Vec<std::collections::BTreeMap<usize, f64>> = Vec::new();
    for cut in &cuts {
        let dir = tempfile::tempdir().unwrap();
        let (y0, y1) = match cut.side {
            Side::Up => (R - cut.ae_mm, 20.0),
            _ => (-20.0, -(R - cut.ae_mm)),
        };
        let kind = if cut.corner_mm == 0.0 { "flat" } else { "ball" };
        let tip_z = 20.0 - cut.ap_mm;
        let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, {y0}, 0]\nmax = [60, {y1}, 20]\ngrid = 0.05\n\
             [tool]\nkind = \"{kind}\"\ndiameter = 10\nflutes = {FLUTES}\nflute_length = 20\nstickout = 60\n\
             youngs_modulus_mpa = 210000\n\
             [program]\npath = \"pass.csv\"\nfeed = {}\n\
             [cutting]\nkc1_1 = {KC}\nmc = 0\nradial_ratio = {KR}\naxial_ratio = {KA}\n\
             band_height = 1\nspindle_rpm = {RPM}\nclosed_loop = false\n",
            FZ * f64::from(FLUTES) * RPM
        );
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        let csv: String = std::iter::once("x,y,z\n".to_string())
            .chain((0..=160).map(|i| format!("{},0,{tip_z}\n", -10.0 + 0.5 * i as f64)))
            .collect();
        std::fs::write(dir.path().join("pass.csv"), csv).unwrap();
        let o = common::run(&["simulate", "job.toml", "--out", "out"], dir.path());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The tool's beam, as the job gives it.
        let setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
        let model = &setup.tools.entries[0].model;
        // Each 1 mm band's volume (per revolution: in proportion to the
        // steady cut's), and its flank forces, of the exact arcs.
        let shape = EdgeShape {
            radius_mm: R,
            corner_mm: cut.corner_mm,
        };
        let arcs = exact_arcs(cut, 400);
        let mut bands = vec![0.0; 10];
        for a in &arcs {
            bands[a.z_lo_mm as usize] += mean_cut(&shape, FLUTES, a, FZ, &COEFFICIENTS).volume_mm3;
        }
        let mut flanks = vec![[[0.0; 2]; 2]; 10];
        cutting::tooth::peak_cut(
            &shape,
            &cutting::tooth::Teeth {
                flutes: FLUTES,
                helix_deg: 30.0,
            },
            &arcs.iter().map(|&a| (a, FZ)).collect::<Vec<_>>(),
            &COEFFICIENTS,
            1.0,
            &mut flanks,
            &mut cutting::tooth::PeakScratch::default(),
        );
        let side = usize::from(!matches!(cut.side, Side::Up));
        // Band k's deflection across the path (y), µm.
        let band_um = |k: usize| {
            flanks[k][side][1] * 1000.0 * model.compliance_at_mm_per_n(&bands, k as f64 + 0.5)
        };
        // At z over the tip: linear between the bands' mid-heights.
        let across_um = |z: f64| {
            let u = (z - 0.5).clamp(0.0, 9.0);
            let k = (u.floor() as usize).min(8);
            band_um(k) + (u - k as f64) * (band_um(k + 1) - band_um(k))
        };
        // The map, and the final surface's normals from its tops.
        let cols = common::grid_columns(&dir.path().join("out"));
        let at = |ix: f64, iy: f64| (ix as usize, iy as usize);
        let col = |name: &str, i: usize| cols[name][i];
        let tops: HashMap<(usize, usize), f32> = (0..cols["ix"].len())
            .map(|i| (at(col("ix", i), col("iy", i)), col("top_mm", i) as f32))
            .collect();
        let (nx, ny) = tops
            .keys()
            .fold((0, 0), |(a, b), &(x, y)| (a.max(x + 1), b.max(y + 1)));
        let top = |ix: usize, iy: usize| tops.get(&(ix, iy)).copied().unwrap_or(f32::NAN);
        let mut errors: std::collections::BTreeMap<usize, Vec<f64>> = Default::default();
        for i in 0..cols["ix"].len() {
            let e = col("error_um", i);
            if !(15.0..=45.0).contains(&col("x_mm", i)) || !e.is_finite() {
                continue;
            }
            let z = col("top_mm", i) - tip_z;
            let k = z.floor().max(0.0) as usize;
            let (ix, iy) = at(col("ix", i), col("iy", i));
            let n = cutting::surface_normal_at(top, nx, ny, ix, iy, 0.05).map(f64::from);
            // The face the column stands for, from its top to its highest
            // neighbour's within the tool's 10 bands: its error of largest
            // size at the ends and the bands' mid-heights.
            // (Off the grid, a wrapped index: no column, NaN.)
            let (xl, yl) = (ix.wrapping_sub(1), iy.wrapping_sub(1));
            let highest = [(xl, iy), (ix + 1, iy), (ix, yl), (ix, iy + 1)]
                .map(|(x, y)| f64::from(top(x, y)) - tip_z)
                .into_iter()
                .filter(|t| t.is_finite())
                .fold(z, f64::max)
                .min(10.0);
            let want = std::iter::once(z)
                .chain(
                    (0..10)
                        .map(|k| k as f64 + 0.5)
                        .filter(|&m| m > z && m < highest),
                )
                .chain(std::iter::once(highest))
                .map(|z| cutting::surface_error_um([0.0, across_um(z)], n))
                .fold(0.0, |w: f64, e| if e.abs() > w.abs() { e } else { w });
            // (A column between two cut ones lies on the floor: no error.)
            if n[1].abs() < 1e-6 {
                assert!(e.abs() < 1e-6, "{}: column ({ix}, {iy}): {e} µm", cut.name);
                continue;
            }
            assert!(want.abs() > 0.01, "{}: band {k}: {want} µm", cut.name);
            // Within 10 %, and 0.15 µm: each band's arcs span its whole
            // height (MODEL.md §3.4), where on the sphere the lowest band
            // cut starts above its foot.
            assert!(
                (e - want).abs() <= 0.1 * want.abs() + 0.15,
                "{}: column ({ix}, {iy}), band {k}: {e} µm vs {want} µm",
                cut.name
            );
            errors.entry(k).or_default().push(e);
        }
        let means: std::collections::BTreeMap<usize, f64> = errors
            .iter()
            .map(|(&k, v)| (k, v.iter().sum::<f64>() / v.len() as f64))
            .collect();
        eprintln!("{}: mean error by band {means:?} µm", cut.name);
        by_cut.push(means);
    }
    // The flat end leaves its walls with the lowest band, the ball with two.
    for (cut, means) in cuts.iter().zip(&by_cut) {
        let bands: Vec<usize> = means.keys().copied().collect();
        let want = if cut.corner_mm == 0.0 {
            vec![0]
        } else {
            vec![3, 4]
        };
        assert_eq!(bands, want, "{}", cut.name);
    }
    // Up milling, the ball's band 4 leaves its wall where more of the edge
    // below it is in the cut than band 3's.
    let up = &by_cut[2];
    assert!(up[&4] > 1.3 * up[&3], "{up:?}");
    // Up and down milling leave different errors.
    for pair in by_cut.chunks(2) {
        let (up, down) = (pair[0].values().sum::<f64>(), pair[1].values().sum::<f64>());
        assert!(
            (up - down).abs() > 0.2 * up.abs().max(down.abs()),
            "{pair:?}"
        );
    }
}
