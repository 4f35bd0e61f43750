//! Pose selection (optimal experimental design for kinematic calibration): which `N` poses
//! of a pool of candidates to measure. The numerical core of `lincal select`.
//!
//! # Model
//! Candidate `i` contributes, for each draw `d` (parameter vectors around the nominal; draw 0
//! the nominal), a whitened Jacobian block `J_dᵢ` (`mᵢ × n`, `1 ≤ mᵢ ≤ 6`, restricted to the
//! `n` free parameters) and so the information `J_dᵢᵀJ_dᵢ`; poses already measured add a
//! given information `G_d` to every design (see [`Pool`]). Since the blocks are whitened, the
//! inverse information is the predicted covariance of the parameters.
//!
//! # Criteria
//! - D ([`Criterion::D`]): maximise `f(S) = (1/D) Σ_d log det(G_d + R_d + Σ_{i∈S} J_dᵢᵀJ_dᵢ)`,
//!   with `R_d` the tiny regulariser of [`SelectOptions::ridge`] (`ε` times the pool's
//!   average information per pose), so designs with fewer rows than parameters are still
//!   ranked and `f` is never `−∞`. Invariant under reparametrisation.
//! - Tip ([`Criterion::Tip`]): minimise `g(S) = (1/D) Σ_d tr(T_d M_d(S)⁻¹ T_dᵀ)`, the mean
//!   predicted variance of given sensitivity rows (I-/V-optimality).
//!
//! # Algorithm ([`select`])
//! 1. Greedy forward selection with rank-`m` updates: the gain of adding block `J` to
//!    information `M` is `log det(I + JM⁻¹Jᵀ)` (D, matrix determinant lemma) or
//!    `tr(TM⁻¹Jᵀ(I + JM⁻¹Jᵀ)⁻¹JM⁻¹Tᵀ)` (tip). Per draw `M⁻¹` is updated by Woodbury after
//!    each addition, and every candidate's `JM⁻¹Jᵀ` by a logged rank-`m` update (`O(m²·n)`);
//!    no determinant is recomputed per candidate (see `state`). D uses lazy evaluation
//!    (gains only shrink, so old gains are upper bounds; same result as the plain greedy),
//!    tip a pass over the pool per step; passes and refreshes run over threads (see
//!    `greedy`). On a pool large against `N` (`(P/N)·ln 100 ≤ P/8`) the D greedy is the
//!    sampled one instead: each step the best of a random sample of `(P/N)·ln 100`
//!    candidates (seeded by [`SelectOptions::seed`]), evaluated exactly.
//! 2. Bounded exchange: best single swaps (every chosen candidate out, the most promising
//!    candidates in) while they improve the criterion by more than the tolerance (see
//!    `exchange`); the result is never worse than the greedy one.
//! 3. Optionally a Kiefer-Wolfowitz lower bound on the D-efficiency ([`kw_bound`]).
//!
//! All work is in whitened coordinates (the pool's average information is the identity, see
//! `frame`), and the state is refactored from scratch from time to time, so the rank-`m`
//! updates keep full accuracy (see `state`).
//!
//! Candidates are chosen at most once. Also here: per-parameter predicted standard
//! deviations ([`predicted_std`]), the random-design baseline ([`baseline()`]) and how many
//! random poses match the chosen ones ([`worth`]), and a visiting order
//! ([`visiting_order`]).

mod baseline;
mod blind;
mod bound;
mod exchange;
mod excursion;
mod frame;
mod greedy;
mod order;
pub mod plan;
mod pool;
mod prior;
mod request;
mod small;
mod state;
pub mod summary;
mod types;
mod update;
mod whiten;

#[cfg(test)]
mod tests;

pub use baseline::{baseline, predicted_std, worth, Baseline};
pub use bound::{continuous_design, kw_bound, Bound, ContinuousDesign};
pub use frame::evaluate;
pub use order::{tour_length, visiting_order, MAX_EVALS};
pub use pool::{Pool, MAX_ROWS};
pub use types::{Criterion, SelectError, SelectOptions};

/// The result of [`select`].
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The chosen candidates, in the order the greedy added them (a swap puts the entering
    /// candidate in the leaving one's place).
    pub chosen: Vec<usize>,
    /// The criterion of the chosen design (`f` for D, `g` for tip), computed from scratch.
    pub value: f64,
    /// The D criterion `f` of the chosen design (equal to `value` for D), from scratch.
    pub log_det: f64,
    /// The criterion of the greedy design, before the exchange.
    pub greedy_value: f64,
    /// Swaps the exchange applied.
    pub swaps: usize,
    /// The bound on the D-efficiency (whatever the criterion), when
    /// [`SelectOptions::bound_iterations`] `> 0` and the design's information is nonsingular.
    pub bound: Option<Bound>,
}

/// Mixed into [`SelectOptions::seed`] for the sampled search's stream.
const SAMPLE_SEED: u64 = 0x6772_6565_6479;

/// Chooses `count` distinct candidates of `pool` optimising `criterion`: greedy, then
/// bounded exchange (see the module documentation). The result does not depend on the
/// thread count; ties go to the lowest index. With the D criterion on a pool large against
/// `count`, the greedy and the exchange sample the pool, and the result depends on
/// [`SelectOptions::seed`].
///
/// # Errors
/// [`SelectError::TooFewCandidates`] for `count > P`; option and tip-matrix checks;
/// [`SelectError::NotPositiveDefinite`] when a given information is not positive
/// semi-definite.
pub fn select(
    pool: &Pool,
    count: usize,
    criterion: &Criterion,
    opts: &SelectOptions,
) -> Result<Selection, SelectError> {
    opts.check()?;
    pool.check_count(count)?;
    let p = pool.n_candidates();
    let frames = frame::frames(pool, opts.ridge)?;
    let tip = frame::whitened_tip(pool, &frames, criterion)?;
    let threads = opts.thread_count(p * pool.n_draws());
    let sampled = match tip {
        None => greedy::sample_size(p, count),
        Some(_) => None,
    };
    let mut st = match sampled {
        Some(s) => state::State::new_sampled(pool, &frames, threads, s, opts.seed ^ SAMPLE_SEED)?,
        None => state::State::new(pool, &frames, tip.as_deref(), threads)?,
    };
    greedy::run(&mut st, count)?;
    let greedy_set = st.chosen.clone();
    let greedy_value = frame::value(pool, &frames, tip.as_deref(), &greedy_set)?;
    let budget = opts.max_swaps.unwrap_or(2 * count);
    let mut swaps = exchange::run(&mut st, opts, budget)?;
    let mut chosen = st.chosen.clone();
    let mut value = frame::value(pool, &frames, tip.as_deref(), &chosen)?;
    // The exchange only applies improving swaps; this guards against rounding.
    let worse = if tip.is_some() {
        value > greedy_value
    } else {
        value < greedy_value
    };
    if swaps > 0 && worse {
        (chosen, value, swaps) = (greedy_set, greedy_value, 0);
    }
    let log_det = if tip.is_some() {
        frame::value(pool, &frames, None, &chosen)?
    } else {
        value
    };
    let bound = if opts.bound_iterations > 0 {
        kw_bound(pool, &chosen, opts.bound_iterations, opts)?
    } else {
        None
    };
    Ok(Selection {
        chosen,
        value,
        log_det,
        greedy_value,
        swaps,
        bound,
    })
}
