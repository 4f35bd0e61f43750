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
//! These are diagnostics and the reference for the extraction ([`crate::extract`]), which fits
//! the physical parameters to the same factors `R_j`.

use nalgebra::DMatrix;

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::geometry::ConstraintKind;
use crate::linalg::{checked_svd, col_norms, lstsq, numerical_rank, scaled_svd, StreamingQr};
use crate::model::CalibModel;

/// How the linear solution of one constraint was formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolutionForm {
    /// The paper's Eq. 4: coefficient of the constant function fixed at 1, least squares for
    /// the rest.
    Normalised,
    /// Unit-norm right-singular vectors of the smallest singular values (one per equation).
    Homogeneous,
    /// Measured tip: each coordinate regressed on the basis.
    Regression,
    /// No poses on this constraint: nothing solved (all zeros).
    Empty,
}

/// The linear solve of one constraint (the poses that lie on it).
#[derive(Clone, Debug)]
pub struct GroupSolve {
    /// Index of the constraint.
    pub constraint: usize,
    /// Its kind.
    pub kind: ConstraintKind,
    /// The model's equation indices `e` of this constraint.
    pub equations: Vec<usize>,
    /// Number of poses on it.
    pub poses: usize,
    /// Columns of its data matrix: `K`, or `K + dim` for a measured tip.
    pub cols: usize,
    /// Upper-triangular factor `R_j` (`cols × cols`, unscaled) with `R_jᵀR_j = A_jᵀA_j`.
    pub r: DMatrix<f64>,
    /// Column norms `‖A_j e_k‖` (the scaling `D_j`; zero for a column the data never excites).
    pub col_norms: Vec<f64>,
    /// Singular values of the column-scaled `S_j = R_j·D_j⁻¹`, descending.
    pub singular_values: Vec<f64>,
    /// Right-singular vectors of `S_j` (columns, in the order of `singular_values`), in scaled
    /// coordinates.
    pub right_singular: DMatrix<f64>,
    /// Numerical rank of `S_j` (tolerance `max(rows, cols)·ε·σ_max`).
    pub rank: usize,
    /// How `solution` was formed.
    pub form: SolutionForm,
    /// The linear solution: one vector of `K` generalized parameters per equation of this
    /// constraint, in the order of `equations` (for the homogeneous form: the singular vectors
    /// of the smallest singular values first; the subspace, not the individual vectors, is
    /// what the data determines).
    pub solution: Vec<Vec<f64>>,
}

