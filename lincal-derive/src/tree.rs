//! The attribute adapter: inline `#[calib(...)]` items as the core's document tree.
//!
//! The derive does not read specs itself. It rewrites the inline items into the same
//! format-neutral tree the YAML adapter makes ([`Value`]), remembering the token span of every
//! field path, and hands the tree to the one spec walker, [`lincal_core::spec::from_tree`].
//! So the inline form and YAML accept and reject exactly the same specs with the same
//! messages; each message is then placed at the token of the field it names.
//!
//! | inline item | tree (as YAML) |
//! |---|---|
//! | `name = "x"`, `dim = 2`, `convention = mdh`, `tool = [0, 0, 0.1]` | `name: x`, `dim: 2`, ... |
//! | `joint(revolute, a = a1, home = th1)` (one per joint) | `joints: [{type: revolute, a: a1, home: th1}]` |
//! | `base(x = 0.1, yaw = pi/2)` | `base: {x: 0.1, yaw: pi/2}` |
//! | `tool(x = tx, z = 0.1, roll = tr)` (a tool frame) | `tool: {x: tx, z: 0.1, roll: tr}` |
//! | `param(a1 = 0.375)`, `params(a1 = 0.375, a2 = 0.4)` | `params: {a1: {nominal: 0.375}, ...}` |
//! | `param(r = 0.15, known)`, `known(r = 0.15)` | `params: {r: {nominal: 0.15, known: true}}` |
//! | `constraint(line(b = [b1, b2]))`, `constraint(measured)` | `constraint: {line: {b: [b1, b2]}}`, `constraint: {measured: null}` |
//! | `constraint(measured_pose(position_std = 2e-5, orientation_std = 5e-5))` | `constraint: {measured_pose: {position_std: 2e-5, orientation_std: 5e-5}}` |
//! | `constraints(line(..), point(..))` | `constraints: [{line: ..}, {point: ..}]` |
//!
//! Values: a string literal is a string (a name or an expression, as a quoted YAML scalar); a
//! number literal, or a negated one, is a number typed by the YAML core schema
//! ([`Number::parse`]); a bare identifier is a string (a name, or `pi`); `[..]` is a list;
//! any other arithmetic (`-pi/2`, `2*pi/3`) is a string of its tokens, which the walker parses
//! as an exact expression. Only what has no YAML counterpart is reported here: an item of the
//! wrong shape (`joint = 1`), a key given twice, a literal of another type (`1u8`, `'c'`).

use std::cell::RefCell;
use std::collections::HashMap;

use lincal_core::error::Location;
use lincal_core::spec::node::{Number, Value};
use lincal_core::spec::validate::Locate;
use lincal_core::spec::{join_index, join_key, parent_field, suggest};
use proc_macro2::{Span, TokenStream};
use quote::ToTokens;
use syn::Expr;

use crate::attr::Node;
use crate::ctxt::Ctxt;

/// The inline top-level keys (the spec keys, with `joint`, `param(s)` and `known` in the
/// place of `joints` and `params`).
pub const TOP: &[&str] = &[
    "name",
    "description",
    "dim",
    "convention",
    "joint",
    "tool",
    "base",
    "param",
    "params",
    "known",
    "constraint",
    "constraints",
    "relations",
    "spec",
    "yaml",
    "crate",
];

/// The tokens an error points at: their first and last token spans (a [`Span`] cannot be
/// joined on stable Rust, so `syn::Error::new_spanned` takes the tokens).
pub type Place = TokenStream;

/// Field path → the tokens that gave it (its value, and its key where it has one).
#[derive(Default)]
pub struct Spans {
    values: HashMap<String, Place>,
    keys: HashMap<String, Place>,
}

impl Spans {
    /// The tokens of `field`'s value, or of its nearest ancestor; whether it was exact.
    fn value(&self, field: &str) -> Option<(Place, bool)> {
        let mut f = field;
        let mut exact = true;
        loop {
            if let Some(s) = self.values.get(f) {
                return Some((s.clone(), exact));
            }
            exact = false;
            f = parent_field(f)?;
        }
    }

    /// The tokens of `field`'s key, else of its value.
    fn key(&self, field: &str) -> Option<(Place, bool)> {
        self.keys
            .get(field)
            .map(|s| (s.clone(), true))
            .or_else(|| self.value(field))
    }
}

