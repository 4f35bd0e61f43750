//! Simulated calibration data: poses whose true tips lie on the true constraint, with the
//! noise of a real experiment (`lincal simulate`).
//!
//! # The method
//! 1. **True parameters** `p*`: from a truth file (a YAML mapping `name: value`, see
//!    [`truth_from_yaml_str`]) or the nominals perturbed deterministically with the seed
//!    ([`perturbed_truth`]): lengths by ±1–2 % (±1–2 mm when the nominal is 0), angles by up to
//!    ±0.02 rad, constraint coefficients by ±0.5–1 % so the constraint still crosses the
//!    workspace the nominal one crosses.
//! 2. **Joint readings**: uniform inside the joint limits (default `[−π, π]` for a revolute
//!    joint, `[0, 0.5]` m for a prismatic one), then projected onto the true constraint by
//!    Newton steps in joint space, the minimum-norm step `Δq = −J⁺ r = −Jᵀ(JJᵀ)⁻¹ r` (through
//!    the SVD) with `J = ∂r/∂q` by central differences. `r` is the geometric residual
//!    ([`geometry::geometric_residual`]: signed distance from a line or plane, offset from a
//!    point, `‖x − c‖ − r` for circles and spheres, Sampson distance for a quadric) minus a
//!    target offset. Its zero set is exactly that of [`geometry::constraint_function`], but it
//!    is in metres, so the tracking noise is a distance and the convergence test one number. A
//!    pose whose projection does not converge (to `1e-12` m), leaves the joint limits or
//!    reaches a singular configuration is rejected and a new one drawn.
//! 3. **Noise**: tracking noise (`--noise-track M`) sets the target offset to `N(0, M²)` per
//!    normal direction, so the true tip sits that far off the constraint (what a tracker that
//!    holds the tip on a laser line to within `M` does); encoder noise (`--noise-encoder RAD`)
//!    adds `N(0, RAD²)` to every recorded joint reading (metres for prismatic joints);
//!    measurement noise (`--noise-measure M`) adds `N(0, M²)` to every coordinate of a
//!    measured tip. For a `measured` constraint there is nothing to project onto: the readings
//!    stay uniform and the true tip is written as `x, y(, z)`.
//! 4. With a list of constraints, pose `l` lies on constraint `l mod count` (round robin).
//!
//! Everything is deterministic for a given seed (ChaCha8, with separate streams for the
//! truth and the poses, so `--truth` does not change the poses drawn).

use std::io::Write;
use std::path::Path;

use crate::spec::node::{parse_yaml, Value, YamlError};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::data::Poses;
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};
use crate::model::geometry::{self, ConstraintKind};
use crate::model::CalibModel;
use crate::spec::{Exact, Spec};

/// Noise levels of a simulated experiment (standard deviations; 0 for none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Noise {
    /// Tracking noise: distance of the true tip from the constraint, metres, per normal
    /// direction.
    pub track: f64,
    /// Encoder noise added to the recorded joint readings (radians; metres for prismatic
    /// joints).
    pub encoder: f64,
    /// Noise added to each coordinate of a measured tip, metres.
    pub measure: f64,
}

/// A simulated data set.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// The true estimated parameters `p*` (the model's order).
    pub truth: Vec<f64>,
    /// The recorded poses (joint readings with encoder noise, measured tips with measurement
    /// noise, the constraint of each pose).
    pub poses: Poses,
    /// The true joint readings, before encoder noise.
    pub true_q: Vec<Vec<f64>>,
}

/// Default sampling range of a joint without limits.
#[must_use]
pub fn default_joint_range(prismatic: bool) -> [f64; 2] {
    if prismatic {
        [0.0, 0.5]
    } else {
        [-std::f64::consts::PI, std::f64::consts::PI]
    }
}

/// Names of the parameters used in the spec's constraint slots.
fn constraint_param_names(spec: &Spec) -> Vec<String> {
    spec.constraints
        .iter()
        .flat_map(|c| c.slots())
        .filter_map(|s| s.param().map(str::to_string))
        .collect()
}

