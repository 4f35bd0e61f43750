//! YAML → [`Spec`], with every problem located (file, line, column, field path).
//!
//! Three steps:
//! 1. [`node`](mod@super::node) parses the text with `yaml-rust2` into a typed tree
//!    ([`Value`]) and, from the same events, an index from each field path
//!    (`joints[1].home`, `params.a1.nominal`, `constraint.line.b[0]`) to the line and column
//!    of its value and key. Syntax errors, repeated keys, a second document and the nesting,
//!    node and size bounds stop here, located.
//! 2. The loader walks that tree by hand (not with `#[derive(Deserialize)]`, which stops at
//!    the first problem) and builds a [`Spec`], reporting every unknown key, wrong type, wrong
//!    length and misplaced slot it meets, and going on with a placeholder so that one mistake
//!    shows once. A path the index lacks (a missing field) is placed at its nearest ancestor,
//!    e.g. the mapping the field is missing from.
//! 3. [`validate`](mod@super::validate) checks the meaning (parameters declared and used, angle or length,
//!    dim-specific rules, symmetric quadric, ...) and sets parameter roles.
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

use super::locate::{join_index, join_key, SourceIndex};
use super::node::{parse_yaml, Value, YamlError};
use super::validate::{self, is_param_name, kind_fits_dim, Context, Locate};
use super::{Base, Constraint, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot, Spec};
use crate::error::{excerpt, Diagnostic, Error, ErrorClass, Location, Result};
use crate::model::geometry::{Relation, RelationKind};

/// Reads and validates a spec file.
///
/// # Errors
/// An [`ErrorClass::Input`] error: the file cannot be read, or every problem of the spec,
/// each naming the file, line, column and field.
pub fn from_yaml_file(path: &Path) -> Result<Spec> {
    let name = path.display().to_string();
    let text = crate::error::read_input_file(path, "spec file", MAX_SPEC_BYTES)?;
    from_yaml_str(&text, Some(&name))
}

/// Parses and validates spec text; `file` names it in errors.
///
/// # Errors
/// An [`ErrorClass::Input`] error with every problem found, each located by file (when
/// given), line, column and field path.
pub fn from_yaml_str(text: &str, file: Option<&str>) -> Result<Spec> {
    // A byte-order mark (some editors write one) would read as a second document.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.len() > MAX_SPEC_BYTES {
        return Err(Error::input(
            Location {
                file: file.map(str::to_string),
                ..Location::default()
            },
            format!(
                "the spec is {} bytes, more than the {MAX_SPEC_BYTES} a spec may have",
                text.len()
            ),
        ));
    }
    let (value, index) = match parse_yaml(text) {
        Ok(v) => v,
        Err(e) => return Err(syntax_error(e, file)),
    };
    from_tree(
        &value,
        &Located {
            file,
            index: &index,
        },
    )
}

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

/// A YAML adapter error, located: repeated keys at each repeat, anything else at its place
/// with its character offset.
fn syntax_error(e: YamlError, file: Option<&str>) -> Error {
    let place = |line: usize, column: usize, field: Option<String>| Location {
        file: file.map(str::to_string),
        line: Some(line),
        column: Some(column),
        field,
        pose: None,
    };
    match e {
        YamlError::Duplicates(repeats) => Error::from_diagnostics(
            ErrorClass::Input,
            repeats
                .into_iter()
                .map(|(path, (line, column))| Diagnostic {
                    location: place(line, column, Some(path)),
                    message: "this key appears twice in its mapping: each key may be given once"
                        .into(),
                })
                .collect(),
        ),
        YamlError::At {
            pos: (line, column),
            offset,
            message,
        } => Error::input(
            place(line, column, None),
            format!("invalid YAML (character {offset}): {message}"),
        ),
    }
}

/// The largest magnitude of any number in a spec (metres, radians, constraint coefficients):
/// far beyond any arm (a line 1 nm from the base origin has `|b| = 10⁹`), far below where
/// squares and products lose meaning in `f64`.
pub const MAX_MAGNITUDE: f64 = 1e9;

/// The largest spec text read, in bytes (a spec of a 20-joint arm is a few kilobytes).
pub const MAX_SPEC_BYTES: usize = 1 << 20;

/// The [`Locate`] of a YAML text: file plus the index's line and column.
struct Located<'a> {
    file: Option<&'a str>,
    index: &'a SourceIndex,
}

/// A location from a field path and an index position; the root path names no field, and a
/// document with no node at all (empty, or only comments) is placed at its start.
fn located(file: Option<&str>, field: &str, pos: Option<(usize, usize)>) -> Location {
    let pos = pos.or(if field.is_empty() { Some((1, 1)) } else { None });
    Location {
        file: file.map(str::to_string),
        line: pos.map(|p| p.0),
        column: pos.map(|p| p.1),
        field: (!field.is_empty()).then(|| field.to_string()),
        pose: None,
    }
}

impl Locate for Located<'_> {
    fn value(&self, field: &str) -> Location {
        located(self.file, field, self.index.value(field))
    }

    fn key(&self, field: &str) -> Location {
        located(self.file, field, self.index.key(field))
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
    "relations",
    "urdf",
];
const RELATION_KINDS: &[&str] = &["distance", "same_normal", "offset"];
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
const CONSTRAINT_EXAMPLE: &str = "a one-key mapping like `line: {b: [b1, b2]}`, or `measured`";
const RELATION_EXAMPLE: &str = "`{distance: [0, 1], value: 0.05}`, `{same_normal: [0, 1]}` or \
                                `{offset: [0, 1], value: 0.02}`";

struct Loader<'a> {
    locate: &'a dyn Locate,
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
        Value::String(s) if s.is_empty() => "an empty string".into(),
        Value::String(s) => format!("the string `{}`", excerpt(s)),
        Value::Sequence(_) => "a list".into(),
        Value::Mapping(_) => "a mapping".into(),
        Value::Tagged(t) => format!("a tagged value `{}` (YAML tags are not supported)", t.tag),
    }
}

/// `: names are lowercase, write `x`` when `v` is one of `allowed` in another case (one
/// strictness for spec and CSV: names exactly as the interface writes them).
fn case_hint(v: &Value, allowed: &[&str]) -> String {
    v.as_str()
        .and_then(|s| allowed.iter().find(|a| a.eq_ignore_ascii_case(s)))
        .map_or(String::new(), |a| {
            format!(" (names are exact and lowercase: write `{a}`)")
        })
}

/// The closest of `allowed` to `key`, if it is a likely typo (edit distance at most 2, and
/// less than the candidate's length; case ignored). Every front suggests with this one rule.
#[must_use]
pub fn suggest<'a>(key: &str, allowed: &[&'a str]) -> Option<&'a str> {
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
    join_index(path, i)
}

/// Names used by the slot-like scalars anywhere inside `v` (for values the loader rejects,
/// so that their names do not also show up as "never used").
fn names_in(v: &Value, out: &mut Vec<String>) {
    match v {
        // Every name in a string, so that `a1 + 0.1` counts `a1` as meant to be used.
        Value::String(s) => out.extend(
            s.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .filter(|w| is_param_name(w))
                .map(str::to_string),
        ),
        Value::Sequence(items) => items.iter().for_each(|x| names_in(x, out)),
        Value::Mapping(m) => m.values().for_each(|x| names_in(x, out)),
        Value::Tagged(t) => names_in(&t.value, out),
        _ => {}
    }
}

