//! Each step's search for its offset in the closed loop (MODEL.md §5.1):
//! the relaxed update, the bracketed search, and the search for a fraction
//! of the offset a step starts at.

use super::{
    LOOP_MAX_PASSES, LOOP_RELAX_MAX, LOOP_RELAX_MIN, LOOP_RELAX_START, LOOP_REL_TOL,
    LOOP_SECANT_SLOPES, LOOP_TOL_UM,
};

/// Per-step relaxed update of the closed loop's offset (MODEL.md §5.1): the
/// next trial is `x + ω (g − x)`; ω halves when the step's residual g − x
/// changes sign (it overshot) and grows by 30 % while it keeps its sign.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Relaxed {
    pub(crate) omega: f64,
    /// The last residual was negative (its sign, starting positive).
    pub(crate) negative: bool,
}

impl Relaxed {
    pub(crate) const START: Relaxed = Relaxed {
        omega: LOOP_RELAX_START,
        negative: false,
    };

    /// Record g at x and return the next x to try (µm).
    pub(crate) fn next(&mut self, x: f64, g: f64) -> f64 {
        let r = g - x;
        let negative = r < 0.0;
        self.omega = if negative == self.negative {
            (1.3 * self.omega).min(LOOP_RELAX_MAX)
        } else {
            (0.5 * self.omega).max(LOOP_RELAX_MIN)
        };
        self.negative = negative;
        x + self.omega * r
    }
}

/// One bound of a step's bracket: the offset, and its residual g − x where
/// a sweep measured it (NaN where the bound is only inferred). The sweep
/// that gave it is kept beside it ([`Bracketed`]'s `lo_pass`, `hi_pass`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bound {
    pub(crate) at: f64,
    pub(crate) r: f64,
}

impl Bound {
    pub(crate) fn measured(&self) -> bool {
        self.r.is_finite()
    }
}

/// One step's search for its offset x = g(x) in the closed loop (MODEL.md
/// §5.1), kept inside a bracket. g falls as x grows (a tool moved out of the
/// material cuts less), so r = g − x falls strictly: a trial with r ≥ 0 is a
/// lower bound of the root, one with r < 0 an upper bound. The relaxed update
/// is taken where it lands inside the bracket or the step is within the
/// tolerance (so a loop that converged before takes the same trials);
/// otherwise (it overshot: a slender tool, g' ≪ −1, where x ← g(x) diverges)
/// the Illinois variant of false position between two measured bounds, or
/// the middle of the bracket; the middle too where the bracket has not
/// halved in three sweeps (a root at a jump of g, where the edge crosses a
/// column centre). The other steps' offsets move g too (a step starts where
/// the one before it ended): a bound a trial contradicts gives way to g(x)
/// (with the other steps as they are the root lies between x and g(x)), and
/// a bracket closed around a bound measured more than two sweeps before
/// drops that bound.
///
/// One a step of the loop: 80 B (sweeps as u8, at most
/// [`LOOP_MAX_PASSES`]; the relaxed update's sign beside them, not padded in
/// a [`Relaxed`]; the offset's cap, the tool's radius, passed in rather than
/// held).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bracketed {
    /// The relaxed update's factor ω ([`Relaxed`], its sign `negative`).
    pub(crate) omega: f64,
    pub(crate) lo: Bound,
    pub(crate) hi: Bound,
    /// Residuals false position weighs the measured bounds with (Illinois: a
    /// bound kept twice in a row has its weight halved).
    pub(crate) w_lo: f64,
    pub(crate) w_hi: f64,
    /// Bracket width when it last halved.
    pub(crate) width_mark: f64,
    /// The rigid sweep's g = δ₀ at x = 0, until the first update takes it
    /// (`first`).
    pub(crate) rigid_g: f64,
    /// Sweeps that gave the bounds.
    pub(crate) lo_pass: u8,
    pub(crate) hi_pass: u8,
    /// Sweeps since the bracket last halved.
    pub(crate) since_halved: u8,
    /// The bound the last trial replaced: −1 lower, 1 upper, 0 none.
    pub(crate) replaced: i8,
    /// No update taken yet: `rigid_g` is the rigid sweep's.
    pub(crate) first: bool,
    /// The relaxed update's last residual was negative ([`Relaxed`]).
    pub(crate) negative: bool,
}

