//! `lincal.select` and its result, `lincal.Selection`: the poses worth measuring, as
//! `lincal select` chooses them.

use lincal_core::calibrate::prior::PriorChoice;
use lincal_core::data::{PoseColumn, Poses, Rows};
use lincal_core::model::CalibModel;
use lincal_core::select::plan::{plan, Candidates, Plan, PlanOptions};
use lincal_core::select::summary;
use lincal_core::simulate::{check_noise, Noise};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use serde_json::Value;

use crate::arrays;
use crate::convert;
use crate::errors::{self, guarded, Origin};
use crate::spec::PySpec;

/// The poses `lincal.select` chose: their indices into the candidates, their joint readings,
/// and what they are worth (the figures of `lincal select --format json`: `to_dict()`).
#[pyclass(module = "lincal", frozen)]
pub struct Selection {
    indices: Py<PyArray1<i64>>,
    q: Py<PyArray2<f64>>,
    constraint: Option<Py<PyArray1<i64>>>,
    json: Value,
    text: String,
}

impl Selection {
    fn field(&self, py: Python<'_>, key: &str) -> PyResult<Py<PyAny>> {
        convert::to_python(py, self.json.get(key).unwrap_or(&Value::Null))
    }
}

#[pymethods]
impl Selection {
    /// The chosen poses' indices (0-based) into `candidates` (or into the generated pool),
    /// in visiting order (an order that keeps joint motion short): an (N,) int64 array.
    #[getter]
    fn indices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.indices.bind(py).clone()
    }

    /// The chosen poses' joint readings, (N, n), in visiting order.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.q.bind(py).clone()
    }

    /// The chosen poses' constraint indices, (N,) int64, for a spec with a list; None
    /// otherwise.
    #[getter]
    fn constraint<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<i64>>> {
        self.constraint.as_ref().map(|a| a.bind(py).clone())
    }

    /// Per free parameter (the gauge-fixed ones the fit estimates), its predicted standard
    /// deviation with the chosen poses and the median over random picks of as many poses
    /// from the same pool: name -> {"std", "random_std"} (None where not finite).
    #[getter]
    fn params(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let d = pyo3::types::PyDict::new(py);
        for p in self.json["params"].as_array().into_iter().flatten() {
            let entry = pyo3::types::PyDict::new(py);
            entry.set_item("std", convert::to_python(py, &p["std"])?)?;
            entry.set_item("random_std", convert::to_python(py, &p["random_std"])?)?;
            d.set_item(p["name"].as_str().unwrap_or(""), entry)?;
        }
        Ok(d.into_any().unbind())
    }

    /// Predicted RMS tip error over the workspace with the chosen poses, metres.
    #[getter]
    fn tip_rms(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "tip_rms")
    }

    /// The same for random picks of as many poses from the pool (median), metres.
    #[getter]
    fn random_tip_rms(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "random_tip_rms")
    }

    /// Condition number of the chosen poses' whitened Jacobian, columns scaled to unit norm.
    #[getter]
    fn condition(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "condition")
    }

    /// How many random poses of the pool match the chosen ones in D (median); None when
    /// the pool holds too few.
    #[getter]
    fn worth(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "worth")
    }

    /// Kiefer-Wolfowitz lower bound on the chosen set's D-efficiency among sets of as many
    /// pool poses; None when not computed.
    #[getter]
    fn efficiency_bound(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "efficiency_bound")
    }

    /// The D criterion of the chosen poses: the mean over the parameter draws of
    /// `log det` of their information.
    #[getter]
    fn log_det(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "log_det")
    }

    /// The D criterion of random picks (median).
    #[getter]
    fn random_log_det(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "random_log_det")
    }

    /// The unknown parameters the gauge rule holds: no pose choice improves them.
    #[getter]
    fn held(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "held")
    }

    /// Candidates dropped as off their nominal constraint: dicts {candidate, line,
    /// residual}.
    #[getter]
    fn dropped(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "dropped")
    }

    /// Whether the count is below the linear method's basis size `K` (proved from samples,
    /// or read from a `K` cached by `calibrate`, whose sketch errs with probability at most
    /// about `2·10⁻⁹`).
    #[getter]
    fn below_basis_size(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "below_basis_size")
    }

    /// Notes on the choice, one sentence each (dropped candidates, held parameters, a count
    /// below `K`).
    #[getter]
    fn notes(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "notes")
    }

    /// The standard deviations the residuals were whitened by: {constraint, measured,
    /// orientation, encoder} (defaults filled in).
    #[getter]
    fn sigma(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "sigma")
    }

    /// The calibration's weak-direction prior the plan was made for: {shape, weight,
    /// length_tolerance, angle_tolerance, applied, weak} (`applied`: the data alone left
    /// `weak` weak, so the plan counted the prior, as the fit will apply it); None when off.
    #[getter]
    fn prior(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.field(py, "prior")
    }

    /// The summary `lincal select` prints on stderr.
    fn summary(&self) -> String {
        self.text.clone()
    }

    /// Every field, as `lincal select SPEC … --format json` prints it (`line` is None).
    fn to_dict(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        convert::to_python(py, &self.json)
    }

    /// The JSON text of `to_dict()`.
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(&self.json).unwrap_or_default()
    }

    fn __repr__(&self) -> String {
        let num = |k: &str| self.json[k].as_f64().unwrap_or(f64::NAN);
        format!(
            "Selection(poses={}, pool={}, criterion={:?}, tip_rms={:.3e}, random_tip_rms={:.3e})",
            self.json["count"],
            self.json["pool"],
            self.json["criterion"].as_str().unwrap_or(""),
            num("tip_rms"),
            num("random_tip_rms")
        )
    }
}

