//! The job file (TOML): what stock, tool, program and machine a run uses.
//!
//! Keys follow the issue's names; every length is mm, feeds mm/min, times as
//! named (`period_ms`, `block_time_ms`), rates mm³/s. Unknown keys are errors.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Deserialize;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    pub stock: StockSpec,
    pub tool: ToolSpec,
    pub program: ProgramSpec,
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
    /// Folder that relative paths are resolved against (the job file's folder).
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// Name shown in messages and reports.
    #[serde(skip)]
    pub name: String,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum StockKind {
    Box,
    Cylinder,
    Mesh,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StockSpec {
    pub kind: StockKind,
    /// Box corners, mm.
    pub min: Option<[f64; 3]>,
    pub max: Option<[f64; 3]>,
    /// Cylinder axis position (x, y), radius and z range, mm.
    pub center: Option<[f64; 2]>,
    pub radius: Option<f64>,
    pub z_min: Option<f64>,
    pub z_max: Option<f64>,
    /// Mesh file (STL or OBJ), relative to the job file.
    pub path: Option<PathBuf>,
    /// Column spacing, mm.
    #[serde(alias = "grid_mm")]
    pub grid: f64,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ToolKind {
    Ball,
    Flat,
    Bull,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    pub kind: ToolKind,
    /// mm.
    pub diameter: f64,
    /// mm; required for bull-nose tools.
    pub corner_radius: Option<f64>,
    /// mm; default 2 × diameter.
    pub flute_length: Option<f64>,
    /// Holder face to tip, mm; default 8 × diameter.
    pub stickout: Option<f64>,
    #[serde(default = "default_flutes")]
    pub flutes: u32,
    /// MPa; default 600 000 (carbide). HSS is about 210 000.
    pub youngs_modulus_mpa: Option<f64>,
    /// Effective diameter of the fluted part for the beam model, mm; default 0.8 × diameter.
    pub effective_diameter: Option<f64>,
}

fn default_flutes() -> u32 {
    2
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramSpec {
    /// G-code (.nc, .ngc, .tap, .gcode) or tool-tip points (.csv with header x,y,z[,feed]).
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
    /// Force law F = a·V^n (N, mm³/rev/tooth); default from the material.
    pub force_a: Option<f64>,
    pub force_n: Option<f64>,
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
            force_a: None,
            force_n: None,
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
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
    /// Tool-tip position (x, y, z), mm, machine frame, when the program
    /// starts. Default: above the program's first point, at the highest Z
    /// the program reaches, so the first move is a straight rapid down.
    pub start: Option<[f64; 3]>,
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
            start: None,
        }
    }
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSpec {
    /// Material removal rate limit, mm³/s.
    pub mrr_max: Option<f64>,
    /// Cutting force limit, N.
    pub force_max: Option<f64>,
    /// Tool tip deflection limit, µm.
    pub deflection_max_um: Option<f64>,
    /// Lowest feed the optimiser may write, mm/min.
    pub feed_min: Option<f64>,
    /// Highest feed the optimiser may write, mm/min (default: machine feed_max).
    pub feed_max: Option<f64>,
    /// S3's cutting-surface-angle rule for ball-end mills.
    #[serde(default)]
    pub angle_rule: bool,
    /// S3's v0: feed near the ball tip, mm/min.
    pub v0: Option<f64>,
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
}

/// `FILE:LINE:COL` of a byte offset.
pub fn location(file: &str, text: &str, offset: usize) -> String {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("{file}:{line}:{col}")
}

impl Job {
    /// Read and check a job file.
    pub fn load(path: &Path) -> Result<Job> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read job file {}", path.display()))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Job::parse(&text, &path.display().to_string(), &base)
    }

    /// Parse job text; `name` is used in messages, `base_dir` resolves relative paths.
    pub fn parse(text: &str, name: &str, base_dir: &Path) -> Result<Job> {
        let mut job: Job = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map_or_else(|| name.to_string(), |s| location(name, text, s.start));
            anyhow::anyhow!("{at}: {}", e.message())
        })?;
        job.base_dir = base_dir.to_path_buf();
        job.name = name.to_string();
        job.validate()
            .with_context(|| format!("{name}: invalid job"))?;
        Ok(job)
    }

    /// Resolve a path from the job file against its folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    fn validate(&self) -> Result<()> {
        fn positive(what: &str, v: f64) -> Result<()> {
            if !(v > 0.0 && v.is_finite()) {
                bail!("{what} must be a positive number, got {v}");
            }
            Ok(())
        }
        fn positive_opt(what: &str, v: Option<f64>) -> Result<()> {
            v.map_or(Ok(()), |v| positive(what, v))
        }
        let s = &self.stock;
        positive("stock.grid (mm)", s.grid)?;
        match s.kind {
            StockKind::Box => {
                let (Some(min), Some(max)) = (s.min, s.max) else {
                    bail!("stock kind \"box\" needs min = [x, y, z] and max = [x, y, z]")
                };
                for k in 0..3 {
                    if !(max[k] > min[k]) {
                        bail!("stock box max must exceed min on every axis, got min {min:?}, max {max:?}");
                    }
                }
            }
            StockKind::Cylinder => {
                let (Some(_), Some(r), Some(lo), Some(hi)) = (s.center, s.radius, s.z_min, s.z_max)
                else {
                    bail!("stock kind \"cylinder\" needs center = [x, y], radius, z_min and z_max")
                };
                positive("stock.radius (mm)", r)?;
                if !(hi > lo) {
                    bail!("stock cylinder z_max ({hi}) must exceed z_min ({lo})");
                }
            }
            StockKind::Mesh => {
                if s.path.is_none() {
                    bail!("stock kind \"mesh\" needs path = \"FILE.stl\" (or .obj)");
                }
            }
        }
        let t = &self.tool;
        positive("tool.diameter (mm)", t.diameter)?;
        positive_opt("tool.flute_length (mm)", t.flute_length)?;
        positive_opt("tool.stickout (mm)", t.stickout)?;
        if t.kind == ToolKind::Bull && t.corner_radius.is_none() {
            bail!("tool kind \"bull\" needs corner_radius (mm)");
        }
        positive_opt("program.feed (mm/min)", self.program.feed)?;
        let c = &self.cutting;
        positive("cutting.band_height (mm)", c.band_height)?;
        positive_opt("cutting.spindle_rpm", c.spindle_rpm)?;
        positive_opt("cutting.force_a", c.force_a)?;
        positive_opt("cutting.force_n", c.force_n)?;
        let m = &self.machine;
        positive("machine.period_ms", m.period_ms)?;
        positive("machine.feed_max (mm/min)", m.feed_max)?;
        positive("machine.rapid (mm/min)", m.rapid)?;
        for a in m.accel {
            positive("machine.accel (mm/s²)", a)?;
        }
        if let Some(j) = m.jerk {
            for v in j {
                positive("machine.jerk (mm/s³)", v)?;
            }
        }
        positive_opt("machine.block_time_ms", m.block_time_ms)?;
        if let Some(p) = m.start {
            if p.iter().any(|v| !v.is_finite()) {
                bail!("machine.start must be three finite numbers (mm)");
            }
        }
        let l = &self.limits;
        positive_opt("limits.mrr_max (mm³/s)", l.mrr_max)?;
        positive_opt("limits.force_max (N)", l.force_max)?;
        positive_opt("limits.deflection_max_um", l.deflection_max_um)?;
        positive_opt("limits.feed_min (mm/min)", l.feed_min)?;
        positive_opt("limits.feed_max (mm/min)", l.feed_max)?;
        positive_opt("limits.v0 (mm/min)", l.v0)?;
        if let (Some(lo), Some(hi)) = (l.feed_min, l.feed_max.or(Some(m.feed_max))) {
            if lo > hi {
                bail!("limits.feed_min ({lo}) exceeds the highest feed ({hi})");
            }
        }
        if l.angle_rule && l.v0.is_none() {
            bail!("limits.angle_rule needs v0 (mm/min), the feed near the ball tip");
        }
        positive("servo.kp (1/s)", self.servo.kp)?;
        positive("servo.tolerance_mm", self.servo.tolerance_mm)?;
        positive("servo.jerk_reference (mm/s³)", self.servo.jerk_reference)?;
        positive(
            "servo.precomp_threshold_mm",
            self.servo.precomp_threshold_mm,
        )?;
        positive_opt("servo.zeta", self.servo.zeta)?;
        positive_opt("servo.omega_n (rad/s)", self.servo.omega_n)?;
        if self.servo.zeta.is_some() != self.servo.omega_n.is_some() {
            bail!("servo: a second-order drive needs both zeta and omega_n");
        }
        if !(0.0..=1.0).contains(&self.servo.feedforward) {
            bail!(
                "servo.feedforward must lie in 0..1, got {}",
                self.servo.feedforward
            );
        }
        Ok(())
    }

    /// The tool as the kernel and the beam model see it.
    pub fn tool(&self) -> Result<dexel::Tool> {
        let t = &self.tool;
        let base = match t.kind {
            ToolKind::Ball => dexel::Tool::ball(t.diameter),
            ToolKind::Flat => dexel::Tool::flat(t.diameter),
            ToolKind::Bull => dexel::Tool::bull(t.diameter, t.corner_radius.unwrap_or(0.0)),
        };
        let tool = dexel::Tool {
            flute_length_mm: t.flute_length.unwrap_or(base.flute_length_mm),
            stickout_mm: t.stickout.unwrap_or(base.stickout_mm),
            flutes: t.flutes,
            youngs_modulus_mpa: t.youngs_modulus_mpa.unwrap_or(base.youngs_modulus_mpa),
            effective_diameter_mm: t.effective_diameter.unwrap_or(base.effective_diameter_mm),
            ..base
        };
        tool.validate().context("invalid [tool]")?;
        Ok(tool)
    }
}

#[cfg(test)]
mod tests {
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
        assert_eq!(job.resolve(&job.program.path), PathBuf::from("/jobs/p.csv"));
        assert_eq!(job.tool().unwrap().flute_length_mm, 12.0);
    }

    #[test]
    fn unknown_key_names_file_line_and_column() {
        let text = MINIMAL.replace("feed = 1000", "feed = 1000\nspeed = 3");
        let err = Job::parse(&text, "job.toml", Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("job.toml:13:1: unknown field `speed`"),
            "{err}"
        );
    }

    #[test]
    fn negative_sizes_are_rejected() {
        let text = MINIMAL.replace("diameter = 6", "diameter = -6");
        let err = format!(
            "{:#}",
            Job::parse(&text, "job.toml", Path::new(".")).unwrap_err()
        );
        assert!(
            err.contains("tool.diameter (mm) must be a positive number"),
            "{err}"
        );
        let text = MINIMAL.replace("max = [10, 10, 10]", "max = [10, -10, 10]");
        assert!(Job::parse(&text, "job.toml", Path::new(".")).is_err());
    }
}
