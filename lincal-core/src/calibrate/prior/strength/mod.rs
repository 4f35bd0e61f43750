//! The prior's strength and shape chosen from the data at every run ([`super::PriorScale::Auto`],
//! the default; [`super::PriorScale`]).
//!
//! # The candidates
//! In the frame prior's whitened coordinates `u = L⁻¹(p_A − μ)` (`Σ = LLᵀ` the frame
//! prior's covariance at tolerances of 1 m and 1 rad, `p_A` the arm's free parameters, `μ`
//! their nominals) the data's information is `G = LᵀSL/σ̂²`, `S` the Gram matrix `JᵀJ` of the
//! residuals at the fit with the drawing's tolerance, with the base, tool and constraint parameters
//! profiled out (a Schur complement: they take their share without a prior). Two families
//! of priors `u ~ N(0, C)` compete, each with a fixed information (not growing with the
//! poses, so that with enough data every fit becomes the plain least-squares fit):
//! - **one scale** `C = τ²I`: every joint mounting off by `τ` (metres and radians), `τ` on a
//!   grid of quarter decades from 1 µm to 1 m ([`scale_grid`]);
//! - **per direction** (automatic relevance determination): in the eigenbasis `G = VHVᵀ`
//!   of the data's information, `C = V·diag(s_k²)·Vᵀ` with each `s_k²` the maximiser of
//!   the evidence of its own direction, `z_k = v_kᵀû ~ N(0, s_k² + 1/h_k)`:
//!   `s_k² = max(z_k² − 1/h_k, 0) + s_min²` ([`ARD_FLOOR`]). A direction the data see well
//!   (`h_k z_k² ≫ 1`) is shrunk by `1/(h_k z_k²)`, nearly nothing; one whose estimate is
//!   within its own noise of the nominal is held there. Directions the data do not see at
//!   all (`h_k·τ₀² < 10⁻⁶`) keep the default tolerance `τ₀` ([`UNSEEN_TOLERANCE`]).
//!
//! A real arm's weak directions are few and carry errors of very different sizes (a wrist's
//! home offset off by 50 mrad beside mountings right to the micrometre), where one scale
//! must either let the null directions drift or pull the large one in; the per-direction
//! prior weighs each by its own evidence.
//!
//! # The choice: grouped cross-validation
//! Every candidate is judged on poses its fit did not see, with folds by placement or by
//! joint-space cluster ([`crate::calibrate::grouping`]). The starting tolerance
//! `τ₀ = max(τ_d, σ̂/√(N·w))` ([`start_tolerance`]) is taken unless another candidate leaves a
//! smaller held-out sum of squares by more than one standard error of the difference (paired
//! over the folds) and by more than [`MIN_GAIN`]; then the one with the least is taken. The
//! data must show another strength better, not merely luckier: a direction they barely see
//! changes the held-out residual by nothing, and only the start holds it. A prior stronger
//! than the start (one that holds more directions in effect) competes only with folds by
//! placement: clusters of one placement share its systematic errors, and a stronger prior
//! that wins on them need not win on the next placement.
//!
//! `τ_d` is the drawing's tolerance ([`UNSEEN_TOLERANCE`] for every joint mounting), a prior
//! whose information is fixed, so it fades as poses are added. `σ̂/√(N·w)` is MUKCa's
//! relative ridge (`w = 10⁻⁴`) at this data set's `N` poses and noise level: where it is
//! the looser (few poses, or a residual of a millimetre), the drawing would hold the arm
//! tighter than the established tool does, and on MUKCa's Kinova data that cost 0.3-1.7 %
//! in-sample and up to 9.5 % held out (docs/benchmarks/accuracy.md, session 41). The larger
//! of the two still has the drawing's bounded information, so the prior fades all the same.
//!
//! # Errors the model cannot hold
//! Clusters of one placement are trusted only where the model explains the poses they did
//! not see: a lack-of-fit test ([`lack_of_fit`](mod@lack_of_fit)) compares the start's held-out sum of
//! squares with its distribution under white noise. Beyond [`SYSTEMATIC_Z`] standard
//! deviations the clusters do not choose, and one tolerance comes from the residual level
//! ([`residual_tolerance`]).
//!
//! # The fits
//! The fits are the Gauss-Newton steps of the linearised problem at the
//! fit with the drawing's tolerance (exact for a linear model): for fold `f`,
//! `δ = −(H_T + σ̂²P)⁻¹(b_T + σ̂²P(p̂_A − μ))` with `H_T, b_T` the Gram matrix and gradient of
//! the other folds (and the relations' rows), `P` the candidate's precision on `p_A`; the
//! held-out residuals are `g_f + J_fδ`, with the parameters only fold `f` sees (a held-out
//! placement's own point or plane) refitted on it. The per-direction prior is found again
//! from each fold's own data. Per fold, one eigen-decomposition serves every one-scale
//! candidate (of the whitened Schur complement onto the arm) and one more the per-direction
//! prior: a millisecond or two for a 7-joint arm.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use crate::calibrate::grouping::{self, Grouping};
use crate::data::Poses;
use crate::error::Result;
use crate::model::CalibModel;

