//! Reports: what `lincal basis` and `lincal calibrate` print, as JSON and as readable text.
//!
//! The JSON contract of `shared/interface.md` is a pair of types, [`BasisReport`] and
//! [`CalibrateReport`] (serialized by `serde`, fields in the order written): every field the
//! interface lists is a field there, with that name and meaning; the extras are documented on
//! each field. A number that is not finite is `null` (JSON has no NaN).
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

#[cfg(feature = "html")]
pub mod html;

use std::fmt::Write as _;

use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::Value;

use crate::calibrate::estimate::{Estimate, ParamEstimate};
use crate::model::CalibModel;
use crate::spec::{Constraint, Spec};
use crate::symbolic::SymbolicModel;

/// A finite number, `None` (JSON `null`) otherwise.
fn num(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Named entries serialized as one JSON object, in their order (a gauge direction
/// `{param: coefficient}`, the parameters `{name: {...}}`).
#[derive(Clone, Debug, PartialEq)]
pub struct Named<T>(pub Vec<(String, T)>);

impl<T: Serialize> Serialize for Named<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

/// One gauge direction: `{param: coefficient}`.
fn gauge_object(g: &[(String, f64)]) -> Named<Option<f64>> {
    Named(g.iter().map(|(n, c)| (n.clone(), num(*c))).collect())
}

/// A report as a JSON value (a report always serializes: no map has a non-string key).
fn to_value<T: Serialize>(report: &T) -> Value {
    serde_json::to_value(report).unwrap_or(Value::Null)
}

/// One constraint of a spec in a [`BasisReport`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConstraintReport {
    /// Its kind (`line`, `plane`, ...).
    pub kind: &'static str,
    /// How many equations it gives.
    pub equations: usize,
}

/// `lincal basis --format json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BasisReport {
    /// The spec's name.
    pub name: String,
    /// 2 (planar) or 3 (extra).
    pub dim: usize,
    /// Number of joints.
    pub joints: usize,
    /// The estimated parameters' names, spec order.
    pub params: Vec<String>,
    /// Names fixed by the spec (`known: true`) (extra).
    pub known: Vec<String>,
    /// Each constraint's kind and equation count (extra).
    pub constraints: Vec<ConstraintReport>,
    /// Total number of equations `E` (extra).
    pub equations: usize,
    /// Distinct joint monomials before reduction.
    pub naive_size: usize,
    /// `K`, the size of the reduced basis `Φ̃`.
    pub basis_size: usize,
    /// The `K` basis functions.
    pub basis: Vec<String>,
    /// 0-based index of the constant function in `basis`, if any (extra).
    pub constant_index: Option<usize>,
    /// `E` lists of `K` strings: `h_e = Σ_k c_{e,k}·basis_k` (extra).
    pub generalized_params: Vec<Vec<String>>,
    /// Independent parameter combinations the constraint determines.
    pub identifiable_count: usize,
    /// Names identifiable on their own.
    pub identifiable: Vec<String>,
    /// Names that are not.
    pub unidentifiable: Vec<String>,
    /// Names the gauge rule holds at their nominal (extra).
    pub held: Vec<String>,
    /// The directions the data cannot see, `{param: coefficient}` each.
    pub gauge: Vec<Named<Option<f64>>>,
    /// Each relation of the spec and the gauge directions it removes (extra; only when the
    /// spec has `relations:`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub relations: Vec<RelationReport>,
    /// Warnings about the spec.
    pub warnings: Vec<String>,
}

/// One relation in a [`BasisReport`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RelationReport {
    /// `distance`, `same_normal` or `offset`.
    pub kind: &'static str,
    /// The two constraint indices.
    pub between: [usize; 2],
    /// The distance in metres (`null` for `same_normal`).
    pub value: Option<f64>,
    /// The gauge directions of the spec without relations that this relation fixes.
    pub removes: Vec<Named<Option<f64>>>,
}

