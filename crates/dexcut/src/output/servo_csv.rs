//! servo.csv: the commanded positions of a run's servo samples, one row a
//! period (and one at each corner where the run's steps split a period).

use std::path::Path;

use crate::error::{Error, Result};
use crate::motion::{self, TimedStep};

/// Rows of servo.csv held before they are formatted and written (1.5 MB).
const ROWS_AT_ONCE: usize = 16_384;

/// servo.csv: commanded positions every period with path feed, axis
/// velocities, the tool and spindle speed of the block each lies on, and
/// whether the move to it is a rapid (`rapid`). A period that the run
/// `steps` (swept from these samples) splits where the motion changes between
/// rapid and feed also gets a row at each such corner, with the time the run
/// gave it and `sample` = 0 (a servo sample: 1). Read as a program (a point
/// list with `t_s`), it is simulated as the optimised run, step for step.
/// Z and its velocity are in the machine's own Z (`z_sign` −1 where it points down).
pub fn write_servo_csv(
    path: &Path,
    samples: impl Iterator<Item = motion::SampleRow>,
    steps: &[TimedStep],
    z_sign: f64,
) -> Result<()> {
    let mut periods = motion::periods(steps);
    export::atomic::write_file(path, |w| {
        let header = [
            "t_s",
            "x",
            "y",
            "z",
            "feed_mm_min",
            "vx_mm_s",
            "vy_mm_s",
            "vz_mm_s",
            "tool",
            "spindle_rpm",
            "rapid",
            "sample",
        ];
        // The header alone (no records).
        export::write_csv_records(w, Some(&header), 0, |_, _| {})?;
        // The rows, made in order, formatted ROWS_AT_ONCE at a time on rayon's threads.
        let mut rows: Vec<[f64; 12]> = Vec::with_capacity(ROWS_AT_ONCE);
        let write = |w: &mut dyn std::io::Write, rows: &mut Vec<[f64; 12]>| {
            export::write_csv_records(w, None, rows.len(), |i, fields| {
                fields.extend(rows[i].map(crate::util::fmt))
            })?;
            rows.clear();
            std::io::Result::Ok(())
        };
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let mut before: Option<motion::SampleRow> = None;
        for (i, s) in samples.enumerate() {
            let (tool, rpm) = (s.tool, s.spindle_rpm);
            // The axis velocities over the period.
            let v = before.map_or(nalgebra::Vector3::zeros(), |b| {
                schedule::axis_velocity_between_mm_s((b.pos, b.t_s), (s.pos, s.t_s))
            });
            // The period's steps (none before the first sample).
            let period = match i {
                0 => &steps[..0],
                _ => periods.next().map_or(&steps[..0], |p| &steps[p]),
            };
            // Its corners, each where a part of positive duration ends
            // before the sample (a corner at the time of the row before it
            // or of the sample adds nothing: that part is empty). The move to
            // the sample takes the kind of its last part that moves.
            let mut t_row = before.map_or(f64::NEG_INFINITY, |b| b.t_s);
            let mut kind = steps.first().is_some_and(|p| p.step.rapid);
            let mut moved = false;
            for (j, c) in period.iter().enumerate() {
                let corner = j + 1 < period.len() && c.t_end_s > t_row && c.t_end_s < s.t_s;
                if corner {
                    let [x, y, z] = c.step.to_mm;
                    rows.push([
                        c.t_end_s,
                        x,
                        y,
                        z_sign * z,
                        c.feed_mm_min,
                        v.x,
                        v.y,
                        z_sign * v.z,
                        c.tool as f64,
                        c.spindle_rpm,
                        flag(c.step.rapid),
                        0.0,
                    ]);
                    t_row = c.t_end_s;
                    moved = false;
                } else if !moved || c.step.from_mm != c.step.to_mm {
                    kind = c.step.rapid;
                    moved = c.step.from_mm != c.step.to_mm;
                }
            }
            rows.push([
                s.t_s,
                s.pos.x,
                s.pos.y,
                z_sign * s.pos.z,
                s.feed_mm_min,
                v.x,
                v.y,
                z_sign * v.z,
                tool as f64,
                rpm,
                flag(kind),
                1.0,
            ]);
            before = Some(s);
            if rows.len() >= ROWS_AT_ONCE {
                write(w, &mut rows)?;
            }
        }
        write(w, &mut rows)
    })
    .map_err(|e| Error::io("cannot write", path, e))
}
