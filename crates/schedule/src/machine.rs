//! Machine limits and the crate's error type.

use thiserror::Error;

/// What can go wrong when building stations or applying caps.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ScheduleError {
    /// A machine parameter is not a finite positive number.
    #[error("machine parameter `{name}` must be finite and > 0, got {value}")]
    InvalidMachine {
        /// Field of [`Machine`].
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A machine parameter is outside the range a real machine can have.
    #[error("machine parameter `{name}` must lie in {lo}..{hi}, got {value}")]
    MachineOutOfRange {
        /// Field of [`Machine`].
        name: &'static str,
        /// The value given.
        value: f64,
        /// Smallest plausible value.
        lo: f64,
        /// Largest plausible value.
        hi: f64,
    },
    /// The station spacing is not a finite positive number.
    #[error("station spacing must be finite and > 0 mm, got {0}")]
    InvalidSpacing(f64),
    /// A segment of the path has a feed or dwell time that cannot be run.
    #[error("segment {segment} (line {line}): {what}")]
    InvalidSegment {
        /// 0-based segment index in the path.
        segment: usize,
        /// 1-based program line of the segment.
        line: u32,
        /// What is wrong with it.
        what: &'static str,
    },
    /// The path has no segment at all, so there is no position to start from.
    #[error("the path is empty")]
    EmptyPath,
    /// A feed cap is NaN or not > 0.
    #[error("feed cap at station {station} must be > 0 mm/min, got {cap_mm_min}")]
    InvalidCap {
        /// 0-based station index.
        station: usize,
        /// The cap given, mm/min.
        cap_mm_min: f64,
    },
    /// The path needs more stations than the planner allows.
    #[error("the path needs {needed} planner stations, more than the limit of {limit} (a very long move or a very fine station spacing)")]
    TooManyStations {
        /// Stations the path would need.
        needed: usize,
        /// `MAX_STATIONS`.
        limit: usize,
    },
    /// The profile needs more servo samples than allowed.
    #[error("the motion needs {needed} servo samples, more than the limit of {limit} (cycle time {cycle_time_s:.1} s at period {period_ms} ms)")]
    TooManySamples {
        /// Samples the profile would need (cycle time over period).
        needed: f64,
        /// `MAX_SAMPLES`.
        limit: usize,
        /// The profile's cycle time, s.
        cycle_time_s: f64,
        /// The servo period, ms.
        period_ms: f64,
    },
    /// A run's servo samples still break an axis' acceleration or jerk limit after the
    /// planner's last fallback (MODEL.md §6.1, "Verified runs"): its samples are not made.
    #[error("the run from station {first} to {last} breaks an axis limit in its servo samples (ratio {ratio:.4} to the limit) even slowed {tries} times to {slow:.3e} of its speed")]
    UnverifiedRun {
        /// First station of the run (a stop).
        first: usize,
        /// Last station of the run (a stop).
        last: usize,
        /// Largest ratio of a sampled difference to its limit.
        ratio: f64,
        /// Tries of the slowed fallback.
        tries: usize,
        /// The last slowing factor σ tried.
        slow: f64,
    },
    /// The job's controller (`[machine] controller`) cannot plan the path.
    #[error("controller {controller}: {what}")]
    Controller {
        /// The controller's name in the job file (`grbl`, `linuxcnc`).
        controller: &'static str,
        /// What it cannot do.
        what: String,
    },
    /// A LinuxCNC INI file could not be read (file:line; line 0 where a key is
    /// missing).
    #[error("{file}:{line}: {message}")]
    Ini {
        /// The file's name as given.
        file: Box<str>,
        /// 1-based line, 0 for a missing key.
        line: usize,
        /// What is wrong.
        message: Box<str>,
    },
    /// A caps slice does not have one value per station.
    #[error("expected {expected} caps (one per station), got {got}")]
    CapCount {
        /// Stations.
        expected: usize,
        /// Caps given.
        got: usize,
    },
}

