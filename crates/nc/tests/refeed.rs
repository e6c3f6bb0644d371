//! Re-feeding: new F words, split blocks, everything else byte for byte.

use nc::{Geometry, Motion, Options};

fn parse(src: &str) -> nc::Path {
    let p = nc::parse(src, "t.ngc", &Options::default());
    assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
    p.path
}

fn feeds(path: &nc::Path) -> Vec<f64> {
    path.segments
        .iter()
        .filter_map(|s| match s.motion {
            Motion::Feed { feed_mm_min, .. } => Some(feed_mm_min),
            _ => None,
        })
        .collect()
}

/// One piece at `feed` for every feed segment.
fn uniform(path: &nc::Path, feed: f64) -> Vec<Vec<(f64, f64)>> {
    every_feed(path, &[(1.0, feed)])
}

/// The same `pieces` for every feed segment, none for the others.
fn every_feed(path: &nc::Path, pieces: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    feed_plan(path, |_, _| pieces.to_vec())
}

/// A plan of `pieces(index, segment)` for every feed segment, none for the others.
fn feed_plan(
    path: &nc::Path,
    mut pieces: impl FnMut(usize, &nc::Segment) -> Vec<(f64, f64)>,
) -> Vec<Vec<(f64, f64)>> {
    path.segments
        .iter()
        .enumerate()
        .map(|(i, s)| match s.motion {
            Motion::Feed { .. } => pieces(i, s),
            _ => vec![],
        })
        .collect()
}

#[test]
fn line_split_in_place_and_other_bytes_kept() {
    let src = "%\n(header)\nG21 G90 G17\nG0 X0 Y0 Z5\nN10 G1 Z0 F300 (plunge)\nN20 X10 ; cut\nG0 Z5\nM30\n%\n";
    let path = parse(src);
    let mut plan = uniform(&path, 250.0);
    plan[2] = vec![(0.3, 500.0), (1.0, 812.7)];
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert_eq!(
        out,
        "%\n(header)\nG21 G90 G17\nG0 X0 Y0 Z5\nN10 G1 Z0 F250 (plunge)\nN20 X3 F500 ; cut\nG1 X10 F812.7\nG0 Z5\nM30\n%\n"
    );
    let new = parse(&out);
    // Feed decimals are kept (six significant digits).
    assert_eq!(feeds(&new), vec![250.0, 500.0, 812.7]);
    assert_eq!(new.segments[3].end, path.segments[2].end);
    // Source lines of the split pieces: the original line, then the inserted one.
    assert_eq!((new.segments[2].line, new.segments[3].line), (6, 7));
}

#[test]
fn f_word_added_before_comments_and_crlf_kept() {
    let src = "G1 X5 F100\r\nX6 (no feed word)\r\nX7;end\r\n";
    let path = parse(src);
    let out = nc::refeed(src, "t.ngc", &Options::default(), &uniform(&path, 1234.9)).unwrap();
    assert_eq!(
        out,
        "G1 X5 F1234.9\r\nX6 F1234.9 (no feed word)\r\nX7 F1234.9;end\r\n"
    );
}

#[test]
fn incremental_inch_split_lands_exactly() {
    let src = "G20 G91\nG1 X1 Y0.5 F10\nX-0.3 Z-0.1\n";
    let path = parse(src);
    let mut plan = uniform(&path, 254.0);
    plan[0] = vec![(1.0 / 3.0, 127.0), (2.0 / 3.0, 200.0), (1.0, 254.0)];
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    let new = parse(&out);
    assert_eq!(new.segments.len(), 4, "{out}");
    // Feeds are written in inch/min, six significant digits rounded down.
    let f = feeds(&new);
    assert!(
        (f[0] - 127.0).abs() < 1e-9
            && f[1] <= 200.0
            && f[1] > 199.97
            && (f[2] - 254.0).abs() < 1e-9,
        "{f:?}"
    );
    for (a, b) in [(2, 0), (3, 1)] {
        assert!(
            (new.segments[a].end - path.segments[b].end).norm() < 1e-9,
            "{out}"
        );
    }
    let third = new.segments[0].end;
    assert!(
        (third - nalgebra::Point3::new(25.4 / 3.0, 12.7 / 3.0, 0.0)).norm() < 1e-4,
        "{third}"
    );
}

#[test]
fn f_in_a_line_that_changes_units_is_read_in_the_old_units() {
    // LinuxCNC reads F before G21 in the same block: F500 here is 500 inch/min.
    let src = "G20 G1 X1 F10\nG21 G1 X100 F500\nG1 X200\n";
    let path = parse(src);
    // (and F10 before G20 on the first line is 10 mm/min).
    assert_eq!(feeds(&path), vec![10.0, 12700.0, 12700.0]);
    let plan = vec![
        vec![(1.0, 10.0)],
        vec![(0.5, 1270.0), (1.0, 2540.0)],
        vec![(1.0, 3000.0)],
    ];
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert_eq!(
        out,
        "G20 G1 X1 F10\nG21 G1 X62.7 F50\nG1 X100 F2540\nG1 X200 F3000\n"
    );
}

