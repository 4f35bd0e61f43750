//! `lincal.calibrate` and its result, `lincal.Calibration`.

use lincal_core::calibrate::estimate::Estimate;
use lincal_core::calibrate::{
    calibrate_spec, pose_residuals,
    prior::{
        out_of_range, PriorChoice, PriorScale, PriorShape, DEFAULT_ANGLE_TOLERANCE,
        DEFAULT_LENGTH_TOLERANCE, TOLERANCE_RANGE, WEIGHT_RANGE,
    },
    CalibrateOptions, Robust, StartChoice,
};
use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use crate::arrays;
use crate::convert;
use crate::errors::{self, guarded, Origin};
use crate::spec::PySpec;

/// The result of `lincal.calibrate`: the calibrated parameters with their standard
/// deviations, the residual of every pose, and the figures of `lincal calibrate --format
/// json` (`to_dict()`, `to_json()` give exactly that JSON).
#[pyclass(module = "lincal", frozen)]
pub struct Calibration {
    estimate: Estimate,
    json: Value,
    residuals: Py<PyArray1<f64>>,
    /// For a `measured_pose` spec, each pose's orientation error (radians).
    orientation_residuals: Option<Py<PyArray1<f64>>>,
}

impl Calibration {
    /// The covariance of the estimated parameters in `model`'s order, for `compensate`'s
    /// predicted uncertainty: the full matrix when the fit gave one, otherwise the standard
    /// deviations (correlations left out).
    pub fn param_covariance(
        &self,
        model: &SymbolicModel,
    ) -> lincal_core::compensate::ParamCovariance {
        use lincal_core::compensate::ParamCovariance;
        let names: Vec<&str> = (0..model.param_count())
            .map(|j| model.param_name(j))
            .collect();
        let np = names.len();
        if let Some(cov) = &self.estimate.covariance {
            let index: Vec<Option<usize>> = cov
                .params
                .iter()
                .map(|n| names.iter().position(|m| m == n))
                .collect();
            let mut full = vec![0.0; np * np];
            for (a, row) in cov.matrix.iter().enumerate() {
                for (b, &x) in row.iter().enumerate() {
                    if let (Some(Some(i)), Some(Some(j))) = (index.get(a), index.get(b)) {
                        full[i * np + j] = x;
                    }
                }
            }
            return ParamCovariance::Full(full);
        }
        let std: Vec<Option<f64>> = names
            .iter()
            .map(|n| {
                self.estimate
                    .params
                    .iter()
                    .find(|p| p.name == *n)
                    .and_then(|p| p.std)
            })
            .collect();
        ParamCovariance::from_std(&std)
    }

    /// The estimated parameters' values (known ones left out), in `model`'s order; an error
    /// when the result was made from another spec.
    pub fn estimated_values(&self, model: &SymbolicModel) -> PyResult<Vec<f64>> {
        let v: Vec<(&str, f64)> = self
            .estimate
            .params
            .iter()
            .filter(|p| !p.known)
            .map(|p| (p.name.as_str(), p.value))
            .collect();
        let same = v.len() == model.param_count()
            && v.iter()
                .enumerate()
                .all(|(j, (n, _))| *n == model.param_name(j));
        if !same {
            return Err(Python::attach(|py| {
                errors::input_error(
                    py,
                    "params",
                    "the Calibration is of a spec with other parameters",
                )
            }));
        }
        Ok(v.into_iter().map(|(_, x)| x).collect())
    }

    fn field(&self, py: Python<'_>, key: &str) -> PyResult<Py<PyAny>> {
        convert::to_python(py, self.json.get(key).unwrap_or(&Value::Null))
    }
}

