use super::*;

const MINIMAL: &str = r#"
[stock]
kind = "box"
min = [0, 0, 0]
max = [10, 10, 10]
grid = 0.5
[tool]
kind = "ball"
diameter = 6
[program]
path = "p.csv"
feed = 1000
"#;

#[test]
fn minimal_job_parses_with_defaults() {
    let job = Job::parse(MINIMAL, "job.toml", Path::new("/jobs")).unwrap();
    assert_eq!(job.machine.period_ms, 16.0);
    assert_eq!(
        job.resolve(&job.program().path),
        PathBuf::from("/jobs/p.csv")
    );
    assert_eq!(job.tool().unwrap().flute_length_mm, 12.0);
}

/// `[machine]` is checked once, by the machine model's own table
/// (`schedule::MACHINE_RANGES`): every range it names is refused beyond
/// either end under its job key, and accepted at its ends.
#[test]
fn machine_ranges_come_from_the_machine_model() {
    for (name, lo, hi) in schedule::MACHINE_RANGES {
        let (key, shown) = match name {
            "period_ms" => ("period_ms", "machine.period_ms"),
            "feed_max_mm_min" => ("feed_max", "machine.feed_max (mm/min)"),
            "rapid_mm_min" => ("rapid", "machine.rapid (mm/min)"),
            "accel_mm_s2" => ("accel", "machine.accel (mm/s²)"),
            "jerk_mm_s3" => ("jerk", "machine.jerk (mm/s³)"),
            "block_time_ms" => ("block_time_ms", "machine.block_time_ms"),
            other => panic!("no job key for {other}"),
        };
        let job_with = |v: f64| {
            let value = if matches!(key, "accel" | "jerk") {
                format!("[{v:e}, {v:e}, {v:e}]")
            } else {
                format!("{v:e}")
            };
            let text = MINIMAL.replace(
                "[program]",
                &format!("[machine]\n{key} = {value}\n[program]"),
            );
            Job::parse(&text, "job.toml", Path::new("."))
        };
        for v in [hi * 10.0, lo / 10.0] {
            let e = format!("{:#}", job_with(v).unwrap_err());
            assert!(
                e.contains(&format!("{shown} must lie in")),
                "{name} = {v}: {e}"
            );
        }
        if lo > 1e-300 {
            job_with(lo).unwrap_or_else(|e| panic!("{name} = {lo}: {e:#}"));
        }
        job_with(hi).unwrap_or_else(|e| panic!("{name} = {hi}: {e:#}"));
    }
}

#[test]
fn unknown_key_names_file_line_and_column() {
    let text = MINIMAL.replace("feed = 1000", "feed = 1000\nspeed = 3");
    let err = Job::parse(&text, "job.toml", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("job.toml:13:1: program.speed: unknown field `speed`"),
        "{err}"
    );
}