#[test]
fn arcs_split_on_the_circle_ij_and_r() {
    // Ends of the pieces at fractions 0.25, 0.5 and 1, worked out by hand: a
    // counter-clockwise half circle, and a clockwise helical full circle.
    let half = [
        [50f64.sqrt(), 50f64.sqrt(), 0.0],
        [0.0, 10.0, 0.0],
        [-10.0, 0.0, 0.0],
    ];
    let helix = [[0.0, -10.0, -0.75], [-10.0, 0.0, -1.5], [10.0, 0.0, -3.0]];
    for (src, ends) in [
        ("G0 X10 Y0\nG17 G3 X-10 Y0 I-10 J0 F600\n", half),
        ("G0 X10 Y0\nG3 X-10 Y0 R10 F600\n", half),
        ("G0 X10 Y0 Z0\nG2 I-10 Z-3 F600\n", helix),
    ] {
        let path = parse(src);
        let mut plan = uniform(&path, 600.0);
        plan[1] = vec![(0.25, 300.0), (0.5, 400.0), (1.0, 600.0)];
        let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
        let new = parse(&out);
        assert_eq!(new.segments.len(), 4, "{out}");
        assert_eq!(feeds(&new), vec![300.0, 400.0, 600.0]);
        let original = path.segments[1];
        let total: f64 = new.segments[1..].iter().map(|s| s.length_mm()).sum();
        assert!(
            (total - original.length_mm()).abs() < 1e-4,
            "{total} vs {}",
            original.length_mm()
        );
        for (k, s) in new.segments[1..].iter().enumerate() {
            let Geometry::Arc {
                center, clockwise, ..
            } = s.geometry
            else {
                panic!("piece {k} is not an arc:\n{out}")
            };
            let Geometry::Arc {
                center: c0,
                clockwise: cw0,
                ..
            } = original.geometry
            else {
                unreachable!()
            };
            assert!(
                (center.xy() - c0.xy()).norm() < 1e-5 && clockwise == cw0,
                "{out}"
            );
            assert!(
                (s.end - nalgebra::Point3::from(ends[k])).norm() < 1e-5,
                "{out}"
            );
        }
        assert!(
            !out.contains('R'),
            "R words are replaced by centres when split:\n{out}"
        );
    }
}

#[test]
fn inverse_time_pieces_get_their_own_times() {
    let src = "G0 X0 Y5\nG93 G1 X100 F10\nG94\n";
    let path = parse(src);
    assert_eq!(feeds(&path), vec![1000.0]);
    let plan = vec![vec![], vec![(0.5, 1000.0), (1.0, 500.0)]];
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert_eq!(out, "G0 X0 Y5\nG93 G1 X50 F20\nG1 X100 F10\nG94\n");
    assert_eq!(feeds(&parse(&out)), vec![1000.0, 500.0]);
}

/// The subroutine's feed line runs twice with different feeds: a counter and
/// a table give each run its own F. The drilling cycle's lines, one feed
/// each, keep their text with their own F.
#[test]
fn repeated_lines_get_a_feed_per_run_and_cycles_the_lowest() {
    let src = "o100 sub\nG1 X[#1] F500\no100 endsub\nG0 Z5\no100 call [10]\no100 call [20]\nG98 G81 X30 Y0 Z-2 R1 F200\nX40\nG80\nM2\n";
    let path = parse(src);
    let mut plan: Vec<Vec<(f64, f64)>> = vec![vec![]; path.segments.len()];
    let mut next = 700.0;
    for (i, s) in path.segments.iter().enumerate() {
        if matches!(s.motion, Motion::Feed { .. }) {
            plan[i] = vec![(1.0, next)];
            next -= 100.0;
        }
    }
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert_eq!(
        out,
        "(dexcut: feeds of lines run more than once, one per run)\n#1000 = 0\n#1001 = 700\n#1002 = 600\n\
         o100 sub\n#1000 = [#1000 + 1]\nG1 X[#1] F#[#1000 + 1000]\no100 endsub\nG0 Z5\no100 call [10]\no100 call [20]\n\
         G98 G81 X30 Y0 Z-2 R1 F500\nX40 F400\nG80\nM2\n"
    );
    let new = parse(&out);
    assert_eq!(feeds(&new), vec![700.0, 600.0, 500.0, 400.0]);
    assert_eq!(new.segments.len(), path.segments.len());
    // A loop under G93 with a leading `%`: each run's F is its own inverse time.
    let src = "%\nG0 X0 Y0 Z1\nG93\n#1 = 1\no1 while [#1 LE 3]\nG1 X[#1 * 10] F1\n#1 = [#1 + 1]\no1 endwhile\nG94\nM2\n%\n";
    let path = parse(src);
    let mut plan: Vec<Vec<(f64, f64)>> = vec![vec![]; path.segments.len()];
    for (i, s) in path.segments.iter().enumerate() {
        if matches!(s.motion, Motion::Feed { .. }) {
            plan[i] = vec![(1.0, 100.0 * i as f64)];
        }
    }
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(out.starts_with("%\n(dexcut: "), "{out}");
    let new = parse(&out);
    // 10 mm at 100, 200, 300 mm/min: inverse times 10, 20, 30 per minute.
    assert_eq!(feeds(&new), vec![100.0, 200.0, 300.0], "{out}");
    // A program that names a parameter of the table range keeps the lowest feed.
    let src =
        "#1500 = 2\no100 sub\nG1 X[#1] F500\no100 endsub\no100 call [10]\no100 call [20]\nM2\n";
    let path = parse(src);
    let plan = feed_plan(&path, |i, _| vec![(1.0, 300.0 + 100.0 * i as f64)]);
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    let lowest = plan
        .iter()
        .filter_map(|p| p.first().map(|x| x.1))
        .fold(f64::INFINITY, f64::min);
    assert!(out.contains(&format!("G1 X[#1] F{lowest}\n")), "{out}");
    assert!(!out.contains("dexcut"), "{out}");
}

