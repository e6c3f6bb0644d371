//! The closed loop of removal and deflection (MODEL.md §5.1) against its
//! closed form. A Ø10 flat end finishes a wall with radial stock a = 0.2 mm
//! (10 mm deep, CSV points 0.5 mm apart, grid 0.01 mm) under S4's force law
//! with n = 1, so the force, and the deflection δ across the path, is
//! proportional to the engaged width: moved off the wall by d, the tool cuts
//! a − d and bends by δ₀ (a − d)/a, δ₀ the rigid tool's deflection. The
//! equilibrium d = δ₀ (a − d)/a is d* = δ₀ a/(a + δ₀) (with the stiffness k
//! and the force per width c: δ₀ = c a/k, d* = c a/(k + c)).
//!
//! The plain iteration d ← δ₀ (a − d)/a has slope −δ₀/a: it converges only
//! for δ₀ < a. Checked for a stiff tool (δ₀ ≈ 1 µm), one at the limit
//! (δ₀ ≈ a) and compliant ones (δ₀ ≈ 5 a and 20 a, where plain iteration
//! diverges).
//! The grid resolves the engaged width to 0.01 mm, so the discrete
//! equilibrium lies within δ₀/(a + δ₀)·g/2 ≤ 5 µm of d*; the direction of
//! the force turns by about 1 % as the engagement narrows (the contact
//! resultant, §1.4): tolerance 5 µm + 2 %.

use std::path::Path;

const JOB: &str = r#"
[stock]
kind = "box"
min = [0, -6, 0]
max = [30, -4.8, 30]
grid = 0.01
[tool]
kind = "flat"
diameter = 10
flute_length = 20
stickout = 40
holder_stiffness_n_per_um = HOLDER
[program]
path = "wall.csv"
feed = 1200
[cutting]
band_height = 1.0
spindle_rpm = 6000
model = "power_law"
force_a = 100
force_n = 1
closed_loop = LOOP
"#;

/// Steps whose tool is at 10 ≤ x ≤ 20 mm (the steady part of the wall).
fn steady(run: &dexcut::Run) -> Vec<usize> {
    (0..run.steps.len())
        .filter(|&i| (10.0..=20.0).contains(&run.steps[i].step.to_mm[0]))
        .collect()
}

fn simulate(dir: &Path, holder: &str, closed: bool) -> dexcut::Simulation {
    let job = JOB
        .replace("HOLDER", holder)
        .replace("LOOP", if closed { "true" } else { "false" });
    let path = dir.join(format!("{holder}_{closed}.toml"));
    std::fs::write(&path, job).unwrap();
    let setup = dexcut::load(&path, None).unwrap();
    dexcut::commands::simulate_setup(&setup, false).unwrap()
}