#[pymethods]
impl Calibration {
    /// Every parameter of the spec (spec order): name -> {value, std, identifiable, known,
    /// held}. `std` is None for known and held parameters; held ones are fixed at their
    /// nominal by the gauge rule, so that every identifiable combination is right.
    #[getter]
    fn params(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "params")
    }

    /// Every parameter's calibrated value, name -> value (spec order); accepted as `params`
    /// by `Spec.tip` and `Spec.residuals`.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for p in &self.estimate.params {
            d.set_item(&p.name, p.value)?;
        }
        Ok(d)
    }

    /// The geometric distance of every pose's calibrated tip from the calibrated constraint,
    /// metres: an (N,) read-only array, in the order of `q` (rejected poses included). For a
    /// `measured_pose` spec, the position error `‖x − x_measured‖` of each pose (the
    /// orientation error is `orientation_residuals`).
    #[getter]
    fn residuals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.residuals.bind(py).clone()
    }

    /// RMS geometric distance of the calibrated tips from the calibrated constraint, metres
    /// (for a `measured_pose` spec, the RMS position error over the poses kept).
    #[getter]
    fn residual_rms(&self) -> f64 {
        self.estimate.residual_rms
    }

    /// For a `measured_pose` spec, the RMS over the poses kept of the orientation error
    /// `‖log(R_measuredᵀ·R)‖`, radians; None for other specs (and when not finite).
    #[getter]
    fn orientation_rms(&self) -> Option<f64> {
        self.estimate.orientation_rms
    }

    /// For a `measured_pose` spec, each pose's orientation error `‖log(R_measuredᵀ·R)‖`
    /// (radians): an (N,) read-only array in the order of `q` (rejected poses included);
    /// None for other specs.
    #[getter]
    fn orientation_residuals<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.orientation_residuals
            .as_ref()
            .map(|a| a.bind(py).clone())
    }

    /// For a `measured_pose` spec, the noise the fit weighed position and orientation by: a
    /// dict {position_std (m), orientation_std (rad), weight (m/rad, position_std /
    /// orientation_std, or the bound of 1e-4..1e4 it is held at), held_ratio (that ratio
    /// when the weight is held, else None), estimated (the levels estimated from the data:
    /// "position", "orientation"; empty when the spec states both), rounds
    /// (variance-component rounds)}.
    /// An estimated level is None when the data cannot estimate it (exact data). None for
    /// other specs.
    #[getter]
    fn pose_noise(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "pose_noise")
    }

    /// K, the size of the basis; `None` when the fit started from the nominals and the
    /// basis was too large to build only for this report (`Spec.basis()` computes it).
    #[getter]
    fn basis_size(&self) -> Option<usize> {
        self.estimate.basis_size
    }

    /// Numerical rank of the data matrix.
    #[getter]
    fn rank(&self) -> usize {
        self.estimate.rank
    }

    /// Number of independent identifiable combinations.
    #[getter]
    fn identifiable_count(&self) -> usize {
        self.estimate.identifiable_count
    }

    /// Poses used.
    #[getter]
    fn poses(&self) -> usize {
        self.estimate.poses
    }

    /// `"linear"`, `"linear+refine"` or `"nominal+refine"`.
    #[getter]
    fn method(&self) -> String {
        self.estimate.method.clone()
    }

    /// `"linear"` when the linear method gave the start, `"nominal"` otherwise.
    #[getter]
    fn start(&self) -> String {
        self.estimate.start.clone()
    }

    /// Condition number of the column-equilibrated, gauge-fixed Jacobian at the estimate.
    #[getter]
    fn condition(&self) -> Option<f64> {
        self.estimate.condition
    }

    /// Human-readable warnings (the spec's and the fit's).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.estimate.warnings.clone()
    }

    /// The poses farthest from their constraint, in descending standardised residual: dicts
    /// {pose, line, residual, standardized}.
    #[getter]
    fn worst_poses(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "worst_poses")
    }

    /// What the weak-direction prior did: dict {weight, length_tolerance, angle_tolerance,
    /// shape, applied, sigma, weak}.
    #[getter]
    fn prior(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "prior")
    }

    /// Poses dropped by `reject_outliers=True`: dicts {pose, line, residual, standardized}.
    #[getter]
    fn rejected(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "rejected")
    }

    /// Every field, as `lincal calibrate SPEC DATA --format json` prints it.
    fn to_dict(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        convert::to_python(py, &self.json)
    }

    /// The JSON text of `lincal calibrate SPEC DATA --format json` (without its final
    /// newline).
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(&self.json).unwrap_or_default()
    }

    fn __repr__(&self) -> String {
        let values: Vec<String> = self
            .estimate
            .params
            .iter()
            .map(|p| format!("{}={:.6}", p.name, p.value))
            .collect();
        let orientation = self
            .estimate
            .orientation_rms
            .map(|o| format!(", orientation_rms={o:.3e}"))
            .unwrap_or_default();
        format!(
            "Calibration(method={:?}, poses={}, residual_rms={:.3e}{orientation}, params={{{}}}, \
             warnings={})",
            self.estimate.method,
            self.estimate.poses,
            self.estimate.residual_rms,
            values.join(", "),
            self.estimate.warnings.len()
        )
    }
}

