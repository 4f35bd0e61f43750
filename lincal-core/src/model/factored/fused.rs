//! `c(p)` and `∂c/∂p` of degree-one equations by a walk over fused joint steps.
//!
//! Between two joints the chain's parameter-only factors compose into one rigid motion, so
//! the state right of joint `j` is `u_j = N_{j,κ_j}·u_{j+1}` with `N_{j,κ} = M_j·P_κ` and
//! `M_j = S_{start_j} ⋯ S_{at_j}` (the factors after joint `j − 1`'s up to joint `j`'s own
//! offset rotation), formed once per call. The base's motion folds into the functional,
//! `c_{e,κ} = (w_e·N_{0,κ_0})·u_1`. A revolute joint's projection keeps two entries of the
//! state (`P₀` the axis and the homogeneous one, `P_c` and `P_s` the plane's two), so
//! `N_{j,κ}` has two nonzero columns: an inner node of the pivots' suffix trie costs eight
//! products and a pivot two per equation, with no branch on the code. The elementary walk
//! ([`super::Tables::contract`]) takes about four elementary steps per joint instead; both
//! give the same values (and the same exact values modulo a prime, which is how the derive's
//! certificate checks this code).
//!
//! `∂c/∂p` by forward tangents on the same walk: differentiating `u_j = N_{j,κ_j}·u_{j+1}`,
//! a parameterised factor `f` of joint `j`'s segment enters through
//! `∂M_j/∂β_f = D_f = (S_start ⋯ S_f)·G_f·(S_{f+1} ⋯ S_{at_j})` (`G_f` its generator), formed
//! once per call with each code's projection. Each such factor carries its tangent state
//! `∂u_i/∂β_f` per level like the states, recomputed only where the pivot's codes changed,
//! so most pivots only read `∂c_{e,κ}/∂β_f = (w_e·N_{0,κ₀})·∂u_1/∂β_f` (two products).
//! Forming the prefix rows `w_e·N_{0,κ₀} ⋯ N_{j−1,κ_{j−1}}` again for every pivot instead
//! cost 1.7-2.5× more on the 7-joint arms (docs/benchmarks/derive.md, session 40).

use super::functional::{functional, Equation};
use super::step::{generator, projection, Ring, Step};
use super::{Tables, MAX_JOINTS};

/// A 4×4 matrix, row-major.
type Matrix<S> = [S; 16];

/// The product `S_a ⋯ S_b` of `steps`.
fn compose<S: Ring>(steps: &[Step<S>]) -> Matrix<S> {
    let mut x = [S::ZERO; 16];
    for i in 0..4 {
        x[5 * i] = S::ONE;
    }
    for s in steps.iter().rev() {
        s.left(&mut x);
    }
    x
}

/// A joint's fused step for one code: `N·u = Σ_r column_r·u[read_r]`, at most four terms
/// (two for every code of a revolute joint).
#[derive(Clone, Copy)]
struct Columns<S> {
    read: [u8; 4],
    column: [[S; 4]; 4],
}

impl<S: Ring> Columns<S> {
    const ZERO: Self = Columns {
        read: [0; 4],
        column: [[S::ZERO; 4]; 4],
    };

    /// Sets `self` to `N = M·P`'s columns at the entries `P` reads (structurally: `P` is a
    /// projection, a generator or a slide, its entries `0` and `±1`); returns their count.
    /// In place: a returned copy cost a stalled `memcpy` per code (the profile's largest
    /// item on small models).
    fn set(&mut self, m: &Matrix<S>, p: Step<S>) -> usize {
        let mut n = *m;
        p.right(&mut n);
        *self = Self::ZERO;
        let mut count = 0;
        for i in 0..4 {
            let mut unit = [S::ZERO; 4];
            unit[i] = S::ONE;
            p.col(&mut unit);
            if unit != [S::ZERO; 4] {
                self.read[count] = i as u8;
                self.column[count] = [n[i], n[4 + i], n[8 + i], n[12 + i]];
                count += 1;
            }
        }
        count
    }

    /// `N·y`, reading the first `R` columns (at least one).
    #[inline]
    fn apply<const R: usize>(&self, y: &[S; 4]) -> [S; 4] {
        let x = y[usize::from(self.read[0]) & 3];
        let mut out = self.column[0].map(|c| c * x);
        for r in 1..R {
            let (col, x) = (&self.column[r], y[usize::from(self.read[r]) & 3]);
            for (o, &c) in out.iter_mut().zip(col) {
                *o = *o + c * x;
            }
        }
        out
    }