/// A line run several times whose runs need different pieces (a piece in
/// air at a high feed, the cut at a low one, at another fraction each run)
/// is split in the same number of blocks every run, each run's end points
/// and feeds read from a table: the program reads back to each run's pieces
/// exactly, under G90 and G91, on lines and arcs.
#[test]
fn repeated_lines_get_their_own_pieces_per_run() {
    for src in [
        "G0 X-5 Y0 Z1\no100 sub\nG1 X[#1] Z[#2] F500\nG0 X-5\no100 endsub\no100 call [10] [0]\no100 call [20] [-1]\no100 call [30] [-2]\nM2\n",
        "G0 X0 Y0 Z1\no1 repeat [3]\nG91 G1 X10 Y2 F500\nG90\no1 endrepeat\nM2\n",
        "G0 X10 Y0 Z0\n#1 = 0\no1 while [#1 LT 3]\nG3 X-10 Y0 Z[-#1] I-10 J0 F500\nG0 X10 Y0\n#1 = [#1 + 1]\no1 endwhile\nM2\n",
    ] {
        let path = parse(src);
        let mut plan: Vec<Vec<(f64, f64)>> = vec![vec![]; path.segments.len()];
        let mut run = 0;
        for (i, s) in path.segments.iter().enumerate() {
            if matches!(s.motion, Motion::Feed { .. }) {
                // Run 0: one piece; run 1: two; run 2: three, at other fractions.
                plan[i] = match run {
                    0 => vec![(1.0, 400.0)],
                    1 => vec![(0.3, 3000.0), (1.0, 250.0)],
                    _ => vec![(0.2, 2500.0), (0.65, 300.5), (1.0, 1200.0)],
                };
                run += 1;
            }
        }
        assert_eq!(run, 3, "{src}");
        let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
        assert!(out.contains("#1000 = [#1000 + 1]\n"), "{out}");
        let new = parse(&out);
        // Every run in three blocks: the longest piece halved where a run has fewer.
        let expect: Vec<Vec<(f64, f64)>> = vec![
            vec![(0.5, 400.0), (0.75, 400.0), (1.0, 400.0)],
            vec![(0.3, 3000.0), (0.65, 250.0), (1.0, 250.0)],
            vec![(0.2, 2500.0), (0.65, 300.5), (1.0, 1200.0)],
        ];
        let (mut j, mut run) = (0, 0);
        for s in &path.segments {
            if !matches!(s.motion, Motion::Feed { .. }) {
                assert!((new.segments[j].end - s.end).norm() < 1e-6);
                j += 1;
                continue;
            }
            for &(frac, feed) in &expect[run] {
                let p = &new.segments[j];
                let want = if frac >= 1.0 { s.end } else { s.point_at_fraction(frac) };
                assert!((p.end - want).norm() < 2e-6, "{out}\nrun {run} at {frac}: {:?} vs {want:?}", p.end);
                assert!(matches!(p.motion, Motion::Feed { feed_mm_min, .. } if (feed_mm_min - feed).abs() < 1e-9), "{out}");
                j += 1;
            }
            run += 1;
        }
        assert_eq!(j, new.segments.len(), "{out}");
    }
}

/// A line that once runs without moving (a zero-length move makes no
/// segment) still counts that run: its record keeps it still (any F; the
/// point where the tool is when the line is split), and every run that moves
/// reads its own pieces. Where that point cannot be written exactly (the
/// tool at X10/3 from a line not re-fed), the split line falls back to its
/// lowest feed.
#[test]
fn a_run_without_motion_keeps_its_record() {
    for (x, split) in [("10", false), ("10", true), ("[10 / 3]", true)] {
        let src = format!("o100 sub\nG1 X[#1] F500\no100 endsub\nG0 X{x}\no100 call [{x}]\no100 call [20]\no100 call [30]\nM2\n");
        let path = parse(&src);
        let plan = feed_plan(&path, |i, _| match split {
            true => vec![(0.5, 1000.0 + 100.0 * i as f64), (1.0, 300.0)],
            false => vec![(1.0, 300.0 + 100.0 * i as f64)],
        });
        assert_eq!(feeds(&path).len(), 2);
        let out = nc::refeed(&src, "t.ngc", &Options::default(), &plan).unwrap();
        let new = feeds(&parse(&out));
        let planned: Vec<f64> = plan.iter().flatten().map(|p| p.1).collect();
        if x == "10" {
            assert!(out.contains("#1000 = [#1000 + 1]"), "{out}");
            assert_eq!(new, planned, "{out}");
        } else {
            assert!(!out.contains("#1000"), "{out}");
            let lowest = planned.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(new.iter().all(|f| *f == lowest), "{out}");
        }
    }
}

#[test]
fn bad_plans_are_rejected() {
    let src = "G1 X10 F100\n";
    let opts = Options::default();
    assert!(matches!(
        nc::refeed(src, "t.ngc", &opts, &[]),
        Err(nc::RefeedError::PlanLength { .. })
    ));
    for bad in [
        vec![(0.5, 100.0)],
        vec![(0.6, 100.0), (0.4, 100.0), (1.0, 1.0)],
        vec![(1.0, 0.0)],
        vec![(1.0, f64::NAN)],
    ] {
        let err = nc::refeed(src, "t.ngc", &opts, &[bad]).unwrap_err();
        assert!(err.to_string().starts_with("t.ngc:1: feed plan"), "{err}");
    }
    let err = nc::refeed("G1 X10\n", "t.ngc", &opts, &[vec![(1.0, 5.0)]]).unwrap_err();
    assert!(err.to_string().starts_with("t.ngc:1:1:"), "{err}");
}

