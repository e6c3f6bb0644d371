//! A column's top material interval ([`Top`]): what a stock holds for
//! every column, and what its size per column ([`crate::grid::BYTES_PER_COLUMN`])
//! is made of.

/// A column's top material interval: the stock holds its `hi` (the
/// column's top, −∞ where empty: the sweep kernel's test of a column reads
/// it alone) and its `lo` in [`Bottoms`](crate::stock::Bottoms). The
/// intervals below it, where a column holds more than one (undercuts,
/// voids), live in the side table of its row
/// ([`RowBelow`](crate::stock::RowBelow)). Empty: `lo > hi` (then nothing
/// lies below either).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Top {
    /// Bottom of the top interval, mm.
    pub(crate) lo: f32,
    /// Top of the top interval, mm.
    pub(crate) hi: f32,
}

impl Top {
    /// No material (`lo` = +∞ above `hi` = −∞).
    pub(crate) const EMPTY: Top = Top {
        lo: f32::INFINITY,
        hi: f32::NEG_INFINITY,
    };
}
