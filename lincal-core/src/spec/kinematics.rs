//! Numeric forward kinematics straight from the spec, in `f64`.
//!
//! Independent of the symbolic expansion on purpose: tests compare the two, and the run-time
//! model uses this for `tip(q, p)`.

use crate::spec::{Convention, JointKind, RowForm, Slot, Spec};

/// Largest magnitude of a predicted coordinate (in the spec's length unit) that the tools
/// return (`lincal predict`, Python's `Spec.tip`): beyond it the parameters are not a
/// robot's, and the output would be `inf` or meaningless digits.
pub const MAX_PREDICTED: f64 = 1e9;

/// A slot resolved for evaluation: a constant or an index into the estimated parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlotRef {
    /// A fixed value.
    Const(f64),
    /// Estimated parameter `j` of `p`.
    Param(usize),
}

impl SlotRef {
    /// Resolves a slot against the spec (known parameters become their nominal).
    #[must_use]
    pub fn resolve(spec: &Spec, slot: &Slot) -> SlotRef {
        match slot {
            Slot::Const(e) => SlotRef::Const(e.to_f64()),
            Slot::Param(name) => {
                let est = spec.estimated_params();
                match est.iter().position(|p| &p.name == name) {
                    Some(j) => SlotRef::Param(j),
                    None => {
                        SlotRef::Const(spec.param(name).map_or(f64::NAN, |p| p.nominal.to_f64()))
                    }
                }
            }
        }
    }

    /// The value for parameters `p`.
    #[must_use]
    #[inline]
    pub fn value(self, p: &[f64]) -> f64 {
        match self {
            SlotRef::Const(v) => v,
            SlotRef::Param(j) => p[j],
        }
    }
}

#[derive(Clone, Debug)]
struct JointNum {
    prismatic: bool,
    a: SlotRef,
    alpha: SlotRef,
    beta: SlotRef,
    d: SlotRef,
    home: SlotRef,
    theta: SlotRef,
    offset: SlotRef,
    /// The origin's `x, y, z, roll, pitch, yaw` ([`crate::spec::Joint::origin`]).
    origin: [SlotRef; 6],
}

/// Forward kinematics of a spec, ready to evaluate.
#[derive(Clone, Debug)]
pub struct Kinematics {
    convention: Convention,
    dim: usize,
    joints: Vec<JointNum>,
    tool: [SlotRef; 3],
    base: Option<[SlotRef; 6]>,
}

type M4 = [[f64; 4]; 4];

fn matmul(a: &M4, b: &M4) -> M4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            r[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

fn rz(t: f64) -> M4 {
    let (s, c) = t.sin_cos();
    [
        [c, -s, 0.0, 0.0],
        [s, c, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn rx(t: f64) -> M4 {
    let (s, c) = t.sin_cos();
    [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, c, -s, 0.0],
        [0.0, s, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn ry(t: f64) -> M4 {
    let (s, c) = t.sin_cos();
    [
        [c, 0.0, s, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [-s, 0.0, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn tr(x: f64, y: f64, z: f64) -> M4 {
    [
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, y],
        [0.0, 0.0, 1.0, z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// A frame's slots `x, y, z, roll, pitch, yaw`, resolved.
fn frame_refs(spec: &Spec, b: &crate::spec::Base) -> [SlotRef; 6] {
    b.slots().map(|(_, s)| SlotRef::resolve(spec, s))
}

/// `Tr(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)` at `p`.
fn frame(v: &[SlotRef; 6], p: &[f64]) -> M4 {
    let v = v.map(|s| s.value(p));
    matmul(
        &matmul(&matmul(&tr(v[0], v[1], v[2]), &rz(v[5])), &ry(v[4])),
        &rx(v[3]),
    )
}

impl Kinematics {
    /// Prepares the spec's chain for evaluation.
    #[must_use]
    pub fn new(spec: &Spec) -> Self {
        let r = |s: &Slot| SlotRef::resolve(spec, s);
        let joints = spec
            .joints
            .iter()
            .map(|j| JointNum {
                prismatic: j.kind == JointKind::Prismatic,
                a: r(&j.a),
                alpha: r(&j.alpha),
                beta: r(&j.beta),
                d: r(&j.d),
                home: r(&j.home),
                theta: r(&j.theta),
                offset: r(&j.offset),
                origin: frame_refs(spec, &j.origin),
            })
            .collect();
        let mut tool = [SlotRef::Const(0.0); 3];
        for (i, s) in spec.tool.iter().enumerate().take(3) {
            tool[i] = r(s);
        }
        let base = spec.base.as_ref().map(|b| frame_refs(spec, b));
        Kinematics {
            convention: spec.convention,
            dim: spec.dim,
            joints,
            tool,
            base,
        }
    }

    /// The tip `x(q; p)` (`dim` values) by multiplying the DH matrices numerically.
    pub fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
        let mut t: M4 = match &self.base {
            Some(b) => frame(b, p),
            None => tr(0.0, 0.0, 0.0),
        };
        for (j, qi) in self.joints.iter().zip(q) {
            if self.convention == Convention::Urdf {
                t = matmul(&t, &frame(&j.origin, p));
            }
            let (theta, d) = if j.prismatic {
                (j.theta.value(p), qi + j.offset.value(p) + j.d.value(p))
            } else {
                (qi - j.home.value(p), j.d.value(p))
            };
            let (a, alpha, beta) = (j.a.value(p), j.alpha.value(p), j.beta.value(p));
            let link = match self.convention.row() {
                RowForm::Dh => matmul(
                    &matmul(
                        &matmul(&matmul(&rz(theta), &tr(0.0, 0.0, d)), &tr(a, 0.0, 0.0)),
                        &rx(alpha),
                    ),
                    &ry(beta),
                ),
                RowForm::Mdh => matmul(
                    &matmul(
                        &matmul(&matmul(&rx(alpha), &ry(beta)), &tr(a, 0.0, 0.0)),
                        &rz(theta),
                    ),
                    &tr(0.0, 0.0, d),
                ),
            };
            t = matmul(&t, &link);
        }
        let tool = [
            self.tool[0].value(p),
            self.tool[1].value(p),
            self.tool[2].value(p),
        ];
        for (i, o) in out.iter_mut().enumerate().take(self.dim) {
            *o = t[i][0] * tool[0] + t[i][1] * tool[1] + t[i][2] * tool[2] + t[i][3];
        }
    }
}
