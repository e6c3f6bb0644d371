//! "Nice" axis ticks (1, 2, 5 × 10ⁿ) and their labels, shared by the PNG colour
//! bar, the PNG scale bar and the SVG plots.

/// A step of the form 1, 2 or 5 × 10ⁿ close to `raw` (rounding up).
pub fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = if f <= 1.0 {
        1.0
    } else if f <= 2.0 {
        2.0
    } else if f <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// The largest 1/2/5 × 10ⁿ not above `x` (for scale bars); 0 for non-positive input.
pub fn nice_floor(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 0.0;
    }
    let mag = 10f64.powf(x.log10().floor());
    let f = x / mag;
    let m = if f >= 5.0 {
        5.0
    } else if f >= 2.0 {
        2.0
    } else {
        1.0
    };
    m * mag
}

/// About `target` nice tick values inside `[lo, hi]`, and their step.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        let v = if lo.is_finite() { lo } else { 0.0 };
        return (vec![v], 1.0);
    }
    let step = nice_step((hi - lo) / target.max(1) as f64);
    let first = (lo / step).ceil();
    let last = (hi / step).floor();
    let mut ticks = Vec::new();
    let mut k = first;
    while k <= last + 1e-9 && ticks.len() < 1000 {
        let v = k * step;
        // Avoid "-0".
        ticks.push(if v.abs() < step * 1e-9 { 0.0 } else { v });
        k += 1.0;
    }
    (ticks, step)
}

/// Label for tick `value` on an axis with tick spacing `step`: as many decimals
/// as the step needs, exponent notation for very large or small magnitudes.
pub fn format_tick(value: f64, step: f64) -> String {
    let mag = value.abs().max(step.abs());
    if mag != 0.0 && !(1e-3..1e6).contains(&mag) {
        return format!("{value:.1e}");
    }
    let decimals = if step > 0.0 {
        (-step.log10().floor()).max(0.0) as usize
    } else {
        0
    };
    format!("{value:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_inside() {
        let (t, step) = nice_ticks(-5.0, 5.0, 5);
        assert_eq!(step, 2.0);
        assert_eq!(t, vec![-4.0, -2.0, 0.0, 2.0, 4.0]);
        let (t, step) = nice_ticks(0.0, 0.37, 4);
        assert_eq!(step, 0.1);
        assert_eq!(t.len(), 4);
        assert_eq!(format_tick(t[3], step), "0.3");
        assert_eq!(nice_ticks(1.0, 1.0, 5).0, vec![1.0]);
        assert_eq!(nice_ticks(f64::NAN, 1.0, 5).0, vec![0.0]);
        assert_eq!(nice_floor(37.0), 20.0);
        assert_eq!(nice_floor(0.7), 0.5);
        assert_eq!(format_tick(2.5e7, 1e7), "2.5e7");
    }
}
