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

/// The measured orientation of a `measured_pose` spec's poses, as the Python arguments give it:
/// `quaternion` (N, 4), unit quaternions scalar first (`qw, qx, qy, qz`), or `rotvec` (N, 3),
/// rotation vectors in radians (`rx, ry, rz`); exactly one of them for such a spec, neither
/// otherwise.
#[derive(Clone, Copy, Default)]
pub struct Orientation<'a, 'py> {
    /// `quaternion=`: (N, 4).
    pub quaternion: Option<&'a Bound<'py, PyAny>>,
    /// `rotvec=`: (N, 3).
    pub rotvec: Option<&'a Bound<'py, PyAny>>,
}

/// Whether some constraint of `model` is `measured_pose`.
pub fn is_pose_model(model: &dyn CalibModel) -> bool {
    (0..model.constraint_count()).any(|j| model.constraint_kind(j) == ConstraintKind::MeasuredPose)
}

/// The quaternion columns, for messages.
const QUATERNION_NAMES: [&str; 4] = ["qw", "qx", "qy", "qz"];
/// The rotation-vector columns, for messages.
const ROTVEC_NAMES: [&str; 3] = ["rx", "ry", "rz"];

/// The measured rotations (column-major, as the core's measured rows hold them) of the `n`
/// poses from the orientation arguments: checked value by value (finite, within
/// [`MAX_CELL`]; a quaternion of unit norm within the core's
/// [`QUATERNION_NORM_TOLERANCE`](lincal_core::model::rotation::QUATERNION_NORM_TOLERANCE),
/// then normalised, as the CSV reader does). `None` for rows of poses whose constraint is not
/// a measured pose and that hold a NaN (`on_other`).
pub fn rotations(
    py: Python<'_>,
    orientation: Orientation<'_, '_>,
    n: usize,
    on_other: &dyn Fn(usize) -> bool,
) -> PyResult<Vec<Option<[f64; 9]>>> {
    use lincal_core::model::rotation::{
        matrix_from_quaternion, matrix_from_rotation_vector, MAX_ROTATION_VECTOR,
        QUATERNION_NORM_TOLERANCE,
    };
    let (obj, what, names): (_, &str, &[&str]) = match (orientation.quaternion, orientation.rotvec)
    {
        (Some(_), Some(_)) => {
            return Err(data_error(
                py,
                Some("rotvec"),
                None,
                "the orientation is given twice, as `quaternion` and as `rotvec`: pass one \
                 form, `quaternion` (N, 4: qw, qx, qy, qz) or `rotvec` (N, 3: rx, ry, rz)",
            ))
        }
        (None, None) => {
            return Err(data_error(
                py,
                Some("quaternion"),
                None,
                "the spec's constraint is `measured_pose`: pass the measured orientation, \
                 `quaternion` (N, 4: a unit quaternion qw, qx, qy, qz, scalar first) or \
                 `rotvec` (N, 3: a rotation vector rx, ry, rz, radians), beside `x`",
            ))
        }
        (Some(q), None) => (q, "quaternion", &QUATERNION_NAMES[..]),
        (None, Some(r)) => (r, "rotvec", &ROTVEC_NAMES[..]),
    };
    let width = names.len();
    let arr = float_rows(py, obj, what, width, &crate::convert::names(names))?;
    let count = arr.as_array().dim().0;
    if count != n {
        return Err(data_error(
            py,
            Some(what),
            None,
            &format!("`{what}` has {count} rows, `q` has {n}: one measured orientation per pose"),
        ));
    }
    let values = rows(
        py,
        &arr,
        what,
        &|c| names.get(c).map_or("?", |s| s).to_string(),
        Some(on_other),
    )?;
    let mut out = Vec::with_capacity(n);
    for (row, v) in values.iter().enumerate() {
        if v.len() != width {
            out.push(None);
            continue;
        }
        if width == 4 {
            let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                return Err(data_error(
                    py,
                    Some(what),
                    Some(row),
                    &format!(
                        "`quaternion[{row}]` (row {row}) = ({}, {}, {}, {}) has norm {norm}, \
                         not 1 (within {QUATERNION_NORM_TOLERANCE:e}): the orientation must be \
                         a unit quaternion, scalar first (qw, qx, qy, qz)",
                        v[0], v[1], v[2], v[3]
                    ),
                ));
            }
            out.push(Some(matrix_from_quaternion([v[0], v[1], v[2], v[3]])));
        } else {
            let angle = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if angle > MAX_ROTATION_VECTOR {
                return Err(data_error(
                    py,
                    Some(what),
                    Some(row),
                    &format!(
                        "`rotvec[{row}]` (row {row}) = ({}, {}, {}) turns by {angle:.4} rad, \
                         beyond a full turn (2π): it looks like degrees; give the axis times \
                         the angle in radians",
                        v[0], v[1], v[2]
                    ),
                ));
            }
            out.push(Some(matrix_from_rotation_vector([v[0], v[1], v[2]])));
        }
    }
    Ok(out)
}

