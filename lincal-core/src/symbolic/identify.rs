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

use super::eval::{param_roles, param_values, pow_small, CompiledPoly};
use super::modp::{self, Echelon};
use super::monomial::VarTable;
use super::poly::Poly;
use super::relations::{relation_point, rows_f64, rows_mod, RelationSlots};
use nalgebra::DMatrix;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    /// Per estimated parameter: `∂c/∂p_j` vanishes identically, so the parameter cannot
    /// affect the constraint at all (often a typo, or a link of zero length before it).
    pub no_effect: Vec<bool>,
    /// Per relation of the spec: the gauge directions (of the analysis without relations) it
    /// removes, in the same form as `gauge`.
    pub relation_removes: Vec<Vec<Vec<(usize, f64)>>>,
}

/// Columns (vectors over the flattened `E·K` entries) of the mixing group's tangent.
fn mixing_columns<T: Copy + Default>(c: &[Vec<T>], groups: &[Vec<usize>], k: usize) -> Vec<Vec<T>> {
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

/// A reduced column: its pivot, its sparse entries, and the combination of the original
/// columns it is.
type EchelonColumn = (usize, Vec<(usize, u64)>, Vec<u64>);

/// The column space of `[∂C/∂p | mixing]` modulo the prime, with a basis of its kernel:
/// every rank the analysis asks for follows from the kernel, so one elimination serves all.
///
/// Removing a set `S` of columns keeps the rank exactly when the kernel's coordinates on `S`
/// have full rank `|S|` (`rank A − rank A_¬S = |S| − dim π_S(ker A)`); in particular column
/// `j` alone is essential when every kernel vector vanishes at `j`.
struct Kernel {
    /// Rank of all columns.
    rank: usize,
    /// Rank of the mixing columns alone.
    rank_mixing: usize,
    /// Kernel vectors, over the columns (parameters first, then mixing columns).
    vectors: Vec<Vec<u64>>,
}

impl Kernel {
    /// Eliminates the mixing columns first (their rank on the way), then the parameter
    /// columns, tracking each reduced column as a combination of the original ones: a column
    /// that reduces to zero yields a kernel vector.
    fn new(jcols: &[Vec<u64>], gcols: &[Vec<u64>]) -> Self {
        let np = jcols.len();
        let n = np + gcols.len();
        // Echelon rows: (pivot, sparse reduced column, combination).
        let mut rows: Vec<EchelonColumn> = Vec::new();
        let mut vectors = Vec::new();
        let mut rank_mixing = 0;
        let order = (np..n).chain(0..np);
        for (step, idx) in order.enumerate() {
            if step == gcols.len() {
                rank_mixing = rows.len();
            }
            let mut v = if idx < np {
                jcols[idx].clone()
            } else {
                gcols[idx - np].clone()
            };
            let mut comb = vec![0u64; n];
            comb[idx] = 1;
            // Each row is zero at the pivots of the rows before it, so one pass in insertion
            // order reduces `v` fully at every pivot.
            for (piv, rv, rc) in &rows {
                let f = v[*piv];
                if f != 0 {
                    for &(i, x) in rv {
                        v[i] = modp::sub(v[i], modp::mul(f, x));
                    }
                    for (c, &x) in comb.iter_mut().zip(rc) {
                        if x != 0 {
                            *c = modp::sub(*c, modp::mul(f, x));
                        }
                    }
                }
            }
            match v.iter().position(|&x| x != 0) {
                None => vectors.push(comb),
                Some(piv) => {
                    let i = modp::inv(v[piv]);
                    let sparse = v
                        .iter()
                        .enumerate()
                        .filter(|(_, &x)| x != 0)
                        .map(|(c, &x)| (c, modp::mul(x, i)))
                        .collect();
                    for x in &mut comb {
                        *x = modp::mul(*x, i);
                    }
                    rows.push((piv, sparse, comb));
                }
            }
        }
        if np == 0 {
            rank_mixing = rows.len();
        }
        Kernel {
            rank: rows.len(),
            rank_mixing,
            vectors,
        }
    }

    /// Whether the columns outside `skip` still have the full rank.
    fn keeps_rank(&self, skip: &[bool]) -> bool {
        let mut e = Echelon::default();
        let mut s = 0;
        for (j, _) in skip.iter().enumerate().filter(|(_, &x)| x) {
            s += 1;
            e.insert(self.vectors.iter().map(|v| v[j]).collect());
        }
        e.rank() == s
    }

    /// Whether column `j` is essential: removing it lowers the rank.
    fn essential(&self, j: usize) -> bool {
        self.vectors.iter().all(|v| v[j] == 0)
    }
}

/// `c_{e,k}` and `∂c_{e,k}/∂p_j` modulo the prime at `point` (the values, and one column per
/// parameter, over the flattened `(e, k)`), in one pass over the terms, computed from `c`
/// itself: on the unit circle the canonical (reduced) form of a derivative has the value of
/// the unreduced one, so no derivative polynomial is built.
fn values_and_jacobian_mod(
    vars: &VarTable,
    c: &[Vec<Poly>],
    point: &[u64],
    np: usize,
) -> (Vec<u64>, Vec<Vec<u64>>) {
    use super::monomial::Var;
    // What each variable contributes to: (parameter, weight of ∂/∂var in d/dp).
    let role: Vec<Option<(usize, u64)>> = vars
        .vars
        .iter()
        .enumerate()
        .map(|(i, v)| match v {
            Var::ParamLength(j) => Some((*j, 1)),
            // d/dθ f(cos θ, sin θ) = −sin θ ∂f/∂cos + cos θ ∂f/∂sin
            Var::ParamCos(j) => {
                let s = vars.trig_pairs.iter().find(|p| p.0 == i).map(|p| p.1)?;
                Some((*j, modp::neg(point[s])))
            }
            Var::ParamSin(j) => {
                let cv = vars.trig_pairs.iter().find(|p| p.1 == i).map(|p| p.0)?;
                Some((*j, point[cv]))
            }
            _ => None,
        })
        .collect();
    let k = c.first().map_or(0, Vec::len);
    let mut cols = vec![vec![0u64; c.len() * k]; np];
    let mut values = vec![0u64; c.len() * k];
    let mut conv = modp::RationalMod::default();
    let mut f: Vec<(usize, u32, u64)> = Vec::new();
    let mut suffix: Vec<u64> = Vec::new();
    for (e, row) in c.iter().enumerate() {
        for (kk, poly) in row.iter().enumerate() {
            let at = e * k + kk;
            for (m, coef) in &poly.terms {
                let Some(x) = conv.get(coef) else {
                    continue;
                };
                f.clear();
                f.extend(m.factors().map(|(v, ex)| (v, ex, pow_small(point[v], ex))));
                // Products of the other factors by prefix and suffix products.
                suffix.clear();
                suffix.resize(f.len() + 1, 1);
                for i in (0..f.len()).rev() {
                    suffix[i] = modp::mul(suffix[i + 1], f[i].2);
                }
                let mut prefix = x;
                for (i, &(v, ex, pv)) in f.iter().enumerate() {
                    if let Some((j, w)) = role[v] {
                        // ∂(v^ex)/∂v = ex · v^(ex−1)
                        let d =
                            modp::mul(modp::from_i64(i64::from(ex)), pow_small(point[v], ex - 1));
                        let term = modp::mul(modp::mul(prefix, suffix[i + 1]), modp::mul(d, w));
                        cols[j][at] = modp::add(cols[j][at], term);
                    }
                    prefix = modp::mul(prefix, pv);
                }
                // The prefix is now the whole term.
                values[at] = modp::add(values[at], prefix);
            }
        }
    }
    (values, cols)
}

/// The seed of the generic point of the exact analysis.
const POINT_SEED: u64 = 0x5eed_1d3a;

/// Compiled polynomials handed out per claim by the threads that share the compilation.
const COMPILE_CHUNK: usize = 64;

/// Analyses identifiability, and compiles `c` for evaluation in `f64` on the way.
///
/// `c[e][k]` are the generalized parameters, `mixing_groups` the equation indices of each
/// constraint whose `c` is only known up to mixing (every group except measured ones),
/// `nominal` the nominal estimated parameters. Returns the analysis and `c` compiled
/// (flattened over `(e, k)`). Both cores work: the second compiles while the first forms the
/// exact columns, then helps it finish; the floating-point columns at the two points the
/// gauge rule needs are then taken one on each core.
#[must_use]
pub fn analyse(
    vars: &VarTable,
    c: &[Vec<Poly>],
    mixing_groups: &[Vec<usize>],
    nominal: &[f64],
    relations: &[RelationSlots],
) -> (Identifiability, Vec<CompiledPoly>) {
    let np = nominal.len();
    let k = c.first().map_or(0, Vec::len);
    let point = relation_point(vars, POINT_SEED, relations);
    let polys: Vec<&Poly> = c.iter().flatten().collect();
    let next = AtomicUsize::new(0);
    let compile_chunks = || {
        let mut out = Vec::new();
        loop {
            let at = next.fetch_add(COMPILE_CHUNK, Ordering::Relaxed);
            if at >= polys.len() {
                return out;
            }
            let end = (at + COMPILE_CHUNK).min(polys.len());
            out.push((
                at,
                polys[at..end]
                    .iter()
                    .map(|p| CompiledPoly::new(p))
                    .collect::<Vec<_>>(),
            ));
        }
    };
    let (exact, c_eval) = std::thread::scope(|s| {
        let other = s.spawn(compile_chunks);
        let exact = exact_columns(vars, c, mixing_groups, relations, &point, np, k);
        let mut chunks = compile_chunks();
        chunks.extend(
            other
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e)),
        );
        chunks.sort_unstable_by_key(|x| x.0);
        let c_eval: Vec<CompiledPoly> = chunks.into_iter().flat_map(|x| x.1).collect();
        (exact, c_eval)
    });
    let ident = analyse_compiled(vars, c, &c_eval, mixing_groups, nominal, relations, exact);
    (ident, c_eval)
}

