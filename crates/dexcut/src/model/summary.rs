//! summary.json: one versioned schema, written and read through the same serde
//! types ([`SimulateSummary`], [`OptimizeSummary`]). `report` reads it back
//! through [`read`], never as untyped JSON.
//!
//! Every file carries `schema_version` ([`SCHEMA_VERSION`]) and `command`
//! (`"simulate"`, `"optimize"`, or `"operations"` for a job of operations). A change of the layout that an older reader
//! cannot read raises the version; a reader refuses any other version with a
//! message that says which one it reads.

use std::path::Path;

use crate::error::{fail, Result, ResultExt as _};
use serde::{Deserialize, Deserializer, Serialize};

pub use super::run_summary::{GridInfo, Summary, ToolPeaks};
pub use super::warnings::{Warning, WarningKind, Warnings};

/// The set-up a run used, for the report's set-up table.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SetupInfo {
    /// Workpiece material (`[cutting] material`).
    pub material: String,
    /// Spindle speed, rev/min.
    pub spindle_rpm: f64,
    /// The tools, in table order.
    pub tools: Vec<ToolInfo>,
    /// Servo period, ms.
    pub period_ms: f64,
    /// Highest programmable feed, mm/min.
    pub feed_max_mm_min: f64,
    /// Rapid feed, mm/min.
    pub rapid_mm_min: f64,
    /// Axis accelerations X, Y, Z, mm/s².
    pub accel_mm_s2: [f64; 3],
    /// Axis jerks X, Y, Z, mm/s³, if limited.
    pub jerk_mm_s3: Option<[f64; 3]>,
    /// The job's `[limits]` (what optimize holds to; simulate only reports).
    pub limits: Vec<(String, f64, String)>,
}

/// One tool of the set-up.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ToolInfo {
    /// T number.
    pub number: u32,
    /// `"ball"`, `"flat"` or `"bull r=R"`.
    pub shape: String,
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Flutes.
    pub flutes: u32,
    /// Holder face to tip, mm.
    pub stickout_mm: f64,
    /// Largest feed per tooth, mm/tooth, if capped.
    pub fz_max_mm: Option<f64>,
    /// Allowable von Mises stress, MPa (MODEL.md §4.4); absent in summaries
    /// written before it was recorded.
    #[serde(default)]
    pub stress_limit_mpa: Option<f64>,
}

/// summary.json of `simulate` (schema in [`crate::model::summary`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SimulateSummary {
    /// Headline numbers of the run.
    #[serde(flatten)]
    pub run: Summary,
    /// Job file.
    pub job: String,
    /// Program file.
    pub program: String,
    /// The program run in exact stop, every segment from rest to rest at its own feed and
    /// axis-limited acceleration (`schedule::exact_stop_time_s`, MODEL.md §6.1, "Exact
    /// stop"): the simplest feasible timing, beside `cycle_time_s` (which can still
    /// exceed it with a jerk limit at short servo periods, MODEL.md §6.1, "Stop or
    /// pass"); absent in summaries written before it was recorded.
    #[serde(default)]
    pub exact_stop_time_s: Option<f64>,
    /// Stock grid, so `report` can rebuild the maps.
    pub grid: GridInfo,
    /// The final surface against the `[design]` model.
    pub design: Option<DesignInfo>,
    /// Material, tools, machine and limits of the job.
    #[serde(default)]
    pub setup: Option<SetupInfo>,
    /// The stock the run left, saved into `stock/` (`--save-stock`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saved_stock: Option<crate::saved_stock::SavedStockDoc>,
    /// Wall time of the command, s.
    pub run_time_s: f64,
    /// The run that wrote the folder (as in manifest.json).
    pub run_id: String,
}

