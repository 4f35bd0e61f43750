//! Times the engine's stages on a spec: `cargo run --release -p lincal-core --example basis_probe -- SPEC`.
use lincal_core::model::CalibModel;
use lincal_core::symbolic::{expand::expand, reduce::reduce, SymbolicModel};
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
    let t = Instant::now();
    let Ok(m) = SymbolicModel::from_spec(&spec) else {
        std::process::exit(1)
    };
    let t_all = t.elapsed();
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
    println!("expand {t_expand:?}  reduce {t_reduce:?}  whole from_spec {t_all:?}");
}
