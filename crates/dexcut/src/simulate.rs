//! `dexcut simulate`: sweep the program through the stock and record what
//! every step removed, the load it puts on the tool and the error it leaves.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use cutting::{CuttingModel, StepLoad};
use dexel::{RemovalRecord, Stock, SweepOptions, Tool, NEVER_CUT};
use serde::Serialize;

use crate::job::{ForceModelKind, Job, ToolSpec};
use crate::motion::TimedStep;
use crate::program::Program;
use crate::progress;
use crate::warnings::{self, LineTally, WarningKind, Warnings};

/// Volume below which a step counts as removing nothing, mm³ (f32 column
/// heights round at about 1e-7 mm; this is a 0.1 µm layer over 10 × 10 cells of 0.1 mm).
pub const NOTHING_MM3: f64 = 1e-6;
use crate::tools::ToolSet;

/// Window of the smoothed MRR in summaries, s (three 16 ms periods).
pub const MRR_WINDOW_S: f64 = 0.048;
/// ... and at least this many grid cells of path: removal per unit length is
/// resolved only to about one column, so shorter windows show the column phase.
pub const MRR_WINDOW_CELLS: f64 = 10.0;

/// A servo period in which the tool advances less than one grid cell has its
/// MRR measured over this many cells of path around it (MODEL.md §2.3): over
/// one cell the column quantisation still gives ±40 % (Ø1.6 mm tool, 0.1 mm
/// grid, camotics_tiny_cat_outline), over six it is within the 2 % that
/// `optimize` holds the limit to.
pub const SUB_CELL_WINDOW_CELLS: f64 = 6.0;

/// One servo period of a run, with the removal it is measured by
/// ([`Run::periods`]).
#[derive(Clone, Copy, Debug)]
pub struct Period {
    /// Its steps, `first_step..=last_step`.
    pub first_step: usize,
    pub last_step: usize,
    /// Path and removal the MRR is measured over (the period itself, or the
    /// run of periods covering one grid cell around it), mm, mm³, s.
    pub s_from_mm: f64,
    pub s_to_mm: f64,
    pub volume_mm3: f64,
    pub dt_s: f64,
    /// Not every part of it is a rapid.
    pub cutting: bool,
    /// The periods (indices) measured: the period itself when it covers a grid cell.
    pub window: (usize, usize),
}

impl Period {
    /// MRR, mm³/s.
    pub fn mrr_mm3_s(&self) -> f64 {
        if self.dt_s > 0.0 {
            self.volume_mm3 / self.dt_s
        } else {
            0.0
        }
    }
}

/// Everything a run produced, in memory.
pub struct Run {
    pub steps: Vec<TimedStep>,
    /// What the (deflected) tool removed, per step.
    pub record: RemovalRecord,
    pub loads: Vec<StepLoad>,
    /// Per step, the lateral offset of the tool in the final pass, µm: its converged
    /// deflection at the contact height (MODEL.md §5.1).
    pub offsets_um: Vec<[f64; 2]>,
    pub initial_volume_mm3: f64,
    /// The stock the deflected tool leaves.
    pub stock: Stock,
    /// Wall-clock time of the sweeps, s.
    pub sweep_s: f64,
    /// Sweeps of the closed loop (1: the tool did not bend measurably).
    pub passes: usize,
    /// Largest |model deflection − applied offset| after the last pass, µm.
    pub loop_residual_um: f64,
    /// Largest deflection at the contact height of the rigid tool's removal, µm.
    pub rigid_peak_deflection_um: f64,
    /// Allowable tool stress of each step's tool, MPa.
    pub stress_limits_mpa: Vec<f64>,
}

/// Closed loop (MODEL.md §5.1): at most this many sweeps...
pub const LOOP_MAX_PASSES: usize = 16;
/// ... until every step's deflection agrees with its applied offset within
/// this many µm plus [`LOOP_REL_TOL`] of the offset.
pub const LOOP_TOL_UM: f64 = 0.5;
pub const LOOP_REL_TOL: f64 = 0.02;

/// One sweep of `steps` through a copy of `stock`, each step with its tool.
fn sweep_pass(
    stock: &Stock,
    tools: &ToolSet,
    tool_of_step: &[usize],
    steps: &[dexel::Step],
    options: &SweepOptions,
    label: &str,
) -> Result<(Stock, RemovalRecord)> {
    let mut work = stock.clone();
    let bar = progress::bar(steps.len() as u64, label);
    let record = dexel::sweep_tools(
        &mut work,
        &tools.tools(),
        tool_of_step,
        steps,
        options,
        &|done| bar.set_position(done as u64),
    )?;
    bar.finish_and_clear();
    Ok((work, record))
}

