//! The exact-stop time of a path: every segment run rest to rest on its own
//! (MODEL.md §6.1, "Exact stop"), the simplest feasible plan, which a summary shows
//! beside the planned cycle time.

use nc::{Geometry, Motion, Path, Segment};

use crate::bound::rest_to_rest_time_s;
use crate::machine::along;
use crate::rules::block_feed_cap_mm_min;
use crate::stations::FeedPolicy;
use crate::Machine;

/// Segments shorter than this are skipped, as the stations skip them.
const MIN_SEGMENT_MM: f64 = 1e-9;

/// Time in s of the path run in exact stop (G61.1): every segment from rest to rest,
/// each at its own limits, plus every dwell. MODEL.md §6.1, "Exact stop".
///
/// * feed: the programmed feed under [`FeedPolicy::Programmed`] (capped at
///   `feed_max_mm_min`), `feed_max_mm_min` under [`FeedPolicy::MachineMax`]; rapids at
///   `rapid_mm_min`; with a block time, at most S0's cap of the segment's length;
/// * a line along unit direction u: acceleration min_i a_i/|u_i|, jerk min_i j_i/|u_i|;
/// * an arc of radius r in a plane with axes (p, q): its feed at most √(a_n·r/2) with
///   a_n = min(a_p, a_q), so that the centripetal part takes at most half the plane's
///   budget, and the other half as its tangential acceleration (a helix's linear axis
///   also limits it, by its share of the tangent); jerk the same way, halved.
///
/// Each segment's time is [`rest_to_rest_time_s`] at those limits: a trapezoid or a
/// triangle without a jerk limit, the 7-segment S-curve with one.
pub fn exact_stop_time_s(path: &Path, machine: &Machine, policy: FeedPolicy) -> f64 {
    path.segments
        .iter()
        .map(|seg| segment_time_s(seg, machine, policy))
        .sum()
}

