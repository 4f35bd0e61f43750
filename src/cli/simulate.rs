//! `lincal simulate`: poses whose true tips satisfy the constraint, as CSV on stdout.

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::simulate::MAX_POSES;

use lincal::error::{Error, Location, Result};
use lincal::model::CalibModel as _;
use lincal::progress::{Progress as _, CHUNK};
use lincal::simulate::{self, Noise};
use lincal::spec::Spec;
use lincal::symbolic::SymbolicModel;

use super::common::{io_err, load_for_fitting, write_file};
use crate::{inputs, outputs, progress};

/// The arguments of `simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// The spec (YAML).
    spec: PathBuf,
    /// Number of poses (1 to 10⁷).
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
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_track: f64,
    /// Encoder noise: std added to the recorded joint readings, radians (metres for
    /// prismatic joints).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_encoder: f64,
    /// Measurement noise: std added to each coordinate of measured tips, metres.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_measure: f64,
    /// Orientation noise of measured poses (`measured_pose`): std of the measured
    /// rotation's error about each axis of the tool frame, radians.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_orientation: f64,
    /// Also write the true parameters used (a truth file for `--truth`) to this path.
    #[arg(long)]
    truth_out: Option<PathBuf>,
}

/// `simulate`: [`SimulateArgs`] as a [`SimulateRun`].
pub fn run(out: &mut dyn Write, args: &SimulateArgs, max_terms: usize) -> Result<()> {
    run_simulate(
        out,
        &SimulateRun {
            spec: &args.spec,
            poses: args.poses,
            seed: args.seed,
            truth: args.truth.as_deref(),
            noise: Noise {
                track: args.noise_track,
                encoder: args.noise_encoder,
                measure: args.noise_measure,
                orientation: args.noise_orientation,
            },
            truth_out: args.truth_out.as_deref(),
        },
        max_terms,
    )
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
    if run.poses == 0 || run.poses > MAX_POSES {
        return Err(Error::input(
            Location {
                field: Some("--poses".to_string()),
                ..Location::default()
            },
            format!(
                "{} poses asked: give 1 to {MAX_POSES} (about 20 s and 1.5 GB of CSV at the \
                 most; run several seeds for more)",
                run.poses
            ),
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
