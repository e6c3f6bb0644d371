//! The interpreter's state: its modes, position, parameters, offsets, call
//! levels and what it has made so far; a fresh interpreter at a run's start;
//! the modes M70/M73 save and M72 restores.

use std::collections::HashMap;
use std::rc::Rc;

use nalgebra::Point3;

use super::comp;
use super::control::Frame;
use super::diagnostics::Tolerated;
use super::{fail, Block, Executed, Fail, Options, SegmentTrace};
use crate::cursor::SyntaxError;
use crate::diag::Diagnostic;
use crate::expr::Params;
use crate::gcode::GCode;
use crate::path::{Path, Plane, Segment};
use crate::syntax::{self, OLabel};

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
pub(super) enum Spindle {
    Stopped,
    Clockwise,
    Counterclockwise,
}

/// M70/M73 context of one call level.
#[derive(Clone, Copy)]
pub(super) struct Context {
    modes: Option<SavedModes>,
    restore_on_return: bool,
}

pub(super) struct Interp<'a> {
    /// What the tolerant file form accepted beyond LinuxCNC, as amendments.
    pub(super) tolerated: Tolerated,
    pub(super) file: &'a str,
    pub(super) options: &'a Options,
    /// Shared so that executing a line needs no copy of it.
    pub(super) lines: Rc<syntax::Lines>,
    /// The source `lines` were read from, to parse a block again where it
    /// runs where they keep no block's items.
    pub(super) source: &'a str,
    pub(super) params: Params,
    pub(super) pos: [f64; 3],
    pub(super) scale: f64,
    pub(super) incremental: bool,
    pub(super) arc_incremental: bool,
    pub(super) inverse_time: bool,
    pub(super) plane: Plane,
    pub(super) motion: GCode,
    pub(super) coord: usize,
    pub(super) work: [[f64; 3]; 6],
    /// Rotation (degrees, counterclockwise about Z) of each coordinate
    /// system, set by `G10 L2 … R` (LinuxCNC's #5210 + 20·n).
    pub(super) rotation_deg: [f64; 6],
    pub(super) g92: [f64; 3],
    /// The G92/G52 offset G92.2 suspends and G92.3 restores (LinuxCNC's
    /// #5211–#5213).
    pub(super) g92_saved: [f64; 3],
    /// G28 and G30 home positions (gauge point, mm, machine frame): the
    /// options', until G28.1 or G30.1 stores the current point.
    pub(super) homes_mm: [[f64; 3]; 2],
    pub(super) feed_mm_min: f64,
    pub(super) spindle_rpm: f64,
    pub(super) spindle: Spindle,
    pub(super) retract_to_start: bool,
    pub(super) cycle_r: Option<f64>,
    pub(super) cycle_z: Option<f64>,
    pub(super) cycle_q: Option<f64>,
    pub(super) cycle_p: f64,
    /// G87's I, J and K, modal while G87 is (LinuxCNC's `cycle_i` …).
    pub(super) cycle_ijk: [f64; 3],
    /// The motion mode before the block now running (LinuxCNC's
    /// `motion_mode` as a canned cycle checks it: a cycle entered from
    /// another mode needs its R, Z and, where it dwells, P words).
    pub(super) previous_motion: GCode,
    /// Z (mm) where the current series of canned cycles started (G98 level).
    pub(super) cycle_initial_z: Option<f64>,
    pub(super) frames: Vec<Frame>,
    pub(super) repeats: HashMap<usize, i64>,
    /// Each `repeat` entered: its count and the segments made before its
    /// first run, to foresee the moves it makes once that run ends.
    pub(super) repeat_runs: HashMap<usize, (i64, usize)>,
    /// Line and column of the loop (repeat, while, do, M98 with L) that
    /// last ran its body again: the one blamed when the moves pass the limit.
    pub(super) last_loop: Option<(usize, u32)>,
    /// A loop was found to make more moves than the limit: the run stops.
    pub(super) halted: bool,
    pub(super) path: Path,
    pub(super) trace: Vec<SegmentTrace>,
    pub(super) diagnostics: Vec<Diagnostic>,
    pub(super) line_index: usize,
    /// Units in force when the current block's F word was read.
    pub(super) feed_scale: f64,
    /// Syntax errors by line index, reported when the line is executed (as
    /// LinuxCNC does: a bad line after M2 is never read).
    pub(super) syntax_errors: HashMap<usize, SyntaxError>,
    /// Lines of the o-words of each label, ascending (linear-time lookup).
    pub(super) olines: HashMap<OLabel, Vec<usize>>,
    /// Line of each Fanuc program number `O1000` (its first occurrence).
    pub(super) programs: HashMap<i64, usize>,
    /// Errors found, including those not kept beyond `max_errors`.
    pub(super) error_count: usize,
    /// Line and column of the first error not kept.
    pub(super) first_dropped: Option<(usize, u32)>,
    /// Tool in the spindle, its gauge length (mm) and the tool selected by T.
    pub(super) tool: u32,
    pub(super) tool_length_mm: f64,
    pub(super) selected_tool: Option<u32>,
    /// First tool loaded by M6/M61.
    pub(super) first_loaded: Option<u32>,
    /// Execution stopped at a program end (M2, M30, closing '%').
    pub(super) ended: bool,
    /// Active tool length offset (G43, G43.1, G43.2) in mm; `pos` is the
    /// gauge point = program + work offset + G92 + this.
    pub(super) tlo_mm: [f64; 3],
    pub(super) tlo_on: bool,
    /// Gauge point of the last move minus the tool length offset then in
    /// force: where LinuxCNC's canon says the machine is.
    pub(super) canon_mm: [f64; 3],
    /// M6/M61 ran: the next block re-reads the position from the canon.
    pub(super) toolchange_pending: bool,
    /// Where the tool tip is: the end of the last segment (the next one
    /// starts here even where the interpreter's idea of `pos` moved without
    /// motion, as after a tool change).
    pub(super) last_tip: Point3<f64>,
    /// M70/M73 contexts per call level (index = frames.len()).
    pub(super) contexts: Vec<Context>,
    /// Cutter radius compensation.
    pub(super) comp: comp::Comp,
    /// Every line executed, in order, with the call depth it ran at
    /// (`Some` only for [`run_recorded`](super::run_recorded)).
    pub(super) executed: Option<Vec<Executed>>,
    /// The path the run is expected to make, while it makes it.
    pub(super) lent: Option<Lent<'a>>,
}

