//! `lincal select` on a spec: the pool of candidate poses on the nominal constraint (the
//! user's own rows, those off the constraint dropped, or poses projected onto it), each
//! candidate's whitened geometric-residual Jacobian over the free (gauge-fixed) parameters at
//! the nominals and at draws around them, the choice ([`super::select`]), and what it is
//! worth against random picks from the same pool.
//!
//! # The information of a pose
//! Pose `l` on constraint `j` has the residual `g_l(p)` (its `m_l` components: the distance
//! to a plane, the offset from a point, the error of a measured tip). With covariance `C_l`
//! (the residual's own noise, plus the encoder noise carried through `∂g_l/∂q`: see
//! [`Sigmas`]), its Fisher information about the free parameters `p_F` is
//! `J_lᵀC_l⁻¹J_l` with `J_l = ∂g_l/∂p_F` exact ([`crate::fit::geometric::pose_jacobians`]);
//! the blocks handed to the design are `L_l⁻¹J_l`, `C_l = L_lL_lᵀ` (whitened; `J_l/σ`
//! without encoder noise). A design's information is their sum plus that of poses already
//! measured (`--given`), and its inverse the predicted covariance of the parameter-space fit
//! (the Cramér-Rao bound it attains to first order).
//!
//! # Draws
//! Where nominals are special (`a5 = a6 = 0` on a PUMA makes a home offset invisible there),
//! a design taken at the nominals alone is blind; so the criterion is averaged over the
//! nominals and `draws` parameter vectors perturbed within their tolerance
//! ([`crate::simulate::perturbed_truth`], seeds `seed + 1 …`).
//!
//! # The tip
//! The predicted tip error is `sqrt(tr(T M⁻¹ Tᵀ))`, `T` the tip Jacobians over the free
//! parameters at [`WORKSPACE_POINTS`] configurations drawn uniformly within the joint limits,
//! stacked and scaled by `1/√W`: the RMS over the workspace of the tip's predicted error.

use nalgebra::{DMatrix, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::calibrate::prior::PriorChoice;
use crate::data::Poses;
use crate::error::{Error, ErrorClass, Location, Result};
use crate::fit::geometric::{pose_jacobians, PoseJacobians};
use crate::model::CalibModel;
use crate::simulate::{perturbed_truth, simulate, Noise};
use crate::spec::Spec;

use super::prior::PlanPrior;
use super::request::{affordable, check_count, check_every_constraint};
pub use super::request::{check_noise_floor, check_sizes, MAX_DRAWS, MAX_POOL, MIN_NOISE};
use super::whiten::{column_scale, mean_variance, whitened, with_nominal_tips};
pub use super::whiten::{Sigmas, DEFAULT_SIGMA};
use super::{baseline, kw_bound, predicted_std, select, worth, Criterion, Pool, SelectOptions};

/// Workspace configurations the tip criterion and the predicted tip error average over.
pub const WORKSPACE_POINTS: usize = 64;

/// The design's regulariser, relative to the pool's mean information per pose
/// ([`SelectOptions::ridge`]): large enough that the rank-`m` updates stay accurate across a
/// design's blind directions (a PUMA's `θ6` at its nominals), small enough to change no
/// choice among designs that see every parameter (its effect is `≈ ε·n/N`).
pub const RIDGE: f64 = 1e-6;

/// Most multiplicative iterations of the Kiefer-Wolfowitz bound (each `O(P·m·n²·D)`: about
/// 7 ms at 10⁴ candidates, 100-200 ms at 10⁵ with 4 draws); the bound holds at every
/// iterate, and they stop once one tightens it by less than 0.1 % (see `kw_bound`).
pub const BOUND_ITERATIONS: usize = 30;

/// The exchange applies a swap only when it raises the D-efficiency by at least this
/// (relative; `Δ log det > n·10⁻⁵`; for `--criterion tip`, when it lowers the predicted tip
/// variance by more than `n·10⁻⁵` of it): on a pool of 10⁵ (Panda at a point, N = 200) a tolerance
/// of 10⁻⁹ let the exchange run 159 swaps whose last hundred gained 10⁻⁶ to 10⁻⁴ in
/// `log det` each, a pass apiece for nothing a user could measure.
pub const SWAP_TOLERANCE: f64 = 1e-5;

/// Random designs the baseline draws (medians over them).
pub const REPLICATES: usize = 31;

/// What to select from.
// One value per plan: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Candidates {
    /// The user's candidate poses (their joint readings; measured tips, if any, unused).
    Given(Poses),
    /// This many poses projected onto the nominal constraint(s), as `simulate` places them.
    Generated(usize),
}