/// Every program of the corpus, every feed block split in three with
/// different feeds: the re-fed program parses to the same path, pieces end
/// where the plan says (refeed verifies this itself before returning).
#[test]
fn corpus_round_trip_with_split_blocks() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../toolpaths");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let file = entry.unwrap().path();
        if file.extension().is_none_or(|e| e != "ngc") {
            continue;
        }
        let src = std::fs::read_to_string(&file).unwrap();
        let path = parse(&src);
        let plan = feed_plan(&path, |i, s| match s.length_mm() > 1.0 {
            true => vec![(0.2, 100.0 + i as f64), (0.7, 2000.0), (1.0, 900.5)],
            false => vec![(1.0, 321.0)],
        });
        let name = file.display().to_string();
        let (out, read) = nc::refeed_read(&src, &name, &Options::default(), &plan)
            .unwrap_or_else(|e| panic!("{e}"));
        // What the writer read back to check is what a reader gets.
        assert_eq!(read, nc::parse(&out, &name, &Options::default()), "{name}");
        let new = parse(&out);
        assert!(new.segments.len() >= path.segments.len());
        assert!(
            (new.length_mm() - path.length_mm()).abs() < 1e-3 * (1.0 + path.length_mm() * 1e-3),
            "{}",
            file.display()
        );
        checked += 1;
    }
    assert!(checked >= 5);
}

/// An arc piece too short to survive the 6 written decimals would read back
/// as a full circle (start = end): the verification must catch it, as it
/// catches a vanishing line piece.
#[test]
fn arc_piece_shorter_than_the_written_digits_is_refused() {
    let src = "G0 X10 Y0\nG3 X-10 Y0 I-10 J0 F600\n";
    let path = parse(src);
    let mut plan = uniform(&path, 600.0);
    plan[1] = vec![(1e-9, 300.0), (1.0, 600.0)];
    let err = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap_err();
    assert!(matches!(err, nc::RefeedError::Verification { .. }), "{err}");
}

/// Canned cycles whose feed moves need two feeds (air above the stock fast,
/// the hole slow) are written out as G0/G1/G4 blocks of their moves: the
/// program reads back to the same moves, each feed move in its planned
/// pieces, the dwell of G82 kept.
#[test]
fn canned_cycles_needing_two_feeds_are_written_out() {
    let src = "G21 G90 G17\nG0 X0 Y0 Z20\nG98 G81 X10 Y5 Z-3 R2 F150\nX20\nG99 G82 X30 Y5 Z-2 R2 P0.5\nG80\nG0 Z20\nM2\n";
    let path = parse(src);
    let plan = every_feed(&path, &[(0.4, 3000.0), (1.0, 120.5)]);
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(!out.contains("G81") && !out.contains("G82"), "{out}");
    assert!(out.contains("G4 P0.5"), "{out}");
    assert_as_planned(&path, &plan, &parse(&out), 1e-6, &out);
}

/// Canned cycle lines run more than once, each run needing its own feeds: in
/// an o-word loop (the hole moves with the loop's parameter, a cycle line
/// with only X continuing it) and in a subroutine called twice (under G91
/// with an L repeat). Each run is written out as its own moves, chosen by a
/// run counter, and the program reads back to every run's pieces in the
/// plan's time. (Before, the cycle lines stayed, at the lowest feed of all
/// their runs.)
pub const CYCLES_RUN_MORE_THAN_ONCE: &str = "o100 sub\nG91 G98 G81 X6 Y0 R-8 Z-5 L2 F150\nG90 G80\no100 endsub\n\
    G21 G90 G17\nG0 X0 Y0 Z10\n#1 = 0\no1 repeat [3]\nG99 G81 X[10 + 10 * #1] Y5 Z-3 R2 F150\nX[15 + 10 * #1]\n\
    G80\n#1 = [#1 + 1]\no1 endrepeat\nG0 X0 Y20 Z10\no100 call\nG0 X30 Y20 Z10\no100 call\nM2\n";

#[test]
fn cycles_run_more_than_once_are_written_out_per_run() {
    let src = CYCLES_RUN_MORE_THAN_ONCE;
    let path = parse(src);
    let plan = drill_plan(&path, |x, _| x > 12.0 && x < 40.0);
    let distinct: std::collections::BTreeSet<String> = plan
        .iter()
        .filter(|p| !p.is_empty())
        .map(|p| format!("{p:?}"))
        .collect();
    assert!(distinct.len() >= 6, "{distinct:?}");
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(!out.contains("G81"), "a cycle kept:\n{out}");
    assert_as_planned(&path, &plan, &parse(&out), 1e-6, &out);
}

