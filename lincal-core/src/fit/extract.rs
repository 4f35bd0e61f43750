//! Extraction: from the data's generalized-parameter information back to the physical
//! parameters, general for any model.
//!
//! # The method
//! The linear solve ([`crate::fit::solve`]) leaves, for each constraint `j`, the factor `R_j` with
//! `R_jᵀR_j = A_jᵀA_j`. For parameters `p` the algebraic residual of pose `l` and equation `e`
//! is `h_e(q_l; p) = c_e(p)·Φ̃(q_l)` (for a measured tip `c_e(p)·Φ̃(q_l) − x_{l,e}`), so
//!
//! ```text
//! cost(p) = Σ_j Σ_{e ∈ j} ‖R_j·c_e(p)‖²          (measured: ‖R_j·[c_e(p); −u_e]‖²)
//!         = Σ_l Σ_e h_e(q_l; p)²,
//! ```
//! computed from `K × K` factors, independent of the number of poses. It is minimised over the
//! free parameters (`!model.param_held(j)`; the held ones, the gauge, stay at their nominal)
//! by Levenberg-Marquardt ([`crate::fit::refine`]'s core) with the Jacobian `R_j·∂c_e/∂p` from
//! [`CalibModel::jacobian`], starting from the nominals.
//!
//! This replaces the paper's analytic step 7 for every model, and it handles the pitfalls of
//! the linear solve by construction: a pinned point (two equations, a 2-D null space: each
//! equation gets its own `c_e(p)`, no "+1" normalisation), a 3-D line (the data's null space
//! has extra structural directions; `c(p)` can only move on the model's manifold, which picks
//! the right ones), circles and spheres (the reduced basis of the model), measured tips.
//!
//! # Finding the global minimum
//! Some mechanisms satisfy a constraint identically for special parameters (`c_e(p) = 0`, say
//! a collapsed link keeping the tip on a sphere): an exact zero of the plain cost. So the fit
//! runs in two phases: first on the scale-invariant cost `Σ ‖R_j c_e‖²/‖D_j c_e‖²` (each
//! equation's Rayleigh quotient on the column-scaled data, `D_j` the column norms), which has
//! no such zero, then on the plain cost from there.
//!
//! A fit is accepted when every fitted `c_e(p̂)` is as close to the data's null space as the
//! linear solve allows: `‖R_j c_e‖/‖D_j c_e‖ ≤ 10·σ_{K−E_j+1}(R_j D_j⁻¹) + 10⁻¹⁰·σ_max`, or for a
//! measured tip a residual within 10 times the regression's ([`fit_ratio`] ≤ 1). Otherwise, in
//! a fixed order (deterministic): a staged start (the constraint's own parameters fitted
//! first with the arm at its nominal), then each free angle shifted by `π, π/2, −π/2` from the
//! best point (up to three rounds), then 24 starts with every free angle drawn about its
//! nominal from a constant-seeded sequence; the lowest cost wins.
//!
//! Discrete ambiguities (the same data fitted exactly by a mirrored arm) are resolved towards
//! the nominals: a free length whose sign differs from its nominal's is flipped and the fit
//! repeated, keeping the flip when it fits as well; a length entering only squared (a radius)
//! or together with a half-turn of an angle takes its nominal's sign. Free angles are wrapped
//! into `(−π, π]`.
//!
//! # Uncertainty
//! `cov = σ̂²(JᵀJ)⁻¹` at the solution with `σ̂² = cost/(m − n)`, `m = Σ_j N_j·E_j` the number of
//! scalar equations over all poses and `n` the number of free parameters. For lines, planes,
//! points and measured tips the algebraic residual is a fixed multiple of the geometric one, so
//! this is the least-squares covariance; for curved constraints it is first-order.
//!
//! # Degenerate data
//! Before fitting: no poses, all poses identical, fewer poses than `K` on a single constraint,
//! or no more equations than free parameters. After: a rank-deficient `J` (column-scaled
//! singular values below `1e-10·σ_max`) names the parameter combinations lost (its null space),
//! the basis functions the data does not excite and the joints that never moved.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::fit::solve::{GroupSolve, LinearSolve};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::numeric::linalg::{checked_svd, StreamingQr};
use crate::numeric::lm::{
    covariance, levenberg_marquardt, FreeSet, LeastSquares, Linearization, LmResult,
};
use crate::numeric::wrap_angle;

/// Relative singular-value threshold below which the column-scaled Jacobian is rank-deficient.
pub const JACOBIAN_RANK_TOL: f64 = 1e-10;

