//! Relations between constraints in the identifiability analysis.
//!
//! A relation `R(v_i, v_j) = 0` on two constraints' values restricts the parameters to a
//! manifold; the directions the data cannot see are then those tangent to it,
//! `ker ∂R/∂p ∩ (gauge without the relation)`. So the analysis appends the gradient rows of
//! `R` (zero in the mixing columns) to `[∂C/∂p | mixing]` and counts as before:
//! `rank [∂C/∂p, mixing; ∂R/∂p, 0] − rank [mixing]` combinations are identifiable.
//!
//! The rows are those of polynomial forms of the relations, so they can be taken modulo the
//! prime: a distance `Σ (c_i − c_j)²`; parallel normals the cross product `b_i × b_j`; an
//! offset, additionally, `F = (s − t)² − D t² s` with `s = b_i·b_i`, `t = b_i·b_j`,
//! `D = d²` (parallel planes `b_i·x + 1 = 0`, `b_j = λ b_i` are `|1/λ − 1|/‖b_i‖` apart,
//! which squared and cleared of denominators is `F = 0`); when a plane is written by normal
//! (`a·x = e`, the paper's plane being `a = b, e = −1`), `F = (e_i r − t e_j)² − D s r²` with
//! `r = a_j·a_j` (`offset_row_by_normal`). A cross product has rank 2 on its
//! zero set but 3 elsewhere, so the generic point is first moved onto the parallel planes:
//! `b_j = λ b_i` with a random `λ`, and `D` is taken where `F` vanishes there.

use super::eval::generic_point_mod;
use super::expand::ParamVars;
use super::modp::{self, Mp, Scalar};
use super::monomial::VarTable;
use crate::model::geometry::{Relation, RelationKind};
use crate::spec::kinematics::SlotRef;
use crate::spec::Spec;
use num_rational::BigRational;

/// A constraint value as the analysis sees it.
#[derive(Clone, Debug, PartialEq)]
pub enum SlotVar {
    /// A fixed value (a number or a known parameter's nominal).
    Const(f64),
    /// Estimated parameter `param`, polynomial variable `var`.
    Param {
        /// Index into the estimated parameters.
        param: usize,
        /// Index into the variable table.
        var: usize,
    },
}

/// One relation with the values of its two constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct RelationSlots {
    /// The relation.
    pub relation: Relation,
    /// The spec's `dim`.
    pub dim: usize,
    /// The values of constraints `between[0]` and `between[1]`, canonical order.
    pub slots: [Vec<SlotVar>; 2],
}

fn dot<F: Scalar>(a: &[F], b: &[F]) -> F {
    a.iter()
        .zip(b)
        .fold(F::int(0), |acc, (&x, &y)| acc.add(x.mul(y)))
}

