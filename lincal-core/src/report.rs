//! Reports: what `lincal basis` and `lincal calibrate` print, as JSON
//! ([`serde_json::Value`]) and as readable text.
//!
//! The JSON fields are the public contract of `shared/interface.md` (every field listed there
//! is present, with that name and meaning); the extra fields are documented on each function.
//!
//! # Example
//! ```
//! let yaml = "
//! name: two_link
//! dim: 2
//! joints:
//!   - {type: revolute, a: a1, home: th1}
//!   - {type: revolute, a: a2, home: th2}
//! params:
//!   a1: {nominal: 0.375}
//!   a2: {nominal: 0.425}
//!   th1: {nominal: 0}
//!   th2: {nominal: 0}
//!   b1: {nominal: -1.8}
//!   b2: {nominal: -0.5}
//! constraint:
//!   line: {b: [b1, b2]}
//! ";
//! let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
//! let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
//! let json = lincal_core::report::basis_json(&model);
//! assert_eq!(json["basis_size"], 5);
//! assert_eq!(json["identifiable_count"], 4);
//! assert!(lincal_core::report::basis_text(&model).contains("identifiable combinations: 4"));
//! ```

use std::fmt::Write as _;

use serde_json::{json, Map, Value};

use crate::estimate::{Estimate, ParamEstimate};
use crate::model::CalibModel;
use crate::spec::{Constraint, Spec};
use crate::symbolic::SymbolicModel;

/// A finite number as JSON, `null` otherwise (JSON has no NaN).
fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

/// One gauge direction as a JSON object `{param: coefficient}`.
fn gauge_object(g: &[(String, f64)]) -> Value {
    let mut m = Map::new();
    for (name, c) in g {
        m.insert(name.clone(), num(*c));
    }
    Value::Object(m)
}

/// A gauge direction as text, e.g. `a1 - 0.5·b1`.
fn gauge_string(g: &[(String, f64)]) -> String {
    let mut s = String::new();
    for (i, (name, c)) in g.iter().enumerate() {
        let (sign, mag) = if *c < 0.0 { ("-", -c) } else { ("+", *c) };
        if i == 0 {
            if sign == "-" {
                s.push('-');
            }
        } else {
            let _ = write!(s, " {sign} ");
        }
        if (mag - 1.0).abs() < 1e-12 {
            s.push_str(name);
        } else {
            let _ = write!(s, "{}·{name}", short(mag));
        }
    }
    s
}

/// A number in a short readable form (6 significant digits).
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-4..1e6).contains(&a) {
        let digits = (5 - a.log10().floor() as i32).clamp(0, 12) as usize;
        let s = format!("{v:.digits$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        s
    } else {
        format!("{v:.5e}")
    }
}

/// The constraints of a spec as JSON: `[{kind, equations}]`.
fn constraints_json(model: &SymbolicModel) -> Value {
    let spec = model.spec();
    let dim = spec.dim;
    Value::Array(
        spec.constraints
            .iter()
            .map(|c| {
                json!({
                    "kind": c.kind_name(),
                    "equations": c.geometry_kind().equation_count(dim),
                })
            })
            .collect(),
    )
}

/// Names of the known parameters of a spec.
fn known_names(spec: &Spec) -> Vec<String> {
    spec.params
        .iter()
        .filter(|p| p.known)
        .map(|p| p.name.clone())
        .collect()
}

