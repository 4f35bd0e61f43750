//! Forward-mode derivatives over the estimated parameters, in the integers modulo the prime
//! or in `f64`: a value with its gradient ([`Dual`]), and a spec's variables at one point as
//! duals ([`Point`]).

use super::super::coef::Coef;
use super::super::modp::Scalar;
use super::super::monomial::{Var, VarTable};
use super::super::poly::Poly;

/// A value with its gradient over the estimated parameters (empty: a constant).
#[derive(Clone, Debug)]
pub(super) struct Dual<T> {
    pub(super) v: T,
    pub(super) g: Vec<T>,
}

impl<T: Scalar> Dual<T> {
    pub(super) fn constant(v: T) -> Self {
        Dual { v, g: Vec::new() }
    }

    pub(super) fn add(&self, o: &Self) -> Self {
        Dual {
            v: self.v.add(o.v),
            g: zip_grad(&self.g, &o.g, |a, b| a.add(b)),
        }
    }

    pub(super) fn sub(&self, o: &Self) -> Self {
        Dual {
            v: self.v.sub(o.v),
            g: zip_grad(&self.g, &o.g, |a, b| a.sub(b)),
        }
    }

    pub(super) fn neg(&self) -> Self {
        Dual::constant(T::zero()).sub(self)
    }

    /// `k·self` for a constant `k`.
    pub(super) fn scale(&self, k: T) -> Self {
        Dual {
            v: self.v.mul(k),
            g: self.g.iter().map(|&x| x.mul(k)).collect(),
        }
    }

    /// `self += a·b` in place: `self.add(&a.mul(b))` to the bit, without a new gradient per
    /// product (a chain's transforms take tens of them per reading, and allocating their
    /// gradients was most of the analysis's time). Bit-identical when every non-empty
    /// gradient has the same length (the parameter count, as every gradient here has).
    pub(super) fn add_product(&mut self, a: &Self, b: &Self) {
        debug_assert!(
            {
                let n = self.g.len().max(a.g.len()).max(b.g.len());
                [&self.g, &a.g, &b.g]
                    .iter()
                    .all(|g| g.is_empty() || g.len() == n)
            },
            "gradients of different lengths"
        );
        self.v = self.v.add(a.v.mul(b.v));
        if self.g.is_empty() && a.g.is_empty() && b.g.is_empty() {
            return;
        }
        if self.g.is_empty() {
            self.g = vec![T::zero(); a.g.len().max(b.g.len())];
        }
        for (i, s) in self.g.iter_mut().enumerate() {
            // The product's gradient entry as `mul` forms it (an empty gradient is zeros).
            let p = match (a.g.get(i), b.g.get(i)) {
                (Some(&x), Some(&y)) => x.mul(b.v).add(y.mul(a.v)),
                (Some(&x), None) => x.mul(b.v),
                (None, Some(&y)) => y.mul(a.v),
                (None, None) => T::zero(),
            };
            *s = s.add(p);
        }
    }

    /// The product rule.
    pub(super) fn mul(&self, o: &Self) -> Self {
        let g = match (self.g.is_empty(), o.g.is_empty()) {
            (true, true) => Vec::new(),
            (false, true) => self.g.iter().map(|&x| x.mul(o.v)).collect(),
            (true, false) => o.g.iter().map(|&x| x.mul(self.v)).collect(),
            (false, false) => self
                .g
                .iter()
                .zip(&o.g)
                .map(|(&a, &b)| a.mul(o.v).add(b.mul(self.v)))
                .collect(),
        };
        Dual {
            v: self.v.mul(o.v),
            g,
        }
    }
}

/// `a ∘ b` entrywise, an empty gradient standing for zeros.
fn zip_grad<T: Scalar>(a: &[T], b: &[T], f: impl Fn(T, T) -> T) -> Vec<T> {
    match (a.is_empty(), b.is_empty()) {
        (true, true) => Vec::new(),
        (false, true) => a.iter().map(|&x| f(x, T::zero())).collect(),
        (true, false) => b.iter().map(|&x| f(T::zero(), x)).collect(),
        (false, false) => a.iter().zip(b).map(|(&x, &y)| f(x, y)).collect(),
    }
}

/// The values of every variable at one point, with the parameters' derivatives.
pub(super) struct Point<'a, T> {
    pub(super) vars: &'a VarTable,
    pub(super) vals: &'a [T],
    pub(super) np: usize,
}

impl<T: Scalar> Point<'_, T> {
    /// Variable `i` as a dual: `∂p_j/∂p_j = 1`, `∂cos p_j = −sin p_j`, `∂sin p_j = cos p_j`
    /// (values alone when `np` is 0).
    pub(super) fn var(&self, i: usize) -> Dual<T> {
        if self.np == 0 {
            return Dual::constant(self.vals[i]);
        }
        let unit = |j: usize, w: T| {
            let mut g = vec![T::zero(); self.np];
            g[j] = w;
            g
        };
        let g = match &self.vars.vars[i] {
            Var::ParamLength(j) => unit(*j, Self::one()),
            Var::ParamCos(j) => {
                let s = self.partner(i);
                unit(*j, T::zero().sub(self.vals[s]))
            }
            Var::ParamSin(j) => unit(*j, self.vals[self.partner(i)]),
            _ => Vec::new(),
        };
        Dual { v: self.vals[i], g }
    }

    pub(super) fn one() -> T {
        T::coef(&Coef::ONE).unwrap_or_else(T::zero)
    }

    /// The other variable of `i`'s `(cos, sin)` pair.
    fn partner(&self, i: usize) -> usize {
        self.vars
            .trig_pairs
            .iter()
            .find_map(|&(c, s)| {
                if c == i {
                    Some(s)
                } else if s == i {
                    Some(c)
                } else {
                    None
                }
            })
            .unwrap_or(i)
    }

    /// A slot polynomial (a constant, a variable, a product of a few) as a dual.
    pub(super) fn poly(&self, p: &Poly) -> Dual<T> {
        let mut acc = Dual::constant(T::zero());
        for (m, c) in &p.terms {
            let mut term = Dual::constant(T::coef(c).unwrap_or_else(T::zero));
            for (v, e) in m.factors() {
                let x = self.var(v);
                for _ in 0..e {
                    term = term.mul(&x);
                }
            }
            acc = acc.add(&term);
        }
        acc
    }

    pub(super) fn pair(&self, p: &(Poly, Poly)) -> (Dual<T>, Dual<T>) {
        (self.poly(&p.0), self.poly(&p.1))
    }
}
