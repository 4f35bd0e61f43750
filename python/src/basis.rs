//! `lincal.Basis`: the symbolic result of a spec, as `lincal basis --format json` prints it.

use pyo3::prelude::*;
use serde_json::Value;

use crate::convert;

/// The symbolic result of a spec (what `lincal basis --format json` prints): the basis, the
/// identifiable combinations and the gauge directions. `to_dict()` has every field.
#[pyclass(module = "lincal", frozen)]
pub struct Basis {
    pub(crate) json: Value,
}

impl Basis {
    fn field(&self, py: Python<'_>, key: &str) -> PyResult<Py<PyAny>> {
        convert::to_python(py, self.json.get(key).unwrap_or(&Value::Null))
    }
}

#[pymethods]
impl Basis {
    /// K, the size of the column-reduced basis (the constant function included when present).
    #[getter]
    fn basis_size(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "basis_size")
    }

    /// The K basis functions, as strings (e.g. `"c1*s2"`, `"1"`).
    #[getter]
    fn basis(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "basis")
    }

    /// Distinct monomials of the constraint function(s) before any reduction.
    #[getter]
    fn naive_size(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "naive_size")
    }

    /// The number of independent parameter combinations the constraint can determine.
    #[getter]
    fn identifiable_count(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "identifiable_count")
    }

    /// Names identifiable on their own.
    #[getter]
    fn identifiable(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "identifiable")
    }

    /// Names not identifiable on their own.
    #[getter]
    fn unidentifiable(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "unidentifiable")
    }

    /// The directions the data cannot see, each a dict {param: coefficient}.
    #[getter]
    fn gauge(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "gauge")
    }

    /// The parameters the gauge rule holds at their nominal.
    #[getter]
    fn held(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "held")
    }

    /// The estimated parameter names, in spec order.
    #[getter]
    fn params(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "params")
    }

    /// Every field, as `lincal basis SPEC --format json` prints it.
    fn to_dict(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        convert::to_python(py, &self.json)
    }

    /// The JSON text of `lincal basis SPEC --format json` (without the final newline).
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(&self.json).unwrap_or_default()
    }

    fn __repr__(&self) -> String {
        let get = |k: &str| self.json.get(k).map_or("?".to_string(), Value::to_string);
        format!(
            "Basis(basis_size={}, identifiable_count={}, basis={}, identifiable={})",
            get("basis_size"),
            get("identifiable_count"),
            get("basis"),
            get("identifiable")
        )
    }
}
