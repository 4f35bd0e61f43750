//! The chain-factored model: `Φ̃(q)`, `c(p)` and `∂c/∂p` from small tables, `no_std`, no
//! allocation. Derived models and the run-time engine both evaluate through it, so its cost
//! grows with the chain and the basis, never with the flat expansion.
//!
//! # The factorisation
//! The chain ([`crate::model::chain`]) is a product of elementary motions
//! `T(q; p) = F_1 ⋯ F_m`. A joint's factor turns (or slides) by `q_i + β_i(p)`, and about one
//! axis `Rot(a, q + β) = Rot(a, β)·Rot(a, q)`, with
//!
//! `Rot(a, q) = P₀ + cos q·P_c + sin q·P_s`  (revolute),  `Trans(a, q) = I + q·N_a`  (prismatic),
//!
//! constant 4×4 matrices (`P₀` keeps the axis and the homogeneous coordinate, `P_c` the plane
//! normal to the axis, `P_s` is the generator of the rotation, `N_a` moves the homogeneous
//! coordinate onto the axis). Every other factor depends on `p` alone. So
//!
//! `T(q; p) = Σ_κ G_0 P_{1,κ₁} G_1 P_{2,κ₂} ⋯ P_{n,κₙ} G_n · φ_{κ₁}(q₁) ⋯ φ_{κₙ}(qₙ)`,
//!
//! a sum over multi-indices `κ` (one code per joint), with `G_j(p)` the products of the
//! parameter-only factors between joints. An equation of degree one in the tip is
//! `h_e = w_e(p)ᵀ·T·v_e`, of degree two `h_e = (T v_e)ᵀ Q_e(p) (T v_e)` (circle, sphere,
//! quadric), with `v_e` the tool point `(0,0,0,1)` or, for a measured pose's rotation entry
//! `R_ic`, the axis `(e_c, 0)`. Products of two joint functions are rewritten with
//! `sin² = 1 − cos²`, as the exact engine does, so a joint's codes are
//!
//! | code | revolute | prismatic |
//! |---|---|---|
//! | 0 | 1 | 1 |
//! | 1 | `cos q` | `q` |
//! | 2 | `sin q` | `q²` |
//! | 3 | `cos² q` | |
//! | 4 | `cos q·sin q` | |
//!
//! and the coefficient of the joint monomial `Π φ_{κᵢ}(qᵢ)` in `h_e` is the contraction
//! `C_{e,κ}(p) = w_eᵀ G_0 P_{κ₁} G_1 ⋯ P_{κₙ} G_n v_e` (for degree two, the same sandwich on
//! `Q_e` with each joint's step the sum of the pairs `P_kᵀ · P_l` whose product reduces to
//! the code). The basis is the exact column reduction `Φ̃_k = Σ_m R_{k,m}·m(q)` and the
//! generalized parameters are the coefficients at the pivot monomials,
//! `c_{e,k}(p) = C_{e,pivot(k)}(p)` (`symbolic::reduce`); [`Tables`] holds the pivots and
//! `R`'s nonzeros, as multi-indices.
//!
//! # Cost
//! `c(p)`: the pivots in lexicographic order share their prefixes (a trie walked with one
//! state per joint), so each pivot costs about one joint step and one segment per equation.
//! `∂c/∂p`, by the product rule: for each pivot a backward pass stores the state right of
//! every factor, and a forward pass reads `∂C/∂β_f = (r_f·S_f)·u_f` at each factor `f` whose
//! amount holds a parameter (`S_f` the factor's generator), and `∂C/∂value = (∂w_e/∂value)·u_0`
//! for the constraint's own values. Both are `O(K·E·m)`, not `O(K·E·P·terms)`.

use super::chain::{Axis, Factor};
use super::geometry::ConstraintKind;

/// The most joints a factored model holds (the trie's stack lives on the call stack).
pub const MAX_JOINTS: usize = 16;

