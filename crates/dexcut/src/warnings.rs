//! Warnings: what a user must look at in a run, each with the program line it
//! comes from. Printed on the console, written to summary.json (`warnings`)
//! and shown by the report.
//!
//! Each check adds at most one [`Warning`] per kind: the first line where it
//! happens, the worst value, how many steps and which lines (the first few).
//! Other checks (force or deflection plausibility, tool changes) push their
//! own warnings onto the same list through [`Warnings::push`] or
//! [`Warnings::from_lines`].

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// What a warning is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarningKind {
    /// A rapid move (G0) removed material.
    RapidCut,
    /// Material above the flute length: the shank or holder touched the stock.
    ShankContact,
    /// The program never touches the stock.
    NoRemoval,
    /// Cutting force above what the tool can plausibly carry.
    Force,
    /// Tool deflection above what is plausible for the tool.
    Deflection,
    /// The tool's stress above its rupture strength: the tool breaks there
    /// (MODEL.md §4.4).
    ToolBreaks,
    /// The closed loop of removal and deflection did not converge (MODEL.md §5.1).
    ClosedLoop,
    /// A tool the program selects is not in the job's tool table.
    UnknownTool,
    /// A tool change the simulation does not follow.
    IgnoredTool,
    /// The grid is too coarse to measure a tool's removal per period honestly.
    CoarseGrid,
    /// A limit that the optimised program does not meet.
    LimitExceeded,
    /// The written program is slower than the plan it was written from.
    PlanNotMet,
    /// The program file has a form LinuxCNC refuses but most controls read
    /// (no program end, a byte-order mark, a dialect word real posts write;
    /// see `nc::amend`); read as they read it.
    ProgramForm,
    /// An S word too slow to be a milling spindle speed for the tool
    /// (MODEL.md §2.1): not taken as rev/min.
    SpindleSpeed,
    /// A tool's chip-load cap far below the feed the program cuts with.
    ChipLoad,
}

/// One warning: kind, the first program line concerned, the worst value and a
/// message in plain words.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Warning {
    /// What kind of problem.
    pub kind: WarningKind,
    /// First program line (1-based) concerned; none for whole-program warnings.
    pub line: Option<u32>,
    /// The worst (or total, as the message says) value, in `unit`.
    #[serde(deserialize_with = "crate::summary::f64_or_nan")]
    pub value: f64,
    /// Unit of `value`.
    pub unit: String,
    /// Steps (servo periods or moves) concerned; 0 where not counted by step.
    pub steps: usize,
    /// All program lines concerned, in order (at most [`MAX_LINES`]).
    pub lines: Vec<u32>,
    /// The warning in plain words.
    pub message: String,
}

impl Warning {
    /// A warning of the job's set-up, printed before any work: the program
    /// file's form, a tool change a single tool cannot follow, S words that
    /// are no spindle speed, the grid check (see `Setup::warnings`),
    /// and optimize's chip-load check (printed once the program as given is
    /// simulated, before the rounds).
    pub fn of_setup(&self) -> bool {
        match self.kind {
            WarningKind::ProgramForm
            | WarningKind::IgnoredTool
            | WarningKind::SpindleSpeed
            | WarningKind::ChipLoad => true,
            WarningKind::CoarseGrid => self.line.is_none(),
            _ => false,
        }
    }
}

/// Lines listed per warning.
pub const MAX_LINES: usize = 10;

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

/// The list of warnings of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Warnings(pub Vec<Warning>);

/// Per line: (steps, total value, worst value).
pub type LineTally = BTreeMap<u32, (usize, f64, f64)>;

impl Warnings {
    /// Add a warning.
    pub fn push(&mut self, w: Warning) {
        self.0.push(w);
    }

    /// No warning.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The warnings in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Warning> {
        self.0.iter()
    }

    /// The first warning of `kind`.
    pub fn of_kind(&self, kind: WarningKind) -> Option<&Warning> {
        self.0.iter().find(|w| w.kind == kind)
    }

    /// One warning summarising per-line tallies (nothing if `tally` is empty).
    /// `total`: the value is the sum over lines (a volume), else the worst.
    /// `describe(value, lines_text)` writes the message.
    pub fn from_lines(
        &mut self,
        kind: WarningKind,
        tally: &LineTally,
        unit: &str,
        total: bool,
        describe: impl Fn(f64, &str) -> String,
    ) {
        let Some((&first, _)) = tally.iter().next() else {
            return;
        };
        let steps = tally.values().map(|t| t.0).sum();
        let value = if total {
            tally.values().map(|t| t.1).sum()
        } else {
            tally.values().map(|t| t.2).fold(f64::MIN, f64::max)
        };
        let lines: Vec<u32> = tally.keys().copied().take(MAX_LINES).collect();
        let mut text = lines
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(", ");
        if tally.len() > MAX_LINES {
            text += &format!(" and {} more", tally.len() - MAX_LINES);
        }
        let lines_text = if tally.len() == 1 {
            format!("line {text}")
        } else {
            format!("lines {text}")
        };
        self.push(Warning {
            kind,
            line: Some(first),
            value,
            unit: unit.into(),
            steps,
            lines,
            message: describe(value, &lines_text),
        });
    }
}

