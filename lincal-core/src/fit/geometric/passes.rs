//! Passes over the poses: the model's kinematics at one parameter vector (through the chain,
//! its pose-independent motions prepared once), the split of the poses into chunks for the
//! worker threads, and [`fold_poses`], which visits every pose with its tip and squared
//! geometric residual.
//!
//! Takes the model, the poses and a parameter vector; gives per-chunk results in pose order.

use crate::data::Poses;
use crate::model::chain::{self, Readings};
use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;

/// Poses below which one thread does the work (spawning costs more than it saves).
const PARALLEL_MIN: usize = 4096;

/// The model's kinematics at one parameter vector, for many poses: through the chain with
/// its pose-independent motions [`chain::prepare`]d once (a factor without a joint costs no
/// sine or cosine per pose), or through the model's own methods when it has no chain.
pub(super) struct Kinematics<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    motions: Vec<chain::Motion>,
    twists: Vec<[f64; 6]>,
}

impl<'a> Kinematics<'a> {
    pub(super) fn new(model: &'a dyn CalibModel, p: &'a [f64]) -> Self {
        let factors = model.chain();
        let mut motions = vec![chain::Motion::default(); factors.len()];
        chain::prepare(factors, p, &mut motions);
        Kinematics {
            model,
            p,
            motions,
            twists: vec![[0.0; 6]; p.len()],
        }
    }

    #[inline]
    pub(super) fn tip(&self, q: Readings<'_>, out: &mut [f64]) {
        let factors = self.model.chain();
        if factors.is_empty() {
            self.model.tip(q.q, self.p, out);
        } else {
            chain::tip_prepared(factors, &self.motions, out.len(), q, out);
        }
    }

    /// The tool frame at `q`: origin and rotation (column-major); NaN without a chain.
    #[inline]
    pub(super) fn pose(&self, q: Readings<'_>, tip: &mut [f64; 3], rot: &mut [f64; 9]) {
        let factors = self.model.chain();
        if factors.is_empty() {
            *tip = [f64::NAN; 3];
            *rot = [f64::NAN; 9];
        } else {
            chain::pose_prepared(factors, &self.motions, q, tip, rot);
        }
    }

    /// The tool frame at `q` and its Jacobian `6 × P` (position rows, then the world angular
    /// velocity rows; [`chain::pose_jacobian_prepared`]); NaN without a chain.
    #[inline]
    pub(super) fn pose_jacobian(
        &mut self,
        q: Readings<'_>,
        tip: &mut [f64; 3],
        rot: &mut [f64; 9],
        jac: &mut [f64],
    ) {
        let factors = self.model.chain();
        if factors.is_empty() {
            *tip = [f64::NAN; 3];
            *rot = [f64::NAN; 9];
            jac.iter_mut().for_each(|v| *v = f64::NAN);
        } else {
            chain::pose_jacobian_prepared(
                factors,
                &self.motions,
                q,
                tip,
                rot,
                jac,
                &mut self.twists,
            );
        }
    }

    #[inline]
    pub(super) fn tip_jacobian(&mut self, q: Readings<'_>, tip: &mut [f64], jac: &mut [f64]) {
        let factors = self.model.chain();
        if factors.is_empty() {
            self.model.tip_jacobian(q.q, self.p, tip, jac);
        } else {
            let dim = tip.len();
            chain::tip_jacobian_prepared(
                factors,
                &self.motions,
                dim,
                q,
                tip,
                jac,
                &mut self.twists,
            );
        }
    }
}

/// Worker threads for passes over the poses: the machine's, at most 8. Asked once: the
/// standard library reads the cgroup files on every call.
pub(super) fn thread_count() -> usize {
    crate::cores::available()
}

/// The ranges of `n` items `threads` workers take (one range below `min` items).
fn chunks_of(n: usize, threads: usize, min: usize) -> Vec<std::ops::Range<usize>> {
    let t = if n < min { 1 } else { threads };
    let size = n.div_ceil(t).max(1);
    (0..t)
        .map(|i| (i * size).min(n)..((i + 1) * size).min(n))
        .filter(|r| !r.is_empty())
        .collect()
}

/// Runs `work` over the chunks of `n` poses (in parallel from [`PARALLEL_MIN`] poses),
/// results in pose order.
pub(super) fn map_chunks<T: Send>(
    n: usize,
    threads: usize,
    work: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    map_ranges(n, threads, PARALLEL_MIN, work)
}

