//! A job fitted to a G-code program, for `dexcut simulate part.nc` and
//! `dexcut optimize part.nc` (and `dexcut job part.nc`, which writes it to
//! edit): a user with only a program from a CAM system gets a run without
//! writing a job first.
//!
//! * **Tool**: `--tool KIND:DIAMETER` (mm), else the cutter the program's
//!   comments name, as CAM posts write it: Fusion's
//!   `(T1 D=3.175 CR=0 - ZMIN=-3 - flat end mill)`, CamBam's `( T1 : 6.0 )`,
//!   BlenderCAM's `(Tool: D = 3.0 mm type END flutes 2)`,
//!   `Tool diameter: 3.175mm`, `3mm Endmill`, … (in the program's units unless
//!   the comment gives its own). One tool per T number
//!   the program uses becomes a `[[tools]]` table when the comments name each.
//! * **Stock**: a box around the program's feed moves, the tool's radius + 2 mm
//!   wider on every side, from 1 mm under the deepest feed move up to Z0 (CAM
//!   posts put Z0 on the stock's top), or 0.5 mm above the lowest feed move when
//!   every feed move is above Z0.
//! * **Machine Z**: `z_axis = "down"` where every rapid across X/Y reaches below
//!   every feed move's end ([`z_points_down`]; Estlcam 10's posts); the stock is
//!   then fitted to the path mirrored into dexcut's Z-up frame.
//! * **Grid**: about 20 columns across the tool, coarser where the stock would
//!   need more than [`MAX_FITTED_COLUMNS`] columns.
//! * Flutes as long as the deepest cut + 0.2 mm, at least 3 diameters; cutters
//!   under 1/8" on a 1/8" shank; aluminium 6061; the machine defaults.
//!
//! Every guess is said in [`FittedJob::notes`] and in the job text's comments,
//! so that the user sees what was assumed and can edit it.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::LazyLock;

use regex::Regex;

use crate::error::{fail, Result};
use crate::input::job::Job;

/// Most columns a fitted stock gets (the grid is coarsened to stay under).
pub const MAX_FITTED_COLUMNS: f64 = 4.0e6;

/// Shank of cutters smaller than it, mm (1/8", as PCB and hobby micro tools).
const MICRO_SHANK_MM: f64 = 3.175;

/// Cutter shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Flat end mill (drills and face mills are swept as flat ends).
    Flat,
    /// Ball-end mill.
    Ball,
    /// Bull nose with this corner radius, mm.
    Bull(f64),
}

/// A cutter, as named by `--tool` or a program comment.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolGuess {
    /// T number the comment gives it, if any.
    pub number: Option<u32>,
    /// Shape.
    pub shape: Shape,
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Flutes, if named.
    pub flutes: Option<u32>,
    /// Where it comes from: `line 12: (T1 D=3.175 …)`, or `--tool`.
    pub source: String,
}

/// What [`fit`] makes: the job's text and what it assumed.
#[derive(Clone, Debug)]
pub struct FittedJob {
    /// The program, as an absolute path (the job names it so).
    pub program: std::path::PathBuf,
    /// The job file's text (TOML), with the guesses in its comments.
    pub toml: String,
    /// One line per guess, for the console.
    pub notes: Vec<String>,
}

/// `--tool KIND:DIAMETER[:CORNER_RADIUS]`, e.g. `flat:6`, `ball:3.175`, `bull:10:1` (mm).
pub fn parse_tool_arg(arg: &str) -> Result<ToolGuess> {
    let parts: Vec<&str> = arg.split(':').map(str::trim).collect();
    let number = |s: &str, what: &str| -> Result<f64> {
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
            _ => fail!(
                request,
                "--tool {arg}: {what} '{s}' is not a positive number of mm"
            ),
        }
    };
    let shape = match (parts.first().map(|s| s.to_ascii_lowercase()), parts.len()) {
        (Some(k), 2) if k == "flat" => Shape::Flat,
        (Some(k), 2) if k == "ball" => Shape::Ball,
        (Some(k), 3) if k == "bull" => Shape::Bull(number(parts[2], "corner radius")?),
        _ => fail!(
            request,
            "--tool {arg}: expected KIND:DIAMETER in mm with KIND flat or ball (flat:6, ball:3.175), or bull:DIAMETER:CORNER_RADIUS (bull:10:1)"
        ),
    };
    Ok(ToolGuess {
        number: None,
        shape,
        diameter_mm: number(parts[1], "diameter")?,
        flutes: None,
        source: "--tool".into(),
    })
}

