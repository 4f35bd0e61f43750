//! Arithmetic modulo the Mersenne prime `P = 2⁶¹ − 1`, for fast exact rank computations.
//!
//! The engine computes ranks and reduced echelon forms modulo `P` (cheap, fixed-size
//! integers), reconstructs small rationals from the residues, and then verifies the result
//! exactly over ℚ. A rank modulo `P` never exceeds the rank over ℚ, and the exact verification
//! bounds it from above, so the reported rank is certified, not probable.

use super::coef::Coef;
use num_bigint::BigInt;
use num_integer::Integer;
use num_rational::BigRational;
use num_traits::ToPrimitive;

/// The prime modulus.
pub const P: u64 = (1 << 61) - 1;

/// `a·b mod P`.
#[inline]
#[must_use]
pub fn mul(a: u64, b: u64) -> u64 {
    let t = u128::from(a) * u128::from(b);
    let lo = (t as u64) & P;
    let hi = (t >> 61) as u64;
    let s = lo + hi;
    if s >= P {
        s - P
    } else {
        s
    }
}

/// `a + b mod P`.
#[inline]
#[must_use]
pub fn add(a: u64, b: u64) -> u64 {
    let s = a + b;
    if s >= P {
        s - P
    } else {
        s
    }
}

/// `a − b mod P`.
#[inline]
#[must_use]
pub fn sub(a: u64, b: u64) -> u64 {
    if a >= b {
        a - b
    } else {
        a + P - b
    }
}

/// `−a mod P`.
#[inline]
#[must_use]
pub fn neg(a: u64) -> u64 {
    if a == 0 {
        0
    } else {
        P - a
    }
}

/// `a^e mod P`.
#[must_use]
pub fn pow(mut a: u64, mut e: u64) -> u64 {
    let mut r = 1;
    while e > 0 {
        if e & 1 == 1 {
            r = mul(r, a);
        }
        a = mul(a, a);
        e >>= 1;
    }
    r
}

/// `a⁻¹ mod P` (`a ≠ 0`).
#[must_use]
pub fn inv(a: u64) -> u64 {
    pow(a, P - 2)
}

/// A rational modulo `P`, or `None` when its denominator is divisible by `P`.
#[must_use]
pub fn from_rational(r: &BigRational) -> Option<u64> {
    // Fast path: machine-size numerator and denominator (nearly every coefficient).
    if let (Some(n), Some(d)) = (r.numer().to_i64(), r.denom().to_u64()) {
        let d = d % P;
        if d == 0 {
            return None;
        }
        let n = from_i64(n);
        return Some(if d == 1 { n } else { mul(n, inv(d)) });
    }
    let p = BigInt::from(P);
    let n = r.numer().mod_floor(&p).to_u64()?;
    let d = r.denom().mod_floor(&p).to_u64()?;
    (d != 0).then(|| mul(n, inv(d)))
}

/// An integer modulo `P`.
#[inline]
#[must_use]
pub fn from_i64(n: i64) -> u64 {
    let m = n.unsigned_abs() % P;
    if n < 0 {
        neg(m)
    } else {
        m
    }
}

/// Converts rationals modulo `P`, remembering the inverses of the denominators met (a
/// polynomial's coefficients share a handful of them, and an inverse costs ~120 products).
#[derive(Clone, Debug, Default)]
pub struct RationalMod {
    inverses: rustc_hash::FxHashMap<u64, u64>,
}

impl RationalMod {
    /// `r` modulo `P`, or `None` when its denominator is divisible by `P`.
    pub fn get(&mut self, r: &Coef) -> Option<u64> {
        let Some((n, d)) = r.small() else {
            return from_rational(&r.to_big());
        };
        let d = d.unsigned_abs();
        let n = from_i64(n);
        if d == 1 {
            return Some(n);
        }
        let d = d % P;
        if d == 0 {
            return None;
        }
        let i = *self.inverses.entry(d).or_insert_with(|| inv(d));
        Some(mul(n, i))
    }
}

/// The rational `a/b` with `|a|, b ≤ √(P/2)` congruent to `x`, if there is one
/// (Wang's rational reconstruction by the extended Euclidean algorithm).
#[must_use]
pub fn reconstruct(x: u64) -> Option<Coef> {
    let bound: i128 = 1_073_741_823; // floor(sqrt(P/2))
    let (mut r0, mut r1) = (i128::from(P), i128::from(x));
    let (mut t0, mut t1) = (0i128, 1i128);
    while r1 > bound {
        let q = r0 / r1;
        (r0, r1) = (r1, r0 - q * r1);
        (t0, t1) = (t1, t0 - q * t1);
    }
    if t1 == 0 || t1.abs() > bound {
        return None;
    }
    // Both are at most 2³⁰: inline.
    let (n, d) = (i64::try_from(r1).ok()?, i64::try_from(t1).ok()?);
    let r = Coef::ratio(n, d);
    // Check: the gcd condition of Wang's theorem.
    match r.small() {
        Some((n, _)) if i128::from(n).abs() <= bound => Some(r),
        _ => None,
    }
}

