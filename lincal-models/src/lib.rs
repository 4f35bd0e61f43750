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
//! | [`Puma560Plane`] | `puma560_plane.yaml` | PUMA 560, 6 joints (DH) | unknown plane |
//! | [`Puma560PoseFrames`] | `puma560_pose_frames.yaml` | PUMA 560, 6 joints (DH), twists known | measured pose (6-DOF tracker; tracker and tool frames unknown) |
//! | [`Ur5Tracker`] | `ur5_tracker.yaml` | Universal Robots UR5 | measured (laser tracker, unknown frame) |
//! | [`AbbIrb120BallBar`] | `abb_irb120_ballbar.yaml` | ABB IRB 120 | sphere of known radius (ball bar), unknown centre |
//! | [`AdeptOneScara`] | `adept_one_scara.yaml` | AdeptOne SCARA, 4 axes (J3 prismatic) | unknown plane |
//!
//! Read at run time only (`lincal basis SPEC`, `SymbolicModel::from_spec`, well under a
//! second each), because their generated code would lengthen every build of this crate
//! (the straight-line `c(p)` and `∂c/∂p` grow with `K` times the equations times the
//! parameters): `puma560_mdh_plane.yaml` (`K` = 195, the MDH twin of [`Puma560Plane`]),
//! `stanford_arm_tracker.yaml` (`K` = 216, three equations), `puma560_sphere.yaml`
//! (`K` = 271), `ur10_tracker.yaml` (every twist unknown, `K` = 729),
//! `franka_panda_sockets.yaml` (three unknown sockets, `K` = 1291),
//! `kuka_iiwa14_point.yaml` (one unknown socket, `K` = 1275) and `puma560_pose_tracker.yaml`
//! (the twin of [`Puma560PoseFrames`] with every twist unknown, `K` = 729 and 12 equations:
//! its `c(p)` and `∂c/∂p` would be about nine million straight-line operations). Beyond a few hundred the
//! linear method would also need that many poses, so those fits start from the nominals. The crate's README section
//! "Model library" tabulates every spec's basis and identifiability.
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

pub mod abb;
pub mod adept;
pub mod planar;
pub mod puma560;
pub mod scara;
pub mod ur;

pub use abb::AbbIrb120BallBar;
pub use adept::{AdeptOne, AdeptOneScara};
pub use planar::{Planar3Line, Planar3Point};
pub use puma560::{Elbow3Line, Puma560Plane, Puma560PoseFrames};
pub use scara::ScaraPlane;
pub use ur::Ur5Tracker;
