//! The motion path: what a program means geometrically, independent of time.
//!
//! Positions are tool-tip positions in the machine frame (mm), after work
//! offsets and unit conversion. Every segment remembers the 1-based source line
//! of the block that produced it so that diagnostics, error maps and the
//! re-feed writer can point back into the program.

use nalgebra::{Point3, Vector3};

/// Arc plane as selected by G17/G18/G19.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17: arcs in XY, helix along Z.
    XY,
    /// G18: arcs in ZX, helix along Y.
    ZX,
    /// G19: arcs in YZ, helix along X.
    YZ,
}

impl Plane {
    /// Indices (first, second, normal) of the plane's axes in [x, y, z].
    /// G18's first axis is Z and second X, so that G2 is clockwise seen from +Y.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::XY => (0, 1, 2),
            Plane::ZX => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        }
    }
}

/// Shape of one segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Geometry {
    /// Straight line from start to end.
    Line,
    /// Circular (or helical) arc. `center` lies in the plane of `start`;
    /// the end may differ from the start plane along the plane normal (helix).
    Arc {
        /// Centre, mm, machine frame.
        center: Point3<f64>,
        /// Plane the arc turns in (G17/G18/G19).
        plane: Plane,
        /// G2 (true) or G3, seen from the positive plane normal.
        clockwise: bool,
        /// Total swept angle, positive, full turns included (2π for a full circle).
        sweep_rad: f64,
    },
}

/// How the machine moves along a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// G0 at the machine's rapid rate.
    Rapid,
    /// Feed motion at the programmed feed (G93 inverse time already converted).
    Feed {
        /// Programmed feed along the path, mm/min.
        feed_mm_min: f64,
        /// The feed is held as programmed: the control runs it with its feed
        /// override disabled (the feed moves of G84/G74 tapping, whose feed is
        /// the tap's pitch times the spindle speed). Re-timing keeps it.
        held: bool,
    },
    /// G4: no motion for a time.
    Dwell {
        /// Dwell time, s.
        seconds: f64,
    },
}

impl Motion {
    /// A feed move at `feed_mm_min` that re-timing may change.
    pub fn feed(feed_mm_min: f64) -> Motion {
        Motion::Feed {
            feed_mm_min,
            held: false,
        }
    }

    /// The feed of a feed move that re-timing must keep
    /// ([`Motion::Feed`]'s `held`), else `None`.
    pub fn held_feed_mm_min(&self) -> Option<f64> {
        match *self {
            Motion::Feed {
                feed_mm_min,
                held: true,
            } => Some(feed_mm_min),
            _ => None,
        }
    }
}

/// One piece of the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Tool tip where the segment starts, mm, machine frame.
    pub start: Point3<f64>,
    /// Tool tip where it ends, mm, machine frame.
    pub end: Point3<f64>,
    /// Line or arc.
    pub geometry: Geometry,
    /// Rapid, feed or dwell.
    pub motion: Motion,
    /// 1-based line in the source file of the block that made this segment.
    pub line: u32,
    /// Spindle speed in force when the segment runs (rev/min, 0 = stopped).
    pub spindle_rpm: f64,
    /// Number (T word) of the tool in the spindle; 0 before any tool is loaded.
    pub tool: u32,
}

