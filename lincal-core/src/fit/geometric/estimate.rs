//! The Levenberg-Marquardt fit of the geometric residual from a start, and what it found: the
//! estimate with its covariance, condition number and numerical rank.
//!
//! Takes the model, the poses, a start (and optional per-pose weights); gives a
//! [`GeometricEstimate`].

use nalgebra::DMatrix;

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;
use crate::numeric::linalg::checked_svd;
use crate::numeric::lm::{levenberg_marquardt, LeastSquares, LmResult};

use super::problem::GeometricFit;

/// What a geometric fit found.
#[derive(Clone, Debug)]
pub struct GeometricEstimate {
    /// The estimated-parameter vector (held ones at their start value).
    pub p: Vec<f64>,
    /// Free parameter indices.
    pub free: Vec<usize>,
    /// `Σ‖g‖²` at the start.
    pub start_cost: f64,
    /// `Σ‖g‖²` at `p`.
    pub cost: f64,
    /// Residual components `m`.
    pub components: usize,
    /// Standard deviations `σ̂²(JᵀJ)⁻¹`, `None` for held parameters (and all `None` when the
    /// Jacobian is singular at `p`). Here and below, "at `p`" is at the last linearisation:
    /// when the relative-offset test ended the fit, one Gauss-Newton step before `p`, less
    /// than `10⁻³·√n` standard errors away.
    pub std: Vec<Option<f64>>,
    /// Covariance of the free parameters (order of `free`), when `JᵀJ` is invertible.
    pub covariance: Option<DMatrix<f64>>,
    /// Condition number of the column-equilibrated Jacobian at `p`.
    pub condition: f64,
    /// Numerical rank of the column-equilibrated Jacobian at `p`.
    pub rank: usize,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
}

/// Relative singular value below which a column-scaled Jacobian direction counts as lost.
pub(crate) const RANK_TOL: f64 = 1e-9;

/// `r` with each column scaled to unit norm (a zero column stays zero).
fn equilibrated(r: &DMatrix<f64>) -> DMatrix<f64> {
    let mut s = r.clone();
    for c in 0..r.ncols() {
        let d = s.column(c).norm();
        s.column_mut(c).unscale_mut(if d > 0.0 { d } else { 1.0 });
    }
    s
}

/// Numerical rank of the singular values `sv` (relative [`RANK_TOL`]).
fn rank_of(sv: &[f64]) -> usize {
    let smax = sv.iter().copied().fold(0.0, f64::max);
    sv.iter().filter(|&&x| x > RANK_TOL * smax).count()
}

/// Condition number and numerical rank of the column-equilibrated factor `r`, from its
/// singular values alone.
pub(crate) fn condition_of(r: &DMatrix<f64>) -> Result<(f64, usize)> {
    if r.ncols() == 0 {
        return Ok((1.0, 0));
    }
    let svd = checked_svd(equilibrated(r), false, false)?;
    let sv = svd.singular_values.as_slice();
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
    let cond = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    Ok((cond, rank_of(sv)))
}

/// Numerical rank, singular values and right singular vectors (columns of `V`) of the
/// column-equilibrated factor `r`: what a lost direction is named from.
pub(crate) fn spectrum_of(r: &DMatrix<f64>) -> Result<(usize, Vec<f64>, DMatrix<f64>)> {
    if r.ncols() == 0 {
        return Ok((0, Vec::new(), DMatrix::zeros(0, 0)));
    }
    let svd = checked_svd(equilibrated(r), false, true)?;
    let sv = svd.singular_values.as_slice().to_vec();
    let v = svd
        .v_t
        .as_ref()
        .map(DMatrix::transpose)
        .ok_or_else(|| Error::other("SVD without V"))?;
    Ok((rank_of(&sv), sv, v))
}

/// Minimises the geometric residual from `start` (every estimated parameter; held ones stay).
///
/// # Errors
/// [`Error::degenerate`] with fewer residual components than free parameters;
/// [`Error::other`] when the residual is not finite at the start.
pub fn fit(model: &dyn CalibModel, poses: &Poses, start: &[f64]) -> Result<GeometricEstimate> {
    fit_weighted(model, poses, start, None)
}

