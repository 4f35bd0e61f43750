//! The Levenberg-Marquardt core that extraction, refinement and the parameter-space fit share,
//! and the gauge-fixed unknowns ([`FreeSet`]) it moves.
//!
//! # Why a Levenberg-Marquardt of our own
//! The `levenberg-marquardt` crate needs the whole `m × n` Jacobian in memory; a million poses
//! of a 30-parameter arm is 240 MB. Here every linearisation is folded into the `n × n` factor
//! `R` of a QR of `[J | r]`, streamed pose by pose ([`StreamingQr`]), so memory is `O(n²)`
//! however many poses there are, and the normal equations are never formed. The step solves
//! `min ‖R·δ + z‖² + μ‖D·δ‖²` (Marquardt's scaling `D = diag` of the largest column norms of
//! `J` seen so far) by QR of the stacked `2n × n` system (SVD where that is singular); `μ`
//! follows Nielsen's update. Both the extraction and the refinement use this core. Fits of
//! noisy data ([`LeastSquares::residual_rows`]) also stop by Bates and Watts' relative-offset
//! test ([`within_offset`]), their last Gauss-Newton step checked by its cost alone.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::model::CalibModel;
use crate::numeric::linalg::{checked_svd, StreamingQr};

/// A linearised least-squares problem at a point, compressed: `‖J·δ + r‖² = ‖R·δ + z‖² + ρ²`
/// with `R` upper triangular `n × n`, and the cost `‖r‖²`.
#[derive(Clone, Debug)]
pub(crate) struct Linearization {
    pub r: DMatrix<f64>,
    pub z: DVector<f64>,
    pub cost: f64,
}

impl Linearization {
    /// Compresses rows `[J_i | r_i]` pushed into a `StreamingQr` of `n + 1` columns.
    pub fn from_qr(qr: &mut StreamingQr, cost: f64) -> Self {
        let n = qr.cols() - 1;
        let full = qr.finish();
        Linearization {
            r: full.view((0, 0), (n, n)).into_owned(),
            z: full.view((0, n), (n, 1)).column(0).into_owned(),
            cost,
        }
    }
}

/// A least-squares problem in `n` unknowns.
pub(crate) trait LeastSquares {
    /// Number of unknowns.
    fn unknowns(&self) -> usize;
    /// `‖r(x)‖²`, `+∞` when not finite.
    fn cost(&self, x: &[f64]) -> f64;
    /// The compressed linearisation at `x`.
    fn linearize(&self, x: &[f64]) -> Result<Linearization>;
    /// The number `m` of residual rows, when the problem is a statistical fit whose
    /// residual holds noise: it turns on the relative-offset test of convergence
    /// ([`within_offset`]). `None` (the default) for problems fitted to exactness. Asked
    /// once per run: it must not change while the problem is fitted.
    fn residual_rows(&self) -> Option<usize> {
        None
    }
}

/// Outcome of [`levenberg_marquardt`].
#[derive(Clone, Debug)]
pub(crate) struct LmResult {
    pub x: Vec<f64>,
    /// The cost at `x`.
    pub cost: f64,
    /// Linearisation at `x`, or, when the relative-offset test ended the run
    /// ([`LeastSquares::residual_rows`]), at the point one Gauss-Newton step before it, less
    /// than `τ·√n` standard errors away.
    pub lin: Linearization,
    /// The cost at the start, from its linearisation.
    pub start_cost: f64,
    pub iterations: usize,
}

/// Relative change of the cost below which the minimum is reached: far below any statistical
/// meaning (the cost's own noise is of relative order `1/√m`), above rounding.
const FTOL: f64 = 1e-12;

/// The relative-offset tolerance of [`within_offset`]: Bates and Watts' (1981) value.
const RELATIVE_OFFSET: f64 = 1e-3;