impl Segment {
    /// The same segment bit for bit (every f64 by its bits: −0 is not 0),
    /// as the interpreter's reading of a lent path checks it
    /// ([`crate::refeed_read_along`]).
    pub(crate) fn same_bits(&self, other: &Segment) -> bool {
        let point = |a: &Point3<f64>, b: &Point3<f64>| {
            a.coords
                .iter()
                .zip(b.coords.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let geometry = match (&self.geometry, &other.geometry) {
            (Geometry::Line, Geometry::Line) => true,
            (
                Geometry::Arc {
                    center: c1,
                    plane: p1,
                    clockwise: w1,
                    sweep_rad: s1,
                },
                Geometry::Arc {
                    center: c2,
                    plane: p2,
                    clockwise: w2,
                    sweep_rad: s2,
                },
            ) => point(c1, c2) && p1 == p2 && w1 == w2 && s1.to_bits() == s2.to_bits(),
            _ => false,
        };
        let motion = match (self.motion, other.motion) {
            (Motion::Rapid, Motion::Rapid) => true,
            (
                Motion::Feed {
                    feed_mm_min: a,
                    held: h,
                },
                Motion::Feed {
                    feed_mm_min: b,
                    held: k,
                },
            ) => a.to_bits() == b.to_bits() && h == k,
            (Motion::Dwell { seconds: a }, Motion::Dwell { seconds: b }) => {
                a.to_bits() == b.to_bits()
            }
            _ => false,
        };
        point(&self.start, &other.start)
            && point(&self.end, &other.end)
            && geometry
            && motion
            && self.line == other.line
            && self.spindle_rpm.to_bits() == other.spindle_rpm.to_bits()
            && self.tool == other.tool
    }

    /// Path length in mm (arc length for arcs, helix included).
    pub fn length_mm(&self) -> f64 {
        self.geometry.length_mm(&self.start, &self.end)
    }

    /// Point at fraction `u` ∈ [0, 1] of the segment.
    pub fn point_at_fraction(&self, u: f64) -> Point3<f64> {
        match self.geometry {
            Geometry::Line => self.start + (self.end - self.start) * u,
            Geometry::Arc {
                center,
                plane,
                clockwise,
                sweep_rad,
            } => {
                let (a, b, n) = plane.axes();
                // The radius goes from the start's to the end's along the sweep (a spiral
                // where a program's end is off its circle by the rounding of its words, as
                // LinuxCNC runs it): the points meet the end at u = 1, not a jump there
                // (a 0.002 mm jump is 2 000 mm/s² in 1 ms servo samples).
                let r0 = arc_radius(&center, plane, &self.start);
                let r = r0 + (arc_radius(&center, plane, &self.end) - r0) * u;
                let a0 = (self.start[b] - center[b]).atan2(self.start[a] - center[a]);
                let ang = if clockwise {
                    a0 - sweep_rad * u
                } else {
                    a0 + sweep_rad * u
                };
                let mut p = self.start;
                p[a] = center[a] + r * ang.cos();
                p[b] = center[b] + r * ang.sin();
                p[n] = self.start[n] + (self.end[n] - self.start[n]) * u;
                if u >= 1.0 {
                    p = self.end;
                }
                p
            }
        }
    }

    /// Unit tangent at fraction `u` (zero vector for a zero-length segment).
    pub fn tangent_at_fraction(&self, u: f64) -> Vector3<f64> {
        let t = match self.geometry {
            Geometry::Line => self.end - self.start,
            Geometry::Arc {
                center,
                plane,
                clockwise,
                sweep_rad,
            } => {
                let (a, b, n) = plane.axes();
                let p = self.point_at_fraction(u);
                let (ra, rb) = (p[a] - center[a], p[b] - center[b]);
                let sign = if clockwise { -1.0 } else { 1.0 };
                let mut v = Vector3::zeros();
                v[a] = -rb * sign * sweep_rad;
                v[b] = ra * sign * sweep_rad;
                v[n] = self.end[n] - self.start[n];
                v
            }
        };
        let len = t.norm();
        if len > 0.0 {
            t / len
        } else {
            Vector3::zeros()
        }
    }

    /// Curvature radius in mm (infinite for lines).
    pub fn radius_mm(&self) -> f64 {
        match self.geometry {
            Geometry::Line => f64::INFINITY,
            Geometry::Arc { center, plane, .. } => arc_radius(&center, plane, &self.start),
        }
    }
}

impl Geometry {
    /// Length in mm of this shape from `start` to `end` (arc length for
    /// arcs, helix included); what [`Segment::length_mm`] returns.
    pub(crate) fn length_mm(&self, start: &Point3<f64>, end: &Point3<f64>) -> f64 {
        match *self {
            Geometry::Line => (end - start).norm(),
            Geometry::Arc {
                center,
                plane,
                sweep_rad,
                ..
            } => {
                let n = plane.axes().2;
                let r = arc_radius(&center, plane, start);
                let h = end[n] - start[n];
                ((r * sweep_rad).powi(2) + h * h).sqrt()
            }
        }
    }
}

/// Distance in the arc plane from `center` to `point`.
fn arc_radius(center: &Point3<f64>, plane: Plane, point: &Point3<f64>) -> f64 {
    let (a, b, _) = plane.axes();
    ((point[a] - center[a]).powi(2) + (point[b] - center[b]).powi(2)).sqrt()
}

/// A whole program's motion, in execution order (subprograms and loops
/// unrolled). A tool change whose new tool reaches lower or higher than the
/// old one is a rapid from the old tool's tip to the new tool's tip.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Path {
    /// The segments in the order the machine runs them.
    pub segments: Vec<Segment>,
    /// The program's path control (G61, G61.1, G64 P Q) as a run-length list:
    /// each change with the first segment it applies to, in segment order.
    /// Segments before the first change run in the control's start-up mode.
    pub path_control: Vec<PathControlChange>,
    /// Segments before which the control waits for the motion before to
    /// stop (spindle, coolant and tool changes, pauses), ascending; no
    /// segment's geometry depends on them.
    pub motion_waits: Vec<usize>,
}

/// How the control joins consecutive moves (G61, G61.1, G64), as the
/// program sets it (MODEL.md §9.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PathControl {
    /// G61: exact path; LinuxCNC stops at every corner it cannot pass tangent.
    ExactPath,
    /// G61.1: exact stop at the end of every move.
    ExactStop,
    /// G64: blend consecutive moves.
    Blend {
        /// P: how far the blended path may leave a corner, mm; `None`
        /// without P (no limit but the moves' own lengths).
        tolerance_mm: Option<f64>,
        /// Q: the naive CAM detector's tolerance, mm (collinear short moves
        /// within it are joined); `None` without Q (then P's value, or off
        /// without P, as LinuxCNC's interpreter sets it).
        naive_cam_mm: Option<f64>,
    },
}

