//! The residuals at the estimate, computed once: every pose's geometric distance `‖g_l‖` from
//! its constraint, the tips' sums (RMS residual, spread, reach, the farthest pose), the robust
//! scale, and per constraint of a list the sums its fit report needs. Statistics, warnings,
//! the outlier test and the worst-pose list all read this one pass ([`Residuals`]).
//!
//! The robust scale is `σ̂ = med_l(‖g_l‖ / χ̃_{m_l})`, `χ̃_m` the median of a χ distribution
//! with the pose's `m_l` residual components ([`crate::numeric::robust::chi_median`]).

use crate::calibrate::constraint_fit::{ConstraintSums, PointShifts};
use crate::data::Poses;
use crate::error::{Error, Location, Result};
use crate::fit::geometric::fold_poses;
use crate::model::CalibModel;
use crate::numeric::robust::{chi_median, median_of};

/// What one pass over the poses at an estimate gives.
pub(super) struct Residuals {
    /// `‖g_l‖` of every pose, in pose order (metres).
    pub(super) norms: Vec<f64>,
    /// The tips' statistics (`inertia_rms` only when asked for, else NaN).
    pub(super) stats: TipStatistics,
    /// The robust scale of the norms (NaN below 10 poses, where a median means little).
    pub(super) scale: f64,
    /// Per constraint, the sums of its fit report (when asked for), and the constraints'
    /// values with each pinned point moved to its poses' mean tip.
    pub(super) constraints: Option<(Vec<ConstraintSums>, Vec<Vec<f64>>)>,
}

/// One chunk's share of the pass.
struct PassSums {
    norms: Vec<f64>,
    tips: TipSums,
    constraints: Vec<ConstraintSums>,
}

impl Residuals {
    /// The pass at `p`: with `inertia`, the tips' smallest scatter too (a second pass in the
    /// plane, for the paper's planar-line figure); with `per_constraint`, each constraint's
    /// sums (for a list or relations).
    pub(super) fn at(
        model: &dyn CalibModel,
        poses: &Poses,
        p: &[f64],
        inertia: bool,
        per_constraint: bool,
    ) -> Residuals {
        let dim = model.dim();
        let shift = first_tip(model, poses, p);
        let points = per_constraint.then(|| PointShifts::new(model, p));
        let nc = if per_constraint {
            model.constraint_count()
        } else {
            0
        };
        let init = || PassSums {
            norms: Vec::new(),
            tips: TipSums::ZERO,
            constraints: vec![ConstraintSums::default(); nc],
        };
        let parts = fold_poses(model, poses, p, init, |a: &mut PassSums, l, tip, d2| {
            a.norms.push(d2.sqrt());
            a.tips.add(dim, &shift, l, tip, d2);
            if let Some(points) = &points {
                points.add(&mut a.constraints, poses.constraint.at(l), tip, d2);
            }
        });
        let mut tips = TipSums::ZERO;
        let mut sums = vec![ConstraintSums::default(); nc];
        let mut norms = Vec::with_capacity(parts.len());
        for part in parts {
            tips.merge(&part.tips);
            ConstraintSums::merge(&mut sums, &part.constraints);
            norms.push(part.norms);
        }
        let norms = concat_parts(norms);
        let scale = robust_scale(model, poses, &norms);
        let stats = tip_statistics_from(model, poses, p, shift, &tips, inertia);
        let constraints = points.map(|pts| {
            let values = pts.means(model, &sums);
            (sums, values)
        });
        Residuals {
            norms,
            stats,
            scale,
            constraints,
        }
    }
}

