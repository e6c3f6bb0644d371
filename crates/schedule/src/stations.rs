//! The path discretised along its arc length, with a feed cap at every station.

use nalgebra::{Point3, Vector3};
use nc::{Geometry, Motion, Path, Segment};
use rayon::prelude::*;

use crate::machine::{along, Machine, ScheduleError};
use crate::rules::block_feed_cap_mm_min;

mod corners;
mod sampled;

pub(crate) use corners::CornerChoice;
use sampled::SampledMemo;

/// Most stations one path may have: about 200 bytes each while planning (the arrays here,
/// the plan's speeds and times, the corner-budget tree), so 4 GB at the bound.
pub const MAX_STATIONS: usize = 20_000_000;

/// Memory one station takes while planning, bytes (for callers' memory estimates).
pub const BYTES_PER_STATION: usize = 200;

/// Segments shorter than this (mm) carry no stations; they neither move nor turn the tool.
const MIN_SEGMENT_MM: f64 = 1e-9;

/// Stations (or intervals) a parallel task of the stations' passes takes at a time
/// ([`Stations::limit_sampled_geometry`], the corner budgets' minima).
const PARALLEL_CHUNK: usize = 1 << 14;

/// Most ramp stations beside one end of a segment ([`ramp_station_counts`]): the nearest
/// is then h/4096 from the end, h the segment's interval.
const MAX_RAMP_STATIONS: u32 = 12;

/// Each ramp station is this many times nearer the segment's end than the one before
/// ([`ramp_station_counts`]).
const RAMP_RATIO: f64 = 2.0;

/// The nearest ramp station is within this share of the closed-form ramp from rest
/// ([`ramp_station_counts`]): the plan's ramp before its jerk filter, at the fraction λ of
/// the acceleration the filter takes, is at least half the S-curve's (MODEL.md §6.1,
/// "Ramp stations").
const RAMP_SHARE: f64 = 0.5;

/// No ramp station nearer a segment's end than this, mm (a few ulps of a path's arc
/// length at 10⁶ mm are 10⁻⁹ mm).
const MIN_RAMP_MM: f64 = 1e-6;

/// Which limit sets a station's feed cap, or, in a profile's time shares, what holds the speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CapKind {
    /// The programmed feed of the block.
    Programmed,
    /// A feed held as programmed (G84/G74 tapping, `nc::Motion::Feed`'s
    /// `held`): no re-timing changes it.
    Held,
    /// The machine's highest cutting feed.
    FeedMax,
    /// The rapid rate (G0).
    Rapid,
    /// Centripetal acceleration on an arc: v ≤ sqrt(a_n · r).
    Curvature,
    /// Tangent jump between segments (corner rule).
    Corner,
    /// Block processing time (S0): a block cannot be crossed faster than it is read.
    BlockTime,
    /// Caller's cap from the material removal rate.
    Removal,
    /// Caller's cap from the cutting force.
    Force,
    /// Caller's cap from the tool deflection.
    Deflection,
    /// Caller's cap from the spindle cutting power.
    Power,
    /// Caller's cap from the tool's allowable stress.
    Stress,
    /// Caller's cap from the cutting-surface angle (S3).
    SurfaceAngle,
    /// Caller's cap from the largest feed per tooth (chip load).
    ChipLoad,
    /// Caller's cap at a factor over the programmed feed.
    FeedScale,
    /// Not at any cap: accelerating or decelerating (jerk ramps included).
    Acceleration,
    /// Standing still for a programmed dwell.
    Dwell,
}

impl CapKind {
    /// Every kind, in the order [`crate::Profile::time_at_cap_share`] reports them.
    pub const ALL: [CapKind; 17] = [
        CapKind::Programmed,
        CapKind::Held,
        CapKind::FeedMax,
        CapKind::Rapid,
        CapKind::Curvature,
        CapKind::Corner,
        CapKind::BlockTime,
        CapKind::Removal,
        CapKind::Force,
        CapKind::Deflection,
        CapKind::Power,
        CapKind::Stress,
        CapKind::SurfaceAngle,
        CapKind::ChipLoad,
        CapKind::FeedScale,
        CapKind::Acceleration,
        CapKind::Dwell,
    ];

    /// Position of the kind in [`CapKind::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Which feed a feed block is capped at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedPolicy {
    /// Machine motion: the programmed feed (itself capped at `feed_max_mm_min`).
    Programmed,
    /// Re-timing: every feed block may run at `feed_max_mm_min`; the caller adds caps.
    MachineMax,
}

/// How [`Stations`] treat the path's corners (MODEL.md §6.1, "Stop or pass").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corners {
    /// Each corner stopped at where that is quicker than passing it, else passed at the
    /// corner rule's speed ([`Stations::new`]).
    Judged,
    /// Every corner passed at the corner rule's speed (the planner before exact stop was
    /// a choice; for tests of the corner rule).
    Passed,
    /// Every corner a stop: exact stop, as the planner runs it.
    Stopped,
}

/// A station where the tool is at rest: path start, path end, and every dwell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Station index.
    pub station: usize,
    /// Time standing still there, in s (0 at a start or end without dwell).
    pub dwell_s: f64,
}

/// The path discretised at arc-length stations, stored as struct of arrays.
///
/// Every segment end is a station, so corners are exact; each segment of length L gets
/// max(2, ⌈L/ds⌉) equal intervals (3 with a jerk limit), and beside an end that may come
/// to rest, where the feed is reached from rest within the first interval h, ramp stations
/// at h/2, h/4, … ([`station_count`]; MODEL.md §6.1, "Ramp stations"). Station k > 0
/// belongs to the segment of the interval k−1 → k that ends at it (a corner station sits
/// at fraction 1 of the segment before the corner); station 0 sits at fraction 0 of the
/// first moving segment.
#[derive(Clone, Debug)]
pub struct Stations {
    machine: Machine,
    /// The path the stations were made from (its segments indexed by `segment`).
    path: Path,
    s_mm: Vec<f64>,
    segment: Vec<u32>,
    fraction: Vec<f64>,
    /// Nothing moves: the one station stands still (tangent zero).
    still: bool,
    cap_mm_min: Vec<f64>,
    cap_kind: Vec<CapKind>,
    interval_accel_mm_s2: Vec<f64>,
    /// Empty without a jerk limit (each interval's would be infinite: 8 B a station
    /// for nothing).
    interval_jerk_mm_s3: Vec<f64>,
    stops: Vec<Stop>,
    /// Stations where the tangent jumps (corners), ascending.
    corners: Vec<usize>,
}

/// Number of stations [`Stations::new`] builds for `path` at spacing `ds_mm` on `machine`
/// under `policy`: one at the start and, per moving segment, max(m, ⌈L/ds⌉) intervals,
/// m = 2, or 3 with a jerk limit (a run from stop to stop then has two stations between
/// its stops at least, which a jerk filter's held peak needs: MODEL.md §6.1, "Stop or
/// pass"), plus the ramp stations beside each end that may come to rest
/// (`ramp_station_counts`). Linear in the segments, allocates nothing, so callers can
/// check the bound before any work. Saturates instead of overflowing.
pub fn station_count(path: &Path, machine: &Machine, ds_mm: f64, policy: FeedPolicy) -> usize {
    let segments = &path.segments;
    let mut count: usize = 1;
    let mut rests_at_start = true;
    for (index, seg) in segments.iter().enumerate() {
        let Ok(Block::Move {
            len_mm, cap_mm_min, ..
        }) = Block::of(seg, machine, policy)
        else {
            continue;
        };
        let layout = SegmentLayout::of(
            segments,
            index,
            len_mm,
            cap_mm_min,
            machine,
            policy,
            ds_mm,
            &mut rests_at_start,
        );
        let stations = layout.intervals + (layout.ramps[0] + layout.ramps[1]) as f64;
        count = count.saturating_add(if stations < usize::MAX as f64 {
            stations as usize
        } else {
            usize::MAX
        });
    }
    count
}

