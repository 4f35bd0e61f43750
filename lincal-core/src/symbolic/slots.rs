//! The spec's slots as the expansion sees them, without the expansion: every DH quantity,
//! the tool, the base and the constraint values as tiny polynomials (a constant, one
//! variable, or a `(cos, sin)` pair) over the same [`VarTable`] the expansion builds, in the
//! same order. The sampled identifiability analysis ([`super::identify::sampled`]) evaluates
//! the chain from these at joint readings, so it sees exactly the constraint functions the
//! expansion would form (known multiples of π/2 exact, other known angles and irrational
//! lengths as generic symbols) at no cost in `K`.

use super::expand::{constraint_values, Builder, ParamVars};
use super::monomial::VarTable;
use super::poly::Poly;
use crate::error::Result;
use crate::spec::kinematics::SlotRef;
use crate::spec::{Base, Constraint, Convention, JointKind, Spec};

/// One joint's quantities: `θ = q − home` (revolute) or the fixed `θ` with
/// `d = q + offset + d` (prismatic).
#[derive(Clone, Debug)]
pub(crate) struct LinkSlots {
    /// `(cos α, sin α)`.
    pub alpha: (Poly, Poly),
    /// `a`.
    pub a: Poly,
    /// `(cos, sin)` of the home offset (revolute) or of the fixed angle `θ` (prismatic).
    pub angle: (Poly, Poly),
    /// `d` (for a prismatic joint, the fixed part added to `q + offset`).
    pub d: Poly,
    /// The prismatic joint's `offset`; `None` for a revolute joint.
    pub offset: Option<Poly>,
    /// `(cos β, sin β)` of Hayati's tilt; `None` when it is the constant 0.
    pub beta: Option<(Poly, Poly)>,
    /// The joint's origin ([`crate::spec::Joint::origin`]) in [`Convention::Urdf`], before
    /// the row; `None` in DH and modified DH.
    pub origin: Option<BaseSlots>,
}

/// The base's `(cos, sin)` of roll, pitch, yaw and its translation.
#[derive(Clone, Debug)]
pub(crate) struct BaseSlots {
    /// Roll, pitch, yaw as `(cos, sin)`.
    pub rpy: [(Poly, Poly); 3],
    /// Translation.
    pub t: [Poly; 3],
}

/// Everything of a spec the chain and the constraint functions are made of.
#[derive(Clone, Debug)]
pub(crate) struct SlotPolys {
    /// The variables (joint variables first), as [`super::expand::expand_with`] numbers them.
    pub vars: VarTable,
    /// The estimated parameters' names (spec order).
    pub param_names: Vec<String>,
    /// Their representation.
    pub param_vars: Vec<ParamVars>,
    /// Their nominal values.
    pub param_nominals: Vec<f64>,
    /// The convention.
    pub convention: Convention,
    /// The spec's `dim`.
    pub dim: usize,
    /// Per joint.
    pub links: Vec<LinkSlots>,
    /// The tool vector.
    pub tool: [Poly; 3],
    /// The base transform, if any.
    pub base: Option<BaseSlots>,
    /// When the tool frame's pose is measured: its rotation's roll, pitch, yaw as
    /// `(cos, sin)` (all zero angles for a tool point).
    pub tool_rpy: Option<[(Poly, Poly); 3]>,
    /// The constraints and their values in [`Constraint::slots`] order.
    pub constraints: Vec<(Constraint, Vec<Poly>)>,
}

/// When the tool frame's pose is measured, its roll, pitch, yaw as `(cos, sin)` (zero angles
/// for a tool point).
fn tool_rpy(b: &mut Builder<'_>, spec: &Spec) -> Result<Option<[(Poly, Poly); 3]>> {
    if !spec.is_measured_pose() {
        return Ok(None);
    }
    let zero = crate::spec::Slot::zero();
    let [r, p, y] = spec
        .tool_rotation
        .clone()
        .unwrap_or_else(|| [zero.clone(), zero.clone(), zero]);
    Ok(Some([
        b.angle(&r, "tool.roll")?,
        b.angle(&p, "tool.pitch")?,
        b.angle(&y, "tool.yaw")?,
    ]))
}