/// `new` (a re-fed program read back) makes the moves of `path`, every feed
/// move in the pieces of `plan`: each piece ends where the plan says (within
/// `tol_mm`), the pieces of a move are as long as it, each runs at its
/// planned feed rounded down to the digits written (never above it), and the
/// feed moves take the plan's time within 0.1 %.
fn assert_as_planned(
    path: &nc::Path,
    plan: &[Vec<(f64, f64)>],
    new: &nc::Path,
    tol_mm: f64,
    out: &str,
) {
    let mut j = 0;
    let mut plan_min = 0.0;
    for (s, pieces) in path.segments.iter().zip(plan) {
        match s.motion {
            Motion::Feed { .. } => {
                let mut length_mm = 0.0;
                let mut from = 0.0;
                for &(frac, feed) in pieces {
                    let p = new
                        .segments
                        .get(j)
                        .unwrap_or_else(|| panic!("too few moves:\n{out}"));
                    let want = if frac >= 1.0 {
                        s.end
                    } else {
                        s.point_at_fraction(frac)
                    };
                    assert!(
                        (p.end - want).norm() < tol_mm,
                        "line {}: ends at {} instead of {want}:\n{out}",
                        s.line,
                        p.end
                    );
                    assert!(
                        matches!(p.motion, Motion::Feed { feed_mm_min, .. } if feed_mm_min <= feed * (1.0 + 1e-12) && feed_mm_min >= feed * (1.0 - 1e-5)),
                        "line {}: {:?} instead of {feed}:\n{out}",
                        s.line,
                        p.motion
                    );
                    length_mm += p.length_mm();
                    plan_min += s.length_mm() * (frac - from) / feed;
                    from = frac;
                    j += 1;
                }
                assert!(
                    (length_mm - s.length_mm()).abs() < tol_mm,
                    "line {}:\n{out}",
                    s.line
                );
            }
            m => {
                let p = new
                    .segments
                    .get(j)
                    .unwrap_or_else(|| panic!("too few moves:\n{out}"));
                assert_eq!(
                    std::mem::discriminant(&p.motion),
                    std::mem::discriminant(&m),
                    "{out}"
                );
                assert!((p.end - s.end).norm() < tol_mm, "line {}:\n{out}", s.line);
                assert!(
                    (p.length_mm() - s.length_mm()).abs() < tol_mm,
                    "line {}:\n{out}",
                    s.line
                );
                j += 1;
            }
        }
    }
    assert_eq!(j, new.segments.len(), "{out}");
    let written_min = feed_time_min(new);
    assert!(
        (written_min / plan_min - 1.0).abs() < 1e-3,
        "written {written_min} min, planned {plan_min} min"
    );
}

/// The plan of drilling into a stock whose top is at z = 0 under the holes
/// where `stock(x, y)` holds, nothing under the others: feed moves in air at
/// 3000 mm/min, in the stock at 100 mm/min + |x| (each hole its own), a move
/// that enters the stock split where it does.
fn drill_plan(path: &nc::Path, stock: impl Fn(f64, f64) -> bool) -> Vec<Vec<(f64, f64)>> {
    feed_plan(path, |_, s| {
        let (z0, z1) = (s.start.z, s.end.z);
        let slow = 100.0 + s.end.x.abs();
        if !stock(s.end.x, s.end.y) || z1 >= 0.0 {
            vec![(1.0, 3000.0)]
        } else if z0 <= 0.0 {
            vec![(1.0, slow)]
        } else {
            vec![(z0 / (z0 - z1), 3000.0), (1.0, slow)]
        }
    })
}

/// Canned cycles repeated by L under G91 (a G81 in mm, a G83 peck cycle in
/// inches, G20 in its line) and polar ones (`^` and `@` increments repeated by L, a polar
/// hole under G90), over a stock under only some of their holes: every
/// repeat is written out as its own G0/G1 blocks, in the distance mode and
/// units its line sets (which stay in force after it), and the program reads
/// back to the same moves, each repeat's feed moves in its own pieces, in
/// the plan's time. (Before, a line with G91 or polar words kept its cycle
/// at the lowest feed of all its repeats.)
#[test]
fn cycles_repeated_by_l_and_polar_cycles_are_written_out_per_repeat() {
    type Stock = fn(f64, f64) -> bool;
    let cases: [(&str, Stock, &[&str]); 3] = [
        (
            "G21 G90 G17\nG0 X0 Y0 Z10\nG91 G98 G81 X10 Y2 R-8 Z-5 L4 F150\nG80\nG0 X5 Z5\nG90 G0 Z20\nM2\n",
            |x, _| x > 25.0,
            &["G91 G98\nG0 X10 Y2 Z0\n", "G80\nG0 X5 Z5\n"],
        ),
        (
            "G21 G90 G17\nG0 X0 Y0 Z12.7\nG20 G91 G99 G83 X0.4 Y0.1 R-0.4 Z-0.3 Q0.08 L3 F6\nG80\nG90 G0 Z1\nM2\n",
            |x, _| x > 15.0,
            &["G20 G91 G99\nG0 X0.4 Y0.1 Z0\nG0 X0 Y0 Z-0.4\n"],
        ),
        (
            "G20 G90\nG0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\nG90 @1 ^33\nG91 G81 @0.5 R.1 Z-0.5 L3\nG80\nM2\n",
            |_, y| y > 0.0,
            &["G91\nG0 X0 Y0 Z0.1\nG0 X-0.75 Y1.299038 Z0\n", "G90\nG0 X0.838671 Y0.544639 Z"],
        ),
    ];
    for (src, stock, written) in cases {
        let path = parse(src);
        let plan = drill_plan(&path, stock);
        // The repeats need different pieces.
        let distinct: std::collections::BTreeSet<String> = plan
            .iter()
            .filter(|p| !p.is_empty())
            .map(|p| format!("{p:?}"))
            .collect();
        assert!(distinct.len() >= 3, "{distinct:?}");
        let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
        for cycle in ["G81", "G83", "L", "@", "^"] {
            assert!(!out.contains(cycle), "{cycle} kept:\n{out}");
        }
        for w in written {
            assert!(out.contains(w), "no {w:?}:\n{out}");
        }
        // Inch coordinates are written to 6 decimals (25 nm).
        assert_as_planned(&path, &plan, &parse(&out), 1e-4, &out);
    }
}

/// A loop with an `if`, a nested `do`/`while` and a subroutine call in it,
/// whose two cutting lines run 400 times each.
pub const MANY_RUNS: &str = "o100 sub\nG0 Z[#1]\no100 endsub\nG0 X0 Y0 Z1\n#1 = 0\n\
    o1 while [#1 LT 800]\no2 if [[#1 MOD 2] EQ 0]\nG1 X[#1 / 10] Y1 F500\no2 else\nG1 X[#1 / 10] Y0 F500\no2 endif\n\
    #2 = 0\no4 do\n#2 = [#2 + 1]\no4 while [#2 LT 2]\n\
    o3 if [[#1 MOD 100] EQ 0]\no100 call [[#1 / 100 + 1]]\no3 endif\n#1 = [#1 + 1]\no1 endwhile\nM2\n";

