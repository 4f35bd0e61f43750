//! The meaning checks of a [`Spec`]: every problem at once, each at its field path.
//!
//! [`super::load`] checks the YAML's shape (fields, types, lengths of fixed-size entries) and
//! builds a `Spec`; this module checks what the `Spec` says, whatever built it (the YAML loader
//! or the derive's lowering):
//! - `name` is an identifier, `dim` is 2 or 3, there is at least one joint;
//! - revolute joints have no `theta`/`offset`, prismatic joints no `home`/`d`;
//! - joint limits are finite with `min < max`;
//! - a planar (`dim: 2`) arm rotates about z: every `alpha` is the constant 0 or π, every
//!   `beta` 0, and the base has no `z`, `roll` or `pitch`;
//! - `tool` and every constraint entry have `dim` entries, each constraint kind fits `dim`,
//!   a quadric's `A` is `dim × dim` and symmetric (constants compared exactly, names by
//!   identity);
//! - exactly one constraint for `constraint:`, at least one for `constraints:`, and a list
//!   does not mix `measured` with geometric constraints;
//! - every name used in a slot is a parameter, every parameter is used, and each parameter
//!   is used either only in angle slots (`home`, `alpha`, `beta`, `theta`, base angles) or
//!   only in length slots, which sets [`Param::role`].
//!
//! Places come from a [`Locate`]: the loader's maps field paths to file, line and column;
//! [`FieldsOnly`] gives the field path alone.

use super::{Base, Constraint, Param, ParamRole, Slot, Spec};
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};
use joints::{check_convention_slots, check_joints};

mod empty;
mod joints;

/// Maps a field path (`joints[1].home`, `params.a1`) to a place in the spec's source.
pub trait Locate {
    /// The place of the value at `field`.
    fn value(&self, field: &str) -> Location;

    /// The place of the key of the mapping entry at `field` (by default, the value's place).
    fn key(&self, field: &str) -> Location {
        self.value(field)
    }
}

/// A [`Locate`] that knows no source: locations carry the field path only.
#[derive(Clone, Copy, Debug, Default)]
pub struct FieldsOnly;

impl Locate for FieldsOnly {
    fn value(&self, field: &str) -> Location {
        Location {
            field: Some(field.to_string()),
            ..Location::default()
        }
    }
}

/// Validates `spec` and sets each parameter's [`Param::role`].
///
/// Locations carry field paths only; [`super::from_yaml_str`] adds file, line and column.
///
/// # Errors
/// An [`ErrorClass::Input`] error with every problem found.
pub fn validate(spec: &mut Spec) -> Result<()> {
    let diagnostics = check(spec, &FieldsOnly);
    if diagnostics.is_empty() {
        Ok(())
    } else {
        Err(Error::from_diagnostics(ErrorClass::Input, diagnostics))
    }
}

/// Every problem of `spec`, located by `locate`; sets each parameter's [`Param::role`] (a
/// parameter used in no slot, or in both kinds of slot, keeps [`ParamRole::Length`]).
#[must_use]
pub fn check(spec: &mut Spec, locate: &dyn Locate) -> Vec<Diagnostic> {
    check_with(spec, locate, &Context::default())
}

/// What the loader already knows when it calls the checks.
#[derive(Debug, Default)]
pub(crate) struct Context {
    /// Field paths the loader already reported: problems at these paths or below them are
    /// consequences and are not reported again.
    pub reported: Vec<String>,
    /// Names in slots the loader read but could not place in the spec (a wrong-length list, a
    /// joint of unknown type): they count as used, so that no "never used" error follows.
    pub used_elsewhere: Vec<String>,
    /// Field path of each entry of `spec.constraints` (e.g. `constraints[2]`), when the
    /// loader skipped entries it could not build; `None`: derived from the position.
    pub constraint_paths: Option<Vec<String>>,
    /// The loader could not build every constraint entry: skip the count checks.
    pub constraints_incomplete: bool,
    /// The loader rejected a whole section (e.g. `joints` is not a list): the uses of the
    /// parameters are unknown, so skip the "never used" check.
    pub uses_incomplete: bool,
}

/// Whether the constraint `kind` (interface name) exists in `dim`, else what to use instead.
pub(crate) fn kind_fits_dim(
    kind: &str,
    has_planes: bool,
    dim: usize,
) -> std::result::Result<(), String> {
    match (kind, dim) {
        ("plane", 2) => {
            Err("`plane` is a 3-D constraint; in dim 2 use `line: {b: [b1, b2]}`".into())
        }
        ("circle", 3) => Err("`circle` is a 2-D constraint; in dim 3 use `sphere`".into()),
        ("sphere", 2) => Err("`sphere` is a 3-D constraint; in dim 2 use `circle`".into()),
        ("line", 2) if has_planes => {
            Err("in dim 2 a line is `line: {b: [b1, b2]}` (b·x + 1 = 0), not `planes`".into())
        }
        ("measured_pose", 2) => Err("`measured_pose` is 3-D; in dim 2 use `measured`".into()),
        ("line", 3) if !has_planes => {
            Err("in dim 3 a line is two planes: `line: {planes: [[..3], [..3]]}`, not `b`".into())
        }
        _ => Ok(()),
    }
}