use super::choice::{DEFAULT_LENGTH_TOLERANCE, DEFAULT_PRIOR_WEIGHT};

mod grams;
pub mod lack_of_fit;
mod one_scale;

use grams::{fold_grams, relation_grams};
use one_scale::OneScale;

pub use lack_of_fit::{residual_tolerance, LackOfFit, REFERENCE_POSES, SYSTEMATIC_Z};

/// The folds of the choice when the poses lie on one placement (joint-space clusters).
pub const CLUSTER_FOLDS: usize = 5;
/// At most this many folds of placements (more placements are merged in turn).
pub const PLACEMENT_FOLDS: usize = 10;
/// The smallest prior standard deviation of a direction in the per-direction prior (metres
/// and radians alike, of a joint mounting): a direction the data leave within their noise
/// of the nominal is held there, to 10 µm or 10 µrad, not exactly.
pub const ARD_FLOOR: f64 = 1e-5;
/// The prior standard deviation of a direction the data do not see at all: the default
/// tolerance of a joint mounting.
pub const UNSEEN_TOLERANCE: f64 = DEFAULT_LENGTH_TOLERANCE;

/// The single-scale candidates `τ` (metres ≡ radians): quarter decades from 1 µm to 1 m.
#[must_use]
pub fn scale_grid() -> Vec<f64> {
    (0..=24)
        .map(|i| 10f64.powf(-6.0 + 0.25 * f64::from(i)))
        .collect()
}

/// Whether two tolerances are the same candidate (equal to rounding).
pub(crate) fn same_tolerance(a: f64, b: f64) -> bool {
    (a / b).ln().abs() < 1e-6
}

/// The tolerance the choice starts from (module docs, *The choice*), metres ≡ radians:
/// `τ₀ = max(τ_d, σ̂/√(N·w))`, the drawing's [`UNSEEN_TOLERANCE`] `τ_d` or MUKCa's relative
/// ridge at this data set (`w` = [`DEFAULT_PRIOR_WEIGHT`] over `N` poses at the noise level
/// `σ̂`), whichever is looser, at most 1 m.
///
/// Its information `min(1/τ_d², N·w/σ̂²)` is bounded by the drawing's, so the prior still
/// fades as poses are added (the relative part passes 1 cm only where `σ̂ > 10⁻⁴·√N` m: 1 mm
/// at 100 poses, never at a tracker's 50 µm);
/// where the residual level is high against the poses (a Kinova Gen3 lite, 0.6-1.1 mm over
/// 40-57 poses) the drawing's fixed tolerance held the arm tighter than the established
/// ridge does, and worse for it, in-sample and held out.
#[must_use]
pub fn start_tolerance(sigma: f64, poses: usize) -> f64 {
    let relative = sigma / (poses.max(1) as f64 * DEFAULT_PRIOR_WEIGHT).sqrt();
    if relative.is_finite() {
        UNSEEN_TOLERANCE.max(relative.min(1.0))
    } else {
        UNSEEN_TOLERANCE
    }
}

/// Which prior the data chose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StrengthRule {
    /// One scale for every joint mounting ([`StrengthSelection::tolerance`]).
    Scale,
    /// Each direction by its own evidence (automatic relevance determination).
    Ard,
    /// One scale for every joint mounting from the residual level
    /// ([`residual_tolerance`]): the held-out residual showed error the model cannot hold
    /// ([`StrengthSelection::lack_of_fit`]).
    Residual,
}

/// One point of the cross-validation curve of the single-scale prior.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CurvePoint {
    /// The tolerance `τ` of every joint mounting (metres ≡ radians).
    pub tolerance: f64,
    /// The held-out RMS residual with it (metres).
    pub rms: f64,
}