/// Add `value` at `line` to a tally.
pub fn tally(t: &mut LineTally, line: u32, value: f64) {
    let e = t.entry(line).or_insert((0, 0.0, f64::MIN));
    e.0 += 1;
    e.1 += value;
    e.2 = e.2.max(value);
}

/// Before any work: whether the grid can measure the tool's removal honestly
/// (MODEL.md §10). Two checks, each with a grid that would do:
/// * the tool spans fewer than [`TOOL_CELLS`] columns across its diameter,
///   so its footprint, and the removal of one step, is coarse;
/// * at the slowest programmed cutting feed the tool advances less than one
///   column per servo period, so removal per period comes in whole columns
///   and the per-period MRR shows the grid rather than the cut (the MRR over
///   ≥ 48 ms is still resolved).
pub fn grid_check(
    diameter_mm: f64,
    grid_mm: f64,
    slowest_feed_mm_min: Option<f64>,
    period_ms: f64,
) -> Option<Warning> {
    let mut reasons = Vec::new();
    let mut suggest = grid_mm;
    if diameter_mm / grid_mm < TOOL_CELLS {
        suggest = suggest.min(diameter_mm / TOOL_CELLS);
        reasons.push(format!(
            "the {diameter_mm} mm tool spans only {:.1} columns of {grid_mm} mm",
            diameter_mm / grid_mm
        ));
    }
    if let Some(f) = slowest_feed_mm_min {
        let advance_mm = f * period_ms / 60_000.0;
        if advance_mm < grid_mm {
            suggest = suggest.min(advance_mm);
            reasons.push(format!(
                "at F{f} the tool advances {advance_mm:.3} mm per {period_ms} ms period, less than one column, so the MRR per period comes in whole columns (the MRR over ≥ 48 ms is resolved)"
            ));
        }
    }
    if reasons.is_empty() {
        return None;
    }
    // Round the suggestion down to two significant digits.
    let scale = 10f64.powf(suggest.log10().floor() - 1.0);
    let suggest = (suggest / scale).floor() * scale;
    Some(Warning {
        kind: WarningKind::CoarseGrid,
        line: None,
        value: grid_mm,
        unit: "mm".into(),
        steps: 0,
        lines: Vec::new(),
        message: format!(
            "the grid is too coarse to measure this tool's removal per period: {}; a grid of {} mm (--grid {}) would resolve it",
            reasons.join("; "),
            trim(suggest),
            trim(suggest)
        ),
    })
}

/// S words of cutting moves that are too slow to be a spindle speed for
/// their tool ([`crate::tools::plausible_rpm`]), when the job gives no
/// `[cutting] spindle_rpm`: one warning with their lines.
pub fn spindle_check(path: &nc::Path, tools: &crate::tools::ToolSet) -> Option<Warning> {
    let mut t = LineTally::new();
    let mut worst: Option<(f64, u32, f64)> = None;
    for s in &path.segments {
        let e = tools.entry(s.tool);
        let d = e.tool.diameter_mm;
        if !matches!(s.motion, nc::Motion::Feed { .. })
            || e.job_rpm.is_some()
            || s.spindle_rpm <= 0.0
            || crate::tools::plausible_rpm(d, s.spindle_rpm)
        {
            continue;
        }
        let v = crate::tools::cutting_speed_m_min(d, s.spindle_rpm);
        tally(&mut t, s.line, v);
        if worst.is_none_or(|w| v < w.0) {
            worst = Some((v, e.number, s.spindle_rpm));
        }
    }
    let (v, number, rpm) = worst?;
    let e = tools.entry(number);
    let taken = e.model.spindle_rpm;
    let mut w = Warnings::default();
    w.from_lines(WarningKind::SpindleSpeed, &t, "m/min", false, |_, lines| {
        format!(
            "S{rpm} at {lines} gives {v:.2} m/min at the edge of {}, below {MIN} m/min and under {RPM} rev/min, slower than any milling cutter runs: it is not taken as rev/min (a spindle override in percent, or a laser's power?); forces and the chip-load cap take {taken} rev/min ({}); set [cutting] spindle_rpm to the real spindle speed",
            tools.name(number),
            if taken == 10_000.0 { "the default" } else { "the program's highest plausible S" },
            MIN = crate::tools::MIN_CUTTING_SPEED_M_MIN,
            RPM = crate::tools::MIN_SPINDLE_RPM,
        )
    });
    let mut w = w.0.pop()?;
    w.value = v;
    Some(w)
}