/// The result of `lincal basis --format json`.
///
/// Fields of the interface: `name`, `joints` (joint count), `params` (estimated names, spec
/// order), `naive_size`, `basis_size`, `basis` (`K` strings), `identifiable_count`,
/// `identifiable`, `unidentifiable`, `gauge` (`[{param: coefficient}]`). Extras: `dim`,
/// `known` (names fixed by the spec), `constraints` (`[{kind, equations}]`), `equations`
/// (total `E`), `constant_index` (0-based index of the constant function in `basis`, or
/// `null`), `generalized_params` (`E` lists of `K` strings: `h_e = Σ_k c_{e,k}·basis_k`),
/// `held` (the parameters the gauge rule holds at their nominal).
#[must_use]
pub fn basis_json(model: &SymbolicModel) -> Value {
    let spec = model.spec();
    let (identifiable, unidentifiable) = model.identifiable_split();
    let ident = model.identifiability();
    let held: Vec<String> = model
        .param_names()
        .iter()
        .zip(&ident.held)
        .filter(|(_, &h)| h)
        .map(|(n, _)| n.clone())
        .collect();
    json!({
        "name": spec.name,
        "dim": spec.dim,
        "joints": spec.joints.len(),
        "params": model.param_names(),
        "known": known_names(spec),
        "constraints": constraints_json(model),
        "equations": model.equation_count(),
        "naive_size": model.naive_size(),
        "basis_size": model.basis_names().len(),
        "basis": model.basis_names(),
        "constant_index": model.constant_index(),
        "generalized_params": model.generalized_param_strings(),
        "identifiable_count": ident.count,
        "identifiable": identifiable,
        "unidentifiable": unidentifiable,
        "held": held,
        "gauge": model.gauge().iter().map(|g| gauge_object(g)).collect::<Vec<_>>(),
        "warnings": model.warnings(),
    })
}

/// Which constraint each equation belongs to, as readable labels.
fn equation_labels(model: &SymbolicModel) -> Vec<String> {
    let spec = model.spec();
    let dim = spec.dim;
    let mut labels = Vec::new();
    for (j, c) in spec.constraints.iter().enumerate() {
        let m = c.geometry_kind().equation_count(dim);
        let what = match c {
            Constraint::Point { .. } => vec!["x − p_x", "y − p_y", "z − p_z"],
            Constraint::Measured => vec!["x", "y", "z"],
            Constraint::Line3 { .. } => vec!["plane 1", "plane 2"],
            _ => vec![""],
        };
        for i in 0..m {
            let mut l = format!("constraint {j} ({})", c.kind_name());
            if m > 1 {
                let _ = write!(l, ", {}", what.get(i).copied().unwrap_or(""));
            }
            labels.push(l);
        }
    }
    labels
}

/// The result of `lincal basis` as a readable report: the basis functions, the generalized
/// parameters `c(p)` of each equation, the identifiability and the gauge directions.
#[must_use]
pub fn basis_text(model: &SymbolicModel) -> String {
    let spec = model.spec();
    let ident = model.identifiability();
    let names = model.param_names();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: dim {}, {} joint(s), {} estimated parameter(s)",
        spec.name,
        spec.dim,
        spec.joints.len(),
        names.len()
    );
    if let Some(d) = &spec.description {
        let _ = writeln!(s, "  {d}");
    }
    let kinds: Vec<&str> = spec.constraints.iter().map(Constraint::kind_name).collect();
    let _ = writeln!(
        s,
        "constraint(s): {} ({} equation(s))",
        kinds.join(", "),
        model.equation_count()
    );
    let known = known_names(spec);
    if !known.is_empty() {
        let _ = writeln!(s, "known (fixed at nominal): {}", known.join(", "));
    }
    let _ = writeln!(
        s,
        "naive size: {} distinct monomials; reduced basis: K = {}",
        model.naive_size(),
        model.basis_names().len()
    );
    let _ = writeln!(s);
    let _ = writeln!(s, "basis functions Φ̃(q):");
    let width = model.basis_names().len().to_string().len();
    for (k, b) in model.basis_names().iter().enumerate() {
        let _ = writeln!(s, "  Φ{:<width$}  {b}", k + 1);
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "generalized parameters c(p), h_e(q; p) = Σ_k c_e,k(p)·Φk(q):"
    );
    let labels = equation_labels(model);
    for (e, row) in model.generalized_param_strings().iter().enumerate() {
        let _ = writeln!(
            s,
            "  equation {} — {}:",
            e + 1,
            labels.get(e).map_or("", String::as_str)
        );
        for (k, c) in row.iter().enumerate() {
            let _ = writeln!(s, "    c{:<width$} = {c}", k + 1);
        }
    }
    let _ = writeln!(s);
    let (yes, no) = model.identifiable_split();
    let held: Vec<&str> = names
        .iter()
        .zip(&ident.held)
        .filter(|(_, &h)| h)
        .map(|(n, _)| n.as_str())
        .collect();
    let list = |v: &[String]| {
        if v.is_empty() {
            "(none)".to_string()
        } else {
            v.join(", ")
        }
    };
    let _ = writeln!(s, "identifiable combinations: {}", ident.count);
    let _ = writeln!(s, "  identifiable on their own: {}", list(&yes));
    let _ = writeln!(s, "  not identifiable on their own: {}", list(&no));
    if !held.is_empty() {
        let _ = writeln!(
            s,
            "  gauge rule: held at their nominal values by `calibrate`: {}",
            held.join(", ")
        );
    }
    let gauge = model.gauge();
    if gauge.is_empty() {
        let _ = writeln!(s, "gauge directions: none (every parameter is determined)");
    } else {
        let _ = writeln!(
            s,
            "gauge directions (parameter changes the constraint cannot see, at the nominals):"
        );
        for (i, g) in gauge.iter().enumerate() {
            let _ = writeln!(s, "  {}. d({})", i + 1, gauge_string(g));
        }
    }
    for w in model.warnings() {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}

