//! The geometric least-squares problem over the free parameters: the residual and its exact
//! Jacobian assembled pose by pose into the Gram matrix `[J | r]ᵀ[J | r]` (in blocks, over
//! chunks of poses), with the relations' rows, and its Cholesky factor as the compressed
//! linearisation the Levenberg-Marquardt core takes.
//!
//! Takes the model, the poses and a start; gives a [`GeometricFit`] ([`LeastSquares`]).

use nalgebra::{DMatrix, DVector};

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;
use crate::numeric::linalg::gram_factor;
use crate::numeric::lm::{FreeSet, LeastSquares, Linearization};

use super::passes::{fold_poses_with, map_chunks, readings, thread_count, Kinematics, ReadingTrig};

/// Rows per block of the Gram accumulation (each block one product,
/// [`crate::numeric::gram::gram_update`]).
const BLOCK: usize = 256;

/// The geometric least-squares problem over the free parameters.
pub(crate) struct GeometricFit<'a> {
    model: &'a dyn CalibModel,
    poses: &'a Poses,
    /// Free parameters and the full-vector template.
    pub set: FreeSet,
    kinds: Vec<ConstraintKind>,
    /// Per constraint: `(value index, free position)` of each value that is a free parameter.
    value_free: Vec<Vec<(usize, usize)>>,
    threads: usize,
    /// Per-pose weights of the squared residuals (robust fits), or all 1.
    pub(super) weights: Option<&'a [f64]>,
    /// The weight `w` of the relations' residual rows (see [`crate::fit::relation`]); 0 without.
    relation_weight: f64,
    /// The prior's rows ([`CalibModel::prior`]) over the free values: each row's
    /// `(free position, coefficient)` terms and its constant (the held parameters' part),
    /// so that the row's residual is `Σ coef·(x_pos − nominal_pos) + constant`.
    prior: Vec<PriorRow>,
    /// The readings' sines and cosines, computed at the first pass for every later one.
    trig: std::sync::OnceLock<Option<ReadingTrig>>,
}

/// The sizes one pass of the Gram accumulation works with: free parameters `n`, all
/// parameters `np`, the workspace dimension `dim`.
#[derive(Clone, Copy)]
struct Sizes {
    n: usize,
    np: usize,
    dim: usize,
}

/// Per-thread scratch for one pose's linearisation.
struct Scratch {
    tip: [f64; 3],
    /// The tool frame's rotation (measured poses).
    rot: [f64; 9],
    /// `∂x/∂p` (`dim × P`), or for a measured pose the frame's `6 × P` Jacobian.
    jac: Vec<f64>,
    /// A measured pose's orientation rows `∂φ/∂p` (`3 × P`).
    dphi: Vec<f64>,
    block: DMatrix<f64>,
    filled: usize,
    gram: DMatrix<f64>,
}

impl<'a> GeometricFit<'a> {
    /// The problem with the model's gauge-fixed free set, held parameters at `start`.
    ///
    /// # Errors
    /// A pose whose constraint index is out of range.
    pub fn new(model: &'a dyn CalibModel, poses: &'a Poses, start: &[f64]) -> Result<Self> {
        let kinds: Vec<ConstraintKind> = (0..model.constraint_count())
            .map(|j| model.constraint_kind(j))
            .collect();
        if poses.constraint.iter().any(|j| j >= kinds.len()) {
            return Err(Error::other("a pose's constraint index is out of range"));
        }
        let set = FreeSet::new(model, start);
        let dim = model.dim();
        let value_free = kinds
            .iter()
            .enumerate()
            .map(|(j, k)| {
                (0..k.value_count(dim))
                    .filter_map(|v| {
                        let param = model.constraint_value_param(j, v)?;
                        let pos = set.free.iter().position(|&f| f == param)?;
                        Some((v, pos))
                    })
                    .collect()
            })
            .collect();
        let threads = thread_count();
        let prior = prior_rows(model, &set.free, start);
        let mut fit = GeometricFit {
            model,
            poses,
            set,
            kinds,
            value_free,
            threads,
            weights: None,
            relation_weight: 0.0,
            prior,
            trig: std::sync::OnceLock::new(),
        };
        if !model.relations().is_empty() {
            // The data's own scale at the start, before the relations join in.
            let x0 = fit.set.take(start);
            if let Ok(lin) = fit.linearize(&x0) {
                let diag: Vec<f64> = lin.r.column_iter().map(|c| c.norm_squared()).collect();
                fit.relation_weight = crate::fit::relation::weight(&diag);
            }
        }
        Ok(fit)
    }

