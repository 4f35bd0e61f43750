//! The solve: damped Gauss-Newton (Levenberg-Marquardt) on the exact chain Jacobian, from the
//! seed, each step the one of least distance from the seed.
//!
//! With `d = q − q₀` (the way from the seed `q₀`), the task error `e(q)` and its Jacobian `J`
//! ([`super::task`]), the linearised problem at `q` is: find the new way `u = d + Δ` with
//! `J·u = e + J·d` (the target reached to first order), of least norm `‖u‖`:
//!
//! `u = Jᵀ·(J·Jᵀ)⁻¹·(e + J·d)`,  `q ← q₀ + u`,
//!
//! that is `Δ = J⁺e − (I − J⁺J)·d`: the Gauss-Newton step plus the pull of the null-space part
//! of the way back to zero. The system is `m × m` (`m` the task rows, ≤ 6), solved by Cholesky.
//! While these steps lower `‖e‖` they are taken as they are; a step that does not (or a
//! singular `J·Jᵀ`) switches to the damped step `Δ = Jᵀ·(J·Jᵀ + λ²·I)⁻¹·e` (Levenberg-Marquardt,
//! the minimiser of `‖J·Δ − e‖² + λ²‖Δ‖²`, without the pull), `λ² = μ·tr(J·Jᵀ)/m`, `μ` raised
//! tenfold (from 10⁻⁹) at each refusal and lowered tenfold at each step taken, back to the
//! undamped step below 10⁻¹².
//!
//! At convergence `e = 0` and `(I − J⁺J)·(q − q₀) = 0`: the way from the seed lies in the row
//! space of `J`, the first-order condition of the least-norm solution of `e(q) = 0`. A redundant
//! arm (or a position target on a 6-joint arm) therefore keeps its self-motion coordinate and
//! its configuration branch; a square, regular task has one nearby solution, the same one.

use super::task::{Arm, Goal, Scratch, TargetKind};

/// The solve's limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveOptions {
    /// A target counts as reached when the position error is at most this (metres) and the
    /// orientation error at most this (radians). Default `1e-10`.
    pub tolerance: f64,
    /// Iterations at most. Default 100.
    pub max_iterations: usize,
    /// The largest gain `‖q′ − q₀‖ / ‖e(q₀)‖` (rad/m, or rad/rad for orientation rows) of a
    /// regular solve: beyond it the correction is amplified by a near-singular Jacobian and the
    /// row is `singular`. Default 100 (a Jacobian's smallest singular value near 1 cm/rad).
    pub max_gain: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            tolerance: 1e-10,
            max_iterations: 100,
            max_gain: 100.0,
        }
    }
}

/// The end of one solve.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The joints reached (the best iterate when the solve did not converge).
    pub q: Vec<f64>,
    /// `‖x* − x(q)‖`, metres.
    pub position_error: f64,
    /// `‖φ‖` of a pose target, radians (0 for a position target).
    pub orientation_error: f64,
    /// `‖e(q₀)‖` at the seed (position and orientation rows together).
    pub start_error: f64,
    /// Iterations taken.
    pub iterations: usize,
    /// Whether both errors are within [`SolveOptions::tolerance`].
    pub converged: bool,
}

/// The floor below which an error counts as exactly zero in `f64` arithmetic (a step is then
/// taken even if it does not lower `‖e‖`, for the way's null-space part to settle).
const ZERO_ERROR: f64 = 1e-14;

/// Steps taken between the checks that the error still falls (see [`solve`]).
const STALL_STEPS: usize = 20;

/// Buffers of one solve, reused from target to target.
pub struct Work {
    e: Vec<f64>,
    e_new: Vec<f64>,
    jac: Vec<f64>,
    jac_new: Vec<f64>,
    a: Vec<f64>,
    rhs: Vec<f64>,
    u: Vec<f64>,
    q_new: Vec<f64>,
    scratch: Scratch,
}

