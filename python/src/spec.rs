//! `lincal.Spec` (a loaded spec and its exact symbolic model) and `lincal.Basis` (what
//! `lincal basis --format json` prints).

use std::path::PathBuf;
use std::sync::Arc;

use lincal_core::data::{Angles, DataLayout, Poses};
use lincal_core::model::CalibModel;
use lincal_core::spec::kinematics::MAX_PREDICTED;
use lincal_core::spec::urdf_record::UrdfRecord;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::symbolic::DEFAULT_MAX_TERMS;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays;
use crate::basis::Basis;
use crate::convert;
use crate::errors::{self, guarded, Origin};

/// A loaded spec: the validated spec and its exact symbolic model (basis, generalized
/// parameters, identifiability), shared by every result made from it.
pub struct Loaded {
    /// The symbolic model; it owns the spec (`model.spec()`).
    pub model: SymbolicModel,
    /// Where the spec came from, for `repr`.
    pub source: String,
    /// The URDF joint names of the spec's `urdf:` record (empty without one), which data
    /// files may use as the joint columns' headers, as on the command line.
    pub joint_names: Vec<String>,
}

/// A robot and its constraint, loaded and validated, with its exact symbolic model.
///
/// Make one with `Spec.from_yaml(path)`, `Spec.from_str(text)` or `Spec.from_dict(d)` (the
/// schema of `shared/interface.md`); problems raise `lincal.SpecError` (a ValueError) with
/// `.field`, `.line` and `.column`.
#[pyclass(module = "lincal", frozen, name = "Spec")]
pub struct PySpec {
    /// The spec and its model.
    pub inner: Arc<Loaded>,
}

/// Builds the symbolic model of the spec text `text()` reads, without the GIL; errors as
/// `SpecError` (bad input) or `ComputationError` (an expansion beyond `max_terms`).
fn build(
    py: Python<'_>,
    text: impl FnOnce() -> lincal_core::error::Result<String> + Send,
    max_terms: usize,
    origin: Origin,
    source: String,
    file: Option<String>,
) -> PyResult<PySpec> {
    let made = py.detach(move || {
        guarded(|| {
            let text = text()?;
            let spec = lincal_core::spec::from_yaml_str(&text, file.as_deref())?;
            let record = UrdfRecord::from_spec_text(&text, file.as_deref())?;
            // The basis is built when something reads it (`basis()`, the linear method):
            // a spec the CLI calibrates loads here whatever its expansion's size.
            let model = SymbolicModel::for_fitting(&spec, max_terms).map_err(|e| match &file {
                Some(f) => e.in_file(f),
                None => e,
            })?;
            let joint_names = record.map_or_else(Vec::new, |r| r.joint_names(model.joint_count()));
            Ok((model, joint_names))
        })
    });
    match made {
        Ok(Ok((model, joint_names))) => Ok(PySpec {
            inner: Arc::new(Loaded {
                model,
                source,
                joint_names,
            }),
        }),
        Ok(Err(e)) => Err(errors::to_py(py, &e, origin)),
        Err(()) => Err(errors::internal(py, "loading the spec")),
    }
}

/// The tool frames of `Spec.tool_pose`: origins (N, 3) and unit quaternions (N, 4).
type PoseArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

use crate::params::param_values;

#[pymethods]
impl PySpec {
    /// Loads a spec file (YAML). `max_terms` bounds the exact expansion (default
    /// `DEFAULT_MAX_TERMS`).
    ///
    /// Raises SpecError (a ValueError) naming the file, line, column and field of every
    /// problem. The exact expansion is built when something reads it (`basis()`, the linear
    /// method of `calibrate`), and raises ComputationError there if it would exceed
    /// `max_terms` terms.
    #[staticmethod]
    #[pyo3(signature = (path, *, max_terms = None))]
    fn from_yaml(
        py: Python<'_>,
        path: PathBuf,
        #[pyo3(from_py_with = crate::ints::max_terms)] max_terms: Option<usize>,
    ) -> PyResult<PySpec> {
        let max_terms = max_terms.unwrap_or(DEFAULT_MAX_TERMS);
        let name = path.display().to_string();
        let p = path.clone();
        build(
            py,
            move || {
                let limit = lincal_core::spec::load::MAX_SPEC_BYTES;
                lincal_core::error::read_input_file(&p, "spec file", limit)
            },
            max_terms,
            Origin::SpecText,
            name.clone(),
            Some(name),
        )
    }

