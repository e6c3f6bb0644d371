//! Exact-answer tests of the interpreter.

use std::f64::consts::{PI, TAU};

use nc::{Geometry, Motion, Options, Parsed, Plane, Segment};

/// Reads `src` followed by a program end (M2) on a line of its own.
fn parse(src: &str) -> Parsed {
    nc::parse(&format!("{src}\nM2"), "t.ngc", &Options::default())
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
    assert_eq!(s[0].motion, Motion::feed(254.0));
    // As in LinuxCNC, F is read before G20/G21 of the same block takes effect.
    assert_eq!(ok("G20 G1 X1 F10")[0].motion, Motion::feed(10.0));
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
    let f = Motion::feed(100.0);
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
fn compensation_errors_with_position() {
    // G41 with a radius: the entry move must be longer than the radius.
    let options = Options {
        tool_diameters_mm: [(1, 10.0)].into_iter().collect(),
        ..Options::default()
    };
    let e = nc::parse("G0 X0\nG1 G41 D1 X4 F100\nM2", "t.ngc", &options).diagnostics;
    assert!(
        e[0].to_string()
            .starts_with("t.ngc:2:1: length of cutter compensation entry move"),
        "{}",
        e[0]
    );
    assert!(errors("G18 G41.1 D2")[0].contains("G17"));
    assert!(errors("G41.1 D2 G0 X10\nG41 X20")[0].contains("already on"));
    assert!(errors("G40 G49 G0 X1").is_empty());
    assert!(errors("G0 X1 D2")[0].contains("D word with no G41 or G42"));
    assert!(errors("G0 X1 H2")[0].contains("H word with no G43"));
}

/// The safety line of Fanuc-style posts: G80 gives way to G0 in the same
/// block (LinuxCNC's read_g), and G0 with no axis words stays put.
#[test]
fn g80_with_a_motion_code_in_one_block() {
    assert!(ok("N1 G00 G17 G21 G40 G49 G80 G90").is_empty());
    let s = ok("G80 G1 X3 F100\nG81 G80 X5 Z-1 R1");
    assert_eq!(end(&s[0]), [3.0, 0.0, 0.0]);
    // G81 wins over G80: a drilled hole at X5.
    assert_eq!(end(&s[s.len() - 1]), [5.0, 0.0, 1.0]);
    assert!(errors("G0 G1 X1")[0].contains("same modal group"));
}

/// LinuxCNC accepts an R arc whose half chord exceeds R by up to 0.00127 mm
/// (a semicircle), and refuses one beyond that with one error, not a cascade.
#[test]
fn r_arc_rounding_tolerance_and_no_cascade() {
    // Chord 3.0169 against 2R = 3.016: a semicircle about the chord's middle.
    let s = ok("G0 X0 Y0\nG2 X3.0169 Y0 R1.508 F100");
    let (c, _, _, sweep) = arc(&s[0]);
    close(c[0], 3.0169 / 2.0);
    close(c[1], 0.0);
    close(sweep, PI);
    // 0.003 mm too far: one error on that line; the next arc is read from
    // the end point the bad one meant to reach.
    let e = errors("G0 X0 Y0\nG2 X3.022 Y0 R1.508 F100\nG2 X0 Y0 R1.511");
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(e[0].starts_with("t.ngc:2:"), "{e:?}");
}

/// Centre-format tolerance as LinuxCNC's arc_data_ijk: start and end radii
/// may differ by 0.0283 mm (G21) before an error.
#[test]
fn ijk_arc_radius_tolerance() {
    assert!(errors("G0 X0 Y0\nG2 X20.02 Y0 I10 J0 F100").is_empty());
    assert!(errors("G0 X0 Y0\nG2 X20.03 Y0 I10 J0 F100")[0].contains("radius to end"));
}

/// Lines end at a lone CR too (old Mac files), not only at LF and CR LF.
#[test]
fn cr_only_line_ends() {
    let s = ok("G0 X1 Z5\rG1 X2 Z1 F100\r\nG1 Y3\r");
    assert_eq!(s.len(), 3);
    assert_eq!(end(&s[2]), [2.0, 3.0, 1.0]);
    assert_eq!(s[2].line, 3);
}

/// A bad line after the program end is never read (as in LinuxCNC); the
/// same line before it is an error. A file with no end is an error.
#[test]
fn lines_after_the_program_end_are_not_read() {
    let src = "G0 X1\nM30\nN2490%\n";
    assert!(nc::parse(src, "t.ngc", &Options::default())
        .diagnostics
        .is_empty());
    let e = errors("G0 X1\nN2490%");
    assert!(e[0].starts_with("t.ngc:2:6"), "{e:?}");
    let strict = Options {
        file_form: nc::FileForm::LinuxCnc,
        ..Options::default()
    };
    let d = nc::parse("G0 X1\n", "t.ngc", &strict).diagnostics;
    assert_eq!(d.len(), 1);
    assert!(d[0].message.contains("no program end"), "{}", d[0]);
    assert!(d[0].is_error());
}

/// A rotary or secondary axis word of 0 keeps that axis where it starts
/// (at 0) and moves nothing, in G90 and in G91: Mastercam's 4-axis post
/// parks A with `G0 G90 G54 X… Y… A0.`; the path is the one without the A
/// words. Any other value is refused, naming the axis and the column.
#[test]
fn an_axis_word_that_keeps_the_axis_at_0_is_read() {
    let with = ok("G21 G0 G90 G54 X51.063 Y50.746 A0. F600\nG1 Z-1 B0 C-0\nG91 X1 A0\nU0 V0 W0");
    let without = ok("G21 G0 G90 G54 X51.063 Y50.746 F600\nG1 Z-1\nG91 X1");
    assert_eq!(with, without);
    for (src, axis, col) in [
        ("G0 X1 A0.5", 'A', 7),
        ("G91 G1 X1 C-1 F100", 'C', 11),
        ("G0 W2", 'W', 4),
    ] {
        let e = errors(src);
        assert!(
            e[0].starts_with(&format!("t.ngc:1:{col}: axis {axis} is not supported")),
            "{src}: {e:?}"
        );
    }
}

/// A P word with nothing in its block to use it is refused, as LinuxCNC
/// refuses it ("P word with no G2 G3 G4 G10 G64 … to use it"): Snapmaker's
/// `M3 P100` (spindle power in percent), a P on G81. Where something uses
/// it (dwell, G82, arc turns in the block's or the modal arc mode, G64,
/// G10 L2, M98) it is read.
#[test]
fn a_p_word_with_nothing_to_use_it_is_refused() {
    for (src, col) in [
        ("G21 M3 P100", 8),
        ("G21 G0 Z2\nG81 X1 Y1 Z-1 R1 P0.5 F100", 18),
        ("G21 G1 X1 F100 P2", 16),
        ("G21 G2 X2 Y0 I1 F100\nG0 Z1\nP2", 1),
    ] {
        let e = errors(src);
        let line = src.lines().count();
        assert!(
            e.first()
                .is_some_and(|e| e.starts_with(&format!("t.ngc:{line}:{col}: P word with no"))),
            "{src}: {e:?}"
        );
    }
    let s = ok("G21 G4 P0.5\nG64 P0.01\nG10 L2 P1 X0\nG0 Z2\nG82 X1 Y1 Z-1 R1 P0.5 F100\nG80\nG0 X0 Y0 Z0\nG2 X2 Y0 I1 P2 F100\nX0 Y0 I-1 P1");
    assert!(!s.is_empty());
}

/// A percent line holds only `%` (blanks around it allowed), as LinuxCNC
/// reads it ("Bad character '%' used"): Fusion's MPCNC post writes a user's
/// start code with `% vfd enable`, a comment or a `;` after the percent is
/// refused too, in either file form; `%` alone still opens and closes.
#[test]
fn a_percent_line_with_text_is_refused() {
    for form in [nc::FileForm::LinuxCnc, nc::FileForm::Tolerant] {
        let options = Options {
            file_form: form,
            ..Options::default()
        };
        for (line, col) in [
            ("% vfd enable", 3),
            ("%( *** START end ***)", 2),
            ("%;x", 2),
            ("%%", 2),
        ] {
            let src = format!("%\nG21 G0 X1\n{line}\nG0 X2\nM2\n%\n");
            let d = nc::parse(&src, "t.ngc", &options).diagnostics;
            let e = d
                .iter()
                .find(|d| d.is_error())
                .unwrap_or_else(|| panic!("{line}: {d:?}"));
            assert_eq!((e.line, e.column), (3, col), "{line}: {e}");
            assert!(e.message.contains("'%' with more on its line"), "{e}");
        }
        let p = nc::parse("%\nG21 G0 X1\n \t%\t\r\nG0 X2\n", "t.ngc", &options);
        assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
        assert_eq!(p.path.segments.len(), 1);
    }
}

/// Read as most controls read a file, a missing program end and a leading
/// UTF-8 byte-order mark are warnings at the line concerned, and the path is
/// the one of the file with `M2` added and the mark dropped; as LinuxCNC
/// reads it, each is an error there.
#[test]
fn tolerant_file_form_warns_where_linuxcnc_refuses() {
    let form = |file_form| Options {
        file_form,
        ..Options::default()
    };
    let src = "\u{feff}G21 G90\nG1 X10 Y5 F600\nG0 Z5\n";
    let tolerant = nc::parse(src, "t.ngc", &form(nc::FileForm::Tolerant));
    let d = &tolerant.diagnostics;
    assert_eq!(d.len(), 2, "{d:?}");
    assert!(d.iter().all(|d| !d.is_error()), "{d:?}");
    assert_eq!((d[0].line, d[0].column), (1, 1), "{}", d[0]);
    assert!(d[0].message.contains("byte-order mark"), "{}", d[0]);
    assert_eq!((d[1].line, d[1].column), (3, 1), "{}", d[1]);
    assert!(d[1].message.contains("no program end"), "{}", d[1]);
    let amended = nc::parse(
        "G21 G90\nG1 X10 Y5 F600\nG0 Z5\nM2\n",
        "t.ngc",
        &form(nc::FileForm::LinuxCnc),
    );
    assert!(amended.diagnostics.is_empty(), "{:?}", amended.diagnostics);
    assert_eq!(tolerant.path, amended.path);
    let strict = nc::parse(src, "t.ngc", &form(nc::FileForm::LinuxCnc)).diagnostics;
    assert!(
        strict.len() >= 2 && strict.iter().all(|d| d.is_error()),
        "{strict:?}"
    );
    assert_eq!((strict[0].line, strict[0].column), (1, 1), "{}", strict[0]);
}

/// CAMotics' sample programs close with a '%' they never opened (its
/// `locket_inside.ngc`, `compass.ngc`): read as most controls read a file, that
/// '%' is the program's end, with a warning at its line and column, and the
/// path is the one of the file with `M2` there; as LinuxCNC reads it, an
/// error. A '%' before other blocks, or a program opened with '%', reads as
/// before.
#[test]
fn a_closing_percent_never_opened_ends_a_tolerant_program() {
    let form = |file_form| Options {
        file_form,
        ..Options::default()
    };
    let linuxcnc = |src: &str| nc::parse(src, "t.ngc", &form(nc::FileForm::LinuxCnc));
    let tolerant = |src: &str| nc::parse(src, "t.ngc", &form(nc::FileForm::Tolerant));
    let with_m2 = linuxcnc("G21 G90\nG1 X10 Y5 F600\nG0 Z5\nM2\n");
    assert!(with_m2.diagnostics.is_empty(), "{:?}", with_m2.diagnostics);
    for (src, col) in [
        ("G21 G90\nG1 X10 Y5 F600\nG0 Z5\n%\n", 1),
        ("G21 G90\r\nG1 X10 Y5 F600\r\nG0 Z5\r\n  %\r\n\r\n", 3),
        ("G21 G90\nG1 X10 Y5 F600\nG0 Z5\n%", 1),
    ] {
        let read = tolerant(src);
        let d = &read.diagnostics;
        assert_eq!(d.len(), 1, "{src:?}: {d:?}");
        assert!(!d[0].is_error(), "{}", d[0]);
        assert_eq!((d[0].line, d[0].column), (4, col), "{}", d[0]);
        assert!(d[0].message.contains("did not open"), "{}", d[0]);
        assert!(read.has_program_end, "{src:?}");
        assert_eq!(read.path, with_m2.path, "{src:?}");
        // The amended file reads as LinuxCNC reads it, through the same moves.
        let amended = linuxcnc(&nc::amend(src, &read.amendments));
        assert!(amended.diagnostics.is_empty(), "{:?}", amended.diagnostics);
        assert_eq!(amended.path, with_m2.path);
        let strict = linuxcnc(src).diagnostics;
        assert!(
            strict
                .iter()
                .any(|d| d.is_error() && (d.line, d.column) == (4, col)),
            "{strict:?}"
        );
    }
    // A '%' with blocks after it is refused in either form.
    let middle = tolerant("G21 G90\nG1 X10 F600\n%\nG0 Z5\nM2\n").diagnostics;
    assert!(
        middle.iter().any(|d| d.is_error() && d.line == 3),
        "{middle:?}"
    );
    // Opened and closed: no warning.
    let opened = tolerant("%\nG21 G90\nG1 X10 Y5 F600\nG0 Z5\n%\n");
    assert!(opened.diagnostics.is_empty(), "{:?}", opened.diagnostics);
    let ends = |p: &nc::Path| p.segments.iter().map(|s| s.end).collect::<Vec<_>>();
    assert_eq!(ends(&opened.path), ends(&with_m2.path));
}

/// At most `max_errors` errors are listed, then one line with the count.
#[test]
fn errors_are_capped_per_program() {
    let src = "G1 X1 G12\n".repeat(30);
    let e = errors(&src);
    assert_eq!(e.len(), 21, "{e:?}");
    assert!(e[20].contains("and 10 more errors"), "{}", e[20]);
    assert!(e[20].starts_with("t.ngc:21:"), "{}", e[20]);
}

/// o-word subroutines found through an index: a sub at the far end of a
/// long file called many times (it took minutes when every call scanned the
/// file; the index's cost is benched by `cargo bench -p dexcut --bench
/// pipeline -- interpret`, not timed here: a wall-clock limit fails under
/// load). Every call runs: the sub's move goes one step further each time (#100 is global;
/// #1 would be the call's own argument, 0 at every call as in rs274).
#[test]
fn oword_calls_through_the_index_all_run() {
    let mut src = String::from("G1 F100\n");
    for _ in 0..20_000 {
        src.push_str("o<far> call\n");
    }
    src.push_str("M2\n");
    src.push_str(&"(padding)\n".repeat(200_000));
    src.push_str("o<far> sub\n#100 = [#100 + 1]\nG1 X[#100 * 0.01]\no<far> endsub\n");
    let p = nc::parse(&src, "t.ngc", &Options::default());
    assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics.first());
    let feeds: Vec<_> = p
        .path
        .segments
        .iter()
        .filter(|s| matches!(s.motion, nc::Motion::Feed { .. }))
        .collect();
    assert_eq!(feeds.len(), 20_000);
    assert!((feeds[19_999].end.x - 200.0).abs() < 1e-9);
}