/// Every pose's residual norm at `p`, and their robust scale (see
/// [`crate::calibrate::estimate::Estimate::robust_scale`]; NaN below 10 poses): the norms
/// alone, for the reweighting rounds of a fit.
pub(super) fn residual_scale(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (f64, Vec<f64>) {
    let x = norms_at(model, poses, p);
    (robust_scale(model, poses, &x), x)
}

/// `‖g_l‖` of every pose at `p`, in pose order.
fn norms_at(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Vec<f64> {
    // Norms only (8 bytes a pose; a million poses stay light), component counts on demand.
    let parts = fold_poses(model, poses, p, Vec::new, |v: &mut Vec<f64>, _, _, d2| {
        v.push(d2.sqrt());
    });
    concat_parts(parts)
}

/// `med_l(x_l / χ̃_{m_l})` of the residual norms `x` (NaN below 10 poses).
fn robust_scale(model: &dyn CalibModel, poses: &Poses, x: &[f64]) -> f64 {
    if x.len() < 10 {
        f64::NAN
    } else {
        median_of(x.len(), |l| x[l] / chi_median(components(model, poses, l)))
    }
}

/// The per-chunk vectors of [`fold_poses`] as one, growing the first in place (a large block
/// is remapped, not copied) and dropping each other as it is taken: the residuals of a
/// million poses are not held twice.
fn concat_parts(parts: Vec<Vec<f64>>) -> Vec<f64> {
    let total: usize = parts.iter().map(Vec::len).sum();
    let mut parts = parts.into_iter();
    let Some(mut x) = parts.next() else {
        return Vec::new();
    };
    x.reserve_exact(total - x.len());
    for part in parts {
        x.extend(part);
    }
    x
}

/// Residual components of pose `l` (1 when its constraint index is out of range).
pub(super) fn components(model: &dyn CalibModel, poses: &Poses, l: usize) -> usize {
    poses
        .constraint
        .get(l)
        .map_or(1, |j| model.constraint_kind(j).residual_count(model.dim()))
}

/// Statistics of the calibrated tips.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TipStatistics {
    /// `sqrt(Σ_l ‖g_l‖² / N)`: RMS geometric distance from the constraint.
    pub residual_rms: f64,
    /// `sqrt(λ_min(I)/N)` of the tips' inertia (scatter) matrix about their centroid.
    pub inertia_rms: f64,
    /// `sqrt(Σ_l ‖x_l − x̄‖² / N)`: RMS distance of the tips from their centroid.
    pub spread: f64,
    /// `sqrt(Σ_l ‖x_l‖² / N)`: RMS distance of the tips from the base origin.
    pub reach: f64,
    /// The pose farthest from its constraint: `(pose index, distance ‖g_l‖)`.
    pub worst: (usize, f64),
}

/// Residual and spread of the tips at parameters `p`: one pass over the poses (in parallel
/// when many), a second in the plane.
#[must_use]
pub fn tip_statistics(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> TipStatistics {
    let (shift, t) = tip_sums(model, poses, p);
    tip_statistics_from(model, poses, p, shift, &t, true)
}

/// The statistics from the tip sums `t` about `shift`; the smallest scatter only with
/// `inertia` (NaN otherwise).
fn tip_statistics_from(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    shift: [f64; 3],
    t: &TipSums,
    inertia: bool,
) -> TipStatistics {
    let dim = model.dim();
    let n = poses.len().max(1) as f64;
    let mean: Vec<f64> = (0..dim).map(|i| shift[i] + t.s1[i] / n).collect();
    // Σ (x − m)(x − m)ᵀ = Σ uuᵀ − n·ūūᵀ with u = x − shift, ū its mean.
    let mut scatter = vec![0.0; dim * dim];
    for a in 0..dim {
        for b in 0..dim {
            scatter[a * dim + b] = t.s2[a][b] - t.s1[a] * t.s1[b] / n;
        }
    }
    let trace: f64 = (0..dim).map(|a| scatter[a * dim + a]).sum::<f64>().max(0.0);
    let inertia_rms = if inertia {
        (smallest_scatter(model, poses, p, &scatter, &mean) / n).sqrt()
    } else {
        f64::NAN
    };
    TipStatistics {
        residual_rms: (t.sum / n).sqrt(),
        inertia_rms,
        spread: (trace / n).sqrt(),
        reach: (t.reach / n).sqrt(),
        worst: (t.worst.0, t.worst.1.sqrt()),
    }
}

/// The sums [`tip_statistics`] needs, over the poses.
#[derive(Clone, Copy)]
struct TipSums {
    /// `Σ ‖g_l‖²`.
    sum: f64,
    /// The pose farthest from its constraint, with its `‖g_l‖²`.
    worst: (usize, f64),
    /// `Σ ‖x_l‖²`.
    reach: f64,
    /// `Σ u_l`, `u = x − shift`.
    s1: [f64; 3],
    /// `Σ u_l u_lᵀ`.
    s2: [[f64; 3]; 3],
}

impl TipSums {
    const ZERO: TipSums = TipSums {
        sum: 0.0,
        worst: (0, 0.0),
        reach: 0.0,
        s1: [0.0; 3],
        s2: [[0.0; 3]; 3],
    };

    /// Adds pose `l` (tip `tip`, squared residual `d2`), the tip shifted by `shift`.
    fn add(&mut self, dim: usize, shift: &[f64; 3], l: usize, tip: &[f64], d2: f64) {
        if d2 > self.worst.1 {
            self.worst = (l, d2);
        }
        self.sum += d2;
        for i in 0..dim {
            let u = tip[i] - shift[i];
            self.reach += tip[i] * tip[i];
            self.s1[i] += u;
            for k in 0..dim {
                self.s2[i][k] += u * (tip[k] - shift[k]);
            }
        }
    }

    /// Merges the next chunk's sums (chunks in pose order: deterministic).
    fn merge(&mut self, a: &TipSums) {
        if a.worst.1 > self.worst.1 {
            self.worst = a.worst;
        }
        self.sum += a.sum;
        self.reach += a.reach;
        for i in 0..3 {
            self.s1[i] += a.s1[i];
            for k in 0..3 {
                self.s2[i][k] += a.s2[i][k];
            }
        }
    }
}

/// The first pose's tip at `p`: the shift that keeps the scatter's digits when the tips are
/// far from the origin.
fn first_tip(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> [f64; 3] {
    let mut shift = [0.0; 3];
    if let Some(q0) = poses.q.first() {
        model.tip(q0, p, &mut shift[..model.dim()]);
    }
    shift
}

/// The tip sums at `p`, with the tips shifted by the first tip, merged chunk by chunk in pose
/// order; and that shift.
fn tip_sums(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> ([f64; 3], TipSums) {
    let dim = model.dim();
    let shift = first_tip(model, poses, p);
    let parts = fold_poses(
        model,
        poses,
        p,
        || TipSums::ZERO,
        |a: &mut TipSums, l, tip, d2| a.add(dim, &shift, l, tip, d2),
    );
    let mut t = TipSums::ZERO;
    for a in parts {
        t.merge(&a);
    }
    (shift, t)
}

/// The smallest eigenvalue of the tips' scatter matrix `scatter` (`dim × dim`, row-major;
/// the tips' centroid `mean`): in the plane from a second pass over the poses, accurately.
fn smallest_scatter(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    scatter: &[f64],
    mean: &[f64],
) -> f64 {
    let dim = model.dim();
    if dim == 2 {
        // The inertia matrix [[Σŷ², −Σx̂ŷ], [−Σx̂ŷ, Σx̂²]] has the scatter matrix's eigenvalues.
        // λ_min from the eigenvalue formula loses half the digits (√ε·spread after the square
        // root), so take the principal direction φ (accurate to ε) and sum the squared offsets
        // along its normal n in a second pass: λ_min = Σ (n·x̂_l)².
        let mut tip = vec![0.0; dim];
        let (a, b, c) = (scatter[0], scatter[1], scatter[3]);
        let phi = 0.5 * (2.0 * b).atan2(a - c);
        let (nx, ny) = (-phi.sin(), phi.cos());
        let mut s = 0.0;
        for q in &poses.q {
            model.tip(q, p, &mut tip);
            let d = nx * (tip[0] - mean[0]) + ny * (tip[1] - mean[1]);
            s += d * d;
        }
        s
    } else {
        let m = nalgebra::DMatrix::from_row_slice(dim, dim, scatter);
        m.try_symmetric_eigen(f64::EPSILON, 1000)
            .map_or(0.0, |e| e.eigenvalues.min().max(0.0))
    }
}

/// The geometric distance `‖g_l‖` of every pose's tip from its constraint at parameters `p`
/// (the model's estimated parameters), metres, in pose order: the values
/// [`crate::calibrate::estimate::Estimate::residual_rms`] is the RMS of (one pass, in parallel when there are many poses); for measured poses (`measured_pose`) the position error `‖x − x_m‖`.
///
/// # Example
/// A 2R arm (`a1 = 0.375`, `a2 = 0.425`) and the line `x = 0.8` (`b = (−1.25, 0)`): the
/// stretched arm touches it, the elbow bent by a right angle is 0.425 m from it.
/// ```
/// use lincal_core::calibrate::pose_residuals;
/// use lincal_core::data::{Poses, Rows};
/// let spec = lincal_core::spec::from_yaml_str(
///     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1}\n  \
///      - {type: revolute, a: a2}\nparams: {a1: {nominal: 0.375}, a2: {nominal: 0.425}}\n\
///      constraint: {line: {b: [-1.25, 0]}}\n",
///     None,
/// )
/// .unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// let poses = Poses {
///     q: Rows::from_vec(2, vec![0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2]).unwrap(),
///     constraint: lincal_core::data::PoseColumn::labels_from([0, 0]),
///     ..Poses::default()
/// };
/// let r = pose_residuals(&model, &poses, &[0.375, 0.425]).unwrap();
/// assert!(r[0].abs() < 1e-15 && (r[1] - 0.425).abs() < 1e-15);
/// ```
///
/// # Errors
/// [`crate::error::ErrorClass::Input`] when `p` is not of the model's length or a pose's constraint index
/// is out of range (naming the pose).
pub fn pose_residuals(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Result<Vec<f64>> {
    if p.len() != model.param_count() {
        return Err(Error::input(
            Location::default(),
            format!(
                "{} parameter values given, the model estimates {}",
                p.len(),
                model.param_count()
            ),
        ));
    }
    let count = model.constraint_count();
    if let Some(l) = poses.constraint.iter().position(|j| j >= count) {
        return Err(Error::input(
            Location {
                pose: Some(l),
                field: Some("constraint".to_string()),
                ..Location::default()
            },
            format!(
                "constraint index {} is out of range: the spec has {count} constraint(s)",
                poses.constraint.at(l)
            ),
        ));
    }
    if super::pose_errors::is_pose_model(model) {
        // Measured poses: the position error, in metres like every other residual (the
        // orientation error is `pose_errors::pose_error_norms`'s second vector).
        return finite_residuals(
            model,
            poses,
            super::pose_errors::pose_error_norms(model, poses, p).0,
        );
    }
    finite_residuals(model, poses, norms_at(model, poses, p))
}

/// `r` when every residual is finite; else the error naming the first pose whose residual is
/// not (constraint values that describe no constraint at these parameters: a line or plane
/// of zero normal, values of 10¹⁶⁰).
fn finite_residuals(model: &dyn CalibModel, poses: &Poses, r: Vec<f64>) -> Result<Vec<f64>> {
    match r.iter().position(|v| !v.is_finite()) {
        None => Ok(r),
        Some(l) => {
            let c = poses.constraint.at(l);
            Err(Error::new(
                crate::error::ErrorClass::Degenerate,
                Location {
                    pose: Some(l),
                    ..Location::default()
                },
                format!(
                    "the residual of pose {l}{} on constraint {c} ({}) is not finite at these \
                     parameters: its values describe no {} there (a zero normal, or values \
                     beyond any robot's scale)",
                    if poses.line.get(l).unwrap_or(0) > 0 {
                        format!(" ({})", poses.place(l))
                    } else {
                        String::new()
                    },
                    model.constraint_kind(c).name(),
                    model.constraint_kind(c).name()
                ),
            ))
        }
    }
}
