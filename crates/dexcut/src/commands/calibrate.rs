//! `dexcut calibrate CSV`: the force law's coefficients fitted to measurements, as a job's
//! `[cutting]` fragment. The CSV's header says which law: columns `v_mm3` and `force_n` fit S4's
//! `F = a·V^n` (MODEL.md §3.1); the columns of straight cuts ([`KIENZLE_COLUMNS`]) fit
//! Kienzle's `kc1_1`, `mc` and the force ratios (§3.2, "Calibration").

use std::path::Path;

use cutting::calibration::{Cut, FitError, KienzleFit, Milling};

use crate::error::{fail, Error, Result, ResultExt as _};

/// The columns of a Kienzle calibration: the cut (all required) and what was measured
/// (`power_w`, or the three forces, or both).
pub const KIENZLE_COLUMNS: [&str; 12] = [
    "tool",
    "diameter_mm",
    "flutes",
    "ap_mm",
    "ae_mm",
    "fz_mm",
    "rpm",
    "milling",
    "power_w",
    "force_x_n",
    "force_y_n",
    "force_z_n",
];

/// Most cuts a Kienzle calibration reads (a shop measures tens).
pub const MAX_CUTS: usize = 1_000_000;

/// What `calibrate` fitted.
#[derive(Clone, Debug, PartialEq)]
pub enum Calibration {
    /// S4's `F = a·V^n` (`[cutting] model = "power_law"`).
    PowerLaw(cutting::Fit),
    /// Kienzle's law (`[cutting] model = "kienzle"`).
    Kienzle(KienzleFit),
}

impl Calibration {
    /// The job's `[cutting]` keys of the fit, as TOML (a fragment to paste into a job).
    pub fn fragment(&self) -> String {
        match self {
            Calibration::PowerLaw(fit) => format!(
                "[cutting]\nmodel = \"power_law\"\nforce_a = {:.6}\nforce_n = {:.6}\n",
                fit.a, fit.n
            ),
            Calibration::Kienzle(fit) => {
                let mut t = format!(
                    "[cutting]\nmodel = \"kienzle\"\nkc1_1 = {:.3}\nmc = {:.6}\n",
                    fit.kc1_1_mpa, fit.mc
                );
                if let (Some(kr), Some(ka)) = (fit.radial_ratio, fit.axial_ratio) {
                    t += &format!("radial_ratio = {kr:.6}\naxial_ratio = {ka:.6}\n");
                }
                t
            }
        }
    }
}

/// `dexcut calibrate CSV [--out FILE]`: fit the law the CSV's header names; with `out`, write
/// the `[cutting]` fragment there (atomically; an existing file is replaced only with `force`).
pub fn calibrate(path: &Path, out: Option<&Path>, force: bool) -> Result<Calibration> {
    let text = crate::bounds::read_text(path, "measurements", crate::bounds::MAX_CSV_BYTES)?;
    let file = path.display().to_string();
    let fit = if is_kienzle_header(&text) {
        let (cuts, lines) = read_cuts(&text, &file)?;
        let fit = cutting::fit_kienzle(&cuts).map_err(|e| match e {
            FitError::BadCut { index, reason } => {
                Error::input(&file, lines.get(index).copied().unwrap_or(1), 1, reason)
            }
            e => Error::run(format!("{file}: cannot fit: {e}")),
        })?;
        Calibration::Kienzle(fit)
    } else {
        let points = read_calibration(&text, &file)?;
        Calibration::PowerLaw(
            cutting::fit_force_law(&points).or_run(|| format!("{file}: cannot fit"))?,
        )
    };
    check_fragment(&fit, &file)?;
    if let Some(out) = out {
        if std::fs::symlink_metadata(out).is_ok() && !force {
            fail!(
                request,
                "{} exists: give --force to replace it, or another --out",
                out.display()
            );
        }
        export::atomic::write_bytes(out, fit.fragment().as_bytes())
            .map_err(|e| Error::io("cannot write", out, e))?;
    }
    Ok(fit)
}

/// A job with the fragment as its `[cutting]` table must read: the fitted values lie in the
/// ranges the job reader accepts (else the measurements are at fault, not the job).
fn check_fragment(fit: &Calibration, file: &str) -> Result<()> {
    let text = format!("{}{}", fit.fragment(), FRAGMENT_HOST_JOB);
    crate::input::job::Job::parse(&text, "fragment", Path::new("."))
        .map(|_| ())
        .map_err(|e| {
            Error::run(format!(
                "{file}: the fitted values are not ones a job accepts ({}); check the measurements' units and the force frame:\n{}",
                e.chain_message(),
                fit.fragment()
            ))
        })
}

