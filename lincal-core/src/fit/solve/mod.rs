//! The linear solve: the paper's Eq. 4, done robustly and streamed.
//!
//! Every pose `l` on constraint `j` contributes one row to that constraint's data matrix
//! `A_j`: the basis `Φ̃(q_l)` (length `K`), or `[Φ̃(q_l), x_l]` (length `K + dim`) when the tip
//! is measured. Each equation `e` of constraint `j` satisfies `A_j·c_e ≈ 0` (for a measured tip
//! `A_j·[c_e; −u_e] ≈ 0`, `u_e` the `e`-th unit vector), so everything the data says about the
//! generalized parameters is in the Gram matrix `A_jᵀA_j = R_jᵀR_j`.
//!
//! Only the upper-triangular factor `R_j` of a QR decomposition of `A_j` is kept: rows are
//! buffered in blocks and `[R_j; block]` is re-factored ([`StreamingQr`]), so memory is
//! `O(K²)` whatever the number of poses, and the normal equations are never formed (their
//! condition number is the square of `A_j`'s).
//!
//! At the end the columns are scaled to unit norm, `S_j = R_j·D_j⁻¹` with
//! `D_j = diag(‖A_j e_k‖)` (the column norms of `R_j` equal those of `A_j`), and the singular
//! values of `S_j` give the numerical rank, with the tolerance
//! `max(rows, cols)·ε·σ_max(S_j)`. The linear solution ([`SolutionForm`]) is
//! - the paper's normalised form when a constraint has one equation and the basis holds the
//!   constant function `Φ̃_{k₀} = 1`: `c_{k₀} = 1` and the other entries the least-squares
//!   solution of `Σ_{k≠k₀} A_{:,k} c_k = −A_{:,k₀}`, solved on `R_j` with scaled columns by SVD;
//! - the homogeneous form otherwise (several equations, such as a pinned point, or no
//!   constant): the right-singular subspace of `S_j` of the `E_j` smallest singular values,
//!   mapped back by `D_j⁻¹`;
//! - for a measured tip, per coordinate the regression `x_e ≈ Φ̃·c_e`, from the blocks of
//!   `R_j = [[R₁₁, R₁₂], [0, R₂₂]]`: `c_e = R₁₁⁺ R₁₂ u_e`.
//!
//! These are diagnostics and the reference for the extraction ([`crate::fit::extract`]), which fits
//! the physical parameters to the same factors `R_j`.

mod group;

pub use group::{GroupSolve, SolutionForm};

use nalgebra::DMatrix;

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;
use crate::numeric::linalg::{col_norms, numerical_rank, scaled_svd, StreamingQr};

use group::solve_group;

/// Everything the linear solve found.
#[derive(Clone, Debug)]
pub struct LinearSolve {
    /// `K`.
    pub basis_size: usize,
    /// Number of poses.
    pub poses: usize,
    /// One entry per constraint of the model (also those without poses).
    pub groups: Vec<GroupSolve>,
    /// Singular values of the column-scaled stacked basis matrix (rows `Φ̃(q_l)` of every
    /// pose, `N × K`), descending.
    pub singular_values: Vec<f64>,
    /// Right-singular vectors (columns, scaled coordinates) of the stacked basis matrix, in
    /// the order of `singular_values`.
    pub basis_right_singular: DMatrix<f64>,
    /// Column norms of the stacked basis matrix.
    pub basis_col_norms: Vec<f64>,
    /// Numerical rank of the stacked basis matrix (tolerance `max(N, K)·ε·σ_max`): `K − E`
    /// for noise-free data on one constraint with `E` independent equations, `K` with noise.
    pub rank: usize,
    /// Smallest reading of each joint.
    pub joint_min: Vec<f64>,
    /// Largest reading of each joint.
    pub joint_max: Vec<f64>,
    /// Whether every pose has the same joint readings.
    pub all_identical: bool,
}

