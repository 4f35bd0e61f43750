//! `lincal calibrate`: the fit of a spec on joint readings taken with the tip on the
//! constraint, with its outputs (the calibrated spec and URDF, the HTML report) and the
//! held-out judgements (`--validate`, `--folds`).

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::ValueEnum;
use lincal::calibrate::estimate::Estimate;
use lincal::calibrate::prior::{
    out_of_range, PriorChoice, PriorScale, PriorShape, DEFAULT_ANGLE_TOLERANCE,
    DEFAULT_LENGTH_TOLERANCE, TOLERANCE_RANGE, WEIGHT_RANGE,
};
use lincal::calibrate::{calibrate_spec_progress, CalibrateOptions, Robust, StartChoice};
use lincal::data::DataLayout;
use lincal::error::{Error, Location, Result};
use lincal::progress::Progress as _;
use lincal::report;
use lincal::spec::{self, Spec};
use lincal::urdf;

use super::common::{
    data_layout, field, load_model, write_file, write_json, write_text, DataArgs, Format,
    MAX_URDF_BYTES,
};
use super::evaluate;
use crate::{heap, html_report, inputs, outputs, progress};

/// The arguments of `calibrate`.
#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {
    /// The spec (YAML).
    spec: PathBuf,
    /// The poses (CSV: q1..qn, then x,y(,z) for measured tips, constraint for lists); with
    /// a list of constraints, several files are one per constraint, in order.
    #[arg(required = true, num_args = 1..)]
    data: Vec<PathBuf>,
    #[command(flatten)]
    data_args: DataArgs,
    /// Also write the spec with the calibrated values as nominals (known and held
    /// parameters, comments and order kept) to this path.
    #[arg(long)]
    write_spec: Option<PathBuf>,
    /// Also write the URDF the spec was imported from with the calibrated joint origins
    /// (home offsets folded in) to this path; the spec needs its `urdf:` record.
    #[arg(long)]
    write_urdf: Option<PathBuf>,
    /// Where `--write-urdf` puts the arm: `calibrated` (the spec's `base:` at its calibrated
    /// value, folded into the first joint's origin) or `urdf` (the `base:` as the URDF has
    /// it: for a `base:` that is a laser tracker's registration, the calibrated arm in the
    /// robot's own base frame). Default `calibrated`, with a warning when the `base:` moved
    /// more than 1 cm (or 0.01 rad) from its nominal.
    #[arg(long, value_enum, requires = "write_urdf")]
    urdf_base: Option<UrdfBase>,
    /// Refine the linear estimate by Levenberg-Marquardt on the geometric residual.
    #[arg(long)]
    refine: bool,
    /// Where the fit starts: `auto` takes the linear method (no initial guess) when every
    /// constraint has at least K poses and the solve is affordable, else the nominals.
    #[arg(long, value_enum, default_value_t = Start::Auto)]
    start: Start,
    /// Drop the poses beyond 5 robust standard deviations (median-based) and fit again;
    /// the dropped poses are listed (JSON `rejected`) with their CSV lines.
    #[arg(long)]
    reject_outliers: bool,
    /// Fit with a robust loss, its tuning constant reported: `huber` (c = 1.345) or
    /// `cauchy` (c = 2.385). The linear solve is iteratively reweighted on its algebraic
    /// residuals; a fit in parameter space (`--refine`, the nominal start) on the
    /// geometric ones.
    #[arg(long, value_enum)]
    robust: Option<RobustLoss>,
    #[command(flatten)]
    prior: PriorArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// Also write a self-contained HTML report (parameters, gauge, residuals before and
    /// after with plots, worst poses, identifiability, input hashes) to this path.
    #[arg(long, value_name = "OUT.html")]
    report: Option<PathBuf>,
    /// Held-out data of another placement, judged with the calibrated and the nominal
    /// parameters (unknown constraint values refitted): its files laid out like the data
    /// arguments, comma-separated (`A.csv,B.csv`); repeat for several placements.
    #[arg(long, value_name = "V.csv[,V2.csv…]", action = clap::ArgAction::Append)]
    validate: Vec<String>,
    /// k-fold cross-validation (K ≥ 2): folds by placement (constraint files), else by
    /// joint-space clusters of the poses; each fold fitted on the others with the same
    /// options and judged on its poses. The output says which grouping was used.
    #[arg(long, value_name = "K")]
    folds: Option<usize>,
}

