//! The support of `E`: the grid monomials that can arise in an equation at all, an upper
//! bound on the basis that the certificate's covered monomials (a lower bound) must meet
//! ([`super`], *Part of the grid*).

use super::{Group, Step, VarTable};
use crate::symbolic::monomial::Mono;
use crate::symbolic::poly::Poly;

/// The most term products one step of the exact prefix may spend (a few milliseconds).
const EXACT_PRODUCTS: usize = 100_000;

/// The most steps the exact prefix goes through: the base's and the first joint's (or the
/// first two joints'). A path cancels where the constraint is invariant under a motion: a
/// cylinder or a sphere about the first joint's axis is left alone by its turn. A later
/// joint's axis moves with the earlier joints, unless parallel to them, and parallel axes
/// make sums of products that no certificate claims. Going further measured no claim more
/// on the repository's specs and the random chains of the tests, and cost up to 10 ms where
/// the certificate then claimed nothing (a UR5 with three parallel axes).
const EXACT_STEPS: usize = 2;

/// Whether the grid monomials (flat index, the last joint fastest) that can hold a nonzero
/// coefficient in some equation are exactly `covered`. `φ_1 ⋯ φ_n` can arise only where a
/// path of nonzero entries `u_e[j_0] · M_base[j_0, j_1] · M_{1,φ_1}[j_1, j_2] ⋯ τ[j_{n+1}]`
/// joins a functional to a tool state. The coefficient is the sum over such paths, so the
/// columns of `E` lie within this set. Where the paths cancel (a cylinder's `x₁² + x₂²` that
/// the first joint's turn about the same axis leaves alone), the set holds more; so the
/// functionals are carried exactly through the first steps (at most [`EXACT_STEPS`]), one
/// step more each time the set still differs from `covered` (while each step's products stay
/// within [`EXACT_PRODUCTS`]; a group that cannot go further stays where it is), and the
/// paths start from the monomials they hold. Where no paths cancel, no exact
/// step is paid for. `None` where a product cannot be formed.
pub(super) fn support_is(
    steps: &[Step],
    groups: &[Group],
    vars: &VarTable,
    covered: &[bool],
) -> Option<bool> {
    let mut exact: Vec<(Vec<Vec<Poly>>, usize)> =
        groups.iter().map(|g| (g.exact.clone(), 0)).collect();
    let mut stuck = vec![false; groups.len()];
    loop {
        if support(steps, groups, &exact, vars, covered.len())? == covered {
            return Some(true);
        }
        let mut deeper = false;
        for ((e, k), stuck) in exact.iter_mut().zip(&mut stuck).filter(|(_, s)| !**s) {
            match exact_step(e, steps, *k, vars) {
                Some(next) => {
                    *e = next;
                    *k += 1;
                    deeper = true;
                }
                None => *stuck = true,
            }
        }
        if !deeper {
            return Some(false);
        }
    }
}

/// The support (see [`support_is`]) with each group's functionals carried exactly through
/// its first `k` steps, the base's first where there is one (`exact[g] = (u_eᵀ M_base M_1 ⋯
/// M_{k−1}, k)`).
fn support(
    steps: &[Step],
    groups: &[Group],
    exact: &[(Vec<Vec<Poly>>, usize)],
    vars: &VarTable,
    total: usize,
) -> Option<Vec<bool>> {
    let mut out = vec![false; total];
    for (g, (exact, k)) in groups.iter().zip(exact) {
        let mut reach = reach_of(exact, &steps[..*k], vars)?;
        for st in &steps[*k..] {
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

/// `exact` (carried through `steps[..k]`) carried through `steps[k]` too; `None` where there
/// is no step `k` (or `k` is [`EXACT_STEPS`]), a product cannot be formed, or the step would
/// pass [`EXACT_PRODUCTS`].
fn exact_step(
    exact: &[Vec<Poly>],
    steps: &[Step],
    k: usize,
    vars: &VarTable,
) -> Option<Vec<Vec<Poly>>> {
    let st = steps.get(k).filter(|_| k < EXACT_STEPS)?;
    let cost: usize = exact
        .iter()
        .flat_map(|f| f.iter().zip(&st.m))
        .map(|(fi, row)| fi.len() * row.iter().map(Poly::len).sum::<usize>())
        .sum();
    if cost > EXACT_PRODUCTS {
        return None;
    }
    let pairs = vars.trig_pairs.as_slice();
    exact
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
        .collect()
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