/// What a block of the path is to the stations.
enum Block {
    /// A dwell, s.
    Dwell(f64),
    /// A move too short to carry stations ([`MIN_SEGMENT_MM`]).
    Still,
    /// A move of `len_mm` capped at `cap_mm_min` by `kind` (before the corners beside it).
    Move {
        len_mm: f64,
        cap_mm_min: f64,
        kind: CapKind,
    },
}

impl Block {
    /// The block `seg` on `machine` under `policy`: its feed cap from the programmed feed
    /// (or `feed_max`), the rapid rate, block time (S0) and curvature; what is wrong with
    /// it otherwise.
    fn of(seg: &Segment, machine: &Machine, policy: FeedPolicy) -> Result<Block, &'static str> {
        let (mut cap_mm_min, mut kind) = match seg.motion {
            Motion::Dwell { seconds } => {
                if !(seconds.is_finite() && seconds >= 0.0) {
                    return Err("dwell time must be finite and >= 0 s");
                }
                return Ok(Block::Dwell(seconds));
            }
            Motion::Rapid => (machine.rapid_mm_min, CapKind::Rapid),
            Motion::Feed { feed_mm_min, held } => {
                if !(feed_mm_min.is_finite() && feed_mm_min > 0.0) {
                    return Err("feed must be finite and > 0 mm/min");
                }
                match policy {
                    // Tapping: the programmed feed under either policy.
                    _ if held && feed_mm_min <= machine.feed_max_mm_min => {
                        (feed_mm_min, CapKind::Held)
                    }
                    FeedPolicy::Programmed if feed_mm_min <= machine.feed_max_mm_min => {
                        (feed_mm_min, CapKind::Programmed)
                    }
                    _ => (machine.feed_max_mm_min, CapKind::FeedMax),
                }
            }
        };
        let len_mm = seg.length_mm();
        if !len_mm.is_finite() {
            return Err("length is not finite");
        }
        if len_mm < MIN_SEGMENT_MM {
            return Ok(Block::Still);
        }
        let mut lower = |cap: f64, k: CapKind| {
            if cap < cap_mm_min {
                cap_mm_min = cap;
                kind = k;
            }
        };
        if let Some(tb_ms) = machine.block_time_ms {
            lower(block_feed_cap_mm_min(len_mm, tb_ms), CapKind::BlockTime);
        }
        if let Geometry::Arc { plane, .. } = seg.geometry {
            let (a, b, _) = plane.axes();
            let a_n = machine.accel_mm_s2[a].min(machine.accel_mm_s2[b]);
            lower(60.0 * (a_n * seg.radius_mm()).sqrt(), CapKind::Curvature);
        }
        Ok(Block::Move {
            len_mm,
            cap_mm_min,
            kind,
        })
    }
}

/// The corner rule's speed for a tangent jump `jump`, mm/min (MODEL.md §6.1 corner
/// rule: v·|Δt_i| ≤ a_i·T/2 on every axis, and ≤ j_i·T²/2 with a jerk limit).
fn corner_cap_mm_min(machine: &Machine, jump: &Vector3<f64>) -> f64 {
    let period_s = machine.period_s();
    let step_mm_s: [f64; 3] = std::array::from_fn(|i| {
        let by_accel = 0.5 * machine.accel_mm_s2[i] * period_s;
        machine
            .jerk_mm_s3
            .map_or(by_accel, |j| by_accel.min(0.5 * j[i] * period_s * period_s))
    });
    60.0 * along(jump, step_mm_s)
}

/// Whether the moving segment `index` (capped at `cap_mm_min`) may end at rest: at the
/// path's end, before a dwell, or at a corner whose rule sets its cap (one the corners'
/// choice may stop at, or pass slowly). A block in error counts as a rest (building
/// stops there with the error).
fn rests_after(
    segments: &[Segment],
    index: usize,
    cap_mm_min: f64,
    machine: &Machine,
    policy: FeedPolicy,
) -> bool {
    for next in &segments[index + 1..] {
        match Block::of(next, machine, policy) {
            Ok(Block::Still) => continue,
            Ok(Block::Move {
                cap_mm_min: next_cap_mm_min,
                ..
            }) => {
                let jump = next.tangent_at_fraction(0.0) - segments[index].tangent_at_fraction(1.0);
                return corner_cap_mm_min(machine, &jump) < cap_mm_min.min(next_cap_mm_min);
            }
            Err(_) | Ok(Block::Dwell(_)) => return true,
        }
    }
    true
}

/// Where a moving segment's stations lie: its equal intervals and the ramp stations beside
/// each end ([`station_count`] counts them, `Stations::fill` places them).
struct SegmentLayout {
    /// max(m, ⌈L/ds⌉), m from [`least_intervals`] (a float: counting saturates).
    intervals: f64,
    /// Ramp stations beside the start and the end ([`ramp_station_counts`]).
    ramps: [u32; 2],
}

impl SegmentLayout {
    /// The layout of moving segment `index` of `segments`, of length `len_mm` and cap
    /// `cap_mm_min` ([`Block::Move`]), stations `ds_mm` apart; `rests_at_start` says whether
    /// its start may be at rest and is left saying whether the next moving segment's may.
    #[allow(clippy::too_many_arguments)]
    fn of(
        segments: &[Segment],
        index: usize,
        len_mm: f64,
        cap_mm_min: f64,
        machine: &Machine,
        policy: FeedPolicy,
        ds_mm: f64,
        rests_at_start: &mut bool,
    ) -> Self {
        let intervals = (len_mm / ds_mm).ceil().max(least_intervals(machine));
        let rests_at_end = rests_after(segments, index, cap_mm_min, machine, policy);
        let ramps = ramp_station_counts(
            &segments[index],
            len_mm,
            intervals,
            cap_mm_min,
            machine,
            [*rests_at_start, rests_at_end],
        );
        *rests_at_start = rests_at_end;
        SegmentLayout { intervals, ramps }
    }

    /// The fractions of the segment's stations after its start, ascending: ramp stations
    /// at h/2^m from the start (nearest first), the equal intervals h, ramp stations
    /// before the end (farthest first), and 1 exactly at the end.
    fn fractions(&self, len_mm: f64) -> impl Iterator<Item = f64> {
        let intervals = self.intervals as usize;
        let h_mm = len_mm / intervals as f64;
        let near_end = move |m: u32| h_mm / RAMP_RATIO.powi(m as i32) / len_mm;
        (1..=self.ramps[0])
            .rev()
            .map(near_end)
            .chain((1..intervals).map(move |j| j as f64 / intervals as f64))
            .chain((1..=self.ramps[1]).map(move |m| 1.0 - near_end(m)))
            .chain(std::iter::once(1.0))
    }
}

