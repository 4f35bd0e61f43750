//! The search for the global minimum: the first fit on the scale-invariant cost, the
//! restarts while it fits badly (a staged start, angle shifts, seeded random starts), the
//! polish on the plain cost, and the sign flips of lengths towards their nominals.
//!
//! Takes the [`AlgebraicProblem`]s and a start; gives the best fit found ([`Search`]).

use crate::error::Result;
use crate::model::CalibModel;
use crate::numeric::lm::{levenberg_marquardt, LeastSquares, LmResult};

use super::problem::{fit_ratio, AlgebraicProblem, Cost};

/// The best fit so far, how far its `c` is from the data's null space (≤ 1: as near as the
/// linear solution), and how many restarts it took.
pub(super) struct Search {
    pub(super) best: LmResult,
    pub(super) ratio: f64,
    pub(super) restarts: usize,
    /// Levenberg-Marquardt iterations the restarts took, against `budget`.
    pub(super) spent: usize,
    /// The iterations the restarts may take ([`restart_budget`]).
    budget: usize,
}

/// The most Levenberg-Marquardt iterations the restarts may take together (ten runs at their
/// cap): a fit that stays bad after them is handed to the geometric refinement as it is.
/// Without it, a model with many free angles on data the linear solution fits exactly (exact
/// orientations) ran every shift and random start to its cap, minutes of `c(p)` gradients.
pub(super) const RESTART_BUDGET: usize = 600;

/// Iterations of one restart's run.
const RUN_CAP: usize = 300;

/// Work the restarts may spend together on `∂c/∂p` ([`CalibModel::jacobian_work`] per
/// iteration): about 1-2 s here (an iteration of a model of 604 900 units, URDF-native rows
/// with 32 unknowns on a measured pose, took 10-12 ms). A model whose `c(p)` polynomials are
/// large gets fewer iterations than [`RESTART_BUDGET`], so the restarts' time is bounded by
/// their cost, not their count; a model of up to 170 000 units keeps all 600.
const RESTART_WORK: usize = 100_000_000;

/// The fewest iterations the restarts get, however costly: a few runs' worth.
const RESTART_MIN: usize = 30;

/// The restarts' iterations for `model`: [`RESTART_BUDGET`], fewer where one iteration's
/// `∂c/∂p` costs more than [`RESTART_WORK`] spread over them, at least [`RESTART_MIN`].
fn restart_budget(model: &dyn CalibModel) -> usize {
    match model.jacobian_work() {
        Some(w) if w > 0 => (RESTART_WORK / w).clamp(RESTART_MIN, RESTART_BUDGET),
        _ => RESTART_BUDGET,
    }
}

impl Search {
    /// One restart's run from `start`, within what is left of its budget; `None` when the
    /// budget is spent or the run failed.
    fn run(&mut self, problem: &AlgebraicProblem<'_>, start: &[f64]) -> Option<LmResult> {
        let left = self.budget.saturating_sub(self.spent).min(RUN_CAP);
        if left == 0 {
            return None;
        }
        self.restarts += 1;
        match levenberg_marquardt(problem, start, left) {
            Ok(res) => {
                self.spent += res.iterations.max(1);
                Some(res)
            }
            Err(_) => {
                self.spent += left;
                None
            }
        }
    }

    /// Whether the restarts' budget is spent.
    fn spent(&self) -> bool {
        self.spent >= self.budget
    }

    /// Keeps `res` when it lowers the cost by more than rounding.
    fn offer(&mut self, problem: &AlgebraicProblem<'_>, res: LmResult) -> bool {
        if res.cost < self.best.cost * (1.0 - 1e-9) {
            self.ratio = fit_ratio(problem.model, problem.lin, &problem.set.full(&res.x));
            self.best = res;
            true
        } else {
            false
        }
    }
}

/// The normalised fit from `x0`; where an equation vanishes identically there, the plain
/// cost first.
pub(super) fn first_fit(
    plain: &AlgebraicProblem<'_>,
    normalized: &AlgebraicProblem<'_>,
    x0: &[f64],
) -> Result<Search> {
    let best = match levenberg_marquardt(normalized, x0, 300) {
        Ok(res) => res,
        Err(_) => {
            let res = levenberg_marquardt(plain, x0, 300)?;
            levenberg_marquardt(normalized, &res.x, 300)?
        }
    };
    let ratio = fit_ratio(plain.model, plain.lin, &plain.set.full(&best.x));
    Ok(Search {
        best,
        ratio,
        restarts: 0,
        spent: 0,
        budget: restart_budget(plain.model),
    })
}

/// A staged start when the fit is bad: the constraint's own parameters first, with the arm
/// at its nominal, then everything.
pub(super) fn staged_start(
    normalized: &AlgebraicProblem<'_>,
    nominal: &[f64],
    x0: &[f64],
    search: &mut Search,
) {
    if search.ratio <= 1.0 {
        return;
    }
    let (model, lin) = (normalized.model, normalized.lin);
    let geo = constraint_only(model, &normalized.set.free, nominal);
    if geo.is_empty() || geo.len() >= normalized.unknowns() {
        return;
    }
    let mut sub = normalized.with_cost(Cost::Normalized);
    sub.set.free = geo.iter().map(|&i| normalized.set.free[i]).collect();
    let Ok(a) = levenberg_marquardt(&sub, &sub.set.take(nominal), 300) else {
        return;
    };
    let mut start = x0.to_vec();
    for (k, &i) in geo.iter().enumerate() {
        start[i] = a.x[k];
    }
    if let Some(res) = search.run(normalized, &start) {
        if res.cost < search.best.cost {
            search.ratio = fit_ratio(model, lin, &normalized.set.full(&res.x));
            search.best = res;
        }
    }
}

