//! # lincal
//!
//! Robot kinematic calibration by the linear generalized-parameter method of Sayeh & Newman:
//! describe a serial arm (Denavit-Hartenberg table) and the constraint its tool tip is held on
//! (a point, line, plane, circle, sphere, quadric, or measured positions), and `lincal` finds
//! the exact minimal basis of the calibration equations, which parameter combinations the
//! constraint can identify, and, from joint readings alone, the calibrated parameters with
//! their uncertainties, with no initial guess.
//!
//! This crate is the facade: it re-exports
//! - [`lincal_core`] (and at the top level its modules and common items): the spec, the
//!   exact symbolic engine, the solver, the reports and the simulator;
//! - [`lincal_models`] (as [`models`]): ready models of known robots;
//! - the `#[derive(CalibModel)]` macro of `lincal-derive`, beside the
//!   [`CalibModel`] trait it implements (they share the name, as serde's `Serialize` does);
//!
//! and builds the `lincal` command line (`src/main.rs`; its contract is
//! `shared/interface.md`).
//!
//! # Example
//! ```
//! use lincal::{spec, symbolic::SymbolicModel, CalibModel};
//! let spec = spec::from_yaml_str(
//!     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
//!      - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
//!      a2: {nominal: 0.425}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  \
//!      b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
//!     None,
//! )
//! .unwrap();
//! let model = SymbolicModel::from_spec(&spec).unwrap();
//! assert_eq!(model.basis_size(), 5);
//! ```

#![warn(missing_docs)]

pub use lincal_core;
pub use lincal_core::{
    calibrate, cancel, compensate, data, error, fit, model, numeric, program, progress, report,
    select, simulate, spec, symbolic, urdf,
};
pub use lincal_core::{CalibModel, ConstraintKind, Error};
/// `#[derive(CalibModel)]`: a model generated at compile time (see the `lincal-derive` docs).
/// Through this facade, name the runtime crate's path with `crate`:
///
/// ```
/// use lincal::CalibModel; // the derive and the trait, one name
///
/// #[derive(CalibModel)]
/// #[calib(
///     crate = "::lincal::lincal_core",
///     dim = 2,
///     joint(revolute, a = a1, home = th1),
///     joint(revolute, a = a2, home = th2),
///     params(a1 = 0.375, th1 = 0, a2 = 0.425, th2 = 0, b1 = -1.79, b2 = -0.56),
///     constraint(line(b = [b1, b2])),
/// )]
/// pub struct TwoLink;
///
/// let m: &dyn CalibModel = &TwoLink;
/// assert_eq!(m.basis_size(), 5);
/// assert_eq!(m.identifiable_count(), 4);
/// ```
pub use lincal_derive::CalibModel;
pub use lincal_models as models;