/// Ramp stations beside each end of a moving segment (MODEL.md §6.1, "Ramp stations"):
/// at an end that may be at rest, the tool reaches the segment's cap v from rest within
/// d = v²/(2·a_t) (a_t, j_t the tangential limits there), and with a jerk limit, whose
/// filter the plan's ramp does not show, within [`RAMP_SHARE`] of the S-curve's
/// v·(v/a_t + a_t/j_t)/2, or of v·√(v/j_t) where a_t is not reached; where d is shorter
/// than the segment's first interval h, stations at h/2, h/4, … down to the first at or
/// below d let v² rise at the acceleration limit up to the cap instead of linearly over
/// the whole interval (2·h/v instead of h/v + v/(2·a)). Returns how many at the start
/// and at the end (`rests`: whether each end may be at rest).
fn ramp_station_counts(
    seg: &Segment,
    len_mm: f64,
    intervals: f64,
    cap_mm_min: f64,
    machine: &Machine,
    rests: [bool; 2],
) -> [u32; 2] {
    let h_mm = len_mm / intervals;
    let v_mm_s = cap_mm_min / 60.0;
    let count = |end: usize| {
        if !rests[end] {
            return 0;
        }
        let tangent = seg.tangent_at_fraction(end as f64);
        let a = machine.tangential_accel_mm_s2(&tangent);
        let j = machine.tangential_jerk_mm_s3(&tangent);
        // From rest to v: v²/(2a) at the acceleration limit; with a jerk limit the
        // S-curve's v·(v/a + a/j)/2, or v·√(v/j) where a is not reached.
        let ramp_mm = if !j.is_finite() {
            v_mm_s * v_mm_s / (2.0 * a)
        } else if v_mm_s * j >= a * a {
            RAMP_SHARE * 0.5 * v_mm_s * (v_mm_s / a + a / j)
        } else {
            RAMP_SHARE * v_mm_s * (v_mm_s / j).sqrt()
        };
        if !(ramp_mm < h_mm) {
            return 0;
        }
        // h/2^m ≤ d, and h/2^m at least MIN_RAMP_MM.
        let to_ramp = ((h_mm / ramp_mm).ln() / RAMP_RATIO.ln()).ceil();
        let to_floor = ((h_mm / MIN_RAMP_MM).ln() / RAMP_RATIO.ln())
            .floor()
            .max(0.0);
        to_ramp.min(to_floor).min(MAX_RAMP_STATIONS as f64) as u32
    };
    [count(0), count(1)]
}

impl Stations {
    /// The path the stations were made from.
    pub fn into_path(self) -> Path {
        self.path
    }

    /// What is checked before anything is allocated; the number of stations.
    pub(crate) fn check(
        path: &Path,
        machine: &Machine,
        ds_mm: f64,
        policy: FeedPolicy,
    ) -> Result<usize, ScheduleError> {
        machine.validate()?;
        if !(ds_mm.is_finite() && ds_mm > 0.0) {
            return Err(ScheduleError::InvalidSpacing(ds_mm));
        }
        path.segments.first().ok_or(ScheduleError::EmptyPath)?;
        let estimate = station_count(path, machine, ds_mm, policy);
        if estimate > MAX_STATIONS {
            return Err(ScheduleError::TooManyStations {
                needed: estimate,
                limit: MAX_STATIONS,
            });
        }
        Ok(estimate)
    }

    /// The stations of `segments` (checked by [`Stations::check`]) with the corners
    /// treated as `corners` says, and with a jerk limit the corners' choice for the
    /// planner to check (`crate::corner_check`); on an error the segments come back.
    #[allow(clippy::type_complexity)]
    pub(crate) fn build_with(
        segments: Vec<Segment>,
        machine: &Machine,
        ds_mm: f64,
        policy: FeedPolicy,
        estimate: usize,
        corners: Corners,
    ) -> Result<(Self, Option<CornerChoice>), (ScheduleError, Vec<Segment>)> {
        let mut st = Stations {
            machine: *machine,
            path: Path::from_segments(segments),
            s_mm: Vec::with_capacity(estimate),
            segment: Vec::with_capacity(estimate),
            fraction: Vec::with_capacity(estimate),
            still: false,
            cap_mm_min: Vec::with_capacity(estimate),
            cap_kind: Vec::with_capacity(estimate),
            interval_accel_mm_s2: Vec::with_capacity(estimate),
            interval_jerk_mm_s3: Vec::with_capacity(if machine.jerk_mm_s3.is_some() {
                estimate
            } else {
                0
            }),
            stops: Vec::new(),
            corners: Vec::new(),
        };
        match st.fill(ds_mm, policy, corners) {
            Ok(choice) => Ok((st, choice)),
            Err(e) => Err((e, st.path.segments)),
        }
    }

    /// Sets the stations, caps and stops of the segments (the body of [`Stations::new`]).
    fn fill(
        &mut self,
        ds_mm: f64,
        policy: FeedPolicy,
        choice: Corners,
    ) -> Result<Option<CornerChoice>, ScheduleError> {
        let machine = self.machine;
        // A dwell (or run of dwells) waiting for the next station: total seconds.
        let mut pending_dwell_s: Option<f64> = None;
        let mut previous: Option<usize> = None;
        // The previous moving segment's tangent where it is a line (the same at its end).
        let mut previous_line_tangent: Option<Vector3<f64>> = None;
        // Corner stations and their tangent jumps.
        let mut corners: Vec<(usize, Vector3<f64>)> = Vec::new();
        // Whether the next moving segment's start may be at rest (the path's start is).
        let mut rests_at_start = true;
        for index in 0..self.path.segments.len() {
            let seg = self.path.segments[index];
            let (len_mm, cap_mm_min, kind) = match Block::of(&seg, &machine, policy) {
                Err(what) => {
                    return Err(ScheduleError::InvalidSegment {
                        segment: index,
                        line: seg.line,
                        what,
                    })
                }
                Ok(Block::Dwell(seconds)) => {
                    *pending_dwell_s.get_or_insert(0.0) += seconds;
                    continue;
                }
                Ok(Block::Still) => continue,
                Ok(Block::Move {
                    len_mm,
                    cap_mm_min,
                    kind,
                }) => (len_mm, cap_mm_min, kind),
            };

            let start_tangent = seg.tangent_at_fraction(0.0);
            // A line's intervals' limits and its end's tangent are its start's.
            let line = straight(&seg);
            let s_start_mm = match previous {
                None => {
                    self.push(0.0, index, 0.0, cap_mm_min, kind);
                    self.stops.push(Stop {
                        station: 0,
                        dwell_s: pending_dwell_s.take().unwrap_or(0.0),
                    });
                    0.0
                }
                Some(prev) => {
                    let junction = self.len() - 1;
                    self.lower_cap(junction, cap_mm_min, kind);
                    match pending_dwell_s.take() {
                        Some(dwell_s) => self.stops.push(Stop {
                            station: junction,
                            dwell_s,
                        }),
                        None => {
                            let prev_end = previous_line_tangent.unwrap_or_else(|| {
                                self.path.segments[prev].tangent_at_fraction(1.0)
                            });
                            let jump = start_tangent - prev_end;
                            let corner_mm_min = corner_cap_mm_min(&machine, &jump);
                            self.lower_cap(junction, corner_mm_min, CapKind::Corner);
                            corners.push((junction, jump));
                        }
                    }
                    self.s_mm[junction]
                }
            };

            let layout = SegmentLayout::of(
                &self.path.segments,
                index,
                len_mm,
                cap_mm_min,
                &machine,
                policy,
                ds_mm,
                &mut rests_at_start,
            );
            for u in layout.fractions(len_mm) {
                // Its position and tangent are [`Stations::position_at`] and
                // [`Stations::tangent_at`] of (segment, u): u = 1 exactly at the end.
                self.push(s_start_mm + len_mm * u, index, u, cap_mm_min, kind);
                let (accel, jerk) = if line {
                    self.limits_between(&start_tangent, &start_tangent)
                } else {
                    self.tangential_limits(self.len() - 2)
                };
                self.interval_accel_mm_s2.push(accel);
                if machine.jerk_mm_s3.is_some() {
                    self.interval_jerk_mm_s3.push(jerk);
                }
            }
            previous = Some(index);
            previous_line_tangent = line.then_some(start_tangent);
        }
        if self.s_mm.is_empty() {
            // Nothing moves: one station where the program starts, standing for its dwells.
            self.still = true;
            self.push(0.0, 0, 0.0, machine.feed_max_mm_min, CapKind::Dwell);
            self.stops.push(Stop {
                station: 0,
                dwell_s: pending_dwell_s.take().unwrap_or(0.0),
            });
        }
        let last = self.len() - 1;
        let dwell_s = pending_dwell_s.unwrap_or(0.0);
        match self.stops.last_mut() {
            Some(stop) if stop.station == last => stop.dwell_s += dwell_s,
            _ => self.stops.push(Stop {
                station: last,
                dwell_s,
            }),
        }
        let own_stops = std::mem::take(&mut self.stops);
        match choice {
            Corners::Judged => return Ok(self.stop_or_pass_corners(own_stops, corners)),
            Corners::Stopped => {
                self.limit_corners(&own_stops, &corners, &|_| false, &|_| false, None)
            }
            Corners::Passed => {
                self.limit_corners(&own_stops, &corners, &|_| true, &|_| false, None)
            }
        }
        Ok(None)
    }

