//! A constraint's unknown values refitted to given tips, the arm fixed: the least-squares
//! fit of the geometric residual over the values that are the fixture's own parameters,
//! the others (known, or shared with the chain) kept.
//!
//! The start is the closed-form fit of [`crate::fit::start::fit_values`] (point mean,
//! total-least-squares plane or line, Kåsa circle or sphere, linear quadric) when every value
//! is free, else the values given; Levenberg-Marquardt ([`crate::numeric::lm`]) on the exact
//! derivatives of [`residual_jacobian`] then minimises `Σ_l ‖g_l‖²`. For a point (all free)
//! the minimum is the mean tip, for a plane or a line the total-least-squares fit, for a
//! circle or sphere the geometric fit.

use crate::error::Result;
use crate::model::chain::Factor;
use crate::model::geometry::{geometric_residual, residual_jacobian, ConstraintKind};
use crate::model::CalibModel;
use crate::numeric::linalg::StreamingQr;
use crate::numeric::lm::{levenberg_marquardt, LeastSquares, Linearization};

/// Iterations of the refit (each one pass over the tips).
const MAX_ITERATIONS: usize = 200;

/// Which values of constraint `j` are refitted: those that are an estimated parameter moving
/// no joint of the chain (a fixture's coordinates, a plane's `b`, a sphere's centre and
/// radius). Known values, numbers, and parameters shared with the chain are kept.
#[must_use]
pub fn refitted_values(model: &dyn CalibModel, j: usize) -> Vec<bool> {
    let np = model.param_count();
    let mut in_chain = vec![false; np];
    for t in model
        .chain()
        .iter()
        .flat_map(|f: &Factor| f.terms.iter().flatten())
    {
        if let Some(u) = in_chain.get_mut(t.param) {
            *u = true;
        }
    }
    let nv = model.constraint_kind(j).value_count(model.dim());
    (0..nv)
        .map(|v| {
            model
                .constraint_value_param(j, v)
                .is_some_and(|s| !in_chain.get(s).copied().unwrap_or(true))
        })
        .collect()
}

/// The tips of one constraint with its values: the least-squares problem in the free values.
struct Refit<'a> {
    kind: ConstraintKind,
    dim: usize,
    tips: &'a [[f64; 3]],
    measured: &'a [Vec<f64>],
    values: Vec<f64>,
    free: Vec<usize>,
}

impl Refit<'_> {
    fn full(&self, x: &[f64]) -> Vec<f64> {
        let mut v = self.values.clone();
        for (&i, &xi) in self.free.iter().zip(x) {
            v[i] = xi;
        }
        v
    }
}

impl LeastSquares for Refit<'_> {
    fn unknowns(&self) -> usize {
        self.free.len()
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let v = self.full(x);
        let c = sum_squares(self.kind, self.dim, &v, self.tips, self.measured);
        if c.is_finite() {
            c
        } else {
            f64::INFINITY
        }
    }

    fn linearize(&self, x: &[f64]) -> Result<Linearization> {
        let n = self.free.len();
        let v = self.full(x);
        let nr = self.kind.residual_count(self.dim);
        let nv = v.len();
        let mut qr = StreamingQr::new(n + 1);
        let mut cost = 0.0;
        let mut row = vec![0.0; n + 1];
        for (l, x) in self.tips.iter().enumerate() {
            let m = self.measured.get(l).map_or(&[][..], Vec::as_slice);
            let rj = residual_jacobian(self.kind, self.dim, &v, &x[..self.dim], m);
            for c in 0..nr {
                for (k, &i) in self.free.iter().enumerate() {
                    row[k] = rj.dv[c * nv + i];
                }
                row[n] = rj.r[c];
                cost += rj.r[c] * rj.r[c];
                qr.push_row(&row);
            }
        }
        if !cost.is_finite() {
            cost = f64::INFINITY;
        }
        Ok(Linearization::from_qr(&mut qr, cost))
    }
}

/// `Σ_l ‖g_l‖²` of `tips` from the constraint with values `v`.
fn sum_squares(
    kind: ConstraintKind,
    dim: usize,
    v: &[f64],
    tips: &[[f64; 3]],
    measured: &[Vec<f64>],
) -> f64 {
    // A measured pose: its position error (the orientation's is not a distance).
    let nr = kind.residual_count(dim).min(3);
    let mut r = [0.0; 3];
    let mut s = 0.0;
    for (l, x) in tips.iter().enumerate() {
        let m = measured.get(l).map_or(&[][..], Vec::as_slice);
        geometric_residual(kind, dim, v, &x[..dim], m, &mut r[..nr]);
        s += r[..nr].iter().map(|a| a * a).sum::<f64>();
    }
    s
}

