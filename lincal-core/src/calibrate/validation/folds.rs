//! k-fold cross-validation over the poses of one run (see the parent module's docs).

use super::{residual_sums, Groups};
use crate::calibrate::grouping::{self, Grouping};
use crate::calibrate::{with_outliers, CalibrateOptions, SpecParam};
use crate::data::Poses;
use crate::error::{Error, ErrorClass, Location, Result};
use crate::fit::start::DataStart;
use crate::model::CalibModel;
use crate::spec::Spec;

/// One fold: fitted on the other folds, judged on this one.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Fold {
    /// 0-based fold index.
    pub fold: usize,
    /// Poses fitted (the other folds).
    pub train_poses: usize,
    /// Poses held out (this fold).
    pub test_poses: usize,
    /// Held-out poses not scored: on a constraint no training pose was on, whose values
    /// refitted to them fit them exactly whatever the parameters (one pose at a point).
    #[serde(skip_serializing_if = "is_zero")]
    pub unscored_poses: usize,
    /// The training fit's `residual_rms`, metres.
    pub residual_rms_train: f64,
    /// RMS residual of the held-out poses from the training fit's constraints, metres.
    pub residual_rms_test: f64,
    /// Largest held-out residual, metres.
    pub max_residual_test: f64,
}

/// One constraint's held-out residual, pooled over the folds.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConstraintHeldOut {
    /// Index in the constraint list.
    pub constraint: usize,
    /// The interface's kind name.
    pub kind: &'static str,
    /// Poses scored (each held out once).
    pub poses: usize,
    /// Poses held out but not scored ([`Fold::unscored_poses`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub unscored_poses: usize,
    /// RMS held-out residual over its poses, metres.
    pub residual_rms_held_out: f64,
}

/// The result of [`cross_validate`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CrossValidation {
    /// The folds used (fitted): `folds_asked`, or fewer when the poses hold fewer groups or
    /// a fold's fit is undeterminable (a warning says so).
    pub folds: usize,
    /// `k`, the folds asked for (`--folds`).
    pub folds_asked: usize,
    /// How the poses were split ([`crate::calibrate::grouping`]): `placements` (a fit never
    /// sees the placement it is judged on; as many folds as placements when they are fewer
    /// than asked) or `joint-space clusters` (one placement, or placements whose folds could
    /// not be fitted: `split_note` says why): the prior's strength choice groups the same way.
    pub split: &'static str,
    /// Why the split is not by placements although the poses lie on several: a fold by
    /// placements could not be fitted (most often the placement held out holds what fixes the
    /// arm's size, a relation's distance or offset), so the folds are clusters instead.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_note: Option<String>,
    /// The fit on every pose: its `residual_rms` (in-sample), metres.
    pub residual_rms_in_sample: f64,
    /// The mean over the folds of the training fits' `residual_rms`, metres.
    pub residual_rms_train_mean: f64,
    /// The mean over the folds of `residual_rms_test`, metres.
    pub residual_rms_held_out_mean: f64,
    /// RMS held-out residual over every pose (each held out once), metres.
    pub residual_rms_held_out: f64,
    /// Per constraint, pooled over the folds.
    pub constraints: Vec<ConstraintHeldOut>,
    /// Each fold fitted.
    pub per_fold: Vec<Fold>,
    /// The folds whose fit could not determine the parameters, left out of every figure.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<SkippedFold>,
    /// What the figures leave out or changed from what was asked (fewer folds than asked),
    /// each naming the option or the fold: the caller shows them with the run's warnings.
    #[serde(skip)]
    pub warnings: Vec<String>,
}

/// The most work `--folds` may ask for, in units of `poses × parameters²` per fold plus
/// [`FOLD_OVERHEAD`] (each fold is a whole fit: its Gauss-Newton passes cost about
/// `N·P²`, its start, prior choice and report a fixed share). Measured: about 1.5·10⁻⁸ s a
/// unit here, so the bound is about two minutes on this machine (a 9-joint arm, 40
/// parameters, 2 000 poses: 45 ms a fold; a PUMA, 27 parameters, 10⁶ poses: 37 s).
pub const MAX_FOLD_WORK: u64 = 8_000_000_000;