/// P turns beyond dexcut's cap get a message naming the cap.
#[test]
fn arc_turns_message_names_the_cap() {
    let e = errors("G0 X10\nG3 X10 Y0 I-10 J0 P1000000 F100");
    assert!(e[0].contains("integer from 1 to 10000"), "{e:?}");
}

/// Polar coordinates: `@` radius and `^` angle about the program origin;
/// incremental ones add to the current point's radius and angle.
#[test]
fn polar_coordinates() {
    let s = ok("G0 @10 ^90\nG91 G0 ^90\nG0 @-5\nG90 G0 ^0");
    close(s[0].end.x, 0.0);
    close(s[0].end.y, 10.0);
    close(s[1].end.x, -10.0);
    close(s[1].end.y, 0.0);
    close(s[2].end.x, -5.0);
    close(s[3].end.x, 5.0);
    close(s[3].end.y, 0.0);
    assert!(errors("G0 X1 @2")[0].contains("polar"));
}

/// G64 P Q, G61 and G61.1 are accepted (dexcut follows the programmed
/// path exactly under all three).
#[test]
fn path_control_modes_accepted() {
    assert_eq!(ok("G64 P0.01 Q0.01\nG1 X1 F100\nG61\nG61.1\nG64").len(), 1);
}

/// Tool length offsets keep positions tool-tip positions: G43 with the
/// tool's own length reads as the program without offsets.
#[test]
fn tool_length_offsets_keep_tip_positions() {
    let options = Options {
        tool_lengths_mm: [(1, 50.0), (2, 80.0)].into_iter().collect(),
        initial_position_mm: [0.0, 0.0, 100.0],
        ..Options::default()
    };
    let with = nc::parse(
        "T1 M6\nG43 H1\nG0 X5 Z10\nG1 Z-1 F100\nG0 Z10\nT2 M6\nG43 Z10 H2\nG1 Z-2 F100\nG49\nM2",
        "t.ngc",
        &options,
    );
    assert!(with.diagnostics.is_empty(), "{:?}", with.diagnostics);
    let without = nc::parse(
        "G0 X5 Z10\nG1 Z-1 F100\nG0 Z10\nG1 Z-2 F100\nM2",
        "t.ngc",
        &Options {
            initial_position_mm: [0.0, 0.0, 100.0],
            ..Options::default()
        },
    );
    // The tool change puts a tool 30 mm longer in: its tip appears 30 mm
    // lower (a rapid), then G43 H2 Z10 brings it to Z10.
    let w: Vec<([f64; 3], u32)> = with
        .path
        .segments
        .iter()
        .map(|s| (end(s), s.tool))
        .collect();
    assert_eq!(
        w,
        [
            ([5.0, 0.0, 10.0], 1),
            ([5.0, 0.0, -1.0], 1),
            ([5.0, 0.0, 10.0], 1),
            ([5.0, 0.0, -20.0], 2),
            ([5.0, 0.0, 10.0], 2),
            ([5.0, 0.0, -2.0], 2),
        ]
    );
    let wo: Vec<[f64; 3]> = without.path.segments.iter().map(end).collect();
    let w_moves: Vec<[f64; 3]> = [0, 1, 2, 5].iter().map(|&i| w[i].0).collect();
    assert_eq!(w_moves, wo);
    // G43.1 sets the offset directly (a tool of length 0 ends 5 mm above
    // the programmed point); G49 removes it without moving the tool.
    let s = nc::parse(
        "G43.1 Z5\nG0 X1 Z0\nG49\nG0 X2\nM2",
        "t.ngc",
        &Options::default(),
    );
    assert!(s.diagnostics.is_empty(), "{:?}", s.diagnostics);
    assert_eq!(end(&s.path.segments[0]), [1.0, 0.0, 5.0]);
    assert_eq!(end(&s.path.segments[1]), [2.0, 0.0, 5.0]);
    // A tool the table lacks is an error at its T word.
    let e = nc::parse("G0 X1\nT7 M6\nM2", "t.ngc", &options).diagnostics;
    assert!(
        e[0].to_string()
            .starts_with("t.ngc:2:1: tool T7 is not in the job's tool table"),
        "{}",
        e[0]
    );
}

