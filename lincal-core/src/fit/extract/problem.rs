//! The c-space least squares: the algebraic cost `Σ_j Σ_e ‖R_j·c_e(p)‖²` over the free
//! parameters (plain or scale-invariant), its streamed linearisation, and how near the
//! fitted `c_e(p)` comes to the data's null space ([`fit_ratio`]).
//!
//! Takes the model and the linear solve's factors `R_j`; gives an [`AlgebraicProblem`] for
//! the shared Levenberg-Marquardt core and the acceptance ratio of a fit.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::fit::solve::{GroupSolve, LinearSolve};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::numeric::linalg::StreamingQr;
use crate::numeric::lm::{FreeSet, LeastSquares, Linearization};

/// Which algebraic cost a problem minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Cost {
    /// `Σ ‖R_j c_e(p)‖²`.
    Plain,
    /// The scale-invariant cost (see [`AlgebraicProblem`]).
    Normalized,
}

/// The algebraic problem over the free parameters.
///
/// With [`Cost::Normalized`], each equation of a constraint that is not measured contributes
/// `R_j c_e(p) / ‖D_j c_e(p)‖` instead of `R_j c_e(p)`: a scale-invariant cost (the
/// Rayleigh quotient of the scaled data matrix) with no minimum at `c_e(p) → 0`. Some
/// mechanisms can satisfy a constraint identically (`c_e(p) = 0`: a collapsed link keeping
/// the tip on a sphere, say), which is an exact zero of the plain cost; the normalised cost is
/// used first to find the right basin, the plain one then polishes within it.
pub(super) struct AlgebraicProblem<'a> {
    pub(super) model: &'a dyn CalibModel,
    pub(super) lin: &'a LinearSolve,
    pub(super) set: FreeSet,
    cost: Cost,
    scales: Vec<Vec<f64>>,
    /// The weight of the relations' rows (see [`crate::fit::relation`]); 0 without relations.
    relation_weight: f64,
    /// Where the weight was taken (the nominals).
    weighed: Vec<f64>,
}

impl<'a> AlgebraicProblem<'a> {
    pub(super) fn new(
        model: &'a dyn CalibModel,
        lin: &'a LinearSolve,
        nominal: &[f64],
        cost: Cost,
    ) -> Self {
        AlgebraicProblem {
            model,
            lin,
            set: FreeSet::new(model, nominal),
            cost,
            scales: lin.groups.iter().map(GroupSolve::scale).collect(),
            relation_weight: 0.0,
            weighed: nominal.to_vec(),
        }
        .weighed_at(nominal)
    }

    /// The same problem (same free set) with the other cost.
    pub(super) fn with_cost(&self, cost: Cost) -> Self {
        AlgebraicProblem {
            model: self.model,
            lin: self.lin,
            set: self.set.clone(),
            cost,
            scales: self.scales.clone(),
            relation_weight: 0.0,
            weighed: self.weighed.clone(),
        }
        .weighed_at(&self.weighed)
    }

    /// The problem with its relation weight taken from the data's Jacobian at `p` (the
    /// relations make the fit in `c`-space a constrained one; see [`crate::fit::relation`]).
    fn weighed_at(mut self, p: &[f64]) -> Self {
        if !self.model.relations().is_empty() && p.len() == self.model.param_count() {
            let x = self.set.take(p);
            if let Ok(lin) = self.linearize(&x) {
                let diag: Vec<f64> = lin.r.column_iter().map(|c| c.norm_squared()).collect();
                self.relation_weight = crate::fit::relation::weight(&diag);
            }
        }
        self
    }

    /// `v_e = c_e` (length `cols`), with `−1` at `K + i` for coordinate `i` of a measured tip.
    fn residual_vector(&self, c: &[f64], g: usize, i: usize) -> DVector<f64> {
        let k = self.lin.basis_size;
        let group = &self.lin.groups[g];
        let e = group.equations[i];
        let mut v = DVector::zeros(group.cols);
        for kk in 0..k {
            v[kk] = c[e * k + kk];
        }
        if group.kind.is_measured() {
            v[k + i] = -1.0;
        }
        v
    }

    /// `‖D_j v_e‖` over the basis part when normalising this group, else `None`.
    fn norm_of(&self, g: usize, v: &DVector<f64>) -> Option<f64> {
        let group = &self.lin.groups[g];
        if self.cost == Cost::Plain || group.kind.is_measured() {
            return None;
        }
        let k = self.lin.basis_size;
        Some(
            (0..k)
                .map(|kk| (v[kk] * self.scales[g][kk]).powi(2))
                .sum::<f64>()
                .sqrt(),
        )
    }

    pub(super) fn gen(&self, p: &[f64]) -> Vec<f64> {
        let mut c = vec![0.0; self.model.equation_count() * self.lin.basis_size];
        self.model.generalized_params(p, &mut c);
        c
    }
}