/// A fold's fixed share of work (its start, prior choice and report), in the units of
/// [`MAX_FOLD_WORK`]: about 15 ms.
pub const FOLD_OVERHEAD: u64 = 1_000_000;

/// The work of `k` folds of `poses` poses and `params` parameters, in the units of
/// `MAX_FOLD_WORK`: `k × (poses × params² + FOLD_OVERHEAD)` (a million is about 15 ms).
#[must_use]
pub fn fold_work(k: usize, poses: usize, params: usize) -> u64 {
    let per_fold = (poses as u64)
        .saturating_mul((params as u64).saturating_mul(params as u64))
        .saturating_add(FOLD_OVERHEAD);
    (k as u64).saturating_mul(per_fold)
}

/// Checks `k`: at least 2, at most the number of poses, and the folds' work
/// `k × (poses × params² + FOLD_OVERHEAD)` within `MAX_FOLD_WORK` (error naming `--folds`,
/// exit 2).
///
/// # Errors
/// [`crate::error::ErrorClass::Input`] otherwise.
pub fn check_folds(k: usize, poses: usize, params: usize) -> Result<()> {
    let field = || Location {
        field: Some("--folds".to_string()),
        ..Location::default()
    };
    if k < 2 {
        return Err(Error::input(
            field(),
            format!("{k} fold(s): cross-validation needs at least 2"),
        ));
    }
    if k > poses {
        return Err(Error::input(
            field(),
            format!("{k} folds for {poses} poses: at most one fold per pose"),
        ));
    }
    let work = fold_work(k, poses, params);
    if work > MAX_FOLD_WORK {
        return Err(Error::input(
            field(),
            format!(
                "{k} folds of {poses} poses and {params} parameters are {work:.2e} units of work \
                 (folds × (poses × parameters² + {FOLD_OVERHEAD:.0e})), more than \
                 {MAX_FOLD_WORK:.0e} (about two minutes here): each fold is a whole fit; use at \
                 most {} folds (10 is the usual choice)",
                (MAX_FOLD_WORK / fold_work(1, poses, params)).max(2)
            ),
        ));
    }
    Ok(())
}

/// k-fold cross-validation of `calibrate` with `opts` over `poses` (see the module docs);
/// `in_sample` is the residual RMS of the fit on every pose, reported beside. A fold whose
/// training fit cannot determine the parameters is skipped, with a warning naming it; fewer
/// folds than `k` (fewer placements or distinct poses) are warned about, naming `--folds`.
///
/// # Errors
/// [`crate::error::ErrorClass::Input`] for `k < 2` or more folds than poses; a fold's fit
/// failing otherwise than undeterminable, or no fold's fit, with the fold named.
pub fn cross_validate(
    model: &dyn CalibModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
    k: usize,
    in_sample: f64,
) -> Result<CrossValidation> {
    check_folds(k, poses.len(), model.param_count())?;
    let folds = grouping::folds(model, poses, k);
    let run = |folds, skip| run_folds(model, spec, poses, opts, folds, (in_sample, k), skip);
    if folds.grouping != Grouping::Placements {
        return run(folds, true);
    }
    // By placements, every fold must fit: a placement that cannot be left out (it holds what
    // fixes the arm's size) makes the split clusters, whose folds are skipped one by one.
    match run(folds, false) {
        Err(e) if e.class() == ErrorClass::Degenerate => {
            let mut cv = run(grouping::clusters(model, poses, k), true)?;
            // The fold's first reason is the one that matters; the advice after it is for a
            // whole calibration, not for this split.
            let why = e.to_string();
            let why = why.split("; ").next().unwrap_or(&why).to_string();
            cv.split_note = Some(format!(
                "not by placements: a fold by placements could not be fitted ({why})"
            ));
            Ok(cv)
        }
        other => other,
    }
}

