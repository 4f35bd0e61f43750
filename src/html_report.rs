//! `calibrate --report OUT.html`: gathers what [`lincal::report::html::calibrate_html`] shows beyond
//! the estimate (residuals before and after, the worst poses' CSV lines, the input files'
//! hashes, the command line) and writes the file.

use std::path::{Path, PathBuf};

use lincal::calibrate::estimate::Estimate;
use lincal::data::Poses;
use lincal::error::Result;
use lincal::report::html::{calibrate_html, csv_lines, InputFile, Provenance, ReportData};
use lincal::report::CalibrateReport;
use lincal::spec::Spec;
use lincal::symbolic::SymbolicModel;

/// Refuses, before any work, a report path that cannot be written: a directory, or a file in
/// a directory that does not exist.
pub fn check_path(path: &Path) -> Result<()> {
    crate::outputs::check_writable("--report", path)
}

/// The command line as typed, each argument shell-quoted where needed, the program as
/// `lincal`.
fn command_line() -> String {
    let quote = |a: &str| {
        let plain = !a.is_empty()
            && a.chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
        if plain {
            a.to_string()
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    let mut parts = vec!["lincal".to_string()];
    parts.extend(
        std::env::args_os()
            .skip(1)
            .map(|a| quote(&a.to_string_lossy())),
    );
    parts.join(" ")
}

/// Writes the report of `est` (fitted to `poses`; the inputs' sizes and hashes in `files`,
/// the data read from `data_paths`) to `out`. The worst poses' CSV lines are quoted from a
/// single data file only (with several, a line number alone does not say which file), and
/// only from a regular file, read again: a pipe or FIFO cannot be, and a file that changed
/// since (its hash differs from the one fitted) shows none.
///
/// # Errors
/// The file cannot be written (exit 2, naming it).
pub fn write(
    out: &Path,
    model: &SymbolicModel,
    spec: &Spec,
    poses: &Poses,
    est: &Estimate,
    files: Vec<InputFile>,
    data_paths: &[PathBuf],
) -> Result<()> {
    let report = CalibrateReport::new(model, est);
    let mut data = ReportData::compute(model, spec, poses, est)?;
    let lines: Vec<usize> = est.worst_poses.iter().map(|w| w.line).collect();
    if let ([one], Some(fitted)) = (data_paths, files.iter().find(|f| f.role == "data")) {
        let regular = std::fs::metadata(one).is_ok_and(|m| m.is_file());
        let unchanged = || InputFile::hash("data", one).is_ok_and(|f| f.sha256 == fitted.sha256);
        if regular && unchanged() {
            data.worst_lines = csv_lines(one, &lines).unwrap_or_default();
        }
    }
    let prov = Provenance {
        command: command_line(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        files,
    };
    let html = calibrate_html(&report, &data, &prov);
    crate::outputs::write_atomic(out, html.as_bytes(), "report")
}
