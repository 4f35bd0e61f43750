//! The geometric residual's linearisation pose by pose, over the free (gauge-fixed)
//! parameters: what pose selection weighs one candidate against another with.
//!
//! Pose `l` on constraint `j` contributes `m_l` rows (the residual count of `j`'s kind):
//! `J_l = ∂g(x(q_l; p), v_j(p))/∂p_F`, exact, as the fit's own linearisation computes them,
//! and the residuals `g_l` themselves (how far the pose is from its constraint at `p`).

use crate::data::Poses;
use crate::error::Result;
use crate::model::CalibModel;

use super::problem::GeometricFit;

/// Every pose's rows `[J_l | g_l]` at one parameter vector.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseJacobians {
    /// The free parameters (indices into the model's parameters), the columns of `J`; the
    /// others are known or held by the gauge rule.
    pub free: Vec<usize>,
    /// The rows, one after another, each `free.len() + 1` long: `J` then `g`.
    pub rows: Vec<f64>,
    /// Pose `l`'s rows are `offsets[l]..offsets[l + 1]` (`N + 1` entries).
    pub offsets: Vec<usize>,
}

impl PoseJacobians {
    /// Row width: free parameters plus the residual.
    #[must_use]
    pub fn width(&self) -> usize {
        self.free.len() + 1
    }

    /// Pose `l`'s rows, `[J_l | g_l]` each.
    #[must_use]
    pub fn pose(&self, l: usize) -> &[f64] {
        let w = self.width();
        &self.rows[self.offsets[l] * w..self.offsets[l + 1] * w]
    }
}

/// The rows `[J_l | g_l]` of every pose at the full parameter vector `p`, over the free set
/// the fit would use from `p` (the model's gauge rule).
///
/// # Errors
/// A constraint index out of range; a pose whose residual or Jacobian is not finite.
pub fn pose_jacobians(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Result<PoseJacobians> {
    let fit = GeometricFit::new(model, poses, p)?;
    let (rows, offsets) = fit.pose_rows(p)?;
    Ok(PoseJacobians {
        free: fit.set.free.clone(),
        rows,
        offsets,
    })
}