impl LinearSolve {
    /// The linear generalized parameters, equation-major (`E·K` values, `out[e·K + k]`), as
    /// the model orders its equations.
    #[must_use]
    pub fn generalized_params(&self, equation_count: usize) -> Vec<f64> {
        let k = self.basis_size;
        let mut out = vec![0.0; equation_count * k];
        for g in &self.groups {
            for (e, c) in g.equations.iter().zip(&g.solution) {
                out[e * k..(e + 1) * k].copy_from_slice(c);
            }
        }
        out
    }

    /// Joints whose reading never changed over the data (`max − min ≤ 1e-12·max(1, |q|)`).
    #[must_use]
    pub fn frozen_joints(&self) -> Vec<usize> {
        (0..self.joint_min.len())
            .filter(|&i| {
                let (lo, hi) = (self.joint_min[i], self.joint_max[i]);
                hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1.0)
            })
            .collect()
    }
}

/// Streams poses into one [`StreamingQr`] per constraint.
///
/// ```text
/// let mut s = LinearSolver::new(model)?;
/// for pose in poses { s.push(q, constraint, measured)?; }
/// let lin = s.finish()?;
/// ```
pub struct LinearSolver<'m> {
    model: &'m dyn CalibModel,
    k: usize,
    groups: Vec<StreamingQr>,
    /// Per constraint: the number of measured values of a pose (0 unless measured: `dim`
    /// for a tip, 12 for a pose).
    measured: Vec<usize>,
    row: Vec<f64>,
    poses: usize,
    joint_min: Vec<f64>,
    joint_max: Vec<f64>,
    first: Option<Vec<f64>>,
    all_identical: bool,
}

impl<'m> LinearSolver<'m> {
    /// An empty solver for `model`.
    ///
    /// # Errors
    /// [`Error::other`] when the model is inconsistent (no basis, no constraint).
    pub fn new(model: &'m dyn CalibModel) -> Result<Self> {
        let k = model.basis_size();
        let m = model.constraint_count();
        if k == 0 || m == 0 {
            return Err(Error::other(format!(
                "model `{}` has an empty basis or no constraint",
                model.name()
            )));
        }
        let dim = model.dim();
        let measured: Vec<usize> = (0..m)
            .map(|j| {
                let kind = model.constraint_kind(j);
                if kind.is_measured() {
                    kind.equation_count(dim)
                } else {
                    0
                }
            })
            .collect();
        let widest = measured.iter().copied().max().unwrap_or(0);
        // Each constraint's triangular factor is `(K + m)²`: a basis of thousands of
        // functions is refused by its size, not aborted by the allocator.
        let need: u64 = measured.iter().map(|&me| StreamingQr::bytes(k + me)).sum();
        if need > crate::memory::budget() {
            return Err(Error::other(format!(
                "the linear method's data matrix for a basis of K = {k} functions takes about \
                 {:.1} GB, beyond what the memory this process has left holds; use --start \
                 auto or nominal",
                need as f64 / 1e9
            )));
        }
        let groups = measured
            .iter()
            .map(|&me| StreamingQr::new(k + me))
            .collect();
        let n = model.joint_count();
        Ok(LinearSolver {
            model,
            k,
            groups,
            measured,
            row: vec![0.0; k + widest],
            poses: 0,
            joint_min: vec![f64::INFINITY; n],
            joint_max: vec![f64::NEG_INFINITY; n],
            first: None,
            all_identical: true,
        })
    }

    /// Adds one pose: joint readings `q`, the constraint it lies on, the measured tip when
    /// that constraint is `measured`.
    ///
    /// # Errors
    /// [`Error::input`] for a constraint index out of range, a missing measured tip, or
    /// non-finite readings; [`Error::other`] when the basis evaluates to a non-finite value.
    pub fn push(&mut self, q: &[f64], constraint: usize, measured: Option<&[f64]>) -> Result<()> {
        self.push_weighted(q, constraint, measured, 1.0)
    }