/// Whether `name` is an identifier `[A-Za-z_][A-Za-z0-9_]*` (the parameter-name syntax).
#[must_use]
pub(crate) fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether `name` is a valid parameter name: an identifier other than `pi` (any case).
#[must_use]
pub(crate) fn is_param_name(name: &str) -> bool {
    is_identifier(name) && !name.eq_ignore_ascii_case("pi")
}

/// A slot as the user would write it.
pub(crate) fn show_slot(slot: &Slot) -> String {
    match slot {
        Slot::Const(e) => {
            // A decimal as the spec wrote it (`0.5`, not `1/2`) where it is one exactly.
            let decimal = format!("{}", e.to_f64());
            let exact = super::Exact::parse(&decimal).is_ok_and(|d| d == *e);
            if exact {
                decimal
            } else {
                e.to_string()
            }
        }
        Slot::Param(n) => n.clone(),
    }
}

struct Checker<'a> {
    locate: &'a dyn Locate,
    ctx: &'a Context,
    out: Vec<Diagnostic>,
}

impl Checker<'_> {
    fn suppressed(&self, field: &str) -> bool {
        self.ctx.reported.iter().any(|r| {
            field == r
                || (field.starts_with(r.as_str())
                    && (r.is_empty() || matches!(field.as_bytes().get(r.len()), Some(b'.' | b'['))))
        })
    }

    fn at_value(&mut self, field: &str, message: String) {
        if !self.suppressed(field) {
            let location = self.locate.value(field);
            self.out.push(Diagnostic { location, message });
        }
    }

    fn at_key(&mut self, field: &str, message: String) {
        if !self.suppressed(field) {
            let location = self.locate.key(field);
            self.out.push(Diagnostic { location, message });
        }
    }
}

/// One use of a name in a slot.
struct Use {
    name: String,
    role: ParamRole,
    field: String,
}

/// Runs every rule family in turn, then the parameter rules over the names the slots use.
///
/// The families report in a fixed order (name and dim, joints, tool and base, constraints,
/// parameters), which is the order of the diagnostics.
pub(crate) fn check_with(spec: &mut Spec, locate: &dyn Locate, ctx: &Context) -> Vec<Diagnostic> {
    let mut ck = Checker {
        locate,
        ctx,
        out: Vec::new(),
    };
    check_name(&mut ck, &spec.name);
    let dim = check_dim(&mut ck, spec.dim);
    check_joints(&mut ck, &spec.joints, dim);
    check_convention_slots(&mut ck, spec, dim);
    check_tool_and_base(&mut ck, spec, dim);
    let paths = constraint_paths(spec, ctx);
    check_constraint_count(&mut ck, spec);
    for (c, prefix) in spec.constraints.iter().zip(&paths) {
        check_constraint(&mut ck, c, prefix, dim, &spec.params);
    }
    let uses = slot_uses(spec, &paths);
    check_params(&mut ck, &mut spec.params, &uses);
    ck.out
}

/// The spec's `name` is an identifier (it names generated files and types).
fn check_name(ck: &mut Checker<'_>, name: &str) {
    if !is_name(name) {
        ck.at_value(
            "name",
            format!(
                "`{name}` is not a valid name: expected an identifier (ASCII letters, digits, `_` \
                 or `-`, starting with a letter or `_`)"
            ),
        );
    }
}

/// `dim` is 2 or 3; returns it, or `None` when it is neither (the dim-specific rules are
/// then skipped rather than reported against a meaningless dimension).
fn check_dim(ck: &mut Checker<'_>, dim: usize) -> Option<usize> {
    match dim {
        2 | 3 => Some(dim),
        d => {
            ck.at_value(
                "dim",
                format!("`dim` must be 2 (planar) or 3 (spatial), found {d}"),
            );
            None
        }
    }
}

