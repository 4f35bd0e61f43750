//! The stacked constraint Jacobian at sampled joint readings, without the expansion.
//!
//! Write each constraint equation as `h_e(q; p) = c_e(p)·Φ̃(q)`. At joint readings
//! `q_1 … q_N` the stacked rows `∂h_e/∂p (q_l) = Φ̃(q_l)ᵀ ∂c_e/∂p` are the columns of
//! `∂C/∂p` mapped by `Φ̃_N = [Φ̃(q_l)ᵀ]`, and the mixing columns `E_ab C_j` map to the
//! values `h_b(q_l)` placed in equation `a`'s rows. The functions of `Φ̃` are linearly
//! independent, so for `r` independent vectors of their span the `N × r` matrix of values at
//! `N ≥ r` generic readings has rank `r` (its leading minor is a non-zero polynomial in the
//! readings). Constraint `j`'s block has at most `P + m_j²` independent columns (the
//! parameters and its own mixing), so `P + m_j² + 4` readings per constraint keep every rank
//! of `[∂C/∂p | mixing]`, and with them its kernel: the identifiability analysis needs no
//! `K`-dimensional expansion, only `O(N·P)` work per reading along the chain. The exact
//! analysis draws readings one at a time until each block's span stops growing
//! ([`spanning_rows_mod`]), a few more than the largest block's share of the rank; the
//! constraints share their readings, so the chain is carried once per reading for all of
//! them.
//!
//! The chain is evaluated with forward-mode derivatives over the estimated parameters, in
//! the integers modulo the prime at rational points of the unit circle (the exact analysis)
//! or in `f64` (the gauge rule's conditioning at the nominals, or near them), from the same
//! slot polynomials the expansion uses ([`crate::symbolic::slots`]), with the same formulas
//! per constraint kind: each link's motion once per point ([`super::motion`]), then the tip
//! carried through the motions at each reading.

use super::super::coef::Coef;
use super::super::modp::{self, Mp, Scalar};
use super::super::monomial::{Var, VarTable};
use super::super::slots::{LinkSlots, SlotPolys};
use super::dual::{Dual, Point};
use super::motion::{Carried, Motion, ENTRIES};
use crate::spec::{Constraint, RowForm};

/// A rigid transform `v ↦ R v + t` over duals.
struct Transform<T> {
    r: [[Dual<T>; 3]; 3],
    t: [Dual<T>; 3],
}

impl<T: Scalar> Transform<T> {
    /// `R v`: a direction (a tool frame's axis) carried through the transform.
    fn rotate(&self, v: &[Dual<T>; 3]) -> [Dual<T>; 3] {
        std::array::from_fn(|i| {
            let mut acc = self.r[i][0].mul(&v[0]);
            for (rij, vj) in self.r[i].iter().zip(v).skip(1) {
                acc.add_product(rij, vj);
            }
            acc
        })
    }

    fn apply(&self, v: &[Dual<T>; 3]) -> [Dual<T>; 3] {
        std::array::from_fn(|i| {
            let mut acc = self.t[i].clone();
            for (rij, vj) in self.r[i].iter().zip(v) {
                acc.add_product(rij, vj);
            }
            acc
        })
    }
}