    /// [`LinearSolver::push`] with a weight `w ≥ 0`: the pose's row enters the data matrix
    /// scaled by `√w`, so its equations count `w` times in the least-squares cost (the
    /// iteratively reweighted solve, [`solve_robust`]).
    ///
    /// # Errors
    /// As [`LinearSolver::push`]; [`Error::other`] for a negative or non-finite weight.
    pub fn push_weighted(
        &mut self,
        q: &[f64],
        constraint: usize,
        measured: Option<&[f64]>,
        w: f64,
    ) -> Result<()> {
        self.check_pose(q, constraint, w)?;
        let cols = self.fill_row(q, constraint, measured)?;
        if w != 1.0 {
            let sw = w.sqrt();
            for v in &mut self.row[..cols] {
                *v *= sw;
            }
        }
        self.groups[constraint].push_row(&self.row[..cols]);
        self.record_joints(q);
        Ok(())
    }

    /// Refuses a pose before anything is computed: a negative or non-finite weight, a
    /// constraint index out of range, the wrong number of joint readings, a non-finite one.
    fn check_pose(&self, q: &[f64], constraint: usize, w: f64) -> Result<()> {
        if !(w >= 0.0 && w.is_finite()) {
            return Err(Error::other(format!(
                "pose {}: the weight {w} is not a finite number >= 0",
                self.poses
            )));
        }
        let pose = self.poses;
        let place = || crate::error::Location {
            pose: Some(pose),
            ..Default::default()
        };
        if constraint >= self.groups.len() {
            return Err(Error::input(
                place(),
                format!(
                    "constraint index {constraint} out of range (the model has {})",
                    self.groups.len()
                ),
            ));
        }
        if q.len() != self.model.joint_count() {
            return Err(Error::input(
                place(),
                format!(
                    "expected {} joint readings, found {}",
                    self.model.joint_count(),
                    q.len()
                ),
            ));
        }
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                place(),
                format!("joint reading q{} is not finite ({})", i + 1, q[i]),
            ));
        }
        Ok(())
    }

    /// Writes the pose's row into `self.row`: the basis at `q`, then the measured tip when the
    /// constraint is measured. Returns the row's length.
    fn fill_row(
        &mut self,
        q: &[f64],
        constraint: usize,
        measured: Option<&[f64]>,
    ) -> Result<usize> {
        let pose = self.poses;
        let place = || crate::error::Location {
            pose: Some(pose),
            ..Default::default()
        };
        let k = self.k;
        let width = self.measured[constraint];
        self.model.basis(q, &mut self.row[..k]);
        if self.row[..k].iter().any(|v| !v.is_finite()) {
            return Err(Error::other(format!(
                "the basis is not finite at pose {pose}"
            )));
        }
        let cols = if width > 0 {
            let x = measured.filter(|x| x.len() == width).ok_or_else(|| {
                Error::input(
                    place(),
                    "a pose on a measured constraint needs its measured tip",
                )
            })?;
            if x.iter().any(|v| !v.is_finite()) {
                return Err(Error::input(place(), "the measured tip is not finite"));
            }
            self.row[k..k + width].copy_from_slice(x);
            k + width
        } else {
            k
        };
        Ok(cols)
    }

    /// Counts the pushed pose and updates each joint's range and whether every pose so far
    /// has the same readings.
    fn record_joints(&mut self, q: &[f64]) {
        for (i, &v) in q.iter().enumerate() {
            self.joint_min[i] = self.joint_min[i].min(v);
            self.joint_max[i] = self.joint_max[i].max(v);
        }
        match &self.first {
            None => self.first = Some(q.to_vec()),
            Some(f) => {
                if self.all_identical && f.as_slice() != q {
                    self.all_identical = false;
                }
            }
        }
        self.poses += 1;
    }

    /// Factors, scales and solves every constraint's data.
    ///
    /// # Errors
    /// [`Error::other`] when an SVD fails to converge (it cannot on finite input).
    pub fn finish(mut self) -> Result<LinearSolve> {
        let model = self.model;
        let k = self.k;
        let mut groups = Vec::with_capacity(self.groups.len());
        let mut stacked = StreamingQr::new(k);
        for (j, acc) in self.groups.iter_mut().enumerate() {
            let r = acc.finish();
            for i in 0..k {
                let row: Vec<f64> = (0..k).map(|c| r[(i, c)]).collect();
                stacked.push_row(&row);
            }
            groups.push(solve_group(model, j, acc.rows(), r)?);
        }
        let basis_r = stacked.finish();
        let basis_col_norms = col_norms(&basis_r);
        let scale: Vec<f64> = basis_col_norms
            .iter()
            .map(|&d| if d > 0.0 { d } else { 1.0 })
            .collect();
        // One constraint without measured columns: the stacked factor is its factor again
        // (an orthogonal transform of the same rows), with the same scaling, singular values
        // and right-singular vectors; not decomposed twice.
        let (sv, bv) = match groups.as_slice() {
            [g] if g.cols == k => (g.singular_values.clone(), g.right_singular.clone()),
            _ => scaled_svd(&basis_r, &scale)?,
        };
        let rank = numerical_rank(&sv, self.poses.max(k));
        let n = model.joint_count();
        if self.poses == 0 {
            self.joint_min = vec![0.0; n];
            self.joint_max = vec![0.0; n];
        }
        Ok(LinearSolve {
            basis_size: k,
            poses: self.poses,
            groups,
            singular_values: sv,
            basis_right_singular: bv,
            basis_col_norms,
            rank,
            joint_min: self.joint_min,
            joint_max: self.joint_max,
            all_identical: self.all_identical,
        })
    }
}

