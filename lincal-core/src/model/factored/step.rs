//! The elementary linear steps of a contraction (a factor's motion, a joint's projection, a
//! generator) on row and column states and on 4×4 forms, for [`super::Tables`].

use core::ops::{Add, Mul, Neg, Sub};

use crate::model::chain::{Axis, Factor};

/// The arithmetic a contraction needs: `f64` for numbers, and the integers modulo a prime for
/// the derive's certificate (`symbolic::certify`), which runs the same contraction exactly.
pub(crate) trait Ring:
    Copy + PartialEq + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// `0`.
    const ZERO: Self;
    /// `1`.
    const ONE: Self;
    /// `self / 2`.
    #[must_use]
    fn half(self) -> Self;
}

impl Ring for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline]
    fn half(self) -> Self {
        0.5 * self
    }
}

/// An elementary linear step of a contraction: a factor's motion, a joint's projection for one
/// code, or a factor's generator.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Step<S = f64> {
    /// Rotation about the axis by the angle with this sine and cosine.
    Rot(usize, S, S),
    /// Translation along the axis.
    Trans(usize, S),
    /// `P₀` of a revolute joint (keeps the axis and the homogeneous coordinate).
    Keep(usize),
    /// `P_c` of a revolute joint (keeps the plane normal to the axis).
    Plane(usize),
    /// `P_s`, the generator of a rotation about the axis.
    Gen(usize),
    /// `N_a`: a prismatic joint's reading, and the generator of a translation.
    Slide(usize),
    /// The identity (`P₀` of a prismatic joint).
    Id,
    /// Zero (a code of degree two in a degree-one contraction).
    Zero,
}

/// The two other axes, in cyclic order.
#[inline]
pub(super) const fn others(a: usize) -> (usize, usize) {
    ((a + 1) % 3, (a + 2) % 3)
}

impl<S: Ring> Step<S> {
    /// `r ← r·M` for a row vector.
    #[inline]
    pub(super) fn row(self, r: &mut [S; 4]) {
        match self {
            Step::Rot(a, s, c) => {
                let (b, d) = others(a);
                let (rb, rd) = (r[b], r[d]);
                r[b] = c * rb + s * rd;
                r[d] = c * rd - s * rb;
            }
            Step::Trans(a, t) => r[3] = r[3] + t * r[a],
            Step::Keep(a) => {
                let (b, d) = others(a);
                r[b] = S::ZERO;
                r[d] = S::ZERO;
            }
            Step::Plane(a) => {
                r[a] = S::ZERO;
                r[3] = S::ZERO;
            }
            Step::Gen(a) => {
                let (b, d) = others(a);
                let (rb, rd) = (r[b], r[d]);
                *r = [S::ZERO; 4];
                r[b] = rd;
                r[d] = -rb;
            }
            Step::Slide(a) => {
                let ra = r[a];
                *r = [S::ZERO; 4];
                r[3] = ra;
            }
            Step::Id => {}
            Step::Zero => *r = [S::ZERO; 4],
        }
    }

    /// `u ← M·u` for a column vector.
    #[inline]
    pub(super) fn col(self, u: &mut [S; 4]) {
        match self {
            Step::Rot(a, s, c) => {
                let (b, d) = others(a);
                let (ub, ud) = (u[b], u[d]);
                u[b] = c * ub - s * ud;
                u[d] = s * ub + c * ud;
            }
            Step::Trans(a, t) => u[a] = u[a] + t * u[3],
            Step::Keep(_) | Step::Plane(_) => self.row(u),
            Step::Gen(a) => {
                let (b, d) = others(a);
                let (ub, ud) = (u[b], u[d]);
                *u = [S::ZERO; 4];
                u[b] = -ud;
                u[d] = ub;
            }
            Step::Slide(a) => {
                let u3 = u[3];
                *u = [S::ZERO; 4];
                u[a] = u3;
            }
            Step::Id => {}
            Step::Zero => *u = [S::ZERO; 4],
        }
    }

    /// `X ← X·M` for a 4×4 matrix (row-major): the row step on every row.
    #[inline]
    pub(super) fn right(self, x: &mut [S; 16]) {
        for i in 0..4 {
            let mut r = [x[4 * i], x[4 * i + 1], x[4 * i + 2], x[4 * i + 3]];
            self.row(&mut r);
            x[4 * i..4 * i + 4].copy_from_slice(&r);
        }
    }

