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

/// The poses on each constraint.
fn pose_counts(model: &dyn CalibModel, poses: &Poses) -> Vec<usize> {
    (0..model.constraint_count())
        .map(|j| poses.constraint.iter().filter(|&c| c == j).count())
        .collect()
}

/// Whether the start of [`plan_start`] is worth deciding after a fit from the nominals
/// rather than before it: with [`StartChoice::Auto`], when the linear method is within
/// reach of the pose counts and the model could only rule it out now by a sampled proof of
/// `K` while `K` is being learnt on the other core ([`CalibModel::basis_exceeds_pending`]).
/// The fit from the nominals is then the one [`plan_start`] chooses whenever `K` turns out
/// too large, and it overlaps the build instead of the proof.
pub(super) fn speculate_nominal(
    model: &dyn CalibModel,
    poses: &Poses,
    choice: StartChoice,
) -> bool {
    // Nothing pending at any `t` (no build ahead, or `K` known): no pass over the poses.
    if choice != StartChoice::Auto || !model.basis_exceeds_pending(0) {
        return false;
    }
    let kstar = largest_auto_k(model, &pose_counts(model, poses));
    kstar > 0 && model.basis_exceeds_pending(kstar)
}

/// The most operations [`StartChoice::Linear`] accepts for its smallest solve (`2K` poses of
/// each constraint, `K²` each): about a minute on one core. Beyond, it is refused by name
/// rather than run for hours (a 9-joint arm with every parameter unknown: `K` = 19 683,
/// 7.7·10¹² at 20 000 poses).
pub const LINEAR_LIMIT: f64 = 2e11;

