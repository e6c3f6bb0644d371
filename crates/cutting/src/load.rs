//! Per-step load of S4: force magnitude from removed volume, direction from the contact
//! resultant, deflection of the tool from the load distribution over its height bands.

use serde::{Deserialize, Serialize};

use std::cell::RefCell;

use crate::beam::SteppedBeam;
use crate::force::{force_n, volume_per_tooth_mm3};
use crate::kienzle::Kienzle;
use crate::tooth::{
    peak_bound, peak_cut, ArcTerms, BandArc, Coefficients, EdgeShape, PeakScratch, Teeth,
};

/// The most a band's arcs may need of the step's own feed per tooth to
/// remove its volume before the step is taken as no steady cut (MODEL.md §3.4).
const MAX_FEED_OVER_MOTION: f64 = 1.25;

/// Bisections of a step's split of the bands at both flanks between
/// slivers and a slot (MODEL.md §3.4): s to 2⁻²⁴.
const SPLIT_BISECTIONS: usize = 24;

/// Below this length the contact resultant is treated as zero (no defined direction).
const MIN_RESULTANT: f64 = 1e-12;

/// Unit XY direction of the cutting force **on the tool** for a step's contact resultant
/// (sum over cut columns of the horizontal unit vector from the tool axis towards the column,
/// weighted by removed volume; its Z component is ignored).
///
/// The material pushes the tool away from itself, so the force acts opposite to the resultant.
/// Returns `[0, 0]` when the horizontal resultant is (nearly) zero, e.g. a pure plunge.
pub fn force_direction(contact_resultant: [f64; 3]) -> [f64; 2] {
    // MODEL.md §1.4 (S4): the contact resultant is the force direction; the tool yields along its reaction.
    let [x, y, _] = contact_resultant;
    let len = x.hypot(y);
    if len.is_nan() || len <= MIN_RESULTANT {
        return [0.0, 0.0];
    }
    [-x / len, -y / len]
}

/// What one step of the sweep does to the tool.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepLoad {
    /// Magnitude of the mean lateral cutting force on the tool, N.
    pub force_n: f64,
    /// Largest lateral force on the tool over a revolution, N (MODEL.md
    /// §3.4; the mean where the step has no engaged arc, and under S4's law).
    pub force_peak_n: f64,
    /// X component of the force on the tool, N.
    pub fx_n: f64,
    /// Y component of the force on the tool, N.
    pub fy_n: f64,
    /// Axial force on the tool, N (pulling it out of the holder; 0 for S4's law).
    pub fz_n: f64,
    /// Spindle cutting power, W.
    pub power_w: f64,
    /// Spindle torque, N·m.
    pub torque_nm: f64,
    /// Mean chip thickness per tooth, mm (0 where the record has none).
    pub chip_thickness_mm: f64,
    /// Height above the tip where the resultant of the band loads acts, mm.
    pub contact_height_mm: f64,
    /// Lateral deflection of the tool at the contact height, µm.
    pub deflection_um: f64,
    /// X component of the deflection at the contact height, µm (along the force).
    pub dx_um: f64,
    /// Y component of the deflection at the contact height, µm (along the force).
    pub dy_um: f64,
    /// Lateral deflection of the tip, µm.
    pub tip_deflection_um: f64,
    /// Largest von Mises stress in the tool (holder face or flute end), MPa.
    pub stress_mpa: f64,
}

impl StepLoad {
    /// The load times `s`: forces, power, torque, deflections and stress
    /// (bending ∝ force, torsion ∝ torque), at the same chip thickness and
    /// contact height. The closed loop's load at a root that lies at a jump
    /// of the removal (MODEL.md §5.1).
    pub fn scaled(&self, s: f64) -> StepLoad {
        StepLoad {
            force_n: s * self.force_n,
            force_peak_n: s * self.force_peak_n,
            fx_n: s * self.fx_n,
            fy_n: s * self.fy_n,
            fz_n: s * self.fz_n,
            power_w: s * self.power_w,
            torque_nm: s * self.torque_nm,
            deflection_um: s * self.deflection_um,
            dx_um: s * self.dx_um,
            dy_um: s * self.dy_um,
            tip_deflection_um: s * self.tip_deflection_um,
            stress_mpa: s * self.stress_mpa,
            ..*self
        }
    }

    /// The tool breaks in this step: its stress exceeds the rupture
    /// strength `rupture_mpa` (MODEL.md §4.4).
    pub fn breaks(&self, rupture_mpa: f64) -> bool {
        self.stress_mpa > rupture_mpa
    }

    /// The load as reported for a tool of rupture strength `rupture_mpa`
    /// (MODEL.md §4.4): where the step's stress σ exceeds it, the tool breaks
    /// and its deflections are the elastic ones at rupture, `δ · σ_R / σ`
    /// (bending stress, torsion and deflection grow together with the
    /// load), not the linear beam's; force, power, torque, chip, contact
    /// height and stress stay what the cut asks. At or under the rupture
    /// strength the load is returned as it is, bit for bit.
    pub fn at_rupture(&self, rupture_mpa: f64) -> StepLoad {
        if !self.breaks(rupture_mpa) {
            return *self;
        }
        let s = self.rupture_scale(rupture_mpa);
        StepLoad {
            deflection_um: s * self.deflection_um,
            dx_um: s * self.dx_um,
            dy_um: s * self.dy_um,
            tip_deflection_um: s * self.tip_deflection_um,
            ..*self
        }
    }

    /// What [`StepLoad::at_rupture`] scales the deflections by: `σ_R / σ`
    /// where the tool breaks, else 1 (any other deflection of the step, such
    /// as its flanks' of [`CuttingModel::step_load_with_flanks`], scales
    /// with it).
    pub fn rupture_scale(&self, rupture_mpa: f64) -> f64 {
        if self.breaks(rupture_mpa) {
            rupture_mpa / self.stress_mpa
        } else {
            1.0
        }
    }

    /// The linear beam's deflection at the contact height of a load
    /// reported by [`StepLoad::at_rupture`] with `rupture_mpa`, µm: the
    /// deflection the load would cause if the tool did not break (what a
    /// limit on the deflection scales with the feed).
    pub fn linear_deflection_um(&self, rupture_mpa: f64) -> f64 {
        if self.breaks(rupture_mpa) {
            self.deflection_um * self.stress_mpa / rupture_mpa
        } else {
            self.deflection_um
        }
    }
}

/// How removed volume turns into force.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ForceModel {
    /// S4's `F = a · V^n` (MODEL.md §3.1).
    PowerLaw {
        /// N at V = 1 mm³ per tooth per revolution.
        a: f64,
        /// Dimensionless exponent.
        n: f64,
    },
    /// Kienzle's specific cutting force at the mean chip thickness (MODEL.md §3.2).
    Kienzle(Kienzle),
}

impl ForceModel {
    /// Exponent p of the feed in force, power and deflection at fixed engagement
    /// (Q ∝ F^p): n for the power law, 1 − mc for Kienzle.
    pub fn feed_exponent(&self) -> f64 {
        match self {
            ForceModel::PowerLaw { n, .. } => *n,
            ForceModel::Kienzle(k) => 1.0 - k.mc,
        }
    }
}

