//! Canned drilling, tapping and boring cycles G73/G74/G81–G87/G89 expanded
//! into moves, as LinuxCNC's `interp_cycles.cc` does it (XY plane only). All
//! positions in mm, machine frame.

/// One move of an expanded cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CycleMove {
    /// Rapid to (x, y, z).
    Rapid([f64; 3]),
    /// Feed to (x, y, z) at the programmed feed.
    Feed([f64; 3]),
    /// Feed to (x, y, z) at the programmed feed with the feed override
    /// off (G84/G74 tapping: the feed is the tap's pitch times the spindle
    /// speed), held as programmed by any re-timing.
    HeldFeed([f64; 3]),
    /// Dwell in seconds.
    Dwell(f64),
    /// The spindle stops (G86 before its rapid out; G87 oriented to pass
    /// the hole).
    SpindleStop,
    /// The spindle turns again as it did before the cycle.
    SpindleStart,
}

/// Retract step of G73/G83 above the last peck (LinuxCNC: 0.010 in).
const RAPID_DELTA_MM: f64 = 0.254;

use crate::gcode::GCode;

/// A cycle to expand.
#[derive(Clone, Debug)]
pub struct Cycle {
    /// G73, G74, G81–G87 or G89.
    pub code: GCode,
    /// Hole positions (mm), one per repeat.
    pub holes: Vec<[f64; 2]>,
    /// The cycle's initial level: the tool's Z at the first block of the
    /// canned cycle (LinuxCNC's `cycle_il`), mm.
    pub start_z: f64,
    /// The tool's Z now (a later block of the cycle starts where the one
    /// before retracted), mm.
    pub current_z: f64,
    /// R plane, hole bottom (mm).
    pub r_z: f64,
    pub bottom_z: f64,
    /// G98 (true): retract to the start height; G99: to R.
    pub retract_to_start: bool,
    /// Peck depth (G73/G83), mm.
    pub peck_mm: f64,
    /// Dwell at the bottom (G74, G82, G84, G86, G89), s.
    pub dwell_s: f64,
    /// G87: where the tool passes the hole with the spindle stopped, from
    /// the hole's centre (I, J), mm.
    pub back_offset_mm: [f64; 2],
    /// G87: the top of the back bore (K), mm.
    pub back_top_z: f64,
}

/// Expands a cycle; `current_xy` is where the tool is. As LinuxCNC's
/// `convert_cycle_xy` and `CYCLE_MACRO`: below the R plane, the tool first
/// rises to it where it is, unless the cycle's initial level is above R;
/// each hole is entered from the clear height (the initial level under G98,
/// R under G99), the first one from the tool's Z where that is above R.
pub fn expand(c: &Cycle, current_xy: [f64; 2]) -> Vec<CycleMove> {
    let mut moves = Vec::new();
    let (mut old_z, mut current_z) = (c.start_z, c.current_z);
    if old_z < c.r_z {
        moves.push(CycleMove::Rapid([current_xy[0], current_xy[1], c.r_z]));
        old_z = c.r_z;
        current_z = c.r_z;
    }
    let clear_z = if c.retract_to_start { old_z } else { c.r_z };
    for (k, &[x, y]) in c.holes.iter().enumerate() {
        let enter_z = if k == 0 && current_z > c.r_z {
            current_z
        } else {
            clear_z
        };
        moves.push(CycleMove::Rapid([x, y, enter_z]));
        if enter_z > c.r_z {
            moves.push(CycleMove::Rapid([x, y, c.r_z]));
        }
        if c.code == GCode::G87 {
            // Back boring (convert_cycle_g87): through the hole beside its
            // centre with the spindle oriented, feed up to K and back down,
            // out the same way.
            let [i, j] = c.back_offset_mm;
            let (ox, oy) = (x + i, y + j);
            moves.extend([
                CycleMove::Rapid([ox, oy, c.r_z]),
                CycleMove::SpindleStop,
                CycleMove::Rapid([ox, oy, c.bottom_z]),
                CycleMove::Rapid([x, y, c.bottom_z]),
                CycleMove::SpindleStart,
                CycleMove::Feed([x, y, c.back_top_z]),
                CycleMove::Feed([x, y, c.bottom_z]),
                CycleMove::SpindleStop,
                CycleMove::Rapid([ox, oy, c.bottom_z]),
                CycleMove::Rapid([ox, oy, clear_z]),
                CycleMove::Rapid([x, y, clear_z]),
                CycleMove::SpindleStart,
            ]);
            continue;
        }
        if matches!(c.code, GCode::G74 | GCode::G84) {
            // Tapping (convert_cycle_g74_g84): in and out at the held feed,
            // the spindle reversed at the bottom (same speed), out to the
            // clear height.
            moves.extend([
                CycleMove::HeldFeed([x, y, c.bottom_z]),
                CycleMove::Dwell(c.dwell_s),
                CycleMove::HeldFeed([x, y, clear_z]),
            ]);
            continue;
        }
        if c.code == GCode::G73 || c.code == GCode::G83 {
            let mut depth = c.r_z - c.peck_mm;
            while depth > c.bottom_z {
                moves.push(CycleMove::Feed([x, y, depth]));
                if c.code == GCode::G83 {
                    moves.push(CycleMove::Rapid([x, y, c.r_z]));
                }
                moves.push(CycleMove::Rapid([x, y, depth + RAPID_DELTA_MM]));
                depth -= c.peck_mm;
            }
        }
        moves.push(CycleMove::Feed([x, y, c.bottom_z]));
        // LinuxCNC dwells at the bottom of these even for P0 (a stop there).
        if matches!(c.code, GCode::G82 | GCode::G86 | GCode::G89) {
            moves.push(CycleMove::Dwell(c.dwell_s));
        }
        match c.code {
            // Boring, feed out: at the feed to R, then rapid to the clear height.
            GCode::G85 => {
                moves.push(CycleMove::Feed([x, y, c.r_z]));
                moves.push(CycleMove::Rapid([x, y, clear_z]));
            }
            // Boring with a dwell, feed out: at the feed to the clear height.
            GCode::G89 => moves.push(CycleMove::Feed([x, y, clear_z])),
            // Boring, spindle stopped, rapid out (convert_cycle_g86).
            GCode::G86 => moves.extend([
                CycleMove::SpindleStop,
                CycleMove::Rapid([x, y, clear_z]),
                CycleMove::SpindleStart,
            ]),
            _ => moves.push(CycleMove::Rapid([x, y, clear_z])),
        }
    }
    moves
}
