//! A Kiefer-Wolfowitz (equivalence theorem) lower bound on the D-efficiency of a chosen
//! design, and the multiplicative algorithm for approximate (continuous) designs.
//!
//! # The bound
//! A continuous design puts weight `wᵢ ≥ 0` (`Σwᵢ = 1`) on candidate `i`; with `N` poses its
//! information is `A_d(w) = G_d + N Σᵢ wᵢ J_dᵢᵀJ_dᵢ` and its criterion the draw average
//! `Φ(w) = (1/D) Σ_d log det A_d(w)` (no regulariser here; [`kw_bound`] averages over the
//! draws where the pool sees every parameter, see [`Bound::draws`]). An exact design `S` of `N`
//! distinct candidates is the design `wᵢ = 1/N` on `S`; since candidates are chosen at most
//! once, exact designs lie in the capped simplex `0 ≤ wᵢ ≤ 1/N`, and `Φ* = max` of `Φ` over
//! it bounds every exact design. The D-efficiency of `S` is `exp((Φ(S) − Φ*)/n)` (the
//! geometric mean over draws of `(det A(S)/det A*)^{1/n}`).
//!
//! For any `w` with `A_d(w)` nonsingular, let `φᵢ = (1/D) Σ_d tr(J_dᵢ A_d⁻¹ J_dᵢᵀ)` and
//! `g = (1/D) Σ_d tr(A_d⁻¹ G_d)`. For the optimum `w*`, `tr(A_d⁻¹A_d*) = tr(A_d⁻¹G_d) +
//! N Σᵢ w*ᵢ tr(J_dᵢA_d⁻¹J_dᵢᵀ)`, and by the AM-GM inequality on the eigenvalues of
//! `A_d⁻¹A_d*`, then Jensen over draws,
//! `Φ* − Φ(w) = (1/D) Σ_d log det(A_d⁻¹A_d*) ≤ n·ln((1/D) Σ_d tr(A_d⁻¹A_d*)/n)
//! ≤ n·ln((g + N Σᵢ w*ᵢ φᵢ)/n) ≤ n·ln((g + s_N)/n) =: U(w) − Φ(w)`,
//! where `s_N` is the sum of the `N` largest `φᵢ` (the largest value of `N Σ w*ᵢφᵢ` over the
//! capped simplex). So `U(w)` is an upper bound on `Φ*` for every `w`, valid for blocks of
//! any rank `m` (only `tr(A⁻¹ JᵢᵀJᵢ) = tr(JᵢA⁻¹Jᵢᵀ)` is used), and
//! `efficiency(S) ≥ exp((Φ(S) − min_w U(w))/n)`. With `G = 0`, one draw and no cap
//! (`s_N = N max φ`, `N φᵢ = dᵢ = tr(Jᵢ M(ξ)⁻¹ Jᵢᵀ)` for `M(ξ) = Σ wᵢJᵢᵀJᵢ`) this is the
//! classical `efficiency ≥ (n / max dᵢ)` bound of the equivalence theorem (`max dᵢ ≥ n`,
//! equality at the optimum). The bound is evaluated at the chosen design itself and at the
//! iterates of the multiplicative algorithm below, and the least `U` is used.
//!
//! # The multiplicative algorithm
//! Titterington's `wᵢ ← wᵢ dᵢ/n`, generalised to the given information and the draw average:
//! `wᵢ ← wᵢ φᵢ / Σⱼ wⱼφⱼ` (for `G = 0`, `Σⱼ wⱼ N φⱼ = n`), from uniform weights; for the capped
//! simplex each step is followed by the projection `wᵢ ← min(λwᵢ, 1/N)` (`λ` so that
//! `Σwᵢ = 1`). The iterates only supply points where `U` is evaluated; the bound holds
//! whatever they are. Each iteration costs `2·P·m·n²·D` flops.

use nalgebra::{DMatrix, DMatrixView};

use super::frame::pool_is_blind;
use super::pool::Pool;
use super::small::{chol_factor, chol_logdet, dot, lower_inverse};
use super::types::{SelectError, SelectOptions};

/// The uniform design's share in the bound's starting weights (the chosen design the rest).
const START_UNIFORM: f64 = 0.05;
/// The bound's iterations stop once one lowers `U/n` (minus the log of the efficiency bound)
/// by less than this: the bound tightens by less than 0.1 %.
const STALL: f64 = 1e-3;

