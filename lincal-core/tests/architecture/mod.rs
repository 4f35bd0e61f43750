//! The shape of `lincal-core/src`, checked on every test run:
//!
//! - **stages point down**: every module belongs to a stage (its top-level folder or file), and
//!   a module imports only from its own stage or from stages below it in [`STAGES`];
//! - **no import cycle** between modules (files), found as strongly connected components of
//!   the graph of `crate::`/`super::`/`self::` paths in non-test code;
//! - **sizes**: no file over [`MAX_FILE_LINES`] lines before its tests, no function over
//!   [`MAX_FN_LINES`] lines.
//!
//! Test code (after a file's first `#[cfg(test)]`/`#[cfg(all(test, …))]` item, and modules
//! declared under `#[cfg(test)]`) and comments are not read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The stages, lowest first: a module may import from its own stage or an earlier one.
/// `lib` (the crate root) may name everything.
const STAGES: &[&[&str]] = &[
    &["error", "progress", "cancel", "cores"],
    &["model"],
    &["numeric"],
    &["spec"],
    &["symbolic"],
    &["program"],
    &["data", "urdf"],
    &["fit"],
    &["calibrate"],
    &["report"],
    &["simulate"],
    &["select"],
    &["compensate"],
];

const MAX_FILE_LINES: usize = 800;
const MAX_FN_LINES: usize = 80;

