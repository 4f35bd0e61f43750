//! YAML → [`Spec`], with every problem located (file, line, column, field path).
//!
//! Three steps:
//! 1. `serde_yaml` 0.9 parses the text into a [`serde_yaml::Value`]. It decides the YAML
//!    syntax, the type of each scalar, and rejects repeated keys; its own errors carry a line
//!    and column, which are kept.
//! 2. The loader walks that tree by hand (not with `#[derive(Deserialize)]`, which stops at
//!    the first problem) and builds a [`Spec`], reporting every unknown key, wrong type, wrong
//!    length and misplaced slot it meets, and going on with a placeholder so that one mistake
//!    shows once.
//! 3. [`super::validate`] checks the meaning (parameters declared and used, angle or length,
//!    dim-specific rules, symmetric quadric, ...) and sets parameter roles.
//!
//! `serde_yaml` 0.9 does not expose the positions of values, so the places of the loader's and
//! the validator's problems come from a second, event-level read of the same text with
//! `yaml-rust2` (module `locate`): an index from each field path (`joints[1].home`,
//! `params.a1.nominal`, `constraint.line.b[0]`) to the line and column of its value and key.
//! A path the index lacks (a missing field) falls back to its nearest ancestor, e.g. the
//! mapping the field is missing from.
//!
//! All problems come back together in one [`ErrorClass::Input`] error, sorted by line.
//!
//! # Slots
//! Every slot is a YAML number (made exact with [`Exact::from_f64`], so `0.375` is 3/8), an
//! expression string parsed by [`Exact::parse`] (`pi/2`, `-pi/2`, `2*pi/3`, `"0.5"`), or a
//! parameter name `[A-Za-z_][A-Za-z0-9_]*` other than `pi`.
//!
//! # Example
//! ```
//! use lincal_core::spec::{from_yaml_str, Constraint, Slot};
//! let spec = from_yaml_str(
//!     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
//!      - {type: revolute, a: 0.425}\nparams:\n  a1: {nominal: 0.375}\n  th1: {nominal: 0}\n\
//!      constraint:\n  line: {b: [-2, -0.5]}\n",
//!     None,
//! )
//! .unwrap();
//! assert_eq!(spec.joints[0].a, Slot::Param("a1".into()));
//! assert!(matches!(spec.constraints[0], Constraint::Line2 { .. }));
//!
//! let err = from_yaml_str("name: x\ndim: 4\n", Some("bad.yaml")).unwrap_err();
//! assert!(err.to_string().contains("bad.yaml:2:6: field `dim`"));
//! ```

use std::path::Path;

use num_bigint::BigInt;
use num_rational::BigRational;
use serde_yaml::Value;

use super::locate::{join_key, SourceIndex};
use super::validate::{self, is_param_name, kind_fits_dim, Context, Locate};
use super::{Base, Constraint, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot, Spec};
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};

/// Reads and validates a spec file.
///
/// # Errors
/// An [`ErrorClass::Input`] error: the file cannot be read, or every problem of the spec,
/// each naming the file, line, column and field.
pub fn from_yaml_file(path: &Path) -> Result<Spec> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| {
        Error::input(
            Location {
                file: Some(name.clone()),
                ..Location::default()
            },
            format!("cannot read the spec file: {e}"),
        )
    })?;
    from_yaml_str(&text, Some(&name))
}

