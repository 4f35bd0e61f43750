//! The spec's `urdf:` record: where an imported spec came from, so that
//! `calibrate --write-urdf` can write the calibrated origins back into that URDF.
//!
//! ```yaml
//! urdf:
//!   path: /robots/ur5_rail.urdf     # relative paths are read from the spec's directory
//!   base: base_link                 # the chain's base link
//!   tip: ee_link                    # the chain's tip link
//!   tool: [0, 0, 0.05]              # the tool point in the tip link's frame
//!   joints: [shoulder_pan_joint, shoulder_lift_joint, ...]   # URDF joint of each spec joint
//! ```
//! The spec's `convention` says which table the import wrote. The record is an extension of
//! the interface's spec: the loader checks its shape (each field, its type) and otherwise
//! ignores it.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::spec::node::{Mapping, Value};

/// The `urdf:` record of a spec.
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfRecord {
    /// The URDF file, as written in the spec.
    pub path: String,
    /// The base link of the chain.
    pub base: String,
    /// The tip link of the chain.
    pub tip: String,
    /// The tool point in the tip link's frame (metres).
    pub tool: [f64; 3],
    /// The URDF joint behind each spec joint, in spec order.
    pub joints: Vec<String>,
}

const FIELDS: &[&str] = &["path", "base", "tip", "tool", "joints"];

/// Reads the record from its YAML value; the problems as `(field path, message)`.
fn read(v: &Value) -> (Option<UrdfRecord>, Vec<(String, String)>) {
    let mut problems = Vec::new();
    let Value::Mapping(m) = v else {
        problems.push((
            "urdf".to_string(),
            "expected a mapping `{path, base, tip, tool, joints}` (written by `lincal import`)"
                .to_string(),
        ));
        return (None, problems);
    };
    unknown_keys(m, &mut problems);
    let path = text(m, "path", &mut problems);
    let base = text(m, "base", &mut problems);
    let tip = text(m, "tip", &mut problems);
    let tool = tool(m, &mut problems);
    let joints = joints(m, &mut problems);
    let rec = match (path, base, tip, tool, joints) {
        (Some(path), Some(base), Some(tip), Some(tool), Some(joints)) => Some(UrdfRecord {
            path,
            base,
            tip,
            tool,
            joints,
        }),
        _ => None,
    };
    (rec, problems)
}

/// Each key of the record that is not one of [`FIELDS`] (or not a string), reported.
fn unknown_keys(m: &Mapping, problems: &mut Vec<(String, String)>) {
    for (k, _) in m.iter() {
        match k.as_str() {
            Some(k) if FIELDS.contains(&k) => {}
            _ => problems.push((
                "urdf".to_string(),
                format!(
                    "unknown key {}: expected {}",
                    k.as_str()
                        .map_or("(not a string)".to_string(), |s| format!("`{s}`")),
                    FIELDS.join(", ")
                ),
            )),
        }
    }
}

/// The required non-empty string `key`; `None` when missing or not one (reported).
fn text(m: &Mapping, key: &str, problems: &mut Vec<(String, String)>) -> Option<String> {
    match m.get(key) {
        Some(Value::String(s)) if !s.is_empty() => Some(s.clone()),
        Some(other) => {
            problems.push((
                format!("urdf.{key}"),
                format!("expected a non-empty string, found {other:?}"),
            ));
            None
        }
        None => {
            problems.push(("urdf".to_string(), format!("missing field `{key}`")));
            None
        }
    }
}

/// `tool:`, three bounded finite numbers (zeros when absent); `None` when malformed, each
/// problem reported.
fn tool(m: &Mapping, problems: &mut Vec<(String, String)>) -> Option<[f64; 3]> {
    let mut tool = Some([0.0; 3]);
    match m.get("tool") {
        None => {}
        Some(Value::Sequence(items)) if items.len() == 3 => {
            let mut t = [0.0; 3];
            for (i, it) in items.iter().enumerate() {
                // `urdf::chain::MAX_LENGTH`, the bound `import --tool` holds (that module
                // needs `std`; this one does not).
                let bound = 1e6;
                match it.as_f64().filter(|x| x.is_finite() && x.abs() <= bound) {
                    Some(x) => t[i] = x,
                    None => {
                        problems.push((
                            format!("urdf.tool[{i}]"),
                            format!(
                                "expected a finite number within {bound:e} m (the tool point, \
                                 metres; no tool is longer)"
                            ),
                        ));
                        tool = None;
                    }
                }
            }
            if tool.is_some() {
                tool = Some(t);
            }
        }
        Some(_) => {
            problems.push((
                "urdf.tool".to_string(),
                "expected a list of 3 numbers (the tool point in the tip link's frame)".to_string(),
            ));
            tool = None;
        }
    }
    tool
}

