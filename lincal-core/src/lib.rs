//! # lincal-core
//!
//! Robot kinematic calibration by the linear generalized-parameter method of Sayeh & Newman:
//! the forward kinematics of a Denavit-Hartenberg chain is rearranged as `x = M(p)·Φ(q)`, a
//! constraint on the tip becomes `c(p)·Φ̃(q) = 0` (with `c·Φ̃ + 1 = 0` in the paper's
//! normalised form), linear in the generalized parameters `c`, which one least-squares solve
//! finds without an initial guess; the physical parameters are then extracted from `c`.
//!
//! # The stages
//! Data flows one way, each stage a module that imports only from those before it (an
//! architecture test checks it):
//!
//! | stage | module | what it does |
//! |---|---|---|
//! | 0 | [`error`], [`progress`], [`cancel`], [`cores`], [`memory`] | errors that name their place, progress, Ctrl-C, threads, memory left |
//! | 1 | [`model`] | the [`CalibModel`] trait, the chain of elementary motions ([`model::chain`]), the factored kernel ([`model::factored`]); `no_std` |
//! | 2 | [`numeric`] | exact and modular arithmetic, linear algebra helpers |
//! | 3 | [`spec`] | the YAML spec: loading, validation with places, writing back |
//! | 4 | [`symbolic`] | spec → exact expansion → minimal basis `Φ̃(q)` and `c(p)` → identifiability and gauge |
//! | 5 | [`program`] | the straight-line programs and tables the derive prints |
//! | 6 | [`data`], [`urdf`] | CSV poses; URDF in and out |
//! | 7 | [`fit`] | the linear solve of `c·Φ̃ + 1 = 0`, extraction of the physical parameters, refinement |
//! | 8 | [`calibrate`] | the whole fit: start, prior chosen from the data, outliers, held-out judgement |
//! | 9 | [`report`] | text, JSON and the HTML report |
//! | 10 | [`simulate`] | simulated experiments from a stated truth |
//! | 11 | [`select`] | planning the poses worth measuring |
//! | 12 | [`compensate`] | joints that put the calibrated tool on a target, for a vendor controller |

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
pub mod memory;
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
