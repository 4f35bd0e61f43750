//! Readings from numpy arrays into `lincal_core`'s [`Poses`], checked value by value with the
//! row and column of the first bad one, and results back into numpy arrays.
//!
//! A C-contiguous float64 array is read through a view (no conversion) and copied once, in
//! one block, into the flat storage of [`Rows`]: a million poses cost one allocation and one
//! `memcpy`, never one per pose. Other layouts and integer or float32 dtypes are converted by
//! numpy first (one more copy).

use lincal_core::data::{Poses, Rows, MAX_CELL};
use lincal_core::model::geometry::ConstraintKind;
use lincal_core::model::CalibModel;
use numpy::{
    PyArray1, PyArray2, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray2, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::data_error;

/// `obj` as a numpy array of `ndim` dimensions and a dtype of kind `f`, `i` or `u` (converted
/// to float64 or int64 as `float` says), or a `DataError` naming `what`.
fn numeric_array<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    what: &str,
    ndim: usize,
    float: bool,
    shape_doc: &str,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let arr = match obj.cast::<PyUntypedArray>() {
        Ok(a) => a.clone(),
        Err(_) => {
            let np = py.import("numpy")?;
            np.call_method1("asarray", (obj,))
                .map_err(|e| {
                    data_error(
                        py,
                        Some(what),
                        None,
                        &format!("`{what}` cannot be read as an array: {e}"),
                    )
                })?
                .cast_into::<PyUntypedArray>()
                .map_err(|e| data_error(py, Some(what), None, &e.to_string()))?
        }
    };
    if arr.ndim() != ndim {
        return Err(data_error(
            py,
            Some(what),
            None,
            &format!(
                "`{what}` must be a {ndim}-D array {shape_doc}, not of shape {:?}",
                arr.shape()
            ),
        ));
    }
    let dtype = arr.dtype();
    let kind = dtype.kind();
    let ok = match kind {
        b'f' | b'i' | b'u' => float || kind != b'f',
        _ => false,
    };
    if !ok {
        let name = dtype
            .str()
            .map_or_else(|_| "?".to_string(), |s| s.to_string());
        let want = if float {
            "float64 (or an integer or float32 dtype, converted)"
        } else {
            "integers"
        };
        return Err(data_error(
            py,
            Some(what),
            None,
            &format!("`{what}` has dtype `{name}`: expected {want}"),
        ));
    }
    let target = if float { "float64" } else { "int64" };
    let native = if float {
        arr.cast::<PyArray2<f64>>().is_ok() || arr.cast::<PyArray1<f64>>().is_ok()
    } else {
        arr.cast::<PyArray1<i64>>().is_ok()
    };
    if native {
        Ok(arr)
    } else {
        Ok(arr
            .call_method1("astype", (target,))?
            .cast_into::<PyUntypedArray>()?)
    }
}

/// `obj` as a readable (N, `width`) float64 array, or a `DataError` naming `what`.
pub fn float_rows<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    what: &str,
    width: usize,
    columns: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let arr = numeric_array(py, obj, what, 2, true, &format!("of shape (N, {width})"))?;
    let arr = arr.cast_into::<PyArray2<f64>>()?;
    let cols = arr.shape()[1];
    if cols != width {
        return Err(data_error(
            py,
            Some(what),
            None,
            &format!(
                "`{what}` has {cols} column(s), expected {width} ({columns}): shape (N, {width})"
            ),
        ));
    }
    arr.try_readonly()
        .map_err(|e| data_error(py, Some(what), None, &format!("`{what}`: {e}")))
}

/// `obj` as an (N,) int64 vector, or a `DataError` naming `what`.
pub fn int_vector(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    what: &str,
    n: usize,
) -> PyResult<Vec<i64>> {
    let arr = numeric_array(py, obj, what, 1, false, "of shape (N,)")?;
    let arr = arr.cast_into::<PyArray1<i64>>()?;
    let ro = arr
        .try_readonly()
        .map_err(|e| data_error(py, Some(what), None, &format!("`{what}`: {e}")))?;
    let v = ro.as_array().to_vec();
    if v.len() != n {
        return Err(data_error(
            py,
            Some(what),
            None,
            &format!(
                "`{what}` has {} entries, one per pose (N = {n}) expected",
                v.len()
            ),
        ));
    }
    Ok(v)
}