/// What the extraction found.
#[derive(Clone, Debug)]
pub struct Extraction {
    /// The estimated-parameter vector `p` (held parameters at their nominal).
    pub p: Vec<f64>,
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// Algebraic cost `Σ_l Σ_e h_e(q_l; p)²` at `p`.
    pub cost: f64,
    /// Number of scalar equations `m = Σ_j N_j·E_j`.
    pub equations: usize,
    /// `σ̂² = cost/(m − n)`.
    pub sigma2: f64,
    /// Covariance of the free parameters (`n × n`, in the order of `free`).
    pub covariance: DMatrix<f64>,
    /// Standard deviation of each estimated parameter; `None` for held ones.
    pub std: Vec<Option<f64>>,
    /// The largest ratio of the fitted `c_e(p)`'s distance from the data's null space to the
    /// linear solution's (with slack, see the module docs): `≤ 1` means the fit is as good as
    /// the linear solve allows.
    pub fit_ratio: f64,
    /// Number of restarts tried.
    pub restarts: usize,
    /// Condition number of the column-scaled Jacobian at `p`.
    pub condition: f64,
    /// Things a user should know.
    pub warnings: Vec<String>,
}

/// Which algebraic cost a problem minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Cost {
    /// `Σ ‖R_j c_e(p)‖²`.
    Plain,
    /// The scale-invariant cost (see [`AlgebraicProblem`]).
    Normalized,
}

/// The algebraic problem over the free parameters.
///
/// With [`Cost::Normalized`], each equation of a constraint that is not measured contributes
/// `R_j c_e(p) / ‖D_j c_e(p)‖` instead of `R_j c_e(p)`: a scale-invariant cost (the
/// Rayleigh quotient of the scaled data matrix) with no minimum at `c_e(p) → 0`. Some
/// mechanisms can satisfy a constraint identically (`c_e(p) = 0`: a collapsed link keeping
/// the tip on a sphere, say), which is an exact zero of the plain cost; the normalised cost is
/// used first to find the right basin, the plain one then polishes within it.
struct AlgebraicProblem<'a> {
    model: &'a dyn CalibModel,
    lin: &'a LinearSolve,
    set: FreeSet,
    cost: Cost,
    scales: Vec<Vec<f64>>,
    /// The weight of the relations' rows (see [`crate::fit::relation`]); 0 without relations.
    relation_weight: f64,
    /// Where the weight was taken (the nominals).
    weighed: Vec<f64>,
}

impl<'a> AlgebraicProblem<'a> {
    fn new(model: &'a dyn CalibModel, lin: &'a LinearSolve, nominal: &[f64], cost: Cost) -> Self {
        AlgebraicProblem {
            model,
            lin,
            set: FreeSet::new(model, nominal),
            cost,
            scales: lin.groups.iter().map(GroupSolve::scale).collect(),
            relation_weight: 0.0,
            weighed: nominal.to_vec(),
        }
        .weighed_at(nominal)
    }

    /// The same problem (same free set) with the other cost.
    fn with_cost(&self, cost: Cost) -> Self {
        AlgebraicProblem {
            model: self.model,
            lin: self.lin,
            set: self.set.clone(),
            cost,
            scales: self.scales.clone(),
            relation_weight: 0.0,
            weighed: self.weighed.clone(),
        }
        .weighed_at(&self.weighed)
    }

    /// The problem with its relation weight taken from the data's Jacobian at `p` (the
    /// relations make the fit in `c`-space a constrained one; see [`crate::fit::relation`]).
    fn weighed_at(mut self, p: &[f64]) -> Self {
        if !self.model.relations().is_empty() && p.len() == self.model.param_count() {
            let x = self.set.take(p);
            if let Ok(lin) = self.linearize(&x) {
                let diag: Vec<f64> = lin.r.column_iter().map(|c| c.norm_squared()).collect();
                self.relation_weight = crate::fit::relation::weight(&diag);
            }
        }
        self
    }

    /// `v_e = c_e` (length `cols`), with `−1` at `K + i` for coordinate `i` of a measured tip.
    fn residual_vector(&self, c: &[f64], g: usize, i: usize) -> DVector<f64> {
        let k = self.lin.basis_size;
        let group = &self.lin.groups[g];
        let e = group.equations[i];
        let mut v = DVector::zeros(group.cols);
        for kk in 0..k {
            v[kk] = c[e * k + kk];
        }
        if group.kind == ConstraintKind::Measured {
            v[k + i] = -1.0;
        }
        v
    }

    /// `‖D_j v_e‖` over the basis part when normalising this group, else `None`.
    fn norm_of(&self, g: usize, v: &DVector<f64>) -> Option<f64> {
        let group = &self.lin.groups[g];
        if self.cost == Cost::Plain || group.kind == ConstraintKind::Measured {
            return None;
        }
        let k = self.lin.basis_size;
        Some(
            (0..k)
                .map(|kk| (v[kk] * self.scales[g][kk]).powi(2))
                .sum::<f64>()
                .sqrt(),
        )
    }

