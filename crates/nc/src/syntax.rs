//! Lexing and parsing of one source line into an unevaluated block.
//!
//! As in LinuxCNC, a line is read case-insensitively with spaces and tabs
//! ignored outside comments (`G 1 X 1 . 5` is `G1X1.5`). Parenthesised and
//! `;` comments are dropped. Columns are 1-based character columns in the
//! original line; byte spans let the re-feed writer edit words in place.

use std::ops::Range;

use crate::cursor::{Cursor, SyntaxError};
use crate::expr::{self, Expr, ParamRef};

/// The UTF-8 byte-order mark some editors write before the first line.
pub(crate) const BYTE_ORDER_MARK: char = '\u{feff}';

/// One word or parameter assignment of a block (40 bytes: a program's
/// lines keep one per word, all in one [`Lines`] arena).
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    /// 1-based column of the item's first character.
    pub col: u32,
    /// Byte range in the line, from the letter (or `#`) to the value's end
    /// ([`Item::span`]).
    start: u32,
    end: u32,
}

impl Item {
    /// Byte range in the line, from the letter (or `#`) to the value's end.
    pub fn span(&self) -> Range<usize> {
        self.start as usize..self.end as usize
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    /// Letter (lower case) and value, e.g. `x` and `[#1 * 2]`.
    Word { letter: char, value: Expr },
    /// `#target = value` (boxed: rare in programs, and the word stays small).
    Assign(Box<(ParamRef, Expr)>),
}

/// Label of an o-word: `o100` or `o<name>`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum OLabel {
    Number(i64),
    Name(String),
}

/// O-word keywords (LinuxCNC flow control).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OKeyword {
    Sub,
    EndSub,
    Call,
    Return,
    If,
    ElseIf,
    Else,
    EndIf,
    While,
    EndWhile,
    Do,
    Repeat,
    EndRepeat,
    Break,
    Continue,
}

const KEYWORDS: [(&str, OKeyword); 15] = [
    ("sub", OKeyword::Sub),
    ("endsub", OKeyword::EndSub),
    ("call", OKeyword::Call),
    ("return", OKeyword::Return),
    ("if", OKeyword::If),
    ("elseif", OKeyword::ElseIf),
    ("else", OKeyword::Else),
    ("endif", OKeyword::EndIf),
    ("while", OKeyword::While),
    ("endwhile", OKeyword::EndWhile),
    ("do", OKeyword::Do),
    ("repeat", OKeyword::Repeat),
    ("endrepeat", OKeyword::EndRepeat),
    ("break", OKeyword::Break),
    ("continue", OKeyword::Continue),
];

/// An o-word statement such as `o100 call [1] [2]`.
#[derive(Clone, Debug, PartialEq)]
pub struct OStmt {
    pub label: OLabel,
    pub keyword: OKeyword,
    pub args: Vec<Expr>,
    pub col: u32,
}

/// What a line holds.
#[derive(Clone, Debug, PartialEq)]
pub enum LineKind {
    /// Blank or comment only.
    Empty,
    /// A `%` program delimiter, at byte `at` and column `col` (1-based) of
    /// its line.
    Percent { at: u32, col: u32 },
    /// Words and assignments, in the [`Lines`] arena.
    Block(Items),
    /// LinuxCNC flow control.
    OWord(Box<OStmt>),
    /// Fanuc program/subprogram number `O1000` alone on its line.
    ProgramNumber(i64),
}

impl LineKind {
    /// A line whose words and assignments are the arena's `len` items from
    /// `start` (at most a line's bytes of them, so within u32): a block, or
    /// where it has none, an empty line.
    fn of_items(start: u32, len: usize) -> LineKind {
        if len == 0 {
            LineKind::Empty
        } else {
            LineKind::Block(Items {
                start,
                len: len as u32,
            })
        }
    }
}

/// A parsed line.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Starts with `/`.
    pub block_delete: bool,
    pub kind: LineKind,
}

