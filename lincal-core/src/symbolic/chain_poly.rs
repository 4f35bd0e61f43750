//! What the chain product and the constraint formulas of [`super::expand`] ask of a
//! polynomial, so that one code path builds either the exact polynomials ([`Poly`]) or their
//! image modulo a prime ([`super::sketch::Sketch`], which gives `K` in a fraction of the time).
//!
//! Every operation is a ring operation in canonical trigonometric form (`sin² = 1 − cos²`
//! rewritten for each `(cos, sin)` pair): `Ctx` carries what the rewriting needs.

use super::poly::{rat, DegreeOverflow, Poly};

/// A polynomial ring in canonical trigonometric form; see the [module docs](self).
pub(super) trait ChainPoly: Clone + Default + Send + Sync {
    /// What products need to rewrite `sin²` (the exact engine's trig pairs, a sketch's
    /// layout).
    type Ctx: ?Sized + Sync;

    /// The integer constant `i`.
    fn int(i: i64) -> Self;
    /// Whether this is zero.
    fn is_zero(&self) -> bool;
    /// Number of terms.
    fn len(&self) -> usize;
    /// Room for `n` more terms.
    fn reserve(&mut self, n: usize);
    /// `self + o`.
    #[must_use]
    fn add(&self, o: &Self) -> Self;
    /// `self += o`.
    fn add_assign(&mut self, o: &Self);
    /// `self − o`.
    #[must_use]
    fn sub(&self, o: &Self) -> Self;
    /// `−self`.
    #[must_use]
    fn neg(&self) -> Self;
    /// `k · self` for an integer `k`.
    #[must_use]
    fn scale_int(&self, k: i64) -> Self;
    /// `self · o`, reduced.
    ///
    /// # Errors
    /// [`DegreeOverflow`] if an exponent would exceed 15.
    fn mul(&self, o: &Self, ctx: &Self::Ctx) -> Result<Self, DegreeOverflow>;
    /// `self²`, reduced.
    ///
    /// # Errors
    /// [`DegreeOverflow`] if an exponent would exceed 15.
    fn square(&self, ctx: &Self::Ctx) -> Result<Self, DegreeOverflow>;
    /// `self += a · b`, reduced.
    ///
    /// # Errors
    /// [`DegreeOverflow`] if an exponent would exceed 15.
    fn add_product(&mut self, a: &Self, b: &Self, ctx: &Self::Ctx) -> Result<(), DegreeOverflow>;
}

impl ChainPoly for Poly {
    type Ctx = [(usize, usize)];

    fn int(i: i64) -> Self {
        Poly::int(i)
    }
    fn is_zero(&self) -> bool {
        Poly::is_zero(self)
    }
    fn len(&self) -> usize {
        Poly::len(self)
    }
    fn reserve(&mut self, n: usize) {
        self.terms.reserve(n);
    }
    fn add(&self, o: &Self) -> Self {
        Poly::add(self, o)
    }
    fn add_assign(&mut self, o: &Self) {
        Poly::add_assign(self, o);
    }
    fn sub(&self, o: &Self) -> Self {
        Poly::sub(self, o)
    }
    fn neg(&self) -> Self {
        Poly::neg(self)
    }
    fn scale_int(&self, k: i64) -> Self {
        self.scale(&rat(k))
    }
    fn mul(&self, o: &Self, ctx: &Self::Ctx) -> Result<Self, DegreeOverflow> {
        Poly::mul(self, o, ctx)
    }
    fn square(&self, ctx: &Self::Ctx) -> Result<Self, DegreeOverflow> {
        Poly::square(self, ctx)
    }
    fn add_product(&mut self, a: &Self, b: &Self, ctx: &Self::Ctx) -> Result<(), DegreeOverflow> {
        Poly::add_product(self, a, b, ctx)
    }
}
