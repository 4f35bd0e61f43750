//! The whitening of each candidate pose's residual rows before they enter the design: the
//! noise model of the residuals, and its inverse Cholesky factor applied pose by pose; then
//! the scale of each parameter's column over the pool ([`column_scale`]).
//!
//! # The noise of a pose's residual
//! Pose `l` (joint readings `q_l`) on constraint `j` has the residual `g_l(q_l; p)`, `m_l`
//! components. Its covariance is
//!
//! `C_l = S_l + σ_enc²·A_l A_lᵀ`,  `A_l = ∂g_l/∂q` (`m_l × n_joints`),
//!
//! with `S_l = σ_track²·I` for a constraint held by the robot (tracking noise, `--noise-track`)
//! or `σ_measure²·I` for a measured tip (`--noise-measure`); for a measured pose the
//! orientation rows, which carry the model's weight `w` (metres per radian), have
//! `(w·σ_orientation)²` when `--noise-orientation` is given (else `σ_measure²`, the weight
//! then taken as `σ_measure/σ_orientation`). The second term is the encoder noise
//! (`--noise-encoder`, `N(0, σ_enc²)` on every reading, as `lincal simulate` adds it) carried
//! to the residual to first order. The whitened rows are `L_l⁻¹ J_l` with `C_l = L_l L_lᵀ`
//! (Cholesky), so that `Σ_l J_lᵀ C_l⁻¹ J_l` is the information of the poses (the Fisher
//! information of the generalised least-squares fit): without encoder noise, `J_l/σ`.
//!
//! `A_l` is taken by central differences in the joint readings of exactly the residual the
//! fit computes ([`crate::model::geometry::geometric_residual`] of the tip, `x − x_measured`
//! for a measured tip, [`crate::model::geometry::pose_residual`] for a measured pose), which
//! holds for every constraint kind and both model sources; its error (about `10⁻¹⁰`
//! relative) is far below what a noise level is known to.

use crate::data::{Poses, Rows};
use crate::fit::geometric::PoseJacobians;
use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;
use crate::simulate::{central_jacobian, Noise};

use super::small::chol;

/// Standard deviation assumed per residual component when neither `--noise-track` nor
/// `--noise-measure` is given, metres.
pub const DEFAULT_SIGMA: f64 = 1e-5;

/// The noise the design weighs each pose's residual by: pose `l`'s residual covariance is
/// `C_l = S_l + σ_enc²·A_lA_lᵀ`, `S_l` diagonal (`constraint²` for a constraint held,
/// `measured²` for a measured tip, `(w·orientation)²` on a measured pose's orientation rows
/// of weight `w` when `orientation > 0`), `A_l = ∂g_l/∂q` the residual's derivative in the
/// joint readings, `σ_enc = encoder`; its rows enter the design as `L_l⁻¹J_l`,
/// `C_l = L_lL_lᵀ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sigmas {
    /// Standard deviation of each component of a constraint's residual, metres.
    pub constraint: f64,
    /// Standard deviation of each coordinate of a measured tip (a measured pose's
    /// position), metres.
    pub measured: f64,
    /// Standard deviation of a measured pose's orientation about each axis, radians; 0: its
    /// weighted rows count as `measured` (the orientation weight then is
    /// `σ_measured/σ_orientation`).
    pub orientation: f64,
    /// Standard deviation of each joint reading (radians; metres on a prismatic joint); 0
    /// for none.
    pub encoder: f64,
}

impl Sigmas {
    /// The sigmas of the noise options: `track` for constraints and `measure` for measured
    /// tips, each standing in for the other when only one is given, both [`DEFAULT_SIGMA`]
    /// when neither is (encoder noise adds to them, it does not replace them).
    #[must_use]
    pub fn of(noise: Noise) -> Sigmas {
        let (constraint, measured) = match (noise.track > 0.0, noise.measure > 0.0) {
            (false, false) => (DEFAULT_SIGMA, DEFAULT_SIGMA),
            (true, false) => (noise.track, noise.track),
            (false, true) => (noise.measure, noise.measure),
            (true, true) => (noise.track, noise.measure),
        };
        Sigmas {
            constraint,
            measured,
            orientation: noise.orientation.max(0.0),
            encoder: noise.encoder.max(0.0),
        }
    }

    /// The variance of component `c` of a residual of `kind` (the diagonal of `S_l`), with
    /// the model's orientation weight `weight` for a measured pose's rows 3..6.
    pub(crate) fn base(&self, kind: ConstraintKind, c: usize, weight: f64) -> f64 {
        let s = match kind {
            ConstraintKind::MeasuredPose if c >= 3 && self.orientation > 0.0 => {
                weight * self.orientation
            }
            k if k.is_measured() => self.measured,
            _ => self.constraint,
        };
        s * s
    }
}

