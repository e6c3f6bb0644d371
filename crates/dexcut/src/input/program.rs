//! Reading the program: G-code through `nc`, or a CSV of tool-tip points.

use crate::error::{fail, Error, Result, ResultExt as _};
use nalgebra::Point3;
use nc::{Geometry, Motion, Segment};

use crate::input::job::{Job, ZAxis};

/// A program ready to run: its motion path and, for G-code, its source text.
#[derive(Clone, Debug)]
pub struct Program {
    pub path: nc::Path,
    /// File name used in messages.
    pub file: String,
    /// G-code source (None for CSV point lists).
    pub gcode: Option<String>,
    /// Interpreter settings the path was read with (G-code only), in the
    /// program's own frame (Z as `[machine] z_axis` says).
    pub nc_options: nc::Options,
    /// The program's Z points down (`[machine] z_axis = "down"`): its path,
    /// and that of every program re-fed from it, is read mirrored in Z
    /// ([`Program::in_frame`]).
    pub z_down: bool,
    /// What the reader warned of: where LinuxCNC would refuse the file (no
    /// program end, a byte-order mark) but most controls read it.
    pub read_warnings: Vec<nc::Diagnostic>,
    /// A servo stream's own timing (a CSV point list with `t_s`, such as
    /// servo.csv): its moves are timed by it, not by their feeds.
    pub stream: Option<StreamTiming>,
}

/// The timing of a servo stream read as a program (a point list with a
/// `t_s` column, such as optimize's servo.csv), per move of its path.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StreamTiming {
    /// Time at the end of each move from the stream's first row, s.
    pub t_end_s: Vec<f64>,
    /// The move continues the servo period of the move before it: it starts
    /// at a corner row (`sample` = 0), where the motion changes between
    /// rapid and feed inside a period.
    pub continues: Vec<bool>,
}

impl Program {
    /// `parsed`: a text (this program, or one re-fed from it) read as this
    /// program was, with its options (`nc::parse(text, &self.file,
    /// &self.nc_options)`, or what `nc::refeed_read` read back), mirrored
    /// into dexcut's Z-up frame when its Z points down.
    pub fn in_frame(&self, mut parsed: nc::Parsed) -> nc::Parsed {
        if self.z_down {
            parsed.path.mirror_z();
        }
        parsed
    }

    /// A G-code program's path read again from its text, as [`parse_gcode`]
    /// read it (its options hold the start it chose: the same text and
    /// options make the same path bit for bit), in dexcut's frame; None for a
    /// point list. Before `[machine] arcs_as_lines` (`Setup::program_path_again`).
    pub fn read_path(&self) -> Option<Result<nc::Path>> {
        let text = self.gcode.as_deref()?;
        let parsed = self.in_frame(nc::parse(text, &self.file, &self.nc_options));
        Some(
            match parsed.diagnostics.into_iter().find(|d| d.is_error()) {
                Some(d) => Err(Error::Program {
                    diagnostics: vec![d],
                }),
                None => Ok(parsed.path),
            },
        )
    }

    /// Highest spindle speed the program sets that a tool `diameter_mm`
    /// wide plausibly runs at ([`crate::input::tools::plausible_rpm`]), rev/min (0
    /// if none): on the moves of tool `tool` (a tool table's entry), or on
    /// every move (`None`: a single `[tool]` cuts every T).
    pub fn spindle_rpm_for(&self, diameter_mm: f64, tool: Option<u32>) -> f64 {
        self.path
            .segments
            .iter()
            .filter(|s| tool.is_none_or(|t| s.tool == t))
            .map(|s| s.spindle_rpm)
            .filter(|&rpm| crate::input::tools::plausible_rpm(diameter_mm, rpm))
            .fold(0.0, f64::max)
    }
}

