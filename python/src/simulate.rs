//! `lincal.simulate` and its result, `lincal.Simulation`.

use std::path::PathBuf;

use lincal_core::model::geometry::ConstraintKind;
use lincal_core::model::rotation;
use lincal_core::model::CalibModel;
use lincal_core::simulate::{self as sim, Noise};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays;
use crate::errors::{self, guarded, Origin};
use crate::params::param_values;
use crate::spec::PySpec;

/// A simulated data set: the recorded readings (and measured tips, constraint indices) ready
/// for `lincal.calibrate`, the true readings and the true parameters.
#[pyclass(module = "lincal", frozen)]
pub struct Simulation {
    q: Py<PyArray2<f64>>,
    true_q: Py<PyArray2<f64>>,
    x: Option<Py<PyArray2<f64>>>,
    quaternion: Option<Py<PyArray2<f64>>>,
    constraint: Option<Py<PyArray1<i64>>>,
    truth: Vec<(String, f64)>,
}

#[pymethods]
impl Simulation {
    /// The recorded joint readings (encoder noise included), (N, n).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.q.bind(py).clone()
    }

    /// The true joint readings (before encoder noise), (N, n).
    #[getter]
    fn true_q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.true_q.bind(py).clone()
    }

    /// The measured tips (measurement noise included), (N, dim), for a spec with a
    /// `measured` or `measured_pose` constraint (NaN rows on poses of other constraints);
    /// None otherwise.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.x.as_ref().map(|a| a.bind(py).clone())
    }

    /// The measured orientations (orientation noise included) of a `measured_pose` spec, as
    /// unit quaternions (N, 4), scalar first (`qw, qx, qy, qz`, `qw >= 0`): the columns
    /// `lincal simulate` writes; None for other specs.
    #[getter]
    fn quaternion<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.quaternion.as_ref().map(|a| a.bind(py).clone())
    }

    /// The constraint of each pose, (N,) int64, for a spec with a list (round robin); None
    /// otherwise.
    #[getter]
    fn constraint<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<i64>>> {
        self.constraint.as_ref().map(|a| a.bind(py).clone())
    }

    /// The true value of every estimated parameter, name -> value.
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.truth {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// The keyword arguments of `lincal.calibrate` for this data: `q`, and `x`,
    /// `quaternion`, `constraint` when the spec needs them
    /// (`lincal.calibrate(spec, **sim.data())`).
    fn data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("q", self.q.bind(py))?;
        if let Some(x) = &self.x {
            d.set_item("x", x.bind(py))?;
        }
        if let Some(r) = &self.quaternion {
            d.set_item("quaternion", r.bind(py))?;
        }
        if let Some(c) = &self.constraint {
            d.set_item("constraint", c.bind(py))?;
        }
        Ok(d)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let n = self.q.bind(py).len().unwrap_or(0);
        let quaternion = if self.quaternion.is_some() {
            ", quaternion=(N, 4)"
        } else {
            ""
        };
        format!(
            "Simulation(poses={n}, x={}{quaternion}, constraint={})",
            if self.x.is_some() { "(N, dim)" } else { "None" },
            if self.constraint.is_some() {
                "(N,)"
            } else {
                "None"
            }
        )
    }
}

