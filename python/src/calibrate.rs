//! `lincal.calibrate`: the fit of a spec on numpy readings, as the command line's `calibrate`
//! runs it, with its options parsed from Python's arguments.

use lincal_core::calibrate::estimate::Estimate;
use lincal_core::calibrate::{
    calibrate_spec, pose_residuals,
    prior::{
        out_of_range, PriorChoice, PriorScale, PriorShape, DEFAULT_ANGLE_TOLERANCE,
        DEFAULT_LENGTH_TOLERANCE, TOLERANCE_RANGE, WEIGHT_RANGE,
    },
    CalibrateOptions, Robust, StartChoice,
};
use numpy::PyArray1;
use pyo3::prelude::*;
use serde_json::Value;

use crate::arrays;
use crate::errors::{self, guarded, Origin};
use crate::spec::PySpec;

use crate::result::Calibration;

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
    // A strength given with the prior off would be dropped without a word (as the CLI).
    if shape.is_none() {
        let given = [
            ("prior_weight", weight.is_some()),
            ("tolerance_length", length.is_some()),
            ("tolerance_angle", angle.is_some()),
        ];
        if let Some((name, _)) = given.iter().find(|g| g.1) {
            return Err(errors::input_error(
                py,
                name,
                &format!(
                    "{name} sets the prior's strength, and prior=\"off\" leaves the prior out: \
                     give one or the other"
                ),
            ));
        }
    }
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
                let (position, orientation) = crate::poses::pose_errors(model, &poses, &p);
                (position, Some(orientation))
            } else {
                (pose_residuals(model, &poses, &p)?, None)
            };
            // As `lincal calibrate --format json` writes it, the spec's structure included.
            let mut json = lincal_core::report::calibrate_json(model, &est);
            json["structure"] = lincal_core::spec::structure::fingerprint(model.spec()).into();
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

/// What a calibration hands back from its worker thread: the estimate, each pose's residual
/// (for measured poses its position error), each measured pose's orientation error, and the
/// JSON.
type Fitted = (Estimate, Vec<f64>, Option<Vec<f64>>, Value);
