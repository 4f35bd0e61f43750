//! Symbolic expansion: a [`Spec`] becomes exact polynomials for the tip `x(q; p)` and for the
//! constraint function(s) `h(q; p)`.
//!
//! Revolute joints enter through `cos q_i`, `sin q_i` (the angle `θ_i = q_i − home_i` is
//! expanded with the angle-difference formulas, so home offsets appear as `cos home_i`,
//! `sin home_i`, separated from the joint variables, as in the paper's sec. 3). Prismatic
//! joints enter through `q_i`. Known parameters are substituted before expansion; angles that
//! are multiples of π/2 are substituted exactly (`cos(pi/2) = 0`), other known angles stay as
//! symbols with their numeric value.

use super::chain_poly::ChainPoly;
use super::kinds::{constraint_polys, predicted_constraint};
use super::limits::{memory_terms, too_big};
use super::link::{dh, m, moment, tilted, try_map3, Transform};
use super::monomial::{Var, VarTable, MAX_VARS};
use super::poly::{Poly, ProductError};
use crate::error::{Error, Result};
use crate::spec::{
    Base, Constraint, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot, Spec,
};
use std::borrow::Cow;
use std::collections::HashMap;

/// How an estimated parameter is represented.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamVars {
    /// A length: one polynomial variable.
    Length(usize),
    /// An angle: the `(cos, sin)` variable pair.
    Angle(usize, usize),
}

/// One scalar constraint equation `h_e(q; p) = 0` (or a measured coordinate).
#[derive(Clone, Debug)]
pub struct Equation {
    /// Index of the constraint (in the spec's list) it comes from.
    pub constraint: usize,
    /// The polynomial `h_e(q; p)`.
    pub poly: Poly,
}

/// The expanded spec.
#[derive(Clone, Debug)]
pub struct Expansion {
    /// The variables.
    pub vars: VarTable,
    /// Names of the estimated parameters (the vector `p`), spec order.
    pub param_names: Vec<String>,
    /// Representation of each estimated parameter.
    pub param_vars: Vec<ParamVars>,
    /// Every constraint equation, in constraint order. A [`super::SymbolicModel`] moves them
    /// out into the reduction, so its own expansion holds none.
    pub equations: Vec<Equation>,
}

pub(super) struct Builder<'a> {
    pub(super) vars: VarTable,
    estimated: HashMap<&'a str, (usize, ParamVars)>,
    known: HashMap<&'a str, &'a Param>,
    const_pairs: HashMap<String, (usize, usize)>,
    const_lengths: HashMap<String, usize>,
}

impl<'a> Builder<'a> {
    fn pairs(&self) -> Vec<(usize, usize)> {
        self.vars.trig_pairs.clone()
    }

    fn check_room(&self) -> Result<()> {
        if self.vars.vars.len() > MAX_VARS {
            return Err(Error::other(format!(
                "the spec needs more than {MAX_VARS} symbolic variables, the most the exact \
                 engine holds (a revolute joint's reading and each unknown or irrational angle \
                 take two, each unknown length one): make the parameters that drawings fix \
                 `known: true` (`predict` needs none of this)"
            )));
        }
        Ok(())
    }

    /// `(cos, sin)` of a constant angle.
    fn const_angle(&mut self, value: &Exact, label: String) -> Result<(Poly, Poly)> {
        if let Some((c, s)) = value.exact_cos_sin() {
            return Ok((Poly::int(i64::from(c)), Poly::int(i64::from(s))));
        }
        let v = value.to_f64();
        let (ci, si) = match self.const_pairs.get(&label) {
            Some(p) => *p,
            None => {
                let p = self.vars.push_pair(
                    Var::ConstCos(v, label.clone()),
                    Var::ConstSin(v, label.clone()),
                );
                self.check_room()?;
                self.const_pairs.insert(label, p);
                p
            }
        };
        Ok((Poly::var(ci), Poly::var(si)))
    }

    fn const_length(&mut self, value: &Exact, label: String) -> Result<Poly> {
        if value.is_rational() {
            return Ok(Poly::constant(value.rational.clone().into()));
        }
        let i = match self.const_lengths.get(&label) {
            Some(i) => *i,
            None => {
                let i = self
                    .vars
                    .push(Var::ConstLength(value.to_f64(), label.clone()));
                self.check_room()?;
                self.const_lengths.insert(label, i);
                i
            }
        };
        Ok(Poly::var(i))
    }