    fn gen(&self, p: &[f64]) -> Vec<f64> {
        let mut c = vec![0.0; self.model.equation_count() * self.lin.basis_size];
        self.model.generalized_params(p, &mut c);
        c
    }
}

impl LeastSquares for AlgebraicProblem<'_> {
    fn unknowns(&self) -> usize {
        self.set.free.len()
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let p = self.set.full(x);
        let c = self.gen(&p);
        let mut cost = crate::fit::relation::cost(self.model, &p, self.relation_weight);
        for (g, group) in self.lin.groups.iter().enumerate() {
            if group.poses == 0 {
                continue;
            }
            for i in 0..group.equations.len() {
                let v = self.residual_vector(&c, g, i);
                let r2 = (&group.r * &v).norm_squared();
                cost += match self.norm_of(g, &v) {
                    Some(nv) => r2 / (nv * nv),
                    None => r2,
                };
            }
        }
        if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        }
    }

    fn linearize(&self, x: &[f64]) -> Result<Linearization> {
        let n = self.unknowns();
        let k = self.lin.basis_size;
        let np = self.model.param_count();
        let p = self.set.full(x);
        let c = self.gen(&p);
        let mut jac = vec![0.0; self.model.equation_count() * k * np];
        self.model.jacobian(&p, &mut jac);
        if jac.iter().chain(&c).any(|v| !v.is_finite()) {
            return Err(Error::other(
                "the generalized parameters or their Jacobian are not finite",
            ));
        }
        let mut qr = StreamingQr::new(n + 1);
        let mut cost = 0.0;
        let mut row = vec![0.0; n + 1];
        for (g, group) in self.lin.groups.iter().enumerate() {
            if group.poses == 0 {
                continue;
            }
            for (i, &e) in group.equations.iter().enumerate() {
                let v = self.residual_vector(&c, g, i);
                let mut r = &group.r * &v;
                let mut jc = DMatrix::zeros(group.cols, n);
                for kk in 0..k {
                    for (col, &j) in self.set.free.iter().enumerate() {
                        jc[(kk, col)] = jac[(e * k + kk) * np + j];
                    }
                }
                let mut rj = &group.r * &jc;
                if let Some(nv) = self.norm_of(g, &v) {
                    if nv == 0.0 {
                        return Err(Error::other("an equation vanishes identically"));
                    }
                    // d(R v / ‖Dv‖) = R dv / ‖Dv‖ − R v (vᵀD² dv) / ‖Dv‖³
                    let mut w = DVector::zeros(n);
                    for col in 0..n {
                        w[col] = (0..k)
                            .map(|kk| v[kk] * self.scales[g][kk].powi(2) * jc[(kk, col)])
                            .sum::<f64>();
                    }
                    rj = rj / nv - (&r * w.transpose()) / (nv * nv * nv);
                    r /= nv;
                }
                for a in 0..group.cols {
                    for col in 0..n {
                        row[col] = rj[(a, col)];
                    }
                    row[n] = r[a];
                    qr.push_row(&row);
                }
                cost += r.norm_squared();
            }
        }
        if self.relation_weight > 0.0 {
            let w = self.relation_weight;
            for rel in crate::fit::relation::rows(self.model, &p) {
                row.iter_mut().for_each(|x| *x = 0.0);
                for (param, d) in &rel.gradient {
                    if let Some(pos) = self.set.free.iter().position(|f| f == param) {
                        row[pos] += w * d;
                    }
                }
                row[n] = w * rel.residual;
                qr.push_row(&row);
                cost += row[n] * row[n];
            }
        }
        Ok(Linearization::from_qr(&mut qr, cost))
    }
}

/// The largest ratio of the fitted `c_e(p)`'s residual to what the linear solve reached (see
/// the module docs); `≤ 1` is a good fit. `+∞` when an equation vanishes identically.
#[must_use]
pub fn fit_ratio(model: &dyn CalibModel, lin: &LinearSolve, p: &[f64]) -> f64 {
    let k = lin.basis_size;
    let mut c = vec![0.0; model.equation_count() * k];
    model.generalized_params(p, &mut c);
    let mut worst: f64 = 0.0;
    for g in lin.groups.iter().filter(|g| g.poses > 0) {
        let ne = g.equations.len();
        let smax = g.singular_values.first().copied().unwrap_or(0.0);
        let scale = g.scale();
        for (i, &e) in g.equations.iter().enumerate() {
            let ce = &c[e * k..(e + 1) * k];
            let mut v = DVector::zeros(g.cols);
            for kk in 0..k {
                v[kk] = ce[kk];
            }
            let ratio = if g.kind == ConstraintKind::Measured {
                v[k + i] = -1.0;
                let res = (&g.r * &v).norm();
                let best = g.r.view((k, k + i), (g.cols - k, 1)).norm();
                let col = g.r.column(k + i).norm();
                res / (10.0 * best + 1e-10 * col + f64::MIN_POSITIVE)
            } else {
                let dnorm = ce
                    .iter()
                    .zip(&scale)
                    .map(|(a, d)| (a * d) * (a * d))
                    .sum::<f64>()
                    .sqrt();
                if dnorm == 0.0 {
                    f64::INFINITY
                } else {
                    let rho = (&g.r * &v).norm() / dnorm;
                    let sref = g
                        .singular_values
                        .get(g.cols.saturating_sub(ne))
                        .copied()
                        .unwrap_or(0.0);
                    rho / (10.0 * sref + 1e-10 * smax + f64::MIN_POSITIVE)
                }
            };
            worst = worst.max(if ratio.is_nan() { f64::INFINITY } else { ratio });
        }
    }
    worst
}

