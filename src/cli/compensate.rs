//! `lincal compensate`: the joints that put the calibrated model's tool on each target, for a
//! controller that keeps its nominal model ([`lincal::lincal_core::compensate`]). Columns,
//! statuses and exit codes are `shared/interface.md`'s (third round).

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::data::DataLayout;
use lincal::error::{Error, Location, Result};
use lincal::lincal_core::compensate::{Compensator, Outcome, ParamCovariance, Summary, Targets};
use lincal::spec::Spec;

use super::common::{data_layout, io_err, write_json, DataArgs, Format};
use super::result_file::{read_result_text, result_values, ParamsArgs};

/// The arguments of `compensate`.
#[derive(clap::Args, Debug)]
pub struct CompensateArgs {
    /// The spec (YAML).
    spec: PathBuf,
    #[command(flatten)]
    source: ParamsArgs,
    /// The targets: joints `q1..qn` alone (joint targets), or with `x,y,z` (and
    /// `qw,qx,qy,qz` or `rx,ry,rz`) as Cartesian targets with their seed joints.
    targets: PathBuf,
    #[command(flatten)]
    data_args: DataArgs,
    /// `text`: the rows on stdout, the summary on stderr; `json`: the summary as one JSON
    /// object on stdout, no rows.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    format: Format,
    /// Exit 0 even when some rows failed (they stay flagged in the status column).
    #[arg(long)]
    allow_failed: bool,
    /// Where a joint target's intended tool stands: `nominal` (the nominal model's, its
    /// `base:` included) or `calibrated` (the nominal arm placed by the calibrated `base:`:
    /// for a spec whose `base:` is a laser tracker's frame, whose nominal is not where the
    /// tracker stood).
    #[arg(long, value_enum, default_value_t = IntendedBase::Nominal)]
    intended_base: IntendedBase,
}

/// `compensate --intended-base`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum IntendedBase {
    /// The nominal model's tool, its `base:` included.
    Nominal,
    /// The nominal arm placed by the calibrated `base:`.
    Calibrated,
}

/// Largest targets file read (read whole, so that a pipe is read once).
const MAX_TARGETS_BYTES: usize = 1 << 30;

/// Runs `compensate`.
pub fn run(out: &mut dyn Write, args: &CompensateArgs) -> Result<()> {
    let spec_text = crate::inputs::SpecText::read(&args.spec)?;
    let spec = spec_text.spec()?;
    let (p, cov) = match (&args.source.params, args.source.nominal) {
        (None, _) | (_, true) => (nominals(&spec), ParamCovariance::None),
        (Some(path), false) => {
            let est = spec.estimated_params();
            (
                result_values(path, &spec, &est)?,
                result_covariance(path, &spec)?,
            )
        }
    };
    let c = Compensator::new(&spec, p, cov)?;
    let c = match args.intended_base {
        IntendedBase::Nominal => c,
        IntendedBase::Calibrated => c.place_by_calibrated_base(),
    };
    let layout = data_layout(DataLayout::of_spec(&spec), &args.data_args, &spec_text)?;
    let name = args.targets.display().to_string();
    let text = lincal::error::read_input_file(&args.targets, "targets file", MAX_TARGETS_BYTES)?;
    let targets = Targets::from_csv_text(&text, Some(&name), &layout, c.is_pose())?;
    drop(text);
    let outcomes = c.compensate_all(&targets);
    let line = |l: usize| targets.poses.line.at(l);
    check_finite(&outcomes, &line, &name)?;
    let summary = Summary::new(&outcomes, line);
    match args.format {
        Format::Text => {
            write_rows(out, &c, &outcomes)?;
            for l in summary.to_text().lines() {
                eprintln!("lincal compensate: {l}");
            }
        }
        Format::Json => write_json(out, &summary.to_json())?,
    }
    if summary.failed() > 0 && !args.allow_failed {
        let first = &summary.failures[0];
        return Err(Error::degenerate(format!(
            "{} of {} targets failed (first: {name}:{} {}); their rows are flagged in the \
             status column; --allow-failed exits 0",
            summary.failed(),
            summary.targets,
            first.line,
            first.status.as_str()
        )));
    }
    Ok(())
}

fn nominals(spec: &Spec) -> Vec<f64> {
    spec.estimated_params()
        .iter()
        .map(|p| p.nominal.to_f64())
        .collect()
}

/// What `compensate` reads of a result file beyond the values: each parameter's `std`, and
/// the full covariance when the file carries one (`covariance: {params, matrix}`).
#[derive(serde::Deserialize)]
struct ResultStd {
    params: Option<std::collections::BTreeMap<String, ParamStd>>,
    #[serde(default)]
    covariance: Option<ResultCovariance>,
}