/// The options of [`plan`].
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Poses to choose.
    pub count: usize,
    /// Parameter draws beside the nominals (0: the nominals only).
    pub draws: usize,
    /// Seed of the pool, the draws, the workspace points and the baseline.
    pub seed: u64,
    /// Optimise the predicted tip error instead of D-optimality.
    pub tip: bool,
    /// The noise of the residuals ([`Sigmas::of`]): `track` for constraints, `measure` for
    /// measured tips (both 0: [`DEFAULT_SIGMA`]), `orientation` for a measured pose's
    /// orientation, `encoder` for the joint readings (carried to each residual through
    /// `∂g/∂q`).
    pub noise: Noise,
    /// Candidates farther than this from their nominal constraint are dropped, metres.
    pub max_off: f64,
    /// The weak-direction prior the calibration will use ([`crate::calibrate::prior`]): when
    /// a choice on the data alone leaves an arm parameter weak, the fit will apply it, so the
    /// plan chooses again with its information `Σ⁻¹` in every design's (Bayesian
    /// D-optimality: poses go where the prior does not already know; see [`Plan::prior_weak`]).
    /// `PriorChoice::Off` plans with the data alone.
    pub prior: PriorChoice,
}

/// A candidate left out: off its constraint under the nominal model.
#[derive(Clone, Debug, PartialEq)]
pub struct Dropped {
    /// Its index among the candidates given.
    pub pose: usize,
    /// Its line in the candidates' file.
    pub line: usize,
    /// Its residual at the nominals, metres.
    pub residual: f64,
}

/// One free parameter's predicted standard deviation.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamStd {
    /// The parameter.
    pub name: String,
    /// With the chosen poses.
    pub chosen: f64,
    /// The median over random picks of as many poses from the same pool.
    pub random: f64,
}

/// The result of [`plan`].
#[derive(Clone, Debug)]
pub struct Plan {
    /// The pool the choice was made from (the candidates kept, or the generated poses).
    pub pool: Poses,
    /// For each pool pose, its index among the candidates given (identity when generated).
    pub pool_index: Vec<usize>,
    /// Candidates dropped as off their constraint.
    pub dropped: Vec<Dropped>,
    /// The chosen pool poses, in visiting order.
    pub chosen: Vec<usize>,
    /// Per free parameter, the predicted standard deviations.
    pub params: Vec<ParamStd>,
    /// Unknown parameters held by the gauge rule: no pose can improve them.
    pub held: Vec<String>,
    /// Predicted RMS tip error over the workspace, chosen poses, metres.
    pub tip_rms: f64,
    /// The same, median of random picks.
    pub random_tip_rms: f64,
    /// Condition number of the chosen poses' whitened Jacobian, columns scaled to unit norm.
    pub condition: f64,
    /// How many random poses of the pool match the chosen ones in D (median), if the pool
    /// holds enough.
    pub worth: Option<usize>,
    /// Kiefer-Wolfowitz lower bound on the chosen set's D-efficiency among sets of as many
    /// pool poses.
    pub efficiency: Option<f64>,
    /// The D criterion (mean log det over the draws) of the chosen and of random picks.
    pub log_det: (f64, f64),
    /// Whether the chosen count is below the linear method's basis size `K` (proved from
    /// samples, or read from a `K` cached by `calibrate`, whose sketch errs with probability
    /// at most about `2·10⁻⁹`).
    pub below_basis: bool,
    /// The noise each pose's residual was whitened by (defaults filled in).
    pub sigmas: Sigmas,
    /// The arm parameters a choice on the data alone left weak (standard deviation above the
    /// calibration's prior's, [`PlanOptions::prior`]): the fit will apply its prior, so the
    /// plan counted the prior's information too. Empty: it was not counted.
    pub prior_weak: Vec<String>,
    /// The calibration's prior as planned with: [`PlanOptions::prior`] with its tolerances
    /// fixed (a relative prior's at the planned noise and pose count).
    pub prior: PriorChoice,
}