/// How the prior's strength was chosen, for the reports (JSON `prior.selection`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StrengthSelection {
    /// The prior chosen.
    pub rule: StrengthRule,
    /// The single scale's tolerance when that was chosen (metres ≡ radians).
    pub tolerance: Option<f64>,
    /// The tolerance the choice started from ([`start_tolerance`]): the drawing's, or MUKCa's
    /// relative ridge at this data set where that is looser (metres ≡ radians).
    pub start: f64,
    /// How the poses were grouped into folds.
    pub grouping: Grouping,
    /// The number of folds (1: too few poses or placements to cross-validate, and the
    /// start was taken).
    pub folds: usize,
    /// The single scale's held-out RMS residual at each tolerance of the grid.
    pub curve: Vec<CurvePoint>,
    /// The per-direction prior's held-out RMS residual (metres), when cross-validated.
    pub ard_rms: Option<f64>,
    /// With folds by joint-space cluster: the start's held-out sum of squares against its
    /// distribution under white noise at the noise level (module docs, *Errors the model
    /// cannot hold*).
    pub lack_of_fit: Option<LackOfFit>,
    /// The directions of the arm the prior acts on (its free parameters).
    pub directions: usize,
    /// How many of those the chosen prior holds, in effect: `Σ_k π_k/(π_k + h_k)` over the
    /// eigen-directions of the data's information `h_k` (whitened), `π_k` the prior's
    /// information there (`1/τ²`, or `1/s_k²`). The parameter count less the fit's effective
    /// degrees of freedom: 0 when the data decide everything, the directions' count when the
    /// prior does. A stronger prior holds more.
    pub held: f64,
}

/// The prior the data chose: its square root `R` over the arm's parameters (`RᵀR = P`,
/// in their own units: the fit adds the rows `σ̂·R(p_A − μ)`), how it was chosen, and
/// whether it is the drawing's tolerance (the prior of the fit the choice was linearised at).
pub struct Chosen {
    /// `R`.
    pub root: DMatrix<f64>,
    /// How it was chosen.
    pub selection: StrengthSelection,
    /// Whether it is the drawing's tolerance ([`UNSEEN_TOLERANCE`] as one scale).
    pub drawing: bool,
}

/// A candidate's held-out squared residuals per fold, and the rows they are over.
struct FoldScores {
    sums: Vec<f64>,
    rows: usize,
}

impl FoldScores {
    /// The held-out RMS residual.
    fn rms(&self) -> f64 {
        (self.sums.iter().sum::<f64>() / self.rows.max(1) as f64).sqrt()
    }
}

/// The least relative gain in held-out sum of squares (0.5 %, a quarter of a percent of the
/// RMS) for which the choice leaves the start ([`start_tolerance`]): below it, a direction the data
/// barely see (whose freedom fits a little noise in every fold alike) would be let go.
pub const MIN_GAIN: f64 = 0.005;

/// The candidate taken (module docs, *The choice*): the start (`default`,
/// [`start_tolerance`] for every joint mounting) unless another candidate's
/// held-out sum of squares is below its own by more than one standard error of the
/// difference (paired over the folds) and by more than [`MIN_GAIN`] of it; then the least.
/// Only the `allowed` candidates compete. The data must show another strength
/// better, not merely luckier, before it is taken: a direction the data barely see moves the
/// held-out residual by nothing, and only the start holds it.
fn one_standard_error(default: usize, scores: &[FoldScores], allowed: &[bool]) -> usize {
    let total = |s: &FoldScores| s.sums.iter().sum::<f64>();
    let best = (0..scores.len())
        .filter(|&c| allowed[c])
        .min_by(|&a, &b| total(&scores[a]).total_cmp(&total(&scores[b])))
        .unwrap_or(default);
    let folds = scores[best].sums.len() as f64;
    let d: Vec<f64> = scores[default]
        .sums
        .iter()
        .zip(&scores[best].sums)
        .map(|(a, b)| a - b)
        .collect();
    let mean = d.iter().sum::<f64>() / folds;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (folds - 1.0).max(1.0);
    // The totals' difference against its standard error `√(F·var)`.
    let gain = mean * folds;
    if gain <= (folds * var).sqrt() || gain <= MIN_GAIN * total(&scores[default]) {
        default
    } else {
        best
    }
}

