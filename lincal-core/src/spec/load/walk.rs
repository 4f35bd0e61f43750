//! The one spec walker: [`from_tree`] takes a document tree and a [`Locate`] and gives a
//! validated [`Spec`] or every problem; the top-level mapping is read field by field, in the
//! order later fields depend on (`dim` first).

use super::loader::{case_hint, describe, idx, Fields, Loader};
use crate::error::{Error, ErrorClass, Result};
use crate::spec::node::Value;
use crate::spec::validate::{self, Context, Locate};
use crate::spec::{Convention, Slot, Spec};

/// The one spec walker: a document tree (from any adapter) to a validated [`Spec`].
///
/// `locate` turns a field path (`joints[1].home`, `params.a1.nominal`) into a place in the
/// source the tree came from: the YAML adapter gives file, line and column; the derive's
/// attribute adapter gives the field only and maps it to a token span itself. Every front
/// therefore accepts and rejects exactly the same specs, with the same messages.
///
/// # Errors
/// An [`ErrorClass::Input`] error with every problem found, each located by `locate`, sorted
/// by line and column where the locations have them (in walk order otherwise).
pub fn from_tree(root: &Value, locate: &dyn Locate) -> Result<Spec> {
    let mut loader = Loader {
        locate,
        diags: Vec::new(),
        ctx: Context::default(),
        dim: None,
        convention: Convention::Dh,
    };
    let mut spec = loader.spec(root);
    let Loader { mut diags, ctx, .. } = loader;
    diags.extend(validate::check_with(&mut spec, locate, &ctx));
    if diags.is_empty() {
        Ok(spec)
    } else {
        diags.sort_by_key(|d| {
            (
                d.location.line.unwrap_or(usize::MAX),
                d.location.column.unwrap_or(usize::MAX),
            )
        });
        Err(Error::from_diagnostics(ErrorClass::Input, diags))
    }
}

/// The keys of the top-level mapping.
const TOP: &[&str] = &[
    "name",
    "description",
    "dim",
    "convention",
    "joints",
    "tool",
    "base",
    "params",
    "constraint",
    "constraints",
    "relations",
    "urdf",
];

