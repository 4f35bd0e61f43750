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
//! `∂c/∂p` by the product rule on the same walk: a factor `f` of joint `j`'s segment enters
//! through `∂M_j/∂β_f = D_f = (S_start ⋯ S_f)·G_f·(S_{f+1} ⋯ S_{at_j})` (`G_f` its generator),
//! formed once per call, so `∂c_{e,κ}/∂β_f = L_{e,j}·D_f·P_{κ_j}·u_{j+1}` with the prefix row
//! `L_{e,j} = w_e·N_{0,κ₀} ⋯ N_{j−1,κ_{j−1}}` formed going up the chain and
//! `g_f = D_f·P_{κ_j}·u_{j+1}` kept with the suffix states (recomputed where the suffix
//! changed).

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

    /// `N = M·P`'s columns at the entries `P` reads (structurally: `P` is a projection, a
    /// generator or a slide, its entries `0` and `±1`).
    fn new(m: &Matrix<S>, p: Step<S>) -> (Self, usize) {
        let mut n = *m;
        p.right(&mut n);
        let mut c = Self::ZERO;
        let mut count = 0;
        for i in 0..4 {
            let mut unit = [S::ZERO; 4];
            unit[i] = S::ONE;
            p.col(&mut unit);
            if unit != [S::ZERO; 4] {
                c.read[count] = i as u8;
                c.column[count] = [n[i], n[4 + i], n[8 + i], n[12 + i]];
                count += 1;
            }
        }
        (c, count)
    }

    /// `N·y`, reading the first `R` columns (at least one).
    #[inline]
    fn apply<const R: usize>(&self, y: &[S; 4]) -> [S; 4] {
        let x = y[usize::from(self.read[0])];
        let mut out = self.column[0].map(|c| c * x);
        for r in 1..R {
            let (col, x) = (&self.column[r], y[usize::from(self.read[r])]);
            for (o, &c) in out.iter_mut().zip(col) {
                *o = *o + c * x;
            }
        }
        out
    }

    /// `w·N` as a row (zero outside the read columns).
    #[inline]
    fn row_times(&self, w: &[S; 4]) -> [S; 4] {
        let mut r = [S::ZERO; 4];
        for (c, &i) in self.column.iter().zip(&self.read) {
            let i = usize::from(i);
            r[i] = r[i] + (w[0] * c[0] + w[1] * c[1] + w[2] * c[2] + w[3] * c[3]);
        }
        r
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

    /// Fills in the fused steps of `tables`' chain at the parameter-only `steps`; `at[j]`
    /// is joint `j`'s factor. In place: the struct is a few kilobytes, and a copy of it
    /// showed in the profile.
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
                let (columns, count) = Columns::new(&m, projection::<S>(f, code));
                self.steps[j][usize::from(code)] = columns;
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
        let mut leaves = [[[S::ZERO; 4]; 4]; 32];
        for (l, w) in leaves.iter_mut().zip(ws) {
            for (lc, n0) in l.iter_mut().zip(&self.steps[0]) {
                *lc = n0.leaf(w);
            }
        }
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
                *y = stack[1][usize::from(r)];
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

/// What the fused `∂c/∂p` reads besides the walk: every factor's derivative, in `scratch`
/// (16 per factor): `D_f = (S_start ⋯ S_f)·G_f·(S_{f+1} ⋯ S_{at_j})` for a factor of joint
/// `j`'s segment, the tool side's `∂t/∂β_f` (four entries) after the last joint.
pub(super) struct Derivatives<'s, S> {
    scratch: &'s [S],
}

