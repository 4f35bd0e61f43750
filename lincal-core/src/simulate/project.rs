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
            // Singular configuration (or a non-finite Jacobian): the constraint cannot be
            // followed from here.
            let step = min_norm_step(&jac, &r)?;
            let len = step.iter().map(|v| v * v).sum::<f64>().sqrt();
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
        let m = rp.len();
        if let Some(factors) = self.chain {
            return self.chain_jacobian(factors, kind, j, q, (rp, rm));
        }
        central_jacobian(q, m, |q, out| self.residual(kind, j, q, target, out))
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

/// The minimum-norm solution `x` of `J·x = r` for a short, wide `J` (`m × n`, `m ≤ n`), by
/// one-sided Jacobi rotations of its rows (Hestenes): plane rotations `G` from the left make
/// the rows of `B = G·J` orthogonal, so `x = Σᵢ bᵢ (G·r)ᵢ / ‖bᵢ‖²`, and the row norms are
/// `J`'s singular values to high relative accuracy. `None` when `J` or `r` is not finite,
/// or its smallest singular value is below `10⁻⁸` of its largest (the rank test a full SVD
/// made here before, at a fraction of its cost for the `m ≤ 6` rows of a constraint).
fn min_norm_step(jac: &DMatrix<f64>, r: &[f64]) -> Option<Vec<f64>> {
    let (m, n) = jac.shape();
    if m == 0 || m > n || r.len() != m {
        return None;
    }
    let mut b = vec![0.0; m * n];
    for ((i, k), v) in (0..m)
        .flat_map(|i| (0..n).map(move |k| (i, k)))
        .zip(b.iter_mut())
    {
        *v = jac[(i, k)];
    }
    let mut y = r.to_vec();
    if b.iter().chain(&y).any(|v| !v.is_finite()) {
        return None;
    }
    let dot = |b: &[f64], i: usize, k: usize| -> f64 {
        (0..n).map(|t| b[i * n + t] * b[k * n + t]).sum()
    };
    let mut orthogonal = false;
    for _sweep in 0..60 {
        let mut rotated = false;
        for i in 0..m {
            for k in i + 1..m {
                let (a, c, g) = (dot(&b, i, i), dot(&b, k, k), dot(&b, i, k));
                if g == 0.0 || g.abs() <= f64::EPSILON * a.sqrt() * c.sqrt() {
                    continue;
                }
                rotated = true;
                let zeta = (c - a) / (2.0 * g);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let cs = 1.0 / (1.0 + t * t).sqrt();
                let sn = cs * t;
                for u in 0..n {
                    let (bi, bk) = (b[i * n + u], b[k * n + u]);
                    b[i * n + u] = cs * bi - sn * bk;
                    b[k * n + u] = sn * bi + cs * bk;
                }
                let (yi, yk) = (y[i], y[k]);
                y[i] = cs * yi - sn * yk;
                y[k] = sn * yi + cs * yk;
            }
        }
        if !rotated {
            orthogonal = true;
            break;
        }
    }
    if !orthogonal {
        return None; // not converged (never seen): no step rather than a wrong one
    }
    let norms: Vec<f64> = (0..m).map(|i| dot(&b, i, i)).collect();
    let smax = norms.iter().copied().fold(0.0, f64::max).sqrt();
    let smin = norms.iter().copied().fold(f64::INFINITY, f64::min).sqrt();
    if !(smax > 0.0 && smax.is_finite() && smin >= 1e-8 * smax) {
        return None;
    }
    let mut x = vec![0.0; n];
    for i in 0..m {
        let f = y[i] / norms[i];
        for (xu, bu) in x.iter_mut().zip(&b[i * n..(i + 1) * n]) {
            *xu += f * bu;
        }
    }
    Some(x)
}

#[cfg(test)]
mod min_norm_tests {
    use super::*;

    /// The Jacobi step against the normal equations' `x = Jᵀ(JJᵀ)⁻¹r` on random short, wide
    /// matrices (rows of very different scale, as metres and radians give), and the rank
    /// test on matrices made rank-deficient. (nalgebra's SVD is not the reference: on some
    /// of these its solution leaves residuals of 10⁻⁵ where this one leaves 10⁻¹⁴.)
    #[test]
    fn min_norm_step_agrees_with_the_normal_equations() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..500 {
            let m = 1 + trial % 3;
            let n = m + trial % 5;
            let mut j = DMatrix::from_fn(m, n, |_, _| rng.gen_range(-1.0..1.0));
            for c in 0..n {
                j[(0, c)] *= 1e3;
            }
            let r = nalgebra::DVector::from_fn(m, |_, _| rng.gen_range(-1.0..1.0));
            let sv = j.singular_values();
            let cond = sv.max() / sv.min();
            let want = j.transpose() * (&j * j.transpose()).lu().solve(&r).unwrap();
            let got = min_norm_step(&j, r.as_slice()).unwrap();
            let err = want
                .iter()
                .zip(&got)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // The normal equations lose cond² digits; the Jacobi step is backward stable.
            assert!(
                err <= 1e-14 * cond * cond * want.norm(),
                "trial {trial}: {err:e}, cond {cond:e}"
            );
            let res = (&j * nalgebra::DVector::from_column_slice(&got) - &r).amax();
            assert!(
                res <= 1e-13 * (j.amax() * want.norm() + r.amax()),
                "trial {trial}: residual {res:e}"
            );
            if m >= 2 {
                // The last row a multiple of the first: rank m − 1, refused.
                let mut d = j.clone();
                for c in 0..n {
                    d[(m - 1, c)] = 0.5 * j[(0, c)];
                }
                assert!(
                    min_norm_step(&d, r.as_slice()).is_none(),
                    "trial {trial}: rank-deficient"
                );
            }
        }
        let nan = DMatrix::from_element(2, 3, f64::NAN);
        assert!(min_norm_step(&nan, &[1.0, 2.0]).is_none());
    }
}
