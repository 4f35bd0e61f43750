//! The lack-of-fit test of the folds by joint-space cluster, and the tolerance taken from
//! the residual level where it fails (the default prior's choice, [`super`]).
//!
//! Clusters of one placement are trusted only where the model explains the poses they did
//! not see. Under an adequate model with white noise at `σ̂`, fold `f`'s held-out sum of
//! squares with the starting prior ([`super::start_tolerance`]) has the expectation
//! `E_f = σ̂²(m_f − l_f + tr(M_f))`
//! (`m_f` the fold's rows, `M_f = A_f⁻¹S_f`, `S_f` its Gram matrix with its own refitted
//! values projected out, `l_f` their rank, `A_f` the training set's Gram matrix with the
//! prior): the noise plus the estimate's own variance at the fold's readings; with the truth
//! drawn from the prior, the exact predictive expectation. Its variance is
//! `2σ̂⁴(m_f − l_f + 2 tr(M_f) + tr(M_f²))`: a fold the others barely predict has a few large
//! terms and a heavy tail.
//!
//! The test sums every fold but the one farthest beyond its own expectation (in its standard
//! deviations), and reports that sum over its expectation ([`LackOfFit::ratio`], about 1) and
//! how many standard deviations beyond it lies ([`LackOfFit::sigmas`]). One fold is left out
//! because encoder noise moves the tip as a home offset does: the residual's `σ̂` understates
//! what the weak directions carry, and one extrapolating fold of white-noise data (leverage
//! 187 over 93 rows) lay 7 standard deviations out, where the other four lay at 0.8. Under
//! systematic error the excess is spread over the folds (MUKCa's `panda_2/back_right`: four of
//! five at 1.1 to 5.9 times their expectation).
//!
//! Beyond [`SYSTEMATIC_Z`] standard deviations the fits extrapolate to the held-out clusters
//! worse than noise and the estimate's own variance explain: the parameters absorb an error
//! the model cannot hold (joint compliance, gear eccentricity, a sagging tool) differently in
//! each region of joint space. The clusters' curve then measures how well the fit absorbs
//! that error, not how the arm extrapolates to the next placement (on `back_right` the
//! clusters prefer a prior of 1 m where the other placements are predicted best at about
//! 1 mm, 2.4× better). There the tolerance is taken from the residual itself,
//! `τ = σ̂/√(N₀·w)` ([`residual_tolerance`]): MUKCa's relative ridge `w = 10⁻⁴` at the size of
//! its data sets, `N₀ = 60` poses, frozen so that its information stays fixed as poses are
//! added. An arm whose unmodelled error is large is held loosely (a Kinova Gen3 lite
//! placement, 1.4 cm), a precise one tightly (the Pandas, 1.2 to 2.9 mm). Model-error-free
//! data (a tracker on a simulated PUMA: −0.78, −0.42 and −0.75 standard deviations at 100,
//! 1 000 and 10 000 poses) keep the cross-validated choice.

use nalgebra::{DMatrix, SymmetricEigen};

use super::super::choice::DEFAULT_PRIOR_WEIGHT;
use super::{pseudo_inverse, Candidate, Grouping, Linearized};
use crate::calibrate::outliers::ROUNDING_FLOOR;

/// How many of its standard deviations the held-out sum of squares must exceed its
/// expectation under white noise before the fits count as absorbing an error the model
/// cannot hold (module docs).
pub const SYSTEMATIC_Z: f64 = 3.0;
/// The poses at which [`residual_tolerance`] equals MUKCa's relative ridge at its weight
/// [`DEFAULT_PRIOR_WEIGHT`] (the size of MUKCa's data sets, 57-77 poses a placement).
pub const REFERENCE_POSES: f64 = 60.0;

/// The tolerance of every joint mounting (metres ≡ radians) where the residual is mostly
/// error the model cannot hold: `σ̂/√(N₀·w)`, `N₀` [`REFERENCE_POSES`] and `w`
/// [`DEFAULT_PRIOR_WEIGHT`], about `12.9·σ̂`, kept within the grid's 1 µm to 1 m.
#[must_use]
pub fn residual_tolerance(sigma: f64) -> f64 {
    (sigma / (REFERENCE_POSES * DEFAULT_PRIOR_WEIGHT).sqrt()).clamp(1e-6, 1.0)
}

/// The lack-of-fit test of the folds by cluster (module docs; JSON
/// `prior.selection.lack_of_fit`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LackOfFit {
    /// The start's held-out sum of squares over its expectation `E` under white noise:
    /// about 1 when the model holds the data.
    pub ratio: f64,
    /// How many standard deviations of that sum beyond `E` it lies,
    /// `(Σ‖e‖² − E)/√Var`; beyond [`SYSTEMATIC_Z`] the rule is [`super::StrengthRule::Residual`].
    pub sigmas: f64,
}