/// M61 Q sets the tool in the spindle; M70/M72 save and restore modes, M73
/// restores them when the subroutine returns.
#[test]
fn m61_and_m70_to_m73() {
    let s = ok("M61 Q3\nG0 X1");
    assert_eq!(s[0].tool, 3);
    let s = ok("G21 F100\nM70\nG20 G91 F10\nG1 X1\nM72\nG1 X1");
    // F is read before G20 takes effect (10 mm/min); M72 restores G21 G90
    // F100: the second move goes to X1 mm absolute at 100 mm/min.
    assert_eq!(end(&s[0]), [25.4, 0.0, 0.0]);
    assert_eq!(s[0].motion, Motion::feed(10.0));
    assert_eq!(end(&s[1]), [1.0, 0.0, 0.0]);
    assert_eq!(s[1].motion, Motion::feed(100.0));
    // G91 in the subroutine is undone on return: X2 is absolute (not 3).
    let s = ok("o<s> sub\nM73\nG91\no<s> endsub\nG1 X1 F100\no<s> call\nG1 X2");
    assert_eq!(end(&s[1]), [2.0, 0.0, 0.0]);
    assert!(errors("M72")[0].contains("no M70"));
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
    assert_eq!(s[0].motion, Motion::feed(60.0));
    assert_eq!(s[1].motion, Motion::Dwell { seconds: 2.5 });
    assert!(!errors("G93 G1 X10").is_empty());
}

