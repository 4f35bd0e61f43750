//! Relations between constraints in the numeric fits: residual rows, the weight that makes
//! them (nearly) exact, projection of a parameter vector onto them, and what they achieve.
//!
//! Each relation `R(v_i, v_j) = 0` ([`crate::model::geometry::relation_residual_in`], in metres) on
//! two constraints' values becomes the rows `w·R(p)` of a least-squares problem, with
//! `∂R/∂p` from dual numbers through the values (a value is a fixed number or one estimated
//! parameter, [`CalibModel::constraint_value_param`]). The weight `w = RELATION_STIFFNESS · s`
//! scales with the data's own Jacobian (`s²` the mean diagonal of `JᵀJ`), so a relation
//! weighs like 10⁶ times an average data direction: the fitted relation is off by about
//! 10⁻⁶ of what the data alone would pull it to, while the normal equations stay well
//! conditioned.

use crate::model::geometry::{relation_residual_in, Dual, Relation, MAX_INPUTS};
use crate::model::CalibModel;

/// `w / s`: a relation weighs like this many average data rows, squared (see the module docs).
pub const RELATION_STIFFNESS: f64 = 1e3;

/// One residual component of a relation: its value (metres) and `∂/∂p` as `(param, value)`.
#[derive(Clone, Debug, PartialEq)]
pub struct RelationRow {
    /// The residual.
    pub residual: f64,
    /// Its gradient over the estimated parameters (sparse).
    pub gradient: Vec<(usize, f64)>,
}

/// The values of constraint `j` at `p`.
fn values(model: &dyn CalibModel, j: usize, p: &[f64]) -> Vec<f64> {
    let n = model.constraint_kind(j).value_count(model.dim());
    let mut v = vec![0.0; n];
    model.constraint_values(j, p, &mut v);
    v
}

/// Every relation's residual components at `p`, in order.
#[must_use]
pub fn residuals(model: &dyn CalibModel, p: &[f64]) -> Vec<f64> {
    rows(model, p).into_iter().map(|r| r.residual).collect()
}

/// Every relation's residual components at `p` with their gradients.
#[must_use]
pub fn rows(model: &dyn CalibModel, p: &[f64]) -> Vec<RelationRow> {
    model
        .relations()
        .iter()
        .flat_map(|rel| relation_rows(model, rel, p))
        .collect()
}

/// The relations (positions in [`CalibModel::relations`]) that `p` misses by more than `tol`
/// (metres) in some residual component, each with its largest component's magnitude (a
/// non-finite one counts as missed).
#[must_use]
pub fn unmet(model: &dyn CalibModel, p: &[f64], tol: f64) -> Vec<(usize, f64)> {
    model
        .relations()
        .iter()
        .enumerate()
        .filter_map(|(k, rel)| {
            let worst = relation_rows(model, rel, p)
                .iter()
                .map(|r| r.residual.abs())
                .fold(0.0f64, |a, r| {
                    if a.is_nan() || r.is_nan() {
                        f64::NAN
                    } else {
                        a.max(r)
                    }
                });
            (worst > tol || worst.is_nan()).then_some((k, worst))
        })
        .collect()
}

/// One relation's residual components at `p` with their gradients (none for a relation on a
/// constraint the model lacks).
pub fn relation_rows(model: &dyn CalibModel, rel: &Relation, p: &[f64]) -> Vec<RelationRow> {
    let dim = model.dim();
    let mut out = Vec::new();
    let [i, j] = rel.between;
    if i >= model.constraint_count() || j >= model.constraint_count() {
        return out;
    }
    let (vi, vj) = (values(model, i, p), values(model, j, p));
    let (ni, nj) = (vi.len(), vj.len());
    if ni + nj > MAX_INPUTS {
        return out;
    }
    let di: Vec<Dual> = vi
        .iter()
        .enumerate()
        .map(|(k, &x)| Dual::input(x, k))
        .collect();
    let dj: Vec<Dual> = vj
        .iter()
        .enumerate()
        .map(|(k, &x)| Dual::input(x, ni + k))
        .collect();
    let m = rel.kind.residual_count(dim);
    let mut r = vec![<Dual as crate::model::geometry::Real>::constant(0.0); m];
    relation_residual_in(rel, dim, &di, &dj, &mut r);
    for comp in r {
        let mut gradient: Vec<(usize, f64)> = Vec::new();
        for (c, n, off) in [(i, ni, 0), (j, nj, ni)] {
            for v in 0..n {
                let g = comp.d[off + v];
                if g == 0.0 {
                    continue;
                }
                if let Some(param) = model.constraint_value_param(c, v) {
                    match gradient.iter_mut().find(|(q, _)| *q == param) {
                        Some(e) => e.1 += g,
                        None => gradient.push((param, g)),
                    }
                }
            }
        }
        out.push(RelationRow {
            residual: comp.v,
            gradient,
        });
    }
    out
}