/// Stock and tool shapes are tagged by `kind`: each takes its own keys and
/// no other, and a missing or foreign key is refused at the section's line.
#[test]
fn shapes_take_their_own_keys_only() {
    let err = |from: &str, to: &str| {
        assert!(MINIMAL.contains(from), "{from}");
        let text = MINIMAL.replacen(from, to, 1);
        Job::parse(&text, "job.toml", Path::new("."))
            .unwrap_err()
            .to_string()
    };
    let cases = [
        (
            "max = [10, 10, 10]\n",
            "",
            "job.toml:2:2: stock.max is missing: a box stock (kind = \"box\") needs min, max and grid",
        ),
        (
            "grid = 0.5",
            "grid = 0.5\nradius = 3",
            "job.toml:7:1: stock.radius is not a key of a box stock (kind = \"box\" takes min, max and grid)",
        ),
        (
            "kind = \"box\"",
            "kind = \"cylinder\"",
            "job.toml:4:1: stock.min is not a key of a cylinder stock",
        ),
        (
            "kind = \"box\"",
            "kind = \"cube\"",
            "job.toml:3:8: stock.kind: unknown variant `cube`, expected one of `box`, `cylinder`, `mesh`",
        ),
        (
            "diameter = 6",
            "diameter = 6\ncorner_radius = 1",
            "job.toml:10:1: invalid job: tool.corner_radius is a key of a bull nose (kind = \"bull\") only, not of kind = \"ball\"",
        ),
        (
            "kind = \"ball\"",
            "kind = \"bull\"",
            "job.toml:7:2: invalid job: tool.corner_radius is missing: a bull nose (kind = \"bull\") needs its corner radius (mm)",
        ),
        (
            "kind = \"ball\"\n",
            "",
            "job.toml:7:1: tool: missing field `kind`",
        ),
        (
            "grid = 0.5",
            "grid = \"0.5\"",
            "job.toml:6:8: stock.grid: invalid type: string \"0.5\", expected f64",
        ),
        (
            "min = [0, 0, 0]",
            "min = [0, 0, \"a\"]",
            "job.toml:4:14: stock.min[2]: invalid type: string \"a\", expected f64",
        ),
        (
            "diameter = 6",
            "diameter = \"6\"",
            "job.toml:9:12: tool.diameter: invalid type: string \"6\", expected f64",
        ),
    ];
    for (from, to, expected) in cases {
        let e = err(from, to);
        assert!(e.starts_with(expected), "{to}: {e}");
    }
    let bull = MINIMAL.replace("kind = \"ball\"", "kind = \"bull\"\ncorner_radius = 1.5");
    let job = Job::parse(&bull, "job.toml", Path::new(".")).unwrap();
    assert_eq!(job.tool().unwrap(), dexel::Tool::bull(6.0, 1.5));
    let wide = bull.replace("corner_radius = 1.5", "corner_radius = 3.5");
    let e = format!(
        "{:#}",
        Job::parse(&wide, "job.toml", Path::new(".")).unwrap_err()
    );
    assert!(
        e.contains("tool.corner_radius (mm) must lie strictly between 0 and half the diameter (3), and be at least 0.001, got 3.5"),
        "{e}"
    );
    let cylinder = "[stock]\nkind = \"cylinder\"\ncenter = [0, 0]\nradius = 5\nz_min = 0\nz_max = 4\ngrid = 0.5\n";
    let text = MINIMAL.replacen(&MINIMAL[..MINIMAL.find("[tool]").unwrap()], cylinder, 1);
    let job = Job::parse(&text, "job.toml", Path::new(".")).unwrap();
    assert!(matches!(job.stock, StockSpec::Cylinder { radius, .. } if radius == 5.0));
    assert_eq!(job.stock.grid_mm(), 0.5);
}

#[test]
fn tool_tables_are_checked_by_key() {
    let table = MINIMAL.replace(
            "[tool]\nkind = \"ball\"\ndiameter = 6",
            "[[tools]]\nnumber = 2\nkind = \"ball\"\ndiameter = 6\nlength = 50\n[[tools]]\nnumber = 5\nkind = \"flat\"\ndiameter = 3",
        );
    let job = Job::parse(&table, "job.toml", Path::new(".")).unwrap();
    let numbers: Vec<Option<u32>> = job.tool_specs().iter().map(|t| t.0).collect();
    assert_eq!(numbers, [Some(2), Some(5)]);
    assert_eq!(job.tool().unwrap().diameter_mm, 6.0);
    let err = |text: &str| {
        format!(
            "{:#}",
            Job::parse(text, "job.toml", Path::new(".")).unwrap_err()
        )
    };
    let twice = table.replace("number = 5", "number = 2");
    assert!(err(&twice).contains("tools[1].number: tool 2 is in the table twice"));
    let both = format!("{table}\n[tool]\nkind = \"flat\"\ndiameter = 1\n");
    assert!(err(&both).contains("not both"), "{}", err(&both));
    let unnumbered = table.replace("number = 5\n", "");
    assert!(err(&unnumbered).contains("tools[1].number is missing"));
    let bad = table.replace("diameter = 3", "diameter = -3");
    assert!(
        err(&bad).contains("tools[1].diameter (mm)"),
        "{}",
        err(&bad)
    );
    let single_length = MINIMAL.replace("diameter = 6", "diameter = 6\nlength = 10");
    assert!(err(&single_length).contains("belong to [[tools]]"));
}

