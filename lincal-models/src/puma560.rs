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