/// Where a block's items lie in the [`Lines`] arena.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Items {
    start: u32,
    len: u32,
}

impl Items {
    /// A block whose items the arena does not keep
    /// ([`Lines::push_parsed_unkept`]): its line is parsed again where it
    /// runs.
    const UNKEPT: Items = Items {
        start: u32::MAX,
        len: 0,
    };

    /// The arena keeps the block's items.
    fn kept(self) -> bool {
        self != Items::UNKEPT
    }
}

/// Every line of a program as parsed (`None`: a syntax error), with the
/// items of all blocks in one arena: two allocations for the whole program
/// rather than one per line (a million-block program keeps about 140 MB,
/// not 350, and frees it in one piece). Or, read to be run
/// ([`Lines::push_parsed_unkept`]), with no block's items: where each line
/// begins in the source, to parse a block again where it is needed
/// ([`Lines::block_items`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lines {
    lines: Vec<Option<Line>>,
    items: Vec<Item>,
    /// Where each line begins in the source, where blocks' items are not
    /// kept; else empty.
    starts: Vec<usize>,
}

impl Lines {
    /// Parses `text` (one line without its terminator) and appends it.
    pub fn push_parsed(&mut self, text: &str) -> Result<(), SyntaxError> {
        let line = parse_line(text, &mut self.items)?;
        self.lines.push(Some(line));
        Ok(())
    }

    /// [`Lines::push_parsed`], but a block's items are not kept (the line
    /// is checked and its kind kept, 24 B, and where it begins in the
    /// source, `start`, 8 B; its items, 40 B a word, are made again where
    /// they are needed: [`Lines::block_items`]). A million-block program
    /// keeps 32 MB instead of about 190. Every line of such a reading says
    /// where it begins ([`Lines::push_start`] before a line pushed
    /// otherwise).
    pub fn push_parsed_unkept(&mut self, text: &str, start: usize) -> Result<(), SyntaxError> {
        // A plain line's words are only counted: each is a letter and a
        // decimal number, which always reads as a value.
        if let Some(words) = plain_words(text, |_| Some(())) {
            self.lines.push(Some(Line {
                block_delete: false,
                kind: if words == 0 {
                    LineKind::Empty
                } else {
                    LineKind::Block(Items::UNKEPT)
                },
            }));
            self.starts.push(start);
            return Ok(());
        }
        let first = self.items.len();
        self.push_parsed(text)?;
        self.starts.push(start);
        if let Some(Some(Line {
            kind: LineKind::Block(items),
            ..
        })) = self.lines.last_mut()
        {
            *items = Items::UNKEPT;
        }
        self.items.truncate(first);
        Ok(())
    }

    /// A line of a reading that keeps no block's items, pushed with
    /// [`Lines::push_parsed`] (its items kept: the tolerant form's mended
    /// line) or [`Lines::push_error`], begins at `start` in the source.
    pub fn push_start(&mut self, start: usize) {
        self.starts.push(start);
    }