/// The comments of one program line: `( … )` groups and what follows `;`.
fn comments(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(open) = rest.find(['(', ';']) {
        if rest[open..].starts_with(';') {
            out.push(&rest[open + 1..]);
            break;
        }
        let after = &rest[open + 1..];
        // Nested parentheses (Estlcam's tool names) close at the last ')'.
        let close = after.rfind(')').unwrap_or(after.len());
        out.push(&after[..close]);
        rest = &after[close.min(after.len())..];
        if rest.starts_with(')') {
            rest = &rest[1..];
        }
    }
    if let Some(c) = line.trim_start().strip_prefix("//") {
        out.push(c);
    }
    out
}

/// Whether the program is written in inches: its first G20 or G21 outside comments is G20.
fn program_in_inches(text: &str) -> bool {
    static UNITS: LazyLock<Regex> =
        LazyLock::new(|| Regex::new(r"(?i)G\s*0*(2[01])(?:[^0-9.]|$)").expect("regex"));
    for line in text.lines() {
        let mut code = line.to_string();
        for c in comments(line) {
            code = code.replace(c, "");
        }
        if let Some(m) = UNITS.captures(&code) {
            return &m[1] == "20";
        }
    }
    false
}

/// A length written as `3.175`, `.125` or `1/8`.
fn length(s: &str) -> Option<f64> {
    let v = match s.split_once('/') {
        Some((a, b)) => a.trim().parse::<f64>().ok()? / b.trim().parse::<f64>().ok()?,
        None => s.trim().parse::<f64>().ok()?,
    };
    (v.is_finite() && v > 0.0).then_some(v)
}

/// mm per unit of a comment's unit word (`mm`, `in`, `inch`, `"`), or of the program's.
fn unit_mm(unit: Option<&str>, inches: bool) -> f64 {
    match unit.map(|u| u.trim().to_ascii_lowercase()) {
        Some(u) if u == "mm" => 1.0,
        Some(u) if u == "\"" || u.starts_with("in") => 25.4,
        _ if inches => 25.4,
        _ => 1.0,
    }
}

/// The shape a comment's words name (ball, bull with a corner radius, else flat).
fn shape_named(text: &str, corner_radius_mm: Option<f64>) -> Shape {
    let t = text.to_ascii_lowercase();
    if t.contains("ball") {
        Shape::Ball
    } else {
        match corner_radius_mm {
            Some(r) if r > 0.0 => Shape::Bull(r),
            _ => Shape::Flat,
        }
    }
}