/// The gradient rows of the relation's polynomial form with respect to the values
/// `(v_i, v_j)` (each row: `∂/∂v_i` then `∂/∂v_j`, entries past the related values zero);
/// `d2` is `D` of an offset.
fn value_rows<F: Scalar>(
    kind: RelationKind,
    dim: usize,
    vi: &[F],
    vj: &[F],
    d2: F,
) -> Vec<[Vec<F>; 2]> {
    let zero = F::int(0);
    let two = F::int(2);
    let (ni, nj) = (vi.len(), vj.len());
    let mut rows = Vec::new();
    match kind {
        RelationKind::Distance => {
            let mut a = vec![zero; ni];
            let mut b = vec![zero; nj];
            for k in 0..dim {
                let g = two.mul(vi[k].sub(vj[k]));
                a[k] = g;
                b[k] = zero.sub(g);
            }
            rows.push([a, b]);
        }
        RelationKind::SameNormal | RelationKind::Offset => {
            let m = if dim == 3 { 3 } else { 2 };
            let cyc: &[(usize, usize)] = if m == 3 {
                &[(1, 2), (2, 0), (0, 1)]
            } else {
                &[(0, 1)]
            };
            // (a × b)_r = a_s b_t − a_t b_s
            for &(s, t) in cyc {
                let mut a = vec![zero; ni];
                let mut b = vec![zero; nj];
                a[s] = vj[t];
                a[t] = zero.sub(vj[s]);
                b[t] = vi[s];
                b[s] = zero.sub(vi[t]);
                rows.push([a, b]);
            }
            if kind == RelationKind::Offset && (ni > m || nj > m) {
                rows.push(offset_row_by_normal(vi, vj, m, d2));
            } else if kind == RelationKind::Offset {
                let (ai, bj) = (&vi[..m], &vj[..m]);
                let s = dot(ai, ai);
                let t = dot(ai, bj);
                let u = s.sub(t);
                let mut a = vec![zero; ni];
                let mut b = vec![zero; nj];
                for k in 0..m {
                    // ∂F/∂a = 2u(2a − b) − D(2ts·b + 2t²·a), ∂F/∂b = −2u·a − 2Dts·a
                    let da = two.mul(u).mul(two.mul(ai[k]).sub(bj[k])).sub(
                        d2.mul(
                            two.mul(t)
                                .mul(s)
                                .mul(bj[k])
                                .add(two.mul(t).mul(t).mul(ai[k])),
                        ),
                    );
                    let db = zero
                        .sub(two.mul(u).mul(ai[k]))
                        .sub(two.mul(d2).mul(t).mul(s).mul(ai[k]));
                    a[k] = da;
                    b[k] = db;
                }
                rows.push([a, b]);
            }
        }
    }
    rows
}

/// A plane's `e` in `a·x = e`: the offset after the normal's `m` entries for a plane by
/// normal, `−1` for `b·x + 1 = 0` (see [`RelationKind::Offset`]).
fn plane_e<F: Scalar>(v: &[F], m: usize) -> F {
    v.get(m).copied().unwrap_or(F::int(-1))
}

/// The offset row when either plane is written by normal and offset: the gradient of
/// `F = (e_i r − t e_j)² − D s r²`, `s = a_i·a_i`, `t = a_i·a_j`, `r = a_j·a_j` (planes
/// `a·x = e`; for `a_j = λ a_i` their distance is `|e_i r − t e_j| / (√s r)`, squared and
/// cleared of denominators). With `g = e_i r − t e_j`: `∂F/∂a_i = −2g e_j a_j − 2D r² a_i`,
/// `∂F/∂a_j = 2g (2e_i a_j − e_j a_i) − 4D s r a_j`, `∂F/∂e_i = 2g r`, `∂F/∂e_j = −2g t`.
fn offset_row_by_normal<F: Scalar>(vi: &[F], vj: &[F], m: usize, d2: F) -> [Vec<F>; 2] {
    let (zero, two, four) = (F::int(0), F::int(2), F::int(4));
    let (ei, ej) = (plane_e(vi, m), plane_e(vj, m));
    let (ai, aj) = (&vi[..m], &vj[..m]);
    let (s, t, r) = (dot(ai, ai), dot(ai, aj), dot(aj, aj));
    let g = ei.mul(r).sub(t.mul(ej));
    let mut a = vec![zero; vi.len()];
    let mut b = vec![zero; vj.len()];
    for k in 0..m {
        a[k] = zero
            .sub(two.mul(g).mul(ej).mul(aj[k]))
            .sub(two.mul(d2).mul(r).mul(r).mul(ai[k]));
        b[k] = two
            .mul(g)
            .mul(two.mul(ei).mul(aj[k]).sub(ej.mul(ai[k])))
            .sub(four.mul(d2).mul(s).mul(r).mul(aj[k]));
    }
    if vi.len() > m {
        a[m] = two.mul(g).mul(r);
    }
    if vj.len() > m {
        b[m] = zero.sub(two.mul(g).mul(t));
    }
    [a, b]
}