/// Parses and validates spec text; `file` names it in errors.
///
/// # Errors
/// An [`ErrorClass::Input`] error with every problem found, each located by file (when
/// given), line, column and field path.
pub fn from_yaml_str(text: &str, file: Option<&str>) -> Result<Spec> {
    let index = SourceIndex::build(text);
    let value: Value = match serde_yaml::from_str(text) {
        Ok(v) => v,
        Err(e) => return Err(syntax_error(&e, &index, file)),
    };
    let mut loader = Loader {
        file,
        index: &index,
        diags: Vec::new(),
        ctx: Context::default(),
        dim: None,
    };
    let mut spec = loader.spec(&value);
    let Loader { mut diags, ctx, .. } = loader;
    let locator = Located {
        file,
        index: &index,
    };
    diags.extend(validate::check_with(&mut spec, &locator, &ctx));
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

/// A `serde_yaml` error, located; repeated keys are placed at each repeat via the index.
fn syntax_error(e: &serde_yaml::Error, index: &SourceIndex, file: Option<&str>) -> Error {
    let mut message = e.to_string();
    if message.starts_with("duplicate entry") && !index.duplicates().is_empty() {
        let diags = index
            .duplicates()
            .iter()
            .map(|(path, (line, column))| Diagnostic {
                location: Location {
                    file: file.map(str::to_string),
                    line: Some(*line),
                    column: Some(*column),
                    field: Some(path.clone()),
                    pose: None,
                },
                message: "this key appears twice in its mapping: each key may be given once".into(),
            })
            .collect();
        return Error::from_diagnostics(ErrorClass::Input, diags);
    }
    let (line, column) = match e.location() {
        Some(l) => {
            // serde_yaml repeats the place in the message: keep it once, in the location.
            let here = format!(" at line {} column {}", l.line(), l.column());
            if let Some(i) = message.find(&here) {
                message.replace_range(i..i + here.len(), "");
            }
            (Some(l.line()), Some(l.column()))
        }
        None => (None, None),
    };
    Error::input(
        Location {
            file: file.map(str::to_string),
            line,
            column,
            ..Location::default()
        },
        format!("invalid YAML: {message}"),
    )
}

/// The [`Locate`] of a YAML text: file plus the index's line and column.
struct Located<'a> {
    file: Option<&'a str>,
    index: &'a SourceIndex,
}

impl Located<'_> {
    fn at(&self, field: &str, pos: Option<(usize, usize)>) -> Location {
        Location {
            file: self.file.map(str::to_string),
            line: pos.map(|p| p.0),
            column: pos.map(|p| p.1),
            field: Some(field.to_string()),
            pose: None,
        }
    }
}

impl Locate for Located<'_> {
    fn value(&self, field: &str) -> Location {
        self.at(field, self.index.value(field))
    }

    fn key(&self, field: &str) -> Location {
        self.at(field, self.index.key(field))
    }
}

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
];
const REVOLUTE: &[&str] = &["type", "a", "alpha", "d", "home", "limits"];
const PRISMATIC: &[&str] = &["type", "a", "alpha", "theta", "offset", "limits"];
const JOINT_ANY: &[&str] = &[
    "type", "a", "alpha", "d", "home", "theta", "offset", "limits",
];
const BASE: &[&str] = &["x", "y", "z", "roll", "pitch", "yaw"];
const PARAM: &[&str] = &["nominal", "known"];
const KINDS: &[&str] = &[
    "point", "line", "plane", "circle", "sphere", "quadric", "measured",
];
const SLOT_HELP: &str = "a number, an expression like `pi/2`, or a parameter name";

struct Loader<'a> {
    file: Option<&'a str>,
    index: &'a SourceIndex,
    diags: Vec<Diagnostic>,
    ctx: Context,
    dim: Option<usize>,
}

/// The string-keyed entries of a mapping, in order.
struct Fields<'v> {
    entries: Vec<(&'v str, &'v Value)>,
}

impl<'v> Fields<'v> {
    fn get(&self, key: &str) -> Option<&'v Value> {
        self.entries
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v)
    }
}

/// Short description of a YAML value for "found ..." messages.
fn describe(v: &Value) -> String {
    match v {
        Value::Null => "nothing (null)".into(),
        Value::Bool(b) => format!("the boolean `{b}`"),
        Value::Number(n) => format!("the number `{n}`"),
        Value::String(s) => format!("the string `{s:?}`"),
        Value::Sequence(_) => "a list".into(),
        Value::Mapping(_) => "a mapping".into(),
        Value::Tagged(t) => format!("a tagged value `{}` (YAML tags are not supported)", t.tag),
    }
}

