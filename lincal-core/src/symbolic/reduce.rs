//! Exact column reduction to the minimal basis (the paper's step 2, done on the span of the
//! constraint functions themselves).
//!
//! Write every equation as `h_e(q; p) = Σ_μ Σ_m E[(e,μ), m] · μ(p) · m(q)` with canonical
//! joint monomials `m` and canonical parameter monomials `μ`. Both families are linearly
//! independent functions, so the span of `{q ↦ h_e(q; p)}` over all `e` and `p` is the row
//! space of `E`. Its reduced row echelon form, with columns ordered simplest monomial first,
//! is a canonical basis `Φ̃`: basis function `k` has coefficient 1 at its pivot monomial and
//! 0 at every other pivot, hence `h_e = Σ_k c_{e,k}(p) Φ̃_k(q)` with `c_{e,k}(p)` the
//! coefficient of pivot monomial `k` in `h_e`: the generalized parameters.
//!
//! The echelon form is computed modulo a prime by sparse elimination of the rows of `E`
//! (sparsest first, stopping at full rank), its entries reconstructed as rationals, and the
//! result verified exactly over ℚ: every row of `E` must be the combination its pivot entries
//! dictate. (Rank mod p ≤ rank over ℚ ≤ the verified `K`, so the `K` reported is exact; at
//! full rank the first inequality alone proves it.) If reconstruction or verification fails,
//! an exact rational elimination runs instead.

use super::coef::Coef;
use super::modp;
use super::monomial::Mono;
use super::poly::{display_key, display_order, DisplayKey, Poly};
use rustc_hash::{FxHashMap, FxHashSet};
use std::borrow::Borrow;
use std::collections::hash_map::Entry as Slot;

/// The column-reduced basis and the generalized parameters.
#[derive(Clone, Debug)]
pub struct Reduction {
    /// Distinct joint monomials of all equations, before reduction (`naive_size` of them),
    /// in pivot order.
    pub monomials: Vec<Mono>,
    /// Basis functions `Φ̃_k = Σ coef · monomial` (sparse, sorted by display order).
    pub basis: Vec<Vec<(Mono, Coef)>>,
    /// `c[e][k]`: the generalized parameter of equation `e` on basis function `k`.
    pub c: Vec<Vec<Poly>>,
    /// The pivot of each basis function: its index in [`Reduction::monomials`].
    pub pivots: Vec<usize>,
}

/// Column-reduces the equations `hs` (polynomials whose first `joint_vars` variables are the
/// joint variables). They are consumed: their coefficients move into `c`. `on_basis_size`
/// is told the basis size `K` (the rank of `E`) as soon as it is known (from one pass over the
/// terms when every row of `E` has one term, [`one_term_rank`]; otherwise from the echelon
/// form), before the basis functions and `c` are assembled: a caller waiting for `K` alone
/// (a report) need not wait for the rest.
pub fn reduce_with(
    hs: Vec<Poly>,
    joint_vars: usize,
    on_basis_size: impl FnOnce(usize),
) -> Reduction {
    let nequations = hs.len();
    let mut on_basis_size = Some(on_basis_size);
    // Rows of one term each (the usual case of a chain whose parameters are all unknown)
    // give `K` in one pass, before the split builds what the basis and `c` need.
    let one_term_k = one_term_rank(&hs, joint_vars);
    if let Some(k) = one_term_k {
        if let Some(tell) = on_basis_size.take() {
            tell(k);
        }
    }
    let (row_keys, col_keys, mut entries) = split_terms(hs, joint_vars);
    let monos = display_columns(col_keys, &mut entries);
    let ncols = monos.len();
    // Rows of E: one per (equation, parameter monomial); sparse over joint monomials. One
    // sort of all terms by (row, column) lays every row out contiguously, in a fixed order
    // (the result does not depend on it: the echelon form is canonical). Rows of one term
    // each need no order: `echelon_basis` reads them as they are.
    if entries.len() != row_keys.len() {
        entries.sort_unstable_by_key(|t| (t.0, t.1));
    }
    let (basis_dense, pivots) = echelon_basis(&entries, row_keys.len(), ncols);
    debug_assert!(one_term_k.is_none_or(|k| k == basis_dense.len()));
    if let Some(tell) = on_basis_size.take() {
        tell(basis_dense.len());
    }
    let basis = basis_functions(&basis_dense, &monos);
    let c = generalized_params(entries, &row_keys, &pivots, ncols, nequations);
    Reduction {
        monomials: monos,
        basis,
        c,
        pivots,
    }
}