/// The lack-of-fit test on `lin`'s folds by cluster for the prior `c`, whose held-out sums
/// of squares are `observed` (fold by fold), over every fold but the one farthest beyond its
/// expectation (module docs); `None` with folds by placement, fewer than three folds, a
/// noise level of rounding (exact data: below [`ROUNDING_FLOOR`], where held-out residuals
/// are rounding too and their ratio says nothing), or where a figure is not finite.
pub(super) fn lack_of_fit(lin: &Linearized, c: Candidate, observed: &[f64]) -> Option<LackOfFit> {
    if lin.grouping != Grouping::Clusters
        || observed.len() < 3
        || lin.sigma2.sqrt() <= ROUNDING_FLOOR
    {
        return None;
    }
    let folds: Vec<(f64, f64, f64)> = lin
        .expected_held_out(c)
        .into_iter()
        .zip(observed)
        .map(|((e, v), &o)| (o, e, v))
        .collect();
    let z = |&(o, e, v): &(f64, f64, f64)| (o - e) / v.sqrt();
    let farthest = (0..folds.len()).max_by(|&a, &b| z(&folds[a]).total_cmp(&z(&folds[b])))?;
    let (mut o, mut e, mut v) = (0.0, 0.0, 0.0);
    for (f, fold) in folds.iter().enumerate() {
        if f != farthest {
            o += fold.0;
            e += fold.1;
            v += fold.2;
        }
    }
    Some(LackOfFit {
        ratio: o / e,
        sigmas: (o - e) / v.sqrt(),
    })
    .filter(|l| l.ratio.is_finite() && l.sigmas.is_finite())
}

impl Linearized {
    /// The held-out sum of squares white noise at `σ̂` would leave with the prior `c`, were
    /// the model adequate, and its variance: `E = σ̂²·Σ_f (m_f − l_f + tr(M_f))` and
    /// `2σ̂⁴·Σ_f (m_f − l_f + 2 tr(M_f) + tr(M_f²))`, `M_f = A_f⁻¹S_f`, `A_f` the training
    /// Gram matrix with the prior over the columns `K` the fit solves for, `S_f` the fold's
    /// Gram matrix over `K` with its own refitted columns `L` projected out (the Schur
    /// complement `G_KK − G_KL G_LL⁺ G_LK`), `l_f` their rank (module docs). With the truth
    /// drawn from the prior, `E` is the exact predictive expectation (the prior's pull on the
    /// estimate included); the folds' correlations are left out.
    fn expected_held_out(&self, c: Candidate) -> Vec<(f64, f64)> {
        let mut out = Vec::with_capacity(self.folds);
        for f in 0..self.folds {
            let aug = self.training(Some(f));
            let p = self.precision(c, Some(f), &aug);
            let n = aug.nrows() - 1;
            let unseen = self.unseen(Some(f), &aug);
            let kept: Vec<usize> = (0..n).filter(|&c| !unseen[c]).collect();
            let a = self.normal_matrix(&aug, &kept, Some(&p));
            let g = &self.gram[f];
            let block = |rows: &[usize], cols: &[usize]| {
                DMatrix::from_fn(rows.len(), cols.len(), |r, c| g[(rows[r], cols[c])])
            };
            let mut gk = block(&kept, &kept);
            // The fold's own values are refitted on it: their columns are projected out of
            // the held-out residual, taking a degree of freedom each of their rank.
            let refitted: Vec<usize> = (0..n).filter(|&c| unseen[c]).collect();
            let mut local = 0.0;
            if !refitted.is_empty() {
                let (inverse, rank) = pseudo_inverse_rank(block(&refitted, &refitted));
                let gkl = block(&kept, &refitted);
                gk -= &gkl * inverse * gkl.transpose();
                local = rank as f64;
            }
            let inverse = match a.clone().cholesky() {
                Some(c) => c.inverse(),
                None => pseudo_inverse(a),
            };
            let spread = inverse * gk;
            let leverage = spread.trace();
            let rows = self.fold_rows[f] as f64;
            let expected = self.sigma2 * (rows - local + leverage);
            // `‖e‖²/σ̂²` is a sum of `χ²₁` weighted by the eigenvalues of `Q(I + J A⁻¹Jᵀ)Q`
            // (`Q` the projection off the refitted columns): variance twice the trace of
            // its square, `2(m − l + 2 tr(M) + tr(M²))`; `tr(M²) = Σ_ij M_ij·M_ji`.
            let square = spread.component_mul(&spread.transpose()).sum();
            let variance =
                2.0 * self.sigma2 * self.sigma2 * (rows - local + 2.0 * leverage + square);
            out.push((expected, variance));
        }
        out
    }
}

/// The pseudo-inverse of a symmetric positive semi-definite matrix and its rank (eigenvalues
/// below `10⁻¹²` of the largest taken as 0, as [`pseudo_inverse`]).
fn pseudo_inverse_rank(a: DMatrix<f64>) -> (DMatrix<f64>, usize) {
    let e = SymmetricEigen::new(a);
    let top = e.eigenvalues.iter().fold(0.0, |m: f64, &v| m.max(v.abs()));
    let kept = |v: f64| v > 1e-12 * top && v > 0.0;
    let rank = e.eigenvalues.iter().filter(|&&v| kept(v)).count();
    let d = e.eigenvalues.map(|v| if kept(v) { 1.0 / v } else { 0.0 });
    (
        &e.eigenvectors * DMatrix::from_diagonal(&d) * e.eigenvectors.transpose(),
        rank,
    )
}
