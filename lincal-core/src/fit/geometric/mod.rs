//! The parameter-space path: Levenberg-Marquardt on the geometric residual with the exact
//! Jacobian, for any number of poses.
//!
//! Over the free (gauge-fixed) parameters `p_F`, minimise
//! `Σ_l ‖g(x(q_l; p), v_j(p))‖²`, `x` the tip, `v_j` the values of the constraint pose `l` lies
//! on and `g` [`geometry::geometric_residual`]. The Jacobian of one pose is exact:
//! `∂g/∂p = ∂g/∂x · ∂x/∂p + ∂g/∂v · ∂v/∂p`, with `∂x/∂p` from the chain
//! ([`crate::model::chain`], `O(P)` per pose), `∂g/∂x`, `∂g/∂v` by forward-mode dual numbers
//! ([`geometry::residual_jacobian`]) and `∂v/∂p` a selection
//! ([`CalibModel::constraint_value_param`]).
//!
//! # Cost
//! Each linearisation streams the poses once and accumulates the Gram matrix
//! `[J | r]ᵀ[J | r]` (`(n+1)²` numbers, whatever `N`) in blocks of rows with a
//! packed matrix product, split over the machine's cores. Its Cholesky factor
//! (column-equilibrated) is the `R` of a QR of `[J | r]`, which the shared Levenberg-Marquardt
//! core ([`crate::fit::refine`]) takes. So an iteration costs `O(N·n²)` flops and `O(n²)` memory:
//! linear in the data, independent of the basis size `K`. The squared condition number of
//! the Gram route is harmless here: the steps are damped and re-linearised (the last one,
//! inside the relative-offset test's bound, checked by its cost), and the reported
//! standard deviations need a few digits only (they are checked against Monte Carlo).
//!
//! [`geometry::geometric_residual`]: crate::model::geometry::geometric_residual
//! [`geometry::residual_jacobian`]: crate::model::geometry::residual_jacobian
//! [`CalibModel::constraint_value_param`]: crate::model::CalibModel::constraint_value_param

mod estimate;
mod jacobians;
mod passes;
mod problem;
mod restarts;
mod support;

pub(crate) use estimate::converged;
pub use estimate::{fit, fit_weighted, GeometricEstimate};
pub use jacobians::{pose_jacobians, PoseJacobians};
pub(crate) use passes::{fold_poses, map_ranges};
pub use restarts::{collapsed_joints, fit_from_nominal, RESTARTS, RESTART_WORK};
pub use support::check_support;
