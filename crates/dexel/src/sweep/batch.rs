//! The batch driver: checks, moves binned by strip, strips run in parallel,
//! sums reduced in a fixed order, smoothing shares applied at the end.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use super::ball::BallEnd;
use super::bull::BullNose;
use super::flat::FlatEnd;
use super::slot::{CONTACT_X, CONTACT_Y, SHANK, VOLUME};
use super::strip::{partial_width, Banding, StripJob};
use super::{
    Envelope, Prepared, RecordRow, RemovalRecord, RowSink, Step, StepSource, SubSteps,
    SweepOptions, EMPTY_OFFSETS, HEAD, PLUNGE_H2,
};
use crate::stock::{BottomsMut, RowBelow};
use crate::{Error, Grid, Stock, Tool, ToolShape};

/// Sweep `tool` along `steps` through `stock`, removing material and recording
/// what each step removed. `progress(done)` is called after each batch with
/// the number of steps finished.
pub fn sweep(
    stock: &mut Stock,
    tool: &Tool,
    steps: &[Step],
    options: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<RemovalRecord, Error> {
    let tools = std::slice::from_ref(tool);
    let sweep = Sweep::with_parts(tools, steps, options, vec![(0, steps.len(), 0)])?;
    Ok(sweep.whole(stock, progress))
}

/// Sweep steps cut by several tools: step `i` is cut by `tools[tool_of_step[i]]`.
/// Each run of consecutive steps with one tool is one [`sweep`] (in order, on
/// the same stock); the record has the band count of the tool with the most
/// bands, the others' higher bands are zero.
pub fn sweep_tools(
    stock: &mut Stock,
    tools: &[Tool],
    tool_of_step: &[usize],
    steps: &[Step],
    options: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<RemovalRecord, Error> {
    let sweep = Sweep::new(tools, tool_of_step, steps, options)?;
    Ok(sweep.whole(stock, progress))
}

/// One run of consecutive steps cut by one tool, and what they removed so far.
struct Part {
    start: usize,
    end: usize,
    tool: usize,
    banding: Banding,
    /// Full rows of every step (made at the first band), or once finished
    /// (or swept by [`Sweep::whole`]) the compact record.
    record: RemovalRecord,
    /// Per step: head values to move to the previous and to the next step
    /// (made at the first band; empty without smoothing).
    spill: Vec<f64>,
}

/// A sweep of a program through a stock held band by band (a tile band of a
/// stock too large for memory, see [`Stock::rows`]): [`Sweep::band`] sweeps
/// every step through one band of rows and adds what it removes there to the
/// per-step record; [`Sweep::finish`] gives the record once every band is
/// swept. The bands must be swept in row order and must not overlap: each
/// step's sums are then added strip by strip in the same order as one sweep
/// of the whole stock, so the record is the whole stock's bit for bit.
/// [`sweep_tools`] is one band holding every row.
///
/// The steps are any [`StepSource`]: a list held whole, or steps made as the
/// sweep asks for them (the same record bit for bit).
pub struct Sweep<'a, S: ?Sized = [Step]> {
    tools: &'a [Tool],
    steps: &'a S,
    options: SweepOptions,
    parts: Vec<Part>,
    /// The grid of the stock swept (the same for every band).
    grid: Option<Grid>,
}

impl<'a, S: StepSource + ?Sized> Sweep<'a, S> {
    /// Check the steps, tools and options and set up an empty record: step
    /// `i` is cut by `tools[tool_of_step[i]]` (see [`sweep_tools`]; the
    /// indices of any unsigned type that converts to `usize`).
    pub fn new<T: Copy + Into<usize>>(
        tools: &'a [Tool],
        tool_of_step: &[T],
        steps: &'a S,
        options: &SweepOptions,
    ) -> Result<Sweep<'a, S>, Error> {
        if tool_of_step.len() != steps.len() {
            return Err(Error::InvalidParameter(format!(
                "{} tool indices for {} steps",
                tool_of_step.len(),
                steps.len()
            )));
        }
        if let Some(bad) = tool_of_step
            .iter()
            .map(|&t| t.into())
            .find(|&t| t >= tools.len())
        {
            return Err(Error::InvalidParameter(format!(
                "tool index {bad} with {} tools",
                tools.len()
            )));
        }
        let mut runs = Vec::new();
        let mut start = 0;
        while start < steps.len() {
            let t: usize = tool_of_step[start].into();
            let end = start
                + tool_of_step[start..]
                    .iter()
                    .position(|&u| u.into() != t)
                    .unwrap_or(steps.len() - start);
            runs.push((start, end, t));
            start = end;
        }
        Sweep::with_parts(tools, steps, options, runs)
    }

    /// [`Sweep::new`] with the runs of one tool given as `(start, end, tool)`.
    fn with_parts(
        tools: &'a [Tool],
        steps: &'a S,
        options: &SweepOptions,
        runs: Vec<(usize, usize, usize)>,
    ) -> Result<Sweep<'a, S>, Error> {
        let mut parts = Vec::with_capacity(runs.len());
        for (start, end, t) in runs {
            let tool = &tools[t];
            tool.validate()?;
            if !(options.band_height_mm > 0.0 && options.band_height_mm.is_finite()) {
                return Err(Error::InvalidParameter(format!(
                    "band height must be positive, got {} mm",
                    options.band_height_mm
                )));
            }
            if let Some(i) = (0..end - start).find(|&i| {
                let s = steps.step(start + i);
                !s.from_mm.iter().chain(&s.to_mm).all(|v| v.is_finite())
            }) {
                return Err(Error::InvalidParameter(format!(
                    "step {i} has a non-finite coordinate"
                )));
            }
            let n_bands = ((tool.flute_length_mm / options.band_height_mm).ceil() as usize).max(1);
            if n_bands > 10_000 {
                return Err(Error::InvalidParameter(format!(
                    "band height {} mm gives {n_bands} bands over the flute length; use a larger band height",
                    options.band_height_mm
                )));
            }
            let banding = Banding {
                n_bands,
                band_h: options.band_height_mm,
                inv_band_h: 1.0 / options.band_height_mm,
                flute_len: tool.flute_length_mm,
            };
            parts.push(Part {
                start,
                end,
                tool: t,
                banding,
                record: RemovalRecord::new(0, n_bands, options.band_height_mm),
                spill: Vec::new(),
            });
        }
        Ok(Sweep {
            tools,
            steps,
            options: *options,
            parts,
            grid: None,
        })
    }

    /// Sweep every step through `stock` (the next band of rows, or the whole
    /// stock), removing material there and adding what each step removes to
    /// the record. `progress(done)` is called after each batch with the
    /// number of steps finished in this band.
    pub fn band(&mut self, stock: &mut Stock, progress: &(dyn Fn(usize) + Sync)) {
        self.sweep_band(stock, progress, Made::Band);
    }

    /// Sweep every step through the whole stock (one band holding every
    /// row) and give the record: [`band`](Self::band) then
    /// [`finish`](Self::finish), with each batch's steps made final
    /// (smoothing shares, plunges unbiased) and kept in compact columns as
    /// the sweep goes, so the full rows of only one batch are held at a
    /// time. The same record bit for bit.
    pub fn whole(mut self, stock: &mut Stock, progress: &(dyn Fn(usize) + Sync)) -> RemovalRecord {
        self.sweep_band(stock, progress, Made::Record);
        self.finish()
    }

    /// [`whole`](Self::whole) without a record: each step's row is given to
    /// `sink(step, row)` as the sweep makes it final, step after step in
    /// order, so no record is held. The rows are the record's bit
    /// for bit ([`RemovalRecord::step_row`]); a step's bands are its own
    /// tool's (see [`n_bands`](Self::n_bands)). Where a band was swept
    /// already, the rest of the stock is swept as one more band and the
    /// finished record given row by row ([`finish_into`](Self::finish_into)).
    /// Gives the columns visited.
    pub fn whole_into(
        mut self,
        stock: &mut Stock,
        progress: &(dyn Fn(usize) + Sync),
        sink: &mut RowSink<'_>,
    ) -> u64 {
        if self.grid.is_some() {
            self.band(stock, progress);
            return self.finish_into(sink);
        }
        self.sweep_band(stock, progress, Made::Sink(sink));
        self.parts.iter().map(|p| p.record.columns_evaluated).sum()
    }

    /// [`finish`](Self::finish), its rows given to `sink(step, row)` in
    /// order (the record is made whole first: a stock swept band by band
    /// makes no row final before its last band); gives the columns visited.
    pub fn finish_into(self, sink: &mut RowSink<'_>) -> u64 {
        let record = self.finish();
        for k in 0..record.len() {
            sink(k, record.step_row(k));
        }
        record.columns_evaluated
    }

    /// Number of steps swept.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// No steps to sweep.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Bands of the record [`finish`](Self::finish) gives: those of the tool
    /// with the most (1 where there are no steps).
    pub fn n_bands(&self) -> usize {
        self.parts
            .iter()
            .map(|p| p.banding.n_bands)
            .max()
            .unwrap_or(1)
    }

    fn sweep_band(
        &mut self,
        stock: &mut Stock,
        progress: &(dyn Fn(usize) + Sync),
        mut made: Made<'_, '_>,
    ) {
        self.grid = Some(*stock.grid());
        let grid = *stock.grid();
        for part in &mut self.parts {
            let tool = &self.tools[part.tool];
            let radius = tool.radius_mm();
            let done = part.start;
            let progress = |d: usize| progress(done + d);
            let steps = SubSteps::new(self.steps, part.start..part.end);
            let n = steps.len();
            let stride = HEAD + part.banding.n_bands;
            // A stream only on a part no band of which was swept yet (else `band`).
            let fresh = part.record.data.is_empty() && !part.record.is_compact();
            let out = match &mut made {
                Made::Record => Some(Out::Record(RemovalRecord::compact_empty(
                    part.record.n_bands,
                    part.record.band_height_mm,
                ))),
                Made::Sink(sink) => Some(Out::Sink(&mut **sink, part.start)),
                Made::Band => None,
            };
            let mut stream = if let (Some(out), true) = (out, fresh) {
                Some(Stream::new(
                    out,
                    n,
                    stride,
                    grid,
                    radius,
                    self.options.smooth,
                ))
            } else {
                // Full rows of every step, zero until swept (pages touched as they are written).
                if part.record.data.len() != n * stride {
                    part.record.data = vec![0.0; n * stride];
                    part.record.offsets = vec![EMPTY_OFFSETS; n * part.banding.n_bands];
                }
                if self.options.smooth && part.spill.len() != n * 2 * HEAD {
                    part.spill = vec![0.0; n * 2 * HEAD];
                }
                None
            };
            // One call per tool shape: `run_batches` is generic over the envelope.
            macro_rules! run {
                ($env:expr) => {
                    run_batches(
                        stock,
                        &$env,
                        radius,
                        &part.banding,
                        &steps,
                        part.start,
                        &self.options,
                        &mut part.record,
                        &mut part.spill,
                        stream.as_mut(),
                        &progress,
                    )
                };
            }
            match tool.shape {
                ToolShape::Ball => run!(BallEnd { r: radius }),
                ToolShape::Flat => run!(FlatEnd::new(radius)),
                ToolShape::Bull { corner_radius_mm } => run!(BullNose {
                    r: radius,
                    rc: corner_radius_mm,
                    ring: radius - corner_radius_mm,
                }),
            }
            if let Some(stream) = stream {
                part.spill = Vec::new();
                if let Out::Record(mut out) = stream.out {
                    let evaluated = part.record.columns_evaluated;
                    // The band volumes grew by doubling; what they hold is kept
                    // (a large block is shrunk where it lies, not copied).
                    out.bands.shrink_to_fit();
                    out.offsets.shrink_to_fit();
                    part.record = out;
                    part.record.columns_evaluated = evaluated;
                } else {
                    // Given away: only the count of columns is kept.
                    part.record.data = Vec::new();
                    part.record.offsets = Vec::new();
                }
            }
        }
    }

    /// The record of every band swept: smoothing shares applied, the runs of
    /// each tool in one record with the band count of the tool with the most
    /// bands (the others' higher bands are zero).
    pub fn finish(self) -> RemovalRecord {
        let mut parts = self.parts;
        // Parts swept by `whole` are final and compact already; those of no
        // band swept removed nothing.
        for part in parts.iter_mut().filter(|p| !p.record.is_compact()) {
            let n = part.end - part.start;
            if part.record.data.len() != n * (HEAD + part.banding.n_bands) {
                part.record.data = vec![0.0; n * (HEAD + part.banding.n_bands)];
                part.record.offsets = vec![EMPTY_OFFSETS; n * part.banding.n_bands];
            }
            if self.options.smooth && part.spill.len() != n * 2 * HEAD {
                part.spill = vec![0.0; n * 2 * HEAD];
            }
        }
        if self.options.smooth {
            for part in parts.iter_mut().filter(|p| !p.record.is_compact()) {
                apply_spill(
                    &mut part.record,
                    &SubSteps::new(self.steps, part.start..part.end),
                    &part.spill,
                );
            }
        }
        // A plunge's contact resultant without the lattice's own bias (MODEL.md §1.4).
        if let Some(grid) = &self.grid {
            for part in parts.iter_mut().filter(|p| !p.record.is_compact()) {
                let radius = self.tools[part.tool].radius_mm();
                unbias_plunges(
                    &mut part.record,
                    &SubSteps::new(self.steps, part.start..part.end),
                    grid,
                    radius,
                );
            }
        }
        // The record in compact columns, part by part.
        for part in &mut parts {
            part.record.compact();
            part.spill = Vec::new();
        }
        if parts.len() == 1 {
            // One tool: the record as it is (no copy).
            return parts.pop().expect("one part").record;
        }
        let n_bands = parts.iter().map(|p| p.record.n_bands).max().unwrap_or(1);
        let mut record = RemovalRecord::compact_empty(n_bands, self.options.band_height_mm);
        for part in &parts {
            record.append(&part.record);
        }
        record
    }
}