/// Runs the linear solve over every pose of `poses`.
///
/// # Errors
/// As [`LinearSolver::push`] and [`LinearSolver::finish`].
pub fn solve(model: &dyn CalibModel, poses: &Poses) -> Result<LinearSolve> {
    solve_weighted(model, poses, None)
}

/// [`solve`] with a weight per pose (`weights[l]` for pose `l`, all 1 when `None`; see
/// [`LinearSolver::push_weighted`]).
///
/// # Errors
/// As [`solve`]; [`Error::other`] when `weights` is not one finite, non-negative number per
/// pose.
pub fn solve_weighted(
    model: &dyn CalibModel,
    poses: &Poses,
    weights: Option<&[f64]>,
) -> Result<LinearSolve> {
    if weights.is_some_and(|w| w.len() != poses.len()) {
        return Err(Error::other(format!(
            "{} weights for {} poses",
            weights.map_or(0, <[f64]>::len),
            poses.len()
        )));
    }
    let mut s = LinearSolver::new(model)?;
    for l in 0..poses.len() {
        let measured = poses.measured.as_ref().and_then(|m| m.get(l));
        let c = poses.constraint.at(l);
        let w = weights.map_or(1.0, |w| w[l]);
        s.push_weighted(&poses.q[l], c, measured, w)
            .map_err(|e| match poses.line.get(l) {
                Some(line) if e.class() == crate::error::ErrorClass::Input => Error::input(
                    crate::error::Location {
                        line: Some(line),
                        pose: Some(l),
                        ..Default::default()
                    },
                    e.diagnostics()
                        .first()
                        .map_or_else(String::new, |d| d.message.clone()),
                ),
                _ => e,
            })?;
    }
    s.finish()
}

/// Rounds of reweighting [`solve_robust`] runs at most (each one linear solve over the poses).
pub const LINEAR_IRLS_ROUNDS: usize = 20;

/// The reweighting stops when no weight moves by more than this between rounds (the weights
/// converge linearly, about tenfold a round; at 10⁻⁴ the solution has stopped moving to about
/// 10⁻⁹ of itself).
pub const LINEAR_IRLS_TOL: f64 = 1e-4;