    /// Number of relation residual components (rows added to the data's).
    pub fn relation_components(&self) -> usize {
        let dim = self.model.dim();
        self.model
            .relations()
            .iter()
            .map(|r| r.kind.residual_count(dim))
            .sum()
    }

    /// `Σ_r (L_r·(p_S − μ))²`: the prior's part of the cost at the free values `x`.
    pub fn prior_cost(&self, x: &[f64]) -> f64 {
        self.prior.iter().map(|row| row.residual(x).powi(2)).sum()
    }

    /// Number of residual components `m`.
    pub fn components(&self) -> usize {
        let dim = self.model.dim();
        self.poses
            .constraint
            .iter()
            .map(|j| self.kinds[j].residual_count(dim))
            .sum()
    }

    fn values(&self, p: &[f64]) -> Vec<Vec<f64>> {
        let dim = self.model.dim();
        self.kinds
            .iter()
            .enumerate()
            .map(|(j, k)| {
                let mut v = vec![0.0; k.value_count(dim)];
                self.model.constraint_values(j, p, &mut v);
                v
            })
            .collect()
    }

    fn measured(&self, l: usize) -> &[f64] {
        self.poses
            .measured
            .as_ref()
            .and_then(|m| m.get(l))
            .unwrap_or(&[])
    }

    /// The readings' sines and cosines ([`ReadingTrig`]), computed on first use.
    fn trig(&self) -> Option<&ReadingTrig> {
        self.trig
            .get_or_init(|| ReadingTrig::of(self.poses))
            .as_ref()
    }

    /// Runs `work` over the pose chunks (in parallel when large) and collects the results.
    fn map_chunks<T: Send>(&self, work: impl Fn(std::ops::Range<usize>) -> T + Sync) -> Vec<T> {
        map_chunks(self.poses.len(), self.threads, work)
    }

    /// Accumulates the Gram matrix of `[J | r]` over `range`.
    fn gram_range(
        &self,
        p: &[f64],
        values: &[Vec<f64>],
        range: std::ops::Range<usize>,
    ) -> Result<DMatrix<f64>> {
        let n = self.set.free.len();
        let np = self.model.param_count();
        let dim = self.model.dim();
        let w = n + 1;
        let mut s = Scratch {
            tip: [0.0; 3],
            rot: [0.0; 9],
            jac: vec![0.0; 6 * np],
            dphi: vec![0.0; 3 * np],
            // Column-major `w × BLOCK`: one pose row per column, contiguous.
            block: DMatrix::zeros(w, BLOCK),
            filled: 0,
            gram: DMatrix::zeros(w, w),
        };
        let mut kin = Kinematics::new(self.model, p);
        let range_copy = range.clone();
        let sizes = Sizes { n, np, dim };
        for l in range {
            self.push_pose(&mut kin, values, l, sizes, &mut s);
        }
        flush(&mut s);
        crate::numeric::gram::mirror_upper(s.gram.as_mut_slice(), w);
        // A non-finite entry anywhere reaches the Gram matrix; only then look for its pose.
        if !s.gram.iter().all(|v| v.is_finite()) {
            return Err(self.non_finite_error(&mut kin, values, range_copy, &mut s));
        }
        Ok(s.gram)
    }