    pub(super) fn angle(&mut self, slot: &Slot, field: &str) -> Result<(Poly, Poly)> {
        match slot {
            Slot::Const(e) => self.const_angle(e, e.to_string()),
            Slot::Param(name) => {
                if let Some((_, pv)) = self.estimated.get(name.as_str()) {
                    match *pv {
                        ParamVars::Angle(c, s) => Ok((Poly::var(c), Poly::var(s))),
                        ParamVars::Length(_) => Err(role_error(name, field)),
                    }
                } else if let Some(p) = self.known.get(name.as_str()) {
                    let nominal = p.nominal.clone();
                    self.const_angle(&nominal, name.clone())
                } else {
                    Err(unknown_param(name, field))
                }
            }
        }
    }

    pub(super) fn length(&mut self, slot: &Slot, field: &str) -> Result<Poly> {
        match slot {
            Slot::Const(e) => self.const_length(e, e.to_string()),
            Slot::Param(name) => {
                if let Some((_, pv)) = self.estimated.get(name.as_str()) {
                    match *pv {
                        ParamVars::Length(v) => Ok(Poly::var(v)),
                        ParamVars::Angle(..) => Err(role_error(name, field)),
                    }
                } else if let Some(p) = self.known.get(name.as_str()) {
                    let nominal = p.nominal.clone();
                    self.const_length(&nominal, name.clone())
                } else {
                    Err(unknown_param(name, field))
                }
            }
        }
    }
}

fn role_error(name: &str, field: &str) -> Error {
    Error::input(
        crate::error::Location {
            field: Some(field.to_string()),
            ..Default::default()
        },
        format!("parameter `{name}` is used both as an angle and as a length"),
    )
}

fn unknown_param(name: &str, field: &str) -> Error {
    Error::input(
        crate::error::Location {
            field: Some(field.to_string()),
            ..Default::default()
        },
        format!("`{name}` is not in `params`"),
    )
}

/// The base transform `Tr(x,y,z)·Rz(yaw)·Ry(pitch)·Rx(roll)`.
fn base_transform(b: &mut Builder<'_>, base: &Base) -> Result<Transform> {
    frame_transform(b, base, "base")
}

/// A frame's transform `Tr(x,y,z)·Rz(yaw)·Ry(pitch)·Rx(roll)` (the base, a joint's origin),
/// its slots named under `field`.
fn frame_transform(b: &mut Builder<'_>, frame: &Base, field: &str) -> Result<Transform> {
    let t = [
        b.length(&frame.x, &format!("{field}.x"))?,
        b.length(&frame.y, &format!("{field}.y"))?,
        b.length(&frame.z, &format!("{field}.z"))?,
    ];
    let r = rpy_matrix(b, [&frame.roll, &frame.pitch, &frame.yaw], field)?;
    Ok(Transform { r, t, norm: None })
}

/// The tool frame's axes (the columns of `Rz(yaw)·Ry(pitch)·Rx(roll)`, or of the identity
/// for a tool point), as directions to carry through the chain.
fn tool_axes(b: &mut Builder<'_>, spec: &Spec) -> Result<[[Poly; 3]; 3]> {
    let r = match &spec.tool_rotation {
        Some([roll, pitch, yaw]) => rpy_matrix(b, [roll, pitch, yaw], "tool")?,
        None => std::array::from_fn(|i| {
            std::array::from_fn(|j| if i == j { Poly::int(1) } else { Poly::zero() })
        }),
    };
    Ok(std::array::from_fn(|c| {
        std::array::from_fn(|i| r[i][c].clone())
    }))
}

