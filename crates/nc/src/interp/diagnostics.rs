//! Errors and warnings at the line and column being read, the execution
//! error a block fails with, and the tolerant form's amendments (each
//! edit made and warned of once, where its item lies in the line).

use super::{FileForm, Interp};
use crate::amend::Amendment;
use crate::diag::{Diagnostic, Severity};
use crate::gcode::GCode;

/// An execution error at a column.
pub(super) struct Fail {
    pub(super) col: u32,
    pub(super) msg: String,
}

pub(super) fn fail<T>(col: u32, msg: impl Into<String>) -> Result<T, Fail> {
    Err(Fail {
        col,
        msg: msg.into(),
    })
}

/// What the tolerant file form read beyond LinuxCNC ([`FileForm::Tolerant`]).
#[derive(Clone, Default)]
pub(super) struct Tolerated {
    pub(super) amendments: Vec<Amendment>,
    /// (line, byte) of every edit made, each made and warned of once.
    pub(super) edited: std::collections::HashSet<(usize, usize)>,
    /// The last G0/G1/G2/G3 mode set: what a Fanuc-style control moves in
    /// after G80.
    pub(super) plain_motion: Option<GCode>,
    /// A G2 or G3 read alone on its line, dropped there: written on the next
    /// block that moves in it.
    pub(super) lone_arc: Option<GCode>,
}

impl Interp<'_> {
    /// In the tolerant file form, reads what LinuxCNC refuses by editing the
    /// line (once per line and place), with a warning; else `false`.
    pub(super) fn tolerate(
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
    pub(super) fn item_span(&self, pc: usize, col: u32) -> Option<std::ops::Range<usize>> {
        self.lines.get(pc)?;
        self.lines
            .block_items(pc, self.source, &mut Vec::new())?
            .iter()
            .find(|i| i.col == col)
            .map(|i| i.span())
    }

    pub(super) fn report(&mut self, col: u32, message: String) {
        self.error_count += 1;
        if self.error_count > self.options.max_errors {
            self.first_dropped.get_or_insert((self.line_index, col));
            return;
        }
        self.push_diagnostic(col, message, Severity::Error);
    }

    /// A warning: the program is read, but the user should know.
    pub(super) fn warn(&mut self, col: u32, message: String) {
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
}
