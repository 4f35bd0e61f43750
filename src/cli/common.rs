//! What several subcommands share: the output format, the data files' options, writing to
//! stdout, loading a spec and its model, and writing output files whole.

use std::io::Write;
use std::path::Path;

use clap::ValueEnum;
use lincal::data::{Angles, DataLayout};
use lincal::error::{Error, ErrorClass, Location, Result};
use lincal::spec::{self, Spec};
use lincal::symbolic::SymbolicModel;

use crate::facts_cache::FactsCache;
use crate::{inputs, outputs, progress};

/// Output format of `basis` and `calibrate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A readable report.
    Text,
    /// One JSON object (the fields of `shared/interface.md`).
    Json,
}

/// The unit of revolute joint readings in data files (`--angles`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AnglesArg {
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
pub struct DataArgs {
    /// The unit of revolute joint readings: `rad`, `deg` (converted as read) or `auto`
    /// (radians; readings that look like degrees are refused, naming line and column).
    #[arg(long, value_enum, default_value_t = AnglesArg::Auto)]
    pub angles: AnglesArg,
    /// The files have no header row; their columns are given by `--columns`.
    #[arg(long, requires = "columns")]
    pub no_header: bool,
    /// The columns of headerless files, comma-separated (`q1,q2,q3,_time`).
    #[arg(long, requires = "no_header")]
    pub columns: Option<String>,
}

/// Whether an error is a closed stdout (`lincal simulate … | head`), which is not a failure.
pub fn is_broken_pipe(e: &Error) -> bool {
    e.class() == ErrorClass::Other && e.to_string().contains(BROKEN_PIPE_MARK)
}

pub const BROKEN_PIPE_MARK: &str = "(stdout closed)";

pub fn io_err(e: &std::io::Error) -> Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        Error::other(format!("cannot write the output {BROKEN_PIPE_MARK}"))
    } else {
        Error::other(format!("cannot write the output: {e}"))
    }
}

pub fn write_text(out: &mut dyn Write, text: &str) -> Result<()> {
    out.write_all(text.as_bytes()).map_err(|e| io_err(&e))
}

pub fn write_json(out: &mut dyn Write, v: &serde_json::Value) -> Result<()> {
    let s = serde_json::to_string_pretty(v)
        .map_err(|e| Error::other(format!("cannot format JSON: {e}")))?;
    write_text(out, &s)?;
    write_text(out, "\n")
}

/// Loads a spec and builds its symbolic model within `max_terms`.
pub fn load(path: &Path, max_terms: usize) -> Result<(Spec, SymbolicModel)> {
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
pub fn load_for_fitting(
    source: &inputs::SpecText,
    max_terms: usize,
) -> Result<(Spec, SymbolicModel, FactsCache)> {
    load_model(source, max_terms, false)
}

/// [`load_for_fitting`], with the basis half built ahead on another thread when `prefetch`
/// ([`SymbolicModel::for_fitting_prefetching`]): for `calibrate`, whose report gives `K`.
pub fn load_model(
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

/// The layout of the data files with the command line's `--angles --no-header --columns`,
/// and the URDF joint names of the spec's `urdf:` record (at `spec_path`) as other names of
/// the joint columns.
pub fn data_layout(
    mut layout: DataLayout,
    args: &DataArgs,
    source: &inputs::SpecText,
) -> Result<DataLayout> {
    layout.angles = match args.angles {
        AnglesArg::Rad => Angles::Rad,
        AnglesArg::Deg => Angles::Deg,
        AnglesArg::Auto => Angles::Auto,
    };
    if let Some(record) = source.urdf_record()? {
        layout.joint_names = record.clone().joint_names(layout.joints);
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

pub fn field(name: &str) -> Location {
    Location {
        field: Some(name.to_string()),
        ..Location::default()
    }
}

/// Writes an output file whole or not at all ([`outputs::write_atomic`]).
pub fn write_file(path: &Path, text: &str, what: &str) -> Result<()> {
    outputs::write_atomic(path, text.as_bytes(), what)
}

/// Largest URDF read (a URDF with inline meshes can be large; text only).
pub const MAX_URDF_BYTES: usize = 64 << 20;
