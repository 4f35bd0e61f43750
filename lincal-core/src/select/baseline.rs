//! What a chosen design is worth: predicted parameter standard deviations, the same numbers
//! for random designs of the pool (the baseline), and how many random poses it takes to
//! match the chosen design.

use nalgebra::{DMatrix, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::frame::{frames, value, whitened_tip, Frame};
use super::pool::Pool;
use super::small::{chol_factor, chol_logdet, lower_inverse};
use super::types::{Criterion, SelectError, SelectOptions};

/// Eigenvalues at most this fraction of the largest count as zero in [`predicted_std`].
const RANK_TOL: f64 = 1e-12;
/// An eigenvector component above this marks a parameter as touched by a deficient direction.
const TOUCH: f64 = 1e-6;

/// Per-parameter predicted standard deviations `σⱼ = √((M⁻¹)ⱼⱼ)` of an information matrix
/// `M` (the blocks are whitened, so `M⁻¹` is the parameters' covariance).
///
/// Rank-deficient `M` (convention): with `M = VΛVᵀ`, eigenvalues `λₖ ≤ 1e-12·λ_max`
/// (negative ones included) are deficient directions; a parameter whose components in them
/// have norm `> 1e-6` is not determined and gets `f64::INFINITY`; the others get
/// `√(Σ_{k not deficient} Vⱼₖ²/λₖ)` (the pseudo-inverse's diagonal). A zero matrix gives all
/// `INFINITY`. A full-rank `M` gives `√((M⁻¹)ⱼⱼ)` from its Cholesky factor.
///
/// # Errors
/// [`SelectError::Shape`] for a non-square matrix, [`SelectError::NonFiniteInput`] for a
/// NaN or infinity.
pub fn predicted_std(info: &DMatrix<f64>) -> Result<Vec<f64>, SelectError> {
    let n = info.nrows();
    if info.ncols() != n {
        return Err(SelectError::Shape(
            "information matrix is not square".into(),
        ));
    }
    if info.iter().any(|v| !v.is_finite()) {
        return Err(SelectError::NonFiniteInput {
            what: "information matrix",
            index: 0,
        });
    }
    let sym = (info + info.transpose()) * 0.5;
    let eig = SymmetricEigen::new(sym.clone());
    let lmax = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    let deficient = |l: f64| !(l > RANK_TOL * lmax && lmax > 0.0);
    if !eig.eigenvalues.iter().any(|&l| deficient(l)) {
        if let Some(l) = chol_factor(&sym) {
            let li = lower_inverse(&l);
            return Ok((0..n).map(|j| li.column(j).norm()).collect());
        }
    }
    Ok((0..n)
        .map(|j| {
            let mut var = 0.0;
            let mut lost = 0.0;
            for (k, &l) in eig.eigenvalues.iter().enumerate() {
                let v = eig.eigenvectors[(j, k)];
                if deficient(l) {
                    lost += v * v;
                } else {
                    var += v * v / l;
                }
            }
            if lost.sqrt() > TOUCH {
                f64::INFINITY
            } else {
                var.sqrt()
            }
        })
        .collect())
}

/// The medians of [`baseline`].
#[derive(Clone, Debug, PartialEq)]
pub struct Baseline {
    /// Median over the random designs of the criterion (as [`crate::select::evaluate`]).
    pub value: f64,
    /// Per parameter, the median over the random designs of its predicted standard deviation
    /// ([`predicted_std`] of the nominal draw's information, given included, no
    /// regulariser; `INFINITY` when not determined).
    pub std: Vec<f64>,
    /// Random designs drawn.
    pub replicates: usize,
}

/// The baseline: `replicates` random designs of `count` distinct candidates (uniform,
/// ChaCha8 seeded with `seed`), and the medians of their criterion and of each parameter's
/// predicted standard deviation. Medians of an even count average the middle two.
///
/// # Errors
/// [`SelectError::TooFewCandidates`] for `count > P`, [`SelectError::BadOption`] for no
/// replicate or bad options, the tip-matrix checks.
pub fn baseline(
    pool: &Pool,
    count: usize,
    criterion: &Criterion,
    opts: &SelectOptions,
    replicates: usize,
    seed: u64,
) -> Result<Baseline, SelectError> {
    opts.check()?;
    pool.check_count(count)?;
    let p = pool.n_candidates();
    if replicates == 0 {
        return Err(SelectError::BadOption("at least one replicate"));
    }
    let fr = frames(pool, opts.ridge)?;
    let tip = whitened_tip(pool, &fr, criterion)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut values = Vec::with_capacity(replicates);
    let mut stds = vec![Vec::with_capacity(replicates); pool.n_params()];
    for _ in 0..replicates {
        let set = rand::seq::index::sample(&mut rng, p, count).into_vec();
        values.push(value(pool, &fr, tip.as_deref(), &set)?);
        let s = predicted_std(&pool.information(0, &set)?)?;
        for (acc, v) in stds.iter_mut().zip(s) {
            acc.push(v);
        }
    }
    Ok(Baseline {
        value: median(&mut values),
        std: stds.iter_mut().map(|v| median(v)).collect(),
        replicates,
    })
}

/// The median of `v` (the mean of the middle two for an even count; NaN when empty).
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    let h = v.len() / 2;
    if v.len() % 2 == 1 {
        v[h]
    } else {
        0.5 * (v[h - 1] + v[h])
    }
}