/// `calibrate`: [`CalibrateArgs`] as a [`CalibrateRun`] (the prior's options checked).
pub fn run(out: &mut dyn Write, args: &CalibrateArgs, max_terms: usize) -> Result<()> {
    run_calibrate(
        out,
        &CalibrateRun {
            spec: &args.spec,
            data: &args.data,
            data_args: &args.data_args,
            write_spec: args.write_spec.as_deref(),
            write_urdf: args.write_urdf.as_deref(),
            urdf_base: args.urdf_base,
            report: args.report.as_deref(),
            opts: CalibrateOptions {
                prior: args.prior.choice()?,
                ..calibrate_options(args.refine, args.start, args.reject_outliers, args.robust)
            },
            format: args.format,
            validate: &args.validate,
            folds: args.folds,
        },
        max_terms,
    )
}

/// Robust loss of `calibrate --robust`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum RobustLoss {
    /// Huber: quadratic within 1.345 σ, linear beyond.
    Huber,
    /// Cauchy: gross errors weigh almost nothing.
    Cauchy,
}

/// Where `calibrate` starts its fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Start {
    /// The linear method where the data support it and it is affordable, else the nominals.
    Auto,
    /// The linear method (exit 1 when the data cannot support it).
    Linear,
    /// The nominals, with deterministic restarts.
    Nominal,
}

/// The arguments of `calibrate`, resolved.
struct CalibrateRun<'a> {
    spec: &'a Path,
    data: &'a [PathBuf],
    data_args: &'a DataArgs,
    write_spec: Option<&'a Path>,
    write_urdf: Option<&'a Path>,
    /// `None`: not given (`calibrated`, warned about when the base moved).
    urdf_base: Option<UrdfBase>,
    report: Option<&'a Path>,
    opts: CalibrateOptions,
    format: Format,
    validate: &'a [String],
    folds: Option<usize>,
}

/// The fit's options from the command line's `--refine --start --reject-outliers --robust`.
fn calibrate_options(
    refine: bool,
    start: Start,
    reject_outliers: bool,
    robust: Option<RobustLoss>,
) -> CalibrateOptions {
    let start = match start {
        Start::Auto => StartChoice::Auto,
        Start::Linear => StartChoice::Linear,
        Start::Nominal => StartChoice::Nominal,
    };
    CalibrateOptions {
        refine,
        start,
        reject_outliers,
        robust: robust.map(|r| match r {
            RobustLoss::Huber => Robust::Huber,
            RobustLoss::Cauchy => Robust::Cauchy,
        }),
        prior: PriorChoice::default(),
    }
}

/// The weak-direction prior's options of `calibrate` (and of `select`, which plans for it).
#[derive(Debug, clap::Args)]
pub(crate) struct PriorArgs {
    /// The prior around the nominals: `frames` (or `on`, the default) says each joint's
    /// mounting is off by a small rigid motion; `params` puts it on each length and angle of
    /// the arm instead; `off` leaves the arm free. It acts on every direction in proportion
    /// to what the data leave unknown there; by default its strength is chosen from the data
    /// (one tolerance, or each direction by its own evidence, whichever does best held out).
    #[arg(long, value_enum, default_value_t = PriorArg::Frames)]
    prior: PriorArg,
    /// A relative prior instead of the data's choice (MUKCa's ridge): the fit minimises
    /// `mean ‖g‖² + W·‖misplacement‖²` (metres, radians), so 1 mm or 1 mrad must buy `√W`
    /// of RMS residual; the tolerances come to `σ̂/√(N·W)`. From 1e-12 to 1e6.
    #[arg(long, value_name = "W", allow_hyphen_values = true, conflicts_with_all = ["tolerance_length", "tolerance_angle"])]
    prior_weight: Option<f64>,
    /// Fixed tolerances instead of the data's choice: one standard deviation of lengths, of
    /// each joint mounting's translation (`frames`) or of each length of the arm (`params`),
    /// metres, from 1e-9 to 1e3 (default 0.01 when only `--tolerance-angle` is given).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    tolerance_length: Option<f64>,
    /// Fixed tolerances instead of the data's choice: one standard deviation of angles, of
    /// each joint mounting's rotation (`frames`) or of each twist and home offset (`params`),
    /// radians, from 1e-9 to 1e3 (default 0.01 when only `--tolerance-length` is given).
    #[arg(long, value_name = "RAD", allow_hyphen_values = true)]
    tolerance_angle: Option<f64>,
}

