//! The `lincal` command line; its contract is `shared/interface.md`.
//!
//! ```text
//! lincal basis SPEC [--format text|json]
//! lincal calibrate SPEC DATA.csv [--refine] [--format text|json]
//! lincal simulate SPEC --poses N [--seed S] [--truth TRUTH.yaml] [--noise-track M]
//!                 [--noise-encoder RAD] [--noise-measure M] [--noise-orientation RAD]
//!                 [--truth-out FILE]
//! lincal import ROBOT.urdf --base LINK --tip LINK [--tool x,y,z] [--convention dh|mdh]
//!                 [--constraint measured|point|plane|sphere|line]          # spec on stdout
//! lincal predict SPEC (--params RESULT.json | --nominal) DATA.csv...      # tips, CSV
//! lincal evaluate SPEC (--params RESULT.json | --nominal) DATA.csv... [--format text|json]
//! lincal compensate SPEC (--params RESULT.json | --nominal) TARGETS.csv [--format text|json]
//!                 [--allow-failed]                       # compensated joints, CSV
//! lincal demo
//! ```
//! `calibrate` and `predict` take several data files (one per constraint of a list),
//! `--angles rad|deg|auto` (the unit of revolute readings, default `auto`) and
//! `--no-header --columns q1,q2,…`; `calibrate` writes `--write-spec OUT.yaml` and
//! `--write-urdf OUT.urdf`, and judges held-out data with `--validate A.csv[,B.csv]`
//! (repeatable, one placement each) and `--folds K` (cross-validation).
//! Exit status: 0 on success, 2 on bad input (the message names the file, line and field; a
//! command-line usage error is bad input too), 1 on anything else (degenerate data, with the
//! reason). A panic is caught and reported as an internal error (exit 1); none is expected on
//! any input.

use lincal::model::CalibModel as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use lincal::calibrate::estimate::Estimate;
use lincal::calibrate::prior::{
    out_of_range, PriorChoice, PriorScale, PriorShape, DEFAULT_ANGLE_TOLERANCE,
    DEFAULT_LENGTH_TOLERANCE, TOLERANCE_RANGE, WEIGHT_RANGE,
};
use lincal::calibrate::{calibrate_spec_progress, CalibrateOptions, Robust, StartChoice};
use lincal::data::{Angles, DataLayout, Poses};
use lincal::error::{Error, ErrorClass, Location, Result};
use lincal::progress::{Progress as _, CHUNK};
use lincal::report;
use lincal::simulate::{self, Noise};
use lincal::spec::{self, Spec};
use lincal::symbolic::SymbolicModel;
use lincal::urdf;

use facts_cache::FactsCache;

/// Robot kinematic calibration by the linear generalized-parameter method (Sayeh & Newman).
#[derive(Parser, Debug)]
#[command(name = "lincal", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Bound on the terms of any polynomial of the exact expansion (about 100 bytes each);
    /// a spec that would cross it is refused at once with exit 1.
    #[arg(long, global = true, default_value_t = lincal::lincal_core::symbolic::DEFAULT_MAX_TERMS)]
    max_terms: usize,
}

/// Robust loss of `calibrate --robust`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum RobustLoss {
    /// Huber: quadratic within 1.345 σ, linear beyond.
    Huber,
    /// Cauchy: gross errors weigh almost nothing.
    Cauchy,
}

/// Output format of `basis` and `calibrate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    /// A readable report.
    Text,
    /// One JSON object (the fields of `shared/interface.md`).
    Json,
}

/// Table convention of `import`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ConventionArg {
    /// Standard Denavit-Hartenberg.
    Dh,
    /// Modified Denavit-Hartenberg (Craig).
    Mdh,
}

/// Constraint block of `import`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ConstraintArg {
    /// Measured tip positions (data has x, y, z).
    Measured,
    /// An unknown pinned point.
    Point,
    /// An unknown plane.
    Plane,
    /// An unknown sphere.
    Sphere,
    /// An unknown 3-D line.
    Line,
    /// Measured tool frames, position and orientation (data has x, y, z and qw, qx, qy, qz
    /// or rx, ry, rz); the tool becomes a frame.
    #[value(name = "measured_pose")]
    MeasuredPose,
}