/// `Rz(yaw)·Ry(pitch)·Rx(roll)` (row-major) from the slots `[roll, pitch, yaw]` of the frame
/// at `field` (`base`, `tool`).
fn rpy_matrix(b: &mut Builder<'_>, rpy: [&Slot; 3], field: &str) -> Result<[[Poly; 3]; 3]> {
    let (cr, sr) = b.angle(rpy[0], &format!("{field}.roll"))?;
    let (cp, sp) = b.angle(rpy[1], &format!("{field}.pitch"))?;
    let (cy, sy) = b.angle(rpy[2], &format!("{field}.yaw"))?;
    let pairs = b.pairs();
    let pr = &pairs;
    // Rz(y)Ry(p)Rx(r)
    let r = [
        [
            m(&cy, &cp, pr)?,
            m(&m(&cy, &sp, pr)?, &sr, pr)?.sub(&m(&sy, &cr, pr)?),
            m(&m(&cy, &sp, pr)?, &cr, pr)?.add(&m(&sy, &sr, pr)?),
        ],
        [
            m(&sy, &cp, pr)?,
            m(&m(&sy, &sp, pr)?, &sr, pr)?.add(&m(&cy, &cr, pr)?),
            m(&m(&sy, &sp, pr)?, &cr, pr)?.sub(&m(&cy, &sr, pr)?),
        ],
        [sp.neg(), m(&cp, &sr, pr)?, m(&cp, &cr, pr)?],
    ];
    Ok(r)
}

/// The default bound on the terms of any polynomial of an expansion: 1-4 GB of memory and
/// seconds at the bound (up to 1 000 bytes per predicted term, measured). A chain with every
/// parameter unknown seldom meets it: its basis is the full grid, proven without the
/// expansion (`symbolic/coverage.rs`, every kind to 9 joints and beyond; the direct expansion
/// is tried first only to 200 000 terms a polynomial). It bounds what remains: a
/// basis that is not the grid (known parameters; a quadric with fixed entries of `A`, from 5
/// joints), where span-equivalent links (`symbolic/surrogate.rs`) cannot stand in.
/// An automatic start builds within a smaller bound ([`crate::calibrate::AUTO_MAX_TERMS`]).
pub const DEFAULT_MAX_TERMS: usize = 4_000_000;

/// Upper bound on the terms of `R v + t` row by row (the largest row).
fn predicted_apply<P: ChainPoly>(l: &Transform<P>, v: &[P; 3]) -> usize {
    (0..3)
        .map(|i| {
            l.t[i].len()
                + (0..3)
                    .map(|j| l.r[i][j].len().saturating_mul(v[j].len()))
                    .sum::<usize>()
        })
        .max()
        .unwrap_or(0)
}

/// Expands a validated spec; no polynomial may grow beyond `max_terms` terms, nor beyond
/// what the memory this process has left holds at the call (about 1 000 bytes a term; a
/// bound per polynomial, not on their sum, so it turns the clearest cases into a refusal
/// and depends on the memory free at the time). The size of
/// each product is bounded before it is formed (the sum of the products of the factors'
/// term counts), so a spec too large is refused in moments, before the memory is spent.
///
/// # Errors
/// A parameter used in a slot of the wrong role, a name missing from `params` (validation
/// normally catches both), a spec too large for the monomial encoding, or an expansion that
/// would cross `max_terms` (naming the spec, the size, the limit and what reduces it).
pub fn expand_with(spec: &Spec, max_terms: usize) -> Result<Expansion> {
    expand_within(spec, max_terms, None)
}

/// [`expand_with`], refused too once all the polynomials together pass `max_total` terms
/// (checked after each constraint).
///
/// # Errors
/// As [`expand_with`]; more terms than `max_total` in all.
pub(super) fn expand_within(
    spec: &Spec,
    max_terms: usize,
    max_total: Option<usize>,
) -> Result<Expansion> {
    // No polynomial larger than the memory left could hold (an address-space limit, a
    // cgroup): refused by size like one beyond --max-terms, not aborted by the allocator.
    let max_terms = max_terms.min(usize::try_from(memory_terms()).unwrap_or(usize::MAX));
    let (vars, estimated, pieces) = pieces(spec)?;
    let pairs = vars.trig_pairs.clone();
    // A sum or copy that could not allocate gave an empty stand-in (`poly::OUT_OF_MEMORY`):
    // whatever the expansion made of it, the answer is the memory error.
    let _ = super::poly::take_out_of_memory();
    let formed = equations(spec, pieces, pairs.as_slice(), max_terms, max_total);
    if super::poly::take_out_of_memory() {
        return Err(ProductError::Memory.into());
    }
    let equations = formed?
        .into_iter()
        .map(|(constraint, poly)| Equation { constraint, poly })
        .collect();
    Ok(Expansion {
        vars,
        param_names: estimated.names,
        param_vars: estimated.vars,
        equations,
    })
}

