//! The run's numbers: its servo periods and their MRR resolved to the grid
//! (MODEL.md §2.3), its peaks, and its summary.

use super::closed_loop::sub_cell_windows;
use super::{Run, MRR_WINDOW_CELLS, MRR_WINDOW_S, NOTHING_MM3, SUB_CELL_WINDOW_CELLS};
use crate::input::tools::ToolSet;
use crate::model::{Summary, ToolPeaks};

/// One servo period of a run, with the removal it is measured by
/// ([`Run::for_each_period`]).
#[derive(Clone, Copy, Debug)]
pub struct Period {
    /// Its steps, `first_step..=last_step`.
    pub first_step: usize,
    pub last_step: usize,
    /// Path and removal the MRR is measured over (the period itself, or the
    /// run of periods covering [`SUB_CELL_WINDOW_CELLS`] grid cells around
    /// it; in a period part feed, part rapid only the feed parts' removal),
    /// mm, mm³, s.
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

impl Run {
    /// Each servo period in turn (a period split where the motion changes
    /// between rapid and feed counts as a whole), with its MRR resolved to
    /// the grid (MODEL.md §2.3): a period in which the tool advances less
    /// than one grid cell is measured over the shortest run of periods
    /// centred on it (of the same cut, no all-rapid period) that covers
    /// [`SUB_CELL_WINDOW_CELLS`] cells of path, since a column's removal
    /// comes whole in the period in which the edge crosses the column's
    /// centre. The periods are made from per-period columns (their first
    /// step, end of path, prefix sums of removal and time; 37 B a period
    /// with the windows' path sums; a period's own removal and time
    /// summed again from its steps) and handed to `f` one by one as its
    /// window is found, never held as a list (72 B a period more), nor are
    /// the windows (16 B).
    pub fn for_each_period(&self, mut f: impl FnMut(Period)) {
        let g = self.stock.grid().spacing_mm;
        let window_mm = SUB_CELL_WINDOW_CELLS * g;
        // Whether the period of steps i..j cuts, and its own removal and
        // time: summed for the prefix sums, and again (the same sums in the
        // same order) where the period is handed over, not held.
        let own = |i: usize, j: usize| {
            let cuts = !self.steps[i..j].iter().all(|s| s.step.rapid);
            // A period that is part feed, part rapid counts its feed parts'
            // removal: what a rapid removes is a collision (rapid_cut warning).
            let (volume_mm3, dt_s) = (i..j).fold((0.0, 0.0), |(v, t), k| {
                let counted = !cuts || !self.steps[k].step.rapid;
                let dv = if counted {
                    self.record.volume_mm3(k)
                } else {
                    0.0
                };
                (v + dv, t + self.steps[k].dt_s)
            });
            (cuts, volume_mm3, dt_s)
        };
        // Per period p: steps first[p]..first[p + 1] (u32), path
        // s_at[p]..s_at[p + 1], whether it cuts, and the prefix sums of
        // removal and time over the periods before it; 29 B a period, each
        // column reserved at its size (8 B more while the windows are found:
        // their path sums; a period's advance is made where it is read).
        let n = crate::motion::periods(&self.steps).count();
        let mut first: Vec<u32> = Vec::with_capacity(n + 1);
        let mut s_at: Vec<f64> = Vec::with_capacity(n + 1);
        let mut cutting: Vec<bool> = Vec::with_capacity(n);
        let (mut volume_sum, mut dt_sum) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        s_at.push(0.0);
        volume_sum.push(0.0);
        dt_sum.push(0.0);
        for std::ops::Range { start: i, end: j } in crate::motion::periods(&self.steps) {
            let (cuts, volume_mm3, dt_s) = own(i, j);
            first.push(u32::try_from(i).expect("fewer than 2³² steps"));
            s_at.push(self.steps[j - 1].s_end_mm);
            cutting.push(cuts);
            volume_sum.push(volume_sum[volume_sum.len() - 1] + volume_mm3);
            dt_sum.push(dt_sum[dt_sum.len() - 1] + dt_s);
        }
        first.push(u32::try_from(self.steps.len()).expect("fewer than 2³² steps"));
        let advance = |p: usize| s_at[p + 1] - s_at[p];
        let each = |p: usize, (a, b): (usize, usize)| {
            let (i, j) = (first[p] as usize, first[p + 1] as usize);
            let (_, volume_mm3, dt_s) = own(i, j);
            let own = Period {
                first_step: i,
                last_step: j - 1,
                s_from_mm: s_at[p],
                s_to_mm: s_at[p + 1],
                volume_mm3,
                dt_s,
                cutting: cutting[p],
                window: (p, p),
            };
            f(if !cutting[p] || advance(p) >= g {
                own
            } else {
                Period {
                    s_from_mm: s_at[a],
                    s_to_mm: s_at[b + 1],
                    volume_mm3: volume_sum[b + 1] - volume_sum[a],
                    dt_s: dt_sum[b + 1] - dt_sum[a],
                    window: (a, b),
                    ..own
                }
            });
        };
        sub_cell_windows(advance, &cutting, |p| cutting[p - 1], g, window_mm, each);
    }

    /// Per step, the MRR of its servo period resolved to the grid ([`Run::for_each_period`]), mm³/s.
    pub fn period_mrr_by_step_mm3_s(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.steps.len()];
        self.for_each_period(|p| out[p.first_step..=p.last_step].fill(p.mrr_mm3_s()));
        out
    }

