//! `lincal select`: the poses worth measuring ([`lincal::select::plan`]), as rows in the data
//! format on stdout, the summary on stderr (or one JSON object on stdout with `--format json`).

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;

use clap::ValueEnum;
use lincal::data::{DataLayout, Poses};
use lincal::error::{Error, Location, Result};
use lincal::select::plan::{plan, Candidates, Plan, PlanOptions};
use lincal::select::summary;
use lincal::simulate::Noise;

use super::calibrate::PriorArgs;
use super::common::{data_layout, io_err, load_for_fitting, write_json, DataArgs, Format};
use crate::inputs;

/// What `select` optimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CriterionArg {
    /// D-optimality: the most information about the free parameters (invariant to units and
    /// to the gauge).
    D,
    /// The least predicted tip error over the workspace.
    Tip,
}

/// The arguments of `select`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("pool_source").required(true).args(["candidates", "pool"])))]
pub struct SelectArgs {
    /// The spec (YAML).
    spec: PathBuf,
    /// How many poses to choose.
    #[arg(short = 'n', long = "count")]
    count: usize,
    /// The candidate poses (a CSV in the data format, reachable and collision-free by your
    /// own planner); rows off the nominal constraint are dropped and reported.
    #[arg(long)]
    candidates: Option<PathBuf>,
    /// Instead of candidates: this many poses projected onto the nominal constraint (1 to
    /// 10⁶).
    #[arg(long)]
    pool: Option<usize>,
    /// Seed of the pool, the parameter draws and the random baseline.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Poses already measured (data format, with measured tips where the spec measures):
    /// their information enters first.
    #[arg(long)]
    given: Option<PathBuf>,
    /// What to optimise.
    #[arg(long, value_enum, default_value_t = CriterionArg::D)]
    criterion: CriterionArg,
    /// Parameter draws around the nominals averaged into the criterion (0: nominals only; at
    /// most 100).
    #[arg(long, default_value_t = 3)]
    draws: usize,
    /// Standard deviation of a tip's distance from its constraint, metres.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_track: f64,
    /// Standard deviation of each coordinate of a measured tip, metres.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_measure: f64,
    /// Standard deviation of each joint reading (radians; metres on a prismatic joint), as
    /// `simulate` adds it: each pose's residual covariance gains `σ²·(∂g/∂q)(∂g/∂q)ᵀ`.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_encoder: f64,
    /// Standard deviation of a measured pose's orientation about each axis, radians
    /// (`measured_pose` specs).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    noise_orientation: f64,
    /// Candidates farther than this from their nominal constraint are dropped, metres.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    max_off: f64,
    /// Output: the chosen rows and a summary on stderr (`text`), or one JSON object.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// The weak-direction prior the calibration will use (as `calibrate`'s options): the
    /// plan counts what it already knows, so poses go where it does not.
    #[command(flatten)]
    prior: PriorArgs,
    #[command(flatten)]
    data: DataArgs,
}

fn field(name: &str, msg: String) -> Error {
    Error::input(
        Location {
            field: Some(name.to_string()),
            ..Location::default()
        },
        msg,
    )
}

/// The candidates' text, read once: its poses, and each line's span for the output.
struct CandidateFile {
    text: String,
    poses: Poses,
    /// Byte span of each line (without its end), lines ending as the data reader ends them:
    /// LF, CRLF or a bare CR, so the poses' line numbers index it.
    lines: Vec<(usize, usize)>,
    /// Read with `--no-header --columns`: its chosen rows are written without a header too,
    /// so they read back with the same options (its first line is a pose, not a header).
    headerless: bool,
}

impl CandidateFile {
    fn new(text: String, poses: Poses, headerless: bool) -> Self {
        let b = text.as_bytes();
        let (mut lines, mut start, mut i) = (Vec::new(), 0, 0);
        while i < b.len() {
            match b[i] {
                b'\n' => {
                    lines.push((start, i));
                    start = i + 1;
                }
                b'\r' => {
                    lines.push((start, i));
                    i += usize::from(b.get(i + 1) == Some(&b'\n'));
                    start = i + 1;
                }
                _ => {}
            }
            i += 1;
        }
        if start < b.len() {
            lines.push((start, b.len()));
        }
        CandidateFile {
            text,
            poses,
            lines,
            headerless,
        }
    }

    /// The text of 1-based line `n`.
    fn line(&self, n: usize) -> &str {
        n.checked_sub(1)
            .and_then(|k| self.lines.get(k))
            .map_or("", |&(a, b)| &self.text[a..b])
    }

    /// The header line (the first that is neither blank nor a `#` comment).
    fn header(&self) -> &str {
        (1..=self.lines.len())
            .map(|n| self.line(n))
            .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
            .unwrap_or("")
    }
}