/// The small pieces an expansion multiplies out: each link's transform (base to tip), the
/// tool point, the base transform, the tool frame's axes (for a measured pose) and each
/// constraint's values, exact ([`pieces`]) or a sketch's image of them
/// ([`super::sketch`]).
pub(super) struct Pieces<P> {
    pub(super) links: Vec<Transform<P>>,
    pub(super) tool: [P; 3],
    pub(super) base: Option<Transform<P>>,
    pub(super) axes: Option<[[P; 3]; 3]>,
    pub(super) values: Vec<Vec<P>>,
}

impl<P> Pieces<P> {
    /// Each polynomial's image under `f`; `None` as soon as one has none.
    pub(super) fn try_map<Q>(&self, f: &mut impl FnMut(&P) -> Option<Q>) -> Option<Pieces<Q>> {
        let links = self
            .links
            .iter()
            .map(|l| l.try_map(f))
            .collect::<Option<Vec<_>>>()?;
        let base = match &self.base {
            Some(b) => Some(b.try_map(f)?),
            None => None,
        };
        let axes = match &self.axes {
            Some([a0, a1, a2]) => Some([try_map3(a0, f)?, try_map3(a1, f)?, try_map3(a2, f)?]),
            None => None,
        };
        let values = self
            .values
            .iter()
            .map(|v| v.iter().map(&mut *f).collect::<Option<Vec<_>>>())
            .collect::<Option<Vec<_>>>()?;
        Some(Pieces {
            links,
            tool: try_map3(&self.tool, f)?,
            base,
            axes,
            values,
        })
    }
}

/// The variables, the estimated parameters and the exact [`Pieces`] of a validated spec, the
/// variables numbered in the order the expansion has always met them (links, tool, base,
/// tool frame, constraints), which fixes the basis' display order.
///
/// # Errors
/// A parameter used in a slot of the wrong role, a name missing from `params`, a spec too
/// large for the monomial encoding.
pub(super) fn pieces(spec: &Spec) -> Result<(VarTable, Estimated, Pieces<Poly>)> {
    let (mut b, estimated) = Builder::for_spec(spec)?;
    let mut links = Vec::with_capacity(spec.joints.len());
    for (i, j) in spec.joints.iter().enumerate() {
        links.push(link(&mut b, spec.convention, i, j)?);
    }
    let mut tool = [Poly::zero(), Poly::zero(), Poly::zero()];
    for (k, s) in spec.tool.iter().enumerate().take(3) {
        tool[k] = b.length(s, &format!("tool[{k}]"))?;
    }
    let base = match &spec.base {
        Some(base) => Some(base_transform(&mut b, base)?),
        None => None,
    };
    // A measured pose also measures the tool frame's axes: carried through the rotations.
    let axes = if spec.is_measured_pose() {
        Some(tool_axes(&mut b, spec)?)
    } else {
        None
    };
    let values = spec
        .constraints
        .iter()
        .enumerate()
        .map(|(ci, c)| constraint_values(&mut b, spec, ci, c))
        .collect::<Result<Vec<_>>>()?;
    let pieces = Pieces {
        links,
        tool,
        base,
        axes,
        values,
    };
    Ok((b.vars, estimated, pieces))
}

