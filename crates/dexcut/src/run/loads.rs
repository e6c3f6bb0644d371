//! Each step's force, power, deflection and stress from its removal
//! (MODEL.md §3, §4), and the step that breaks its tool.

use cutting::{CuttingModel, StepLoad, StepRemoval};
use dexel::RemovalRecord;
use rayon::prelude::*;

use super::error_map::FlankDeflections;
use super::StepTools;
use crate::motion::TimedStep;

/// What a run's loads are made of: its steps, what each removed (the
/// record), each step's tool and the grid.
#[derive(Clone, Copy)]
pub(crate) struct Removals<'a> {
    pub of_step: StepTools<'a>,
    pub record: &'a RemovalRecord,
    pub steps: &'a [TimedStep],
    /// Column spacing, mm.
    pub grid_mm: f64,
}

/// Steps [`Removals::rigid_loads`] takes at a time before it looks at its
/// guess (a whole number of [`FLANK_BLOCK`]s).
const GUESS_STEPS: usize = 64 * FLANK_BLOCK;

/// Steps a task of [`Removals::loads_with_flanks`] takes at a time.
const FLANK_BLOCK: usize = 256;

impl<'a> Removals<'a> {
    pub(crate) fn new(
        of_step: StepTools<'a>,
        record: &'a RemovalRecord,
        steps: &'a [TimedStep],
        grid_mm: f64,
    ) -> Self {
        Removals {
            of_step,
            record,
            steps,
            grid_mm,
        }
    }

    /// Step i's tool's model.
    fn model(&self, i: usize) -> &CuttingModel {
        &self.of_step.tools.entries[self.of_step.tool_of_step[i]].model
    }

