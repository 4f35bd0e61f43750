//! One insta snapshot per spec in `specs/`, from the run-time engine: the basis list, `K`, the
//! naive size, `c(p)` and the identifiability summary. Any change to the engine's result shows
//! up as a diff to review (`cargo insta review`); CI runs with `INSTA_UPDATE=no`.

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
    let _ = writeln!(s, "generalized_params:");
    let c = m
        .generalized_param_strings()
        .expect("a freshly built model keeps c(p)");
    for (e, row) in c.iter().enumerate() {
        for (k, c) in row.iter().enumerate() {
            let _ = writeln!(s, "  c[{e}][{k}] = {c}");
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
