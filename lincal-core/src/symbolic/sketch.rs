//! `K` without the exact expansion: the same expansion carried out on a homomorphic image of
//! the polynomials, with fixed-size keys and coefficients modulo the prime `P = 2⁶¹ − 1`.
//!
//! The exact engine writes every constraint function as `h_e(q; p) = Σ κ · μ(p) · m(q)`, with
//! `m` a joint monomial and `μ` a parameter monomial, both in canonical trigonometric form
//! (each sine to the power 0 or 1). The matrix `E` has a row per `(e, μ)` and a column per
//! `m`, and `K = rank E`. When every row of `E` has a single term, each row is a unit vector
//! and every column holds one, so `K` is the number of distinct joint monomials
//! ([`super::reduce`]'s one-term pass). Neither needs `κ` exactly, nor `μ` written out: only
//! which terms are there and which rows they fall in.
//!
//! So a term is kept here as
//! - `m`, packed (4 bits a joint variable, at most 16 of them: an 8-joint arm);
//! - `μ` as the set of its sines (a bit per angle pair, at most 64) and `Σ_v e_v · w_v mod P`
//!   over the exponents `e_v` of its other variables, with weights `w_v` drawn once from a
//!   fixed seed: products add these, and `sin² = 1 − cos²` on a pair met twice clears its bit
//!   and adds `2 · w_cos`, exactly as the exact product rewrites the monomial;
//! - `κ mod P`.
//!
//! A monomial's image (its joint part, its sines, its weighted sum) multiplies as the monomial
//! does, with the same rewriting of `sin²`, so the map is a ring homomorphism: the sketch of
//! each `h_e` is the image of the exact `h_e`, whatever happened to intermediate terms. Its
//! terms, rows and columns are then the exact ones unless (a) two distinct terms of one `h_e`
//! share their parameter monomials' weighted sums (probability `1/P` a pair over the weights:
//! exponent vectors differ by small integers), or (b) a nonzero coefficient is a multiple of
//! `P` (a numerator beyond `2⁶¹`; none of the specs met has one). Either can only lose a term
//! (a lower `K`) or make a row look like two terms (then no `K` from here). With `T_e` terms
//! in `h_e`, the sketch's `K` is wrong with probability at most `Σ_e T_e² / 2P`: below
//! `10⁻¹⁰` for the bench's PUMA (3 equations of 11 832 terms), `2.2·10⁻⁹` at the build ahead's
//! bound of 100 000 terms in all ([`super::model::REPORT_MAX_TERMS`]). Terms merged the same
//! way in an intermediate product can also hide that the exact expansion passes a size bound
//! (a `K` where the exact build would refuse the spec), with a probability of the same order.
//! When the rows are not all one term, the sketch gives nothing and the exact reduction
//! decides.

use super::chain_poly::ChainPoly;
use super::expand::{equations, pieces};
use super::modp::{self, RationalMod, Rng};
use super::monomial::VarTable;
use super::poly::{Poly, ProductError};
use crate::spec::Spec;
use rustc_hash::{FxHashMap, FxHashSet};

/// The seed of the weights.
const WEIGHTS_SEED: u64 = 0x5ce7_c4ba_5150_0001;

/// A term's image: its joint monomial packed, its parameter monomial's sines and weighted
/// exponent sum (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
struct Key {
    joint: u64,
    sines: u64,
    rest: u64,
}

/// Where each variable goes in a [`Key`], and what the `sin²` rewriting needs.
#[derive(Debug)]
pub(super) struct Layout {
    /// Per joint `(cos, sin)` pair: the bit shifts of their exponents in [`Key::joint`].
    joint_pairs: Vec<(u32, u32)>,
    /// The bits of [`Key::joint`] set when a joint sine's exponent is 2 or more.
    joint_sine_twice: u64,
    /// Per bit of [`Key::sines`]: the weight of its pair's cosine.
    cos_weight: Vec<u64>,
    /// Number of joint variables (packed in the low bits of [`Key::joint`]).
    joint_vars: usize,
    /// Per variable from `joint_vars` on: its sine bit, or its weight.
    roles: Vec<Role>,
    /// Per variable from `joint_vars` on: its slot in [`Sketch::degrees`] (a pair's two
    /// variables share one).
    slots: Vec<usize>,
    /// The largest degree bound any product has had (saturating): a product past 15 makes
    /// the exact build fail even when its result feeds no equation (a planar tip's third
    /// coordinate).
    max_degree: std::sync::atomic::AtomicU8,
}