/// The steps with the tool moved sideways by `offsets_mm` (per step, at its end; a
/// step that continues the previous one starts at the previous offset, so the
/// offset path stays continuous).
fn offset_steps(steps: &[TimedStep], offsets_mm: &[[f64; 2]]) -> Vec<dexel::Step> {
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let o = offsets_mm[i];
            let start = if i > 0 && steps[i - 1].step.to_mm == s.step.from_mm {
                offsets_mm[i - 1]
            } else {
                o
            };
            let [fx, fy, fz] = s.step.from_mm;
            let [tx, ty, tz] = s.step.to_mm;
            dexel::Step {
                from_mm: [fx + start[0], fy + start[1], fz],
                to_mm: [tx + o[0], ty + o[1], tz],
                rapid: s.step.rapid,
            }
        })
        .collect()
}

/// The tool's offset per step, µm: `magnitude · direction` for feed steps; a
/// rapid keeps the offset of the feed step before it (the tool leaves the cut
/// where it was, and no rapid cuts what the bent tool left).
fn applied_offsets_um(steps: &[TimedStep], magnitude: &[f64], dirs: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut carried = [0.0, 0.0];
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            if !s.step.rapid {
                carried = [magnitude[i] * dirs[i][0], magnitude[i] * dirs[i][1]];
            }
            carried
        })
        .collect()
}

/// Per-step bracket of the closed loop's root of h(x) = x − g(x), x the offset
/// along the rigid force direction and g the deflection the removal at x causes.
#[derive(Clone, Copy)]
struct Bracket {
    lo: (f64, f64),
    hi: Option<(f64, f64)>,
    /// Side replaced last (−1 lo, +1 hi), for the Illinois step.
    last: i8,
}

impl Bracket {
    /// Record g at x and return the next x to try (µm).
    fn next(&mut self, x: f64, g: f64) -> f64 {
        let side = if x - g > 0.0 {
            self.hi = Some((x, g));
            1
        } else {
            self.lo = (x, g);
            -1
        };
        let Some((xh, gh)) = self.hi else {
            // No offset yet where the tool bends less than it is moved: follow g.
            self.last = side;
            return g.max(0.0);
        };
        let (xl, gl) = self.lo;
        if xh - xl <= 1e-9 {
            return 0.5 * (xl + xh);
        }
        let mid = 0.5 * (xl + xh);
        if side == self.last {
            // The same end moved twice: bisect so the other end moves too.
            self.last = 0;
            return mid;
        }
        self.last = side;
        // Regula falsi on g linear between the ends: x = g_lo + slope (x − x_lo).
        let slope = (gh - gl) / (xh - xl);
        let x_new = (gl - slope * xl) / (1.0 - slope);
        if x_new.is_finite() && x_new > xl && x_new < xh {
            x_new
        } else {
            mid
        }
    }
}