/// Positions in `free` of the parameters that do not move the tip (the constraint's own),
/// found by perturbing each at two fixed joint configurations.
fn constraint_only(model: &dyn CalibModel, free: &[usize], p: &[f64]) -> Vec<usize> {
    let nj = model.joint_count();
    let dim = model.dim();
    let qs: [Vec<f64>; 2] = [
        (0..nj).map(|i| 0.3 + 0.7 * i as f64).collect(),
        (0..nj).map(|i| -1.1 + 0.45 * i as f64).collect(),
    ];
    let mut t0 = vec![0.0; dim];
    let mut t1 = vec![0.0; dim];
    (0..free.len())
        .filter(|&i| {
            let j = free[i];
            let mut pp = p.to_vec();
            pp[j] += 1e-3 * p[j].abs().max(1.0);
            qs.iter().all(|q| {
                model.tip(q, p, &mut t0);
                model.tip(q, &pp, &mut t1);
                t0.iter().zip(&t1).all(|(a, b)| a == b)
            })
        })
        .collect()
}

/// Sign conventions for the exact symmetries of `c(p)`: a free length that enters only
/// squared (a radius) takes its nominal's sign (zero counts as positive); a free length that
/// flips together with a half-turn of a free angle (`a → −a, θ → θ + π`) takes its nominal's
/// sign when that is not zero, and otherwise the variant whose angle is nearer its nominal.
fn canonical_signs(problem: &AlgebraicProblem<'_>, x: &mut [f64], nominal: &[f64]) {
    let model = problem.model;
    let set = &problem.set;
    let n = set.free.len();
    let c0 = problem.gen(&set.full(x));
    let scale = c0.iter().fold(1.0f64, |a, v| a.max(v.abs()));
    let same = |y: &[f64]| {
        let c = problem.gen(&set.full(y));
        c.iter()
            .zip(&c0)
            .all(|(a, b)| (a - b).abs() <= 1e-12 * scale)
    };
    for i in 0..n {
        let j = set.free[i];
        if model.param_is_angle(j) || x[i] == 0.0 {
            continue;
        }
        let wanted = if nominal[j] < 0.0 { -1.0 } else { 1.0 };
        let mut y = x.to_vec();
        y[i] = -y[i];
        if same(&y) {
            if x[i].signum() != wanted {
                x.copy_from_slice(&y);
            }
            continue;
        }
        for a in (0..n).filter(|&a| model.param_is_angle(set.free[a])) {
            let mut z = y.clone();
            z[a] += std::f64::consts::PI;
            if !same(&z) {
                continue;
            }
            let better = if nominal[j] != 0.0 {
                x[i].signum() != wanted
            } else {
                let nom = nominal[set.free[a]];
                wrap_angle(z[a] - nom).abs() < wrap_angle(x[a] - nom).abs() - 1e-12
            };
            if better {
                x.copy_from_slice(&z);
            }
            break;
        }
    }
}

/// Checks the data can determine the free parameters at all (before any fit).
///
/// # Errors
/// [`Error::degenerate`] with the reason.
pub fn check_data(model: &dyn CalibModel, lin: &LinearSolve) -> Result<()> {
    let k = lin.basis_size;
    let n = lin.poses;
    let free = (0..model.param_count())
        .filter(|&j| !model.param_held(j))
        .count();
    if n == 0 {
        return Err(Error::degenerate("no poses in the data"));
    }
    if lin.all_identical && n > 1 {
        return Err(Error::degenerate(format!(
            "all {n} poses have the same joint readings: the data determines nothing"
        )));
    }
    if model.constraint_count() == 1 && n < k {
        return Err(Error::degenerate(format!(
            "{n} poses, but the basis has K = {k} functions: at least {k} poses are needed (more for noisy data)"
        )));
    }
    let m: usize = lin.groups.iter().map(|g| g.poses * g.equations.len()).sum();
    if m <= free {
        return Err(Error::degenerate(format!(
            "the {n} poses give {m} equations for {free} free parameters: more poses are needed"
        )));
    }
    Ok(())
}