/// A fold whose placements left out pinned what the others cannot (the arm's scale, held by
/// a relation or a known point among them): its fit would hold more of the arm at the
/// nominals than the whole calibration does, and judge that model, not the calibration's.
/// The error names what it would hold.
fn undetermined(
    model: &dyn CalibModel,
    fold_model: &dyn CalibModel,
    unseen: &[bool],
) -> Option<Error> {
    let held = crate::calibrate::warnings::newly_held(model, fold_model, unseen);
    (!held.is_empty()).then(|| {
        let names: Vec<&str> = held.iter().map(|&j| model.param_name(j)).collect();
        Error::degenerate(format!(
            "without the placement(s) held out, the other poses do not determine {} (the whole \
             data do)",
            names.join(", ")
        ))
    })
}

/// One fold left out of the figures: its training fit could not determine the parameters.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkippedFold {
    /// 0-based fold index.
    pub fold: usize,
    /// Poses the fit was given (the other folds).
    pub train_poses: usize,
    /// Poses held out, not scored.
    pub test_poses: usize,
    /// Why the fit failed.
    pub reason: String,
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The held-out sums pooled over the folds fitted, per constraint.
struct Pooled {
    d2: Vec<f64>,
    n: Vec<usize>,
    unscored: Vec<usize>,
    per_fold: Vec<Fold>,
}

impl Pooled {
    /// Adds fold `f`'s held-out sums per constraint (`held`) and its fit.
    fn add(&mut self, f: usize, (train, test): (usize, usize), rms_train: f64, held: &[Held]) {
        let (mut d2, mut n, mut max, mut unscored) = (0.0, 0, 0.0f64, 0);
        for (j, h) in held.iter().enumerate() {
            self.d2[j] += h.d2;
            self.n[j] += h.n;
            self.unscored[j] += h.unscored;
            d2 += h.d2;
            n += h.n;
            max = max.max(h.max);
            unscored += h.unscored;
        }
        self.per_fold.push(Fold {
            fold: f,
            train_poses: train,
            test_poses: test,
            unscored_poses: unscored,
            residual_rms_train: rms_train,
            residual_rms_test: rms(d2, n),
            max_residual_test: if n == 0 { f64::NAN } else { max },
        });
    }
}

/// [`cross_validate`] over the given folds, `k` asked; a fold whose fit is undeterminable
/// skipped when `skip`, else the error (naming the fold).
fn run_folds(
    model: &dyn CalibModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
    folds: grouping::Folds,
    (in_sample, asked): (f64, usize),
    skip: bool,
) -> Result<CrossValidation> {
    let params = SpecParam::list(spec);
    let (fold, k) = (folds.fold, folds.folds);
    let nc = model.constraint_count();
    let mut pooled = Pooled {
        d2: vec![0.0; nc],
        n: vec![0; nc],
        unscored: vec![0; nc],
        per_fold: Vec::with_capacity(k),
    };
    let mut skipped = Vec::new();
    for f in 0..k {
        let train: Vec<usize> = (0..poses.len()).filter(|&l| fold[l] != f).collect();
        let test: Vec<usize> = (0..poses.len()).filter(|&l| fold[l] == f).collect();
        // A placement the fit does not see: its own values held and its relations left out
        // in the fit (its poses are all held out), then refitted on its poses (the
        // fixture's point or plane is no property of the arm).
        let unseen: Vec<bool> = (0..nc)
            .map(|j| !train.iter().any(|&l| poses.constraint.at(l) == j))
            .collect();
        let fold_model = DataStart::plain(model).without_constraints(&unseen);
        let fitted = match undetermined(model, &fold_model, &unseen) {
            Some(e) => Err(e),
            None => fold_fit(&fold_model, spec, &params, &poses.select(&train), opts),
        };
        let p = match fitted {
            Ok(p) => p,
            Err(e) if skip && e.class() == ErrorClass::Degenerate => {
                skipped.push(SkippedFold {
                    fold: f,
                    train_poses: train.len(),
                    test_poses: test.len(),
                    reason: e.to_string(),
                });
                continue;
            }
            Err(e) => return Err(fold_error(&e, f, k, train.len())),
        };
        let held = held_out(model, &poses.select(&test), &p.0, &unseen);
        pooled.add(f, (train.len(), test.len()), p.1, &held);
    }
    if pooled.per_fold.is_empty() {
        let first = skipped
            .first()
            .map_or_else(String::new, |s| s.reason.clone());
        return Err(Error::degenerate(format!(
            "cross-validation: no fold of {k} could be fitted (fold 0, on {} poses: {first}); \
             ask for fewer folds (--folds), or give more poses",
            skipped.first().map_or(0, |s| s.train_poses)
        )));
    }
    let mut cv = summary(model, pooled, folds.grouping, in_sample);
    cv.folds_asked = asked;
    cv.warnings = fold_warnings(&cv, k, poses.len(), &skipped);
    cv.skipped = skipped;
    Ok(cv)
}