/// Mean over the grid's column centres within `r` of `(cx, cy)` (the
/// lattice continued beyond the stock) of the unit vector from that point to
/// the centre (zero for a centre on the point): the contact resultant per
/// unit volume that a plunge removing the same depth from every column under
/// a disc of radius `r` records, where the disc itself gives zero.
pub(super) fn lattice_disc_bias(grid: &Grid, cx: f64, cy: f64, r: f64) -> [f64; 2] {
    let s = grid.spacing_mm;
    // Centres x0 + (i + ½)s for any integer i.
    let index = |v: f64, v0: f64| (v - v0) / s - 0.5;
    let (iy0, iy1) = (
        index(cy - r, grid.y0_mm).ceil() as i64,
        index(cy + r, grid.y0_mm).floor() as i64,
    );
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0u64);
    for iy in iy0..=iy1 {
        let wy = grid.y0_mm + (iy as f64 + 0.5) * s - cy;
        let half = (r * r - wy * wy).max(0.0).sqrt();
        let (ix0, ix1) = (
            index(cx - half, grid.x0_mm).ceil() as i64 - 1,
            index(cx + half, grid.x0_mm).floor() as i64 + 1,
        );
        for ix in ix0..=ix1 {
            let wx = grid.x0_mm + (ix as f64 + 0.5) * s - cx;
            // The kernel's test of a column under a plunging disc.
            if wx * wx + wy * wy > r * r {
                continue;
            }
            n += 1;
            let dist = wx.hypot(wy);
            if dist > 1e-12 {
                sx += wx / dist;
                sy += wy / dist;
            }
        }
    }
    if n == 0 {
        [0.0, 0.0]
    } else {
        [sx / n as f64, sy / n as f64]
    }
}