/// The unit of revolute joint readings in data files (`--angles`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum AnglesArg {
    /// Radians, taken as they are (readings beyond a full turn are warned about).
    Rad,
    /// Degrees, converted to radians as they are read (prismatic readings and measured tips
    /// untouched).
    Deg,
    /// Radians, but a reading beyond a full turn and outside the joint's limits (or of a joint
    /// without limits) is refused (exit 2) as likely degrees.
    Auto,
}

/// How data files are read (`calibrate`, `predict`).
#[derive(clap::Args, Debug)]
struct DataArgs {
    /// The unit of revolute joint readings: `rad`, `deg` (converted as read) or `auto`
    /// (radians; readings that look like degrees are refused, naming line and column).
    #[arg(long, value_enum, default_value_t = AnglesArg::Auto)]
    angles: AnglesArg,
    /// The files have no header row; their columns are given by `--columns`.
    #[arg(long, requires = "columns")]
    no_header: bool,
    /// The columns of headerless files, comma-separated (`q1,q2,q3,_time`).
    #[arg(long, requires = "no_header")]
    columns: Option<String>,
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

#[derive(Subcommand, Debug)]
enum Command {
    /// The symbolic result for a spec: basis, generalized parameters, identifiability, gauge.
    Basis {
        /// The spec (YAML).
        spec: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Calibrates a spec on joint readings taken with the tip on the constraint.
    Calibrate {
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
        /// k-fold cross-validation over the poses (K ≥ 2, interleaved split): each fold
        /// fitted on the others with the same options and judged on its poses.
        #[arg(long, value_name = "K")]
        folds: Option<usize>,
    },
    /// Writes simulated poses (CSV) whose true tips satisfy the constraint, to stdout.
    Simulate {
        /// The spec (YAML).
        spec: PathBuf,
        /// Number of poses.
        #[arg(long)]
        poses: usize,
        /// Seed of the random generator (the same seed gives the same data).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// True parameters: a YAML mapping `name: value` (default: the nominals perturbed
        /// with the seed).
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Tracking noise: std of the true tip's distance from the constraint, metres.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        noise_track: f64,
        /// Encoder noise: std added to the recorded joint readings, radians (metres for
        /// prismatic joints).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        noise_encoder: f64,
        /// Measurement noise: std added to each coordinate of measured tips, metres.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        noise_measure: f64,
        /// Orientation noise of measured poses (`measured_pose`): std of the measured
        /// rotation's error about each axis of the tool frame, radians.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        noise_orientation: f64,
        /// Also write the true parameters used (a truth file for `--truth`) to this path.
        #[arg(long)]
        truth_out: Option<PathBuf>,
    },
    /// The poses worth measuring: `-n N` poses of a pool (`--candidates POOL.csv` or
    /// `--pool M` projected onto the nominal constraint), D-optimal over the free parameters
    /// (or least tip error), as data rows on stdout and a summary on stderr.
    Select(select::SelectArgs),
    /// The paper's AdeptOne experiment on data embedded in the binary: the paper's values and
    /// ours side by side.
    Demo,
    /// Converts the serial chain between two links of a URDF to a spec (YAML on stdout).
    Import {
        /// The URDF file.
        urdf: PathBuf,
        /// The chain's base link.
        #[arg(long)]
        base: String,
        /// The chain's tip link.
        #[arg(long)]
        tip: String,
        /// The tool point in the tip link's frame, `x,y,z` metres (default the link origin).
        #[arg(long, allow_hyphen_values = true)]
        tool: Option<String>,
        /// The table to write.
        #[arg(long, value_enum, default_value_t = ConventionArg::Dh)]
        convention: ConventionArg,
        /// The constraint block, with fresh unknown parameters (default `measured`, or
        /// `point` with `--points`).
        #[arg(long, value_enum)]
        constraint: Option<ConstraintArg>,
        /// With `point`: this many unknown pinned points (the sockets of one part), a
        /// `constraints:` list taking one data file per point, in order.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
        points: u32,
        /// With `--points`: the known distances between consecutive points, metres: one value
        /// for every consecutive pair, or one per pair (`d01,d12,…`); written as `relations:`.
        #[arg(long, requires = "points")]
        distance: Option<String>,
    },
    /// Judges calibrated (or nominal) parameters on held-out data, beside the nominals: per
    /// constraint the residual with its unknown values refitted, points' spread and means.
    Evaluate {
        /// The spec (YAML).
        spec: PathBuf,
        /// The calibrated parameters: the JSON of `lincal calibrate --format json`.
        #[arg(long, required_unless_present = "nominal", conflicts_with = "nominal")]
        params: Option<PathBuf>,
        /// Use the spec's nominal values.
        #[arg(long)]
        nominal: bool,
        /// The held-out poses, laid out as `calibrate`'s data (one file per constraint of a
        /// list, in order).
        #[arg(required = true, num_args = 1..)]
        data: Vec<PathBuf>,
        #[command(flatten)]
        data_args: DataArgs,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// For each target (joints, or a tool position or pose with seed joints), the joints that
    /// put the calibrated model's tool on it, for a controller that keeps its nominal model:
    /// CSV on stdout, a summary on stderr; exit 1 when a row failed (unless --allow-failed).
    Compensate(compensate::CompensateArgs),
    /// The tip of every pose (CSV `x,y(,z)` on stdout) for calibrated or nominal parameters.
    Predict {
        /// The spec (YAML).
        spec: PathBuf,
        /// The calibrated parameters: the JSON of `lincal calibrate --format json`.
        #[arg(long, required_unless_present = "nominal", conflicts_with = "nominal")]
        params: Option<PathBuf>,
        /// Use the spec's nominal values.
        #[arg(long)]
        nominal: bool,
        /// The poses (only the joint columns are used).
        #[arg(required = true, num_args = 1..)]
        data: Vec<PathBuf>,
        #[command(flatten)]
        data_args: DataArgs,
    },
}

fn main() -> ExitCode {
    heap::tune_for_engine();
    // A write past the file-size limit fails with EFBIG (the temporary output is removed
    // and the error named) instead of the signal killing the process mid-write.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore" before any thread is started.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    std::panic::set_hook(Box::new(|info| {
        eprintln!("lincal: internal error (a bug, please report it): {info}");
    }));
    match std::panic::catch_unwind(run) {
        Ok(code) => code,
        Err(_) => ExitCode::from(1),
    }
}

