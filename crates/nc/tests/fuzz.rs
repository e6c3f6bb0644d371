//! Property tests: `parse` never panics and every diagnostic points inside
//! the input. Run longer with `PROPTEST_CASES=200000 cargo test -p nc --test fuzz --release`.

use nc::Options;
use proptest::prelude::*;

fn check(src: &str) {
    let options = Options {
        max_blocks: 20_000,
        ..Options::default()
    };
    let parsed = nc::parse(src, "fuzz.ngc", &options);
    // Lines end at \n, \r\n or a lone \r, as LinuxCNC reads them.
    let unified = src.replace("\r\n", "\n");
    let lines: Vec<&str> = unified.split(['\n', '\r']).collect();
    for d in &parsed.diagnostics {
        assert!(
            d.line >= 1 && (d.line as usize) <= lines.len(),
            "{d} outside {} lines",
            lines.len()
        );
        let cols = lines[d.line as usize - 1].chars().count() as u32 + 1;
        assert!(
            d.column >= 1 && d.column <= cols,
            "{d}: column outside 1..={cols}"
        );
    }
    for s in &parsed.path.segments {
        assert!(
            s.start.iter().chain(s.end.iter()).all(|v| v.is_finite()),
            "{s:?}"
        );
    }
}

const TOKENS: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G4",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G28",
    "G30",
    "G40",
    "G41",
    "G43",
    "G53",
    "G54",
    "G59",
    "G80",
    "G81",
    "G82",
    "G83",
    "G73",
    "G90",
    "G91",
    "G90.1",
    "G91.1",
    "G92",
    "G93",
    "G94",
    "G98",
    "G99",
    "G10 L2 P1",
    "M3",
    "M5",
    "M6",
    "M98",
    "M99",
    "M30",
    "X",
    "Y",
    "Z",
    "I",
    "J",
    "K",
    "R",
    "P",
    "Q",
    "L",
    "F",
    "S",
    "T",
    "1",
    "-2.5",
    "0",
    ".",
    "..",
    "1e5",
    "360",
    "#1",
    "#<a>",
    "=",
    "[",
    "]",
    "**",
    "*",
    "/",
    "MOD",
    "SIN",
    "ATAN",
    "SQRT",
    "LN",
    "LT",
    "AND",
    "(",
    ")",
    ";",
    "%",
    "\n",
    "\n",
    "\n",
    "o1",
    "o2",
    "sub",
    "endsub",
    "call",
    "while",
    "endwhile",
    "if",
    "else",
    "endif",
    "repeat",
    "endrepeat",
    "break",
    "continue",
    "O1000",
    "N10",
    " ",
    "#2=",
    "1e308",
    "999999999",
    "-0",
];

/// Lines of the test corpus (toolpaths/), for mutation.
fn corpus_lines() -> &'static [String] {
    static LINES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    LINES.get_or_init(|| {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../toolpaths");
        let mut lines = Vec::new();
        for e in std::fs::read_dir(dir).expect("toolpaths/") {
            let p = e.expect("entry").path();
            if p.extension().is_some_and(|e| e == "ngc") {
                lines.extend(
                    std::fs::read_to_string(&p)
                        .expect("read")
                        .lines()
                        .map(String::from),
                );
            }
        }
        lines
    })
}

proptest! {
    /// Real programs' lines, a window of up to 60, with up to 8 byte edits.
    #[test]
    fn mutated_corpus_never_panics(
        start in any::<prop::sample::Index>(),
        len in 1usize..60,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), 0u8..3, any::<u8>()), 0..8),
    ) {
        let lines = corpus_lines();
        let first = start.index(lines.len());
        let mut bytes = lines[first..(first + len).min(lines.len())].join("\n").into_bytes();
        for (at, kind, byte) in edits {
            let i = at.index(bytes.len() + 1);
            match kind {
                0 => bytes.insert(i, byte),
                1 if i < bytes.len() => { bytes.remove(i); }
                _ if i < bytes.len() => bytes[i] = byte,
                _ => {}
            }
        }
        check(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        check(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn token_soup_never_panics(tokens in proptest::collection::vec(proptest::sample::select(TOKENS), 0..120)) {
        check(&tokens.concat());
    }

    #[test]
    fn spaced_token_soup_never_panics(tokens in proptest::collection::vec(proptest::sample::select(TOKENS), 0..120)) {
        check(&tokens.join(" "));
    }
}