/// Every pose's algebraic residual norm at the generalized parameters `c` (equation-major,
/// `E·K` values, as [`LinearSolve::generalized_params`] gives them): over the equations `e` of
/// the pose's constraint, `‖(c_e·Φ̃(q_l))_e‖`, the measured coordinate subtracted for a
/// measured tip (`c_e·Φ̃(q_l) − x_{l,e}`). A pose whose constraint index is out of range, or
/// whose measured tip is missing, gets NaN.
///
/// # Example
/// A 2R arm on the line `x = 0.8` (`b = (−1.25, 0)`): the stretched arm lies on it, so its
/// algebraic residual `b·x + 1` (in the linear solve's normalisation, the constant's
/// coefficient 1) is zero; the bent arm's is `−1.25·0.375 + 1`.
/// ```
/// use lincal_core::data::{Poses, Rows};
/// use lincal_core::fit::solve::algebraic_residuals;
/// use lincal_core::CalibModel;
/// let spec = lincal_core::spec::from_yaml_str(
///     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1}\n  \
///      - {type: revolute, a: a2}\nparams: {a1: {nominal: 0.375}, a2: {nominal: 0.425}}\n\
///      constraint: {line: {b: [-1.25, 0]}}\n",
///     None,
/// )
/// .unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// let mut c = vec![0.0; model.basis_size()];
/// model.generalized_params(&[0.375, 0.425], &mut c);
/// let k0 = model.constant_index().unwrap();
/// let c: Vec<f64> = c.iter().map(|v| v / c[k0]).collect();
/// let poses = Poses {
///     q: Rows::from_vec(2, vec![0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2]).unwrap(),
///     constraint: lincal_core::data::PoseColumn::labels_from([0, 0]),
///     ..Poses::default()
/// };
/// let r = algebraic_residuals(&model, &poses, &c);
/// assert!(r[0].abs() < 1e-15);
/// assert!((r[1] - (1.0 - 1.25 * 0.375)).abs() < 1e-15);
/// ```
#[must_use]
pub fn algebraic_residuals(model: &dyn CalibModel, poses: &Poses, c: &[f64]) -> Vec<f64> {
    let k = model.basis_size();
    let ne = model.equation_count();
    if c.len() != ne * k {
        return vec![f64::NAN; poses.len()];
    }
    // For each constraint: its equations, and for a measured one each equation's coordinate
    // (the equations of a measured constraint are the tip coordinates, in order).
    let eqs: Vec<Vec<usize>> = (0..model.constraint_count())
        .map(|j| {
            (0..ne)
                .filter(|&e| model.equation_constraint(e) == j)
                .collect()
        })
        .collect();
    let mut phi = vec![0.0; k];
    let mut out = Vec::with_capacity(poses.len());
    for (l, q) in poses.q.iter().enumerate() {
        let Some(j) = poses.constraint.get(l).filter(|&j| j < eqs.len()) else {
            out.push(f64::NAN);
            continue;
        };
        model.basis(q, &mut phi);
        let measured = model.constraint_kind(j).is_measured();
        let x = poses.measured.as_ref().and_then(|m| m.get(l));
        let mut sum = 0.0;
        for (i, &e) in eqs[j].iter().enumerate() {
            let mut r: f64 = c[e * k..(e + 1) * k]
                .iter()
                .zip(&phi)
                .map(|(a, b)| a * b)
                .sum();
            if measured {
                r -= x.and_then(|x| x.get(i)).copied().unwrap_or(f64::NAN);
            }
            sum += r * r;
        }
        out.push(sum.sqrt());
    }
    out
}

/// What the iteratively reweighted linear solve ([`solve_robust`]) did.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearReweighting {
    /// Weighted solves run after the ordinary one (0 when no constraint had a robust scale:
    /// fewer than 10 poses on each, or exact data).
    pub rounds: usize,
    /// Poses whose weight in the last solve was below ½.
    pub downweighted: usize,
    /// Each pose's weight in the last solve (1 for every pose when `rounds` is 0).
    pub weights: Vec<f64>,
}

