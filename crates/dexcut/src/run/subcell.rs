//! Loads of steps in which the tool advances less than a grid cell (MODEL.md
//! §1.6): the removal record gives such a step whole columns or nothing, so
//! its load is taken from the removal per unit length over
//! [`SUB_CELL_WINDOW_CELLS`] cells of path around it, at its own length and
//! duration.

use cutting::StepRemoval;
use dexel::RemovalRecord;
use rayon::prelude::*;

/// A servo period in which the tool advances less than one grid cell has its
/// MRR measured over this many cells of path around it (MODEL.md §2.3): over
/// one cell the column quantisation still gives ±40 % (Ø1.6 mm tool, 0.1 mm
/// grid, camotics_tiny_cat_outline), over six it is within the 2 % that
/// `optimize` holds the limit to.
pub const SUB_CELL_WINDOW_CELLS: f64 = 6.0;

use crate::motion::TimedStep;

/// Head values summed over a window: volume, contact along and left of each
/// step's own feed direction, chip edge area times step length, volume over
/// radius (MODEL.md §1.6).
const SUMS: usize = 5;
const VOL: usize = 0;
const ALONG: usize = 1;
const LEFT: usize = 2;
const EDGE_LEN: usize = 3;
const OVER_R: usize = 4;

/// A step's length (mm) and XY feed direction where it can be windowed: a
/// feed step that moves in XY, however steeply (its flank crosses column
/// centres in XY; a plunge straight down is resolved in Z and has no feed
/// direction).
fn geometry(s: &TimedStep) -> Option<(f64, [f64; 2])> {
    if s.step.rapid {
        return None;
    }
    let [fx, fy, fz] = s.step.from_mm;
    let [tx, ty, tz] = s.step.to_mm;
    let (dx, dy, dz) = (tx - fx, ty - fy, tz - fz);
    let xy = dx.hypot(dy);
    (xy > 0.0).then(|| (xy.hypot(dz), [dx / xy, dy / xy]))
}

/// Window sums of one run of steps (MODEL.md §1.6): the steps of the run
/// from `lo` on whose end lies before the window's start, and from `hi` on
/// whose end lies before its end, so the steps `lo..hi` are summed whole and
/// the step at each end of the window is added or taken off by its share.
struct Window {
    lo: usize,
    hi: usize,
    head: [f64; SUMS],
    bands: Vec<f64>,
    /// Steps in `lo..hi` that removed material: where none did, the sums are
    /// set to exactly zero (no rounding left over from the steps taken off).
    cutting: usize,
}

impl Window {
    fn add(&mut self, head: &[f64; SUMS], bands: &[f64], w: f64) {
        for (s, v) in self.head.iter_mut().zip(head) {
            *s += w * v;
        }
        for (s, v) in self.bands.iter_mut().zip(bands) {
            *s += w * v;
        }
    }
}

/// One step's head values for the window ([`SUMS`]), its contact turned into
/// its own feed frame `u`.
fn head_of(record: &RemovalRecord, k: usize, len: f64, u: [f64; 2]) -> [f64; SUMS] {
    let [cx, cy] = record.contact_resultant(k);
    let mut h = [0.0; SUMS];
    h[VOL] = record.volume_mm3(k);
    h[ALONG] = cx * u[0] + cy * u[1];
    h[LEFT] = cy * u[0] - cx * u[1];
    h[EDGE_LEN] = record.chip_edge_area_mm2(k) * len;
    h[OVER_R] = record.volume_over_radius_mm2(k);
    h
}

