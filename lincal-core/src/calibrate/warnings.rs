//! The warnings about the data and the estimate: readings (likely degrees, frozen joints, outside
//! the limits), practically unidentifiable directions, a residual large for the data's scale.

use super::checks::{and_more, limit_warning, Readings, LIMITS_SHOWN};
use super::constraint_fit::{ConstraintFit, RelationFit};
use super::residuals::TipStatistics;
use super::PRACTICAL_FRACTION;
use crate::data::Poses;
use crate::model::CalibModel;

/// The warnings about the data and the estimate, in order: the readings, practically
/// unidentifiable directions (given the covariance), a residual large for the data's scale,
/// readings outside the joint limits, measured poses copied. `id` numbers the poses as the data does.
pub(super) fn data_warnings(
    model: &dyn CalibModel,
    poses: &Poses,
    readings: &Readings,
    stats: &TipStatistics,
    covariance: Option<&(Vec<usize>, nalgebra::DMatrix<f64>)>,
    id: &dyn Fn(usize) -> usize,
) -> Vec<String> {
    let mut warnings = reading_warnings(model, poses, readings);
    // The data's scale: the spread of the tips, or a tenth of their distance from the base
    // origin when they cluster (a pinned point).
    let scale = stats.spread.max(0.1 * stats.reach);
    if let Some((free, cov)) = covariance {
        warnings.extend(practical_warnings(model, free, cov, scale));
    }
    warnings.extend(fit_warning(poses, stats, scale, id));
    warnings.extend(limit_warning(poses, readings, id));
    warnings.extend(super::copies::copies_warning(poses, id));
    warnings
}

/// A relation the estimate misses by more than this (a residual component: metres, or for
/// `same_normal` the cross product of the unit normals) is named in a warning. The fits
/// weigh a relation like 10⁶ times the whole data's information on an average parameter
/// ([`crate::fit::relation`]), which holds a consistent one to about 10⁻⁶ of the data's pull
/// on it; only relations that contradict each other or the constraints' known values, or
/// data that disagree with a stated value by centimetres, come near this.
const RELATION_MISS: f64 = 1e-6;

/// The warning naming the spec's relations that the estimate `p` misses by more than
/// [`RELATION_MISS`]: the fit is then a compromise, not what the spec says.
pub(super) fn relation_warning(model: &dyn CalibModel, p: &[f64]) -> Option<String> {
    let unmet = crate::fit::relation::unmet(model, p, RELATION_MISS);
    if unmet.is_empty() {
        return None;
    }
    let shown: Vec<String> = unmet
        .iter()
        .take(LIMITS_SHOWN)
        .map(|&(k, off)| {
            let r = &model.relations()[k];
            let value = if r.kind.has_value() {
                format!(" of {}", r.value)
            } else {
                String::new()
            };
            format!(
                "`relations:` item {k} (from 0; {}{value} between constraints {} and {}) is \
                 off by {off:.3e}",
                r.kind.name(),
                r.between[0],
                r.between[1]
            )
        })
        .collect();
    Some(format!(
        "the calibrated model does not hold the spec's relations: {} (metres; for \
         `same_normal` the sine of the angle between the normals); relations that contradict \
         each other or the constraints' known values cannot all hold, nor one whose value the \
         data disagree with, and the fit is a compromise between them (`relations` in the \
         report: stated against achieved)",
        and_more(&shown, unmet.len())
    ))
}