/// Cutters the program's comments name, in file order.
pub fn tools_in_comments(text: &str) -> Vec<ToolGuess> {
    /// Fusion 360's posts: `T1 D=3.175 CR=0. - ZMIN=-3 - flat end mill`.
    static FUSION: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)\bT(\d+)\s+D=([\d.]+)\s+CR=([\d.]+)(.*)").expect("regex")
    });
    /// CamBam: `T1 : 6.0`.
    static CAMBAM: LazyLock<Regex> =
        LazyLock::new(|| Regex::new(r"(?i)^\s*T(\d+)\s*:\s*([\d.]+)\s*$").expect("regex"));
    /// BlenderCAM: `Tool: D = 3.0 mm  type END flutes 2`.
    static BLENDERCAM: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)Tool:\s*D\s*=\s*([\d.]+)\s*(mm|in)?\s*type\s+(\w+)(?:\s+flutes\s+(\d+))?")
            .expect("regex")
    });
    /// Mastercam: `T212 |    3. FLAT ENDMILL | H0`.
    static MASTERCAM: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)\bT(\d+)\s*\|\s*([\d.]+)\s*(\w+)?\s*END\s*MILL").expect("regex")
    });
    /// pcb-gcode's drill table (Eagle): `T01 | 0.800mm 0.0315in | 0.0000in | …`.
    static PCB_GCODE: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)\bT(\d+)\s*\|\s*([\d.]+)\s*mm\s+[\d.]+\s*in\s*\|").expect("regex")
    });
    /// `T2 Diameter: 0.40mm` (drl2gcode), `Tool diameter: 3.175mm` (gcodekit4),
    /// `TOOL DIAMETER: 3.0`, `Endmill Diameter: 1`, `Bit diameter: 1/8"`,
    /// `Change tool bit to mill diameter 0.00787in` (pcb2gcode).
    static DIAMETER: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r#"(?i)(?:\bT(\d+)\s+|tool\s+|end\s*mill\s+|mill\s+|bit\s+|cutter\s+)diameter\s*[:=]?\s*([\d./]+)\s*(mm|inch|in|")?"#)
            .expect("regex")
    });
    /// `T01 = 1/2"  END MILL` (Haas shop comments), `0.049" endmill`, `Use a 1/64inch Bit`,
    /// `3mm Endmill` (FreeCAD's tool controllers), `Carbide 4-Flute Endmill, 2mm`,
    /// `End mill 3mm` (Estlcam).
    static SIZED_MILL: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r#"(?i)(?:\bT(\d+)\s*=\s*)?([\d./]+)\s*(mm|inch|in|")\s*(ball\s*)?(?:end\s*mill|bit\b)"#)
            .expect("regex")
    });
    static MILL_SIZED: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r#"(?i)(?:(\d)-flute\s+)?(ball\s*)?end\s*mill,?\s+([\d./]+)\s*(mm|inch|in|")"#)
            .expect("regex")
    });
    /// `Change tool bit to drill size 0.0157inch` (pcb2gcode).
    static DRILL: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)drill\s+size\s*([\d.]+)\s*(mm|inch|in)?").expect("regex")
    });
    /// `Tool: 3.0mm` (UGS's designer).
    static TOOL_MM: LazyLock<Regex> =
        LazyLock::new(|| Regex::new(r#"(?i)^\s*Tool:\s*([\d.]+)\s*(mm|in|")"#).expect("regex"));

    let inches = program_in_inches(text);
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        for c in comments(line) {
            let source = format!("line {}: {}", i + 1, line.trim());
            let guess = if let Some(m) = FUSION.captures(c) {
                let scale = unit_mm(None, inches);
                let cr = length(&m[3]).map(|r| r * scale);
                length(&m[2]).map(|d| ToolGuess {
                    number: m[1].parse().ok(),
                    shape: shape_named(&m[4], cr),
                    diameter_mm: d * scale,
                    flutes: None,
                    source,
                })
            } else if let Some(m) = CAMBAM.captures(c) {
                length(&m[2]).map(|d| ToolGuess {
                    number: m[1].parse().ok(),
                    shape: Shape::Flat,
                    diameter_mm: d * unit_mm(None, inches),
                    flutes: None,
                    source,
                })
            } else if let Some(m) = BLENDERCAM.captures(c) {
                length(&m[1]).map(|d| ToolGuess {
                    number: None,
                    shape: shape_named(&m[3], None),
                    diameter_mm: d * unit_mm(m.get(2).map(|u| u.as_str()), inches),
                    flutes: m.get(4).and_then(|f| f.as_str().parse().ok()),
                    source,
                })
            } else if let Some(m) = MASTERCAM.captures(c) {
                length(&m[2]).map(|d| ToolGuess {
                    number: m[1].parse().ok(),
                    shape: shape_named(m.get(3).map_or("", |s| s.as_str()), None),
                    diameter_mm: d * unit_mm(None, inches),
                    flutes: None,
                    source,
                })
            } else if let Some(m) = PCB_GCODE.captures(c) {
                length(&m[2]).map(|d| ToolGuess {
                    number: m[1].parse().ok(),
                    shape: Shape::Flat,
                    diameter_mm: d,
                    flutes: None,
                    source,
                })
            } else if let Some(m) = DIAMETER.captures(c) {
                length(&m[2]).map(|d| ToolGuess {
                    number: m.get(1).and_then(|n| n.as_str().parse().ok()),
                    shape: shape_named(c, None),
                    diameter_mm: d * unit_mm(m.get(3).map(|u| u.as_str()), inches),
                    flutes: None,
                    source,
                })
            } else if let Some(m) = SIZED_MILL.captures(c) {
                length(&m[2]).map(|d| ToolGuess {
                    number: m.get(1).and_then(|n| n.as_str().parse().ok()),
                    shape: if m.get(4).is_some() {
                        Shape::Ball
                    } else {
                        Shape::Flat
                    },
                    diameter_mm: d * unit_mm(Some(&m[3]), inches),
                    flutes: None,
                    source,
                })
            } else if let Some(m) = MILL_SIZED.captures(c) {
                length(&m[3]).map(|d| ToolGuess {
                    number: None,
                    shape: if m.get(2).is_some() {
                        Shape::Ball
                    } else {
                        Shape::Flat
                    },
                    diameter_mm: d * unit_mm(Some(&m[4]), inches),
                    flutes: m.get(1).and_then(|f| f.as_str().parse().ok()),
                    source,
                })
            } else if let Some(m) = DRILL.captures(c) {
                length(&m[1]).map(|d| ToolGuess {
                    number: None,
                    shape: Shape::Flat,
                    diameter_mm: d * unit_mm(m.get(2).map(|u| u.as_str()), inches),
                    flutes: None,
                    source,
                })
            } else if let Some(m) = TOOL_MM.captures(c) {
                length(&m[1]).map(|d| ToolGuess {
                    number: None,
                    shape: Shape::Flat,
                    diameter_mm: d * unit_mm(Some(&m[2]), inches),
                    flutes: None,
                    source,
                })
            } else {
                None
            };
            out.extend(guess);
        }
    }
    out
}