/// Give `set(step, removal)` the removal whose load replaces that of each
/// step shorter than a grid cell (`grid_mm`; `None`: no load, the window
/// removes nothing): the steady cut's, per run of windowable steps (feed steps that move in
/// XY, one tool, each starting where the one before ended), the
/// removal per unit length over [`SUB_CELL_WINDOW_CELLS`] cells of path
/// centred on the step (shifted to lie within the run, or the whole run
/// where it is shorter), at the step's own length, feed direction and
/// duration (MODEL.md §1.6). Steps of a cell or more keep their loads bit
/// for bit. Allocates per call, not per step.
pub fn window_loads(
    mut set: impl FnMut(usize, Option<&StepRemoval>),
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
    grid_mm: f64,
) {
    let n = steps.len();
    let width_mm = SUB_CELL_WINDOW_CELLS * grid_mm;
    // Per step of the current run: its start along the run, mm.
    let mut start: Vec<f64> = Vec::new();
    let mut geo: Vec<(f64, [f64; 2])> = Vec::new();
    let mut bands = vec![0.0; record.n_bands];
    // The window's bands' ranges of offsets (MODEL.md §1.7): their union
    // over the steps it takes from.
    let mut offsets = vec![dexel::EMPTY_OFFSETS; record.n_bands];
    let mut win = Window {
        lo: 0,
        hi: 0,
        head: [0.0; SUMS],
        bands: vec![0.0; record.n_bands],
        cutting: 0,
    };
    let mut k = 0;
    while k < n {
        // The run k..end.
        let Some(first) = geometry(&steps[k]) else {
            k += 1;
            continue;
        };
        // The run's end, and whether every step of it is a cell or longer:
        // its steps' geometry is held only where one is not (a whole
        // program's run of long steps would hold 32 B a step).
        let mut end = k + 1;
        let mut all_long = first.0 >= grid_mm;
        while end < n
            && tool_of_step[end] == tool_of_step[k]
            && steps[end - 1].step.to_mm == steps[end].step.from_mm
        {
            let Some(g) = geometry(&steps[end]) else {
                break;
            };
            all_long &= g.0 >= grid_mm;
            end += 1;
        }
        if all_long {
            k = end;
            continue;
        }
        start.clear();
        geo.clear();
        start.push(0.0);
        geo.push(first);
        for step in &steps[k + 1..end] {
            let g = geometry(step).expect("a step of the run");
            start.push(start[start.len() - 1] + geo[geo.len() - 1].0);
            geo.push(g);
        }
        let run_mm = start[start.len() - 1] + geo[geo.len() - 1].0;
        win.lo = 0;
        win.hi = 0;
        win.head = [0.0; SUMS];
        win.bands.fill(0.0);
        win.cutting = 0;
        // Step j of the run (0-based): record index k + j.
        let head = |j: usize| head_of(record, k + j, geo[j].0, geo[j].1);
        let m = geo.len();
        for t in 0..m {
            let (len, u) = geo[t];
            if len >= grid_mm {
                continue;
            }
            let mid = start[t] + 0.5 * len;
            let (a, b) = if run_mm <= width_mm {
                (0.0, run_mm)
            } else {
                let a = (mid - 0.5 * width_mm).clamp(0.0, run_mm - width_mm);
                (a, a + width_mm)
            };
            // Steps wholly before a leave, steps wholly before b enter.
            while win.hi < m && start[win.hi] + geo[win.hi].0 <= b {
                let j = win.hi;
                win.add(&head(j), record.band_volumes_mm3(k + j), 1.0);
                win.cutting += usize::from(record.volume_mm3(k + j) > 0.0);
                win.hi += 1;
            }
            while win.lo < win.hi && start[win.lo] + geo[win.lo].0 <= a {
                let j = win.lo;
                win.add(&head(j), record.band_volumes_mm3(k + j), -1.0);
                win.cutting -= usize::from(record.volume_mm3(k + j) > 0.0);
                win.lo += 1;
            }
            if win.cutting == 0 {
                win.head = [0.0; SUMS];
                win.bands.fill(0.0);
            }
            // The window's sums: whole steps lo..hi, plus the part of step hi
            // before b, less the part of step lo before a.
            let mut sum = win.head;
            bands.copy_from_slice(&win.bands);
            let mut part = |j: usize, x: f64, sign: f64| {
                if j < m {
                    let share = ((x - start[j]) / geo[j].0).clamp(0.0, 1.0);
                    if share > 0.0 {
                        for (s, v) in sum.iter_mut().zip(head(j)) {
                            *s += sign * share * v;
                        }
                        for (s, v) in bands.iter_mut().zip(record.band_volumes_mm3(k + j)) {
                            *s += sign * share * v;
                        }
                    }
                }
            };
            part(win.hi, b, 1.0);
            part(win.lo, a, -1.0);
            let scale = len / (b - a);
            let volume = sum[VOL] * scale;
            let i = k + t;
            if !(volume > 0.0) {
                set(i, None);
                continue;
            }
            for v in bands.iter_mut() {
                *v = (*v * scale).max(0.0);
            }
            offsets.fill(dexel::EMPTY_OFFSETS);
            for j in win.lo..=win.hi.min(m - 1) {
                for (o, r) in offsets.iter_mut().zip(record.band_offsets_mm(k + j)) {
                    *o = [o[0].min(r[0]), o[1].max(r[1])];
                }
            }
            let left = [-u[1], u[0]];
            set(
                i,
                Some(&StepRemoval {
                    volume_mm3: volume,
                    band_volumes_mm3: &bands,
                    contact_resultant: [
                        (sum[ALONG] * u[0] + sum[LEFT] * left[0]) * scale,
                        (sum[ALONG] * u[1] + sum[LEFT] * left[1]) * scale,
                    ],
                    // Σ dV/h over a step does not depend on its length (dV and h
                    // both grow with it): the window's Σ (dV/h)·L over its length.
                    chip_edge_area_mm2: sum[EDGE_LEN] / (b - a),
                    volume_over_radius_mm2: sum[OVER_R] * scale,
                    dt_s: steps[i].dt_s,
                    band_offsets_mm: &offsets,
                    feed_dir: u,
                    len_xy_mm: super::loads::len_xy_mm(&steps[i].step),
                    cell_mm: grid_mm,
                }),
            );
        }
        k = end;
    }
}

