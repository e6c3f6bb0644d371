//! `[tool_library]`: the tools of a shop's library, by the numbers M6 T
//! calls them: a LinuxCNC tool table (`.tbl`), a Fusion 360 tool library
//! (JSON, or its `.tools` zip) or a FreeCAD ToolBit (`.fctb`) or library
//! (`.fctl`). Each tool becomes a [`ToolSpec`] checked as a `[[tools]]` entry
//! is; what a library does not give (stick-out, shank, flutes, a shape its
//! comment does not name) is defaulted as a machinist would and said in the
//! tool's notes, which the set-up prints (`tool_library` warnings). Tools the
//! simulator cannot model (taps, chamfer and face mills, probes, holders…)
//! are skipped with their reason. docs/guide/job.md, `[tool_library]`.

use std::path::{Path, PathBuf};
use std::sync::LazyLock;

use regex::Regex;

use serde::Deserialize;

use crate::error::{fail, Error, Result};
use crate::input::job::{ToolKind, ToolSpec};

mod freecad;
mod fusion;
mod linuxcnc;
mod zip;

/// Largest tool library file read, bytes.
pub const MAX_LIBRARY_BYTES: u64 = 64 << 20;

/// mm per inch.
const MM_PER_INCH: f64 = 25.4;

/// Shank diameters a holder grips, where a library gives a tool's overall
/// length but not its stick-out.
const GRIP_SHANK_DIAMETERS: f64 = 3.0;

/// Largest gauge length (LinuxCNC's Z offset) accepted, ± mm.
const MAX_GAUGE_MM: f64 = 1e6;

/// `[tool_library]` of a job.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolLibrarySpec {
    /// The library file, relative to the job file.
    pub path: PathBuf,
    /// `"linuxcnc"`, `"fusion"` or `"freecad"`; by default from the file's
    /// extension, else its content.
    pub format: Option<LibraryFormat>,
    /// A LinuxCNC table's units, the machine's: `"mm"` (default) or `"inch"`.
    pub units: Option<TableUnits>,
}

/// The formats of a tool library.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum LibraryFormat {
    /// A LinuxCNC tool table (`.tbl`).
    Linuxcnc,
    /// A Fusion 360 tool library (JSON, or the `.tools` zip holding it).
    Fusion,
    /// A FreeCAD ToolBit (`.fctb`) or tool library (`.fctl`).
    Freecad,
}

impl LibraryFormat {
    fn name(self) -> &'static str {
        match self {
            LibraryFormat::Linuxcnc => "LinuxCNC tool table",
            LibraryFormat::Fusion => "Fusion 360 tool library",
            LibraryFormat::Freecad => "FreeCAD tool library",
        }
    }
}

/// Units of a LinuxCNC tool table.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum TableUnits {
    /// Millimetres.
    #[default]
    #[serde(rename = "mm")]
    Mm,
    /// Inches.
    #[serde(rename = "inch")]
    Inch,
}

/// One tool read from a library.
#[derive(Clone, Debug)]
pub struct LibraryTool {
    /// Its number, the T word that selects it.
    pub number: u32,
    /// The tool as a `[[tools]]` entry, every default filled in.
    pub spec: ToolSpec,
    /// Where it is written: `tools.tbl:13`, `Library/Default.fctl: nr 3
    /// (Bit/6mm_Ball_End.fctb)`, `tools.json: data[4]`.
    pub place: String,
    /// Its name in the library (comment, description), maybe empty.
    pub name: String,
    /// What was inferred and what defaulted, in words.
    pub notes: Vec<String>,
    /// The fields taken by default, by their `[tools]` key names.
    pub defaulted: Vec<&'static str>,
}

/// An entry of a library the simulator does not take, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// Its number, where it has one.
    pub number: Option<u32>,
    /// Where it is written.
    pub place: String,
    /// Its name in the library.
    pub name: String,
    /// Why it is not taken ("a chamfer mill", "no diameter (D absent or not above 0)").
    pub reason: String,
}

