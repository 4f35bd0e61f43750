//! The error, the options and the criterion of pose selection, shared by every step.

use std::fmt;

use nalgebra::DMatrix;

/// Why a selection could not be made. Every function of [`crate::select`] checks its input
/// and returns one of these rather than panicking.
#[derive(Clone, Debug, PartialEq)]
pub enum SelectError {
    /// More poses wanted than the pool holds (candidates are chosen at most once).
    TooFewCandidates {
        /// Poses asked for.
        wanted: usize,
        /// Candidates in the pool.
        pool: usize,
    },
    /// A candidate's block holds a NaN or an infinity.
    NonFinite {
        /// The candidate.
        candidate: usize,
        /// The draw whose block it is.
        draw: usize,
    },
    /// Some other input (given information, tip rows, joint vector, information matrix)
    /// holds a NaN or an infinity.
    NonFiniteInput {
        /// What the input is.
        what: &'static str,
        /// Its index (draw, pose, …).
        index: usize,
    },
    /// Inconsistent sizes: block lengths, row counts outside `1..=6`, matrices of the wrong
    /// shape, ragged joint vectors.
    Shape(String),
    /// A candidate index outside the pool, or one named twice.
    BadCandidate {
        /// The index.
        index: usize,
    },
    /// An option out of its range.
    BadOption(&'static str),
    /// The information matrix of a draw is not positive definite where it must be (a given
    /// information that is not positive semi-definite, or a removal that would make the
    /// design singular).
    NotPositiveDefinite {
        /// The draw.
        draw: usize,
    },
}

impl fmt::Display for SelectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SelectError::TooFewCandidates { wanted, pool } => write!(
                f,
                "{wanted} poses wanted but the pool holds only {pool} candidates"
            ),
            SelectError::NonFinite { candidate, draw } => write!(
                f,
                "candidate {candidate} has a non-finite Jacobian entry (draw {draw})"
            ),
            SelectError::NonFiniteInput { what, index } => {
                write!(f, "non-finite value in {what} {index}")
            }
            SelectError::Shape(what) => write!(f, "inconsistent sizes: {what}"),
            SelectError::BadCandidate { index } => {
                write!(f, "candidate {index} is outside the pool or named twice")
            }
            SelectError::BadOption(what) => write!(f, "bad option: {what}"),
            SelectError::NotPositiveDefinite { draw } => {
                write!(
                    f,
                    "information matrix of draw {draw} is not positive definite"
                )
            }
        }
    }
}

impl std::error::Error for SelectError {}

/// What a selection optimises.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Criterion {
    /// D-optimality averaged over draws: maximise
    /// `f(S) = (1/D) Σ_d log det(G_d + R_d + Σ_{i∈S} J_dᵢᵀ J_dᵢ)`
    /// (`R_d` the regulariser of [`SelectOptions::ridge`]).
    #[default]
    D,
    /// Tip (I-/V-) optimality: minimise the mean predicted variance of the rows of `T_d`,
    /// `g(S) = (1/D) Σ_d tr(T_d M_d(S)⁻¹ T_dᵀ)` with `M_d(S)` the matrix inside the log det
    /// above. One `k × n` matrix per draw (`k ≥ 1`), e.g. tip Jacobians at workspace points.
    Tip(Vec<DMatrix<f64>>),
}

/// Options of [`crate::select::select`] (and of the baseline functions, which use the same
/// regulariser).
#[derive(Clone, Debug, PartialEq)]
pub struct SelectOptions {
    /// Relative weight `ε` of the regulariser (default `1e-9`, must be `> 0`).
    ///
    /// Each draw's information gets `R_d = ε·(M̄_d + τ_d I)` added, where
    /// `M̄_d = (1/P) Σ_i J_dᵢᵀ J_dᵢ` is the pool's average information per pose and
    /// `τ_d = 1e-10·tr(M̄_d)/n` (`1e-6·tr(M̄_d)/n` when `M̄_d` has an eigenvalue below
    /// `1e-6·tr(M̄_d)/n`, a direction the pool barely sees) only keeps `R_d` definite when the pool itself is rank-deficient
    /// (for an all-zero pool, `R_d = ε·s·I` with `s` the mean diagonal of `G_d`, or 1).
    /// So designs with fewer rows than parameters are ranked (by their information relative
    /// to the pool average) and `log det` is never `-∞`. Shaping the ridge like `M̄_d`
    /// instead of `I` keeps the criterion invariant under every reparametrisation
    /// `J → J·A` (units, linear combinations): `log det` shifts by `2 log|det A|` for every
    /// design, so the choice does not change. Its effect on a nonsingular design `M` is
    /// `≈ ε·tr(M⁻¹ M̄)`, i.e. negligible.
    pub ridge: f64,
    /// Most swaps the exchange applies; `None`: `2·N`. `Some(0)` turns the exchange off.
    pub max_swaps: Option<usize>,
    /// How many not-chosen candidates (those of largest single-addition gain) the exchange
    /// tries as entering poses each pass; `0`: all of them (full Fedorov exchange,
    /// `O(N·P·m²·n)` per pass). Default 64.
    pub entering: usize,
    /// A swap is applied only when it improves the criterion by more than this relative
    /// amount: for D, `Δf > tolerance` (the determinant grows by a factor `> e^tolerance`);
    /// for tip, `Δg < −tolerance·g`. Default `1e-9`.
    pub tolerance: f64,
    /// Worker threads for the passes over the pool; `0`: the machine's (at most 8). The
    /// result does not depend on it. Pools with `P·D < 2000` use one.
    pub threads: usize,
    /// Iterations of the multiplicative algorithm for the Kiefer-Wolfowitz efficiency bound;
    /// `0` (default): no bound. Each iteration costs `2·P·m·n²·D` flops.
    pub bound_iterations: usize,
    /// Seed of the sampled greedy's random subsets, used for the D criterion when the pool
    /// is large against the count (`(P/N)·ln(100) ≤ P/8`); the same seed gives the same
    /// choice. Default 0.
    pub seed: u64,
}

impl Default for SelectOptions {
    fn default() -> Self {
        SelectOptions {
            ridge: 1e-9,
            max_swaps: None,
            entering: 64,
            tolerance: 1e-9,
            threads: 0,
            bound_iterations: 0,
            seed: 0,
        }
    }
}

impl SelectOptions {
    /// Checks the ranges of the options.
    ///
    /// # Errors
    /// [`SelectError::BadOption`] for a ridge not finite and `> 0` or a tolerance not
    /// finite and `≥ 0`.
    pub fn check(&self) -> Result<(), SelectError> {
        if !(self.ridge.is_finite() && self.ridge > 0.0) {
            return Err(SelectError::BadOption("ridge must be finite and > 0"));
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(SelectError::BadOption("tolerance must be finite and >= 0"));
        }
        Ok(())
    }

    /// The worker count to use for `work` items (candidates × draws).
    pub(crate) fn thread_count(&self, work: usize) -> usize {
        if work < PARALLEL_MIN {
            return 1;
        }
        if self.threads > 0 {
            return self.threads;
        }
        std::thread::available_parallelism()
            .map_or(1, std::num::NonZeroUsize::get)
            .clamp(1, 8)
    }
}

/// Candidates × draws below which the passes run on one thread.
const PARALLEL_MIN: usize = 2000;
