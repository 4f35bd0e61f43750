//! Degenerate data: an error of class `Degenerate` with the reason, never a panic or a NaN.

use super::models::{Kind, PlanarArm};
use super::sim::{gauss, simulate, SimOptions};
use lincal_core::calibrate::{calibrate, CalibrateOptions};
use lincal_core::data::Poses;
use lincal_core::error::{Error, ErrorClass};
use lincal_core::model::geometry::{geometric_residual, ConstraintKind};
use lincal_core::CalibModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn truth3() -> Vec<f64> {
    vec![0.4, 0.05, 0.3, -0.031, 0.2, 0.052, -1.8, 1.0]
}

fn model3() -> PlanarArm {
    let mut nom = truth3();
    nom[2] = 0.32;
    nom[3] = 0.0;
    nom[5] = 0.0;
    PlanarArm::new(3, Kind::Line, nom)
}

fn degenerate(model: &PlanarArm, poses: &Poses) -> Error {
    let e = calibrate(
        model,
        &model.spec_params(),
        poses,
        CalibrateOptions::default(),
    )
    .expect_err("degenerate data must be an error");
    assert_eq!(e.class(), ErrorClass::Degenerate, "{e}");
    e
}

#[test]
fn fewer_poses_than_the_basis() {
    let model = model3();
    let poses = simulate(&model, &truth3(), SimOptions::new(6, 1));
    // 6 poses on a line give 6 equations for the 6 free parameters: too few, whatever the
    // path (the rule is the same for the linear method and the parameter-space fit).
    let e = degenerate(&model, &poses);
    assert!(e.to_string().contains("6 free parameters"), "{e}");
    // No poses at all.
    let e = degenerate(&model, &Poses::default());
    assert!(e.to_string().contains("no poses"), "{e}");
}

#[test]
fn all_poses_identical() {
    let model = model3();
    let one = simulate(&model, &truth3(), SimOptions::new(1, 2));
    let mut poses = Poses::default();
    for l in 0..30 {
        poses.q.push(&one.q[0]);
        poses.constraint.push(0);
        poses.line.push(l + 2);
    }
    let e = degenerate(&model, &poses);
    assert!(e.to_string().contains("same joint readings"), "{e}");
}

/// Poses with joint 3 frozen at 0.4: random q2, q1 by Newton on the line residual.
fn frozen_poses(model: &PlanarArm, p: &[f64], count: usize, track: f64) -> Poses {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut poses = Poses::default();
    let vals = [p[6], p[7]];
    let res = |q: &[f64]| {
        let mut tip = [0.0; 2];
        model.tip(q, p, &mut tip);
        let mut r = [0.0];
        geometric_residual(ConstraintKind::Line2, 2, &vals, &tip, &[], &mut r);
        r[0]
    };
    while poses.len() < count {
        let mut q = [rng.gen_range(-2.5..2.5), rng.gen_range(-2.5..2.5), 0.4];
        let target = track * gauss(&mut rng);
        for _ in 0..60 {
            let r = res(&q) - target;
            let h = 1e-7;
            let mut qp = q;
            qp[0] += h;
            let mut qm = q;
            qm[0] -= h;
            let d = (res(&qp) - res(&qm)) / (2.0 * h);
            q[0] -= (r / d).clamp(-0.5, 0.5);
        }
        if (res(&q) - target).abs() < 1e-13 && q[0].abs() < 2.8 {
            poses.q.push(&q);
            poses.constraint.push(0);
            poses.line.push(poses.len() + 1);
        }
    }
    poses
}

#[test]
fn frozen_joint_names_what_is_lost() {
    let model = model3();
    for track in [0.0, 30e-6] {
        let poses = frozen_poses(&model, &truth3(), 80, track);
        let e = degenerate(&model, &poses);
        let msg = e.to_string();
        assert!(msg.contains("q3"), "{msg}");
        assert!(msg.contains("th3") || msg.contains("a3"), "{msg}");
        assert!(msg.contains("lost"), "{msg}");
    }
}

#[test]
fn measured_too_few_poses() {
    let t = vec![0.4, 0.05, 0.3, -0.031, 0.1, -0.05];
    let model = PlanarArm::new(2, Kind::Measured, t.clone());
    let poses = simulate(&model, &t, SimOptions::new(3, 4));
    degenerate_any(&model, &poses);
}

fn degenerate_any(model: &PlanarArm, poses: &Poses) {
    let e = calibrate(
        model,
        &model.spec_params(),
        poses,
        CalibrateOptions {
            refine: true,
            ..Default::default()
        },
    )
    .expect_err("must fail");
    assert_eq!(e.class(), ErrorClass::Degenerate, "{e}");
}

#[test]
fn never_nan_on_a_short_wiggle() {
    // Joint 2 moves by 1e-9 rad only: either an error or finite numbers.
    let model = model3();
    let mut poses = frozen_poses(&model, &truth3(), 40, 0.0);
    for (l, q) in poses.q.iter_mut().enumerate() {
        q[2] += 1e-9 * (l as f64).sin();
    }
    match calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions {
            refine: true,
            ..Default::default()
        },
    ) {
        Ok(est) => {
            assert!(est.params.iter().all(|p| p.value.is_finite()));
            assert!(est.residual_rms.is_finite());
        }
        Err(e) => assert_ne!(e.class(), ErrorClass::Input, "{e}"),
    }
}

#[test]
fn nan_reading_in_programmatic_poses() {
    let model = model3();
    let mut poses = simulate(&model, &truth3(), SimOptions::new(20, 8));
    poses.q[5][1] = f64::NAN;
    let e = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap_err();
    assert_eq!(e.class(), ErrorClass::Input);
    assert!(
        e.to_string().contains("pose 5") && e.to_string().contains("q2"),
        "{e}"
    );
}