/// The D criterion `f` of the design whose raw information sums (without `G`) are `sums`.
fn f_of(fr: &[Frame], sums: &[DMatrix<f64>]) -> f64 {
    let mut total = 0.0;
    for (frame, s) in fr.iter().zip(sums) {
        let mut m = frame.w.transpose() * s * &frame.w + &frame.given;
        for k in 0..m.nrows() {
            m[(k, k)] += frame.eps;
        }
        super::pool::symmetrize(&mut m);
        total += match chol_factor(&m) {
            Some(l) => chol_logdet(&l) + frame.shift,
            // Summed over a whole pool, rounding in a direction the pool barely sees can
            // reach `−ε`; the eigenvalues, floored at the regulariser, give the value.
            None => {
                let e = nalgebra::SymmetricEigen::new(m).eigenvalues;
                e.iter().map(|v| v.max(frame.eps).ln()).sum::<f64>() + frame.shift
            }
        };
    }
    total / fr.len() as f64
}

/// `sums_d += Σ J_dᵢᵀJ_dᵢ` over `cands`.
fn add_to(pool: &Pool, sums: &mut [DMatrix<f64>], cands: &[usize]) {
    for (d, s) in sums.iter_mut().enumerate() {
        pool.accumulate(d, cands.iter().map(|&i| (i, 1.0)), s);
    }
}

/// "Worth": the smallest number `k` of random poses such that at least half of
/// `replicates` random `k`-designs reach D criterion `target` (e.g. the chosen design's
/// [`crate::select::Selection::log_det`]) — the median random design of `k` poses is as good.
/// `None` when even the whole pool falls short.
///
/// Each replicate is one random order of the pool (ChaCha8 seeded with `seed`, one stream
/// over the replicates) and its `k`-designs are the prefixes, so its criterion grows with
/// `k`; its threshold `kᵣ` is found by doubling then bisection, adding information
/// incrementally (`O(kᵣ·m·n² + n³·log kᵣ)` per draw). The answer is the `⌈R/2⌉`-th smallest
/// `kᵣ`.
///
/// # Errors
/// [`SelectError::BadOption`] for no replicate, a non-finite target or bad options.
pub fn worth(
    pool: &Pool,
    target: f64,
    opts: &SelectOptions,
    replicates: usize,
    seed: u64,
) -> Result<Option<usize>, SelectError> {
    opts.check()?;
    if replicates == 0 {
        return Err(SelectError::BadOption("at least one replicate"));
    }
    if !target.is_finite() {
        return Err(SelectError::BadOption("worth needs a finite target"));
    }
    let (p, n) = (pool.n_candidates(), pool.n_params());
    let fr = frames(pool, opts.ridge)?;
    let zero = vec![DMatrix::zeros(n, n); pool.n_draws()];
    if f_of(&fr, &zero) >= target {
        return Ok(Some(0));
    }
    let all: Vec<DMatrix<f64>> = (0..pool.n_draws())
        .map(|d| pool.mean_information(d) * p as f64)
        .collect();
    if f_of(&fr, &all) < target {
        return Ok(None);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut ks: Vec<usize> = (0..replicates)
        .map(|_| threshold(pool, &fr, &zero, target, &mut rng))
        .collect();
    ks.sort_unstable();
    Ok(Some(ks[replicates.div_ceil(2) - 1]))
}

/// One replicate of [`worth`]: the smallest prefix of a random order reaching `target`
/// (`P` at most).
fn threshold(
    pool: &Pool,
    fr: &[Frame],
    zero: &[DMatrix<f64>],
    target: f64,
    rng: &mut ChaCha8Rng,
) -> usize {
    let p = pool.n_candidates();
    let mut perm: Vec<usize> = (0..p).collect();
    let mut made = 0;
    let mut extend = |perm: &mut Vec<usize>, to: usize| {
        while made < to {
            let j = rng.gen_range(made..p);
            perm.swap(made, j);
            made += 1;
        }
    };
    let (mut lo, mut sums_lo) = (0, zero.to_vec());
    let mut k = 1.min(p);
    let mut hi = p;
    while k <= p {
        extend(&mut perm, k);
        let mut s = sums_lo.clone();
        add_to(pool, &mut s, &perm[lo..k]);
        if f_of(fr, &s) >= target || k == p {
            hi = k;
            break;
        }
        (lo, sums_lo) = (k, s);
        k = (2 * k).min(p);
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        let mut s = sums_lo.clone();
        add_to(pool, &mut s, &perm[lo..mid]);
        if f_of(fr, &s) >= target {
            hi = mid;
        } else {
            (lo, sums_lo) = (mid, s);
        }
    }
    hi
}
