//! Covariance of the linear method's estimate: the heteroskedasticity-robust sandwich
//! `H⁻¹MH⁻¹` of the algebraic least-squares problem (clustered by pose).

use crate::data::Poses;
use crate::model::CalibModel;

/// Heteroskedasticity-robust (sandwich) standard deviations of the algebraic least-squares
/// estimate at `p` over the free parameters `free`: with per-pose, per-equation residuals
/// `r_le = c_e(p)·Φ̃(q_l)` (minus the measured coordinate for measured tips) and rows
/// `a_le = Φ̃(q_l)ᵀ ∂c_e/∂p_free`, `Cov = H⁻¹ M H⁻¹`, `H = Σ a aᵀ`,
/// `M = Σ_l (Σ_e a_le r_le)(Σ_e a_le r_le)ᵀ` (clustered by pose), scaled by `N/(N − n)`.
/// With pose weights `w_l` (the reweighted solve of `--robust`), the weighted estimate's:
/// `H = Σ w a aᵀ`, `M = Σ_l w_l² (Σ_e a r)(Σ_e a r)ᵀ`.
/// `None` when `H` is singular or a value is not finite.
pub(super) fn sandwich_std(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    free: &[usize],
    weights: Option<&[f64]>,
) -> Option<Vec<Option<f64>>> {
    use nalgebra::{DMatrix, DVector};
    let k = model.basis_size();
    let ne = model.equation_count();
    let np = model.param_count();
    let n = free.len();
    let mut std = vec![None; np];
    if n == 0 {
        return Some(std);
    }
    let mut c = vec![0.0; ne * k];
    model.generalized_params(p, &mut c);
    let mut jac = vec![0.0; ne * k * np];
    model.jacobian(p, &mut jac);
    let mut phi = vec![0.0; k];
    let mut h = DMatrix::<f64>::zeros(n, n);
    let mut meat = DMatrix::<f64>::zeros(n, n);
    for l in 0..poses.len() {
        let w = weights.map_or(Some(1.0), |w| w.get(l).copied())?;
        model.basis(&poses.q[l], &mut phi);
        let j = poses.constraint.at(l);
        let mut score = DVector::<f64>::zeros(n);
        for e in (0..ne).filter(|&e| model.equation_constraint(e) == j) {
            let mut r: f64 = (0..k).map(|i| c[e * k + i] * phi[i]).sum();
            if model.constraint_kind(j).is_measured() {
                // Equations of a measured constraint are the tip coordinates, in order.
                let coord = (0..e)
                    .filter(|&f| model.equation_constraint(f) == j)
                    .count();
                r -= poses.measured.as_ref()?.get(l)?.get(coord)?;
            }
            let a = DVector::<f64>::from_iterator(
                n,
                free.iter().map(|&fj| {
                    (0..k)
                        .map(|i| phi[i] * jac[(e * k + i) * np + fj])
                        .sum::<f64>()
                }),
            );
            h += &a * a.transpose() * w;
            score += &a * (r * w);
        }
        meat += &score * score.transpose();
    }
    // Relations are exact equations: heavy rows in H (no residual, so nothing in M) make the
    // directions they fix (nearly) certain, as in the fits.
    let relation_rows = crate::fit::relation::rows(model, p);
    if !relation_rows.is_empty() {
        let diag: Vec<f64> = (0..n).map(|i| h[(i, i)]).collect();
        let w = crate::fit::relation::weight(&diag);
        for row in relation_rows {
            let mut a = DVector::<f64>::zeros(n);
            for (param, d) in &row.gradient {
                if let Some(pos) = free.iter().position(|f| f == param) {
                    a[pos] += w * d;
                }
            }
            h += &a * a.transpose();
        }
    }
    let hinv = h.try_inverse()?;
    let dof = poses.len() as f64 / (poses.len().saturating_sub(n).max(1)) as f64;
    let cov = &hinv * meat * &hinv * dof;
    for (i, &fj) in free.iter().enumerate() {
        let v = cov[(i, i)].max(0.0).sqrt();
        if !v.is_finite() {
            return None;
        }
        std[fj] = Some(v);
    }
    Some(std)
}
