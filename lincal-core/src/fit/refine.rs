//! Refinement (`--refine`): Levenberg-Marquardt (the crate's own `lm` core) on the geometric
//! residual.
//!
//! # The refinement
//! Over the free (gauge-fixed) parameters `p_F` (held ones stay at their nominal), minimise
//! `Σ_l ‖g(x(q_l; p), v_j(p))‖²`, where `x(q; p)` is the model's tip, `v_j(p)` the values of
//! the constraint pose `l` lies on and `g` [`crate::model::geometry::geometric_residual`] (distance from a
//! line or plane, offset from a point, `‖x − c‖ − r` for a circle or sphere, Sampson distance
//! for a quadric, `x − x_measured` for a measured tip), starting from the extraction. The
//! Jacobian is exact; [`crate::fit::geometric`] does the work.
//!
//! Covariance at the solution: `σ̂²(JᵀJ)⁻¹` with `σ̂² = cost/(m − n)`, `m` the number of
//! residual components, `n` the number of free parameters. The gauge fix (the model holds one
//! length and the angles the constraint cannot see) rules out the collapse of all lengths
//! to zero; and a refined result whose cost is not below the start is rejected by the caller
//! ([`crate::calibrate`]).

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;

/// Result of [`refine`].
#[derive(Clone, Debug)]
pub struct Refinement {
    /// The refined estimated-parameter vector (held ones at their start value).
    pub p: Vec<f64>,
    /// `Σ‖g‖²` at the start.
    pub start_cost: f64,
    /// `Σ‖g‖²` at `p`.
    pub cost: f64,
    /// `σ̂² = cost/(m − n)`.
    pub sigma2: f64,
    /// Standard deviation of each estimated parameter, `None` for held ones.
    pub std: Vec<Option<f64>>,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
}

/// Levenberg-Marquardt on the geometric residual over the free parameters, from `start`
/// (the model's `p`, typically the extraction), see the module docs.
///
/// # Errors
/// [`Error::degenerate`] when there are no more residual components than free parameters or
/// the Jacobian at the solution is singular; [`Error::other`] when the residual is not finite
/// at the start.
pub fn refine(model: &dyn CalibModel, poses: &Poses, start: &[f64]) -> Result<Refinement> {
    let est = crate::fit::geometric::fit(model, poses, start)?;
    let n = est.free.len();
    if n > 0 && est.covariance.is_none() {
        return Err(Error::degenerate(
            "refinement: the geometric Jacobian is singular at the solution (a parameter the data does not determine)",
        ));
    }
    Ok(Refinement {
        sigma2: est.cost / (est.components - n) as f64,
        p: est.p,
        start_cost: est.start_cost,
        cost: est.cost,
        std: est.std,
        iterations: est.iterations,
    })
}
