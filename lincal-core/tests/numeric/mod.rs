//! The numeric pipeline: CSV loading, linear solve, extraction, refinement, calibrate.
pub mod models;
pub mod sim;

mod angles;
mod cases;
mod completeness;
mod csv;
mod degenerate;
mod fuzz;
mod kinds;
mod outliers;
mod param_path;
mod planar;
mod plane_normal;
mod pose;
mod prior_strength;
mod real_robots;
mod stream;
mod validation;