/// A model's tables: everything the kernel reads besides `q`, `p` and the constraint values.
///
/// Derived models embed them as `static`s; the run-time engine builds them from its exact
/// reduction (`SymbolicModel::factored`).
#[derive(Clone, Copy, Debug)]
pub struct Tables<'a> {
    /// Tip coordinates (2 or 3).
    pub dim: usize,
    /// Joints `n`.
    pub joints: usize,
    /// The chain's elementary motions, base to tool; joint `i`'s factor is the only one with
    /// `joint == Some(i)`, and the joints' factors come in joint order.
    pub chain: &'a [Factor],
    /// Every constraint's kind.
    pub kinds: &'a [ConstraintKind],
    /// Start of each constraint's values in the concatenated values (and the total, last).
    pub offsets: &'a [usize],
    /// The constraint of each equation.
    pub equation_constraint: &'a [usize],
    /// The estimated parameter each constraint value is (`None`: fixed), concatenated as
    /// [`Tables::offsets`] says.
    pub value_params: &'a [Option<usize>],
    /// The pivot multi-indices, `K × n` codes, in lexicographic order.
    pub pivots: &'a [u8],
    /// The basis function of each pivot of [`Tables::pivots`].
    pub pivot_basis: &'a [u32],
    /// The monomials of `R`'s nonzeros, `T × n` codes, in lexicographic order.
    pub term_monomials: &'a [u8],
    /// The basis function of each term.
    pub term_basis: &'a [u32],
    /// The coefficient of each term (exact rationals rounded to `f64`).
    pub term_coefs: &'a [f64],
}

/// An elementary linear step of a contraction: a factor's motion, a joint's projection for one
/// code, or a factor's generator.
#[derive(Clone, Copy, Debug)]
enum Step {
    /// Rotation about the axis by the angle with this sine and cosine.
    Rot(usize, f64, f64),
    /// Translation along the axis.
    Trans(usize, f64),
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
const fn others(a: usize) -> (usize, usize) {
    ((a + 1) % 3, (a + 2) % 3)
}

impl Step {
    /// `r ← r·M` for a row vector.
    #[inline]
    fn row(self, r: &mut [f64; 4]) {
        match self {
            Step::Rot(a, s, c) => {
                let (b, d) = others(a);
                let (rb, rd) = (r[b], r[d]);
                r[b] = c * rb + s * rd;
                r[d] = c * rd - s * rb;
            }
            Step::Trans(a, t) => r[3] += t * r[a],
            Step::Keep(a) => {
                let (b, d) = others(a);
                r[b] = 0.0;
                r[d] = 0.0;
            }
            Step::Plane(a) => {
                r[a] = 0.0;
                r[3] = 0.0;
            }
            Step::Gen(a) => {
                let (b, d) = others(a);
                let (rb, rd) = (r[b], r[d]);
                *r = [0.0; 4];
                r[b] = rd;
                r[d] = -rb;
            }
            Step::Slide(a) => {
                let ra = r[a];
                *r = [0.0; 4];
                r[3] = ra;
            }
            Step::Id => {}
            Step::Zero => *r = [0.0; 4],
        }
    }

    /// `u ← M·u` for a column vector.
    #[inline]
    fn col(self, u: &mut [f64; 4]) {
        match self {
            Step::Rot(a, s, c) => {
                let (b, d) = others(a);
                let (ub, ud) = (u[b], u[d]);
                u[b] = c * ub - s * ud;
                u[d] = s * ub + c * ud;
            }
            Step::Trans(a, t) => u[a] += t * u[3],
            Step::Keep(_) | Step::Plane(_) => self.row(u),
            Step::Gen(a) => {
                let (b, d) = others(a);
                let (ub, ud) = (u[b], u[d]);
                *u = [0.0; 4];
                u[b] = -ud;
                u[d] = ub;
            }
            Step::Slide(a) => {
                let u3 = u[3];
                *u = [0.0; 4];
                u[a] = u3;
            }
            Step::Id => {}
            Step::Zero => *u = [0.0; 4],
        }
    }