/// A standard normal deviate (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn random_sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.gen::<bool>() {
        1.0
    } else {
        -1.0
    }
}

/// The nominals of the model's estimated parameters perturbed deterministically with `seed`:
/// angles by a uniform amount in `[−0.02, 0.02]` rad; robot lengths by ±1–2 % (±1–2 mm when
/// the nominal is 0); constraint coefficients (parameters used in constraint slots) by
/// ±0.5–1 % (±0.001–0.002 when the nominal is 0), so a constraint that crosses the nominal
/// workspace still crosses the true one.
#[must_use]
pub fn perturbed_truth(model: &dyn CalibModel, spec: &Spec, seed: u64) -> Vec<f64> {
    perturb(model, spec, seed, 1.0)
}

/// [`perturbed_truth`] with the constraint coefficients' perturbation scaled by
/// `constraint_scale` (the random draws are the same whatever the scale).
fn perturb(model: &dyn CalibModel, spec: &Spec, seed: u64, constraint_scale: f64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(1);
    let in_constraint = constraint_param_names(spec);
    (0..model.param_count())
        .map(|j| {
            let nominal = model.param_nominal(j);
            let sign = random_sign(&mut rng);
            let u: f64 = rng.gen::<f64>();
            let of_constraint = in_constraint.iter().any(|n| n == model.param_name(j));
            let scale = if of_constraint { constraint_scale } else { 1.0 };
            if model.param_is_angle(j) {
                nominal + scale * 0.02 * (2.0 * u - 1.0)
            } else if nominal == 0.0 {
                scale * sign * (0.001 + 0.001 * u)
            } else if of_constraint {
                nominal * (1.0 + scale * sign * (0.005 + 0.005 * u))
            } else {
                nominal * (1.0 + sign * (0.01 + 0.01 * u))
            }
        })
        .collect()
}

/// The seeded truth: [`perturbed_truth`] when its constraint(s) still cross the workspace (a
/// trial projection places poses on each), else the same with the constraint perturbation
/// halved, quartered, and finally none (the nominal constraint with the perturbed robot).
fn seeded_truth(model: &dyn CalibModel, spec: &Spec, seed: u64) -> Vec<f64> {
    for scale in [1.0, 0.5, 0.25] {
        let p = perturb(model, spec, seed, scale);
        if Projector::new(model, &p).crosses_workspace(seed) {
            return p;
        }
    }
    perturb(model, spec, seed, 0.0)
}

/// Reads a truth file (see [`truth_from_yaml_str`]).
///
/// # Errors
/// As [`truth_from_yaml_str`], and a file that cannot be read.
pub fn truth_from_yaml_file(path: &Path, model: &dyn CalibModel, spec: &Spec) -> Result<Vec<f64>> {
    let name = path.display().to_string();
    let text =
        crate::error::read_input_file(path, "truth file", crate::spec::load::MAX_SPEC_BYTES)?;
    truth_from_yaml_str(&text, Some(&name), model, spec)
}