/// Load the job's program, choosing the reader by its content (any file
/// name: .nc, .ngc, .gc, .tap, .gcode, .cnc, … are all G-code).
pub fn load(job: &Job) -> Result<Program> {
    let path = job.resolve(&job.program().path);
    let size = crate::bounds::check_input_file(&path, "program", crate::bounds::MAX_PROGRAM_BYTES)?;
    crate::bounds::check_memory(
        size as f64 * crate::bounds::BYTES_PER_PROGRAM_BYTE,
        &format!("reading the {size}-byte program {}", path.display()),
    )?;
    let (text, not_utf8) = read_text(&path)?;
    let file = path.display().to_string();
    if is_points_csv(&text) {
        // A point list gives tool tips in the machine's own Z, as servo.csv
        // writes them: mirrored where `[machine] z_axis = "down"`.
        // A point list without a tool column is cut by the job's first tool.
        let tool = job.tool_specs()[0].0.unwrap_or(1);
        let (mut path, stream) = read_points_csv(&text, &file, job.program().feed, tool)?;
        if job.machine.z_axis == ZAxis::Down {
            path.mirror_z();
        }
        Ok(Program {
            path,
            file,
            gcode: None,
            nc_options: nc::Options::default(),
            z_down: job.machine.z_axis == ZAxis::Down,
            read_warnings: Vec::new(),
            stream,
        })
    } else {
        let mut program = parse_gcode(text, &file, job)?;
        if let Some(w) = not_utf8 {
            let at = program.read_warnings.partition_point(|d| d.line <= w.line);
            program.read_warnings.insert(at, w);
        }
        Ok(program)
    }
}

/// The text of the program at `path`: UTF-8, or where a byte is not,
/// G-code with those bytes read as Windows-1252 ([`nc::decode`]) and the
/// warning of that at the first one's line and column. A CSV point list
/// must be UTF-8: one that is not is refused at that byte's line and column.
pub fn read_text(path: &std::path::Path) -> Result<(String, Option<nc::Diagnostic>)> {
    let bytes = crate::bounds::read_bytes(path, "program", crate::bounds::MAX_PROGRAM_BYTES)?;
    // Checked once: a UTF-8 text is taken as it is, without a copy.
    let (bytes, e) = match String::from_utf8(bytes) {
        Ok(text) => return Ok((text, None)),
        Err(e) => {
            let at = e.utf8_error();
            (e.into_bytes(), at)
        }
    };
    // Whether it is a point list is told by its first lines: only those decoded.
    let head = &bytes[..bytes.len().min(64 << 10)];
    if is_points_csv(&String::from_utf8_lossy(head)) {
        return Err(crate::bounds::not_utf8(path, "point list", &bytes, e));
    }
    Ok(nc::decode(
        bytes,
        &path.display().to_string(),
        nc::FileForm::Tolerant,
    ))
}

/// True when the first non-blank line is a CSV header naming columns x, y
/// and z: a tool-tip point list. Anything else is read as G-code.
pub fn is_points_csv(text: &str) -> bool {
    let Some(first) = text.lines().map(str::trim).find(|l| !l.is_empty()) else {
        return false;
    };
    let fields: Vec<String> = first
        .split(',')
        .map(|f| f.trim().to_ascii_lowercase())
        .collect();
    ["x", "y", "z"]
        .iter()
        .all(|axis| fields.iter().any(|f| f == axis))
}