/// Take the lattice's bias out of every plunge's contact resultant (MODEL.md
/// §1.4): a plunge removes whole columns whose centres lie under the tool,
/// and those centres are not symmetric about an axis between them, so an
/// evenly engaged plunge, whose cutting forces cancel over a revolution,
/// would record a resultant of a few per cent of its volume (4 % for a
/// Ø0.4 mm tool on a 0.05 mm grid) and push the tool sideways. Subtracting
/// volume × [`lattice_disc_bias`] makes an even plunge's resultant zero and
/// leaves the asymmetry of a partly engaged one.
fn unbias_plunges(
    record: &mut RemovalRecord,
    steps: &(impl StepSource + ?Sized),
    grid: &Grid,
    radius: f64,
) {
    let stride = record.stride();
    for i in 0..steps.len() {
        unbias_plunge(
            &mut record.data[i * stride..(i + 1) * stride],
            &steps.step(i),
            grid,
            radius,
        );
    }
}

/// [`unbias_plunges`] for one step's row.
fn unbias_plunge(row: &mut [f64], step: &Step, grid: &Grid, radius: f64) {
    let m = Prepared::new(step);
    if m.h2 > PLUNGE_H2 || row[VOLUME] <= 0.0 {
        return;
    }
    let [bx, by] = lattice_disc_bias(grid, m.p0[0], m.p0[1], radius);
    row[CONTACT_X] -= row[VOLUME] * bx;
    row[CONTACT_Y] -= row[VOLUME] * by;
}