/// [`analyse`] with `c` compiled (`c_eval`) and the exact columns formed (`exact`).
fn analyse_compiled(
    vars: &VarTable,
    c: &[Vec<Poly>],
    c_eval: &[CompiledPoly],
    mixing_groups: &[Vec<usize>],
    nominal: &[f64],
    relations: &[RelationSlots],
    exact: (Vec<Vec<u64>>, Kernel),
) -> Identifiability {
    let np = nominal.len();
    let k = c.first().map_or(0, Vec::len);
    let near = perturbed(vars, nominal);
    // The floating-point columns near and at the nominals (for the gauge rule): one point on
    // each core.
    let mut both = std::thread::scope(|s| {
        let at_near = s.spawn(|| numeric_columns(vars, c, c_eval, mixing_groups, np, &near));
        let at_nominal = numeric_columns(vars, c, c_eval, mixing_groups, np, nominal);
        let at_near = at_near
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        vec![at_near, at_nominal]
    });
    let (jcols, kernel) = exact;
    let r_all = kernel.rank;
    let count = r_all - kernel.rank_mixing;
    let identifiable: Vec<bool> = (0..np).map(|j| kernel.essential(j)).collect();
    // The gauge rule is applied where the fit starts, at the nominals. There the gauge
    // directions are those of the generic null space in the limit p → nominal (at a
    // degenerate nominal point extra null directions appear, e.g. a home offset of a joint
    // whose link has zero length). A parameter is held only if, together with those already
    // held, it pins the gauge directions well: the smallest principal cosine between the
    // gauge space and the held coordinates stays above 0.1. So a length whose nominal is 0
    // is never chosen to fix a scale. What that cannot fill is filled by the generic rank.
    let gauge_dim = np - count;
    for (cols, at) in both.iter_mut().zip([&near[..], nominal]) {
        let (jc, gc) = cols.split_at_mut(np);
        let mut jc = jc.to_vec();
        let mut gc = gc.to_vec();
        append_rows(&mut jc, &mut gc, &rows_f64(relations, at), 0.0);
        *cols = jc.into_iter().chain(gc).collect();
    }
    let cols_nominal = both.pop().unwrap_or_default();
    let cols_near = both.pop().unwrap_or_default();
    let n_near = null_parameter_space(&cols_near, np, r_all, gauge_dim, false);
    let mut held = vec![false; np];
    let mut n_held = 0;
    for pass in 0..2 {
        for j in 0..np {
            if n_held == gauge_dim {
                break;
            }
            if identifiable[j] || held[j] {
                continue;
            }
            held[j] = true;
            let pins = pass == 1 || pinning(&n_near, &held) > 0.1;
            if pins && kernel.keeps_rank(&held) {
                n_held += 1;
            } else {
                held[j] = false;
            }
        }
    }
    let nominal_generic = numeric_rank(&cols_nominal.iter().collect::<Vec<_>>()) == r_all;
    let gauge_cols = if nominal_generic {
        &cols_nominal
    } else {
        &cols_near
    };
    // Each parameter's effect per unit change: its Jacobian column's norm.
    let effect: Vec<f64> = gauge_cols
        .iter()
        .take(np)
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let gauge = readable_gauge(
        null_parameter_space(gauge_cols, np, r_all, gauge_dim, true),
        &held,
        &effect,
    );
    // A zero column at a generic point is a zero polynomial column: no effect anywhere.
    let no_effect = jcols.iter().map(|c| c.iter().all(|&x| x == 0)).collect();
    let relation_removes = if relations.is_empty() {
        Vec::new()
    } else {
        // Where the gauge directions were taken (see above).
        let at: &[f64] = if nominal_generic { nominal } else { &near };
        let point = relation_point(vars, POINT_SEED, &[]);
        let exact = exact_columns(vars, c, mixing_groups, &[], &point, np, k);
        let plain = analyse_compiled(vars, c, c_eval, mixing_groups, nominal, &[], exact);
        relations
            .iter()
            .map(|r| removed_directions(&plain.gauge, &rows_f64(std::slice::from_ref(r), at)))
            .collect()
    };
    Identifiability {
        count,
        identifiable,
        held,
        gauge,
        no_effect,
        relation_removes,
    }
}

