//! The calibration pipeline: linear solve → extraction → (optional) refinement → [`Estimate`].
//!
//! ```text
//! poses ──solve──▶ R_j (K×K per constraint), rank, linear c
//!       ──extract──▶ p̂ minimising Σ_j Σ_e ‖R_j c_e(p)‖² over the free set, σ̂²(JᵀJ)⁻¹
//!       ──refine──▶ p̂ minimising the geometric residual (with `refine: true`)
//! ```
//! `residual_rms` is `sqrt(Σ_l ‖g_l‖² / N)`, the RMS over poses of the geometric distance
//! `‖g_l‖` of the calibrated tip from the calibrated constraint (metres;
//! [`crate::model::geometry::geometric_residual`]). For one planar line, `paper_err_rms` is the paper's
//! sec. 5 figure `sqrt(λ_min(I)/N)`, `I` the inertia matrix of the calibrated tips about
//! their centroid: the RMS distance of the tips from their own best-fit line.

mod checks;
pub mod constraint_fit;
mod copies;
mod covariance;
pub mod estimate;
mod fit_stage;
pub mod grouping;
pub mod joint_ranges;
mod outliers;
pub mod plane_fit;
pub mod pose_errors;
pub mod pose_weight;
pub mod prior;
mod residuals;
mod reweight;
mod start;
pub mod validation;
mod warnings;

pub use residuals::{pose_residuals, tip_statistics, TipStatistics};
pub use start::AUTO_MAX_TERMS;

use checks::{check_finite, check_model_params, check_poses, Readings};
use constraint_fit::{ConstraintFit, ConstraintSums, PointDistance, RelationFit};
use estimate::{Estimate, ParamEstimate};
use fit_stage::{canonical_form, fit_stage, FitOutcome};
use outliers::{listed, outliers, reject_outliers, Job};
use residuals::Residuals;
use warnings::data_warnings;

use crate::data::Poses;
use crate::error::Result;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
pub use crate::numeric::robust::Robust;
use crate::spec::Spec;
/// Where the fit starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartChoice {
    /// The linear method where the data support it and it is affordable, else the nominals
    /// (see [`calibrate`]).
    #[default]
    Auto,
    /// The linear method (an error when the data cannot support it).
    Linear,
    /// The nominals, with deterministic restarts (the parameter-space path).
    Nominal,
}

/// Options of [`calibrate`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CalibrateOptions {
    /// Refine the linear estimate by Levenberg-Marquardt on the geometric residual.
    pub refine: bool,
    /// Where the fit starts.
    pub start: StartChoice,
    /// Drop the poses beyond [`OUTLIER_SIGMAS`] robust standard deviations and fit again.
    pub reject_outliers: bool,
    /// Fit with a robust loss: the linear solve reweighted on its algebraic residuals
    /// ([`crate::fit::solve::solve_robust`]); a fit in parameter space (refinement, the nominal
    /// start, the fit over every pose after a linear subset) reweighted on the geometric
    /// residuals from that fit's estimate. Without refinement the reweighted linear estimate
    /// is reported as it is.
    pub robust: Option<Robust>,
    /// The weak-direction prior on the arm's parameters ([`prior`]; on by default).
    pub prior: prior::PriorChoice,
}

/// A pose whose residual exceeds this many robust standard deviations
/// ([`Estimate::robust_scale`]) is an outlier: warned about always, dropped with
/// `reject_outliers`. (Gaussian noise reaches 5σ in one pose of about 10⁵ with three
/// components, one of 10⁶ with one.)
pub const OUTLIER_SIGMAS: f64 = 5.0;

/// Largest linear solve [`StartChoice::Auto`] runs, in flops of the data matrix
/// (`Σ_j N_j·K_j²`; the whole linear path, extraction included, takes about a second
/// there): beyond it the linear method runs on an
/// evenly spread subset of the poses, and when even `2K` poses exceed it the fit starts from
/// the nominals.
pub const LINEAR_BUDGET: f64 = 2e8;

/// How many poses [`worst_poses`](Estimate::worst_poses) lists.
pub const WORST_SHOWN: usize = 10;

/// Fraction of the data's scale above which a parameter direction's standard deviation is
/// reported as practically unidentifiable.
pub const PRACTICAL_FRACTION: f64 = 0.1;

