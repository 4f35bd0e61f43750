//! ABB industrial arms.

use lincal_derive::CalibModel;

/// ABB IRB 120, six joints (ABB "Product specification IRB 120" dimensions as a standard-DH
/// table), the tool ball on a ball bar of known length (0.1 m) about an unknown pivot: a
/// `sphere` constraint with unknown centre and known radius.
///
/// Estimated: `d1, a2, a3, d4, d6`, the home offsets of joints 1-5 and the pivot; `K` = 77,
/// 11 of the 13 parameters' combinations identifiable. The known bar length fixes the scale
/// (lengths in metres); `d1` goes with the pivot's height and `θh1` with the pivot's bearing
/// about the base axis. The ball is on joint 6's axis, so joint 6 is not calibrated.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/abb_irb120_ballbar.yaml")]
pub struct AbbIrb120BallBar;