/// The exact Jacobian columns `∂c/∂p` (modulo the prime, at `point`) with the relations' rows
/// below them, and the kernel of `[∂c/∂p | mixing]`.
fn exact_columns(
    vars: &VarTable,
    c: &[Vec<Poly>],
    mixing_groups: &[Vec<usize>],
    relations: &[RelationSlots],
    point: &[u64],
    np: usize,
    k: usize,
) -> (Vec<Vec<u64>>, Kernel) {
    let (values, mut jcols) = values_and_jacobian_mod(vars, c, point, np);
    let c_mod: Vec<Vec<u64>> = (0..c.len())
        .map(|e| values[e * k..(e + 1) * k].to_vec())
        .collect();
    let mut gcols = mixing_columns(&c_mod, mixing_groups, k);
    append_rows(&mut jcols, &mut gcols, &rows_mod(relations, point, np), 0);
    let kernel = Kernel::new(&jcols, &gcols);
    (jcols, kernel)
}

/// Appends `rows` (one entry per parameter) below the parameter columns and zeros below the
/// mixing columns: a relation constrains the parameters, not the mixing.
fn append_rows<T: Copy>(jcols: &mut [Vec<T>], gcols: &mut [Vec<T>], rows: &[Vec<T>], zero: T) {
    for row in rows {
        for (col, &x) in jcols.iter_mut().zip(row) {
            col.push(x);
        }
        for col in gcols.iter_mut() {
            col.push(zero);
        }
    }
}