impl Loader<'_> {
    fn location(&self, field: &str, key: bool) -> Location {
        if key {
            self.locate.key(field)
        } else {
            self.locate.value(field)
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
                // A number or boolean key is indexed under its text; other keys (null, a
                // list, a mapping) are placed at their mapping, without hiding other problems
                // there.
                let text = match k {
                    Value::Number(n) => Some(n.to_string()),
                    Value::Bool(b) => Some(b.to_string()),
                    _ => None,
                };
                let field = text.map_or_else(|| path.to_string(), |t| join_key(path, &t));
                let location = self.location(&field, true);
                self.diags.push(Diagnostic {
                    location,
                    message: format!(
                        "keys must be field or parameter names, found {} as a key",
                        describe(k)
                    ),
                });
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
        let mut location = self.location(parent, false);
        location.field = Some(field.clone());
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
                    Some(e) => self.bounded(e.to_f64(), path).map(|_| Slot::Const(e)),
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
                    Ok(e) => self.bounded(e.to_f64(), path).map(|_| Slot::Const(e)),
                    Err(msg) => {
                        self.error(
                            path,
                            format!(
                                "expected {SLOT_HELP}, found `{}`, which does not parse: {msg}",
                                excerpt(s)
                            ),
                        );
                        self.orphan(v);
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
        let x = self.number_unbounded(v, path, what)?;
        self.bounded(x, path)
    }

    /// `x` if it is finite and within [`MAX_MAGNITUDE`]; otherwise reported.
    fn bounded(&mut self, x: f64, path: &str) -> Option<f64> {
        if x.is_finite() && x.abs() <= MAX_MAGNITUDE {
            return Some(x);
        }
        if !x.is_finite() {
            self.error(path, format!("expected a finite number, found {x}"));
            return None;
        }
        self.error(
            path,
            format!(
                "the value {x:e} is out of range: numbers in a spec are metres or radians (or a \
                 constraint's coefficients), at most {MAX_MAGNITUDE:e} in magnitude"
            ),
        );
        None
    }

    fn number_unbounded(&mut self, v: &Value, path: &str, what: &str) -> Option<f64> {
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
                            "expected {what}, found the name `{}` (names are not allowed here)",
                            excerpt(t)
                        ),
                    );
                    return None;
                }
                match Exact::parse(t) {
                    Ok(e) => Some(e.to_f64()),
                    Err(msg) => {
                        self.error(
                            path,
                            format!("expected {what}, found `{}`: {msg}", excerpt(s)),
                        );
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

    /// `convention:` (optional): `dh` or `mdh`.
    fn convention_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
        let Some(v) = top.get("convention") else {
            return;
        };
        match v.as_str() {
            Some("dh") => spec.convention = Convention::Dh,
            Some("mdh") => spec.convention = Convention::Mdh,
            _ => self.error(
                "convention",
                format!(
                    "expected `dh` (standard Denavit-Hartenberg) or `mdh` (modified, \
                     Craig), found {}{}",
                    describe(v),
                    case_hint(v, &["dh", "mdh"])
                ),
            ),
        }
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

    /// `tool:`, the tip in the last frame (zeros when absent); its length is checked by
    /// validation.
    fn tool_field(&mut self, top: &Fields<'_>, spec: &mut Spec) {
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
    }

    /// `urdf:`, where an imported spec came from (`lincal import`; read by `--write-urdf`):
    /// only checked here.
    fn urdf_field(&mut self, top: &Fields<'_>) {
        if let Some(v) = top.get("urdf") {
            for (field, message) in super::urdf_record::problems(v) {
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

    /// `relations:`: a list of `{distance: [i, j], value: d}`, `{same_normal: [i, j]}`,
    /// `{offset: [i, j], value: d}` between entries of `constraints:`. The indices are checked
    /// against the list, the kinds against what each relation relates (a centre, a normal),
    /// and a relation between two fully known constraints against their values.
    fn relations(&mut self, v: &Value, spec: &Spec) -> Vec<Relation> {
        let Some(items) = self.relation_items(v, spec) else {
            return Vec::new();
        };
        items
            .iter()
            .enumerate()
            .filter_map(|(k, item)| self.relation(item, &idx("relations", k), spec))
            .collect()
    }

    /// The list under `relations:`; `None`, reported, when the spec has one `constraint:`
    /// (nothing to relate) or the value is not a list.
    fn relation_items<'v>(&mut self, v: &'v Value, spec: &Spec) -> Option<&'v [Value]> {
        if !spec.constraint_list {
            self.key_error(
                "relations",
                "relations are between entries of `constraints:` (a list); this spec has one \
                 `constraint:`"
                    .into(),
            );
            self.orphan(v);
            return None;
        }
        let Value::Sequence(items) = v else {
            self.error(
                "relations",
                format!(
                    "expected a list like `- {{distance: [0, 1], value: 0.05}}`, found {}",
                    describe(v)
                ),
            );
            self.orphan(v);
            return None;
        };
        Some(items)
    }

    /// One entry of `relations:` at `path`: its kind, its pair of constraints and its
    /// value; `None` when any is wrong (reported). A relation the spec's known values
    /// contradict is reported and kept.
    fn relation(&mut self, item: &Value, path: &str, spec: &Spec) -> Option<Relation> {
        let mut allowed: Vec<&str> = RELATION_KINDS.to_vec();
        allowed.push("value");
        let fields = self.mapping(item, path, Some(&allowed), RELATION_EXAMPLE)?;
        let (name, pair) = self.relation_kind(&fields, item, path)?;
        let kind = match name {
            "distance" => RelationKind::Distance,
            "same_normal" => RelationKind::SameNormal,
            _ => RelationKind::Offset,
        };
        let between = self.relation_pair(pair, &join_key(path, name), kind, spec);
        let value = self.relation_value(fields.get("value"), kind, path);
        let (between, value) = (between?, value?);
        let relation = Relation {
            kind,
            between,
            value,
        };
        if let Some(message) = known_conflict(&relation, spec) {
            self.error(path, message);
        }
        Some(relation)
    }

    /// The one kind key of a relation entry and its `[i, j]`; `None`, reported, for none or
    /// several.
    fn relation_kind<'v>(
        &mut self,
        fields: &Fields<'v>,
        item: &Value,
        path: &str,
    ) -> Option<(&'v str, &'v Value)> {
        let kinds: Vec<(&str, &Value)> = fields
            .entries
            .iter()
            .filter(|(key, _)| RELATION_KINDS.contains(key))
            .copied()
            .collect();
        match kinds.as_slice() {
            [one] => Some(*one),
            [] => {
                if !fields_were_rejected(item) {
                    self.error(
                        path,
                        format!("expected {RELATION_EXAMPLE}: the kind is missing"),
                    );
                }
                None
            }
            [(first, _), (second, _), ..] => {
                self.key_error(
                    &join_key(path, second),
                    format!(
                        "a relation has one kind, found `{first}` and `{second}`: write \
                         each as its own entry"
                    ),
                );
                None
            }
        }
    }

    /// A relation's `value:`: a positive distance for `distance` and `offset`, none for
    /// `same_normal` (whose value is 0); `None` when wrong or missing (reported).
    fn relation_value(&mut self, x: Option<&Value>, kind: RelationKind, path: &str) -> Option<f64> {
        let value_path = join_key(path, "value");
        match (x, kind.has_value()) {
            (Some(x), true) => {
                let d = self.number(x, &value_path, "a distance in metres");
                match d {
                    Some(d) if d > 0.0 => Some(d),
                    Some(d) => {
                        self.error(
                            &value_path,
                            format!("a distance must be positive, found {d}"),
                        );
                        None
                    }
                    None => None,
                }
            }
            (None, true) => {
                self.missing(path, "value", "`value:` (the distance in metres)");
                None
            }
            (Some(_), false) => {
                self.key_error(
                    &value_path,
                    "`same_normal` takes no value (use `offset` for parallel planes a \
                     known distance apart)"
                        .into(),
                );
                None
            }
            (None, false) => Some(0.0),
        }
    }

    /// The `[i, j]` of a relation: two distinct indices into the constraint list whose kinds
    /// the relation accepts.
    fn relation_pair(
        &mut self,
        v: &Value,
        path: &str,
        kind: RelationKind,
        spec: &Spec,
    ) -> Option<[usize; 2]> {
        let expected = "`[i, j]`, two indices into `constraints` (0-based)";
        let Value::Sequence(items) = v else {
            self.error(path, format!("expected {expected}, found {}", describe(v)));
            return None;
        };
        if items.len() != 2 {
            self.error(
                path,
                format!("expected {expected}, found {} entries", items.len()),
            );
            return None;
        }
        let pair = self.relation_indices(items, path, spec)?;
        if pair[0] == pair[1] {
            self.error(
                path,
                format!(
                    "a relation is between two different constraints, found {} twice",
                    pair[0]
                ),
            );
            return None;
        }
        if self.ctx.constraints_incomplete {
            return None;
        }
        self.relation_kinds_fit(pair, path, kind, spec)
            .then_some(pair)
    }

    /// The two entries of a relation's `[i, j]` as indices into the constraint list (not
    /// checked against its length when the list is incomplete); `None` when either is
    /// wrong (each reported).
    fn relation_indices(&mut self, items: &[Value], path: &str, spec: &Spec) -> Option<[usize; 2]> {
        let mut pair = [0usize; 2];
        let mut ok = true;
        for (e, item) in items.iter().enumerate() {
            let at = idx(path, e);
            match item.as_u64().and_then(|x| usize::try_from(x).ok()) {
                Some(i) if self.ctx.constraints_incomplete || i < spec.constraints.len() => {
                    pair[e] = i;
                }
                Some(i) => {
                    self.error(
                        &at,
                        format!(
                            "constraint {i} does not exist: the list has {} entries (0 to {})",
                            spec.constraints.len(),
                            spec.constraints.len().saturating_sub(1)
                        ),
                    );
                    ok = false;
                }
                None => {
                    self.error(
                        &at,
                        format!(
                            "expected an index into `constraints` (0, 1, …), found {}",
                            describe(item)
                        ),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(pair)
    }

    /// Whether both constraints of `pair` are of a kind the relation accepts (a centre for
    /// `distance`, a normal otherwise); each one that is not is reported.
    fn relation_kinds_fit(
        &mut self,
        pair: [usize; 2],
        path: &str,
        kind: RelationKind,
        spec: &Spec,
    ) -> bool {
        let mut ok = true;
        for (e, &i) in pair.iter().enumerate() {
            let c = &spec.constraints[i];
            if !kind.accepts(c.geometry_kind()) {
                let what = match kind {
                    RelationKind::Distance => "a point, circle or sphere (something with a centre)",
                    _ => "a plane (a line in dim 2)",
                };
                self.error(
                    &idx(path, e),
                    format!(
                        "`{}` relates {what}, but constraint {i} is a {}",
                        kind.name(),
                        c.kind_name()
                    ),
                );
                ok = false;
            }
        }
        ok
    }

    /// One joint of `joints:` at `path`: its type, then each slot where the type allows it
    /// and `limits`; a placeholder revolute joint when the entry is not a mapping.
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
        let kind = self.joint_kind(&fields, path);
        if let Some(k) = kind {
            joint.kind = k;
        }
        for &(key, val) in &fields.entries {
            let field = join_key(path, key);
            match key {
                "type" => {}
                "limits" => joint.limits = self.limits(val, &field),
                _ => self.joint_slot(&mut joint, kind, key, val, &field),
            }
        }
        joint
    }

    /// A joint's `type:`, `revolute` or `prismatic`; `None` when missing or wrong
    /// (reported).
    fn joint_kind(&mut self, fields: &Fields<'_>, path: &str) -> Option<JointKind> {
        let Some(t) = fields.get("type") else {
            self.missing(path, "type", "`revolute` or `prismatic`");
            return None;
        };
        match t.as_str() {
            Some("revolute") => Some(JointKind::Revolute),
            Some("prismatic") => Some(JointKind::Prismatic),
            _ => {
                self.error(
                    &join_key(path, "type"),
                    format!(
                        "expected `revolute` or `prismatic`, found {}{}",
                        describe(t),
                        case_hint(t, &["revolute", "prismatic"])
                    ),
                );
                None
            }
        }
    }

    /// One slot `key` of a joint of type `kind` (`None`: unknown, so no slot is accepted)
    /// into `joint`; a slot the type does not have is reported, saying which it has.
    fn joint_slot(
        &mut self,
        joint: &mut Joint,
        kind: Option<JointKind>,
        key: &str,
        val: &Value,
        field: &str,
    ) {
        let allowed = match kind {
            Some(JointKind::Revolute) => REVOLUTE.contains(&key),
            Some(JointKind::Prismatic) => PRISMATIC.contains(&key),
            None => false,
        };
        if !allowed {
            match kind {
                Some(JointKind::Revolute) => self.key_error(
                    field,
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
                    self.key_error(field, why.into());
                }
                None => {}
            }
            self.orphan(val);
            return;
        }
        let Some(s) = self.slot(val, field) else {
            return;
        };
        if let Some(dst) = joint.slot_mut(key) {
            *dst = s;
        }
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
        let mut base = Base::zero();
        for &(key, val) in &fields.entries {
            let Some(s) = self.slot(val, &join_key("base", key)) else {
                continue;
            };
            if let Some(dst) = base.slot_mut(key) {
                *dst = s;
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
                                     name `{}` (a nominal cannot be another parameter)",
                                    n.as_str().unwrap_or_default().trim()
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
        if let Value::String(s) = v {
            return self.constraint_word(s, path);
        }
        let fields = self.mapping(v, path, Some(KINDS), CONSTRAINT_EXAMPLE)?;
        let (kind, body) = self.constraint_kind(&fields, v, path)?;
        let base = join_key(path, kind);
        if kind == "measured" {
            return self.measured_body(body, &base);
        }
        let f = self.constraint_body(kind, body, &base)?;
        match kind {
            "point" => self.point(&f, &base),
            "line" => self.line(&f, &base),
            "plane" => self.plane(&f, &base),
            "circle" | "sphere" => self.round(kind, &f, &base),
            _ => self.quadric(&f, &base),
        }
    }

    /// A constraint given as a bare string: `measured`, else reported (a kind without its
    /// fields, or an unknown kind with the nearest one suggested).
    fn constraint_word(&mut self, s: &str, path: &str) -> Option<Constraint> {
        match s.trim() {
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
        }
    }

    /// The kind key of a constraint entry and its body: the first key, each further one
    /// reported; `None` for an empty mapping (reported unless its keys were rejected).
    fn constraint_kind<'v>(
        &mut self,
        fields: &Fields<'v>,
        v: &Value,
        path: &str,
    ) -> Option<(&'v str, &'v Value)> {
        match fields.entries.as_slice() {
            [] => {
                if !fields_were_rejected(v) {
                    self.error(
                        path,
                        format!("expected {CONSTRAINT_EXAMPLE}, found an empty mapping"),
                    );
                }
                None
            }
            [one] => Some(*one),
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
                Some(fields.entries[0])
            }
        }
    }

    /// `measured`'s body: nothing (null or `{}`).
    fn measured_body(&mut self, body: &Value, base: &str) -> Option<Constraint> {
        let empty = match body {
            Value::Null => true,
            Value::Mapping(m) => m.is_empty(),
            _ => false,
        };
        if !empty {
            self.error(
                base,
                format!("`measured` takes no fields, found {}", describe(body)),
            );
            self.orphan(body);
            return None;
        }
        Some(Constraint::Measured)
    }

    /// The fields of a constraint's body (unknown ones reported against the kind's), once
    /// the kind is known to fit the spec's `dim`.
    fn constraint_body<'v>(
        &mut self,
        kind: &str,
        body: &'v Value,
        base: &str,
    ) -> Option<Fields<'v>> {
        let allowed: &[&str] = match kind {
            "point" => &["p"],
            "line" => &["b", "planes"],
            "plane" => &["b"],
            "circle" | "sphere" => &["center", "radius"],
            _ => &["A", "b"],
        };
        let what = format!("the fields of `{kind}`: {}", list(allowed));
        let f = self.mapping(body, base, Some(allowed), &format!("a mapping with {what}"))?;
        let has_planes = f.get("planes").is_some();
        if let Some(d) = self.dim {
            if let Err(msg) = kind_fits_dim(kind, has_planes && f.get("b").is_none(), d) {
                self.key_error(base, msg);
                self.orphan(body);
                return None;
            }
        }
        Some(f)
    }

    /// The field `key` of the constraint body `f` at `base`; reported as missing (expected
    /// `what`) when absent.
    fn required<'v>(
        &mut self,
        f: &Fields<'v>,
        base: &str,
        key: &str,
        what: &str,
    ) -> Option<&'v Value> {
        let got = f.get(key);
        if got.is_none() {
            self.missing(base, key, what);
        }
        got
    }

    /// The length of a constraint vector as messages write it: the spec's `dim`, or `dim`
    /// when it is unknown.
    fn n_text(&self) -> String {
        self.dim.map_or("dim".to_string(), |d| d.to_string())
    }

    /// `point: {p: [..]}`.
    fn point(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let n_text = self.n_text();
        let p = self.required(f, base, "p", &format!("the point, {n_text} entries"))?;
        Some(Constraint::Point {
            p: self.slots(
                p,
                &join_key(base, "p"),
                &format!("a list of {n_text} entries"),
            )?,
        })
    }

    /// `line:`: `b: [b1, b2]` in dim 2, `planes: [[..3], [..3]]` in dim 3, not both.
    fn line(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        match (f.get("b"), f.get("planes")) {
            (Some(_), Some(pl)) => {
                self.key_error(
                    &join_key(base, "planes"),
                    "a line is either `b` (dim 2) or `planes` (dim 3), not both".into(),
                );
                self.orphan(pl);
                None
            }
            (Some(b), None) => Some(Constraint::Line2 {
                b: self.array::<2>(b, &join_key(base, "b"), "b1, b2 of b·x + 1 = 0")?,
            }),
            (None, Some(pl)) => self.line_planes(pl, base),
            (None, None) => {
                let dim_n = self.dim;
                let what = match dim_n {
                    Some(3) => "`planes: [[..3], [..3]]` (dim 3)",
                    Some(_) => "`b: [b1, b2]` (dim 2)",
                    None => "`b: [b1, b2]` (dim 2) or `planes: [[..3], [..3]]` (dim 3)",
                };
                self.missing(base, if dim_n == Some(3) { "planes" } else { "b" }, what);
                None
            }
        }
    }

    /// A 3-D line's `planes:`, two planes `[b1, b2, b3]`.
    fn line_planes(&mut self, pl: &Value, base: &str) -> Option<Constraint> {
        let pp = join_key(base, "planes");
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
            (Some(a), Some(b)) => Some(Constraint::Line3 { planes: [a, b] }),
            (a, b) => {
                for s in a.iter().chain(b.iter()) {
                    self.orphan_slots(s);
                }
                None
            }
        }
    }

    /// `plane: {b: [b1, b2, b3]}`.
    fn plane(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let b = self.required(f, base, "b", "`[b1, b2, b3]` of b·x + 1 = 0")?;
        Some(Constraint::Plane {
            b: self.array::<3>(b, &join_key(base, "b"), "b1, b2, b3 of b·x + 1 = 0")?,
        })
    }

    /// `circle:` (dim 2) or `sphere:` (dim 3) `{center: [..], radius: r}`.
    fn round(&mut self, kind: &str, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let n_text = self.n_text();
        let center = self.required(f, base, "center", &format!("the center, {n_text} entries"));
        let radius = self.required(f, base, "radius", &format!("the radius ({SLOT_HELP})"));
        let cp = join_key(base, "center");
        let r = radius.and_then(|r| self.slot(r, &join_key(base, "radius")));
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
            (Some((Some(center), _)), Some(radius)) => Some(Constraint::Circle { center, radius }),
            (Some((_, Some(center))), Some(radius)) => Some(Constraint::Sphere { center, radius }),
            (c, r) => {
                if let Some((c2, c3)) = c {
                    c2.iter().for_each(|s| self.orphan_slots(s));
                    c3.iter().for_each(|s| self.orphan_slots(s));
                }
                if let Some(r) = r {
                    self.orphan_slots(&[r]);
                }
                None
            }
        }
    }

    /// `quadric: {A: [[..], ..], b: [..]}`.
    fn quadric(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let n_text = self.n_text();
        let a = self.required(
            f,
            base,
            "A",
            &format!("the symmetric {n_text}×{n_text} matrix"),
        );
        let b = self.required(f, base, "b", &format!("the linear part, {n_text} entries"));
        let ap = join_key(base, "A");
        let a = a.and_then(|a| self.matrix(a, &ap));
        let b = b.and_then(|b| {
            self.slots(
                b,
                &join_key(base, "b"),
                &format!("a list of {n_text} entries"),
            )
        });
        match (a, b) {
            (Some(a), Some(b)) => Some(Constraint::Quadric { a, b }),
            (a, b) => {
                a.iter().flatten().for_each(|r| self.orphan_slots(r));
                b.iter().for_each(|r| self.orphan_slots(r));
                None
            }
        }
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

/// The spec the loader fills in: nothing read yet (dim 0, standard DH, no joints).
fn blank_spec() -> Spec {
    Spec {
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
        relations: Vec::new(),
    }
}

/// Whether `v` is a mapping whose keys all were rejected (so "empty" was already reported).
fn fields_were_rejected(v: &Value) -> bool {
    matches!(v, Value::Mapping(m) if !m.is_empty())
}

/// When both constraints of `relation` are fully known (numbers and known parameters), why
/// their values contradict it (beyond 10⁻⁹ m), else `None`.
fn known_conflict(relation: &Relation, spec: &Spec) -> Option<String> {
    let value = |slot: &Slot| -> Option<f64> {
        match slot {
            Slot::Const(e) => Some(e.to_f64()),
            Slot::Param(n) => spec
                .params
                .iter()
                .find(|p| &p.name == n && p.known)
                .map(|p| p.nominal.to_f64()),
        }
    };
    let [i, j] = relation.between;
    let vi: Option<Vec<f64>> = spec
        .constraints
        .get(i)?
        .slots()
        .into_iter()
        .map(value)
        .collect();
    let vj: Option<Vec<f64>> = spec
        .constraints
        .get(j)?
        .slots()
        .into_iter()
        .map(value)
        .collect();
    let (vi, vj) = (vi?, vj?);
    let mut r = [0.0; 4];
    let m = relation.kind.residual_count(spec.dim);
    crate::model::geometry::relation_residual_in(relation, spec.dim, &vi, &vj, &mut r[..m]);
    let worst = r[..m].iter().fold(0.0f64, |a, x| a.max(x.abs()));
    (worst > 1e-9 || worst.is_nan()).then(|| {
        format!(
            "constraints {i} and {j} are both fully known and do not satisfy this `{}` \
             relation (off by {worst:.3e} m): fix the values or leave a slot unknown",
            relation.kind.name()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::ParamRole;

    const FILE: &str = "t.yaml";

    /// A valid planar spec; the bad specs below replace one line of it.
    const BASE2: &str = "\
name: t2
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2, 2]}
  - {type: revolute, a: a2, alpha: 0, d: 0, home: th2}
tool: [0.1, 0]
params:
  a1: {nominal: 0.375}
  a2: {nominal: 0.425}
  th1: {nominal: 0}
  th2: {nominal: 0.0}
  b1: {nominal: -1.79}
  b2: {nominal: -0.56}
constraint:
  line: {b: [b1, b2]}
";

    /// A valid spatial spec (PUMA-like first three joints).
    const BASE3: &str = "\
name: t3
dim: 3
convention: dh
joints:
  - {type: revolute, alpha: pi/2, home: th1}
  - {type: revolute, a: a2, home: th2}
  - {type: revolute, a: a3, alpha: '-pi/2', d: d3, home: th3}
tool: [0, 0, 0.1]
params:
  th1: {nominal: 0}
  th2: {nominal: 0}
  th3: {nominal: 0}
  a2: {nominal: 0.4318}
  a3: {nominal: 0.0203}
  d3: {nominal: 0.15005}
  r: {nominal: 0.2}
constraint:
  sphere: {center: [0.4, 0.1, 0.2], radius: r}
";

    fn load(text: &str) -> Result<Spec> {
        from_yaml_str(text, Some(FILE))
    }

    fn ok(text: &str) -> Spec {
        match load(text) {
            Ok(s) => s,
            Err(e) => panic!("expected a valid spec, got:\n{e}\n---\n{text}"),
        }
    }

    /// Replaces the one line of `base` that starts with `old` by `new`.
    fn edit(base: &str, old: &str, new: &str) -> String {
        let mut hit = 0;
        let out: Vec<String> = base
            .lines()
            .map(|l| {
                if l.starts_with(old) {
                    hit += 1;
                    new.to_string()
                } else {
                    l.to_string()
                }
            })
            .collect();
        assert_eq!(hit, 1, "`{old}` must match one line");
        out.join("\n") + "\n"
    }

    /// Asserts that loading fails with a diagnostic at `line` for `field` whose message
    /// contains `fragment`, and that the rendered error shows file, line and field.
    fn bad(text: &str, line: usize, field: &str, fragment: &str) -> Error {
        let e = match load(text) {
            Ok(_) => panic!("expected an error for:\n{text}"),
            Err(e) => e,
        };
        assert_eq!(e.class(), ErrorClass::Input);
        let hit = e.diagnostics().iter().any(|d| {
            d.location.line == Some(line)
                && d.location.file.as_deref() == Some(FILE)
                && d.location.field.as_deref() == Some(field)
                && d.message.contains(fragment)
        });
        assert!(
            hit,
            "no diagnostic at line {line}, field `{field}`, containing `{fragment}`; got:\n{e}"
        );
        let shown = e.to_string();
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
        assert!(shown.contains(&format!("field `{field}`")), "{shown}");
        for d in e.diagnostics() {
            assert!(d.location.line.is_some(), "unlocated: {d}");
        }
        e
    }

    fn shared_case(name: &str) -> Option<std::path::PathBuf> {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/cases")
            .join(name)
            .join("spec.yaml");
        if p.exists() {
            Some(p)
        } else {
            eprintln!("skipped: {} is not there", p.display());
            None
        }
    }

    fn exact(s: &str) -> Slot {
        Slot::Const(Exact::parse(s).unwrap())
    }

    fn name(s: &str) -> Slot {
        Slot::Param(s.into())
    }

    // ---- valid specs ----

    #[test]
    fn loads_the_shared_adept_line_case() {
        let Some(path) = shared_case("adept_line") else {
            return;
        };
        let spec = from_yaml_file(&path).unwrap();
        assert_eq!(spec.name, "adept_line");
        assert_eq!(spec.dim, 2);
        assert_eq!(spec.convention, Convention::Dh);
        assert_eq!(spec.joints.len(), 2);
        assert_eq!(spec.joints[0].a, name("a1"));
        assert_eq!(spec.joints[1].home, name("th2"));
        assert_eq!(spec.joints[0].limits, Some([-2.618, 2.618]));
        assert_eq!(spec.tool, vec![Slot::zero(), Slot::zero()]);
        let names: Vec<&str> = spec.params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a1", "th1", "a2", "th2", "b1", "b2"]);
        assert_eq!(
            spec.param("a1").unwrap().nominal,
            Exact::parse("0.375").unwrap()
        );
        assert_eq!(spec.param("a1").unwrap().role, ParamRole::Length);
        assert_eq!(spec.param("th1").unwrap().role, ParamRole::Angle);
        assert_eq!(
            spec.constraints,
            vec![Constraint::Line2 {
                b: [name("b1"), name("b2")]
            }]
        );
        assert!(!spec.constraint_list);
    }

    #[test]
    fn loads_the_shared_planar3_line_case() {
        let Some(path) = shared_case("planar3_line") else {
            return;
        };
        let spec = from_yaml_file(&path).unwrap();
        assert_eq!(spec.joints.len(), 3);
        assert_eq!(spec.params.len(), 8);
        assert!(spec.params.iter().all(|p| !p.known));
        assert_eq!(spec.param("th3").unwrap().role, ParamRole::Angle);
    }

    #[test]
    fn loads_the_model_specs() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../lincal-models/specs");
        let adept = from_yaml_file(&dir.join("adept_one.yaml")).unwrap();
        assert_eq!(adept.name, "adept_one");
        assert_eq!(adept.param("a1").unwrap().nominal.to_f64(), 0.375);
        assert_eq!(adept.param("a2").unwrap().nominal.to_f64(), 0.425);

        for (file, kind, extra) in [
            ("puma560_plane.yaml", "plane", 3),
            ("puma560_sphere.yaml", "sphere", 4),
        ] {
            let spec = from_yaml_file(&dir.join(file)).unwrap();
            assert_eq!(spec.dim, 3);
            assert_eq!(spec.joints.len(), 6);
            assert_eq!(spec.params.len(), 18 + extra);
            assert_eq!(spec.constraints[0].kind_name(), kind);
            let alphas: Vec<Option<(i8, i8)>> = spec
                .joints
                .iter()
                .map(|j| match &j.alpha {
                    Slot::Const(e) => e.exact_cos_sin(),
                    Slot::Param(_) => None,
                })
                .collect();
            let want = [(0, 1), (1, 0), (0, -1), (0, 1), (0, -1), (1, 0)];
            assert_eq!(alphas, want.map(Some).to_vec());
            assert_eq!(spec.tool[2], exact("0.1"));
            assert_eq!(
                spec.param("d4").unwrap().nominal,
                Exact::parse("0.4318").unwrap()
            );
            assert_eq!(spec.param("th6").unwrap().role, ParamRole::Angle);
            assert_eq!(spec.param("d3").unwrap().role, ParamRole::Length);
        }
    }

    #[test]
    fn loads_a_puma_like_spec_with_exact_angles() {
        let spec = ok(BASE3);
        assert_eq!(spec.joints[0].alpha, exact("pi/2"));
        assert_eq!(spec.joints[2].alpha, exact("-pi/2"));
        assert_eq!(spec.joints[0].a, Slot::zero());
        assert_eq!(spec.joints[2].d, name("d3"));
        assert_eq!(
            spec.constraints[0],
            Constraint::Sphere {
                center: [exact("0.4"), exact("0.1"), exact("0.2")],
                radius: name("r"),
            }
        );
        // Expressions in every slot form, and mdh.
        let spec = ok(&edit(
            &edit(BASE3, "convention:", "convention: mdh"),
            "  - {type: revolute, alpha: pi/2",
            "  - {type: revolute, alpha: 2*pi/3, a: \"0.5\", d: 1e-3, home: th1}",
        ));
        assert_eq!(spec.convention, Convention::Mdh);
        assert_eq!(spec.joints[0].alpha, exact("2*pi/3"));
        assert_eq!(spec.joints[0].a, exact("1/2"));
        assert_eq!(spec.joints[0].d, exact("1/1000"));
    }

    #[test]
    fn loads_a_prismatic_joint() {
        let text = edit(
            BASE3,
            "  - {type: revolute, a: a3",
            "  - {type: prismatic, a: a3, alpha: -pi/2, theta: pi/2, offset: d3, limits: [0, 0.5]}",
        );
        let text = edit(&text, "  th3:", "");
        let spec = ok(&text);
        let j = &spec.joints[2];
        assert_eq!(j.kind, JointKind::Prismatic);
        assert_eq!(j.theta, exact("pi/2"));
        assert_eq!(j.offset, name("d3"));
        assert_eq!(j.d, Slot::zero());
        assert_eq!(j.home, Slot::zero());
        assert_eq!(j.limits, Some([0.0, 0.5]));
        assert_eq!(spec.param("d3").unwrap().role, ParamRole::Length);
    }

    #[test]
    fn loads_base_tool_known_and_description() {
        let text = edit(
            BASE3,
            "tool:",
            "tool: [tx, 0, 0.1]\nbase: {x: bx, z: 0.5, yaw: pi/4, roll: rr}\ndescription: a test",
        );
        let text = edit(
            &text,
            "  r:",
            "  r: {nominal: 0.2, known: true}\n  tx: {nominal: pi/100}\n  bx: {nominal: 1}\n  rr: {nominal: 0}",
        );
        let spec = ok(&text);
        assert_eq!(spec.description.as_deref(), Some("a test"));
        assert!(spec.param("r").unwrap().known);
        assert!(!spec.param("tx").unwrap().known);
        assert_eq!(
            spec.param("tx").unwrap().nominal,
            Exact::parse("pi/100").unwrap()
        );
        assert_eq!(spec.param("rr").unwrap().role, ParamRole::Angle);
        assert_eq!(spec.param("bx").unwrap().role, ParamRole::Length);
        let base = spec.base.clone().unwrap();
        assert_eq!(base.x, name("bx"));
        assert_eq!(base.y, Slot::zero());
        assert_eq!(base.yaw, exact("pi/4"));
        assert_eq!(spec.estimated_params().len(), spec.params.len() - 1);
        // A planar base: x, y, yaw.
        let spec = ok(&edit(
            BASE2,
            "tool:",
            "tool: [0.1, 0]\nbase: {x: 0.1, y: -0.2, yaw: pi}",
        ));
        assert_eq!(spec.base.unwrap().yaw, exact("pi"));
    }

    fn with_constraint(base: &str, constraint: &str) -> Spec {
        let text = edit(base, "constraint:", constraint);
        let text = edit(&text, "  line:", "");
        ok(&text)
    }

    #[test]
    fn names_are_exact_and_lowercase_as_in_the_csv() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: Revolute, a: a1, home: th1, limits: [-2, 2]}",
            ),
            4,
            "joints[0].type",
            "write `revolute`",
        );
        bad(
            &edit(BASE2, "dim: 2", "dim: 2\nconvention: MDH"),
            3,
            "convention",
            "write `mdh`",
        );
        bad(
            &edit(BASE2, "  th2: {nominal: 0.0}", "  th2: {nominal: PI/2}"),
            11,
            "params.th2.nominal",
            "write `pi`",
        );
        bad(&edit(BASE2, "dim: 2", "dim: !custom 2"), 2, "dim", "tag");
    }

    #[test]
    fn loads_every_constraint_kind() {
        // Planar: b1, b2 are declared, so every 2-D constraint uses both.
        let c = |text: &str| with_constraint(BASE2, text).constraints.remove(0);
        assert_eq!(
            c("constraint: {point: {p: [b1, b2]}}"),
            Constraint::Point {
                p: vec![name("b1"), name("b2")]
            }
        );
        assert_eq!(
            c("constraint: {circle: {center: [b1, b2], radius: 0.5}}"),
            Constraint::Circle {
                center: [name("b1"), name("b2")],
                radius: exact("0.5"),
            }
        );
        assert_eq!(
            c("constraint: {quadric: {A: [[b1, 0], [0, b1]], b: [b2, 0]}}"),
            Constraint::Quadric {
                a: vec![
                    vec![name("b1"), Slot::zero()],
                    vec![Slot::zero(), name("b1")]
                ],
                b: vec![name("b2"), Slot::zero()],
            }
        );
        // Spatial: BASE3 declares r.
        let c3 = |text: &str| {
            let text = edit(BASE3, "constraint:", text);
            ok(&edit(&text, "  sphere:", "")).constraints.remove(0)
        };
        assert_eq!(
            c3("constraint:\n  point: {p: [0.5, 0, r]}"),
            Constraint::Point {
                p: vec![exact("0.5"), Slot::zero(), name("r")]
            }
        );
        assert_eq!(
            c3("constraint:\n  plane: {b: [0, 0, r]}"),
            Constraint::Plane {
                b: [Slot::zero(), Slot::zero(), name("r")]
            }
        );
        assert_eq!(
            c3("constraint:\n  line: {planes: [[r, 0, 0], [0, -2, 0]]}"),
            Constraint::Line3 {
                planes: [
                    [name("r"), Slot::zero(), Slot::zero()],
                    [Slot::zero(), exact("-2"), Slot::zero()]
                ]
            }
        );
        assert!(matches!(
            c3("constraint:\n  quadric:\n    A: [[r, 0, 1], [0, r, 0], [1, 0, 2]]\n    b: [0, 0, 0]"),
            Constraint::Quadric { a, .. } if a.len() == 3
        ));
    }

    #[test]
    fn loads_measured_in_three_forms() {
        for form in [
            "constraint: measured",
            "constraint: {measured: {}}",
            "constraint: {measured: null}",
            "constraint:\n  measured:",
            "constraints: [measured]",
        ] {
            let text = edit(BASE2, "constraint:", form);
            let text = edit(&text, "  line:", "");
            let text = edit(&text, "  b1:", "");
            let text = edit(&text, "  b2:", "");
            let spec = ok(&text);
            assert_eq!(spec.constraints, vec![Constraint::Measured], "{form}");
            assert!(spec.is_measured());
        }
    }

    #[test]
    fn loads_constraint_lists() {
        let text = edit(
            BASE2,
            "constraint:",
            "constraints:\n  - line: {b: [b1, b2]}\n  - {line: {b: [b1, c2]}}\n  - circle: {center: [0, 0], radius: 1}",
        );
        let text = edit(&text, "  line:", "");
        let text = edit(&text, "  b2:", "  b2: {nominal: -0.56}\n  c2: {nominal: 1}");
        let spec = ok(&text);
        assert!(spec.constraint_list);
        assert_eq!(spec.constraints.len(), 3);
        assert_eq!(spec.constraints[2].kind_name(), "circle");
        assert_eq!(spec.param("c2").unwrap().role, ParamRole::Length);
    }

    const RELATED: &str = "name: related
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0}
  a2: {nominal: 0.3}
  th2: {nominal: 0}
  x1: {nominal: 0.5}
  x2: {nominal: 0.4}
  u1: {nominal: -2}
  u2: {nominal: 1}