/// Runs `select`.
///
/// # Errors
/// Bad arguments or inputs (exit 2); too few poses to see every free parameter (exit 1).
pub fn run(out: &mut dyn Write, args: &SelectArgs, max_terms: usize) -> Result<()> {
    let noise = Noise {
        track: args.noise_track,
        encoder: args.noise_encoder,
        measure: args.noise_measure,
        orientation: args.noise_orientation,
    };
    lincal::simulate::check_noise(noise)?;
    // The request's own bounds before the spec is read (and never blamed on a file).
    lincal::select::plan::check_noise_floor(noise)?;
    lincal::select::plan::check_sizes(args.pool, args.draws)?;
    if !(args.max_off.is_finite() && args.max_off > 0.0) {
        return Err(field(
            "--max-off",
            format!("{} is not a positive distance", args.max_off),
        ));
    }
    let spec_text = inputs::SpecText::read(&args.spec)?;
    let (spec, model, cache) = load_for_fitting(&spec_text, max_terms)?;
    cache.store(&model.facts());
    if args.noise_measure != 0.0 && !spec.is_measured() {
        let what = if args.noise_track > 0.0 {
            "has no effect (--noise-track is the residual σ)"
        } else {
            "is taken as the residual σ of every constraint (--noise-track is the level of a tip \
             held on a constraint)"
        };
        eprintln!("lincal: warning: --noise-measure {what}: the spec has no `measured` constraint");
    }
    let read = |path: &PathBuf, joints_only: bool| -> Result<CandidateFile> {
        let mut layout = data_layout(
            DataLayout::of_model(&model, spec.constraint_list),
            &args.data,
            &spec_text,
        )?;
        layout.joints_only = joints_only;
        let text = lincal::error::read_input_file(path, "data file", MAX_CANDIDATE_BYTES)?;
        let name = path.display().to_string();
        let poses = Poses::from_csv_reader_with(text.as_bytes(), Some(&name), &layout)?;
        let headerless = layout.columns.is_some();
        Ok(CandidateFile::new(text, poses, headerless))
    };
    let file = args
        .candidates
        .as_ref()
        .map(|p| read(p, true))
        .transpose()?;
    let given = args.given.as_ref().map(|p| read(p, false)).transpose()?;
    let candidates = match (&file, args.pool) {
        (Some(f), _) => Candidates::Given(f.poses.clone()),
        (None, Some(m)) => Candidates::Generated(m),
        (None, None) => return Err(field("--candidates", "give --candidates or --pool".into())),
    };
    let opts = PlanOptions {
        count: args.count,
        draws: args.draws,
        seed: args.seed,
        tip: args.criterion == CriterionArg::Tip,
        noise,
        max_off: args.max_off,
        prior: args.prior.choice()?,
    };
    let result = plan(
        &model,
        &spec,
        candidates,
        given.as_ref().map(|g| &g.poses),
        &opts,
    )
    .map_err(|e| match &args.candidates {
        Some(p) => e.in_file(&p.display().to_string()),
        None => e,
    })?;
    match args.format {
        Format::Json => write_json(
            out,
            &summary::plan_json(&result, &opts, args.candidates.is_some()),
        ),
        Format::Text => {
            write_rows(out, &model, spec.constraint_list, &result, file.as_ref())?;
            eprint!("{}", summary::plan_text(&result, &opts));
            Ok(())
        }
    }
}

/// Largest candidates or given file read (10⁵ rows of a 7-joint arm are about 15 MB).
const MAX_CANDIDATE_BYTES: usize = 256 << 20;

/// The chosen rows: the candidates' own lines under their header, or the generated poses.
fn write_rows(
    out: &mut dyn Write,
    model: &dyn lincal::CalibModel,
    constraint_list: bool,
    plan: &Plan,
    file: Option<&CandidateFile>,
) -> Result<()> {
    let mut text = String::new();
    match file {
        Some(f) => {
            if !f.headerless {
                let _ = writeln!(text, "{}", f.header());
            }
            for &i in &plan.chosen {
                let _ = writeln!(text, "{}", f.line(plan.pool.line.at(i)));
            }
        }
        None => {
            let mut buf = Vec::new();
            let measured = plan.pool.measured.is_some();
            let err = |e: std::io::Error| io_err(&e);
            lincal::simulate::write_csv_header(&mut buf, model, measured, constraint_list)
                .map_err(err)?;
            for &i in &plan.chosen {
                let m = plan.pool.measured.as_ref().map(|m| m.get(i).unwrap_or(&[]));
                let c = constraint_list.then(|| plan.pool.constraint.at(i));
                lincal::simulate::write_csv_row(&mut buf, model.dim(), &plan.pool.q[i], m, c)
                    .map_err(err)?;
            }
            text = String::from_utf8_lossy(&buf).into_owned();
        }
    }
    out.write_all(text.as_bytes()).map_err(|e| io_err(&e))
}
