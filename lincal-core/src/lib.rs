//! # lincal-core
//!
//! Robot kinematic calibration by the linear generalized-parameter method of Sayeh & Newman:
//! the forward kinematics of a Denavit-Hartenberg chain is rearranged as `x = M(p)·Φ(q)`, a
//! constraint on the tip becomes `c(p)·Φ̃(q) = 0` (with `c·Φ̃ + 1 = 0` in the paper's
//! normalised form), linear in the generalized parameters `c`, which one least-squares solve
//! finds without an initial guess; the physical parameters are then extracted from `c`.
//!
//! Data flows one way:
//! `spec` → `symbolic` (expand, reduce, identify) → `SymbolicModel` → `solve` → `extract` →
//! `refine` → `report`.
//!
//! # Features
//! - `std` (default): the engine: `numeric`, `spec` (YAML), `symbolic`, `program`, `data`
//!   (CSV), `fit`, `calibrate`, `report` (text and JSON), `simulate`. Without it only
//!   [`model`] (the [`CalibModel`] trait, [`model::chain`], [`model::geometry`]) and the
//!   `__private` helpers generated code uses are compiled, so derived models build for firmware
//!   (`no_std`).
//! - `urdf` (default; implies `std`): URDF in and out, the `urdf` module (`quick-xml`, read
//!   by a streamed reader of its own). The spec's `urdf:` record is part of the spec format
//!   and checked without it (`spec::urdf_record`).
//! - `html` (default; implies `std`): the HTML report, the `html` module (`plotters`, `sha2`).
//!
//! The derive and `lincal-models` use `std` alone, so the proc-macro's host build compiles
//! no plotting, XML or hashing.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

pub mod model;

pub use model::geometry::{ConstraintKind, Relation, RelationKind};
pub use model::CalibModel;

#[cfg(feature = "std")]
pub mod cancel;
#[cfg(feature = "std")]
pub mod cores;
#[cfg(feature = "std")]
pub mod error;
#[cfg(feature = "std")]
pub mod spec;
#[cfg(feature = "std")]
pub mod symbolic;

#[cfg(feature = "std")]
pub use error::Error;

/// Items generated code reaches through absolute paths. Not public API.
#[doc(hidden)]
pub mod __private {
    pub use crate::model::chain::{tip_jacobian, Axis, Factor, Term};
    pub use crate::model::factored::Tables;
    pub use crate::model::geometry::{ConstraintKind, Relation, RelationKind};
    pub use crate::model::CalibModel;
    pub use libm;

    /// The first `N` values of `s` as an array reference (derived models' trait methods take
    /// slices, their inherent functions arrays).
    ///
    /// # Panics
    /// If `s` holds fewer than `N` values, like indexing past its end.
    #[inline]
    #[must_use]
    pub fn head<const N: usize>(s: &[f64]) -> &[f64; N] {
        match s.get(..N).map(<&[f64; N]>::try_from) {
            Some(Ok(a)) => a,
            _ => panic!("a slice of {} values where {} are needed", s.len(), N),
        }
    }
}

#[cfg(feature = "std")]
pub mod numeric;

#[cfg(feature = "std")]
pub mod program;

#[cfg(feature = "std")]
pub mod data;
#[cfg(feature = "urdf")]
pub mod urdf;

#[cfg(feature = "std")]
pub mod fit;
#[cfg(feature = "std")]
pub mod select;

#[cfg(feature = "std")]
pub mod calibrate;

#[cfg(feature = "std")]
pub mod compensate;

#[cfg(feature = "std")]
pub mod report;

#[cfg(feature = "std")]
pub mod simulate;

#[cfg(feature = "std")]
pub mod progress;