impl PriorArgs {
    /// The choice, the weight or tolerances checked (finite and positive).
    pub(crate) fn choice(&self) -> Result<PriorChoice> {
        for (name, v, range) in [
            ("--prior-weight", self.prior_weight, WEIGHT_RANGE),
            ("--tolerance-length", self.tolerance_length, TOLERANCE_RANGE),
            ("--tolerance-angle", self.tolerance_angle, TOLERANCE_RANGE),
        ] {
            if let Some(why) = v.and_then(|v| out_of_range(v, range)) {
                return Err(Error::input(field(name), why));
            }
        }
        // A strength given with `--prior off` would be dropped without a word.
        let given = [
            ("--prior-weight", self.prior_weight.is_some()),
            ("--tolerance-length", self.tolerance_length.is_some()),
            ("--tolerance-angle", self.tolerance_angle.is_some()),
        ];
        if let (PriorArg::Off, Some((name, _))) = (self.prior, given.iter().find(|g| g.1)) {
            return Err(Error::input(
                field(name),
                format!("{name} sets the prior's strength, and `--prior off` leaves the prior out: give one or the other"),
            ));
        }
        let scale = if self.tolerance_length.is_some() || self.tolerance_angle.is_some() {
            PriorScale::Tolerances {
                length: self.tolerance_length.unwrap_or(DEFAULT_LENGTH_TOLERANCE),
                angle: self.tolerance_angle.unwrap_or(DEFAULT_ANGLE_TOLERANCE),
            }
        } else if let Some(w) = self.prior_weight {
            PriorScale::Weight(w)
        } else {
            PriorScale::Auto
        };
        let on = |shape| PriorChoice::On { scale, shape };
        Ok(match self.prior {
            PriorArg::Off => PriorChoice::Off,
            PriorArg::Frames => on(PriorShape::Frames),
            PriorArg::Params => on(PriorShape::Params),
        })
    }
}

/// `--prior`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum PriorArg {
    /// Hold weak directions near the nominals, each joint's mounting within the tolerances
    /// (default).
    #[value(alias = "on")]
    Frames,
    /// Hold weak directions near the nominals, each parameter within the tolerances.
    Params,
    /// Leave them free.
    Off,
}

