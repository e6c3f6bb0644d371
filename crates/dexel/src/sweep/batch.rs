//! The batch driver: checks, moves binned by strip, strips run in parallel,
//! sums reduced in a fixed order, smoothing shares applied at the end.

use rayon::prelude::*;

use super::ball::BallEnd;
use super::bull::BullNose;
use super::flat::FlatEnd;
use super::slot::{SHANK, VOLUME};
use super::strip::{Banding, StripJob};
use super::{Envelope, Prepared, RemovalRecord, Step, SweepOptions, HEAD};
use crate::{Error, Stock, Tool, ToolShape};

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
    tool.validate()?;
    if !(options.band_height_mm > 0.0 && options.band_height_mm.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "band height must be positive, got {} mm",
            options.band_height_mm
        )));
    }
    if let Some((i, _)) = steps
        .iter()
        .enumerate()
        .find(|(_, s)| !s.from_mm.iter().chain(&s.to_mm).all(|v| v.is_finite()))
    {
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
    let radius = tool.radius_mm();
    let mut record = RemovalRecord::new(steps.len(), n_bands, options.band_height_mm);
    // One call per tool shape: `run_batches` is generic over the envelope.
    macro_rules! run {
        ($env:expr) => {
            run_batches(
                stock,
                &$env,
                radius,
                &banding,
                steps,
                options,
                &mut record,
                progress,
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
    Ok(record)
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
    if tool_of_step.len() != steps.len() {
        return Err(Error::InvalidParameter(format!(
            "{} tool indices for {} steps",
            tool_of_step.len(),
            steps.len()
        )));
    }
    if let Some(&bad) = tool_of_step.iter().find(|&&t| t >= tools.len()) {
        return Err(Error::InvalidParameter(format!(
            "tool index {bad} with {} tools",
            tools.len()
        )));
    }
    let mut parts = Vec::new();
    let mut start = 0;
    while start < steps.len() {
        let t = tool_of_step[start];
        let end = start
            + tool_of_step[start..]
                .iter()
                .position(|&u| u != t)
                .unwrap_or(steps.len() - start);
        let done = start;
        parts.push((
            start,
            sweep(stock, &tools[t], &steps[start..end], options, &|d| {
                progress(done + d)
            })?,
        ));
        start = end;
    }
    if parts.len() == 1 {
        // One tool: the record as it is (no copy).
        return Ok(parts.pop().expect("one part").1);
    }
    let n_bands = parts.iter().map(|(_, r)| r.n_bands).max().unwrap_or(1);
    let mut record = RemovalRecord::new(steps.len(), n_bands, options.band_height_mm);
    let stride = record.stride();
    for (offset, part) in &parts {
        record.columns_evaluated += part.columns_evaluated;
        for j in 0..part.len() {
            let row = part.row(j);
            let at = (offset + j) * stride;
            record.data[at..at + row.len()].copy_from_slice(row);
        }
    }
    Ok(record)
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

#[allow(clippy::too_many_arguments)]
fn run_batches<E: Envelope>(
    stock: &mut Stock,
    env: &E,
    radius: f64,
    banding: &Banding,
    steps: &[Step],
    options: &SweepOptions,
    record: &mut RemovalRecord,
    progress: &(dyn Fn(usize) + Sync),
) {
    let grid = *stock.grid();
    let strip_rows = options.strip_rows.max(1);
    let n_strips = grid.ny.div_ceil(strip_rows);
    let stride = HEAD + banding.n_bands;
    let batch = options.batch_steps.max(1);
    // Per step: head values to move to the previous and to the next step.
    let mut spill = if options.smooth {
        vec![0.0f64; steps.len() * 2 * HEAD]
    } else {
        Vec::new()
    };
    let mut done = 0;
    // Buffers kept from batch to batch: a fresh allocation of the partial sums
    // (tens of MB when a move spans many strips) is paged in again each time.
    let mut moves: Vec<Prepared> = Vec::new();
    let mut counts: Vec<u32> = Vec::new();
    let mut fill: Vec<u32> = Vec::new();
    let mut entries: Vec<u32> = Vec::new();
    let mut partial: Vec<f64> = Vec::new();
    for (b, chunk) in steps.chunks(batch).enumerate() {
        let first_step = b * batch;
        moves.clear();
        moves.extend(chunk.iter().enumerate().map(|(i, step)| {
            let g = first_step + i;
            Prepared {
                follows: g > 0 && steps[g - 1].to_mm == step.from_mm,
                ..Prepared::new(step)
            }
        }));
        // Bin moves by strip (CSR): a move joins every strip its footprint's rows touch.
        counts.clear();
        counts.resize(n_strips + 1, 0);
        let strip_span = |m: &Prepared| {
            m.row_range(&grid, radius)
                .map(|(a, b)| (a / strip_rows, b / strip_rows))
        };
        for m in &moves {
            if let Some((s0, s1)) = strip_span(m) {
                for s in s0..=s1 {
                    counts[s + 1] += 1;
                }
            }
        }
        for s in 0..n_strips {
            counts[s + 1] += counts[s];
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
            first_step,
            smooth: options.smooth,
        };
        let width = job.width();
        partial.clear();
        partial.resize(entries.len() * width, 0.0);
        // Split columns, last-cut marks and partial sums into per-strip pieces.
        let strip_len = strip_rows * grid.nx;
        let mut partial_pieces: Vec<&mut [f64]> = Vec::with_capacity(n_strips);
        let mut rest: &mut [f64] = &mut partial;
        for s in 0..n_strips {
            let n = (counts[s + 1] - counts[s]) as usize * width;
            let (head, tail) = rest.split_at_mut(n);
            partial_pieces.push(head);
            rest = tail;
        }
        let visited: u64 = stock
            .columns
            .par_chunks_mut(strip_len)
            .zip(stock.last_cut.par_chunks_mut(strip_len))
            .zip(partial_pieces.into_par_iter())
            .enumerate()
            .map(|(s, ((cols, last), out))| {
                let ents = &entries[counts[s] as usize..counts[s + 1] as usize];
                if ents.is_empty() {
                    0
                } else {
                    job.run(s * strip_rows, cols, last, ents, out)
                }
            })
            .sum();
        record.columns_evaluated += visited;
        // Reduce in strip order: the same sums whatever the thread count. The
        // shares for the neighbouring steps are summed per step and applied
        // once the whole program is swept (`apply_spill`).
        for (e, &mi) in entries.iter().enumerate() {
            let i = first_step + mi as usize;
            let src = &partial[e * width..(e + 1) * width];
            let dst = i * stride;
            for (d, s) in record.data[dst..dst + stride].iter_mut().zip(src) {
                *d += s;
            }
            if width > stride {
                for (d, s) in spill[i * 2 * HEAD..(i + 1) * 2 * HEAD]
                    .iter_mut()
                    .zip(&src[stride..])
                {
                    *d += s;
                }
            }
        }
        done += chunk.len();
        progress(done);
    }
    if options.smooth {
        apply_spill(record, steps, &spill);
    }
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
fn apply_spill(record: &mut RemovalRecord, steps: &[Step], spill: &[f64]) {
    let stride = record.stride();
    let n = steps.len();
    if n == 0 {
        return;
    }
    let mut row = record.data[..stride].to_vec();
    let mut next = vec![0.0; stride];
    let mut prev_volume = 0.0;
    for i in 0..n {
        if i + 1 < n {
            next.copy_from_slice(&record.data[(i + 1) * stride..(i + 2) * stride]);
        }
        let volume = row[VOLUME];
        if volume > 0.0 {
            let targets = [
                (i > 0 && continues(&steps[i - 1], &steps[i]) && prev_volume > 0.0).then(|| i - 1),
                (i + 1 < n && continues(&steps[i], &steps[i + 1]) && next[VOLUME] > 0.0)
                    .then_some(i + 1),
            ];
            for (side, target) in targets.into_iter().enumerate() {
                let Some(t) = target else {
                    continue;
                };
                let moved = &spill[(2 * i + side) * HEAD..(2 * i + side + 1) * HEAD];
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
                    record.data[i * stride + k] -= v;
                    record.data[t * stride + k] += v;
                }
            }
        }
        prev_volume = volume;
        std::mem::swap(&mut row, &mut next);
    }
}
