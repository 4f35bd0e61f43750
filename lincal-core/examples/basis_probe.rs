//! Times the engine's stages on a spec: `cargo run --release -p lincal-core --example basis_probe -- SPEC
//! [--dump | --whole]` (`--dump` prints everything derived, `--whole` times `from_spec` alone).
//!
//! The stages after `reduce` (compiling `c`, identifiability) are replayed here the
//! way `SymbolicModel::from_spec` runs them, so each can be timed on its own.
use lincal_core::model::CalibModel;
use lincal_core::spec::Constraint;
use lincal_core::symbolic::eval::CompiledPoly;
use lincal_core::symbolic::expand::expand;
use lincal_core::symbolic::identify::analyse;
use lincal_core::symbolic::{reduce::reduce, SymbolicModel};
use std::time::Instant;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: basis_probe SPEC");
        std::process::exit(2);
    };
    let spec = match lincal_core::spec::from_yaml_file(std::path::Path::new(&path)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2)
        }
    };
    if std::env::args().nth(2).as_deref() == Some("--whole") {
        // Only `from_spec`, best of five runs (for profiling and steady timings).
        let mut best = std::time::Duration::MAX;
        for _ in 0..5 {
            let t = Instant::now();
            let Ok(m) = SymbolicModel::from_spec(&spec) else {
                std::process::exit(1)
            };
            best = best.min(t.elapsed());
            drop(m);
        }
        println!("whole from_spec (best of 5) {best:?}");
        return;
    }
    let t = Instant::now();
    let Ok(e) = expand(&spec) else {
        std::process::exit(1)
    };
    let t_expand = t.elapsed();
    let hs: Vec<_> = e.equations.iter().map(|e| &e.poly).collect();
    let terms: usize = hs.iter().map(|h| h.len()).sum();
    let t = Instant::now();
    let r = reduce(&hs, e.vars.joint_vars);
    let t_reduce = t.elapsed();
    // The generalized parameters compiled, as `from_spec` does (their derivatives come from
    // them by the product rule; the exact Jacobian polynomials only for generated code).
    let t = Instant::now();
    let c_eval: Vec<CompiledPoly> = r.c.iter().flatten().map(CompiledPoly::new).collect();
    let t_compile = t.elapsed();
    let ec: Vec<usize> = e.equations.iter().map(|q| q.constraint).collect();
    let groups: Vec<Vec<usize>> = spec
        .constraints
        .iter()
        .enumerate()
        .filter(|(_, c)| !matches!(c, Constraint::Measured))
        .map(|(ci, _)| (0..ec.len()).filter(|&q| ec[q] == ci).collect())
        .collect();
    let t = Instant::now();
    let ident = analyse(&e.vars, &r.c, &c_eval, &groups, &e.param_nominals);
    let t_ident = t.elapsed();
    let t = Instant::now();
    let Ok(m) = SymbolicModel::from_spec(&spec) else {
        std::process::exit(1)
    };
    let t_all = t.elapsed();
    assert_eq!(&ident, m.identifiability());
    println!(
        "{}: {terms} terms, naive {} K {} identifiable {}",
        spec.name,
        r.monomials.len(),
        m.basis_size(),
        m.identifiability().count
    );
    let held: Vec<&str> = (0..m.param_count())
        .filter(|&j| m.param_held(j))
        .map(|j| m.param_name(j))
        .collect();
    println!(
        "held {held:?}\nidentifiable {:?}\ngauge {:?}",
        m.identifiable_split().0,
        m.gauge()
    );
    if std::env::args().nth(2).as_deref() == Some("--dump") {
        // Everything the engine derives, for comparing two builds exactly.
        println!("basis {:?}", m.basis_names());
        println!("c {:?}", m.generalized_param_strings());
        println!("ident {:?}", m.identifiability());
        let Ok(jac) = m.jacobian_polys() else {
            std::process::exit(1)
        };
        let jac: Vec<String> = jac
            .iter()
            .flatten()
            .flatten()
            .map(|p| p.display(&m.expansion().vars, m.param_names()))
            .collect();
        println!("jac {jac:?}");
        println!("warnings {:?}", m.warnings());
    }
    println!(
        "expand {t_expand:?}  reduce {t_reduce:?}  compile {t_compile:?}  identify {t_ident:?}  \
         whole from_spec {t_all:?}"
    );
}
