//! The `lincal` command line; its contract is `shared/interface.md`.
//!
//! ```text
//! lincal basis SPEC [--format text|json]
//! lincal calibrate SPEC DATA.csv [--refine] [--format text|json]
//! lincal simulate SPEC --poses N [--seed S] [--truth TRUTH.yaml] [--noise-track M]
//!                 [--noise-encoder RAD] [--noise-measure M] [--truth-out FILE]
//! lincal demo
//! ```
//! Exit status: 0 on success, 2 on bad input (the message names the file, line and field; a
//! command-line usage error is bad input too), 1 on anything else (degenerate data, with the
//! reason). A panic is caught and reported as an internal error (exit 1); none is expected on
//! any input.

use lincal::model::CalibModel as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use lincal::calibrate::{calibrate_spec_progress, CalibrateOptions, Robust, StartChoice};
use lincal::data::Poses;
use lincal::error::{Error, ErrorClass, Location, Result};
use lincal::progress::{Progress as _, CHUNK};
use lincal::report;
use lincal::simulate::{self, Noise};
use lincal::spec::{self, Spec};
use lincal::symbolic::SymbolicModel;

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
        /// The poses (CSV: q1..qn, then x,y(,z) for measured tips, constraint for lists).
        data: PathBuf,
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
        /// Fit with a robust loss (iteratively reweighted from the ordinary fit), its tuning
        /// constant reported: `huber` (c = 1.345) or `cauchy` (c = 2.385).
        #[arg(long, value_enum)]
        robust: Option<RobustLoss>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Also write a self-contained HTML report (parameters, gauge, residuals before and
        /// after with plots, worst poses, identifiability, input hashes) to this path.
        #[arg(long, value_name = "OUT.html")]
        report: Option<PathBuf>,
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
        /// Also write the true parameters used (a truth file for `--truth`) to this path.
        #[arg(long)]
        truth_out: Option<PathBuf>,
    },
    /// The paper's AdeptOne experiment on data embedded in the binary: the paper's values and
    /// ours side by side.
    Demo,
}

fn main() -> ExitCode {
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

fn execute(command: Command, max_terms: usize, out: &mut dyn Write) -> Result<()> {
    match command {
        Command::Basis { spec, format } => {
            let (_, model) = load(&spec, max_terms)?;
            match format {
                Format::Json => write_json(out, &report::basis_json(&model)),
                Format::Text => write_text(out, &report::basis_text(&model)),
            }
        }
        Command::Calibrate {
            spec,
            data,
            refine,
            start,
            reject_outliers,
            robust,
            format,
            report: report_path,
        } => {
            if let Some(path) = &report_path {
                html_report::check_path(path)?;
            }
            let spec_path = spec;
            let (spec, model) = load(&spec_path, max_terms)?;
            let big = std::fs::metadata(&data).is_ok_and(|m| m.len() >= progress::BIG_FILE);
            let bar = progress::Bar::new(big);
            let poses = Poses::from_csv_path_progress(&data, &model, spec.constraint_list, &bar)?;
            drop(bar);
            let bar = progress::Bar::new(poses.len() >= progress::MANY_POSES);
            let start = match start {
                Start::Auto => StartChoice::Auto,
                Start::Linear => StartChoice::Linear,
                Start::Nominal => StartChoice::Nominal,
            };
            let opts = CalibrateOptions {
                refine,
                start,
                reject_outliers,
                robust: robust.map(|r| match r {
                    RobustLoss::Huber => Robust::Huber,
                    RobustLoss::Cauchy => Robust::Cauchy,
                }),
            };
            let mut est = calibrate_spec_progress(&model, &spec, &poses, opts, &bar)
                .map_err(|e| e.in_file(&data.display().to_string()))?;
            est.warnings.extend(model.warnings());
            if let Some(path) = &report_path {
                bar.stage("writing the report", None);
                html_report::write(path, &model, &spec, &poses, &est, &spec_path, &data)?;
            }
            bar.finish();
            match format {
                Format::Json => write_json(out, &report::calibrate_json(&model, &est)),
                Format::Text => write_text(out, &report::calibrate_text(&model, &est)),
            }
        }
        Command::Simulate {
            spec,
            poses,
            seed,
            truth,
            noise_track,
            noise_encoder,
            noise_measure,
            truth_out,
        } => {
            let (spec, model) = load(&spec, max_terms)?;
            if noise_measure != 0.0 && !spec.is_measured() {
                eprintln!(
                    "lincal: warning: --noise-measure has no effect: the spec's constraint is not \
                     `measured` (use --noise-track for a tip held on a constraint)"
                );
            }
            if poses == 0 {
                return Err(Error::input(
                    Location {
                        field: Some("--poses".to_string()),
                        ..Location::default()
                    },
                    "the number of poses must be at least 1",
                ));
            }
            let truth = match &truth {
                Some(path) => Some(simulate::truth_from_yaml_file(path, &model, &spec)?),
                None => None,
            };
            let noise = Noise {
                track: noise_track,
                encoder: noise_encoder,
                measure: noise_measure,
            };
            // The truth first (so it exists even if the run is cut short), then the rows as
            // they are made: memory does not grow with --poses.
            let p = simulate::resolve_truth(&model, &spec, seed, truth.as_deref())?;
            simulate::check_noise(noise)?;
            if let Some(path) = &truth_out {
                std::fs::write(path, simulate::truth_to_yaml(&model, &p)).map_err(|e| {
                    Error::new(
                        ErrorClass::Other,
                        Location {
                            file: Some(path.display().to_string()),
                            ..Location::default()
                        },
                        format!("cannot write the truth file: {e}"),
                    )
                })?;
            }
            let measured = (0..model.constraint_count())
                .any(|j| model.constraint_kind(j) == lincal::geometry::ConstraintKind::Measured);
            let mut w = std::io::BufWriter::new(out);
            simulate::write_csv_header(&mut w, &model, measured, spec.constraint_list)
                .map_err(|e| io_err(&e))?;
            let dim = model.dim();
            let bar = progress::Bar::new(poses >= progress::MANY_POSES);
            bar.stage("simulating", Some(poses as u64));
            simulate::simulate_each(&model, &spec, poses, seed, Some(&p), noise, |pose| {
                if (pose.index + 1) % CHUNK == 0 {
                    bar.inc(CHUNK as u64);
                }
                let m = measured.then(|| pose.measured.unwrap_or(&[]));
                let c = spec.constraint_list.then_some(pose.constraint);
                simulate::write_csv_row(&mut w, dim, pose.q, m, c).map_err(|e| io_err(&e))
            })?;
            w.flush().map_err(|e| io_err(&e))
        }
        Command::Demo => {
            let text = demo::run()?;
            write_text(out, &text)
        }
    }
}

mod demo;
mod html_report;
mod progress;