/// `K` at once when every row of `E` has a single term: then each row is a unit vector (a
/// polynomial keeps no zero coefficient) and every column has one, so `K` is the number of
/// distinct joint monomials. `None` as soon as two terms of one equation share their
/// parameter monomial (a row of two terms or more: the echelon form decides).
///
/// One pass whose row set has 8-byte keys, where the split that follows keys each row by 16
/// bytes (equation, fingerprint) and confirms a hit against its monomial; the column set
/// holds the joint monomials themselves. A row is keyed by a digest of (equation, parameter
/// monomial): equal pairs have equal digests, so keys that are all distinct prove the rows
/// distinct; two different pairs sharing a digest (about `2⁻⁶⁴` a pair) only send the count
/// to the echelon form. The row set grows as it goes (no reserve of every term up front), so
/// a pass that gives up at an early repeat, the usual case when rows have several terms,
/// costs little.
fn one_term_rank(hs: &[Poly], joint_vars: usize) -> Option<usize> {
    let mut rows: FxHashSet<u64> = FxHashSet::default();
    let mut cols: FxHashSet<Mono> = FxHashSet::default();
    for (e, h) in hs.iter().enumerate() {
        // An odd multiplier keeps the equations' offsets apart.
        let salt = (e as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        for m in h.terms.keys() {
            let (jm, pm) = m.split(joint_vars);
            if !rows.insert(pm.fingerprint() ^ salt) {
                return None;
            }
            cols.insert(jm);
        }
    }
    Some(cols.len())
}

/// One term of `E`: its row, its column and its coefficient.
type Entry = (u32, u32, Coef);

/// Each term `coef · μ(p) · m(q)` of each equation, split once into its row of `E` (the
/// pair (equation, μ), numbered in order of first appearance) and its joint monomial
/// (numbered likewise, provisionally): the rows' keys, the columns' monomials and the terms.
fn split_terms(hs: Vec<Poly>, joint_vars: usize) -> (Vec<(u32, Mono)>, Vec<Mono>, Vec<Entry>) {
    split_terms_by(hs, joint_vars, Mono::fingerprint)
}

/// [`split_terms`] with the rows' fingerprint `fingerprint` (the tests force collisions).
fn split_terms_by(
    hs: Vec<Poly>,
    joint_vars: usize,
    fingerprint: impl Fn(&Mono) -> u64,
) -> (Vec<(u32, Mono)>, Vec<Mono>, Vec<Entry>) {
    let total: usize = hs.iter().map(Poly::len).sum();
    let mut col_of: FxHashMap<Mono, u32> = FxHashMap::default();
    // Rows keyed by (equation, the parameter monomial's fingerprint): a 16-byte key where the
    // monomial itself is 64 bytes, so the table of tens of thousands of rows stays in cache.
    // A hit is confirmed against the row's monomial; a different monomial with the same
    // fingerprint (about 2⁻⁶⁴ a pair) goes to `spill`, keyed by the monomial itself.
    let mut row_of: FxHashMap<(u32, u64), u32> = FxHashMap::default();
    let mut spill: FxHashMap<(u32, Mono), u32> = FxHashMap::default();
    row_of.reserve(total);
    let mut row_keys: Vec<(u32, Mono)> = Vec::new();
    let mut col_keys: Vec<Mono> = Vec::new();
    let mut entries: Vec<Entry> = Vec::with_capacity(total);
    for (e, h) in hs.into_iter().enumerate() {
        let e = e as u32;
        for (m, c) in h.terms {
            let (jm, pm) = m.split(joint_vars);
            let col = *col_of.entry(jm).or_insert_with(|| {
                col_keys.push(jm);
                (col_keys.len() - 1) as u32
            });
            let next = row_keys.len() as u32;
            let row = match row_of.entry((e, fingerprint(&pm))) {
                Slot::Occupied(o) if row_keys[*o.get() as usize].1 == pm => *o.get(),
                Slot::Occupied(_) => *spill.entry((e, pm)).or_insert(next),
                Slot::Vacant(v) => *v.insert(next),
            };
            if row == next {
                row_keys.push((e, pm));
            }
            entries.push((row, col, c));
        }
    }
    drop(row_of);
    drop(spill);
    drop(col_of);
    (row_keys, col_keys, entries)
}

/// The columns in display order (distinct monomials: an unstable sort by the precomputed
/// key is exact): the monomial of each column, with `entries` renumbered to match.
fn display_columns(col_keys: Vec<Mono>, entries: &mut [Entry]) -> Vec<Mono> {
    let mut keyed: Vec<(DisplayKey, u32)> = col_keys
        .iter()
        .enumerate()
        .map(|(i, m)| (display_key(m), i as u32))
        .collect();
    keyed.sort_unstable_by_key(|x| x.0);
    let mut final_col = vec![0u32; col_keys.len()];
    for (i, &(_, prov)) in keyed.iter().enumerate() {
        final_col[prov as usize] = i as u32;
    }
    let monos: Vec<Mono> = keyed
        .iter()
        .map(|&(_, prov)| col_keys[prov as usize])
        .collect();
    drop(keyed);
    drop(col_keys);
    for t in entries.iter_mut() {
        t.1 = final_col[t.1 as usize];
    }
    monos
}

/// The canonical echelon basis of the rows of `E` (`entries`, sorted by row then column,
/// `nrows` rows) and its pivot columns: modular, or exact when that fails. The coefficients
/// are borrowed: only the rows the elimination takes are ever converted.
fn echelon_basis(entries: &[Entry], nrows: usize, ncols: usize) -> (Vec<SparseRow>, Vec<usize>) {
    if entries.len() == nrows {
        // Every row one term (each parameter monomial meets one joint monomial, as in a
        // chain whose parameters are all unknown): each row is a unit vector over ℚ (the
        // split keeps no zero coefficient), and every column has one (columns are made by
        // terms), so the basis is the identity.
        debug_assert!(entries.iter().all(|t| !t.2.is_zero()));
        debug_assert!({
            let mut seen = vec![false; ncols];
            entries.iter().for_each(|t| seen[t.1 as usize] = true);
            seen.into_iter().all(|s| s)
        });
        let basis = (0..ncols).map(|c| vec![(c, Coef::ONE)]).collect();
        return (basis, (0..ncols).collect());
    }
    let flat: Vec<(usize, &Coef)> = entries.iter().map(|t| (t.1 as usize, &t.2)).collect();
    let mut rows: Vec<&[(usize, &Coef)]> = Vec::with_capacity(nrows);
    let mut start = 0;
    for i in 1..=entries.len() {
        if i == entries.len() || entries[i].0 != entries[start].0 {
            rows.push(&flat[start..i]);
            start = i;
        }
    }
    modular_basis(&rows, ncols).unwrap_or_else(|| exact_basis(&rows, ncols))
}

/// The basis functions `Φ̃_k`: each row of the echelon basis as `(monomial, coefficient)`
/// pairs in display order.
fn basis_functions(basis_dense: &[SparseRow], monos: &[Mono]) -> Vec<Vec<(Mono, Coef)>> {
    basis_dense
        .iter()
        .map(|row| {
            let mut v: Vec<(Mono, Coef)> = row
                .iter()
                .map(|(col, c)| (monos[*col], c.clone()))
                .collect();
            v.sort_by(|a, b| display_order(&a.0, &b.0));
            v
        })
        .collect()
}

/// `c[e][k]`: the parameter polynomial of pivot monomial `k` in equation `e`, the terms of
/// `entries` moved into it.
fn generalized_params(
    entries: Vec<Entry>,
    row_keys: &[(u32, Mono)],
    pivots: &[usize],
    ncols: usize,
    nequations: usize,
) -> Vec<Vec<Poly>> {
    let mut pivot_index: Vec<Option<usize>> = vec![None; ncols];
    for (k, &p) in pivots.iter().enumerate() {
        pivot_index[p] = Some(k);
    }
    // Sized first: each polynomial's table is allocated once.
    let mut count = vec![vec![0usize; pivots.len()]; nequations];
    for &(row, col, _) in &entries {
        if let Some(k) = pivot_index[col as usize] {
            count[row_keys[row as usize].0 as usize][k] += 1;
        }
    }
    let mut c: Vec<Vec<Poly>> = count
        .into_iter()
        .map(|ce| {
            ce.into_iter()
                .map(|n| {
                    let mut p = Poly::zero();
                    p.terms.reserve(n);
                    p
                })
                .collect()
        })
        .collect();
    for (row, col, coef) in entries {
        if let Some(k) = pivot_index[col as usize] {
            let (e, pm) = row_keys[row as usize];
            c[e as usize][k].terms.insert(pm, coef);
        }
    }
    c
}

type SparseRow = Vec<(usize, Coef)>;
/// A sparse row modulo p.
type ModRow = Vec<(usize, u64)>;

/// Canonical echelon basis modulo p by sparse elimination, reconstructed and verified exactly.
///
/// The rows of `E` are sparse (a parameter monomial meets few joint monomials), so they are
/// eliminated as they are, sparsest first, against an echelon form kept sparse (dense random
/// combinations of them would cost `O(ncols³)` even when the span is everything). The
/// elimination stops as soon as every column is a pivot: then the basis is the unit vectors,
/// and rank `ncols` modulo p proves rank `ncols` over ℚ.
fn modular_basis<R: Borrow<Coef>, Row: AsRef<[(usize, R)]>>(
    rows: &[Row],
    ncols: usize,
) -> Option<(Vec<SparseRow>, Vec<usize>)> {
    let mut conv = modp::RationalMod::default();
    // Rows are converted as the elimination takes them (it stops at full rank, usually long
    // before the last row).
    let to_mod = |r: &Row| -> Option<ModRow> {
        r.as_ref()
            .iter()
            .map(|(c, v)| conv.get(v.borrow()).map(|x| (*c, x)))
            .collect()
    };
    let (ech, pivot_of) = sparse_echelon(rows, ncols, to_mod)?;
    let rank = ech.len();
    if rank == ncols {
        // Full rank: the canonical form is the identity, exact by the rank argument alone.
        let basis = (0..ncols).map(|c| vec![(c, Coef::ONE)]).collect();
        return Some((basis, (0..ncols).collect()));
    }
    let (rref_rows, pivots) = sweep(ech, &pivot_of, ncols);
    let mut basis = Vec::with_capacity(rref_rows.len());
    for r in &rref_rows {
        let mut row = Vec::with_capacity(r.len());
        for &(c, x) in r {
            row.push((c, modp::reconstruct(x)?));
        }
        basis.push(row);
    }
    verify(rows, &basis, &pivots).then_some((basis, pivots))
}

/// Row echelon form (leading entry 1 at the row's pivot, leftmost possible pivots) of the
/// span of sparse `rows` modulo p; `pivot_of[col]` is the row whose pivot `col` is. Rows are
/// taken sparsest first, which keeps the fill small; stops early at full rank.
fn sparse_echelon<T, Row: AsRef<[(usize, T)]>>(
    rows: &[Row],
    ncols: usize,
    mut to_mod: impl FnMut(&Row) -> Option<ModRow>,
) -> Option<(Vec<ModRow>, Vec<Option<usize>>)> {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    // The index breaks ties: the order is that of a stable sort.
    order.sort_unstable_by_key(|&i| {
        let r = rows[i].as_ref();
        (r.len(), r.first().map_or(0, |x| x.0), i)
    });
    let mut ech: Vec<Vec<(usize, u64)>> = Vec::new();
    let mut pivot_of: Vec<Option<usize>> = vec![None; ncols];
    let mut acc = vec![0u64; ncols];
    for &ri in &order {
        if ech.len() == ncols {
            break;
        }
        // A row with one (nonzero) entry is the unit vector at its column over ℚ itself,
        // whatever its residue: it is a new pivot or nothing, with no conversion.
        if let [(col, _)] = rows[ri].as_ref() {
            if pivot_of[*col].is_none() {
                pivot_of[*col] = Some(ech.len());
                ech.push(vec![(*col, 1)]);
            }
            continue;
        }
        let row = to_mod(&rows[ri])?;
        let Some(&(lo, _)) = row.first() else {
            continue;
        };
        let mut hi = lo;
        for &(c, x) in &row {
            acc[c] = x;
            hi = hi.max(c);
        }
        // Left to right: every entry at a pivot is eliminated (which only adds entries to
        // its right); the first entry left at a free column is the new pivot.
        let mut new_pivot = None;
        let mut col = lo;
        while col <= hi {
            let x = acc[col];
            if x != 0 {
                match pivot_of[col] {
                    Some(i) => {
                        let prow = &ech[i];
                        for &(c, y) in &prow[1..] {
                            acc[c] = modp::sub(acc[c], modp::mul(x, y));
                        }
                        if let Some(&(last, _)) = prow.last() {
                            hi = hi.max(last);
                        }
                        acc[col] = 0;
                    }
                    None => {
                        new_pivot = Some(col);
                        break;
                    }
                }
            }
            col += 1;
        }
        if let Some(p) = new_pivot {
            let i = modp::inv(acc[p]);
            let mut stored = Vec::new();
            for (c, a) in acc.iter_mut().enumerate().take(hi + 1).skip(p) {
                if *a != 0 {
                    stored.push((c, modp::mul(*a, i)));
                    *a = 0;
                }
            }
            pivot_of[p] = Some(ech.len());
            ech.push(stored);
        }
    }
    Some((ech, pivot_of))
}

/// The canonical reduced form of a sparse echelon basis: rows in pivot order, each cleared
/// at every other pivot (back substitution, rightmost pivots first).
fn sweep(
    ech: Vec<Vec<(usize, u64)>>,
    pivot_of: &[Option<usize>],
    ncols: usize,
) -> (Vec<Vec<(usize, u64)>>, Vec<usize>) {
    let pivots: Vec<usize> = (0..ncols).filter(|&c| pivot_of[c].is_some()).collect();
    let mut ech: Vec<Option<Vec<(usize, u64)>>> = ech.into_iter().map(Some).collect();
    let mut done: Vec<Option<Vec<(usize, u64)>>> = vec![None; ncols];
    let mut acc = vec![0u64; ncols];
    for &p in pivots.iter().rev() {
        let Some(i) = pivot_of[p] else { continue };
        let Some(row) = ech[i].take() else { continue };
        let hi = row.last().map_or(p, |x| x.0);
        let mut end = hi;
        for &(c, x) in &row {
            acc[c] = x;
        }
        // Entries right of the pivot at other pivots: subtract those rows (already reduced,
        // so they add entries only at free columns, which need no further scan).
        for col in p + 1..=hi {
            let x = acc[col];
            if x != 0 {
                if let Some(r) = &done[col] {
                    for &(c, y) in &r[1..] {
                        acc[c] = modp::sub(acc[c], modp::mul(x, y));
                    }
                    end = end.max(r.last().map_or(col, |x| x.0));
                    acc[col] = 0;
                }
            }
        }
        let mut out = Vec::new();
        for (c, a) in acc.iter_mut().enumerate().take(end + 1).skip(p) {
            if *a != 0 {
                out.push((c, *a));
                *a = 0;
            }
        }
        done[p] = Some(out);
    }
    let rows = pivots.iter().filter_map(|&p| done[p].take()).collect();
    (rows, pivots)
}

/// Exact check that every row is the combination of basis rows given by its pivot entries.
fn verify<R: Borrow<Coef>, Row: AsRef<[(usize, R)]>>(
    rows: &[Row],
    basis: &[SparseRow],
    pivots: &[usize],
) -> bool {
    let pivot_index: FxHashMap<usize, usize> =
        pivots.iter().enumerate().map(|(k, &c)| (c, k)).collect();
    for r in rows {
        let mut comb: FxHashMap<usize, Coef> = FxHashMap::default();
        let r = r.as_ref();
        for (c, v) in r {
            let v = v.borrow();
            if let Some(&k) = pivot_index.get(c) {
                for (bc, bv) in &basis[k] {
                    let add = if bv.is_one() { v.clone() } else { v * bv };
                    *comb.entry(*bc).or_insert(Coef::ZERO) += &add;
                }
            }
        }
        comb.retain(|_, v| !v.is_zero());
        if comb.len() != r.len() {
            return false;
        }
        for (c, v) in r {
            if comb.get(c) != Some(v.borrow()) {
                return false;
            }
        }
    }
    true
}

/// Exact rational reduced echelon form (fallback; slow on large inputs): rows are inserted
/// into an echelon basis, which is then swept column by column into the canonical form
/// (leftmost pivots), the same form the modular path produces.
fn exact_basis<R: Borrow<Coef>, Row: AsRef<[(usize, R)]>>(
    rows: &[Row],
    ncols: usize,
) -> (Vec<SparseRow>, Vec<usize>) {
    let mut ech: Vec<Vec<Coef>> = Vec::new();
    let mut pivots: Vec<usize> = Vec::new();
    for r in rows {
        let mut v = vec![Coef::ZERO; ncols];
        for (c, x) in r.as_ref() {
            v[*c] = x.borrow().clone();
        }
        for (row, &p) in ech.iter().zip(&pivots) {
            if !v[p].is_zero() {
                let f = v[p].clone();
                for (x, y) in v.iter_mut().zip(row) {
                    if !y.is_zero() {
                        *x = &*x - &(&f * y);
                    }
                }
            }
        }
        if let Some(p) = v.iter().position(|x| !x.is_zero()) {
            let Some(inv) = v[p].recip() else { continue };
            for x in &mut v {
                *x = &*x * &inv;
            }
            ech.push(v);
            pivots.push(p);
        }
    }
    // Canonical sweep.
    let mut r = 0;
    let mut piv = Vec::new();
    for col in 0..ncols {
        let Some(sel) = (r..ech.len()).find(|&i| !ech[i][col].is_zero()) else {
            continue;
        };
        ech.swap(r, sel);
        let Some(inv) = ech[r][col].recip() else {
            continue;
        };
        for x in &mut ech[r] {
            *x = &*x * &inv;
        }
        let pivot_row = ech[r].clone();
        for (i, row) in ech.iter_mut().enumerate() {
            if i != r && !row[col].is_zero() {
                let f = row[col].clone();
                for (x, y) in row.iter_mut().zip(&pivot_row) {
                    if !y.is_zero() {
                        *x = &*x - &(&f * y);
                    }
                }
            }
        }
        piv.push(col);
        r += 1;
        if r == ech.len() {
            break;
        }
    }
    let basis = ech
        .iter()
        .map(|row| {
            row.iter()
                .enumerate()
                .filter(|(_, x)| !x.is_zero())
                .map(|(c, x)| (c, x.clone()))
                .collect()
        })
        .collect();
    (basis, piv)
}

#[cfg(test)]
mod tests {
    use super::*;
    fn q(n: i64, d: i64) -> Coef {
        Coef::ratio(n, d)
    }

    /// Rows keyed by fingerprint are the rows keyed by monomial: with every fingerprint equal
    /// (each row but the first a collision, all through the spill table) the split is the
    /// same as with the real one.
    #[test]
    fn fingerprint_collisions_split_as_distinct_rows() {
        let spec = crate::symbolic::testutil::repo_spec("tests/specs/plane_spatial.yaml");
        let ex = crate::symbolic::expand::expand_with(&spec, 500_000).expect("expansion");
        let hs: Vec<Poly> = ex.equations.iter().map(|e| e.poly.clone()).collect();
        let jv = ex.vars.joint_vars;
        let real = split_terms(hs.clone(), jv);
        let colliding = split_terms_by(hs, jv, |_| 7);
        assert!(real.0.len() > 10, "rows: {}", real.0.len());
        assert_eq!(real.0, colliding.0);
        assert_eq!(real.1, colliding.1);
        assert_eq!(real.2, colliding.2);
    }

    #[test]
    fn modular_and_exact_paths_agree_and_are_canonical() {
        // Row space spanned by (0,1,1,0), (1,0,0,2) and their sum, plus a dependent row with
        // awkward rationals.
        let rows: Vec<SparseRow> = vec![
            vec![(1, q(1, 1)), (2, q(1, 1))],
            vec![(0, q(3, 7)), (3, q(6, 7))],
            vec![(0, q(1, 1)), (1, q(1, 1)), (2, q(1, 1)), (3, q(2, 1))],
            vec![(1, q(-5, 3)), (2, q(-5, 3))],
        ];
        let (mb, mp) = modular_basis(&rows, 4).expect("modular path succeeds");
        let (eb, ep) = exact_basis(&rows, 4);
        assert_eq!(mp, vec![0, 1]);
        assert_eq!(mp, ep);
        assert_eq!(mb, eb);
        assert_eq!(eb[0], vec![(0, q(1, 1)), (3, q(2, 1))]);
        assert!(verify(&rows, &eb, &ep));
    }

    #[test]
    fn sparse_modular_path_matches_exact_elimination() {
        let mut rng = modp::Rng::new(5);
        for trial in 0..30 {
            let ncols = 2 + trial % 9;
            let rank = 1 + trial % ncols.min(5);
            // Rows: small rational combinations of `rank` sparse generators.
            let gens: Vec<Vec<i64>> = (0..rank)
                .map(|_| {
                    (0..ncols)
                        .map(|_| match rng.next_u64() % 4 {
                            0 | 1 => 0,
                            _ => (rng.next_u64() % 7) as i64 - 3,
                        })
                        .collect()
                })
                .collect();
            let rows: Vec<SparseRow> = (0..6)
                .map(|_| {
                    let w: Vec<i64> = gens
                        .iter()
                        .map(|_| (rng.next_u64() % 5) as i64 - 2)
                        .collect();
                    let d = 1 + (rng.next_u64() % 4) as i64;
                    (0..ncols)
                        .filter_map(|c| {
                            let x: i64 = gens.iter().zip(&w).map(|(g, w)| g[c] * w).sum();
                            (x != 0).then(|| (c, q(x, d)))
                        })
                        .collect()
                })
                .collect();
            let (eb, ep) = exact_basis(&rows, ncols);
            let (mb, mp) = modular_basis(&rows, ncols).expect("small rationals reconstruct");
            assert_eq!((mb, mp), (eb, ep));
        }
        // Full rank: the unit vectors, without a sweep.
        let rows: Vec<SparseRow> = vec![
            vec![(0, q(1, 1)), (1, q(2, 3))],
            vec![(1, q(-1, 5))],
            vec![(0, q(7, 1)), (2, q(1, 1))],
        ];
        let (mb, mp) = modular_basis(&rows, 3).expect("full rank");
        assert_eq!((mb, mp), exact_basis(&rows, 3));
    }

    /// Rows of one term each (the shortcut of `echelon_basis`): the same basis and pivots as
    /// the elimination gives, whatever the coefficients and however often a column recurs.
    #[test]
    fn one_term_rows_give_the_eliminations_basis() {
        let mut rng = modp::Rng::new(17);
        for ncols in [1, 2, 5, 9] {
            let nrows = ncols + (rng.next_u64() % 7) as usize;
            // Every column at least once, then random ones; random nonzero coefficients.
            let entries: Vec<Entry> = (0..nrows)
                .map(|r| {
                    let col = if r < ncols {
                        r
                    } else {
                        (rng.next_u64() % ncols as u64) as usize
                    };
                    let n = (rng.next_u64() % 9) as i64 + 1;
                    (r as u32, col as u32, q(n, 1 + (rng.next_u64() % 4) as i64))
                })
                .collect();
            let rows: Vec<SparseRow> = entries
                .iter()
                .map(|e| vec![(e.1 as usize, e.2.clone())])
                .collect();
            let want = exact_basis(&rows, ncols);
            assert_eq!(
                echelon_basis(&entries, nrows, ncols),
                want,
                "{ncols} columns"
            );
        }
    }

    /// `K` from the one-term pass is the echelon form's wherever the pass gives one, it gives
    /// one exactly when every row of `E` has one term, and `K` is told once either way: on
    /// every test and shipped spec, and the bench's PUMA with measured tips.
    #[test]
    fn one_term_pass_gives_the_echelon_forms_k() {
        let mut paths =
            crate::symbolic::testutil::repo_spec_paths(&["tests/specs", "lincal-models/specs"]);
        paths.push("bench/specs/puma560_mdh_measured.yaml".into());
        let (mut one_term, mut multi_term) = (0, 0);
        for name in paths {
            let spec = crate::symbolic::testutil::repo_spec(&name);
            let Ok(ex) = crate::symbolic::expand::expand_with(&spec, 500_000) else {
                continue;
            };
            let hs: Vec<Poly> = ex.equations.iter().map(|e| e.poly.clone()).collect();
            let jv = ex.vars.joint_vars;
            let pass = one_term_rank(&hs, jv);
            let (rows, _, entries) = split_terms(hs.clone(), jv);
            assert_eq!(pass.is_some(), entries.len() == rows.len(), "{name}");
            let mut told = None;
            let reduction = reduce_with(hs, jv, |k| told = Some(k));
            assert_eq!(told, Some(reduction.basis.len()), "{name}");
            if let Some(k) = pass {
                assert_eq!(k, reduction.basis.len(), "{name}");
                one_term += 1;
            } else {
                multi_term += 1;
            }
        }
        assert!(
            one_term >= 2 && multi_term >= 3,
            "{one_term} / {multi_term}"
        );
    }

    #[test]
    fn verification_rejects_a_wrong_basis() {
        let rows: Vec<SparseRow> = vec![vec![(0, q(1, 1)), (1, q(1, 2))]];
        let wrong = vec![vec![(0, q(1, 1)), (1, q(1, 3))]];
        assert!(!verify(&rows, &wrong, &[0]));
    }
}