    /// The items of block line `index`: the arena's, or where it keeps none,
    /// the line of `source` (the text these lines were read from) parsed
    /// again into `again`; None where the line is not a block.
    pub fn block_items<'s>(
        &'s self,
        index: usize,
        source: &str,
        again: &'s mut Vec<Item>,
    ) -> Option<&'s [Item]> {
        match &self.lines[index] {
            Some(Line {
                kind: LineKind::Block(items),
                ..
            }) if items.kept() => Some(self.items(*items)),
            Some(Line {
                kind: LineKind::Block(_),
                ..
            }) => Some(Self::parse_again(self.text(index, source), again)),
            _ => None,
        }
    }

    /// Block line `index`'s words as the run reads them where the arena
    /// keeps no items and the line is plain ([`parse_plain_words`]): each
    /// word's letter (lower case), column and value, as evaluating the
    /// items the general reading makes gives them (a signed number's sign
    /// applied, as `Expr::Neg` does), written into `words`; false (and
    /// `words` empty) where the line is not such a block, or has more
    /// words than `words` holds. A million-block program's lines were
    /// parsed into items again only to be evaluated: 44 % of reading and
    /// running it once (callgrind, its first 200 k lines).
    pub fn plain_block_words(
        &self,
        index: usize,
        source: &str,
        words: &mut PlainBlockWords,
    ) -> bool {
        words.len = 0;
        let unkept = matches!(
            &self.lines[index],
            Some(Line { kind: LineKind::Block(items), .. }) if !items.kept()
        );
        if !unkept {
            return false;
        }
        let text = self.text(index, source);
        let read = plain_words(text, |word| {
            let slot = words.words.get_mut(words.len)?;
            let magnitude = decimal(&text[word.digits.clone()])?;
            let value = if word.negative { -magnitude } else { magnitude };
            // Within the line, whose length is a u32 (checked by `plain_words`).
            *slot = PlainWordValue {
                letter: word.letter,
                col: word.at as u32 + 1,
                value,
            };
            words.len += 1;
            Some(())
        });
        if read.is_none() {
            words.len = 0;
        }
        read.is_some()
    }

    /// The text of line `index` of `source` (without its terminator, as
    /// [`split_lines`] gives it), in a reading that keeps no block's items.
    fn text<'t>(&self, index: usize, source: &'t str) -> &'t str {
        let from = self.starts[index];
        match self.starts.get(index + 1) {
            // Up to the next line, less this one's terminator (`\n`, `\r\n`
            // or `\r`: a `\r` always ends a line).
            Some(&next) => {
                let text = &source[from..next];
                let text = text.strip_suffix('\n').unwrap_or(text);
                text.strip_suffix('\r').unwrap_or(text)
            }
            None => {
                let rest = &source[from..];
                let end = rest.bytes().position(|b| b == b'\n' || b == b'\r');
                &rest[..end.unwrap_or(rest.len())]
            }
        }
    }

    /// The items of `text`, a line that parsed before as a block, parsed
    /// again into `again`, which holds only them.
    fn parse_again<'s>(text: &str, again: &'s mut Vec<Item>) -> &'s [Item] {
        again.clear();
        match parse_line(text, again) {
            Ok(Line {
                kind: LineKind::Block(_),
                ..
            }) => again,
            _ => unreachable!("a block line parses as one again"),
        }
    }

    /// Appends a line that did not parse.
    pub fn push_error(&mut self) {
        self.lines.push(None);
    }

    /// The items of a block whose items are kept ([`Items::kept`]).
    fn items(&self, items: Items) -> &[Item] {
        let start = items.start as usize;
        &self.items[start..start + items.len as usize]
    }

    /// Items the arena holds, and lines whose start it keeps.
    #[cfg(test)]
    pub fn held(&self) -> (usize, usize) {
        (self.items.len(), self.starts.len())
    }

    /// Frees the spare room of the arena (the lines live for the whole run).
    pub fn shrink_to_fit(&mut self) {
        self.lines.shrink_to_fit();
        self.items.shrink_to_fit();
        self.starts.shrink_to_fit();
    }
}

impl std::ops::Deref for Lines {
    type Target = [Option<Line>];
    fn deref(&self) -> &[Option<Line>] {
        &self.lines
    }
}

/// Splits a program into lines and their terminators, as LinuxCNC reads
/// them: `\n`, `\r\n` and a lone `\r` (old Mac files) all end a line.
pub fn split_lines(source: &str) -> impl Iterator<Item = (&str, &str)> {
    let bytes = source.as_bytes();
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= bytes.len() {
            return None;
        }
        let from = start;
        let mut i = from;
        while i < bytes.len() && bytes[i] != b'\n' && bytes[i] != b'\r' {
            i += 1;
        }
        let eol_len = match (bytes.get(i), bytes.get(i + 1)) {
            (Some(b'\r'), Some(b'\n')) => 2,
            (Some(_), _) => 1,
            (None, _) => 0,
        };
        start = i + eol_len;
        Some((&source[from..i], &source[i..i + eol_len]))
    })
}

