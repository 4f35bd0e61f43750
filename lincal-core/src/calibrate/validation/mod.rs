//! Held-out validation: given parameter values judged on poses the fit did not see, nominal
//! beside calibrated, and k-fold cross-validation over the poses of one run.
//!
//! # Held-out data ([`evaluate`])
//! On another placement the fixture has moved, so each constraint's **unknown** values (the
//! values that are an estimated parameter moving no joint: a socket's point, a plane's `b`, a
//! sphere's centre and radius) are refitted to the held-out predicted tips with the arm's
//! parameters fixed ([`refit_values`]); known values (numbers, `known: true` parameters) and
//! values shared with the chain stay as given. Then, per constraint `j` with poses `L_j`
//! (`n_j = |L_j|`), for each parameter vector (the nominals, and the given values):
//! - `residual_rms = sqrt(Σ_{l∈L_j} ‖g_l‖² / n_j)` and `max_residual = max ‖g_l‖`, `g_l` the
//!   geometric residual ([`crate::model::geometry::geometric_residual`]) of tip `x_l` from
//!   the refitted constraint;
//! - for a point: the mean tip `x̄_j` and the spread `s_j = sqrt(Σ ‖x_l − x̄_j‖² / n_j)` (for
//!   an unknown point, the refitted point is `x̄_j` and the residual RMS is the spread);
//! - per pair of points `(i, j)`: the distance `‖x̄_i − x̄_j‖` between the means, and where a
//!   `distance` relation holds between them its error `‖x̄_i − x̄_j‖ − d`;
//! - pooled over the points, `sqrt(Σ_j n_j s_j² / Σ_j n_j)`; over every pose the residual RMS.
//!
//! # Cross-validation ([`cross_validate`])
//! The poses are split into at most `k` folds by the rule the prior's strength choice uses
//! ([`crate::calibrate::grouping`]): by placement when they lie on two or more constraints
//! (a fit never sees the placement it is judged on), else by clusters in joint space
//! (interleaved folds are optimistic on clustered data: a fold would be judged on errors its
//! fit has seen). Each fold is held out in turn: the other folds are fitted with the same
//! options, and the held-out poses are judged against that fit's constraint values, refitted
//! to them for a placement the fit did not see (its fixture's point or plane is not a
//! property of the arm).

mod folds;
mod refit;

pub use folds::{
    check_folds, cross_validate, fold_work, ConstraintHeldOut, CrossValidation, Fold, SkippedFold,
};
pub use refit::{refit_values, refitted_values};

use crate::calibrate::constraint_fit::{distance, distance_relation};
use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::geometry::{geometric_residual, ConstraintKind};
use crate::model::CalibModel;

/// One constraint on held-out data, nominal beside calibrated.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConstraintEvaluation {
    /// Index in the constraint list.
    pub constraint: usize,
    /// The interface's kind name (`point`, `plane`, …).
    pub kind: &'static str,
    /// Held-out poses on this constraint.
    pub poses: usize,
    /// The parameters refitted to the held-out tips (the constraint's unknown values).
    pub refitted: Vec<String>,
    /// RMS geometric residual at the nominals, metres.
    pub residual_rms_nominal: f64,
    /// RMS geometric residual at the given parameters, metres.
    pub residual_rms: f64,
    /// Largest residual at the nominals, metres.
    pub max_residual_nominal: f64,
    /// Largest residual at the given parameters, metres.
    pub max_residual: f64,
    /// The residual components left once the refitted values are fitted to the held-out
    /// tips: their count less the rank of their Jacobian over the refitted parameters
    /// (`refit::residual_dof`). 0 when the refitted values fit these tips exactly whatever
    /// the arm's parameters (three poses on a plane, one at a point): the residual is then 0
    /// and says nothing about the parameters.
    pub residual_dof: usize,
    /// Points: RMS distance of the nominal tips from their mean, metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread_nominal: Option<f64>,
    /// Points: the same at the given parameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread: Option<f64>,
    /// Points: the mean nominal tip.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_nominal: Option<Vec<f64>>,
    /// Points: the mean tip at the given parameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean: Option<Vec<f64>>,
    /// The constraint's values fitted at the nominals (canonical order of
    /// [`crate::model::geometry`]).
    pub values_nominal: Vec<f64>,
    /// The constraint's values fitted at the given parameters.
    pub values: Vec<f64>,
}

