//! The interpreter: modal state, block execution in LinuxCNC's order, flow
//! control (Fanuc M98/M99, LinuxCNC o-words) and motion generation.
//!
//! Internally all lengths are mm in the machine frame; program values are
//! scaled by 25.4 under G20 and shifted by the active work offset and G92.

use std::collections::{BTreeMap, HashMap};
use std::rc::Rc;

use nalgebra::Point3;

mod comp;

use crate::amend::{self, Amendment};
use crate::cursor::SyntaxError;
use crate::cycles::{self, Cycle, CycleMove};
use crate::diag::{Diagnostic, Severity};
use crate::expr::Params;
use crate::gcode::integer_value;
use crate::path::{Geometry, Motion, Path, Plane, Segment};
use crate::syntax::{self, Item, ItemKind, LineKind, OKeyword, OLabel, OStmt, BYTE_ORDER_MARK};
use crate::GCode;

/// Settings the program cannot know by itself.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// G54..G59 work offsets (mm, machine frame).
    pub work_offsets_mm: [[f64; 3]; 6],
    /// Tool tip at program start (mm, machine frame).
    pub initial_position_mm: [f64; 3],
    /// G28 home position (mm, machine frame).
    pub g28_home_mm: [f64; 3],
    /// G30 home position (mm, machine frame).
    pub g30_home_mm: [f64; 3],
    /// Skip lines starting with `/` (block delete switch on).
    pub block_delete: bool,
    /// Stop with an error after executing this many blocks (endless loops).
    pub max_blocks: u64,
    /// Stop with an error once the path has more segments than this (memory bound).
    pub max_segments: usize,
    /// Tool table: gauge length (mm) of each tool number (T word), used by
    /// G43. Empty: every T is accepted and every tool has length 0.
    pub tool_lengths_mm: BTreeMap<u32, f64>,
    /// Diameter (mm) of each tool number, for cutter compensation (G41/G42).
    pub tool_diameters_mm: BTreeMap<u32, f64>,
    /// Diameter (mm) of a tool the map lacks (a single tool for every T).
    pub default_tool_diameter_mm: f64,
    /// Tool in the spindle when the program starts; `None`: the first tool
    /// the program loads (M6, M61), or 0 if it loads none.
    pub initial_tool: Option<u32>,
    /// Errors kept per program; the rest are counted in a last "and K more".
    pub max_errors: usize,
    /// What the reader asks of the file as a whole: its program end and a
    /// leading byte-order mark (a fragment by default).
    pub file_form: FileForm,
}

/// What the reader asks of a file as a whole, beyond its blocks.
///
/// LinuxCNC refuses a file that ends without `M2`, `M30` or a closing `%`,
/// and a UTF-8 byte-order mark before the first line. GRBL, Mach3 and
/// simulators such as CAMotics read both, and CAM posts (BlenderCAM among
/// them) and Windows editors write them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FileForm {
    /// A program fragment (tests, snippets): no program end is needed; a
    /// byte-order mark is an error, as any character the language lacks.
    #[default]
    Fragment,
    /// As LinuxCNC's interpreter: a missing program end and a byte-order mark
    /// are errors.
    LinuxCnc,
    /// As most controls: the program ends at its last line when it has no
    /// program end, a leading byte-order mark is skipped, and the dialects
    /// real posts write are read as their controls read them (see
    /// [`crate::amend`]); each is a warning naming what LinuxCNC would
    /// refuse, and an [`Amendment`] in [`Parsed::amendments`].
    Tolerant,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            work_offsets_mm: [[0.0; 3]; 6],
            initial_position_mm: [0.0; 3],
            g28_home_mm: [0.0; 3],
            g30_home_mm: [0.0; 3],
            block_delete: true,
            max_blocks: 10_000_000,
            max_segments: 5_000_000,
            tool_lengths_mm: BTreeMap::new(),
            tool_diameters_mm: BTreeMap::new(),
            default_tool_diameter_mm: 0.0,
            initial_tool: None,
            max_errors: 20,
            file_form: FileForm::Fragment,
        }
    }
}

/// Result of [`crate::parse`]: the path and every diagnostic found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Parsed {
    /// The motion, as far as the program could be read (a block with an
    /// error adds no motion; later blocks start where it meant to end).
    pub path: Path,
    /// Errors and warnings, in program order.
    pub diagnostics: Vec<Diagnostic>,
    /// The program ended with M2, M30, a closing `%` (or M99 outside any
    /// subprogram), rather than at the end of the file.
    pub has_program_end: bool,
    /// What makes a tolerantly read file one LinuxCNC reads with the same
    /// moves ([`crate::amend`]); empty in the other file forms.
    pub amendments: Vec<Amendment>,
}

/// Per-segment facts the re-feed writer needs (modes in force at the block).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentTrace {
    /// 0-based line index.
    pub line_index: usize,
    /// mm per program unit (1 or 25.4) of the block's coordinates.
    pub scale: f64,
    /// mm per program unit of the block's F word: the units in force before
    /// the block, as F is read before a G20/G21 in the same block takes effect.
    pub feed_scale: f64,
    pub incremental: bool,
    pub arc_incremental: bool,
    pub inverse_time: bool,
    /// Work offset + G92 in force (mm): machine = program·scale + offset.
    pub offset_mm: [f64; 3],
    /// Cutter radius compensation shaped the segment: its block cannot be
    /// split (the pieces would be compensated again).
    pub compensated: bool,
    /// A canned cycle that stops or reverses the spindle made the segment
    /// (G74, G84, G86, G87): its line is never written out as plain moves.
    pub spindle_cycle: bool,
}

/// What a run returns besides the parse result.
pub struct Trace {
    /// One per path segment of a recorded run ([`run_recorded`], the re-feed
    /// writer's); empty otherwise.
    pub segments: Vec<SegmentTrace>,
    /// Every source line as parsed (`None`: syntax error), split as
    /// [`syntax::split_lines`] splits them, keeping no block's items (a
    /// million-line program's are about 190 MB):
    /// [`syntax::Lines::block_items`] parses a block again from the source.
    pub lines: Rc<syntax::Lines>,
    /// The run made the path it was lent ([`run_recorded_along`]) bit for
    /// bit, segment for segment: its [`Parsed::path`] holds no segments.
    pub on_lent_path: bool,
}

/// An execution error at a column.
struct Fail {
    col: u32,
    msg: String,
}

/// Most pecks (times L repeats) one drilling cycle block may make.
const MAX_CYCLE_PECKS: f64 = 100_000.0;

fn fail<T>(col: u32, msg: impl Into<String>) -> Result<T, Fail> {
    Err(Fail {
        col,
        msg: msg.into(),
    })
}

/// A block after evaluation of its words.
#[derive(Default)]
struct Block {
    /// G codes with columns.
    g: Vec<(GCode, u32)>,
    m: Vec<(i32, u32)>,
    /// Letter values and columns, indexed by [`slot`].
    words: [Option<(f64, u32)>; 28],
    first_col: u32,
}

/// Index of a word letter: a–z, then `@` (polar radius) and `^` (polar angle).
fn slot(letter: char) -> usize {
    match letter {
        '@' => 26,
        '^' => 27,
        l => (l as u8 - b'a') as usize,
    }
}

impl Block {
    fn get(&self, letter: char) -> Option<f64> {
        self.words[slot(letter)].map(|w| w.0)
    }
    fn col(&self, letter: char) -> u32 {
        self.words[slot(letter)].map_or(self.first_col, |w| w.1)
    }
    fn has_g(&self, code: GCode) -> Option<u32> {
        self.g.iter().find(|g| g.0 == code).map(|g| g.1)
    }
    fn has_m(&self, code: i32) -> bool {
        self.m.iter().any(|m| m.0 == code)
    }
    /// The column of the block's first axis word (its first column if none).
    fn first_axis_col(&self) -> u32 {
        ['x', 'y', 'z', '@', '^']
            .iter()
            .filter(|&&c| self.get(c).is_some())
            .map(|&c| self.col(c))
            .min()
            .unwrap_or(self.first_col)
    }

    fn has_axes(&self) -> bool {
        ['x', 'y', 'z', '@', '^']
            .iter()
            .any(|&c| self.get(c).is_some())
    }
    /// Sets a two-state mode from the block's G code for it, if any (the two
    /// codes share a modal group, so at most one is present).
    fn set_mode(&self, mode: &mut bool, off_code: GCode, on_code: GCode) {
        if self.has_g(on_code).is_some() {
            *mode = true;
        } else if self.has_g(off_code).is_some() {
            *mode = false;
        }
    }
}

/// LinuxCNC's RADIUS_TOLERANCE (0.00005 in = 0.00127 mm): an R arc's half
/// chord may exceed R by this much, and a shorter radius is zero.
const RADIUS_TOLERANCE_MM: f64 = 0.00127;

/// Modal group of a G code, `None` when unknown (LinuxCNC's table, keyed by
/// the code ×10).
fn g_group(code: GCode) -> Option<u8> {
    Some(match code.tenths() {
        40 | 100 | 280 | 281 | 300 | 301 | 920 | 921 | 922 | 923 => 0,
        530 => 99,
        0 | 10 | 20 | 30 | 330 | 382 | 383 | 384 | 385 | 730 | 740 | 760 | 800..=890 => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 420 | 411 | 421 => 7,
        430 | 431 | 432 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        960 | 970 => 14,
        _ => return None,
    })
}

fn m_group(code: i32) -> Option<u8> {
    Some(match code {
        0 | 1 | 2 | 30 | 60 => 4,
        // Digital and analog outputs, waiting on an input: they move nothing.
        62..=68 => 5,
        6 | 61 => 6,
        3..=5 | 19 | 70..=73 => 7,
        7 | 9 => 8,
        8 => 9,
        // Override switches: the run is simulated at 100 %.
        48..=53 => 10,
        98 | 99 => 11,
        _ => return None,
    })
}

enum Frame {
    Fanuc {
        return_pc: usize,
        start: usize,
        remaining: u32,
    },
    OSub {
        return_pc: usize,
        saved: Box<[f64; 30]>,
    },
}

/// Modal state saved by M70/M73 and restored by M72 or, after M73, on return
/// (LinuxCNC's `save_settings`/`restore_settings`; the motion mode is not restored).
#[derive(Clone, Copy)]
struct SavedModes {
    scale: f64,
    plane: Plane,
    incremental: bool,
    arc_incremental: bool,
    inverse_time: bool,
    coord: usize,
    retract_to_start: bool,
    tlo_on: bool,
    feed_mm_min: f64,
    spindle_rpm: f64,
    spindle: Spindle,
}

/// Which way the spindle turns (M3, M4; M5 and M19 stop it), as LinuxCNC's
/// `spindle_turning`: G84 needs it clockwise, G74 counterclockwise, G86 and
/// G87 turning.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Spindle {
    Stopped,
    Clockwise,
    Counterclockwise,
}

/// M70/M73 context of one call level.
#[derive(Clone, Copy)]
struct Context {
    modes: Option<SavedModes>,
    restore_on_return: bool,
}

