//! What the chain product and the constraint formulas of [`super::expand`] ask of a
//! polynomial, so that one code path builds either the exact polynomials ([`Poly`]) or their
//! image modulo a prime ([`super::sketch::Sketch`], which gives `K` in a fraction of the time).
//!
//! Every operation is a ring operation in canonical trigonometric form (`sin² = 1 − cos²`
//! rewritten for each `(cos, sin)` pair): `Ctx` carries what the rewriting needs.

use super::poly::{rat, Poly, ProductError};

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
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    fn mul(&self, o: &Self, ctx: &Self::Ctx) -> Result<Self, ProductError>;
    /// `self²`, reduced.
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    fn square(&self, ctx: &Self::Ctx) -> Result<Self, ProductError>;
    /// `self += a · b`, reduced.
    ///
    /// # Errors
    /// [`ProductError`] if an exponent would exceed 15 or the terms outgrow the memory left.
    fn add_product(&mut self, a: &Self, b: &Self, ctx: &Self::Ctx) -> Result<(), ProductError>;
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
        // `n` is a bound (products before like terms merge), not the size: a table that
        // large may not fit where the merged result does, and a failed reservation costs
        // nothing but the growth steps.
        let _ = self.terms.try_reserve(n);
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
    fn mul(&self, o: &Self, ctx: &Self::Ctx) -> Result<Self, ProductError> {
        Poly::mul(self, o, ctx)
    }
    fn square(&self, ctx: &Self::Ctx) -> Result<Self, ProductError> {
        Poly::square(self, ctx)
    }
    fn add_product(&mut self, a: &Self, b: &Self, ctx: &Self::Ctx) -> Result<(), ProductError> {
        Poly::add_product(self, a, b, ctx)
    }
}