/// The tools of the fitted job, by T number where there are several: `--tool`
/// for every tool, else per T number the program uses the first comment that
/// names it, else the first comment's tool for all.
fn job_tools(
    given: Option<&ToolGuess>,
    named: &[ToolGuess],
    used: &[u32],
    program: &Path,
) -> Result<Vec<(Option<u32>, ToolGuess)>> {
    if let Some(t) = given {
        return Ok(vec![(None, t.clone())]);
    }
    let Some(first) = named.first() else {
        fail!(
            request,
            "{}: no comment of the program names its cutter's diameter (as CAM posts write it: `(T1 D=3.175 CR=0 - flat end mill)`, `( T1 : 6.0 )`, `(Tool diameter: 3mm)`): give it with --tool, e.g. --tool flat:3.175 (KIND:DIAMETER in mm, KIND flat, ball, or bull:DIAMETER:CORNER_RADIUS), or write a job file (dexcut example shows one)",
            program.display()
        );
    };
    let used: Vec<u32> = used.iter().copied().filter(|&n| n != 0).collect();
    if used.len() > 1 {
        let per_number: Option<Vec<(Option<u32>, ToolGuess)>> = used
            .iter()
            .map(|&n| {
                named
                    .iter()
                    .find(|t| t.number == Some(n))
                    .map(|t| (Some(n), t.clone()))
            })
            .collect();
        if let Some(tools) = per_number {
            return Ok(tools);
        }
    }
    Ok(vec![(None, first.clone())])
}

/// The program's feed moves (G1, G2, G3 and canned cycles' feeds).
fn feed_moves(path: &nc::Path) -> impl Iterator<Item = &nc::Segment> {
    path.segments
        .iter()
        .filter(|s| matches!(s.motion, nc::Motion::Feed { .. }))
}

/// Points along a segment: its ends, and 31 points between along an arc.
fn points_along(s: &nc::Segment) -> impl Iterator<Item = nalgebra::Point3<f64>> + '_ {
    let pieces = if matches!(s.geometry, nc::Geometry::Line) {
        1
    } else {
        32
    };
    (0..=pieces).map(move |k| s.point_at_fraction(k as f64 / pieces as f64))
}

