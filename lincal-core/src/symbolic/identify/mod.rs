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
use gauge::{gauge_directions, null_parameter_space, numeric_rank, pinning, removed_directions};
use std::sync::atomic::{AtomicUsize, Ordering};

mod gauge;

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
    priority: &[usize],
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
    let problem = Problem {
        vars,
        c,
        c_eval: &c_eval,
        mixing_groups,
        nominal,
        priority,
    };
    let ident = analyse_compiled(&problem, relations, exact);
    (ident, c_eval)
}

/// What the analysis works on: the engine's variables, `c` exact and compiled, the mixing
/// groups, the nominal parameters and the gauge rule's order of them.
struct Problem<'a> {
    vars: &'a VarTable,
    c: &'a [Vec<Poly>],
    c_eval: &'a [CompiledPoly],
    mixing_groups: &'a [Vec<usize>],
    nominal: &'a [f64],
    priority: &'a [usize],
}

/// [`analyse`] with `c` compiled (`c_eval`) and the exact columns formed (`exact`).
fn analyse_compiled(
    problem: &Problem<'_>,
    relations: &[RelationSlots],
    exact: (Vec<Vec<u64>>, Kernel),
) -> Identifiability {
    let Problem {
        vars,
        c,
        c_eval,
        mixing_groups,
        nominal,
        priority,
    } = *problem;
    let np = nominal.len();
    let near = perturbed(vars, nominal);
    let both = columns_near_and_at_nominal(vars, c, c_eval, mixing_groups, &near, nominal);
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
    let (cols_near, cols_nominal) = with_relation_rows(both, relations, &near, nominal);
    let n_near = null_parameter_space(&cols_near, np, r_all, gauge_dim, false);
    let held = held_by_gauge_rule(&identifiable, &n_near, &kernel, gauge_dim, priority);
    let nominal_generic = numeric_rank(&cols_nominal.iter().collect::<Vec<_>>()) == r_all;
    let gauge_cols = if nominal_generic {
        &cols_nominal
    } else {
        &cols_near
    };
    let gauge = gauge_directions(gauge_cols, np, r_all, gauge_dim, &held);
    // A zero column at a generic point is a zero polynomial column: no effect anywhere.
    let no_effect = jcols.iter().map(|c| c.iter().all(|&x| x == 0)).collect();
    let relation_removes = if relations.is_empty() {
        Vec::new()
    } else {
        // Where the gauge directions were taken (see above).
        let at: &[f64] = if nominal_generic { nominal } else { &near };
        removed_by_relations(problem, relations, at)
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

/// The floating-point columns near the nominals (at `near`) and at them (for the gauge
/// rule), in that order: one point on each core.
fn columns_near_and_at_nominal(
    vars: &VarTable,
    c: &[Vec<Poly>],
    c_eval: &[CompiledPoly],
    mixing_groups: &[Vec<usize>],
    near: &[f64],
    nominal: &[f64],
) -> Vec<Vec<Vec<f64>>> {
    let np = nominal.len();
    std::thread::scope(|s| {
        let at_near = s.spawn(|| numeric_columns(vars, c, c_eval, mixing_groups, np, near));
        let at_nominal = numeric_columns(vars, c, c_eval, mixing_groups, np, nominal);
        let at_near = at_near
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        vec![at_near, at_nominal]
    })
}

/// The columns near and at the nominals (`both`, from [`columns_near_and_at_nominal`]), each
/// with the relations' rows at its point below them: `(near, nominal)`.
fn with_relation_rows(
    mut both: Vec<Vec<Vec<f64>>>,
    relations: &[RelationSlots],
    near: &[f64],
    nominal: &[f64],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let np = nominal.len();
    for (cols, at) in both.iter_mut().zip([near, nominal]) {
        let (jc, gc) = cols.split_at_mut(np);
        let mut jc = jc.to_vec();
        let mut gc = gc.to_vec();
        append_rows(&mut jc, &mut gc, &rows_f64(relations, at), 0.0);
        *cols = jc.into_iter().chain(gc).collect();
    }
    let cols_nominal = both.pop().unwrap_or_default();
    let cols_near = both.pop().unwrap_or_default();
    (cols_near, cols_nominal)
}

/// The gauge rule: walking the parameters in the order `priority` (see
/// [`super::priority`]; twice, the second time without asking that they pin the gauge space
/// `n_near` well), one not identifiable on its own is held when the rest still determine
/// every identifiable combination, until `gauge_dim` are held.
fn held_by_gauge_rule(
    identifiable: &[bool],
    n_near: &[Vec<f64>],
    kernel: &Kernel,
    gauge_dim: usize,
    priority: &[usize],
) -> Vec<bool> {
    let np = identifiable.len();
    let mut held = vec![false; np];
    let mut n_held = 0;
    for pass in 0..2 {
        for &j in priority {
            if n_held == gauge_dim {
                break;
            }
            if identifiable[j] || held[j] {
                continue;
            }
            held[j] = true;
            let pins = pass == 1 || pinning(n_near, &held) > 0.1;
            if pins && kernel.keeps_rank(&held) {
                n_held += 1;
            } else {
                held[j] = false;
            }
        }
    }
    held
}

/// The gauge directions relative to each relation of the spec: of the analysis without
/// relations, those each relation's rows at `at` see.
fn removed_by_relations(
    problem: &Problem<'_>,
    relations: &[RelationSlots],
    at: &[f64],
) -> Vec<Vec<Vec<(usize, f64)>>> {
    let Problem {
        vars,
        c,
        mixing_groups,
        nominal,
        ..
    } = *problem;
    let np = nominal.len();
    let k = c.first().map_or(0, Vec::len);
    let point = relation_point(vars, POINT_SEED, &[]);
    let exact = exact_columns(vars, c, mixing_groups, &[], &point, np, k);
    let plain = analyse_compiled(problem, &[], exact);
    relations
        .iter()
        .map(|r| removed_directions(&plain.gauge, &rows_f64(std::slice::from_ref(r), at)))
        .collect()
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