/// What a sweep of the whole stock makes of its rows.
enum Made<'m, 's> {
    /// Full rows of every step, made final by [`Sweep::finish`] ([`Sweep::band`]).
    Band,
    /// A compact record, made batch by batch ([`Sweep::whole`]).
    Record,
    /// Rows given to a sink as they are made final ([`Sweep::whole_into`]).
    Sink(&'m mut RowSink<'s>),
}

/// Where a [`Stream`] puts the rows it makes final.
enum Out<'m> {
    /// Pushed onto a compact record.
    Record(RemovalRecord),
    /// Given to a sink, the part's steps numbered from the offset on.
    Sink(&'m mut RowSink<'m>, usize),
}

/// A part's record made final and compact batch by batch ([`Sweep::whole`]):
/// `run_batches` holds full rows (and smoothing shares) only for the steps
/// from `first` on; after each batch the steps whose rows can no longer
/// change get their neighbours' shares, their plunges unbiased, and go into
/// `out` in compact columns (or to a sink, [`Sweep::whole_into`]), in the
/// order [`Sweep::finish`] does all this for a whole record, so the values
/// are the same bit for bit.
struct Stream<'m> {
    /// First step whose full row is held.
    first: usize,
    /// Values a full row holds (head values, then the tool's bands).
    stride: usize,
    spill: SpillCursor,
    grid: Grid,
    radius: f64,
    smooth: bool,
    out: Out<'m>,
}

impl<'m> Stream<'m> {
    /// A stream of `n` steps' rows into `out` (a compact record's head
    /// values and band starts reserved for them: grown by doubling, they
    /// could hold up to twice as much).
    fn new(
        mut out: Out<'m>,
        n: usize,
        stride: usize,
        grid: Grid,
        radius: f64,
        smooth: bool,
    ) -> Self {
        if let Out::Record(out) = &mut out {
            out.data.reserve_exact(n * HEAD);
            out.band_start.reserve_exact(n);
        }
        Stream {
            first: 0,
            stride,
            spill: SpillCursor::default(),
            grid,
            radius,
            smooth,
            out,
        }
    }

    /// [`Stream::advance`] over a record's full rows and offset ranges.
    fn advance_record(
        &mut self,
        record: &mut RemovalRecord,
        spill: &mut Vec<f64>,
        steps: &(impl StepSource + ?Sized),
        swept: usize,
    ) {
        self.advance(&mut record.data, &mut record.offsets, spill, steps, swept);
    }

    /// Steps before `swept` are swept (their rows, offset ranges and
    /// shares, from `first` on, in `rows`, `offsets` and `spill`): make
    /// final and move out those that are.
    fn advance(
        &mut self,
        rows: &mut Vec<f64>,
        offsets: &mut Vec<[f32; 2]>,
        spill: &mut Vec<f64>,
        steps: &(impl StepSource + ?Sized),
        swept: usize,
    ) {
        let n = steps.len();
        let stride = self.stride;
        // Step i's shares move once row i + 1 is swept; rows up to i − 1 are then final.
        let final_end = if !self.smooth || swept == n {
            if self.smooth {
                self.spill.run(rows, self.first, stride, steps, spill, n);
            }
            swept
        } else {
            self.spill
                .run(rows, self.first, stride, steps, spill, swept - 1);
            (swept - 1).saturating_sub(1).max(self.first)
        };
        let done = final_end - self.first;
        let n_bands = stride - HEAD;
        for (j, row) in rows[..done * stride].chunks_exact_mut(stride).enumerate() {
            unbias_plunge(row, &steps.step(self.first + j), &self.grid, self.radius);
            let ranges = &offsets[j * n_bands..(j + 1) * n_bands];
            match &mut self.out {
                Out::Record(out) => out.push_row(row, ranges),
                Out::Sink(sink, start) => {
                    sink(*start + self.first + j, RecordRow::of_full(row, ranges))
                }
            }
        }
        rows.drain(..done * stride);
        offsets.drain(..done * n_bands);
        if self.smooth {
            spill.drain(..done * 2 * HEAD);
        }
        self.first = final_end;
    }
}

/// Whether `b` continues `a`'s motion: it starts where `a` ends, is of the same
/// kind (a rapid must not look as if it cut) and turns by less than 90° in XY.
fn continues(a: &Step, b: &Step) -> bool {
    let da = [a.to_mm[0] - a.from_mm[0], a.to_mm[1] - a.from_mm[1]];
    let db = [b.to_mm[0] - b.from_mm[0], b.to_mm[1] - b.from_mm[1]];
    a.rapid == b.rapid
        && a.to_mm
            .iter()
            .zip(&b.from_mm)
            .all(|(p, q)| (p - q).abs() <= 1e-9)
        && da[0] * db[0] + da[1] * db[1] > 0.0
}

