//! Monomials over the engine's variables, packed as 4-bit exponents.
//!
//! Variables are numbered by a [`VarTable`]: joint variables first (`cos q_i`, `sin q_i` of
//! revolute joints, `q_k` of prismatic ones), then parameter variables (lengths, and
//! `cos p`, `sin p` of angle parameters), then constant symbols (known angles whose cosine is
//! not rational). A monomial is a product of variables with exponents 0..=15, packed into
//! eight 64-bit words, so multiplying monomials is word-wise addition.

use std::fmt;

/// Number of 64-bit words in a monomial.
pub(crate) const WORDS: usize = 8;
/// Maximum number of variables (4 bits each).
pub const MAX_VARS: usize = WORDS * 16;

/// A monomial: exponent `0..=15` per variable.
#[derive(Clone, Copy, Eq, PartialOrd, Ord, Default)]
pub struct Mono([u64; WORDS]);

// Equality and hashing by hand: the derived ones call `memcmp` and feed eight words to the
// hasher, where the expansion's hash maps (tens of thousands of lookups a model) want one
// branch-free comparison and one word.
impl PartialEq for Mono {
    #[inline]
    fn eq(&self, o: &Mono) -> bool {
        self.0
            .iter()
            .zip(&o.0)
            .fold(0u64, |acc, (a, b)| acc | (a ^ b))
            == 0
    }
}

impl std::hash::Hash for Mono {
    #[inline]
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        state.write_u64(self.fingerprint());
    }
}

impl Mono {
    /// The constant monomial `1`.
    pub const ONE: Mono = Mono([0; WORDS]);

    /// A well-mixed 64-bit digest of the exponents (each word folded in with a multiply and
    /// a xor-shift, as splitmix64 finishes). Equal monomials have equal fingerprints; two
    /// different ones share one with probability about `2⁻⁶⁴`, so users that key a table by
    /// it compare the monomials on a hit.
    #[must_use]
    #[inline]
    pub fn fingerprint(&self) -> u64 {
        let mut h = 0x9e37_79b9_7f4a_7c15u64;
        for &w in &self.0 {
            h = (h ^ w).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h ^= h >> 31;
        }
        h = h.wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^ (h >> 29)
    }

    /// The monomial `v^1`.
    #[must_use]
    pub fn var(v: usize) -> Mono {
        let mut m = Mono::ONE;
        m.set(v, 1);
        m
    }

    /// Exponent of variable `v`.
    #[must_use]
    #[inline]
    pub fn get(&self, v: usize) -> u32 {
        ((self.0[v / 16] >> ((v % 16) * 4)) & 0xF) as u32
    }

    /// Sets the exponent of variable `v` (must be ≤ 15).
    #[inline]
    pub fn set(&mut self, v: usize, e: u32) {
        debug_assert!(e <= 15);
        let shift = (v % 16) * 4;
        let w = &mut self.0[v / 16];
        *w = (*w & !(0xF << shift)) | (u64::from(e) << shift);
    }

    /// The product, or `None` when an exponent would exceed 15.
    #[must_use]
    #[inline]
    pub fn mul(&self, o: &Mono) -> Option<Mono> {
        const NIBBLE_LOW: u64 = 0x1111_1111_1111_1110;
        let mut out = [0u64; WORDS];
        for ((o, &a), &b) in out.iter_mut().zip(&self.0).zip(&o.0) {
            let (s, overflow) = a.overflowing_add(b);
            // A carry out of a nibble flips the low bit of the next one relative to a ^ b.
            if overflow || (a ^ b ^ s) & NIBBLE_LOW != 0 {
                return None;
            }
            *o = s;
        }
        Some(Mono(out))
    }

    /// Whether this is the constant monomial.
    #[must_use]
    pub fn is_one(&self) -> bool {
        self.0 == [0; WORDS]
    }

    /// Total degree.
    #[must_use]
    #[inline]
    pub fn degree(&self) -> u32 {
        // Nibble sums by SWAR: pairs of nibbles into bytes (each ≤ 30), then all bytes of a
        // word (≤ 240, so no byte overflows) gathered in the top byte by one multiplication.
        self.0
            .iter()
            .map(|&w| {
                let b = (w & 0x0F0F_0F0F_0F0F_0F0F) + ((w >> 4) & 0x0F0F_0F0F_0F0F_0F0F);
                (b.wrapping_mul(0x0101_0101_0101_0101) >> 56) as u32
            })
            .sum()
    }

    /// The raw packed words (variable `v` in word `v / 16`, bits `4·(v % 16)..`).
    #[must_use]
    #[inline]
    pub fn words(&self) -> &[u64; WORDS] {
        &self.0
    }

    /// The part of the monomial in variables `< split` (first) and `>= split` (second).
    #[must_use]
    pub fn split(&self, split: usize) -> (Mono, Mono) {
        let mut lo = Mono::ONE;
        let mut hi = *self;
        for (i, (l, h)) in lo.0.iter_mut().zip(hi.0.iter_mut()).enumerate() {
            let first = i * 16;
            let mask = if split >= first + 16 {
                u64::MAX
            } else if split <= first {
                0
            } else {
                (1u64 << ((split - first) * 4)) - 1
            };
            *l = *h & mask;
            *h &= !mask;
        }
        (lo, hi)
    }

    /// Number of variables present.
    #[must_use]
    #[inline]
    pub fn factor_count(&self) -> usize {
        self.0
            .iter()
            .map(|&w| {
                let any = (w | (w >> 1) | (w >> 2) | (w >> 3)) & 0x1111_1111_1111_1111;
                any.count_ones() as usize
            })
            .sum()
    }

