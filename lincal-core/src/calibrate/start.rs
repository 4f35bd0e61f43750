//! Where the fit starts: the linear method (on every pose, or an evenly spread subset within
//! [`super::LINEAR_BUDGET`]) or the nominals, from the poses per constraint and the basis size.

use super::{StartChoice, LINEAR_BUDGET};
use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// The start [`calibrate`] takes.
pub(super) enum Plan {
    /// The linear method, on every pose (`None`) or on the listed ones.
    Linear(Option<Vec<usize>>),
    /// The nominals.
    Nominal,
}

/// Chooses the start: the linear method when every constraint with poses has at least `K`
/// of them (its data matrix can then determine `c`) and its cost `Σ_j N_j·K²` fits
/// [`LINEAR_BUDGET`], on an evenly spread subset when only that fits; else the nominals.
pub(super) fn plan_start(
    model: &dyn CalibModel,
    poses: &Poses,
    choice: StartChoice,
) -> Result<Plan> {
    let k = model.basis_size();
    let nc = model.constraint_count();
    let counts: Vec<usize> = (0..nc)
        .map(|j| poses.constraint.iter().filter(|&c| c == j).count())
        .collect();
    // A measured constraint regresses each coordinate on the basis: K columns; the others
    // need K − 1 poses for a null vector of K columns.
    let need = |j: usize| {
        if model.constraint_kind(j) == ConstraintKind::Measured {
            k
        } else {
            k.saturating_sub(1).max(1)
        }
    };
    let enough =
        (0..nc).all(|j| counts[j] == 0 || counts[j] >= need(j)) && counts.iter().any(|&c| c > 0);
    let kk = (k * k) as f64;
    let cap = ((LINEAR_BUDGET / kk) as usize).max(1);
    match choice {
        StartChoice::Nominal => return Ok(Plan::Nominal),
        StartChoice::Linear if !enough => {
            let short: Vec<String> = (0..nc)
                .filter(|&j| counts[j] > 0 && counts[j] < need(j))
                .map(|j| format!("constraint {j} has {} poses, needs {}", counts[j], need(j)))
                .collect();
            return Err(Error::degenerate(format!(
                "the linear method needs at least K = {k} poses per constraint ({}); use --start auto or nominal",
                short.join("; ")
            )));
        }
        StartChoice::Linear => {}
        StartChoice::Auto => {
            // Each group needs about 2K poses for a well-posed linear start; when even that
            // exceeds the budget, the nominals are the cheaper start.
            let min_cost: f64 = (0..nc)
                .filter(|&j| counts[j] > 0)
                .map(|j| (2 * need(j)).min(counts[j]) as f64 * kk)
                .sum();
            if !enough || min_cost > LINEAR_BUDGET {
                return Ok(Plan::Nominal);
            }
        }
    }
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
        let take = of_j.len().min(share.max(2 * need(j)));
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
