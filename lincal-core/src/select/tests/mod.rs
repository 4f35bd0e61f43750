//! Tests of pose selection: shared pool builders and from-scratch reference computations.

mod core;
mod extra;
mod perf;
mod whiten;

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Pool;

/// A random pool: `p` candidates of `rows(i)` rows, `n` parameters, `draws` draws (draw
/// `d > 0` is draw 0 perturbed by 10 %), and a positive definite given information when
/// `given`.
pub(super) fn random_pool(
    p: usize,
    n: usize,
    rows: impl Fn(usize) -> usize,
    draws: usize,
    seed: u64,
    given: bool,
) -> Pool {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let base: Vec<DMatrix<f64>> = (0..p)
        .map(|i| DMatrix::from_fn(rows(i), n, |_, _| rng.gen_range(-1.0..1.0)))
        .collect();
    let blocks: Vec<Vec<DMatrix<f64>>> = (0..draws)
        .map(|d| {
            base.iter()
                .map(|b| {
                    if d == 0 {
                        b.clone()
                    } else {
                        b.map(|v| v + 0.1 * rng.gen_range(-1.0..1.0))
                    }
                })
                .collect()
        })
        .collect();
    let pool = Pool::from_blocks(n, &blocks).expect("pool");
    if !given {
        return pool;
    }
    let g = (0..draws)
        .map(|_| {
            let x = DMatrix::from_fn(2 * n, n, |_, _| rng.gen_range(-1.0..1.0));
            x.transpose() * x * 0.5
        })
        .collect();
    pool.with_given(g).expect("given")
}

/// Candidate `i`'s block of draw `d` as a matrix.
pub(super) fn block(pool: &Pool, d: usize, i: usize) -> DMatrix<f64> {
    DMatrix::from_row_slice(pool.rows(i), pool.n_params(), pool.block(d, i))
}

/// The documented regulariser `R_d = ε(M̄_d + τI)`, computed directly.
pub(super) fn regulariser(pool: &Pool, d: usize, ridge: f64) -> DMatrix<f64> {
    let n = pool.n_params();
    let p = pool.n_candidates();
    let mut mean = DMatrix::zeros(n, n);
    for i in 0..p {
        let j = block(pool, d, i);
        mean += j.transpose() * &j;
    }
    mean /= p as f64;
    let tau = 1e-10 * mean.trace() / n as f64;
    (mean + DMatrix::identity(n, n) * tau) * ridge
}

/// `G_d + R_d + Σ_{i∈S} JᵢᵀJᵢ`, directly.
pub(super) fn direct_info(pool: &Pool, d: usize, set: &[usize], ridge: f64) -> DMatrix<f64> {
    let mut m = pool.given(d) + regulariser(pool, d, ridge);
    for &i in set {
        let j = block(pool, d, i);
        m += j.transpose() * &j;
    }
    m
}

/// `f(S)` from LU determinants.
pub(super) fn direct_f(pool: &Pool, set: &[usize], ridge: f64) -> f64 {
    let dn = pool.n_draws();
    (0..dn)
        .map(|d| direct_info(pool, d, set, ridge).determinant().ln())
        .sum::<f64>()
        / dn as f64
}

/// `g(S) = mean tr(T M⁻¹ Tᵀ) = mean ‖L⁻¹Tᵀ‖²` from Cholesky factors `M = LLᵀ`.
pub(super) fn direct_g(pool: &Pool, set: &[usize], ridge: f64, t: &[DMatrix<f64>]) -> f64 {
    let dn = pool.n_draws();
    (0..dn)
        .map(|d| {
            let chol = nalgebra::Cholesky::new(direct_info(pool, d, set, ridge)).expect("chol");
            let x = chol
                .l()
                .solve_lower_triangular(&t[d].transpose())
                .expect("solve");
            x.norm_squared()
        })
        .sum::<f64>()
        / dn as f64
}

/// Random tip matrices (`k × n`, one per draw).
pub(super) fn random_tip(pool: &Pool, k: usize, seed: u64) -> Vec<DMatrix<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..pool.n_draws())
        .map(|_| DMatrix::from_fn(k, pool.n_params(), |_, _| rng.gen_range(-1.0..1.0)))
        .collect()
}

/// `|a − b| ≤ tol·max(|b|, floor)`.
pub(super) fn close(a: f64, b: f64, tol: f64, floor: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(floor)
}