/// Bates and Watts' relative-offset test (*A relative offset orthogonality convergence
/// criterion for nonlinear least squares*, Technometrics 23, 1981): the residual's part in the
/// tangent plane of the model, per parameter, against its part orthogonal to it, per degree of
/// freedom,
/// `√(‖Q₁ᵀr‖²/n) / √(‖Q₂ᵀr‖²/(m − n)) ≤ τ`.
/// Here `‖Q₁ᵀr‖² = ‖z‖²` (the Gauss-Newton step's predicted gain) and `‖Q₂ᵀr‖² = cost − ‖z‖²`.
/// When it holds, the Gauss-Newton step from `lin`'s point moves the estimate by at most
/// `τ·√n` standard errors in any direction (its Mahalanobis length is `‖z‖/σ̂`): the point is
/// statistically at the minimum, and the step left is checked by the cost alone, without the
/// Jacobians of a further linearisation. Unlike a relative cost change it does not depend on
/// how far the last step went, and it is invariant to the parameters' units. Never true on
/// data without noise (`‖Q₂ᵀr‖ = 0`), where the other tests decide.
fn within_offset(lin: &Linearization, m: usize, n: usize) -> bool {
    if m <= n || n == 0 {
        return false;
    }
    let tangent = lin.z.norm_squared();
    let orthogonal = lin.cost - tangent;
    orthogonal > 0.0
        && tangent * (m - n) as f64 <= RELATIVE_OFFSET * RELATIVE_OFFSET * n as f64 * orthogonal
}

/// Minimises `‖r(x)‖²` from `x0` (see the module docs).
pub(crate) fn levenberg_marquardt(
    problem: &dyn LeastSquares,
    x0: &[f64],
    max_iterations: usize,
) -> Result<LmResult> {
    let n = problem.unknowns();
    let mut x = x0.to_vec();
    let mut lin = problem.linearize(&x)?;
    if !lin.cost.is_finite() {
        return Err(Error::other(
            "the residual is not finite at the starting point",
        ));
    }
    let start_cost = lin.cost;
    // Asked once: the count does not change while the fit iterates.
    let rows = problem.residual_rows();
    // The cost after a last step checked by its cost alone (the relative-offset test).
    let mut last = None;
    let mut damping = Damping {
        d: vec![0.0f64; n],
        mu: 1e-3,
        nu: 2.0,
    };
    let mut iterations = 0;
    while iterations < max_iterations {
        crate::cancel::check()?;
        iterations += 1;
        if lin.cost == 0.0 || n == 0 {
            break;
        }
        if at_stationary_point(&lin, &mut damping.d) {
            break;
        }
        if rows.is_some_and(|m| within_offset(&lin, m, n)) {
            // The last step, well inside the model's range of validity: the undamped
            // Gauss-Newton step (the damping may still be at its start, which would shorten
            // it), checked by the cost alone, a pass without Jacobians; kept when it does not
            // raise the cost, so `x` is where a checked, linearised step would put it.
            let delta = damped_step(&lin, &damping.d, 0.0)?;
            let xn: Vec<f64> = x.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            let cost_new = problem.cost(&xn);
            if cost_new <= lin.cost {
                x = xn;
                last = Some(cost_new);
                break;
            }
        }
        if step(problem, &mut x, &mut lin, &mut damping)? {
            break;
        }
    }
    Ok(LmResult {
        cost: last.unwrap_or(lin.cost),
        x,
        lin,
        start_cost,
        iterations,
    })
}

/// The state of the damping: Marquardt's scaling `D` (the largest column norms of `J` seen so
/// far), the damping `μ` and its growth factor `ν` (Nielsen's update).
struct Damping {
    d: Vec<f64>,
    mu: f64,
    nu: f64,
}

/// Raises the scaling `d` to the column norms of `lin`'s `J`; `true` when the point is
/// already stationary: `J` is zero, or `r` is orthogonal to every column of `J` (the gradient
/// test).
fn at_stationary_point(lin: &Linearization, d: &mut [f64]) -> bool {
    let n = d.len();
    // Marquardt scaling: the largest column norms of J seen so far.
    let norms: Vec<f64> = (0..n).map(|c| lin.r.column(c).norm()).collect();
    let nmax = norms.iter().copied().fold(0.0, f64::max);
    if nmax == 0.0 {
        return true;
    }
    for (di, &ni) in d.iter_mut().zip(&norms) {
        *di = di.max(ni).max(1e-12 * nmax);
    }
    // Gradient test: cosine between r and each column of J.
    let g = lin.r.transpose() * &lin.z;
    let gmax = (0..n)
        .map(|i| g[i].abs() / (norms[i].max(1e-300) * lin.cost.sqrt()))
        .fold(0.0, f64::max);
    gmax <= 1e-13
}