impl GroupSolve {
    /// The scaling `D_j`: column norms, with 1 in place of a zero norm.
    #[must_use]
    pub fn scale(&self) -> Vec<f64> {
        self.col_norms
            .iter()
            .map(|&d| if d > 0.0 { d } else { 1.0 })
            .collect()
    }
}

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
    measured: Vec<bool>,
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
        let measured: Vec<bool> = (0..m)
            .map(|j| model.constraint_kind(j) == ConstraintKind::Measured)
            .collect();
        let groups = measured
            .iter()
            .map(|&me| StreamingQr::new(if me { k + dim } else { k }))
            .collect();
        let n = model.joint_count();
        Ok(LinearSolver {
            model,
            k,
            groups,
            measured,
            row: vec![0.0; k + dim],
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
        let k = self.k;
        let dim = self.model.dim();
        self.model.basis(q, &mut self.row[..k]);
        if self.row[..k].iter().any(|v| !v.is_finite()) {
            return Err(Error::other(format!(
                "the basis is not finite at pose {pose}"
            )));
        }
        let cols = if self.measured[constraint] {
            let x = measured.filter(|x| x.len() == dim).ok_or_else(|| {
                Error::input(
                    place(),
                    "a pose on a measured constraint needs its measured tip",
                )
            })?;
            if x.iter().any(|v| !v.is_finite()) {
                return Err(Error::input(place(), "the measured tip is not finite"));
            }
            self.row[k..k + dim].copy_from_slice(x);
            k + dim
        } else {
            k
        };
        self.groups[constraint].push_row(&self.row[..cols]);
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
        Ok(())
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
        let (sv, bv) = scaled_svd(&basis_r, &scale)?;
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
    let mut s = LinearSolver::new(model)?;
    for l in 0..poses.len() {
        let measured = poses.measured.as_ref().and_then(|m| m.get(l));
        let c = poses.constraint.get(l).copied().unwrap_or(0);
        s.push(&poses.q[l], c, measured)
            .map_err(|e| match poses.line.get(l) {
                Some(&line) if e.class() == crate::error::ErrorClass::Input => Error::input(
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

fn solve_group(
    model: &dyn CalibModel,
    j: usize,
    poses: usize,
    r: DMatrix<f64>,
) -> Result<GroupSolve> {
    let k = model.basis_size();
    let kind = model.constraint_kind(j);
    let equations: Vec<usize> = (0..model.equation_count())
        .filter(|&e| model.equation_constraint(e) == j)
        .collect();
    let cols = r.ncols();
    let norms = col_norms(&r);
    let scale: Vec<f64> = norms
        .iter()
        .map(|&d| if d > 0.0 { d } else { 1.0 })
        .collect();
    let (sv, v) = scaled_svd(&r, &scale)?;
    let rank = numerical_rank(&sv, poses.max(cols));
    let mut group = GroupSolve {
        constraint: j,
        kind,
        equations,
        poses,
        cols,
        r,
        col_norms: norms,
        singular_values: sv,
        right_singular: v,
        rank,
        form: SolutionForm::Empty,
        solution: Vec::new(),
    };
    let ne = group.equations.len();
    if poses == 0 {
        group.solution = vec![vec![0.0; k]; ne];
        return Ok(group);
    }
    if kind == ConstraintKind::Measured {
        // c_e = R₁₁⁺ R₁₂ u_e, on scaled columns of R₁₁.
        let mut r11 = group.r.view((0, 0), (k, k)).into_owned();
        for (c, &d) in scale.iter().enumerate().take(k) {
            r11.column_mut(c).unscale_mut(d);
        }
        let rhs = group.r.view((0, k), (k, cols - k)).into_owned();
        let svd = checked_svd(r11, true, true)?;
        let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
        let tol = k.max(poses) as f64 * f64::EPSILON * smax;
        let x = svd
            .solve(&rhs, tol)
            .map_err(|e| Error::other(e.to_string()))?;
        group.solution = (0..ne)
            .map(|e| (0..k).map(|c| x[(c, e)] / scale[c]).collect())
            .collect();
        group.form = SolutionForm::Regression;
        return Ok(group);
    }
    if ne == 1 {
        if let Some(k0) = model.constant_index() {
            let others: Vec<usize> = (0..k).filter(|&c| c != k0).collect();
            let mut m = DMatrix::zeros(k, k - 1);
            for (i, &c) in others.iter().enumerate() {
                m.set_column(i, &(group.r.column(c) / scale[c]));
            }
            let b = -group.r.column(k0).into_owned();
            let x = lstsq(m, &b)?;
            let mut c = vec![0.0; k];
            c[k0] = 1.0;
            for (i, &col) in others.iter().enumerate() {
                c[col] = x[i] / scale[col];
            }
            if c.iter().all(|v| v.is_finite()) {
                group.solution = vec![c];
                group.form = SolutionForm::Normalised;
                return Ok(group);
            }
        }
    }
    // Homogeneous: the `ne` right-singular vectors of the smallest singular values.
    group.solution = (0..ne)
        .map(|i| {
            let col = cols - 1 - i;
            let mut c: Vec<f64> = (0..k)
                .map(|r| group.right_singular[(r, col)] / scale[r])
                .collect();
            let norm = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            let big = c
                .iter()
                .copied()
                .fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
            let s = if norm > 0.0 { big.signum() / norm } else { 0.0 };
            for x in &mut c {
                *x *= s;
            }
            c
        })
        .collect();
    group.form = SolutionForm::Homogeneous;
    Ok(group)
}