/// The problem linearised at the fit with the drawing's tolerance (module docs).
struct Linearized {
    /// The arm's positions among the free parameters (the plan's order).
    arm: Vec<usize>,
    /// `p̂_A − μ`.
    offset: DVector<f64>,
    /// `L⁻¹` (`u = L⁻¹(p_A − μ)`).
    linv: DMatrix<f64>,
    /// `L⁻ᵀL⁻¹ = Σ⁻¹`, the one-scale candidates' precision at `τ` = 1 (each candidate's is
    /// this over `τ²`: formed once, not once per fold and candidate).
    unit_precision: DMatrix<f64>,
    /// `L`.
    l: DMatrix<f64>,
    /// `σ̂²`.
    sigma2: f64,
    /// The free parameters (model indices), the columns of `J`.
    free: Vec<usize>,
    /// Per fold, the Gram matrix of its rows `[J | g]ᵀ[J | g]` (`n + 1` square): all the
    /// cross-validation needs of the rows, so they are never held all at once.
    gram: Vec<DMatrix<f64>>,
    /// Per fold, its row count.
    fold_rows: Vec<usize>,
    /// Each relation's rows' Gram matrix, with the constraints it relates: in a training
    /// set when both have poses there.
    relations: Vec<(DMatrix<f64>, [usize; 2])>,
    /// Per fold, per constraint: whether the other folds have poses on it.
    trained: Vec<Vec<bool>>,
    /// Per constraint, the free positions of its values that are parameters.
    values: Vec<Vec<usize>>,
    /// The number of folds (the per-pose assignment is not kept: the Gram matrices hold it).
    folds: usize,
    grouping: Grouping,
}

/// A candidate prior.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Candidate {
    Scale(f64),
    Ard,
}

/// The prior of the data's choice (module docs) for the arm's free parameters `arm` (model
/// indices), whose frame-prior square root at unit tolerances is `root_unit` (`k × k`,
/// `L⁻¹`), at the fit with the drawing's tolerance `p_hat`, with noise level `sigma` (the
/// unregularised fit's). `None` when the
/// arm's parameters are not all free there or `L⁻¹` is singular.
///
/// # Errors
/// A pose whose residual or Jacobian is not finite at `p_hat`.
pub(super) fn choose(
    model: &dyn CalibModel,
    poses: &Poses,
    arm: &[usize],
    root_unit: &DMatrix<f64>,
    p_hat: &[f64],
    sigma: f64,
) -> Result<Option<Chosen>> {
    let Some(lin) = Linearized::new(model, poses, arm, root_unit, p_hat, sigma)? else {
        return Ok(None);
    };
    let k = lin.arm.len();
    let all = lin.training(None);
    let (e, u) = lin.whitened_eigen(None, &all);
    let (ard, ard_held) = lin.ard_from(&e, &u);
    let h = e.eigenvalues;
    let scale_held = |t: f64| {
        let prior = 1.0 / (t * t);
        h.iter().map(|&e| prior / (prior + e.max(0.0))).sum::<f64>()
    };
    let start = start_tolerance(lin.sigma2.sqrt(), poses.len());
    let mut grid = scale_grid();
    if !grid.iter().any(|&t| same_tolerance(t, start)) {
        grid.push(start);
        grid.sort_by(f64::total_cmp);
    }
    let mut candidates: Vec<(Candidate, f64)> = grid
        .into_iter()
        .map(|t| (Candidate::Scale(t), scale_held(t)))
        .collect();
    candidates.push((Candidate::Ard, ard_held));
    let is_drawing =
        |c: Candidate| matches!(c, Candidate::Scale(t) if same_tolerance(t, UNSEEN_TOLERANCE));
    let default = candidates
        .iter()
        .position(|&(c, _)| matches!(c, Candidate::Scale(t) if same_tolerance(t, start)))
        .unwrap_or(candidates.len() - 1);
    // Without two folds, the start.
    let (pick, curve, ard_rms, lack_of_fit) = if lin.folds >= 2 {
        cross_validated(&lin, &candidates, default)
    } else {
        (default, Vec::new(), None, None)
    };
    let systematic = lack_of_fit.is_some_and(|l| l.sigmas > SYSTEMATIC_Z);
    let (chosen, held) = if systematic {
        let t = residual_tolerance(lin.sigma2.sqrt());
        (Candidate::Scale(t), scale_held(t))
    } else {
        candidates[pick]
    };
    let root = match chosen {
        Candidate::Scale(t) => &lin.linv / t,
        Candidate::Ard => ard,
    };
    Ok(Some(Chosen {
        root,
        drawing: is_drawing(chosen),
        selection: StrengthSelection {
            rule: match chosen {
                _ if systematic => StrengthRule::Residual,
                Candidate::Scale(_) => StrengthRule::Scale,
                Candidate::Ard => StrengthRule::Ard,
            },
            tolerance: match chosen {
                Candidate::Scale(t) => Some(t),
                Candidate::Ard => None,
            },
            start,
            grouping: lin.grouping,
            folds: lin.folds,
            curve,
            ard_rms,
            lack_of_fit,
            directions: k,
            held,
        },
    }))
}