/// The parameter vectors the design averages over: `draws` perturbed, then the nominals.
///
/// The perturbed draws come first: draw 0 is the one the per-parameter report reads
/// ([`Pool::information`] of draw 0), and a robot as built is a perturbed one; at special
/// nominals (`a5 = a6 = 0` on a PUMA) some parameters are blind at the nominals alone.
fn draw_points(model: &dyn CalibModel, spec: &Spec, draws: usize, seed: u64) -> Vec<Vec<f64>> {
    let nominal: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    (1..=draws as u64)
        .map(|d| perturbed_truth(model, spec, seed.wrapping_add(d)))
        .chain(std::iter::once(nominal))
        .collect()
}

/// The information `Σ_l J_lᵀC_l⁻¹J_l` of `poses` at `p` over `free` ([`whitened`]).
fn information(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    free: &[usize],
    sigmas: Sigmas,
) -> Result<DMatrix<f64>> {
    let n = free.len();
    let at_p = with_nominal_tips(model, poses, p);
    let jac = pose_jacobians(model, &at_p, p)?;
    same_free(&jac, free)?;
    let rows = whitened(model, &at_p, p, &jac, sigmas);
    let m = DMatrix::from_row_slice(rows.len() / n, n, &rows);
    Ok(m.transpose() * m)
}

fn same_free(jac: &PoseJacobians, free: &[usize]) -> Result<()> {
    if jac.free == free {
        Ok(())
    } else {
        Err(Error::other(
            "the free parameter set differs between parameter draws (a bug)",
        ))
    }
}

/// The tip sensitivities `T_d` (see the module docs) at each draw.
fn tip_rows(
    model: &dyn CalibModel,
    points: &[Vec<f64>],
    free: &[usize],
    seed: u64,
) -> Vec<DMatrix<f64>> {
    let (dim, np, joints) = (model.dim(), model.param_count(), model.joint_count());
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7169_7020_726f_7773);
    let configs: Vec<Vec<f64>> = (0..WORKSPACE_POINTS)
        .map(|_| {
            (0..joints)
                .map(|i| {
                    let [lo, hi] = model.joint_limits(i).unwrap_or_else(|| {
                        crate::simulate::default_joint_range(model.joint_is_prismatic(i))
                    });
                    lo + (hi - lo) * rng.gen::<f64>()
                })
                .collect()
        })
        .collect();
    let scale = 1.0 / (WORKSPACE_POINTS as f64).sqrt();
    points
        .iter()
        .map(|p| {
            let mut t = DMatrix::zeros(WORKSPACE_POINTS * dim, free.len());
            let (mut tip, mut jac) = (vec![0.0; dim], vec![0.0; dim * np]);
            for (w, q) in configs.iter().enumerate() {
                model.tip_jacobian(q, p, &mut tip, &mut jac);
                for c in 0..dim {
                    for (k, &f) in free.iter().enumerate() {
                        t[(w * dim + c, k)] = jac[c * np + f] * scale;
                    }
                }
            }
            t
        })
        .collect()
}