/// Checks one value: finite and within [`MAX_CELL`].
fn check_value(
    py: Python<'_>,
    what: &str,
    column_name: &dyn Fn(usize) -> String,
    row: usize,
    col: usize,
    v: f64,
) -> PyResult<()> {
    if v.is_finite() && v.abs() <= MAX_CELL {
        return Ok(());
    }
    let column = column_name(col);
    let why = if v.is_finite() {
        format!("is out of range ({v:e}): readings are radians or metres, at most {MAX_CELL:e} in magnitude")
    } else {
        format!("is {v}: readings must be finite numbers")
    };
    Err(data_error(
        py,
        Some(&column),
        Some(row),
        &format!("`{what}[{row}, {col}]` ({column} of row {row}) {why}"),
    ))
}

/// The readings of a checked array as [`Rows`]; rows for which `may_be_empty(row)` holds and
/// that hold a NaN become empty rows (a measured tip left out on a constraint that is not
/// measured), every other value must be finite and within [`MAX_CELL`].
pub fn rows(
    py: Python<'_>,
    arr: &PyReadonlyArray2<'_, f64>,
    what: &str,
    column_name: &dyn Fn(usize) -> String,
    may_be_empty: Option<&dyn Fn(usize) -> bool>,
) -> PyResult<Rows> {
    let view = arr.as_array();
    let (n, width) = view.dim();
    let empty_row = |row: usize, values: &numpy::ndarray::ArrayView1<'_, f64>| {
        may_be_empty.is_some_and(|f| f(row)) && values.iter().any(|v| v.is_nan())
    };
    let mut any_empty = false;
    for (row, values) in view.outer_iter().enumerate() {
        if empty_row(row, &values) {
            any_empty = true;
            continue;
        }
        for (col, &v) in values.iter().enumerate() {
            check_value(py, what, column_name, row, col, v)?;
        }
    }
    if !any_empty {
        // One block copy from the view when the array is C-contiguous.
        // (`as_slice` also takes a Fortran-ordered array, column after column: not rows.)
        crate::errors::check_memory(
            &format!("a copy of `{what}`"),
            (n as u64).saturating_mul(width as u64 * 8),
        )?;
        let mut flat = try_vec(n * width, what)?;
        match arr.as_slice() {
            Ok(s) if arr.is_c_contiguous() => flat.extend_from_slice(s),
            _ => flat.extend(view.iter().copied()),
        }
        return Rows::from_vec(width, flat)
            .ok_or_else(|| data_error(py, Some(what), None, "inconsistent array shape"));
    }
    let mut out = Rows::new(width);
    out.reserve(n);
    for (row, values) in view.outer_iter().enumerate() {
        if empty_row(row, &values) {
            out.push(&[]);
        } else {
            let values: Vec<f64> = values.iter().copied().collect();
            out.push(&values);
        }
    }
    Ok(out)
}

/// Bytes per pose beyond its readings' copies: line and constraint indices, the residual
/// and weight of the fit, the returned residuals.
const POSE_OVERHEAD: u64 = 64;

/// A flat vector of `len` values, or a `MemoryError` (never the allocator's abort).
fn try_vec(len: usize, what: &str) -> PyResult<Vec<f64>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| {
        PyErr::new::<pyo3::exceptions::PyMemoryError, _>(format!(
            "no memory for a copy of `{what}` ({len} values)"
        ))
    })?;
    Ok(v)
}

/// The joint names `q1..qn` of a model.
pub fn joint_names(model: &dyn CalibModel) -> String {
    crate::convert::names((1..=model.joint_count()).map(|i| format!("q{i}")))
}