    /// Appends pose `l`'s rows `[∂g_c/∂p_F | g_c]` (scaled by `√w_l` in a weighted fit) to
    /// the block, folding the block into the Gram matrix whenever it is full.
    #[inline]
    fn push_pose(
        &self,
        kin: &mut Kinematics<'_>,
        values: &[Vec<f64>],
        l: usize,
        sizes: Sizes,
        s: &mut Scratch,
    ) {
        let Sizes { n, np, dim } = sizes;
        let w = n + 1;
        let j = self.poses.constraint.at(l);
        let kind = self.kinds[j];
        if kind == ConstraintKind::MeasuredPose {
            self.push_measured_pose(kin, l, sizes, s);
            return;
        }
        let (nr, nv) = (kind.residual_count(dim), kind.value_count(dim));
        kin.tip_jacobian(
            readings(self.poses, self.trig(), l),
            &mut s.tip[..dim],
            &mut s.jac[..dim * np],
        );
        let rj =
            geometry::residual_jacobian(kind, dim, &values[j], &s.tip[..dim], self.measured(l));
        // dx is the identity for a point or a measured tip: the rows of ∂x/∂p as they are.
        let identity = matches!(kind, ConstraintKind::Point | ConstraintKind::Measured);
        for c in 0..nr {
            if s.filled == BLOCK {
                flush(s);
            }
            let col = &mut s.block.as_mut_slice()[s.filled * w..(s.filled + 1) * w];
            let dxc = &rj.dx[c * dim..(c + 1) * dim];
            if identity {
                let row = &s.jac[c * np..(c + 1) * np];
                for (slot, &fj) in col[..n].iter_mut().zip(&self.set.free) {
                    *slot = row[fj];
                }
            } else {
                for (slot, &fj) in col[..n].iter_mut().zip(&self.set.free) {
                    let mut v = 0.0;
                    for (i, &d) in dxc.iter().enumerate() {
                        v += d * s.jac[i * np + fj];
                    }
                    *slot = v;
                }
            }
            for &(v, k) in &self.value_free[j] {
                col[k] += rj.dv[c * nv + v];
            }
            col[n] = rj.r[c];
            if let Some(w) = self.weights {
                let sw = w[l].sqrt();
                col.iter_mut().for_each(|v| *v *= sw);
            }
            s.filled += 1;
        }
    }

    /// A measured pose's 6 rows: the position error's `∂x/∂p` as it is, then the weighted
    /// orientation error's `w·J_r⁻¹(φ)·Rᵀ·ω` ([`crate::model::rotation`]).
    fn push_measured_pose(
        &self,
        kin: &mut Kinematics<'_>,
        l: usize,
        sizes: Sizes,
        s: &mut Scratch,
    ) {
        let Sizes { n, np, .. } = sizes;
        let w = n + 1;
        let measured = self.measured(l);
        kin.pose_jacobian(
            readings(self.poses, self.trig(), l),
            &mut s.tip,
            &mut s.rot,
            &mut s.jac[..6 * np],
        );
        let weight = self.model.orientation_weight();
        let mut r = [0.0; 6];
        geometry::pose_residual(measured, &s.tip, &s.rot, weight, &mut r);
        let rm: [f64; 9] = measured
            .get(3..12)
            .and_then(|m| m.try_into().ok())
            .unwrap_or([f64::NAN; 9]);
        let omega = &s.jac[3 * np..6 * np];
        crate::model::rotation::orientation_residual(
            &rm,
            &s.rot,
            Some((omega, &mut s.dphi[..3 * np])),
        );
        for (c, &rc) in r.iter().enumerate() {
            if s.filled == BLOCK {
                flush(s);
            }
            let col = &mut s.block.as_mut_slice()[s.filled * w..(s.filled + 1) * w];
            let (row, scale) = if c < 3 {
                (&s.jac[c * np..(c + 1) * np], 1.0)
            } else {
                (&s.dphi[(c - 3) * np..(c - 2) * np], weight)
            };
            for (slot, &fj) in col[..n].iter_mut().zip(&self.set.free) {
                *slot = scale * row[fj];
            }
            col[n] = rc;
            if let Some(w) = self.weights {
                let sw = w[l].sqrt();
                col.iter_mut().for_each(|v| *v *= sw);
            }
            s.filled += 1;
        }
    }

