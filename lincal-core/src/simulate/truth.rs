//! The true parameters of a simulation: the seeded perturbation of the nominals, and truth
//! files (YAML `name: value`) read and written.
//!
//! Takes the model and its spec (and a seed, or a truth file's text); gives the true
//! estimated parameters in the model's order, or a located [`ErrorClass::Input`] error.

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::project::Projector;
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};
use crate::model::CalibModel;
use crate::spec::node::{parse_yaml, Mapping, Value, YamlError};
use crate::spec::{Exact, Spec};

/// Names of the parameters used in the spec's constraint slots.
fn constraint_param_names(spec: &Spec) -> Vec<String> {
    spec.constraints
        .iter()
        .flat_map(|c| c.slots())
        .filter_map(|s| s.param().map(str::to_string))
        .collect()
}

/// `1` or `−1`, even odds.
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
pub(crate) fn seeded_truth(model: &dyn CalibModel, spec: &Spec, seed: u64) -> Vec<f64> {
    for scale in [1.0, 0.5, 0.25] {
        let p = perturb(model, spec, seed, scale);
        if Projector::new(model, &p).crosses_workspace(seed) {
            return p;
        }
    }
    perturb(model, spec, seed, 0.0)
}

/// Reads a truth file (see [`truth_from_yaml_str`]) for `simulate`: its values must also
/// leave every constraint a geometric object (`b ≠ 0`, a line's planes crossing, a quadric
/// with real points), as a spec's known values must.
///
/// # Errors
/// As [`truth_from_yaml_str`], a file that cannot be read, and values that leave a constraint
/// with no point.
pub fn truth_from_yaml_file(path: &Path, model: &dyn CalibModel, spec: &Spec) -> Result<Vec<f64>> {
    let name = path.display().to_string();
    let text =
        crate::error::read_input_file(path, "truth file", crate::spec::load::MAX_SPEC_BYTES)?;
    // A byte-order mark (an editor's) is no part of the first name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let p = truth_from_yaml_str(text, Some(&name), model, spec)?;
    constraints_hold(model, spec, &p, Some(&name))?;
    Ok(p)
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
/// an empty document (`{}` is the truth at the nominals), a document that is not a
/// mapping, a name that is not a parameter of the spec, a value that
/// is not a finite number, a known parameter given another value.
pub fn truth_from_yaml_str(
    text: &str,
    file: Option<&str>,
    model: &dyn CalibModel,
    spec: &Spec,
) -> Result<Vec<f64>> {
    let reader = TruthReader { file, model, spec };
    let (doc, index) = parse_yaml(text).map_err(|e| reader.yaml_error(e))?;
    let mut p: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    let (map, prefix) = reader.truth_mapping(doc)?;
    let mut problems = Vec::new();
    for (k, v) in &map {
        let Some(name) = k.as_str() else {
            problems.push(Diagnostic {
                location: reader.at(None, None, None),
                message: format!("key {k:?} is not a parameter name"),
            });
            continue;
        };
        let field = format!("{prefix}{name}");
        let (line, column) = index.key(&field).unzip();
        let place = reader.at(line, column, Some(field));
        if let Some(problem) = reader.apply(name, v, place, &mut p) {
            problems.push(problem);
        }
    }
    if !problems.is_empty() {
        return Err(Error::from_diagnostics(ErrorClass::Input, problems));
    }
    Ok(p)
}

/// The truth's constraints are geometric objects: the check a spec's known values get
/// ([`crate::spec::validate`]: `b = 0`, two parallel planes of a line, a quadric with no real
/// point), on the truth's values. Such a truth places no pose, and `simulate` would otherwise
/// ask whether the constraint crosses the workspace.
fn constraints_hold(
    model: &dyn CalibModel,
    spec: &Spec,
    p: &[f64],
    file: Option<&str>,
) -> Result<()> {
    let mut truth = spec.clone();
    for (j, &v) in p.iter().enumerate() {
        let name = model.param_name(j);
        if let (Some(q), Some(e)) = (
            truth.params.iter_mut().find(|q| q.name == name),
            Exact::from_f64(v),
        ) {
            q.nominal = e;
            q.known = true;
        }
    }
    let bad: Vec<Diagnostic> =
        crate::spec::validate::check(&mut truth, &crate::spec::validate::FieldsOnly)
            .into_iter()
            .filter(|d| {
                d.location
                    .field
                    .as_deref()
                    .is_some_and(|f| f.starts_with("constraint"))
            })
            .map(|d| Diagnostic {
                location: Location {
                    file: file.map(str::to_string),
                    ..Location::default()
                },
                message: format!(
                    "with the truth's values, `{}`: {}",
                    d.location.field.unwrap_or_default(),
                    d.message
                ),
            })
            .collect();
    if bad.is_empty() {
        Ok(())
    } else {
        Err(Error::from_diagnostics(ErrorClass::Input, bad))
    }
}

/// What reading a truth file needs besides its text: the file's name (for locations), the
/// model whose parameters it sets, and the spec that names the known ones.
struct TruthReader<'a> {
    file: Option<&'a str>,
    model: &'a dyn CalibModel,
    spec: &'a Spec,
}

