//! Outliers: poses beyond [`super::OUTLIER_SIGMAS`] robust standard deviations, the
//! [`super::WORST_SHOWN`] worst poses by standardised residual, and `--reject-outliers`' refits.

use super::checks::and_more;
use super::residuals::{components, Residuals};
use super::{calibrate_inner, CalibrateOptions, SpecParam, OUTLIER_SIGMAS, WORST_SHOWN};
use crate::calibrate::estimate::{Estimate, WorstPose};
use crate::data::Poses;
use crate::error::Result;
use crate::model::CalibModel;
use crate::numeric::robust::chi_median;
use crate::spec::Spec;

/// What [`calibrate_inner`] needs besides the poses, for the refits of
/// [`reject_outliers`].
pub(super) struct Job<'a> {
    pub(super) model: &'a dyn CalibModel,
    pub(super) params: &'a [SpecParam],
    pub(super) opts: CalibrateOptions,
    pub(super) spec: Option<&'a Spec>,
}

/// `--reject-outliers`: drop the outliers `out` of the first fit `first` (robust scale
/// `first_scale`), fit again, and repeat while the cleaner fit shows more (a fit pulled by
/// many bad rows hides some of them behind an inflated scale), at most 5 times. The last
/// fit, with the dropped poses listed (by residual) and a warning first.
pub(super) fn reject_outliers(
    job: &Job<'_>,
    poses: &Poses,
    progress: &dyn crate::progress::Progress,
    first: Estimate,
    out: Vec<WorstPose>,
    first_scale: f64,
) -> Result<Estimate> {
    const REJECT_ROUNDS: usize = 5;
    let model = job.model;
    let mut rejected = out;
    let mut keep: Vec<usize> = Vec::new();
    let mut again = first;
    for round in 0..REJECT_ROUNDS {
        crate::cancel::check()?;
        let mut bad: Vec<usize> = rejected.iter().map(|w| w.pose).collect();
        bad.sort_unstable();
        keep = (0..poses.len())
            .filter(|l| bad.binary_search(l).is_err())
            .collect();
        let inliers = poses.select(&keep);
        progress.stage(
            &format!("refit without outliers (round {})", round + 1),
            None,
        );
        let res;
        (again, res) =
            calibrate_inner(model, job.params, &inliers, job.opts, job.spec, Some(&keep))?;
        let (more, worst) = outliers(model, &inliers, &res);
        again.robust_scale = res.scale;
        // Pose indices stay those of the file.
        again.worst_poses = worst
            .into_iter()
            .map(|w| WorstPose {
                pose: keep[w.pose],
                ..w
            })
            .collect();
        // Only poses a further fit drops are reported as dropped.
        if more.is_empty() || round + 1 == REJECT_ROUNDS {
            break;
        }
        rejected.extend(more.into_iter().map(|w| WorstPose {
            pose: keep[w.pose],
            ..w
        }));
    }
    rejected.sort_by(|a, b| b.residual.total_cmp(&a.residual).then(a.pose.cmp(&b.pose)));
    again.warnings.insert(
        0,
        format!(
            "--reject-outliers dropped {} of {} poses (beyond {OUTLIER_SIGMAS} robust standard \
             deviations, σ ≈ {first_scale:.3e} m at the first fit): {}; the estimate uses the \
             other {}",
            rejected.len(),
            poses.len(),
            listed(&rejected),
            keep.len()
        ),
    );
    again.rejected = rejected;
    Ok(again)
}

/// The first [`WORST_SHOWN`] poses of `v` for a warning (pose, CSV line, residual), and how
/// many more there are.
pub(super) fn listed(v: &[WorstPose]) -> String {
    let shown: Vec<String> = v
        .iter()
        .take(WORST_SHOWN)
        .map(|w| format!("pose {} ({}) {:.3e} m", w.pose, w.place(), w.residual))
        .collect();
    and_more(&shown, v.len())
}