/// Three dialects real posts write and LinuxCNC refuses, read as the
/// controls they were written for read them, each with a warning at its line
/// and column: Estlcam's parentheses nested in a comment, FreeCAD's GRBL post
/// `K0` on XY arcs (GRBL ignores it), and Fusion's `.tap` axis words after
/// G80 (Fanuc-style controls move in the G0/G1 mode set before the cycle).
/// The amended text ([`nc::amend`]) reads as LinuxCNC reads it, through the
/// same path, with no further amendment; each line is warned of once.
#[test]
fn dialects_real_posts_write_are_read_tolerantly_and_amended() {
    let form = |file_form| Options {
        file_form,
        ..Options::default()
    };
    let cases = [
        (
            "(Tools: (HSS Twist Drill, 3mm (R)))\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n",
            (1, 9),
            "nested in a comment",
            "(Tools: [HSS Twist Drill, 3mm [R]])\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n",
        ),
        (
            "G17 G0 X0 Y0 Z1\nG1 X1 F300\nG3 X2 Y1 I0 J1 K0.000\nM2\n",
            (3, 16),
            "K0 on an arc in this plane ignored",
            "G17 G0 X0 Y0 Z1\nG1 X1 F300\nG3 X2 Y1 I0 J1\nM2\n",
        ),
        (
            "G0 X0 Y0 Z5\nG98 G81 X1 Y1 Z-1 R2 F100\nX2\nG80\nX0 Y-2 Z6\no1 repeat [2]\nX1 Y1\no1 endrepeat\nM2\n",
            (5, 1),
            "axis words after G80 moved in G0",
            "G0 X0 Y0 Z5\nG98 G81 X1 Y1 Z-1 R2 F100\nX2\nG80\nG0 X0 Y-2 Z6\no1 repeat [2]\nX1 Y1\no1 endrepeat\nM2\n",
        ),
        (
            "G21 G90\n  $I  ; build info\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n",
            (2, 3),
            "GRBL system command skipped",
            "G21 G90\n  ($I)  ; build info\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n",
        ),
    ];
    for (src, (line, column), what, written) in cases {
        let strict = nc::parse(src, "t.ngc", &form(nc::FileForm::LinuxCnc));
        assert!(strict.diagnostics.iter().any(|d| d.is_error()), "{src}");
        let tolerant = nc::parse(src, "t.ngc", &form(nc::FileForm::Tolerant));
        let d = &tolerant.diagnostics;
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(!d[0].is_error() && d[0].message.contains(what), "{}", d[0]);
        assert_eq!((d[0].line, d[0].column), (line, column), "{}", d[0]);
        let amended = nc::amend(src, &tolerant.amendments);
        assert_eq!(amended, written);
        let linuxcnc = nc::parse(&amended, "t.ngc", &form(nc::FileForm::LinuxCnc));
        assert!(
            linuxcnc.diagnostics.is_empty(),
            "{:?}",
            linuxcnc.diagnostics
        );
        assert_eq!(linuxcnc.path, tolerant.path);
        let again = nc::parse(&amended, "t.ngc", &form(nc::FileForm::Tolerant));
        assert!(again.amendments.is_empty() && again.diagnostics.is_empty());
    }
    // After G80 with no G0/G1 set before the cycle, there is no mode to fall back to.
    let src = "G98 G81 X1 Y1 Z-1 R2 F100\nG80\nX0 Y-2 Z6\nM2\n";
    let d = nc::parse(src, "t.ngc", &form(nc::FileForm::Tolerant)).diagnostics;
    assert!(d.iter().any(|d| d.is_error() && d.line == 3), "{d:?}");
    // GRBL's homing and jogging move the machine where the program cannot say.
    for src in ["$H\nG0 X1\nM2\n", "$J=G91 X10 F100\nG0 X1\nM2\n"] {
        let d = nc::parse(src, "t.ngc", &form(nc::FileForm::Tolerant)).diagnostics;
        assert!(d.iter().any(|d| d.is_error() && d.line == 1), "{d:?}");
    }
}

