//! Work materials and their force-law coefficients.

use serde::Serialize;

use crate::kienzle::Kienzle;

/// Ratios of the radial and axial to the tangential force used for every built-in material
/// (MODEL.md §3.2): between aluminium's 0.21 / 0.28 (Altintas, *Manufacturing Automation*,
/// Al7075-T6 with a 30° helix end mill: K_tc 796, K_rc 168, K_ac 222 N/mm²) and steels' ≈ 0.4.
pub const RADIAL_RATIO: f64 = 0.3;
/// Axial over tangential force for every built-in material (see [`RADIAL_RATIO`]).
pub const AXIAL_RATIO: f64 = 0.25;

/// A work material with the coefficients of S4's force law `F = a · V^n`
/// (F in N, V = removed volume per tooth per revolution in mm³).
///
/// The built-in values ([`Material::ALL`]) are **starting points to be calibrated** on the
/// machine, tool and coolant at hand (fit measured forces with
/// [`crate::calibration::fit_force_law`]). They were chosen so that a typical finishing chip of
/// V ≈ 0.1 mm³ gives tens of newtons and a roughing chip of V ≈ 1 mm³ gives a few hundred, with
/// `a` roughly following the specific cutting energy of the material (aluminium ≈ 0.7 J/mm³,
/// carbon steel ≈ 2.5, hardened tool steel ≈ 3.5, titanium ≈ 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Material {
    /// Short identifier used to look the material up, e.g. `"s50c"`.
    pub name: &'static str,
    /// `a` in `F = a · V^n`: force in N for V = 1 mm³ per tooth per revolution.
    pub force_coef_a: f64,
    /// `n` in `F = a · V^n` (dimensionless, typically 0.6–0.8).
    pub force_exp_n: f64,
    /// Kienzle's specific cutting force (MODEL.md §3.2).
    pub kienzle: Kienzle,
    /// Where the Kienzle values come from.
    pub kienzle_source: &'static str,
}

/// ISCAR, *Turning tools* catalogue 2017, "Material groups according to DIN/ISO 513 and
/// VDI 3323", kc1 (N/mm², for a 1 mm² chip of 1 mm thickness) and mc per group.
const ISCAR_VDI3323: &str =
    "ISCAR turning catalogue 2017, material groups after DIN/ISO 513 and VDI 3323";

/// Where al6061's Kienzle values come from (MODEL.md §3.3).
const AL6061_MILLING: &str = "milling sources for 6061-T6 (MODEL.md 3.3): Al6082-T6 measured \
     slot coefficients, Mitsubishi Materials' and Tungaloy's milling Kc tables; mc from VDI 3323";

const fn kienzle(kc1_1_mpa: f64, mc: f64) -> Kienzle {
    Kienzle {
        kc1_1_mpa,
        mc,
        radial_ratio: RADIAL_RATIO,
        axial_ratio: AXIAL_RATIO,
    }
}

impl Material {
    /// Aluminium alloy 6061-T6.
    pub const AL6061: Material = Material {
        name: "al6061",
        force_coef_a: 250.0,
        force_exp_n: 0.70,
        // Milling data, not VDI 3323 group 22's turning value (800, mc 0.25: 1.9× the
        // milling sources at h = 0.1 mm). kc1_1 425 with VDI's mc 0.25 gives 756 N/mm² at
        // h = 0.1 mm and 899 at 0.05: Al6082-T6's measured slot coefficients 761 and 891,
        // Mitsubishi's milling Kc at f_z 0.1 interpolated to 6061-T6's 310 MPa 753, the
        // median of the ten milling sources at 0.1 mm 770 (MODEL.md §3.3).
        kienzle: kienzle(425.0, 0.25),
        kienzle_source: AL6061_MILLING,
    };
    /// Carbon steel S50C (JIS; ≈ C50 / AISI 1050), annealed, ≈ 200 HB.
    pub const S50C: Material = Material {
        name: "s50c",
        force_coef_a: 800.0,
        force_exp_n: 0.72,
        // VDI 3323 group 2, non-alloy steel ≥ 0.25 % C annealed (C45/C50, 190 HB): kc1 1500, mc 0.22.
        kienzle: kienzle(1500.0, 0.22),
        kienzle_source: ISCAR_VDI3323,
    };
    /// Pre-hardened tool steel, ≈ 40 HRC (e.g. NAK80, P20 class).
    pub const TOOL_STEEL_40HRC: Material = Material {
        name: "tool-steel-40hrc",
        force_coef_a: 1100.0,
        force_exp_n: 0.75,
        // VDI 3323 group 11, high-alloy and tool steel quenched and tempered (1100 N/mm²,
        // 325 HB ≈ 35 HRC, the nearest group to 40 HRC): kc1 2500, mc 0.23.
        kienzle: kienzle(2500.0, 0.23),
        kienzle_source: ISCAR_VDI3323,
    };
    /// Titanium alloy Ti-6Al-4V.
    pub const TI6AL4V: Material = Material {
        name: "ti6al4v",
        force_coef_a: 950.0,
        force_exp_n: 0.75,
        // VDI 3323 group 37, α+β titanium alloys (Rm 1050 N/mm²): kc1 2110, mc 0.22.
        kienzle: kienzle(2110.0, 0.22),
        kienzle_source: ISCAR_VDI3323,
    };

    /// The built-in table.
    pub const ALL: &'static [Material] = &[
        Material::AL6061,
        Material::S50C,
        Material::TOOL_STEEL_40HRC,
        Material::TI6AL4V,
    ];

    /// Looks a built-in material up by [`Material::name`], ignoring ASCII case.
    pub fn by_name(name: &str) -> Option<&'static Material> {
        Material::ALL
            .iter()
            .find(|m| m.name.eq_ignore_ascii_case(name))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_by_name() {
        assert_eq!(Material::by_name("S50C"), Some(&Material::S50C));
        assert_eq!(Material::by_name("unobtainium"), None);
        for m in Material::ALL {
            assert_eq!(Material::by_name(m.name), Some(m));
            assert!(m.force_coef_a > 0.0 && (0.5..=1.0).contains(&m.force_exp_n));
            assert!(
                (300.0..3000.0).contains(&m.kienzle.kc1_1_mpa)
                    && (0.1..0.4).contains(&m.kienzle.mc)
            );
        }
    }

    /// al6061 against the milling sources nearest 6061-T6 (MODEL.md §3.3): the cutting
    /// coefficients fitted to measured slot forces in Al6082-T6, K_tc + K_te/h = 631 + 13/h
    /// N/mm² (891 and 761 at h 0.05 and 0.1 mm), and Mitsubishi Materials' milling Kc at
    /// f_z 0.1 mm interpolated by tensile strength between Al-Si (200 MPa, 700 N/mm²) and
    /// Al-Zn-Mg-Cu (570 MPa, 880) to 6061-T6's 310 MPa. The turning catalogue's 800 N/mm²
    /// was 1.9× the first.
    #[test]
    fn al6061_matches_the_milling_data() {
        let k = Material::AL6061.kienzle;
        for h in [0.05, 0.1] {
            let measured = 631.0 + 13.0 / h;
            let kc = k.specific_force_mpa(h);
            assert!(
                (kc / measured - 1.0).abs() < 0.01,
                "h {h}: {kc} vs {measured}"
            );
        }
        let mitsubishi = 700.0 + (310.0 - 200.0) / (570.0 - 200.0) * (880.0 - 700.0);
        let kc = k.specific_force_mpa(0.1);
        assert!((kc / mitsubishi - 1.0).abs() < 0.01, "{kc} vs {mitsubishi}");
    }
}