/// Every candidate's held-out figures: the one taken ([`one_standard_error`] from `default`),
/// the single scale's curve, the per-direction prior's RMS and, with folds by cluster, the
/// drawing's lack of fit ([`StrengthSelection::lack_of_fit`]).
fn cross_validated(
    lin: &Linearized,
    candidates: &[(Candidate, f64)],
    default: usize,
) -> (usize, Vec<CurvePoint>, Option<f64>, Option<LackOfFit>) {
    let scores = lin.cross_validate(candidates);
    let mut curve = Vec::new();
    let mut ard_rms = None;
    for ((c, _), s) in candidates.iter().zip(&scores) {
        match c {
            Candidate::Scale(t) => curve.push(CurvePoint {
                tolerance: *t,
                rms: s.rms(),
            }),
            Candidate::Ard => ard_rms = Some(s.rms()),
        }
    }
    // Folds within one placement share its systematic errors: there, a prior stronger than
    // the drawing's (holding more directions in effect) that wins held out wins on errors
    // the next placement will not have (MUKCa's Kinova: 1.8 mm chosen in-session where
    // 14 mm generalises to the other placements). Only folds by placement may choose it.
    let allowed: Vec<bool> = candidates
        .iter()
        .map(|&(_, held)| {
            lin.grouping == Grouping::Placements || held <= candidates[default].1 + 1e-12
        })
        .collect();
    let lack_of_fit = lack_of_fit::lack_of_fit(lin, candidates[default].0, &scores[default].sums);
    (
        one_standard_error(default, &scores, &allowed),
        curve,
        ard_rms,
        lack_of_fit,
    )
}

impl Linearized {
    fn new(
        model: &dyn CalibModel,
        poses: &Poses,
        arm: &[usize],
        root_unit: &DMatrix<f64>,
        p_hat: &[f64],
        sigma: f64,
    ) -> Result<Option<Linearized>> {
        // The fit's free set (the model's gauge rule), whichever poses a chunk holds.
        let free = crate::numeric::lm::FreeSet::new(model, p_hat).free;
        let Some(arm_pos) = arm
            .iter()
            .map(|j| free.iter().position(|f| f == j))
            .collect::<Option<Vec<usize>>>()
        else {
            return Ok(None);
        };
        let k = arm.len();
        if k == 0 || root_unit.nrows() != k || root_unit.ncols() != k {
            return Ok(None);
        }
        let Some(l) = root_unit.clone().try_inverse() else {
            return Ok(None);
        };
        let offset =
            DVector::from_iterator(k, arm.iter().map(|&j| p_hat[j] - model.param_nominal(j)));
        let used = grouping::placements(poses);
        let placements = if used.len() >= grouping::MIN_PLACEMENTS {
            PLACEMENT_FOLDS
        } else {
            CLUSTER_FOLDS
        };
        let folds = grouping::folds(model, poses, placements.min(poses.len()));
        let (gram, fold_rows) = fold_grams(model, poses, p_hat, free.len() + 1, &folds, sigma)?;
        let relations = relation_grams(model, p_hat, &free, &gram);
        let nc = model.constraint_count();
        let trained = (0..folds.folds)
            .map(|f| {
                let mut t = vec![false; nc];
                for (l, c) in poses.constraint.iter().enumerate() {
                    if folds.fold[l] != f && c < nc {
                        t[c] = true;
                    }
                }
                t
            })
            .collect();
        let values = (0..nc)
            .map(|c| {
                (0..model.constraint_kind(c).value_count(model.dim()))
                    .filter_map(|v| model.constraint_value_param(c, v))
                    .filter_map(|j| free.iter().position(|&f| f == j))
                    .collect()
            })
            .collect();
        Ok(Some(Linearized {
            arm: arm_pos,
            offset,
            unit_precision: root_unit.transpose() * root_unit,
            linv: root_unit.clone(),
            l,
            sigma2: sigma * sigma,
            free,
            gram,
            fold_rows,
            relations,
            trained,
            values,
            folds: folds.folds,
            grouping: folds.grouping,
        }))
    }