    /// Parses spec text (YAML); errors as `from_yaml`, located in the text.
    #[staticmethod]
    #[pyo3(signature = (text, *, max_terms = None))]
    fn from_str(
        py: Python<'_>,
        text: String,
        #[pyo3(from_py_with = crate::ints::max_terms)] max_terms: Option<usize>,
    ) -> PyResult<PySpec> {
        let max_terms = max_terms.unwrap_or(DEFAULT_MAX_TERMS);
        build(
            py,
            move || Ok(text),
            max_terms,
            Origin::SpecText,
            "<text>".to_string(),
            None,
        )
    }

    /// Builds a spec from a dict with the schema of a YAML spec (nested dicts, lists,
    /// strings, numbers; numpy scalars and arrays are taken as their Python values).
    ///
    /// The dict goes through the same loader as a YAML file, so the errors are the same:
    /// SpecError with `.field` (e.g. `joints[1].home`); `.line` is None (a dict has no lines).
    #[staticmethod]
    #[pyo3(signature = (d, *, max_terms = None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::ints::max_terms)] max_terms: Option<usize>,
    ) -> PyResult<PySpec> {
        let max_terms = max_terms.unwrap_or(DEFAULT_MAX_TERMS);
        if d.cast::<pyo3::types::PyMapping>().is_err() {
            return Err(errors::input_error(
                py,
                "(top level)",
                "a spec is a dict (name, dim, joints, params, constraint...)",
            ));
        }
        let limit = lincal_core::spec::load::MAX_SPEC_BYTES;
        let text = convert::to_yaml(d, limit).map_err(|u| {
            let e = lincal_core::Error::input(
                lincal_core::error::Location {
                    field: Some(u.field),
                    ..Default::default()
                },
                u.message,
            );
            errors::to_py(py, &e, Origin::SpecDict)
        })?;
        build(
            py,
            move || Ok(text),
            max_terms,
            Origin::SpecDict,
            "<dict>".to_string(),
            None,
        )
    }

    /// The spec's `name`.
    #[getter]
    fn name(&self) -> String {
        self.inner.model.spec().name.clone()
    }

    /// 2 (planar) or 3.
    #[getter]
    fn dim(&self) -> usize {
        self.inner.model.dim()
    }

    /// Number of joints `n` (columns of `q`).
    #[getter]
    fn joint_count(&self) -> usize {
        self.inner.model.joint_count()
    }

    /// Every parameter name of `params`, in spec order (known ones included).
    #[getter]
    fn params(&self) -> Vec<String> {
        self.inner
            .model
            .spec()
            .params
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// The estimated parameter names (known ones left out), in spec order: the order of a
    /// parameter vector `p`.
    #[getter]
    fn estimated(&self) -> Vec<String> {
        let m = &self.inner.model;
        (0..m.param_count())
            .map(|j| m.param_name(j).to_string())
            .collect()
    }

    /// The nominal value of every parameter, name -> value (spec order).
    #[getter]
    fn nominal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for p in &self.inner.model.spec().params {
            d.set_item(&p.name, p.nominal.to_f64())?;
        }
        Ok(d)
    }

    /// The names of the parameters the spec declares `known: true`.
    #[getter]
    fn known(&self) -> Vec<String> {
        self.inner
            .model
            .spec()
            .params
            .iter()
            .filter(|p| p.known)
            .map(|p| p.name.clone())
            .collect()
    }

    /// The kind of each constraint (`line`, `plane`, `measured`, ...), one entry per
    /// constraint of a list, one entry for a single `constraint:`.
    #[getter]
    fn constraints(&self) -> Vec<String> {
        let m = &self.inner.model;
        (0..m.constraint_count())
            .map(|j| m.constraint_kind(j).name().to_string())
            .collect()
    }

    /// Whether the spec has a list (`constraints:`), so `calibrate` needs `constraint`.
    #[getter]
    fn constraint_list(&self) -> bool {
        self.inner.model.spec().constraint_list
    }

    /// Whether some constraint is `measured` or `measured_pose`, so `calibrate` needs `x`.
    #[getter]
    fn measured(&self) -> bool {
        let m = &self.inner.model;
        (0..m.constraint_count()).any(|j| m.constraint_kind(j).is_measured())
    }

    /// Whether the constraint is `measured_pose` (the tool frame's position and orientation
    /// are measured), so `calibrate` needs `x` and `quaternion` or `rotvec`.
    #[getter]
    fn measured_pose(&self) -> bool {
        arrays::is_pose_model(&self.inner.model)
    }

    /// The symbolic result: what `lincal basis SPEC --format json` prints.
    ///
    /// Raises ComputationError when the exact expansion would exceed the spec's `max_terms`.
    fn basis(&self, py: Python<'_>) -> PyResult<Basis> {
        let model = &self.inner.model;
        let ready = py.detach(|| guarded(|| model.basis_ready().map_err(str::to_string)));
        match ready {
            Ok(Ok(())) => Ok(Basis {
                json: lincal_core::report::basis_json(model),
            }),
            Ok(Err(message)) => Err(errors::to_py(
                py,
                &lincal_core::error::Error::other(format!("{message} (the bound is `max_terms`)")),
                Origin::SpecText,
            )),
            Err(()) => Err(errors::internal(py, "building the basis")),
        }
    }

    /// The tips of the poses `q` (N, n) at `params`: an (N, dim) array, metres.
    ///
    /// `params`: None (the nominals), a Calibration, a dict name -> value (estimated
    /// parameters left out take their nominal), or P numbers in the order of `estimated`.
    /// A tip beyond 10⁹ m (or not finite) raises InputError (`field` "params"), as
    /// `lincal predict` refuses it.
    #[pyo3(signature = (q, params = None))]
    fn tip<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        params: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let model = &self.inner.model;
        let p = param_values(py, &self.inner.model, params)?;
        let arr = arrays::float_rows(py, q, "q", model.joint_count(), &arrays::joint_names(model))?;
        let rows = arrays::rows(py, &arr, "q", &|c| format!("q{}", c + 1), None)?;
        let dim = model.dim();
        let tips = py
            .detach(|| {
                guarded(|| {
                    let mut out = vec![0.0; rows.len() * dim];
                    for (row, t) in rows.iter().zip(out.chunks_exact_mut(dim.max(1))) {
                        model.tip(row, &p, t);
                    }
                    out
                })
            })
            .map_err(|()| errors::internal(py, "Spec.tip"))?;
        // As `lincal predict`: a tip beyond 10⁹ m is not a robot's, so not an answer.
        if let Some(i) = tips
            .iter()
            .position(|v| !v.is_finite() || v.abs() > MAX_PREDICTED)
        {
            return Err(errors::input_error(
                py,
                "params",
                &format!(
                    "the predicted tip of pose {} has a coordinate {:e}, beyond {MAX_PREDICTED:e}: \
                     the parameters are not a robot's",
                    i / dim.max(1),
                    tips[i]
                ),
            ));
        }
        arrays::array2(py, tips, dim)
    }

    /// The tool frame of the poses `q` (N, n) at `params` (3-D specs): a tuple of the origins
    /// (N, 3), metres, and the orientations as unit quaternions (N, 4), scalar first
    /// (`qw, qx, qy, qz`, `qw >= 0`), in the world (base) frame; what `lincal predict` prints
    /// for a `measured_pose` spec. The tool frame is `tool: {x, y, z, roll, pitch, yaw}` in
    /// the last link's frame (for `tool: [x, y, z]`, the last frame's axes). `params` as in
    /// `tip`.
    #[pyo3(signature = (q, params = None))]
    fn tool_pose<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        params: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PoseArrays<'py>> {
        let model = &self.inner.model;
        if model.dim() != 3 {
            return Err(errors::input_error(
                py,
                "dim",
                "a planar spec (dim 2) has no tool frame orientation: use `Spec.tip`",
            ));
        }
        let p = param_values(py, &self.inner.model, params)?;
        let arr = arrays::float_rows(py, q, "q", model.joint_count(), &arrays::joint_names(model))?;
        let rows = arrays::rows(py, &arr, "q", &|c| format!("q{}", c + 1), None)?;
        let made = py
            .detach(|| guarded(|| crate::poses::tool_poses(model, &rows, &p)))
            .map_err(|()| errors::internal(py, "Spec.tool_pose"))?;
        let Some((x, quat)) = made else {
            return Err(errors::internal(py, "Spec.tool_pose (no kinematic chain)"));
        };
        Ok((arrays::array2(py, x, 3)?, arrays::array2(py, quat, 4)?))
    }

    /// The geometric distance of each pose's tip from its constraint at `params` (metres),
    /// an (N,) array: the residuals a calibration at `params` would report. `params` as in
    /// `tip` (None: the nominals, which gives the residuals before calibration); `x`,
    /// `quaternion`, `rotvec`, `constraint` as in `lincal.calibrate`. For a `measured_pose`
    /// spec, the position error of each pose (as `Calibration.residuals`).
    #[pyo3(signature = (q, params = None, *, x = None, quaternion = None, rotvec = None,
                        constraint = None))]
    #[allow(clippy::too_many_arguments)]
    fn residuals<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        params: Option<&Bound<'py, PyAny>>,
        x: Option<&Bound<'py, PyAny>>,
        quaternion: Option<&Bound<'py, PyAny>>,
        rotvec: Option<&Bound<'py, PyAny>>,
        constraint: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let model = &self.inner.model;
        let p = param_values(py, &self.inner.model, params)?;
        let poses = arrays::poses(
            py,
            model,
            model.spec().constraint_list,
            q,
            x,
            arrays::Orientation { quaternion, rotvec },
            constraint,
            None,
        )?;
        if arrays::is_pose_model(model) {
            let r = py
                .detach(|| guarded(|| crate::poses::pose_errors(model, &poses, &p).0))
                .map_err(|()| errors::internal(py, "Spec.residuals"))?;
            return Ok(numpy::IntoPyArray::into_pyarray(r, py));
        }
        let r = py
            .detach(|| guarded(|| lincal_core::calibrate::pose_residuals(model, &poses, &p)))
            .map_err(|()| errors::internal(py, "Spec.residuals"))?
            .map_err(|e| errors::to_py(py, &e, Origin::Data))?;
        Ok(numpy::IntoPyArray::into_pyarray(r, py))
    }

    /// Judges `params` on held-out poses `q` beside the nominals, as `lincal evaluate` does:
    /// each constraint's unknown values refitted to the held-out tips (the fixture may have
    /// moved), per constraint the residual RMS and largest residual, for points the spread
    /// and mean tip, per pair of points the distance between the means. A dict, the JSON of
    /// `lincal evaluate --format json` without `name`, `params` and `files`. `params`, `x`,
    /// `quaternion`, `rotvec`, `constraint` as in `residuals`.
    #[pyo3(signature = (q, params = None, *, x = None, quaternion = None, rotvec = None,
                        constraint = None))]
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &self,
        py: Python<'_>,
        q: &Bound<'_, PyAny>,
        params: Option<&Bound<'_, PyAny>>,
        x: Option<&Bound<'_, PyAny>>,
        quaternion: Option<&Bound<'_, PyAny>>,
        rotvec: Option<&Bound<'_, PyAny>>,
        constraint: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let model = &self.inner.model;
        let p = param_values(py, &self.inner.model, params)?;
        let poses = arrays::poses(
            py,
            model,
            model.spec().constraint_list,
            q,
            x,
            arrays::Orientation { quaternion, rotvec },
            constraint,
            None,
        )?;
        // A Calibration's own orientation weight, so that the pose RMS is the fit's measure.
        let weight = params
            .and_then(|c| c.cast::<crate::result::Calibration>().ok())
            .and_then(|c| c.get().estimate.pose_noise.as_ref().map(|n| n.weight));
        let e = py
            .detach(|| {
                guarded(|| {
                    lincal_core::calibrate::validation::evaluate_weighted(model, &poses, &p, weight)
                })
            })
            .map_err(|()| errors::internal(py, "Spec.evaluate"))?
            .map_err(|e| errors::to_py(py, &e, Origin::Data))?;
        let mut v = serde_json::to_value(&e).unwrap_or(serde_json::Value::Null);
        // A Calibration's joint ranges judge the held-out poses' extrapolation, as
        // `lincal evaluate` does (`beyond_ranges`).
        if let (Some(c), serde_json::Value::Object(map)) = (
            params.and_then(|c| c.cast::<crate::result::Calibration>().ok()),
            &mut v,
        ) {
            let prismatic = model.spec().prismatic_joints();
            let ranges = &c.get().estimate.joint_ranges;
            if let Some(Ok(b)) =
                lincal_core::calibrate::joint_ranges::beyond_ranges(ranges, &prismatic, &poses)
                    .map(|b| serde_json::to_value(&b))
            {
                map.insert("beyond_ranges".into(), b);
            }
        }
        convert::to_python(py, &v)
    }

    /// Reads a data CSV (the format of `lincal calibrate`) into arrays: a dict with `q`
    /// (N, n), `x` (N, dim; NaN rows for poses on constraints that are not measured) or
    /// None, `constraint` (N,) or None, and `lines` (N,), the 1-based line of each pose; for
    /// a `measured_pose` spec also `quaternion` (N, 4), the measured orientations as unit
    /// quaternions (scalar first, `qw >= 0`) whichever form the file holds. The dict is the
    /// keyword arguments of `lincal.calibrate`.
    /// `path` is one file or a list of them, read as `lincal calibrate` reads its data
    /// files: a spec with a list of constraints takes one file per constraint, in order
    /// (file `k` holds the poses on constraint `k`, without a `constraint` column); the
    /// files of a spec with one constraint are joined. A spec imported from a URDF (its
    /// `urdf:` record) also takes the URDF's joint names as the joint columns' headers.
    /// `angles` is the unit of revolute readings, as `lincal calibrate --angles`: `"rad"`,
    /// `"deg"` (converted to radians as read) or `"auto"` (radians; a reading beyond a full
    /// turn and outside the joint's limits raises DataError as likely degrees).
    /// Raises DataError naming the file, line and column of a bad cell.
    #[pyo3(signature = (path, *, angles = "auto"))]
    fn read_csv<'py>(
        &self,
        py: Python<'py>,
        path: DataPaths,
        angles: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let model = &self.inner.model;
        let list = model.spec().constraint_list;
        let mut layout = DataLayout::of_model(model, list);
        layout.joint_names.clone_from(&self.inner.joint_names);
        layout.angles = angles
            .parse::<Angles>()
            .map_err(|m| errors::input_error(py, "angles", &m))?;
        let paths = path.into_vec();
        if paths.is_empty() {
            return Err(errors::input_error(py, "path", "no data file given"));
        }
        let poses: Poses = py
            .detach(|| {
                guarded(|| {
                    let p: Vec<&std::path::Path> = paths.iter().map(PathBuf::as_path).collect();
                    Poses::from_csv_paths(&p, &layout)
                })
            })
            .map_err(|()| errors::internal(py, "Spec.read_csv"))?
            .map_err(|e| errors::to_py(py, &e, Origin::Data))?;
        let n = poses.len();
        let d = PyDict::new(py);
        let joints = model.joint_count();
        let mut q = Vec::with_capacity(n * joints);
        for row in &poses.q {
            q.extend_from_slice(row);
        }
        d.set_item("q", arrays::array2(py, q, joints)?)?;
        let dim = model.dim();
        match &poses.measured {
            Some(m) => {
                let mut x = Vec::with_capacity(n * dim);
                for row in m {
                    if row.len() < dim {
                        x.extend(std::iter::repeat_n(f64::NAN, dim));
                    } else {
                        // A measured pose's row holds its rotation after the tip.
                        x.extend_from_slice(&row[..dim]);
                    }
                }
                d.set_item("x", arrays::array2(py, x, dim)?)?;
                if arrays::is_pose_model(model) {
                    let quat = crate::poses::measured_quaternions(m);
                    d.set_item("quaternion", arrays::array2(py, quat, 4)?)?;
                }
            }
            None => d.set_item("x", py.None())?,
        }
        if list {
            let c: Vec<i64> = poses.constraint.iter().map(|j| j as i64).collect();
            d.set_item("constraint", numpy::IntoPyArray::into_pyarray(c, py))?;
        } else {
            d.set_item("constraint", py.None())?;
        }
        let lines: Vec<i64> = poses.line.iter().map(|l| l as i64).collect();
        d.set_item("lines", numpy::IntoPyArray::into_pyarray(lines, py))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let m = &self.inner.model;
        format!(
            "Spec(name={:?}, dim={}, joints={}, constraints=[{}], estimated=[{}], source={:?})",
            m.spec().name,
            m.dim(),
            m.joint_count(),
            convert::names((0..m.constraint_count()).map(|j| m.constraint_kind(j).name())),
            convert::names((0..m.param_count()).map(|j| m.param_name(j))),
            self.inner.source
        )
    }
}

/// `Spec.read_csv`'s files: one path, or a list of them.
#[derive(FromPyObject)]
pub enum DataPaths {
    /// One file.
    One(PathBuf),
    /// Several files, in order.
    Many(Vec<PathBuf>),
}

impl DataPaths {
    fn into_vec(self) -> Vec<PathBuf> {
        match self {
            DataPaths::One(p) => vec![p],
            DataPaths::Many(v) => v,
        }
    }
}