/// Two point constraints on held-out data: the distance between their mean tips.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointPairEvaluation {
    /// The two constraint indices.
    pub between: [usize; 2],
    /// The stated distance of a `distance` relation between them, metres.
    pub value: Option<f64>,
    /// `‖x̄_i − x̄_j‖` at the nominals, metres.
    pub distance_nominal: f64,
    /// `‖x̄_i − x̄_j‖` at the given parameters, metres.
    pub distance: f64,
    /// `distance_nominal − value`, with a relation.
    pub error_nominal: Option<f64>,
    /// `distance − value`, with a relation.
    pub error: Option<f64>,
}

/// Parameter values judged on held-out poses (see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Evaluation {
    /// The data files (when read from files; set by the caller).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<String>,
    /// Held-out poses.
    pub poses: usize,
    /// RMS residual over every pose at the nominals, metres.
    pub residual_rms_nominal: f64,
    /// RMS residual over every pose at the given parameters, metres.
    pub residual_rms: f64,
    /// Points: `sqrt(Σ_j n_j s_j² / Σ_j n_j)` at the nominals, metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread_pooled_nominal: Option<f64>,
    /// Points: the same at the given parameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread_pooled: Option<f64>,
    /// Each constraint of the list.
    pub constraints: Vec<ConstraintEvaluation>,
    /// Each pair of point constraints.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub point_pairs: Vec<PointPairEvaluation>,
    /// The measured poses' orientation error (`measured_pose`), beside their position error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation: Option<OrientationEvaluation>,
}

/// Held-out measured poses (`measured_pose`): the orientation error `‖log(R_mᵀR)‖` beside the
/// position error, and the two together with the model's orientation weight `w` (metres per
/// radian, the stated noise levels' ratio), `sqrt(Σ (‖e_pos‖² + w²‖e_rot‖²) / n)`: what the
/// fit minimises in-sample.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OrientationEvaluation {
    /// Measured poses with an orientation.
    pub poses: usize,
    /// RMS orientation error at the nominals, radians.
    pub orientation_rms_nominal: f64,
    /// RMS orientation error at the given parameters, radians.
    pub orientation_rms: f64,
    /// Largest orientation error at the nominals, radians.
    pub max_orientation_nominal: f64,
    /// Largest orientation error at the given parameters, radians.
    pub max_orientation: f64,
    /// The orientation weight `w`, metres per radian.
    pub weight: f64,
    /// The weighted pose RMS at the nominals, metres.
    pub pose_rms_nominal: f64,
    /// The weighted pose RMS at the given parameters, metres.
    pub pose_rms: f64,
}

/// The orientation figures of the measured poses at `nominal` and `p`; `None` without any.
fn orientation_evaluation(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    p: &[f64],
    weight: Option<f64>,
) -> Option<OrientationEvaluation> {
    let norms = crate::calibrate::pose_errors::pose_error_norms;
    let ((pos0, ori0), (pos1, ori1)) = (norms(model, poses, nominal), norms(model, poses, p));
    let w = weight.unwrap_or_else(|| model.orientation_weight());
    let (mut n, mut o0, mut o1, mut m0, mut m1, mut q0, mut q1) =
        (0usize, 0.0, 0.0, 0.0f64, 0.0f64, 0.0, 0.0);
    for l in 0..ori1.len() {
        if !(ori0[l].is_finite() && ori1[l].is_finite()) {
            continue;
        }
        n += 1;
        o0 += ori0[l] * ori0[l];
        o1 += ori1[l] * ori1[l];
        m0 = m0.max(ori0[l]);
        m1 = m1.max(ori1[l]);
        q0 += pos0[l] * pos0[l] + w * w * ori0[l] * ori0[l];
        q1 += pos1[l] * pos1[l] + w * w * ori1[l] * ori1[l];
    }
    (n > 0).then(|| OrientationEvaluation {
        poses: n,
        orientation_rms_nominal: rms(o0, n),
        orientation_rms: rms(o1, n),
        max_orientation_nominal: m0,
        max_orientation: m1,
        weight: w,
        pose_rms_nominal: rms(q0, n),
        pose_rms: rms(q1, n),
    })
}

/// One constraint at one parameter vector.
struct Side {
    values: Vec<f64>,
    n: usize,
    /// The residual components left after the refit ([`ConstraintEvaluation::residual_dof`]).
    dof: usize,
    d2: f64,
    max: f64,
    mean: Option<Vec<f64>>,
    spread: Option<f64>,
}

/// The poses of each constraint, and their measured tips.
pub(crate) struct Groups {
    pub(crate) poses: Vec<Vec<usize>>,
    pub(crate) measured: Vec<Vec<Vec<f64>>>,
}