/// The closest of `allowed` to `key`, if it is a likely typo.
fn suggest<'a>(key: &str, allowed: &[&'a str]) -> Option<&'a str> {
    let k = key.to_ascii_lowercase();
    allowed
        .iter()
        .map(|a| (edit_distance(&k, a), *a))
        .filter(|(d, a)| *d <= 2 && *d < a.len().max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, a)| a)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

fn list(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("`{s}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn idx(path: &str, i: usize) -> String {
    format!("{path}[{i}]")
}

/// Names used by the slot-like scalars anywhere inside `v` (for values the loader rejects,
/// so that their names do not also show up as "never used").
fn names_in(v: &Value, out: &mut Vec<String>) {
    match v {
        Value::String(s) if is_param_name(s.trim()) => out.push(s.trim().to_string()),
        Value::Sequence(items) => items.iter().for_each(|x| names_in(x, out)),
        Value::Mapping(m) => m.values().for_each(|x| names_in(x, out)),
        Value::Tagged(t) => names_in(&t.value, out),
        _ => {}
    }
}

impl Loader<'_> {
    fn location(&self, field: &str, key: bool) -> Location {
        let pos = if key {
            self.index.key(field)
        } else {
            self.index.value(field)
        };
        Location {
            file: self.file.map(str::to_string),
            line: pos.map(|p| p.0),
            column: pos.map(|p| p.1),
            field: Some(field.to_string()),
            pose: None,
        }
    }

    /// A problem with the value at `field`.
    fn error(&mut self, field: &str, message: String) {
        let location = self.location(field, false);
        self.push(field, location, message);
    }

    /// A problem with the key of the entry at `field` (an unknown or misplaced key).
    fn key_error(&mut self, field: &str, message: String) {
        let location = self.location(field, true);
        self.push(field, location, message);
    }

    fn push(&mut self, field: &str, location: Location, message: String) {
        self.ctx.reported.push(field.to_string());
        self.diags.push(Diagnostic { location, message });
    }

    /// Keeps the names inside a rejected value counted as used.
    fn orphan(&mut self, v: &Value) {
        names_in(v, &mut self.ctx.used_elsewhere);
    }

    fn orphan_slots(&mut self, slots: &[Slot]) {
        for s in slots {
            if let Slot::Param(n) = s {
                self.ctx.used_elsewhere.push(n.clone());
            }
        }
    }

    /// The entries of the mapping at `path`, reporting unknown keys (against `allowed`) and
    /// non-string keys; `None` (reported) when `v` is not a mapping.
    fn mapping<'v>(
        &mut self,
        v: &'v Value,
        path: &str,
        allowed: Option<&[&str]>,
        expected: &str,
    ) -> Option<Fields<'v>> {
        let Value::Mapping(m) = v else {
            self.error(path, format!("expected {expected}, found {}", describe(v)));
            self.orphan(v);
            return None;
        };
        let mut entries = Vec::new();
        for (k, val) in m {
            let Value::String(key) = k else {
                self.error(
                    path,
                    format!("keys must be plain names, found {} as a key", describe(k)),
                );
                self.orphan(val);
                continue;
            };
            let field = join_key(path, key);
            if let Some(allowed) = allowed {
                if !allowed.contains(&key.as_str()) {
                    let hint = suggest(key, allowed)
                        .map(|s| format!("did you mean `{s}`? "))
                        .unwrap_or_default();
                    self.key_error(
                        &field,
                        format!(
                            "unknown field `{key}`: {hint}expected one of {}",
                            list(allowed)
                        ),
                    );
                    self.orphan(val);
                    continue;
                }
            }
            entries.push((key.as_str(), val));
        }
        Some(Fields { entries })
    }

    fn missing(&mut self, parent: &str, key: &str, what: &str) {
        let field = join_key(parent, key);
        let location = self.location(parent, false);
        self.push(
            &field,
            location,
            format!("missing field `{key}`: expected {what}"),
        );
    }

    /// A slot: number, exact expression or parameter name.
    fn slot(&mut self, v: &Value, path: &str) -> Option<Slot> {
        match v {
            Value::Number(n) => {
                let exact = if let Some(i) = n.as_i64() {
                    Some(Exact::from_int(i))
                } else if let Some(u) = n.as_u64() {
                    Some(Exact::from_rational(BigRational::from_integer(
                        BigInt::from(u),
                    )))
                } else {
                    n.as_f64().and_then(Exact::from_f64)
                };
                match exact {
                    Some(e) => Some(Slot::Const(e)),
                    None => {
                        self.error(path, format!("expected a finite number, found `{n}`"));
                        None
                    }
                }
            }
            Value::String(s) => {
                let t = s.trim();
                if validate::is_identifier(t) && !t.eq_ignore_ascii_case("pi") {
                    return Some(Slot::Param(t.to_string()));
                }
                match Exact::parse(t) {
                    Ok(e) => Some(Slot::Const(e)),
                    Err(msg) => {
                        self.error(path, format!("`{s}` is not {SLOT_HELP}: {msg}"));
                        None
                    }
                }
            }
            other => {
                self.error(
                    path,
                    format!("expected {SLOT_HELP}, found {}", describe(other)),
                );
                self.orphan(other);
                None
            }
        }
    }

    /// A number or exact expression (no parameter names), as `f64`.
    fn number(&mut self, v: &Value, path: &str, what: &str) -> Option<f64> {
        match v {
            Value::Number(n) => n.as_f64().or_else(|| {
                self.error(path, format!("expected {what}, found `{n}`"));
                None
            }),
            Value::String(s) => {
                let t = s.trim();
                if validate::is_identifier(t) && !t.eq_ignore_ascii_case("pi") {
                    self.error(
                        path,
                        format!(
                            "expected {what}, found the name `{t}` (names are not allowed here)"
                        ),
                    );
                    return None;
                }
                match Exact::parse(t) {
                    Ok(e) => Some(e.to_f64()),
                    Err(msg) => {
                        self.error(path, format!("expected {what}, found `{s}`: {msg}"));
                        None
                    }
                }
            }
            other => {
                self.error(path, format!("expected {what}, found {}", describe(other)));
                None
            }
        }
    }

    /// A list of slots (`None`, reported, when `v` is not a list).
    fn slots(&mut self, v: &Value, path: &str, expected: &str) -> Option<Vec<Slot>> {
        let Value::Sequence(items) = v else {
            self.error(path, format!("expected {expected}, found {}", describe(v)));
            self.orphan(v);
            return None;
        };
        let mut out = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            out.push(self.slot(item, &idx(path, i)).unwrap_or_else(Slot::zero));
        }
        Some(out)
    }

    /// A list of exactly `N` slots.
    fn array<const N: usize>(&mut self, v: &Value, path: &str, what: &str) -> Option<[Slot; N]> {
        let items = self.slots(v, path, &format!("a list of {N} entries ({what})"))?;
        let n = items.len();
        match <[Slot; N]>::try_from(items) {
            Ok(a) => Some(a),
            Err(items) => {
                self.error(path, format!("expected {N} entries ({what}), found {n}"));
                self.orphan_slots(&items);
                None
            }
        }
    }

    fn spec(&mut self, root: &Value) -> Spec {
        let mut spec = Spec {
            name: String::new(),
            description: None,
            dim: 0,
            convention: Convention::Dh,
            joints: Vec::new(),
            tool: Vec::new(),
            base: None,
            params: Vec::new(),
            constraints: Vec::new(),
            constraint_list: false,
        };
        if matches!(root, Value::Null) {
            self.error(
                "",
                "the spec is empty: expected a mapping with `name`, `dim`, `joints`, `params` \
                 and `constraint`"
                    .into(),
            );
            return spec;
        }
        let Some(top) = self.mapping(
            root,
            "",
            Some(TOP),
            "a mapping with `name`, `dim`, `joints`, `params` and `constraint`",
        ) else {
            return spec;
        };

        // dim first: other fields depend on it.
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
        if let Some(v) = top.get("convention") {
            match v.as_str() {
                Some("dh") => spec.convention = Convention::Dh,
                Some("mdh") => spec.convention = Convention::Mdh,
                _ => self.error(
                    "convention",
                    format!(
                        "expected `dh` (standard Denavit-Hartenberg) or `mdh` (modified, \
                         Craig), found {}",
                        describe(v)
                    ),
                ),
            }
        }

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
            }
        }

        match top.get("tool") {
            None => spec.tool = vec![Slot::zero(); self.dim.unwrap_or(0)],
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

        if let Some(v) = top.get("base") {
            spec.base = self.base(v);
        }

        if let Some(v) = top.get("params") {
            spec.params = self.params(v);
        }

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
                match lst {
                    Value::Sequence(items) => {
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
                    v => {
                        self.error(
                            "constraints",
                            format!(
                                "expected a list of constraints (e.g. `- line: {{b: [b1, b2]}}`), \
                                 found {}",
                                describe(v)
                            ),
                        );
                        self.orphan(v);
                        self.ctx.constraints_incomplete = true;
                    }
                }
            }
        }
        spec
    }

    fn joint(&mut self, v: &Value, path: &str) -> Joint {
        let mut joint = Joint {
            kind: JointKind::Revolute,
            a: Slot::zero(),
            alpha: Slot::zero(),
            d: Slot::zero(),
            home: Slot::zero(),
            theta: Slot::zero(),
            offset: Slot::zero(),
            limits: None,
        };
        let Some(fields) = self.mapping(
            v,
            path,
            Some(JOINT_ANY),
            "a joint mapping like `{type: revolute, a: a1, home: th1}`",
        ) else {
            return joint;
        };
        let kind = match fields.get("type") {
            None => {
                self.missing(path, "type", "`revolute` or `prismatic`");
                None
            }
            Some(t) => match t.as_str() {
                Some("revolute") => Some(JointKind::Revolute),
                Some("prismatic") => Some(JointKind::Prismatic),
                _ => {
                    self.error(
                        &join_key(path, "type"),
                        format!("expected `revolute` or `prismatic`, found {}", describe(t)),
                    );
                    None
                }
            },
        };
        if let Some(k) = kind {
            joint.kind = k;
        }
        for &(key, val) in &fields.entries {
            let field = join_key(path, key);
            if key == "type" {
                continue;
            }
            if key == "limits" {
                joint.limits = self.limits(val, &field);
                continue;
            }
            let allowed = match kind {
                Some(JointKind::Revolute) => REVOLUTE.contains(&key),
                Some(JointKind::Prismatic) => PRISMATIC.contains(&key),
                None => false,
            };
            if !allowed {
                match kind {
                    Some(JointKind::Revolute) => self.key_error(
                        &field,
                        format!(
                            "`{key}` belongs to prismatic joints: a revolute joint has {} \
                             (θ = q − home)",
                            list(&REVOLUTE[1..5])
                        ),
                    ),
                    Some(JointKind::Prismatic) => {
                        let why = if key == "d" {
                            "a prismatic joint's `d` is its reading plus `offset`: give \
                             `offset`"
                        } else {
                            "`home` belongs to revolute joints: a prismatic joint has \
                             `theta` (a fixed angle) and `offset` (d = q + offset)"
                        };
                        self.key_error(&field, why.into());
                    }
                    None => {}
                }
                self.orphan(val);
                continue;
            }
            let Some(s) = self.slot(val, &field) else {
                continue;
            };
            match key {
                "a" => joint.a = s,
                "alpha" => joint.alpha = s,
                "d" => joint.d = s,
                "home" => joint.home = s,
                "theta" => joint.theta = s,
                _ => joint.offset = s,
            }
        }
        joint
    }

    fn limits(&mut self, v: &Value, path: &str) -> Option<[f64; 2]> {
        let Value::Sequence(items) = v else {
            self.error(
                path,
                format!("expected `[min, max]` (two numbers), found {}", describe(v)),
            );
            return None;
        };
        if items.len() != 2 {
            self.error(
                path,
                format!(
                    "expected `[min, max]` (two numbers), found {} entries",
                    items.len()
                ),
            );
            return None;
        }
        let lo = self.number(&items[0], &idx(path, 0), "a number (the lower limit)");
        let hi = self.number(&items[1], &idx(path, 1), "a number (the upper limit)");
        Some([lo?, hi?])
    }

    fn base(&mut self, v: &Value) -> Option<Base> {
        let fields = self.mapping(
            v,
            "base",
            Some(BASE),
            "a mapping `{x, y, z, roll, pitch, yaw}`",
        )?;
        let mut base = Base {
            x: Slot::zero(),
            y: Slot::zero(),
            z: Slot::zero(),
            roll: Slot::zero(),
            pitch: Slot::zero(),
            yaw: Slot::zero(),
        };
        for &(key, val) in &fields.entries {
            let Some(s) = self.slot(val, &join_key("base", key)) else {
                continue;
            };
            match key {
                "x" => base.x = s,
                "y" => base.y = s,
                "z" => base.z = s,
                "roll" => base.roll = s,
                "pitch" => base.pitch = s,
                _ => base.yaw = s,
            }
        }
        Some(base)
    }

    fn params(&mut self, v: &Value) -> Vec<Param> {
        let mut out = Vec::new();
        if matches!(v, Value::Null) {
            return out;
        }
        let Some(fields) = self.mapping(
            v,
            "params",
            None,
            "a mapping of parameter names to `{nominal: .., known: ..}`",
        ) else {
            return out;
        };
        for &(name, val) in &fields.entries {
            let path = join_key("params", name);
            let mut param = Param {
                name: name.to_string(),
                nominal: Exact::zero(),
                known: false,
                role: ParamRole::Length,
            };
            if let Some(f) = self.mapping(
                val,
                &path,
                Some(PARAM),
                "a mapping `{nominal: <number>, known: <true|false>}`",
            ) {
                match f.get("nominal") {
                    None => self.missing(&path, "nominal", "a number or an expression like `pi/2`"),
                    Some(n) => {
                        let field = join_key(&path, "nominal");
                        let is_name = n.as_str().is_some_and(|s| is_param_name(s.trim()));
                        if is_name {
                            self.error(
                                &field,
                                format!(
                                    "expected a number or an expression like `pi/2`, found the \
                                     name {:?} (a nominal cannot be another parameter)",
                                    n.as_str().unwrap_or_default()
                                ),
                            );
                        } else if let Some(Slot::Const(e)) = self.slot(n, &field) {
                            param.nominal = e;
                        }
                    }
                }
                match f.get("known") {
                    None => {}
                    Some(Value::Bool(b)) => param.known = *b,
                    Some(k) => self.error(
                        &join_key(&path, "known"),
                        format!("expected `true` or `false`, found {}", describe(k)),
                    ),
                }
            }
            out.push(param);
        }
        out
    }

    /// One constraint entry `{kind: {fields}}` (or the bare string `measured`).
    fn constraint(&mut self, v: &Value, path: &str) -> Option<Constraint> {
        let example = "a one-key mapping like `line: {b: [b1, b2]}`, or `measured`";
        if let Value::String(s) = v {
            return match s.trim() {
                "measured" => Some(Constraint::Measured),
                k if KINDS.contains(&k) => {
                    self.error(
                        path,
                        format!("the `{k}` constraint needs its fields: write `{k}: {{...}}`"),
                    );
                    None
                }
                k => {
                    let hint = suggest(k, KINDS)
                        .map(|s| format!("did you mean `{s}`? "))
                        .unwrap_or_default();
                    self.error(
                        path,
                        format!(
                            "unknown constraint kind `{k}`: {hint}expected one of {}",
                            list(KINDS)
                        ),
                    );
                    None
                }
            };
        }
        let fields = self.mapping(v, path, Some(KINDS), example)?;
        let (kind, body) = match fields.entries.as_slice() {
            [] => {
                if fields_were_rejected(v) {
                    return None;
                }
                self.error(path, format!("expected {example}, found an empty mapping"));
                return None;
            }
            [one] => *one,
            [(first, _), rest @ ..] => {
                for &(k, val) in rest {
                    self.key_error(
                        &join_key(path, k),
                        format!(
                            "a constraint entry has one kind, found `{first}` and `{k}`: use \
                             `constraints:` (a list) for several"
                        ),
                    );
                    self.orphan(val);
                }
                fields.entries[0]
            }
        };
        let base = join_key(path, kind);
        if kind == "measured" {
            let empty = match body {
                Value::Null => true,
                Value::Mapping(m) => m.is_empty(),
                _ => false,
            };
            if !empty {
                self.error(
                    &base,
                    format!("`measured` takes no fields, found {}", describe(body)),
                );
                self.orphan(body);
                return None;
            }
            return Some(Constraint::Measured);
        }
        let allowed: &[&str] = match kind {
            "point" => &["p"],
            "line" => &["b", "planes"],
            "plane" => &["b"],
            "circle" | "sphere" => &["center", "radius"],
            _ => &["A", "b"],
        };
        let what = format!("the fields of `{kind}`: {}", list(allowed));
        let f = self.mapping(
            body,
            &base,
            Some(allowed),
            &format!("a mapping with {what}"),
        )?;
        let has_planes = f.get("planes").is_some();
        if let Some(d) = self.dim {
            if let Err(msg) = kind_fits_dim(kind, has_planes && f.get("b").is_none(), d) {
                self.key_error(&base, msg);
                self.orphan(body);
                return None;
            }
        }
        let need = |me: &mut Self, key: &str, what: &str| -> Option<&Value> {
            let got = f.get(key);
            if got.is_none() {
                me.missing(&base, key, what);
            }
            got
        };
        let dim_n = self.dim;
        let n_text = dim_n.map_or("dim".to_string(), |d| d.to_string());
        let c = match kind {
            "point" => {
                let p = need(self, "p", &format!("the point, {n_text} entries"))?;
                Constraint::Point {
                    p: self.slots(
                        p,
                        &join_key(&base, "p"),
                        &format!("a list of {n_text} entries"),
                    )?,
                }
            }
            "line" => match (f.get("b"), f.get("planes")) {
                (Some(_), Some(pl)) => {
                    self.key_error(
                        &join_key(&base, "planes"),
                        "a line is either `b` (dim 2) or `planes` (dim 3), not both".into(),
                    );
                    self.orphan(pl);
                    return None;
                }
                (Some(b), None) => Constraint::Line2 {
                    b: self.array::<2>(b, &join_key(&base, "b"), "b1, b2 of b·x + 1 = 0")?,
                },
                (None, Some(pl)) => {
                    let pp = join_key(&base, "planes");
                    let Value::Sequence(rows) = pl else {
                        self.error(
                            &pp,
                            format!(
                                "expected two planes `[[b1, b2, b3], [b1, b2, b3]]`, found {}",
                                describe(pl)
                            ),
                        );
                        self.orphan(pl);
                        return None;
                    };
                    if rows.len() != 2 {
                        self.error(
                            &pp,
                            format!(
                                "expected two planes `[[b1, b2, b3], [b1, b2, b3]]`, found {} \
                                 entries",
                                rows.len()
                            ),
                        );
                        self.orphan(pl);
                        return None;
                    }
                    let p0 = self.array::<3>(&rows[0], &idx(&pp, 0), "b1, b2, b3 of a plane");
                    let p1 = self.array::<3>(&rows[1], &idx(&pp, 1), "b1, b2, b3 of a plane");
                    match (p0, p1) {
                        (Some(a), Some(b)) => Constraint::Line3 { planes: [a, b] },
                        (a, b) => {
                            for s in a.iter().chain(b.iter()) {
                                self.orphan_slots(s);
                            }
                            return None;
                        }
                    }
                }
                (None, None) => {
                    let what = match dim_n {
                        Some(3) => "`planes: [[..3], [..3]]` (dim 3)",
                        Some(_) => "`b: [b1, b2]` (dim 2)",
                        None => "`b: [b1, b2]` (dim 2) or `planes: [[..3], [..3]]` (dim 3)",
                    };
                    self.missing(&base, if dim_n == Some(3) { "planes" } else { "b" }, what);
                    return None;
                }
            },
            "plane" => {
                let b = need(self, "b", "`[b1, b2, b3]` of b·x + 1 = 0")?;
                Constraint::Plane {
                    b: self.array::<3>(b, &join_key(&base, "b"), "b1, b2, b3 of b·x + 1 = 0")?,
                }
            }
            "circle" | "sphere" => {
                let center = need(self, "center", &format!("the center, {n_text} entries"));
                let radius = need(self, "radius", &format!("the radius ({SLOT_HELP})"));
                let cp = join_key(&base, "center");
                let r = radius.and_then(|r| self.slot(r, &join_key(&base, "radius")));
                let c = if kind == "circle" {
                    center
                        .and_then(|c| self.array::<2>(c, &cp, "the center x, y"))
                        .map(|center| (Some(center), None))
                } else {
                    center
                        .and_then(|c| self.array::<3>(c, &cp, "the center x, y, z"))
                        .map(|center| (None, Some(center)))
                };
                match (c, r) {
                    (Some((Some(center), _)), Some(radius)) => {
                        Constraint::Circle { center, radius }
                    }
                    (Some((_, Some(center))), Some(radius)) => {
                        Constraint::Sphere { center, radius }
                    }
                    (c, r) => {
                        if let Some((c2, c3)) = c {
                            c2.iter().for_each(|s| self.orphan_slots(s));
                            c3.iter().for_each(|s| self.orphan_slots(s));
                        }
                        if let Some(r) = r {
                            self.orphan_slots(&[r]);
                        }
                        return None;
                    }
                }
            }
            _ => {
                let a = need(
                    self,
                    "A",
                    &format!("the symmetric {n_text}×{n_text} matrix"),
                );
                let b = need(self, "b", &format!("the linear part, {n_text} entries"));
                let ap = join_key(&base, "A");
                let a = a.and_then(|a| self.matrix(a, &ap));
                let b = b.and_then(|b| {
                    self.slots(
                        b,
                        &join_key(&base, "b"),
                        &format!("a list of {n_text} entries"),
                    )
                });
                match (a, b) {
                    (Some(a), Some(b)) => Constraint::Quadric { a, b },
                    (a, b) => {
                        a.iter().flatten().for_each(|r| self.orphan_slots(r));
                        b.iter().for_each(|r| self.orphan_slots(r));
                        return None;
                    }
                }
            }
        };
        Some(c)
    }

    /// A list of lists of slots (a quadric's `A`).
    fn matrix(&mut self, v: &Value, path: &str) -> Option<Vec<Vec<Slot>>> {
        let expected = match self.dim {
            Some(d) => format!("a {d}×{d} matrix as a list of {d} rows"),
            None => "a matrix as a list of rows".to_string(),
        };
        let Value::Sequence(rows) = v else {
            self.error(path, format!("expected {expected}, found {}", describe(v)));
            self.orphan(v);
            return None;
        };
        let mut out = Vec::with_capacity(rows.len());
        let mut ok = true;
        for (i, row) in rows.iter().enumerate() {
            match self.slots(row, &idx(path, i), "a row (a list of entries)") {
                Some(r) => out.push(r),
                None => ok = false,
            }
        }
        if ok {
            Some(out)
        } else {
            out.iter().for_each(|r| self.orphan_slots(r));
            None
        }
    }
}

/// Whether `v` is a mapping whose keys all were rejected (so "empty" was already reported).
fn fields_were_rejected(v: &Value) -> bool {
    matches!(v, Value::Mapping(m) if !m.is_empty())
}
