//! Every tool's chip-load cap against what the program feeds it, and the
//! warning of a cap far below the programmed feed.

use crate::input::tools::ToolSet;
use crate::model::summary::ToolChipLoad;
use crate::model::warnings::{Warning, WarningKind};
use crate::run::Run;

/// Every tool's chip-load cap, at the spindle speed of its fastest cutting
/// step in `run` (the program as given); empty without chip-load limits.
pub fn chip_loads(
    run: &Run,
    tools: &ToolSet,
    program: &crate::input::program::Program,
    material: &str,
) -> Vec<ToolChipLoad> {
    let top = run.top_cutting_step_by_tool(tools);
    tools
        .entries
        .iter()
        .zip(top)
        .filter_map(|(e, top)| {
            let fz_max_mm = e.fz_max_mm?;
            let step = top.map(|i| &run.steps[i]);
            let block_rpm = step.map_or(0.0, |s| s.spindle_rpm);
            let rpm = e.spindle_rpm(block_rpm);
            let fallback = match program
                .spindle_rpm_for(e.tool.diameter_mm, (!tools.single).then_some(e.number))
            {
                p if p > 0.0 => format!("taken from the program's highest plausible S{p}"),
                _ => "assumed 10000 rev/min, the default".to_string(),
            };
            let spindle_from = if e.job_rpm.is_some() {
                "[cutting] spindle_rpm".to_string()
            } else if crate::input::tools::plausible_rpm(e.tool.diameter_mm, block_rpm) {
                format!("S{block_rpm}")
            } else if block_rpm > 0.0 {
                format!(
                    "S{block_rpm} is {:.2} m/min at the edge, not a spindle speed: {fallback}",
                    crate::input::tools::cutting_speed_m_min(e.tool.diameter_mm, block_rpm)
                )
            } else {
                format!("no S word: {fallback}")
            };
            let feed_mm_min = e.chip_load_feed_mm_min(block_rpm)?;
            let programmed = step.map(|s| s.feed_mm_min);
            Some(ToolChipLoad {
                tool: e.number,
                diameter_mm: e.tool.diameter_mm,
                flutes: e.model.flutes,
                fz_max_mm,
                fz_max_from: if e.fz_max_given {
                    "fz_max".into()
                } else {
                    format!("default for {material}, Ø{} mm", e.tool.diameter_mm)
                },
                spindle_rpm: rpm,
                spindle_from,
                feed_mm_min,
                programmed_feed_mm_min: programmed,
                programmed_fz_mm: programmed.map(|f| f / (f64::from(e.model.flutes) * rpm)),
                line: step.map(|s| s.line),
            })
        })
        .collect()
}

/// A chip-load cap below this share of the tool's programmed cutting feed is
/// warned of ([`chip_load_check`]).
pub const CHIP_LOAD_FAR_BELOW: f64 = 0.2;

/// One warning per tool whose chip-load cap is below
/// [`CHIP_LOAD_FAR_BELOW`] of the feed the program cuts with: optimize will
/// slow its cuts many times, which a machinist trusts only if the cap is
/// right for the stock and the tool.
pub fn chip_load_check(
    loads: &[ToolChipLoad],
    tools: &crate::input::tools::ToolSet,
) -> Vec<Warning> {
    loads
        .iter()
        .filter_map(|c| {
            let programmed = c.programmed_feed_mm_min?;
            if c.feed_mm_min >= CHIP_LOAD_FAR_BELOW * programmed {
                return None;
            }
            let line = c.line?;
            Some(Warning {
                kind: WarningKind::ChipLoad,
                line: Some(line),
                value: programmed / c.feed_mm_min,
                unit: "×".into(),
                steps: 0,
                lines: vec![line],
                message: format!(
                    "{} with {} flutes cuts at F{programmed:.0}, {:.4} mm/tooth at {:.0} rev/min ({}), but its chip-load cap is {:.4} mm/tooth ({}) = {:.0} mm/min, {:.1}× lower: optimize slows its cuts to the cap. If the stock is wood or plastic, or the tool is made for more, set fz_max for the tool ([tool] or its [[tools]] entry) or [cutting] material (the default table has metals only, MODEL.md §2.1); if the spindle speed is wrong, set [cutting] spindle_rpm",
                    tools.name(c.tool),
                    c.flutes,
                    c.programmed_fz_mm.unwrap_or(f64::NAN),
                    c.spindle_rpm,
                    c.spindle_from,
                    c.fz_max_mm,
                    c.fz_max_from,
                    c.feed_mm_min,
                    programmed / c.feed_mm_min,
                ),
            })
        })
        .collect()
}