/// Simulates `n` poses of `spec` whose true tips lie on the true constraint, as
/// `lincal simulate` does (the same seed gives the same data as the command line).
///
/// `truth`: the true parameters (a dict name -> value, estimated parameters left out taking
/// their nominal; a path to a truth YAML file; or P numbers in the order of
/// `spec.estimated`), default the nominals perturbed with `seed`. `noise_track`: the true
/// tip's distance from the constraint (metres, std); `noise_encoder`: std added to the
/// recorded readings (radians, metres for prismatic joints); `noise_measure`: std added to
/// each coordinate of measured tips (metres); `noise_orientation`: std of a measured pose's
/// orientation error about each axis of the tool frame (radians, `measured_pose`).
///
/// Raises InputError for a bad truth or noise level, DegenerateError when poses cannot be
/// placed on the constraint.
#[pyfunction]
#[pyo3(signature = (spec, n, *, seed = 1, truth = None, noise_track = 0.0, noise_encoder = 0.0,
                    noise_measure = 0.0, noise_orientation = 0.0))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    spec: &Bound<'_, PySpec>,
    #[pyo3(from_py_with = crate::ints::n)] n: i64,
    #[pyo3(from_py_with = crate::ints::seed)] seed: u64,
    truth: Option<&Bound<'_, PyAny>>,
    noise_track: f64,
    noise_encoder: f64,
    noise_measure: f64,
    noise_orientation: f64,
) -> PyResult<Simulation> {
    let loaded = spec.get().inner.clone();
    let model = &loaded.model;
    let spec = model.spec();
    let n = match usize::try_from(n) {
        Ok(n) if n > 0 => n,
        _ => {
            return Err(errors::input_error(
                py,
                "n",
                &format!("the number of poses must be at least 1, not {n}"),
            ))
        }
    };
    let measured = (0..model.constraint_count()).any(|j| model.constraint_kind(j).is_measured());
    let pose = (0..model.constraint_count())
        .any(|j| model.constraint_kind(j) == ConstraintKind::MeasuredPose);
    if noise_orientation != 0.0 && !pose {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        PyErr::warn(
            py,
            &category,
            c"noise_orientation has no effect: the spec's constraint is not `measured_pose`",
            1,
        )?;
    }
    if noise_measure != 0.0 && !measured {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        PyErr::warn(
            py,
            &category,
            c"noise_measure has no effect: the spec's constraint is not `measured` (use noise_track for a tip held on a constraint)",
            1,
        )?;
    }
    let truth: Option<Vec<f64>> = match truth {
        None => None,
        Some(t) if t.is_instance_of::<pyo3::types::PyString>() || t.hasattr("__fspath__")? => {
            let path: PathBuf = t.extract()?;
            Some(
                py.detach(|| guarded(|| sim::truth_from_yaml_file(&path, model, spec)))
                    .map_err(|()| errors::internal(py, "reading the truth file"))?
                    .map_err(|e| errors::to_py(py, &e, Origin::Other))?,
            )
        }
        Some(t) => Some(param_values(py, &loaded.model, Some(t))?),
    };
    let noise = Noise {
        track: noise_track,
        encoder: noise_encoder,
        measure: noise_measure,
        orientation: noise_orientation,
    };
    // The core names the command line's options; say the keyword arguments instead.
    sim::check_noise(noise)
        .map_err(|e| errors::to_py(py, &errors::keyword_names(&e), Origin::Other))?;
    let joints = model.joint_count();
    let dim = model.dim();
    let list = spec.constraint_list;
    let cap = n.min(1 << 24);
    let with_pose = pose;
    // Before any allocation: the arrays returned (joints twice, the tip, the quaternion, the
    // constraint), so a count beyond memory is a MemoryError, not an abort.
    let per_pose = 8
        * (2 * joints
            + if measured { dim } else { 0 }
            + if pose { 4 } else { 0 }
            + usize::from(list)) as u64;
    errors::check_memory(
        &format!("a simulation of {n} poses"),
        (n as u64).saturating_mul(per_pose),
    )?;
    // On a worker thread, so that Ctrl-C stops it (checked every 4096 poses).
    let made = errors::interruptible(py, || {
        guarded(|| {
            let mut done = 0usize;
            let mut q = Vec::with_capacity(cap * joints);
            let mut true_q = Vec::with_capacity(cap * joints);
            let mut x = Vec::with_capacity(if measured { cap * dim } else { 0 });
            let mut quat = Vec::with_capacity(if pose { cap * 4 } else { 0 });
            let mut c = Vec::with_capacity(if list { cap } else { 0 });
            let p = sim::simulate_each(model, spec, n, seed, truth.as_deref(), noise, |pose| {
                done += 1;
                if done.is_multiple_of(4096) {
                    lincal_core::cancel::check()?;
                }
                q.extend_from_slice(pose.q);
                true_q.extend_from_slice(pose.true_q);
                if measured {
                    // A measured pose's row: the tip, then its rotation column-major.
                    match pose.measured {
                        Some(m) if m.len() >= dim => x.extend_from_slice(&m[..dim]),
                        _ => x.extend(std::iter::repeat_n(f64::NAN, dim)),
                    }
                }
                if with_pose {
                    match pose
                        .measured
                        .and_then(|m| m.get(dim..dim + 9))
                        .and_then(|r| <&[f64; 9]>::try_from(r).ok())
                    {
                        Some(r) => quat.extend_from_slice(&rotation::quaternion_from_matrix(r)),
                        None => quat.extend([f64::NAN; 4]),
                    }
                }
                if list {
                    c.push(pose.constraint as i64);
                }
                Ok(())
            })?;
            Ok::<_, lincal_core::Error>((p, q, true_q, x, quat, c))
        })
    })?;
    let (p, q, true_q, x, quat, c) = made
        .map_err(|()| errors::internal(py, "simulate"))?
        .map_err(|e| errors::to_py(py, &e, Origin::Other))?;
    Ok(Simulation {
        q: arrays::array2(py, q, joints)?.unbind(),
        true_q: arrays::array2(py, true_q, joints)?.unbind(),
        x: if measured {
            Some(arrays::array2(py, x, dim)?.unbind())
        } else {
            None
        },
        quaternion: if pose {
            Some(arrays::array2(py, quat, 4)?.unbind())
        } else {
            None
        },
        constraint: if list {
            Some(numpy::IntoPyArray::into_pyarray(c, py).unbind())
        } else {
            None
        },
        truth: (0..model.param_count())
            .map(|j| (model.param_name(j).to_string(), p[j]))
            .collect(),
    })
}