#[test]
fn negative_sizes_are_rejected() {
    let text = MINIMAL.replace("diameter = 6", "diameter = -6");
    let err = format!(
        "{:#}",
        Job::parse(&text, "job.toml", Path::new(".")).unwrap_err()
    );
    assert!(
        err.contains(
            "job.toml:9:1: invalid job: tool.diameter (mm) must lie in 0.005..500, got -6"
        ),
        "{err}"
    );
    let text = MINIMAL.replace("max = [10, 10, 10]", "max = [10, -10, 10]");
    assert!(Job::parse(&text, "job.toml", Path::new(".")).is_err());
}

/// Non-finite and absurd numbers are refused
/// at parse time, each with its key.
#[test]
fn non_finite_and_absurd_numbers_name_their_key() {
    let cases: [(&str, &str, &str); 26] = [
        (
            "max = [10, 10, 10]",
            "max = [10, 10, inf]",
            "stock.max (mm)[2] must be a finite number, got inf",
        ),
        (
            "diameter = 6",
            "diameter = 6\nrupture_strength_mpa = -1",
            "tool.rupture_strength_mpa must",
        ),
        (
            "diameter = 6",
            "diameter = 6\nstress_limit_mpa = 1500\nrupture_strength_mpa = 1400",
            "tool.rupture_strength_mpa (1400 MPa) is below tool.stress_limit_mpa (1500 MPa)",
        ),
        (
            "min = [0, 0, 0]",
            "min = [nan, 0, 0]",
            "stock.min (mm)[0] must be a finite number, got NaN",
        ),
        (
            "grid = 0.5",
            "grid = 1000",
            "stock.grid (1000 mm) is too coarse",
        ),
        (
            "grid = 0.5",
            "grid = nan",
            "stock.grid (mm) must be a finite number",
        ),
        (
            "diameter = 6",
            "diameter = inf",
            "tool.diameter (mm) must be a finite number",
        ),
        (
            "diameter = 6",
            "diameter = 6\nflutes = 0",
            "tool.flutes must be 1..100, got 0",
        ),
        (
            "feed = 1000",
            "feed = 1e-9",
            "program.feed (mm/min) must lie in 0.001..1e7",
        ),
        (
            "[program]",
            "[machine]\naccel = [1e-9, 1000, 1000]\n[program]",
            "machine.accel (mm/s²) must lie in",
        ),
        (
            "[program]",
            "[machine]\nfeed_max = 1e-6\n[program]",
            "machine.feed_max (mm/min) must lie in",
        ),
        (
            "[program]",
            "[machine]\nperiod_ms = 1e-6\n[program]",
            "machine.period_ms must lie in 0.01..1000",
        ),
        (
            "[program]",
            "[machine]\nperiod_ms = 1e9\n[program]",
            "machine.period_ms must lie in 0.01..1000",
        ),
        (
            "[program]",
            "[machine]\njerk = [1e-6, 1, 1]\n[program]",
            "machine.jerk (mm/s³) must lie in",
        ),
        (
            "[program]",
            "[machine]\nblock_time_ms = 1e9\n[program]",
            "machine.block_time_ms must lie in",
        ),
        (
            "[program]",
            "[machine]\nstart = [0, 0, 1e12]\n[program]",
            "machine.start (mm)[2] must lie within",
        ),
        (
            "[program]",
            "[limits]\nmrr_max = 1e-12\n[program]",
            "limits.mrr_max (mm³/s) must lie in 1e-6..1e9, got 1e-12",
        ),
        (
            "[program]",
            "[limits]\nforce_max = 1e-9\n[program]",
            "limits.force_max (N) must lie in",
        ),
        (
            "[program]",
            "[limits]\ndeflection_max_um = 1e-9\n[program]",
            "limits.deflection_max_um must lie in",
        ),
        (
            "[program]",
            "[cutting]\nspindle_rpm = 1e-300\n[program]",
            "cutting.spindle_rpm (rev/min) must lie in 1..1000000",
        ),
        (
            "[program]",
            "[servo]\nkp = nan\n[program]",
            "servo.kp (1/s) must be a finite number",
        ),
        (
            "[program]",
            "[servo]\nka = nan\n[program]",
            "servo.ka must be a finite number",
        ),
        (
            "[program]",
            "[servo]\nprecomp_iterations = 100000000000\n[program]",
            "servo.precomp_iterations must be at most 1000",
        ),
        (
            "[program]",
            "[servo]\nprecomp_threshold_mm = 1e-300\n[program]",
            "servo.precomp_threshold_mm must lie in",
        ),
        (
            "[program]",
            "[offsets]\ng55 = [0, nan, 0]\n[program]",
            "offsets.g55 (mm)[1] must be a finite number",
        ),
        (
            "[program]",
            "[cutting]\nforce_n = -1\n[program]",
            "cutting.force_n must lie in 0.01..2, got -1",
        ),
    ];
    for (from, to, expected) in cases {
        assert!(MINIMAL.contains(from), "{from}");
        let text = MINIMAL.replacen(from, to, 1);
        let err = format!(
            "{:#}",
            Job::parse(&text, "job.toml", Path::new(".")).unwrap_err()
        );
        assert!(err.contains(expected), "{to}: {err}");
    }
}