/// The figures pooled over the folds fitted.
fn summary(
    model: &dyn CalibModel,
    pooled: Pooled,
    grouping: Grouping,
    in_sample: f64,
) -> CrossValidation {
    let Pooled {
        d2,
        n,
        unscored,
        per_fold,
    } = pooled;
    let used = per_fold.len();
    let mean = |v: &dyn Fn(&Fold) -> f64| per_fold.iter().map(v).sum::<f64>() / used as f64;
    // The held-out mean over the folds with a pose scored (a fold of unscored poses has none).
    let scored: Vec<f64> = per_fold
        .iter()
        .map(|f| f.residual_rms_test)
        .filter(|v| v.is_finite())
        .collect();
    let held_out_mean = if scored.is_empty() {
        f64::NAN
    } else {
        scored.iter().sum::<f64>() / scored.len() as f64
    };
    CrossValidation {
        folds: used,
        folds_asked: used,
        split: grouping.name(),
        split_note: None,
        residual_rms_in_sample: in_sample,
        residual_rms_train_mean: mean(&|f| f.residual_rms_train),
        residual_rms_held_out_mean: held_out_mean,
        residual_rms_held_out: rms(d2.iter().sum(), n.iter().sum()),
        constraints: (0..d2.len())
            .map(|j| ConstraintHeldOut {
                constraint: j,
                kind: model.constraint_kind(j).name(),
                poses: n[j],
                unscored_poses: unscored[j],
                residual_rms_held_out: rms(d2[j], n[j]),
            })
            .collect(),
        per_fold,
        skipped: Vec::new(),
        warnings: Vec::new(),
    }
}

/// The warnings of a cross-validation over `made` folds (of `cv.folds_asked` asked) of
/// `poses`, `skipped` left out: each names `--folds` or the fold.
fn fold_warnings(
    cv: &CrossValidation,
    made: usize,
    poses: usize,
    skipped: &[SkippedFold],
) -> Vec<String> {
    let asked = cv.folds_asked;
    let mut out = Vec::new();
    if made < asked {
        let why = if cv.split == Grouping::Placements.name() {
            format!("the poses lie on {made} placements, and a fold holds out whole placements")
        } else {
            format!(
                "the {poses} poses form only {made} separate clusters in joint space (fewer \
                 distinct poses than folds)"
            )
        };
        out.push(format!(
            "--folds {asked}: cross-validation used {made} folds, not {asked}: {why}"
        ));
    }
    for c in cv.constraints.iter().filter(|c| c.unscored_poses > 0) {
        let count = c.unscored_poses;
        out.push(format!(
            "cross-validation: constraint {} ({}): {count} held-out pose{} not scored: no fold's \
             fit saw this constraint when {} held out, and its unknown values refitted to {} \
             fit {} exactly whatever the parameters; give this constraint more poses than its \
             unknown values need, or make them known",
            c.constraint,
            c.kind,
            if count == 1 { "" } else { "s" },
            if count == 1 { "it was" } else { "they were" },
            if count == 1 { "it" } else { "them" },
            if count == 1 { "it" } else { "them" },
        ));
    }
    for s in skipped {
        // The first reason; the advice after it is for a whole calibration.
        let why = s.reason.split("; ").next().unwrap_or(&s.reason);
        out.push(format!(
            "cross-validation: fold {} of {made} skipped: its fit on {} poses is undeterminable \
             ({why}); its {} held-out poses are not scored, and the figures are over the {} \
             folds fitted",
            s.fold, s.train_poses, s.test_poses, cv.folds
        ));
    }
    out
}