/// Limits of the machine and its control.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Machine {
    /// Interpolation (servo) period in ms.
    pub period_ms: f64,
    /// Highest cutting feed in mm/min.
    pub feed_max_mm_min: f64,
    /// Rapid (G0) rate in mm/min.
    pub rapid_mm_min: f64,
    /// Acceleration limit of each axis X, Y, Z in mm/s².
    pub accel_mm_s2: [f64; 3],
    /// Jerk limit of each axis X, Y, Z in mm/s³; `None`: acceleration may jump.
    pub jerk_mm_s3: Option<[f64; 3]>,
    /// Block processing time Tb in ms (S0); `None`: blocks are read instantly.
    pub block_time_ms: Option<f64>,
}

impl Default for Machine {
    fn default() -> Self {
        Machine {
            period_ms: 16.0,
            feed_max_mm_min: 3000.0,
            rapid_mm_min: 10000.0,
            accel_mm_s2: [1000.0; 3],
            jerk_mm_s3: None,
            block_time_ms: None,
        }
    }
}

/// The plausible range of each machine parameter (field, lowest, highest), in
/// the field's unit: what [`Machine::validate`] accepts. A job file's
/// `[machine]` is checked through it, so this table is the one source of truth.
pub const MACHINE_RANGES: [(&str, f64, f64); 6] = [
    ("period_ms", 0.01, 1000.0),
    ("feed_max_mm_min", 1e-3, 1e7),
    ("rapid_mm_min", 1e-3, 1e7),
    ("accel_mm_s2", 1e-3, 1e8),
    ("jerk_mm_s3", 1e-3, 1e12),
    ("block_time_ms", 1e-3, 1000.0),
];

impl Machine {
    /// Checks that every limit is finite, > 0 and within [`MACHINE_RANGES`].
    pub fn validate(&self) -> Result<(), ScheduleError> {
        let check = |name: &'static str, value: f64| {
            let (_, lo, hi) = MACHINE_RANGES
                .iter()
                .copied()
                .find(|r| r.0 == name)
                .expect("every checked field has a range");
            if !(value.is_finite() && value > 0.0) {
                Err(ScheduleError::InvalidMachine { name, value })
            } else if !(lo..=hi).contains(&value) {
                Err(ScheduleError::MachineOutOfRange {
                    name,
                    value,
                    lo,
                    hi,
                })
            } else {
                Ok(())
            }
        };
        check("period_ms", self.period_ms)?;
        check("feed_max_mm_min", self.feed_max_mm_min)?;
        check("rapid_mm_min", self.rapid_mm_min)?;
        for a in self.accel_mm_s2 {
            check("accel_mm_s2", a)?;
        }
        if let Some(jerk) = self.jerk_mm_s3 {
            for j in jerk {
                check("jerk_mm_s3", j)?;
            }
        }
        if let Some(tb) = self.block_time_ms {
            check("block_time_ms", tb)?;
        }
        Ok(())
    }

    /// Interpolation period in s.
    pub fn period_s(&self) -> f64 {
        self.period_ms * 1e-3
    }

    /// Tangential acceleration limit in mm/s² along unit direction `t`:
    /// the largest a with a·|t_i| ≤ a_i on every axis.
    pub fn tangential_accel_mm_s2(&self, t: &nalgebra::Vector3<f64>) -> f64 {
        along(t, self.accel_mm_s2)
    }

    /// Tangential jerk limit in mm/s³ along unit direction `t` (infinite without a jerk limit).
    pub fn tangential_jerk_mm_s3(&self, t: &nalgebra::Vector3<f64>) -> f64 {
        self.jerk_mm_s3.map_or(f64::INFINITY, |j| along(t, j))
    }
}

/// min_i limit_i / |t_i| (infinite for the zero vector).
pub(crate) fn along(t: &nalgebra::Vector3<f64>, limit: [f64; 3]) -> f64 {
    (0..3)
        .filter(|&i| t[i] != 0.0)
        .map(|i| limit[i] / t[i].abs())
        .fold(f64::INFINITY, f64::min)
}
