//! A LinuxCNC tool table: `T1 P1 Z+0.5 D6.0 ;comment` lines, words in any
//! order and either case, in the machine's units. D is the diameter and Z
//! the length offset (the gauge length G43 applies); the table has no shape,
//! so the comment names it where it clearly does ("ball", "bull", "corner
//! radius R0.5", "end mill", "drill"), and a tool whose comment names none is
//! a flat end mill, said in its notes. P, X, Y, A, B, C, U, V, W, I, J and Q
//! are read and not used.

use std::sync::LazyLock;

use regex::Regex;

use super::{finish, parse_number, Draft, Library, Skipped, TableUnits, MM_PER_INCH};
use crate::error::{Error, Result};
use crate::input::job::ToolKind;

/// The words of a tool table entry.
const LETTERS: &str = "TPXYZABCUVWDIJQ";

/// What a comment says the tool is.
#[derive(Debug, PartialEq)]
pub(crate) enum Named {
    /// A shape the simulator models, with what the comment said.
    Shape(ToolKind, Option<f64>, String),
    /// A tool it does not: the reason.
    Not(String),
}

/// The words of the comment, lower case, split at anything but letters,
/// digits and '-'.
fn words(comment: &str) -> Vec<String> {
    comment
        .to_lowercase()
        .split(|c: char| !(c.is_alphanumeric() || c == '-'))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// The shape a comment names, in the table's units for a corner radius.
pub(crate) fn named(comment: &str) -> Named {
    let w = words(comment);
    let has = |x: &str| w.iter().any(|v| v == x);
    let starts = |x: &str| w.iter().any(|v| v.starts_with(x));
    let pair = |a: &str, b: &str| w.windows(2).any(|p| p[0] == a && p[1] == b);
    let not = |r: &str| Named::Not(r.to_string());
    if has("probe") {
        return not("a probe");
    }
    if pair("tap", "drill") {
        return Named::Shape(
            ToolKind::Flat,
            None,
            "a tap drill: modelled as a flat end of its diameter (its point is not modelled)"
                .into(),
        );
    }
    if pair("center", "drill") || pair("centre", "drill") {
        return not("a center drill");
    }
    if has("tap") || has("tapping") {
        return not("a tap");
    }
    if starts("chamfer") || has("spot") || starts("countersink") || starts("engrav") {
        return not("a chamfer, spot or engraving tool");
    }
    if has("v-bit") || has("vbit") || pair("v", "bit") {
        return not("a V-bit");
    }
    if starts("thread") {
        return not("a thread mill");
    }
    if starts("taper") {
        return not("a tapered mill");
    }
    if pair("face", "mill")
        || has("facemill")
        || starts("flycut")
        || pair("fly", "cutter")
        || pair("shell", "mill")
    {
        return not("a face mill");
    }
    if starts("boring") || has("dovetail") || starts("slitting") || has("saw") || starts("reamer") {
        return not("a boring, dovetail, saw or reaming tool");
    }
    if has("ball") || has("ballnose") || has("ball-nose") || has("ballend") {
        return Named::Shape(ToolKind::Ball, None, "ball from the comment".into());
    }
    if has("bull") || has("bullnose") || has("bull-nose") || pair("corner", "radius") || has("cr") {
        return match corner_radius(comment) {
            Some(r) => Named::Shape(
                ToolKind::Bull,
                Some(r),
                "bull nose and its corner radius from the comment".into(),
            ),
            None => Named::Shape(
                ToolKind::Flat,
                None,
                "the comment names a corner radius but not its size: taken as a flat end".into(),
            ),
        };
    }
    if has("drill") || starts("drill") {
        return Named::Shape(
            ToolKind::Flat,
            None,
            "a drill: modelled as a flat end of its diameter (its point is not modelled)".into(),
        );
    }
    if has("endmill") || has("end-mill") || pair("end", "mill") || has("flat") || has("slot") {
        return Named::Shape(ToolKind::Flat, None, "flat end from the comment".into());
    }
    Named::Shape(
        ToolKind::Flat,
        None,
        "the comment names no shape: taken as a flat end mill".into(),
    )
}

/// A corner radius a comment gives: "R0.5", "r=1", "CR 0.25", "corner
/// radius 0.5".
fn corner_radius(comment: &str) -> Option<f64> {
    static RADIUS: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)(?:\bcorner\s+radius|\bcr|\br)\s*[=:]?\s*(\d+(?:[.,]\d+)?|[.,]\d+)")
            .expect("regex")
    });
    RADIUS
        .captures(comment)
        .and_then(|c| parse_number(&c[1]))
        .filter(|r| *r > 0.0)
}

/// Flutes a comment gives: "2 flute", "4F", "3flt", "2Fl".
fn flutes(comment: &str) -> Option<u32> {
    static FLUTES: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"(?i)\b(\d{1,2})\s*-?\s*(?:flutes?|flt|fl|f)\b").expect("regex")
    });
    FLUTES
        .captures(comment)
        .and_then(|c| c[1].parse().ok())
        .filter(|n| (1..=12).contains(n))
}