/// Fold `f` of `k`'s fit on its training poses: the estimated parameters (the known ones
/// left out, model order) and the fit's `residual_rms`.
fn fold_fit(
    model: &dyn CalibModel,
    spec: &Spec,
    params: &[SpecParam],
    train: &Poses,
    opts: CalibrateOptions,
) -> Result<(Vec<f64>, f64)> {
    let est = with_outliers(
        model,
        params,
        train,
        opts,
        Some(spec),
        &crate::progress::NoProgress,
    )?;
    let p = est
        .params
        .iter()
        .filter(|x| !x.known)
        .map(|x| x.value)
        .collect();
    Ok((p, est.residual_rms))
}

/// `e`, a fold's fit failing, with the fold named.
fn fold_error(e: &Error, f: usize, k: usize, train: usize) -> Error {
    Error::new(
        e.class(),
        Location::default(),
        format!("cross-validation, fold {f} of {k} (fitted on {train} poses): {e}"),
    )
}

/// One constraint's held-out poses in one fold: `Σ ‖g_l‖²`, the count and the largest
/// `‖g_l‖` of those scored, and the count of those not scored ([`held_out`]).
struct Held {
    d2: f64,
    n: usize,
    max: f64,
    unscored: usize,
}

fn rms(d2: f64, n: usize) -> f64 {
    if n == 0 {
        f64::NAN
    } else {
        (d2 / n as f64).sqrt()
    }
}

/// Per constraint: `Σ ‖g_l‖²`, the count and the largest `‖g_l‖` of `poses` from the
/// constraints at `p`, refitted to those poses where `unseen` (a placement the fit had no
/// pose on; [`super::refit_values`]), as they are otherwise; and the poses not scored: those
/// of an unseen constraint whose refitted values fit them exactly whatever the parameters
/// (one pose at a point, two on a planar line: [`super::refit::residual_dof`] 0), whose
/// residual of 0 would say nothing.
fn held_out(model: &dyn CalibModel, poses: &Poses, p: &[f64], unseen: &[bool]) -> Vec<Held> {
    let dim = model.dim();
    let groups = Groups::new(model, poses);
    (0..model.constraint_count())
        .map(|j| {
            let kind = model.constraint_kind(j);
            let measured = &groups.measured[j];
            let mut values = vec![0.0; kind.value_count(dim)];
            model.constraint_values(j, p, &mut values);
            let tips = groups.tips(model, poses, j, p);
            if unseen.get(j).copied().unwrap_or(false) {
                let free = super::refitted_values(model, j);
                values = super::refit_values(kind, dim, &values, &free, &tips, measured);
                let slot_param: Vec<Option<usize>> = (0..values.len())
                    .map(|v| model.constraint_value_param(j, v))
                    .collect();
                let dof = super::refit::residual_dof(
                    kind,
                    dim,
                    &values,
                    &free,
                    &slot_param,
                    &tips,
                    measured,
                );
                if dof == 0 && free.iter().any(|&f| f) {
                    let (_, n, _) = residual_sums(kind, dim, &values, &tips, measured);
                    return Held {
                        d2: 0.0,
                        n: 0,
                        max: 0.0,
                        unscored: n,
                    };
                }
            }
            let (d2, n, max) = residual_sums(kind, dim, &values, &tips, measured);
            Held {
                d2,
                n,
                max,
                unscored: 0,
            }
        })
        .collect()
}

#[cfg(test)]
mod bound_tests {
    use super::*;

    #[test]
    fn fold_counts_are_bounded_by_the_poses_and_the_work() {
        assert!(check_folds(1, 10, 4).is_err());
        assert!(check_folds(10, 10, 4).is_ok());
        assert!(check_folds(11, 10, 4).is_err());
        // Leave-one-out of 12 000 poses of a PUMA (27 parameters): refused with the way out.
        let e = check_folds(12_000, 12_000, 27).unwrap_err().to_string();
        assert!(
            e.contains("--folds") && e.contains("at most 820 folds"),
            "{e}"
        );
        assert!(check_folds(800, 12_000, 27).is_ok());
        // The attack's cases: 20 folds of 10⁶ PUMA poses, 2 000 folds of a 9-joint arm's 2 000.
        assert!(check_folds(20, 1_000_000, 27).is_err());
        assert!(check_folds(2_000, 2_000, 40).is_err());
        assert!(check_folds(10, 100_000, 40).is_ok());
    }
}
