//! Canned cycles (G73, G74, G81-G87, G89): their modal words, holes and
//! the moves they expand to.

use super::state::Spindle;
use super::{fail, Block, Fail, Interp};
use crate::cycles::{self, Cycle, CycleMove};
use crate::gcode::GCode;
use crate::path::{Geometry, Motion, Plane};

/// Most pecks (times L repeats) one drilling cycle block may make.
const MAX_CYCLE_PECKS: f64 = 100_000.0;

/// A cycle block's words as read (R, Z, L) and its peck depth (mm, 0 where
/// it does not peck).
struct CycleWords {
    r: f64,
    z: f64,
    repeats: f64,
    peck_mm: f64,
}

impl Interp<'_> {
    /// The block's canned cycle: its words, the spindle and feed it needs,
    /// its holes (every L repeat, polar words too), then its moves.
    pub(super) fn cycle(&mut self, b: &Block, pc: usize) -> Result<(), Fail> {
        let CycleWords {
            r,
            z,
            repeats,
            peck_mm,
        } = self.cycle_words(b)?;
        let code = self.motion;
        // LinuxCNC checks the spindle where the cycle runs its hole.
        let spindle_error = match (code, self.spindle) {
            (GCode::G74 | GCode::G84 | GCode::G86 | GCode::G87, Spindle::Stopped) => {
                Some(format!("Spindle not turning in {code}"))
            }
            (GCode::G84, Spindle::Counterclockwise) => {
                Some("Spindle turning counterclockwise in G84".to_string())
            }
            (GCode::G74, Spindle::Clockwise) => Some("Spindle turning clockwise in G74".into()),
            _ => None,
        };
        if let Some(msg) = spindle_error {
            return fail(b.first_col, msg);
        }
        if self.feed_mm_min <= 0.0 {
            return fail(b.first_col, "canned cycle with zero feed rate");
        }
        let initial_z = *self.cycle_initial_z.get_or_insert(self.pos[2]);
        let off = self.offset();
        let (r_z, bottom_z, holes) = if self.incremental {
            // LinuxCNC's CYCLE_MACRO: each repeat steps X/Y, then the polar
            // radius and angle about the program origin.
            let r_z = initial_z + r * self.scale;
            // In a rotated coordinate system (G10 L2 R), in its own frame.
            let rotated = self.rotation() != 0.0;
            let (mut aa, mut bb) = if rotated {
                let p = self.to_program(self.pos);
                (p[0] / self.scale, p[1] / self.scale)
            } else {
                (
                    (self.pos[0] - off[0]) / self.scale,
                    (self.pos[1] - off[1]) / self.scale,
                )
            };
            let (di, dj) = (b.get('x').unwrap_or(0.0), b.get('y').unwrap_or(0.0));
            let (dr, dt) = (b.get('@').unwrap_or(0.0), b.get('^').unwrap_or(0.0));
            let mut holes = Vec::with_capacity(repeats as usize);
            for _ in 0..repeats as u32 {
                aa += di;
                bb += dj;
                for (radius_inc, angle_inc) in [(dr, 0.0), (0.0, dt.to_radians())] {
                    if radius_inc == 0.0 && angle_inc == 0.0 {
                        continue;
                    }
                    if aa == 0.0 && bb == 0.0 {
                        return fail(
                            b.col(if dr != 0.0 { '@' } else { '^' }),
                            "incremental polar motion is indeterminate at the origin",
                        );
                    }
                    let (radius, theta) = (aa.hypot(bb) + radius_inc, bb.atan2(aa) + angle_inc);
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
                holes.push(if rotated {
                    let m = self.to_machine([aa * self.scale, bb * self.scale, 0.0]);
                    [m[0], m[1]]
                } else {
                    [aa * self.scale + off[0], bb * self.scale + off[1]]
                });
            }
            (r_z, r_z + z * self.scale, holes)
        } else {
            let t = self.target(b, false)?;
            (
                r * self.scale + off[2],
                z * self.scale + off[2],
                vec![[t[0], t[1]]; repeats as usize],
            )
        };
        if r_z < bottom_z {
            return fail(b.col('r'), "R plane below the hole bottom Z");
        }
        // G87's K: the back bore's top, absolute, or from the bottom under G91.
        let back_top_z = if self.incremental {
            bottom_z + self.cycle_ijk[2] * self.scale
        } else {
            self.cycle_ijk[2] * self.scale + off[2]
        };
        // Each peck is a few moves: bound them before expanding (Q 1e-9 would be 1e10 moves).
        let pecks = if peck_mm > 0.0 {
            ((r_z - bottom_z) / peck_mm).ceil() * repeats
        } else {
            repeats
        };
        if !(pecks <= MAX_CYCLE_PECKS) {
            return fail(
                b.col(if peck_mm > 0.0 { 'q' } else { 'l' }),
                format!(
                    "the cycle would make {pecks:.3e} pecks (limit {MAX_CYCLE_PECKS}): Q peck depth too small"
                ),
            );
        }
        let c = Cycle {
            code: self.motion,
            holes,
            start_z: initial_z,
            current_z: self.pos[2],
            r_z,
            bottom_z,
            retract_to_start: self.retract_to_start,
            peck_mm,
            dwell_s: self.cycle_p,
            back_offset_mm: super::motion::rotate(
                [
                    self.cycle_ijk[0] * self.scale,
                    self.cycle_ijk[1] * self.scale,
                ],
                self.rotation(),
            ),
            back_top_z,
        };
        self.cycle_moves(&c, pc);
        Ok(())
    }

    /// The cycle's modal words, checked as LinuxCNC's convert_cycle checks
    /// them (the plane, G93, R, Z, L, Q, P, and I J K for G87), held for the
    /// cycle's next blocks: the first of [`Interp::cycle`]'s steps.
    fn cycle_words(&mut self, b: &Block) -> Result<CycleWords, Fail> {
        if self.plane != Plane::XY {
            return fail(
                b.first_col,
                "canned cycles are supported in the G17 plane only",
            );
        }
        if self.inverse_time {
            return fail(
                b.first_col,
                "canned cycles cannot be used with G93 inverse time",
            );
        }
        // As LinuxCNC's convert_cycle: no rotary axis word in a cycle's block
        // (A0 too, which elsewhere keeps the axis at 0).
        if let Some(axis) = ['a', 'b', 'c'].into_iter().find(|&l| b.get(l).is_some()) {
            return fail(
                b.col(axis),
                format!(
                    "cannot put {} word in a canned cycle",
                    axis.to_ascii_uppercase()
                ),
            );
        }
        // As LinuxCNC's convert_cycle: a cycle entered from another motion
        // mode needs its R and Z words (and P where it dwells, I J K for
        // G87); a later block of the same cycle takes those it lacks from
        // the block before.
        let code = self.motion;
        let entered = self.previous_motion != code;
        let modal = |word: Option<f64>, held: Option<f64>| {
            if entered {
                word
            } else {
                word.or(held)
            }
        };
        let r = modal(b.get('r'), self.cycle_r).ok_or(Fail {
            col: b.first_col,
            msg: "R clearance plane unspecified in cycle".into(),
        })?;
        let z = modal(b.get('z'), self.cycle_z).ok_or(Fail {
            col: b.first_col,
            msg: "Z value unspecified in XY plane canned cycle".into(),
        })?;
        self.cycle_r = Some(r);
        self.cycle_z = Some(z);
        let repeats = b.get('l').unwrap_or(1.0);
        if repeats < 1.0 || repeats.fract() != 0.0 || repeats > 1e5 {
            return fail(
                b.col('l'),
                "L repeat count must be an integer from 1 to 100000",
            );
        }
        let mut peck_mm = 0.0;
        if matches!(self.motion, GCode::G73 | GCode::G83) {
            let q = b.get('q').or(self.cycle_q).ok_or(Fail {
                col: b.first_col,
                msg: "G73/G83 need a Q word (peck depth)".into(),
            })?;
            if q <= 0.0 {
                return fail(b.col('q'), "Q (peck depth) must be positive");
            }
            self.cycle_q = Some(q);
            peck_mm = q * self.scale;
        }
        if matches!(code, GCode::G82 | GCode::G86 | GCode::G89) && entered && b.get('p').is_none() {
            return fail(
                b.first_col,
                format!("Dwell time P word missing with {code}"),
            );
        }
        if matches!(
            code,
            GCode::G74 | GCode::G82 | GCode::G84 | GCode::G86 | GCode::G89
        ) {
            self.cycle_p = b.get('p').unwrap_or(self.cycle_p);
        }
        if code == GCode::G87 {
            for (k, letter) in ['i', 'j', 'k'].into_iter().enumerate() {
                match b.get(letter) {
                    Some(v) => self.cycle_ijk[k] = v,
                    None if entered => {
                        return fail(
                            b.first_col,
                            format!("{} word missing with G87", letter.to_ascii_uppercase()),
                        )
                    }
                    None => {}
                }
            }
        }
        Ok(CycleWords {
            r,
            z,
            repeats,
            peck_mm,
        })
    }

    /// Appends the moves cycle `c` expands to, the spindle stopped and
    /// started again where the cycle does: the last of [`Interp::cycle`]'s steps.
    fn cycle_moves(&mut self, c: &Cycle, pc: usize) {
        let turning = self.spindle;
        for m in cycles::expand(c, [self.pos[0], self.pos[1]]) {
            match m {
                CycleMove::Rapid(p) => self.rapid(p, pc),
                CycleMove::Feed(p) => {
                    self.push(p, Geometry::Line, Motion::feed(self.feed_mm_min), pc, false)
                }
                CycleMove::HeldFeed(p) => self.push(
                    p,
                    Geometry::Line,
                    Motion::Feed {
                        feed_mm_min: self.feed_mm_min,
                        held: true,
                    },
                    pc,
                    false,
                ),
                CycleMove::SpindleStop => self.spindle = Spindle::Stopped,
                CycleMove::SpindleStart => self.spindle = turning,
                CycleMove::Dwell(s) => self.push(
                    self.pos,
                    Geometry::Line,
                    Motion::Dwell { seconds: s },
                    pc,
                    true,
                ),
            }
        }
    }
}
