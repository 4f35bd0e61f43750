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

pub mod constraint_fit;
pub mod estimate;

use crate::calibrate::estimate::{Estimate, ParamEstimate, RobustFit, WorstPose};
use crate::data::Poses;
use crate::error::{Error, ErrorClass, Result};
use crate::fit::extract::extract_from;
use crate::fit::solve::solve;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
pub use crate::numeric::robust::Robust;
use crate::numeric::robust::{chi_median, median_of};
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
}

/// Rounds of reweighting at most.
const IRLS_ROUNDS: usize = 30;

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
    progress.stage("fitting", None);
    let mut est = calibrate_inner(model, params, poses, opts, spec, None)?;
    progress.stage("checking outliers", None);
    let (scale, out, worst) = outliers(model, poses, &estimated_values(&est));
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

/// What [`calibrate_inner`] needs besides the poses, for the refits of
/// [`reject_outliers`].
struct Job<'a> {
    model: &'a dyn CalibModel,
    params: &'a [SpecParam],
    opts: CalibrateOptions,
    spec: Option<&'a Spec>,
}

/// `--reject-outliers`: drop the outliers `out` of the first fit `first` (robust scale
/// `first_scale`), fit again, and repeat while the cleaner fit shows more (a fit pulled by
/// many bad rows hides some of them behind an inflated scale), at most 5 times. The last
/// fit, with the dropped poses listed (by residual) and a warning first.
fn reject_outliers(
    job: &Job<'_>,
    poses: &Poses,
    progress: &dyn crate::progress::Progress,
    first: Estimate,
    out: Vec<WorstPose>,
    first_scale: f64,
) -> Result<Estimate> {
    const REJECT_ROUNDS: usize = 5;
    let model = job.model;
    let mut rejected = out;
    let mut keep: Vec<usize> = Vec::new();
    let mut again = first;
    for round in 0..REJECT_ROUNDS {
        let mut bad: Vec<usize> = rejected.iter().map(|w| w.pose).collect();
        bad.sort_unstable();
        keep = (0..poses.len())
            .filter(|l| bad.binary_search(l).is_err())
            .collect();
        let inliers = poses.select(&keep);
        progress.stage(
            &format!("refit without outliers (round {})", round + 1),
            None,
        );
        again = calibrate_inner(model, job.params, &inliers, job.opts, job.spec, Some(&keep))?;
        let (scale2, more, worst) = outliers(model, &inliers, &estimated_values(&again));
        again.robust_scale = scale2;
        // Pose indices stay those of the file.
        again.worst_poses = worst
            .into_iter()
            .map(|w| WorstPose {
                pose: keep[w.pose],
                ..w
            })
            .collect();
        // Only poses a further fit drops are reported as dropped.
        if more.is_empty() || round + 1 == REJECT_ROUNDS {
            break;
        }
        rejected.extend(more.into_iter().map(|w| WorstPose {
            pose: keep[w.pose],
            ..w
        }));
    }
    rejected.sort_by(|a, b| b.residual.total_cmp(&a.residual).then(a.pose.cmp(&b.pose)));
    again.warnings.insert(
        0,
        format!(
            "--reject-outliers dropped {} of {} poses (beyond {OUTLIER_SIGMAS} robust standard \
             deviations, σ ≈ {first_scale:.3e} m at the first fit): {}; the estimate uses the \
             other {}",
            rejected.len(),
            poses.len(),
            listed(&rejected),
            keep.len()
        ),
    );
    again.rejected = rejected;
    Ok(again)
}

/// The first [`WORST_SHOWN`] poses of `v` for a warning (pose, CSV line, residual), and how
/// many more there are.
fn listed(v: &[WorstPose]) -> String {
    let shown: Vec<String> = v
        .iter()
        .take(WORST_SHOWN)
        .map(|w| format!("pose {} (line {}) {:.3e} m", w.pose, w.line, w.residual))
        .collect();
    and_more(&shown, v.len())
}

/// The items `shown` (the first of `total`) joined with `; `, then `; and N more` for the rest.
fn and_more(shown: &[String], total: usize) -> String {
    let more = total.saturating_sub(shown.len());
    let head = shown.join("; ");
    if more > 0 {
        format!("{head}; and {more} more")
    } else {
        head
    }
}

/// The iteratively reweighted fit from `p0` with `loss` (see [`Robust`]): the last weighted
/// fit (`None` when the residuals vanish, exact data, and no weighting is needed) and what
/// it did.
fn robust_refit(
    model: &dyn CalibModel,
    poses: &Poses,
    p0: &[f64],
    loss: Robust,
) -> Result<(Option<crate::fit::geometric::GeometricEstimate>, RobustFit)> {
    let mut p = p0.to_vec();
    let mut last = None;
    let mut info = RobustFit {
        loss: loss.name().to_string(),
        tuning: loss.tuning(),
        scale: f64::NAN,
        rounds: 0,
        downweighted: 0,
        linear_rounds: 0,
        linear_downweighted: 0,
    };
    for round in 1..=IRLS_ROUNDS {
        let (scale, d) = residual_scale(model, poses, &p);
        if !(scale > 0.0 && scale.is_finite()) {
            break;
        }
        let w: Vec<f64> = d
            .iter()
            .enumerate()
            .map(|(l, &x)| {
                let m = components(model, poses, l).max(1) as f64;
                loss.weight(x / (scale * m.sqrt()))
            })
            .collect();
        info.scale = scale;
        info.rounds = round;
        info.downweighted = w.iter().filter(|&&x| x < 0.5).count();
        let mut r = crate::fit::geometric::fit_weighted(model, poses, &p, Some(&w))?;
        // The covariance's σ̂² from the robust scale, not from the weighted cost (which the
        // down-weighted poses still inflate): σ̂²·(JᵀWJ)⁻¹.
        let dof = r.components.saturating_sub(r.free.len()).max(1) as f64;
        let sigma2 = r.cost / dof;
        if sigma2 > 0.0 && sigma2.is_finite() {
            let f = scale * scale / sigma2;
            for v in r.std.iter_mut().flatten() {
                *v *= f.sqrt();
            }
            if let Some(c) = &mut r.covariance {
                *c *= f;
            }
        }
        let moved =
            r.p.iter()
                .zip(&p)
                .map(|(a, b)| (a - b).abs() / (1.0 + b.abs()))
                .fold(0.0, f64::max);
        p.clone_from(&r.p);
        last = Some(r);
        if moved <= 1e-10 {
            break;
        }
    }
    Ok((last, info))
}