/// The linear solve, iteratively reweighted by `loss`: the ordinary solve, then, at most
/// [`LINEAR_IRLS_ROUNDS`] times, each pose's algebraic residual `r_l`
/// ([`algebraic_residuals`] at the current solution) is standardised by its constraint's
/// robust scale, `z_l = r_l / (s_j·√E_j)` with `s_j` the median over the constraint's poses of
/// `r / χ̃_{E_j}` (`E_j` its equations, `χ̃` the median of a χ distribution: a noise σ per
/// equation that one bad row cannot inflate), weighted `w_l = loss.weight(z_l)`, and the
/// data solved again with those weights ([`solve_weighted`]); it stops when no weight moves
/// by more than [`LINEAR_IRLS_TOL`]. A constraint with fewer than 10 poses (no meaningful
/// median) or a vanishing scale keeps weight 1.
///
/// The algebraic residual is the constraint function `c_e·Φ̃(q)`: to first order the
/// geometric distance times the function's gradient, which is the same for every pose on a
/// line, a plane or a pinned point and nearly so on a circle or a sphere (`‖x − c‖² − r² ≈
/// 2r·d`), so each constraint's robust scale plays the role of its noise level.
///
/// # Errors
/// As [`solve`].
pub fn solve_robust(
    model: &dyn CalibModel,
    poses: &Poses,
    loss: crate::numeric::robust::Robust,
) -> Result<(LinearSolve, LinearReweighting)> {
    let n = poses.len();
    let mut lin = solve(model, poses)?;
    let mut weights = vec![1.0; n];
    let mut rounds = 0;
    let nc = model.constraint_count();
    // Equations per constraint.
    let eq: Vec<usize> = (0..nc)
        .map(|j| {
            (0..model.equation_count())
                .filter(|&e| model.equation_constraint(e) == j)
                .count()
                .max(1)
        })
        .collect();
    let group = |l: usize| poses.constraint.get(l).filter(|&j| j < nc);
    for round in 1..=LINEAR_IRLS_ROUNDS {
        crate::cancel::check()?;
        let c = lin.generalized_params(model.equation_count());
        let r = algebraic_residuals(model, poses, &c);
        let scale = robust_scales(&r, &eq, group);
        let usable = |s: f64| s > 0.0 && s.is_finite();
        if !scale.iter().copied().any(usable) {
            break;
        }
        let next: Vec<f64> = r
            .iter()
            .enumerate()
            .map(|(l, &x)| match group(l) {
                Some(j) if usable(scale[j]) && x.is_finite() => {
                    loss.weight(x / (scale[j] * (eq[j] as f64).sqrt()))
                }
                _ => 1.0,
            })
            .collect();
        let moved = next
            .iter()
            .zip(&weights)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if moved <= LINEAR_IRLS_TOL {
            break;
        }
        weights = next;
        lin = solve_weighted(model, poses, Some(&weights))?;
        rounds = round;
    }
    let downweighted = weights.iter().filter(|&&w| w < 0.5).count();
    Ok((
        lin,
        LinearReweighting {
            rounds,
            downweighted,
            weights,
        },
    ))
}

/// The robust scale of each constraint's residuals `r` (one per pose; `group` names a
/// pose's constraint, `eq` each constraint's equations): the median of the finite
/// `r / χ̃_{E_j}` over its poses, NaN with fewer than 10 of them.
fn robust_scales(r: &[f64], eq: &[usize], group: impl Fn(usize) -> Option<usize>) -> Vec<f64> {
    let nc = eq.len();
    let mut u: Vec<Vec<f64>> = vec![Vec::new(); nc];
    for (l, &x) in r.iter().enumerate() {
        if let Some(j) = group(l) {
            if x.is_finite() {
                u[j].push(x / crate::numeric::robust::chi_median(eq[j]));
            }
        }
    }
    u.iter_mut()
        .map(|v| {
            if v.len() < 10 {
                return f64::NAN;
            }
            let mid = v.len() / 2;
            *v.select_nth_unstable_by(mid, f64::total_cmp).1
        })
        .collect()
}
