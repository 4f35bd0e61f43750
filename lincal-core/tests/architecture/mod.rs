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

use std::path::{Path, PathBuf};

mod shape;
use shape::{code, cycles, graph, modules_in, named_paths, Module};
use std::collections::{BTreeMap, BTreeSet};

/// The stages, lowest first: a module may import from its own stage or an earlier one.
/// `lib` (the crate root) may name everything.
const STAGES: &[&[&str]] = &[
    &["error", "progress", "cancel", "cores", "memory"],
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

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every module of `lincal-core` with its non-test code.
fn modules() -> Vec<Module> {
    modules_in(&src_dir())
}

fn stage_of(module: &str) -> Option<usize> {
    let top = module.split("::").next().unwrap_or("");
    STAGES.iter().position(|s| s.contains(&top))
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
