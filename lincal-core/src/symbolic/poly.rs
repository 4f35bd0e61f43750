//! Exact sparse polynomials with rational coefficients, in canonical trigonometric form.
//!
//! For every `(cos, sin)` pair of the [`VarTable`], `sin²` is rewritten as `1 − cos²`, so each
//! monomial has `sin` exponent 0 or 1. In that form, distinct monomials are linearly
//! independent functions (of the joints, and of the parameters), which makes equality of
//! functions equality of representations: the property every later step relies on.

use super::coef::Coef;
use super::monomial::{Mono, VarTable, WORDS};
use rustc_hash::FxHashMap;
use std::fmt::Write as _;

/// Why a product of polynomials could not be formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProductError {
    /// A monomial exponent went past 15 (far beyond any kinematic chain's degree).
    Degree,
    /// The terms outgrew what the process could still allocate (an address-space limit, a
    /// cgroup, free memory): refused, not aborted.
    Memory,
}

/// A polynomial `Σ coef · monomial` in canonical trig form.
#[derive(Debug, Default, PartialEq)]
pub struct Poly {
    /// The terms; no zero coefficients.
    pub terms: FxHashMap<Mono, Coef>,
}

thread_local! {
    /// Set when a sum, difference or copy could not allocate its table: the operation gave
    /// an empty polynomial instead of aborting, and the expansion that called it must fail
    /// ([`take_out_of_memory`]). Products report it directly ([`ProductError::Memory`]).
    static OUT_OF_MEMORY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether an operation on this thread ran out of memory since the last call (and clears
/// it): an expansion checks it at each link and before it returns, so an empty stand-in is
/// never taken for a result.
pub(crate) fn take_out_of_memory() -> bool {
    OUT_OF_MEMORY.with(|f| f.replace(false))
}

/// A table of `p`'s terms with room for `extra` more, allocated fallibly; `None` (and
/// [`OUT_OF_MEMORY`] set) when the allocation fails.
fn copy_with_room(p: &Poly, extra: usize) -> Option<Poly> {
    let mut r = Poly::zero();
    if r.terms.try_reserve(p.len().saturating_add(extra)).is_err() {
        OUT_OF_MEMORY.with(|f| f.set(true));
        return None;
    }
    r.terms.extend(p.terms.iter().map(|(m, c)| (*m, c.clone())));
    Some(r)
}

/// A copy that does not abort on a failed allocation: empty then, with [`OUT_OF_MEMORY`]
/// set.
impl Clone for Poly {
    fn clone(&self) -> Self {
        copy_with_room(self, 0).unwrap_or_default()
    }
}

/// Rational from an integer.
#[must_use]
pub fn rat(i: i64) -> Coef {
    Coef::int(i)
}

/// Per word of the monomials' layout, a 1 in the low bit of every nibble (variable) that
/// occurs in some monomial of `monos`.
fn support<'a>(monos: impl Iterator<Item = &'a Mono>) -> [u64; WORDS] {
    const LOW: u64 = 0x1111_1111_1111_1111;
    let mut or = [0u64; WORDS];
    for m in monos {
        for (o, w) in or.iter_mut().zip(m.words()) {
            *o |= w;
        }
    }
    or.map(|w| (w | (w >> 1) | (w >> 2) | (w >> 3)) & LOW)
}

impl Poly {
    /// The zero polynomial.
    #[must_use]
    pub fn zero() -> Self {
        Poly::default()
    }

    /// A constant.
    #[must_use]
    pub fn constant(c: Coef) -> Self {
        let mut p = Poly::zero();
        if !c.is_zero() {
            p.terms.insert(Mono::ONE, c);
        }
        p
    }

    /// An integer constant.
    #[must_use]
    pub fn int(i: i64) -> Self {
        Self::constant(rat(i))
    }

    /// The variable `v`.
    #[must_use]
    pub fn var(v: usize) -> Self {
        let mut p = Poly::zero();
        p.terms.insert(Mono::var(v), Coef::ONE);
        p
    }

    /// Whether this is zero.
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    /// Number of terms.
    #[must_use]
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    fn add_term(&mut self, m: Mono, c: Coef) {
        if c.is_zero() {
            return;
        }
        match self.terms.entry(m) {
            std::collections::hash_map::Entry::Occupied(mut e) => {
                *e.get_mut() += &c;
                if e.get().is_zero() {
                    e.remove();
                }
            }
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(c);
            }
        }
    }

    /// Adds `c · m`, rewriting `sin² = 1 − cos²` for every trig pair.
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    pub fn add_reduced(
        &mut self,
        m: Mono,
        c: &Coef,
        pairs: &[(usize, usize)],
    ) -> Result<(), ProductError> {
        self.room()?;
        reduce_trig(m, false, pairs, &mut |m, neg| {
            self.add_term(m, if neg { -c } else { c.clone() });
            true
        })?;
        Ok(())
    }

    /// Room for at least two more terms (a reduced term may split in two), the table's
    /// growth allocated fallibly: an expansion beyond the memory left ends in
    /// [`ProductError::Memory`], not in an abort.
    fn room(&mut self) -> Result<(), ProductError> {
        let (len, cap) = (self.terms.len(), self.terms.capacity());
        if len + 2 > cap {
            self.terms
                .try_reserve(len.max(64))
                .map_err(|_| ProductError::Memory)?;
        }
        Ok(())
    }

    /// `self + o`.
    #[must_use]
    pub fn add(&self, o: &Poly) -> Poly {
        // Copy the larger, add the smaller: the same sum.
        let (big, small) = if self.len() >= o.len() {
            (self, o)
        } else {
            (o, self)
        };
        let Some(mut r) = copy_with_room(big, small.len()) else {
            return Poly::zero();
        };
        r.add_assign(small);
        r
    }

    /// `self += o`.
    pub fn add_assign(&mut self, o: &Poly) {
        if self.terms.try_reserve(o.len()).is_err() {
            OUT_OF_MEMORY.with(|f| f.set(true));
            return;
        }
        for (m, c) in &o.terms {
            self.add_term(*m, c.clone());
        }
    }

    /// `self − o`.
    #[must_use]
    pub fn sub(&self, o: &Poly) -> Poly {
        let Some(mut r) = copy_with_room(self, o.len()) else {
            return Poly::zero();
        };
        for (m, c) in &o.terms {
            r.add_term(*m, -c);
        }
        r
    }

    /// `−self`.
    #[must_use]
    pub fn neg(&self) -> Poly {
        Poly {
            terms: self.terms.iter().map(|(m, c)| (*m, -c)).collect(),
        }
    }

    /// `k · self`.
    #[must_use]
    pub fn scale(&self, k: &Coef) -> Poly {
        if k.is_zero() {
            return Poly::zero();
        }
        Poly {
            terms: self.terms.iter().map(|(m, c)| (*m, c * k)).collect(),
        }
    }

    /// `self · o`, reduced.
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    pub fn mul(&self, o: &Poly, pairs: &[(usize, usize)]) -> Result<Poly, ProductError> {
        if self.is_zero() || o.is_zero() {
            return Ok(Poly::zero());
        }
        // Factors in disjoint variables (a link's transform applied to the chain beyond it,
        // where the bulk of an expansion's work is): every product of two terms is a distinct
        // monomial, and none has a squared sine, so no term needs looking up or rewriting.
        let (sa, sb) = (support(self.terms.keys()), support(o.terms.keys()));
        if sa.iter().zip(&sb).all(|(a, b)| a & b == 0) {
            return self.mul_disjoint(o);
        }
        let mut r = Poly::zero();
        let _ = r.terms.try_reserve(self.len() * o.len());
        for (m1, c1) in &self.terms {
            for (m2, c2) in &o.terms {
                let m = m1.mul(m2).ok_or(ProductError::Degree)?;
                r.add_reduced(m, &(c1 * c2), pairs)?;
            }
        }
        Ok(r)
    }

    /// `self += a · b`, reduced, each product term added in place: no product polynomial
    /// is formed and added again (half the hashing of `self.add_assign(&a.mul(b))`, and no
    /// large temporary table). Factors in disjoint variables need no `sin²` rewriting (see
    /// [`Poly::mul`]).
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    pub fn add_product(
        &mut self,
        a: &Poly,
        b: &Poly,
        pairs: &[(usize, usize)],
    ) -> Result<(), ProductError> {
        if a.is_zero() || b.is_zero() {
            return Ok(());
        }
        let (sa, sb) = (support(a.terms.keys()), support(b.terms.keys()));
        let disjoint = sa.iter().zip(&sb).all(|(x, y)| x & y == 0);
        for (m1, c1) in &a.terms {
            for (m2, c2) in &b.terms {
                let m = m1.mul(m2).ok_or(ProductError::Degree)?;
                let c = times(c1, c2);
                self.room()?;
                if disjoint {
                    self.add_term(m, c);
                } else {
                    self.add_reduced(m, &c, pairs)?;
                }
            }
        }
        Ok(())
    }

    /// The product of factors in disjoint variables (see [`Poly::mul`]).
    fn mul_disjoint(&self, o: &Poly) -> Result<Poly, ProductError> {
        let mut terms = FxHashMap::default();
        terms
            .try_reserve(self.len() * o.len())
            .map_err(|_| ProductError::Memory)?;
        for (m1, c1) in &self.terms {
            for (m2, c2) in &o.terms {
                // Disjoint supports: no exponent grows, so no overflow either.
                let m = m1.mul(m2).ok_or(ProductError::Degree)?;
                let c = times(c1, c2);
                terms.insert(m, c);
            }
        }
        Ok(Poly { terms })
    }

    /// `self²`, reduced; each cross term once (half the products of [`Poly::mul`]).
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    pub fn square(&self, pairs: &[(usize, usize)]) -> Result<Poly, ProductError> {
        let t: Vec<(&Mono, &Coef)> = self.terms.iter().collect();
        let two = Coef::int(2);
        let mut r = Poly::zero();
        let _ = r.terms.try_reserve(t.len() * (t.len() + 1) / 2);
        for (i, (m1, c1)) in t.iter().enumerate() {
            r.add_reduced(m1.mul(m1).ok_or(ProductError::Degree)?, &(*c1 * *c1), pairs)?;
            for (m2, c2) in &t[i + 1..] {
                let m = m1.mul(m2).ok_or(ProductError::Degree)?;
                r.add_reduced(m, &(&two * &(*c1 * *c2)), pairs)?;
            }
        }
        Ok(r)
    }

    /// `∂self/∂v` (no trig rule: the caller combines cos and sin derivatives).
    #[must_use]
    pub fn diff(&self, v: usize) -> Poly {
        let mut r = Poly::zero();
        let n = self.terms.keys().filter(|m| m.get(v) > 0).count();
        if n == 0 {
            return r;
        }
        r.terms.reserve(n);
        for (m, c) in &self.terms {
            let e = m.get(v);
            if e > 0 {
                let mut m2 = *m;
                m2.set(v, e - 1);
                // Distinct monomials stay distinct after lowering one exponent.
                let d = if e == 1 {
                    c.clone()
                } else {
                    c * &rat(i64::from(e))
                };
                r.terms.insert(m2, d);
            }
        }
        r
    }

    /// Terms sorted by a display order: ascending degree, then by variables.
    #[must_use]
    pub fn sorted_terms(&self) -> Vec<(Mono, Coef)> {
        let mut t: Vec<(&Mono, &Coef)> = self.terms.iter().collect();
        t.sort_by_cached_key(|x| display_key(x.0));
        t.into_iter().map(|(m, c)| (*m, c.clone())).collect()
    }

    /// Human-readable form, e.g. `a1*b1*cos(th1) - a1*b2*sin(th1)`.
    #[must_use]
    pub fn display(&self, vars: &VarTable, param_names: &[String]) -> String {
        if self.is_zero() {
            return "0".into();
        }
        let mut s = String::new();
        for (i, (m, c)) in self.sorted_terms().iter().enumerate() {
            let neg = c.is_negative();
            let a = c.abs();
            if i == 0 {
                if neg {
                    s.push('-');
                }
            } else {
                s.push_str(if neg { " - " } else { " + " });
            }
            let mono = mono_display(m, vars, param_names);
            let coef = a.to_string();
            match (a.is_one(), mono.is_empty()) {
                (true, true) => s.push('1'),
                (true, false) => s.push_str(&mono),
                (false, true) => s.push_str(&coef),
                (false, false) => {
                    let _ = write!(s, "{coef}*{mono}");
                }
            }
        }
        s
    }
}