/// A fuzzer over job files: random keys of every section set to
/// hostile values (non-finite, huge, tiny, negative, wrong types). No
/// panic; every error names a key or a file line; every accepted job has
/// finite numbers only.
#[test]
fn fuzzed_jobs_give_named_errors_or_finite_jobs() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    use std::sync::atomic::{AtomicUsize, Ordering};
    const KEYS: [(&str, &str, usize); 35] = [
        ("stock", "grid", 1),
        ("stock", "min", 3),
        ("stock", "max", 3),
        ("tool", "diameter", 1),
        ("tool", "flute_length", 1),
        ("tool", "stickout", 1),
        ("tool", "youngs_modulus_mpa", 1),
        ("tool", "effective_diameter", 1),
        ("tool", "stress_limit_mpa", 1),
        ("tool", "rupture_strength_mpa", 1),
        ("program", "feed", 1),
        ("cutting", "band_height", 1),
        ("cutting", "spindle_rpm", 1),
        ("cutting", "force_a", 1),
        ("cutting", "force_n", 1),
        ("machine", "period_ms", 1),
        ("machine", "feed_max", 1),
        ("machine", "rapid", 1),
        ("machine", "accel", 3),
        ("machine", "jerk", 3),
        ("machine", "block_time_ms", 1),
        ("machine", "start", 3),
        ("limits", "mrr_max", 1),
        ("limits", "force_max", 1),
        ("limits", "deflection_max_um", 1),
        ("limits", "feed_min", 1),
        ("limits", "feed_max", 1),
        ("servo", "kp", 1),
        ("servo", "feedforward", 1),
        ("servo", "ka", 1),
        ("servo", "tolerance_mm", 1),
        ("servo", "precomp_threshold_mm", 1),
        ("servo", "precomp_iterations", 1),
        ("offsets", "g54", 3),
        ("offsets", "g59", 3),
    ];
    let scalar = prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0".to_string()),
        Just("-0.0".to_string()),
        Just("1e-300".to_string()),
        Just("1e300".to_string()),
        Just("1e308".to_string()),
        Just("-1".to_string()),
        Just("\"x\"".to_string()),
        Just("true".to_string()),
        Just("[1, 2]".to_string()),
        any::<f64>().prop_map(|v| format!("{v:e}")),
        any::<i64>().prop_map(|v| v.to_string()),
        (-1e4f64..1e4).prop_map(|v| format!("{v:?}")),
    ];
    let edit = (0..KEYS.len(), proptest::collection::vec(scalar, 3));
    let jobs = proptest::collection::vec(edit, 1..5);
    let (tried, accepted, named) = (
        AtomicUsize::new(0),
        AtomicUsize::new(0),
        AtomicUsize::new(0),
    );
    let mut runner = TestRunner::new(Config {
        cases: 3000,
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&jobs, |edits| {
            tried.fetch_add(1, Ordering::Relaxed);
            // Sections of MINIMAL are edited in place; others are appended once.
            let mut text = MINIMAL.to_string();
            let mut extra: std::collections::BTreeMap<&str, Vec<String>> = Default::default();
            for (k, values) in &edits {
                let (section, key, arity) = KEYS[*k];
                let value = if arity == 1 {
                    values[0].clone()
                } else {
                    format!("[{}]", values[..arity].join(", "))
                };
                let line = format!("{key} = {value}");
                match section {
                    "stock" | "tool" | "program" => {
                        let header = format!("[{section}]\n");
                        text = text.replacen(&header, &format!("{header}{line}\n"), 1);
                    }
                    _ => extra.entry(section).or_default().push(line),
                }
            }
            for (section, lines) in extra {
                text.push_str(&format!("[{section}]\n{}\n", lines.join("\n")));
            }
            match Job::parse(&text, "job.toml", Path::new(".")) {
                Ok(job) => {
                    accepted.fetch_add(1, Ordering::Relaxed);
                    let m = &job.machine;
                    let mut numbers = vec![
                        job.stock.grid_mm(),
                        job.tool_specs()[0].1.diameter,
                        m.period_ms,
                        m.feed_max,
                        m.rapid,
                    ];
                    numbers.extend(m.accel);
                    numbers.extend(m.jerk.into_iter().flatten());
                    numbers.extend(m.start.into_iter().flatten());
                    numbers.extend(job.offsets.as_array().into_iter().flatten());
                    numbers.extend([job.servo.kp, job.servo.ka, job.servo.tolerance_mm]);
                    prop_assert!(numbers.iter().all(|v| v.is_finite()), "{text}");
                }
                Err(e) => {
                    let msg = format!("{e:#}");
                    let keyed = KEYS
                        .iter()
                        .any(|(s, k, _)| msg.contains(&format!("{s}.{k}")))
                        || msg.starts_with("job.toml:")
                        || msg.contains("stock.max must exceed stock.min")
                        || msg.contains("stock.grid (")
                        || msg.contains("limits.feed_min (");
                    prop_assert!(keyed, "error names no key or line: {msg}\n{text}");
                    named.fetch_add(1, Ordering::Relaxed);
                }
            }
            Ok(())
        })
        .unwrap();
    let (tried, accepted, named) = (
        tried.into_inner(),
        accepted.into_inner(),
        named.into_inner(),
    );
    eprintln!("job fuzzer: {tried} cases, {accepted} accepted, {named} refused with a key or line, 0 unnamed");
    assert_eq!(accepted + named, tried);
}