/// One parameter of the spec, as the report needs it.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecParam {
    /// Name.
    pub name: String,
    /// Nominal value.
    pub nominal: f64,
    /// Known (fixed at the nominal by the spec, not estimated).
    pub known: bool,
}

impl SpecParam {
    /// Every parameter of a spec, in spec order.
    #[must_use]
    pub fn list(spec: &Spec) -> Vec<SpecParam> {
        spec.params
            .iter()
            .map(|p| SpecParam {
                name: p.name.clone(),
                nominal: p.nominal.to_f64(),
                known: p.known,
            })
            .collect()
    }
}

/// [`calibrate`] with the parameter list taken from a spec.
///
/// # Example
/// A planar 2R arm with its tip on an unknown line: poses placed exactly on the line, then
/// the identifiable combinations come back (the gauge `a1, th1` is held at the nominals).
/// ```
/// use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
/// use lincal_core::data::Poses;
/// let yaml = "name: two_link
/// dim: 2
/// joints:
///   - {type: revolute, a: a1, home: th1}
///   - {type: revolute, a: a2, home: th2}
/// params: {a1: {nominal: 0.375}, th1: {nominal: 0}, a2: {nominal: 0.4},
///          th2: {nominal: 0}, b1: {nominal: -1.7}, b2: {nominal: -0.6}}
/// constraint: {line: {b: [b1, b2]}}
/// ";
/// let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// // True arm a1 = 0.375, a2 = 0.425, th2 = 0.0446 on the line b = (-1.79, -0.56).
/// let (a1, a2, th2, b1, b2) = (0.375_f64, 0.425_f64, 0.0446_f64, -1.79_f64, -0.56_f64);
/// let mut poses = Poses::default();
/// for i in 0..40 {
///     let q2 = -2.0 + 0.1 * f64::from(i);
///     // tip = e^{i q1}·w, w = a1 + a2·e^{i(q2 − th2)}; solve b·tip + 1 = 0 for q1.
///     let (wx, wy) = (a1 + a2 * (q2 - th2).cos(), a2 * (q2 - th2).sin());
///     let c = -1.0 / (b1.hypot(b2) * wx.hypot(wy));
///     if c.abs() >= 1.0 {
///         continue; // this elbow angle cannot reach the line
///     }
///     let q1 = c.acos() - wy.atan2(wx) + b2.atan2(b1);
///     poses.q.push(&[q1, q2]);
///     poses.constraint.push(0);
/// }
/// let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
/// let value = |n: &str| est.params.iter().find(|p| p.name == n).unwrap().value;
/// assert!((value("a2") / value("a1") - a2 / a1).abs() < 1e-9);
/// assert!((value("th2") - th2).abs() < 1e-9);
/// assert!(est.residual_rms < 1e-9);
/// ```
///
/// # Errors
/// As [`calibrate`].
pub fn calibrate_spec(
    model: &dyn CalibModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
) -> Result<Estimate> {
    calibrate_spec_progress(model, spec, poses, opts, &crate::progress::NoProgress)
}

/// [`calibrate_spec`], telling `progress` which stage runs: `fitting`, `checking outliers`,
/// and with `reject_outliers` each `refit without outliers (round i)`; each stage's length is
/// unknown (the iterations of a fit run until it converges).
///
/// # Errors
/// As [`calibrate`].
pub fn calibrate_spec_progress(
    model: &dyn CalibModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
    progress: &dyn crate::progress::Progress,
) -> Result<Estimate> {
    with_outliers(
        model,
        &SpecParam::list(spec),
        poses,
        opts,
        Some(spec),
        progress,
    )
}

/// Calibrates `model` on `poses`.
///
/// `params` lists every parameter of the spec in spec order; the estimated ones (not
/// `known`) must be exactly the model's `p`, in order. The result has every spec parameter:
/// known ones at their nominal (`known: true`, `identifiable: false`, no std), held ones at
/// their nominal (`held: true`, no std), the rest fitted with their standard deviation.
///
/// # Errors
/// [`crate::error::ErrorClass::Degenerate`] when the poses cannot determine the parameters
/// (with the reason); [`crate::error::ErrorClass::Input`] for poses that do not fit the model;
/// [`crate::error::ErrorClass::Other`] for a model inconsistent with `params` or a numerical
/// failure. Never a NaN.
pub fn calibrate(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
) -> Result<Estimate> {
    with_outliers(
        model,
        params,
        poses,
        opts,
        None,
        &crate::progress::NoProgress,
    )
}