/// A relation as text, e.g. `distance between constraints 0 and 1 = 0.05 m`.
#[must_use]
pub fn relation_string(r: &crate::model::geometry::Relation) -> String {
    let [i, j] = r.between;
    match r.kind {
        crate::model::geometry::RelationKind::Distance => {
            format!("distance between constraints {i} and {j} = {} m", r.value)
        }
        crate::model::geometry::RelationKind::SameNormal => {
            format!("constraints {i} and {j} parallel (same normal)")
        }
        crate::model::geometry::RelationKind::Offset => {
            format!("constraints {i} and {j} parallel, {} m apart", r.value)
        }
    }
}

impl BasisReport {
    /// The report of `model`.
    #[must_use]
    pub fn new(model: &SymbolicModel) -> Self {
        let spec = model.spec();
        let (identifiable, unidentifiable) = model.identifiable_split();
        let ident = model.identifiability();
        BasisReport {
            name: spec.name.clone(),
            dim: spec.dim,
            joints: spec.joints.len(),
            params: model.param_names().to_vec(),
            known: known_names(spec),
            constraints: spec
                .constraints
                .iter()
                .map(|c| ConstraintReport {
                    kind: c.kind_name(),
                    equations: c.geometry_kind().equation_count(spec.dim),
                })
                .collect(),
            equations: model.equation_count(),
            naive_size: model.naive_size(),
            basis_size: model.basis_names().len(),
            basis: model.basis_names().to_vec(),
            constant_index: model.constant_index(),
            // A model whose exact polynomials were released has none to show.
            generalized_params: model.generalized_param_strings().unwrap_or_default(),
            identifiable_count: ident.count,
            identifiable,
            unidentifiable,
            held: model
                .param_names()
                .iter()
                .zip(&ident.held)
                .filter(|(_, &h)| h)
                .map(|(n, _)| n.clone())
                .collect(),
            gauge: model.gauge().iter().map(|g| gauge_object(g)).collect(),
            relations: spec
                .relations
                .iter()
                .zip(model.relation_gauge())
                .map(|(r, removes)| RelationReport {
                    kind: r.kind.name(),
                    between: r.between,
                    value: r.kind.has_value().then_some(r.value),
                    removes: removes.iter().map(|g| gauge_object(g)).collect(),
                })
                .collect(),
            warnings: model.warnings(),
        }
    }
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

/// Names of the known parameters of a spec.
fn known_names(spec: &Spec) -> Vec<String> {
    spec.params
        .iter()
        .filter(|p| p.known)
        .map(|p| p.name.clone())
        .collect()
}

/// The result of `lincal basis --format json`: [`BasisReport`] as a JSON value.
#[must_use]
pub fn basis_json(model: &SymbolicModel) -> Value {
    to_value(&BasisReport::new(model))
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
    for (e, row) in model
        .generalized_param_strings()
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
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
    let relations = &model.spec().relations;
    if !relations.is_empty() {
        let _ = writeln!(s, "relations (and the gauge directions each one removes):");
        for (i, (r, removes)) in relations.iter().zip(model.relation_gauge()).enumerate() {
            let _ = writeln!(s, "  {}. {}", i + 1, relation_string(r));
            if removes.is_empty() {
                let _ = writeln!(s, "     removes no gauge direction");
            }
            for g in &removes {
                let _ = writeln!(s, "     removes d({})", gauge_string(g));
            }
        }
    }
    for w in model.warnings() {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}

/// One parameter in a [`CalibrateReport`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ParamReport {
    /// The value (calibrated, or the nominal for known and held parameters).
    pub value: Option<f64>,
    /// Its standard deviation; `null` for known and held parameters.
    pub std: Option<f64>,
    /// Whether the data determine it on its own.
    pub identifiable: bool,
    /// Fixed by the spec (`known: true`).
    pub known: bool,
    /// Held at its nominal by the gauge rule (extra).
    pub held: bool,
}

impl From<&ParamEstimate> for ParamReport {
    fn from(p: &ParamEstimate) -> Self {
        ParamReport {
            value: num(p.value),
            std: p.std.and_then(num),
            identifiable: p.identifiable,
            known: p.known,
            held: p.held,
        }
    }
}

/// A pose named in a [`CalibrateReport`] (worst or rejected).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseReport {
    /// 0-based pose index in the data.
    pub pose: usize,
    /// Its CSV line.
    pub line: usize,
    /// Its residual, metres.
    pub residual: Option<f64>,
    /// Its standardised residual (residual over the robust scale times the median of a χ
    /// distribution with the pose's residual components; about 1 for a typical pose), null
    /// when the robust scale is undefined (extra).
    pub standardized: Option<f64>,
}