/// Builds the poses of `model` from the Python arguments of `calibrate` and
/// `Spec.residuals`: `q` (N, n), `x` (N, dim) for measured tips, `constraint` (N,) for a list
/// of constraints, `lines` (N,) for messages.
pub fn poses(
    py: Python<'_>,
    model: &dyn CalibModel,
    constraint_list: bool,
    q: &Bound<'_, PyAny>,
    x: Option<&Bound<'_, PyAny>>,
    constraint: Option<&Bound<'_, PyAny>>,
    lines: Option<&Bound<'_, PyAny>>,
) -> PyResult<Poses> {
    let joints = model.joint_count();
    let dim = model.dim();
    let count = model.constraint_count();
    let q_arr = float_rows(py, q, "q", joints, &joint_names(model))?;
    let n = q_arr.as_array().dim().0;
    // Before any copy: the poses, the fit's per-pose buffers and the residuals, estimated
    // generously (a broadcast view of 10^8 rows costs the caller nothing, lincal gigabytes).
    let per_pose = 4 * 8 * (joints + dim) as u64 + POSE_OVERHEAD;
    crate::errors::check_memory(
        &format!("a fit of {n} poses"),
        (n as u64).saturating_mul(per_pose),
    )?;
    let qrows = rows(py, &q_arr, "q", &|c| format!("q{}", c + 1), None)?;
    let constraint: Vec<usize> =
        match (constraint, constraint_list) {
            (None, false) => vec![0; n],
            (None, true) => {
                return Err(data_error(
                    py,
                    Some("constraint"),
                    None,
                    &format!(
                    "the spec has a list of {count} constraints: pass `constraint`, the 0-based \
                     index of the constraint each pose lies on, shape (N,)"
                ),
                ))
            }
            (Some(_), false) => return Err(data_error(
                py,
                Some("constraint"),
                None,
                "the spec has one constraint (`constraint:`): leave `constraint` out (it is for \
                 specs with a list, `constraints:`)",
            )),
            (Some(c), true) => {
                let v = int_vector(py, c, "constraint", n)?;
                let mut out = Vec::with_capacity(n);
                for (row, &j) in v.iter().enumerate() {
                    match usize::try_from(j) {
                        Ok(j) if j < count => out.push(j),
                        _ => {
                            return Err(data_error(
                                py,
                                Some("constraint"),
                                Some(row),
                                &format!(
                                "`constraint[{row}]` is {j}: the spec has {count} constraint(s), \
                                 indices 0 to {}",
                                count - 1
                            ),
                            ))
                        }
                    }
                }
                out
            }
        };
    let measured: Vec<bool> = (0..count)
        .map(|j| model.constraint_kind(j) == ConstraintKind::Measured)
        .collect();
    let tip_names = ["x", "y", "z"];
    let measured_rows = match (x, measured.iter().any(|&m| m)) {
        (None, false) => None,
        (Some(_), false) => {
            return Err(data_error(
                py,
                Some("x"),
                None,
                "the spec has no `measured` constraint: leave `x` out (measured tips are for \
                 `measured` constraints)",
            ))
        }
        (None, true) => {
            return Err(data_error(
                py,
                Some("x"),
                None,
                &format!(
                    "the spec has a `measured` constraint: pass `x`, the measured tips, shape \
                     (N, {dim})"
                ),
            ))
        }
        (Some(x), true) => {
            let arr = float_rows(py, x, "x", dim, &crate::convert::names(&tip_names[..dim]))?;
            let rows_x = arr.as_array().dim().0;
            if rows_x != n {
                return Err(data_error(
                    py,
                    Some("x"),
                    None,
                    &format!("`x` has {rows_x} rows, `q` has {n}: one measured tip per pose"),
                ));
            }
            let on_other = |row: usize| !measured[constraint[row]];
            Some(rows(
                py,
                &arr,
                "x",
                &|c| tip_names.get(c).map_or("?", |s| s).to_string(),
                Some(&on_other),
            )?)
        }
    };
    let line = match lines {
        None => Vec::new(),
        Some(l) => int_vector(py, l, "lines", n)?
            .into_iter()
            .enumerate()
            .map(|(row, v)| {
                usize::try_from(v).map_err(|_| {
                    data_error(
                        py,
                        Some("lines"),
                        Some(row),
                        &format!("`lines[{row}]` is {v}: line numbers are not negative"),
                    )
                })
            })
            .collect::<PyResult<Vec<usize>>>()?,
    };
    Ok(Poses {
        q: qrows,
        measured: measured_rows,
        constraint: lincal_core::data::PoseColumn::labels_from(constraint),
        line: lincal_core::data::PoseColumn::counting_from(line),
    })
}

/// A flat vector of `rows × width` values as a numpy array of that shape, without a copy.
pub fn array2(py: Python<'_>, data: Vec<f64>, width: usize) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let n = data.len().checked_div(width).unwrap_or(0);
    numpy::IntoPyArray::into_pyarray(data, py).reshape([n, width])
}
