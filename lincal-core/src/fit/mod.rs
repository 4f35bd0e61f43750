//! The fits: from poses (and a model) to parameter estimates.
//!
//! Takes a [`crate::model::CalibModel`] and [`crate::data::Poses`]; gives estimates of the
//! model's parameters with their covariance. Two paths, one per file group:
//! - the linear method of Sayeh & Newman: `solve` (the streamed QR of the algebraic data
//!   matrix, `c` per constraint), then `closed_form` (the paper's sec. 4.1, where it applies)
//!   and `extract` (the physical parameters from `c`, a fit in c-space);
//! - the parameter-space path: `geometric` (Levenberg-Marquardt on the geometric residual with
//!   the exact `∂x/∂p`), `refine` (its `--refine` use on a linear estimate), with `relation`
//!   (the rows relations add to either fit) and `symmetry` (the canonical one of mirrored
//!   equivalent solutions);
//! - `start`: unknown constraints fitted to the nominal arm's tips, the start every path
//!   takes instead of the spec's guesses.
//!
//! Shared numerics live below, in [`crate::numeric`]; the pipeline that chooses a path and
//! reports on it lives above, in [`crate::calibrate`].

pub mod closed_form;
pub mod extract;
pub mod geometric;
pub mod refine;
pub mod relation;
pub mod solve;
pub mod start;
pub mod symmetry;