/// A deterministic generator of field elements (splitmix64), for reproducible random points.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniformly random element of the field.
    pub fn element(&mut self) -> u64 {
        loop {
            let v = self.next_u64() & P;
            if v < P {
                return v;
            }
        }
    }

    /// A random point `(cos, sin)` on the unit circle over the field:
    /// `((1 − t²)/(1 + t²), 2t/(1 + t²))`.
    pub fn circle_point(&mut self) -> (u64, u64) {
        loop {
            let t = self.element();
            let t2 = mul(t, t);
            let den = add(1, t2);
            if den != 0 {
                let i = inv(den);
                return (mul(sub(1, t2), i), mul(add(t, t), i));
            }
        }
    }
}

/// The arithmetic of the analysis's formulas (the sampled chain, the relations' rows): `f64`,
/// or integers modulo [`P`] ([`Mp`]).
pub(crate) trait Scalar: Copy + PartialEq {
    /// The integer `n`.
    fn int(n: i64) -> Self;
    /// Zero.
    fn zero() -> Self {
        Self::int(0)
    }
    /// `a + b`.
    fn add(self, o: Self) -> Self;
    /// `a − b`.
    fn sub(self, o: Self) -> Self;
    /// `a · b`.
    fn mul(self, o: Self) -> Self;
    /// An exact rational constant (`None` when it has no value here).
    fn coef(c: &Coef) -> Option<Self>;
}

impl Scalar for f64 {
    fn int(n: i64) -> Self {
        n as f64
    }
    fn add(self, o: Self) -> Self {
        self + o
    }
    fn sub(self, o: Self) -> Self {
        self - o
    }
    fn mul(self, o: Self) -> Self {
        self * o
    }
    fn coef(c: &Coef) -> Option<Self> {
        Some(c.to_f64())
    }
}

/// An integer modulo [`P`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Mp(pub u64);

impl Scalar for Mp {
    fn int(n: i64) -> Self {
        Mp(from_i64(n))
    }
    fn add(self, o: Self) -> Self {
        Mp(add(self.0, o.0))
    }
    fn sub(self, o: Self) -> Self {
        Mp(sub(self.0, o.0))
    }
    fn mul(self, o: Self) -> Self {
        Mp(mul(self.0, o.0))
    }
    fn coef(c: &Coef) -> Option<Self> {
        RationalMod::default().get(c).map(Mp)
    }
}

// The field's operators, for the factored kernel's contraction run exactly
// (`crate::model::factored::Ring`, the derive's certificate).
impl std::ops::Add for Mp {
    type Output = Mp;
    fn add(self, o: Mp) -> Mp {
        Mp(add(self.0, o.0))
    }
}

impl std::ops::Sub for Mp {
    type Output = Mp;
    fn sub(self, o: Mp) -> Mp {
        Mp(sub(self.0, o.0))
    }
}

impl std::ops::Mul for Mp {
    type Output = Mp;
    fn mul(self, o: Mp) -> Mp {
        Mp(mul(self.0, o.0))
    }
}

impl std::ops::Neg for Mp {
    type Output = Mp;
    fn neg(self) -> Mp {
        Mp(neg(self.0))
    }
}

impl crate::model::factored::Ring for Mp {
    const ZERO: Mp = Mp(0);
    const ONE: Mp = Mp(1);
    fn half(self) -> Mp {
        // 2⁻¹ = (P + 1)/2.
        Mp(mul(self.0, P.div_ceil(2)))
    }
}

/// Incremental reduced row echelon form over the field, for rows of a fixed length.
#[derive(Clone, Debug, Default)]
pub struct Echelon {
    /// Basis rows, each with a 1 at its pivot and 0 at every other row's pivot.
    pub rows: Vec<Vec<u64>>,
    /// Pivot column of each row.
    pub pivots: Vec<usize>,
}

impl Echelon {
    /// The rank so far.
    #[must_use]
    pub fn rank(&self) -> usize {
        self.rows.len()
    }

    /// Reduces `v` against the basis; adds it if independent. Returns whether it was added.
    pub fn insert(&mut self, mut v: Vec<u64>) -> bool {
        for (row, &piv) in self.rows.iter().zip(&self.pivots) {
            let f = v[piv];
            if f != 0 {
                for (x, &r) in v.iter_mut().zip(row) {
                    if r != 0 {
                        *x = sub(*x, mul(f, r));
                    }
                }
            }
        }
        let Some(piv) = v.iter().position(|&x| x != 0) else {
            return false;
        };
        let i = inv(v[piv]);
        for x in &mut v {
            *x = mul(*x, i);
        }
        // Keep the form reduced: clear the new pivot from the older rows.
        for row in &mut self.rows {
            let f = row[piv];
            if f != 0 {
                for (x, &r) in row.iter_mut().zip(&v) {
                    if r != 0 {
                        *x = sub(*x, mul(f, r));
                    }
                }
            }
        }
        self.rows.push(v);
        self.pivots.push(piv);
        true
    }
}

