//! Exact rational coefficients, inline while they are small.
//!
//! A kinematic expansion's coefficients are nearly all small integers (±1, ±2, the
//! occasional exact constant such as 1/2): a [`BigRational`] for each would cost two heap
//! allocations per term, on every clone, and a gcd on every product. [`Coef`] keeps
//! `n/d` inline (`i64` numerator, positive `i64` denominator, in lowest terms), does the
//! arithmetic in `i128` where it cannot overflow, and moves to a boxed [`BigRational`] only
//! when a result does not fit. The representation is canonical (a value fits inline exactly
//! when it is stored inline), so equality and hashing are those of the rational number.

use num_bigint::BigInt;
use num_integer::Integer;
use num_rational::BigRational;
use num_traits::{One, Signed, ToPrimitive, Zero};
use std::fmt;
use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// An exact rational number; see the [module docs](self).
#[derive(Clone, PartialEq, Eq, Hash)]
pub struct Coef(Repr);

#[derive(Clone, PartialEq, Eq, Hash)]
enum Repr {
    /// `n / d` in lowest terms, `d ≥ 1`, `n ≠ i64::MIN` (so negation never overflows).
    Small(i64, i64),
    /// Anything else, in lowest terms (as `BigRational` keeps it).
    Big(Box<BigRational>),
}

impl Coef {
    /// Zero.
    pub const ZERO: Coef = Coef(Repr::Small(0, 1));
    /// One.
    pub const ONE: Coef = Coef(Repr::Small(1, 1));

    /// The integer `n`.
    #[must_use]
    pub fn int(n: i64) -> Coef {
        Coef::from_i128(i128::from(n), 1)
    }

    /// `n / d` (any signs; `d ≠ 0`), in lowest terms.
    ///
    /// # Panics
    /// If `d` is zero.
    #[must_use]
    pub fn ratio(n: i64, d: i64) -> Coef {
        assert!(d != 0, "a rational with denominator zero");
        let (n, d) = (i128::from(n), i128::from(d));
        let g = n.gcd(&d);
        let s = if d < 0 { -1 } else { 1 };
        Coef::from_i128(s * n / g, s * d / g)
    }

    /// From a reduced `n / d` with `d > 0`: inline when both fit.
    fn from_i128(n: i128, d: i128) -> Coef {
        match (i64::try_from(n), i64::try_from(d)) {
            (Ok(n), Ok(d)) if n != i64::MIN => Coef(Repr::Small(n, d)),
            _ => Coef(Repr::Big(Box::new(BigRational::new_raw(
                BigInt::from(n),
                BigInt::from(d),
            )))),
        }
    }

    /// From a [`BigRational`] (kept inline when it fits).
    #[must_use]
    pub fn from_big(r: BigRational) -> Coef {
        match (r.numer().to_i64(), r.denom().to_i64()) {
            (Some(n), Some(d)) if n != i64::MIN => Coef(Repr::Small(n, d)),
            _ => Coef(Repr::Big(Box::new(r))),
        }
    }

    /// As a [`BigRational`].
    #[must_use]
    pub fn to_big(&self) -> BigRational {
        match &self.0 {
            Repr::Small(n, d) => BigRational::new_raw(BigInt::from(*n), BigInt::from(*d)),
            Repr::Big(r) => (**r).clone(),
        }
    }

    /// `Some((n, d))` when inline: numerator and positive denominator in lowest terms.
    #[must_use]
    #[inline]
    pub fn small(&self) -> Option<(i64, i64)> {
        match self.0 {
            Repr::Small(n, d) => Some((n, d)),
            Repr::Big(_) => None,
        }
    }

    /// Whether this is 0.
    #[must_use]
    #[inline]
    pub fn is_zero(&self) -> bool {
        matches!(self.0, Repr::Small(0, _))
    }

    /// Whether this is 1.
    #[must_use]
    #[inline]
    pub fn is_one(&self) -> bool {
        matches!(self.0, Repr::Small(1, 1))
    }

    /// Whether this is below 0.
    #[must_use]
    pub fn is_negative(&self) -> bool {
        match &self.0 {
            Repr::Small(n, _) => *n < 0,
            Repr::Big(r) => r.is_negative(),
        }
    }

    /// Whether this is an integer.
    #[must_use]
    pub fn is_integer(&self) -> bool {
        match &self.0 {
            Repr::Small(_, d) => *d == 1,
            Repr::Big(r) => r.is_integer(),
        }
    }

