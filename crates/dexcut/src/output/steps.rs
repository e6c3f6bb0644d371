//! The per-step results of a run: steps.csv, and its binary form for long
//! programs (`steps.json` and one NumPy `.npy` array per column, written by
//! `export::NpyTableWriter`). Both are written from the same column
//! definitions below, so they hold the same values: the CSV prints each f64
//! in its shortest round-trip form, the arrays keep its bits.

use std::path::Path;

use export::{NpyType, NpyValues, TableColumn};

use crate::error::{Error, Result};
use crate::run::Run;
use crate::util::fmt;

/// How a run's per-step results are written (`--steps-format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StepsFormat {
    /// steps.csv up to [`AUTO_NPY_STEPS`] steps, the `.npy` arrays above.
    #[default]
    Auto,
    /// steps.csv: one text row per step.
    Csv,
    /// `steps.json` and `steps_<column>.npy`: one binary array per column.
    Npy,
    /// Both.
    Both,
}

/// Above this many steps, [`StepsFormat::Auto`] writes the `.npy` arrays
/// instead of steps.csv (about 90 MB of text; the 1 M-block program's 522 505
/// steps are 232 MB, which the CSV took 2.1 s of CPU to print, BENCHMARKS.md).
pub const AUTO_NPY_STEPS: usize = 200_000;

impl StepsFormat {
    /// The format written for a run of `steps` steps: [`StepsFormat::Auto`]
    /// made [`StepsFormat::Csv`] or [`StepsFormat::Npy`], the others as they are.
    pub fn resolve(self, steps: usize) -> StepsFormat {
        match self {
            StepsFormat::Auto if steps > AUTO_NPY_STEPS => StepsFormat::Npy,
            StepsFormat::Auto => StepsFormat::Csv,
            other => other,
        }
    }

    fn csv(self) -> bool {
        matches!(self, StepsFormat::Csv | StepsFormat::Both)
    }

    fn npy(self) -> bool {
        matches!(self, StepsFormat::Npy | StepsFormat::Both)
    }
}

/// Name, unit and meaning of a column.
type ColumnDef = (&'static str, &'static str, &'static str);

/// The f64 columns before the band volumes, in steps.csv's order ([`Run::step_head`]).
const HEAD: [ColumnDef; 7] = [
    ("t_s", "s", "time at the end of the step from the program start"),
    ("x", "mm", "tool tip X at the end of the step (machine frame)"),
    ("y", "mm", "tool tip Y at the end of the step"),
    ("z", "mm", "tool tip Z at the end of the step"),
    ("feed_mm_min", "mm/min", "mean path speed over the step"),
    ("volume_mm3", "mm³", "volume the step removed (bands and shank)"),
    ("mrr_mm3_s", "mm³/s", "removal rate of the step's servo period (over the periods covering 6 grid cells where a period travels less than one, MODEL.md §2.3)"),
];

/// The f64 columns after the band volumes, in steps.csv's order ([`Run::step_loads`]).
const LOADS: [ColumnDef; 15] = [
    (
        "shank_mm3",
        "mm³",
        "volume removed above the flute length (shank contact)",
    ),
    (
        "force_n",
        "N",
        "magnitude of the mean lateral cutting force on the tool",
    ),
    (
        "force_peak_n",
        "N",
        "largest lateral force on the tool over a revolution (MODEL.md §3.4)",
    ),
    ("fx_n", "N", "X component of the force on the tool"),
    ("fy_n", "N", "Y component of the force on the tool"),
    (
        "fz_n",
        "N",
        "axial force on the tool (pulling it out of the holder)",
    ),
    ("power_w", "W", "spindle cutting power"),
    ("torque_nm", "N·m", "spindle torque"),
    (
        "chip_mm",
        "mm",
        "mean chip thickness per tooth (0 where nothing was cut)",
    ),
    (
        "contact_height_mm",
        "mm",
        "height above the tip where the resultant of the band loads acts",
    ),
    (
        "deflection_um",
        "µm",
        "lateral deflection of the tool at the contact height",
    ),
    (
        "dx_um",
        "µm",
        "X component of the deflection at the contact height",
    ),
    (
        "dy_um",
        "µm",
        "Y component of the deflection at the contact height",
    ),
    ("tip_deflection_um", "µm", "lateral deflection of the tip"),
    ("stress_mpa", "MPa", "largest von Mises stress in the tool"),
];

/// The integer columns at the end of steps.csv.
const BREAKS: ColumnDef = (
    "breaks",
    "1",
    "1 where the stress exceeds the tool's rupture strength: the tool breaks there, and the deflections given are the elastic ones at rupture (MODEL.md §4.4)",
);
const LINE: ColumnDef = ("line", "1", "program line of the block the step ends in");
const RAPID: ColumnDef = ("rapid", "1", "1 for a rapid (G0) step, 0 for a feed step");
const TOOL: ColumnDef = ("tool", "1", "number (T word) of the tool cutting the step");

/// Name of the band column of the binary form (steps.csv's `band_<k>_mm3`).
const BAND: &str = "band_mm3";

/// What a row of the binary form is.
const NPY_LAYOUT: &str = "row i of every array is step i (steps.csv's row with step = i): a servo period of a G-code program (split where it crosses the start or end of a rapid) or a move of a CSV point list";

/// Steps per block written to the `.npy` arrays (a block's values are copied
/// into column buffers, about 300 B a step with 20 bands).
const NPY_BLOCK_STEPS: usize = 16 * 1024;

/// A run's per-step results as whole columns, in steps.csv's order: the
/// values of the steps' `.npy` arrays, bit for bit (both are made by one
/// function, [`Run::step_columns`] whole, the arrays' writer a block of steps
/// at a time). Row i of every column is step i.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepColumns {
    /// The f64 columns before the band volumes: `t_s`, `x`, `y`, `z`,
    /// `feed_mm_min`, `volume_mm3`, `mrr_mm3_s` ([`StepColumns::HEAD`]).
    pub head: [Vec<f64>; 7],
    /// The band volumes, mm³, row-major `(steps, band_count)`: element
    /// `[i * band_count + k]` is band k of step i (steps.csv's `band_k_mm3`).
    pub bands: Vec<f64>,
    /// Bands listed per step: up to the highest any step cut (steps.csv
    /// lists all the tool's; those above are zero in every step).
    pub band_count: usize,
    /// The f64 columns after the band volumes: `shank_mm3`, `force_n`, …,
    /// `stress_mpa` ([`StepColumns::LOADS`]).
    pub loads: [Vec<f64>; 15],
    /// 1 where the stress exceeds the tool's rupture strength.
    pub breaks: Vec<u8>,
    /// Program line of the block the step ends in.
    pub line: Vec<u32>,
    /// 1 for a rapid (G0) step.
    pub rapid: Vec<u8>,
    /// Number (T word) of the tool cutting the step.
    pub tool: Vec<u32>,
}

