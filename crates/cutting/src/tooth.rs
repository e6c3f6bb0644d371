//! Forces through one tooth period from the engagement of each height band
//! (MODEL.md §3.4): the edge's own frame on flat, bull-nose and ball ends
//! (Altintas, *Manufacturing Automation* ch. 2; Lee & Altintas 1996), a
//! helical edge, the mean over a revolution in closed form and the peak over
//! the revolution from the force's piecewise closed form.
//!
//! Angles: the immersion φ is measured clockwise seen from above (+Z down the
//! view), from the left of the feed (+y of the feed frame); a tooth at φ sits at
//! `r (sin φ, cos φ)` in the feed frame (x along the feed, y to its left, z
//! up), and an M3 (clockwise) spindle turns it towards larger φ. Up milling
//! starts at φ = 0 (material on the left), down milling ends at φ = π. The
//! chip at φ on an edge whose normal makes the angle κ with the axis is
//! `h = f_z sin φ sin κ`; forces are on the tool.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

/// The cutting edge's profile: the radius and the angle κ of the edge's normal
/// to the tool axis as functions of the height z above the tip.
///
/// A flat end is a bull nose of corner radius 0, a ball end one of corner
/// radius R; κ is 90° on the cylinder above the corner.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeShape {
    /// Tool radius R, mm.
    pub radius_mm: f64,
    /// Corner radius r_c (0 flat end, R ball end), mm.
    pub corner_mm: f64,
}

/// The integrals of a stretch of edge over its heights [z0, z1]:
/// `∫ dz`, `∫ sin κ dz`, `∫ cos κ dz`, `∫ r dz` (mm, mm, mm, mm²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EdgeMoments {
    /// Height spanned, mm.
    pub length_mm: f64,
    /// ∫ sin κ dz, mm.
    pub sin_k_mm: f64,
    /// ∫ cos κ dz, mm.
    pub cos_k_mm: f64,
    /// ∫ r dz, mm².
    pub radius_mm2: f64,
}

impl EdgeShape {
    /// A flat end mill of radius `radius_mm`.
    pub fn flat(radius_mm: f64) -> Self {
        EdgeShape {
            radius_mm,
            corner_mm: 0.0,
        }
    }

    /// A ball end mill of radius `radius_mm`.
    pub fn ball(radius_mm: f64) -> Self {
        EdgeShape {
            radius_mm,
            corner_mm: radius_mm,
        }
    }

    /// The edge's radius at height `z_mm` above the tip, mm.
    pub fn radius_at_mm(&self, z_mm: f64) -> f64 {
        let (rr, rc) = (self.radius_mm, self.corner_mm);
        if z_mm >= rc {
            return rr;
        }
        let z = z_mm.max(0.0);
        // On the corner z = r_c (1 − cos κ), r = R − r_c + r_c sin κ.
        rr - rc + (z * (2.0 * rc - z)).max(0.0).sqrt()
    }

    /// The corner's angle κ at height z (≤ r_c): cos κ = 1 − z / r_c.
    fn corner_kappa(&self, z: f64) -> f64 {
        (1.0 - z / self.corner_mm).clamp(-1.0, 1.0).acos()
    }

    /// [`EdgeMoments`] over the heights `[z0_mm, z1_mm]` in closed form: on
    /// the corner, with z = r_c (1 − cos κ), `∫ sin κ dz = r_c (κ/2 − sin 2κ/4)`,
    /// `∫ cos κ dz = r_c sin²κ / 2`, `∫ r dz = (R − r_c) z + r_c² (κ/2 − sin 2κ/4)`;
    /// on the cylinder κ = 90°.
    pub fn moments(&self, z0_mm: f64, z1_mm: f64) -> EdgeMoments {
        let (z0, z1) = (z0_mm.max(0.0), z1_mm.max(0.0));
        if z1 <= z0 {
            return EdgeMoments::default();
        }
        let (rr, rc) = (self.radius_mm, self.corner_mm);
        let mut m = EdgeMoments {
            length_mm: z1 - z0,
            ..EdgeMoments::default()
        };
        // The corner's part.
        let (c0, c1) = (z0.min(rc), z1.min(rc));
        if c1 > c0 {
            let (k0, k1) = (self.corner_kappa(c0), self.corner_kappa(c1));
            let g = |k: f64| k / 2.0 - (2.0 * k).sin() / 4.0;
            let s2 = |k: f64| k.sin().powi(2) / 2.0;
            m.sin_k_mm += rc * (g(k1) - g(k0));
            m.cos_k_mm += rc * (s2(k1) - s2(k0));
            m.radius_mm2 += (rr - rc) * (c1 - c0) + rc * rc * (g(k1) - g(k0));
        }
        // The cylinder's part.
        let (y0, y1) = (z0.max(rc), z1.max(rc));
        if y1 > y0 {
            m.sin_k_mm += y1 - y0;
            m.radius_mm2 += rr * (y1 - y0);
        }
        m
    }
}

/// The engaged arc of one height band: the edge cuts between the immersion
/// angles `phi_st_rad` and `phi_ex_rad` over the heights `[z_lo_mm, z_hi_mm]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandArc {
    /// Lowest height of the band above the tip, mm.
    pub z_lo_mm: f64,
    /// Highest height, mm.
    pub z_hi_mm: f64,
    /// Entry angle φ_st, rad (0 ≤ φ_st ≤ φ_ex ≤ π).
    pub phi_st_rad: f64,
    /// Exit angle φ_ex, rad.
    pub phi_ex_rad: f64,
}

impl BandArc {
    /// The arcs of a band over `[z_lo_mm, z_hi_mm]` whose cut columns lie at
    /// the signed offsets `[e_lo, e_hi]` (mm, to the left of the feed) from
    /// the move's line, on a grid of `cell_mm`, and whose removal is
    /// `width_mm` wide across the feed (the band's volume over its height and
    /// the step's length; MODEL.md §3.4). Each column stands for its cell, so
    /// the offsets widen by half a cell; the columns give where the cut lies,
    /// the volume how wide it is (the columns alone would move the arc's
    /// bound in jumps of a cell as the tool moves across them, and span the
    /// uncut middle where the tool leaves a slot): a range that reaches one
    /// flank (`±r`, its outermost column within three cells of it) keeps it and takes the width from there; one that reaches
    /// both is cut at both flanks, half the width each (the whole half circle
    /// at the width of a slot); one that reaches neither takes the width
    /// about its middle. The edge at the band's middle height (radius r)
    /// meets the bounds at `cos φ = e / r` (clamped: on a ball or a corner the
    /// band's outermost columns are cut above the middle). A width that is
    /// not a positive number keeps the columns' range. Empty where the band
    /// has no radius or no columns.
    pub fn from_offsets(
        shape: &EdgeShape,
        z_lo_mm: f64,
        z_hi_mm: f64,
        offsets_mm: [f64; 2],
        cell_mm: f64,
        width_mm: f64,
    ) -> [Option<BandArc>; 2] {
        let r = shape.radius_at_mm(0.5 * (z_lo_mm + z_hi_mm));
        if !(r > 0.0) || !(offsets_mm[0] <= offsets_mm[1]) {
            return [None, None];
        }
        let arc = |lo: f64, hi: f64| {
            let e = |v: f64| (v / r).clamp(-1.0, 1.0);
            Some(BandArc {
                z_lo_mm,
                z_hi_mm,
                phi_st_rad: e(hi).acos(),
                phi_ex_rad: e(lo).acos(),
            })
        };
        let (lo, hi) = (offsets_mm[0] - 0.5 * cell_mm, offsets_mm[1] + 0.5 * cell_mm);
        if !(width_mm > 0.0) {
            return [arc(lo, hi), None];
        }
        let w = width_mm.min(2.0 * r);
        // A flank is reached where the outermost column lies within three
        // cells of it (its centre can be up to a cell inside; the margin keeps
        // a column wavering near it, as the closed loop moves the tool, from
        // moving the arc between the flank and the middle: the
        // three_operations example's semi-finish took 13 sweeps at one cell,
        // 10 and an unsettled step at 1.5, 6 at three cells and at five).
        match (hi + 3.0 * cell_mm >= r, lo - 3.0 * cell_mm <= -r) {
            (true, true) => [arc(r - 0.5 * w, r), arc(-r, 0.5 * w - r)],
            (true, false) => [arc(r - w, r), None],
            (false, true) => [arc(-r, w - r), None],
            (false, false) => {
                let mid = 0.5 * (lo + hi);
                [arc(mid - 0.5 * w, mid + 0.5 * w), None]
            }
        }
    }

    /// The cut of a band whose columns reach both flanks, `width_mm` wide
    /// across the feed in all (MODEL.md §3.4): the arcs `[0, φ_a]` and
    /// `[π − φ_a, π]` over the height from the band's bottom that holds its
    /// volume, `Δz · w / (2r (1 − cos φ_a))`, with `φ_a = φ_s + s (π/2 − φ_s)`
    /// between the slivers' `φ_s = arccos(1 − w/2r)` (the band's whole
    /// height, s = 0) and a slot's π/2 (part of it, s = 1); r at the band's
    /// middle. `[None, None]` where nothing is removed.
    pub fn flanks(
        shape: &EdgeShape,
        z_lo_mm: f64,
        z_hi_mm: f64,
        width_mm: f64,
        s: f64,
    ) -> [Option<BandArc>; 2] {
        let r = shape.radius_at_mm(0.5 * (z_lo_mm + z_hi_mm));
        if !(r > 0.0 && width_mm > 0.0) {
            return [None, None];
        }
        let filled = (width_mm / (2.0 * r)).min(1.0);
        let phi_s = (1.0 - filled).acos();
        let phi_a = phi_s + s.clamp(0.0, 1.0) * (0.5 * PI - phi_s);
        let height = (z_hi_mm - z_lo_mm) * (filled / (1.0 - phi_a.cos())).min(1.0);
        let arc = |phi_st_rad: f64, phi_ex_rad: f64| {
            Some(BandArc {
                z_lo_mm,
                z_hi_mm: z_lo_mm + height,
                phi_st_rad,
                phi_ex_rad,
            })
        };
        [arc(0.0, phi_a), arc(PI - phi_a, PI)]
    }