/// The efficiency bound of a chosen design (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    /// Lower bound on the D-efficiency of the chosen design among all designs of as many
    /// distinct candidates, `exp((Φ(S) − U)/n)`, in `[0, 1]`.
    pub efficiency: f64,
    /// `Φ(S)`: the chosen design's mean `log det`, without regulariser, over the bound's
    /// [`Bound::draws`] (so not [`super::Selection::log_det`], which has the regulariser and
    /// every draw).
    pub log_det: f64,
    /// The least upper bound `U` on the optimum `Φ*` found.
    pub upper: f64,
    /// Multiplicative iterations run (at most the number asked for).
    pub iterations: usize,
    /// The draws the bound averages over: those where the pool's mean information sees every
    /// parameter (a draw where the pool is blind to a direction cannot rank designs).
    pub draws: usize,
}

/// An approximate (continuous) design from [`continuous_design`].
#[derive(Clone, Debug, PartialEq)]
pub struct ContinuousDesign {
    /// The weights `wᵢ` (sum 1).
    pub weights: Vec<f64>,
    /// `Φ(w)` at the last iterate.
    pub value: f64,
    /// `N·max φᵢ` at the last iterate; with no given information and one draw this is
    /// `max dᵢ`, which is `≥ n` and tends to `n` as the design tends to the optimum.
    pub max_d: f64,
    /// The least upper bound `U(w)` on the optimum over the iterates (capped simplex when
    /// the design was computed capped, the plain simplex otherwise).
    pub upper: f64,
    /// Iterations run.
    pub iterations: usize,
}

/// `Φ`, `g` and every `φᵢ` of one design.
struct Eval {
    value: f64,
    g: f64,
    phi: Vec<f64>,
}

/// Evaluates the design `A_d = G_d + Σ cᵢ J_dᵢᵀJ_dᵢ` over `(i, cᵢ)`, averaged over `draws`;
/// `None` when singular.
fn eval(pool: &Pool, draws: &[usize], items: &[(usize, f64)], threads: usize) -> Option<Eval> {
    let (p, dn) = (pool.n_candidates(), draws.len());
    let mut out = Eval {
        value: 0.0,
        g: 0.0,
        phi: vec![0.0; p],
    };
    for &d in draws {
        let a = pool.given(d) + weighted_sum(pool, d, items, threads);
        let l = chol_factor(&a)?;
        let linv = lower_inverse(&l);
        out.value += chol_logdet(&l);
        out.g += (linv.transpose() * &linv).dot(pool.given(d));
        add_leverages(pool, d, &linv, threads, &mut out.phi);
    }
    let k = 1.0 / dn as f64;
    out.value *= k;
    out.g *= k;
    out.phi.iter_mut().for_each(|v| *v *= k);
    Some(out)
}

/// `Σ cᵢ J_dᵢᵀJ_dᵢ` over `items`, as partial sums over fixed chunks (over threads) added in
/// chunk order, so the result does not depend on the thread count.
fn weighted_sum(pool: &Pool, d: usize, items: &[(usize, f64)], threads: usize) -> DMatrix<f64> {
    const CHUNK: usize = 4096;
    let n = pool.n_params();
    let part = |chunk: &[(usize, f64)]| {
        let mut a = DMatrix::zeros(n, n);
        pool.accumulate(d, chunk.iter().copied(), &mut a);
        a
    };
    let chunks: Vec<&[(usize, f64)]> = items.chunks(CHUNK).collect();
    let t = threads.clamp(1, chunks.len().max(1));
    let parts: Vec<DMatrix<f64>> = if t == 1 {
        chunks.iter().map(|c| part(c)).collect()
    } else {
        let per = chunks.len().div_ceil(t);
        let groups = chunks.chunks(per).collect();
        crate::cores::map_parts(groups, |group: &[&[(usize, f64)]]| {
            group.iter().map(|c| part(c)).collect::<Vec<_>>()
        })
        .into_iter()
        .flatten()
        .collect()
    };
    parts
        .into_iter()
        .fold(DMatrix::zeros(n, n), |acc, p| acc + p)
}