/// What the sweep recorded for one step, the input of [`CuttingModel::step_load`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepRemoval<'a> {
    /// Removed volume, mm³.
    pub volume_mm3: f64,
    /// Removed volume per tool height band, mm³.
    pub band_volumes_mm3: &'a [f64],
    /// Σ dV · r̂ (mm³), r̂ the unit vector from the axis to where the edge cut.
    pub contact_resultant: [f64; 2],
    /// Σ dV / h (mm²), h the thickness the edge cut in the step.
    pub chip_edge_area_mm2: f64,
    /// Σ dV / r (mm²), r the edge's radius where it cut.
    pub volume_over_radius_mm2: f64,
    /// Duration of the step, s.
    pub dt_s: f64,
    /// Per band, the least and greatest signed offset (mm, to the left of the
    /// feed) of the columns the band cut; a band that cut nothing, or a
    /// plunge, has none (`lo > hi` or NaN). Empty: no engagement recorded.
    pub band_offsets_mm: &'a [[f32; 2]],
    /// The step's unit XY feed direction ([0, 0] for a plunge).
    pub feed_dir: [f64; 2],
    /// The step's length in XY, mm (what its bands' volumes are removed over).
    pub len_xy_mm: f64,
    /// The grid's cell size, mm (a column stands for its cell).
    pub cell_mm: f64,
}

/// The parameters that turn a step's removed volume into force and deflection.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CuttingModel {
    /// How removed volume becomes cutting force (S4's power law or Kienzle).
    pub force_model: ForceModel,
    /// Spindle speed, rev/min.
    pub spindle_rpm: f64,
    /// Number of flutes (teeth).
    pub flutes: u32,
    /// Nominal tool radius, mm (cutting speed of S4's law).
    pub tool_radius_mm: f64,
    /// Height h of one band of the tool, mm; band k spans `[k·h, (k+1)·h)` above the tip.
    pub band_height_mm: f64,
    /// The tool as a beam.
    pub beam: SteppedBeam,
    /// The cutting edge's profile (MODEL.md §3.4).
    pub edge: EdgeShape,
    /// Helix angle of the flutes, degrees.
    pub helix_deg: f64,
}

/// Scratch of [`CuttingModel::tooth_forces`]: the arcs with their feeds per
/// tooth, the bands' cuts, and the peak's slices and events (no allocation
/// per step once grown).
#[derive(Default)]
struct ToothScratch {
    arcs: Vec<(BandArc, f64)>,
    cuts: Vec<BandCut>,
    peak: PeakScratch,
}

thread_local! {
    static TOOTH_SCRATCH: RefCell<ToothScratch> = RefCell::new(ToothScratch::default());
}

/// The bands of a step from the first that removed something to the last
/// (none: an empty slice), and the index of the first among all.
#[derive(Clone, Copy)]
struct CutBands<'a> {
    first: usize,
    volumes_mm3: &'a [f64],
}

impl<'a> CutBands<'a> {
    fn of(band_volumes_mm3: &'a [f64]) -> CutBands<'a> {
        let cut = |v: &f64| *v > 0.0;
        match (
            band_volumes_mm3.iter().position(cut),
            band_volumes_mm3.iter().rposition(cut),
        ) {
            (Some(first), Some(last)) => CutBands {
                first,
                volumes_mm3: &band_volumes_mm3[first..=last],
            },
            _ => CutBands {
                first: 0,
                volumes_mm3: &[],
            },
        }
    }
}

/// A band's cut as the sweep recorded it (MODEL.md §3.4): its volume, its
/// heights, its width across the feed, and what its columns' offsets make of
/// it.
#[derive(Clone, Copy, Debug)]
struct BandCut {
    volume_mm3: f64,
    z_mm: [f64; 2],
    width_mm: f64,
    kind: BandKind,
    /// Its arcs and their terms where they do not depend on the step's
    /// split (not [`BandKind::Split`]): made once, for the contact along the
    /// feed and both feeds of the arcs' mean.
    fixed: Option<FixedArcs>,
}

/// A band's arcs that do not depend on the step's split, and their terms.
#[derive(Clone, Copy, Debug)]
struct FixedArcs {
    arcs: [Option<BandArc>; 2],
    terms: [Option<ArcTerms>; 2],
}

/// What a band's columns make of its cut (MODEL.md §3.4).
#[derive(Clone, Copy, Debug)]
enum BandKind {
    /// Its arcs (at one flank, or at neither).
    Arcs([Option<BandArc>; 2]),
    /// Both flanks: between slivers and a slot, split by the step's contact
    /// along the feed ([`BandArc::flanks`]).
    Split,
    /// Both flanks, above a band cut across the whole width: the top of a
    /// slot, cut as one over part of its height whatever the contact.
    SlotTop,
}

/// A step's forces through a tooth period (MODEL.md §3.4), machine axes.
/// How much of the force through the tooth period a load takes (MODEL.md §3.4).
enum Peak<'f> {
    /// The mean only: the peak is the mean's lateral force.
    Mean,
    /// Upper bounds of the peak and of its torque ([`peak_bound`]).
    Bound,
    /// The peak ([`peak_cut`]), and per entry the forces at its band's flanks.
    Exact(&'f mut [[[f64; 2]; 2]]),
}

struct ToothForces {
    mean_n: [f64; 3],
    peak_lateral_n: f64,
    peak_torque_nmm: f64,
}

impl CuttingModel {
    /// Height above the tip where the band loads' resultant acts, mm: the volume-weighted
    /// mean of the bands' mid-heights `(k + ½)·h`; at the tip when no band has volume.
    pub fn contact_height_mm(&self, band_volumes_mm3: &[f64]) -> f64 {
        let (sum, moment) = band_volumes_mm3
            .iter()
            .enumerate()
            .filter(|(_, v)| **v > 0.0)
            .fold((0.0, 0.0), |(s, m), (k, v)| {
                (s + v, m + v * (k as f64 + 0.5) * self.band_height_mm)
            });
        if sum > 0.0 {
            moment / sum
        } else {
            0.0
        }
    }

    /// Deflection in mm at `at_from_tip_mm` per newton of cutting force spread over the
    /// bands like `band_volumes_mm3` (band k carries its share at its mid-height; the whole
    /// force at the tip when no band has volume). Does not allocate.
    pub fn compliance_at_mm_per_n(&self, band_volumes_mm3: &[f64], at_from_tip_mm: f64) -> f64 {
        self.compliance_of(CutBands::of(band_volumes_mm3), at_from_tip_mm)
    }