/// The warning naming stated relations whose value the calibrated arm's tips disagree with:
/// the fit holds a relation on the constraints' parameters, but where the data put the two
/// constraints elsewhere (a wrong stated distance, a socket swapped between files), the tips'
/// means stand apart by another distance and the residuals absorb the difference. Named when
/// the achieved value misses the stated one by more than five standard errors of the two
/// means (`rms/√n` each) and by more than 0.1 mm.
pub(super) fn relation_data_warning(
    relations: &[RelationFit],
    constraints: &[ConstraintFit],
) -> Option<String> {
    let se = |j: usize| {
        constraints
            .iter()
            .find(|c| c.constraint == j && c.poses > 0)
            .map(|c| c.residual_rms / (c.poses as f64).sqrt())
    };
    let off: Vec<String> = relations
        .iter()
        .filter_map(|r| {
            let value = r.value?;
            let (a, b) = (se(r.between[0])?, se(r.between[1])?);
            let miss = (r.calibrated - value).abs();
            // Shortest form, in exponent form far from metres (a hostile 1e-300).
            let value = if (1e-4..1e6).contains(&value.abs()) {
                format!("{value}")
            } else {
                format!("{value:e}")
            };
            let bound = (5.0 * a.hypot(b)).max(1e-4);
            (miss > bound || !miss.is_finite()).then(|| {
                format!(
                    "{} {value} between constraints {} and {}: the calibrated tips are {:.6} \
                     apart",
                    r.kind, r.between[0], r.between[1], r.calibrated
                )
            })
        })
        .collect();
    if off.is_empty() {
        return None;
    }
    Some(format!(
        "the data disagree with the spec's relations: {} (metres); the fit holds each \
         relation on the constraints' parameters and the residuals take the difference: check \
         the stated value, and that each file's poses are on the constraint it names",
        and_more(&off, off.len())
    ))
}

