//! The fit stage: the planned start ([`super::start`]), the linear path (solve → closed form
//! → extraction, then refinement when asked or after a subset) or the nominal path, the
//! robust reweighting, and the canonical one of the mirrored equivalent solutions. Gives a
//! [`FitOutcome`]: the estimate, its covariance and the fit's warnings in order.

use super::covariance::sandwich_std;
use super::estimate::RobustFit;
use super::prior::{self, PriorChoice, PriorReport, PriorScale};
use super::residuals::residual_scale;
use super::residuals::tip_statistics;
use super::reweight::{linear_solve, robust_refit};
use super::start::{plan_start, speculate_nominal, Plan};
use super::{CalibrateOptions, StartChoice};
use crate::data::Poses;
use crate::error::{Error, ErrorClass, Result};
use crate::fit::extract::extract_from;
use crate::fit::start::DataStart;
use crate::model::CalibModel;
use crate::numeric::robust::Robust;
use crate::spec::Spec;

/// What the fit stage found: the estimate and its statistics, where it started and how it
/// went on, the linear solution when there was one, and the warnings of the fit, in the
/// order they arose.
pub(super) struct FitOutcome {
    /// The estimated parameters (model order).
    pub(super) p: Vec<f64>,
    /// Their standard deviations (`None` for held ones).
    pub(super) std: Vec<Option<f64>>,
    /// `linear` or `nominal` ([`Estimate::start`]).
    pub(super) start: &'static str,
    /// [`Estimate::method`].
    pub(super) method: String,
    /// [`Estimate::rank`]: the linear data matrix's, or the Jacobian's from the nominals.
    pub(super) rank: usize,
    /// Condition number of the last fit.
    pub(super) condition: f64,
    /// Covariance of the free parameters (with their indices), when known.
    pub(super) covariance: Option<(Vec<usize>, nalgebra::DMatrix<f64>)>,
    /// The linear generalized parameters, from a linear start.
    pub(super) lin_c: Option<Vec<f64>>,
    /// Poses the linear method was tried on (0 for a planned nominal start).
    pub(super) linear_poses: usize,
    /// What the reweighted linear solve did (`--robust` and a linear start).
    pub(super) reweighted: Option<crate::fit::solve::LinearReweighting>,
    /// What the robust fit did (`--robust`).
    pub(super) robust: Option<RobustFit>,
    /// Warnings of the fit, in order.
    pub(super) warnings: Vec<String>,
    /// What the weak-direction prior did ([`super::prior`]).
    pub(super) prior: PriorReport,
    /// `K` for the report, when known ([`CalibModel::basis_size_for_report`]).
    pub(super) basis_size: Option<usize>,
}

/// The fit stage: the planned start (linear, on every pose or a subset, or the nominals;
/// [`plan_start`]), the path from it, then with `--robust` the reweighting. After a start
/// from the nominals, `K` for the report is learnt on the other core while the fit runs
/// ([`CalibModel::basis_size_for_report`]). `prior_plan`: the prior's plan when made
/// already ([`prior::plan`] on `model`), else it is made here.
pub(super) fn fit_stage(
    model: &dyn CalibModel,
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    prior_plan: Option<&prior::PriorPlan>,
) -> Result<FitOutcome> {
    // Unknown constraints start from the nominal arm's tips, not from the spec's guesses.
    let started = DataStart::new(model, poses);
    if speculate_nominal(&started, poses, opts.start) {
        #[cfg(test)]
        SPECULATED.with(|n| n.set(n.get() + 1));
        // The fit from the nominals first, the start decided after it: when `K` rules the
        // linear method out (the usual case at few poses), that fit is the one chosen, with
        // the same inputs, and nothing was spent proving `K` large.
        let fit = fit_from(&started, poses, opts, spec, Plan::Nominal(None), prior_plan);
        // Waiting for `K` here (the report needs it anyway) lets the plan read it, not prove
        // it. (Read before the plan, `K` for the report is the build ahead's: should that
        // build fail within the report's bound where the model's own bound, larger, would
        // succeed, the report says "beyond" where a plan made first could have built it.)
        let basis_size = started.basis_size_for_report();
        match plan_start(&started, poses, opts.start)? {
            Plan::Nominal(note) => {
                // A note from the plan comes first, as `fit_from` would have put it.
                return fit.map(|mut f| {
                    if let Some(note) = note {
                        f.warnings.insert(0, note);
                    }
                    FitOutcome { basis_size, ..f }
                });
            }
            plan => return planned_fit_stage(&started, poses, opts, spec, plan, prior_plan),
        }
    }
    let plan = plan_start(&started, poses, opts.start)?;
    planned_fit_stage(&started, poses, opts, spec, plan, prior_plan)
}