/// The most terms of expansion [`StartChoice::Auto`] builds the basis within (whatever
/// `--max-terms` allows `lincal basis` and `--start linear`): under a second and a few
/// hundred megabytes, the default bound before `--max-terms` grew to hold 9-joint arms. A
/// larger expansion is seconds and gigabytes (a 9-joint arm with every DH parameter unknown
/// and a measured pose: 15 million terms of `c(p)`, `K` = 19 683) for a basis whose linear
/// solve the automatic start could seldom afford ([`LINEAR_BUDGET`]); the fit then starts
/// from the nominals.
pub const AUTO_MAX_TERMS: usize = 500_000;

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
    let counts = pose_counts(model, poses);
    match choice {
        StartChoice::Nominal => return Ok(Plan::Nominal(None)),
        StartChoice::Auto => {
            let kstar = largest_auto_k(model, &counts);
            if kstar == 0 || model.basis_exceeds(kstar) == Some(true) {
                return Ok(Plan::Nominal(None));
            }
            if let Err(why) = model.basis_ready_within(AUTO_MAX_TERMS) {
                return Ok(Plan::Nominal(Some(format!(
                    "the linear method was not tried: its basis is beyond the expansion's \
                     bound ({why}; an automatic start expands at most {AUTO_MAX_TERMS} terms); \
                     the fit started from the nominals (`--start linear` builds it within \
                     --max-terms)"
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
            linear_within_reach(model, &counts)?;
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

/// Whether `--start linear` can run: every constraint with poses has enough of them for the
/// basis, and its smallest solve is within [`LINEAR_LIMIT`]; the error says why not.
fn linear_within_reach(model: &dyn CalibModel, counts: &[usize]) -> Result<()> {
    let nc = counts.len();
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
        // A null vector of K columns takes K − 1 poses; a measured tip's regression K.
        return Err(Error::degenerate(format!(
            "the linear method needs K − 1 poses per constraint for a basis of K = {k} \
                 functions (K − 1 for a null vector, K for measured tips): {}; use --start \
                 auto or nominal",
            if short.is_empty() {
                "no constraint has poses".to_string()
            } else {
                short.join("; ")
            }
        )));
    }
    // Even the smallest subset the method takes (2K poses of each constraint) must
    // be a solve of minutes, not hours.
    let least: f64 = (0..nc)
        .map(|j| counts[j].min(2 * need(model, j, k)) as f64 * (k * k) as f64)
        .sum();
    if least > LINEAR_LIMIT {
        return Err(Error::degenerate(format!(
            "the linear method on a basis of K = {k} functions would cost about \
                 {least:.1e} operations (its data matrix of K² = {} entries per pose, on at \
                 least {} poses): beyond {LINEAR_LIMIT:.0e}, many minutes to hours on one core; use \
                 --start auto or nominal (the parameter-space fit needs no basis)",
            k * k,
            (0..nc)
                .map(|j| counts[j].min(2 * need(model, j, k)))
                .sum::<usize>()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::fit_stage::SPECULATED;
    use crate::calibrate::{calibrate_spec, CalibrateOptions};
    use crate::simulate::{simulate, Noise};
    use crate::spec::from_yaml_file;
    use crate::symbolic::prefetch::DELAY;
    use crate::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
    use std::time::Duration;

    /// A fit that starts from the nominals while `K` is still being built, and plans its start
    /// after ([`speculate_nominal`]), ends exactly where the fit that proves `K` large first
    /// ends: with too few poses for the linear method (the nominal fit kept) and with enough
    /// (the linear start taken after all), the same estimate to the bit, the same start,
    /// method, warnings and `K`. The build ahead is held back, so that `K` is not yet there
    /// when the fit starts and the speculation surely runs (a counter checks that it did).
    #[test]
    fn planning_the_start_after_the_nominal_fit_changes_nothing() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/specs");
        let opts = CalibrateOptions::default();
        let mut linear_after = 0;
        for name in [
            "plane_spatial",
            "measured_spatial",
            "circle_planar3",
            "sphere_mdh",
        ] {
            let path = format!("{dir}/{name}.yaml");
            let spec = from_yaml_file(std::path::Path::new(&path)).expect("spec");
            let k = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS)
                .expect("model")
                .basis_size();
            // Below `K - 1` poses the linear method is out of reach; at `3K` within.
            for n in [k - 2, 3 * k] {
                let proving = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS).expect("model");
                let noise = Noise {
                    track: 1e-5,
                    measure: 1e-5,
                    ..Noise::default()
                };
                let poses = simulate(&proving, &spec, n, 11, None, noise)
                    .expect("simulate")
                    .poses;
                let want = calibrate_spec(&proving, &spec, &poses, opts).expect("fit");
                DELAY.with(|d| d.set(Duration::from_millis(300)));
                let ahead = SymbolicModel::for_fitting_prefetching(&spec, DEFAULT_MAX_TERMS, None);
                DELAY.with(|d| d.set(Duration::ZERO));
                let ahead = ahead.expect("model");
                let what = format!("{name}, {n} poses");
                let before = SPECULATED.with(std::cell::Cell::get);
                let got = calibrate_spec(&ahead, &spec, &poses, opts).expect("fit");
                assert_eq!(
                    SPECULATED.with(std::cell::Cell::get),
                    before + 1,
                    "{what}: the start was not planned after the nominal fit"
                );
                assert_eq!(got.start, want.start, "{what}");
                assert_eq!(got.method, want.method, "{what}");
                assert_eq!(got.basis_size, Some(k), "{what}");
                assert_eq!(got.basis_size, want.basis_size, "{what}");
                assert_eq!(got.linear_poses, want.linear_poses, "{what}");
                assert_eq!(
                    got.residual_rms.to_bits(),
                    want.residual_rms.to_bits(),
                    "{what}"
                );
                assert_eq!(got.warnings, want.warnings, "{what}");
                assert_eq!(got.params.len(), want.params.len(), "{what}");
                for (g, w) in got.params.iter().zip(&want.params) {
                    assert_eq!(g.value.to_bits(), w.value.to_bits(), "{what}: {}", g.name);
                    let bits = |s: Option<f64>| s.map(f64::to_bits);
                    assert_eq!(bits(g.std), bits(w.std), "{what}: std of {}", g.name);
                }
                linear_after += usize::from(got.start == "linear");
            }
        }
        // Both outcomes were seen: the nominal fit kept, and discarded for the linear start.
        assert!(
            linear_after >= 2,
            "linear start after speculation {linear_after} times"
        );
    }
}
