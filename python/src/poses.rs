//! Tool frames and measured poses as flat arrays: the tool frame of every pose, the measured
//! rotations as quaternions, and the per-pose errors of a `measured_pose` fit.

use lincal_core::data::{Poses, Rows};
use lincal_core::model::geometry::ConstraintKind;
use lincal_core::model::CalibModel;

/// The tool frame of every pose `q` at `p`: the origins (N × 3) and the rotations as unit
/// quaternions `qw, qx, qy, qz` (N × 4, scalar first, `qw ≥ 0`), flat; `None` for a model
/// without a spatial chain.
pub fn tool_poses(model: &dyn CalibModel, q: &Rows, p: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
    use lincal_core::model::{chain, rotation};
    let factors = model.chain();
    if model.dim() != 3 || factors.is_empty() {
        return None;
    }
    let mut motions = vec![chain::Motion::default(); factors.len()];
    chain::prepare(factors, p, &mut motions);
    let (mut x, mut quat) = (
        Vec::with_capacity(q.len() * 3),
        Vec::with_capacity(q.len() * 4),
    );
    let (mut tip, mut rot) = ([0.0; 3], [0.0; 9]);
    for row in q {
        chain::pose_prepared(factors, &motions, row, &mut tip, &mut rot);
        x.extend_from_slice(&tip);
        quat.extend_from_slice(&rotation::quaternion_from_matrix(&rot));
    }
    Some((x, quat))
}

/// The unit quaternions (`qw, qx, qy, qz`, N × 4, flat) of measured rows holding a rotation
/// after the tip (a measured pose's 12 values); NaN for an empty row.
pub fn measured_quaternions(measured: &Rows) -> Vec<f64> {
    let mut out = Vec::with_capacity(measured.len() * 4);
    for row in measured {
        match row.get(3..12).and_then(|r| <&[f64; 9]>::try_from(r).ok()) {
            Some(r) => {
                out.extend_from_slice(&lincal_core::model::rotation::quaternion_from_matrix(r))
            }
            None => out.extend([f64::NAN; 4]),
        }
    }
    out
}

/// Per pose of a `measured_pose` spec, the position error `‖x − x_m‖` (metres) and the
/// orientation error `‖log(R_mᵀR)‖` (radians) at `p`, as the core's `residual_rms` and
/// `orientation_rms` sum them; NaN for a pose without a measured pose.
pub fn pose_errors(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (Vec<f64>, Vec<f64>) {
    use lincal_core::model::{chain, rotation};
    let n = poses.len();
    let (mut position, mut orientation) = (vec![f64::NAN; n], vec![f64::NAN; n]);
    let factors = model.chain();
    if factors.is_empty() {
        return (position, orientation);
    }
    let mut motions = vec![chain::Motion::default(); factors.len()];
    chain::prepare(factors, p, &mut motions);
    let (mut tip, mut rot) = ([0.0; 3], [0.0; 9]);
    for l in 0..n {
        let on_pose = poses.constraint.get(l).is_some_and(|j| {
            j < model.constraint_count() && model.constraint_kind(j) == ConstraintKind::MeasuredPose
        });
        let Some(m) = poses.measured.as_ref().and_then(|m| m.get(l)) else {
            continue;
        };
        let Some(rm) = m.get(3..12).and_then(|r| <&[f64; 9]>::try_from(r).ok()) else {
            continue;
        };
        if !on_pose {
            continue;
        }
        chain::pose_prepared(factors, &motions, &poses.q[l], &mut tip, &mut rot);
        position[l] = (0..3).map(|i| (tip[i] - m[i]).powi(2)).sum::<f64>().sqrt();
        orientation[l] = rotation::angle(&rotation::transpose_times(rm, &rot));
    }
    (position, orientation)
}
