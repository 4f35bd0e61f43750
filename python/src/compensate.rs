//! `lincal.compensate`: the joints (and the filtered Cartesian targets) a controller that keeps
//! its nominal model needs, so that the calibrated arm reaches the intended tool: the core's
//! `compensate`, as `lincal compensate` runs it, numpy in and out.

use lincal_core::compensate::{
    Compensator, Outcome, ParamCovariance, Summary, TargetForm, Targets,
};
use lincal_core::data::{PoseColumn, Poses, Rows};
use lincal_core::model::rotation::quaternion_from_matrix;
use lincal_core::model::CalibModel;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use serde_json::Value;

use crate::arrays::{self, Orientation};
use crate::convert;
use crate::errors::{self, data_error, guarded, Origin};
use crate::params::param_values;
use crate::result::Calibration;
use crate::spec::PySpec;

/// The compensated targets, one row per target in input order (`lincal compensate`'s columns
/// as arrays).
#[pyclass(module = "lincal", frozen)]
pub struct Compensation {
    q: Py<PyArray2<f64>>,
    x: Py<PyArray2<f64>>,
    quaternion: Option<Py<PyArray2<f64>>>,
    correction: Py<PyArray1<f64>>,
    residual: Py<PyArray1<f64>>,
    orientation_residual: Py<PyArray1<f64>>,
    sigma: Py<PyArray1<f64>>,
    status: Vec<&'static str>,
    summary: Value,
}

#[pymethods]
impl Compensation {
    /// The compensated joints `q′` (N, n): send these to the controller. A failed row holds
    /// the solve's last point, not to be sent (see `status`).
    #[getter]
    fn q(&self, py: Python<'_>) -> Py<PyArray2<f64>> {
        self.q.clone_ref(py)
    }

    /// The filtered Cartesian targets `FK_nominal(q′)` (N, dim), for a controller that takes
    /// Cartesian targets and solves them with its nominal model.
    #[getter]
    fn x(&self, py: Python<'_>) -> Py<PyArray2<f64>> {
        self.x.clone_ref(py)
    }

    /// The filtered targets' orientation as unit quaternions (N, 4: qw, qx, qy, qz), when the
    /// spec's tool is a frame (`measured_pose`); otherwise None.
    #[getter]
    fn quaternion(&self, py: Python<'_>) -> Option<Py<PyArray2<f64>>> {
        self.quaternion.as_ref().map(|a| a.clone_ref(py))
    }

    /// `‖q′ − q₀‖` per target (radians; metres for prismatic joints).
    #[getter]
    fn correction(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.correction.clone_ref(py)
    }

    /// The remaining position error `‖x* − FK_calibrated(q′)‖` per target, metres.
    #[getter]
    fn residual(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.residual.clone_ref(py)
    }

    /// The remaining orientation error of pose targets, radians (0 otherwise).
    #[getter]
    fn orientation_residual(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.orientation_residual.clone_ref(py)
    }

    /// The calibration's predicted tool position uncertainty at `q′`, metres
    /// (`√tr(J_p Σ_p J_pᵀ)`; 0 with nominal parameters or a parameter list).
    #[getter]
    fn sigma(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.sigma.clone_ref(py)
    }

    /// Each target's status: `ok`, `limit`, `singular`, `branch` or `diverged`.
    #[getter]
    fn status(&self) -> Vec<&'static str> {
        self.status.clone()
    }

    /// How many targets did not end `ok`.
    #[getter]
    fn failed(&self) -> usize {
        self.status.iter().filter(|s| **s != "ok").count()
    }

    /// The summary `lincal compensate --format json` prints (counts, failures, worst rows;
    /// `line` is the row index here).
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        convert::to_python(py, &self.summary)
    }

    fn __len__(&self) -> usize {
        self.status.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Compensation(targets={}, failed={})",
            self.status.len(),
            self.failed()
        )
    }
}

