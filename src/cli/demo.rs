//! `lincal demo`: the AdeptOne experiment of Sayeh & Newman (1993), sec. 5, on data embedded
//! in the binary.
//!
//! The paper's encoder readings are not published, so the two data sets here were simulated
//! once with `lincal simulate` in the paper's setup (joints 1-2, an unknown laser line, about
//! 32 µm of tracking noise, true a2/a1 = 1.13323 and θh2 = 0.0446 rad) and committed:
//!
//! ```text
//! lincal simulate src/cli/demo/adept_one.yaml --poses 200 --seed 1993 --truth src/cli/demo/truth.yaml \
//!     --noise-track 32.2e-6 > src/cli/demo/adept_one_1.csv
//! lincal simulate src/cli/demo/adept_one.yaml --poses 200 --seed 2024 --truth src/cli/demo/truth.yaml \
//!     --noise-track 35.7e-6 > src/cli/demo/adept_one_2.csv
//! ```

use std::fmt::Write as _;

use lincal::calibrate::estimate::Estimate;
use lincal::calibrate::{calibrate_spec, CalibrateOptions};
use lincal::data::Poses;
use lincal::error::{Error, Result};
use lincal::symbolic::SymbolicModel;
use lincal::CalibModel;

/// The spec of the experiment.
pub const SPEC: &str = include_str!("demo/adept_one.yaml");
/// The true parameters the data were simulated with.
pub const TRUTH: &str = include_str!("demo/truth.yaml");
/// The first data set (32.2 µm tracking noise).
pub const DATA_1: &str = include_str!("demo/adept_one_1.csv");
/// The second data set (35.7 µm tracking noise).
pub const DATA_2: &str = include_str!("demo/adept_one_2.csv");

/// The paper's table (sec. 5): nominal, computed(1), computed(2).
const PAPER_RATIO: [f64; 3] = [1.13333, 1.13323, 1.13338];
const PAPER_TH2: [f64; 3] = [0.0, 0.0446, 0.0445];
const PAPER_ERR_UM: [f64; 2] = [32.20, 35.68];

/// Our numbers for one data set.
struct Ours {
    ratio: f64,
    th2: f64,
    th2_std: Option<f64>,
    err_rms: f64,
    residual_rms: f64,
    poses: usize,
}

fn value(est: &Estimate, name: &str) -> Result<(f64, Option<f64>)> {
    est.params
        .iter()
        .find(|p| p.name == name)
        .map(|p| (p.value, p.std))
        .ok_or_else(|| Error::other(format!("the demo spec has no parameter `{name}`")))
}

fn fit(model: &SymbolicModel, file: &str, data: &str) -> Result<Ours> {
    let spec = model.spec();
    let poses = Poses::from_csv_str(data, Some(file), model, spec.constraint_list)?;
    let est = calibrate_spec(model, spec, &poses, CalibrateOptions::default())?;
    let (a1, _) = value(&est, "a1")?;
    let (a2, _) = value(&est, "a2")?;
    let (th2, th2_std) = value(&est, "th2")?;
    Ok(Ours {
        ratio: a2 / a1,
        th2,
        th2_std,
        err_rms: est.paper_err_rms.unwrap_or(f64::NAN),
        residual_rms: est.residual_rms,
        poses: est.poses,
    })
}

/// Runs the demo; the text it prints.
pub fn run() -> Result<String> {
    let spec = lincal::spec::from_yaml_str(SPEC, Some("demo/adept_one.yaml"))?;
    let model = SymbolicModel::from_spec(&spec)?;
    let ours = [
        fit(&model, "demo/adept_one_1.csv", DATA_1)?,
        fit(&model, "demo/adept_one_2.csv", DATA_2)?,
    ];
    let truth =
        lincal::simulate::truth_from_yaml_str(TRUTH, Some("demo/truth.yaml"), &model, &spec)?;
    let t = |name: &str| {
        (0..model.param_count())
            .find(|&j| model.param_name(j) == name)
            .map_or(f64::NAN, |j| truth[j])
    };
    let (true_ratio, true_th2) = (t("a2") / t("a1"), t("th2"));

    let mut s = String::new();
    let _ = writeln!(
        s,
        "lincal demo: the AdeptOne experiment of Sayeh & Newman (1993), sec. 5"
    );
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "Joints 1-2 of an AdeptOne as a planar 2-link arm; a four-quadrant optical detector holds\n\
         the tool tip on an unknown laser line (about 32 µm of tracking noise). Nominal\n\
         a1 = 0.375 m, a2 = 0.425 m (a2/a1 = 1.13333). One linear least-squares solve (the\n\
         paper's Eq. 4), no initial guess; the basis has K = {} functions and the line\n\
         identifies {} parameter combinations (a2/a1, θh2, β + θh1, a1·‖b‖).",
        model.basis_size(),
        model.identifiable_count()
    );
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "The paper's encoder readings are not published. The data here were simulated once with\n\
         the same setup (`lincal simulate`: {} and {} poses inside the joint limits, true\n\
         a2/a1 = {:.5}, θh2 = {:.4} rad, tracking noise 32.2 and 35.7 µm, fixed seeds) and are\n\
         embedded in the binary; the paper's own values are shown beside ours.",
        ours[0].poses, ours[1].poses, true_ratio, true_th2
    );
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:<22}{:>10}  {:>12}{:>12}  {:>12}{:>12}",
        "AdeptOne", "nominal", "paper (1)", "paper (2)", "lincal (1)", "lincal (2)"
    );
    let _ = writeln!(
        s,
        "{:<22}{:>10.5}  {:>12.5}{:>12.5}  {:>12.5}{:>12.5}",
        "a2/a1", PAPER_RATIO[0], PAPER_RATIO[1], PAPER_RATIO[2], ours[0].ratio, ours[1].ratio
    );
    let _ = writeln!(
        s,
        "{:<22}{:>10}  {:>12.4}{:>12.4}  {:>12.4}{:>12.4}",
        "θh2 [rad]", PAPER_TH2[0], PAPER_TH2[1], PAPER_TH2[2], ours[0].th2, ours[1].th2
    );
    let _ = writeln!(
        s,
        "{:<22}{:>10}  {:>12.2}{:>12.2}  {:>12.2}{:>12.2}",
        "err_rms [µm]",
        "-",
        PAPER_ERR_UM[0],
        PAPER_ERR_UM[1],
        ours[0].err_rms * 1e6,
        ours[1].err_rms * 1e6
    );
    let _ = writeln!(
        s,
        "{:<22}{:>10}  {:>12}{:>12}  {:>12.2}{:>12.2}",
        "residual_rms [µm]",
        "-",
        "-",
        "-",
        ours[0].residual_rms * 1e6,
        ours[1].residual_rms * 1e6
    );
    let _ = writeln!(s);
    let std = |o: &Ours| {
        o.th2_std
            .map_or_else(|| "-".to_string(), |v| format!("{:.1} µrad", v * 1e6))
    };
    let _ = writeln!(
        s,
        "err_rms is the paper's sec. 5 figure, sqrt(λmin(I)/N) of the calibrated tips' inertia\n\
         matrix; residual_rms is the rms distance of the calibrated tips from the calibrated line.\n\
         Standard deviation of θh2: {} (1), {} (2). Truth of the simulation:\n\
         a2/a1 = {:.5}, θh2 = {:.4} rad.",
        std(&ours[0]),
        std(&ours[1]),
        true_ratio,
        true_th2
    );
    let _ = writeln!(
        s,
        "Your own data: lincal calibrate SPEC DATA.csv (see `lincal calibrate --help`)."
    );
    Ok(s)
}
