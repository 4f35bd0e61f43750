//! A spec's chain as the elementary motions of [`crate::model::chain`]: each DH row's
//! rotations and translations, every slot resolved against the estimated parameters (known ones
//! become constants). Run-time models and programs build their [`Chain`] here.

use super::{Base, Convention, Joint, JointKind, RowForm, Slot, Spec};
use crate::model::chain::{Axis, Factor, Term};

/// A spec's chain, resolved against its estimated parameters (known ones become constants).
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    /// The factors, base first.
    pub factors: Vec<Factor>,
    /// Per constraint, per constraint value: the estimated parameter it is, if any.
    pub value_params: Vec<Vec<Option<usize>>>,
}

/// Pushes one factor: rotation or not, axis, signed slots, joint.
type Push<'a> = dyn FnMut(bool, Axis, &[(&Slot, f64)], Option<usize>) + 'a;

/// A slot as `(constant, parameter)`.
fn resolve(spec: &Spec, est: &[&str], slot: &Slot) -> (f64, Option<usize>) {
    match slot {
        Slot::Const(e) => (e.to_f64(), None),
        Slot::Param(name) => match est.iter().position(|n| n == name) {
            Some(j) => (0.0, Some(j)),
            None => (
                spec.param(name).map_or(f64::NAN, |p| p.nominal.to_f64()),
                None,
            ),
        },
    }
}

impl Chain {
    /// The chain of `spec` (see the module docs for the factor order).
    #[must_use]
    pub fn from_spec(spec: &Spec) -> Chain {
        let est: Vec<&str> = spec
            .estimated_params()
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let mut factors = Vec::new();
        // A factor `rotation/axis` of amount `sign·slot + joint`.
        let mut push =
            |rotation: bool, axis: Axis, slots: &[(&Slot, f64)], joint: Option<usize>| {
                let mut constant = 0.0;
                let mut terms = [None, None];
                let mut n = 0;
                for &(s, sign) in slots {
                    let (c, param) = resolve(spec, &est, s);
                    constant += sign * c;
                    if let Some(param) = param {
                        terms[n] = Some(Term { param, coef: sign });
                        n += 1;
                    }
                }
                // Identity motions are dropped (they change nothing and carry no parameter).
                if constant != 0.0 || joint.is_some() || n > 0 {
                    factors.push(Factor {
                        rotation,
                        axis,
                        constant,
                        joint,
                        terms,
                    });
                }
            };
        if let Some(b) = &spec.base {
            push_base(&mut push, b);
        }
        for (i, j) in spec.joints.iter().enumerate() {
            push_joint(&mut push, spec.convention, i, j);
        }
        let axes = [Axis::X, Axis::Y, Axis::Z];
        for (s, &axis) in spec.tool.iter().zip(&axes) {
            push(false, axis, &[(s, 1.0)], None);
        }
        // A tool frame's rotation Rz(yaw)·Ry(pitch)·Rx(roll), after its translation.
        if let Some([roll, pitch, yaw]) = &spec.tool_rotation {
            push(true, Axis::Z, &[(yaw, 1.0)], None);
            push(true, Axis::Y, &[(pitch, 1.0)], None);
            push(true, Axis::X, &[(roll, 1.0)], None);
        }
        let value_params = value_params(spec, &est);
        Chain {
            factors,
            value_params,
        }
    }
}

/// The base's factors: its translation `x`, `y`, `z`, then its rotation yaw (about z), pitch
/// (about y), roll (about x).
fn push_base(push: &mut Push<'_>, b: &Base) {
    push(false, Axis::X, &[(&b.x, 1.0)], None);
    push(false, Axis::Y, &[(&b.y, 1.0)], None);
    push(false, Axis::Z, &[(&b.z, 1.0)], None);
    push(true, Axis::Z, &[(&b.yaw, 1.0)], None);
    push(true, Axis::Y, &[(&b.pitch, 1.0)], None);
    push(true, Axis::X, &[(&b.roll, 1.0)], None);
}

/// The factors of joint `i`, in the order of `convention`: its motion along or about z (the
/// reading with `home`, `d`, or `theta`, `offset`), `a`, `alpha` about x, and Hayati's `beta`
/// about y right after `alpha`; in [`Convention::Urdf`] the joint's origin first (as the
/// base's factors), then the modified-DH row (whose `a`, `alpha`, `beta` are 0).
fn push_joint(push: &mut Push<'_>, convention: Convention, i: usize, j: &Joint) {
    if convention == Convention::Urdf {
        push_base(push, &j.origin);
    }
    let joint_z = |push: &mut Push<'_>| match j.kind {
        JointKind::Revolute => {
            push(true, Axis::Z, &[(&j.home, -1.0)], Some(i));
            push(false, Axis::Z, &[(&j.d, 1.0)], None);
        }
        JointKind::Prismatic => {
            push(true, Axis::Z, &[(&j.theta, 1.0)], None);
            push(false, Axis::Z, &[(&j.offset, 1.0), (&j.d, 1.0)], Some(i));
        }
    };
    match convention.row() {
        RowForm::Dh => {
            joint_z(push);
            push(false, Axis::X, &[(&j.a, 1.0)], None);
            push(true, Axis::X, &[(&j.alpha, 1.0)], None);
            push(true, Axis::Y, &[(&j.beta, 1.0)], None);
        }
        RowForm::Mdh => {
            push(true, Axis::X, &[(&j.alpha, 1.0)], None);
            push(true, Axis::Y, &[(&j.beta, 1.0)], None);
            push(false, Axis::X, &[(&j.a, 1.0)], None);
            joint_z(push);
        }
    }
}

/// Per constraint, per constraint value: the estimated parameter (index into `est`) it is,
/// if any.
fn value_params(spec: &Spec, est: &[&str]) -> Vec<Vec<Option<usize>>> {
    spec.constraints
        .iter()
        .map(|c| {
            c.slots()
                .into_iter()
                .map(|s| resolve(spec, est, s).1)
                .collect()
        })
        .collect()
}
