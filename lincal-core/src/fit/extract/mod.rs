//! Extraction: from the data's generalized-parameter information back to the physical
//! parameters, general for any model.
//!
//! # The method
//! The linear solve ([`crate::fit::solve`]) leaves, for each constraint `j`, the factor `R_j` with
//! `R_jᵀR_j = A_jᵀA_j`. For parameters `p` the algebraic residual of pose `l` and equation `e`
//! is `h_e(q_l; p) = c_e(p)·Φ̃(q_l)` (for a measured tip `c_e(p)·Φ̃(q_l) − x_{l,e}`), so
//!
//! ```text
//! cost(p) = Σ_j Σ_{e ∈ j} ‖R_j·c_e(p)‖²          (measured: ‖R_j·[c_e(p); −u_e]‖²)
//!         = Σ_l Σ_e h_e(q_l; p)²,
//! ```
//! computed from `K × K` factors, independent of the number of poses. It is minimised over the
//! free parameters (`!model.param_held(j)`; the held ones, the gauge, stay at their nominal)
//! by Levenberg-Marquardt ([`crate::fit::refine`]'s core) with the Jacobian `R_j·∂c_e/∂p` from
//! [`CalibModel::jacobian`], starting from the nominals.
//!
//! This replaces the paper's analytic step 7 for every model, and it handles the pitfalls of
//! the linear solve by construction: a pinned point (two equations, a 2-D null space: each
//! equation gets its own `c_e(p)`, no "+1" normalisation), a 3-D line (the data's null space
//! has extra structural directions; `c(p)` can only move on the model's manifold, which picks
//! the right ones), circles and spheres (the reduced basis of the model), measured tips.
//!
//! # Finding the global minimum
//! Some mechanisms satisfy a constraint identically for special parameters (`c_e(p) = 0`, say
//! a collapsed link keeping the tip on a sphere): an exact zero of the plain cost. So the fit
//! runs in two phases: first on the scale-invariant cost `Σ ‖R_j c_e‖²/‖D_j c_e‖²` (each
//! equation's Rayleigh quotient on the column-scaled data, `D_j` the column norms), which has
//! no such zero, then on the plain cost from there.
//!
//! A fit is accepted when every fitted `c_e(p̂)` is as close to the data's null space as the
//! linear solve allows: `‖R_j c_e‖/‖D_j c_e‖ ≤ 10·σ_{K−E_j+1}(R_j D_j⁻¹) + 10⁻¹⁰·σ_max`, or for a
//! measured tip a residual within 10 times the regression's, or for a measured pose's rotation
//! entry within 10⁻⁶ of the entry's own norm ([`fit_ratio`] ≤ 1; the equations of a measured
//! pose share `p`, so an exactly measured orientation takes the positions' noise through it).
//! Otherwise, in a fixed order (deterministic): a staged start (the constraint's own
//! parameters fitted
//! first with the arm at its nominal), then each free angle shifted by `π, π/2, −π/2` from the
//! best point (up to three rounds), then 24 starts with every free angle drawn about its
//! nominal from a constant-seeded sequence; the lowest cost wins.
//!
//! Discrete ambiguities (the same data fitted exactly by a mirrored arm) are resolved towards
//! the nominals: a free length whose sign differs from its nominal's is flipped and the fit
//! repeated, keeping the flip when it fits as well; a length entering only squared (a radius)
//! or together with a half-turn of an angle takes its nominal's sign. Free angles are wrapped
//! into `(−π, π]`.
//!
//! # Uncertainty
//! `cov = σ̂²(JᵀJ)⁻¹` at the solution with `σ̂² = cost/(m − n)`, `m = Σ_j N_j·E_j` the number of
//! scalar equations over all poses and `n` the number of free parameters. For lines, planes,
//! points and measured tips the algebraic residual is a fixed multiple of the geometric one, so
//! this is the least-squares covariance; for curved constraints it is first-order.
//!
//! # Degenerate data
//! Before fitting: no poses, all poses identical, fewer poses than `K` on a single constraint,
//! or no more equations than free parameters. After: a rank-deficient `J` (column-scaled
//! singular values below `1e-10·σ_max`) names the parameter combinations lost (its null space),
//! the basis functions the data does not excite and the joints that never moved.

