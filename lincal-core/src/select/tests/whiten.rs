//! The whitening of the candidates' rows: `J/σ` without encoder noise, and with it rows `W`
//! whose information `WᵀW` is `Jᵀ(σ²I + σ_enc²AAᵀ)⁻¹J`, `A = ∂x/∂q` written out by hand for a
//! planar 3R arm pinned at a point.

use nalgebra::DMatrix;

use super::super::plan::{Sigmas, DEFAULT_SIGMA};
use super::super::whiten::{whitened, with_nominal_tips};
use crate::data::Poses;
use crate::fit::geometric::pose_jacobians;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::simulate::Noise;
use crate::symbolic::SymbolicModel;

const ARM: &str = "name: point_planar3
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
  - {type: revolute, a: a3, home: th3}
params: {a1: {nominal: 0.4}, th1: {nominal: 0.0}, a2: {nominal: 0.3}, th2: {nominal: 0.05},
         a3: {nominal: 0.2}, th3: {nominal: -0.02}, px: {nominal: 0.45}, py: {nominal: 0.2}}
constraint:
  point: {p: [px, py]}
";

fn setup() -> (SymbolicModel, Poses, Vec<f64>) {
    let spec = crate::spec::from_yaml_str(ARM, None).expect("spec");
    let model = SymbolicModel::from_spec(&spec).expect("model");
    let mut poses = Poses::default();
    for k in 0..7 {
        let t = f64::from(k);
        poses
            .q
            .push(&[0.3 * t - 1.0, 1.1 - 0.2 * t, 0.5 + 0.15 * t]);
        poses.constraint.push(0);
    }
    let p = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    (model, poses, p)
}

/// `∂x/∂q` of the planar 3R arm (`θ_i = q_i − home_i`, `φ_i = θ_1 + … + θ_i`):
/// `∂x/∂q_k = −Σ_{i≥k} a_i sin φ_i`, `∂y/∂q_k = Σ_{i≥k} a_i cos φ_i`.
fn joint_jacobian(q: &[f64], a: [f64; 3], home: [f64; 3]) -> DMatrix<f64> {
    let mut phi = [0.0; 3];
    let mut acc = 0.0;
    for i in 0..3 {
        acc += q[i] - home[i];
        phi[i] = acc;
    }
    DMatrix::from_fn(2, 3, |r, k| {
        (k..3)
            .map(|i| {
                if r == 0 {
                    -a[i] * phi[i].sin()
                } else {
                    a[i] * phi[i].cos()
                }
            })
            .sum()
    })
}

#[test]
fn without_encoder_noise_rows_are_divided_by_sigma() {
    let (model, poses, p) = setup();
    let jac = pose_jacobians(&model, &poses, &p).expect("jacobians");
    let n = jac.free.len();
    let sig = Sigmas::of(Noise {
        track: 2e-5,
        ..Noise::default()
    });
    let w = whitened(&model, &poses, &p, &jac, sig);
    let raw: Vec<f64> = jac
        .rows
        .chunks_exact(n + 1)
        .flat_map(|r| r[..n].to_vec())
        .collect();
    assert_eq!(w.len(), raw.len());
    for (a, b) in w.iter().zip(&raw) {
        assert!((a - b / 2e-5).abs() <= 1e-12 * (b / 2e-5).abs().max(1.0));
    }
    // No noise given: the default σ.
    assert_eq!(Sigmas::of(Noise::default()).constraint, DEFAULT_SIGMA);
}

#[test]
fn encoder_noise_whitens_by_the_residual_covariance() {
    let (model, poses, p) = setup();
    let jac = pose_jacobians(&model, &poses, &p).expect("jacobians");
    let n = jac.free.len();
    let (sigma, enc) = (1e-5, 2e-4);
    let sig = Sigmas::of(Noise {
        track: sigma,
        encoder: enc,
        ..Noise::default()
    });
    let w = whitened(&model, &poses, &p, &jac, sig);
    assert_eq!(w.len(), poses.len() * 2 * n);
    let name = |s: &str| (0..model.param_count()).find(|&j| model.param_name(j) == s);
    let value = |s: &str| name(s).map_or(0.0, |j| p[j]);
    let a = [value("a1"), value("a2"), value("a3")];
    let home = [value("th1"), value("th2"), value("th3")];
    for l in 0..poses.len() {
        let j_l = DMatrix::from_fn(2, n, |r, k| jac.pose(l)[r * (n + 1) + k]);
        let w_l = DMatrix::from_row_slice(2, n, &w[l * 2 * n..(l + 1) * 2 * n]);
        let aq = joint_jacobian(&poses.q[l], a, home);
        let cov = DMatrix::identity(2, 2) * (sigma * sigma) + &aq * aq.transpose() * (enc * enc);
        let expect = j_l.transpose() * cov.try_inverse().expect("inverse") * &j_l;
        let got = w_l.transpose() * &w_l;
        let scale = expect.abs().max();
        assert!(
            (&got - &expect).abs().max() <= 1e-7 * scale,
            "pose {l}: {got} vs {expect}"
        );
        // The encoder noise only lowers the information.
        let plain = j_l.transpose() * &j_l / (sigma * sigma);
        assert!(
            (plain - got).symmetric_eigenvalues().min() > -1e-6 * scale,
            "pose {l}"
        );
    }
}

#[test]
fn measured_tips_are_set_to_the_model_tip_and_orientation_noise_weighs_its_rows() {
    let s = Sigmas::of(Noise {
        measure: 1e-4,
        orientation: 1e-3,
        ..Noise::default()
    });
    assert_eq!(s.constraint, 1e-4, "track stands in for measure");
    let w = 0.5;
    assert!((s.base(ConstraintKind::MeasuredPose, 1, w) - 1e-8).abs() < 1e-20);
    assert!((s.base(ConstraintKind::MeasuredPose, 4, w) - 0.25e-6).abs() < 1e-18);
    let no_orientation = Sigmas {
        orientation: 0.0,
        ..s
    };
    assert!((no_orientation.base(ConstraintKind::MeasuredPose, 4, w) - 1e-8).abs() < 1e-20);
    // A pose without measured rows stays as it is.
    let (model, poses, p) = setup();
    assert_eq!(with_nominal_tips(&model, &poses, &p), poses);
}
