//! Span-equivalent links: the basis `Φ̃` from a smaller expansion, where the direct one
//! crosses its bound (URDF-native rows, six unknowns a joint; issue 48).
//!
//! Write link `i`'s transform in homogeneous form as `T_i = Σ_μ μ·C_{iμ}`: `μ` runs over the
//! canonical monomials in the link's own non-joint variables (its unknowns and its kept
//! constants), and `C_{iμ}` is a matrix of joint polynomials in `q_i` with rational
//! coefficients. The equations of a kind affine in the tip and the tool frame's axes (point,
//! line, plane, measured tip or pose) are multilinear in `(T_1, …, T_n)`; a sphere's too, in
//! the links' `(T_i, R_iᵀt_i, ‖t_i‖²)`, as the expansion carries `‖tip‖²` along the chain
//! (`n ↦ n + 2(Rᵀt)·v + ‖t‖²`, [`super::link`]). When no other piece
//! of the spec shares a link's variables, monomials of distinct links multiply into distinct
//! canonical monomials, so the rows of the matrix `E` that the reduction reads
//! ([`super::reduce`]) are `F(C_{1μ₁}, …, C_{nμₙ}; ρ)`, and they span
//! `{F(X_1, …, X_n; ρ) : X_i ∈ S_i}` with `S_i = span_μ C_{iμ}`. The row space sees each
//! link only through `S_i`.
//!
//! So link `i` may be replaced by `T'_i = C_{i1} + Σ_k λ_k B_{ik}`, with `B_{ik}` a basis of
//! `span{C_{iμ} : μ ≠ 1}` (exact, over ℚ) and fresh variables `λ_k` (`C_{i1}` carries the
//! homogeneous 1). The row space is the same, hence the same reduced echelon form: the same
//! `Φ̃`, pivots, `R`, `K` and monomials before the reduction, all still exact. The `λ`s enter
//! linearly, where a URDF-native link's monomials are products of up to eight trigonometric
//! factors, so the expansion shrinks by orders of magnitude. Its `c` are polynomials in `λ`,
//! not in `p`: a model built this way evaluates `c(p)` and `∂c/∂p` with the factored kernel
//! ([`crate::model::factored`]) and prints no `c(p)`.

use super::coef::Coef;
use super::expand::{equations, Equation, Expansion};
use super::limits::memory_terms;
use super::link::Transform;
use super::monomial::{Mono, Var, VarTable, MAX_VARS};
use super::poly::{take_out_of_memory, Poly, ProductError};
use crate::error::Result;
use crate::spec::{Constraint, Spec};
use num_traits::Zero;
use std::collections::BTreeMap;

/// The largest polynomial of a direct expansion where span-equivalent links could stand in:
/// [`crate::symbolic::REPORT_C_TERMS`], beyond which the reports print no `c(p)` anyway.
pub const DIRECT_MAX_TERMS: usize = 200_000;

/// A coordinate of a link's matrix: its entry (`R` row-major `0..9`, `t` `9..12`, and where
/// `‖tip‖²` is carried, `Rᵀt` `12..15` and `‖t‖²` `15`) and a joint monomial.
type Key = (u8, Mono);

/// A sparse vector over [`Key`]s.
type Vector = BTreeMap<Key, Coef>;

/// Whether every constraint of `spec` is affine in the tip, the tool frame's axes and
/// `‖tip‖²` (the kinds whose equations are multilinear in the links, `‖tip‖²` carried along
/// the chain as `n ↦ n + 2(Rᵀt)·v + ‖t‖²`): all but a circle (whose planar `‖tip‖²` drops
/// the third coordinate's square) and a quadric.
pub(super) fn affine_kinds(spec: &Spec) -> bool {
    spec.constraints.iter().all(|c| {
        matches!(
            c,
            Constraint::Point { .. }
                | Constraint::Line2 { .. }
                | Constraint::Line3 { .. }
                | Constraint::Plane { .. }
                | Constraint::PlaneNormal { .. }
                | Constraint::Sphere { .. }
                | Constraint::Measured
                | Constraint::MeasuredPose { .. }
        )
    })
}

