//! The layer order of `docs/ARCHITECTURE.md` holds in `src/`: every file is in exactly one
//! layer, no file imports one of a higher layer, and no files import each other, directly or
//! through others. Imports are read from the source text: `use` trees and `crate::` / `super::`
//! / `self::` paths in code (and `photon::` in the binary's files), without comments, strings
//! and test modules. A crate of its own rather than a module of `integration/`: it reads source
//! text and never links the library, and `cargo test --release --test layers` is the command
//! every change of layout is checked with.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// Every `.rs` file under `src/`, as its path relative to `src/` without the extension.
fn source_files() -> BTreeSet<String> {
    fn walk(dir: &Path, prefix: &str, out: &mut BTreeSet<String>) {
        for entry in std::fs::read_dir(dir).expect("read src") {
            let path = entry.expect("entry").path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                walk(&path, &format!("{prefix}{name}/"), out);
            } else if let Some(stem) = name.strip_suffix(".rs") {
                out.insert(format!("{prefix}{stem}"));
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(&root().join("src"), "", &mut out);
    out
}

/// The layer of every file, from the ```layers block of the architecture document.
fn layers(files: &BTreeSet<String>) -> BTreeMap<String, usize> {
    let doc = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).expect("doc");
    let block = doc
        .split("```layers\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a ```layers block in docs/ARCHITECTURE.md");
    let mut layer_of = BTreeMap::new();
    for line in block.lines().filter(|l| !l.trim().is_empty()) {
        let (head, names) = line.split_once(':').expect("'N name: files'");
        let level: usize = head
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .expect("layer");
        for name in names.split_whitespace() {
            let matched: Vec<&String> = match name.strip_suffix("/*") {
                Some(folder) => files
                    .iter()
                    .filter(|f| f.starts_with(&format!("{folder}/")))
                    .collect(),
                None => files.iter().filter(|f| *f == name).collect(),
            };
            assert!(!matched.is_empty(), "layer entry {name} names no file");
            for f in matched {
                let previous = layer_of.insert(f.clone(), level);
                assert!(previous.is_none(), "{f} is in two layers");
            }
        }
    }
    let missing: Vec<&String> = files
        .iter()
        .filter(|f| !layer_of.contains_key(*f))
        .collect();
    assert!(missing.is_empty(), "files in no layer: {missing:?}");
    layer_of
}

/// The source without comments, string and char literals, and everything from the first
/// `#[cfg(test)]` on (test modules end the files that have them).
fn code_only(source: &str) -> String {
    let source = source.split("#[cfg(test)]").next().unwrap();
    let b = source.as_bytes();
    let mut out = String::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let end = source[i + 2..]
                .find("*/")
                .map_or(b.len(), |e| i + 2 + e + 2);
            i = end;
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal ('x' or '\n'); a lone quote is a lifetime.
            let end = source[i + 1..]
                .find('\'')
                .map_or(b.len(), |e| i + 1 + e + 1);
            i = end;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// Identifiers, `::` and single punctuation characters.
fn tokens(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let chars: Vec<char> = code.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(chars[start..i].iter().collect());
        } else if c == ':' && chars.get(i + 1) == Some(&':') {
            out.push("::".into());
            i += 2;
        } else {
            if !c.is_whitespace() {
                out.push(c.to_string());
            }
            i += 1;
        }
    }
    out
}