    /// `w·N`'s entries at the read columns, `(w·N)·y = Σ_r leaf_r·y[read_r]`.
    fn leaf(&self, w: &[S; 4]) -> [S; 4] {
        self.column
            .map(|c| w[0] * c[0] + w[1] * c[1] + w[2] * c[2] + w[3] * c[3])
    }
}

/// Every joint's fused step for each degree-one code. Slot 3 is zero: a code of degree two
/// (a pivot of a circle's, sphere's or quadric's equations in the same model) reads nothing
/// in degree one.
pub(super) struct Fused<S> {
    steps: [[Columns<S>; 4]; MAX_JOINTS],
    /// Whether every code of the joint reads at most two entries (a revolute joint).
    narrow: [bool; MAX_JOINTS],
}

impl<S: Ring> Fused<S> {
    /// No joint's steps (a call with no degree-one equation).
    pub(super) fn empty() -> Self {
        Fused {
            steps: [[Columns::ZERO; 4]; MAX_JOINTS],
            narrow: [true; MAX_JOINTS],
        }
    }

    /// Fills in the fused steps of `tables`' chain at the parameter-only `steps`, on a
    /// fresh [`Fused::empty`]; `at[j]` is joint `j`'s factor. In place: the struct is a few
    /// kilobytes, and a copy of it showed in the profile.
    pub(super) fn fill(
        &mut self,
        tables: &Tables<'_>,
        at: &[usize; MAX_JOINTS],
        steps: &[Step<S>],
    ) {
        for j in 0..tables.joints {
            let start = if j == 0 { 0 } else { at[j - 1] + 1 };
            let m = compose(&steps[start..=at[j]]);
            let f = &tables.chain[at[j]];
            for code in 0..3 {
                let count = self.steps[j][usize::from(code)].set(&m, projection::<S>(f, code));
                self.narrow[j] &= count <= 2;
            }
        }
    }

    /// Writes `out[e·K + k] = c_{e,k}` for the equations `rows` with functionals `ws`, all of
    /// degree one and sharing the tool-side state `tail` (the probe moved by every factor
    /// after the last joint).
    pub(super) fn contract(
        &self,
        tables: &Tables<'_>,
        tail: [S; 4],
        ws: &[[S; 4]],
        rows: &[usize],
        out: &mut [S],
    ) {
        let kk = tables.basis_size();
        // Each equation's functional through the first joint's step, by code: a pivot's
        // value is then a short dot product with the state right of the first joint.
        let leaves = self.leaves(ws);
        let leaves = &leaves[..ws.len()];
        let mut starts = [0usize; 32];
        for (s, &e) in starts.iter_mut().zip(rows) {
            *s = e * kk;
        }
        let starts = &starts[..ws.len()];
        // The common group sizes (a plane's one equation, a point's three) unrolled.
        match (self.narrow[0], ws.len()) {
            (true, 1) => self.walk::<2, 1>(tables, tail, leaves, starts, out),
            (true, 2) => self.walk::<2, 2>(tables, tail, leaves, starts, out),
            (true, 3) => self.walk::<2, 3>(tables, tail, leaves, starts, out),
            (true, _) => self.walk::<2, 0>(tables, tail, leaves, starts, out),
            (false, 1) => self.walk::<4, 1>(tables, tail, leaves, starts, out),
            (false, 3) => self.walk::<4, 3>(tables, tail, leaves, starts, out),
            (false, _) => self.walk::<4, 0>(tables, tail, leaves, starts, out),
        }
    }

    /// Each functional of `ws` (at most 32) through the first joint's step, by code: the
    /// entries of `w·N_{0,κ}` at the columns the step reads.
    fn leaves(&self, ws: &[[S; 4]]) -> [[[S; 4]; 4]; 32] {
        let mut leaves = [[[S::ZERO; 4]; 4]; 32];
        for (l, w) in leaves.iter_mut().zip(ws) {
            for (lc, n0) in l.iter_mut().zip(&self.steps[0]) {
                *lc = n0.leaf(w);
            }
        }
        leaves
    }