/// `calibrate`: loads the spec and the poses, fits, writes the calibrated spec or URDF when
/// asked, then the report. A fit error on a single data file names that file.
fn run_calibrate(out: &mut dyn Write, run: &CalibrateRun<'_>, max_terms: usize) -> Result<()> {
    if let Some(path) = run.report {
        html_report::check_path(path)?;
    }
    // Before any work: what can be refused is refused now (no output may be an input or
    // another output; `--write-urdf` needs the spec's `urdf:` record), so nothing is
    // written by a run that fails.
    let spec_text = inputs::SpecText::read(run.spec)?;
    let urdf_source = match run.write_urdf {
        Some(_) => Some(urdf_record(&spec_text)?),
        None => None,
    };
    // The spec's URDF is an input even when nothing is written into it (a `--report`
    // must not replace it).
    let urdf_path = match &urdf_source {
        Some((_, path, _)) => Some(path.clone()),
        None => spec_text
            .urdf_record()
            .ok()
            .flatten()
            .map(|record| record.resolve(&spec_text.path)),
    };
    check_calibrate_outputs(run, urdf_path.as_deref())?;
    let (spec, mut model, cache) = load_model(&spec_text, max_terms, true)?;
    if let Some((record, path, text)) = &urdf_source {
        // A dry run at the nominals: a URDF that no longer matches the record (a joint
        // renamed, duplicated, emptied) is refused now, not after the fit.
        let nominal = |n: &str| spec.param(n).map(|p| p.nominal.to_f64());
        urdf::write_urdf(text, &path.display().to_string(), record, &spec, &nominal)?;
    }
    // Fitting reads c(p) compiled; the exact polynomials would only sit beside the poses.
    model.release_exact_polynomials();
    heap::release_engine_scratch();
    let layout = data_layout(
        DataLayout::of_model(&model, spec.constraint_list),
        run.data_args,
        &spec_text,
    )?;
    let bytes: u64 = run
        .data
        .iter()
        .filter_map(|p| std::fs::metadata(p).ok())
        .map(|m| m.len())
        .sum();
    let bar = progress::Bar::new(bytes >= progress::BIG_FILE);
    // With a report, what it records is the bytes read here, hashed as they are read.
    let (poses, data_files) = inputs::read_data(run.data, &layout, &bar, run.report.is_some())?;
    drop(bar);
    let mut long_folds = false;
    if let Some(k) = run.folds {
        let params = lincal::model::CalibModel::param_count(&model);
        lincal::calibrate::validation::check_folds(k, poses.len(), params)?;
        long_folds = lincal::calibrate::validation::fold_work(k, poses.len(), params)
            >= progress::LONG_FOLD_WORK;
    }
    let mut held_out = Vec::new();
    for files in evaluate::placements(run.validate)? {
        // A placement's files are `--validate`'s, not the data arguments'.
        let p = evaluate::read_placement(&model, &spec, &spec_text, run.data_args, &files)
            .map_err(|e| e.field_renamed("DATA", "--validate"))?;
        held_out.push((files, p));
    }
    let bar = progress::Bar::new(poses.len() >= progress::MANY_POSES || long_folds);
    let mut est = calibrate_spec_progress(&model, &spec, &poses, run.opts, &bar).map_err(|e| {
        match run.data {
            [one] => e.in_file(&one.display().to_string()),
            _ => e,
        }
    })?;
    est.warnings.extend(model.warnings());
    est.warnings.extend(repeated_data_files(run.data));
    cache.store(&model.facts());
    if run.folds.is_some() {
        bar.stage("cross-validation", None);
    }
    evaluate::calibrate_extras(
        &model, &spec, &poses, run.opts, held_out, run.folds, &mut est,
    )?;
    // Every output is made before the first is written.
    let new_spec = match run.write_spec {
        Some(out) => Some((out, calibrated_spec(&spec_text, &est)?)),
        None => None,
    };
    let new_urdf = match (run.write_urdf, &urdf_source) {
        (Some(out), Some((record, path, text))) => {
            if run.urdf_base.is_none() {
                est.warnings.extend(moved_base_warning(&spec, &est));
            }
            let base = run.urdf_base.unwrap_or(UrdfBase::Calibrated);
            let urdf = calibrated_urdf(record, path, text, &spec, &est, base)?;
            Some((out, urdf))
        }
        _ => None,
    };
    if let Some(path) = run.report {
        bar.stage("writing the report", None);
        let files = std::iter::once(spec_text.input_file())
            .chain(data_files)
            .collect();
        html_report::write(path, &model, &spec, &poses, &est, files, run.data)?;
    }
    if let Some((out, text)) = new_spec {
        write_file(out, &text, "spec")?;
    }
    if let Some((out, text)) = new_urdf {
        write_file(out, &text, "URDF")?;
    }
    bar.finish();
    match run.format {
        Format::Json => {
            // What the values belong to, for `predict`, `evaluate` and `compensate`.
            let mut json = report::calibrate_json(&model, &est);
            json["structure"] = lincal::spec::structure::fingerprint(&spec).into();
            write_json(out, &json)
        }
        Format::Text => write_text(out, &report::calibrate_text(&model, &est)),
    }
}

