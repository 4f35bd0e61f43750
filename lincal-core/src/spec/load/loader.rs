//! The walker's state and its tools: a [`Loader`] (the [`Locate`] it reports through, the
//! diagnostics so far, the validation context and the `dim` once read), the reporting of a
//! problem at a value or a key, the mapping reader that reports unknown and non-string keys,
//! and the helpers every message uses ([`describe`], [`case_hint`], [`suggest`], [`list`]).

use crate::error::{excerpt, Diagnostic, Location};
use crate::spec::locate::{join_index, join_key};
use crate::spec::node::Value;
use crate::spec::validate::{is_param_name, Context, Locate};
use crate::spec::Slot;

/// The walker's state: where problems are reported, the problems so far, what validation
/// needs to know of the walk, and the spec's `dim` once read.
pub(super) struct Loader<'a> {
    /// Field path → place in the source.
    pub(super) locate: &'a dyn Locate,
    /// Every problem met so far, in walk order.
    pub(super) diags: Vec<Diagnostic>,
    /// What the walk tells validation (fields reported, names used elsewhere, ...).
    pub(super) ctx: Context,
    /// The spec's `dim`, once read (2 or 3).
    pub(super) dim: Option<usize>,
    /// The spec's `convention` (read before the joints, whose keys depend on it).
    pub(super) convention: crate::spec::Convention,
}

/// The string-keyed entries of a mapping, in order.
pub(super) struct Fields<'v> {
    /// Key and value of each entry.
    pub(super) entries: Vec<(&'v str, &'v Value)>,
}

impl<'v> Fields<'v> {
    /// The value of `key`, if the mapping has it.
    pub(super) fn get(&self, key: &str) -> Option<&'v Value> {
        self.entries
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v)
    }
}

/// Short description of a YAML value for "found ..." messages.
pub(super) fn describe(v: &Value) -> String {
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
pub(super) fn case_hint(v: &Value, allowed: &[&str]) -> String {
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

/// Levenshtein distance between `a` and `b`, by characters.
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

/// `items` as a message lists them: each in backticks, comma-separated.
pub(super) fn list(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("`{s}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The field path of entry `i` of the list at `path` (`joints[1]`).
pub(super) fn idx(path: &str, i: usize) -> String {
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
    /// Where the value (or, with `key`, the key) of `field` is.
    fn location(&self, field: &str, key: bool) -> Location {
        if key {
            self.locate.key(field)
        } else {
            self.locate.value(field)
        }
    }

    /// A problem with the value at `field`.
    pub(super) fn error(&mut self, field: &str, message: String) {
        let location = self.location(field, false);
        self.push(field, location, message);
    }

    /// A problem with the key of the entry at `field` (an unknown or misplaced key).
    pub(super) fn key_error(&mut self, field: &str, message: String) {
        let location = self.location(field, true);
        self.push(field, location, message);
    }

    /// Records a problem at `location`, and `field` as reported (for validation).
    fn push(&mut self, field: &str, location: Location, message: String) {
        self.ctx.reported.push(field.to_string());
        self.diags.push(Diagnostic { location, message });
    }

    /// Keeps the names inside a rejected value counted as used.
    pub(super) fn orphan(&mut self, v: &Value) {
        names_in(v, &mut self.ctx.used_elsewhere);
    }

    /// Keeps the parameter names among rejected slots counted as used.
    pub(super) fn orphan_slots(&mut self, slots: &[Slot]) {
        for s in slots {
            if let Slot::Param(n) = s {
                self.ctx.used_elsewhere.push(n.clone());
            }
        }
    }

    /// The entries of the mapping at `path`, reporting unknown keys (against `allowed`) and
    /// non-string keys; `None` (reported) when `v` is not a mapping.
    pub(super) fn mapping<'v>(
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
                    let hint = if key == "<<" {
                        // YAML 1.1's merge key: no part of YAML 1.2, which the loader reads.
                        "YAML merge keys (`<<: *anchor`) are not supported: write the fields \
                         out in each mapping; "
                            .to_string()
                    } else {
                        suggest(key, allowed)
                            .map(|s| format!("did you mean `{s}`? "))
                            .unwrap_or_default()
                    };
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

    /// A required field `key` missing from the mapping at `parent` (expected `what`), placed
    /// at the mapping.
    pub(super) fn missing(&mut self, parent: &str, key: &str, what: &str) {
        let field = join_key(parent, key);
        let mut location = self.location(parent, false);
        location.field = Some(field.clone());
        self.push(
            &field,
            location,
            format!("missing field `{key}`: expected {what}"),
        );
    }
}

/// Whether `v` is a mapping whose keys all were rejected (so "empty" was already reported).
pub(super) fn fields_were_rejected(v: &Value) -> bool {
    matches!(v, Value::Mapping(m) if !m.is_empty())
}