/// Builds the poses of `model` from the Python arguments of `calibrate` and
/// `Spec.residuals`: `q` (N, n), `x` (N, dim) for measured tips (and poses), `orientation`
/// for measured poses (`measured_pose`), `constraint` (N,) for a list of constraints,
/// `lines` (N,) for messages.
#[allow(clippy::too_many_arguments)]
pub fn poses(
    py: Python<'_>,
    model: &dyn CalibModel,
    constraint_list: bool,
    q: &Bound<'_, PyAny>,
    x: Option<&Bound<'_, PyAny>>,
    orientation: Orientation<'_, '_>,
    constraint: Option<&Bound<'_, PyAny>>,
    lines: Option<&Bound<'_, PyAny>>,
) -> PyResult<Poses> {
    let joints = model.joint_count();
    let dim = model.dim();
    let count = model.constraint_count();
    let pose = is_pose_model(model);
    if !pose {
        for (given, what) in [
            (orientation.quaternion, "quaternion"),
            (orientation.rotvec, "rotvec"),
        ] {
            if given.is_some() {
                return Err(data_error(
                    py,
                    Some(what),
                    None,
                    &format!(
                        "the spec has no `measured_pose` constraint: leave `{what}` out (a \
                         measured orientation is for `measured_pose`)"
                    ),
                ));
            }
        }
    }
    let q_arr = float_rows(py, q, "q", joints, &joint_names(model))?;
    let n = q_arr.as_array().dim().0;
    // Before any copy: the poses, the fit's per-pose buffers and the residuals, estimated
    // generously (a broadcast view of 10^8 rows costs the caller nothing, lincal gigabytes).
    let measured_width = if pose { 12 } else { dim };
    let per_pose = 4 * 8 * (joints + measured_width) as u64 + POSE_OVERHEAD;
    crate::errors::check_memory(
        &format!("a fit of {n} poses"),
        (n as u64).saturating_mul(per_pose),
    )?;
    let qrows = rows(py, &q_arr, "q", &|c| format!("q{}", c + 1), None)?;
    let constraint = constraint_indices(py, count, constraint_list, constraint, n, "constraint")?;
    let measured: Vec<bool> = (0..count)
        .map(|j| model.constraint_kind(j).is_measured())
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
                 `measured` and `measured_pose` constraints)",
            ))
        }
        (None, true) => {
            return Err(data_error(
                py,
                Some("x"),
                None,
                &format!(
                    "the spec has a `{}` constraint: pass `x`, the measured tips, shape \
                     (N, {dim})",
                    if pose { "measured_pose" } else { "measured" }
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
            let tips = rows(
                py,
                &arr,
                "x",
                &|c| tip_names.get(c).map_or("?", |s| s).to_string(),
                Some(&on_other),
            )?;
            if pose {
                let turns = rotations(py, orientation, n, &on_other)?;
                // A measured pose's row: the tip, then its rotation column-major.
                let mut out = Rows::new(12);
                out.reserve(n);
                let mut row12 = [0.0; 12];
                for (tip, turn) in tips.iter().zip(&turns) {
                    match turn {
                        Some(r) if tip.len() == 3 => {
                            row12[..3].copy_from_slice(tip);
                            row12[3..].copy_from_slice(r);
                            out.push(&row12);
                        }
                        _ => out.push(&[]),
                    }
                }
                Some(out)
            } else {
                Some(tips)
            }
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
        files: Default::default(),
    })
}

/// The 0-based constraint index of each of `n` poses: `constraint` (an (N,) integer array,
/// named `what` in errors) for a spec with a list of `count` constraints, all 0 for a spec
/// with one (where `constraint` must be left out).
pub fn constraint_indices(
    py: Python<'_>,
    count: usize,
    constraint_list: bool,
    constraint: Option<&Bound<'_, PyAny>>,
    n: usize,
    what: &str,
) -> PyResult<Vec<usize>> {
    match (constraint, constraint_list) {
        (None, false) => Ok(vec![0; n]),
        (None, true) => Err(data_error(
            py,
            Some(what),
            None,
            &format!(
                "the spec has a list of {count} constraints: pass `{what}`, the 0-based index \
                 of the constraint each pose lies on, shape (N,)"
            ),
        )),
        (Some(_), false) => Err(data_error(
            py,
            Some(what),
            None,
            &format!(
                "the spec has one constraint (`constraint:`): leave `{what}` out (it is for \
                 specs with a list, `constraints:`)"
            ),
        )),
        (Some(c), true) => {
            let v = int_vector(py, c, what, n)?;
            let mut out = Vec::with_capacity(n);
            for (row, &j) in v.iter().enumerate() {
                match usize::try_from(j) {
                    Ok(j) if j < count => out.push(j),
                    _ => {
                        return Err(data_error(
                            py,
                            Some(what),
                            Some(row),
                            &format!(
                                "`{what}[{row}]` is {j}: the spec has {count} constraint(s), \
                                 indices 0 to {}",
                                count - 1
                            ),
                        ))
                    }
                }
            }
            Ok(out)
        }
    }
}

/// A flat vector of `rows × width` values as a numpy array of that shape, without a copy.
pub fn array2(py: Python<'_>, data: Vec<f64>, width: usize) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let n = data.len().checked_div(width).unwrap_or(0);
    numpy::IntoPyArray::into_pyarray(data, py).reshape([n, width])
}
