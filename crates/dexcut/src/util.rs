//! General helpers of every layer: heap marks between phases, the CSV
//! number format and atomic JSON writes.

use std::path::Path;

use serde::Serialize;

use crate::error::{Error, Result};

/// With the `heap-marks` feature, prints the heap now and its peak since the
/// last mark, after `phase` (the `dexcut` binary's counting allocator:
/// BENCHMARKS.md); without it, nothing (an empty function).
#[inline(always)]
pub(crate) fn heap_mark(phase: std::fmt::Arguments<'_>) {
    #[cfg(feature = "heap-marks")]
    heapmarks::mark(&phase.to_string());
    #[cfg(not(feature = "heap-marks"))]
    let _ = phase;
}

/// Compact number formatting for CSV (shortest round-trip form).
pub fn fmt(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v}")
    }
}

/// A length or number for messages, at most four decimals, trailing zeros
/// dropped: 6.35, 12.7, 0.7938, 4.
pub(crate) fn short(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Write any serialisable value as pretty JSON, atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    export::atomic::write_file(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    })
    .map_err(|e| Error::io("cannot write", path, e))
}
