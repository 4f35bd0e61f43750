//! How poses are grouped when a fit is judged on poses it did not see: the prior's strength
//! choice ([`super::prior`]), `--folds` and the held-out figures all use this one rule.
//!
//! Poses of one placement (one constraint of a list: a socket, a plane, a tracker session
//! kept in its own file) share what the model leaves out at that placement (a fixture's
//! compliance, the arm's temperature that day), so a fold that holds out some poses of a
//! placement and fits the others judges the fit on errors it has already seen: interleaved
//! folds are optimistic on clustered data. So:
//! - poses on three or more constraints: one group per placement
//!   ([`Grouping::Placements`]), merged in turn into at most the folds asked for; a fit never
//!   sees the placement it is judged on;
//! - poses on one or two constraints: clusters in joint space ([`Grouping::Clusters`]).
//!   Two constraints are most often two sockets of one fixture in one session, and a fit on
//!   one pinned point alone leaves most of an arm unseen: held out against it, the other
//!   socket judges an extrapolation, not the fit. The clusters are k-means on
//!   each revolute joint's `(cos q, sin q)` and each prismatic joint's reading over its
//!   spread, seeded by farthest points from the first pose (deterministic): a fold holds
//!   out a region of the workspace, which is what a calibration is used on next.

use crate::data::Poses;
use crate::model::CalibModel;

/// Which grouping the folds follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Grouping {
    /// One group per placement (constraint of the list), merged into the folds.
    Placements,
    /// Clusters of the poses in joint space (one placement).
    Clusters,
}

impl Grouping {
    /// The word for the reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Grouping::Placements => "placements",
            Grouping::Clusters => "joint-space clusters",
        }
    }
}

/// Poses split into folds: `fold[l]` is pose `l`'s fold, `0..folds`, every fold non-empty.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Folds {
    /// Each pose's fold.
    pub fold: Vec<usize>,
    /// The number of folds (at least 1).
    pub folds: usize,
    /// The rule that made them.
    pub grouping: Grouping,
}

impl Folds {
    /// The poses of fold `f`, in order.
    #[must_use]
    pub fn members(&self, f: usize) -> Vec<usize> {
        (0..self.fold.len())
            .filter(|&l| self.fold[l] == f)
            .collect()
    }
}

/// At most `k` folds of `poses` (module docs): by placement when the poses lie on
/// [`MIN_PLACEMENTS`] or more constraints (as many folds as placements when those are fewer
/// than `k`), else `k` clusters in joint space (fewer when there are fewer distinct poses).
#[must_use]
pub fn folds(model: &dyn CalibModel, poses: &Poses, k: usize) -> Folds {
    let k = k.max(1);
    let mut used: Vec<usize> = poses.constraint.iter().collect();
    used.sort_unstable();
    used.dedup();
    if used.len() >= MIN_PLACEMENTS {
        let folds = used.len().min(k);
        let fold = poses
            .constraint
            .iter()
            .map(|c| used.binary_search(&c).map_or(0, |r| r % folds))
            .collect();
        return Folds {
            fold,
            folds,
            grouping: Grouping::Placements,
        };
    }
    clusters(model, poses, k)
}

/// The fewest placements (constraints with poses) the folds are made of (module docs).
pub const MIN_PLACEMENTS: usize = 3;

/// Lloyd's iterations of the k-means clustering; it settles long before on real data.
const KMEANS_ROUNDS: usize = 30;

/// `k` clusters of the poses in joint space (module docs), whatever the placements.
#[must_use]
pub fn clusters(model: &dyn CalibModel, poses: &Poses, k: usize) -> Folds {
    let points = features(model, poses);
    let n = points.len();
    if n == 0 {
        return Folds {
            fold: Vec::new(),
            folds: 1,
            grouping: Grouping::Clusters,
        };
    }
    // Farthest-point seeds from the first pose: deterministic and spread out.
    let mut centers: Vec<Vec<f64>> = vec![points[0].clone()];
    let mut nearest: Vec<f64> = points.iter().map(|x| dist2(x, &points[0])).collect();
    while centers.len() < k {
        let (far, d) = nearest
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (i, &d)| if d > b.1 { (i, d) } else { b });
        if d <= 0.0 {
            break; // fewer distinct poses than folds
        }
        centers.push(points[far].clone());
        for (x, m) in points.iter().zip(&mut nearest) {
            *m = m.min(dist2(x, &points[far]));
        }
    }
    let mut fold = vec![0; n];
    for _ in 0..KMEANS_ROUNDS {
        let mut changed = false;
        for (x, f) in points.iter().zip(&mut fold) {
            let best = (0..centers.len())
                .min_by(|&a, &b| dist2(x, &centers[a]).total_cmp(&dist2(x, &centers[b])))
                .unwrap_or(0);
            changed |= best != *f;
            *f = best;
        }
        for (c, center) in centers.iter_mut().enumerate() {
            let members: Vec<&Vec<f64>> = points
                .iter()
                .zip(&fold)
                .filter(|(_, &f)| f == c)
                .map(|(x, _)| x)
                .collect();
            if members.is_empty() {
                continue; // keeps its seed; relabelled below if it stays empty
            }
            for (t, v) in center.iter_mut().enumerate() {
                *v = members.iter().map(|x| x[t]).sum::<f64>() / members.len() as f64;
            }
        }
        if !changed {
            break;
        }
    }
    // Folds numbered in order of first appearance, none empty.
    let mut label = vec![usize::MAX; centers.len()];
    let mut next = 0;
    for f in &mut fold {
        if label[*f] == usize::MAX {
            label[*f] = next;
            next += 1;
        }
        *f = label[*f];
    }
    Folds {
        fold,
        folds: next.max(1),
        grouping: Grouping::Clusters,
    }
}

/// Each pose as a point of joint space: `(cos q, sin q)` of a revolute joint, a prismatic
/// joint's reading over its spread in the data (so a metre and a turn weigh alike).
fn features(model: &dyn CalibModel, poses: &Poses) -> Vec<Vec<f64>> {
    let nj = model.joint_count().min(poses.q.width());
    let spread: Vec<f64> = (0..nj)
        .map(|i| {
            let (lo, hi) = poses
                .q
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[i]), hi.max(q[i]))
                });
            if hi > lo {
                hi - lo
            } else {
                1.0
            }
        })
        .collect();
    poses
        .q
        .iter()
        .map(|q| {
            let mut x = Vec::with_capacity(2 * nj);
            for i in 0..nj {
                if model.joint_is_prismatic(i) {
                    x.push(q[i] / spread[i]);
                } else {
                    x.push(q[i].cos());
                    x.push(q[i].sin());
                }
            }
            x
        })
        .collect()
}

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}