/// Sweep `steps` (a run of one tool, from step `step0` of the program on)
/// through `stock` in batches.
#[allow(clippy::too_many_arguments)]
fn run_batches<E: Envelope, S: StepSource + ?Sized>(
    stock: &mut Stock,
    env: &E,
    radius: f64,
    banding: &Banding,
    steps: &S,
    step0: usize,
    options: &SweepOptions,
    record: &mut RemovalRecord,
    spill: &mut Vec<f64>,
    mut stream: Option<&mut Stream<'_>>,
    progress: &(dyn Fn(usize) + Sync),
) {
    let grid = *stock.grid();
    let rows = stock.rows();
    if rows.is_empty() {
        if let Some(stream) = stream {
            // Nothing to cut: every step's row is zero.
            let stride = HEAD + banding.n_bands;
            record.data.resize(steps.len() * stride, 0.0);
            record
                .offsets
                .resize(steps.len() * banding.n_bands, EMPTY_OFFSETS);
            if options.smooth {
                spill.resize(steps.len() * 2 * HEAD, 0.0);
            }
            stream.advance_record(record, spill, steps, steps.len());
        }
        progress(steps.len());
        return;
    }
    let strip_rows = options.strip_rows.max(1);
    // The strips are the whole grid's (strip s: rows s·strip_rows ..): those
    // the band holds, cut at its edges.
    let first_strip = rows.start / strip_rows;
    let n_strips = (rows.end - 1) / strip_rows + 1 - first_strip;
    let stride = HEAD + banding.n_bands;
    let width = partial_width(banding, options.smooth);
    let batch = options.batch_steps.max(1);
    // A batch ends before its moves' strip entries would need more than
    // `batch_bytes` of partial sums (a move across many strips, a wide tool
    // on a fine grid, takes many), with at least one move in it. (Their
    // ranges of lateral offsets, 8 B a band, come beside that bound: the
    // batches, and so the columns visited, are those of the sums alone.)
    let max_entries = (options.batch_bytes / (width * std::mem::size_of::<f64>())).max(1);
    let strip_span = |m: &Prepared| {
        m.row_range(&grid, radius).and_then(|(a, b)| {
            let (a, b) = (a.max(rows.start), b.min(rows.end - 1));
            (a <= b).then(|| (a / strip_rows - first_strip, b / strip_rows - first_strip))
        })
    };
    let mut done = 0;
    // Buffers kept from batch to batch: a fresh allocation of the partial sums
    // is paged in again each time.
    let mut moves: Vec<Prepared> = Vec::new();
    let mut counts: Vec<u32> = Vec::new();
    let mut fill: Vec<u32> = Vec::new();
    let mut entries: Vec<u32> = Vec::new();
    let mut partial: Vec<f64> = Vec::new();
    // Per strip entry and band, the range of lateral offsets (min/max).
    let mut ranges: Vec<[f32; 2]> = Vec::new();
    let n_bands = banding.n_bands;
    // Where the last step taken into a batch ends (each step is made once here).
    let mut last_end: Option<[f64; 3]> = None;
    // What each strip took in the last batch that ran it, ns (0: none yet).
    let cost_ns: Vec<AtomicU64> = (0..n_strips).map(|_| AtomicU64::new(0)).collect();
    while done < steps.len() {
        let first_step = done;
        // The batch's moves, binned by strip (CSR): a move joins every strip
        // of the band its footprint's rows touch.
        moves.clear();
        counts.clear();
        counts.resize(n_strips + 1, 0);
        let mut n_entries = 0;
        while first_step + moves.len() < steps.len() && moves.len() < batch {
            let g = first_step + moves.len();
            let step = steps.step(g);
            let m = Prepared {
                follows: last_end == Some(step.from_mm),
                ..Prepared::new(&step)
            };
            let span = strip_span(&m);
            let k = span.map_or(0, |(s0, s1)| s1 - s0 + 1);
            if !moves.is_empty() && n_entries + k > max_entries {
                break;
            }
            n_entries += k;
            last_end = Some(step.to_mm);
            if let Some((s0, s1)) = span {
                for s in s0..=s1 {
                    counts[s + 1] += 1;
                }
            }
            moves.push(m);
        }
        let chunk_len = moves.len();
        // Rows (and shares) held from step `base` on: every step, or from the
        // first step a stream has not made final.
        let base = stream.as_ref().map_or(0, |s| s.first);
        if stream.is_some() {
            let held = first_step + chunk_len - base;
            record.data.resize(held * stride, 0.0);
            record.offsets.resize(held * n_bands, EMPTY_OFFSETS);
            if options.smooth {
                spill.resize(held * 2 * HEAD, 0.0);
            }
        }
        for s in 0..n_strips {
            counts[s + 1] += counts[s];
        }
        if counts[n_strips] == 0 {
            // No move of the batch reaches the band.
            if let Some(stream) = stream.as_deref_mut() {
                stream.advance_record(record, spill, steps, first_step + chunk_len);
            }
            done += chunk_len;
            progress(done);
            continue;
        }
        entries.clear();
        entries.resize(counts[n_strips] as usize, 0);
        fill.clear();
        fill.extend_from_slice(&counts);
        for (i, m) in moves.iter().enumerate() {
            if let Some((s0, s1)) = strip_span(m) {
                for s in s0..=s1 {
                    entries[fill[s] as usize] = i as u32;
                    fill[s] += 1;
                }
            }
        }
        let job = StripJob {
            env,
            grid: &grid,
            radius,
            banding,
            moves: &moves,
            first_step: step0 + first_step,
            smooth: options.smooth,
        };
        // Exactly the batch's partial sums (grown by doubling, the buffer
        // kept from batch to batch could hold up to twice `batch_bytes`);
        // each strip clears its own entries on its thread (`run_strips`).
        fit_exact(&mut partial, entries.len() * width, 0.0);
        fit_exact(&mut ranges, entries.len() * n_bands, EMPTY_OFFSETS);
        let strips = Strips {
            first: first_strip,
            count: n_strips,
            rows: strip_rows,
            band: rows.clone(),
        };
        let visited = run_strips(
            &job,
            stock,
            &strips,
            (&counts, &entries),
            &mut partial,
            &mut ranges,
            &cost_ns,
        );
        record.columns_evaluated += visited;
        reduce_batch(
            Held {
                rows: &mut record.data,
                offsets: &mut record.offsets,
                spill,
                from: first_step - base,
            },
            (&counts, &entries),
            (&partial, &ranges),
            (width, stride, n_bands),
            chunk_len,
            REDUCE_STEPS,
        );
        if let Some(stream) = stream.as_deref_mut() {
            stream.advance_record(record, spill, steps, first_step + chunk_len);
        }
        done += chunk_len;
        progress(done);
    }
}