/// How a non-joint variable enters a [`Key`].
#[derive(Clone, Copy, Debug)]
enum Role {
    Sine(u32),
    Weight(u64),
}

impl Layout {
    /// The layout of `vars`, or `None` when it does not fit a key (more than 16 joint
    /// variables or more than 64 non-joint angle pairs).
    fn new(vars: &VarTable) -> Option<Layout> {
        let jv = vars.joint_vars;
        if jv > 16 {
            return None;
        }
        let mut rng = Rng::new(WEIGHTS_SEED);
        let mut roles: Vec<Role> = (jv..vars.vars.len())
            .map(|_| Role::Weight(rng.element()))
            .collect();
        let mut slots: Vec<usize> = (0..roles.len()).collect();
        let (mut joint_pairs, mut cos_weight) = (Vec::new(), Vec::new());
        for &(cv, sv) in &vars.trig_pairs {
            if sv < jv {
                joint_pairs.push((4 * cv as u32, 4 * sv as u32));
            } else {
                let bit = u32::try_from(cos_weight.len()).ok().filter(|&b| b < 64)?;
                let Role::Weight(w) = roles[cv - jv] else {
                    return None;
                };
                cos_weight.push(w);
                roles[sv - jv] = Role::Sine(bit);
                slots[sv - jv] = slots[cv - jv];
            }
        }
        let joint_sine_twice = joint_pairs
            .iter()
            .fold(0, |acc, &(_, ss)| acc | (0xE << ss));
        Some(Layout {
            joint_pairs,
            joint_sine_twice,
            cos_weight,
            joint_vars: jv,
            roles,
            slots,
            max_degree: std::sync::atomic::AtomicU8::new(0),
        })
    }
}

/// Per slot, the larger of two degree bounds (a missing slot is 0).
fn max_degrees(a: &[u8], b: &[u8]) -> Vec<u8> {
    let at = |v: &[u8], i: usize| v.get(i).copied().unwrap_or(0);
    (0..a.len().max(b.len()))
        .map(|i| at(a, i).max(at(b, i)))
        .collect()
}

/// Per slot, the sum of two degree bounds: a product's (saturating: past 15 is all
/// [`basis_size`] asks).
fn sum_degrees(a: &[u8], b: &[u8]) -> Vec<u8> {
    let at = |v: &[u8], i: usize| v.get(i).copied().unwrap_or(0);
    (0..a.len().max(b.len()))
        .map(|i| at(a, i).saturating_add(at(b, i)))
        .collect()
}

impl Layout {
    /// [`sum_degrees`], the result's largest bound kept in [`Layout::max_degree`].
    fn product_degrees(&self, a: &[u8], b: &[u8]) -> Vec<u8> {
        let d = sum_degrees(a, b);
        let top = d.iter().copied().max().unwrap_or(0);
        self.max_degree
            .fetch_max(top, std::sync::atomic::Ordering::Relaxed);
        d
    }
}

/// A polynomial's image (see the [module docs](self)); no zero coefficients.
///
/// The image forgets the parameter variables' exponents, which the exact engine bounds by 15
/// ([`ProductError`]); so that the sketch never gives `K` for a spec whose exact expansion
/// fails, each polynomial carries an upper bound on each parameter variable's (a pair's: the
/// cosine's and sine's together) exponent over its terms, summed by products and maxed by
/// sums, and a product whose bound passes 15 anywhere in the expansion gives no `K`
/// (sometimes where the exact build would succeed: it then decides).
#[derive(Clone, Debug, Default)]
pub(super) struct Sketch {
    terms: FxHashMap<Key, u64>,
    /// Per slot of [`Layout`] (missing: 0), the bound on the exponents.
    degrees: Vec<u8>,
}

