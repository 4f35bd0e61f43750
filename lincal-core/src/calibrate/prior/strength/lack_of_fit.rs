//! The lack-of-fit test of the folds by joint-space cluster, and the tolerance taken from
//! the residual level where it fails (the default prior's choice, [`super`]).
//!
//! Clusters of one placement are trusted only where the model explains the poses they did
//! not see. Under an adequate model with white noise at `σ̂`, the drawing's held-out sum of
//! squares has the expectation `E = σ̂²·Σ_f (m_f + tr(A_f⁻¹ G_f) − l_f)` (`m_f` the fold's
//! rows, `G_f` its Gram matrix, `A_f` the training set's with the prior, `l_f` the fold's own
//! refitted values): the noise plus the estimate's own variance at the fold's readings. Its
//! ratio to the observed sum ([`LackOfFit`]) is about 1; its variance
//! `2σ̂⁴·Σ_f (m_f + 2 tr(M_f) + tr(M_f²) − l_f)` (`M_f = A_f⁻¹G_f`: a fold the others barely
//! predict has a few large terms and a heavy tail) gives the test. Beyond [`SYSTEMATIC_Z`]
//! standard deviations the fits extrapolate to the held-out clusters worse than noise and
//! the estimate's own variance explain: the parameters absorb an error the model cannot hold
//! (joint compliance, gear eccentricity, a sagging tool) differently in each region of joint
//! space. The clusters' curve then measures how well the fit absorbs that error, not how the
//! arm extrapolates to the next placement (on MUKCa's `panda_2/back_right` the
//! clusters prefer a prior of 1 m where the other placements are predicted best at about
//! 1 mm, 2.4× better). There the tolerance is taken from the residual itself,
//! `τ = σ̂/√(N₀·w)` ([`residual_tolerance`]): MUKCa's relative ridge `w = 10⁻⁴` at the size of
//! its data sets, `N₀ = 60` poses, frozen so that its information stays fixed as poses are
//! added. An arm whose unmodelled error is large is held loosely (the Kinova Gen3 lite, about
//! 1 cm), a precise one tightly (the Pandas, about 1 mm). Model-error-free data (a tracker on
//! a simulated arm: 0.985, 0.997 and 1.000 at 100, 1 000 and 10 000 poses) keep the
//! cross-validated choice.

use nalgebra::DMatrix;

use super::super::choice::DEFAULT_PRIOR_WEIGHT;
use super::{pseudo_inverse, Candidate, Grouping, Linearized};

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
    /// The drawing's held-out sum of squares over its expectation `E` under white noise:
    /// about 1 when the model holds the data.
    pub ratio: f64,
    /// How many standard deviations of that sum beyond `E` it lies,
    /// `(Σ‖e‖² − E)/√Var`; beyond [`SYSTEMATIC_Z`] the rule is [`super::StrengthRule::Residual`].
    pub sigmas: f64,
}

/// The lack-of-fit test on `lin`'s folds by cluster for the prior `c`, whose held-out sum of
/// squares over the folds is `observed`; `None` with folds by placement or where a figure is
/// not finite.
pub(super) fn lack_of_fit(lin: &Linearized, c: Candidate, observed: f64) -> Option<LackOfFit> {
    if lin.grouping != Grouping::Clusters {
        return None;
    }
    let (expected, variance) = lin.expected_held_out(c);
    Some(LackOfFit {
        ratio: observed / expected,
        sigmas: (observed - expected) / variance.sqrt(),
    })
    .filter(|l| l.ratio.is_finite() && l.sigmas.is_finite())
}

impl Linearized {
    /// The held-out sum of squares white noise at `σ̂` would leave with the prior `c`, were
    /// the model adequate, and its variance: `E = σ̂²·Σ_f (m_f + tr(M_f) − l_f)` and
    /// `2σ̂⁴·Σ_f (m_f + 2 tr(M_f) + tr(M_f²) − l_f)`, `M_f = A_f⁻¹G_f`, `A_f` the training
    /// Gram matrix with the prior over the columns the fit solves for, `G_f` the fold's over
    /// the same, `l_f` the fold's own refitted columns (module docs). The prior's pull on the
    /// estimate is left out (a bias, not noise), and so are the folds' correlations.
    fn expected_held_out(&self, c: Candidate) -> (f64, f64) {
        let (mut expected, mut variance) = (0.0, 0.0);
        for f in 0..self.folds {
            let aug = self.training(Some(f));
            let p = self.precision(c, Some(f), &aug);
            let n = aug.nrows() - 1;
            let unseen = self.unseen(Some(f), &aug);
            let kept: Vec<usize> = (0..n).filter(|&c| !unseen[c]).collect();
            let mut a = DMatrix::from_fn(kept.len(), kept.len(), |r, c| aug[(kept[r], kept[c])]);
            let at: Vec<Option<usize>> = self
                .arm
                .iter()
                .map(|&ai| kept.iter().position(|&c| c == ai))
                .collect();
            for (i, ri) in at.iter().enumerate() {
                for (j, rj) in at.iter().enumerate() {
                    if let (Some(ri), Some(rj)) = (ri, rj) {
                        a[(*ri, *rj)] += self.sigma2 * p[(i, j)];
                    }
                }
            }
            let g = &self.gram[f];
            let gk = DMatrix::from_fn(kept.len(), kept.len(), |r, c| g[(kept[r], kept[c])]);
            let inverse = match a.clone().cholesky() {
                Some(c) => c.inverse(),
                None => pseudo_inverse(a),
            };
            let spread = inverse * gk;
            let leverage = spread.trace();
            // The fold's own values refitted on it take a degree of freedom each.
            let local = (0..n).filter(|&c| unseen[c] && g[(c, c)] > 0.0).count() as f64;
            let rows = self.fold_rows[f] as f64;
            expected += self.sigma2 * (rows + leverage - local);
            // `‖e‖²/σ̂²` is a sum of `χ²₁` weighted by the eigenvalues of `I + J A⁻¹Jᵀ`:
            // variance `2·tr((I + J A⁻¹Jᵀ)²) = 2(m + 2 tr(A⁻¹G) + tr((A⁻¹G)²))`.
            // `tr(M²) = Σ_ij M_ij·M_ji`, without the product.
            let square = spread.component_mul(&spread.transpose()).sum();
            variance += 2.0 * self.sigma2 * self.sigma2 * (rows + 2.0 * leverage + square - local);
        }
        (expected, variance)
    }
}