/// Whether span-equivalent links may stand in for `spec`'s: every kind affine in the tip
/// ([`affine_kinds`]), and a chain the factored kernel holds ([`kernel_chain`]).
pub(super) fn kernel_holds(spec: &Spec) -> bool {
    affine_kinds(spec) && kernel_chain(spec)
}

/// Whether the factored kernel holds `spec`'s chain (it then evaluates `c(p)` and `∂c/∂p`
/// where they have no exact polynomials).
pub(super) fn kernel_chain(spec: &Spec) -> bool {
    use crate::model::factored::{MAX_FACTORS, MAX_JOINTS};
    spec.joints.len() <= MAX_JOINTS
        && crate::spec::chain::Chain::from_spec(spec).factors.len() <= MAX_FACTORS
}

/// Whether `‖tip‖²` is carried along the chain (a sphere).
fn carries_norm(spec: &Spec) -> bool {
    spec.constraints
        .iter()
        .any(|c| matches!(c, Constraint::Sphere { .. }))
}

/// The non-joint variables of `p`, as a bit set.
pub(super) fn own_vars(p: &Poly, vars: &VarTable) -> u128 {
    let mut set = 0u128;
    for m in p.terms.keys() {
        for v in vars.joint_vars..vars.vars.len() {
            if m.get(v) > 0 {
                set |= 1u128 << v;
            }
        }
    }
    set
}

/// The non-joint variables of a transform.
pub(super) fn transform_vars(t: &Transform, vars: &VarTable) -> u128 {
    entries(t).fold(0, |s, p| s | own_vars(p, vars))
}

fn entries(t: &Transform) -> impl Iterator<Item = &Poly> {
    let norm = t.norm.iter().flat_map(|nm| nm.0.iter().chain([&nm.1]));
    t.r.iter().flatten().chain(&t.t).chain(norm)
}

/// `t` with `(Rᵀt, ‖t‖²)` written out as polynomials of their own (`None` on an exponent
/// overflow).
fn with_norm(t: &Transform, pairs: &[(usize, usize)]) -> Option<Transform> {
    let mut rt: [Poly; 3] = Default::default();
    let mut tt = Poly::zero();
    for (i, ti) in t.t.iter().enumerate() {
        for (j, u) in rt.iter_mut().enumerate() {
            u.add_assign(&t.r[i][j].mul(ti, pairs).ok()?);
        }
        tt.add_assign(&ti.square(pairs).ok()?);
    }
    Some(Transform {
        r: t.r.clone(),
        t: t.t.clone(),
        norm: Some(Box::new((rt, tt))),
    })
}

/// `m` split into its joint part and the rest.
fn split(m: &Mono, vars: &VarTable) -> (Mono, Mono) {
    let (mut joint, mut rest) = (Mono::ONE, Mono::ONE);
    for v in 0..vars.vars.len() {
        let e = m.get(v);
        if e > 0 {
            if v < vars.joint_vars {
                joint.set(v, e);
            } else {
                rest.set(v, e);
            }
        }
    }
    (joint, rest)
}

/// A link's matrices `C_μ` by monomial `μ`.
fn coefficient_matrices(t: &Transform, vars: &VarTable) -> BTreeMap<Mono, Vector> {
    let mut out: BTreeMap<Mono, Vector> = BTreeMap::new();
    for (idx, p) in entries(t).enumerate() {
        for (m, c) in &p.terms {
            let (joint, rest) = split(m, vars);
            out.entry(rest)
                .or_default()
                .insert((idx as u8, joint), c.clone());
        }
    }
    out
}

