//! Amendments: what makes a file read as most controls read it
//! ([`crate::FileForm::Tolerant`]) one that LinuxCNC reads too, with the
//! same moves.
//!
//! The tolerant reader records one amendment per thing it tolerated, and the
//! re-feed writer applies them, so that every file dexcut writes for a
//! machine reads on every control:
//!
//! * a leading UTF-8 byte-order mark is dropped;
//! * a file with no program end gets `M2`, and one that closes with a `%` it
//!   never opened (CAMotics' sample programs) has `M2` written for that `%`;
//! * parentheses nested in a comment (Estlcam writes tool names such as
//!   `(HSS Twist Drill, 3mm (R))`) are written as brackets;
//! * the off-plane word of an arc (FreeCAD's GRBL post writes `K0.000` on
//!   XY arcs; GRBL ignores it) is dropped;
//! * axis words after `G80` with no motion word (Fanuc-style posts such as
//!   Fusion's `.tap`), which those controls move in the G0/G1 mode in force
//!   before the canned cycle, get that G code;
//! * a G2 or G3 alone on its line (UCCNC's and Mach3's posts), which those
//!   controls take as the arc mode of the next block's axis words, is moved
//!   onto that block;
//! * GRBL's system commands that report or unlock (`$$ $# $G $I $N $X`, a
//!   bare `$`) and the `?` status query, which senders stream with the
//!   program and GRBL answers outside its G-code parser, are written as
//!   comments.

use std::ops::Range;

use crate::syntax;

/// One change to a tolerantly read file; see the module docs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Amendment {
    /// Drop the UTF-8 byte-order mark before the first line.
    DropByteOrderMark,
    /// Replace bytes `range` of the 0-based line `line_index` (counted after
    /// any byte-order mark) with `text`.
    Edit {
        /// 0-based line.
        line_index: usize,
        /// Byte range in the line (empty for an insertion).
        range: Range<usize>,
        /// The replacement.
        text: String,
    },
    /// Add a program end after the last line.
    AppendProgramEnd,
}

/// The block added to a file that had no program end.
const PROGRAM_END_ADDED: &str = "M2 (program end added by dexcut: the original had none)";

/// `source` with `amendments` applied; every other byte as it was. Line
/// terminators are kept; an added program end uses the file's own (`\r\n`
/// when the file has any).
pub fn amend(source: &str, amendments: &[Amendment]) -> String {
    let mut source = source;
    let mut edits: Vec<(usize, &Range<usize>, &str)> = Vec::new();
    let mut append_end = false;
    for a in amendments {
        match a {
            Amendment::DropByteOrderMark => {
                source = source
                    .strip_prefix(syntax::BYTE_ORDER_MARK)
                    .unwrap_or(source)
            }
            Amendment::Edit {
                line_index,
                range,
                text,
            } => edits.push((*line_index, range, text)),
            Amendment::AppendProgramEnd => append_end = true,
        }
    }
    // Per line, the later ranges first so that earlier ones keep their offsets.
    edits.sort_by_key(|&(line, range, _)| (line, std::cmp::Reverse(range.start)));
    edits.dedup_by_key(|e| (e.0, e.1.clone()));
    let mut out = String::with_capacity(source.len() + 64);
    let mut pending = edits.iter().peekable();
    for (i, (text, eol)) in syntax::split_lines(source).enumerate() {
        let mut line = text.to_owned();
        while let Some(&&(_, range, with)) = pending.peek().filter(|e| e.0 == i) {
            if range.end <= line.len() && line.is_char_boundary(range.start) {
                // A word removed takes the blanks before it.
                let mut start = range.start;
                if with.is_empty() {
                    start = line[..start].trim_end_matches([' ', '\t']).len();
                }
                line.replace_range(start..range.end, with);
            }
            pending.next();
        }
        out.push_str(&line);
        out.push_str(eol);
    }
    if append_end {
        let eol = if source.contains("\r\n") {
            "\r\n"
        } else {
            "\n"
        };
        if !out.is_empty() && !out.ends_with('\n') && !out.ends_with('\r') {
            out.push_str(eol);
        }
        out.push_str(PROGRAM_END_ADDED);
        out.push_str(eol);
    }
    out
}

