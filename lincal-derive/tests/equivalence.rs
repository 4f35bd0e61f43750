//! Models derived from inline attributes equal the run-time engine built from the same spec
//! written in YAML: constants, `basis(q)·generalized_params(p)` to 1e-12 relative at random
//! `(q, p)`, the tip, and the Jacobian against central differences. Also the
//! `crate = "..."` rename.

use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use lincal_derive::CalibModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Modified DH, a prismatic joint, a base, known parameters (one an irrational angle), a tool
/// with a parameter, and a list of two constraints (a 3-D line and a sphere).
#[derive(CalibModel)]
#[calib(
    name = "mixed",
    description = "every kind of slot",
    dim = 3,
    convention = mdh,
    joint(revolute, d = d1, home = th1, limits = [-2.5, 2.5]),
    joint(revolute, a = a2, alpha = pi/2, home = "th2"),
    joint(prismatic, a = a3, alpha = tw, theta = 0, offset = o3, limits = [0, 0.3]),
    joint(revolute, a = 0.1, alpha = 2*pi/3, d = 0.05, home = 0.3),
    tool = [tx, 0, L],
    base(x = bx, y = 0.2, pitch = 0.1, yaw = yw),
    params(d1 = 0.3, th1 = 0.01, a2 = 0.4, th2 = -0.02, a3 = 0.05, o3 = 0.1, tx = 0.02),
    known(tw = 0.7, L = 0.1),
    params(bx = 0.5, yw = 0.1),
    params(u1 = -2.0, u2 = 0.5, w2 = 0.4, w3 = -2.5, cx = 0.4, cy = 0.1, cz = 0.2, r = 0.15),
    constraints(
        line(planes = [[u1, u2, 0], [0, w2, w3]]),
        sphere(center = [cx, cy, cz], radius = r),
    ),
)]
struct Mixed;

const MIXED_YAML: &str = "
name: mixed
dim: 3
convention: mdh
joints:
  - {type: revolute, d: d1, home: th1, limits: [-2.5, 2.5]}
  - {type: revolute, a: a2, alpha: pi/2, home: th2}
  - {type: prismatic, a: a3, alpha: tw, theta: 0, offset: o3, limits: [0, 0.3]}
  - {type: revolute, a: 0.1, alpha: 2*pi/3, d: 0.05, home: 0.3}
tool: [tx, 0, L]
base: {x: bx, y: 0.2, pitch: 0.1, yaw: yw}
params:
  d1: {nominal: 0.3}
  th1: {nominal: 0.01}
  a2: {nominal: 0.4}
  th2: {nominal: -0.02}
  a3: {nominal: 0.05}
  o3: {nominal: 0.1}
  tx: {nominal: 0.02}
  tw: {nominal: 0.7, known: true}
  L: {nominal: 0.1, known: true}
  bx: {nominal: 0.5}
  yw: {nominal: 0.1}
  u1: {nominal: -2.0}
  u2: {nominal: 0.5}
  w2: {nominal: 0.4}
  w3: {nominal: -2.5}
  cx: {nominal: 0.4}
  cy: {nominal: 0.1}
  cz: {nominal: 0.2}
  r: {nominal: 0.15}
constraints:
  - line: {planes: [[u1, u2, 0], [0, w2, w3]]}
  - sphere: {center: [cx, cy, cz], radius: r}
";

/// The paper's planar arm pinned at a point, with a quadric-free measured twin below.
#[derive(CalibModel)]
#[calib(dim = 2)]
#[calib(joint(revolute, a = a1, home = th1), joint(revolute, a = a2, home = th2))]
#[calib(params(a1 = 0.375, th1 = 0, a2 = 0.425, th2 = 0), constraint(measured))]
struct PlanarMeasured;

const PLANAR_MEASURED_YAML: &str = "
name: planar_measured
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
params:
  a1: {nominal: 0.375}
  th1: {nominal: 0}
  a2: {nominal: 0.425}
  th2: {nominal: 0}
constraint: measured
";

/// A 2-D quadric (ellipse) with a known matrix entry.
#[derive(CalibModel)]
#[calib(
    dim = 2,
    joint(revolute, a = a1, home = th1),
    joint(revolute, a = a2),
    params(a1 = 0.3, th1 = 0.1, a2 = 0.2, q11 = 1.5, q12 = 0.1, g1 = 0.2, g2 = -0.3),
    constraint(quadric(A = [[q11, q12], [q12, 2]], b = [g1, g2])),
)]
struct Ellipse;