/// Fits the physical parameters to the linear solve (see the module docs).
///
/// # Errors
/// [`Error::degenerate`] when the data cannot determine the free parameters (with the reason
/// and what is lost); [`Error::other`] on a numerical failure.
pub fn extract(model: &dyn CalibModel, lin: &LinearSolve) -> Result<Extraction> {
    extract_from(model, lin, None)
}

/// [`extract`] starting from `start` (all estimated parameters; held ones are taken from the
/// nominals regardless) instead of the nominals, e.g. a closed-form solution
/// ([`crate::fit::closed_form`]).
///
/// # Errors
/// As [`extract`].
pub fn extract_from(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    start: Option<&[f64]>,
) -> Result<Extraction> {
    check_data(model, lin)?;
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    if nominal.iter().any(|v| !v.is_finite()) {
        return Err(Error::other("a nominal parameter value is not finite"));
    }
    let plain = AlgebraicProblem::new(model, lin, &nominal, Cost::Plain);
    let normalized = plain.with_cost(Cost::Normalized);
    check_excitation(&plain, &nominal)?;
    let x0 = match start {
        Some(s) if s.len() == np && s.iter().all(|v| v.is_finite()) => plain.set.take(s),
        _ => plain.set.take(&nominal),
    };
    // Phase 1: the normalised cost finds the basin (with restarts when it fits badly).
    let mut search = first_fit(&plain, &normalized, &x0)?;
    staged_start(&normalized, &nominal, &x0, &mut search);
    angle_shifts(&normalized, &mut search);
    random_restarts(&normalized, &x0, &mut search);
    // Phase 2: the plain cost Σ h² polishes within it.
    polish(&plain, &mut search)?;
    // Phase 3: discrete ambiguities of lengths, then canonical signs and wrapped angles.
    sign_flips(&plain, &nominal, &mut search);
    finish(&plain, &nominal, search)
}

/// The best fit so far, how far its `c` is from the data's null space (≤ 1: as near as the
/// linear solution), and how many restarts it took.
struct Search {
    best: LmResult,
    ratio: f64,
    restarts: usize,
}

impl Search {
    /// Keeps `res` when it lowers the cost by more than rounding.
    fn offer(&mut self, problem: &AlgebraicProblem<'_>, res: LmResult) -> bool {
        if res.cost < self.best.cost * (1.0 - 1e-9) {
            self.ratio = fit_ratio(problem.model, problem.lin, &problem.set.full(&res.x));
            self.best = res;
            true
        } else {
            false
        }
    }
}

/// Can these poses determine the free parameters at all? A frozen joint or too few distinct
/// poses make the data-weighted Jacobian singular at every parameter point, so it is checked
/// at a generic point near the nominals, before any fit (a fit on such data can wander off
/// instead of stopping where the final rank test would catch it).
fn check_excitation(plain: &AlgebraicProblem<'_>, nominal: &[f64]) -> Result<()> {
    if plain.unknowns() == 0 {
        return Ok(());
    }
    let (model, lin, set) = (plain.model, plain.lin, &plain.set);
    let xg = generic_point(model, &set.free, &set.take(nominal));
    let l = plain.linearize(&xg)?;
    match rank_deficiency(model, lin, set, &l.r, &set.full(&xg))? {
        Some(err) => Err(err),
        None => Ok(()),
    }
}

/// The normalised fit from `x0`; where an equation vanishes identically there, the plain
/// cost first.
fn first_fit(
    plain: &AlgebraicProblem<'_>,
    normalized: &AlgebraicProblem<'_>,
    x0: &[f64],
) -> Result<Search> {
    let best = match levenberg_marquardt(normalized, x0, 300) {
        Ok(res) => res,
        Err(_) => {
            let res = levenberg_marquardt(plain, x0, 300)?;
            levenberg_marquardt(normalized, &res.x, 300)?
        }
    };
    let ratio = fit_ratio(plain.model, plain.lin, &plain.set.full(&best.x));
    Ok(Search {
        best,
        ratio,
        restarts: 0,
    })
}