/// Run `k` of a feed move: in air at a high feed up to a fraction that moves
/// with `k`, then the cut at its own feed.
fn run_pieces(k: usize) -> Vec<(f64, f64)> {
    vec![
        (0.3 + 0.08 * (k % 5) as f64, 3000.0 - k as f64),
        (1.0, 250.0 + 0.5 * k as f64),
    ]
}

/// [`run_pieces`] for every feed segment in turn.
fn runs_plan(path: &nc::Path) -> Vec<Vec<(f64, f64)>> {
    let mut run = 0;
    path.segments
        .iter()
        .map(|s| match s.motion {
            Motion::Feed { .. } => {
                run += 1;
                run_pieces(run - 1)
            }
            _ => vec![],
        })
        .collect()
}

/// Feed lines in polar coordinates (`G1 @ ^`, LinuxCNC): under G90 about
/// the program origin, under G91 from the current point's radius and angle,
/// in inches, one with Z, and one in a loop whose runs read their pieces
/// from a table. Lines needing several feeds are split, each piece written
/// as Cartesian X Y: the program reads back to the planned pieces in the
/// plan's time. (Before, polar lines were never split: the lowest feed of
/// their pieces.)
pub const POLAR_FEEDS: &str = "G21 G90 G17\nG0 X0 Y0 Z1\nG1 @20 ^30 F600\nG1 @20 ^75 Z-1\nG91 G1 @-5 ^15\n\
    G1 ^-40\nG90 G20 G1 @0.5 ^200\nG21\n#1 = 0\no1 repeat [3]\nG1 @[10 + 3 * #1] ^[100 + 20 * #1] F500\n#1 = [#1 + 1]\no1 endrepeat\nM2\n";

#[test]
fn polar_feed_lines_are_split_in_cartesian_pieces() {
    let src = POLAR_FEEDS;
    let path = parse(src);
    let plan = feed_plan(&path, |i, _| {
        vec![
            (0.35 + 0.05 * i as f64, 2000.0 - i as f64),
            (1.0, 200.0 + i as f64),
        ]
    });
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(
        !out.contains('@') && !out.contains('^'),
        "polar words kept:\n{out}"
    );
    assert!(out.contains("G91 G1 X"), "{out}");
    assert_as_planned(&path, &plan, &parse(&out), 1e-4, &out);
}

/// A loop whose runs need their own pieces, with more records than the
/// numbered parameters 1000–4999 hold (800 runs × 2 blocks × X, Y, F): the
/// loop is written out in full, as its lines ran, and every run reads back
/// to its own pieces exactly.
#[test]
fn loops_whose_records_do_not_fit_are_unrolled() {
    let path = parse(MANY_RUNS);
    let plan = runs_plan(&path);
    assert_eq!(plan.iter().filter(|p| !p.is_empty()).count(), 800);
    let (out, read) = nc::refeed_read(MANY_RUNS, "t.ngc", &Options::default(), &plan).unwrap();
    // The unrolled text's reading, as a reader gets it.
    assert_eq!(read, nc::parse(&out, "t.ngc", &Options::default()));
    // No loop or branch is left; the subroutine stays one, called as before.
    for gone in [
        "o1 while",
        "o1 endwhile",
        "o2 if",
        "o2 else",
        "o4 do",
        "o3 if",
    ] {
        assert!(!out.contains(gone), "{gone} left");
    }
    assert_eq!(out.matches("o100 call").count(), 8);
    assert!(
        out.starts_with("o100 sub\nG0 Z[#1]\no100 endsub\n"),
        "{}",
        &out[..200]
    );
    let new = parse(&out);
    let (mut j, mut run) = (0, 0);
    for s in &path.segments {
        if !matches!(s.motion, Motion::Feed { .. }) {
            assert!((new.segments[j].end - s.end).norm() < 1e-9);
            j += 1;
            continue;
        }
        for (frac, feed) in run_pieces(run) {
            let p = &new.segments[j];
            let want = if frac >= 1.0 {
                s.end
            } else {
                s.point_at_fraction(frac)
            };
            assert!(
                (p.end - want).norm() < 2e-6,
                "run {run} at {frac}: {:?} vs {want:?}",
                p.end
            );
            assert!(
                matches!(p.motion, Motion::Feed { feed_mm_min, .. } if (feed_mm_min - feed).abs() < 1e-9),
                "run {run}: {:?} vs {feed}",
                p.motion
            );
            j += 1;
        }
        run += 1;
    }
    assert_eq!(j, new.segments.len());
    // The same loop with few runs keeps its loop and reads a table.
    let few = MANY_RUNS.replace("LT 800", "LT 80");
    let path = parse(&few);
    let plan = runs_plan(&path);
    let out = nc::refeed(&few, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(
        out.contains("o1 while") && out.contains("#1000 = [#1000 + 1]"),
        "{out}"
    );
}

/// Σ length / feed over the feed moves, minutes.
fn feed_time_min(path: &nc::Path) -> f64 {
    path.segments
        .iter()
        .map(|s| match s.motion {
            Motion::Feed { feed_mm_min, .. } => s.length_mm() / feed_mm_min,
            _ => 0.0,
        })
        .sum()
}

/// A subroutine line called 300 times from a loop, each run needing five
/// pieces: 300 × 5 blocks × X, Y, F do not fit the table and the line is in
/// no loop to unroll. Every run is written in four blocks instead, the two
/// neighbours whose merge costs least time merged at the lower feed: never
/// above the plan, within 2 % of its time, and far faster than the lowest
/// feed of all runs.
#[test]
fn subroutine_lines_with_too_many_records_are_split_in_fewer_blocks() {
    let src = "o100 sub\nG1 X[#1] Y[#2] F500\no100 endsub\nG0 X-5 Y0 Z0\n#3 = 0\n\
        o1 while [#3 LT 300]\no100 call [[#3 MOD 2] * 20] [#3 / 10]\n#3 = [#3 + 1]\no1 endwhile\nM2\n";
    let path = parse(src);
    let mut run = 0.0;
    let plan = feed_plan(&path, |_, _| {
        run += 1.0;
        vec![
            (0.2, 3000.0 - run),
            (0.5, 800.0),
            (0.55, 790.0),
            (0.7, 2000.0),
            (1.0, 300.0 + run),
        ]
    });
    assert_eq!(run, 300.0);
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(out.contains("F#[#1000 * 12 + "), "not four blocks of X Y F");
    let new = parse(&out);
    assert_eq!(new.segments.len(), path.segments.len() + 300 * 3);
    let plan_min: f64 = path
        .segments
        .iter()
        .zip(&plan)
        .map(|(s, pieces)| {
            let mut from = 0.0;
            pieces
                .iter()
                .map(|&(to, f)| {
                    let t = (to - from) * s.length_mm() / f;
                    from = to;
                    t
                })
                .sum::<f64>()
        })
        .sum();
    let written = feed_time_min(&new);
    assert!(
        written >= plan_min * (1.0 - 1e-6) && written <= plan_min * 1.02,
        "{written} vs {plan_min}"
    );
    let lowest = plan
        .iter()
        .flatten()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min);
    let length: f64 = path
        .segments
        .iter()
        .filter(|s| matches!(s.motion, Motion::Feed { .. }))
        .map(nc::Segment::length_mm)
        .sum();
    assert!(
        written < 0.5 * length / lowest,
        "{written} vs {}",
        length / lowest
    );
}