const ELLIPSE_YAML: &str = "
name: ellipse
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2}
params:
  a1: {nominal: 0.3}
  th1: {nominal: 0.1}
  a2: {nominal: 0.2}
  q11: {nominal: 1.5}
  q12: {nominal: 0.1}
  g1: {nominal: 0.2}
  g2: {nominal: -0.3}
constraint:
  quadric: {A: [[q11, q12], [q12, 2]], b: [g1, g2]}
";

fn check(derived: &dyn CalibModel, yaml: &str) {
    let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
    let rt = SymbolicModel::from_spec(&spec).unwrap();
    assert_eq!(derived.name(), rt.name());
    assert_eq!(derived.basis_size(), rt.basis_size());
    assert_eq!(derived.param_count(), rt.param_count());
    assert_eq!(derived.identifiable_count(), rt.identifiable_count());
    assert_eq!(derived.equation_count(), rt.equation_count());
    assert_eq!(derived.relations(), rt.relations());
    for j in 0..rt.param_count() {
        assert_eq!(derived.param_name(j), rt.param_name(j));
        assert_eq!(derived.param_nominal(j), rt.param_nominal(j));
        assert_eq!(derived.param_held(j), rt.param_held(j));
    }
    for k in 0..rt.basis_size() {
        assert_eq!(derived.basis_name(k), rt.basis_name(k));
    }
    let (n, np, k, e, dim) = (
        rt.joint_count(),
        rt.param_count(),
        rt.basis_size(),
        rt.equation_count(),
        rt.dim(),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let (mut phi, mut c, mut phi_rt, mut c_rt) = (
        vec![0.0; k],
        vec![0.0; e * k],
        vec![0.0; k],
        vec![0.0; e * k],
    );
    let (mut tip, mut tip_rt) = (vec![0.0; dim], vec![0.0; dim]);
    for _ in 0..100 {
        let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
        let p: Vec<f64> = (0..np)
            .map(|j| rt.param_nominal(j) + rng.gen_range(-0.5..0.5))
            .collect();
        derived.basis(&q, &mut phi);
        derived.generalized_params(&p, &mut c);
        rt.basis(&q, &mut phi_rt);
        rt.generalized_params(&p, &mut c_rt);
        for eq in 0..e {
            let terms: Vec<f64> = (0..k).map(|i| c[eq * k + i] * phi[i]).collect();
            let h: f64 = terms.iter().sum();
            let h_rt: f64 = (0..k).map(|i| c_rt[eq * k + i] * phi_rt[i]).sum();
            let scale = terms.iter().map(|x| x.abs()).sum::<f64>().max(1.0);
            assert!(
                (h - h_rt).abs() <= 1e-12 * scale,
                "{}: h {h} vs {h_rt}",
                rt.name()
            );
        }
        derived.tip(&q, &p, &mut tip);
        rt.tip(&q, &p, &mut tip_rt);
        for (a, b) in tip.iter().zip(&tip_rt) {
            assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "tip {a} vs {b}");
        }
        let mut jac = vec![0.0; e * k * np];
        derived.jacobian(&p, &mut jac);
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
                    "dc[{i}]/dp[{j}] {a} vs {fd}"
                );
            }
        }
        for con in 0..rt.constraint_count() {
            let len = rt.constraint_kind(con).value_count(dim);
            let (mut v, mut v_rt) = (vec![0.0; len], vec![0.0; len]);
            derived.constraint_values(con, &p, &mut v);
            rt.constraint_values(con, &p, &mut v_rt);
            assert_eq!(v, v_rt);
        }
    }
}

#[test]
fn mixed_spatial_model() {
    check(&Mixed, MIXED_YAML);
    assert_eq!(Mixed::NAME, "mixed");
    assert_eq!(Mixed::JOINTS, 4);
    assert!(Mixed.joint_is_prismatic(2));
    assert_eq!(Mixed.joint_limits(2), Some([0.0, 0.3]));
    assert_eq!(Mixed.constraint_count(), 2);
    assert_eq!(Mixed::EQUATIONS, 3);
}

#[test]
fn measured_tip() {
    check(&PlanarMeasured, PLANAR_MEASURED_YAML);
    // The default name is the type's, in snake_case.
    assert_eq!(PlanarMeasured::NAME, "planar_measured");
    // For a measured tip the equations are the tip itself.
    let q = [0.3, 1.1];
    let p = PlanarMeasured::NOMINALS;
    let h = PlanarMeasured::equations(&q, &p);
    let x = PlanarMeasured::tip(&q, &p);
    assert!((h[0] - x[0]).abs() < 1e-14 && (h[1] - x[1]).abs() < 1e-14);
}

