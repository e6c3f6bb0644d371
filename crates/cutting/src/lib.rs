//! Cutting physics of S4: removed volume → cutting force → tool deflection → shape error.
//!
//! Everything here takes values and returns values (no I/O, no allocation per step):
//!
//! * [`material`]: force-law coefficients `F = a · V^n` per work material, starting points to be
//!   calibrated with [`calibration::fit_force_law`] (and Kienzle's with [`calibration::fit_kienzle`]).
//! * [`chipload`]: the largest feed per tooth by tool diameter and material, and its feed cap.
//! * [`force`]: volume per tooth per revolution and the force law.
//! * [`kienzle`]: Kienzle's specific cutting force and the mean chip thickness of milling.
//! * [`beam`]: the tool as a cantilever clamped in the holder (uniform, and stepped: flutes,
//!   shank, holder spring); point loads, band loads and the stress at the holder.
//! * [`tooth`]: forces through one tooth period from each band's engaged arc (mean, peak).
//! * [`load`]: per step of the sweep, force magnitude and direction and the tool's deflection.
//! * [`surface`]: projection of the deflection on the final surface's normal (error map) and
//!   normals of a height field.
//!
//! In: per step of the sweep what it removed ([`StepRemoval`]: volume, height bands, contact
//! resultant) and the tool, material and spindle ([`CuttingModel`]). Out: the step's load
//! ([`StepLoad`]: force, power, deflection, stress), and from deflections the shape error
//! along a surface normal. In the pipeline of the `dexcut` library
//! (job → stock (`dexel`, `mesh`) + program (`nc`) → motion (`schedule`) → sweep (`dexel`) →
//! loads (`cutting`) → outputs (`export`)) this crate is the loads stage; it depends on no
//! other crate of the workspace. S4 and the other sources are listed in docs/MODEL.md.
//!
//! Units (MODEL.md): mm, s, N, MPa (= N/mm²); deflections in reports in µm.
#![warn(missing_docs)]

pub mod beam;
pub mod calibration;
pub mod chipload;
pub mod force;
pub mod kienzle;
pub mod load;
pub mod material;
pub mod surface;
pub mod tooth;

pub use beam::{Cantilever, SteppedBeam};
pub use calibration::{fit_force_law, fit_kienzle, Cut, Fit, FitError, KienzleFit, Milling};
pub use force::{force_n, volume_per_tooth_at_force_mm3, volume_per_tooth_mm3};
pub use kienzle::{mean_chip_thickness_mm, Kienzle};
pub use load::{force_direction, CuttingModel, ForceModel, StepLoad, StepRemoval};
pub use material::Material;
pub use surface::{surface_error_um, surface_normal_at, surface_normals_from_heights};
pub use tooth::{BandArc, Coefficients, EdgeShape, Teeth};
