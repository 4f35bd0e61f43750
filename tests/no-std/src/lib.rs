//! Proves that derived models build without `std`: this crate is `#![no_std]`, depends on
//! `lincal-core` with `default-features = false`, and derives three real models, two from
//! YAML files (one the 7R arm with all 28 DH parameters unknown, through the factored kernel)
//! and one from an inline spec. `cargo build -p lincal-no-std-check` runs in CI.
#![no_std]
#![warn(missing_docs)]

use lincal_derive::CalibModel;

/// Planar 2-link arm on an unknown line, from `specs/planar2_line.yaml`.
#[derive(CalibModel)]
#[calib(spec = "specs/planar2_line.yaml")]
pub struct Planar2Line;

/// SCARA RRP with a stylus on an unknown plane, inline (uses `cos`/`sin` via `libm`).
#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1, d = d1, home = th1),
    joint(revolute, a = a2, alpha = pi, home = th2),
    joint(prismatic, offset = o3),
    tool = [0, 0, 0.05],
    params(a1 = 0.425, d1 = 0.877, th1 = 0, a2 = 0.375, th2 = 0, o3 = 0.1),
    params(b1 = 0.1, b2 = -0.05, b3 = -1.6),
    constraint(plane(b = [b1, b2, b3])),
)]
pub struct ScaraPlane;

/// `h(q; p)` of the planar arm through the trait object, as firmware would call it.
#[must_use]
pub fn planar_residual(q: &[f64; 2], p: &[f64; Planar2Line::PARAMS]) -> f64 {
    let m: &dyn lincal_core::CalibModel = &Planar2Line;
    let mut phi = [0.0; Planar2Line::BASIS_SIZE];
    let mut c = [0.0; Planar2Line::BASIS_SIZE];
    m.basis(q, &mut phi);
    m.generalized_params(p, &mut c);
    phi.iter().zip(&c).map(|(a, b)| a * b).sum()
}

/// The SCARA stylus tip at joint readings `q` and nominal parameters.
#[must_use]
pub fn scara_tip(q: &[f64; 3]) -> [f64; 3] {
    ScaraPlane::tip(q, &ScaraPlane::NOMINALS)
}

/// A 7R arm with all 28 DH parameters unknown, ball pinned in an unknown socket (`K` = 2187):
/// the factored kernel and its tables build without `std` too.
#[derive(CalibModel)]
#[calib(spec = "../../lincal-models/specs/arm7_all_unknown_point.yaml")]
pub struct Arm7AllUnknownPoint;

/// `h(q; p)` of the 7R arm at the nominal parameters, through the trait (the kernel writes
/// into the caller's buffers).
#[must_use]
pub fn arm7_residual(q: &[f64; 7]) -> [f64; 3] {
    let m: &dyn lincal_core::CalibModel = &Arm7AllUnknownPoint;
    let mut phi = [0.0; Arm7AllUnknownPoint::BASIS_SIZE];
    let mut c = [0.0; 3 * Arm7AllUnknownPoint::BASIS_SIZE];
    m.basis(q, &mut phi);
    m.generalized_params(&Arm7AllUnknownPoint::NOMINALS, &mut c);
    let mut h = [0.0; 3];
    for (e, h) in h.iter_mut().enumerate() {
        *h = phi
            .iter()
            .zip(&c[e * phi.len()..])
            .map(|(a, b)| a * b)
            .sum();
    }
    h
}