constraints:
  - point: {p: [x1, 0.1]}
  - point: {p: [x2, 0.1]}
  - line: {b: [u1, u2]}
  - line: {b: [-1, 0.5]}
  - point: {p: [0.3, 0.2]}
  - point: {p: [0.3, 0.3]}
";

    /// `RELATED` with `relations:` holding `entries` (the first at line 23).
    fn related(entries: &[&str]) -> String {
        let mut t = format!("{RELATED}relations:\n");
        for e in entries {
            t.push_str(&format!("  - {e}\n"));
        }
        t
    }

    #[test]
    fn loads_relations() {
        use crate::model::geometry::{Relation, RelationKind};
        let spec = ok(&related(&[
            "{distance: [0, 1], value: 0.1}",
            "{same_normal: [2, 3]}",
            "{offset: [3, 2], value: 2*0.01}",
        ]));
        assert_eq!(
            spec.relations,
            vec![
                Relation {
                    kind: RelationKind::Distance,
                    between: [0, 1],
                    value: 0.1
                },
                Relation {
                    kind: RelationKind::SameNormal,
                    between: [2, 3],
                    value: 0.0
                },
                Relation {
                    kind: RelationKind::Offset,
                    between: [3, 2],
                    value: 0.02
                },
            ]
        );
    }

    #[test]
    fn rejects_bad_relations() {
        let one = |e: &str, field: &str, fragment: &str| {
            bad(&related(&[e]), 23, field, fragment);
        };
        one(
            "{distance: [0, 7], value: 0.1}",
            "relations[0].distance[1]",
            "does not exist",
        );
        one(
            "{distance: [1, 1], value: 0.1}",
            "relations[0].distance",
            "two different",
        );
        one(
            "{distance: [0, 2], value: 0.1}",
            "relations[0].distance[1]",
            "is a line",
        );
        one(
            "{same_normal: [0, 2]}",
            "relations[0].same_normal[0]",
            "is a point",
        );
        one("{distance: [0, 1]}", "relations[0].value", "missing field");
        one(
            "{distance: [0, 1], value: -0.1}",
            "relations[0].value",
            "positive",
        );
        one(
            "{same_normal: [2, 3], value: 1}",
            "relations[0].value",
            "takes no value",
        );
        one(
            "{distance: [0, 1], offset: [2, 3], value: 1}",
            "relations[0].offset",
            "one kind",
        );
        one(
            "{distanse: [0, 1], value: 0.1}",
            "relations[0].distanse",
            "distance",
        );
        one(
            "{distance: [0, a], value: 0.1}",
            "relations[0].distance[1]",
            "an index",
        );
        // Both fully known and contradicting the stated distance (they are 0.1 apart).
        one(
            "{distance: [4, 5], value: 0.2}",
            "relations[0]",
            "fully known",
        );
        // Consistent: accepted.
        ok(&related(&["{distance: [4, 5], value: 0.1}"]));
        // A single `constraint:` has nothing to relate.
        let head = &RELATED[..RELATED.find("  u1:").unwrap_or(0)];
        let single = format!("{head}constraint:\n  point: {{p: [x1, x2]}}\n");
        bad(
            &format!("{single}relations: []\n"),
            15,
            "relations",
            "a list",
        );
    }

    // ---- bad specs: each names the line and the field ----

    #[test]
    fn rejects_missing_required_fields() {
        bad(
            &edit(BASE2, "name:", "# no name"),
            2,
            "name",
            "missing field `name`",
        );
        bad(
            &edit(BASE2, "dim:", "# no dim"),
            1,
            "dim",
            "missing field `dim`",
        );
        let text = edit(&edit(BASE2, "constraint:", ""), "  line:", "");
        bad(&text, 1, "constraint", "`constraints:`");
        bad(
            &edit(BASE2, "  th2:", "  th2: {known: true}"),
            11,
            "params.th2.nominal",
            "missing field `nominal`",
        );
    }

    #[test]
    fn rejects_bad_name_dim_convention() {
        bad(&edit(BASE2, "dim:", "dim: 4"), 2, "dim", "2 (planar) or 3");
        bad(
            &edit(BASE2, "dim:", "dim: two"),
            2,
            "dim",
            "2 (planar) or 3",
        );
        bad(
            &edit(BASE2, "name:", "name: 2 links"),
            1,
            "name",
            "identifier",
        );
        bad(
            &edit(BASE2, "name:", "name: [x]"),
            1,
            "name",
            "found a list",
        );
        bad(
            &edit(BASE2, "dim:", "dim: 2\nconvention: craig"),
            3,
            "convention",
            "`mdh`",
        );
    }

    #[test]
    fn rejects_unknown_keys_with_a_suggestion() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: revolute, a: a1, hoem: th1, home: th1}",
            ),
            4,
            "joints[0].hoem",
            "did you mean `home`?",
        );
        bad(
            &edit(BASE2, "tool:", "tool: [0, 0]\nrobot: x"),
            7,
            "robot",
            "unknown field `robot`",
        );
        bad(
            &edit(BASE2, "  a1:", "  a1: {nominal: 0.375, fixed: true}"),
            8,
            "params.a1.fixed",
            "expected one of `nominal`, `known`",
        );
        bad(
            &edit(BASE2, "  line:", "  line: {b: [b1, b2], c: 1}"),
            15,
            "constraint.line.c",
            "unknown field `c`",
        );
    }

    #[test]
    fn rejects_undeclared_and_unused_parameters() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a3, home: th2}",
            ),
            5,
            "joints[1].a",
            "`a3` is not a parameter",
        );
        bad(
            &edit(BASE2, "  a2:", "  a2: {nominal: 0.425}\n  c9: {nominal: 1}"),
            10,
            "params.c9",
            "never used",
        );
    }

    #[test]
    fn rejects_wrong_types() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: [a2], home: th2}",
            ),
            5,
            "joints[1].a",
            "found a list",
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, home: true}",
            ),
            5,
            "joints[1].home",
            "found the boolean `true`",
        );
        bad(
            &edit(BASE2, "  th1:", "  th1: {nominal: 0, known: yes}"),
            10,
            "params.th1.known",
            "`true` or `false`",
        );
        bad(
            &edit(BASE2, "  a1:", "  a1: 0.375"),
            8,
            "params.a1",
            "{nominal: <number>",
        );
        let text = edit(
            &edit(BASE2, "joints:", "joints: {a: a1}"),
            "  - {type: revolute, a: a1",
            "",
        );
        let text = edit(&text, "  - {type: revolute, a: a2", "");
        let e = bad(&text, 3, "joints", "a list of joints");
        assert_eq!(
            e.diagnostics().len(),
            1,
            "no cascade of unused parameters: {e}"
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: rotary, a: a1, home: th1}",
            ),
            4,
            "joints[0].type",
            "`revolute` or `prismatic`",
        );
    }

    #[test]
    fn rejects_bad_expressions_and_nominals() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, home: \"pi*pi\"}",
            ),
            5,
            "joints[1].home",
            "`pi`",
        );
        bad(
            &edit(BASE2, "  a1:", "  a1: {nominal: .nan}"),
            8,
            "params.a1.nominal",
            "finite",
        );
        bad(
            &edit(BASE2, "  a1:", "  a1: {nominal: -.inf}"),
            8,
            "params.a1.nominal",
            "finite",
        );
        bad(
            &edit(BASE2, "  a1:", "  a1: {nominal: a2}"),
            8,
            "params.a1.nominal",
            "cannot be another parameter",
        );
        bad(
            &edit(BASE2, "  a1:", "  pi: {nominal: 1}"),
            8,
            "params.pi",
            "constant π",
        );
    }

    #[test]
    fn rejects_wrong_lengths() {
        bad(
            &edit(BASE2, "tool:", "tool: [0.1, 0, 0]"),
            6,
            "tool",
            "2 entries",
        );
        bad(
            &edit(BASE2, "  line:", "  line: {b: [b1, b2, 0]}"),
            15,
            "constraint.line.b",
            "2 entries",
        );
        bad(
            &edit(BASE3, "tool:", "tool: [0, 0.1]"),
            8,
            "tool",
            "3 entries",
        );
        bad(
            &edit(
                BASE3,
                "  sphere:",
                "  sphere: {center: [0.4, 0.1], radius: r}",
            ),
            18,
            "constraint.sphere.center",
            "3 entries",
        );
        bad(
            &edit(
                BASE2,
                "  line:",
                "  quadric: {A: [[b1, 0, 0], [0, b1, 0], [0, 0, 1]], b: [b2, 0]}",
            ),
            15,
            "constraint.quadric.A",
            "2×2",
        );
        bad(
            &edit(BASE2, "  line:", "  point: {p: [b1, b2, 0]}"),
            15,
            "constraint.point.p",
            "2 entries",
        );
    }

    #[test]
    fn rejects_constraints_that_do_not_fit_dim() {
        bad(
            &edit(BASE2, "  line:", "  plane: {b: [b1, b2, 1]}"),
            15,
            "constraint.plane",
            "3-D",
        );
        bad(
            &edit(
                BASE2,
                "  line:",
                "  sphere: {center: [b1, b2, 0], radius: 1}",
            ),
            15,
            "constraint.sphere",
            "use `circle`",
        );
        bad(
            &edit(
                BASE3,
                "  sphere:",
                "  circle: {center: [0.4, 0.1], radius: r}",
            ),
            18,
            "constraint.circle",
            "use `sphere`",
        );
        bad(
            &edit(BASE3, "  sphere:", "  line: {b: [r, 1]}"),
            18,
            "constraint.line",
            "two planes",
        );
        bad(
            &edit(
                BASE2,
                "  line:",
                "  line: {planes: [[b1, b2, 0], [0, 0, 1]]}",
            ),
            15,
            "constraint.line",
            "in dim 2",
        );
    }

    #[test]
    fn rejects_a_non_symmetric_quadric() {
        bad(
            &edit(
                BASE2,
                "  line:",
                "  quadric: {A: [[1, b1], [0.5, 1]], b: [b2, 0]}",
            ),
            15,
            "constraint.quadric.A[0][1]",
            "symmetric",
        );
    }

    #[test]
    fn rejects_slots_of_the_wrong_joint_type() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: prismatic, a: a2, home: th2}",
            ),
            5,
            "joints[1].home",
            "revolute joints",
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, home: th2, offset: 1}",
            ),
            5,
            "joints[1].offset",
            "prismatic joints",
        );
        bad(
            &edit(
                BASE3,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, home: th2, theta: 0}",
            ),
            6,
            "joints[1].theta",
            "prismatic joints",
        );
        bad(
            &edit(
                BASE3,
                "  - {type: revolute, a: a2",
                "  - {type: prismatic, a: a2, d: 0.1, theta: th2}",
            ),
            6,
            "joints[1].d",
            "`offset`",
        );
    }

    #[test]
    fn rejects_out_of_plane_rotations_in_dim_2() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, alpha: pi/2, home: th2}",
            ),
            5,
            "joints[1].alpha",
            "0 or pi",
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, alpha: b2, home: th2}",
            ),
            5,
            "joints[1].alpha",
            "not the parameter `b2`",
        );
        bad(
            &edit(BASE2, "tool:", "tool: [0, 0]\nbase: {x: 1, roll: 0.1}"),
            7,
            "base.roll",
            "x, y and yaw",
        );
        // alpha = pi is in the plane.
        ok(&edit(
            BASE2,
            "  - {type: revolute, a: a2",
            "  - {type: revolute, a: a2, alpha: pi, home: th2}",
        ));
    }

    #[test]
    fn rejects_bad_constraint_sections() {
        let both = edit(BASE2, "constraint:", "constraints: [measured]\nconstraint:");
        bad(&both, 14, "constraints", "not both");
        let empty = edit(
            &edit(BASE2, "constraint:", "constraints: []"),
            "  line:",
            "",
        );
        bad(&empty, 14, "constraints", "empty");
        let mixed = edit(
            &edit(
                BASE2,
                "constraint:",
                "constraints:\n  - line: {b: [b1, b2]}\n  - measured",
            ),
            "  line:",
            "",
        );
        bad(&mixed, 15, "constraints", "must not mix `measured`");
        bad(
            &edit(BASE2, "  line:", "  lines: {b: [b1, b2]}"),
            15,
            "constraint.lines",
            "did you mean `line`?",
        );
        bad(
            &edit(
                BASE2,
                "  line:",
                "  line: {b: [b1, b2]}\n  point: {p: [0, 0]}",
            ),
            16,
            "constraint.point",
            "one kind",
        );
        bad(
            &edit(BASE2, "  line:", "  measured: {x: 1}\n  # b1 b2"),
            15,
            "constraint.measured",
            "no fields",
        );
        let text = edit(&edit(BASE2, "constraint:", "constraint: 3"), "  line:", "");
        bad(&text, 14, "constraint", "one-key mapping");
    }

    #[test]
    fn rejects_empty_joints_and_bad_limits() {
        let text = edit(
            &edit(
                &edit(BASE2, "joints:", "joints: []"),
                "  - {type: revolute, a: a1",
                "",
            ),
            "  - {type: revolute, a: a2",
            "",
        );
        bad(&text, 3, "joints", "at least one joint");
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: revolute, a: a1, home: th1, limits: [2, -2]}",
            ),
            4,
            "joints[0].limits",
            "min < max",
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: revolute, a: a1, home: th1, limits: [-.inf, 2]}",
            ),
            4,
            "joints[0].limits[0]",
            "finite",
        );
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a1",
                "  - {type: revolute, a: a1, home: th1, limits: [-2]}",
            ),
            4,
            "joints[0].limits",
            "two numbers",
        );
    }

    #[test]
    fn rejects_a_parameter_that_is_both_angle_and_length() {
        bad(
            &edit(
                BASE2,
                "  - {type: revolute, a: a2",
                "  - {type: revolute, a: a2, d: th1, home: th2}",
            ),
            5,
            "joints[1].d",
            "either an angle",
        );
    }

    #[test]
    fn reports_yaml_syntax_and_duplicate_keys() {
        // An unclosed list: the parser stops on the next line, where the list cannot go on.
        let e = load(&edit(BASE2, "tool:", "tool: [0.1, 0")).unwrap_err();
        let d = &e.diagnostics()[0];
        assert_eq!(d.location.line, Some(8));
        assert!(d.message.contains("invalid YAML"), "{e}");
        assert!(!d.message.contains("at line 7"), "{e}");

        let e = load(&edit(
            BASE2,
            "  a2:",
            "  a2: {nominal: 0.425}\n  a1: {nominal: 1}",
        ))
        .unwrap_err();
        let d = &e.diagnostics()[0];
        assert_eq!(
            (d.location.line, d.location.column),
            (Some(10), Some(3)),
            "{e}"
        );
        assert_eq!(d.location.field.as_deref(), Some("params.a1"));
        assert!(d.message.contains("twice"));

        let e = load("").unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let e = load("- 1\n- 2\n").unwrap_err();
        assert!(e.to_string().contains("t.yaml:1:1"), "{e}");
        let e = load("\u{feff}name: [x]\n").unwrap_err();
        assert!(e.to_string().contains("t.yaml:1:7: field `name`"), "{e}");
        let e = load("a: 1\n---\nb: 2\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("t.yaml:2:1: invalid YAML (character 5): a second YAML document"),
            "{e}"
        );
    }

    #[test]
    fn reports_every_problem_at_once_in_line_order() {
        let text = "\
name: t
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, hoem: 0}
  - {type: prismatic, a: x, home: th2}
