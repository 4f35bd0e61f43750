//! One insta snapshot per spec in `specs/`, from the run-time engine: the basis list, `K`, the
//! naive size, `c(p)` and the identifiability summary. Any change to the engine's result shows
//! up as a diff to review (`cargo insta review`); CI runs with `INSTA_UPDATE=no`.
//!
//! A `c(p)` whose text passes [`MAX_C_TEXT`] (`puma560_pose_tracker.yaml`: 12 equations of
//! 729 entries, about 80 MB of polynomials) is pinned entry by entry by its length and a
//! 64-bit FNV-1a hash of its text instead: every change still shows up, only not readable in
//! the diff (print the entry with `SymbolicModel::generalized_param_strings`).

use std::fmt::Write as _;

use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;

/// A float for a snapshot: rounded to 9 significant digits, so that last-bit noise does not
/// make a diff.
fn num(x: f64) -> String {
    let r = format!("{x:.9e}").parse::<f64>().unwrap_or(x);
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r}")
    }
}

/// The longest `c(p)` text (bytes, all entries) a snapshot prints in full (the UR10's, the
/// longest printed, is about 8 MB).
const MAX_C_TEXT: usize = 16 << 20;

/// 64-bit FNV-1a of a string: stable across platforms and Rust versions.
fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn summary(m: &SymbolicModel) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "name: {}", m.name());
    let _ = writeln!(s, "joints: {}", m.joint_count());
    let _ = writeln!(s, "params: [{}]", m.param_names().join(", "));
    let _ = writeln!(s, "naive_size: {}", m.naive_size());
    let _ = writeln!(s, "basis_size: {}", m.basis_size());
    let _ = writeln!(s, "basis:");
    for (k, b) in m.basis_names().iter().enumerate() {
        let _ = writeln!(s, "  {k}: {b}");
    }
    let c = m
        .generalized_param_strings()
        .expect("a freshly built model keeps c(p)");
    let text: usize = c.iter().flatten().map(String::len).sum();
    if text > MAX_C_TEXT {
        let _ = writeln!(
            s,
            "generalized_params: (too long to print, {text} bytes: length and FNV-1a hash of each)"
        );
        for (e, row) in c.iter().enumerate() {
            for (k, c) in row.iter().enumerate() {
                let _ = writeln!(s, "  c[{e}][{k}]: {} {:016x}", c.len(), fnv1a(c));
            }
        }
    } else {
        let _ = writeln!(s, "generalized_params:");
        for (e, row) in c.iter().enumerate() {
            for (k, c) in row.iter().enumerate() {
                let _ = writeln!(s, "  c[{e}][{k}] = {c}");
            }
        }
    }
    let (yes, no) = m.identifiable_split();
    let _ = writeln!(s, "identifiable_count: {}", m.identifiable_count());
    let _ = writeln!(s, "identifiable: [{}]", yes.join(", "));
    let _ = writeln!(s, "unidentifiable: [{}]", no.join(", "));
    let held: Vec<&str> = (0..m.param_count())
        .filter(|&j| m.param_held(j))
        .map(|j| m.param_name(j))
        .collect();
    let _ = writeln!(s, "held: [{}]", held.join(", "));
    let _ = writeln!(s, "gauge:");
    for g in m.gauge() {
        let terms: Vec<String> = g.iter().map(|(n, c)| format!("{n}: {}", num(*c))).collect();
        let _ = writeln!(s, "  - {{{}}}", terms.join(", "));
    }
    s
}

#[test]
fn every_spec() {
    insta::glob!("../specs", "*.yaml", |path| {
        let spec = lincal_core::spec::from_yaml_file(path).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        insta::assert_snapshot!(summary(&m));
    });
}
