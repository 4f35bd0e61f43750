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
//! # Example: a derived model, calibrated
//! The model is generated at compile time from its spec (`#[derive(CalibModel)]`, the same
//! `no_std` code a firmware tool links); the spec's text gives the fit the parameters'
//! names, nominals and the constraint. Simulated poses on an unknown line stand in for the
//! measurements, and the fit recovers the truth with no initial guess:
//! ```
//! use lincal::calibrate::{calibrate_spec, CalibrateOptions};
//! use lincal::simulate::{simulate, Noise};
//! use lincal::{spec, CalibModel};
//!
//! /// The paper's AdeptOne, joints 1-2, its tip on an unknown laser line `b·x + 1 = 0`.
//! #[derive(CalibModel)]
//! #[calib(
//!     crate = "::lincal::lincal_core",
//!     dim = 2,
//!     joint(revolute, a = a1, home = th1),
//!     joint(revolute, a = a2, home = th2),
//!     params(a1 = 0.375, th1 = 0, a2 = 0.425, th2 = 0, b1 = -1.79, b2 = -0.56),
//!     constraint(line(b = [b1, b2])),
//! )]
//! struct AdeptLine;
//!
//! let spec = spec::from_yaml_str(
//!     "name: adept_line\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
//!      - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
//!      th1: {nominal: 0}\n  a2: {nominal: 0.425}\n  th2: {nominal: 0}\n  \
//!      b1: {nominal: -1.79}\n  b2: {nominal: -0.56}\nconstraint:\n  line: {b: [b1, b2]}\n",
//!     None,
//! )?;
//! assert_eq!(AdeptLine::BASIS_SIZE, 5); // Φ̃(q) = (c1, s1, c12, s12, 1), the paper's
//!
//! // The truth, off the drawing by millimetres and milliradians (the model's order).
//! let truth = [0.3762, 0.004, 0.4241, -0.003, -1.8, -0.55];
//! let sim = simulate(&AdeptLine, &spec, 60, 7, Some(&truth), Noise::default())?;
//! let est = calibrate_spec(&AdeptLine, &spec, &sim.poses, CalibrateOptions::default())?;
//!
//! // A line sees the arm only up to scale: the length ratio and the home offsets.
//! let value = |n: &str| est.params.iter().find(|p| p.name == n).map(|p| p.value);
//! let ratio = value("a2").zip(value("a1")).map(|(a2, a1)| a2 / a1);
//! assert!((ratio.unwrap_or(0.0) - 0.4241 / 0.3762).abs() < 1e-9);
//! assert!((value("th2").unwrap_or(0.0) + 0.003).abs() < 1e-9);
//! println!("{}", lincal::report::calibrate_text(&AdeptLine, &est));
//! # Ok::<(), lincal::Error>(())
//! ```
//!
//! A spec read at run time (`lincal::symbolic::SymbolicModel::from_spec`) is a
//! [`CalibModel`] too, and the command line takes that path.

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
