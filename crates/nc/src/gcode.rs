//! G codes as a small type: the number with its one decimal digit, so G38.2
//! and G38 are told apart without floating-point comparison.

use std::fmt;

/// A G code as written, G38.2 being number 38 and decimal 2. Read with
/// [`GCode::from_value`]; the codes the interpreter acts on are named constants
/// ([`GCode::G1`], [`GCode::G43_1`], ...). Unknown codes are representable, so that
/// a message can name them (`unknown G code G12.3`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GCode(i32);

/// Named constants `G<number>` and `G<number>_<decimal>`.
macro_rules! named {
    ($($name:ident = ($number:literal, $decimal:literal)),* $(,)?) => {
        impl GCode {
            $(
                #[doc = concat!("G", stringify!($number), " with decimal digit ", stringify!($decimal), ".")]
                pub const $name: GCode = GCode::new($number, $decimal);
            )*
        }
    };
}

named! {
    G0 = (0, 0), G1 = (1, 0), G2 = (2, 0), G3 = (3, 0), G4 = (4, 0), G10 = (10, 0),
    G17 = (17, 0), G18 = (18, 0), G19 = (19, 0), G20 = (20, 0), G21 = (21, 0),
    G28 = (28, 0), G28_1 = (28, 1), G30 = (30, 0), G30_1 = (30, 1), G33 = (33, 0),
    G38_2 = (38, 2), G38_3 = (38, 3), G38_4 = (38, 4), G38_5 = (38, 5),
    G40 = (40, 0), G41 = (41, 0), G41_1 = (41, 1), G42 = (42, 0), G42_1 = (42, 1),
    G43 = (43, 0), G43_1 = (43, 1), G43_2 = (43, 2), G49 = (49, 0), G52 = (52, 0), G53 = (53, 0),
    G54 = (54, 0), G55 = (55, 0), G56 = (56, 0), G57 = (57, 0), G58 = (58, 0), G59 = (59, 0),
    G59_1 = (59, 1), G59_2 = (59, 2), G59_3 = (59, 3),
    G61 = (61, 0), G61_1 = (61, 1), G64 = (64, 0), G73 = (73, 0), G74 = (74, 0), G76 = (76, 0),
    G80 = (80, 0), G81 = (81, 0), G82 = (82, 0), G83 = (83, 0), G84 = (84, 0), G85 = (85, 0),
    G86 = (86, 0), G87 = (87, 0), G88 = (88, 0), G89 = (89, 0),
    G90 = (90, 0), G90_1 = (90, 1), G91 = (91, 0), G91_1 = (91, 1),
    G92 = (92, 0), G92_1 = (92, 1), G92_2 = (92, 2), G92_3 = (92, 3),
    G93 = (93, 0), G94 = (94, 0), G95 = (95, 0), G96 = (96, 0), G97 = (97, 0), G98 = (98, 0), G99 = (99, 0),
}

impl GCode {
    /// G`number`.`decimal`; `decimal` is one digit.
    pub const fn new(number: u16, decimal: u8) -> GCode {
        assert!(decimal < 10, "a G code has one decimal digit");
        GCode(number as i32 * 10 + decimal as i32)
    }

    /// The code of a G word's value as rs274ngc reads it (`read_g`): its
    /// tenths rounded where within 0.001 of a whole tenth (G0.99995 is G1,
    /// G17.99995 is G18), `None` otherwise or beyond ±1e5.
    pub fn from_value(value: f64) -> Option<GCode> {
        near_integer(value * 10.0, 0.001, 0.999)
            .filter(|tenths| tenths.abs() <= 1_000_000)
            .map(|tenths| GCode(tenths as i32))
    }

    /// A canned cycle LinuxCNC reads in group 1: G73, G74, G81–G89.
    pub const fn is_canned_cycle(self) -> bool {
        matches!(self.0, 730 | 740 | 810..=890) && self.0 % 10 == 0
    }

    /// The code as a number times ten (G38.2 → 382): the key of the modal-group table.
    pub const fn tenths(self) -> i32 {
        self.0
    }

    /// The number before the decimal point (38 for G38.2).
    pub const fn number(self) -> i32 {
        self.0 / 10
    }