/// The pool: the candidates kept (with their index among those given) and the dropped.
fn build_pool(
    model: &dyn CalibModel,
    spec: &Spec,
    candidates: Candidates,
    opts: &PlanOptions,
    nominal: &[f64],
) -> Result<(Poses, Vec<usize>, Vec<Dropped>)> {
    let poses = match candidates {
        Candidates::Generated(m) => {
            let zero = Noise::default();
            // Nominals that miss the spec's relations (an import's sockets all at one
            // guessed point, 0.1 m apart by the relations) are no truth to simulate: the
            // pool's tips stand on them moved onto the relations, or on the seeded truth
            // `simulate` would draw when that move fails.
            let on_relations = if crate::fit::relation::unmet(model, nominal, 1e-9).is_empty() {
                Some(nominal.to_vec())
            } else {
                crate::fit::relation::project(model, nominal)
            };
            let sim = simulate(model, spec, m, opts.seed, on_relations.as_deref(), zero)?;
            let index = (0..sim.poses.len()).collect();
            return Ok((sim.poses, index, Vec::new()));
        }
        Candidates::Given(p) => p,
    };
    let jac = pose_jacobians(model, &with_nominal_tips(model, &poses, nominal), nominal)?;
    let w = jac.width();
    let (mut keep, mut dropped) = (Vec::new(), Vec::new());
    for l in 0..poses.len() {
        let r = jac
            .pose(l)
            .chunks_exact(w)
            .map(|row| row[w - 1] * row[w - 1])
            .sum::<f64>()
            .sqrt();
        if r <= opts.max_off {
            keep.push(l);
        } else {
            dropped.push(Dropped {
                pose: l,
                line: poses.line.at(l),
                residual: r,
            });
        }
    }
    Ok((poses.select(&keep), keep, dropped))
}

/// The design, the free parameters, each pool pose's row count, each column's scale.
struct DesignPool {
    /// The design problem (the given poses' information as given; no prior).
    design: Pool,
    /// The free parameters (model indices).
    free: Vec<usize>,
    /// Each pool pose's residual rows.
    rows: Vec<usize>,
    /// Each free parameter's column scale.
    scale: Vec<f64>,
}

/// The design problem: every pool pose's whitened blocks at each draw, the given poses'
/// information, the free parameters and each pose's row count.
fn design_pool(
    model: &dyn CalibModel,
    pool: &Poses,
    given: Option<&Poses>,
    points: &[Vec<f64>],
    sigmas: Sigmas,
    count: usize,
) -> Result<DesignPool> {
    let mut blocks = Vec::with_capacity(points.len());
    let mut free = Vec::new();
    for (d, p) in points.iter().enumerate() {
        let at_p = with_nominal_tips(model, pool, p);
        let jac = pose_jacobians(model, &at_p, p)?;
        if d == 0 {
            free.clone_from(&jac.free);
        }
        same_free(&jac, &free)?;
        blocks.push(whitened(model, &at_p, p, &jac, sigmas));
    }
    if free.is_empty() {
        return Err(unseen(
            "no free parameter: every parameter is known or held".into(),
        ));
    }
    // Columns scaled to unit RMS over the pool (angles and lengths, whitened by σ, differ by
    // many orders): D-optimality is invariant to it, the factorisations are not.
    let scale = column_scale(&blocks, free.len());
    for b in &mut blocks {
        for row in b.chunks_exact_mut(free.len()) {
            row.iter_mut().zip(&scale).for_each(|(v, s)| *v /= s);
        }
    }
    let rows: Vec<usize> = (0..pool.len())
        .map(|l| {
            model
                .constraint_kind(pool.constraint.at(l))
                .residual_count(model.dim())
        })
        .collect();
    let mut design =
        Pool::new(free.len(), &rows, blocks).map_err(|e| Error::other(e.to_string()))?;
    let mean_rows = rows.iter().sum::<usize>() as f64 / rows.len().max(1) as f64;
    if given.is_some() || !model.relations().is_empty() {
        let infos = points
            .iter()
            .map(|p| {
                let mut m = match given {
                    Some(g) => {
                        let m = information(model, g, p, &free, sigmas)?;
                        DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| {
                            m[(i, j)] / (scale[i] * scale[j])
                        })
                    }
                    None => DMatrix::zeros(free.len(), free.len()),
                };
                m += relation_information(model, p, &free, &scale, count as f64 * mean_rows);
                Ok(m)
            })
            .collect::<Result<Vec<_>>>()?;
        design = design
            .with_given(infos)
            .map_err(|e| Error::other(e.to_string()))?;
    }
    Ok(DesignPool {
        design,
        free,
        rows,
        scale,
    })
}