/// Parses true parameter values: a YAML mapping `name: value`, each value a number or an
/// exact expression (`pi/2`). Estimated parameters it leaves out take their nominal value; a
/// known parameter may be listed only with its nominal value (the model fixes it there).
///
/// Also accepted, for convenience: a value written `{value: v}` (or `{nominal: v}`), and a
/// whole spec-like document whose `params:` mapping holds the true values (`a1: {nominal:
/// 0.376}`; its other keys are ignored), so a copy of the spec with true nominals is a truth
/// file.
///
/// # Errors
/// An [`ErrorClass::Input`] error naming the file, line and field: YAML that does not parse,
/// a document that is not a mapping, a name that is not a parameter of the spec, a value that
/// is not a finite number, a known parameter given another value.
pub fn truth_from_yaml_str(
    text: &str,
    file: Option<&str>,
    model: &dyn CalibModel,
    spec: &Spec,
) -> Result<Vec<f64>> {
    let at = |line: Option<usize>, column: Option<usize>, field: Option<String>| Location {
        file: file.map(str::to_string),
        line,
        column,
        field,
        pose: None,
    };
    let (doc, index) = parse_yaml(text).map_err(|e| match e {
        YamlError::At {
            pos: (line, column),
            offset,
            message,
        } => Error::input(
            at(Some(line), Some(column), None),
            format!("the truth file is not valid YAML (character {offset}): {message}"),
        ),
        YamlError::Duplicates(repeats) => Error::from_diagnostics(
            ErrorClass::Input,
            repeats
                .into_iter()
                .map(|(path, (line, column))| Diagnostic {
                    location: at(Some(line), Some(column), Some(path)),
                    message: "this parameter is given twice".into(),
                })
                .collect(),
        ),
    })?;
    let mut p: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    let (map, prefix) = match doc {
        Value::Mapping(m) => match m.get("params") {
            Some(Value::Mapping(params)) => (params.clone(), "params."),
            _ => (m, ""),
        },
        Value::Null => return Ok(p),
        _ => {
            return Err(Error::input(
                at(Some(1), None, None),
                "the truth file must be a mapping `parameter: value`",
            ))
        }
    };
    let mut problems = Vec::new();
    for (k, v) in &map {
        let Some(name) = k.as_str() else {
            problems.push(Diagnostic {
                location: at(None, None, None),
                message: format!("key {k:?} is not a parameter name"),
            });
            continue;
        };
        let field = format!("{prefix}{name}");
        let (line, column) = index.key(&field).unzip();
        let place = || at(line, column, Some(field.clone()));
        let scalar = |v: &Value| match v {
            Value::Number(n) => n.as_f64(),
            Value::String(s) => Exact::parse(s).ok().map(|e| e.to_f64()),
            _ => None,
        };
        let value = match v {
            Value::Mapping(m) => m.get("value").or_else(|| m.get("nominal")).and_then(scalar),
            other => scalar(other),
        };
        let Some(value) = value.filter(|x| x.is_finite()) else {
            problems.push(Diagnostic {
                location: place(),
                message: format!(
                    "the true value of `{name}` must be a finite number or an exact expression such as pi/2"
                ),
            });
            continue;
        };
        if let Some(j) = (0..model.param_count()).find(|&j| model.param_name(j) == name) {
            p[j] = value;
        } else if let Some(param) = spec.param(name) {
            let nominal = param.nominal.to_f64();
            if (value - nominal).abs() > 1e-12 * nominal.abs().max(1.0) {
                problems.push(Diagnostic {
                    location: place(),
                    message: format!(
                        "`{name}` is known (fixed at its nominal {nominal}); its true value cannot differ"
                    ),
                });
            }
        } else {
            let names: Vec<&str> = spec.params.iter().map(|p| p.name.as_str()).collect();
            problems.push(Diagnostic {
                location: place(),
                message: format!(
                    "unknown parameter `{name}`: the spec's parameters are {}",
                    names.join(", ")
                ),
            });
        }
    }
    if problems.is_empty() {
        Ok(p)
    } else {
        Err(Error::from_diagnostics(ErrorClass::Input, problems))
    }
}

/// The estimated parameters as a truth file (`name: value`, full precision), readable by
/// [`truth_from_yaml_str`].
#[must_use]
pub fn truth_to_yaml(model: &dyn CalibModel, p: &[f64]) -> String {
    let mut s = String::new();
    for (j, v) in p.iter().enumerate() {
        s.push_str(&format!("{}: {v:?}\n", model.param_name(j)));
    }
    s
}

/// Newton projection of one pose; see the module docs.
struct Projector<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    dim: usize,
    values: Vec<Vec<f64>>,
    ranges: Vec<[f64; 2]>,
    limited: Vec<bool>,
}

