//! The result files `predict`, `evaluate` and `compensate` take (`calibrate --format json`),
//! read with the spec's own rules: each parameter once, known ones unchanged, every value
//! within the loader's bound.

use std::path::{Path, PathBuf};

use lincal::error::{Error, Location, Result};
use lincal::spec::{self, Spec};

/// Where a command's parameter values come from: a calibration result (`--params`) or the
/// spec's nominals (`--nominal`), one of the two (`predict`, `evaluate`, `compensate`).
#[derive(clap::Args, Debug)]
pub struct ParamsArgs {
    /// The calibrated parameters: the JSON of `lincal calibrate --format json`.
    #[arg(long, required_unless_present = "nominal", conflicts_with = "nominal")]
    pub params: Option<PathBuf>,
    /// Use the spec's nominal values.
    #[arg(long)]
    pub nominal: bool,
}

impl ParamsArgs {
    /// The values of the spec's estimated parameters `est` (in order): the result file's
    /// ([`result_values`]), or the nominals.
    ///
    /// # Errors
    /// As [`result_values`].
    pub fn values(&self, spec: &Spec, est: &[&spec::Param]) -> Result<Vec<f64>> {
        match self.params.as_deref() {
            None => Ok(est.iter().map(|p| p.nominal.to_f64()).collect()),
            Some(path) => result_values(path, spec, est),
        }
    }

    /// The orientation weight (metres per radian) the result's fit weighed measured poses
    /// by (`pose_noise.weight`), when the result file has one: a held-out pose RMS is then
    /// the fit's own measure. `None` with `--nominal`, or a result without it (read after
    /// [`Self::values`] checked the file).
    pub fn orientation_weight(&self) -> Option<f64> {
        #[derive(serde::Deserialize)]
        struct Noise {
            weight: f64,
        }
        #[derive(serde::Deserialize)]
        struct WithNoise {
            pose_noise: Option<Noise>,
        }
        let text = read_result_text(self.params.as_deref()?).ok()?;
        let v: WithNoise = serde_json::from_str(&text).ok()?;
        v.pose_noise
            .map(|n| n.weight)
            .filter(|w| w.is_finite() && *w > 0.0)
    }
}

impl ParamsArgs {
    /// The poses of `poses` beyond the joint ranges the result's calibration saw (JSON
    /// `joint_ranges`), when the result file has them and they match the spec's joints:
    /// `None` with `--nominal` or an older result (read after [`Self::values`] checked the
    /// file).
    pub fn beyond_ranges(
        &self,
        spec: &Spec,
        poses: &lincal::data::Poses,
    ) -> Option<lincal::lincal_core::calibrate::joint_ranges::BeyondRanges> {
        use lincal::lincal_core::calibrate::joint_ranges::{beyond_ranges, JointRange};
        #[derive(serde::Deserialize)]
        struct WithRanges {
            joint_ranges: Option<Vec<JointRange>>,
        }
        let text = read_result_text(self.params.as_deref()?).ok()?;
        let ranges = serde_json::from_str::<WithRanges>(&text)
            .ok()?
            .joint_ranges?;
        beyond_ranges(&ranges, &spec.prismatic_joints(), poses)
    }

    /// [`Self::beyond_ranges`], said on stderr as a warning when any pose is beyond them.
    pub fn warn_beyond_ranges(
        &self,
        spec: &Spec,
        poses: &lincal::data::Poses,
    ) -> Option<lincal::lincal_core::calibrate::joint_ranges::BeyondRanges> {
        let beyond = self.beyond_ranges(spec, poses)?;
        if let Some(w) = lincal::lincal_core::calibrate::joint_ranges::beyond_warning(&beyond) {
            eprintln!("lincal: warning: {w}");
        }
        Some(beyond)
    }
}

/// The text of the result file at `path` (at most [`MAX_RESULT_BYTES`]), a leading
/// byte-order mark (an editor's, not JSON) left out: every reader of a result file reads it
/// here.
pub fn read_result_text(path: &Path) -> Result<String> {
    let text = lincal::error::read_input_file(path, "result file", MAX_RESULT_BYTES)?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// Largest result file `predict --params` reads (a `calibrate --format json` output is a few
/// kilobytes per parameter; 16 MiB is far beyond any real one).
pub const MAX_RESULT_BYTES: usize = 16 << 20;

/// What `predict` reads of a result file: each parameter's `value`; every other field is
/// skipped while parsing, so memory is the parameters', not a tree of the file.
#[derive(serde::Deserialize)]
struct ResultFile {
    /// The name of the spec the result was made from (`calibrate`'s `name`).
    name: Option<String>,
    /// The fingerprint of that spec's structure (`calibrate`'s `structure`).
    structure: Option<String>,
    params: Option<UniqueParams>,
}

/// The `params` object of a result file, each name once: a name given twice is an error at
/// its place (a JSON object's later duplicate would otherwise silently win).
struct UniqueParams(std::collections::BTreeMap<String, ResultParam>);

impl<'de> serde::Deserialize<'de> for UniqueParams {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = UniqueParams;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("an object of parameters")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> std::result::Result<UniqueParams, A::Error> {
                let mut out = std::collections::BTreeMap::new();
                while let Some((k, v)) = map.next_entry::<String, ResultParam>()? {
                    if out.contains_key(&k) {
                        return Err(serde::de::Error::custom(format!(
                            "parameter `{}` is given twice",
                            lincal::error::excerpt(&k)
                        )));
                    }
                    out.insert(k, v);
                }
                Ok(UniqueParams(out))
            }
        }
        d.deserialize_map(Visit)
    }
}