/// The fit, then the outliers: a warning naming them, or (with `reject_outliers`) a second fit
/// without them, pose indices reported in the data as given.
fn with_outliers(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    progress: &dyn crate::progress::Progress,
) -> Result<Estimate> {
    if !pose_errors::is_pose_model(model) {
        return fit_and_outliers(model, params, poses, opts, spec, progress);
    }
    // Measured poses: always the weighted geometric fit (the linear method's regression
    // weighs rotation entries as metres), with the orientation weight stated or estimated.
    let opts = CalibrateOptions {
        refine: true,
        ..opts
    };
    progress.stage("weighing orientation against position", None);
    check_poses(model, poses, &|l| l)?;
    let (noise, weight_warning) = pose_weight::pose_noise(model, poses, opts, spec)?;
    let weighted = crate::fit::start::DataStart::plain(model).with_orientation_weight(noise.weight);
    let mut est = fit_and_outliers(&weighted, params, poses, opts, spec, progress)?;
    let kept: Vec<usize> = {
        let rejected: std::collections::HashSet<usize> =
            est.rejected.iter().map(|w| w.pose).collect();
        (0..poses.len()).filter(|l| !rejected.contains(l)).collect()
    };
    let p = est.estimated_values();
    let (position, orientation) = if kept.len() == poses.len() {
        pose_errors::pose_errors(model, poses, &p)
    } else {
        pose_errors::pose_errors(model, &poses.select(&kept), &p)
    };
    est.residual_rms = position;
    est.orientation_rms = Some(orientation).filter(|v| v.is_finite());
    split_listed(model, poses, &p, &mut est.worst_poses);
    split_listed(model, poses, &p, &mut est.rejected);
    est.warnings
        .extend(warnings::orientation_warning(orientation));
    est.warnings.extend(weight_warning);
    est.warnings
        .extend(pose_weight::stated_mismatch(&weighted, poses, &p, &noise));
    est.pose_noise = Some(noise);
    Ok(est)
}

/// Gives each listed measured pose its position and orientation errors at `p`
/// ([`WorstPose::pose_parts`]): the list's residual weighs one against the other.
fn split_listed(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    listed: &mut [estimate::WorstPose],
) {
    let index: Vec<usize> = listed
        .iter()
        .map(|w| w.pose)
        .filter(|&l| l < poses.len())
        .collect();
    if index.len() != listed.len() {
        return;
    }
    let (pos, ori) = pose_errors::pose_error_norms(model, &poses.select(&index), p);
    for ((w, x), a) in listed.iter_mut().zip(pos).zip(ori) {
        w.pose_parts = (x.is_finite() && a.is_finite()).then_some((x, a));
    }
}

/// The fit, then the outliers (see [`with_outliers`]).
fn fit_and_outliers(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    progress: &dyn crate::progress::Progress,
) -> Result<Estimate> {
    progress.stage("fitting", None);
    let (mut est, res) = calibrate_inner(model, params, poses, opts, spec, None)?;
    progress.stage("checking outliers", None);
    let (out, worst) = outliers(model, poses, &res);
    let scale = res.scale;
    drop(res);
    est.robust_scale = scale;
    est.worst_poses = worst;
    if out.is_empty() {
        return Ok(est);
    }
    if !opts.reject_outliers {
        est.warnings.push(format!(
            "{} pose(s) lie beyond {OUTLIER_SIGMAS} robust standard deviations (σ ≈ {scale:.3e} m \
             from the median residual): {}. A bad row (a joint reading off, a tip on the wrong \
             constraint) pulls the whole fit; check those lines, or pass --reject-outliers",
            out.len(),
            listed(&out)
        ));
        return Ok(est);
    }
    let job = Job {
        model,
        params,
        opts,
        spec,
    };
    reject_outliers(&job, poses, progress, est, out, scale)
}

