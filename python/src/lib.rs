//! `lincal` for Python: numpy bindings of `lincal-core` (PyO3, abi3).
//!
//! Every function is a thin wrapper over the core: the spec goes through the same loader as
//! `lincal basis`/`calibrate` (a dict is written as YAML text first), readings are copied once
//! from a numpy view into the core's flat pose storage, the work runs without the GIL, and
//! results come back as numpy arrays (made from the core's vectors without a copy) and the
//! very JSON the command line prints. Core errors become Python exceptions
//! ([`errors`]); a panic is caught at the boundary and raised as `lincal.InternalError`.
//!
//! ```text
//! lincal.Spec.from_yaml(path) / .from_str(text) / .from_dict(d)  -> Spec
//! spec.basis()                          -> Basis (lincal basis --format json)
//! spec.tip(q, params), spec.tool_pose(q, params) -> (x, quaternion)
//! spec.residuals(q, params, x=, quaternion=|rotvec=, constraint=), spec.read_csv(path, angles=)
//! lincal.calibrate(spec, q, x=, quaternion=|rotvec=, constraint=, refine=, ...) -> Calibration
//! lincal.simulate(spec, n, seed=, truth=, noise_track=, ...)                 -> Simulation
//! lincal.select(spec, n, candidates=|pool=, given=, criterion=, draws=, ...)  -> Selection
//! lincal.compensate(spec, params, q, x=, quaternion=|rotvec=)               -> Compensation
//! ```

mod arrays;
mod basis;
mod calibrate;
mod compensate;
mod convert;
mod errors;
mod ints;
mod params;
mod poses;
mod result;
mod select;
mod simulate;
mod spec;

use pyo3::prelude::*;

/// Robot kinematic calibration by the linear generalized-parameter method (Sayeh & Newman),
/// with numpy arrays in and out.
#[pymodule]
fn lincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    m.add_class::<spec::PySpec>()?;
    m.add_class::<basis::Basis>()?;
    m.add_class::<result::Calibration>()?;
    m.add_class::<simulate::Simulation>()?;
    m.add_class::<select::Selection>()?;
    m.add_class::<compensate::Compensation>()?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(select::select, m)?)?;
    m.add_function(wrap_pyfunction!(compensate::compensate, m)?)?;
    m.add(
        "DEFAULT_MAX_TERMS",
        lincal_core::symbolic::DEFAULT_MAX_TERMS,
    )?;
    Ok(())
}