    /// `X ← X·M` for a 4×4 matrix (row-major): the row step on every row.
    #[inline]
    fn right(self, x: &mut [f64; 16]) {
        for i in 0..4 {
            let mut r = [x[4 * i], x[4 * i + 1], x[4 * i + 2], x[4 * i + 3]];
            self.row(&mut r);
            x[4 * i..4 * i + 4].copy_from_slice(&r);
        }
    }

    /// `X ← Mᵀ·X`: the row step on every column.
    #[inline]
    fn left_t(self, x: &mut [f64; 16]) {
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
    fn left(self, x: &mut [f64; 16]) {
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
    fn right_t(self, x: &mut [f64; 16]) {
        for i in 0..4 {
            let mut u = [x[4 * i], x[4 * i + 1], x[4 * i + 2], x[4 * i + 3]];
            self.col(&mut u);
            x[4 * i..4 * i + 4].copy_from_slice(&u);
        }
    }
}

fn axis(a: Axis) -> usize {
    match a {
        Axis::X => 0,
        Axis::Y => 1,
        Axis::Z => 2,
    }
}

/// The parameter-only step of factor `f` at `p` (a joint's factor: its reading-free part).
fn fixed_step(f: &Factor, p: &[f64]) -> Step {
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
fn generator(f: &Factor) -> Step {
    if f.rotation {
        Step::Gen(axis(f.axis))
    } else {
        Step::Slide(axis(f.axis))
    }
}

/// A joint's projection for a degree-one code (`Zero` for a code of degree two).
fn projection(f: &Factor, code: u8) -> Step {
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
/// (`sin² = 1 − cos²`), for a joint's step of degree two.
fn pairs(revolute: bool, code: u8) -> &'static [(u8, u8, f64)] {
    match (revolute, code) {
        (true, 0) => &[(0, 0, 1.0), (2, 2, 1.0)],
        (true, 1) | (false, 1) => &[(0, 1, 1.0), (1, 0, 1.0)],
        (true, 2) => &[(0, 2, 1.0), (2, 0, 1.0)],
        (true, 3) => &[(1, 1, 1.0), (2, 2, -1.0)],
        (true, 4) => &[(1, 2, 1.0), (2, 1, 1.0)],
        (false, 0) => &[(0, 0, 1.0)],
        (false, 2) => &[(1, 1, 1.0)],
        _ => &[],
    }
}

/// The value of joint function `code` at reading `q` (see the module's table).
#[inline]
fn joint_function(revolute: bool, code: u8, sc: (f64, f64), q: f64) -> f64 {
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

/// How one equation reads the chain: the functional's degree, the constraint and the row
/// within it, and the probe vector `v_e`.
#[derive(Clone, Copy, Debug)]
struct Equation {
    degree: u8,
    kind: ConstraintKind,
    row: usize,
    /// Start of the constraint's values.
    offset: usize,
    constraint: usize,
    probe: [f64; 4],
}

/// A state of a contraction: a row vector (degree one) or a 4×4 form (degree two).
type State = [f64; 16];

fn dot(a: &State, b: &State, degree: u8) -> f64 {
    let n = if degree == 1 { 4 } else { 16 };
    a[..n].iter().zip(&b[..n]).map(|(x, y)| x * y).sum()
}

fn as4(x: &State) -> [f64; 4] {
    [x[0], x[1], x[2], x[3]]
}

fn set4(x: &mut State, r: [f64; 4]) {
    x[..4].copy_from_slice(&r);
}

/// `x ← x·M` on a forward state (`Mᵀ·x·M` for degree two).
fn forward(step: Step, x: &mut State, degree: u8) {
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
fn backward(step: Step, u: &mut State, degree: u8) {
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
fn forward_joint(f: &Factor, code: u8, x: &mut State, degree: u8) {
    if degree == 1 {
        forward(projection(f, code), x, 1);
        return;
    }
    let mut acc = [0.0; 16];
    for &(k, l, sign) in pairs(f.rotation, code) {
        // Pₖᵀ·X·Pₗ
        let mut t = *x;
        projection(f, l).right(&mut t);
        projection(f, k).left_t(&mut t);
        for (a, b) in acc.iter_mut().zip(&t) {
            *a += sign * b;
        }
    }
    *x = acc;
}

/// A joint's step for `code` on a backward state.
fn backward_joint(f: &Factor, code: u8, u: &mut State, degree: u8) {
    if degree == 1 {
        backward(projection(f, code), u, 1);
        return;
    }
    let mut acc = [0.0; 16];
    for &(k, l, sign) in pairs(f.rotation, code) {
        // Pₖ·U·Pₗᵀ
        let mut t = *u;
        projection(f, k).left(&mut t);
        projection(f, l).right_t(&mut t);
        for (a, b) in acc.iter_mut().zip(&t) {
            *a += sign * b;
        }
    }
    *u = acc;
}

/// `∂C/∂amount` at a factor: `⟨x·S + Sᵀ·x, u⟩` (degree two) or `(x·S)·u`.
fn derivative(gen: Step, x: &State, u: &State, degree: u8) -> f64 {
    if degree == 1 {
        let mut r = as4(x);
        gen.row(&mut r);
        return r.iter().zip(u).map(|(a, b)| a * b).sum();
    }
    let mut a = *x;
    gen.right(&mut a);
    let mut b = *x;
    gen.left_t(&mut b);
    a.iter().zip(&b).zip(u).map(|((a, b), u)| (a + b) * u).sum()
}

/// The functional of an equation at the constraint values `vals`: `w_e` (degree one, the
/// first four entries) or `Q_e` (degree two). With `wrt = Some(v)`, its derivative with
/// respect to value `v` instead. Matches [`crate::model::geometry::constraint_function`].
fn functional(eq: &Equation, dim: usize, vals: &[f64], wrt: Option<usize>) -> State {
    let mut w = [0.0; 16];
    let d = |i: usize| f64::from(u8::from(wrt == Some(i)));
    let val = |i: usize| if wrt.is_some() { d(i) } else { vals[i] };
    match eq.kind {
        ConstraintKind::Point => {
            if wrt.is_none() {
                w[eq.row] = 1.0;
            }
            w[3] = -val(eq.row);
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => {
            for i in 0..eq.kind.value_count(dim) {
                w[i] = val(i);
            }
            w[3] = if wrt.is_some() { 0.0 } else { 1.0 };
        }
        ConstraintKind::PlaneNormal => {
            for i in 0..3 {
                w[i] = val(i);
            }
            w[3] = -val(3);
        }
        ConstraintKind::Line3 => {
            for i in 0..3 {
                w[i] = val(3 * eq.row + i);
            }
            w[3] = if wrt.is_some() { 0.0 } else { 1.0 };
        }
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => {
            if wrt.is_none() {
                w[if eq.row < 3 { eq.row } else { (eq.row - 3) % 3 }] = 1.0;
            }
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            // ‖x − c‖² − r² = xᵀx − 2cᵀx + cᵀc − r²
            let mut corner = 0.0;
            for i in 0..dim {
                if wrt.is_none() {
                    w[5 * i] = 1.0;
                    corner += vals[i] * vals[i];
                } else {
                    corner += 2.0 * vals[i] * d(i);
                }
                w[4 * i + 3] = -val(i);
                w[12 + i] = -val(i);
            }
            corner -= if wrt.is_some() {
                2.0 * vals[dim] * d(dim)
            } else {
                vals[dim] * vals[dim]
            };
            w[15] = corner;
        }
        ConstraintKind::Quadric => {
            // xᵀAx + bᵀx + 1, A symmetrised.
            for i in 0..dim {
                for j in 0..dim {
                    let a = 0.5 * (val(i * dim + j) + val(j * dim + i));
                    w[4 * i + j] = a;
                }
                let b = 0.5 * val(dim * dim + i);
                w[4 * i + 3] = b;
                w[12 + i] = b;
            }
            w[15] = if wrt.is_some() { 0.0 } else { 1.0 };
        }
    }
    w
}

impl Tables<'_> {
    /// `K`.
    #[must_use]
    pub fn basis_size(&self) -> usize {
        self.pivot_basis.len()
    }

    /// Equations `E`.
    #[must_use]
    pub fn equation_count(&self) -> usize {
        self.equation_constraint.len()
    }

    /// Scratch `f64`s [`Tables::jacobian`] needs: 16 per factor.
    #[must_use]
    pub const fn scratch_len(factors: usize) -> usize {
        16 * factors
    }

    fn equation(&self, e: usize) -> Equation {
        let constraint = self.equation_constraint[e];
        let first = self
            .equation_constraint
            .iter()
            .position(|&c| c == constraint)
            .unwrap_or(e);
        let kind = self.kinds[constraint];
        let row = e - first;
        let degree = match kind {
            ConstraintKind::Circle | ConstraintKind::Sphere | ConstraintKind::Quadric => 2,
            _ => 1,
        };
        let mut probe = [0.0, 0.0, 0.0, 1.0];
        if kind == ConstraintKind::MeasuredPose && row >= 3 {
            // R_ic, column-major: entry 3 + 3c + i.
            probe = [0.0; 4];
            probe[(row - 3) / 3] = 1.0;
        }
        Equation {
            degree,
            kind,
            row,
            offset: self.offsets[constraint],
            constraint,
            probe,
        }
    }

    /// The chain index of each joint's factor.
    fn joint_factors(&self) -> [usize; MAX_JOINTS] {
        let mut at = [0; MAX_JOINTS];
        for (i, f) in self.chain.iter().enumerate() {
            if let Some(j) = f.joint {
                at[j] = i;
            }
        }
        at
    }

    /// The probe `v_e` as a backward state.
    fn probe_state(eq: &Equation) -> State {
        let mut u = [0.0; 16];
        if eq.degree == 1 {
            u[..4].copy_from_slice(&eq.probe);
        } else {
            for i in 0..4 {
                for j in 0..4 {
                    u[4 * i + j] = eq.probe[i] * eq.probe[j];
                }
            }
        }
        u
    }

    /// `c(p)`: `out[e*K + k] = c_{e,k}(p)`, `E·K` values, from the constraint values `vals`
    /// (every constraint's, concatenated as [`Tables::offsets`] says).
    ///
    /// # Panics
    /// If the tables are inconsistent or `out` is short (a programming error).
    pub fn generalized_params(&self, p: &[f64], vals: &[f64], out: &mut [f64]) {
        let (n, kk) = (self.joints, self.basis_size());
        let at = self.joint_factors();
        for e in 0..self.equation_count() {
            let eq = self.equation(e);
            let v = &vals[eq.offset..];
            let mut stack = [[0.0; 16]; MAX_JOINTS + 1];
            // Segment 0: the factors before the first joint.
            let mut x = functional(&eq, self.dim, v, None);
            let first = if n == 0 { self.chain.len() } else { at[0] };
            for f in &self.chain[..first] {
                forward(fixed_step(f, p), &mut x, eq.degree);
            }
            stack[0] = x;
            let mut prev: &[u8] = &[];
            for i in 0..kk {
                let codes = &self.pivots[i * n..(i + 1) * n];
                let from = codes.iter().zip(prev).take_while(|(a, b)| a == b).count();
                for j in from..n {
                    let mut x = stack[j];
                    let f = &self.chain[at[j]];
                    forward(fixed_step(f, p), &mut x, eq.degree);
                    forward_joint(f, codes[j], &mut x, eq.degree);
                    let end = if j + 1 < n {
                        at[j + 1]
                    } else {
                        self.chain.len()
                    };
                    for g in &self.chain[at[j] + 1..end] {
                        forward(fixed_step(g, p), &mut x, eq.degree);
                    }
                    stack[j + 1] = x;
                }
                prev = codes;
                let u = Self::probe_state(&eq);
                out[e * kk + self.pivot_basis[i] as usize] = dot(&stack[n], &u, eq.degree);
            }
        }
    }

    /// `∂c/∂p`: `out[(e*K + k)*P + j] = ∂c_{e,k}/∂p_j`, `E·K·P` values (every one written),
    /// with `P = p.len()`. `scratch` holds at least [`Tables::scratch_len`]`(chain.len())`.
    ///
    /// # Panics
    /// If the tables are inconsistent or a buffer is short (a programming error).
    pub fn jacobian(&self, p: &[f64], vals: &[f64], scratch: &mut [f64], out: &mut [f64]) {
        let (n, kk, np, m) = (self.joints, self.basis_size(), p.len(), self.chain.len());
        out[..self.equation_count() * kk * np].fill(0.0);
        for e in 0..self.equation_count() {
            let eq = self.equation(e);
            let v = &vals[eq.offset..];
            let w = functional(&eq, self.dim, v, None);
            let vparams = &self.value_params[eq.offset..self.offsets[eq.constraint + 1]];
            for i in 0..kk {
                let codes = &self.pivots[i * n..(i + 1) * n];
                let row = (e * kk + self.pivot_basis[i] as usize) * np;
                // Backward: the state right of every factor (after a joint's projection).
                let mut u = Self::probe_state(&eq);
                for (fi, f) in self.chain.iter().enumerate().rev() {
                    if let Some(j) = f.joint {
                        backward_joint(f, codes[j], &mut u, eq.degree);
                    }
                    scratch[16 * fi..16 * fi + 16].copy_from_slice(&u);
                    backward(fixed_step(f, p), &mut u, eq.degree);
                }
                // The constraint's own values: C is linear in the functional.
                for (vi, param) in vparams.iter().enumerate() {
                    if let Some(j) = *param {
                        let dw = functional(&eq, self.dim, v, Some(vi));
                        out[row + j] += dot(&dw, &u, eq.degree);
                    }
                }
                // Forward: each parameterised factor's derivative.
                let mut x = w;
                for (fi, f) in self.chain.iter().enumerate().take(m) {
                    forward(fixed_step(f, p), &mut x, eq.degree);
                    if f.terms.iter().any(Option::is_some) {
                        let mut uf = [0.0; 16];
                        uf.copy_from_slice(&scratch[16 * fi..16 * fi + 16]);
                        let dc = derivative(generator(f), &x, &uf, eq.degree);
                        for t in f.terms.iter().flatten() {
                            out[row + t.param] += t.coef * dc;
                        }
                    }
                    if let Some(j) = f.joint {
                        forward_joint(f, codes[j], &mut x, eq.degree);
                    }
                }
            }
        }
    }

    /// `Φ̃(q)`: `K` values, `Φ̃_k(q) = Σ R_{k,m}·m(q)` over the terms.
    ///
    /// # Panics
    /// If the tables are inconsistent or `out` is short (a programming error).
    pub fn basis(&self, q: &[f64], out: &mut [f64]) {
        let n = self.joints;
        out[..self.basis_size()].fill(0.0);
        let at = self.joint_factors();
        let mut trig = [(0.0, 1.0); MAX_JOINTS];
        let mut revolute = [true; MAX_JOINTS];
        for j in 0..n {
            revolute[j] = self.chain[at[j]].rotation;
            if revolute[j] {
                trig[j] = libm::sincos(q[j]);
            }
        }
        let mut prefix = [1.0; MAX_JOINTS + 1];
        let mut prev: &[u8] = &[];
        for t in 0..self.term_basis.len() {
            let codes = &self.term_monomials[t * n..(t + 1) * n];
            let from = codes.iter().zip(prev).take_while(|(a, b)| a == b).count();
            for j in from..n {
                prefix[j + 1] = prefix[j] * joint_function(revolute[j], codes[j], trig[j], q[j]);
            }
            prev = codes;
            out[self.term_basis[t] as usize] += self.term_coefs[t] * prefix[n];
        }
    }
}