/// The part of the gauge space `gauge` (sparse vectors over the parameters) that the relation
/// rows `rows` see: the images of the right singular vectors of `rows · gaugeᵀ` with non-zero
/// singular values, each scaled so that its first entry is 1.
fn removed_directions(gauge: &[Vec<(usize, f64)>], rows: &[Vec<f64>]) -> Vec<Vec<(usize, f64)>> {
    let g = gauge.len();
    if g == 0 || rows.is_empty() {
        return Vec::new();
    }
    let m = DMatrix::from_fn(rows.len().max(g), g, |r, k| {
        rows.get(r)
            .map_or(0.0, |row| gauge[k].iter().map(|&(j, x)| row[j] * x).sum())
    });
    let svd = m.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Vec::new();
    };
    // A direction is removed when the relation changes along it at a rate comparable to
    // its own gradient's size (relative 10⁻⁶, above the near-nominal point's residue).
    let row_norm = rows.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    let dir_norm = gauge
        .iter()
        .map(|g| g.iter().map(|(_, x)| x * x).sum::<f64>().sqrt())
        .fold(0.0f64, f64::max);
    let mx = 1e-3 * row_norm * dir_norm;
    if mx == 0.0 {
        return Vec::new();
    }
    let np = gauge
        .iter()
        .flatten()
        .map(|&(j, _)| j + 1)
        .max()
        .unwrap_or(0);
    let mut out = Vec::new();
    for (s, sv) in svd.singular_values.iter().enumerate() {
        if *sv <= mx {
            continue;
        }
        let mut dir = vec![0.0; np];
        for (k, dirs) in gauge.iter().enumerate() {
            for &(j, x) in dirs {
                dir[j] += vt[(s, k)] * x;
            }
        }
        let big = dir.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // Entries below 10⁻⁶ of the largest are the residue of a near-nominal point.
        let Some(lead) = dir.iter().copied().find(|x| x.abs() > 1e-6 * big) else {
            continue;
        };
        out.push(
            dir.iter()
                .enumerate()
                .filter(|(_, x)| x.abs() > 1e-6 * big)
                .map(|(j, x)| (j, x / lead))
                .collect(),
        );
    }
    out
}

