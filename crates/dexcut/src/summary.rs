//! summary.json: one versioned schema, written and read through the same serde
//! types ([`SimulateSummary`], [`OptimizeSummary`]). `report` reads it back
//! through [`read`], never as untyped JSON.
//!
//! Every file carries `schema_version` ([`SCHEMA_VERSION`]) and `command`
//! (`"simulate"` or `"optimize"`). A change of the layout that an older reader
//! cannot read raises the version; a reader refuses any other version with a
//! message that says which one it reads.

use std::path::Path;

use crate::error::{fail, Result, ResultExt as _};
use serde::{Deserialize, Deserializer, Serialize};

pub use crate::commands::{
    DesignInfo, DeviationKind, LimitsOut, LineDeviation, OptimizeSummary, SimulateSummary,
};
pub use crate::optimize::CapShare;
pub use crate::simulate::{GridInfo, Summary, ToolPeaks};
pub use crate::warnings::{Warning, WarningKind, Warnings};

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
}

impl SummaryDoc {
    /// The run id recorded in the file (as in manifest.json).
    pub fn run_id(&self) -> &str {
        match self {
            SummaryDoc::Simulate(s) => &s.run_id,
            SummaryDoc::Optimize(o) => &o.run_id,
        }
    }

    /// Stock grid of the run.
    pub fn grid(&self) -> &GridInfo {
        match self {
            SummaryDoc::Simulate(s) => &s.grid,
            SummaryDoc::Optimize(o) => &o.grid,
        }
    }

    /// Program file of the run.
    pub fn program(&self) -> &str {
        match self {
            SummaryDoc::Simulate(s) => &s.program,
            SummaryDoc::Optimize(o) => &o.program,
        }
    }

    /// The design comparison, if the job has a `[design]` model.
    pub fn design(&self) -> Option<&DesignInfo> {
        match self {
            SummaryDoc::Simulate(s) => s.design.as_ref(),
            SummaryDoc::Optimize(o) => o.design.as_ref(),
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
    crate::simulate::write_json(
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
    crate::simulate::write_json(
        path,
        &Versioned {
            schema_version: SCHEMA_VERSION,
            command: "optimize",
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
            run: summary(),
            job: "job.toml".into(),
            program: "p.nc".into(),
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
                chip_load: vec![crate::optimize::ToolChipLoad {
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
