//! `dexcut simulate`: sweep the program through the stock and record what
//! every step removed, the load it puts on the tool and the error it leaves.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use cutting::{CuttingModel, StepLoad};
use dexel::{RemovalRecord, Stock, SweepOptions, Tool, NEVER_CUT};
use serde::Serialize;

use crate::job::Job;
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

/// Everything a run produced, in memory.
pub struct Run {
    pub steps: Vec<TimedStep>,
    pub record: RemovalRecord,
    pub loads: Vec<StepLoad>,
    pub initial_volume_mm3: f64,
    pub stock: Stock,
    /// Wall-clock time of the sweep, s.
    pub sweep_s: f64,
}

/// Sweep `steps` through `stock` (consumed), each with its tool (MODEL.md
/// §9.1), and compute the loads.
pub fn run(mut stock: Stock, tools: &ToolSet, steps: Vec<TimedStep>, label: &str) -> Result<Run> {
    let initial_volume_mm3 = stock.volume_mm3();
    let sweep_steps: Vec<dexel::Step> = steps.iter().map(|s| s.step).collect();
    let tool_of_step = tools.indices(steps.iter().map(|s| (s.tool, s.line)))?;
    let options = SweepOptions {
        band_height_mm: tools.entries[0].model.band_height_mm,
        ..SweepOptions::default()
    };
    let bar = progress::bar(sweep_steps.len() as u64, label);
    let started = Instant::now();
    let record = dexel::sweep_tools(
        &mut stock,
        &tools.tools(),
        &tool_of_step,
        &sweep_steps,
        &options,
        &|done| bar.set_position(done as u64),
    )?;
    let sweep_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let loads = loads(tools, &tool_of_step, &record, &steps);
    Ok(Run {
        steps,
        record,
        loads,
        initial_volume_mm3,
        stock,
        sweep_s,
    })
}

/// Per-step force and deflection (S4), each step with its tool's model.
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
            let [cx, cy] = record.contact_resultant(i);
            let v = record.volume_mm3(i);
            let model = &tools.entries[tool_of_step[i]].model;
            if v > 0.0 && s.dt_s > 0.0 {
                model.step_load(v, record.band_volumes_mm3(i), [cx, cy, 0.0], s.dt_s)
            } else {
                StepLoad::default()
            }
        })
        .collect()
}

/// The force and beam model from the job's [cutting] and [tool].
pub fn cutting_model(job: &Job, tool: &Tool, program: &Program) -> Result<CuttingModel> {
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
    Ok(CuttingModel {
        force_coef_a: c.force_a.unwrap_or(material.force_coef_a),
        force_exp_n: c.force_n.unwrap_or(material.force_exp_n),
        spindle_rpm: c.spindle_rpm.unwrap_or(if program_rpm > 0.0 {
            program_rpm
        } else {
            10_000.0
        }),
        flutes: tool.flutes,
        band_height_mm: c.band_height,
        beam: cutting::Cantilever {
            stickout_mm: tool.stickout_mm,
            effective_diameter_mm: tool.effective_diameter_mm,
            youngs_modulus_mpa: tool.youngs_modulus_mpa,
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
    pub peak_deflection_um: f64,
    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub peak_cutting_feed_mm_min: f64,
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
    /// MRR of the servo period that step `i` belongs to, mm³/s: a period split
    /// where the motion changes between rapid and feed counts as a whole.
    pub fn period_mrr_mm3_s(&self, i: usize) -> f64 {
        let mut first = i;
        while first > 0 && self.steps[first].continues {
            first -= 1;
        }
        let mut last = i;
        while last + 1 < self.steps.len() && self.steps[last + 1].continues {
            last += 1;
        }
        let (vol, dt) = (first..=last).fold((0.0, 0.0), |(v, t), k| {
            (v + self.record.volume_mm3(k), t + self.steps[k].dt_s)
        });
        if dt > 0.0 {
            vol / dt
        } else {
            0.0
        }
    }

    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub fn peak_cutting_feed_mm_min(&self) -> f64 {
        (0..self.steps.len())
            .filter(|&i| !self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .map(|i| self.steps[i].feed_mm_min)
            .fold(0.0, f64::max)
    }

    /// Largest MRR of a servo period, mm³/s.
    pub fn peak_period_mrr_mm3_s(&self) -> f64 {
        (0..self.steps.len())
            .filter(|&i| !self.steps[i].continues)
            .map(|i| self.period_mrr_mm3_s(i))
            .fold(0.0, f64::max)
    }

    /// Warnings of this run (MODEL.md §10): rapid moves that cut, shank or
    /// holder contact, a program that removes nothing.
    pub fn warnings(&self) -> Warnings {
        let mut out = Warnings::default();
        let (mut rapid, mut shank) = (LineTally::new(), LineTally::new());
        for (i, s) in self.steps.iter().enumerate() {
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
            peak_deflection_um: self
                .loads
                .iter()
                .map(|l| l.deflection_um)
                .fold(0.0, f64::max),
            peak_cutting_feed_mm_min: self.peak_cutting_feed_mm_min(),
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
            p.peak_mrr_mm3_s = p.peak_mrr_mm3_s.max(self.period_mrr_mm3_s(i));
            p.peak_force_n = p.peak_force_n.max(self.loads[i].force_n);
            p.peak_deflection_um = p.peak_deflection_um.max(self.loads[i].deflection_um);
        }
        out
    }

    /// Predicted shape error per column, µm (S4 error map): the deflection of
    /// the step that last cut the column, projected on the normal of the final
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
                let load = &self.loads[step as usize];
                cutting::surface_error_um([load.dx_um, load.dy_um], n.map(f64::from)) as f32
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
                    "deflection_um",
                    "dx_um",
                    "dy_um",
                    "line",
                    "rapid",
                    "tool",
                ]
                .map(String::from),
            );
            out.write_record(&header)?;
            let mut row: Vec<String> = Vec::with_capacity(header.len());
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
                        self.period_mrr_mm3_s(i),
                    ]
                    .map(fmt),
                );
                row.extend(self.record.band_volumes_mm3(i).iter().map(|v| fmt(*v)));
                row.push(fmt(self.record.shank_volume_mm3(i)));
                row.extend([l.force_n, l.fx_n, l.fy_n, l.deflection_um, l.dx_um, l.dy_um].map(fmt));
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

    /// Write columns.csv: final surface (`tops`, the stock's top heights), last
    /// cutting step and predicted error per column.
    pub fn write_columns_csv(
        &self,
        path: &Path,
        tops: &[f32],
        design_diff_um: Option<&[f32]>,
    ) -> Result<()> {
        let last: Vec<f32> = self
            .stock
            .last_cut()
            .iter()
            .map(|&s| if s == NEVER_CUT { f32::NAN } else { s as f32 })
            .collect();
        let error = self.error_map_um(tops);
        let mut columns: Vec<(&str, &[f32])> =
            vec![("top_mm", tops), ("last_step", &last), ("error_um", &error)];
        if let Some(d) = design_diff_um {
            columns.push(("design_um", d));
        }
        let grid = GridInfo::of(self.stock.grid()).export();
        export::write_column_csv(path, &grid, &columns)
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