    /// The Gram matrix `[J | g]ᵀ[J | g]` of every fold but `out` (all with `None`), and the
    /// rows of the relations between constraints it has poses on.
    fn training(&self, out: Option<usize>) -> DMatrix<f64> {
        let w = self.free.len() + 1;
        let mut t = DMatrix::zeros(w, w);
        for (f, g) in self.gram.iter().enumerate() {
            if Some(f) != out {
                t += g;
            }
        }
        for (g, [i, j]) in &self.relations {
            let on =
                |c: usize| out.is_none_or(|f| self.trained[f].get(c).copied().unwrap_or(false));
            if on(*i) && on(*j) {
                t += g;
            }
        }
        t
    }

    /// The free parameters (positions) the training set `aug` (without fold `out`) does not
    /// see and no prior holds: a held-out placement's own values, refitted on it.
    fn unseen(&self, out: Option<usize>, aug: &DMatrix<f64>) -> Vec<bool> {
        let n = aug.nrows() - 1;
        let top = (0..n).map(|c| aug[(c, c)]).fold(0.0, f64::max);
        let mut unseen: Vec<bool> = (0..n).map(|c| aug[(c, c)] <= 1e-20 * top).collect();
        if let Some(f) = out {
            for (c, vals) in self.values.iter().enumerate() {
                if !self.trained[f][c] {
                    for &v in vals {
                        unseen[v] = true;
                    }
                }
            }
        }
        for &a in &self.arm {
            unseen[a] = false;
        }
        unseen
    }

    /// The linearised fit on `aug` with the prior of precision `p` (over the arm, own
    /// units, `None`: no prior): the step `δ` over the free parameters (0 on those unseen).
    fn step(
        &self,
        out: Option<usize>,
        aug: &DMatrix<f64>,
        p: Option<&DMatrix<f64>>,
    ) -> DVector<f64> {
        let n = aug.nrows() - 1;
        let unseen = self.unseen(out, aug);
        let kept: Vec<usize> = (0..n).filter(|&c| !unseen[c]).collect();
        let a = self.normal_matrix(aug, &kept, p);
        let mut rhs = DVector::from_fn(kept.len(), |r, _| -aug[(kept[r], n)]);
        if let Some(p) = p {
            let po = p * &self.offset;
            for (i, ri) in self.arm_rows(&kept).into_iter().enumerate() {
                if let Some(ri) = ri {
                    rhs[ri] -= self.sigma2 * po[i];
                }
            }
        }
        let x = solve_psd(a, &rhs);
        let mut delta = DVector::zeros(n);
        for (r, &c) in kept.iter().enumerate() {
            delta[c] = x[r];
        }
        delta
    }

    /// The arm's rows among the columns `kept` (`None`: not among them).
    fn arm_rows(&self, kept: &[usize]) -> Vec<Option<usize>> {
        self.arm
            .iter()
            .map(|&ai| kept.iter().position(|&c| c == ai))
            .collect()
    }

    /// The normal matrix of the fit on `aug` over the columns `kept`, with the prior of
    /// precision `p` over the arm (`σ̂²P` added): `A = H_KK + σ̂²P`.
    fn normal_matrix(
        &self,
        aug: &DMatrix<f64>,
        kept: &[usize],
        p: Option<&DMatrix<f64>>,
    ) -> DMatrix<f64> {
        let mut a = DMatrix::from_fn(kept.len(), kept.len(), |r, c| aug[(kept[r], kept[c])]);
        if let Some(p) = p {
            let at = self.arm_rows(kept);
            for (i, ri) in at.iter().enumerate() {
                for (j, rj) in at.iter().enumerate() {
                    if let (Some(ri), Some(rj)) = (ri, rj) {
                        a[(*ri, *rj)] += self.sigma2 * p[(i, j)];
                    }
                }
            }
        }
        a
    }

