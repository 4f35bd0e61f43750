//! `lincal.Calibration`, the result of `lincal.calibrate` ([`crate::calibrate`]): the one
//! type that `calibrate`, `Spec` (which takes a result as `params`) and `compensate` share.

use lincal_core::calibrate::estimate::Estimate;
use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use crate::convert;
use crate::errors;

/// The result of `lincal.calibrate`: the calibrated parameters with their standard
/// deviations, the residual of every pose, and the figures of `lincal calibrate --format
/// json` (`to_dict()`, `to_json()` give exactly that JSON).
#[pyclass(module = "lincal", frozen)]
pub struct Calibration {
    pub(crate) estimate: Estimate,
    pub(crate) json: Value,
    pub(crate) residuals: Py<PyArray1<f64>>,
    /// For a `measured_pose` spec, each pose's orientation error (radians).
    pub(crate) orientation_residuals: Option<Py<PyArray1<f64>>>,
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
    /// when the result was made from another spec: of another name (the parameter names may
    /// match while the robots differ, as the CLI refuses a result file), or other parameters.
    pub fn estimated_values(&self, model: &SymbolicModel) -> PyResult<Vec<f64>> {
        if let Some(name) = self.json.get("name").and_then(Value::as_str) {
            if name != model.name() {
                let (a, b) = (
                    lincal_core::error::excerpt(name),
                    lincal_core::error::excerpt(model.name()),
                );
                return Err(Python::attach(|py| {
                    errors::input_error(
                        py,
                        "params",
                        &format!(
                            "the Calibration is of spec `{a}`, not of this spec `{b}`: its values \
                             are used only with the spec they were calibrated with; calibrate \
                             with this spec for its own result, or, for the same robot's spec \
                             renamed, pass its `.values` (a dict name -> value)"
                        ),
                    )
                }));
            }
        }
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

    /// `"linear"` or `"linear+refine"` (`start` says whether the fit began at the linear
    /// estimate or the nominals).
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

    /// The poses farthest from their constraint: dicts {pose, line, residual, standardized},
    /// the 10 of largest standardised residual, listed in descending residual.
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
