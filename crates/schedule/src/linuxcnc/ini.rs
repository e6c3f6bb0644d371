//! [`LinuxCncIni`] from a LinuxCNC INI file's text (the caller reads
//! the file): `[EMCMOT] SERVO_PERIOD`, `[TRAJ]` limits and blend settings,
//! `[AXIS_X|Y|Z]` (or the `[JOINT_n]` of the axis' letter in `[TRAJ]
//! COORDINATES`) `MAX_VELOCITY`/`MAX_ACCELERATION`, `[DISPLAY]
//! MAX_FEED_OVERRIDE`, and a `G64 P` in `[RS274NGC] RS274NGC_STARTUP_CODE`.

use super::{LinuxCncIni, STARTUP_TOLERANCE_MM};
use crate::ScheduleError;
use std::collections::HashMap;

/// One value of the file with its 1-based line.
struct Value {
    text: String,
    line: usize,
}

/// The file's sections: `(section, key)` to its first value (LinuxCNC's
/// `IniFile::Find` returns the first).
struct Ini<'a> {
    file: &'a str,
    values: HashMap<(String, String), Value>,
}

impl Ini<'_> {
    fn error(&self, line: usize, message: String) -> ScheduleError {
        ScheduleError::Ini {
            file: self.file.into(),
            line,
            message: message.into(),
        }
    }

    fn text(&self, section: &str, key: &str) -> Option<&Value> {
        self.values.get(&(section.to_owned(), key.to_owned()))
    }

    /// A number, `None` when the key is missing.
    fn number(&self, section: &str, key: &str) -> Result<Option<(f64, usize)>, ScheduleError> {
        let Some(v) = self.text(section, key) else {
            return Ok(None);
        };
        let n: f64 = v.text.parse().map_err(|_| {
            self.error(
                v.line,
                format!("[{section}] {key} = {}: not a number", v.text),
            )
        })?;
        if !n.is_finite() {
            return Err(self.error(
                v.line,
                format!("[{section}] {key} = {}: not finite", v.text),
            ));
        }
        Ok(Some((n, v.line)))
    }

    /// A number that must be > 0, `None` when missing.
    fn positive(&self, section: &str, key: &str) -> Result<Option<f64>, ScheduleError> {
        match self.number(section, key)? {
            Some((n, line)) if n <= 0.0 => {
                Err(self.error(line, format!("[{section}] {key} must be > 0, got {n}")))
            }
            other => Ok(other.map(|v| v.0)),
        }
    }
}

fn parse<'a>(text: &str, file: &'a str) -> Result<Ini<'a>, ScheduleError> {
    let mut ini = Ini {
        file,
        values: HashMap::new(),
    };
    let mut section: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with(';') {
            continue;
        }
        if let Some(rest) = line.strip_prefix('[') {
            let Some(name) = rest.strip_suffix(']') else {
                return Err(ini.error(i + 1, format!("section header `{line}` has no closing ]")));
            };
            section = Some(name.trim().to_owned());
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(ini.error(
                i + 1,
                format!("`{line}` is neither a section nor KEY = VALUE"),
            ));
        };
        let Some(sec) = &section else {
            return Err(ini.error(i + 1, format!("`{line}` comes before any [SECTION]")));
        };
        ini.values
            .entry((sec.clone(), key.trim().to_owned()))
            .or_insert(Value {
                text: value.trim().to_owned(),
                line: i + 1,
            });
    }
    Ok(ini)
}

/// Millimetres per machine unit of `[TRAJ] LINEAR_UNITS` (mm, inch, or a
/// number of units per mm as LinuxCNC accepts).
fn mm_per_unit(ini: &Ini) -> Result<f64, ScheduleError> {
    let Some(v) = ini.text("TRAJ", "LINEAR_UNITS") else {
        return Ok(1.0);
    };
    match v.text.to_ascii_lowercase().as_str() {
        "mm" | "metric" | "millimeter" | "millimetre" => Ok(1.0),
        "in" | "inch" | "imperial" => Ok(25.4),
        "cm" => Ok(10.0),
        other => match other.parse::<f64>() {
            Ok(units_per_mm) if units_per_mm > 0.0 => Ok(1.0 / units_per_mm),
            _ => Err(ini.error(
                v.line,
                format!("[TRAJ] LINEAR_UNITS = {}: not mm, inch or a number", v.text),
            )),
        },
    }
}