/// The columns `[∂C/∂p | mixing]` evaluated in `f64` at `point` (parameter values).
fn numeric_columns(
    vars: &VarTable,
    c: &[Vec<Poly>],
    c_eval: &[CompiledPoly],
    mixing_groups: &[Vec<usize>],
    np: usize,
    point: &[f64],
) -> Vec<Vec<f64>> {
    let roles = param_roles(vars);
    let k = c.first().map_or(0, Vec::len);
    let mut grad = vec![0.0; np];
    let vals = param_values(vars, point);
    let mut cols = vec![vec![0.0; c_eval.len()]; np];
    for (row, poly) in c_eval.iter().enumerate() {
        grad.iter_mut().for_each(|g| *g = 0.0);
        poly.add_gradient(&vals, &roles, &mut grad);
        for (col, &g) in cols.iter_mut().zip(&grad) {
            col[row] = g;
        }
    }
    let c_f: Vec<Vec<f64>> = c_eval
        .chunks(k.max(1))
        .map(|row| row.iter().map(|poly| poly.eval(&vals)).collect())
        .collect();
    cols.extend(mixing_columns(&c_f, mixing_groups, k));
    cols
}

/// Numerical rank of a set of columns, each scaled to unit norm (relative tolerance 1e-9).
fn numeric_rank(cols: &[&Vec<f64>]) -> usize {
    let Some(first) = cols.first() else {
        return 0;
    };
    let nrows = first.len().max(cols.len());
    // Each norm once (not once per entry).
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let a = DMatrix::from_fn(nrows, cols.len(), |i, j| {
        let n = norms[j];
        if n > 0.0 {
            cols[j].get(i).copied().unwrap_or(0.0) / n
        } else {
            0.0
        }
    });
    let sv = a.singular_values();
    let mx = sv.iter().fold(0.0f64, |m, x| m.max(*x));
    sv.iter().filter(|s| **s > 1e-9 * mx).count()
}

/// A point near `nominal` that is generic: every parameter moved by a small pseudo-random
/// amount (1e-6 rad for angles, 1e-6 of the largest nominal length for lengths): generic,
/// yet close enough that its gauge directions are those at the nominals to display precision.
fn perturbed(vars: &VarTable, nominal: &[f64]) -> Vec<f64> {
    let scale = vars
        .vars
        .iter()
        .filter_map(|v| match v {
            super::monomial::Var::ParamLength(j) => Some(nominal[*j].abs()),
            _ => None,
        })
        .fold(1e-3f64, f64::max);
    let mut rng = super::modp::Rng::new(0xfeed);
    let mut p = nominal.to_vec();
    for v in &vars.vars {
        let u = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        match v {
            super::monomial::Var::ParamLength(j) => p[*j] += 2e-6 * scale * u,
            super::monomial::Var::ParamCos(j) => p[*j] += 2e-6 * u,
            _ => {}
        }
    }
    p
}