/// [`calibrate`], with the spec when there is one (for closed-form starts); `ids` maps the
/// poses to their numbers in the data as given (after outlier rejection, a subset). The
/// stages in order: checks, the fit, the one residual pass at the estimate, then everything
/// reported from it. Gives the estimate (its robust scale and worst poses still to be set
/// from the pass, which comes with it).
fn calibrate_inner(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    ids: Option<&[usize]>,
) -> Result<(Estimate, Residuals)> {
    let mut unseen = vec![true; model.constraint_count()];
    for c in poses.constraint.iter() {
        if let Some(u) = unseen.get_mut(c) {
            *u = false;
        }
    }
    let (mut est, res) = if unseen.contains(&true) {
        // A constraint without poses: the fit determines what the others' poses determine.
        let part = crate::fit::start::DataStart::plain(model).without_poses_on(&unseen);
        let (mut est, res) = calibrate_seen(&part, params, poses, opts, spec, ids)?;
        est.warnings
            .extend(warnings::unseen_gauge_warning(model, &part, &unseen));
        (est, res)
    } else {
        calibrate_seen(model, params, poses, opts, spec, ids)?
    };
    est.warnings.extend(warnings::reach_warning(
        model,
        poses,
        &est.estimated_values(),
        spec,
    ));
    Ok((est, res))
}

/// [`check_model_params`], then [`check_poses`] (its failure naming the readings outside
/// the limits, pose numbers `id(l)`), with the prior's plan ([`prior::plan`]) made beside it when a core is
/// free (both are serial steps before the fit; the plan takes 0.3-0.5 ms on a 7-joint arm).
/// The plan reads the spec and the arm's chain at the nominals, not the data: it is the one
/// the fit stage would make on its data start, whose nominals differ from `model`'s only in
/// the constraints' own values, which no chain holds.
fn checked_with_plan(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    id: &(dyn Fn(usize) -> usize + Sync),
) -> Result<(Readings, Option<prior::PriorPlan>)> {
    check_model_params(model, params)?;
    if spec.is_none() || matches!(opts.prior, prior::PriorChoice::Off) || crate::cores::free() < 2 {
        return Ok((check_poses(model, poses, id)?, None));
    }
    let (readings, plan) = crate::cores::join(
        || check_poses(model, poses, id),
        || prior::plan(model, spec, opts.prior),
    );
    Ok((readings?, Some(plan)))
}

/// [`calibrate_inner`] once every constraint of `model` has poses (or is left out of it).
fn calibrate_seen(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    ids: Option<&[usize]>,
) -> Result<(Estimate, Residuals)> {
    // Pose numbers as the user's file has them (the poses may be a subset after rejection).
    let id = |l: usize| ids.and_then(|m| m.get(l).copied()).unwrap_or(l);
    let (readings, prior_plan) = checked_with_plan(model, params, poses, opts, spec, &id)?;
    let noted = |e| checks::with_limits_note(e, poses, &readings, &id);
    let FitOutcome {
        mut p,
        std,
        start,
        method,
        rank,
        condition,
        covariance,
        lin_c,
        linear_poses,
        robust,
        mut warnings,
        prior,
        basis_size,
        ..
    } = fit_stage(model, poses, opts, spec, prior_plan.as_ref()).map_err(noted)?;
    let covariance_report = canonical_with_covariance(model, poses, &mut p, covariance.as_ref());
    let paper_line = model.dim() == 2
        && model.constraint_count() == 1
        && model.constraint_kind(0) == ConstraintKind::Line2;
    let mut res = Residuals::at(model, poses, &p, paper_line, has_constraint_report(model));
    let stats = res.stats;
    let paper_err_rms = paper_line.then_some(stats.inertia_rms);
    // With the prior applied, it holds the weak directions (its report names them).
    let (cov, id) = (covariance.as_ref().filter(|_| !prior.applied), &id);
    warnings.extend(data_warnings(model, poses, &readings, &stats, cov, id));
    warnings.extend(warnings::relation_warning(model, &p));
    let out_params = param_estimates(model, params, &p, &std);
    // The linear solve's `c`; none from the nominals (`c(p̂)` would cost the compiled basis).
    let generalized_params = lin_c.unwrap_or_default();
    let rms = stats.residual_rms;
    check_finite(&out_params, rms, paper_err_rms, &generalized_params)?;
    let (constraints, relations, point_distances) =
        constraint_fits(model, poses, res.constraints.take());
    warnings.extend(warnings::relation_data_warning(&relations, &constraints));
    let est = Estimate {
        params: out_params,
        identifiable_count: model.identifiable_count(),
        basis_size,
        poses: poses.len(),
        rank,
        residual_rms: rms,
        paper_err_rms,
        method,
        start: start.to_string(),
        linear_poses,
        condition: condition.is_finite().then_some(condition),
        // Ranked by standardised residual once the robust scale is known (`with_outliers`).
        worst_poses: Vec::new(),
        robust_scale: f64::NAN,
        rejected: Vec::new(),
        robust,
        warnings,
        generalized_params,
        constraints,
        relations,
        prior,
        point_distances,
        validation: Vec::new(),
        cross_validation: None,
        planes: plane_fit::plane_fits(model, &p),
        joint_ranges: joint_ranges::joint_ranges(poses),
        orientation_rms: None,
        pose_noise: None,
        covariance: covariance_report,
    };
    Ok((est, res))
}