/// Parse G-code text; every error diagnostic is reported at once. The tool
/// starts at `[machine] start`, or by default at the highest Z of the
/// program above its first rapid's end or the origin (see [`default_start`]). The text
/// is kept as the program's source (not copied). With `[machine] z_axis =
/// "down"` the program is read in its own frame, tool lengths towards −Z
/// (the tip below the gauge point is at its +Z), and its path mirrored in Z
/// ([`nc::Path::mirror_z`]); `start` is in the program's frame.
pub fn parse_gcode(text: String, file: &str, job: &Job) -> Result<Program> {
    let z_down = job.machine.z_axis == ZAxis::Down;
    // The tip is the gauge length below the gauge point: towards −Z, or +Z
    // on a machine whose Z points down.
    let length_sign = if z_down { -1.0 } else { 1.0 };
    let mut options = nc::Options {
        work_offsets_mm: job.offsets.as_array(),
        // Read as most controls read a file: no program end and a byte-order
        // mark are warnings, not errors as in LinuxCNC.
        file_form: nc::FileForm::Tolerant,
        tool_lengths_mm: job
            .tools
            .iter()
            .filter_map(|t| Some((t.number?, length_sign * t.length.unwrap_or(0.0))))
            .collect(),
        // Cutter compensation (G41/G42) takes the radius from these.
        tool_diameters_mm: job
            .tools
            .iter()
            .filter_map(|t| Some((t.number?, t.diameter)))
            .collect(),
        default_tool_diameter_mm: job.tool.as_ref().map_or(0.0, |t| t.diameter),
        // A table of one tool: it is in the spindle from the start.
        initial_tool: match job.tools.as_slice() {
            [only] => only.number,
            _ => None,
        },
        // The moves its loops make are bounded by memory, not by its text.
        max_segments: crate::bounds::max_path_segments(text.len()),
        ..nc::Options::default()
    };
    options.initial_position_mm = job.machine.start.unwrap_or_default();
    // Read once: with the default start the program runs again from there,
    // in the first run's memory.
    let reader = nc::Reader::new(&text, file, &options);
    // What the first run found wrong (its errors, or no motion): then no second run.
    let mut refused: Option<Error> = None;
    let mut default = None;
    let mut parsed = reader.parse_then_from(|first| {
        let errors: Vec<nc::Diagnostic> = first
            .diagnostics
            .iter()
            .filter(|d| d.is_error())
            .cloned()
            .collect();
        if !errors.is_empty() {
            refused = Some(Error::Program {
                diagnostics: errors,
            });
            return None;
        }
        if first.path.segments.is_empty() {
            refused = Some(Error::request(format!("{file}: the program has no motion")));
            return None;
        }
        if job.machine.start.is_some() {
            return None;
        }
        // The default start depends on the path run from the origin: run it again from there.
        // Found in dexcut's frame, given in the program's.
        let [x, y, z] = default_start(&first.path, z_down);
        default = Some([x, y, if z_down { -z } else { z }]);
        default
    });
    if let Some(e) = refused {
        return Err(e);
    }
    if let Some(start) = default {
        options.initial_position_mm = start;
    }
    if z_down {
        parsed.path.mirror_z();
    }
    Ok(Program {
        path: parsed.path,
        file: file.to_string(),
        gcode: Some(text),
        nc_options: options,
        z_down,
        read_warnings: parsed
            .diagnostics
            .into_iter()
            .filter(|d| !d.is_error())
            .collect(),
        stream: None,
    })
}

/// Start at the highest Z of the path (the machine arrives from a safe
/// height), above the end of the first move when it is a rapid, else above
/// where the program was read from (the machine origin): a rapid is never
/// split when the program is re-fed, a feed move may be, so the written
/// program (optimized.nc) read on its own starts where the original did.
/// `path` is the program's as read, in dexcut's frame once mirrored where
/// Z points down (`z_down`): the start is in dexcut's frame.
fn default_start(path: &nc::Path, z_down: bool) -> [f64; 3] {
    let first = match path.segments[0] {
        nc::Segment {
            motion: nc::Motion::Rapid,
            end,
            ..
        } => end,
        nc::Segment { start, .. } => start,
    };
    // Z as `nc::Path::mirror_z` gives it.
    let z = |z: f64| if z_down { -z } else { z };
    let top = path
        .segments
        .iter()
        .map(|s| z(s.end.z).max(z(s.start.z)))
        .fold(z(first.z), f64::max);
    [first.x, first.y, top]
}