/// Sweep `steps` through `stock` and compute the loads, closing the loop between
/// removal and deflection (MODEL.md §5.1): the rigid tool's removal gives each
/// step's deflection; the program is swept again with the tool moved by it, and
/// the offsets are refined per step (regula falsi in a bracket) until the
/// deflection the removal causes equals the offset that produced it. Each step
/// is cut by its own tool (MODEL.md §9.1).
pub fn run(stock: Stock, tools: &ToolSet, steps: Vec<TimedStep>, label: &str) -> Result<Run> {
    let initial_volume_mm3 = stock.volume_mm3();
    let rigid_steps: Vec<dexel::Step> = steps.iter().map(|s| s.step).collect();
    let tool_of_step = tools.indices(steps.iter().map(|s| (s.tool, s.line)))?;
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    let started = Instant::now();
    let (rigid_stock, mut record) =
        sweep_pass(&stock, tools, &tool_of_step, &rigid_steps, &options, label)?;
    // At most two stocks at a time: the initial one and the last pass's.
    let mut final_stock = Some(rigid_stock);
    let mut step_loads = loads(tools, &tool_of_step, &record, &steps);
    let n = steps.len();
    // Rigid force directions, kept for the loop (unit, µm per µm); rapids are
    // not moved (a collision's load means nothing).
    let dirs: Vec<[f64; 2]> = step_loads
        .iter()
        .zip(&steps)
        .map(|(l, s)| {
            if l.deflection_um > 0.0 && !s.step.rapid {
                [l.dx_um / l.deflection_um, l.dy_um / l.deflection_um]
            } else {
                [0.0, 0.0]
            }
        })
        .collect();
    let rigid: Vec<f64> = step_loads
        .iter()
        .zip(&dirs)
        .map(|(l, d)| {
            if *d == [0.0, 0.0] {
                0.0
            } else {
                l.deflection_um
            }
        })
        .collect();
    let rigid_peak_deflection_um = rigid.iter().copied().fold(0.0, f64::max);
    let mut x: Vec<f64> = vec![0.0; n];
    let mut residual = rigid_peak_deflection_um;
    let mut passes = 1;
    if rigid_peak_deflection_um > LOOP_TOL_UM {
        let mut brackets: Vec<Bracket> = rigid
            .iter()
            .map(|&g| Bracket {
                lo: (0.0, g),
                hi: None,
                last: -1,
            })
            .collect();
        let mut trial = rigid.clone();
        loop {
            let offsets_mm: Vec<[f64; 2]> = applied_offsets_um(&steps, &trial, &dirs)
                .into_iter()
                .map(|[x, y]| [1e-3 * x, 1e-3 * y])
                .collect();
            let shifted = offset_steps(&steps, &offsets_mm);
            drop(final_stock.take());
            let (pass_stock, pass_record) =
                sweep_pass(&stock, tools, &tool_of_step, &shifted, &options, label)?;
            (final_stock, record) = (Some(pass_stock), pass_record);
            step_loads = loads(tools, &tool_of_step, &record, &steps);
            passes += 1;
            x.clone_from(&trial);
            // g: the deflection the removal at the trial offset causes, along the rigid direction.
            let g: Vec<f64> = (0..n)
                .map(|i| step_loads[i].dx_um * dirs[i][0] + step_loads[i].dy_um * dirs[i][1])
                .collect();
            residual = (0..n).map(|i| (g[i] - x[i]).abs()).fold(0.0, f64::max);
            let converged =
                (0..n).all(|i| (g[i] - x[i]).abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x[i].abs());
            if converged || passes >= LOOP_MAX_PASSES {
                break;
            }
            for i in 0..n {
                if dirs[i] != [0.0, 0.0] {
                    trial[i] = brackets[i].next(x[i], g[i]);
                }
            }
        }
    }
    let sweep_s = started.elapsed().as_secs_f64();
    let offsets_um = applied_offsets_um(&steps, &x, &dirs);
    Ok(Run {
        steps,
        record,
        loads: step_loads,
        offsets_um,
        initial_volume_mm3,
        stock: final_stock.expect("a pass ran"),
        sweep_s,
        passes,
        loop_residual_um: residual,
        rigid_peak_deflection_um,
        stress_limits_mpa: tool_of_step
            .iter()
            .map(|&t| tools.entries[t].stress_limit_mpa)
            .collect(),
    })
}

/// Per-step force, power and deflection (MODEL.md §3, §4), each step with its tool's model.
pub fn loads(
    tools: &ToolSet,
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
) -> Vec<StepLoad> {
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let model = &tools.entries[tool_of_step[i]].model;
            model.step_load(&cutting::StepRemoval {
                volume_mm3: record.volume_mm3(i),
                band_volumes_mm3: record.band_volumes_mm3(i),
                contact_resultant: record.contact_resultant(i),
                chip_edge_area_mm2: record.chip_edge_area_mm2(i),
                volume_over_radius_mm2: record.volume_over_radius_mm2(i),
                dt_s: s.dt_s,
            })
        })
        .collect()
}

/// Allowable stress of a tool (MODEL.md §4.4).
pub fn stress_limit_mpa(spec: &ToolSpec, tool: &Tool) -> f64 {
    spec.stress_limit_mpa
        .unwrap_or(if tool.youngs_modulus_mpa >= 400_000.0 {
            1200.0
        } else {
            1000.0
        })
}

/// The force and beam model from the job's [cutting] and a tool's spec.
pub fn cutting_model(
    job: &Job,
    spec: &ToolSpec,
    tool: &Tool,
    program: &Program,
) -> Result<CuttingModel> {
    let c = &job.cutting;
    let material = cutting::Material::by_name(&c.material).with_context(|| {
        let names: Vec<&str> = cutting::Material::ALL.iter().map(|m| m.name).collect();
        format!(
            "{}: unknown cutting.material {:?}; known: {}",
            job.name,
            c.material,
            names.join(", ")
        )
    })?;
    let program_rpm = program.spindle_rpm();
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
    })
}