/// A warning for each data argument that repeats an earlier one: the same file (by any
/// spelling or link), or another file with the same bytes. Its poses then count twice, and
/// the standard deviations shrink by `√2` as if they were new.
fn repeated_data_files(data: &[PathBuf]) -> Vec<String> {
    let keys: Vec<_> = data.iter().map(|p| std::fs::canonicalize(p).ok()).collect();
    let size = |p: &Path| {
        std::fs::metadata(p)
            .ok()
            .filter(|m| m.is_file())
            .map(|m| m.len())
    };
    let same_bytes = |a: &Path, b: &Path| {
        matches!((size(a), size(b)), (Some(x), Some(y)) if x == y) && same_content(a, b)
    };
    let mut warnings = Vec::new();
    for (i, b) in data.iter().enumerate() {
        let earlier = (0..i)
            .position(|j| (keys[j].is_some() && keys[j] == keys[i]) || same_bytes(&data[j], b));
        if let Some(j) = earlier {
            warnings.push(format!(
                "data file {} (argument {}) repeats {} (argument {}): its poses count twice, \
                 and the standard deviations shrink as if they were new measurements; give \
                 each file once",
                b.display(),
                i + 1,
                data[j].display(),
                j + 1
            ));
        }
    }
    warnings
}

/// Whether two files hold the same bytes, read side by side in 64 KiB blocks (the poses are
/// still in memory: the files are not read whole), stopping at the first difference.
fn same_content(a: &Path, b: &Path) -> bool {
    let (Ok(mut fa), Ok(mut fb)) = (std::fs::File::open(a), std::fs::File::open(b)) else {
        return false;
    };
    let (mut ba, mut bb) = (vec![0u8; 1 << 16], vec![0u8; 1 << 16]);
    loop {
        let (Ok(na), Ok(nb)) = (read_full(&mut fa, &mut ba), read_full(&mut fb, &mut bb)) else {
            return false;
        };
        if na != nb || ba[..na] != bb[..nb] {
            return false;
        }
        if na == 0 {
            return true;
        }
    }
}