/// Parses one line (without its line terminator); a block's items are
/// appended to `arena` (nothing is left there on an error).
pub fn parse_line(text: &str, arena: &mut Vec<Item>) -> Result<Line, SyntaxError> {
    if let Some(line) = parse_plain_words(text, arena) {
        return Ok(line);
    }
    let first = arena.len();
    let line = parse_line_into(text, arena);
    if line.is_err() {
        arena.truncate(first);
    }
    line
}

/// The line as [`parse_line_into`] reads it where it is a block of plain
/// words, or None (the arena as it was) where it holds anything else.
///
/// A plain line is ASCII: blanks, an optional line number first (`N12`),
/// then words, each a letter other than N and O followed at once by at most
/// one sign and an unsigned decimal number (`X-1.5`, `g1`, `F.5`), the words
/// apart or not (`G1X2`). That is what CAM systems write on nearly every
/// motion line; a comment, a parameter, an expression, a blank inside a word
/// or anything malformed leaves the line to the general reading, which
/// reports its errors. The items, values, columns and spans are those the
/// general reading makes (test `plain_words_read_as_the_general_reading_does`),
/// without its character list, its number texts or its error paths: a
/// program's lines are read twice ([`Lines::push_parsed_unkept`], then
/// [`Lines::block_items`]), and these were half of reading a million-block
/// program.
fn parse_plain_words(text: &str, arena: &mut Vec<Item>) -> Option<Line> {
    let arena_start = u32::try_from(arena.len()).ok()?;
    let first = arena.len();
    let words = plain_words(text, |word| {
        let num = Expr::Num(text[word.digits.clone()].parse().ok()?);
        let value = if word.negative {
            Expr::Neg(Box::new(num))
        } else {
            num
        };
        // Within the line, whose length is a u32 (checked by `plain_words`).
        arena.push(Item {
            kind: ItemKind::Word {
                letter: word.letter,
                value,
            },
            col: word.at as u32 + 1,
            start: word.at as u32,
            end: word.digits.end as u32,
        });
        Some(())
    });
    let Some(words) = words else {
        arena.truncate(first);
        return None;
    };
    Some(Line {
        block_delete: false,
        kind: LineKind::of_items(arena_start, words),
    })
}

/// The value of an unsigned decimal number (digits with at most one
/// point), as `str::parse` gives it, bit for bit: where its digits make an
/// integer below 2^53 and at most 22 of them follow the point, that integer
/// and the power of ten are exact doubles and one division rounds their
/// quotient correctly (Clinger's fast path); else `str::parse`.
fn decimal(digits: &str) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let bytes = digits.as_bytes();
    if bytes.len() <= 16 {
        let mut mantissa = 0u64;
        let mut after_point: Option<usize> = None;
        for (i, &b) in bytes.iter().enumerate() {
            match b {
                b'0'..=b'9' => mantissa = mantissa * 10 + u64::from(b - b'0'),
                b'.' => after_point = Some(bytes.len() - 1 - i),
                _ => return digits.parse().ok(),
            }
        }
        // At most 16 digits: below 10^16, so the test is the bound.
        if mantissa < 1 << 53 {
            return Some(mantissa as f64 / POW10[after_point.unwrap_or(0)]);
        }
    }
    digits.parse().ok()
}

/// One word of a plain block line as the run reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlainWordValue {
    /// Its letter, lower case.
    pub letter: char,
    /// Its 1-based column.
    pub col: u32,
    /// Its value, the sign applied.
    pub value: f64,
}

/// The words of a plain block line as the run reads them
/// ([`Lines::plain_block_words`]), in the line's order; room for 16, which
/// CAM systems' lines hold.
#[derive(Clone)]
pub struct PlainBlockWords {
    words: [PlainWordValue; 16],
    len: usize,
}

