//! From the attributes to the core's [`Spec`], validated by the core, then to the core's
//! [`ModelProgram`]: the derive does no mathematics itself.
//!
//! - `spec = "file.yaml"`: the file (relative to `CARGO_MANIFEST_DIR`) goes through
//!   [`lincal_core::spec::from_yaml_str`]; each located problem becomes an error on the string,
//!   naming the file, line and field.
//! - `yaml = "..."`: the same, for text in the attribute.
//! - inline items: read here into a `Spec` (remembering the span of every field path), then
//!   checked by [`lincal_core::spec::validate::check`]; each problem points at the token of
//!   the field it names.

use std::collections::HashMap;
use std::path::PathBuf;

use lincal_core::error::{Diagnostic, Location};
use lincal_core::spec::validate::{self, Locate};
use lincal_core::spec::{
    Base, Constraint, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot, Spec,
};
use lincal_core::symbolic::program::ModelProgram;
use lincal_core::symbolic::SymbolicModel;
use proc_macro2::Span;
use quote::ToTokens;
use syn::spanned::Spanned;
use syn::{Expr, LitStr};

use crate::ast::Container;
use crate::attr::{attr_span, Node};
use crate::ctxt::Ctxt;

/// Environment variable that, when set, replaces `CARGO_MANIFEST_DIR` as the base of
/// `spec = "..."` paths. A testing hook: trybuild compiles test cases in a crate of its own.
pub const MANIFEST_DIR_OVERRIDE: &str = "LINCAL_DERIVE_MANIFEST_DIR";

/// The model, ready to print.
pub struct Lowered {
    /// Every program and constant.
    pub program: ModelProgram,
    /// Absolute path of the spec file, for `include_str!` (rebuild on edit).
    pub include: Option<String>,
}

/// Lowers the container's attributes to a model; every problem goes to `cx`.
pub fn lower(c: &Container, cx: &Ctxt) -> Option<Lowered> {
    let attrs = &c.attrs;
    attrs.first.as_ref()?;
    if let (Some(_), Some(y)) = (&attrs.spec, &attrs.yaml) {
        cx.error_spanned_by(
            y,
            "give either `spec = \"file.yaml\"` or `yaml = \"...\"`, not both",
        );
        return None;
    }
    if attrs.spec.is_some() || attrs.yaml.is_some() {
        let which = if attrs.spec.is_some() { "spec" } else { "yaml" };
        for node in &attrs.inline {
            cx.error_spanned_by(
                node.key(),
                format!(
                    "`{}` cannot be combined with `{which} = ...`: the YAML gives the whole model \
                     (inline keys are for a spec written in the attribute)",
                    node.name()
                ),
            );
        }
        if !attrs.inline.is_empty() {
            return None;
        }
    }
    let (spec, include) = if let Some(lit) = &attrs.spec {
        let (spec, path) = from_file(lit, cx)?;
        (spec, Some(path))
    } else if let Some(lit) = &attrs.yaml {
        (from_yaml_lit(lit, cx)?, None)
    } else {
        (from_inline(c, cx)?, None)
    };
    let program = match SymbolicModel::from_spec(&spec).and_then(|m| ModelProgram::from_model(&m)) {
        Ok(p) => p,
        Err(e) => {
            for d in e.diagnostics() {
                cx.error_at(attr_span(attrs), format!("the model cannot be built: {d}"));
            }
            return None;
        }
    };
    Some(Lowered { program, include })
}

fn from_file(lit: &LitStr, cx: &Ctxt) -> Option<(Spec, String)> {
    let rel = lit.value();
    let base = std::env::var_os(MANIFEST_DIR_OVERRIDE)
        .or_else(|| std::env::var_os("CARGO_MANIFEST_DIR"))
        .map(PathBuf::from)
        .unwrap_or_default();
    let path = base.join(&rel);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            cx.error_spanned_by(
                lit,
                format!(
                    "cannot read the spec file `{rel}`: {e} (the path is relative to the \
                     directory of the crate's Cargo.toml)"
                ),
            );
            return None;
        }
    };
    let Some(abs) = path.to_str().map(str::to_string) else {
        cx.error_spanned_by(lit, format!("the path of `{rel}` is not valid UTF-8"));
        return None;
    };
    match lincal_core::spec::from_yaml_str(&text, Some(&rel)) {
        Ok(spec) => Some((spec, abs)),
        Err(e) => {
            for d in e.diagnostics() {
                cx.error_spanned_by(lit, d);
            }
            None
        }
    }
}

