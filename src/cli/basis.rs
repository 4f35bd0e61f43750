//! `lincal basis`: the symbolic result for a spec (basis, generalized parameters,
//! identifiability, gauge), no data needed.

use std::io::Write;
use std::path::PathBuf;

use lincal::error::Result;
use lincal::report;

use super::common::{load, write_json, write_text, Format};

/// The arguments of `basis`.
#[derive(clap::Args, Debug)]
pub struct BasisArgs {
    /// The spec (YAML).
    spec: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
}

/// `basis`: the symbolic result for a spec, as text or JSON.
pub fn run(out: &mut dyn Write, args: &BasisArgs, max_terms: usize) -> Result<()> {
    let (_, model) = load(&args.spec, max_terms)?;
    // Tables that fail their proof are an engine bug: an error, not a report.
    if let Some(Err(e)) = model.factored_certificate() {
        return Err(e);
    }
    match args.format {
        Format::Json => write_json(out, &report::basis_json(&model)),
        Format::Text => write_text(out, &report::basis_text(&model)),
    }
}