    /// MODEL.md §6.1 sampled geometry: at constant speed v a sample at arc length s and its
    /// neighbours one period T away (L = v·T) have per-axis second difference
    /// D_i = |P_i(s+L) − 2P_i(s) + P_i(s−L)|/T² and third difference
    /// E_i = |P_i(s+2L) − 3P_i(s+L) + 3P_i(s) − P_i(s−L)|/T³, whatever the geometry: an arc
    /// (v²/r), a corner (v·|Δt_i|/T) or many short chords of a curve (their turns add up
    /// within one period). Each station's cap is lowered until D_i ≤ a_i/2 (and E_i ≤ j_i/2),
    /// and each interval's tangential acceleration is limited to what the axes have left,
    /// a_i − D_i at the capped speed (with a jerk limit also the cross term
    /// 3·a_t·D_i/v ≤ j_i/4), so that tangential and normal acceleration together stay
    /// within a_i in the samples.
    ///
    /// With `kept` (a corner choice's, [`SampledMemo`]) the first limiting is kept there, and
    /// each later one judges again only the stations whose inputs differ from it: the same
    /// values as judging them all.
    fn limit_sampled_geometry(&mut self, kept: Option<&mut Option<SampledMemo>>) {
        self.limit_sampled_geometry_in(PARALLEL_CHUNK, kept);
    }