    /// Per entry of `tools`, the step of that tool with the highest mean
    /// path speed among those that removed material (not rapids): its index,
    /// or None where the tool cuts nothing.
    pub fn top_cutting_step_by_tool(&self, tools: &ToolSet) -> Vec<Option<usize>> {
        let mut top: Vec<Option<usize>> = vec![None; tools.entries.len()];
        for i in 0..self.steps.len() {
            let s = &self.steps[i];
            if s.step.rapid || self.record.volume_mm3(i) <= NOTHING_MM3 {
                continue;
            }
            let k = tools.index_of(s.tool).unwrap_or(0);
            if top[k].is_none_or(|j| s.feed_mm_min > self.steps[j].feed_mm_min) {
                top[k] = Some(i);
            }
        }
        top
    }

    /// Highest mean path speed of a step that removed material (not a rapid), mm/min.
    pub fn peak_cutting_feed_mm_min(&self) -> f64 {
        (0..self.steps.len())
            .filter(|&i| !self.steps[i].step.rapid && self.record.volume_mm3(i) > NOTHING_MM3)
            .map(|i| self.steps[i].feed_mm_min)
            .fold(0.0, f64::max)
    }

    /// Largest MRR of a servo period resolved to the grid, mm³/s, over the
    /// periods that are not all rapid: a rapid move that removes stock is a
    /// collision, told by the rapid_cut warning with its volume and line, not
    /// a removal rate the feed sets.
    pub fn peak_period_mrr_mm3_s(&self) -> f64 {
        let mut peak = 0.0;
        self.for_each_period(|p| {
            if p.cutting {
                peak = f64::max(peak, p.mrr_mm3_s());
            }
        });
        peak
    }

    /// Step `i` breaks its tool: its stress exceeds the tool's rupture
    /// strength (MODEL.md §4.4).
    pub fn breaks(&self, i: usize) -> bool {
        self.loads[i].breaks(self.rupture_strength_mpa_at(i))
    }

    /// The linear beam's deflection of step `i` at the contact height, µm:
    /// its reported deflection, or where the step breaks the tool, the one it
    /// would have if the tool did not break (what a deflection limit scales
    /// with the feed, MODEL.md §4.4).
    pub fn linear_deflection_um(&self, i: usize) -> f64 {
        self.loads[i].linear_deflection_um(self.rupture_strength_mpa_at(i))
    }

    /// The step with the largest reported deflection breaks its tool: the
    /// peak is capped at rupture.
    pub fn peak_deflection_at_rupture(&self) -> bool {
        let mut peak: Option<(usize, f64)> = None;
        for (i, l) in self.loads.iter().enumerate() {
            if peak.is_none_or(|(_, d)| l.deflection_um > d) {
                peak = Some((i, l.deflection_um));
            }
        }
        peak.is_some_and(|(i, _)| self.breaks(i))
    }

    /// The lowest allowable stress of the tools the run uses, MPa.
    pub fn stress_limit_mpa(&self) -> f64 {
        self.strengths_mpa
            .values()
            .map(|s| s[0])
            .fold(f64::INFINITY, f64::min)
    }

    /// Allowable stress of step `i`'s tool, MPa.
    pub fn stress_limit_mpa_at(&self, i: usize) -> f64 {
        self.strengths_mpa[&self.steps[i].tool][0]
    }

    /// Rupture strength of step `i`'s tool, MPa: a step whose stress
    /// exceeds it breaks the tool, and its deflections are those at rupture
    /// (MODEL.md §4.4, [`cutting::StepLoad::at_rupture`]).
    pub fn rupture_strength_mpa_at(&self, i: usize) -> f64 {
        self.strengths_mpa[&self.steps[i].tool][1]
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

    /// The headline numbers of the run.
    pub fn summary(&self) -> Summary {
        let n = self.steps.len();
        let [min_error_um, max_error_um] = self.error_range_um();
        let final_volume_mm3 = self.final_volume_mm3;
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
            peak_force_revolution_n: self
                .loads
                .iter()
                .map(|l| l.force_peak_n)
                .fold(0.0, f64::max),
            peak_power_w: self.loads.iter().map(|l| l.power_w).fold(0.0, f64::max),
            peak_torque_nm: self.loads.iter().map(|l| l.torque_nm).fold(0.0, f64::max),
            peak_deflection_um: self
                .loads
                .iter()
                .map(|l| l.deflection_um)
                .fold(0.0, f64::max),
            peak_deflection_at_rupture: self.peak_deflection_at_rupture(),
            tool_breaks_steps: (0..n).filter(|&i| self.breaks(i)).count(),
            peak_cutting_feed_mm_min: self.peak_cutting_feed_mm_min(),
            peak_tip_deflection_um: self
                .loads
                .iter()
                .map(|l| l.tip_deflection_um)
                .fold(0.0, f64::max),
            rigid_peak_deflection_um: self.rigid_peak_deflection_um,
            max_error_um,
            min_error_um,
            closed_loop: self.closed_loop.enabled,
            closed_loop_converged: self.closed_loop.converged,
            closed_loop_passes: self.closed_loop.passes,
            closed_loop_residual_um: self.closed_loop.residual_um,
            closed_loop_unconverged_steps: self.closed_loop.unconverged.len(),
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
            if !s.step.rapid {
                p.peak_mrr_mm3_s = p.peak_mrr_mm3_s.max(mrr[i]);
            }
            p.peak_force_n = p.peak_force_n.max(self.loads[i].force_n);
            p.peak_deflection_um = p.peak_deflection_um.max(self.loads[i].deflection_um);
        }
        out
    }
}
