//! The JSON reports: [`BasisReport`] (`lincal basis --format json`) and [`CalibrateReport`]
//! (`lincal calibrate --format json`), serialized by `serde` with their fields in the order
//! written.
//!
//! Takes a model (and an estimate); gives the report types and their JSON values, every
//! number that is not finite as `null`.

use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::Value;

use crate::calibrate::estimate::{Estimate, ParamEstimate};
use crate::model::CalibModel;
use crate::spec::Spec;
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

/// The spec's warnings, and where `c(p)` was not expanded, why.
fn basis_warnings(model: &SymbolicModel) -> Vec<String> {
    let mut w = model.warnings();
    if let Some(route) = model.unexpanded_route() {
        w.push(format!(
            "generalized_params is empty: the basis {route} (the direct \
             expansion was beyond its bound, or c(p) beyond the terms printed), which leaves c(p) in factored form; the run-time \
             model and #[derive(CalibModel)] evaluate it from the chain"
        ));
    }
    w
}

/// One gauge direction: `{param: coefficient}`.
pub(crate) fn gauge_object(g: &[(String, f64)]) -> Named<Option<f64>> {
    Named(g.iter().map(|(n, c)| (n.clone(), num(*c))).collect())
}

/// A report as a JSON value (a report always serializes: no map has a non-string key).
pub(crate) fn to_value<T: Serialize>(report: &T) -> Value {
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
    /// `E` lists of `K` strings: `h_e = Σ_k c_{e,k}·basis_k` (extra); empty when they are
    /// beyond the reports' bound (`generalized_params_terms` says how large).
    pub generalized_params: Vec<Vec<String>>,
    /// The terms of every polynomial of `c(p)` together, when they are too many to print
    /// (beyond [`crate::symbolic::model::REPORT_C_TERMS`]); absent otherwise (extra).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generalized_params_terms: Option<usize>,
    /// Where `c(p)` is left in factored form, the proof that the tables the derive and the
    /// run-time model evaluate it with give the model's constraint functions (extra; absent
    /// where `c(p)` is printed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub factored_certificate: Option<CertificateReport>,
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

/// The certificate of a model's factored tables in a [`BasisReport`]
/// ([`crate::symbolic::certify`]): `Σ_k c_{e,k}(p)·Φ̃_k(q) = h_e(q; p)` exactly modulo
/// `2⁶¹ − 1` at random points.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CertificateReport {
    /// Independent random points checked.
    pub points: usize,
    /// Equations checked at each.
    pub equations: usize,
    /// Whether `∂c/∂p` was proven too (`Σ_k ∂c_{e,k}/∂p_j·Φ̃_k = ∂h_e/∂p_j`, which also
    /// proves which parameter each motion of the tables reads); `c(p)` alone beyond
    /// [`crate::symbolic::certify::CERTIFY_MAX_VALUES`] values of `∂c/∂p`.
    pub jacobian: bool,
    /// The probability that wrong tables pass, at most.
    pub failure_bound: f64,
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
            generalized_params_terms: model
                .generalized_param_terms()
                .filter(|&t| t > crate::symbolic::model::REPORT_C_TERMS),
            factored_certificate: model.factored_certificate().and_then(Result::ok).map(|c| {
                CertificateReport {
                    points: c.points,
                    equations: c.equations,
                    jacobian: c.jacobian,
                    failure_bound: c.failure_bound,
                }
            }),
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
            warnings: basis_warnings(model),
        }
    }
}