    /// [`limit_sampled_geometry`](Self::limit_sampled_geometry), `chunk` stations a
    /// parallel task (the same values for any `chunk`).
    fn limit_sampled_geometry_in(&mut self, chunk: usize, kept: Option<&mut Option<SampledMemo>>) {
        let n = self.len();
        if n < 2 {
            return;
        }
        let period_s = self.machine.period_s();
        let accel = self.machine.accel_mm_s2;
        let jerk = self.machine.jerk_mm_s3;
        // Caps and interval accelerations are written station by station while the
        // closures below read the geometry (nothing here reads them but station k's own).
        let mut caps = std::mem::take(&mut self.cap_mm_min);
        let mut kinds = std::mem::take(&mut self.cap_kind);
        let mut interval_accel = std::mem::take(&mut self.interval_accel_mm_s2);
        // The run (stop to stop) of each station; a window reaching past a stop continues
        // straight along the run's end tangent (the tool rests there, so nothing beyond it
        // is sampled at speed). Stops are in station order: a station strictly between two
        // consecutive stops is in their run (a stop itself is never sampled here).
        let mut is_stop = vec![false; n];
        for stop in &self.stops {
            is_stop[stop.station] = true;
        }
        // The intervals k → k+1 where the path turns (tangent change or arc) and that do
        // not start at a stop, ascending: the arc length to the nearest turn before and
        // after each station is read from them as the stations are visited in order (no
        // per-station arrays). A kept limiting holds those of every station.
        let turning = match kept.as_deref() {
            Some(Some(memo)) => memo.turns_but_stops(&is_stop),
            _ => self.turning_intervals(chunk, &is_stop),
        };
        // Where the path is at arc length x (the stations are searched outwards from
        // `near`, which is left where x was found: the next station's search for its
        // own neighbour on that side starts there).
        let position = |run: (usize, usize), x: f64, near: &mut usize| {
            let (lo, hi) = run;
            if x <= self.s_mm[lo] {
                return self.position_at(lo).coords
                    - (self.s_mm[lo] - x) * self.tangent_at((lo + 1).min(n - 1));
            }
            if x >= self.s_mm[hi] {
                return self.position_at(hi).coords + (x - self.s_mm[hi]) * self.tangent_at(hi);
            }
            *near = partition_point_near(&self.s_mm, *near, |sk| sk <= x);
            self.locate((*near).clamp(1, n - 1) - 1, x).0.coords
        };
        // Station k's differences at speed v, the searches for its neighbours at s − l,
        // s + l and s + 2l started from `near` (and left where they were found).
        let differences = |k: usize, v: f64, run: (usize, usize), near: &mut [usize; 3]| {
            let (s, l) = (self.s_mm[k], v * period_s);
            let p0 = self.position_at(k).coords;
            let (pm, p1) = (
                position(run, s - l, &mut near[0]),
                position(run, s + l, &mut near[1]),
            );
            let d = (p1 - 2.0 * p0 + pm).map(f64::abs) / (period_s * period_s);
            let e = match jerk {
                Some(_) => {
                    let p2 = position(run, s + 2.0 * l, &mut near[2]);
                    (p2 - 3.0 * p1 + 3.0 * p0 - pm).map(f64::abs) / period_s.powi(3)
                }
                None => Vector3::zeros(),
            };
            (d, e)
        };
        let within = |(d, e): (Vector3<f64>, Vector3<f64>)| {
            (0..3).all(|i| {
                d[i] <= 0.5 * accel[i] * (1.0 + 1e-9)
                    && jerk.is_none_or(|j| e[i] <= 0.5 * j[i] * (1.0 + 1e-9))
            })
        };
        // The fastest any plan can be at each station: the sampled differences are
        // judged at that speed, not at the cap (a station just before a corner cannot
        // run at its cap).
        let envelope = self.envelope_mm_s(&caps, &interval_accel);
        // Station k at its cap `cap_mm_min` (the turns' and stops' cursor at the station
        // before): none where no turn is within the reach of its speed or it is a stop,
        // else its cap lowered where its differences ask it, and the budget it gives the
        // intervals beside it where it has differences.
        let station = |k: usize, cap_mm_min: f64, cursor: &mut Cursor| {
            let cap = (cap_mm_min / 60.0).min(envelope[k] as f64);
            let reach = 2.0 * cap * period_s + 1e-9;
            let (last_turn, next_turn) = self.turn_window(&turning, cursor, k);
            if is_stop[k] || self.s_mm[k] - last_turn > reach && next_turn - self.s_mm[k] > reach {
                return None;
            }
            let run = self.run_of(cursor, k);
            // The speed v kept at station k and its differences there (each taken once):
            // at the speed asked, the neighbours searched from where the last station's
            // were found (a station or two on), at lower speeds from those.
            let at_cap = differences(k, cap, run, &mut cursor.neighbours);
            let near = cursor.neighbours;
            let at_speed = |v: f64| differences(k, v, run, &mut { near });
            let mut v = cap;
            let mut d = at_cap.0;
            let mut limit = SampledLimit {
                lowered_cap_mm_min: None,
                budget: None,
            };
            if !within(at_cap) {
                let (mut lo, mut hi, mut d_lo) = (0.0, cap, None);
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    let at_mid = at_speed(mid);
                    if within(at_mid) {
                        (lo, d_lo) = (mid, Some(at_mid.0));
                    } else {
                        hi = mid;
                    }
                }
                v = lo;
                d = d_lo.unwrap_or_else(|| at_speed(lo).0);
                // Station k's cap is final from here (no other station lowers it).
                limit.lowered_cap_mm_min = (60.0 * v < cap_mm_min).then_some(60.0 * v);
            }
            if d != Vector3::zeros() {
                let v = v.min(limit.lowered_cap_mm_min.unwrap_or(cap_mm_min) / 60.0);
                limit.budget = Some(std::array::from_fn(|axis| {
                    let left = accel[axis] - d[axis];
                    match jerk {
                        Some(j) if d[axis] > 0.0 => left.min(0.25 * j[axis] * v / (3.0 * d[axis])),
                        _ => left,
                    }
                }));
            }
            Some(limit)
        };
        let from_kept = match kept.as_deref() {
            Some(Some(memo)) => {
                let limited = sampled::Limited {
                    caps: &mut caps,
                    kinds: &mut kinds,
                    interval_accel: &mut interval_accel,
                };
                memo.limit(self, &envelope, &turning, limited, &station)
            }
            _ => false,
        };
        match kept {
            _ if from_kept => {}
            Some(slot @ None) => {
                // The stations' limits apart from the intervals' accelerations they
                // are taken into, kept for the next limiting.
                let start = sampled::CapsStart::of(&caps, period_s);
                let mut limits = vec![f64::INFINITY; n - 1];
                let lowered = self.limit_stations_in_chunks(
                    chunk,
                    &turning,
                    &mut caps,
                    &mut kinds,
                    &mut limits,
                    &station,
                );
                interval_accel
                    .par_iter_mut()
                    .zip(&limits)
                    .for_each(|(a, &limit)| *a = a.min(limit));
                *slot = Some(SampledMemo::new(
                    self,
                    envelope,
                    &turning,
                    lowered.concat(),
                    limits,
                    start,
                ));
            }
            _ => {
                self.limit_stations_in_chunks(
                    chunk,
                    &turning,
                    &mut caps,
                    &mut kinds,
                    &mut interval_accel,
                    &station,
                );
            }
        }
        self.cap_mm_min = caps;
        self.cap_kind = kinds;
        self.interval_accel_mm_s2 = interval_accel;
    }

    /// The run (stop to stop) of station k, the stops' cursor (`cursor.stops_up_to`:
    /// how many stops are at or before the last station asked, which is at most k)
    /// moved up to it ([`Stations::limit_sampled_geometry`]).
    fn run_of(&self, cursor: &mut Cursor, k: usize) -> (usize, usize) {
        let after = &mut cursor.stops_up_to;
        while *after < self.stops.len() && self.stops[*after].station <= k {
            *after += 1;
        }
        match (after.checked_sub(1), self.stops.get(*after)) {
            (Some(before), Some(next)) => (self.stops[before].station, next.station),
            _ => (0, self.len() - 1),
        }
    }

    /// Where the last turn before station k ends and the next one after it starts (arc
    /// lengths, mm; ∓∞ where there is none), the turning intervals `turning`'s cursor
    /// (`cursor.turns_before`) moved up to k ([`Stations::limit_sampled_geometry`]): the
    /// last turn ends at s[k] if the interval k → k+1 turns, else at the end s[j+1] of the
    /// last turning interval j < k; the next one starts at s[k] if the interval k−1 → k
    /// turns, else at the start s[i] of the first turning interval i ≥ k.
    fn turn_window(&self, turning: &[u32], cursor: &mut Cursor, k: usize) -> (f64, f64) {
        let first_at_or_after = &mut cursor.turns_before;
        while *first_at_or_after < turning.len() && (turning[*first_at_or_after] as usize) < k {
            *first_at_or_after += 1;
        }
        let first_at_or_after = *first_at_or_after;
        let here = turning.get(first_at_or_after).map(|&i| i as usize) == Some(k);
        let last = if here {
            self.s_mm[k]
        } else {
            first_at_or_after
                .checked_sub(1)
                .map_or(f64::NEG_INFINITY, |j| self.s_mm[turning[j] as usize + 1])
        };
        let next =
            if k > 0 && first_at_or_after > 0 && turning[first_at_or_after - 1] as usize == k - 1 {
                self.s_mm[k]
            } else {
                turning
                    .get(first_at_or_after)
                    .map_or(f64::INFINITY, |&i| self.s_mm[i as usize])
            };
        (last, next)
    }

    /// The intervals k → k+1 where the path turns ([`Stations::turns`]) but those that
    /// start at a stop (`is_stop`), ascending. Found in chunks of `chunk` in parallel,
    /// each with its own recent tangents: the same list in the same order.
    fn turning_intervals(&self, chunk: usize, is_stop: &[bool]) -> Vec<u32> {
        let n = self.len();
        // (u32: at most MAX_STATIONS; half the memory, pages to fault in and list to
        // copy of usize where every interval turns, as on a curved finish.)
        (0..(n - 1).div_ceil(chunk))
            .into_par_iter()
            .flat_map_iter(|c| {
                let mut tangents = RecentTangents::new();
                (c * chunk..((c + 1) * chunk).min(n - 1))
                    .filter(move |&k| !is_stop[k] && self.turns(&mut tangents, k))
                    .map(|k| k as u32)
            })
            .collect()
    }

    /// Whether the path turns over the interval k → k+1: its tangent changes, or it is
    /// on an arc.
    fn turns(&self, tangents: &mut RecentTangents, k: usize) -> bool {
        (tangents.get(self, k + 1) - tangents.get(self, k)).norm() > 1e-12
            || matches!(
                self.path.segments[self.segment[k + 1] as usize].geometry,
                Geometry::Arc { .. }
            )
    }

    /// Each station's [`SampledLimit`] (`station(k, its cap, the cursor)`, the cursor's
    /// `turns_before` an index in `turning`) put on `caps`, `kinds` and the intervals'
    /// accelerations `interval_accel`, `chunk` stations a parallel task; the caps
    /// lowered, ascending, a list a chunk (joined only where a kept limiting needs
    /// them).
    fn limit_stations_in_chunks(
        &self,
        chunk: usize,
        turning: &[u32],
        caps: &mut [f64],
        kinds: &mut [CapKind],
        interval_accel: &mut Vec<f64>,
        station: &(dyn Fn(usize, f64, &mut Cursor) -> Option<SampledLimit> + Sync),
    ) -> Vec<Vec<LoweredCap>> {
        // Station k's speed and budget read the geometry and its own cap only, and
        // set its own cap and kind and the intervals k−1 → k and k → k+1 (each the
        // minimum of what it had and its stations' budgets: the same in any order). So
        // the stations go in chunks in parallel: a chunk holds its stations' intervals
        // k → k+1 (one slot more at the path's end), and gives back the budget of the
        // interval before its first station (the chunk before's), taken after.
        interval_accel.push(f64::INFINITY);
        let (before_chunks, lowered): (Vec<f64>, Vec<Vec<LoweredCap>>) = caps
            .par_chunks_mut(chunk)
            .zip(kinds.par_chunks_mut(chunk))
            .zip(interval_accel.par_chunks_mut(chunk))
            .enumerate()
            .map(|(c, ((caps, kinds), interval_accel))| {
                let k0 = c * chunk;
                let mut lowered = Vec::new();
                let before = self.limit_station_range(
                    k0,
                    caps,
                    turning,
                    station,
                    &mut lowered,
                    interval_accel,
                );
                for cap in &lowered {
                    caps[cap.station as usize - k0] = cap.cap_mm_min;
                    kinds[cap.station as usize - k0] = CapKind::Curvature;
                }
                (before, lowered)
            })
            .unzip();
        interval_accel.pop();
        for (c, before) in before_chunks.into_iter().enumerate().skip(1) {
            let a = &mut interval_accel[c * chunk - 1];
            *a = a.min(before);
        }
        lowered
    }

    /// The stations `k0, k0 + 1, …` (caps `caps`) limited by `station` (the turns
    /// `turning`): the caps they lower pushed to `lowered`, and their
    /// budgets taken into the intervals k0 → k0 + 1, … (`interval_accel`, one a
    /// station); the budget of the interval before `k0` returned.
    fn limit_station_range(
        &self,
        k0: usize,
        caps: &[f64],
        turning: &[u32],
        station: &(dyn Fn(usize, f64, &mut Cursor) -> Option<SampledLimit> + Sync),
        lowered: &mut Vec<LoweredCap>,
        interval_accel: &mut [f64],
    ) -> f64 {
        let n = self.len();
        let mut cursor = Cursor {
            turns_before: turning.partition_point(|&t| (t as usize) < k0),
            stops_up_to: self.stops.partition_point(|stop| stop.station <= k0),
            neighbours: [k0; 3],
        };
        let mut tangents = RecentTangents::new();
        let mut before = f64::INFINITY;
        for (i, k) in (k0..k0 + caps.len()).enumerate() {
            let Some(limit) = station(k, caps[i], &mut cursor) else {
                continue;
            };
            if let Some(cap_mm_min) = limit.lowered_cap_mm_min {
                lowered.push(LoweredCap {
                    station: k as u32,
                    cap_mm_min,
                });
            }
            let Some(budget) = limit.budget else {
                continue;
            };
            for interval in [k.wrapping_sub(1), k] {
                if interval >= n - 1 {
                    continue;
                }
                // (Both ends on one line: one tangent, one limit.)
                let (t0, t1) = (
                    tangents.get(self, interval),
                    tangents.get(self, interval + 1),
                );
                let limit = along(&t0, budget);
                let limit = if t1 == t0 {
                    limit
                } else {
                    limit.min(along(&t1, budget))
                };
                let a = if interval < k0 {
                    &mut before
                } else {
                    &mut interval_accel[interval - k0]
                };
                *a = a.min(limit);
            }
        }
        before
    }

    /// The acceleration-limited envelope (MODEL.md §6.1, "Sampled geometry"): the highest
    /// speed at each station under the caps `caps_mm_min`, at rest at every stop, with v²
    /// changing by at most 2·a_k·Δs over each interval k → k+1, a_k from
    /// `interval_accel` (the forward and backward passes without holds or filter), mm/s.
    /// No plan under these caps and accelerations (or lower ones) is faster at any
    /// station, so a sampled difference judged at the envelope's speed bounds the plan's
    /// there.
    fn envelope_mm_s(&self, caps_mm_min: &[f64], interval_accel: &[f64]) -> Vec<f32> {
        // v² and then v held as f32 rounded up (4 B a station): each value an upper bound.
        let up = |x: f64| {
            let f = x as f32;
            if (f as f64) < x {
                f32::from_bits(f.to_bits() + 1)
            } else {
                f
            }
        };
        let n = self.len();
        let s = &self.s_mm;
        let mut v2: Vec<f32> = caps_mm_min.iter().map(|c| up((c / 60.0).powi(2))).collect();
        for stop in &self.stops {
            v2[stop.station] = 0.0;
        }
        // Where the speed before is at least the cap here (a run of one cap, the
        // usual case) the cap is kept whatever the reach (reach ≥ v²_before ≥ cap,
        // rounded up): a branch the processor predicts, so the passes do not wait on
        // the conversions and rounding of the station before.
        let step = |before: f32, gain: f64, cap: f32| {
            if before >= cap && gain >= 0.0 {
                cap
            } else {
                cap.min(up(before as f64 + gain))
            }
        };
        for k in 1..n {
            v2[k] = step(
                v2[k - 1],
                2.0 * interval_accel[k - 1] * (s[k] - s[k - 1]),
                v2[k],
            );
        }
        for k in (0..n.saturating_sub(1)).rev() {
            v2[k] = step(
                v2[k + 1],
                2.0 * interval_accel[k] * (s[k + 1] - s[k]),
                v2[k],
            );
        }
        v2.iter_mut().for_each(|x| *x = up((*x as f64).sqrt()));
        v2
    }

    /// Every interval's acceleration its [`Stations::tangential_limits`] (no corner's
    /// budget taken out), the intervals in chunks in parallel.
    fn set_tangential_accels(&mut self) {
        let mut accel = std::mem::take(&mut self.interval_accel_mm_s2);
        let intervals = self.len() - 1;
        accel[..intervals]
            .par_chunks_mut(PARALLEL_CHUNK)
            .enumerate()
            .for_each(|(c, accel)| {
                for (i, a) in accel.iter_mut().enumerate() {
                    *a = self.tangential_limits(c * PARALLEL_CHUNK + i).0;
                }
            });
        self.interval_accel_mm_s2 = accel;
    }

    /// The tangential acceleration and jerk limits of interval k → k+1, mm/s² and mm/s³:
    /// min_i a_i/|t_i| (and j_i/|t_i|) over the tangents of its segment at both ends (from
    /// fraction 0 where the interval starts a segment).
    fn tangential_limits(&self, k: usize) -> (f64, f64) {
        let segment = self.segment[k + 1];
        let seg = &self.path.segments[segment as usize];
        let start = if self.segment[k] == segment {
            self.fraction[k]
        } else {
            0.0
        };
        let t0 = seg.tangent_at_fraction(start);
        let t1 = if straight(seg) {
            t0
        } else {
            seg.tangent_at_fraction(self.fraction[k + 1])
        };
        self.limits_between(&t0, &t1)
    }

    /// [`Stations::tangential_limits`] of an interval whose ends have the tangents
    /// `t0` and `t1`.
    fn limits_between(&self, t0: &Vector3<f64>, t1: &Vector3<f64>) -> (f64, f64) {
        let m = &self.machine;
        (
            m.tangential_accel_mm_s2(t0)
                .min(m.tangential_accel_mm_s2(t1)),
            m.tangential_jerk_mm_s3(t0).min(m.tangential_jerk_mm_s3(t1)),
        )
    }

    fn push(&mut self, s_mm: f64, segment: usize, fraction: f64, cap_mm_min: f64, kind: CapKind) {
        self.s_mm.push(s_mm);
        self.segment.push(segment as u32);
        self.fraction.push(fraction);
        self.cap_mm_min.push(cap_mm_min);
        self.cap_kind.push(kind);
    }

    fn lower_cap(&mut self, station: usize, cap_mm_min: f64, kind: CapKind) {
        if cap_mm_min < self.cap_mm_min[station] {
            self.cap_mm_min[station] = cap_mm_min;
            self.cap_kind[station] = kind;
        }
    }

    /// Lowers the cap of station `station` to `cap_mm_min` (mm/min, > 0) where that is lower,
    /// recording `kind` as the binding limit.
    pub fn apply_cap(
        &mut self,
        station: usize,
        cap_mm_min: f64,
        kind: CapKind,
    ) -> Result<(), ScheduleError> {
        if invalid_cap(cap_mm_min) {
            return Err(ScheduleError::InvalidCap {
                station,
                cap_mm_min,
            });
        }
        self.lower_cap(station, cap_mm_min, kind);
        Ok(())
    }

    /// [`Stations::apply_cap`] for every station, one cap (mm/min) per station.
    pub fn apply_caps(&mut self, caps_mm_min: &[f64], kind: CapKind) -> Result<(), ScheduleError> {
        if caps_mm_min.len() != self.len() {
            return Err(ScheduleError::CapCount {
                expected: self.len(),
                got: caps_mm_min.len(),
            });
        }
        if let Some((station, &cap_mm_min)) = caps_mm_min
            .iter()
            .enumerate()
            .find(|(_, &c)| invalid_cap(c))
        {
            return Err(ScheduleError::InvalidCap {
                station,
                cap_mm_min,
            });
        }
        for (station, &cap_mm_min) in caps_mm_min.iter().enumerate() {
            self.lower_cap(station, cap_mm_min, kind);
        }
        Ok(())
    }

    /// Runs `f` on the stations (to apply caps and plan under them) and puts
    /// their caps and the kinds that set them back as they were afterwards:
    /// a trial plan without a copy of the stations (a copy of a
    /// million-block program's stations and path is about 250 MB).
    pub fn with_caps_restored<R>(&mut self, f: impl FnOnce(&mut Stations) -> R) -> R {
        let (caps, kinds) = (self.cap_mm_min.clone(), self.cap_kind.clone());
        let r = f(self);
        self.cap_mm_min = caps;
        self.cap_kind = kinds;
        r
    }

    /// Number of stations (at least 1).
    pub fn len(&self) -> usize {
        self.s_mm.len()
    }

    /// Always false: a built path has at least one station.
    pub fn is_empty(&self) -> bool {
        self.s_mm.is_empty()
    }

    /// The machine the stations were built for.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The path's segments (indexed by [`Stations::segment`]).
    pub fn segments(&self) -> &[Segment] {
        &self.path.segments
    }

    /// The path the stations were made from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Arc length from the path start at each station, mm.
    pub fn s_mm(&self) -> &[f64] {
        &self.s_mm
    }

    /// Segment index of each station.
    pub fn segment(&self) -> &[u32] {
        &self.segment
    }

    /// Fraction within its segment of each station, in [0, 1].
    pub fn fraction(&self) -> &[f64] {
        &self.fraction
    }

    /// Tool-tip position of station `k`, mm: its segment's start at fraction 0, its end at
    /// fraction 1, else the point at its fraction (made from the segment when asked, not
    /// stored: 24 bytes a station less).
    pub fn position_at(&self, k: usize) -> Point3<f64> {
        let seg = &self.path.segments[self.segment[k] as usize];
        match self.fraction[k] {
            0.0 => seg.start,
            1.0 => seg.end,
            u => seg.point_at_fraction(u),
        }
    }

    /// Unit tangent of station `k`'s segment there (incoming side at a corner; zero where
    /// nothing moves), made from the segment when asked.
    pub fn tangent_at(&self, k: usize) -> Vector3<f64> {
        if self.still {
            return Vector3::zeros();
        }
        self.path.segments[self.segment[k] as usize].tangent_at_fraction(self.fraction[k])
    }

    /// Feed cap of each station, mm/min.
    pub fn cap_mm_min(&self) -> &[f64] {
        &self.cap_mm_min
    }

    /// Which limit sets each station's cap.
    pub fn cap_kind(&self) -> &[CapKind] {
        &self.cap_kind
    }

    /// Tangential acceleration limit of each interval k → k+1, mm/s²: min_i a_i/|t_i| over
    /// the tangents at both ends.
    pub fn interval_accel_mm_s2(&self) -> &[f64] {
        &self.interval_accel_mm_s2
    }

    /// Tangential jerk limit of each interval k → k+1, mm/s³ (min_i j_i/|t_i| over the
    /// tangents at both ends); `None` without a jerk limit, where every interval's is
    /// infinite (not held: 8 B a station saved).
    pub fn interval_jerk_mm_s3(&self) -> Option<&[f64]> {
        self.machine
            .jerk_mm_s3
            .is_some()
            .then_some(&self.interval_jerk_mm_s3[..])
    }

    /// Stations where the tool is at rest, in path order: the start, every dwell, the end.
    pub fn stops(&self) -> &[Stop] {
        &self.stops
    }

    /// Stations where the tangent jumps (corners crossed without stopping), ascending.
    pub fn corners(&self) -> &[usize] {
        &self.corners
    }

    /// Tool-tip position and segment index at arc length `s_mm` within interval `k` → k+1.
    pub(crate) fn locate(&self, k: usize, s_mm: f64) -> (Point3<f64>, u32) {
        let segment = self.segment[k + 1];
        let start = if self.segment[k] == segment {
            self.fraction[k]
        } else {
            0.0
        };
        let ds = self.s_mm[k + 1] - self.s_mm[k];
        let w = ((s_mm - self.s_mm[k]) / ds).clamp(0.0, 1.0);
        let u = start + w * (self.fraction[k + 1] - start);
        (
            self.path.segments[segment as usize].point_at_fraction(u),
            segment,
        )
    }
}

