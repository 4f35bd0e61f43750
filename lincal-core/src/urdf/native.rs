//! The URDF-native table (`lincal import --convention urdf`): each moving joint's origin as
//! six unknowns `x, y, z, roll, pitch, yaw`, the shape of a URDF's `<origin xyz rpy>`, the
//! parameterisation the URDF-based peers (MUKCa, FIGAROH, robot_calibration) fit.
//!
//! A spec joint turns (or slides) about its own z axis, so joint `i`'s spec frame is the
//! URDF joint frame `U_i` (at zero readings, fixed joints folded in) turned by a constant
//! `R_i` with `R_i·e_z = a_i`, the URDF `<axis>`: `S_i = U_i·R_i`, and the row's origin is
//! `O_i = S_{i−1}⁻¹·S_i` (`S_0` the base link's frame). For an axis along `+z`, `R_i` is the
//! identity and the origin is the URDF's own; otherwise `R_i` is the shortest turn of `e_z`
//! onto `a_i`. Either way, when the origin's pitch would lie within 60° of ±90° (where roll
//! and yaw turn about nearly one axis and the rpy chart is singular), `R_i` is turned further
//! about the axis by the `γ` that makes the pitch 0: the third row of `O_i` is
//! `a_{i−1}ᵀ·(…)`, independent of the previous joint's `γ`, so each joint's `γ` is chosen on
//! its own.
//!
//! Six numbers per joint are more than the arm has (a turn about a revolute axis, a shift
//! along a prismatic one, and the base against the first origin are redundant): every one is
//! written unknown and the exact gauge rule holds the redundant ones, in spec order, so the
//! first origin is held and the base (the measurement frame's registration) stays free.

use super::chain::{ElementKind, UrdfChain};
use super::frame::{cross, dot, norm, unit, Iso};

/// One row of the native table: the origin's six values and the joint's URDF facts.
pub(super) struct NativeRow {
    /// The URDF joint's name.
    pub(super) name: String,
    /// Prismatic (else revolute).
    pub(super) prismatic: bool,
    /// `<limit lower upper>`.
    pub(super) limits: Option<[f64; 2]>,
    /// `x, y, z` of the origin `O_i`.
    pub(super) xyz: [f64; 3],
    /// `roll, pitch, yaw` of the origin `O_i`.
    pub(super) rpy: [f64; 3],
    /// Whether `R_i` is not the identity (the spec frame differs from the URDF joint frame).
    pub(super) turned: bool,
}

/// The native rows of `chain`, the last spec frame `S_n` and the tip (`tool` in the tip
/// link's frame), both in the base link's frame at zero readings.
pub(super) fn native_rows(chain: &UrdfChain, tool: [f64; 3]) -> (Vec<NativeRow>, Iso, [f64; 3]) {
    let mut t = Iso::IDENTITY;
    let mut prev = Iso::IDENTITY;
    let mut rows = Vec::new();
    for e in &chain.elements {
        t = t.mul(&e.origin);
        if e.kind == ElementKind::Fixed {
            continue;
        }
        let r0 = align_z(unit(e.axis));
        let m = prev.inverse().mul(&t).mul(&r0);
        // The pitch of `m` is −asin(m₂₀); near ±90° turn about z until m₂₀ = 0.
        let r = if m.r[2][0].abs() > 0.5 {
            r0.mul(&Iso::rotation(
                [0.0, 0.0, 1.0],
                (-m.r[2][0]).atan2(m.r[2][1]),
            ))
        } else {
            r0
        };
        let s = t.mul(&r);
        let origin = prev.inverse().mul(&s);
        rows.push(NativeRow {
            name: e.name.clone(),
            prismatic: e.kind == ElementKind::Prismatic,
            limits: e.limits,
            xyz: origin.t,
            rpy: origin.rpy(),
            turned: r.distance(&Iso::IDENTITY).0 > 0.0,
        });
        prev = s;
    }
    (rows, prev, t.apply(tool))
}

/// The shortest turn taking `e_z` onto the unit `a` (a half turn about x for `−e_z`).
fn align_z(a: [f64; 3]) -> Iso {
    let z = [0.0, 0.0, 1.0];
    let k = cross(z, a);
    let s = norm(k);
    if s < 1e-15 {
        return if dot(z, a) > 0.0 {
            Iso::IDENTITY
        } else {
            Iso::rotation([1.0, 0.0, 0.0], std::f64::consts::PI)
        };
    }
    Iso::rotation(unit(k), s.atan2(dot(z, a)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn align_z_takes_z_onto_the_axis() {
        for a in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            unit([0.3, -0.5, 0.2]),
        ] {
            let r = align_z(a);
            let z = r.rotate([0.0, 0.0, 1.0]);
            assert!(
                norm([z[0] - a[0], z[1] - a[1], z[2] - a[2]]) < 1e-15,
                "{a:?}: {z:?}"
            );
        }
    }
}

#[cfg(test)]
mod chain_tests {
    use super::*;

    /// The UR5 on a rail of the tests: its rail slides along −x, its shoulder lift turns
    /// about y with a pitched origin.
    #[test]
    fn rows_reproduce_the_urdf_and_turn_only_where_needed() {
        let text = include_str!("../../../tests/urdf/ur5_rail.urdf");
        let robot = crate::urdf::read::read(text, "ur5_rail.urdf").unwrap();
        let chain = UrdfChain::from_robot(&robot, "ur5_rail.urdf", "world", "ee_link").unwrap();
        let (rows, last, tip) = native_rows(&chain, [0.0; 3]);
        // The rail's axis is −x: its frame is turned; wrist 2 turns about z after a pitched
        // wrist 1 whose frame was turned to z already, and keeps its URDF frame.
        assert!(rows[0].turned && !rows[5].turned);
        for r in &rows {
            let pitch = r.rpy[1].abs();
            assert!(pitch < 1.05, "{}: pitch {}", r.name, r.rpy[1]);
        }
        // The product of the origins is the last frame, whose origin is the tip's link.
        let mut t = Iso::IDENTITY;
        for r in &rows {
            t = t.mul(&Iso::from_xyz_rpy(r.xyz, r.rpy));
        }
        let (dr, dt) = t.distance(&last);
        assert!(dr < 1e-12 && dt < 1e-12, "{dr} {dt}");
        assert!(norm(tip) > 0.1);
    }
}