#[test]
fn closed_loop_finds_the_equilibrium_of_a_force_linear_in_the_engaged_width() {
    let dir = tempfile::tempdir().unwrap();
    let csv: String = std::iter::once("x,y,z\n".to_string())
        .chain((0..=100).map(|i| format!("{},0,20\n", -10.0 + 0.5 * i as f64)))
        .collect();
    std::fs::write(dir.path().join("wall.csv"), csv).unwrap();
    let a = 200.0;
    for (holder, delta0_range) in [
        ("1e12", (0.5, 2.0)),
        ("0.1", (150.0, 250.0)),
        ("0.02", (800.0, 1200.0)),
        ("0.005", (3000.0, 5000.0)),
    ] {
        // δ₀: the rigid tool's deflection across the path (+y, off the wall).
        let open = simulate(dir.path(), holder, false);
        let rigid: Vec<f64> = steady(&open.run)
            .iter()
            .map(|&i| open.run.loads[i].dy_um)
            .collect();
        let delta0 = rigid[0];
        assert!(
            rigid.iter().all(|d| (d - delta0).abs() < 1e-6 * delta0),
            "{holder}: the rigid deflection is not steady: {rigid:?}"
        );
        assert!(
            (delta0_range.0..delta0_range.1).contains(&delta0),
            "{holder}: δ₀ {delta0} µm"
        );
        let expected = delta0 * a / (a + delta0);
        let closed = simulate(dir.path(), holder, true);
        let run = &closed.run;
        for &i in &steady(run) {
            let [dx, dy] = run.offsets_um[i];
            assert!(
                (dy - expected).abs() <= 5.0 + 0.02 * expected,
                "{holder}: step {i} at offset {dy} µm, closed form {expected} µm (δ₀ {delta0} µm)"
            );
            assert!(dx.abs() < 1e-9, "{holder}: offset along the path {dx}");
            // The deflection reported is the equilibrium's too (at a root on
            // a jump of the removal, the load scaled to it).
            let bent = run.loads[i].dy_um;
            assert!(
                (bent - expected).abs() <= 5.0 + 0.02 * expected,
                "{holder}: step {i} deflects {bent} µm, closed form {expected} µm"
            );
        }
        // Every steady step within the loop's tolerance; what is left out
        // (the compliant tool) lies where the tool enters or leaves the wall.
        for &(i, r) in &run.closed_loop.unconverged {
            let x = run.steps[i].step.to_mm[0];
            assert!(
                !(10.0..=20.0).contains(&x),
                "{holder}: step {i} at x {x} left out of tolerance by {r} µm"
            );
        }
        eprintln!(
            "{holder}: δ₀ {delta0:.3} µm, d* {expected:.3} µm, {} sweeps, converged {}, residual {:.3} µm",
            run.closed_loop.passes, run.closed_loop.converged, run.closed_loop.residual_um
        );
        if holder == "1e12" || holder == "0.1" {
            assert!(run.closed_loop.converged, "{holder}: {:?}", run.closed_loop);
        }
        // The stiff tool barely bends: its offset cannot change its load by
        // more than the tolerance (MODEL.md §5.1, eq. 5.1e), so the rigid
        // sweep settles the loop, and the deflection it reports is within
        // the loop's tolerance of the closed form; the others run the loop.
        let settled = holder == "1e12";
        assert_eq!(
            run.closed_loop.settled, settled,
            "{holder}: {:?}",
            run.closed_loop
        );
        if settled {
            assert_eq!(run.closed_loop.passes, 1);
            assert!(run.closed_loop.residual_um <= 0.5, "{:?}", run.closed_loop);
            for &i in &steady(run) {
                let bent = run.loads[i].dy_um;
                assert!(
                    (bent - expected).abs() <= 0.5 + 0.02 * expected,
                    "step {i} deflects {bent} µm, closed form {expected} µm"
                );
            }
        }
        // No offset beyond the stock the tool can be pushed out of.
        for o in &run.offsets_um {
            assert!(o[1] <= a + 1e-9, "offset {o:?} beyond the {a} µm of stock");
        }
    }
}

/// A drill cycle (pcb2gcode's, 0.4 mm drill, G81 in inches) into a box: an
/// even plunge pushes the tool sideways by nothing (the contact resultant
/// without the lattice's bias, MODEL.md §1.4), so the loop has nothing to
/// do. Before, the grid's asymmetry under the hole gave 0.47 N sideways, a
/// 477 µm deflection of the 13.6 mm long tool and a loop that diverged to
/// 27 mm.
#[test]
fn a_plunge_does_not_bend_the_tool() {
    let dir = tempfile::tempdir().unwrap();
    let job = r#"
[stock]
kind = "box"
min = [-2.2, -22.52, -2.6]
max = [44.11, 2.2, 0]
grid = 0.05
[tool]
kind = "flat"
diameter = 0.4
flute_length = 3.6
stickout = 13.6
[program]
path = "drill.ngc"
[cutting]
material = "al6061"
"#;
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    std::fs::write(
        dir.path().join("drill.ngc"),
        "G94 G20 G90\nS12000 M3\nG0 Z0.08\nG81 R0.08 Z-0.06299 F30 X0.9 Y-0.45\nX1.65 Y-0.55\nX1.65 Y-0.8\nG80\nG0 Z1\nM2\n",
    )
    .unwrap();
    let setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
    let sim = dexcut::commands::simulate_setup(&setup, false).unwrap();
    let s = &sim.summary;
    assert!(s.removed_volume_mm3 > 0.5, "{}", s.removed_volume_mm3);
    assert!(s.peak_force_n < 1e-9, "sideways force {} N", s.peak_force_n);
    assert!(s.peak_deflection_um < 1e-6, "{} µm", s.peak_deflection_um);
    assert!(
        s.closed_loop_converged && s.closed_loop_passes == 1,
        "{s:?}"
    );
}

