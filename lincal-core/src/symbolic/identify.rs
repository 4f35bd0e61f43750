//! Identifiability: which parameter combinations the constraint data can determine.
//!
//! The data of constraint group `j` (its `m_j` equations) determine the row space
//! `span{c_e(p) : e ∈ j}`, i.e. `c` up to an invertible mixing `C_j ↦ G C_j` (for one
//! equation, up to scale). A measured tip is seen directly, so nothing is taken modulo there.
//! The number of independent identifiable combinations is therefore
//!
//! `rank [∂C/∂p | {E_ab C_j}] − rank [{E_ab C_j}]`,
//!
//! the rank of the Jacobian modulo the tangent of the mixing group, computed exactly at a
//! generic point modulo a prime. Parameter `p_i` is identifiable on its own when removing its
//! column lowers that rank. The gauge rule holds parameters at their nominal values: walking
//! `params` in spec order, a parameter that is not identifiable on its own is held whenever the
//! remaining free parameters still determine every identifiable combination. The gauge
//! directions (the parameter changes the constraint cannot see) are reported at the nominal
//! point, in a reduced form whose leading coefficient is 1.

use super::eval::{eval_mod, param_values, CompiledPoly};
use super::modp::{self, Echelon};
use super::monomial::VarTable;
use super::poly::Poly;
use nalgebra::DMatrix;

/// Result of the identifiability analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct Identifiability {
    /// Number of independent identifiable combinations.
    pub count: usize,
    /// Per estimated parameter: identifiable on its own.
    pub identifiable: Vec<bool>,
    /// Per estimated parameter: held at nominal by the gauge rule.
    pub held: Vec<bool>,
    /// Gauge directions at the nominal point: `(parameter index, coefficient)`.
    pub gauge: Vec<Vec<(usize, f64)>>,
}

/// Columns (vectors over the flattened `E·K` entries) of the mixing group's tangent.
fn mixing_columns<T: Copy + Default>(
    c: &[Vec<T>],
    groups: &[Vec<usize>],
    k: usize,
) -> Vec<Vec<T>> {
    let mut cols = Vec::new();
    for g in groups {
        for &a in g {
            for &b in g {
                let mut col = vec![T::default(); c.len() * k];
                col[a * k..(a + 1) * k].copy_from_slice(&c[b]);
                cols.push(col);
            }
        }
    }
    cols
}

fn rank_of(cols: &[&Vec<u64>]) -> usize {
    let mut e = Echelon::default();
    for c in cols {
        e.insert((*c).clone());
    }
    e.rank()
}

/// Analyses identifiability.
///
/// `c[e][k]` are the generalized parameters, `jac[e][k][j]` their derivatives,
/// `mixing_groups` the equation indices of each constraint whose `c` is only known up to
/// mixing (every group except measured ones), `nominal` the nominal estimated parameters.
#[must_use]
pub fn analyse(
    vars: &VarTable,
    c: &[Vec<Poly>],
    jac: &[Vec<Vec<Poly>>],
    mixing_groups: &[Vec<usize>],
    nominal: &[f64],
) -> Identifiability {
    let np = nominal.len();
    let k = c.first().map_or(0, Vec::len);
    let point = super::eval::generic_point_mod(vars, 0x5eed_1d3a);
    let c_mod: Vec<Vec<u64>> = c
        .iter()
        .map(|row| row.iter().map(|p| eval_mod(p, &point)).collect())
        .collect();
    let jcols: Vec<Vec<u64>> = (0..np)
        .map(|j| {
            let mut col = Vec::with_capacity(c.len() * k);
            for row in jac {
                for d in row {
                    col.push(eval_mod(&d[j], &point));
                }
            }
            col
        })
        .collect();
    let gcols = mixing_columns(&c_mod, mixing_groups, k);
    let r_g = rank_of(&gcols.iter().collect::<Vec<_>>());
    let rank_without = |skip: &[bool]| -> usize {
        let cols: Vec<&Vec<u64>> = jcols
            .iter()
            .enumerate()
            .filter(|(j, _)| !skip[*j])
            .map(|(_, c)| c)
            .chain(gcols.iter())
            .collect();
        rank_of(&cols)
    };
    let none = vec![false; np];
    let r_all = rank_without(&none);
    let count = r_all - r_g;
    let identifiable: Vec<bool> = (0..np)
        .map(|j| {
            let mut skip = none.clone();
            skip[j] = true;
            rank_without(&skip) < r_all
        })
        .collect();
    let mut held = none.clone();
    let mut n_held = 0;
    for j in 0..np {
        if n_held == np - count {
            break;
        }
        if identifiable[j] {
            continue;
        }
        held[j] = true;
        if rank_without(&held) == r_all {
            n_held += 1;
        } else {
            held[j] = false;
        }
    }
    let gauge = gauge_at(vars, c, jac, mixing_groups, nominal, r_all, np - count);
    let _ = modp::P;
    Identifiability {
        count,
        identifiable,
        held,
        gauge,
    }
}