    /// The walk of [`Fused::contract`], the first joint's step reading `R0` entries, for
    /// `E` equations (`0`: as many as `leaves` holds).
    fn walk<const R0: usize, const E: usize>(
        &self,
        tables: &Tables<'_>,
        tail: [S; 4],
        leaves: &[[[S; 4]; 4]],
        starts: &[usize],
        out: &mut [S],
    ) {
        let mut stack = [[S::ZERO; 4]; MAX_JOINTS + 1];
        stack[tables.joints] = tail;
        for (pivot, k, top) in changes(tables) {
            let code = |j: usize| code(pivot, j);
            for j in (1..=top).rev() {
                let step = &self.steps[j][code(j)];
                stack[j] = if self.narrow[j] {
                    step.apply::<2>(&stack[j + 1])
                } else {
                    step.apply::<4>(&stack[j + 1])
                };
            }
            let c0 = code(0);
            let read = &self.steps[0][c0].read;
            let mut y = [S::ZERO; R0];
            for (y, &r) in y.iter_mut().zip(read) {
                // `& 3`: an entry index (below 4 by construction), with no bounds check.
                *y = stack[1][usize::from(r) & 3];
            }
            let count = if E == 0 { leaves.len() } else { E };
            for (l, &s) in leaves[..count].iter().zip(&starts[..count]) {
                let w = &l[c0];
                let mut v = w[0] * y[0];
                for r in 1..R0 {
                    v = v + w[r] * y[r];
                }
                out[s + k] = v;
            }
        }
    }
}

/// The most constraint values one equation reads in degree one (a 3-D line's six).
const MAX_VALUES: usize = 6;

/// Scratch entries the fused `∂c/∂p` takes for a parameterised factor of segment `seg` (the
/// segment after the last joint being `n`): its tangent states at levels `0..=seg`, then,
/// before the last joint, its derivative through each degree-one code's projection (three
/// codes' `columns` columns: two for a revolute joint, four for a prismatic one).
const fn slot_len(seg: usize, columns: usize) -> usize {
    4 * (seg + 1) + 12 * columns
}

/// The columns a joint's fused steps read: two for a revolute joint, four for a prismatic
/// one.
fn columns(joint: &crate::model::chain::Factor) -> usize {
    if joint.rotation {
        2
    } else {
        4
    }
}

/// The scratch entries the fused `∂c/∂p` takes for `chain` (every parameterised factor's
/// [`slot_len`], nothing for the others).
pub(super) fn scratch_len(chain: &[crate::model::chain::Factor]) -> usize {
    let mut total = 0;
    let mut seg = 0;
    for (i, f) in chain.iter().enumerate() {
        if f.terms.iter().any(Option::is_some) {
            // The factor's joint: the first joint factor from it on (none on the tool side).
            let joint = chain[i..].iter().find(|g| g.joint.is_some());
            total += slot_len(seg, joint.map_or(0, columns));
        }
        seg += usize::from(f.joint.is_some());
    }
    total
}

/// The parameterised factors of the fused `∂c/∂p`, last first: `(factor, segment, slot)`,
/// the segment of a factor after the last joint being `n`, the slot where its derivatives
/// and tangent states start in the caller's `scratch` ([`slot_len`] entries).
pub(super) struct Derivatives<S> {
    factors: [(u16, u16, u32); super::MAX_FACTORS],
    count: usize,
    /// Every parameter term of the listed factors, `(index in the list, parameter, ±1)`:
    /// the first `after` of factors after the first joint's segment (read through its
    /// leaves), those from `first` on of factors in it.
    terms: [(u16, u32, S); 2 * super::MAX_FACTORS],
    after: usize,
    first: usize,
}

impl<S: Ring> Derivatives<S> {
    /// Lists `terms` from the listed factors.
    fn list_terms(&mut self, tables: &Tables<'_>) {
        let (mut na, mut nb) = (0, self.terms.len());
        for (i, &(f, seg, _)) in self.factors[..self.count].iter().enumerate() {
            for t in tables.chain[usize::from(f)].terms.iter().flatten() {
                let sign = if t.coef < 0.0 { -S::ONE } else { S::ONE };
                // At most `MAX_FACTORS` factors; parameter indices are far below `u32::MAX`.
                let term = (i as u16, t.param as u32, sign);
                if seg >= 1 {
                    self.terms[na] = term;
                    na += 1;
                } else {
                    nb -= 1;
                    self.terms[nb] = term;
                }
            }
        }
        (self.after, self.first) = (na, nb);
    }
}

