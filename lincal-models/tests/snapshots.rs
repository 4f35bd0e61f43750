//! One insta snapshot per spec in `specs/`, from the run-time engine: the model in the form
//! the derive embeds it, small enough to review as a diff (`cargo insta review`; CI runs with
//! `INSTA_UPDATE=no`):
//! - the chain, one elementary motion per line: the per-link parameter parts;
//! - `K`, the naive size and the basis `Φ̃_k = Σ R_{k,m}·m(q)`, one function per line (its
//!   pivot, the monomial `c_{e,k}(p)` is read at, is its first term);
//! - the identifiable set, the held parameters and the gauge.
//!
//! `c(p)` is not printed: it is the chain's contraction at each pivot
//! (`lincal_core::model::factored`), fixed by the lines above, and tested against the exact
//! polynomials by the engine's own tests and `tests/equivalence.rs`.

use std::fmt::Write as _;

use lincal_core::model::chain::{Axis, Factor};
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

/// One factor as `Rz(q1 + 0.1 - th1)`: a rotation or translation about an axis, by its
/// constant, joint reading and parameter terms.
fn factor(f: &Factor, names: &[String]) -> String {
    let kind = if f.rotation { 'R' } else { 'T' };
    let axis = match f.axis {
        Axis::X => 'x',
        Axis::Y => 'y',
        Axis::Z => 'z',
    };
    let mut parts: Vec<String> = Vec::new();
    if let Some(j) = f.joint {
        parts.push(format!("q{}", j + 1));
    }
    if f.constant != 0.0 || (parts.is_empty() && f.terms.iter().all(Option::is_none)) {
        parts.push(num(f.constant));
    }
    let mut text = parts.join(" + ");
    for t in f.terms.iter().flatten() {
        let name = &names[t.param];
        let term = if t.coef == 1.0 {
            name.clone()
        } else if t.coef == -1.0 {
            format!("-{name}")
        } else {
            format!("{}*{name}", num(t.coef))
        };
        if text.is_empty() {
            text = term;
        } else if let Some(neg) = term.strip_prefix('-') {
            let _ = write!(text, " - {neg}");
        } else {
            let _ = write!(text, " + {term}");
        }
    }
    format!("{kind}{axis}({text})")
}

fn summary(m: &SymbolicModel) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "name: {}", m.name());
    let _ = writeln!(s, "joints: {}", m.joint_count());
    let _ = writeln!(s, "params: [{}]", m.param_names().join(", "));
    let _ = writeln!(s, "chain:");
    for f in m.chain() {
        let _ = writeln!(s, "  - {}", factor(f, m.param_names()));
    }
    let _ = writeln!(s, "naive_size: {}", m.naive_size());
    let _ = writeln!(s, "basis_size: {}", m.basis_size());
    let _ = writeln!(s, "basis:");
    for (k, b) in m.basis_names().iter().enumerate() {
        let _ = writeln!(s, "  {k}: {b}");
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