/// The rest of a job around a `[cutting]` fragment (no file is read).
const FRAGMENT_HOST_JOB: &str = r#"[stock]
kind = "box"
min = [0, 0, 0]
max = [10, 10, 10]
grid = 0.5
[tool]
kind = "flat"
diameter = 6
[program]
path = "p.csv"
feed = 1000
"#;

/// Whether the CSV's header names the columns of a Kienzle calibration (any of the cut's
/// columns but `tool`): then it is read as one, and every other column is refused by name.
fn is_kienzle_header(text: &str) -> bool {
    let first = text.lines().next().unwrap_or("");
    first
        .split(',')
        .map(|h| h.trim().trim_matches('"'))
        .any(|h| {
            KIENZLE_COLUMNS[1..8]
                .iter()
                .any(|c| c.eq_ignore_ascii_case(h))
        })
}

/// The 1-based column of field `i` of a CSV record (its start, counting the commas before it).
fn cell_column(rec: &csv::StringRecord, i: usize) -> u64 {
    rec.range(i).map_or(1, |r| r.start + i + 1) as u64
}

/// (volume per tooth mm³, force N) pairs from CSV text with columns v_mm3 and force_n.
pub fn read_calibration(text: &str, file: &str) -> Result<Vec<(f64, f64)>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .or_input(file, 1, 1, || "cannot read the header".into())?
        .clone();
    let find = |n: &str| headers.iter().position(|h| h.eq_ignore_ascii_case(n));
    let (Some(iv), Some(if_)) = (find("v_mm3"), find("force_n")) else {
        return Err(Error::input(
            file,
            1,
            1,
            format!(
                "the header must name columns v_mm3 and force_n (S4's F = a·V^n), or a straight cut's for Kienzle's law: {}",
                KIENZLE_COLUMNS.join(",")
            ),
        ));
    };
    let mut points = Vec::new();
    for rec in reader.records() {
        let rec = rec.or_results(|| format!("{file}: bad row"))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize| -> Result<f64> {
            let raw = rec.get(i).unwrap_or("");
            let col = cell_column(&rec, i);
            let v: f64 = raw
                .parse()
                .or_input(file, line, col, || format!("not a number: {raw:?}"))?;
            // The law F = a·V^n is fitted in logs: only positive, finite values mean anything.
            if !(v > 0.0 && v.is_finite()) {
                let message = format!(
                    "{} must be a positive, finite number, got {raw}",
                    headers.get(i).unwrap_or("value")
                );
                return Err(Error::input(file, line, col, message));
            }
            Ok(v)
        };
        points.push((num(iv)?, num(if_)?));
    }
    Ok(points)
}