/// The estimated parameters and their covariance from `params`: a Calibration (its values
/// and covariance), or anything `param_values` takes (no covariance: `sigma` is 0).
fn parameters(
    py: Python<'_>,
    spec: &PySpec,
    params: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Vec<f64>, ParamCovariance)> {
    let model = &spec.inner.model;
    let p = param_values(py, &spec.inner.model, params)?;
    let cov = match params.map(|b| b.cast::<Calibration>()) {
        Some(Ok(c)) => c.get().param_covariance(model),
        _ => ParamCovariance::None,
    };
    Ok((p, cov))
}

/// The targets from the arrays: seeds `q`, with `x` (and an orientation for a frame tool)
/// Cartesian goals, without them joint targets.
fn targets(
    py: Python<'_>,
    c: &Compensator,
    model: &dyn CalibModel,
    q: &Bound<'_, PyAny>,
    x: Option<&Bound<'_, PyAny>>,
    orientation: Orientation<'_, '_>,
) -> PyResult<Targets> {
    let (n_joints, dim) = (c.joints(), c.dim());
    let q_arr = arrays::float_rows(py, q, "q", n_joints, &arrays::joint_names(model))?;
    let qrows = arrays::rows(py, &q_arr, "q", &|col| format!("q{}", col + 1), None)?;
    let n = qrows.len();
    let given = orientation.quaternion.is_some() || orientation.rotvec.is_some();
    let Some(x) = x else {
        if given {
            return Err(data_error(
                py,
                Some(if orientation.quaternion.is_some() {
                    "quaternion"
                } else {
                    "rotvec"
                }),
                None,
                "an orientation without `x`: a pose target is `x` with `quaternion` or \
                 `rotvec`; joint targets are `q` alone",
            ));
        }
        return Ok(Targets {
            poses: poses(qrows, None),
            form: TargetForm::Joints,
            dim,
        });
    };
    let names = ["x", "y", "z"];
    let x_arr = arrays::float_rows(py, x, "x", dim, &convert::names(&names[..dim]))?;
    let xrows = arrays::rows(py, &x_arr, "x", &|col| names[col].to_string(), None)?;
    if xrows.len() != n {
        return Err(data_error(
            py,
            Some("x"),
            None,
            &format!(
                "`x` has {} rows, `q` has {n}: one target per seed",
                xrows.len()
            ),
        ));
    }
    if c.is_pose() != given {
        let message = if c.is_pose() {
            "the spec's tool is a frame (`measured_pose`): a Cartesian target needs its \
             orientation, `quaternion` (N, 4) or `rotvec` (N, 3), beside `x`"
        } else {
            "the spec's tool is a point: leave the orientation out (positions only)"
        };
        return Err(data_error(py, Some("x"), None, message));
    }
    let rot = if given {
        Some(arrays::rotations(py, orientation, n, &|_| false)?)
    } else {
        None
    };
    let width = dim + if given { 9 } else { 0 };
    let mut measured = Rows::new(width);
    measured.reserve(n);
    let mut row = vec![0.0; width];
    for l in 0..n {
        row[..dim].copy_from_slice(&xrows[l]);
        if let Some(Some(r)) = rot.as_ref().map(|r| r[l]) {
            row[dim..].copy_from_slice(&r);
        }
        measured.push(&row);
    }
    Ok(Targets {
        poses: poses(qrows, Some(measured)),
        form: if given {
            TargetForm::Pose
        } else {
            TargetForm::Position
        },
        dim,
    })
}

fn poses(q: Rows, measured: Option<Rows>) -> Poses {
    Poses {
        q,
        measured,
        constraint: PoseColumn::labels(),
        line: PoseColumn::counting(),
        files: Default::default(),
    }
}