/// `a·b`, without the arithmetic when either is 1 (most of an expansion's coefficients).
fn times(a: &Coef, b: &Coef) -> Coef {
    if a.is_one() {
        b.clone()
    } else if b.is_one() {
        a.clone()
    } else {
        a * b
    }
}

/// Rewrites `m` with `sin² = 1 − cos²` for every trig pair and calls `emit(term, negated)` for
/// each resulting monomial (with its sign relative to `m`); stops early, returning
/// `Ok(false)`, as soon as `emit` does.
///
/// # Errors
/// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
pub fn reduce_trig(
    m: Mono,
    neg: bool,
    pairs: &[(usize, usize)],
    emit: &mut dyn FnMut(Mono, bool) -> bool,
) -> Result<bool, ProductError> {
    for &(cv, sv) in pairs {
        let e = m.get(sv);
        if e >= 2 {
            let mut m1 = m;
            m1.set(sv, e - 2);
            let ce = m1.get(cv);
            if ce + 2 > 15 {
                return Err(ProductError::Degree);
            }
            let mut m2 = m1;
            m2.set(cv, ce + 2);
            return Ok(reduce_trig(m1, neg, pairs, emit)? && reduce_trig(m2, !neg, pairs, emit)?);
        }
    }
    Ok(emit(m, neg))
}

