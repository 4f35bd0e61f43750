//! Held-out validation and cross-validation on simulated data with known answers.

use lincal_core::calibrate::validation::{cross_validate, evaluate};
use lincal_core::calibrate::CalibrateOptions;
use lincal_core::simulate::{simulate, Noise};
use lincal_core::spec::Spec;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;

/// A planar 3R arm with a ball in two unknown sockets 50 mm apart.
const SOCKETS: &str = "name: sockets_planar3
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-3.0, 3.0]}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0.0}
  a2: {nominal: 0.3}
  th2: {nominal: 0.0}
  a3: {nominal: 0.2}
  th3: {nominal: 0.0}
  p0x: {nominal: 0.45}
  p0y: {nominal: 0.2}
  p1x: {nominal: 0.45}
  p1y: {nominal: 0.25}
constraints:
  - point: {p: [p0x, p0y]}
  - point: {p: [p1x, p1y]}
relations:
  - {distance: [0, 1], value: 0.05}
";

fn model(yaml: &str) -> (Spec, SymbolicModel) {
    let spec = lincal_core::spec::from_yaml_str(yaml, None).expect("spec");
    let model = SymbolicModel::from_spec(&spec).expect("model");
    (spec, model)
}

fn noise(track: f64) -> Noise {
    Noise {
        track,
        ..Noise::default()
    }
}

/// The true arm (a1 10 mm longer than nominal, the rest nominal) with the sockets at `p`.
fn sockets_truth(p: [f64; 4]) -> Vec<f64> {
    vec![0.41, 0.0, 0.3, 0.0, 0.2, 0.0, p[0], p[1], p[2], p[3]]
}

#[test]
fn true_parameters_on_a_moved_fixture_give_zero_and_the_true_distance() {
    let (spec, model) = model(SOCKETS);
    // Held out: the part moved (sockets 50 mm apart, rotated and shifted).
    let moved = sockets_truth([0.30, 0.20, 0.33, 0.24]);
    let held = simulate(&model, &spec, 60, 11, Some(&moved), noise(0.0)).expect("sim");
    // The true arm, the sockets where the *training* placement had them.
    let truth = sockets_truth([0.45, 0.2, 0.45, 0.25]);
    let e = evaluate(&model, &held.poses, &truth).expect("evaluate");
    assert!(e.residual_rms < 1e-9, "{}", e.residual_rms);
    for c in &e.constraints {
        assert!(c.residual_rms < 1e-9 && c.max_residual < 1e-9, "{c:?}");
        assert_eq!(c.refitted.len(), 2);
        assert!(c.spread.unwrap() < 1e-9);
    }
    let mean0 = e.constraints[0].mean.as_ref().unwrap();
    assert!((mean0[0] - 0.30).abs() < 1e-9 && (mean0[1] - 0.20).abs() < 1e-9);
    let pair = &e.point_pairs[0];
    assert_eq!(pair.between, [0, 1]);
    assert!((pair.distance - 0.05).abs() < 1e-9, "{pair:?}");
    assert!(pair.error.unwrap().abs() < 1e-9);
    assert_eq!(pair.value, Some(0.05));
}

#[test]
fn nominal_parameters_give_the_analytic_spread() {
    let (spec, model) = model(SOCKETS);
    let moved = sockets_truth([0.30, 0.20, 0.33, 0.24]);
    let held = simulate(&model, &spec, 60, 12, Some(&moved), noise(0.0)).expect("sim");
    let e = evaluate(&model, &held.poses, &moved).expect("evaluate");
    // The nominal tip is the true tip minus δ·(cos q1, sin q1) (δ = 10 mm of a1, th1 = 0):
    // per socket the spread is δ·sqrt(1 − ‖mean of (cos q1, sin q1)‖²).
    let delta = 0.01;
    let mut pooled = (0.0, 0usize);
    for c in &e.constraints {
        let (mut sc, mut ss, mut n) = (0.0, 0.0, 0.0);
        for l in 0..held.poses.len() {
            if held.poses.constraint.at(l) == c.constraint {
                let q1 = held.poses.q[l][0];
                sc += q1.cos();
                ss += q1.sin();
                n += 1.0;
            }
        }
        let expected = delta * (1.0 - (sc / n).powi(2) - (ss / n).powi(2)).sqrt();
        let got = c.spread_nominal.unwrap();
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
        assert!((c.residual_rms_nominal - expected).abs() < 1e-12);
        assert!(got > 1e-3, "the nominal spread is the 10 mm error seen");
        assert!(c.spread.unwrap() < 1e-9);
        pooled.0 += n * expected * expected;
        pooled.1 += n as usize;
    }
    let pooled = (pooled.0 / pooled.1 as f64).sqrt();
    assert!((e.spread_pooled_nominal.unwrap() - pooled).abs() < 1e-12);
}