/// Names of the known parameters of a spec.
pub(crate) fn known_names(spec: &Spec) -> Vec<String> {
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

/// The worst poses in the contract's order, descending residual (`shared/interface.md`):
/// the poses are chosen by their standardised residual `z` (a bad plane pose among clean
/// point poses, whose norms add three noise components), then listed by residual.
fn by_residual(mut poses: Vec<PoseReport>) -> Vec<PoseReport> {
    let key = |p: &PoseReport| p.residual.unwrap_or(f64::NEG_INFINITY);
    poses.sort_by(|a, b| key(b).total_cmp(&key(a)));
    poses
}

/// A pose named in a [`CalibrateReport`] (worst or rejected).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseReport {
    /// 0-based pose index in the data.
    pub pose: usize,
    /// Its CSV line.
    pub line: usize,
    /// Its data file, when several were given (extra; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Its residual, metres.
    pub residual: Option<f64>,
    /// Its standardised residual (residual over the robust scale times the median of a χ
    /// distribution with the pose's residual components; about 1 for a typical pose), null
    /// when the robust scale is undefined (extra).
    pub standardized: Option<f64>,
    /// A measured pose's position error, metres (extra; absent for other constraints):
    /// `residual` weighs it with the orientation error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position: Option<f64>,
    /// A measured pose's orientation error `‖log(R_mᵀR)‖`, radians (extra; absent for
    /// other constraints).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation: Option<f64>,
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
    /// `K`, the size of the reduced basis; `null` after a fit from the nominals whose basis
    /// is beyond [`crate::symbolic::REPORT_MAX_TERMS`] (`lincal basis` gives it).
    pub basis_size: Option<usize>,
    /// Poses used.
    pub poses: usize,
    /// Numerical rank of the data matrix.
    pub rank: usize,
    /// RMS geometric distance of the calibrated tips from the calibrated constraint, metres
    /// (for measured poses, of the position error).
    pub residual_rms: Option<f64>,
    /// For measured poses (`measured_pose`): the RMS orientation error `‖log(R_mᵀR)‖`,
    /// radians.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_rms: Option<f64>,
    /// For measured poses: the noise levels (stated or estimated) and the orientation weight
    /// the fit used (extra).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pose_noise: Option<crate::calibrate::estimate::PoseNoise>,
    /// The estimated parameters' covariance `{params, matrix}` when the fit gave one (extra;
    /// `compensate` reads it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub covariance: Option<crate::calibrate::estimate::ParamCovarianceReport>,
    /// `linear` or `linear+refine` (the contract's two; `start` says where the fit began).
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
    /// The weak-direction prior: its tolerances, whether it was applied, the noise level it
    /// was scaled with and the parameters that were weak (extra; see
    /// [`crate::calibrate::prior`]).
    pub prior: crate::calibrate::prior::PriorReport,
    /// A constraint list's constraints one by one, nominal and calibrated (extra; lists only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub constraints: Vec<crate::calibrate::constraint_fit::ConstraintFit>,
    /// The relations' stated and achieved values (extra; only with `relations:`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub relations: Vec<crate::calibrate::constraint_fit::RelationFit>,
    /// Each pair of pinned points of a list: the distance between the means of their
    /// predicted tips, nominal and calibrated (extra; only with two points or more).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub point_distances: Vec<crate::calibrate::constraint_fit::PointDistance>,
    /// Held-out placements of `--validate`, calibrated beside nominal (extra; only when asked).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub validation: Vec<crate::calibrate::validation::Evaluation>,
    /// k-fold cross-validation of `--folds` (extra; only when asked).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_validation: Option<crate::calibrate::validation::CrossValidation>,
    /// Each plane by normal and offset, unit-normalised: `{constraint, normal, offset, scale}`
    /// with `normal = n/‖n‖`, `offset = d/‖n‖` (metres) and `scale = ‖n‖` of the fitted
    /// parameters (extra; only for `plane: {normal, offset}`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<crate::calibrate::plane_fit::PlaneFit>,
    /// Each joint's range of readings over the poses the fit used, `{min, max}` (radians,
    /// metres for a prismatic joint; extra): `predict`, `evaluate` and `compensate` name the
    /// poses beyond it, where the calibration extrapolates.
    pub joint_ranges: Vec<crate::calibrate::joint_ranges::JointRange>,
    /// Everything the user should know.
    pub warnings: Vec<String>,
    /// The basis function names of the linear solve (extra; empty after a start from the
    /// nominals).
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
        let k = est.basis_size.unwrap_or(0);
        let pose = |w: &crate::calibrate::estimate::WorstPose| PoseReport {
            pose: w.pose,
            line: w.line,
            file: w.file.clone(),
            residual: num(w.residual),
            standardized: w.standardized.and_then(num),
            position: w.pose_parts.and_then(|(x, _)| num(x)),
            orientation: w.pose_parts.and_then(|(_, a)| num(a)),
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
            orientation_rms: est.orientation_rms.and_then(num),
            pose_noise: est.pose_noise.clone(),
            covariance: est.covariance.clone(),
            method: est.method.clone(),
            start: est.start.clone(),
            linear_poses: est.linear_poses,
            condition: est.condition.and_then(num),
            worst_poses: by_residual(est.worst_poses.iter().map(pose).collect()),
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
            prior: est.prior.clone(),
            constraints: est.constraints.clone(),
            relations: est.relations.clone(),
            point_distances: est.point_distances.clone(),
            validation: est.validation.clone(),
            cross_validation: est.cross_validation.clone(),
            planes: est.planes.clone(),
            joint_ranges: est.joint_ranges.clone(),
            warnings: est.warnings.clone(),
            // The basis the linear solve used, beside its `c`; a fit from the nominals used
            // none (and naming one would build it).
            basis: if est.start == "linear" {
                (0..k).map(|i| model.basis_name(i).to_string()).collect()
            } else {
                Vec::new()
            },
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
