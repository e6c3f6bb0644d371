//! A program's bytes as text: UTF-8, or where a byte is not, Windows-1252
//! (the code page Windows editors and many CAM posts write comments in, as
//! `(T1 D=6 CR=0 - Fräser)` with byte 0xE4).

use crate::diag::{Diagnostic, Severity};
use crate::interp::FileForm;
use crate::syntax::split_lines;

/// A program's text from its bytes, and in the tolerant form a warning at
/// the line and column of the first byte that is not UTF-8.
///
/// Valid UTF-8 is taken as it is (not copied). Every byte that is not part
/// of a valid UTF-8 sequence is read as the Windows-1252 character it
/// stands for, so the text is read as LinuxCNC reads such a file where the
/// bytes stand in comments (rs274 ignores a comment's bytes), and written
/// out again (`optimized.nc`) in UTF-8, which LinuxCNC reads with the same
/// moves. Outside a comment the character is refused by the reader at its
/// line and column, as rs274 refuses the byte ("Bad character"). The
/// warning is given in [`FileForm::Tolerant`] only; the other forms decode
/// the same way silently.
pub fn decode(bytes: Vec<u8>, file_name: &str, form: FileForm) -> (String, Option<Diagnostic>) {
    let bytes = match String::from_utf8(bytes) {
        Ok(text) => return (text, None),
        Err(e) => e.into_bytes(),
    };
    let mut text = String::with_capacity(bytes.len() + bytes.len() / 8);
    let mut first: Option<(usize, u8)> = None;
    for chunk in bytes.utf8_chunks() {
        text.push_str(chunk.valid());
        let invalid = chunk.invalid();
        if invalid.is_empty() {
            continue;
        }
        first.get_or_insert((text.len(), invalid[0]));
        let (decoded, _) = encoding_rs::WINDOWS_1252.decode_without_bom_handling(invalid);
        text.push_str(&decoded);
    }
    let warning = match (first, form) {
        (Some((at, byte)), FileForm::Tolerant) => {
            let (line, column) = line_and_column(&text[..at]);
            Some(Diagnostic {
                file: file_name.to_owned(),
                line,
                column,
                message: format!(
                    "byte 0x{byte:02X} at column {column} is not UTF-8: the file's bytes that are not UTF-8 are read as Windows-1252 ('{}' here), which LinuxCNC reads only in comments; optimized.nc is written in UTF-8",
                    text[at..].chars().next().unwrap_or('?')
                ),
                severity: Severity::Warning,
            })
        }
        _ => None,
    };
    (text, warning)
}

/// 1-based line and character column of the character after `prefix`,
/// lines split as the reader splits them (`\n`, `\r\n` or `\r`).
fn line_and_column(prefix: &str) -> (u32, u32) {
    let mut line = 0u32;
    let mut last = "";
    let mut ended = true;
    for (text, eol) in split_lines(prefix) {
        line += 1;
        last = text;
        ended = !eol.is_empty();
    }
    if ended {
        (line + 1, 1)
    } else {
        (line.max(1), last.chars().count() as u32 + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Windows-1252 comment: decoded, its UTF-8 neighbours kept, the
    /// warning at the first such byte's line and character column.
    #[test]
    fn bytes_that_are_not_utf8_are_read_as_windows_1252() {
        let bytes = b"G21 (\xc3\xbc)\r\n(T1 D=6 CR=0 - Fr\xe4ser \x80)\nG0 X1\n".to_vec();
        let (text, warning) = decode(bytes, "p.nc", FileForm::Tolerant);
        assert_eq!(text, "G21 (ü)\r\n(T1 D=6 CR=0 - Fräser €)\nG0 X1\n");
        let w = warning.expect("a warning");
        assert_eq!((w.line, w.column), (2, 18), "{w}");
        assert!(!w.is_error());
        assert!(w.message.contains("0xE4"), "{w}");
        let (same, none) = decode(b"G0 X1\r(\xe4)".to_vec(), "p.nc", FileForm::LinuxCnc);
        assert_eq!((same.as_str(), none), ("G0 X1\r(ä)", None));
        let (_, w) = decode(b"G0 X1\r\xe4".to_vec(), "p.nc", FileForm::Tolerant);
        assert_eq!(w.map(|w| (w.line, w.column)), Some((2, 1)));
        let (text, w) = decode(b"G0 X1\n".to_vec(), "p.nc", FileForm::Tolerant);
        assert_eq!((text.as_str(), w), ("G0 X1\n", None));
    }
}
