//! The parameter-space path: Levenberg-Marquardt on the geometric residual with the exact
//! Jacobian, for any number of poses.
//!
//! Over the free (gauge-fixed) parameters `p_F`, minimise
//! `Σ_l ‖g(x(q_l; p), v_j(p))‖²`, `x` the tip, `v_j` the values of the constraint pose `l` lies
//! on and `g` [`geometry::geometric_residual`]. The Jacobian of one pose is exact:
//! `∂g/∂p = ∂g/∂x · ∂x/∂p + ∂g/∂v · ∂v/∂p`, with `∂x/∂p` from the chain
//! ([`crate::model::chain`], `O(P)` per pose), `∂g/∂x`, `∂g/∂v` by forward-mode dual numbers
//! ([`geometry::residual_jacobian`]) and `∂v/∂p` a selection
//! ([`CalibModel::constraint_value_param`]).
//!
//! # Cost
//! Each linearisation streams the poses once and accumulates the Gram matrix
//! `[J | r]ᵀ[J | r]` (`(n+1)²` numbers, whatever `N`) in blocks of rows with a
//! cache-blocked matrix product, split over the machine's cores. Its Cholesky factor
//! (column-equilibrated) is the `R` of a QR of `[J | r]`, which the shared Levenberg-Marquardt
//! core ([`crate::fit::refine`]) takes. So an iteration costs `O(N·n²)` flops and `O(n²)` memory:
//! linear in the data, independent of the basis size `K`. The squared condition number of
//! the Gram route is harmless here: the steps are damped and re-linearised, and the reported
//! standard deviations need a few digits only (they are checked against Monte Carlo).

use nalgebra::{DMatrix, DVector};

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::chain;
use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;
use crate::numeric::linalg::{checked_svd, gram_factor};
use crate::numeric::lm::{levenberg_marquardt, FreeSet, LeastSquares, Linearization, LmResult};

/// Rows per block of the Gram accumulation (a multiple of the kernel's tile).
const BLOCK: usize = 256;
/// Poses below which one thread does the work (spawning costs more than it saves).
const PARALLEL_MIN: usize = 4096;

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
    weights: Option<&'a [f64]>,
    /// The weight `w` of the relations' residual rows (see [`crate::fit::relation`]); 0 without.
    relation_weight: f64,
}

/// The model's kinematics at one parameter vector, for many poses: through the chain with
/// its pose-independent motions [`chain::prepare`]d once (a factor without a joint costs no
/// sine or cosine per pose), or through the model's own methods when it has no chain.
struct Kinematics<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    motions: Vec<chain::Motion>,
    twists: Vec<[f64; 6]>,
}