tool: [0, 0, 0]
params:
  a1: {nominal: 1}
  th1: {nominal: .nan}
  unused: {nominal: 0}
constraint:
  plane: {b: [1, 2, 3]}
";
        let e = load(text).unwrap_err();
        let lines: Vec<usize> = e
            .diagnostics()
            .iter()
            .map(|d| d.location.line.unwrap())
            .collect();
        assert!(lines.windows(2).all(|w| w[0] <= w[1]), "{e}");
        for field in [
            "joints[0].hoem",
            "joints[1].home",
            "joints[1].a",
            "tool",
            "params.th1.nominal",
            "params.unused",
            "constraint.plane",
            "joints[1].type",
        ] {
            assert!(
                e.diagnostics()
                    .iter()
                    .any(|d| d.location.field.as_deref() == Some(field)),
                "missing `{field}` in:\n{e}"
            );
        }
        // th2 is only in a rejected slot: no "undeclared" error for it, nor "unused" cascade.
        assert_eq!(e.diagnostics().len(), 8, "{e}");
    }

    #[test]
    fn the_file_is_named_in_read_errors() {
        let e = from_yaml_file(Path::new("/nonexistent/spec.yaml")).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Input);
        assert!(
            e.to_string()
                .starts_with("/nonexistent/spec.yaml: cannot read"),
            "{e}"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// Random edits of a valid spec never panic, and every error is located.
        #[test]
        fn never_panics(cut in 0usize..600, len in 0usize..20, insert in "[ -~\\n]{0,8}") {
            let base = BASE3;
            let cut = cut.min(base.len());
            let end = (cut + len).min(base.len());
            if base.is_char_boundary(cut) && base.is_char_boundary(end) {
                let text = format!("{}{}{}", &base[..cut], insert, &base[end..]);
                if let Err(e) = from_yaml_str(&text, None) {
                    proptest::prop_assert!(!e.diagnostics().is_empty());
                    proptest::prop_assert_eq!(e.class(), ErrorClass::Input);
                }
            }
        }
    }
}