/// The convention's link transform from `cos θ, sin θ, cos α, sin α, a, d` (as the
/// expansion's `dh`).
fn dh<T: Scalar>(
    conv: RowForm,
    q: [&Dual<T>; 2],
    al: [&Dual<T>; 2],
    a: &Dual<T>,
    d: &Dual<T>,
    tilt: Option<&[Dual<T>; 2]>,
) -> Transform<T> {
    let [ct, st] = q;
    let [ca, sa] = al;
    let z = || Dual::constant(T::zero());
    if let Some([cb, sb]) = tilt {
        return match conv {
            // Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β): the untilted rows times Ry(β).
            RowForm::Dh => {
                let mut t = dh(conv, q, al, a, d, None);
                for row in &mut t.r {
                    let (r0, r2) = (row[0].clone(), row[2].clone());
                    row[0] = cb.mul(&r0).sub(&sb.mul(&r2));
                    row[2] = sb.mul(&r0).add(&cb.mul(&r2));
                }
                t
            }
            // A = Rx(α)·Ry(β), then A·Rz(θ) and A·(a, 0, d).
            RowForm::Mdh => {
                let am = [
                    [cb.clone(), z(), sb.clone()],
                    [sa.mul(sb), ca.clone(), sa.mul(cb).neg()],
                    [ca.mul(sb).neg(), sa.clone(), ca.mul(cb)],
                ];
                Transform {
                    r: std::array::from_fn(|i| {
                        [
                            am[i][0].mul(ct).add(&am[i][1].mul(st)),
                            am[i][1].mul(ct).sub(&am[i][0].mul(st)),
                            am[i][2].clone(),
                        ]
                    }),
                    t: std::array::from_fn(|i| am[i][0].mul(a).add(&am[i][2].mul(d))),
                }
            }
        };
    }
    match conv {
        RowForm::Dh => Transform {
            r: [
                [ct.clone(), st.mul(ca).neg(), st.mul(sa)],
                [st.clone(), ct.mul(ca), ct.mul(sa).neg()],
                [z(), sa.clone(), ca.clone()],
            ],
            t: [a.mul(ct), a.mul(st), d.clone()],
        },
        RowForm::Mdh => Transform {
            r: [
                [ct.clone(), st.neg(), z()],
                [st.mul(ca), ct.mul(ca), sa.neg()],
                [st.mul(sa), ct.mul(sa), ca.clone()],
            ],
            t: [a.clone(), sa.mul(d).neg(), ca.mul(d)],
        },
    }
}

/// The base `Tr(x,y,z)·Rz(yaw)·Ry(pitch)·Rx(roll)`.
fn base_transform<T: Scalar>(rpy: &[(Dual<T>, Dual<T>); 3], t: [Dual<T>; 3]) -> Transform<T> {
    let [(cr, sr), (cp, sp), (cy, sy)] = rpy;
    let r = [
        [
            cy.mul(cp),
            cy.mul(sp).mul(sr).sub(&sy.mul(cr)),
            cy.mul(sp).mul(cr).add(&sy.mul(sr)),
        ],
        [
            sy.mul(cp),
            sy.mul(sp).mul(sr).add(&cy.mul(cr)),
            sy.mul(sp).mul(cr).sub(&cy.mul(sr)),
        ],
        [sp.neg(), cp.mul(sr), cp.mul(cr)],
    ];
    Transform { r, t }
}

/// One link's values at a point: `(cos α, sin α)`, `a`, the angle pair, `d` with the prismatic
/// offset; `(cos β, sin β)` of a tilt; the origin's transform in `convention: urdf`.
type LinkValues<T> = ([Dual<T>; 6], Option<[Dual<T>; 2]>, Option<Transform<T>>);

/// `outer ∘ inner`: `R = R_o·R_i`, `t = R_o·t_i + t_o` (a URDF joint's row, then its origin).
fn then<T: Scalar>(outer: &Transform<T>, inner: &Transform<T>) -> Transform<T> {
    let cols: [[Dual<T>; 3]; 3] =
        std::array::from_fn(|c| outer.rotate(&std::array::from_fn(|i| inner.r[i][c].clone())));
    Transform {
        r: std::array::from_fn(|i| std::array::from_fn(|c| cols[c][i].clone())),
        t: outer.apply(&inner.t),
    }
}

/// A transform's entries in [`ENTRIES`]' order.
fn flat<T: Scalar>(t: Transform<T>) -> [Dual<T>; ENTRIES] {
    let [r0, r1, r2] = t.r;
    let mut it = r0.into_iter().chain(r1).chain(r2).chain(t.t);
    std::array::from_fn(|_| it.next().unwrap_or_else(|| Dual::constant(T::zero())))
}