/// The relations' information in the scaled columns, as the fit weighs them
/// ([`crate::fit::relation`]: each row like `RELATION_STIFFNESS²` times the data's mean
/// diagonal, a nearly exact equation): `Σ_rows w_r² g_r g_rᵀ`, `g_r` the row's gradient over
/// the free parameters divided by their scales, `w_r² = STIFFNESS²·data / ‖g_r‖²` with `data`
/// the expected diagonal of the chosen poses' information (their residual rows: the columns
/// have unit RMS over the pool).
fn relation_information(
    model: &dyn CalibModel,
    p: &[f64],
    free: &[usize],
    scale: &[f64],
    data: f64,
) -> DMatrix<f64> {
    let n = free.len();
    let mut info = DMatrix::zeros(n, n);
    let stiffness = crate::fit::relation::RELATION_STIFFNESS;
    for row in crate::fit::relation::rows(model, p) {
        let mut g = vec![0.0; n];
        for (param, v) in &row.gradient {
            if let Some(k) = free.iter().position(|f| f == param) {
                g[k] += v / scale[k];
            }
        }
        let norm2: f64 = g.iter().map(|v| v * v).sum();
        if !(norm2.is_finite() && norm2 > 0.0) {
            continue;
        }
        let w2 = stiffness * stiffness * data.max(1.0) / norm2;
        for a in 0..n {
            for b in 0..n {
                info[(a, b)] += w2 * g[a] * g[b];
            }
        }
    }
    info
}

/// Exit 1 (degenerate) naming what stays unseen.
fn unseen(msg: String) -> Error {
    Error::new(ErrorClass::Degenerate, Location::default(), msg)
}

/// Chooses `opts.count` poses for calibrating `model` (of `spec`) from `candidates`, with the
/// poses `given` already measured (see the module docs).
///
/// # Errors
/// An input error for a count of 0 or above the pool, a generated pool of 0 or above
/// [`MAX_POOL`] poses, more than [`MAX_DRAWS`] draws, a noise level below [`MIN_NOISE`], no pose left on the constraint, or
/// poses that cannot be linearised; a degenerate error (exit 1) naming the parameters the
/// chosen poses cannot determine (too few poses); the simulation's errors for a generated
/// pool.
pub fn plan(
    model: &dyn CalibModel,
    spec: &Spec,
    candidates: Candidates,
    given: Option<&Poses>,
    opts: &PlanOptions,
) -> Result<Plan> {
    let generated = match candidates {
        Candidates::Generated(m) => Some(m),
        Candidates::Given(_) => None,
    };
    check_sizes(generated, opts.draws)?;
    check_noise_floor(opts.noise)?;
    let points = draw_points(model, spec, opts.draws, opts.seed);
    affordable(model, points.len(), generated, None, opts.count)?;
    let nominal = points.last().cloned().unwrap_or_default();
    let (pool, pool_index, dropped) = build_pool(model, spec, candidates, opts, &nominal)?;
    check_count(opts.count, pool.len(), dropped.len())?;
    check_every_constraint(model, &pool, given)?;
    affordable(model, points.len(), generated, Some(&pool), opts.count)?;
    let sigmas = Sigmas::of(opts.noise);
    let DesignPool {
        design,
        free,
        rows,
        scale,
    } = design_pool(model, &pool, given, &points, sigmas, opts.count)?;
    let names: Vec<String> = free
        .iter()
        .map(|&j| model.param_name(j).to_string())
        .collect();
    let tips: Vec<DMatrix<f64>> = tip_rows(model, &points, &free, opts.seed)
        .into_iter()
        .map(|t| DMatrix::from_fn(t.nrows(), t.ncols(), |i, j| t[(i, j)] / scale[j]))
        .collect();
    let criterion = if opts.tip {
        Criterion::Tip(tips.clone())
    } else {
        Criterion::D
    };
    let sel_opts = SelectOptions {
        bound_iterations: BOUND_ITERATIONS,
        ridge: RIDGE,
        seed: opts.seed,
        tolerance: SWAP_TOLERANCE * free.len() as f64,
        ..SelectOptions::default()
    };
    let resolved = resolved_prior(model, &pool, &nominal, opts, given, sigmas);
    let prior = PlanPrior::of(model, spec, &free, &scale, resolved);
    let (design, sel, weak) = choose(design, prior.as_ref(), opts.count, &criterion, &sel_opts)?;
    let zero = DMatrix::zeros(free.len(), free.len());
    let seen = Seen {
        names: &names,
        scale: &scale,
        rows: &rows,
        prior: match &prior {
            Some(p) if !weak.is_empty() => &p.information,
            _ => &zero,
        },
        given: given.is_some(),
        pool: &pool,
        generated: generated.is_some(),
    };
    let std = seen_std(&design, &sel, &seen, opts)?;
    let scaled = Scaled {
        names: &names,
        weak: &weak,
        free: &free,
        scale: &scale,
        tips: &tips,
        prior: resolved,
    };
    finish(
        model, pool, pool_index, dropped, &design, &sel, &scaled, opts, sigmas, std,
    )
}