/// A frame's slots (the base, a joint's origin) under `field`, in the expansion's order:
/// the translation, then roll, pitch, yaw.
fn frame_slots(b: &mut Builder<'_>, frame: &Base, field: &str) -> Result<BaseSlots> {
    let t = [
        b.length(&frame.x, &format!("{field}.x"))?,
        b.length(&frame.y, &format!("{field}.y"))?,
        b.length(&frame.z, &format!("{field}.z"))?,
    ];
    Ok(BaseSlots {
        rpy: [
            b.angle(&frame.roll, &format!("{field}.roll"))?,
            b.angle(&frame.pitch, &format!("{field}.pitch"))?,
            b.angle(&frame.yaw, &format!("{field}.yaw"))?,
        ],
        t,
    })
}

/// The slots of a validated spec, visited in the expansion's order (so the variables are
/// numbered alike).
///
/// # Errors
/// As the expansion's builder: a parameter of the wrong role or missing from `params`, too
/// many symbolic variables.
pub(crate) fn slot_polys(spec: &Spec) -> Result<SlotPolys> {
    let (mut b, est) = Builder::for_spec(spec)?;
    let mut links = Vec::with_capacity(spec.joints.len());
    for (i, j) in spec.joints.iter().enumerate() {
        let f = |s: &str| format!("joints[{i}].{s}");
        // The origin first, as the expansion visits it.
        let origin = if spec.convention == Convention::Urdf {
            Some(frame_slots(&mut b, &j.origin, &format!("joints[{i}]"))?)
        } else {
            None
        };
        let alpha = b.angle(&j.alpha, &f("alpha"))?;
        let a = b.length(&j.a, &f("a"))?;
        let mut link = match j.kind {
            JointKind::Revolute => {
                let angle = b.angle(&j.home, &f("home"))?;
                let d = b.length(&j.d, &f("d"))?;
                LinkSlots {
                    alpha,
                    a,
                    angle,
                    d,
                    offset: None,
                    beta: None,
                    origin,
                }
            }
            JointKind::Prismatic => {
                let angle = b.angle(&j.theta, &f("theta"))?;
                let offset = Some(b.length(&j.offset, &f("offset"))?);
                let d = b.length(&j.d, &f("d"))?;
                LinkSlots {
                    alpha,
                    a,
                    angle,
                    d,
                    offset,
                    beta: None,
                    origin,
                }
            }
        };
        // Last, as the expansion visits it.
        let (cb, sb) = b.angle(&j.beta, &f("beta"))?;
        if !(sb.is_zero() && cb == Poly::int(1)) {
            link.beta = Some((cb, sb));
        }
        links.push(link);
    }
    let mut tool = [Poly::zero(), Poly::zero(), Poly::zero()];
    for (k, s) in spec.tool.iter().enumerate().take(3) {
        tool[k] = b.length(s, &format!("tool[{k}]"))?;
    }
    let base = match &spec.base {
        Some(base) => Some(frame_slots(&mut b, base, "base")?),
        None => None,
    };
    // In the expansion's order: the tool frame's rotation after the base.
    let tool_rpy = tool_rpy(&mut b, spec)?;
    let mut constraints = Vec::with_capacity(spec.constraints.len());
    for (ci, c) in spec.constraints.iter().enumerate() {
        constraints.push((c.clone(), constraint_values(&mut b, spec, ci, c)?));
    }
    Ok(SlotPolys {
        vars: b.vars,
        param_names: est.names,
        param_vars: est.vars,
        param_nominals: est.nominals,
        convention: spec.convention,
        dim: spec.dim,
        links,
        tool,
        base,
        tool_rpy,
        constraints,
    })
}

/// Each constraint's value slots, resolved against the spec.
pub(super) fn constraint_slots(spec: &Spec) -> Vec<Vec<SlotRef>> {
    spec.constraints
        .iter()
        .map(|c| {
            c.slots()
                .into_iter()
                .map(|s| SlotRef::resolve(spec, s))
                .collect()
        })
        .collect()
}