/// Link `l`'s transform as a function of its joint reading ([`Motion`]), from its values `f`:
/// evaluated at `(cos q, sin q) = (0, 0), (1, 0), (0, 1)` (revolute) or `q = 0, 1`
/// (prismatic), the origin after the row in `convention: urdf`.
fn link_motion<T: Scalar>(sp: &SlotPolys, l: &LinkSlots, f: &LinkValues<T>) -> Motion<T> {
    let ([ca, sa, a, c, s, d], tilt, origin) = f;
    let row = sp.convention.row();
    let (zero, one) = (T::zero(), Point::<T>::one());
    let at = |phi: &[T]| -> [Dual<T>; ENTRIES] {
        let tr = if l.offset.is_none() {
            let (cq, sq) = (phi[0], phi[1]);
            // θ = q − home: cos θ = cq·ch + sq·sh, sin θ = sq·ch − cq·sh.
            let ct = c.scale(cq).add(&s.scale(sq));
            let st = c.scale(sq).sub(&s.scale(cq));
            dh(row, [&ct, &st], [ca, sa], a, d, tilt.as_ref())
        } else {
            let dq = d.add(&Dual::constant(phi[0]));
            dh(row, [c, s], [ca, sa], a, &dq, tilt.as_ref())
        };
        flat(match origin {
            Some(o) => then(o, &tr),
            None => tr,
        })
    };
    let points: Vec<[Dual<T>; ENTRIES]> = if l.offset.is_none() {
        vec![at(&[zero, zero]), at(&[one, zero]), at(&[zero, one])]
    } else {
        vec![at(&[zero]), at(&[one])]
    };
    Motion::from_points(&points)
}

/// The parameter-dependent part of the chain at one point, evaluated once.
struct Fixed<T> {
    /// Per link, its transform as a function of its reading.
    links: Vec<Motion<T>>,
    tool: [Dual<T>; 3],
    /// The tool frame's axes in the last frame, when its pose is measured.
    tool_axes: Option<[[Dual<T>; 3]; 3]>,
    base: Option<Motion<T>>,
    values: Vec<Vec<Dual<T>>>,
    /// The estimated parameters (the gradients' length).
    np: usize,
}

impl<T: Scalar> Fixed<T> {
    /// The fixed parts at the parameter and constant values `vals`, with gradients over the
    /// first `np` parameters (`0`: values alone).
    fn at(sp: &SlotPolys, vals: &[T], np: usize) -> Self {
        let at = Point {
            vars: &sp.vars,
            vals,
            np,
        };
        Self::new(sp, &at)
    }

    fn new(sp: &SlotPolys, at: &Point<'_, T>) -> Self {
        let link = |l: &LinkSlots| -> Motion<T> {
            let (ca, sa) = at.pair(&l.alpha);
            let (c, s) = at.pair(&l.angle);
            let off = l
                .offset
                .as_ref()
                .map_or_else(|| Dual::constant(T::zero()), |o| at.poly(o));
            let tilt = l.beta.as_ref().map(|b| {
                let (cb, sb) = at.pair(b);
                [cb, sb]
            });
            let origin = l.origin.as_ref().map(|o| {
                let rpy = std::array::from_fn(|k| at.pair(&o.rpy[k]));
                base_transform(&rpy, std::array::from_fn(|k| at.poly(&o.t[k])))
            });
            let values = (
                [ca, sa, at.poly(&l.a), c, s, at.poly(&l.d).add(&off)],
                tilt,
                origin,
            );
            link_motion(sp, l, &values)
        };
        Fixed {
            links: sp.links.iter().map(link).collect(),
            tool: std::array::from_fn(|k| at.poly(&sp.tool[k])),
            tool_axes: sp.tool_rpy.as_ref().map(|rpy| {
                let rpy = std::array::from_fn(|k| at.pair(&rpy[k]));
                let zero = || Dual::constant(T::zero());
                let r = base_transform(&rpy, [zero(), zero(), zero()]).r;
                std::array::from_fn(|c| std::array::from_fn(|i| r[i][c].clone()))
            }),
            base: sp.base.as_ref().map(|b| {
                let rpy = std::array::from_fn(|k| at.pair(&b.rpy[k]));
                let t = base_transform(&rpy, std::array::from_fn(|k| at.poly(&b.t[k])));
                Motion::from_points(&[flat(t)])
            }),
            values: sp
                .constraints
                .iter()
                .map(|(_, vals)| vals.iter().map(|v| at.poly(v)).collect())
                .collect(),
            np: at.np,
        }
    }

    /// The tip at joint readings `joint` (the joint variables' values, `cos q, sin q` of a
    /// revolute joint, `q` of a prismatic one, in the variable table's order), followed, when
    /// the pose is measured, by the tool frame's rotation column-major (9 more values).
    fn tip(&self, sp: &SlotPolys, joint: &[T]) -> Vec<Dual<T>> {
        let mut carried = Carried::new(&self.tool, self.tool_axes.as_ref(), self.np);
        let mut at = joint.len();
        for (l, m) in sp.links.iter().zip(&self.links).rev() {
            at -= if l.offset.is_none() { 2 } else { 1 };
            let phi = &joint[at..at + if l.offset.is_none() { 2 } else { 1 }];
            carried.through(m, phi);
        }
        if let Some(b) = &self.base {
            carried.through(b, &[]);
        }
        carried.into_duals(sp.dim)
    }
}

