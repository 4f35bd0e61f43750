//! The whitened coordinates every selection computes in, and the criterion values computed
//! directly (from scratch, by Cholesky factors).
//!
//! For each draw the pool's average information `M̄ = (1/P) Σᵢ JᵢᵀJᵢ` (plus `τI`, see
//! [`SelectOptions::ridge`]) is factored `M̄ + τI = L̄L̄ᵀ`, and a row `j` of a block becomes
//! `j̃ = j·W` with `W = L̄⁻ᵀ`. Then the regulariser `R = ε(M̄ + τI)` becomes `εI`, the average
//! pose has unit information, and the information of a design is
//! `M̃ = WᵀMW = G̃ + εI + Σ J̃ᵢᵀJ̃ᵢ` with `log det M = log det M̃ + log det(M̄ + τI)`.
//! The criterion is invariant under reparametrisation, and the factors and inverses of `M̃`
//! are well scaled (the floor `ε` is relative to one average pose) whatever the units.

use nalgebra::DMatrix;

use super::pool::Pool;
use super::small::{chol_factor, chol_logdet, lower_inverse};
use super::types::{Criterion, SelectError, SelectOptions};

/// The whitening of one draw.
#[derive(Clone, Debug)]
pub(crate) struct Frame {
    /// `W = L̄⁻ᵀ`: a raw row `j` becomes `j·W`.
    pub(crate) w: DMatrix<f64>,
    /// `log det(M̄ + τI)`: raw `log det` = whitened `log det` + shift.
    pub(crate) shift: f64,
    /// `G̃ = WᵀGW`.
    pub(crate) given: DMatrix<f64>,
    /// The regulariser's weight `ε` (whitened regulariser `εI`).
    pub(crate) eps: f64,
}

/// Relative size of `τ` (see [`SelectOptions::ridge`]) for a pool that sees every
/// direction: at rounding level, so the criterion stays invariant to reparametrisation.
const TAU: f64 = 1e-10;

/// Relative size of `τ` for a pool with a direction it barely sees ([`pool_is_blind`]): whitening amplifies that direction by `1/√τ`, and at
/// rounding level a blind direction (a PUMA's `θ6` at its nominals) would be blown up until
/// the updates' factorisations fail; `10⁻⁶` keeps the amplification at `10³`.
const TAU_BLIND: f64 = 1e-6;

/// Smallest eigenvalue of `M̄` scaled to unit diagonal below which a pool is taken as blind
/// in a direction.
const BLIND: f64 = 1e-6;

/// Whether the pool's mean information `mean` barely sees some direction: its smallest
/// eigenvalue, with the columns scaled to unit diagonal (so the parameters' units do not
/// matter), is below [`BLIND`], or a column is zero.
pub(crate) fn pool_is_blind(mean: &DMatrix<f64>) -> bool {
    let n = mean.nrows();
    let d: Vec<f64> = (0..n).map(|i| mean[(i, i)]).collect();
    if d.iter().any(|&v| v.is_nan() || v <= 0.0) {
        return true;
    }
    let scaled = DMatrix::from_fn(n, n, |i, j| mean[(i, j)] / (d[i] * d[j]).sqrt());
    nalgebra::SymmetricEigen::new(scaled)
        .eigenvalues
        .iter()
        .any(|&v| v < BLIND)
}

/// The frames of every draw of `pool` for regulariser weight `ridge`.
pub(crate) fn frames(pool: &Pool, ridge: f64) -> Result<Vec<Frame>, SelectError> {
    let n = pool.n_params();
    (0..pool.n_draws())
        .map(|d| {
            let mean = pool.mean_information(d).clone();
            let tr = mean.trace();
            let base = if tr > 0.0 {
                let rel = if pool_is_blind(&mean) { TAU_BLIND } else { TAU };
                let tau = rel * tr / n as f64;
                mean + DMatrix::identity(n, n) * tau
            } else {
                let g = pool.given(d).trace() / n as f64;
                DMatrix::identity(n, n) * if g > 0.0 { g } else { 1.0 }
            };
            let l = chol_factor(&base).ok_or(SelectError::NotPositiveDefinite { draw: d })?;
            let w = lower_inverse(&l).transpose();
            let given = w.transpose() * pool.given(d) * &w;
            Ok(Frame {
                w,
                shift: chol_logdet(&l),
                given,
                eps: ridge,
            })
        })
        .collect()
}