fn from_yaml_lit(lit: &LitStr, cx: &Ctxt) -> Option<Spec> {
    match lincal_core::spec::from_yaml_str(&lit.value(), None) {
        Ok(spec) => Some(spec),
        Err(e) => {
            for d in e.diagnostics() {
                cx.error_spanned_by(lit, format!("in the `yaml` text, line {d}"));
            }
            None
        }
    }
}

/// `CamelCase` → `camel_case`.
fn snake_case(name: &str) -> String {
    let mut out = String::new();
    let chars: Vec<char> = name.chars().collect();
    for (i, &ch) in chars.iter().enumerate() {
        if ch.is_uppercase() {
            let prev_lower =
                i > 0 && (chars[i - 1].is_lowercase() || chars[i - 1].is_ascii_digit());
            let next_lower = chars.get(i + 1).is_some_and(|c| c.is_lowercase());
            if i > 0 && (prev_lower || (next_lower && chars[i - 1].is_uppercase())) {
                out.push('_');
            }
            out.extend(ch.to_lowercase());
        } else {
            out.push(ch);
        }
    }
    out
}

/// Field path → span of the token that gave it.
#[derive(Default)]
struct Spans {
    map: HashMap<String, Span>,
}

impl Spans {
    fn set(&mut self, field: impl Into<String>, span: Span) {
        self.map.insert(field.into(), span);
    }

    /// The span of `field`, or of its nearest ancestor; whether it was exact.
    fn find(&self, field: &str) -> Option<(Span, bool)> {
        let mut f = field;
        let mut exact = true;
        loop {
            if let Some(s) = self.map.get(f) {
                return Some((*s, exact));
            }
            exact = false;
            let cut = f.rfind(['.', '['])?;
            f = &f[..cut];
        }
    }
}

/// The [`Locate`] of an inline spec: locations carry the field path only; spans are looked up
/// afterwards.
struct Fields;

impl Locate for Fields {
    fn value(&self, field: &str) -> Location {
        Location {
            field: Some(field.to_string()),
            ..Location::default()
        }
    }
}

const TOP: &[&str] = &[
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
    "spec",
    "yaml",
    "crate",
];
const JOINT: &[&str] = &["a", "alpha", "d", "home", "theta", "offset", "limits"];
const BASE: &[&str] = &["x", "y", "z", "roll", "pitch", "yaw"];
const KINDS: &[&str] = &[
    "point", "line", "plane", "circle", "sphere", "quadric", "measured",
];

fn one_of(list: &[&str]) -> String {
    let v: Vec<String> = list.iter().map(|k| format!("`{k}`")).collect();
    v.join(", ")
}

/// Closest allowed key to a typo.
fn suggest<'a>(key: &str, allowed: &[&'a str]) -> Option<&'a str> {
    fn dist(a: &str, b: &str) -> usize {
        let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
        let mut prev: Vec<usize> = (0..=b.len()).collect();
        for i in 1..=a.len() {
            let mut cur = vec![i; b.len() + 1];
            for j in 1..=b.len() {
                let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
                cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
            }
            prev = cur;
        }
        prev[b.len()]
    }
    allowed
        .iter()
        .map(|a| (dist(key, a), *a))
        .filter(|(d, a)| *d <= 2 && *d < a.len())
        .min_by_key(|(d, _)| *d)
        .map(|(_, a)| a)
}

fn unknown_key(node: &Node, what: &str, allowed: &[&str], cx: &Ctxt) {
    let key = node.name();
    let hint = match suggest(&key, allowed) {
        Some(s) => format!(" (did you mean `{s}`?)"),
        None => String::new(),
    };
    cx.error_spanned_by(
        node.key(),
        format!(
            "unknown key `{key}` in {what}{hint}: expected one of {}",
            one_of(allowed)
        ),
    );
}

