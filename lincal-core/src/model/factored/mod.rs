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
//! `c(p)`: the pivots in colexicographic order share their suffixes (a trie walked with one
//! state per joint), so each pivot costs about one joint step and one segment per equation.
//! Degree-one equations walk fused steps (the private `fused` module): the factors between
//! two joints and the joint's projection in one product of two columns, the base folded into
//! the functional, so a pivot costs about eight products and two per equation; their
//! `∂c/∂p` takes each factor's derivative of its joint's fused step, formed once per call.
//! `∂c/∂p`, by the product rule: for each pivot a backward pass stores the state right of
//! every factor, and a forward pass reads `∂C/∂β_f = (r_f·S_f)·u_f` at each factor `f` whose
//! amount holds a parameter (`S_f` the factor's generator), and `∂C/∂value = (∂w_e/∂value)·u_0`
//! for the constraint's own values. Both are `O(K·E·m)`, not `O(K·E·P·terms)`.

mod functional;
mod fused;
mod step;

use super::chain::Factor;
use super::geometry::ConstraintKind;
use functional::{functional, Equation};
use fused::Fused;
use step::{
    backward, backward_joint, derivative, dot, fixed_step, forward, forward_joint, generator,
    joint_function, State,
};
pub(crate) use step::{Ring, Step};

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
    /// When `R` is a permutation of a full grid of joint monomials (a chain whose every
    /// parameter is unknown: no two monomials share a coefficient polynomial), each joint's
    /// number of codes `g_j`: the terms are then the grid `Π_j {0 … g_j − 1}` in lexicographic
    /// order, each of coefficient 1 and its own basis function, and [`Tables::basis`] forms the
    /// tensor product `⊗_j φ(q_j)` directly. Empty otherwise.
    pub term_grid: &'a [u8],
}