/// `M̃ = G̃ + εI + Wᵀ(Σ_{i∈S} JᵢᵀJᵢ)W` of draw `d` (with the regulariser when `ridge`).
pub(crate) fn whitened_information(
    pool: &Pool,
    frame: &Frame,
    d: usize,
    chosen: &[usize],
    ridge: bool,
) -> DMatrix<f64> {
    let n = pool.n_params();
    let mut raw = DMatrix::zeros(n, n);
    pool.accumulate(d, chosen.iter().map(|&i| (i, 1.0)), &mut raw);
    let mut m = frame.w.transpose() * raw * &frame.w + &frame.given;
    if ridge {
        for k in 0..n {
            m[(k, k)] += frame.eps;
        }
    }
    super::pool::symmetrize(&mut m);
    m
}

/// The tip rows of each draw in whitened coordinates, `T̃_d = T_d·W_d`.
pub(crate) fn whitened_tip(
    pool: &Pool,
    frames: &[Frame],
    criterion: &Criterion,
) -> Result<Option<Vec<DMatrix<f64>>>, SelectError> {
    let Criterion::Tip(t) = criterion else {
        return Ok(None);
    };
    if t.len() != pool.n_draws() {
        return Err(SelectError::Shape(format!(
            "{} tip matrices for {} draws",
            t.len(),
            pool.n_draws()
        )));
    }
    for (d, td) in t.iter().enumerate() {
        if td.ncols() != pool.n_params() || td.nrows() == 0 {
            return Err(SelectError::Shape(format!(
                "tip matrix {d} is {}×{}, k×{} with k ≥ 1 expected",
                td.nrows(),
                td.ncols(),
                pool.n_params()
            )));
        }
        if td.iter().any(|v| !v.is_finite()) {
            return Err(SelectError::NonFiniteInput {
                what: "tip matrix",
                index: d,
            });
        }
    }
    Ok(Some(
        t.iter().zip(frames).map(|(td, f)| td * &f.w).collect(),
    ))
}

/// The criterion of design `chosen`, computed from scratch: for D,
/// `f = (1/D) Σ_d log det(G_d + R_d + Σ_{i∈S} J_dᵢᵀJ_dᵢ)`; for tip,
/// `g = (1/D) Σ_d tr(T_d M_d⁻¹ T_dᵀ)`.
pub(crate) fn value(
    pool: &Pool,
    frames: &[Frame],
    tip: Option<&[DMatrix<f64>]>,
    chosen: &[usize],
) -> Result<f64, SelectError> {
    let mut sum = 0.0;
    for (d, frame) in frames.iter().enumerate() {
        let m = whitened_information(pool, frame, d, chosen, true);
        let l = chol_factor(&m).ok_or(SelectError::NotPositiveDefinite { draw: d })?;
        sum += match tip {
            None => chol_logdet(&l) + frame.shift,
            Some(t) => {
                let x = l
                    .solve_lower_triangular(&t[d].transpose())
                    .ok_or(SelectError::NotPositiveDefinite { draw: d })?;
                x.norm_squared()
            }
        };
    }
    Ok(sum / frames.len() as f64)
}

/// The criterion of the design `chosen` (see [`Criterion`]), computed directly from scratch
/// by Cholesky factors, with the regulariser of `opts`.
///
/// # Errors
/// [`SelectError::BadCandidate`] for an index out of range or repeated, the option and
/// tip-matrix checks, [`SelectError::NotPositiveDefinite`] if a given information is not
/// positive semi-definite.
pub fn evaluate(
    pool: &Pool,
    chosen: &[usize],
    criterion: &Criterion,
    opts: &SelectOptions,
) -> Result<f64, SelectError> {
    opts.check()?;
    pool.check_chosen(chosen)?;
    let frames = frames(pool, opts.ridge)?;
    let tip = whitened_tip(pool, &frames, criterion)?;
    value(pool, &frames, tip.as_deref(), chosen)
}