impl Sketch {
    /// The image of the exact `p`; `None` when a coefficient has none (its denominator a
    /// multiple of `P`) or a monomial is not in canonical form.
    fn of(p: &Poly, layout: &Layout, rm: &mut RationalMod) -> Option<Sketch> {
        let jv = layout.joint_vars;
        let joint_mask = if jv == 16 {
            u64::MAX
        } else {
            (1u64 << (4 * jv)) - 1
        };
        let mut s = Sketch::default();
        s.terms.reserve(p.len());
        s.degrees = vec![0; layout.roles.len()];
        let mut degrees = vec![0u8; layout.roles.len()];
        for (m, c) in &p.terms {
            let mut key = Key {
                joint: m.words()[0] & joint_mask,
                ..Key::default()
            };
            degrees.fill(0);
            for (k, role) in layout.roles.iter().enumerate() {
                let e = m.get(jv + k);
                if e == 0 {
                    continue;
                }
                degrees[layout.slots[k]] += e as u8;
                match *role {
                    Role::Sine(bit) if e == 1 => key.sines |= 1 << bit,
                    Role::Sine(_) => return None,
                    Role::Weight(w) => {
                        key.rest = modp::add(key.rest, modp::mul(w, u64::from(e)));
                    }
                }
            }
            let c = rm.get(c).filter(|&c| c != 0)?;
            s.add_term(key, c);
            s.degrees = max_degrees(&s.degrees, &degrees);
        }
        Some(s)
    }

    fn add_term(&mut self, k: Key, c: u64) {
        if c == 0 {
            return;
        }
        match self.terms.entry(k) {
            std::collections::hash_map::Entry::Occupied(mut e) => {
                let v = modp::add(*e.get(), c);
                if v == 0 {
                    e.remove();
                } else {
                    *e.get_mut() = v;
                }
            }
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(c);
            }
        }
    }

    /// Adds `c · a · b` (reduced) for the terms `a`, `b`.
    fn add_term_product(
        &mut self,
        a: &Key,
        b: &Key,
        c: u64,
        layout: &Layout,
    ) -> Result<(), ProductError> {
        let joint = add_exponents(a.joint, b.joint)?;
        let key = Key {
            joint,
            sines: a.sines ^ b.sines,
            rest: modp::add(a.rest, b.rest),
        };
        let twice = a.sines & b.sines;
        if twice == 0 && joint & layout.joint_sine_twice == 0 {
            // No sine met twice (factors in disjoint variables, the bulk of the chain).
            self.add_term(key, c);
            return Ok(());
        }
        self.add_reduced(key, c, twice, layout)
    }

    /// Adds `c · key · Π_{pairs in twice} sin²`, rewriting `sin² = 1 − cos²` for the
    /// parameter pairs in `twice` and for every joint pair.
    fn add_reduced(
        &mut self,
        key: Key,
        c: u64,
        twice: u64,
        layout: &Layout,
    ) -> Result<(), ProductError> {
        if twice != 0 {
            let bit = twice.trailing_zeros() as usize;
            let others = twice & (twice - 1);
            let w = layout.cos_weight[bit];
            self.add_reduced(key, c, others, layout)?;
            let key2 = Key {
                rest: modp::add(key.rest, modp::add(w, w)),
                ..key
            };
            return self.add_reduced(key2, modp::neg(c), others, layout);
        }
        for &(cs, ss) in &layout.joint_pairs {
            if (key.joint >> ss) & 0xF >= 2 {
                let j1 = key.joint - (2 << ss);
                if (j1 >> cs) & 0xF > 13 {
                    return Err(ProductError::Degree);
                }
                self.add_reduced(Key { joint: j1, ..key }, c, 0, layout)?;
                let j2 = j1 + (2 << cs);
                return self.add_reduced(Key { joint: j2, ..key }, modp::neg(c), 0, layout);
            }
        }
        self.add_term(key, c);
        Ok(())
    }
}

/// `a + b` of two packed exponent words, or [`ProductError`] when an exponent passes 15.
fn add_exponents(a: u64, b: u64) -> Result<u64, ProductError> {
    let s = a.wrapping_add(b);
    // A carry into a nibble's lowest bit, or out of the word, is an exponent beyond 15.
    if (a ^ b ^ s) & 0x1111_1111_1111_1110 != 0 || s < a {
        return Err(ProductError::Degree);
    }
    Ok(s)
}

impl ChainPoly for Sketch {
    type Ctx = Layout;

