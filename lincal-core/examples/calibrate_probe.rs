//! Runs `calibrate --refine` on a spec and a data file without the CLI's build (the prior's
//! choice studied side by side): `cargo run --release -p lincal-core --example
//! calibrate_probe -- SPEC DATA.csv [off|auto|TOLERANCE]`. Prints the fit's JSON, as
//! `lincal calibrate --format json` does, and its wall time on stderr.
use lincal_core::calibrate::prior::{PriorChoice, PriorScale, PriorShape};
use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
use lincal_core::CalibModel;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: calibrate_probe SPEC DATA.csv [off|auto|TOLERANCE]");
        std::process::exit(2);
    }
    let fail = |e: &dyn std::fmt::Display, code: i32| -> ! {
        eprintln!("{e}");
        std::process::exit(code)
    };
    let spec = lincal_core::spec::from_yaml_file(std::path::Path::new(&args[1]))
        .unwrap_or_else(|e| fail(&e, 2));
    let t = Instant::now();
    let model =
        SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS).unwrap_or_else(|e| fail(&e, 1));
    let poses = lincal_core::data::Poses::from_csv_path(
        std::path::Path::new(&args[2]),
        &model,
        model.constraint_count() > 1,
    )
    .unwrap_or_else(|e| fail(&e, 2));
    let prior = match args.get(3).map(String::as_str) {
        None | Some("auto") => PriorChoice::default(),
        Some("off") => PriorChoice::Off,
        Some(t) => {
            let t: f64 = t.parse().unwrap_or_else(|e| fail(&e, 2));
            PriorChoice::On {
                scale: PriorScale::Tolerances {
                    length: t,
                    angle: t,
                },
                shape: PriorShape::Frames,
            }
        }
    };
    let opts = CalibrateOptions {
        refine: true,
        prior,
        ..CalibrateOptions::default()
    };
    let est = calibrate_spec(&model, &spec, &poses, opts).unwrap_or_else(|e| fail(&e, 1));
    eprintln!("{:.3} s", t.elapsed().as_secs_f64());
    println!("{}", lincal_core::report::calibrate_json(&model, &est));
}
