//! The words of a re-fed line: F words, the axis and centre words of each
//! piece, and a line split into one block per piece.

use crate::expr::Expr;
use crate::interp::SegmentTrace;
use crate::path::{Geometry, Segment};
use crate::syntax::{Item, ItemKind};

pub(super) fn valid_pieces(pieces: &[(f64, f64)]) -> bool {
    let mut prev = 0.0;
    for &(frac, feed) in pieces {
        if !(frac > prev && frac <= 1.0 && feed > 0.0 && feed.is_finite()) {
            return false;
        }
        prev = frac;
    }
    prev == 1.0
}

pub(super) fn lowest(pieces: &[(f64, f64)]) -> f64 {
    pieces.iter().map(|p| p.1).fold(f64::INFINITY, f64::min)
}

fn word_letter(item: &Item) -> Option<char> {
    match &item.kind {
        ItemKind::Word { letter, .. } => Some(*letter),
        ItemKind::Assign { .. } => None,
    }
}

/// A line may be split when its one feed segment is a plain G1/G2/G3 move:
/// no G53 (machine coordinates), no dwell or program stop in the block, G and
/// M codes written as numbers, no multi-turn arc. Polar words (`@`, `^`) are
/// written as the X and Y of each piece ([`block_axes`]).
pub(super) fn splittable(items: &[Item], seg: &Segment) -> bool {
    let plain_codes = items.iter().all(|it| match &it.kind {
        ItemKind::Word {
            letter: 'g',
            value: Expr::Num(v),
        } => ![4.0, 53.0].contains(v),
        ItemKind::Word {
            letter: 'm',
            value: Expr::Num(v),
        } => ![0.0, 1.0, 2.0, 30.0, 60.0].contains(v),
        ItemKind::Word {
            letter: 'g' | 'm', ..
        } => false,
        _ => true,
    });
    let multi_turn = matches!(seg.geometry, Geometry::Arc { sweep_rad, .. } if sweep_rad > std::f64::consts::TAU + 1e-9);
    plain_codes && !multi_turn
}

/// `F` word for a feed in mm/min over a piece `length_mm` long, six significant
/// digits (at least three decimals) rounded down, so the feed never exceeds it. `in_original_line`: the F word is read with
/// the units in force before the line (a G20/G21 in it comes after F).
pub(super) fn f_word(
    t: &SegmentTrace,
    feed_mm_min: f64,
    length_mm: f64,
    in_original_line: bool,
) -> String {
    let scale = if in_original_line {
        t.feed_scale
    } else {
        t.scale
    };
    let value = if t.inverse_time {
        feed_mm_min / length_mm
    } else {
        feed_mm_min / scale
    };
    // Six significant digits (at least three decimals), rounded down.
    // (A feed of 0, refused before any F word is written, would give
    // log10 = −∞, i32::MIN: wrapped, as a release build always did, to 3
    // decimals, not a panic.)
    let magnitude = value.abs().log10().floor() as i32;
    let decimals = 5i32.wrapping_sub(magnitude).clamp(3, 8);
    let unit = 10f64.powi(decimals);
    // The feed is q / unit: its digits, `decimals` of them after the point.
    let q = (value * unit * (1.0 + 1e-12)).floor().max(1.0);
    format!("F{}", fixed_point(q, decimals as usize))
}

/// `q / 10^decimals` (q a whole number at least 1, decimals ≤ 8) as
/// `trim_number(&format!("{v:.decimals$}"))` writes v = q / 10^decimals,
/// without the float formatting where q < 2⁵⁰: v is within 2⁻⁵³·v of
/// q / 10^decimals, far less than half the last decimal, so its digits
/// rounded to `decimals` places are q's (test
/// `fixed_point_writes_what_float_formatting_writes`).
fn fixed_point(q: f64, decimals: usize) -> String {
    if !(1.0..(1u64 << 50) as f64).contains(&q) {
        let v = q / 10f64.powi(decimals as i32);
        return trim_number(&format!("{v:.decimals$}"));
    }
    let digits = format!("{:0width$}", q as u64, width = decimals + 1);
    let (whole, fraction) = digits.split_at(digits.len() - decimals);
    let fraction = fraction.trim_end_matches('0');
    if fraction.is_empty() {
        whole.to_string()
    } else {
        format!("{whole}.{fraction}")
    }
}

pub(super) fn f_value(word: &str) -> f64 {
    word[1..].parse().unwrap_or(f64::INFINITY)
}

pub(super) fn trim_number(s: &str) -> String {
    if s.contains('.') {
        let t = s.trim_end_matches('0').trim_end_matches('.');
        if t.is_empty() || t == "-" || t == "-0" {
            "0".into()
        } else {
            t.into()
        }
    } else {
        s.into()
    }
}

pub(super) fn coord(v: f64) -> String {
    trim_number(&format!("{v:.6}"))
}