    /// The data's information in the whitened coordinates `u`, `LᵀSL/σ̂²` (`S` the Schur
    /// complement of `aug`'s Gram matrix onto the arm), and the unregularised estimate `û`.
    fn whitened_information(
        &self,
        out: Option<usize>,
        aug: &DMatrix<f64>,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let n = aug.nrows() - 1;
        let unseen = self.unseen(out, aug);
        let others: Vec<usize> = (0..n)
            .filter(|c| !unseen[*c] && !self.arm.contains(c))
            .collect();
        let k = self.arm.len();
        let haa = DMatrix::from_fn(k, k, |r, c| aug[(self.arm[r], self.arm[c])]);
        let s = if others.is_empty() {
            haa
        } else {
            let han = DMatrix::from_fn(k, others.len(), |r, c| aug[(self.arm[r], others[c])]);
            let hnn = DMatrix::from_fn(others.len(), others.len(), |r, c| {
                aug[(others[r], others[c])]
            });
            haa - &han * pseudo_inverse(hnn) * han.transpose()
        };
        let h = self.l.transpose() * s * &self.l / self.sigma2;
        let delta = self.step(out, aug, None);
        let da = DVector::from_iterator(k, self.arm.iter().map(|&a| delta[a]));
        let u = &self.linv * (&self.offset + da);
        (h, u)
    }

    /// The eigen-decomposition `VHVᵀ` of the data's whitened information on `aug`
    /// ([`Self::whitened_information`]) and the unregularised estimate `û`.
    fn whitened_eigen(
        &self,
        out: Option<usize>,
        aug: &DMatrix<f64>,
    ) -> (SymmetricEigen<f64, nalgebra::Dyn>, DVector<f64>) {
        let (h, u) = self.whitened_information(out, aug);
        (SymmetricEigen::new(h), u)
    }

    /// The per-direction prior's square root from `aug`'s data (module docs), and the
    /// directions it holds in effect ([`StrengthSelection::held`]).
    fn ard_root(&self, out: Option<usize>, aug: &DMatrix<f64>) -> (DMatrix<f64>, f64) {
        let (e, u) = self.whitened_eigen(out, aug);
        self.ard_from(&e, &u)
    }

    /// [`Self::ard_root`] from the whitened information's eigen-decomposition `e` and `û`.
    fn ard_from(
        &self,
        e: &SymmetricEigen<f64, nalgebra::Dyn>,
        u: &DVector<f64>,
    ) -> (DMatrix<f64>, f64) {
        let k = u.len();
        let mut root = DMatrix::zeros(k, k);
        let mut held = 0.0;
        for d in 0..k {
            let hk = e.eigenvalues[d];
            let v = e.eigenvectors.column(d);
            let s2 = ard_variance(hk, || v.dot(u));
            held += 1.0 / (1.0 + s2 * hk.max(0.0));
            let row = v.transpose() * &self.linv / s2.sqrt();
            root.row_mut(d).copy_from(&row);
        }
        (root, held)
    }

    /// The candidate's precision over the arm on `aug`'s data.
    fn precision(&self, c: Candidate, out: Option<usize>, aug: &DMatrix<f64>) -> DMatrix<f64> {
        match c {
            Candidate::Scale(t) => &self.unit_precision / (t * t),
            Candidate::Ard => {
                let r = self.ard_root(out, aug).0;
                r.transpose() * r
            }
        }
    }

    /// Each candidate's held-out squared residuals, fold by fold (module docs). The folds
    /// come first, so each training set is summed once for every candidate. The folds are
    /// independent: with a free core ([`crate::cores`]) the second half of them is scored on
    /// another thread, and the scores are gathered in fold order, the same either way.
    fn cross_validate(&self, candidates: &[(Candidate, f64)]) -> Vec<FoldScores> {
        let fold = |f: usize| -> Vec<(f64, usize)> {
            let aug = self.training(Some(f));
            let one_scale = OneScale::new(self, Some(f), &aug);
            let refit = self.refit(f, &aug);
            candidates
                .iter()
                .map(|&(c, _)| {
                    let family = match (c, &one_scale) {
                        (Candidate::Scale(t), Some(s)) => s.step(self.sigma2 / (t * t)),
                        (Candidate::Ard, Some(s)) => s.per_direction_step(self.sigma2),
                        _ => None,
                    };
                    let delta = family.unwrap_or_else(|| {
                        let p = self.precision(c, Some(f), &aug);
                        self.step(Some(f), &aug, Some(&p))
                    });
                    self.held_out(f, refit.as_ref(), &delta)
                })
                .collect()
        };
        let threads = crate::cores::free().min(2);
        let per_fold: Vec<Vec<(f64, usize)>> =
            crate::fit::geometric::map_ranges(self.folds, threads, 2, |folds| {
                folds.map(fold).collect::<Vec<_>>()
            })
            .into_iter()
            .flatten()
            .collect();
        let mut scores: Vec<FoldScores> = candidates
            .iter()
            .map(|_| FoldScores {
                sums: Vec::with_capacity(self.folds),
                rows: 0,
            })
            .collect();
        for sums in &per_fold {
            for (score, &(s, r)) in scores.iter_mut().zip(sums) {
                score.sums.push(s);
                score.rows += r;
            }
        }
        scores
    }