/// The robust refit in a [`CalibrateReport`] (extra).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RobustReport {
    /// `huber` or `cauchy`.
    pub loss: String,
    /// The loss's tuning constant, in units of the scale.
    pub tuning: Option<f64>,
    /// The robust scale of the residuals, metres.
    pub scale: Option<f64>,
    /// Reweighting rounds of the parameter-space fit (0 when the linear estimate is reported
    /// alone, without refinement).
    pub rounds: usize,
    /// Poses whose weight ended below one half (in the parameter-space fit, or in the linear
    /// solve when its estimate is reported alone).
    pub downweighted: usize,
    /// Reweighted linear solves run (0 when the linear method did not run).
    pub linear_rounds: usize,
    /// Poses whose weight in the linear solve's last round was below one half.
    pub linear_downweighted: usize,
}

/// The linear solve's generalized parameters: one list of `K` numbers per equation, or one
/// flat list when they do not split so.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum GeneralizedParams {
    /// `E` lists of `K` numbers.
    ByEquation(Vec<Vec<Option<f64>>>),
    /// One list.
    Flat(Vec<Option<f64>>),
}

/// `lincal calibrate --format json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CalibrateReport {
    /// The model's name (extra).
    pub name: String,
    /// Every parameter of the spec, `{name: {value, std, identifiable, known, held}}`.
    pub params: Named<ParamReport>,
    /// Independent parameter combinations the constraint determines.
    pub identifiable_count: usize,
    /// `K`, the size of the reduced basis.
    pub basis_size: usize,
    /// Poses used.
    pub poses: usize,
    /// Numerical rank of the data matrix.
    pub rank: usize,
    /// RMS geometric distance of the calibrated tips from the calibrated constraint, metres.
    pub residual_rms: Option<f64>,
    /// `linear`, `linear+refine`, `nominal+refine`.
    pub method: String,
    /// `linear` when the linear method gave the start, `nominal` otherwise.
    pub start: String,
    /// Poses the linear method used, 0 when it did not run (extra).
    pub linear_poses: usize,
    /// Condition number of the column-equilibrated, gauge-fixed Jacobian at the estimate.
    pub condition: Option<f64>,
    /// The poses farthest from the constraint, in descending standardised residual (in
    /// descending residual when that is undefined).
    pub worst_poses: Vec<PoseReport>,
    /// Robust scale of the residuals (median-based), metres (extra).
    pub robust_scale: Option<f64>,
    /// Poses left out by `--reject-outliers` (extra).
    pub rejected: Vec<PoseReport>,
    /// The robust refit of `--robust`, if any (extra).
    pub robust: Option<RobustReport>,
    /// A constraint list's constraints one by one, nominal and calibrated (extra; lists only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub constraints: Vec<crate::calibrate::constraint_fit::ConstraintFit>,
    /// The relations' stated and achieved values (extra; only with `relations:`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub relations: Vec<crate::calibrate::constraint_fit::RelationFit>,
    /// Everything the user should know.
    pub warnings: Vec<String>,
    /// The basis function names (extra).
    pub basis: Vec<String>,
    /// The linear solve's `c` (extra).
    pub generalized_params: GeneralizedParams,
    /// The paper's sec. 5 `err_rms`, metres: planar arms on one line only (extra).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_err_rms: Option<f64>,
}