impl TruthReader<'_> {
    /// A place in the truth file.
    fn at(&self, line: Option<usize>, column: Option<usize>, field: Option<String>) -> Location {
        Location {
            file: self.file.map(str::to_string),
            line,
            column,
            field,
            pose: None,
        }
    }

    /// The error of a truth file that does not parse: invalid YAML, or repeated keys.
    fn yaml_error(&self, e: YamlError) -> Error {
        match e {
            YamlError::At {
                pos: (line, column),
                offset,
                message,
            } => Error::input(
                self.at(Some(line), Some(column), None),
                format!("the truth file is not valid YAML (character {offset}): {message}"),
            ),
            YamlError::Duplicates(repeats) => Error::from_diagnostics(
                ErrorClass::Input,
                repeats
                    .into_iter()
                    .map(|(path, (line, column))| Diagnostic {
                        location: self.at(Some(line), Some(column), Some(path)),
                        message: "this parameter is given twice".into(),
                    })
                    .collect(),
            ),
        }
    }

    /// The mapping that holds the true values and the field prefix of its keys: the
    /// document's `params:` when it has one (a spec-like document), else the document; an
    /// error for an empty document or one that is not a mapping.
    fn truth_mapping(&self, doc: Value) -> Result<(Mapping, &'static str)> {
        match doc {
            Value::Mapping(m) => Ok(match m.get("params") {
                Some(Value::Mapping(params)) => (params.clone(), "params."),
                _ => (m, ""),
            }),
            // An empty file (or `null`, or comments only) is more likely a truth that was never
            // written than a choice of the nominals, which `{}` states.
            Value::Null => Err(Error::input(
                self.at(Some(1), None, None),
                "the truth file holds no values (empty, `null` or comments only); write `{}` \
                 for a truth at the nominals",
            )),
            _ => Err(Error::input(
                self.at(Some(1), None, None),
                "the truth file must be a mapping `parameter: value`",
            )),
        }
    }

    /// Sets the true value of parameter `name` (at `place` in the file) from `v`; the
    /// problem, if any: not a finite number, a known parameter given another value than its
    /// nominal, a name that is not a parameter.
    fn apply(&self, name: &str, v: &Value, place: Location, p: &mut [f64]) -> Option<Diagnostic> {
        let max = crate::spec::load::MAX_MAGNITUDE;
        let Some(value) = truth_value(v).filter(|x| x.is_finite() && x.abs() <= max) else {
            return Some(Diagnostic {
                location: place,
                message: format!(
                    "the value of `{name}` must be a finite number of magnitude at most \
                     {max:e} (as a spec's), or an exact expression such as pi/2"
                ),
            });
        };
        let model = self.model;
        if let Some(j) = (0..model.param_count()).find(|&j| model.param_name(j) == name) {
            p[j] = value;
            None
        } else if let Some(param) = self.spec.param(name) {
            let nominal = param.nominal.to_f64();
            ((value - nominal).abs() > 1e-12 * nominal.abs().max(1.0)).then(|| Diagnostic {
                location: place,
                message: format!(
                    "`{name}` is known (fixed at its nominal {nominal}); its true value cannot differ"
                ),
            })
        } else {
            let names: Vec<&str> = self.spec.params.iter().map(|p| p.name.as_str()).collect();
            Some(Diagnostic {
                location: place,
                message: format!(
                    "unknown parameter `{name}`: the spec's parameters are {}",
                    names.join(", ")
                ),
            })
        }
    }
}

/// A true value as written: a number, an exact expression, or either under `value:` (or
/// `nominal:`) in a mapping; `None` for anything else.
fn truth_value(v: &Value) -> Option<f64> {
    let scalar = |v: &Value| match v {
        Value::Number(n) => n.as_f64(),
        Value::String(s) => Exact::parse(s).ok().map(|e| e.to_f64()),
        _ => None,
    };
    match v {
        Value::Mapping(m) => m.get("value").or_else(|| m.get("nominal")).and_then(scalar),
        other => scalar(other),
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
