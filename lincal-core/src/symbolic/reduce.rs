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
//! The echelon form is computed modulo a prime from random combinations of the rows, its
//! entries reconstructed as rationals, and the result verified exactly over ℚ: every row of
//! `E` must be the combination its pivot entries dictate. (Rank mod p ≤ rank over ℚ ≤ the
//! verified `K`, so the `K` reported is exact.) If reconstruction or verification fails, an
//! exact rational elimination runs instead.

use super::modp::{self, Echelon, Rng};
use super::monomial::Mono;
use super::poly::{display_order, Poly};
use num_rational::BigRational;
use num_traits::{One, Zero};
use rustc_hash::FxHashMap;

/// The column-reduced basis and the generalized parameters.
#[derive(Clone, Debug)]
pub struct Reduction {
    /// Distinct joint monomials of all equations, before reduction (`naive_size` of them),
    /// in pivot order.
    pub monomials: Vec<Mono>,
    /// Basis functions `Φ̃_k = Σ coef · monomial` (sparse, sorted by display order).
    pub basis: Vec<Vec<(Mono, BigRational)>>,
    /// Pivot monomial of each basis function.
    pub pivots: Vec<Mono>,
    /// `c[e][k]`: the generalized parameter of equation `e` on basis function `k`.
    pub c: Vec<Vec<Poly>>,
}

/// Splits `h` into `{joint monomial → parameter polynomial}`.
#[must_use]
pub fn by_joint_monomial(h: &Poly, joint_vars: usize) -> FxHashMap<Mono, Poly> {
    let mut out: FxHashMap<Mono, Poly> = FxHashMap::default();
    for (m, c) in &h.terms {
        let (jm, pm) = m.split(joint_vars);
        out.entry(jm).or_default().terms.insert(pm, c.clone());
    }
    out
}

/// Column-reduces the equations `hs` (polynomials whose first `joint_vars` variables are the
/// joint variables).
#[must_use]
pub fn reduce(hs: &[&Poly], joint_vars: usize) -> Reduction {
    // Rows of E: one per (equation, parameter monomial); sparse over joint monomials.
    let mut monos: Vec<Mono> = Vec::new();
    let mut col_of: FxHashMap<Mono, usize> = FxHashMap::default();
    let split: Vec<FxHashMap<Mono, Poly>> = hs
        .iter()
        .map(|h| by_joint_monomial(h, joint_vars))
        .collect();
    for s in &split {
        for jm in s.keys() {
            if !col_of.contains_key(jm) {
                col_of.insert(*jm, 0);
                monos.push(*jm);
            }
        }
    }
    monos.sort_by(display_order);
    for (i, m) in monos.iter().enumerate() {
        col_of.insert(*m, i);
    }
    let ncols = monos.len();
    let mut rows: FxHashMap<(usize, Mono), Vec<(usize, BigRational)>> = FxHashMap::default();
    for (e, s) in split.iter().enumerate() {
        for (jm, pp) in s {
            let col = col_of[jm];
            for (pm, c) in &pp.terms {
                rows.entry((e, *pm)).or_default().push((col, c.clone()));
            }
        }
    }
    let mut rows: Vec<Vec<(usize, BigRational)>> = rows.into_values().collect();
    for r in &mut rows {
        r.sort_by_key(|x| x.0);
    }
    rows.sort();

    let basis_rows = modular_basis(&rows, ncols).or_else(|| Some(exact_basis(&rows, ncols)));
    let (basis_dense, pivots) = basis_rows.unwrap_or_default();

    let basis: Vec<Vec<(Mono, BigRational)>> = basis_dense
        .iter()
        .map(|row| {
            let mut v: Vec<(Mono, BigRational)> = row
                .iter()
                .map(|(col, c)| (monos[*col], c.clone()))
                .collect();
            v.sort_by(|a, b| display_order(&a.0, &b.0));
            v
        })
        .collect();
    let pivot_monos: Vec<Mono> = pivots.iter().map(|&p| monos[p]).collect();
    let c = split
        .iter()
        .map(|s| {
            pivot_monos
                .iter()
                .map(|pm| s.get(pm).cloned().unwrap_or_default())
                .collect()
        })
        .collect();
    Reduction {
        monomials: monos,
        basis,
        pivots: pivot_monos,
        c,
    }
}

type SparseRow = Vec<(usize, BigRational)>;