/// Parses the command line and runs it; the exit status.
fn run() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let out = std::io::stdout();
    let mut out = std::io::BufWriter::new(out.lock());
    let result = execute(cli.command, cli.max_terms, &mut out)
        .and_then(|()| out.flush().map_err(|e| io_err(&e)));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            for line in e.to_string().lines() {
                eprintln!("lincal: error: {line}");
            }
            match e.class() {
                ErrorClass::Input => ExitCode::from(2),
                ErrorClass::Degenerate | ErrorClass::Other => ExitCode::from(1),
            }
        }
    }
}

/// Whether an error is a closed stdout (`lincal simulate … | head`), which is not a failure.
fn is_broken_pipe(e: &Error) -> bool {
    e.class() == ErrorClass::Other && e.to_string().contains(BROKEN_PIPE_MARK)
}

const BROKEN_PIPE_MARK: &str = "(stdout closed)";

fn io_err(e: &std::io::Error) -> Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        Error::other(format!("cannot write the output {BROKEN_PIPE_MARK}"))
    } else {
        Error::other(format!("cannot write the output: {e}"))
    }
}

fn write_text(out: &mut dyn Write, text: &str) -> Result<()> {
    out.write_all(text.as_bytes()).map_err(|e| io_err(&e))
}

fn write_json(out: &mut dyn Write, v: &serde_json::Value) -> Result<()> {
    let s = serde_json::to_string_pretty(v)
        .map_err(|e| Error::other(format!("cannot format JSON: {e}")))?;
    write_text(out, &s)?;
    write_text(out, "\n")
}

/// Loads a spec and builds its symbolic model within `max_terms`.
fn load(path: &Path, max_terms: usize) -> Result<(Spec, SymbolicModel)> {
    let spec = spec::from_yaml_file(path)?;
    let spinner = progress::Spinner::after(progress::SPINNER_DELAY, "expanding the spec");
    let model = SymbolicModel::from_spec_with(&spec, max_terms)
        .map_err(|e| e.in_file(&path.display().to_string()))?;
    drop(spinner);
    Ok((spec, model))
}

/// Loads a spec and builds the model a fit needs ([`SymbolicModel::for_fitting_with`]): the
/// identifiability analysis now (or its cached result), the basis only if the fit reads it
/// (within `max_terms`). The cache entry comes along, for [`FactsCache::store`] once the
/// command has learnt what it could.
fn load_for_fitting(
    source: &inputs::SpecText,
    max_terms: usize,
) -> Result<(Spec, SymbolicModel, FactsCache)> {
    load_model(source, max_terms, false)
}