    /// `|self|`.
    #[must_use]
    pub fn abs(&self) -> Coef {
        if self.is_negative() {
            -self
        } else {
            self.clone()
        }
    }

    /// `1 / self`, `None` for zero.
    #[must_use]
    pub fn recip(&self) -> Option<Coef> {
        match &self.0 {
            Repr::Small(0, _) => None,
            Repr::Small(n, d) => {
                let s = if *n < 0 { -1 } else { 1 };
                Some(Coef::from_i128(s * i128::from(*d), s * i128::from(*n)))
            }
            Repr::Big(r) => Some(Coef::from_big(r.recip())),
        }
    }

    /// The nearest `f64` (NaN if not representable).
    #[must_use]
    #[inline]
    pub fn to_f64(&self) -> f64 {
        // Integers of at most 53 bits are exact in f64, so one IEEE division rounds
        // correctly: the value `BigRational::to_f64` gives.
        const EXACT: i64 = 1 << 53;
        match &self.0 {
            Repr::Small(n, d) if (-EXACT..=EXACT).contains(n) && *d <= EXACT => {
                *n as f64 / *d as f64
            }
            Repr::Small(..) => self.to_big().to_f64().unwrap_or(f64::NAN),
            Repr::Big(r) => r.to_f64().unwrap_or(f64::NAN),
        }
    }

    /// The numerator (of the lowest terms).
    #[must_use]
    pub fn numer(&self) -> BigInt {
        match &self.0 {
            Repr::Small(n, _) => BigInt::from(*n),
            Repr::Big(r) => r.numer().clone(),
        }
    }

    /// The positive denominator (of the lowest terms).
    #[must_use]
    pub fn denom(&self) -> BigInt {
        match &self.0 {
            Repr::Small(_, d) => BigInt::from(*d),
            Repr::Big(r) => r.denom().clone(),
        }
    }

    /// A binary operation: inline by `small` when both operands are inline, else on
    /// [`BigRational`]s.
    fn op(
        &self,
        o: &Coef,
        small: fn(i64, i64, i64, i64) -> Coef,
        big: fn(BigRational, BigRational) -> BigRational,
    ) -> Coef {
        match (&self.0, &o.0) {
            (Repr::Small(a, b), Repr::Small(c, d)) => small(*a, *b, *c, *d),
            _ => Coef::from_big(big(self.to_big(), o.to_big())),
        }
    }
}

/// `a/b + c/d` for inline operands (`|a|, b, |c|, d < 2⁶³`: every intermediate fits `i128`).
fn add_small(a: i64, b: i64, c: i64, d: i64) -> Coef {
    if b == 1 && d == 1 {
        return Coef::from_i128(i128::from(a) + i128::from(c), 1);
    }
    let g = b.gcd(&d);
    let (b1, d1) = (i128::from(b / g), i128::from(d / g));
    let n = i128::from(a) * d1 + i128::from(c) * b1;
    if n == 0 {
        return Coef::ZERO;
    }
    let den = b1 * i128::from(d);
    // gcd(n, b1·d1·g) = gcd(n, g), as n is prime to b1 and to d1.
    let g2 = n.gcd(&i128::from(g));
    Coef::from_i128(n / g2, den / g2)
}

/// `a/b · c/d` for inline operands, cross-reduced first (so the result is in lowest terms).
fn mul_small(a: i64, b: i64, c: i64, d: i64) -> Coef {
    if b == 1 && d == 1 {
        return Coef::from_i128(i128::from(a) * i128::from(c), 1);
    }
    if a == 0 || c == 0 {
        return Coef::ZERO;
    }
    let g1 = a.gcd(&d);
    let g2 = c.gcd(&b);
    Coef::from_i128(
        i128::from(a / g1) * i128::from(c / g2),
        i128::from(b / g2) * i128::from(d / g1),
    )
}

impl Default for Coef {
    fn default() -> Self {
        Coef::ZERO
    }
}

impl From<BigRational> for Coef {
    fn from(r: BigRational) -> Self {
        Coef::from_big(r)
    }
}

impl From<i64> for Coef {
    fn from(n: i64) -> Self {
        Coef::int(n)
    }
}

impl Neg for &Coef {
    type Output = Coef;
    fn neg(self) -> Coef {
        match &self.0 {
            Repr::Small(n, d) => Coef(Repr::Small(-n, *d)),
            Repr::Big(r) => Coef::from_big(-(**r).clone()),
        }
    }
}