/// A slot cut in four layers, each entered by a plunge at the slot's end
/// (blendercam_Op_Cutout_Layers' pattern). An even plunge has no sideways
/// load: its rigid resultant is round-off (10⁻¹⁵ µm), and a direction made
/// from it sent the loop after the plunges, each moved by its own noise and
/// starting where the one before it ended (on main at dcebdb6: 9 sweeps, 11
/// steps out by up to 8.4 µm, all plunges or the cut right after them). The
/// plunges stay where the program puts them (with a direction made of
/// round-off they move: this test fails at the offset check), and the loop
/// converges (5 sweeps at dcebdb6, 9 at aad65ed).
#[test]
fn plunges_between_layers_stay_put_and_the_loop_converges() {
    let dir = tempfile::tempdir().unwrap();
    let job = r#"
[stock]
kind = "box"
min = [-5, -5, -4]
max = [25, 5, 0]
grid = 0.1
[tool]
kind = "flat"
diameter = 3
flute_length = 9
stickout = 19
shank_diameter = 3.175
[program]
path = "layers.ngc"
[cutting]
material = "al6061"
[machine]
feed_max = 5000
rapid = 10000
"#;
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    std::fs::write(
        dir.path().join("layers.ngc"),
        "G21 G90 G94\nS10000 M3\nG0 X0 Y0 Z1\nG1 Z0 F500\n\
         G1 Z-1 F100\nG1 X20 F1000\nG1 Z-2 F100\nG1 X0 F1000\n\
         G1 Z-3 F100\nG1 X20 F1000\nG1 Z-4 F100\nG1 X0 F1000\nG0 Z1\nM2\n",
    )
    .unwrap();
    let setup = dexcut::load(&dir.path().join("job.toml"), None).unwrap();
    let sim = dexcut::commands::simulate_setup(&setup, false).unwrap();
    let run = &sim.run;
    let mut plunges = 0;
    for (i, s) in run.steps.iter().enumerate() {
        let [fx, fy, fz] = s.step.from_mm;
        let [tx, ty, tz] = s.step.to_mm;
        if !s.step.rapid && fx == tx && fy == ty && tz < fz && fz < 0.0 {
            plunges += 1;
            assert_eq!(run.offsets_um[i], [0.0, 0.0], "plunge step {i} moved");
        }
    }
    assert!(plunges >= 3, "{plunges} plunge steps in the stock");
    let s = &sim.summary;
    assert!(s.peak_deflection_um > 10.0, "{} µm", s.peak_deflection_um);
    assert!(s.closed_loop_converged, "{:?}", run.closed_loop);
}

/// The wall above cut at F30 as G-code: 8 µm of path per 16 ms servo period
/// on the 10 µm grid, so a step's load comes in whole columns (MODEL.md
/// §1.5) and g jumps from step to step (4.3…6.0 µm on the steady wall at
/// the end) while the grid resolves it over six cells of path (§2.3). The
/// loop counts such a step within tolerance where the mean residual over that
/// window is, less the grid's resolution of it (MODEL.md §5.1). Before, the
/// loop chased the steps' column noise and stopped unconverged after 9 sweeps
/// (47 steps out by up to 12.4 µm). The mean offset of the steady wall is the
/// closed form's d* = δ₀ a/(a + δ₀) within the loop's tolerance.
#[test]
fn a_sub_cell_advance_converges_over_the_grids_window() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("wall.ngc"),
        "G21 G90 G94\nG0 X-10 Y0 Z20\nG1 X40 F30\nM2\n",
    )
    .unwrap();
    let run = |closed: bool| {
        let job = JOB
            .replace("path = \"wall.csv\"\nfeed = 1200", "path = \"wall.ngc\"")
            .replace("HOLDER", "0.1")
            .replace("LOOP", if closed { "true" } else { "false" });
        let path = dir.path().join(format!("slow_{closed}.toml"));
        std::fs::write(&path, job).unwrap();
        let setup = dexcut::load(&path, None).unwrap();
        dexcut::commands::simulate_setup(&setup, false).unwrap()
    };
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let open = run(false);
    let steady_open = steady(&open.run);
    assert!(steady_open.len() > 1000, "{} steps", steady_open.len());
    let advance = open.run.steps[steady_open[1]].step.to_mm[0]
        - open.run.steps[steady_open[1]].step.from_mm[0];
    assert!(advance < 0.01, "{advance} mm per step");
    let a = 200.0;
    let delta0 = mean(
        &steady_open
            .iter()
            .map(|&i| open.run.loads[i].dy_um)
            .collect::<Vec<_>>(),
    );
    assert!((4.0..6.0).contains(&delta0), "δ₀ {delta0} µm");
    let expected = delta0 * a / (a + delta0);
    let closed = run(true);
    let r = &closed.run;
    assert!(
        r.closed_loop.converged && r.closed_loop.passes <= 5,
        "{:?}",
        r.closed_loop
    );
    let offset = mean(
        &steady(r)
            .iter()
            .map(|&i| r.offsets_um[i][1])
            .collect::<Vec<_>>(),
    );
    assert!(
        (offset - expected).abs() <= 0.5 + 0.02 * expected,
        "mean offset {offset} µm, closed form {expected} µm (δ₀ {delta0} µm)"
    );
}