    /// The share along the feed of the unit vectors from the tool's axis to
    /// the cut of `arcs` (of one band), weighted by the volume each removes
    /// (the chip, ∝ sin φ): `∫ sin²φ dφ / ∫ sin φ dφ` over them; π/4 for a
    /// slot, near 0 for slivers at its flanks (MODEL.md §3.4). 0 for no arc.
    pub fn forward_share(arcs: &[Option<BandArc>]) -> f64 {
        forward_share_of(arcs.iter().flatten().map(BandArc::integrals))
    }

    /// A straight cut of a cylindrical flank `ae_mm` wide into material on
    /// the left (up milling for M3: φ from 0 to arccos(1 − ae/R)) or on the
    /// right (down milling: from π − arccos(1 − ae/R) to π); `ae_mm ≥ 2R` is
    /// a slot.
    pub fn side_cut(radius_mm: f64, ae_mm: f64, z_lo_mm: f64, z_hi_mm: f64, up: bool) -> BandArc {
        let sweep = (1.0 - (ae_mm / radius_mm).min(2.0)).acos();
        let (phi_st_rad, phi_ex_rad) = if up { (0.0, sweep) } else { (PI - sweep, PI) };
        BandArc {
            z_lo_mm,
            z_hi_mm,
            phi_st_rad,
            phi_ex_rad,
        }
    }

    /// `∫ sin φ dφ`, `∫ sin²φ dφ`, `∫ sin φ cos φ dφ` over the arc.
    fn integrals(&self) -> [f64; 3] {
        let (a, b) = (self.phi_st_rad, self.phi_ex_rad);
        let ss = |p: f64| p / 2.0 - (2.0 * p).sin() / 4.0;
        let sc = |p: f64| p.sin().powi(2) / 2.0;
        [a.cos() - b.cos(), ss(b) - ss(a), sc(b) - sc(a)]
    }
}

/// The tool's teeth: their number and the helix angle of the edge.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Teeth {
    /// Number of flutes N.
    pub flutes: u32,
    /// Helix angle β, degrees (0: straight flutes).
    pub helix_deg: f64,
}

/// The cutting coefficients: the tangential force per mm² of chip `kt_mpa`
/// (Kienzle's kc at the step's mean chip), and the radial and axial force
/// as fractions of the tangential.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// Tangential force per chip area, N/mm².
    pub kt_mpa: f64,
    /// Radial over tangential force.
    pub radial_ratio: f64,
    /// Axial over tangential force.
    pub axial_ratio: f64,
}

/// Mean values over one revolution of a band's cut (feed frame, on the tool).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeanCut {
    /// Force [x (along the feed), y (its left), z (up)], N.
    pub force_n: [f64; 3],
    /// Torque about the axis, N·mm.
    pub torque_nmm: f64,
    /// Volume removed per revolution, mm³.
    pub volume_mm3: f64,
}

/// The mean force, torque and volume per revolution of a band cut at feed
/// per tooth `fz_mm` (MODEL.md eq. 3.4a):
/// `F̄ = N K_t f_z/(2π) · [−I_sc L − a I_ss, I_ss L − a I_sc, b I_s]` with
/// `I_s, I_ss, I_sc` the arc's integrals of sin φ, sin²φ, sin φ cos φ, L, S,
/// C the band's `∫dz, ∫sin κ dz, ∫cos κ dz`, `a = k_r S + k_a C`,
/// `b = k_r C − k_a S`; torque `N K_t f_z/(2π) I_s ∫r dz`, volume
/// `N f_z I_s ∫r dz`.
pub fn mean_cut(
    shape: &EdgeShape,
    flutes: u32,
    arc: &BandArc,
    fz_mm: f64,
    c: &Coefficients,
) -> MeanCut {
    ArcTerms::of(shape, arc).mean_cut(flutes, fz_mm, c)
}

/// [`BandArc::forward_share`] of arcs given by their integrals
/// (`[I_s, I_ss, I_sc]` each, in the arcs' order).
fn forward_share_of(integrals: impl Iterator<Item = [f64; 3]>) -> f64 {
    let (s, ss) = integrals.fold((0.0, 0.0), |(s, ss), [i_s, i_ss, _]| (s + i_s, ss + i_ss));
    if s > 0.0 {
        ss / s
    } else {
        0.0
    }
}

/// What [`mean_cut`] takes of an arc whatever the feed: its band's edge
/// moments ([`EdgeShape::moments`]) and the arc's integrals (`I_s, I_ss,
/// I_sc`), made once where an arc's cut is wanted at more than one feed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArcTerms {
    moments: EdgeMoments,
    integrals: [f64; 3],
}

impl ArcTerms {
    /// The terms of `arc` on the edge `shape`.
    pub(crate) fn of(shape: &EdgeShape, arc: &BandArc) -> ArcTerms {
        ArcTerms {
            moments: shape.moments(arc.z_lo_mm, arc.z_hi_mm),
            integrals: arc.integrals(),
        }
    }

    /// Each of `arcs`' terms ([`ArcTerms::of`]).
    pub(crate) fn of_each(shape: &EdgeShape, arcs: [Option<BandArc>; 2]) -> [Option<ArcTerms>; 2] {
        arcs.map(|arc| arc.map(|arc| ArcTerms::of(shape, &arc)))
    }

    /// [`BandArc::forward_share`] of the arcs whose terms are `terms`, bit for bit.
    pub(crate) fn forward_share(terms: &[Option<ArcTerms>]) -> f64 {
        forward_share_of(terms.iter().flatten().map(|t| t.integrals))
    }

    /// [`mean_cut`] of the arc at the feed per tooth `fz_mm`, bit for bit.
    pub(crate) fn mean_cut(&self, flutes: u32, fz_mm: f64, c: &Coefficients) -> MeanCut {
        let m = self.moments;
        let [i_s, i_ss, i_sc] = self.integrals;
        let n = f64::from(flutes);
        let a = c.radial_ratio * m.sin_k_mm + c.axial_ratio * m.cos_k_mm;
        let b = c.radial_ratio * m.cos_k_mm - c.axial_ratio * m.sin_k_mm;
        let k = n * c.kt_mpa * fz_mm / (2.0 * PI);
        MeanCut {
            force_n: [
                k * (-i_sc * m.length_mm - a * i_ss),
                k * (i_ss * m.length_mm - a * i_sc),
                k * b * i_s,
            ],
            torque_nmm: k * i_s * m.radius_mm2,
            volume_mm3: n * fz_mm * i_s * m.radius_mm2,
        }
    }
}

/// The force on the tool at the instant of the revolution where it is
/// largest sideways (feed frame), and the torque then.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PeakCut {
    /// Largest lateral force over the revolution, N.
    pub lateral_n: f64,
    /// The force vector at that instant [x, y, z], N.
    pub force_n: [f64; 3],
    /// Torque at that instant, N·mm.
    pub torque_nmm: f64,
    /// Tool rotation at that instant (tooth 0 at the tip), rad in [0, 2π/N).
    pub rotation_rad: f64,
}

/// Largest helix lag across one slice of edge, rad: slices are cut so the
/// lag changes by at most this much over each (MODEL.md §3.4).
const SLICE_LAG_RAD: f64 = 3.0 * PI / 180.0;
/// Slices per band at most.
const MAX_SLICES: usize = 16;
/// Widest step, in 2φ, between the points where the force's size is taken
/// inside a stretch of the revolution with the same teeth engaged.
const SAMPLE_2PHI_RAD: f64 = 5.0 * PI / 180.0;

/// sin x and cos x, by the pure Rust port of musl's `sincos` (the `libm`
/// crate): within an ulp of the system's `f64::sin_cos`, as that is of the
/// exact values, and 35–40 % quicker (5.2 against 9.0 ns for the small
/// angles of a sampling step, 9.0 against 13.4 ns over [0, 4π]: glibc saves
/// and restores the rounding mode on every call; measured on sample
/// arguments, not a bound), and not dependent on the C library. The peak's
/// sines and cosines (a slice's lag, the samples of each stretch, the
/// flanks) go through it; the edge's moments (`acos`, `sin`) and the
/// helix's `tan` still take the C library's.
#[inline]
fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// One tooth's contribution to the force's coefficients in the rotation φ
/// (tooth 0's angle at the tip): x and y are `P + Q cos 2φ + R sin 2φ`, z and
/// the torque `C cos φ + S sin φ`.
#[derive(Clone, Copy, Debug, Default)]
struct Harmonics {
    x: [f64; 3],
    y: [f64; 3],
    z: [f64; 2],
    t: [f64; 2],
}

impl Harmonics {
    fn add(&mut self, o: &Harmonics, sign: f64) {
        for i in 0..3 {
            self.x[i] += sign * o.x[i];
            self.y[i] += sign * o.y[i];
        }
        for i in 0..2 {
            self.z[i] += sign * o.z[i];
            self.t[i] += sign * o.t[i];
        }
    }

    fn lateral(&self, phi: f64) -> [f64; 2] {
        let (s2, c2) = sin_cos(2.0 * phi);
        self.lateral_cs(c2, s2)
    }

    /// [`lateral`](Self::lateral) at the rotation whose 2φ has cosine `c2`
    /// and sine `s2`.
    fn lateral_cs(&self, c2: f64, s2: f64) -> [f64; 2] {
        [
            self.x[0] + self.x[1] * c2 + self.x[2] * s2,
            self.y[0] + self.y[1] * c2 + self.y[2] * s2,
        ]
    }