/// What a calibration hands back from its worker thread: the estimate, each pose's residual
/// (for measured poses its position error), each measured pose's orientation error, and the
/// JSON.
type Fitted = (Estimate, Vec<f64>, Option<Vec<f64>>, Value);

/// Parses the `robust` argument.
fn robust_of(py: Python<'_>, robust: Option<&str>) -> PyResult<Option<Robust>> {
    match robust {
        None => Ok(None),
        Some("huber") => Ok(Some(Robust::Huber)),
        Some("cauchy") => Ok(Some(Robust::Cauchy)),
        Some(other) => Err(errors::input_error(
            py,
            "robust",
            &format!("`{other}` is not a robust loss: expected None, \"huber\" or \"cauchy\""),
        )),
    }
}

/// The weak-direction prior of the `prior` (`True`/`"frames"`, `"params"`, `False`/`"off"`),
/// `prior_weight`, `tolerance_length`, `tolerance_angle` arguments (each within its accepted
/// range; a weight and tolerances together are refused). Tolerances given make a fixed
/// prior (the other one 0.01 when left out), a weight a relative one; neither, the data
/// choose the strength (the default).
pub(crate) fn prior_of(
    py: Python<'_>,
    prior: Option<&Bound<'_, PyAny>>,
    length: Option<f64>,
    angle: Option<f64>,
    weight: Option<f64>,
) -> PyResult<PriorChoice> {
    for (name, v, range) in [
        ("tolerance_length", length, TOLERANCE_RANGE),
        ("tolerance_angle", angle, TOLERANCE_RANGE),
        ("prior_weight", weight, WEIGHT_RANGE),
    ] {
        if let Some(why) = v.and_then(|v| out_of_range(v, range)) {
            return Err(errors::input_error(py, name, &why));
        }
    }
    let scale = match (length, angle, weight) {
        (None, None, None) => PriorScale::Auto,
        (None, None, Some(w)) => PriorScale::Weight(w),
        (_, _, Some(_)) => {
            return Err(errors::input_error(
                py,
                "prior_weight",
                "give a weight or tolerances, not both",
            ))
        }
        (l, a, None) => PriorScale::Tolerances {
            length: l.unwrap_or(DEFAULT_LENGTH_TOLERANCE),
            angle: a.unwrap_or(DEFAULT_ANGLE_TOLERANCE),
        },
    };
    let shape = match prior {
        None => Some(PriorShape::Frames),
        Some(p) => match p.extract::<bool>() {
            Ok(on) => on.then_some(PriorShape::Frames),
            Err(_) => match p.extract::<String>().ok().as_deref() {
                Some("frames" | "on") => Some(PriorShape::Frames),
                Some("params") => Some(PriorShape::Params),
                Some("off") => None,
                _ => {
                    return Err(errors::input_error(
                        py,
                        "prior",
                        "expected True, False, \"frames\", \"params\" or \"off\"",
                    ))
                }
            },
        },
    };
    Ok(match shape {
        Some(shape) => PriorChoice::On { scale, shape },
        None => PriorChoice::Off,
    })
}

/// Parses the `start` argument.
fn start_of(py: Python<'_>, start: &str) -> PyResult<StartChoice> {
    match start {
        "auto" => Ok(StartChoice::Auto),
        "linear" => Ok(StartChoice::Linear),
        "nominal" => Ok(StartChoice::Nominal),
        other => Err(errors::input_error(
            py,
            "start",
            &format!("`{other}` is not a start: expected \"auto\", \"linear\" or \"nominal\""),
        )),
    }
}

