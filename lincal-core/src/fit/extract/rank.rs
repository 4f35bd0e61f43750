//! Whether the data determines the free parameters: the rank of the data-weighted Jacobian
//! (before any fit, at a generic point near the nominals), and, when it is rank-deficient,
//! the error naming what is lost: parameter combinations, unexcited basis functions, frozen
//! joints and constraints without poses.
//!
//! Takes the [`AlgebraicProblem`] (or the model, the linear solve and the Jacobian factor);
//! gives `Ok` or an [`Error::degenerate`].

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::fit::solve::LinearSolve;
use crate::model::CalibModel;
use crate::numeric::linalg::checked_svd;
use crate::numeric::lm::{FreeSet, LeastSquares};

use super::problem::AlgebraicProblem;

/// Relative singular-value threshold below which the column-scaled Jacobian is rank-deficient.
pub const JACOBIAN_RANK_TOL: f64 = 1e-10;

/// Can these poses determine the free parameters at all? A frozen joint or too few distinct
/// poses make the data-weighted Jacobian singular at every parameter point, so it is checked
/// at a generic point near the nominals, before any fit (a fit on such data can wander off
/// instead of stopping where the final rank test would catch it).
pub(super) fn check_excitation(plain: &AlgebraicProblem<'_>, nominal: &[f64]) -> Result<()> {
    if plain.unknowns() == 0 {
        return Ok(());
    }
    let (model, lin, set) = (plain.model, plain.lin, &plain.set);
    let xg = generic_point(model, &set.free, &set.take(nominal));
    let l = plain.linearize(&xg)?;
    rank_deficiency(model, lin, set, &l.r, &set.full(&xg))?.map(|_| ())
}

/// A deterministic generic point about the nominals `x` of the free parameters: angles moved
/// by up to 0.3 rad, lengths by up to 10 % of the largest nominal length.
fn generic_point(model: &dyn CalibModel, free: &[usize], x: &[f64]) -> Vec<f64> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x9e4e);
    let scale = free
        .iter()
        .zip(x)
        .filter(|(&j, _)| !model.param_is_angle(j))
        .fold(0.1f64, |m, (_, v)| m.max(v.abs()));
    free.iter()
        .zip(x)
        .map(|(&j, &v)| {
            let u: f64 = rng.gen_range(-1.0..1.0);
            if model.param_is_angle(j) {
                v + 0.3 * u
            } else {
                v + 0.1 * scale * u
            }
        })
        .collect()
}

/// The degenerate-data error when the data-weighted Jacobian factor `r` (free parameters as
/// columns) is rank-deficient at `p` (a zero column, or its column-equilibrated smallest
/// singular value below [`JACOBIAN_RANK_TOL`] of the largest), or else the condition number
/// `σ_max/σ_min` of the equilibrated factor.
pub(super) fn rank_deficiency(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    set: &FreeSet,
    r: &DMatrix<f64>,
    p: &[f64],
) -> Result<std::result::Result<f64, Error>> {
    let n = r.ncols();
    let norms: Vec<f64> = (0..n).map(|c| r.column(c).norm()).collect();
    let mut s = r.clone();
    for (c, &d) in norms.iter().enumerate() {
        s.column_mut(c).unscale_mut(if d > 0.0 { d } else { 1.0 });
    }
    let svd = checked_svd(s, false, true)?;
    let sv = svd.singular_values.as_slice().to_vec();
    let smax = sv.first().copied().unwrap_or(0.0);
    let smin = sv.last().copied().unwrap_or(0.0);
    if norms.contains(&0.0) || smin <= JACOBIAN_RANK_TOL * smax {
        let v = svd
            .v_t
            .as_ref()
            .map(DMatrix::transpose)
            .ok_or_else(|| Error::other("SVD without V"))?;
        return Ok(Err(rank_error(model, lin, set, p, &sv, &v, &norms)));
    }
    Ok(Ok(smax / smin))
}

/// The degenerate-data error for a rank-deficient Jacobian: what is lost and why.
pub(super) fn rank_error(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    set: &FreeSet,
    p: &[f64],
    sv: &[f64],
    v: &DMatrix<f64>,
    norms: &[f64],
) -> Error {
    let lost = lost_combinations(model, set, sv, v, norms);
    let mut msg = format!(
        "the poses do not determine every free parameter; lost combination(s): {}",
        lost.join("; ")
    );
    push_unexcited(&mut msg, model, lin, p);
    let frozen = lin.frozen_joints();
    if !frozen.is_empty() {
        let names: Vec<String> = frozen.iter().map(|i| format!("q{}", i + 1)).collect();
        msg.push_str(&format!("; joints that never moved: {}", names.join(", ")));
    }
    let empty: Vec<String> = lin
        .groups
        .iter()
        .filter(|g| g.poses == 0)
        .map(|g| g.constraint.to_string())
        .collect();
    if !empty.is_empty() {
        msg.push_str(&format!(
            "; constraints without poses: {}",
            empty.join(", ")
        ));
    }
    Error::degenerate(msg)
}

