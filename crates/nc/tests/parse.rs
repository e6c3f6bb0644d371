//! Exact-answer tests of the interpreter.

use std::f64::consts::{PI, TAU};

use nc::{Geometry, Motion, Options, Parsed, Plane, Segment};

fn parse(src: &str) -> Parsed {
    nc::parse(src, "t.ngc", &Options::default())
}

fn ok(src: &str) -> Vec<Segment> {
    let p = parse(src);
    assert!(
        p.diagnostics.is_empty(),
        "{:?}",
        p.diagnostics
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
    );
    p.path.segments
}

fn errors(src: &str) -> Vec<String> {
    parse(src)
        .diagnostics
        .iter()
        .map(ToString::to_string)
        .collect()
}

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < 1e-9, "{a} != {b}");
}

fn end(s: &Segment) -> [f64; 3] {
    [s.end.x, s.end.y, s.end.z]
}

fn arc(s: &Segment) -> ([f64; 3], Plane, bool, f64) {
    match s.geometry {
        Geometry::Arc {
            center,
            plane,
            clockwise,
            sweep_rad,
        } => ([center.x, center.y, center.z], plane, clockwise, sweep_rad),
        Geometry::Line => panic!("not an arc: {s:?}"),
    }
}

#[test]
fn r_arcs_both_signs() {
    // G2 from (0,0) to (10,0), R5: semicircle, centre (5,0).
    let s = ok("G1 F100 X0\nG2 X10 Y0 R5");
    close(arc(&s[0]).0[0], 5.0);
    // R = 5·√2: short arc (R>0) centre below the chord for G2, long arc (R<0) above.
    let r = 50f64.sqrt();
    let s = ok(&format!("F100\nG2 X10 Y0 R{r}\nG0 X0 Y0\nG2 X10 Y0 R-{r}"));
    let (c, _, cw, sweep) = arc(&s[0]);
    close(c[0], 5.0);
    close(c[1], -5.0);
    assert!(cw);
    close(sweep, PI / 2.0);
    let (c, _, _, sweep) = arc(&s[2]);
    close(c[1], 5.0);
    close(sweep, 1.5 * PI);
}

#[test]
fn full_circle_and_helix() {
    let s = ok("F100\nG0 X10\nG3 X10 Y0 I-10 J0");
    let (c, _, cw, sweep) = arc(&s[1]);
    assert_eq!((c, cw), ([0.0, 0.0, 0.0], false));
    close(sweep, TAU);
    close(s[1].length_mm(), TAU * 10.0);
    // Helix: 3 turns of radius 10 dropping 6 mm.
    let s = ok("F100\nG0 X10\nG2 X10 Y0 Z-6 I-10 P3");
    close(arc(&s[1]).3, 3.0 * TAU);
    close(s[1].length_mm(), ((10.0 * 3.0 * TAU).powi(2) + 36.0).sqrt());
}

#[test]
fn incremental_and_inch() {
    let s = ok("G91 G1 X1 Y2 F100\nX1\nG20 X1\nG90 G21 X0");
    assert_eq!(end(&s[0]), [1.0, 2.0, 0.0]);
    assert_eq!(end(&s[1]), [2.0, 2.0, 0.0]);
    close(s[2].end.x, 27.4);
    let s = ok("G20\nG1 X1 F10");
    close(s[0].end.x, 25.4);
    assert_eq!(s[0].motion, Motion::Feed { feed_mm_min: 254.0 });
    // As in LinuxCNC, F is read before G20/G21 of the same block takes effect.
    assert_eq!(
        ok("G20 G1 X1 F10")[0].motion,
        Motion::Feed { feed_mm_min: 10.0 }
    );
}

#[test]
fn plane_directions_as_linuxcnc() {
    // G18 (first axis Z, second X, as rs274's ARC_FEED): G3 turns from +Z to +X
    // the short way, G2 the long way.
    let s = ok("F100\nG0 Z10\nG18 G3 X10 Z0 I0 K-10");
    let (_, plane, cw, sweep) = arc(&s[1]);
    assert_eq!((plane, cw), (Plane::ZX, false));
    close(sweep, PI / 2.0);
    let mid = s[1].point_at_fraction(0.5);
    assert!(mid.x > 0.0 && mid.z > 0.0);
    close(
        arc(&ok("F100\nG0 Z10\nG18 G2 X10 Z0 I0 K-10")[1]).3,
        1.5 * PI,
    );
    // G19: G2 from +Y to +Z is clockwise seen from +X.
    let s = ok("F100\nG0 Y10\nG19 G2 Y0 Z10 J-10 K0");
    close(arc(&s[1]).3, 1.5 * PI);
}