/// The line with its F word replaced by (or, without one, followed by) `f`.
pub(super) fn with_f_word(text: &str, items: &[Item], f: &str) -> String {
    if let Some(it) = items.iter().find(|it| word_letter(it) == Some('f')) {
        format!(
            "{}{}{}",
            &text[..it.span().start],
            f,
            &text[it.span().end..]
        )
    } else {
        let end = items.last().map_or(text.len(), |it| it.span().end);
        format!("{} {}{}", &text[..end], f, &text[end..])
    }
}

/// Axis and centre words of one piece from `from` to `to` (machine mm), as
/// (letter, value as written). `axes`: which of X, Y, Z to write (the others
/// keep their value).
pub(super) fn piece_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    from: [f64; 3],
    to: [f64; 3],
    written_start: &mut [f64; 3],
) -> Vec<(char, f64)> {
    let mut w = Vec::new();
    let written = |v: f64| coord(v).parse::<f64>().unwrap_or(v);
    for (i, l) in ['x', 'y', 'z']
        .into_iter()
        .enumerate()
        .filter(|&(i, _)| axes[i])
    {
        let v = if t.incremental {
            // Increments from the position written so far, so rounding never accumulates.
            let target = (to[i] - t.offset_mm[i]) / t.scale;
            let inc = written(target - written_start[i]);
            written_start[i] += inc;
            inc
        } else {
            written((to[i] - t.offset_mm[i]) / t.scale)
        };
        w.push((l, v));
    }
    if let Geometry::Arc { center, plane, .. } = seg.geometry {
        let (a, b, _) = plane.axes();
        let mut axes = [a, b];
        axes.sort_unstable();
        for axis in axes {
            let v = if t.arc_incremental {
                (center[axis] - from[axis]) / t.scale
            } else {
                (center[axis] - t.offset_mm[axis]) / t.scale
            };
            w.push((['i', 'j', 'k'][axis], written(v)));
        }
    }
    w
}

/// The words of every block a segment is split into, F last: axis and
/// centre values as written, F as [`f_word`] writes it (the first block's
/// read with the units in force before the line).
pub(super) fn block_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    pieces: &[(f64, f64)],
) -> Vec<Vec<(char, f64)>> {
    // Program coordinates written so far (for increments under G91).
    let mut written: [f64; 3] = std::array::from_fn(|i| (seg.start[i] - t.offset_mm[i]) / t.scale);
    pieces_values(seg, t, axes, pieces, &mut written, true)
}

/// [`block_values`] from the position `written` so far (program
/// coordinates, updated to the last block's end as written);
/// `in_original_line`: the first block's F is read in the units in force
/// before the line ([`f_word`]), else every F in the segment's own units.
pub(super) fn pieces_values(
    seg: &Segment,
    t: &SegmentTrace,
    axes: [bool; 3],
    pieces: &[(f64, f64)],
    written: &mut [f64; 3],
    in_original_line: bool,
) -> Vec<Vec<(char, f64)>> {
    let fractions: Vec<f64> = std::iter::once(0.0)
        .chain(pieces.iter().map(|p| p.0))
        .collect();
    let points: Vec<[f64; 3]> = fractions
        .iter()
        .map(|&u| {
            if u >= 1.0 {
                seg.end.into()
            } else {
                seg.point_at_fraction(u).into()
            }
        })
        .collect();
    // Lines and arcs (helices included) run at constant speed in the fraction.
    let length_mm = seg.length_mm();
    (0..pieces.len())
        .map(|k| {
            let mut words = piece_values(seg, t, axes, points[k], points[k + 1], written);
            let f = f_word(
                t,
                pieces[k].1,
                length_mm * (fractions[k + 1] - fractions[k]),
                in_original_line && k == 0,
            );
            words.push(('f', f_value(&f)));
            words
        })
        .collect()
}

/// Words of one block as text, each followed by a blank but the last.
pub(super) fn words_text(words: impl Iterator<Item = (char, String)>) -> String {
    let parts: Vec<String> = words
        .map(|(l, v)| format!("{}{v}", l.to_ascii_uppercase()))
        .collect();
    parts.join(" ")
}

/// G1, G2 or G3.
pub(super) fn motion_word(geometry: &Geometry) -> &'static str {
    match geometry {
        Geometry::Arc {
            clockwise: true, ..
        } => "G2",
        Geometry::Arc {
            clockwise: false, ..
        } => "G3",
        Geometry::Line => "G1",
    }
}

pub(super) fn plane_of(geometry: &Geometry) -> Option<crate::path::Plane> {
    match geometry {
        Geometry::Arc { plane, .. } => Some(*plane),
        Geometry::Line => None,
    }
}