    /// An upper bound of the lateral force's size at any rotation:
    /// `|P| + √(|Q|² + |R|²)` (|Q cos θ + R sin θ| ≤ √(|Q|² + |R|²) for the
    /// vectors Q = (x₁, y₁), R = (x₂, y₂)), above by a relative 1e-9 so that
    /// rounding cannot put it under a sample it bounds.
    fn lateral_bound(&self) -> f64 {
        // (√ of the sum of squares, not `hypot` (8 % of real program A's
        // loads): within an ulp of it where the squares neither overflow nor
        // underflow, far inside the 1e-9 above; `hypot` outside. The bound
        // only skips stretches none of whose samples can be the peak, so the
        // peak is the same bit for bit.)
        let p2 = self.x[0] * self.x[0] + self.y[0] * self.y[0];
        let p = if (1e-290..1e290).contains(&p2) {
            p2.sqrt()
        } else {
            self.x[0].hypot(self.y[0])
        };
        let qr = (self.x[1] * self.x[1]
            + self.y[1] * self.y[1]
            + self.x[2] * self.x[2]
            + self.y[2] * self.y[2])
            .sqrt();
        (p + qr) * (1.0 + 1e-9)
    }

    fn at(&self, phi: f64) -> ([f64; 3], f64) {
        let [x, y] = self.lateral(phi);
        let (s, c) = sin_cos(phi);
        (
            [x, y, self.z[0] * c + self.z[1] * s],
            self.t[0] * c + self.t[1] * s,
        )
    }
}

/// One slice of a band's edge: its moments, times `K_t f_z`, and its lag.
#[derive(Clone, Copy, Debug)]
struct Slice {
    /// `K_t f_z ∫dz`, `K_t f_z (k_r S + k_a C)`, `K_t f_z (k_r C − k_a S)`, `K_t f_z ∫ r dz`.
    w: [f64; 4],
    lag: f64,
    arc: [f64; 2],
}

impl Slice {
    /// The harmonics of tooth angle α = φ + c at the slice (eq. 3.4b): per unit
    /// `K_t f_z`, x `−L sin α cos α − a sin²α`, y `L sin²α − a sin α cos α`,
    /// z `b sin α`, torque `∫r dz · sin α`.
    /// (At the angle c whose cosine is `cc` and sine `sc`.)
    fn tooth_cs(&self, cc: f64, sc: f64) -> Harmonics {
        let [l, a, b, r] = self.w;
        let (s2, c2) = (2.0 * sc * cc, cc * cc - sc * sc);
        Harmonics {
            x: [
                -a / 2.0,
                -l * s2 / 2.0 + a * c2 / 2.0,
                -l * c2 / 2.0 - a * s2 / 2.0,
            ],
            y: [
                l / 2.0,
                -l * c2 / 2.0 - a * s2 / 2.0,
                l * s2 / 2.0 - a * c2 / 2.0,
            ],
            z: [b * sc, b * cc],
            t: [r * sc, r * cc],
        }
    }
}

/// Scratch space of [`peak_cut`], kept between calls so a step allocates
/// nothing once it has grown.
#[derive(Clone, Debug, Default)]
pub struct PeakScratch {
    slices: Vec<Slice>,
    /// The events, as [`Event::key`]s.
    events: Vec<u128>,
    /// Per slice and tooth j, the tooth's harmonics (`Slice::tooth` at
    /// `c_j = 2πj/N − lag`), N a slice.
    teeth: Vec<Harmonics>,
    /// Per slice and tooth j, its angle at rotation 0, `c_j` in [0, 2π).
    angles: Vec<f64>,
}

/// A tooth entering or leaving a slice's arc within one tooth period.
#[derive(Clone, Copy, Debug)]
struct Event {
    /// Rotation of tooth 0 at the tip, rad in [0, 2π/N).
    rotation: f64,
    /// Index of the slice in [`PeakScratch::slices`].
    slice: usize,
    /// A tooth enters the arc (else one leaves it).
    enters: bool,
    /// The tooth at the arc's bound at `rotation`.
    tooth: u32,
}

impl Event {
    /// The event as one integer whose order is the events' order: rotation
    /// (in `f64::total_cmp`'s order), then slice, then an entry before an
    /// exit; the tooth in the lowest bits never decides, as a slice has one
    /// entry and one exit. (Integers sort in a fraction of the time a
    /// comparison of the fields takes: the sort was 9 % of real program B's
    /// `optimize`.)
    fn key(self) -> u128 {
        let bits = self.rotation.to_bits();
        // total_cmp's order, unsigned: negatives' bits all flipped, the sign
        // bit of the rest set.
        let ordered = if bits >> 63 == 1 {
            !bits
        } else {
            bits | 1 << 63
        };
        // (31 bits of slice: at most 16 slices a band, far fewer bands.)
        debug_assert!(self.slice < 1 << 31);
        u128::from(ordered) << 64
            | (self.slice as u128) << 33
            | u128::from(!self.enters) << 32
            | u128::from(self.tooth)
    }

    /// The event of [`key`](Self::key).
    fn from_key(key: u128) -> Event {
        let ordered = (key >> 64) as u64;
        let bits = if ordered >> 63 == 1 {
            ordered & !(1 << 63)
        } else {
            !ordered
        };
        Event {
            rotation: f64::from_bits(bits),
            slice: ((key >> 33) as u64 & ((1 << 31) - 1)) as usize,
            enters: (key >> 32) & 1 == 0,
            tooth: key as u32,
        }
    }
}

