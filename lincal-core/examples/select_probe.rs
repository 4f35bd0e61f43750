//! Times `lincal select`'s planning on a spec without the CLI's build:
//! `cargo run --release -p lincal-core --example select_probe -- SPEC N POOL [SEED]`.
//! Prints the whole plan's wall time, the chosen set's `log det` and the efficiency bound.
use lincal_core::select::plan::{plan, Candidates, PlanOptions};
use lincal_core::simulate::Noise;
use lincal_core::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        eprintln!("usage: select_probe SPEC N POOL [SEED]");
        std::process::exit(2);
    }
    let spec = match lincal_core::spec::from_yaml_file(std::path::Path::new(&args[1])) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2)
        }
    };
    let parse = |i: usize| args.get(i).and_then(|v| v.parse::<u64>().ok());
    let (Some(n), Some(pool)) = (parse(2), parse(3)) else {
        eprintln!("N and POOL are counts");
        std::process::exit(2)
    };
    let Ok(model) = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS) else {
        std::process::exit(1)
    };
    let opts = PlanOptions {
        count: n as usize,
        draws: 3,
        seed: parse(4).unwrap_or(1),
        tip: false,
        noise: Noise::default(),
        max_off: 0.05,
        prior: lincal_core::calibrate::prior::PriorChoice::default(),
    };
    let t = Instant::now();
    match plan(
        &model,
        &spec,
        Candidates::Generated(pool as usize),
        None,
        &opts,
    ) {
        Ok(p) => println!(
            "{:.3} s  log det {:.4}  bound {:?}",
            t.elapsed().as_secs_f64(),
            p.log_det.0,
            p.efficiency
        ),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1)
        }
    }
}