/// summary.json of `optimize` (schema in [`crate::model::summary`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OptimizeSummary {
    /// Job file.
    pub job: String,
    /// Program file.
    pub program: String,
    /// Stock grid, so `report` can rebuild the maps.
    pub grid: GridInfo,
    /// The program as given.
    pub before: Summary,
    /// optimized.nc read back and simulated.
    pub after: Summary,
    /// The limits it worked to.
    pub limits: LimitsOut,
    /// Share of the re-timed program's time spent at each cap.
    pub cap_time_share: Vec<CapShare>,
    /// Σ Δs / cap: no schedule under these caps can be faster.
    pub lower_bound_time_s: f64,
    /// The program as given run in exact stop, every segment from rest to rest at its
    /// programmed feed and axis-limited acceleration (`schedule::exact_stop_time_s`,
    /// MODEL.md §6.1, "Exact stop"), beside `before.cycle_time_s`; absent in summaries
    /// written before it was recorded.
    #[serde(default)]
    pub exact_stop_time_s: Option<f64>,
    /// (after − bound) / bound.
    #[serde(deserialize_with = "f64_or_nan")]
    pub optimality_gap: f64,
    /// Planner stations along the path.
    pub stations: usize,
    /// Spacing of the planner stations, mm.
    pub station_spacing_mm: f64,
    /// Peak MRR per servo period of the written program / mrr_max (≤ 1.02 is the target).
    pub peak_mrr_ratio: Option<f64>,
    /// Cycle time of the plan as written (each block at its feed), s.
    pub plan_time_s: f64,
    /// Cycle time with feeds free to change every 0.05 mm under the same caps, s.
    pub time_optimal_s: f64,
    /// (written program's cycle time − plan's) / plan's.
    #[serde(deserialize_with = "f64_or_nan")]
    pub written_vs_plan: f64,
    /// Rounds of writing, re-simulating and correcting the program.
    pub rounds: usize,
    /// Feeds within this ratio share a block in optimized.nc.
    pub merge_ratio: f64,
    /// The program as given was within every limit and faster: optimized.nc is the original.
    pub kept_original: bool,
    /// Largest feed per tooth on cutting moves, mm/tooth.
    pub fz_max_mm: Option<f64>,
    /// The final surface against the `[design]` model.
    pub design: Option<DesignInfo>,
    /// Material, tools, machine and limits of the job.
    #[serde(default)]
    pub setup: Option<SetupInfo>,
    /// The stock the run left, saved into `stock/` (`--save-stock`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saved_stock: Option<crate::saved_stock::SavedStockDoc>,
    /// Wall time of the command, s.
    pub run_time_s: f64,
    /// Wall time of the engagement sweep, s.
    pub time_engagement_s: f64,
    /// Wall time of planning and writing the program, s.
    pub time_plan_s: f64,
    /// Wall time of simulating the program as given, s.
    pub time_simulate_s: f64,
    /// The run that wrote the folder (as in manifest.json).
    pub run_id: String,
}

/// The limits optimize worked to, as summary.json records them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LimitsOut {
    /// `mrr_max`, mm³/s.
    pub mrr_max_mm3_s: Option<f64>,
    /// `force_max`, N.
    pub force_max_n: Option<f64>,
    /// `deflection_max_um`, µm.
    pub deflection_max_um: Option<f64>,
    /// `power_max_kw`, kW.
    pub power_max_kw: Option<f64>,
    /// `feed_min`, mm/min.
    pub feed_min_mm_min: Option<f64>,
    /// The machine's highest feed, mm/min.
    pub feed_max_mm_min: f64,
    /// fz_max · flutes · spindle rpm of the first tool, mm/min (`chip_load`
    /// gives every tool's).
    pub chip_load_feed_mm_min: Option<f64>,
    /// Every tool's chip-load cap against its programmed cutting feed.
    #[serde(default)]
    pub chip_load: Vec<ToolChipLoad>,
    /// `feed_scale_max`: at most this times the programmed feed.
    pub feed_scale_max: Option<f64>,
    /// The lowest `stress_limit_mpa` of the job's tools, MPa, where `[limits]
    /// stress` holds the tools to it (each tool is held to its own); None when off.
    #[serde(default)]
    pub stress_limit_mpa: Option<f64>,
}

/// Design comparison (S1): the final surface against the design model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DesignInfo {
    /// Design model file.
    pub path: String,
    /// Largest stock left (distance outside the design model), µm.
    pub max_stock_left_um: f64,
    /// Deepest gouge (negative distance), µm; 0 if none.
    pub worst_gouge_um: f64,
    /// Program line of the step that last cut the worst gouge.
    pub worst_gouge_line: Option<u32>,
    /// Column centre of the worst gouge, mm.
    pub worst_gouge_xy_mm: Option<[f64; 2]>,
    /// Tolerances the per-line lists use, µm.
    pub gouge_tolerance_um: f64,
    /// Stock above the design beyond this is listed, µm.
    pub stock_tolerance_um: f64,
    /// Every program line whose cut left a gouge deeper than `gouge_tolerance_um` or stock
    /// above `stock_tolerance_um` (S1, MODEL.md §8), by line, gouges first.
    pub lines: Vec<LineDeviation>,
    /// Columns no step cut that stand above the design by more than `stock_tolerance_um`.
    pub uncut_stock_columns: usize,
}

