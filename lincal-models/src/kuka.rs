//! KUKA arms.

use lincal_derive::CalibModel;

/// KUKA LBR iiwa 14 R820, seven joints (standard DH), an off-axis flange ball pinned in one
/// socket at an unknown place (`K` = 1275). `c(p)` and `∂c/∂p` come from the factored kernel.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/kuka_iiwa14_point.yaml")]
pub struct KukaIiwa14Point;
