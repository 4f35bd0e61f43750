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

/// The most elementary motions in a factored model's chain (their prepared steps live on the
/// call stack).
pub const MAX_FACTORS: usize = 128;

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
    /// The pivot multi-indices in colexicographic order (sorted by the last
    /// joint's code first): consecutive pivots share a suffix of the chain. Each packed in
    /// one `u64`, joint `j`'s code in bits `3j..3j+3` ([`pack`]).
    pub pivots: &'a [u64],
    /// The basis function of each pivot of [`Tables::pivots`].
    pub pivot_basis: &'a [u32],
    /// The monomials of `R`'s nonzeros in lexicographic order, packed as the pivots.
    pub term_monomials: &'a [u64],
    /// How many leading codes each term shares with the term before it (0 for the first):
    /// the prefix products the trie keeps.
    pub term_shared: &'a [u8],
    /// The basis function of each term.
    pub term_basis: &'a [u32],
    /// The coefficient of each term (exact rationals rounded to `f64`).
    pub term_coefs: &'a [f64],
}

/// A multi-index packed in one `u64`: joint `j`'s code in bits `3j..3j+3` (codes are below
/// 5, joints at most [`MAX_JOINTS`]).
#[must_use]
pub fn pack(codes: &[u8]) -> u64 {
    codes
        .iter()
        .enumerate()
        .fold(0, |acc, (j, &c)| acc | (u64::from(c) << (3 * j)))
}

