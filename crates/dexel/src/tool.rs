//! Cutting tools: the shape of the cutting end and the beam data physics needs.

use crate::Error;

/// Shape of the cutting end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToolShape {
    /// Ball-end mill: corner radius = diameter / 2.
    Ball,
    /// Flat-end mill: corner radius 0.
    Flat,
    /// Bull-nose (torus) mill with corner radius in (0, diameter/2).
    Bull {
        /// Radius of the torus' tube, mm.
        corner_radius_mm: f64,
    },
}

/// A milling tool. The sweep treats the tool as its cutting end plus a
/// cylinder of the same diameter above it, reaching up indefinitely (shank and
/// holder are not modelled separately; material removed above the flute length
/// is reported as shank contact).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tool {
    /// Shape of the cutting end.
    pub shape: ToolShape,
    /// Cutting diameter, mm.
    pub diameter_mm: f64,
    /// Length of the fluted part above the tip.
    pub flute_length_mm: f64,
    /// Length from the holder face to the tip (cantilever length).
    pub stickout_mm: f64,
    /// Number of cutting edges (teeth).
    pub flutes: u32,
    /// Young's modulus of the tool material, MPa (N/mm²).
    pub youngs_modulus_mpa: f64,
    /// Effective diameter of the fluted part for the beam model, mm.
    pub effective_diameter_mm: f64,
}

impl Tool {
    /// Ball-end mill with common defaults for the beam data (carbide, 80 % effective diameter).
    pub fn ball(diameter_mm: f64) -> Tool {
        Tool {
            shape: ToolShape::Ball,
            diameter_mm,
            flute_length_mm: 2.0 * diameter_mm,
            stickout_mm: 8.0 * diameter_mm,
            flutes: 2,
            youngs_modulus_mpa: 600_000.0,
            effective_diameter_mm: 0.8 * diameter_mm,
        }
    }

    /// Same defaults with a flat end.
    pub fn flat(diameter_mm: f64) -> Tool {
        Tool {
            shape: ToolShape::Flat,
            ..Tool::ball(diameter_mm)
        }
    }

    /// Same defaults with a bull-nose end.
    pub fn bull(diameter_mm: f64, corner_radius_mm: f64) -> Tool {
        Tool {
            shape: ToolShape::Bull { corner_radius_mm },
            ..Tool::ball(diameter_mm)
        }
    }

    /// Half the diameter, mm.
    pub fn radius_mm(&self) -> f64 {
        0.5 * self.diameter_mm
    }

    /// Reject tools no machine could hold.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |what: &str, v: f64| {
            Err(Error::InvalidParameter(format!(
                "tool {what} must be a positive number, got {v}"
            )))
        };
        for (what, v) in [
            ("diameter_mm", self.diameter_mm),
            ("flute_length_mm", self.flute_length_mm),
            ("stickout_mm", self.stickout_mm),
            ("youngs_modulus_mpa", self.youngs_modulus_mpa),
            ("effective_diameter_mm", self.effective_diameter_mm),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return bad(what, v);
            }
        }
        if self.flutes == 0 {
            return Err(Error::InvalidParameter(
                "tool flutes must be at least 1".into(),
            ));
        }
        if let ToolShape::Bull {
            corner_radius_mm: r,
        } = self.shape
        {
            if !(r > 0.0 && r < self.radius_mm()) {
                return Err(Error::InvalidParameter(format!(
                    "bull-nose corner_radius_mm must lie in (0, diameter/2 = {}), got {r}",
                    self.radius_mm()
                )));
            }
        }
        if self.flute_length_mm > self.stickout_mm {
            return Err(Error::InvalidParameter(format!(
                "tool flute_length_mm ({}) is longer than stickout_mm ({})",
                self.flute_length_mm, self.stickout_mm
            )));
        }
        Ok(())
    }
}