    /// [`compliance_at_mm_per_n`](Self::compliance_at_mm_per_n) of the bands
    /// `cut` holds: the same sums of the same terms in the same order (the
    /// bands that removed nothing, which the sums leave out, not scanned).
    fn compliance_of(&self, cut: CutBands<'_>, at_from_tip_mm: f64) -> f64 {
        let total: f64 = cut.volumes_mm3.iter().filter(|v| **v > 0.0).sum();
        if total <= 0.0 {
            return self.beam.deflection_mm(1.0, 0.0, at_from_tip_mm);
        }
        cut.volumes_mm3
            .iter()
            .enumerate()
            .filter(|(_, v)| **v > 0.0)
            .map(|(j, v)| {
                let mid_mm = ((cut.first + j) as f64 + 0.5) * self.band_height_mm;
                self.beam.deflection_mm(v / total, mid_mm, at_from_tip_mm)
            })
            .sum()
    }

    /// Deflection at the contact height per newton (what `deflection_um` reports).
    pub fn compliance_mm_per_n(&self, band_volumes_mm3: &[f64]) -> f64 {
        self.compliance_at_mm_per_n(band_volumes_mm3, self.contact_height_mm(band_volumes_mm3))
    }

    /// Tooth passes during `dt_s`.
    fn tooth_passes(&self, dt_s: f64) -> f64 {
        f64::from(self.flutes) * self.spindle_rpm * dt_s / 60.0
    }

    /// Load of one step.
    ///
    /// * S4's law (MODEL.md §3.1): `F = a · V^n` with V from [`volume_per_tooth_mm3`],
    ///   opposite the contact resultant; power `F · v_c` at the nominal radius.
    /// * Kienzle (MODEL.md §3.2): mean chip thickness per tooth `h_m = V / (Σ dV/h) / N`,
    ///   `kc = kc1_1 · h_m^(−mc)`, power `kc · V / Δt`, torque `P / ω`, mean force
    ///   `kc / (2π N_rev) · (Σ dV/r) / V · (ẑ × C − k_r C)`, axial `−k_a` times the mean
    ///   tangential force (toward −Z: out of the holder).
    /// * Deflection (MODEL.md §4.2, §4.3): the force spread over the bands, on the stepped
    ///   beam, at the contact height and at the tip, along the force.
    ///
    /// Does not allocate.
    pub fn step_load(&self, r: &StepRemoval<'_>) -> StepLoad {
        self.load(r, Peak::Exact(&mut []))
    }

    /// [`step_load`](Self::step_load) but for the force through the tooth
    /// period's peak: `force_peak_n` and `stress_mpa` are upper bounds of
    /// its (from [`peak_bound`]: MODEL.md §3.4, "A bound on the peak"), the
    /// rest its own bit for bit; where the step has no engaged arc (plunges,
    /// S4's law) its own too. What decides whether a step can stress its tool
    /// beyond a limit at a fraction of the peak's cost: where the bound is
    /// within the limit the step's own stress is.
    ///
    /// Does not allocate.
    pub fn step_load_bounded(&self, r: &StepRemoval<'_>) -> StepLoad {
        self.load(r, Peak::Bound)
    }

    /// [`step_load`](Self::step_load), and per entry k of `flanks_um` the
    /// deflection [x, y] (µm, machine axes) at band k's mid-height
    /// `z_k = (k + ½)·h` at the instants a tooth there passes the flank on
    /// the left of the feed (φ = 0: the wall up milling leaves) and on the
    /// right (φ = π: down milling's), `[left, right]` (MODEL.md §5.2): the
    /// force through the tooth period at that instant, spread over the bands
    /// like the mean (§4.3), on the beam at z_k. Where the step has no
    /// engaged arc (plunges, S4's law), the mean force's deflection at z_k on
    /// both sides; zero where it removes nothing.
    ///
    /// Does not allocate.
    pub fn step_load_with_flanks(
        &self,
        r: &StepRemoval<'_>,
        flanks_um: &mut [[[f64; 2]; 2]],
    ) -> StepLoad {
        self.load(r, Peak::Exact(flanks_um))
    }

    /// The mean deflection [x, y] at the contact height (µm, along the mean
    /// force: `dx_um`, `dy_um` of [`step_load`](Self::step_load), bit for
    /// bit), without the force through the tooth period's peak and flanks
    /// (MODEL.md §3.4): what the closed loop moves the tool by (§5.1), at a
    /// fraction of the cost.
    ///
    /// Does not allocate.
    pub fn mean_deflection_um(&self, r: &StepRemoval<'_>) -> [f64; 2] {
        let l = self.load(r, Peak::Mean);
        [l.dx_um, l.dy_um]
    }