impl<'a> Kinematics<'a> {
    fn new(model: &'a dyn CalibModel, p: &'a [f64]) -> Self {
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
    fn tip(&self, q: &[f64], out: &mut [f64]) {
        let factors = self.model.chain();
        if factors.is_empty() {
            self.model.tip(q, self.p, out);
        } else {
            chain::tip_prepared(factors, &self.motions, out.len(), q, out);
        }
    }

    #[inline]
    fn tip_jacobian(&mut self, q: &[f64], tip: &mut [f64], jac: &mut [f64]) {
        let factors = self.model.chain();
        if factors.is_empty() {
            self.model.tip_jacobian(q, self.p, tip, jac);
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

/// Worker threads for passes over the poses: the machine's, at most 8.
fn thread_count() -> usize {
    std::thread::available_parallelism()
        .map_or(1, std::num::NonZeroUsize::get)
        .clamp(1, 8)
}

/// The pose ranges `threads` workers take (one range below [`PARALLEL_MIN`] poses).
fn pose_chunks(n: usize, threads: usize) -> Vec<std::ops::Range<usize>> {
    let t = if n < PARALLEL_MIN { 1 } else { threads };
    let size = n.div_ceil(t).max(1);
    (0..t)
        .map(|i| (i * size).min(n)..((i + 1) * size).min(n))
        .filter(|r| !r.is_empty())
        .collect()
}

/// Runs `work` over the chunks of `n` poses (in parallel when large), results in pose order.
fn map_chunks<T: Send>(
    n: usize,
    threads: usize,
    work: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    let chunks = pose_chunks(n, threads);
    if chunks.len() <= 1 {
        return chunks.into_iter().map(&work).collect();
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .into_iter()
            .map(|c| {
                let work = &work;
                s.spawn(move || work(c))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

/// Visits every pose at parameters `p` with its tip and squared geometric residual
/// `‖g_l‖²`: `step(acc, l, tip, ‖g_l‖²)`, over chunks of consecutive poses (in parallel when
/// there are many), each chunk folding into its own accumulator from `init`. The
/// accumulators come back in pose order, so merging them in order is deterministic.
pub(crate) fn fold_poses<A: Send>(
    model: &dyn CalibModel,
    poses: &Poses,
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
    map_chunks(poses.len(), thread_count(), |range| {
        let kin = Kinematics::new(model, p);
        let mut acc = init();
        let (mut tip, mut r) = ([0.0; 3], [0.0; 3]);
        for l in range {
            let j = poses.constraint.at(l);
            let Some(value) = values.get(j) else {
                continue; // out of range: refused where the poses are checked
            };
            let kind = model.constraint_kind(j);
            let nr = kind.residual_count(dim);
            kin.tip(&poses.q[l], &mut tip[..dim]);
            let measured = poses
                .measured
                .as_ref()
                .and_then(|m| m.get(l))
                .unwrap_or(&[]);
            geometry::geometric_residual(kind, dim, value, &tip[..dim], measured, &mut r[..nr]);
            let d2 = r[..nr].iter().map(|v| v * v).sum::<f64>();
            step(&mut acc, l, &tip[..dim], d2);
        }
        acc
    })
}

/// Per-thread scratch for one pose's linearisation.
struct Scratch {
    tip: [f64; 3],
    jac: Vec<f64>,
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
        let mut fit = GeometricFit {
            model,
            poses,
            set,
            kinds,
            value_free,
            threads,
            weights: None,
            relation_weight: 0.0,
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
            jac: vec![0.0; 3 * np],
            // Column-major `w × BLOCK`: one pose row per column, contiguous.
            block: DMatrix::zeros(w, BLOCK),
            filled: 0,
            gram: DMatrix::zeros(w, w),
        };
        let mut kin = Kinematics::new(self.model, p);
        let range_copy = range.clone();
        for l in range {
            let j = self.poses.constraint.at(l);
            let kind = self.kinds[j];
            let (nr, nv) = (kind.residual_count(dim), kind.value_count(dim));
            kin.tip_jacobian(&self.poses.q[l], &mut s.tip[..dim], &mut s.jac[..dim * np]);
            let rj =
                geometry::residual_jacobian(kind, dim, &values[j], &s.tip[..dim], self.measured(l));
            // dx is the identity for a point or a measured tip: the rows of ∂x/∂p as they are.
            let identity = matches!(kind, ConstraintKind::Point | ConstraintKind::Measured);
            for c in 0..nr {
                if s.filled == BLOCK {
                    flush(&mut s);
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
        flush(&mut s);
        // A non-finite entry anywhere reaches the Gram matrix; only then look for its pose.
        if !s.gram.iter().all(|v| v.is_finite()) {
            let at = range_copy
                .clone()
                .find(|&l| !self.pose_is_finite(&mut kin, values, l, &mut s));
            return Err(Error::other(match at {
                Some(l) => format!(
                    "the geometric residual is not finite at pose {l} (line {})",
                    self.poses.line.at(l)
                ),
                None => "the normal equations overflowed: the parameters have run off to \
                         values far beyond the data's scale"
                    .to_string(),
            }));
        }
        Ok(s.gram)
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
        kin.tip_jacobian(&self.poses.q[l], &mut s.tip[..dim], &mut s.jac[..dim * np]);
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

/// Folds the filled block into the Gram matrix: `G += B·Bᵀ` (a blocked matrix product).
fn flush(s: &mut Scratch) {
    if s.filled == 0 {
        return;
    }
    let b = s.block.columns(0, s.filled);
    let bt = b.transpose();
    s.gram.gemm(1.0, &b, &bt, 1.0);
    s.filled = 0;
}

impl LeastSquares for GeometricFit<'_> {
    fn unknowns(&self) -> usize {
        self.set.free.len()
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let p = self.set.full(x);
        let w = |l: usize| self.weights.map_or(1.0, |w| w[l]);
        let cost: f64 = fold_poses(
            self.model,
            self.poses,
            &p,
            || 0.0,
            |c, l, _, d2| {
                *c += w(l) * d2;
            },
        )
        .into_iter()
        .sum::<f64>()
            + crate::fit::relation::cost(self.model, &p, self.relation_weight);
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

/// What a geometric fit found.
#[derive(Clone, Debug)]
pub struct GeometricEstimate {
    /// The estimated-parameter vector (held ones at their start value).
    pub p: Vec<f64>,
    /// Free parameter indices.
    pub free: Vec<usize>,
    /// `Σ‖g‖²` at the start.
    pub start_cost: f64,
    /// `Σ‖g‖²` at `p`.
    pub cost: f64,
    /// Residual components `m`.
    pub components: usize,
    /// Standard deviations `σ̂²(JᵀJ)⁻¹`, `None` for held parameters (and all `None` when the
    /// Jacobian is singular at `p`).
    pub std: Vec<Option<f64>>,
    /// Covariance of the free parameters (order of `free`), when `JᵀJ` is invertible.
    pub covariance: Option<DMatrix<f64>>,
    /// Condition number of the column-equilibrated Jacobian at `p`.
    pub condition: f64,
    /// Numerical rank of the column-equilibrated Jacobian at `p`.
    pub rank: usize,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
}

/// Relative singular value below which a column-scaled Jacobian direction counts as lost.
pub(crate) const RANK_TOL: f64 = 1e-9;

/// Condition number and numerical rank of the column-equilibrated factor `r`.
pub(crate) fn condition_of(r: &DMatrix<f64>) -> Result<(f64, usize, Vec<f64>, DMatrix<f64>)> {
    let n = r.ncols();
    if n == 0 {
        return Ok((1.0, 0, Vec::new(), DMatrix::zeros(0, 0)));
    }
    let mut s = r.clone();
    for c in 0..n {
        let d = s.column(c).norm();
        s.column_mut(c).unscale_mut(if d > 0.0 { d } else { 1.0 });
    }
    let svd = checked_svd(s, false, true)?;
    let sv = svd.singular_values.as_slice().to_vec();
    let v = svd
        .v_t
        .as_ref()
        .map(DMatrix::transpose)
        .ok_or_else(|| Error::other("SVD without V"))?;
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
    let rank = sv.iter().filter(|&&x| x > RANK_TOL * smax).count();
    let cond = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    Ok((cond, rank, sv, v))
}

/// Minimises the geometric residual from `start` (every estimated parameter; held ones stay).
///
/// # Errors
/// [`Error::degenerate`] with fewer residual components than free parameters;
/// [`Error::other`] when the residual is not finite at the start.
pub fn fit(model: &dyn CalibModel, poses: &Poses, start: &[f64]) -> Result<GeometricEstimate> {
    fit_weighted(model, poses, start, None)
}

/// [`fit`] minimising `Σ_l w_l ‖g_l‖²` (one weight per pose; an iteratively reweighted robust
/// fit calls it with weights from the previous residuals).
///
/// # Errors
/// As [`fit`].
pub fn fit_weighted(
    model: &dyn CalibModel,
    poses: &Poses,
    start: &[f64],
    weights: Option<&[f64]>,
) -> Result<GeometricEstimate> {
    let mut problem = GeometricFit::new(model, poses, start)?;
    if let Some(w) = weights {
        if w.len() != poses.len() || w.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(Error::other(
                "one finite, non-negative weight per pose is needed",
            ));
        }
        problem.weights = Some(w);
    }
    let n = problem.unknowns();
    let m = problem.components() + problem.relation_components();
    if m <= n {
        return Err(Error::degenerate(format!(
            "{} poses give {m} residual components for {n} free parameters: more poses are needed",
            poses.len()
        )));
    }
    let x0 = problem.set.take(start);
    let start_cost = problem.cost(&x0);
    if !start_cost.is_finite() {
        return Err(Error::other(
            "the geometric residual is not finite at the starting point",
        ));
    }
    let res: LmResult = levenberg_marquardt(&problem, &x0, 200)?;
    finish(&problem, model, start_cost, res, m)
}

fn finish(
    problem: &GeometricFit<'_>,
    model: &dyn CalibModel,
    start_cost: f64,
    res: LmResult,
    m: usize,
) -> Result<GeometricEstimate> {
    let n = problem.unknowns();
    let p = problem.set.full(&res.x);
    let sigma2 = res.cost / (m - n) as f64;
    let (condition, rank, _, _) = condition_of(&res.lin.r)?;
    let mut std = vec![None; model.param_count()];
    let covariance = if rank == n {
        crate::numeric::lm::covariance(&res.lin.r, sigma2)
    } else {
        None
    };
    if let Some(cov) = &covariance {
        for (i, &j) in problem.set.free.iter().enumerate() {
            std[j] = Some(cov[(i, i)].max(0.0).sqrt());
        }
    }
    Ok(GeometricEstimate {
        p,
        free: problem.set.free.clone(),
        start_cost,
        cost: res.cost,
        components: m,
        std,
        covariance,
        condition,
        rank,
        iterations: res.iterations,
    })
}

/// Deterministic restarts about the nominals tried by [`fit_from_nominal`] after the nominal
/// start itself.
pub const RESTARTS: usize = 6;

/// Restarts run only when one linearisation costs at most this many flops (`m·n²`, about
/// 2 ms): on larger data sets the nominal start alone is taken.
pub const RESTART_WORK: f64 = 1e6;

/// [`fit`] from the nominals, then from [`RESTARTS`] deterministic perturbations of them
/// (free angles by up to ±0.5 rad, free lengths by up to ±20 % of the largest nominal length);
/// the lowest cost wins. Returns the estimate and how many starts were tried.
///
/// # Errors
/// As [`fit`] for the nominal start.
pub fn fit_from_nominal(
    model: &dyn CalibModel,
    poses: &Poses,
) -> Result<(GeometricEstimate, usize)> {
    use rand::{Rng, SeedableRng};
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let first = fit(model, poses, &nominal)?;
    let mut collapsed = collapsed_joints(model, poses, &nominal, &first.p);
    let mut best = first;
    let scale = (0..np)
        .filter(|&j| !model.param_is_angle(j))
        .fold(0.1f64, |m, j| m.max(nominal[j].abs()));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x1a2b);
    let mut tried = 1;
    // Restarts are for small data sets (where a start is cheap and a far local minimum is
    // likeliest); a large one has long since pulled the fit into the right basin.
    let work = best.components as f64 * (best.free.len() as f64).powi(2);
    let restarts = if work <= RESTART_WORK { RESTARTS } else { 0 };
    for _ in 0..restarts {
        // An exact fit needs no more starts: the cost per component is tiny against the
        // data's scale.
        let rms = (best.cost / best.components.max(1) as f64).sqrt();
        if rms <= 1e-9 * scale && collapsed.is_empty() {
            break;
        }
        let start: Vec<f64> = (0..np)
            .map(|j| {
                if model.param_held(j) {
                    nominal[j]
                } else if model.param_is_angle(j) {
                    nominal[j] + 0.5 * rng.gen_range(-1.0..1.0)
                } else {
                    nominal[j] + 0.2 * scale * rng.gen_range(-1.0..1.0)
                }
            })
            .collect();
        tried += 1;
        if let Ok(e) = fit(model, poses, &start) {
            let c = collapsed_joints(model, poses, &nominal, &e.p);
            // A mechanism that stopped moving is no answer, however well it fits.
            let better = if c.is_empty() == collapsed.is_empty() {
                e.cost < best.cost * (1.0 - 1e-9)
            } else {
                c.is_empty()
            };
            if better {
                best = e;
                collapsed = c;
            }
        }
    }
    if !collapsed.is_empty() {
        let names: Vec<String> = collapsed.iter().map(|i| format!("q{}", i + 1)).collect();
        return Err(Error::degenerate(format!(
            "the fit from the nominals collapses the arm: joint(s) {} no longer move the tip, a degenerate mechanism that satisfies the constraint trivially; use enough poses for the linear start (at least K = {} per constraint), or hold a length (`known: true`)",
            names.join(", "),
            model.basis_size()
        )));
    }
    Ok((best, tried))
}

/// Joints that move the tip at the nominals but (almost) not at `p`: the RMS over the poses
/// of `‖∂x/∂q_i‖` (central differences; this is a check, not a fit) falls below `10⁻⁶` of
/// its nominal value.
#[must_use]
pub fn collapsed_joints(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    p: &[f64],
) -> Vec<usize> {
    let dim = model.dim();
    let nj = model.joint_count();
    let step = poses.len().div_ceil(64).max(1);
    let speed = |params: &[f64], i: usize| {
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        let mut sum = 0.0;
        for q in poses.q.iter().step_by(step) {
            let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
            qp[i] += 1e-4;
            qm[i] -= 1e-4;
            model.tip(&qp, params, &mut a[..dim]);
            model.tip(&qm, params, &mut b[..dim]);
            sum += (0..dim).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
        }
        sum.sqrt()
    };
    (0..nj)
        .filter(|&i| {
            let nom = speed(nominal, i);
            nom > 0.0 && speed(p, i) < 1e-6 * nom
        })
        .collect()
}

/// Checks, before any expensive step, that the poses can determine the free parameters:
/// enough residual components, joints that move, and a Jacobian of full column rank at a
/// deterministic generic point near the nominals (`O(N·n²)`, one pass).
///
/// # Errors
/// [`Error::degenerate`] naming what is lost.
pub fn check_support(model: &dyn CalibModel, poses: &Poses) -> Result<()> {
    let n = poses.len();
    if n == 0 {
        return Err(Error::degenerate("no poses in the data"));
    }
    let nj = model.joint_count();
    let moved: Vec<bool> = (0..nj)
        .map(|i| {
            let first = poses.q[0][i];
            poses.q.iter().any(|q| q[i] != first)
        })
        .collect();
    if n > 1 && moved.iter().all(|m| !m) {
        return Err(Error::degenerate(format!(
            "all {n} poses have the same joint readings: the data determines nothing"
        )));
    }
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let generic = generic_point(model, &nominal);
    let problem = GeometricFit::new(model, poses, &generic)?;
    let free = problem.unknowns();
    let m = problem.components();
    if m <= free {
        return Err(Error::degenerate(format!(
            "the {n} poses give {m} residual components for {free} free parameters: at least {} poses are needed",
            (n * (free + 1)).div_ceil(m.max(1))
        )));
    }
    let lin = problem.linearize(&problem.set.take(&generic))?;
    let (_, rank, sv, v) = condition_of(&lin.r)?;
    if rank < free {
        let smax = sv.iter().copied().fold(0.0, f64::max);
        let mut lost = Vec::new();
        for (i, &s) in sv.iter().enumerate() {
            if s > RANK_TOL * smax {
                continue;
            }
            let col = v.column(i);
            let big = col.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            let terms: Vec<String> = col
                .iter()
                .enumerate()
                .filter(|(_, x)| x.abs() >= 0.2 * big)
                .map(|(c, x)| format!("{x:+.2}·{}", model.param_name(problem.set.free[c])))
                .collect();
            lost.push(terms.join(" "));
        }
        let mut msg = format!(
            "the {n} poses do not determine every free parameter; lost combination(s): {}",
            lost.join("; ")
        );
        let frozen: Vec<String> = (0..nj)
            .filter(|&i| !moved[i])
            .map(|i| format!("q{}", i + 1))
            .collect();
        if !frozen.is_empty() {
            msg.push_str(&format!("; joints that never moved: {}", frozen.join(", ")));
        }
        let empty: Vec<String> = (0..model.constraint_count())
            .filter(|&j| !poses.constraint.iter().any(|c| c == j))
            .map(|j| j.to_string())
            .collect();
        if !empty.is_empty() {
            msg.push_str(&format!(
                "; constraints without poses: {}",
                empty.join(", ")
            ));
        }
        return Err(Error::degenerate(msg));
    }
    Ok(())
}

/// A deterministic generic point about the nominals (free angles by up to 0.3 rad, free
/// lengths by up to 10 % of the largest nominal length): a nominal of exactly zero can hide
/// directions that any real arm has.
fn generic_point(model: &dyn CalibModel, nominal: &[f64]) -> Vec<f64> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x9e4e);
    let scale = (0..nominal.len())
        .filter(|&j| !model.param_is_angle(j))
        .fold(0.1f64, |m, j| m.max(nominal[j].abs()));
    (0..nominal.len())
        .map(|j| {
            let u: f64 = rng.gen_range(-1.0..1.0);
            if model.param_held(j) {
                nominal[j]
            } else if model.param_is_angle(j) {
                nominal[j] + 0.3 * u
            } else {
                nominal[j] + 0.1 * scale * u
            }
        })
        .collect()
}
