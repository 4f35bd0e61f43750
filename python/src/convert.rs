//! Conversions between Python objects and the texts and JSON values of `lincal_core`.
//!
//! A spec given as a dict (and a parameter mapping given as a dict) is written as one line of
//! flow YAML (JSON syntax, which YAML reads) and handed to the same loader as a spec file, so
//! there is one front end and one set of located errors. Numbers are written so that they read
//! back to the same `f64` (Rust's shortest round-trip form), NaN and infinities as YAML's
//! `.nan` and `.inf` (which the loader then refuses at their field).

use std::fmt::Write as _;

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyMapping, PySequence, PyString};
use serde_json::Value;

/// Deepest nesting written (the loader refuses beyond 64 itself; this stops self-referencing
/// containers).
const MAX_DEPTH: usize = 80;

/// A Python object that cannot be written as YAML: the field path and what is wrong.
#[derive(Debug)]
pub struct Unwritable {
    /// Field path, e.g. `joints[1].a`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

/// Writes `obj` (dicts with string keys, lists, tuples, strings, numbers, booleans, None,
/// numpy scalars and arrays) as flow YAML, stopping once the text exceeds `limit` bytes (the
/// loader then refuses its size).
///
/// # Errors
/// An object of another type, a non-string key, or nesting deeper than [`MAX_DEPTH`].
pub fn to_yaml(obj: &Bound<'_, PyAny>, limit: usize) -> Result<String, Unwritable> {
    let mut out = String::new();
    write(obj, &mut out, "", 0, limit)?;
    Ok(out)
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn fail(path: &str, message: impl Into<String>) -> Unwritable {
    Unwritable {
        field: if path.is_empty() {
            "(top level)".to_string()
        } else {
            path.to_string()
        },
        message: message.into(),
    }
}

/// A float as a YAML core-schema number that reads back exactly.
pub fn float_text(v: f64) -> String {
    if v.is_nan() {
        ".nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { ".inf" } else { "-.inf" }.to_string()
    } else {
        // Debug is the shortest round-trip form: `0.375`, `1e-7`, `12.0`.
        format!("{v:?}")
    }
}

fn write(
    obj: &Bound<'_, PyAny>,
    out: &mut String,
    path: &str,
    depth: usize,
    limit: usize,
) -> Result<(), Unwritable> {
    if out.len() > limit {
        return Ok(());
    }
    if depth > MAX_DEPTH {
        return Err(fail(
            path,
            format!("nested deeper than {MAX_DEPTH} levels (a spec needs five)"),
        ));
    }
    let type_name = || {
        obj.get_type()
            .name()
            .map_or_else(|_| "?".to_string(), |n| n.to_string())
    };
    if obj.is_none() {
        out.push_str("null");
    } else if let Ok(b) = obj.cast::<PyBool>() {
        out.push_str(if b.is_true() { "true" } else { "false" });
    } else if let Ok(i) = obj.cast::<PyInt>() {
        // Any size: the loader bounds magnitudes and names the field.
        let s = i.str().map_err(|e| fail(path, e.to_string()))?;
        out.push_str(&s.to_string_lossy());
    } else if let Ok(f) = obj.cast::<PyFloat>() {
        out.push_str(&float_text(f.value()));
    } else if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_string_lossy();
        out.push_str(&serde_json::to_string(&*s).unwrap_or_else(|_| "\"\"".to_string()));
    } else if let Ok(m) = obj.cast::<PyMapping>() {
        out.push('{');
        let items = m.items().map_err(|e| fail(path, e.to_string()))?;
        for (i, item) in items.iter().enumerate() {
            let k = item.get_item(0).map_err(|e| fail(path, e.to_string()))?;
            let v = item.get_item(1).map_err(|e| fail(path, e.to_string()))?;
            let Ok(key) = k.cast::<PyString>() else {
                return Err(fail(
                    path,
                    format!(
                        "a key of type `{}` ({}): keys must be strings",
                        k.get_type()
                            .name()
                            .map_or_else(|_| "?".to_string(), |n| n.to_string()),
                        k.repr().map_or_else(|_| "?".to_string(), |r| r.to_string())
                    ),
                ));
            };
            let key = key.to_string_lossy();
            if i > 0 {
                out.push_str(", ");
            }
            out.push_str(&serde_json::to_string(&*key).unwrap_or_else(|_| "\"\"".to_string()));
            out.push_str(": ");
            write(&v, out, &join(path, &key), depth + 1, limit)?;
        }
        out.push('}');
    } else if obj.hasattr("tolist").unwrap_or(false) && obj.hasattr("dtype").unwrap_or(false) {
        // A numpy array or scalar: its Python equivalent.
        let plain = obj
            .call_method0("tolist")
            .map_err(|e| fail(path, e.to_string()))?;
        write(&plain, out, path, depth + 1, limit)?;
    } else if obj.is_instance_of::<PyList>() || obj.is_instance_of::<pyo3::types::PyTuple>() {
        let seq = obj
            .cast::<PySequence>()
            .map_err(|e| fail(path, e.to_string()))?;
        out.push('[');
        let n = seq.len().map_err(|e| fail(path, e.to_string()))?;
        for i in 0..n {
            if i > 0 {
                out.push_str(", ");
            }
            let v = seq.get_item(i).map_err(|e| fail(path, e.to_string()))?;
            write(&v, out, &format!("{path}[{i}]"), depth + 1, limit)?;
            if out.len() > limit {
                break;
            }
        }
        out.push(']');
    } else if obj.hasattr("__index__").unwrap_or(false) {
        let s = obj
            .call_method0("__index__")
            .and_then(|v| v.str())
            .map_err(|e| fail(path, e.to_string()))?;
        out.push_str(&s.to_string_lossy());
    } else if obj.hasattr("__float__").unwrap_or(false) {
        let v: f64 = obj
            .extract()
            .map_err(|e: PyErr| fail(path, e.to_string()))?;
        out.push_str(&float_text(v));
    } else {
        return Err(fail(
            path,
            format!(
                "a value of type `{}`: expected a dict, list, string, number, boolean or None",
                type_name()
            ),
        ));
    }
    Ok(())
}

/// A JSON value as Python objects (`dict` keeps the order of the object).
pub fn to_python(py: Python<'_>, v: &Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        Value::Null => py.None(),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any().unbind(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any().unbind()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any().unbind()
            } else {
                n.as_f64()
                    .unwrap_or(f64::NAN)
                    .into_pyobject(py)?
                    .into_any()
                    .unbind()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| to_python(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any().unbind()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any().unbind()
        }
    })
}

/// Names joined for a message: `q1, q2, q3`.
pub fn names(list: impl IntoIterator<Item = impl AsRef<str>>) -> String {
    let mut s = String::new();
    for (i, n) in list.into_iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        let _ = write!(s, "{}", n.as_ref());
    }
    s
}