/// A basis of the span of `vectors` chosen among them, sparsest first: each vector
/// independent of those chosen before it (tested against a reduced echelon form of the chosen
/// ones, by exact elimination). Chosen, not combined, so that the link keeps its own sparsity:
/// where its matrices `C_μ` are independent already, nothing changes.
fn span_basis(vectors: impl IntoIterator<Item = Vector>) -> Vec<Vector> {
    let mut vs: Vec<Vector> = vectors.into_iter().collect();
    // Stable: ties keep the monomials' order, so the choice is deterministic.
    vs.sort_by_key(BTreeMap::len);
    let mut echelon: Vec<(Key, Vector)> = Vec::new();
    let mut chosen = Vec::new();
    for v in vs {
        let mut r = v.clone();
        for (pivot, b) in &echelon {
            axpy(&mut r, pivot, b);
        }
        let Some((&pivot, lead)) = r.iter().next() else {
            continue;
        };
        let Some(inv) = lead.recip() else { continue };
        for c in r.values_mut() {
            *c = &*c * &inv;
        }
        for (_, b) in &mut echelon {
            axpy(b, &pivot, &r);
        }
        echelon.push((pivot, r));
        chosen.push(v);
    }
    chosen
}

/// `v ← v − v[pivot]·b`, for `b` with 1 at `pivot`.
fn axpy(v: &mut Vector, pivot: &Key, b: &Vector) {
    let Some(f) = v.get(pivot).cloned() else {
        return;
    };
    for (k, c) in b {
        let e = v.entry(*k).or_insert_with(Coef::zero);
        *e = &*e - &(&f * c);
    }
    v.retain(|_, c| !c.is_zero());
}

/// Link `t` as `C_1 + Σ_k λ_k B_k` over the variables `lambdas` (one per basis vector, as
/// [`span_basis`] of the link's `C_μ, μ ≠ 1` gives them), or `None` when an exponent would
/// overflow.
fn replaced(
    constant: &Vector,
    basis: &[Vector],
    lambdas: &[usize],
    norm: bool,
) -> Option<Transform> {
    let mut e: [Poly; 16] = std::array::from_fn(|_| Poly::zero());
    for (&(idx, joint), c) in constant {
        e[usize::from(idx)].terms.insert(joint, c.clone());
    }
    for (b, &l) in basis.iter().zip(lambdas) {
        for (&(idx, joint), c) in b {
            let m = joint.mul(&Mono::var(l))?;
            e[usize::from(idx)].terms.insert(m, c.clone());
        }
    }
    let mut it = e.into_iter();
    let mut next = || it.next().unwrap_or_default();
    let r = std::array::from_fn(|_| std::array::from_fn(|_| next()));
    let t = std::array::from_fn(|_| next());
    let rt = std::array::from_fn(|_| next());
    let norm = norm.then(|| Box::new((rt, next())));
    Some(Transform { r, t, norm })
}

fn terms(t: &Transform) -> usize {
    entries(t).map(Poly::len).sum()
}

/// Link `link`'s constant matrix `C_1` and an independent subset of its other `C_μ`
/// (with `Rᵀt` and `‖t‖²` where `norm`), when they hold fewer terms than the link.
fn plan(link: &Transform, vars: &VarTable, norm: bool) -> Option<(Vector, Vec<Vector>)> {
    let full = if norm {
        with_norm(link, &vars.trig_pairs)?
    } else {
        Transform {
            r: link.r.clone(),
            t: link.t.clone(),
            norm: None,
        }
    };
    let mut c = coefficient_matrices(&full, vars);
    let constant = c.remove(&Mono::ONE).unwrap_or_default();
    let basis = span_basis(c.into_values());
    let size = constant.len() + basis.iter().map(BTreeMap::len).sum::<usize>();
    (size < terms(&full)).then_some((constant, basis))
}