/// One parameter of an estimate as JSON.
fn param_json(p: &ParamEstimate) -> Value {
    json!({
        "value": num(p.value),
        "std": p.std.map_or(Value::Null, num),
        "identifiable": p.identifiable,
        "known": p.known,
        "held": p.held,
    })
}

/// The result of `lincal calibrate --format json`.
///
/// Fields of the interface: `params` (`{name: {value, std, identifiable, known}}` for every
/// parameter of the spec, `std` `null` for known and held ones), `identifiable_count`,
/// `basis_size`, `poses`, `rank`, `residual_rms` (metres), `method`, `warnings`, `start`
/// (`"linear"` or `"nominal"`), `condition` (of the gauge-fixed Jacobian at the estimate,
/// column-equilibrated), `worst_poses` (`{pose, line, residual}`, descending). Extras:
/// `linear_poses` (poses the linear method used, 0 when it did not run),
/// `name` (the model's), `held` per parameter (held at its nominal by the gauge rule),
/// `paper_err_rms` (the paper's sec. 5 err_rms in metres, planar arms on one line only),
/// `basis` (the basis function names) and `generalized_params` (the linear solve's `c`, one
/// list of `K` numbers per equation).
#[must_use]
pub fn calibrate_json(model: &dyn CalibModel, est: &Estimate) -> Value {
    let mut params = Map::new();
    for p in &est.params {
        params.insert(p.name.clone(), param_json(p));
    }
    let k = est.basis_size;
    let basis: Vec<&str> = (0..model.basis_size())
        .map(|i| model.basis_name(i))
        .collect();
    let generalized: Vec<Value> = if k > 0 && est.generalized_params.len().is_multiple_of(k) {
        est.generalized_params
            .chunks(k)
            .map(|row| Value::Array(row.iter().map(|v| num(*v)).collect()))
            .collect()
    } else {
        est.generalized_params.iter().map(|v| num(*v)).collect()
    };
    let mut out = json!({
        "name": model.name(),
        "params": Value::Object(params),
        "identifiable_count": est.identifiable_count,
        "basis_size": est.basis_size,
        "poses": est.poses,
        "rank": est.rank,
        "residual_rms": num(est.residual_rms),
        "method": est.method,
        "start": est.start,
        "linear_poses": est.linear_poses,
        "condition": est.condition.map_or(Value::Null, num),
        "worst_poses": est.worst_poses.iter().map(|w| json!({
            "pose": w.pose,
            "line": w.line,
            "residual": num(w.residual),
        })).collect::<Vec<_>>(),
        "robust_scale": if est.robust_scale.is_finite() { num(est.robust_scale) } else { Value::Null },
        "rejected": est.rejected.iter().map(|w| json!({
            "pose": w.pose,
            "line": w.line,
            "residual": num(w.residual),
        })).collect::<Vec<_>>(),
        "robust": est.robust.as_ref().map_or(Value::Null, |r| json!({
            "loss": r.loss,
            "tuning": num(r.tuning),
            "scale": if r.scale.is_finite() { num(r.scale) } else { Value::Null },
            "rounds": r.rounds,
            "downweighted": r.downweighted,
        })),
        "warnings": est.warnings,
        "basis": basis,
        "generalized_params": generalized,
    });
    if let (Some(v), Some(obj)) = (est.paper_err_rms, out.as_object_mut()) {
        obj.insert("paper_err_rms".to_string(), num(v));
    }
    out
}