/// Issue 39, "tool and machine numbers without a physical range" and "type
/// errors located at the section": every stiffness, strength and size of a
/// tool has a shop's range, and every error names the key's path and the
/// line and column where the key is written (in a `[[tools]]` entry too).
#[test]
fn errors_name_the_key_path_and_its_own_line() {
    let table = MINIMAL.replace(
        "[tool]\nkind = \"ball\"\ndiameter = 6",
        "[[tools]]\nnumber = 1\nkind = \"ball\"\ndiameter = 6\n[[tools]]\nnumber = 2\nkind = \"flat\"\ndiameter = 6\nKEY",
    );
    // The line the KEY placeholder is on (1-based).
    let line = table[..table.find("KEY").unwrap()].matches('\n').count() + 1;
    let cases = [
        (
            "youngs_modulus_mpa = 1e-3",
            "tools[1].youngs_modulus_mpa must lie in 10000..1e7, got 0.001",
        ),
        (
            "holder_stiffness_n_per_um = 1e-300",
            "tools[1].holder_stiffness_n_per_um must lie in 0.001..1e12",
        ),
        (
            "stress_limit_mpa = 1e-3",
            "tools[1].stress_limit_mpa must lie in 1..1000000",
        ),
        (
            "rupture_strength_mpa = 0.5",
            "tools[1].rupture_strength_mpa must lie in 1..1000000",
        ),
        (
            "effective_diameter = 20",
            "tools[1].effective_diameter (mm) must lie in 0.6..6, got 20",
        ),
        (
            "stickout = 1e9",
            "tools[1].stickout (mm) must lie in 0.005..2000",
        ),
        (
            "shank_diameter = 1e-9",
            "tools[1].shank_diameter (mm) must lie in 0.005..500",
        ),
        (
            "fz_max = 50",
            "tools[1].fz_max (mm/tooth) must lie in 1e-5..10",
        ),
        (
            "flutes = \"2\"",
            "tools[1].flutes: invalid type: string \"2\", expected u32",
        ),
        (
            "length = [1]",
            "tools[1].length: invalid type: sequence, expected f64",
        ),
    ];
    for (key_value, expected) in cases {
        let text = table.replace("KEY", key_value);
        let e = format!(
            "{:#}",
            Job::parse(&text, "job.toml", Path::new(".")).unwrap_err()
        );
        let col = if expected.contains("invalid type") {
            key_value.find('=').unwrap() + 3
        } else {
            1
        };
        assert!(
            e.starts_with(&format!("job.toml:{line}:{col}: ")),
            "{key_value}: {e}"
        );
        assert!(e.contains(expected), "{key_value}: {e}");
    }
    // [cutting] too.
    let text = MINIMAL.replace("[program]", "[cutting]\nkc1_1 = 1e-300\n[program]");
    let e = format!(
        "{:#}",
        Job::parse(&text, "job.toml", Path::new(".")).unwrap_err()
    );
    assert!(
        e.starts_with("job.toml:11:1: invalid job: cutting.kc1_1 (N/mm²) must lie in 1..20000"),
        "{e}"
    );
}