impl CalibrateReport {
    /// The report of `est`, an estimate of `model`.
    #[must_use]
    pub fn new(model: &dyn CalibModel, est: &Estimate) -> Self {
        let k = est.basis_size;
        let pose = |w: &crate::calibrate::estimate::WorstPose| PoseReport {
            pose: w.pose,
            line: w.line,
            residual: num(w.residual),
            standardized: w.standardized.and_then(num),
        };
        let generalized_params = if k > 0 && est.generalized_params.len().is_multiple_of(k) {
            GeneralizedParams::ByEquation(
                est.generalized_params
                    .chunks(k)
                    .map(|row| row.iter().map(|v| num(*v)).collect())
                    .collect(),
            )
        } else {
            GeneralizedParams::Flat(est.generalized_params.iter().map(|v| num(*v)).collect())
        };
        CalibrateReport {
            name: model.name().to_string(),
            params: Named(
                est.params
                    .iter()
                    .map(|p| (p.name.clone(), ParamReport::from(p)))
                    .collect(),
            ),
            identifiable_count: est.identifiable_count,
            basis_size: est.basis_size,
            poses: est.poses,
            rank: est.rank,
            residual_rms: num(est.residual_rms),
            method: est.method.clone(),
            start: est.start.clone(),
            linear_poses: est.linear_poses,
            condition: est.condition.and_then(num),
            worst_poses: est.worst_poses.iter().map(pose).collect(),
            robust_scale: num(est.robust_scale),
            rejected: est.rejected.iter().map(pose).collect(),
            robust: est.robust.as_ref().map(|r| RobustReport {
                loss: r.loss.clone(),
                tuning: num(r.tuning),
                scale: num(r.scale),
                rounds: r.rounds,
                downweighted: r.downweighted,
                linear_rounds: r.linear_rounds,
                linear_downweighted: r.linear_downweighted,
            }),
            constraints: est.constraints.clone(),
            relations: est.relations.clone(),
            warnings: est.warnings.clone(),
            basis: (0..model.basis_size())
                .map(|i| model.basis_name(i).to_string())
                .collect(),
            generalized_params,
            paper_err_rms: est.paper_err_rms.and_then(num),
        }
    }
}

/// The result of `lincal calibrate --format json`: [`CalibrateReport`] as a JSON value.
#[must_use]
pub fn calibrate_json(model: &dyn CalibModel, est: &Estimate) -> Value {
    to_value(&CalibrateReport::new(model, est))
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
            "robust fit: {} loss, c = {} robust σ (σ̂ = {:.3e} m); linear solve reweighted {} \
             rounds ({} below ½); parameter-space fit {} rounds; {} poses down-weighted",
            r.loss,
            r.tuning,
            r.scale,
            r.linear_rounds,
            r.linear_downweighted,
            r.rounds,
            r.downweighted
        );
    }
    if !est.worst_poses.is_empty() {
        let shown: Vec<String> = est
            .worst_poses
            .iter()
            .take(5)
            .map(|w| {
                let z = w
                    .standardized
                    .map_or(String::new(), |z| format!(", z = {z:.1}"));
                format!("pose {} (line {}) {:.3e} m{z}", w.pose, w.line, w.residual)
            })
            .collect();
        let _ = writeln!(
            s,
            "worst poses{}: {}",
            if est.worst_poses.iter().any(|w| w.standardized.is_some()) {
                " (ranked by z, the standardised residual)"
            } else {
                ""
            },
            shown.join("; ")
        );
    }
    if !est.constraints.is_empty() {
        let _ = writeln!(
            s,
            "per constraint (nominal → calibrated): residual rms; spread of the tips (points)"
        );
        for c in &est.constraints {
            let spread = match (c.spread_nominal, c.spread) {
                (Some(a), Some(b)) => format!("; spread {a:.3e} → {b:.3e} m"),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "  {} {} ({} poses): {:.3e} → {:.3e} m{spread}",
                c.constraint, c.kind, c.poses, c.residual_rms_nominal, c.residual_rms
            );
        }
    }
    if !est.relations.is_empty() {
        let _ = writeln!(s, "relations (stated; nominal → calibrated):");
        for r in &est.relations {
            let [i, j] = r.between;
            let (what, unit) = if r.kind == "same_normal" {
                ("angle between normals".to_string(), "rad")
            } else {
                (format!("{} {}", r.kind, r.value.unwrap_or(f64::NAN)), "m")
            };
            let _ = writeln!(
                s,
                "  {i}–{j} {what}: {:.6} → {:.6} {unit}",
                r.nominal, r.calibrated
            );
        }
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
        assert_eq!(to_value(&gauge_object(&g))["b1"], -0.5);
    }
}