/// Order used for display and for choosing pivots: ascending total degree, then the
/// variables' exponents from the lowest-numbered variable (so `c1` before `c2`, cos before sin).
#[must_use]
pub fn display_order(a: &Mono, b: &Mono) -> std::cmp::Ordering {
    a.degree().cmp(&b.degree()).then_with(|| {
        // The first differing variable is the lowest differing nibble.
        for (&wa, &wb) in a.words().iter().zip(b.words()) {
            let x = wa ^ wb;
            if x != 0 {
                let shift = (x.trailing_zeros() / 4) * 4;
                return ((wb >> shift) & 0xF).cmp(&((wa >> shift) & 0xF));
            }
        }
        std::cmp::Ordering::Equal
    })
}

/// The sort key of [`display_key`].
pub type DisplayKey = (u32, [u64; 8]);

/// A key whose natural order is [`display_order`]: the degree, then every word with its
/// nibbles reversed (variable 0 most significant) and complemented (a larger exponent
/// first). For sorting many monomials by a precomputed key.
#[must_use]
#[inline]
pub fn display_key(m: &Mono) -> DisplayKey {
    let mut k = [0u64; 8];
    for (o, &w) in k.iter_mut().zip(m.words()) {
        let b = w.swap_bytes();
        *o = !(((b >> 4) & 0x0F0F_0F0F_0F0F_0F0F) | ((b & 0x0F0F_0F0F_0F0F_0F0F) << 4));
    }
    (m.degree(), k)
}

