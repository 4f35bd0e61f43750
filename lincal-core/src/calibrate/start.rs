//! Where the fit starts: the linear method (on every pose, or an evenly spread subset within
//! [`super::LINEAR_BUDGET`]) or the nominals, from the poses per constraint and the basis size.

use super::{StartChoice, LINEAR_BUDGET};
use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;

/// The start [`calibrate`] takes.
pub(super) enum Plan {
    /// The linear method, on every pose (`None`) or on the listed ones.
    Linear(Option<Vec<usize>>),
    /// The nominals; with a note for the report when the linear method was possible by the
    /// pose counts but its basis could not be built.
    Nominal(Option<String>),
}

/// How many poses constraint `j` needs for the linear method at basis size `k`: a measured
/// constraint regresses each coordinate on the basis (`K` columns); the others need `K − 1`
/// poses for a null vector of `K` columns.
fn need(model: &dyn CalibModel, j: usize, k: usize) -> usize {
    if model.constraint_kind(j).is_measured() {
        k
    } else {
        k.saturating_sub(1).max(1)
    }
}

/// Whether [`StartChoice::Auto`] takes the linear method at basis size `k`: every constraint
/// with poses has enough of them, and about `2K` poses of each fit [`LINEAR_BUDGET`].
fn auto_linear(model: &dyn CalibModel, counts: &[usize], k: usize) -> bool {
    let enough = (0..counts.len()).all(|j| counts[j] == 0 || counts[j] >= need(model, j, k))
        && counts.iter().any(|&c| c > 0);
    let kk = (k * k) as f64;
    let min_cost: f64 = (0..counts.len())
        .filter(|&j| counts[j] > 0)
        .map(|j| (2 * need(model, j, k)).min(counts[j]) as f64 * kk)
        .sum();
    enough && min_cost <= LINEAR_BUDGET
}

/// The largest `K` at which [`auto_linear`] holds (0 when none): it holds for every smaller
/// `K` too (fewer poses needed, a cheaper solve), so a bisection finds it.
fn largest_auto_k(model: &dyn CalibModel, counts: &[usize]) -> usize {
    let (mut lo, mut hi) = (0, counts.iter().copied().max().unwrap_or(0) + 2);
    while hi - lo > 1 {
        let mid = usize::midpoint(lo, hi);
        if auto_linear(model, counts, mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Chooses the start: the linear method when every constraint with poses has at least `K`
/// of them (its data matrix can then determine `c`) and its cost `Σ_j N_j·K²` fits
/// [`LINEAR_BUDGET`], on an evenly spread subset when only that fits; else the nominals.
/// With [`StartChoice::Auto`], a `K` proved too large for the poses
/// ([`CalibModel::basis_exceeds`]) decides for the nominals without building the basis.
pub(super) fn plan_start(
    model: &dyn CalibModel,
    poses: &Poses,
    choice: StartChoice,
) -> Result<Plan> {
    let nc = model.constraint_count();
    let counts: Vec<usize> = (0..nc)
        .map(|j| poses.constraint.iter().filter(|&c| c == j).count())
        .collect();
    match choice {
        StartChoice::Nominal => return Ok(Plan::Nominal(None)),
        StartChoice::Auto => {
            let kstar = largest_auto_k(model, &counts);
            if kstar == 0 || model.basis_exceeds(kstar) == Some(true) {
                return Ok(Plan::Nominal(None));
            }
            if let Err(why) = model.basis_ready() {
                return Ok(Plan::Nominal(Some(format!(
                    "the linear method was not tried: its basis is beyond the expansion's \
                     bound ({why}); the fit started from the nominals"
                ))));
            }
            if !auto_linear(model, &counts, model.basis_size()) {
                return Ok(Plan::Nominal(None));
            }
        }
        StartChoice::Linear => {
            if let Err(why) = model.basis_ready() {
                return Err(Error::degenerate(format!(
                    "the linear method needs the basis, which is beyond the expansion's bound \
                     ({why}); use --start auto or nominal, or raise --max-terms"
                )));
            }
            let k = model.basis_size();
            let short: Vec<String> = (0..nc)
                .filter(|&j| counts[j] > 0 && counts[j] < need(model, j, k))
                .map(|j| {
                    format!(
                        "constraint {j} has {} poses, needs {}",
                        counts[j],
                        need(model, j, k)
                    )
                })
                .collect();
            if !short.is_empty() || counts.iter().all(|&c| c == 0) {
                return Err(Error::degenerate(format!(
                    "the linear method needs at least K = {k} poses per constraint ({}); use --start auto or nominal",
                    short.join("; ")
                )));
            }
        }
    }
    let k = model.basis_size();
    let kk = (k * k) as f64;
    let cap = ((LINEAR_BUDGET / kk) as usize).max(1);
    let total: f64 = counts.iter().map(|&c| c as f64 * kk).sum();
    if total <= LINEAR_BUDGET || choice == StartChoice::Linear && total <= 50.0 * LINEAR_BUDGET {
        return Ok(Plan::Linear(None));
    }
    // An evenly spread subset of each constraint's poses, at least 2K of each.
    let share = (cap / nc.max(1)).max(1);
    let mut idx = Vec::new();
    for j in 0..nc {
        let of_j: Vec<usize> = (0..poses.len())
            .filter(|&l| poses.constraint.at(l) == j)
            .collect();
        let take = of_j.len().min(share.max(2 * need(model, j, k)));
        if take == 0 {
            continue;
        }
        for t in 0..take {
            idx.push(of_j[t * of_j.len() / take]);
        }
    }
    idx.sort_unstable();
    Ok(Plan::Linear(Some(idx)))
}