impl Default for PlainBlockWords {
    fn default() -> Self {
        PlainBlockWords {
            words: [PlainWordValue {
                letter: '\0',
                col: 0,
                value: 0.0,
            }; 16],
            len: 0,
        }
    }
}

impl PlainBlockWords {
    /// The words read.
    pub fn words(&self) -> &[PlainWordValue] {
        &self.words[..self.len]
    }
}

/// One word of a plain line: its letter (lower case) at byte `at`, its sign
/// and the bytes of its unsigned number.
struct PlainWord {
    letter: char,
    at: usize,
    negative: bool,
    digits: Range<usize>,
}

/// The words of `text` where it is a plain line ([`parse_plain_words`]),
/// each given to `word` in turn: their count, or None where the line is not
/// plain or `word` says None (after some words, maybe).
fn plain_words(text: &str, mut word: impl FnMut(PlainWord) -> Option<()>) -> Option<usize> {
    let bytes = text.as_bytes();
    u32::try_from(bytes.len()).ok()?;
    let is_blank = |b: u8| b.is_ascii() && char::from(b).is_whitespace();
    // An unsigned decimal number from `i` (digits with at most one point,
    // at least one digit), as `Cursor::number` reads it: its end, or None.
    let number_end = |i: usize| {
        let mut end = i;
        let mut dots = 0;
        let mut digits = 0;
        while let Some(&b) = bytes.get(end) {
            match b {
                b'0'..=b'9' => digits += 1,
                b'.' => dots += 1,
                _ => break,
            }
            end += 1;
        }
        (digits > 0 && dots <= 1).then_some(end)
    };
    // After a number, blanks, then a letter or the end: a digit or point
    // would continue the number in the general reading (blanks are dropped
    // there), anything else is not plain.
    let next_word = |mut i: usize| {
        while bytes.get(i).is_some_and(|&b| is_blank(b)) {
            i += 1;
        }
        match bytes.get(i) {
            None => Some(i),
            Some(b) if b.is_ascii_alphabetic() => Some(i),
            Some(_) => None,
        }
    };
    let mut i = next_word(0)?;
    if matches!(bytes.get(i), Some(b'n' | b'N')) {
        i = next_word(number_end(i + 1)?)?;
    }
    let mut words = 0;
    while let Some(&b) = bytes.get(i) {
        let letter = char::from(b.to_ascii_lowercase());
        if letter == 'n' || letter == 'o' {
            return None;
        }
        let sign = bytes.get(i + 1).filter(|&&b| b == b'-' || b == b'+');
        let start = i + 1 + usize::from(sign.is_some());
        let end = number_end(start)?;
        word(PlainWord {
            letter,
            at: i,
            negative: sign == Some(&b'-'),
            digits: start..end,
        })?;
        words += 1;
        i = next_word(end)?;
    }
    Some(words)
}

