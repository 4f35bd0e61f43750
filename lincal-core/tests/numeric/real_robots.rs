//! Real robots out of the box (issue 22): unknown fixtures start from the data (two sockets
//! both left at the import's nominal calibrate, no NaN), and the answer does not depend on the
//! order of `params:`.

use super::sim::{simulate, SimOptions};
use lincal_core::calibrate::{calibrate_spec, pose_residuals, CalibrateOptions};
use lincal_core::fit::start::{constraint_start, fit_values};
use lincal_core::model::geometry::ConstraintKind;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;

/// A 5R spatial arm (modified DH, no two axes parallel, like a Panda's or an iiwa's) with every
/// length, twist and home unknown, a ball on a tool, seated in two sockets `distance` apart.
fn sockets_spec(params: &[(&str, f64)], p0: [f64; 3], p1: [f64; 3]) -> String {
    let mut s = String::from(
        "name: sockets5\ndim: 3\nconvention: mdh\njoints:\n\
         \x20 - {type: revolute, d: d1, home: h1}\n\
         \x20 - {type: revolute, a: a2, alpha: al2, d: d2, home: h2}\n\
         \x20 - {type: revolute, a: a3, alpha: al3, d: d3, home: h3}\n\
         \x20 - {type: revolute, a: a4, alpha: al4, d: d4, home: h4}\n\
         \x20 - {type: revolute, a: a5, alpha: al5, d: d5, home: h5}\n\
         tool: [0.02, 0.01, 0.1]\nparams:\n",
    );
    for (n, v) in params {
        s.push_str(&format!("  {n}: {{nominal: {v}}}\n"));
    }
    for (k, p) in [("p0", p0), ("p1", p1)] {
        for (c, v) in ["x", "y", "z"].iter().zip(p) {
            s.push_str(&format!("  {k}{c}: {{nominal: {v}}}\n"));
        }
    }
    s.push_str(
        "constraints:\n  - point: {p: [p0x, p0y, p0z]}\n  - point: {p: [p1x, p1y, p1z]}\n\
         relations:\n  - {distance: [0, 1], value: 0.05}\n",
    );
    s
}

const ARM: &[(&str, f64)] = &[
    ("d1", 0.34),
    ("h1", 0.0),
    ("a2", 0.01),
    ("al2", -std::f64::consts::FRAC_PI_2),
    ("d2", 0.0),
    ("h2", 0.0),
    ("a3", 0.02),
    ("al3", std::f64::consts::FRAC_PI_2),
    ("d3", 0.3),
    ("h3", 0.0),
    ("a4", 0.05),
    ("al4", -std::f64::consts::FRAC_PI_2),
    ("d4", 0.01),
    ("h4", 0.0),
    ("a5", 0.01),
    ("al5", std::f64::consts::FRAC_PI_2),
    ("d5", 0.25),
    ("h5", 0.0),
];

/// The true arm: the nominals, each length off by up to 3 mm and each angle by 0.01 rad.
fn truth(m: &SymbolicModel, p0: [f64; 3], p1: [f64; 3]) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| {
            let name = m.param_name(j);
            let nom = m.param_nominal(j);
            let socket = |p: [f64; 3]| p[usize::from(name.as_bytes()[2] - b'x')];
            match name {
                n if n.starts_with("p0") => socket(p0),
                n if n.starts_with("p1") => socket(p1),
                _ if m.param_held(j) => nom,
                _ => {
                    nom + if m.param_is_angle(j) { 0.01 } else { 0.003 } * ((j % 5) as f64 - 2.0)
                        / 2.0
                }
            }
        })
        .collect()
}

#[test]
fn sockets_left_at_one_nominal_start_from_their_poses() {
    let (t0, t1) = ([0.45, 0.1, 0.2], [0.45, 0.15, 0.2]);
    // The user's first spec: both sockets at the import's nominal, the same point.
    let spec =
        lincal_core::spec::from_yaml_str(&sockets_spec(ARM, [0.4; 3], [0.4; 3]), None).unwrap();
    let m = SymbolicModel::from_spec(&spec).unwrap();
    let p = truth(&m, t0, t1);
    let mut opts = SimOptions::new(80, 7);
    opts.track = 2e-5;
    let poses = simulate(&m, &p, opts);
    // The start: each socket at the mean nominal tip of its own poses, apart.
    let (start, fitted) = constraint_start(&m, &poses);
    assert_eq!(fitted, vec![0, 1]);
    let at = |k: &str| {
        start[(0..m.param_count())
            .position(|j| m.param_name(j) == k)
            .unwrap()]
    };
    let gap = ((at("p0x") - at("p1x")).powi(2) + (at("p0y") - at("p1y")).powi(2)).sqrt();
    assert!(gap > 0.03, "the sockets start {gap} m apart");
    let est = calibrate_spec(&m, &spec, &poses, CalibrateOptions::default())
        .expect("coincident starts calibrate");
    assert!(est.params.iter().all(|q| q.value.is_finite()));
    assert!(est.residual_rms < 1e-4, "residual {}", est.residual_rms);
    let rel = &est.relations[0];
    assert!((rel.calibrated - 0.05).abs() < 1e-4, "{rel:?}");
}

