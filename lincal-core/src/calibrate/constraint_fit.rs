//! How well each constraint of a list, and each relation, is met: by the nominal model and
//! by the calibrated one.
//!
//! Per constraint `j` with poses `L_j`: the RMS geometric residual
//! `sqrt(Σ_{l∈L_j} ‖g_l‖² / |L_j|)` and, for a pinned point, the spread of the predicted tips
//! `sqrt(Σ_{l∈L_j} ‖x_l − x̄_j‖² / |L_j|)` (what a user sees as "the ball wanders by this much
//! in the socket"; it does not depend on where the spec puts the point). Per relation: what it
//! measures ([`crate::fit::relation::achieved`]) on the constraints' values, where a pinned point's
//! value is the mean predicted tip `x̄_j` of its poses (the data's own socket position).

use crate::data::Poses;
use crate::model::geometry::{ConstraintKind, Relation, RelationKind};
use crate::model::CalibModel;

/// One constraint's fit, nominal and calibrated.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConstraintFit {
    /// Index in the constraint list.
    pub constraint: usize,
    /// The interface's kind name (`point`, `plane`, …).
    pub kind: &'static str,
    /// Poses on this constraint.
    pub poses: usize,
    /// RMS residual at the nominal parameters, metres.
    pub residual_rms_nominal: f64,
    /// RMS residual at the calibrated parameters, metres.
    pub residual_rms: f64,
    /// Pinned points: RMS distance of the nominal model's tips from their mean, metres.
    pub spread_nominal: Option<f64>,
    /// Pinned points: the same for the calibrated model.
    pub spread: Option<f64>,
}

/// One relation, nominal and calibrated.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RelationFit {
    /// `distance`, `same_normal` or `offset`.
    pub kind: &'static str,
    /// The two constraint indices.
    pub between: [usize; 2],
    /// The stated distance (metres), `None` for `same_normal`.
    pub value: Option<f64>,
    /// What the nominal model achieves (metres; radians between the normals for
    /// `same_normal`).
    pub nominal: f64,
    /// What the calibrated model achieves.
    pub calibrated: f64,
}

/// Two pinned points of a list: the distance between the means of their predicted tips
/// (MUKCa's KPI, what a user measures), nominal and calibrated.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointDistance {
    /// The two constraint indices.
    pub between: [usize; 2],
    /// The stated distance of a `distance` relation between them, metres (`None` without one).
    pub value: Option<f64>,
    /// `‖x̄_i − x̄_j‖` of the nominal model's mean tips, metres.
    pub nominal: f64,
    /// `‖x̄_i − x̄_j‖` of the calibrated model's mean tips, metres.
    pub calibrated: f64,
}

/// The value of a `distance` relation between constraints `i` and `j` (either order), if any.
#[must_use]
pub fn distance_relation(model: &dyn CalibModel, i: usize, j: usize) -> Option<f64> {
    model
        .relations()
        .iter()
        .find(|r| r.kind == RelationKind::Distance && (r.between == [i, j] || r.between == [j, i]))
        .map(|r| r.value)
}

/// `‖a − b‖`.
#[must_use]
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Every pair of pinned points with poses: the distance between their mean tips `means0`
/// (nominal) and `means1` (calibrated), each constraint's values with a point's moved to its
/// mean tip.
fn point_distances(
    model: &dyn CalibModel,
    counts: &[ConstraintSums],
    means0: &[Vec<f64>],
    means1: &[Vec<f64>],
) -> Vec<PointDistance> {
    let dim = model.dim();
    let nc = model.constraint_count();
    let point = |j: usize| model.constraint_kind(j) == ConstraintKind::Point && counts[j].count > 0;
    let mut out = Vec::new();
    for i in (0..nc).filter(|&i| point(i)) {
        for j in (i + 1..nc).filter(|&j| point(j)) {
            out.push(PointDistance {
                between: [i, j],
                value: distance_relation(model, i, j),
                nominal: distance(&means0[i][..dim], &means0[j][..dim]),
                calibrated: distance(&means1[i][..dim], &means1[j][..dim]),
            });
        }
    }
    out
}

/// Per-constraint sums over the poses at one parameter vector.
#[derive(Clone, Debug, Default)]
pub(crate) struct ConstraintSums {
    count: usize,
    d2: f64,
    /// Σ (x − shift), Σ ‖x − shift‖²: the tips about a shift near them (no lost digits).
    s1: [f64; 3],
    s2: f64,
}

impl ConstraintSums {
    /// Adds each constraint's next chunk of sums `part` into `total` (chunks in pose order).
    pub(crate) fn merge(total: &mut [ConstraintSums], part: &[ConstraintSums]) {
        for (t, s) in total.iter_mut().zip(part) {
            t.count += s.count;
            t.d2 += s.d2;
            for i in 0..3 {
                t.s1[i] += s.s1[i];
            }
            t.s2 += s.s2;
        }
    }
}

/// The constraints' values at one parameter vector, and the shift of each constraint's tips:
/// a pinned point's tips are taken about the point itself; other kinds need no spread.
pub(crate) struct PointShifts {
    values: Vec<Vec<f64>>,
    shift: Vec<[f64; 3]>,
    dim: usize,
}