/// Replaces every link that owns its variables (`others`: the variables of every other piece
/// of the spec) by its span-equivalent form when that has fewer terms, renumbering the freed
/// variables as `λ`s (and adding more where they do not suffice). `Some` with the new
/// variable table when at least one link was replaced; `None` when none was, or the `λ`s
/// would pass [`MAX_VARS`].
pub(super) fn replace_links(
    vars: &VarTable,
    links: &mut [Transform],
    others: u128,
    norm: bool,
) -> Option<VarTable> {
    // A `(cos, sin)` pair is owned together: a link holding one of them holds both.
    let paired = |set: u128| {
        vars.trig_pairs.iter().fold(set, |s, &(c, n)| {
            if (s >> c | s >> n) & 1 == 1 {
                s | 1u128 << c | 1u128 << n
            } else {
                s
            }
        })
    };
    let others = paired(others);
    let owned: Vec<u128> = links
        .iter()
        .map(|l| paired(transform_vars(l, vars)))
        .collect();
    let mut table = vars.clone();
    let mut freed: Vec<usize> = Vec::new();
    let mut plans = Vec::new();
    for (i, link) in links.iter().enumerate() {
        let shared = owned
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .fold(others, |s, (_, o)| s | o);
        if owned[i] == 0 || owned[i] & shared != 0 {
            continue;
        }
        let Some((constant, basis)) = plan(link, vars, norm) else {
            continue;
        };
        freed.extend((0..MAX_VARS).filter(|&v| owned[i] >> v & 1 == 1));
        plans.push((i, constant, basis));
    }
    if plans.is_empty() {
        return None;
    }
    let lambda = || Var::ConstLength(0.0, "λ".to_string());
    table
        .trig_pairs
        .retain(|&(c, s)| !freed.contains(&c) && !freed.contains(&s));
    for &v in &freed {
        table.vars[v] = lambda();
    }
    freed.sort_unstable();
    let mut free = freed.into_iter();
    let mut out = Vec::new();
    for (i, constant, basis) in plans {
        let lambdas: Vec<usize> = (0..basis.len())
            .map(|_| free.next().unwrap_or_else(|| table.push(lambda())))
            .collect();
        if table.vars.len() > MAX_VARS {
            return None;
        }
        out.push((i, replaced(&constant, &basis, &lambdas, norm)?));
    }
    for (i, t) in out {
        links[i] = t;
    }
    Some(table)
}