/// Headline numbers of a run (summary.json).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub initial_volume_mm3: f64,
    pub final_volume_mm3: f64,
    pub removed_volume_mm3: f64,
    pub cycle_time_s: f64,
    /// Largest MRR of a single step (servo period), mm³/s.
    pub peak_mrr_mm3_s: f64,
    /// Largest MRR averaged over at least [`MRR_WINDOW_S`] and
    /// [`MRR_WINDOW_CELLS`] grid cells of path, mm³/s: the per-period value
    /// carries the dexel grid's column quantisation (±15 % for a slot at 0.8
    /// cells per period), which this average resolves.
    pub peak_mrr_windowed_mm3_s: f64,
    pub peak_force_n: f64,
    /// Largest spindle cutting power, W, and torque, N·m.
    pub peak_power_w: f64,
    pub peak_torque_nm: f64,
    /// Largest deflection at the contact height (closed loop), µm.
    pub peak_deflection_um: f64,
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
    /// Sweeps of the closed loop and its largest remaining disagreement, µm.
    pub closed_loop_passes: usize,
    pub closed_loop_residual_um: f64,
    /// Largest von Mises stress in the tool, MPa, and the allowable stress.
    pub peak_stress_mpa: f64,
    pub stress_limit_mpa: f64,
    pub steps: usize,
    pub grid_mm: f64,
    pub columns: usize,
    /// Steps that removed material above the flute length.
    pub shank_contact_steps: usize,
    /// Rapid steps that removed material (collisions).
    pub rapid_collision_steps: usize,
    /// First program line with a rapid collision, if any.
    pub first_collision_line: Option<u32>,
    /// What a user must look at, each with its program line.
    pub warnings: Warnings,
    pub columns_evaluated: u64,
    pub sweep_time_s: f64,
    /// The same peaks per tool, in order of first use.
    pub tools: Vec<ToolPeaks>,
}

/// Peaks of the steps one tool cut (summary.json `tools`).
#[derive(Clone, Debug, Serialize)]
pub struct ToolPeaks {
    /// T number.
    pub tool: u32,
    pub steps: usize,
    pub removed_volume_mm3: f64,
    /// Time the tool is in the spindle, s.
    pub time_s: f64,
    pub peak_mrr_mm3_s: f64,
    pub peak_force_n: f64,
    pub peak_deflection_um: f64,
}

impl Summary {
    /// A result that is inf or NaN is an error, not an output.
    pub fn check_finite(&self) -> Result<()> {
        for (key, v) in [
            ("initial volume (mm³)", self.initial_volume_mm3),
            ("final volume (mm³)", self.final_volume_mm3),
            ("removed volume (mm³)", self.removed_volume_mm3),
            ("cycle time (s)", self.cycle_time_s),
            ("peak MRR (mm³/s)", self.peak_mrr_mm3_s),
            ("peak windowed MRR (mm³/s)", self.peak_mrr_windowed_mm3_s),
            ("peak force (N)", self.peak_force_n),
            ("peak deflection (µm)", self.peak_deflection_um),
        ] {
            if !v.is_finite() {
                anyhow::bail!("the run's {key} is {v}: the inputs give no finite result");
            }
        }
        Ok(())
    }
}