    /// The error for a Gram matrix that is not finite over `range`: the first pose whose
    /// residual or Jacobian is not finite, or an overflow when every pose is finite.
    fn non_finite_error(
        &self,
        kin: &mut Kinematics<'_>,
        values: &[Vec<f64>],
        range: std::ops::Range<usize>,
        s: &mut Scratch,
    ) -> Error {
        let at = range
            .clone()
            .find(|&l| !self.pose_is_finite(kin, values, l, s));
        Error::other(match at {
            Some(l) => format!(
                "the geometric residual is not finite at pose {l} ({})",
                self.poses.place(l)
            ),
            None => "the normal equations overflowed: the parameters have run off to \
                     values far beyond the data's scale"
                .to_string(),
        })
    }

    /// Whether pose `l`'s tip, Jacobian and residual are all finite.
    fn pose_is_finite(
        &self,
        kin: &mut Kinematics<'_>,
        values: &[Vec<f64>],
        l: usize,
        s: &mut Scratch,
    ) -> bool {
        let j = self.poses.constraint.at(l);
        let dim = self.model.dim();
        let np = self.model.param_count();
        if self.kinds[j] == ConstraintKind::MeasuredPose {
            let n = self.set.free.len();
            s.filled = 0;
            self.push_measured_pose(kin, l, Sizes { n, np, dim }, s);
            let ok = s.block.as_slice()[..s.filled * (n + 1)]
                .iter()
                .all(|v| v.is_finite());
            s.filled = 0;
            return ok;
        }
        kin.tip_jacobian(
            readings(self.poses, self.trig(), l),
            &mut s.tip[..dim],
            &mut s.jac[..dim * np],
        );
        let rj = geometry::residual_jacobian(
            self.kinds[j],
            dim,
            &values[j],
            &s.tip[..dim],
            self.measured(l),
        );
        s.jac[..dim * np]
            .iter()
            .chain(&rj.r)
            .chain(&rj.dx)
            .chain(&rj.dv)
            .all(|v| v.is_finite())
    }
}

impl GeometricFit<'_> {
    /// Every pose's residual rows `[∂g_c/∂p_F | g_c]` at the full parameters `p`, row after
    /// row (width `n + 1`), and per pose the index of its first row (`N + 1` offsets): the
    /// linearisation of [`LeastSquares::linearize`] before it is folded into the Gram matrix,
    /// kept pose by pose for those who weigh poses one against another (pose selection).
    ///
    /// # Errors
    /// A pose whose residual or Jacobian is not finite (named).
    pub(crate) fn pose_rows(&self, p: &[f64]) -> Result<(Vec<f64>, Vec<usize>)> {
        let n = self.set.free.len();
        let np = self.model.param_count();
        let dim = self.model.dim();
        let w = n + 1;
        let values = self.values(p);
        let parts = self.map_chunks(|range| -> Result<(Vec<f64>, Vec<usize>)> {
            let mut s = Scratch {
                tip: [0.0; 3],
                rot: [0.0; 9],
                jac: vec![0.0; 6 * np],
                dphi: vec![0.0; 3 * np],
                block: DMatrix::zeros(w, BLOCK),
                filled: 0,
                gram: DMatrix::zeros(0, 0),
            };
            let mut kin = Kinematics::new(self.model, p);
            let (mut rows, mut counts) = (Vec::new(), Vec::with_capacity(range.len()));
            for l in range.clone() {
                s.filled = 0;
                self.push_pose(&mut kin, &values, l, Sizes { n, np, dim }, &mut s);
                let block = &s.block.as_slice()[..s.filled * w];
                if !block.iter().all(|v| v.is_finite()) {
                    return Err(self.non_finite_error(&mut kin, &values, l..l + 1, &mut s));
                }
                rows.extend_from_slice(block);
                counts.push(s.filled);
            }
            Ok((rows, counts))
        });
        let mut rows = Vec::new();
        let mut offsets = vec![0];
        for part in parts {
            let (r, c) = part?;
            rows.extend(r);
            for k in c {
                offsets.push(offsets.last().copied().unwrap_or(0) + k);
            }
        }
        Ok((rows, offsets))
    }
}

/// Folds the filled block into the Gram matrix: `G += B·Bᵀ` (the triangles are made
/// exactly symmetric once, at the end of the range).
fn flush(s: &mut Scratch) {
    if s.filled == 0 {
        return;
    }
    crate::numeric::gram::gram_update(&mut s.gram, &s.block, s.filled);
    s.filled = 0;
}