/// Rows over the `np` estimated parameters from rows over the values.
fn param_rows<F: Scalar>(rel: &RelationSlots, rows: Vec<[Vec<F>; 2]>, np: usize) -> Vec<Vec<F>> {
    rows.into_iter()
        .map(|sides| {
            let mut out = vec![F::int(0); np];
            for (side, grads) in sides.iter().enumerate() {
                for (slot, g) in rel.slots[side].iter().zip(grads) {
                    if let SlotVar::Param { param, .. } = slot {
                        out[*param] = out[*param].add(*g);
                    }
                }
            }
            out
        })
        .collect()
}

fn const_mod(x: f64) -> u64 {
    BigRational::from_float(x)
        .and_then(|r| modp::from_rational(&r))
        .unwrap_or(0)
}

fn value_mod(slot: &SlotVar, point: &[u64]) -> u64 {
    match slot {
        SlotVar::Const(x) => const_mod(*x),
        SlotVar::Param { var, .. } => point[*var],
    }
}

/// The generic point of the analysis (see [`generic_point_mod`]) moved onto the relations'
/// zero set where that needs it: for parallel normals, `b_j = λ b_i` with a random `λ` (or the
/// `λ` two fixed values imply), each value set from its partner. Values that no parameter can
/// move (both fixed) are left as they are.
pub(crate) fn relation_point(vars: &VarTable, seed: u64, relations: &[RelationSlots]) -> Vec<u64> {
    let mut point = generic_point_mod(vars, seed);
    let mut rng = modp::Rng::new(seed ^ 0x7e1a_7105);
    let mut placed: Vec<usize> = Vec::new();
    for rel in relations {
        if rel.relation.kind == RelationKind::Distance {
            continue;
        }
        let m = if rel.dim == 3 { 3 } else { 2 };
        let [si, sj] = &rel.slots;
        // λ from two fixed values if any pair has them, else random.
        let mut lambda = rng.element().max(1);
        for k in 0..m {
            if let (SlotVar::Const(x), SlotVar::Const(y)) = (&si[k], &sj[k]) {
                if *x != 0.0 {
                    lambda = modp::mul(const_mod(*y), modp::inv(const_mod(*x)));
                    break;
                }
            }
        }
        for k in 0..m {
            let (a, b) = (&si[k], &sj[k]);
            match (a, b) {
                (SlotVar::Const(x), SlotVar::Param { var, .. }) => {
                    point[*var] = modp::mul(lambda, const_mod(*x));
                    placed.push(*var);
                }
                (SlotVar::Param { var, .. }, SlotVar::Const(y)) => {
                    point[*var] = modp::mul(const_mod(*y), modp::inv(lambda));
                    placed.push(*var);
                }
                (SlotVar::Param { var: va, .. }, SlotVar::Param { var: vb, .. }) => {
                    if placed.contains(vb) {
                        point[*va] = modp::mul(point[*vb], modp::inv(lambda));
                        placed.push(*va);
                    } else {
                        point[*vb] = modp::mul(lambda, point[*va]);
                        placed.push(*vb);
                    }
                }
                _ => {}
            }
        }
    }
    point
}