/// One entry's words: letter → (value, column).
type Words = Vec<(char, f64, usize)>;

/// The words of an entry line (before its comment), each with its column.
fn entry_words(text: &str, file: &str, line: usize) -> Result<Words> {
    let mut out: Words = Vec::new();
    let mut i = 0;
    let bytes = text.as_bytes();
    while i < bytes.len() {
        if bytes[i].is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let word = &text[start..i];
        let col = text[..start].chars().count() as u64 + 1;
        let mut chars = word.chars();
        let letter = chars.next().map(|c| c.to_ascii_uppercase()).unwrap_or(' ');
        if !LETTERS.contains(letter) {
            return Err(Error::input(
                file,
                line as u64,
                col,
                format!(
                    "{word:?} is not a tool table word (T, P, D, Z, X, Y, A, B, C, U, V, W, I, J, Q followed by a number)"
                ),
            ));
        }
        let Some(v) = parse_number(chars.as_str()).filter(|_| !chars.as_str().contains(',')) else {
            return Err(Error::input(
                file,
                line as u64,
                col,
                format!("{word:?}: {letter} needs a number"),
            ));
        };
        if out.iter().any(|(l, _, _)| *l == letter) {
            return Err(Error::input(
                file,
                line as u64,
                col,
                format!("{letter} is given twice in this entry"),
            ));
        }
        out.push((letter, v, col as usize));
    }
    Ok(out)
}

/// Read a tool table into `lib`.
pub(crate) fn read(text: &str, file: &str, units: TableUnits, lib: &mut Library) -> Result<()> {
    let scale = match units {
        TableUnits::Mm => 1.0,
        TableUnits::Inch => MM_PER_INCH,
    };
    let unit = match units {
        TableUnits::Mm => "mm",
        TableUnits::Inch => "inch",
    };
    let mut ignored: Vec<usize> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let (entry, comment) = match raw.find(';') {
            Some(k) => (&raw[..k], raw[k + 1..].trim()),
            None => (raw, ""),
        };
        let t = entry.trim_start();
        // An entry begins with T and its number; other lines (headers such as
        // QtPyVCP's) are no entries.
        let is_entry = t.len() > 1
            && t.as_bytes()[0].eq_ignore_ascii_case(&b'T')
            && (t.as_bytes()[1].is_ascii_digit() || t.as_bytes()[1] == b'+');
        if !is_entry {
            if !t.trim().is_empty() {
                ignored.push(line);
            }
            continue;
        }
        let w = entry_words(entry, file, line)?;
        let get = |l: char| w.iter().find(|(x, _, _)| *x == l).map(|&(_, v, c)| (v, c));
        let (t_value, t_col) = get('T').expect("an entry begins with T");
        if t_value.fract() != 0.0 || !(0.0..=u32::MAX as f64).contains(&t_value) {
            return Err(Error::input(
                file,
                line as u64,
                t_col as u64,
                format!("T{t_value}: a tool number is a whole number from 0"),
            ));
        }
        let number = t_value as u32;
        let place = format!("{file}:{line}");
        if number == 0 {
            // T0 is the empty spindle.
            continue;
        }
        let skip = |lib: &mut Library, reason: String| {
            lib.skipped.push(Skipped {
                number: Some(number),
                place: place.clone(),
                name: comment.to_string(),
                reason,
            })
        };
        let d = get('D').map(|(v, _)| v * scale);
        let Some(diameter) = d.filter(|d| *d > 0.0) else {
            skip(lib, "no diameter (D absent or not above 0)".into());
            continue;
        };
        let (kind, corner, how) = match named(comment) {
            Named::Not(reason) => {
                skip(lib, reason);
                continue;
            }
            Named::Shape(kind, r, how) => (kind, r.map(|r| r * scale), how),
        };
        let mut draft = Draft::new(number, place, comment.to_string(), kind, diameter);
        draft.corner_radius = corner;
        draft.length = Some(get('Z').map_or(0.0, |(z, _)| z * scale));
        draft.notes.push(how);
        match get('Z') {
            Some((z, _)) => draft.notes.push(format!(
                "gauge length {} mm (Z, for G43)",
                super::mm(z * scale)
            )),
            None => draft.notes.push("gauge length 0 (no Z)".into()),
        }
        if units == TableUnits::Inch {
            draft
                .notes
                .push(format!("D and Z in {unit} (tool_library.units)"));
        }
        if let Some(n) = flutes(comment) {
            draft.flutes = Some(n);
            draft.notes.push(format!("{n} flutes from the comment"));
        }
        lib.tools.push(finish(draft)?);
    }
    if !ignored.is_empty() {
        let shown: Vec<String> = ignored.iter().take(5).map(usize::to_string).collect();
        lib.notes.push(format!(
            "{file}: {} line(s) that are no tool entry (no T word first) ignored: line {}{}",
            ignored.len(),
            shown.join(", "),
            if ignored.len() > 5 { ", …" } else { "" }
        ));
    }
    Ok(())
}
