//! The shape of the code, checked: `crates/dexcut/src` is layered (a module
//! imports only from its own layer's lower modules or lower layers), no crate
//! of the workspace has an import circle between its modules, and no source
//! file or function grows past what a reader can hold (ARCHITECTURE.md).
//!
//! `cargo test --release -p dexcut --test layers -- --nocapture` prints the
//! import graph of `crates/dexcut/src` it checks.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The layers of `crates/dexcut/src`, lowest first: each top-level module
/// (a file `src/NAME.rs` or a folder `src/NAME/`) and its layer. A module
/// may import from lower layers and, within its layer, only from modules
/// listed before it on its row; `lib.rs` stands above them all.
const DEXCUT_LAYERS: &[&[&str]] = &[
    &["error", "util", "bounds", "progress", "saved_stock"],
    &["model"],
    &["input"],
    &["motion"],
    &["setup"],
    &["run"],
    &["output"],
    &["design", "optimize", "evaluate", "report"],
    &["commands"],
];

/// Longest source file, in lines, and longest function, in lines, outside
/// test code (a `#[cfg(test)]` module or a `tests.rs` file).
const MAX_FILE_LINES: usize = 1500;
const MAX_FN_LINES: usize = 200;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a source file belongs to: `lib` for lib.rs/main.rs,
/// else the first path component under `src` without `.rs`.
fn top_module(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy();
    let name = first.trim_end_matches(".rs").to_string();
    if name == "lib" || name == "main" {
        "lib".into()
    } else {
        name
    }
}

/// The code of a file with comments and string literals blanked, so doc
/// links and texts that mention `crate::x` are not read as imports.
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                if b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 2;
        } else if b[i] == b'r' && (b.get(i + 1) == Some(&b'"') || b.get(i + 1) == Some(&b'#')) {
            // A raw string r"..." or r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while j < b.len() && b[j] == b'#' {
                hashes += 1;
                j += 1;
            }
            if j < b.len() && b[j] == b'"' && (i == 0 || !is_ident(b[i - 1])) {
                j += 1;
                loop {
                    if j >= b.len() {
                        break;
                    }
                    if b[j] == b'"'
                        && b[j + 1..]
                            .iter()
                            .take(hashes)
                            .filter(|&&c| c == b'#')
                            .count()
                            == hashes
                    {
                        j += 1 + hashes;
                        break;
                    }
                    if b[j] == b'\n' {
                        out.push('\n');
                    }
                    j += 1;
                }
                out.push_str("\"\"");
                i = j;
            } else {
                out.push('r');
                i += 1;
            }
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                if i < b.len() && b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            out.push_str("' '");
            i += 3;
        } else if b[i] == b'\'' && b.get(i + 1) == Some(&b'\\') {
            let mut j = i + 2;
            while j < b.len() && b[j] != b'\'' {
                j += 1;
            }
            out.push_str("' '");
            i = j + 1;
        } else {
            let ch = text[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The first segments of every `crate::` path in `code`, `use crate::{a,
/// b::c}` groups included.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let b = code.as_bytes();
    let mut from = 0;
    while let Some(at) = code[from..].find("crate::") {
        let start = from + at;
        from = start + 7;
        if start > 0 && (is_ident(b[start - 1]) || b[start - 1] == b'$') {
            continue;
        }
        let rest = &code[from..];
        let rest = rest.trim_start();
        if let Some(group) = rest.strip_prefix('{') {
            // The group's own top-level names.
            let mut depth = 0;
            let mut item = String::new();
            let mut names = Vec::new();
            for ch in group.chars() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => names.push(std::mem::take(&mut item)),
                    _ if depth == 0 => item.push(ch),
                    _ => {}
                }
            }
            names.push(item);
            for n in names {
                let first: String = n
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !first.is_empty() && first != "self" {
                    found.insert(first);
                }
            }
        } else {
            let first: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !first.is_empty() {
                found.insert(first);
            }
        }
    }
    found
}

/// Each top-level module of a crate's `src` and the top-level modules its
/// files name through `crate::` paths (itself left out).
fn import_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let from = top_module(src, f);
        let code = code_only(&fs::read_to_string(f).unwrap());
        let entry = graph.entry(from.clone()).or_default();
        for to in crate_paths(&code) {
            if to != from {
                entry.insert(to);
            }
        }
    }
    graph
}

