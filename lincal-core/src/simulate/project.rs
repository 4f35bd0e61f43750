//! Newton projection of joint readings onto a constraint (step 2 of the method in the
//! [module docs](super)).
//!
//! Takes the model and its true parameters; gives uniform draws of the joint readings
//! inside their ranges, and those readings moved onto a constraint (at a target offset), or
//! nothing when the projection fails.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;

/// Default sampling range of a joint without limits.
#[must_use]
pub fn default_joint_range(prismatic: bool) -> [f64; 2] {
    if prismatic {
        [0.0, 0.5]
    } else {
        [-std::f64::consts::PI, std::f64::consts::PI]
    }
}

/// Newton projection of one pose; see the module docs.
pub(crate) struct Projector<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    dim: usize,
    values: Vec<Vec<f64>>,
    ranges: Vec<[f64; 2]>,
    limited: Vec<bool>,
}

impl<'a> Projector<'a> {
    /// The projector of `model` with true parameters `p`: the constraints' values and the
    /// joints' sampling ranges.
    pub(crate) fn new(model: &'a dyn CalibModel, p: &'a [f64]) -> Self {
        let dim = model.dim();
        let nj = model.joint_count();
        let values = (0..model.constraint_count())
            .map(|j| {
                let mut v = vec![0.0; model.constraint_kind(j).value_count(dim)];
                model.constraint_values(j, p, &mut v);
                v
            })
            .collect();
        let limits: Vec<Option<[f64; 2]>> = (0..nj).map(|i| model.joint_limits(i)).collect();
        Projector {
            model,
            p,
            dim,
            values,
            ranges: (0..nj)
                .map(|i| {
                    limits[i].unwrap_or_else(|| default_joint_range(model.joint_is_prismatic(i)))
                })
                .collect(),
            limited: limits.iter().map(Option::is_some).collect(),
        }
    }

    /// A uniform draw of the joint readings inside the ranges.
    pub(crate) fn draw(&self, rng: &mut ChaCha8Rng) -> Vec<f64> {
        self.ranges
            .iter()
            .map(|&[lo, hi]| lo + (hi - lo) * rng.gen::<f64>())
            .collect()
    }

    /// Whether every constraint can be reached: at least 3 of 100 trial projections land.
    pub(crate) fn crosses_workspace(&self, seed: u64) -> bool {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(3);
        (0..self.model.constraint_count()).all(|j| {
            let kind = self.model.constraint_kind(j);
            if kind.is_measured() {
                return true;
            }
            let zero = vec![0.0; kind.residual_count(self.dim)];
            let mut hits = 0;
            for _ in 0..100 {
                let q0 = self.draw(&mut rng);
                if self.project(j, q0, &zero).is_some() {
                    hits += 1;
                    if hits >= 3 {
                        return true;
                    }
                }
            }
            false
        })
    }

    /// The geometric residual of constraint `j` at `q`, minus `target`, into `out`.
    fn residual(&self, kind: ConstraintKind, j: usize, q: &[f64], target: &[f64], out: &mut [f64]) {
        let mut tip = [0.0; 3];
        self.model.tip(q, self.p, &mut tip[..self.dim]);
        geometry::geometric_residual(kind, self.dim, &self.values[j], &tip[..self.dim], &[], out);
        for (o, t) in out.iter_mut().zip(target) {
            *o -= t;
        }
    }

    /// Projects `q` onto constraint `j` at offset `target`; `None` when it fails.
    pub(crate) fn project(&self, j: usize, mut q: Vec<f64>, target: &[f64]) -> Option<Vec<f64>> {
        let kind = self.model.constraint_kind(j);
        let m = kind.residual_count(self.dim);
        let n = q.len();
        let mut r = vec![0.0; m];
        let mut converged = false;
        let mut extra = 0;
        for _ in 0..80 {
            self.residual(kind, j, &q, target, &mut r);
            let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return None;
            }
            if norm <= 1e-12 {
                converged = true;
                // One or two more steps polish the pose to rounding level.
                extra += 1;
                if norm <= 1e-15 || extra > 2 {
                    break;
                }
            }
            let jac = self.jacobian(kind, j, &mut q, target);
            let Ok(svd) = crate::numeric::linalg::checked_svd(jac.clone(), true, true) else {
                return None; // not finite: no step from here
            };
            let smax = svd.singular_values.max();
            if smax.is_nan()
                || smax <= 0.0
                || svd.singular_values.min() < 1e-8 * smax
                || svd.rank(1e-8 * smax) < m
            {
                // Singular configuration: the constraint cannot be followed from here.
                return None;
            }
            let rv = nalgebra::DVector::from_column_slice(&r);
            let step = svd.solve(&rv, 1e-8 * smax).ok()?;
            let len = step.norm();
            let scale = if len > 0.5 { 0.5 / len } else { 1.0 };
            for i in 0..n {
                q[i] -= scale * step[i];
            }
        }
        if !converged {
            return None;
        }
        self.inside_limits(q)
    }

    /// `J = ∂r/∂q` of constraint `j` at `q` by central differences ([`central_jacobian`];
    /// `q` is restored).
    fn jacobian(
        &self,
        kind: ConstraintKind,
        j: usize,
        q: &mut [f64],
        target: &[f64],
    ) -> DMatrix<f64> {
        let m = kind.residual_count(self.dim);
        central_jacobian(q, m, |q, out| self.residual(kind, j, q, target, out))
    }

    /// A projected pose checked against the joint limits (`None` when outside), its angles
    /// without limits wrapped to `(−π, π]`.
    fn inside_limits(&self, mut q: Vec<f64>) -> Option<Vec<f64>> {
        for (i, qi) in q.iter_mut().enumerate() {
            if self.limited[i] {
                let [lo, hi] = self.ranges[i];
                if *qi < lo || *qi > hi {
                    return None;
                }
            } else if !self.model.joint_is_prismatic(i) {
                *qi = crate::numeric::wrap_angle(*qi);
            }
        }
        Some(q)
    }
}

/// `∂f/∂q` of an `m`-valued function `f(q, out)` at `q` by central differences, step
/// `h_i = 10⁻⁶·max(|q_i|, 1)` per reading: `(f(q + h_i e_i) − f(q − h_i e_i))/(2h_i)`, exact
/// to `O(h²)` (about `10⁻¹²` relative) plus rounding `ε·|f|/h`. `q` is restored. The
/// projector's Newton steps and pose selection's encoder noise (`∂g/∂q`) use it.
pub(crate) fn central_jacobian(
    q: &mut [f64],
    m: usize,
    mut f: impl FnMut(&[f64], &mut [f64]),
) -> DMatrix<f64> {
    let n = q.len();
    let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
    let mut jac = DMatrix::<f64>::zeros(m, n);
    for i in 0..n {
        let h = 1e-6 * q[i].abs().max(1.0);
        let keep = q[i];
        q[i] = keep + h;
        f(q, &mut rp);
        q[i] = keep - h;
        f(q, &mut rm);
        q[i] = keep;
        for e in 0..m {
            jac[(e, i)] = (rp[e] - rm[e]) / (2.0 * h);
        }
    }
    jac
}
