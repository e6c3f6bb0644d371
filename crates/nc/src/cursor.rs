//! The cursor over the normalised characters of one source line (lower
//! case, blanks and comments dropped) that the line and expression parsers
//! read with, and the syntax error it reports.

/// A syntax error at a column of a line.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntaxError {
    /// 1-based character column.
    pub col: u32,
    pub message: String,
}

/// Characters a cursor holds room for from the start (a line's bytes, up to
/// this): a program's line is read without growing its buffer again and
/// again (a fifth of a million-block program's reading went to that), a
/// long one grows from there.
const LINE_CAPACITY: usize = 256;

#[derive(Clone, Copy, Debug)]
struct Char {
    c: char,
    col: u32,
    byte: usize,
    len: usize,
}

/// A cursor over the normalised (lower-case, blank- and comment-free)
/// characters of a line.
pub struct Cursor {
    chars: Vec<Char>,
    pos: usize,
    end_col: u32,
}

impl Cursor {
    /// The normalised characters of `text`, or the error of an unclosed or
    /// nested comment.
    pub(crate) fn new(text: &str) -> Result<Cursor, SyntaxError> {
        let mut chars = Vec::with_capacity(text.len().min(LINE_CAPACITY));
        let mut comment_start: Option<u32> = None;
        let mut col = 0u32;
        for (byte, c) in text.char_indices() {
            col += 1;
            if let Some(start) = comment_start {
                if c == ')' {
                    comment_start = None;
                } else if c == '(' {
                    return Err(SyntaxError {
                        col,
                        message: format!("nested comment (comment opened at column {start})"),
                    });
                }
                continue;
            }
            match c {
                '(' => comment_start = Some(col),
                ';' => break,
                c if c.is_whitespace() => {}
                c => chars.push(Char {
                    c: c.to_ascii_lowercase(),
                    col,
                    byte,
                    len: c.len_utf8(),
                }),
            }
        }
        if let Some(start) = comment_start {
            return Err(SyntaxError {
                col: start,
                message: "comment not closed with ')'".into(),
            });
        }
        Ok(Cursor {
            chars,
            pos: 0,
            end_col: col + 1,
        })
    }

    /// Current character, if any.
    pub fn peek(&self) -> Option<char> {
        self.chars.get(self.pos).map(|c| c.c)
    }

    /// Advances by one character.
    pub fn bump(&mut self) {
        self.pos = (self.pos + 1).min(self.chars.len());
    }

    /// Column of the current character (one past the line at its end).
    pub fn col(&self) -> u32 {
        self.chars.get(self.pos).map_or(self.end_col, |c| c.col)
    }

    /// Byte offset in the line of the current character (0 at the end).
    pub(crate) fn byte(&self) -> usize {
        self.chars.get(self.pos).map_or(0, |c| c.byte)
    }

    /// Byte offset in the line just past the previous character.
    pub(crate) fn byte_end_of_previous(&self) -> usize {
        self.pos
            .checked_sub(1)
            .and_then(|i| self.chars.get(i))
            .map_or(0, |c| c.byte + c.len)
    }

    /// Consumes `text` (lower case) if the input continues with it.
    pub fn eat_str(&mut self, text: &str) -> bool {
        let n = text.chars().count();
        let matches = self.chars.len() >= self.pos + n
            && self.chars[self.pos..self.pos + n]
                .iter()
                .map(|c| c.c)
                .eq(text.chars());
        if matches {
            self.pos += n;
        }
        matches
    }

    /// Consumes the first entry of `table` whose text (lower case) the input
    /// continues with, and returns its value.
    pub fn eat_any<T: Copy>(&mut self, table: &[(&str, T)]) -> Option<T> {
        table
            .iter()
            .find(|(text, _)| self.eat_str(text))
            .map(|&(_, value)| value)
    }

    /// Reads `<name>` (the cursor is on `<`) and returns the name;
    /// `unclosed` is the error message when no `>` follows.
    pub fn angle_name(&mut self, unclosed: &str) -> Result<String, SyntaxError> {
        self.bump(); // '<'
        let mut name = String::new();
        loop {
            match self.peek() {
                Some('>') => break,
                Some(c) => name.push(c),
                None => return Err(self.error(unclosed)),
            }
            self.bump();
        }
        self.bump(); // '>'
        Ok(name)
    }

    /// The rest of the normalised line.
    pub fn rest(&self) -> String {
        self.chars[self.pos..].iter().map(|c| c.c).collect()
    }

    /// An error at the current column.
    pub fn error(&self, message: &str) -> SyntaxError {
        SyntaxError {
            col: self.col(),
            message: message.to_owned(),
        }
    }

    /// Reads an unsigned decimal number (`12`, `1.5`, `.5`, `3.`).
    pub fn number(&mut self) -> Result<f64, SyntaxError> {
        let start_col = self.col();
        let mut text = String::new();
        let mut seen_dot = false;
        while let Some(c) = self.peek() {
            if c.is_ascii_digit() {
                text.push(c);
            } else if c == '.' {
                if seen_dot {
                    return Err(SyntaxError {
                        col: start_col,
                        message: format!("malformed number '{text}.'"),
                    });
                }
                seen_dot = true;
                text.push(c);
            } else {
                break;
            }
            self.bump();
        }
        if !text.chars().any(|c| c.is_ascii_digit()) {
            return Err(SyntaxError {
                col: start_col,
                message: "expected digits in number".into(),
            });
        }
        text.parse().map_err(|_| SyntaxError {
            col: start_col,
            message: format!("malformed number '{text}'"),
        })
    }
}