/// `poses` with every measured tip (measured frame) set to the model's at `p`: a planned
/// pose has no measurement; its residual is then 0 and its Jacobian that of the tip.
pub(crate) fn with_nominal_tips(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Poses {
    let mut out = poses.clone();
    if let Some(m) = &mut out.measured {
        let dim = model.dim();
        let mut rows = Rows::new(m.width());
        let mut tip = vec![0.0; dim];
        for (l, q) in poses.q.iter().enumerate() {
            let kind = model.constraint_kind(poses.constraint.at(l));
            if kind == ConstraintKind::Measured {
                model.tip(q, p, &mut tip);
                rows.push(&tip);
            } else if kind == ConstraintKind::MeasuredPose {
                // The whole frame: its orientation residual is then 0 too.
                let (mut x, mut rot) = ([0.0; 3], [0.0; 9]);
                model.tool_pose(q, p, &mut x, &mut rot);
                let mut row = x.to_vec();
                row.extend_from_slice(&rot);
                rows.push(&row);
            } else {
                rows.push(m.get(l).unwrap_or(&[]));
            }
        }
        *m = rows;
    }
    out
}

/// What one pose's residual needs besides the joint readings.
struct Residual<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    /// Each constraint's values at `p`.
    values: Vec<Vec<f64>>,
    weight: f64,
}

impl<'a> Residual<'a> {
    /// The residual of `model` at `p`, when `sigmas` has encoder noise to carry through it.
    fn with_encoder(model: &'a dyn CalibModel, p: &'a [f64], sigmas: Sigmas) -> Option<Self> {
        (sigmas.encoder > 0.0).then(|| Residual {
            model,
            p,
            values: (0..model.constraint_count())
                .map(|j| {
                    let mut v = vec![0.0; model.constraint_kind(j).value_count(model.dim())];
                    model.constraint_values(j, p, &mut v);
                    v
                })
                .collect(),
            weight: model.orientation_weight(),
        })
    }

    /// `∂g/∂q` of pose `l` of `poses` (its `m` residual components), by central differences.
    fn by_reading(&self, poses: &Poses, l: usize, m: usize) -> nalgebra::DMatrix<f64> {
        let j = poses.constraint.at(l);
        let measured = poses
            .measured
            .as_ref()
            .and_then(|rows| rows.get(l))
            .unwrap_or(&[]);
        let mut q = poses.q[l].to_vec();
        central_jacobian(&mut q, m, |q, r| self.eval(j, measured, q, r))
    }

    /// The residual `g(q)` of a pose on constraint `j` (measured row `measured`) into `out`
    /// (its [`ConstraintKind::residual_count`] components), as the fit computes it.
    fn eval(&self, j: usize, measured: &[f64], q: &[f64], out: &mut [f64]) {
        let kind = self.model.constraint_kind(j);
        if kind == ConstraintKind::MeasuredPose {
            let (mut x, mut rot, mut r) = ([0.0; 3], [0.0; 9], [0.0; 6]);
            self.model.tool_pose(q, self.p, &mut x, &mut rot);
            if measured.len() >= 12 {
                geometry::pose_residual(measured, &x, &rot, self.weight, &mut r);
            } else {
                r = [f64::NAN; 6];
            }
            out.copy_from_slice(&r[..out.len()]);
            return;
        }
        let dim = self.model.dim();
        let mut tip = [0.0; 3];
        self.model.tip(q, self.p, &mut tip[..dim]);
        geometry::geometric_residual(kind, dim, &self.values[j], &tip[..dim], measured, out);
    }
}

/// The variance of one residual component averaged over `poses` at `p`: the base variances of [`Sigmas::base`] plus the encoder noise carried
/// through `∂g/∂q`, `σ_enc²·‖∂g_c/∂q‖²`, the diagonal of each pose's covariance (module docs).
/// It is the noise level `σ̂²` a fit of such poses would estimate, which a prior relative to
/// the data is scaled by ([`crate::calibrate::prior::PriorScale::Weight`]).
pub(crate) fn mean_variance(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    sigmas: Sigmas,
) -> f64 {
    let weight = model.orientation_weight();
    let residual = Residual::with_encoder(model, p, sigmas);
    let var = sigmas.encoder * sigmas.encoder;
    let (mut sum, mut count) = (0.0, 0usize);
    for l in 0..poses.len() {
        let j = poses.constraint.at(l);
        let kind = model.constraint_kind(j);
        let m = kind.residual_count(model.dim());
        let through = residual.as_ref().map(|res| res.by_reading(poses, l, m));
        for c in 0..m {
            let enc = through
                .as_ref()
                .map_or(0.0, |a| var * a.row(c).norm_squared());
            let v = sigmas.base(kind, c, weight) + enc;
            if v.is_finite() {
                sum += v;
                count += 1;
            }
        }
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64
    }
}

/// Poses below which (per thread) the whitening with encoder noise runs on one thread.
const CHUNK: usize = 512;