/// Echelon basis modulo p from random row combinations, reconstructed and verified exactly.
fn modular_basis(rows: &[SparseRow], ncols: usize) -> Option<(Vec<SparseRow>, Vec<usize>)> {
    let rows_mod: Vec<Vec<(usize, u64)>> = rows
        .iter()
        .map(|r| {
            r.iter()
                .map(|(c, v)| modp::from_rational(v).map(|x| (*c, x)))
                .collect::<Option<Vec<_>>>()
        })
        .collect::<Option<Vec<_>>>()?;
    let mut rng = Rng::new(0x1a2b_3c4d);
    let mut ech = Echelon::default();
    let mut misses = 0;
    // A random combination lies in the span found so far with probability ≤ 1/p unless the
    // span is complete; several misses in a row make that certain enough, and the exact
    // verification below settles it.
    while misses < 4 && ech.rank() < ncols {
        let mut v = vec![0u64; ncols];
        for r in &rows_mod {
            let w = rng.element();
            for &(c, x) in r {
                v[c] = modp::add(v[c], modp::mul(w, x));
            }
        }
        if ech.insert(v) {
            misses = 0;
        } else {
            misses += 1;
        }
    }
    // The canonical echelon form: leftmost pivots, so basis functions come simplest first
    // and do not depend on the order rows were found in.
    let (rref_rows, rref_pivots) = modp::rref(ech.rows);
    let mut basis = Vec::with_capacity(rref_rows.len());
    for r in &rref_rows {
        let mut row = Vec::new();
        for (c, &x) in r.iter().enumerate() {
            if x != 0 {
                row.push((c, modp::reconstruct(x)?));
            }
        }
        basis.push(row);
    }
    let pivots = rref_pivots;
    verify(rows, &basis, &pivots).then_some((basis, pivots))
}

/// Exact check that every row is the combination of basis rows given by its pivot entries.
fn verify(rows: &[SparseRow], basis: &[SparseRow], pivots: &[usize]) -> bool {
    let pivot_index: FxHashMap<usize, usize> =
        pivots.iter().enumerate().map(|(k, &c)| (c, k)).collect();
    for r in rows {
        let mut comb: FxHashMap<usize, BigRational> = FxHashMap::default();
        for (c, v) in r {
            if let Some(&k) = pivot_index.get(c) {
                for (bc, bv) in &basis[k] {
                    *comb.entry(*bc).or_insert_with(BigRational::zero) += v * bv;
                }
            }
        }
        comb.retain(|_, v| !v.is_zero());
        if comb.len() != r.len() {
            return false;
        }
        for (c, v) in r {
            if comb.get(c) != Some(v) {
                return false;
            }
        }
    }
    true
}

/// Exact rational reduced echelon form (fallback; slow on large inputs): rows are inserted
/// into an echelon basis, which is then swept column by column into the canonical form
/// (leftmost pivots), the same form the modular path produces.
fn exact_basis(rows: &[SparseRow], ncols: usize) -> (Vec<SparseRow>, Vec<usize>) {
    let mut ech: Vec<Vec<BigRational>> = Vec::new();
    let mut pivots: Vec<usize> = Vec::new();
    for r in rows {
        let mut v = vec![BigRational::zero(); ncols];
        for (c, x) in r {
            v[*c] = x.clone();
        }
        for (row, &p) in ech.iter().zip(&pivots) {
            if !v[p].is_zero() {
                let f = v[p].clone();
                for (x, y) in v.iter_mut().zip(row) {
                    if !y.is_zero() {
                        *x -= &f * y;
                    }
                }
            }
        }
        if let Some(p) = v.iter().position(|x| !x.is_zero()) {
            let inv = BigRational::one() / v[p].clone();
            for x in &mut v {
                *x *= &inv;
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
        let inv = BigRational::one() / ech[r][col].clone();
        for x in &mut ech[r] {
            *x *= &inv;
        }
        let pivot_row = ech[r].clone();
        for (i, row) in ech.iter_mut().enumerate() {
            if i != r && !row[col].is_zero() {
                let f = row[col].clone();
                for (x, y) in row.iter_mut().zip(&pivot_row) {
                    if !y.is_zero() {
                        *x -= &f * y;
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
    use num_bigint::BigInt;

    fn q(n: i64, d: i64) -> BigRational {
        BigRational::new(BigInt::from(n), BigInt::from(d))
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
    fn verification_rejects_a_wrong_basis() {
        let rows: Vec<SparseRow> = vec![vec![(0, q(1, 1)), (1, q(1, 2))]];
        let wrong = vec![vec![(0, q(1, 1)), (1, q(1, 3))]];
        assert!(!verify(&rows, &wrong, &[0]));
    }
}
