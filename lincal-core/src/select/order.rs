//! The order in which to visit the chosen poses, keeping joint motion short.
//!
//! Distance between joint vectors `a` and `b`: `max_k |a_k − b_k|` (joints move at the same
//! time, so a move lasts as long as its largest joint change; values are compared raw, no
//! angle wrapping, since joints travel the way their limits allow). The tour is an open path
//! (the robot need not come back): nearest neighbour from the first pose (or from the pose
//! nearest the given start, the start then being the path's fixed head), then 2-opt: a move
//! reverses a stretch of the path, including stretches that reach either end, and is taken
//! when it shortens the path; passes repeat until none does, at most [`MAX_EVALS`] move
//! evaluations in all, so the time is bounded and the result deterministic.

use super::types::SelectError;

/// Most 2-opt move evaluations.
pub const MAX_EVALS: usize = 50_000_000;

/// `max_k |a_k − b_k|`.
fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The length of the path visiting `joints` in `order` (after `start`, when given), with
/// the distance of the module documentation.
#[must_use]
pub fn tour_length(joints: &[Vec<f64>], order: &[usize], start: Option<&[f64]>) -> f64 {
    let legs: f64 = order
        .windows(2)
        .map(|w| dist(&joints[w[0]], &joints[w[1]]))
        .sum();
    match (start, order.first()) {
        (Some(s), Some(&f)) => legs + dist(s, &joints[f]),
        _ => legs,
    }
}

/// Checks that every joint vector (and the start) has the same length and finite values.
fn check(joints: &[Vec<f64>], start: Option<&[f64]>) -> Result<(), SelectError> {
    let len = start.map_or_else(|| joints.first().map_or(0, Vec::len), <[f64]>::len);
    for (i, q) in joints.iter().enumerate() {
        if q.len() != len {
            return Err(SelectError::Shape(format!(
                "pose {i} has {} joint values, {len} expected",
                q.len()
            )));
        }
        if q.iter().any(|v| !v.is_finite()) {
            return Err(SelectError::NonFiniteInput {
                what: "joint vector of pose",
                index: i,
            });
        }
    }
    if start.is_some_and(|s| s.iter().any(|v| !v.is_finite())) {
        return Err(SelectError::NonFiniteInput {
            what: "start joint vector",
            index: 0,
        });
    }
    Ok(())
}

/// The nearest-neighbour path: from the pose nearest `start` (pose 0 without one), always
/// to the nearest pose not yet visited, ties to the lowest index.
pub(crate) fn nearest_neighbour(joints: &[Vec<f64>], start: Option<&[f64]>) -> Vec<usize> {
    let p = joints.len();
    let mut left: Vec<bool> = vec![true; p];
    let mut order = Vec::with_capacity(p);
    let nearest = |from: &[f64], left: &[bool]| {
        let mut best: Option<(usize, f64)> = None;
        for (i, q) in joints.iter().enumerate() {
            if left[i] {
                let d = dist(from, q);
                if best.is_none_or(|(_, b)| d < b) {
                    best = Some((i, d));
                }
            }
        }
        best.map(|(i, _)| i)
    };
    let mut cur = match start {
        Some(s) => nearest(s, &left),
        None => (p > 0).then_some(0),
    };
    while let Some(c) = cur {
        left[c] = false;
        order.push(c);
        cur = nearest(&joints[c], &left);
    }
    order
}

/// 2-opt on the open path `order` (fixed head `start` when given); returns the move
/// evaluations used.
pub(crate) fn two_opt(
    joints: &[Vec<f64>],
    order: &mut [usize],
    start: Option<&[f64]>,
    budget: usize,
) -> usize {
    let l = order.len();
    let mut evals = 0;
    let mut improved = true;
    while improved && evals < budget {
        improved = false;
        let tol = 1e-12 * tour_length(joints, order, start).max(f64::MIN_POSITIVE);
        for i in 0..l {
            for k in i + 1..l {
                evals += 1;
                let (a, b) = (&joints[order[i]], &joints[order[k]]);
                let prev: Option<&[f64]> = if i > 0 {
                    Some(&joints[order[i - 1]])
                } else {
                    start
                };
                let mut delta = 0.0;
                if let Some(p) = prev {
                    delta += dist(p, b) - dist(p, a);
                }
                if k + 1 < l {
                    let nx = &joints[order[k + 1]];
                    delta += dist(a, nx) - dist(b, nx);
                }
                if delta < -tol {
                    order[i..=k].reverse();
                    improved = true;
                }
            }
            if evals >= budget {
                break;
            }
        }
    }
    evals
}

/// A visiting order of the poses with joint vectors `joints` (radians or metres), as a
/// permutation of `0..joints.len()`: nearest neighbour then bounded 2-opt (see the module
/// documentation). With `start`, the path begins at the start configuration.
///
/// # Errors
/// [`SelectError::Shape`] for joint vectors of different lengths,
/// [`SelectError::NonFiniteInput`] for a NaN or infinity.
pub fn visiting_order(
    joints: &[Vec<f64>],
    start: Option<&[f64]>,
) -> Result<Vec<usize>, SelectError> {
    check(joints, start)?;
    let mut order = nearest_neighbour(joints, start);
    two_opt(joints, &mut order, start, MAX_EVALS);
    Ok(order)
}
