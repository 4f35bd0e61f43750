//! Universal Robots arms.

use lincal_derive::CalibModel;

/// UR5, six joints (Universal Robots, "DH parameters for calculations of kinematics and
/// dynamics", standard DH), a reflector ball on the flange measured by a laser tracker whose
/// frame is unknown (`measured` constraint, base transform estimated).
///
/// Estimated: `d1, a2, a3, d4, d5, d6`, every home offset, the twists of the non-parallel
/// joints 1, 4 and 5, the ball's place on the flange and the tracker frame; `K` = 93, 20 of
/// the 24 parameters' combinations identifiable (`d1` with the base height, `θh1` with the
/// base yaw, `d6` with the tool's z, `θh6` with the tool's direction about z6). The UR10
/// with the twists of the parallel joints unknown too is [`Ur10Tracker`].
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/ur5_tracker.yaml")]
pub struct Ur5Tracker;

/// UR10 (Universal Robots DH table), every twist unknown, the SMR measured by a laser tracker
/// in an unknown frame (`K` = 729). `c(p)` and `∂c/∂p` come from the factored kernel.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/ur10_tracker.yaml")]
pub struct Ur10Tracker;