/// A sweep of the closed loop as [`Bracketed`] holds it.
pub(crate) fn pass_u8(pass: usize) -> u8 {
    const _: () = assert!(LOOP_MAX_PASSES <= u8::MAX as usize);
    u8::try_from(pass).expect("at most LOOP_MAX_PASSES sweeps")
}

impl Bracketed {
    /// A step whose rigid sweep (offset 0, sweep 1) gave the deflection
    /// `rigid` ≥ 0 across the path; its offsets stay within ± `cap` (its
    /// tool's radius), µm.
    pub(crate) fn new(rigid: f64, cap: f64) -> Bracketed {
        let hi = cap;
        Bracketed {
            omega: Relaxed::START.omega,
            lo: Bound { at: 0.0, r: rigid },
            hi: Bound {
                at: hi,
                r: f64::NAN,
            },
            w_lo: rigid,
            w_hi: f64::NAN,
            width_mark: hi,
            rigid_g: rigid,
            lo_pass: 1,
            hi_pass: 0,
            since_halved: 0,
            replaced: 0,
            first: true,
            negative: Relaxed::START.negative,
        }
    }

    /// Record the residual `r` = g − x of the trial `x` measured by sweep
    /// `pass` (offsets within ± `cap`, as in [`Bracketed::new`]).
    pub(crate) fn observe(&mut self, x: f64, r: f64, pass: usize, cap: f64) {
        let pass = pass_u8(pass);
        if r >= 0.0 {
            if x >= self.hi.at {
                // The upper bound no longer holds (the steps before moved):
                // the root is now in [x, g(x)].
                self.hi = Bound {
                    at: (x + r).min(cap),
                    r: f64::NAN,
                };
                self.hi_pass = pass;
            }
            (self.lo, self.lo_pass) = (Bound { at: x, r }, pass);
            if self.replaced == -1 {
                self.w_hi *= 0.5;
            }
            (self.w_lo, self.replaced) = (r, -1);
        } else {
            if x <= self.lo.at {
                // In [g(x), x].
                self.lo = Bound {
                    at: (x + r).max(-cap),
                    r: f64::NAN,
                };
                self.lo_pass = pass;
            }
            (self.hi, self.hi_pass) = (Bound { at: x, r }, pass);
            if self.replaced == 1 {
                self.w_lo *= 0.5;
            }
            (self.w_hi, self.replaced) = (r, 1);
        }
        if self.hi.at - self.lo.at <= LOOP_TOL_UM {
            // Closed around a bound measured long ago: it may be stale.
            if self.lo_pass + 2 < pass {
                (self.lo, self.lo_pass) = (
                    Bound {
                        at: -cap,
                        r: f64::NAN,
                    },
                    pass,
                );
            }
            if self.hi_pass + 2 < pass {
                (self.hi, self.hi_pass) = (
                    Bound {
                        at: cap,
                        r: f64::NAN,
                    },
                    pass,
                );
            }
        }
        if !self.lo.measured() {
            self.w_lo = f64::NAN;
        }
        if !self.hi.measured() {
            self.w_hi = f64::NAN;
        }
        let width = self.hi.at - self.lo.at;
        if width <= 0.5 * self.width_mark || width > self.width_mark {
            (self.width_mark, self.since_halved) = (width, 0);
        } else {
            self.since_halved += 1;
        }
    }

    /// Both bounds measured in the last two sweeps and within the tolerance
    /// of each other: the root lies between them, at a jump of g if the
    /// residual there is larger.
    pub(crate) fn closed(&self, pass: usize) -> bool {
        let pass = pass_u8(pass);
        let tol = LOOP_TOL_UM + LOOP_REL_TOL * self.lo.at.abs().max(self.hi.at.abs());
        self.lo.measured()
            && self.hi.measured()
            && self.hi.at - self.lo.at <= tol
            && self.lo_pass + 2 >= pass
            && self.hi_pass + 2 >= pass
    }

    /// After the first trial `x` gave `g`: the slope s = Δg/Δx of g between
    /// the rigid sweep (x = 0) and this one, where they lie more than the
    /// tolerance apart (None after the first update).
    pub(crate) fn first_slope(&self, x: f64, g: f64) -> Option<f64> {
        if !self.first {
            return None;
        }
        let (x0, g0) = (0.0, self.rigid_g);
        ((x - x0).abs() > LOOP_TOL_UM).then(|| (g - g0) / (x - x0))
    }