impl Loader<'_> {
    /// The whole spec: the top-level mapping, then its fields in the order later ones
    /// depend on (`dim` first), each problem reported and a placeholder kept in its place.
    fn spec(&mut self, root: &Value) -> Spec {
        let mut spec = blank_spec();
        let Some(top) = self.top(root) else {
            return spec;
        };
        // dim first: other fields depend on it.
        self.dim_field(&top, &mut spec);
        self.name_fields(&top, &mut spec);
        self.convention_field(&top, &mut spec);
        self.joints_field(&top, &mut spec);
        self.tool_field(&top, &mut spec);
        if let Some(v) = top.get("base") {
            spec.base = self.base(v);
        }
        if let Some(v) = top.get("params") {
            spec.params = self.params(v);
        }
        self.urdf_field(&top);
        self.constraint_fields(&top, &mut spec);
        if let Some(v) = top.get("relations") {
            spec.relations = self.relations(v, &spec);
        }
        spec
    }

    /// The top-level mapping's entries (unknown keys reported); `None`, reported, for an
    /// empty document or one that is not a mapping.
    fn top<'v>(&mut self, root: &'v Value) -> Option<Fields<'v>> {
        if matches!(root, Value::Null) {
            self.error(
                "",
                "the spec is empty: expected a mapping with `name`, `dim`, `joints`, `params` \
                 and `constraint`"
                    .into(),
            );
            return None;
        }
        self.mapping(
            root,
            "",
            Some(TOP),
            "a mapping with `name`, `dim`, `joints`, `params` and `constraint`",
        )
    }

    /// `dim:` (2 or 3), into the spec and the loader (the later fields read it).
    fn dim_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        match top.get("dim") {
            None => self.missing("", "dim", "2 (planar) or 3 (spatial)"),
            Some(v) => match v.as_u64() {
                Some(d @ (2 | 3)) => {
                    spec.dim = d as usize;
                    self.dim = Some(d as usize);
                }
                _ => self.error(
                    "dim",
                    format!("expected 2 (planar) or 3 (spatial), found {}", describe(v)),
                ),
            },
        }
    }

    /// `name:` (required) and `description:` (optional), both strings.
    fn name_fields(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        match top.get("name") {
            None => self.missing("", "name", "an identifier naming the robot"),
            Some(Value::String(s)) => spec.name = s.clone(),
            Some(v) => self.error(
                "name",
                format!("expected an identifier (a string), found {}", describe(v)),
            ),
        }
        match top.get("description") {
            None | Some(Value::Null) => {}
            Some(Value::String(s)) => spec.description = Some(s.clone()),
            Some(v) => self.error(
                "description",
                format!("expected a string, found {}", describe(v)),
            ),
        }
    }

    /// `convention:` (optional): `dh`, `mdh` or `urdf`.
    fn convention_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        let Some(v) = top.get("convention") else {
            return;
        };
        match v.as_str() {
            Some("dh") => spec.convention = Convention::Dh,
            Some("mdh") => spec.convention = Convention::Mdh,
            Some("urdf") => spec.convention = Convention::Urdf,
            _ => self.error(
                "convention",
                format!(
                    "expected `dh` (standard Denavit-Hartenberg), `mdh` (modified, \
                     Craig) or `urdf` (each joint's origin xyz/rpy), found {}{}",
                    describe(v),
                    case_hint(v, &["dh", "mdh", "urdf"])
                ),
            ),
        }
        self.convention = spec.convention;
    }

    /// `joints:`, a list read joint by joint; when it is not a list, the parameter uses are
    /// marked incomplete (no "never used" for the names it would have used).
    fn joints_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        match top.get("joints") {
            None => self.missing("", "joints", "a list of joints, base to tip"),
            Some(Value::Sequence(items)) => {
                for (i, item) in items.iter().enumerate() {
                    let j = self.joint(item, &idx("joints", i));
                    spec.joints.push(j);
                }
            }
            Some(v) => {
                self.error(
                    "joints",
                    format!("expected a list of joints, found {}", describe(v)),
                );
                self.orphan(v);
                self.ctx.uses_incomplete = true;
            }
        }
    }

    /// `tool:`, the tip in the last frame (zeros when absent), or a tool frame
    /// `{x, y, z, roll, pitch, yaw}` (read as `base`); its length is checked by validation.
    fn tool_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        match top.get("tool") {
            None => spec.tool = vec![Slot::zero(); self.dim.unwrap_or(0)],
            Some(v @ Value::Mapping(_)) => match self.frame(v, "tool") {
                Some(f) => {
                    spec.tool = vec![f.x, f.y, f.z];
                    spec.tool_rotation = Some([f.roll, f.pitch, f.yaw]);
                }
                None => self.ctx.reported.push("tool".into()),
            },
            Some(v) => {
                let what = match self.dim {
                    Some(d) => format!("a list of {d} entries (the tip in the last frame)"),
                    None => "a list (the tip in the last frame)".to_string(),
                };
                if let Some(t) = self.slots(v, "tool", &what) {
                    spec.tool = t;
                } else {
                    self.ctx.reported.push("tool".into());
                }
            }
        }
    }

    /// `urdf:`, where an imported spec came from (`lincal import`; read by `--write-urdf`):
    /// only checked here.
    fn urdf_field(&mut self, top: &Fields<'_>) {
        if let Some(v) = top.get("urdf") {
            for (field, message) in crate::spec::urdf_record::problems(v) {
                self.error(&field, message);
            }
        }
    }

    /// `constraint:` (one) or `constraints:` (a list), exactly one of them; a constraint that
    /// cannot be read marks the constraints incomplete (so relations and uses are not
    /// judged against a partial list).
    fn constraint_fields(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        match (top.get("constraint"), top.get("constraints")) {
            (None, None) => {
                self.missing(
                    "",
                    "constraint",
                    "`constraint:` (one constraint) or `constraints:` (a list)",
                );
                self.ctx.constraints_incomplete = true;
            }
            (Some(one), other) => {
                if let Some(lst) = other {
                    self.key_error(
                        "constraints",
                        "give either `constraint:` (one) or `constraints:` (a list), not both"
                            .into(),
                    );
                    self.orphan(lst);
                }
                match self.constraint(one, "constraint") {
                    Some(c) => spec.constraints.push(c),
                    None => self.ctx.constraints_incomplete = true,
                }
            }
            (None, Some(lst)) => {
                spec.constraint_list = true;
                self.constraint_list(lst, spec);
            }
        }
    }

    /// The entries of `constraints:`, with the field path of each one read (for
    /// validation).
    fn constraint_list(&mut self, lst: &Value, spec: &mut Spec) {
        let Value::Sequence(items) = lst else {
            self.error(
                "constraints",
                format!(
                    "expected a list of constraints (e.g. `- line: {{b: [b1, b2]}}`), \
                     found {}",
                    describe(lst)
                ),
            );
            self.orphan(lst);
            self.ctx.constraints_incomplete = true;
            return;
        };
        let mut paths = Vec::new();
        for (k, item) in items.iter().enumerate() {
            let path = idx("constraints", k);
            match self.constraint(item, &path) {
                Some(c) => {
                    spec.constraints.push(c);
                    paths.push(path);
                }
                None => self.ctx.constraints_incomplete = true,
            }
        }
        self.ctx.constraint_paths = Some(paths);
    }
}

/// The spec the loader fills in: nothing read yet (dim 0, standard DH, no joints).
fn blank_spec() -> Spec {
    Spec {
        name: String::new(),
        description: None,
        dim: 0,
        convention: Convention::Dh,
        joints: Vec::new(),
        tool: Vec::new(),
        tool_rotation: None,
        base: None,
        params: Vec::new(),
        constraints: Vec::new(),
        constraint_list: false,
        relations: Vec::new(),
    }
}