/// The module paths a use tree starting at `tokens[*i]` names (each as its segments), with
/// `prefix` before them; stops after the tree.
fn use_tree(tokens: &[String], i: &mut usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
    let mut path = prefix;
    loop {
        match tokens.get(*i).map(String::as_str) {
            Some("{") => {
                *i += 1;
                while tokens.get(*i).map(String::as_str) != Some("}") {
                    use_tree(tokens, i, path.clone(), out);
                    if tokens.get(*i).map(String::as_str) == Some(",") {
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            Some("*") => {
                *i += 1;
                out.push(path);
                return;
            }
            Some(t) if t.chars().all(|c| c.is_alphanumeric() || c == '_') => {
                path.push(t.to_string());
                *i += 1;
                if tokens.get(*i).map(String::as_str) == Some("::") {
                    *i += 1;
                    continue;
                }
                if tokens.get(*i).map(String::as_str) == Some("as") {
                    *i += 2;
                }
                out.push(path);
                return;
            }
            _ => return,
        }
    }
}

/// Every module path the file's code names: use trees and inline `crate::`/`super::` paths.
fn named_paths(code: &str) -> Vec<Vec<String>> {
    let t = tokens(code);
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        let after_colons = i > 0 && t[i - 1] == "::";
        if t[i] == "use" && !after_colons {
            i += 1;
            use_tree(&t, &mut i, Vec::new(), &mut out);
        } else if matches!(t[i].as_str(), "crate" | "super" | "self" | "photon")
            && !after_colons
            && t.get(i + 1).map(String::as_str) == Some("::")
        {
            use_tree(&t, &mut i, Vec::new(), &mut out);
        } else {
            i += 1;
        }
    }
    out
}

/// The file (relative to `src/`, without `.rs`) that a path named in `file` refers to, if it
/// is one of ours: the longest prefix of the path that is a file.
fn resolve(file: &str, path: &[String], files: &BTreeSet<String>) -> Option<String> {
    let binary = ["main", "cli", "bench"].contains(&file);
    // The module path of `file`: `a/b/mod` is a::b, `a/c` is a::c; the crate roots are empty.
    let mut module: Vec<String> = file.split('/').map(String::from).collect();
    if matches!(
        module.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        module.pop();
    }
    if binary {
        module = if file == "main" {
            vec![]
        } else {
            vec![file.to_string()]
        };
    }
    let mut full: Vec<String> = match path.first().map(String::as_str) {
        Some("crate") if binary => return Some(path.get(1)?.clone()).filter(|m| files.contains(m)),
        Some("crate") | Some("photon") => path[1..].to_vec(),
        Some("self") => [module.clone(), path[1..].to_vec()].concat(),
        Some("super") => {
            let mut base = module.clone();
            let mut rest = path;
            while rest.first().map(String::as_str) == Some("super") {
                base.pop();
                rest = &rest[1..];
            }
            [base, rest.to_vec()].concat()
        }
        // A bare path: a child module of this one, or another crate.
        Some(_) => [module.clone(), path.to_vec()].concat(),
        None => return None,
    };
    if binary && path.first().map(String::as_str) != Some("photon") {
        return None;
    }
    while !full.is_empty() {
        let joined = full.join("/");
        for candidate in [joined.clone(), format!("{joined}/mod")] {
            if files.contains(&candidate) {
                return Some(candidate);
            }
        }
        full.pop();
    }
    None
}

#[test]
fn no_file_imports_one_above_it_and_no_imports_form_a_cycle() {
    let files = source_files();
    let layer = layers(&files);
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut upward = Vec::new();
    for file in &files {
        let source =
            std::fs::read_to_string(root().join("src").join(format!("{file}.rs"))).expect("source");
        for path in named_paths(&code_only(&source)) {
            let Some(target) = resolve(file, &path, &files) else {
                continue;
            };
            if &target == file {
                continue;
            }
            if layer[&target] > layer[file] {
                upward.push(format!(
                    "{file} (layer {}) imports {target} (layer {}) via {}",
                    layer[file],
                    layer[&target],
                    path.join("::")
                ));
            }
            edges.entry(file.clone()).or_default().insert(target);
        }
    }
    assert!(
        upward.is_empty(),
        "imports up the layer order:\n{}",
        upward.join("\n")
    );

    // Depth-first search for a cycle, reporting it when found.
    fn visit(
        node: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(node) {
            Some(2) => return None,
            Some(1) => {
                let start = stack.iter().position(|n| n == node).unwrap();
                return Some([&stack[start..], &[node.to_string()]].concat());
            }
            _ => {}
        }
        state.insert(node.to_string(), 1);
        stack.push(node.to_string());
        for next in edges.get(node).into_iter().flatten() {
            if let Some(cycle) = visit(next, edges, state, stack) {
                return Some(cycle);
            }
        }
        stack.pop();
        state.insert(node.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for file in &files {
        let cycle = visit(file, &edges, &mut state, &mut Vec::new());
        assert!(
            cycle.is_none(),
            "import cycle: {}",
            cycle.unwrap().join(" -> ")
        );
    }
    // The test sees imports: the integrators import the core.
    assert!(edges["integrator/path"].contains("integrator/walk"));
    assert!(edges["cli"].contains("render"));
}

#[test]
fn the_import_reader_finds_use_trees_and_inline_paths() {
    let code = code_only(
        "use super::{a::B, c}; // use crate::commented;\n\
         use crate::x::{self, y::{Z, W}};\n\
         fn f() { let s = \"crate::in_string\"; crate::inline::g(); }\n\
         #[cfg(test)] mod tests { use crate::test_only; }",
    );
    let paths: Vec<String> = named_paths(&code).iter().map(|p| p.join("::")).collect();
    assert_eq!(
        paths,
        [
            "super::a::B",
            "super::c",
            "crate::x::self",
            "crate::x::y::Z",
            "crate::x::y::W",
            "crate::inline::g"
        ]
    );
}
