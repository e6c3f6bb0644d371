//! A FreeCAD ToolBit (`.fctb`: `"shape": "endmill.fcstd"`, `"parameter":
//! {"Diameter": "6.00 mm", "CuttingEdgeHeight": …, "Length": …,
//! "ShankDiameter": …, "Flutes": …, "CornerRadius"/"FlatRadius"/"TorusRadius"}`)
//! or a tool library (`.fctl`: `"tools": [{"nr": 1, "path": "x.fctb"}]`, the
//! bits in the `Bit` folder beside the library's `Library` folder, as FreeCAD
//! lays them out). Quantities carry their units ("6,0 mm" with a decimal
//! comma, "1 cm", "0.25 in"). A single bit is tool 1. Better Tool Library's
//! `btl-stickout` attribute gives the stick-out.

use std::path::{Path, PathBuf};
use std::sync::LazyLock;

use regex::Regex;
use serde_json::Value;

use super::{finish, parse_number, Draft, Library, Skipped, MAX_LIBRARY_BYTES, MM_PER_INCH};
use crate::error::{fail, Error, Result};
use crate::input::job::ToolKind;

fn parse_json(text: &str, file: &str) -> Result<Value> {
    serde_json::from_str(text).map_err(|e| {
        Error::input(
            file,
            e.line() as u64,
            e.column() as u64,
            format!("not a FreeCAD tool bit or library (JSON): {e}"),
        )
    })
}

/// Read a `.fctb` (tool 1) or a `.fctl` (its bits by number) into `lib`.
pub(crate) fn read(text: &str, path: &Path, lib: &mut Library) -> Result<()> {
    let file = path.display().to_string();
    let root = parse_json(text, &file)?;
    if let Some(tools) = root.get("tools") {
        let Some(tools) = tools.as_array() else {
            fail!(
                job,
                "{file}: \"tools\" must be a list of {{\"nr\", \"path\"}}"
            );
        };
        for (i, t) in tools.iter().enumerate() {
            let place = format!("{file}: tools[{i}]");
            let Some(nr) = t.get("nr").and_then(Value::as_u64) else {
                fail!(job, "{place}: no tool number \"nr\"");
            };
            let Some(bit) = t.get("path").and_then(Value::as_str) else {
                fail!(job, "{place}: no bit \"path\"");
            };
            let number = match u32::try_from(nr) {
                Ok(0) | Err(_) => {
                    fail!(job, "{place}: nr must be a tool number from 1, got {nr}")
                }
                Ok(n) => n,
            };
            let bit_path = find_bit(path, bit).ok_or_else(|| {
                Error::job(format!(
                    "{place}: the bit {bit:?} of tool {number} is not in the Bit folder beside the library's folder nor beside the library"
                ))
            })?;
            let bit_file = bit_path.display().to_string();
            let text = crate::bounds::read_text(&bit_path, "tool bit", MAX_LIBRARY_BYTES)?;
            let value = parse_json(&text, &bit_file)?;
            lib.files.push(bit_path);
            bit_tool(
                &value,
                number,
                format!("{place} nr {number} ({bit_file})"),
                lib,
            )?;
        }
        return Ok(());
    }
    if root.get("shape").is_some() {
        return bit_tool(&root, 1, file, lib);
    }
    fail!(
        job,
        "{file}: neither a FreeCAD tool bit (no \"shape\") nor a library (no \"tools\")"
    )
}

/// Where a library's bit is: as given when absolute, else in `../Bit/`
/// beside the library's folder (FreeCAD's layout), else beside the library.
fn find_bit(library: &Path, bit: &str) -> Option<PathBuf> {
    let p = Path::new(bit);
    if p.is_absolute() {
        return p.is_file().then(|| p.to_path_buf());
    }
    let dir = library.parent().unwrap_or(Path::new(""));
    let name = p.file_name().map(Path::new).unwrap_or(p);
    // `Library/../Bit` as `Bit` beside `Library`, for messages.
    let bits = match (dir.components().next_back(), dir.parent()) {
        (Some(std::path::Component::Normal(_)), Some(up)) => up.join("Bit"),
        _ => dir.join("..").join("Bit"),
    };
    [bits.join(p), bits.join(name), dir.join(p)]
        .into_iter()
        .find(|c| c.is_file())
}