/// [`load_for_fitting`], with the basis half built ahead on another thread when `prefetch`
/// ([`SymbolicModel::for_fitting_prefetching`]): for `calibrate`, whose report gives `K`.
fn load_model(
    source: &inputs::SpecText,
    max_terms: usize,
    prefetch: bool,
) -> Result<(Spec, SymbolicModel, FactsCache)> {
    let path = &source.path;
    let spec = source.spec()?;
    let spinner = progress::Spinner::after(progress::SPINNER_DELAY, "analysing the spec");
    let cache = FactsCache::open(&spec, max_terms);
    let model = if prefetch {
        SymbolicModel::for_fitting_prefetching(&spec, max_terms, cache.found())
    } else {
        SymbolicModel::for_fitting_with(&spec, max_terms, cache.found())
    }
    .map_err(|e| e.in_file(&path.display().to_string()))?;
    drop(spinner);
    Ok((spec, model, cache))
}

/// Runs one subcommand, writing its output to `out`.
fn execute(command: Command, max_terms: usize, out: &mut dyn Write) -> Result<()> {
    match command {
        Command::Basis { spec, format } => run_basis(out, &spec, format, max_terms),
        Command::Calibrate {
            spec,
            data,
            data_args,
            write_spec,
            write_urdf,
            refine,
            start,
            reject_outliers,
            robust,
            prior,
            format,
            report: report_path,
            validate,
            folds,
        } => run_calibrate(
            out,
            &CalibrateRun {
                spec: &spec,
                data: &data,
                data_args: &data_args,
                write_spec: write_spec.as_deref(),
                write_urdf: write_urdf.as_deref(),
                report: report_path.as_deref(),
                opts: CalibrateOptions {
                    prior: prior.choice()?,
                    ..calibrate_options(refine, start, reject_outliers, robust)
                },
                format,
                validate: &validate,
                folds,
            },
            max_terms,
        ),
        Command::Select(args) => select::run(out, &args, max_terms),
        Command::Compensate(args) => compensate::run(out, &args),
        Command::Simulate {
            spec,
            poses,
            seed,
            truth,
            noise_track,
            noise_encoder,
            noise_measure,
            noise_orientation,
            truth_out,
        } => run_simulate(
            out,
            &SimulateRun {
                spec: &spec,
                poses,
                seed,
                truth: truth.as_deref(),
                noise: Noise {
                    track: noise_track,
                    encoder: noise_encoder,
                    measure: noise_measure,
                    orientation: noise_orientation,
                },
                truth_out: truth_out.as_deref(),
            },
            max_terms,
        ),
        Command::Demo => {
            let text = demo::run()?;
            write_text(out, &text)
        }
        Command::Import {
            urdf,
            base,
            tip,
            tool,
            convention,
            constraint,
            points,
            distance,
        } => run_import(
            out,
            &urdf,
            ImportArgs {
                base,
                tip,
                tool: tool.as_deref(),
                convention,
                constraint: constraint.unwrap_or(if points > 1 {
                    ConstraintArg::Point
                } else {
                    ConstraintArg::Measured
                }),
                points: points as usize,
                distance: distance.as_deref(),
            },
        ),
        Command::Predict {
            spec,
            params,
            nominal: _,
            data,
            data_args,
        } => run_predict(out, &spec, params.as_deref(), &data, &data_args),
        Command::Evaluate {
            spec,
            params,
            nominal: _,
            data,
            data_args,
            format,
        } => evaluate::run_evaluate(
            out,
            &evaluate::EvaluateRun {
                spec: &spec,
                params: params.as_deref(),
                data: &data,
                data_args: &data_args,
                format,
            },
            max_terms,
        ),
    }
}

/// `basis`: the symbolic result for a spec, as text or JSON.
fn run_basis(out: &mut dyn Write, spec: &Path, format: Format, max_terms: usize) -> Result<()> {
    let (_, model) = load(spec, max_terms)?;
    match format {
        Format::Json => write_json(out, &report::basis_json(&model)),
        Format::Text => write_text(out, &report::basis_text(&model)),
    }
}

