//! The command line's rooms: one file per subcommand, each with its clap arguments and its
//! run function (cargo's `commands/`, ripgrep's flags); [`common`] holds what several share
//! (data options, output helpers, spec loading) and [`result_file`] the reader of
//! `calibrate --format json` results that `predict`, `evaluate` and `compensate` take.

use std::io::Write;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use lincal::error::Result;

pub mod basis;
pub mod calibrate;
pub mod common;
pub mod compensate;
pub mod demo;
pub mod evaluate;
pub mod import;
pub mod predict;
pub mod result_file;
pub mod select;
pub mod simulate;

pub use common::{io_err, is_broken_pipe};

/// Robot kinematic calibration by the linear generalized-parameter method (Sayeh & Newman).
#[derive(Parser, Debug)]
#[command(name = "lincal", version, about, long_about = None)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
    /// Bound on the terms of any polynomial of the exact expansion (300 to 1 000 bytes each
    /// at the peak); a spec that would cross it is refused at once with exit 1.
    #[arg(long, global = true, default_value_t = lincal::lincal_core::symbolic::DEFAULT_MAX_TERMS)]
    pub max_terms: usize,
}

/// The subcommands, each in its own file.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// The symbolic result for a spec: basis, generalized parameters, identifiability, gauge.
    Basis(basis::BasisArgs),
    /// Calibrates a spec on joint readings taken with the tip on the constraint.
    Calibrate(calibrate::CalibrateArgs),
    /// Writes simulated poses (CSV) whose true tips satisfy the constraint, to stdout.
    Simulate(simulate::SimulateArgs),
    /// The poses worth measuring: `-n N` poses of a pool (`--candidates POOL.csv` or
    /// `--pool M` projected onto the nominal constraint), D-optimal over the free parameters
    /// (or least tip error), as data rows on stdout and a summary on stderr.
    Select(select::SelectArgs),
    /// The paper's AdeptOne experiment on data embedded in the binary: the paper's values and
    /// ours side by side.
    Demo,
    /// Converts the serial chain between two links of a URDF to a spec (YAML on stdout).
    Import(import::ImportArgs),
    /// Judges calibrated (or nominal) parameters on held-out data, beside the nominals: per
    /// constraint the residual with its unknown values refitted, points' spread and means.
    Evaluate(evaluate::EvaluateArgs),
    /// For each target (joints, or a tool position or pose with seed joints), the joints that
    /// put the calibrated model's tool on it, for a controller that keeps its nominal model:
    /// CSV on stdout, a summary on stderr; exit 1 when a row failed (unless --allow-failed).
    Compensate(compensate::CompensateArgs),
    /// The tip of every pose (CSV `x,y(,z)` on stdout) for calibrated or nominal parameters.
    Predict(predict::PredictArgs),
}

impl Cli {
    /// Parses the process's arguments. A negative number is read as a value everywhere
    /// (`--poses -1`), so the value's own check names the flag and what it accepts, instead
    /// of clap's "unexpected argument '-1'" with a tip to write `-- -1` (which passes it as
    /// a positional argument, never to the flag).
    ///
    /// # Errors
    /// clap's error for the arguments (or its help and version output).
    pub fn try_parse_args() -> std::result::Result<Cli, clap::Error> {
        let command = Cli::command()
            .allow_negative_numbers(true)
            .mut_subcommands(|s| s.allow_negative_numbers(true));
        let mut matches = command.try_get_matches()?;
        Cli::from_arg_matches_mut(&mut matches)
    }
}

/// Runs one subcommand, writing its output to `out`.
pub fn execute(command: Command, max_terms: usize, out: &mut dyn Write) -> Result<()> {
    match command {
        Command::Basis(args) => basis::run(out, &args, max_terms),
        Command::Calibrate(args) => calibrate::run(out, &args, max_terms),
        Command::Simulate(args) => simulate::run(out, &args, max_terms),
        Command::Select(args) => select::run(out, &args, max_terms),
        Command::Demo => common::write_text(out, &demo::run()?),
        Command::Import(args) => import::run(out, args),
        Command::Evaluate(args) => evaluate::run(out, &args, max_terms),
        Command::Compensate(args) => compensate::run(out, &args),
        Command::Predict(args) => predict::run(out, &args),
    }
}