/// Issue 39, "checks that disagree": what the kernel refuses (a bull nose's
/// corner radius of 0 or half the diameter, flutes longer than the
/// stick-out, defaults included) is refused by the job check, once, with the
/// key and its line, and never passes it to fail later without one.
#[test]
fn the_job_check_is_the_only_check_of_a_tool() {
    let err = |text: &str| {
        format!(
            "{:#}",
            Job::parse(text, "job.toml", Path::new(".")).unwrap_err()
        )
    };
    for r in ["0", "3"] {
        let text = MINIMAL.replace(
            "kind = \"ball\"",
            &format!("kind = \"bull\"\ncorner_radius = {r}"),
        );
        let e = err(&text);
        assert!(e.starts_with("job.toml:9:1: invalid job: tool.corner_radius (mm) must lie strictly between 0 and half the diameter (3)"), "{e}");
    }
    let text = MINIMAL.replace("diameter = 6", "diameter = 6\nstickout = 10");
    let e = err(&text);
    assert!(
        e.contains("tool.flute_length (12 mm, its default 2 × diameter) is longer than tool.stickout (10 mm)"),
        "{e}"
    );
    // Every tool the job check passes, the kernel takes.
    for (extra, _) in [
        ("flute_length = 10\nstickout = 10", ()),
        ("corner_radius = 2.999", ()),
    ] {
        let kind = if extra.contains("corner") {
            "bull"
        } else {
            "ball"
        };
        let text = MINIMAL.replace("kind = \"ball\"", &format!("kind = \"{kind}\"\n{extra}"));
        let job = Job::parse(&text, "job.toml", Path::new(".")).unwrap();
        job.tool().unwrap().validate().unwrap();
    }
}

/// A job with every section and key the job file has.
const EVERY_KEY: &str = r#"
[stock]
kind = "box"
min = [0, 0, 0]
max = [40, 40, 20]
grid = 0.5

[[tools]]
number = 1
kind = "bull"
diameter = 6
corner_radius = 1
flute_length = 12
stickout = 30
flutes = 3
youngs_modulus_mpa = 600000
effective_diameter = 5
fz_max = 0.05
length = 40
shank_diameter = 6
holder_stiffness_n_per_um = 20
stress_limit_mpa = 1200
rupture_strength_mpa = 3500

[program]
path = "p.nc"
feed = 1000

[cutting]
band_height = 1
material = "al6061"
spindle_rpm = 12000
model = "kienzle"
kc1_1 = 700
mc = 0.25
force_a = 100
force_n = 0.8
radial_ratio = 0.3
axial_ratio = 0.25
closed_loop = true

[machine]
period_ms = 4
feed_max = 3000
rapid = 10000
accel = [1000, 1000, 1000]
jerk = [20000, 20000, 20000]
block_time_ms = 1
arcs_as_lines = false
start = [0, 0, 50]
z_axis = "up"

[limits]
mrr_max = 100
force_max = 400
deflection_max_um = 20
power_max_kw = 5
feed_min = 10
feed_max = 3000
angle_rule = true
v0 = 300
feed_scale_max = 2
stress = true