/// A path lent to a run ([`run_recorded_along`](super::run_recorded_along)): the caller's reading of
/// the same text. While each segment the run makes is the lent path's next
/// bit for bit, it is counted, not pushed; at the first that is not (or
/// before cutter compensation takes a segment's index to move its end
/// later) the segments matched so far are copied into the run's own path
/// and it goes on as any run (a million-block program's re-feed would
/// otherwise hold its path twice, 126 MB each).
#[derive(Clone, Copy)]
pub(super) struct Lent<'a> {
    pub(super) path: &'a [Segment],
    /// Segments made so far, each the lent path's own.
    pub(super) matched: usize,
}

/// A fresh interpreter at the start `options` give.
pub(super) fn interp<'a>(file: &'a str, options: &'a Options, record: bool) -> Interp<'a> {
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
        rotation_deg: [0.0; 6],
        g92: [0.0; 3],
        g92_saved: [0.0; 3],
        homes_mm: [options.g28_home_mm, options.g30_home_mm],
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
        repeat_runs: HashMap::new(),
        last_loop: None,
        halted: false,
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

impl Interp<'_> {
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
    pub(super) fn m70_m73(&mut self, b: &Block) -> Result<(), Fail> {
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

    pub(super) fn enter_call_level(&mut self) {
        self.contexts.push(Context {
            modes: None,
            restore_on_return: false,
        });
    }

    pub(super) fn leave_call_level(&mut self) {
        if self.contexts.len() > 1 {
            let c = self.contexts.pop().expect("a call level");
            if let (true, Some(modes)) = (c.restore_on_return, c.modes) {
                self.restore(modes);
            }
        }
    }
}
