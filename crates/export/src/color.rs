//! Colour scales shared by the PNG maps, the GLB vertex colours and the report,
//! so a value has the same colour everywhere.

/// Which colour gradient a scale uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Palette {
    /// Blue (low) – white (middle) – red (high); for signed values such as
    /// shape errors (positive = material left = red).
    Diverging,
    /// Viridis, dark blue (low) to yellow (high); for unsigned values such as heights.
    Sequential,
}

/// A mapping from values to colours over `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorScale {
    /// Value at the low end of the gradient.
    pub min: f64,
    /// Value at the high end of the gradient.
    pub max: f64,
    /// The gradient.
    pub palette: Palette,
}

impl ColorScale {
    /// A scale over the finite values of `values`. With `symmetric`, the
    /// diverging palette is centred on 0 (`[-m, m]`, m = largest |value|);
    /// otherwise the sequential palette spans `[min, max]`. Degenerate ranges
    /// (no finite values, all equal) are widened so the scale stays usable.
    pub fn for_values(values: &[f32], symmetric: bool) -> ColorScale {
        let range = crate::finite_range(values);
        if symmetric {
            let m = range.map_or(0.0, |(lo, hi)| f64::from(lo.abs().max(hi.abs())));
            let m = if m > 0.0 { m } else { 1.0 };
            ColorScale {
                min: -m,
                max: m,
                palette: Palette::Diverging,
            }
        } else {
            let (lo, hi) = range.map_or((0.0, 1.0), |(lo, hi)| (f64::from(lo), f64::from(hi)));
            let (lo, hi) = if hi > lo {
                (lo, hi)
            } else {
                (lo - 0.5, lo + 0.5)
            };
            ColorScale {
                min: lo,
                max: hi,
                palette: Palette::Sequential,
            }
        }
    }

    /// Position of `value` along the scale, clamped to `[0, 1]`; NaN for NaN.
    pub fn fraction(&self, value: f64) -> f64 {
        if value.is_nan() {
            return f64::NAN;
        }
        let span = self.max - self.min;
        if span <= 0.0 {
            return 0.5;
        }
        ((value - self.min) / span).clamp(0.0, 1.0)
    }

    /// Colour at fraction `t` in `[0, 1]` of the scale.
    pub fn rgb_at(&self, t: f64) -> [u8; 3] {
        let t = t.clamp(0.0, 1.0);
        let c = match self.palette {
            // colorous RED_BLUE runs red (0) to blue (1); flip so high = red.
            Palette::Diverging => colorous::RED_BLUE.eval_continuous(1.0 - t),
            Palette::Sequential => colorous::VIRIDIS.eval_continuous(t),
        };
        [c.r, c.g, c.b]
    }

    /// Colour of `value`, or `None` for NaN (no data).
    pub fn rgb(&self, value: f64) -> Option<[u8; 3]> {
        let t = self.fraction(value);
        if t.is_nan() {
            None
        } else {
            Some(self.rgb_at(t))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_scale_is_centred_on_zero() {
        let s = ColorScale::for_values(&[-2.0, 5.0, f32::NAN], true);
        assert_eq!((s.min, s.max), (-5.0, 5.0));
        assert_eq!(s.fraction(0.0), 0.5);
        let red = s.rgb(5.0).unwrap();
        let blue = s.rgb(-5.0).unwrap();
        assert!(
            red[0] > red[2] && blue[2] > blue[0],
            "red {red:?} blue {blue:?}"
        );
        assert_eq!(s.rgb(f64::NAN), None);
    }

    #[test]
    fn degenerate_inputs_give_usable_scales() {
        for symmetric in [false, true] {
            for values in [&[][..], &[f32::NAN][..], &[3.0, 3.0][..], &[0.0][..]] {
                let s = ColorScale::for_values(values, symmetric);
                assert!(s.max > s.min, "{values:?} {symmetric}: {s:?}");
            }
        }
    }
}