/// The codes of a packed multi-index of `n` joints.
#[must_use]
pub fn unpack(packed: u64, n: usize) -> [u8; MAX_JOINTS] {
    let mut codes = [0; MAX_JOINTS];
    for (j, c) in codes.iter_mut().enumerate().take(n) {
        *c = ((packed >> (3 * j)) & 7) as u8;
    }
    codes
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
        let mut first = e;
        while first > 0 && self.equation_constraint[first - 1] == constraint {
            first -= 1;
        }
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

    /// Every factor's parameter-only step at `p` (sine and cosine once per call).
    fn steps(&self, p: &[f64]) -> [Step; MAX_FACTORS] {
        assert!(
            self.chain.len() <= MAX_FACTORS,
            "a chain of more than {MAX_FACTORS} factors"
        );
        let mut steps = [Step::Id; MAX_FACTORS];
        for (s, f) in steps.iter_mut().zip(self.chain) {
            *s = fixed_step(f, p);
        }
        steps
    }

    /// The probes, as `(degree, coordinate set to one)`: the tool point of degree one and
    /// two, and the three axes of a measured pose's rotation.
    const PROBES: [(u8, usize); 5] = [(1, 3), (2, 3), (1, 0), (1, 1), (1, 2)];

    /// Whether equation `eq` reads the chain through the probe `(degree, axis)`.
    fn reads(eq: &Equation, (degree, axis): (u8, usize)) -> bool {
        eq.degree == degree && eq.probe[axis] == 1.0
    }

    /// The backward state of a pivot whose codes' last `keep` joints equal the previous
    /// pivot's: `stack[j]` covers every factor right of joint `j − 1`'s, and is recomputed
    /// from joint `n − keep − 1` down to `0` (`stack[0]`, the whole chain, is the result).
    fn backward_trie(
        &self,
        at: &[usize; MAX_JOINTS],
        codes: &[u8],
        keep: usize,
        steps: &[Step],
        degree: u8,
        stack: &mut [State; MAX_JOINTS + 1],
    ) {
        let n = self.joints;
        for j in (0..n - keep).rev() {
            let mut u = stack[j + 1];
            let f = &self.chain[at[j]];
            backward_joint(f, codes[j], &mut u, degree);
            backward(steps[at[j]], &mut u, degree);
            let start = if j == 0 { 0 } else { at[j - 1] + 1 };
            for s in steps[start..at[j]].iter().rev() {
                backward(*s, &mut u, degree);
            }
            stack[j] = u;
        }
    }

    /// The common suffix length of two pivots' codes.
    fn shared_suffix(a: &[u8], b: &[u8]) -> usize {
        a.iter()
            .rev()
            .zip(b.iter().rev())
            .take_while(|(x, y)| x == y)
            .count()
    }

    /// `c(p)`: `out[e*K + k] = c_{e,k}(p)`, `E·K` values, from the constraint values `vals`
    /// (every constraint's, concatenated as [`Tables::offsets`] says).
    ///
    /// Each pivot's backward state `u = P_{κ₁} G_1 ⋯ v` is shared by every equation of the
    /// same probe (`c_{e,κ} = w_e·u`), and consecutive pivots share a suffix of the chain.
    ///
    /// # Panics
    /// If the tables are inconsistent or `out` is short (a programming error).
    pub fn generalized_params(&self, p: &[f64], vals: &[f64], out: &mut [f64]) {
        let (n, kk, m, ne) = (
            self.joints,
            self.basis_size(),
            self.chain.len(),
            self.equation_count(),
        );
        let at = self.joint_factors();
        let steps = self.steps(p);
        for probe in Self::PROBES {
            // The group's functionals, 32 equations at a time.
            let mut e0 = 0;
            while e0 < ne {
                let mut ws = [[0.0; 16]; 32];
                let mut rows = [0usize; 32];
                let mut count = 0;
                let mut e = e0;
                let mut degree = 1;
                while e < ne && count < 32 {
                    let eq = self.equation(e);
                    if Self::reads(&eq, probe) {
                        ws[count] = functional(&eq, self.dim, &vals[eq.offset..], None);
                        rows[count] = e;
                        degree = eq.degree;
                        count += 1;
                    }
                    e += 1;
                }
                e0 = e;
                if count == 0 {
                    continue;
                }
                let first = self.equation(rows[0]);
                let mut stack = [[0.0; 16]; MAX_JOINTS + 1];
                let mut u = Self::probe_state(&first);
                let last = if n == 0 { 0 } else { at[n - 1] + 1 };
                for s in steps[last..m].iter().rev() {
                    backward(*s, &mut u, degree);
                }
                stack[n] = u;
                let mut prev = [0u8; MAX_JOINTS];
                for i in 0..kk {
                    let unpacked = unpack(self.pivots[i], n);
                    let codes = &unpacked[..n];
                    let keep = if i == 0 {
                        0
                    } else {
                        Self::shared_suffix(codes, &prev[..n])
                    };
                    self.backward_trie(&at, codes, keep, &steps, degree, &mut stack);
                    prev = unpacked;
                    let k = self.pivot_basis[i] as usize;
                    for (w, &e) in ws.iter().zip(&rows).take(count) {
                        out[e * kk + k] = dot(w, &stack[0], degree);
                    }
                }
            }
        }
    }

    /// `∂c/∂p`: `out[(e*K + k)*P + j] = ∂c_{e,k}/∂p_j`, `E·K·P` values (every one written),
    /// with `P = p.len()`. `scratch` holds at least [`Tables::scratch_len`]`(chain.len())`.
    ///
    /// # Panics
    /// If the tables are inconsistent or a buffer is short (a programming error).
    pub fn jacobian(&self, p: &[f64], vals: &[f64], scratch: &mut [f64], out: &mut [f64]) {
        let (n, kk, np, ne) = (
            self.joints,
            self.basis_size(),
            p.len(),
            self.equation_count(),
        );
        out[..ne * kk * np].fill(0.0);
        let steps = self.steps(p);
        // The backward states depend on the probe alone: one pass per probe and pivot,
        // shared by every equation that reads it.
        for probe in Self::PROBES {
            let Some(first) = (0..ne)
                .map(|e| self.equation(e))
                .find(|eq| Self::reads(eq, probe))
            else {
                continue;
            };
            let mut prev = [0u8; MAX_JOINTS];
            for i in 0..kk {
                let unpacked = unpack(self.pivots[i], n);
                let codes = &unpacked[..n];
                let keep = if i == 0 {
                    0
                } else {
                    Self::shared_suffix(codes, &prev[..n])
                };
                prev = unpacked;
                let u0 = self.backward_pass(&first, codes, keep, &steps, scratch);
                for e in 0..ne {
                    let eq = self.equation(e);
                    if !Self::reads(&eq, probe) {
                        continue;
                    }
                    let row = (e * kk + self.pivot_basis[i] as usize) * np;
                    self.accumulate(
                        &eq,
                        codes,
                        vals,
                        &steps,
                        scratch,
                        &u0,
                        &mut out[row..row + np],
                    );
                }
            }
        }
    }

    /// The backward pass of one pivot: the state right of every factor into `scratch` (after
    /// a joint's projection), and the whole contraction's state `u₀`. With `keep` last
    /// joints' codes equal to those of the pivot the scratch holds, the states right of them
    /// are kept.
    fn backward_pass(
        &self,
        eq: &Equation,
        codes: &[u8],
        keep: usize,
        steps: &[Step],
        scratch: &mut [f64],
    ) -> State {
        let (n, m) = (self.joints, self.chain.len());
        let (mut u, start) = if keep == 0 || keep >= n {
            (Self::probe_state(eq), m)
        } else {
            let at = self.joint_factors();
            let start = at[n - keep - 1] + 1;
            let mut u = [0.0; 16];
            u.copy_from_slice(&scratch[16 * start..16 * start + 16]);
            backward(steps[start], &mut u, eq.degree);
            (u, start)
        };
        for fi in (0..start).rev() {
            let f = &self.chain[fi];
            if let Some(j) = f.joint {
                backward_joint(f, codes[j], &mut u, eq.degree);
            }
            scratch[16 * fi..16 * fi + 16].copy_from_slice(&u);
            backward(steps[fi], &mut u, eq.degree);
        }
        u
    }

    /// One equation's derivatives at one pivot, added into `row` (`P` values), from the
    /// backward states of [`Tables::backward_pass`].
    #[allow(clippy::too_many_arguments)]
    fn accumulate(
        &self,
        eq: &Equation,
        codes: &[u8],
        vals: &[f64],
        steps: &[Step],
        scratch: &[f64],
        u0: &State,
        row: &mut [f64],
    ) {
        let v = &vals[eq.offset..];
        // The constraint's own values: C is linear in the functional.
        let vparams = &self.value_params[eq.offset..self.offsets[eq.constraint + 1]];
        for (vi, param) in vparams.iter().enumerate() {
            if let Some(j) = *param {
                let dw = functional(eq, self.dim, v, Some(vi));
                row[j] += dot(&dw, u0, eq.degree);
            }
        }
        // Forward: each parameterised factor's derivative.
        let mut x = functional(eq, self.dim, v, None);
        for (fi, f) in self.chain.iter().enumerate() {
            forward(steps[fi], &mut x, eq.degree);
            if f.terms.iter().any(Option::is_some) {
                let mut uf = [0.0; 16];
                uf.copy_from_slice(&scratch[16 * fi..16 * fi + 16]);
                let dc = derivative(generator(f), &x, &uf, eq.degree);
                for t in f.terms.iter().flatten() {
                    row[t.param] += t.coef * dc;
                }
            }
            if let Some(j) = f.joint {
                forward_joint(f, codes[j], &mut x, eq.degree);
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
        // Every joint function's value once.
        let mut table = [[0.0; 5]; MAX_JOINTS];
        for j in 0..n {
            let revolute = self.chain[at[j]].rotation;
            let sc = if revolute {
                libm::sincos(q[j])
            } else {
                (0.0, 1.0)
            };
            for (code, v) in table[j].iter_mut().enumerate() {
                *v = joint_function(revolute, code as u8, sc, q[j]);
            }
        }
        let mut prefix = [1.0; MAX_JOINTS + 1];
        for t in 0..self.term_basis.len() {
            let codes = self.term_monomials[t];
            for j in self.term_shared[t] as usize..n {
                prefix[j + 1] = prefix[j] * table[j][((codes >> (3 * j)) & 7) as usize];
            }
            out[self.term_basis[t] as usize] += self.term_coefs[t] * prefix[n];
        }
    }
}