    /// What step i removed, as the force model takes it ([`step_removal`]).
    fn removal(&self, i: usize) -> StepRemoval<'_> {
        step_removal(self.record, i, &self.steps[i], self.grid_mm)
    }

    /// `set(step, removal)` for each step shorter than a grid cell, with
    /// the removal of its window (`subcell::window_loads`).
    fn windows(&self, set: impl FnMut(usize, Option<&StepRemoval>)) {
        let (tool_of_step, record) = (self.of_step.tool_of_step, self.record);
        super::subcell::window_loads(set, tool_of_step, record, self.steps, self.grid_mm);
    }

    /// [`Removals::windows`] with each value made on rayon's threads
    /// (`subcell::window_loads_in_parallel`).
    fn windows_in_parallel<S: Default + Send, T: Send>(
        &self,
        make: impl Fn(&mut S, usize, Option<&StepRemoval>) -> T + Sync,
        set: impl FnMut(usize, T),
    ) {
        let (tool_of_step, record) = (self.of_step.tool_of_step, self.record);
        super::subcell::window_loads_in_parallel(
            make,
            set,
            tool_of_step,
            record,
            self.steps,
            self.grid_mm,
        );
    }

    /// Each step's mean deflection [x, y] at the contact height (µm, MODEL.md
    /// §3, §4: `CuttingModel::mean_deflection_um`, the `dx_um`, `dy_um` of its
    /// load bit for bit, without the force through the tooth period's peak)
    /// with its tool's model, as `of(deflection, step)` makes it (the closed
    /// loop's passes keep each step's deflection across its path, 8 B); a step
    /// shorter than a grid cell has the deflection of the steady cut around
    /// it (MODEL.md §1.6).
    pub(crate) fn deflections_as<T: Send>(
        &self,
        of: impl Fn([f64; 2], usize) -> T + Sync,
    ) -> Vec<T> {
        // Steps in parallel: each step's deflection is its own, and the order
        // of the results is the steps'.
        let mut out: Vec<T> = (0..self.steps.len())
            .into_par_iter()
            .map(|i| of(self.model(i).mean_deflection_um(&self.removal(i)), i))
            .collect();
        self.windows(|i, r| {
            out[i] = of(
                r.map_or([0.0; 2], |r| self.model(i).mean_deflection_um(r)),
                i,
            );
        });
        out
    }

    /// Each step's load as the closed loop's plan reads it (MODEL.md §5.1):
    /// [`Removals::loads_with_flanks`]' loads bit for bit but for the force
    /// through the tooth period's peak where it cannot matter to the plan.
    /// The plan reads a step's peak only through its stress, against its
    /// tool's allowable stress and rupture strength (`limit_mpa(i)`: the
    /// lower of them); where the stress bound of
    /// `CuttingModel::step_load_bounded` (MODEL.md §3.4, "A bound on the
    /// peak") is within that, `force_peak_n` and `stress_mpa` may be those
    /// bounds, elsewhere they are the step's own.
    ///
    /// A loop that runs makes every load again from its last pass; one that
    /// settles or converges on the rigid sweep keeps the rigid loads with
    /// their peaks and flanks. So the steps are taken in order,
    /// [`GUESS_STEPS`] at a time, with peaks and flanks until
    /// `likely(step, load)` guesses that the loop will run, then with the
    /// bound. Returns the loads, and the flanks where every load has them
    /// (the guess never made): then both are
    /// [`Removals::loads_with_flanks`]' bit for bit.
    pub(crate) fn rigid_loads(
        &self,
        limit_mpa: impl Fn(usize) -> f64 + Sync,
        likely: impl Fn(usize, &StepLoad) -> bool + Sync,
    ) -> (Vec<StepLoad>, Option<FlankDeflections>) {
        let bounded = |i: usize, r: &StepRemoval| {
            let load = self.model(i).step_load_bounded(r);
            if load.stress_mpa > limit_mpa(i) {
                self.model(i).step_load(r)
            } else {
                load
            }
        };
        let mut flanks = FlankDeflections::sized(self.record, self.steps.len());
        let mut out = vec![StepLoad::default(); self.steps.len()];
        let mut full = true;
        let mut bands = flanks.blocks_mut(FLANK_BLOCK);
        for (c, (loads, bands)) in out
            .chunks_mut(GUESS_STEPS)
            .zip(bands.chunks_mut(GUESS_STEPS / FLANK_BLOCK))
            .enumerate()
        {
            let first = c * GUESS_STEPS;
            if full {
                self.own_loads_with_flanks(first, loads, bands);
                full = !(loads.par_iter().enumerate()).any(|(j, l)| likely(first + j, l));
            } else {
                loads
                    .par_iter_mut()
                    .enumerate()
                    .for_each(|(j, l)| *l = bounded(first + j, &self.removal(first + j)));
            }
        }
        drop(bands);
        if full {
            self.windowed_loads_with_flanks(&mut out, &mut flanks);
            return (out, Some(flanks));
        }
        drop(flanks);
        self.windows_in_parallel(
            |_: &mut (), i, r| r.map_or_else(StepLoad::default, |r| bounded(i, r)),
            |i, l| out[i] = l,
        );
        (out, None)
    }

    /// Each step's load (MODEL.md §3, §4; a step shorter than a grid cell,
    /// the steady cut's around it, §1.6), and per step and band the
    /// deflections when a tooth at the band's mid-height passes the flanks
    /// (`CuttingModel::step_load_with_flanks`, MODEL.md §5.2): the error
    /// map's model, as many bands a step as the record keeps (at least one).
    pub(crate) fn loads_with_flanks(&self) -> (Vec<StepLoad>, FlankDeflections) {
        let mut flanks = FlankDeflections::sized(self.record, self.steps.len());
        let mut out = vec![StepLoad::default(); self.steps.len()];
        let mut bands = flanks.blocks_mut(FLANK_BLOCK);
        self.own_loads_with_flanks(0, &mut out, &mut bands);
        drop(bands);
        self.windowed_loads_with_flanks(&mut out, &mut flanks);
        (out, flanks)
    }

    /// Step i's load from its removal `r` with its flanks written into its
    /// f32 bands `out` (the model's f64 made in `buf`).
    fn load_with_flanks(
        &self,
        i: usize,
        r: Option<&StepRemoval>,
        out: &mut [[[f32; 2]; 2]],
        buf: &mut Vec<[[f64; 2]; 2]>,
    ) -> StepLoad {
        buf.clear();
        buf.resize(out.len(), [[0.0; 2]; 2]);
        let load = r.map_or_else(StepLoad::default, |r| {
            self.model(i).step_load_with_flanks(r, buf)
        });
        for (o, b) in out.iter_mut().zip(buf.iter()) {
            *o = b.map(|xy| xy.map(|c| c as f32));
        }
        load
    }

    /// The loads and flanks of steps `first..first + loads.len()` from
    /// their own removals, blocks of [`FLANK_BLOCK`] steps in parallel, each
    /// block with its part of the bands (`bands`, one slice a block).
    fn own_loads_with_flanks(
        &self,
        first: usize,
        loads: &mut [StepLoad],
        bands: &mut [&mut [[[f32; 2]; 2]]],
    ) {
        loads
            .par_chunks_mut(FLANK_BLOCK)
            .zip(bands.par_iter_mut())
            .enumerate()
            .for_each(|(b, (loads, bands))| {
                let mut buf = Vec::new();
                let mut bands: &mut [[[f32; 2]; 2]] = bands;
                for (j, load) in loads.iter_mut().enumerate() {
                    let i = first + b * FLANK_BLOCK + j;
                    let (own, rest) = std::mem::take(&mut bands)
                        .split_at_mut(FlankDeflections::bands_of(self.record, i));
                    *load = self.load_with_flanks(i, Some(&self.removal(i)), own, &mut buf);
                    bands = rest;
                }
            });
    }

    /// The sub-cell steps' loads and flanks from their windows, made in
    /// parallel (each step's bands made apart, then written over its own).
    fn windowed_loads_with_flanks(&self, out: &mut [StepLoad], flanks: &mut FlankDeflections) {
        self.windows_in_parallel(
            |buf, i, r| {
                let mut bands = vec![[[0.0; 2]; 2]; FlankDeflections::bands_of(self.record, i)];
                (self.load_with_flanks(i, r, &mut bands, buf), bands)
            },
            |i, (load, bands)| {
                out[i] = load;
                flanks.of_step_mut(i).copy_from_slice(&bands);
            },
        );
    }
}