fn is_param_name(s: &str) -> bool {
    let mut ch = s.chars();
    matches!(ch.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && ch.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !s.eq_ignore_ascii_case("pi")
}

const SLOT_HELP: &str = "expected a number, an expression like `pi/2`, or a parameter name";

/// Renders a numeric expression for [`Exact::parse`].
fn expr_text(e: &Expr, out: &mut String) -> syn::Result<()> {
    match e {
        Expr::Lit(l) => match &l.lit {
            syn::Lit::Int(i) if matches!(i.suffix(), "" | "f64") => out.push_str(i.base10_digits()),
            syn::Lit::Float(f) if matches!(f.suffix(), "" | "f64") => {
                out.push_str(f.base10_digits());
            }
            _ => {
                return Err(syn::Error::new_spanned(
                    e,
                    format!("not a number: {SLOT_HELP}"),
                ))
            }
        },
        Expr::Path(p) if p.qself.is_none() && p.path.get_ident().is_some() => {
            let id = p.path.segments[0].ident.to_string();
            if id.eq_ignore_ascii_case("pi") {
                out.push_str("pi");
            } else {
                return Err(syn::Error::new_spanned(
                    e,
                    format!(
                        "`{id}` inside an expression: only `pi` may appear in an expression; a \
                         parameter is used alone"
                    ),
                ));
            }
        }
        Expr::Unary(u) if matches!(u.op, syn::UnOp::Neg(_)) => {
            out.push_str("-(");
            expr_text(&u.expr, out)?;
            out.push(')');
        }
        Expr::Binary(b) => {
            let op = match b.op {
                syn::BinOp::Add(_) => "+",
                syn::BinOp::Sub(_) => "-",
                syn::BinOp::Mul(_) => "*",
                syn::BinOp::Div(_) => "/",
                _ => {
                    return Err(syn::Error::new_spanned(
                        b.op,
                        "only `+ - * /` may appear in an expression",
                    ))
                }
            };
            out.push('(');
            expr_text(&b.left, out)?;
            out.push_str(op);
            expr_text(&b.right, out)?;
            out.push(')');
        }
        Expr::Paren(p) => expr_text(&p.expr, out)?,
        Expr::Group(g) => expr_text(&g.expr, out)?,
        _ => return Err(syn::Error::new_spanned(e, SLOT_HELP)),
    }
    Ok(())
}

/// An exact number from an expression (`0.375`, `-pi/2`, `"2*pi/3"`).
fn exact(e: &Expr, cx: &Ctxt) -> Option<Exact> {
    let text = match e {
        Expr::Lit(syn::ExprLit {
            lit: syn::Lit::Str(s),
            ..
        }) => s.value(),
        _ => {
            let mut t = String::new();
            if let Err(err) = expr_text(e, &mut t) {
                cx.syn_error(err);
                return None;
            }
            t
        }
    };
    match Exact::parse(&text) {
        Ok(x) => Some(x),
        Err(msg) => {
            cx.error_spanned_by(e, format!("not a valid number: {msg}"));
            None
        }
    }
}

/// A slot: a parameter name (bare or quoted), or an exact number.
fn slot(e: &Expr, cx: &Ctxt) -> Option<Slot> {
    match e {
        Expr::Path(p) if p.qself.is_none() && p.path.get_ident().is_some() => {
            let id = p.path.segments[0].ident.to_string();
            if is_param_name(&id) {
                return Some(Slot::Param(id));
            }
        }
        Expr::Lit(syn::ExprLit {
            lit: syn::Lit::Str(s),
            ..
        }) if is_param_name(s.value().trim()) => return Some(Slot::Param(s.value().trim().into())),
        _ => {}
    }
    exact(e, cx).map(Slot::Const)
}

/// `[a, b, ...]` as its elements.
fn array<'e>(e: &'e Expr, what: &str, cx: &Ctxt) -> Option<Vec<&'e Expr>> {
    match e {
        Expr::Array(a) => Some(a.elems.iter().collect()),
        _ => {
            cx.error_spanned_by(e, format!("expected a list `[...]` for {what}"));
            None
        }
    }
}