impl<'a> Projector<'a> {
    fn new(model: &'a dyn CalibModel, p: &'a [f64]) -> Self {
        let dim = model.dim();
        let nj = model.joint_count();
        let values = (0..model.constraint_count())
            .map(|j| {
                let mut v = vec![0.0; model.constraint_kind(j).value_count(dim)];
                model.constraint_values(j, p, &mut v);
                v
            })
            .collect();
        let limits: Vec<Option<[f64; 2]>> = (0..nj).map(|i| model.joint_limits(i)).collect();
        Projector {
            model,
            p,
            dim,
            values,
            ranges: (0..nj)
                .map(|i| {
                    limits[i].unwrap_or_else(|| default_joint_range(model.joint_is_prismatic(i)))
                })
                .collect(),
            limited: limits.iter().map(Option::is_some).collect(),
        }
    }

    /// A uniform draw of the joint readings inside the ranges.
    fn draw(&self, rng: &mut ChaCha8Rng) -> Vec<f64> {
        self.ranges
            .iter()
            .map(|&[lo, hi]| lo + (hi - lo) * rng.gen::<f64>())
            .collect()
    }

    /// Whether every constraint can be reached: at least 3 of 100 trial projections land.
    fn crosses_workspace(&self, seed: u64) -> bool {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(3);
        (0..self.model.constraint_count()).all(|j| {
            let kind = self.model.constraint_kind(j);
            if kind == ConstraintKind::Measured {
                return true;
            }
            let zero = vec![0.0; kind.residual_count(self.dim)];
            let mut hits = 0;
            for _ in 0..100 {
                let q0 = self.draw(&mut rng);
                if self.project(j, q0, &zero).is_some() {
                    hits += 1;
                    if hits >= 3 {
                        return true;
                    }
                }
            }
            false
        })
    }

    fn residual(&self, kind: ConstraintKind, j: usize, q: &[f64], target: &[f64], out: &mut [f64]) {
        let mut tip = [0.0; 3];
        self.model.tip(q, self.p, &mut tip[..self.dim]);
        geometry::geometric_residual(kind, self.dim, &self.values[j], &tip[..self.dim], &[], out);
        for (o, t) in out.iter_mut().zip(target) {
            *o -= t;
        }
    }

    /// Projects `q` onto constraint `j` at offset `target`; `None` when it fails.
    fn project(&self, j: usize, mut q: Vec<f64>, target: &[f64]) -> Option<Vec<f64>> {
        let kind = self.model.constraint_kind(j);
        let m = kind.residual_count(self.dim);
        let n = q.len();
        let mut r = vec![0.0; m];
        let mut rp = vec![0.0; m];
        let mut rm = vec![0.0; m];
        let mut converged = false;
        let mut extra = 0;
        for _ in 0..80 {
            self.residual(kind, j, &q, target, &mut r);
            let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return None;
            }
            if norm <= 1e-12 {
                converged = true;
                // One or two more steps polish the pose to rounding level.
                extra += 1;
                if norm <= 1e-15 || extra > 2 {
                    break;
                }
            }
            let mut jac = DMatrix::<f64>::zeros(m, n);
            for i in 0..n {
                let h = 1e-6 * q[i].abs().max(1.0);
                let keep = q[i];
                q[i] = keep + h;
                self.residual(kind, j, &q, target, &mut rp);
                q[i] = keep - h;
                self.residual(kind, j, &q, target, &mut rm);
                q[i] = keep;
                for e in 0..m {
                    jac[(e, i)] = (rp[e] - rm[e]) / (2.0 * h);
                }
            }
            let Ok(svd) = crate::numeric::linalg::checked_svd(jac.clone(), true, true) else {
                return None; // not finite: no step from here
            };
            let smax = svd.singular_values.max();
            if smax.is_nan()
                || smax <= 0.0
                || svd.singular_values.min() < 1e-8 * smax
                || svd.rank(1e-8 * smax) < m
            {
                // Singular configuration: the constraint cannot be followed from here.
                return None;
            }
            let rv = nalgebra::DVector::from_column_slice(&r);
            let step = svd.solve(&rv, 1e-8 * smax).ok()?;
            let len = step.norm();
            let scale = if len > 0.5 { 0.5 / len } else { 1.0 };
            for i in 0..n {
                q[i] -= scale * step[i];
            }
        }
        if !converged {
            return None;
        }
        for (i, qi) in q.iter_mut().enumerate() {
            if self.limited[i] {
                let [lo, hi] = self.ranges[i];
                if *qi < lo || *qi > hi {
                    return None;
                }
            } else if !self.model.joint_is_prismatic(i) {
                *qi = crate::numeric::wrap_angle(*qi);
            }
        }
        Some(q)
    }
}

