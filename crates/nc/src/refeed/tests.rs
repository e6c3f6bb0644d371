use super::*;

/// The check keeps of the source's path only its ends, lengths, motions
/// and lines ([`Expected`]), and refuses each change of them as the
/// path itself did: the written text read back passes; a moved end, an
/// arc round another centre to the same end, a feed move made a rapid and
/// a feed above the plan each fail, with the line they are on.
#[test]
fn the_check_refuses_each_change_the_path_would() {
    let src = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10 F600\nG2 X20 Y0 I5 J0 F600\nG0 Z5\n";
    let options = Options::default();
    let path = crate::parse(src, "t.ngc", &options).path;
    let plan: Vec<Vec<(f64, f64)>> = path
        .segments
        .iter()
        .map(|s| match s.motion {
            Motion::Feed { .. } => vec![(1.0, 500.0)],
            _ => Vec::new(),
        })
        .collect();
    let expected: Vec<Expected> = path.segments.iter().map(Expected::of).collect();
    let written = WrittenPlan {
        plan: &plan,
        coarse: BTreeMap::new(),
    };
    let pieces = vec![1; plan.len()];
    let check = |text: &str| verify(text, "t.ngc", &options, &expected, &written, &pieces);
    let good = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10 F500\nG2 X20 Y0 I5 J0 F500\nG0 Z5\n";
    assert_eq!(
        check(good).expect("the plan's feeds read back").path,
        crate::parse(good, "t.ngc", &options).path
    );
    for (text, says) in [
        (good.replace("X10 F500", "X10.01 F500"), "line 3: ends at"),
        (
            good.replace("I5 J0", "I5 J5"),
            "line 4: 33.3216 mm long instead of 15.7080 mm",
        ),
        (
            good.replace("G1 X10 F500", "G0 X10"),
            "line 3: motion kind changed",
        ),
        (
            good.replace("X10 F500", "X10 F501"),
            "line 3: feed 501.000 above the plan's 500.000",
        ),
    ] {
        let err = check(&text).expect_err(&text).to_string();
        assert!(err.contains(says), "{text}: {err}");
    }
}

/// A run along a lent path holds none of it where it makes it bit for
/// bit (its own path empty, [`interp::Trace::on_lent_path`]), and is
/// otherwise the plain recorded run: the same path (the lent one, or its
/// own), trace and executed lines. A lent path that differs (an end moved
/// by one ulp, one segment short or more) gives the run its own path; so
/// does cutter compensation, which moves a segment's end after it is made.
#[test]
fn a_run_along_a_lent_path_holds_it_only_where_it_differs() {
    let plain = "G0 X0 Y0 Z1\nG1 Z-1 F300\nG1 X10\nG2 X20 Y0 I5 J0\nG0 Z5\nM2\n";
    let comp = "T1 M6\nG0 X-5 Y-5 Z1\nG1 Z-1 F300\nG41.1 D4 X0 Y0\nG1 X10\nY10\nG40 X15 Y15\nM2\n";
    let options = Options::default();
    for (src, along) in [(plain, true), (comp, false)] {
        let (want, trace, executed) = interp::run_recorded(src, "t.ngc", &options);
        assert!(want.diagnostics.is_empty(), "{:?}", want.diagnostics);
        let path = &want.path.segments;
        let n = path.len();
        let mut moved = path.clone();
        moved[n / 2].end.y = f64::from_bits(moved[n / 2].end.y.to_bits() + 1);
        let longer: Vec<Segment> = path.iter().chain(path.last()).copied().collect();
        for (lent, same) in [
            (&path[..], along),
            (&moved[..], false),
            (&path[..n - 1], false),
            (&longer[..], false),
        ] {
            let (got, t, e) = interp::run_recorded_along(src, "t.ngc", &options, lent);
            assert_eq!(t.on_lent_path, same, "{src}");
            let made = if same { lent } else { &got.path.segments[..] };
            assert_eq!(got.path.segments.is_empty(), same);
            assert!(made.len() == n && made.iter().zip(path).all(|(a, b)| a.same_bits(b)));
            assert_eq!(
                (&got.diagnostics, &t.segments, &e),
                (&want.diagnostics, &trace.segments, &executed)
            );
        }
    }
}

/// The flat per-line columns list each line's segments as a map of one
/// `Vec` per line does: lines run many times by a loop and a subroutine,
/// lines that make no segment, and the last line.
#[test]
fn line_segments_are_each_lines_segments_ascending() {
    let src = "o100 sub\nG1 Z[#1] F100\no100 endsub\nG0 X0 Y0 Z1\n#1 = 0\n\
        o1 while [#1 LT 5]\nG1 X[#1] F500\nY[#1]\no2 if [#1 EQ 2]\no100 call [-1]\no2 endif\n\
        #1 = [#1 + 1]\no1 endwhile\nG0 Z5\n";
    let (parsed, trace, _) = interp::run_recorded(src, "t.ngc", &Options::default());
    assert!(parsed.diagnostics.is_empty(), "{:?}", parsed.diagnostics);
    let mut map: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, t) in trace.segments.iter().enumerate() {
        map.entry(t.line_index).or_default().push(i);
    }
    assert!(map.values().any(|s| s.len() == 4), "{map:?}");
    let flat = lines_segments(&trace);
    let listed: Vec<(usize, Vec<usize>)> = flat
        .iter()
        .map(|(line, segs)| (line, segs.to_vec()))
        .collect();
    assert_eq!(listed, map.clone().into_iter().collect::<Vec<_>>());
    for line in 0..=trace.lines.len() + 1 {
        assert_eq!(
            flat.get(line),
            map.get(&line).map(Vec::as_slice),
            "line {line}"
        );
    }
}