/// A quantity in mm: "6.0000 mm", "6,0 mm", "1 cm", "0.25 in", "25,0 μm",
/// a bare number (mm).
pub(crate) fn quantity(s: &str) -> Option<f64> {
    static Q: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r#"^\s*([+-]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][+-]?\d+)?)\s*(mm|cm|dm|m|in|inch|"|μm|µm|um|thou|mil)?\s*$"#)
            .expect("regex")
    });
    let c = Q.captures(s)?;
    let v = parse_number(&c[1])?;
    let scale = match c.get(2).map_or("mm", |m| m.as_str()) {
        "mm" => 1.0,
        "cm" => 10.0,
        "dm" => 100.0,
        "m" => 1000.0,
        "in" | "inch" | "\"" => MM_PER_INCH,
        "thou" | "mil" => MM_PER_INCH / 1000.0,
        _ => 1e-3,
    };
    Some(v * scale)
}

/// The tool of one bit's JSON, numbered `number`.
fn bit_tool(bit: &Value, number: u32, place: String, lib: &mut Library) -> Result<()> {
    let name = bit
        .get("name")
        .and_then(Value::as_str)
        .unwrap_or("")
        .trim()
        .to_string();
    let shape = bit
        .get("shape")
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_lowercase();
    let shape = shape.trim_end_matches(".fcstd");
    let params = bit.get("parameter");
    let text = |key: &str| -> Option<String> {
        match params.and_then(|p| p.get(key))? {
            Value::String(s) => Some(s.clone()),
            Value::Number(n) => Some(n.to_string()),
            _ => None,
        }
    };
    let q = |key: &str| -> Result<Option<f64>> {
        match text(key) {
            None => Ok(None),
            Some(s) => match quantity(&s) {
                Some(v) => Ok(Some(v)),
                None => fail!(job, "{place}: parameter {key} {s:?} is not a length"),
            },
        }
    };
    let skip = |lib: &mut Library, reason: String| {
        lib.skipped.push(Skipped {
            number: Some(number),
            place: place.clone(),
            name: name.clone(),
            reason,
        })
    };
    let (kind, how) = match shape {
        "endmill" => (ToolKind::Flat, None),
        "ballend" => (ToolKind::Ball, None),
        "bullnose" | "torus" => (ToolKind::Bull, None),
        "drill" => (
            ToolKind::Flat,
            Some("a drill: modelled as a flat end of its diameter (its point is not modelled)"),
        ),
        "" => {
            skip(lib, "no shape".into());
            return Ok(());
        }
        other => {
            skip(lib, format!("shape {other}"));
            return Ok(());
        }
    };
    let Some(diameter) = q("Diameter")? else {
        fail!(job, "{place}: T{number} has no Diameter parameter");
    };
    let mut d = Draft::new(number, place.clone(), name.clone(), kind, diameter);
    if let Some(how) = how {
        d.notes.push(how.into());
    }
    if kind == ToolKind::Bull {
        d.corner_radius = if let Some(r) = q("CornerRadius")? {
            Some(r)
        } else if let Some(r) = q("TorusRadius")? {
            Some(r)
        } else if let Some(flat) = q("FlatRadius")? {
            d.notes.push(format!(
                "corner radius = diameter / 2 − FlatRadius ({} mm)",
                flat
            ));
            Some(diameter / 2.0 - flat)
        } else {
            fail!(
                job,
                "{place}: T{number} is a bull nose without CornerRadius, TorusRadius or FlatRadius"
            )
        };
    }
    d.flute_length = q("CuttingEdgeHeight")?;
    d.overall_length = q("Length")?;
    d.shank_diameter = match q("ShankDiameter")? {
        Some(s) => Some(s),
        None => q("ShaftDiameter")?,
    };
    if let Some(f) = text("Flutes") {
        match f.trim().parse::<u32>() {
            Ok(0) => {}
            Ok(n) => d.flutes = Some(n),
            Err(_) => fail!(job, "{place}: parameter Flutes {f:?} is not a whole number"),
        }
    }
    let stickout = bit
        .get("attribute")
        .and_then(|a| a.get("btl-stickout"))
        .and_then(Value::as_str);
    if let Some(s) = stickout {
        match quantity(s) {
            Some(v) => {
                d.stickout = Some(v);
                d.notes
                    .push("stickout from the btl-stickout attribute".into());
            }
            None => fail!(job, "{place}: attribute btl-stickout {s:?} is not a length"),
        }
    }
    d.notes.push("gauge length 0 (a bit has none)".into());
    lib.tools.push(finish(d)?);
    Ok(())
}
