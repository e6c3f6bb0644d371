//! The job file (TOML): what stock, tool, program and machine a run uses.
//!
//! Keys follow the names; every length is mm, feeds mm/min, times as
//! named (`period_ms`, `block_time_ms`), rates mm³/s. Unknown keys are errors.

use std::path::{Path, PathBuf};

use crate::error::{fail, Context as _, Error, Result, ResultExt as _};
use crate::input::tool_library::{Library, ToolLibrarySpec};
use serde::{Deserialize, Serialize};

pub use super::operations::{Operation, OperationSpec};

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    pub stock: StockSpec,
    /// The one tool: tool 1, and every T of the program.
    pub tool: Option<ToolSpec>,
    /// A tool table: entries keyed by `number` (the T word).
    #[serde(default)]
    pub tools: Vec<ToolSpec>,
    /// A shop's tool library (LinuxCNC, Fusion 360, FreeCAD): its tools are
    /// appended to `tools` when the job is read, after the job's own
    /// `[[tools]]`, which win over library tools of the same number.
    pub tool_library: Option<ToolLibrarySpec>,
    /// The program (a job of `[[operations]]` has none: each operation has its own).
    #[serde(default)]
    pub program: Option<ProgramSpec>,
    /// `[[operations]]`: programs run in order on one stock
    /// ([`Job::operation_jobs`]); none for a job of one `[program]`.
    #[serde(default)]
    pub operations: Vec<OperationSpec>,
    /// Each operation as a job of its own, checked when the job is read.
    #[serde(skip)]
    pub operation_jobs: Vec<Operation>,
    #[serde(default)]
    pub cutting: CuttingSpec,
    #[serde(default)]
    pub machine: MachineSpec,
    #[serde(default)]
    pub limits: LimitsSpec,
    #[serde(default)]
    pub servo: ServoSpec,
    #[serde(default)]
    pub offsets: OffsetsSpec,
    pub design: Option<DesignSpec>,
    /// Whether the job file has a `[servo]` table (optimize then writes pre-compensated
    /// servo data).
    #[serde(skip)]
    pub servo_given: bool,
    /// Folder that relative paths are resolved against (the job file's folder).
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// Name shown in messages and reports.
    #[serde(skip)]
    pub name: String,
    /// What `[tool_library]` gave, its notes and skipped entries.
    #[serde(skip)]
    pub library: Option<Library>,
    /// How many entries at the end of `tools` are the library's (checked
    /// where they were read, with the library's file and line).
    #[serde(skip)]
    pub library_tools: usize,
}

/// `[stock]`: the blank, one shape per `kind`. Each shape takes its own keys,
/// all required, and no other: a box with `radius` or a cylinder without
/// `z_max` is refused with the key's name and line. Read through the flat
/// [`StockKeys`] (an internally tagged enum would be read whole before its
/// keys, and serde's errors would lose their place).
#[derive(Clone, Debug, Deserialize)]
#[serde(try_from = "StockKeys")]
pub enum StockSpec {
    /// `kind = "box"`: an axis-aligned box.
    Box {
        /// Lowest corner (x, y, z), mm.
        min: [f64; 3],
        /// Highest corner (x, y, z), mm.
        max: [f64; 3],
        /// Column spacing, mm.
        grid: f64,
    },
    /// `kind = "cylinder"`: a cylinder with its axis along Z.
    Cylinder {
        /// Axis position (x, y), mm.
        center: [f64; 2],
        /// mm.
        radius: f64,
        /// Bottom and top, mm.
        z_min: f64,
        z_max: f64,
        /// Column spacing, mm.
        grid: f64,
    },
    /// `kind = "mesh"`: a closed mesh (STL or OBJ), relative to the job file.
    Mesh {
        path: PathBuf,
        /// Column spacing, mm.
        grid: f64,
    },
    /// `kind = "saved"`: the stock a run left, saved by `--save-stock`
    /// (the folder `DIR/stock`, relative to the job file), on its own grid.
    Saved {
        path: PathBuf,
        /// Column spacing, mm: the saved stock's (read from its stock.json
        /// when the job is read; a `grid` key must equal it).
        grid: f64,
    },
}

/// The shapes of `[stock]`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum StockKind {
    Box,
    Cylinder,
    Mesh,
    Saved,
}

/// `[stock]` as written: every shape's keys, each checked against `kind`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StockKeys {
    kind: StockKind,
    #[serde(alias = "grid_mm")]
    grid: Option<f64>,
    min: Option<[f64; 3]>,
    max: Option<[f64; 3]>,
    center: Option<[f64; 2]>,
    radius: Option<f64>,
    z_min: Option<f64>,
    z_max: Option<f64>,
    path: Option<PathBuf>,
}

impl TryFrom<StockKeys> for StockSpec {
    type Error = String;

    fn try_from(k: StockKeys) -> std::result::Result<StockSpec, String> {
        let (kind, takes) = match k.kind {
            StockKind::Box => ("box", "min, max and grid"),
            StockKind::Cylinder => ("cylinder", "center, radius, z_min, z_max and grid"),
            StockKind::Mesh => ("mesh", "path and grid"),
            StockKind::Saved => ("saved", "path (and grid, if given, the saved stock's)"),
        };
        let given = [
            ("min", k.min.is_some()),
            ("max", k.max.is_some()),
            ("center", k.center.is_some()),
            ("radius", k.radius.is_some()),
            ("z_min", k.z_min.is_some()),
            ("z_max", k.z_max.is_some()),
            ("path", k.path.is_some()),
        ];
        let own: &[&str] = match k.kind {
            StockKind::Box => &["min", "max"],
            StockKind::Cylinder => &["center", "radius", "z_min", "z_max"],
            StockKind::Mesh | StockKind::Saved => &["path"],
        };
        for (key, is) in given {
            if is && !own.contains(&key) {
                return Err(format!(
                    "stock.{key} is not a key of a {kind} stock (kind = \"{kind}\" takes {takes})"
                ));
            }
            if !is && own.contains(&key) {
                return Err(format!(
                    "stock.{key} is missing: a {kind} stock (kind = \"{kind}\") needs {takes}"
                ));
            }
        }
        let missing = "checked above";
        // Every shape but a saved stock (which has its own) takes its grid.
        let grid = match (k.kind, k.grid) {
            (StockKind::Saved, g) => g.unwrap_or(f64::NAN),
            (_, Some(g)) => g,
            (_, None) => {
                return Err(format!(
                    "stock.grid is missing: a {kind} stock (kind = \"{kind}\") needs {takes}"
                ))
            }
        };
        Ok(match k.kind {
            StockKind::Box => StockSpec::Box {
                min: k.min.expect(missing),
                max: k.max.expect(missing),
                grid,
            },
            StockKind::Cylinder => StockSpec::Cylinder {
                center: k.center.expect(missing),
                radius: k.radius.expect(missing),
                z_min: k.z_min.expect(missing),
                z_max: k.z_max.expect(missing),
                grid,
            },
            StockKind::Mesh => StockSpec::Mesh {
                path: k.path.expect(missing),
                grid,
            },
            StockKind::Saved => StockSpec::Saved {
                path: k.path.expect(missing),
                grid,
            },
        })
    }
}

