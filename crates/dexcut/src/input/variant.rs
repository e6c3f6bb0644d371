//! A job with some of its numbers changed: one point of a parameter sweep
//! (`python -m dexcut batch sweep`). The job's text is read as TOML, each
//! `section.key = value` is set, and the paths it names (`[program]`,
//! `[stock]` and `[design]` `path`) are made absolute, so the variant reads
//! the same files from wherever it is written. What the variant means is
//! checked when it is loaded, as any job's.

use std::path::Path;

use crate::error::{fail, Error, Result};

/// The keys a sweep may set, each a number: `[limits]`'s, `[tool]`'s (every
/// `[[tools]]` entry's in a tool table), `[machine]`'s (a number for an
/// axis triple such as `accel` sets every axis), `[cutting]`'s and `[servo]`'s.
pub const SWEEP_SECTIONS: [&str; 5] = ["limits", "tool", "machine", "cutting", "servo"];

/// The text of the job `text` (named `name` in messages, its relative paths
/// resolved against `base_dir`) with each `(section.key, value)` of
/// `overrides` set. A key outside [`SWEEP_SECTIONS`], or one whose present
/// value is not a number or a list of numbers, is refused.
pub fn variant(
    text: &str,
    name: &str,
    base_dir: &Path,
    overrides: &[(String, f64)],
) -> Result<String> {
    let mut doc: toml::Table =
        toml::from_str(text).map_err(|e| Error::job(format!("{name}: {}", e.message())))?;
    for (key, value) in overrides {
        let Some((section, field)) = key.split_once('.') else {
            fail!(
                job,
                "{name}: sweep key {key:?} is not SECTION.KEY (e.g. limits.mrr_max)"
            );
        };
        if !SWEEP_SECTIONS.contains(&section) || field.is_empty() || field.contains('.') {
            fail!(
                job,
                "{name}: sweep key {key:?}: the sections a sweep may set are {}",
                SWEEP_SECTIONS.join(", ")
            );
        }
        if !value.is_finite() {
            fail!(
                job,
                "{name}: sweep key {key}: {value} is not a finite number"
            );
        }
        let tables: Vec<&mut toml::Table> = if section == "tool" && doc.contains_key("tools") {
            match doc.get_mut("tools") {
                Some(toml::Value::Array(entries)) => entries
                    .iter_mut()
                    .filter_map(|e| e.as_table_mut())
                    .collect(),
                _ => fail!(job, "{name}: [[tools]] is not a list of tables"),
            }
        } else {
            let table = doc
                .entry(section)
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            match table.as_table_mut() {
                Some(t) => vec![t],
                None => fail!(job, "{name}: {section} is not a table"),
            }
        };
        for table in tables {
            set_number(table, field, *value)
                .map_err(|what| Error::job(format!("{name}: sweep key {key}: {what}")))?;
        }
    }
    for (section, only_mesh) in [("program", false), ("stock", true), ("design", false)] {
        let Some(table) = doc.get_mut(section).and_then(|t| t.as_table_mut()) else {
            continue;
        };
        if only_mesh && table.get("kind").and_then(|k| k.as_str()) != Some("mesh") {
            continue;
        }
        if let Some(toml::Value::String(p)) = table.get_mut("path") {
            let path = Path::new(p.as_str());
            if path.is_relative() {
                *p = base_dir.join(path).display().to_string();
            }
        }
    }
    let mut out = format!("# {name} with {}\n", describe(overrides));
    out.push_str(
        &toml::to_string(&doc)
            .map_err(|e| Error::job(format!("{name}: cannot write the variant: {e}")))?,
    );
    Ok(out)
}

/// Set `field` of `table` to `value`: a list of numbers has every element set.
fn set_number(table: &mut toml::Table, field: &str, value: f64) -> std::result::Result<(), String> {
    let number = |v: f64| {
        if v.fract() == 0.0 && v.abs() < 1e15 {
            toml::Value::Integer(v as i64)
        } else {
            toml::Value::Float(v)
        }
    };
    match table.get_mut(field) {
        None | Some(toml::Value::Integer(_)) | Some(toml::Value::Float(_)) => {
            let axes = matches!(field, "accel" | "jerk");
            let v = if axes && table.get(field).is_none() {
                toml::Value::Array(vec![number(value); 3])
            } else {
                number(value)
            };
            table.insert(field.to_string(), v);
            Ok(())
        }
        Some(toml::Value::Array(items)) => {
            if items
                .iter()
                .any(|i| !matches!(i, toml::Value::Integer(_) | toml::Value::Float(_)))
            {
                return Err("its value is not a list of numbers".into());
            }
            items.iter_mut().for_each(|i| *i = number(value));
            Ok(())
        }
        Some(_) => Err("its value is not a number".into()),
    }
}

/// `limits.mrr_max = 80, tool.stickout = 30`.
pub fn describe(overrides: &[(String, f64)]) -> String {
    overrides
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const JOB: &str = "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [10, 10, 5]\ngrid = 0.1\n[tool]\nkind = \"ball\"\ndiameter = 6\n[program]\npath = \"part.nc\"\n[machine]\naccel = [500, 500, 300]\n";

    #[test]
    fn sets_numbers_axes_and_absolute_paths() {
        let o = vec![
            ("limits.mrr_max".to_string(), 80.0),
            ("tool.stickout".to_string(), 30.5),
            ("machine.accel".to_string(), 1000.0),
        ];
        let text = variant(JOB, "job.toml", Path::new("/jobs"), &o).unwrap();
        let doc: toml::Table = toml::from_str(&text).unwrap();
        assert_eq!(doc["limits"]["mrr_max"].as_integer(), Some(80));
        assert_eq!(doc["tool"]["stickout"].as_float(), Some(30.5));
        assert_eq!(doc["machine"]["accel"].as_array().unwrap().len(), 3);
        assert_eq!(doc["machine"]["accel"][2].as_integer(), Some(1000));
        assert_eq!(doc["program"]["path"].as_str(), Some("/jobs/part.nc"));
        assert!(text.starts_with("# job.toml with limits.mrr_max = 80"));
    }

    #[test]
    fn sets_every_tool_of_a_table_and_refuses_other_keys() {
        let job = "[[tools]]\nnumber = 1\nkind = \"flat\"\ndiameter = 6\n[[tools]]\nnumber = 2\nkind = \"ball\"\ndiameter = 3\n";
        let text = variant(job, "j", Path::new("/"), &[("tool.stickout".into(), 20.0)]).unwrap();
        let doc: toml::Table = toml::from_str(&text).unwrap();
        for t in doc["tools"].as_array().unwrap() {
            assert_eq!(t["stickout"].as_integer(), Some(20));
        }
        for bad in ["stock.grid", "mrr_max", "tool.kind"] {
            assert!(
                variant(job, "j", Path::new("/"), &[(bad.into(), 1.0)]).is_err(),
                "{bad}"
            );
        }
    }
}
