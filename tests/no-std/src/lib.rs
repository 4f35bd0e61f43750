//! Proves that derived models build without `std`: this crate is `#![no_std]`, depends on
//! `lincal-core` with `default-features = false`, and derives two real models, one from a
//! YAML file and one from an inline spec. `cargo build -p lincal-no-std-check` runs in CI.
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