impl Neg for Coef {
    type Output = Coef;
    fn neg(self) -> Coef {
        match self.0 {
            Repr::Small(n, d) => Coef(Repr::Small(-n, d)),
            Repr::Big(r) => Coef::from_big(-*r),
        }
    }
}

impl Add for &Coef {
    type Output = Coef;
    fn add(self, o: &Coef) -> Coef {
        self.op(o, add_small, |x, y| x + y)
    }
}

impl Sub for &Coef {
    type Output = Coef;
    fn sub(self, o: &Coef) -> Coef {
        self + &-o
    }
}

impl Mul for &Coef {
    type Output = Coef;
    fn mul(self, o: &Coef) -> Coef {
        self.op(o, mul_small, |x, y| x * y)
    }
}

impl AddAssign<&Coef> for Coef {
    fn add_assign(&mut self, o: &Coef) {
        *self = &*self + o;
    }
}

impl fmt::Display for Coef {
    /// `n` or `n/d`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.0 {
            Repr::Small(n, 1) => write!(f, "{n}"),
            Repr::Small(n, d) => write!(f, "{n}/{d}"),
            Repr::Big(r) => write!(f, "{r}"),
        }
    }
}

impl fmt::Debug for Coef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl Zero for Coef {
    fn zero() -> Self {
        Coef::ZERO
    }
    fn is_zero(&self) -> bool {
        Coef::is_zero(self)
    }
}

impl Add for Coef {
    type Output = Coef;
    fn add(self, o: Coef) -> Coef {
        &self + &o
    }
}

impl Mul for Coef {
    type Output = Coef;
    fn mul(self, o: Coef) -> Coef {
        &self * &o
    }
}

impl One for Coef {
    fn one() -> Self {
        Coef::ONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::modp::Rng;

    fn big(n: i128, d: i128) -> BigRational {
        BigRational::new(BigInt::from(n), BigInt::from(d))
    }

    /// Random operands across the inline range, its edges and beyond.
    fn sample(rng: &mut Rng) -> (i128, i128) {
        let pick = |rng: &mut Rng| -> i128 {
            match rng.next_u64() % 5 {
                0 => (rng.next_u64() % 7) as i128 - 3,
                1 => (rng.next_u64() >> 1) as i128,
                2 => i128::from(i64::MAX) - (rng.next_u64() % 3) as i128,
                3 => -(i128::from(i64::MAX)) - (rng.next_u64() % 3) as i128,
                _ => (rng.next_u64() as i128) << 40,
            }
        };
        let n = pick(rng);
        let mut d = pick(rng);
        if d == 0 {
            d = 1;
        }
        (n, d)
    }

    #[test]
    fn arithmetic_matches_bigrational_everywhere() {
        let mut rng = Rng::new(11);
        for _ in 0..20_000 {
            let (a, b) = sample(&mut rng);
            let (c, d) = sample(&mut rng);
            let (x, y) = (big(a, b), big(c, d));
            let (cx, cy) = (Coef::from_big(x.clone()), Coef::from_big(y.clone()));
            assert_eq!(cx.to_big(), x);
            assert_eq!((&cx + &cy).to_big(), &x + &y, "{x} + {y}");
            assert_eq!((&cx - &cy).to_big(), &x - &y, "{x} - {y}");
            assert_eq!((&cx * &cy).to_big(), &x * &y, "{x} * {y}");
            assert_eq!((-&cx).to_big(), -x.clone());
            // Canonical: equal values, equal representations.
            assert_eq!(&cx + &cy, Coef::from_big(&x + &y));
            assert_eq!(&cx * &cy, Coef::from_big(&x * &y));
            if !y.is_zero() {
                assert_eq!(cy.recip().map(|r| r.to_big()), Some(y.recip()));
            }
            assert_eq!(cx.to_f64(), x.to_f64().unwrap_or(f64::NAN));
            assert_eq!(cx.is_negative(), x.is_negative());
            assert_eq!(cx.is_integer(), x.is_integer());
            assert_eq!(cx.to_string(), x.to_string());
        }
    }

    #[test]
    fn ratio_is_lowest_terms() {
        assert_eq!(Coef::ratio(6, -4), Coef::from_big(big(-3, 2)));
        assert_eq!(Coef::ratio(0, -4), Coef::ZERO);
        assert!(Coef::ratio(4, 4).is_one());
        assert_eq!(Coef::int(i64::MIN).to_big(), big(i128::from(i64::MIN), 1));
    }
}
