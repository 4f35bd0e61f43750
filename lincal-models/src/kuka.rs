//! KUKA arms.

use lincal_derive::CalibModel;

/// KUKA LBR iiwa 14 R820, seven joints (standard DH), an off-axis flange ball pinned in one
/// socket at an unknown place (`K` = 1275). `c(p)` and `∂c/∂p` come from the factored kernel.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/kuka_iiwa14_point.yaml")]
pub struct KukaIiwa14Point;

/// A 7R arm with the iiwa 14's table as nominals and **every** one of its 28 DH parameters
/// unknown (a, α, d and the home offset of each joint), an off-axis flange ball pinned in one
/// socket at an unknown place (`K` = 2187 = 3⁷: every joint monomial is a basis function).
/// The model a user writes when nothing of the drawing is trusted.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/arm7_all_unknown_point.yaml")]
pub struct Arm7AllUnknownPoint;