    /// The next offset to try after `x` gave `g` (observed first). `secant`:
    /// at the first update, take the secant's root where the slope of g is
    /// in [`LOOP_SECANT_SLOPES`] (the loop allows it where every step's is).
    pub(crate) fn next(&mut self, x: f64, g: f64, secant: bool) -> f64 {
        let mut update = Relaxed {
            omega: self.omega,
            negative: self.negative,
        };
        let relaxed = update.next(x, g);
        (self.omega, self.negative) = (update.omega, update.negative);
        let p = match self.first_slope(x, g) {
            Some(s) if secant && LOOP_SECANT_SLOPES.contains(&s) => {
                x + (g - x) / (1.0 - s.min(0.0))
            }
            _ => relaxed,
        };
        self.first = false;
        let (lo, hi) = (self.lo, self.hi);
        let middle = 0.5 * (lo.at + hi.at);
        // A step within the tolerance takes the relaxed update (it moves
        // little, and x may sit on a bound: g = x there).
        if (g - x).abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() {
            return p;
        }
        let measured = lo.measured() && hi.measured();
        if measured && self.since_halved >= 3 {
            return middle;
        }
        let above = p > lo.at || (!lo.measured() && p >= lo.at);
        let below = p < hi.at || (!hi.measured() && p <= hi.at);
        if above && below {
            return p;
        }
        if measured {
            // Illinois: false position on the weighted residuals.
            let t = self.w_lo / (self.w_lo - self.w_hi);
            if t.is_finite() && t > 0.0 && t < 1.0 {
                return lo.at + t * (hi.at - lo.at);
            }
        }
        middle
    }
}

/// The closed loop's search for the offset of a step that took its direction
/// from the step before it ([`inherit_directions`], MODEL.md §5.1, eq. 5.1a):
/// the fraction φ of the offset x₋ the step starts at, x = φ x₋, with the
/// root in 0 ≤ φ ≤ 1. At φ = 0 the step sweeps back to the programmed path
/// (the offset of a step with no direction, its first trial: a step whose
/// sweep back removes nothing keeps it); at φ = 1 it is the rigid step moved
/// by x₋, which pushes the tool across its path by nothing (its second
/// trial). g − x falls with x, so a trial whose residual puts the root at a
/// larger |x| is a lower bound of φ, otherwise an upper one (a bound a trial
/// contradicts, x₋ having moved, gives way to 0 or 1), and the next trial is
/// the Illinois false position between the two ([`Bracketed`]'s rule; its
/// bounds are absolute offsets, these move with x₋), or the middle where the
/// bracket has not halved in three sweeps. A short step's g is steep (the
/// sweep back of 1 µm of wall in 0.1 ms loads the tool as 200 µm of it in
/// a 25 ms step would), and its root lies within a µm of x₋: false position
/// from φ = 0 and 1 finds it in one or two sweeps, where halving 0…1 takes
/// seven.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fraction {
    pub(crate) phi: f64,
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    /// The residuals g − x at the bounds, signed so that the lower one is
    /// ≥ 0 and the upper one < 0 (Illinois: halved when the other bound
    /// moved twice in a row).
    pub(crate) w_lo: f64,
    pub(crate) w_hi: f64,
    /// Sweeps that measured the bounds (0: not measured).
    pub(crate) lo_pass: usize,
    pub(crate) hi_pass: usize,
    /// The bound the last trial replaced: −1 lower, 1 upper, 0 none.
    pub(crate) replaced: i8,
    /// Bracket width when it last halved, and sweeps since.
    pub(crate) width_mark: f64,
    pub(crate) since_halved: u32,
}

impl Fraction {
    pub(crate) const START: Fraction = Fraction {
        phi: 0.0,
        lo: 0.0,
        hi: 1.0,
        w_lo: f64::NAN,
        w_hi: f64::NAN,
        lo_pass: 0,
        hi_pass: 0,
        replaced: 0,
        width_mark: 1.0,
        since_halved: 0,
    };

