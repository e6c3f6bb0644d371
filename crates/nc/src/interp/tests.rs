use super::run::read_lines;
use super::*;
use crate::amend::Amendment;

/// A program parsed where its blocks run ([`parse`], each block's items
/// parsed again from the source, none held) reads as one whose lines
/// are held: the same path, diagnostics, program end and amendments,
/// from the program's start and another, for every real program of the
/// corpus (o-word subroutines and loops, M98 subprograms, arcs, cycles,
/// cutter compensation, inch files) and the tolerant form's mends (a
/// line mended keeps its own items; an edit after G80 or of an arc word
/// finds its item's span in the line parsed again), with the source's
/// byte-order mark, a line ending in CR alone and CR LF. The reading
/// holds no item but a mended line's, and gives every block's items
/// (parsed again, as the re-feed writer asks for them) as the held
/// lines do.
#[test]
fn a_program_parsed_where_it_runs_reads_as_one_held() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    let mut sources: Vec<(String, String)> = std::fs::read_dir(&dir)
        .expect("the corpus")
        .map(|e| e.expect("a corpus file").path())
        .filter(|p| p.extension().is_some_and(|e| e != "md"))
        .map(|p| {
            let bytes = std::fs::read(&p).expect("a corpus file");
            (
                p.display().to_string(),
                String::from_utf8_lossy(&bytes).into_owned(),
            )
        })
        .collect();
    sources.sort();
    assert!(sources.len() >= 90, "{}", sources.len());
    for (name, text) in [
        ("nested", "(Tools: (HSS Twist Drill, 3mm (R)))\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n"),
        ("k0", "\u{feff}G17 G0 X0 Y0 Z1\r\nG1 X1 F300\r\nG3 X2 Y1 I0 J1 K0.000\rM2\n"),
        ("g80", "G0 X0 Y0 Z5\nG98 G81 X1 Y1 Z-1 R2 F100\nX2\nG80\nX0 Y-2 Z6\no1 repeat [2]\nX1 Y1\no1 endrepeat\nM2\n"),
        ("grbl", "G21 G90\n  $I  ; build info\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM2\n"),
        ("subs", "o<s> sub\nG91 G1 X[#1] F100\no<s> endsub\n#2 = 0\no2 while [#2 LT 3]\no<s> call [#2 + 1]\n#2 = [#2 + 1]\no2 endwhile\nG90 G0 X0\nM98 P1000 L2\nM30\nO1000\nG91 G1 Y1\nM99\n"),
        ("syntax error", "G0 X0\nG1 X1 Y F100\nG1 X2\nM2\n"),
    ] {
        sources.push((name.to_owned(), text.to_owned()));
    }
    // Plain lines whose words the run refuses, each with its error and
    // column as the items give them (the plain reading's words).
    let huge = format!("G1 X1{} F100", "0".repeat(400));
    sources.push((
        "plain refusals".to_owned(),
        format!("G0 X0 Y0 Z5\nG1 X1 X2 F100\nG1.7 X1\nM123456789\nT1.5 M6\n{huge}\nG1 X-0 Y.5 Z5. F100\nG1 X12345678901234567 Y0.12345678901234567\nM2\n"),
    ));
    let mut blocks = 0;
    for (name, source) in &sources {
        for file_form in [FileForm::Tolerant, FileForm::LinuxCnc] {
            let options = Options {
                file_form,
                ..Options::default()
            };
            let held = read(source, name, &options);
            let unkept = read_lines(source, name, &options, false);
            // Lines mended as they are read keep their items.
            let mended = held
                .tolerated
                .amendments
                .iter()
                .any(|a| matches!(a, Amendment::Edit { .. }));
            if !mended {
                assert_eq!(unkept.lines.held().0, 0, "{name}");
            }
            blocks += held.lines.held().0;
            assert_eq!(unkept.lines.len(), held.lines.len(), "{name}");
            assert_eq!(unkept.lines.held().1, held.lines.len(), "{name}");
            assert_eq!(held.lines.held().1, 0, "{name}");
            // Every block's items, as the re-feed writer asks for them.
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for index in 0..held.lines.len() {
                assert_eq!(
                    unkept.lines.block_items(index, source, &mut a),
                    held.lines.block_items(index, "", &mut b),
                    "{name} line {}",
                    index + 1
                );
            }
            let start = [3.0, -2.0, 40.0];
            let moved = Options {
                initial_position_mm: start,
                ..options.clone()
            };
            for options in [&options, &moved] {
                let (held, _, executed) =
                    run_read_and_record(&held, "", name, options, true, None, PathRoom::default());
                let streamed = parse(source, name, options);
                assert_eq!(streamed, held, "{name} {file_form:?}");
                assert!(!executed.is_empty(), "{name}");
            }
        }
    }
    assert!(blocks > 100_000, "{blocks}");
}
