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
const LOADS: [ColumnDef; 14] = [
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
    fn step_loads(&self, i: usize) -> [f64; 14] {
        let l = &self.loads[i];
        [
            self.record.shank_volume_mm3(i),
            l.force_n,
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
            let mut out = csv::Writer::from_writer(w);
            let mut header: Vec<String> = vec!["step".into()];
            header.extend(HEAD.iter().map(|c| c.0.to_string()));
            header.extend((0..n_bands).map(|k| format!("band_{k}_mm3")));
            header.extend(LOADS.iter().map(|c| c.0.to_string()));
            header.extend([BREAKS, LINE, RAPID, TOOL].map(|c| c.0.to_string()));
            out.write_record(&header)?;
            let mut row: Vec<String> = Vec::with_capacity(header.len());
            let mrr = self.period_mrr_by_step_mm3_s();
            for (i, s) in self.steps.iter().enumerate() {
                row.clear();
                row.push(i.to_string());
                row.extend(self.step_head(i, &mrr).map(fmt));
                row.extend((0..n_bands).map(|k| fmt(self.record.band_volume_mm3(i, k))));
                row.extend(self.step_loads(i).map(fmt));
                row.push(u8::from(self.breaks(i)).to_string());
                row.push(s.line.to_string());
                row.push(u8::from(s.step.rapid).to_string());
                row.push(s.tool.to_string());
                out.write_record(&row)?;
            }
            out.flush()?;
            Ok(())
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
        // A finishing cut reaches one or two of a tool's 20 bands: the
        // bands above the highest any step cut would be zeros.
        let n_bands = (0..n)
            .map(|i| self.record.band_volumes_mm3(i).len())
            .max()
            .unwrap_or(0)
            .min(self.record.n_bands);
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
        let mut head: [Vec<f64>; 7] = std::array::from_fn(|_| Vec::with_capacity(block));
        let mut loads: [Vec<f64>; 14] = std::array::from_fn(|_| Vec::with_capacity(block));
        let mut bands: Vec<f64> = Vec::with_capacity(block * n_bands);
        let mut breaks: Vec<u8> = Vec::with_capacity(block);
        let mut line: Vec<u32> = Vec::with_capacity(block);
        let mut rapid: Vec<u8> = Vec::with_capacity(block);
        let mut tool: Vec<u32> = Vec::with_capacity(block);
        for start in (0..n).step_by(block) {
            let end = (start + block).min(n);
            head.iter_mut().for_each(Vec::clear);
            loads.iter_mut().for_each(Vec::clear);
            bands.clear();
            breaks.clear();
            line.clear();
            rapid.clear();
            tool.clear();
            for i in start..end {
                for (col, v) in head.iter_mut().zip(self.step_head(i, &mrr)) {
                    col.push(v);
                }
                let stored = self.record.band_volumes_mm3(i);
                bands.extend_from_slice(&stored[..stored.len().min(n_bands)]);
                bands.extend(std::iter::repeat_n(
                    0.0,
                    n_bands.saturating_sub(stored.len()),
                ));
                for (col, v) in loads.iter_mut().zip(self.step_loads(i)) {
                    col.push(v);
                }
                breaks.push(u8::from(self.breaks(i)));
                let s = &self.steps[i];
                line.push(s.line);
                rapid.push(u8::from(s.step.rapid));
                tool.push(s.tool);
            }
            let mut values: Vec<NpyValues> = head.iter().map(|c| NpyValues::F64(c)).collect();
            values.push(NpyValues::F64(&bands));
            values.extend(loads.iter().map(|c| NpyValues::F64(c)));
            values.extend([
                NpyValues::U8(&breaks),
                NpyValues::U32(&line),
                NpyValues::U8(&rapid),
                NpyValues::U32(&tool),
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
            "t_s,x,y,z,feed_mm_min,volume_mm3,mrr_mm3_s,shank_mm3,force_n,fx_n,fy_n,fz_n,power_w,torque_nm,chip_mm,contact_height_mm,deflection_um,dx_um,dy_um,tip_deflection_um,stress_mpa,breaks,line,rapid,tool"
        );
    }
}
