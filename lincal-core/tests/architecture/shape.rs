//! The shape checks shared by the crates' architecture tests: a crate's source files as
//! modules (non-test code only), the graph of their `crate::`/`super::`/`self::` imports, and
//! its cycles. `lincal-core` adds its stages; the root crate and the Python crate include this
//! file with `#[path]` for their size and cycle checks.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One source file as a module: its path (`fit::solve`), and its non-test lines.
pub struct Module {
    pub name: String,
    pub file: PathBuf,
    pub lines: Vec<String>,
}

pub fn module_name(rel: &Path) -> String {
    let mut parts: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts
        .last()
        .is_some_and(|l| l == "mod" || l == "lib" || l == "main")
    {
        parts.pop();
    }
    parts.join("::")
}

pub fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
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
pub fn starts_tests(l: &str) -> bool {
    let t = l.trim_start();
    t.starts_with("#[cfg(test)]") || t.starts_with("#[cfg(all(test")
}

/// Every module of the crate with its non-test code, test-only modules left out.
pub fn modules_in(src: &Path) -> Vec<Module> {
    let src = src.to_path_buf();
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
pub fn code(l: &str) -> String {
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
pub fn named_paths(line: &str, this: &str) -> Vec<Vec<String>> {
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
pub fn resolve(path: &[String], known: &BTreeSet<String>) -> String {
    for n in (1..=path.len()).rev() {
        let cand = path[..n].join("::");
        if known.contains(&cand) {
            return cand;
        }
    }
    String::new()
}

/// `module → modules it imports` (non-test code, itself and its own ancestors' re-export
/// edges left out: a `mod.rs` naming its children in `pub use` is a facade, not a dependency).
pub fn graph(mods: &[Module]) -> BTreeMap<String, BTreeSet<String>> {
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
pub fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
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
