//! The joint table's rules: each joint's slots fit its type and the spec's convention, its
//! limits are an interval, and a planar arm's joints stay in the plane.

use super::Checker;
use crate::spec::{Convention, Joint, JointKind, Slot, Spec};

/// The joint list is not empty, and each joint follows the rules of
/// [`check_joint`], joint by joint.
pub(super) fn check_joints(ck: &mut Checker<'_>, joints: &[Joint], dim: Option<usize>) {
    if joints.is_empty() {
        ck.at_value(
            "joints",
            "the joint list is empty: expected at least one joint".into(),
        );
    }
    for (i, j) in joints.iter().enumerate() {
        check_joint(ck, i, j, dim);
    }
}

/// One joint: its slots fit its type, its limits are an interval, and in a planar arm it is
/// revolute about z (twist 0 or π).
fn check_joint(ck: &mut Checker<'_>, i: usize, j: &Joint, dim: Option<usize>) {
    let f = |s: &str| format!("joints[{i}].{s}");
    check_joint_type_slots(ck, i, j);
    if let Some([lo, hi]) = j.limits {
        if !lo.is_finite() || !hi.is_finite() {
            ck.at_value(
                &f("limits"),
                format!("limits must be finite numbers, found [{lo}, {hi}]"),
            );
        } else if lo >= hi {
            ck.at_value(
                &f("limits"),
                format!("limits must be [min, max] with min < max, found [{lo}, {hi}]"),
            );
        }
    }
    if dim == Some(2) {
        check_planar_joint(ck, i, j);
    }
}

/// A revolute joint has no `theta`/`offset` (its angle is `q − home`); a prismatic joint
/// has no `home` and no `d` (its `d` is `q + offset`).
fn check_joint_type_slots(ck: &mut Checker<'_>, i: usize, j: &Joint) {
    let f = |s: &str| format!("joints[{i}].{s}");
    match j.kind {
        JointKind::Revolute => {
            for (name, s) in [("theta", &j.theta), ("offset", &j.offset)] {
                if *s != Slot::zero() {
                    ck.at_key(
                        &f(name),
                        format!(
                            "`{name}` belongs to prismatic joints; a revolute joint has \
                             `home` (θ = q − home)"
                        ),
                    );
                }
            }
        }
        JointKind::Prismatic => {
            if j.home != Slot::zero() {
                ck.at_key(
                    &f("home"),
                    "`home` belongs to revolute joints; a prismatic joint has `offset` \
                     (d = q + offset) and a fixed angle `theta`"
                        .into(),
                );
            }
            if j.d != Slot::zero() {
                ck.at_key(
                    &f("d"),
                    "a prismatic joint's `d` is its reading plus `offset`: give `offset`, \
                     not `d`"
                        .into(),
                );
            }
        }
    }
}

/// A joint of a planar (dim 2) arm: revolute, with `alpha` the constant 0 or π and no `beta`,
/// so that the arm stays in the plane.
fn check_planar_joint(ck: &mut Checker<'_>, i: usize, j: &Joint) {
    let f = |s: &str| format!("joints[{i}].{s}");
    if j.kind == JointKind::Prismatic {
        // With every twist 0 or π, a DH prismatic joint slides along z: out of the plane,
        // so its reading would change nothing a planar constraint can see.
        ck.at_value(
            &f("type"),
            "a planar (dim 2) arm cannot have a prismatic joint: a DH prismatic joint slides \
             along its z axis, out of the plane; describe the arm with dim: 3"
                .to_string(),
        );
    }
    if !matches!(&j.beta, Slot::Const(e) if e.exact_cos_sin() == Some((1, 0))) {
        let msg = "a planar (dim 2) arm rotates about z: `beta` tilts an axis out of the plane";
        ck.at_value(&f("beta"), format!("{msg} and must be 0 (or left out)"));
    }
    match &j.alpha {
        Slot::Param(n) => ck.at_value(
            &f("alpha"),
            format!(
                "a planar (dim 2) arm rotates about z: `alpha` must be the constant 0 or \
                 pi, not the parameter `{n}`"
            ),
        ),
        Slot::Const(e) if !matches!(e.exact_cos_sin(), Some((_, 0))) => ck.at_value(
            &f("alpha"),
            format!("a planar (dim 2) arm rotates about z: `alpha` must be 0 or pi, found {e}"),
        ),
        Slot::Const(_) => {}
    }
}

/// A joint's origin is written only with `convention: urdf`, which in turn has no DH `a`,
/// `alpha`, `beta`, and is spatial (a planar arm is a DH table about parallel z axes).
pub(super) fn check_convention_slots(ck: &mut Checker<'_>, spec: &Spec, dim: Option<usize>) {
    let urdf = spec.convention == Convention::Urdf;
    if urdf && dim == Some(2) {
        ck.at_value(
            "convention",
            "`convention: urdf` describes a spatial chain (dim 3); a planar arm is a DH \
             table (`convention: dh`)"
                .into(),
        );
    }
    for (i, j) in spec.joints.iter().enumerate() {
        let f = |s: &str| format!("joints[{i}].{s}");
        if urdf {
            for (name, s) in [("a", &j.a), ("alpha", &j.alpha), ("beta", &j.beta)] {
                if *s != Slot::zero() {
                    ck.at_key(
                        &f(name),
                        format!(
                            "`{name}` is a DH entry: with `convention: urdf` a joint has its \
                             origin x, y, z, roll, pitch, yaw"
                        ),
                    );
                }
            }
        } else {
            for (name, s) in j.origin.slots() {
                if *s != Slot::zero() {
                    ck.at_key(
                        &f(name),
                        format!(
                            "`{name}` is part of a joint's origin, which only \
                             `convention: urdf` has"
                        ),
                    );
                }
            }
        }
    }
}
