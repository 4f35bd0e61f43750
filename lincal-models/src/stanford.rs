//! The Stanford (Scheinman) arm, with its prismatic third joint.

use lincal_derive::CalibModel;

/// Stanford arm, six joints, joint 3 prismatic (Spong et al., "Robot Modeling and Control",
/// table 3.4; values of Stanford AIM-177 as in Corke's Robotics Toolbox), the tool tip
/// measured by a tracker registered to the base frame (`measured` constraint).
///
/// Estimated: `d1, d2`, the shoulder twists, the prismatic zero offset `o3`, `d6`, every home
/// offset and the probe point; `K` = 216, 12 of the 14 parameters' combinations
/// identifiable (`d6` with the probe's z, `θh6` with the probe's direction about z6).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/stanford_arm_tracker.yaml")]
pub struct StanfordArmTracker;