[servo]
kp = 30
feedforward = 0.5
zeta = 0.7
omega_n = 500
ka = 1
kb = 1
kc = 1
tolerance_mm = 0.01
jerk_reference = 100000
precomp_threshold_mm = 0.001
precomp_iterations = 20

[offsets]
g54 = [0, 0, 0]
g55 = [10, 0, 0]

[design]
path = "part.stl"
gouge_tolerance_um = 10
stock_tolerance_um = 50
"#;

/// Issue 39's job-file fuzzer: every key of every section (and every entry
/// of its arrays) given a value of each wrong type and absurd numbers. Each
/// job is either read (the value was one the key takes) or refused with an
/// error that names the key's path (or, for a check across keys, its name)
/// at a line and column inside the file. Never a panic.
#[test]
fn every_key_mutated_is_refused_at_its_path_and_line() {
    let base: toml::Table = toml::from_str(EVERY_KEY).unwrap();
    Job::parse(EVERY_KEY, "job.toml", Path::new(".")).unwrap();
    // (path, leaf name, value) of every key and array entry.
    fn leaves(t: &toml::Table, prefix: &str, out: &mut Vec<(String, String)>) {
        for (k, v) in t {
            let path = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match v {
                toml::Value::Table(t) => leaves(t, &path, out),
                toml::Value::Array(a) => {
                    out.push((path.clone(), k.clone()));
                    for (i, v) in a.iter().enumerate() {
                        let entry = format!("{path}[{i}]");
                        match v {
                            toml::Value::Table(t) => leaves(t, &entry, out),
                            _ => out.push((entry, k.clone())),
                        }
                    }
                }
                _ => out.push((path, k.clone())),
            }
        }
    }
    fn set(t: &mut toml::Table, path: &str, value: toml::Value) {
        let (head, rest) = path.split_once('.').unwrap_or((path, ""));
        let (key, index) = match head.split_once('[') {
            Some((k, i)) => (k, Some(i.trim_end_matches(']').parse::<usize>().unwrap())),
            None => (head, None),
        };
        let slot = t.get_mut(key).unwrap();
        let slot = match index {
            Some(i) => &mut slot.as_array_mut().unwrap()[i],
            None => slot,
        };
        if rest.is_empty() {
            *slot = value;
        } else {
            set(slot.as_table_mut().unwrap(), rest, value);
        }
    }
    let mut keys = Vec::new();
    leaves(&base, "", &mut keys);
    assert!(keys.len() > 80, "{} keys", keys.len());
    let values: Vec<toml::Value> = [
        "\"text\"",
        "true",
        "[1, 2]",
        "{ a = 1 }",
        "-1",
        "0",
        "1e-300",
        "1e300",
        "-1e300",
        "nan",
        "inf",
        "-inf",
        "4294967296",
    ]
    .iter()
    .map(|v| toml::from_str::<toml::Table>(&format!("v = {v}")).unwrap()["v"].clone())
    .collect();
    let (mut refused, mut read) = (0, 0);
    for (path, leaf) in &keys {
        for value in &values {
            let mut t = base.clone();
            set(&mut t, path, value.clone());
            let text = toml::to_string(&t).unwrap();
            let lines = text.lines().count();
            let result = std::panic::catch_unwind(|| Job::parse(&text, "job.toml", Path::new(".")));
            let Ok(result) = result else {
                panic!("{path} = {value}: panicked");
            };
            let Err(e) = result else {
                read += 1;
                continue;
            };
            refused += 1;
            let e = format!("{e:#}");
            let at = e
                .strip_prefix("job.toml:")
                .and_then(|r| {
                    let mut p = r.splitn(3, ':');
                    Some((
                        p.next()?.parse::<usize>().ok()?,
                        p.next()?.parse::<usize>().ok()?,
                    ))
                })
                .unwrap_or_else(|| panic!("{path} = {value}: no line and column: {e}"));
            assert!(
                at.0 >= 1 && at.0 <= lines && at.1 >= 1,
                "{path} = {value}: {at:?} outside: {e}"
            );
            // The key's path, without the array entry where the message
            // names the array (`stock.min (mm)[2]`), or its name in a check
            // across keys (`limits.feed_min (…) exceeds the highest feed`).
            let array = path.split('[').next().unwrap();
            assert!(
                e.contains(path.as_str()) || e.contains(array) || e.contains(leaf.as_str()),
                "{path} = {value}: the error does not name the key: {e}"
            );
        }
    }
    eprintln!(
        "{} keys × {} values: {refused} refused, {read} read",
        keys.len(),
        values.len()
    );
    assert!(refused > read);
}

