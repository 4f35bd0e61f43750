//! The plane by normal and offset (`n·x = d`): its data start (a total-least-squares plane,
//! also through the origin, scaled to the held or known entries) and a calibration through the
//! core API on a tilted table through the base origin.

use super::sim::{simulate, SimOptions};
use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::fit::start::{constraint_start, fit_values};
use lincal_core::model::geometry::ConstraintKind;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;

fn grid() -> Vec<[f64; 3]> {
    (0..30)
        .map(|i| {
            let t = f64::from(i) * 0.7;
            [0.3 * t.cos() + 0.01 * t, 0.2 * (1.3 * t).sin(), 0.0]
        })
        .collect()
}

#[test]
fn fit_values_gives_a_unit_normal_and_its_offset_also_through_the_origin() {
    // z = 0, which b·x + 1 = 0 cannot write: n = (0, 0, 1), d = 0.
    let through = grid();
    assert!(fit_values(ConstraintKind::Plane, 3, &through).is_none());
    let v = fit_values(ConstraintKind::PlaneNormal, 3, &through).unwrap();
    for (a, b) in v.iter().zip([0.0, 0.0, 1.0, 0.0]) {
        assert!((a - b).abs() < 1e-12, "{v:?}");
    }
    // 2x − y + 0.5z = 1: n̂ = (2, −1, 0.5)/‖·‖, d̂ = 1/‖·‖ (largest entry positive).
    let plane: Vec<[f64; 3]> = grid()
        .iter()
        .map(|x| [x[0], x[1], 2.0 * (1.0 - 2.0 * x[0] + x[1])])
        .collect();
    let v = fit_values(ConstraintKind::PlaneNormal, 3, &plane).unwrap();
    let norm = (4.0f64 + 1.0 + 0.25).sqrt();
    for (a, b) in v
        .iter()
        .zip([2.0 / norm, -1.0 / norm, 0.5 / norm, 1.0 / norm])
    {
        assert!((a - b).abs() < 1e-9, "{v:?}");
    }
}

const ARM: &str = "name: table\ndim: 3\njoints:\n  \
    - {type: revolute, a: 0, alpha: pi/2, d: 0.3, home: th1}\n  \
    - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}\n  \
    - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}\n\
    params:\n  th1: {nominal: 0}\n  a2: {nominal: 0.4}\n  th2: {nominal: 0}\n  \
    a3: {nominal: 0.35}\n  th3: {nominal: 0}\n";

fn model(constraint: &str, extra: &str) -> SymbolicModel {
    let text = format!("{ARM}{extra}constraint:\n  plane: {constraint}\n");
    let spec = lincal_core::spec::from_yaml_str(&text, None).unwrap();
    SymbolicModel::from_spec(&spec).unwrap()
}

fn index(m: &SymbolicModel, name: &str) -> usize {
    (0..m.param_count())
        .position(|j| m.param_name(j) == name)
        .unwrap()
}

#[test]
fn the_start_respects_held_and_known_entries() {
    // An unknown tilted table through the origin; truth n ∝ (0.1, −0.05, 1), d = 0.
    let m = model(
        "{normal: [n1, n2, n3], offset: d}",
        "  n1: {nominal: 0}\n  n2: {nominal: 0}\n  n3: {nominal: 2}\n  d: {nominal: 0.5}\n",
    );
    let mut p: Vec<f64> = (0..m.param_count()).map(|j| m.param_nominal(j)).collect();
    for (n, v) in [
        ("n1", 0.2),
        ("n2", -0.1),
        ("n3", 2.0),
        ("d", 0.0),
        ("th2", 0.02),
    ] {
        p[index(&m, n)] = v;
    }
    // n3, the largest nominal entry, holds the scale.
    assert!(m.param_held(index(&m, "n3")));
    let poses = simulate(&m, &p, SimOptions::new(60, 3));
    let (start, fitted) = constraint_start(&m, &poses);
    assert_eq!(fitted, vec![0]);
    assert_eq!(start[index(&m, "n3")], 2.0);
    // The nominal arm's tips are close to the truth's: the start is close to the true plane
    // scaled to n3 = 2.
    for (n, v) in [("n1", 0.2), ("n2", -0.1), ("d", 0.0)] {
        assert!(
            (start[index(&m, n)] - v).abs() < 0.05,
            "{n}: {}",
            start[index(&m, n)]
        );
    }
    let spec = m.spec().clone();
    let est = calibrate_spec(&m, &spec, &poses, CalibrateOptions::default()).unwrap();
    assert!(est.residual_rms < 1e-10, "{}", est.residual_rms);
    let plane = &est.planes[0];
    let norm = (0.04f64 + 0.01 + 4.0).sqrt();
    for (a, b) in plane
        .normal
        .iter()
        .zip([0.2 / norm, -0.1 / norm, 2.0 / norm])
    {
        assert!((a - b).abs() < 1e-7, "{plane:?}");
    }
    assert!(plane.offset.abs() < 1e-7, "{plane:?}");

    // A known normal of any length with an unknown offset: d = n·x̄ of the nominal tips.
    let m = model("{normal: [0, 0, 2], offset: d}", "  d: {nominal: 1}\n");
    let mut p: Vec<f64> = (0..m.param_count()).map(|j| m.param_nominal(j)).collect();
    p[index(&m, "d")] = 0.1;
    let poses = simulate(&m, &p, SimOptions::new(40, 4));
    let (start, fitted) = constraint_start(&m, &poses);
    assert_eq!(fitted, vec![0]);
    assert!(
        (start[index(&m, "d")] - 0.1).abs() < 1e-9,
        "{}",
        start[index(&m, "d")]
    );
}