/// [`fit`] minimising `Σ_l w_l ‖g_l‖²` (one weight per pose; an iteratively reweighted robust
/// fit calls it with weights from the previous residuals).
///
/// # Errors
/// As [`fit`].
pub fn fit_weighted(
    model: &dyn CalibModel,
    poses: &Poses,
    start: &[f64],
    weights: Option<&[f64]>,
) -> Result<GeometricEstimate> {
    converged(model, poses, start, weights)?.finish()
}

/// [`fit_weighted`] up to convergence, what only the chosen fit needs left for
/// [`Converged::finish`].
pub(crate) fn converged(
    model: &dyn CalibModel,
    poses: &Poses,
    start: &[f64],
    weights: Option<&[f64]>,
) -> Result<Converged> {
    let mut problem = GeometricFit::new(model, poses, start)?;
    if let Some(w) = weights {
        if w.len() != poses.len() || w.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(Error::other(
                "one finite, non-negative weight per pose is needed",
            ));
        }
        problem.weights = Some(w);
    }
    let n = problem.unknowns();
    let m = problem.components() + problem.relation_components();
    if m <= n {
        return Err(Error::degenerate(format!(
            "{} poses give {m} residual components for {n} free parameters: more poses are needed",
            poses.len()
        )));
    }
    let x0 = problem.set.take(start);
    let res: LmResult = levenberg_marquardt(&problem, &x0, 200)?;
    Ok(Converged::new(&problem, model.param_count(), res, m))
}

/// A fit that has converged, before what only the chosen fit needs: the condition number,
/// rank and covariance from an SVD of the final factor `R` (the restarts compare costs, and
/// most of them lose; [`super::restarts`]).
pub(crate) struct Converged {
    /// [`GeometricEstimate::p`].
    pub(crate) p: Vec<f64>,
    /// [`GeometricEstimate::free`].
    free: Vec<usize>,
    /// [`GeometricEstimate::start_cost`].
    start_cost: f64,
    /// [`GeometricEstimate::cost`].
    pub(crate) cost: f64,
    /// [`GeometricEstimate::components`].
    pub(crate) components: usize,
    /// [`GeometricEstimate::iterations`].
    iterations: usize,
    /// The last linearisation's triangular factor.
    r: DMatrix<f64>,
    /// The noise level from the data's residual alone (a prior's rows are not data).
    sigma2: f64,
    /// The model's parameter count.
    param_count: usize,
}

impl Converged {
    fn new(problem: &GeometricFit<'_>, param_count: usize, res: LmResult, m: usize) -> Self {
        let n = problem.unknowns();
        Converged {
            p: problem.set.full(&res.x),
            free: problem.set.free.clone(),
            start_cost: res.start_cost,
            cost: res.cost,
            components: m,
            iterations: res.iterations,
            sigma2: (res.cost - problem.prior_cost(&res.x)).max(0.0) / (m - n) as f64,
            r: res.lin.r,
            param_count,
        }
    }

    /// The estimate with its condition number, rank, covariance and standard deviations.
    ///
    /// # Errors
    /// When the SVD of `R` fails (a non-finite entry).
    pub(crate) fn finish(self) -> Result<GeometricEstimate> {
        let n = self.free.len();
        let (condition, rank) = condition_of(&self.r)?;
        let mut std = vec![None; self.param_count];
        let covariance = if rank == n {
            crate::numeric::lm::covariance(&self.r, self.sigma2)
        } else {
            None
        };
        if let Some(cov) = &covariance {
            for (i, &j) in self.free.iter().enumerate() {
                std[j] = Some(cov[(i, i)].max(0.0).sqrt());
            }
        }
        Ok(GeometricEstimate {
            p: self.p,
            free: self.free,
            start_cost: self.start_cost,
            cost: self.cost,
            components: self.components,
            std,
            covariance,
            condition,
            rank,
            iterations: self.iterations,
        })
    }
}
