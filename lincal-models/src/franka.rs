//! Franka Emika arms.

use lincal_derive::CalibModel;

/// Franka Panda, seven joints (Franka FCI modified-DH table), the flange ball seated in three
/// sockets at unknown places (a list of three `point` constraints); every length, twist and
/// home offset unknown (`K` = 1291). `c(p)` and `∂c/∂p` come from the factored kernel.
#[derive(Clone, Copy, Debug, Default, CalibModel)]
#[calib(spec = "specs/franka_panda_sockets.yaml")]
pub struct FrankaPandaSockets;
