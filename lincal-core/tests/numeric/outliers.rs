//! Bad poses among good ones: the worst poses ranked by standardised residual, so that
//! constraints with different numbers of residual components compare fairly.

use super::sim::{place, simulate, SimOptions};
use lincal_core::calibrate::{calibrate_spec, pose_residuals, CalibrateOptions};
use lincal_core::CalibModel;

/// A spatial 4R arm whose tip was pinned at an unknown point (three residual components) in
/// some poses and held on an unknown plane (one component) in the others.
const MIXED: &str = "name: point_and_plane
dim: 3
joints:
  - {type: revolute, a: 0, alpha: pi/2, d: d1, home: th1}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, alpha: pi/2, home: th3, limits: [-3.0, 3.0]}
  - {type: revolute, a: a4, home: th4, limits: [-3.0, 3.0]}
params:
  d1: {nominal: 0.3}
  th1: {nominal: 0.0}
  a2: {nominal: 0.4}
  th2: {nominal: 0.0}
  a3: {nominal: 0.3}
  th3: {nominal: 0.0}
  a4: {nominal: 0.2}
  th4: {nominal: 0.0}
  p1: {nominal: 0.3}
  p2: {nominal: 0.2}
  p3: {nominal: 0.5}
  b1: {nominal: -1.5}
  b2: {nominal: -0.8}
  b3: {nominal: 0.6}
constraints:
  - point: {p: [p1, p2, p3]}
  - plane: {b: [b1, b2, b3]}
";

/// The true parameters (model order).
const TRUTH: [f64; 14] = [
    0.3, 0.0, 0.4, -0.015, 0.292, 0.011, 0.194, 0.005, 0.292, 0.2, 0.492, -1.517, -0.82, 0.61,
];

/// 150 poses at the point and 30 on the plane, σ = 10 µm of noise per residual component;
/// one plane pose moved 3σ off the plane. Its residual is smaller than the largest of the
/// point poses' (three components each), so a ranking by residual puts a clean point pose
/// first; by standardised residual the bad pose comes first.
#[test]
fn a_bad_pose_on_a_one_component_constraint_comes_first_by_z() {
    let spec = lincal_core::spec::from_yaml_str(MIXED, None).unwrap();
    let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
    let sigma = 1e-5;
    let mut opts = SimOptions::new(300, 11);
    opts.track = sigma;
    let all = simulate(&model, &TRUTH, opts);
    // Every point pose, the first 30 plane poses.
    let mut planes = 0;
    let keep: Vec<usize> = (0..all.len())
        .filter(|&l| {
            let plane = all.constraint.at(l) == 1;
            planes += usize::from(plane);
            !plane || planes <= 30
        })
        .collect();
    let mut poses = all.select(&keep);
    assert_eq!(poses.len(), 180);
    let bad = (0..poses.len())
        .rfind(|&l| poses.constraint.at(l) == 1)
        .unwrap();
    let q = place(&model, 1, &TRUTH, &poses.q[bad], &[3.0 * sigma]).unwrap();
    poses.q[bad].copy_from_slice(&q);

    let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
    // The robust scale is the noise level.
    assert!(
        (0.7 * sigma..1.4 * sigma).contains(&est.robust_scale),
        "{}",
        est.robust_scale
    );
    let worst = &est.worst_poses;
    assert_eq!(worst.len(), 10);
    assert_eq!(worst[0].pose, bad, "{worst:#?}");
    // z descends, and is the residual over σ̂ times the χ median of the pose's components.
    let z: Vec<f64> = worst.iter().map(|w| w.standardized.unwrap()).collect();
    assert!(z.windows(2).all(|w| w[0] >= w[1]), "{z:?}");
    for w in worst {
        let chi = if poses.constraint.at(w.pose) == 0 {
            1.538_172_254_455_58
        } else {
            0.674_489_750_196_08
        };
        let expect = w.residual / (est.robust_scale * chi);
        assert!((w.standardized.unwrap() - expect).abs() <= 1e-12 * expect);
    }
    assert!(z[0] > 1.1 * z[1], "{z:?}");
    // The raw residuals would rank a clean point pose above the bad one.
    let p: Vec<f64> = est
        .params
        .iter()
        .filter(|x| !x.known)
        .map(|x| x.value)
        .collect();
    let d = pose_residuals(&model, &poses, &p).unwrap();
    let (top, _) = d
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .unwrap();
    assert_ne!(top, bad);
    assert_eq!(poses.constraint.at(top), 0);
    assert!(
        d[top] > worst[0].residual,
        "{} vs {}",
        d[top],
        worst[0].residual
    );
    assert_eq!(model.constraint_count(), 2);
}

