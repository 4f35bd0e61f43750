//! URDF in and out: `lincal import` and `lincal calibrate --write-urdf`.
//!
//! - [`read`]: the links and joints of a URDF, streamed (bounded depth and memory).
//! - [`chain`]: the serial chain between two links of a URDF and its forward kinematics.
//! - [`import()`]: that chain as a Denavit-Hartenberg spec (standard or modified) whose
//!   nominals reproduce the URDF exactly, every geometric entry a named parameter, with a
//!   `urdf:` record ([`UrdfRecord`]) of where it came from.
//! - [`write_urdf`]: the URDF with the calibrated joint origins (home offsets folded in),
//!   the rest of the file untouched.
//! - [`numeric`]: a spec's chain frame by frame; [`frame`]: rigid transforms.

mod axes;
pub mod chain;
pub mod frame;
pub mod import;
mod native;
mod normal;
pub mod numeric;
mod points;
pub mod read;
pub mod write;
mod xml;

pub use axes::NEAR_PARALLEL;
pub use chain::UrdfChain;
pub use import::{import, ConstraintChoice, ImportOptions, Imported, SNAP_PARALLEL};
pub use numeric::NumChain;
pub use record::UrdfRecord;
pub use write::{urdf_base_values, write_urdf};

/// The spec's `urdf:` record (part of the spec format, so it lives with the spec loader and
/// is checked without this module's feature).
pub use crate::spec::urdf_record as record;
pub use crate::spec::write::num_exact;

pub(crate) use crate::spec::urdf_record::num;