/// The joint readings `q` (named `what`) and constraint indices (`constraint`, named
/// `constraint_what`) as poses without measurements (a plan uses the model's own tips).
fn joint_poses(
    py: Python<'_>,
    model: &dyn CalibModel,
    list: bool,
    q: &Bound<'_, PyAny>,
    constraint: Option<&Bound<'_, PyAny>>,
    (what, constraint_what): (&str, &str),
) -> PyResult<Poses> {
    let joints = model.joint_count();
    let arr = arrays::float_rows(py, q, what, joints, &arrays::joint_names(model))?;
    let n = arr.as_array().dim().0;
    if n == 0 {
        return Err(errors::data_error(
            py,
            Some(what),
            None,
            &format!("`{what}` has no rows: at least one pose"),
        ));
    }
    let qrows = arrays::rows(py, &arr, what, &|c| format!("q{}", c + 1), None)?;
    let count = model.constraint_count();
    let c = arrays::constraint_indices(py, count, list, constraint, n, constraint_what)?;
    let measured = (0..count).any(|j| model.constraint_kind(j).is_measured());
    let measured = measured.then(|| {
        let width = if arrays::is_pose_model(model) {
            12
        } else {
            model.dim()
        };
        let mut rows = Rows::new(width);
        for _ in 0..n {
            rows.push(&[]);
        }
        rows
    });
    Ok(Poses {
        q: qrows,
        measured,
        constraint: PoseColumn::labels_from(c),
        line: PoseColumn::counting_from(Vec::new()),
        files: Default::default(),
    })
}

/// A count argument: an integer from `min`, or an `InputError` naming `what`.
fn count_arg(py: Python<'_>, v: i64, min: i64, what: &str) -> PyResult<usize> {
    match usize::try_from(v) {
        Ok(u) if v >= min => Ok(u),
        _ => Err(errors::input_error(
            py,
            what,
            &format!("`{what}` must be an integer of at least {min}, not {v}"),
        )),
    }
}

/// The plan's options from `select`'s arguments, each checked (an `InputError` naming it).
fn plan_options(
    py: Python<'_>,
    n: i64,
    seed: u64,
    criterion: &str,
    draws: i64,
    noise: Noise,
    max_off: f64,
) -> PyResult<PlanOptions> {
    let tip = match criterion {
        "d" | "D" => false,
        "tip" => true,
        other => {
            return Err(errors::input_error(
                py,
                "criterion",
                &format!("`{other}` is not a criterion: expected \"d\" or \"tip\""),
            ))
        }
    };
    check_noise(noise).map_err(|e| errors::to_py(py, &errors::keyword_names(&e), Origin::Other))?;
    if !(max_off.is_finite() && max_off > 0.0) {
        return Err(errors::input_error(
            py,
            "max_off",
            &format!("{max_off} is not a positive distance"),
        ));
    }
    Ok(PlanOptions {
        count: count_arg(py, n, 1, "n")?,
        draws: count_arg(py, draws, 0, "draws")?,
        seed,
        tip,
        noise,
        max_off,
        prior: PriorChoice::default(),
    })
}

/// Chooses the `n` poses worth measuring for calibrating `spec`, as `lincal select` does:
/// D-optimality of the whitened geometric-residual Jacobian over the free parameters,
/// averaged over the nominals and `draws` parameter draws within tolerance (`criterion="tip"`:
/// the least predicted tip error over the workspace instead), greedy with rank-m updates and
/// a bounded exchange.
///
/// `candidates`: (M, n) joint readings to choose from (a plan needs no measured tips: it
/// uses the model's); `constraint`: (M,) their constraint indices for a spec with a list.
/// Or `pool`: M poses projected onto the nominal constraint (as `simulate` places them).
/// `given`: (G, n) readings of poses already measured (`given_constraint` for a list):
/// their information enters first. `seed`: of the pool, the draws and the random baseline.
/// `noise_track`, `noise_measure` (metres; 1e-5 when neither is given), `noise_encoder`
/// (radians), `noise_orientation` (radians, `measured_pose`): the residuals' noise, each
/// pose's covariance `σ²I + σ_enc²(∂g/∂q)(∂g/∂q)ᵀ`. `max_off`: candidates farther than this
/// from their nominal constraint are dropped (metres). `prior`, `prior_weight`,
/// `tolerance_length`, `tolerance_angle`: the weak-direction prior the calibration will use,
/// as `calibrate`'s (default: each joint's mounting at the drawing's tolerance, 1 cm and
/// 0.01 rad, where the fit's choice starts); its information counts in every
/// design, so poses go where it does not already know (`prior="off"`: the data alone).
///
/// Raises InputError (a ValueError) naming the argument for a bad argument, `n` above the
/// pool, or no pose source; DataError for a bad array; DegenerateError when `n` poses cannot
/// see every free parameter (naming those that stay unseen).
#[pyfunction]
#[pyo3(signature = (spec, n, *, candidates = None, constraint = None, pool = None, seed = 1,
                    given = None, given_constraint = None, criterion = "d", draws = 3,
                    noise_track = 0.0, noise_encoder = 0.0, noise_measure = 0.0,
                    noise_orientation = 0.0, max_off = 0.05, prior = None,
                    prior_weight = None, tolerance_length = None, tolerance_angle = None))]