#[cfg(test)]
thread_local! {
    /// Tests only: how many fits on this thread planned their start after a fit from the
    /// nominals ([`speculate_nominal`]).
    pub(super) static SPECULATED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// [`fit_stage`] once its start is planned.
fn planned_fit_stage(
    started: &DataStart<'_>,
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    plan: Plan,
    prior_plan: Option<&prior::PriorPlan>,
) -> Result<FitOutcome> {
    if let Plan::Nominal(_) = plan {
        // A plain spawn: this helper mostly waits for the build ahead, which may hold the
        // other core (a helper moved there would keep the fit waiting for it).
        std::thread::scope(|s| {
            let k = s.spawn(|| started.basis_size_for_report());
            let fit = fit_from(started, poses, opts, spec, plan, prior_plan);
            let k = k.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
            fit.map(|f| FitOutcome { basis_size: k, ..f })
        })
    } else {
        let fit = fit_from(started, poses, opts, spec, plan, prior_plan)?;
        Ok(FitOutcome {
            basis_size: Some(started.basis_size()),
            ..fit
        })
    }
}

/// [`fit_stage`] from its plan.
fn fit_from(
    started: &DataStart<'_>,
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
    plan: Plan,
    prior_plan: Option<&prior::PriorPlan>,
) -> Result<FitOutcome> {
    let model: &dyn CalibModel = started;
    let mut warnings = Vec::new();
    let (linear, linear_poses) = match plan {
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
        Plan::Nominal(note) => {
            warnings.extend(note);
            (None, 0)
        }
    };
    let plan = match prior_plan {
        Some(made) => made.clone(),
        None => prior::plan(model, spec, opts.prior),
    };
    let mut with_prior = !plan.arm().is_empty();
    let mut fit = match linear {
        Some(start) => linear_path(model, poses, start, opts.refine, linear_poses, warnings)?,
        None => nominal_path(model, poses, linear_poses, warnings, with_prior)?,
    };
    // The prior joins every geometric fit it is on (no per-parameter switch: it acts on
    // each direction in proportion to what the data leave unknown there), its rows scaled
    // by the unregularised fit's noise level. The paper's linear estimate alone (no
    // `--refine`) is the linear method's answer and stays, unless it leaves an arm
    // parameter less certain than its prior (the drawing's tolerance by default): then the
    // fit goes on geometrically, with the prior (a prior needs the geometric fit).
    let noise = |p: &[f64]| prior_noise(started, poses, p, opts.robust);
    let linear_alone = fit.start == "linear" && !opts.refine && fit.linear_poses == poses.len();
    // A relative prior's tolerances `σ̂/√(N·w)` are reported even where it is not applied.
    let relative = match opts.prior {
        PriorChoice::On {
            scale: PriorScale::Weight(_),
            ..
        } if with_prior => Some(noise(&fit.p)),
        _ => None,
    };
    if linear_alone && with_prior {
        let factor = match opts.prior {
            PriorChoice::On {
                scale: s @ PriorScale::Weight(_),
                ..
            } => s.tolerances(relative.unwrap_or(f64::NAN), poses.len()).0,
            PriorChoice::On {
                scale: PriorScale::Auto,
                ..
            } => prior::UNSEEN_TOLERANCE,
            _ => 1.0,
        };
        let tol: Vec<Option<f64>> = plan.tol.iter().map(|t| t.map(|t| t * factor)).collect();
        with_prior &= !prior::weak_params(&tol, &fit.std).is_empty();
    }
    let sigma = with_prior.then(|| relative.unwrap_or_else(|| noise(&fit.p)));
    fit.prior = prior::not_applied(opts.prior, sigma.or(relative), poses.len());
    let prior_model = match sigma {
        Some(sigma) => prior_fit(started, poses, &plan, opts.prior, sigma, &mut fit)?,
        None => None,
    };
    let model: &dyn CalibModel = match &prior_model {
        Some(m) => m,
        None => model,
    };
    if let Some(loss) = opts.robust {
        robust_reweighting(model, poses, opts.refine, loss, &mut fit)?;
    }
    Ok(fit)
}

/// The noise level that scales the prior's rows at `p`: the residual level; with a robust
/// loss, the robust scale at the robust fit without the prior (when lower). The outliers
/// the robust fit is about to downweight must not set the prior's strength: one joint
/// reading off by 0.5 rad among 120 tracker poses made the level 3.6·10⁻² m where the noise
/// is 5·10⁻⁵, a prior 700 times too strong, and the least-squares fit they pull leaves the
/// other poses' median residual several times the noise too.
fn prior_noise(model: &dyn CalibModel, poses: &Poses, p: &[f64], robust: Option<Robust>) -> f64 {
    let free = (0..model.param_count())
        .filter(|&j| !model.param_held(j))
        .count();
    let level = prior::noise_level(model, poses, p, free);
    let Some(loss) = robust else {
        return level;
    };
    let at = match super::reweight::robust_refit(model, poses, p, loss) {
        Ok((Some(r), _)) => r.p,
        _ => p.to_vec(),
    };
    let (scale, _) = super::residuals::residual_scale(model, poses, &at);
    if scale.is_finite() && scale > 0.0 {
        scale.max(1e-9).min(level)
    } else {
        level
    }
}

/// A prior whose fit leaves the data's residual level more than this many times the
/// unregularised fit's is named in a warning (a strength set by hand, tighter than the arm).
const PRIOR_PULL: f64 = 2.0;

/// The fit again from `fit`'s estimate with the prior of `plan` and `choice`
/// ([`super::prior`]), its rows scaled by the noise level `sigma`; `fit` takes it (and its
/// report), and the model with the prior is returned for the robust reweighting. When that
/// fit fails and the first one has statistics, the first stays (with a warning) and `None`
/// is returned; an error when even the prior leaves the Jacobian singular.
fn prior_fit<'a>(
    started: &DataStart<'a>,
    poses: &Poses,
    plan: &prior::PriorPlan,
    choice: PriorChoice,
    sigma: f64,
    fit: &mut FitOutcome,
) -> Result<Option<DataStart<'a>>> {
    let PriorChoice::On { scale, .. } = choice else {
        return Ok(None);
    };
    let root = prior::given_root(plan, scale, sigma, poses.len());
    // Where the prior mattered most: the parameters the data alone left less certain.
    let weak = prior::weak_params(
        &prior::prior_std(started.param_count(), plan, &root),
        &fit.std,
    );
    let mut model = prior::model_with(started, plan, &root, sigma);
    let mut best = map_fit(started, &model, poses, plan, &fit.p);
    // The data's choice, linearised at the fit with the drawing's tolerance (near where the
    // chosen fit ends; the unregularised one may have run far along a weak direction).
    let mut selection = None;
    if let (PriorScale::Auto, Ok(at)) = (scale, &best) {
        if let Some(chosen) = prior::data_choice(started, poses, plan, &at.p, sigma)? {
            if !chosen.drawing {
                let m = prior::model_with(started, plan, &chosen.root, sigma);
                if let Ok(r) = crate::fit::geometric::fit(&m, poses, &at.p) {
                    best = Ok(r);
                    model = m;
                    selection = Some(chosen.selection);
                }
            } else {
                selection = Some(chosen.selection);
            }
        }
    }
    let r = match best {
        Ok(r) => r,
        // A first fit with its own statistics stays, with the reason the prior could not
        // join; one without (a singular end) has nothing to fall back on.
        Err(e) if fit.covariance.is_some() || fit.std.iter().any(Option::is_some) => {
            fit.warnings.push(format!(
                "the fit with the weak-direction prior failed ({e}); the fit without it is \
                 reported"
            ));
            return Ok(None);
        }
        Err(e) => return Err(e),
    };
    if r.covariance.is_none() {
        return Err(Error::degenerate(format!(
            "the fit ends where the poses do not determine every free parameter, even with the \
             prior on the arm's parameters (Jacobian rank {} of {}): add poses that move every \
             joint, or hold more parameters (`known: true`)",
            r.rank,
            r.free.len()
        )));
    }
    fit.p = r.p;
    fit.std = r.std;
    fit.condition = r.condition;
    fit.covariance = r.covariance.map(|c| (r.free, c));
    // A strength the user set can hold the arm far from what the data say: the data's own
    // residual level at the estimate, against the unregularised fit's.
    if !matches!(scale, PriorScale::Auto) {
        let free = (0..started.param_count())
            .filter(|&j| !started.param_held(j))
            .count();
        let level = prior::noise_level(started, poses, &fit.p, free);
        if level > PRIOR_PULL * sigma {
            fit.warnings.push(format!(
                "the prior holds the fit {:.1}× beyond the data's own residual level ({level:.3e} \
                 against {sigma:.3e} without it): its tolerances are tighter than the arm's \
                 errors; loosen --tolerance-length/--tolerance-angle or --prior-weight, or leave \
                 the strength to the data (the default)",
                level / sigma
            ));
        }
    }
    if fit.method == "linear" {
        fit.method = "linear+refine".to_string();
    }
    fit.prior.applied = true;
    fit.prior.sigma = Some(sigma);
    fit.prior.selection = selection;
    if let Some(sel) = &fit.prior.selection {
        // The tolerance the data chose, as the report's tolerances, when it is one scale.
        fit.prior.length_tolerance = sel.tolerance;
        fit.prior.angle_tolerance = sel.tolerance;
    }
    fit.prior.weak = weak
        .iter()
        .map(|&j| started.param_name(j).to_string())
        .collect();
    Ok(Some(model))
}