/// The straight cuts of a Kienzle calibration CSV ([`KIENZLE_COLUMNS`]) and the line of each.
pub fn read_cuts(text: &str, file: &str) -> Result<(Vec<Cut>, Vec<u64>)> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .or_input(file, 1, 1, || "cannot read the header".into())?
        .clone();
    let mut at = [None; 12];
    for (i, h) in headers.iter().enumerate() {
        let Some(k) = KIENZLE_COLUMNS
            .iter()
            .position(|c| c.eq_ignore_ascii_case(h))
        else {
            let message = format!(
                "unknown column {h:?}: a Kienzle calibration has the columns {}",
                KIENZLE_COLUMNS.join(",")
            );
            return Err(Error::input(file, 1, cell_column(&headers, i), message));
        };
        if at[k].is_some() {
            let message = format!("column {h} is named twice");
            return Err(Error::input(file, 1, cell_column(&headers, i), message));
        }
        at[k] = Some(i);
    }
    let missing: Vec<&str> = (0..8)
        .filter(|&k| at[k].is_none())
        .map(|k| KIENZLE_COLUMNS[k])
        .collect();
    if !missing.is_empty() {
        return Err(Error::input(
            file,
            1,
            1,
            format!(
                "a Kienzle calibration needs the column(s) {} (header: {})",
                missing.join(", "),
                KIENZLE_COLUMNS[..8].join(",")
            ),
        ));
    }
    let forces = at[9..12].iter().filter(|a| a.is_some()).count();
    if forces % 3 != 0 || (forces == 0 && at[8].is_none()) {
        return Err(Error::input(
            file,
            1,
            1,
            "name what was measured: power_w (spindle cutting power, W), or all of force_x_n, force_y_n, force_z_n (mean force on the tool, N), or both",
        ));
    }
    let col = |k: usize| at[k].unwrap_or(0);
    let mut cuts = Vec::new();
    let mut lines = Vec::new();
    for rec in reader.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            Error::input(file, line, 1, format!("bad row: {e}"))
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        if cuts.len() == MAX_CUTS {
            return Err(Error::input(
                file,
                line,
                1,
                format!("more than {MAX_CUTS} cuts"),
            ));
        }
        let cell = |k: usize| Cell {
            raw: rec.get(col(k)).unwrap_or(""),
            file,
            line,
            column: cell_column(&rec, col(k)),
            name: KIENZLE_COLUMNS[k],
        };
        let tool = cell(0);
        if !tool.raw.eq_ignore_ascii_case("flat") {
            let why = if ["ball", "bull"]
                .iter()
                .any(|t| tool.raw.eq_ignore_ascii_case(t))
            {
                "only flat end mills are calibrated: a ball's or bull nose's chip thins towards its tip, so ae, ap and fz alone do not give its mean chip; the coefficients are the material's and hold for every tool"
            } else {
                "tool must be flat"
            };
            return Err(tool.error(format!("tool {:?}: {why}", tool.raw)));
        }
        let diameter_mm = cell(1).positive()?;
        let flutes = cell(2);
        let flutes = match flutes.raw.parse::<u32>() {
            Ok(n @ 1..=100) => n,
            _ => {
                return Err(flutes.error(format!(
                    "flutes must be a whole number from 1 to 100, got {:?}",
                    flutes.raw
                )))
            }
        };
        let ap_mm = cell(3).positive()?;
        let ae = cell(4);
        let ae_mm = ae.positive()?;
        if ae_mm > diameter_mm {
            return Err(ae.error(format!(
                "ae ({ae_mm} mm) is wider than the tool's diameter ({diameter_mm} mm)"
            )));
        }
        let fz_mm = cell(5).positive()?;
        let rpm = cell(6).positive()?;
        let m = cell(7);
        let milling = match m.raw.to_ascii_lowercase().as_str() {
            "up" => Milling::Up,
            "down" => Milling::Down,
            "slot" => Milling::Slot,
            _ => return Err(m.error(format!("milling must be up, down or slot, got {:?}", m.raw))),
        };
        if milling == Milling::Slot && ae_mm != diameter_mm {
            return Err(ae.error(format!(
                "a slot cuts ae = diameter ({diameter_mm} mm), got {ae_mm} mm: give up or down milling"
            )));
        }
        let power_w = at[8].map(|_| cell(8).positive()).transpose()?;
        let force_n = if forces == 3 {
            Some([cell(9).finite()?, cell(10).finite()?, cell(11).finite()?])
        } else {
            None
        };
        cuts.push(Cut {
            diameter_mm,
            flutes,
            ap_mm,
            ae_mm,
            fz_mm,
            rpm,
            milling,
            power_w,
            force_n,
        });
        lines.push(line);
    }
    Ok((cuts, lines))
}

/// One cell of a calibration CSV, with its place for messages.
struct Cell<'a> {
    raw: &'a str,
    file: &'a str,
    line: u64,
    column: u64,
    name: &'static str,
}