/// A circle of the graph's modules, if there is one (depth-first search).
fn find_circle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in graph.get(n).into_iter().flatten() {
            if !graph.contains_key(m) {
                continue; // a re-export at the crate root, not a module
            }
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|s| s == m).unwrap();
                    let mut circle = stack[at..].to_vec();
                    circle.push(m.clone());
                    return Some(circle);
                }
                0 => {
                    if let Some(c) = visit(m, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(n, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn dexcut_modules_import_only_downward() {
    let src = workspace().join("crates/dexcut/src");
    let graph = import_graph(&src);
    let mut rank = BTreeMap::new();
    for (layer, row) in DEXCUT_LAYERS.iter().enumerate() {
        for (i, m) in row.iter().enumerate() {
            rank.insert(m.to_string(), (layer, i));
        }
    }
    println!("import graph of crates/dexcut/src (layer: module -> the modules it imports):");
    let mut wrong = Vec::new();
    for (from, tos) in &graph {
        if from == "lib" {
            continue;
        }
        let imports = tos.iter().cloned().collect::<Vec<_>>().join(", ");
        let Some(&(layer, i)) = rank.get(from) else {
            println!("  L? {from} -> {imports}");
            wrong.push(format!(
                "module `{from}` is in no layer of DEXCUT_LAYERS: add it to the table"
            ));
            continue;
        };
        println!("  L{layer} {from} -> {imports}");
        for to in tos {
            match rank.get(to) {
                Some(&(l, j)) if l < layer || (l == layer && j < i) => {}
                Some(&(l, _)) => wrong.push(format!("`{from}` (layer {layer}) imports `{to}` (layer {l})")),
                None => wrong.push(format!(
                    "`{from}` imports `crate::{to}`, which is no module of a lower layer (a crate-root item: import it from its module)"
                )),
            }
        }
    }
    assert!(wrong.is_empty(), "layering broken:\n{}", wrong.join("\n"));
}

#[test]
fn no_crate_has_an_import_circle_between_its_modules() {
    let mut circles = Vec::new();
    let mut crates: Vec<_> = fs::read_dir(workspace().join("crates"))
        .unwrap()
        .map(|e| e.unwrap().path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    crates.sort();
    assert!(crates.len() >= 9, "the workspace's crates were not found");
    for src in crates {
        let graph = import_graph(&src);
        if let Some(c) = find_circle(&graph) {
            circles.push(format!("{}: {}", src.display(), c.join(" -> ")));
        }
    }
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.join("\n")
    );
}

/// The length in lines of each function that starts in `code` (lines
/// already stripped of comments and strings), as (first line, name, lines).
fn function_lengths(code: &str) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let words: Vec<&str> = line
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .filter(|w| !w.is_empty())
            .collect();
        let Some(at) = words.iter().position(|w| *w == "fn") else {
            continue;
        };
        let Some(name) = words.get(at + 1) else {
            continue;
        };
        // A `fn` keyword in an item header (not `Fn(..)` or a pointer type).
        let before = &words[..at];
        if !before.iter().all(|w| {
            matches!(
                *w,
                "pub"
                    | "crate"
                    | "super"
                    | "in"
                    | "self"
                    | "const"
                    | "async"
                    | "unsafe"
                    | "extern"
                    | "C"
            )
        }) {
            continue;
        }
        let mut depth = 0i64;
        let mut opened = false;
        let mut end = None;
        'scan: for (j, l) in lines.iter().enumerate().skip(i) {
            for ch in l.chars() {
                match ch {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    ';' if !opened && depth == 0 => break 'scan,
                    _ => {}
                }
                if opened && depth == 0 {
                    end = Some(j);
                    break 'scan;
                }
            }
        }
        if let Some(j) = end {
            out.push((i + 1, name.to_string(), j - i + 1));
        }
    }
    out
}

/// The non-test part of a source file: all of it, or what comes before its
/// `#[cfg(test)] mod tests` module; nothing for a `tests.rs` file.
fn non_test_part(path: &Path, code: &str) -> String {
    if path.file_name().is_some_and(|n| n == "tests.rs")
        || path.components().any(|c| c.as_os_str() == "tests")
    {
        return String::new();
    }
    let lines: Vec<&str> = code.lines().collect();
    for (i, l) in lines.iter().enumerate() {
        if l.trim() == "#[cfg(test)]"
            && lines
                .get(i + 1)
                .is_some_and(|n| n.trim_start().starts_with("mod "))
        {
            return lines[..i].join("\n");
        }
    }
    code.to_string()
}

#[test]
fn source_files_and_functions_stay_short() {
    let mut files = Vec::new();
    for c in fs::read_dir(workspace().join("crates")).unwrap() {
        let src = c.unwrap().path().join("src");
        if src.is_dir() {
            rust_files(&src, &mut files);
        }
    }
    assert!(files.len() > 50, "the workspace's sources were not found");
    let mut long = Vec::new();
    for f in &files {
        let text = fs::read_to_string(f).unwrap();
        let code = non_test_part(f, &code_only(&text));
        let n = code.lines().count();
        if n > MAX_FILE_LINES {
            long.push(format!(
                "{}: {n} lines outside tests (at most {MAX_FILE_LINES})",
                f.display()
            ));
        }
        for (line, name, len) in function_lengths(&code) {
            if len > MAX_FN_LINES {
                long.push(format!(
                    "{}:{line}: fn {name} is {len} lines (at most {MAX_FN_LINES})",
                    f.display()
                ));
            }
        }
    }
    assert!(long.is_empty(), "too long:\n{}", long.join("\n"));
}

#[test]
fn the_checks_read_what_they_claim() {
    // The parser finds grouped and plain crate paths, not those in comments
    // or strings.
    let code = code_only(
        "use crate::{a::B, c, d::{e, f}};\nuse crate::g;\n// crate::h\nlet s = \"crate::i\";\nfn x() { crate::j::k(); }\n",
    );
    let found: Vec<_> = crate_paths(&code).into_iter().collect();
    assert_eq!(found, ["a", "c", "d", "g", "j"]);
    let mut g = BTreeMap::new();
    g.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    g.insert("b".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(find_circle(&g).unwrap(), ["a", "b", "a"]);
    let body = (0..250)
        .map(|_| "    x += 1;")
        .collect::<Vec<_>>()
        .join("\n");
    let long = code_only(&format!(
        "pub(crate) fn big() {{\n{body}\n}}\nfn small() {{ 1 }}\n"
    ));
    let lengths = function_lengths(&long);
    assert_eq!(
        lengths,
        [(1, "big".to_string(), 252), (253, "small".to_string(), 1)]
    );
}
