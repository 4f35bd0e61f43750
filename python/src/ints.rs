//! Integer arguments of any size. pyo3 converts a Python int to `u64`, `usize` or `i64` with a
//! raw `OverflowError` when it does not fit (a negative seed, `10**30` poses); these
//! extractors (`#[pyo3(from_py_with = …)]`) raise lincal's `InputError` (a ValueError) naming
//! the argument and the range it takes instead. A value that is not an integer stays a
//! TypeError, as for any integer argument.

use pyo3::exceptions::PyOverflowError;
use pyo3::prelude::*;

use crate::errors;

/// `obj` as an integer within `lo..=hi`, else an `InputError` naming `name` and the range.
fn int_in(obj: &Bound<'_, PyAny>, name: &str, lo: i128, hi: i128) -> PyResult<i128> {
    let py = obj.py();
    let value = match obj.extract::<i128>() {
        Ok(v) => Some(v),
        Err(e) if e.is_instance_of::<PyOverflowError>(py) => None,
        Err(e) => return Err(e),
    };
    match value {
        Some(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => {
            let text = obj.str().map(|s| s.to_string()).unwrap_or_default();
            Err(errors::input_error(
                py,
                name,
                &format!(
                    "`{name}` must be an integer from {lo} to {hi}, not {}",
                    lincal_core::error::excerpt(&text)
                ),
            ))
        }
    }
}

/// The whole range of `i64` (the callee checks its own bounds within it, by name).
fn i64_named(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<i64> {
    let v = int_in(obj, name, i64::MIN.into(), i64::MAX.into())?;
    Ok(i64::try_from(v).unwrap_or(i64::MAX))
}

/// `seed`: 0 to 2⁶⁴ − 1, as the command line's `--seed`.
pub fn seed(obj: &Bound<'_, PyAny>) -> PyResult<u64> {
    let v = int_in(obj, "seed", 0, u64::MAX.into())?;
    Ok(u64::try_from(v).unwrap_or(u64::MAX))
}

/// `n`, a number of poses (checked further by the function).
pub fn n(obj: &Bound<'_, PyAny>) -> PyResult<i64> {
    i64_named(obj, "n")
}

/// `draws` (checked further by `select`).
pub fn draws(obj: &Bound<'_, PyAny>) -> PyResult<i64> {
    i64_named(obj, "draws")
}

/// `pool`, or None (checked further by `select`).
pub fn pool(obj: &Bound<'_, PyAny>) -> PyResult<Option<i64>> {
    if obj.is_none() {
        return Ok(None);
    }
    i64_named(obj, "pool").map(Some)
}

/// `max_terms`, or None (the default): 0 to the platform's largest size, as the command
/// line's `--max-terms`.
pub fn max_terms(obj: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    if obj.is_none() {
        return Ok(None);
    }
    let hi = i128::try_from(usize::MAX).unwrap_or(i128::MAX);
    let v = int_in(obj, "max_terms", 0, hi)?;
    Ok(Some(usize::try_from(v).unwrap_or(usize::MAX)))
}
