//! The parameter values the Python API's `params` arguments name: None (the nominals), a
//! `Calibration`, a dict (name -> value, or a result's dict held to a result file's checks),
//! or a sequence in the model's order.

use lincal_core::model::CalibModel;
use pyo3::prelude::*;

use crate::convert;
use crate::errors::{self, guarded, Origin};
use lincal_core::symbolic::SymbolicModel;

/// The estimated parameter values `p` (model order) from the Python `params` argument: None
/// (the nominals), a `Calibration`, a mapping name → value (like a truth file: estimated
/// parameters left out take their nominal, known ones may only repeat theirs), or a sequence
/// of `P` numbers in the model's order.
pub fn param_values(
    py: Python<'_>,
    model: &SymbolicModel,
    params: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<f64>> {
    let Some(params) = params else {
        return Ok((0..model.param_count())
            .map(|j| model.param_nominal(j))
            .collect());
    };
    if let Ok(c) = params.cast::<crate::result::Calibration>() {
        return c.get().estimated_values(model);
    }
    if let Ok(map) = params.cast::<pyo3::types::PyMapping>() {
        check_result_dict(py, model, map)?;
        let text = convert::to_yaml(params, lincal_core::spec::load::MAX_SPEC_BYTES)
            .map_err(|u| errors::input_error(py, &format!("params.{}", u.field), &u.message))?;
        let text = if text == "{}" { String::new() } else { text };
        return guarded(|| {
            lincal_core::simulate::truth_from_yaml_str(&text, None, model, model.spec())
        })
        .map_err(|()| errors::internal(py, "reading the parameters"))?
        .map_err(|e| errors::to_py(py, &e, Origin::OtherDict));
    }
    let v: Vec<f64> = params.extract().map_err(|_| {
        errors::input_error(
            py,
            "params",
            &format!(
                "expected None, a Calibration, a dict name -> value, or {} numbers ({})",
                model.param_count(),
                convert::names((0..model.param_count()).map(|j| model.param_name(j)))
            ),
        )
    })?;
    if v.len() != model.param_count() {
        return Err(errors::input_error(
            py,
            "params",
            &format!(
                "{} values given, the spec estimates {} ({})",
                v.len(),
                model.param_count(),
                convert::names((0..model.param_count()).map(|j| model.param_name(j)))
            ),
        ));
    }
    let max = lincal_core::spec::load::MAX_MAGNITUDE;
    if let Some(j) = v.iter().position(|x| !x.is_finite() || x.abs() > max) {
        return Err(errors::input_error(
            py,
            model.param_name(j),
            &format!(
                "the value of `{}` is {:e}: expected a finite number of magnitude at most \
                 {max:e}, as a spec's",
                model.param_name(j),
                v[j]
            ),
        ));
    }
    Ok(v)
}

/// A result dict (`Calibration.to_dict()`, or a `calibrate --format json` file loaded: a
/// `params` mapping beside a `name` or `structure`) passed as `params` is held to what
/// `predict --params` holds a result file to: the same spec's name and structure, and a value
/// for every estimated parameter (a truth-like dict may leave some to their nominals; a
/// result may not, or another robot's values would pass for this one's).
fn check_result_dict(
    py: Python<'_>,
    model: &SymbolicModel,
    map: &Bound<'_, pyo3::types::PyMapping>,
) -> PyResult<()> {
    let get = |k: &str| map.get_item(k).ok().filter(|v| !v.is_none());
    let Some(values) = get("params") else {
        return Ok(());
    };
    let (name, structure) = (get("name"), get("structure"));
    if name.is_none() && structure.is_none() {
        return Ok(());
    }
    let spec = model.spec();
    if let Some(n) = name.and_then(|n| n.extract::<String>().ok()) {
        if n != model.name() {
            return Err(errors::input_error(
                py,
                "params.name",
                &format!(
                    "the result is of spec `{}`, not of this spec `{}`: its values are used only \
                     with the spec they were calibrated with; for the same robot's spec \
                     renamed, pass a dict name -> value",
                    lincal_core::error::excerpt(&n),
                    lincal_core::error::excerpt(model.name())
                ),
            ));
        }
    }
    if let Some(st) = structure.and_then(|s| s.extract::<String>().ok()) {
        if st != lincal_core::spec::structure::fingerprint(spec) {
            return Err(errors::input_error(
                py,
                "params.structure",
                "the result was calibrated with a spec of this name but of another structure \
                 (convention, slots, constraints, relations or known values): calibrate again \
                 with this spec",
            ));
        }
    }
    let missing: Vec<&str> = (0..model.param_count())
        .map(|j| model.param_name(j))
        .filter(|n| values.get_item(*n).map_or(true, |v| v.is_none()))
        .collect();
    if !missing.is_empty() {
        return Err(errors::input_error(
            py,
            &format!("params.params.{}", missing[0]),
            &format!(
                "missing: every estimated parameter needs a value in a result ({})",
                convert::names(missing.iter().copied())
            ),
        ));
    }
    Ok(())
}