#[derive(serde::Deserialize)]
struct ParamStd {
    #[serde(default)]
    std: Option<f64>,
}

#[derive(serde::Deserialize)]
struct ResultCovariance {
    params: Vec<String>,
    matrix: Vec<Vec<f64>>,
}

/// The estimate's covariance from the result file at `path` (already read once and checked
/// by [`result_values`]): the full matrix when present, the standard deviations otherwise.
fn result_covariance(path: &Path, spec: &Spec) -> Result<ParamCovariance> {
    let text = read_result_text(path)?;
    let bad = |f: &str, m: String| {
        Error::input(
            Location {
                file: Some(path.display().to_string()),
                field: Some(f.to_string()),
                ..Location::default()
            },
            m,
        )
    };
    let v: ResultStd = serde_json::from_str(&text).map_err(|e| {
        bad(
            "(json)",
            format!(
                "not a calibration result: {}",
                lincal::error::excerpt(&e.to_string())
            ),
        )
    })?;
    let est = spec.estimated_params();
    if let Some(cov) = v.covariance {
        let np = est.len();
        let index: Vec<Option<usize>> = cov
            .params
            .iter()
            .map(|n| est.iter().position(|p| &p.name == n))
            .collect();
        let k = cov.params.len();
        if cov.matrix.len() != k || cov.matrix.iter().any(|r| r.len() != k) {
            return Err(bad(
                "covariance.matrix",
                format!("expected {k} rows of {k} numbers"),
            ));
        }
        let mut full = vec![0.0; np * np];
        for (a, row) in cov.matrix.iter().enumerate() {
            for (b, &x) in row.iter().enumerate() {
                if !x.is_finite() {
                    return Err(bad("covariance.matrix", "expected finite numbers".into()));
                }
                if let (Some(i), Some(j)) = (index[a], index[b]) {
                    full[i * np + j] = x;
                }
            }
        }
        return Ok(ParamCovariance::Full(full));
    }
    let params = v.params.unwrap_or_default();
    let std: Vec<Option<f64>> = est
        .iter()
        .map(|p| params.get(&p.name).and_then(|s| s.std))
        .collect();
    Ok(ParamCovariance::from_std(&std))
}

/// No row carries a value that is not finite (none is expected: the solve keeps finite
/// points only); one would be refused naming its line rather than written as `NaN`.
fn check_finite(outcomes: &[Outcome], line: &dyn Fn(usize) -> usize, file: &str) -> Result<()> {
    for (l, o) in outcomes.iter().enumerate() {
        let values = o.q.iter().chain(&o.filtered.x).chain(&o.filtered.rot);
        let extra = [o.correction, o.residual, o.sigma];
        if values.chain(&extra).any(|v| !v.is_finite()) {
            return Err(Error::other(format!(
                "{file}:{}: the compensation of this target is not finite",
                line(l)
            )));
        }
    }
    Ok(())
}

/// The header and one row per target:
/// `q1..qn,x,y(,z)[,qw,qx,qy,qz],correction,residual,sigma,status`.
fn write_rows(out: &mut dyn Write, c: &Compensator, outcomes: &[Outcome]) -> Result<()> {
    let mut w = std::io::BufWriter::new(out);
    let mut header: Vec<String> = (1..=c.joints()).map(|i| format!("q{i}")).collect();
    header.extend(["x", "y", "z"][..c.dim()].iter().map(|s| s.to_string()));
    if c.is_pose() {
        header.extend(["qw", "qx", "qy", "qz"].iter().map(|s| s.to_string()));
    }
    header.extend(["correction", "residual", "sigma", "status"].map(String::from));
    writeln!(w, "{}", header.join(",")).map_err(|e| io_err(&e))?;
    let mut line = String::new();
    for o in outcomes {
        line.clear();
        let mut values: Vec<f64> = o.q.clone();
        values.extend_from_slice(&o.filtered.x[..c.dim()]);
        if c.is_pose() {
            let q = lincal::model::rotation::quaternion_from_matrix(&o.filtered.rot);
            values.extend_from_slice(&q);
        }
        values.extend([o.correction, o.residual, o.sigma]);
        for v in values {
            line.push_str(&format!("{v:?},"));
        }
        line.push_str(o.verdict.status.as_str());
        line.push('\n');
        w.write_all(line.as_bytes()).map_err(|e| io_err(&e))?;
    }
    w.flush().map_err(|e| io_err(&e))
}