/// The constraint functions `h_e(q; p)` of `spec` from its `pieces`, each with the index of
/// its constraint, in constraint order: the tip carried through the chain, then each
/// constraint's formula. No polynomial may grow beyond `max_terms` terms, nor (with
/// `max_total`) all of them together beyond `max_total`, checked after each constraint.
///
/// # Errors
/// An expansion that would cross `max_terms` or `max_total`; an exponent beyond 15.
pub(super) fn equations<P: ChainPoly>(
    spec: &Spec,
    pieces: Pieces<P>,
    pairs: &P::Ctx,
    max_terms: usize,
    max_total: Option<usize>,
) -> Result<Vec<(usize, P)>> {
    let Pieces {
        links,
        tool,
        base,
        axes,
        values,
    } = pieces;
    let (tip, carried) = chain_product(spec, &links, base.as_ref(), tool, pairs, max_terms)?;
    let (norm2, moments) = (carried.norm2, carried.moments);
    let axes = match axes {
        Some(axes) => Some(chain_axes(
            spec,
            &links,
            base.as_ref(),
            axes,
            pairs,
            max_terms,
        )?),
        None => None,
    };
    // The last constraint takes the tip and the axes: a measured tip's equations are the tip
    // itself, and a copy of the whole expansion would be its largest allocation.
    let mut equations = Vec::new();
    let (mut tip, mut axes) = (tip, axes);
    let last = spec.constraints.len().saturating_sub(1);
    for (ci, c) in spec.constraints.iter().enumerate() {
        let tip_here = if ci == last {
            Cow::Owned(std::mem::take(&mut tip))
        } else {
            Cow::Borrowed(tip.as_slice())
        };
        // The size of the largest product is bounded before the kind's formula forms it.
        let predicted =
            predicted_constraint(c, &tip_here, spec.dim, norm2.is_some(), moments.as_ref());
        if predicted > max_terms {
            let at = format!("in `{}`", constraint_field(spec, ci, c));
            return Err(too_big(spec, predicted, max_terms, &at));
        }
        let carried = (norm2.as_ref(), moments.as_ref());
        let mut hs = constraint_polys(c, &values[ci], tip_here, carried, spec.dim, pairs)?;
        if let Constraint::MeasuredPose { .. } = c {
            // The 9 rotation entries after the 3 coordinates, column-major.
            if ci == last {
                hs.extend(axes.take().into_iter().flatten().flatten());
            } else if let Some(axes) = &axes {
                hs.extend(axes.iter().flatten().cloned());
            }
        }
        equations.extend(hs.into_iter().map(|h| (ci, h)));
        let total: usize = equations.iter().map(|(_, h)| h.len()).sum();
        if let Some(max) = max_total.filter(|&m| total > m) {
            return Err(Error::other(format!(
                "the constraint polynomials have more than {max} terms ({total} after {} of {} \
                 constraints)",
                ci + 1,
                spec.constraints.len()
            )));
        }
    }
    Ok(equations)
}

/// The estimated parameters, in spec order: the vector `p`.
pub(super) struct Estimated {
    pub(super) names: Vec<String>,
    pub(super) vars: Vec<ParamVars>,
    pub(super) nominals: Vec<f64>,
}

impl<'a> Builder<'a> {
    /// The variable table's fixed part: the joint variables first (so that they are
    /// `0..joint_vars`), then one variable (length) or pair (angle) per estimated parameter;
    /// known parameters are kept aside to be substituted.
    pub(super) fn for_spec(spec: &'a Spec) -> Result<(Self, Estimated)> {
        let mut b = Builder {
            vars: VarTable::default(),
            estimated: HashMap::new(),
            known: HashMap::new(),
            const_pairs: HashMap::new(),
            const_lengths: HashMap::new(),
        };
        for (i, j) in spec.joints.iter().enumerate() {
            match j.kind {
                JointKind::Revolute => {
                    b.vars.push_pair(Var::JointCos(i), Var::JointSin(i));
                }
                JointKind::Prismatic => {
                    b.vars.push(Var::JointLinear(i));
                }
            }
        }
        b.vars.joint_vars = b.vars.vars.len();
        let mut est = Estimated {
            names: Vec::new(),
            vars: Vec::new(),
            nominals: Vec::new(),
        };
        for p in &spec.params {
            if p.known {
                b.known.insert(&p.name, p);
                continue;
            }
            let j = est.names.len();
            let pv = match p.role {
                ParamRole::Length => ParamVars::Length(b.vars.push(Var::ParamLength(j))),
                ParamRole::Angle => {
                    let (c, s) = b.vars.push_pair(Var::ParamCos(j), Var::ParamSin(j));
                    ParamVars::Angle(c, s)
                }
            };
            b.check_room()?;
            b.estimated.insert(&p.name, (j, pv));
            est.names.push(p.name.clone());
            est.vars.push(pv);
            est.nominals.push(p.nominal.to_f64());
        }
        Ok((b, est))
    }
}

/// The transform of joint `i`: its DH quantities as polynomials (`θ = q − home` expanded by
/// the angle-difference formulas for a revolute joint, `d = q + offset + d` for a prismatic
/// one), then the convention's product.
fn link(b: &mut Builder<'_>, conv: Convention, i: usize, j: &Joint) -> Result<Transform> {
    if conv == Convention::Urdf {
        // The origin's variables first, as `slots::slot_polys` numbers them.
        let origin = frame_transform(b, &j.origin, &format!("joints[{i}]"))?;
        let row = row(b, conv, i, j)?;
        return origin.then(&row, &b.pairs());
    }
    row(b, conv, i, j)
}

