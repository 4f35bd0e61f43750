//! The PUMA 560 (standard DH, Corke & Armstrong-Hélouvry 1994).

use lincal_derive::CalibModel;

/// PUMA 560, all six joints, every length, offset and home unknown, tip on an unknown plane
/// (`K` = 195 basis functions).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/puma560_plane.yaml")]
pub struct Puma560Plane;

/// PUMA 560 joints 1-3 (the positioning arm), wrist centre on an unknown 3-D line.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/elbow3_line.yaml")]
pub struct Elbow3Line;

/// PUMA 560, the tool frame's full pose measured by a 6-DOF tracker (`measured_pose`, 20 µm
/// and 50 µrad stated, so `orientation_weight()` is 0.4 m/rad): every length, offset and
/// home unknown, the tracker frame (base) and the probe's frame on the flange (tool: 3 shifts,
/// 3 angles) unknown, the twists at their nominal values (`K` = 195, 12 equations: the tool
/// frame's origin and its rotation's 9 entries). 24 of the 30 parameters' combinations are
/// identifiable; the gauge pairs `d1` with the base height, `θh1` with the base yaw, `d2`
/// with `d3`, `a6` with the tool's x, `d6` with its z and `θh6` with its yaw.
///
/// The same arm with every twist unknown too is [`Puma560PoseTracker`].
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/puma560_pose_frames.yaml")]
pub struct Puma560PoseFrames;

/// PUMA 560 in Craig's modified DH table, tip on an unknown plane (`K` = 195): the MDH twin
/// of [`Puma560Plane`].
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/puma560_mdh_plane.yaml")]
pub struct Puma560MdhPlane;

/// PUMA 560 (standard DH), tip on an unknown sphere (`K` = 271): equations of degree two in
/// the tip.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/puma560_sphere.yaml")]
pub struct Puma560Sphere;

/// PUMA 560 (standard DH), the tool frame's full pose measured by a 6-DOF tracker in an
/// unknown frame, every twist unknown too (`K` = 729, 12 equations). `c(p)` and `∂c/∂p` come
/// from the factored kernel (the straight-line form would be about nine million operations).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/puma560_pose_tracker.yaml")]
pub struct Puma560PoseTracker;