impl StepColumns {
    /// Names of [`StepColumns::head`], in order.
    pub const HEAD: [&'static str; 7] = [
        HEAD[0].0, HEAD[1].0, HEAD[2].0, HEAD[3].0, HEAD[4].0, HEAD[5].0, HEAD[6].0,
    ];
    /// Names of [`StepColumns::loads`], in order.
    pub const LOADS: [&'static str; 15] = [
        LOADS[0].0,
        LOADS[1].0,
        LOADS[2].0,
        LOADS[3].0,
        LOADS[4].0,
        LOADS[5].0,
        LOADS[6].0,
        LOADS[7].0,
        LOADS[8].0,
        LOADS[9].0,
        LOADS[10].0,
        LOADS[11].0,
        LOADS[12].0,
        LOADS[13].0,
        LOADS[14].0,
    ];
    /// Name of [`StepColumns::bands`] (the arrays' `steps_band_mm3.npy`).
    pub const BANDS: &'static str = BAND;

    fn with_capacity(steps: usize, band_count: usize) -> StepColumns {
        StepColumns {
            head: std::array::from_fn(|_| Vec::with_capacity(steps)),
            bands: Vec::with_capacity(steps * band_count),
            band_count,
            loads: std::array::from_fn(|_| Vec::with_capacity(steps)),
            breaks: Vec::with_capacity(steps),
            line: Vec::with_capacity(steps),
            rapid: Vec::with_capacity(steps),
            tool: Vec::with_capacity(steps),
        }
    }

    fn clear(&mut self) {
        self.head.iter_mut().for_each(Vec::clear);
        self.loads.iter_mut().for_each(Vec::clear);
        self.bands.clear();
        self.breaks.clear();
        self.line.clear();
        self.rapid.clear();
        self.tool.clear();
    }

    /// Steps held.
    pub fn len(&self) -> usize {
        self.line.len()
    }

    /// No step.
    pub fn is_empty(&self) -> bool {
        self.line.is_empty()
    }
}

impl Run {
    /// Step `i`'s values before its band volumes, as [`HEAD`] lists them.
    fn step_head(&self, i: usize, mrr_mm3_s: &[f64]) -> [f64; 7] {
        let s = &self.steps[i];
        let [x, y, z] = s.step.to_mm;
        [
            s.t_end_s,
            x,
            y,
            z,
            s.feed_mm_min,
            self.record.volume_mm3(i),
            mrr_mm3_s[i],
        ]
    }