    fn int(i: i64) -> Self {
        let mut s = Sketch::default();
        s.add_term(Key::default(), modp::from_i64(i));
        s
    }
    fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }
    fn len(&self) -> usize {
        self.terms.len()
    }
    fn reserve(&mut self, n: usize) {
        // `n` is a bound (products before like terms merge), not the size: a table that
        // large may not fit where the merged result does, and a failed reservation costs
        // nothing but the growth steps.
        let _ = self.terms.try_reserve(n);
    }
    fn add(&self, o: &Self) -> Self {
        let mut r = self.clone();
        r.add_assign(o);
        r
    }
    fn add_assign(&mut self, o: &Self) {
        self.terms.reserve(o.len());
        for (k, c) in &o.terms {
            self.add_term(*k, *c);
        }
        self.degrees = max_degrees(&self.degrees, &o.degrees);
    }
    fn sub(&self, o: &Self) -> Self {
        let mut r = self.clone();
        for (k, c) in &o.terms {
            r.add_term(*k, modp::neg(*c));
        }
        r.degrees = max_degrees(&r.degrees, &o.degrees);
        r
    }
    fn neg(&self) -> Self {
        self.scale_int(-1)
    }
    fn scale_int(&self, k: i64) -> Self {
        let k = modp::from_i64(k);
        let mut r = Sketch {
            degrees: self.degrees.clone(),
            ..Sketch::default()
        };
        r.terms.reserve(self.len());
        for (key, c) in &self.terms {
            r.add_term(*key, modp::mul(*c, k));
        }
        r
    }
    fn mul(&self, o: &Self, ctx: &Layout) -> Result<Self, ProductError> {
        let mut r = Sketch::default();
        r.terms.reserve(self.len() * o.len());
        r.add_product(self, o, ctx)?;
        Ok(r)
    }
    fn square(&self, ctx: &Layout) -> Result<Self, ProductError> {
        let t: Vec<(&Key, &u64)> = self.terms.iter().collect();
        let mut r = Sketch {
            degrees: ctx.product_degrees(&self.degrees, &self.degrees),
            ..Sketch::default()
        };
        r.terms.reserve(t.len() * (t.len() + 1) / 2);
        for (i, (k1, c1)) in t.iter().enumerate() {
            r.add_term_product(k1, k1, modp::mul(**c1, **c1), ctx)?;
            let twice = modp::add(**c1, **c1);
            for (k2, c2) in &t[i + 1..] {
                r.add_term_product(k1, k2, modp::mul(twice, **c2), ctx)?;
            }
        }
        Ok(r)
    }
    fn add_product(&mut self, a: &Self, b: &Self, ctx: &Layout) -> Result<(), ProductError> {
        // No reserve here: the caller sizes the table once for all its products.
        self.degrees = max_degrees(&self.degrees, &ctx.product_degrees(&a.degrees, &b.degrees));
        for (k1, c1) in &a.terms {
            for (k2, c2) in &b.terms {
                self.add_term_product(k1, k2, modp::mul(*c1, *c2), ctx)?;
            }
        }
        Ok(())
    }
}

/// `K` as the reduction found it, with the expansion's size (which decides whether a report
/// gives it: [`super::model::REPORT_MAX_TERMS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct KnownBasisSize {
    /// The basis size.
    pub k: usize,
    /// Terms of all constraint polynomials before the reduction (0 for a basis of grid
    /// monomials proven without them, [`super::coverage`]).
    pub terms: usize,
}

/// What the sketch tells of `K`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Sketched {
    /// `K` and the constraint polynomials' term count (every row of `E` one term).
    Known(KnownBasisSize),
    /// The exact expansion fails for certain: it would pass `max_terms` a polynomial or
    /// `max_total` in all (a sketch has at most the exact terms, so a bound it passes the
    /// exact expansion passes too), or a joint's exponent past 15 (packed exactly here).
    Beyond,
    /// Nothing certain: the exact build decides.
    Unknown,
}

/// `K` from the sketch when every row of `E` has one term (see the [module docs](self));
/// [`Sketched::Beyond`] when the exact expansion would fail its bounds; otherwise (rows of
/// several terms, a spec beyond the sketch's layout, a coefficient without an image, a
/// parameter's degree bound past 15) [`Sketched::Unknown`].
pub(super) fn basis_size(spec: &Spec, max_terms: usize, max_total: Option<usize>) -> Sketched {
    let Ok((vars, _, exact)) = pieces(spec) else {
        return Sketched::Unknown;
    };
    let Some(layout) = Layout::new(&vars) else {
        return Sketched::Unknown;
    };
    let mut rm = RationalMod::default();
    let mut image = |p: &Poly| Sketch::of(p, &layout, &mut rm);
    let Some(sketched) = exact.try_map(&mut image) else {
        return Sketched::Unknown;
    };
    let Ok(hs) = equations(spec, sketched, &layout, max_terms, max_total) else {
        return Sketched::Beyond;
    };
    if layout.max_degree.load(std::sync::atomic::Ordering::Relaxed) > 15 {
        return Sketched::Unknown;
    }
    let terms: usize = hs.iter().map(|(_, h)| h.len()).sum();
    match one_term_rank(&hs) {
        Some(k) => Sketched::Known(KnownBasisSize { k, terms }),
        None => Sketched::Unknown,
    }
}