mod finish;
mod problem;
mod rank;
mod search;

pub use finish::Extraction;
pub use problem::fit_ratio;
pub use rank::{unexcited_basis, JACOBIAN_RANK_TOL};

use crate::error::{Error, Result};
use crate::fit::solve::LinearSolve;
use crate::model::CalibModel;

use finish::finish;
use problem::{AlgebraicProblem, Cost};
use rank::check_excitation;
use search::{angle_shifts, first_fit, polish, random_restarts, sign_flips, staged_start};

/// Checks the data can determine the free parameters at all (before any fit).
///
/// # Errors
/// [`Error::degenerate`] with the reason.
pub fn check_data(model: &dyn CalibModel, lin: &LinearSolve) -> Result<()> {
    let k = lin.basis_size;
    let n = lin.poses;
    let free = (0..model.param_count())
        .filter(|&j| !model.param_held(j))
        .count();
    if n == 0 {
        return Err(Error::degenerate("no poses in the data"));
    }
    if lin.all_identical && n > 1 {
        return Err(Error::degenerate(format!(
            "all {n} poses have the same joint readings: the data determines nothing"
        )));
    }
    if model.constraint_count() == 1 && n < k {
        return Err(Error::degenerate(format!(
            "{n} poses, but the basis has K = {k} functions: at least {k} poses are needed (more for noisy data)"
        )));
    }
    let m: usize = lin.groups.iter().map(|g| g.poses * g.equations.len()).sum();
    if m <= free {
        return Err(Error::degenerate(format!(
            "the {n} poses give {m} equations for {free} free parameters: more poses are needed"
        )));
    }
    Ok(())
}

/// Fits the physical parameters to the linear solve (see the module docs).
///
/// # Errors
/// [`Error::degenerate`] when the data cannot determine the free parameters (with the reason
/// and what is lost); [`Error::other`] on a numerical failure.
pub fn extract(model: &dyn CalibModel, lin: &LinearSolve) -> Result<Extraction> {
    extract_from(model, lin, None)
}

/// [`extract`] starting from `start` (all estimated parameters; held ones are taken from the
/// nominals regardless) instead of the nominals, e.g. a closed-form solution
/// ([`crate::fit::closed_form`]).
///
/// # Errors
/// As [`extract`].
pub fn extract_from(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    start: Option<&[f64]>,
) -> Result<Extraction> {
    check_data(model, lin)?;
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    if nominal.iter().any(|v| !v.is_finite()) {
        return Err(Error::other("a nominal parameter value is not finite"));
    }
    let plain = AlgebraicProblem::new(model, lin, &nominal, Cost::Plain);
    let normalized = plain.with_cost(Cost::Normalized);
    check_excitation(&plain, &nominal)?;
    let x0 = match start {
        Some(s) if s.len() == np && s.iter().all(|v| v.is_finite()) => plain.set.take(s),
        _ => plain.set.take(&nominal),
    };
    // Phase 1: the normalised cost finds the basin (with restarts when it fits badly).
    let mut search = first_fit(&plain, &normalized, &x0)?;
    staged_start(&normalized, &nominal, &x0, &mut search);
    angle_shifts(&normalized, &mut search);
    random_restarts(&normalized, &x0, &mut search);
    // Phase 2: the plain cost Σ h² polishes within it.
    polish(&plain, &mut search)?;
    // Phase 3: discrete ambiguities of lengths, then canonical signs and wrapped angles.
    sign_flips(&plain, &nominal, &mut search);
    finish(&plain, &nominal, search)
}