impl Groups {
    pub(crate) fn new(model: &dyn CalibModel, poses: &Poses) -> Groups {
        let nc = model.constraint_count();
        let mut g = vec![Vec::new(); nc];
        let mut m = vec![Vec::new(); nc];
        for l in 0..poses.len() {
            let j = poses.constraint.at(l);
            if j < nc {
                g[j].push(l);
                let row = poses.measured.as_ref().and_then(|r| r.get(l));
                m[j].push(row.map(<[f64]>::to_vec).unwrap_or_default());
            }
        }
        Groups {
            poses: g,
            measured: m,
        }
    }

    /// The tips at `p` of constraint `j`'s poses.
    pub(crate) fn tips(
        &self,
        model: &dyn CalibModel,
        poses: &Poses,
        j: usize,
        p: &[f64],
    ) -> Vec<[f64; 3]> {
        let dim = model.dim();
        self.poses[j]
            .iter()
            .map(|&l| {
                let mut x = [0.0; 3];
                model.tip(&poses.q[l], p, &mut x[..dim]);
                x
            })
            .collect()
    }
}

/// Constraint `j` at `p`: with its unknown values refitted to the tips when `refit`, with
/// the values at `p` otherwise.
fn side(
    model: &dyn CalibModel,
    poses: &Poses,
    groups: &Groups,
    j: usize,
    p: &[f64],
    refit: bool,
) -> Side {
    let dim = model.dim();
    let kind = model.constraint_kind(j);
    let tips = groups.tips(model, poses, j, p);
    let measured = &groups.measured[j];
    let mut values = vec![0.0; kind.value_count(dim)];
    model.constraint_values(j, p, &mut values);
    let free = if refit {
        refitted_values(model, j)
    } else {
        vec![false; values.len()]
    };
    if refit {
        values = refit_values(kind, dim, &values, &free, &tips, measured);
    }
    let slot_param: Vec<Option<usize>> = (0..values.len())
        .map(|v| model.constraint_value_param(j, v))
        .collect();
    let dof = refit::residual_dof(kind, dim, &values, &free, &slot_param, &tips, measured);
    let (d2, n, max) = residual_sums(kind, dim, &values, &tips, measured);
    let (mean, spread) = if kind == ConstraintKind::Point && !tips.is_empty() {
        let (mean, spread) = mean_spread(&tips, dim);
        (Some(mean), Some(spread))
    } else {
        (None, None)
    };
    Side {
        values,
        n,
        dof,
        d2,
        max,
        mean,
        spread,
    }
}

/// `Σ ‖g_l‖²`, the count and the largest `‖g_l‖` of `tips` from the constraint of `kind`
/// with `values` (a measured pose without its measured tip is left out).
pub(crate) fn residual_sums(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    tips: &[[f64; 3]],
    measured: &[Vec<f64>],
) -> (f64, usize, f64) {
    // A measured pose: its position error (the orientation's is not a distance).
    let nr = kind.residual_count(dim).min(3);
    let (mut d2, mut max, mut n) = (0.0, 0.0f64, 0);
    let mut r = [0.0; 3];
    for (l, x) in tips.iter().enumerate() {
        let m = measured.get(l).map_or(&[][..], Vec::as_slice);
        if kind == ConstraintKind::Measured && m.len() < dim {
            continue;
        }
        geometric_residual(kind, dim, values, &x[..dim], m, &mut r[..nr]);
        let e: f64 = r[..nr].iter().map(|a| a * a).sum();
        d2 += e;
        max = max.max(e.sqrt());
        n += 1;
    }
    (d2, n, max)
}

/// The mean of `tips` and their RMS distance from it (about the first tip, no lost digits).
fn mean_spread(tips: &[[f64; 3]], dim: usize) -> (Vec<f64>, f64) {
    let n = tips.len() as f64;
    let o = tips[0];
    let mut s1 = [0.0; 3];
    let mut s2 = 0.0;
    for x in tips {
        for i in 0..dim {
            let u = x[i] - o[i];
            s1[i] += u;
            s2 += u * u;
        }
    }
    let mean = (0..dim).map(|i| o[i] + s1[i] / n).collect();
    let m2: f64 = s1[..dim].iter().map(|s| (s / n).powi(2)).sum();
    (mean, (s2 / n - m2).max(0.0).sqrt())
}

fn rms(d2: f64, n: usize) -> f64 {
    if n == 0 {
        f64::NAN
    } else {
        (d2 / n as f64).sqrt()
    }
}

