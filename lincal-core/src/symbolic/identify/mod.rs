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
//! generic point modulo a prime, from the stacked constraint Jacobian at sampled joint
//! readings ([`sampled`]: no expansion, no `K`). Parameter `p_i` is identifiable on its own when removing its
//! column lowers that rank. The gauge rule holds parameters at their nominal values: walking
//! `params` in spec order, a parameter that is not identifiable on its own is held whenever the
//! remaining free parameters still determine every identifiable combination. The gauge
//! directions (the parameter changes the constraint cannot see) are reported at the nominal
//! point, in a reduced form whose leading coefficient is 1.

use super::eval::param_values;
use super::modp::{self, Echelon, Mp};
use super::monomial::VarTable;
use super::relations::{relation_point, rows_f64, rows_mod, RelationSlots};
use super::slots::SlotPolys;
use gauge::{pinning, removed_directions, ScaledStack};
use sampled::readings_needed;

mod dual;
pub(crate) mod gauge;
mod motion;
pub(crate) mod sampled;

/// Result of the identifiability analysis.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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

/// The seed of the generic point of the exact analysis.
const POINT_SEED: u64 = 0x5eed_1d3a;

/// The seed of the exact analysis's joint readings.
const READINGS_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// The seed of the floating-point readings of the gauge rule.
const FLOAT_SEED: u64 = 0xf10a_7ed5;