/// The calibration's prior with its tolerances fixed as the fit will fix them
/// ([`PriorChoice::resolved`]): a relative prior's `σ/√(N·w)`, `σ²` the residual variance per
/// component the planned noise gives on (a sample of) the pool (encoder noise carried
/// through, as the fit's `σ̂` would see it: `whiten::mean_variance`) at the nominals, `N` the
/// poses chosen and given.
fn resolved_prior(
    model: &dyn CalibModel,
    pool: &Poses,
    nominal: &[f64],
    opts: &PlanOptions,
    given: Option<&Poses>,
    sigmas: Sigmas,
) -> PriorChoice {
    if opts.prior.weight().is_none() {
        // Fixed tolerances as they are; a prior the data will choose, at the default ones.
        return opts.prior.resolved(f64::NAN, 1);
    }
    // About 256 evenly spaced poses say it well enough: only those get the nominal tips.
    let step = pool.len().div_ceil(256).max(1);
    let some: Vec<usize> = (0..pool.len()).step_by(step).collect();
    let at = with_nominal_tips(model, &pool.select(&some), nominal);
    let sigma = mean_variance(model, &at, nominal, sigmas).sqrt();
    let poses = opts.count + given.map_or(0, Poses::len);
    opts.prior.resolved(sigma, poses)
}

/// What [`seen_std`] reads beside the design and the choice.
struct Seen<'a> {
    /// The free parameters' names.
    names: &'a [String],
    /// Their column scales.
    scale: &'a [f64],
    /// Each pool pose's residual rows.
    rows: &'a [usize],
    /// The prior's information in the scaled columns (part of the design's given one).
    prior: &'a DMatrix<f64>,
    /// Whether poses were given (`--given`).
    given: bool,
    /// The candidates on the constraint (whom to blame for unseen parameters).
    pool: &'a Poses,
    /// Whether the pool was generated (`--pool`).
    generated: bool,
}