/// The constraint functions of one kind at the tip `x` (the expansion's formulas); `x` is
/// [`Fixed::tip`]'s output, the tip then (a measured pose's) rotation entries, which only
/// `measured_pose` takes.
fn functions<T: Scalar>(
    c: &Constraint,
    vals: &[Dual<T>],
    x: &[Dual<T>],
    dim: usize,
) -> Vec<Dual<T>> {
    if matches!(c, Constraint::MeasuredPose { .. }) {
        return x.to_vec();
    }
    let x = &x[..dim];
    let one = Dual::constant(T::coef(&Coef::ONE).unwrap_or_else(T::zero));
    let dot_plus_one = |b: &[Dual<T>]| {
        b.iter().zip(x).fold(one.clone(), |mut acc, (bi, xi)| {
            acc.add_product(bi, xi);
            acc
        })
    };
    match c {
        Constraint::Point { .. } => x.iter().zip(vals).map(|(xi, p)| xi.sub(p)).collect(),
        Constraint::Line2 { .. } | Constraint::Plane { .. } => vec![dot_plus_one(vals)],
        Constraint::PlaneNormal { .. } => {
            let h = vals[..3]
                .iter()
                .zip(x)
                .fold(vals[3].neg(), |acc, (n, xi)| acc.add(&n.mul(xi)));
            vec![h]
        }
        Constraint::Line3 { .. } => vec![dot_plus_one(&vals[0..3]), dot_plus_one(&vals[3..6])],
        Constraint::Circle { .. } | Constraint::Sphere { .. } => {
            let r2 = vals[dim].mul(&vals[dim]);
            let h = x.iter().zip(vals).fold(r2.neg(), |acc, (xi, ci)| {
                let d = xi.sub(ci);
                acc.add(&d.mul(&d))
            });
            vec![h]
        }
        Constraint::Quadric { .. } => {
            let mut h = dot_plus_one(&vals[dim * dim..]);
            for i in 0..dim {
                for j in 0..dim {
                    h = h.add(&vals[i * dim + j].mul(&x[i]).mul(&x[j]));
                }
            }
            vec![h]
        }
        Constraint::Measured | Constraint::MeasuredPose { .. } => x.to_vec(),
    }
}

/// Whether a constraint's equations are seen up to a mixing (every kind but a measured tip
/// or pose, which is seen directly: module docs of [`super`]).
fn has_mixing(c: &Constraint) -> bool {
    !matches!(c, Constraint::Measured | Constraint::MeasuredPose { .. })
}

/// The number of equations of a constraint kind in dimension `dim`.
pub(crate) fn equation_count(c: &Constraint, dim: usize) -> usize {
    match c {
        Constraint::Point { .. } | Constraint::Measured => dim,
        Constraint::MeasuredPose { .. } => 12,
        Constraint::Line3 { .. } => 2,
        _ => 1,
    }
}

/// The stacked columns at sampled readings: one per estimated parameter (`∂h/∂p_j` over
/// every reading and equation), then the mixing columns in the order of the groups
/// (non-measured constraints, in order), `a`, `b`.
pub(crate) struct Columns<T> {
    /// `∂h/∂p_j`, one column per estimated parameter.
    pub params: Vec<Vec<T>>,
    /// The mixing columns.
    pub mixing: Vec<Vec<T>>,
}