/// A chip-load cap below this share of the tool's programmed cutting feed is
/// warned of ([`chip_load_check`]).
pub const CHIP_LOAD_FAR_BELOW: f64 = 0.2;

/// One warning per tool whose chip-load cap is below
/// [`CHIP_LOAD_FAR_BELOW`] of the feed the program cuts with: optimize will
/// slow its cuts many times, which a machinist trusts only if the cap is
/// right for the stock and the tool.
pub fn chip_load_check(
    loads: &[crate::optimize::ToolChipLoad],
    tools: &crate::tools::ToolSet,
) -> Vec<Warning> {
    loads
        .iter()
        .filter_map(|c| {
            let programmed = c.programmed_feed_mm_min?;
            if c.feed_mm_min >= CHIP_LOAD_FAR_BELOW * programmed {
                return None;
            }
            let line = c.line?;
            Some(Warning {
                kind: WarningKind::ChipLoad,
                line: Some(line),
                value: programmed / c.feed_mm_min,
                unit: "×".into(),
                steps: 0,
                lines: vec![line],
                message: format!(
                    "{} with {} flutes cuts at F{programmed:.0}, {:.4} mm/tooth at {:.0} rev/min ({}), but its chip-load cap is {:.4} mm/tooth ({}) = {:.0} mm/min, {:.1}× lower: optimize slows its cuts to the cap. If the stock is wood or plastic, or the tool is made for more, set fz_max for the tool ([tool] or its [[tools]] entry) or [cutting] material (the default table has metals only, MODEL.md §2.1); if the spindle speed is wrong, set [cutting] spindle_rpm",
                    tools.name(c.tool),
                    c.flutes,
                    c.programmed_fz_mm.unwrap_or(f64::NAN),
                    c.spindle_rpm,
                    c.spindle_from,
                    c.fz_max_mm,
                    c.fz_max_from,
                    c.feed_mm_min,
                    programmed / c.feed_mm_min,
                ),
            })
        })
        .collect()
}

/// Columns a tool's diameter should span for its removal to be resolved.
pub const TOOL_CELLS: f64 = 10.0;

fn trim(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_check_names_both_reasons_and_a_grid() {
        assert!(grid_check(10.0, 0.1, Some(1000.0), 16.0).is_none());
        // 1 mm on 0.2 mm: 5 columns; F150 at 16 ms: 0.04 mm per period.
        let w = grid_check(1.0, 0.2, Some(150.0), 16.0).unwrap();
        assert_eq!(w.kind, WarningKind::CoarseGrid);
        assert!(
            w.message.contains("spans only 5.0 columns"),
            "{}",
            w.message
        );
        assert!(
            w.message.contains("advances 0.040 mm per 16 ms"),
            "{}",
            w.message
        );
        assert!(
            w.message
                .ends_with("a grid of 0.04 mm (--grid 0.04) would resolve it"),
            "{}",
            w.message
        );
        let w = grid_check(1.0, 0.2, None, 16.0).unwrap();
        assert!(w.message.contains("a grid of 0.1 mm"), "{}", w.message);
    }

    #[test]
    fn from_lines_lists_lines_and_sums() {
        let mut t = LineTally::new();
        for line in 1..=12 {
            tally(&mut t, line, 0.5);
        }
        tally(&mut t, 3, 2.0);
        let mut w = Warnings::default();
        w.from_lines(WarningKind::RapidCut, &t, "mm³", true, |v, l| {
            format!("{v:.1} mm³ at {l}")
        });
        let w = &w.0[0];
        assert_eq!(w.line, Some(1));
        assert_eq!(w.steps, 13);
        assert!((w.value - 8.0).abs() < 1e-12);
        assert_eq!(w.lines.len(), MAX_LINES);
        assert_eq!(
            w.message,
            "8.0 mm³ at lines 1, 2, 3, 4, 5, 6, 7, 8, 9, 10 and 2 more"
        );
        let json = serde_json::to_value(w).unwrap();
        assert_eq!(json["kind"], "rapid_cut");
    }
}
