//! Both fronts accept and reject exactly the same specs.
//!
//! Every spec of the repository (and of `../shared/cases`) is read by the YAML adapter into
//! its document tree, printed back as inline `#[calib(...)]` items, and read by the attribute
//! adapter ([`crate::tree`]). The two trees must give the same [`Spec`], or the same problems
//! (field and message), through the one walker. Then each spec is broken in a dozen ways
//! (in its tree, printed once as YAML and once inline) and the verdicts are compared again.

use std::path::{Path, PathBuf};

use lincal_core::error::Error;
use lincal_core::spec::node::{parse_tree, Mapping, Value};
use lincal_core::spec::validate::FieldsOnly;
use lincal_core::spec::{from_tree, from_yaml_str, Spec};
use syn::DeriveInput;

use crate::ast::Container;
use crate::ctxt::Ctxt;
use crate::tree::Adapter;

/// Every spec YAML of the repository: files with a top-level `joints:` key.
fn spec_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut dirs = vec![
        root.join("lincal-models/specs"),
        root.join("tests/specs"),
        root.join("tests/no-std/specs"),
        root.join("bench/specs"),
        root.join("src/cli/demo"),
    ];
    if let Ok(cases) = std::fs::read_dir(root.join("../shared/cases")) {
        dirs.extend(cases.flatten().map(|e| e.path()));
    }
    let mut out = Vec::new();
    for d in dirs {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            let is_yaml = p.extension().is_some_and(|x| x == "yaml");
            let text = std::fs::read_to_string(&p).unwrap_or_default();
            if is_yaml && text.lines().any(|l| l.starts_with("joints:")) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// A value as an attribute expression.
fn expr(v: &Value) -> String {
    match v {
        Value::Null => "_".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => n.to_string(),
        // A name or an expression as its tokens when they are an expression, else quoted.
        Value::String(s) => {
            if !s.is_empty() && syn::parse_str::<syn::Expr>(s).is_ok() && !s.contains('"') {
                s.clone()
            } else {
                format!("{s:?}")
            }
        }
        Value::Sequence(items) => format!(
            "[{}]",
            items.iter().map(expr).collect::<Vec<_>>().join(", ")
        ),
        Value::Mapping(_) | Value::Tagged(_) => "{}".into(),
    }
}

/// `key = value` items of a mapping.
fn items(m: &Mapping) -> Vec<String> {
    m.iter()
        .map(|(k, v)| {
            let k = k.as_str().unwrap_or("_");
            match v {
                Value::Mapping(inner) => format!("{k}({})", items(inner).join(", ")),
                Value::Null => k.to_string(),
                _ => format!("{k} = {}", expr(v)),
            }
        })
        .collect()
}

/// One constraint entry as an inline item.
fn constraint(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Mapping(m) => items(m).join(", "),
        other => expr(other),
    }
}

/// The inline attribute of a spec tree (the inverse of [`crate::tree`]).
fn inline(root: &Value) -> String {
    let Value::Mapping(m) = root else {
        return String::new();
    };
    let mut out = Vec::new();
    for (k, v) in m {
        let key = k.as_str().unwrap_or("_");
        match (key, v) {
            ("joints", Value::Sequence(js)) => {
                for j in js {
                    let Value::Mapping(jm) = j else {
                        out.push(format!("joint({})", expr(j)));
                        continue;
                    };
                    // The type as the leading bare word, the rest as `key = value`.
                    let mut parts = Vec::new();
                    let mut rest = Mapping::default();
                    for (jk, jv) in jm {
                        match (jk.as_str(), jv) {
                            (Some("type"), Value::String(t)) if parts.is_empty() => {
                                parts.push(t.clone());
                            }
                            _ => rest.push(jk.clone(), jv.clone()),
                        }
                    }
                    parts.extend(items(&rest));
                    out.push(format!("joint({})", parts.join(", ")));
                }
            }
            ("params", Value::Mapping(ps)) => {
                for (name, p) in ps {
                    let name = name.as_str().unwrap_or("_");
                    let Value::Mapping(pm) = p else {
                        out.push(format!("param({name} = {})", expr(p)));
                        continue;
                    };
                    let nominal = pm.get("nominal").map_or("_".into(), expr);
                    let known = matches!(pm.get("known"), Some(Value::Bool(true)));
                    out.push(if known {
                        format!("param({name} = {nominal}, known)")
                    } else {
                        format!("param({name} = {nominal})")
                    });
                }
            }
            ("base", Value::Mapping(b)) => out.push(format!("base({})", items(b).join(", "))),
            ("constraint", c) => out.push(format!("constraint({})", constraint(c))),
            ("constraints", Value::Sequence(cs)) => out.push(format!(
                "constraints({})",
                cs.iter().map(constraint).collect::<Vec<_>>().join(", ")
            )),
            (_, Value::Mapping(inner)) => out.push(format!("{key}({})", items(inner).join(", "))),
            _ => out.push(format!("{key} = {}", expr(v))),
        }
    }
    format!("#[calib({})] struct Robot;", out.join(", "))
}