/// `joints:`, the list of URDF joint names (required); `None` when missing or malformed,
/// each problem reported.
fn joints(m: &Mapping, problems: &mut Vec<(String, String)>) -> Option<Vec<String>> {
    let mut joints = Some(Vec::new());
    match m.get("joints") {
        Some(Value::Sequence(items)) => {
            for (i, it) in items.iter().enumerate() {
                match it {
                    Value::String(s) => {
                        if let Some(j) = joints.as_mut() {
                            j.push(s.clone());
                        }
                    }
                    _ => {
                        problems.push((
                            format!("urdf.joints[{i}]"),
                            "expected a URDF joint name (a string)".to_string(),
                        ));
                        joints = None;
                    }
                }
            }
        }
        Some(_) => {
            problems.push((
                "urdf.joints".to_string(),
                "expected a list of URDF joint names".to_string(),
            ));
            joints = None;
        }
        None => {
            problems.push(("urdf".to_string(), "missing field `joints`".to_string()));
            joints = None;
        }
    }
    joints
}

/// The problems of a `urdf:` value, as `(field path, message)`, for the spec loader.
#[must_use]
pub fn problems(v: &Value) -> Vec<(String, String)> {
    read(v).1
}

impl UrdfRecord {
    /// The URDF joint names a data file may use as the headers of a spec's `joints` joint
    /// columns: the record's, or none when the record was edited to another number of
    /// joints (its columns then stay unknown rather than mapped to the wrong joint).
    #[must_use]
    pub fn joint_names(self, joints: usize) -> Vec<String> {
        if self.joints.len() == joints {
            self.joints
        } else {
            Vec::new()
        }
    }

    /// The record of a spec's text, if it has one (`file` names the spec in errors).
    ///
    /// # Errors
    /// An input error when the text may hold a record (it names `urdf` or has an escape) and
    /// is not YAML, or when the record is malformed (the spec loader reports the same
    /// problems, located).
    pub fn from_spec_text(text: &str, file: Option<&str>) -> Result<Option<UrdfRecord>> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        // No `urdf` key can be written without those four letters or an escape: most specs
        // are then spared a second parse of their YAML (a tenth of a millisecond per run).
        if !text.contains("urdf") && !text.contains('\\') {
            return Ok(None);
        }
        let (value, index) = crate::spec::node::parse_yaml(text).map_err(|_| {
            Error::input(
                Location {
                    file: file.map(str::to_string),
                    ..Location::default()
                },
                "the spec is not YAML",
            )
        })?;
        let Value::Mapping(top) = &value else {
            return Ok(None);
        };
        let Some(v) = top.get("urdf") else {
            return Ok(None);
        };
        let (rec, problems) = read(v);
        if let Some((field, message)) = problems.into_iter().next() {
            let pos = index.value(&field);
            return Err(Error::input(
                Location {
                    file: file.map(str::to_string),
                    line: pos.map(|p| p.0),
                    column: pos.map(|p| p.1),
                    field: Some(field),
                    pose: None,
                },
                message,
            ));
        }
        Ok(rec)
    }

    /// The URDF file: `path` as written if absolute, else relative to the spec's directory.
    #[must_use]
    pub fn resolve(&self, spec_path: &Path) -> PathBuf {
        let p = Path::new(&self.path);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        spec_path
            .parent()
            .map_or_else(|| p.to_path_buf(), |d| d.join(p))
    }

    /// The record as YAML lines (a top-level `urdf:` mapping).
    #[must_use]
    pub fn to_yaml(&self) -> String {
        let q = |s: &str| yaml_string(s);
        let tool: Vec<String> = self.tool.iter().map(|v| num(*v)).collect();
        let joints: Vec<String> = self.joints.iter().map(|j| q(j)).collect();
        format!(
            "urdf:\n  path: {}\n  base: {}\n  tip: {}\n  tool: [{}]\n  joints: [{}]\n",
            q(&self.path),
            q(&self.base),
            q(&self.tip),
            tool.join(", "),
            joints.join(", ")
        )
    }
}

/// A YAML double-quoted string (always quoted, so names like `true` or `1` stay strings).
#[must_use]
pub fn yaml_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A number as the spec writes it: shortest round-trip decimal, tiny values as 0.
pub(crate) fn num(v: f64) -> String {
    if v.abs() < 1e-15 {
        "0".to_string()
    } else {
        format!("{v:?}")
    }
}