impl<S: Ring> Fused<S> {
    /// Every parameterised factor's derivative into `scratch`, for the probe `v`: for a
    /// factor of joint `j`'s segment, `∂N_{j,κ}/∂β_f = D_f·P_κ` by code (the columns `N_{j,κ}`
    /// reads), `D_f = (S_start ⋯ S_f)·G_f·(S_{f+1} ⋯ S_{at_j})`; for a factor after the last
    /// joint, the tool side's `∂t/∂β_f` as its tangent state at level `n`.
    pub(super) fn derivatives(
        tables: &Tables<'_>,
        at: &[usize; MAX_JOINTS],
        steps: &[Step<S>],
        probe: [S; 4],
        scratch: &mut [S],
    ) -> Derivatives<S> {
        let (n, m) = (tables.joints, tables.chain.len());
        let segment_of = |f: usize| (0..n).find(|&j| f <= at[j]);
        let mut d = Derivatives {
            factors: [(0, 0, 0); super::MAX_FACTORS],
            count: 0,
            terms: [(0, 0, S::ZERO); 2 * super::MAX_FACTORS],
            after: 0,
            first: 0,
        };
        let mut start = 0;
        for (f, factor) in tables.chain.iter().enumerate().rev() {
            if !factor.terms.iter().any(Option::is_some) {
                continue;
            }
            let segment = segment_of(f);
            let seg = segment.unwrap_or(n);
            let cols = segment.map_or(0, |j| columns(&tables.chain[at[j]]));
            let len = slot_len(seg, cols);
            let slot = &mut scratch[start..start + len];
            let gen = generator::<S>(factor);
            match segment {
                Some(j) => {
                    let first = if j == 0 { 0 } else { at[j - 1] + 1 };
                    let mut x = compose(&steps[f + 1..=at[j]]);
                    gen.left(&mut x);
                    for s in steps[first..=f].iter().rev() {
                        s.left(&mut x);
                    }
                    let mut c = Columns::ZERO;
                    for code in 0..3u8 {
                        c.set(&x, projection::<S>(&tables.chain[at[j]], code));
                        for (r, column) in c.column.iter().enumerate().take(cols) {
                            let o = 4 * (seg + 1) + 4 * cols * usize::from(code) + 4 * r;
                            slot[o..o + 4].copy_from_slice(column);
                        }
                    }
                }
                None => {
                    let mut v = probe;
                    for s in steps[f + 1..m].iter().rev() {
                        s.col(&mut v);
                    }
                    gen.col(&mut v);
                    for s in steps[at[n - 1] + 1..=f].iter().rev() {
                        s.col(&mut v);
                    }
                    slot[4 * n..4 * n + 4].copy_from_slice(&v);
                }
            }
            // At most `MAX_FACTORS` factors and `MAX_JOINTS` joints: both fit.
            d.factors[d.count] = (f as u16, segment.unwrap_or(n) as u16, start as u32);
            d.count += 1;
            start += len;
        }
        d.list_terms(tables);
        d
    }