/// What a tool library gave.
#[derive(Clone, Debug)]
pub struct Library {
    /// The file, as given (resolved against the job's folder).
    pub path: PathBuf,
    /// Its format.
    pub format: LibraryFormat,
    /// The tools taken, in the library's order.
    pub tools: Vec<LibraryTool>,
    /// The entries skipped.
    pub skipped: Vec<Skipped>,
    /// Notes on the file as a whole (lines that are no tool entries).
    pub notes: Vec<String>,
    /// Every file read: the library and, for a `.fctl`, its bits.
    pub files: Vec<PathBuf>,
    /// Numbers of library tools the job's own `[[tools]]` replace.
    pub replaced: Vec<u32>,
}

impl Library {
    /// The tool numbered `n`.
    pub fn tool(&self, n: u32) -> Option<&LibraryTool> {
        self.tools.iter().find(|t| t.number == n)
    }

    /// The file as messages name it.
    pub fn file_name(&self) -> String {
        self.path.display().to_string()
    }
}

/// Read the library `spec` names, relative to `base_dir` (the job file's
/// folder): every tool checked as a `[[tools]]` entry is, each default
/// said in its notes. Errors name the file, and the line (and column) where
/// there is one.
pub fn read_tool_library(spec: &ToolLibrarySpec, base_dir: &Path) -> Result<Library> {
    let path = if spec.path.is_absolute() {
        spec.path.clone()
    } else {
        base_dir.join(&spec.path)
    };
    let bytes = crate::bounds::read_bytes(&path, "tool library", MAX_LIBRARY_BYTES)?;
    let file = path.display().to_string();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    // A Fusion `.tools` file is a zip holding tools.json.
    let is_zip = bytes.starts_with(b"PK\x03\x04");
    let format = match spec.format {
        Some(f) => f,
        None => match ext.as_str() {
            "tbl" => LibraryFormat::Linuxcnc,
            "json" | "tools" => LibraryFormat::Fusion,
            "fctb" | "fctl" => LibraryFormat::Freecad,
            _ if is_zip => LibraryFormat::Fusion,
            _ => sniff(&bytes),
        },
    };
    if spec.units.is_some() && format != LibraryFormat::Linuxcnc {
        fail!(
            job,
            "tool_library.units is for a LinuxCNC tool table (the machine's units); a {} gives its own units",
            format.name()
        );
    }
    let text_of = |bytes: Vec<u8>, name: &str| -> Result<String> {
        String::from_utf8(bytes).map_err(|e| {
            crate::bounds::not_utf8(
                Path::new(name),
                "tool library",
                e.as_bytes(),
                e.utf8_error(),
            )
        })
    };
    let mut lib = Library {
        path: path.clone(),
        format,
        tools: Vec::new(),
        skipped: Vec::new(),
        notes: Vec::new(),
        files: vec![path.clone()],
        replaced: Vec::new(),
    };
    match format {
        LibraryFormat::Linuxcnc => {
            let text = text_of(bytes, &file)?;
            linuxcnc::read(&text, &file, spec.units.unwrap_or_default(), &mut lib)?;
        }
        LibraryFormat::Fusion => {
            let (json, name) = if is_zip {
                let (entry, data) = zip::json_entry(&bytes, &file)?;
                (
                    text_of(data, &format!("{file}!{entry}"))?,
                    format!("{file}!{entry}"),
                )
            } else {
                (text_of(bytes, &file)?, file.clone())
            };
            fusion::read(&json, &name, &mut lib)?;
        }
        LibraryFormat::Freecad => {
            let text = text_of(bytes, &file)?;
            freecad::read(&text, &path, &mut lib)?;
        }
    }
    let mut seen: Vec<(u32, &str)> = Vec::new();
    for t in &lib.tools {
        if let Some((_, first)) = seen.iter().find(|(n, _)| *n == t.number) {
            fail!(
                job,
                "{}: tool T{} is in the library twice ({first} and {}): a T word must select one tool",
                file,
                t.number,
                t.place
            );
        }
        seen.push((t.number, &t.place));
    }
    if lib.tools.is_empty() {
        let skipped = skipped_list(&lib.skipped);
        fail!(
            job,
            "{file}: the {} has no tool the simulator can model (ball, flat or bull-nose end mills, drills){}",
            format.name(),
            if skipped.is_empty() {
                String::new()
            } else {
                format!("; skipped: {skipped}")
            }
        );
    }
    Ok(lib)
}