/// The inline spec reader.
struct Reader<'a> {
    cx: &'a Ctxt,
    spans: Spans,
    /// Field paths already reported here: the validator's problems there are not repeated.
    reported: Vec<String>,
    /// A slot could not be read: "parameter never used" may be a consequence.
    bad_slot: bool,
}

impl Reader<'_> {
    fn slot(&mut self, e: &Expr, field: &str) -> Slot {
        self.spans.set(field, e.span());
        match slot(e, self.cx) {
            Some(s) => s,
            None => {
                self.bad_slot = true;
                self.reported.push(field.to_string());
                Slot::zero()
            }
        }
    }

    fn slots(&mut self, e: &Expr, field: &str) -> Vec<Slot> {
        self.spans.set(field, e.span());
        let Some(elems) = array(e, &format!("`{field}`"), self.cx) else {
            self.reported.push(field.to_string());
            self.bad_slot = true;
            return Vec::new();
        };
        elems
            .iter()
            .enumerate()
            .map(|(i, x)| self.slot(x, &format!("{field}[{i}]")))
            .collect()
    }

    fn fixed<const N: usize>(&mut self, e: &Expr, field: &str, dims: &str) -> [Slot; N] {
        let v = self.slots(e, field);
        if v.len() != N && !self.reported.iter().any(|r| r == field) {
            self.cx.error_spanned_by(
                e,
                format!(
                    "`{field}` must have {N} entries ({dims}), found {}",
                    v.len()
                ),
            );
            self.reported.push(field.to_string());
        }
        let mut out: [Slot; N] = std::array::from_fn(|_| Slot::zero());
        for (o, s) in out.iter_mut().zip(v) {
            *o = s;
        }
        out
    }

    fn value<'n>(&self, node: &'n Node) -> Option<&'n Expr> {
        match node {
            Node::Value(_, e) => Some(e),
            _ => {
                self.cx
                    .error_spanned_by(node, format!("expected `{} = ...`", node.name()));
                None
            }
        }
    }

    fn list<'n>(&self, node: &'n Node, example: &str) -> Option<&'n [Node]> {
        match node {
            Node::List(_, items) => Some(items),
            _ => {
                self.cx.error_spanned_by(
                    node,
                    format!("expected `{}(...)`, e.g. `{example}`", node.name()),
                );
                None
            }
        }
    }

    fn usize_value(&self, node: &Node) -> Option<usize> {
        let e = self.value(node)?;
        match e {
            Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Int(i),
                ..
            }) => match i.base10_parse::<usize>() {
                Ok(v) => Some(v),
                Err(err) => {
                    self.cx.syn_error(err);
                    None
                }
            },
            _ => {
                self.cx
                    .error_spanned_by(e, format!("`{}` must be an integer", node.name()));
                None
            }
        }
    }

    fn string_value(&self, node: &Node) -> Option<String> {
        match self.value(node)? {
            Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            }) => Some(s.value()),
            e => {
                self.cx
                    .error_spanned_by(e, format!("`{}` must be a string `\"...\"`", node.name()));
                None
            }
        }
    }

    fn joint(&mut self, node: &Node, i: usize) -> Option<Joint> {
        let items = self.list(node, "joint(revolute, a = a1, home = th1)")?;
        let f = |s: &str| format!("joints[{i}].{s}");
        self.spans.set(format!("joints[{i}]"), node.span());
        let kind = match items.first() {
            Some(Node::Word(w)) if w == "revolute" => JointKind::Revolute,
            Some(Node::Word(w)) if w == "prismatic" => JointKind::Prismatic,
            other => {
                let tokens =
                    other.map_or_else(|| node.to_token_stream(), ToTokens::to_token_stream);
                self.cx.error_spanned_by(
                    tokens,
                    "a joint starts with its type: `joint(revolute, ...)` or \
                     `joint(prismatic, ...)`",
                );
                self.reported.push(format!("joints[{i}]"));
                self.bad_slot = true;
                return None;
            }
        };
        let mut j = Joint {
            kind,
            a: Slot::zero(),
            alpha: Slot::zero(),
            d: Slot::zero(),
            home: Slot::zero(),
            theta: Slot::zero(),
            offset: Slot::zero(),
            limits: None,
        };
        let mut seen: Vec<String> = Vec::new();
        for item in &items[1..] {
            let key = item.name();
            if !JOINT.contains(&key.as_str()) {
                unknown_key(item, "a joint", JOINT, self.cx);
                continue;
            }
            if seen.contains(&key) {
                self.cx
                    .error_spanned_by(item.key(), format!("`{key}` is given twice in this joint"));
                continue;
            }
            seen.push(key.clone());
            let Some(e) = self.value(item) else { continue };
            let field = f(&key);
            match key.as_str() {
                "limits" => {
                    self.spans.set(field.clone(), e.span());
                    let v = array(e, "`limits`", self.cx).and_then(|v| {
                        if v.len() == 2 {
                            Some([
                                exact(v[0], self.cx)?.to_f64(),
                                exact(v[1], self.cx)?.to_f64(),
                            ])
                        } else {
                            self.cx.error_spanned_by(e, "`limits` must be `[min, max]`");
                            None
                        }
                    });
                    j.limits = v;
                }
                slot => {
                    let s = self.slot(e, &field);
                    if let Some(dst) = j.slot_mut(slot) {
                        *dst = s;
                    }
                }
            }
        }
        Some(j)
    }

    fn base(&mut self, node: &Node) -> Option<Base> {
        let items = self.list(node, "base(x = 0.1, yaw = pi/2)")?;
        self.spans.set("base", node.span());
        let mut b = Base::zero();
        for item in items {
            let key = item.name();
            if !BASE.contains(&key.as_str()) {
                unknown_key(item, "`base`", BASE, self.cx);
                continue;
            }
            let Some(e) = self.value(item) else { continue };
            let s = self.slot(e, &format!("base.{key}"));
            if let Some(dst) = b.slot_mut(&key) {
                *dst = s;
            }
        }
        Some(b)
    }

    /// `name = nominal` entries (and `known` words when `allow_known`).
    fn params(&mut self, node: &Node, known: bool, out: &mut Vec<Param>) {
        let Some(items) = self.list(node, "param(a1 = 0.375)") else {
            return;
        };
        let single = node.name() == "param";
        let mut is_known = known;
        if single {
            let words: Vec<&Node> = items
                .iter()
                .filter(|n| matches!(n, Node::Word(_)))
                .collect();
            for w in &words {
                if w.name() == "known" {
                    is_known = true;
                } else {
                    self.cx.error_spanned_by(
                        w,
                        format!("unknown flag `{}`: a parameter is `param(name = nominal)` or `param(name = nominal, known)`", w.name()),
                    );
                }
            }
            let values = items.iter().filter(|n| !matches!(n, Node::Word(_))).count();
            if values != 1 {
                self.cx.error_spanned_by(
                    node,
                    "`param(...)` declares one parameter: `param(a1 = 0.375)` or \
                     `param(r = 0.15, known)`; use `params(a = .., b = ..)` for several",
                );
            }
        }
        for item in items {
            if single && matches!(item, Node::Word(_)) {
                continue;
            }
            let name = item.key().unraw_string();
            let Some(e) = (match item {
                Node::Value(_, e) => Some(e),
                _ => {
                    self.cx.error_spanned_by(
                        item,
                        format!(
                            "expected `{name} = nominal` (a number or an expression like `pi/2`)"
                        ),
                    );
                    None
                }
            }) else {
                continue;
            };
            let field = format!("params.{name}");
            self.spans.set(field.clone(), item.key().span());
            self.spans.set(format!("{field}.nominal"), e.span());
            let nominal = match e {
                Expr::Path(p) if p.path.get_ident().is_some_and(|i| i != "pi" && i != "PI") => {
                    self.cx.error_spanned_by(
                        e,
                        format!("the nominal value of `{name}` must be a number or an expression like `pi/2`, not a name"),
                    );
                    Exact::zero()
                }
                _ => exact(e, self.cx).unwrap_or_else(Exact::zero),
            };
            out.push(Param {
                name,
                nominal,
                known: is_known,
                role: ParamRole::Length,
            });
        }
    }

    fn constraint(&mut self, node: &Node, prefix: &str) -> Option<Constraint> {
        let kind = node.name();
        let base = format!("{prefix}.{kind}");
        self.spans.set(base.clone(), node.key().span());
        if !KINDS.contains(&kind.as_str()) {
            unknown_key(node, "the constraint kinds", KINDS, self.cx);
            self.reported.push(prefix.to_string());
            self.bad_slot = true;
            return None;
        }
        if kind == "measured" {
            if !matches!(node, Node::Word(_)) {
                self.cx.error_spanned_by(
                    node,
                    "`measured` has no fields: write `constraint(measured)`",
                );
            }
            return Some(Constraint::Measured);
        }
        let example = match kind.as_str() {
            "point" => "point(p = [px, py])",
            "line" => "line(b = [b1, b2])",
            "plane" => "plane(b = [b1, b2, b3])",
            "circle" => "circle(center = [cx, cy], radius = r)",
            "sphere" => "sphere(center = [cx, cy, cz], radius = r)",
            _ => "quadric(A = [[a11, a12], [a12, a22]], b = [b1, b2])",
        };
        let Some(items) = self.list(node, example) else {
            self.reported.push(prefix.to_string());
            self.bad_slot = true;
            return None;
        };
        let allowed: &[&str] = match kind.as_str() {
            "point" => &["p"],
            "line" => &["b", "planes"],
            "plane" => &["b"],
            "circle" | "sphere" => &["center", "radius"],
            _ => &["A", "b"],
        };
        let mut fields: HashMap<String, &Expr> = HashMap::new();
        for item in items {
            let key = item.name();
            if !allowed.contains(&key.as_str()) {
                unknown_key(item, &format!("`{kind}`"), allowed, self.cx);
                self.bad_slot = true;
                continue;
            }
            if let Some(e) = self.value(item) {
                self.spans.set(format!("{base}.{key}"), e.span());
                fields.insert(key, e);
            }
        }
        let need = |k: &str, me: &mut Self| -> Option<&Expr> {
            let got = fields.get(k).copied();
            if got.is_none() {
                me.cx.error_spanned_by(
                    node,
                    format!("`{kind}` needs `{k} = ...`, e.g. `{example}`"),
                );
                me.reported.push(prefix.to_string());
                me.bad_slot = true;
            }
            got
        };
        let f = |k: &str| format!("{base}.{k}");
        Some(match kind.as_str() {
            "point" => {
                let e = need("p", self)?;
                Constraint::Point {
                    p: self.slots(e, &f("p")),
                }
            }
            "line" if fields.contains_key("planes") => {
                let e = fields["planes"];
                let rows = array(e, "`planes`", self.cx)?;
                if rows.len() != 2 {
                    self.cx
                        .error_spanned_by(e, "`planes` must hold two planes `[[..3], [..3]]`");
                    self.reported.push(prefix.to_string());
                    return None;
                }
                let p0 = self.fixed::<3>(rows[0], &format!("{}[0]", f("planes")), "a plane in 3-D");
                let p1 = self.fixed::<3>(rows[1], &format!("{}[1]", f("planes")), "a plane in 3-D");
                Constraint::Line3 { planes: [p0, p1] }
            }
            "line" => {
                let e = need("b", self)?;
                Constraint::Line2 {
                    b: self.fixed::<2>(e, &f("b"), "a line in dim 2"),
                }
            }
            "plane" => {
                let e = need("b", self)?;
                Constraint::Plane {
                    b: self.fixed::<3>(e, &f("b"), "a plane in dim 3"),
                }
            }
            "circle" => {
                let (ce, re) = (need("center", self), need("radius", self));
                let center = self.fixed::<2>(ce?, &f("center"), "a circle in dim 2");
                let radius = self.slot(re?, &f("radius"));
                Constraint::Circle { center, radius }
            }
            "sphere" => {
                let (ce, re) = (need("center", self), need("radius", self));
                let center = self.fixed::<3>(ce?, &f("center"), "a sphere in dim 3");
                let radius = self.slot(re?, &f("radius"));
                Constraint::Sphere { center, radius }
            }
            _ => {
                let (ae, be) = (need("A", self), need("b", self));
                let (ae, be) = (ae?, be?);
                let rows = array(ae, "`A`", self.cx)?;
                let mut a = Vec::new();
                for (r, row) in rows.iter().enumerate() {
                    a.push(self.slots(row, &format!("{}[{r}]", f("A"))));
                }
                let b = self.slots(be, &f("b"));
                Constraint::Quadric { a, b }
            }
        })
    }
}