/// The parameter combinations a rank-deficient Jacobian loses: each free parameter whose
/// column is zero, then each right-singular direction (columns of `v`) of a singular value in
/// `sv` below the rank tolerance, as its large terms.
fn lost_combinations(
    model: &dyn CalibModel,
    set: &FreeSet,
    sv: &[f64],
    v: &DMatrix<f64>,
    norms: &[f64],
) -> Vec<String> {
    let smax = sv.first().copied().unwrap_or(0.0);
    let mut lost = Vec::new();
    for (c, &d) in norms.iter().enumerate() {
        if d == 0.0 {
            lost.push(model.param_name(set.free[c]).to_string());
        }
    }
    for (i, &s) in sv.iter().enumerate() {
        if s > JACOBIAN_RANK_TOL * smax {
            continue;
        }
        let col = v.column(i);
        let big = col.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let big_cols: Vec<usize> = col
            .iter()
            .enumerate()
            .filter(|(_, x)| x.abs() >= 0.2 * big)
            .map(|(c, _)| c)
            .collect();
        // A direction along a column of zeros is already named above.
        if big_cols.iter().all(|&c| norms[c] == 0.0) {
            continue;
        }
        let terms: Vec<String> = big_cols
            .iter()
            .map(|&c| format!("{:+.2}·{}", col[c], model.param_name(set.free[c])))
            .collect();
        lost.push(terms.join(" "));
    }
    lost
}

/// Appends to `msg` the basis functions the data does not excite at `p` (the first few).
fn push_unexcited(msg: &mut String, model: &dyn CalibModel, lin: &LinearSolve, p: &[f64]) {
    let unexcited = unexcited_basis(model, lin, p);
    if !unexcited.is_empty() {
        // A long list helps nobody: the first few show which joints are involved.
        const SHOWN: usize = 10;
        let more = unexcited.len().saturating_sub(SHOWN);
        msg.push_str(&format!(
            "; basis functions the data does not excite: {}{}",
            unexcited[..unexcited.len().min(SHOWN)].join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ));
    }
}

/// Basis functions in the stacked data matrix's (near) null space that the fitted constraint
/// equations do not explain: the directions the data does not excite.
#[must_use]
pub fn unexcited_basis(model: &dyn CalibModel, lin: &LinearSolve, p: &[f64]) -> Vec<String> {
    let k = lin.basis_size;
    let smax = lin.singular_values.first().copied().unwrap_or(0.0);
    let scale: Vec<f64> = lin
        .basis_col_norms
        .iter()
        .map(|&d| if d > 0.0 { d } else { 1.0 })
        .collect();
    let mut c = vec![0.0; model.equation_count() * k];
    model.generalized_params(p, &mut c);
    // Orthonormal basis of the fitted equations' directions (scaled), constraint by constraint.
    let mut explained: Vec<DVector<f64>> = Vec::new();
    for g in lin.groups.iter().filter(|g| g.poses > 0) {
        if g.kind.is_measured() {
            continue;
        }
        for &e in &g.equations {
            let mut u = DVector::from_iterator(k, (0..k).map(|kk| c[e * k + kk] * scale[kk]));
            for q in &explained {
                let d = q.dot(&u);
                u -= q * d;
            }
            let nu = u.norm();
            if nu > 1e-8 {
                explained.push(u / nu);
            }
        }
    }
    let mut names: Vec<String> = Vec::new();
    for (i, &s) in lin.singular_values.iter().enumerate() {
        if s > 1e-9 * smax {
            continue;
        }
        let mut w = lin.basis_right_singular.column(i).into_owned();
        for q in &explained {
            let d = q.dot(&w);
            w -= q * d;
        }
        if w.norm() < 0.5 {
            continue;
        }
        let big = w.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for (kk, x) in w.iter().enumerate() {
            let name = model.basis_name(kk).to_string();
            if x.abs() >= 0.3 * big && !names.contains(&name) {
                names.push(name);
            }
        }
    }
    for (kk, &d) in lin.basis_col_norms.iter().enumerate() {
        let name = model.basis_name(kk).to_string();
        if d == 0.0 && !names.contains(&name) {
            names.push(name);
        }
    }
    names
}