/// `c1*s2`, `q3^2`, `a1*cos(th1)`; empty for the constant monomial.
#[must_use]
pub fn mono_display(m: &Mono, vars: &VarTable, param_names: &[String]) -> String {
    use super::monomial::Var;
    // Joint variables, then lengths, then cosines and sines: `a2*b1*cos(th1)*sin(th2)`.
    let rank = |v: usize| match vars.vars.get(v) {
        Some(Var::ParamLength(_) | Var::ConstLength(..)) => 1,
        Some(Var::ParamCos(_) | Var::ParamSin(_) | Var::ConstCos(..) | Var::ConstSin(..)) => 2,
        _ => 0,
    };
    let mut factors: Vec<(usize, u32)> = m.factors().collect();
    factors.sort_by_key(|&(v, _)| (rank(v), v));
    let parts: Vec<String> = factors
        .into_iter()
        .map(|(v, e)| {
            let n = vars.name(v, param_names);
            if e == 1 {
                n
            } else {
                format!("{n}^{e}")
            }
        })
        .collect();
    parts.join("*")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_key_orders_as_display_order() {
        let mut rng = crate::symbolic::modp::Rng::new(7);
        let monos: Vec<Mono> = (0..300)
            .map(|_| {
                let mut m = Mono::ONE;
                for _ in 0..(rng.next_u64() % 6) {
                    let v = (rng.next_u64() % 128) as usize;
                    m.set(v, (rng.next_u64() % 16) as u32);
                }
                m
            })
            .collect();
        for a in &monos {
            for b in &monos {
                let slow = a.degree().cmp(&b.degree()).then_with(|| {
                    (0..crate::symbolic::monomial::MAX_VARS)
                        .find(|&v| a.get(v) != b.get(v))
                        .map_or(std::cmp::Ordering::Equal, |v| b.get(v).cmp(&a.get(v)))
                });
                assert_eq!(display_order(a, b), slow);
                assert_eq!(display_key(a).cmp(&display_key(b)), slow);
            }
        }
    }

    #[test]
    fn pythagoras_reduces_to_one() {
        let pairs = [(0, 1)];
        let c = Poly::var(0);
        let s = Poly::var(1);
        let sum = c.mul(&c, &pairs).unwrap().add(&s.mul(&s, &pairs).unwrap());
        assert_eq!(sum, Poly::int(1));
    }

    #[test]
    fn angle_sum_identity() {
        // cos(a+b)² + sin(a+b)² = 1 with cos(a+b) = ca cb − sa sb.
        let pairs = [(0, 1), (2, 3)];
        let (ca, sa, cb, sb) = (Poly::var(0), Poly::var(1), Poly::var(2), Poly::var(3));
        let cab = ca
            .mul(&cb, &pairs)
            .unwrap()
            .sub(&sa.mul(&sb, &pairs).unwrap());
        let sab = sa
            .mul(&cb, &pairs)
            .unwrap()
            .add(&ca.mul(&sb, &pairs).unwrap());
        let one = cab
            .mul(&cab, &pairs)
            .unwrap()
            .add(&sab.mul(&sab, &pairs).unwrap());
        assert_eq!(one, Poly::int(1));
    }
}
