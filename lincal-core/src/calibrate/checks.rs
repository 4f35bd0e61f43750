//! Checks before and after the fit: the model's parameters are the spec's estimated ones, the
//! poses are consistent and their readings finite, the data support the fit (one pass,
//! `O(N·n²)`), and every reported number is finite.

use super::estimate::ParamEstimate;
use super::SpecParam;
use crate::data::{looks_like_degrees, Poses};
use crate::error::{Error, Location, Result};
use crate::model::CalibModel;

/// How many readings outside the joint limits a warning names (the rest are counted).
pub(super) const LIMITS_SHOWN: usize = 5;

/// What the one pass over the joint readings finds, besides their being valid: what the
/// reading warnings say after the fit.
pub(super) struct Readings {
    /// Per joint, the largest `|q_i|` of the readings that look like degrees (beyond a full
    /// turn and outside limits that can vouch for them, as `--angles auto` judges; 0 when
    /// none does, and for prismatic joints).
    pub(super) degree_like: Vec<f64>,
    /// Per joint, whether every pose reads the same value.
    pub(super) frozen: Vec<bool>,
    /// The first [`LIMITS_SHOWN`] readings outside the spec's joint limits, in pose then joint
    /// order: `(pose, joint, reading, [lo, hi])`.
    pub(super) outside: Vec<(usize, usize, f64, [f64; 2])>,
    /// How many readings are outside the limits.
    pub(super) outside_count: usize,
}

