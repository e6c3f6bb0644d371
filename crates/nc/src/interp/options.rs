//! What a run is given: the settings a program cannot know by itself and
//! the file form it is read in.

use std::collections::BTreeMap;

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
    /// refuse, and an [`Amendment`](crate::Amendment) in
    /// [`Parsed::amendments`](crate::Parsed::amendments).
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