/// One source file as a module: its path (`fit::solve`), and its non-test lines.
struct Module {
    name: String,
    file: PathBuf,
    lines: Vec<String>,
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn module_name(rel: &Path) -> String {
    let mut parts: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
        parts.pop();
    }
    parts.join("::")
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("read src")
        .map(|e| e.expect("dir entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Whether line `l` starts test-only code at the item level.
fn starts_tests(l: &str) -> bool {
    let t = l.trim_start();
    t.starts_with("#[cfg(test)]") || t.starts_with("#[cfg(all(test")
}

/// Every module of the crate with its non-test code, test-only modules left out.
fn modules() -> Vec<Module> {
    let src = src_dir();
    let mut files = Vec::new();
    walk(&src, &mut files);
    let mut all = Vec::new();
    let mut test_only: BTreeSet<String> = BTreeSet::new();
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read file");
        let name = module_name(f.strip_prefix(&src).expect("under src"));
        let raw: Vec<&str> = text.lines().collect();
        // `#[cfg(test)] mod x;` declares a test-only file module.
        for w in raw.windows(2) {
            if starts_tests(w[0]) {
                let d = w[1].trim();
                if let Some(m) = d.strip_prefix("mod ").and_then(|r| r.strip_suffix(';')) {
                    let child = if name.is_empty() {
                        m.to_string()
                    } else {
                        format!("{name}::{m}")
                    };
                    test_only.insert(child);
                }
            }
        }
        // Test code starts at the first top-level test item.
        let end = raw
            .iter()
            .position(|l| l.starts_with("#[cfg(test)]") || l.starts_with("#[cfg(all(test"))
            .unwrap_or(raw.len());
        // `#![cfg(test)]` makes the whole file test code.
        let end = if raw.iter().any(|l| l.trim() == "#![cfg(test)]") {
            0
        } else {
            end
        };
        let lines = raw[..end].iter().map(|l| (*l).to_string()).collect();
        all.push(Module {
            name,
            file: f,
            lines,
        });
    }
    all.retain(|m| !test_only.contains(&m.name));
    all
}

/// The code of a line, without its `//` comment (doc comments included) and string literals.
fn code(l: &str) -> String {
    let mut out = String::new();
    let mut in_str = false;
    let mut prev = ' ';
    let b: Vec<char> = l.chars().collect();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if in_str {
            if c == '"' && prev != '\\' {
                in_str = false;
            }
        } else if c == '"' {
            in_str = true;
        } else if c == '/' && b.get(i + 1) == Some(&'/') {
            break;
        } else {
            out.push(c);
        }
        prev = if prev == '\\' && c == '\\' { ' ' } else { c };
        i += 1;
    }
    out
}

/// The module paths a line names: `crate::a::b`, `super::x`, `self::y`, and the grouped
/// `crate::{a::b, c}` form, resolved against `this` (the module the line is in; `is_dir_mod`
/// when it is a `mod.rs`/`lib.rs`, whose `super` is its parent).
fn named_paths(line: &str, this: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let seg = |s: &str| -> Vec<String> {
        s.split("::")
            .map(|x| {
                x.trim()
                    .trim_matches(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .to_string()
            })
            .take_while(|x| !x.is_empty() && x.chars().next().is_some_and(char::is_lowercase))
            .collect()
    };
    let here: Vec<String> = if this.is_empty() {
        Vec::new()
    } else {
        this.split("::").map(str::to_string).collect()
    };
    for (anchor, base) in [
        ("crate::", Vec::new()),
        ("super::", here[..here.len().saturating_sub(1)].to_vec()),
        ("self::", here.clone()),
    ] {
        let mut rest = line;
        while let Some(at) = rest.find(anchor) {
            // Not part of a longer identifier (`lincal_core::` is another crate).
            let before = rest[..at].chars().last();
            let tail = &rest[at + anchor.len()..];
            rest = tail;
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let groups: Vec<String> = if let Some(g) = tail.strip_prefix('{') {
                let inner = g.split('}').next().unwrap_or("");
                inner.split(',').map(str::to_string).collect()
            } else {
                let end = tail
                    .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .unwrap_or(tail.len());
                vec![tail[..end].to_string()]
            };
            for g in groups {
                let mut p = base.clone();
                p.extend(seg(&g));
                out.push(p);
            }
        }
    }
    out
}

/// The longest prefix of `path` that is a module (the root `""` at worst).
fn resolve(path: &[String], known: &BTreeSet<String>) -> String {
    for n in (1..=path.len()).rev() {
        let cand = path[..n].join("::");
        if known.contains(&cand) {
            return cand;
        }
    }
    String::new()
}

fn stage_of(module: &str) -> Option<usize> {
    let top = module.split("::").next().unwrap_or("");
    STAGES.iter().position(|s| s.contains(&top))
}

/// `module → modules it imports` (non-test code, itself and its own ancestors' re-export
/// edges left out: a `mod.rs` naming its children in `pub use` is a facade, not a dependency).
fn graph(mods: &[Module]) -> BTreeMap<String, BTreeSet<String>> {
    let known: BTreeSet<String> = mods.iter().map(|m| m.name.clone()).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for m in mods {
        let is_dir_mod = m
            .file
            .file_name()
            .is_some_and(|f| f == "mod.rs" || f == "lib.rs");
        // `super` of `a/b.rs` (module `a::b`) is `a`; of `a/mod.rs` (module `a`) the root:
        // both are "drop the last segment" of the module path.
        let edges = g.entry(m.name.clone()).or_default();
        for l in &m.lines {
            let c = code(l);
            let reexport = c.trim_start().starts_with("pub use")
                || c.trim_start().starts_with("pub(crate) use");
            for p in named_paths(&c, &m.name) {
                let to = resolve(&p, &known);
                let child_of_this =
                    is_dir_mod && (m.name.is_empty() || to.starts_with(&format!("{}::", m.name)));
                if to == m.name || (reexport && child_of_this) || m.name.is_empty() {
                    continue;
                }
                edges.insert(to);
            }
        }
    }
    g
}

/// Strongly connected components of more than one module (Tarjan).
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        t.on.insert(v);
        if let Some(ws) = t.g.get(v) {
            for w in ws {
                let w = w.as_str();
                if !t.index.contains_key(w) {
                    visit(t, w);
                    let lw = t.low[w];
                    let lv = t.low[v];
                    t.low.insert(v, lv.min(lw));
                } else if t.on.contains(w) {
                    let iw = t.index[w];
                    let lv = t.low[v];
                    t.low.insert(v, lv.min(iw));
                }
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn every_module_belongs_to_a_stage() {
    let lost: Vec<String> = modules()
        .iter()
        .filter(|m| !m.name.is_empty() && stage_of(&m.name).is_none())
        .map(|m| m.name.clone())
        .collect();
    assert!(lost.is_empty(), "modules outside every stage: {lost:?}");
}

#[test]
fn stages_import_only_downward() {
    let g = graph(&modules());
    let mut up = Vec::new();
    for (from, tos) in &g {
        let Some(a) = stage_of(from) else { continue };
        for to in tos {
            if let Some(b) = stage_of(to) {
                if b > a {
                    up.push(format!("{from} → {to}"));
                }
            }
        }
    }
    assert!(up.is_empty(), "imports from a stage above: {up:#?}");
}

#[test]
fn no_import_cycle() {
    let c = cycles(&graph(&modules()));
    assert!(c.is_empty(), "import cycles: {c:#?}");
}

#[test]
fn no_file_over_the_limit_before_its_tests() {
    let big: Vec<String> = modules()
        .iter()
        .filter(|m| m.lines.len() > MAX_FILE_LINES)
        .map(|m| format!("{} ({} lines)", m.file.display(), m.lines.len()))
        .collect();
    assert!(
        big.is_empty(),
        "files over {MAX_FILE_LINES} lines: {big:#?}"
    );
}

/// Whether code `t` (trimmed) starts an `fn` item: any visibility (`pub`, `pub(crate)`,
/// `pub(super)`, `pub(in …)`), then any of `const`, `async`, `unsafe`, `extern "…"`, then `fn`.
fn starts_fn(t: &str) -> bool {
    let mut rest = t;
    if let Some(r) = rest.strip_prefix("pub") {
        rest = r.trim_start();
        if rest.starts_with('(') {
            match rest.find(')') {
                Some(k) => rest = rest[k + 1..].trim_start(),
                None => return false,
            }
        }
    }
    loop {
        let before = rest;
        for q in ["const ", "async ", "unsafe ", "extern "] {
            if let Some(r) = rest.strip_prefix(q) {
                rest = r.trim_start();
            }
        }
        if rest == before {
            break;
        }
    }
    rest.starts_with("fn ")
}

/// Functions: from a line whose code starts an `fn` item to the `}` at its indentation.
#[test]
fn no_function_over_the_limit() {
    let mut long = Vec::new();
    for m in modules() {
        let lines = &m.lines;
        let mut i = 0;
        while i < lines.len() {
            let c = code(&lines[i]);
            let t = c.trim_start();
            let indent = c.len() - t.len();
            let is_fn = starts_fn(t);
            let t = &format!(" {t}");
            if is_fn && !t.trim_end().ends_with(';') {
                let close = format!("{}}}", " ".repeat(indent));
                // A one-line body ends on its own line.
                let end = if t.trim_end().ends_with('}') {
                    Some(i)
                } else {
                    lines[i + 1..]
                        .iter()
                        .position(|l| l.trim_end() == close)
                        .map(|k| i + 1 + k)
                };
                if let Some(e) = end {
                    let n = e - i + 1;
                    if n > MAX_FN_LINES {
                        let name = t.split(" fn ").nth(1).unwrap_or(t);
                        let name = name.split(['(', '<']).next().unwrap_or(name);
                        long.push(format!("{}:{} {name} ({n} lines)", m.file.display(), i + 1));
                    }
                }
            }
            i += 1;
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines: {long:#?}"
    );
}

/// The checks above can fail: the graph sees imports the code is known to make, and the cycle
/// search finds a planted cycle.
#[test]
fn the_checks_see_what_they_check() {
    let g = graph(&modules());
    assert!(
        g["fit::solve"].contains("numeric::linalg"),
        "{:?}",
        g["fit::solve"]
    );
    assert!(
        g["spec::chain"].contains("model::chain"),
        "{:?}",
        g["spec::chain"]
    );
    assert!(g.keys().any(|k| k.starts_with("calibrate")));
    let mut planted: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    planted.insert("a".into(), ["b".to_string()].into());
    planted.insert("b".into(), ["c".to_string()].into());
    planted.insert("c".into(), ["a".to_string()].into());
    planted.insert("d".into(), ["a".to_string()].into());
    assert_eq!(
        cycles(&planted),
        vec![vec!["a".to_string(), "b".into(), "c".into()]]
    );
    assert!(starts_fn("pub(super) fn x() {") && starts_fn("pub(crate) const fn y()"));
    assert!(starts_fn("fn z<T>(") && starts_fn("pub unsafe fn w(") && !starts_fn("// fn x"));
    assert!(!starts_fn("let fn_x = 1;") && !starts_fn("pub struct F;"));
    assert_eq!(
        named_paths("use super::{Convention, Spec};", "spec::chain"),
        vec![
            vec!["spec".to_string(), "Convention".into()],
            vec!["spec".to_string(), "Spec".into()]
        ]
        .into_iter()
        .map(|v| v.into_iter().take(1).collect::<Vec<_>>())
        .collect::<Vec<_>>()
    );
}