/// Indices (in the free set) of the free angles.
pub(super) fn free_angles(problem: &AlgebraicProblem<'_>) -> Vec<usize> {
    (0..problem.unknowns())
        .filter(|&i| problem.model.param_is_angle(problem.set.free[i]))
        .collect()
}

/// Up to three rounds of shifting each free angle by π and ±π/2, while the fit is bad.
pub(super) fn angle_shifts(normalized: &AlgebraicProblem<'_>, search: &mut Search) {
    use std::f64::consts::{FRAC_PI_2, PI};
    let angles = free_angles(normalized);
    for _round in 0..3 {
        if search.ratio <= 1.0 {
            return;
        }
        let mut improved = false;
        for &i in &angles {
            for shift in [PI, FRAC_PI_2, -FRAC_PI_2] {
                if search.spent() {
                    return;
                }
                let mut start = search.best.x.clone();
                start[i] += shift;
                let Some(res) = search.run(normalized, &start) else {
                    continue;
                };
                if search.offer(normalized, res) {
                    improved = true;
                    if search.ratio <= 1.0 {
                        return;
                    }
                }
            }
        }
        if !improved {
            return;
        }
    }
}

/// Last resort: a fixed pseudo-random sequence of starts, every free angle drawn in (−π, π)
/// about its nominal (deterministic: a constant seed).
pub(super) fn random_restarts(normalized: &AlgebraicProblem<'_>, x0: &[f64], search: &mut Search) {
    use rand::{Rng, SeedableRng};
    use std::f64::consts::PI;
    let angles = free_angles(normalized);
    if search.ratio <= 1.0 || angles.is_empty() {
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed);
    for _ in 0..24 {
        if search.spent() {
            return;
        }
        let mut start = x0.to_vec();
        for &i in &angles {
            start[i] += rng.gen_range(-PI..PI);
        }
        let Some(res) = search.run(normalized, &start) else {
            continue;
        };
        if search.offer(normalized, res) && search.ratio <= 1.0 {
            return;
        }
    }
}

/// The plain cost from the normalised fit's point; kept unless it drifted towards a
/// degenerate zero (then phase 1's point, linearised for the plain cost).
pub(super) fn polish(plain: &AlgebraicProblem<'_>, search: &mut Search) -> Result<()> {
    let polished = levenberg_marquardt(plain, &search.best.x, 300)?;
    let polished_ratio = fit_ratio(plain.model, plain.lin, &plain.set.full(&polished.x));
    if polished_ratio <= search.ratio.max(1.0) {
        search.best = polished;
        search.ratio = polished_ratio;
    } else {
        search.best = levenberg_marquardt(plain, &search.best.x, 0)?;
    }
    Ok(())
}

/// A free length with the opposite sign to its nominal is flipped and the fit repeated; the
/// flipped solution is kept when it fits as well.
pub(super) fn sign_flips(plain: &AlgebraicProblem<'_>, nominal: &[f64], search: &mut Search) {
    let (model, lin) = (plain.model, plain.lin);
    for i in 0..plain.unknowns() {
        let j = plain.set.free[i];
        let x = &search.best.x;
        if model.param_is_angle(j) || nominal[j] == 0.0 || x[i].signum() == nominal[j].signum() {
            continue;
        }
        let mut start = x.clone();
        start[i] = -start[i];
        let Ok(res) = levenberg_marquardt(plain, &start, 300) else {
            continue;
        };
        let r = fit_ratio(model, lin, &plain.set.full(&res.x));
        let ratio = search.ratio;
        let as_good = r <= ratio.max(1.0)
            && (res.cost <= search.best.cost * (1.0 + 1e-6) || (r <= 1e-3 && ratio <= 1e-3));
        if as_good && res.x[i].signum() == nominal[j].signum() {
            search.best = res;
            search.ratio = r;
        }
    }
}

/// Positions in `free` of the parameters that do not move the tip (the constraint's own),
/// found by perturbing each at two fixed joint configurations.
fn constraint_only(model: &dyn CalibModel, free: &[usize], p: &[f64]) -> Vec<usize> {
    let nj = model.joint_count();
    let dim = model.dim();
    let qs: [Vec<f64>; 2] = [
        (0..nj).map(|i| 0.3 + 0.7 * i as f64).collect(),
        (0..nj).map(|i| -1.1 + 0.45 * i as f64).collect(),
    ];
    let mut t0 = vec![0.0; dim];
    let mut t1 = vec![0.0; dim];
    (0..free.len())
        .filter(|&i| {
            let j = free[i];
            let mut pp = p.to_vec();
            pp[j] += 1e-3 * p[j].abs().max(1.0);
            qs.iter().all(|q| {
                model.tip(q, p, &mut t0);
                model.tip(q, &pp, &mut t1);
                t0.iter().zip(&t1).all(|(a, b)| a == b)
            })
        })
        .collect()
}