/// The force through one tooth period of a step whose bands cut the arcs
/// `bands` (each with its feed per tooth: the one at which its arc removes
/// the band's volume, from [`mean_cut`]'s volume per revolution): the
/// edge of each band cut in slices whose helix lag `z tan β / R` changes by at
/// most 3°, tooth j of a slice at `α = φ + 2πj/N − z tan β / R` (MODEL.md
/// eq. 3.4b). Between the rotations where a tooth enters or leaves a slice's
/// arc the lateral force is `P + Q cos 2φ + R sin 2φ` in closed form; its size
/// is taken at both ends of each such stretch (so the jump at a tooth's
/// entry is caught exactly) and every 2.5° inside.
///
/// Also, per entry k of `flanks_n`, the lateral force [x, y] (N) at the two
/// instants a tooth at band k's mid-height `z = (k + ½)·band_height_mm`
/// passes the flanks, φ = 0 (left of the feed: up milling's wall) and φ = π
/// (right: down milling's), rotations `ψ(z)` and `π + ψ(z)`: the forces when
/// that band leaves a wall (MODEL.md §5.2). `[left, right]` per band.
pub fn peak_cut(
    shape: &EdgeShape,
    teeth: &Teeth,
    bands: &[(BandArc, f64)],
    c: &Coefficients,
    band_height_mm: f64,
    flanks_n: &mut [[[f64; 2]; 2]],
    scratch: &mut PeakScratch,
) -> PeakCut {
    let n = teeth.flutes.max(1);
    let period = 2.0 * PI / f64::from(n);
    let lag_per_mm = teeth.helix_deg.to_radians().tan() / shape.radius_mm;
    let PeakScratch {
        slices,
        events,
        teeth: harmonics,
        angles,
    } = scratch;
    slices.clear();
    events.clear();
    harmonics.clear();
    angles.clear();
    let mut sum = Harmonics::default();
    for (arc, fz) in bands {
        let span = arc.z_hi_mm - arc.z_lo_mm;
        if !(span > 0.0) || !(*fz > 0.0) || !(arc.phi_ex_rad > arc.phi_st_rad) {
            continue;
        }
        let k = ((span * lag_per_mm.abs() / SLICE_LAG_RAD).ceil() as usize).clamp(1, MAX_SLICES);
        let dz = span / k as f64;
        let kf = c.kt_mpa * fz;
        for i in 0..k {
            let (z0, z1) = (
                arc.z_lo_mm + i as f64 * dz,
                arc.z_lo_mm + (i + 1) as f64 * dz,
            );
            let m = shape.moments(z0, z1);
            let a = c.radial_ratio * m.sin_k_mm + c.axial_ratio * m.cos_k_mm;
            let b = c.radial_ratio * m.cos_k_mm - c.axial_ratio * m.sin_k_mm;
            slices.push(Slice {
                w: [kf * m.length_mm, kf * a, kf * b, kf * m.radius_mm2],
                lag: 0.5 * (z0 + z1) * lag_per_mm,
                arc: [arc.phi_st_rad, arc.phi_ex_rad],
            });
        }
    }
    // Each slice's teeth: c_j = j·period − lag, their harmonics by rotation
    // (one sin_cos a slice) and their angles in [0, 2π).
    let (sp, cp) = sin_cos(period);
    for s in slices.iter() {
        let (mut sc, mut cc) = sin_cos(-s.lag);
        for _ in 0..n {
            harmonics.push(s.tooth_cs(cc, sc));
            (sc, cc) = (sc * cp + cc * sp, cc * cp - sc * sp);
        }
        angles.extend((0..n).map(|j| rem_euclid(f64::from(j) * period - s.lag, 2.0 * PI)));
    }
    let engaged = Engaged {
        slices,
        harmonics,
        angles,
        flutes: n,
    };
    let nu = n as usize;
    for (si, s) in slices.iter().enumerate() {
        // The rotations in [0, period) where a tooth enters (α = φ_st) and
        // one leaves (α = φ_ex): α = rotation + c_j, so j is the whole
        // number of periods in bound + lag − rotation.
        for (bound, enters) in [(s.arc[0], true), (s.arc[1], false)] {
            let rotation = rem_euclid(bound + s.lag, period);
            let q = ((bound + s.lag - rotation) / period).round() as i64;
            events.push(
                Event {
                    rotation,
                    slice: si,
                    enters,
                    // (Nearly always a whole period or none: no division.)
                    tooth: q.rem_euclid(i64::from(n)) as u32,
                }
                .key(),
            );
        }
    }
    // In rotation, ties in the order the events were listed (slice by slice,
    // each slice's entry before its exit): the order of a stable sort,
    // without its scratch.
    events.sort_unstable();
    let mut best = PeakCut::default();
    // With an even number of teeth half a revolution is a whole number of
    // tooth periods: as one tooth passes the left flank another passes the
    // right, so the two instants are one (the force the same, but for
    // rounding, and but where a tooth lies exactly on an arc's bound inside
    // the revolution, where the force jumps: there the two sums may hold the
    // tooth on different sides of the jump; test
    // `flanks_are_the_force_at_their_instants`).
    let flanks_at_once = n.is_multiple_of(2);
    for (k, flank) in flanks_n.iter_mut().enumerate() {
        let lag = (k as f64 + 0.5) * band_height_mm * lag_per_mm;
        let left = engaged.at(lag).lateral(lag);
        let right = if flanks_at_once {
            left
        } else {
            engaged.at(PI + lag).lateral(PI + lag)
        };
        *flank = [left, right];
    }
    let m = events.len();
    if m == 0 {
        return best;
    }
    // Start in the longest stretch between events (r_i0, r_i0+1): the teeth
    // engaged at its middle, found afresh (far from every arc's bound, so
    // rounding cannot disagree with the events); then the events in turn,
    // once round.
    // (Events i in [0, 2m): the second time round one period on. The
    // longest stretch, the last of equals, as `Iterator::max_by` finds it.)
    let event = |i: usize| Event::from_key(events[if i >= m { i - m } else { i }]);
    let at = |i: usize| event(i).rotation + if i >= m { period } else { 0.0 };
    let (mut i0, mut longest) = (0, at(1) - at(0));
    for a in 1..m {
        let gap = at(a + 1) - at(a);
        if longest.total_cmp(&gap).is_le() {
            (i0, longest) = (a, gap);
        }
    }
    let mid = 0.5 * (at(i0) + at(i0 + 1));
    sum.add(&engaged.at(mid), 1.0);
    // The largest squared lateral force so far, and where: the rotation and
    // the teeth engaged there (their force and torque made once, at the end,
    // from the same sum at the same rotation).
    let mut best_sq = 0.0;
    let mut best_at: Option<(Harmonics, f64)> = None;
    // sin and cos of 2φ, exact, at the end of the stretch before where it
    // was sampled in one step (none otherwise): this stretch's start, the
    // same rotation (the same bits).
    let mut end_sc: Option<(f64, f64)> = None;
    for k in 0..m {
        // The stretch [from, to] with the same teeth engaged, then the event at `to`.
        let (from, to) = (at(i0 + k), at(i0 + k + 1));
        let start_sc = end_sc.take();
        // No sample of a stretch can beat the best so far where its bound
        // does not (the same peak, for less work).
        if sum.lateral_bound() > best.lateral_n {
            let mut sample = |s2: f64, c2: f64, phi: f64| {
                let [x, y] = sum.lateral_cs(c2, s2);
                let q = x * x + y * y;
                if q > best_sq {
                    best_sq = q;
                    best.lateral_n = q.sqrt();
                    best_at = Some((sum, phi));
                }
            };
            let steps = ((2.0 * (to - from) / SAMPLE_2PHI_RAD).ceil() as usize).max(1);
            let d_phi = (to - from) / steps as f64;
            // 2φ of the samples by rotation from the stretch's start (one
            // sin_cos a stretch, not one a sample), but at the end of a
            // stretch of one step exact: that end is the next stretch's
            // start, so stretches of one step sampled in a row cost one
            // sin_cos each.
            let (mut s2, mut c2) = start_sc.unwrap_or_else(|| sin_cos(2.0 * from));
            sample(s2, c2, from);
            if steps == 1 {
                let (s2, c2) = sin_cos(2.0 * to);
                sample(s2, c2, to);
                end_sc = Some((s2, c2));
            } else {
                let (ds, dc) = sin_cos(2.0 * d_phi);
                for i in 1..=steps {
                    (s2, c2) = (s2 * dc + c2 * ds, c2 * dc - s2 * ds);
                    sample(s2, c2, from + d_phi * i as f64);
                }
            }
        }
        let Event {
            slice: si,
            enters: enter,
            tooth: j,
            ..
        } = event(i0 + k + 1);
        // The tooth at the arc's bound at this rotation (one period on, the
        // tooth before it).
        let j = match (j as usize, i0 + k + 1 >= m) {
            (j, false) => j,
            (0, true) => nu - 1,
            (j, true) => j - 1,
        };
        sum.add(&harmonics[si * nu + j], if enter { 1.0 } else { -1.0 });
    }
    if let Some((teeth, phi)) = best_at {
        (best.force_n, best.torque_nmm) = teeth.at(phi);
        best.rotation_rad = rem_euclid(phi, period);
    }
    best
}

/// Upper bounds of [`peak_cut`]'s lateral force and of the size of its
/// torque for the same `bands` (MODEL.md §3.4, "A bound on the peak"), at
/// the cost of one [`EdgeShape::moments`] a band: no slices, events or
/// samples. By eq. 3.4b a tooth at α on a slice of weights `l = K_t f_z ∫dz`,
/// `a = K_t f_z (k_r S + k_a C)` pushes the tool sideways by
/// `sin α √(l² + a²) ≤ sin α (l + |a|)` and turns it by `sin α K_t f_z ∫r dz`,
/// so a slice's teeth in its arcs give at most `Σ sin α` ([`teeth_sines`])
/// times those weights; summed over the slices the moments are the band's
/// (S, C ≥ 0 on every edge). Above by a relative 1e-9, so that rounding
/// cannot put a bound under the sum it bounds.
pub fn peak_bound(
    shape: &EdgeShape,
    teeth: &Teeth,
    bands: &[(BandArc, f64)],
    c: &Coefficients,
) -> PeakBound {
    let n = teeth.flutes.max(1);
    let period = 2.0 * PI / f64::from(n);
    let mut bound = PeakBound::default();
    // The arcs of one band (the same heights and feed: listed together, as
    // a slot's or slivers' two flanks are) cut one slice's teeth: their sines
    // are bounded arc by arc, or over the arcs' hull where that is less (a
    // tooth is in one flank's arc or the other's, not in both).
    let mut rest = bands;
    while let Some(((first, fz), _)) = rest.split_first() {
        let same = |(a, f): &(BandArc, f64)| {
            (a.z_lo_mm, a.z_hi_mm, *f) == (first.z_lo_mm, first.z_hi_mm, *fz)
        };
        let len = rest.iter().take_while(|b| same(b)).count();
        let (band, after) = rest.split_at(len);
        rest = after;
        // (The bands `peak_cut` slices.)
        let span = first.z_hi_mm - first.z_lo_mm;
        if !(span > 0.0) || !(*fz > 0.0) {
            continue;
        }
        let arcs = || {
            band.iter()
                .map(|(a, _)| (a.phi_st_rad, a.phi_ex_rad))
                .filter(|(st, ex)| ex > st)
        };
        let Some(hull) = arcs().reduce(|(a, b), (c, d)| (a.min(c), b.max(d))) else {
            continue;
        };
        let apart: f64 = arcs().map(|(st, ex)| teeth_sines(st, ex, period, n)).sum();
        // (Arcs that overlap count a tooth in both, as `peak_cut` does: the
        // hull only over arcs apart, as a band's flanks are.)
        let overlap = arcs()
            .enumerate()
            .any(|(i, (a, b))| arcs().skip(i + 1).any(|(c, d)| c < b && a < d));
        let sines = if overlap {
            apart
        } else {
            apart.min(teeth_sines(hull.0, hull.1, period, n))
        };
        let m = shape.moments(first.z_lo_mm, first.z_hi_mm);
        let w = sines * (c.kt_mpa * fz).abs();
        bound.lateral_n += w
            * (m.length_mm
                + c.radial_ratio.abs() * m.sin_k_mm.abs()
                + c.axial_ratio.abs() * m.cos_k_mm.abs());
        bound.torque_nmm += w * m.radius_mm2.abs();
    }
    if let Some(h) = helix_bound(shape, teeth, bands, c) {
        bound.lateral_n = bound.lateral_n.min(h.lateral_n);
        bound.torque_nmm = bound.torque_nmm.min(h.torque_nmm);
    }
    PeakBound {
        lateral_n: bound.lateral_n * (1.0 + 1e-9),
        torque_nmm: bound.torque_nmm * (1.0 + 1e-9),
    }
}

