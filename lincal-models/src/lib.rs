//! # lincal-models
//!
//! Ready calibration models, each derived at compile time from a spec in `specs/` with
//! `#[derive(CalibModel)]`: one module per robot family, every model re-exported here.
//!
//! | model | spec | robot | constraint |
//! |---|---|---|---|
//! | [`AdeptOne`] | `adept_one.yaml` | AdeptOne joints 1-2 (planar) | unknown line |
//! | [`Planar3Line`] | `planar3_line.yaml` | planar 3-link arm | unknown line |
//! | [`Planar3Point`] | `planar3_point.yaml` | planar 3-link arm | unknown point |
//! | [`ScaraPlane`] | `scara_plane.yaml` | SCARA RRP | unknown plane |
//! | [`Elbow3Line`] | `elbow3_line.yaml` | PUMA 560 joints 1-3 | unknown 3-D line |
//! | [`Puma560Plane`] | `puma560_plane.yaml` | PUMA 560, 6 joints | unknown plane |
//!
//! `specs/puma560_sphere.yaml` is read at run time only (`lincal basis`): its symbolic
//! expansion takes seconds, too long to repeat in every build.
//!
//! # Example
//! ```
//! use lincal_core::model::CalibModel;
//! use lincal_models::AdeptOne;
//!
//! assert_eq!(AdeptOne::BASIS_SIZE, 5);
//! let phi = AdeptOne::basis(&[0.3, -0.2]);
//! let c = AdeptOne::generalized_params(&AdeptOne::NOMINALS);
//! let h: f64 = phi.iter().zip(&c).map(|(f, c)| f * c).sum();
//! // The same model as a trait object, as the solver takes it.
//! let m: &dyn CalibModel = &AdeptOne;
//! assert_eq!(m.identifiable_count(), 4);
//! # let _ = h;
//! ```
#![warn(missing_docs)]

pub mod adept;
pub mod planar;
pub mod puma560;
pub mod scara;

pub use adept::AdeptOne;
pub use planar::{Planar3Line, Planar3Point};
pub use puma560::{Elbow3Line, Puma560Plane};
pub use scara::ScaraPlane;
