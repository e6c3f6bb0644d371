//! The job's tools: one `[tool]` (tool 1 and every T) or a `[[tools]]`
//! table keyed by the T word, each with its kernel shape, gauge length and
//! force and beam model (MODEL.md §9.1).

use std::collections::BTreeMap;

use crate::error::{fail, Result};
use cutting::CuttingModel;
use dexel::Tool;

use crate::input::job::{ForceModelKind, Job, ToolSpec};
use crate::input::program::Program;

/// One tool of the job.
#[derive(Clone, Debug)]
pub struct ToolEntry {
    /// T number (1 for the single `[tool]`).
    pub number: u32,
    pub tool: Tool,
    /// Gauge length, mm (G43).
    pub length_mm: f64,
    pub model: CuttingModel,
    /// Largest feed per tooth, mm/tooth (chip-load cap of optimize).
    pub fz_max_mm: Option<f64>,
    /// Allowable stress in the tool, MPa (MODEL.md §4.4).
    pub stress_limit_mpa: f64,
    /// Stress at which the tool breaks, MPa (MODEL.md §4.4).
    pub rupture_strength_mpa: f64,
    /// `[cutting] spindle_rpm` when the job gives it: it overrides S words.
    pub job_rpm: Option<f64>,
    /// `fz_max` is the job's (not the default of MODEL.md §2.1's table).
    pub fz_max_given: bool,
}

/// Slowest cutting speed at the tool's edge that an S word is taken for,
/// m/min (MODEL.md §2.1): below the slowest published starting speed for
/// milling (HSS in hardened steel, about 10–15 m/min), an S word is not a
/// spindle speed in rev/min (a percentage, a laser's power).
pub const MIN_CUTTING_SPEED_M_MIN: f64 = 10.0;

/// An S word of at least this many rev/min is a spindle speed whatever the
/// tool (MODEL.md §2.1): above GRBL's default laser scale ($30 = 1000) and any
/// percent override, and what micro tools run at (pcb2gcode's S12000 on a
/// Ø0.2 mm tool gives 7.5 m/min).
pub const MIN_SPINDLE_RPM: f64 = 5000.0;

/// Cutting speed at the edge of a tool `diameter_mm` wide at `rpm`, m/min.
pub fn cutting_speed_m_min(diameter_mm: f64, rpm: f64) -> f64 {
    std::f64::consts::PI * diameter_mm * rpm / 1000.0
}

/// An S word a milling cutter of `diameter_mm` plausibly runs at
/// ([`MIN_CUTTING_SPEED_M_MIN`] at its edge, or [`MIN_SPINDLE_RPM`]); 0 (no
/// S word) is not one.
pub fn plausible_rpm(diameter_mm: f64, rpm: f64) -> bool {
    rpm > 0.0
        && (cutting_speed_m_min(diameter_mm, rpm) >= MIN_CUTTING_SPEED_M_MIN
            || rpm >= MIN_SPINDLE_RPM)
}

/// Allowable stress of a tool (MODEL.md §4.4): `stress_limit_mpa`, else 1200
/// MPa for carbide (E ≥ 400 000 MPa) and 1000 MPa otherwise, and never above
/// a rupture strength the job gives.
pub fn stress_limit_mpa(spec: &ToolSpec, tool: &Tool) -> f64 {
    spec.stress_limit_mpa.unwrap_or_else(|| {
        let default = if tool.youngs_modulus_mpa >= 400_000.0 {
            1200.0
        } else {
            1000.0
        };
        spec.rupture_strength_mpa
            .map_or(default, |r| default.min(r))
    })
}

/// Rupture strength of a tool (MODEL.md §4.4): `rupture_strength_mpa`, else
/// 3500 MPa for carbide (E ≥ 400 000 MPa, the middle of a fine-grain
/// carbide's transverse rupture strength of 3000–4000 MPa) and 3000 MPa
/// otherwise (HSS), and never below the allowable stress.
pub fn rupture_strength_mpa(spec: &ToolSpec, tool: &Tool) -> f64 {
    spec.rupture_strength_mpa.unwrap_or_else(|| {
        let default: f64 = if tool.youngs_modulus_mpa >= 400_000.0 {
            3500.0
        } else {
            3000.0
        };
        default.max(stress_limit_mpa(spec, tool))
    })
}

/// Helix angle of a tool whose spec gives none, degrees (general-purpose end
/// mills: 30°).
pub const DEFAULT_HELIX_DEG: f64 = 30.0;