impl StockSpec {
    /// Column spacing, mm.
    pub fn grid_mm(&self) -> f64 {
        match *self {
            StockSpec::Box { grid, .. }
            | StockSpec::Cylinder { grid, .. }
            | StockSpec::Mesh { grid, .. }
            | StockSpec::Saved { grid, .. } => grid,
        }
    }

    fn grid_mut(&mut self) -> &mut f64 {
        match self {
            StockSpec::Box { grid, .. }
            | StockSpec::Cylinder { grid, .. }
            | StockSpec::Mesh { grid, .. }
            | StockSpec::Saved { grid, .. } => grid,
        }
    }
}

/// `[tool]` or a `[[tools]]` entry: the shape named by `kind`, with the keys
/// every shape shares and `corner_radius` for a bull nose only (required
/// there). One flat table, so that serde's errors keep each key's place.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    /// `"ball"`, `"flat"` or `"bull"`.
    pub kind: ToolKind,
    /// Bull nose only: the corner radius, mm, up to half the diameter.
    pub corner_radius: Option<f64>,
    /// mm.
    pub diameter: f64,
    /// mm; default 2 × diameter.
    pub flute_length: Option<f64>,
    /// Holder face to tip, mm; default 8 × diameter.
    pub stickout: Option<f64>,
    #[serde(default = "default_flutes")]
    pub flutes: u32,
    /// MPa; default 600 000 (carbide). HSS is about 210 000.
    pub youngs_modulus_mpa: Option<f64>,
    /// Helix angle of the flutes, degrees (0 straight flutes); default 30
    /// (MODEL.md §3.4: the force through a tooth period).
    pub helix_deg: Option<f64>,
    /// Effective diameter of the fluted part for the beam model, mm; default 0.8 × diameter.
    pub effective_diameter: Option<f64>,
    /// Largest feed per tooth, mm/tooth (chip-load limit of optimize); default
    /// from the tool diameter and cutting.material (MODEL.md §2.1).
    pub fz_max: Option<f64>,
    /// `[[tools]]` only: the tool number (T word), 1 or more.
    pub number: Option<u32>,
    /// `[[tools]]` only: gauge length, mm (what G43 applies); default 0.
    pub length: Option<f64>,
    /// Diameter of the solid shank between the flutes and the holder, mm; default diameter.
    pub shank_diameter: Option<f64>,
    /// Lateral stiffness of holder and spindle at the holder face, N/µm; default rigid.
    pub holder_stiffness_n_per_um: Option<f64>,
    /// Allowable von Mises stress in the tool, MPa (plausibility warnings); default
    /// 1200 for carbide (E ≥ 400 000 MPa), 1000 otherwise, at most the rupture
    /// strength (MODEL.md §4.4).
    pub stress_limit_mpa: Option<f64>,
    /// Transverse rupture strength of the tool, MPa: above it the tool breaks
    /// (`tool_breaks` warning, deflection reported at rupture); default 3500
    /// for carbide (E ≥ 400 000 MPa), 3000 otherwise, at least the allowable
    /// stress (MODEL.md §4.4).
    pub rupture_strength_mpa: Option<f64>,
}

/// The shapes of a tool.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ToolKind {
    /// Ball-end mill.
    Ball,
    /// Flat-end mill.
    Flat,
    /// Bull-nose (torus) mill: `corner_radius`.
    Bull,
}

