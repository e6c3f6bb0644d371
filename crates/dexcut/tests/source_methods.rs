//! The source methods against their exact answers: S3's cutting-surface angle
//! (MODEL.md §6.3).

use std::path::{Path, PathBuf};

use dexcut::commands::Setup;
use dexcut::optimize::{self, SurfaceFrom};
use schedule::CapKind;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A job with a Ø10 ball, S3's rule (v0 300 mm/min) and no other limit that binds.
fn job(stock: &str, extra: &str) -> String {
    format!(
        "{stock}\n[tool]\nkind = \"ball\"\ndiameter = 10\nfz_max = 10\n\
         [program]\npath = \"part.nc\"\n[cutting]\nmaterial = \"al6061\"\n\
         [machine]\nfeed_max = 3000\nrapid = 10000\naccel = [1000, 1000, 1000]\n\
         [limits]\nangle_rule = true\nv0 = 300\n{extra}"
    )
}

/// Caps of the cutting intervals whose middle satisfies `keep`, after S3.
fn caps_where(
    dir: &Path,
    surface: fn(&Setup) -> SurfaceFrom,
    keep: impl Fn([f64; 3]) -> bool,
) -> Vec<(f64, CapKind)> {
    let setup = Setup::load(&dir.join("job.toml"), None).unwrap();
    let limits = &setup.job.limits;
    let machine = optimize::optimising_machine(&setup.machine, limits);
    let stations = optimize::free_stations(&setup.program.path, &machine).unwrap();
    let engagement =
        optimize::engagement(&stations, &setup.stock, &setup.tools, surface(&setup)).unwrap();
    let caps = optimize::interval_caps(&engagement, &stations, limits, &setup.tools);
    let kept: Vec<_> = caps
        .iter()
        .enumerate()
        .filter(|&(k, _)| {
            let m = nalgebra::center(&stations.position_at(k), &stations.position_at(k + 1));
            engagement.area_mm2[k] > 0.0 && keep([m.x, m.y, m.z])
        })
        .map(|(_, c)| *c)
        .collect();
    assert!(kept.len() > 100, "only {} intervals", kept.len());
    kept
}

fn from_stock(_: &Setup) -> SurfaceFrom<'_> {
    SurfaceFrom::Stock
}

fn from_design(s: &Setup) -> SurfaceFrom<'_> {
    SurfaceFrom::Design(&s.design.as_ref().expect("a design").1)
}

#[test]
fn s3_waterline_along_a_vertical_wall_runs_at_the_programmed_feed() {
    // A wall 0.2 mm proud of the tool's reach (x = 4.8 against the ball's 5), cut by
    // waterline passes at tip z = 4, 2 and 0 along y. The upper passes touch only the
    // wall (the ledge below lies farther, on the last pass's ball): θ = 90°, F(θ) = F.
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "job.toml",
        &job(
            "[stock]\nkind = \"box\"\nmin = [4.8, -10, 0]\nmax = [20, 10, 10]\ngrid = 0.1",
            "",
        ),
    );
    write(
        dir.path(),
        "part.nc",
        "G21 G90\nG0 X0 Y-15 Z20\nG1 Z4 F1500\nG1 Y15\nG0 Z20\nG0 Y-15\nG1 Z2\nG1 Y15\n\
         G0 Z20\nG0 Y-15\nG1 Z0\nG1 Y15\nG0 Z20\nM30\n",
    );
    let caps = caps_where(dir.path(), from_stock, |p| {
        p[1].abs() < 8.0 && ((p[2] - 4.0).abs() < 1e-9 || (p[2] - 2.0).abs() < 1e-9)
    });
    for (cap, kind) in caps {
        assert_eq!((cap, kind), (1500.0, CapKind::SurfaceAngle));
    }
}

#[test]
fn s3_flat_floor_runs_at_v0() {
    // A 0.1 mm skim of a flat top along x: the ball touches with its tip, θ < θk = 18°.
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "job.toml",
        &job(
            "[stock]\nkind = \"box\"\nmin = [-10, -10, -5]\nmax = [10, 10, 0.1]\ngrid = 0.1",
            "",
        ),
    );
    write(
        dir.path(),
        "part.nc",
        "G21 G90\nG0 X-15 Y0 Z5\nG1 Z0 F1500\nG1 X15\nG0 Z5\nM30\n",
    );
    let caps = caps_where(dir.path(), from_stock, |p| p[0].abs() < 8.0);
    for (cap, kind) in caps {
        assert_eq!((cap, kind), (300.0, CapKind::SurfaceAngle));
    }
}

