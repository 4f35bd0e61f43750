//! From the attributes to the core's [`Spec`], validated by the core, then to the core's
//! [`ModelProgram`]: the derive does no mathematics itself.
//!
//! - `spec = "file.yaml"`: the file (relative to `CARGO_MANIFEST_DIR`) goes through
//!   [`lincal_core::spec::from_yaml_str`]; each located problem becomes an error on the string,
//!   naming the file, line and field.
//! - `yaml = "..."`: the same, for text in the attribute.
//! - inline items: rewritten by [`crate::tree`] into the core's document tree (remembering the
//!   span of every field path) and walked by [`lincal_core::spec::from_tree`], the walker the
//!   YAML goes through; each problem points at the token of the field it names.

use std::path::PathBuf;

use lincal_core::program::ModelProgram;
use lincal_core::spec::{from_tree, Spec};
use lincal_core::symbolic::SymbolicModel;
use syn::LitStr;

use crate::ast::Container;
use crate::attr::attr_span;
use crate::ctxt::Ctxt;
use crate::tree::{unknown_top, Adapter, Placer};

/// Environment variable that, when set, replaces `CARGO_MANIFEST_DIR` as the base of
/// `spec = "..."` paths. A testing hook: trybuild compiles test cases in a crate of its own.
pub const MANIFEST_DIR_OVERRIDE: &str = "LINCAL_DERIVE_MANIFEST_DIR";

/// The model, ready to print.
pub struct Lowered {
    /// Every program and constant.
    pub program: ModelProgram,
    /// Absolute path of the spec file, for `include_str!` (rebuild on edit).
    pub include: Option<String>,
    /// A `measured_pose` spec stating both noise levels: the orientation weight
    /// `position_std / orientation_std` the run-time model gives (`None`: the trait's default).
    pub orientation_weight: Option<f64>,
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
    let built = SymbolicModel::from_spec(&spec)
        .and_then(|m| ModelProgram::from_model(&m).map(|p| (p, orientation_weight(&spec, &m))));
    let (program, orientation_weight) = match built {
        Ok(p) => p,
        Err(e) => {
            for d in e.diagnostics() {
                cx.error_at(attr_span(attrs), format!("the model cannot be built: {d}"));
            }
            return None;
        }
    };
    Some(Lowered {
        program,
        include,
        orientation_weight,
    })
}

/// The orientation weight to print: the run-time model's own value, when the spec states both
/// noise levels of a `measured_pose` (else the trait's default stands, and the calibration
/// estimates the ratio from the data).
fn orientation_weight(spec: &Spec, m: &SymbolicModel) -> Option<f64> {
    use lincal_core::model::CalibModel as _;
    matches!(spec.pose_noise(), Some((Some(_), Some(_)))).then(|| m.orientation_weight())
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

/// The inline items through the attribute adapter ([`crate::tree`]) and the core's one spec
/// walker; each problem at the token of the field it names.
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
    let mut adapter = Adapter::new(cx);
    let root = adapter.root(&attrs.inline, &snake_case(&c.ident.to_string()), whole);
    let placer = Placer::new(&adapter.spans, whole);
    match from_tree(&root, &placer) {
        Ok(spec) if !cx.has_errors() => Some(spec),
        Ok(_) => None,
        Err(e) => {
            for d in e.diagnostics() {
                let field = d.location.field.clone().unwrap_or_default();
                // A hole the adapter reported: the walker would only repeat it.
                let under = |r: &String| {
                    field == *r
                        || field
                            .strip_prefix(r.as_str())
                            .is_some_and(|rest| rest.starts_with('.') || rest.starts_with('['))
                };
                if adapter.reported.iter().any(under) {
                    continue;
                }
                let (place, exact) = placer.place_of(&d.location);
                if adapter.unknown.contains(&field) && d.message.starts_with("unknown field") {
                    cx.error_spanned_by(place, unknown_top(&field));
                } else if exact || field.is_empty() {
                    cx.error_spanned_by(place, &d.message);
                } else {
                    cx.error_spanned_by(place, format!("field `{field}`: {}", d.message));
                }
            }
            None
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