/// Where a chunk of stations visited in order stands in the path's turns and stops
/// ([`Stations::limit_sampled_geometry`]).
struct Cursor {
    /// How many turning intervals start before the station.
    turns_before: usize,
    /// How many stops are at or before the last station whose run was asked.
    stops_up_to: usize,
    /// Where the last station's neighbours one sample before, one after and two after
    /// were found (partition points of the arc lengths): only where to start the next
    /// searches.
    neighbours: [usize; 3],
}

/// What one station's sampled differences make of it (MODEL.md §6.1, "Sampled
/// geometry"): its cap where they lower it, mm/min, and each axis' acceleration
/// budget it leaves the intervals beside it, mm/s² (none where it has no
/// differences).
struct SampledLimit {
    lowered_cap_mm_min: Option<f64>,
    budget: Option<[f64; 3]>,
}

/// A station's cap the sampled geometry lowered ([`SampledLimit::lowered_cap_mm_min`]).
#[derive(Clone, Copy, Debug)]
struct LoweredCap {
    station: u32,
    cap_mm_min: f64,
}

/// Whether `seg` is a straight line: its tangent is the same at every fraction
/// (`Segment::tangent_at_fraction` reads none), so one serves all its stations.
fn straight(seg: &Segment) -> bool {
    matches!(seg.geometry, Geometry::Line)
}

