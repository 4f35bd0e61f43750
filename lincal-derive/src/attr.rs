//! The syntax of `#[calib(...)]`: a tree of `key`, `key = value` and `key(...)` items.
//!
//! This module only reads tokens. The top-level keys that decide where the model comes from
//! (`spec`, `yaml`, `crate`) are taken out here; what the inline items mean is
//! [`crate::lower`]'s business.

use proc_macro2::{Span, TokenStream};
use quote::ToTokens;
use syn::ext::IdentExt;
use syn::parse::{Parse, ParseStream};
use syn::punctuated::Punctuated;
use syn::{Attribute, Expr, Ident, LitStr, Token};

use crate::ctxt::Ctxt;

/// One item of an attribute list.
#[derive(Clone)]
pub enum Node {
    /// `key`, e.g. `known`, `revolute`, `measured`.
    Word(Ident),
    /// `key = value`, e.g. `dim = 2`, `a = a1`, `alpha = -pi/2`, `b = [b1, b2]`.
    Value(Ident, Expr),
    /// `key(items)`, e.g. `joint(revolute, a = a1)`.
    List(Ident, Vec<Node>),
}

impl Node {
    /// The key.
    pub fn key(&self) -> &Ident {
        match self {
            Node::Word(k) | Node::Value(k, _) | Node::List(k, _) => k,
        }
    }

    /// The key as a string (`r#type` as `type`).
    pub fn name(&self) -> String {
        self.key().unraw().to_string()
    }
}

impl ToTokens for Node {
    fn to_tokens(&self, tokens: &mut TokenStream) {
        match self {
            Node::Word(k) => k.to_tokens(tokens),
            Node::Value(k, v) => {
                k.to_tokens(tokens);
                <Token![=]>::default().to_tokens(tokens);
                v.to_tokens(tokens);
            }
            Node::List(k, items) => {
                k.to_tokens(tokens);
                let inner: Punctuated<&Node, Token![,]> = items.iter().collect();
                syn::token::Paren(k.span()).surround(tokens, |t| inner.to_tokens(t));
            }
        }
    }
}

impl Parse for Node {
    fn parse(input: ParseStream<'_>) -> syn::Result<Self> {
        // Keys may be keywords (`crate`, `type`).
        let key = Ident::parse_any(input)?;
        if input.peek(Token![=]) {
            input.parse::<Token![=]>()?;
            let value: Expr = input.parse()?;
            Ok(Node::Value(key, value))
        } else if input.peek(syn::token::Paren) {
            let content;
            syn::parenthesized!(content in input);
            let items = Punctuated::<Node, Token![,]>::parse_terminated(&content)?;
            Ok(Node::List(key, items.into_iter().collect()))
        } else {
            Ok(Node::Word(key))
        }
    }
}

/// The container attributes, split by role.
pub struct Attrs {
    /// `crate = "path"`: where the runtime is (default `::lincal_core`).
    pub krate: Option<syn::Path>,
    /// `spec = "file.yaml"`, relative to `CARGO_MANIFEST_DIR`.
    pub spec: Option<LitStr>,
    /// `yaml = "..."`: the spec's YAML text inline.
    pub yaml: Option<LitStr>,
    /// Every other item: the inline spec.
    pub inline: Vec<Node>,
    /// The first `#[calib]` attribute, for errors about the whole spec.
    pub first: Option<Attribute>,
}

fn lit_str(node: &Node, cx: &Ctxt) -> Option<LitStr> {
    match node {
        Node::Value(
            _,
            Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            }),
        ) => Some(s.clone()),
        _ => {
            cx.error_spanned_by(
                node,
                format!("expected `{} = \"...\"` (a string)", node.name()),
            );
            None
        }
    }
}

fn set_once<T>(slot: &mut Option<T>, value: Option<T>, node: &Node, cx: &Ctxt) {
    if slot.is_some() {
        cx.error_spanned_by(
            node.key(),
            format!("`{}` is given more than once", node.name()),
        );
    } else {
        *slot = value;
    }
}

/// Reads every `#[calib(...)]` attribute; syntax errors go to `cx`.
pub fn read(attrs: &[Attribute], cx: &Ctxt) -> Attrs {
    let mut out = Attrs {
        krate: None,
        spec: None,
        yaml: None,
        inline: Vec::new(),
        first: None,
    };
    for attr in attrs.iter().filter(|a| a.path().is_ident("calib")) {
        if out.first.is_none() {
            out.first = Some(attr.clone());
        }
        let items = match attr.parse_args_with(Punctuated::<Node, Token![,]>::parse_terminated) {
            Ok(items) => items,
            Err(e) => {
                cx.syn_error(e);
                continue;
            }
        };
        for node in items {
            match node.name().as_str() {
                "crate" => {
                    let path = lit_str(&node, cx).and_then(|s| match s.parse::<syn::Path>() {
                        Ok(p) => Some(p),
                        Err(_) => {
                            cx.error_spanned_by(
                                &s,
                                format!("`{}` is not a path: expected e.g. `crate = \"::lincal::core\"`", s.value()),
                            );
                            None
                        }
                    });
                    set_once(&mut out.krate, path, &node, cx);
                }
                "spec" => {
                    let s = lit_str(&node, cx);
                    set_once(&mut out.spec, s, &node, cx);
                }
                "yaml" => {
                    let s = lit_str(&node, cx);
                    set_once(&mut out.yaml, s, &node, cx);
                }
                _ => out.inline.push(node),
            }
        }
    }
    out
}

/// The span of the first `#[calib]` attribute, or the call site.
pub fn attr_span(attrs: &Attrs) -> Span {
    attrs.first.as_ref().map_or_else(Span::call_site, |a| {
        a.path()
            .get_ident()
            .map_or_else(Span::call_site, Ident::span)
    })
}
