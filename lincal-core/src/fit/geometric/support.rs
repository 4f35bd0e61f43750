//! Whether the poses can determine the free parameters, checked before any expensive step:
//! enough residual components, joints that move, and a Jacobian of full column rank at a
//! generic point near the nominals.
//!
//! Takes the model and the poses; gives `Ok` or an [`Error::degenerate`] naming what is lost.

use nalgebra::DMatrix;

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;
use crate::numeric::lm::LeastSquares;

use super::estimate::{condition_of, spectrum_of, RANK_TOL};
use super::problem::GeometricFit;

/// Checks, before any expensive step, that the poses can determine the free parameters:
/// enough residual components, joints that move, and a Jacobian of full column rank at a
/// deterministic generic point near the nominals (`O(N·n²)`, one pass; on large data a pass
/// over a strided sample first, which settles it whenever the rank is full there).
///
/// # Errors
/// [`Error::degenerate`] naming what is lost.
pub fn check_support(model: &dyn CalibModel, poses: &Poses) -> Result<()> {
    let n = poses.len();
    if n == 0 {
        return Err(Error::degenerate("no poses in the data"));
    }
    let nj = model.joint_count();
    let moved: Vec<bool> = (0..nj)
        .map(|i| {
            let first = poses.q[0][i];
            poses.q.iter().any(|q| q[i] != first)
        })
        .collect();
    if n > 1 && moved.iter().all(|m| !m) {
        return Err(Error::degenerate(format!(
            "all {n} poses have the same joint readings: the data determines nothing"
        )));
    }
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let generic = generic_point(model, &nominal);
    let problem = GeometricFit::new(model, poses, &generic)?;
    let free = problem.unknowns();
    let m = problem.components();
    if m <= free {
        return Err(Error::degenerate(format!(
            "the {n} poses give {m} residual components for {free} free parameters: at least {} poses are needed",
            (n * (free + 1)).div_ceil(m.max(1))
        )));
    }
    // With relations, building the problem above already linearised every pose.
    if n >= 2 * SAMPLE
        && model.relations().is_empty()
        && full_rank_on_sample(model, poses, &generic, free)?
    {
        return Ok(());
    }
    let lin = problem.linearize(&problem.set.take(&generic))?;
    // The singular values alone settle it; `V` names the lost directions.
    let (_, rank) = condition_of(&lin.r)?;
    if rank < free {
        let (_, sv, v) = spectrum_of(&lin.r)?;
        let msg = lost_message(model, poses, &problem.set.free, &moved, &sv, &v);
        return Err(Error::degenerate(msg));
    }
    Ok(())
}