impl Cell<'_> {
    fn error(&self, message: String) -> Error {
        Error::input(self.file, self.line, self.column, message)
    }

    fn finite(&self) -> Result<f64> {
        let v: f64 = self
            .raw
            .parse()
            .or_input(self.file, self.line, self.column, || {
                format!("{}: not a number: {:?}", self.name, self.raw)
            })?;
        if !v.is_finite() {
            return Err(self.error(format!(
                "{} must be a finite number, got {}",
                self.name, self.raw
            )));
        }
        Ok(v)
    }

    fn positive(&self) -> Result<f64> {
        let v = self.finite()?;
        if !(v > 0.0) {
            return Err(self.error(format!(
                "{} must be a positive, finite number, got {}",
                self.name, self.raw
            )));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::job::{ForceModelKind, Job};

    const HEADER: &str = "tool,diameter_mm,flutes,ap_mm,ae_mm,fz_mm,rpm,milling,power_w,force_x_n,force_y_n,force_z_n\n";

    /// Cuts measured under kc1_1 = 1500, mc = 0.22, k_r = 0.3, k_a = 0.25, as CSV rows.
    fn rows() -> String {
        let law = cutting::Kienzle {
            kc1_1_mpa: 1500.0,
            mc: 0.22,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let mut text = String::from(HEADER);
        for (ae, milling) in [
            (1.0, Milling::Up),
            (3.0, Milling::Down),
            (10.0, Milling::Slot),
        ] {
            for fz in [0.03, 0.06, 0.12] {
                let mut cut = Cut {
                    diameter_mm: 10.0,
                    flutes: 3,
                    ap_mm: 4.0,
                    ae_mm: ae,
                    fz_mm: fz,
                    rpm: 5000.0,
                    milling,
                    power_w: None,
                    force_n: None,
                };
                cut.power_w = Some(cut.power_w_of(&law));
                let f = cut.force_n_of(&law);
                let m = format!("{milling:?}").to_lowercase();
                text += &format!(
                    "flat,10,3,4,{ae},{fz},5000,{m},{:?},{:?},{:?},{:?}\n",
                    cut.power_w.unwrap_or(0.0),
                    f[0],
                    f[1],
                    f[2]
                );
            }
        }
        text
    }

    #[test]
    fn fragment_reads_as_the_jobs_cutting_table() {
        let (cuts, lines) = read_cuts(&rows(), "m.csv").unwrap();
        assert_eq!(lines, (2..=10).collect::<Vec<u64>>());
        let fit = Calibration::Kienzle(cutting::fit_kienzle(&cuts).unwrap());
        let text = format!("{}{FRAGMENT_HOST_JOB}", fit.fragment());
        let job = Job::parse(&text, "job.toml", Path::new(".")).unwrap();
        let c = &job.cutting;
        assert_eq!(c.model, ForceModelKind::Kienzle);
        assert_eq!(c.kc1_1, Some(1500.0));
        assert_eq!(c.mc, Some(0.22));
        assert_eq!(c.radial_ratio, Some(0.3));
        assert_eq!(c.axial_ratio, Some(0.25));
        // Forces alone (no power_w column): K_t from each cut's x and y forces.
        let forces_only: String = rows()
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                format!("{},{}\n", f[..8].join(","), f[9..].join(","))
            })
            .collect();
        let (cuts, _) = read_cuts(&forces_only, "m.csv").unwrap();
        assert!(cuts
            .iter()
            .all(|c| c.power_w.is_none() && c.force_n.is_some()));
        let fit = cutting::fit_kienzle(&cuts).unwrap();
        assert_eq!(fit.kc_source, cutting::calibration::KcSource::Forces);
        assert!((fit.kc1_1_mpa - 1500.0).abs() < 1e-6 && (fit.mc - 0.22).abs() < 1e-9);
        // The power law's too.
        let fit =
            Calibration::PowerLaw(cutting::fit_force_law(&[(0.01, 10.0), (0.1, 50.0)]).unwrap());
        let job = Job::parse(
            &format!("{}{FRAGMENT_HOST_JOB}", fit.fragment()),
            "job.toml",
            Path::new("."),
        )
        .unwrap();
        assert_eq!(job.cutting.model, ForceModelKind::PowerLaw);
        assert!(job.cutting.force_a.is_some() && job.cutting.force_n.is_some());
    }

    #[test]
    fn bad_cuts_are_named_at_their_line_and_column() {
        let good = rows();
        let check = |edit: &dyn Fn(&str) -> String, needle: &str| {
            let e = read_cuts(&edit(&good), "m.csv")
                .map(|_| ())
                .unwrap_err()
                .chain_message();
            assert!(e.contains(needle), "{e}\nwanted {needle}");
        };
        check(
            &|t| t.replacen("ae_mm", "ae", 1),
            "m.csv:1:31: unknown column \"ae\"",
        );
        check(
            &|t| t.replacen(",power_w", ",", 1).replacen("ae_mm,", "", 1),
            "m.csv:1:",
        );
        check(
            &|t| t.replacen("tool,", "", 1).replace("flat,", ""),
            "needs the column(s) tool",
        );
        check(
            &|t| t.replacen("flat,10,3,4,1,", "ball,10,3,4,1,", 1),
            "m.csv:2:1: tool \"ball\": only flat end mills",
        );
        check(
            &|t| t.replacen("flat,10,3,4,1,", "flat,10,3,4,12,", 1),
            "m.csv:2:13: ae (12 mm) is wider",
        );
        check(
            &|t| t.replacen("flat,10,3,4,1,0.03", "flat,10,3,4,1,x", 1),
            "m.csv:2:15: fz_mm: not a number: \"x\"",
        );
        check(
            &|t| t.replacen("flat,10,3,4,1,0.03", "flat,10,3,-4,1,0.03", 1),
            "m.csv:2:11: ap_mm must be a positive, finite number, got -4",
        );
        check(
            &|t| t.replacen(",down,", ",sideways,", 1),
            "m.csv:5:25: milling must be up, down or slot, got \"sideways\"",
        );
        check(
            &|t| {
                t.replacen(
                    "flat,10,3,4,10,0.03,5000,slot",
                    "flat,10,3,4,9,0.03,5000,slot",
                    1,
                )
            },
            "m.csv:8:13: a slot cuts ae = diameter (10 mm), got 9 mm",
        );
        check(
            &|t| {
                t.replacen(
                    "power_w,force_x_n,force_y_n,force_z_n",
                    "power_w,force_x_n,force_y_n,force_z",
                    1,
                )
            },
            "m.csv:1:83: unknown column \"force_z\"",
        );
    }
}