/// The [`Locate`] of an inline spec. The walker's locations carry the field path; the span
/// (which a [`Location`] cannot hold) is kept in a table here, and the location's `line` is
/// its number in that table (1-based), so each message can be put back at its token.
pub struct Placer<'a> {
    spans: &'a Spans,
    whole: Place,
    table: RefCell<Vec<(Place, bool)>>,
}

impl<'a> Placer<'a> {
    /// A placer over `spans`; a path with no indexed ancestor is placed at `whole`.
    pub fn new(spans: &'a Spans, whole: Span) -> Self {
        Placer {
            spans,
            whole: at(whole),
            table: RefCell::new(Vec::new()),
        }
    }

    fn place(&self, field: &str, found: Option<(Place, bool)>) -> Location {
        let mut table = self.table.borrow_mut();
        table.push(found.unwrap_or_else(|| (self.whole.clone(), false)));
        Location {
            line: Some(table.len()),
            field: (!field.is_empty()).then(|| field.to_string()),
            ..Location::default()
        }
    }

    /// The tokens a location of this placer stands for, and whether they are the field's own.
    pub fn place_of(&self, location: &Location) -> (Place, bool) {
        location
            .line
            .and_then(|i| self.table.borrow().get(i.wrapping_sub(1)).cloned())
            .unwrap_or_else(|| (self.whole.clone(), false))
    }
}

impl Locate for Placer<'_> {
    fn value(&self, field: &str) -> Location {
        self.place(field, self.spans.value(field))
    }

    fn key(&self, field: &str) -> Location {
        self.place(field, self.spans.key(field))
    }
}

/// Builds the tree of the inline items; shape errors go to `cx`.
pub struct Adapter<'a> {
    cx: &'a Ctxt,
    /// Where every field path came from.
    pub spans: Spans,
    /// Field paths whose problem was reported here (the walker would repeat it, about the
    /// hole left in the tree).
    pub reported: Vec<String>,
    /// Top-level keys that are not inline keys: passed to the walker as they are (so that
    /// the rest of the spec is judged as YAML would judge it), reported here in inline terms.
    pub unknown: Vec<String>,
}

/// A mapping being built, with the keys seen (a repeat is an error, as in YAML).
#[derive(Default)]
struct Entries {
    entries: Vec<(Value, Value)>,
    seen: Vec<String>,
}