/// [`peak_bound`] of a helical edge over all its bands at once: the teeth
/// of bands at different heights lag one another, so that the bands are
/// not all engaged at the rotation where each is most (a Ø2 ball 6 mm
/// deep at 30° lags 198° over the cut). With `λ = tan β / R` the lag per mm,
/// tooth j at height z sits at `α = φ + c_j − λ z`, and a slice counts as
/// engaged where the α of its middle lies in its band's arc, inside the
/// arcs' hull H. Per mm of edge a tooth pushes by at most
/// `K_t f_z (1 + √(k_r² + k_a²)) sin α` (|k_r sin κ + k_a cos κ| ≤ √(k_r² + k_a²)) and
/// turns by `K_t f_z R sin α`. At one rotation the heights where one tooth's
/// α lies in H are one interval of `|H| / |λ|` (of every tooth and turn,
/// at most `⌊(Z|λ| + |H|) / (2π/N)⌋ + 1` such intervals over the cut's Z), and
/// the slices' middles there sum `sin α dz` to at most
/// `(∫ |sin α| dα over H widened by half a slice's lag Δα each side + (|H| + Δα) Δα² / 24) / |λ|`
/// (the midpoint rule on a function of |second derivative| ≤ 1). `None`
/// for straight flutes, where no band lags another, or arcs outside [0, π].
fn helix_bound(
    shape: &EdgeShape,
    teeth: &Teeth,
    bands: &[(BandArc, f64)],
    c: &Coefficients,
) -> Option<PeakBound> {
    let lag = (teeth.helix_deg.to_radians().tan() / shape.radius_mm).abs();
    if !(lag > 0.0 && lag.is_finite()) {
        return None;
    }
    // The bands `peak_cut` slices: their arcs' hull, heights, largest
    // K_t f_z and largest slice (in lag), as it slices them.
    let (mut hull, mut z, mut kf, mut slice_lag) =
        ([PI, 0.0], [f64::INFINITY, 0.0], 0.0f64, 0.0f64);
    for (arc, fz) in bands {
        let span = arc.z_hi_mm - arc.z_lo_mm;
        if !(span > 0.0) || !(*fz > 0.0) || !(arc.phi_ex_rad > arc.phi_st_rad) {
            continue;
        }
        if !(arc.phi_st_rad >= 0.0 && arc.phi_ex_rad <= PI) {
            return None;
        }
        hull = [hull[0].min(arc.phi_st_rad), hull[1].max(arc.phi_ex_rad)];
        z = [z[0].min(arc.z_lo_mm), z[1].max(arc.z_hi_mm)];
        kf = kf.max((c.kt_mpa * fz).abs());
        let k = ((span * lag / SLICE_LAG_RAD).ceil() as usize).clamp(1, MAX_SLICES);
        slice_lag = slice_lag.max(span / k as f64 * lag);
    }
    if !(hull[1] > hull[0]) {
        return Some(PeakBound::default());
    }
    let width = hull[1] - hull[0];
    let period = 2.0 * PI / f64::from(teeth.flutes.max(1));
    let intervals = (((z[1] - z[0]) * lag + width) / period).floor() + 1.0;
    let half = 0.5 * slice_lag;
    let (a, b) = ((hull[0] - half).max(0.0), (hull[1] + half).min(PI));
    // ∫|sin| over the widened hull: inside [0, π] in closed form, at most
    // half a slice's lag (|sin α| ≤ Δα/2 there) on each side outside.
    let sines =
        (a.cos() - b.cos()) + slice_lag + (width + slice_lag) * slice_lag * slice_lag / 24.0;
    let per_mm = intervals * sines / lag;
    Some(PeakBound {
        lateral_n: kf * (1.0 + c.radial_ratio.hypot(c.axial_ratio)) * per_mm,
        torque_nmm: kf * shape.radius_mm * per_mm,
    })
}

/// What [`peak_bound`] bounds: [`PeakCut::lateral_n`] and the size of
/// [`PeakCut::torque_nmm`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PeakBound {
    /// N.
    pub lateral_n: f64,
    /// N·mm.
    pub torque_nmm: f64,
}

/// An upper bound of `Σ sin α` over the teeth of one slice (N of them,
/// `period` apart) inside the arc `[st, ex)` at any rotation: at most
/// `⌈(ex − st) / period⌉` of them, each at sin α no more than its largest on
/// the arc, and where that width is a whole number of periods (a slot's
/// [0, π] and two flutes) one more at its ends, as a tooth leaves when the
/// next enters; sin α to 10⁻¹² above (the teeth's angles are rounded).
fn teeth_sines(st: f64, ex: f64, period: f64, n: u32) -> f64 {
    let (q, n) = ((ex - st) / period, f64::from(n));
    let inside = (q - 1e-9).ceil().clamp(1.0, n);
    let at_ends = if (q + 1e-9).floor() + 1.0 > inside && inside < n {
        st.sin().abs().max(ex.sin().abs()) + 1e-12
    } else {
        0.0
    };
    inside * (largest_sin(st, ex) + 1e-12).min(1.0) + at_ends
}

/// The largest |sin α| for α in `[a, b]` (a ≤ b): 1 where the interval holds
/// an odd multiple of π/2, else at one of its ends (|sin| is monotone
/// between those multiples).
fn largest_sin(a: f64, b: f64) -> f64 {
    let k = ((a - 0.5 * PI) / PI).ceil();
    if 0.5 * PI + k * PI <= b {
        1.0
    } else {
        a.sin().abs().max(b.sin().abs())
    }
}

/// `x.rem_euclid(p)` bit for bit (p > 0), without the division's remainder
/// where x lies within (−p, 2p): there `x % p` is x, or x − p (exact by
/// Sterbenz's lemma), and a negative x gets p added as `rem_euclid` adds it.
#[inline]
fn rem_euclid(x: f64, p: f64) -> f64 {
    if x >= 0.0 {
        if x < p {
            return x;
        }
        if x < 2.0 * p {
            return x - p;
        }
    } else if x > -p {
        return x + p;
    }
    x.rem_euclid(p)
}

/// The slices' teeth of a [`peak_cut`]: their harmonics
/// ([`PeakScratch::teeth`]) and angles at rotation 0
/// ([`PeakScratch::angles`]).
struct Engaged<'a> {
    slices: &'a [Slice],
    harmonics: &'a [Harmonics],
    angles: &'a [f64],
    flutes: u32,
}