/// The most poses for which [`map_fit`] runs its two fits side by side: there it saves a
/// fit's time on a cold start (1-2 ms of the bench's 10-20 ms). From 4 096 poses each fit
/// spreads its passes over every core already (`fit::geometric::passes`), and on a million
/// poses the second fit's per-pose buffers cost 4 MB of peak memory (98 → 102 MB, past
/// `bench/resource.sh`'s 100 MB bound).
const MAP_SIDE_BY_SIDE_POSES: usize = 4_095;

/// The maximum a posteriori fit with the prior rows of `model`: from `from` (the
/// unregularised estimate) and from the same with the arm back at its nominals (that estimate
/// may have run far along the weak directions, into another basin of the prior's cost), the
/// lower cost kept. The two fits are independent: side by side when a core is free
/// ([`crate::cores`]) and the data set is small ([`MAP_SIDE_BY_SIDE_POSES`]), the result the
/// same either way.
fn map_fit(
    started: &DataStart<'_>,
    model: &DataStart<'_>,
    poses: &Poses,
    plan: &prior::PriorPlan,
    from: &[f64],
) -> Result<crate::fit::geometric::GeometricEstimate> {
    let mut back = from.to_vec();
    for &j in plan.arm() {
        back[j] = started.param_nominal(j);
    }
    // Only the fit kept pays for its covariance.
    let fit = |start: &[f64]| crate::fit::geometric::converged(model, poses, start, None);
    let (first, second) = if crate::cores::free() > 1 && poses.len() <= MAP_SIDE_BY_SIDE_POSES {
        crate::cores::join(|| fit(from), || fit(&back))
    } else {
        (fit(from), fit(&back))
    };
    match (first, second) {
        (Ok(a), Ok(b)) => (if b.cost < a.cost { b } else { a }).finish(),
        (Ok(a), Err(_)) | (Err(_), Ok(a)) => a.finish(),
        (Err(e), Err(_)) => Err(e),
    }
}

