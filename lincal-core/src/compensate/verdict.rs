//! What a solve's end means: `ok`, or the reason the compensated joints must not be used.
//!
//! In the order they are judged:
//! - `diverged`: the target was not reached within the tolerance (out of reach of the
//!   calibrated arm, or the iteration stalled);
//! - `singular`: the target was reached, but the correction is amplified: the gain
//!   `‖q′ − q₀‖ / ‖e(q₀)‖` exceeds [`SolveOptions::max_gain`], which a regular Jacobian with
//!   smallest singular value `σ_min` bounds by `1/σ_min`; the message gives `σ_min` of `J(q′)`;
//! - `limit`: a joint of `q′` lies beyond its limits (the spec's `limits:`);
//! - `branch`: the configuration changed between seed and solution. The task Jacobian maps
//!   joint steps to tool motion; moving within one branch, `J(q′)` stays close to `J(q₀)`, and
//!   crossing a singularity reverses one direction of it. The test is the sign of
//!   `det(J(q′)·J(q₀)ᵀ)` (`m ≤ n`; `det(J(q₀)ᵀ·J(q′))` for `m > n`): for a square task the sign
//!   of `det J(q′)·det J(q₀)` (an elbow or wrist flip), for a redundant one the orientation of
//!   `J(q′)·J(q₀)⁺`, positive on the seed's branch. It is not judged when either Jacobian is
//!   singular to rounding (a seed on a singularity has no side).

use super::solve::{Solution, SolveOptions};
use nalgebra::DMatrix;

/// The outcome of one target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Status {
    /// Reached, regular, within limits, on the seed's branch.
    Ok,
    /// A joint beyond its limits.
    Limit,
    /// The correction amplified by a near-singular Jacobian.
    Singular,
    /// A configuration flip between seed and solution.
    Branch,
    /// The target was not reached.
    Diverged,
}

impl Status {
    /// Every status, `ok` first (the order of summaries).
    pub const ALL: [Status; 5] = [
        Status::Ok,
        Status::Limit,
        Status::Singular,
        Status::Branch,
        Status::Diverged,
    ];

    /// The name written in the status column: `ok`, `limit`, `singular`, `branch`,
    /// `diverged`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Limit => "limit",
            Status::Singular => "singular",
            Status::Branch => "branch",
            Status::Diverged => "diverged",
        }
    }
}

/// A status and the sentence that explains it (empty for `ok`).
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// The status.
    pub status: Status,
    /// Why (the joint and its limit, the gain and `σ_min`, ...); empty for `ok`.
    pub message: String,
}

/// What [`judge`] reads besides the solution: the seed, the task Jacobians at the seed and at
/// the solution (`m × n`, row-major), the joints' limits.
pub struct Evidence<'a> {
    /// The seed `q₀`.
    pub seed: &'a [f64],
    /// `J(q₀)`.
    pub jac_seed: &'a [f64],
    /// `J(q′)`.
    pub jac_end: &'a [f64],
    /// Task rows `m`.
    pub rows: usize,
    /// Each joint's limits, if any (empty: none).
    pub limits: &'a [Option<[f64; 2]>],
}