/// A staged start when the fit is bad: the constraint's own parameters first, with the arm
/// at its nominal, then everything.
fn staged_start(
    normalized: &AlgebraicProblem<'_>,
    nominal: &[f64],
    x0: &[f64],
    search: &mut Search,
) {
    if search.ratio <= 1.0 {
        return;
    }
    let (model, lin) = (normalized.model, normalized.lin);
    let geo = constraint_only(model, &normalized.set.free, nominal);
    if geo.is_empty() || geo.len() >= normalized.unknowns() {
        return;
    }
    let mut sub = normalized.with_cost(Cost::Normalized);
    sub.set.free = geo.iter().map(|&i| normalized.set.free[i]).collect();
    let Ok(a) = levenberg_marquardt(&sub, &sub.set.take(nominal), 300) else {
        return;
    };
    let mut start = x0.to_vec();
    for (k, &i) in geo.iter().enumerate() {
        start[i] = a.x[k];
    }
    search.restarts += 1;
    if let Ok(res) = levenberg_marquardt(normalized, &start, 300) {
        if res.cost < search.best.cost {
            search.ratio = fit_ratio(model, lin, &normalized.set.full(&res.x));
            search.best = res;
        }
    }
}

/// Indices (in the free set) of the free angles.
fn free_angles(problem: &AlgebraicProblem<'_>) -> Vec<usize> {
    (0..problem.unknowns())
        .filter(|&i| problem.model.param_is_angle(problem.set.free[i]))
        .collect()
}

/// Up to three rounds of shifting each free angle by π and ±π/2, while the fit is bad.
fn angle_shifts(normalized: &AlgebraicProblem<'_>, search: &mut Search) {
    use std::f64::consts::{FRAC_PI_2, PI};
    let angles = free_angles(normalized);
    for _round in 0..3 {
        if search.ratio <= 1.0 {
            return;
        }
        let mut improved = false;
        for &i in &angles {
            for shift in [PI, FRAC_PI_2, -FRAC_PI_2] {
                let mut start = search.best.x.clone();
                start[i] += shift;
                search.restarts += 1;
                let Ok(res) = levenberg_marquardt(normalized, &start, 300) else {
                    continue;
                };
                if search.offer(normalized, res) {
                    improved = true;
                    if search.ratio <= 1.0 {
                        return;
                    }
                }
            }
        }
        if !improved {
            return;
        }
    }
}

/// Last resort: a fixed pseudo-random sequence of starts, every free angle drawn in (−π, π)
/// about its nominal (deterministic: a constant seed).
fn random_restarts(normalized: &AlgebraicProblem<'_>, x0: &[f64], search: &mut Search) {
    use rand::{Rng, SeedableRng};
    use std::f64::consts::PI;
    let angles = free_angles(normalized);
    if search.ratio <= 1.0 || angles.is_empty() {
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed);
    for _ in 0..24 {
        let mut start = x0.to_vec();
        for &i in &angles {
            start[i] += rng.gen_range(-PI..PI);
        }
        search.restarts += 1;
        let Ok(res) = levenberg_marquardt(normalized, &start, 300) else {
            continue;
        };
        if search.offer(normalized, res) && search.ratio <= 1.0 {
            return;
        }
    }
}

/// The plain cost from the normalised fit's point; kept unless it drifted towards a
/// degenerate zero (then phase 1's point, linearised for the plain cost).
fn polish(plain: &AlgebraicProblem<'_>, search: &mut Search) -> Result<()> {
    let polished = levenberg_marquardt(plain, &search.best.x, 300)?;
    let polished_ratio = fit_ratio(plain.model, plain.lin, &plain.set.full(&polished.x));
    if polished_ratio <= search.ratio.max(1.0) {
        search.best = polished;
        search.ratio = polished_ratio;
    } else {
        search.best = levenberg_marquardt(plain, &search.best.x, 0)?;
    }
    Ok(())
}

/// A free length with the opposite sign to its nominal is flipped and the fit repeated; the
/// flipped solution is kept when it fits as well.
fn sign_flips(plain: &AlgebraicProblem<'_>, nominal: &[f64], search: &mut Search) {
    let (model, lin) = (plain.model, plain.lin);
    for i in 0..plain.unknowns() {
        let j = plain.set.free[i];
        let x = &search.best.x;
        if model.param_is_angle(j) || nominal[j] == 0.0 || x[i].signum() == nominal[j].signum() {
            continue;
        }
        let mut start = x.clone();
        start[i] = -start[i];
        let Ok(res) = levenberg_marquardt(plain, &start, 300) else {
            continue;
        };
        let r = fit_ratio(model, lin, &plain.set.full(&res.x));
        let ratio = search.ratio;
        let as_good = r <= ratio.max(1.0)
            && (res.cost <= search.best.cost * (1.0 + 1e-6) || (r <= 1e-3 && ratio <= 1e-3));
        if as_good && res.x[i].signum() == nominal[j].signum() {
            search.best = res;
            search.ratio = r;
        }
    }
}