/// A file read as most controls read it (no program end, a byte-order mark)
/// is written as LinuxCNC reads it too: the mark dropped, `M2` added in the
/// file's own line ending, every move and feed as planned.
#[test]
fn tolerant_files_are_written_with_an_end_and_no_byte_order_mark() {
    let tolerant = Options {
        file_form: nc::FileForm::Tolerant,
        ..Options::default()
    };
    let linuxcnc = Options {
        file_form: nc::FileForm::LinuxCnc,
        ..Options::default()
    };
    for (src, eol) in [
        ("\u{feff}G0 X0 Y0 Z5\nG1 Z0 F300\nX10", "\n"),
        ("G0 X0 Y0 Z5\r\nG1 Z0 F300\r\nX10\r\n", "\r\n"),
    ] {
        let read = nc::parse(src, "t.ngc", &tolerant);
        assert!(!read.has_program_end);
        let plan = uniform(&read.path, 420.0);
        let (out, read_back) = nc::refeed_read(src, "t.ngc", &tolerant, &plan).unwrap();
        assert_eq!(read_back, nc::parse(&out, "t.ngc", &tolerant));
        assert!(!out.starts_with('\u{feff}'), "{out:?}");
        assert!(
            out.ends_with(&format!(
                "X10 F420{eol}M2 (program end added by dexcut: the original had none){eol}"
            )),
            "{out:?}"
        );
        let back = nc::parse(&out, "t.ngc", &linuxcnc);
        assert!(back.diagnostics.is_empty(), "{:?}", back.diagnostics);
        assert!(back.has_program_end);
        assert_eq!(feeds(&back.path), vec![420.0, 420.0]);
        let ends = |p: &nc::Path| p.segments.iter().map(|s| s.end).collect::<Vec<_>>();
        assert_eq!(ends(&back.path), ends(&read.path));
    }
    // A dialect word LinuxCNC refuses (FreeCAD's K0 on an XY arc) is written as it reads it.
    let src = "G17 G0 X0 Y0 Z1\nG1 X1 F300\nG3 X2 Y1 I0 J1 K0.000\nM2\n";
    let read = nc::parse(src, "t.ngc", &tolerant);
    let out = nc::refeed(src, "t.ngc", &tolerant, &uniform(&read.path, 420.0)).unwrap();
    assert_eq!(
        out,
        "G17 G0 X0 Y0 Z1\nG1 X1 F420\nG3 X2 Y1 I0 J1 F420\nM2\n"
    );
    assert!(nc::parse(&out, "t.ngc", &linuxcnc).diagnostics.is_empty());
    // A whole file as LinuxCNC reads it, and a fragment, are written as they were.
    let src = "G1 X10 F300\nM2\n";
    let path = nc::parse(src, "t.ngc", &tolerant).path;
    let out = nc::refeed(src, "t.ngc", &tolerant, &uniform(&path, 500.0)).unwrap();
    assert_eq!(out, "G1 X10 F500\nM2\n");
    let out = nc::refeed(
        "G1 X10 F300\n",
        "t.ngc",
        &Options::default(),
        &uniform(&path, 500.0),
    )
    .unwrap();
    assert_eq!(out, "G1 X10 F500\n");
}