/// The expansion of `spec` with its links replaced where they can be ([`replace_links`]), or
/// `None` where that does not apply: a kind not affine in the tip (a circle, a quadric),
/// or no link that owns its variables and shrinks.
///
/// # Errors
/// As [`super::expand::expand_with`].
pub(super) fn expand(spec: &Spec, max_terms: usize) -> Result<Option<Expansion>> {
    if !affine_kinds(spec) {
        return Ok(None);
    }
    let max_terms = max_terms.min(usize::try_from(memory_terms()).unwrap_or(usize::MAX));
    // Cleared before any polynomial is formed here: a failed allocation from now on counts.
    let _ = take_out_of_memory();
    let (vars, estimated, mut pieces) = super::expand::pieces(spec)?;
    let mut others = pieces
        .tool
        .iter()
        .chain(pieces.axes.iter().flatten().flatten())
        .chain(pieces.values.iter().flatten())
        .fold(0, |s, p| s | own_vars(p, &vars));
    if let Some(b) = &pieces.base {
        others |= transform_vars(b, &vars);
    }
    let Some(table) = replace_links(&vars, &mut pieces.links, others, carries_norm(spec)) else {
        return Ok(None);
    };
    let formed = equations(spec, pieces, table.trig_pairs.as_slice(), max_terms, None);
    if take_out_of_memory() {
        return Err(ProductError::Memory.into());
    }
    let equations = formed?
        .into_iter()
        .map(|(constraint, poly)| Equation { constraint, poly })
        .collect();
    Ok(Some(Expansion {
        vars: table,
        param_names: estimated.names,
        param_vars: estimated.vars,
        equations,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::expand::{expand_with, DEFAULT_MAX_TERMS};
    use crate::symbolic::reduce::{reduce_with, Reduction};

    fn reduced(e: Expansion) -> Reduction {
        let hs = e.equations.into_iter().map(|q| q.poly).collect();
        reduce_with(hs, e.vars.joint_vars, |_| ())
    }

    /// Joints of every kind: URDF-native rows (a prismatic one among them), DH and MDH rows
    /// with a known irrational twist and Hayati's tilt, a parameter shared by two links (those
    /// two stay as they are), a base and a rotated tool; the affine kinds.
    const SPECS: &[&str] = &[
        "name: u\ndim: 3\nconvention: urdf\njoints:\n  \
         - {type: revolute, x: x1, y: y1, z: z1, roll: r1, pitch: p1, yaw: w1}\n  \
         - {type: prismatic, x: x2, y: y2, z: z2, roll: r2, pitch: p2, yaw: w2}\n  \
         - {type: revolute, x: x3, y: 0.1, z: z3, roll: r3, pitch: 0.3, yaw: w3, home: h3}\n\
         tool: [t1, t2, t3]\nparams:\n  x1: {nominal: 0.1}\n  y1: {nominal: 0}\n  \
         z1: {nominal: 0.3}\n  r1: {nominal: 0.1}\n  p1: {nominal: 0.2}\n  w1: {nominal: 0}\n  \
         x2: {nominal: 0.2}\n  y2: {nominal: 0}\n  z2: {nominal: 0.1}\n  r2: {nominal: -1.5}\n  \
         p2: {nominal: 0.1}\n  w2: {nominal: 0}\n  x3: {nominal: 0.05}\n  z3: {nominal: 0.2}\n  \
         r3: {nominal: 0.4}\n  w3: {nominal: 0.1}\n  h3: {nominal: 0}\n  t1: {nominal: 0.1}\n  \
         t2: {nominal: 0}\n  t3: {nominal: 0.05}\nconstraint:\n  measured: {}\n",
        "name: d\ndim: 3\njoints:\n  \
         - {type: revolute, a: a1, alpha: al1, d: d1, home: h1}\n  \
         - {type: revolute, a: a2, alpha: 0.3, d: d2, home: h2, beta: b2}\n  \
         - {type: prismatic, a: a3, alpha: al3, theta: th3, offset: o3}\n  \
         - {type: revolute, a: a4, alpha: al4, d: d4, home: h4}\n\
         tool: [t1, 0, t3]\nparams:\n  a1: {nominal: 0.1}\n  al1: {nominal: 1.5}\n  \
         d1: {nominal: 0.3}\n  h1: {nominal: 0}\n  a2: {nominal: 0.4}\n  d2: {nominal: 0.1}\n  \
         h2: {nominal: 0}\n  b2: {nominal: 0.01}\n  a3: {nominal: 0.05}\n  \
         al3: {nominal: -1.5}\n  th3: {nominal: 0.1}\n  o3: {nominal: 0.2}\n  \
         a4: {nominal: 0.1}\n  al4: {nominal: 0.2}\n  d4: {nominal: 0.1}\n  h4: {nominal: 0}\n  \
         t1: {nominal: 0.1}\n  t3: {nominal: 0.05}\n  n1: {nominal: 0.1}\n  n2: {nominal: 0.2}\n  \
         n3: {nominal: -1.0}\nconstraint:\n  plane: {b: [n1, n2, n3]}\n",
        "name: m\ndim: 3\nconvention: urdf\njoints:\n  \
         - {type: revolute, x: x1, z: z1, roll: r1, yaw: w1}\n  \
         - {type: revolute, x: x1, y: y2, roll: r2, pitch: p2}\n  \
         - {type: revolute, x: x3, y: y3, z: z3, roll: r3, pitch: p3, yaw: w3}\n\
         tool: {x: tx, y: 0, z: tz, roll: 0.3, pitch: tp, yaw: ty}\n\
         base: {x: bx, y: 0.1, z: 0, roll: br, pitch: 0, yaw: byaw}\nparams:\n  \
         x1: {nominal: 0.1}\n  z1: {nominal: 0.3}\n  r1: {nominal: 1.5}\n  w1: {nominal: 0}\n  \
         y2: {nominal: 0.1}\n  r2: {nominal: 0.1}\n  p2: {nominal: 0}\n  x3: {nominal: 0.2}\n  \
         y3: {nominal: 0}\n  z3: {nominal: 0.1}\n  r3: {nominal: -1.5}\n  p3: {nominal: 0.2}\n  \
         w3: {nominal: 0}\n  tx: {nominal: 0.01}\n  tz: {nominal: 0.1}\n  tp: {nominal: 0.2}\n  \
         ty: {nominal: -0.1}\n  bx: {nominal: -1}\n  br: {nominal: 0.1}\n  byaw: {nominal: 0.5}\n\
         constraint:\n  measured_pose: {}\n",
    ];

    fn spec(yaml: &str, constraint: Option<&str>) -> Spec {
        let mut y = yaml.to_string();
        if let Some(c) = constraint {
            let at = y.find("constraint:").unwrap();
            y.truncate(at);
            y.push_str(c);
        }
        crate::spec::from_yaml_str(&y, None).unwrap()
    }

    #[test]
    fn span_equivalent_links_give_the_direct_basis() {
        let sphere = "constraint:\n  sphere: {center: [0.1, 0.2, t3], radius: 0.5}\n";
        let kinds: [&[Option<&str>]; 3] = [
            &[
                None,
                Some(sphere),
                Some("constraint:\n  point: {p: [t1, 0.2, 0.3]}\n"),
                Some("constraint:\n  line: {planes: [[0.1, 0.2, -1], [1, 0.5, 0.25]]}\n"),
            ],
            &[
                None,
                Some("constraint:\n  sphere: {center: [n1, n3, 0.3], radius: n2}\n"),
            ],
            &[None],
        ];
        let mut replaced = 0;
        for (yaml, kinds) in SPECS.iter().zip(kinds) {
            for c in kinds {
                let s = spec(yaml, *c);
                let direct = reduced(expand_with(&s, DEFAULT_MAX_TERMS).unwrap());
                let Some(sur) = expand(&s, DEFAULT_MAX_TERMS).unwrap() else {
                    continue;
                };
                replaced += 1;
                let terms = |e: &Expansion| e.equations.iter().map(|q| q.poly.len()).sum::<usize>();
                let smaller = terms(&sur) < terms(&expand_with(&s, DEFAULT_MAX_TERMS).unwrap());
                assert!(
                    smaller,
                    "{}: the span-equivalent expansion is not smaller",
                    s.name
                );
                let sur = reduced(sur);
                assert_eq!(direct.monomials, sur.monomials, "{}", s.name);
                assert_eq!(direct.basis, sur.basis, "{}", s.name);
                assert_eq!(direct.pivots, sur.pivots, "{}", s.name);
            }
        }
        assert_eq!(replaced, 7);
    }

    #[test]
    fn the_direct_expansion_stops_where_the_reports_stop_printing_c() {
        assert_eq!(DIRECT_MAX_TERMS, crate::symbolic::REPORT_C_TERMS);
    }

    #[test]
    fn kinds_not_affine_in_the_tip_keep_the_direct_expansion() {
        let s = spec(
            SPECS[0],
            Some("constraint:\n  quadric: {A: [[t3, 0, 0], [0, 1, 0], [0, 0, 1]], b: [0, 0, 1]}\n"),
        );
        assert!(expand(&s, DEFAULT_MAX_TERMS).unwrap().is_none());
    }

    fn unit(idx: u8, c: i64) -> Vector {
        [((idx, Mono::ONE), Coef::int(c))].into_iter().collect()
    }

    #[test]
    fn the_span_basis_keeps_independent_vectors_sparsest_first() {
        let mut a = unit(0, 2);
        a.insert((1, Mono::ONE), Coef::int(4));
        let b = unit(1, 3);
        let mut sum = a.clone();
        sum.insert((1, Mono::ONE), Coef::int(7)); // a + b
        let basis = span_basis([a.clone(), sum, b.clone()]);
        assert_eq!(basis, vec![b, a]);
    }
}