/// Which side of the design a deviation lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeviationKind {
    /// Below the design surface: material cut that the part needs.
    Gouge,
    /// Above the design surface: material left.
    Stock,
}

impl std::fmt::Display for DeviationKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DeviationKind::Gouge => "gouge",
            DeviationKind::Stock => "stock",
        })
    }
}

/// One program line's worst deviation from the design of one kind.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LineDeviation {
    /// Program line of the step that last cut the columns.
    pub line: u32,
    /// Below the design (gouge) or above it (stock).
    pub kind: DeviationKind,
    /// Worst signed distance, µm (negative for a gouge).
    pub worst_um: f64,
    /// Column centre of the worst one, mm.
    pub x_mm: f64,
    /// Column centre, y, mm.
    pub y_mm: f64,
    /// Number of columns beyond the tolerance whose last cut was on this line.
    pub columns: usize,
}

/// One tool's chip-load cap (MODEL.md §2.1) against what the program asks
/// of it: summary.json's `limits.chip_load`, one per tool of the job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ToolChipLoad {
    /// T number (1 for the single `[tool]`).
    pub tool: u32,
    /// Nominal diameter, mm.
    pub diameter_mm: f64,
    /// Flutes.
    pub flutes: u32,
    /// Largest feed per tooth, mm/tooth.
    pub fz_max_mm: f64,
    /// Where `fz_max_mm` comes from, in words (the job's `fz_max`, or the
    /// default for the material and diameter).
    pub fz_max_from: String,
    /// Spindle speed the cap is taken at, rev/min (that of the tool's
    /// fastest cutting step, or of a block without S where it cuts nothing).
    pub spindle_rpm: f64,
    /// Where `spindle_rpm` comes from, in words.
    pub spindle_from: String,
    /// The cap f_z,max · z · n, mm/min.
    pub feed_mm_min: f64,
    /// Highest programmed feed of a step the tool cuts, mm/min; None where it cuts nothing.
    pub programmed_feed_mm_min: Option<f64>,
    /// That feed per tooth at `spindle_rpm`, mm/tooth.
    pub programmed_fz_mm: Option<f64>,
    /// Program line of that step.
    pub line: Option<u32>,
}

/// Share of the optimised time spent at each kind of cap.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CapShare {
    /// The cap, in a user's words.
    pub cap: String,
    /// Share of the cycle time, 0…1.
    pub share: f64,
}

/// summary.json of a job of `[[operations]]`: the folder holds one results
/// folder per operation (`op1_roughing/`, each a `simulate` or `optimize`
/// folder with its own summary.json), and this document of the whole job.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OperationsSummary {
    /// What each operation's folder holds: "simulate" or "optimize".
    pub ran: String,
    /// Job file.
    pub job: String,
    /// The stock's grid (one stock through every operation).
    pub grid: GridInfo,
    /// The operations, in order.
    pub operations: Vec<OperationLine>,
    /// The operations' cycle times summed, s (optimize: of the programs written).
    pub cycle_time_s: f64,
    /// optimize: the programs as given, summed, s.
    pub cycle_time_before_s: Option<f64>,
    /// Stock volume before the first operation, mm³.
    pub initial_volume_mm3: f64,
    /// Stock volume after the last, mm³.
    pub final_volume_mm3: f64,
    /// Volume the operations removed, mm³.
    pub removed_volume_mm3: f64,
    /// The folder of the saved final stock (`--save-stock`), if written.
    pub saved_stock: Option<String>,
    /// Wall time of the command, s.
    pub run_time_s: f64,
    /// The run that wrote the folder (as in manifest.json and every operation's summary).
    pub run_id: String,
}

/// One operation of [`OperationsSummary`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OperationLine {
    /// 1-based position in the job.
    pub number: usize,
    /// Its name.
    pub name: String,
    /// Its results folder, relative to the job's.
    pub folder: String,
    /// Its program file.
    pub program: String,
    /// Its cycle time, s (optimize: of the program written).
    pub cycle_time_s: f64,
    /// optimize: of the program as given, s.
    pub cycle_time_before_s: Option<f64>,
    /// optimize: the program as given was kept (within every limit and faster).
    pub kept_original: Option<bool>,
    /// Volume it removed, mm³.
    pub removed_volume_mm3: f64,
    /// Its peaks (optimize: of the program written).
    pub peak_mrr_mm3_s: f64,
    /// Largest cutting force, N.
    pub peak_force_n: f64,
    /// Largest spindle power, W.
    pub peak_power_w: f64,
    /// Largest deflection at the contact height, µm.
    pub peak_deflection_um: f64,
    /// Its error map's range, µm.
    pub min_error_um: f64,
    /// Largest material left, µm.
    pub max_error_um: f64,
    /// Warnings in its summary.
    pub warnings: usize,
    /// Its peaks per tool.
    pub tools: Vec<ToolPeaks>,
}