struct Interp<'a> {
    /// What the tolerant file form accepted beyond LinuxCNC, as amendments.
    tolerated: Tolerated,
    file: &'a str,
    options: &'a Options,
    /// Shared so that executing a line needs no copy of it.
    lines: Rc<syntax::Lines>,
    /// The source `lines` were read from, to parse a block again where it
    /// runs where they keep no block's items.
    source: &'a str,
    params: Params,
    pos: [f64; 3],
    scale: f64,
    incremental: bool,
    arc_incremental: bool,
    inverse_time: bool,
    plane: Plane,
    motion: GCode,
    coord: usize,
    work: [[f64; 3]; 6],
    g92: [f64; 3],
    feed_mm_min: f64,
    spindle_rpm: f64,
    spindle: Spindle,
    retract_to_start: bool,
    cycle_r: Option<f64>,
    cycle_z: Option<f64>,
    cycle_q: Option<f64>,
    cycle_p: f64,
    /// G87's I, J and K, modal while G87 is (LinuxCNC's `cycle_i` …).
    cycle_ijk: [f64; 3],
    /// The motion mode before the block now running (LinuxCNC's
    /// `motion_mode` as a canned cycle checks it: a cycle entered from
    /// another mode needs its R, Z and, where it dwells, P words).
    previous_motion: GCode,
    /// Z (mm) where the current series of canned cycles started (G98 level).
    cycle_initial_z: Option<f64>,
    frames: Vec<Frame>,
    repeats: HashMap<usize, i64>,
    path: Path,
    trace: Vec<SegmentTrace>,
    diagnostics: Vec<Diagnostic>,
    line_index: usize,
    /// Units in force when the current block's F word was read.
    feed_scale: f64,
    /// Syntax errors by line index, reported when the line is executed (as
    /// LinuxCNC does: a bad line after M2 is never read).
    syntax_errors: HashMap<usize, SyntaxError>,
    /// Lines of the o-words of each label, ascending (linear-time lookup).
    olines: HashMap<OLabel, Vec<usize>>,
    /// Line of each Fanuc program number `O1000` (its first occurrence).
    programs: HashMap<i64, usize>,
    /// Errors found, including those not kept beyond `max_errors`.
    error_count: usize,
    /// Line and column of the first error not kept.
    first_dropped: Option<(usize, u32)>,
    /// Tool in the spindle, its gauge length (mm) and the tool selected by T.
    tool: u32,
    tool_length_mm: f64,
    selected_tool: Option<u32>,
    /// First tool loaded by M6/M61.
    first_loaded: Option<u32>,
    /// Execution stopped at a program end (M2, M30, closing '%').
    ended: bool,
    /// Active tool length offset (G43, G43.1, G43.2) in mm; `pos` is the
    /// gauge point = program + work offset + G92 + this.
    tlo_mm: [f64; 3],
    tlo_on: bool,
    /// Gauge point of the last move minus the tool length offset then in
    /// force: where LinuxCNC's canon says the machine is.
    canon_mm: [f64; 3],
    /// M6/M61 ran: the next block re-reads the position from the canon.
    toolchange_pending: bool,
    /// Where the tool tip is: the end of the last segment (the next one
    /// starts here even where the interpreter's idea of `pos` moved without
    /// motion, as after a tool change).
    last_tip: Point3<f64>,
    /// M70/M73 contexts per call level (index = frames.len()).
    contexts: Vec<Context>,
    /// Cutter radius compensation.
    comp: comp::Comp,
    /// Every line executed, in order, with the call depth it ran at
    /// (`Some` only for [`run_recorded`]).
    executed: Option<Vec<Executed>>,
    /// The path the run is expected to make, while it makes it.
    lent: Option<Lent<'a>>,
}

/// A path lent to a run ([`run_recorded_along`]): the caller's reading of
/// the same text. While each segment the run makes is the lent path's next
/// bit for bit, it is counted, not pushed; at the first that is not (or
/// before cutter compensation takes a segment's index to move its end
/// later) the segments matched so far are copied into the run's own path
/// and it goes on as any run (a million-block program's re-feed would
/// otherwise hold its path twice, 126 MB each).
#[derive(Clone, Copy)]
struct Lent<'a> {
    path: &'a [Segment],
    /// Segments made so far, each the lent path's own.
    matched: usize,
}

/// A line as executed: its 0-based index and the call depth it ran at
/// (0 in the main program, +1 per o-word or M98 call).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Executed {
    pub line_index: u32,
    pub depth: u32,
    /// Segments made before the line ran (the line made those up to the next
    /// entry's count).
    pub segments_before: u32,
}

/// Parses and runs a program ([`crate::parse`]). Without an initial tool,
/// the first tool the program loads is taken to be in the spindle from the
/// start. Its lines' items are not held through the run: each block is
/// parsed again where it runs ([`syntax::Lines::push_parsed_unkept`]), for
/// a million-block program 24 + 8 MB for its lines instead of about 200.
/// The lines are parsed twice; the result is that of a run of
/// the lines held ([`run_read_and_record`] of [`read`]).
pub(crate) fn parse(source: &str, file: &str, options: &Options) -> Parsed {
    let read = read_lines(source, file, options, false);
    run_read_and_record(&read, source, file, options, false, None).0
}

/// [`parse`], with the trace of a recorded run and every line executed in
/// the order it ran (for unrolling loops). The trace's lines keep no
/// block's items: [`syntax::Lines::block_items`] with `source` gives them.
pub fn run_recorded(source: &str, file: &str, options: &Options) -> (Parsed, Trace, Vec<Executed>) {
    let read = read_lines(source, file, options, false);
    run_read_and_record(&read, source, file, options, true, None)
}

/// [`run_recorded`] lent the path the caller read the same text to
/// (`path`): where the run makes that path bit for bit
/// ([`Trace::on_lent_path`]) the returned [`Parsed::path`] holds no
/// segments, and the path is `path`; otherwise it holds the run's own, as
/// [`run_recorded`] returns it.
pub fn run_recorded_along(
    source: &str,
    file: &str,
    options: &Options,
    path: &[Segment],
) -> (Parsed, Trace, Vec<Executed>) {
    let read = read_lines(source, file, options, false);
    run_read_and_record(&read, source, file, options, true, Some(path))
}

/// A run of a program already read (its lines parsed once, or where `read`
/// keeps no block's items, again from `source`, the text it read).
pub(crate) fn run_read_and_record(
    read: &Read,
    source: &str,
    file: &str,
    options: &Options,
    record: bool,
    lent: Option<&[Segment]>,
) -> (Parsed, Trace, Vec<Executed>) {
    let (parsed, trace, first, executed) = run_read(read, source, file, options, record, lent);
    match (options.initial_tool, first) {
        (None, Some(tool)) if tool != 0 => {
            // Dropped before the run again: one path at a time.
            drop((parsed, trace, executed));
            let options = Options {
                initial_tool: Some(tool),
                ..options.clone()
            };
            let (parsed, trace, _, executed) = run_read(read, source, file, &options, record, lent);
            (parsed, trace, executed)
        }
        _ => (parsed, trace, executed),
    }
}

/// A program's lines as read before it runs, and what reading them found:
/// the same for every run of the program whatever its start.
#[derive(Clone)]
pub(crate) struct Read {
    lines: Rc<syntax::Lines>,
    olines: HashMap<OLabel, Vec<usize>>,
    programs: HashMap<i64, usize>,
    syntax_errors: HashMap<usize, SyntaxError>,
    tolerated: Tolerated,
    diagnostics: Vec<Diagnostic>,
}

/// A fresh interpreter at the start `options` give.
fn interp<'a>(file: &'a str, options: &'a Options, record: bool) -> Interp<'a> {
    let tool = options.initial_tool.unwrap_or(0);
    let tool_length_mm = options.tool_lengths_mm.get(&tool).copied().unwrap_or(0.0);
    let mut pos = options.initial_position_mm;
    pos[2] += tool_length_mm;
    Interp {
        tolerated: Tolerated::default(),
        file,
        options,
        lines: Rc::default(),
        source: "",
        params: Params::default(),
        pos,
        scale: 1.0,
        incremental: false,
        arc_incremental: true,
        inverse_time: false,
        plane: Plane::XY,
        motion: GCode::G80,
        coord: 0,
        work: options.work_offsets_mm,
        g92: [0.0; 3],
        feed_mm_min: 0.0,
        spindle_rpm: 0.0,
        spindle: Spindle::Stopped,
        retract_to_start: false,
        cycle_r: None,
        cycle_z: None,
        cycle_q: None,
        cycle_p: 0.0,
        cycle_ijk: [0.0; 3],
        previous_motion: GCode::G80,
        cycle_initial_z: None,
        frames: Vec::new(),
        repeats: HashMap::new(),
        path: Path::default(),
        trace: Vec::new(),
        diagnostics: Vec::new(),
        line_index: 0,
        feed_scale: 1.0,
        syntax_errors: HashMap::new(),
        olines: HashMap::new(),
        programs: HashMap::new(),
        error_count: 0,
        first_dropped: None,
        tool,
        tool_length_mm,
        selected_tool: None,
        first_loaded: None,
        ended: false,
        tlo_mm: [0.0; 3],
        tlo_on: false,
        canon_mm: pos,
        toolchange_pending: false,
        last_tip: Point3::from(options.initial_position_mm),
        contexts: vec![Context {
            modes: None,
            restore_on_return: false,
        }],
        comp: comp::Comp {
            first: true,
            ..comp::Comp::default()
        },
        executed: record.then(Vec::new),
        lent: None,
    }
}

/// Reads every line of `source` (syntax, the tolerant form's amendments, o-word labels).
pub(crate) fn read(source: &str, file: &str, options: &Options) -> Read {
    read_lines(source, file, options, true)
}

/// [`read`]; where `keep` is false, a block's items are not kept (the line is
/// parsed again from the source where it runs); a line the tolerant form
/// mended keeps its items, which are not the source's.
fn read_lines(source: &str, file: &str, options: &Options, keep: bool) -> Read {
    let mut it = interp(file, options, false);
    let whole = source;
    let source = match source.strip_prefix(BYTE_ORDER_MARK) {
        Some(rest) if options.file_form == FileForm::Tolerant => {
            it.tolerated.amendments.push(Amendment::DropByteOrderMark);
            it.warn(
                1,
                "UTF-8 byte-order mark before the first line skipped (LinuxCNC would refuse the file)"
                    .into(),
            );
            rest
        }
        _ => source,
    };
    let mut lines = syntax::Lines::default();
    for (i, (text, _)) in syntax::split_lines(source).enumerate() {
        let start = text.as_ptr() as usize - whole.as_ptr() as usize;
        let pushed = if keep {
            lines.push_parsed(text)
        } else {
            lines.push_parsed_unkept(text, start)
        };
        let e = match pushed {
            Ok(()) => {
                match lines.last().and_then(Option::as_ref).map(|l| &l.kind) {
                    Some(LineKind::OWord(stmt)) => {
                        it.olines.entry(stmt.label.clone()).or_default().push(i)
                    }
                    Some(LineKind::ProgramNumber(n)) => {
                        it.programs.entry(*n).or_insert(i);
                    }
                    _ => {}
                }
                continue;
            }
            Err(e) => e,
        };
        // Parentheses nested in a comment that closes on the line, or
        // a GRBL system command that neither moves nor sets anything.
        let fixed = (options.file_form == FileForm::Tolerant)
            .then(|| {
                amend::flatten_nested_comments(text)
                    .map(|(fixed, col)| (fixed, col, "parentheses nested in a comment read as one comment, written as [ ]".to_owned()))
                    .or_else(|| {
                        amend::comment_grbl_system_command(text).map(|(fixed, col)| {
                            (fixed, col, "GRBL system command skipped, as GRBL runs it outside the program (it neither moves the machine nor changes how the program reads); written as a comment".to_owned())
                        })
                    })
            })
            .flatten()
            .filter(|(fixed, _, _)| lines.push_parsed(fixed).is_ok());
        if !keep {
            lines.push_start(start);
        }
        match fixed {
            Some((fixed, col, what)) => {
                it.line_index = i;
                let start = fixed
                    .bytes()
                    .zip(text.bytes())
                    .position(|(a, b)| a != b)
                    .unwrap_or(0);
                // The common tail, not reaching back past `start`.
                let tail = fixed
                    .bytes()
                    .rev()
                    .zip(text.bytes().rev())
                    .take(fixed.len().min(text.len()) - start)
                    .take_while(|(a, b)| a == b)
                    .count();
                it.tolerate(
                    start..text.len() - tail,
                    fixed[start..fixed.len() - tail].to_owned(),
                    col,
                    what,
                );
            }
            None => {
                it.syntax_errors.insert(i, e);
                lines.push_error();
            }
        }
    }
    lines.shrink_to_fit();
    Read {
        lines: Rc::new(lines),
        olines: it.olines,
        programs: it.programs,
        syntax_errors: it.syntax_errors,
        tolerated: it.tolerated,
        diagnostics: it.diagnostics,
    }
}