/// The whitened rows `L_l⁻¹ J_l` (see the module docs) of every pose of `jac` (the rows of
/// `poses` at `p`; `poses` with [`with_nominal_tips`] where tips are measured), packed pose
/// after pose, `jac.free.len()` values a row, as [`super::Pool::new`] takes them. A pose
/// whose covariance does not factor (not finite) keeps rows of NaN, which the pool refuses
/// by name.
pub(crate) fn whitened(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    jac: &PoseJacobians,
    sigmas: Sigmas,
) -> Vec<f64> {
    let n = jac.free.len();
    let residual = Residual::with_encoder(model, p, sigmas);
    let work = |range: std::ops::Range<usize>| -> Vec<f64> {
        let mut out = Vec::with_capacity(range.len() * n * 3);
        for l in range {
            whiten_pose(model, poses, jac, l, sigmas, residual.as_ref(), &mut out);
        }
        out
    };
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let parts = if threads < 2 || poses.len() < 2 * CHUNK {
        vec![work(0..poses.len())]
    } else {
        // Each pose's rows depend on that pose alone: contiguous ranges over threads, joined
        // in order, give the same result whatever the thread count.
        let per = poses.len().div_ceil(threads);
        let ranges = (0..poses.len())
            .step_by(per)
            .map(|a| a..(a + per).min(poses.len()))
            .collect();
        crate::cores::map_parts(ranges, work)
    };
    parts.concat()
}

/// Appends pose `l`'s whitened rows to `out`: `J_l` divided by the standard deviations
/// without encoder noise (`residual` `None`), else `L_l⁻¹ J_l` with `L_l` the Cholesky factor
/// of `C_l` (see the module docs).
fn whiten_pose(
    model: &dyn CalibModel,
    poses: &Poses,
    jac: &PoseJacobians,
    l: usize,
    sigmas: Sigmas,
    residual: Option<&Residual<'_>>,
    out: &mut Vec<f64>,
) {
    let (n, w) = (jac.free.len(), jac.width());
    let j = poses.constraint.at(l);
    let kind = model.constraint_kind(j);
    let weight = model.orientation_weight();
    let Some(res) = residual else {
        for (c, row) in jac.pose(l).chunks_exact(w).enumerate() {
            let s = sigmas.base(kind, c, weight).sqrt();
            out.extend(row[..n].iter().map(|v| v / s));
        }
        return;
    };
    let rows: Vec<&[f64]> = jac.pose(l).chunks_exact(w).map(|r| &r[..n]).collect();
    let m = rows.len();
    let a = res.by_reading(poses, l, m);
    // C = S + σ_enc²·A·Aᵀ, row-major, then its Cholesky factor in place.
    let var = sigmas.encoder * sigmas.encoder;
    let mut cov = vec![0.0; m * m];
    for r in 0..m {
        for c in 0..m {
            let aa = a.row(r).dot(&a.row(c));
            cov[r * m + c] = var * aa
                + if r == c {
                    sigmas.base(kind, r, weight)
                } else {
                    0.0
                };
        }
    }
    if !chol(&mut cov, m) {
        out.extend(std::iter::repeat_n(f64::NAN, m * n));
        return;
    }
    // Forward substitution L·X = J, row by row.
    let start = out.len();
    for r in 0..m {
        let d = cov[r * m + r];
        for k in 0..n {
            let mut v = rows[r][k];
            for c in 0..r {
                v -= cov[r * m + c] * out[start + c * n + k];
            }
            out.push(v / d);
        }
    }
}

/// Each column's RMS over the rows of every draw's `blocks` (width `n`), the largest over
/// the draws: a column the nominals leave blind (`θ6` of a PUMA at `a5 = a6 = 0`) holds
/// rounding noise there, which must not be blown up to unit size. A column that no draw
/// sees, zero or below [`BLIND_COLUMN`] of the largest, takes the largest's scale (1 when
/// every column is zero). With `--draws 0` the blind column holds rounding noise alone, and
/// scaled by that noise the prior's information on its parameter, `Σ⁻¹/s²`, reached 10³⁰
/// and broke every factorisation of the design.
pub(super) fn column_scale(blocks: &[Vec<f64>], n: usize) -> Vec<f64> {
    let mut sum = vec![0.0_f64; n];
    let mut count = 0usize;
    for block in blocks {
        let mut s = vec![0.0; n];
        for row in block.chunks_exact(n) {
            s.iter_mut().zip(row).for_each(|(s, v)| *s += v * v);
        }
        sum.iter_mut()
            .zip(s)
            .for_each(|(m, v): (&mut f64, f64)| *m = m.max(v));
        count = count.max(block.len() / n);
    }
    let rms: Vec<f64> = sum
        .into_iter()
        .map(|s| (s / count.max(1) as f64).sqrt())
        .collect();
    let largest = rms
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .fold(0.0, f64::max);
    // A blind column takes the largest one's scale: the data add nothing to it either way,
    // and the prior's information on it then comes out of the size of the others'.
    let blind = if largest > 0.0 { largest } else { 1.0 };
    rms.into_iter()
        .map(|r| {
            if r > BLIND_COLUMN * largest && r.is_finite() {
                r
            } else {
                blind
            }
        })
        .collect()
}

/// A Jacobian column whose RMS over the pool is below this fraction of the largest column's
/// holds rounding noise, not a parameter's effect ([`column_scale`]). Columns are metres per
/// metre or per radian (lever arms), so a physical one is within a few decades of the others;
/// rounding noise is 10⁻¹⁶ of them.
const BLIND_COLUMN: f64 = 1e-10;