    /// The parameters fold `f` refits on itself (those the training set `aug` does not
    /// see) and the pseudo-inverse of their block of the fold's Gram matrix, `(J_LᵀJ_L)⁺`:
    /// the same for every candidate ([`Self::held_out`]). `None`: there are none.
    fn refit(&self, f: usize, aug: &DMatrix<f64>) -> Option<(Vec<usize>, DMatrix<f64>)> {
        let n = self.free.len();
        let g = &self.gram[f];
        let unseen = self.unseen(Some(f), aug);
        let local: Vec<usize> = (0..n).filter(|&c| unseen[c]).collect();
        if local.is_empty() || self.fold_rows[f] == 0 {
            return None;
        }
        let a = DMatrix::from_fn(local.len(), local.len(), |r, c| g[(local[r], local[c])]);
        Some((local, pseudo_inverse(a)))
    }

    /// Fold `f`'s squared held-out residuals after the step `delta` (fitted on the other
    /// folds), with the parameters they do not see refitted on the fold itself (`refit`,
    /// [`Self::refit`]), and its row count.
    ///
    /// From the fold's Gram matrix `G = [J | g]ᵀ[J | g]` alone: the residuals
    /// `e = g + Jδ` have `‖e‖² = δ̃ᵀGδ̃` (`δ̃ = [δ; 1]`), and refitting the unseen columns
    /// `L` leaves `‖e‖² − bᵀ(J_LᵀJ_L)⁺b` with `b = J_Lᵀe = G_{L,·}δ̃`.
    fn held_out(
        &self,
        f: usize,
        refit: Option<&(Vec<usize>, DMatrix<f64>)>,
        delta: &DVector<f64>,
    ) -> (f64, usize) {
        let n = self.free.len();
        let g = &self.gram[f];
        let d = DVector::from_fn(n + 1, |r, _| if r < n { delta[r] } else { 1.0 });
        let gd = g * &d;
        let mut sum = d.dot(&gd);
        if let Some((local, pinv)) = refit {
            let b = DVector::from_fn(local.len(), |r, _| gd[local[r]]);
            sum -= b.dot(&(pinv * &b));
        }
        (sum.max(0.0), self.fold_rows[f])
    }
}

/// The per-direction prior's variance of a direction whose whitened information is `hk`,
/// the unregularised estimate's coordinate along it `z` (module docs):
/// `max(z² − 1/h_k, 0) + s_min²`, or the default tolerance's square where the data do not
/// see the direction (`h_k·τ₀² < 10⁻⁶`; `z` is then not read).
fn ard_variance(hk: f64, z: impl FnOnce() -> f64) -> f64 {
    if hk * UNSEEN_TOLERANCE * UNSEEN_TOLERANCE >= 1e-6 {
        let z = z();
        (z * z - 1.0 / hk).max(0.0) + ARD_FLOOR * ARD_FLOOR
    } else {
        UNSEEN_TOLERANCE * UNSEEN_TOLERANCE
    }
}

/// `a⁻¹b` for a symmetric positive semi-definite `a`: Cholesky when it is definite, the
/// pseudo-inverse otherwise.
fn solve_psd(a: DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    match a.clone().cholesky() {
        Some(c) => c.solve(b),
        None => pseudo_inverse(a) * b,
    }
}

/// The pseudo-inverse of a symmetric positive semi-definite matrix (eigenvalues below
/// `10⁻¹²` of the largest taken as 0).
fn pseudo_inverse(a: DMatrix<f64>) -> DMatrix<f64> {
    let e = SymmetricEigen::new(a);
    let top = e.eigenvalues.iter().fold(0.0, |m: f64, &v| m.max(v.abs()));
    let d = e.eigenvalues.map(|v| {
        if v > 1e-12 * top && v > 0.0 {
            1.0 / v
        } else {
            0.0
        }
    });
    &e.eigenvectors * DMatrix::from_diagonal(&d) * e.eigenvectors.transpose()
}