/// The version of summary.json this build writes and reads.
pub const SCHEMA_VERSION: u32 = 1;

/// The body of a summary.json, by the command that wrote it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "command", rename_all = "lowercase")]
pub enum SummaryDoc {
    /// Written by `simulate`.
    Simulate(Box<SimulateSummary>),
    /// Written by `optimize`.
    Optimize(Box<OptimizeSummary>),
    /// Written by `simulate` or `optimize` for a job of `[[operations]]`.
    Operations(Box<OperationsSummary>),
}

impl SummaryDoc {
    /// The run id recorded in the file (as in manifest.json).
    pub fn run_id(&self) -> &str {
        match self {
            SummaryDoc::Simulate(s) => &s.run_id,
            SummaryDoc::Optimize(o) => &o.run_id,
            SummaryDoc::Operations(j) => &j.run_id,
        }
    }

    /// Stock grid of the run.
    pub fn grid(&self) -> &GridInfo {
        match self {
            SummaryDoc::Simulate(s) => &s.grid,
            SummaryDoc::Optimize(o) => &o.grid,
            SummaryDoc::Operations(j) => &j.grid,
        }
    }

    /// Program file of the run.
    pub fn program(&self) -> &str {
        match self {
            SummaryDoc::Simulate(s) => &s.program,
            SummaryDoc::Optimize(o) => &o.program,
            SummaryDoc::Operations(j) => &j.job,
        }
    }

    /// The design comparison, if the job has a `[design]` model.
    pub fn design(&self) -> Option<&DesignInfo> {
        match self {
            SummaryDoc::Simulate(s) => s.design.as_ref(),
            SummaryDoc::Optimize(o) => o.design.as_ref(),
            SummaryDoc::Operations(_) => None,
        }
    }
}

/// summary.json as a whole: the version, then the command's document.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SummaryFile {
    /// [`SCHEMA_VERSION`] of the writer.
    pub schema_version: u32,
    /// The document, tagged by `command`.
    #[serde(flatten)]
    pub doc: SummaryDoc,
}

/// The same layout as [`SummaryFile`], borrowing the document to write it.
#[derive(Serialize)]
struct Versioned<'a, T: Serialize> {
    schema_version: u32,
    command: &'static str,
    #[serde(flatten)]
    doc: &'a T,
}

/// Write the summary.json of `simulate`, atomically.
pub fn write_simulate(path: &Path, doc: &SimulateSummary) -> Result<()> {
    crate::util::write_json(
        path,
        &Versioned {
            schema_version: SCHEMA_VERSION,
            command: "simulate",
            doc,
        },
    )
}

/// Write the summary.json of `optimize`, atomically.
pub fn write_optimize(path: &Path, doc: &OptimizeSummary) -> Result<()> {
    crate::util::write_json(
        path,
        &Versioned {
            schema_version: SCHEMA_VERSION,
            command: "optimize",
            doc,
        },
    )
}

/// Write the summary.json of a job of `[[operations]]`, atomically.
pub fn write_operations(path: &Path, doc: &OperationsSummary) -> Result<()> {
    crate::util::write_json(
        path,
        &Versioned {
            schema_version: SCHEMA_VERSION,
            command: "operations",
            doc,
        },
    )
}

/// Parse summary.json text (`file` names it in errors): the version first, so
/// a file of another version is refused by name, then the typed document.
pub fn parse(text: &str, file: &str) -> Result<SummaryDoc> {
    #[derive(Deserialize)]
    struct Header {
        schema_version: Option<u32>,
    }
    let header: Header =
        serde_json::from_str(text).or_results(|| format!("{file}: not valid JSON"))?;
    match header.schema_version {
        Some(SCHEMA_VERSION) => {}
        Some(v) => fail!(results,
            "{file}: schema_version {v}, but this dexcut reads version {SCHEMA_VERSION}: run the command again with this dexcut"
        ),
        None => fail!(results,
            "{file}: no schema_version (written by an older dexcut): run the command again to write version {SCHEMA_VERSION}"
        ),
    }
    let parsed: SummaryFile = serde_json::from_str(text)
        .or_results(|| format!("{file}: not a dexcut summary of version {SCHEMA_VERSION}"))?;
    Ok(parsed.doc)
}