/// Fills `buf` from `r` as far as the input goes: the bytes read (fewer only at its end).
fn read_full(r: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// `calibrate`'s outputs against its inputs (spec, data, held-out data, the URDF that
/// `--write-urdf` reads) and each other ([`outputs::check_distinct`]).
fn check_calibrate_outputs(run: &CalibrateRun<'_>, urdf: Option<&Path>) -> Result<()> {
    let held_out = evaluate::placements(run.validate)?;
    let mut inputs: Vec<(&str, &Path)> = vec![("spec", run.spec)];
    inputs.extend(run.data.iter().map(|d| ("data file", d.as_path())));
    inputs.extend(
        held_out
            .iter()
            .flatten()
            .map(|d| ("--validate file", d.as_path())),
    );
    inputs.extend(urdf.map(|u| ("URDF", u)));
    let outputs: Vec<(&str, &Path)> = [
        ("--write-spec", run.write_spec),
        ("--write-urdf", run.write_urdf),
        ("--report", run.report),
    ]
    .into_iter()
    .filter_map(|(r, p)| p.map(|p| (r, p)))
    .collect();
    outputs::check_distinct(&inputs, &outputs)
}

/// `--write-spec`: the spec's text with the fitted values as nominals.
fn calibrated_spec(source: &inputs::SpecText, est: &Estimate) -> Result<String> {
    let name = source.name();
    let text = &source.text;
    let values: Vec<(String, f64)> = est
        .params
        .iter()
        .filter(|p| !p.known && !p.held)
        .map(|p| (p.name.clone(), p.value))
        .collect();
    spec::write::with_nominals(text, Some(&name), &values)
}

/// The spec's `urdf:` record, the URDF file it names and that file's text, read once (exit
/// 2 without a record or a readable file).
fn urdf_record(source: &inputs::SpecText) -> Result<(urdf::UrdfRecord, PathBuf, String)> {
    let Some(record) = source.urdf_record()?.cloned() else {
        // A spec that is not YAML says so first (the record's reader may not have parsed it).
        source.spec()?;
        return Err(Error::input(
            Location {
                file: Some(source.name()),
                field: Some("urdf".to_string()),
                ..Location::default()
            },
            "the spec has no `urdf:` record (it did not come from `lincal import`), so there is \
             no URDF to write the calibrated origins into: import the robot with `lincal import \
             ROBOT.urdf --base LINK --tip LINK` and calibrate that spec",
        ));
    };
    let urdf_path = record.resolve(&source.path);
    let text = lincal::error::read_input_file(&urdf_path, "URDF file", MAX_URDF_BYTES)?;
    Ok((record, urdf_path, text))
}

/// `--write-urdf`: the URDF of the spec's `urdf:` record with the calibrated origins.
fn calibrated_urdf(
    record: &urdf::UrdfRecord,
    urdf_path: &Path,
    urdf_text: &str,
    spec: &Spec,
    est: &Estimate,
    urdf_base: UrdfBase,
) -> Result<String> {
    let file = urdf_path.display().to_string();
    let kept = match urdf_base {
        UrdfBase::Calibrated => Vec::new(),
        UrdfBase::Urdf => urdf::urdf_base_values(urdf_text, &file, record, spec)?,
    };
    let value = |n: &str| {
        let own = kept.iter().find(|(k, _)| k == n).map(|&(_, v)| v);
        own.or_else(|| est.params.iter().find(|p| p.name == n).map(|p| p.value))
    };
    urdf::write_urdf(urdf_text, &file, record, spec, &value)
}

/// `calibrate --urdf-base`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum UrdfBase {
    /// The spec's `base:` at its calibrated value.
    Calibrated,
    /// The spec's `base:` as the URDF has it ([`urdf::urdf_base_values`]).
    Urdf,
}

/// How far a calibrated `base:` may move from its nominal (metres, and radians for its
/// angles) before `--write-urdf` says where it went: a robot's mounting errs by millimetres,
/// a tracker's registration by whatever the nominal guessed.
const BASE_MOVED: f64 = 0.01;

/// With `--write-urdf` and no `--urdf-base` (the default, `calibrated`): a warning when the spec's
/// `base:` moved beyond [`BASE_MOVED`] from its nominal, since the written URDF then places
/// the arm by it (in the first joint's origin), which for a tracker's registration is the
/// tracker's frame, not the robot's.
fn moved_base_warning(spec: &Spec, est: &Estimate) -> Option<String> {
    let names = spec.base_params();
    // The angles (roll, pitch, yaw) among them.
    let angle_names: Vec<&str> = spec
        .base
        .iter()
        .flat_map(|b| b.slots())
        .filter(|(k, _)| matches!(*k, "roll" | "pitch" | "yaw"))
        .filter_map(|(_, s)| s.param())
        .collect();
    let moved: Vec<String> = est
        .params
        .iter()
        .filter(|p| names.contains(&p.name.as_str()))
        .filter_map(|p| {
            let mut off = p.value - spec.param(&p.name)?.nominal.to_f64();
            // An angle fitted past ±π is written a turn away (the canonical form).
            if angle_names.contains(&p.name.as_str()) {
                off = lincal::lincal_core::numeric::wrap_angle(off);
            }
            (off.abs() > BASE_MOVED).then(|| format!("{} {off:+.4}", p.name))
        })
        .collect();
    (!moved.is_empty()).then(|| {
        format!(
            "the written URDF places the arm by the calibrated `base:` (from its nominal: {}), \
             in the first joint's origin; where `base:` is a measuring device's frame (a laser \
             tracker's registration), `--urdf-base urdf` writes the calibrated arm in the robot's \
             own base frame, as the URDF places it",
            moved.join(", ")
        )
    })
}