/// Runs `work` over `threads` contiguous ranges of `n` items (one range below `min` items),
/// results in item order: for work whose items cost more than a pose's pass.
pub(crate) fn map_ranges<T: Send>(
    n: usize,
    threads: usize,
    min: usize,
    work: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    let chunks = chunks_of(n, threads, min);
    if chunks.len() <= 1 {
        return chunks.into_iter().map(&work).collect();
    }
    crate::cores::map_parts(chunks, work)
}

/// Visits every pose at parameters `p` with its tip and squared geometric residual
/// `‖g_l‖²` (for a measured pose, position and weighted orientation together,
/// [`geometry::pose_residual`] with [`CalibModel::orientation_weight`]):
/// `step(acc, l, tip, ‖g_l‖²)`, over chunks of consecutive poses (in parallel when
/// there are many), each chunk folding into its own accumulator from `init`. The
/// accumulators come back in pose order, so merging them in order is deterministic.
pub(crate) fn fold_poses<A: Send>(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    init: impl Fn() -> A + Sync,
    step: impl Fn(&mut A, usize, &[f64], f64) + Sync,
) -> Vec<A> {
    fold_poses_with(model, poses, None, p, init, step)
}

/// [`fold_poses`] with the readings' sines and cosines when known ([`ReadingTrig`]).
pub(super) fn fold_poses_with<A: Send>(
    model: &dyn CalibModel,
    poses: &Poses,
    trig: Option<&ReadingTrig>,
    p: &[f64],
    init: impl Fn() -> A + Sync,
    step: impl Fn(&mut A, usize, &[f64], f64) + Sync,
) -> Vec<A> {
    let dim = model.dim();
    let values: Vec<Vec<f64>> = (0..model.constraint_count())
        .map(|j| {
            let mut v = vec![0.0; model.constraint_kind(j).value_count(dim)];
            model.constraint_values(j, p, &mut v);
            v
        })
        .collect();
    let weight = model.orientation_weight();
    map_chunks(poses.len(), thread_count(), |range| {
        let kin = Kinematics::new(model, p);
        let mut acc = init();
        let (mut tip, mut r, mut rot) = ([0.0; 3], [0.0; 6], [0.0; 9]);
        for l in range {
            let j = poses.constraint.at(l);
            let Some(value) = values.get(j) else {
                continue; // out of range: refused where the poses are checked
            };
            let kind = model.constraint_kind(j);
            let nr = kind.residual_count(dim);
            let measured = poses
                .measured
                .as_ref()
                .and_then(|m| m.get(l))
                .unwrap_or(&[]);
            if kind == ConstraintKind::MeasuredPose {
                kin.pose(readings(poses, trig, l), &mut tip, &mut rot);
                let r6: &mut [f64; 6] = &mut r;
                geometry::pose_residual(measured, &tip, &rot, weight, r6);
            } else {
                kin.tip(readings(poses, trig, l), &mut tip[..dim]);
                geometry::geometric_residual(kind, dim, value, &tip[..dim], measured, &mut r[..nr]);
            }
            let d2 = r[..nr].iter().map(|v| v * v).sum::<f64>();
            step(&mut acc, l, &tip[..dim], d2);
        }
        acc
    })
}

/// Poses below which (in readings, joints × poses) a fit keeps the sine and cosine of every
/// reading: 16 MB at most, so that a million poses keep their bounded memory.
const TRIG_MAX_READINGS: usize = 1 << 20;

/// `[sin q, cos q]` of every joint reading of the poses, row after row: the readings do not
/// change while a fit iterates, so each revolute joint's `sincos` per pose and evaluation
/// becomes four products ([`Readings`]).
pub(crate) struct ReadingTrig {
    table: Vec<[f64; 2]>,
    joints: usize,
}

impl ReadingTrig {
    /// The table of `poses`, or `None` past [`TRIG_MAX_READINGS`] or for rows of unequal
    /// lengths.
    pub(crate) fn of(poses: &Poses) -> Option<Self> {
        let joints = poses.q.get(0).map_or(0, <[f64]>::len);
        if joints == 0 || poses.len().saturating_mul(joints) > TRIG_MAX_READINGS {
            return None;
        }
        let mut table = Vec::with_capacity(poses.len() * joints);
        for q in &poses.q {
            if q.len() != joints {
                return None;
            }
            chain::reading_trig(q, &mut table);
        }
        Some(ReadingTrig { table, joints })
    }
}

/// Pose `l`'s readings, with their sines and cosines from `trig` when given.
#[inline]
pub(super) fn readings<'a>(
    poses: &'a Poses,
    trig: Option<&'a ReadingTrig>,
    l: usize,
) -> Readings<'a> {
    Readings {
        q: &poses.q[l],
        trig: trig.map(|t| &t.table[l * t.joints..(l + 1) * t.joints]),
    }
}