/// Whether the program is written for a machine whose +Z points to the table
/// (`[machine] z_axis = "down"`; Estlcam 10's posts: safe height Z-20, cuts down
/// to Z+2): it has at least two rapids that move in X or Y, and each of them
/// reaches below the lowest point every feed move goes to (its start aside:
/// Estlcam plunges at the feed from the safe height). Read with Z up, those
/// rapids would travel under the cuts, through the stock. (A single one is
/// not enough: a `G28` return to a home at Z0 before cuts above Z0, as the
/// corpus's sprayer programs do, is one.)
pub fn z_points_down(path: &nc::Path) -> bool {
    let lowest_feed = feed_moves(path)
        .flat_map(|s| points_along(s).skip(1))
        .fold(f64::INFINITY, |m, p| m.min(p.z));
    let (mut below, mut traverses) = (true, 0);
    for s in path.segments.iter().filter(|s| {
        matches!(s.motion, nc::Motion::Rapid)
            && (s.end.x - s.start.x).hypot(s.end.y - s.start.y) > 1e-6
    }) {
        traverses += 1;
        below &= s.start.z.min(s.end.z) < lowest_feed - 1e-6;
    }
    lowest_feed.is_finite() && traverses >= 2 && below
}

/// A grid spacing of 1, 2 or 5 × 10^k mm, the largest such not above `mm`.
fn round_grid(mm: f64) -> f64 {
    let decade = 10f64.powf(mm.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|&g| g <= mm * (1.0 + 1e-9))
        .unwrap_or(decade)
}