/// The choice ([`select`]) on `design`, counting `prior` when the fit will apply it (see
/// `select::prior`): first with the data alone; if that choice leaves an arm parameter weak,
/// again with the prior's information added to every draw's given one. The design the
/// choice was made on, the choice, and the free parameters (positions) the data alone left
/// weak (empty: the prior was not counted).
fn choose(
    design: Pool,
    prior: Option<&PlanPrior>,
    count: usize,
    criterion: &Criterion,
    sel_opts: &SelectOptions,
) -> Result<(Pool, super::Selection, Vec<usize>)> {
    let err = |e: super::SelectError| Error::other(e.to_string());
    let Some(prior) = prior else {
        let sel = select(&design, count, criterion, sel_opts).map_err(err)?;
        return Ok((design, sel, Vec::new()));
    };
    // The bound only for the choice kept (`finish` computes it when missing).
    let first_opts = SelectOptions {
        bound_iterations: 0,
        ..sel_opts.clone()
    };
    let first = select(&design, count, criterion, &first_opts).map_err(err)?;
    let weak = prior
        .weak(&design.information(0, &first.chosen).map_err(err)?)
        .map_err(err)?;
    if weak.is_empty() {
        return Ok((design, first, weak));
    }
    let infos = (0..design.n_draws())
        .map(|d| design.given(d) + &prior.information)
        .collect();
    let design = design.with_given(infos).map_err(err)?;
    let sel = select(&design, count, criterion, sel_opts).map_err(err)?;
    // Near the fewest poses that see every parameter, a choice counting the prior can leave
    // one unseen by the data that the data-only choice saw (the prior already covers it):
    // then the data-only choice is kept, reported with the prior as the fit will apply it.
    if data_blind(&design, &sel.chosen, prior)? && !data_blind(&design, &first.chosen, prior)? {
        return Ok((design, first, weak));
    }
    Ok((design, sel, weak))
}

/// Whether the chosen poses of `design` (the prior among its given information) leave some
/// free parameter unseen by the data at every draw.
fn data_blind(design: &Pool, chosen: &[usize], prior: &PlanPrior) -> Result<bool> {
    let err = |e: super::SelectError| Error::other(e.to_string());
    let mut seen = vec![false; design.n_params()];
    for d in 0..design.n_draws() {
        let info = design.information(d, chosen).map_err(err)?;
        let data = predicted_std(&(&info - &prior.information)).map_err(err)?;
        seen.iter_mut()
            .zip(&data)
            .for_each(|(s, v)| *s |= v.is_finite());
    }
    Ok(seen.iter().any(|s| !s))
}

/// Each free parameter's predicted std with the chosen poses (draw 0), in its own units (the
/// posterior one, with the prior); a degenerate error (exit 1) naming the parameters the
/// chosen poses leave unseen, judged on the data alone: a prior does not measure a parameter.
fn seen_std(
    design: &Pool,
    sel: &super::Selection,
    seen: &Seen<'_>,
    opts: &PlanOptions,
) -> Result<Vec<f64>> {
    let err = |e: super::SelectError| Error::other(e.to_string());
    let n = seen.names.len();
    // Per draw, back in the parameters' own units (θ'_k = s_k·θ_k); the report reads the
    // first draw, and a parameter is unseen only when no draw sees it (a direction nearly
    // blind at one draw, parallel axes slightly tilted, is not a property of the poses).
    let mut per_draw = Vec::with_capacity(design.n_draws());
    let mut seen_by_data = vec![false; n];
    for d in 0..design.n_draws() {
        let info = design.information(d, &sel.chosen).map_err(err)?;
        let std = predicted_std(&info).map_err(err)?;
        let data = predicted_std(&(&info - seen.prior)).map_err(err)?;
        for (s, v) in seen_by_data.iter_mut().zip(&data) {
            *s |= v.is_finite();
        }
        per_draw.push(
            std.iter()
                .zip(seen.scale)
                .map(|(v, s)| v / s)
                .collect::<Vec<_>>(),
        );
    }
    let blind: Vec<&str> = seen
        .names
        .iter()
        .zip(&seen_by_data)
        .filter(|&(_, &s)| !s)
        .map(|(n, _)| n.as_str())
        .collect();
    let std = (0..n)
        .map(|k| {
            per_draw
                .iter()
                .map(|s| s[k])
                .find(|v| v.is_finite())
                .unwrap_or(f64::INFINITY)
        })
        .collect();
    if !blind.is_empty() {
        let case = super::blind::BlindCase {
            design,
            prior: seen.prior,
            pool: seen.pool,
            rows: sel.chosen.iter().map(|&i| seen.rows[i]).sum(),
            pool_rows: seen.rows.iter().sum(),
            params: n,
            given: seen.given,
            generated: seen.generated,
        };
        return Err(super::blind::blind_error(
            &case, &blind, opts.count, opts.draws,
        )?);
    }
    Ok(std)
}