/// The wall above (holder 0.1 N/µm, δ₀ ≈ 197 µm, d* ≈ 99 µm), then the tool
/// lifts out of it at feed at the wall's end: 40 steps of `Z+0.05 F220` at
/// one point, as Fusion's `Z-10.294667 F220` after a cut along a wall on
/// fusion_led_floor_light_holes. Each lift takes the wall's direction (eq.
/// 5.1a) and starts at the offset the step before left. Sought as a fraction
/// of it, its only sideways cut is its own sweep from that offset, which the
/// grid removes as whole rows of columns or none: g jumps between 0 and a
/// row's load at a place the offsets before it move, and the loop chased it
/// (before eq. 5.1d: 16 sweeps, 9 steps out by up to 132 µm, the lifts'
/// deflection up to 132 µm against the wall's 99). A step at one point keeps
/// the offset it starts at (MODEL.md §5.1, eq. 5.1d): the lifts stay at the
/// wall's offset, cut nothing sideways, the loop converges, and the steady
/// wall's offset and deflection are the closed form's d* within 5 µm + 2 %.
#[test]
fn lifts_at_the_end_of_a_wall_keep_its_offset_and_the_loop_settles() {
    let dir = tempfile::tempdir().unwrap();
    let csv: String = std::iter::once("x,y,z,feed\n".to_string())
        .chain((0..=50).map(|i| format!("{},0,20,1200\n", -10.0 + 0.5 * i as f64)))
        .chain((1..=40).map(|k| format!("15,0,{:.2},220\n", 20.0 + 0.05 * k as f64)))
        .collect();
    std::fs::write(dir.path().join("wall.csv"), csv).unwrap();
    let (a, holder) = (200.0, "0.1");
    let open = simulate(dir.path(), holder, false);
    let delta0 = open.run.loads[steady(&open.run)[0]].dy_um;
    let expected = delta0 * a / (a + delta0);
    let closed = simulate(dir.path(), holder, true);
    let run = &closed.run;
    eprintln!(
        "δ₀ {delta0:.3} µm, d* {expected:.3} µm, {} sweeps, converged {}, residual {:.3} µm",
        run.closed_loop.passes, run.closed_loop.converged, run.closed_loop.residual_um
    );
    assert!(run.closed_loop.converged, "{:?}", run.closed_loop);
    // The steady wall (the lifts at x = 15 mm excepted).
    let along_the_wall = |i: usize| run.steps[i].step.from_mm[0] != run.steps[i].step.to_mm[0];
    for i in steady(run).into_iter().filter(|&i| along_the_wall(i)) {
        let (dy, bent) = (run.offsets_um[i][1], run.loads[i].dy_um);
        assert!(
            (dy - expected).abs() <= 5.0 + 0.02 * expected,
            "step {i} at offset {dy} µm, closed form {expected} µm (δ₀ {delta0} µm)"
        );
        assert!(
            (bent - expected).abs() <= 5.0 + 0.02 * expected,
            "step {i} deflects {bent} µm, closed form {expected} µm"
        );
    }
    let at_point = |i: usize| {
        let s = &run.steps[i].step;
        !s.rapid && s.from_mm[..2] == s.to_mm[..2] && s.to_mm[2] > s.from_mm[2]
    };
    let lifts: Vec<usize> = (0..run.steps.len()).filter(|&i| at_point(i)).collect();
    assert!(lifts.len() >= 40, "{} lifts", lifts.len());
    let wall_end = lifts[0] - 1;
    assert!(!at_point(wall_end));
    let held = run.offsets_um[wall_end];
    assert!(
        (held[1] - expected).abs() <= 5.0 + 0.02 * expected,
        "the wall's last step at {held:?} µm"
    );
    for &i in &lifts {
        assert_eq!(run.offsets_um[i], held, "lift {i}");
        // No sideways sweep: no more deflection than the wall's.
        assert!(
            run.loads[i].dy_um.abs() <= expected + 5.0 + 0.02 * expected,
            "lift {i} deflects {} µm",
            run.loads[i].dy_um
        );
    }
}