    /// `∂c/∂p` of the degree-one equations `rows` (their functionals `ws`, sharing the
    /// tool-side state `tail`), added into `out[(e·K + k)·P + j]`, `P = np`, by forward
    /// tangents on the walk of [`Fused::contract`]. Differentiating `u_j = N_{j,κ_j}·u_{j+1}`,
    /// each parameterised factor `f` carries `∂u_j/∂β_f = N_{j,κ_j}·∂u_{j+1}/∂β_f` (plus
    /// `D_f·P_{κ_j}·u_{j+1}` at its own joint `j`; the tool side's `∂t/∂β_f` at level `n`),
    /// kept per level like the states: a pivot recomputes only the levels whose codes
    /// changed, so most pivots only read `∂c_{e,κ}/∂β_f = (w_e·N_{0,κ₀})·∂u_1/∂β_f`. A
    /// factor of the first joint's segment gives `w_e·D_f·P_{κ₀}·u_1`, a constraint value
    /// `(∂w_e/∂value)·u_0`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn jacobian(
        &self,
        tables: &Tables<'_>,
        d: &Derivatives<S>,
        scratch: &mut [S],
        tail: [S; 4],
        eqs: &[Equation],
        rows: &[usize],
        vals: &[S],
        np: usize,
        out: &mut [S],
    ) {
        let (n, kk) = (tables.joints, tables.basis_size());
        let r = Readings::new(tables, eqs, vals);
        let ne = eqs.len();
        let leaves = self.leaves(&r.ws[..ne]);
        let leaves = &leaves[..ne];
        let factors = &d.factors[..d.count];
        let mut ys = [[S::ZERO; 4]; super::MAX_FACTORS];
        let ys = &mut ys[..d.count];
        let (after, first) = (&d.terms[..d.after], &d.terms[d.first..]);
        let mut stack = [[S::ZERO; 4]; MAX_JOINTS + 1];
        stack[n] = tail;
        for (pivot, k, top) in changes(tables) {
            self.descend(d, scratch, pivot, top, &mut stack);
            let c0 = code(pivot, 0);
            let step0 = &self.steps[0][c0];
            let base = |e: usize| (rows[e] * kk + k) * np;
            // Each factor's tangent right of the first joint, at the entries its step reads
            // (a factor of the first joint's segment: `D_f·P_{κ₀}·u_1` whole).
            for (y, &(_, seg, slot)) in ys.iter_mut().zip(factors) {
                let slot = slot as usize;
                *y = if seg >= 1 {
                    let t = quad(&scratch[slot + 4..slot + 8]);
                    step0.read.map(|i| t[usize::from(i)])
                } else if c0 < 3 {
                    let cols = if self.narrow[0] { 2 } else { 4 };
                    let o = slot + 4 + 4 * cols * c0;
                    apply_columns(&scratch[o..o + 4 * cols], &step0.read, &stack[1])
                } else {
                    // A code of degree two reads nothing in degree one.
                    [S::ZERO; 4]
                };
            }
            // Row by row: one equation's derivatives at this pivot are `np` values in a row,
            // each term `(factor, parameter, ±1)` adding its factor's derivative.
            for e in 0..ne {
                let row = &mut out[base(e)..base(e) + np];
                let l = &leaves[e][c0];
                if self.narrow[0] {
                    for &(i, param, sign) in after {
                        let (y, o) = (&ys[usize::from(i)], &mut row[param as usize]);
                        *o = *o + sign * (l[0] * y[0] + l[1] * y[1]);
                    }
                } else {
                    for &(i, param, sign) in after {
                        let o = &mut row[param as usize];
                        *o = *o + sign * dot(l, &ys[usize::from(i)]);
                    }
                }
                let w = &r.ws[e];
                for &(i, param, sign) in first {
                    let o = &mut row[param as usize];
                    *o = *o + sign * dot(w, &ys[usize::from(i)]);
                }
            }
            // The constraint's own values: c is linear in the functional.
            if r.values {
                let u0 = step0.apply::<4>(&stack[1]);
                for (e, dws) in r.dws.iter().enumerate().take(ne) {
                    for (param, dw) in &dws[..r.nd[e]] {
                        let o = &mut out[base(e) + param];
                        *o = *o + dot(dw, &u0);
                    }
                }
            }
        }
    }

    /// Down the chain from joint `top` (the highest whose code changed) to joint 1: the
    /// states right of each joint, and each listed factor's tangent at those levels (those
    /// of its own segment or beyond).
    fn descend(
        &self,
        d: &Derivatives<S>,
        scratch: &mut [S],
        pivot: u64,
        top: usize,
        stack: &mut [[S; 4]; MAX_JOINTS + 1],
    ) {
        for j in (1..=top).rev() {
            let cj = code(pivot, j);
            let step = &self.steps[j][cj];
            let narrow = self.narrow[j];
            stack[j] = apply(step, narrow, &stack[j + 1]);
            for &(_, seg, slot) in &d.factors[..d.count] {
                let (seg, slot) = (usize::from(seg), slot as usize);
                if seg < j {
                    break;
                }
                let t = slot + 4 * j;
                let v = if seg > j {
                    apply(step, narrow, &quad(&scratch[t + 4..t + 8]))
                } else if cj < 3 {
                    let cols = if narrow { 2 } else { 4 };
                    let o = t + 4 + 4 * cols * cj;
                    apply_columns(&scratch[o..o + 4 * cols], &step.read, &stack[j + 1])
                } else {
                    [S::ZERO; 4]
                };
                scratch[t..t + 4].copy_from_slice(&v);
            }
        }
    }
}

/// `N·y` for a fused step, reading two entries where the joint is revolute (`narrow`).
#[inline]
fn apply<S: Ring>(step: &Columns<S>, narrow: bool, y: &[S; 4]) -> [S; 4] {
    if narrow {
        step.apply::<2>(y)
    } else {
        step.apply::<4>(y)
    }
}

/// `Σ_r column_r·y[read_r]` for the columns stored one after another in `columns` (a
/// factor's derivative through one code's projection, read as that code's fused step reads).
#[inline]
fn apply_columns<S: Ring>(columns: &[S], read: &[u8; 4], y: &[S; 4]) -> [S; 4] {
    let mut out = [S::ZERO; 4];
    for (col, &i) in columns.chunks_exact(4).zip(read) {
        let x = y[usize::from(i)];
        for (o, &c) in out.iter_mut().zip(col) {
            *o = *o + c * x;
        }
    }
    out
}