/// A lost combination may be the spec's, not the data's: an angle whose nominal is ±π/2
/// among its terms is, for a frame's pitch (the base, the tool, a URDF-native origin), the
/// point where roll and yaw turn about one axis and no data can tell them apart. Empty when
/// no lost direction holds such an angle.
fn gimbal_hint(model: &dyn CalibModel, free: &[usize], sv: &[f64], v: &DMatrix<f64>) -> String {
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut names: Vec<&str> = Vec::new();
    for (i, &s) in sv.iter().enumerate() {
        if s > RANK_TOL * smax {
            continue;
        }
        let col = v.column(i);
        let big = col.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for (c, x) in col.iter().enumerate() {
            let j = free[c];
            let nominal = model.param_nominal(j);
            let at_pole = (nominal.abs() - half_pi).abs() < 1e-6;
            if x.abs() >= 0.2 * big && model.param_is_angle(j) && at_pole {
                names.push(model.param_name(j));
            }
        }
    }
    names.sort_unstable();
    names.dedup();
    if names.is_empty() {
        return String::new();
    }
    format!(
        " ({} has the nominal ±π/2: if it is a frame's pitch, the base's, the tool's or a \
         URDF-native origin's, roll and yaw turn about one axis there and no poses can tell \
         them apart; move that nominal off ±90°, or write the frame another way)",
        names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Poses in the strided sample that [`check_support`] tries first on large data.
const SAMPLE: usize = 1024;

/// Whether the Jacobian of a strided sample of about [`SAMPLE`] poses (every stretch of the
/// recording in it) has full column rank with a margin: its smallest relative singular value
/// (columns equilibrated) above `100·RANK_TOL`. Its rows are rows of the whole data's
/// Jacobian, so in exact arithmetic a full rank here is a full rank there; the margin covers
/// what rounding and the other rows' column scaling can take from it. One pass over a
/// thousand poses instead of all of them. Anything short of that proves nothing (the sample
/// may miss what the rest shows, a constraint with few poses among them), and the caller
/// checks the whole data.
fn full_rank_on_sample(
    model: &dyn CalibModel,
    poses: &Poses,
    generic: &[f64],
    free: usize,
) -> Result<bool> {
    let stride = poses.len() / SAMPLE;
    let picked: Vec<usize> = (0..poses.len()).step_by(stride.max(1)).collect();
    let sample = poses.select(&picked);
    let problem = GeometricFit::new(model, &sample, generic)?;
    if problem.components() <= free {
        return Ok(false);
    }
    let lin = problem.linearize(&problem.set.take(generic))?;
    let (condition, rank) = condition_of(&lin.r)?;
    Ok(rank == free && condition < 0.01 / RANK_TOL)
}

/// The message for a rank-deficient Jacobian: the lost parameter combinations (from the
/// singular values `sv` and right-singular vectors `v` over the `free` parameters), the joints
/// that never `moved`, and the constraints without poses.
fn lost_message(
    model: &dyn CalibModel,
    poses: &Poses,
    free: &[usize],
    moved: &[bool],
    sv: &[f64],
    v: &DMatrix<f64>,
) -> String {
    let n = poses.len();
    let nj = model.joint_count();
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let mut lost = Vec::new();
    for (i, &s) in sv.iter().enumerate() {
        if s > RANK_TOL * smax {
            continue;
        }
        let col = v.column(i);
        let big = col.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let terms: Vec<String> = col
            .iter()
            .enumerate()
            .filter(|(_, x)| x.abs() >= 0.2 * big)
            .map(|(c, x)| format!("{x:+.2}·{}", model.param_name(free[c])))
            .collect();
        lost.push(terms.join(" "));
    }
    let mut msg = format!(
        "the {n} poses do not determine every free parameter; lost combination(s): {}",
        lost.join("; ")
    );
    msg.push_str(&gimbal_hint(model, free, sv, v));
    let frozen: Vec<String> = (0..nj)
        .filter(|&i| !moved[i])
        .map(|i| format!("q{}", i + 1))
        .collect();
    if !frozen.is_empty() {
        msg.push_str(&format!("; joints that never moved: {}", frozen.join(", ")));
    }
    let empty: Vec<String> = (0..model.constraint_count())
        .filter(|&j| !poses.constraint.iter().any(|c| c == j))
        .map(|j| j.to_string())
        .collect();
    if !empty.is_empty() {
        msg.push_str(&format!(
            "; constraints without poses: {}",
            empty.join(", ")
        ));
    }
    msg
}

/// A deterministic generic point about the nominals (free angles by up to 0.3 rad, free
/// lengths by up to 10 % of the largest nominal length): a nominal of exactly zero can hide
/// directions that any real arm has.
fn generic_point(model: &dyn CalibModel, nominal: &[f64]) -> Vec<f64> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x9e4e);
    let scale = (0..nominal.len())
        .filter(|&j| !model.param_is_angle(j))
        .fold(0.1f64, |m, j| m.max(nominal[j].abs()));
    (0..nominal.len())
        .map(|j| {
            let u: f64 = rng.gen_range(-1.0..1.0);
            if model.param_held(j) {
                nominal[j]
            } else if model.param_is_angle(j) {
                nominal[j] + 0.3 * u
            } else {
                nominal[j] + 0.1 * scale * u
            }
        })
        .collect()
}