/// Sub-cell steps whose windowed removals [`window_loads_in_parallel`] holds
/// before it makes their values together: a few hundred kB of bands held.
const PARALLEL_STEPS: usize = 1024;

/// [`window_loads`] with each step's value made on rayon's threads:
/// `make(scratch, step, removal)` for up to [`PARALLEL_STEPS`] sub-cell
/// steps at a time (each thread with its own scratch, `S::default()` at
/// first), then `set(step, value)` for each of them in step order. The
/// values are those of `window_loads` with `set(step, make(..))`, bit for
/// bit (each is a function of its own removal); the windows themselves are
/// summed in order on the calling thread.
pub fn window_loads_in_parallel<S: Default + Send, T: Send>(
    make: impl Fn(&mut S, usize, Option<&StepRemoval>) -> T + Sync,
    set: impl FnMut(usize, T),
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
    grid_mm: f64,
) {
    window_loads_in_chunks(
        PARALLEL_STEPS,
        make,
        set,
        tool_of_step,
        record,
        steps,
        grid_mm,
    );
}

/// [`window_loads_in_parallel`] holding up to `chunk` steps at a time.
pub(crate) fn window_loads_in_chunks<S: Default + Send, T: Send>(
    chunk: usize,
    make: impl Fn(&mut S, usize, Option<&StepRemoval>) -> T + Sync,
    mut set: impl FnMut(usize, T),
    tool_of_step: &[usize],
    record: &RemovalRecord,
    steps: &[TimedStep],
    grid_mm: f64,
) {
    let mut held = HeldWindows::default();
    window_loads(
        |i, r| {
            held.push(i, r);
            if held.steps.len() >= chunk {
                held.make_and_set(&make, &mut set);
            }
        },
        tool_of_step,
        record,
        steps,
        grid_mm,
    );
    held.make_and_set(&make, &mut set);
}

/// Windowed removals held for [`window_loads_in_parallel`]: per step its
/// removal with empty slices (none: the window removes nothing) and where
/// its bands' volumes and offsets lie in `bands` and `offsets`.
#[derive(Default)]
struct HeldWindows {
    steps: Vec<(usize, Option<StepRemoval<'static>>, std::ops::Range<usize>)>,
    bands: Vec<f64>,
    offsets: Vec<[f32; 2]>,
}

impl HeldWindows {
    fn push(&mut self, i: usize, r: Option<&StepRemoval>) {
        let start = self.bands.len();
        let removal = r.map(|r| {
            // One range for both: a window's bands and offsets are the record's bands.
            debug_assert_eq!(r.band_volumes_mm3.len(), r.band_offsets_mm.len());
            self.bands.extend_from_slice(r.band_volumes_mm3);
            self.offsets.extend_from_slice(r.band_offsets_mm);
            StepRemoval {
                volume_mm3: r.volume_mm3,
                band_volumes_mm3: &[],
                contact_resultant: r.contact_resultant,
                chip_edge_area_mm2: r.chip_edge_area_mm2,
                volume_over_radius_mm2: r.volume_over_radius_mm2,
                dt_s: r.dt_s,
                band_offsets_mm: &[],
                feed_dir: r.feed_dir,
                len_xy_mm: r.len_xy_mm,
                cell_mm: r.cell_mm,
            }
        });
        self.steps.push((i, removal, start..self.bands.len()));
    }

    /// Every held step's value made in parallel, then set in step order; the
    /// steps let go.
    fn make_and_set<S: Default + Send, T: Send>(
        &mut self,
        make: &(impl Fn(&mut S, usize, Option<&StepRemoval>) -> T + Sync),
        set: &mut impl FnMut(usize, T),
    ) {
        let (bands, offsets) = (&self.bands, &self.offsets);
        let values: Vec<T> = self
            .steps
            .par_iter()
            .map_init(S::default, |scratch, (i, removal, at)| {
                let removal = removal.map(|r| StepRemoval {
                    band_volumes_mm3: &bands[at.clone()],
                    band_offsets_mm: &offsets[at.clone()],
                    ..r
                });
                make(scratch, *i, removal.as_ref())
            })
            .collect();
        for (&(i, _, _), value) in self.steps.iter().zip(values) {
            set(i, value);
        }
        self.steps.clear();
        self.bands.clear();
        self.offsets.clear();
    }
}