/// The four entries of `s` as an array.
#[inline]
fn quad<S: Ring>(s: &[S]) -> [S; 4] {
    [s[0], s[1], s[2], s[3]]
}

/// Each pivot of `tables` (in table order) with its basis function and the highest joint
/// whose code differs from the pivot before (the last joint for the first pivot): every
/// state right of a joint up to it is stale. The top set bit of the two packed codes' XOR.
fn changes<'t>(tables: &'t Tables<'_>) -> impl Iterator<Item = (u64, usize, usize)> + 't {
    let n = tables.joints;
    let mut prev = tables
        .pivots
        .first()
        .map_or(0, |&p| p ^ (1 << (3 * (n - 1))));
    tables
        .pivots
        .iter()
        .zip(tables.pivot_basis)
        .map(move |(&pivot, &k)| {
            let top = (63 - ((pivot ^ prev) | 1).leading_zeros() as usize) / 3;
            prev = pivot;
            (pivot, k as usize, top)
        })
}

/// Joint `j`'s code in `pivot`, as a slot of [`Fused`]: codes of degree two read the zero
/// slot.
#[inline]
fn code(pivot: u64, j: usize) -> usize {
    (((pivot >> (3 * j)) & 7) as usize).min(3)
}

/// `a·b` of two 4-vectors.
#[inline]
fn dot<S: Ring>(a: &[S; 4], b: &[S; 4]) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// The functionals of a group of degree-one equations and their derivatives by the
/// constraint values that are parameters.
struct Readings<S> {
    ws: [[S; 4]; 32],
    /// Per equation: `(parameter, ∂w_e/∂value)`, the first `nd[e]`.
    dws: [[(usize, [S; 4]); MAX_VALUES]; 32],
    nd: [usize; 32],
    /// Whether any equation reads a value that is a parameter.
    values: bool,
}

