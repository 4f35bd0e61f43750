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

/// Which slot of the spec a factor's amount reads: the derive's certificate
/// (`symbolic::certify`) maps each to the expansion's own slot polynomials.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SlotKey {
    /// The base's `x, y, z, roll, pitch, yaw` (`0..6`).
    Base(usize),
    /// Joint `i`'s origin in [`Convention::Urdf`], the same six.
    Origin(usize, usize),
    /// Joint `i`'s `home` (revolute).
    Home(usize),
    /// Joint `i`'s fixed `theta` (prismatic).
    Theta(usize),
    /// Joint `i`'s `offset` (prismatic).
    Offset(usize),
    /// Joint `i`'s `d`.
    D(usize),
    /// Joint `i`'s `a`.
    A(usize),
    /// Joint `i`'s `alpha`.
    Alpha(usize),
    /// Joint `i`'s Hayati tilt `beta`.
    Beta(usize),
    /// The tool vector's coordinate `k`.
    Tool(usize),
    /// The tool frame's roll, pitch, yaw (`0..3`).
    ToolRotation(usize),
}

/// Pushes one factor: rotation or not, axis, signed slots (each with its key), joint.
type Push<'a> = dyn FnMut(bool, Axis, &[(&Slot, f64, SlotKey)], Option<usize>) + 'a;

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
        Self::keyed(spec).0
    }

    /// The chain of `spec`, and for each factor the signed slots its amount sums
    /// (`amount = q[joint] + Σ sign·slot`).
    pub(crate) fn keyed(spec: &Spec) -> (Chain, Vec<Vec<(SlotKey, f64)>>) {
        let est: Vec<&str> = spec
            .estimated_params()
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let mut factors = Vec::new();
        let mut keys = Vec::new();
        // A factor `rotation/axis` of amount `sign·slot + joint`.
        let mut push =
            |rotation: bool, axis: Axis, slots: &[(&Slot, f64, SlotKey)], joint: Option<usize>| {
                let mut constant = 0.0;
                let mut terms = [None, None];
                let mut n = 0;
                for &(s, sign, _) in slots {
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
                    keys.push(slots.iter().map(|&(_, sign, k)| (k, sign)).collect());
                }
            };
        if let Some(b) = &spec.base {
            push_base(&mut push, b, SlotKey::Base);
        }
        for (i, j) in spec.joints.iter().enumerate() {
            push_joint(&mut push, spec.convention, i, j);
        }
        let axes = [Axis::X, Axis::Y, Axis::Z];
        for (k, (s, &axis)) in spec.tool.iter().zip(&axes).enumerate() {
            push(false, axis, &[(s, 1.0, SlotKey::Tool(k))], None);
        }
        // A tool frame's rotation Rz(yaw)·Ry(pitch)·Rx(roll), after its translation.
        if let Some([roll, pitch, yaw]) = &spec.tool_rotation {
            let r = SlotKey::ToolRotation;
            push(true, Axis::Z, &[(yaw, 1.0, r(2))], None);
            push(true, Axis::Y, &[(pitch, 1.0, r(1))], None);
            push(true, Axis::X, &[(roll, 1.0, r(0))], None);
        }
        let value_params = value_params(spec, &est);
        let chain = Chain {
            factors,
            value_params,
        };
        (chain, keys)
    }
}

/// The base's factors: its translation `x`, `y`, `z`, then its rotation yaw (about z), pitch
/// (about y), roll (about x).
/// `key(k)` names slot `k` of `x, y, z, roll, pitch, yaw`.
fn push_base(push: &mut Push<'_>, b: &Base, key: impl Fn(usize) -> SlotKey) {
    push(false, Axis::X, &[(&b.x, 1.0, key(0))], None);
    push(false, Axis::Y, &[(&b.y, 1.0, key(1))], None);
    push(false, Axis::Z, &[(&b.z, 1.0, key(2))], None);
    push(true, Axis::Z, &[(&b.yaw, 1.0, key(5))], None);
    push(true, Axis::Y, &[(&b.pitch, 1.0, key(4))], None);
    push(true, Axis::X, &[(&b.roll, 1.0, key(3))], None);
}

/// The factors of joint `i`, in the order of `convention`: its motion along or about z (the
/// reading with `home`, `d`, or `theta`, `offset`), `a`, `alpha` about x, and Hayati's `beta`
/// about y right after `alpha`; in [`Convention::Urdf`] the joint's origin first (as the
/// base's factors), then the modified-DH row (whose `a`, `alpha`, `beta` are 0).
fn push_joint(push: &mut Push<'_>, convention: Convention, i: usize, j: &Joint) {
    use SlotKey as K;
    if convention == Convention::Urdf {
        push_base(push, &j.origin, |k| K::Origin(i, k));
    }
    let joint_z = |push: &mut Push<'_>| match j.kind {
        JointKind::Revolute => {
            push(true, Axis::Z, &[(&j.home, -1.0, K::Home(i))], Some(i));
            push(false, Axis::Z, &[(&j.d, 1.0, K::D(i))], None);
        }
        JointKind::Prismatic => {
            push(true, Axis::Z, &[(&j.theta, 1.0, K::Theta(i))], None);
            let slots = [(&j.offset, 1.0, K::Offset(i)), (&j.d, 1.0, K::D(i))];
            push(false, Axis::Z, &slots, Some(i));
        }
    };
    match convention.row() {
        RowForm::Dh => {
            joint_z(push);
            push(false, Axis::X, &[(&j.a, 1.0, K::A(i))], None);
            push(true, Axis::X, &[(&j.alpha, 1.0, K::Alpha(i))], None);
            push(true, Axis::Y, &[(&j.beta, 1.0, K::Beta(i))], None);
        }
        RowForm::Mdh => {
            push(true, Axis::X, &[(&j.alpha, 1.0, K::Alpha(i))], None);
            push(true, Axis::Y, &[(&j.beta, 1.0, K::Beta(i))], None);
            push(false, Axis::X, &[(&j.a, 1.0, K::A(i))], None);
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