/// Canonical signs and wrapped angles, the rank of the Jacobian on the data, the
/// covariance, and the checks that nothing is non-finite.
fn finish(plain: &AlgebraicProblem<'_>, nominal: &[f64], search: Search) -> Result<Extraction> {
    let (model, lin) = (plain.model, plain.lin);
    let n = plain.unknowns();
    let np = model.param_count();
    let m: usize = lin.groups.iter().map(|g| g.poses * g.equations.len()).sum();
    let Search {
        best,
        ratio,
        restarts,
    } = search;
    let mut warnings = Vec::new();
    let mut x = best.x.clone();
    canonical_signs(plain, &mut x, nominal);
    for i in free_angles(plain) {
        x[i] = wrap_angle(x[i]);
    }
    let p = plain.set.full(&x);
    let cost = best.cost;
    if ratio > 1.0 {
        warnings.push(format!(
            "the fitted generalized parameters are {:.3e} times farther from the data's null space than the linear solution allows: possibly a local minimum, a model that does not fit the data, or too few poses",
            ratio * 10.0
        ));
    }
    let mut condition = 1.0;
    let mut covariance_m = DMatrix::zeros(n, n);
    let sigma2 = cost / (m - n) as f64;
    let mut std = vec![None; np];
    if n > 0 {
        let l = plain.linearize(&x)?;
        let norms: Vec<f64> = (0..n).map(|c| l.r.column(c).norm()).collect();
        let mut s = l.r.clone();
        for (c, &d) in norms.iter().enumerate() {
            s.column_mut(c).unscale_mut(if d > 0.0 { d } else { 1.0 });
        }
        let svd = checked_svd(s, false, true)?;
        let sv = svd.singular_values.as_slice().to_vec();
        let smax = sv.first().copied().unwrap_or(0.0);
        let smin = sv.last().copied().unwrap_or(0.0);
        if norms.contains(&0.0) || smin <= JACOBIAN_RANK_TOL * smax {
            let v = svd
                .v_t
                .as_ref()
                .map(DMatrix::transpose)
                .ok_or_else(|| Error::other("SVD without V"))?;
            return Err(rank_error(model, lin, &plain.set, &p, &sv, &v, &norms));
        }
        condition = smax / smin;
        if condition > 1e8 {
            warnings.push(format!(
                "the parameters are poorly determined by these poses (condition number {condition:.2e}): move every joint over a wider range"
            ));
        }
        covariance_m = covariance(&l.r, sigma2)
            .ok_or_else(|| Error::degenerate("the Jacobian is singular at the solution"))?;
        for (i, &j) in plain.set.free.iter().enumerate() {
            std[j] = Some(covariance_m[(i, i)].max(0.0).sqrt());
        }
    }
    if p.iter().any(|v| !v.is_finite())
        || !cost.is_finite()
        || std.iter().flatten().any(|v| !v.is_finite())
    {
        return Err(Error::other(
            "the extraction produced a non-finite value; the data or the model is degenerate",
        ));
    }
    Ok(Extraction {
        p,
        free: plain.set.free.clone(),
        cost,
        equations: m,
        sigma2,
        covariance: covariance_m,
        std,
        fit_ratio: ratio,
        restarts,
        condition,
        warnings,
    })
}

/// A deterministic generic point about the nominals `x` of the free parameters: angles moved
/// by up to 0.3 rad, lengths by up to 10 % of the largest nominal length.
fn generic_point(model: &dyn CalibModel, free: &[usize], x: &[f64]) -> Vec<f64> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x9e4e);
    let scale = free
        .iter()
        .zip(x)
        .filter(|(&j, _)| !model.param_is_angle(j))
        .fold(0.1f64, |m, (_, v)| m.max(v.abs()));
    free.iter()
        .zip(x)
        .map(|(&j, &v)| {
            let u: f64 = rng.gen_range(-1.0..1.0);
            if model.param_is_angle(j) {
                v + 0.3 * u
            } else {
                v + 0.1 * scale * u
            }
        })
        .collect()
}

/// The degenerate-data error when the data-weighted Jacobian factor `r` (free parameters as
/// columns) is rank-deficient at `p`, `None` when it has full column rank.
fn rank_deficiency(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    set: &FreeSet,
    r: &DMatrix<f64>,
    p: &[f64],
) -> Result<Option<Error>> {
    let n = r.ncols();
    let norms: Vec<f64> = (0..n).map(|c| r.column(c).norm()).collect();
    let mut s = r.clone();
    for (c, &d) in norms.iter().enumerate() {
        s.column_mut(c).unscale_mut(if d > 0.0 { d } else { 1.0 });
    }
    let svd = checked_svd(s, false, true)?;
    let sv = svd.singular_values.as_slice().to_vec();
    let smax = sv.first().copied().unwrap_or(0.0);
    let smin = sv.last().copied().unwrap_or(0.0);
    if norms.contains(&0.0) || smin <= JACOBIAN_RANK_TOL * smax {
        let v = svd
            .v_t
            .as_ref()
            .map(DMatrix::transpose)
            .ok_or_else(|| Error::other("SVD without V"))?;
        return Ok(Some(rank_error(model, lin, set, p, &sv, &v, &norms)));
    }
    Ok(None)
}

