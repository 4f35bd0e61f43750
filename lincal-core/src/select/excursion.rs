//! DETMAX excursions (Mitchell 1974): when no single swap improves the design, go up by `k`
//! greedy additions then back down by `k` greedy removals (or down then up), and keep the
//! result if it is better. This escapes local optima of the single-swap exchange, where two
//! candidates must change together.
//!
//! Each step factors the current design afresh (`O(N·m·n² + n³)` per draw) and evaluates the
//! entering list (additions) or the design's members (removals) in square-root form:
//! with `X = L̃⁻¹J̃ᵀ`, `H = XᵀX` and (tip) `F = YᵀY`, `Y = R̃L̃⁻ᵀX`, adding (`s = 1`) or removing
//! (`s = −1`) a candidate changes `f` by `log det(I + sH)` and lowers `g` by
//! `s·tr((I + sH)⁻¹F)`.

use nalgebra::DMatrix;

use super::frame::{value, whitened_information};
use super::small::{chol, chol_det, chol_factor, chol_trace, lower_inverse};
use super::state::State;
use super::types::SelectError;

/// Per draw, `L̃⁻¹` of design `set`.
fn factors(state: &State<'_>, set: &[usize]) -> Result<Vec<DMatrix<f64>>, SelectError> {
    (0..state.draws.len())
        .map(|d| {
            let m = whitened_information(state.pool, &state.frames[d], d, set, true);
            let l = chol_factor(&m).ok_or(SelectError::NotPositiveDefinite { draw: d })?;
            Ok(lower_inverse(&l))
        })
        .collect()
}

/// The mean improvement of adding (`sign = 1`) or removing (`−1`) candidate `c` to or from
/// the design factored by `linvs` (D: `Δf`; tip: the decrease of `g`); `None` when a removal
/// would leave a singular design.
fn change(state: &State<'_>, linvs: &[DMatrix<f64>], c: usize, sign: f64) -> Option<f64> {
    let m = state.pool.rows(c);
    let mut sum = 0.0;
    for (d, linv) in linvs.iter().enumerate() {
        let x = linv * state.whitened_t(d, c);
        let h = x.tr_mul(&x);
        let mut a = [0.0; 36];
        for i in 0..m {
            for k in 0..m {
                a[i * m + k] = sign * h[(i, k)] + if i == k { 1.0 } else { 0.0 };
            }
        }
        if !chol(&mut a[..m * m], m) {
            return None;
        }
        sum += match &state.draws[d].tip {
            None => chol_det(&a, m).ln(),
            Some((_, root)) => {
                let y = root * linv.transpose() * &x;
                let f = y.tr_mul(&y);
                let fs: Vec<f64> = (0..m * m).map(|t| f[(t / m, t % m)]).collect();
                sign * chol_trace(&a, m, &fs)
            }
        };
    }
    Some(sum / linvs.len() as f64)
}

/// The `rank`-th best (0: the best) of `cands` to add (`sign = 1`) or remove (`−1`), ties to
/// the lowest index.
fn ranked(
    state: &State<'_>,
    linvs: &[DMatrix<f64>],
    cands: &[usize],
    sign: f64,
    rank: usize,
) -> Option<usize> {
    let mut all: Vec<(usize, f64)> = cands
        .iter()
        .filter_map(|&c| change(state, linvs, c, sign).map(|v| (c, v)))
        .filter(|(_, v)| !v.is_nan())
        .collect();
    all.sort_unstable_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    all.get(rank).map(|&(c, _)| c)
}

/// One excursion of length `k` from the state's design over the `entering` list (up then
/// down, or down then up; the first move takes the `first`-th best candidate, the others the
/// best); the new design and its improvement (D: `Δf`, tip: decrease of `g`), when it
/// differs from the current one.
pub(crate) fn excursion(
    state: &State<'_>,
    entering: &[usize],
    k: usize,
    up_first: bool,
    first: usize,
) -> Result<Option<(Vec<usize>, f64)>, SelectError> {
    if !up_first && k >= state.chosen.len() {
        return Ok(None);
    }
    let roots: Option<Vec<DMatrix<f64>>> = state
        .draws
        .iter()
        .map(|st| st.tip.as_ref().map(|(_, r)| r.clone()))
        .collect();
    let mut t = state.chosen.clone();
    let mut rank = first;
    for up in [up_first, !up_first] {
        for _ in 0..k {
            let linvs = factors(state, &t)?;
            if up {
                let pool: Vec<usize> = entering
                    .iter()
                    .copied()
                    .filter(|c| !t.contains(c))
                    .collect();
                let Some(c) = ranked(state, &linvs, &pool, 1.0, rank) else {
                    return Ok(None);
                };
                t.push(c);
            } else {
                let Some(j) = ranked(state, &linvs, &t, -1.0, rank) else {
                    return Ok(None);
                };
                t.retain(|&c| c != j);
            }
            rank = 0;
        }
    }
    let mut sorted = t.clone();
    sorted.sort_unstable();
    let mut now = state.chosen.clone();
    now.sort_unstable();
    if sorted == now {
        return Ok(None);
    }
    let before = value(state.pool, state.frames, roots.as_deref(), &state.chosen)?;
    let after = value(state.pool, state.frames, roots.as_deref(), &t)?;
    let gain = if roots.is_some() {
        before - after
    } else {
        after - before
    };
    Ok(Some((t, gain)))
}