/// The relations' gradient rows over the estimated parameters, modulo the prime, at `point`
/// (from [`relation_point`]).
pub(crate) fn rows_mod(relations: &[RelationSlots], point: &[u64], np: usize) -> Vec<Vec<u64>> {
    let mut out = Vec::new();
    for rel in relations {
        let vi: Vec<Mp> = rel.slots[0]
            .iter()
            .map(|s| Mp(value_mod(s, point)))
            .collect();
        let vj: Vec<Mp> = rel.slots[1]
            .iter()
            .map(|s| Mp(value_mod(s, point)))
            .collect();
        // D where F vanishes at this point: (s − t)² / (t² s), or g² / (s r²) when a plane is
        // written by normal ([`offset_row_by_normal`]).
        let m = if rel.dim == 3 { 3 } else { 2 };
        let by_normal = vi.len() > m || vj.len() > m;
        let d2 = if rel.relation.kind == RelationKind::Offset && by_normal {
            let (ei, ej) = (plane_e(&vi, m), plane_e(&vj, m));
            let s = dot(&vi[..m], &vi[..m]);
            let t = dot(&vi[..m], &vj[..m]);
            let r = dot(&vj[..m], &vj[..m]);
            let g = ei.mul(r).sub(t.mul(ej));
            let den = s.mul(r).mul(r).0;
            if den == 0 {
                Mp(0)
            } else {
                Mp(modp::mul(g.mul(g).0, modp::inv(den)))
            }
        } else if rel.relation.kind == RelationKind::Offset && vi.len() >= m && vj.len() >= m {
            let s = dot(&vi[..m], &vi[..m]);
            let t = dot(&vi[..m], &vj[..m]);
            let u = s.sub(t);
            let den = t.mul(t).mul(s).0;
            if den == 0 {
                Mp(0)
            } else {
                Mp(modp::mul(u.mul(u).0, modp::inv(den)))
            }
        } else {
            Mp(0)
        };
        let rows = value_rows(rel.relation.kind, rel.dim, &vi, &vj, d2);
        out.extend(
            param_rows(rel, rows, np)
                .into_iter()
                .map(|r| r.into_iter().map(|x| x.0).collect::<Vec<u64>>()),
        );
    }
    out
}

/// The relations' gradient rows over the estimated parameters in `f64` at parameters `p`
/// (`D = d²` from the spec for an offset).
pub(crate) fn rows_f64(relations: &[RelationSlots], p: &[f64]) -> Vec<Vec<f64>> {
    let np = p.len();
    let value = |s: &SlotVar| match s {
        SlotVar::Const(x) => *x,
        SlotVar::Param { param, .. } => p[*param],
    };
    let mut out = Vec::new();
    for rel in relations {
        let vi: Vec<f64> = rel.slots[0].iter().map(value).collect();
        let vj: Vec<f64> = rel.slots[1].iter().map(value).collect();
        let d2 = rel.relation.value * rel.relation.value;
        let rows = value_rows(rel.relation.kind, rel.dim, &vi, &vj, d2);
        out.extend(param_rows(rel, rows, np));
    }
    out
}

