//! The Stanford arm.

use lincal_derive::CalibModel;

/// Stanford arm (Spong table 3.4, AIM-177 values), prismatic joint 3, the tip measured in the
/// base frame (`measured`, three equations, `K` = 216).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/stanford_arm_tracker.yaml")]
pub struct StanfordArmTracker;
