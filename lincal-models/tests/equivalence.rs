//! Every derived model equals the run-time engine built from the same YAML file: constants,
//! `basis(q)·generalized_params(p)` against the engine's `h(q; p)` and against the constraint
//! function of the forward-kinematics tip, the tip itself, and the Jacobian against central
//! differences, at random `(q, p)`; for a measured pose also the tool frame (`tool_pose`)
//! and the orientation weight.

use std::path::Path;

use lincal_core::model::geometry::{constraint_function, ConstraintKind};
use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use lincal_models::{
    AbbIrb120BallBar, AdeptOne, AdeptOneScara, Arm7AllUnknownPoint, Elbow3Line, FrankaPandaSockets,
    KukaIiwa14Point, Planar3Line, Planar3Point, Puma560MdhPlane, Puma560Plane, Puma560PoseFrames,
    Puma560PoseTracker, Puma560Sphere, ScaraPlane, StanfordArmTracker, Ur10Tracker, Ur5Tracker,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn runtime(file: &str) -> SymbolicModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("specs")
        .join(file);
    let spec = lincal_core::spec::from_yaml_file(&path).unwrap();
    SymbolicModel::from_spec(&spec).unwrap()
}

/// `|a − b| ≤ 1e-12 · scale` (scale at least 1e-300 so that exact zeros compare).
fn assert_close(a: f64, b: f64, scale: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-12 * scale.max(1e-300),
        "{what}: {a} vs {b} (scale {scale})"
    );
}

fn random_q(m: &dyn CalibModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..m.joint_count())
        .map(|i| match m.joint_limits(i) {
            Some([lo, hi]) => rng.gen_range(lo..hi),
            None => rng.gen_range(-3.0..3.0),
        })
        .collect()
}

fn random_p(m: &dyn CalibModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| m.param_nominal(j) + rng.gen_range(-0.2..0.2))
        .collect()
}