/// Outputs, input waits and override switches move nothing; M19 orients the
/// spindle, which stops turning until the next M3; a wait on an input (M66
/// L1–L4) is read with a warning, since the run does not wait.
#[test]
fn io_codes_move_nothing_and_m19_stops_the_spindle() {
    let plain = ok("G21 G90 S8000 M3\nG1 X1 F100\nG1 X2\nG1 X3");
    let with_codes = parse(
        "G21 G90 S8000 M3\nM62 P0 G1 X1 F100\nM50 P0\nM19 R90\nG1 X2\nM67 E0 Q2.5 M3\nM66 P1 L3 Q0.5\nG1 X3",
    );
    let warnings: Vec<String> = with_codes
        .diagnostics
        .iter()
        .map(ToString::to_string)
        .collect();
    assert!(
        with_codes.diagnostics.iter().all(|d| !d.is_error()),
        "{warnings:?}"
    );
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("t.ngc:7:1: M66 waits for an input (up to 0.5 s)"),
        "{warnings:?}"
    );
    let segs = with_codes.path.segments;
    assert_eq!(segs.len(), plain.len());
    for (a, b) in segs.iter().zip(&plain) {
        assert_eq!((a.start, a.end, a.motion), (b.start, b.end, b.motion));
    }
    let rpm: Vec<f64> = segs.iter().map(|s| s.spindle_rpm).collect();
    assert_eq!(rpm, [8000.0, 0.0, 8000.0]);
}