/// Warnings about the joint readings themselves (from the readings pass `seen`): revolute
/// readings beyond a full turn (likely degrees), joints that never moved.
fn reading_warnings(model: &dyn CalibModel, poses: &Poses, seen: &Readings) -> Vec<String> {
    let mut warnings = Vec::new();
    // Readings beyond a full turn (and the limits) on a revolute joint are legal but usually
    // degrees.
    for i in (0..model.joint_count()).filter(|&i| !model.joint_is_prismatic(i)) {
        let max = seen.degree_like[i];
        if max > 0.0 {
            warnings.push(format!(
                "joint q{} has readings up to {max:.4} in magnitude, beyond a full turn (2π) \
                 and outside its limits (or two turns): revolute readings are radians; if these are degrees, multiply by π/180 \
                 (`--angles deg` reads them so)",
                i + 1
            ));
        }
    }
    let frozen: Vec<String> = (0..model.joint_count())
        .filter(|&i| seen.frozen[i])
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

/// The parameters a fit without poses on the constraints `unseen` holds beyond `model`'s own
/// gauge (`part`: [`crate::fit::start::DataStart::without_constraints`]), other than those
/// constraints' own values: they pinned directions the others leave free (a known point fixes
/// the scale that two unknown sockets cannot), so such a fit holds them at their nominals.
pub(super) fn newly_held(
    model: &dyn CalibModel,
    part: &dyn CalibModel,
    unseen: &[bool],
) -> Vec<usize> {
    let own: Vec<usize> = (0..model.constraint_count())
        .filter(|&j| unseen.get(j).copied().unwrap_or(false))
        .flat_map(|j| {
            (0..model.constraint_kind(j).value_count(model.dim()))
                .filter_map(move |v| model.constraint_value_param(j, v))
        })
        .collect();
    (0..model.param_count())
        .filter(|&j| part.param_held(j) && !model.param_held(j) && !own.contains(&j))
        .collect()
}

/// [`newly_held`] named in a warning; `None` when there are none.
pub(super) fn unseen_gauge_warning(
    model: &dyn CalibModel,
    part: &dyn CalibModel,
    unseen: &[bool],
) -> Option<String> {
    let held: Vec<&str> = newly_held(model, part, unseen)
        .into_iter()
        .map(|j| model.param_name(j))
        .collect();
    if held.is_empty() {
        return None;
    }
    let constraints: Vec<String> = (0..unseen.len())
        .filter(|&j| unseen[j])
        .map(|j| j.to_string())
        .collect();
    Some(format!(
        "without poses on constraint(s) {}, the other poses leave more of the arm undetermined \
         than the spec's constraints together would: {} held at the nominal value(s) by the \
         gauge rule (add poses on those constraints to fit them)",
        constraints.join(", "),
        held.join(", ")
    ))
}

/// How far the calibrated tips may spread beyond (or within) the nominal ones before a
/// warning: a factor of 3 either way is no calibration of a drawn arm, but a value in other
/// units.
const REACH_FACTOR: f64 = 3.0;

/// The calibrated arm's size against the nominal arm's, named in a warning when beyond
/// [`REACH_FACTOR`] either way: no calibration moves a drawn arm's size threefold, but a length
/// in other units does. Measured tips or a known constraint's values in millimetres fit an
/// arm 1000× its drawing as well as metres fit the drawn one; a relation's distance in
/// millimetres sets a size no pose can contradict (pinned points see the arm's shape, not its
/// size): a 1 km arm, and residuals as small as ever.
///
/// The size is the sum of the magnitudes of the length parameters in the joints' slots
/// ([`crate::calibrate::prior::arm_slots`]): not the base's nor the tool's (a tracker fitted
/// metres away, a probe's length found from a nominal of 0), nor the tips' spread (at one
/// pinned point the calibrated tips collapse onto it). Without a spec (a derived model) and
/// with relations, the tips' spread about their mean (over at most 200 poses) stands in.
pub(super) fn reach_warning(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    spec: Option<&crate::spec::Spec>,
) -> Option<String> {
    let nominal: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    if p.len() != nominal.len() {
        return None;
    }
    let (before, after, what) = match spec {
        Some(spec) => {
            let arm: Vec<&str> = crate::calibrate::prior::arm_slots(spec).collect();
            let lengths: Vec<usize> = (0..p.len())
                .filter(|&j| !model.param_is_angle(j) && arm.contains(&model.param_name(j)))
                .collect();
            let size = |v: &[f64]| lengths.iter().map(|&j| v[j].abs()).sum::<f64>();
            (size(&nominal), size(p), "the arm's lengths sum to")
        }
        None if !model.relations().is_empty() => (
            tip_spread(model, poses, &nominal),
            tip_spread(model, poses, p),
            "the calibrated tips spread",
        ),
        None => return None,
    };
    let ratio = after / before;
    if !(before > 0.0 && ratio.is_finite()) || (1.0 / REACH_FACTOR..=REACH_FACTOR).contains(&ratio)
    {
        return None;
    }
    Some(format!(
        "the calibrated arm is {ratio:.3}× the size of the nominal one ({what} {after:.4e} m, \
         against {before:.4e} m): lengths in other units (millimetres for metres?) make an arm \
         of that size; check the units of the measured columns, of the constraints' known \
         values and of the `relations:` values (lincal reads metres)"
    ))
}

/// The spread of the tips about their mean over the first 200 poses (metres).
fn tip_spread(model: &dyn CalibModel, poses: &Poses, params: &[f64]) -> f64 {
    let dim = model.dim();
    let n = poses.len().min(200);
    let mut tips = vec![0.0; n * dim];
    for l in 0..n {
        if let Some(q) = poses.q.get(l) {
            model.tip(q, params, &mut tips[l * dim..(l + 1) * dim]);
        }
    }
    let mean: Vec<f64> = (0..dim)
        .map(|c| (0..n).map(|l| tips[l * dim + c]).sum::<f64>() / n.max(1) as f64)
        .collect();
    let ss: f64 = (0..n * dim)
        .map(|i| (tips[i] - mean[i % dim]).powi(2))
        .sum();
    (ss / n.max(1) as f64).sqrt()
}

/// An orientation RMS from which the measured orientations are no measurement of the tool
/// frame at all (0.3 rad, 17°: no tracker errs by that), whatever the arm.
const ORIENTATION_MISFIT: f64 = 0.3;

/// Measured poses whose orientations the calibrated model misses by [`ORIENTATION_MISFIT`]
/// or more (RMS, radians), named in a warning: orientations written in another convention
/// (a quaternion scalar-last under `qw,qx,qy,qz`, a conjugate, the tracker's frame rather than
/// the tool's) fit nothing, and the tool frame's angles are fitted to them.
pub(super) fn orientation_warning(rms: f64) -> Option<String> {
    (rms.is_finite() && rms >= ORIENTATION_MISFIT).then(|| {
        format!(
            "the measured orientations do not fit the calibrated model at all (RMS {rms:.3} rad, \
             {:.0}°): check their convention (a quaternion's order, qw first; a conjugate or \
             inverse rotation; the columns' frame) before reading the tool frame's angles",
            rms.to_degrees()
        )
    })
}
