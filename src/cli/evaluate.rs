//! `lincal evaluate` and the held-out options of `calibrate` (`--validate`, `--folds`): data
//! read exactly as `calibrate` reads it, judged with [`lincal::calibrate::validation`].

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::calibrate::estimate::Estimate;
use lincal::calibrate::joint_ranges::{self, BeyondRanges};
use lincal::calibrate::validation::{self, Evaluation};
use lincal::calibrate::CalibrateOptions;
use lincal::data::{DataLayout, Poses};
use lincal::error::{Error, Location, Result};
use lincal::report;
use lincal::spec::Spec;
use lincal::symbolic::SymbolicModel;

use super::common::{data_layout, load_for_fitting, write_json, write_text, DataArgs, Format};
use super::result_file::ParamsArgs;

/// The arguments of `evaluate`.
#[derive(clap::Args, Debug)]
pub struct EvaluateArgs {
    /// The spec (YAML).
    spec: PathBuf,
    #[command(flatten)]
    source: ParamsArgs,
    /// The held-out poses, laid out as `calibrate`'s data (one file per constraint of a
    /// list, in order).
    #[arg(required = true, num_args = 1..)]
    data: Vec<PathBuf>,
    #[command(flatten)]
    data_args: DataArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
}

/// The poses of one placement: `files` (one per constraint of a list, or one file with a
/// `constraint` column) read as `calibrate` reads its data.
pub fn read_placement(
    model: &SymbolicModel,
    spec: &Spec,
    spec_text: &crate::inputs::SpecText,
    data_args: &DataArgs,
    files: &[PathBuf],
) -> Result<Poses> {
    let layout = data_layout(
        DataLayout::of_model(model, spec.constraint_list),
        data_args,
        spec_text,
    )?;
    let paths: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    Poses::from_csv_paths(&paths, &layout)
}

/// `--validate A.csv,B.csv` (repeatable): each occurrence one placement, its files split at
/// commas; an empty name is refused (exit 2, naming `--validate`).
pub fn placements(args: &[String]) -> Result<Vec<Vec<PathBuf>>> {
    args.iter()
        .map(|a| {
            let files: Vec<PathBuf> = a.split(',').map(|f| PathBuf::from(f.trim())).collect();
            if files.iter().any(|f| f.as_os_str().is_empty()) {
                return Err(Error::input(
                    Location {
                        field: Some("--validate".to_string()),
                        ..Location::default()
                    },
                    format!("`{a}` has an empty file name: expected `A.csv` or `A.csv,B.csv`"),
                ));
            }
            Ok(files)
        })
        .collect()
}

fn names(files: &[PathBuf]) -> Vec<String> {
    files.iter().map(|f| f.display().to_string()).collect()
}

/// The held-out extras of `calibrate`: each placement judged with the estimate, and the
/// cross-validation with `folds`, stored in `est`.
pub fn calibrate_extras(
    model: &SymbolicModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
    placements: Vec<(Vec<PathBuf>, Poses)>,
    folds: Option<usize>,
    est: &mut Estimate,
) -> Result<()> {
    let p = est.estimated_values();
    let weight = est.pose_noise.as_ref().map(|n| n.weight);
    for (files, held) in placements {
        let mut e =
            validation::evaluate_weighted(model, &held, &p, weight).map_err(|e| {
                match files.as_slice() {
                    [one] => e.in_file(&one.display().to_string()),
                    _ => e,
                }
            })?;
        e.files = names(&files);
        // Held-out poses beyond the fit's joint ranges judge its extrapolation: say so.
        let prismatic = spec.prismatic_joints();
        if let Some(w) = joint_ranges::beyond_ranges(&est.joint_ranges, &prismatic, &held)
            .as_ref()
            .and_then(joint_ranges::beyond_warning)
        {
            est.warnings
                .push(format!("--validate {}: {w}", e.files.join(",")));
        }
        est.validation.push(e);
    }
    if let Some(k) = folds {
        // Over the poses the fit kept: a pose `--reject-outliers` left out is no more a test
        // of the calibration than it was part of it.
        let rejected: Vec<usize> = est.rejected.iter().map(|r| r.pose).collect();
        let kept: Vec<usize> = (0..poses.len()).filter(|l| !rejected.contains(l)).collect();
        let kept_poses = (kept.len() < poses.len()).then(|| poses.select(&kept));
        let poses = kept_poses.as_ref().unwrap_or(poses);
        let cv = validation::cross_validate(model, spec, poses, opts, k, est.residual_rms)?;
        est.warnings.extend(cv.warnings.iter().cloned());
        est.cross_validation = Some(cv);
    }
    Ok(())
}

/// `evaluate`: the given parameters (or the nominals) judged on held-out data, beside the
/// nominals, as text or JSON.
pub fn run(out: &mut dyn Write, run: &EvaluateArgs, max_terms: usize) -> Result<()> {
    let spec_text = crate::inputs::SpecText::read(&run.spec)?;
    let (spec, mut model, cache) = load_for_fitting(&spec_text, max_terms)?;
    model.release_exact_polynomials();
    cache.store(&model.facts());
    let est = spec.estimated_params();
    let p = run.source.values(&spec, &est)?;
    let poses = read_placement(&model, &spec, &spec_text, &run.data_args, &run.data)?;
    let beyond = run.source.warn_beyond_ranges(&spec, &poses);
    let weight = run.source.orientation_weight();
    let mut e = validation::evaluate_weighted(&model, &poses, &p, weight).map_err(|e| match run
        .data
        .as_slice()
    {
        [one] => e.in_file(&one.display().to_string()),
        _ => e,
    })?;
    e.files = names(&run.data);
    let source = run
        .source
        .params
        .as_deref()
        .map_or_else(|| "nominal".to_string(), |p| p.display().to_string());
    match run.format {
        Format::Json => write_json(
            out,
            &evaluation_json(&spec.name, &source, &e, beyond.as_ref()),
        ),
        Format::Text => {
            let label = if run.source.params.is_some() {
                "given"
            } else {
                "nominal"
            };
            let head = format!("{}: parameters from {source}\n", spec.name);
            write_text(out, &(head + &report::evaluation_text(&e, label)))
        }
    }
}

/// `{name, params, …the evaluation's fields, beyond_ranges}` (`beyond_ranges` only when the
/// result file recorded its joint ranges).
fn evaluation_json(
    name: &str,
    source: &str,
    e: &Evaluation,
    beyond: Option<&BeyondRanges>,
) -> serde_json::Value {
    let mut map = serde_json::Map::new();
    map.insert("name".into(), name.into());
    map.insert("params".into(), source.into());
    if let Ok(serde_json::Value::Object(fields)) = serde_json::to_value(e) {
        map.extend(fields);
    }
    if let Some(Ok(b)) = beyond.map(serde_json::to_value) {
        map.insert("beyond_ranges".into(), b);
    }
    serde_json::Value::Object(map)
}