/// Read and parse a summary.json (size-capped like every input).
pub fn read(path: &Path) -> Result<SummaryDoc> {
    let text = crate::bounds::read_text(path, "summary", crate::bounds::MAX_SUMMARY_BYTES)?;
    parse(&text, &path.display().to_string())
}

/// JSON has no inf or NaN: serde_json writes them as `null`. A value that can
/// be non-finite (an absent stress limit is +inf) reads `null` back as NaN.
pub fn f64_or_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary() -> Summary {
        Summary {
            initial_volume_mm3: 1000.0,
            final_volume_mm3: 900.0,
            removed_volume_mm3: 100.0,
            cycle_time_s: 2.5,
            peak_mrr_mm3_s: 40.0,
            peak_mrr_windowed_mm3_s: 39.0,
            peak_force_n: 12.5,
            peak_force_revolution_n: 19.0,
            peak_power_w: 100.0,
            peak_torque_nm: 0.1,
            peak_deflection_um: 3.0,
            peak_deflection_at_rupture: false,
            tool_breaks_steps: 0,
            peak_cutting_feed_mm_min: 600.0,
            peak_tip_deflection_um: 4.0,
            rigid_peak_deflection_um: 3.5,
            max_error_um: 2.0,
            min_error_um: -1.0,
            closed_loop: true,
            closed_loop_converged: true,
            closed_loop_passes: 3,
            closed_loop_unconverged_steps: 0,
            closed_loop_residual_um: 0.01,
            peak_stress_mpa: 50.0,
            // No tool with a limit: +inf, written as null.
            stress_limit_mpa: f64::INFINITY,
            steps: 10,
            grid_mm: 0.5,
            columns: 400,
            shank_contact_steps: 0,
            rapid_collision_steps: 1,
            first_collision_line: Some(7),
            warnings: Warnings(vec![Warning {
                kind: WarningKind::RapidCut,
                line: Some(7),
                value: f64::NAN,
                unit: "mm³".into(),
                steps: 1,
                lines: vec![7],
                message: "rapid cuts".into(),
            }]),
            columns_evaluated: 1234,
            sweep_time_s: 0.1,
            tools: vec![ToolPeaks {
                tool: 1,
                steps: 10,
                removed_volume_mm3: 100.0,
                time_s: 2.5,
                peak_mrr_mm3_s: 40.0,
                peak_force_n: 12.5,
                peak_deflection_um: 3.0,
            }],
        }
    }

    fn grid() -> GridInfo {
        GridInfo {
            nx: 20,
            ny: 20,
            x0_mm: 0.25,
            y0_mm: 0.25,
            spacing_mm: 0.5,
        }
    }

    /// What is written reads back to the same document, through the same types.
    #[test]
    fn simulate_summary_round_trips() {
        let doc = SimulateSummary {
            saved_stock: None,
            run: summary(),
            job: "job.toml".into(),
            program: "p.nc".into(),
            exact_stop_time_s: Some(2.6),
            grid: grid(),
            design: Some(DesignInfo {
                path: "part.stl".into(),
                max_stock_left_um: 80.0,
                worst_gouge_um: -12.0,
                worst_gouge_line: Some(9),
                worst_gouge_xy_mm: Some([1.0, 2.0]),
                gouge_tolerance_um: 10.0,
                stock_tolerance_um: 50.0,
                lines: vec![LineDeviation {
                    line: 9,
                    kind: DeviationKind::Gouge,
                    worst_um: -12.0,
                    x_mm: 1.0,
                    y_mm: 2.0,
                    columns: 3,
                }],
                uncut_stock_columns: 0,
            }),
            setup: Some(SetupInfo {
                material: "al6061".into(),
                limits: vec![("mrr_max".into(), 8.0, "mm³/s".into())],
                ..SetupInfo::default()
            }),
            run_time_s: 0.5,
            run_id: "abc".into(),
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("summary.json");
        write_simulate(&path, &doc).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let raw: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(raw["schema_version"], SCHEMA_VERSION);
        assert_eq!(raw["command"], "simulate");
        // Flattened: the run's numbers are top-level keys.
        assert_eq!(raw["peak_force_n"], 12.5);
        assert_eq!(raw["design"]["lines"][0]["kind"], "gouge");
        let SummaryDoc::Simulate(back) = read(&path).unwrap() else {
            panic!("not read as a simulate summary")
        };
        assert_eq!(back.run.peak_force_n, 12.5);
        assert_eq!(back.run.first_collision_line, Some(7));
        assert!(back.run.stress_limit_mpa.is_nan());
        assert!(back.run.warnings.0[0].value.is_nan());
        assert_eq!(back.run.warnings.0[0].kind, WarningKind::RapidCut);
        assert_eq!(back.grid.nx, 20);
        assert_eq!(back.design.unwrap().lines[0].kind, DeviationKind::Gouge);
        assert_eq!(back.run_id, "abc");
        let setup = back.setup.unwrap();
        assert_eq!(setup.material, "al6061");
        assert_eq!(setup.limits[0].1, 8.0);
    }

    #[test]
    fn optimize_summary_round_trips() {
        let doc = OptimizeSummary {
            saved_stock: None,
            job: "job.toml".into(),
            program: "p.nc".into(),
            grid: grid(),
            before: summary(),
            after: Summary {
                cycle_time_s: 2.0,
                ..summary()
            },
            limits: LimitsOut {
                mrr_max_mm3_s: Some(8.0),
                force_max_n: None,
                deflection_max_um: None,
                power_max_kw: None,
                feed_min_mm_min: None,
                feed_max_mm_min: 3000.0,
                chip_load_feed_mm_min: Some(2160.0),
                feed_scale_max: None,
                stress_limit_mpa: None,
                chip_load: vec![ToolChipLoad {
                    tool: 2,
                    diameter_mm: 1.0,
                    flutes: 2,
                    fz_max_mm: 0.007,
                    fz_max_from: "default for al6061, Ø1 mm".into(),
                    spindle_rpm: 10_000.0,
                    spindle_from: "no S word".into(),
                    feed_mm_min: 140.0,
                    programmed_feed_mm_min: Some(1016.0),
                    programmed_fz_mm: Some(0.0508),
                    line: Some(12),
                }],
            },
            cap_time_share: vec![CapShare {
                cap: "MRR".into(),
                share: 0.5,
            }],
            lower_bound_time_s: 1.9,
            exact_stop_time_s: Some(2.7),
            optimality_gap: 2.0 / 1.9 - 1.0,
            stations: 100,
            station_spacing_mm: 0.05,
            peak_mrr_ratio: Some(1.0),
            plan_time_s: 2.0,
            time_optimal_s: 1.95,
            written_vs_plan: 0.0,
            rounds: 1,
            merge_ratio: 1.05,
            kept_original: false,
            fz_max_mm: Some(0.03),
            design: None,
            setup: None,
            run_time_s: 1.0,
            time_engagement_s: 0.1,
            time_plan_s: 0.1,
            time_simulate_s: 0.1,
            run_id: "xyz".into(),
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("summary.json");
        write_optimize(&path, &doc).unwrap();
        let SummaryDoc::Optimize(back) = read(&path).unwrap() else {
            panic!("not read as an optimize summary")
        };
        assert_eq!(back.after.cycle_time_s, 2.0);
        assert_eq!(back.before.cycle_time_s, 2.5);
        assert_eq!(back.limits.mrr_max_mm3_s, Some(8.0));
        assert_eq!(back.limits.force_max_n, None);
        assert_eq!(back.cap_time_share[0].cap, "MRR");
        assert_eq!(back.run_id, "xyz");
        assert_eq!(back.limits.chip_load, doc.limits.chip_load);
        // A version-1 file written before `limits.chip_load` existed still reads.
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        v["limits"].as_object_mut().unwrap().remove("chip_load");
        std::fs::write(&path, v.to_string()).unwrap();
        let SummaryDoc::Optimize(old) = read(&path).unwrap() else {
            panic!("not read as an optimize summary")
        };
        assert!(old.limits.chip_load.is_empty());
    }

    /// Another version, or none, is refused by name before the body is read.
    #[test]
    fn other_versions_are_refused() {
        let e = parse(r#"{"schema_version": 99, "command": "simulate"}"#, "s.json").unwrap_err();
        assert!(
            e.to_string()
                .contains("s.json: schema_version 99, but this dexcut reads version 1"),
            "{e}"
        );
        let e = parse(r#"{"steps": 3}"#, "s.json").unwrap_err();
        assert!(e.to_string().contains("no schema_version"), "{e}");
        let e = parse(r#"{"schema_version": 1, "command": "mill"}"#, "s.json").unwrap_err();
        assert!(
            format!("{e:#}").contains("not a dexcut summary of version 1"),
            "{e:#}"
        );
    }
}