/// Held-out kinds with their unknown values refitted: a plane, and a sphere whose radius is
/// known (only its centre refitted), each moved.
#[test]
fn planes_and_spheres_are_refitted_known_values_kept() {
    let plane = lincal_core::spec::from_yaml_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/specs/plane_spatial.yaml"
        ))
        .expect("plane spec"),
        None,
    )
    .expect("spec");
    let sphere_yaml = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/specs/sphere_mdh.yaml"
    ))
    .expect("sphere spec")
    .replace("r: {nominal: 0.35}", "r: {nominal: 0.35, known: true}");
    let sphere = lincal_core::spec::from_yaml_str(&sphere_yaml, None).expect("spec");
    for spec in [plane, sphere] {
        let model = SymbolicModel::from_spec(&spec).expect("model");
        let truth: Vec<f64> = (0..model.param_count())
            .map(|j| model.param_nominal(j))
            .collect();
        // Move the fixture: every constraint value shifted by 2-5 %.
        let mut moved = truth.clone();
        for v in 0..model.constraint_kind(0).value_count(model.dim()) {
            if let Some(s) = model.constraint_value_param(0, v) {
                moved[s] *= 1.02 + 0.01 * v as f64;
            }
        }
        let held = simulate(&model, &spec, 50, 5, Some(&moved), noise(0.0)).expect("sim");
        let e = evaluate(&model, &held.poses, &truth).expect("evaluate");
        assert!(e.residual_rms < 1e-9, "{}: {}", spec.name, e.residual_rms);
        assert!(!e.constraints[0].refitted.is_empty());
        assert!(!e.constraints[0].refitted.iter().any(|n| n == "r"));
    }
}

#[test]
fn k_fold_noise_free_is_zero_and_noisy_is_the_noise() {
    let (spec, model) = model(SOCKETS);
    let truth = sockets_truth([0.45, 0.2, 0.45, 0.25]);
    let opts = CalibrateOptions {
        refine: true,
        ..CalibrateOptions::default()
    };
    let exact = simulate(&model, &spec, 60, 21, Some(&truth), noise(0.0)).expect("sim");
    let cv = cross_validate(&model, &spec, &exact.poses, opts, 5, 0.0).expect("cv");
    assert_eq!(cv.per_fold.len(), 5);
    assert_eq!(cv.per_fold.iter().map(|f| f.test_poses).sum::<usize>(), 60);
    assert!(
        cv.residual_rms_held_out < 1e-9,
        "{}",
        cv.residual_rms_held_out
    );

    // Tracking noise σ per direction: a point's residual has 2 components, rms σ√2.
    let sigma = 1e-4;
    let noisy = simulate(&model, &spec, 200, 22, Some(&truth), noise(sigma)).expect("sim");
    let est =
        lincal_core::calibrate::calibrate_spec(&model, &spec, &noisy.poses, opts).expect("fit");
    let cv = cross_validate(&model, &spec, &noisy.poses, opts, 5, est.residual_rms).expect("cv");
    let level = sigma * 2f64.sqrt();
    assert!(
        cv.residual_rms_held_out >= 0.98 * cv.residual_rms_in_sample,
        "{cv:?}"
    );
    assert!(
        cv.residual_rms_held_out >= cv.residual_rms_train_mean,
        "{cv:?}"
    );
    assert!(
        cv.residual_rms_held_out > 0.7 * level && cv.residual_rms_held_out < 1.5 * level,
        "{} vs noise {level}",
        cv.residual_rms_held_out
    );
}

#[test]
fn folds_are_checked() {
    let (spec, model) = model(SOCKETS);
    let truth = sockets_truth([0.45, 0.2, 0.45, 0.25]);
    let sim = simulate(&model, &spec, 20, 1, Some(&truth), noise(0.0)).expect("sim");
    let opts = CalibrateOptions::default();
    for k in [0, 1, 21] {
        let err = cross_validate(&model, &spec, &sim.poses, opts, k, 0.0).unwrap_err();
        assert!(err.to_string().contains("--folds"), "{err}");
    }
}