/// `Σ_r (w·R_r(p))²`: what the relation rows of weight `w` add to a fit's cost (nothing when
/// `w` is 0, a fit without relations).
#[must_use]
pub fn cost(model: &dyn CalibModel, p: &[f64], w: f64) -> f64 {
    if w == 0.0 {
        return 0.0;
    }
    let w2 = w * w;
    residuals(model, p).iter().map(|r| w2 * r * r).sum()
}

/// The relations' weight for a problem whose Jacobian has squared column norms `diag`
/// (`JᵀJ`'s diagonal over the free parameters): `RELATION_STIFFNESS · sqrt(mean diag)`.
#[must_use]
pub fn weight(diag: &[f64]) -> f64 {
    let n = diag.len().max(1) as f64;
    let s2 = diag.iter().filter(|x| x.is_finite()).sum::<f64>() / n;
    RELATION_STIFFNESS * s2.max(f64::MIN_POSITIVE).sqrt()
}

/// `p` moved the least (in the Euclidean norm over the parameters the relations involve)
/// onto the relations' zero set, by Gauss-Newton with minimum-norm steps; `None` when 50
/// steps do not bring every residual below `1e-13` m.
#[must_use]
pub fn project(model: &dyn CalibModel, p: &[f64]) -> Option<Vec<f64>> {
    let mut x = p.to_vec();
    for _ in 0..50 {
        let rows = rows(model, &x);
        let worst = rows.iter().fold(0.0f64, |a, r| a.max(r.residual.abs()));
        if !worst.is_finite() {
            return None;
        }
        if worst <= 1e-13 {
            return Some(x);
        }
        let np = x.len();
        let j = nalgebra::DMatrix::from_fn(rows.len(), np, |r, c| {
            rows[r]
                .gradient
                .iter()
                .find(|(q, _)| *q == c)
                .map_or(0.0, |e| e.1)
        });
        let r = nalgebra::DVector::from_iterator(rows.len(), rows.iter().map(|r| -r.residual));
        let step = j.svd(true, true).solve(&r, 1e-12).ok()?;
        for (xi, d) in x.iter_mut().zip(step.iter()) {
            *xi += d;
        }
    }
    None
}

/// What each relation measures at `p` (a distance in metres for `distance` and `offset`, the
/// angle between the normals in radians for `same_normal`), from the constraints' values
/// `values(j)`.
#[must_use]
pub fn achieved(relation: &Relation, dim: usize, vi: &[f64], vj: &[f64]) -> f64 {
    use crate::model::geometry::RelationKind;
    match relation.kind {
        RelationKind::Distance => (0..dim)
            .map(|k| (vi[k] - vj[k]).powi(2))
            .sum::<f64>()
            .sqrt(),
        RelationKind::SameNormal | RelationKind::Offset => {
            let m = if dim == 3 { 3 } else { 2 };
            let (a, b) = (&vi[..m], &vj[..m]);
            let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
            let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
            let cos = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / (na * nb);
            if relation.kind == RelationKind::SameNormal {
                // The angle between the lines of the normals (sign-free), in [0, π/2].
                cos.abs().min(1.0).acos()
            } else {
                use crate::model::geometry::plane_offset;
                (plane_offset(vi, m, na) - cos * plane_offset(vj, m, nb)).abs()
            }
        }
    }
}