    /// The decimal digit (2 for G38.2).
    pub const fn decimal(self) -> i32 {
        self.0 % 10
    }
}

/// The whole number rs274ngc reads a real value as where the language wants
/// one (its `read_integer_value`: M, T, H and L words, O numbers, parameter
/// numbers, and M98's P): the nearest integer where the value lies within
/// 0.0001 of it (T1.99995 is T2, L2.99995 is L3, T-0.00005 is T0), `None`
/// otherwise. Values computed by expressions land a few ulps off whole
/// numbers; LinuxCNC rounds them so.
pub fn integer_value(value: f64) -> Option<i64> {
    near_integer(value, 0.0001, 0.9999)
}

/// `value` rounded as rs274ngc rounds a real to a whole number: to its floor
/// where the fraction above the floor is at most `down`, to its ceiling where
/// that fraction is over `up`; `None` between, for infinities and NaN, and
/// beyond ±1e15.
fn near_integer(value: f64, down: f64, up: f64) -> Option<i64> {
    let floor = value.floor();
    // NaN for NaN and the infinities: neither branch, so None.
    let fraction = value - floor;
    let n = if fraction > up {
        floor + 1.0
    } else if fraction <= down {
        floor
    } else {
        return None;
    };
    (n.abs() <= 1e15).then_some(n as i64)
}

impl fmt::Display for GCode {
    /// `G1`, `G38.2`; a negative code as `G-1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (sign, t) = if self.0 < 0 {
            ("-", -self.0)
        } else {
            ("", self.0)
        };
        if t % 10 == 0 {
            write!(f, "G{sign}{}", t / 10)
        } else {
            write!(f, "G{sign}{}.{}", t / 10, t % 10)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{integer_value, GCode};

    #[test]
    fn values_read_to_codes_and_print_back() {
        assert_eq!(GCode::from_value(38.2), Some(GCode::G38_2));
        assert_eq!(GCode::from_value(1.0), Some(GCode::G1));
        // An expression's rounding error is forgiven; a second decimal is not.
        assert_eq!(GCode::from_value(0.1 + 0.2 + 92.0), Some(GCode::G92_3));
        assert_eq!(GCode::from_value(1.25), None);
        assert_eq!(GCode::from_value(f64::NAN), None);
        assert_eq!(GCode::from_value(1e7), None);
        for (code, text) in [
            (GCode::G0, "G0"),
            (GCode::G38_2, "G38.2"),
            (GCode::G59_3, "G59.3"),
            (GCode::from_value(-1.5).unwrap(), "G-1.5"),
        ] {
            assert_eq!(code.to_string(), text);
            if code.tenths() >= 0 {
                assert_eq!(
                    GCode::from_value(text[1..].parse().unwrap()),
                    Some(code),
                    "{text}"
                );
            }
        }
        assert_eq!((GCode::G43_2.number(), GCode::G43_2.decimal()), (43, 2));
        assert_eq!(GCode::G80.tenths(), 800);
        // Within 0.001 of a tenth, as rs274ngc's read_g.
        assert_eq!(GCode::from_value(17.99995), Some(GCode::G18));
        assert_eq!(GCode::from_value(38.20009), Some(GCode::G38_2));
        assert_eq!(GCode::from_value(38.2002), None);
    }

    /// rs274ngc's read_integer_value: the floor where the fraction is at most
    /// 0.0001, the ceiling where it is over 0.9999, nothing between.
    #[test]
    fn whole_numbers_are_read_to_within_a_ten_thousandth() {
        for (value, read) in [
            (3.0, Some(3)),
            (3.00009, Some(3)),
            // 3.0001 is 3.000100000000000211 as a double: over, as in LinuxCNC.
            (3.0001, None),
            (2.99991, Some(3)),
            (-0.00005, Some(0)),
            (-2.99995, Some(-3)),
            (3.00011, None),
            (2.9998, None),
            (3.5, None),
            (f64::NAN, None),
            (f64::INFINITY, None),
            (1e16, None),
        ] {
            assert_eq!(integer_value(value), read, "{value}");
        }
    }
}