/// The residual (metres) below which no pose is an outlier: a nanometre is rounding, not
/// measurement (laser trackers resolve micrometres), so exact data, whose robust scale is
/// itself rounding (about 10⁻¹⁶ m), flags no pose for lying 5 such scales out.
pub(super) const ROUNDING_FLOOR: f64 = 1e-9;

/// From the residual pass `res` (robust scale `σ̂`, see [`Estimate::robust_scale`]): the
/// poses beyond [`OUTLIER_SIGMAS`] of it (descending residual) and beyond
/// [`ROUNDING_FLOOR`], and the [`WORST_SHOWN`] worst poses by standardised residual
/// ([`worst_poses`]). No outliers when the scale vanishes (exact data) or when fewer than 10
/// poses make a median meaningless.
pub(super) fn outliers(
    model: &dyn CalibModel,
    poses: &Poses,
    res: &Residuals,
) -> (Vec<WorstPose>, Vec<WorstPose>) {
    let (scale, d) = (res.scale, &res.norms);
    let worst = worst_poses(model, poses, d, scale);
    if !(scale > 0.0 && scale.is_finite()) {
        return (Vec::new(), worst);
    }
    // The threshold per pose: OUTLIER_SIGMAS·σ on the residual norm, raised by the χ median
    // so a pose with more components is not flagged for having them.
    let mut out: Vec<WorstPose> = d
        .iter()
        .enumerate()
        .filter(|&(l, &x)| {
            x > ROUNDING_FLOOR
                && x > OUTLIER_SIGMAS * scale * chi_median(components(model, poses, l)).max(1.0)
        })
        .map(|(l, &x)| WorstPose {
            pose: l,
            line: poses.line.at(l),
            file: poses.files.name(l).map(str::to_string),
            residual: x,
            standardized: standardized(x, scale, components(model, poses, l)),
            pose_parts: None,
        })
        .collect();
    out.sort_by(|a, b| b.residual.total_cmp(&a.residual).then(a.pose.cmp(&b.pose)));
    (out, worst)
}

/// The standardised residual `z = x / (scale·χ̃_m)` of a pose with residual norm `x` and `m`
/// components (see [`WorstPose::standardized`]); `None` when the scale is not positive and
/// finite.
pub(super) fn standardized(x: f64, scale: f64, m: usize) -> Option<f64> {
    (scale > 0.0 && scale.is_finite()).then(|| x / (scale * chi_median(m)))
}

/// The [`WORST_SHOWN`] poses farthest from their constraint, given every pose's residual
/// norm `d` and the robust scale `scale`: ordered by standardised residual
/// ([`WorstPose::standardized`]), which puts poses of constraints with different numbers of
/// residual components on one footing; by residual when the scale is undefined (fewer than
/// 10 poses, exact data). Ties go to the lower pose index.
pub(super) fn worst_poses(
    model: &dyn CalibModel,
    poses: &Poses,
    d: &[f64],
    scale: f64,
) -> Vec<WorstPose> {
    let z = |l: usize, x: f64| standardized(x, scale, components(model, poses, l));
    // The sort key: z where defined, else the residual (the same for every pose).
    let key = |l: usize, x: f64| z(l, x).unwrap_or(x);
    let order = |a: &(f64, usize), b: &(f64, usize)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    let keep = |v: &mut Vec<(f64, usize)>| {
        v.sort_by(order);
        v.truncate(WORST_SHOWN);
    };
    // One pass keeping the largest few (memory O(WORST_SHOWN), a million poses stay light).
    let mut top: Vec<(f64, usize)> = Vec::with_capacity(8 * WORST_SHOWN);
    for (l, &x) in d.iter().enumerate() {
        top.push((key(l, x), l));
        if top.len() >= 8 * WORST_SHOWN {
            keep(&mut top);
        }
    }
    keep(&mut top);
    top.into_iter()
        .map(|(_, l)| WorstPose {
            pose: l,
            line: poses.line.at(l),
            file: poses.files.name(l).map(str::to_string),
            residual: d[l],
            standardized: z(l, d[l]),
            pose_parts: None,
        })
        .collect()
}