/// One segment's rest-to-rest time (a dwell's seconds).
fn segment_time_s(seg: &Segment, machine: &Machine, policy: FeedPolicy) -> f64 {
    let mut feed_mm_min = match seg.motion {
        Motion::Dwell { seconds } => return seconds.max(0.0),
        Motion::Rapid => machine.rapid_mm_min,
        Motion::Feed { feed_mm_min, held } => match policy {
            FeedPolicy::MachineMax if !held => machine.feed_max_mm_min,
            _ => feed_mm_min.min(machine.feed_max_mm_min),
        },
    };
    let len_mm = seg.length_mm();
    if !(len_mm >= MIN_SEGMENT_MM) {
        return 0.0;
    }
    if let Some(tb_ms) = machine.block_time_ms {
        feed_mm_min = feed_mm_min.min(block_feed_cap_mm_min(len_mm, tb_ms));
    }
    let jerk = machine.jerk_mm_s3.unwrap_or([f64::INFINITY; 3]);
    let (v, a, j) = match seg.geometry {
        Geometry::Line => {
            let u = (seg.end - seg.start) / len_mm;
            (
                feed_mm_min / 60.0,
                along(&u, machine.accel_mm_s2),
                along(&u, jerk),
            )
        }
        Geometry::Arc { plane, .. } => {
            let (p, q, n) = plane.axes();
            let a_n = machine.accel_mm_s2[p].min(machine.accel_mm_s2[q]);
            let j_n = jerk[p].min(jerk[q]);
            // The helix's share of the tangent along the plane's normal axis.
            let t = seg.tangent_at_fraction(0.0);
            let share = if t.norm() > 0.0 {
                (t[n] / t.norm()).abs()
            } else {
                0.0
            };
            let lin = |limit: f64| {
                if share > 0.0 {
                    limit / share
                } else {
                    f64::INFINITY
                }
            };
            let v_curv = (a_n * seg.radius_mm() / 2.0).sqrt();
            (
                (feed_mm_min / 60.0).min(v_curv),
                (a_n / 2.0).min(lin(machine.accel_mm_s2[n])),
                (j_n / 2.0).min(lin(jerk[n])),
            )
        }
    };
    rest_to_rest_time_s(len_mm, v, a, j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn seg(end: Point3<f64>, feed_mm_min: f64) -> Segment {
        Segment {
            start: Point3::origin(),
            end,
            geometry: Geometry::Line,
            motion: Motion::feed(feed_mm_min),
            line: 1,
            spindle_rpm: 0.0,
            tool: 1,
        }
    }

    fn machine(jerk: Option<f64>) -> Machine {
        Machine {
            accel_mm_s2: [1000.0, 500.0, 250.0],
            jerk_mm_s3: jerk.map(|j| [j; 3]),
            ..Machine::default()
        }
    }

    fn close(a: f64, b: f64) {
        assert!((a - b).abs() <= 1e-12 * b.max(1.0), "{a} against {b}");
    }

    #[test]
    fn a_trapezoid_along_x_is_the_closed_form() {
        // 10 mm at 50 mm/s and 1000 mm/s²: 10/50 + 50/1000.
        let path = Path {
            segments: vec![seg(Point3::new(10.0, 0.0, 0.0), 3000.0)],
            ..Default::default()
        };
        close(
            exact_stop_time_s(&path, &machine(None), FeedPolicy::Programmed),
            0.25,
        );
    }

    #[test]
    fn a_triangle_takes_the_slowest_axis_share() {
        // 1 mm along (1, 1)/√2: a = min(1000, 500)·√2; triangle 2·√(L/a).
        let d = 1.0 / 2f64.sqrt();
        let path = Path {
            segments: vec![seg(Point3::new(d, d, 0.0), 3000.0)],
            ..Default::default()
        };
        let a = 500.0 * 2f64.sqrt();
        close(
            exact_stop_time_s(&path, &machine(None), FeedPolicy::Programmed),
            2.0 * (1.0 / a).sqrt(),
        );
    }

    #[test]
    fn the_feed_is_capped_at_feed_max_and_machine_max_uses_it() {
        // 100 mm along Z: programmed 6000 capped at 3000 (50 mm/s), a = 250.
        let path = Path {
            segments: vec![seg(Point3::new(0.0, 0.0, 100.0), 6000.0)],
            ..Default::default()
        };
        close(
            exact_stop_time_s(&path, &machine(None), FeedPolicy::Programmed),
            100.0 / 50.0 + 50.0 / 250.0,
        );
        let slow = Path {
            segments: vec![seg(Point3::new(0.0, 0.0, 100.0), 600.0)],
            ..Default::default()
        };
        close(
            exact_stop_time_s(&slow, &machine(None), FeedPolicy::MachineMax),
            100.0 / 50.0 + 50.0 / 250.0,
        );
    }

    #[test]
    fn with_jerk_a_long_move_is_the_s_curve() {
        // L/v + v/a + a/j when the acceleration limit is reached.
        let path = Path {
            segments: vec![
                seg(Point3::new(20.0, 0.0, 0.0), 3000.0),
                Segment {
                    motion: Motion::Dwell { seconds: 0.5 },
                    ..seg(Point3::origin(), 1.0)
                },
            ],
            ..Default::default()
        };
        close(
            exact_stop_time_s(&path, &machine(Some(20000.0)), FeedPolicy::Programmed),
            20.0 / 50.0 + 50.0 / 1000.0 + 1000.0 / 20000.0 + 0.5,
        );
    }

    #[test]
    fn an_arc_takes_half_the_plane_budget() {
        // Full circle r = 1 in XY: v = √(500·1/2) ≈ 15.8 mm/s, a_t = 250.
        let start = Point3::new(1.0, 0.0, 0.0);
        let path = Path {
            segments: vec![Segment {
                start,
                end: start,
                geometry: Geometry::Arc {
                    center: Point3::origin(),
                    plane: nc::Plane::XY,
                    clockwise: false,
                    sweep_rad: 2.0 * std::f64::consts::PI,
                },
                ..seg(start, 3000.0)
            }],
            ..Default::default()
        };
        let v = 250f64.sqrt();
        let len = 2.0 * std::f64::consts::PI;
        close(
            exact_stop_time_s(&path, &machine(None), FeedPolicy::Programmed),
            len / v + v / 250.0,
        );
    }
}
