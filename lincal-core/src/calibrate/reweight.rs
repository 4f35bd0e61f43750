//! `--robust`: iteratively reweighted fits. The linear solve reweighted on its algebraic
//! residuals ([`crate::fit::solve::solve_robust`]) and the parameter-space fit on its geometric
//! residuals, both with the losses of [`crate::numeric::robust::Robust`].

use super::estimate::RobustFit;
use super::residuals::{components, residual_scale};
use crate::data::Poses;
use crate::error::Result;
use crate::fit::solve::solve;
use crate::model::CalibModel;
use crate::numeric::robust::Robust;

/// Rounds of reweighting at most.
pub(super) const IRLS_ROUNDS: usize = 30;

/// The iteratively reweighted fit from `p0` with `loss` (see [`Robust`]): the last weighted
/// fit (`None` when the residuals vanish, exact data, and no weighting is needed) and what
/// it did.
pub(super) fn robust_refit(
    model: &dyn CalibModel,
    poses: &Poses,
    p0: &[f64],
    loss: Robust,
) -> Result<(Option<crate::fit::geometric::GeometricEstimate>, RobustFit)> {
    let mut p = p0.to_vec();
    let mut last = None;
    let mut info = RobustFit {
        loss: loss.name().to_string(),
        tuning: loss.tuning(),
        scale: f64::NAN,
        rounds: 0,
        downweighted: 0,
        linear_rounds: 0,
        linear_downweighted: 0,
    };
    for round in 1..=IRLS_ROUNDS {
        crate::cancel::check()?;
        let (scale, d) = residual_scale(model, poses, &p);
        if !(scale > 0.0 && scale.is_finite()) {
            break;
        }
        let w: Vec<f64> = d
            .iter()
            .enumerate()
            .map(|(l, &x)| {
                let m = components(model, poses, l).max(1) as f64;
                loss.weight(x / (scale * m.sqrt()))
            })
            .collect();
        info.scale = scale;
        info.rounds = round;
        info.downweighted = w.iter().filter(|&&x| x < 0.5).count();
        let mut r = crate::fit::geometric::fit_weighted(model, poses, &p, Some(&w))?;
        // The covariance's σ̂² from the robust scale, not from the weighted cost (which the
        // down-weighted poses still inflate): σ̂²·(JᵀWJ)⁻¹.
        let dof = r.components.saturating_sub(r.free.len()).max(1) as f64;
        let sigma2 = r.cost / dof;
        if sigma2 > 0.0 && sigma2.is_finite() {
            let f = scale * scale / sigma2;
            for v in r.std.iter_mut().flatten() {
                *v *= f.sqrt();
            }
            if let Some(c) = &mut r.covariance {
                *c *= f;
            }
        }
        let moved =
            r.p.iter()
                .zip(&p)
                .map(|(a, b)| (a - b).abs() / (1.0 + b.abs()))
                .fold(0.0, f64::max);
        p.clone_from(&r.p);
        last = Some(r);
        if moved <= 1e-10 {
            break;
        }
    }
    Ok((last, info))
}

/// The linear solve, iteratively reweighted with a robust loss
/// ([`crate::fit::solve::solve_robust`]), and what the reweighting did.
pub(super) fn linear_solve(
    model: &dyn CalibModel,
    poses: &Poses,
    robust: Option<Robust>,
) -> Result<(
    crate::fit::solve::LinearSolve,
    Option<crate::fit::solve::LinearReweighting>,
)> {
    match robust {
        Some(loss) => {
            crate::fit::solve::solve_robust(model, poses, loss).map(|(l, r)| (l, Some(r)))
        }
        None => solve(model, poses).map(|l| (l, None)),
    }
}