/// The DH row of joint `i` (after its origin in [`Convention::Urdf`]).
fn row(b: &mut Builder<'_>, conv: Convention, i: usize, j: &Joint) -> Result<Transform> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let (ca, sa) = b.angle(&j.alpha, &f("alpha"))?;
    let a = b.length(&j.a, &f("a"))?;
    let (ct, st, d) = match j.kind {
        JointKind::Revolute => {
            let (ch, sh) = b.angle(&j.home, &f("home"))?;
            let d = b.length(&j.d, &f("d"))?;
            let (cq, sq) = joint_pair(&b.vars, i);
            let pairs = b.pairs();
            // θ = q − home: cos θ = cq·ch + sq·sh, sin θ = sq·ch − cq·sh.
            let ct = m(&cq, &ch, &pairs)?.add(&m(&sq, &sh, &pairs)?);
            let st = m(&sq, &ch, &pairs)?.sub(&m(&cq, &sh, &pairs)?);
            (ct, st, d)
        }
        JointKind::Prismatic => {
            let (ct, st) = b.angle(&j.theta, &f("theta"))?;
            let off = b.length(&j.offset, &f("offset"))?;
            let dslot = b.length(&j.d, &f("d"))?;
            let qv = joint_linear(&b.vars, i);
            (ct, st, Poly::var(qv).add(&off).add(&dslot))
        }
    };
    let (cb, sb) = b.angle(&j.beta, &f("beta"))?;
    let pairs = b.pairs();
    if sb.is_zero() && cb == Poly::int(1) {
        return dh(conv.row(), &ct, &st, &ca, &sa, &a, &d, &pairs);
    }
    tilted(
        conv.row(),
        [&ct, &st],
        [&ca, &sa],
        [&cb, &sb],
        [&a, &d],
        &pairs,
    )
}

/// What [`chain_product`] carries besides the tip: `‖tip‖²` for a sphere or a circle, and the
/// tip's second moments `x xᵀ` ([`moment`] order) for a quadric or a circle.
struct Carried<P> {
    norm2: Option<P>,
    moments: Option<[P; 6]>,
}

/// What [`chain_product`] carries, at the tool point `v`: `‖v‖²` for a sphere, `v vᵀ` for a
/// quadric or a circle.
fn carried_at_the_tool<P: ChainPoly>(
    spec: &Spec,
    v: &[P; 3],
    pairs: &P::Ctx,
) -> Result<Carried<P>> {
    let has = |f: fn(&Constraint) -> bool| spec.constraints.iter().any(f);
    let norm2 = if has(|c| matches!(c, Constraint::Sphere { .. })) {
        let mut n = P::default();
        for x in v {
            n = n.add(&x.square(pairs)?);
        }
        Some(n)
    } else {
        None
    };
    let moments = if has(|c| matches!(c, Constraint::Circle { .. } | Constraint::Quadric { .. })) {
        let mut x2: [P; 6] = Default::default();
        for i in 0..3 {
            for j in i..3 {
                x2[moment(i, j)] = m(&v[i], &v[j], pairs)?;
            }
        }
        Some(x2)
    } else {
        None
    };
    Ok(Carried { norm2, moments })
}