/// The degenerate-data error for a rank-deficient Jacobian: what is lost and why.
fn rank_error(
    model: &dyn CalibModel,
    lin: &LinearSolve,
    set: &FreeSet,
    p: &[f64],
    sv: &[f64],
    v: &DMatrix<f64>,
    norms: &[f64],
) -> Error {
    let smax = sv.first().copied().unwrap_or(0.0);
    let mut lost = Vec::new();
    for (c, &d) in norms.iter().enumerate() {
        if d == 0.0 {
            lost.push(model.param_name(set.free[c]).to_string());
        }
    }
    for (i, &s) in sv.iter().enumerate() {
        if s > JACOBIAN_RANK_TOL * smax {
            continue;
        }
        let col = v.column(i);
        let big = col.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let big_cols: Vec<usize> = col
            .iter()
            .enumerate()
            .filter(|(_, x)| x.abs() >= 0.2 * big)
            .map(|(c, _)| c)
            .collect();
        // A direction along a column of zeros is already named above.
        if big_cols.iter().all(|&c| norms[c] == 0.0) {
            continue;
        }
        let terms: Vec<String> = big_cols
            .iter()
            .map(|&c| format!("{:+.2}·{}", col[c], model.param_name(set.free[c])))
            .collect();
        lost.push(terms.join(" "));
    }
    let mut msg = format!(
        "the poses do not determine every free parameter; lost combination(s): {}",
        lost.join("; ")
    );
    let unexcited = unexcited_basis(model, lin, p);
    if !unexcited.is_empty() {
        // A long list helps nobody: the first few show which joints are involved.
        const SHOWN: usize = 10;
        let more = unexcited.len().saturating_sub(SHOWN);
        msg.push_str(&format!(
            "; basis functions the data does not excite: {}{}",
            unexcited[..unexcited.len().min(SHOWN)].join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ));
    }
    let frozen = lin.frozen_joints();
    if !frozen.is_empty() {
        let names: Vec<String> = frozen.iter().map(|i| format!("q{}", i + 1)).collect();
        msg.push_str(&format!("; joints that never moved: {}", names.join(", ")));
    }
    let empty: Vec<String> = lin
        .groups
        .iter()
        .filter(|g| g.poses == 0)
        .map(|g| g.constraint.to_string())
        .collect();
    if !empty.is_empty() {
        msg.push_str(&format!(
            "; constraints without poses: {}",
            empty.join(", ")
        ));
    }
    Error::degenerate(msg)
}

/// Basis functions in the stacked data matrix's (near) null space that the fitted constraint
/// equations do not explain: the directions the data does not excite.
#[must_use]
pub fn unexcited_basis(model: &dyn CalibModel, lin: &LinearSolve, p: &[f64]) -> Vec<String> {
    let k = lin.basis_size;
    let smax = lin.singular_values.first().copied().unwrap_or(0.0);
    let scale: Vec<f64> = lin
        .basis_col_norms
        .iter()
        .map(|&d| if d > 0.0 { d } else { 1.0 })
        .collect();
    let mut c = vec![0.0; model.equation_count() * k];
    model.generalized_params(p, &mut c);
    // Orthonormal basis of the fitted equations' directions (scaled), constraint by constraint.
    let mut explained: Vec<DVector<f64>> = Vec::new();
    for g in lin.groups.iter().filter(|g| g.poses > 0) {
        if g.kind == ConstraintKind::Measured {
            continue;
        }
        for &e in &g.equations {
            let mut u = DVector::from_iterator(k, (0..k).map(|kk| c[e * k + kk] * scale[kk]));
            for q in &explained {
                let d = q.dot(&u);
                u -= q * d;
            }
            let nu = u.norm();
            if nu > 1e-8 {
                explained.push(u / nu);
            }
        }
    }
    let mut names: Vec<String> = Vec::new();
    for (i, &s) in lin.singular_values.iter().enumerate() {
        if s > 1e-9 * smax {
            continue;
        }
        let mut w = lin.basis_right_singular.column(i).into_owned();
        for q in &explained {
            let d = q.dot(&w);
            w -= q * d;
        }
        if w.norm() < 0.5 {
            continue;
        }
        let big = w.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for (kk, x) in w.iter().enumerate() {
            let name = model.basis_name(kk).to_string();
            if x.abs() >= 0.3 * big && !names.contains(&name) {
                names.push(name);
            }
        }
    }
    for (kk, &d) in lin.basis_col_norms.iter().enumerate() {
        let name = model.basis_name(kk).to_string();
        if d == 0.0 && !names.contains(&name) {
            names.push(name);
        }
    }
    names
}