#[allow(clippy::too_many_arguments)]
pub fn select(
    py: Python<'_>,
    spec: &Bound<'_, PySpec>,
    #[pyo3(from_py_with = crate::ints::n)] n: i64,
    candidates: Option<&Bound<'_, PyAny>>,
    constraint: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::ints::pool)] pool: Option<i64>,
    #[pyo3(from_py_with = crate::ints::seed)] seed: u64,
    given: Option<&Bound<'_, PyAny>>,
    given_constraint: Option<&Bound<'_, PyAny>>,
    criterion: &str,
    #[pyo3(from_py_with = crate::ints::draws)] draws: i64,
    noise_track: f64,
    noise_encoder: f64,
    noise_measure: f64,
    noise_orientation: f64,
    max_off: f64,
    prior: Option<&Bound<'_, PyAny>>,
    prior_weight: Option<f64>,
    tolerance_length: Option<f64>,
    tolerance_angle: Option<f64>,
) -> PyResult<Selection> {
    let loaded = spec.get().inner.clone();
    let model = &loaded.model;
    let list = model.spec().constraint_list;
    let noise = Noise {
        track: noise_track,
        encoder: noise_encoder,
        measure: noise_measure,
        orientation: noise_orientation,
    };
    let mut opts = plan_options(py, n, seed, criterion, draws, noise, max_off)?;
    opts.prior =
        crate::calibrate::prior_of(py, prior, tolerance_length, tolerance_angle, prior_weight)?;
    let source = match (candidates, pool) {
        (Some(_), Some(_)) => {
            return Err(errors::input_error(
                py,
                "pool",
                "give `candidates` or `pool`, not both",
            ))
        }
        (None, None) => {
            return Err(errors::input_error(
                py,
                "candidates",
                "give `candidates` (joint readings to choose from) or `pool` (how many poses \
                 to generate)",
            ))
        }
        (Some(c), None) => Candidates::Given(joint_poses(
            py,
            model,
            list,
            c,
            constraint,
            ("candidates", "constraint"),
        )?),
        (None, Some(m)) => {
            if constraint.is_some() {
                return Err(errors::input_error(
                    py,
                    "constraint",
                    "`constraint` goes with `candidates`: a generated pool places its own",
                ));
            }
            Candidates::Generated(count_arg(py, m, 1, "pool")?)
        }
    };
    let given = given
        .map(|g| {
            joint_poses(
                py,
                model,
                list,
                g,
                given_constraint,
                ("given", "given_constraint"),
            )
        })
        .transpose()?;
    if given.is_none() && given_constraint.is_some() {
        return Err(errors::input_error(
            py,
            "given_constraint",
            "`given_constraint` goes with `given`",
        ));
    }
    let outcome = errors::interruptible(py, || {
        guarded(|| plan(model, model.spec(), source, given.as_ref(), &opts))
    })?;
    let result = outcome
        .map_err(|()| errors::internal(py, "select"))?
        .map_err(|e| errors::to_py(py, &errors::keyword_names(&e), Origin::Other))?;
    selection(py, &result, &opts, list)
}

/// The Python result of a plan.
fn selection(py: Python<'_>, plan: &Plan, opts: &PlanOptions, list: bool) -> PyResult<Selection> {
    let joints = plan.pool.q.width();
    let mut q = Vec::with_capacity(plan.chosen.len() * joints);
    for &i in &plan.chosen {
        q.extend_from_slice(&plan.pool.q[i]);
    }
    let indices: Vec<i64> = plan
        .chosen
        .iter()
        .map(|&i| plan.pool_index[i] as i64)
        .collect();
    let constraint: Vec<i64> = plan
        .chosen
        .iter()
        .map(|&i| plan.pool.constraint.at(i) as i64)
        .collect();
    Ok(Selection {
        indices: numpy::IntoPyArray::into_pyarray(indices, py).unbind(),
        q: arrays::array2(py, q, joints)?.unbind(),
        constraint: list.then(|| numpy::IntoPyArray::into_pyarray(constraint, py).unbind()),
        json: summary::plan_json(plan, opts, false),
        text: summary::plan_text(plan, opts),
    })
}