/// The arguments of `calibrate`.
struct CalibrateRun<'a> {
    spec: &'a Path,
    data: &'a [PathBuf],
    data_args: &'a DataArgs,
    write_spec: Option<&'a Path>,
    write_urdf: Option<&'a Path>,
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
    #[arg(long, value_name = "W", conflicts_with_all = ["tolerance_length", "tolerance_angle"])]
    prior_weight: Option<f64>,
    /// Fixed tolerances instead of the data's choice: one standard deviation of lengths, of
    /// each joint mounting's translation (`frames`) or of each length of the arm (`params`),
    /// metres, from 1e-9 to 1e3 (default 0.01 when only `--tolerance-angle` is given).
    #[arg(long, value_name = "M")]
    tolerance_length: Option<f64>,
    /// Fixed tolerances instead of the data's choice: one standard deviation of angles, of
    /// each joint mounting's rotation (`frames`) or of each twist and home offset (`params`),
    /// radians, from 1e-9 to 1e3 (default 0.01 when only `--tolerance-length` is given).
    #[arg(long, value_name = "RAD")]
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
    check_calibrate_outputs(run, urdf_source.as_ref().map(|(_, p, _)| p.as_path()))?;
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
    if let Some(k) = run.folds {
        lincal::calibrate::validation::check_folds(k, poses.len())?;
    }
    let mut held_out = Vec::new();
    for files in evaluate::placements(run.validate)? {
        let p = evaluate::read_placement(&model, &spec, &spec_text, run.data_args, &files)?;
        held_out.push((files, p));
    }
    let bar = progress::Bar::new(poses.len() >= progress::MANY_POSES);
    let mut est = calibrate_spec_progress(&model, &spec, &poses, run.opts, &bar).map_err(|e| {
        match run.data {
            [one] => e.in_file(&one.display().to_string()),
            _ => e,
        }
    })?;
    est.warnings.extend(model.warnings());
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
            Some((out, calibrated_urdf(record, path, text, &spec, &est)?))
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
        Format::Json => write_json(out, &report::calibrate_json(&model, &est)),
        Format::Text => write_text(out, &report::calibrate_text(&model, &est)),
    }
}

/// The arguments of `simulate`.
struct SimulateRun<'a> {
    spec: &'a Path,
    poses: usize,
    seed: u64,
    truth: Option<&'a Path>,
    noise: Noise,
    truth_out: Option<&'a Path>,
}

/// `simulate`: checks the arguments, resolves the true parameters, then streams the simulated
/// rows as CSV, writing the true parameters when asked once the first pose is placed
/// ([`write_simulated`]).
fn run_simulate(out: &mut dyn Write, run: &SimulateRun<'_>, max_terms: usize) -> Result<()> {
    let mut inputs: Vec<(&str, &Path)> = vec![("spec", run.spec)];
    inputs.extend(run.truth.map(|t| ("--truth file", t)));
    let outputs: Vec<(&str, &Path)> = run
        .truth_out
        .map(|t| ("--truth-out", t))
        .into_iter()
        .collect();
    outputs::check_distinct(&inputs, &outputs)?;
    let (spec, model, cache) = load_for_fitting(&inputs::SpecText::read(run.spec)?, max_terms)?;
    cache.store(&model.facts());
    if run.noise.measure != 0.0 && !spec.is_measured() {
        eprintln!(
            "lincal: warning: --noise-measure has no effect: the spec's constraint is not \
             `measured` (use --noise-track for a tip held on a constraint)"
        );
    }
    if run.noise.orientation != 0.0 && !spec.is_measured_pose() {
        eprintln!(
            "lincal: warning: --noise-orientation has no effect: the spec's constraint is not \
             `measured_pose`"
        );
    }
    if run.poses == 0 {
        return Err(Error::input(
            Location {
                field: Some("--poses".to_string()),
                ..Location::default()
            },
            "the number of poses must be at least 1",
        ));
    }
    let truth = match run.truth {
        Some(path) => Some(simulate::truth_from_yaml_file(path, &model, &spec)?),
        None => None,
    };
    let p = simulate::resolve_truth(&model, &spec, run.seed, truth.as_deref())?;
    simulate::check_noise(run.noise)?;
    write_simulated(out, &model, &spec, run, &p)
}