/// ASCII STL of the prism under z = top(x) = c − x over x, y ∈ [−10, 10], down to z = −20.
fn wedge_stl(c: f64) -> String {
    let (x0, x1, y0, y1, zb) = (-10.0f64, 10.0f64, -10.0f64, 10.0f64, -20.0f64);
    let top = |x: f64| c - x;
    // Cross-section in XZ, counter-clockwise seen from +Y: bottom, right, top, left.
    let q = [(x0, zb), (x1, zb), (x1, top(x1)), (x0, top(x0))];
    let v = |(x, z): (f64, f64), y: f64| [x, y, z];
    // The two end caps (y = y0 facing −Y, y = y1 facing +Y).
    let mut tris: Vec<[[f64; 3]; 3]> = vec![
        [v(q[0], y0), v(q[1], y0), v(q[2], y0)],
        [v(q[0], y0), v(q[2], y0), v(q[3], y0)],
        [v(q[0], y1), v(q[2], y1), v(q[1], y1)],
        [v(q[0], y1), v(q[3], y1), v(q[2], y1)],
    ];
    // The four sides of the section, extruded along y.
    for i in 0..4 {
        let (a, b) = (q[i], q[(i + 1) % 4]);
        tris.push([v(a, y0), v(b, y1), v(b, y0)]);
        tris.push([v(a, y0), v(a, y1), v(b, y1)]);
    }
    let mut s = String::from("solid wedge\n");
    for t in tris {
        s.push_str("facet normal 0 0 0\nouter loop\n");
        for p in t {
            s.push_str(&format!("vertex {} {} {}\n", p[0], p[1], p[2]));
        }
        s.push_str("endloop\nendfacet\n");
    }
    s.push_str("endsolid wedge\n");
    s
}

/// A ball finishing down a 45° slope (design z = −x) with 0.3 mm of stock: the
/// programmed tip path keeps the ball centre 5 mm off the design along its normal.
fn slope_case(design: bool) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let allowance = 0.3 * 2f64.sqrt();
    write(dir.path(), "stock.stl", &wedge_stl(allowance));
    write(dir.path(), "design.stl", &wedge_stl(0.0));
    let design_section = if design {
        "[design]\npath = \"design.stl\"\n"
    } else {
        ""
    };
    write(
        dir.path(),
        "job.toml",
        &job(
            "[stock]\nkind = \"mesh\"\npath = \"stock.stl\"\ngrid = 0.1",
            design_section,
        ),
    );
    // Ball centre (t, 0, −t) + 5·(1, 0, 1)/√2, tip 5 mm below it.
    let h = 5.0 / 2f64.sqrt();
    let tip = |t: f64| (t + h, -t + h - 5.0);
    let (a, b) = (tip(-12.0), tip(12.0));
    write(
        dir.path(),
        "part.nc",
        &format!(
            "G21 G90\nG0 X{:.6} Y0 Z30\nG1 Z{:.6} F1500\nG1 X{:.6} Z{:.6}\nG0 Z30\nM30\n",
            a.0, a.1, b.0, b.1
        ),
    );
    dir
}

#[test]
fn s3_slope_of_45_degrees_runs_at_half_the_programmed_feed() {
    // θ = 45° ≥ θk = 18°: F(θ) = 1500 · 45 / 90 = 750 mm/min, from the stock the
    // removal leaves and from the design model.
    for (design, surface) in [
        (false, from_stock as fn(&Setup) -> SurfaceFrom),
        (true, from_design),
    ] {
        let dir = slope_case(design);
        let caps = caps_where(dir.path(), surface, |p| p[0].abs() < 6.0);
        for (cap, kind) in caps {
            assert_eq!(kind, CapKind::SurfaceAngle);
            assert!((cap - 750.0).abs() < 1e-3, "design {design}: {cap}");
        }
    }
}

/// The jerk-limited planner against its lower bound (MODEL.md §6.1) on the two example
/// programs as written, jerk 20 000 mm/s³: `cargo test --release -p dexcut --test
/// source_methods jerk_gap -- --ignored --nocapture`.
#[test]
#[ignore = "measurement; run with --ignored --nocapture"]
fn jerk_gap_on_the_examples() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for job in [
        "examples/boss_contour/job.toml",
        "examples/3d_chips/job.toml",
    ] {
        let setup = Setup::load(&root.join(job), None).unwrap();
        for jerk_mm_s3 in [None, Some([20_000.0; 3])] {
            let machine = schedule::Machine {
                jerk_mm_s3,
                ..setup.machine
            };
            let st = schedule::Stations::new(
                &setup.program.path,
                &machine,
                0.05, // the planner's station spacing (motion::STATION_DS_MM)
                schedule::FeedPolicy::Programmed,
            )
            .unwrap();
            let cycle = schedule::plan(&st).cycle_time_s();
            let bound = schedule::lower_bound_time_s(&st);
            println!(
            "{job}, jerk {jerk_mm_s3:?}: cycle {cycle:.4} s, lower bound {bound:.4} s, gap {:.2} %",
            100.0 * (cycle / bound - 1.0)
        );
        }
    }
}