/// Runs a program read by [`read`] (with the same file form) from the start `options` give.
pub(crate) fn run_read(
    read: &Read,
    source: &str,
    file: &str,
    options: &Options,
    record: bool,
    lent: Option<&[Segment]>,
) -> (Parsed, Trace, Option<u32>, Vec<Executed>) {
    let mut it = interp(file, options, record);
    it.lent = lent.map(|path| Lent { path, matched: 0 });
    it.lines = Rc::clone(&read.lines);
    it.source = source;
    it.olines = read.olines.clone();
    it.programs = read.programs.clone();
    it.syntax_errors = read.syntax_errors.clone();
    it.tolerated = read.tolerated.clone();
    it.diagnostics = read.diagnostics.clone();
    it.execute();
    if let Some((line, col)) = it.first_dropped {
        let more = it.error_count - it.options.max_errors;
        it.diagnostics.push(Diagnostic {
            file: it.file.to_owned(),
            line: line as u32 + 1,
            column: col.max(1),
            message: format!(
                "and {more} more error{} (only the first {} are listed)",
                if more == 1 { "" } else { "s" },
                it.options.max_errors
            ),
            severity: Severity::Error,
        });
    }
    // The lent path is the run's only where the run made all of it.
    let on_lent_path = it.lent.is_some_and(|l| l.matched == l.path.len());
    if !on_lent_path {
        it.own_path();
    }
    // The path is held as long as its program runs: not at the capacity its
    // pushes grew it to, up to twice its segments (125.8 MB for a million
    // segments of 120 B, not 120.0).
    it.path.segments.shrink_to_fit();
    let trace = Trace {
        segments: it.trace,
        lines: it.lines,
        on_lent_path,
    };
    (
        Parsed {
            path: it.path,
            diagnostics: it.diagnostics,
            has_program_end: it.ended,
            amendments: it.tolerated.amendments,
        },
        trace,
        it.first_loaded,
        it.executed.unwrap_or_default(),
    )
}

/// What the tolerant file form read beyond LinuxCNC ([`FileForm::Tolerant`]).
#[derive(Clone, Default)]
struct Tolerated {
    amendments: Vec<Amendment>,
    /// (line, byte) of every edit made, each made and warned of once.
    edited: std::collections::HashSet<(usize, usize)>,
    /// The last G0/G1/G2/G3 mode set: what a Fanuc-style control moves in
    /// after G80.
    plain_motion: Option<GCode>,
    /// A G2 or G3 read alone on its line, dropped there: written on the next
    /// block that moves in it.
    lone_arc: Option<GCode>,
}

