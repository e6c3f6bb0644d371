//! The run's warnings (MODEL.md §10) and their texts.

use dexel::NEVER_CUT;

use super::loads::breaking_step;
use super::{Run, NOTHING_MM3};
use crate::model::warnings::{self, LineTally, WarningKind, Warnings};

impl Run {
    /// Warnings of this run (MODEL.md §10): rapid moves that cut, shank or
    /// holder contact, a program that removes nothing.
    pub fn warnings(&self) -> Warnings {
        let mut out = Warnings::default();
        let (mut rapid, mut shank) = (LineTally::new(), LineTally::new());
        let (mut stress, mut breaks) = (LineTally::new(), LineTally::new());
        for (i, s) in self.steps.iter().enumerate() {
            if self.loads[i].stress_mpa > self.stress_limit_mpa_at(i) {
                warnings::tally(&mut stress, s.line, self.loads[i].stress_mpa);
            }
            if self.breaks(i) {
                warnings::tally(&mut breaks, s.line, self.loads[i].stress_mpa);
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
        // The allowable stress of the step the message quotes (the highest stress over
        // its own tool's limit), not the lowest of all tools.
        let limit = (0..self.steps.len())
            .filter(|&i| self.loads[i].stress_mpa > self.stress_limit_mpa_at(i))
            .max_by(|&a, &b| {
                self.loads[a]
                    .stress_mpa
                    .total_cmp(&self.loads[b].stress_mpa)
            })
            .map_or_else(|| self.stress_limit_mpa(), |i| self.stress_limit_mpa_at(i));
        let rigid_kept = if self.closed_loop.rigid_kept {
            "; the closed loop keeps the rigid tool's force, deflection and error for it (no elastic balance, docs/MODEL.md §5.1)"
        } else {
            ""
        };
        out.from_lines(WarningKind::Force, &stress, "MPa", false, |v, lines| {
            format!("the cutting force and torque stress the tool to {v:.0} MPa at {lines}, above the allowable {limit:.0} MPa ([tool] stress_limit_mpa, docs/MODEL.md §4.4): lower the feed or the engagement, or use a shorter or stiffer tool{rigid_kept}")
        });
        if let Some((w, ratio)) = breaking_step(&self.loads, |i| self.rupture_strength_mpa_at(i)) {
            let rupture = self.rupture_strength_mpa_at(w);
            let (tool, line, force) = (
                &self.tool_names[&self.steps[w].tool],
                self.steps[w].line,
                self.loads[w].force_n,
            );
            out.from_lines(WarningKind::ToolBreaks, &breaks, "MPa", false, |v, lines| {
                format!("the tool breaks: the cutting force and torque stress {tool} to {v:.0} MPa at {lines}, {ratio:.1}× its rupture strength of {rupture:.0} MPa ([tool] rupture_strength_mpa, docs/MODEL.md §4.4; {force:.1} N at line {line}); the deflection and error of these steps are the tool's elastic ones at rupture, not the linear beam's: lower the feed or the engagement, or use a stronger tool")
            });
        }
        if self.closed_loop.enabled && !self.closed_loop.converged {
            let mut stalled = LineTally::new();
            for &(i, r) in &self.closed_loop.unconverged {
                warnings::tally(&mut stalled, self.steps[i].line, r);
            }
            let passes = self.closed_loop.passes;
            let steps = self.closed_loop.unconverged.len();
            // The columns of the final surface those steps made (their error
            // map is uncertain by their residual); none known for a tiled stock.
            let mut left = vec![false; self.steps.len()];
            for &(i, _) in &self.closed_loop.unconverged {
                left[i] = true;
            }
            let columns = self
                .stock
                .last_cut()
                .iter()
                .filter(|&&c| c != NEVER_CUT && left[c as usize])
                .count();
            let cell = self.stock.grid().spacing_mm;
            let plural = if steps == 1 { "" } else { "s" };
            let surface = if columns > 0 {
                format!(
                    " and the error map of the {columns} columns ({:.3} mm²) whose surface they made",
                    columns as f64 * cell * cell
                )
            } else {
                String::new()
            };
            out.from_lines(WarningKind::ClosedLoop, &stalled, "µm", false, |v, lines| {
                format!("the closed loop did not settle at {steps} step{plural} after {passes} sweeps, at {lines} (docs/MODEL.md §5.1): there the tool's equilibrium lies between the offset tried and the deflection it caused, up to {v:.1} µm apart, so the deflection there{surface} are uncertain by up to {v:.1} µm, and their force in proportion (elsewhere the loop met 0.5 µm + 2 %); the error map stays within the stock")
            });
        }
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
}
