//! The AdeptOne SCARA of Sayeh & Newman's experiment.

use lincal_derive::CalibModel;

/// AdeptOne joints 1-2 as a planar 2-link arm, tip on an unknown straight laser line
/// (Sayeh & Newman 1993, sec. 5).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/adept_one.yaml")]
pub struct AdeptOne;