impl Interp<'_> {
    /// In the tolerant file form, reads what LinuxCNC refuses by editing the
    /// line (once per line and place), with a warning; else `false`.
    fn tolerate(
        &mut self,
        range: std::ops::Range<usize>,
        text: String,
        col: u32,
        what: String,
    ) -> bool {
        if self.options.file_form != FileForm::Tolerant {
            return false;
        }
        if self.tolerated.edited.insert((self.line_index, range.start)) {
            self.tolerated.amendments.push(Amendment::Edit {
                line_index: self.line_index,
                range,
                text,
            });
            self.warn(col, format!("{what} (LinuxCNC would refuse the line)"));
        }
        true
    }

    /// Byte range of the item of line `pc` at column `col`.
    fn item_span(&self, pc: usize, col: u32) -> Option<std::ops::Range<usize>> {
        self.lines.get(pc)?;
        self.lines
            .block_items(pc, self.source, &mut Vec::new())?
            .iter()
            .find(|i| i.col == col)
            .map(|i| i.span())
    }

    fn report(&mut self, col: u32, message: String) {
        self.error_count += 1;
        if self.error_count > self.options.max_errors {
            self.first_dropped.get_or_insert((self.line_index, col));
            return;
        }
        self.push_diagnostic(col, message, Severity::Error);
    }

    /// A warning: the program is read, but the user should know.
    fn warn(&mut self, col: u32, message: String) {
        self.push_diagnostic(col, message, Severity::Warning);
    }

    /// A diagnostic at column `col` of the line being read.
    fn push_diagnostic(&mut self, col: u32, message: String, severity: Severity) {
        self.diagnostics.push(Diagnostic {
            file: self.file.to_owned(),
            line: self.line_index as u32 + 1,
            column: col.max(1),
            message,
            severity,
        });
    }

    fn execute(&mut self) {
        let mut pc = 0usize;
        let mut executed = 0u64;
        let mut seen_percent = false;
        let lines = Rc::clone(&self.lines);
        // A block's items parsed again where they are not kept.
        let mut again = Vec::new();
        while pc < lines.len() {
            executed += 1;
            if executed > self.options.max_blocks {
                self.line_index = pc;
                self.report(
                    1,
                    format!(
                        "more than {} blocks executed; endless loop?",
                        self.options.max_blocks
                    ),
                );
                return;
            }
            if self.segment_count() > self.options.max_segments {
                self.report(
                    1,
                    format!(
                        "the program makes more than {} moves (the limit)",
                        self.options.max_segments
                    ),
                );
                return;
            }
            self.line_index = pc;
            if self.toolchange_pending {
                // LinuxCNC's refresh_actual_position after a tool change:
                // the program point is the canon's, which ignores a tool
                // length offset changed since the last move (rs274 does so).
                self.toolchange_pending = false;
                self.pos = std::array::from_fn(|i| self.canon_mm[i] + self.tlo_mm[i]);
            }
            let Some(line) = &lines[pc] else {
                if let Some(e) = self.syntax_errors.get(&pc) {
                    let e = e.clone();
                    self.report(e.col, e.message);
                }
                pc += 1;
                continue;
            };
            if line.block_delete && self.options.block_delete {
                pc += 1;
                continue;
            }
            let segments_before = self.segment_count() as u32;
            if let Some(executed) = &mut self.executed {
                executed.push(Executed {
                    line_index: pc as u32,
                    depth: self.frames.len() as u32,
                    segments_before,
                });
            }
            let next = match &line.kind {
                LineKind::Empty | LineKind::ProgramNumber(_) => Ok(Some(pc + 1)),
                // As LinuxCNC: '%' opens a program on the first line and
                // then closes it; anywhere else it is an error.
                LineKind::Percent if seen_percent => Ok(None),
                LineKind::Percent if pc == 0 => {
                    seen_percent = true;
                    Ok(Some(pc + 1))
                }
                LineKind::Percent => Err(Fail {
                    col: 1,
                    msg: "'%' is allowed only on the first line and to close a program opened with it".into(),
                }),
                LineKind::OWord(stmt) => self.oword(pc, stmt),
                LineKind::Block(_) => {
                    let items = lines.block_items(pc, self.source, &mut again);
                    self.block(pc, items.expect("a block's items"))
                }
            };
            match next {
                Ok(Some(n)) => pc = n,
                Ok(None) => {
                    self.ended = true;
                    return;
                }
                Err(f) => {
                    self.report(f.col, f.msg);
                    pc += 1;
                }
            }
        }
        // As LinuxCNC: a program ends with M2, M30 or a closing '%'.
        self.line_index = lines.len().saturating_sub(1);
        match self.options.file_form {
            FileForm::Fragment => {}
            FileForm::LinuxCnc => self.report(
                1,
                "file ended with no program end (M2 or M30) or closing '%'".into(),
            ),
            FileForm::Tolerant => {
                self.tolerated.amendments.push(Amendment::AppendProgramEnd);
                self.warn(
                    1,
                    "file ended with no program end (M2 or M30) or closing '%': the program ends at its last line (LinuxCNC would refuse the file)".into(),
                )
            }
        }
    }

    /// Finds the next (or previous) o-word with `label` and one of `keywords`.
    fn find_o(
        &self,
        from: usize,
        label: &OLabel,
        keywords: &[OKeyword],
        forward: bool,
    ) -> Option<usize> {
        let matches = |i: &usize| {
            matches!(&self.lines[*i], Some(syntax::Line { kind: LineKind::OWord(s), .. })
                if keywords.contains(&s.keyword))
        };
        let at = self.olines.get(label)?;
        if forward {
            let k = at.partition_point(|&i| i <= from);
            at[k..].iter().copied().find(matches)
        } else {
            let k = at.partition_point(|&i| i < from);
            at[..k].iter().rev().copied().find(matches)
        }
    }

    fn cond(&self, stmt: &OStmt) -> Result<bool, Fail> {
        let e = stmt.args.first().ok_or(Fail {
            col: stmt.col,
            msg: "missing [condition]".into(),
        })?;
        Ok(self
            .params
            .eval(e)
            .map_err(|msg| Fail { col: stmt.col, msg })?
            != 0.0)
    }

    fn oword(&mut self, pc: usize, s: &OStmt) -> Result<Option<usize>, Fail> {
        use OKeyword as K;
        let missing = |what: &str| Fail {
            col: s.col,
            msg: format!("no matching '{what}' for this o-word"),
        };
        let after =
            |r: Option<usize>, what: &str| r.map(|i| Some(i + 1)).ok_or_else(|| missing(what));
        match s.keyword {
            K::Sub => after(self.find_o(pc, &s.label, &[K::EndSub], true), "endsub"),
            K::EndSub | K::Return => match self.frames.pop() {
                Some(Frame::OSub { return_pc, saved }) => {
                    if let Some(e) = s.args.first() {
                        let v = self
                            .params
                            .eval(e)
                            .map_err(|msg| Fail { col: s.col, msg })?;
                        self.params.pop_scope(&saved);
                        self.params.set_named("_value", v);
                    } else {
                        self.params.pop_scope(&saved);
                    }
                    self.leave_call_level();
                    Ok(Some(return_pc))
                }
                Some(other) => {
                    self.frames.push(other);
                    fail(s.col, "endsub/return inside an M98 subprogram")
                }
                None => fail(s.col, "endsub/return outside a subroutine"),
            },
            K::Call => {
                let start = self
                    .olines
                    .get(&s.label)
                    .and_then(|at| {
                        at.iter().copied().find(|&i| {
                            matches!(&self.lines[i], Some(syntax::Line { kind: LineKind::OWord(d), .. })
                                if d.keyword == K::Sub)
                        })
                    })
                    .ok_or_else(|| Fail {
                        col: s.col,
                        msg: "called subroutine is not defined".into(),
                    })?;
                if self.frames.len() >= 64 {
                    return fail(s.col, "subroutine calls nested too deeply");
                }
                let args = s
                    .args
                    .iter()
                    .map(|e| self.params.eval(e))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|msg| Fail { col: s.col, msg })?;
                let saved = self.params.push_scope(&args);
                self.frames.push(Frame::OSub {
                    return_pc: pc + 1,
                    saved: Box::new(saved),
                });
                self.enter_call_level();
                Ok(Some(start + 1))
            }
            K::If => {
                let mut i = pc;
                let mut stmt = s;
                loop {
                    if self.cond(stmt)? {
                        return Ok(Some(i + 1));
                    }
                    i = self
                        .find_o(i, &s.label, &[K::ElseIf, K::Else, K::EndIf], true)
                        .ok_or_else(|| missing("endif"))?;
                    match &self.lines[i] {
                        Some(syntax::Line {
                            kind: LineKind::OWord(next),
                            ..
                        }) if next.keyword == K::ElseIf => stmt = next,
                        _ => return Ok(Some(i + 1)),
                    }
                }
            }
            K::ElseIf | K::Else => after(self.find_o(pc, &s.label, &[K::EndIf], true), "endif"),
            K::EndIf | K::Do => Ok(Some(pc + 1)),
            K::While => {
                let end = self.find_o(pc, &s.label, &[K::EndWhile], true);
                match end {
                    Some(end) => Ok(Some(if self.cond(s)? { pc + 1 } else { end + 1 })),
                    None => {
                        let d = self
                            .find_o(pc, &s.label, &[K::Do], false)
                            .ok_or_else(|| missing("endwhile"))?;
                        Ok(Some(if self.cond(s)? { d + 1 } else { pc + 1 }))
                    }
                }
            }
            K::EndWhile => self
                .find_o(pc, &s.label, &[K::While], false)
                .map(Some)
                .ok_or_else(|| missing("while")),
            K::Repeat => {
                let e = s.args.first().ok_or(Fail {
                    col: s.col,
                    msg: "missing [count]".into(),
                })?;
                let n = self
                    .params
                    .eval(e)
                    .map_err(|msg| Fail { col: s.col, msg })?
                    .round() as i64;
                if n > 0 {
                    self.repeats.insert(pc, n);
                    Ok(Some(pc + 1))
                } else {
                    after(
                        self.find_o(pc, &s.label, &[K::EndRepeat], true),
                        "endrepeat",
                    )
                }
            }
            K::EndRepeat => {
                let start = self
                    .find_o(pc, &s.label, &[K::Repeat], false)
                    .ok_or_else(|| missing("repeat"))?;
                let left = self.repeats.entry(start).or_insert(1);
                *left -= 1;
                Ok(Some(if *left > 0 { start + 1 } else { pc + 1 }))
            }
            K::Break => {
                let end = self
                    .find_o(pc, &s.label, &[K::EndWhile, K::EndRepeat, K::While], true)
                    .ok_or_else(|| missing("endwhile/endrepeat"))?;
                Ok(Some(end + 1))
            }
            K::Continue => {
                if let Some(w) = self.find_o(pc, &s.label, &[K::While, K::Repeat], false) {
                    if matches!(&self.lines[w], Some(syntax::Line { kind: LineKind::OWord(t), .. }) if t.keyword == K::While)
                    {
                        return Ok(Some(w));
                    }
                }
                self.find_o(pc, &s.label, &[K::EndRepeat, K::While], true)
                    .map(Some)
                    .ok_or_else(|| missing("loop end"))
            }
        }
    }

    fn eval_block(&mut self, items: &[Item]) -> Result<Block, Fail> {
        let mut b = Block {
            first_col: items.first().map_or(1, |i| i.col),
            ..Block::default()
        };
        let mut assignments = Vec::new();
        for item in items {
            let err = |msg| Fail { col: item.col, msg };
            match &item.kind {
                ItemKind::Assign(assign) => {
                    let (target, value) = &**assign;
                    let t = self.params.resolve(target).map_err(err)?;
                    let v = self.params.eval(value).map_err(err)?;
                    assignments.push((t, v));
                }
                ItemKind::Word { letter, value } => {
                    let v = self.params.eval(value).map_err(err)?;
                    match letter {
                        'g' => {
                            let Some(code) = GCode::from_value(v) else {
                                return fail(item.col, format!("G{v} is not a valid code"));
                            };
                            b.g.push((code, item.col));
                        }
                        'm' => {
                            let Some(code) = integer_value(v).filter(|c| c.abs() <= 100_000) else {
                                return fail(item.col, format!("M{v} is not a valid code"));
                            };
                            b.m.push((code as i32, item.col));
                        }
                        l => {
                            // LinuxCNC reads T, H and L words as whole numbers.
                            let v = match l {
                                't' | 'h' | 'l' => match integer_value(v) {
                                    Some(n) => n as f64,
                                    None => {
                                        return fail(
                                            item.col,
                                            format!(
                                                "{}{v} is not a whole number",
                                                l.to_ascii_uppercase()
                                            ),
                                        )
                                    }
                                },
                                _ => v,
                            };
                            let slot = &mut b.words[slot(*l)];
                            if slot.is_some() {
                                return fail(
                                    item.col,
                                    format!(
                                        "more than one {} word in the block",
                                        l.to_ascii_uppercase()
                                    ),
                                );
                            }
                            *slot = Some((v, item.col));
                        }
                    }
                }
            }
        }
        for &(code, col) in &b.g {
            if g_group(code).is_none() {
                return fail(col, format!("unknown G code {code}"));
            }
        }
        // As in LinuxCNC, G80 gives way to another motion code in the block.
        if b.g
            .iter()
            .any(|g| g_group(g.0) == Some(1) && g.0 != GCode::G80)
        {
            b.g.retain(|g| g.0 != GCode::G80);
        } else if let Some(i) = b.g.iter().position(|g| g.0 == GCode::G80) {
            let mut k = 0;
            b.g.retain(|g| {
                k += 1;
                g.0 != GCode::G80 || k - 1 == i
            });
        }
        for (i, &(code, col)) in b.g.iter().enumerate() {
            let group = g_group(code);
            if let Some(&(other, _)) = b.g[..i].iter().find(|g| g_group(g.0) == group) {
                return fail(
                    col,
                    format!("{other} and {code} are in the same modal group"),
                );
            }
        }
        for (i, &(code, col)) in b.m.iter().enumerate() {
            let Some(group) = m_group(code) else {
                return fail(col, format!("unknown M code M{code}"));
            };
            if b.m[..i].iter().any(|m| m_group(m.0) == Some(group)) {
                return fail(
                    col,
                    format!("two M codes of the same modal group (M{code})"),
                );
            }
        }
        // The other axes start at 0; a word of 0 keeps one there in every
        // distance mode and offset (only 0 is read anywhere), so it moves
        // nothing: 4-axis posts park the rotary with it (Mastercam's
        // `G0 G90 G54 X… Y… A0.`). Any other value would move it.
        for l in ['a', 'b', 'c', 'u', 'v', 'w'] {
            if b.get(l).is_some_and(|v| v != 0.0) {
                return fail(
                    b.col(l),
                    format!(
                        "axis {} is not supported (3-axis X Y Z only; {}0, which keeps it at 0, is read)",
                        l.to_ascii_uppercase(),
                        l.to_ascii_uppercase()
                    ),
                );
            }
        }
        if b.get('e').is_some() && !(66..=68).any(|m| b.has_m(m)) {
            return fail(b.col('e'), "E word with no M66, M67 or M68 to use it");
        }
        for (t, v) in assignments {
            self.params.assign(&t, v);
        }
        Ok(b)
    }

    fn block(&mut self, pc: usize, items: &[Item]) -> Result<Option<usize>, Fail> {
        let b = self.eval_block(items)?;
        self.feed_scale = self.scale;
        let g_col = |code| b.has_g(code);
        // Feed mode, feed, speed, tool, spindle.
        if let Some(col) = g_col(GCode::G95) {
            return fail(col, "G95 feed per revolution is not supported");
        }
        b.set_mode(&mut self.inverse_time, GCode::G94, GCode::G93);
        if let Some(f) = b.get('f') {
            if f < 0.0 {
                return fail(b.col('f'), "negative feed rate");
            }
            if !self.inverse_time {
                self.feed_mm_min = f * self.scale;
            }
        }
        if let Some(s) = b.get('s') {
            if s < 0.0 {
                return fail(b.col('s'), "negative spindle speed");
            }
            self.spindle_rpm = s;
        }
        if let Some(t) = b.get('t') {
            self.selected_tool = Some(self.tool_number(t, b.col('t'), 'T')?);
        }
        if (b.has_m(6) || b.has_m(61)) && self.comp.side.is_some() {
            return fail(
                b.first_col,
                "cannot change tools with cutter radius compensation on",
            );
        }
        if b.has_m(6) {
            self.load_tool(self.selected_tool.unwrap_or(self.tool), pc);
        }
        if b.has_m(61) {
            let q = b.get('q').ok_or(Fail {
                col: b.first_col,
                msg: "M61 needs a Q word (tool number)".into(),
            })?;
            // LinuxCNC rounds M61's Q to the nearest whole number (round_to_int).
            let t = self.tool_number(q.round_ties_even(), b.col('q'), 'Q')?;
            self.load_tool(t, pc);
        }
        if b.has_m(3) {
            self.spindle = Spindle::Clockwise;
        }
        if b.has_m(4) {
            self.spindle = Spindle::Counterclockwise;
        }
        // M19 orients the spindle: it stops turning until the next M3 or M4.
        if b.has_m(5) || b.has_m(19) {
            self.spindle = Spindle::Stopped;
        }
        self.inputs_and_outputs(&b)?;
        self.m70_m73(&b)?;
        if let Some(col) = g_col(GCode::G4) {
            let p = b.get('p').ok_or(Fail {
                col,
                msg: "G4 needs a P word (seconds)".into(),
            })?;
            if p < 0.0 {
                return fail(b.col('p'), "negative dwell time");
            }
            self.push(
                self.pos,
                Geometry::Line,
                Motion::Dwell { seconds: p },
                pc,
                true,
            );
        }
        for (code, plane) in [
            (GCode::G17, Plane::XY),
            (GCode::G18, Plane::ZX),
            (GCode::G19, Plane::YZ),
        ] {
            if g_col(code).is_some() {
                self.plane = plane;
            }
        }
        if g_col(GCode::G20).is_some() {
            self.scale = 25.4;
        }
        if g_col(GCode::G21).is_some() {
            self.scale = 1.0;
        }
        if g_col(GCode::G40).is_some() {
            self.comp_off()?;
        }
        let comp_code = [GCode::G41, GCode::G42, GCode::G41_1, GCode::G42_1]
            .into_iter()
            .find_map(|c| g_col(c).map(|col| (c, col)));
        match comp_code {
            Some((code, col)) => self.comp_on(code, &b, col)?,
            None if b.get('d').is_some() => {
                return fail(b.col('d'), "D word with no G41 or G42 to use it")
            }
            None => {}
        }
        self.tool_length_offset(&b)?;
        for (i, code) in [
            GCode::G54,
            GCode::G55,
            GCode::G56,
            GCode::G57,
            GCode::G58,
            GCode::G59,
        ]
        .into_iter()
        .enumerate()
        {
            if g_col(code).is_some() {
                self.coord = i;
            }
        }
        for code in [
            GCode::G59_1,
            GCode::G59_2,
            GCode::G59_3,
            GCode::G96,
            GCode::G33,
            GCode::G38_2,
            GCode::G38_3,
            GCode::G38_4,
            GCode::G38_5,
            GCode::G76,
            GCode::G88,
            GCode::G92_2,
            GCode::G92_3,
            GCode::G28_1,
            GCode::G30_1,
        ] {
            if let Some(col) = g_col(code) {
                return fail(col, format!("{code} is not supported"));
            }
        }
        b.set_mode(&mut self.incremental, GCode::G90, GCode::G91);
        b.set_mode(&mut self.arc_incremental, GCode::G90_1, GCode::G91_1);
        b.set_mode(&mut self.retract_to_start, GCode::G99, GCode::G98);
        // Non-modal group 0.
        let axis_user = b.g.iter().find(|g| {
            matches!(
                g.0,
                GCode::G10 | GCode::G28 | GCode::G30 | GCode::G92 | GCode::G43_1 | GCode::G43_2
            )
        });
        let motion_code = b.g.iter().find(|g| g_group(g.0) == Some(1)).copied();
        // As LinuxCNC (its check_other_codes): a P, Q, L or R word needs
        // something in the block to use it (Snapmaker's `M3 P100`, a spindle
        // power in percent, is refused there and by GRBL; a stray word would
        // make the written program one the control refuses). The motion it
        // would serve is the block's own, or the modal one when the block
        // has axis words.
        let motion = motion_code
            .map(|m| m.0)
            .or(b.has_axes().then_some(self.motion));
        let cycle = motion.is_some_and(GCode::is_canned_cycle);
        let in_block = |codes: &[GCode]| codes.iter().any(|&g| g_col(g).is_some());
        let m_in = |used: fn(i32) -> bool| b.m.iter().any(|m| used(m.0));
        let words = [
            (
                'p',
                matches!(
                    motion,
                    Some(
                        GCode::G2
                            | GCode::G3
                            | GCode::G74
                            | GCode::G82
                            | GCode::G84
                            | GCode::G86
                            | GCode::G89
                    )
                )
                    || in_block(&[GCode::G4, GCode::G10, GCode::G64])
                    || m_in(|m| matches!(m, 19 | 50..=53 | 62..=66 | 98)),
                "P word with no G2, G3, G4, G10, G64, G74, G82, G84, G86, G89, M19, M50-M53, M62-M66 or M98 to use it",
            ),
            (
                'q',
                matches!(motion, Some(GCode::G73 | GCode::G83))
                    || in_block(&[GCode::G10, GCode::G64])
                    || m_in(|m| matches!(m, 19 | 61 | 66..=68)),
                "Q word with no G10, G64, G73, G83, M19, M61, M66, M67 or M68 to use it",
            ),
            (
                'l',
                cycle
                    || in_block(&[GCode::G10, GCode::G41, GCode::G41_1, GCode::G42, GCode::G42_1])
                    || m_in(|m| matches!(m, 66 | 98)),
                "L word with no G10, cutter compensation, canned cycle, M66 or M98 to use it",
            ),
            (
                'r',
                matches!(motion, Some(GCode::G2 | GCode::G3))
                    || cycle
                    || in_block(&[GCode::G10])
                    || m_in(|m| m == 19),
                "R word with no G2, G3, G10, canned cycle or M19 to use it",
            ),
        ];
        if let Some(&(letter, _, message)) = words
            .iter()
            .find(|&&(letter, used, _)| b.get(letter).is_some() && !used)
        {
            return fail(b.col(letter), message);
        }
        if let (Some(&(a, col)), Some((m, _))) = (axis_user, motion_code) {
            if m != GCode::G80 && b.has_axes() {
                return fail(col, format!("{a} and {m} both use axis words"));
            }
        }
        if let Some(&(code, col)) =
            axis_user.filter(|g| !matches!(g.0, GCode::G43_1 | GCode::G43_2))
        {
            self.modal0(code, col, &b, pc)?;
        } else if g_col(GCode::G92_1).is_some() {
            self.g92 = [0.0; 3];
        }
        self.previous_motion = self.motion;
        if let Some((code, _)) = motion_code {
            self.motion = code;
            self.tolerated.lone_arc = None;
            if matches!(code, GCode::G0 | GCode::G1 | GCode::G2 | GCode::G3) {
                self.tolerated.plain_motion = Some(code);
            }
            if !code.is_canned_cycle() {
                self.cycle_initial_z = None;
            }
        }
        let use_motion = axis_user.is_none() && (motion_code.is_some() || b.has_axes());
        if use_motion {
            if self.motion == GCode::G80 && b.has_axes() {
                self.axis_words_after_g80(&b, pc)?;
            }
            if self.motion == GCode::G80 {
                self.cycle_r = None;
                self.cycle_z = None;
            } else if let Some((code, _)) = motion_code.filter(|_| self.lone_arc_mode(&b, pc)) {
                // Nothing moves: the arc mode waits for the next axis words.
                self.tolerated.lone_arc = Some(code);
            } else if b.has_axes() || matches!(self.motion, GCode::G2 | GCode::G3) {
                if motion_code.is_none() {
                    self.arc_mode_written_here(&b, pc);
                }
                self.motion_block(&b, pc)?;
            }
        }
        if !matches!(self.motion, GCode::G2 | GCode::G3 | GCode::G87) || !use_motion {
            for l in ['i', 'j', 'k'] {
                if b.get(l).is_some() {
                    return fail(
                        b.col(l),
                        format!(
                            "{} word with no G2, G3 or G87 to use it",
                            l.to_ascii_uppercase()
                        ),
                    );
                }
            }
        }
        // Stop and flow.
        if b.has_m(2) || b.has_m(30) {
            return Ok(None);
        }
        if b.has_m(98) {
            let p = b.get('p').ok_or(Fail {
                col: b.first_col,
                msg: "M98 needs a P word (program number)".into(),
            })?;
            let l = b.get('l').unwrap_or(1.0);
            if l < 1.0 || l.fract() != 0.0 || l > 1e6 {
                return fail(
                    b.col('l'),
                    "L repeat count must be an integer from 1 to 1000000",
                );
            }
            let target = integer_value(p).ok_or(Fail {
                col: b.col('p'),
                msg: format!("M98 P{p} is not a program number (a whole number)"),
            })?;
            let start = *self.programs.get(&target).ok_or(Fail {
                col: b.col('p'),
                msg: format!("subprogram O{target} not found"),
            })?;
            if self.frames.len() >= 64 {
                return fail(b.first_col, "subprogram calls nested too deeply");
            }
            self.frames.push(Frame::Fanuc {
                return_pc: pc + 1,
                start,
                remaining: l as u32 - 1,
            });
            self.enter_call_level();
            return Ok(Some(start + 1));
        }
        if b.has_m(99) {
            return match self.frames.pop() {
                Some(Frame::Fanuc {
                    return_pc,
                    start,
                    remaining,
                }) => {
                    if remaining > 0 {
                        self.frames.push(Frame::Fanuc {
                            return_pc,
                            start,
                            remaining: remaining - 1,
                        });
                        Ok(Some(start + 1))
                    } else {
                        self.leave_call_level();
                        Ok(Some(return_pc))
                    }
                }
                Some(other) => {
                    self.frames.push(other);
                    fail(b.first_col, "M99 inside an o-word subroutine")
                }
                None => Ok(None),
            };
        }
        Ok(Some(pc + 1))
    }

    /// Work offset + G92 + tool length offset (mm): gauge point = program·scale + this.
    fn offset(&self) -> [f64; 3] {
        let w = self.work[self.coord];
        std::array::from_fn(|i| w[i] + self.g92[i] + self.tlo_mm[i])
    }

    /// Target of the block's axis words (mm, machine frame, gauge point),
    /// polar `@` radius and `^` angle (degrees) included, as LinuxCNC's
    /// `find_ends`: about the program origin, incremental ones from the
    /// current point's polar coordinates.
    fn target(&self, b: &Block, machine: bool) -> Result<[f64; 3], Fail> {
        let off = self.offset();
        // Under compensation, words not given keep the programmed point.
        let base = if self.comp_active() && !self.comp.first {
            [self.comp.program[0], self.comp.program[1], self.pos[2]]
        } else {
            self.pos
        };
        let mut t = base;
        for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
            if let Some(v) = b.get(l) {
                t[i] = if machine {
                    v * self.scale
                } else if self.incremental {
                    base[i] + v * self.scale
                } else {
                    v * self.scale + off[i]
                };
            }
        }
        let (radius, theta) = (b.get('@'), b.get('^'));
        if radius.is_none() && theta.is_none() {
            return Ok(t);
        }
        let col = b.col(if radius.is_some() { '@' } else { '^' });
        if machine {
            return fail(col, "cannot use polar coordinates with G53");
        }
        if b.get('x').is_some() || b.get('y').is_some() {
            return fail(col, "cannot specify X or Y words with polar coordinates");
        }
        // Current point in program units about the program origin.
        let (px, py) = (
            (base[0] - off[0]) / self.scale,
            (base[1] - off[1]) / self.scale,
        );
        let (r, a) = if self.incremental {
            if px == 0.0 && py == 0.0 {
                return fail(
                    col,
                    "incremental polar motion is indeterminate at the origin",
                );
            }
            (
                px.hypot(py) + radius.unwrap_or(0.0),
                py.atan2(px) + theta.unwrap_or(0.0).to_radians(),
            )
        } else {
            let a = match theta {
                Some(deg) => deg.to_radians(),
                None if px == 0.0 && py == 0.0 => {
                    return fail(col, "polar radius at the origin needs an angle (^)")
                }
                None => py.atan2(px),
            };
            (radius.unwrap_or_else(|| px.hypot(py)), a)
        };
        t[0] = r * a.cos() * self.scale + off[0];
        t[1] = r * a.sin() * self.scale + off[1];
        Ok(t)
    }

    /// A T or Q value as a tool number, checked against the tool table.
    fn tool_number(&self, v: f64, col: u32, letter: char) -> Result<u32, Fail> {
        if v < 0.0 || v.fract() != 0.0 || v > 1e9 {
            return fail(
                col,
                format!("{letter}{v} is not a tool number (an integer from 0)"),
            );
        }
        let t = v as u32;
        let table = &self.options.tool_lengths_mm;
        if t != 0 && !table.is_empty() && !table.contains_key(&t) {
            let known: Vec<String> = table.keys().map(|k| format!("T{k}")).collect();
            return fail(
                col,
                format!(
                    "tool T{t} is not in the job's tool table (it has {})",
                    known.join(", ")
                ),
            );
        }
        Ok(t)
    }

    /// Diameter of tool `t` (mm).
    fn diameter_of(&self, t: u32) -> f64 {
        self.options
            .tool_diameters_mm
            .get(&t)
            .copied()
            .unwrap_or(self.options.default_tool_diameter_mm)
    }

    /// Gauge length of tool `t` (mm); 0 for T0 and without a table.
    fn length_of(&self, t: u32) -> f64 {
        self.options.tool_lengths_mm.get(&t).copied().unwrap_or(0.0)
    }

    /// M6 / M61: puts tool `t` in the spindle. The gauge point stays; if the
    /// tip moves (another length), a rapid from the old tip to the new one
    /// records the change (MODEL.md §9.1).
    fn load_tool(&mut self, t: u32, pc: usize) {
        self.first_loaded.get_or_insert(t);
        self.toolchange_pending = true;
        if t == self.tool {
            return;
        }
        let old_tip = self.last_tip;
        let old_length = self.tool_length_mm;
        self.tool = t;
        self.tool_length_mm = self.length_of(t);
        let mut new_tip = old_tip;
        new_tip.z += old_length - self.tool_length_mm;
        if old_tip != new_tip {
            self.emit(old_tip, new_tip, Geometry::Line, Motion::Rapid, pc);
        }
    }

    /// G43 [H], G43.1, G43.2 and G49 (LinuxCNC's `convert_tool_length_offset`).
    fn tool_length_offset(&mut self, b: &Block) -> Result<(), Fail> {
        let code = b.g.iter().find(|g| g_group(g.0) == Some(8)).copied();
        if b.get('h').is_some() && !matches!(code, Some((GCode::G43 | GCode::G43_2, _))) {
            return fail(b.col('h'), "H word with no G43 to use it");
        }
        let Some((code, col)) = code else {
            return Ok(());
        };
        if self.comp.side.is_some() {
            return fail(
                col,
                "cannot change tool offset with cutter radius compensation on",
            );
        }
        let h_tool = |it: &Self| -> Result<u32, Fail> {
            match b.get('h') {
                None => Ok(it.tool),
                Some(h) => {
                    let t = it.tool_number(h, b.col('h'), 'H')?;
                    Ok(if t == 0 { it.tool } else { t })
                }
            }
        };
        match code {
            GCode::G49 => {
                self.tlo_mm = [0.0; 3];
                self.tlo_on = false;
            }
            GCode::G43 => {
                let t = h_tool(self)?;
                self.tlo_mm = [0.0, 0.0, self.length_of(t)];
                self.tlo_on = true;
            }
            GCode::G43_1 | GCode::G43_2 => {
                if code == GCode::G43_2 && b.get('h').is_some() {
                    if b.has_axes() {
                        return fail(col, "G43.2: cannot have both H and axis words");
                    }
                    let t = h_tool(self)?;
                    self.tlo_mm[2] += self.length_of(t);
                } else {
                    if code == GCode::G43_2 && !b.has_axes() {
                        return fail(col, "G43.2: no axes specified and H word missing");
                    }
                    for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                        if let Some(v) = b.get(l) {
                            let v = v * self.scale;
                            self.tlo_mm[i] = if code == GCode::G43_1 {
                                v
                            } else {
                                self.tlo_mm[i] + v
                            };
                        }
                    }
                }
                self.tlo_on = true;
            }
            _ => {}
        }
        Ok(())
    }

    fn modes(&self) -> SavedModes {
        SavedModes {
            scale: self.scale,
            plane: self.plane,
            incremental: self.incremental,
            arc_incremental: self.arc_incremental,
            inverse_time: self.inverse_time,
            coord: self.coord,
            retract_to_start: self.retract_to_start,
            tlo_on: self.tlo_on,
            feed_mm_min: self.feed_mm_min,
            spindle_rpm: self.spindle_rpm,
            spindle: self.spindle,
        }
    }

    /// LinuxCNC's `restore_settings`: units first, then the modes; F is
    /// restored to 0.1 and S to 1 in program units, G43 with the tool in
    /// the spindle.
    fn restore(&mut self, m: SavedModes) {
        self.scale = m.scale;
        self.plane = m.plane;
        self.incremental = m.incremental;
        self.arc_incremental = m.arc_incremental;
        self.inverse_time = m.inverse_time;
        self.coord = m.coord;
        self.retract_to_start = m.retract_to_start;
        if m.tlo_on != self.tlo_on {
            self.tlo_on = m.tlo_on;
            self.tlo_mm = [0.0, 0.0, if m.tlo_on { self.tool_length_mm } else { 0.0 }];
        }
        if m.feed_mm_min != self.feed_mm_min {
            self.feed_mm_min = (m.feed_mm_min / self.scale * 10.0).round() / 10.0 * self.scale;
        }
        if m.spindle_rpm != self.spindle_rpm {
            self.spindle_rpm = m.spindle_rpm.round();
        }
        self.spindle = m.spindle;
    }

    /// M70 save, M71 invalidate, M72 restore, M73 save and restore on return.
    /// M19's words, and the outputs and input waits (M62–M68) as LinuxCNC
    /// checks them. None moves an axis; a wait (M66 with L1–L4) takes the
    /// run no time, since the input's change cannot be known: a warning.
    fn inputs_and_outputs(&mut self, b: &Block) -> Result<(), Fail> {
        if b.has_m(19) && b.get('p').is_some_and(|p| ![0.0, 1.0, 2.0].contains(&p)) {
            return fail(b.col('p'), "P value must be 0, 1 or 2 with M19");
        }
        let col = |m: i32| b.m.iter().find(|c| c.0 == m).map_or(b.first_col, |c| c.1);
        if let Some(m) = (62..=65).find(|&m| b.has_m(m)) {
            if b.get('p').is_none() {
                return fail(col(m), format!("M{m} needs a P word (the output's number)"));
            }
        }
        if b.has_m(66) {
            let (p, e) = (b.get('p'), b.get('e'));
            let wait = b.get('l').unwrap_or(0.0);
            match (p, e) {
                (None, None) => {
                    return fail(
                        col(66),
                        "M66 needs a P word (digital input) or an E word (analog input)",
                    )
                }
                (Some(_), Some(_)) => {
                    return fail(
                        b.col('e'),
                        "M66 selects a digital (P) or an analog (E) input, not both",
                    )
                }
                (None, Some(_)) if wait != 0.0 => {
                    return fail(
                        b.col('l'),
                        "M66 waits on an analog input (E) only with L0 (immediate)",
                    )
                }
                _ => {}
            }
            if wait != 0.0 {
                let timeout_s = b.get('q').unwrap_or(0.0);
                if timeout_s <= 0.0 {
                    return fail(
                        col(66),
                        "M66 with a wait (L1-L4) needs a Q word (timeout, seconds)",
                    );
                }
                self.warn(
                    col(66),
                    format!("M66 waits for an input (up to {timeout_s} s): the run is simulated without the wait"),
                );
            }
        }
        if let Some(m) = [67, 68].into_iter().find(|&m| b.has_m(m)) {
            if b.get('e').is_none() {
                return fail(
                    col(m),
                    format!("M{m} needs an E word (the analog output's number)"),
                );
            }
        }
        Ok(())
    }

    fn m70_m73(&mut self, b: &Block) -> Result<(), Fail> {
        let level = self.contexts.len() - 1;
        let col = b.m.iter().find(|m| (70..=73).contains(&m.0)).map(|m| m.1);
        if b.has_m(70) || b.has_m(73) {
            let modes = self.modes();
            let c = &mut self.contexts[level];
            c.modes = Some(modes);
            c.restore_on_return |= b.has_m(73) && level > 0;
        } else if b.has_m(71) {
            self.contexts[level].modes = None;
        } else if b.has_m(72) {
            let Some(modes) = self.contexts[level].modes else {
                return fail(
                    col.unwrap_or(b.first_col),
                    "cannot restore modes: no M70 or M73 at this call level",
                );
            };
            self.restore(modes);
        }
        Ok(())
    }

    fn enter_call_level(&mut self) {
        self.contexts.push(Context {
            modes: None,
            restore_on_return: false,
        });
    }

    fn leave_call_level(&mut self) {
        if self.contexts.len() > 1 {
            let c = self.contexts.pop().expect("a call level");
            if let (true, Some(modes)) = (c.restore_on_return, c.modes) {
                self.restore(modes);
            }
        }
    }

    fn modal0(&mut self, code: GCode, col: u32, b: &Block, pc: usize) -> Result<(), Fail> {
        match code {
            GCode::G28 | GCode::G30 => {
                let home = if code == GCode::G28 {
                    self.options.g28_home_mm
                } else {
                    self.options.g30_home_mm
                };
                let mid = self.target(b, false)?;
                self.rapid(mid, pc);
                let mut end = self.pos;
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if !b.has_axes() || b.get(l).is_some() {
                        end[i] = home[i];
                    }
                }
                self.rapid(end, pc);
            }
            GCode::G92 => {
                let w = self.work[self.coord];
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if let Some(v) = b.get(l) {
                        self.g92[i] = self.pos[i] - w[i] - self.tlo_mm[i] - v * self.scale;
                    }
                }
            }
            GCode::G10 => {
                let l = b.get('l').unwrap_or(0.0);
                let p = b.get('p').unwrap_or(0.0);
                if l != 2.0 || !(1.0..=6.0).contains(&p) || p.fract() != 0.0 {
                    return fail(col, "only G10 L2 P1..P6 (set work offset) is supported");
                }
                let w = &mut self.work[p as usize - 1];
                for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                    if let Some(v) = b.get(l) {
                        w[i] = v * self.scale;
                    }
                }
            }
            _ => return fail(col, format!("{code} is not supported")),
        }
        Ok(())
    }

    fn rapid(&mut self, to: [f64; 3], pc: usize) {
        self.push(to, Geometry::Line, Motion::Rapid, pc, false);
    }

    /// Tool tip (path frame) of gauge point `gauge`.
    fn tip(&self, gauge: [f64; 3]) -> Point3<f64> {
        Point3::new(gauge[0], gauge[1], gauge[2] - self.tool_length_mm)
    }

    /// Appends a segment from the current position to `to` (gauge points,
    /// turned into tool tips); zero-length lines are dropped. `dwell` keeps
    /// a zero-length segment.
    fn push(&mut self, to: [f64; 3], geometry: Geometry, motion: Motion, pc: usize, dwell: bool) {
        let start = self.last_tip;
        let end = if dwell { start } else { self.tip(to) };
        self.pos = to;
        self.canon_mm = std::array::from_fn(|i| to[i] - self.tlo_mm[i]);
        if !dwell && geometry == Geometry::Line && start == end {
            return;
        }
        let geometry = match geometry {
            Geometry::Arc {
                center,
                plane,
                clockwise,
                sweep_rad,
            } => Geometry::Arc {
                center: self.tip(center.into()),
                plane,
                clockwise,
                sweep_rad,
            },
            g => g,
        };
        self.emit(start, end, geometry, motion, pc);
    }

    /// Appends a segment between two tool-tip points.
    fn emit(
        &mut self,
        start: Point3<f64>,
        end: Point3<f64>,
        geometry: Geometry,
        motion: Motion,
        pc: usize,
    ) {
        self.last_tip = end;
        let segment = Segment {
            start,
            end,
            geometry,
            motion,
            line: pc as u32 + 1,
            spindle_rpm: if self.spindle != Spindle::Stopped {
                self.spindle_rpm
            } else {
                0.0
            },
            tool: self.tool,
        };
        let lent = self.lent.as_mut().is_some_and(|l| {
            let same = l.path.get(l.matched).is_some_and(|s| s.same_bits(&segment));
            l.matched += usize::from(same);
            same
        });
        if !lent {
            self.own_path();
            self.path.segments.push(segment);
        }
        // Only the re-feed writer reads the trace, and only from a recorded
        // run: a program parsed to be simulated keeps none (56 B a segment).
        if self.executed.is_none() {
            return;
        }
        let mut offset_mm = self.offset();
        offset_mm[2] -= self.tool_length_mm;
        self.trace.push(SegmentTrace {
            line_index: pc,
            scale: self.scale,
            incremental: self.incremental,
            arc_incremental: self.arc_incremental,
            inverse_time: self.inverse_time,
            offset_mm,
            feed_scale: self.feed_scale,
            compensated: self.comp_active(),
            spindle_cycle: matches!(
                self.motion,
                GCode::G74 | GCode::G84 | GCode::G86 | GCode::G87
            ),
        });
    }

    /// Segments made so far (those of a lent path included).
    fn segment_count(&self) -> usize {
        self.path.segments.len() + self.lent.map_or(0, |l| l.matched)
    }

    /// The run's path its own: the lent segments it made so far copied into
    /// it, and no more compared (before a segment's index is taken).
    fn own_path(&mut self) {
        if let Some(l) = self.lent.take() {
            self.path.segments = l.path[..l.matched].to_vec();
        }
    }

    /// Feed motion for a G1/G2/G3 of known geometry.
    fn feed_motion(&self, b: &Block, length_mm: f64) -> Result<Motion, Fail> {
        if self.inverse_time {
            let f = b.get('f').ok_or(Fail {
                col: b.first_col,
                msg: "F word missing with inverse time (G93) feed move".into(),
            })?;
            if f <= 0.0 {
                return fail(b.col('f'), "inverse time feed must be positive");
            }
            Ok(Motion::feed(length_mm * f))
        } else if self.feed_mm_min <= 0.0 {
            fail(b.first_col, "feed move with zero feed rate (no F word yet)")
        } else {
            Ok(Motion::feed(self.feed_mm_min))
        }
    }

    fn motion_block(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let machine = b.has_g(GCode::G53).is_some();
        if machine && !matches!(self.motion, GCode::G0 | GCode::G1) {
            return fail(b.has_g(GCode::G53).unwrap_or(1), "G53 needs G0 or G1");
        }
        let t = self.target(b, machine)?;
        if self.comp_active() {
            if machine {
                return fail(
                    b.has_g(GCode::G53).unwrap_or(1),
                    "cannot use G53 with cutter radius compensation",
                );
            }
            if self.inverse_time {
                return fail(
                    b.first_col,
                    "inverse time feed (G93) with cutter radius compensation is not supported",
                );
            }
            match self.motion {
                GCode::G0 => return self.straight_comp(b, t, Motion::Rapid, pc),
                GCode::G1 => {
                    let m = self.feed_motion(b, 1.0)?;
                    return self.straight_comp(b, t, m, pc);
                }
                code if code.is_canned_cycle() => {
                    return fail(
                        b.first_col,
                        "cannot use canned cycles with cutter radius compensation",
                    )
                }
                _ => {}
            }
        }
        if matches!(self.motion, GCode::G0 | GCode::G1) {
            self.comp.arc_not_allowed = false;
        }
        let done = match self.motion {
            GCode::G0 => {
                self.rapid(t, pc);
                Ok(())
            }
            GCode::G1 => {
                let len = (Point3::from(t) - Point3::from(self.pos)).norm();
                if len > 0.0 {
                    let m = self.feed_motion(b, len)?;
                    self.push(t, Geometry::Line, m, pc, false);
                }
                Ok(())
            }
            GCode::G2 | GCode::G3 => self.arc(b, t, pc),
            code if code.is_canned_cycle() => return self.cycle(b, pc),
            _ => return fail(b.first_col, format!("{} is not supported", self.motion)),
        };
        if done.is_err() {
            // Later blocks start where this one meant to end: one error per
            // problem, not a cascade of follow-on errors.
            self.pos = t;
        }
        done
    }

    /// A block whose only motion word is G2 or G3, with no axis, R, I, J or
    /// K word: an error in LinuxCNC (an arc with no end or centre); read
    /// tolerantly, it sets the arc mode for the axis words of a later block,
    /// as Fanuc-style controls (UCCNC, Mach3) read it, and the word is
    /// dropped here and written on that block
    /// ([`Interp::arc_mode_written_here`]).
    fn lone_arc_mode(&mut self, b: &Block, pc: usize) -> bool {
        let Some(&(code, col)) = b.g.iter().find(|g| g_group(g.0) == Some(1)) else {
            return false;
        };
        let words = ['r', 'i', 'j', 'k'].iter().any(|&l| b.get(l).is_some());
        if !matches!(code, GCode::G2 | GCode::G3) || b.has_axes() || words {
            return false;
        }
        let Some(span) = self.item_span(pc, col) else {
            return false;
        };
        let what = format!("{code} alone on its line sets the arc mode for the next block's axis words, as Fanuc-style controls (UCCNC, Mach3) read it; written on that block");
        self.tolerate(span, String::new(), col, what)
    }

    /// The G2 or G3 read alone on an earlier line ([`Interp::lone_arc_mode`])
    /// written before this block's first axis word, which moves in it.
    fn arc_mode_written_here(&mut self, b: &Block, pc: usize) {
        let Some(code) = self.tolerated.lone_arc.take() else {
            return;
        };
        let col = b.first_axis_col();
        if let Some(span) = self.item_span(pc, col) {
            let what = format!("{code} from the line where it stood alone written here");
            self.tolerate(span.start..span.start, format!("{code} "), col, what);
        }
    }

    /// Axis words with G80 in force: an error, as in LinuxCNC; read
    /// tolerantly, a move in the G0/G1 mode set before the canned cycle, as
    /// Fanuc-style controls (Mach3) make it, written with that G code.
    fn axis_words_after_g80(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let col = b.first_axis_col();
        if let (Some(code), Some(span)) = (self.tolerated.plain_motion, self.item_span(pc, col)) {
            let what = format!("axis words after G80 moved in {code}, the mode before the canned cycle, as Fanuc-style controls do; written with {code}");
            if self.tolerate(span.start..span.start, format!("{code} "), col, what) {
                self.motion = code;
                return Ok(());
            }
        }
        fail(
            b.first_col,
            "axis words without a motion mode (G80 is active)",
        )
    }

    fn arc(&mut self, b: &Block, end: [f64; 3], pc: usize) -> Result<(), Fail> {
        let clockwise = self.motion == GCode::G2;
        let (a, bb, n) = self.plane.axes();
        let letters = ['i', 'j', 'k'];
        let off_word = letters[n];
        let tolerated = b.get(off_word).is_some_and(|v| {
            let col = b.col(off_word);
            let letter = off_word.to_ascii_uppercase();
            self.item_span(pc, col).is_some_and(|span| {
                self.tolerate(span, String::new(), col, format!("{letter}{v} on an arc in this plane ignored, as GRBL does; written without it"))
            })
        });
        if b.get(off_word).is_some() && !tolerated {
            return fail(
                b.col(off_word),
                format!(
                    "{} word not allowed for an arc in this plane",
                    off_word.to_ascii_uppercase()
                ),
            );
        }
        if self.comp.arc_not_allowed {
            return fail(
                b.first_col,
                "the move just after exiting cutter compensation (G40) must be straight",
            );
        }
        // Under compensation the arc is defined on the programmed contour.
        let start = if self.comp_active() && !self.comp.first {
            self.comp.program
        } else {
            self.pos
        };
        let center = self.arc_center(b, start, end)?;
        let col = b.first_col;
        let r = (start[a] - center[a]).hypot(start[bb] - center[bb]);
        if r == 0.0 {
            return fail(col, "arc of zero radius");
        }
        let turns = b.get('p').unwrap_or(1.0);
        if turns < 1.0 || turns.fract() != 0.0 || turns > 1e4 {
            return fail(
                b.col('p'),
                "P (turns) of an arc must be an integer from 1 to 10000",
            );
        }
        if self.comp_active() {
            let motion = self.feed_motion(b, 0.0)?;
            return self.arc_comp(b, end, [center[a], center[bb]], turns as i32, motion, pc);
        }
        self.arc_from(b, start, end, center, clockwise, turns, pc)
    }

    /// Centre (gauge frame) of the block's arc from `start` to `end`, with
    /// LinuxCNC's R and I/J/K tolerances.
    fn arc_center(&self, b: &Block, start: [f64; 3], end: [f64; 3]) -> Result<[f64; 3], Fail> {
        let clockwise = self.motion == GCode::G2;
        let (a, bb, _) = self.plane.axes();
        let letters = ['i', 'j', 'k'];
        let mut center = start;
        let col = b.first_col;
        if let Some(r) = b.get('r') {
            if b.get(letters[a]).is_some() || b.get(letters[bb]).is_some() {
                return fail(b.col('r'), "mixed radius (R) and centre (I/J/K) format arc");
            }
            let r_mm = r * self.scale;
            let (dx, dy) = (end[a] - start[a], end[bb] - start[bb]);
            let half = 0.5 * dx.hypot(dy);
            if half == 0.0 {
                return fail(
                    b.col('r'),
                    "R format arc with end point equal to start point",
                );
            }
            // LinuxCNC's arc_data_r: a chord up to 2 × 0.00127 mm longer
            // than the diameter is a semicircle.
            let abs_r = r_mm.abs();
            if half - abs_r > RADIUS_TOLERANCE_MM || abs_r == 0.0 {
                return fail(
                    b.col('r'),
                    format!(
                        "arc radius {:.4} mm too small to reach the end point (half chord {half:.4} mm)",
                        abs_r
                    ),
                );
            }
            let half = if half / abs_r > 1.0 - 1e-12 {
                abs_r
            } else {
                half
            };
            let right = clockwise == (r_mm > 0.0);
            let theta = dy.atan2(dx)
                + if right {
                    -std::f64::consts::FRAC_PI_2
                } else {
                    std::f64::consts::FRAC_PI_2
                };
            let offset = abs_r * (half / abs_r).asin().cos();
            center[a] = 0.5 * (start[a] + end[a]) + offset * theta.cos();
            center[bb] = 0.5 * (start[bb] + end[bb]) + offset * theta.sin();
        } else {
            let (ca, cb) = (b.get(letters[a]), b.get(letters[bb]));
            if ca.is_none() && cb.is_none() {
                return fail(col, "arc needs R or centre (I/J/K) words");
            }
            let off = self.offset();
            for (axis, v) in [(a, ca), (bb, cb)] {
                let v = v.unwrap_or(0.0) * self.scale;
                center[axis] = if self.arc_incremental {
                    start[axis] + v
                } else {
                    v + off[axis]
                };
            }
            // LinuxCNC's arc_data_ijk tolerances.
            let r1 = (start[a] - center[a]).hypot(start[bb] - center[bb]);
            let r2 = (end[a] - center[a]).hypot(end[bb] - center[bb]);
            if r1 < RADIUS_TOLERANCE_MM || r2 < RADIUS_TOLERANCE_MM {
                return fail(col, "arc of zero radius");
            }
            let spiral_mm = if self.scale == 1.0 {
                2.0 * 0.01 * std::f64::consts::SQRT_2
            } else {
                2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4
            };
            let abs_err = (r1 - r2).abs();
            if abs_err > 100.0 * spiral_mm || (abs_err / r1.max(r2) > 0.001 && abs_err > spiral_mm)
            {
                return fail(
                    col,
                    format!(
                        "radius to end of arc differs from radius to start ({r1:.4} vs {r2:.4} mm)"
                    ),
                );
            }
        }
        Ok(center)
    }

    /// Appends the arc from `start` about `center` to `end`.
    #[allow(clippy::too_many_arguments)]
    fn arc_from(
        &mut self,
        b: &Block,
        start: [f64; 3],
        end: [f64; 3],
        center: [f64; 3],
        clockwise: bool,
        turns: f64,
        pc: usize,
    ) -> Result<(), Fail> {
        let (a, bb, _) = self.plane.axes();
        let a0 = (start[bb] - center[bb]).atan2(start[a] - center[a]);
        let a1 = (end[bb] - center[bb]).atan2(end[a] - center[a]);
        let tau = std::f64::consts::TAU;
        let mut sweep = if clockwise { a0 - a1 } else { a1 - a0 }.rem_euclid(tau);
        if sweep < 1e-12 || (start[a] == end[a] && start[bb] == end[bb]) {
            sweep = tau;
        }
        sweep += (turns - 1.0) * tau;
        let geometry = Geometry::Arc {
            center: Point3::from(center),
            plane: self.plane,
            clockwise,
            sweep_rad: sweep,
        };
        let motion = self.feed_motion(
            b,
            geometry.length_mm(&Point3::from(start), &Point3::from(end)),
        )?;
        self.push(end, geometry, motion, pc, false);
        Ok(())
    }

    fn cycle(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        if self.plane != Plane::XY {
            return fail(
                b.first_col,
                "canned cycles are supported in the G17 plane only",
            );
        }
        if self.inverse_time {
            return fail(
                b.first_col,
                "canned cycles cannot be used with G93 inverse time",
            );
        }
        // As LinuxCNC's convert_cycle: a cycle entered from another motion
        // mode needs its R and Z words (and P where it dwells, I J K for
        // G87); a later block of the same cycle takes those it lacks from
        // the block before.
        let code = self.motion;
        let entered = self.previous_motion != code;
        let modal = |word: Option<f64>, held: Option<f64>| {
            if entered {
                word
            } else {
                word.or(held)
            }
        };
        let r = modal(b.get('r'), self.cycle_r).ok_or(Fail {
            col: b.first_col,
            msg: "R clearance plane unspecified in cycle".into(),
        })?;
        let z = modal(b.get('z'), self.cycle_z).ok_or(Fail {
            col: b.first_col,
            msg: "Z value unspecified in XY plane canned cycle".into(),
        })?;
        self.cycle_r = Some(r);
        self.cycle_z = Some(z);
        let repeats = b.get('l').unwrap_or(1.0);
        if repeats < 1.0 || repeats.fract() != 0.0 || repeats > 1e5 {
            return fail(
                b.col('l'),
                "L repeat count must be an integer from 1 to 100000",
            );
        }
        let mut peck_mm = 0.0;
        if matches!(self.motion, GCode::G73 | GCode::G83) {
            let q = b.get('q').or(self.cycle_q).ok_or(Fail {
                col: b.first_col,
                msg: "G73/G83 need a Q word (peck depth)".into(),
            })?;
            if q <= 0.0 {
                return fail(b.col('q'), "Q (peck depth) must be positive");
            }
            self.cycle_q = Some(q);
            peck_mm = q * self.scale;
        }
        if matches!(code, GCode::G82 | GCode::G86 | GCode::G89) && entered && b.get('p').is_none() {
            return fail(
                b.first_col,
                format!("Dwell time P word missing with {code}"),
            );
        }
        if matches!(
            code,
            GCode::G74 | GCode::G82 | GCode::G84 | GCode::G86 | GCode::G89
        ) {
            self.cycle_p = b.get('p').unwrap_or(self.cycle_p);
        }
        if code == GCode::G87 {
            for (k, letter) in ['i', 'j', 'k'].into_iter().enumerate() {
                match b.get(letter) {
                    Some(v) => self.cycle_ijk[k] = v,
                    None if entered => {
                        return fail(
                            b.first_col,
                            format!("{} word missing with G87", letter.to_ascii_uppercase()),
                        )
                    }
                    None => {}
                }
            }
        }
        // LinuxCNC checks the spindle where the cycle runs its hole.
        let spindle_error = match (code, self.spindle) {
            (GCode::G74 | GCode::G84 | GCode::G86 | GCode::G87, Spindle::Stopped) => {
                Some(format!("Spindle not turning in {code}"))
            }
            (GCode::G84, Spindle::Counterclockwise) => {
                Some("Spindle turning counterclockwise in G84".to_string())
            }
            (GCode::G74, Spindle::Clockwise) => Some("Spindle turning clockwise in G74".into()),
            _ => None,
        };
        if let Some(msg) = spindle_error {
            return fail(b.first_col, msg);
        }
        if self.feed_mm_min <= 0.0 {
            return fail(b.first_col, "canned cycle with zero feed rate");
        }
        let initial_z = *self.cycle_initial_z.get_or_insert(self.pos[2]);
        let off = self.offset();
        let (r_z, bottom_z, holes) = if self.incremental {
            // LinuxCNC's CYCLE_MACRO: each repeat steps X/Y, then the polar
            // radius and angle about the program origin.
            let r_z = initial_z + r * self.scale;
            let (mut aa, mut bb) = (
                (self.pos[0] - off[0]) / self.scale,
                (self.pos[1] - off[1]) / self.scale,
            );
            let (di, dj) = (b.get('x').unwrap_or(0.0), b.get('y').unwrap_or(0.0));
            let (dr, dt) = (b.get('@').unwrap_or(0.0), b.get('^').unwrap_or(0.0));
            let mut holes = Vec::with_capacity(repeats as usize);
            for _ in 0..repeats as u32 {
                aa += di;
                bb += dj;
                for (radius_inc, angle_inc) in [(dr, 0.0), (0.0, dt.to_radians())] {
                    if radius_inc == 0.0 && angle_inc == 0.0 {
                        continue;
                    }
                    if aa == 0.0 && bb == 0.0 {
                        return fail(
                            b.col(if dr != 0.0 { '@' } else { '^' }),
                            "incremental polar motion is indeterminate at the origin",
                        );
                    }
                    let (radius, theta) = (aa.hypot(bb) + radius_inc, bb.atan2(aa) + angle_inc);
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
                holes.push([aa * self.scale + off[0], bb * self.scale + off[1]]);
            }
            (r_z, r_z + z * self.scale, holes)
        } else {
            let t = self.target(b, false)?;
            (
                r * self.scale + off[2],
                z * self.scale + off[2],
                vec![[t[0], t[1]]; repeats as usize],
            )
        };
        if r_z < bottom_z {
            return fail(b.col('r'), "R plane below the hole bottom Z");
        }
        // G87's K: the back bore's top, absolute, or from the bottom under G91.
        let back_top_z = if self.incremental {
            bottom_z + self.cycle_ijk[2] * self.scale
        } else {
            self.cycle_ijk[2] * self.scale + off[2]
        };
        // Each peck is a few moves: bound them before expanding (Q 1e-9 would be 1e10 moves).
        let pecks = if peck_mm > 0.0 {
            ((r_z - bottom_z) / peck_mm).ceil() * repeats
        } else {
            repeats
        };
        if !(pecks <= MAX_CYCLE_PECKS) {
            return fail(
                b.col(if peck_mm > 0.0 { 'q' } else { 'l' }),
                format!(
                    "the cycle would make {pecks:.3e} pecks (limit {MAX_CYCLE_PECKS}): Q peck depth too small"
                ),
            );
        }
        let c = Cycle {
            code: self.motion,
            holes,
            start_z: initial_z,
            current_z: self.pos[2],
            r_z,
            bottom_z,
            retract_to_start: self.retract_to_start,
            peck_mm,
            dwell_s: self.cycle_p,
            back_offset_mm: [
                self.cycle_ijk[0] * self.scale,
                self.cycle_ijk[1] * self.scale,
            ],
            back_top_z,
        };
        let turning = self.spindle;
        for m in cycles::expand(&c, [self.pos[0], self.pos[1]]) {
            match m {
                CycleMove::Rapid(p) => self.rapid(p, pc),
                CycleMove::Feed(p) => {
                    self.push(p, Geometry::Line, Motion::feed(self.feed_mm_min), pc, false)
                }
                CycleMove::HeldFeed(p) => self.push(
                    p,
                    Geometry::Line,
                    Motion::Feed {
                        feed_mm_min: self.feed_mm_min,
                        held: true,
                    },
                    pc,
                    false,
                ),
                CycleMove::SpindleStop => self.spindle = Spindle::Stopped,
                CycleMove::SpindleStart => self.spindle = turning,
                CycleMove::Dwell(s) => self.push(
                    self.pos,
                    Geometry::Line,
                    Motion::Dwell { seconds: s },
                    pc,
                    true,
                ),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A program parsed where its blocks run ([`parse`], each block's items
    /// parsed again from the source, none held) reads as one whose lines
    /// are held: the same path, diagnostics, program end and amendments,
    /// from the program's start and another, for every real program of the
    /// corpus (o-word subroutines and loops, M98 subprograms, arcs, cycles,
    /// cutter compensation, inch files) and the tolerant form's mends (a
    /// line mended keeps its own items; an edit after G80 or of an arc word
    /// finds its item's span in the line parsed again), with the source's
    /// byte-order mark, a line ending in CR alone and CR LF. The reading
    /// holds no item but a mended line's, and gives every block's items
    /// (parsed again, as the re-feed writer asks for them) as the held
    /// lines do.
    #[test]
    fn a_program_parsed_where_it_runs_reads_as_one_held() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
        let mut sources: Vec<(String, String)> = std::fs::read_dir(&dir)
            .expect("the corpus")
            .map(|e| e.expect("a corpus file").path())
            .filter(|p| p.extension().is_some_and(|e| e != "md"))
            .map(|p| {
                let bytes = std::fs::read(&p).expect("a corpus file");
                (
                    p.display().to_string(),
                    String::from_utf8_lossy(&bytes).into_owned(),
                )
            })
            .collect();
        sources.sort();
        assert!(sources.len() >= 90, "{}", sources.len());
        for (name, text) in [
            ("nested", "(Tools: (HSS Twist Drill, 3mm (R)))\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n"),
            ("k0", "\u{feff}G17 G0 X0 Y0 Z1\r\nG1 X1 F300\r\nG3 X2 Y1 I0 J1 K0.000\rM2\n"),
            ("g80", "G0 X0 Y0 Z5\nG98 G81 X1 Y1 Z-1 R2 F100\nX2\nG80\nX0 Y-2 Z6\no1 repeat [2]\nX1 Y1\no1 endrepeat\nM2\n"),
            ("grbl", "G21 G90\n  $I  ; build info\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n"),
            ("subs", "o<s> sub\nG91 G1 X[#1] F100\no<s> endsub\n#2 = 0\no2 while [#2 LT 3]\no<s> call [#2 + 1]\n#2 = [#2 + 1]\no2 endwhile\nG90 G0 X0\nM98 P1000 L2\nM30\nO1000\nG91 G1 Y1\nM99\n"),
            ("syntax error", "G0 X0\nG1 X1 Y F100\nG1 X2\nM2\n"),
        ] {
            sources.push((name.to_owned(), text.to_owned()));
        }
        let mut blocks = 0;
        for (name, source) in &sources {
            for file_form in [FileForm::Tolerant, FileForm::LinuxCnc] {
                let options = Options {
                    file_form,
                    ..Options::default()
                };
                let held = read(source, name, &options);
                let unkept = read_lines(source, name, &options, false);
                // Lines mended as they are read keep their items.
                let mended = held
                    .tolerated
                    .amendments
                    .iter()
                    .any(|a| matches!(a, Amendment::Edit { .. }));
                if !mended {
                    assert_eq!(unkept.lines.held().0, 0, "{name}");
                }
                blocks += held.lines.held().0;
                assert_eq!(unkept.lines.len(), held.lines.len(), "{name}");
                assert_eq!(unkept.lines.held().1, held.lines.len(), "{name}");
                assert_eq!(held.lines.held().1, 0, "{name}");
                // Every block's items, as the re-feed writer asks for them.
                let (mut a, mut b) = (Vec::new(), Vec::new());
                for index in 0..held.lines.len() {
                    assert_eq!(
                        unkept.lines.block_items(index, source, &mut a),
                        held.lines.block_items(index, "", &mut b),
                        "{name} line {}",
                        index + 1
                    );
                }
                let start = [3.0, -2.0, 40.0];
                let moved = Options {
                    initial_position_mm: start,
                    ..options.clone()
                };
                for options in [&options, &moved] {
                    let (held, _, executed) =
                        run_read_and_record(&held, "", name, options, true, None);
                    let streamed = parse(source, name, options);
                    assert_eq!(streamed, held, "{name} {file_form:?}");
                    assert!(!executed.is_empty(), "{name}");
                }
            }
        }
        assert!(blocks > 100_000, "{blocks}");
    }
}
