//! The support of `E`: the grid monomials that can arise in an equation at all, an upper
//! bound on the basis that the certificate's covered monomials (a lower bound) must meet
//! ([`super`], *Part of the grid*).

use super::{Group, Step, VarTable};
use crate::symbolic::monomial::Mono;
use crate::symbolic::poly::Poly;

/// The most term products one step of the exact prefix may spend (a few milliseconds).
const EXACT_PRODUCTS: usize = 100_000;

/// The most prefixes of joint monomials the exact prefix may reach (its index is a table of
/// them; cancellations come from the first links, next to the equation).
const EXACT_PREFIXES: usize = 4096;

/// The grid monomials (flat index, the last joint fastest) that can hold a nonzero
/// coefficient in some equation: `φ_1 ⋯ φ_n` only where a path of nonzero entries
/// `u_e[j_0] · M_base[j_0, j_1] · M_{1,φ_1}[j_1, j_2] ⋯ τ[j_{n+1}]` joins a functional to a
/// tool state. The coefficient is the sum over such paths, so the columns of `E` lie within
/// this set. Where the paths cancel (a cylinder's `x₁² + x₂²` that the first joint's turn about
/// the same axis leaves alone), the set holds more; so the functionals are carried exactly
/// through the first steps while each step's products stay within [`EXACT_PRODUCTS`] (and the
/// prefixes within [`EXACT_PREFIXES`]), and the paths
/// start from the monomials they hold. `None` where a product cannot be formed.
pub(super) fn support(
    steps: &[Step],
    groups: &[Group],
    vars: &VarTable,
    total: usize,
) -> Option<Vec<bool>> {
    let mut out = vec![false; total];
    for g in groups {
        let (exact, k) = exact_prefix(&g.exact, steps, vars);
        let mut reach = reach_of(&exact, &steps[..k], vars)?;
        for st in &steps[k..] {
            let n = st.phis.len();
            let mut next = vec![0u16; reach.len() * n];
            for (idx, &m) in reach.iter().enumerate().filter(|(_, &m)| m != 0) {
                let rows = st.reach.iter().enumerate().filter(|(i, _)| m & 1 << i != 0);
                for (_, row) in rows {
                    for (o, &r) in next[idx * n..(idx + 1) * n].iter_mut().zip(row) {
                        *o |= r;
                    }
                }
            }
            reach = next;
        }
        for (o, &m) in out.iter_mut().zip(&reach) {
            *o |= m & g.to != 0;
        }
    }
    Some(out)
}

/// `u_eᵀ M_base M_1 ⋯ M_k` exact (one polynomial a state coordinate, each equation), through
/// as many steps `k` as [`EXACT_PRODUCTS`] a step and [`EXACT_PREFIXES`] allow (none where a
/// product cannot be formed).
fn exact_prefix(
    functionals: &[Vec<Poly>],
    steps: &[Step],
    vars: &VarTable,
) -> (Vec<Vec<Poly>>, usize) {
    let pairs = vars.trig_pairs.as_slice();
    let mut exact = functionals.to_vec();
    let mut prefixes = 1usize;
    for (k, st) in steps.iter().enumerate() {
        prefixes = prefixes.saturating_mul(st.phis.len());
        if prefixes > EXACT_PREFIXES {
            return (exact, k);
        }
        let cost: usize = exact
            .iter()
            .flat_map(|f| f.iter().zip(&st.m))
            .map(|(fi, row)| fi.len() * row.iter().map(Poly::len).sum::<usize>())
            .sum();
        if cost > EXACT_PRODUCTS {
            return (exact, k);
        }
        let next: Option<Vec<Vec<Poly>>> = exact
            .iter()
            .map(|f| {
                let mut g = vec![Poly::zero(); f.len()];
                for (fi, row) in f.iter().zip(&st.m) {
                    for (o, mij) in g.iter_mut().zip(row) {
                        o.add_assign(&fi.mul(mij, pairs).ok()?);
                    }
                }
                Some(g)
            })
            .collect();
        match next {
            Some(n) => exact = n,
            None => return (exact, k),
        }
    }
    (exact, steps.len())
}

/// The state coordinates (bits) each prefix of joint monomials of `steps` (flat index, the
/// last joint fastest) reaches with a nonzero exact coefficient in `exact`.
fn reach_of(exact: &[Vec<Poly>], steps: &[Step], vars: &VarTable) -> Option<Vec<u16>> {
    let prefixes = super::products(steps)?;
    let index: rustc_hash::FxHashMap<Mono, usize> =
        prefixes.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let mut reach = vec![0u16; prefixes.len()];
    for f in exact {
        for (j, p) in f.iter().enumerate() {
            for mono in p.terms.keys() {
                reach[*index.get(&mono.split(vars.joint_vars).0)?] |= 1 << j;
            }
        }
    }
    Some(reach)
}