/// One parameter of a result file.
#[derive(serde::Deserialize)]
struct ResultParam {
    #[serde(default)]
    value: Option<f64>,
}

/// The refusal of a result whose spec had this spec's name but another structure
/// (`lincal_core::spec::structure`): another convention, slot, constraint or known value.
fn other_structure(spec: &str) -> String {
    format!(
        "the result was calibrated with a spec named `{}` of another structure (a convention, \
         a joint's slot, a constraint, a relation or a known value differs; the estimated \
         nominals may change freely): its values would be read into another model; calibrate \
         again with this spec",
        lincal::error::excerpt(spec)
    )
}

/// The refusal of a result made from the spec named `result` for the spec named `spec`: the
/// parameter names may match while the robots differ (two arms of one product line, a spec
/// edited and renamed), so the values would silently be another robot's.
fn other_spec(result: &str, spec: &str) -> String {
    let (result, spec) = (lincal::error::excerpt(result), lincal::error::excerpt(spec));
    format!(
        "the result is of spec `{result}`, not of this spec `{spec}`: its values are read only \
         with the spec they were calibrated with; run `lincal calibrate` with this spec (`--format \
         json`) for its own result, or, if `{spec}` is the same robot's spec renamed, set the \
         result's `name` to `{spec}`"
    )
}

/// The values of the estimated parameters `est` (in order) from the result file at `path`
/// (the output of `calibrate --format json`): made from a spec of the same name (its `name`,
/// when it has one), every parameter it lists is the spec's, every estimated one has a
/// finite `value`.
pub fn result_values(path: &Path, spec: &Spec, est: &[&spec::Param]) -> Result<Vec<f64>> {
    let text = read_result_text(path)?;
    let bad = |f: String, m: String| {
        Error::input(
            Location {
                file: Some(path.display().to_string()),
                field: Some(f),
                ..Location::default()
            },
            m,
        )
    };
    let v: ResultFile = serde_json::from_str(&text).map_err(|e| {
        bad(
            "(json)".into(),
            format!(
                "not a calibration result (line {}, column {}): {}; expected the output of \
                 `lincal calibrate --format json`",
                e.line(),
                e.column(),
                lincal::error::excerpt(&e.to_string())
            ),
        )
    })?;
    if let Some(name) = v.name.as_deref().filter(|n| *n != spec.name) {
        return Err(bad("name".into(), other_spec(name, &spec.name)));
    }
    let here = spec::structure::fingerprint(spec);
    if v.structure.as_deref().is_some_and(|s| s != here) {
        return Err(bad("structure".into(), other_structure(&spec.name)));
    }
    let Some(UniqueParams(obj)) = v.params else {
        return Err(bad(
            "params".into(),
            "missing: expected the output of `lincal calibrate --format json`".into(),
        ));
    };
    if let Some(k) = obj.keys().find(|k| spec.param(k).is_none()) {
        return Err(bad(
            format!("params.{}", lincal::error::excerpt(k)),
            "the spec has no such parameter: is this the result of another spec?".into(),
        ));
    }
    // The spec's own rules: a known parameter keeps the spec's value (a result cannot move
    // it), every value within the loader's bound.
    let bound = lincal::lincal_core::spec::load::MAX_MAGNITUDE;
    for (k, x) in &obj {
        let Some(param) = spec.param(k) else { continue };
        let f = format!("params.{}.value", lincal::error::excerpt(k));
        if let Some(v) = x.value {
            if v.is_finite() && v.abs() > bound {
                return Err(bad(
                    f,
                    format!("{v:e} is beyond {bound:e} in magnitude, the spec's own bound"),
                ));
            }
            let nominal = param.nominal.to_f64();
            if param.known && (v - nominal).abs() > 1e-12 * nominal.abs().max(1.0) {
                return Err(bad(
                    f,
                    format!(
                        "`{}` is known in the spec ({nominal}); the result file gives {v}: a \
                         result cannot change a known parameter, edit the spec instead",
                        lincal::error::excerpt(k)
                    ),
                ));
            }
        }
    }
    let mut p = Vec::with_capacity(est.len());
    for e in est {
        let f = format!("params.{}.value", e.name);
        match obj.get(&e.name).map(|x| x.value) {
            Some(Some(v)) if v.is_finite() => p.push(v),
            Some(_) => return Err(bad(f, "expected a finite number".into())),
            None => {
                return Err(bad(
                    f,
                    "missing: every estimated parameter needs a value".into(),
                ))
            }
        }
    }
    Ok(p)
}