/// The unit tangents ([`Stations::tangent_at`]) of the last three stations asked for,
/// one a slot by the station's index modulo 3: where stations are visited in order
/// (each interval asking for both its ends), each tangent is made once. And the
/// tangent of the last [`straight`] segment met, which its stations share.
struct RecentTangents {
    station: [usize; 3],
    tangent: [Vector3<f64>; 3],
    line: u32,
    line_tangent: Vector3<f64>,
}

impl RecentTangents {
    fn new() -> Self {
        RecentTangents {
            station: [usize::MAX; 3],
            tangent: [Vector3::zeros(); 3],
            line: u32::MAX,
            line_tangent: Vector3::zeros(),
        }
    }

    /// [`Stations::tangent_at`] of station `k` of `stations`.
    fn get(&mut self, stations: &Stations, k: usize) -> Vector3<f64> {
        let slot = k % 3;
        if self.station[slot] != k {
            self.station[slot] = k;
            let segment = stations.segment[k];
            self.tangent[slot] = if segment == self.line {
                self.line_tangent
            } else {
                let tangent = stations.tangent_at(k);
                if straight(&stations.path.segments[segment as usize]) {
                    (self.line, self.line_tangent) = (segment, tangent);
                }
                tangent
            };
        }
        self.tangent[slot]
    }
}