/// The force and beam model from the job's [cutting] and a tool's spec.
pub fn cutting_model(
    job: &Job,
    spec: &ToolSpec,
    tool: &Tool,
    program: &Program,
) -> Result<CuttingModel> {
    let c = &job.cutting;
    let material = job.material()?;
    // The highest S word this tool (a tool table's entry: on its own moves)
    // plausibly runs at (MODEL.md §2.1).
    let program_rpm = program.spindle_rpm_for(tool.diameter_mm, spec.number);
    let force_model = match c.model {
        ForceModelKind::PowerLaw => cutting::ForceModel::PowerLaw {
            a: c.force_a.unwrap_or(material.force_coef_a),
            n: c.force_n.unwrap_or(material.force_exp_n),
        },
        ForceModelKind::Kienzle => {
            let k = material.kienzle;
            cutting::ForceModel::Kienzle(cutting::Kienzle {
                kc1_1_mpa: c.kc1_1.unwrap_or(k.kc1_1_mpa),
                mc: c.mc.unwrap_or(k.mc),
                radial_ratio: c.radial_ratio.unwrap_or(k.radial_ratio),
                axial_ratio: c.axial_ratio.unwrap_or(k.axial_ratio),
            })
        }
    };
    Ok(CuttingModel {
        force_model,
        spindle_rpm: c.spindle_rpm.unwrap_or(if program_rpm > 0.0 {
            program_rpm
        } else {
            10_000.0
        }),
        flutes: tool.flutes,
        tool_radius_mm: tool.radius_mm(),
        band_height_mm: c.band_height,
        beam: cutting::SteppedBeam {
            stickout_mm: tool.stickout_mm,
            flute_length_mm: tool.flute_length_mm,
            flute_diameter_mm: tool.effective_diameter_mm,
            shank_diameter_mm: spec.shank_diameter.unwrap_or(tool.diameter_mm),
            youngs_modulus_mpa: tool.youngs_modulus_mpa,
            holder_stiffness_n_per_um: spec.holder_stiffness_n_per_um,
        },
        edge: cutting::EdgeShape {
            radius_mm: tool.radius_mm(),
            corner_mm: match tool.shape {
                dexel::ToolShape::Ball => tool.radius_mm(),
                dexel::ToolShape::Flat => 0.0,
                dexel::ToolShape::Bull { corner_radius_mm } => corner_radius_mm,
            },
        },
        helix_deg: spec.helix_deg.unwrap_or(DEFAULT_HELIX_DEG),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both sides of each rule (MODEL.md §2.1): 10 m/min at the edge is
    /// n = 10 000/(π D) rev/min; at and above 5000 rev/min any tool.
    #[test]
    fn s_words_are_spindle_speeds_at_10_m_min_or_5000_rev_min() {
        // Ø2: 10 m/min at 1591.55 rev/min; S100 (0.63 m/min) is not one.
        let n10 = 10_000.0 / (std::f64::consts::PI * 2.0);
        assert!(plausible_rpm(2.0, n10 * (1.0 + 1e-12)));
        assert!(!plausible_rpm(2.0, n10 * (1.0 - 1e-9)));
        assert!(!plausible_rpm(2.0, 100.0));
        // Ø0.2: 10 m/min needs 15 915 rev/min; S12000 (7.5 m/min) is kept
        // by the second rule, S4999 (3.1 m/min) and S1000 (a laser's power) are not.
        assert!(plausible_rpm(0.2, 12_000.0));
        assert!(plausible_rpm(0.2, 5000.0));
        assert!(!plausible_rpm(0.2, 4999.0));
        assert!(!plausible_rpm(0.2, 1000.0));
        assert!(!plausible_rpm(0.2, 0.0));
    }
}

impl ToolEntry {
    /// The spindle speed the tool's loads and chip load take for a block
    /// whose S word is `block_rpm` (0 when none), rev/min: the job's
    /// `spindle_rpm`, else a plausible S word, else the cutting model's
    /// (MODEL.md §2.1).
    pub fn spindle_rpm(&self, block_rpm: f64) -> f64 {
        match self.job_rpm {
            Some(rpm) => rpm,
            None if plausible_rpm(self.tool.diameter_mm, block_rpm) => block_rpm,
            None => self.model.spindle_rpm,
        }
    }

    /// The chip-load feed cap F = f_z,max · z · n (MODEL.md §2.1) at the
    /// spindle speed [`ToolEntry::spindle_rpm`] takes for a block whose S word
    /// is `block_rpm`, mm/min; None without a chip-load limit.
    pub fn chip_load_feed_mm_min(&self, block_rpm: f64) -> Option<f64> {
        self.fz_max_mm.map(|fz| {
            cutting::chipload::chip_load_feed_mm_min(
                fz,
                self.model.flutes,
                self.spindle_rpm(block_rpm),
            )
        })
    }
}

/// The tools a run can use.
#[derive(Clone, Debug)]
pub struct ToolSet {
    pub entries: Vec<ToolEntry>,
    /// A single `[tool]`: it cuts whatever T the program names.
    pub single: bool,
    /// Close the loop between removal and deflection (`[cutting] closed_loop`, MODEL.md §5.1).
    pub closed_loop: bool,
}

impl ToolSet {
    /// The job's tools, with their cutting models.
    pub fn from_job(job: &Job, program: &Program) -> Result<ToolSet> {
        let specs = job.tool_specs();
        let single = job.tool.is_some();
        let mut entries = Vec::with_capacity(specs.len());
        for (number, spec) in specs {
            let tool = spec.dexel_tool()?;
            let model = cutting_model(job, spec, &tool, program)?;
            entries.push(ToolEntry {
                number: number.unwrap_or(1),
                tool,
                length_mm: spec.length.unwrap_or(0.0),
                model,
                fz_max_mm: spec.fz_max_mm(&job.cutting.material),
                stress_limit_mpa: stress_limit_mpa(spec, &tool),
                rupture_strength_mpa: rupture_strength_mpa(spec, &tool),
                job_rpm: job.cutting.spindle_rpm,
                fz_max_given: spec.fz_max.is_some(),
            });
        }
        Ok(ToolSet {
            entries,
            single,
            closed_loop: job.cutting.closed_loop,
        })
    }

    /// Gauge lengths by tool number for the G-code reader (empty for a
    /// single `[tool]`: every T is accepted, with length 0).
    pub fn lengths_mm(&self) -> BTreeMap<u32, f64> {
        if self.single {
            BTreeMap::new()
        } else {
            self.entries
                .iter()
                .map(|e| (e.number, e.length_mm))
                .collect()
        }
    }

    /// Index into `entries` of tool `number`.
    pub fn index_of(&self, number: u32) -> Option<usize> {
        if self.single {
            Some(0)
        } else {
            self.entries.iter().position(|e| e.number == number)
        }
    }

    /// The entry of tool `number` (the first entry if the table lacks it).
    pub fn entry(&self, number: u32) -> &ToolEntry {
        &self.entries[self.index_of(number).unwrap_or(0)]
    }

    /// Per item, the index of the tool numbered by `numbers`; an error names
    /// the program line of the first number the table lacks. The indices are
    /// of any integer type that holds every index of the table (`u16` keeps 2
    /// bytes an item instead of 8).
    pub fn indices<T: TryFrom<usize>>(
        &self,
        numbers: impl Iterator<Item = (u32, u32)>,
    ) -> Result<Vec<T>> {
        let Ok(_) = T::try_from(self.entries.len().saturating_sub(1)) else {
            fail!(
                job,
                "{} tools: more than a program's steps can index",
                self.entries.len()
            );
        };
        let index = |i: usize| T::try_from(i).ok().expect("every index fits");
        // As many as the items (a collected Result grows by doubling).
        let mut out = Vec::with_capacity(numbers.size_hint().0);
        for (number, line) in numbers {
            out.push(match self.index_of(number) {
                Some(i) => index(i),
                None if number == 0 => fail!(job,
                    "line {line}: moves with no tool in the spindle (T0); load one of the job's tools ({}) with T… M6",
                    self.names()
                ),
                None => fail!(job,
                    "line {line}: tool T{number} is not in the job's [[tools]] ({})",
                    self.names()
                ),
            });
        }
        Ok(out)
    }

    /// Tool `number` as the user knows it, for messages: "the job's tool
    /// (Ø6 mm)" for a single `[tool]` (which cuts whatever T the program
    /// names, none included), else "tool T2 (Ø6 mm)".
    pub fn name(&self, number: u32) -> String {
        let d = self.entry(number).tool.diameter_mm;
        if self.single {
            format!("the job's tool (Ø{d} mm)")
        } else {
            format!("tool T{number} (Ø{d} mm)")
        }
    }

    /// "T1, T2, …".
    pub fn names(&self) -> String {
        self.entries
            .iter()
            .map(|e| format!("T{}", e.number))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The kernel shapes, in `entries` order.
    pub fn tools(&self) -> Vec<Tool> {
        self.entries.iter().map(|e| e.tool).collect()
    }
}