/// Calibrates `spec` on joint readings `q`, an (N, n) float64 array (one pose per row, joints
/// in spec order), exactly as `lincal calibrate` does.
///
/// `x`: (N, dim) measured tips, for `measured` and `measured_pose` constraints (NaN rows on
/// poses whose constraint is not measured); `quaternion`: (N, 4) the measured orientations
/// of a `measured_pose` spec as unit quaternions, scalar first (`qw, qx, qy, qz`; a norm off
/// 1 by more than 1e-3 is refused, within it normalised), or `rotvec`: (N, 3) the same as
/// rotation vectors (`rx, ry, rz`, radians), one form only; `constraint`: (N,) 0-based constraint index of each pose, for
/// a spec with a list (`constraints:`); `refine`: Levenberg-Marquardt on the geometric
/// residual from the linear estimate; `robust`: None, `"huber"` or `"cauchy"`; `start`:
/// `"auto"`, `"linear"` or `"nominal"`; `reject_outliers`: drop poses beyond 5 robust
/// standard deviations and fit again; `lines`: (N,) line numbers named in warnings and
/// `worst_poses` (0 when not given); `prior` (`True` or `"frames"`: each joint's mounting,
/// the default; `"params"`: each parameter; `False` or `"off"`), its strength chosen from
/// the data by default, or `prior_weight` (MUKCa's relative weight against the mean squared
/// residual per pose), or fixed `tolerance_length` (m),
/// `tolerance_angle` (rad): the weak-direction prior of `--prior`, `--prior-weight`,
/// `--tolerance-length`, `--tolerance-angle` (the result's `to_dict()["prior"]` says what it
/// did).
///
/// Raises DataError (a ValueError) for a bad array (shape, dtype, NaN, index, a non-unit
/// quaternion, both orientation forms), naming the argument, row and column; DegenerateError (a ValueError) when the poses cannot determine the
/// parameters; ComputationError on a numerical failure.
#[pyfunction]
#[pyo3(signature = (spec, q, *, x = None, quaternion = None, rotvec = None, constraint = None,
                    refine = false, robust = None,
                    start = "auto", reject_outliers = false, lines = None,
                    prior = None, prior_weight = None,
                    tolerance_length = None, tolerance_angle = None))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate(
    py: Python<'_>,
    spec: &Bound<'_, PySpec>,
    q: &Bound<'_, PyAny>,
    x: Option<&Bound<'_, PyAny>>,
    quaternion: Option<&Bound<'_, PyAny>>,
    rotvec: Option<&Bound<'_, PyAny>>,
    constraint: Option<&Bound<'_, PyAny>>,
    refine: bool,
    robust: Option<&str>,
    start: &str,
    reject_outliers: bool,
    lines: Option<&Bound<'_, PyAny>>,
    prior: Option<&Bound<'_, PyAny>>,
    prior_weight: Option<f64>,
    tolerance_length: Option<f64>,
    tolerance_angle: Option<f64>,
) -> PyResult<Calibration> {
    let loaded = spec.get().inner.clone();
    let model = &loaded.model;
    let opts = CalibrateOptions {
        refine,
        start: start_of(py, start)?,
        reject_outliers,
        robust: robust_of(py, robust)?,
        prior: prior_of(py, prior, tolerance_length, tolerance_angle, prior_weight)?,
    };
    let poses = arrays::poses(
        py,
        model,
        model.spec().constraint_list,
        q,
        x,
        arrays::Orientation { quaternion, rotvec },
        constraint,
        lines,
    )?;
    let pose = arrays::is_pose_model(model);
    // On a worker thread, so that Ctrl-C stops the fit within an iteration.
    let outcome = errors::interruptible(py, || {
        guarded(|| -> lincal_core::error::Result<Fitted> {
            // What `lincal calibrate` does (src/main.rs): the fit, then the spec's warnings.
            let mut est = calibrate_spec(model, model.spec(), &poses, opts)?;
            est.warnings.extend(model.warnings());
            let p: Vec<f64> = est
                .params
                .iter()
                .filter(|p| !p.known)
                .map(|p| p.value)
                .collect();
            // A measured pose: its position and orientation errors apart (the core's
            // residual mixes them by the fit's weight).
            let (residuals, orientation) = if pose {
                let (position, orientation) = arrays::pose_errors(model, &poses, &p);
                (position, Some(orientation))
            } else {
                (pose_residuals(model, &poses, &p)?, None)
            };
            let json = lincal_core::report::calibrate_json(model, &est);
            Ok((est, residuals, orientation, json))
        })
    });
    let (estimate, residuals, orientation, json) = outcome?
        .map_err(|()| errors::internal(py, "calibrate"))?
        .map_err(|e| errors::to_py(py, &e, Origin::Data))?;
    let read_only = |v: Vec<f64>| -> PyResult<Py<PyArray1<f64>>> {
        let a = numpy::IntoPyArray::into_pyarray(v, py);
        a.getattr("flags")
            .and_then(|f| f.setattr("writeable", false))?;
        Ok(a.unbind())
    };
    Ok(Calibration {
        estimate,
        json,
        residuals: read_only(residuals)?,
        orientation_residuals: orientation.map(read_only).transpose()?,
    })
}
