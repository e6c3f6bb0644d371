//! The design comparison (S1, MODEL.md §8): the final surface of a run
//! against the job's `[design]` model, per column and per program line.

use dexel::NEVER_CUT;

use crate::error::Result;
use crate::model::summary::{DesignInfo, DeviationKind, LineDeviation};
use crate::run::Run;
use crate::setup::Setup;

/// Per program line, the columns beyond tolerance (MODEL.md §8): `deviations` is
/// `(line of the last cut or None, signed distance µm, x mm, y mm)` for each column.
fn line_deviations(
    deviations: impl Iterator<Item = (Option<u32>, f64, f64, f64)>,
    gouge_tolerance_um: f64,
    stock_tolerance_um: f64,
) -> (Vec<LineDeviation>, usize) {
    let mut by_line: std::collections::BTreeMap<(u32, u8), LineDeviation> = Default::default();
    let mut uncut = 0;
    for (line, d_um, x_mm, y_mm) in deviations {
        let kind = if d_um < -gouge_tolerance_um {
            (0u8, DeviationKind::Gouge)
        } else if d_um > stock_tolerance_um {
            (1u8, DeviationKind::Stock)
        } else {
            continue;
        };
        let Some(line) = line else {
            uncut += usize::from(kind.0 == 1);
            continue;
        };
        let entry = by_line.entry((line, kind.0)).or_insert(LineDeviation {
            line,
            kind: kind.1,
            worst_um: d_um,
            x_mm,
            y_mm,
            columns: 0,
        });
        entry.columns += 1;
        if d_um.abs() > entry.worst_um.abs() {
            (entry.worst_um, entry.x_mm, entry.y_mm) = (d_um, x_mm, y_mm);
        }
    }
    (by_line.into_values().collect(), uncut)
}

/// A run's comparison with the `[design]` model: each column's signed
/// distance to it, µm (positive = stock left), and the per-line comparison.
pub type Comparison = (Vec<f32>, DesignInfo);

/// Signed distance (µm) of each column's top (the final stock's top heights) to the design model; positive = stock left.
pub fn design_comparison(setup: &Setup, run: &Run) -> Result<Option<Comparison>> {
    let Some((path, model)) = &setup.design else {
        return Ok(None);
    };
    let tops = run.stock.top_heights();
    let grid = *run.stock.grid();
    let point = |i: usize| {
        [
            grid.x_mm(i % grid.nx),
            grid.y_mm(i / grid.nx),
            tops[i] as f64,
        ]
    };
    let valid: Vec<usize> = (0..tops.len()).filter(|&i| tops[i].is_finite()).collect();
    let distances = model.signed_distances_mm(&valid.iter().map(|&i| point(i)).collect::<Vec<_>>());
    let mut diff_um = vec![f32::NAN; tops.len()];
    for (&i, d) in valid.iter().zip(&distances) {
        diff_um[i] = (d * 1000.0) as f32;
    }
    let last_cut = run.stock.last_cut();
    let line_of = |i: usize| {
        let step = last_cut[i];
        (step != NEVER_CUT).then(|| run.steps[step as usize].line)
    };
    let spec = setup.job.design.as_ref();
    let gouge_tolerance_um = spec.map_or(10.0, |d| d.gouge_tolerance_um);
    let stock_tolerance_um = spec.map_or(50.0, |d| d.stock_tolerance_um);
    let (lines, uncut_stock_columns) = line_deviations(
        valid.iter().zip(&distances).map(|(&i, d)| {
            let [x, y, _] = point(i);
            (line_of(i), d * 1000.0, x, y)
        }),
        gouge_tolerance_um,
        stock_tolerance_um,
    );
    let mut info = DesignInfo {
        path: path.display().to_string(),
        max_stock_left_um: distances.iter().copied().fold(0.0, f64::max) * 1000.0,
        worst_gouge_um: 0.0,
        worst_gouge_line: None,
        worst_gouge_xy_mm: None,
        gouge_tolerance_um,
        stock_tolerance_um,
        lines,
        uncut_stock_columns,
    };
    if let Some((j, d)) = distances
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
    {
        if *d < 0.0 {
            let i = valid[j];
            let [x, y, _] = point(i);
            info.worst_gouge_um = d * 1000.0;
            info.worst_gouge_xy_mm = Some([x, y]);
            info.worst_gouge_line = line_of(i);
        }
    }
    Ok(Some((diff_um, info)))
}