/// Steps of a batch one task of its reduction takes ([`reduce_batch`]).
const REDUCE_STEPS: usize = 512;

/// `v` holding exactly `len` values (its capacity grown to no more than
/// that), those it held kept and any new ones `fill`.
fn fit_exact<T: Copy>(v: &mut Vec<T>, len: usize, fill: T) {
    if len > v.len() {
        v.reserve_exact(len - v.len());
    }
    v.resize(len, fill);
}

/// What a sweep holds of its steps from some step on: their full rows
/// (`stride` values a step), ranges of lateral offsets (`n_bands` a step)
/// and (smoothing) shares for the neighbouring steps (`2 · HEAD` a step);
/// a batch's first step is the `from`-th held.
struct Held<'a> {
    rows: &'a mut [f64],
    offsets: &'a mut [[f32; 2]],
    spill: &'a mut [f64],
    from: usize,
}

/// Add a batch's partial sums (`partial`, `width` values for each strip
/// entry) to its steps' held rows and shares and merge its ranges of
/// lateral offsets (`ranges`, `n_bands` an entry) into theirs by min/max
/// (MODEL.md §1.7); the entries are the batch's `n_moves` moves binned by
/// strip (`counts`, `entries`: CSR, each strip's moves ascending). The
/// shares for the neighbouring steps are summed per step and applied once
/// the whole program is swept (`apply_spill`), or by a stream once the next
/// step is swept.
///
/// In parallel over runs of `chunk` steps: each takes its steps' entries
/// strip by strip, so each step's sums are made in strip order, the same
/// sums whatever the thread count or the chunk.
fn reduce_batch(
    held: Held<'_>,
    (counts, entries): (&[u32], &[u32]),
    (partial, ranges): (&[f64], &[[f32; 2]]),
    (width, stride, n_bands): (usize, usize, usize),
    n_moves: usize,
    chunk: usize,
) {
    let spread = width > stride;
    let n_strips = counts.len() - 1;
    let Held {
        rows,
        offsets,
        spill,
        from,
    } = held;
    let mut rows = &mut rows[from * stride..];
    let mut offsets = &mut offsets[from * n_bands..];
    let mut spill: &mut [f64] = if spread {
        &mut spill[from * 2 * HEAD..]
    } else {
        &mut []
    };
    // Each run's rows, ranges and shares, split off one after the other.
    let mut runs = Vec::with_capacity(n_moves.div_ceil(chunk.max(1)));
    let mut m0 = 0;
    while m0 < n_moves {
        let m1 = (m0 + chunk.max(1)).min(n_moves);
        let n = m1 - m0;
        let (r, rest) = std::mem::take(&mut rows).split_at_mut(n * stride);
        rows = rest;
        let (o, rest) = std::mem::take(&mut offsets).split_at_mut(n * n_bands);
        offsets = rest;
        let (sp, rest) =
            std::mem::take(&mut spill).split_at_mut(if spread { n * 2 * HEAD } else { 0 });
        spill = rest;
        runs.push((m0 as u32..m1 as u32, r, o, sp));
        m0 = m1;
    }
    runs.into_par_iter()
        .with_max_len(1)
        .for_each(|(moves, rows, offsets, spill)| {
            for s in 0..n_strips {
                let (c0, c1) = (counts[s] as usize, counts[s + 1] as usize);
                let strip = &entries[c0..c1];
                let a = c0 + strip.partition_point(|&m| m < moves.start);
                let b = c0 + strip.partition_point(|&m| m < moves.end);
                for e in a..b {
                    let i = (entries[e] - moves.start) as usize;
                    let src = &partial[e * width..(e + 1) * width];
                    for (d, s) in rows[i * stride..(i + 1) * stride].iter_mut().zip(src) {
                        *d += s;
                    }
                    if spread {
                        for (d, s) in spill[i * 2 * HEAD..(i + 1) * 2 * HEAD]
                            .iter_mut()
                            .zip(&src[stride..])
                        {
                            *d += s;
                        }
                    }
                    let src = &ranges[e * n_bands..(e + 1) * n_bands];
                    for (d, s) in offsets[i * n_bands..(i + 1) * n_bands].iter_mut().zip(src) {
                        d[0] = d[0].min(s[0]);
                        d[1] = d[1].max(s[1]);
                    }
                }
            }
        });
}

/// The strips of a band of rows: strip s holds the grid's rows
/// `(first + s)·rows ..`, cut at the band's edges.
struct Strips {
    first: usize,
    count: usize,
    rows: usize,
    band: std::ops::Range<usize>,
}

impl Strips {
    fn row0(&self, s: usize) -> usize {
        ((self.first + s) * self.rows).max(self.band.start)
    }
}