impl<S: Ring> Readings<S> {
    fn new(tables: &Tables<'_>, eqs: &[Equation], vals: &[S]) -> Self {
        let mut r = Readings {
            ws: [[S::ZERO; 4]; 32],
            dws: [[(0usize, [S::ZERO; 4]); MAX_VALUES]; 32],
            nd: [0usize; 32],
            values: false,
        };
        for (i, eq) in eqs.iter().enumerate() {
            let v = &vals[eq.offset..];
            let w = functional(eq, tables.dim, v, None);
            r.ws[i].copy_from_slice(&w[..4]);
            let params = &tables.value_params[eq.offset..tables.offsets[eq.constraint + 1]];
            for (vi, param) in params.iter().enumerate() {
                if let Some(j) = *param {
                    let dw = functional(eq, tables.dim, v, Some(vi));
                    r.dws[i][r.nd[i]] = (j, [dw[0], dw[1], dw[2], dw[3]]);
                    r.nd[i] += 1;
                    r.values = true;
                }
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use crate::model::CalibModel;
    use crate::symbolic::SymbolicModel;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// An RRP arm with a tool, on a plane and an ellipsoid at once: degree-one equations
    /// whose pivots include codes of degree two (the quadric's `cos²`, `cos·sin`, `q²`), and
    /// a prismatic joint.
    const MIXED: &str = "
name: mixed
dim: 3
joints:
  - {type: revolute, a: a1, d: d1, alpha: pi/2, home: th1}
  - {type: revolute, a: a2, alpha: al2, home: th2}
  - {type: prismatic, offset: d3}
tool: [tx, ty, tz]
params:
  a1: {nominal: 0.35}
  d1: {nominal: 0.2}
  th1: {nominal: 0.1}
  a2: {nominal: 0.3}
  al2: {nominal: 0.2}
  th2: {nominal: 0.0}
  d3: {nominal: 0.05}
  tx: {nominal: 0.01}
  ty: {nominal: 0.02}
  tz: {nominal: 0.1}
  b1: {nominal: -0.4}
  b2: {nominal: -0.3}
  b3: {nominal: 4.0}
  A11: {nominal: 1.0}
  A22: {nominal: 2.0}
  A33: {nominal: 3.0}
  c1: {nominal: 0.3}
  c2: {nominal: 0.1}
  c3: {nominal: 0.2}
constraints:
  - plane: {b: [b1, b2, b3]}
  - quadric: {A: [[A11, 0, 0], [0, A22, 0], [0, 0, A33]], b: [c1, c2, c3]}
";

    /// A PRR arm on a rail, its first joint's fused steps reading four entries, on each of
    /// `constraint`'s (with its parameters `params`): one group size the walk unrolls each.
    fn rail(constraint: &str, params: &str) -> String {
        format!(
            "
name: rail
dim: 3
joints:
  - {{type: prismatic, offset: d0, alpha: al0}}
  - {{type: revolute, a: a1, d: d1, alpha: pi/2, home: th1}}
  - {{type: revolute, a: a2, alpha: al2, home: th2}}
tool: [tx, ty, tz]
params:
  d0: {{nominal: 0.1}}
  al0: {{nominal: 0.05}}
  a1: {{nominal: 0.35}}
  d1: {{nominal: 0.2}}
  th1: {{nominal: 0.1}}
  a2: {{nominal: 0.3}}
  al2: {{nominal: 0.2}}
  th2: {{nominal: 0.0}}
  tx: {{nominal: 0.01}}
  ty: {{nominal: 0.02}}
  tz: {{nominal: 0.1}}
{params}
constraint: {constraint}
"
        )
    }

    /// The fused walk gives the elementary walk's `c(p)` and `∂c/∂p` on the test specs, the
    /// model library's and a model mixing degree one and two, at random parameters.
    #[test]
    fn the_fused_walk_equals_the_elementary_one() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut specs = vec![crate::spec::from_yaml_str(MIXED, None).unwrap()];
        // A point's three equations, a 3-D line's two, a plane's one.
        for (constraint, params) in [
            (
                "{point: {p: [p1, p2, p3]}}",
                "  p1: {nominal: 0.5}\n  p2: {nominal: 0.1}\n  p3: {nominal: 0.3}",
            ),
            (
                "{line: {planes: [[e1, 0, 0.5], [0, 1.5, e3]]}}",
                "  e1: {nominal: 1.0}\n  e3: {nominal: -2.0}",
            ),
            (
                "{plane: {b: [b1, b2, b3]}}",
                "  b1: {nominal: -0.4}\n  b2: {nominal: -0.3}\n  b3: {nominal: 4.0}",
            ),
        ] {
            let yaml = rail(constraint, params);
            specs.push(crate::spec::from_yaml_str(&yaml, None).unwrap());
        }
        let fixed = specs.len();
        for dir in ["tests/specs", "lincal-models/specs"] {
            let mut paths: Vec<_> = std::fs::read_dir(root.join(dir))
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
                .collect();
            paths.sort();
            specs.extend(
                paths
                    .iter()
                    .filter_map(|p| crate::spec::from_yaml_file(p).ok()),
            );
        }
        let mut rng = ChaCha8Rng::seed_from_u64(39);
        let mut checked = 0;
        for (i, spec) in specs.iter().enumerate() {
            // The models above (first) must be read; a library spec the engine refuses is
            // another test's business.
            let agreed = agree(spec, &mut rng);
            assert!(agreed || i >= fixed, "{} refused", spec.name);
            checked += usize::from(agreed);
        }
        assert!(checked > 20, "only {checked} specs checked");
    }

    /// Compares the fused and the elementary walks' `c(p)` and `∂c/∂p` on `spec` at random
    /// parameters near the nominal ones; `false` if the engine refuses the spec.
    fn agree(spec: &crate::spec::Spec, rng: &mut ChaCha8Rng) -> bool {
        let Ok(m) = SymbolicModel::from_spec(spec) else {
            return false;
        };
        let Ok(t) = m.factored() else {
            return false;
        };
        let tables = t.tables();
        let (k, e) = (m.basis_size(), m.equation_count());
        let p: Vec<f64> = (0..m.param_count())
            .map(|j| m.param_nominal(j) + rng.gen_range(-0.1..0.1))
            .collect();
        let mut vals = vec![0.0; t.offsets.last().copied().unwrap_or(0)];
        for j in 0..m.constraint_count() {
            m.constraint_values(j, &p, &mut vals[t.offsets[j]..t.offsets[j + 1]]);
        }
        let steps = tables.steps(&p);
        let steps = &steps[..tables.chain.len()];
        let (mut fused, mut elementary) = (vec![f64::NAN; e * k], vec![f64::NAN; e * k]);
        tables.contract_by(steps, &vals, &mut fused, true);
        tables.contract_by(steps, &vals, &mut elementary, false);
        let scale = elementary.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        for (i, (a, b)) in fused.iter().zip(&elementary).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12 * scale,
                "{}: c[{i}] fused {a} elementary {b}",
                spec.name
            );
        }
        let np = m.param_count();
        let mut scratch = vec![0.0; super::super::Tables::scratch_len(tables.chain)];
        let (mut fused, mut elementary) = (vec![f64::NAN; e * k * np], vec![f64::NAN; e * k * np]);
        tables.jacobian_by(steps, np, &vals, &mut scratch, &mut fused, true);
        tables.jacobian_by(steps, np, &vals, &mut scratch, &mut elementary, false);
        let scale = elementary.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        for (i, (a, b)) in fused.iter().zip(&elementary).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12 * scale,
                "{}: ∂c[{}]/∂{} fused {a} elementary {b}",
                spec.name,
                i / np,
                m.param_name(i % np)
            );
        }
        true
    }

    /// A random serial chain of one to five joints, revolute or prismatic, each slot a
    /// number or a parameter, with or without a tool and a base frame, on a point, a plane,
    /// a 3-D line or a measured tip (the constraint's values known or parameters).
    fn random_spec(rng: &mut ChaCha8Rng, id: usize) -> String {
        let mut params = String::new();
        let mut slot = |rng: &mut ChaCha8Rng, name: String, lo: f64, hi: f64| {
            let x: f64 = rng.gen_range(lo..hi);
            if rng.gen_bool(0.6) {
                params.push_str(&format!("  {name}: {{nominal: {x}}}\n"));
                name
            } else {
                format!("{x}")
            }
        };
        let n = rng.gen_range(1..=5);
        let mut joints = String::new();
        for j in 0..n {
            let a = slot(rng, format!("a{j}"), -0.5, 0.5);
            let alpha = match rng.gen_range(0..4) {
                0 => "pi/2".to_string(),
                1 => "0".to_string(),
                _ => slot(rng, format!("al{j}"), -1.5, 1.5),
            };
            if rng.gen_bool(0.3) {
                let o = slot(rng, format!("o{j}"), 0.0, 0.3);
                joints.push_str(&format!(
                    "  - {{type: prismatic, a: {a}, alpha: {alpha}, offset: {o}}}\n"
                ));
            } else {
                let d = slot(rng, format!("d{j}"), -0.3, 0.3);
                let h = slot(rng, format!("th{j}"), -0.2, 0.2);
                joints.push_str(&format!(
                    "  - {{type: revolute, a: {a}, alpha: {alpha}, d: {d}, home: {h}}}\n"
                ));
            }
        }
        let mut extra = String::new();
        if rng.gen_bool(0.6) {
            let t: Vec<String> = (0..3)
                .map(|i| slot(rng, format!("t{i}"), -0.1, 0.1))
                .collect();
            extra.push_str(&format!("tool: [{}]\n", t.join(", ")));
        }
        if rng.gen_bool(0.4) {
            let (x, yaw) = (
                slot(rng, "bx".into(), -1.0, 1.0),
                slot(rng, "byaw".into(), -1.0, 1.0),
            );
            extra.push_str(&format!("base: {{x: {x}, yaw: {yaw}}}\n"));
        }
        let constraint = match rng.gen_range(0..4) {
            0 => {
                let v: Vec<String> = (0..3)
                    .map(|i| slot(rng, format!("p{i}"), -1.0, 1.0))
                    .collect();
                format!("{{point: {{p: [{}]}}}}", v.join(", "))
            }
            1 => {
                let v: Vec<String> = (0..3)
                    .map(|i| slot(rng, format!("b{i}"), 1.0, 3.0))
                    .collect();
                format!("{{plane: {{b: [{}]}}}}", v.join(", "))
            }
            2 => {
                let (e1, e2) = (
                    slot(rng, "e1".into(), 1.0, 2.0),
                    slot(rng, "e2".into(), 1.0, 2.0),
                );
                format!("{{line: {{planes: [[{e1}, 0, 0.5], [0.2, {e2}, -1.0]]}}}}")
            }
            _ => "{measured: {}}".to_string(),
        };
        format!("name: random{id}\ndim: 3\njoints:\n{joints}{extra}params:\n{params}constraint: {constraint}\n")
    }

    /// The fused walk gives the elementary walk's `c(p)` and `∂c/∂p` on random chains.
    #[test]
    fn the_fused_walk_equals_the_elementary_one_on_random_chains() {
        let mut rng = ChaCha8Rng::seed_from_u64(40);
        let mut checked = 0;
        for id in 0..60 {
            let yaml = random_spec(&mut rng, id);
            // A draw with no parameter at all is not a spec; the others must be read.
            let Ok(spec) = crate::spec::from_yaml_str(&yaml, None) else {
                assert!(!yaml.contains("nominal"), "{yaml}");
                continue;
            };
            checked += usize::from(agree(&spec, &mut rng));
        }
        assert!(checked >= 45, "only {checked} random chains checked");
    }
}