#[test]
fn quadric() {
    check(&Ellipse, ELLIPSE_YAML);
}

/// A crate that re-exports lincal-core under another path.
mod reexport {
    pub use lincal_core as engine;
}

#[derive(CalibModel)]
#[calib(crate = "crate::equivalence::reexport::engine")]
#[calib(
    dim = 2,
    joint(revolute, a = a1, home = th1),
    params(a1 = 0.4, th1 = 0, cx = 0.1, cy = 0.2, r = 0.3),
    constraint(circle(center = [cx, cy], radius = r)),
)]
struct Renamed;

#[test]
fn renamed_crate_path() {
    let m: &dyn CalibModel = &Renamed;
    assert_eq!(m.constraint_kind(0), lincal_core::ConstraintKind::Circle);
    assert_eq!(Renamed::PARAM_NAMES, ["a1", "th1", "cx", "cy", "r"]);
}

/// A generic type gets the impls with its generics.
#[derive(CalibModel)]
#[calib(
    dim = 2,
    joint(revolute, a = a1),
    params(a1 = 0.4, px = 0.4, py = 0),
    constraint(point(p = [px, py])),
)]
// Models are `Sync` (fits share them across threads), so type parameters are too.
struct Generic<T: Copy + Sync>(core::marker::PhantomData<T>);

#[test]
fn generic_type() {
    let m: &dyn CalibModel = &Generic::<u8>(core::marker::PhantomData);
    assert_eq!(m.joint_count(), 1);
    assert_eq!(Generic::<u8>::BASIS_NAMES, ["1", "c1", "s1"]);
    assert_eq!(Generic::<u8>::basis(&[0.0]), [1.0, 1.0, 0.0]);
}

/// Two sockets a known distance apart and two parallel lines 3 cm apart: the relations come
/// through the inline front-end as through YAML, and the scale becomes identifiable.
#[derive(CalibModel)]
#[calib(
    name = "sockets_and_rails",
    dim = 2,
    joint(revolute, a = a1, home = th1),
    joint(revolute, a = a2, home = th2),
    joint(revolute, a = a3, home = th3),
    params(a1 = 0.4, th1 = 0, a2 = 0.3, th2 = 0, a3 = 0.2, th3 = 0),
    params(x1 = 0.5, y1 = 0.2, x2 = 0.45, y2 = 0.25, u1 = -2.0, u2 = 0.5, v1 = -1.9, v2 = 0.475),
    constraints(
        point(p = [x1, y1]),
        point(p = [x2, y2]),
        line(b = [u1, u2]),
        line(b = [v1, v2]),
    ),
    relations(
        distance(between = [0, 1], value = 0.0707),
        offset(between = [2, 3], value = 0.03),
    ),
)]
struct SocketsAndRails;

const SOCKETS_AND_RAILS_YAML: &str = "
name: sockets_and_rails
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
  - {type: revolute, a: a3, home: th3}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0}
  a2: {nominal: 0.3}
  th2: {nominal: 0}
  a3: {nominal: 0.2}
  th3: {nominal: 0}
  x1: {nominal: 0.5}
  y1: {nominal: 0.2}
  x2: {nominal: 0.45}
  y2: {nominal: 0.25}
  u1: {nominal: -2.0}
  u2: {nominal: 0.5}
  v1: {nominal: -1.9}
  v2: {nominal: 0.475}
constraints:
  - point: {p: [x1, y1]}
  - point: {p: [x2, y2]}
  - line: {b: [u1, u2]}
  - line: {b: [v1, v2]}
relations:
  - {distance: [0, 1], value: 0.0707}
  - {offset: [2, 3], value: 0.03}
";

#[test]
fn relations_between_constraints() {
    use lincal_core::model::geometry::RelationKind;
    check(&SocketsAndRails, SOCKETS_AND_RAILS_YAML);
    let r = SocketsAndRails.relations();
    assert_eq!(r.len(), 2);
    assert_eq!(
        (r[0].kind, r[0].between, r[0].value),
        (RelationKind::Distance, [0, 1], 0.0707)
    );
    assert_eq!(
        (r[1].kind, r[1].between, r[1].value),
        (RelationKind::Offset, [2, 3], 0.03)
    );
    // A known distance fixes the scale: every link length is identifiable on its own.
    for j in 0..SocketsAndRails.param_count() {
        if SocketsAndRails.param_name(j).starts_with('a') {
            assert!(
                SocketsAndRails.param_identifiable(j),
                "{}",
                SocketsAndRails.param_name(j)
            );
        }
    }
}

