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
    /// What a `[tool_library]` gave: a tool the program uses with what was
    /// inferred and defaulted, or the entries it skipped.
    ToolLibrary,
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
    #[serde(deserialize_with = "super::summary::f64_or_nan")]
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
            | WarningKind::ChipLoad
            | WarningKind::ToolLibrary => true,
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

#[cfg(test)]
mod tests {
    use super::*;

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
