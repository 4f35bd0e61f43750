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
//! | [`Puma560MdhPlane`] | `puma560_mdh_plane.yaml` | PUMA 560, modified DH | unknown plane |
//! | [`Puma560Sphere`] | `puma560_sphere.yaml` | PUMA 560 (DH) | unknown sphere |
//! | [`Puma560PoseTracker`] | `puma560_pose_tracker.yaml` | PUMA 560, every twist unknown | measured pose, 12 equations |
//! | [`StanfordArmTracker`] | `stanford_arm_tracker.yaml` | Stanford arm (prismatic joint 3) | measured |
//! | [`Ur10Tracker`] | `ur10_tracker.yaml` | UR10, every twist unknown | measured (laser tracker) |
//! | [`FrankaPandaSockets`] | `franka_panda_sockets.yaml` | Franka Panda, 7 joints (MDH) | three unknown points |
//! | [`KukaIiwa14Point`] | `kuka_iiwa14_point.yaml` | KUKA LBR iiwa 14, 7 joints | unknown point |
//! | [`Arm7AllUnknownPoint`] | `arm7_all_unknown_point.yaml` | 7R arm, all 28 DH parameters unknown | unknown point |
//!
//! Every spec is derived. Small models print `Φ̃(q)`, `c(p)` and `∂c/∂p` as straight-line
//! code; beyond a few thousand terms the derived model embeds the chain-factored tables
//! (pivots and the basis's terms, one code per joint) and evaluates them with the kernel of
//! `lincal_core::model::factored`, so the generated code no longer grows with `K` times the
//! parameters. `docs/08-derive.md` (*Model library*) tabulates every spec's basis and identifiability.
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
pub mod franka;
pub mod kuka;
pub mod planar;
pub mod puma560;
pub mod scara;
pub mod stanford;
pub mod ur;

pub use abb::AbbIrb120BallBar;
pub use adept::{AdeptOne, AdeptOneScara};
pub use franka::FrankaPandaSockets;
pub use kuka::{Arm7AllUnknownPoint, KukaIiwa14Point};
pub use planar::{Planar3Line, Planar3Point};
pub use puma560::{
    Elbow3Line, Puma560MdhPlane, Puma560Plane, Puma560PoseFrames, Puma560PoseTracker, Puma560Sphere,
};
pub use scara::ScaraPlane;
pub use stanford::StanfordArmTracker;
pub use ur::{Ur10Tracker, Ur5Tracker};