trait UnrawString {
    fn unraw_string(&self) -> String;
}

impl UnrawString for syn::Ident {
    fn unraw_string(&self) -> String {
        use syn::ext::IdentExt;
        self.unraw().to_string()
    }
}

fn from_inline(c: &Container, cx: &Ctxt) -> Option<Spec> {
    let attrs = &c.attrs;
    let whole = attr_span(attrs);
    if attrs.inline.is_empty() {
        cx.error_at(
            whole,
            "the `#[calib(...)]` attribute gives no model: write `spec = \"specs/robot.yaml\"`, \
             or the spec inline (`dim = 2, joint(revolute, a = a1, home = th1), \
             param(a1 = 0.4), ..., constraint(line(b = [b1, b2]))`)",
        );
        return None;
    }
    let mut r = Reader {
        cx,
        spans: Spans::default(),
        reported: Vec::new(),
        bad_slot: false,
    };
    let mut name: Option<String> = None;
    let mut description = None;
    let mut dim: Option<usize> = None;
    let mut convention = None;
    let mut joints = Vec::new();
    let mut tool: Option<Vec<Slot>> = None;
    let mut base = None;
    let mut params = Vec::new();
    let mut constraints = Vec::new();
    let mut single: Option<&Node> = None;
    let mut list: Option<&Node> = None;
    let mut seen: Vec<String> = Vec::new();
    // Keys a typo probably meant: no "missing ..." error for them.
    let mut typos: Vec<&str> = Vec::new();
    for node in &attrs.inline {
        let key = node.name();
        let repeatable = matches!(key.as_str(), "joint" | "param" | "params" | "known");
        if !TOP.contains(&key.as_str()) {
            unknown_key(node, "`#[calib(...)]`", TOP, cx);
            typos.extend(suggest(&key, TOP));
            continue;
        }
        if !repeatable {
            if seen.contains(&key) {
                cx.error_spanned_by(node.key(), format!("`{key}` is given more than once"));
                continue;
            }
            seen.push(key.clone());
        }
        match key.as_str() {
            "name" => {
                r.spans.set("name", node.span());
                name = r.string_value(node);
            }
            "description" => description = r.string_value(node),
            "dim" => {
                r.spans.set("dim", node.span());
                dim = r.usize_value(node);
                if dim.is_none() {
                    r.reported.push("dim".into());
                }
            }
            "convention" => {
                if let Some(e) = r.value(node) {
                    let text = match e {
                        Expr::Path(p) => p.path.get_ident().map(ToString::to_string),
                        Expr::Lit(syn::ExprLit {
                            lit: syn::Lit::Str(s),
                            ..
                        }) => Some(s.value()),
                        _ => None,
                    };
                    convention = match text.as_deref() {
                        Some("dh") => Some(Convention::Dh),
                        Some("mdh") => Some(Convention::Mdh),
                        _ => {
                            cx.error_spanned_by(
                                e,
                                "`convention` is `dh` (standard Denavit-Hartenberg, the default) \
                                 or `mdh` (modified, Craig)",
                            );
                            None
                        }
                    };
                }
            }
            "joint" => {
                let i = joints.len();
                if let Some(j) = r.joint(node, i) {
                    joints.push(j);
                }
            }
            "tool" => {
                if let Some(e) = r.value(node) {
                    tool = Some(r.slots(e, "tool"));
                }
            }
            "base" => base = r.base(node),
            "param" | "params" => r.params(node, false, &mut params),
            "known" => r.params(node, true, &mut params),
            "constraint" => single = Some(node),
            "constraints" => list = Some(node),
            // `spec`, `yaml`, `crate` were taken out by `attr::read`.
            _ => {}
        }
    }
    if joints.is_empty() && !r.reported.iter().any(|f| f.starts_with("joints")) {
        r.spans.set("joints", whole);
    }
    let constraint_list = list.is_some();
    match (single, list) {
        (Some(_), Some(l)) => {
            cx.error_spanned_by(
                l.key(),
                "give either `constraint(...)` (one) or `constraints(...)` (a list), not both",
            );
            r.reported.push("constraints".into());
            r.reported.push("constraint".into());
        }
        (Some(node), None) => {
            r.spans.set("constraint", node.span());
            match node {
                Node::List(_, items) if items.len() == 1 => {
                    if let Some(c) = r.constraint(&items[0], "constraint") {
                        constraints.push(c);
                    }
                }
                _ => {
                    cx.error_spanned_by(
                        node,
                        "`constraint(...)` holds one constraint, e.g. `constraint(line(b = [b1, b2]))`; \
                         use `constraints(...)` for a list",
                    );
                    r.reported.push("constraint".into());
                    r.bad_slot = true;
                }
            }
        }
        (None, Some(node)) => {
            r.spans.set("constraints", node.span());
            if let Some(items) =
                r.list(node, "constraints(line(b = [b1, b2]), point(p = [px, py]))")
            {
                for (k, item) in items.iter().enumerate() {
                    if let Some(c) = r.constraint(item, &format!("constraints[{k}]")) {
                        constraints.push(c);
                    }
                }
            }
        }
        (None, None) if typos.iter().any(|t| t.starts_with("constraint")) => {
            r.reported.push("constraint".into());
        }
        (None, None) => {
            cx.error_at(
                whole,
                "no constraint: add `constraint(...)`, e.g. `constraint(line(b = [b1, b2]))`, \
                 `constraint(plane(b = [b1, b2, b3]))` or `constraint(measured)`",
            );
            r.reported.push("constraint".into());
        }
    }
    if dim.is_none() && !r.reported.iter().any(|f| f == "dim") && !typos.contains(&"dim") {
        cx.error_at(whole, "missing `dim = 2` (planar) or `dim = 3` (spatial)");
        r.reported.push("dim".into());
    }
    let d = dim.unwrap_or(2);
    let mut spec = Spec {
        name: name.unwrap_or_else(|| snake_case(&c.ident.to_string())),
        description,
        dim: d,
        convention: convention.unwrap_or(Convention::Dh),
        joints,
        tool: tool.unwrap_or_else(|| vec![Slot::zero(); d]),
        base,
        params,
        constraints,
        constraint_list,
    };
    // "Parameter never used" after another mistake is most likely its consequence.
    r.bad_slot |= cx.has_errors();
    let diags = validate::check(&mut spec, &Fields);
    report(&diags, &r, whole, cx);
    if cx.has_errors() {
        None
    } else {
        Some(spec)
    }
}

/// Reports the validator's problems at the tokens of their fields.
fn report(diags: &[Diagnostic], r: &Reader<'_>, whole: Span, cx: &Ctxt) {
    for d in diags {
        let field = d.location.field.clone().unwrap_or_default();
        let suppressed = r.reported.iter().any(|rep| {
            field == *rep
                || (field.starts_with(rep.as_str())
                    && matches!(field.as_bytes().get(rep.len()), Some(b'.' | b'[')))
        });
        if suppressed || (r.bad_slot && d.message.contains("never used")) {
            continue;
        }
        match r.spans.find(&field) {
            Some((span, true)) => cx.error_at(span, &d.message),
            Some((span, false)) => cx.error_at(span, format!("field `{field}`: {}", d.message)),
            None => cx.error_at(whole, format!("field `{field}`: {}", d.message)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::snake_case;

    #[test]
    fn snake_case_names() {
        assert_eq!(snake_case("AdeptOne"), "adept_one");
        assert_eq!(snake_case("Puma560Plane"), "puma560_plane");
        assert_eq!(snake_case("SCARALine"), "scara_line");
        assert_eq!(snake_case("planar2"), "planar2");
    }
}
