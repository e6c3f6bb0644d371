//! grbl's settings checked against plausible ranges, and read from a `$$` settings dump.

use super::GrblSettings;
use crate::ScheduleError;

/// The plausible range of each grbl setting (field, lowest, highest) in the field's unit:
/// what [`GrblSettings::validate`] accepts. `$11` = 0 is grbl's exact stop.
pub const GRBL_RANGES: [(&str, f64, f64); 6] = [
    ("junction_deviation_mm", 0.0, 10.0),
    ("arc_tolerance_mm", 1e-6, 10.0),
    ("steps_per_mm", 1e-2, 1e6),
    ("max_rate_mm_min", 1e-3, 1e7),
    ("accel_mm_s2", 1e-3, 1e8),
    ("planner_blocks", 1.0, 1024.0),
];

/// A line of a `$$` dump that cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {what}")]
pub struct DumpError {
    /// 1-based line of the dump.
    pub line: usize,
    /// What is wrong with it.
    pub what: String,
}

impl GrblSettings {
    /// Checks every setting against [`GRBL_RANGES`].
    pub fn validate(&self) -> Result<(), ScheduleError> {
        let check = |name: &'static str, value: f64| {
            let (_, lo, hi) = GRBL_RANGES
                .iter()
                .copied()
                .find(|r| r.0 == name)
                .expect("every checked field has a range");
            if (lo..=hi).contains(&value) {
                Ok(())
            } else if !value.is_finite() {
                Err(ScheduleError::InvalidMachine { name, value })
            } else {
                Err(ScheduleError::MachineOutOfRange {
                    name,
                    value,
                    lo,
                    hi,
                })
            }
        };
        check("junction_deviation_mm", self.junction_deviation_mm)?;
        check("arc_tolerance_mm", self.arc_tolerance_mm)?;
        for i in 0..3 {
            check("steps_per_mm", self.steps_per_mm[i])?;
            check("max_rate_mm_min", self.max_rate_mm_min[i])?;
            check("accel_mm_s2", self.accel_mm_s2[i])?;
        }
        check("planner_blocks", self.planner_blocks as f64)
    }

    /// These settings with the values of a grbl `$$` dump put over them: `$11`, `$12`,
    /// `$100`–`$102`, `$110`–`$112` and `$120`–`$122` (grbl's units: mm, steps/mm,
    /// mm/min, mm/s²); the dump's other settings, blank lines, `ok` and bracketed
    /// messages are skipped, and a trailing `(comment)` (grbl 0.9's form) is allowed.
    /// Every line that is not one of those is a [`DumpError`] with its line; the values
    /// are then checked by [`GrblSettings::validate`].
    pub fn with_dump(mut self, text: &str) -> Result<GrblSettings, DumpError> {
        for (i, raw) in text.lines().enumerate() {
            let fail = |what: String| DumpError { line: i + 1, what };
            let line = raw.trim();
            if line.is_empty() || line == "ok" || line.starts_with('[') || line.starts_with('<') {
                continue;
            }
            let Some(setting) = line.strip_prefix('$') else {
                return Err(fail(format!("expected a setting `$N=value`, got `{line}`")));
            };
            let Some((number, value)) = setting.split_once('=') else {
                return Err(fail(format!("expected `$N=value`, got `{line}`")));
            };
            let number: u32 = number
                .trim()
                .parse()
                .map_err(|_| fail(format!("`${}` is not a setting number", number.trim())))?;
            let value = value.split('(').next().unwrap_or("").trim();
            let value: f64 = value
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| fail(format!("${number}: `{value}` is not a number")))?;
            match number {
                11 => self.junction_deviation_mm = value,
                12 => self.arc_tolerance_mm = value,
                100..=102 => self.steps_per_mm[(number - 100) as usize] = value,
                110..=112 => self.max_rate_mm_min[(number - 110) as usize] = value,
                120..=122 => self.accel_mm_s2[(number - 120) as usize] = value,
                _ => {}
            }
        }
        Ok(self)
    }
}
