//! End-to-end tests: the `lincal` binary driven exactly as `shared/interface.md` defines it.
//! One test binary (modules), to keep link time low.

mod angles;
mod cache;
mod cases;
mod cli;
mod compensate;
mod docs;
mod errors;
mod hostile;
mod leftovers;
mod outliers;
mod outputs;
mod plane_normal;
mod pose;
mod relations;
mod report;
#[cfg(target_os = "linux")]
mod resource;
mod round3b;
mod round4;
mod roundtrip;
mod select;
mod shape;
mod urdf;
mod util;
mod validation;