/// `phiᵢ += ‖L⁻¹J_dᵢᵀ‖²_F` for every candidate, by blocks of matrix products over threads.
fn add_leverages(pool: &Pool, d: usize, linv: &DMatrix<f64>, threads: usize, phi: &mut [f64]) {
    const BLOCK: usize = 256;
    let p = phi.len();
    let n = pool.n_params();
    let work = |start: usize, out: &mut [f64]| {
        let mut a = start;
        while a < start + out.len() {
            let b = (a + BLOCK).min(start + out.len());
            let rows = pool.row_start(b) - pool.row_start(a);
            let xt = linv * DMatrixView::from_slice(pool.span(d, a..b), n, rows);
            let xs = xt.as_slice();
            for c in a..b {
                let r0 = pool.row_start(c) - pool.row_start(a);
                let seg = &xs[r0 * n..(r0 + pool.rows(c)) * n];
                out[c - start] += dot(seg, seg);
            }
            a = b;
        }
    };
    let t = threads.clamp(1, p.div_ceil(BLOCK).max(1));
    if t == 1 {
        work(0, phi);
        return;
    }
    let per = p.div_ceil(BLOCK).div_ceil(t) * BLOCK;
    let parts = phi.chunks_mut(per).enumerate().collect();
    crate::cores::map_parts(parts, |(k, chunk): (usize, &mut [f64])| {
        work(k * per, chunk)
    });
}

/// `U(w) = Φ(w) + n·ln((g + s)/n)`, `s` the sum of the `total` largest `φᵢ` (capped) or
/// `total·max φᵢ`.
fn upper(ev: &Eval, total: usize, n: usize, capped: bool) -> f64 {
    let s = if capped {
        let mut v = ev.phi.clone();
        let k = total.min(v.len());
        if k == 0 {
            0.0
        } else {
            v.select_nth_unstable_by(k - 1, |a, b| b.total_cmp(a));
            v[..k].iter().sum()
        }
    } else {
        total as f64 * ev.phi.iter().copied().fold(0.0, f64::max)
    };
    let nf = n as f64;
    ev.value + nf * ((ev.g + s) / nf).ln()
}

/// `wᵢ ← min(λwᵢ, cap)` with `Σwᵢ = 1` (`cap·P ≥ 1`).
fn project(w: &mut [f64], cap: f64) {
    let mut idx: Vec<usize> = (0..w.len()).collect();
    idx.sort_unstable_by(|&a, &b| w[b].total_cmp(&w[a]).then(a.cmp(&b)));
    let mut rest: f64 = w.iter().sum();
    for (c, &top) in idx.iter().enumerate() {
        let left = (1.0 - c as f64 * cap).max(0.0);
        if rest <= 0.0 {
            let each = left / (w.len() - c) as f64;
            idx[c..].iter().for_each(|&i| w[i] = each.min(cap));
            return;
        }
        let lambda = left / rest;
        if lambda * w[top] <= cap {
            idx[c..].iter().for_each(|&i| w[i] *= lambda);
            idx[..c].iter().for_each(|&i| w[i] = cap);
            return;
        }
        rest -= w[top];
    }
    w.iter_mut().for_each(|v| *v = cap);
}

/// The approximate D-optimal design for `total` poses on the pool by the multiplicative
/// algorithm (see the module documentation), `iterations` steps from uniform weights, on the
/// capped simplex `wᵢ ≤ 1/total` when `capped`. `None` when the pool's information (with
/// the given) is singular.
///
/// # Errors
/// [`SelectError::TooFewCandidates`] when `capped` and `total > P`, or `total = 0`.
pub fn continuous_design(
    pool: &Pool,
    total: usize,
    iterations: usize,
    capped: bool,
    opts: &SelectOptions,
) -> Result<Option<ContinuousDesign>, SelectError> {
    let p = pool.n_candidates();
    if total == 0 || p == 0 || (capped && total > p) {
        return Err(SelectError::TooFewCandidates {
            wanted: total,
            pool: p,
        });
    }
    let w = vec![1.0 / p as f64; p];
    let draws: Vec<usize> = (0..pool.n_draws()).collect();
    Ok(iterate(
        pool, &draws, total, iterations, capped, opts, w, None,
    ))
}