/// Tool-tip points with header `x,y,z[,feed]` (mm, mm/min) become straight
/// feed moves from each point to the next; the first point is the start.
/// With a `t_s` column (s) the list is a servo stream, such as optimize's
/// servo.csv: each row is where the tool is at that time, a move takes the
/// time between its rows (its feed is length / time), a row where the tool
/// stays put is a dwell, and a feed column is not read. Optional columns
/// `tool` (T number; else `default_tool`) and `spindle_rpm` (rev/min; else
/// none given) say which tool cuts each move and at what spindle speed, as
/// servo.csv's do. A stream's optional column `rapid` (1: the move ending at
/// the row is a rapid, G0) gives the moves their kind, and `sample` (0: the
/// row is a corner inside a servo period, where the motion changes between
/// rapid and feed; 1 or absent: a servo sample) says which move continues the
/// period of the one before; the stream's timing comes back with the path.
pub fn read_points_csv(
    text: &str,
    file: &str,
    default_feed: Option<f64>,
    default_tool: u32,
) -> Result<(nc::Path, Option<StreamTiming>)> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .or_input(file, 1, 1, || "cannot read the CSV header".into())?
        .clone();
    let find = |name: &str| headers.iter().position(|h| h.eq_ignore_ascii_case(name));
    let (Some(ix), Some(iy), Some(iz)) = (find("x"), find("y"), find("z")) else {
        return Err(Error::input(
            file,
            1,
            1,
            format!(
                "the header must name columns x, y, z (and optionally feed); found {:?}",
                headers.iter().collect::<Vec<_>>()
            ),
        ));
    };
    let ifeed = find("feed").or_else(|| find("feed_mm_min"));
    // A servo stream (servo.csv): where the tool is at each time; the times
    // time the moves, not a feed.
    let it = find("t_s");
    let (ispindle, itool) = (find("spindle_rpm"), find("tool"));
    let (irapid, isample) = (find("rapid"), find("sample"));
    let mut timing = it.map(|_| StreamTiming::default());
    let (mut t_first, mut prev_corner) = (None, false);
    if it.is_none() && ifeed.is_none() && default_feed.is_none() {
        return Err(Error::input(
            file,
            1,
            1,
            "no feed column and no [program] feed in the job",
        ));
    }
    let mut segments = Vec::new();
    let mut prev: Option<Point3<f64>> = None;
    let mut prev_t: Option<f64> = None;
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            Error::input(file, line, 1, e.to_string())
        })?;
        let line = record.position().map_or(0, |p| p.line()) as u32;
        let field = |i: usize, what: &str| -> Result<f64> {
            // Field ranges exclude delimiters: add one per preceding field.
            let col = record.range(i).map_or(1, |r| r.start + i + 1);
            let raw = record.get(i).unwrap_or("");
            let (line, col) = (line as u64, col as u64);
            let v: f64 = raw.parse().or_input(file, line, col, || {
                format!("{what} is not a number: {raw:?}")
            })?;
            if !v.is_finite() {
                let message = format!("{what} must be finite, got {raw}");
                return Err(Error::input(file, line, col, message));
            }
            Ok(v)
        };
        let p = Point3::new(field(ix, "x")?, field(iy, "y")?, field(iz, "z")?);
        let col_of = |i: usize| record.range(i).map_or(1, |r| r.start + i + 1) as u64;
        // A 0/1 column of a stream (absent: `absent`).
        let flag = |i: Option<usize>, what: &str, absent: bool| -> Result<bool> {
            let Some(i) = i.filter(|_| it.is_some()) else {
                return Ok(absent);
            };
            let v = field(i, what)?;
            if v != 0.0 && v != 1.0 {
                let message = format!("{what} must be 0 or 1, got {v}");
                return Err(Error::input(file, line as u64, col_of(i), message));
            }
            Ok(v == 1.0)
        };
        let rapid = flag(irapid, "rapid", false)?;
        let corner = !flag(isample, "sample", true)?;
        // The move from the previous row to this one.
        let motion = if let Some(it) = it {
            let t = field(it, "t_s")?;
            let dt = prev_t.map(|t0| (t - t0, t0));
            prev_t = Some(t);
            let t_first = *t_first.get_or_insert(t);
            match (prev, dt) {
                (Some(start), Some((dt, t0))) => {
                    if !(dt > 0.0) {
                        let message =
                            format!("t_s must increase from row to row: {t} s after {t0} s");
                        return Err(Error::input(file, line as u64, col_of(it), message));
                    }
                    if let Some(timing) = timing.as_mut() {
                        timing.t_end_s.push(t - t_first);
                        timing.continues.push(prev_corner);
                    }
                    let length = (p - start).norm();
                    // A row where the tool stays put is a dwell of its period.
                    if rapid {
                        Motion::Rapid
                    } else if length > 0.0 {
                        Motion::feed(60.0 * length / dt)
                    } else {
                        Motion::Dwell { seconds: dt }
                    }
                }
                _ => Motion::Rapid,
            }
        } else {
            let feed = match ifeed {
                Some(i) if !record.get(i).unwrap_or("").is_empty() => field(i, "feed")?,
                _ => default_feed.unwrap_or(0.0),
            };
            if !(feed > 0.0) {
                let col = ifeed.map_or(1, col_of);
                let message = format!("feed must be positive, got {feed}");
                return Err(Error::input(file, line as u64, col, message));
            }
            Motion::feed(feed)
        };
        let spindle_rpm = match ispindle {
            Some(i) => {
                let rpm = field(i, "spindle_rpm")?;
                if rpm < 0.0 {
                    let message = format!("spindle_rpm must not be negative, got {rpm}");
                    return Err(Error::input(file, line as u64, col_of(i), message));
                }
                rpm
            }
            None => 0.0,
        };
        let tool = match itool {
            Some(i) => {
                let number = field(i, "tool")?;
                if !(number >= 0.0 && number <= u32::MAX as f64 && number.fract() == 0.0) {
                    let message = format!("tool must be a tool number, got {number}");
                    return Err(Error::input(file, line as u64, col_of(i), message));
                }
                number as u32
            }
            None => default_tool,
        };
        prev_corner = corner;
        if let Some(start) = prev {
            segments.push(Segment {
                start,
                end: p,
                geometry: Geometry::Line,
                motion,
                line,
                spindle_rpm,
                tool,
            });
        }
        prev = Some(p);
    }
    if segments.is_empty() {
        fail!(request, "{file}: need at least two points to make a move");
    }
    Ok((nc::Path::from_segments(segments), timing))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_points_become_lines() {
        let (path, timing) = read_points_csv(
            "x,y,z,feed\n0,0,1,\n10,0,1,600\n10,5,1,\n",
            "p.csv",
            Some(1200.0),
            1,
        )
        .unwrap();
        assert_eq!(timing, None);
        assert_eq!(path.segments.len(), 2);
        assert_eq!(path.segments[0].motion, Motion::feed(600.0));
        assert_eq!(path.segments[1].motion, Motion::feed(1200.0));
        assert_eq!(path.segments[1].line, 4);
        assert!((path.length_mm() - 15.0).abs() < 1e-12);
    }

    #[test]
    fn programs_are_told_apart_by_content() {
        assert!(is_points_csv("\n x, y ,Z,feed\n0,0,0,100\n"));
        assert!(!is_points_csv("%\nG0 X0 Y0 Z5\nM30\n%\n"));
        assert!(!is_points_csv("(x,y,z)\nG0 X1\n"));
        assert!(!is_points_csv(""));
    }

    #[test]
    fn csv_errors_name_line_and_column() {
        let err = read_points_csv("x,y,z\n0,0,1\n1,abc,1\n", "p.csv", Some(100.0), 1)
            .unwrap_err()
            .to_string();
        assert_eq!(err, "p.csv:3:3: y is not a number: \"abc\"");
        let err = read_points_csv("a,b\n0,0\n", "p.csv", Some(100.0), 1)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("p.csv:1:1: the header must name"), "{err}");
        let err = read_points_csv("x,y,z\n0,0,0\n1,1,1\n", "p.csv", None, 1)
            .unwrap_err()
            .to_string();
        assert!(err.contains("no feed column"), "{err}");
    }
}