/// Run a batch's strips in parallel: the stock's columns, the rows'
/// intervals below their tops, the last-cut marks, the partial sums and the
/// ranges of offsets split into per-strip pieces, each strip given its
/// entries (`counts`, `entries`: the batch's moves binned by strip, CSR).
/// Returns the columns visited.
fn run_strips<E: Envelope>(
    job: &StripJob<'_, E>,
    stock: &mut Stock,
    strips: &Strips,
    (counts, entries): (&[u32], &[u32]),
    partial: &mut [f64],
    ranges: &mut [[f32; 2]],
    cost_ns: &[AtomicU64],
) -> u64 {
    let grid = *stock.grid();
    let width = partial_width(job.banding, job.smooth);
    let n_bands = job.banding.n_bands;
    // Split columns, the rows' intervals below their tops, last-cut marks
    // and partial sums into per-strip pieces.
    type Piece<'a> = (
        &'a mut [f32],
        BottomsMut<'a>,
        &'a mut [RowBelow],
        &'a mut [u32],
        &'a mut [f64],
        &'a mut [[f32; 2]],
    );
    let mut pieces: Vec<Piece> = Vec::with_capacity(strips.count);
    let mut rest: &mut [f64] = partial;
    let mut ranges_rest: &mut [[f32; 2]] = ranges;
    let (mut cols_rest, mut bottoms_rest, mut below_rest, mut last_rest) = stock.parts_mut();
    for s in 0..strips.count {
        let n = (counts[s + 1] - counts[s]) as usize * width;
        let (head, tail) = rest.split_at_mut(n);
        rest = tail;
        let n_ranges = (counts[s + 1] - counts[s]) as usize * n_bands;
        let (strip_ranges, ranges_tail) = ranges_rest.split_at_mut(n_ranges);
        ranges_rest = ranges_tail;
        let strip_end = ((strips.first + s + 1) * strips.rows).min(strips.band.end);
        let (below, below_tail) = below_rest.split_at_mut(strip_end - strips.row0(s));
        below_rest = below_tail;
        let len = (strip_end - strips.row0(s)) * grid.nx;
        let (cols, cols_tail) = cols_rest.split_at_mut(len);
        cols_rest = cols_tail;
        let (bottoms, bottoms_tail) = bottoms_rest.split_at_mut(len);
        bottoms_rest = bottoms_tail;
        let (last, last_tail) = last_rest.split_at_mut(len);
        last_rest = last_tail;
        pieces.push((cols, bottoms, below, last, head, strip_ranges));
    }
    // The strips with moves, the costliest first by the time each took in the
    // batch before (a batch's cuts crowd into the few strips where the tool
    // meets fresh material, a raster's next pass, and those stay the same
    // for many batches; strips not timed yet after them, by their moves),
    // each taken in that order by the next free thread (`par_bridge`): the
    // batch ends with cheap strips, not with a costly one on one core while
    // the others wait. The strips are independent, so their order changes no
    // result.
    let mut order: Vec<(usize, Piece)> = pieces
        .into_iter()
        .enumerate()
        .filter(|&(s, _)| counts[s + 1] > counts[s])
        .collect();
    order.sort_by_key(|&(s, _)| {
        std::cmp::Reverse(match cost_ns[s].load(Ordering::Relaxed) {
            0 => u64::from(counts[s + 1] - counts[s]),
            ns => ns,
        })
    });
    order
        .into_iter()
        .par_bridge()
        .map(|(s, (cols, bottoms, below, last, out, rng))| {
            let ents = &entries[counts[s] as usize..counts[s + 1] as usize];
            let started = Instant::now();
            // The strip's partial sums and ranges start empty (the buffers
            // are kept from batch to batch), cleared here on its thread.
            out.fill(0.0);
            rng.fill(EMPTY_OFFSETS);
            let r0 = strips.row0(s);
            let visited = match bottoms {
                BottomsMut::Uniform(lo) => job.run(r0, cols, lo, below, last, ents, out, rng),
                BottomsMut::Columns(lo) => job.run(r0, cols, lo, below, last, ents, out, rng),
            };
            let ns = u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX);
            cost_ns[s].store(ns.max(1), Ordering::Relaxed);
            visited
        })
        .sum()
}

/// Move each step's shares to its neighbours (MODEL.md §1.5): head values as
/// recorded per column, the shank and the bands in proportion to the volume
/// moved. A share moves only where the motion continues into the neighbour
/// and the neighbour removes material of its own, else it stays.
///
/// The shares are taken from each step's row as swept. Step i moves values
/// only into rows i − 1 and i + 1, so when step i is handled row i + 1 is
/// still as swept and row i has received only step i − 1's shares: two rows
/// kept aside (step i's as swept, and the volume of i − 1 as swept) stand in
/// for a copy of the whole record.
fn apply_spill(record: &mut RemovalRecord, steps: &(impl StepSource + ?Sized), spill: &[f64]) {
    let stride = record.stride();
    SpillCursor::default().run(&mut record.data, 0, stride, steps, spill, steps.len());
}

/// [`apply_spill`] from step to step: where it stands, so it can go on once
/// more rows are swept ([`Stream`]).
#[derive(Default)]
struct SpillCursor {
    /// Next step whose shares move.
    i: usize,
    /// Step i's row as swept (empty before step 0).
    row: Vec<f64>,
    next: Vec<f64>,
    /// Step i − 1's volume as swept.
    prev_volume: f64,
    /// Step i (once made: each step is made once here), and whether it
    /// continues step i − 1.
    step: Option<Step>,
    continues_prev: bool,
}