/// A change of [`PathControl`] in a [`Path`]: `mode` applies from segment
/// `first_segment` on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathControlChange {
    /// Index of the first segment made after the block that set the mode.
    pub first_segment: usize,
    /// The mode.
    pub mode: PathControl,
}

impl Path {
    /// A path of `segments` run in the control's start-up mode throughout.
    pub fn from_segments(segments: Vec<Segment>) -> Path {
        Path {
            segments,
            path_control: Vec::new(),
            motion_waits: Vec::new(),
        }
    }

    /// The program's path control in force at segment `index`, `None` where
    /// the program has set none yet (the control's start-up mode).
    pub fn path_control_at(&self, index: usize) -> Option<PathControl> {
        let n = self
            .path_control
            .partition_point(|c| c.first_segment <= index);
        n.checked_sub(1).map(|i| self.path_control[i].mode)
    }

    /// Total length in mm of all segments.
    pub fn length_mm(&self) -> f64 {
        self.segments.iter().map(Segment::length_mm).sum()
    }

    /// The path mirrored in Z (z ↦ −z): a program written for a machine whose
    /// Z axis points down, in a frame whose Z points up, and back. Arcs in
    /// the ZX and YZ planes turn the other way; XY arcs keep their direction
    /// (their X and Y are not mirrored). Lengths and fractions are unchanged.
    pub fn mirror_z(&mut self) {
        for s in &mut self.segments {
            s.start.z = -s.start.z;
            s.end.z = -s.end.z;
            if let Geometry::Arc {
                center,
                plane,
                clockwise,
                ..
            } = &mut s.geometry
            {
                center.z = -center.z;
                if *plane != Plane::XY {
                    *clockwise = !*clockwise;
                }
            }
        }
    }
}

impl Path {
    /// Tool numbers in order of first use.
    pub fn tools(&self) -> Vec<u32> {
        let mut tools: Vec<u32> = Vec::new();
        for s in &self.segments {
            if !tools.contains(&s.tool) {
                tools.push(s.tool);
            }
        }
        tools
    }
}

#[cfg(test)]
mod tests {
    /// Mirrored in Z, every point of every segment (lines, a helix in XY,
    /// arcs in ZX and YZ both ways) is the mirror of the original's at the
    /// same fraction, lengths are kept, and mirroring twice gives the path back.
    #[test]
    fn a_path_mirrored_in_z_is_the_mirror_image_point_by_point() {
        let source = "G0 X1 Y2 Z3\nG1 Z-1 F100\nG17 G2 X5 Y2 Z-2 I2 J0\nG1 Z-1\nG18 G2 X9 Z-1 I2 K0\nG3 X13 Z-1 I2 K0\n\
            G19 G2 Y6 Z-1 J2 K0\nG3 Y10 Z-1 J2 K0\nM2\n";
        let path = crate::parse(source, "m.ngc", &crate::Options::default()).path;
        assert_eq!(path.segments.len(), 8);
        let mut mirrored = path.clone();
        mirrored.mirror_z();
        for (a, b) in path.segments.iter().zip(&mirrored.segments) {
            assert!((a.length_mm() - b.length_mm()).abs() < 1e-12);
            for k in 0..=8 {
                let u = k as f64 / 8.0;
                let (p, q) = (a.point_at_fraction(u), b.point_at_fraction(u));
                assert!(
                    (p.x - q.x).abs() < 1e-12
                        && (p.y - q.y).abs() < 1e-12
                        && (p.z + q.z).abs() < 1e-12,
                    "line {}: {p} vs {q} at {u}",
                    a.line
                );
            }
        }
        mirrored.mirror_z();
        assert_eq!(mirrored, path);
    }

    /// An arc whose end is off its start's circle (within LinuxCNC's 0.0283 mm) runs as a
    /// spiral, as LinuxCNC does: its points reach the written end continuously, with no
    /// jump at u = 1 (0.02 mm there was 20 000 mm/s² in 1 ms servo samples).
    #[test]
    fn an_arc_off_its_circle_meets_its_end_without_a_jump() {
        let source = "G0 X0 Y0\nG2 X20.02 Y0 I10 J0 F100\nM2\n";
        let path = crate::parse(source, "s.ngc", &crate::Options::default()).path;
        let arc = path.segments.last().expect("the arc");
        let (r0, r1) = (10.0, 10.02);
        let center = nalgebra::Point3::new(10.0, 0.0, 0.0);
        for k in 0..=1000 {
            let u = k as f64 / 1000.0;
            let r = (arc.point_at_fraction(u) - center).norm();
            assert!((r - (r0 + (r1 - r0) * u)).abs() < 1e-9, "r {r} at {u}");
        }
        let step = (arc.point_at_fraction(1.0) - arc.point_at_fraction(1.0 - 1e-9)).norm();
        assert!(step < 1e-6, "{step}");
        assert_eq!(arc.point_at_fraction(1.0), arc.end);
    }
}
