//! The chain's entries: one `joints:` entry to a [`Joint`] (its type, the slots that type
//! has, `limits`), `base:` to a [`Base`] and `params:` to the declared [`Param`]s.

use super::loader::{case_hint, describe, idx, list, Fields, Loader};
use crate::spec::locate::join_key;
use crate::spec::node::Value;
use crate::spec::validate::is_param_name;
use crate::spec::{Base, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot};

/// The keys of a revolute joint.
const REVOLUTE: &[&str] = &["type", "a", "alpha", "beta", "d", "home", "limits"];
/// The keys of a prismatic joint.
const PRISMATIC: &[&str] = &["type", "a", "alpha", "beta", "theta", "offset", "limits"];
/// The keys of a joint of either type, in any convention.
const JOINT_ANY: &[&str] = &[
    "type", "a", "alpha", "beta", "d", "home", "theta", "offset", "limits", "x", "y", "z", "roll",
    "pitch", "yaw",
];
/// The DH entries that `convention: urdf` replaces by the joint's origin.
const DH_ONLY: &[&str] = &["a", "alpha", "beta"];
/// The keys of `base:`.
const BASE: &[&str] = &["x", "y", "z", "roll", "pitch", "yaw"];
/// The keys of a parameter.
const PARAM: &[&str] = &["nominal", "known"];

impl Loader<'_> {
    /// One joint of `joints:` at `path`: its type, then each slot where the type allows it
    /// and `limits`; a placeholder revolute joint when the entry is not a mapping.
    pub(super) fn joint(&mut self, v: &Value, path: &str) -> Joint {
        let mut joint = Joint {
            kind: JointKind::Revolute,
            a: Slot::zero(),
            alpha: Slot::zero(),
            beta: Slot::zero(),
            d: Slot::zero(),
            home: Slot::zero(),
            theta: Slot::zero(),
            offset: Slot::zero(),
            limits: None,
            origin: Base::zero(),
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
        let urdf = self.convention == Convention::Urdf;
        if (!urdf && BASE.contains(&key)) || (urdf && DH_ONLY.contains(&key)) {
            let why = if urdf {
                format!(
                    "`{key}` is a DH entry: with `convention: urdf` a joint has its origin \
                     {} (as a URDF's `<origin xyz rpy>`) and turns or slides along its z axis",
                    list(BASE)
                )
            } else {
                format!(
                    "`{key}` is part of a joint's origin, which only `convention: urdf` has; \
                     with `convention: {}` a joint has {}",
                    self.convention.name(),
                    list(&REVOLUTE[1..6])
                )
            };
            self.key_error(field, why);
            self.orphan(val);
            return;
        }
        let allowed = match kind {
            _ if BASE.contains(&key) => kind.is_some(),
            Some(JointKind::Revolute) => REVOLUTE.contains(&key),
            Some(JointKind::Prismatic) => PRISMATIC.contains(&key),
            None => false,
        };
        if !allowed {
            match kind {
                Some(JointKind::Revolute) => {
                    // A URDF-native row's keys are its origin's and `home`, `d`.
                    let has = if self.convention == Convention::Urdf {
                        format!("{}, `home`, `d`", list(BASE))
                    } else {
                        list(&REVOLUTE[1..5])
                    };
                    self.key_error(
                        field,
                        format!(
                            "`{key}` belongs to prismatic joints: a revolute joint has {has} \
                             (θ = q − home)"
                        ),
                    );
                }
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

    /// A joint's `limits: [min, max]`, two bounded numbers.
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

    /// `base:`, the mapping `{x, y, z, roll, pitch, yaw}` of slots (zero where absent).
    pub(super) fn base(&mut self, v: &Value) -> Option<Base> {
        self.frame(v, "base")
    }

    /// A frame `{x, y, z, roll, pitch, yaw}` of slots at `path` (`base`, or a tool frame),
    /// zero where absent.
    pub(super) fn frame(&mut self, v: &Value, path: &str) -> Option<Base> {
        let fields = self.mapping(
            v,
            path,
            Some(BASE),
            "a mapping `{x, y, z, roll, pitch, yaw}`",
        )?;
        let mut base = Base::zero();
        for &(key, val) in &fields.entries {
            let Some(s) = self.slot(val, &join_key(path, key)) else {
                continue;
            };
            if let Some(dst) = base.slot_mut(key) {
                *dst = s;
            }
        }
        Some(base)
    }

    /// `params:`, each name to its `nominal` and `known`.
    pub(super) fn params(&mut self, v: &Value) -> Vec<Param> {
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
}
