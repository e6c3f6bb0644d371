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

/// The mean force [x, y, z] (N) and power (W) of the cut from the closed
/// forms, integrated over 400 slices of height with each slice's exact arc.
fn exact(cut: &Cut) -> ([f64; 3], f64) {
    let shape = EdgeShape {
        radius_mm: R,
        corner_mm: cut.corner_mm,
    };
    let c = Coefficients {
        kt_mpa: KC,
        radial_ratio: KR,
        axial_ratio: KA,
    };
    let n = 400;
    let (mut f, mut vol) = ([0.0; 3], 0.0);
    for i in 0..n {
        let (z0, z1) = (
            cut.ap_mm * i as f64 / n as f64,
            cut.ap_mm * (i + 1) as f64 / n as f64,
        );
        let r = shape.radius_at_mm(0.5 * (z0 + z1));
        // The stock's edge at e = ±(R − a_e) from the path.
        let edge = (R - cut.ae_mm) / r;
        let (a, b) = match cut.side {
            Side::Slot => (0.0, PI),
            Side::Up if edge >= 1.0 => continue,
            Side::Up => (0.0, edge.max(-1.0).acos()),
            Side::Down if edge >= 1.0 => continue,
            Side::Down => ((-edge).max(-1.0).acos(), PI),
        };
        let arc = BandArc {
            z_lo_mm: z0,
            z_hi_mm: z1,
            phi_st_rad: a,
            phi_ex_rad: b,
        };
        let m = mean_cut(&shape, FLUTES, &arc, FZ, &c);
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

/// The error map of a wall finish (MODEL.md §5.2): a flat end leaves the
/// wall when a tooth passes the flank, φ = 0 in up milling (material on the
/// left), φ = π in down milling; the error there is the deflection at that
/// instant across the wall, not the mean's. Up and down milling the same
/// 0.2 mm wall give different errors, each of the sign and size of the
/// flank force (through the tool's compliance, the mean deflection over the
/// mean force), against the wall's outward normal (−y up, +y down).
#[test]
fn wall_errors_follow_the_force_when_the_tooth_leaves_the_wall() {
    let mut errors = Vec::new();
    for cut in [&CUTS[3], &CUTS[4]] {
        let dir = tempfile::tempdir().unwrap();
        let (y0, y1) = match cut.side {
            Side::Up => (R - cut.ae_mm, 20.0),
            _ => (-20.0, -(R - cut.ae_mm)),
        };
        let job = format!(
            "[stock]\nkind = \"box\"\nmin = [0, {y0}, 0]\nmax = [60, {y1}, 20]\ngrid = 0.05\n\
             [tool]\nkind = \"flat\"\ndiameter = 10\nflutes = {FLUTES}\nflute_length = 20\nstickout = 60\n\
             youngs_modulus_mpa = 210000\n\
             [program]\npath = \"pass.csv\"\nfeed = {}\n\
             [cutting]\nkc1_1 = {KC}\nmc = 0\nradial_ratio = {KR}\naxial_ratio = {KA}\n\
             band_height = 1\nspindle_rpm = {RPM}\nclosed_loop = false\n",
            FZ * f64::from(FLUTES) * RPM
        );
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        let csv: String = std::iter::once("x,y,z\n".to_string())
            .chain(
                (0..=160).map(|i| format!("{},0,{}\n", -10.0 + 0.5 * i as f64, 20.0 - cut.ap_mm)),
            )
            .collect();
        std::fs::write(dir.path().join("pass.csv"), csv).unwrap();
        let o = common::run(&["simulate", "job.toml", "--out", "out"], dir.path());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap(),
        )
        .unwrap();
        let run = &summary;
        let (lo, hi) = (
            run["min_error_um"].as_f64().unwrap(),
            run["max_error_um"].as_f64().unwrap(),
        );
        let error = if hi.abs() > lo.abs() { hi } else { lo };
        // The flank force of the exact cut, and the tool's compliance from
        // the steady steps (mean deflection over mean force).
        let steps = csv_columns(&dir.path().join("out/steps.csv"));
        let rows: Vec<usize> = (0..steps["x"].len())
            .filter(|&i| (15.0..=45.0).contains(&steps["x"][i]))
            .collect();
        let mean = |k: &str| rows.iter().map(|&i| steps[k][i]).sum::<f64>() / rows.len() as f64;
        let um_per_n = mean("deflection_um") / mean("force_n");
        let shape = EdgeShape::flat(R);
        let arc = BandArc::side_cut(R, cut.ae_mm, 0.0, cut.ap_mm, matches!(cut.side, Side::Up));
        let bands: Vec<(BandArc, f64)> = (0..10)
            .map(|k| {
                let mut a = arc;
                a.z_lo_mm = k as f64;
                a.z_hi_mm = k as f64 + 1.0;
                (a, FZ)
            })
            .collect();
        let c = Coefficients {
            kt_mpa: KC,
            radial_ratio: KR,
            axial_ratio: KA,
        };
        let p = cutting::tooth::peak_cut(
            &shape,
            &cutting::tooth::Teeth {
                flutes: FLUTES,
                helix_deg: 30.0,
            },
            &bands,
            &c,
            mean("contact_height_mm"),
            &mut cutting::tooth::PeakScratch::default(),
        );
        let expected = match cut.side {
            Side::Up => -p.at_left_flank_n[1] * um_per_n,
            _ => p.at_right_flank_n[1] * um_per_n,
        };
        eprintln!(
            "{}: error {error:.3} µm, flank force across the wall {expected:.3} µm",
            cut.name
        );
        assert!(expected.abs() > 0.5, "{}: {expected}", cut.name);
        assert!(
            (error - expected).abs() <= 0.1 * expected.abs(),
            "{}: {error} vs {expected}",
            cut.name
        );
        errors.push(error);
    }
    assert!(
        (errors[0] - errors[1]).abs() > 0.2 * errors[0].abs().max(errors[1].abs()),
        "{errors:?}"
    );
}