    /// Step `i`'s values after its band volumes, as [`LOADS`] lists them.
    fn step_loads(&self, i: usize) -> [f64; 15] {
        let l = &self.loads[i];
        [
            self.record.shank_volume_mm3(i),
            l.force_n,
            l.force_peak_n,
            l.fx_n,
            l.fy_n,
            l.fz_n,
            l.power_w,
            l.torque_nm,
            l.chip_thickness_mm,
            l.contact_height_mm,
            l.deflection_um,
            l.dx_um,
            l.dy_um,
            l.tip_deflection_um,
            l.stress_mpa,
        ]
    }

    /// Bands the steps' binary form lists: up to the highest any step cut.
    fn npy_band_count(&self) -> usize {
        // A finishing cut reaches one or two of a tool's 20 bands: the
        // bands above the highest any step cut would be zeros.
        (0..self.steps.len())
            .map(|i| self.record.band_volumes_mm3(i).len())
            .max()
            .unwrap_or(0)
            .min(self.record.n_bands)
    }

    /// Append steps `at`'s values to `rows` (whose `band_count` is
    /// [`Run::npy_band_count`]); `mrr_mm3_s`: [`Run::period_mrr_by_step_mm3_s`].
    fn push_step_rows(
        &self,
        at: std::ops::Range<usize>,
        mrr_mm3_s: &[f64],
        rows: &mut StepColumns,
    ) {
        let n_bands = rows.band_count;
        for i in at {
            for (col, v) in rows.head.iter_mut().zip(self.step_head(i, mrr_mm3_s)) {
                col.push(v);
            }
            let stored = self.record.band_volumes_mm3(i);
            rows.bands
                .extend_from_slice(&stored[..stored.len().min(n_bands)]);
            rows.bands.extend(std::iter::repeat_n(
                0.0,
                n_bands.saturating_sub(stored.len()),
            ));
            for (col, v) in rows.loads.iter_mut().zip(self.step_loads(i)) {
                col.push(v);
            }
            rows.breaks.push(u8::from(self.breaks(i)));
            let s = &self.steps[i];
            rows.line.push(s.line);
            rows.rapid.push(u8::from(s.step.rapid));
            rows.tool.push(s.tool);
        }
    }

    /// The per-step results as whole columns: the values the steps' `.npy`
    /// arrays hold ([`Run::write_steps_npy`]), bit for bit.
    pub fn step_columns(&self) -> StepColumns {
        let n = self.steps.len();
        let mrr = self.period_mrr_by_step_mm3_s();
        let mut rows = StepColumns::with_capacity(n, self.npy_band_count());
        self.push_step_rows(0..n, &mrr, &mut rows);
        rows
    }

    /// Write the per-step results into the folder `dir` as `format` says
    /// (resolved for this run's step count): `<stem>.csv`, and/or
    /// `<stem>.json` with `<stem>_<column>.npy`. Returns the format written.
    pub fn write_steps(&self, dir: &Path, stem: &str, format: StepsFormat) -> Result<StepsFormat> {
        let format = format.resolve(self.steps.len());
        if format.csv() {
            self.write_steps_csv(&dir.join(format!("{stem}.csv")))?;
        }
        if format.npy() {
            self.write_steps_npy(dir, stem)?;
        }
        Ok(format)
    }

    /// Write steps.csv.
    pub fn write_steps_csv(&self, path: &Path) -> Result<()> {
        let n_bands = self.record.n_bands;
        export::atomic::write_file(path, |w| {
            let bands: Vec<String> = (0..n_bands).map(|k| format!("band_{k}_mm3")).collect();
            let header: Vec<&str> = std::iter::once("step")
                .chain(HEAD.iter().map(|c| c.0))
                .chain(bands.iter().map(String::as_str))
                .chain(LOADS.iter().map(|c| c.0))
                .chain([BREAKS, LINE, RAPID, TOOL].map(|c| c.0))
                .collect();
            let mrr = self.period_mrr_by_step_mm3_s();
            export::write_csv_records(w, Some(&header), self.steps.len(), |i, row| {
                let s = &self.steps[i];
                row.push(i.to_string());
                row.extend(self.step_head(i, &mrr).map(fmt));
                row.extend((0..n_bands).map(|k| fmt(self.record.band_volume_mm3(i, k))));
                row.extend(self.step_loads(i).map(fmt));
                row.push(u8::from(self.breaks(i)).to_string());
                row.push(s.line.to_string());
                row.push(u8::from(s.step.rapid).to_string());
                row.push(s.tool.to_string());
            })
        })
        .map_err(|e| Error::io("cannot write", path, e))
    }

