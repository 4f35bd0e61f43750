//! Full-pose measurements (`measured_pose`): each pose's position and orientation error at
//! a parameter vector, and their RMS, as the reports give them (the orientation in radians,
//! not weighed).

use crate::data::Poses;
use crate::model::geometry::{self, ConstraintKind};
use crate::model::{chain, CalibModel};

/// Whether `model` fits full poses.
pub(crate) fn is_pose_model(model: &dyn CalibModel) -> bool {
    (0..model.constraint_count()).any(|j| model.constraint_kind(j) == ConstraintKind::MeasuredPose)
}

/// The RMS over poses of the position error `‖x − x_m‖` (metres) and of the orientation
/// error `‖log(R_mᵀR)‖` (radians) at `p`, over the measured poses.
#[must_use]
pub fn pose_errors(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (f64, f64) {
    let (pos, ori) = pose_error_norms(model, poses, p);
    let (mut sp, mut so, mut count) = (0.0, 0.0, 0usize);
    for (x, a) in pos.iter().zip(&ori) {
        if x.is_finite() && a.is_finite() {
            sp += x * x;
            so += a * a;
            count += 1;
        }
    }
    if count == 0 {
        return (f64::NAN, f64::NAN);
    }
    ((sp / count as f64).sqrt(), (so / count as f64).sqrt())
}

/// Every pose's position error `‖x − x_m‖` (metres) and orientation error `‖log(R_mᵀR)‖`
/// (radians) at `p`, in pose order; NaN for a pose that is not a measured pose.
#[must_use]
pub fn pose_error_norms(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let factors = model.chain();
    let mut motions = vec![chain::Motion::default(); factors.len()];
    chain::prepare(factors, p, &mut motions);
    let (mut pos, mut ori) = (
        Vec::with_capacity(poses.len()),
        Vec::with_capacity(poses.len()),
    );
    let (mut tip, mut rot, mut r) = ([0.0; 3], [0.0; 9], [0.0; 6]);
    for l in 0..poses.len() {
        let on_pose = poses.constraint.get(l).is_some_and(|j| {
            j < model.constraint_count() && model.constraint_kind(j) == ConstraintKind::MeasuredPose
        });
        let m = poses.measured.as_ref().and_then(|m| m.get(l));
        let Some(m) = m.filter(|m| on_pose && m.len() >= 12 && !factors.is_empty()) else {
            pos.push(f64::NAN);
            ori.push(f64::NAN);
            continue;
        };
        chain::pose_prepared(factors, &motions, &poses.q[l], &mut tip, &mut rot);
        geometry::pose_residual(m, &tip, &rot, 1.0, &mut r);
        pos.push(r[..3].iter().map(|v| v * v).sum::<f64>().sqrt());
        ori.push(r[3..].iter().map(|v| v * v).sum::<f64>().sqrt());
    }
    (pos, ori)
}