/// `G10 L2 … R` rotates its coordinate system about Z (issue 39): a move
/// after it is turned about the system's origin, as in LinuxCNC (the rs274
/// test `rotated_coordinate_systems_read_as_in_linuxcnc_rs274`). Before, the
/// R word was dropped and `G1 X10` ended at X10 Y0.
#[test]
fn g10_l2_r_rotates_the_coordinate_system() {
    let s = ok("G10 L2 P1 X0 Y0 R45\nG1 X10 F100");
    let h = 50f64.sqrt();
    close(end(&s[0])[0], h);
    close(end(&s[0])[1], h);
    // About the system's origin (X5 Y-3), the arc's centre turned with it.
    let s = ok("G10 L2 P1 X5 Y-3 R90\nG0 X0 Y0\nG2 X10 Y0 I5 J0 F100");
    close(end(&s[0])[0], 5.0);
    close(end(&s[0])[1], -3.0);
    close(end(&s[1])[0], 5.0);
    close(end(&s[1])[1], 7.0);
    let (c, _, clockwise, sweep) = arc(&s[1]);
    close(c[0], 5.0);
    close(c[1], 2.0);
    assert!(clockwise);
    close(sweep, PI);
    // G55 keeps its own rotation; G54 has none (Y stays where G55 left it).
    let s = ok("G10 L2 P2 R90\nG55 G1 X2 F100\nG54 G1 X3");
    close(end(&s[0])[0], 0.0);
    close(end(&s[0])[1], 2.0);
    close(end(&s[1])[0], 3.0);
    close(end(&s[1])[1], 2.0);
    // Refused where LinuxCNC refuses it, or where dexcut cannot follow.
    let e = errors("G10 L20 P1 X1 R30");
    assert!(
        e[0].contains("t.ngc:1:15: R not allowed in G10 L20"),
        "{e:?}"
    );
    let e = errors("G10 L2 P1 R30\nG18 G2 X10 Z0 I5 K0 F100");
    assert!(
        e[0].starts_with("t.ngc:2:") && e[0].contains("rotated by G10 L2 R"),
        "{e:?}"
    );
}