#[test]
fn expressions_and_functions() {
    let s = ok("#1=2\n#<a>=[#1**3 - 10 MOD 3 + SIN[30] * 2 + ATAN[1]/[1] + SQRT[ABS[-16]]]\nG0 X#<a> Y[ROUND[2.5] + FIX[-1.5] + FUP[1.2] + [1 LT 2] + [2 EQ 2.00001]]");
    close(s[0].end.x, 8.0 - 1.0 + 1.0 + 45.0 + 4.0);
    close(s[0].end.y, 3.0 - 2.0 + 2.0 + 1.0 + 1.0);
    // Assignments take effect after the line is read.
    let s = ok("#1=1\n#1=5 G0 X#1\nG0 X#1");
    close(s[0].end.x, 1.0);
    close(s[1].end.x, 5.0);
    assert!(errors("G0 X[1/0]")[0].starts_with("t.ngc:1:4: division by zero"));
}

#[test]
fn fanuc_subprogram_with_repeat() {
    let s = ok("G91 F100\nM98 P1000 L3\nG90 G0 X0\nM30\nO1000\nG1 X1\nG1 Y1\nM99");
    assert_eq!(s.len(), 7);
    assert_eq!(end(&s[5]), [3.0, 3.0, 0.0]);
    assert_eq!(s[0].line, 6);
}

#[test]
fn oword_subroutine_and_loops() {
    let s = ok("o1 sub\nG0 X#1 Y#2\no1 endsub\n#5=0\no2 while [#5 lt 3]\no1 call [#5] [2]\n#5=[#5+1]\no2 endwhile\nM2");
    assert_eq!(
        s.iter().map(|s| s.end.x).collect::<Vec<_>>(),
        vec![0.0, 1.0, 2.0]
    );
}

#[test]
fn drill_cycle_g98_g99() {
    use Motion::*;
    let f = Feed { feed_mm_min: 100.0 };
    let moves = |src| {
        ok(src)
            .iter()
            .map(|s| (s.motion, end(s)))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        moves("F100\nG0 Z10\nG98 G81 X5 Y5 Z-2 R1\nX8"),
        vec![
            (Rapid, [0.0, 0.0, 10.0]),
            (Rapid, [5.0, 5.0, 10.0]),
            (Rapid, [5.0, 5.0, 1.0]),
            (f, [5.0, 5.0, -2.0]),
            (Rapid, [5.0, 5.0, 10.0]),
            (Rapid, [8.0, 5.0, 10.0]),
            (Rapid, [8.0, 5.0, 1.0]),
            (f, [8.0, 5.0, -2.0]),
            (Rapid, [8.0, 5.0, 10.0]),
        ]
    );
    assert_eq!(
        moves("F100\nG0 Z10\nG99 G81 X5 Y5 Z-2 R1\nX8")[4..],
        [
            (Rapid, [5.0, 5.0, 1.0]),
            (Rapid, [8.0, 5.0, 1.0]),
            (f, [8.0, 5.0, -2.0]),
            (Rapid, [8.0, 5.0, 1.0])
        ]
    );
}

#[test]
fn compensation_rejected_with_position() {
    assert_eq!(
        errors("G0 X0\nG1 G41 D1 X5 F100")[0].split(": ").next(),
        Some("t.ngc:2:4")
    );
    assert!(errors("G43 H1 Z5")[0].contains("tool length compensation"));
    assert!(errors("G40 G49 G0 X1").is_empty());
}

#[test]
fn malformed_words_point_at_columns() {
    let e = errors("G1 X1..2 F1\nX\nG1 Xabc F1\nG1 X1 G12 F1\nG1 G2 X1\nX1 X2");
    let heads: Vec<_> = e
        .iter()
        .map(|d| d.splitn(4, ':').take(3).collect::<Vec<_>>().join(":"))
        .collect();
    assert_eq!(
        heads,
        [
            "t.ngc:1:5",
            "t.ngc:2:1",
            "t.ngc:3:5",
            "t.ngc:4:7",
            "t.ngc:5:4",
            "t.ngc:6:4"
        ]
    );
}

#[test]
fn inverse_time_and_dwell() {
    let s = ok("G93 G1 X10 F6\nG4 P2.5");
    assert_eq!(s[0].motion, Motion::Feed { feed_mm_min: 60.0 });
    assert_eq!(s[1].motion, Motion::Dwell { seconds: 2.5 });
    assert!(!errors("G93 G1 X10").is_empty());
}