/// `[machine] controller`: an unknown one is refused at its place, each controller's keys
/// only under it and in their range, and a grbl `$$` dump is read with its keys winning
/// over it and a bad line named at file:line.
#[test]
fn controllers_and_their_settings_are_checked() {
    let with = |machine: &str| MINIMAL.to_string() + "[machine]\n" + machine + "\n";
    let err = |machine: &str| {
        Job::parse(&with(machine), "job.toml", Path::new("."))
            .unwrap_err()
            .to_string()
    };
    let e = err("controller = \"mach3\"");
    assert!(
        e.starts_with("job.toml:14:14: machine.controller: unknown variant `mach3`"),
        "{e}"
    );
    let e = err("junction_deviation_mm = 0.02");
    assert!(
        e.contains("machine.junction_deviation_mm is a setting of controller = \"grbl\""),
        "{e}"
    );
    let e = err("controller = \"grbl\"\nblend_tolerance_mm = 0.1");
    assert!(
        e.contains("machine.blend_tolerance_mm is a setting of controller = \"linuxcnc\""),
        "{e}"
    );
    let e = err("controller = \"grbl\"\njunction_deviation_mm = 50");
    assert!(e.contains("machine.junction_deviation_mm"), "{e}");

    let dir = std::env::temp_dir().join(format!("dexcut-grbl-dump-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("ok.txt"),
        "$11=0.05\n$12=0.01\n$110=6000\n$120=200\nok\n",
    )
    .unwrap();
    std::fs::write(dir.join("bad.txt"), "$11=0.05\n$121=x\n").unwrap();
    let job = |extra: &str| {
        Job::parse(
            &with(&format!("controller = \"grbl\"\n{extra}")),
            "job.toml",
            &dir,
        )
        .unwrap()
    };
    let settings =
        match controller(&job("grbl_settings = \"ok.txt\"\narc_tolerance_mm = 0.003")).unwrap() {
            schedule::Controller::Grbl(s) => s,
            c => panic!("{c:?}"),
        };
    assert_eq!(settings.junction_deviation_mm, 0.05);
    assert_eq!(settings.arc_tolerance_mm, 0.003);
    assert_eq!(settings.max_rate_mm_min, [6000.0, 10000.0, 10000.0]);
    assert_eq!(settings.accel_mm_s2, [200.0, 1000.0, 1000.0]);
    assert_eq!(settings.planner_blocks, 15);
    let e = controller(&job("grbl_settings = \"bad.txt\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.txt:2: $121: `x` is not a number"), "{e}");
    assert_eq!(
        controller(&Job::parse(MINIMAL, "job.toml", Path::new(".")).unwrap()).unwrap(),
        schedule::Controller::Ideal
    );

    // LinuxCNC: an INI read with the job (the recording machine's, 1 ms servo
    // period), a bad one named at file:line, the key refused under another controller.
    let lcnc = |extra: &str| {
        Job::parse(
            &with(&format!("controller = \"linuxcnc\"\n{extra}")),
            "job.toml",
            &dir,
        )
        .unwrap()
    };
    let ini = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scripts/linuxcnc_reference/sim.ini"
    );
    let settings = match controller(&lcnc(&format!("linuxcnc_ini = {ini:?}"))).unwrap() {
        schedule::Controller::LinuxCnc(s) => s,
        c => panic!("{c:?}"),
    };
    let read = settings.ini.expect("the INI's settings");
    assert_eq!(read.period_s, 1e-3);
    std::fs::write(dir.join("bad.ini"), "[EMCMOT]\nSERVO_PERIOD = fast\n").unwrap();
    let e = controller(&lcnc("linuxcnc_ini = \"bad.ini\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.ini:2"), "{e}");
    let e = err("linuxcnc_ini = \"bad.ini\"");
    assert!(
        e.contains("machine.linuxcnc_ini is a setting of controller = \"linuxcnc\""),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