/// The re-feed along the caller's path ([`nc::refeed_read_along`]) writes
/// and reads back what [`nc::refeed_read`] does, whether the path handed
/// over is the source's own bit for bit (then the source's reading holds no
/// copy of it) or not: an end moved by one ulp in the middle, a 0 given as −0, one
/// segment short, one segment more. The corpus (its cutter compensation
/// files among them), loops unrolled and a tolerant file (read again
/// amended).
#[test]
fn the_reading_along_a_lent_path_writes_the_same_text() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../toolpaths");
    let tolerant = Options {
        file_form: nc::FileForm::Tolerant,
        ..Options::default()
    };
    let mut programs: Vec<(String, String, Options)> = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let file = entry.unwrap().path();
        if file.extension().is_some_and(|e| e == "ngc") {
            let src = std::fs::read_to_string(&file).unwrap();
            programs.push((file.display().to_string(), src, Options::default()));
        }
    }
    assert!(programs.iter().any(|(name, _, _)| name.contains("g41")));
    programs.push(("many_runs".into(), MANY_RUNS.into(), Options::default()));
    programs.push((
        "bom".into(),
        "\u{feff}G0 X0 Y0 Z5\nG1 Z0 F300\nX10\nG2 X20 I5 J0\n".into(),
        tolerant,
    ));
    let mut variants_checked = 0;
    for (name, src, options) in &programs {
        let path = nc::parse(src, name, options).path;
        let plan = feed_plan(&path, |i, s| match s.length_mm() > 1.0 {
            true => vec![(0.25, 150.0 + i as f64), (1.0, 800.5)],
            false => vec![(1.0, 321.0)],
        });
        let want = nc::refeed_read(src, name, options, &plan).unwrap_or_else(|e| panic!("{e}"));
        let n = path.segments.len();
        let mut moved = path.segments.clone();
        moved[n / 2].end.x = f64::from_bits(moved[n / 2].end.x.to_bits() + 1);
        let mut signed = path.segments.clone();
        let zero = signed
            .iter_mut()
            .flat_map(|s| s.end.coords.iter_mut())
            .find(|v| **v == 0.0);
        let has_zero = zero.map(|v| *v = -0.0).is_some();
        let longer: Vec<nc::Segment> = path
            .segments
            .iter()
            .chain(path.segments.last())
            .copied()
            .collect();
        let variants: [(&str, &[nc::Segment]); 5] = [
            ("the same", &path.segments),
            ("one end moved", &moved),
            ("-0 for 0", if has_zero { &signed } else { &moved }),
            ("one short", &path.segments[..n - 1]),
            ("one more", &longer),
        ];
        for (what, lent) in variants {
            let lent = nc::Path {
                segments: lent.to_vec(),
                ..Default::default()
            };
            let got = nc::refeed_read_along(src, name, options, &plan, lent)
                .unwrap_or_else(|e| panic!("{name}, {what}: {e}"));
            assert!(
                got == want,
                "{name}, {what}: the text or its reading differs"
            );
            variants_checked += 1;
        }
    }
    assert!(variants_checked >= 5 * 9, "{variants_checked}");
}

/// The modes (G61, G61.1, G64 P Q, in the block's units) of `path`, each
/// with the end point of the segment before it.
fn modes_at_ends(path: &nc::Path) -> Vec<(Option<[f64; 3]>, nc::PathControl)> {
    path.path_control
        .iter()
        .map(|c| {
            let before = c
                .first_segment
                .checked_sub(1)
                .map(|k| path.segments[k].end.coords.into());
            (before, c.mode)
        })
        .collect()
}

#[test]
fn path_control_is_recorded_per_segment_and_kept_by_refeed() {
    use nc::PathControl::{Blend, ExactPath, ExactStop};
    let src = "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z0 F300\nG64 P0.05 Q0.02 G1 X10\nX20 Y5\nG61 X30\n\
               G61.1\nG1 Y10\nG20 G64 P0.001\nG1 X0\nG64\nY0\nM30\n";
    let path = parse(src);
    let blend = |p: Option<f64>, q: Option<f64>| Blend {
        tolerance_mm: p,
        naive_cam_mm: q,
    };
    let want = vec![
        (Some([0.0, 0.0, 0.0]), blend(Some(0.05), Some(0.02))),
        (Some([20.0, 5.0, 0.0]), ExactPath),
        (Some([30.0, 5.0, 0.0]), ExactStop),
        (Some([30.0, 10.0, 0.0]), blend(Some(0.0254), None)),
        (Some([0.0, 10.0, 0.0]), blend(None, None)),
    ];
    assert_eq!(modes_at_ends(&path), want);
    assert_eq!(path.path_control_at(1), None);
    assert_eq!(path.path_control_at(2), Some(blend(Some(0.05), Some(0.02))));
    assert_eq!(path.path_control_at(7), Some(blend(None, None)));
    // Split blocks: the G64 words stay on the written block's first piece.
    let plan = every_feed(&path, &[(0.5, 400.0), (1.0, 700.0)]);
    let out = nc::refeed(src, "t.ngc", &Options::default(), &plan).unwrap();
    assert!(out.contains("G64 P0.05 Q0.02 G1 X5 F400"), "{out}");
    let again = parse(&out);
    assert_eq!(modes_at_ends(&again), want, "{out}");
}

#[test]
fn motion_waits_are_recorded_before_the_moves_they_hold() {
    // LinuxCNC's task waits for motion to stop at spindle, coolant and tool
    // changes: before segments 1 (M3 S), 2 (M8) and 3 (M5 M9 then M6).
    let src = "G21 G90\nG0 X1\nM3 S1000\nG1 X2 F100\nM8\nG1 X3\nM5\nM9\nT2 M6\nG0 X4\nG1 X5\nM2\n";
    let p = parse(src);
    assert_eq!(p.motion_waits, vec![1, 2, 3]);
}
