//! Times the engine's stages on a spec: `cargo run --release -p lincal-core --example basis_probe -- SPEC
//! [--dump | --whole | --fitting | --bound T | --reported]` (`--dump` prints everything derived,
//! `--whole` times `from_spec` alone, `--fitting` times `for_fitting`: the identifiability
//! analysis a fit waits for, without the expansion; `--bound T` times the sampled proof of
//! `K > T`; `--reported` times the `K` a calibration reports on a model built for fitting: the
//! grid certificate, else the expansion within the report's bound).
//!
//! The stage times come from `SymbolicModel::from_spec_profiled`.
use lincal_core::model::CalibModel;
use lincal_core::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
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
    if std::env::args().nth(2).as_deref() == Some("--fitting") {
        // Only `for_fitting` (the analysis a fit waits for), best of five runs.
        let mut best = std::time::Duration::MAX;
        for _ in 0..5 {
            let t = Instant::now();
            let Ok(m) = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS) else {
                std::process::exit(1)
            };
            best = best.min(t.elapsed());
            drop(m);
        }
        println!("for_fitting (best of 5) {best:?}");
        return;
    }
    if std::env::args().nth(2).as_deref() == Some("--bound") {
        // Only the sampled proof of `K > t` (`basis_exceeds` without a basis), best of five.
        let t: usize = std::env::args()
            .nth(3)
            .and_then(|a| a.parse().ok())
            .unwrap_or(100);
        let Ok(m) = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS) else {
            std::process::exit(1)
        };
        let mut best = std::time::Duration::MAX;
        let mut answer = None;
        for _ in 0..5 {
            let clock = Instant::now();
            answer = m.basis_exceeds(t);
            best = best.min(clock.elapsed());
        }
        println!("basis_exceeds({t}) = {answer:?} (best of 5) {best:?}");
        return;
    }
    if std::env::args().nth(2).as_deref() == Some("--reported") {
        // Only `basis_size_for_report` (each run on a fresh model), best of five.
        let mut best = std::time::Duration::MAX;
        let mut k = None;
        for _ in 0..5 {
            let Ok(m) = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS) else {
                std::process::exit(1)
            };
            let clock = Instant::now();
            k = m.basis_size_for_report();
            best = best.min(clock.elapsed());
        }
        println!("basis_size_for_report = {k:?} (best of 5) {best:?}");
        return;
    }
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
    let Ok((m, profile)) = SymbolicModel::from_spec_profiled(&spec, DEFAULT_MAX_TERMS) else {
        std::process::exit(1)
    };
    let terms = profile.terms;
    println!(
        "{}: {terms} terms, naive {} K {} identifiable {}",
        spec.name,
        profile.naive_size,
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
        let Ok(program) = lincal_core::program::ModelProgram::from_model(&m) else {
            std::process::exit(1)
        };
        if let Some(j) = &program.jacobian {
            println!("jac {j}");
        }
        println!("warnings {:?}", m.warnings());
    }
    println!(
        "expand {:?}  reduce {:?}  compile {:?}  identify {:?}  whole from_spec {:?}",
        profile.expand, profile.reduce, profile.compile, profile.identify, profile.whole
    );
}