    /// `X ← Mᵀ·X`: the row step on every column.
    #[inline]
    pub(super) fn left_t(self, x: &mut [S; 16]) {
        for j in 0..4 {
            let mut r = [x[j], x[4 + j], x[8 + j], x[12 + j]];
            self.row(&mut r);
            for i in 0..4 {
                x[4 * i + j] = r[i];
            }
        }
    }

    /// `X ← M·X`: the column step on every column.
    #[inline]
    pub(super) fn left(self, x: &mut [S; 16]) {
        // A motion mixes two rows (a rotation) or adds one to another (a translation): row
        // operations, without a column gathered and scattered per entry.
        match self {
            Step::Rot(a, s, c) => {
                let (b, d) = others(a);
                for j in 0..4 {
                    let (xb, xd) = (x[4 * b + j], x[4 * d + j]);
                    x[4 * b + j] = c * xb - s * xd;
                    x[4 * d + j] = s * xb + c * xd;
                }
                return;
            }
            Step::Trans(a, t) => {
                for j in 0..4 {
                    x[4 * a + j] = x[4 * a + j] + t * x[12 + j];
                }
                return;
            }
            _ => {}
        }
        for j in 0..4 {
            let mut u = [x[j], x[4 + j], x[8 + j], x[12 + j]];
            self.col(&mut u);
            for i in 0..4 {
                x[4 * i + j] = u[i];
            }
        }
    }

    /// `X ← X·Mᵀ`: the column step on every row.
    #[inline]
    pub(super) fn right_t(self, x: &mut [S; 16]) {
        for i in 0..4 {
            let mut u = [x[4 * i], x[4 * i + 1], x[4 * i + 2], x[4 * i + 3]];
            self.col(&mut u);
            x[4 * i..4 * i + 4].copy_from_slice(&u);
        }
    }
}

pub(super) fn axis(a: Axis) -> usize {
    match a {
        Axis::X => 0,
        Axis::Y => 1,
        Axis::Z => 2,
    }
}

/// The parameter-only step of factor `f` at `p` (a joint's factor: its reading-free part).
pub(super) fn fixed_step(f: &Factor, p: &[f64]) -> Step {
    let mut v = f.constant;
    for t in f.terms.iter().flatten() {
        v += t.coef * p[t.param];
    }
    if f.rotation {
        let (s, c) = libm::sincos(v);
        Step::Rot(axis(f.axis), s, c)
    } else {
        Step::Trans(axis(f.axis), v)
    }
}

/// The generator `S` of factor `f`'s motion: `∂M/∂amount = M·S`.
pub(super) fn generator<S: Ring>(f: &Factor) -> Step<S> {
    if f.rotation {
        Step::Gen(axis(f.axis))
    } else {
        Step::Slide(axis(f.axis))
    }
}

/// A joint's projection for a degree-one code (`Zero` for a code of degree two).
pub(super) fn projection<S: Ring>(f: &Factor, code: u8) -> Step<S> {
    let a = axis(f.axis);
    match (f.rotation, code) {
        (true, 0) => Step::Keep(a),
        (true, 1) => Step::Plane(a),
        (true, 2) => Step::Gen(a),
        (false, 0) => Step::Id,
        (false, 1) => Step::Slide(a),
        _ => Step::Zero,
    }
}

/// The pairs `(k, l, sign)` of degree-one codes whose product `φ_k·φ_l` reduces to `code`
/// (`sin² = 1 − cos²`), for a joint's step of degree two; `false`: subtracted.
pub(super) fn pairs(revolute: bool, code: u8) -> &'static [(u8, u8, bool)] {
    match (revolute, code) {
        (true, 0) => &[(0, 0, true), (2, 2, true)],
        (true, 1) | (false, 1) => &[(0, 1, true), (1, 0, true)],
        (true, 2) => &[(0, 2, true), (2, 0, true)],
        (true, 3) => &[(1, 1, true), (2, 2, false)],
        (true, 4) => &[(1, 2, true), (2, 1, true)],
        (false, 0) => &[(0, 0, true)],
        (false, 2) => &[(1, 1, true)],
        _ => &[],
    }
}

