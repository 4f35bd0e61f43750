//! Engine tests: the paper's examples, independent numerical checks at random points.
#![cfg(test)]

use super::testutil::*;
use super::SymbolicModel;
use crate::model::CalibModel;
use crate::spec::{Constraint, ParamRole};

#[test]
fn planar_line_matches_the_paper() {
    for n in 2..=6 {
        let m = SymbolicModel::from_spec(&planar_line(n)).unwrap();
        assert_eq!(m.basis_size(), 2 * n + 1, "n = {n}: {:?}", m.basis_names());
        assert_eq!(m.identifiability().count, 2 * n, "n = {n}");
    }
}

#[test]
fn planar_point_identifies_six() {
    let m = SymbolicModel::from_spec(&planar_point(3)).unwrap();
    assert_eq!(m.identifiability().count, 6, "{:?}", m.basis_names());
}

#[test]
fn puma_plane_probe() {
    let t = std::time::Instant::now();
    let spec = puma(
        Constraint::Plane { b: [p("b1"), p("b2"), p("b3")] },
        vec![
            param("b1", 0.0, ParamRole::Length),
            param("b2", 0.0, ParamRole::Length),
            param("b3", -3.3, ParamRole::Length),
        ],
    );
    let m = SymbolicModel::from_spec(&spec).unwrap();
    eprintln!("puma plane: naive {} K {} ident {} in {:?}", m.naive_size(), m.basis_size(), m.identifiability().count, t.elapsed());
}