    /// [`step_load_with_flanks`](Self::step_load_with_flanks) with
    /// [`Peak::Exact`]'s flanks; [`step_load_bounded`](Self::step_load_bounded)
    /// with [`Peak::Bound`]; the mean only with [`Peak::Mean`] (the peak is
    /// the mean's lateral force: [`mean_deflection_um`](Self::mean_deflection_um)).
    fn load(&self, r: &StepRemoval<'_>, mut peak: Peak<'_>) -> StepLoad {
        if let Peak::Exact(f) = &mut peak {
            f.fill([[0.0; 2]; 2]);
        }
        if !(r.volume_mm3 > 0.0 && r.dt_s > 0.0) {
            return StepLoad::default();
        }
        let passes = self.tooth_passes(r.dt_s);
        let revolutions = self.spindle_rpm * r.dt_s / 60.0;
        let omega = 2.0 * std::f64::consts::PI * self.spindle_rpm / 60.0;
        let chip_thickness_mm = if r.chip_edge_area_mm2 > 0.0 {
            r.volume_mm3 / r.chip_edge_area_mm2 / passes
        } else {
            0.0
        };
        let bands = r.band_volumes_mm3;
        let contact_height_mm = self.contact_height_mm(bands);
        // (fx, fy, fz, power, the forces through the tooth period where the
        // step has engaged arcs)
        let (fx, fy, fz, power_w, tooth) = match self.force_model {
            ForceModel::PowerLaw { a, n } => {
                let v = volume_per_tooth_mm3(r.volume_mm3, self.flutes, self.spindle_rpm, r.dt_s);
                let f = force_n(v, a, n);
                let [ux, uy] =
                    force_direction([r.contact_resultant[0], r.contact_resultant[1], 0.0]);
                // P = F · v_c, v_c = ω R (mm/s) → W = N·mm/s / 1000
                let power_w = f * omega * self.tool_radius_mm / 1000.0;
                (f * ux, f * uy, 0.0, power_w, None)
            }
            ForceModel::Kienzle(k) => {
                if chip_thickness_mm <= 0.0 {
                    return StepLoad::default();
                }
                let kc = k.specific_force_mpa(chip_thickness_mm);
                let power_w = kc * r.volume_mm3 / r.dt_s / 1000.0;
                let coefficients = Coefficients {
                    kt_mpa: kc,
                    radial_ratio: k.radial_ratio,
                    axial_ratio: k.axial_ratio,
                };
                // §3.2's mean from the aggregates. Mean tangential force:
                // energy per revolution over the edge's path 2π r.
                let ft = kc * r.volume_over_radius_mm2 / (2.0 * std::f64::consts::PI * revolutions);
                let [cx, cy] = r.contact_resultant;
                let scale = ft / r.volume_mm3;
                // Tangential (ẑ × C) for a clockwise (M3) spindle, radial −C;
                // axial −k_a F_t: a right-hand helix turning M3 pulls the tool
                // out of its holder, toward −Z (MODEL.md §3.2: forces on the
                // tool, machine axes, +Z up).
                let aggregate = [
                    scale * (-cy - k.radial_ratio * cx),
                    scale * (cx - k.radial_ratio * cy),
                    -k.axial_ratio * ft,
                ];
                let tooth = self.tooth_forces(
                    r,
                    &coefficients,
                    revolutions,
                    aggregate,
                    1000.0 * power_w / omega,
                    &mut peak,
                );
                let [fx, fy, fz] = tooth.as_ref().map_or(aggregate, |t| t.mean_n);
                (fx, fy, fz, power_w, tooth)
            }
        };
        let force = fx.hypot(fy);
        let (ux, uy) = if force > 0.0 {
            (fx / force, fy / force)
        } else {
            (0.0, 0.0)
        };
        // The deflection at the contact height per newton (the bands that
        // removed something found once: a long flute's flanks below take
        // the compliance at each band's height).
        let cut = CutBands::of(bands);
        let compliance_mm_per_n = self.compliance_of(cut, contact_height_mm);
        let deflection_um = 1000.0 * force * compliance_mm_per_n;
        let tip_deflection_um = 1000.0 * force * self.compliance_of(cut, 0.0);
        let torque_nm = power_w / omega;
        let (force_peak_n, peak_torque_nmm) = match &tooth {
            Some(t) => (t.peak_lateral_n, t.peak_torque_nmm),
            None => (force, 1000.0 * torque_nm),
        };
        // Each band's flank forces (the mean's where the step has no
        // engaged arc) on the beam at the band's mid-height (MODEL.md §5.2).
        let flanks_um: &mut [[[f64; 2]; 2]] = match peak {
            Peak::Exact(f) => f,
            Peak::Mean | Peak::Bound => &mut [],
        };
        for (k, flank) in flanks_um.iter_mut().enumerate() {
            let um_per_n = 1000.0 * self.compliance_of(cut, (k as f64 + 0.5) * self.band_height_mm);
            if tooth.is_none() {
                *flank = [[fx, fy]; 2];
            }
            *flank = flank.map(|f| f.map(|c| um_per_n * c));
        }
        StepLoad {
            force_n: force,
            force_peak_n,
            fx_n: fx,
            fy_n: fy,
            fz_n: fz,
            power_w,
            torque_nm,
            chip_thickness_mm,
            contact_height_mm,
            deflection_um,
            dx_um: deflection_um * ux,
            dy_um: deflection_um * uy,
            tip_deflection_um,
            // Peak von Mises stress: the largest lateral force of the
            // revolution (§3.4) at the contact height, with the torque then.
            stress_mpa: self
                .beam
                .peak_stress_mpa(&[(contact_height_mm, force_peak_n)], peak_torque_nmm),
        }
    }

    /// The mean force and the peak over a revolution from the bands' engaged
    /// arcs (MODEL.md §3.4), on the tool in machine axes: each band's feed
    /// per tooth set so that its arc removes the band's volume per
    /// revolution. A band with no arcs, or whose arcs are no steady cut,
    /// takes its share of the volume of §3.2's mean `aggregate_n` (and of
    /// the mean torque `torque_nmm`), added to the arcs' mean, peak and
    /// flank forces. `None` where the step has no horizontal feed or no band
    /// has arcs: the aggregates' mean is used whole. Per entry k of
    /// `flanks_n`, the lateral forces (machine axes, N) when a tooth at band
    /// k's mid-height passes the left and the right flank ([`peak_cut`];
    /// written only where `Some` is returned: [`Peak::Exact`]). With
    /// [`Peak::Bound`], [`peak_bound`]'s bounds in place of the peak; with
    /// [`Peak::Mean`], the mean only: the peak is the mean's lateral force.
    fn tooth_forces(
        &self,
        r: &StepRemoval<'_>,
        c: &Coefficients,
        revolutions: f64,
        aggregate_n: [f64; 3],
        torque_nmm: f64,
        peak: &mut Peak<'_>,
    ) -> Option<ToothForces> {
        let [ux, uy] = r.feed_dir;
        if (ux == 0.0 && uy == 0.0) || !(revolutions > 0.0) {
            return None;
        }
        TOOTH_SCRATCH.with(|scratch| {
            let ToothScratch {
                arcs,
                cuts,
                peak: peak_scratch,
            } = &mut *scratch.borrow_mut();
            arcs.clear();
            cuts.clear();
            let h = self.band_height_mm;
            let fz_motion = r.len_xy_mm / (f64::from(self.flutes) * revolutions);
            // The volume of the bands that take §3.2's mean.
            let mut aggregate_mm3 = 0.0;
            // The bands with arcs: their volume, and the volume times the
            // share along the feed of the contact of those whose arcs are
            // known (at one flank, at neither, or a slot's top).
            let (mut arcs_mm3, mut known) = (0.0, 0.0);
            // The band below was cut across the tool's whole width.
            let mut below_whole = false;
            for (k, &v) in r.band_volumes_mm3.iter().enumerate() {
                let below = std::mem::take(&mut below_whole);
                if !(v > 0.0) {
                    continue;
                }
                let Some(&[lo, hi]) = r.band_offsets_mm.get(k) else {
                    aggregate_mm3 += v;
                    continue;
                };
                let z_lo = k as f64 * h;
                let z_hi = (z_lo + h).min(self.beam.flute_length_mm.max(z_lo));
                // The band's removal across the feed: its volume over its
                // height and the step's length.
                let width_mm = v / ((z_hi - z_lo) * r.len_xy_mm);
                let pieces = BandArc::from_offsets(
                    &self.edge,
                    z_lo,
                    z_hi,
                    [f64::from(lo), f64::from(hi)],
                    r.cell_mm,
                    width_mm,
                );
                if pieces.iter().all(Option::is_none) {
                    aggregate_mm3 += v;
                    continue;
                }
                let both_flanks = pieces.iter().all(Option::is_some);
                // (The width of a slot within the grid's resolution.)
                let whole_mm = 2.0 * self.edge.radius_at_mm(0.5 * (z_lo + z_hi)) - 2.0 * r.cell_mm;
                below_whole = both_flanks && width_mm >= whole_mm;
                let mut cut = BandCut {
                    volume_mm3: v,
                    z_mm: [z_lo, z_hi],
                    width_mm,
                    kind: BandKind::Split,
                    fixed: None,
                };
                if !both_flanks {
                    cut.kind = BandKind::Arcs(pieces);
                } else if below {
                    cut.kind = BandKind::SlotTop;
                }
                if !matches!(cut.kind, BandKind::Split) {
                    let arcs = self.cut_arcs(&cut, 1.0);
                    let terms = ArcTerms::of_each(&self.edge, arcs);
                    known += v * ArcTerms::forward_share(&terms);
                    cut.fixed = Some(FixedArcs { arcs, terms });
                }
                arcs_mm3 += v;
                cuts.push(cut);
            }
            // The contact along the feed of the bands with arcs: the step's
            // (their part of it), less that of those whose arcs are known.
            let measured = (r.contact_resultant[0] * ux + r.contact_resultant[1] * uy) * arcs_mm3
                / r.volume_mm3;
            let s = self.split(cuts, measured - known);
            let mut mean = [0.0; 3];
            for cut in cuts.iter() {
                let v = cut.volume_mm3;
                // Its arcs, and each arc's terms once for both feeds below.
                let FixedArcs {
                    arcs: pieces,
                    terms,
                } = cut.fixed.unwrap_or_else(|| {
                    let arcs = self.cut_arcs(cut, s);
                    FixedArcs {
                        arcs,
                        terms: ArcTerms::of_each(&self.edge, arcs),
                    }
                });
                // One feed per tooth for the arcs (one, or one at each
                // flank): their volume per revolution over theirs at
                // f_z = 1.
                let per_fz: f64 = terms
                    .iter()
                    .flatten()
                    .map(|t| t.mean_cut(self.flutes, 1.0, c).volume_mm3)
                    .sum();
                // A steady cut's arcs remove the band's volume at about
                // the feed per tooth the step's motion gives. Where they
                // would need more than 1.25 times it (a tool that starts
                // buried in the stock), the chip is not f_z sin φ and the
                // arcs do not describe the cut: §3.2's aggregates do
                // (their force is the energy's): the band takes its share
                // of their mean.
                let fz = v / revolutions / per_fz;
                if !(per_fz > 0.0) || fz > MAX_FEED_OVER_MOTION * fz_motion {
                    aggregate_mm3 += v;
                    continue;
                }
                for (arc, t) in pieces.into_iter().zip(terms).filter_map(|(a, t)| a.zip(t)) {
                    let m = t.mean_cut(self.flutes, fz, c);
                    for (s, f) in mean.iter_mut().zip(m.force_n) {
                        *s += f;
                    }
                    arcs.push((arc, fz));
                }
            }
            if arcs.is_empty() {
                return None;
            }
            // The bands without a steady cut's arcs: their share of §3.2's
            // mean, steady through the revolution.
            let share = aggregate_mm3 / r.volume_mm3;
            let [ax, ay, az] = aggregate_n.map(|f| share * f);
            // Feed frame (x along the feed, y to its left) to machine axes.
            let machine = |[fx, fy]: [f64; 2]| [fx * ux - fy * uy + ax, fx * uy + fy * ux + ay];
            let [fx, fy] = machine([mean[0], mean[1]]);
            let mean_n = [fx, fy, mean[2] + az];
            let teeth = Teeth {
                flutes: self.flutes,
                helix_deg: self.helix_deg,
            };
            let flanks_n = match peak {
                Peak::Mean => {
                    return Some(ToothForces {
                        mean_n,
                        peak_lateral_n: fx.hypot(fy),
                        peak_torque_nmm: torque_nmm,
                    })
                }
                // Above the exact branch's sums, term by term.
                Peak::Bound => {
                    let b = peak_bound(&self.edge, &teeth, arcs, c);
                    return Some(ToothForces {
                        mean_n,
                        peak_lateral_n: b.lateral_n + ax.hypot(ay),
                        peak_torque_nmm: b.torque_nmm + (share * torque_nmm).abs(),
                    });
                }
                Peak::Exact(f) => &mut **f,
            };
            let peak = peak_cut(&self.edge, &teeth, arcs, c, h, flanks_n, peak_scratch);
            for flank in flanks_n.iter_mut() {
                *flank = flank.map(machine);
            }
            Some(ToothForces {
                mean_n,
                peak_lateral_n: peak.lateral_n + ax.hypot(ay),
                peak_torque_nmm: peak.torque_nmm + share * torque_nmm,
            })
        })
    }