impl LeastSquares for AlgebraicProblem<'_> {
    fn unknowns(&self) -> usize {
        self.set.free.len()
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let p = self.set.full(x);
        let c = self.gen(&p);
        let mut cost = crate::fit::relation::cost(self.model, &p, self.relation_weight);
        for (g, group) in self.lin.groups.iter().enumerate() {
            if group.poses == 0 {
                continue;
            }
            for i in 0..group.equations.len() {
                let v = self.residual_vector(&c, g, i);
                let r2 = (&group.r * &v).norm_squared();
                cost += match self.norm_of(g, &v) {
                    Some(nv) => r2 / (nv * nv),
                    None => r2,
                };
            }
        }
        if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        }
    }

    fn linearize(&self, x: &[f64]) -> Result<Linearization> {
        let n = self.unknowns();
        let k = self.lin.basis_size;
        let np = self.model.param_count();
        let p = self.set.full(x);
        let c = self.gen(&p);
        let mut jac = vec![0.0; self.model.equation_count() * k * np];
        self.model.jacobian(&p, &mut jac);
        if jac.iter().chain(&c).any(|v| !v.is_finite()) {
            return Err(Error::other(
                "the generalized parameters or their Jacobian are not finite",
            ));
        }
        let mut qr = StreamingQr::new(n + 1);
        let mut cost = 0.0;
        let mut row = vec![0.0; n + 1];
        for (g, group) in self.lin.groups.iter().enumerate() {
            if group.poses == 0 {
                continue;
            }
            for (i, &e) in group.equations.iter().enumerate() {
                let v = self.residual_vector(&c, g, i);
                let mut r = &group.r * &v;
                let mut jc = DMatrix::zeros(group.cols, n);
                for kk in 0..k {
                    for (col, &j) in self.set.free.iter().enumerate() {
                        jc[(kk, col)] = jac[(e * k + kk) * np + j];
                    }
                }
                let mut rj = &group.r * &jc;
                if let Some(nv) = self.norm_of(g, &v) {
                    if nv == 0.0 {
                        return Err(Error::other("an equation vanishes identically"));
                    }
                    // d(R v / ‖Dv‖) = R dv / ‖Dv‖ − R v (vᵀD² dv) / ‖Dv‖³
                    let mut w = DVector::zeros(n);
                    for col in 0..n {
                        w[col] = (0..k)
                            .map(|kk| v[kk] * self.scales[g][kk].powi(2) * jc[(kk, col)])
                            .sum::<f64>();
                    }
                    rj = rj / nv - (&r * w.transpose()) / (nv * nv * nv);
                    r /= nv;
                }
                for a in 0..group.cols {
                    for col in 0..n {
                        row[col] = rj[(a, col)];
                    }
                    row[n] = r[a];
                    qr.push_row(&row);
                }
                cost += r.norm_squared();
            }
        }
        if self.relation_weight > 0.0 {
            self.push_relation_rows(&p, &mut qr, &mut row, &mut cost);
        }
        Ok(Linearization::from_qr(&mut qr, cost))
    }
}

impl AlgebraicProblem<'_> {
    /// Pushes the relations' rows `[w ∂R/∂p_F | w R]` at `p` into `qr` (through the scratch
    /// `row`, `n + 1` long), adding their squared residuals to `cost`.
    fn push_relation_rows(&self, p: &[f64], qr: &mut StreamingQr, row: &mut [f64], cost: &mut f64) {
        let n = row.len() - 1;
        let w = self.relation_weight;
        for rel in crate::fit::relation::rows(self.model, p) {
            row.iter_mut().for_each(|x| *x = 0.0);
            for (param, d) in &rel.gradient {
                if let Some(pos) = self.set.free.iter().position(|f| f == param) {
                    row[pos] += w * d;
                }
            }
            row[n] = w * rel.residual;
            qr.push_row(row);
            *cost += row[n] * row[n];
        }
    }
}

/// The residual of a measured rotation entry's regression (a `measured_pose`'s equations
/// after the three coordinates), relative to the entry's own norm over the poses, below which
/// [`fit_ratio`] takes a fit as good whatever the linear solve reached: 10⁻⁶ rad, under any
/// real sensor's noise (a coordinate's floor stays 10⁻¹⁰: it depends on the frame's origin).
pub const MEASURED_FLOOR: f64 = 1e-6;

/// The largest ratio of the fitted `c_e(p)`'s residual to what the linear solve reached (see
/// the module docs); `≤ 1` is a good fit. `+∞` when an equation vanishes identically.
#[must_use]
pub fn fit_ratio(model: &dyn CalibModel, lin: &LinearSolve, p: &[f64]) -> f64 {
    let k = lin.basis_size;
    let mut c = vec![0.0; model.equation_count() * k];
    model.generalized_params(p, &mut c);
    let mut worst: f64 = 0.0;
    for g in lin.groups.iter().filter(|g| g.poses > 0) {
        let ne = g.equations.len();
        let smax = g.singular_values.first().copied().unwrap_or(0.0);
        let scale = g.scale();
        for (i, &e) in g.equations.iter().enumerate() {
            let ce = &c[e * k..(e + 1) * k];
            let mut v = DVector::zeros(g.cols);
            for kk in 0..k {
                v[kk] = ce[kk];
            }
            let ratio = if g.kind.is_measured() {
                v[k + i] = -1.0;
                let res = (&g.r * &v).norm();
                let best = g.r.view((k, k + i), (g.cols - k, 1)).norm();
                let col = g.r.column(k + i).norm();
                // The floor: the 12 equations of a measured pose share `p`, so a rotation entry
                // measured exactly (a simulated orientation) takes the positions' noise
                // through `p`. Rotation entries lie in [−1, 1] whatever the frame's origin.
                let rotation = g.kind == ConstraintKind::MeasuredPose && i >= 3;
                let floor = if rotation { MEASURED_FLOOR } else { 1e-10 };
                res / (10.0 * best + floor * col + f64::MIN_POSITIVE)
            } else {
                let dnorm = ce
                    .iter()
                    .zip(&scale)
                    .map(|(a, d)| (a * d) * (a * d))
                    .sum::<f64>()
                    .sqrt();
                if dnorm == 0.0 {
                    f64::INFINITY
                } else {
                    let rho = (&g.r * &v).norm() / dnorm;
                    let sref = g
                        .singular_values
                        .get(g.cols.saturating_sub(ne))
                        .copied()
                        .unwrap_or(0.0);
                    rho / (10.0 * sref + 1e-10 * smax + f64::MIN_POSITIVE)
                }
            };
            worst = worst.max(if ratio.is_nan() { f64::INFINITY } else { ratio });
        }
    }
    worst
}