/// A measured tool frame written inline: a tool frame with parameters, a base, and the noise
/// levels stated (so `orientation_weight()` is their ratio).
#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, alpha = pi/2, d = d1, home = th1),
    joint(revolute, a = a2, alpha = al2, home = th2),
    joint(revolute, a = 0.05, alpha = -pi/2, home = th3),
    tool(x = tx, z = 0.1, roll = tr, pitch = tp, yaw = tw),
    base(x = bx, yaw = by),
    params(a1 = 0.1, d1 = 0.3, th1 = 0, a2 = 0.4, al2 = 0.01, th2 = 0, th3 = 0),
    params(tx = 0.02, tr = 0.1, tp = -0.1, tw = 0.2, bx = 1.5, by = 0.3),
    constraint(measured_pose(position_std = 2e-5, orientation_std = 5e-5)),
)]
struct WristPose;

const WRIST_POSE_YAML: &str = "
name: wrist_pose
dim: 3
joints:
  - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1}
  - {type: revolute, a: a2, alpha: al2, home: th2}
  - {type: revolute, a: 0.05, alpha: -pi/2, home: th3}
tool: {x: tx, z: 0.1, roll: tr, pitch: tp, yaw: tw}
base: {x: bx, yaw: by}
params:
  a1: {nominal: 0.1}
  d1: {nominal: 0.3}
  th1: {nominal: 0}
  a2: {nominal: 0.4}
  al2: {nominal: 0.01}
  th2: {nominal: 0}
  th3: {nominal: 0}
  tx: {nominal: 0.02}
  tr: {nominal: 0.1}
  tp: {nominal: -0.1}
  tw: {nominal: 0.2}
  bx: {nominal: 1.5}
  by: {nominal: 0.3}
constraint:
  measured_pose: {position_std: 2.0e-5, orientation_std: 5.0e-5}
";

/// The bare kind: no noise levels, so the trait's default weight (the fit estimates it).
#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, alpha = pi/2, home = th1),
    joint(revolute, a = a2, home = th2),
    tool(z = tz, yaw = tw),
    params(a1 = 0.3, th1 = 0, a2 = 0.2, th2 = 0, tz = 0.1, tw = 0),
    constraint(measured_pose),
)]
struct BarePose;

#[test]
fn measured_pose_inline() {
    use lincal_core::model::geometry::{ConstraintKind, DEFAULT_ORIENTATION_WEIGHT};
    check(&WristPose, WRIST_POSE_YAML);
    let rt =
        SymbolicModel::from_spec(&lincal_core::spec::from_yaml_str(WRIST_POSE_YAML, None).unwrap())
            .unwrap();
    assert_eq!(WristPose.constraint_kind(0), ConstraintKind::MeasuredPose);
    assert_eq!(WristPose::EQUATIONS, 12);
    assert_eq!(WristPose.orientation_weight(), rt.orientation_weight());
    assert_eq!(WristPose.orientation_weight(), 2.0e-5 / 5.0e-5);
    assert_eq!(BarePose.orientation_weight(), DEFAULT_ORIENTATION_WEIGHT);
    // The tool frame through the generated chain is the run-time model's, and the
    // generated equations are its origin and rotation entries (column-major).
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..50 {
        let q: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-3.0..3.0));
        let p: [f64; WristPose::PARAMS] =
            core::array::from_fn(|j| WristPose::NOMINALS[j] + rng.gen_range(-0.3..0.3));
        let (mut x, mut r, mut x_rt, mut r_rt) = ([0.0; 3], [0.0; 9], [0.0; 3], [0.0; 9]);
        WristPose.tool_pose(&q, &p, &mut x, &mut r);
        rt.tool_pose(&q, &p, &mut x_rt, &mut r_rt);
        let h = WristPose::equations(&q, &p);
        for (i, (a, b)) in x.iter().chain(&r).zip(x_rt.iter().chain(&r_rt)).enumerate() {
            assert!((a - b).abs() <= 1e-12, "tool_pose[{i}] {a} vs {b}");
            assert!((h[i] - b).abs() <= 1e-12, "h[{i}] {} vs {b}", h[i]);
        }
    }
}