/// Axes a block of the line writes: those the line names (X and Y for polar
/// `@`/`^` words, which the blocks replace), those that move, and an arc's
/// plane axes.
pub(super) fn block_axes(items: &[Item], seg: &Segment) -> [bool; 3] {
    let plane_axes = plane_of(&seg.geometry).map(|p| p.axes());
    let polar = items
        .iter()
        .any(|it| matches!(word_letter(it), Some('@' | '^')));
    std::array::from_fn(|i| {
        let named = items
            .iter()
            .any(|it| word_letter(it) == Some(['x', 'y', 'z'][i]))
            || (polar && i < 2);
        named || seg.start[i] != seg.end[i] || plane_axes.is_some_and(|(a, b, _)| i == a || i == b)
    })
}

/// Writes the line carrying the first piece and one block per further piece.
pub(super) fn split_line(
    out: &mut String,
    text: &str,
    eol: &str,
    items: &[Item],
    seg: &Segment,
    t: &SegmentTrace,
    pieces: &[(f64, f64)],
) {
    let blocks: Vec<String> = block_values(seg, t, block_axes(items, seg), pieces)
        .into_iter()
        .map(|b| {
            words_text(b.into_iter().map(|(l, v)| {
                let text = if l == 'f' {
                    trim_number(&format!("{v:.8}"))
                } else {
                    coord(v)
                };
                (l, text)
            }))
        })
        .collect();
    write_blocks(out, text, eol, items, &seg.geometry, &blocks);
}

/// Writes the line with its axis, centre and F words replaced by `blocks[0]`,
/// then one block per further entry of `blocks` in the line's motion mode.
pub(super) fn write_blocks(
    out: &mut String,
    text: &str,
    eol: &str,
    items: &[Item],
    geometry: &Geometry,
    blocks: &[String],
) {
    let arc = matches!(geometry, Geometry::Arc { .. });
    // Words the pieces rewrite: axes (polar ones too), arc centre / radius / turns, feed.
    let replaced: Vec<&Item> = items
        .iter()
        .filter(|it| match word_letter(it) {
            Some('x' | 'y' | 'z' | 'f' | '@' | '^') => true,
            Some('i' | 'j' | 'k' | 'r' | 'p') => arc,
            _ => false,
        })
        .collect();
    let first = &blocks[0];
    let mut line = String::with_capacity(text.len() + first.len());
    let mut at = 0;
    for (k, it) in replaced.iter().enumerate() {
        let gap = &text[at..it.span().start];
        // Blanks between two rewritten words go with them.
        if k == 0 || !gap.trim().is_empty() {
            line.push_str(gap);
        }
        if k == 0 {
            line.push_str(first);
        }
        at = it.span().end;
    }
    if replaced.is_empty() {
        let end = items.last().map_or(text.len(), |it| it.span().end);
        line.push_str(&text[..end]);
        line.push(' ');
        line.push_str(first);
        at = end;
    }
    line.push_str(&text[at..]);
    out.push_str(&line);
    out.push_str(eol_or_newline(eol));
    for (k, block) in blocks.iter().enumerate().skip(1) {
        out.push_str(motion_word(geometry));
        out.push(' ');
        out.push_str(block);
        out.push_str(if k + 1 == blocks.len() {
            eol
        } else {
            eol_or_newline(eol)
        });
    }
}

pub(super) fn eol_or_newline(eol: &str) -> &str {
    if eol.is_empty() {
        "\n"
    } else {
        eol
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The digits written without float formatting are those of the
    /// formatted value, over whole numbers of every size up to 2⁵⁰ and past
    /// it, at 3 to 8 decimals.
    #[test]
    fn fixed_point_writes_what_float_formatting_writes() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for i in 0..400_000 {
            let decimals = 3 + (i % 6);
            let bits = 1 + next() % 56;
            let q = ((next() >> (64 - bits)) as f64).max(1.0);
            let v = q / 10f64.powi(decimals as i32);
            assert_eq!(
                fixed_point(q, decimals),
                trim_number(&format!("{v:.decimals$}")),
                "{q} at {decimals} decimals"
            );
        }
        assert_eq!(fixed_point(1.0, 3), "0.001");
        assert_eq!(fixed_point(1_200_000.0, 5), "12");
        assert_eq!(fixed_point(1_234_500.0, 3), "1234.5");
    }

    /// An F word keeps six significant digits rounded down, at least three
    /// decimals, and never goes below the last decimal (a feed of 0
    /// included, which overflowed in a debug build before 3ba618b).
    #[test]
    fn f_words_keep_six_digits_rounded_down() {
        let trace = SegmentTrace {
            line_index: 0,
            scale: 1.0,
            feed_scale: 1.0,
            incremental: false,
            arc_incremental: false,
            inverse_time: false,
            offset_mm: [0.0; 3],
            compensated: false,
            rotated: false,
            spindle_cycle: false,
        };
        for (feed, word) in [
            (1234.5678, "F1234.567"),
            (0.123456789, "F0.123456"),
            (3000.0, "F3000"),
            (250_000.0, "F250000"),
            (0.0, "F0.001"),
        ] {
            assert_eq!(f_word(&trace, feed, 1.0, false), word, "{feed}");
        }
    }
}