    /// `(variable, exponent)` for every variable present, in variable order.
    pub fn factors(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        // Skips empty words and nibbles: a monomial has few factors among many variables.
        self.0.iter().enumerate().flat_map(|(i, &w)| {
            let mut w = w;
            std::iter::from_fn(move || {
                if w == 0 {
                    return None;
                }
                let nib = (w.trailing_zeros() / 4) as usize;
                let e = ((w >> (nib * 4)) & 0xF) as u32;
                w &= !(0xF << (nib * 4));
                Some((i * 16 + nib, e))
            })
        })
    }
}

impl fmt::Debug for Mono {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v: Vec<String> = self.factors().map(|(v, e)| format!("x{v}^{e}")).collect();
        write!(f, "Mono({})", v.join("*"))
    }
}

/// What a variable stands for.
#[derive(Clone, Debug, PartialEq)]
pub enum Var {
    /// `cos q_i` of revolute joint `i` (0-based).
    JointCos(usize),
    /// `sin q_i` of revolute joint `i`.
    JointSin(usize),
    /// `q_i` of prismatic joint `i`.
    JointLinear(usize),
    /// Estimated length parameter, by index into the estimated-parameter vector `p`.
    ParamLength(usize),
    /// `cos p_j` of estimated angle parameter `j`.
    ParamCos(usize),
    /// `sin p_j` of estimated angle parameter `j`.
    ParamSin(usize),
    /// `cos` of a known angle with an irrational cosine (kept symbolic; its value and label).
    ConstCos(f64, String),
    /// `sin` of the same.
    ConstSin(f64, String),
    /// A known length that is not rational (e.g. a multiple of π), kept symbolic.
    ConstLength(f64, String),
}

/// The variables of one symbolic model, joint variables first.
#[derive(Clone, Debug, Default)]
pub struct VarTable {
    /// Every variable, by index.
    pub vars: Vec<Var>,
    /// `(cos, sin)` variable pairs, reduced with `cos² + sin² = 1`.
    pub trig_pairs: Vec<(usize, usize)>,
    /// Number of joint variables (they come first).
    pub joint_vars: usize,
}

impl VarTable {
    /// Adds a variable and returns its index.
    pub fn push(&mut self, v: Var) -> usize {
        self.vars.push(v);
        self.vars.len() - 1
    }

    /// Adds a `(cos, sin)` pair and returns both indices.
    pub fn push_pair(&mut self, c: Var, s: Var) -> (usize, usize) {
        let ci = self.push(c);
        let si = self.push(s);
        self.trig_pairs.push((ci, si));
        (ci, si)
    }

    /// Display name of a variable, given joint numbering from 1 and parameter names.
    #[must_use]
    pub fn name(&self, v: usize, param_names: &[String]) -> String {
        match &self.vars[v] {
            Var::JointCos(i) => format!("c{}", i + 1),
            Var::JointSin(i) => format!("s{}", i + 1),
            Var::JointLinear(i) => format!("q{}", i + 1),
            Var::ParamLength(j) => param_names[*j].clone(),
            Var::ParamCos(j) => format!("cos({})", param_names[*j]),
            Var::ParamSin(j) => format!("sin({})", param_names[*j]),
            Var::ConstCos(_, l) => format!("cos({l})"),
            Var::ConstSin(_, l) => format!("sin({l})"),
            Var::ConstLength(_, l) => format!("({l})"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mul_adds_exponents_and_detects_overflow() {
        let mut a = Mono::ONE;
        a.set(3, 2);
        a.set(70, 1);
        let mut b = Mono::ONE;
        b.set(3, 5);
        let c = a.mul(&b).unwrap();
        assert_eq!(c.get(3), 7);
        assert_eq!(c.get(70), 1);
        let mut big = Mono::ONE;
        big.set(15, 15);
        assert!(big.mul(&Mono::var(15)).is_none());
        big.set(16, 0);
        let mut top = Mono::ONE;
        top.set(127, 15);
        assert!(top.mul(&Mono::var(127)).is_none());
    }

    #[test]
    fn degree_and_factors_match_the_definition() {
        let mut m = Mono::ONE;
        for (v, e) in [(0, 15), (15, 3), (16, 1), (63, 15), (64, 2), (127, 15)] {
            m.set(v, e);
        }
        assert_eq!(m.degree(), 51);
        let f: Vec<(usize, u32)> = m.factors().collect();
        let slow: Vec<(usize, u32)> = (0..MAX_VARS)
            .filter_map(|v| (m.get(v) > 0).then_some((v, m.get(v))))
            .collect();
        assert_eq!(f, slow);
        assert_eq!(m.factor_count(), slow.len());
        for at in [0, 5, 16, 17, 64, 100, 128] {
            let (lo, hi) = m.split(at);
            for v in 0..MAX_VARS {
                let (l, h) = if v < at { (m.get(v), 0) } else { (0, m.get(v)) };
                assert_eq!((lo.get(v), hi.get(v)), (l, h));
            }
        }
    }

    #[test]
    fn split_separates_joint_part() {
        let mut m = Mono::ONE;
        m.set(1, 1);
        m.set(5, 2);
        let (lo, hi) = m.split(3);
        assert_eq!((lo.get(1), lo.get(5), hi.get(1), hi.get(5)), (1, 0, 0, 2));
    }
}