/// The values of a constraint of `kind` with the `free` ones refitted to `tips` (see the
/// module docs); `values` are the given ones (kept where not free, and the start otherwise
/// when the closed form does not apply). Gives the values unchanged when nothing is free or
/// there are no tips; the better of the start and the refit otherwise.
#[must_use]
pub fn refit_values(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    free: &[bool],
    tips: &[[f64; 3]],
    measured: &[Vec<f64>],
) -> Vec<f64> {
    let free_idx: Vec<usize> = (0..values.len()).filter(|&i| free[i]).collect();
    if free_idx.is_empty() || tips.is_empty() {
        return values.to_vec();
    }
    let mut start = values.to_vec();
    if free_idx.len() == values.len() {
        if let Some(v) = crate::fit::start::fit_values(kind, dim, tips) {
            if v.len() == values.len() && v.iter().all(|x| x.is_finite()) {
                start = v;
            }
        }
    }
    let problem = Refit {
        kind,
        dim,
        tips,
        measured,
        values: start.clone(),
        free: free_idx.clone(),
    };
    let x0: Vec<f64> = free_idx.iter().map(|&i| start[i]).collect();
    let c0 = problem.cost(&x0);
    match levenberg_marquardt(&problem, &x0, MAX_ITERATIONS) {
        Ok(r) if r.cost.is_finite() && r.cost <= c0 => problem.full(&r.x),
        _ => start,
    }
}

/// How many of the held-out residual components are left to judge a model by once the
/// refitted values are fitted to them: the position residual rows of `tips` (as
/// [`refit_values`] counts them) less the rank of their Jacobian over the refitted
/// parameters, at `values` (the refitted ones). `slot_param[v]` is the parameter in value
/// slot `v` of a `free` one: slots holding one parameter (a symmetric quadric's `A12`) are
/// one column. 0 when the refitted values can fit the tips exactly (three tips and a plane,
/// one tip and a point), whatever the arm's parameters: that residual says nothing. Repeated
/// poses count once.
#[must_use]
pub fn residual_dof(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    free: &[bool],
    slot_param: &[Option<usize>],
    tips: &[[f64; 3]],
    measured: &[Vec<f64>],
) -> usize {
    let nr = kind.residual_count(dim).min(3);
    let nv = values.len();
    // Columns: the distinct parameters of the free slots.
    let mut params: Vec<usize> = Vec::new();
    let col: Vec<Option<usize>> = (0..nv)
        .map(|v| {
            let param = slot_param.get(v).copied().flatten().filter(|_| free[v])?;
            Some(params.iter().position(|&q| q == param).unwrap_or_else(|| {
                params.push(param);
                params.len() - 1
            }))
        })
        .collect();
    let n = params.len();
    let mut rows = 0usize;
    let mut jtj = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut row = vec![0.0; n];
    // Once the rows seen have full rank, the rest only count: checked at 2n, 4n, 8n, … rows,
    // so a large held-out set costs a few dozen Jacobian rows, not one per component.
    let (mut next_check, mut full) = (2 * n.max(1), false);
    // A pose repeated (the same tip, to a picometre, and the same measurement) adds no
    // information: it is counted once.
    let mut seen = std::collections::HashSet::new();
    let key = |v: f64| (v * 1e12).round() as i64;
    for (l, x) in tips.iter().enumerate() {
        let m = measured.get(l).map_or(&[][..], Vec::as_slice);
        if kind == ConstraintKind::Measured && m.len() < dim {
            continue;
        }
        let k: Vec<i64> = x[..dim].iter().chain(m).map(|&v| key(v)).collect();
        if !seen.insert(k) {
            continue;
        }
        if full {
            rows += nr;
            continue;
        }
        let rj = residual_jacobian(kind, dim, values, &x[..dim], m);
        for c in 0..nr {
            row.iter_mut().for_each(|r| *r = 0.0);
            for (v, k) in col.iter().enumerate() {
                if let Some(k) = *k {
                    row[k] += rj.dv[c * nv + v];
                }
            }
            for a in 0..n {
                for b in 0..n {
                    jtj[(a, b)] += row[a] * row[b];
                }
            }
            rows += 1;
        }
        if rows >= next_check {
            full = n > 0 && rank(&jtj) == n;
            next_check *= 2;
        }
    }
    if full {
        return rows - n;
    }
    rows.saturating_sub(rank(&jtj))
}

/// The rank of `J` from `JᵀJ`: its eigenvalues above 10⁻²⁰ of the largest (singular values
/// above 10⁻¹⁰ of the largest); 0 for an empty or non-finite matrix.
fn rank(jtj: &nalgebra::DMatrix<f64>) -> usize {
    if jtj.nrows() == 0 || !jtj.iter().all(|v| v.is_finite()) {
        return 0;
    }
    let eig = jtj.clone().symmetric_eigen().eigenvalues;
    let top = eig.iter().copied().fold(0.0f64, f64::max);
    eig.iter()
        .filter(|&&e| top > 0.0 && e > 1e-20 * top)
        .count()
}