    /// The split `s` of [`BandArc::flanks`], one for the step's bands that
    /// reach both flanks (`BandKind::Split` among `cuts`), between slivers at
    /// the flanks (the contact across the feed, s = 0) and a slot over part
    /// of their height (along it: π/4 of their volume, s = 1): the one whose
    /// volume-weighted contact along the feed is `target_mm3`, by bisection
    /// (it grows with s; MODEL.md §3.4). 0 where no band is split.
    fn split(&self, cuts: &[BandCut], target_mm3: f64) -> f64 {
        let split = |cut: &&BandCut| matches!(cut.kind, BandKind::Split);
        let along = |s: f64| -> f64 {
            cuts.iter()
                .filter(split)
                .map(|cut| cut.volume_mm3 * BandArc::forward_share(&self.cut_arcs(cut, s)))
                .sum()
        };
        if !cuts.iter().any(|cut| split(&cut)) || along(0.0) >= target_mm3 {
            return 0.0;
        }
        if along(1.0) <= target_mm3 {
            return 1.0;
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..SPLIT_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if along(mid) < target_mm3 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// The arcs of a band's cut `cut`: its own, or where it reaches both
    /// flanks [`BandArc::flanks`] at the step's split `s` (a slot's top: 1).
    fn cut_arcs(&self, cut: &BandCut, s: f64) -> [Option<BandArc>; 2] {
        let [z_lo, z_hi] = cut.z_mm;
        match cut.kind {
            BandKind::Arcs(arcs) => arcs,
            BandKind::Split => BandArc::flanks(&self.edge, z_lo, z_hi, cut.width_mm, s),
            BandKind::SlotTop => BandArc::flanks(&self.edge, z_lo, z_hi, cut.width_mm, 1.0),
        }
    }

    /// The highest feed (mm/min) at which `quantity_at(feed)` stays at or under `limit`,
    /// for a quantity that grows like `feed^p` at fixed engagement (p from
    /// [`ForceModel::feed_exponent`]; 1 for removal rate): `F = F₁ (limit / Q(F₁))^(1/p)`.
    pub fn feed_for_limit(&self, quantity_at_ref: f64, ref_feed_mm_min: f64, limit: f64) -> f64 {
        if !(quantity_at_ref > 0.0) {
            return f64::INFINITY;
        }
        let p = self.force_model.feed_exponent();
        ref_feed_mm_min * (limit / quantity_at_ref).powf(1.0 / p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tooth::mean_cut;

    #[test]
    fn scaled_load_scales_forces_and_keeps_the_chip() {
        let l = StepLoad {
            force_n: 10.0,
            force_peak_n: 14.0,
            fx_n: 6.0,
            fy_n: -8.0,
            fz_n: 2.5,
            power_w: 100.0,
            torque_nm: 0.2,
            chip_thickness_mm: 0.05,
            contact_height_mm: 1.5,
            deflection_um: 40.0,
            dx_um: 24.0,
            dy_um: -32.0,
            tip_deflection_um: 50.0,
            stress_mpa: 300.0,
        };
        let h = l.scaled(0.25);
        assert_eq!(
            (h.force_n, h.fx_n, h.fy_n, h.fz_n, h.power_w, h.torque_nm),
            (2.5, 1.5, -2.0, 0.625, 25.0, 0.05)
        );
        assert_eq!(
            (
                h.deflection_um,
                h.dx_um,
                h.dy_um,
                h.tip_deflection_um,
                h.stress_mpa
            ),
            (10.0, 6.0, -8.0, 12.5, 75.0)
        );
        assert_eq!((h.chip_thickness_mm, h.contact_height_mm), (0.05, 1.5));
    }

    /// A uniform cantilever (L 80, d 10, E 210 000) loaded at the tip, no
    /// torque: σ = F L/(π d³/32) reaches σ_R = 3000 MPa at F_R = σ_R π d³/(32 L)
    /// = 3681.55 N, and the tip deflection at rupture is
    /// F_R L³/(3EI) = σ_R L²/(3 E d/2) = 6.0952 mm, whatever the load beyond.
    #[test]
    fn a_load_past_rupture_reports_the_deflection_at_rupture() {
        let beam = SteppedBeam::uniform(&Cantilever {
            stickout_mm: 80.0,
            effective_diameter_mm: 10.0,
            youngs_modulus_mpa: 210_000.0,
        });
        let rupture = 3000.0;
        let f_r = rupture * std::f64::consts::PI * 1000.0 / (32.0 * 80.0);
        let at = |f: f64| {
            let d = 1000.0 * beam.deflection_mm(f, 0.0, 0.0);
            StepLoad {
                force_n: f,
                fx_n: f,
                deflection_um: d,
                dx_um: d,
                tip_deflection_um: d,
                stress_mpa: beam.peak_stress_mpa(&[(0.0, f)], 0.0),
                ..StepLoad::default()
            }
        };
        // δ_R = σ_R·L²/(3E·d/2) = 6 095.238 µm.
        let closed_um = 1000.0 * rupture * 80.0 * 80.0 / (3.0 * 210_000.0 * 5.0);
        // The closed-form crossing: just under F_R nothing changes (bit for bit),
        // just over it and far past it the deflection is the one at rupture.
        let under = at(f_r * (1.0 - 1e-9));
        assert!(!under.breaks(rupture));
        assert_eq!(under.at_rupture(rupture), under);
        assert_eq!(under.linear_deflection_um(rupture), under.deflection_um);
        for f in [f_r * (1.0 + 1e-9), 2.0 * f_r, 1e3 * f_r] {
            let l = at(f);
            assert!(l.breaks(rupture), "{f} N");
            let r = l.at_rupture(rupture);
            for d in [r.deflection_um, r.dx_um, r.tip_deflection_um] {
                assert!((d - closed_um).abs() < 1e-9 * closed_um, "{f} N: {d} µm");
            }
            assert_eq!((r.force_n, r.stress_mpa), (l.force_n, l.stress_mpa));
            assert!(
                (r.linear_deflection_um(rupture) - l.deflection_um).abs() < 1e-12 * l.deflection_um
            );
        }
    }
    use crate::beam::Cantilever;

    fn model(force_model: ForceModel) -> CuttingModel {
        CuttingModel {
            force_model,
            spindle_rpm: 6000.0,
            flutes: 2,
            tool_radius_mm: 5.0,
            band_height_mm: 1.0,
            beam: SteppedBeam::uniform(&Cantilever {
                stickout_mm: 80.0,
                effective_diameter_mm: 10.0,
                youngs_modulus_mpa: 210_000.0,
            }),
            edge: EdgeShape::flat(5.0),
            helix_deg: 30.0,
        }
    }

    const S4: ForceModel = ForceModel::PowerLaw { a: 800.0, n: 0.72 };

    /// The compliance over the bands that removed something
    /// ([`CutBands`]) is the sum over every band of the flute that removed
    /// something, bit for bit: bands cut at the bottom, in the middle and at
    /// the top of an 80-band flute, with bands between that removed
    /// nothing, none cut, at heights along and beyond the flute.
    #[test]
    fn compliance_over_the_cut_bands_is_over_every_band() {
        let m = model(S4);
        let every_band = |bands: &[f64], at: f64| -> f64 {
            let total: f64 = bands.iter().filter(|v| **v > 0.0).sum();
            if total <= 0.0 {
                return m.beam.deflection_mm(1.0, 0.0, at);
            }
            bands
                .iter()
                .enumerate()
                .filter(|(_, v)| **v > 0.0)
                .map(|(k, v)| {
                    let mid_mm = (k as f64 + 0.5) * m.band_height_mm;
                    m.beam.deflection_mm(v / total, mid_mm, at)
                })
                .sum()
        };
        let mut seed = 5u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..200 {
            let mut bands = vec![0.0; 80];
            let (lo, len) = ((next() * 80.0) as usize, 1 + (next() * 6.0) as usize);
            for band in &mut bands[lo..(lo + len).min(80)] {
                // Some bands between remove nothing.
                *band = if next() < 0.3 { 0.0 } else { next() * 0.2 };
            }
            if case % 20 == 0 {
                bands.fill(0.0);
            }
            for at in [0.0, 0.5, 3.7, 41.5, 79.5, 120.0] {
                let (got, want) = (m.compliance_at_mm_per_n(&bands, at), every_band(&bands, at));
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "case {case} at {at}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn direction_is_opposite_the_contact_resultant() {
        // Material on +x of the tool pushes it towards −x.
        assert_eq!(force_direction([2.0, 0.0, 0.0]), [-1.0, 0.0]);
        let [x, y] = force_direction([3.0, -4.0, 7.0]);
        assert!((x + 0.6).abs() < 1e-15 && (y - 0.8).abs() < 1e-15);
        assert_eq!(force_direction([0.0, 0.0, 5.0]), [0.0, 0.0]);
        assert_eq!(force_direction([f64::NAN, 0.0, 0.0]), [0.0, 0.0]);
    }

    #[test]
    fn power_law_step_load_by_hand() {
        let m = model(S4);
        // 2 flutes · 6000 rpm · 0.016 s / 60 = 3.2 tooth passes; 1.6 mm³ → V = 0.5 mm³.
        // F = 800 · 0.5^0.72 = 485.67795 N, split 3:1 over bands 0 and 2 (mid-heights 0.5, 2.5).
        let bands = [0.3, 0.0, 0.1];
        let load = m.step_load(&StepRemoval {
            volume_mm3: 1.6,
            band_volumes_mm3: &bands,
            contact_resultant: [0.0, 1.0],
            dt_s: 0.016,
            ..StepRemoval::default()
        });
        let f = 800.0 * 0.5f64.powf(0.72);
        assert!((load.force_n - f).abs() < 1e-9);
        assert!(load.fx_n.abs() < 1e-12 && (load.fy_n + f).abs() < 1e-9);
        // Contact height: (0.3 · 0.5 + 0.1 · 2.5) / 0.4 = 1.0 mm.
        assert!((load.contact_height_mm - 1.0).abs() < 1e-12);
        let at = |x: f64| {
            1000.0
                * m.beam
                    .deflection_from_band_loads(&[(0.5, 0.75 * f), (2.5, 0.25 * f)], x)
        };
        assert!((load.deflection_um - at(1.0)).abs() < 1e-9);
        assert!((load.tip_deflection_um - at(0.0)).abs() < 1e-9);
        assert!(load.dx_um.abs() < 1e-12 && (load.dy_um + load.deflection_um).abs() < 1e-12);
        // Power F·ω·R: 485.678 · 628.3185 · 5 / 1000 = 1525.8 W; torque F·R = 2.428 N·m.
        assert!((load.power_w - f * 200.0 * std::f64::consts::PI * 5.0 / 1000.0).abs() < 1e-9);
        assert!((load.torque_nm - f * 0.005).abs() < 1e-12);
    }

    #[test]
    fn kienzle_full_slot_by_hand() {
        let k = Kienzle {
            kc1_1_mpa: 1500.0,
            mc: 0.22,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let m = model(ForceModel::Kienzle(k));
        // Full slot, R = 5, a_p = 2, f = 0.32 mm per step (3.2 tooth passes → f_z = 0.1):
        // V = 2R·a_p·f = 6.4 mm³, edge area Σ dV/h = a_p·R·π·(per step) → V/E = 2f/π,
        // C = a_p R f · π/2 along the feed (+x) per step... scaled to V: C = V·π/4 x̂.
        let (v, f) = (6.4, 0.32);
        let edge = v / (2.0 * f / std::f64::consts::PI);
        let c = [v * std::f64::consts::PI / 4.0, 0.0];
        // From the aggregates (§3.2), and from the bands' arcs (§3.4: the
        // columns at −4.95…4.95 mm on a 0.1 mm grid, the whole half circle).
        let offsets = [[-4.95f32, 4.95]; 2];
        for (band_offsets_mm, feed_dir) in [(&[][..], [0.0, 0.0]), (&offsets[..], [1.0, 0.0])] {
            let load = m.step_load(&StepRemoval {
                volume_mm3: v,
                band_volumes_mm3: &[3.2, 3.2],
                contact_resultant: c,
                chip_edge_area_mm2: edge,
                volume_over_radius_mm2: v / 5.0,
                dt_s: 0.016,
                band_offsets_mm,
                feed_dir,
                len_xy_mm: 0.32,
                cell_mm: 0.1,
            });
            let hm = 2.0 * 0.1 / std::f64::consts::PI;
            assert!((load.chip_thickness_mm - hm).abs() < 1e-12);
            let kc = 1500.0 * hm.powf(-0.22);
            assert!((load.power_w - kc * v / 0.016 / 1000.0).abs() < 1e-9);
            // Altintas' mean slot forces per tooth pass: F_y = z a_p f_z K_t / 4, F_x = −k_r F_y.
            let fy = 2.0 * 2.0 * 0.1 * kc / 4.0;
            // (1e-6: the offsets are f32, so the arc misses π by ~1e-7.)
            assert!((load.fy_n - fy).abs() < 1e-6 * fy, "{} vs {fy}", load.fy_n);
            assert!((load.fx_n + 0.3 * fy).abs() < 1e-6 * fy);
            // Torque = P/ω; mean tangential force = T / R; axial = k_a · that,
            // on the tool toward −Z (out of the holder).
            let ft = load.torque_nm * 1000.0 / 5.0;
            assert!(load.fz_n < 0.0 && (load.fz_n + 0.25 * ft).abs() < 1e-6 * ft);
            assert!(load.stress_mpa > 0.0);
            if feed_dir[0] > 0.0 {
                // Two flutes at 30°: the peak is above the mean, below the
                // straight-flute peak K_t a_p f_z √(1 + k_r²).
                let straight = kc * 2.0 * 0.1 * (1.0f64 + 0.09).sqrt();
                assert!(load.force_peak_n > load.force_n && load.force_peak_n < straight);
            } else {
                assert_eq!(load.force_peak_n, load.force_n);
            }
        }
    }

    /// Kienzle's s50c-like law of the tests below: kc1_1 1500, mc 0.22,
    /// k_r 0.3, k_a 0.25.
    const KIENZLE: Kienzle = Kienzle {
        kc1_1_mpa: 1500.0,
        mc: 0.22,
        radial_ratio: 0.3,
        axial_ratio: 0.25,
    };

    /// A flat Ø10 slot step along +X of [`model`]: f = 0.32 mm a step,
    /// 1.6 revolutions (f_z 0.1), mean chip 2 f_z/π, `bands` of volume with
    /// their `offsets`, the contact's share along the feed `along`.
    fn slot_removal<'a>(bands: &'a [f64], offsets: &'a [[f32; 2]], along: f64) -> StepRemoval<'a> {
        let (pi, f) = (std::f64::consts::PI, 0.32);
        let v: f64 = bands.iter().sum();
        StepRemoval {
            volume_mm3: v,
            band_volumes_mm3: bands,
            contact_resultant: [v * along, 0.0],
            chip_edge_area_mm2: v / (2.0 * f / pi),
            volume_over_radius_mm2: v / 5.0,
            dt_s: 0.016,
            band_offsets_mm: offsets,
            feed_dir: [1.0, 0.0],
            len_xy_mm: f,
            cell_mm: 0.1,
        }
    }

    /// A band whose columns reach both flanks is a slot over the part of
    /// its height its volume fills where the step's contact lies along the
    /// feed as a slot's does (π/4), slivers at both flanks where it lies as
    /// theirs does, and arcs between for a contact between; above a band cut
    /// across the whole width it is the top of a slot whatever the contact
    /// (MODEL.md §3.4).
    #[test]
    fn a_band_at_both_flanks_is_a_slot_or_two_slivers_by_the_contact() {
        let m = model(ForceModel::Kienzle(KIENZLE));
        let pi = std::f64::consts::PI;
        let kc = 1500.0 * (2.0 * 0.1 / pi).powf(-0.22);
        let c = Coefficients {
            kt_mpa: kc,
            radial_ratio: 0.3,
            axial_ratio: 0.25,
        };
        let removal = slot_removal;
        const SLOT: [[f32; 2]; 2] = [[-4.95, 4.95]; 2];
        // Half a slot's volume in band 0 (1.6 mm³ = 2R · 0.5 · f), contact
        // along the feed as a slot's: a slot 0.5 mm deep, Altintas'
        // F_y = N a_p f_z K_t / 4.
        let fy = |ap: f64| 2.0 * ap * 0.1 * kc / 4.0;
        let slot = m.step_load(&removal(&[1.6], &SLOT, pi / 4.0));
        assert!(
            (slot.fy_n - fy(0.5)).abs() < 1e-6 * fy(0.5),
            "{}",
            slot.fy_n
        );
        assert!((slot.fx_n + 0.3 * fy(0.5)).abs() < 1e-6 * fy(0.5));
        // The same volume with the contact of two 2.5 mm slivers at the
        // flanks: those slivers, at the motion's f_z (their arcs remove the
        // volume at it).
        let slivers = BandArc::from_offsets(&m.edge, 0.0, 1.0, [-4.95, 4.95], 0.1, 5.0);
        let along = BandArc::forward_share(&slivers);
        assert!(along < pi / 4.0 - 0.1);
        let two = m.step_load(&removal(&[1.6], &SLOT, along));
        let expected = slivers
            .iter()
            .flatten()
            .map(|a| mean_cut(&m.edge, 2, a, 0.1, &c).force_n[1])
            .sum::<f64>();
        assert!(
            (two.fy_n - expected).abs() < 1e-6 * fy(0.5),
            "{} vs {expected}",
            two.fy_n
        );
        assert!((two.fy_n - slot.fy_n).abs() > 0.1 * slot.fy_n);
        // A contact halfway between: arcs between the slivers' and the
        // slot's, and so is the force.
        let mid = m.step_load(&removal(&[1.6], &SLOT, 0.5 * (along + pi / 4.0)));
        let (lo, hi) = (two.fy_n.min(slot.fy_n), two.fy_n.max(slot.fy_n));
        assert!(
            mid.fy_n > lo && mid.fy_n < hi,
            "{} not in {lo}…{hi}",
            mid.fy_n
        );
        // Above a whole band (1 mm slot, 3.2 mm³): the top of a 1.5 mm slot
        // even with the slivers' contact.
        let top = m.step_load(&removal(&[3.2, 1.6], &SLOT, along));
        assert!((top.fy_n - fy(1.5)).abs() < 1e-6 * fy(1.5), "{}", top.fy_n);
    }

    /// A band with volume but no offsets (a neighbour's share of a column)
    /// adds its share of §3.2's mean to the arcs', so that a sliver moves
    /// the step's force by its share, not to another model.
    #[test]
    fn a_band_without_arcs_takes_its_share_of_the_aggregate_mean() {
        let m = model(ForceModel::Kienzle(KIENZLE));
        let pi = std::f64::consts::PI;
        let revs = 1.6;
        let kc = 1500.0 * (2.0 * 0.1 / pi).powf(-0.22);
        let removal = |bands, offsets| slot_removal(bands, offsets, pi / 4.0);
        const SLOT: [[f32; 2]; 1] = [[-4.95, 4.95]];
        // A whole 1 mm slot in band 0, then the same with a 0.1 % sliver in
        // band 1 that has no offsets.
        const EMPTY: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];
        const WITH_SLIVER: [[f32; 2]; 2] = [[-4.95, 4.95], EMPTY];
        let slot = m.step_load(&removal(&[3.2], &SLOT));
        let sliver = 0.0032;
        let with = m.step_load(&removal(&[3.2, sliver], &WITH_SLIVER));
        // §3.2's mean of the whole step: F_t = kc (V/R) / (2π revs) along
        // ẑ × C, radial −k_r C (C along +x): F_y = F_t |C|/V, F_x = −k_r F_y.
        let v = 3.2 + sliver;
        let ft = kc * (v / 5.0) / (2.0 * pi * revs);
        let aggregate_fy = ft * pi / 4.0;
        let share = sliver / v;
        let expected = 2.0 * 1.0 * 0.1 * kc / 4.0 + share * aggregate_fy;
        assert!(
            (with.fy_n - expected).abs() < 1e-6 * expected,
            "{} vs {expected}",
            with.fy_n
        );
        assert!((with.fy_n - slot.fy_n).abs() < 2.0 * share * slot.fy_n);
        assert!(with.force_peak_n > slot.force_peak_n);
        assert!(with.force_peak_n - slot.force_peak_n < 2.0 * share * slot.force_n);
    }

    /// `step_load_bounded` is `step_load` bit for bit but for the peak and
    /// the stress, which it bounds from above: on the slots, slivers, arcs
    /// between, a band without arcs, a step without feed and S4's law of
    /// the tests above; and the bound is no more than twice the peak there.
    #[test]
    fn a_bounded_load_is_the_load_with_its_peak_and_stress_bounded() {
        let pi = std::f64::consts::PI;
        const SLOT: [[f32; 2]; 2] = [[-4.95, 4.95]; 2];
        const EMPTY: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];
        const WITH_SLIVER: [[f32; 2]; 2] = [[-4.95, 4.95], EMPTY];
        const SIDE: [[f32; 2]; 2] = [[3.05, 4.95]; 2];
        let kienzle = model(ForceModel::Kienzle(KIENZLE));
        let s4 = model(S4);
        let mut cases = vec![
            (&kienzle, slot_removal(&[1.6], &SLOT, pi / 4.0)),
            (&kienzle, slot_removal(&[1.6], &SLOT, 0.2)),
            (&kienzle, slot_removal(&[1.6], &SLOT, 0.5)),
            (&kienzle, slot_removal(&[3.2, 1.6], &SLOT, 0.2)),
            (
                &kienzle,
                slot_removal(&[3.2, 0.0032], &WITH_SLIVER, pi / 4.0),
            ),
            (&kienzle, slot_removal(&[0.9, 0.9], &SIDE, 0.3)),
            (&s4, slot_removal(&[1.6], &SLOT, pi / 4.0)),
        ];
        let mut plunge = slot_removal(&[1.6], &SLOT, pi / 4.0);
        plunge.feed_dir = [0.0, 0.0];
        cases.push((&kienzle, plunge));
        for (i, (m, r)) in cases.iter().enumerate() {
            let (exact, bounded) = (m.step_load(r), m.step_load_bounded(r));
            assert!(exact.force_peak_n > 0.0, "case {i}");
            assert!(
                bounded.force_peak_n >= exact.force_peak_n
                    && bounded.force_peak_n <= 2.0 * exact.force_peak_n
                    && bounded.stress_mpa >= exact.stress_mpa,
                "case {i}: {bounded:?} against {exact:?}"
            );
            let others = |l: StepLoad| StepLoad {
                force_peak_n: 0.0,
                stress_mpa: 0.0,
                ..l
            };
            assert_eq!(others(bounded), others(exact), "case {i}");
            assert_eq!(
                m.mean_deflection_um(r),
                [bounded.dx_um, bounded.dy_um],
                "case {i}"
            );
        }
    }

    #[test]
    fn air_cut_and_empty_bands() {
        let m = model(S4);
        let nothing = StepRemoval {
            dt_s: 0.016,
            ..StepRemoval::default()
        };
        assert_eq!(m.step_load(&nothing), StepLoad::default());
        // Volume but no band breakdown: the force acts at the tip.
        let load = m.step_load(&StepRemoval {
            volume_mm3: 1.6,
            contact_resultant: [-1.0, 0.0],
            dt_s: 0.016,
            ..StepRemoval::default()
        });
        let tip_um = 1000.0 * m.beam.deflection_mm(load.force_n, 0.0, 0.0);
        assert!((load.dx_um - tip_um).abs() < 1e-9);
    }

    #[test]
    fn feed_for_limit_inverts_the_power_law() {
        let m = model(S4);
        // Q(1000) = 50 grows like F^0.72: Q(F) = 80 at F = 1000 · 1.6^(1/0.72).
        let f = m.feed_for_limit(50.0, 1000.0, 80.0);
        assert!((50.0 * (f / 1000.0).powf(0.72) - 80.0).abs() < 1e-9);
        assert_eq!(m.feed_for_limit(0.0, 1000.0, 80.0), f64::INFINITY);
    }
}
