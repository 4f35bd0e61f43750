//! `lincal compensate`: the joints that put the calibrated model's tool on each target, for a
//! controller that keeps its nominal model ([`lincal::lincal_core::compensate`]). Columns,
//! statuses and exit codes are `shared/interface.md`'s (third round).

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::calibrate::joint_ranges::BeyondRanges;
use lincal::data::{DataLayout, PoseColumn, Poses, Rows};
use lincal::error::{Error, Location, Result};
use lincal::lincal_core::compensate::{
    Compensator, Outcome, ParamCovariance, Status, Summary, Targets,
};
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
    /// tracker stood). Default `nominal`, with a warning when the calibrated `base:` moves
    /// the joint targets' tools by more than 1 cm.
    #[arg(long, value_enum)]
    intended_base: Option<IntendedBase>,
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
        None | Some(IntendedBase::Nominal) => c,
        Some(IntendedBase::Calibrated) => c.place_by_calibrated_base(),
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
    let beyond = beyond_found(&args.source, &spec, &outcomes, &line);
    // Only a calibration's `base:` can have moved (`--nominal` has none).
    let shift = args
        .source
        .params
        .as_ref()
        .filter(|_| !args.source.nominal && args.intended_base.is_none())
        .and_then(|_| c.base_shift_warning(&targets));
    if let Some(w) = &shift {
        eprintln!("lincal compensate: warning: {w}");
    }
    match args.format {
        Format::Text => {
            write_rows(out, &c, &outcomes)?;
            for l in summary.to_text().lines() {
                eprintln!("lincal compensate: {l}");
            }
        }
        Format::Json => {
            let mut json = summary.to_json();
            if let serde_json::Value::Object(map) = &mut json {
                if let Some(Ok(b)) = beyond.as_ref().map(serde_json::to_value) {
                    map.insert("beyond_ranges".into(), b);
                }
                map.insert(
                    "warnings".into(),
                    serde_json::json!(shift.iter().collect::<Vec<_>>()),
                );
            }
            write_json(out, &json)?;
        }
    }
    if summary.failed() > 0 && !args.allow_failed {
        let first = &summary.failures[0];
        let hint = if shift.is_some() && summary.counts[Status::Diverged as usize] > 0 {
            " (the calibrated `base:` moved the intended tools: see the warning above on \
             `--intended-base calibrated`)"
        } else {
            ""
        };
        return Err(Error::degenerate(format!(
            "{} of {} targets failed (first: {name}:{} {}){hint}; their rows are flagged in \
             the status column; --allow-failed exits 0",
            summary.failed(),
            summary.targets,
            first.line,
            first.status.as_str()
        )));
    }
    Ok(())
}

/// The joints found, against the ranges the calibration saw (`joint_ranges` of the result
/// file, said on stderr): beyond them the corrected model extrapolates. A row that did not
/// reach its target (`diverged`, `branch`) has no joints to send and is not judged.
fn beyond_found(
    source: &ParamsArgs,
    spec: &Spec,
    outcomes: &[Outcome],
    line: &dyn Fn(usize) -> usize,
) -> Option<BeyondRanges> {
    let reached: Vec<usize> = (0..outcomes.len())
        .filter(|&l| {
            !matches!(
                outcomes[l].verdict.status,
                Status::Diverged | Status::Branch
            )
        })
        .collect();
    let q = Rows::from_vec(
        spec.joints.len(),
        reached
            .iter()
            .flat_map(|&l| outcomes[l].q.iter().copied())
            .collect(),
    )?;
    let found = Poses {
        q,
        line: PoseColumn::labels_from(reached.iter().map(|&l| line(l))),
        ..Poses::default()
    };
    let mut beyond = source.beyond_ranges(spec, &found)?;
    // Numbered as the targets are, not among the rows that reached theirs.
    if let Some(f) = beyond.farthest.as_mut() {
        f.pose = reached.get(f.pose).copied().unwrap_or(f.pose);
    }
    if let Some(w) = lincal::calibrate::joint_ranges::beyond_warning(&beyond) {
        eprintln!("lincal: warning: {w}");
    }
    Some(beyond)
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
        return full_covariance(&cov, &est, &bad).map(ParamCovariance::Full);
    }
    let params = v.params.unwrap_or_default();
    let mut std = Vec::with_capacity(est.len());
    for p in &est {
        let s = params.get(&p.name).and_then(|s| s.std);
        if let Some(s) = s.filter(|s| !(s.is_finite() && (0.0..=MAX_STD).contains(s))) {
            return Err(bad(
                &format!("params.{}.std", p.name),
                format!("{s:e} is not a standard deviation from 0 to {MAX_STD:e}"),
            ));
        }
        std.push(s);
    }
    if !est.is_empty() && std.iter().all(Option::is_none) {
        eprintln!(
            "lincal compensate: {}: no standard deviation and no covariance: the sigma column \
             is 0 (no uncertainty known), not a zero uncertainty",
            path.display()
        );
    }
    Ok(ParamCovariance::from_std(&std))
}