/// The linear solve, iteratively reweighted with a robust loss
/// ([`crate::fit::solve::solve_robust`]), and what the reweighting did.
fn linear_solve(
    model: &dyn CalibModel,
    poses: &Poses,
    robust: Option<Robust>,
) -> Result<(
    crate::fit::solve::LinearSolve,
    Option<crate::fit::solve::LinearReweighting>,
)> {
    match robust {
        Some(loss) => {
            crate::fit::solve::solve_robust(model, poses, loss).map(|(l, r)| (l, Some(r)))
        }
        None => solve(model, poses).map(|l| (l, None)),
    }
}

/// The estimated parameters' values of an estimate (known ones left out), in model order.
fn estimated_values(est: &Estimate) -> Vec<f64> {
    est.params
        .iter()
        .filter(|x| !x.known)
        .map(|x| x.value)
        .collect()
}

/// Every pose's residual norm and component count at `p`, and their robust scale (see
/// [`Estimate::robust_scale`]; NaN below 10 poses, where a median means little).
fn residual_scale(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (f64, Vec<f64>) {
    let m = |l: usize| components(model, poses, l);
    // Norms only (8 bytes a pose; a million poses stay light), component counts on demand.
    let parts = crate::fit::geometric::fold_poses(
        model,
        poses,
        p,
        Vec::new,
        |v: &mut Vec<f64>, _, _, d2| {
            v.push(d2.sqrt());
        },
    );
    let x = concat_parts(parts);
    let scale = if x.len() < 10 {
        f64::NAN
    } else {
        median_of(x.len(), |l| x[l] / chi_median(m(l)))
    };
    (scale, x)
}

/// The per-chunk vectors of [`crate::fit::geometric::fold_poses`] as one, growing the first in place
/// (a large block is remapped, not copied) and dropping each other as it is taken: the
/// residuals of a million poses are not held twice.
fn concat_parts(parts: Vec<Vec<f64>>) -> Vec<f64> {
    let total: usize = parts.iter().map(Vec::len).sum();
    let mut parts = parts.into_iter();
    let Some(mut x) = parts.next() else {
        return Vec::new();
    };
    x.reserve_exact(total - x.len());
    for part in parts {
        x.extend(part);
    }
    x
}

/// Residual components of pose `l` (1 when its constraint index is out of range).
fn components(model: &dyn CalibModel, poses: &Poses, l: usize) -> usize {
    poses
        .constraint
        .get(l)
        .map_or(1, |j| model.constraint_kind(j).residual_count(model.dim()))
}

/// The robust scale of the residuals at `p` (see [`Estimate::robust_scale`]), the poses
/// beyond [`OUTLIER_SIGMAS`] of it (descending residual), and the [`WORST_SHOWN`] worst
/// poses by standardised residual ([`worst_poses`]). No outliers when the scale vanishes
/// (exact data) or when fewer than 10 poses make a median meaningless.
fn outliers(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
) -> (f64, Vec<WorstPose>, Vec<WorstPose>) {
    let (scale, d) = residual_scale(model, poses, p);
    let worst = worst_poses(model, poses, &d, scale);
    if !(scale > 0.0 && scale.is_finite()) {
        return (scale, Vec::new(), worst);
    }
    // The threshold per pose: OUTLIER_SIGMAS·σ on the residual norm, raised by the χ median
    // so a pose with more components is not flagged for having them.
    let mut out: Vec<WorstPose> = d
        .iter()
        .enumerate()
        .filter(|&(l, &x)| {
            x > OUTLIER_SIGMAS * scale * chi_median(components(model, poses, l)).max(1.0)
        })
        .map(|(l, &x)| WorstPose {
            pose: l,
            line: poses.line.at(l),
            residual: x,
            standardized: standardized(x, scale, components(model, poses, l)),
        })
        .collect();
    out.sort_by(|a, b| b.residual.total_cmp(&a.residual).then(a.pose.cmp(&b.pose)));
    (scale, out, worst)
}

/// The standardised residual `z = x / (scale·χ̃_m)` of a pose with residual norm `x` and `m`
/// components (see [`WorstPose::standardized`]); `None` when the scale is not positive and
/// finite.
fn standardized(x: f64, scale: f64, m: usize) -> Option<f64> {
    (scale > 0.0 && scale.is_finite()).then(|| x / (scale * chi_median(m)))
}

/// [`calibrate`], with the spec when there is one (for closed-form starts); `ids` maps the
/// poses to their numbers in the data as given (after outlier rejection, a subset).
fn calibrate_inner(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    ids: Option<&[usize]>,
) -> Result<Estimate> {
    // Pose numbers as the user's file has them (the poses may be a subset after rejection).
    let id = |l: usize| ids.and_then(|m| m.get(l).copied()).unwrap_or(l);
    check_model_params(model, params)?;
    check_poses(model, poses)?;
    let k = model.basis_size();
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
        ..
    } = fit_stage(model, poses, opts, spec)?;
    canonical_form(model, poses, &mut p);
    let stats = tip_statistics(model, poses, &p);
    let residual_rms = stats.residual_rms;
    let paper_err_rms = (model.dim() == 2
        && model.constraint_count() == 1
        && model.constraint_kind(0) == ConstraintKind::Line2)
        .then_some(stats.inertia_rms);
    warnings.extend(data_warnings(
        model,
        poses,
        &stats,
        covariance.as_ref(),
        &id,
    ));
    let out_params = param_estimates(model, params, &p, &std);
    let generalized_params = lin_c.unwrap_or_else(|| generalized_params_at(model, &p));
    check_finite(
        &out_params,
        residual_rms,
        paper_err_rms,
        &generalized_params,
    )?;
    let (constraints, relations) = constraint_fits(model, poses, &p);
    Ok(Estimate {
        params: out_params,
        identifiable_count: model.identifiable_count(),
        basis_size: k,
        poses: poses.len(),
        rank,
        residual_rms,
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
    })
}

