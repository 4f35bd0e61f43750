//! `relations:`: a list of relations between entries of `constraints:`, each read into a
//! [`Relation`] (kind, pair of indices, value) with its indices checked against the list,
//! its kinds against what the relation relates, and its value against fully known
//! constraints.

use super::loader::{describe, fields_were_rejected, idx, Fields, Loader};
use crate::model::geometry::{Relation, RelationKind};
use crate::spec::locate::join_key;
use crate::spec::node::Value;
use crate::spec::{Slot, Spec};

/// The kind keys of a relation entry.
const RELATION_KINDS: &[&str] = &["distance", "same_normal", "offset"];

/// What a relation entry looks like, for messages.
const RELATION_EXAMPLE: &str = "`{distance: [0, 1], value: 0.05}`, `{same_normal: [0, 1]}` or \
                                `{offset: [0, 1], value: 0.02}`";

impl Loader<'_> {
    /// `relations:`: a list of `{distance: [i, j], value: d}`, `{same_normal: [i, j]}`,
    /// `{offset: [i, j], value: d}` between entries of `constraints:`. The indices are checked
    /// against the list, the kinds against what each relation relates (a centre, a normal),
    /// and a relation between two fully known constraints against their values.
    pub(super) fn relations(&mut self, v: &Value, spec: &Spec) -> Vec<Relation> {
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