/// The simulated poses as CSV: the header, then one row per pose as it is made (memory does
/// not grow with `--poses`). Nothing is written until the first pose is placed: then the
/// truth file (`--truth-out`, so that it exists even if the run is cut short later), the
/// header and the row. A run that cannot place any pose (an unreachable constraint) leaves
/// neither a truth file nor a header-only CSV behind.
fn write_simulated(
    out: &mut dyn Write,
    model: &SymbolicModel,
    spec: &Spec,
    run: &SimulateRun<'_>,
    p: &[f64],
) -> Result<()> {
    let measured = (0..model.constraint_count()).any(|j| model.constraint_kind(j).is_measured());
    let mut w = std::io::BufWriter::new(out);
    let mut started = false;
    let dim = model.dim();
    let bar = progress::Bar::new(run.poses >= progress::MANY_POSES);
    bar.stage("simulating", Some(run.poses as u64));
    simulate::simulate_each(
        model,
        spec,
        run.poses,
        run.seed,
        Some(p),
        run.noise,
        |pose| {
            if (pose.index + 1) % CHUNK == 0 {
                bar.inc(CHUNK as u64);
            }
            if !started {
                started = true;
                if let Some(path) = run.truth_out {
                    write_file(path, &simulate::truth_to_yaml(model, p), "truth file")?;
                }
                simulate::write_csv_header(&mut w, model, measured, spec.constraint_list)
                    .map_err(|e| io_err(&e))?;
            }
            let m = measured.then(|| pose.measured.unwrap_or(&[]));
            let c = spec.constraint_list.then_some(pose.constraint);
            simulate::write_csv_row(&mut w, dim, pose.q, m, c).map_err(|e| io_err(&e))
        },
    )?;
    w.flush().map_err(|e| io_err(&e))
}

/// The layout of the data files with the command line's `--angles --no-header --columns`,
/// and the URDF joint names of the spec's `urdf:` record (at `spec_path`) as other names of
/// the joint columns.
fn data_layout(
    mut layout: DataLayout,
    args: &DataArgs,
    source: &inputs::SpecText,
) -> Result<DataLayout> {
    layout.angles = match args.angles {
        AnglesArg::Rad => Angles::Rad,
        AnglesArg::Deg => Angles::Deg,
        AnglesArg::Auto => Angles::Auto,
    };
    let name = source.name();
    if let Some(record) = urdf::UrdfRecord::from_spec_text(&source.text, Some(&name))? {
        // A record edited to another number of joints names none (its columns then stay
        // unknown rather than mapped to the wrong joint).
        if record.joints.len() == layout.joints {
            layout.joint_names = record.joints;
        }
    }
    if let (true, Some(cols)) = (args.no_header, &args.columns) {
        let names: Vec<String> = cols.split(',').map(|c| c.trim().to_string()).collect();
        if names.iter().any(String::is_empty) {
            return Err(Error::input(
                field("--columns"),
                format!("`{cols}` has an empty column name: expected names like `q1,q2,q3`"),
            ));
        }
        layout.columns = Some(names);
    }
    Ok(layout)
}

fn field(name: &str) -> Location {
    Location {
        field: Some(name.to_string()),
        ..Location::default()
    }
}