/// A tree printed as flow YAML (JSON is YAML; strings quoted, so they stay strings).
fn yaml(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => n.to_string(),
        Value::String(s) => format!("{s:?}"),
        Value::Sequence(items) => format!(
            "[{}]",
            items.iter().map(yaml).collect::<Vec<_>>().join(", ")
        ),
        Value::Mapping(m) => format!(
            "{{{}}}",
            m.iter()
                .map(|(k, v)| format!("{}: {}", yaml(k), yaml(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Value::Tagged(t) => format!("{} {}", t.tag, yaml(&t.value)),
    }
}

/// The verdict of the walker, as something comparable: the spec, or every (field, message).
#[derive(Debug, PartialEq)]
enum Verdict {
    Accepted(Box<Spec>),
    Rejected(Vec<(String, String)>),
}

fn verdict(r: Result<Spec, Error>) -> Verdict {
    match r {
        Ok(s) => Verdict::Accepted(Box::new(s)),
        Err(e) => {
            let mut v: Vec<(String, String)> = e
                .diagnostics()
                .iter()
                .map(|d| {
                    (
                        d.location.field.clone().unwrap_or_default(),
                        d.message.clone(),
                    )
                })
                .collect();
            v.sort();
            Verdict::Rejected(v)
        }
    }
}

/// The attribute front: the inline text through the adapter and the walker. `None` when the
/// adapter itself objects (a shape the inline form cannot say).
fn through_attribute(text: &str) -> Option<Verdict> {
    let input: DeriveInput = syn::parse_str(text).expect("the printed attribute parses");
    let cx = Ctxt::new();
    let container = Container::from_ast(&input, &cx);
    let mut adapter = Adapter::new(&cx);
    let root = adapter.root(
        &container.attrs.inline,
        "robot",
        proc_macro2::Span::call_site(),
    );
    let adapter_ok = !cx.has_errors();
    let _ = cx.check();
    adapter_ok.then(|| verdict(from_tree(&root, &FieldsOnly)))
}

/// The YAML front on the flow text of `tree`.
fn through_yaml(tree: &Value) -> Verdict {
    verdict(from_yaml_str(&yaml(tree), None))
}

fn assert_same(tree: &Value, what: &str) {
    let text = inline(tree);
    let Some(attr) = through_attribute(&text) else {
        panic!("{what}: the attribute adapter refused {text}");
    };
    let yaml_verdict = through_yaml(tree);
    assert_eq!(
        attr,
        yaml_verdict,
        "{what}\ninline: {text}\nyaml: {}",
        yaml(tree)
    );
}

fn map_mut(v: &mut Value) -> Option<&mut Vec<(Value, Value)>> {
    match v {
        Value::Mapping(m) => Some(m.entries_mut()),
        _ => None,
    }
}

fn entry<'v>(v: &'v mut Value, key: &str) -> Option<&'v mut Value> {
    map_mut(v)?
        .iter_mut()
        .find(|(k, _)| k.as_str() == Some(key))
        .map(|(_, v)| v)
}

/// The spec broken in one way each; the mutation's name and the tree.
fn mutations(tree: &Value) -> Vec<(&'static str, Value)> {
    let s = |x: &str| Value::String(x.into());
    let num = |x: &str| Value::Number(lincal_core::spec::node::Number::parse(x).expect("number"));
    let mut out: Vec<(&'static str, Value)> = Vec::new();
    let mut m = |name: &'static str, f: &dyn Fn(&mut Value) -> Option<()>| {
        let mut t = tree.clone();
        if f(&mut t).is_some() {
            out.push((name, t));
        }
    };
    m("dim 4", &|t| {
        *entry(t, "dim")? = num("4");
        Some(())
    });
    m("convention MDH", &|t| {
        map_mut(t)?.retain(|(k, _)| k.as_str() != Some("convention"));
        map_mut(t)?.push((s("convention"), s("MDH")));
        Some(())
    });
    m("type Revolute", &|t| {
        let Value::Sequence(js) = entry(t, "joints")? else {
            return None;
        };
        *entry(js.first_mut()?, "type")? = s("Revolute");
        Some(())
    });
    m("typo in a joint key", &|t| {
        let Value::Sequence(js) = entry(t, "joints")? else {
            return None;
        };
        map_mut(js.first_mut()?)?.push((s("hom"), s("th1")));
        Some(())
    });
    m("a parameter inside an expression", &|t| {
        let Value::Sequence(js) = entry(t, "joints")? else {
            return None;
        };
        let first = map_mut(js.first_mut()?)?;
        first.retain(|(k, _)| k.as_str() != Some("alpha"));
        let name = entry(t, "params").and_then(|p| {
            map_mut(p)?
                .first()
                .and_then(|(k, _)| k.as_str().map(String::from))
        })?;
        let Value::Sequence(js) = entry(t, "joints")? else {
            return None;
        };
        map_mut(js.first_mut()?)?.push((s("alpha"), s(&format!("{name} + 0.1"))));
        Some(())
    });
    m("a parameter removed", &|t| {
        map_mut(entry(t, "params")?)?.remove(0);
        Some(())
    });
    m("an unused parameter", &|t| {
        let nominal: Mapping = std::iter::once((s("nominal"), num("0.5"))).collect();
        map_mut(entry(t, "params")?)?.push((s("unused_q"), Value::Mapping(nominal)));
        Some(())
    });
    m("a nominal that is a word", &|t| {
        let (_, p) = map_mut(entry(t, "params")?)?.first_mut()?;
        *entry(p, "nominal")? = s("abc");
        Some(())
    });
    m("known, with a nominal", &|t| {
        let (_, p) = map_mut(entry(t, "params")?)?.first_mut()?;
        map_mut(p)?.retain(|(k, _)| k.as_str() != Some("known"));
        map_mut(p)?.push((s("known"), Value::Bool(true)));
        Some(())
    });
    m("no constraint", &|t| {
        map_mut(t)?.retain(|(k, _)| !matches!(k.as_str(), Some("constraint" | "constraints")));
        Some(())
    });
    m("a tool of the wrong length", &|t| {
        map_mut(t)?.retain(|(k, _)| k.as_str() != Some("tool"));
        map_mut(t)?.push((s("tool"), Value::Sequence(vec![num("0"); 5])));
        Some(())
    });
    m("an absurd length", &|t| {
        let Value::Sequence(js) = entry(t, "joints")? else {
            return None;
        };
        let j = map_mut(js.last_mut()?)?;
        j.retain(|(k, _)| k.as_str() != Some("a"));
        j.push((s("a"), num("1e12")));
        Some(())
    });
    m("an unknown top-level key", &|t| {
        map_mut(t)?.push((s("dims"), num("2")));
        Some(())
    });
    out
}

#[test]
fn every_spec_of_the_repository_reads_the_same_through_both_fronts() {
    let files = spec_files();
    assert!(files.len() >= 10, "found only {files:?}");
    let mut compared = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).expect("readable");
        let tree = parse_tree(&text).expect("the repository's specs are YAML");
        let what = f.display().to_string();
        // The spec as given (the YAML front on its own text too: same spec as its flow print).
        assert_same(&tree, &what);
        assert_eq!(
            verdict(from_yaml_str(&text, None)),
            through_yaml(&tree),
            "{what}: the flow print reads as the file"
        );
        for (name, broken) in mutations(&tree) {
            assert_same(&broken, &format!("{what}, {name}"));
            compared += 1;
        }
    }
    assert!(compared > 100, "only {compared} mutations compared");
}

#[test]
fn inline_sugar_is_the_yaml_schema() {
    // `known(...)` and `params(...)` lists, `type = ...` spelled out, a quoted name.
    let inline = "#[calib(dim = 2, joint(type = revolute, a = \"a1\", home = th1), \
                  params(a1 = 0.375, th1 = 0), known(b1 = -1.79, b2 = -0.56), \
                  constraint(line(b = [b1, b2])))] struct Robot;";
    let yaml = "name: robot\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n\
                params:\n  a1: {nominal: 0.375}\n  th1: {nominal: 0}\n  \
                b1: {nominal: -1.79, known: true}\n  b2: {nominal: -0.56, known: true}\n\
                constraint:\n  line: {b: [b1, b2]}\n";
    assert_eq!(
        through_attribute(inline),
        Some(verdict(from_yaml_str(yaml, None)))
    );
}