/// GRBL's `$` lines and `?` that leave the machine where it is and the
/// program read as it was: `$$` `$#` `$G` `$I` `$N` (reports), `$X`
/// (alarm unlock), `$` (help) and `?` (status query). GRBL reads a line
/// that starts with `$` as a system command, not G-code, and `?` as a
/// real-time command ("Grbl v1.1 Commands", gnea/grbl
/// doc/markdown/commands.md). `$H` (homing) and `$J=` (jogging) move the
/// machine, `$C` (check mode) stops it moving, `$x=` and `$Nx=` change
/// settings and start-up blocks, and `$SLP` sleeps: those stay refused.
///
/// The line with the command in parentheses (a comment for every control)
/// and the 1-based column of the command; `None` for any other line.
pub(crate) fn comment_grbl_system_command(text: &str) -> Option<(String, u32)> {
    const QUIET: [&str; 8] = ["?", "$", "$$", "$#", "$G", "$I", "$N", "$X"];
    let lead = text.len() - text.trim_start_matches([' ', '\t']).len();
    let rest = &text[lead..];
    let command = rest[..rest.find([';', '(']).unwrap_or(rest.len())].trim_end_matches([' ', '\t']);
    let key: String = command
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_uppercase();
    QUIET.contains(&key.as_str()).then(|| {
        (
            format!("{}({command}){}", &text[..lead], &rest[command.len()..]),
            lead as u32 + 1,
        )
    })
}

/// Where a line's comments nest parentheses but each comment closes on the
/// line: the line with every inner `(` `)` written as `[` `]` (the same
/// byte length, so columns and spans stay), and the 1-based column of the
/// first inner `(`. `None` when nothing nests or the nesting does not close.
pub(crate) fn flatten_nested_comments(text: &str) -> Option<(String, u32)> {
    let mut out = String::with_capacity(text.len());
    let mut depth = 0usize;
    let mut first: Option<u32> = None;
    for (col, c) in (1u32..).zip(text.chars()) {
        match (c, depth) {
            (';', 0) => {
                out.push_str(&text[out.len()..]);
                break;
            }
            ('(', 0) => depth = 1,
            ('(', _) => {
                depth += 1;
                first.get_or_insert(col);
                out.push('[');
                continue;
            }
            (')', 1) => depth = 0,
            (')', d) if d > 1 => {
                depth -= 1;
                out.push(']');
                continue;
            }
            _ => {}
        }
        out.push(c);
    }
    (depth == 0).then_some(())?;
    first.map(|col| (out, col))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grbl_system_commands_that_neither_move_nor_set_become_comments() {
        assert_eq!(
            comment_grbl_system_command("$I  ; View build info"),
            Some(("($I)  ; View build info".into(), 1))
        );
        assert_eq!(
            comment_grbl_system_command("  ?"),
            Some(("  (?)".into(), 3))
        );
        assert_eq!(
            comment_grbl_system_command("$x (unlock)"),
            Some(("($x) (unlock)".into(), 1))
        );
        for moves_or_sets in [
            "$H",
            "$J=G91 X10 F100",
            "$C",
            "$100=80",
            "$N0=G20",
            "$SLP",
            "G0 X1",
        ] {
            assert_eq!(
                comment_grbl_system_command(moves_or_sets),
                None,
                "{moves_or_sets}"
            );
        }
    }

    #[test]
    fn nested_comments_flatten_only_when_they_close() {
        assert_eq!(
            flatten_nested_comments("(HSS Twist Drill, 3mm (R)) G0 X1"),
            Some(("(HSS Twist Drill, 3mm [R]) G0 X1".into(), 23))
        );
        assert_eq!(
            flatten_nested_comments("G1 X1 (a (b (c)) d) ; (e (f"),
            Some(("G1 X1 (a [b [c]] d) ; (e (f".into(), 10))
        );
        assert_eq!(flatten_nested_comments("(a (b)"), None);
        assert_eq!(flatten_nested_comments("(plain) G1 X2"), None);
    }

    #[test]
    fn edits_keep_other_bytes_and_line_ends() {
        let src = "\u{feff}G2 X1 Y0 I0.5 J0 K0.000\r\n(a (b))\r\nX2";
        let amendments = [
            Amendment::DropByteOrderMark,
            Amendment::Edit {
                line_index: 0,
                range: 17..23,
                text: String::new(),
            },
            Amendment::Edit {
                line_index: 0,
                range: 0..0,
                text: "N1 ".into(),
            },
            Amendment::Edit {
                line_index: 1,
                range: 3..6,
                text: "[b]".into(),
            },
            Amendment::AppendProgramEnd,
        ];
        assert_eq!(
            amend(src, &amendments),
            "N1 G2 X1 Y0 I0.5 J0\r\n(a [b])\r\nX2\r\nM2 (program end added by dexcut: the original had none)\r\n"
        );
    }
}