/// Every `params:` order gives the same calibrated tips (the gauge rule walks the chain, not
/// the map), and holds the same parameters.
#[test]
fn the_order_of_params_does_not_change_the_answer() {
    let (t0, t1) = ([0.45, 0.1, 0.2], [0.45, 0.15, 0.2]);
    let guess = ([0.5, 0.0, 0.3], [0.5, 0.1, 0.3]);
    let base =
        lincal_core::spec::from_yaml_str(&sockets_spec(ARM, guess.0, guess.1), None).unwrap();
    let m0 = SymbolicModel::from_spec(&base).unwrap();
    let mut opts = SimOptions::new(80, 11);
    opts.track = 2e-5;
    let poses = simulate(&m0, &truth(&m0, t0, t1), opts);
    let mut orders: Vec<Vec<(&str, f64)>> = vec![ARM.to_vec(), ARM.iter().rev().copied().collect()];
    // A fixed shuffle: every third, then the rest.
    orders.push(
        (0..3)
            .flat_map(|r| ARM.iter().skip(r).step_by(3).copied())
            .collect(),
    );
    let mut tips: Vec<Vec<f64>> = Vec::new();
    let mut held: Vec<Vec<String>> = Vec::new();
    for order in &orders {
        let spec =
            lincal_core::spec::from_yaml_str(&sockets_spec(order, guess.0, guess.1), None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let est = calibrate_spec(&m, &spec, &poses, CalibrateOptions::default()).unwrap();
        let mut h: Vec<String> = est
            .params
            .iter()
            .filter(|q| q.held)
            .map(|q| q.name.clone())
            .collect();
        h.sort();
        held.push(h);
        // The calibrated tips at every pose (the model's order of p is the spec's).
        let p: Vec<f64> = (0..m.param_count())
            .map(|j| {
                est.params
                    .iter()
                    .find(|q| q.name == m.param_name(j))
                    .unwrap()
                    .value
            })
            .collect();
        let mut x = Vec::new();
        for q in poses.q.iter() {
            let mut t = [0.0; 3];
            m.tip(q, &p, &mut t);
            x.extend(t);
        }
        assert!(pose_residuals(&m, &poses, &p)
            .unwrap()
            .iter()
            .all(|r| *r < 2e-4));
        tips.push(x);
    }
    for k in 1..orders.len() {
        assert_eq!(held[k], held[0], "held parameters, order {k}");
        let worst = tips[k]
            .iter()
            .zip(&tips[0])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "order {k}: tips differ by {worst} m");
    }
    // The gauge is held by the arm, not by a socket coordinate.
    assert!(held[0].iter().all(|n| !n.starts_with('p')), "{:?}", held[0]);
}

/// Each kind's fit recovers an exact constraint from points on it.
#[test]
fn constraint_fits_recover_exact_constraints() {
    let pts: Vec<[f64; 3]> = (0..40)
        .map(|i| {
            let (u, v) = (f64::from(i) * 0.37, f64::from(i % 7) * 0.9);
            [u.cos() * v.sin(), u.sin() * v.sin(), v.cos()]
        })
        .collect();
    // Sphere of radius 0.3 about (0.5, -0.2, 0.4).
    let sphere: Vec<[f64; 3]> = pts
        .iter()
        .map(|x| [0.5 + 0.3 * x[0], -0.2 + 0.3 * x[1], 0.4 + 0.3 * x[2]])
        .collect();
    let v = fit_values(ConstraintKind::Sphere, 3, &sphere).unwrap();
    for (a, b) in v.iter().zip([0.5, -0.2, 0.4, 0.3]) {
        assert!((a - b).abs() < 1e-12, "{v:?}");
    }
    // The plane 2x − y + 0.5z = 1, b = −(2, −1, 0.5).
    let plane: Vec<[f64; 3]> = pts
        .iter()
        .map(|x| [x[0], x[1], 2.0 * (1.0 - 2.0 * x[0] + x[1])])
        .collect();
    let v = fit_values(ConstraintKind::Plane, 3, &plane).unwrap();
    for (a, b) in v.iter().zip([-2.0, 1.0, -0.5]) {
        assert!((a - b).abs() < 1e-9, "{v:?}");
    }
    // A plane through the origin has no b: no start, the nominal stays.
    let through: Vec<[f64; 3]> = pts.iter().map(|x| [x[0], x[1], 0.0]).collect();
    assert!(fit_values(ConstraintKind::Plane, 3, &through).is_none());
    // A point: the mean.
    let v = fit_values(ConstraintKind::Point, 3, &sphere[..2]).unwrap();
    assert!((v[0] - (sphere[0][0] + sphere[1][0]) / 2.0).abs() < 1e-15);
}