/// Smallest principal cosine between the gauge space (orthonormal columns `n`, one row per
/// parameter, in column-scaled units) and the coordinates of the held parameters: how well
/// holding them pins every gauge direction (1 = perfectly, 0 = not at all).
fn pinning(n: &[Vec<f64>], held: &[bool]) -> f64 {
    let rows: Vec<usize> = (0..held.len()).filter(|&j| held[j]).collect();
    let g = n.len();
    if g == 0 || rows.is_empty() {
        return 1.0;
    }
    let m = DMatrix::from_fn(rows.len().max(g), g, |i, k| {
        rows.get(i).map_or(0.0, |&j| n[k][j])
    });
    let sv = m.singular_values();
    let mut v: Vec<f64> = sv.iter().copied().collect();
    v.sort_by(|a, b| b.total_cmp(a));
    // With |held| ≤ g, the |held|-th largest singular value is the one that matters.
    v.get(rows.len().min(g) - 1).copied().unwrap_or(0.0)
}

/// Orthonormal basis (`dim` vectors over the parameters, in the columns' scaled units) of the
/// parameter part of the null space of `[∂C/∂p | mixing]`, given its generic rank `r_all`.
/// With `unscale`, the vectors are in parameter units (for display), else in the scaled
/// units where every column has unit norm (for conditioning).
fn null_parameter_space(
    cols: &[Vec<f64>],
    np: usize,
    r_all: usize,
    dim: usize,
    unscale: bool,
) -> Vec<Vec<f64>> {
    if dim == 0 || cols.is_empty() {
        return Vec::new();
    }
    let ncols = cols.len();
    let nrows = cols[0].len().max(ncols);
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
    let Ok(svd) = crate::numeric::linalg::checked_svd(a, false, true) else {
        return Vec::new();
    };
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
        .map(|&i| {
            (0..np)
                .map(|j| vt[(i, j)] * if unscale { scales[j] } else { 1.0 })
                .collect()
        })
        .collect();
    if null_p.is_empty() {
        return Vec::new();
    }
    let n = DMatrix::from_fn(np, null_p.len().max(np), |i, j| {
        null_p.get(j).map_or(0.0, |v| v[i])
    });
    let Ok(svd2) = crate::numeric::linalg::checked_svd(n, true, false) else {
        return Vec::new();
    };
    let Some(u) = svd2.u else {
        return Vec::new();
    };
    let mut order2: Vec<usize> = (0..svd2.singular_values.len()).collect();
    order2.sort_by(|&x, &y| svd2.singular_values[y].total_cmp(&svd2.singular_values[x]));
    let rows: Vec<Vec<f64>> = order2
        .iter()
        .take(dim)
        .map(|&i| (0..np).map(|j| u[(j, i)]).collect())
        .collect();
    rows
}

/// Gauge directions for display: each one moves one held parameter by 1 (and no other held
/// parameter) with the compensating change of the free ones; when the held set does not
/// pin the space (a degenerate nominal point), a unit-leading reduced form instead.
fn readable_gauge(
    mut rows: Vec<Vec<f64>>,
    held: &[bool],
    effect: &[f64],
) -> Vec<Vec<(usize, f64)>> {
    let pivots: Vec<usize> = (0..held.len()).filter(|&j| held[j]).collect();
    if !solve_for_pivots(&mut rows, &pivots) {
        readable(&mut rows);
    }
    // Drop the O(1e-6) residue of the near-nominal point, compared in effect units (so metres,
    // radians and 1/metres are comparable); never a held parameter (its 1 is what the
    // direction is expressed against).
    rows.iter()
        .map(|r| {
            let weighted = |j: usize, x: f64| x.abs() * effect.get(j).copied().unwrap_or(1.0);
            let mx = r
                .iter()
                .enumerate()
                .fold(0.0f64, |m, (j, x)| m.max(weighted(j, *x)));
            r.iter()
                .enumerate()
                .filter(|(j, x)| {
                    // A held parameter is 1 in its own direction and 0 in the others.
                    if held[*j] {
                        (**x - 1.0).abs() < 1e-6
                    } else {
                        weighted(*j, **x) > 1e-5 * mx
                    }
                })
                .map(|(j, x)| (j, *x))
                .collect()
        })
        .collect()
}

