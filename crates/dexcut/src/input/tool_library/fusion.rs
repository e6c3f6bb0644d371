//! A Fusion 360 tool library as it exports it: `{"data": [tool, …]}`, each
//! tool with its `type` ("flat end mill", "ball end mill", "bull nose end
//! mill", "drill", …), `unit` ("millimeters" or "inches"), `geometry` (DC
//! diameter, RE corner radius, LCF flute length, LB body length below the
//! holder: the stick-out, OAL overall length, NOF flutes, SFDM shank
//! diameter) and `post-process.number`, the T number. Drills are modelled as
//! flat ends of their diameter; other types (chamfer, face, slot, thread,
//! tapered mills, taps, probes, holders…) are skipped.

use serde_json::Value;

use super::{finish, Draft, Library, Skipped, MM_PER_INCH};
use crate::error::{fail, Error, Result};
use crate::input::job::ToolKind;

/// Read a Fusion 360 library's JSON text into `lib`; `file` names it.
pub(crate) fn read(text: &str, file: &str, lib: &mut Library) -> Result<()> {
    let root: Value = serde_json::from_str(text).map_err(|e| {
        Error::input(
            file,
            e.line() as u64,
            e.column() as u64,
            format!("not a Fusion 360 tool library (JSON): {e}"),
        )
    })?;
    let Some(data) = root.get("data").and_then(Value::as_array) else {
        fail!(
            job,
            "{file}: not a Fusion 360 tool library: no \"data\" list of tools at its top"
        );
    };
    for (i, tool) in data.iter().enumerate() {
        read_tool(tool, i, file, lib)?;
    }
    Ok(())
}

/// A geometry value in mm, where the tool gives it.
fn length(geometry: Option<&Value>, key: &str, scale: f64, place: &str) -> Result<Option<f64>> {
    match geometry.and_then(|g| g.get(key)) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => match v.as_f64() {
            Some(x) => Ok(Some(x * scale)),
            None => fail!(job, "{place}: geometry.{key} must be a number, got {v}"),
        },
    }
}

fn read_tool(tool: &Value, i: usize, file: &str, lib: &mut Library) -> Result<()> {
    let place = format!("{file}: data[{i}]");
    let kind_name = tool.get("type").and_then(Value::as_str).unwrap_or("");
    let name = tool
        .get("description")
        .and_then(Value::as_str)
        .unwrap_or("")
        .trim()
        .to_string();
    let number = tool
        .get("post-process")
        .and_then(|p| p.get("number"))
        .and_then(Value::as_u64);
    let skip = |lib: &mut Library, reason: String| {
        lib.skipped.push(Skipped {
            number: number.and_then(|n| u32::try_from(n).ok()),
            place: place.clone(),
            name: name.clone(),
            reason,
        })
    };
    let (kind, how) = match kind_name {
        "flat end mill" => (ToolKind::Flat, None),
        "ball end mill" => (ToolKind::Ball, None),
        "bull nose end mill" => (ToolKind::Bull, None),
        "drill" => (
            ToolKind::Flat,
            Some("a drill: modelled as a flat end of its diameter (its point is not modelled)"),
        ),
        "" => {
            skip(lib, "no type".into());
            return Ok(());
        }
        other => {
            skip(lib, format!("a {other}"));
            return Ok(());
        }
    };
    let number = match number {
        Some(n) if n >= 1 && n <= u32::MAX as u64 => n as u32,
        Some(_) => {
            skip(lib, "tool number 0 (none given in Fusion)".into());
            return Ok(());
        }
        None => {
            skip(lib, "no post-process.number".into());
            return Ok(());
        }
    };
    let scale = match tool.get("unit").and_then(Value::as_str) {
        Some("millimeters") => 1.0,
        Some("inches") => MM_PER_INCH,
        other => fail!(
            job,
            "{place}: unit must be \"millimeters\" or \"inches\", got {}",
            other.map_or("none".to_string(), |u| format!("{u:?}"))
        ),
    };
    let g = tool.get("geometry");
    let Some(diameter) = length(g, "DC", scale, &place)? else {
        fail!(job, "{place}: T{number} has no geometry.DC (its diameter)");
    };
    let mut d = Draft::new(number, place.clone(), name.clone(), kind, diameter);
    if let Some(how) = how {
        d.notes.push(how.into());
    }
    let re = length(g, "RE", scale, &place)?;
    match kind {
        ToolKind::Bull => {
            d.corner_radius = Some(re.unwrap_or(0.0));
        }
        ToolKind::Flat if re.is_some_and(|r| r > 0.0) && how.is_none() => {
            d.kind = ToolKind::Bull;
            d.corner_radius = re;
            d.notes
                .push("a flat end mill with a corner radius RE: modelled as a bull nose".into());
        }
        _ => {}
    }
    d.flute_length = length(g, "LCF", scale, &place)?;
    d.stickout = length(g, "LB", scale, &place)?;
    d.overall_length = length(g, "OAL", scale, &place)?;
    d.shank_diameter = length(g, "SFDM", scale, &place)?;
    d.flutes = g
        .and_then(|g| g.get("NOF"))
        .and_then(Value::as_u64)
        .filter(|n| *n >= 1)
        .and_then(|n| u32::try_from(n).ok());
    if scale != 1.0 {
        d.notes.push("lengths in inches (its unit)".into());
    }
    d.notes
        .push("gauge length 0 (the library's holder is not used)".into());
    lib.tools.push(finish(d)?);
    Ok(())
}