impl LeastSquares for GeometricFit<'_> {
    fn unknowns(&self) -> usize {
        self.set.free.len()
    }

    /// The data's and the relations' rows: the `m` of `σ̂²` (the prior's rows are not data).
    fn residual_rows(&self) -> Option<usize> {
        Some(self.components() + self.relation_components())
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let p = self.set.full(x);
        let w = |l: usize| self.weights.map_or(1.0, |w| w[l]);
        let cost: f64 = fold_poses_with(
            self.model,
            self.poses,
            self.trig(),
            &p,
            || 0.0,
            |c, l, _, d2| {
                *c += w(l) * d2;
            },
        )
        .into_iter()
        .sum::<f64>()
            + crate::fit::relation::cost(self.model, &p, self.relation_weight)
            + self.prior_cost(x);
        if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        }
    }

    fn linearize(&self, x: &[f64]) -> Result<Linearization> {
        let n = self.unknowns();
        let p = self.set.full(x);
        let values = self.values(&p);
        let mut g = DMatrix::zeros(n + 1, n + 1);
        for part in self.map_chunks(|r| self.gram_range(&p, &values, r)) {
            g += part?;
        }
        if self.relation_weight > 0.0 {
            // Each relation row [w ∂R/∂x | w R] joins the Gram matrix like a pose's rows.
            let w = self.relation_weight;
            for row in crate::fit::relation::rows(self.model, &p) {
                let mut v = DVector::zeros(n + 1);
                for (param, d) in &row.gradient {
                    if let Some(pos) = self.set.free.iter().position(|f| f == param) {
                        v[pos] += w * d;
                    }
                }
                v[n] = w * row.residual;
                g += &v * v.transpose();
            }
        }
        // Each prior row [L_r | L_r·(p_S − μ)] joins it the same way.
        for row in &self.prior {
            let r = row.residual(x);
            for &(a, ca, _) in &row.terms {
                for &(b, cb, _) in &row.terms {
                    g[(a, b)] += ca * cb;
                }
                g[(a, n)] += ca * r;
                g[(n, a)] += ca * r;
            }
            g[(n, n)] += r * r;
        }
        // Only the upper triangle matters; the product filled both.
        let cost = g[(n, n)];
        let r = gram_factor(&g);
        Ok(Linearization {
            r: r.view((0, 0), (n, n)).into_owned(),
            z: r.view((0, n), (n, 1)).column(0).into_owned(),
            cost,
        })
    }
}

/// One prior row over the free values: `Σ coef·(x_pos − nominal) + constant`.
#[derive(Clone, Debug)]
struct PriorRow {
    /// `(free position, coefficient, nominal)`.
    terms: Vec<(usize, f64, f64)>,
    /// The held parameters' part, `Σ coef·(p_j − nominal_j)` at the start.
    constant: f64,
}

impl PriorRow {
    fn residual(&self, x: &[f64]) -> f64 {
        self.terms
            .iter()
            .map(|&(pos, c, nominal)| c * (x[pos] - nominal))
            .sum::<f64>()
            + self.constant
    }
}

/// `model`'s prior ([`CalibModel::prior`]) as rows over the free parameters `free`; a held
/// parameter's term is a constant at its value in `start` (held values do not move).
fn prior_rows(model: &dyn CalibModel, free: &[usize], start: &[f64]) -> Vec<PriorRow> {
    let Some(prior) = model.prior() else {
        return Vec::new();
    };
    let k = prior.params.len();
    if k == 0 {
        return Vec::new();
    }
    prior
        .rows
        .chunks_exact(k)
        .map(|row| {
            let mut out = PriorRow {
                terms: Vec::new(),
                constant: 0.0,
            };
            for ((&j, &nominal), &c) in prior.params.iter().zip(prior.nominal).zip(row) {
                if c == 0.0 || !c.is_finite() {
                    continue;
                }
                match free.iter().position(|&f| f == j) {
                    Some(pos) => out.terms.push((pos, c, nominal)),
                    None => out.constant += c * (start[j] - nominal),
                }
            }
            out
        })
        .filter(|r| !r.terms.is_empty())
        .collect()
}