    /// Write `<stem>.json` and one `.npy` array per column of steps.csv into
    /// `dir`: f64 (`<f8`) values, the band volumes as one `(steps, K)` array
    /// (K: bands up to the highest any step cut; steps.csv lists all the
    /// tool's bands, those above K all zero), the line and tool as `<u4`, the
    /// rapid and breaks flags as `|u1`; the step number is the row.
    pub fn write_steps_npy(&self, dir: &Path, stem: &str) -> Result<()> {
        let n = self.steps.len();
        let n_bands = self.npy_band_count();
        let h = self.record.band_height_mm;
        let band_meaning = format!(
            "volume removed in each tool height band: element [i, k] is band k ({h}·k to {h}·(k + 1) mm above the tip) of step i, steps.csv's band_k_mm3; the bands of the flutes above the {n_bands} listed (steps.csv lists {}) removed nothing in any step",
            self.record.n_bands
        );
        let column = |(name, unit, meaning): ColumnDef, dtype| TableColumn {
            name,
            unit,
            meaning,
            dtype,
            width: None,
        };
        let mut columns: Vec<TableColumn> = HEAD.iter().map(|&c| column(c, NpyType::F64)).collect();
        columns.push(TableColumn {
            name: BAND,
            unit: "mm³",
            meaning: &band_meaning,
            dtype: NpyType::F64,
            width: Some(n_bands),
        });
        columns.extend(LOADS.iter().map(|&c| column(c, NpyType::F64)));
        columns.extend([
            column(BREAKS, NpyType::U8),
            column(LINE, NpyType::U32),
            column(RAPID, NpyType::U8),
            column(TOOL, NpyType::U32),
        ]);
        let export_err = |e: export::Error| {
            Error::Export(e).context(format!(
                "cannot write the steps' arrays ({stem}.json) in {}",
                dir.display()
            ))
        };
        let mut writer = export::NpyTableWriter::begin(dir, stem, n, NPY_LAYOUT, &columns)
            .map_err(export_err)?;
        let mrr = self.period_mrr_by_step_mm3_s();
        let block = NPY_BLOCK_STEPS.min(n.max(1));
        let mut rows = StepColumns::with_capacity(block, n_bands);
        for start in (0..n).step_by(block) {
            rows.clear();
            self.push_step_rows(start..(start + block).min(n), &mrr, &mut rows);
            let mut values: Vec<NpyValues> = rows.head.iter().map(|c| NpyValues::F64(c)).collect();
            values.push(NpyValues::F64(&rows.bands));
            values.extend(rows.loads.iter().map(|c| NpyValues::F64(c)));
            values.extend([
                NpyValues::U8(&rows.breaks),
                NpyValues::U32(&rows.line),
                NpyValues::U8(&rows.rapid),
                NpyValues::U32(&rows.tool),
            ]);
            writer.write_rows(&values).map_err(export_err)?;
        }
        writer.finish().map_err(export_err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_writes_the_arrays_above_the_step_count_only() {
        assert_eq!(StepsFormat::default(), StepsFormat::Auto);
        assert_eq!(StepsFormat::Auto.resolve(0), StepsFormat::Csv);
        assert_eq!(StepsFormat::Auto.resolve(AUTO_NPY_STEPS), StepsFormat::Csv);
        assert_eq!(
            StepsFormat::Auto.resolve(AUTO_NPY_STEPS + 1),
            StepsFormat::Npy
        );
        for f in [StepsFormat::Csv, StepsFormat::Npy, StepsFormat::Both] {
            assert_eq!(f.resolve(1), f);
            assert_eq!(f.resolve(10 * AUTO_NPY_STEPS), f);
        }
        assert!(StepsFormat::Both.csv() && StepsFormat::Both.npy());
        assert!(!StepsFormat::Csv.npy() && !StepsFormat::Npy.csv());
    }

    /// steps.csv's header is the column lists in order: one list for both forms.
    #[test]
    fn the_column_lists_are_steps_csv_order() {
        let names: Vec<&str> = HEAD
            .iter()
            .chain(&LOADS)
            .chain(&[BREAKS, LINE, RAPID, TOOL])
            .map(|c| c.0)
            .collect();
        assert_eq!(
            names.join(","),
            "t_s,x,y,z,feed_mm_min,volume_mm3,mrr_mm3_s,shank_mm3,force_n,force_peak_n,fx_n,fy_n,fz_n,power_w,torque_nm,chip_mm,contact_height_mm,deflection_um,dx_um,dy_um,tip_deflection_um,stress_mpa,breaks,line,rapid,tool"
        );
    }
}
