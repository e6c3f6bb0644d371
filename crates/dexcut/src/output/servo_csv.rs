//! servo.csv: the commanded positions of a run's servo samples, one row a
//! period (and one at each corner where the run's steps split a period).

use std::path::Path;

use crate::error::{Error, Result};
use crate::motion::{self, TimedStep};

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
        let mut out = csv::Writer::from_writer(w);
        out.write_record([
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
        ])?;
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
                    out.write_record(
                        [
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
                        ]
                        .map(crate::util::fmt),
                    )?;
                    t_row = c.t_end_s;
                    moved = false;
                } else if !moved || c.step.from_mm != c.step.to_mm {
                    kind = c.step.rapid;
                    moved = c.step.from_mm != c.step.to_mm;
                }
            }
            out.write_record(
                [
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
                ]
                .map(crate::util::fmt),
            )?;
            before = Some(s);
        }
        out.flush()
    })
    .map_err(|e| Error::io("cannot write", path, e))
}