fn default_flutes() -> u32 {
    2
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramSpec {
    /// G-code (any extension) or tool-tip points (a CSV with header x,y,z[,feed]), told apart by content.
    pub path: PathBuf,
    /// Feed for CSV rows without one, mm/min.
    pub feed: Option<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CuttingSpec {
    /// Height of one tool band above the tip, mm.
    #[serde(default = "default_band")]
    pub band_height: f64,
    /// Work material name for default force coefficients.
    #[serde(default = "default_material")]
    pub material: String,
    /// Spindle speed, rev/min; default: the program's S word, else 10 000.
    pub spindle_rpm: Option<f64>,
    /// Force model: "kienzle" (specific cutting force at the mean chip thickness,
    /// MODEL.md §3.2) or "power_law" (S4's F = a·V^n, §3.1).
    #[serde(default)]
    pub model: ForceModelKind,
    /// Force law F = a·V^n (N, mm³/rev/tooth); default from the material.
    pub force_a: Option<f64>,
    pub force_n: Option<f64>,
    /// Kienzle: specific cutting force at 1 mm chip thickness, N/mm²; default from the material.
    pub kc1_1: Option<f64>,
    /// Kienzle exponent mc; default from the material.
    pub mc: Option<f64>,
    /// Radial and axial force over tangential force; default 0.3 and 0.25.
    pub radial_ratio: Option<f64>,
    pub axial_ratio: Option<f64>,
    /// Sweep again with the tool moved by its deflection until they agree
    /// (MODEL.md §5.1); false: one rigid sweep, the error map clamped to the stock (§5).
    #[serde(default = "default_true")]
    pub closed_loop: bool,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ForceModelKind {
    #[default]
    Kienzle,
    PowerLaw,
}

fn default_true() -> bool {
    true
}
fn default_band() -> f64 {
    1.0
}
fn default_material() -> String {
    "s50c".into()
}

impl Default for CuttingSpec {
    fn default() -> Self {
        CuttingSpec {
            band_height: default_band(),
            material: default_material(),
            spindle_rpm: None,
            model: ForceModelKind::default(),
            force_a: None,
            force_n: None,
            kc1_1: None,
            mc: None,
            radial_ratio: None,
            axial_ratio: None,
            closed_loop: true,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MachineSpec {
    /// Interpolation (servo) period, ms.
    #[serde(default = "default_period")]
    pub period_ms: f64,
    /// Highest cutting feed, mm/min.
    #[serde(default = "default_feed_max")]
    pub feed_max: f64,
    /// Rapid traverse rate, mm/min.
    #[serde(default = "default_rapid")]
    pub rapid: f64,
    /// Axis acceleration limits (x, y, z), mm/s².
    #[serde(default = "default_accel")]
    pub accel: [f64; 3],
    /// Axis jerk limits (x, y, z), mm/s³; none by default.
    pub jerk: Option<[f64; 3]>,
    /// Block processing time of the control, ms (S0); none by default.
    pub block_time_ms: Option<f64>,
    /// The control runs each feed arc as straight blocks, linearised within S0's chord
    /// tolerance for its feed and `block_time_ms` (MODEL.md §6.2); off by default.
    #[serde(default)]
    pub arcs_as_lines: bool,
    /// Tool-tip position (x, y, z), mm, machine frame, when the program
    /// starts. Default: at the highest Z the program reaches, above the end
    /// of its first move when that is a rapid (so that move is a straight
    /// rapid down), else above the machine origin.
    pub start: Option<[f64; 3]>,
    /// Which way the machine's positive Z points, as its G-code programs are
    /// written: "up" (away from the table, the ISO/LinuxCNC convention; the
    /// default) or "down" (towards the table: a safe height such as `Z-20`).
    /// dexcut works with Z up: a "down" program is read mirrored in Z and
    /// optimized.nc is written back in the program's own Z.
    #[serde(default)]
    pub z_axis: ZAxis,
    /// The control whose planner runs the program (MODEL.md §6.4): "ideal" (dexcut's
    /// time-optimal planner, the default), "grbl" or "linuxcnc".
    #[serde(default)]
    pub controller: ControllerKind,
    /// grbl's `$11` junction deviation, mm (default 0.01; grbl only). Over a dump's `$11`.
    pub junction_deviation_mm: Option<f64>,
    /// grbl's `$12` arc tolerance, mm (default 0.002; grbl only). Over a dump's `$12`.
    pub arc_tolerance_mm: Option<f64>,
    /// Blocks grbl's planner buffer holds, the running one included (default 15, the
    /// ATmega328p's; grbl only).
    pub planner_blocks: Option<u32>,
    /// A grbl `$$` settings dump, relative to the job file (grbl only): its `$11`, `$12`,
    /// `$100`–`$102`, `$110`–`$112` and `$120`–`$122` replace the defaults, `rapid` as
    /// the axes' maximum rate and `accel`.
    pub grbl_settings: Option<PathBuf>,
    /// LinuxCNC's default blending tolerance (the INI's, for G64 without P), mm
    /// (linuxcnc only).
    pub blend_tolerance_mm: Option<f64>,
    /// A LinuxCNC INI file, relative to the job file (linuxcnc only): its `[EMCMOT]
    /// SERVO_PERIOD`, `[TRAJ]` and `[AXIS_n]`/`[JOINT_n]` limits and start-up `G64 P`
    /// replace the machine's.
    pub linuxcnc_ini: Option<PathBuf>,
}

/// `[machine] controller`: which planner runs the program.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// dexcut's time-optimal planner (MODEL.md §6.1).
    #[default]
    Ideal,
    /// grbl 1.1's planner (MODEL.md §6.4).
    Grbl,
    /// LinuxCNC's trajectory planner.
    Linuxcnc,
}

/// Direction of the machine's positive Z axis ([`MachineSpec::z_axis`]).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ZAxis {
    /// Positive Z away from the table (the tool retracts to +Z).
    #[default]
    Up,
    /// Positive Z towards the table (the tool plunges to +Z).
    Down,
}

fn default_period() -> f64 {
    16.0
}
fn default_feed_max() -> f64 {
    3000.0
}
fn default_rapid() -> f64 {
    10000.0
}
fn default_accel() -> [f64; 3] {
    [1000.0; 3]
}

impl Default for MachineSpec {
    fn default() -> Self {
        MachineSpec {
            period_ms: default_period(),
            feed_max: default_feed_max(),
            rapid: default_rapid(),
            accel: default_accel(),
            jerk: None,
            block_time_ms: None,
            arcs_as_lines: false,
            start: None,
            z_axis: ZAxis::Up,
            controller: ControllerKind::Ideal,
            junction_deviation_mm: None,
            arc_tolerance_mm: None,
            planner_blocks: None,
            grbl_settings: None,
            linuxcnc_ini: None,
            blend_tolerance_mm: None,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSpec {
    /// Material removal rate limit, mm³/s.
    pub mrr_max: Option<f64>,
    /// Cutting force limit, N.
    pub force_max: Option<f64>,
    /// Tool deflection limit at the contact height, µm.
    pub deflection_max_um: Option<f64>,
    /// Spindle cutting power limit, kW.
    pub power_max_kw: Option<f64>,
    /// Lowest feed the optimiser may write, mm/min.
    pub feed_min: Option<f64>,
    /// Highest feed the optimiser may write, mm/min (default: machine feed_max).
    pub feed_max: Option<f64>,
    /// S3's cutting-surface-angle rule for ball-end mills.
    #[serde(default)]
    pub angle_rule: bool,
    /// S3's v0: feed near the ball tip, mm/min.
    pub v0: Option<f64>,
    /// Largest factor over the programmed feed on cutting moves (none by default).
    pub feed_scale_max: Option<f64>,
    /// Hold every cutting step's von Mises stress to its tool's
    /// `stress_limit_mpa` (MPa, MODEL.md §4.4) like a force limit; on by
    /// default (`stress = false` turns it off).
    #[serde(default = "default_true")]
    pub stress: bool,
}

impl Default for LimitsSpec {
    fn default() -> Self {
        LimitsSpec {
            mrr_max: None,
            force_max: None,
            deflection_max_um: None,
            power_max_kw: None,
            feed_min: None,
            feed_max: None,
            angle_rule: false,
            v0: None,
            feed_scale_max: None,
            stress: true,
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServoSpec {
    /// Position loop gain, 1/s.
    pub kp: f64,
    /// Velocity feed-forward fraction, 0–1.
    pub feedforward: f64,
    /// Second-order drive: damping ratio and natural frequency (rad/s); first order when absent.
    pub zeta: Option<f64>,
    pub omega_n: Option<f64>,
    /// S2 weights of V = Ka·Va + Kb·Vb + Kc·Vc.
    pub ka: f64,
    pub kb: f64,
    pub kc: f64,
    /// Trajectory error that scores Va = 1, mm.
    pub tolerance_mm: f64,
    /// Jerk that scores Vc = 1, mm/s³.
    pub jerk_reference: f64,
    /// Pre-compensation stops below this error, mm, or after this many iterations.
    pub precomp_threshold_mm: f64,
    pub precomp_iterations: usize,
}

impl Default for ServoSpec {
    fn default() -> Self {
        ServoSpec {
            kp: 30.0,
            feedforward: 0.0,
            zeta: None,
            omega_n: None,
            ka: 1.0,
            kb: 1.0,
            kc: 1.0,
            tolerance_mm: 0.01,
            jerk_reference: 1.0e5,
            precomp_threshold_mm: 0.001,
            precomp_iterations: 20,
        }
    }
}

/// Work offsets G54–G59 (x, y, z), mm.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OffsetsSpec {
    pub g54: Option<[f64; 3]>,
    pub g55: Option<[f64; 3]>,
    pub g56: Option<[f64; 3]>,
    pub g57: Option<[f64; 3]>,
    pub g58: Option<[f64; 3]>,
    pub g59: Option<[f64; 3]>,
}

impl OffsetsSpec {
    pub fn as_array(&self) -> [[f64; 3]; 6] {
        [self.g54, self.g55, self.g56, self.g57, self.g58, self.g59].map(|o| o.unwrap_or([0.0; 3]))
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Design model (STL or OBJ) to compare the final stock with.
    pub path: PathBuf,
    /// A column cut deeper than this below the design is a gouge, µm (S1, MODEL.md §8).
    #[serde(default = "default_gouge_tolerance_um")]
    pub gouge_tolerance_um: f64,
    /// A column left higher than this above the design is stock left, µm.
    #[serde(default = "default_stock_tolerance_um")]
    pub stock_tolerance_um: f64,
}

fn default_gouge_tolerance_um() -> f64 {
    10.0
}

fn default_stock_tolerance_um() -> f64 {
    50.0
}

/// `FILE:LINE:COL` of a byte offset.
pub fn location(file: &str, text: &str, offset: usize) -> String {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("{file}:{line}:{col}")
}

/// Finest column spacing and smallest tool size accepted, mm.
const MIN_GRID_MM: f64 = 1e-4;
/// Largest coordinate or length accepted, mm (1 km).
const MAX_LENGTH_MM: f64 = 1e6;
/// Feeds accepted, mm/min: 1 µm/min to 10 km/min.
const FEED_RANGE_MM_MIN: (f64, f64) = (1e-3, 1e7);
const MAX_FLUTES: u32 = 100;
/// The ranges of a shop's tools (docs/guide/job.md, `[tool]`): diameter
/// (micro tools of 5 µm to face mills of 500 mm) and shank, mm.
const TOOL_DIAMETER_MM: (f64, f64) = (0.005, 500.0);
/// Flute length and stick-out, mm.
const TOOL_LENGTH_MM: (f64, f64) = (0.005, 2000.0);
/// Young's modulus of a tool's material, MPa: from 10 000 (below any metal's)
/// to ten times diamond's, so that a comparison may take a near-rigid tool
/// (aluminium 70 000, HSS 210 000, carbide 450 000–650 000, PCD ≈ 1 000 000).
const TOOL_MODULUS_MPA: (f64, f64) = (10_000.0, 1e7);
/// Allowable stress and rupture strength, MPa: 1 MPa up (carbide's
/// transverse rupture strength is 2 000–6 000; 10⁶ lifts the check).
const TOOL_STRENGTH_MPA: (f64, f64) = (1.0, 1e6);
/// Lateral stiffness of holder and spindle, N/µm (a shop's are 5–200; 10¹²
/// is rigid).
const HOLDER_STIFFNESS_N_PER_UM: (f64, f64) = (1e-3, 1e12);
/// Smallest corner radius of a bull nose, mm (a smaller one is a flat end's
/// edge honing).
const MIN_CORNER_RADIUS_MM: f64 = 1e-3;
/// Largest feed per tooth, mm/tooth.
const TOOL_FZ_MAX_MM: (f64, f64) = (1e-5, 10.0);
/// Tool bands per step (each costs 12 B per servo sample in the removal record).
const MAX_BANDS: f64 = 1000.0;
/// Helix angles of end mills, degrees: straight flutes to high-helix finishers.
const TOOL_HELIX_DEG: (f64, f64) = (0.0, 60.0);
/// Pre-compensation iterations accepted (each is one drive simulation).
const MAX_PRECOMP_ITERATIONS: usize = 1000;
/// Columns a stock must have across its narrowest XY extent: a coarser grid
/// rounds the stock's outline to a few cells (grid 1000 mm on a 20 mm box
/// reported a thousand times its volume).
const MIN_COLUMNS_ACROSS: f64 = 4.0;

/// A number as written in messages: plain when moderate, else with an exponent
/// (1e-300, not three hundred zeros).
fn num(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `key` must be a finite number in `lo..=hi`.
fn range(key: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if !(v >= lo && v <= hi) {
        if !v.is_finite() {
            fail!(job, "{key} must be a finite number, got {v}");
        }
        fail!(
            job,
            "{key} must lie in {}..{}, got {}",
            num(lo),
            num(hi),
            num(v)
        );
    }
    Ok(())
}

/// An optional positive number up to `hi`.
fn positive_opt(key: &str, v: Option<f64>, hi: f64) -> Result<()> {
    match v {
        Some(v) if !(v > 0.0) => {
            if v.is_nan() {
                fail!(job, "{key} must be a finite number, got {v}");
            }
            fail!(job, "{key} must be a positive number, got {}", num(v))
        }
        Some(v) => range(key, v, 0.0, hi),
        None => Ok(()),
    }
}

fn feed_opt(key: &str, v: Option<f64>) -> Result<()> {
    positive_opt(key, v, FEED_RANGE_MM_MIN.1)?;
    v.map_or(Ok(()), |v| {
        range(key, v, FEED_RANGE_MM_MIN.0, FEED_RANGE_MM_MIN.1)
    })
}

/// Finite coordinates within ±1 km; the key names the element.
fn coordinates(key: &str, v: &[f64]) -> Result<()> {
    for (i, x) in v.iter().enumerate() {
        if !(x.abs() <= MAX_LENGTH_MM) {
            let at = if v.len() > 1 {
                format!("{key}[{i}]")
            } else {
                key.to_string()
            };
            if !x.is_finite() {
                fail!(job, "{at} must be a finite number, got {x}");
            }
            fail!(
                job,
                "{at} must lie within ±{} mm, got {}",
                num(MAX_LENGTH_MM),
                num(*x)
            );
        }
    }
    Ok(())
}

/// The grid must resolve the stock: at least [`MIN_COLUMNS_ACROSS`] columns across.
fn grid_resolves(kind: &str, grid_mm: f64, extent_mm: f64) -> Result<()> {
    if grid_mm * MIN_COLUMNS_ACROSS > extent_mm {
        let keys = if kind == "box" {
            "stock.min and stock.max"
        } else {
            "stock.radius"
        };
        fail!(job,
            "stock.grid ({} mm) is too coarse for the {kind}'s {} mm XY extent ({keys}): at least {MIN_COLUMNS_ACROSS} columns across are needed",
            num(grid_mm),
            num(extent_mm)
        );
    }
    Ok(())
}

impl Job {
    /// Read and check a job file.
    pub fn load(path: &Path) -> Result<Job> {
        let text = crate::bounds::read_text(path, "job file", crate::bounds::MAX_JOB_BYTES)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Job::parse(&text, &path.display().to_string(), &base)
    }

    /// Parse job text; `name` is used in messages, `base_dir` resolves relative paths.
    pub fn parse(text: &str, name: &str, base_dir: &Path) -> Result<Job> {
        let keys = super::toml_keys::KeyPlaces::new(name, text);
        let mut job: Job = toml::from_str(text).map_err(|e| Error::job(keys.de_error(&e)))?;
        job.base_dir = base_dir.to_path_buf();
        job.name = name.to_string();
        job.servo_given = toml::from_str::<toml::Table>(text)
            .map(|t| t.contains_key("servo"))
            .unwrap_or(false);
        // A saved stock's grid is its own.
        if let StockSpec::Saved { path, grid } = &job.stock {
            let dir = job.resolve(path);
            let doc = crate::saved_stock::read_doc(&dir, "stock.path").map_err(|e| {
                e.context(format!("{}: invalid job", keys.of_message("stock.path")))
            })?;
            let saved = doc.grid.spacing_mm;
            if !grid.is_nan() && *grid != saved {
                let at = keys.of_message("stock.grid");
                fail!(job, "{at}: invalid job: stock.grid ({grid} mm) must be the saved stock's, {saved} mm (a saved stock keeps its grid; leave stock.grid out)");
            }
            *job.stock.grid_mut() = saved;
        }
        if let Some(spec) = job.tool_library.clone() {
            let at = keys.of_message("tool_library.path");
            job.attach_library(&spec, base_dir)
                .map_err(|e| e.context(format!("{at}: tool_library")))?;
        }
        // A key's error at the key's own line and column.
        if let Err(e) = job.validate() {
            let at = keys.of_message(&e.to_string());
            return Err(e.context(format!("{at}: invalid job")));
        }
        job.operation_jobs = job.operation_jobs(&keys)?;
        Ok(job)
    }

    /// Override the stock's column spacing (`--grid`) and check the job again.
    pub fn set_grid(&mut self, grid_mm: f64) -> Result<()> {
        if let StockSpec::Saved { grid, .. } = self.stock {
            if grid != grid_mm {
                fail!(job, "--grid {grid_mm}: {} starts from a saved stock, which keeps its grid of {grid} mm", self.name);
            }
        }
        for op in &mut self.operation_jobs {
            op.job.set_grid(grid_mm)?;
        }
        *self.stock.grid_mut() = grid_mm;
        self.validate()
            .context_with(|| format!("--grid {grid_mm}: invalid for {}", self.name))
    }

    /// The program of a job of one program (checked when the job is read: a
    /// job of `[[operations]]` runs each operation's job).
    pub fn program(&self) -> &ProgramSpec {
        self.program
            .as_ref()
            .expect("a job of operations is run operation by operation")
    }

    /// Resolve a path from the job file against its folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// Every number is checked against a plausible range here, at parse time,
    /// with its key: non-finite values (toml reads `inf` and `nan`) and absurd
    /// ones (a 1e-9 mm/s² acceleration, a 1e9 ms period) never reach the work.
    pub(crate) fn validate(&self) -> Result<()> {
        match (&self.program, self.operations.is_empty()) {
            (None, true) => fail!(job, "the job needs a [program] (path = …), or [[operations]] each with its program"),
            (Some(_), false) => fail!(job, "[program] and [[operations]]: a job of operations gives each operation its program"),
            _ => {}
        }
        self.validate_stock()?;
        // A job of operations may leave its tools to them.
        if self.operations.is_empty() || self.tool.is_some() || !self.tools.is_empty() {
            self.validate_tools()?;
        }
        self.validate_cutting()?;
        self.validate_machine()?;
        self.validate_limits()?;
        self.validate_servo()?;
        Ok(())
    }

    /// The stock's numbers: its grid, and a box's or a cylinder's shape.
    fn validate_stock(&self) -> Result<()> {
        range(
            "stock.grid (mm)",
            self.stock.grid_mm(),
            MIN_GRID_MM,
            MAX_LENGTH_MM,
        )?;
        match self.stock {
            StockSpec::Box { min, max, grid } => {
                coordinates("stock.min (mm)", &min)?;
                coordinates("stock.max (mm)", &max)?;
                for k in 0..3 {
                    if !(max[k] > min[k]) {
                        fail!(job, "stock.max must exceed stock.min on every axis, got min {min:?}, max {max:?}");
                    }
                }
                grid_resolves("box", grid, (max[0] - min[0]).min(max[1] - min[1]))?;
            }
            StockSpec::Cylinder {
                center,
                radius,
                z_min,
                z_max,
                grid,
            } => {
                coordinates("stock.center (mm)", &center)?;
                range(
                    "stock.radius (mm)",
                    radius,
                    f64::MIN_POSITIVE,
                    MAX_LENGTH_MM,
                )?;
                coordinates("stock.z_min (mm)", &[z_min])?;
                coordinates("stock.z_max (mm)", &[z_max])?;
                if !(z_max > z_min) {
                    fail!(
                        job,
                        "stock cylinder z_max ({z_max}) must exceed z_min ({z_min})"
                    );
                }
                grid_resolves("cylinder", grid, 2.0 * radius)?;
            }
            StockSpec::Mesh { .. } | StockSpec::Saved { .. } => {}
        }
        Ok(())
    }

    /// The job's own `[[tools]]` entries: `tools` but the library's, which
    /// `[tool_library]` put after them ([`Job::library_tools`]). A job made
    /// from another (an operation's) that sets `tools` resets `library` and
    /// `library_tools` and attaches its own library ([`Job::attach_library`]).
    pub fn own_tools(&self) -> &[ToolSpec] {
        &self.tools[..self.tools.len().saturating_sub(self.library_tools)]
    }

    /// The tools of the library `spec` (a path relative to `base_dir`) put
    /// after the job's own `[[tools]]` (which replace library tools of their
    /// number): `tools`, `library` and `library_tools` set together, the one
    /// place that sets them.
    pub(crate) fn attach_library(&mut self, spec: &ToolLibrarySpec, base_dir: &Path) -> Result<()> {
        let (tools, library) =
            crate::input::tool_library::tools_of_library(spec, base_dir, &self.tools)?;
        self.library_tools = tools.len() - self.tools.len();
        self.tools = tools;
        self.library = Some(library);
        Ok(())
    }

    /// The `[tool]` or the `[[tools]]` table: one of them, numbered once each.
    fn validate_tools(&self) -> Result<()> {
        if self.tool.is_some() && self.tool_library.is_some() {
            fail!(
                job,
                "tool_library: a single [tool] cuts every T, so it cannot be combined with a tool library; give [[tools]] entries (with number = …) to add to the library's tools or replace them"
            );
        }
        // The library's entries were checked where they were read.
        let own = self.own_tools();
        match (&self.tool, self.tools.is_empty()) {
            (None, true) => {
                fail!(
                    job,
                    "the job needs a [tool] or a tool table ([[tools]] with number = …)"
                )
            }
            (Some(_), false) => fail!(
                job,
                "give either one [tool] or a tool table [[tools]], not both"
            ),
            (Some(t), true) => {
                if t.number.is_some() || t.length.is_some() {
                    fail!(job, "tool.number and tool.length belong to [[tools]] entries: a single [tool] is every T, with no gauge length");
                }
                t.validate("tool")?;
            }
            (None, false) => {
                let mut seen = std::collections::BTreeSet::new();
                for (i, t) in own.iter().enumerate() {
                    let key = format!("tools[{i}]");
                    let Some(n) = t.number else {
                        fail!(job, "{key}.number is missing: each [[tools]] entry needs the tool number (T word)");
                    };
                    if n == 0 {
                        fail!(
                            job,
                            "{key}.number must be 1 or more (T0 is the empty spindle), got 0"
                        );
                    }
                    if !seen.insert(n) {
                        fail!(job, "{key}.number: tool {n} is in the table twice");
                    }
                    if let Some(l) = t.length {
                        range(&format!("{key}.length (mm)"), l, 0.0, MAX_LENGTH_MM)?;
                    }
                    t.validate(&key)?;
                }
            }
        }
        Ok(())
    }

    /// `program.feed` and `[cutting]`: the band height against the flute length, the force model's coefficients.
    fn validate_cutting(&self) -> Result<()> {
        feed_opt(
            "program.feed (mm/min)",
            self.program.as_ref().and_then(|p| p.feed),
        )?;
        let c = &self.cutting;
        self.material()?;
        range(
            "cutting.band_height (mm)",
            c.band_height,
            MIN_GRID_MM,
            MAX_LENGTH_MM,
        )?;
        let flute_mm = self
            .tool
            .iter()
            .chain(&self.tools)
            .map(|t| t.flute_length.unwrap_or(2.0 * t.diameter))
            .fold(0.0, f64::max);
        if flute_mm / c.band_height > MAX_BANDS {
            fail!(job,
                "cutting.band_height ({} mm) gives {:.0} bands over the {} mm flute length, more than {MAX_BANDS}: use a larger band height",
                num(c.band_height),
                (flute_mm / c.band_height).ceil(),
                num(flute_mm)
            );
        }
        if let Some(rpm) = c.spindle_rpm {
            range("cutting.spindle_rpm (rev/min)", rpm, 1.0, 1e6)?;
        }
        if let Some(v) = c.force_a {
            range("cutting.force_a", v, 1e-3, 1e7)?;
        }
        if let Some(v) = c.force_n {
            range("cutting.force_n", v, 0.01, 2.0)?;
        }
        // From foams and woods (a few N/mm²) to nickel alloys (≈ 3 500).
        if let Some(kc) = c.kc1_1 {
            range("cutting.kc1_1 (N/mm²)", kc, 1.0, 20_000.0)?;
        }
        if let Some(mc) = c.mc {
            if !(0.0..1.0).contains(&mc) {
                fail!(job, "cutting.mc must lie in 0..1, got {mc}");
            }
        }
        for (what, v) in [
            ("cutting.radial_ratio", c.radial_ratio),
            ("cutting.axial_ratio", c.axial_ratio),
        ] {
            if let Some(v) = v {
                if !(0.0..=100.0).contains(&v) {
                    fail!(job, "{what} must be a number from 0 to 100, got {v}");
                }
            }
        }
        Ok(())
    }

    /// `[machine]`: the machine model's own ranges, told in job keys.
    fn validate_machine(&self) -> Result<()> {
        let m = &self.machine;
        // The machine model's own check (schedule::MACHINE_RANGES), told in job keys.
        if let Err(e) = machine(self).validate() {
            let (name, value, lo, hi) = match e {
                schedule::ScheduleError::MachineOutOfRange {
                    name,
                    value,
                    lo,
                    hi,
                } => (name, value, lo, hi),
                schedule::ScheduleError::InvalidMachine { name, value } => {
                    (name, value, f64::NAN, f64::NAN)
                }
                e => fail!(job, "invalid [machine]: {e}"),
            };
            let key = match name {
                "period_ms" => "machine.period_ms",
                "feed_max_mm_min" => "machine.feed_max (mm/min)",
                "rapid_mm_min" => "machine.rapid (mm/min)",
                "accel_mm_s2" => "machine.accel (mm/s²)",
                "jerk_mm_s3" => "machine.jerk (mm/s³)",
                "block_time_ms" => "machine.block_time_ms",
                other => other,
            };
            if lo.is_nan() {
                // Not a finite positive number.
                positive_opt(key, Some(value), f64::INFINITY)?;
                fail!(job, "{key} must be a finite number, got {value}");
            }
            range(key, value, lo, hi)?;
        }
        if m.arcs_as_lines && m.block_time_ms.is_none() {
            fail!(job, "machine.arcs_as_lines needs machine.block_time_ms (ms), the time the control takes per block (S0)");
        }
        if let Some(p) = m.start {
            coordinates("machine.start (mm)", &p)?;
        }
        self.validate_controller()
    }

    /// `[machine]`'s controller keys: each only with its controller, in its range.
    fn validate_controller(&self) -> Result<()> {
        let m = &self.machine;
        let grbl_keys = [
            ("junction_deviation_mm", m.junction_deviation_mm.is_some()),
            ("arc_tolerance_mm", m.arc_tolerance_mm.is_some()),
            ("planner_blocks", m.planner_blocks.is_some()),
            ("grbl_settings", m.grbl_settings.is_some()),
        ];
        if m.controller != ControllerKind::Grbl {
            if let Some((key, _)) = grbl_keys.iter().find(|k| k.1) {
                fail!(job, "machine.{key} is a setting of controller = \"grbl\"; this job's controller is \"{}\"", m.controller.name());
            }
        }
        let linuxcnc_keys = [
            ("blend_tolerance_mm", m.blend_tolerance_mm.is_some()),
            ("linuxcnc_ini", m.linuxcnc_ini.is_some()),
        ];
        if m.controller != ControllerKind::Linuxcnc {
            if let Some((key, _)) = linuxcnc_keys.iter().find(|k| k.1) {
                fail!(job, "machine.{key} is a setting of controller = \"linuxcnc\"; this job's controller is \"{}\"", m.controller.name());
            }
        }
        let grbl_range = |name: &str| {
            schedule::controller::grbl::GRBL_RANGES
                .iter()
                .find(|r| r.0 == name)
                .map(|r| (r.1, r.2))
                .expect("a grbl setting's range")
        };
        for (key, name, value) in [
            (
                "machine.junction_deviation_mm",
                "junction_deviation_mm",
                m.junction_deviation_mm,
            ),
            (
                "machine.arc_tolerance_mm",
                "arc_tolerance_mm",
                m.arc_tolerance_mm,
            ),
            (
                "machine.planner_blocks",
                "planner_blocks",
                m.planner_blocks.map(f64::from),
            ),
        ] {
            if let Some(v) = value {
                let (lo, hi) = grbl_range(name);
                if !v.is_finite() {
                    fail!(job, "{key} must be a finite number, got {v}");
                }
                range(key, v, lo, hi)?;
            }
        }
        if let Some(v) = m.blend_tolerance_mm {
            positive_opt("machine.blend_tolerance_mm", Some(v), 100.0)?;
            range("machine.blend_tolerance_mm", v, 1e-6, 100.0)?;
        }
        Ok(())
    }

    /// `[limits]` and `[design]`.
    fn validate_limits(&self) -> Result<()> {
        let m = &self.machine;
        let l = &self.limits;
        for (key, v) in [
            ("limits.mrr_max (mm³/s)", l.mrr_max),
            ("limits.force_max (N)", l.force_max),
            ("limits.deflection_max_um", l.deflection_max_um),
            ("limits.power_max_kw", l.power_max_kw),
        ] {
            positive_opt(key, v, 1e9)?;
            if let Some(v) = v {
                range(key, v, 1e-6, 1e9)?;
            }
        }
        feed_opt("limits.feed_min (mm/min)", l.feed_min)?;
        feed_opt("limits.feed_max (mm/min)", l.feed_max)?;
        feed_opt("limits.v0 (mm/min)", l.v0)?;
        if let Some(v) = l.feed_scale_max {
            range("limits.feed_scale_max", v, 0.01, 1000.0)?;
        }
        if let (Some(lo), Some(hi)) = (l.feed_min, l.feed_max.or(Some(m.feed_max))) {
            if lo > hi {
                fail!(
                    job,
                    "limits.feed_min ({lo}) exceeds the highest feed ({hi})"
                );
            }
        }
        if l.angle_rule && l.v0.is_none() {
            fail!(
                job,
                "limits.angle_rule needs v0 (mm/min), the feed near the ball tip"
            );
        }
        if let Some(d) = &self.design {
            range("design.gouge_tolerance_um", d.gouge_tolerance_um, 0.0, 1e6)?;
            range("design.stock_tolerance_um", d.stock_tolerance_um, 0.0, 1e6)?;
        }
        Ok(())
    }

    /// `[servo]` and `[offsets]`.
    fn validate_servo(&self) -> Result<()> {
        let sv = &self.servo;
        range("servo.kp (1/s)", sv.kp, 1e-3, 1e5)?;
        range("servo.tolerance_mm", sv.tolerance_mm, 1e-9, MAX_LENGTH_MM)?;
        range(
            "servo.jerk_reference (mm/s³)",
            sv.jerk_reference,
            1e-3,
            1e15,
        )?;
        range(
            "servo.precomp_threshold_mm",
            sv.precomp_threshold_mm,
            1e-9,
            MAX_LENGTH_MM,
        )?;
        if sv.precomp_iterations > MAX_PRECOMP_ITERATIONS {
            fail!(
                job,
                "servo.precomp_iterations must be at most {MAX_PRECOMP_ITERATIONS}, got {}",
                sv.precomp_iterations
            );
        }
        if let Some(v) = sv.zeta {
            range("servo.zeta", v, 1e-3, 100.0)?;
        }
        if let Some(v) = sv.omega_n {
            range("servo.omega_n (rad/s)", v, 1e-2, 1e6)?;
        }
        for (key, v) in [
            ("servo.ka", sv.ka),
            ("servo.kb", sv.kb),
            ("servo.kc", sv.kc),
        ] {
            range(key, v, 0.0, 1e6)?;
        }
        if sv.zeta.is_some() != sv.omega_n.is_some() {
            fail!(
                job,
                "servo: a second-order drive needs both zeta and omega_n"
            );
        }
        range("servo.feedforward", sv.feedforward, 0.0, 1.0)?;
        for (i, o) in [
            self.offsets.g54,
            self.offsets.g55,
            self.offsets.g56,
            self.offsets.g57,
            self.offsets.g58,
            self.offsets.g59,
        ]
        .iter()
        .enumerate()
        {
            if let Some(o) = o {
                coordinates(&format!("offsets.g{} (mm)", 54 + i), o)?;
            }
        }
        Ok(())
    }

    /// The work material `cutting.material` names (one check, with the key).
    pub fn material(&self) -> Result<&'static cutting::Material> {
        let name = &self.cutting.material;
        cutting::Material::by_name(name).ok_or_else(|| {
            let names: Vec<&str> = cutting::Material::ALL.iter().map(|m| m.name).collect();
            Error::job(format!(
                "cutting.material {name:?} is not one of the known materials: {}",
                names.join(", ")
            ))
        })
    }

    /// Largest feed per tooth of the first tool, mm/tooth: its `fz_max`,
    /// else the default for its diameter and the work material (MODEL.md §2.1).
    pub fn fz_max_mm(&self) -> Option<f64> {
        self.tool_specs()[0].1.fz_max_mm(&self.cutting.material)
    }

    /// The tools, each with its number (`None`: the single [tool], every T).
    pub fn tool_specs(&self) -> Vec<(Option<u32>, &ToolSpec)> {
        match &self.tool {
            Some(t) => vec![(None, t)],
            None => self.tools.iter().map(|t| (t.number, t)).collect(),
        }
    }

    /// The first tool (the single [tool], or the table's first entry) as the
    /// kernel and the beam model see it.
    pub fn tool(&self) -> Result<dexel::Tool> {
        let (_, t) = self.tool_specs()[0];
        t.dexel_tool()
    }
}

impl ToolSpec {
    /// Every key against the range a shop's tools have (docs/guide/job.md
    /// lists them beside the keys): a tool key outside it is a typing slip
    /// (`youngs_modulus_mpa = 1e-3` bent a Ø6 ball by 3.5·10¹⁰ µm).
    pub(crate) fn validate(&self, key: &str) -> Result<()> {
        let t = self;
        let k = |name: &str| format!("{key}.{name}");
        range(
            &k("diameter (mm)"),
            t.diameter,
            TOOL_DIAMETER_MM.0,
            TOOL_DIAMETER_MM.1,
        )?;
        match (t.kind, t.corner_radius) {
            // The kernel's own range (dexel::Tool::validate), told once here:
            // 0 is a flat end, half the diameter a ball.
            (ToolKind::Bull, Some(r)) if !(r >= MIN_CORNER_RADIUS_MM && r < t.diameter / 2.0) => fail!(
                job,
                "{key}.corner_radius (mm) must lie strictly between 0 and half the diameter ({}), and be at least {MIN_CORNER_RADIUS_MM}, got {} (0 is kind = \"flat\", half the diameter kind = \"ball\")",
                num(t.diameter / 2.0),
                num(r)
            ),
            (ToolKind::Bull, Some(_)) => {}
            (ToolKind::Bull, None) => fail!(
                job,
                "{key}.corner_radius is missing: a bull nose (kind = \"bull\") needs its corner radius (mm)"
            ),
            (_, Some(_)) => fail!(
                job,
                "{key}.corner_radius is a key of a bull nose (kind = \"bull\") only, not of kind = \"{}\"",
                if t.kind == ToolKind::Ball { "ball" } else { "flat" }
            ),
            (_, None) => {}
        }
        let opt = |name: &str, v: Option<f64>, (lo, hi): (f64, f64)| match v {
            Some(v) => range(&k(name), v, lo, hi),
            None => Ok(()),
        };
        opt("flute_length (mm)", t.flute_length, TOOL_LENGTH_MM)?;
        opt("stickout (mm)", t.stickout, TOOL_LENGTH_MM)?;
        // The kernel's check (dexel::Tool::validate), with the keys and defaults.
        let tool = self.dexel_shape();
        let (flute, stickout) = (
            t.flute_length.unwrap_or(tool.flute_length_mm),
            t.stickout.unwrap_or(tool.stickout_mm),
        );
        if flute > stickout {
            let said = |v: Option<f64>, default: &str| {
                if v.is_some() {
                    String::new()
                } else {
                    format!(", its default {default}")
                }
            };
            fail!(
                job,
                "{key}.flute_length ({} mm{}) is longer than {key}.stickout ({} mm{}): the flutes end inside the holder",
                num(flute),
                said(t.flute_length, "2 × diameter"),
                num(stickout),
                said(t.stickout, "8 × diameter")
            );
        }
        opt("youngs_modulus_mpa", t.youngs_modulus_mpa, TOOL_MODULUS_MPA)?;
        opt("helix_deg (°)", t.helix_deg, TOOL_HELIX_DEG)?;
        opt(
            "effective_diameter (mm)",
            t.effective_diameter,
            (t.diameter / 10.0, t.diameter),
        )?;
        if !(1..=MAX_FLUTES).contains(&t.flutes) {
            fail!(
                job,
                "{key}.flutes must be 1..{MAX_FLUTES}, got {}",
                t.flutes
            );
        }
        opt("fz_max (mm/tooth)", t.fz_max, TOOL_FZ_MAX_MM)?;
        opt("shank_diameter (mm)", t.shank_diameter, TOOL_DIAMETER_MM)?;
        opt(
            "holder_stiffness_n_per_um",
            t.holder_stiffness_n_per_um,
            HOLDER_STIFFNESS_N_PER_UM,
        )?;
        opt("stress_limit_mpa", t.stress_limit_mpa, TOOL_STRENGTH_MPA)?;
        opt(
            "rupture_strength_mpa",
            t.rupture_strength_mpa,
            TOOL_STRENGTH_MPA,
        )?;
        if let (Some(limit), Some(rupture)) = (t.stress_limit_mpa, t.rupture_strength_mpa) {
            if rupture < limit {
                fail!(
                    job,
                    "{key}.rupture_strength_mpa ({rupture} MPa) is below {key}.stress_limit_mpa ({limit} MPa): the stress a tool breaks at cannot be below the one it may carry (docs/MODEL.md §4.4)"
                );
            }
        }
        Ok(())
    }

    /// Largest feed per tooth, mm/tooth: `fz_max`, else the default for the
    /// diameter and the work material `material` (MODEL.md §2.1).
    pub fn fz_max_mm(&self, material: &str) -> Option<f64> {
        self.fz_max
            .or_else(|| cutting::chipload::default_fz_max_mm(material, self.diameter))
    }

    /// The kernel's tool of this shape and diameter, with its defaults.
    fn dexel_shape(&self) -> dexel::Tool {
        match self.kind {
            ToolKind::Ball => dexel::Tool::ball(self.diameter),
            ToolKind::Flat => dexel::Tool::flat(self.diameter),
            ToolKind::Bull => dexel::Tool::bull(self.diameter, self.corner_radius.unwrap_or(0.0)),
        }
    }

    /// The tool as the kernel and the beam model see it.
    pub fn dexel_tool(&self) -> Result<dexel::Tool> {
        let t = self;
        let base = t.dexel_shape();
        let tool = dexel::Tool {
            flute_length_mm: t.flute_length.unwrap_or(base.flute_length_mm),
            stickout_mm: t.stickout.unwrap_or(base.stickout_mm),
            flutes: t.flutes,
            youngs_modulus_mpa: t.youngs_modulus_mpa.unwrap_or(base.youngs_modulus_mpa),
            effective_diameter_mm: t.effective_diameter.unwrap_or(base.effective_diameter_mm),
            ..base
        };
        tool.validate().or_job(|| "invalid [tool]".into())?;
        Ok(tool)
    }
}

impl ControllerKind {
    /// The name the job file writes.
    pub fn name(self) -> &'static str {
        match self {
            ControllerKind::Ideal => "ideal",
            ControllerKind::Grbl => "grbl",
            ControllerKind::Linuxcnc => "linuxcnc",
        }
    }
}

/// The job's controller with its settings: a grbl dump (`grbl_settings`) read here, its
/// values over grbl's defaults and the machine's `rapid` and `accel`, the job's own
/// `junction_deviation_mm`, `arc_tolerance_mm` and `planner_blocks` over the dump's.
pub fn controller(job: &Job) -> Result<schedule::Controller> {
    let m = &job.machine;
    Ok(match m.controller {
        ControllerKind::Ideal => schedule::Controller::Ideal,
        ControllerKind::Linuxcnc => {
            let ini = match &m.linuxcnc_ini {
                Some(path) => {
                    let file = job.resolve(path);
                    crate::bounds::check_input_file(&file, "LinuxCNC INI file", 1 << 20)?;
                    let text = std::fs::read_to_string(&file)
                        .map_err(|e| Error::io("cannot read LinuxCNC INI file", &file, e))?;
                    let ini = schedule::linuxcnc::ini::settings_from_ini(
                        &text,
                        &file.display().to_string(),
                    )
                    .map_err(|e| Error::job(e.to_string()))?;
                    Some(ini)
                }
                None => None,
            };
            schedule::Controller::LinuxCnc(schedule::controller::LinuxCncSettings {
                blend_tolerance_mm: m.blend_tolerance_mm,
                ini,
            })
        }
        ControllerKind::Grbl => {
            let mut settings = schedule::controller::GrblSettings::for_machine(&machine(job));
            if let Some(dump) = &m.grbl_settings {
                let file = job.resolve(dump);
                crate::bounds::check_input_file(&file, "grbl settings dump", 1 << 20)?;
                let text = std::fs::read_to_string(&file)
                    .map_err(|e| Error::io("cannot read grbl settings dump", &file, e))?;
                settings = settings.with_dump(&text).map_err(|e| {
                    Error::job(format!("{}:{}: {}", file.display(), e.line, e.what))
                })?;
                settings
                    .validate()
                    .map_err(|e| Error::job(format!("{}: {e}", file.display())))?;
            }
            if let Some(v) = m.junction_deviation_mm {
                settings.junction_deviation_mm = v;
            }
            if let Some(v) = m.arc_tolerance_mm {
                settings.arc_tolerance_mm = v;
            }
            if let Some(v) = m.planner_blocks {
                settings.planner_blocks = v as usize;
            }
            schedule::Controller::Grbl(settings)
        }
    })
}

/// The machine limits from the job.
pub fn machine(job: &Job) -> schedule::Machine {
    let m = &job.machine;
    schedule::Machine {
        period_ms: m.period_ms,
        feed_max_mm_min: m.feed_max,
        rapid_mm_min: m.rapid,
        accel_mm_s2: m.accel,
        jerk_mm_s3: m.jerk,
        block_time_ms: m.block_time_ms,
    }
}

#[cfg(test)]
mod tests;