impl Work {
    /// Buffers for a chain of `joints` joints.
    #[must_use]
    pub fn new(joints: usize) -> Self {
        Work {
            e: vec![0.0; 6],
            e_new: vec![0.0; 6],
            jac: vec![0.0; 6 * joints],
            jac_new: vec![0.0; 6 * joints],
            a: vec![0.0; 36],
            rhs: vec![0.0; 6],
            u: vec![0.0; joints],
            q_new: vec![0.0; joints],
            scratch: Scratch::new(joints),
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Solves `e(q) = 0` for `goal` from the seed `seed` (see the module docs). A solution whose
/// way from the seed keeps a null-space part above [`SELF_MOTION`] (the solve wandered along
/// the self-motion, and a pull step that would bring it back raised the error and was
/// refused) is then settled onto the least-norm one (`settle`: gradient projection with
/// restoration).
///
/// (Following the path of goals from the seed's tool to the target, a homotopy, was tried
/// for the targets this leaves `diverged`: on the issue-49 grids it reached none of them
/// (they lie beyond the calibrated arm's reach near a singularity) and cost 25 % more time.)
pub fn solve(
    arm: &Arm<'_>,
    goal: &Goal,
    kind: TargetKind,
    seed: &[f64],
    opts: &SolveOptions,
    w: &mut Work,
) -> Solution {
    let mut best = solve_from(arm, goal, kind, seed, opts, w);
    let (_, wander) = null_part(arm, &best.q, seed, goal, kind, w);
    // A singular `J·Jᵀ` has no null-space projector to settle along.
    if best.converged && wander.is_finite() && wander > SELF_MOTION {
        settle(arm, goal, kind, seed, opts, w, &mut best);
    }
    best
}

/// Moves a solution `sol` along the self-motion towards the seed until its way has no
/// null-space part (the least-norm solution's first-order condition): the null-space part
/// `v = (I − J⁺J)(q − q₀)` is stepped back, `q − α·v` (`α` from 1, halved), and the target
/// reached again from there by undamped least-norm steps (the restoration); a step is kept
/// when the target is reached and the way is shorter. Gradient projection with restoration:
/// each kept step shortens the way, so it ends at a stationary point of the way's length on
/// the solutions, the one the seed's self-motion coordinate leads to.
fn settle(
    arm: &Arm<'_>,
    goal: &Goal,
    kind: TargetKind,
    seed: &[f64],
    opts: &SolveOptions,
    w: &mut Work,
    sol: &mut Solution,
) {
    let (m, n) = (arm.rows(kind), arm.joints);
    let way = |q: &[f64]| {
        q.iter()
            .zip(seed)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    };
    for _ in 0..SETTLE_ROUNDS {
        let (v, size) = null_part(arm, &sol.q, seed, goal, kind, w);
        if size <= SELF_MOTION * 1e-3 {
            break;
        }
        let before = way(&sol.q);
        let mut kept = false;
        let mut alpha = 1.0;
        while alpha >= 1.0 / 64.0 {
            let mut q: Vec<f64> = sol.q.iter().zip(&v).map(|(a, b)| a - alpha * b).collect();
            let mut iterations = 0;
            let reached = loop {
                arm.error(
                    &q,
                    goal,
                    kind,
                    &mut w.e[..m],
                    Some(&mut w.jac[..m * n]),
                    &mut w.scratch,
                );
                let cost = norm(&w.e[..m]);
                if cost <= opts.tolerance * 1e-2 || cost <= ZERO_ERROR {
                    break true;
                }
                iterations += 1;
                // The undamped least-norm step from `q` (no pull: a tiny damping selects it).
                if iterations > 10 || !step(arm, seed, &q, f64::MIN_POSITIVE, m, w) {
                    break false;
                }
                q.copy_from_slice(&w.q_new);
            };
            sol.iterations += iterations;
            if reached && way(&q) < before {
                sol.position_error = norm(&w.e[..arm.dim]);
                sol.orientation_error = if m == 6 { norm(&w.e[3..6]) } else { 0.0 };
                sol.q = q;
                kept = true;
                break;
            }
            alpha /= 2.0;
        }
        if !kept {
            break;
        }
    }
}

/// Rounds of [`settle`] at most.
const SETTLE_ROUNDS: usize = 200;

/// The largest null-space part `‖(I − J⁺J)(q′ − q₀)‖` (radians, metres for a slide) of a
/// solution that is kept as it is: beyond it the solve wandered along the self-motion, and
/// the solve takes it back (`settle`).
pub const SELF_MOTION: f64 = 1e-6;

/// The null-space part `(I − J⁺J)(q − q₀)` of the way from the seed at `q`, and its norm:
/// the part along the self-motion (zero for a square task); infinite where `J·Jᵀ` is
/// singular.
fn null_part(
    arm: &Arm<'_>,
    q: &[f64],
    seed: &[f64],
    goal: &Goal,
    kind: TargetKind,
    w: &mut Work,
) -> (Vec<f64>, f64) {
    let (m, n) = (arm.rows(kind), arm.joints);
    if m >= n {
        return (vec![0.0; n], 0.0);
    }
    arm.error(
        q,
        goal,
        kind,
        &mut w.e_new[..m],
        Some(&mut w.jac_new[..m * n]),
        &mut w.scratch,
    );
    let jac = &w.jac_new[..m * n];
    for i in 0..m {
        for j in 0..=i {
            let v: f64 = (0..n).map(|k| jac[i * n + k] * jac[j * n + k]).sum();
            w.a[i * m + j] = v;
            w.a[j * m + i] = v;
        }
        w.rhs[i] = (0..n).map(|k| jac[i * n + k] * (q[k] - seed[k])).sum();
    }
    if !cholesky_solve(&mut w.a[..m * m], &mut w.rhs[..m], m) {
        return (vec![0.0; n], f64::INFINITY);
    }
    let v: Vec<f64> = (0..n)
        .map(|k| {
            let row: f64 = (0..m).map(|i| jac[i * n + k] * w.rhs[i]).sum();
            q[k] - seed[k] - row
        })
        .collect();
    let size = norm(&v);
    (v, size)
}

/// The damped Gauss-Newton solve of [`solve`] from the seed.
fn solve_from(
    arm: &Arm<'_>,
    goal: &Goal,
    kind: TargetKind,
    seed: &[f64],
    opts: &SolveOptions,
    w: &mut Work,
) -> Solution {
    let (m, n) = (arm.rows(kind), arm.joints);
    let mut q = seed.to_vec();
    arm.error(
        &q,
        goal,
        kind,
        &mut w.e[..m],
        Some(&mut w.jac[..m * n]),
        &mut w.scratch,
    );
    let start_error = norm(&w.e[..m]);
    let mut cost = start_error;
    let mut mu = 0.0_f64;
    let mut iterations = 0;
    let (mut checked, mut accepted) = (cost, 0);
    while iterations < opts.max_iterations {
        iterations += 1;
        if !step(arm, seed, &q, mu, m, w) {
            mu = (mu * 10.0).max(1e-9);
            if mu > 1e12 {
                break;
            }
            continue;
        }
        let new_cost = trial_cost(arm, goal, kind, w);
        if new_cost.is_finite() && (new_cost < cost || new_cost <= ZERO_ERROR) {
            let moved = q
                .iter()
                .zip(&w.q_new)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            accept(&mut q, w);
            cost = new_cost;
            mu = if mu < 1e-12 { 0.0 } else { mu / 10.0 };
            // A target beyond the arm's reach ends at the nearest point with the error stuck
            // at millimetres: when STALL_STEPS steps taken have not lowered it by a tenth,
            // more will not reach it.
            accepted += 1;
            if accepted % STALL_STEPS == 0 {
                if cost > opts.tolerance && cost > 0.9 * checked {
                    break;
                }
                checked = cost;
            }
            if cost <= ZERO_ERROR && moved <= 1e-15 * (1.0 + norm(&q)) {
                break;
            }
        } else {
            mu = (mu * 10.0).max(1e-9);
            if mu > 1e12 {
                break;
            }
        }
    }
    iterations += polish(arm, goal, kind, seed, &mut q, &mut cost, opts, w);
    finish(arm, q, m, start_error, iterations, opts, w)
}

/// The error's norm at the trial point `w.q_new` (its errors and Jacobian into `w.e_new`,
/// `w.jac_new`).
fn trial_cost(arm: &Arm<'_>, goal: &Goal, kind: TargetKind, w: &mut Work) -> f64 {
    let (m, n) = (arm.rows(kind), arm.joints);
    arm.error(
        &w.q_new,
        goal,
        kind,
        &mut w.e_new[..m],
        Some(&mut w.jac_new[..m * n]),
        &mut w.scratch,
    );
    norm(&w.e_new[..m])
}

/// The trial point taken: `q` and its errors and Jacobian become `w.q_new`'s.
fn accept(q: &mut [f64], w: &mut Work) {
    q.copy_from_slice(&w.q_new);
    std::mem::swap(&mut w.e, &mut w.e_new);
    std::mem::swap(&mut w.jac, &mut w.jac_new);
}

/// Undamped least-norm steps at most (no pull) after a solve that stopped short of the
/// tolerance.
const POLISH_STEPS: usize = 20;

/// Gauss-Newton steps from `q` (the least-norm step, without the pull to the seed) while
/// they lower `cost` and it is above the tolerance: the pulled steps, which hold the
/// redundant joints near the seed, can creep near the end (7 of 200 000 reachable targets
/// of a UR5 stopped at 3·10⁻¹⁰ to 1.6·10⁻⁴ m and were called diverged); these converge
/// quadratically where the target is within reach, and change nothing where it is not. The
/// steps taken.
#[allow(clippy::too_many_arguments)]
fn polish(
    arm: &Arm<'_>,
    goal: &Goal,
    kind: TargetKind,
    seed: &[f64],
    q: &mut [f64],
    cost: &mut f64,
    opts: &SolveOptions,
    w: &mut Work,
) -> usize {
    let m = arm.rows(kind);
    let mut taken = 0;
    while taken < POLISH_STEPS && *cost > opts.tolerance && cost.is_finite() {
        // A tiny damping selects the least-norm step from `q` (see `step`).
        if !step(arm, seed, q, f64::MIN_POSITIVE, m, w) {
            break;
        }
        let new_cost = trial_cost(arm, goal, kind, w);
        if new_cost.is_nan() || new_cost >= *cost {
            break;
        }
        accept(q, w);
        *cost = new_cost;
        taken += 1;
    }
    taken
}

/// The solution at `q`: its errors and whether they are within tolerance.
fn finish(
    arm: &Arm<'_>,
    q: Vec<f64>,
    m: usize,
    start_error: f64,
    iterations: usize,
    opts: &SolveOptions,
    w: &Work,
) -> Solution {
    let position_error = norm(&w.e[..arm.dim]);
    let orientation_error = if m == 6 { norm(&w.e[3..6]) } else { 0.0 };
    Solution {
        converged: position_error <= opts.tolerance && orientation_error <= opts.tolerance,
        q,
        position_error,
        orientation_error,
        start_error,
        iterations,
    }
}

/// One step from `q` into `w.q_new` (see the module docs): the least-norm step with the pull
/// when `mu` is 0, the damped step otherwise; `false` when the system is not positive
/// definite (a singular `J` with `μ = 0`) or a value is not finite.
fn step(arm: &Arm<'_>, seed: &[f64], q: &[f64], mu: f64, m: usize, w: &mut Work) -> bool {
    let n = arm.joints;
    let jac = &w.jac[..m * n];
    let pull = mu == 0.0;
    // A = J·Jᵀ + λ²I, rhs = e (+ J·d with the pull).
    let mut trace = 0.0;
    for i in 0..m {
        for j in 0..=i {
            let v: f64 = (0..n).map(|k| jac[i * n + k] * jac[j * n + k]).sum();
            w.a[i * m + j] = v;
            w.a[j * m + i] = v;
        }
        trace += w.a[i * m + i];
        w.rhs[i] = w.e[i];
        if pull {
            w.rhs[i] += (0..n)
                .map(|k| jac[i * n + k] * (q[k] - seed[k]))
                .sum::<f64>();
        }
    }
    let lambda2 = mu * (trace / m as f64).max(f64::MIN_POSITIVE);
    for i in 0..m {
        w.a[i * m + i] += lambda2;
    }
    if !cholesky_solve(&mut w.a[..m * m], &mut w.rhs[..m], m) {
        return false;
    }
    let from = if pull { seed } else { q };
    for k in 0..n {
        w.u[k] = (0..m).map(|i| jac[i * n + k] * w.rhs[i]).sum();
        w.q_new[k] = from[k] + w.u[k];
    }
    w.q_new.iter().all(|v| v.is_finite())
}

/// Solves `A·y = b` in place (`b ← y`) for a symmetric positive definite `m × m` `A`
/// (row-major, overwritten by its Cholesky factor); `false` when a pivot is not positive
/// beyond rounding (relative to the largest diagonal entry).
pub(crate) fn cholesky_solve(a: &mut [f64], b: &mut [f64], m: usize) -> bool {
    let scale = (0..m).map(|i| a[i * m + i]).fold(0.0_f64, f64::max);
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        // NaN fails too.
        if d.is_nan() || d <= 1e-13 * scale {
            return false;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut s = a[i * m + j];
            for k in 0..j {
                s -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = s / d;
        }
    }
    for i in 0..m {
        let s: f64 = (0..i).map(|k| a[i * m + k] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * m + i];
    }
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|k| a[k * m + i] * b[k]).sum();
        b[i] = (b[i] - s) / a[i * m + i];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_small_system() {
        let mut a = vec![4.0, 2.0, 2.0, 3.0];
        let mut b = vec![2.0, 1.0];
        assert!(cholesky_solve(&mut a, &mut b, 2));
        // 4y0 + 2y1 = 2, 2y0 + 3y1 = 1 → y = (0.5, 0).
        assert!((b[0] - 0.5).abs() < 1e-15 && b[1].abs() < 1e-15);
        let mut s = vec![1.0, 1.0, 1.0, 1.0];
        assert!(!cholesky_solve(&mut s, &mut [1.0, 1.0], 2));
    }
}