impl<S: Ring> Fused<S> {
    /// Every parameterised factor's derivative of its segment into `scratch`, for the probe
    /// `v` (only the tool side reads it).
    pub(super) fn derivatives<'s>(
        tables: &Tables<'_>,
        at: &[usize; MAX_JOINTS],
        steps: &[Step<S>],
        probe: [S; 4],
        scratch: &'s mut [S],
    ) -> Derivatives<'s, S> {
        let (n, m) = (tables.joints, tables.chain.len());
        let segment_of = |f: usize| (0..n).find(|&j| f <= at[j]);
        for (f, factor) in tables.chain.iter().enumerate() {
            if !factor.terms.iter().any(Option::is_some) {
                continue;
            }
            let slot = &mut scratch[16 * f..16 * f + 16];
            let gen = generator::<S>(factor);
            match segment_of(f) {
                Some(j) => {
                    let start = if j == 0 { 0 } else { at[j - 1] + 1 };
                    let mut x = compose(&steps[f + 1..=at[j]]);
                    gen.left(&mut x);
                    for s in steps[start..=f].iter().rev() {
                        s.left(&mut x);
                    }
                    slot.copy_from_slice(&x);
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
                    slot[..4].copy_from_slice(&v);
                }
            }
        }
        Derivatives { scratch }
    }

    /// `∂c/∂p` of the degree-one equations `rows` (their functionals `ws`, sharing the
    /// tool-side state `tail`), added into `out[(e·K + k)·P + j]`, `P = np`. For each pivot
    /// the suffix states come from the trie as in [`Fused::contract`], and the prefix rows
    /// `L_{e,j} = w_e·N_{0,κ₀} ⋯ N_{j−1,κ_{j−1}}` are formed going up the chain: a factor of
    /// joint `j`'s segment adds `L_{e,j}·D_f·P_{κ_j}·u_{j+1}`, a tool-side factor
    /// `L_{e,n}·∂t/∂β_f`, a constraint value `(∂w_e/∂value)·u_0`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn jacobian(
        &self,
        tables: &Tables<'_>,
        d: &Derivatives<'_, S>,
        tail: [S; 4],
        eqs: &[Equation],
        rows: &[usize],
        vals: &[S],
        np: usize,
        out: &mut [S],
    ) {
        let (n, kk, m) = (tables.joints, tables.basis_size(), tables.chain.len());
        let at = tables.joint_factors();
        let r = Readings::new(tables, eqs, vals);
        let mut stack = [[S::ZERO; 4]; MAX_JOINTS + 1];
        stack[n] = tail;
        let mut gs = [[S::ZERO; 4]; super::MAX_FACTORS];
        for (pivot, k, top) in changes(tables) {
            self.descend(tables, &at, d, pivot, top, &mut stack, &mut gs);
            let code = |j: usize| code(pivot, j);
            let base = |e: usize| (rows[e] * kk + k) * np;
            // Up the chain: L_{e,j} for every equation.
            let mut ls = r.ws;
            let ls = &mut ls[..eqs.len()];
            for j in 0..n {
                let f0 = if j == 0 { 0 } else { at[j - 1] + 1 };
                for (factor, g) in tables.chain[f0..=at[j]].iter().zip(&gs[f0..=at[j]]) {
                    if factor.terms.iter().any(Option::is_some) {
                        for (e, l) in ls.iter().enumerate() {
                            add(out, base(e), factor, dot(l, g));
                        }
                    }
                }
                let step = &self.steps[j][code(j)];
                for l in ls.iter_mut() {
                    *l = step.row_times(l);
                }
            }
            for (f, factor) in tables.chain.iter().enumerate().take(m).skip(at[n - 1] + 1) {
                if factor.terms.iter().any(Option::is_some) {
                    let dt = &d.scratch[16 * f..16 * f + 4];
                    let dt = [dt[0], dt[1], dt[2], dt[3]];
                    for (e, l) in ls.iter().enumerate() {
                        add(out, base(e), factor, dot(l, &dt));
                    }
                }
            }
            // The constraint's own values: c is linear in the functional.
            if r.values {
                let u0 = self.steps[0][code(0)].apply::<4>(&stack[1]);
                for (e, dws) in r.dws.iter().enumerate().take(eqs.len()) {
                    for (param, dw) in &dws[..r.nd[e]] {
                        let o = &mut out[base(e) + param];
                        *o = *o + dot(dw, &u0);
                    }
                }
            }
        }
    }

    /// Down the chain from joint `top` (the highest whose code changed): the states right of
    /// each joint and each factor's `g_f = D_f·P_{κ_j}·u_{j+1}`, which depend on the suffix
    /// alone.
    #[allow(clippy::too_many_arguments)]
    fn descend(
        &self,
        tables: &Tables<'_>,
        at: &[usize; MAX_JOINTS],
        d: &Derivatives<'_, S>,
        pivot: u64,
        top: usize,
        stack: &mut [[S; 4]; MAX_JOINTS + 1],
        gs: &mut [[S; 4]; super::MAX_FACTORS],
    ) {
        for j in (0..=top).rev() {
            let cj = code(pivot, j);
            let mut v = stack[j + 1];
            if cj < 3 {
                projection::<S>(&tables.chain[at[j]], cj as u8).col(&mut v);
            } else {
                v = [S::ZERO; 4];
            }
            let f0 = if j == 0 { 0 } else { at[j - 1] + 1 };
            let segment = tables.chain[f0..=at[j]].iter().zip(&mut gs[f0..=at[j]]);
            for (f, (factor, g)) in (f0..).zip(segment) {
                if factor.terms.iter().any(Option::is_some) {
                    let df = &d.scratch[16 * f..16 * f + 16];
                    *g = [0, 1, 2, 3].map(|r| {
                        dot(
                            &[df[4 * r], df[4 * r + 1], df[4 * r + 2], df[4 * r + 3]],
                            &v,
                        )
                    });
                }
            }
            if j > 0 {
                stack[j] = self.steps[j][cj].apply::<4>(&stack[j + 1]);
            }
        }
    }
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

/// Adds `∂c/∂β_f = dc` to every parameter of factor `f`'s amount (a term's coefficient is
/// ±1: a home offset enters negated), in the row starting at `base`.
#[inline]
fn add<S: Ring>(out: &mut [S], base: usize, factor: &crate::model::chain::Factor, dc: S) {
    for t in factor.terms.iter().flatten() {
        let o = &mut out[base + t.param];
        *o = if t.coef < 0.0 { *o - dc } else { *o + dc };
    }
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
            let m = SymbolicModel::from_spec(spec).map_err(|e| (i, e));
            let Ok(m) = m else {
                assert!(i >= fixed, "{m:?}");
                continue;
            };
            let Ok(t) = m.factored() else {
                assert!(i >= fixed);
                continue;
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
            let mut scratch = vec![0.0; super::super::Tables::scratch_len(tables.chain.len())];
            let (mut fused, mut elementary) =
                (vec![f64::NAN; e * k * np], vec![f64::NAN; e * k * np]);
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
            checked += 1;
        }
        assert!(checked > 20, "only {checked} specs checked");
    }
}