/// A `G64 P` in `[RS274NGC] RS274NGC_STARTUP_CODE` (in its G20/G21 units).
fn startup_tolerance_mm(ini: &Ini) -> Option<f64> {
    let code = ini
        .text("RS274NGC", "RS274NGC_STARTUP_CODE")?
        .text
        .to_ascii_uppercase();
    let compact: String = code.chars().filter(|c| !c.is_whitespace()).collect();
    let at = compact.find("G64P")?;
    let digits: String = compact[at + 4..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    let p: f64 = digits.parse().ok()?;
    Some(if compact.contains("G20") { p * 25.4 } else { p })
}

/// The settings a LinuxCNC INI file gives its planner; `file` names it in
/// errors (file:line).
pub fn settings_from_ini(text: &str, file: &str) -> Result<LinuxCncIni, ScheduleError> {
    let ini = parse(text, file)?;
    let mm = mm_per_unit(&ini)?;
    let period_ns = ini
        .positive("EMCMOT", "SERVO_PERIOD")?
        .unwrap_or(1_000_000.0);
    let coordinates: Vec<char> = ini
        .text("TRAJ", "COORDINATES")
        .map(|v| v.text.chars().filter(|c| c.is_ascii_alphabetic()).collect())
        .unwrap_or_else(|| vec!['X', 'Y', 'Z']);
    let mut vel = [0.0; 3];
    let mut acc = [0.0; 3];
    for (i, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let axis = format!("AXIS_{letter}");
        let joint = coordinates
            .iter()
            .position(|c| c.eq_ignore_ascii_case(&letter))
            .map(|j| format!("JOINT_{j}"));
        let find = |key: &str| -> Result<f64, ScheduleError> {
            if let Some(v) = ini.positive(&axis, key)? {
                return Ok(v);
            }
            if let Some(j) = &joint {
                if let Some(v) = ini.positive(j, key)? {
                    return Ok(v);
                }
            }
            Err(ini.error(
                0,
                format!(
                    "no [{axis}] {key} (nor [{}] {key})",
                    joint.as_deref().unwrap_or("JOINT_n")
                ),
            ))
        };
        vel[i] = find("MAX_VELOCITY")? * mm;
        acc[i] = find("MAX_ACCELERATION")? * mm;
    }
    let max_linear = match ini.positive("TRAJ", "MAX_LINEAR_VELOCITY")? {
        Some(v) => v,
        None => ini
            .positive("TRAJ", "MAX_VELOCITY")?
            .unwrap_or_else(|| vel.iter().cloned().fold(0.0, f64::max) / mm),
    } * mm;
    let arc_blend_enable = ini
        .number("TRAJ", "ARC_BLEND_ENABLE")?
        .is_none_or(|v| v.0 != 0.0);
    let opt_depth = ini
        .number("TRAJ", "ARC_BLEND_OPTIMIZATION_DEPTH")?
        .map_or(50.0, |v| v.0);
    Ok(LinuxCncIni {
        period_s: period_ns * 1e-9,
        axis_max_vel_mm_s: vel,
        axis_max_acc_mm_s2: acc,
        max_linear_vel_mm_s: max_linear,
        max_feed_scale: ini.positive("DISPLAY", "MAX_FEED_OVERRIDE")?.unwrap_or(1.0),
        startup_tolerance_mm: startup_tolerance_mm(&ini).unwrap_or(STARTUP_TOLERANCE_MM),
        arc_blend_enable,
        arc_blend_opt_depth: opt_depth.max(0.0) as usize,
        arc_blend_gap_cycles: ini
            .number("TRAJ", "ARC_BLEND_GAP_CYCLES")?
            .map_or(4.0, |v| v.0),
        arc_blend_ramp_freq_hz: ini
            .positive("TRAJ", "ARC_BLEND_RAMP_FREQ")?
            .unwrap_or(100.0),
        arc_blend_kink_ratio: ini
            .number("TRAJ", "ARC_BLEND_KINK_RATIO")?
            .map_or(0.1, |v| v.0),
    })
}
