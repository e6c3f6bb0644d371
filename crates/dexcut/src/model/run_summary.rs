//! The numbers summary.json holds of a run: its headline numbers
//! ([`Summary`]), its peaks per tool ([`ToolPeaks`]) and the geometry of its
//! column grid ([`GridInfo`]). Data only.

use serde::Serialize;

use crate::error::{fail, Result};
use crate::model::warnings::Warnings;

/// Headline numbers of a run (summary.json).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Summary {
    /// Stock volume before the run, mm³.
    pub initial_volume_mm3: f64,
    /// Stock volume after the run, mm³.
    pub final_volume_mm3: f64,
    /// Volume the program removed, mm³.
    pub removed_volume_mm3: f64,
    /// Time the program runs, s.
    pub cycle_time_s: f64,
    /// Largest MRR of a servo period, mm³/s: a period under one grid cell of
    /// path measured over the periods around it, all-rapid periods left out
    /// ([`crate::Run::peak_period_mrr_mm3_s`], MODEL.md §2.3).
    pub peak_mrr_mm3_s: f64,
    /// Largest MRR averaged over at least [`crate::run::MRR_WINDOW_S`] and
    /// [`crate::run::MRR_WINDOW_CELLS`] grid cells of path, mm³/s: the per-period value
    /// carries the dexel grid's column quantisation (±15 % for a slot at 0.8
    /// cells per period), which this average resolves.
    pub peak_mrr_windowed_mm3_s: f64,
    /// Largest cutting force on the tool (a step's mean over a revolution), N.
    pub peak_force_n: f64,
    /// Largest lateral force on the tool at any instant of a revolution
    /// (MODEL.md §3.4), N: what `[limits] force_max` and the stress act on.
    #[serde(default)]
    pub peak_force_revolution_n: f64,
    /// Largest spindle cutting power, W, and torque, N·m.
    pub peak_power_w: f64,
    /// Largest spindle torque, N·m.
    pub peak_torque_nm: f64,
    /// Largest deflection at the contact height (closed loop), µm; where the
    /// tool breaks, the deflection at rupture (MODEL.md §4.4).
    pub peak_deflection_um: f64,
    /// The peak deflection is a step's that breaks the tool: capped at its
    /// elastic deflection at rupture (MODEL.md §4.4).
    #[serde(default)]
    pub peak_deflection_at_rupture: bool,
    /// Steps whose stress exceeds their tool's rupture strength: the tool
    /// breaks (`tool_breaks` warning, MODEL.md §4.4).
    #[serde(default)]
    pub tool_breaks_steps: usize,
    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub peak_cutting_feed_mm_min: f64,
    /// Largest tip deflection (closed loop), µm.
    pub peak_tip_deflection_um: f64,
    /// Largest deflection at the contact height of the rigid tool's removal, µm
    /// (what an open-loop model predicts).
    pub rigid_peak_deflection_um: f64,
    /// Largest material left on the surface, µm (≥ 0; error map, MODEL.md §5).
    pub max_error_um: f64,
    /// Deepest overcut, µm (≤ 0).
    pub min_error_um: f64,
    /// The closed loop of removal and deflection ran (`[cutting] closed_loop`, MODEL.md §5.1).
    pub closed_loop: bool,
    /// Every step's offset agreed with its deflection (false for an open loop
    /// whose rigid tool bent by more than the tolerance).
    pub closed_loop_converged: bool,
    /// Sweeps (the rigid one included) and the largest remaining disagreement
    /// between offset and deflection across the path, µm.
    pub closed_loop_passes: usize,
    #[serde(deserialize_with = "crate::model::summary::f64_or_nan")]
    /// Largest disagreement left between applied offset and deflection, µm.
    pub closed_loop_residual_um: f64,
    /// Steps whose offset and deflection still disagree by more than the tolerance.
    pub closed_loop_unconverged_steps: usize,
    /// Largest von Mises stress in the tool, MPa, and the allowable stress.
    pub peak_stress_mpa: f64,
    #[serde(deserialize_with = "crate::model::summary::f64_or_nan")]
    /// Allowable stress of the weakest tool, MPa (null in JSON when no tool has one).
    pub stress_limit_mpa: f64,
    /// Steps swept (servo periods or moves).
    pub steps: usize,
    /// Column spacing, mm.
    pub grid_mm: f64,
    /// Columns of the stock.
    pub columns: usize,
    /// Steps that removed material above the flute length.
    pub shank_contact_steps: usize,
    /// Rapid steps that removed material (collisions).
    pub rapid_collision_steps: usize,
    /// First program line with a rapid collision, if any.
    pub first_collision_line: Option<u32>,
    /// What a user must look at, each with its program line.
    pub warnings: Warnings,
    /// Column visits of the sweep kernel.
    pub columns_evaluated: u64,
    /// Wall time of the sweeps, s.
    pub sweep_time_s: f64,
    /// The same peaks per tool, in order of first use.
    pub tools: Vec<ToolPeaks>,
}