fn parse_line_into(text: &str, arena: &mut Vec<Item>) -> Result<Line, SyntaxError> {
    // Item positions are u32: a line and an arena of at most 4 GiB.
    let Ok(text_len) = u32::try_from(text.len()) else {
        return Err(SyntaxError {
            col: 1,
            message: "line longer than 4 GiB".into(),
        });
    };
    let first = arena.len();
    let Ok(arena_start) = u32::try_from(first) else {
        return Err(SyntaxError {
            col: 1,
            message: "more than 4 294 967 295 words in the program".into(),
        });
    };
    let mut cur = Cursor::new(text)?;
    let block_delete = cur.eat_str("/");
    if cur.eat_str("%") {
        // As LinuxCNC ("Bad character '%' used"): the percent line holds
        // nothing else, no word and no comment (Fusion's MPCNC post writes a
        // user's start code with `% vfd enable` lines).
        let percent = text.find('%').unwrap_or(0);
        if let Some((i, _)) = text[percent + 1..]
            .char_indices()
            .find(|(_, c)| !c.is_whitespace())
        {
            let col = text[..percent + 1 + i].chars().count() as u32 + 1;
            return Err(SyntaxError {
                col,
                message: "'%' with more on its line (a percent line holds only '%')".into(),
            });
        }
        return Ok(Line {
            block_delete,
            kind: LineKind::Percent {
                at: percent as u32,
                col: text[..percent].chars().count() as u32 + 1,
            },
        });
    }
    if cur.peek() == Some('n') {
        cur.bump();
        cur.number()?;
    }
    if cur.peek() == Some('o') {
        return Ok(Line {
            block_delete,
            kind: parse_oword(&mut cur)?,
        });
    }
    while let Some(c) = cur.peek() {
        let col = cur.col();
        let start = cur.byte();
        let kind = match c {
            'a'..='z' | '@' | '^' if c != 'n' && c != 'o' => {
                cur.bump();
                if cur.peek().is_none() {
                    return Err(SyntaxError {
                        col,
                        message: format!("missing value after '{}'", c.to_ascii_uppercase()),
                    });
                }
                ItemKind::Word {
                    letter: c,
                    value: expr::parse_value(&mut cur, 0)?,
                }
            }
            '#' => {
                let target = expr::parse_param(&mut cur, 0)?;
                if !cur.eat_str("=") {
                    return Err(cur.error("expected '=' in parameter assignment"));
                }
                ItemKind::Assign(Box::new((target, expr::parse_value(&mut cur, 0)?)))
            }
            'n' => return Err(cur.error("N word not at start of line")),
            'o' => return Err(cur.error("O word not at start of line")),
            c => return Err(cur.error(&format!("unexpected character '{c}'"))),
        };
        // Byte offsets within the line: at most its length, a u32.
        let end = cur.byte_end_of_previous() as u32;
        debug_assert!(end <= text_len);
        arena.push(Item {
            kind,
            col,
            start: start as u32,
            end,
        });
    }
    Ok(Line {
        block_delete,
        kind: LineKind::of_items(arena_start, arena.len() - first),
    })
}

