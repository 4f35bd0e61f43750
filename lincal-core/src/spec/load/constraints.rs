//! One constraint entry (`constraint:` or an entry of `constraints:`) to a [`Constraint`]:
//! its kind (one key, or the bare word `measured`), the kind checked against `dim`, then the
//! kind's fields (`point`, `line`, `plane`, `circle`/`sphere`, `quadric`).

use super::loader::{describe, fields_were_rejected, idx, list, suggest, Fields, Loader};
use super::values::SLOT_HELP;
use crate::spec::locate::join_key;
use crate::spec::node::Value;
use crate::spec::validate::kind_fits_dim;
use crate::spec::{Constraint, Slot};

/// The range of a stated `position_std / orientation_std` (metres per radian): wide enough
/// for any real sensor (about 10⁻² to 10² m/rad), narrow enough that the weighted residuals
/// stay far from overflow.
const STATED_RATIO: (f64, f64) = (1e-12, 1e12);

/// The constraint kinds.
const KINDS: &[&str] = &[
    "point",
    "line",
    "plane",
    "circle",
    "sphere",
    "quadric",
    "measured",
    "measured_pose",
];

/// What a constraint entry looks like, for messages.
const CONSTRAINT_EXAMPLE: &str =
    "a one-key mapping like `line: {b: [b1, b2]}`, or `measured` (or `measured_pose`)";

impl Loader<'_> {
    /// One constraint entry `{kind: {fields}}` (or the bare string `measured`).
    pub(super) fn constraint(&mut self, v: &Value, path: &str) -> Option<Constraint> {
        if let Value::String(s) = v {
            return self.constraint_word(s, path);
        }
        let fields = self.mapping(v, path, Some(KINDS), CONSTRAINT_EXAMPLE)?;
        let (kind, body) = self.constraint_kind(&fields, v, path)?;
        let base = join_key(path, kind);
        if kind == "measured" {
            return self.measured_body(body, &base);
        }
        if kind == "measured_pose" {
            return self.measured_pose_body(body, &base);
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
            "measured_pose" => self.measured_pose_body(&Value::Null, path),
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

    /// `measured_pose`'s body: nothing, or `{position_std: m, orientation_std: rad}` (each
    /// optional, a positive number); a 3-D kind.
    fn measured_pose_body(&mut self, body: &Value, base: &str) -> Option<Constraint> {
        if let Some(d) = self.dim {
            if let Err(msg) = kind_fits_dim("measured_pose", false, d) {
                self.key_error(base, msg);
                self.orphan(body);
                return None;
            }
        }
        if matches!(body, Value::Null) {
            return Some(Constraint::MeasuredPose {
                position_std: None,
                orientation_std: None,
            });
        }
        const FIELDS: &[&str] = &["position_std", "orientation_std"];
        let f = self.mapping(
            body,
            base,
            Some(FIELDS),
            "a mapping with the optional fields `position_std` (metres) and `orientation_std` \
             (radians)",
        )?;
        let mut std = |key: &str, unit: &str| -> Result<Option<f64>, ()> {
            let Some(v) = f.get(key) else {
                return Ok(None);
            };
            let path = join_key(base, key);
            let what = format!("a positive number ({unit})");
            match self.number(v, &path, &what) {
                Some(x) if x > 0.0 => Ok(Some(x)),
                Some(x) => {
                    self.error(&path, format!("expected {what}, found {x}"));
                    Err(())
                }
                None => Err(()),
            }
        };
        // Both read before either error returns: every bad field is reported.
        let position_std = std("position_std", "metres");
        let orientation_std = std("orientation_std", "radians");
        let (position_std, orientation_std) = (position_std.ok()?, orientation_std.ok()?);
        // Stated together, their ratio weighs the orientation residual (metres per radian):
        // it must be a number the fit can multiply by, not an overflow or an underflow.
        if let (Some(sp), Some(so)) = (position_std, orientation_std) {
            let ratio = sp / so;
            if !(STATED_RATIO.0..=STATED_RATIO.1).contains(&ratio) {
                self.error(
                    base,
                    format!(
                        "position_std / orientation_std is {ratio:e} m/rad, outside {:e} to \
                         {:e}: one of the two levels is mistyped (a tracker's 6-DoF probe is \
                         about 20e-6 m and 1e-4 rad, 0.2 m/rad)",
                        STATED_RATIO.0, STATED_RATIO.1
                    ),
                );
                return None;
            }
        }
        Some(Constraint::MeasuredPose {
            position_std,
            orientation_std,
        })
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
            "plane" => &["b", "normal", "offset"],
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

    /// `plane: {b: [b1, b2, b3]}` (`b·x + 1 = 0`) or `plane: {normal: [n1, n2, n3], offset: d}`
    /// (`n·x = d`), not both.
    fn plane(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let (normal, offset) = (f.get("normal"), f.get("offset"));
        if normal.is_none() && offset.is_none() {
            let b = self.required(
                f,
                base,
                "b",
                "`[b1, b2, b3]` of b·x + 1 = 0 (or `normal: [n1, n2, n3]` with `offset: d`, \
                 n·x = d)",
            )?;
            return Some(Constraint::Plane {
                b: self.array::<3>(b, &join_key(base, "b"), "b1, b2, b3 of b·x + 1 = 0")?,
            });
        }
        if f.get("b").is_some() {
            for (key, v) in [("normal", normal), ("offset", offset)] {
                if let Some(v) = v {
                    self.key_error(
                        &join_key(base, key),
                        "a plane is either `b: [b1, b2, b3]` (b·x + 1 = 0) or `normal: [n1, n2, \
                         n3]` with `offset: d` (n·x = d), not both"
                            .into(),
                    );
                    self.orphan(v);
                }
            }
            return None;
        }
        self.plane_normal(f, base)
    }

    /// `plane: {normal: [n1, n2, n3], offset: d}`: both fields required.
    fn plane_normal(&mut self, f: &Fields<'_>, base: &str) -> Option<Constraint> {
        let normal = self.required(f, base, "normal", "the normal `[n1, n2, n3]` of n·x = d");
        let offset = self.required(
            f,
            base,
            "offset",
            &format!("the offset d of n·x = d ({SLOT_HELP})"),
        );
        let n = normal
            .and_then(|n| self.array::<3>(n, &join_key(base, "normal"), "n1, n2, n3 of n·x = d"));
        let d = offset.and_then(|d| self.slot(d, &join_key(base, "offset")));
        match (n, d) {
            (Some(normal), Some(offset)) => Some(Constraint::PlaneNormal { normal, offset }),
            (n, d) => {
                if let Some(n) = n {
                    self.orphan_slots(&n);
                }
                if let Some(d) = d {
                    self.orphan_slots(&[d]);
                }
                None
            }
        }
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