    /// Record the residual `r` = g − x of the trial φ measured by sweep
    /// `pass`, the step having started at the offset `from`.
    pub(crate) fn observe(&mut self, r: f64, from: f64, pass: usize) {
        let phi = self.phi;
        let was_measured = self.lo_pass > 0 && self.hi_pass > 0;
        let w = if from < 0.0 { -r } else { r };
        if w >= 0.0 {
            if phi >= self.hi {
                (self.hi, self.hi_pass) = (1.0, 0);
            }
            (self.lo, self.lo_pass) = (phi, pass);
            if self.replaced == -1 {
                self.w_hi *= 0.5;
            }
            (self.w_lo, self.replaced) = (w, -1);
        } else {
            if phi <= self.lo {
                (self.lo, self.lo_pass) = (0.0, 0);
            }
            (self.hi, self.hi_pass) = (phi, pass);
            if self.replaced == 1 {
                self.w_lo *= 0.5;
            }
            (self.w_hi, self.replaced) = (w, 1);
        }
        // (Counted from the sweep that measured both bounds: the first
        // trials, φ = 0 and 1, halve nothing.)
        let width = self.hi - self.lo;
        if !was_measured || width <= 0.5 * self.width_mark || width > self.width_mark {
            (self.width_mark, self.since_halved) = (width, 0);
        } else {
            self.since_halved += 1;
        }
    }

    /// Both bounds measured in the last two sweeps (or the lower one, if
    /// measured after the upper one: a bracket held at its lower bound,
    /// [`Fraction::next`]) and, as offsets from `from`, within the tolerance
    /// of each other.
    pub(crate) fn closed(&self, from: f64, pass: usize) -> bool {
        self.lo_pass > 0
            && self.hi_pass > 0
            && self.lo_pass + 2 >= pass
            && (self.hi_pass + 2 >= pass || self.lo_pass > self.hi_pass)
            && self.width_um(from) <= LOOP_TOL_UM + LOOP_REL_TOL * (self.hi * from).abs()
    }

    /// The bracket's width as offsets from `from`, µm.
    pub(crate) fn width_um(&self, from: f64) -> f64 {
        (self.hi - self.lo) * from.abs()
    }

    /// The root lies outside 0 ≤ φ ≤ 1, and the step's offset is the bound
    /// it lies beyond (MODEL.md §5.1, eq. 5.1b): even at φ = 1 the bent
    /// tool's removal pushes the step further than the offset it starts at
    /// (material its neighbours' offsets left), and the step goes on at that
    /// offset; or even at φ = 0 it pushes the tool back across the path
    /// (the step's own cut, of material the other steps' offsets left, loads
    /// it the other way), and the step ends on the path. Its load is
    /// reported as swept.
    pub(crate) fn held(&self) -> bool {
        (self.lo >= 1.0 && self.lo_pass > 0) || (self.hi <= 0.0 && self.hi_pass > 0)
    }

    /// The next fraction to try (observed first), the step having started at
    /// the offset `from`: the trial kept where its residual `r` at the
    /// offset `x` is within the tolerance; where the bracket is, the bound
    /// measured longer ago again (x₋ may have moved since), except that a
    /// closed bracket whose lower bound this sweep `pass` measured is held
    /// there (MODEL.md §5.1, eq. 5.1c): trying its bounds in turn cut a row
    /// of columns at one sweep and not at the next, and the step after it,
    /// starting there, found the row cut or not and never settled.
    pub(crate) fn next(&mut self, r: f64, x: f64, from: f64, pass: usize) -> f64 {
        if r.abs() <= LOOP_TOL_UM + LOOP_REL_TOL * x.abs() {
            return self.phi;
        }
        let narrow = self.width_um(from) <= LOOP_TOL_UM + LOOP_REL_TOL * (self.hi * from).abs();
        self.phi = if self.hi_pass == 0 {
            self.hi
        } else if self.lo_pass == 0 {
            self.lo
        } else if narrow {
            let held = self.lo_pass == pass && self.closed(from, pass);
            if held || self.lo_pass < self.hi_pass {
                self.lo
            } else {
                self.hi
            }
        } else {
            let t = self.w_lo / (self.w_lo - self.w_hi);
            if self.since_halved < 3 && t.is_finite() && t > 0.0 && t < 1.0 {
                self.lo + t * (self.hi - self.lo)
            } else {
                0.5 * (self.lo + self.hi)
            }
        };
        self.phi
    }
}
