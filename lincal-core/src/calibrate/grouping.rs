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

/// At most `k` folds of `poses` (module docs): by placement when the poses lie on
/// [`MIN_PLACEMENTS`] or more constraints (as many folds as placements when those are fewer
/// than `k`), else `k` clusters in joint space (fewer when there are fewer distinct poses).
#[must_use]
pub fn folds(model: &dyn CalibModel, poses: &Poses, k: usize) -> Folds {
    let k = k.max(1);
    let used = placements(poses);
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

/// The constraints the poses lie on (the placements), ascending; without a copy per pose.
#[must_use]
pub fn placements(poses: &Poses) -> Vec<usize> {
    // Inserted one by one: `collect` into a set would first gather and sort every pose's.
    let mut set = std::collections::BTreeSet::new();
    for c in poses.constraint.iter() {
        set.insert(c);
    }
    set.into_iter().collect()
}

/// The fewest placements (constraints with poses) the folds are made of (module docs).
pub const MIN_PLACEMENTS: usize = 3;

/// Lloyd's iterations of the k-means clustering; it settles long before on real data.
const KMEANS_ROUNDS: usize = 30;

/// The most poses the centers are found from: beyond, an evenly strided sample of this many
/// (every pose is then given its nearest center), so memory and time stay flat in the data.
const KMEANS_SAMPLE: usize = 20_000;

/// `k` clusters of the poses in joint space (module docs), whatever the placements.
#[must_use]
pub fn clusters(model: &dyn CalibModel, poses: &Poses, k: usize) -> Folds {
    let map = FeatureMap::new(model, poses);
    let n = poses.len();
    let dim = map.dim;
    if n == 0 || dim == 0 {
        return Folds {
            fold: vec![0; n],
            folds: 1,
            grouping: Grouping::Clusters,
        };
    }
    let sample: Vec<usize> = if n > KMEANS_SAMPLE {
        (0..KMEANS_SAMPLE).map(|i| i * n / KMEANS_SAMPLE).collect()
    } else {
        (0..n).collect()
    };
    let mut flat = Vec::with_capacity(sample.len() * dim);
    for &l in &sample {
        map.push(poses.q.get(l).unwrap_or(&[]), &mut flat);
    }
    let (centers, mut fold) = lloyd(&flat, dim, k);
    if sample.len() < n {
        let mut x = Vec::with_capacity(dim);
        fold = poses
            .q
            .iter()
            .map(|q| {
                x.clear();
                map.push(q, &mut x);
                nearest(&x, &centers)
            })
            .collect();
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

/// k-means of the points `flat` (each `dim` long, one after another), seeded by farthest
/// points from the first (deterministic, spread out): the centers, and each point's.
fn lloyd(flat: &[f64], dim: usize, k: usize) -> (Vec<Vec<f64>>, Vec<usize>) {
    let point = |i: usize| &flat[i * dim..(i + 1) * dim];
    let points = || flat.chunks_exact(dim);
    let n = flat.len() / dim;
    let mut centers: Vec<Vec<f64>> = vec![point(0).to_vec()];
    let mut near: Vec<f64> = points().map(|x| dist2(x, point(0))).collect();
    while centers.len() < k {
        let (far, d) = near
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (i, &d)| if d > b.1 { (i, d) } else { b });
        if d <= 0.0 {
            break; // fewer distinct poses than folds
        }
        centers.push(point(far).to_vec());
        for (x, m) in points().zip(&mut near) {
            *m = m.min(dist2(x, point(far)));
        }
    }
    let mut fold = vec![0; n];
    for _ in 0..KMEANS_ROUNDS {
        let mut changed = false;
        for (x, f) in points().zip(&mut fold) {
            let best = nearest(x, &centers);
            changed |= best != *f;
            *f = best;
        }
        // Every center's mean in one pass over the points.
        let mut sums = vec![vec![0.0; dim]; centers.len()];
        let mut counts = vec![0usize; centers.len()];
        for (x, &f) in points().zip(&fold) {
            counts[f] += 1;
            for (s, v) in sums[f].iter_mut().zip(x) {
                *s += v;
            }
        }
        for ((center, sum), &count) in centers.iter_mut().zip(&sums).zip(&counts) {
            if count == 0 {
                continue; // keeps its seed; relabelled by the caller if it stays empty
            }
            for (v, s) in center.iter_mut().zip(sum) {
                *v = s / count as f64;
            }
        }
        if !changed {
            break;
        }
    }
    (centers, fold)
}

/// The first of the nearest centers to `x`.
fn nearest(x: &[f64], centers: &[Vec<f64>]) -> usize {
    let mut best = (0, f64::INFINITY);
    for (c, center) in centers.iter().enumerate() {
        let d = dist2(x, center);
        if d < best.1 {
            best = (c, d);
        }
    }
    best.0
}

/// Each pose as a point of joint space: `(cos q, sin q)` of a revolute joint, a prismatic
/// joint's reading over its spread in the data (so a metre and a turn weigh alike).
struct FeatureMap {
    /// Per joint (those the data hold), its spread when prismatic.
    spread: Vec<f64>,
    prismatic: Vec<bool>,
    /// The point's dimension.
    dim: usize,
}

impl FeatureMap {
    fn new(model: &dyn CalibModel, poses: &Poses) -> Self {
        let nj = model.joint_count().min(poses.q.width());
        let prismatic: Vec<bool> = (0..nj).map(|i| model.joint_is_prismatic(i)).collect();
        let spread = (0..nj)
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
        let dim = prismatic.iter().map(|&p| if p { 1 } else { 2 }).sum();
        FeatureMap {
            spread,
            prismatic,
            dim,
        }
    }

    /// Appends the point of the joint readings `q` to `out`.
    fn push(&self, q: &[f64], out: &mut Vec<f64>) {
        for (i, (&p, &s)) in self.prismatic.iter().zip(&self.spread).enumerate() {
            let v = q.get(i).copied().unwrap_or(0.0);
            if p {
                out.push(v / s);
            } else {
                out.push(v.cos());
                out.push(v.sin());
            }
        }
    }
}

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}