/// The stacked columns of [`Columns`] at the parameter and constant values `vals` (every
/// variable of `sp.vars`; joint entries unused), constraint `ci` at the first `counts[ci]` of
/// the joint readings `readings` (the joint variables' values).
///
/// The constraints share their readings, so the chain is carried once per reading for all of
/// them: each block's rank argument (module docs) holds at any generic readings, whatever the
/// other blocks were evaluated at, and the stack's row space is the sum of the blocks'.
pub(crate) fn columns<T: Scalar>(
    sp: &SlotPolys,
    vals: &[T],
    readings: &[Vec<T>],
    counts: &[usize],
) -> Columns<T> {
    let np = sp.param_nominals.len();
    debug_assert!(
        counts.len() == sp.constraints.len() && counts.iter().all(|&n| n <= readings.len()),
        "one count per constraint, each within the readings"
    );
    let fixed = Fixed::at(sp, vals, np);
    let used = counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .min(readings.len());
    let tips: Vec<Vec<Dual<T>>> = readings[..used]
        .iter()
        .map(|joint| fixed.tip(sp, joint))
        .collect();
    // Every constraint's equations at its readings, constraint-major.
    let mut blocks: Vec<Vec<Vec<Dual<T>>>> = Vec::with_capacity(counts.len());
    for (ci, (c, _)) in sp.constraints.iter().enumerate() {
        let n = counts.get(ci).copied().unwrap_or(0).min(used);
        let rows = tips[..n]
            .iter()
            .map(|tip| functions(c, &fixed.values[ci], tip, sp.dim))
            .collect();
        blocks.push(rows);
    }
    let n_rows: usize = blocks.iter().flatten().map(Vec::len).sum();
    let mut params = vec![Vec::with_capacity(n_rows); np];
    let mut mixing = Vec::new();
    let mut row0 = 0;
    for (ci, block) in blocks.iter().enumerate() {
        let m = block.first().map_or(0, Vec::len);
        for eqs in block {
            for h in eqs {
                for (j, col) in params.iter_mut().enumerate() {
                    col.push(h.g.get(j).copied().unwrap_or_else(T::zero));
                }
            }
        }
        if has_mixing(&sp.constraints[ci].0) {
            for a in 0..m {
                for b in 0..m {
                    let mut col = vec![T::zero(); n_rows];
                    for (l, eqs) in block.iter().enumerate() {
                        col[row0 + l * m + a] = eqs[b].v;
                    }
                    mixing.push(col);
                }
            }
        }
        row0 += block.len() * m;
    }
    Columns { params, mixing }
}

/// A spanning set of the rows of `[∂h/∂p | mixing]` modulo the prime (the layout of
/// [`Columns`], row-major) at the parameter and constant values `vals`.
///
/// Readings are drawn from `rng` one at a time and shared by the constraints; each reading's
/// rows are reduced against the span so far and kept when independent. Constraint `ci` stops
/// at its first reading that adds nothing, or after `caps[ci]` readings (a bound never
/// reached: each reading that adds raises the span within `V_ci`, of dimension at most
/// `P + m²`). Why the span still ends as the stack's row space `Σ V_j`: block `ci` stops at
/// reading `q` when its rows lie in `W = S + Σ V_j` (`S` the span before `q`, fixed before `q`
/// is drawn; `j < ci` the blocks still open, whose rows of the same reading came first). If
/// `V_ci ⊄ W`, the readings for which that happens are roots of a non-zero polynomial (a
/// coordinate of the rows' image in a complement of `W`), probability at most `deg/p`; else
/// `V_ci ⊂ W`, and by induction over `ci` (the first open block has no `j`) every `V_j` in `W`
/// ends inside the final span. So the span is the row space of the stack at `P + m² + 4`
/// readings per constraint, except with probability at most `deg/p` per stop, from the few
/// readings the largest block needs in place of `P + m² + 4` per constraint. Returns the rows'
/// width (the parameters and the mixing columns), the rows, and how many readings each
/// constraint took.
pub(crate) fn spanning_rows_mod(
    sp: &SlotPolys,
    vals: &[Mp],
    caps: &[usize],
    rng: &mut modp::Rng,
) -> (usize, Vec<Vec<u64>>, Vec<usize>) {
    let np = sp.param_nominals.len();
    let fixed = Fixed::at(sp, vals, np);
    // Each constraint's first mixing column (none for a measured one).
    let mut mixing_at = Vec::with_capacity(sp.constraints.len());
    let mut width = np;
    for (c, _) in &sp.constraints {
        mixing_at.push(width);
        if has_mixing(c) {
            let m = equation_count(c, sp.dim);
            width += m * m;
        }
    }
    let mut span = modp::RankCounter::default();
    let mut taken = vec![0usize; sp.constraints.len()];
    // One cap per constraint (a missing one: none of its readings).
    let cap = |ci: usize| caps.get(ci).copied().unwrap_or(0);
    let mut open: Vec<bool> = (0..sp.constraints.len()).map(|ci| cap(ci) > 0).collect();
    while open.iter().any(|&o| o) {
        let joint = readings_mod(&sp.vars, 1, rng).remove(0);
        let tip = fixed.tip(sp, &joint);
        for (ci, (c, _)) in sp.constraints.iter().enumerate() {
            if !open[ci] {
                continue;
            }
            let eqs = functions(c, &fixed.values[ci], &tip, sp.dim);
            let mixed = has_mixing(c);
            let m = eqs.len();
            let mut added = false;
            for a in 0..m {
                let mut row = vec![0u64; width];
                for (x, g) in row.iter_mut().zip(&eqs[a].g) {
                    *x = g.0;
                }
                if mixed {
                    for (b, h) in eqs.iter().enumerate() {
                        row[mixing_at[ci] + a * m + b] = h.v.0;
                    }
                }
                added |= span.insert(row);
            }
            taken[ci] += 1;
            open[ci] = added && taken[ci] < cap(ci);
        }
    }
    (width, span.into_rows(), taken)
}

