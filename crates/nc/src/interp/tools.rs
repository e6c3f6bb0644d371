//! Tools: numbers checked against the tool table, diameters and lengths,
//! tool changes (M6, M61) and tool length offsets (G43, G43.1, G43.2, G49).

use super::block::g_group;
use super::{fail, Block, Fail, Interp};
use crate::gcode::GCode;
use crate::path::{Geometry, Motion};

impl Interp<'_> {
    /// A T or Q value as a tool number, checked against the tool table.
    pub(super) fn tool_number(&self, v: f64, col: u32, letter: char) -> Result<u32, Fail> {
        if v < 0.0 || v.fract() != 0.0 || v > 1e9 {
            return fail(
                col,
                format!("{letter}{v} is not a tool number (an integer from 0)"),
            );
        }
        let t = v as u32;
        let table = &self.options.tool_lengths_mm;
        if t != 0 && !table.is_empty() && !table.contains_key(&t) {
            let known: Vec<String> = table.keys().map(|k| format!("T{k}")).collect();
            return fail(
                col,
                format!(
                    "tool T{t} is not in the job's tool table (it has {})",
                    known.join(", ")
                ),
            );
        }
        Ok(t)
    }

    /// Diameter of tool `t` (mm).
    pub(super) fn diameter_of(&self, t: u32) -> f64 {
        self.options
            .tool_diameters_mm
            .get(&t)
            .copied()
            .unwrap_or(self.options.default_tool_diameter_mm)
    }

    /// Gauge length of tool `t` (mm); 0 for T0 and without a table.
    fn length_of(&self, t: u32) -> f64 {
        self.options.tool_lengths_mm.get(&t).copied().unwrap_or(0.0)
    }

    /// M6 / M61: puts tool `t` in the spindle. The gauge point stays; if the
    /// tip moves (another length), a rapid from the old tip to the new one
    /// records the change (MODEL.md §9.1).
    pub(super) fn load_tool(&mut self, t: u32, pc: usize) {
        self.first_loaded.get_or_insert(t);
        self.toolchange_pending = true;
        if t == self.tool {
            return;
        }
        let old_tip = self.last_tip;
        let old_length = self.tool_length_mm;
        self.tool = t;
        self.tool_length_mm = self.length_of(t);
        let mut new_tip = old_tip;
        new_tip.z += old_length - self.tool_length_mm;
        if old_tip != new_tip {
            self.emit(old_tip, new_tip, Geometry::Line, Motion::Rapid, pc);
        }
    }

    /// G43 [H], G43.1, G43.2 and G49 (LinuxCNC's `convert_tool_length_offset`).
    pub(super) fn tool_length_offset(&mut self, b: &Block) -> Result<(), Fail> {
        let code = b.g.iter().find(|g| g_group(g.0) == Some(8)).copied();
        if b.get('h').is_some() && !matches!(code, Some((GCode::G43 | GCode::G43_2, _))) {
            return fail(b.col('h'), "H word with no G43 to use it");
        }
        let Some((code, col)) = code else {
            return Ok(());
        };
        if self.comp.side.is_some() {
            return fail(
                col,
                "cannot change tool offset with cutter radius compensation on",
            );
        }
        let h_tool = |it: &Self| -> Result<u32, Fail> {
            match b.get('h') {
                None => Ok(it.tool),
                Some(h) => {
                    let t = it.tool_number(h, b.col('h'), 'H')?;
                    Ok(if t == 0 { it.tool } else { t })
                }
            }
        };
        match code {
            GCode::G49 => {
                self.tlo_mm = [0.0; 3];
                self.tlo_on = false;
            }
            GCode::G43 => {
                let t = h_tool(self)?;
                self.tlo_mm = [0.0, 0.0, self.length_of(t)];
                self.tlo_on = true;
            }
            GCode::G43_1 | GCode::G43_2 => {
                if code == GCode::G43_2 && b.get('h').is_some() {
                    if b.has_axes() {
                        return fail(col, "G43.2: cannot have both H and axis words");
                    }
                    let t = h_tool(self)?;
                    self.tlo_mm[2] += self.length_of(t);
                } else {
                    if code == GCode::G43_2 && !b.has_axes() {
                        return fail(col, "G43.2: no axes specified and H word missing");
                    }
                    for (i, l) in ['x', 'y', 'z'].into_iter().enumerate() {
                        if let Some(v) = b.get(l) {
                            let v = v * self.scale;
                            self.tlo_mm[i] = if code == GCode::G43_1 {
                                v
                            } else {
                                self.tlo_mm[i] + v
                            };
                        }
                    }
                }
                self.tlo_on = true;
            }
            _ => {}
        }
        Ok(())
    }
}