/// `p` in its canonical form ([`canonical_form`]), and the fit's covariance for the report:
/// none when the canonical form moved the estimate (a mirrored link), rather than the
/// covariance of another parametrisation.
fn canonical_with_covariance(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &mut [f64],
    covariance: Option<&(Vec<usize>, nalgebra::DMatrix<f64>)>,
) -> Option<estimate::ParamCovarianceReport> {
    let fitted = p.to_vec();
    canonical_form(model, poses, p);
    covariance
        .filter(|_| fitted == p)
        .and_then(|(free, m)| covariance_report(model, free, m))
}

/// The covariance `m` of the free parameters `free` (model indices) for the report, by name;
/// `None` when an entry is not finite.
fn covariance_report(
    model: &dyn CalibModel,
    free: &[usize],
    m: &nalgebra::DMatrix<f64>,
) -> Option<estimate::ParamCovarianceReport> {
    if m.nrows() != free.len() || m.ncols() != free.len() || !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    Some(estimate::ParamCovarianceReport {
        params: free
            .iter()
            .map(|&j| model.param_name(j).to_string())
            .collect(),
        matrix: m.row_iter().map(|r| r.iter().copied().collect()).collect(),
    })
}

/// Whether the report lists constraints and relations one by one: a list, or relations.
fn has_constraint_report(model: &dyn CalibModel) -> bool {
    model.constraint_count() > 1 || !model.relations().is_empty()
}

/// A list's constraints one by one, and the relations, for the nominal and calibrated
/// models (nothing for one constraint without relations): the calibrated sums `calibrated`
/// from the residual pass, the nominal ones summed here.
fn constraint_fits(
    model: &dyn CalibModel,
    poses: &Poses,
    calibrated: Option<(Vec<ConstraintSums>, Vec<Vec<f64>>)>,
) -> (Vec<ConstraintFit>, Vec<RelationFit>, Vec<PointDistance>) {
    match calibrated {
        Some(c) if has_constraint_report(model) => {
            let nominal: Vec<f64> = (0..model.param_count())
                .map(|j| model.param_nominal(j))
                .collect();
            constraint_fit::constraint_fits_with(model, poses, &nominal, c)
        }
        _ => (Vec::new(), Vec::new(), Vec::new()),
    }
}

/// Every spec parameter's estimate in spec order: known ones at their nominal, estimated
/// ones from `p` with their `std` (none when held by the gauge rule).
fn param_estimates(
    model: &dyn CalibModel,
    params: &[SpecParam],
    p: &[f64],
    std: &[Option<f64>],
) -> Vec<ParamEstimate> {
    let mut out_params = Vec::with_capacity(params.len());
    let mut j = 0;
    for sp in params {
        if sp.known {
            out_params.push(ParamEstimate {
                name: sp.name.clone(),
                value: sp.nominal,
                std: None,
                identifiable: false,
                known: true,
                held: false,
            });
        } else {
            let held = model.param_held(j);
            out_params.push(ParamEstimate {
                name: sp.name.clone(),
                value: p[j],
                std: if held { None } else { std[j] },
                identifiable: model.param_identifiable(j),
                known: false,
                held,
            });
            j += 1;
        }
    }
    out_params
}
