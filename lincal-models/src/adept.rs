//! The AdeptOne SCARA of Sayeh & Newman's experiment.

use lincal_derive::CalibModel;

/// AdeptOne joints 1-2 as a planar 2-link arm, tip on an unknown straight laser line
/// (Sayeh & Newman 1993, sec. 5).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/adept_one.yaml")]
pub struct AdeptOne;

/// AdeptOne SCARA, all four axes (Adept specification: links 0.425 m and 0.375 m; Spong et
/// al. ex. 3.3.4 DH structure): J1, J2 revolute, J3 the prismatic quill, J4 the tool roll,
/// an off-axis stylus touching an unknown plane.
///
/// `K` = 8, 7 of the 12 parameters' combinations identifiable: a plane sees neither the scale
/// (`a1` with every length and `1/‖b‖`) nor vertical shifts (`d1`, the quill offset `o3` and
/// the stylus length each go with the plane's offset) nor a rotation about the J1 axis
/// (`θh1` with the plane's normal).
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/adept_one_scara.yaml")]
pub struct AdeptOneScara;