fn parse_oword(cur: &mut Cursor) -> Result<LineKind, SyntaxError> {
    let col = cur.col();
    cur.bump(); // 'o'
    let label = if cur.peek() == Some('<') {
        OLabel::Name(cur.angle_name("o-word name not closed with '>'")?)
    } else {
        let n = cur.number()?;
        let Some(n) = crate::gcode::integer_value(n) else {
            return Err(SyntaxError {
                col,
                message: "O number must be an integer".into(),
            });
        };
        OLabel::Number(n)
    };
    let kw_col = cur.col();
    let word: String = cur
        .rest()
        .chars()
        .take_while(char::is_ascii_alphabetic)
        .collect();
    if word.is_empty() {
        return match (label, cur.peek()) {
            (OLabel::Number(n), None) => Ok(LineKind::ProgramNumber(n)),
            _ => Err(cur.error("expected an o-word keyword (sub, call, if, while, …)")),
        };
    }
    let Some(&(_, keyword)) = KEYWORDS.iter().find(|(name, _)| *name == word) else {
        return Err(SyntaxError {
            col: kw_col,
            message: format!("unknown o-word keyword '{word}'"),
        });
    };
    cur.eat_str(&word);
    let mut args = Vec::new();
    while let Some(c) = cur.peek() {
        if c != '[' {
            return Err(cur.error(&format!("unexpected character '{c}' after o-word")));
        }
        args.push(expr::parse_value(cur, 0)?);
    }
    Ok(LineKind::OWord(Box::new(OStmt {
        label,
        keyword,
        args,
        col,
    })))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The plain reading's line and arena.
    type Plain = (Line, Vec<Item>);

    /// The general reading of `text` into an arena that already holds an
    /// item (so the lines' item ranges are checked off zero), and the plain
    /// reading's where it takes the line; None where it leaves it.
    fn both(text: &str) -> (Result<Line, SyntaxError>, Vec<Item>, Option<Plain>) {
        let held = Item {
            kind: ItemKind::Word {
                letter: 'g',
                value: Expr::Num(0.0),
            },
            col: 1,
            start: 0,
            end: 2,
        };
        let mut general = vec![held.clone()];
        let line = parse_line_into(text, &mut general);
        if line.is_err() {
            general.truncate(1);
        }
        let mut plain = vec![held.clone()];
        let fast = parse_plain_words(text, &mut plain).map(|l| (l, plain.clone()));
        if fast.is_none() {
            assert_eq!(plain, [held], "{text:?}: the plain reading left items");
        }
        (line, general, fast)
    }

    /// Every item the same, its value to the bit (a sign kept as written).
    fn same_values(a: &[Item], b: &[Item]) -> bool {
        format!("{a:?}") == format!("{b:?}")
            && a.iter().zip(b).all(|(x, y)| match (&x.kind, &y.kind) {
                (ItemKind::Word { value: v, .. }, ItemKind::Word { value: w, .. }) => {
                    bits(v) == bits(w)
                }
                _ => false,
            })
    }

    fn bits(value: &Expr) -> Option<(bool, u64)> {
        match value {
            Expr::Num(x) => Some((false, x.to_bits())),
            Expr::Neg(inner) => match **inner {
                Expr::Num(x) => Some((true, x.to_bits())),
                _ => None,
            },
            _ => None,
        }
    }

    fn check(text: &str) -> bool {
        let (line, general, fast) = both(text);
        match fast {
            None => {
                assert_eq!(plain_words(text, |_| Some(())), None, "{text:?}");
                false
            }
            Some((fast_line, items)) => {
                assert_eq!(line.as_ref(), Ok(&fast_line), "{text:?}");
                // Counted without their values, as a reading that keeps no
                // items checks the line.
                assert_eq!(
                    plain_words(text, |_| Some(())),
                    Some(items.len() - 1),
                    "{text:?}"
                );
                assert!(
                    same_values(&general, &items),
                    "{text:?}: {general:?} against {items:?}"
                );
                true
            }
        }
    }

    /// `decimal` gives `str::parse`'s value bit for bit: integers, points
    /// first and last, leading and trailing zeros, 15 to 17 significant
    /// digits about 2^53, 22 decimals and more (the slow path).
    #[test]
    fn decimals_are_parsed_as_rust_parses_them() {
        let mut texts: Vec<String> = [
            "0",
            "0.",
            ".0",
            "00012.5000",
            "9007199254740991",
            "9007199254740992",
            "9007199254740993",
            "1234567890.123456",
            "0.1",
            "0.3",
            ".0000000000000000000001",
            "123.4567890123456789",
            "99999999999999999999",
            "5.",
            "1.0000000000000002",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // Every point position of some digit strings of 1 to 20 digits.
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let len = 1 + (seed % 20) as usize;
            let digits: String = (0..len)
                .map(|i| char::from(b'0' + ((seed >> (i * 3 % 60)) % 10) as u8))
                .collect();
            let at = (seed >> 40) as usize % (len + 2);
            texts.push(if at > len {
                digits
            } else {
                format!("{}.{}", &digits[..at], &digits[at..])
            });
        }
        for text in &texts {
            let want: f64 = text.parse().expect("a decimal");
            assert_eq!(
                decimal(text).map(f64::to_bits),
                Some(want.to_bits()),
                "{text}"
            );
        }
    }

    #[test]
    fn plain_words_read_as_the_general_reading_does() {
        for text in [
            "",
            "   \t",
            "G1 X99.5996 Y0.0000 Z-1.0581 F3000",
            "g1x-.5y+2.z3",
            "N0010 G01 X1.5",
            "n5g0x1",
            "X-0",
            "G1 X1e5",
            "M3 S12000\x0b",
        ] {
            assert!(check(text), "{text:?} is plain");
        }
        // Left to the general reading, which reads or rejects them.
        for text in [
            "G1 X1 (comment)",
            "G1 X1 ; note",
            "/G1 X1",
            "%",
            "G1 X 1",
            "G1 X1 .5",
            "G1 X1.2.3",
            "G1 X--1",
            "G1 X+-1",
            "G1 X#1",
            "G1 X[1+2]",
            "#1=2",
            "N 10 G1",
            "N10 O100 sub",
            "O100 call",
            "G1 N10",
            "G1 X1 Y",
            "G1 Xé1",
            "G1 X1 é",
            "@1 ^2",
            "G1 X-",
            "X.",
        ] {
            assert!(!check(text), "{text:?} is not plain");
        }
    }

    /// Every line of the real programs in tests/data/real (most of them
    /// plain: 51 711 of 56 620 lines): the plain reading reads what the
    /// general reading reads.
    #[test]
    fn plain_words_of_real_programs_read_as_the_general_reading_does() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
        let (mut lines, mut plain) = (0, 0);
        for entry in std::fs::read_dir(dir).unwrap() {
            let bytes = std::fs::read(entry.unwrap().path()).unwrap();
            let source = String::from_utf8_lossy(&bytes);
            for (text, _) in split_lines(&source) {
                lines += 1;
                plain += usize::from(check(text));
            }
        }
        assert!(
            lines > 50_000 && plain * 10 > lines * 8,
            "{plain} of {lines}"
        );
    }

    /// A reading that keeps no items holds, line for line, what it held when
    /// every line was parsed with its values and its items then dropped.
    #[test]
    fn unkept_plain_lines_are_the_parsed_lines_without_their_items() {
        let source =
            "G21 G90\nN10 G1 X1 Y-2.5 F300\n\n(comment)\nG1 X#1\n  \ng2x1y1i.5j0\nG1 X1 .5\n%\n";
        let mut unkept = Lines::default();
        let mut oracle = Lines::default();
        let mut start = 0;
        for (text, eol) in split_lines(source) {
            let got = unkept.push_parsed_unkept(text, start);
            let first = oracle.items.len();
            let want = oracle.push_parsed(text).map(|()| {
                if let Some(Some(Line {
                    kind: LineKind::Block(items),
                    ..
                })) = oracle.lines.last_mut()
                {
                    *items = Items::UNKEPT;
                }
                oracle.items.truncate(first);
                oracle.starts.push(start);
            });
            if want.is_err() {
                oracle.push_error();
                unkept.push_error();
                oracle.starts.push(start);
                unkept.push_start(start);
            }
            assert_eq!(got, want, "{text:?}");
            start += text.len() + eol.len();
        }
        assert_eq!(unkept, oracle);
        assert_eq!(unkept.held().0, 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Lines made of words, numbers, signs, blanks and the characters
        /// that are not plain: where the plain reading takes one it reads
        /// what the general reading reads, and it takes every line of words.
        #[test]
        fn plain_reading_agrees_on_any_line(
            parts in prop::collection::vec(prop::sample::select(vec![
                "G", "x", "Y", "n", "N", "o", "O", "e", "-", "+", ".", "0", "1", "5", "99",
                " ", "\t", "\x0b", "(", ")", ";", "#", "[", "]", "=", "/", "%", "é", "@",
            ]), 0..14),
            words in prop::collection::vec(
                (prop::sample::select(vec!['G', 'x', 'Y', 'z', 'F', 'i', 'M']),
                 prop::sample::select(vec!["", "-", "+"]),
                 0u32..100_000, 0usize..5, any::<bool>(),
                 prop::sample::select(vec!["", " ", "  ", "\t"])),
                0..8),
        ) {
            check(&parts.concat());
            let mut line = String::new();
            for (letter, sign, value, point, lead, blank) in &words {
                let digits = value.to_string();
                let at = (*point).min(digits.len());
                let number = if *lead { format!(".{digits}") } else {
                    format!("{}.{}", &digits[..at], &digits[at..])
                };
                line.push_str(&format!("{letter}{sign}{number}{blank}"));
            }
            // Words apart by blanks or not at all are plain.
            prop_assert!(check(&line), "{:?}", line);
        }
    }
}