impl SpillCursor {
    /// Move the shares of steps `self.i .. until`: `rows` holds the full rows
    /// of steps `first ..` (every step up to `until`, and step `until` unless
    /// it is the last), `spill` their shares.
    fn run(
        &mut self,
        rows: &mut [f64],
        first: usize,
        stride: usize,
        steps: &(impl StepSource + ?Sized),
        spill: &[f64],
        until: usize,
    ) {
        let n = steps.len();
        if self.i >= until {
            return;
        }
        if self.row.is_empty() {
            debug_assert_eq!((self.i, first), (0, 0));
            self.row = rows[..stride].to_vec();
            self.next = vec![0.0; stride];
        }
        let (row, next) = (&mut self.row, &mut self.next);
        let at = |i: usize| (i - first) * stride;
        for i in self.i..until {
            if i + 1 < n {
                next.copy_from_slice(&rows[at(i + 1)..at(i + 1) + stride]);
            }
            let step = self.step.take().unwrap_or_else(|| steps.step(i));
            let after = (i + 1 < n).then(|| steps.step(i + 1));
            let continues_next = after.as_ref().is_some_and(|b| continues(&step, b));
            let volume = row[VOLUME];
            if volume > 0.0 {
                let targets = [
                    (i > 0 && self.continues_prev && self.prev_volume > 0.0).then(|| i - 1),
                    (continues_next && next[VOLUME] > 0.0).then_some(i + 1),
                ];
                for (side, target) in targets.into_iter().enumerate() {
                    let Some(t) = target else {
                        continue;
                    };
                    let sh = 2 * (i - first) + side;
                    let moved = &spill[sh * HEAD..(sh + 1) * HEAD];
                    if moved[VOLUME] <= 0.0 {
                        continue;
                    }
                    let f = (moved[VOLUME] / volume).min(1.0);
                    for k in 0..stride {
                        // Head values as recorded per column; shank and bands in proportion.
                        let v = if k < HEAD && k != SHANK {
                            moved[k]
                        } else {
                            f * row[k]
                        };
                        rows[at(i) + k] -= v;
                        rows[at(t) + k] += v;
                    }
                }
            }
            self.prev_volume = volume;
            self.step = after;
            self.continues_prev = continues_next;
            std::mem::swap(row, next);
        }
        self.i = until;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::testing::lcg;

    /// The batch's reduction in runs of 1, 7, 512 and all steps adds the
    /// same values in the same order as entry by entry: bit for bit, with
    /// and without the shares, from a held step other than the first.
    #[test]
    fn reduce_batch_in_runs_is_entry_by_entry() {
        let mut seed = 7;
        let (n_moves, n_strips, n_bands, from) = (40, 9, 3, 5);
        for spread in [false, true] {
            let stride = HEAD + n_bands;
            let width = if spread { stride + 2 * HEAD } else { stride };
            // Each move joins a run of strips (none for some), binned CSR.
            let mut counts = vec![0u32; n_strips + 1];
            let mut spans = Vec::new();
            for _ in 0..n_moves {
                let s0 = (lcg(&mut seed) * n_strips as f64) as usize;
                let k = (lcg(&mut seed) * 4.0) as usize;
                let span = (s0..(s0 + k).min(n_strips)).collect::<Vec<_>>();
                for &s in &span {
                    counts[s + 1] += 1;
                }
                spans.push(span);
            }
            for s in 0..n_strips {
                counts[s + 1] += counts[s];
            }
            let mut fill = counts.clone();
            let mut entries = vec![0u32; counts[n_strips] as usize];
            for (m, span) in spans.iter().enumerate() {
                for &s in span {
                    entries[fill[s] as usize] = m as u32;
                    fill[s] += 1;
                }
            }
            // Values of mixed magnitudes, so that the order of the sums shows.
            let mut value = || (lcg(&mut seed) - 0.5) * 10f64.powi((lcg(&mut seed) * 12.0) as i32);
            let partial: Vec<f64> = (0..entries.len() * width).map(|_| value()).collect();
            let ranges: Vec<[f32; 2]> = (0..entries.len() * n_bands)
                .map(|_| {
                    let (a, b) = (value() as f32, value() as f32);
                    [a.min(b), a.max(b)]
                })
                .collect();
            let held = from + n_moves + 3;
            let rows0: Vec<f64> = (0..held * stride).map(|_| value()).collect();
            let offsets0 = vec![EMPTY_OFFSETS; held * n_bands];
            let spill0: Vec<f64> = if spread {
                (0..held * 2 * HEAD).map(|_| value()).collect()
            } else {
                Vec::new()
            };
            // Entry by entry, in the order of the entries.
            let (mut rows, mut offsets, mut spill) =
                (rows0.clone(), offsets0.clone(), spill0.clone());
            for (e, &m) in entries.iter().enumerate() {
                let i = from + m as usize;
                for k in 0..stride {
                    rows[i * stride + k] += partial[e * width + k];
                }
                for k in 0..width - stride {
                    spill[i * 2 * HEAD + k] += partial[e * width + stride + k];
                }
                for k in 0..n_bands {
                    let (d, s) = (&mut offsets[i * n_bands + k], ranges[e * n_bands + k]);
                    *d = [d[0].min(s[0]), d[1].max(s[1])];
                }
            }
            for chunk in [1, 7, 512, n_moves] {
                let (mut r, mut o, mut sp) = (rows0.clone(), offsets0.clone(), spill0.clone());
                reduce_batch(
                    Held {
                        rows: &mut r,
                        offsets: &mut o,
                        spill: &mut sp,
                        from,
                    },
                    (&counts, &entries),
                    (&partial, &ranges),
                    (width, stride, n_bands),
                    n_moves,
                    chunk,
                );
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&r),
                    bits(&rows),
                    "rows, runs of {chunk}, shares {spread}"
                );
                assert_eq!(bits(&sp), bits(&spill), "shares, runs of {chunk}");
                assert_eq!(o, offsets, "offset ranges, runs of {chunk}");
            }
        }
    }
}