/// The number of distinct joint monomials when every `(equation, parameter monomial)` row
/// has one term, else `None`.
fn one_term_rank(hs: &[(usize, Sketch)]) -> Option<usize> {
    let mut rows: FxHashSet<(usize, u64, u64)> = FxHashSet::default();
    let mut cols: FxHashSet<u64> = FxHashSet::default();
    for (e, (_, h)) in hs.iter().enumerate() {
        for k in h.terms.keys() {
            if !rows.insert((e, k.sines, k.rest)) {
                return None;
            }
            cols.insert(k.joint);
        }
    }
    Some(cols.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::basis_part::expand_and_reduce;
    use crate::symbolic::DEFAULT_MAX_TERMS;

    /// Every spec of the test set, the model library and the bench: the sketch's `K` and
    /// term count are the exact reduction's whenever it gives them, and it gives them for
    /// the specs whose rows are all one term (at least the bench's PUMA and a few others).
    #[test]
    fn sketch_gives_the_exact_k() {
        let mut given = 0;
        let mut checked = 0;
        let paths = crate::symbolic::testutil::repo_spec_paths(&[
            "tests/specs",
            "lincal-models/specs",
            "bench/specs",
        ]);
        for name in &paths {
            let spec = crate::symbolic::testutil::repo_spec(name);
            // With the build ahead's bounds: `Beyond` only where the exact build fails
            // them, `K` only where it succeeds, and the same `K`.
            let r = crate::symbolic::REPORT_MAX_TERMS;
            match (
                basis_size(&spec, r, Some(r)),
                expand_and_reduce(&spec, r, Some(r)),
            ) {
                (Sketched::Beyond, exact) => assert!(exact.is_err(), "{name}"),
                (Sketched::Known(s), Ok((p, _))) => {
                    assert_eq!(s.k, p.reduction.basis.len(), "{name}");
                }
                (Sketched::Known(_), Err(_)) => panic!("{name}: K where the build fails"),
                (Sketched::Unknown, _) => {}
            }
            let Ok((part, _)) = expand_and_reduce(&spec, DEFAULT_MAX_TERMS, None) else {
                // Where the exact build fails, the sketch gives no `K`.
                let sketch = basis_size(&spec, DEFAULT_MAX_TERMS, None);
                assert!(!matches!(sketch, Sketched::Known(_)), "{name}");
                continue;
            };
            checked += 1;
            let sketch = basis_size(&spec, DEFAULT_MAX_TERMS, None);
            assert_ne!(sketch, Sketched::Beyond, "{name}");
            if let Sketched::Known(s) = sketch {
                given += 1;
                assert_eq!(s.k, part.reduction.basis.len(), "{name}");
                // A basis of grid monomials proven without the expansion counts no terms.
                if part.proven_grid.is_none() {
                    assert_eq!(s.terms, part.terms_before_reduction, "{name}");
                }
            }
        }
        assert!(checked >= 30 && given >= 5, "{given} of {checked}");
    }

    /// A carry between packed exponents is an exponent beyond 15, as in the exact engine; the
    /// parameters' degree bounds add and take maxima.
    #[test]
    fn exponent_overflow_is_caught() {
        assert!(add_exponents(0x7, 0x8).is_ok());
        assert!(add_exponents(0x8, 0x8).is_err());
        assert!(add_exponents(0x80, 0x80).is_err());
        assert!(add_exponents(0xF << 60, 0x1 << 60).is_err());
        assert_eq!(add_exponents(0x21, 0x12), Ok(0x33));
        // The parameters' bounds: summed by products, maxed by sums.
        assert_eq!(sum_degrees(&[7, 1], &[8]), vec![15, 1]);
        assert_eq!(sum_degrees(&[250], &[8]), vec![255]);
        assert_eq!(max_degrees(&[2], &[1, 3]), vec![2, 3]);
    }
}
