//! Planar serial arms (the paper's sec. 4 examples).

use lincal_derive::CalibModel;

/// Planar 3-link arm, tip on an unknown straight line (Sayeh & Newman sec. 4.1, n = 3).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/planar3_line.yaml")]
pub struct Planar3Line;

/// Planar 3-link arm, tip pinned at an unknown point (Sayeh & Newman sec. 4.2).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/planar3_point.yaml")]
pub struct Planar3Point;