/// The tip: the tool vector carried through the links from the tool back to the base, then
/// the base transform. With it `‖tip‖²` for a sphere (`n ↦ n + 2(Rᵀt)·v + ‖t‖²`), and the
/// second moments `x xᵀ` for a quadric or a circle (a circle's planar `‖tip‖²` is `X_00 + X_11`),
/// built along the chain: cheaper than squaring the tip. Each product's size is bounded
/// before it is formed, so a spec too large is refused at once.
fn chain_product<P: ChainPoly>(
    spec: &Spec,
    links: &[Transform<P>],
    base: Option<&Transform<P>>,
    tool: [P; 3],
    pairs: &P::Ctx,
    max_terms: usize,
) -> Result<(Vec<P>, Carried<P>)> {
    let mut v = tool;
    let circle = spec
        .constraints
        .iter()
        .any(|c| matches!(c, Constraint::Circle { .. }));
    let Carried {
        mut norm2,
        mut moments,
    } = carried_at_the_tool(spec, &v, pairs)?;
    let joints = links.len();
    let steps = links
        .iter()
        .rev()
        .enumerate()
        .map(|(k, l)| {
            (
                l,
                format!("link {} of {joints} (counting from the tool)", k + 1),
            )
        })
        .chain(base.map(|b| (b, "the base transform".to_string())));
    for (l, at) in steps {
        let predicted = predicted_apply(l, &v);
        if predicted > max_terms {
            return Err(too_big(spec, predicted, max_terms, &format!("at {at}")));
        }
        if let Some(n) = &mut norm2 {
            *n = l.norm2_after(&v, n, pairs)?;
            if n.len() > max_terms {
                return Err(too_big(
                    spec,
                    n.len(),
                    max_terms,
                    &format!("in ‖x‖² at {at}"),
                ));
            }
        }
        if let Some(x2) = &mut moments {
            let predicted = l.predicted_moments(&v, x2);
            if predicted > max_terms {
                return Err(too_big(
                    spec,
                    predicted,
                    max_terms,
                    &format!("in x·xᵀ at {at}"),
                ));
            }
            *x2 = l.moments_after(&v, x2, pairs)?;
        }
        v = l.apply(&v, pairs)?;
    }
    if circle {
        // A circle's tip is planar (dim 2) and a sphere's spatial: never both in one spec.
        debug_assert!(norm2.is_none(), "a circle and a sphere in one spec");
        if let Some(x2) = &moments {
            norm2 = Some(x2[moment(0, 0)].add(&x2[moment(1, 1)]));
        }
    }
    Ok((
        v.into_iter().take(spec.dim).collect(),
        Carried { norm2, moments },
    ))
}

/// The tool frame's axes (directions `axes`, in the last frame) carried through the links'
/// and the base's rotations to the world: the columns of the tool frame's rotation.
fn chain_axes<P: ChainPoly>(
    spec: &Spec,
    links: &[Transform<P>],
    base: Option<&Transform<P>>,
    axes: [[P; 3]; 3],
    pairs: &P::Ctx,
    max_terms: usize,
) -> Result<[[P; 3]; 3]> {
    let mut out = axes;
    let joints = links.len();
    for v in &mut out {
        for (k, l) in links.iter().rev().enumerate() {
            let predicted = predicted_apply(l, v);
            if predicted > max_terms {
                let at = format!(
                    "in the tool frame's axes at link {} of {joints} (counting from the tool)",
                    k + 1
                );
                return Err(too_big(spec, predicted, max_terms, &at));
            }
            *v = l.rotate(v, pairs)?;
        }
        if let Some(bt) = base {
            *v = bt.rotate(v, pairs)?;
        }
    }
    Ok(out)
}

/// The field of constraint `ci` in the spec (`constraints[1].plane`, `constraint.point`).
fn constraint_field(spec: &Spec, ci: usize, c: &Constraint) -> String {
    if spec.constraint_list {
        format!("constraints[{ci}].{}", c.kind_name())
    } else {
        format!("constraint.{}", c.kind_name())
    }
}

/// Constraint `ci`'s values as polynomials, in [`Constraint::slots`] order.
///
/// # Errors
/// As [`Builder::length`].
pub(super) fn constraint_values(
    b: &mut Builder<'_>,
    spec: &Spec,
    ci: usize,
    c: &Constraint,
) -> Result<Vec<Poly>> {
    let prefix = constraint_field(spec, ci, c);
    c.slots()
        .into_iter()
        .enumerate()
        .map(|(k, s)| b.length(s, &format!("{prefix}[{k}]")))
        .collect()
}

fn joint_pair(vars: &VarTable, i: usize) -> (Poly, Poly) {
    let c = vars
        .vars
        .iter()
        .position(|v| *v == Var::JointCos(i))
        .unwrap_or(0);
    let s = vars
        .vars
        .iter()
        .position(|v| *v == Var::JointSin(i))
        .unwrap_or(0);
    (Poly::var(c), Poly::var(s))
}

fn joint_linear(vars: &VarTable, i: usize) -> usize {
    vars.vars
        .iter()
        .position(|v| *v == Var::JointLinear(i))
        .unwrap_or(0)
}