/// Gauge directions at `nominal` in `f64`: the `dim` parameter-space directions of the null
/// space of `[∂C/∂p | mixing]`, in reduced form.
fn gauge_at(
    vars: &VarTable,
    c: &[Vec<Poly>],
    jac: &[Vec<Vec<Poly>>],
    mixing_groups: &[Vec<usize>],
    nominal: &[f64],
    r_all: usize,
    dim: usize,
) -> Vec<Vec<(usize, f64)>> {
    let np = nominal.len();
    if dim == 0 {
        return Vec::new();
    }
    let vals = param_values(vars, nominal);
    let k = c.first().map_or(0, Vec::len);
    let c_f: Vec<Vec<f64>> = c
        .iter()
        .map(|row| row.iter().map(|p| CompiledPoly::new(p).eval(&vals)).collect())
        .collect();
    let mut cols: Vec<Vec<f64>> = (0..np)
        .map(|j| {
            jac.iter()
                .flat_map(|row| row.iter().map(|d| CompiledPoly::new(&d[j]).eval(&vals)))
                .collect()
        })
        .collect();
    cols.extend(mixing_columns(&c_f, mixing_groups, k));
    let ncols = cols.len();
    let nrows = (c.len() * k).max(ncols);
    // Scale columns to unit norm so the SVD sees directions, not units.
    let scales: Vec<f64> = cols
        .iter()
        .map(|col| {
            let n = col.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n > 0.0 {
                1.0 / n
            } else {
                1.0
            }
        })
        .collect();
    let a = DMatrix::from_fn(nrows, ncols, |i, j| {
        cols[j].get(i).copied().unwrap_or(0.0) * scales[j]
    });
    let svd = a.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Vec::new();
    };
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&x, &y| svd.singular_values[x].total_cmp(&svd.singular_values[y]));
    let null_dim = ncols.saturating_sub(r_all);
    // Parameter parts of the null vectors, unscaled.
    let null_p: Vec<Vec<f64>> = order
        .iter()
        .take(null_dim)
        .map(|&i| (0..np).map(|j| vt[(i, j)] * scales[j]).collect())
        .collect();
    if null_p.is_empty() {
        return Vec::new();
    }
    let n = DMatrix::from_fn(np, null_p.len().max(np), |i, j| {
        null_p.get(j).map_or(0.0, |v| v[i])
    });
    let svd2 = n.svd(true, false);
    let Some(u) = svd2.u else {
        return Vec::new();
    };
    let mut order2: Vec<usize> = (0..svd2.singular_values.len()).collect();
    order2.sort_by(|&x, &y| svd2.singular_values[y].total_cmp(&svd2.singular_values[x]));
    let mut rows: Vec<Vec<f64>> = order2
        .iter()
        .take(dim)
        .map(|&i| (0..np).map(|j| u[(j, i)]).collect())
        .collect();
    readable(&mut rows);
    rows.iter()
        .map(|r| {
            let mx = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            r.iter()
                .enumerate()
                .filter(|(_, x)| x.abs() > 1e-9 * mx)
                .map(|(j, x)| (j, *x))
                .collect()
        })
        .collect()
}

/// Reduced echelon form with partial pivoting, pivots in parameter order, leading
/// coefficient 1.
fn readable(rows: &mut [Vec<f64>]) {
    let ncols = rows.first().map_or(0, Vec::len);
    let mut r = 0;
    for col in 0..ncols {
        if r == rows.len() {
            break;
        }
        let (best, val) = (r..rows.len())
            .map(|i| (i, rows[i][col].abs()))
            .fold((r, 0.0), |acc, x| if x.1 > acc.1 { x } else { acc });
        if val < 1e-9 {
            continue;
        }
        rows.swap(r, best);
        let piv = rows[r][col];
        for x in &mut rows[r] {
            *x /= piv;
        }
        let pr = rows[r].clone();
        for (i, row) in rows.iter_mut().enumerate() {
            if i != r {
                let f = row[col];
                if f != 0.0 {
                    for (x, y) in row.iter_mut().zip(&pr) {
                        *x -= f * y;
                    }
                }
            }
        }
        r += 1;
    }
}