/// One simulated pose, as [`simulate_each`] hands it over.
#[derive(Clone, Copy, Debug)]
pub struct SimPose<'a> {
    /// Pose index (0-based).
    pub index: usize,
    /// The recorded joint readings (encoder noise included).
    pub q: &'a [f64],
    /// The true joint readings.
    pub true_q: &'a [f64],
    /// The measured tip (measurement noise included), on a `measured` constraint.
    pub measured: Option<&'a [f64]>,
    /// The constraint the pose lies on.
    pub constraint: usize,
}

/// The largest `--noise-track` / `--noise-measure`, metres: beyond it nothing of the arm is
/// left in the data.
pub const MAX_NOISE_LENGTH: f64 = 1.0;
/// The largest `--noise-encoder`, radians (or metres on a prismatic joint).
pub const MAX_NOISE_ENCODER: f64 = 1.0;
/// Attempts on one constraint that may all fail before the simulation gives up on it.
pub const FAIL_FAST: usize = 500;
/// Longest stretch without a placed pose before the simulation gives up.
pub const STALL: std::time::Duration = std::time::Duration::from_secs(20);

/// Simulates `n` poses of `model` with true parameters `truth` (or the nominals perturbed
/// with `seed` when `None`), collected in memory; see [`simulate_each`].
///
/// # Errors
/// As [`simulate_each`].
pub fn simulate(
    model: &dyn CalibModel,
    spec: &Spec,
    n: usize,
    seed: u64,
    truth: Option<&[f64]>,
    noise: Noise,
) -> Result<Simulation> {
    let any_measured =
        (0..model.constraint_count()).any(|j| model.constraint_kind(j) == ConstraintKind::Measured);
    let mut poses = Poses {
        q: crate::data::Rows::new(model.joint_count()),
        measured: any_measured.then(|| crate::data::Rows::new(model.dim())),
        ..Poses::default()
    };
    let mut true_q = Vec::with_capacity(n.min(1 << 16));
    let truth = simulate_each(model, spec, n, seed, truth, noise, |pose| {
        if let Some(m) = &mut poses.measured {
            m.push(pose.measured.unwrap_or(&[]));
        }
        poses.q.push(pose.q);
        poses.constraint.push(pose.constraint);
        poses.line.push(pose.index + 2);
        true_q.push(pose.true_q.to_vec());
        Ok(())
    })?;
    Ok(Simulation {
        truth,
        poses,
        true_q,
    })
}