/// The multiplicative algorithm of [`continuous_design`] from weights `w` (sum 1, capped
/// when `capped`), for at most `iterations` steps; with `stall`, it stops early once two
/// steps in a row lower the least upper bound `U` by less than `stall`.
#[allow(clippy::too_many_arguments)]
fn iterate(
    pool: &Pool,
    draws: &[usize],
    total: usize,
    iterations: usize,
    capped: bool,
    opts: &SelectOptions,
    mut w: Vec<f64>,
    stall: Option<f64>,
) -> Option<ContinuousDesign> {
    let p = pool.n_candidates();
    let threads = opts.thread_count(p * pool.n_draws());
    let n = pool.n_params();
    let mut best = f64::INFINITY;
    let mut stalls = 0;
    for it in 0..=iterations {
        let items: Vec<(usize, f64)> = w
            .iter()
            .enumerate()
            .filter(|(_, &v)| v > 0.0)
            .map(|(i, &v)| (i, v * total as f64))
            .collect();
        let ev = eval(pool, draws, &items, threads)?;
        let before = best;
        best = best.min(upper(&ev, total, n, capped));
        // `U` along the iterates need not fall monotonically: two stalled steps in a row.
        if stall.is_some_and(|t| it > 0 && before - best < t) {
            stalls += 1;
        } else {
            stalls = 0;
        }
        if it == iterations || stalls >= 2 {
            let max = ev.phi.iter().copied().fold(0.0, f64::max);
            return Some(ContinuousDesign {
                weights: w,
                value: ev.value,
                max_d: total as f64 * max,
                upper: best,
                iterations: it,
            });
        }
        let norm: f64 = w.iter().zip(&ev.phi).map(|(a, b)| a * b).sum();
        if !(norm > 0.0 && norm.is_finite()) {
            return None;
        }
        w.iter_mut().zip(&ev.phi).for_each(|(a, b)| *a *= b / norm);
        if capped {
            project(&mut w, 1.0 / total as f64);
        }
    }
    None
}

/// The Kiefer-Wolfowitz lower bound on the D-efficiency of the exact design `chosen` among
/// designs of as many distinct candidates (see the module documentation), from the bound at
/// the design itself and at up to `iterations` capped multiplicative iterates, started at
/// `0.95·S + 0.05·uniform` and stopped once two in a row tighten the bound by less than 0.1 %
/// ([`Bound::iterations`] says how many ran). `None` when
/// `chosen` is empty or its information (given included, no regulariser) is singular.
///
/// # Errors
/// [`SelectError::BadCandidate`] for an index out of range or repeated.
pub fn kw_bound(
    pool: &Pool,
    chosen: &[usize],
    iterations: usize,
    opts: &SelectOptions,
) -> Result<Option<Bound>, SelectError> {
    pool.check_chosen(chosen)?;
    let total = chosen.len();
    if total == 0 {
        return Ok(None);
    }
    let n = pool.n_params();
    let threads = opts.thread_count(pool.n_candidates() * pool.n_draws());
    // A draw where the pool itself barely sees a direction (a PUMA's `θ6` at nominals with
    // `a5 = a6 = 0`) gives every design a `log det` ruled by rounding: it cannot rank
    // designs, and its factorisations fail at random. The bound is over the other draws.
    let draws: Vec<usize> = (0..pool.n_draws())
        .filter(|&d| !pool_is_blind(pool.mean_information(d)))
        .collect();
    if draws.is_empty() {
        return Ok(None);
    }
    let items: Vec<(usize, f64)> = chosen.iter().map(|&i| (i, 1.0)).collect();
    let Some(ev) = eval(pool, &draws, &items, threads) else {
        return Ok(None);
    };
    let mut u = upper(&ev, total, n, true);
    let mut run = 0;
    if iterations > 0 {
        // Started at the chosen design itself, mixed with a little of the uniform design so
        // that every candidate keeps weight, the iterates reach a tighter `U` in a third of
        // the steps a uniform start needs (6 against 30 for the Panda pinned at a point,
        // 10⁵ candidates, N = 200); they stop once two steps in a row tighten the bound on
        // the efficiency by less than 0.1 % (relative).
        let p = pool.n_candidates();
        let mut w = vec![START_UNIFORM / p as f64; p];
        for &i in chosen {
            w[i] += (1.0 - START_UNIFORM) / total as f64;
        }
        let stall = STALL * n as f64;
        if let Some(c) = iterate(pool, &draws, total, iterations, true, opts, w, Some(stall)) {
            u = u.min(c.upper);
            run = c.iterations;
        }
    }
    let efficiency = ((ev.value - u) / n as f64).exp().clamp(0.0, 1.0);
    Ok(Some(Bound {
        efficiency,
        log_det: ev.value,
        upper: u,
        iterations: run,
        draws: draws.len(),
    }))
}