/// Every equation's value `h_e(q_l)` at the parameter and constant values `vals` (no
/// derivatives), all constraints at the same `readings`: `out[e][l]`, equations in
/// constraint order.
pub(crate) fn equation_values<T: Scalar>(
    sp: &SlotPolys,
    vals: &[T],
    readings: &[Vec<T>],
) -> Vec<Vec<T>> {
    let fixed = Fixed::at(sp, vals, 0);
    let ne: usize = sp
        .constraints
        .iter()
        .map(|(c, _)| equation_count(c, sp.dim))
        .sum();
    let mut out = vec![Vec::with_capacity(readings.len()); ne];
    for joint in readings {
        let tip = fixed.tip(sp, joint);
        let mut e = 0;
        for (ci, (c, _)) in sp.constraints.iter().enumerate() {
            for h in functions(c, &fixed.values[ci], &tip, sp.dim) {
                out[e].push(h.v);
                e += 1;
            }
        }
    }
    out
}

/// Every equation's gradient `∂h_e/∂p (q)` over the `np` estimated parameters at one joint
/// reading `joint` and the parameter and constant values `vals`: `out[e][j]`, equations in
/// constraint order (for the derive's certificate of `∂c/∂p`, [`crate::symbolic::certify`]).
pub(crate) fn equation_gradients<T: Scalar>(
    sp: &SlotPolys,
    vals: &[T],
    np: usize,
    joint: &[T],
) -> Vec<Vec<T>> {
    let fixed = Fixed::at(sp, vals, np);
    let tip = fixed.tip(sp, joint);
    let mut out = Vec::new();
    for (ci, (c, _)) in sp.constraints.iter().enumerate() {
        for h in functions(c, &fixed.values[ci], &tip, sp.dim) {
            let mut g = h.g;
            // An empty gradient is zeros.
            g.resize(np, T::zero());
            out.push(g);
        }
    }
    out
}

/// How many readings constraint `c`'s block needs at most: `P + m² + 4` (see the module
/// docs; the exact analysis's cap, and four more the float stack's at most).
pub(crate) fn readings_needed(c: &Constraint, dim: usize, np: usize) -> usize {
    let m = equation_count(c, dim);
    np + m * m + 4
}

/// `n` random joint readings modulo the prime: rational points of the circle for revolute
/// joints, random elements for prismatic ones (joint variables' order).
pub(crate) fn readings_mod(vars: &VarTable, n: usize, rng: &mut modp::Rng) -> Vec<Vec<Mp>> {
    (0..n)
        .map(|_| {
            let mut v = vec![Mp(0); vars.joint_vars];
            let mut i = 0;
            while i < vars.joint_vars {
                if matches!(vars.vars[i], Var::JointCos(_)) {
                    let (c, s) = rng.circle_point();
                    v[i] = Mp(c);
                    v[i + 1] = Mp(s);
                    i += 2;
                } else {
                    v[i] = Mp(rng.element());
                    i += 1;
                }
            }
            v
        })
        .collect()
}