impl Engaged<'_> {
    /// The harmonics of the teeth engaged at the rotation `phi` (tooth j of
    /// a slice at `α = φ + c_j`, engaged on `[φ_st, φ_ex)`), summed (eq. 3.4b).
    fn at(&self, phi: f64) -> Harmonics {
        let tau = 2.0 * PI;
        let phi = rem_euclid(phi, tau);
        let n = self.flutes as usize;
        let mut sum = Harmonics::default();
        for (si, s) in self.slices.iter().enumerate() {
            for j in 0..n {
                let mut alpha = self.angles[si * n + j] + phi;
                if alpha >= tau {
                    alpha -= tau;
                }
                if alpha >= s.arc[0] && alpha < s.arc[1] {
                    sum.add(&self.harmonics[si * n + j], 1.0);
                }
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: Coefficients = Coefficients {
        kt_mpa: 2000.0,
        radial_ratio: 0.3,
        axial_ratio: 0.25,
    };

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-12)
    }

    /// Events sorted by their keys come in the order of their fields
    /// compared (rotation by `total_cmp`, slice, an entry first), and each
    /// key gives its event back bit for bit: signed zeros, ties in rotation
    /// and slice, the period's ends, infinities and NaN.
    #[test]
    fn event_keys_sort_as_the_events_do() {
        let rotations = [
            0.0,
            -0.0,
            1e-300,
            0.5,
            0.5 + f64::EPSILON,
            PI - 1e-16,
            PI,
            -1e-9,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        let mut events = Vec::new();
        for (i, &rotation) in rotations.iter().enumerate() {
            for slice in [0, 3, 7, (1 << 31) - 1] {
                for enters in [true, false] {
                    let tooth = if i == 4 {
                        u32::MAX
                    } else {
                        (i as u32 * 7 + slice as u32) % 5
                    };
                    events.push(Event {
                        rotation,
                        slice,
                        enters,
                        tooth,
                    });
                }
            }
        }
        // A shuffle that is the same on every run.
        let len = events.len();
        for i in 0..len {
            events.swap(i, (i * 37 + 11) % len);
        }
        for e in &events {
            let back = Event::from_key(e.key());
            assert_eq!(
                (back.rotation.to_bits(), back.slice, back.enters, back.tooth),
                (e.rotation.to_bits(), e.slice, e.enters, e.tooth)
            );
        }
        let mut by_fields = events.clone();
        by_fields.sort_by(|a, b| {
            a.rotation
                .total_cmp(&b.rotation)
                .then(a.slice.cmp(&b.slice))
                .then(b.enters.cmp(&a.enters))
        });
        let mut keys: Vec<u128> = events.iter().map(|e| e.key()).collect();
        keys.sort_unstable();
        let by_keys: Vec<Event> = keys.into_iter().map(Event::from_key).collect();
        for (a, b) in by_fields.iter().zip(&by_keys) {
            assert_eq!(
                (a.rotation.to_bits(), a.slice, a.enters),
                (b.rotation.to_bits(), b.slice, b.enters)
            );
        }
    }

    #[test]
    fn rem_euclid_is_the_standard_one_bit_for_bit() {
        for p in [2.0 * PI, PI, 2.0 * PI / 3.0, 0.5] {
            let edges = [
                -p,
                -p * (1.0 - f64::EPSILON),
                -1e-300,
                -0.0,
                0.0,
                1e-300,
                p * (1.0 - f64::EPSILON),
                p,
                2.0 * p * (1.0 - f64::EPSILON),
                2.0 * p,
                -2.0 * p,
                7.5 * p,
                -7.5 * p,
                f64::NAN,
                f64::INFINITY,
            ];
            let grid = (-400..=400).map(|i| f64::from(i) * p / 97.3);
            for x in edges.into_iter().chain(grid) {
                let (ours, std) = (rem_euclid(x, p), x.rem_euclid(p));
                assert!(
                    ours.to_bits() == std.to_bits() || ours.is_nan() && std.is_nan(),
                    "{x} mod {p}: {ours} against {std}"
                );
            }
        }
    }

    #[test]
    fn lateral_bound_is_above_every_rotation() {
        // Harmonics of a few teeth at arbitrary angles and coefficients.
        let slice = Slice {
            w: [3.0, 0.7, -0.2, 4.0],
            lag: 0.1,
            arc: [0.0, PI],
        };
        let mut h = Harmonics::default();
        for (k, c) in [0.3, 1.9, 2.6, 4.4].into_iter().enumerate() {
            let (sc, cc) = f64::sin_cos(c);
            h.add(&slice.tooth_cs(cc, sc), if k == 2 { -0.5 } else { 1.0 });
            let bound = h.lateral_bound();
            let peak = (0..3600)
                .map(|i| {
                    let [x, y] = h.lateral(f64::from(i) * PI / 3600.0);
                    x.hypot(y)
                })
                .fold(0.0, f64::max);
            assert!(peak <= bound && bound < 2.0 * peak, "{peak} {bound}");
        }
    }

    #[test]
    fn moments_of_a_ball_and_a_flat() {
        let ball = EdgeShape::ball(5.0);
        // Up to the equator: ∫ sin κ dz = R π/4, ∫ cos κ dz = R/2, ∫ r dz = R² π/4.
        let m = ball.moments(0.0, 5.0);
        assert!(close(m.sin_k_mm, 5.0 * PI / 4.0, 1e-12));
        assert!(close(m.cos_k_mm, 2.5, 1e-12));
        assert!(close(m.radius_mm2, 25.0 * PI / 4.0, 1e-12));
        // Additive over heights.
        let (a, b) = (ball.moments(0.0, 1.7), ball.moments(1.7, 7.0));
        let w = ball.moments(0.0, 7.0);
        assert!(close(a.sin_k_mm + b.sin_k_mm, w.sin_k_mm, 1e-12));
        assert!(close(a.radius_mm2 + b.radius_mm2, w.radius_mm2, 1e-12));
        let flat = EdgeShape::flat(5.0).moments(0.5, 2.5);
        assert_eq!(
            (flat.sin_k_mm, flat.cos_k_mm, flat.radius_mm2),
            (2.0, 0.0, 10.0)
        );
    }

    /// The closed forms for a ball slot, mc = 0, feed +X, M3:
    /// κ₀ = arccos(1 − ap/R); Fy = N K_t f_z a_p/4;
    /// Fx = −N K_t f_z R/4 [k_r(κ₀/2 − sin 2κ₀/4) + k_a sin²κ₀/2];
    /// Fz = N K_t f_z R/π [k_r sin²κ₀/2 − k_a(κ₀/2 − sin 2κ₀/4)]; P = K_t A v_f.
    #[test]
    fn ball_slot_matches_the_closed_forms() {
        let (r, n, fz) = (5.0, 2u32, 0.05);
        let nf = f64::from(n);
        for ap in [1.0, 3.0, 5.0] {
            let k0 = (1.0f64 - ap / r).acos();
            let g = k0 / 2.0 - (2.0 * k0).sin() / 4.0;
            let s2 = k0.sin().powi(2) / 2.0;
            let arc = BandArc {
                z_lo_mm: 0.0,
                z_hi_mm: ap,
                phi_st_rad: 0.0,
                phi_ex_rad: PI,
            };
            let m = mean_cut(&EdgeShape::ball(r), n, &arc, fz, &C);
            let kt = C.kt_mpa;
            let fx = -nf * kt * fz * r / 4.0 * (C.radial_ratio * g + C.axial_ratio * s2);
            let fy = nf * kt * fz * ap / 4.0;
            let fzz = nf * kt * fz * r / PI * (C.radial_ratio * s2 - C.axial_ratio * g);
            assert!(
                close(m.force_n[0], fx, 1e-12),
                "ap {ap}: {:?} {fx}",
                m.force_n
            );
            assert!(close(m.force_n[1], fy, 1e-12));
            assert!(close(m.force_n[2], fzz, 1e-12));
            // Volume per revolution = slot cross-section × feed per revolution:
            // A = R² (κ₀ − sin κ₀ cos κ₀)… for a ball slot of depth ap,
            // A = R² k₀ − (R − ap) √(ap (2R − ap)).
            let area = r * r * k0 - (r - ap) * (ap * (2.0 * r - ap)).sqrt();
            assert!(close(m.volume_mm3, area * nf * fz, 1e-12));
            // Energy per revolution = K_t × volume (P = K_t A v_f).
            assert!(close(2.0 * PI * m.torque_nmm, kt * m.volume_mm3, 1e-12));
        }
    }

    /// A flat full slot: mean torque K_t a_p f_z N D/(2π), Fy = N K_t f_z a_p/4,
    /// Fx = −k_r Fy, Fz = −k_a N K_t f_z a_p/π.
    #[test]
    fn flat_slot_matches_the_closed_forms() {
        let (r, ap, fz, n) = (5.0, 2.0, 0.1, 4u32);
        let nf = f64::from(n);
        let arc = BandArc::side_cut(r, 2.0 * r, 0.0, ap, true);
        let m = mean_cut(&EdgeShape::flat(r), n, &arc, fz, &C);
        let kt = C.kt_mpa;
        let fy = nf * kt * fz * ap / 4.0;
        assert!(close(m.force_n[1], fy, 1e-12));
        assert!(close(m.force_n[0], -C.radial_ratio * fy, 1e-12));
        assert!(close(
            m.force_n[2],
            -C.axial_ratio * nf * kt * fz * ap / PI,
            1e-12
        ));
        assert!(close(
            m.torque_nmm,
            kt * ap * fz * nf * 2.0 * r / (2.0 * PI),
            1e-12
        ));
    }

    /// Flat side cuts against Altintas' mean forces (*Manufacturing Automation*
    /// eq. 2.x, the same instantaneous forces integrated over the arc):
    /// `F̄x = N a f_z/(8π) [K_t cos 2φ − K_r (2φ − sin 2φ)]`,
    /// `F̄y = N a f_z/(8π) [K_t (2φ − sin 2φ) + K_r cos 2φ]` from φ_st to φ_ex;
    /// and at small immersion the wall pushes the tool away from the material.
    #[test]
    fn flat_side_cuts_match_altintas() {
        let (r, ap, fz, n) = (5.0, 2.0, 0.1, 3u32);
        let nf = f64::from(n);
        let kt = C.kt_mpa;
        let kr = C.radial_ratio;
        for (ae, up) in [
            (1.0, true),
            (1.0, false),
            (5.0, true),
            (5.0, false),
            (0.2, true),
            (0.2, false),
        ] {
            let arc = BandArc::side_cut(r, ae, 0.0, ap, up);
            let m = mean_cut(&EdgeShape::flat(r), n, &arc, fz, &C);
            let k = nf * ap * fz / (8.0 * PI);
            let fx = |p: f64| kt * (2.0 * p).cos() - kt * kr * (2.0 * p - (2.0 * p).sin());
            let fy = |p: f64| kt * (2.0 * p - (2.0 * p).sin()) + kt * kr * (2.0 * p).cos();
            let (a, b) = (arc.phi_st_rad, arc.phi_ex_rad);
            let (ax, ay) = (k * (fx(b) - fx(a)), k * (fy(b) - fy(a)));
            assert!(
                close(m.force_n[0], ax, 1e-12),
                "ae {ae} up {up}: {:?} {ax}",
                m.force_n
            );
            assert!(
                close(m.force_n[1], ay, 1e-12),
                "ae {ae} up {up}: {:?} {ay}",
                m.force_n
            );
            if ae <= 0.2 {
                // A wall finish: material on the left (up milling) pushes the
                // tool right (−y), on the right left (+y).
                assert_eq!(m.force_n[1] < 0.0, up, "ae {ae} up {up}: {:?}", m.force_n);
            }
        }
    }

    /// One straight tooth in a flat slot (N = 2, β = 0: one tooth engaged at a
    /// time): the peak is at φ = π/2, `K_t a_p f_z √(1 + k_r²)`.
    #[test]
    fn peak_of_a_straight_two_flute_slot() {
        let (r, ap, fz) = (5.0, 2.0, 0.1);
        let teeth = Teeth {
            flutes: 2,
            helix_deg: 0.0,
        };
        let arc = BandArc::side_cut(r, 2.0 * r, 0.0, ap, true);
        let mut flanks = [[[f64::NAN; 2]; 2]; 2];
        let p = peak_cut(
            &EdgeShape::flat(r),
            &teeth,
            &[(arc, fz)],
            &C,
            1.0,
            &mut flanks,
            &mut PeakScratch::default(),
        );
        let want = C.kt_mpa * ap * fz * (1.0 + C.radial_ratio.powi(2)).sqrt();
        // Straight teeth at the flanks cut nothing (h = f_z sin φ = 0 there)
        // and the other tooth is out of the slot: no force, at either
        // band's height.
        for [left, right] in flanks {
            assert_eq!(left, [0.0, 0.0]);
            assert!(right[0].abs() < 1e-9 && right[1].abs() < 1e-9, "{right:?}");
        }
        assert!(close(p.lateral_n, want, 1e-9), "{p:?} {want}");
        assert!(close(p.rotation_rad, PI / 2.0, 1e-9), "{p:?}");
        assert!(
            close(p.force_n[2], -C.axial_ratio * C.kt_mpa * ap * fz, 1e-9),
            "{p:?}"
        );
    }

    /// The forces at the flanks are the forces at their instants, rotations
    /// `ψ(z)` and `π + ψ(z)` at each band's mid-height, summed tooth by tooth
    /// (`force_at`), for one to four flutes, straight and helical, on a ball
    /// cutting slivers, part of a slot and a whole slot: with an even number
    /// of flutes the right flank's, taken as the left's, too.
    #[test]
    fn flanks_are_the_force_at_their_instants() {
        let shape = EdgeShape::ball(3.0);
        let mut scratch = PeakScratch::default();
        let mut checked = 0;
        for flutes in [1, 2, 3, 4] {
            for helix_deg in [0.0, 30.0] {
                let teeth = Teeth { flutes, helix_deg };
                for (st, ex) in [(0.0, 0.6), (0.4, 2.5), (2.2, PI), (0.0, PI)] {
                    let bands: Vec<(BandArc, f64)> = (0..3)
                        .map(|k| {
                            let z = 0.5 * k as f64;
                            let arc = BandArc {
                                z_lo_mm: z,
                                z_hi_mm: z + 0.5,
                                phi_st_rad: st,
                                phi_ex_rad: ex,
                            };
                            (arc, 0.03)
                        })
                        .collect();
                    let mut flanks = [[[f64::NAN; 2]; 2]; 3];
                    let p = peak_cut(&shape, &teeth, &bands, &C, 0.5, &mut flanks, &mut scratch);
                    let lag_per_mm = helix_deg.to_radians().tan() / shape.radius_mm;
                    for (k, [left, right]) in flanks.into_iter().enumerate() {
                        let lag = (k as f64 + 0.5) * 0.5 * lag_per_mm;
                        for (got, phi) in [(left, lag), (right, PI + lag)] {
                            let want = force_at(&shape, &teeth, &bands, &C, phi);
                            assert!(
                                (got[0] - want[0]).hypot(got[1] - want[1]) <= 1e-9 * p.lateral_n,
                                "{teeth:?} [{st}, {ex}] band {k} at {phi}: {got:?} against {want:?}"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(checked, 4 * 2 * 4 * 3 * 2);
    }

    /// `peak_bound` is above `peak_cut`'s lateral force and torque on every
    /// edge, helix, flute count and set of arcs tried (a grid of arcs from
    /// slivers at either flank to whole slots, over one to three bands, with
    /// feeds differing per band), and within √2 of it on the straight
    /// two-flute slot, where `(1 + k_r) / √(1 + k_r²)` is its ratio.
    #[test]
    fn peak_bound_is_above_the_peak_and_near_it_in_a_slot() {
        let mut scratch = PeakScratch::default();
        let mut flanks = [[[0.0; 2]; 2]; 3];
        let mut tried = 0;
        let mut tightest: f64 = f64::INFINITY;
        for shape in [
            EdgeShape::ball(1.0),
            EdgeShape::ball(5.0),
            EdgeShape::flat(3.0),
            EdgeShape {
                radius_mm: 4.0,
                corner_mm: 1.0,
            },
        ] {
            for flutes in [1, 2, 3, 4] {
                for helix_deg in [0.0, 30.0, 45.0] {
                    let teeth = Teeth { flutes, helix_deg };
                    for (i, st) in [0.0, 0.3, 1.2, PI / 2.0, 2.0, 2.9].into_iter().enumerate() {
                        for width in [0.05, 0.5, 1.4, PI] {
                            let ex = (st + width).min(PI);
                            let bands: Vec<(BandArc, f64)> = (0..1 + i % 3)
                                .map(|k| {
                                    let z = 0.7 * k as f64;
                                    let arc = BandArc {
                                        z_lo_mm: z,
                                        z_hi_mm: z + 0.7,
                                        phi_st_rad: (st - 0.2 * k as f64).max(0.0),
                                        phi_ex_rad: ex,
                                    };
                                    (arc, 0.02 + 0.03 * k as f64)
                                })
                                .collect();
                            let p = peak_cut(
                                &shape,
                                &teeth,
                                &bands,
                                &C,
                                0.7,
                                &mut flanks[..bands.len()],
                                &mut scratch,
                            );
                            let b = peak_bound(&shape, &teeth, &bands, &C);
                            assert!(
                                p.lateral_n <= b.lateral_n && p.torque_nmm.abs() <= b.torque_nmm,
                                "{shape:?} {teeth:?} {bands:?}: {p:?} above {b:?}"
                            );
                            tried += 1;
                            if p.lateral_n > 0.0 {
                                tightest = tightest.min(b.lateral_n / p.lateral_n);
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(tried, 4 * 4 * 3 * 6 * 4);
        // A Ø2 ball 6 mm deep (real program A's side cuts: 1 mm bands, the
        // helix lags 198° over the cut): the bound over all bands at once is
        // within 3 times the peak (two flutes), every band's at its most is not.
        let shape = EdgeShape::ball(1.0);
        for flutes in [2, 3, 4] {
            for helix_deg in [30.0, 45.0, -30.0] {
                let teeth = Teeth { flutes, helix_deg };
                for (st, ex) in [(0.0, 1.05), (2.06, PI), (0.4, 1.9)] {
                    let bands: Vec<(BandArc, f64)> = (0..6)
                        .map(|k| {
                            let arc = BandArc {
                                z_lo_mm: k as f64,
                                z_hi_mm: k as f64 + 1.0,
                                phi_st_rad: st + 0.01 * k as f64,
                                phi_ex_rad: ex - 0.02 * k as f64,
                            };
                            (arc, 0.015 + 0.001 * k as f64)
                        })
                        .collect();
                    let p = peak_cut(&shape, &teeth, &bands, &C, 1.0, &mut [], &mut scratch);
                    let b = peak_bound(&shape, &teeth, &bands, &C);
                    assert!(
                        p.lateral_n <= b.lateral_n && p.torque_nmm.abs() <= b.torque_nmm,
                        "{teeth:?} {st} {ex}: {p:?} above {b:?}"
                    );
                    if flutes == 2 {
                        assert!(
                            b.lateral_n < 3.0 * p.lateral_n,
                            "{teeth:?} {st} {ex}: {b:?} {p:?}"
                        );
                    }
                }
            }
        }
        // One band's two flanks (slivers to a slot), bounded together; and
        // two arcs of one band that overlap (beyond π/2, or one slot twice),
        // whose teeth `peak_cut` counts in both.
        for flutes in [1, 2, 3, 4, 6] {
            let teeth = Teeth {
                flutes,
                helix_deg: 30.0,
            };
            for phi in [0.1, 0.7, PI / 3.0, PI / 2.0, 2.0, 2.8, PI] {
                let flank = |st: f64, ex: f64| {
                    let arc = BandArc {
                        z_lo_mm: 0.5,
                        z_hi_mm: 1.5,
                        phi_st_rad: st,
                        phi_ex_rad: ex,
                    };
                    (arc, 0.05)
                };
                let bands = [flank(0.0, phi), flank(PI - phi, PI)];
                let shape = EdgeShape::ball(3.0);
                let p = peak_cut(&shape, &teeth, &bands, &C, 1.0, &mut [], &mut scratch);
                let b = peak_bound(&shape, &teeth, &bands, &C);
                assert!(
                    p.lateral_n <= b.lateral_n && p.torque_nmm.abs() <= b.torque_nmm,
                    "{flutes} {phi}: {p:?} above {b:?}"
                );
            }
        }
        // Somewhere the bound is nearly reached (one tooth at sin α = 1).
        assert!(tightest < 1.5, "{tightest}");
        let (r, ap, fz) = (5.0, 2.0, 0.1);
        let teeth = Teeth {
            flutes: 2,
            helix_deg: 0.0,
        };
        let slot = [(BandArc::side_cut(r, 2.0 * r, 0.0, ap, true), fz)];
        let p = peak_cut(
            &EdgeShape::flat(r),
            &teeth,
            &slot,
            &C,
            1.0,
            &mut flanks[..2],
            &mut scratch,
        );
        let b = peak_bound(&EdgeShape::flat(r), &teeth, &slot, &C);
        let ratio = (1.0 + C.radial_ratio) / (1.0 + C.radial_ratio.powi(2)).sqrt();
        assert!(close(b.lateral_n / p.lateral_n, ratio, 1e-8), "{b:?} {p:?}");
    }

    /// The arcs of a band from its columns' offsets and its width: one
    /// flank keeps it, both share it, neither centres it on the columns.
    #[test]
    fn arcs_from_offsets_at_a_flank_in_a_slot_and_in_the_middle() {
        let flat = EdgeShape::flat(5.0);
        let (cell, near) = (0.1, |a: f64, b: f64| (a - b).abs() < 1e-12);
        // Left flank (up milling), 2 mm wide: φ from 0 to arccos(3/5).
        let [a, b] = BandArc::from_offsets(&flat, 1.0, 2.0, [3.05, 4.95], cell, 2.0);
        let a = a.unwrap();
        assert!(b.is_none() && near(a.phi_st_rad, 0.0) && near(a.phi_ex_rad, 0.6f64.acos()));
        assert!(near(a.z_lo_mm, 1.0) && near(a.z_hi_mm, 2.0));
        // Right flank (down milling).
        let [a, _] = BandArc::from_offsets(&flat, 1.0, 2.0, [-4.95, -3.05], cell, 2.0);
        let a = a.unwrap();
        assert!(near(a.phi_st_rad, (-0.6f64).acos()) && near(a.phi_ex_rad, PI));
        // Both flanks, half a slot's volume: 2.5 mm at each flank (as a tool
        // leaving a slot cuts two slivers; MODEL.md §3.4 on what it misses).
        let [a, b] = BandArc::from_offsets(&flat, 1.0, 2.0, [-4.95, 4.95], cell, 5.0);
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!(near(a.phi_st_rad, 0.0) && near(a.phi_ex_rad, 0.5f64.acos()));
        assert!(near(b.phi_st_rad, (-0.5f64).acos()) && near(b.phi_ex_rad, PI));
        assert!(near(a.z_lo_mm, 1.0) && near(a.z_hi_mm, 2.0));
        // Neither flank: 1 mm about the columns' middle (offsets 0.45…1.45
        // widened by half a cell: middle 0.95).
        let [a, _] = BandArc::from_offsets(&flat, 1.0, 2.0, [0.45, 1.45], cell, 1.0);
        let a = a.unwrap();
        assert!(near(a.phi_st_rad, (1.45f64 / 5.0).acos()));
        assert!(near(a.phi_ex_rad, (0.45f64 / 5.0).acos()));
        // No columns: no arc.
        let empty = [f64::INFINITY, f64::NEG_INFINITY];
        assert_eq!(
            BandArc::from_offsets(&flat, 1.0, 2.0, empty, cell, 1.0),
            [None, None]
        );
    }

    /// The mean of the instantaneous force over a tooth period is the closed
    /// form, for a helical ball in a side step (slices and lags included).
    #[test]
    fn instantaneous_force_averages_to_the_mean() {
        let shape = EdgeShape::ball(5.0);
        let teeth = Teeth {
            flutes: 3,
            helix_deg: 30.0,
        };
        let bands = [
            (
                BandArc::from_offsets(&shape, 0.0, 1.0, [1.0, 3.0], 0.0, 0.0)[0].unwrap(),
                0.07,
            ),
            (
                BandArc::from_offsets(&shape, 1.0, 2.0, [2.0, 5.0], 0.0, 0.0)[0].unwrap(),
                0.05,
            ),
        ];
        let mean = bands.iter().fold([0.0; 3], |acc, (arc, fz)| {
            let m = mean_cut(&shape, teeth.flutes, arc, *fz, &C);
            [
                acc[0] + m.force_n[0],
                acc[1] + m.force_n[1],
                acc[2] + m.force_n[2],
            ]
        });
        // Average the piecewise closed form on a fine grid of rotations.
        let period = 2.0 * PI / 3.0;
        let k = 20_000;
        let mut avg = [0.0; 3];
        for i in 0..k {
            let phi = (i as f64 + 0.5) / k as f64 * period;
            let f = force_at(&shape, &teeth, &bands, &C, phi);
            for d in 0..3 {
                avg[d] += f[d] / k as f64;
            }
        }
        for d in 0..3 {
            assert!(
                (avg[d] - mean[d]).abs() < 1e-3 * mean[0].hypot(mean[1]),
                "{avg:?} {mean:?}"
            );
        }
        let p = peak_cut(
            &shape,
            &teeth,
            &bands,
            &C,
            1.0,
            &mut [],
            &mut PeakScratch::default(),
        );
        // The peak is the largest lateral force on the fine grid (within its step).
        let grid_max = (0..k)
            .map(|i| {
                let f = force_at(&shape, &teeth, &bands, &C, i as f64 / k as f64 * period);
                f[0].hypot(f[1])
            })
            .fold(0.0, f64::max);
        assert!(
            p.lateral_n >= grid_max * (1.0 - 1e-6),
            "{} {grid_max}",
            p.lateral_n
        );
        assert!(
            p.lateral_n <= grid_max * (1.0 + 1e-3),
            "{} {grid_max}",
            p.lateral_n
        );
    }

    pub(super) fn force_at_pub(
        shape: &EdgeShape,
        teeth: &Teeth,
        bands: &[(BandArc, f64)],
        c: &Coefficients,
        phi: f64,
    ) -> [f64; 3] {
        force_at(shape, teeth, bands, c, phi)
    }

    /// The force at one rotation summed element by element (the test's own
    /// sum: slices as `peak_cut` cuts them, teeth tested one by one).
    fn force_at(
        shape: &EdgeShape,
        teeth: &Teeth,
        bands: &[(BandArc, f64)],
        c: &Coefficients,
        phi: f64,
    ) -> [f64; 3] {
        let n = teeth.flutes;
        let lag_per_mm = teeth.helix_deg.to_radians().tan() / shape.radius_mm;
        let mut f = [0.0; 3];
        for (arc, fz) in bands {
            let span = arc.z_hi_mm - arc.z_lo_mm;
            let k = ((span * lag_per_mm / SLICE_LAG_RAD).ceil() as usize).clamp(1, MAX_SLICES);
            for i in 0..k {
                let z0 = arc.z_lo_mm + span * i as f64 / k as f64;
                let z1 = arc.z_lo_mm + span * (i + 1) as f64 / k as f64;
                let m = shape.moments(z0, z1);
                let lag = 0.5 * (z0 + z1) * lag_per_mm;
                for j in 0..n {
                    let alpha =
                        (phi + f64::from(j) * 2.0 * PI / f64::from(n) - lag).rem_euclid(2.0 * PI);
                    if alpha < arc.phi_st_rad || alpha >= arc.phi_ex_rad {
                        continue;
                    }
                    let (s, co) = alpha.sin_cos();
                    let a = c.radial_ratio * m.sin_k_mm + c.axial_ratio * m.cos_k_mm;
                    let b = c.radial_ratio * m.cos_k_mm - c.axial_ratio * m.sin_k_mm;
                    let kf = c.kt_mpa * fz;
                    f[0] += kf * (-m.length_mm * s * co - a * s * s);
                    f[1] += kf * (m.length_mm * s * s - a * s * co);
                    f[2] += kf * b * s;
                }
            }
        }
        f
    }
}

#[cfg(test)]
mod ball_slot_peak {
    use super::*;

    /// The largest lateral force of two-flute `bands` at 20 000 rotations
    /// through one tooth period (π).
    fn brute_peak(
        shape: &EdgeShape,
        teeth: &Teeth,
        bands: &[(BandArc, f64)],
        c: &Coefficients,
    ) -> f64 {
        let k = 20_000;
        (0..k)
            .map(|i| {
                let f =
                    super::tests::force_at_pub(shape, teeth, bands, c, i as f64 / k as f64 * PI);
                f[0].hypot(f[1])
            })
            .fold(0.0, f64::max)
    }

    /// A two-flute ball slot in 0.25 mm bands whose arcs are [0, π] (every
    /// tooth's entry and exit at the same rotation) or shrunk unevenly as a
    /// grid's column centres leave them: the peak is the brute force maximum.
    /// (Starting the sweep of events in a stretch between two events that
    /// rounding had made 1e-16 apart once lost 8 % of it.)
    #[test]
    fn peak_is_the_brute_force_maximum_on_a_banded_ball_slot() {
        let c = Coefficients {
            kt_mpa: 1500.0,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let shape = EdgeShape::ball(5.0);
        let teeth = Teeth {
            flutes: 2,
            helix_deg: 30.0,
        };
        let uneven = [
            0.12, 0.0, 0.0, 0.00025, 0.066, 0.108, 0.0, 0.0002, 0.0, 0.0, 0.082, 0.0,
        ];
        for shrink in [0.0, 1e-3, 0.05, -1.0] {
            let bands: Vec<(BandArc, f64)> = (0..12)
                .map(|k| {
                    let z = 0.25 * k as f64;
                    let s = if shrink < 0.0 { uneven[k] } else { shrink };
                    (
                        BandArc {
                            z_lo_mm: z,
                            z_hi_mm: z + 0.25,
                            phi_st_rad: s,
                            phi_ex_rad: PI - s,
                        },
                        0.05,
                    )
                })
                .collect();
            let p = peak_cut(
                &shape,
                &teeth,
                &bands,
                &c,
                1.0,
                &mut [],
                &mut PeakScratch::default(),
            );
            let brute = brute_peak(&shape, &teeth, &bands, &c);
            // Within the sampling of the stretches (every 2.5°), and never above.
            assert!(
                p.lateral_n <= brute * (1.0 + 1e-9) && p.lateral_n >= brute * (1.0 - 1e-3),
                "arcs shrunk by {shrink}: peak {} against {brute}",
                p.lateral_n
            );
        }
    }

    /// Real program A's deepest passes (a Ø2 ball 5 mm down a wall, 30°
    /// helix: 60 slices, stretches of about a degree, most sampled in one
    /// step, each start the end before it), with the wall's arcs ending at
    /// 40 angles: the force made again at the rotation each peak reports is
    /// the peak to rounding, so every sample's 2φ is its rotation's; and the
    /// peak is the brute force maximum.
    #[test]
    fn peak_of_short_stretches_in_a_row_is_the_force_where_it_says() {
        let c = Coefficients {
            kt_mpa: 1500.0,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let shape = EdgeShape::ball(1.0);
        let teeth = Teeth {
            flutes: 2,
            helix_deg: 30.0,
        };
        let wall = |entry: f64, exit: f64| -> Vec<(BandArc, f64)> {
            (0..5)
                .map(|k| {
                    let z = f64::from(k);
                    (
                        BandArc {
                            z_lo_mm: z,
                            z_hi_mm: z + 1.0,
                            phi_st_rad: entry + 0.05 * z,
                            phi_ex_rad: exit - 0.1 * z,
                        },
                        0.01,
                    )
                })
                .collect()
        };
        let mut scratch = PeakScratch::default();
        for i in 0..40 {
            let (entry, exit) = (0.3 - 0.0075 * f64::from(i), PI - 0.02 * f64::from(i));
            let p = peak_cut(
                &shape,
                &teeth,
                &wall(entry, exit),
                &c,
                1.0,
                &mut [],
                &mut scratch,
            );
            assert!(
                scratch.events.len() > 100,
                "{} events",
                scratch.events.len()
            );
            // (Made again from the teeth engaged there, with its own sin_cos:
            // at an event, the teeth of the stretch that ends there.)
            let there = p.force_n[0].hypot(p.force_n[1]);
            assert!(
                (p.lateral_n - there).abs() <= 1e-12 * there,
                "arcs [{entry}, {exit}]: peak {} against {there} at its rotation",
                p.lateral_n
            );
        }
        let bands = wall(0.3, PI);
        let p = peak_cut(&shape, &teeth, &bands, &c, 1.0, &mut [], &mut scratch);
        let brute = brute_peak(&shape, &teeth, &bands, &c);
        // (Within the sampling, either side: the peak here is at a tooth's
        // entry, the limit of a jump the grid of rotations meets only to
        // within its step.)
        assert!(
            (p.lateral_n - brute).abs() <= 1e-3 * brute,
            "peak {} against {brute}",
            p.lateral_n
        );
    }
}