/// Fewer than 10 poses: no robust scale, the worst poses by residual and `standardized`
/// undefined.
#[test]
fn few_poses_rank_by_residual_without_z() {
    let spec = lincal_core::spec::from_yaml_str(MIXED, None).unwrap();
    let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
    let mut opts = SimOptions::new(9, 3);
    opts.track = 1e-5;
    let poses = simulate(&model, &TRUTH, opts);
    let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
    assert!(est.robust_scale.is_nan());
    assert!(!est.worst_poses.is_empty());
    assert!(est.worst_poses.iter().all(|w| w.standardized.is_none()));
    assert!(est
        .worst_poses
        .windows(2)
        .all(|w| w[0].residual >= w[1].residual));
}

/// One spec of `tests/specs/`, loaded, with its run-time model.
fn load(
    name: &str,
) -> (
    lincal_core::spec::Spec,
    lincal_core::symbolic::SymbolicModel,
) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/specs")
        .join(name);
    let spec = lincal_core::spec::from_yaml_file(&path).unwrap();
    let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
    (spec, model)
}

/// The largest distance of an estimate's parameters from the truth (held parameters are at
/// their nominals, which these truths keep).
fn max_error(est: &lincal_core::calibrate::estimate::Estimate, truth: &[f64]) -> f64 {
    est.params
        .iter()
        .filter(|p| !p.known)
        .zip(truth)
        .map(|(p, t)| (p.value - t).abs())
        .fold(0.0, f64::max)
}

/// `--robust` without refinement on the linear solve's other paths: a measured tip (the
/// algebraic residual is the regression's, the measured coordinate subtracted) and a list of
/// two lines (a robust scale per constraint). One bad row each: the plain linear estimate is
/// pulled far off the truth, the reweighted one stays at the noise level.
#[test]
fn robust_linear_solve_on_measured_tips_and_on_a_list() {
    let opts = |robust| CalibrateOptions {
        robust,
        ..CalibrateOptions::default()
    };
    let huber = Some(lincal_core::calibrate::Robust::Huber);

    // Measured tips, one of them 1 cm off in x.
    let (spec, model) = load("measured_spatial.yaml");
    let truth = [0.052, 0.31, 0.02, 0.41, -0.03, 0.345, 0.04, 0.49, -0.21];
    let mut o = SimOptions::new(200, 5);
    o.measure = 1e-5;
    let mut poses = simulate(&model, &truth, o);
    poses.measured.as_mut().unwrap()[60][0] += 0.01;
    let plain = calibrate_spec(&model, &spec, &poses, opts(None)).unwrap();
    let robust = calibrate_spec(&model, &spec, &poses, opts(huber)).unwrap();
    assert_eq!(robust.method, "linear");
    let info = robust.robust.as_ref().unwrap();
    assert!(
        info.linear_rounds >= 1 && info.linear_rounds < 20,
        "{info:?}"
    );
    assert_eq!(info.rounds, 0);
    assert!((1..=3).contains(&info.linear_downweighted), "{info:?}");
    let (ep, er) = (max_error(&plain, &truth), max_error(&robust, &truth));
    eprintln!("measured: plain off by {ep:.3e}, robust by {er:.3e}, {info:?}");
    assert!(
        er < 1e-4 && ep > 20.0 * er,
        "measured: plain {ep:e}, robust {er:e}"
    );

    // Two lines; one pose on the second with joint 2 off by 0.3 rad. The truth keeps the
    // gauge (a1, th1) at its nominals, so every parameter compares with the truth.
    let (spec, model) = load("lines_list.yaml");
    let truth = [0.375, 0.0, 0.43, 0.03, -1.82, -0.55, 0.52, -2.05];
    let mut o = SimOptions::new(200, 9);
    o.track = 1e-5;
    let mut poses = simulate(&model, &truth, o);
    assert_eq!(poses.constraint.at(101), 1);
    poses.q[101][1] += 0.3;
    let plain = calibrate_spec(&model, &spec, &poses, opts(None)).unwrap();
    let robust = calibrate_spec(&model, &spec, &poses, opts(huber)).unwrap();
    let info = robust.robust.as_ref().unwrap();
    assert!(
        info.linear_rounds >= 1 && info.linear_rounds < 20,
        "{info:?}"
    );
    let (ep, er) = (max_error(&plain, &truth), max_error(&robust, &truth));
    eprintln!("list: plain off by {ep:.3e}, robust by {er:.3e}, {info:?}");
    assert!(
        er < 1e-4 && ep > 20.0 * er,
        "list: plain {ep:e}, robust {er:e}"
    );
}