/// The format of a file with no telling extension, by its content.
fn sniff(bytes: &[u8]) -> LibraryFormat {
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    let t = text.trim_start();
    if t.starts_with('{') || t.starts_with('[') {
        if t.contains("\"data\"") {
            LibraryFormat::Fusion
        } else {
            LibraryFormat::Freecad
        }
    } else {
        LibraryFormat::Linuxcnc
    }
}

/// "T11 (6mm 90 chamfer mill: a chamfer mill), …" for messages.
pub(crate) fn skipped_list(skipped: &[Skipped]) -> String {
    skipped
        .iter()
        .map(|s| {
            let who = match s.number {
                Some(n) => format!("T{n}"),
                None => s.place.clone(),
            };
            if s.name.is_empty() {
                format!("{who} ({})", s.reason)
            } else {
                format!("{who} ({:?}: {})", s.name, s.reason)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A tool as a reader found it, lengths in mm, before the defaults.
#[derive(Clone, Debug)]
pub(crate) struct Draft {
    pub number: u32,
    pub place: String,
    pub name: String,
    pub kind: ToolKind,
    pub diameter: f64,
    pub corner_radius: Option<f64>,
    pub flute_length: Option<f64>,
    pub stickout: Option<f64>,
    /// Overall length of the tool: the stick-out is never taken longer.
    pub overall_length: Option<f64>,
    pub shank_diameter: Option<f64>,
    pub flutes: Option<u32>,
    /// Gauge length (LinuxCNC's Z offset), mm.
    pub length: Option<f64>,
    /// What the reader inferred ("ball from the comment").
    pub notes: Vec<String>,
}

impl Draft {
    /// A draft of tool `number` at `place` with only its shape and diameter.
    pub fn new(number: u32, place: String, name: String, kind: ToolKind, diameter: f64) -> Draft {
        Draft {
            number,
            place,
            name,
            kind,
            diameter,
            corner_radius: None,
            flute_length: None,
            stickout: None,
            overall_length: None,
            shank_diameter: None,
            flutes: None,
            length: None,
            notes: Vec::new(),
        }
    }
}

use crate::util::short as mm;

/// The tool of a draft: its defaults as a machinist takes them, each said;
/// its values checked as a `[[tools]]` entry's, errors at its place.
pub(crate) fn finish(d: Draft) -> Result<LibraryTool> {
    let key = format!("T{}", d.number);
    let at = |e: Error| e.context(&d.place);
    // The shape's range first: the defaults below are multiples of it.
    if !(d.diameter >= 0.005 && d.diameter <= 500.0) {
        return Err(at(Error::job(format!(
            "{key}.diameter (mm) must lie in 0.005..500, got {}",
            mm(d.diameter)
        ))));
    }
    let mut notes = d.notes.clone();
    let mut defaulted = Vec::new();
    let (mut kind, mut corner) = (d.kind, d.corner_radius);
    if kind == ToolKind::Bull {
        match corner {
            Some(r) if (r - d.diameter / 2.0).abs() <= 1e-9 * d.diameter => {
                kind = ToolKind::Ball;
                corner = None;
                notes.push(format!(
                    "corner radius {} mm is half the diameter: a ball end",
                    mm(r)
                ));
            }
            Some(r) if r <= 0.0 => {
                kind = ToolKind::Flat;
                corner = None;
                notes.push("corner radius 0: a flat end".into());
            }
            _ => {}
        }
    } else {
        corner = None;
    }
    let flute_length = match d.flute_length {
        Some(f) => f,
        None => {
            defaulted.push("flute_length");
            notes.push(format!(
                "flute length {} mm (2 × diameter, not in the library)",
                mm(2.0 * d.diameter)
            ));
            2.0 * d.diameter
        }
    };
    let shank_for_grip = d.shank_diameter.unwrap_or(d.diameter);
    let stickout = match d.stickout {
        Some(s) => s,
        None => {
            defaulted.push("stickout");
            let (s, how) = match (d.overall_length, d.flute_length) {
                // Gripped by three shank diameters, the rest out of the holder.
                (Some(l), _) => (
                    (l - GRIP_SHANK_DIAMETERS * shank_for_grip).max(flute_length),
                    "overall length less a grip of 3 shank diameters, at least the flute length",
                ),
                // Held as short as the flutes allow, a diameter of shank showing.
                (None, Some(f)) => (f + d.diameter, "flute length + diameter"),
                (None, None) => (8.0 * d.diameter, "8 × diameter"),
            };
            notes.push(format!("stickout {} mm ({how}; not in the library)", mm(s)));
            s
        }
    };
    let shank = match d.shank_diameter {
        Some(s) => s,
        None => {
            defaulted.push("shank_diameter");
            notes.push(format!(
                "shank Ø{} mm (the diameter, not in the library)",
                mm(d.diameter)
            ));
            d.diameter
        }
    };
    let flutes = match d.flutes {
        Some(n) => n,
        None => {
            defaulted.push("flutes");
            notes.push("2 flutes (not in the library)".into());
            2
        }
    };
    if let Some(l) = d.length {
        if !(l.abs() <= MAX_GAUGE_MM) {
            return Err(at(Error::job(format!(
                "{key}.length (mm) must lie within ±{MAX_GAUGE_MM:e}, got {l}"
            ))));
        }
    }
    let spec = ToolSpec {
        kind,
        corner_radius: corner,
        diameter: d.diameter,
        flute_length: Some(flute_length),
        stickout: Some(stickout),
        flutes,
        youngs_modulus_mpa: None,
        helix_deg: None,
        effective_diameter: None,
        fz_max: None,
        number: Some(d.number),
        length: Some(d.length.unwrap_or(0.0)),
        shank_diameter: Some(shank),
        holder_stiffness_n_per_um: None,
        stress_limit_mpa: None,
        rupture_strength_mpa: None,
    };
    spec.validate(&key).map_err(at)?;
    Ok(LibraryTool {
        number: d.number,
        spec,
        place: d.place,
        name: d.name,
        notes,
        defaulted,
    })
}

impl LibraryTool {
    /// The tool in one line: "T12 (tools.tbl:13, "2Fl 1/4in Ball End Mill"):
    /// ball Ø6.35 mm, flute length 12.7 mm, stickout 50.8 mm; ball from the
    /// comment; …".
    pub fn describe(&self) -> String {
        let s = &self.spec;
        let shape = match (s.kind, s.corner_radius) {
            (ToolKind::Ball, _) => "ball".to_string(),
            (ToolKind::Flat, _) => "flat".to_string(),
            (ToolKind::Bull, r) => format!("bull r{} mm", mm(r.unwrap_or(0.0))),
        };
        let name = if self.name.is_empty() {
            String::new()
        } else {
            format!(", {:?}", self.name)
        };
        let mut text = format!(
            "T{} ({}{name}): {shape} Ø{} mm, flute length {} mm, stickout {} mm, {} flutes",
            self.number,
            self.place,
            mm(s.diameter),
            mm(s.flute_length.unwrap_or(0.0)),
            mm(s.stickout.unwrap_or(0.0)),
            s.flutes
        );
        if !self.notes.is_empty() {
            text += "; ";
            text += &self.notes.join("; ");
        }
        text
    }
}

/// The tool table of `own` `[[tools]]` entries and `library`: the library's
/// tools appended after `own`, except those of a number `own` gives, which
/// `own`'s entry replaces (their numbers recorded in [`Library::replaced`]).
/// Returns how many were appended (the last ones of `tools`, checked where
/// they were read). For a job's `[tool_library]` and any other place that
/// takes a library beside its own tools (an operation's).
pub fn merge_tools(tools: &mut Vec<ToolSpec>, library: &mut Library) -> usize {
    let own: Vec<u32> = tools.iter().filter_map(|t| t.number).collect();
    let mut added = 0;
    library.replaced.clear();
    for t in &library.tools {
        if own.contains(&t.number) {
            library.replaced.push(t.number);
        } else {
            tools.push(t.spec.clone());
            added += 1;
        }
    }
    added
}

/// The tools of the library `spec` names, read relative to `job_dir` (the
/// job file's folder), with `own` `[[tools]]` entries over them
/// ([`merge_tools`]): the tool table and the library (its notes, skipped
/// entries and files, for [`notes`] and [`check_used`]). Errors name the
/// library file, the entry and (where there is one) its line.
pub fn tools_of_library(
    spec: &ToolLibrarySpec,
    job_dir: &Path,
    own: &[ToolSpec],
) -> Result<(Vec<ToolSpec>, Library)> {
    let mut library = read_tool_library(spec, job_dir)?;
    let mut tools = own.to_vec();
    merge_tools(&mut tools, &mut library);
    Ok((tools, library))
}

/// What the set-up says of the library: each tool the program uses (its
/// shape, what was inferred and defaulted), the tools the job replaces and
/// the entries skipped, one line each (`tool_library` warnings).
pub fn notes(library: &Library, used: &[u32]) -> Vec<String> {
    let file = library.file_name();
    let mut out: Vec<String> = library.notes.clone();
    for t in &library.tools {
        if used.contains(&t.number) && !library.replaced.contains(&t.number) {
            out.push(t.describe());
        }
    }
    if !library.replaced.is_empty() {
        let list: Vec<String> = library.replaced.iter().map(|n| format!("T{n}")).collect();
        out.push(format!(
            "{file}: {} replaced by the job's [[tools]] entries of the same number",
            list.join(", ")
        ));
    }
    if !library.skipped.is_empty() {
        out.push(format!(
            "{file}: {} entries skipped, which the simulator cannot model: {}",
            library.skipped.len(),
            skipped_list(&library.skipped)
        ));
    }
    out
}

/// Tools a program calls that the library skipped (and the job does not
/// give): an error naming the program line and why the tool was skipped.
pub fn check_used(
    lib: &Library,
    job_numbers: &[u32],
    used: impl Iterator<Item = (u32, u32)>,
) -> Result<()> {
    for (number, line) in used {
        if job_numbers.contains(&number) || lib.tool(number).is_some() {
            continue;
        }
        if let Some(s) = lib.skipped.iter().find(|s| s.number == Some(number)) {
            fail!(
                job,
                "line {line}: tool T{number} of the tool library {} ({}{}) is {}, which the simulator cannot model: give it as a [[tools]] entry with number = {number} if it cuts as a ball, flat or bull-nose end mill",
                lib.file_name(),
                s.place,
                if s.name.is_empty() { String::new() } else { format!(", {:?}", s.name) },
                s.reason
            );
        }
    }
    Ok(())
}

/// A program error of a tool the tool table lacks ("tool T5 is not in the
/// job's tool table"), where the library skipped that tool: the reason
/// added to the diagnostic, and how to cut with it. Other errors as they are.
pub fn explain_program_error(lib: &Library, e: Error) -> Error {
    static MISSING: LazyLock<Regex> = LazyLock::new(|| {
        Regex::new(r"^tool T(\d+) is not in the job's tool table").expect("regex")
    });
    match e {
        Error::Program { mut diagnostics } => {
            for d in &mut diagnostics {
                let Some(n) = MISSING
                    .captures(&d.message)
                    .and_then(|c| c[1].parse::<u32>().ok())
                else {
                    continue;
                };
                if let Some(s) = lib.skipped.iter().find(|s| s.number == Some(n)) {
                    d.message = format!(
                        "{}; the tool library {} has it ({}{}) but skipped it: {}, which the simulator cannot model; give it as a [[tools]] entry with number = {n} if it cuts as a ball, flat or bull-nose end mill",
                        d.message,
                        lib.file_name(),
                        s.place,
                        if s.name.is_empty() { String::new() } else { format!(", {:?}", s.name) },
                        s.reason
                    );
                }
            }
            Error::Program { diagnostics }
        }
        other => other,
    }
}

/// Parse a decimal number as a library writes it ("6.35", "+0.5", "6,0"
/// with a decimal comma).
pub(crate) fn parse_number(s: &str) -> Option<f64> {
    let t = s.trim();
    let t = t.strip_prefix('+').unwrap_or(t);
    if t.is_empty()
        || !t
            .bytes()
            .all(|b| b.is_ascii_digit() || b".,-eE+".contains(&b))
    {
        return None;
    }
    let v: f64 = t.replace(',', ".").parse().ok()?;
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests;