/// Transforms the basis `rows` so that row `i` has 1 at `pivots[i]` and 0 at the other
/// pivots. Returns `false` (leaving `rows` untouched) when that submatrix is singular.
fn solve_for_pivots(rows: &mut [Vec<f64>], pivots: &[usize]) -> bool {
    let g = rows.len();
    if pivots.len() != g || g == 0 {
        return false;
    }
    let sub = DMatrix::from_fn(g, g, |i, k| rows[i][pivots[k]]);
    let Some(inv) = sub.clone().try_inverse() else {
        return false;
    };
    if sub.singular_values().min() < 1e-6 * sub.singular_values().max() {
        return false;
    }
    let np = rows[0].len();
    // new_rows = inv(sub)ᵀ-combination: new_i = Σ_r inv[(r, i)] rows_r has entry δ_ik at pivot k.
    let new: Vec<Vec<f64>> = (0..g)
        .map(|i| {
            (0..np)
                .map(|j| (0..g).map(|r| inv[(i, r)] * rows[r][j]).sum())
                .collect()
        })
        .collect();
    for (r, n) in rows.iter_mut().zip(new) {
        *r = n;
    }
    true
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The rank of `cols` minus those in `skip`, from scratch.
    fn rank_without(cols: &[Vec<u64>], skip: &[bool]) -> usize {
        let kept: Vec<Vec<u64>> = cols
            .iter()
            .zip(skip)
            .filter(|(_, &s)| !s)
            .map(|(c, _)| c.clone())
            .collect();
        modp::rank(&kept)
    }

    #[test]
    fn kernel_ranks_match_direct_elimination() {
        let mut rng = modp::Rng::new(11);
        for trial in 0..40 {
            let len = 3 + trial % 7;
            let (np, ng) = (2 + trial % 5, trial % 3);
            // Low-rank columns: combinations of a few random vectors, some repeated or zero.
            let gens: Vec<Vec<u64>> = (0..1 + trial % 4)
                .map(|_| (0..len).map(|_| rng.element()).collect())
                .collect();
            let mut make = || -> Vec<u64> {
                let mut v = vec![0u64; len];
                for g in &gens {
                    let w = if rng.next_u64().is_multiple_of(3) {
                        0
                    } else {
                        rng.element()
                    };
                    for (x, &y) in v.iter_mut().zip(g) {
                        *x = modp::add(*x, modp::mul(w, y));
                    }
                }
                v
            };
            let jcols: Vec<Vec<u64>> = (0..np).map(|_| make()).collect();
            let gcols: Vec<Vec<u64>> = (0..ng).map(|_| make()).collect();
            let all: Vec<Vec<u64>> = jcols.iter().chain(&gcols).cloned().collect();
            let kernel = Kernel::new(&jcols, &gcols);
            let none = vec![false; np + ng];
            assert_eq!(kernel.rank, rank_without(&all, &none));
            assert_eq!(kernel.rank_mixing, modp::rank(&gcols));
            for j in 0..np {
                let mut skip = none.clone();
                skip[j] = true;
                assert_eq!(kernel.essential(j), rank_without(&all, &skip) < kernel.rank);
            }
            for mask in 0u32..(1 << np) {
                let skip: Vec<bool> = (0..np + ng).map(|j| j < np && mask >> j & 1 == 1).collect();
                assert_eq!(
                    kernel.keeps_rank(&skip),
                    rank_without(&all, &skip) == kernel.rank
                );
            }
        }
    }
}
