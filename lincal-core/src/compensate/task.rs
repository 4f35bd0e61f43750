//! The task a solve drives to zero: the error between a target and the tool of a chain at the
//! joint readings `q`, and its exact Jacobian with respect to `q`.
//!
//! With the tool frame `(x(q), R(q))` ([`crate::model::chain::pose_joint_jacobian_prepared`]) and a
//! target `(x*, R*)`, the error is
//!
//! `e(q) = [x* − x(q);  φ(q)]`,  `φ = log(R*·R(q)ᵀ)` (a world rotation vector),
//!
//! the orientation rows present only for a pose target. To first order in a joint step `Δ`,
//! `x(q + Δ) = x(q) + J_x·Δ` and `R(q + Δ) = Exp(J_ω·Δ)·R(q)`, so `e(q + Δ) ≈ e(q) − J·Δ` with
//! `J = [J_x; J_ω]` (the last rows exact at `φ = 0`, where the solve ends). A planar chain
//! (`dim: 2`) has the rows `x, y` only.

use crate::model::chain::{self, Factor, Motion};
use crate::model::rotation;

/// What a target fixes: the tool position (`dim` rows) or its whole pose (6 rows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetKind {
    /// Position only (`x, y(, z)`).
    Position,
    /// Position and orientation.
    Pose,
}

/// One target in the measurement (world) frame: a position, and a rotation (column-major) for
/// a pose target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    /// The tool position (`x, y, z`; `z` unused on a planar chain).
    pub x: [f64; 3],
    /// The tool rotation, column-major, for a pose target.
    pub rot: Option<[f64; 9]>,
}

/// A chain and its parameters, evaluated for the solves: the tool frame and its joint
/// Jacobian at any `q`.
pub struct Arm<'a> {
    /// The chain's factors.
    pub factors: &'a [Factor],
    /// Their motions [`chain::prepare`]d at the parameters' values.
    pub motions: &'a [Motion],
    /// 2 (planar) or 3.
    pub dim: usize,
    /// The joint count.
    pub joints: usize,
}

/// The tool frame of an [`Arm`] at some `q`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tool {
    /// Its origin (world frame).
    pub x: [f64; 3],
    /// Its rotation, column-major.
    pub rot: [f64; 9],
}

impl Arm<'_> {
    /// The rows of the task for `kind`: `dim` for a position, 6 for a pose.
    #[must_use]
    pub fn rows(&self, kind: TargetKind) -> usize {
        match kind {
            TargetKind::Position => self.dim,
            TargetKind::Pose => 6,
        }
    }

    /// The tool frame at `q`.
    #[must_use]
    pub fn tool(&self, q: &[f64]) -> Tool {
        let mut t = Tool::default();
        chain::pose_prepared(self.factors, self.motions, q, &mut t.x, &mut t.rot);
        t
    }

    /// The tool frame at `q`, the error `e` against `goal` (`rows(kind)` values) and, when
    /// `jac` is given, the task Jacobian `J` (`rows × joints`, row-major, `e(q+Δ) ≈ e − J·Δ`).
    /// `scratch` holds `6·joints + joints` values.
    pub fn error(
        &self,
        q: &[f64],
        goal: &Goal,
        kind: TargetKind,
        e: &mut [f64],
        jac: Option<&mut [f64]>,
        scratch: &mut Scratch,
    ) -> Tool {
        let mut t = Tool::default();
        let n = self.joints;
        chain::pose_joint_jacobian_prepared(
            self.factors,
            self.motions,
            q,
            &mut t.x,
            &mut t.rot,
            &mut scratch.jac,
            &mut scratch.twists,
        );
        for ((e, g), x) in e.iter_mut().zip(&goal.x).zip(&t.x).take(self.dim) {
            *e = g - x;
        }
        let pose = kind == TargetKind::Pose;
        if let (true, Some(r)) = (pose, &goal.rot) {
            let phi = rotation_error(r, &t.rot);
            e[3..6].copy_from_slice(&phi);
        }
        if let Some(jac) = jac {
            let rows = self.rows(kind);
            for i in 0..rows {
                // Pose rows are 0-5 of the frame Jacobian; a planar position takes rows 0-1.
                jac[i * n..(i + 1) * n].copy_from_slice(&scratch.jac[i * n..(i + 1) * n]);
            }
        }
        t
    }
}

/// Scratch buffers of [`Arm::error`].
pub struct Scratch {
    jac: Vec<f64>,
    twists: Vec<[f64; 6]>,
}

impl Scratch {
    /// Buffers for a chain of `joints` joints.
    #[must_use]
    pub fn new(joints: usize) -> Self {
        Scratch {
            jac: vec![0.0; 6 * joints],
            twists: vec![[0.0; 6]; joints],
        }
    }
}

/// `φ = log(R*·Rᵀ)`: the world rotation vector that takes `r` onto `target` (both
/// column-major), as `log(M)` with `M = (R·R*ᵀ)ᵀ`, i.e. `−log(R·R*ᵀ)`.
#[must_use]
pub fn rotation_error(target: &[f64; 9], r: &[f64; 9]) -> [f64; 3] {
    // (R·R*ᵀ)_ij = Σ_k R_ik R*_jk; column-major a[3c + i] = A_ic.
    let mut m = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            m[3 * j + i] = (0..3).map(|k| r[3 * k + i] * target[3 * k + j]).sum();
        }
    }
    let v = rotation::rotation_vector(&m);
    [-v[0], -v[1], -v[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_error_takes_the_frame_onto_the_target() {
        let r = rotation::matrix_from_rotation_vector([0.3, -0.2, 0.5]);
        let d = [0.01, 0.02, -0.03];
        // target = Exp(d)·R
        let e = rotation::matrix_from_rotation_vector(d);
        let mut t = [0.0; 9];
        for c in 0..3 {
            for i in 0..3 {
                t[3 * c + i] = (0..3).map(|k| e[3 * k + i] * r[3 * c + k]).sum();
            }
        }
        let phi = rotation_error(&t, &r);
        for k in 0..3 {
            assert!((phi[k] - d[k]).abs() < 1e-14, "{phi:?}");
        }
    }
}
