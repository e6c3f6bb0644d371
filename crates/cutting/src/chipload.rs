//! Chip-load limit: the largest feed per tooth f_z (mm/tooth) a tool may run
//! at, and the feed cap it gives, F ≤ f_z,max · z · n (MODEL.md §2.1).
//!
//! Defaults come from published starting values for solid carbide end mills
//! by diameter and work material (table and sources in MODEL.md §2.1). Between
//! the tabulated diameters the value is interpolated linearly; below the
//! smallest it scales with the diameter (chip load grows about linearly with
//! the diameter at small sizes), above the largest it stays at the last value.

/// Tabulated tool diameters, mm.
pub const DIAMETERS_MM: [f64; 9] = [1.0, 1.5, 3.0, 6.0, 10.0, 12.0, 16.0, 20.0, 25.0];

/// Largest feed per tooth at [`DIAMETERS_MM`], mm/tooth, per material name
/// (the names of [`crate::Material`]).
pub const FZ_MAX_TABLE: [(&str, [f64; 9]); 4] = [
    (
        "al6061",
        [
            0.007, 0.010, 0.025, 0.050, 0.075, 0.090, 0.110, 0.130, 0.150,
        ],
    ),
    (
        "s50c",
        [
            0.003, 0.005, 0.013, 0.025, 0.050, 0.064, 0.080, 0.100, 0.115,
        ],
    ),
    (
        "tool-steel-40hrc",
        [
            0.003, 0.004, 0.010, 0.020, 0.040, 0.050, 0.064, 0.080, 0.090,
        ],
    ),
    (
        "ti6al4v",
        [
            0.0035, 0.005, 0.010, 0.022, 0.038, 0.044, 0.054, 0.063, 0.071,
        ],
    ),
];

/// Default largest feed per tooth, mm/tooth, for a tool of `diameter_mm` in
/// `material`; `None` for a material not in the table.
pub fn default_fz_max_mm(material: &str, diameter_mm: f64) -> Option<f64> {
    let (_, fz) = FZ_MAX_TABLE.iter().find(|(name, _)| *name == material)?;
    let d = &DIAMETERS_MM;
    if diameter_mm <= d[0] {
        return Some(fz[0] * diameter_mm / d[0]);
    }
    for k in 1..d.len() {
        if diameter_mm <= d[k] {
            let u = (diameter_mm - d[k - 1]) / (d[k] - d[k - 1]);
            return Some(fz[k - 1] + u * (fz[k] - fz[k - 1]));
        }
    }
    Some(fz[d.len() - 1])
}

/// Feed cap from a chip load, mm/min: F = f_z · z · n.
pub fn chip_load_feed_mm_min(fz_mm: f64, flutes: u32, spindle_rpm: f64) -> f64 {
    fz_mm * flutes as f64 * spindle_rpm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_points_interpolation_and_ends() {
        let near = |m: &str, d: f64, v: f64| (default_fz_max_mm(m, d).unwrap() - v).abs() < 1e-12;
        assert!(near("al6061", 10.0, 0.075));
        assert!(near("s50c", 3.0, 0.013));
        // Halfway between 10 and 12 mm.
        let v = default_fz_max_mm("s50c", 11.0).unwrap();
        assert!((v - 0.057).abs() < 1e-12, "{v}");
        // Below 1 mm: proportional to the diameter; above 25 mm: the last value.
        assert!((default_fz_max_mm("al6061", 0.5).unwrap() - 0.0035).abs() < 1e-12);
        assert_eq!(default_fz_max_mm("ti6al4v", 40.0), Some(0.071));
        assert_eq!(default_fz_max_mm("wood", 6.0), None);
        // Every material of the force-law table has a chip-load row, increasing with the diameter.
        for m in crate::Material::ALL {
            assert!(default_fz_max_mm(m.name, 6.0).is_some(), "{}", m.name);
        }
        for (_, row) in FZ_MAX_TABLE {
            assert!(row.windows(2).all(|w| w[1] > w[0]));
        }
        // 0.05 mm/tooth × 2 flutes × 10 000 rev/min = 1000 mm/min.
        assert!((chip_load_feed_mm_min(0.05, 2, 10_000.0) - 1000.0).abs() < 1e-9);
    }
}