impl PointShifts {
    /// The values and shifts of `model`'s constraints at `p`.
    pub(crate) fn new(model: &dyn CalibModel, p: &[f64]) -> PointShifts {
        let dim = model.dim();
        let nc = model.constraint_count();
        let values: Vec<Vec<f64>> = (0..nc)
            .map(|j| {
                let mut v = vec![0.0; model.constraint_kind(j).value_count(dim)];
                model.constraint_values(j, p, &mut v);
                v
            })
            .collect();
        let shift: Vec<[f64; 3]> = (0..nc)
            .map(|j| {
                let mut s = [0.0; 3];
                if model.constraint_kind(j) == ConstraintKind::Point {
                    s[..dim].copy_from_slice(&values[j][..dim]);
                }
                s
            })
            .collect();
        PointShifts { values, shift, dim }
    }

    /// Adds a pose of constraint `j` (tip `tip`, squared residual `d2`) to `acc`.
    pub(crate) fn add(&self, acc: &mut [ConstraintSums], j: usize, tip: &[f64], d2: f64) {
        let a = &mut acc[j];
        a.count += 1;
        a.d2 += d2;
        for (i, (&x, &s)) in tip.iter().zip(&self.shift[j]).take(self.dim).enumerate() {
            let u = x - s;
            a.s1[i] += u;
            a.s2 += u * u;
        }
    }

    /// The constraints' values with each pinned point's value moved to its poses' mean tip
    /// (for the relations), given the totals `total`.
    pub(crate) fn means(self, model: &dyn CalibModel, total: &[ConstraintSums]) -> Vec<Vec<f64>> {
        let mut values = self.values;
        for (j, t) in total.iter().enumerate() {
            if model.constraint_kind(j) == ConstraintKind::Point && t.count > 0 {
                for (i, v) in values[j].iter_mut().take(self.dim).enumerate() {
                    *v = self.shift[j][i] + t.s1[i] / t.count as f64;
                }
            }
        }
        values
    }
}

/// The sums of each constraint at `p`, and each constraint's values there.
fn sums(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> (Vec<ConstraintSums>, Vec<Vec<f64>>) {
    let nc = model.constraint_count();
    let points = PointShifts::new(model, p);
    let parts = crate::fit::geometric::fold_poses(
        model,
        poses,
        p,
        || vec![ConstraintSums::default(); nc],
        |acc, l, tip, d2| points.add(acc, poses.constraint.at(l), tip, d2),
    );
    let mut total = vec![ConstraintSums::default(); nc];
    for part in parts {
        ConstraintSums::merge(&mut total, &part);
    }
    let values = points.means(model, &total);
    (total, values)
}

fn rms(s: &ConstraintSums) -> f64 {
    (s.d2 / s.count.max(1) as f64).sqrt()
}

fn spread(s: &ConstraintSums, dim: usize) -> f64 {
    let n = s.count.max(1) as f64;
    let mean2: f64 = s.s1[..dim].iter().map(|x| (x / n).powi(2)).sum();
    (s.s2 / n - mean2).max(0.0).sqrt()
}

/// Each constraint's and each relation's fit at the nominal parameters `nominal` and at the
/// calibrated `p`.
#[must_use]
pub fn constraint_fits(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    p: &[f64],
) -> (Vec<ConstraintFit>, Vec<RelationFit>) {
    let (c, r, _) = constraint_fits_with(model, poses, nominal, sums(model, poses, p));
    (c, r)
}

/// [`constraint_fits`] with the calibrated sums and values already summed (by the pipeline's
/// one residual pass), and the distances between pinned points' mean tips.
pub(crate) fn constraint_fits_with(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    calibrated: (Vec<ConstraintSums>, Vec<Vec<f64>>),
) -> (Vec<ConstraintFit>, Vec<RelationFit>, Vec<PointDistance>) {
    let dim = model.dim();
    let (s0, v0) = sums(model, poses, nominal);
    let (s1, v1) = calibrated;
    let constraints = (0..model.constraint_count())
        .map(|j| {
            let kind = model.constraint_kind(j);
            let point = kind == ConstraintKind::Point;
            ConstraintFit {
                constraint: j,
                kind: kind.name(),
                poses: s1[j].count,
                residual_rms_nominal: rms(&s0[j]),
                residual_rms: rms(&s1[j]),
                spread_nominal: point.then(|| spread(&s0[j], dim)),
                spread: point.then(|| spread(&s1[j], dim)),
            }
        })
        .collect();
    let relations = model
        .relations()
        .iter()
        .filter(|r| r.between.iter().all(|&j| j < model.constraint_count()))
        .map(|r: &Relation| {
            let [i, j] = r.between;
            RelationFit {
                kind: r.kind.name(),
                between: r.between,
                value: r.kind.has_value().then_some(r.value),
                nominal: crate::fit::relation::achieved(r, dim, &v0[i], &v0[j]),
                calibrated: crate::fit::relation::achieved(r, dim, &v1[i], &v1[j]),
            }
        })
        .collect();
    let distances = point_distances(model, &s1, &v0, &v1);
    (constraints, relations, distances)
}
