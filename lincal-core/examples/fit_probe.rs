//! Times a calibration without the spec's analysis and the data's reading:
//! `cargo run --release -p lincal-core --example fit_probe -- SPEC DATA.csv [REPS]` (the
//! analysis and the reading once, then `calibrate_spec` `REPS` times, as `--refine --prior
//! off`, the fit with its checks and report values; best time printed).
use lincal_core::calibrate::{calibrate_spec, prior::PriorChoice, CalibrateOptions};
use lincal_core::data::Poses;
use lincal_core::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: fit_probe SPEC DATA.csv [REPS]");
        std::process::exit(2);
    }
    let spec = lincal_core::spec::from_yaml_file(std::path::Path::new(&args[1]))
        .unwrap_or_else(|e| panic!("{e}"));
    let model =
        SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS).unwrap_or_else(|e| panic!("{e}"));
    let list = spec.constraints.len() > 1;
    let clock = Instant::now();
    let poses = Poses::from_csv_path(std::path::Path::new(&args[2]), &model, list)
        .unwrap_or_else(|e| panic!("{e}"));
    println!("reading {:?}", clock.elapsed());
    let reps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(5);
    let mut best = std::time::Duration::MAX;
    for _ in 0..reps {
        let opts = CalibrateOptions {
            refine: true,
            prior: PriorChoice::Off,
            ..CalibrateOptions::default()
        };
        let t = Instant::now();
        let est = calibrate_spec(&model, &spec, &poses, opts).unwrap_or_else(|e| panic!("{e}"));
        best = best.min(t.elapsed());
        println!("residual_rms {:e}", est.residual_rms);
    }
    println!("fit (best of {reps}) {best:?}");
}