/// The model's parameters are exactly the spec's estimated (not `known`) ones, in order.
fn check_model_params(model: &dyn CalibModel, params: &[SpecParam]) -> Result<()> {
    let estimated: Vec<&SpecParam> = params.iter().filter(|p| !p.known).collect();
    let consistent = estimated.len() == model.param_count()
        && estimated
            .iter()
            .enumerate()
            .all(|(j, p)| p.name == model.param_name(j));
    if consistent {
        return Ok(());
    }
    Err(Error::other(format!(
        "the model's parameters ({}) are not the spec's estimated parameters ({})",
        (0..model.param_count())
            .map(|j| model.param_name(j))
            .collect::<Vec<_>>()
            .join(", "),
        estimated
            .iter()
            .map(|p| p.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

/// The poses are consistent (a constraint index, and a measured tip where tips are
/// measured, for each), their readings finite, and they support the fit: the one rule,
/// checked first and cheaply (one pass, O(N·n²)), enough residual components and a Jacobian
/// of full column rank near the nominals, whatever the path.
fn check_poses(model: &dyn CalibModel, poses: &Poses) -> Result<()> {
    let n = poses.len();
    let measured_ok = poses.measured.as_ref().is_none_or(|m| m.len() == n);
    if poses.constraint.len() != n || !measured_ok {
        return Err(Error::other(
            "inconsistent poses: every pose needs a constraint index (and a measured-tip entry when tips are measured)",
        ));
    }
    check_readings(model, poses)?;
    crate::fit::geometric::check_support(model, poses)
}

/// What the fit stage found: the estimate and its statistics, where it started and how it
/// went on, the linear solution when there was one, and the warnings of the fit, in the
/// order they arose.
struct FitOutcome {
    /// The estimated parameters (model order).
    p: Vec<f64>,
    /// Their standard deviations (`None` for held ones).
    std: Vec<Option<f64>>,
    /// `linear` or `nominal` ([`Estimate::start`]).
    start: &'static str,
    /// [`Estimate::method`].
    method: String,
    /// [`Estimate::rank`]: the linear data matrix's, or the Jacobian's from the nominals.
    rank: usize,
    /// Condition number of the last fit.
    condition: f64,
    /// Covariance of the free parameters (with their indices), when known.
    covariance: Option<(Vec<usize>, nalgebra::DMatrix<f64>)>,
    /// The linear generalized parameters, from a linear start.
    lin_c: Option<Vec<f64>>,
    /// Poses the linear method was tried on (0 for a planned nominal start).
    linear_poses: usize,
    /// What the reweighted linear solve did (`--robust` and a linear start).
    reweighted: Option<crate::fit::solve::LinearReweighting>,
    /// What the robust fit did (`--robust`).
    robust: Option<RobustFit>,
    /// Warnings of the fit, in order.
    warnings: Vec<String>,
}

/// The fit stage: the planned start (linear, on every pose or a subset, or the nominals;
/// [`plan_start`]), the path from it, then with `--robust` the reweighting.
fn fit_stage(
    model: &dyn CalibModel,
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
) -> Result<FitOutcome> {
    let plan = plan_start(model, poses, opts.start)?;
    let mut warnings = Vec::new();
    let (linear, linear_poses) = match &plan {
        Plan::Linear(subset) => {
            let sub = subset.as_ref().map(|idx| poses.select(idx));
            let use_poses = sub.as_ref().unwrap_or(poses);
            let start = linear_start(
                model,
                use_poses,
                subset.is_some(),
                opts,
                spec,
                &mut warnings,
            )?;
            (start, use_poses.len())
        }
        Plan::Nominal => (None, 0),
    };
    let mut fit = match linear {
        Some(start) => linear_path(model, poses, start, opts.refine, linear_poses, warnings)?,
        None => nominal_path(model, poses, linear_poses, warnings)?,
    };
    if let Some(loss) = opts.robust {
        robust_reweighting(model, poses, opts.refine, loss, &mut fit)?;
    }
    Ok(fit)
}

/// A linear start: the solve, its extraction, what the reweighting did (with `--robust`),
/// and whether it ran on a subset of the poses.
struct LinearStart {
    lin: crate::fit::solve::LinearSolve,
    ext: crate::fit::extract::Extraction,
    reweighted: Option<crate::fit::solve::LinearReweighting>,
    subset: bool,
}

/// The linear method on `use_poses` (all of them, or the subset when `subset`): solve, then
/// extract (from the paper's closed form where it applies). With [`StartChoice::Auto`], a
/// degenerate failure is a warning and `None` (the fit starts from the nominals).
fn linear_start(
    model: &dyn CalibModel,
    use_poses: &Poses,
    subset: bool,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    warnings: &mut Vec<String>,
) -> Result<Option<LinearStart>> {
    let attempt = linear_solve(model, use_poses, opts.robust).and_then(|(lin, reweighted)| {
        // The paper's sec. 4.1 closed form, where it applies, is the exact start of the
        // general extraction (which then only confirms it).
        let cf = spec.and_then(|s| crate::fit::closed_form::planar_line(s, model, &lin));
        extract_from(model, &lin, cf.as_deref()).map(|ext| LinearStart {
            lin,
            ext,
            reweighted,
            subset,
        })
    });
    match attempt {
        Ok(x) => Ok(Some(x)),
        Err(e) if opts.start == StartChoice::Auto && e.class() == ErrorClass::Degenerate => {
            warnings.push(format!(
                "the linear method could not start ({e}); the fit started from the nominals"
            ));
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// The path from a linear start: the extracted estimate with sandwich standard deviations,
/// then (with `refine`, or after a subset, to use every pose) the geometric fit from it,
/// kept only when it lowers the cost.
fn linear_path(
    model: &dyn CalibModel,
    poses: &Poses,
    start: LinearStart,
    refine: bool,
    linear_poses: usize,
    mut warnings: Vec<String>,
) -> Result<FitOutcome> {
    let LinearStart {
        lin,
        ext,
        reweighted,
        subset,
    } = start;
    warnings.extend(ext.warnings.iter().cloned());
    // The linear method's estimate minimises the algebraic cost Σ h², whose equations
    // carry different scales in a list or on a 3-D line: its covariance is the sandwich
    // H⁻¹MH⁻¹, which needs no assumption about those scales.
    // With `--robust`, each pose weighs what the reweighted solve gave it.
    let w = (!subset)
        .then(|| reweighted.as_ref().map(|r| r.weights.as_slice()))
        .flatten();
    let std = sandwich_std(model, poses, &ext.p, &ext.free, w).unwrap_or_else(|| ext.std.clone());
    warnings.extend(linear_warnings(model, &lin, subset));
    let mut fit = FitOutcome {
        p: ext.p.clone(),
        std,
        start: "linear",
        method: "linear".to_string(),
        rank: lin.rank,
        condition: ext.condition,
        covariance: None,
        lin_c: Some(lin.generalized_params(model.equation_count())),
        linear_poses,
        reweighted,
        robust: None,
        warnings,
    };
    // A subset needs the fit over every pose to use all the data.
    if refine || subset {
        refine_linear(model, poses, &ext.p, &mut fit)?;
    } else {
        fit.covariance = Some((ext.free, ext.covariance));
    }
    Ok(fit)
}

/// Warnings about the linear solve's data: fewer than `2K` poses (on every pose, not a
/// subset), constraints without poses.
fn linear_warnings(
    model: &dyn CalibModel,
    lin: &crate::fit::solve::LinearSolve,
    subset: bool,
) -> Vec<String> {
    let k = model.basis_size();
    let mut warnings = Vec::new();
    if k > 0 && lin.poses < 2 * k && !subset {
        warnings.push(format!(
            "only {} poses for a basis of K = {k} functions: the linear fit has few redundant equations; use at least {}",
            lin.poses,
            2 * k
        ));
    }
    for g in lin.groups.iter().filter(|g| g.poses == 0) {
        warnings.push(format!(
            "constraint {} has no poses; its parameters stay at the values the other data allow",
            g.constraint
        ));
    }
    warnings
}

/// The geometric fit from the linear estimate `p0`, taken into `fit` when it does not raise
/// the cost and its Jacobian is regular (`rank` stays the linear data matrix's, the
/// interface's meaning); otherwise a warning, and the linear estimate stays (without a
/// covariance).
fn refine_linear(
    model: &dyn CalibModel,
    poses: &Poses,
    p0: &[f64],
    fit: &mut FitOutcome,
) -> Result<()> {
    let r = crate::fit::geometric::fit(model, poses, p0)?;
    if r.cost <= r.start_cost * (1.0 + 1e-12) && r.covariance.is_some() {
        fit.p = r.p;
        fit.std = r.std;
        fit.condition = r.condition;
        fit.covariance = r.covariance.map(|c| (r.free, c));
        fit.method = "linear+refine".to_string();
    } else if r.covariance.is_none() {
        fit.warnings.push(
            "refinement reached a point where the geometric Jacobian is singular and was rejected; the linear estimate is reported"
                .to_string(),
        );
    } else {
        fit.warnings.push(format!(
            "refinement ended above its starting cost ({:.6e} > {:.6e}) and was rejected; the linear estimate is reported",
            r.cost, r.start_cost
        ));
    }
    Ok(())
}

/// The path from the nominals (deterministic restarts); an error when it ends where the
/// poses do not determine every free parameter.
fn nominal_path(
    model: &dyn CalibModel,
    poses: &Poses,
    linear_poses: usize,
    warnings: Vec<String>,
) -> Result<FitOutcome> {
    let (r, _tried) = crate::fit::geometric::fit_from_nominal(model, poses)?;
    if r.covariance.is_none() {
        return Err(Error::degenerate(format!(
            "the fit from the nominals ends where the poses do not determine every free parameter (Jacobian rank {} of {}): add poses that move every joint, or hold more parameters (`known: true`)",
            r.rank,
            r.free.len()
        )));
    }
    Ok(FitOutcome {
        p: r.p,
        std: r.std,
        start: "nominal",
        method: "nominal+refine".to_string(),
        rank: r.rank,
        condition: r.condition,
        covariance: r.covariance.map(|c| (r.free, c)),
        lin_c: None,
        linear_poses,
        reweighted: None,
        robust: None,
        warnings,
    })
}

/// `--robust`: the reweighted linear estimate is reported as it is without refinement; a
/// fit in parameter space (refinement, the nominal start, the fit over every pose after a
/// linear subset) is reweighted in its turn ([`robust_refit`]). Sets `fit.robust`.
fn robust_reweighting(
    model: &dyn CalibModel,
    poses: &Poses,
    refine: bool,
    loss: Robust,
    fit: &mut FitOutcome,
) -> Result<()> {
    let (lr, ld) = fit
        .reweighted
        .as_ref()
        .map_or((0, 0), |r| (r.rounds, r.downweighted));
    let linear_alone = fit.start == "linear" && !refine && fit.linear_poses == poses.len();
    let info = if linear_alone {
        RobustFit {
            loss: loss.name().to_string(),
            tuning: loss.tuning(),
            scale: residual_scale(model, poses, &fit.p).0,
            rounds: 0,
            downweighted: ld,
            linear_rounds: lr,
            linear_downweighted: ld,
        }
    } else {
        let (r, info) = robust_refit(model, poses, &fit.p, loss)?;
        if let Some(r) = r {
            fit.p = r.p;
            fit.std = r.std;
            fit.rank = r.rank;
            fit.condition = r.condition;
            fit.covariance = r.covariance.map(|c| (r.free, c));
        }
        RobustFit {
            linear_rounds: lr,
            linear_downweighted: ld,
            ..info
        }
    };
    fit.robust = Some(info);
    Ok(())
}

/// Equivalent solutions (mirrored links) nearest the nominals, always; free angles wrapped
/// into (−π, π] (fits may leave them outside).
fn canonical_form(model: &dyn CalibModel, poses: &Poses, p: &mut [f64]) {
    let scale0 = {
        let s = tip_statistics(model, poses, p);
        s.spread.max(0.1 * s.reach)
    };
    crate::fit::symmetry::canonicalize(model, p, scale0);
    for (j, v) in p.iter_mut().enumerate() {
        if model.param_is_angle(j) && !model.param_held(j) {
            *v = crate::numeric::wrap_angle(*v);
        }
    }
}

/// The warnings about the data and the estimate, in order: the readings, practically
/// unidentifiable directions (given the covariance), a residual large for the data's scale,
/// readings outside the joint limits. `id` numbers the poses as the data does.
fn data_warnings(
    model: &dyn CalibModel,
    poses: &Poses,
    stats: &TipStatistics,
    covariance: Option<&(Vec<usize>, nalgebra::DMatrix<f64>)>,
    id: &dyn Fn(usize) -> usize,
) -> Vec<String> {
    let mut warnings = reading_warnings(model, poses);
    // The data's scale: the spread of the tips, or a tenth of their distance from the base
    // origin when they cluster (a pinned point).
    let scale = stats.spread.max(0.1 * stats.reach);
    if let Some((free, cov)) = covariance {
        warnings.extend(practical_warnings(model, free, cov, scale));
    }
    warnings.extend(fit_warning(poses, stats, scale, id));
    warnings.extend(limit_warning(model, poses, id));
    warnings
}

/// The generalized parameters `c(p)` (without a linear solution), normalised as the linear
/// solve does: the constant function's coefficient 1 (not for a measured tip).
fn generalized_params_at(model: &dyn CalibModel, p: &[f64]) -> Vec<f64> {
    let k = model.basis_size();
    let mut c = vec![0.0; model.equation_count() * k];
    model.generalized_params(p, &mut c);
    if let Some(ci) = model.constant_index() {
        for row in c.chunks_mut(k.max(1)) {
            let d = row[ci];
            if d != 0.0 && model.constraint_kind(0) != ConstraintKind::Measured {
                row.iter_mut().for_each(|v| *v /= d);
            }
        }
    }
    c
}

/// Every reported number finite; otherwise an error (never a NaN passed on silently).
fn check_finite(
    params: &[ParamEstimate],
    residual_rms: f64,
    paper_err_rms: Option<f64>,
    generalized_params: &[f64],
) -> Result<()> {
    let finite = params
        .iter()
        .all(|q| q.value.is_finite() && q.std.is_none_or(f64::is_finite))
        && residual_rms.is_finite()
        && paper_err_rms.is_none_or(f64::is_finite)
        && generalized_params.iter().all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(Error::other(
            "the calibration produced a non-finite value; the data or the model is degenerate",
        ))
    }
}

/// A list's constraints one by one, and the relations, for the nominal and calibrated
/// models (nothing for one constraint without relations).
fn constraint_fits(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
) -> (
    Vec<crate::calibrate::constraint_fit::ConstraintFit>,
    Vec<crate::calibrate::constraint_fit::RelationFit>,
) {
    if model.constraint_count() > 1 || !model.relations().is_empty() {
        let nominal: Vec<f64> = (0..model.param_count())
            .map(|j| model.param_nominal(j))
            .collect();
        crate::calibrate::constraint_fit::constraint_fits(model, poses, &nominal, p)
    } else {
        (Vec::new(), Vec::new())
    }
}

/// Warnings about the joint readings themselves: revolute readings beyond a full turn (likely
/// degrees), joints that never moved.
fn reading_warnings(model: &dyn CalibModel, poses: &Poses) -> Vec<String> {
    let mut warnings = Vec::new();
    // Readings beyond a full turn on a revolute joint are legal but usually degrees.
    for i in (0..model.joint_count()).filter(|&i| !model.joint_is_prismatic(i)) {
        let max = poses.q.iter().map(|q| q[i].abs()).fold(0.0, f64::max);
        if max > std::f64::consts::TAU + 1e-9 {
            warnings.push(format!(
                "joint q{} has readings up to {max:.4} in magnitude, beyond a full turn (2π): \
                 revolute readings are radians; if these are degrees, multiply by π/180",
                i + 1
            ));
        }
    }
    let frozen: Vec<String> = (0..model.joint_count())
        .filter(|&i| poses.q.iter().all(|q| q[i] == poses.q[0][i]))
        .map(|i| format!("q{}", i + 1))
        .collect();
    if !frozen.is_empty() && poses.len() > 1 {
        warnings.push(format!("joints that never moved: {}", frozen.join(", ")));
    }
    warnings
}

/// The warning for a residual above 5 % of the data's `scale`: noisy data or a model that
/// does not fit, naming the farthest pose.
fn fit_warning(
    poses: &Poses,
    stats: &TipStatistics,
    scale: f64,
    id: &dyn Fn(usize) -> usize,
) -> Option<String> {
    let residual_rms = stats.residual_rms;
    if !(scale > 0.0 && residual_rms > 0.05 * scale) {
        return None;
    }
    let (l, d) = stats.worst;
    let line = poses
        .line
        .get(l)
        .map_or(String::new(), |n| format!(", line {n}"));
    Some(format!(
        "the residual rms {residual_rms:.3e} m is {:.1}% of the scale of the data ({scale:.3e} m): the data is noisy or the model does not fit it; the farthest pose is {}{line} ({d:.3e} m from the constraint)",
        100.0 * residual_rms / scale,
        id(l)
    ))
}

/// The warning for readings outside the spec's joint limits (legal input, but often a sign of
/// a bad row): the first few, with pose numbers `id(l)` and CSV lines.
fn limit_warning(
    model: &dyn CalibModel,
    poses: &Poses,
    id: &dyn Fn(usize) -> usize,
) -> Option<String> {
    // Readings outside the spec's joint limits are legal input but often a sign of a bad row.
    let mut outside = Vec::new();
    for (l, q) in poses.q.iter().enumerate() {
        for (i, &qi) in q.iter().enumerate() {
            if let Some([lo, hi]) = model.joint_limits(i) {
                if qi < lo || qi > hi {
                    let line = poses
                        .line
                        .get(l)
                        .map_or(String::new(), |n| format!(" (line {n})"));
                    outside.push(format!(
                        "pose {}{line}: q{} = {qi} not in [{lo}, {hi}]",
                        id(l),
                        i + 1
                    ));
                }
            }
        }
    }
    if outside.is_empty() {
        return None;
    }
    const SHOWN: usize = 5;
    Some(format!(
        "{} joint reading(s) outside the spec's limits: {}",
        outside.len(),
        and_more(&outside[..outside.len().min(SHOWN)], outside.len())
    ))
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

/// Heteroskedasticity-robust (sandwich) standard deviations of the algebraic least-squares
/// estimate at `p` over the free parameters `free`: with per-pose, per-equation residuals
/// `r_le = c_e(p)·Φ̃(q_l)` (minus the measured coordinate for measured tips) and rows
/// `a_le = Φ̃(q_l)ᵀ ∂c_e/∂p_free`, `Cov = H⁻¹ M H⁻¹`, `H = Σ a aᵀ`,
/// `M = Σ_l (Σ_e a_le r_le)(Σ_e a_le r_le)ᵀ` (clustered by pose), scaled by `N/(N − n)`.
/// With pose weights `w_l` (the reweighted solve of `--robust`), the weighted estimate's:
/// `H = Σ w a aᵀ`, `M = Σ_l w_l² (Σ_e a r)(Σ_e a r)ᵀ`.
/// `None` when `H` is singular or a value is not finite.
fn sandwich_std(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    free: &[usize],
    weights: Option<&[f64]>,
) -> Option<Vec<Option<f64>>> {
    use nalgebra::{DMatrix, DVector};
    let k = model.basis_size();
    let ne = model.equation_count();
    let np = model.param_count();
    let n = free.len();
    let mut std = vec![None; np];
    if n == 0 {
        return Some(std);
    }
    let mut c = vec![0.0; ne * k];
    model.generalized_params(p, &mut c);
    let mut jac = vec![0.0; ne * k * np];
    model.jacobian(p, &mut jac);
    let mut phi = vec![0.0; k];
    let mut h = DMatrix::<f64>::zeros(n, n);
    let mut meat = DMatrix::<f64>::zeros(n, n);
    for l in 0..poses.len() {
        let w = weights.map_or(Some(1.0), |w| w.get(l).copied())?;
        model.basis(&poses.q[l], &mut phi);
        let j = poses.constraint.at(l);
        let mut score = DVector::<f64>::zeros(n);
        for e in (0..ne).filter(|&e| model.equation_constraint(e) == j) {
            let mut r: f64 = (0..k).map(|i| c[e * k + i] * phi[i]).sum();
            if model.constraint_kind(j) == ConstraintKind::Measured {
                // Equations of a measured constraint are the tip coordinates, in order.
                let coord = (0..e)
                    .filter(|&f| model.equation_constraint(f) == j)
                    .count();
                r -= poses.measured.as_ref()?.get(l)?.get(coord)?;
            }
            let a = DVector::<f64>::from_iterator(
                n,
                free.iter().map(|&fj| {
                    (0..k)
                        .map(|i| phi[i] * jac[(e * k + i) * np + fj])
                        .sum::<f64>()
                }),
            );
            h += &a * a.transpose() * w;
            score += &a * (r * w);
        }
        meat += &score * score.transpose();
    }
    // Relations are exact equations: heavy rows in H (no residual, so nothing in M) make the
    // directions they fix (nearly) certain, as in the fits.
    let relation_rows = crate::fit::relation::rows(model, p);
    if !relation_rows.is_empty() {
        let diag: Vec<f64> = (0..n).map(|i| h[(i, i)]).collect();
        let w = crate::fit::relation::weight(&diag);
        for row in relation_rows {
            let mut a = DVector::<f64>::zeros(n);
            for (param, d) in &row.gradient {
                if let Some(pos) = free.iter().position(|f| f == param) {
                    a[pos] += w * d;
                }
            }
            h += &a * a.transpose();
        }
    }
    let hinv = h.try_inverse()?;
    let dof = poses.len() as f64 / (poses.len().saturating_sub(n).max(1)) as f64;
    let cov = &hinv * meat * &hinv * dof;
    for (i, &fj) in free.iter().enumerate() {
        let v = cov[(i, i)].max(0.0).sqrt();
        if !v.is_finite() {
            return None;
        }
        std[fj] = Some(v);
    }
    Some(std)
}

/// Statistics of the calibrated tips.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TipStatistics {
    /// `sqrt(Σ_l ‖g_l‖² / N)`: RMS geometric distance from the constraint.
    pub residual_rms: f64,
    /// `sqrt(λ_min(I)/N)` of the tips' inertia (scatter) matrix about their centroid.
    pub inertia_rms: f64,
    /// `sqrt(Σ_l ‖x_l − x̄‖² / N)`: RMS distance of the tips from their centroid.
    pub spread: f64,
    /// `sqrt(Σ_l ‖x_l‖² / N)`: RMS distance of the tips from the base origin.
    pub reach: f64,
    /// The pose farthest from its constraint: `(pose index, distance ‖g_l‖)`.
    pub worst: (usize, f64),
}

/// Residual and spread of the tips at parameters `p`: one pass over the poses (in parallel
/// when many), a second in the plane.
#[must_use]
pub fn tip_statistics(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> TipStatistics {
    let dim = model.dim();
    let n = poses.len().max(1) as f64;
    let (shift, t) = tip_sums(model, poses, p);
    let mean: Vec<f64> = (0..dim).map(|i| shift[i] + t.s1[i] / n).collect();
    // Σ (x − m)(x − m)ᵀ = Σ uuᵀ − n·ūūᵀ with u = x − shift, ū its mean.
    let mut scatter = vec![0.0; dim * dim];
    for a in 0..dim {
        for b in 0..dim {
            scatter[a * dim + b] = t.s2[a][b] - t.s1[a] * t.s1[b] / n;
        }
    }
    let trace: f64 = (0..dim).map(|a| scatter[a * dim + a]).sum::<f64>().max(0.0);
    let lmin = smallest_scatter(model, poses, p, &scatter, &mean);
    TipStatistics {
        residual_rms: (t.sum / n).sqrt(),
        inertia_rms: (lmin / n).sqrt(),
        spread: (trace / n).sqrt(),
        reach: (t.reach / n).sqrt(),
        worst: (t.worst.0, t.worst.1.sqrt()),
    }
}

/// The sums [`tip_statistics`] needs, over the poses.
#[derive(Clone, Copy)]
struct TipSums {
    /// `Σ ‖g_l‖²`.
    sum: f64,
    /// The pose farthest from its constraint, with its `‖g_l‖²`.
    worst: (usize, f64),
    /// `Σ ‖x_l‖²`.
    reach: f64,
    /// `Σ u_l`, `u = x − shift`.
    s1: [f64; 3],
    /// `Σ u_l u_lᵀ`.
    s2: [[f64; 3]; 3],
}

impl TipSums {
    const ZERO: TipSums = TipSums {
        sum: 0.0,
        worst: (0, 0.0),
        reach: 0.0,
        s1: [0.0; 3],
        s2: [[0.0; 3]; 3],
    };
}

/// The tip sums at `p`, with the tips shifted by the first tip (so the scatter loses no
/// digits to a far origin), merged chunk by chunk in pose order; and that shift.
fn tip_sums(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> ([f64; 3], TipSums) {
    let dim = model.dim();
    let mut shift = [0.0; 3];
    if let Some(q0) = poses.q.first() {
        model.tip(q0, p, &mut shift[..dim]);
    }
    let init = || TipSums::ZERO;
    let parts =
        crate::fit::geometric::fold_poses(model, poses, p, init, |a: &mut TipSums, l, tip, d2| {
            if d2 > a.worst.1 {
                a.worst = (l, d2);
            }
            a.sum += d2;
            for i in 0..dim {
                let u = tip[i] - shift[i];
                a.reach += tip[i] * tip[i];
                a.s1[i] += u;
                for k in 0..dim {
                    a.s2[i][k] += u * (tip[k] - shift[k]);
                }
            }
        });
    let mut t = init();
    for a in parts {
        if a.worst.1 > t.worst.1 {
            t.worst = a.worst;
        }
        t.sum += a.sum;
        t.reach += a.reach;
        for i in 0..3 {
            t.s1[i] += a.s1[i];
            for k in 0..3 {
                t.s2[i][k] += a.s2[i][k];
            }
        }
    }
    (shift, t)
}

/// The smallest eigenvalue of the tips' scatter matrix `scatter` (`dim × dim`, row-major;
/// the tips' centroid `mean`): in the plane from a second pass over the poses, accurately.
fn smallest_scatter(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    scatter: &[f64],
    mean: &[f64],
) -> f64 {
    let dim = model.dim();
    if dim == 2 {
        // The inertia matrix [[Σŷ², −Σx̂ŷ], [−Σx̂ŷ, Σx̂²]] has the scatter matrix's eigenvalues.
        // λ_min from the eigenvalue formula loses half the digits (√ε·spread after the square
        // root), so take the principal direction φ (accurate to ε) and sum the squared offsets
        // along its normal n in a second pass: λ_min = Σ (n·x̂_l)².
        let mut tip = vec![0.0; dim];
        let (a, b, c) = (scatter[0], scatter[1], scatter[3]);
        let phi = 0.5 * (2.0 * b).atan2(a - c);
        let (nx, ny) = (-phi.sin(), phi.cos());
        let mut s = 0.0;
        for q in &poses.q {
            model.tip(q, p, &mut tip);
            let d = nx * (tip[0] - mean[0]) + ny * (tip[1] - mean[1]);
            s += d * d;
        }
        s
    } else {
        let m = nalgebra::DMatrix::from_row_slice(dim, dim, scatter);
        m.try_symmetric_eigen(f64::EPSILON, 1000)
            .map_or(0.0, |e| e.eigenvalues.min().max(0.0))
    }
}

/// The geometric distance `‖g_l‖` of every pose's tip from its constraint at parameters `p`
/// (the model's estimated parameters), metres, in pose order: the values
/// [`Estimate::residual_rms`] is the RMS of (one pass, in parallel when there are many poses).
///
/// # Example
/// A 2R arm (`a1 = 0.375`, `a2 = 0.425`) and the line `x = 0.8` (`b = (−1.25, 0)`): the
/// stretched arm touches it, the elbow bent by a right angle is 0.425 m from it.
/// ```
/// use lincal_core::calibrate::pose_residuals;
/// use lincal_core::data::{Poses, Rows};
/// let spec = lincal_core::spec::from_yaml_str(
///     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1}\n  \
///      - {type: revolute, a: a2}\nparams: {a1: {nominal: 0.375}, a2: {nominal: 0.425}}\n\
///      constraint: {line: {b: [-1.25, 0]}}\n",
///     None,
/// )
/// .unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// let poses = Poses {
///     q: Rows::from_vec(2, vec![0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2]).unwrap(),
///     constraint: lincal_core::data::PoseColumn::labels_from([0, 0]),
///     ..Poses::default()
/// };
/// let r = pose_residuals(&model, &poses, &[0.375, 0.425]).unwrap();
/// assert!(r[0].abs() < 1e-15 && (r[1] - 0.425).abs() < 1e-15);
/// ```
///
/// # Errors
/// [`ErrorClass::Input`] when `p` is not of the model's length or a pose's constraint index
/// is out of range (naming the pose).
pub fn pose_residuals(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Result<Vec<f64>> {
    if p.len() != model.param_count() {
        return Err(Error::input(
            crate::error::Location::default(),
            format!(
                "{} parameter values given, the model estimates {}",
                p.len(),
                model.param_count()
            ),
        ));
    }
    let count = model.constraint_count();
    if let Some(l) = poses.constraint.iter().position(|j| j >= count) {
        return Err(Error::input(
            crate::error::Location {
                pose: Some(l),
                field: Some("constraint".to_string()),
                ..crate::error::Location::default()
            },
            format!(
                "constraint index {} is out of range: the spec has {count} constraint(s)",
                poses.constraint.at(l)
            ),
        ));
    }
    let parts = crate::fit::geometric::fold_poses(
        model,
        poses,
        p,
        Vec::new,
        |v: &mut Vec<f64>, _, _, d2| {
            v.push(d2.sqrt());
        },
    );
    let mut out = Vec::with_capacity(poses.len());
    for part in parts {
        out.extend(part);
    }
    Ok(out)
}

/// The start [`calibrate`] takes.
enum Plan {
    /// The linear method, on every pose (`None`) or on the listed ones.
    Linear(Option<Vec<usize>>),
    /// The nominals.
    Nominal,
}

/// Chooses the start: the linear method when every constraint with poses has at least `K`
/// of them (its data matrix can then determine `c`) and its cost `Σ_j N_j·K²` fits
/// [`LINEAR_BUDGET`], on an evenly spread subset when only that fits; else the nominals.
fn plan_start(model: &dyn CalibModel, poses: &Poses, choice: StartChoice) -> Result<Plan> {
    let k = model.basis_size();
    let nc = model.constraint_count();
    let counts: Vec<usize> = (0..nc)
        .map(|j| poses.constraint.iter().filter(|&c| c == j).count())
        .collect();
    // A measured constraint regresses each coordinate on the basis: K columns; the others
    // need K − 1 poses for a null vector of K columns.
    let need = |j: usize| {
        if model.constraint_kind(j) == ConstraintKind::Measured {
            k
        } else {
            k.saturating_sub(1).max(1)
        }
    };
    let enough =
        (0..nc).all(|j| counts[j] == 0 || counts[j] >= need(j)) && counts.iter().any(|&c| c > 0);
    let kk = (k * k) as f64;
    let cap = ((LINEAR_BUDGET / kk) as usize).max(1);
    match choice {
        StartChoice::Nominal => return Ok(Plan::Nominal),
        StartChoice::Linear if !enough => {
            let short: Vec<String> = (0..nc)
                .filter(|&j| counts[j] > 0 && counts[j] < need(j))
                .map(|j| format!("constraint {j} has {} poses, needs {}", counts[j], need(j)))
                .collect();
            return Err(Error::degenerate(format!(
                "the linear method needs at least K = {k} poses per constraint ({}); use --start auto or nominal",
                short.join("; ")
            )));
        }
        StartChoice::Linear => {}
        StartChoice::Auto => {
            // Each group needs about 2K poses for a well-posed linear start; when even that
            // exceeds the budget, the nominals are the cheaper start.
            let min_cost: f64 = (0..nc)
                .filter(|&j| counts[j] > 0)
                .map(|j| (2 * need(j)).min(counts[j]) as f64 * kk)
                .sum();
            if !enough || min_cost > LINEAR_BUDGET {
                return Ok(Plan::Nominal);
            }
        }
    }
    let total: f64 = counts.iter().map(|&c| c as f64 * kk).sum();
    if total <= LINEAR_BUDGET || choice == StartChoice::Linear && total <= 50.0 * LINEAR_BUDGET {
        return Ok(Plan::Linear(None));
    }
    // An evenly spread subset of each constraint's poses, at least 2K of each.
    let share = (cap / nc.max(1)).max(1);
    let mut idx = Vec::new();
    for j in 0..nc {
        let of_j: Vec<usize> = (0..poses.len())
            .filter(|&l| poses.constraint.at(l) == j)
            .collect();
        let take = of_j.len().min(share.max(2 * need(j)));
        if take == 0 {
            continue;
        }
        for t in 0..take {
            idx.push(of_j[t * of_j.len() / take]);
        }
    }
    idx.sort_unstable();
    Ok(Plan::Linear(Some(idx)))
}

/// The [`WORST_SHOWN`] poses farthest from their constraint, given every pose's residual
/// norm `d` and the robust scale `scale`: ordered by standardised residual
/// ([`WorstPose::standardized`]), which puts poses of constraints with different numbers of
/// residual components on one footing; by residual when the scale is undefined (fewer than
/// 10 poses, exact data). Ties go to the lower pose index.
fn worst_poses(model: &dyn CalibModel, poses: &Poses, d: &[f64], scale: f64) -> Vec<WorstPose> {
    let z = |l: usize, x: f64| standardized(x, scale, components(model, poses, l));
    // The sort key: z where defined, else the residual (the same for every pose).
    let key = |l: usize, x: f64| z(l, x).unwrap_or(x);
    let order = |a: &(f64, usize), b: &(f64, usize)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    let keep = |v: &mut Vec<(f64, usize)>| {
        v.sort_by(order);
        v.truncate(WORST_SHOWN);
    };
    // One pass keeping the largest few (memory O(WORST_SHOWN), a million poses stay light).
    let mut top: Vec<(f64, usize)> = Vec::with_capacity(8 * WORST_SHOWN);
    for (l, &x) in d.iter().enumerate() {
        top.push((key(l, x), l));
        if top.len() >= 8 * WORST_SHOWN {
            keep(&mut top);
        }
    }
    keep(&mut top);
    top.into_iter()
        .map(|(_, l)| WorstPose {
            pose: l,
            line: poses.line.at(l),
            residual: d[l],
            standardized: z(l, d[l]),
        })
        .collect()
}

/// Warnings for parameter directions the data barely determine: each eigen-direction of the
/// covariance (lengths in metres, angles times the data's scale `scale`, so both are
/// distances at the tip) whose standard deviation exceeds [`PRACTICAL_FRACTION`] of `scale`,
/// naming the parameters that make it up.
fn practical_warnings(
    model: &dyn CalibModel,
    free: &[usize],
    cov: &nalgebra::DMatrix<f64>,
    scale: f64,
) -> Vec<String> {
    let n = free.len();
    if n == 0 || scale <= 0.0 || cov.nrows() != n {
        return Vec::new();
    }
    let unit: Vec<f64> = free
        .iter()
        .map(|&j| if model.param_is_angle(j) { scale } else { 1.0 })
        .collect();
    let scaled = nalgebra::DMatrix::from_fn(n, n, |a, b| cov[(a, b)] * unit[a] * unit[b]);
    // Bounded: a covariance that will not converge gives no warning rather than a hang.
    let Some(eig) = scaled.try_symmetric_eigen(f64::EPSILON, 1000) else {
        return Vec::new();
    };
    let limit = PRACTICAL_FRACTION * scale;
    let mut out = Vec::new();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    for i in order {
        let sd = eig.eigenvalues[i].max(0.0).sqrt();
        // (NaN compares false: stop there too.)
        if sd.is_nan() || sd <= limit {
            break;
        }
        let v = eig.eigenvectors.column(i);
        let big = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let names: Vec<usize> = (0..n).filter(|&a| v[a].abs() >= 0.3 * big).collect();
        let combo: Vec<String> = names
            .iter()
            .map(|&a| format!("{:+.2}·{}", v[a], model.param_name(free[a])))
            .collect();
        let list: Vec<&str> = names.iter().map(|&a| model.param_name(free[a])).collect();
        out.push(format!(
            "practically unidentifiable: the combination {} has a std of {sd:.3e} m at the tip, more than {:.0}% of the data's scale ({scale:.3e} m); hold one of {} at its nominal (`known: true`), or add poses that move it",
            combo.join(" "),
            100.0 * PRACTICAL_FRACTION,
            list.join(", ")
        ));
    }
    out
}

/// Every joint reading (and measured coordinate) finite and of the right count, naming the
/// pose and joint otherwise.
fn check_readings(model: &dyn CalibModel, poses: &Poses) -> Result<()> {
    use crate::error::Location;
    let nj = model.joint_count();
    for (l, q) in poses.q.iter().enumerate() {
        let place = || Location {
            pose: Some(l),
            ..Location::default()
        };
        let j = poses.constraint.at(l);
        if j >= model.constraint_count() {
            return Err(Error::input(
                place(),
                format!(
                    "constraint index {j} out of range (the model has {})",
                    model.constraint_count()
                ),
            ));
        }
        if q.len() != nj {
            return Err(Error::input(
                place(),
                format!("{} joint readings where the model has {nj} joints", q.len()),
            ));
        }
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                place(),
                format!("joint reading q{} is not finite ({})", i + 1, q[i]),
            ));
        }
        let m = poses.measured.as_ref().and_then(|m| m.get(l));
        if m.is_some_and(|m| m.iter().any(|v| !v.is_finite())) {
            return Err(Error::input(place(), "the measured tip is not finite"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    #[test]
    fn median_of_is_the_exact_median() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for n in [10, 11, 64, 1001] {
            // Values closer together than one f32 step, exact ties, and a far cluster.
            let v: Vec<f64> = (0..n)
                .map(|i| {
                    let far = if i % 7 == 0 { 1.0 } else { 0.0 };
                    1.0 + f64::from(rng.gen_range(0..50u32)) * 1e-12 + far
                })
                .collect();
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            assert_eq!(super::median_of(n, |l| v[l]), sorted[n / 2], "n = {n}");
        }
    }
}