/// G52 sets the G92 offset to its words, G92.2 suspends it and G92.3 brings
/// it back, none moving the machine, as in LinuxCNC (issue 39: before, G52
/// was an unknown code and G92.2, G92.3 were refused).
#[test]
fn g52_and_g92_2_g92_3_shift_the_program_origin() {
    let s = ok("G0 X1 Y1\nG52 X10\nG0 X0\nG92.2\nG0 X0\nG92.3\nG0 X1\nG92.1\nG0 X0");
    let xs: Vec<f64> = s.iter().map(|s| end(s)[0]).collect();
    assert_eq!(xs, [1.0, 10.0, 0.0, 11.0, 0.0]);
}

/// Loops whose runs would take the path past the limit of moves (issue 39:
/// `o1 repeat [1000000000]` around two G1 lines aborted on a 503 MB
/// allocation) stop once their first run shows it, with an error at the
/// loop's line and column giving the moves it would make and the limit:
/// repeat, nested repeats, a subroutine called in a loop, M98 with L; a
/// while or do-while loop, whose runs are not counted, at the limit itself.
/// Nothing near the limit is held: each case ends quickly.
#[test]
fn loops_past_the_limit_of_moves_stop_at_their_line() {
    let options = Options {
        max_segments: 10_000,
        ..Options::default()
    };
    let cases = [
        (
            "G0 X0\no1 repeat [1000000000]\nG1 X1 F100\nG1 X0\no1 endrepeat\nM2",
            "t.ngc:2:1: this repeat would make the program 2.0000e9 moves (2 a run, 1000000000 runs), more than the limit of 10000",
        ),
        (
            "o1 repeat [100000]\no2 repeat [3]\nG1 X1 F100\nG1 X0\no2 endrepeat\no1 endrepeat\nM2",
            "t.ngc:1:1: this repeat would make the program 6.0000e5 moves (6 a run, 100000 runs)",
        ),
        (
            "o9 sub\nG1 X1 F100\nG1 X0\no9 endsub\n#1 = 0\no1 repeat [10000000]\no9 call\no1 endrepeat\nM2",
            "t.ngc:6:1: this repeat would make the program 2.0000e7 moves",
        ),
        (
            "G91\nM98 P8 L1000000\nM2\nO8\nG1 X1 F100\nG1 X-1\nM99",
            "t.ngc:2:1: this M98 L would make the program 2.0000e6 moves (2 a run, 1000000 runs)",
        ),
        (
            "#1 = 0\no1 while [#1 LT 1000000000]\nG1 X[#1 MOD 2] F100\n#1 = [#1 + 1]\no1 endwhile\nM2",
            "t.ngc:2:1: this loop made the program more than 10000 moves (the limit) before its end",
        ),
        (
            "#1 = 0\no1 do\nG1 X[#1 MOD 2] F100\n#1 = [#1 + 1]\no1 while [#1 LT 1000000000]\nM2",
            "t.ngc:2:1: this loop made the program more than 10000 moves (the limit) before its end",
        ),
    ];
    for (src, want) in cases {
        let started = std::time::Instant::now();
        let parsed = nc::parse(src, "t.ngc", &options);
        let errors: Vec<String> = parsed
            .diagnostics
            .iter()
            .filter(|d| d.is_error())
            .map(ToString::to_string)
            .collect();
        assert_eq!(errors.len(), 1, "{src}: {errors:?}");
        assert!(errors[0].starts_with(want), "{src}: {}", errors[0]);
        assert!(parsed.path.segments.len() <= 10_001, "{src}");
        assert!(started.elapsed().as_secs() < 5, "{src}");
    }
    // Under the limit, a loop runs in full.
    let parsed = nc::parse(
        "o1 repeat [4000]\nG1 X1 F100\nG1 X0\no1 endrepeat\nM2",
        "t.ngc",
        &options,
    );
    assert!(parsed.diagnostics.is_empty(), "{:?}", parsed.diagnostics);
    assert_eq!(parsed.path.segments.len(), 8000);
}