/// Damped trial steps from `x` until one lowers the cost enough (`x` and `lin` then move
/// there and the damping falls) or the damping gives up (it rises on each rejection).
/// Returns whether the minimum is reached: a step or a gain too small to matter, a
/// rejected step that could gain nothing measurable, or the damping at its limit.
fn step(
    problem: &dyn LeastSquares,
    x: &mut Vec<f64>,
    lin: &mut Linearization,
    damping: &mut Damping,
) -> Result<bool> {
    loop {
        let delta = damped_step(lin, &damping.d, damping.mu)?;
        let xn: Vec<f64> = x.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
        // The trial point is linearised at once (its cost comes with it): most trials
        // are accepted, and one pass over the data then serves both the test and the
        // next step. A trial whose linearisation fails is rejected like an infinite cost.
        let trial = problem.linearize(&xn).ok().filter(|l| l.cost.is_finite());
        let cost_new = trial.as_ref().map_or(f64::INFINITY, |l| l.cost);
        let lin_res = &lin.r * &delta + &lin.z;
        let pred = lin.z.norm_squared() - lin_res.norm_squared();
        let act = lin.cost - cost_new;
        let rho = gain_ratio(cost_new, act, pred);
        if rho > 1e-4 {
            damping.mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1e-3);
            damping.nu = 2.0;
            let dx = scaled_norm(delta.iter(), &damping.d);
            let dxx = scaled_norm(x.iter(), &damping.d);
            let small_step = dx <= 1e-13 * dxx || dx == 0.0;
            let small_gain = act <= FTOL * lin.cost && pred <= FTOL * lin.cost;
            *x = xn;
            if let Some(t) = trial {
                *lin = t;
            }
            return Ok(small_step || small_gain);
        } else if pred <= FTOL * lin.cost && act.abs() <= FTOL * lin.cost {
            // A step that could gain nothing measurable and changed the cost only by
            // rounding: the minimum, whatever the damping (without this test the damping
            // would be raised to its limit, one wasted pass over the data per raise).
            return Ok(true);
        } else {
            damping.mu *= damping.nu;
            damping.nu *= 2.0;
            if damping.nu > 1e15 || damping.mu > 1e30 {
                return Ok(true);
            }
        }
    }
}

/// The ratio `ρ` of the actual to the predicted gain of a trial step (`−1` for a trial whose
/// cost is not finite, or a gain neither predicted nor achieved).
fn gain_ratio(cost_new: f64, act: f64, pred: f64) -> f64 {
    if !cost_new.is_finite() {
        -1.0
    } else if pred > 0.0 {
        act / pred
    } else if act > 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// `‖D·v‖`: the norm of `v` scaled entrywise by `d`.
fn scaled_norm<'a>(v: impl Iterator<Item = &'a f64>, d: &[f64]) -> f64 {
    v.zip(d).map(|(a, b)| (a * b) * (a * b)).sum::<f64>().sqrt()
}

/// `argmin_δ ‖R·δ + z‖² + μ‖D·δ‖²`: the least-squares solution of the stacked `2n × n`
/// system `[R; √μ·D]·δ = [−z; 0]`. `R` is already triangular, so each row `√μ·d_i·e_iᵀ` is
/// rotated into it by Givens rotations against rows `i, i+1, …` (the fill-in moves right),
/// as MINPACK's `qrsolv` does: about `2n³/3` operations where a Householder QR of the
/// stacked matrix takes `10n³/3`, and every trial step pays it. With `D > 0` and `μ > 0`
/// the system has full rank; when rounding has made it numerically singular (a triangular
/// factor with a diagonal entry below `2n·ε` of the largest) the SVD's truncated solution
/// is taken instead.
fn damped_step(lin: &Linearization, d: &[f64], mu: f64) -> Result<DVector<f64>> {
    let n = d.len();
    if let Some(delta) = rotated_solve(&lin.r, &lin.z, d, mu.sqrt()) {
        return Ok(delta);
    }
    let mut m = DMatrix::zeros(2 * n, n);
    m.view_mut((0, 0), (n, n)).copy_from(&lin.r);
    let s = mu.sqrt();
    for i in 0..n {
        m[(n + i, i)] = s * d[i];
    }
    let mut rhs = DVector::zeros(2 * n);
    for i in 0..n {
        rhs[i] = -lin.z[i];
    }
    let svd = checked_svd(m, true, true)?;
    let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
    svd.solve(&rhs, 2.0 * n as f64 * f64::EPSILON * smax)
        .map_err(|e| Error::other(e.to_string()))
}