/// The base's entries, each with its role: `x`, `y`, `z` are lengths, `roll`, `pitch`,
/// `yaw` angles.
fn base_entries(b: &Base) -> [(&'static str, &Slot, ParamRole); 6] {
    [
        ("x", &b.x, ParamRole::Length),
        ("y", &b.y, ParamRole::Length),
        ("z", &b.z, ParamRole::Length),
        ("roll", &b.roll, ParamRole::Angle),
        ("pitch", &b.pitch, ParamRole::Angle),
        ("yaw", &b.yaw, ParamRole::Angle),
    ]
}

/// `tool` has `dim` entries, and a planar base moves in the plane only (no `z`, `roll`,
/// `pitch`). A tool frame (`tool: {x, y, z, roll, pitch, yaw}`) is 3-D, and its rotation
/// holds parameters only when a `measured_pose` constraint can see it.
fn check_tool_and_base(ck: &mut Checker<'_>, spec: &Spec, dim: Option<usize>) {
    if spec.tool_rotation.is_some() {
        // A constraint the loader refused may have been a `measured_pose`: say nothing then.
        let refused = ck.ctx.reported.iter().any(|r| r.starts_with("constraint"));
        for (field, message) in super::tool_frame::problems(spec, dim, refused) {
            ck.at_value(&field, message);
        }
        if dim == Some(2) {
            return;
        }
    }
    if let Some(d) = dim {
        if spec.tool.len() != d {
            ck.at_value(
                "tool",
                format!(
                    "`tool` must have {d} entries (dim {d}), found {}",
                    spec.tool.len()
                ),
            );
        }
    }
    if let (Some(b), Some(2)) = (&spec.base, dim) {
        for (name, s, _) in base_entries(b) {
            if matches!(name, "z" | "roll" | "pitch") && *s != Slot::zero() {
                ck.at_value(
                    &format!("base.{name}"),
                    format!(
                        "a planar (dim 2) base is x, y and yaw only: `{name}` must be 0, found \
                         `{}`",
                        show_slot(s)
                    ),
                );
            }
        }
    }
}

/// The field path of each constraint entry (`constraints[2]`, or `constraint` alone): the
/// loader's paths when it skipped entries, else derived from the position.
fn constraint_paths(spec: &Spec, ctx: &Context) -> Vec<String> {
    let list_name = if spec.constraint_list {
        "constraints"
    } else {
        "constraint"
    };
    (0..spec.constraints.len())
        .map(|k| {
            ctx.constraint_paths
                .as_ref()
                .and_then(|p| p.get(k).cloned())
                .unwrap_or_else(|| {
                    if spec.constraint_list {
                        format!("{list_name}[{k}]")
                    } else {
                        list_name.to_string()
                    }
                })
        })
        .collect()
}

/// Exactly one constraint under `constraint:`, at least one under `constraints:` (unless the
/// loader could not build them all), and a list does not mix `measured` with geometric
/// constraints.
fn check_constraint_count(ck: &mut Checker<'_>, spec: &Spec) {
    if !ck.ctx.constraints_incomplete {
        if spec.constraints.is_empty() {
            if spec.constraint_list {
                ck.at_value(
                    "constraints",
                    "the `constraints:` list is empty: expected at least one constraint".into(),
                );
            } else {
                ck.at_value(
                    "constraint",
                    "no constraint: expected `constraint:` (one) or `constraints:` (a list)".into(),
                );
            }
        } else if !spec.constraint_list && spec.constraints.len() > 1 {
            ck.at_value(
                "constraint",
                format!(
                    "`constraint:` holds one constraint, found {}: use `constraints:` (a list)",
                    spec.constraints.len()
                ),
            );
        }
    }
    let measured = spec
        .constraints
        .iter()
        .filter(|c| matches!(c, Constraint::Measured | Constraint::MeasuredPose { .. }))
        .count();
    if spec.constraint_list && measured > 0 && spec.constraints.len() > 1 {
        let what = if measured == spec.constraints.len() {
            "more than one measured entry (`measured`, `measured_pose`): a measured tip or pose \
             needs no list, use `constraint: measured` (or `constraint: measured_pose`)"
        } else {
            "the `constraints:` list must not mix `measured` with geometric constraints (a \
             measured tip is not held on a constraint)"
        };
        ck.at_value("constraints", what.into());
    }
}

/// One constraint entry at `prefix`: its kind fits `dim`, a radius is not negative, its
/// vectors have `dim` entries and a quadric's `A` is square and symmetric.
fn check_constraint(
    ck: &mut Checker<'_>,
    c: &Constraint,
    prefix: &str,
    dim: Option<usize>,
    params: &[Param],
) {
    let kind = c.kind_name();
    let base = format!("{prefix}.{kind}");
    // Lengths are checked against dim only when the kind fits dim.
    let mut len_dim = dim;
    if let Some(d) = dim {
        if let Err(msg) = kind_fits_dim(kind, matches!(c, Constraint::Line3 { .. }), d) {
            ck.at_key(&base, msg);
            len_dim = None;
        }
    }
    // A radius is a length from the centre: negative is a sign error.
    if let Constraint::Circle { radius, .. } | Constraint::Sphere { radius, .. } = c {
        let negative = match radius {
            Slot::Const(e) => e.to_f64() < 0.0,
            Slot::Param(n) => params
                .iter()
                .any(|p| &p.name == n && p.nominal.to_f64() < 0.0),
        };
        if negative {
            ck.at_value(
                &format!("{base}.radius"),
                "the radius is negative: a radius is a distance, >= 0".into(),
            );
        }
    }
    match c {
        Constraint::Plane { b } => empty::check_b_not_zero(ck, &format!("{base}.b"), b, params),
        Constraint::Line2 { b } => empty::check_b_not_zero(ck, &format!("{base}.b"), b, params),
        Constraint::Line3 { planes } => empty::check_line_planes(ck, &base, planes, params),
        Constraint::Quadric { a, b } => empty::check_quadric_has_points(ck, &base, a, b, params),
        Constraint::PlaneNormal { normal, .. } => {
            if let Some(m) = super::plane_normal::zero_normal(normal, params) {
                ck.at_value(&format!("{base}.normal"), m.into());
            }
        }
        _ => {}
    }
    match c {
        Constraint::Point { p } => check_vector_len(ck, &base, p, "p", len_dim),
        Constraint::Line2 { b } => check_vector_len(ck, &base, b, "b", len_dim),
        Constraint::Plane { b } => check_vector_len(ck, &base, b, "b", len_dim),
        Constraint::Circle { center, .. } => {
            check_vector_len(ck, &base, center, "center", len_dim);
        }
        Constraint::Sphere { center, .. } => {
            check_vector_len(ck, &base, center, "center", len_dim);
        }
        Constraint::Quadric { a, b } => {
            check_quadric(ck, &base, a, len_dim);
            check_vector_len(ck, &base, b, "b", len_dim);
        }
        Constraint::Line3 { .. }
        | Constraint::PlaneNormal { .. }
        | Constraint::Measured
        | Constraint::MeasuredPose { .. } => {}
    }
}

/// The vector `name` of the constraint at `base` has `dim` entries (when `dim` is known and
/// the kind fits it).
fn check_vector_len(
    ck: &mut Checker<'_>,
    base: &str,
    v: &[Slot],
    name: &str,
    len_dim: Option<usize>,
) {
    if let Some(d) = len_dim {
        if v.len() != d {
            ck.at_value(
                &format!("{base}.{name}"),
                format!(
                    "`{name}` must have {d} entries (dim {d}), found {}",
                    v.len()
                ),
            );
        }
    }
}

/// Every name used in a slot, with the role of the slot and its field path, in spec order
/// (joints, tool, base, constraints): the input of [`check_params`].
fn slot_uses(spec: &Spec, constraint_paths: &[String]) -> Vec<Use> {
    let mut uses: Vec<Use> = Vec::new();
    let mut slot = |s: &Slot, role: ParamRole, field: String| {
        if let Slot::Param(name) = s {
            uses.push(Use {
                name: name.clone(),
                role,
                field,
            });
        }
    };
    for (i, j) in spec.joints.iter().enumerate() {
        let f = |s: &str| format!("joints[{i}].{s}");
        slot(&j.a, ParamRole::Length, f("a"));
        slot(&j.alpha, ParamRole::Angle, f("alpha"));
        slot(&j.beta, ParamRole::Angle, f("beta"));
        slot(&j.d, ParamRole::Length, f("d"));
        slot(&j.home, ParamRole::Angle, f("home"));
        slot(&j.theta, ParamRole::Angle, f("theta"));
        slot(&j.offset, ParamRole::Length, f("offset"));
        for (name, s, role) in base_entries(&j.origin) {
            slot(s, role, f(name));
        }
    }
    for (s, role, field) in super::tool_frame::tool_slots(spec) {
        slot(s, role, field);
    }
    if let Some(b) = &spec.base {
        for (name, s, role) in base_entries(b) {
            slot(s, role, format!("base.{name}"));
        }
    }
    for (c, prefix) in spec.constraints.iter().zip(constraint_paths) {
        let base = format!("{prefix}.{}", c.kind_name());
        let mut vector = |v: &[Slot], name: &str| {
            for (i, s) in v.iter().enumerate() {
                slot(s, ParamRole::Length, format!("{base}.{name}[{i}]"));
            }
        };
        match c {
            Constraint::Point { p } => vector(p, "p"),
            Constraint::Line2 { b } => vector(b, "b"),
            Constraint::Plane { b } => vector(b, "b"),
            Constraint::PlaneNormal { normal, offset } => {
                vector(normal, "normal");
                slot(offset, ParamRole::Length, format!("{base}.offset"));
            }
            Constraint::Line3 { planes } => {
                for (r, plane) in planes.iter().enumerate() {
                    vector(plane, &format!("planes[{r}]"));
                }
            }
            Constraint::Circle { center, radius } => {
                vector(center, "center");
                slot(radius, ParamRole::Length, format!("{base}.radius"));
            }
            Constraint::Sphere { center, radius } => {
                vector(center, "center");
                slot(radius, ParamRole::Length, format!("{base}.radius"));
            }
            Constraint::Quadric { a, b } => {
                for (r, row) in a.iter().enumerate() {
                    vector(row, &format!("A[{r}]"));
                }
                vector(b, "b");
            }
            Constraint::Measured | Constraint::MeasuredPose { .. } => {}
        }
    }
    uses
}

/// `name` is an identifier that may also contain `-`.
fn is_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn check_quadric(ck: &mut Checker<'_>, base: &str, a: &[Vec<Slot>], dim: Option<usize>) {
    let field = format!("{base}.A");
    let n = a.len();
    if let Some(d) = dim {
        if n != d {
            ck.at_value(
                &field,
                format!("`A` must be {d}×{d} (dim {d}), found {n} rows"),
            );
            return;
        }
    }
    for (r, row) in a.iter().enumerate() {
        if row.len() != n {
            ck.at_value(
                &format!("{field}[{r}]"),
                format!(
                    "`A` must be square: row {r} has {} entries, expected {n}",
                    row.len()
                ),
            );
            return;
        }
    }
    for (r, row) in a.iter().enumerate() {
        for (c, upper) in row.iter().enumerate().skip(r + 1) {
            let lower = &a[c][r];
            if upper != lower {
                ck.at_value(
                    &format!("{field}[{r}][{c}]"),
                    format!(
                        "`A` must be symmetric: A[{r}][{c}] is `{}` but A[{c}][{r}] is `{}`",
                        show_slot(upper),
                        show_slot(lower)
                    ),
                );
            }
        }
    }
}

/// The parameter rules over the names the slots use: every name used is declared, every
/// declared name is valid and used, as an angle or as a length (which sets its role), and
/// declared once.
fn check_params(ck: &mut Checker<'_>, params: &mut [Param], uses: &[Use]) {
    check_declared(ck, params, uses);
    for p in params.iter_mut() {
        check_param_name(ck, p);
        check_param_uses(ck, p, uses);
    }
    check_declared_once(ck, params);
}

/// Names used but not declared: one error per name, at its first use, listing the others.
fn check_declared(ck: &mut Checker<'_>, params: &[Param], uses: &[Use]) {
    let mut seen: Vec<&str> = Vec::new();
    for u in uses {
        if seen.contains(&u.name.as_str()) {
            continue;
        }
        seen.push(&u.name);
        if !params.iter().any(|p| p.name == u.name) {
            let others: Vec<&str> = uses
                .iter()
                .filter(|v| v.name == u.name && v.field != u.field)
                .map(|v| v.field.as_str())
                .collect();
            let also = if others.is_empty() {
                String::new()
            } else {
                format!(" (also used in {})", others.join(", "))
            };
            ck.at_value(
                &u.field,
                format!(
                    "`{}` is not a parameter: every name used in a slot must be declared under \
                     `params:` (e.g. `{}: {{nominal: 0.0}}`){also}",
                    u.name, u.name
                ),
            );
        }
    }
}

/// A declared name is an identifier other than `pi`.
fn check_param_name(ck: &mut Checker<'_>, p: &Param) {
    if !is_param_name(&p.name) {
        let why = if is_identifier(&p.name) {
            "`pi` is the constant π".to_string()
        } else {
            "expected an identifier `[A-Za-z_][A-Za-z0-9_]*`".to_string()
        };
        ck.at_key(
            &format!("params.{}", p.name),
            format!("`{}` is not a valid parameter name: {why}", p.name),
        );
    }
}

/// `p`'s role from its uses: the role of its first use, when every use agrees (else an
/// error at the first that differs, and a length); a parameter never used is reported
/// (unless its uses may be missing or it was used in a rejected value) and a length.
fn check_param_uses(ck: &mut Checker<'_>, p: &mut Param, uses: &[Use]) {
    let field = format!("params.{}", p.name);
    let mine: Vec<&Use> = uses.iter().filter(|u| u.name == p.name).collect();
    let Some(first) = mine.first() else {
        if !ck.ctx.uses_incomplete && !ck.ctx.used_elsewhere.contains(&p.name) {
            ck.at_key(
                &field,
                format!(
                    "parameter `{}` is never used in a slot: remove it or use it",
                    p.name
                ),
            );
        }
        p.role = ParamRole::Length;
        return;
    };
    match mine.iter().find(|u| u.role != first.role) {
        None => p.role = first.role,
        Some(other) => {
            let word = |r: ParamRole| match r {
                ParamRole::Angle => "an angle",
                ParamRole::Length => "a length",
            };
            ck.at_value(
                &other.field,
                format!(
                    "parameter `{}` is used as {} here but as {} in `{}`: a parameter is \
                     either an angle (home, alpha, theta, base roll/pitch/yaw) or a length, \
                     not both",
                    p.name,
                    word(other.role),
                    word(first.role),
                    first.field
                ),
            );
            p.role = ParamRole::Length;
        }
    }
}

/// The same name declared twice (only possible for specs not read from YAML).
fn check_declared_once(ck: &mut Checker<'_>, params: &[Param]) {
    for (i, p) in params.iter().enumerate() {
        if params[..i].iter().any(|q| q.name == p.name) {
            ck.at_key(
                &format!("params.{}", p.name),
                format!("parameter `{}` is declared more than once", p.name),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{Convention, Exact, Joint, JointKind};

    fn name(s: &str) -> Slot {
        Slot::Param(s.into())
    }

    fn num(s: &str) -> Slot {
        Slot::Const(Exact::parse(s).unwrap())
    }

    fn param(n: &str) -> Param {
        Param {
            name: n.into(),
            nominal: Exact::zero(),
            known: false,
            role: ParamRole::Length,
        }
    }

    fn revolute(a: Slot, alpha: Slot, home: Slot) -> Joint {
        Joint {
            kind: JointKind::Revolute,
            a,
            alpha,
            beta: Slot::zero(),
            d: Slot::zero(),
            home,
            theta: Slot::zero(),
            offset: Slot::zero(),
            limits: None,
            origin: Base::zero(),
        }
    }

    /// A valid planar two-link arm on a line.
    fn planar() -> Spec {
        Spec {
            name: "two_link".into(),
            description: None,
            dim: 2,
            convention: Convention::Dh,
            joints: vec![
                revolute(name("a1"), Slot::zero(), name("th1")),
                revolute(name("a2"), num("pi"), name("th2")),
            ],
            tool: vec![Slot::zero(), Slot::zero()],
            tool_rotation: None,
            base: None,
            params: ["a1", "a2", "th1", "th2", "b1", "b2"].map(param).to_vec(),
            constraints: vec![Constraint::Line2 {
                b: [name("b1"), name("b2")],
            }],
            constraint_list: false,
            relations: Vec::new(),
        }
    }

    /// The field paths of the problems of `spec`, sorted.
    fn fields(mut spec: Spec) -> Vec<String> {
        let mut f: Vec<String> = check(&mut spec, &FieldsOnly)
            .into_iter()
            .map(|d| d.location.field.unwrap_or_default())
            .collect();
        f.sort();
        f
    }

    #[test]
    fn accepts_a_valid_spec_and_sets_roles() {
        let mut spec = planar();
        validate(&mut spec).unwrap();
        assert_eq!(spec.param("a1").unwrap().role, ParamRole::Length);
        assert_eq!(spec.param("th2").unwrap().role, ParamRole::Angle);
        assert_eq!(spec.param("b2").unwrap().role, ParamRole::Length);
    }

    #[test]
    fn base_angles_are_angles() {
        let mut spec = planar();
        spec.base = Some(Base {
            x: name("bx"),
            y: Slot::zero(),
            z: Slot::zero(),
            roll: Slot::zero(),
            pitch: Slot::zero(),
            yaw: name("yaw"),
        });
        spec.params.push(param("bx"));
        spec.params.push(param("yaw"));
        validate(&mut spec).unwrap();
        assert_eq!(spec.param("yaw").unwrap().role, ParamRole::Angle);
        assert_eq!(spec.param("bx").unwrap().role, ParamRole::Length);
    }

    #[test]
    fn reports_undeclared_unused_and_mixed_parameters() {
        let mut spec = planar();
        spec.joints[1].a = name("a9");
        spec.joints[1].d = name("th1");
        assert_eq!(fields(spec), ["joints[1].a", "joints[1].d", "params.a2"]);
        let mut spec = planar();
        spec.joints[0].home = name("b1");
        assert_eq!(fields(spec), ["constraint.line.b[0]", "params.th1"]);
    }

    #[test]
    fn reports_planar_rules() {
        let mut spec = planar();
        spec.joints[0].alpha = num("pi/2");
        spec.joints[1].alpha = name("th2");
        spec.tool.push(Slot::zero());
        spec.base = Some(Base {
            x: Slot::zero(),
            y: Slot::zero(),
            z: num("0.1"),
            roll: Slot::zero(),
            pitch: Slot::zero(),
            yaw: Slot::zero(),
        });
        assert_eq!(
            fields(spec),
            ["base.z", "joints[0].alpha", "joints[1].alpha", "tool"]
        );
    }

    #[test]
    fn reports_a_known_zero_b() {
        let mut spec = planar();
        spec.constraints = vec![Constraint::Line2 {
            b: [num("0"), name("b1")],
        }];
        spec.params.truncate(5);
        spec.params[4].known = true;
        assert_eq!(fields(spec), ["constraint.line.b"]);
        // An unknown entry whose nominal is 0 is no error: the fit moves it.
        let mut spec = planar();
        spec.constraints = vec![Constraint::Line2 {
            b: [num("0"), name("b1")],
        }];
        spec.params.truncate(5);
        assert!(fields(spec).is_empty());
    }

    #[test]
    fn reports_a_zero_normal() {
        let spatial = |normal: [Slot; 3], known: bool| {
            let mut spec = planar();
            spec.dim = 3;
            spec.tool.push(Slot::zero());
            spec.constraints = vec![Constraint::PlaneNormal {
                normal,
                offset: num("0"),
            }];
            spec.params.truncate(5);
            spec.params[4].known = known;
            spec
        };
        let zero = || [num("0"), name("b1"), Slot::zero()];
        assert_eq!(fields(spatial(zero(), true)), ["constraint.plane.normal"]);
        let mut unknown = spatial(zero(), false);
        unknown.params[4].nominal = Exact::from_int(0);
        assert_eq!(fields(unknown), ["constraint.plane.normal"]);
        // Any nonzero normal, unit or not, through the origin or not.
        let ok = spatial([num("0"), name("b1"), num("2")], true);
        assert!(fields(ok).is_empty());
    }

    #[test]
    fn reports_kinds_that_do_not_fit_dim_and_lengths() {
        let mut spec = planar();
        spec.constraints = vec![
            Constraint::Plane {
                b: [name("b1"), name("b2"), Slot::zero()],
            },
            Constraint::Point {
                p: vec![Slot::zero(); 3],
            },
        ];
        spec.constraint_list = true;
        assert_eq!(
            fields(spec),
            ["constraints[0].plane", "constraints[1].point.p"]
        );
        let mut spec = planar();
        spec.dim = 3;
        spec.tool.push(Slot::zero());
        assert_eq!(fields(spec), ["constraint.line"]);
    }

    #[test]
    fn reports_non_symmetric_and_non_square_quadrics() {
        let mut spec = planar();
        spec.constraints = vec![Constraint::Quadric {
            a: vec![vec![name("b1"), num("1")], vec![num("1"), name("b2")]],
            b: vec![Slot::zero(), Slot::zero()],
        }];
        assert!(fields(spec.clone()).is_empty());
        if let Constraint::Quadric { a, .. } = &mut spec.constraints[0] {
            a[1][0] = name("b1");
        }
        assert_eq!(fields(spec.clone()), ["constraint.quadric.A[0][1]"]);
        if let Constraint::Quadric { a, .. } = &mut spec.constraints[0] {
            a[1].pop();
        }
        assert_eq!(fields(spec), ["constraint.quadric.A[1]", "params.b2"]);
    }

    /// A known quadric with no real point is refused (`‖x‖² + 1 = 0`, `1 = 0`); an ellipse,
    /// a hyperbola, a parabola and a quadric with an unknown entry are not.
    #[test]
    fn reports_a_known_quadric_with_no_real_point() {
        let quadric = |a: [[&str; 2]; 2], b: [&str; 2]| {
            let mut spec = planar();
            spec.constraints = vec![Constraint::Quadric {
                a: a.iter()
                    .map(|r| r.iter().map(|&x| num(x)).collect())
                    .collect(),
                b: b.iter().map(|&x| num(x)).collect(),
            }];
            spec.params.truncate(4);
            fields(spec)
        };
        let refused = ["constraint.quadric"];
        assert_eq!(quadric([["1", "0"], ["0", "1"]], ["0", "0"]), refused);
        assert_eq!(quadric([["0", "0"], ["0", "0"]], ["0", "0"]), refused);
        // (x − 1)² + y² = 2 written out: x² + y² − 2x − 1 … scaled to + 1: a real circle.
        assert!(quadric([["-1", "0"], ["0", "-1"]], ["2", "0"]).is_empty());
        // x² + y² + 4x + 1 = 0: (x + 2)² + y² = 3, a circle; x² + 2x + 1 + y² = 0, one point.
        assert!(quadric([["1", "0"], ["0", "1"]], ["4", "0"]).is_empty());
        assert!(quadric([["1", "0"], ["0", "1"]], ["2", "0"]).is_empty());
        // x² − y² + 1 = 0 (a hyperbola), x² + y + 1 = 0 (a parabola), y + 1 = 0 (a line).
        assert!(quadric([["1", "0"], ["0", "-1"]], ["0", "0"]).is_empty());
        assert!(quadric([["1", "0"], ["0", "0"]], ["0", "1"]).is_empty());
        assert!(quadric([["0", "0"], ["0", "0"]], ["0", "1"]).is_empty());
        // x² + 1 = 0 along a null direction with no linear term: no point.
        assert_eq!(quadric([["1", "0"], ["0", "0"]], ["0", "0"]), refused);
        // An unknown entry: the fit moves it.
        let mut spec = planar();
        spec.constraints = vec![Constraint::Quadric {
            a: vec![vec![num("1"), num("0")], vec![num("0"), name("b1")]],
            b: vec![Slot::zero(), Slot::zero()],
        }];
        spec.params.truncate(5);
        assert!(fields(spec).is_empty());
    }

    /// A 3-D line's two known planes must not be parallel, nor either `b` zero.
    #[test]
    fn reports_a_line_of_parallel_planes() {
        let line = |p: [[&str; 3]; 2]| {
            let mut spec = planar();
            spec.dim = 3;
            spec.joints[1].alpha = Slot::zero();
            spec.tool = vec![Slot::zero(); 3];
            spec.constraints = vec![Constraint::Line3 {
                planes: p.map(|b| b.map(num)),
            }];
            spec.params.truncate(4);
            fields(spec)
        };
        assert!(line([["2", "0", "0"], ["0", "3", "0"]]).is_empty());
        assert_eq!(
            line([["2", "0", "0"], ["2", "0", "0"]]),
            ["constraint.line.planes"]
        );
        assert_eq!(
            line([["2", "0", "0"], ["-4", "0", "0"]]),
            ["constraint.line.planes"]
        );
        assert_eq!(
            line([["2", "0", "0"], ["0", "0", "0"]]),
            ["constraint.line.planes[1]"]
        );
    }

    #[test]
    fn reports_joint_slots_of_the_other_type_and_limits() {
        let mut spec = planar();
        spec.joints[0].theta = num("1");
        spec.joints[1].kind = JointKind::Prismatic;
        spec.joints[1].limits = Some([1.0, 1.0]);
        spec.joints[0].limits = Some([f64::NEG_INFINITY, 1.0]);
        assert_eq!(
            fields(spec),
            [
                "joints[0].limits",
                "joints[0].theta",
                "joints[1].home",
                "joints[1].limits",
                "joints[1].type"
            ]
        );
    }

    #[test]
    fn reports_constraint_counts_and_mixing() {
        let mut spec = planar();
        spec.constraints.clear();
        assert_eq!(
            fields(spec.clone()),
            ["constraint", "params.b1", "params.b2"]
        );
        spec.constraint_list = true;
        let f = fields(spec.clone());
        assert_eq!(f, ["constraints", "params.b1", "params.b2"]);
        spec.constraints = vec![
            Constraint::Measured,
            Constraint::Line2 {
                b: [name("b1"), name("b2")],
            },
        ];
        assert_eq!(fields(spec), ["constraints"]);
    }

    #[test]
    fn reports_bad_names_and_dim() {
        let mut spec = planar();
        spec.name = "two links".into();
        spec.params.push(param("pi"));
        spec.params.push(param("a1"));
        spec.dim = 4;
        let f = fields(spec);
        assert_eq!(f, ["dim", "name", "params.a1", "params.pi", "params.pi"]);
    }

    #[test]
    fn validate_gives_an_input_error_with_field_paths() {
        let mut spec = planar();
        spec.joints.clear();
        let e = validate(&mut spec).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Input);
        assert!(
            e.to_string()
                .starts_with("field `joints`: the joint list is empty"),
            "{e}"
        );
    }

    #[test]
    fn kind_fits_dim_table() {
        assert!(kind_fits_dim("line", false, 2).is_ok());
        assert!(kind_fits_dim("line", true, 3).is_ok());
        assert!(kind_fits_dim("line", true, 2).is_err());
        assert!(kind_fits_dim("line", false, 3).is_err());
        assert!(kind_fits_dim("quadric", false, 2).is_ok());
        assert!(kind_fits_dim("point", false, 3).is_ok());
        assert!(kind_fits_dim("plane", false, 2).is_err());
        assert!(is_param_name("_x1") && !is_param_name("Pi") && !is_param_name("1x"));
    }
}