/// The value of joint function `code` at reading `q` (see the module's table).
#[inline]
pub(super) fn joint_function(revolute: bool, code: u8, sc: (f64, f64), q: f64) -> f64 {
    let (s, c) = sc;
    match (revolute, code) {
        (_, 0) => 1.0,
        (true, 1) => c,
        (true, 2) => s,
        (true, 3) => c * c,
        (true, 4) => c * s,
        (false, 1) => q,
        (false, 2) => q * q,
        _ => 0.0,
    }
}

/// A state of a contraction: a row vector (degree one) or a 4×4 form (degree two).
pub(super) type State<S = f64> = [S; 16];

#[inline]
pub(super) fn dot<S: Ring>(a: &State<S>, b: &State<S>, degree: u8) -> S {
    let n = if degree == 1 { 4 } else { 16 };
    a[..n]
        .iter()
        .zip(&b[..n])
        .fold(S::ZERO, |acc, (&x, &y)| acc + x * y)
}

pub(super) fn as4<S: Ring>(x: &State<S>) -> [S; 4] {
    [x[0], x[1], x[2], x[3]]
}

pub(super) fn set4<S: Ring>(x: &mut State<S>, r: [S; 4]) {
    x[..4].copy_from_slice(&r);
}

/// `x ← x·M` on a forward state (`Mᵀ·x·M` for degree two).
pub(super) fn forward<S: Ring>(step: Step<S>, x: &mut State<S>, degree: u8) {
    if degree == 1 {
        let mut r = as4(x);
        step.row(&mut r);
        set4(x, r);
    } else {
        step.right(x);
        step.left_t(x);
    }
}

/// `u ← M·u` on a backward state (`M·u·Mᵀ` for degree two).
pub(super) fn backward<S: Ring>(step: Step<S>, u: &mut State<S>, degree: u8) {
    if degree == 1 {
        let mut v = as4(u);
        step.col(&mut v);
        set4(u, v);
    } else {
        step.left(u);
        step.right_t(u);
    }
}

/// A joint's step for `code` on a forward state.
pub(super) fn forward_joint<S: Ring>(f: &Factor, code: u8, x: &mut State<S>, degree: u8) {
    if degree == 1 {
        forward(projection(f, code), x, 1);
        return;
    }
    let mut acc = [S::ZERO; 16];
    for &(k, l, plus) in pairs(f.rotation, code) {
        // Pₖᵀ·X·Pₗ
        let mut t = *x;
        projection(f, l).right(&mut t);
        projection(f, k).left_t(&mut t);
        accumulate(&mut acc, &t, plus);
    }
    *x = acc;
}

/// A joint's step for `code` on a backward state.
pub(super) fn backward_joint<S: Ring>(f: &Factor, code: u8, u: &mut State<S>, degree: u8) {
    if degree == 1 {
        backward(projection(f, code), u, 1);
        return;
    }
    let mut acc = [S::ZERO; 16];
    for &(k, l, plus) in pairs(f.rotation, code) {
        // Pₖ·U·Pₗᵀ
        let mut t = *u;
        projection(f, k).left(&mut t);
        projection(f, l).right_t(&mut t);
        accumulate(&mut acc, &t, plus);
    }
    *u = acc;
}

/// `acc ← acc ± t`.
#[inline]
fn accumulate<S: Ring>(acc: &mut State<S>, t: &State<S>, plus: bool) {
    for (a, &b) in acc.iter_mut().zip(t) {
        *a = if plus { *a + b } else { *a - b };
    }
}

/// `∂C/∂amount` at a factor: `⟨x·S + Sᵀ·x, u⟩` (degree two) or `(x·S)·u`.
pub(super) fn derivative<S: Ring>(gen: Step<S>, x: &State<S>, u: &State<S>, degree: u8) -> S {
    if degree == 1 {
        let mut r = as4(x);
        gen.row(&mut r);
        return r.iter().zip(u).fold(S::ZERO, |acc, (&a, &b)| acc + a * b);
    }
    let mut a = *x;
    gen.right(&mut a);
    let mut b = *x;
    gen.left_t(&mut b);
    a.iter()
        .zip(&b)
        .zip(u)
        .fold(S::ZERO, |acc, ((&a, &b), &u)| acc + (a + b) * u)
}