/// Smallest singular value of an `m × n` row-major matrix (of the `min(m, n)` ones).
#[must_use]
pub fn sigma_min(jac: &[f64], m: usize, n: usize) -> f64 {
    let a = DMatrix::from_row_slice(m, n, jac);
    let sv = a.singular_values();
    sv.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The verdict on `sol` (see the module docs).
#[must_use]
pub fn judge(sol: &Solution, ev: &Evidence<'_>, opts: &SolveOptions) -> Verdict {
    let n = ev.seed.len();
    // σ_min only where a message states it: two SVDs per target were a sixth of the time.
    let smin = || sigma_min(ev.jac_end, ev.rows, n);
    let verdict = |status, message| Verdict { status, message };
    if !sol.converged {
        let smin = smin();
        // The orientation's error only where the target has one (a pose target's rows).
        let rotation = if ev.rows > 3 {
            format!(" (and {:.3e} rad)", sol.orientation_error)
        } else {
            String::new()
        };
        return verdict(
            Status::Diverged,
            format!(
                "not reached after {} iterations: {:.3e} m{rotation} from the target \
                 (σ_min of the Jacobian {smin:.3e})",
                sol.iterations, sol.position_error
            ),
        );
    }
    let correction = distance(&sol.q, ev.seed);
    if correction > opts.max_gain * sol.start_error {
        let smin = smin();
        return verdict(
            Status::Singular,
            format!(
                "the correction {correction:.3e} is {:.0}× the error {:.3e} it corrects (bound \
                 {}×): σ_min of the Jacobian is {smin:.3e}",
                correction / sol.start_error.max(f64::MIN_POSITIVE),
                sol.start_error,
                opts.max_gain
            ),
        );
    }
    if let Some(message) = beyond_limits(&sol.q, ev.limits) {
        return verdict(Status::Limit, message);
    }
    if flipped(ev) {
        return verdict(
            Status::Branch,
            "the configuration flipped between seed and solution (det(J(q')·J(q0)ᵀ) changed \
             sign): the solution lies on another branch"
                .into(),
        );
    }
    verdict(Status::Ok, String::new())
}

/// `‖a − b‖` (the correction's size): the one Euclidean distance of the crate.
pub use crate::calibrate::constraint_fit::distance;

/// The first joint of `q` beyond its limits, as a sentence.
fn beyond_limits(q: &[f64], limits: &[Option<[f64; 2]>]) -> Option<String> {
    q.iter().zip(limits).enumerate().find_map(|(i, (&v, lim))| {
        let [lo, hi] = (*lim)?;
        (v < lo || v > hi).then(|| {
            format!(
                "joint {} would be at {v:.6}, beyond its limits [{lo}, {hi}]",
                i + 1
            )
        })
    })
}

/// Whether the configuration flipped (see the module docs); `false` when either Jacobian is
/// singular to rounding (σ_min at most `10⁻⁹` of the larger Frobenius norm), which is only
/// checked when the sign says flipped (most targets keep it, and skip two SVDs).
fn flipped(ev: &Evidence<'_>) -> bool {
    let (m, n) = (ev.rows, ev.seed.len());
    let j0 = DMatrix::from_row_slice(m, n, ev.jac_seed);
    let j1 = DMatrix::from_row_slice(m, n, ev.jac_end);
    let d = if m <= n {
        (&j1 * j0.transpose()).determinant()
    } else {
        (j0.transpose() * &j1).determinant()
    };
    if d > 0.0 {
        return false;
    }
    let scale = j0.norm().max(j1.norm());
    sigma_min(ev.jac_seed, m, n) > 1e-9 * scale && sigma_min(ev.jac_end, m, n) > 1e-9 * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sol(q: Vec<f64>, start_error: f64) -> Solution {
        Solution {
            q,
            position_error: 0.0,
            orientation_error: 0.0,
            start_error,
            iterations: 3,
            converged: true,
        }
    }

    #[test]
    fn each_failure_is_named() {
        let opts = SolveOptions::default();
        const ID: [f64; 4] = [1.0, 0.0, 0.0, 1.0];
        const FLIP: [f64; 4] = [1.0, 0.0, 0.0, -1.0];
        let ev = |seed: &'static [f64], end: &'static [f64]| Evidence {
            seed,
            jac_seed: &[1.0, 0.0, 0.0, 1.0],
            jac_end: end,
            rows: 2,
            limits: &[Some([-1.0, 1.0]), None],
        };
        let ok = judge(&sol(vec![0.001, 0.0], 1e-3), &ev(&[0.0, 0.0], &ID), &opts);
        assert_eq!(ok.status, Status::Ok);
        let amplified = judge(&sol(vec![0.5, 0.0], 1e-3), &ev(&[0.0, 0.0], &ID), &opts);
        assert_eq!(amplified.status, Status::Singular);
        assert!(amplified.message.contains("σ_min"));
        let lim = judge(
            &sol(vec![1.0005, 0.0], 1e-3),
            &ev(&[0.9999, 0.0], &ID),
            &opts,
        );
        assert_eq!(lim.status, Status::Limit, "{}", lim.message);
        assert!(lim.message.contains("joint 1"));
        let br = judge(&sol(vec![0.001, 0.0], 1e-3), &ev(&[0.0, 0.0], &FLIP), &opts);
        assert_eq!(br.status, Status::Branch);
        let mut far = sol(vec![0.0, 0.0], 1e-3);
        far.converged = false;
        assert_eq!(
            judge(&far, &ev(&[0.0, 0.0], &ID), &opts).status,
            Status::Diverged
        );
    }
}