/// The spec's relations with their constraints' values as the analysis sees them: estimated
/// parameters by their variable, everything else by its value.
pub(super) fn relation_slots(spec: &Spec, param_vars: &[ParamVars]) -> Vec<RelationSlots> {
    let slot = |s: &crate::spec::Slot| -> SlotVar {
        match SlotRef::resolve(spec, s) {
            SlotRef::Const(x) => SlotVar::Const(x),
            SlotRef::Param(j) => match param_vars.get(j) {
                Some(ParamVars::Length(var)) => SlotVar::Param {
                    param: j,
                    var: *var,
                },
                // Constraint values are lengths; an angle here cannot happen after validation.
                _ => SlotVar::Const(spec.estimated_params()[j].nominal.to_f64()),
            },
        }
    };
    spec.relations
        .iter()
        .filter_map(|r| {
            let [i, j] = r.between;
            let si = spec
                .constraints
                .get(i)?
                .slots()
                .into_iter()
                .map(slot)
                .collect();
            let sj = spec
                .constraints
                .get(j)?
                .slots()
                .into_iter()
                .map(slot)
                .collect();
            Some(RelationSlots {
                relation: *r,
                dim: spec.dim,
                slots: [si, sj],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(v_i, v_j)` with entry `k` of side `side` moved by `+h`, then by `−h`.
    fn nudged(vi: &[f64], vj: &[f64], side: usize, k: usize, h: f64) -> [(Vec<f64>, Vec<f64>); 2] {
        [h, -h].map(|d| {
            let (mut a, mut b) = (vi.to_vec(), vj.to_vec());
            if side == 0 {
                a[k] += d;
            } else {
                b[k] += d;
            }
            (a, b)
        })
    }

    /// The offset row with a plane by normal (`a·x = e`, its `e` after the normal) on either
    /// side or both is the gradient of `F = (e_i r − t e_j)² − D s r²`: central differences.
    #[test]
    fn offset_rows_by_normal_are_gradients() {
        let d2 = 0.37;
        let e = |v: &[f64]| if v.len() > 3 { v[3] } else { -1.0 };
        let f = |a: &[f64], b: &[f64]| -> f64 {
            let (s, t, r) = (
                dot(&a[..3], &a[..3]),
                dot(&a[..3], &b[..3]),
                dot(&b[..3], &b[..3]),
            );
            (e(a) * r - t * e(b)).powi(2) - d2 * s * r * r
        };
        // F vanishes for parallel planes `a·x = 0.45` and `−2a·x = 0.3`, `|0.45 + 0.15|/‖a‖`
        // apart, at `D` = that distance squared.
        let a = [0.3, -0.7, 1.1];
        let gap = (0.45f64 + 0.15) / dot(&a, &a).sqrt();
        let (s2, t, r) = (dot(&a, &a), -2.0 * dot(&a, &a), 4.0 * dot(&a, &a));
        let g = 0.45 * r - t * 0.3;
        assert!((g * g - gap * gap * s2 * r * r).abs() < 1e-12 * (g * g));
        let normal = vec![0.3, -0.7, 1.1, 0.45];
        let b_form = vec![-0.2, 0.5, 0.4];
        let other = vec![0.6, 0.2, -0.3, -0.8];
        for (vi, vj) in [(&normal, &b_form), (&b_form, &normal), (&normal, &other)] {
            let rows = value_rows(RelationKind::Offset, 3, vi, vj, d2);
            let row = rows.last().expect("the offset row");
            let h = 1e-6;
            for (side, grads) in row.iter().enumerate() {
                for (k, &g) in grads.iter().enumerate() {
                    let [(ap, bp), (am, bm)] = nudged(vi, vj, side, k, h);
                    let fd = (f(&ap, &bp) - f(&am, &bm)) / (2.0 * h);
                    assert!((g - fd).abs() < 1e-6, "side {side} k {k}: {g} vs {fd}");
                }
            }
        }
    }

    /// The rows are the gradients of the polynomial forms: compare with central differences.
    #[test]
    fn rows_are_gradients_of_the_polynomial_forms() {
        let vi = [0.3, -0.7, 1.1];
        let vj = [-0.2, 0.5, 0.4];
        let d2 = 0.37;
        let forms = |kind: RelationKind, a: &[f64], b: &[f64]| -> Vec<f64> {
            let s = dot(a, a);
            let t = dot(a, b);
            let mut f = match kind {
                RelationKind::Distance => vec![(0..3).map(|k| (a[k] - b[k]).powi(2)).sum()],
                _ => vec![
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ],
            };
            if kind == RelationKind::Offset {
                f.push((s - t).powi(2) - d2 * t * t * s);
            }
            f
        };
        for kind in [
            RelationKind::Distance,
            RelationKind::SameNormal,
            RelationKind::Offset,
        ] {
            let rows = value_rows(kind, 3, &vi, &vj, d2);
            let h = 1e-6;
            for side in 0..2 {
                for k in 0..3 {
                    let [(ap, bp), (am, bm)] = nudged(&vi, &vj, side, k, h);
                    let fp = forms(kind, &ap, &bp);
                    let fm = forms(kind, &am, &bm);
                    for (r, row) in rows.iter().enumerate() {
                        let fd = (fp[r] - fm[r]) / (2.0 * h);
                        assert!(
                            (row[side][k] - fd).abs() < 1e-6,
                            "{kind:?} row {r} side {side} k {k}"
                        );
                    }
                }
            }
        }
    }
}