/// The most values of the block [`Tables::basis`] forms once on a full grid (a stack array).
const GRID_BLOCK: usize = 256;

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

    /// Scratch `f64`s [`Tables::jacobian`] needs for `chain`: the fused walk's derivatives
    /// and tangent states of each parameterised factor of segment `s` (`48 + 4·(s + 1)`, the
    /// segment after the last joint being `n`), and at least the elementary walk's 16 states
    /// per factor.
    #[must_use]
    pub fn scratch_len(chain: &[Factor]) -> usize {
        fused::scratch_len(chain).max(16 * chain.len())
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
    fn probe_state<S: Ring>(eq: &Equation) -> State<S> {
        let mut u = [S::ZERO; 16];
        let unit = |x: f64| if x == 1.0 { S::ONE } else { S::ZERO };
        if eq.degree == 1 {
            for (u, &x) in u.iter_mut().zip(&eq.probe) {
                *u = unit(x);
            }
        } else {
            for i in 0..4 {
                for j in 0..4 {
                    u[4 * i + j] = unit(eq.probe[i] * eq.probe[j]);
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
        let mut steps: [Step; MAX_FACTORS] = [Step::Id; MAX_FACTORS];
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
    fn backward_trie<S: Ring>(
        &self,
        at: &[usize; MAX_JOINTS],
        codes: &[u8],
        keep: usize,
        steps: &[Step<S>],
        degree: u8,
        stack: &mut [State<S>; MAX_JOINTS + 1],
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

    /// Each pivot in table order: its index, its codes, and how many last joints' codes it
    /// shares with the pivot before (the states right of them are kept).
    fn walk(&self) -> impl Iterator<Item = (usize, [u8; MAX_JOINTS], usize)> + '_ {
        let n = self.joints;
        let mut prev = [0u8; MAX_JOINTS];
        (0..self.basis_size()).map(move |i| {
            let codes = unpack(self.pivots[i], n);
            let keep = if i == 0 {
                0
            } else {
                Self::shared_suffix(&codes[..n], &prev[..n])
            };
            prev = codes;
            (i, codes, keep)
        })
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
        let steps = self.steps(p);
        self.contract(&steps[..self.chain.len()], vals, out);
    }

    /// [`Tables::generalized_params`] from every factor's parameter-only step (`steps[f]`,
    /// a rotation's sine and cosine or a translation, in any [`Ring`]): the same contraction
    /// in `f64`, or exactly modulo a prime for the derive's certificate.
    pub(crate) fn contract<S: Ring>(&self, steps: &[Step<S>], vals: &[S], out: &mut [S]) {
        self.contract_by(steps, vals, out, true);
    }

    /// [`Tables::contract`], the degree-one equations by the fused walk (`fused_walk`, see
    /// [`fused`]) or by elementary steps like degree two (the test's reference).
    fn contract_by<S: Ring>(&self, steps: &[Step<S>], vals: &[S], out: &mut [S], fused_walk: bool) {
        let (n, kk, m, ne) = (
            self.joints,
            self.basis_size(),
            self.chain.len(),
            self.equation_count(),
        );
        let at = self.joint_factors();
        // Degree-one equations walk the fused joint motions, formed once.
        let linear = fused_walk && n > 0 && (0..ne).any(|e| self.equation(e).degree == 1);
        let mut fused = Fused::empty();
        if linear {
            fused.fill(self, &at, steps);
        }
        for probe in Self::PROBES {
            // The group's functionals, 32 equations at a time.
            let mut e0 = 0;
            while e0 < ne {
                let mut rows = [0usize; 32];
                let mut count = 0;
                let mut e = e0;
                let mut degree = 1;
                while e < ne && count < 32 {
                    let eq = self.equation(e);
                    if Self::reads(&eq, probe) {
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
                let rows = &rows[..count];
                let first = self.equation(rows[0]);
                let mut u = Self::probe_state(&first);
                let last = if n == 0 { 0 } else { at[n - 1] + 1 };
                for s in steps[last..m].iter().rev() {
                    backward(*s, &mut u, degree);
                }
                let w = |e: usize| {
                    let eq = self.equation(e);
                    functional(&eq, self.dim, &vals[eq.offset..], None)
                };
                if degree == 1 && linear {
                    let mut w4 = [[S::ZERO; 4]; 32];
                    for (w4, &e) in w4.iter_mut().zip(rows) {
                        w4.copy_from_slice(&w(e)[..4]);
                    }
                    let tail = [u[0], u[1], u[2], u[3]];
                    fused.contract(self, tail, &w4[..count], rows, out);
                    continue;
                }
                let mut ws = [[S::ZERO; 16]; 32];
                for (ws, &e) in ws.iter_mut().zip(rows) {
                    *ws = w(e);
                }
                let mut stack = [[S::ZERO; 16]; MAX_JOINTS + 1];
                stack[n] = u;
                for (i, unpacked, keep) in self.walk() {
                    let codes = &unpacked[..n];
                    self.backward_trie(&at, codes, keep, steps, degree, &mut stack);
                    let k = self.pivot_basis[i] as usize;
                    for (w, &e) in ws.iter().zip(rows) {
                        out[e * kk + k] = dot(w, &stack[0], degree);
                    }
                }
            }
        }
    }

    /// `∂c/∂p`: `out[(e*K + k)*P + j] = ∂c_{e,k}/∂p_j`, `E·K·P` values (every one written),
    /// with `P = p.len()`. `scratch` holds at least [`Tables::scratch_len`]`(chain)`.
    ///
    /// # Panics
    /// If the tables are inconsistent or a buffer is short (a programming error).
    pub fn jacobian(&self, p: &[f64], vals: &[f64], scratch: &mut [f64], out: &mut [f64]) {
        let steps = self.steps(p);
        self.jacobian_with(&steps[..self.chain.len()], p.len(), vals, scratch, out);
    }

    /// [`Tables::jacobian`] from every factor's parameter-only step (as
    /// [`Tables::contract`]), for `np` parameters, in any [`Ring`].
    pub(crate) fn jacobian_with<S: Ring>(
        &self,
        steps: &[Step<S>],
        np: usize,
        vals: &[S],
        scratch: &mut [S],
        out: &mut [S],
    ) {
        self.jacobian_by(steps, np, vals, scratch, out, true);
    }

    /// [`Tables::jacobian_with`], the degree-one equations by the fused walk (`fused_walk`)
    /// or by the elementary product rule like degree two (the test's reference).
    fn jacobian_by<S: Ring>(
        &self,
        steps: &[Step<S>],
        np: usize,
        vals: &[S],
        scratch: &mut [S],
        out: &mut [S],
        fused_walk: bool,
    ) {
        let (n, kk, ne) = (self.joints, self.basis_size(), self.equation_count());
        out[..ne * kk * np].fill(S::ZERO);
        let at = self.joint_factors();
        let linear = fused_walk && n > 0 && (0..ne).any(|e| self.equation(e).degree == 1);
        let mut fused = Fused::empty();
        if linear {
            fused.fill(self, &at, steps);
        }
        // The backward states depend on the probe alone: one pass per probe and pivot,
        // shared by every equation that reads it.
        for probe in Self::PROBES {
            let Some(first) = (0..ne)
                .map(|e| self.equation(e))
                .find(|eq| Self::reads(eq, probe))
            else {
                continue;
            };
            if linear && first.degree == 1 {
                self.fused_jacobian(&fused, &at, steps, (probe, &first), np, vals, scratch, out);
                continue;
            }
            for (i, unpacked, keep) in self.walk() {
                let codes = &unpacked[..n];
                let u0 = self.backward_pass(&first, codes, keep, steps, scratch);
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
                        steps,
                        scratch,
                        &u0,
                        &mut out[row..row + np],
                    );
                }
            }
        }
    }

    /// The degree-one equations reading `probe` (`first` among them), by the fused walk.
    #[allow(clippy::too_many_arguments)]
    fn fused_jacobian<S: Ring>(
        &self,
        fused: &Fused<S>,
        at: &[usize; MAX_JOINTS],
        steps: &[Step<S>],
        (probe, first): ((u8, usize), &Equation),
        np: usize,
        vals: &[S],
        scratch: &mut [S],
        out: &mut [S],
    ) {
        let (n, m, ne) = (self.joints, self.chain.len(), self.equation_count());
        let v = Self::probe_state::<S>(first);
        let v = [v[0], v[1], v[2], v[3]];
        let mut tail = v;
        for s in steps[at[n - 1] + 1..m].iter().rev() {
            s.col(&mut tail);
        }
        let d = Fused::derivatives(self, at, steps, v, scratch);
        let mut e0 = 0;
        while e0 < ne {
            let mut eqs = [*first; 32];
            let mut rows = [0usize; 32];
            let mut count = 0;
            while e0 < ne && count < 32 {
                let eq = self.equation(e0);
                if Self::reads(&eq, probe) {
                    eqs[count] = eq;
                    rows[count] = e0;
                    count += 1;
                }
                e0 += 1;
            }
            if count > 0 {
                let (eqs, rows) = (&eqs[..count], &rows[..count]);
                fused.jacobian(self, &d, scratch, tail, eqs, rows, vals, np, out);
            }
        }
    }

    /// The backward pass of one pivot: the state right of every factor into `scratch` (after
    /// a joint's projection), and the whole contraction's state `u₀`. With `keep` last
    /// joints' codes equal to those of the pivot the scratch holds, the states right of them
    /// are kept.
    fn backward_pass<S: Ring>(
        &self,
        eq: &Equation,
        codes: &[u8],
        keep: usize,
        steps: &[Step<S>],
        scratch: &mut [S],
    ) -> State<S> {
        let (n, m) = (self.joints, self.chain.len());
        let (mut u, start) = if keep == 0 || keep >= n {
            (Self::probe_state(eq), m)
        } else {
            let at = self.joint_factors();
            let start = at[n - keep - 1] + 1;
            let mut u = [S::ZERO; 16];
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
    fn accumulate<S: Ring>(
        &self,
        eq: &Equation,
        codes: &[u8],
        vals: &[S],
        steps: &[Step<S>],
        scratch: &[S],
        u0: &State<S>,
        row: &mut [S],
    ) {
        let v = &vals[eq.offset..];
        // The constraint's own values: C is linear in the functional.
        let vparams = &self.value_params[eq.offset..self.offsets[eq.constraint + 1]];
        for (vi, param) in vparams.iter().enumerate() {
            if let Some(j) = *param {
                let dw = functional(eq, self.dim, v, Some(vi));
                row[j] = row[j] + dot(&dw, u0, eq.degree);
            }
        }
        // Forward: each parameterised factor's derivative.
        let mut x = functional(eq, self.dim, v, None);
        for (fi, f) in self.chain.iter().enumerate() {
            forward(steps[fi], &mut x, eq.degree);
            if f.terms.iter().any(Option::is_some) {
                let mut uf = [S::ZERO; 16];
                uf.copy_from_slice(&scratch[16 * fi..16 * fi + 16]);
                let dc = derivative(generator(f), &x, &uf, eq.degree);
                for t in f.terms.iter().flatten() {
                    // A term's coefficient is ±1 (a home offset enters negated).
                    debug_assert!(t.coef.abs() == 1.0, "a term of coefficient {}", t.coef);
                    row[t.param] = row[t.param] + if t.coef < 0.0 { -dc } else { dc };
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
        if !self.term_grid.is_empty() {
            self.grid_basis(&table, out);
            return;
        }
        out[..self.basis_size()].fill(0.0);
        let mut prefix = [1.0; MAX_JOINTS + 1];
        for t in 0..self.term_basis.len() {
            let codes = self.term_monomials[t];
            for j in self.term_shared[t] as usize..n {
                prefix[j + 1] = prefix[j] * table[j][((codes >> (3 * j)) & 7) as usize];
            }
            out[self.term_basis[t] as usize] += self.term_coefs[t] * prefix[n];
        }
    }

    /// [`Tables::basis`] on a full grid ([`Tables::term_grid`]): the tensor product of the
    /// last joints' functions (at most [`GRID_BLOCK`] values) is formed once, then an
    /// odometer over the other joints keeps their prefix products, and each prefix scales
    /// the whole block: one product and one store per basis function, in loops the compiler
    /// keeps tight (no codes to unpack, no sum).
    fn grid_basis(&self, table: &[[f64; 5]; MAX_JOINTS], out: &mut [f64]) {
        let n = self.joints;
        let g = self.term_grid;
        // The block: the last joints, as many as fit in GRID_BLOCK values.
        let mut split = n;
        let mut len = 1;
        while split > 0 && len * usize::from(g[split - 1]) <= GRID_BLOCK {
            split -= 1;
            len *= usize::from(g[split]);
        }
        let mut block = [0.0; GRID_BLOCK];
        block[0] = 1.0;
        let mut filled = 1;
        for j in split..n {
            let gj = usize::from(g[j]);
            // Lexicographic: joint j's code runs fastest after the earlier joints'.
            for i in (0..filled).rev() {
                let x = block[i];
                for c in (0..gj).rev() {
                    block[i * gj + c] = x * table[j][c];
                }
            }
            filled *= gj;
        }
        let block = &block[..len];
        let mut digits = [0u8; MAX_JOINTS];
        let mut prefix = [1.0; MAX_JOINTS + 1];
        for j in 0..split {
            prefix[j + 1] = prefix[j] * table[j][0];
        }
        for chunk in self.term_basis.chunks_exact(len) {
            let p = prefix[split];
            for (&b, &v) in chunk.iter().zip(block) {
                out[b as usize] = p * v;
            }
            // The next prefix: the last joint (before the block) whose digit can grow.
            let Some(j) = (0..split).rev().find(|&j| digits[j] + 1 < g[j]) else {
                return;
            };
            digits[j] += 1;
            for d in &mut digits[j + 1..split] {
                *d = 0;
            }
            for i in j..split {
                prefix[i + 1] = prefix[i] * table[i][usize::from(digits[i])];
            }
        }
    }
}