/// [`damped_step`] by Givens rotations of the rows `s·d_i·e_iᵀ` into the upper triangle of
/// `r`, then back substitution; `None` when the triangular factor is numerically singular
/// or anything is not finite.
fn rotated_solve(r: &DMatrix<f64>, z: &DVector<f64>, d: &[f64], s: f64) -> Option<DVector<f64>> {
    let n = d.len();
    // Column-major upper triangle: `t[i + j·n]`, `i ≤ j`.
    let mut t = vec![0.0; n * n];
    for j in 0..n {
        for i in 0..=j {
            t[i + j * n] = r[(i, j)];
        }
    }
    let mut b: Vec<f64> = z.iter().map(|v| -v).collect();
    let mut row = vec![0.0; n];
    for i in 0..n {
        let di = s * d[i];
        if di == 0.0 {
            continue;
        }
        row[i..].fill(0.0);
        row[i] = di;
        let mut beta = 0.0;
        for k in i..n {
            if row[k] == 0.0 {
                continue;
            }
            // The rotation taking (t_kk, row_k) to (ρ, 0).
            let (a, c) = (t[k + k * n], row[k]);
            let rho = a.hypot(c);
            let (cos, sin) = (a / rho, c / rho);
            t[k + k * n] = rho;
            row[k] = 0.0;
            for j in k + 1..n {
                let (x, y) = (t[k + j * n], row[j]);
                t[k + j * n] = cos * x + sin * y;
                row[j] = cos * y - sin * x;
            }
            let (x, y) = (b[k], beta);
            b[k] = cos * x + sin * y;
            beta = cos * y - sin * x;
        }
    }
    let dmax = (0..n).map(|i| t[i + i * n].abs()).fold(0.0, f64::max);
    let tol = 2.0 * n as f64 * f64::EPSILON * dmax;
    if !dmax.is_finite() || dmax == 0.0 || (0..n).any(|i| t[i + i * n].abs() <= tol) {
        return None;
    }
    for i in (0..n).rev() {
        let mut v = b[i];
        for j in i + 1..n {
            v -= t[i + j * n] * b[j];
        }
        b[i] = v / t[i + i * n];
    }
    b.iter()
        .all(|v| v.is_finite())
        .then(|| DVector::from_vec(b))
}

/// Covariance `σ̂²·(RᵀR)⁻¹` of the free parameters from a compressed linearisation, or
/// `None` when `R` is singular.
pub(crate) fn covariance(r: &DMatrix<f64>, sigma2: f64) -> Option<DMatrix<f64>> {
    let n = r.nrows();
    let rinv = r.clone().solve_upper_triangular(&DMatrix::identity(n, n))?;
    let cov = &rinv * rinv.transpose() * sigma2;
    cov.iter().all(|v| v.is_finite()).then_some(cov)
}

/// The free parameters and the full-vector template.
#[derive(Clone, Debug)]
pub(crate) struct FreeSet {
    /// Indices (into the model's `p`) of the free parameters.
    pub free: Vec<usize>,
    /// The full `p` with held parameters at their nominal.
    pub template: Vec<f64>,
}

impl FreeSet {
    pub fn new(model: &dyn CalibModel, start: &[f64]) -> Self {
        let free = (0..model.param_count())
            .filter(|&j| !model.param_held(j))
            .collect();
        FreeSet {
            free,
            template: start.to_vec(),
        }
    }

    pub fn full(&self, x: &[f64]) -> Vec<f64> {
        let mut p = self.template.clone();
        for (&j, &v) in self.free.iter().zip(x) {
            p[j] = v;
        }
        p
    }