fn check(derived: &dyn CalibModel, file: &str) {
    let rt = runtime(file);
    // Constants.
    assert_eq!(derived.name(), rt.name());
    assert_eq!(derived.dim(), rt.dim());
    assert_eq!(derived.joint_count(), rt.joint_count());
    assert_eq!(derived.param_count(), rt.param_count());
    assert_eq!(derived.basis_size(), rt.basis_size());
    assert_eq!(derived.identifiable_count(), rt.identifiable_count());
    assert_eq!(derived.constant_index(), CalibModel::constant_index(&rt));
    assert_eq!(derived.equation_count(), rt.equation_count());
    assert_eq!(derived.constraint_count(), rt.constraint_count());
    for i in 0..rt.joint_count() {
        assert_eq!(derived.joint_is_prismatic(i), rt.joint_is_prismatic(i));
        assert_eq!(derived.joint_limits(i), rt.joint_limits(i));
    }
    for j in 0..rt.param_count() {
        assert_eq!(derived.param_name(j), rt.param_name(j));
        assert_eq!(derived.param_nominal(j), rt.param_nominal(j));
        assert_eq!(derived.param_is_angle(j), rt.param_is_angle(j));
        assert_eq!(derived.param_identifiable(j), rt.param_identifiable(j));
        assert_eq!(derived.param_held(j), rt.param_held(j));
    }
    for k in 0..rt.basis_size() {
        assert_eq!(derived.basis_name(k), rt.basis_name(k));
    }
    for e in 0..rt.equation_count() {
        assert_eq!(derived.equation_constraint(e), rt.equation_constraint(e));
    }
    for c in 0..rt.constraint_count() {
        assert_eq!(derived.constraint_kind(c), rt.constraint_kind(c));
    }
    assert_eq!(derived.orientation_weight(), rt.orientation_weight());

    let (n, np, k, e, dim) = (
        rt.joint_count(),
        rt.param_count(),
        rt.basis_size(),
        rt.equation_count(),
        rt.dim(),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(0x11ca1);
    let (mut phi, mut c) = (vec![0.0; k], vec![0.0; e * k]);
    let (mut phi_rt, mut c_rt) = (vec![0.0; k], vec![0.0; e * k]);
    let (mut tip, mut tip_rt) = (vec![0.0; dim], vec![0.0; dim]);
    let expanded_eqs = rt.expanded_equations().expect("the spec expands");
    for _ in 0..50 {
        let q = random_q(&rt, &mut rng);
        let p = random_p(&rt, &mut rng);
        assert_eq!(q.len(), n);
        derived.basis(&q, &mut phi);
        derived.generalized_params(&p, &mut c);
        rt.basis(&q, &mut phi_rt);
        rt.generalized_params(&p, &mut c_rt);
        derived.tip(&q, &p, &mut tip);
        rt.tip(&q, &p, &mut tip_rt);
        let tip_scale: f64 = tip_rt.iter().map(|x| x.abs()).sum::<f64>().max(1.0);
        for (a, b) in tip.iter().zip(&tip_rt) {
            assert_close(*a, *b, tip_scale, &format!("{file}: tip"));
        }
        // The tool frame, through each model's chain.
        let (mut x, mut rot, mut x_rt, mut rot_rt) = ([0.0; 3], [0.0; 9], [0.0; 3], [0.0; 9]);
        if dim == 3 {
            derived.tool_pose(&q, &p, &mut x, &mut rot);
            rt.tool_pose(&q, &p, &mut x_rt, &mut rot_rt);
            for (a, b) in x.iter().zip(&x_rt) {
                assert_close(*a, *b, tip_scale, &format!("{file}: tool_pose origin"));
            }
            for (a, b) in x.iter().zip(&tip_rt) {
                assert_close(
                    *a,
                    *b,
                    tip_scale,
                    &format!("{file}: tool_pose origin vs tip"),
                );
            }
            for (a, b) in rot.iter().zip(&rot_rt) {
                assert_close(*a, *b, 1.0, &format!("{file}: tool_pose rotation"));
            }
        }
        let expanded = expanded_eqs.eval(&q, &p);
        for eq in 0..e {
            let terms: Vec<f64> = (0..k).map(|kk| c[eq * k + kk] * phi[kk]).collect();
            let h: f64 = terms.iter().sum();
            let scale: f64 = terms.iter().map(|x| x.abs()).sum::<f64>().max(1.0);
            // The run-time engine's h(q; p), through its own basis and c(p).
            let h_rt: f64 = (0..k).map(|kk| c_rt[eq * k + kk] * phi_rt[kk]).sum();
            assert_close(
                h,
                h_rt,
                scale,
                &format!("{file}: h[{eq}] vs run-time basis·c"),
            );
            // ... and from its expanded polynomials (no reduction involved).
            assert_close(
                h,
                expanded[eq],
                scale,
                &format!("{file}: h[{eq}] vs expanded"),
            );
        }
        // The direct forward kinematics and the constraint function.
        for con in 0..rt.constraint_count() {
            let kind = rt.constraint_kind(con);
            let mut vals = vec![0.0; kind.value_count(dim)];
            derived.constraint_values(con, &p, &mut vals);
            let mut h_geo = vec![0.0; kind.equation_count(dim)];
            constraint_function(kind, dim, &vals, &tip_rt, &mut h_geo);
            if kind == ConstraintKind::MeasuredPose {
                // The rotation entries, column-major, after the tip.
                h_geo[3..12].copy_from_slice(&rot_rt);
            }
            let eqs: Vec<usize> = (0..e)
                .filter(|&x| rt.equation_constraint(x) == con)
                .collect();
            for (hg, &eq) in h_geo.iter().zip(&eqs) {
                let terms: Vec<f64> = (0..k).map(|kk| c[eq * k + kk] * phi[kk]).collect();
                let h: f64 = terms.iter().sum();
                let scale: f64 = terms.iter().map(|x| x.abs()).sum::<f64>().max(1.0);
                assert_close(h, *hg, scale, &format!("{file}: h[{eq}] vs geometry"));
            }
        }
        // Jacobian: exact against the run-time engine, and against central differences.
        let mut jac = vec![0.0; e * k * np];
        let mut jac_rt = vec![0.0; e * k * np];
        derived.jacobian(&p, &mut jac);
        rt.jacobian(&p, &mut jac_rt);
        for (a, b) in jac.iter().zip(&jac_rt) {
            assert_close(
                *a,
                *b,
                b.abs().max(1.0),
                &format!("{file}: jacobian vs run-time"),
            );
        }
        let step = 1e-6;
        let (mut cp, mut cm) = (vec![0.0; e * k], vec![0.0; e * k]);
        for j in 0..np {
            let mut pp = p.clone();
            pp[j] += step;
            derived.generalized_params(&pp, &mut cp);
            pp[j] -= 2.0 * step;
            derived.generalized_params(&pp, &mut cm);
            for i in 0..e * k {
                let fd = (cp[i] - cm[i]) / (2.0 * step);
                let a = jac[i * np + j];
                assert!(
                    (a - fd).abs() <= 1e-6 * (1.0 + a.abs()),
                    "{file}: dc[{i}]/dp[{j}] = {a}, central difference {fd}"
                );
            }
        }
    }
}

#[test]
fn adept_one() {
    check(&AdeptOne, "adept_one.yaml");
    assert_eq!(AdeptOne::BASIS_SIZE, 5);
}

#[test]
fn planar3_line() {
    check(&Planar3Line, "planar3_line.yaml");
}

#[test]
fn planar3_point() {
    check(&Planar3Point, "planar3_point.yaml");
}

#[test]
fn scara_plane() {
    check(&ScaraPlane, "scara_plane.yaml");
}

#[test]
fn elbow3_line() {
    check(&Elbow3Line, "elbow3_line.yaml");
}

#[test]
fn puma560_plane() {
    check(&Puma560Plane, "puma560_plane.yaml");
    assert_eq!(Puma560Plane::BASIS_SIZE, 195);
}

#[test]
fn ur5_tracker() {
    check(&Ur5Tracker, "ur5_tracker.yaml");
    assert_eq!(Ur5Tracker::BASIS_SIZE, 93);
}

#[test]
fn puma560_pose_frames() {
    check(&Puma560PoseFrames, "puma560_pose_frames.yaml");
    assert_eq!(Puma560PoseFrames::BASIS_SIZE, 195);
    assert_eq!(Puma560PoseFrames::EQUATIONS, 12);
    assert_eq!(
        Puma560PoseFrames.constraint_kind(0),
        ConstraintKind::MeasuredPose
    );
    // The stated noise levels: 20 µm against 50 µrad.
    let w = Puma560PoseFrames.orientation_weight();
    assert_eq!(w, 2.0e-5 / 5.0e-5);
    assert!((w - 0.4).abs() < 1e-15);
}

/// The PUMA whose twists are unknown too (`puma560_pose_tracker.yaml`) at the nominal twists is the derived [`Puma560PoseFrames`]: the same tool
/// frame, and its 12 equations `c(p)·Φ̃(q)` (K = 729) are that frame's origin and rotation.
#[test]
fn puma560_pose_tracker_at_nominal_twists() {
    let full = runtime("puma560_pose_tracker.yaml");
    let derived = Puma560PoseFrames;
    assert_eq!(full.basis_size(), 729);
    assert_eq!(full.equation_count(), 12);
    assert_eq!(full.orientation_weight(), derived.orientation_weight());
    let mut rng = ChaCha8Rng::seed_from_u64(0x9053);
    let (k, e) = (full.basis_size(), full.equation_count());
    let (mut phi, mut c) = (vec![0.0; k], vec![0.0; e * k]);
    for _ in 0..20 {
        let q = random_q(&derived, &mut rng);
        let p = random_p(&derived, &mut rng);
        // The full model's parameters by name; the twists at their nominals.
        let p_full: Vec<f64> = (0..full.param_count())
            .map(|j| {
                let name = full.param_name(j);
                (0..derived.param_count())
                    .find(|&i| derived.param_name(i) == name)
                    .map_or_else(|| full.param_nominal(j), |i| p[i])
            })
            .collect();
        let (mut x, mut rot, mut x_f, mut rot_f) = ([0.0; 3], [0.0; 9], [0.0; 3], [0.0; 9]);
        derived.tool_pose(&q, &p, &mut x, &mut rot);
        full.tool_pose(&q, &p_full, &mut x_f, &mut rot_f);
        let pose: Vec<f64> = x.iter().chain(&rot).copied().collect();
        for (a, b) in pose.iter().zip(x_f.iter().chain(&rot_f)) {
            assert_close(*a, *b, 1.0, "tool_pose, full vs derived");
        }
        full.basis(&q, &mut phi);
        full.generalized_params(&p_full, &mut c);
        for (eq, want) in pose.iter().enumerate() {
            let terms: Vec<f64> = (0..k).map(|kk| c[eq * k + kk] * phi[kk]).collect();
            let h: f64 = terms.iter().sum();
            let scale: f64 = terms.iter().map(|x| x.abs()).sum::<f64>().max(1.0);
            assert_close(
                h,
                *want,
                scale,
                &format!("full model h[{eq}] vs tool frame"),
            );
        }
    }
}

#[test]
fn puma560_mdh_plane() {
    check(&Puma560MdhPlane, "puma560_mdh_plane.yaml");
    assert_eq!(Puma560MdhPlane::BASIS_SIZE, 195);
}

#[test]
fn puma560_sphere() {
    check(&Puma560Sphere, "puma560_sphere.yaml");
    assert_eq!(Puma560Sphere::BASIS_SIZE, 271);
}

#[test]
fn puma560_pose_tracker() {
    check(&Puma560PoseTracker, "puma560_pose_tracker.yaml");
    assert_eq!(Puma560PoseTracker::BASIS_SIZE, 729);
    assert_eq!(Puma560PoseTracker::EQUATIONS, 12);
}

#[test]
fn stanford_arm_tracker() {
    check(&StanfordArmTracker, "stanford_arm_tracker.yaml");
    assert_eq!(StanfordArmTracker::BASIS_SIZE, 216);
}

#[test]
fn ur10_tracker() {
    check(&Ur10Tracker, "ur10_tracker.yaml");
    assert_eq!(Ur10Tracker::BASIS_SIZE, 729);
}

#[test]
fn franka_panda_sockets() {
    check(&FrankaPandaSockets, "franka_panda_sockets.yaml");
    assert_eq!(FrankaPandaSockets::BASIS_SIZE, 1291);
}

#[test]
fn kuka_iiwa14_point() {
    check(&KukaIiwa14Point, "kuka_iiwa14_point.yaml");
    assert_eq!(KukaIiwa14Point::BASIS_SIZE, 1275);
}

#[test]
fn arm7_all_unknown_point() {
    check(&Arm7AllUnknownPoint, "arm7_all_unknown_point.yaml");
    assert_eq!(Arm7AllUnknownPoint::BASIS_SIZE, 2187);
}

#[test]
fn abb_irb120_ballbar() {
    check(&AbbIrb120BallBar, "abb_irb120_ballbar.yaml");
    assert_eq!(AbbIrb120BallBar::BASIS_SIZE, 77);
}

#[test]
fn adept_one_scara() {
    check(&AdeptOneScara, "adept_one_scara.yaml");
    assert_eq!(AdeptOneScara::BASIS_SIZE, 8);
}

/// The inherent functions and constants say the same as the trait.
#[test]
fn inherent_items_match_the_trait() {
    let q = [0.3, -0.4, 0.05];
    let p = ScaraPlane::NOMINALS;
    let mut out = [0.0; ScaraPlane::BASIS_SIZE];
    ScaraPlane.basis(&q, &mut out);
    assert_eq!(out, ScaraPlane::basis(&q));
    let h = ScaraPlane::equations(&q, &p);
    let phi = ScaraPlane::basis(&q);
    let c = ScaraPlane::generalized_params(&p);
    let direct: f64 = phi.iter().zip(&c).map(|(a, b)| a * b).sum();
    assert!((h[0] - direct).abs() < 1e-15);
    assert_eq!(ScaraPlane::PARAM_NAMES.len(), ScaraPlane::PARAMS);
    assert_eq!(ScaraPlane::JOINTS, 3);
    let gauge_names: Vec<&str> = ScaraPlane::GAUGE
        .iter()
        .flat_map(|g| g.iter().map(|(n, _)| *n))
        .collect();
    assert!(gauge_names
        .iter()
        .all(|n| ScaraPlane::PARAM_NAMES.contains(n)));
}