/// Fit a job to the G-code program at `program` (module docs). `tool`:
/// `--tool`; `grid_mm`: `--grid`, else about 20 columns across the smallest tool.
pub fn fit(program: &Path, tool: Option<&ToolGuess>, grid_mm: Option<f64>) -> Result<FittedJob> {
    let (text, _) = crate::input::program::read_text(program)?;
    let named = tools_in_comments(&text);
    let abs = std::path::absolute(program).unwrap_or_else(|_| program.to_path_buf());
    let path_toml = toml::Value::String(abs.display().to_string()).to_string();
    // Read the program with a stock far from it, to find where it cuts.
    let probe_tool = tool.or(named.first()).map_or(3.0, |t| t.diameter_mm);
    let probe = format!(
        "[stock]\nkind = \"box\"\nmin = [-50000, -50000, -90000]\nmax = [50000, 50000, -89990]\ngrid = 500\n[tool]\nkind = \"flat\"\ndiameter = {probe_tool}\n[program]\npath = {path_toml}\n"
    );
    let job = Job::parse(&probe, &program.display().to_string(), Path::new(""))?;
    let mut read = crate::input::program::load(&job)?;
    let z_down = z_points_down(&read.path);
    if z_down {
        read.path.mirror_z();
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for s in feed_moves(&read.path) {
        for p in points_along(s) {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    if !lo[0].is_finite() {
        fail!(
            request,
            "{}: the program has no feed move (G1, G2, G3 or a canned cycle) to fit a stock around",
            program.display()
        );
    }
    let tools = job_tools(tool, &named, &read.path.tools(), program)?;
    let smallest = tools
        .iter()
        .map(|(_, t)| t.diameter_mm)
        .fold(f64::INFINITY, f64::min);
    let largest = tools.iter().map(|(_, t)| t.diameter_mm).fold(0.0, f64::max);
    let margin = largest / 2.0 + 2.0;
    let top = if lo[2] < 0.0 { 0.0 } else { lo[2] + 0.5 };
    let bottom = lo[2] - 1.0;
    let (min, max) = (
        [lo[0] - margin, lo[1] - margin, bottom],
        [hi[0] + margin, hi[1] + margin, top],
    );
    let columns = |g: f64| ((max[0] - min[0]) / g).ceil() * ((max[1] - min[1]) / g).ceil();
    let grid = grid_mm.unwrap_or_else(|| {
        let mut g = round_grid(smallest / 20.0);
        while columns(g) > MAX_FITTED_COLUMNS {
            // The next of 1, 2, 5 × 10^k (× 2.6 lands between the next and the one after).
            g = round_grid(g * 2.6);
        }
        g
    });
    let depth = top - lo[2];
    let mut notes = Vec::new();
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Job fitted by dexcut to {} (edit it and run `dexcut simulate` or `optimize` on this file).",
        abs.display()
    );
    let _ = writeln!(t, "[stock]");
    let _ = writeln!(
        t,
        "# A box around the feed moves (the tool's radius + 2 mm each side), from 1 mm under the deepest\n# feed move up to {}: set it to your stock.",
        if lo[2] < 0.0 { "Z0 (where CAM posts put the stock's top)" } else { "0.5 mm above the lowest feed move (every feed move is above Z0)" }
    );
    let _ = writeln!(t, "kind = \"box\"");
    let f = |v: [f64; 3]| format!("[{:.3}, {:.3}, {:.3}]", v[0], v[1], v[2]);
    let _ = writeln!(t, "min = {}\nmax = {}", f(min), f(max));
    let _ = writeln!(
        t,
        "grid = {grid:?}   # mm; {}",
        if grid_mm.is_some() {
            "--grid".to_string()
        } else {
            format!("about 20 columns across the Ø{smallest} mm tool, at most {MAX_FITTED_COLUMNS:.0} columns")
        }
    );
    if z_down {
        let _ = writeln!(t);
        let _ = writeln!(
            t,
            "[machine]\nz_axis = \"down\"   # every rapid across X/Y travels below the feed moves: +Z points to the table"
        );
        notes.push("machine: +Z points to the table (z_axis = \"down\"): every rapid that moves in X or Y travels below every feed move, as Estlcam's posts write safe heights (Z-20); set [machine] z_axis = \"up\" in the job if that is wrong".into());
    }
    notes.push(format!(
        "stock: a box from {} to {} mm around the feed moves, top at Z{top}, grid {grid} mm ({:.0} columns): edit [stock] in the job to match your stock",
        f(min),
        f(max),
        columns(grid)
    ));
    let several = tools.len() > 1;
    for (number, g) in &tools {
        let _ = writeln!(t);
        let _ = writeln!(t, "# From {}", g.source.replace('\n', " "));
        if several {
            let _ = writeln!(t, "[[tools]]\nnumber = {}", number.unwrap_or(1));
        } else {
            let _ = writeln!(t, "[tool]");
        }
        let (kind, corner) = match g.shape {
            Shape::Flat => ("flat", String::new()),
            Shape::Ball => ("ball", String::new()),
            Shape::Bull(r) => (
                "bull",
                format!("corner_radius = {}\n", r.min(g.diameter_mm / 2.0)),
            ),
        };
        let flute = (3.0 * g.diameter_mm).max(depth + 0.2);
        let _ = write!(
            t,
            "kind = \"{kind}\"\ndiameter = {}\n{corner}flute_length = {flute:.3}   # the deepest cut + 0.2 mm, at least 3 diameters\nstickout = {:.3}\n",
            g.diameter_mm,
            flute + 10.0
        );
        if let Some(n) = g.flutes {
            let _ = writeln!(t, "flutes = {n}");
        }
        if g.diameter_mm < MICRO_SHANK_MM {
            let _ = writeln!(t, "shank_diameter = {MICRO_SHANK_MM}   # 1/8\" shank");
        }
        notes.push(format!(
            "tool{}: {kind} Ø{} mm{}, from {}",
            number.map_or(String::new(), |n| format!(" T{n}")),
            g.diameter_mm,
            if let Shape::Bull(r) = g.shape {
                format!(" r{r}")
            } else {
                String::new()
            },
            g.source
        ));
    }
    let _ = writeln!(t);
    let _ = writeln!(t, "[program]\npath = {path_toml}");
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "[cutting]\nmaterial = \"al6061\"   # al6061 | s50c | tool-steel-40hrc | ti6al4v"
    );
    notes.push("material: aluminium 6061, machine: dexcut's defaults (feed_max 3000 mm/min, rapid 10 000 mm/min, 1000 mm/s² per axis): edit [cutting] and [machine] in the job".into());
    Ok(FittedJob {
        program: abs,
        toml: t,
        notes,
    })
}

impl FittedJob {
    /// Write the job to `path` (`dexcut job`), replacing a file there only with `force`.
    pub fn write(&self, path: &Path, force: bool) -> Result<()> {
        if std::fs::symlink_metadata(path).is_ok() && !force {
            fail!(
                request,
                "{} exists: give --force to replace it, or another --out",
                path.display()
            );
        }
        export::atomic::write_bytes(path, self.toml.as_bytes())
            .map_err(|e| crate::error::Error::io("cannot write", path, e))
    }
}

/// Whether `path` is a job file rather than a program: a `.toml` extension,
/// or text that reads as TOML with a `[program]` table. Anything that is not
/// a regular file counts as a job, so that the job reader refuses it (a FIFO
/// or device is never read here); a file larger than a job may be is a program.
pub fn is_job_file(path: &Path) -> bool {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
    {
        return true;
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => {
            m.len() <= crate::bounds::MAX_JOB_BYTES
                && std::fs::read_to_string(path)
                    .ok()
                    .and_then(|t| toml::from_str::<toml::Table>(&t).ok())
                    .is_some_and(|t| t.contains_key("program"))
        }
        _ => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(text: &str) -> ToolGuess {
        let found = tools_in_comments(text);
        assert!(!found.is_empty(), "nothing found in {text:?}");
        found[0].clone()
    }

    #[test]
    fn posts_comment_forms_give_the_cutter() {
        let cases: [(&str, Option<u32>, Shape, f64); 12] = [
            (
                "G21\n(T1  D=1.7 CR=0 - ZMIN=-3 - flat end mill)\n",
                Some(1),
                Shape::Flat,
                1.7,
            ),
            (
                "G20\n(T1 D=0.125 CR=0. - ZMIN=-0.1575 - flat end mill)\n",
                Some(1),
                Shape::Flat,
                3.175,
            ),
            (
                "(T3 D=6 CR=3 - ZMIN=-3 - ball end mill)\nG21\n",
                Some(3),
                Shape::Ball,
                6.0,
            ),
            (
                "(T2 D=10 CR=1 - ZMIN=-3 - bull nose end mill)\n",
                Some(2),
                Shape::Bull(1.0),
                10.0,
            ),
            (
                "G20\n( T0 : 0.0394 )\n",
                Some(0),
                Shape::Flat,
                0.0394 * 25.4,
            ),
            (
                "(Tool: D = 3.0 mm  type END flutes 2)\n",
                None,
                Shape::Flat,
                3.0,
            ),
            (
                "( T212 |    3. FLAT ENDMILL | H0 )\n",
                Some(212),
                Shape::Flat,
                3.0,
            ),
            ("; T2 Diameter: 0.40mm\n", Some(2), Shape::Flat, 0.4),
            ("(Bit diameter: 1/8\")\nG21\n", None, Shape::Flat, 3.175),
            ("(HSS 1-Flute Endmill, 3.175mm)\n", None, Shape::Flat, 3.175),
            ("(Block-name: 6mm Endmill001)\n", None, Shape::Flat, 6.0),
            (
                "(T01 = 1/2\"  END MILL    03-0086)\n",
                Some(1),
                Shape::Flat,
                12.7,
            ),
        ];
        for (text, number, shape, d) in cases {
            let t = one(text);
            assert_eq!((t.number, t.shape), (number, shape), "{text}");
            assert!(
                (t.diameter_mm - d).abs() < 1e-9,
                "{text}: {}",
                t.diameter_mm
            );
        }
        assert_eq!(one("(Tool: D = 3.0 mm  type END flutes 2)").flutes, Some(2));
        assert!(
            tools_in_comments("G1 X1 (move to D=3 CR=0)\nG0 Z5 ; end mill retract\n").is_empty()
        );
    }

    #[test]
    fn tool_argument_reads_kind_and_millimetres() {
        let t = parse_tool_arg("ball:3.175").unwrap();
        assert_eq!((t.shape, t.diameter_mm), (Shape::Ball, 3.175));
        assert_eq!(parse_tool_arg("bull:10:1").unwrap().shape, Shape::Bull(1.0));
        for bad in ["flat", "flat:-2", "cone:3", "bull:10", "flat:x"] {
            let e = parse_tool_arg(bad).unwrap_err().to_string();
            assert!(e.contains("--tool"), "{bad}: {e}");
        }
    }

    #[test]
    fn grid_rounds_down_to_one_two_five() {
        assert_eq!(round_grid(0.1058), 0.1);
        assert_eq!(round_grid(0.3), 0.2);
        assert_eq!(round_grid(0.013), 0.01);
        assert_eq!(round_grid(0.5), 0.5);
    }
}