/// `s.partition_point(pred)` (`pred` true on a prefix of `s`), found by galloping out
/// from `hint`: the same index in O(log distance) rather than O(log len), for searches
/// that land near a known station.
fn partition_point_near(s: &[f64], hint: usize, pred: impl Fn(f64) -> bool) -> usize {
    let n = s.len();
    let hint = hint.min(n);
    if hint < n && pred(s[hint]) {
        // The boundary lies after `hint`; every index before `lo` satisfies `pred`.
        let (mut lo, mut step) = (hint + 1, 1);
        loop {
            let hi = lo + step;
            if hi >= n {
                return lo + s[lo..].partition_point(|&v| pred(v));
            }
            if !pred(s[hi]) {
                return lo + s[lo..hi].partition_point(|&v| pred(v));
            }
            lo = hi + 1;
            step *= 2;
        }
    }
    // The boundary lies at or before `hint`; no index from `hi` on satisfies `pred`.
    let (mut hi, mut step) = (hint, 1);
    loop {
        if hi < step {
            return s[..hi].partition_point(|&v| pred(v));
        }
        let probe = hi - step;
        if pred(s[probe]) {
            return probe + 1 + s[probe + 1..hi].partition_point(|&v| pred(v));
        }
        hi = probe;
        step *= 2;
    }
}

/// The fewest intervals a moving segment is cut into: 2, or 3 with a jerk limit
/// ([`station_count`]).
fn least_intervals(machine: &Machine) -> f64 {
    if machine.jerk_mm_s3.is_some() {
        3.0
    } else {
        2.0
    }
}

/// A cap must be > 0 mm/min (+∞ is allowed and changes nothing); NaN is rejected.
fn invalid_cap(cap_mm_min: f64) -> bool {
    cap_mm_min.is_nan() || cap_mm_min <= 0.0
}

#[cfg(test)]
mod partition_tests {
    use super::partition_point_near;

    #[test]
    fn partition_near_matches_partition_point() {
        let s = [0.0, 0.5, 0.5, 1.0, 2.0, 2.0, 2.0, 3.5, 7.0, 7.0, 9.0];
        for hint in 0..=s.len() + 2 {
            for x in [
                -1.0, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0, 3.0, 3.5, 7.0, 8.0, 9.0, 10.0,
            ] {
                assert_eq!(
                    partition_point_near(&s, hint, |v| v <= x),
                    s.partition_point(|&v| v <= x),
                    "hint {hint} x {x} (<=)"
                );
                assert_eq!(
                    partition_point_near(&s, hint, |v| v < x),
                    s.partition_point(|&v| v < x),
                    "hint {hint} x {x} (<)"
                );
            }
        }
        assert_eq!(partition_point_near(&[], 0, |v: f64| v < 1.0), 0);
    }
}

#[cfg(test)]
mod tangent_tests {
    use nalgebra::Point3;
    use nc::{Geometry, Motion, Path, Plane, Segment};

    use super::{Corners, FeedPolicy, RecentTangents, Stations};
    use crate::machine::Machine;

    /// Lines in several directions (one of zero length between two, which has
    /// no stations: the next line starts anew), a helical arc and a quarter
    /// circle, with a jerk limit: the stations' tangents taken through the
    /// recent tangents (each line's shared by its stations), in order and out of
    /// it, and the intervals' limits (a line's tangent taken once for both ends,
    /// and in the fill its start's) are those made from each station's segment
    /// and fraction, bit for bit. The jerk limits are the fill's alone (nothing
    /// after it changes them).
    #[test]
    fn shared_line_tangents_are_each_stations_own() {
        let feed = Motion::feed(1800.0);
        let segment = |start: [f64; 3], end: [f64; 3], geometry| Segment {
            start: Point3::from(start),
            end: Point3::from(end),
            geometry,
            motion: feed,
            line: 1,
            spindle_rpm: 10000.0,
            tool: 1,
        };
        let arc = |center: [f64; 3], clockwise, sweep_rad| Geometry::Arc {
            center: Point3::from(center),
            plane: Plane::XY,
            clockwise,
            sweep_rad,
        };
        let path = Path::from_segments(vec![
            segment([0.0, 0.0, 5.0], [3.0, 1.0, 4.0], Geometry::Line),
            segment([3.0, 1.0, 4.0], [3.0, 1.0, 4.0], Geometry::Line),
            segment([3.0, 1.0, 4.0], [7.0, 1.0, 4.0], Geometry::Line),
            segment(
                [7.0, 1.0, 4.0],
                [9.0, 3.0, 3.5],
                arc([7.0, 3.0, 4.0], false, std::f64::consts::FRAC_PI_2),
            ),
            segment([9.0, 3.0, 3.5], [9.0, 8.0, 3.5], Geometry::Line),
            segment(
                [9.0, 8.0, 3.5],
                [7.0, 10.0, 3.5],
                arc([7.0, 8.0, 3.5], false, std::f64::consts::FRAC_PI_2),
            ),
            segment([7.0, 10.0, 3.5], [-2.0, 10.0, 6.0], Geometry::Line),
        ]);
        let machine = Machine {
            jerk_mm_s3: Some([20000.0, 15000.0, 5000.0]),
            ..Machine::default()
        };
        let st = Stations::with_corners(
            &path,
            &machine,
            0.5,
            FeedPolicy::MachineMax,
            Corners::Judged,
        )
        .expect("stations");
        let n = st.len();
        assert!(n > 40, "{n} stations");
        let own =
            |k: usize| path.segments[st.segment[k] as usize].tangent_at_fraction(st.fraction[k]);
        let bits = |t: nalgebra::Vector3<f64>| t.map(f64::to_bits);
        let mut recent = RecentTangents::new();
        for k in 0..n {
            assert_eq!(bits(recent.get(&st, k)), bits(own(k)), "station {k}");
        }
        let mut recent = RecentTangents::new();
        for k in (0..n).rev().chain((0..n).step_by(7)) {
            assert_eq!(bits(recent.get(&st, k)), bits(own(k)), "station {k}");
        }
        for k in 0..n - 1 {
            let seg = &path.segments[st.segment[k + 1] as usize];
            let start = if st.segment[k] == st.segment[k + 1] {
                st.fraction[k]
            } else {
                0.0
            };
            let (t0, t1) = (
                seg.tangent_at_fraction(start),
                seg.tangent_at_fraction(st.fraction[k + 1]),
            );
            let (accel, jerk) = st.tangential_limits(k);
            let want = st.limits_between(&t0, &t1);
            assert_eq!(
                (accel.to_bits(), jerk.to_bits()),
                (want.0.to_bits(), want.1.to_bits()),
                "interval {k}"
            );
            let filled = st.interval_jerk_mm_s3().expect("a jerk limit")[k];
            assert_eq!(filled.to_bits(), want.1.to_bits(), "interval {k} as filled");
        }
    }
}