    pub fn take(&self, p: &[f64]) -> Vec<f64> {
        self.free.iter().map(|&j| p[j]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// `y_l = a·exp(b·t_l) + noise` at 200 readings, with or without the relative-offset test;
    /// counts its linearisations.
    struct Exponential {
        t: Vec<f64>,
        y: Vec<f64>,
        offset_test: bool,
        linearized: Cell<usize>,
    }

    impl Exponential {
        fn new(offset_test: bool) -> Self {
            // Noise of std about 0.01 from a fixed linear congruential sequence (sums of four
            // uniforms), so the test is the same on every run.
            let mut state = 12_345u64;
            let mut uniform = || {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let t: Vec<f64> = (0..200).map(|l| f64::from(l) / 199.0).collect();
            let y = t
                .iter()
                .map(|&t| 2.0 * (-1.3 * t).exp() + 0.017 * (0..4).map(|_| uniform()).sum::<f64>())
                .collect();
            Exponential {
                t,
                y,
                offset_test,
                linearized: Cell::new(0),
            }
        }
    }

    impl LeastSquares for Exponential {
        fn unknowns(&self) -> usize {
            2
        }
        fn cost(&self, x: &[f64]) -> f64 {
            self.t
                .iter()
                .zip(&self.y)
                .map(|(&t, &y)| (x[0] * (x[1] * t).exp() - y).powi(2))
                .sum()
        }
        fn linearize(&self, x: &[f64]) -> Result<Linearization> {
            self.linearized.set(self.linearized.get() + 1);
            let mut qr = StreamingQr::new(3);
            for (&t, &y) in self.t.iter().zip(&self.y) {
                let e = (x[1] * t).exp();
                qr.push_row(&[e, x[0] * t * e, x[0] * e - y]);
            }
            Ok(Linearization::from_qr(&mut qr, self.cost(x)))
        }
        fn residual_rows(&self) -> Option<usize> {
            self.offset_test.then_some(self.t.len())
        }
    }

    /// The relative-offset test ends the fit with fewer linearisations, at the minimum the
    /// cost-change test reaches, to far below a standard error.
    #[test]
    fn relative_offset_stops_sooner_at_the_same_minimum() {
        let (with, without) = (Exponential::new(true), Exponential::new(false));
        let a = levenberg_marquardt(&with, &[1.0, 0.0], 200).expect("fit");
        let b = levenberg_marquardt(&without, &[1.0, 0.0], 200).expect("fit");
        assert!(with.linearized.get() < without.linearized.get());
        let sigma2 = b.cost / (200.0 - 2.0);
        let cov = covariance(&b.lin.r, sigma2).expect("covariance");
        for i in 0..2 {
            let std = cov[(i, i)].sqrt();
            assert!(
                (a.x[i] - b.x[i]).abs() < 1e-6 * std,
                "{i}: {:?} {:?}",
                a.x,
                b.x
            );
        }
        // The cost reported is the cost at the estimate, measured.
        assert_eq!(a.cost, with.cost(&a.x));
        assert!(a.cost <= b.cost * (1.0 + 1e-12));
    }

    /// The damped step by rotations equals the least-squares solution of the stacked system
    /// `[R; √μ·D]·δ = [−z; 0]` (normal equations `(RᵀR + μD²)δ = −Rᵀz`), on triangular
    /// factors of random sizes and scales, with zero damping entries, zero damping and an
    /// ill-conditioned `R`; a singular `R` without damping falls back to the SVD.
    #[test]
    fn the_rotated_damped_step_solves_the_stacked_system() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for (n, mu, spread) in [
            (1, 0.5, 1.0),
            (5, 1e-3, 1.0),
            (12, 10.0, 1e6),
            (30, 0.0, 1.0),
        ] {
            let r = DMatrix::from_fn(n, n, |i, j| {
                if i > j {
                    0.0
                } else if i == j {
                    (1.0 + rng.gen_range(0.0..1.0)) / f64::powf(spread, i as f64 / n as f64)
                } else {
                    rng.gen_range(-1.0..1.0)
                }
            });
            let z = DVector::from_fn(n, |_, _| rng.gen_range(-1.0..1.0));
            let d: Vec<f64> = (0..n)
                .map(|i| {
                    if i % 4 == 3 {
                        0.0
                    } else {
                        rng.gen_range(0.1..2.0)
                    }
                })
                .collect();
            let lin = Linearization {
                r: r.clone(),
                z: z.clone(),
                cost: 0.0,
            };
            let delta = damped_step(&lin, &d, mu).expect("step");
            let dd = DMatrix::from_fn(n, n, |i, j| if i == j { mu * d[i] * d[i] } else { 0.0 });
            let normal = r.transpose() * &r + dd;
            let want = normal.lu().solve(&(-(r.transpose() * &z))).expect("solve");
            let err = (&delta - &want).norm() / want.norm().max(1e-300);
            assert!(err < 1e-8 * spread, "n {n} mu {mu}: relative error {err}");
        }
        // A zero column in R with no damping: singular, the SVD's minimum-norm solution.
        let mut r = DMatrix::identity(3, 3);
        r[(1, 1)] = 0.0;
        let lin = Linearization {
            r,
            z: DVector::from_vec(vec![1.0, 2.0, 3.0]),
            cost: 0.0,
        };
        let delta = damped_step(&lin, &[1.0, 1.0, 1.0], 0.0).expect("step");
        assert_eq!(delta.as_slice(), &[-1.0, 0.0, -3.0]);
    }
}
