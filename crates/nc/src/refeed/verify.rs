//! The check of a re-fed program: read back, against the original path and
//! the plan.

use super::words::lowest;
use super::{Expected, RefeedError, WrittenPlan};
use crate::interp::{self, Options, Parsed};
use crate::path::{Motion, Segment};

/// Parses the re-fed program and checks it against the original path and
/// plan; what it read.
pub(super) fn verify(
    out: &str,
    file: &str,
    options: &Options,
    original: &[Expected],
    plan: &WrittenPlan<'_>,
    written: &[usize],
) -> Result<Parsed, RefeedError> {
    let fail = |detail: String| RefeedError::Verification {
        file: file.to_owned(),
        detail,
    };
    // Its blocks parsed where they run, not held (a million-line text's
    // items, about 190 MB).
    let parsed = interp::parse(out, file, options);
    if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
        return Err(fail(format!("it does not parse: {d}")));
    }
    let new = &parsed.path.segments;
    let expected: usize = written.iter().sum();
    if new.len() != expected {
        return Err(fail(format!(
            "{} segments instead of {expected}",
            new.len()
        )));
    }
    let mut j = 0;
    for (i, seg) in original.iter().enumerate() {
        let pieces = &new[j..j + written[i]];
        j += written[i];
        let end = pieces[pieces.len() - 1].end;
        if (end - seg.end).norm() > 1e-3 {
            return Err(fail(format!(
                "line {}: ends at {:?} instead of {:?}",
                seg.line, end, seg.end
            )));
        }
        // Same end points can hide a changed shape: a piece of an arc shorter
        // than the written digits reads back as a full circle.
        let length_mm: f64 = pieces.iter().map(Segment::length_mm).sum();
        if (length_mm - seg.length_mm).abs() > 1e-3 {
            return Err(fail(format!(
                "line {}: {length_mm:.4} mm long instead of {:.4} mm",
                seg.line, seg.length_mm
            )));
        }
        if std::mem::discriminant(&pieces[0].motion) != std::mem::discriminant(&seg.motion) {
            return Err(fail(format!("line {}: motion kind changed", seg.line)));
        }
        if let Motion::Feed { .. } = seg.motion {
            for (k, p) in pieces.iter().enumerate() {
                let allowed = if written[i] == 1 {
                    lowest(&plan[i])
                } else {
                    plan[i][k].1
                };
                let Motion::Feed { feed_mm_min, held } = p.motion else {
                    return Err(fail(format!(
                        "line {}: a piece is not a feed move",
                        seg.line
                    )));
                };
                // A held feed (tapping) reads back held, at its own feed.
                if let Some(programmed) = seg.motion.held_feed_mm_min() {
                    if !held || (feed_mm_min - programmed).abs() > 1e-4 * programmed {
                        return Err(fail(format!(
                            "line {}: the held feed {programmed:.3} mm/min reads back as {feed_mm_min:.3} mm/min{}",
                            seg.line,
                            if held { "" } else { ", not held" }
                        )));
                    }
                } else if held {
                    return Err(fail(format!("line {}: a feed reads back held", seg.line)));
                }
                if feed_mm_min > allowed * (1.0 + 1e-4) {
                    return Err(fail(format!(
                        "line {}: feed {feed_mm_min:.3} above the plan's {allowed:.3} mm/min",
                        seg.line
                    )));
                }
            }
        }
    }
    Ok(parsed)
}