/// The largest standard deviation a result file may state (metres or radians), as for values.
const MAX_STD: f64 = 1e9;

/// A result file's `covariance` over the spec's estimated parameters `est` (row-major,
/// `est.len()` square; parameters it leaves out have no variance), checked: every name an
/// estimated parameter of the spec and named once, a square matrix of finite numbers,
/// symmetric (to 10⁻⁹ of the entries' scale), its diagonal from 0 to `MAX_STD²`, and every
/// entry within the bound `|Σ_ab| ≤ √(Σ_aa Σ_bb)` every covariance holds.
fn full_covariance(
    cov: &ResultCovariance,
    est: &[&lincal::spec::Param],
    bad: &dyn Fn(&str, String) -> Error,
) -> Result<Vec<f64>> {
    let np = est.len();
    let mut index = Vec::with_capacity(cov.params.len());
    for (a, n) in cov.params.iter().enumerate() {
        let field = format!("covariance.params[{a}]");
        let Some(i) = est.iter().position(|p| &p.name == n) else {
            return Err(bad(
                &field,
                format!("`{n}` is not an estimated parameter of the spec"),
            ));
        };
        if index.contains(&i) {
            return Err(bad(&field, format!("`{n}` is named twice")));
        }
        index.push(i);
    }
    let k = cov.params.len();
    if cov.matrix.len() != k || cov.matrix.iter().any(|r| r.len() != k) {
        return Err(bad(
            "covariance.matrix",
            format!("expected {k} rows of {k} numbers"),
        ));
    }
    let m = |a: usize, b: usize| cov.matrix[a][b];
    for a in 0..k {
        let d = m(a, a);
        if !(d.is_finite() && (0.0..=MAX_STD * MAX_STD).contains(&d)) {
            return Err(bad(
                &format!("covariance.matrix[{a}][{a}]"),
                format!(
                    "the variance of `{}` is {d:e}: expected 0 to {:e}",
                    cov.params[a],
                    MAX_STD * MAX_STD
                ),
            ));
        }
    }
    let mut full = vec![0.0; np * np];
    for a in 0..k {
        for b in 0..k {
            let (x, y) = (m(a, b), m(b, a));
            let bound = (m(a, a) * m(b, b)).sqrt();
            let field = || format!("covariance.matrix[{a}][{b}]");
            if !x.is_finite() {
                return Err(bad(&field(), "expected finite numbers".into()));
            }
            if (x - y).abs() > 1e-9 * bound.max(x.abs()).max(y.abs()) {
                return Err(bad(
                    &field(),
                    format!("{x:e} against [{b}][{a}] {y:e}: the matrix is not symmetric"),
                ));
            }
            if x.abs() > bound * (1.0 + 1e-9) + f64::MIN_POSITIVE {
                return Err(bad(
                    &field(),
                    format!("{x:e} exceeds √(variance·variance) = {bound:e}: not a covariance"),
                ));
            }
            full[index[a] * np + index[b]] = x;
        }
    }
    Ok(full)
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