/// The free parameters of a design, the scale of their columns, the scaled tip rows and the
/// parameters (positions) that made the plan count the prior.
struct Scaled<'a> {
    names: &'a [String],
    weak: &'a [usize],
    free: &'a [usize],
    scale: &'a [f64],
    tips: &'a [DMatrix<f64>],
    /// The calibration's prior, tolerances fixed ([`Plan::prior`]).
    prior: PriorChoice,
}

/// The report of a choice: baselines, worth, bound, condition, visiting order.
#[allow(clippy::too_many_arguments)]
fn finish(
    model: &dyn CalibModel,
    pool: Poses,
    pool_index: Vec<usize>,
    dropped: Vec<Dropped>,
    design: &Pool,
    sel: &super::Selection,
    scaled: &Scaled<'_>,
    opts: &PlanOptions,
    sigmas: Sigmas,
    std: Vec<f64>,
) -> Result<Plan> {
    let Scaled {
        names,
        weak,
        free,
        scale,
        tips,
        prior,
    } = *scaled;
    let err = |e: super::SelectError| Error::other(e.to_string());
    let sel_opts = SelectOptions {
        ridge: RIDGE,
        ..SelectOptions::default()
    };
    let seed = opts.seed.wrapping_add(0x5e1e_c7ed);
    let random_of =
        |c: &Criterion| baseline(design, opts.count, c, &sel_opts, REPLICATES, seed).map_err(err);
    let random = random_of(&Criterion::D)?;
    let tip_crit = Criterion::Tip(tips.to_vec());
    let random_tip = random_of(&tip_crit)?;
    let tip_value = super::evaluate(design, &sel.chosen, &tip_crit, &sel_opts).map_err(err)?;
    let worth = worth(design, sel.log_det, &sel_opts, REPLICATES, seed).map_err(err)?;
    let info = design.information(0, &sel.chosen).map_err(err)?;
    let joints: Vec<Vec<f64>> = sel.chosen.iter().map(|&i| pool.q[i].to_vec()).collect();
    let order = super::visiting_order(&joints, None).map_err(err)?;
    let chosen = order.iter().map(|&k| sel.chosen[k]).collect();
    let held = (0..model.param_count())
        .filter(|j| !free.contains(j) && model.param_held(*j))
        .map(|j| model.param_name(j).to_string())
        .collect();
    let efficiency = match &sel.bound {
        Some(b) => Some(b.efficiency),
        None => kw_bound(design, &sel.chosen, BOUND_ITERATIONS, &sel_opts)
            .map_err(err)?
            .map(|b| b.efficiency),
    };
    Ok(Plan {
        pool,
        pool_index,
        dropped,
        chosen,
        params: names
            .iter()
            .zip(std)
            .zip(random.std.iter().zip(scale))
            .map(|((name, chosen), (&random, s))| ParamStd {
                name: name.clone(),
                chosen,
                random: random / s,
            })
            .collect(),
        held,
        tip_rms: tip_value.max(0.0).sqrt(),
        random_tip_rms: random_tip.value.max(0.0).sqrt(),
        condition: condition(&info),
        worth,
        efficiency,
        log_det: (sel.log_det, random.value),
        below_basis: model.basis_exceeds(opts.count) == Some(true),
        sigmas,
        prior_weak: weak.iter().map(|&k| names[k].clone()).collect(),
        prior,
    })
}

/// `sqrt(λ_max/λ_min)` of the information with its columns scaled to unit diagonal: the
/// condition of the whitened Jacobian, free of the parameters' units.
fn condition(info: &DMatrix<f64>) -> f64 {
    let n = info.nrows();
    let d: Vec<f64> = (0..n).map(|i| info[(i, i)].sqrt().max(1e-300)).collect();
    let scaled = DMatrix::from_fn(n, n, |i, j| info[(i, j)] / (d[i] * d[j]));
    let e = SymmetricEigen::new(scaled).eigenvalues;
    let (lo, hi) = e.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    if lo > 0.0 {
        (hi / lo).sqrt()
    } else {
        f64::INFINITY
    }
}