/// A linear start: the solve, its extraction, what the reweighting did (with `--robust`),
/// and whether it ran on a subset of the poses.
pub(super) struct LinearStart {
    lin: crate::fit::solve::LinearSolve,
    ext: crate::fit::extract::Extraction,
    reweighted: Option<crate::fit::solve::LinearReweighting>,
    subset: bool,
}

/// The linear method on `use_poses` (all of them, or the subset when `subset`): solve, then
/// extract (from the paper's closed form where it applies). With [`StartChoice::Auto`], a
/// degenerate failure is a warning and `None` (the fit starts from the nominals).
pub(super) fn linear_start(
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
pub(super) fn linear_path(
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
        prior: prior::not_applied(PriorChoice::Off, None, 0),
        basis_size: None,
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
pub(super) fn linear_warnings(
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
pub(super) fn refine_linear(
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
pub(super) fn nominal_path(
    model: &dyn CalibModel,
    poses: &Poses,
    linear_poses: usize,
    warnings: Vec<String>,
    with_prior: bool,
) -> Result<FitOutcome> {
    let (r, _tried) = crate::fit::geometric::fit_from_nominal(model, poses)?;
    // With a prior to come, a singular end is left to it (its weak parameters have no std).
    if r.covariance.is_none() && !with_prior {
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
        // The contract names two methods; `start` says this one began at the nominals.
        method: "linear+refine".to_string(),
        rank: r.rank,
        condition: r.condition,
        covariance: r.covariance.map(|c| (r.free, c)),
        lin_c: None,
        linear_poses,
        reweighted: None,
        robust: None,
        warnings,
        prior: prior::not_applied(PriorChoice::Off, None, 0),
        basis_size: None,
    })
}

/// Equivalent solutions (mirrored links) nearest the nominals, always; free angles wrapped
/// into (−π, π] (fits may leave them outside).
pub(super) fn canonical_form(model: &dyn CalibModel, poses: &Poses, p: &mut [f64]) {
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