/// The true parameters a simulation uses: `truth`, checked, or the seeded perturbation of
/// the nominals.
///
/// # Errors
/// A truth of the wrong length or with non-finite values.
pub fn resolve_truth(
    model: &dyn CalibModel,
    spec: &Spec,
    seed: u64,
    truth: Option<&[f64]>,
) -> Result<Vec<f64>> {
    let given = truth.is_some();
    let mut p: Vec<f64> = match truth {
        Some(t) => t.to_vec(),
        None => seeded_truth(model, spec, seed),
    };
    if p.len() != model.param_count() || p.iter().any(|v| !v.is_finite()) {
        return Err(Error::input(
            Location::default(),
            format!(
                "the true parameters must be {} finite numbers ({})",
                model.param_count(),
                (0..model.param_count())
                    .map(|j| model.param_name(j))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    if !model.relations().is_empty() {
        p = relation_truth(model, p, given)?;
    }
    Ok(p)
}

/// A truth that satisfies the spec's relations: a given one is checked (to 10⁻⁹ m), a drawn
/// one is moved onto them (the least change of the parameters they involve).
fn relation_truth(model: &dyn CalibModel, p: Vec<f64>, given: bool) -> Result<Vec<f64>> {
    let worst = crate::fit::relation::residuals(model, &p)
        .iter()
        .fold(0.0f64, |a, r| a.max(r.abs()));
    if given {
        if worst > 1e-9 {
            return Err(Error::input(
                Location::default(),
                format!(
                    "the true parameters do not satisfy the spec's relations (off by {worst:.3e} \
                     m): give values that do"
                ),
            ));
        }
        return Ok(p);
    }
    crate::fit::relation::project(model, &p).ok_or_else(|| {
        Error::degenerate(
            "the drawn true parameters cannot be moved onto the spec's relations (are the \
             related constraints' values all fixed?)",
        )
    })
}

/// Checks the noise levels: finite, not negative, within [`MAX_NOISE_LENGTH`] and
/// [`MAX_NOISE_ENCODER`].
///
/// # Errors
/// [`ErrorClass::Input`] naming the option.
pub fn check_noise(noise: Noise) -> Result<()> {
    for (what, v, max) in [
        ("--noise-track", noise.track, MAX_NOISE_LENGTH),
        ("--noise-encoder", noise.encoder, MAX_NOISE_ENCODER),
        ("--noise-measure", noise.measure, MAX_NOISE_LENGTH),
    ] {
        let place = Location {
            field: Some(what.to_string()),
            ..Location::default()
        };
        if v.is_finite() && v < 0.0 {
            return Err(Error::input(
                place,
                format!("the noise level is negative ({v}): it is a standard deviation, >= 0"),
            ));
        }
        if !(v.is_finite() && v <= max) {
            return Err(Error::input(
                place,
                format!("the noise level must be a finite number from 0 to {max}, not {v}"),
            ));
        }
    }
    Ok(())
}

/// Simulates `n` poses and hands each to `emit` as soon as it is made (so memory does not
/// grow with `n`: the CLI writes rows as they come). Returns the true parameters.
///
/// Work is bounded: at most `200·n + 1000` attempts in all, a constraint none of whose first
/// [`FAIL_FAST`] attempts lands is given up at once, and so is a run that places nothing for
/// [`STALL`].
///
/// # Errors
/// [`ErrorClass::Input`] for a truth of the wrong length or non-finite values, or bad noise
/// ([`check_noise`]); [`ErrorClass::Degenerate`] when poses cannot be placed on the true
/// constraint (it does not cross the workspace inside the joint limits); any error of `emit`.
pub fn simulate_each(
    model: &dyn CalibModel,
    spec: &Spec,
    n: usize,
    seed: u64,
    truth: Option<&[f64]>,
    noise: Noise,
    mut emit: impl FnMut(&SimPose<'_>) -> Result<()>,
) -> Result<Vec<f64>> {
    let p = resolve_truth(model, spec, seed, truth)?;
    check_noise(noise)?;
    let dim = model.dim();
    let count = model.constraint_count();
    let proj = Projector::new(model, &p);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(2);
    let max_attempts = n.max(1).saturating_mul(200).saturating_add(1000);
    let mut attempts = 0usize;
    let mut failed = vec![0usize; count];
    let mut placed = vec![0usize; count];
    let mut last_placed = std::time::Instant::now();
    let mut recorded = vec![0.0; model.joint_count()];
    let mut tip = vec![0.0; dim];
    for l in 0..n {
        let j = l % count.max(1);
        let kind = model.constraint_kind(j);
        let q = loop {
            attempts += 1;
            let hopeless = placed[j] == 0 && failed[j] >= FAIL_FAST;
            let stalled = attempts.is_multiple_of(64) && last_placed.elapsed() > STALL;
            if attempts > max_attempts || hopeless || stalled {
                let fails: Vec<String> = failed
                    .iter()
                    .enumerate()
                    .filter(|(_, &f)| f > 0)
                    .map(|(j, f)| {
                        format!(
                            "constraint {j} ({}): {f} failed",
                            model.constraint_kind(j).name()
                        )
                    })
                    .collect();
                let why = if hopeless {
                    format!("the first {FAIL_FAST} attempts on constraint {j} all failed")
                } else if stalled {
                    format!("no pose was placed for {} s", STALL.as_secs())
                } else {
                    format!("after {max_attempts} attempts")
                };
                return Err(Error::degenerate(format!(
                    "could place only {l} of {n} poses on the true constraint: {why} ({}): does the constraint cross the workspace inside the joint limits?",
                    fails.join(", ")
                )));
            }
            let q0 = proj.draw(&mut rng);
            if kind == ConstraintKind::Measured {
                break q0;
            }
            let m = kind.residual_count(dim);
            let target: Vec<f64> = (0..m).map(|_| noise.track * normal(&mut rng)).collect();
            match proj.project(j, q0, &target) {
                Some(q) => break q,
                None => failed[j] += 1,
            }
        };
        placed[j] += 1;
        for (r, v) in recorded.iter_mut().zip(&q) {
            *r = if noise.encoder > 0.0 {
                v + noise.encoder * normal(&mut rng)
            } else {
                *v
            };
        }
        let measured = if kind == ConstraintKind::Measured {
            model.tip(&q, &p, &mut tip);
            for t in &mut tip {
                if noise.measure > 0.0 {
                    *t += noise.measure * normal(&mut rng);
                }
            }
            Some(&tip[..])
        } else {
            None
        };
        emit(&SimPose {
            index: l,
            q: &recorded,
            true_q: &q,
            measured,
            constraint: j,
        })?;
        // Time the consumer spent (a slow pipe) is not time spent failing to place poses.
        last_placed = std::time::Instant::now();
    }
    Ok(p)
}

/// Writes the data CSV header (see [`write_csv`]); `measured`: with `x, y(, z)` columns.
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv_header<W: Write>(
    w: &mut W,
    model: &dyn CalibModel,
    measured: bool,
    constraint_list: bool,
) -> std::io::Result<()> {
    let dim = model.dim();
    let mut header: Vec<String> = (1..=model.joint_count()).map(|i| format!("q{i}")).collect();
    if measured {
        header.extend(["x", "y", "z"][..dim].iter().map(|s| (*s).to_string()));
    }
    if constraint_list {
        header.push("constraint".to_string());
    }
    writeln!(w, "{}", header.join(","))
}

/// Writes one data row (see [`write_csv`]): `measured` is `Some` (possibly empty) exactly
/// when the file has `x, y(, z)` columns.
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv_row<W: Write>(
    w: &mut W,
    dim: usize,
    q: &[f64],
    measured: Option<&[f64]>,
    constraint: Option<usize>,
) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let mut line = String::new();
    for (i, v) in q.iter().enumerate() {
        if i > 0 {
            line.push(',');
        }
        let _ = write!(line, "{v:?}");
    }
    if let Some(tip) = measured {
        for i in 0..dim {
            line.push(',');
            if let Some(v) = tip.get(i) {
                let _ = write!(line, "{v:?}");
            }
        }
    }
    if let Some(c) = constraint {
        let _ = write!(line, ",{c}");
    }
    writeln!(w, "{line}")
}

/// Writes poses as the data CSV of `shared/interface.md`: header `q1..qn`, then `x, y(, z)`
/// when any constraint is measured (blank on poses of other constraints), then `constraint`
/// when `constraint_list`; every value at full precision (shortest round-trip form).
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv<W: Write>(
    mut w: W,
    model: &dyn CalibModel,
    constraint_list: bool,
    poses: &Poses,
) -> std::io::Result<()> {
    write_csv_header(&mut w, model, poses.measured.is_some(), constraint_list)?;
    for l in 0..poses.len() {
        let measured = poses.measured.as_ref().map(|m| m.get(l).unwrap_or(&[]));
        let constraint = constraint_list.then(|| poses.constraint.at(l));
        write_csv_row(&mut w, model.dim(), &poses.q[l], measured, constraint)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::SymbolicModel;

    const TWO_LINK: &str = "
name: two_link
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.6, 2.6]}
  - {type: revolute, a: a2, home: th2, limits: [-2.5, 2.5]}
params:
  a1: {nominal: 0.375}
  a2: {nominal: 0.425}
  th1: {nominal: 0}
  th2: {nominal: 0}
  b1: {nominal: -1.79}
  b2: {nominal: -0.56}
constraint:
  line: {b: [b1, b2]}
";

    fn model() -> (Spec, SymbolicModel) {
        let spec = crate::spec::from_yaml_str(TWO_LINK, None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        (spec, m)
    }

    #[test]
    fn poses_lie_on_the_true_line_inside_limits() {
        let (spec, m) = model();
        let sim = simulate(&m, &spec, 50, 7, None, Noise::default()).unwrap();
        assert_eq!(sim.poses.len(), 50);
        let p = &sim.truth;
        let mut tip = [0.0; 2];
        for q in &sim.poses.q {
            assert!(q[0].abs() <= 2.6 && q[1].abs() <= 2.5);
            m.tip(q, p, &mut tip);
            let h = p[4] * tip[0] + p[5] * tip[1] + 1.0;
            assert!(h.abs() < 1e-11, "h = {h}");
        }
    }

    #[test]
    fn deterministic_and_truth_independent_of_poses() {
        let (spec, m) = model();
        let a = simulate(
            &m,
            &spec,
            10,
            3,
            None,
            Noise {
                track: 1e-5,
                ..Noise::default()
            },
        )
        .unwrap();
        let b = simulate(
            &m,
            &spec,
            10,
            3,
            None,
            Noise {
                track: 1e-5,
                ..Noise::default()
            },
        )
        .unwrap();
        assert_eq!(a, b);
        let c = simulate(&m, &spec, 10, 4, None, Noise::default()).unwrap();
        assert_ne!(a.truth, c.truth);
    }

    #[test]
    fn tracking_noise_moves_tips_off_the_line() {
        let (spec, m) = model();
        let sim = simulate(
            &m,
            &spec,
            400,
            1,
            None,
            Noise {
                track: 1e-4,
                ..Noise::default()
            },
        )
        .unwrap();
        let p = &sim.truth;
        let nb = p[4].hypot(p[5]);
        let mut tip = [0.0; 2];
        let mut s2 = 0.0;
        for q in &sim.poses.q {
            m.tip(q, p, &mut tip);
            let d = (p[4] * tip[0] + p[5] * tip[1] + 1.0) / nb;
            s2 += d * d;
        }
        let rms = (s2 / 400.0).sqrt();
        assert!((rms - 1e-4).abs() < 2e-5, "rms {rms}");
    }

    #[test]
    fn truth_file_errors_are_located() {
        let (spec, m) = model();
        let e = truth_from_yaml_str("a1: 0.4\nzz: 1\n", Some("t.yaml"), &m, &spec).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("t.yaml:2") && s.contains("zz"), "{s}");
        let e = truth_from_yaml_str("a1: [1\n", Some("t.yaml"), &m, &spec).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Input);
        let p = truth_from_yaml_str("th2: pi/180\n", None, &m, &spec).unwrap();
        assert!((p[3] - std::f64::consts::PI / 180.0).abs() < 1e-15);
        // A spec-like document: its params' nominals are the truth.
        let text = TWO_LINK.replace("a2: {nominal: 0.425}", "a2: {nominal: 0.43}");
        let p = truth_from_yaml_str(&text, None, &m, &spec).unwrap();
        assert_eq!(p[1], 0.43);
        let p = truth_from_yaml_str("a2: {value: 0.44}\n", None, &m, &spec).unwrap();
        assert_eq!(p[1], 0.44);
        let e = truth_from_yaml_str("params:\n  a9: {nominal: 1}\n", Some("t.yaml"), &m, &spec)
            .unwrap_err();
        assert!(
            e.to_string().contains("t.yaml:2:3: field `params.a9`"),
            "{e}"
        );
    }

    #[test]
    fn unreachable_line_is_degenerate() {
        let (spec, m) = model();
        let truth = [0.375, 0.425, 0.0, 0.0, -0.1, -0.1];
        let e = simulate(&m, &spec, 5, 1, Some(&truth), Noise::default()).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Degenerate);
    }
}
