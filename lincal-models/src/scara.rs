//! SCARA arms with a prismatic quill.

use lincal_derive::CalibModel;

/// SCARA RRP (Spong et al. ex. 3.3.4), a known stylus on the quill touching an unknown plane.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/scara_plane.yaml")]
pub struct ScaraPlane;