/// `n` random joint readings in `f64`: angles uniform in `(−π, π)`, prismatic readings in
/// `(−0.5, 0.5)` m.
pub(crate) fn readings_f64(vars: &VarTable, n: usize, rng: &mut modp::Rng) -> Vec<Vec<f64>> {
    let mut uniform = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
    (0..n)
        .map(|_| {
            let mut v = vec![0.0; vars.joint_vars];
            let mut i = 0;
            while i < vars.joint_vars {
                if matches!(vars.vars[i], Var::JointCos(_)) {
                    let q = std::f64::consts::TAU * uniform();
                    v[i] = q.cos();
                    v[i + 1] = q.sin();
                    i += 2;
                } else {
                    v[i] = uniform();
                    i += 1;
                }
            }
            v
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::eval::generic_point_mod;
    use crate::symbolic::expand::{expand_with, DEFAULT_MAX_TERMS};
    use crate::symbolic::poly::Poly;
    use crate::symbolic::slots::slot_polys;

    /// `poly` modulo the prime at `vals`.
    fn eval_mod(poly: &Poly, vals: &[u64]) -> u64 {
        let mut acc = 0;
        for (m, c) in &poly.terms {
            let mut t = Mp::coef(c).map_or(0, |x| x.0);
            for (v, e) in m.factors() {
                for _ in 0..e {
                    t = modp::mul(t, vals[v]);
                }
            }
            acc = modp::add(acc, t);
        }
        acc
    }

    /// The sampled chain gives the expansion's constraint functions and their parameter
    /// derivatives exactly (modulo the prime) at random readings and a random point, for
    /// every spec of the repository's `tests/specs` (every constraint kind, both
    /// conventions, prismatic joints, bases, known angles that are not multiples of π/2), the
    /// touch-plane example (Hayati's tilt) and the PUMA pose tracker (a measured pose, a rotated
    /// base).
    #[test]
    fn sampled_functions_and_derivatives_equal_the_expansions() {
        let mut paths = crate::symbolic::testutil::repo_spec_paths(&["tests/specs"]);
        // Hayati's tilt (the touch-plane example, a UR5 import), a measured pose and a
        // rotated base (the PUMA pose tracker).
        paths.push("examples/touch_planes/spec.yaml".into());
        paths.push("lincal-models/specs/puma560_pose_tracker.yaml".into());
        let mut checked = 0;
        for path in paths {
            let spec = crate::symbolic::testutil::repo_spec(&path);
            let exp = expand_with(&spec, DEFAULT_MAX_TERMS).unwrap();
            let sp = slot_polys(&spec).unwrap();
            assert_eq!(sp.vars.vars, exp.vars.vars, "{}", path);
            let np = sp.param_nominals.len();
            let mut rng = modp::Rng::new(7);
            // Three points a spec of `tests/specs`, one for the larger ones beyond it.
            let seeds = if path.starts_with("tests/specs") {
                3
            } else {
                1
            };
            for seed in 0..seeds {
                let mut vals = generic_point_mod(&sp.vars, 100 + seed);
                let mp: Vec<Mp> = vals.iter().map(|&x| Mp(x)).collect();
                let fixed = Fixed::at(&sp, &mp, np);
                let joint = readings_mod(&sp.vars, 1, &mut rng).remove(0);
                for (i, x) in joint.iter().enumerate() {
                    vals[i] = x.0;
                }
                for (ci, (c, _)) in sp.constraints.iter().enumerate() {
                    let hs = functions(c, &fixed.values[ci], &fixed.tip(&sp, &joint), sp.dim);
                    let polys: Vec<&Poly> = exp
                        .equations
                        .iter()
                        .filter(|e| e.constraint == ci)
                        .map(|e| &e.poly)
                        .collect();
                    assert_eq!(hs.len(), polys.len(), "{}", path);
                    for (h, poly) in hs.iter().zip(polys) {
                        assert_eq!(h.v.0, eval_mod(poly, &vals), "{}", path);
                        for (j, pv) in exp.param_vars.iter().enumerate() {
                            let d = match *pv {
                                crate::symbolic::expand::ParamVars::Length(v) => {
                                    eval_mod(&poly.diff(v), &vals)
                                }
                                crate::symbolic::expand::ParamVars::Angle(cv, sv) => modp::sub(
                                    modp::mul(vals[cv], eval_mod(&poly.diff(sv), &vals)),
                                    modp::mul(vals[sv], eval_mod(&poly.diff(cv), &vals)),
                                ),
                            };
                            let g = h.g.get(j).map_or(0, |x| x.0);
                            assert_eq!(g, d, "{}: ∂h/∂p{j}", path);
                        }
                    }
                }
                checked += 1;
            }
        }
        assert!(checked >= 30, "only {checked} spec points checked");
    }
}