/// Incremental rank over the field, for rows of a fixed length: an echelon form that is not
/// kept reduced. A row never changes once added, and each was reduced against every earlier
/// one, so a later row is 0 at every earlier pivot and reducing a new vector against the rows
/// in order clears every pivot: the rank of [`Echelon`] at about half its work (no row is
/// scaled or cleared after it is added), for callers that need the rank alone.
#[derive(Clone, Debug, Default)]
pub struct RankCounter {
    /// Rows in insertion order, each 0 at the earlier rows' pivots.
    rows: Vec<Vec<u64>>,
    /// Pivot column of each row.
    pivots: Vec<usize>,
    /// Inverse of each row's pivot entry.
    scales: Vec<u64>,
}

impl RankCounter {
    /// The rank so far.
    #[must_use]
    pub fn rank(&self) -> usize {
        self.rows.len()
    }

    /// The independent rows kept, in insertion order (each reduced against the earlier
    /// ones): a basis of the span of every row inserted.
    #[must_use]
    pub fn into_rows(self) -> Vec<Vec<u64>> {
        self.rows
    }

    /// Reduces `v` against the rows; adds it if independent. Returns whether it was added.
    pub fn insert(&mut self, mut v: Vec<u64>) -> bool {
        for ((row, &piv), &scale) in self.rows.iter().zip(&self.pivots).zip(&self.scales) {
            let f = mul(v[piv], scale);
            if f != 0 {
                for (x, &r) in v.iter_mut().zip(row) {
                    if r != 0 {
                        *x = sub(*x, mul(f, r));
                    }
                }
            }
        }
        let Some(piv) = v.iter().position(|&x| x != 0) else {
            return false;
        };
        self.scales.push(inv(v[piv]));
        self.rows.push(v);
        self.pivots.push(piv);
        true
    }
}

#[cfg(test)]
/// Rank of a dense matrix (rows) over the field.
#[must_use]
pub fn rank(rows: &[Vec<u64>]) -> usize {
    let mut e = Echelon::default();
    for r in rows {
        e.insert(r.clone());
    }
    e.rank()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_ops() {
        assert_eq!(mul(inv(7), 7), 1);
        assert_eq!(add(P - 1, 2), 1);
        let third = from_rational(&BigRational::new(1.into(), 3.into())).unwrap();
        assert_eq!(mul(third, 3), 1);
    }

    #[test]
    fn reconstructs_small_rationals() {
        for (n, d) in [(1i64, 2i64), (-3, 7), (0, 1), (12345, 678), (-1, 1)] {
            let r = BigRational::new(n.into(), d.into());
            assert_eq!(
                reconstruct(from_rational(&r).unwrap()),
                Some(Coef::from_big(r))
            );
        }
    }

    #[test]
    fn circle_points_are_on_the_circle() {
        let mut g = Rng::new(1);
        for _ in 0..10 {
            let (c, s) = g.circle_point();
            assert_eq!(add(mul(c, c), mul(s, s)), 1);
        }
    }

    #[test]
    fn echelon_rank() {
        let rows = vec![vec![1, 2, 3], vec![2, 4, 6], vec![0, 1, 1]];
        assert_eq!(rank(&rows), 2);
    }

    /// The unreduced counter's rank is the reduced form's after every row, on random
    /// matrices with planted dependencies (a row a combination of earlier ones) and columns
    /// left zero.
    #[test]
    fn rank_counter_agrees_with_the_reduced_form() {
        let mut g = Rng::new(7);
        for trial in 0..40 {
            let (n, len) = (3 + trial % 9, 2 + trial % 7);
            let mut rows: Vec<Vec<u64>> = Vec::new();
            for i in 0..n {
                let row: Vec<u64> = if i >= 2 && i % 3 == 0 {
                    let (a, b) = (g.element(), g.element());
                    rows[i - 1]
                        .iter()
                        .zip(&rows[i - 2])
                        .map(|(&x, &y)| add(mul(a, x), mul(b, y)))
                        .collect()
                } else {
                    (0..len)
                        .map(|c| if c % 4 == 3 { 0 } else { g.element() })
                        .collect()
                };
                rows.push(row);
            }
            let (mut e, mut r) = (Echelon::default(), RankCounter::default());
            for row in &rows {
                assert_eq!(
                    e.insert(row.clone()),
                    r.insert(row.clone()),
                    "trial {trial}"
                );
                assert_eq!(e.rank(), r.rank(), "trial {trial}");
            }
        }
    }
}