/// Writes an output file whole or not at all ([`outputs::write_atomic`]).
fn write_file(path: &Path, text: &str, what: &str) -> Result<()> {
    outputs::write_atomic(path, text.as_bytes(), what)
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
    let name = source.name();
    let Some(record) = urdf::UrdfRecord::from_spec_text(&source.text, Some(&name))? else {
        return Err(Error::input(
            Location {
                file: Some(name),
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
) -> Result<String> {
    let value = |n: &str| est.params.iter().find(|p| p.name == n).map(|p| p.value);
    urdf::write_urdf(
        urdf_text,
        &urdf_path.display().to_string(),
        record,
        spec,
        &value,
    )
}

/// Largest URDF read (a URDF with inline meshes can be large; text only).
const MAX_URDF_BYTES: usize = 64 << 20;

/// `import`: the spec of the URDF's chain from `base` to `tip`, on `out`; the importer's
/// notes on stderr.
fn run_import(out: &mut dyn Write, path: &Path, args: ImportArgs) -> Result<()> {
    let ImportArgs {
        base,
        tip,
        tool,
        convention,
        constraint,
        points,
        distance,
    } = args;
    let tool = import_tool(tool)?;
    let distances = import_distances(distance)?;
    if points < 2 && !distances.is_empty() {
        return Err(Error::input(
            field("--distance"),
            "distances need `--points 2` or more",
        ));
    }
    let text = lincal::error::read_input_file(path, "URDF file", MAX_URDF_BYTES)?;
    let recorded = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut command = import_command(path, &base, &tip, tool, convention, constraint);
    if points > 1 {
        command.push_str(&format!(" --points {points}"));
    }
    if let Some(d) = distance {
        command.push_str(&format!(" --distance {d}"));
    }
    let imported = urdf::import(
        &text,
        &path.display().to_string(),
        &urdf::ImportOptions {
            path: recorded.display().to_string(),
            base,
            tip,
            tool,
            points,
            distances,
            convention: match convention {
                ConventionArg::Dh => spec::Convention::Dh,
                ConventionArg::Mdh => spec::Convention::Mdh,
            },
            constraint: match constraint {
                ConstraintArg::Measured => urdf::ConstraintChoice::Measured,
                ConstraintArg::Point => urdf::ConstraintChoice::Point,
                ConstraintArg::Plane => urdf::ConstraintChoice::Plane,
                ConstraintArg::Sphere => urdf::ConstraintChoice::Sphere,
                ConstraintArg::Line => urdf::ConstraintChoice::Line,
                ConstraintArg::MeasuredPose => urdf::ConstraintChoice::MeasuredPose,
            },
            command,
        },
    )?;
    for note in &imported.notes {
        // A note quotes URDF names; no control character reaches the terminal.
        let note: String = note
            .chars()
            .map(|c| if c.is_control() { '?' } else { c })
            .collect();
        eprintln!("lincal: note: {note}");
    }
    write_text(out, &imported.yaml)
}

/// The arguments of `import` after the URDF path.
struct ImportArgs<'a> {
    base: String,
    tip: String,
    tool: Option<&'a str>,
    convention: ConventionArg,
    constraint: ConstraintArg,
    points: usize,
    distance: Option<&'a str>,
}

/// `import --distance d[,d…]`: finite numbers (the range is checked with the point count).
fn import_distances(distance: Option<&str>) -> Result<Vec<f64>> {
    let Some(d) = distance else {
        return Ok(Vec::new());
    };
    d.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::input(
                        field("--distance"),
                        format!("`{}` is not a number (metres)", p.trim()),
                    )
                })
        })
        .collect()
}

/// `import --tool x,y,z`: three finite numbers (metres, at most 10⁹); zeros when not given.
fn import_tool(tool: Option<&str>) -> Result<[f64; 3]> {
    let Some(t) = tool else {
        return Ok([0.0; 3]);
    };
    let parts: Vec<&str> = t.split(',').map(str::trim).collect();
    let vals: Vec<f64> = parts
        .iter()
        .filter_map(|p| p.parse::<f64>().ok())
        .filter(|v| v.is_finite())
        .collect();
    match <[f64; 3]>::try_from(vals) {
        Ok(v) if parts.len() == 3 => Ok(v),
        _ => Err(Error::input(
            field("--tool"),
            format!("`{t}` is not three finite numbers `x,y,z` (metres)"),
        )),
    }
}

/// The `import` command line as the imported spec records it (every option spelled out;
/// `--tool` only when not zero).
fn import_command(
    path: &Path,
    base: &str,
    tip: &str,
    tool: [f64; 3],
    convention: ConventionArg,
    constraint: ConstraintArg,
) -> String {
    let name = |v: ConventionArg| format!("{v:?}").to_lowercase();
    format!(
        "lincal import {} --base {base} --tip {tip}{} --convention {} --constraint {}",
        path.display(),
        if tool.iter().any(|v| *v != 0.0) {
            format!(" --tool {},{},{}", tool[0], tool[1], tool[2])
        } else {
            String::new()
        },
        name(convention),
        constraint
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string())
    )
}

