//! The fit from the nominals with deterministic restarts about them, and the check that the
//! winner has not collapsed the arm (joints that no longer move the tip).
//!
//! Takes the model and the poses; gives the best [`GeometricEstimate`] and the starts tried.

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;

use super::estimate::{fit, GeometricEstimate};

/// Deterministic restarts about the nominals tried by [`fit_from_nominal`] after the nominal
/// start itself.
pub const RESTARTS: usize = 6;

/// Restarts stop once this many of them have ended at the best cost found (no better one
/// since): far starts that all return to one minimum.
pub const CONFIRMATIONS: usize = 2;

/// Relative cost difference below which two fits ended at the same minimum.
const SAME_COST: f64 = 1e-6;

/// Restarts run only when one linearisation costs at most this many flops (`m·n²`, about
/// 2 ms): on larger data sets the nominal start alone is taken.
pub const RESTART_WORK: f64 = 1e6;

/// [`fit`] from the nominals, then from [`RESTARTS`] deterministic perturbations of them
/// (free angles by up to ±0.5 rad, free lengths by up to ±20 % of the largest nominal length);
/// the lowest cost wins. Returns the estimate and how many starts were tried.
///
/// # Errors
/// As [`fit`] for the nominal start.
pub fn fit_from_nominal(
    model: &dyn CalibModel,
    poses: &Poses,
) -> Result<(GeometricEstimate, usize)> {
    use rand::{Rng, SeedableRng};
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let first = fit(model, poses, &nominal)?;
    let mut collapsed = collapsed_joints(model, poses, &nominal, &first.p);
    let mut best = first;
    let scale = (0..np)
        .filter(|&j| !model.param_is_angle(j))
        .fold(0.1f64, |m, j| m.max(nominal[j].abs()));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x1a2b);
    let mut tried = 1;
    // Restarts are for small data sets (where a start is cheap and a far local minimum is
    // likeliest); a large one has long since pulled the fit into the right basin.
    let work = best.components as f64 * (best.free.len() as f64).powi(2);
    let restarts = if work <= RESTART_WORK { RESTARTS } else { 0 };
    // Starts that end where the best one did (same cost, to `SAME_COST`).
    let mut confirmed = 0;
    for _ in 0..restarts {
        // Far starts that all come back to the best minimum: a landscape with one basin
        // about the nominals, where more starts would only repeat it.
        if confirmed >= CONFIRMATIONS && collapsed.is_empty() {
            break;
        }
        // An exact fit needs no more starts: the cost per component is tiny against the
        // data's scale.
        let rms = (best.cost / best.components.max(1) as f64).sqrt();
        if rms <= 1e-9 * scale && collapsed.is_empty() {
            break;
        }
        let start: Vec<f64> = (0..np)
            .map(|j| {
                if model.param_held(j) {
                    nominal[j]
                } else if model.param_is_angle(j) {
                    nominal[j] + 0.5 * rng.gen_range(-1.0..1.0)
                } else {
                    nominal[j] + 0.2 * scale * rng.gen_range(-1.0..1.0)
                }
            })
            .collect();
        tried += 1;
        if let Ok(e) = fit(model, poses, &start) {
            let c = collapsed_joints(model, poses, &nominal, &e.p);
            // A mechanism that stopped moving is no answer, however well it fits.
            let better = if c.is_empty() == collapsed.is_empty() {
                e.cost < best.cost * (1.0 - 1e-9)
            } else {
                c.is_empty()
            };
            let same = !better && c.is_empty() && e.cost <= best.cost * (1.0 + SAME_COST);
            if better {
                best = e;
                collapsed = c;
                confirmed = 0;
            } else if same {
                confirmed += 1;
            }
        }
    }
    if !collapsed.is_empty() {
        let names: Vec<String> = collapsed.iter().map(|i| format!("q{}", i + 1)).collect();
        return Err(Error::degenerate(format!(
            "the fit from the nominals collapses the arm: joint(s) {} no longer move the tip, a degenerate mechanism that satisfies the constraint trivially; use enough poses for the linear start (at least K per constraint, `lincal basis` gives K), or hold a length (`known: true`)",
            names.join(", ")
        )));
    }
    Ok((best, tried))
}

/// Joints that move the tip at the nominals but (almost) not at `p`: the RMS over the poses
/// of `‖∂x/∂q_i‖` (central differences; this is a check, not a fit) falls below `10⁻⁶` of
/// its nominal value.
#[must_use]
pub fn collapsed_joints(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    p: &[f64],
) -> Vec<usize> {
    let dim = model.dim();
    let nj = model.joint_count();
    let step = poses.len().div_ceil(64).max(1);
    let speed = |params: &[f64], i: usize| {
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        let mut sum = 0.0;
        for q in poses.q.iter().step_by(step) {
            let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
            qp[i] += 1e-4;
            qm[i] -= 1e-4;
            model.tip(&qp, params, &mut a[..dim]);
            model.tip(&qm, params, &mut b[..dim]);
            sum += (0..dim).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
        }
        sum.sqrt()
    };
    (0..nj)
        .filter(|&i| {
            let nom = speed(nominal, i);
            nom > 0.0 && speed(p, i) < 1e-6 * nom
        })
        .collect()
}