/// Evaluates the parameter values `p` (the model's estimated parameters, in order) on the
/// held-out `poses`, beside the model's nominals: every constraint's unknown values refitted
/// to the tips (see the module docs).
///
/// # Errors
/// [`crate::error::ErrorClass::Other`] when `p` is not one value per estimated parameter;
/// [`crate::error::ErrorClass::Degenerate`] without poses.
pub fn evaluate(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Result<Evaluation> {
    evaluate_weighted(model, poses, p, None)
}

/// [`evaluate`] with the weighted pose RMS of measured poses taken at the orientation weight
/// `weight` (metres per radian): the one the fit estimated (`pose_noise.weight` of its
/// result), so that the held-out pose RMS is the fit's own measure; `None`, the model's
/// (the spec's stated ratio, else 1).
///
/// # Errors
/// As [`evaluate`].
pub fn evaluate_weighted(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    weight: Option<f64>,
) -> Result<Evaluation> {
    if p.len() != model.param_count() {
        return Err(Error::other(format!(
            "{} parameter values given for a model of {} estimated parameters",
            p.len(),
            model.param_count()
        )));
    }
    if poses.is_empty() {
        return Err(Error::degenerate("no poses to evaluate on"));
    }
    let nominal: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    let groups = Groups::new(model, poses);
    let nc = model.constraint_count();
    let s0: Vec<Side> = (0..nc)
        .map(|j| side(model, poses, &groups, j, &nominal, true))
        .collect();
    let s1: Vec<Side> = (0..nc)
        .map(|j| side(model, poses, &groups, j, p, true))
        .collect();
    let constraints = (0..nc)
        .map(|j| constraint_evaluation(model, j, &s0[j], &s1[j]))
        .collect();
    let total = |s: &[Side]| {
        let n: usize = s.iter().map(|x| x.n).sum();
        rms(s.iter().map(|x| x.d2).sum(), n)
    };
    Ok(Evaluation {
        files: Vec::new(),
        poses: poses.len(),
        residual_rms_nominal: total(&s0),
        residual_rms: total(&s1),
        spread_pooled_nominal: pooled_spread(&s0),
        spread_pooled: pooled_spread(&s1),
        constraints,
        point_pairs: point_pairs(model, &s0, &s1),
        orientation: orientation_evaluation(model, poses, &nominal, p, weight),
    })
}

fn constraint_evaluation(
    model: &dyn CalibModel,
    j: usize,
    s0: &Side,
    s1: &Side,
) -> ConstraintEvaluation {
    // Without held-out poses nothing is refitted: the values stay the calibrated ones.
    let free = if s1.n == 0 {
        Vec::new()
    } else {
        refitted_values(model, j)
    };
    // A parameter in several slots (a symmetric quadric's `A12`) is one parameter: named once.
    let mut refitted: Vec<String> = Vec::new();
    for param in free
        .iter()
        .enumerate()
        .filter(|(_, &f)| f)
        .filter_map(|(v, _)| model.constraint_value_param(j, v))
    {
        let name = model.param_name(param).to_string();
        if !refitted.contains(&name) {
            refitted.push(name);
        }
    }
    ConstraintEvaluation {
        constraint: j,
        kind: model.constraint_kind(j).name(),
        poses: s1.n,
        refitted,
        residual_rms_nominal: rms(s0.d2, s0.n),
        residual_rms: rms(s1.d2, s1.n),
        max_residual_nominal: if s0.n > 0 { s0.max } else { f64::NAN },
        max_residual: if s1.n > 0 { s1.max } else { f64::NAN },
        residual_dof: s1.dof,
        spread_nominal: s0.spread,
        spread: s1.spread,
        mean_nominal: s0.mean.clone(),
        mean: s1.mean.clone(),
        values_nominal: s0.values.clone(),
        values: s1.values.clone(),
    }
}

/// `sqrt(Σ_j n_j s_j² / Σ_j n_j)` over the points with poses; `None` without any.
fn pooled_spread(s: &[Side]) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0usize);
    for x in s {
        if let Some(sp) = x.spread {
            num += x.n as f64 * sp * sp;
            den += x.n;
        }
    }
    (den > 0).then(|| (num / den as f64).sqrt())
}

/// The distance between the mean tips of every pair of points with poses, and the error
/// against a `distance` relation between them.
fn point_pairs(model: &dyn CalibModel, s0: &[Side], s1: &[Side]) -> Vec<PointPairEvaluation> {
    let nc = s1.len();
    let mut out = Vec::new();
    for i in 0..nc {
        for j in i + 1..nc {
            let (Some(a0), Some(b0), Some(a1), Some(b1)) =
                (&s0[i].mean, &s0[j].mean, &s1[i].mean, &s1[j].mean)
            else {
                continue;
            };
            let value = distance_relation(model, i, j);
            let (d0, d1) = (distance(a0, b0), distance(a1, b1));
            out.push(PointPairEvaluation {
                between: [i, j],
                value,
                distance_nominal: d0,
                distance: d1,
                error_nominal: value.map(|v| d0 - v),
                error: value.map(|v| d1 - v),
            });
        }
    }
    out
}
