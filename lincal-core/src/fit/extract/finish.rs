//! The finishing statistics of an extraction: canonical signs and wrapped angles, the rank
//! of the Jacobian on the data, the covariance and standard deviations, and the checks that
//! nothing is non-finite.
//!
//! Takes the plain [`AlgebraicProblem`] and the [`Search`]'s best fit; gives the
//! [`Extraction`].

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::numeric::lm::{covariance, LeastSquares};
use crate::numeric::wrap_angle;

use super::problem::AlgebraicProblem;
use super::rank::rank_deficiency;
use super::search::{free_angles, Search};

/// What the extraction found.
#[derive(Clone, Debug)]
pub struct Extraction {
    /// The estimated-parameter vector `p` (held parameters at their nominal).
    pub p: Vec<f64>,
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// Algebraic cost `Σ_l Σ_e h_e(q_l; p)²` at `p`.
    pub cost: f64,
    /// Number of scalar equations `m = Σ_j N_j·E_j`.
    pub equations: usize,
    /// `σ̂² = cost/(m − n)`.
    pub sigma2: f64,
    /// Covariance of the free parameters (`n × n`, in the order of `free`).
    pub covariance: DMatrix<f64>,
    /// Standard deviation of each estimated parameter; `None` for held ones.
    pub std: Vec<Option<f64>>,
    /// The largest ratio of the fitted `c_e(p)`'s distance from the data's null space to the
    /// linear solution's (with slack, see the module docs): `≤ 1` means the fit is as good as
    /// the linear solve allows.
    pub fit_ratio: f64,
    /// Number of restarts tried.
    pub restarts: usize,
    /// Condition number of the column-scaled Jacobian at `p`.
    pub condition: f64,
    /// Things a user should know.
    pub warnings: Vec<String>,
}

/// Canonical signs and wrapped angles, the rank of the Jacobian on the data, the
/// covariance, and the checks that nothing is non-finite.
pub(super) fn finish(
    plain: &AlgebraicProblem<'_>,
    nominal: &[f64],
    search: Search,
) -> Result<Extraction> {
    let (model, lin) = (plain.model, plain.lin);
    let n = plain.unknowns();
    let np = model.param_count();
    let m: usize = lin.groups.iter().map(|g| g.poses * g.equations.len()).sum();
    let Search {
        best,
        ratio,
        restarts,
        ..
    } = search;
    let mut warnings = Vec::new();
    let x = canonical_point(plain, &best.x, nominal);
    let p = plain.set.full(&x);
    let cost = best.cost;
    if ratio > 1.0 {
        warnings.push(format!(
            "the fitted generalized parameters are {:.3e} times farther from the data's null space than the linear solution allows: possibly a local minimum, a model that does not fit the data, or too few poses",
            ratio * 10.0
        ));
    }
    let mut condition = 1.0;
    let mut covariance_m = DMatrix::zeros(n, n);
    let sigma2 = cost / (m - n) as f64;
    let mut std = vec![None; np];
    if n > 0 {
        (condition, covariance_m) =
            free_statistics(plain, &x, &p, sigma2, &mut std, &mut warnings)?;
    }
    check_finite(&p, cost, &std)?;
    Ok(Extraction {
        p,
        free: plain.set.free.clone(),
        cost,
        equations: m,
        sigma2,
        covariance: covariance_m,
        std,
        fit_ratio: ratio,
        restarts,
        condition,
        warnings,
    })
}

/// The free parameters `x` with canonical signs ([`canonical_signs`]) and wrapped angles.
fn canonical_point(plain: &AlgebraicProblem<'_>, x: &[f64], nominal: &[f64]) -> Vec<f64> {
    let mut x = x.to_vec();
    canonical_signs(plain, &mut x, nominal);
    for i in free_angles(plain) {
        x[i] = wrap_angle(x[i]);
    }
    x
}

/// At the solution `x` (`p` in full): the rank test of the column-scaled Jacobian (the
/// degenerate-data error when it fails), its condition number (a warning when large), the
/// covariance `σ̂²(JᵀJ)⁻¹` and each free parameter's standard deviation into `std`.
/// Returns the condition number and the covariance.
fn free_statistics(
    plain: &AlgebraicProblem<'_>,
    x: &[f64],
    p: &[f64],
    sigma2: f64,
    std: &mut [Option<f64>],
    warnings: &mut Vec<String>,
) -> Result<(f64, DMatrix<f64>)> {
    let l = plain.linearize(x)?;
    let condition = rank_deficiency(plain.model, plain.lin, &plain.set, &l.r, p)??;
    if condition > 1e8 {
        warnings.push(format!(
            "the parameters are poorly determined by these poses (condition number {condition:.2e}): move every joint over a wider range"
        ));
    }
    let covariance_m = covariance(&l.r, sigma2)
        .ok_or_else(|| Error::degenerate("the Jacobian is singular at the solution"))?;
    for (i, &j) in plain.set.free.iter().enumerate() {
        std[j] = Some(covariance_m[(i, i)].max(0.0).sqrt());
    }
    Ok((condition, covariance_m))
}

/// The error when the extraction produced a non-finite parameter, cost or deviation.
fn check_finite(p: &[f64], cost: f64, std: &[Option<f64>]) -> Result<()> {
    if p.iter().any(|v| !v.is_finite())
        || !cost.is_finite()
        || std.iter().flatten().any(|v| !v.is_finite())
    {
        return Err(Error::other(
            "the extraction produced a non-finite value; the data or the model is degenerate",
        ));
    }
    Ok(())
}

/// Sign conventions for the exact symmetries of `c(p)`: a free length that enters only
/// squared (a radius) takes its nominal's sign (zero counts as positive); a free length that
/// flips together with a half-turn of a free angle (`a → −a, θ → θ + π`) takes its nominal's
/// sign when that is not zero, and otherwise the variant whose angle is nearer its nominal.
fn canonical_signs(problem: &AlgebraicProblem<'_>, x: &mut [f64], nominal: &[f64]) {
    let model = problem.model;
    let set = &problem.set;
    let n = set.free.len();
    let c0 = problem.gen(&set.full(x));
    let scale = c0.iter().fold(1.0f64, |a, v| a.max(v.abs()));
    let same = |y: &[f64]| {
        let c = problem.gen(&set.full(y));
        c.iter()
            .zip(&c0)
            .all(|(a, b)| (a - b).abs() <= 1e-12 * scale)
    };
    for i in 0..n {
        let j = set.free[i];
        if model.param_is_angle(j) || x[i] == 0.0 {
            continue;
        }
        let wanted = if nominal[j] < 0.0 { -1.0 } else { 1.0 };
        let mut y = x.to_vec();
        y[i] = -y[i];
        if same(&y) {
            if x[i].signum() != wanted {
                x.copy_from_slice(&y);
            }
            continue;
        }
        for a in (0..n).filter(|&a| model.param_is_angle(set.free[a])) {
            let mut z = y.clone();
            z[a] += std::f64::consts::PI;
            if !same(&z) {
                continue;
            }
            let better = if nominal[j] != 0.0 {
                x[i].signum() != wanted
            } else {
                let nom = nominal[set.free[a]];
                wrap_angle(z[a] - nom).abs() < wrap_angle(x[a] - nom).abs() - 1e-12
            };
            if better {
                x.copy_from_slice(&z);
            }
            break;
        }
    }
}