/// Peaks of the steps one tool cut (summary.json `tools`).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct ToolPeaks {
    /// T number.
    pub tool: u32,
    /// Steps cut with this tool.
    pub steps: usize,
    /// Volume this tool removed, mm³.
    pub removed_volume_mm3: f64,
    /// Time the tool is in the spindle, s.
    pub time_s: f64,
    /// Largest MRR per period, mm³/s.
    pub peak_mrr_mm3_s: f64,
    /// Largest cutting force, N.
    pub peak_force_n: f64,
    /// Largest deflection at the contact height, µm.
    pub peak_deflection_um: f64,
}

impl Summary {
    /// A result that is inf or NaN is an error, not an output.
    pub fn check_finite(&self) -> Result<()> {
        // Each result with the inputs that make it (the job's keys), so that a
        // result the ranges let through non-finite still names its causes.
        const STOCK: &str = "[stock] (its shape, grid) and the tools' sizes";
        const MOTION: &str =
            "[machine] feed_max, rapid, accel, jerk, period_ms and the program's feeds";
        const FORCE: &str =
            "[cutting] (kc1_1, mc, force_a, force_n, spindle_rpm), the tools' flutes and the feeds";
        const BEAM: &str = "the force's inputs and the tools' youngs_modulus_mpa, stickout, flute_length, effective_diameter, shank_diameter and holder_stiffness_n_per_um";
        for (key, v, inputs) in [
            ("initial volume (mm³)", self.initial_volume_mm3, STOCK),
            ("final volume (mm³)", self.final_volume_mm3, STOCK),
            ("removed volume (mm³)", self.removed_volume_mm3, STOCK),
            ("cycle time (s)", self.cycle_time_s, MOTION),
            ("peak MRR (mm³/s)", self.peak_mrr_mm3_s, MOTION),
            (
                "peak windowed MRR (mm³/s)",
                self.peak_mrr_windowed_mm3_s,
                MOTION,
            ),
            ("peak force (N)", self.peak_force_n, FORCE),
            (
                "peak force over a revolution (N)",
                self.peak_force_revolution_n,
                FORCE,
            ),
            ("peak deflection (µm)", self.peak_deflection_um, BEAM),
        ] {
            if !v.is_finite() {
                fail!(
                    run,
                    "the run's {key} is {v}: the inputs give no finite result; it is made of {inputs}"
                );
            }
        }
        Ok(())
    }
}

/// Grid geometry recorded in summary.json so `report` can rebuild maps.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct GridInfo {
    /// Columns along X.
    pub nx: usize,
    /// Columns along Y.
    pub ny: usize,
    /// Centre of column (0, 0), mm.
    pub x0_mm: f64,
    /// Centre of column (0, 0), y, mm.
    pub y0_mm: f64,
    /// Column spacing, mm.
    pub spacing_mm: f64,
}

impl GridInfo {
    /// The geometry of a dexel grid.
    pub fn of(g: &dexel::Grid) -> GridInfo {
        GridInfo {
            nx: g.nx,
            ny: g.ny,
            x0_mm: g.x_mm(0),
            y0_mm: g.y_mm(0),
            spacing_mm: g.spacing_mm,
        }
    }

    /// The export crate's copy of the grid geometry.
    pub fn export(&self) -> export::Grid {
        export::Grid {
            nx: self.nx,
            ny: self.ny,
            x0_mm: self.x0_mm,
            y0_mm: self.y0_mm,
            spacing_mm: self.spacing_mm,
        }
    }
}