/// The model's parameters are exactly the spec's estimated (not `known`) ones, in order.
pub(super) fn check_model_params(model: &dyn CalibModel, params: &[SpecParam]) -> Result<()> {
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
/// of full column rank near the nominals, whatever the path. Gives what the readings pass
/// found for the warnings. A failure names the readings outside the spec's limits, if any
/// (pose numbers `id(l)`): a reading of 10⁹ m on a prismatic joint ends the support check as
/// a lost combination of angles, which names neither the row nor the limits.
pub(super) fn check_poses(
    model: &dyn CalibModel,
    poses: &Poses,
    id: &dyn Fn(usize) -> usize,
) -> Result<Readings> {
    let n = poses.len();
    let measured_ok = poses.measured.as_ref().is_none_or(|m| m.len() == n);
    if poses.constraint.len() != n || !measured_ok {
        return Err(Error::other(
            "inconsistent poses: every pose needs a constraint index (and a measured-tip entry when tips are measured)",
        ));
    }
    let readings = check_readings(model, poses)?;
    check_parallel_relations(model, poses)?;
    crate::fit::geometric::check_support(model, poses)
        .map_err(|e| with_limits_note(e, poses, &readings, id))?;
    Ok(readings)
}

/// `e` with the readings outside the spec's limits named (a fit that fails keeps no
/// warnings, and such a reading may be why), when it is a degenerate-data error.
pub(super) fn with_limits_note(
    e: Error,
    poses: &Poses,
    readings: &Readings,
    id: &dyn Fn(usize) -> usize,
) -> Error {
    match limit_warning(poses, readings, id) {
        Some(w) if e.class() == crate::error::ErrorClass::Degenerate => {
            e.with_note(&format!("the data hold {w}"))
        }
        _ => e,
    }
}

/// The sine of the angle beyond which two planes the spec's relations hold parallel are
/// refused when each one's own poses, through the nominal arm, lie on planes that far apart
/// (30°: a nominal arm is off by millimetres and milliradians, not by that).
const PARALLEL_REFUSED: f64 = 0.5;

/// A `same_normal` or `offset` relation between two planes whose data say otherwise: each
/// plane fitted to its own poses' nominal tips (the fit's own start), the relation's normal
/// part evaluated there. Such a relation cannot hold with the data, and the fit would end in
/// a rank or collapse message that names neither; an input error names the relation.
fn check_parallel_relations(model: &dyn CalibModel, poses: &Poses) -> Result<()> {
    use crate::model::geometry::RelationKind;
    let relations = model.relations();
    if relations.is_empty() {
        return Ok(());
    }
    let (p, fitted) = crate::fit::start::constraint_start(model, poses);
    let rows = crate::fit::relation::rows(model, &p);
    let mut at = 0;
    for (k, r) in relations.iter().enumerate() {
        let count = r.kind.residual_count(model.dim());
        let parallel = matches!(r.kind, RelationKind::SameNormal | RelationKind::Offset);
        let seen = r.between.iter().all(|j| fitted.contains(j));
        // The cross product of the unit normals leads each such relation's rows.
        let cross = if model.dim() == 3 { 3 } else { 1 };
        if parallel && seen && rows.len() >= at + cross {
            let sine = rows[at..at + cross]
                .iter()
                .map(|row| row.residual * row.residual)
                .sum::<f64>()
                .sqrt();
            if sine > PARALLEL_REFUSED {
                return Err(Error::input(
                    crate::error::Location {
                        field: Some(format!("relations[{k}]")),
                        ..Default::default()
                    },
                    format!(
                        "`{}` holds constraints {} and {} parallel, but their poses lie on \
                         planes {:.1}° apart (each plane fitted to its own poses through the \
                         nominal arm): check the relation's constraint numbers and the order \
                         of the data files",
                        r.kind.name(),
                        r.between[0],
                        r.between[1],
                        sine.min(1.0).asin().to_degrees()
                    ),
                ));
            }
        }
        at += count;
    }
    Ok(())
}

/// Every reported number finite; otherwise an error (never a NaN passed on silently).
pub(super) fn check_finite(
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

/// Every joint reading (and measured coordinate) finite and of the right count, naming the
/// pose and joint otherwise; in the same pass, what [`Readings`] records.
fn check_readings(model: &dyn CalibModel, poses: &Poses) -> Result<Readings> {
    let nj = model.joint_count();
    let mut seen = Readings {
        degree_like: vec![0.0; nj],
        frozen: vec![true; nj],
        outside: Vec::new(),
        outside_count: 0,
    };
    let limits: Vec<Option<[f64; 2]>> = (0..nj).map(|i| model.joint_limits(i)).collect();
    for (l, q) in poses.q.iter().enumerate() {
        check_pose(model, poses, l, q)?;
        let first = &poses.q[0];
        for (i, &qi) in q.iter().enumerate() {
            if !model.joint_is_prismatic(i) && looks_like_degrees(qi, limits[i]) {
                seen.degree_like[i] = seen.degree_like[i].max(qi.abs());
            }
            seen.frozen[i] &= qi == first[i];
            if let Some([lo, hi]) = limits[i] {
                if qi < lo || qi > hi {
                    seen.outside_count += 1;
                    if seen.outside.len() < LIMITS_SHOWN {
                        seen.outside.push((l, i, qi, [lo, hi]));
                    }
                }
            }
        }
    }
    Ok(seen)
}

/// Pose `l` (readings `q`): a constraint index in range, one reading per joint, every reading
/// and measured coordinate finite.
fn check_pose(model: &dyn CalibModel, poses: &Poses, l: usize, q: &[f64]) -> Result<()> {
    let nj = model.joint_count();
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
    let kind = model.constraint_kind(j);
    let width = kind.equation_count(model.dim());
    if kind.is_measured() && m.map_or(0, <[f64]>::len) != width {
        let what = if width == 12 {
            "a measured pose needs its position and orientation (12 values: x, y, z, then \
             the rotation matrix column-major)"
        } else {
            "a pose on a measured constraint needs its measured tip"
        };
        return Err(Error::input(place(), what));
    }
    Ok(())
}

/// The items `shown` (the first of `total`) joined with `; `, then `; and N more` for the rest.
pub(super) fn and_more(shown: &[String], total: usize) -> String {
    let more = total.saturating_sub(shown.len());
    let head = shown.join("; ");
    if more > 0 {
        format!("{head}; and {more} more")
    } else {
        head
    }
}

/// `v` as a reader takes it in: plain decimals for ordinary sizes, exponent form for tiny
/// and huge ones (a subnormal written out in full is 320 digits).
fn readable(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The warning for readings outside the spec's joint limits (legal input, but often a sign of
/// a bad row): the first few (from the readings pass `seen`), with pose numbers `id(l)` and
/// CSV lines.
pub(super) fn limit_warning(
    poses: &Poses,
    seen: &Readings,
    id: &dyn Fn(usize) -> usize,
) -> Option<String> {
    if seen.outside_count == 0 {
        return None;
    }
    let shown: Vec<String> = seen
        .outside
        .iter()
        .map(|&(l, i, qi, [lo, hi])| {
            let line = poses
                .line
                .get(l)
                .map_or(String::new(), |_| format!(" ({})", poses.place(l)));
            format!(
                "pose {}{line}: q{} = {} not in [{lo}, {hi}]",
                id(l),
                i + 1,
                readable(qi)
            )
        })
        .collect();
    Some(format!(
        "{} joint reading(s) outside the spec's limits: {}",
        seen.outside_count,
        and_more(&shown[..shown.len().min(LIMITS_SHOWN)], seen.outside_count)
    ))
}