/// `predict`: the tips of the spec's chain at each data row's joint readings, as CSV on
/// `out`, with the nominals or a calibration result's values.
fn run_predict(
    out: &mut dyn Write,
    spec_path: &Path,
    params: Option<&Path>,
    data: &[PathBuf],
    data_args: &DataArgs,
) -> Result<()> {
    let spec_text = inputs::SpecText::read(spec_path)?;
    let spec = spec_text.spec()?;
    let est = spec.estimated_params();
    let p: Vec<f64> = match params {
        None => est.iter().map(|p| p.nominal.to_f64()).collect(),
        Some(path) => result_values(path, &spec, &est)?,
    };
    let mut layout = data_layout(DataLayout::of_spec(&spec), data_args, &spec_text)?;
    layout.joints_only = true;
    let paths: Vec<&Path> = data.iter().map(PathBuf::as_path).collect();
    let poses = Poses::from_csv_paths(&paths, &layout)?;
    write_tips(out, &spec, &poses, &p).map_err(|e| match data {
        [one] => e.in_file(&one.display().to_string()),
        _ => e,
    })
}

/// Largest result file `predict --params` reads (a `calibrate --format json` output is a few
/// kilobytes per parameter; 16 MiB is far beyond any real one).
const MAX_RESULT_BYTES: usize = 16 << 20;

/// What `predict` reads of a result file: each parameter's `value`; every other field is
/// skipped while parsing, so memory is the parameters', not a tree of the file.
#[derive(serde::Deserialize)]
struct ResultFile {
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

/// The values of the estimated parameters `est` (in order) from the result file at `path`
/// (the output of `calibrate --format json`): every parameter it lists is the spec's, every
/// estimated one has a finite `value`.
fn result_values(path: &Path, spec: &Spec, est: &[&spec::Param]) -> Result<Vec<f64>> {
    let text = lincal::error::read_input_file(path, "result file", MAX_RESULT_BYTES)?;
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

/// Largest magnitude of a predicted coordinate (in the spec's length unit): beyond it the
/// parameters are not a robot's, and the output would be `inf` or meaningless digits.
const MAX_PREDICTED: f64 = 1e9;

/// Writes the tip at every pose's joint readings and parameters `p` as CSV (`x,y` or
/// `x,y,z`, shortest round-trip decimals).
fn write_tips(out: &mut dyn Write, spec: &Spec, poses: &Poses, p: &[f64]) -> Result<()> {
    let kin = lincal::lincal_core::spec::kinematics::Kinematics::new(spec);
    // A measured pose's spec: the tool frame, `x, y, z` then its quaternion `qw, qx, qy, qz`.
    let pose = spec.is_measured_pose();
    let chain = lincal::lincal_core::spec::chain::Chain::from_spec(spec);
    let dim = if pose { 7 } else { spec.dim };
    // Every tip is computed and checked before the first is written: an error leaves no
    // partial table on stdout.
    let mut tips = vec![0.0; poses.len() * dim];
    for (l, (q, tip)) in poses.q.iter().zip(tips.chunks_exact_mut(dim)).enumerate() {
        if pose {
            let (mut x, mut rot) = ([0.0; 3], [0.0; 9]);
            lincal::model::chain::pose(&chain.factors, q, p, &mut x, &mut rot);
            tip[..3].copy_from_slice(&x);
            tip[3..].copy_from_slice(&lincal::model::rotation::quaternion_from_matrix(&rot));
        } else {
            kin.tip(q, p, tip);
        }
        if let Some(v) = tip
            .iter()
            .find(|v| !v.is_finite() || v.abs() > MAX_PREDICTED)
        {
            return Err(Error::input(
                Location {
                    line: poses.line.get(l),
                    field: Some("--params".to_string()),
                    ..Location::default()
                },
                format!(
                    "the predicted tip of pose {l} has a coordinate {v:e}, beyond \
                     {MAX_PREDICTED:e}: the parameters are not a robot's"
                ),
            ));
        }
    }
    let mut w = std::io::BufWriter::new(out);
    let header = match dim {
        2 => "x,y\n",
        7 => "x,y,z,qw,qx,qy,qz\n",
        _ => "x,y,z\n",
    };
    w.write_all(header.as_bytes()).map_err(|e| io_err(&e))?;
    let mut line = String::new();
    for tip in tips.chunks_exact(dim) {
        line.clear();
        for (i, v) in tip.iter().enumerate() {
            if i > 0 {
                line.push(',');
            }
            line.push_str(&format!("{v:?}"));
        }
        line.push('\n');
        w.write_all(line.as_bytes()).map_err(|e| io_err(&e))?;
    }
    w.flush().map_err(|e| io_err(&e))
}

mod compensate;
mod demo;
mod evaluate;
mod facts_cache;
mod heap;
mod html_report;
mod inputs;
mod outputs;
mod progress;
mod select;