/// The arrays of the outcomes.
fn compensation(py: Python<'_>, c: &Compensator, outcomes: &[Outcome]) -> PyResult<Compensation> {
    let (n, dim) = (c.joints(), c.dim());
    let q: Vec<f64> = outcomes.iter().flat_map(|o| o.q.iter().copied()).collect();
    let x: Vec<f64> = outcomes
        .iter()
        .flat_map(|o| o.filtered.x[..dim].to_vec())
        .collect();
    let quaternion = if c.is_pose() {
        let v: Vec<f64> = outcomes
            .iter()
            .flat_map(|o| quaternion_from_matrix(&o.filtered.rot))
            .collect();
        Some(arrays::array2(py, v, 4)?.unbind())
    } else {
        None
    };
    let column = |f: &dyn Fn(&Outcome) -> f64| {
        PyArray1::from_vec(py, outcomes.iter().map(f).collect()).unbind()
    };
    let summary = Summary::new(outcomes, |l| l).to_json();
    Ok(Compensation {
        q: arrays::array2(py, q, n)?.unbind(),
        x: arrays::array2(py, x, dim)?.unbind(),
        quaternion,
        correction: column(&|o| o.correction),
        residual: column(&|o| o.residual),
        orientation_residual: column(&|o| o.orientation_residual),
        sigma: column(&|o| o.sigma),
        status: outcomes.iter().map(|o| o.verdict.status.as_str()).collect(),
        summary,
    })
}

/// Compensates targets for a controller that keeps its nominal model (`lincal compensate`).
///
/// `params`: a Calibration (its values; its covariance gives `sigma`), a dict name -> value,
/// P numbers, or None (the nominals). `q` (N, n): joint targets (the intended tool is the
/// nominal model's at `q`), or with `x` (N, dim) the seeds of Cartesian targets in the
/// measurement frame (with `quaternion` (N, 4) or `rotvec` (N, 3) when the spec's tool is a
/// frame). Each target is solved for `FK_calibrated(q′) = target` from its seed (least-norm
/// steps: a redundant arm keeps its self-motion). Failed targets are flagged in `status`, not
/// raised. `intended_base="calibrated"` places a joint target's nominal arm by the calibrated
/// `base:` (a laser tracker's frame), as `lincal compensate --intended-base calibrated`;
/// without it (`None`: `"nominal"`), a `UserWarning` says when the calibrated `base:` moves
/// the joint targets' intended tools by more than 1 cm; an explicit `"nominal"` does not.
#[pyfunction]
#[pyo3(signature = (spec, params, q, *, x = None, quaternion = None, rotvec = None,
    intended_base = None))]
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    py: Python<'_>,
    spec: &Bound<'_, PySpec>,
    params: Option<&Bound<'_, PyAny>>,
    q: &Bound<'_, PyAny>,
    x: Option<&Bound<'_, PyAny>>,
    quaternion: Option<&Bound<'_, PyAny>>,
    rotvec: Option<&Bound<'_, PyAny>>,
    intended_base: Option<&str>,
) -> PyResult<Compensation> {
    let spec = spec.get();
    let model = &spec.inner.model;
    let (p, cov) = parameters(py, spec, params)?;
    let c =
        Compensator::new(model.spec(), p, cov).map_err(|e| errors::to_py(py, &e, Origin::Other))?;
    let c = match intended_base.unwrap_or("nominal") {
        "nominal" => c,
        "calibrated" => c.place_by_calibrated_base(),
        other => {
            return Err(errors::input_error(
                py,
                "intended_base",
                &format!(
                    "`{}` is not a placement: expected \"nominal\" or \"calibrated\"",
                    lincal_core::error::excerpt(other)
                ),
            ))
        }
    };
    let targets = targets(py, &c, model, q, x, Orientation { quaternion, rotvec })?;
    // Only a calibration's `base:` can have moved (the nominals have none).
    let chosen = intended_base.is_some();
    if let Some(w) = params
        .filter(|_| !chosen)
        .and_then(|_| c.base_shift_warning(&targets))
    {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        let w = std::ffi::CString::new(w.replace('\0', " "))
            .map_err(|_| errors::internal(py, "a warning's text"))?;
        PyErr::warn(py, &category, &w, 1)?;
    }
    let outcomes = py
        .detach(|| guarded(|| c.compensate_all(&targets)))
        .map_err(|()| errors::internal(py, "compensating the targets"))?;
    compensation(py, &c, &outcomes)
}
