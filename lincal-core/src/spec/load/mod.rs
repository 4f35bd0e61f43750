//! YAML → [`Spec`], with every problem located (file, line, column, field path).
//!
//! Three steps:
//! 1. [`node`](mod@super::node) parses the text with `yaml-rust2` into a typed tree
//!    ([`Value`](super::node::Value)) and, from the same events, an index from each field path
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
//! # Layout
//! This module is the YAML front (text → tree and index → [`from_tree`]); the walker is
//! split by what it reads:
//! - `walk`: [`from_tree`] and the top-level mapping, field by field, in dependency order;
//! - `loader`: the walker's state, its reporting, the mapping reader and the message helpers;
//! - `values`: slots, numbers and lists of them (bounded by [`MAX_MAGNITUDE`]);
//! - `joints`: `joints:` entries, `base:` and `params:`;
//! - `constraints`: `constraint:` / `constraints:` entries, kind by kind;
//! - `relations`: `relations:` entries and their check against known values.
//!
//! # Slots
//! Every slot is a YAML number (made exact with [`Exact::from_f64`](super::Exact::from_f64), so `0.375` is 3/8), an
//! expression string parsed by [`Exact::parse`](super::Exact::parse) (`pi/2`, `-pi/2`, `2*pi/3`, `"0.5"`), or a
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

use super::locate::SourceIndex;
use super::node::{parse_yaml, YamlError};
use super::validate::Locate;
use super::Spec;
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};

mod constraints;
mod joints;
mod loader;
mod relations;
mod values;
mod walk;

pub use loader::suggest;
pub use values::MAX_MAGNITUDE;
pub use walk::from_tree;

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
                .iter()
                // A repeated key's own children repeat with it (`params.b1` given twice
                // repeats `params.b1.nominal`): the key is named, not each of them.
                .filter(|(path, _)| {
                    !repeats.iter().any(|(outer, _)| {
                        path.len() > outer.len()
                            && path.starts_with(outer.as_str())
                            && matches!(path.as_bytes()[outer.len()], b'.' | b'[')
                    })
                })
                .map(|(path, pos)| Diagnostic {
                    location: place(pos.0, pos.1, Some(path.clone())),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{Constraint, Convention, Exact, JointKind, ParamRole, Slot};

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

    /// `convention: urdf`: each joint's origin, any entry a parameter of its role; the DH
    /// entries and a planar arm refused by field, as the origin keys are in a DH table.
    #[test]
    fn loads_urdf_native_rows_and_refuses_mixed_keys() {
        let text = "name: u\ndim: 3\nconvention: urdf\njoints:\n  \
                    - {type: revolute, x: x1, z: 0.1, roll: pi/2, yaw: y1}\n  \
                    - {type: prismatic, y: 0.2, pitch: p2, offset: o2}\ntool: [0, 0, 0.1]\n\
                    params:\n  x1: {nominal: 0.01}\n  y1: {nominal: 0.1}\n  p2: {nominal: 0}\n  \
                    o2: {nominal: 0}\nconstraint: measured\n";
        let spec = ok(text);
        assert_eq!(spec.convention, Convention::Urdf);
        assert_eq!(spec.joints[0].origin.x, name("x1"));
        assert_eq!(spec.joints[0].origin.roll, exact("pi/2"));
        assert_eq!(spec.joints[1].origin.pitch, name("p2"));
        assert_eq!(spec.param("y1").unwrap().role, ParamRole::Angle);
        assert_eq!(spec.param("x1").unwrap().role, ParamRole::Length);
        bad(
            &text.replace("x: x1,", "x: x1, a: 0.1,"),
            5,
            "joints[0].a",
            "with `convention: urdf` a joint has its origin",
        );
        bad(
            &text.replace("x: x1,", "x: x1, theta: 0.1,"),
            5,
            "joints[0].theta",
            "a revolute joint has `x`, `y`, `z`, `roll`, `pitch`, `yaw`, `home`, `d`",
        );
        bad(
            &text.replace("convention: urdf", "convention: dh"),
            5,
            "joints[0].x",
            "only `convention: urdf` has",
        );
        bad(
            &text
                .replace("dim: 3", "dim: 2")
                .replace("tool: [0, 0, 0.1]", "tool: [0, 0.1]"),
            3,
            "convention",
            "spatial chain",
        );
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
            c3("constraint:\n  plane: {normal: [0, 0, 1], offset: r}"),
            Constraint::PlaneNormal {
                normal: [Slot::zero(), Slot::zero(), exact("1")],
                offset: name("r")
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