impl Adapter<'_> {
    /// A new adapter reporting to `cx`.
    pub fn new(cx: &Ctxt) -> Adapter<'_> {
        Adapter {
            cx,
            spans: Spans::default(),
            reported: Vec::new(),
            unknown: Vec::new(),
        }
    }

    /// `key: value` into `map` at `path` (the mapping's path), unless `key` is there already.
    fn insert(
        &mut self,
        map: &mut Entries,
        path: &str,
        key: &str,
        key_span: Span,
        value: Value,
    ) -> bool {
        if map.seen.iter().any(|k| k == key) {
            self.reported.push(join_key(path, key));
            self.cx.error_at(
                key_span,
                format!("`{key}` is given more than once: each key may be given once"),
            );
            return false;
        }
        map.seen.push(key.to_string());
        self.spans.keys.insert(join_key(path, key), at(key_span));
        map.entries.push((Value::String(key.to_string()), value));
        true
    }

    /// The root mapping of the inline `items`; `default_name` when they give no `name`.
    pub fn root(&mut self, items: &[Node], default_name: &str, whole: Span) -> Value {
        let mut root = Entries::default();
        let mut joints: Vec<Value> = Vec::new();
        let mut joints_span: Option<Span> = None;
        let mut params = Entries::default();
        let mut params_span: Option<Span> = None;
        for node in items {
            let key = node.name();
            match key.as_str() {
                "joint" => {
                    let path = join_index("joints", joints.len());
                    joints_span.get_or_insert(node.key().span());
                    if let Some(j) = self.joint(node, &path) {
                        self.spans.values.insert(path, node.to_token_stream());
                        joints.push(j);
                    }
                }
                "param" | "params" | "known" => {
                    params_span.get_or_insert(node.key().span());
                    self.params(node, key == "known", &mut params);
                }
                "base" => {
                    if let Some(items) = self.list(node, "base", "base(x = 0.1, yaw = pi/2)") {
                        let v = self.fields(items, "base", None);
                        self.top(&mut root, node, v);
                    }
                }
                "constraint" => {
                    let v = match node {
                        Node::List(_, items) if items.len() == 1 => {
                            Some(self.constraint(&items[0], "constraint"))
                        }
                        _ => {
                            self.reported.push("constraint".into());
                            self.cx.error_spanned_by(
                                node,
                                "`constraint(...)` holds one constraint, e.g. \
                                 `constraint(line(b = [b1, b2]))`; use `constraints(...)` for a list",
                            );
                            None
                        }
                    };
                    if let Some(v) = v {
                        self.top(&mut root, node, v);
                    }
                }
                "constraints" => {
                    if let Some(items) = self.list(
                        node,
                        "constraints",
                        "constraints(line(b = [b1, b2]), point(p = [px, py]))",
                    ) {
                        let v = Value::Sequence(
                            items
                                .iter()
                                .enumerate()
                                .map(|(k, item)| {
                                    self.constraint(item, &join_index("constraints", k))
                                })
                                .collect(),
                        );
                        self.top(&mut root, node, v);
                    }
                }
                "relations" => {
                    if let Some(items) = self.list(
                        node,
                        "relations",
                        "relations(distance(between = [0, 1], value = 0.05))",
                    ) {
                        let v = Value::Sequence(
                            items
                                .iter()
                                .enumerate()
                                .map(|(k, item)| self.relation(item, &join_index("relations", k)))
                                .collect(),
                        );
                        self.top(&mut root, node, v);
                    }
                }
                // A tool frame `tool(x = .., roll = ..)`, as `base(...)`; `tool = [..]` below.
                "tool" if matches!(node, Node::List(..)) => {
                    if let Some(items) = self.list(
                        node,
                        "tool",
                        "tool(x = tx, y = 0, z = tz, roll = 0, yaw = tw)",
                    ) {
                        let v = self.fields(items, "tool", None);
                        self.top(&mut root, node, v);
                    }
                }
                "name" | "description" | "dim" | "convention" | "tool" => {
                    if let Node::Value(_, e) = node {
                        let v = self.value(e, &key);
                        self.top(&mut root, node, v);
                    } else {
                        self.reported.push(key.clone());
                        let msg = if key == "tool" {
                            "expected `tool = [tx, ty, tz]` (the tip in the last frame) or a tool \
                             frame `tool(x = .., y = .., z = .., roll = .., pitch = .., yaw = ..)`"
                                .to_string()
                        } else {
                            format!("expected `{key} = ...`")
                        };
                        self.cx.error_spanned_by(node, msg);
                    }
                }
                // Taken out by `attr::read`.
                "spec" | "yaml" | "crate" => {}
                _ => {
                    let v = match node {
                        Node::Value(_, e) => self.value(e, &key),
                        Node::List(_, items) => self.any(items, &key),
                        Node::Word(_) => Value::Null,
                    };
                    self.unknown.push(key.clone());
                    self.top(&mut root, node, v);
                }
            }
        }
        if !root.seen.iter().any(|k| k == "name") {
            root.entries.push((
                Value::String("name".into()),
                Value::String(default_name.to_string()),
            ));
        }
        let span = joints_span.unwrap_or(whole);
        self.spans.values.insert("joints".into(), at(span));
        root.entries
            .push((Value::String("joints".into()), Value::Sequence(joints)));
        if params_span.is_some() || !params.entries.is_empty() {
            self.spans
                .values
                .insert("params".into(), at(params_span.unwrap_or(whole)));
            root.entries.push((
                Value::String("params".into()),
                Value::Mapping(params.entries.into_iter().collect()),
            ));
        }
        self.spans.values.insert(String::new(), at(whole));
        Value::Mapping(root.entries.into_iter().collect())
    }

    /// A top-level entry `node.name(): v`.
    fn top(&mut self, root: &mut Entries, node: &Node, v: Value) {
        let key = node.name();
        let span = match node {
            Node::Value(_, e) => e.to_token_stream(),
            _ => node.to_token_stream(),
        };
        if self.insert(root, "", &key, node.key().span(), v) {
            self.spans.values.entry(key).or_insert(span);
        }
    }

    /// `key(items)`'s items, or an error naming `example`.
    fn list<'n>(&mut self, node: &'n Node, path: &str, example: &str) -> Option<&'n [Node]> {
        match node {
            Node::List(_, items) => Some(items),
            _ => {
                self.reported.push(path.to_string());
                self.cx.error_spanned_by(
                    node,
                    format!("expected `{}(...)`, e.g. `{example}`", node.name()),
                );
                None
            }
        }
    }

    /// `key = value` items as a mapping at `path`; a bare word is `word_key: word` when
    /// `word_key` is given (a joint's type), else an error.
    fn fields(&mut self, items: &[Node], path: &str, word_key: Option<&str>) -> Value {
        let mut map = Entries::default();
        for item in items {
            match item {
                Node::Value(k, e) => {
                    let key = item.name();
                    let field = join_key(path, &key);
                    let v = self.value(e, &field);
                    self.insert(&mut map, path, &key, k.span(), v);
                }
                Node::Word(w) if word_key.is_some() => {
                    let wk = word_key.unwrap_or_default();
                    let field = join_key(path, wk);
                    self.spans.values.insert(field, w.to_token_stream());
                    self.insert(&mut map, path, wk, w.span(), Value::String(item.name()));
                }
                _ => {
                    self.reported.push(join_key(path, &item.name()));
                    self.cx
                        .error_spanned_by(item, format!("expected `{} = ...` here", item.name()));
                }
            }
        }
        Value::Mapping(map.entries.into_iter().collect())
    }

    /// Items of any shape as a mapping at `path` (`word` → null, `k(..)` → a mapping), for a
    /// key the walker will reject: its names still count as used there.
    fn any(&mut self, items: &[Node], path: &str) -> Value {
        let mut map = Entries::default();
        for item in items {
            let key = item.name();
            let field = join_key(path, &key);
            let v = match item {
                Node::Word(_) => Value::Null,
                Node::Value(_, e) => self.value(e, &field),
                Node::List(_, inner) => self.any(inner, &field),
            };
            self.insert(&mut map, path, &key, item.key().span(), v);
        }
        Value::Mapping(map.entries.into_iter().collect())
    }

    /// `joint(revolute, a = a1, ...)` at `path`.
    fn joint(&mut self, node: &Node, path: &str) -> Option<Value> {
        let items = self.list(node, path, "joint(revolute, a = a1, home = th1)")?;
        Some(self.fields(items, path, Some("type")))
    }

    /// `param(a1 = 0.375[, known])`, `params(...)`, `known(...)` into `params`.
    fn params(&mut self, node: &Node, known_list: bool, params: &mut Entries) {
        let Some(items) = self.list(node, "params", "params(a1 = 0.375, a2 = 0.425)") else {
            return;
        };
        // `known` as a word marks every parameter of the item.
        let known_word = items.iter().find_map(|i| match i {
            Node::Word(w) if i.name() == "known" => Some(w.span()),
            _ => None,
        });
        for item in items {
            match item {
                Node::Value(k, e) => {
                    let name = item.name();
                    let path = join_key("params", &name);
                    let nominal_path = join_key(&path, "nominal");
                    let nominal = self.value(e, &nominal_path);
                    let mut fields = vec![(Value::String("nominal".into()), nominal)];
                    if let Some(span) = known_word.or(known_list.then(|| k.span())) {
                        self.spans.values.insert(join_key(&path, "known"), at(span));
                        fields.push((Value::String("known".into()), Value::Bool(true)));
                    }
                    self.spans.values.insert(path.clone(), k.to_token_stream());
                    self.insert(
                        params,
                        "params",
                        &name,
                        k.span(),
                        Value::Mapping(fields.into_iter().collect()),
                    );
                }
                Node::Word(_) if item.name() == "known" => {}
                _ => {
                    self.reported.push(join_key("params", &item.name()));
                    self.cx.error_spanned_by(
                        item,
                        format!(
                            "expected `name = nominal` here, e.g. `{} = 0.1`",
                            item.name()
                        ),
                    );
                }
            }
        }
    }

    /// One constraint item (`line(b = [b1, b2])`, `measured`) at `path`.
    /// One relation `kind(between = [i, j], value = d)`, as the spec's
    /// `{kind: [i, j], value: d}` (the pair's tokens placed at `kind`).
    fn relation(&mut self, item: &Node, path: &str) -> Value {
        self.spans
            .values
            .insert(path.to_string(), item.to_token_stream());
        let kind = item.name();
        let Node::List(_, items) = item else {
            self.reported.push(path.to_string());
            self.cx.error_spanned_by(
                item,
                format!("expected `{kind}(between = [i, j], ...)`, e.g. `distance(between = [0, 1], value = 0.05)`"),
            );
            return Value::Null;
        };
        let Value::Mapping(mut map) = self.fields(items, path, None) else {
            return Value::Null;
        };
        let between = join_key(path, "between");
        let field = join_key(path, &kind);
        if let Some(span) = self.spans.values.remove(&between) {
            self.spans.values.insert(field.clone(), span);
        }
        if let Some(span) = self.spans.keys.remove(&between) {
            self.spans.keys.insert(field, span);
        }
        for (k, _) in map.entries_mut() {
            if k.as_str() == Some("between") {
                *k = Value::String(kind.clone());
            }
        }
        Value::Mapping(map)
    }

    fn constraint(&mut self, item: &Node, path: &str) -> Value {
        self.spans
            .values
            .insert(path.to_string(), item.to_token_stream());
        let kind = item.name();
        let field = join_key(path, &kind);
        self.spans
            .keys
            .insert(field.clone(), item.key().to_token_stream());
        let body = match item {
            Node::Word(w) => {
                self.spans.values.insert(field, w.to_token_stream());
                Value::Null
            }
            Node::Value(_, e) => self.value(e, &field),
            Node::List(_, fields) => {
                self.spans
                    .values
                    .insert(field.clone(), item.to_token_stream());
                self.fields(fields, &field, None)
            }
        };
        Value::Mapping(std::iter::once((Value::String(kind), body)).collect())
    }

    /// An expression as a tree value at `path` (see the module docs).
    fn value(&mut self, e: &Expr, path: &str) -> Value {
        self.spans
            .values
            .insert(path.to_string(), e.to_token_stream());
        match e {
            Expr::Lit(l) => match &l.lit {
                syn::Lit::Str(s) => Value::String(s.value()),
                syn::Lit::Bool(b) => Value::Bool(b.value),
                syn::Lit::Int(i) if matches!(i.suffix(), "" | "f64") => {
                    number(i.base10_digits().to_string())
                }
                syn::Lit::Float(f) if matches!(f.suffix(), "" | "f64") => {
                    number(f.base10_digits().to_string())
                }
                _ => {
                    self.reported.push(path.to_string());
                    self.cx.error_spanned_by(
                        e,
                        "expected a number, a string, an expression like `pi/2`, a parameter \
                         name, or a list `[...]`",
                    );
                    Value::Null
                }
            },
            Expr::Unary(u) if matches!(u.op, syn::UnOp::Neg(_)) => match &*u.expr {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Int(i),
                    ..
                }) if i.suffix().is_empty() => number(format!("-{}", i.base10_digits())),
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Float(f),
                    ..
                }) if f.suffix().is_empty() => number(format!("-{}", f.base10_digits())),
                _ => Value::String(tokens(e)),
            },
            Expr::Path(p) if p.qself.is_none() && p.path.get_ident().is_some() => Value::String(
                p.path
                    .get_ident()
                    .map(|i| {
                        use syn::ext::IdentExt;
                        i.unraw().to_string()
                    })
                    .unwrap_or_default(),
            ),
            Expr::Array(a) => Value::Sequence(
                a.elems
                    .iter()
                    .enumerate()
                    .map(|(i, x)| self.value(x, &join_index(path, i)))
                    .collect(),
            ),
            Expr::Binary(_) | Expr::Paren(_) | Expr::Group(_) | Expr::Unary(_) => {
                Value::String(tokens(e))
            }
            _ => {
                self.reported.push(path.to_string());
                self.cx.error_spanned_by(
                    e,
                    "expected a number, a string, an expression like `pi/2`, a parameter name, \
                     or a list `[...]`",
                );
                Value::Null
            }
        }
    }
}

/// A place at one span.
fn at(span: Span) -> Place {
    quote::quote_spanned!(span=> _)
}

/// A literal's digits as a number, or (not a core-schema number) as a string.
fn number(text: String) -> Value {
    Number::parse(&text).map_or(Value::String(text), Value::Number)
}

/// The tokens of an expression as text (`- pi / 2`), for the walker's expression parser.
fn tokens(e: &Expr) -> String {
    e.to_token_stream().to_string()
}

/// The message for a top-level key that is not an inline key, in inline terms.
pub fn unknown_top(key: &str) -> String {
    let hint = suggest(key, TOP)
        .map(|s| format!("did you mean `{s}`? "))
        .unwrap_or_default();
    let allowed: Vec<String> = TOP.iter().map(|k| format!("`{k}`")).collect();
    format!(
        "unknown key `{key}` in `#[calib(...)]`: {hint}expected one of {}",
        allowed.join(", ")
    )
}