/// The result of `lincal calibrate` as a readable table.
#[must_use]
pub fn calibrate_text(model: &dyn CalibModel, est: &Estimate) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} poses, method {}",
        model.name(),
        est.poses,
        est.method
    );
    let start = match est.start.as_str() {
        "linear" if est.linear_poses < est.poses => format!(
            "the linear method (no initial guess), on {} of the {} poses",
            est.linear_poses, est.poses
        ),
        "linear" => "the linear method (no initial guess)".to_string(),
        _ => "the nominals (deterministic restarts)".to_string(),
    };
    let _ = writeln!(s, "start: {start}");
    let _ = writeln!(
        s,
        "basis K = {}, rank {}, identifiable combinations {}{}",
        est.basis_size,
        est.rank,
        est.identifiable_count,
        est.condition
            .map_or(String::new(), |c| format!(", condition {c:.3e}"))
    );
    let _ = writeln!(s);
    let w = est
        .params
        .iter()
        .map(|p| p.name.chars().count())
        .max()
        .unwrap_or(5)
        .max(9);
    let _ = writeln!(
        s,
        "  {:<w$}  {:>18}  {:>11}  status",
        "parameter", "value", "std"
    );
    for p in &est.params {
        let status = if p.known {
            "known (fixed by the spec)"
        } else if p.held {
            "held at nominal (gauge rule)"
        } else if p.identifiable {
            "identifiable"
        } else {
            "fitted (only a combination is identifiable)"
        };
        let std = p
            .std
            .map_or_else(|| "-".to_string(), |v| format!("{v:.3e}"));
        let _ = writeln!(
            s,
            "  {:<w$}  {:>18.12}  {:>11}  {status}",
            p.name, p.value, std
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "residual rms (distance of the calibrated tips from the constraint): {:.4e} m ({:.3} µm)",
        est.residual_rms,
        est.residual_rms * 1e6
    );
    if let Some(e) = est.paper_err_rms {
        let _ = writeln!(
            s,
            "paper's err_rms (sec. 5, scatter of the tips about their best line): {:.4e} m ({:.3} µm)",
            e,
            e * 1e6
        );
    }
    if let Some(r) = &est.robust {
        let _ = writeln!(
            s,
            "robust fit: {} loss, c = {} robust σ (σ̂ = {:.3e} m), {} rounds, {} poses down-weighted",
            r.loss, r.tuning, r.scale, r.rounds, r.downweighted
        );
    }
    if !est.worst_poses.is_empty() {
        let shown: Vec<String> = est
            .worst_poses
            .iter()
            .take(5)
            .map(|w| format!("pose {} (line {}) {:.3e} m", w.pose, w.line, w.residual))
            .collect();
        let _ = writeln!(s, "worst poses: {}", shown.join("; "));
    }
    if !est.warnings.is_empty() {
        let _ = writeln!(s, "warnings:");
        for warn in &est.warnings {
            let _ = writeln!(s, "  - {warn}");
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_numbers() {
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(-2.0), "-2");
        assert_eq!(short(1.0 / 3.0), "0.333333");
        assert_eq!(short(1.5e-7), "1.50000e-7");
    }

    #[test]
    fn gauge_strings() {
        let g = vec![("a1".to_string(), 1.0), ("b1".to_string(), -0.5)];
        assert_eq!(gauge_string(&g), "a1 - 0.5·b1");
        assert_eq!(gauge_object(&g)["b1"], -0.5);
    }
}