/// The identifiability analysis of a spec's slots ([`crate::symbolic::slots`]) under
/// `relations`, the gauge rule walking the parameters in the order `priority`.
///
/// The ranks and the kernel of `[∂C/∂p | mixing]` come from the stacked constraint Jacobian
/// at sampled joint readings ([`sampled`]), modulo the prime at a generic point; the gauge
/// rule's conditioning from the same columns in `f64` near and at the nominals.
#[must_use]
pub fn identifiability(
    sp: &SlotPolys,
    relations: &[RelationSlots],
    priority: &[usize],
) -> Identifiability {
    let nominal = &sp.param_nominals;
    let np = nominal.len();
    let near = perturbed(&sp.vars, nominal);
    // The exact analysis first: how many readings each constraint's rows took to span their
    // part sizes the float stack ([`float_counts`]; at a degenerate nominal point, the full
    // `P + m² + 8`). The rule, the rank and the gauge directions read `AᵀA` only: each stack
    // of hundreds of rows as `n × n`. (Where the nominal point is nearly degenerate, the
    // directions' small coefficients along its extra null direction are rounding either way.)
    let (jcols, kernel, taken) = exact_columns(sp, relations);
    let stack = |p: &[f64], counts: &[usize]| float_stack(sp, relations, p, counts);
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
    // Where the nominal point has the generic rank, its null space is that limit (a point
    // 10⁻⁶ away, where the rule was taken before, chose the same held parameters on every spec
    // of the repository); where it is degenerate, the rule and the printed directions are
    // taken at such a point instead.
    let gauge_dim = np - count;
    let mut counts = float_counts(sp, &taken);
    let mut at_nominal = ScaledStack::new(&stack(nominal, &counts), np);
    let all = reading_counts(sp, 4);
    if at_nominal.rank() < r_all && counts != all {
        // The counts are sized at a generic point: at the nominals, a special one, a block
        // may need more before the rank says the point is degenerate.
        counts = all;
        at_nominal = ScaledStack::new(&stack(nominal, &counts), np);
    }
    let nominal_generic = at_nominal.rank() == r_all;
    let at_rule = if nominal_generic {
        at_nominal
    } else {
        ScaledStack::new(&stack(&near, &counts), np)
    };
    let n_near = at_rule.null_parameter_space(np, r_all, gauge_dim, false);
    let held = held_by_gauge_rule(&identifiable, &n_near, &kernel, gauge_dim, priority);
    let gauge = at_rule.gauge_directions(np, r_all, gauge_dim, &held);
    // A zero column at generic readings and a generic point is a zero polynomial column: no
    // effect anywhere.
    let no_effect = jcols.iter().map(|c| c.iter().all(|&x| x == 0)).collect();
    let relation_removes = if relations.is_empty() {
        Vec::new()
    } else {
        // Where the gauge directions were taken (see above).
        let at: &[f64] = if nominal_generic { nominal } else { &near };
        let plain = identifiability(sp, &[], priority);
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

/// [`identifiability`] of `spec`'s equations without those of the constraints marked
/// `unseen` (and, unless `all_relations`, without the relations that involve them): what a
/// fit of poses on the other constraints can determine
/// ([`crate::model::CalibModel::identifiability_without`]).
pub(crate) fn without_constraints(
    sp: &SlotPolys,
    spec: &crate::spec::Spec,
    unseen: &[bool],
    all_relations: bool,
) -> crate::model::DataGauge {
    let seen = |j: usize| !unseen.get(j).copied().unwrap_or(false);
    let mut part = sp.clone();
    part.constraints = sp
        .constraints
        .iter()
        .enumerate()
        .filter(|&(j, _)| seen(j))
        .map(|(_, c)| c.clone())
        .collect();
    let relations: Vec<RelationSlots> = super::relations::relation_slots(spec, &sp.param_vars)
        .into_iter()
        .zip(&spec.relations)
        .filter(|(_, r)| all_relations || r.between.iter().all(|&j| seen(j)))
        .map(|(slots, _)| slots)
        .collect();
    let ident = identifiability(&part, &relations, &super::priority::gauge_priority(spec));
    crate::model::DataGauge {
        held: ident.held,
        identifiable: ident.identifiable,
        count: ident.count,
    }
}

/// The parameter columns of a basis of the rows of `∂h/∂p` (modulo the prime, at sampled
/// readings and a generic point on the relations' zero set; [`sampled::spanning_rows_mod`])
/// with the relations' rows below them, and the kernel of `[∂h/∂p | mixing]`. Only that
/// kernel and which columns are zero mean anything: the rows are reduced combinations.
fn exact_columns(
    sp: &SlotPolys,
    relations: &[RelationSlots],
) -> (Vec<Vec<u64>>, Kernel, Vec<usize>) {
    let np = sp.param_nominals.len();
    let point = relation_point(&sp.vars, POINT_SEED, relations);
    let vals: Vec<Mp> = point.iter().map(|&x| Mp(x)).collect();
    let mut rng = modp::Rng::new(READINGS_SEED);
    let (width, rows, taken) =
        sampled::spanning_rows_mod(sp, &vals, &reading_counts(sp, 0), &mut rng);
    // The rows span the stack's row space, so its columns have the same kernel (and a column
    // is zero in them exactly when it is zero in the stack).
    let column = |j: usize| rows.iter().map(|r| r[j]).collect::<Vec<u64>>();
    let mut jcols: Vec<Vec<u64>> = (0..np).map(column).collect();
    let mut gcols: Vec<Vec<u64>> = (np..width).map(column).collect();
    append_rows(&mut jcols, &mut gcols, &rows_mod(relations, &point, np), 0);
    let kernel = Kernel::new(&jcols, &gcols);
    (jcols, kernel, taken)
}

/// The columns `[∂h/∂p | mixing]` in `f64` at parameter values `p`, constraint `i` at the
/// first `counts[i]` of readings shared by every constraint ([`float_counts`]).
fn float_columns(sp: &SlotPolys, p: &[f64], counts: &[usize]) -> Vec<Vec<f64>> {
    let vals = param_values(&sp.vars, p);
    let mut rng = modp::Rng::new(FLOAT_SEED);
    let most = counts.iter().copied().max().unwrap_or(0);
    let readings = sampled::readings_f64(&sp.vars, most, &mut rng);
    let cols = sampled::columns(sp, &vals, &readings, counts);
    cols.params.into_iter().chain(cols.mixing).collect()
}

/// How many readings each constraint's block of the float stack takes: three times what its
/// exact rows took to stop adding to the span (`taken`, [`sampled::spanning_rows_mod`]) and
/// four more, at most `P + m² + 8` (what every block took before). The exact count is what
/// spans the block's part in exact arithmetic at a generic point; random angles are less well
/// spread than exact generic points, so about three rows stand for each one the span needs,
/// as before. (The nominal point is not generic: where the stack there falls short of the
/// generic rank, [`identifiability`] takes the full count again before calling the point
/// degenerate.) The 6-point Panda's analysis takes 3.3 ms where it took 5.5 (serial).
fn float_counts(sp: &SlotPolys, taken: &[usize]) -> Vec<usize> {
    reading_counts(sp, 4)
        .into_iter()
        .zip(taken)
        .map(|(most, &t)| most.min(3 * t + 4))
        .collect()
}

/// Per constraint, the readings its block needs ([`readings_needed`]) and `extra` more.
fn reading_counts(sp: &SlotPolys, extra: usize) -> Vec<usize> {
    let np = sp.param_nominals.len();
    sp.constraints
        .iter()
        .map(|(c, _)| readings_needed(c, sp.dim, np) + extra)
        .collect()
}

/// The columns `[∂h/∂p | mixing]` in `f64` at `p` ([`float_columns`]), with the relations'
/// rows at `p` below them.
fn float_stack(
    sp: &SlotPolys,
    relations: &[RelationSlots],
    p: &[f64],
    counts: &[usize],
) -> Vec<Vec<f64>> {
    let np = p.len();
    let cols = float_columns(sp, p, counts);
    let (jc, gc) = cols.split_at(np);
    let (mut jc, mut gc) = (jc.to_vec(), gc.to_vec());
    append_rows(&mut jc, &mut gc, &rows_f64(relations, p), 0.0);
    jc.into_iter().chain(gc).collect()
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

    /// The kernel of the whole stack at `P + m² + 4` readings per constraint (the rows the
    /// analysis took before they were drawn until the span stops growing; here the
    /// constraints share them), and the parameter columns (with the relations' rows below
    /// them).
    fn full_stack(sp: &SlotPolys, relations: &[RelationSlots]) -> (Vec<Vec<u64>>, Kernel) {
        let np = sp.param_nominals.len();
        let point = relation_point(&sp.vars, POINT_SEED, relations);
        let vals: Vec<Mp> = point.iter().map(|&x| Mp(x)).collect();
        let mut rng = modp::Rng::new(0x51de);
        let counts = reading_counts(sp, 0);
        let most = counts.iter().copied().max().unwrap_or(0);
        let readings = sampled::readings_mod(&sp.vars, most, &mut rng);
        let cols = sampled::columns(sp, &vals, &readings, &counts);
        let plain = |c: Vec<Vec<Mp>>| -> Vec<Vec<u64>> {
            c.into_iter()
                .map(|v| v.into_iter().map(|x| x.0).collect())
                .collect()
        };
        let (mut jcols, mut gcols) = (plain(cols.params), plain(cols.mixing));
        append_rows(&mut jcols, &mut gcols, &rows_mod(relations, &point, np), 0);
        let kernel = Kernel::new(&jcols, &gcols);
        (jcols, kernel)
    }

    /// The rows drawn until each constraint's span stops growing give the whole stack's
    /// ranks, kernel and zero columns, on every spec of the repository but the large ones
    /// (every constraint kind, relations, measured poses, several constraints sharing their
    /// readings).
    #[test]
    fn spanning_rows_give_the_whole_stacks_kernel() {
        let paths = crate::symbolic::testutil::repo_spec_paths(&[
            "tests/specs",
            "lincal-models/specs",
            "bench/specs",
            "examples",
            "../shared/cases",
        ]);
        assert!(paths.len() >= 35, "only {} specs", paths.len());
        for name in &paths {
            let spec = crate::symbolic::testutil::repo_spec(name);
            let sp = crate::symbolic::slots::slot_polys(&spec).unwrap();
            let relations = crate::symbolic::relations::relation_slots(&spec, &sp.param_vars);
            let (jf, full) = full_stack(&sp, &relations);
            let (js, span, _) = exact_columns(&sp, &relations);
            let np = sp.param_nominals.len();
            assert_eq!(span.rank, full.rank, "{name}: rank");
            assert_eq!(span.rank_mixing, full.rank_mixing, "{name}: mixing rank");
            for j in 0..np {
                assert_eq!(span.essential(j), full.essential(j), "{name}: column {j}");
                let zero = |c: &Vec<u64>| c.iter().all(|&x| x == 0);
                assert_eq!(zero(&js[j]), zero(&jf[j]), "{name}: zero column {j}");
            }
            // The same kernel: each basis inside the span of the other.
            let both: Vec<Vec<u64>> = span.vectors.iter().chain(&full.vectors).cloned().collect();
            assert_eq!(
                span.vectors.len(),
                full.vectors.len(),
                "{name}: kernel dimension"
            );
            assert_eq!(modp::rank(&both), full.vectors.len(), "{name}: kernel");
        }
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