/// What step `i` (`step`) of `record` removed, as the force model takes it.
pub(crate) fn step_removal<'r>(
    record: &'r RemovalRecord,
    i: usize,
    step: &TimedStep,
    grid_mm: f64,
) -> cutting::StepRemoval<'r> {
    cutting::StepRemoval {
        volume_mm3: record.volume_mm3(i),
        band_volumes_mm3: record.band_volumes_mm3(i),
        contact_resultant: record.contact_resultant(i),
        chip_edge_area_mm2: record.chip_edge_area_mm2(i),
        volume_over_radius_mm2: record.volume_over_radius_mm2(i),
        dt_s: step.dt_s,
        band_offsets_mm: record.band_offsets_mm(i),
        feed_dir: feed_dir(&step.step),
        len_xy_mm: len_xy_mm(&step.step),
        cell_mm: grid_mm,
    }
}

/// A step's unit XY feed direction, [0, 0] where it has no horizontal part
/// (the frame of its forces through a tooth period, MODEL.md §3.4).
pub(crate) fn feed_dir(step: &dexel::Step) -> [f64; 2] {
    let (dx, dy) = (
        step.to_mm[0] - step.from_mm[0],
        step.to_mm[1] - step.from_mm[1],
    );
    let xy = dx.hypot(dy);
    if xy > 0.0 {
        [dx / xy, dy / xy]
    } else {
        [0.0, 0.0]
    }
}

/// A step's length in XY, mm.
pub(crate) fn len_xy_mm(step: &dexel::Step) -> f64 {
    (step.to_mm[0] - step.from_mm[0]).hypot(step.to_mm[1] - step.from_mm[1])
}

/// The step the `tool_breaks` warning describes (MODEL.md §4.4): of the steps
/// whose stress exceeds their tool's rupture strength (`ruptures_mpa`, per
/// step), the one of the highest stress (the warning's value; the first of
/// equals), with its stress over its rupture strength. Its tool, line, force
/// and rupture strength are the message's, so that with tools of different
/// strengths the message speaks of one step. `None` when no step breaks.
pub(crate) fn breaking_step(
    loads: &[StepLoad],
    rupture_mpa: impl Fn(usize) -> f64,
) -> Option<(usize, f64)> {
    let mut worst: Option<usize> = None;
    for (i, l) in loads.iter().enumerate() {
        if l.breaks(rupture_mpa(i)) && worst.is_none_or(|w| l.stress_mpa > loads[w].stress_mpa) {
            worst = Some(i);
        }
    }
    worst.map(|w| (w, loads[w].stress_mpa / rupture_mpa(w)))
}
