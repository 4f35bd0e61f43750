//! The linear solve of one constraint: from the factor `R_j` of its poses' data matrix, the
//! column scaling, the singular values and numerical rank, and the linear solution in the
//! form that applies (normalised, homogeneous, or a measured tip's regression).
//!
//! Takes the model, the constraint's index and its factor; gives a [`GroupSolve`].

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::numeric::linalg::{checked_svd, col_norms, lstsq, numerical_rank, scaled_svd};

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

/// The linear solve of constraint `j` from its factor `r` over `poses` poses: the scaled
/// SVD and rank, then the solution in the form that applies ([`SolutionForm`]).
pub(super) fn solve_group(
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
        group.solution = regression_solution(&group, k, &scale)?;
        group.form = SolutionForm::Regression;
        return Ok(group);
    }
    if ne == 1 {
        if let Some(k0) = model.constant_index() {
            if let Some(c) = normalised_solution(&group, k, k0, &scale)? {
                group.solution = vec![c];
                group.form = SolutionForm::Normalised;
                return Ok(group);
            }
        }
    }
    group.solution = homogeneous_solution(&group, k, &scale);
    group.form = SolutionForm::Homogeneous;
    Ok(group)
}

/// A measured tip's regression `c_e = R₁₁⁺ R₁₂ u_e` per coordinate, on scaled columns of
/// `R₁₁`.
fn regression_solution(group: &GroupSolve, k: usize, scale: &[f64]) -> Result<Vec<Vec<f64>>> {
    let (cols, poses, ne) = (group.cols, group.poses, group.equations.len());
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
    Ok((0..ne)
        .map(|e| (0..k).map(|c| x[(c, e)] / scale[c]).collect())
        .collect())
}

/// The paper's normalised solution: `c_{k₀} = 1` for the constant function `k₀`, the rest the
/// least-squares solution on scaled columns; `None` when it is not finite.
fn normalised_solution(
    group: &GroupSolve,
    k: usize,
    k0: usize,
    scale: &[f64],
) -> Result<Option<Vec<f64>>> {
    if k >= LARGE_BASIS && group.rank == k && group.cols == k {
        return Ok(normalised_from_svd(group, k, k0, scale));
    }
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
    Ok(c.iter().all(|v| v.is_finite()).then_some(c))
}

/// From this basis size on, a full-rank normalised solve is read off the constraint's SVD
/// ([`normalised_from_svd`]) instead of a second SVD of the same columns: at `K` in the
/// thousands each SVD takes tens of seconds (issue 50, item 9).
const LARGE_BASIS: usize = 500;

/// The normalised solution from the SVD `S = UΣVᵀ` of the scaled factor (full rank): the
/// minimiser of `‖S·c̃‖` with `c̃_{k₀} = D_{k₀}` (that is `c_{k₀} = 1`) is
/// `c̃ = D_{k₀}·G⁻¹e / (eᵀG⁻¹e)` with `G = SᵀS = VΣ²Vᵀ`, `e = e_{k₀}`: the same least-squares
/// problem as [`normalised_solution`]'s, without factoring its columns again.
fn normalised_from_svd(group: &GroupSolve, k: usize, k0: usize, scale: &[f64]) -> Option<Vec<f64>> {
    let v = &group.right_singular;
    // y = Σ⁻²Vᵀe, then G⁻¹e = V·y.
    let y: Vec<f64> = (0..k)
        .map(|i| v[(k0, i)] / (group.singular_values[i] * group.singular_values[i]))
        .collect();
    let g: Vec<f64> = (0..k)
        .map(|r| (0..k).map(|i| v[(r, i)] * y[i]).sum::<f64>())
        .collect();
    let denom = g[k0];
    let c: Vec<f64> = (0..k)
        .map(|r| g[r] / denom / scale[r] * scale[k0])
        .collect();
    let mut c = c;
    c[k0] = 1.0;
    c.iter().all(|x| x.is_finite()).then_some(c)
}

/// The homogeneous solution: the right-singular vectors of the `E_j` smallest singular
/// values, mapped back by `D_j⁻¹`, each of unit norm with its largest entry positive.
fn homogeneous_solution(group: &GroupSolve, k: usize, scale: &[f64]) -> Vec<Vec<f64>> {
    let (cols, ne) = (group.cols, group.equations.len());
    // Homogeneous: the `ne` right-singular vectors of the smallest singular values.
    (0..ne)
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
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The normalised solution read off the SVD equals the one from factoring the columns
    /// again, on a random full-rank factor with badly scaled columns.
    #[test]
    fn the_normalised_solution_from_the_svd_is_the_least_squares_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(50);
        let k = 9;
        let a = DMatrix::from_fn(40, k, |_, c| {
            rng.gen_range(-1.0..1.0) * 10f64.powi(c as i32 % 4 - 2)
        });
        let r = a.qr().r();
        let norms = col_norms(&r);
        let (sv, v) = scaled_svd(&r, &norms).unwrap();
        let group = GroupSolve {
            constraint: 0,
            kind: ConstraintKind::Plane,
            equations: vec![0],
            poses: 40,
            cols: k,
            r,
            col_norms: norms.clone(),
            rank: k,
            singular_values: sv,
            right_singular: v,
            form: SolutionForm::Empty,
            solution: Vec::new(),
        };
        for k0 in [0, 4, k - 1] {
            let want = normalised_solution(&group, k, k0, &norms).unwrap().unwrap();
            let got = normalised_from_svd(&group, k, k0, &norms).unwrap();
            for (w, g) in want.iter().zip(&got) {
                assert!((w - g).abs() <= 1e-9 * w.abs().max(1.0), "{want:?} {got:?}");
            }
        }
    }
}