impl Run {
    /// Servo periods (a period split where the motion changes between rapid
    /// and feed counts as a whole), each with its MRR resolved to the grid
    /// (MODEL.md §2.3): a period in which the tool advances less than one grid
    /// cell is measured over the shortest run of periods centred on it (of
    /// the same cut, no all-rapid period) that covers
    /// [`SUB_CELL_WINDOW_CELLS`] cells of path, since a column's removal comes
    /// whole in the period in which the edge crosses the column's centre.
    pub fn periods(&self) -> Vec<Period> {
        let g = self.stock.grid().spacing_mm;
        let window_mm = SUB_CELL_WINDOW_CELLS * g;
        // Own values per period: steps first..=last.
        let mut own: Vec<Period> = Vec::new();
        let mut s_prev = 0.0;
        let mut i = 0;
        while i < self.steps.len() {
            let mut j = i + 1;
            while j < self.steps.len() && self.steps[j].continues {
                j += 1;
            }
            let (volume_mm3, dt_s) = (i..j).fold((0.0, 0.0), |(v, t), k| {
                (v + self.record.volume_mm3(k), t + self.steps[k].dt_s)
            });
            let s_to = self.steps[j - 1].s_end_mm;
            own.push(Period {
                first_step: i,
                last_step: j - 1,
                s_from_mm: s_prev,
                s_to_mm: s_to,
                volume_mm3,
                dt_s,
                cutting: !self.steps[i..j].iter().all(|s| s.step.rapid),
                window: (own.len(), own.len()),
            });
            s_prev = s_to;
            i = j;
        }
        // Prefix sums of path, volume and time over periods.
        let n = own.len();
        let (mut adv, mut vol, mut time) = (vec![0.0; n + 1], vec![0.0; n + 1], vec![0.0; n + 1]);
        for (p, q) in own.iter().enumerate() {
            adv[p + 1] = adv[p] + (q.s_to_mm - q.s_from_mm);
            vol[p + 1] = vol[p] + q.volume_mm3;
            time[p + 1] = time[p] + q.dt_s;
        }
        // Last period of the run of cutting periods each period lies in.
        let mut run_ends = vec![0; n];
        for p in (0..n).rev() {
            run_ends[p] = if p + 1 < n && own[p + 1].cutting && own[p].cutting {
                run_ends[p + 1]
            } else {
                p
            };
        }
        let mut out = own.clone();
        let mut run_start = 0;
        for p in 0..n {
            if !own[p].cutting {
                run_start = p + 1;
                continue;
            }
            if own[p].s_to_mm - own[p].s_from_mm >= g {
                continue;
            }
            let run_end = run_ends[p];
            let window = |k: usize| (p.saturating_sub(k).max(run_start), (p + k).min(run_end));
            let covers = |k: usize| {
                let (a, b) = window(k);
                adv[b + 1] - adv[a] >= window_mm
            };
            // Smallest half-width that covers a cell (or the whole run).
            let k_max = (p - run_start).max(run_end - p);
            let (mut lo, mut hi) = (0, k_max);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if covers(mid) {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            let (a, b) = window(lo);
            out[p] = Period {
                s_from_mm: own[a].s_from_mm,
                s_to_mm: own[b].s_to_mm,
                volume_mm3: vol[b + 1] - vol[a],
                dt_s: time[b + 1] - time[a],
                window: (a, b),
                ..own[p]
            };
        }
        out
    }

    /// Per step, the MRR of its servo period resolved to the grid ([`Run::periods`]), mm³/s.
    pub fn period_mrr_by_step_mm3_s(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.steps.len()];
        for p in self.periods() {
            out[p.first_step..=p.last_step].fill(p.mrr_mm3_s());
        }
        out
    }

    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub fn peak_cutting_feed_mm_min(&self) -> f64 {
        (0..self.steps.len())
            .filter(|&i| !self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .map(|i| self.steps[i].feed_mm_min)
            .fold(0.0, f64::max)
    }

    /// Largest MRR of a servo period resolved to the grid, mm³/s.
    pub fn peak_period_mrr_mm3_s(&self) -> f64 {
        self.periods()
            .iter()
            .map(Period::mrr_mm3_s)
            .fold(0.0, f64::max)
    }

    /// The lowest allowable stress of the tools the run uses, MPa.
    pub fn stress_limit_mpa(&self) -> f64 {
        self.stress_limits_mpa
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    }

    /// Warnings of this run (MODEL.md §10): rapid moves that cut, shank or
    /// holder contact, a program that removes nothing.
    pub fn warnings(&self) -> Warnings {
        let mut out = Warnings::default();
        let (mut rapid, mut shank) = (LineTally::new(), LineTally::new());
        let mut stress = LineTally::new();
        for (i, s) in self.steps.iter().enumerate() {
            if self.loads[i].stress_mpa > self.stress_limits_mpa[i] {
                warnings::tally(&mut stress, s.line, self.loads[i].stress_mpa);
            }
            let v = self.record.volume_mm3(i);
            if s.step.rapid && v > NOTHING_MM3 {
                warnings::tally(&mut rapid, s.line, v);
            }
            let sv = self.record.shank_volume_mm3(i);
            if sv > NOTHING_MM3 {
                warnings::tally(&mut shank, s.line, sv);
            }
        }
        out.from_lines(WarningKind::RapidCut, &rapid, "mm³", true, |v, lines| {
            format!("rapid moves (G0) removed {v:.3} mm³ of stock at {lines}: a collision on a real machine")
        });
        out.from_lines(WarningKind::ShankContact, &shank, "mm³", true, |v, lines| {
            format!("the tool above its flute length (shank or holder) removed {v:.3} mm³ at {lines}: raise the flute length or stick-out, or change the program")
        });
        let limit = self.stress_limit_mpa();
        out.from_lines(WarningKind::Force, &stress, "MPa", false, |v, lines| {
            format!("the cutting force and torque stress the tool to {v:.0} MPa at {lines}, above the allowable {limit:.0} MPa ([tool] stress_limit_mpa, docs/MODEL.md §4.4): lower the feed or the engagement, or use a shorter or stiffer tool")
        });
        if self.record.total_volume_mm3() <= NOTHING_MM3 {
            out.push(warnings::Warning {
                kind: WarningKind::NoRemoval,
                line: None,
                value: 0.0,
                unit: "mm³".into(),
                steps: self.steps.len(),
                lines: Vec::new(),
                message: "the program removes no material: check the stock position, the work offsets and [machine] start".into(),
            });
        }
        out
    }

    /// Largest mean MRR over any run of consecutive steps lasting at least
    /// `window_s` and covering at least `window_mm` of path (a run shorter than
    /// that over the whole program counts as a whole).
    pub fn peak_windowed_mrr_mm3_s(&self, window_s: f64, window_mm: f64) -> f64 {
        let lengths: Vec<f64> = self
            .steps
            .iter()
            .map(|s| nalgebra::distance(&s.step.from_mm.into(), &s.step.to_mm.into()))
            .collect();
        let (mut first, mut vol, mut time, mut len, mut peak) = (0, 0.0, 0.0, 0.0, 0.0f64);
        for (i, s) in self.steps.iter().enumerate() {
            vol += self.record.volume_mm3(i);
            time += s.dt_s;
            len += lengths[i];
            while first < i
                && time - self.steps[first].dt_s >= window_s
                && len - lengths[first] >= window_mm
            {
                vol -= self.record.volume_mm3(first);
                time -= self.steps[first].dt_s;
                len -= lengths[first];
                first += 1;
            }
            let full = time >= window_s && len >= window_mm;
            if (full || (first == 0 && i + 1 == self.steps.len())) && time > 0.0 {
                peak = peak.max(vol / time);
            }
        }
        peak
    }

    pub fn summary(&self) -> Summary {
        let n = self.steps.len();
        let errors: Vec<f64> = self
            .error_map_um(&self.stock.top_heights())
            .into_iter()
            .filter(|e| e.is_finite())
            .map(f64::from)
            .collect();
        let final_volume_mm3 = self.stock.volume_mm3();
        let collisions: Vec<usize> = (0..n)
            .filter(|&i| self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .collect();
        Summary {
            initial_volume_mm3: self.initial_volume_mm3,
            final_volume_mm3,
            removed_volume_mm3: self.record.total_volume_mm3(),
            cycle_time_s: self.steps.last().map_or(0.0, |s| s.t_end_s),
            peak_mrr_mm3_s: self.peak_period_mrr_mm3_s(),
            peak_mrr_windowed_mm3_s: self.peak_windowed_mrr_mm3_s(
                MRR_WINDOW_S,
                MRR_WINDOW_CELLS * self.stock.grid().spacing_mm,
            ),
            peak_force_n: self.loads.iter().map(|l| l.force_n).fold(0.0, f64::max),
            peak_power_w: self.loads.iter().map(|l| l.power_w).fold(0.0, f64::max),
            peak_torque_nm: self.loads.iter().map(|l| l.torque_nm).fold(0.0, f64::max),
            peak_deflection_um: self
                .loads
                .iter()
                .map(|l| l.deflection_um)
                .fold(0.0, f64::max),
            peak_cutting_feed_mm_min: self.peak_cutting_feed_mm_min(),
            peak_tip_deflection_um: self
                .loads
                .iter()
                .map(|l| l.tip_deflection_um)
                .fold(0.0, f64::max),
            rigid_peak_deflection_um: self.rigid_peak_deflection_um,
            max_error_um: errors.iter().fold(0.0, |a, &e| if e > a { e } else { a }),
            min_error_um: errors.iter().fold(0.0, |a, &e| if e < a { e } else { a }),
            closed_loop_passes: self.passes,
            closed_loop_residual_um: self.loop_residual_um,
            peak_stress_mpa: self.loads.iter().map(|l| l.stress_mpa).fold(0.0, f64::max),
            stress_limit_mpa: self.stress_limit_mpa(),
            steps: n,
            grid_mm: self.stock.grid().spacing_mm,
            columns: self.stock.grid().len(),
            shank_contact_steps: (0..n)
                .filter(|&i| self.record.shank_volume_mm3(i) > NOTHING_MM3)
                .count(),
            rapid_collision_steps: collisions.len(),
            first_collision_line: collisions.first().map(|&i| self.steps[i].line),
            columns_evaluated: self.record.columns_evaluated,
            sweep_time_s: self.sweep_s,
            warnings: self.warnings(),
            tools: self.tool_peaks(),
        }
    }

    /// Peaks per tool, in order of first use.
    pub fn tool_peaks(&self) -> Vec<ToolPeaks> {
        let mut out: Vec<ToolPeaks> = Vec::new();
        let mrr = self.period_mrr_by_step_mm3_s();
        for (i, s) in self.steps.iter().enumerate() {
            let k = match out.iter().position(|p| p.tool == s.tool) {
                Some(k) => k,
                None => {
                    out.push(ToolPeaks {
                        tool: s.tool,
                        steps: 0,
                        removed_volume_mm3: 0.0,
                        time_s: 0.0,
                        peak_mrr_mm3_s: 0.0,
                        peak_force_n: 0.0,
                        peak_deflection_um: 0.0,
                    });
                    out.len() - 1
                }
            };
            let p = &mut out[k];
            p.steps += 1;
            p.removed_volume_mm3 += self.record.volume_mm3(i);
            p.time_s += s.dt_s;
            p.peak_mrr_mm3_s = p.peak_mrr_mm3_s.max(mrr[i]);
            p.peak_force_n = p.peak_force_n.max(self.loads[i].force_n);
            p.peak_deflection_um = p.peak_deflection_um.max(self.loads[i].deflection_um);
        }
        out
    }

    /// Predicted shape error per column, µm (MODEL.md §5): the offset of the
    /// deflected tool (its converged deflection at the contact height) at the
    /// step that last cut the column, projected on the normal of the final
    /// surface `tops` (the stock's top heights); positive = material left. NaN
    /// where no step cut.
    pub fn error_map_um(&self, tops: &[f32]) -> Vec<f32> {
        let grid = *self.stock.grid();
        let normals =
            cutting::surface_normals_from_heights(tops, grid.nx, grid.ny, grid.spacing_mm);
        self.stock
            .last_cut()
            .iter()
            .zip(&normals)
            .map(|(&step, n)| {
                if step == NEVER_CUT || n.iter().any(|v| v.is_nan()) {
                    return f32::NAN;
                }
                let offset = self.offsets_um[step as usize];
                cutting::surface_error_um(offset, n.map(f64::from)) as f32
            })
            .collect()
    }

    /// Write steps.csv.
    pub fn write_steps_csv(&self, path: &Path) -> Result<()> {
        let n_bands = self.record.n_bands;
        export::atomic::write_file(path, |w| {
            let mut out = csv::Writer::from_writer(w);
            let mut header: Vec<String> = [
                "step",
                "t_s",
                "x",
                "y",
                "z",
                "feed_mm_min",
                "volume_mm3",
                "mrr_mm3_s",
            ]
            .map(String::from)
            .to_vec();
            header.extend((0..n_bands).map(|k| format!("band_{k}_mm3")));
            header.extend(
                [
                    "shank_mm3",
                    "force_n",
                    "fx_n",
                    "fy_n",
                    "fz_n",
                    "power_w",
                    "torque_nm",
                    "chip_mm",
                    "contact_height_mm",
                    "deflection_um",
                    "dx_um",
                    "dy_um",
                    "tip_deflection_um",
                    "stress_mpa",
                    "line",
                    "rapid",
                    "tool",
                ]
                .map(String::from),
            );
            out.write_record(&header)?;
            let mut row: Vec<String> = Vec::with_capacity(header.len());
            let mrr = self.period_mrr_by_step_mm3_s();
            for (i, s) in self.steps.iter().enumerate() {
                row.clear();
                let l = &self.loads[i];
                let [x, y, z] = s.step.to_mm;
                row.push(i.to_string());
                row.extend(
                    [
                        s.t_end_s,
                        x,
                        y,
                        z,
                        s.feed_mm_min,
                        self.record.volume_mm3(i),
                        mrr[i],
                    ]
                    .map(fmt),
                );
                row.extend(self.record.band_volumes_mm3(i).iter().map(|v| fmt(*v)));
                row.push(fmt(self.record.shank_volume_mm3(i)));
                row.extend(
                    [
                        l.force_n,
                        l.fx_n,
                        l.fy_n,
                        l.fz_n,
                        l.power_w,
                        l.torque_nm,
                        l.chip_thickness_mm,
                        l.contact_height_mm,
                        l.deflection_um,
                        l.dx_um,
                        l.dy_um,
                        l.tip_deflection_um,
                        l.stress_mpa,
                    ]
                    .map(fmt),
                );
                row.push(s.line.to_string());
                row.push(u8::from(s.step.rapid).to_string());
                row.push(s.tool.to_string());
                out.write_record(&row)?;
            }
            out.flush()?;
            Ok(())
        })
        .with_context(|| format!("cannot write {}", path.display()))
    }

    /// Write the per-column results into the folder `dir`: final surface
    /// (`tops`, the stock's top heights), last cutting step, predicted error,
    /// and with a design model the distance to it and the program line that
    /// last cut. Always as the compact grid (`columns.json` and one `.npy`
    /// array each); also as `columns.csv` when `csv` is set.
    pub fn write_columns(
        &self,
        dir: &Path,
        tops: &[f32],
        design_diff_um: Option<&[f32]>,
        line: Option<&[i32]>,
        csv: bool,
    ) -> Result<()> {
        let last: Vec<i32> = self
            .stock
            .last_cut()
            .iter()
            .map(|&s| if s == NEVER_CUT { -1 } else { s as i32 })
            .collect();
        let error = self.error_map_um(tops);
        let grid = GridInfo::of(self.stock.grid()).export();
        let mut arrays = vec![
            export::GridArray {
                name: "top_mm",
                unit: "mm",
                meaning: "top of the material after the run; NaN where the column holds none",
                values: export::NpyValues::F32(tops),
            },
            export::GridArray {
                name: "last_step",
                unit: "1",
                meaning:
                    "index of the step (row of steps.csv) that last cut the column; -1 if never cut",
                values: export::NpyValues::I32(&last),
            },
            export::GridArray {
                name: "error_um",
                unit: "µm",
                meaning:
                    "predicted shape error from tool deflection, + material left; NaN where not cut",
                values: export::NpyValues::F32(&error),
            },
        ];
        if let Some(d) = design_diff_um {
            arrays.push(export::GridArray {
                name: "design_um",
                unit: "µm",
                meaning: "final surface minus the design model, + stock left, - gouge; NaN outside the design",
                values: export::NpyValues::F32(d),
            });
        }
        if let Some(l) = line {
            arrays.push(export::GridArray {
                name: "line",
                unit: "1",
                meaning: "program line of the step that last cut the column; -1 if never cut",
                values: export::NpyValues::I32(l),
            });
        }
        export::write_column_grid(dir, &grid, &arrays)
            .with_context(|| format!("cannot write the column grid in {}", dir.display()))?;
        if !csv {
            return Ok(());
        }
        // columns.csv: integers as numbers, "no value" as an empty field.
        let as_f32 = |v: &[i32]| -> Vec<f32> {
            v.iter()
                .map(|&i| if i < 0 { f32::NAN } else { i as f32 })
                .collect()
        };
        let last_f = as_f32(&last);
        let line_f = line.map(as_f32);
        let mut columns: Vec<(&str, &[f32])> = vec![
            ("top_mm", tops),
            ("last_step", &last_f),
            ("error_um", &error),
        ];
        if let Some(d) = design_diff_um {
            columns.push(("design_um", d));
        }
        if let Some(l) = &line_f {
            columns.push(("line", l));
        }
        let path = dir.join("columns.csv");
        export::write_column_csv(&path, &grid, &columns)
            .with_context(|| format!("cannot write {}", path.display()))
    }
}

/// Grid geometry recorded in summary.json so `report` can rebuild maps.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct GridInfo {
    pub nx: usize,
    pub ny: usize,
    /// Centre of column (0, 0), mm.
    pub x0_mm: f64,
    pub y0_mm: f64,
    pub spacing_mm: f64,
}

impl GridInfo {
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

/// Compact number formatting for CSV (shortest round-trip form).
pub fn fmt(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v}")
    }
}

/// Write any serialisable value as pretty JSON, atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    export::atomic::write_file(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    })
    .with_context(|| format!("cannot write {}", path.display()))
}
