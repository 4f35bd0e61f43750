//! Newton projection of joint readings onto a constraint (step 2 of the method in the
//! [module docs](super)).
//!
//! Takes the model and its true parameters; gives uniform draws of the joint readings
//! inside their ranges, and those readings moved onto a constraint (at a target offset), or
//! nothing when the projection fails.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::model::chain::{self, Factor};
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
    /// The model's chain of elementary motions when it reproduces the model's tip (then
    /// `∂x/∂q` is exact, [`chain::tip_joint_jacobian`]); `None`: central differences.
    chain: Option<&'a [Factor]>,
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
        let ranges: Vec<[f64; 2]> = (0..nj)
            .map(|i| limits[i].unwrap_or_else(|| default_joint_range(model.joint_is_prismatic(i))))
            .collect();
        let chain = exact_chain(model, p, &ranges);
        Projector {
            model,
            p,
            dim,
            values,
            ranges,
            limited: limits.iter().map(Option::is_some).collect(),
            chain,
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
        let mut rp = vec![0.0; m];
        let mut rm = vec![0.0; m];
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
            let jac = self.jacobian(kind, j, &mut q, target, (&mut rp, &mut rm));
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

    /// `J = ∂r/∂q` of constraint `j` at `q`: `(∂r/∂x)(∂x/∂q)` with the chain's exact
    /// `∂x/∂q` when there is one, else central differences of the whole residual (`q` is
    /// restored; `rp` and `rm` are scratch space of the residual's length).
    fn jacobian(
        &self,
        kind: ConstraintKind,
        j: usize,
        q: &mut [f64],
        target: &[f64],
        (rp, rm): (&mut [f64], &mut [f64]),
    ) -> DMatrix<f64> {
        let (m, n) = (rp.len(), q.len());
        if let Some(factors) = self.chain {
            return self.chain_jacobian(factors, kind, j, q, (rp, rm));
        }
        let mut jac = DMatrix::<f64>::zeros(m, n);
        for i in 0..n {
            let h = 1e-6 * q[i].abs().max(1.0);
            let keep = q[i];
            q[i] = keep + h;
            self.residual(kind, j, q, target, rp);
            q[i] = keep - h;
            self.residual(kind, j, q, target, rm);
            q[i] = keep;
            for e in 0..m {
                jac[(e, i)] = (rp[e] - rm[e]) / (2.0 * h);
            }
        }
        jac
    }

    /// `(∂r/∂x)(∂x/∂q)`: `∂x/∂q` exact from the chain, `∂r/∂x` by central differences of
    /// the geometric residual in the tip (no kinematics; the residuals are smooth in `x`).
    fn chain_jacobian(
        &self,
        factors: &[Factor],
        kind: ConstraintKind,
        j: usize,
        q: &[f64],
        (rp, rm): (&mut [f64], &mut [f64]),
    ) -> DMatrix<f64> {
        let (m, n, dim) = (rp.len(), q.len(), self.dim);
        let (mut x, mut dxdq) = ([0.0; 3], vec![0.0; dim * n]);
        let mut twists = vec![[0.0; 6]; n];
        chain::tip_joint_jacobian(factors, dim, q, self.p, &mut x, &mut dxdq, &mut twists);
        let mut drdx = [[0.0; 3]; 6];
        for c in 0..dim {
            let h = 1e-6 * x[c].abs().max(1.0);
            let (mut xp, mut xm) = (x, x);
            xp[c] += h;
            xm[c] -= h;
            let v = &self.values[j];
            geometry::geometric_residual(kind, dim, v, &xp[..dim], &[], rp);
            geometry::geometric_residual(kind, dim, v, &xm[..dim], &[], rm);
            for e in 0..m {
                drdx[e][c] = (rp[e] - rm[e]) / (2.0 * h);
            }
        }
        DMatrix::from_fn(m, n, |e, i| {
            (0..dim).map(|c| drdx[e][c] * dxdq[c * n + i]).sum::<f64>()
        })
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

/// The model's chain when it reproduces the model's tip (to `1e-9` relative, at the middle
/// and a corner of the joint ranges) and names only the model's joints; `None` otherwise
/// (a model without a chain table), which leaves the projector to central differences.
fn exact_chain<'a>(
    model: &'a dyn CalibModel,
    p: &[f64],
    ranges: &[[f64; 2]],
) -> Option<&'a [Factor]> {
    let factors = model.chain();
    let nj = ranges.len();
    let dim = model.dim();
    if factors.is_empty() || dim > 3 || factors.iter().any(|f| f.joint.is_some_and(|k| k >= nj)) {
        return None;
    }
    let probes = [
        ranges
            .iter()
            .map(|r| 0.5 * (r[0] + r[1]))
            .collect::<Vec<_>>(),
        ranges.iter().map(|r| 0.3 * r[0] + 0.7 * r[1]).collect(),
    ];
    for q in &probes {
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        model.tip(q, p, &mut a[..dim]);
        chain::tip(factors, dim, q, p, &mut b[..dim]);
        let scale = 1.0 + a.iter().map(|v| v.abs()).sum::<f64>();
        if a.iter()
            .zip(&b)
            .any(|(u, v)| (u - v).abs().is_nan() || (u - v).abs() > 1e-9 * scale)
        {
            return None;
        }
    }
    Some(factors)
}
