//! The HTML report of a calibration (`lincal calibrate … --report OUT.html`): one
//! self-contained file, plots as inline SVG drawn by plotters, no script, no stylesheet or
//! image from anywhere else.
//!
//! Sections, each a `<section>` with a fixed `id`:
//! - `summary`: poses, method, start, `K`, rank, the residual RMS before (nominal model) and
//!   after;
//! - `parameters`: every parameter's nominal, calibrated value, change, std, and whether it
//!   is identifiable, held by the gauge rule, or known;
//! - `gauge`: the directions the data cannot see, in words;
//! - `residuals`: the residual of every pose before and after (log scale);
//! - `histogram`: the histogram of both (log-spaced bins, every pose counted);
//! - `worst`: the poses farthest from the constraint (by standardised residual `z`, shown
//!   beside the residual) with their CSV lines;
//! - `tip-errors` (measured tips only): a 3-D scatter (2-D for planar arms) of the error
//!   vectors, calibrated tip minus measured tip;
//! - `identifiability`: the condition number and every warning, the practical-identifiability
//!   ones marked;
//! - `reproduce`: the command, the lincal version and the SHA-256 of every input file.
//!
//! All text from the user (names, warnings, CSV lines, paths, the command) is escaped. Plots
//! show at most [`MAX_PLOT_POINTS`] points per series (an even sample, the worst poses always
//! in) and say so in their caption; non-finite residuals are left out of the plots and
//! counted. No estimate makes the builder panic: zero poses, NaN residuals and a plot that
//! cannot be drawn give a sentence in place of the plot.
//!
//! # Example
//! ```
//! use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
//! use lincal_core::data::Poses;
//! use lincal_core::report::html::{calibrate_html, Provenance, ReportData};
//! use lincal_core::report::CalibrateReport;
//! let yaml = "name: two_link
//! dim: 2
//! joints:
//!   - {type: revolute, a: a1, home: th1}
//!   - {type: revolute, a: a2, home: th2}
//! params: {a1: {nominal: 0.375}, th1: {nominal: 0}, a2: {nominal: 0.4},
//!          th2: {nominal: 0}, b1: {nominal: -1.7}, b2: {nominal: -0.6}}
//! constraint: {line: {b: [b1, b2]}}
//! ";
//! let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
//! let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
//! let (a1, a2, th2, b1, b2) = (0.375_f64, 0.425_f64, 0.0446_f64, -1.79_f64, -0.56_f64);
//! let mut poses = Poses::default();
//! for i in 0..40 {
//!     let q2 = -2.0 + 0.1 * f64::from(i);
//!     let (wx, wy) = (a1 + a2 * (q2 - th2).cos(), a2 * (q2 - th2).sin());
//!     let c = -1.0 / (b1.hypot(b2) * wx.hypot(wy));
//!     if c.abs() < 1.0 {
//!         poses.q.push(&[c.acos() - wy.atan2(wx) + b2.atan2(b1), q2]);
//!         poses.constraint.push(0);
//!     }
//! }
//! let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
//! let data = ReportData::compute(&model, &spec, &poses, &est).unwrap();
//! let prov = Provenance {
//!     command: "lincal calibrate two_link.yaml data.csv --report r.html".to_string(),
//!     version: "0.1.0".to_string(),
//!     files: Vec::new(),
//! };
//! let html = calibrate_html(&CalibrateReport::new(&model, &est), &data, &prov);
//! assert!(html.contains(r#"<section id="parameters">"#));
//! assert!(!html.contains("<script"));
//! ```

use std::error::Error as StdError;
use std::fmt::Write as _;
use std::io::{BufRead, Read};
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use sha2::{Digest, Sha256};

use crate::calibrate::estimate::Estimate;
use crate::calibrate::{pose_residuals, SpecParam};
use crate::data::Poses;
use crate::error::Result;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::report::CalibrateReport;
use crate::spec::Spec;
use crate::symbolic::SymbolicModel;

/// Most points a plot shows per series; beyond it an even sample (plus the worst poses) is
/// drawn and the caption says so.
pub const MAX_PLOT_POINTS: usize = 20_000;

/// Bins of the residual histogram.
const BINS: usize = 40;

/// The section ids of a report, in order (`tip-errors` only for measured tips).
pub const SECTIONS: [&str; 9] = [
    "summary",
    "parameters",
    "gauge",
    "residuals",
    "histogram",
    "worst",
    "tip-errors",
    "identifiability",
    "reproduce",
];

/// One input file of a run, identified for reproducibility.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputFile {
    /// What it is (`spec`, `data`).
    pub role: String,
    /// The path as given on the command line.
    pub path: String,
    /// Its size in bytes.
    pub bytes: u64,
    /// SHA-256 of its content, lower-case hex.
    pub sha256: String,
}

impl InputFile {
    /// Reads `path` (streamed) and hashes it.
    ///
    /// # Errors
    /// The file cannot be read.
    pub fn hash(role: &str, path: &Path) -> std::io::Result<InputFile> {
        let mut file = std::fs::File::open(path)?;
        let mut hasher = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = file.read(&mut buf)?;
            if n == 0 {
                break;
            }
            bytes += n as u64;
            hasher.update(&buf[..n]);
        }
        let digest = hasher.finalize();
        let mut sha256 = String::with_capacity(64);
        for b in digest.iter() {
            let _ = write!(sha256, "{b:02x}");
        }
        Ok(InputFile {
            role: role.to_string(),
            path: path.display().to_string(),
            bytes,
            sha256,
        })
    }
}

/// How the report was made: what a reader needs to run it again.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Provenance {
    /// The command line, as typed (shell-quoted where needed).
    pub command: String,
    /// The lincal version that made the report.
    pub version: String,
    /// The input files with their hashes.
    pub files: Vec<InputFile>,
}

/// The calibrated tip minus the measured tip of every pose on a `measured` constraint.
#[derive(Clone, Debug, PartialEq)]
pub struct TipErrors {
    /// 2 or 3 components a pose.
    pub dim: usize,
    /// The poses (0-based, of the data as given) with a measured tip.
    pub poses: Vec<usize>,
    /// Their error vectors, `dim` numbers a pose, metres.
    pub errors: Vec<f64>,
}

/// What the report shows beyond the [`CalibrateReport`]: the nominals, the gauge, every
/// pose's residual before and after, the measured tips' errors, the worst poses' CSV lines.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportData {
    /// Every parameter of the spec with its nominal value, spec order.
    pub nominal: Vec<(String, f64)>,
    /// The gauge directions, `{param: coefficient}` each (see
    /// [`SymbolicModel::gauge`]).
    pub gauge: Vec<Vec<(String, f64)>>,
    /// The constraint kinds, by name (`line`, `measured`, …).
    pub constraints: Vec<String>,
    /// Each pose's distance from its constraint with the nominal parameters, metres.
    pub before: Vec<f64>,
    /// Each pose's distance from its constraint with the calibrated parameters, metres.
    pub after: Vec<f64>,
    /// The error vectors of the measured tips, when the spec has a `measured` constraint.
    pub tip_errors: Option<TipErrors>,
    /// The CSV text of the worst poses' lines: `(line number, text)`; empty when the poses
    /// were not read from a file (see [`csv_lines`]).
    pub worst_lines: Vec<(usize, String)>,
}

impl ReportData {
    /// Computes the residuals before (at the spec's nominals) and after (at `est`), and the
    /// measured tips' errors, for `poses` (the poses `est` was fitted to, as given: after
    /// `--reject-outliers` the dropped ones included). `worst_lines` is left empty.
    ///
    /// # Errors
    /// Poses that do not fit the model (a constraint index out of range).
    pub fn compute(
        model: &SymbolicModel,
        spec: &Spec,
        poses: &Poses,
        est: &Estimate,
    ) -> Result<ReportData> {
        let params = SpecParam::list(spec);
        let nominal_p: Vec<f64> = params
            .iter()
            .filter(|p| !p.known)
            .map(|p| p.nominal)
            .collect();
        let fitted_p: Vec<f64> = est
            .params
            .iter()
            .filter(|p| !p.known)
            .map(|p| p.value)
            .collect();
        let before = pose_residuals(model, poses, &nominal_p)?;
        let after = pose_residuals(model, poses, &fitted_p)?;
        let tip_errors = tip_errors(model, poses, &fitted_p);
        Ok(ReportData {
            nominal: params.iter().map(|p| (p.name.clone(), p.nominal)).collect(),
            gauge: model.gauge(),
            constraints: spec
                .constraints
                .iter()
                .map(|c| c.kind_name().to_string())
                .collect(),
            before,
            after,
            tip_errors,
            worst_lines: Vec::new(),
        })
    }
}

/// Calibrated tip minus measured tip for every pose on a measured constraint; `None` when
/// there is none.
fn tip_errors(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Option<TipErrors> {
    let measured = poses.measured.as_ref()?;
    let dim = model.dim();
    let mut out = TipErrors {
        dim,
        poses: Vec::new(),
        errors: Vec::new(),
    };
    let mut tip = vec![0.0; dim];
    for (l, q) in poses.q.iter().enumerate() {
        let on_measured = poses.constraint.get(l).is_some_and(|j| {
            j < model.constraint_count() && model.constraint_kind(j) == ConstraintKind::Measured
        });
        let Some(m) = measured.get(l).filter(|m| m.len() >= dim) else {
            continue;
        };
        if !on_measured {
            continue;
        }
        model.tip(q, p, &mut tip);
        out.poses.push(l);
        out.errors.extend(tip.iter().zip(m).map(|(t, x)| t - x));
    }
    (!out.poses.is_empty()).then_some(out)
}

/// The text of the given 1-based lines of a file (each line at most once, in file order),
/// read in one streamed pass that stops after the last wanted line.
///
/// # Errors
/// The file cannot be read.
pub fn csv_lines(path: &Path, wanted: &[usize]) -> std::io::Result<Vec<(usize, String)>> {
    let mut want: Vec<usize> = wanted.iter().copied().filter(|&l| l > 0).collect();
    want.sort_unstable();
    want.dedup();
    let Some(&last) = want.last() else {
        return Ok(Vec::new());
    };
    let mut reader = std::io::BufReader::new(std::fs::File::open(path)?);
    let mut out = Vec::with_capacity(want.len());
    let mut buf = Vec::new();
    let mut line = 0;
    while line < last {
        buf.clear();
        if reader.read_until(b'\n', &mut buf)? == 0 {
            break;
        }
        line += 1;
        if want.binary_search(&line).is_ok() {
            let text = String::from_utf8_lossy(&buf);
            out.push((line, text.trim_end_matches(['\r', '\n']).to_string()));
        }
    }
    Ok(out)
}

/// `s` with the characters HTML gives a meaning escaped.
#[must_use]
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// A number for a table: about 10 significant digits, `—` when not finite.
fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return "—".to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-4..1e6).contains(&a) {
        let digits = (9 - a.log10().floor() as i32).clamp(0, 15) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.6e}")
    }
}

/// A short number (4 significant digits), `—` when not finite.
fn fmt_short(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "—".to_string()
    }
}

/// An axis tick: at most 3 decimals, trailing zeros dropped.
fn tick(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// A length with a readable unit (`12.3 µm`), `—` when not finite.
fn fmt_len(v: f64) -> String {
    if !v.is_finite() {
        return "—".to_string();
    }
    let (f, u) = unit(v.abs());
    format!("{:.4} {u}", v * f)
}

/// Factor and unit to show lengths of about `m` metres.
fn unit(m: f64) -> (f64, &'static str) {
    if !(m.is_finite() && m > 0.0) || m >= 1.0 {
        (1.0, "m")
    } else if m >= 1e-3 {
        (1e3, "mm")
    } else if m >= 1e-6 {
        (1e6, "µm")
    } else {
        (1e9, "nm")
    }
}

/// RMS of the finite values and how many were not finite.
fn rms(v: &[f64]) -> (f64, usize) {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if finite.is_empty() {
        return (f64::NAN, v.len());
    }
    let s: f64 = finite.iter().map(|x| x * x).sum();
    ((s / finite.len() as f64).sqrt(), v.len() - finite.len())
}

/// The indices to plot of `n` values: all of them, or every `stride`-th plus `always`; and
/// the stride (1 when all are shown).
fn sample(n: usize, always: &[usize]) -> (Vec<usize>, usize) {
    if n <= MAX_PLOT_POINTS {
        return ((0..n).collect(), 1);
    }
    let stride = n.div_ceil(MAX_PLOT_POINTS);
    let mut idx: Vec<usize> = (0..n).step_by(stride).collect();
    idx.extend(always.iter().copied().filter(|&l| l < n));
    idx.sort_unstable();
    idx.dedup();
    (idx, stride)
}

/// The sentence of a caption about sampling.
fn sampling_note(n: usize, shown: usize, stride: usize) -> String {
    if stride <= 1 {
        format!("All {n} poses shown.")
    } else {
        format!(
            "{n} poses: every {stride}th pose is shown ({shown} points, the worst poses \
             included), at most {MAX_PLOT_POINTS} per series."
        )
    }
}

type DrawResult = std::result::Result<(), Box<dyn StdError>>;

/// Every chart's mesh alike: the axis titles, a faint grid, the report's fonts. The caller
/// adds its tick formatters and draws.
fn house_mesh<'a, 'b, 'm, X, Y, XT, YT, DB>(
    mesh: &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB>,
    x_desc: impl Into<String>,
    y_desc: impl Into<String>,
) -> &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB>
where
    X: plotters::coord::ranged1d::Ranged<ValueType = XT>
        + plotters::coord::ranged1d::ValueFormatter<XT>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = YT>
        + plotters::coord::ranged1d::ValueFormatter<YT>,
    DB: DrawingBackend,
{
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .light_line_style(BLACK.mix(0.05))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
}

/// Draws into an SVG of `size` with `draw`; the SVG text, or the reason it could not be drawn.
fn svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult,
) -> std::result::Result<String, String> {
    let mut out = String::new();
    let result = {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE)
            .map_err(|e| -> Box<dyn StdError> { Box::new(e) })
            .and_then(|()| draw(&root))
            .and_then(|()| {
                root.present()
                    .map_err(|e| -> Box<dyn StdError> { Box::new(e) })
            })
    };
    match result {
        Ok(()) => Ok(out),
        Err(e) => Err(e.to_string()),
    }
}

const BEFORE: RGBColor = RGBColor(230, 120, 30);
const AFTER: RGBColor = RGBColor(30, 100, 200);

/// Lower and upper end of a log axis holding the positive finite values of `sets` (zeros
/// and smaller values are drawn at the lower end); `None` when there is no finite value.
fn log_range(sets: &[&[f64]]) -> Option<(f64, f64)> {
    let mut hi = f64::NEG_INFINITY;
    let mut lo = f64::INFINITY;
    for v in sets.iter().flat_map(|s| s.iter()) {
        if v.is_finite() {
            hi = hi.max(*v);
            if *v > 0.0 {
                lo = lo.min(*v);
            }
        }
    }
    if !hi.is_finite() {
        return None;
    }
    if hi <= 0.0 {
        // Every residual is exactly zero.
        return Some((1e-12, 1e-9));
    }
    let lo = lo.max(hi * 1e-12);
    let lo = 10f64.powf(lo.log10().floor());
    let hi = 10f64.powf(hi.log10().ceil()).max(lo * 10.0);
    Some((lo, hi))
}

/// The residual-per-pose plot and its caption.
fn residual_plot(
    data: &ReportData,
    worst: &[usize],
) -> (std::result::Result<String, String>, String) {
    let n = data.before.len().max(data.after.len());
    if n == 0 {
        return (Err("no poses".to_string()), String::new());
    }
    let Some((lo, hi)) = log_range(&[&data.before, &data.after]) else {
        return (Err("no finite residual to plot".to_string()), String::new());
    };
    let (idx, stride) = sample(n, worst);
    let (_, bad_before) = rms(&data.before);
    let (_, bad_after) = rms(&data.after);
    let mut caption = format!(
        "Distance of each pose's tip from its constraint, with the nominal parameters (orange) \
         and the calibrated ones (blue), log scale. {}",
        sampling_note(n, idx.len(), stride)
    );
    if bad_before + bad_after > 0 {
        let _ = write!(
            caption,
            " Non-finite residuals left out: {bad_before} before, {bad_after} after."
        );
    }
    if lo > 0.0 && (data.before.iter().chain(&data.after)).any(|&v| v.is_finite() && v < lo) {
        let _ = write!(
            caption,
            " Residuals below {lo:.0e} m are drawn at {lo:.0e} m."
        );
    }
    let points = |v: &[f64]| -> Vec<(f64, f64)> {
        idx.iter()
            .filter_map(|&l| v.get(l).map(|&r| (l as f64, r)))
            .filter(|(_, r)| r.is_finite())
            .map(|(l, r)| (l, r.max(lo)))
            .collect()
    };
    let before = points(&data.before);
    let after = points(&data.after);
    let plot = svg((960, 380), |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            // A decade on top for the legend.
            .build_cartesian_2d(0f64..(n as f64).max(1.0), (lo..hi * 10.0).log_scale())?;
        let (fx, fy) = (|v: &f64| format!("{v:.0}"), |v: &f64| format!("{v:.0e}"));
        house_mesh(
            &mut chart.configure_mesh(),
            "pose (0-based)",
            "residual (m)",
        )
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .draw()?;
        for (pts, color, label) in [
            (&before, BEFORE, "before (nominal)"),
            (&after, AFTER, "after (calibrated)"),
        ] {
            chart
                .draw_series(
                    pts.iter()
                        .map(|&p| Circle::new(p, 2, color.mix(0.55).filled())),
                )?
                .label(label)
                .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 14))
            .draw()?;
        Ok(())
    });
    (plot, caption)
}

/// Counts of `v` in `bins` log-spaced bins from `lo` to `hi` (values below `lo` in the
/// first, non-finite ones left out).
fn histogram(v: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut counts = vec![0; bins];
    let (a, b) = (lo.log10(), hi.log10());
    let width = (b - a) / bins as f64;
    for &x in v {
        if !x.is_finite() {
            continue;
        }
        let t = ((x.max(lo).log10() - a) / width).floor();
        let k = if t.is_finite() && t > 0.0 {
            (t as usize).min(bins - 1)
        } else {
            0
        };
        counts[k] += 1;
    }
    counts
}

/// The histogram plot and its caption.
fn histogram_plot(data: &ReportData) -> (std::result::Result<String, String>, String) {
    let n = data.before.len().max(data.after.len());
    if n == 0 {
        return (Err("no poses".to_string()), String::new());
    }
    let Some((lo, hi)) = log_range(&[&data.before, &data.after]) else {
        return (Err("no finite residual to plot".to_string()), String::new());
    };
    let hb = histogram(&data.before, lo, hi, BINS);
    let ha = histogram(&data.after, lo, hi, BINS);
    let top = hb.iter().chain(&ha).copied().max().unwrap_or(1).max(1);
    let caption = format!(
        "How many poses have each residual, before (orange) and after (blue) calibration: \
         {BINS} log-spaced bins from {lo:.0e} m to {hi:.0e} m, every pose counted ({n} poses)."
    );
    let edges: Vec<f64> = (0..=BINS)
        .map(|k| 10f64.powf(lo.log10() + (hi.log10() - lo.log10()) * k as f64 / BINS as f64))
        .collect();
    let plot =
        svg((960, 340), |root| {
            let mut chart = ChartBuilder::on(root)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d((lo..hi).log_scale(), 0f64..(top as f64 * 1.3))?;
            let (fx, fy) = (|v: &f64| format!("{v:.0e}"), |v: &f64| format!("{v:.0}"));
            house_mesh(&mut chart.configure_mesh(), "residual (m)", "poses")
                .x_label_formatter(&fx)
                .y_label_formatter(&fy)
                .draw()?;
            for (counts, color, label) in [
                (&hb, BEFORE, "before (nominal)"),
                (&ha, AFTER, "after (calibrated)"),
            ] {
                chart
                    .draw_series(counts.iter().enumerate().filter(|(_, &c)| c > 0).map(
                        |(k, &c)| {
                            Rectangle::new(
                                [(edges[k], 0.0), (edges[k + 1], c as f64)],
                                color.mix(0.55).filled(),
                            )
                        },
                    ))?
                    .label(label)
                    .legend(move |(x, y)| {
                        Rectangle::new([(x - 5, y - 5), (x + 5, y + 5)], color.filled())
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font(("sans-serif", 14))
                .draw()?;
            Ok(())
        });
    (plot, caption)
}

/// The measured tips' error scatter and its caption.
fn tip_error_plot(t: &TipErrors, worst: &[usize]) -> (std::result::Result<String, String>, String) {
    let dim = t.dim.clamp(2, 3);
    let n = t.poses.len();
    let vec = |i: usize| -> [f64; 3] {
        let mut e = [0.0; 3];
        for (k, v) in e.iter_mut().enumerate().take(dim) {
            *v = t.errors.get(i * t.dim + k).copied().unwrap_or(f64::NAN);
        }
        e
    };
    // The worst poses, as positions in `t.poses`.
    let worst_pos: Vec<usize> = worst
        .iter()
        .filter_map(|w| t.poses.binary_search(w).ok())
        .collect();
    let (idx, stride) = sample(n, &worst_pos);
    let pts: Vec<[f64; 3]> = idx
        .iter()
        .map(|&i| vec(i))
        .filter(|e| e.iter().all(|v| v.is_finite()))
        .collect();
    let left_out = idx.len() - pts.len();
    let r = pts
        .iter()
        .flat_map(|e| e.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let (f, u) = unit(r);
    let r = if r > 0.0 { r * f * 1.1 } else { 1.0 };
    let mut caption = format!(
        "Error of each measured tip, calibrated tip minus measured tip, in {u}{}. {}",
        if dim == 3 {
            " (a 3-D scatter seen obliquely; the axes are equal)"
        } else {
            " (equal axes)"
        },
        sampling_note(n, idx.len(), stride)
    );
    if left_out > 0 {
        let _ = write!(caption, " {left_out} non-finite errors left out.");
    }
    let style = AFTER.mix(0.55).filled();
    let plot = if dim == 3 {
        svg((720, 560), |root| {
            let mut chart =
                ChartBuilder::on(root)
                    .margin(20)
                    .build_cartesian_3d(-r..r, -r..r, -r..r)?;
            chart.with_projection(|mut pb| {
                pb.yaw = 0.6;
                pb.pitch = 0.35;
                pb.scale = 0.85;
                pb.into_matrix()
            });
            chart
                .configure_axes()
                .light_grid_style(BLACK.mix(0.08))
                .max_light_lines(3)
                .label_style(("sans-serif", 13))
                .x_formatter(&|v| tick(*v))
                .y_formatter(&|v| tick(*v))
                .z_formatter(&|v| tick(*v))
                .draw()?;
            // Plotters' vertical axis is its y: show the error's z upward.
            chart.draw_series(
                pts.iter()
                    .map(|e| Circle::new((e[0] * f, e[2] * f, e[1] * f), 2, style)),
            )?;
            let label = ("sans-serif", 16).into_font().color(&BLACK);
            chart.draw_series([
                Text::new(format!("x ({u})"), (r, -r, -r), label.clone()),
                Text::new(format!("z ({u})"), (-r, r, -r), label.clone()),
                Text::new(format!("y ({u})"), (-r, -r, r), label),
            ])?;
            Ok(())
        })
    } else {
        svg((560, 520), |root| {
            let mut chart = ChartBuilder::on(root)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(-r..r, -r..r)?;
            let ticks = |v: &f64| tick(*v);
            house_mesh(
                &mut chart.configure_mesh(),
                format!("x error ({u})"),
                format!("y error ({u})"),
            )
            .x_label_formatter(&ticks)
            .y_label_formatter(&ticks)
            .draw()?;
            chart.draw_series(
                pts.iter()
                    .map(|e| Circle::new((e[0] * f, e[1] * f), 2, style)),
            )?;
            Ok(())
        })
    };
    (plot, caption)
}

/// A figure: the SVG or the reason there is none, and the caption.
fn figure(s: &mut String, plot: std::result::Result<String, String>, caption: &str) {
    s.push_str("<figure>\n");
    match plot {
        Ok(svg) => {
            s.push_str(&svg);
            s.push('\n');
        }
        Err(why) => {
            let _ = writeln!(s, "<p class=\"none\">No plot: {}.</p>", escape(&why));
        }
    }
    if !caption.is_empty() {
        let _ = writeln!(s, "<figcaption>{}</figcaption>", escape(caption));
    }
    s.push_str("</figure>\n");
}

/// A gauge direction in words.
fn gauge_words(g: &[(String, f64)], report: &CalibrateReport, nominal: &[(String, f64)]) -> String {
    let held = |name: &str| report.params.0.iter().any(|(n, p)| n == name && p.held);
    // The parameter the direction moves by 1 and the rule holds, if any.
    let lead = g
        .iter()
        .find(|(n, c)| (c - 1.0).abs() < 1e-12 && held(n))
        .or_else(|| g.first());
    let Some((lead, lead_c)) = lead else {
        return "an empty direction".to_string();
    };
    let amount = |c: f64| {
        if (c - 1.0).abs() < 1e-12 {
            "t".to_string()
        } else if (c + 1.0).abs() < 1e-12 {
            "−t".to_string()
        } else {
            format!("{}·t", fmt_num(c).replace('-', "−"))
        }
    };
    let others: Vec<String> = g
        .iter()
        .filter(|(n, _)| n != lead)
        .map(|(n, c)| format!("<code>{}</code> by {}", escape(n), amount(*c)))
        .collect();
    let mut s = format!(
        "Changing <code>{}</code> by {}",
        escape(lead),
        amount(*lead_c)
    );
    if others.is_empty() {
        s.push_str(" alone");
    } else {
        let _ = write!(s, " together with {}", others.join(", "));
    }
    s.push_str(
        " (for any small t) moves no tip off its constraint: the data cannot tell these values \
         apart.",
    );
    if held(lead) {
        let nom = nominal
            .iter()
            .find(|(n, _)| n == lead)
            .map_or(f64::NAN, |(_, v)| *v);
        let _ = write!(
            s,
            " The gauge rule holds <code>{}</code> at its nominal ({}); the other parameters of \
             this direction are calibrated relative to it.",
            escape(lead),
            fmt_num(nom)
        );
    }
    s
}

/// Whether a warning is about practical identifiability.
fn is_practical(w: &str) -> bool {
    w.contains("practically unidentifiable")
}

const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; color: #1b1f24;
       max-width: 1000px; margin: 0 auto; padding: 16px 24px 48px; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #d0d7de; padding-bottom: 4px; margin-top: 1.8em; }
nav a { margin-right: 0.9em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
th, td { border: 1px solid #d0d7de; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f3f5f7; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: ui-monospace, monospace; }
code, pre { font-family: ui-monospace, 'DejaVu Sans Mono', monospace; font-size: 0.9em; }
pre { background: #f6f8fa; padding: 8px; overflow-x: auto; white-space: pre-wrap; word-break: break-all; }
figure { margin: 0.5em 0; }
figure svg { max-width: 100%; height: auto; display: block; }
figcaption { color: #57606a; font-size: 0.9em; }
.yes { color: #1a7f37; } .no { color: #8c959f; } .held { color: #9a6700; }
.warn { background: #fff8c5; border-left: 4px solid #d4a72c; padding: 4px 8px; margin: 4px 0; }
.warn.practical { background: #ffebe9; border-left-color: #cf222e; }
.none { color: #57606a; font-style: italic; }
.big { font-size: 1.15em; }
";

/// The report as one HTML document (see the module docs).
#[must_use]
pub fn calibrate_html(report: &CalibrateReport, data: &ReportData, prov: &Provenance) -> String {
    let mut s = String::with_capacity(256 * 1024);
    let name = escape(&report.name);
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"lincal {}\">\n\
         <title>lincal calibration report: {name}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(&prov.version)
    );
    let (rms_before, _) = rms(&data.before);
    let (rms_after, _) = rms(&data.after);
    let _ = writeln!(
        s,
        "<header>\n<h1>Calibration report: {name}</h1>\n<p class=\"big\">{} poses on {} — \
         residual RMS {} with the nominal parameters, <strong>{}</strong> calibrated \
         (method <code>{}</code>).</p>\n</header>",
        report.poses,
        escape(&data.constraints.join(", ")),
        fmt_len(rms_before),
        fmt_len(report.residual_rms.unwrap_or(rms_after)),
        escape(&report.method)
    );
    let has_tips = data.tip_errors.is_some();
    s.push_str("<nav>");
    for (id, title) in [
        ("summary", "Summary"),
        ("parameters", "Parameters"),
        ("gauge", "Gauge"),
        ("residuals", "Residuals"),
        ("histogram", "Histogram"),
        ("worst", "Worst poses"),
        ("tip-errors", "Tip errors"),
        ("identifiability", "Identifiability"),
        ("reproduce", "Reproduce"),
    ] {
        if id != "tip-errors" || has_tips {
            let _ = write!(s, "<a href=\"#{id}\">{title}</a>");
        }
    }
    s.push_str("</nav>\n");

    // Summary.
    s.push_str("<section id=\"summary\">\n<h2>Summary</h2>\n<table>\n");
    let row = |s: &mut String, k: &str, v: String| {
        let _ = writeln!(s, "<tr><th>{k}</th><td>{v}</td></tr>");
    };
    row(&mut s, "poses", report.poses.to_string());
    row(
        &mut s,
        "constraint(s)",
        escape(&data.constraints.join(", ")),
    );
    row(
        &mut s,
        "method",
        format!("<code>{}</code>", escape(&report.method)),
    );
    row(
        &mut s,
        "start",
        if report.start == "linear" {
            format!(
                "the linear method (no initial guess), on {} poses",
                report.linear_poses
            )
        } else {
            "the nominals".to_string()
        },
    );
    row(
        &mut s,
        "basis size K, rank",
        format!("{}, {}", report.basis_size, report.rank),
    );
    row(
        &mut s,
        "identifiable combinations",
        report.identifiable_count.to_string(),
    );
    row(&mut s, "residual RMS before (nominal)", fmt_len(rms_before));
    row(
        &mut s,
        "residual RMS after (calibrated)",
        fmt_len(report.residual_rms.unwrap_or(f64::NAN)),
    );
    if rms_before.is_finite() && rms_after > 0.0 {
        row(
            &mut s,
            "improvement",
            format!("{:.3}×", rms_before / rms_after),
        );
    }
    row(
        &mut s,
        "robust scale σ",
        fmt_len(report.robust_scale.unwrap_or(f64::NAN)),
    );
    if let Some(e) = report.paper_err_rms {
        row(&mut s, "paper's err_rms (sec. 5)", fmt_len(e));
    }
    if let Some(r) = &report.robust {
        row(
            &mut s,
            "robust fit",
            format!(
                "{} loss, c = {}; linear solve reweighted {} rounds ({} below ½); \
                 parameter-space fit {} rounds; {} poses down-weighted",
                escape(&r.loss),
                r.tuning.map_or("—".to_string(), fmt_num),
                r.linear_rounds,
                r.linear_downweighted,
                r.rounds,
                r.downweighted
            ),
        );
    }
    if !report.rejected.is_empty() {
        row(
            &mut s,
            "rejected outliers",
            format!("{} poses (listed under warnings)", report.rejected.len()),
        );
    }
    s.push_str("</table>\n</section>\n");

    // Parameters.
    s.push_str(
        "<section id=\"parameters\">\n<h2>Parameters</h2>\n<table>\n<tr><th>parameter</th>\
         <th>nominal</th><th>calibrated</th><th>change</th><th>std</th><th>identifiable</th>\
         <th>held</th><th>known</th></tr>\n",
    );
    for (pname, p) in &report.params.0 {
        let nom = data
            .nominal
            .iter()
            .find(|(n, _)| n == pname)
            .map_or(f64::NAN, |(_, v)| *v);
        let value = p.value.unwrap_or(f64::NAN);
        let flag = |b: bool, cls: &str| {
            if b {
                format!("<td class=\"{cls}\">yes</td>")
            } else {
                "<td class=\"no\">no</td>".to_string()
            }
        };
        let _ = writeln!(
            s,
            "<tr><td><code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{}</td><td class=\"num\">{}</td>{}{}{}</tr>",
            escape(pname),
            fmt_num(nom),
            fmt_num(value),
            fmt_short(value - nom),
            p.std.map_or("—".to_string(), fmt_short),
            flag(p.identifiable, "yes"),
            flag(p.held, "held"),
            flag(p.known, "held"),
        );
    }
    s.push_str(
        "</table>\n<p>Lengths in metres, angles in radians. <em>Held</em>: kept at the nominal \
         by the gauge rule (see below); <em>known</em>: fixed by the spec; neither has a std.</p>\n\
         </section>\n",
    );

    // Gauge.
    s.push_str("<section id=\"gauge\">\n<h2>Gauge directions</h2>\n");
    if data.gauge.is_empty() {
        s.push_str(
            "<p>None: the constraint determines every estimated parameter on its own.</p>\n",
        );
    } else {
        let _ = writeln!(
            s,
            "<p>The constraint determines {} independent combination(s) of the parameters; {} \
             direction(s) of parameter change leave every pose exactly as far from its \
             constraint (at the nominals):</p>\n<ol>",
            report.identifiable_count,
            data.gauge.len()
        );
        for g in &data.gauge {
            let _ = writeln!(s, "<li>{}</li>", gauge_words(g, report, &data.nominal));
        }
        s.push_str("</ol>\n");
    }
    s.push_str("</section>\n");

    // A list's constraints one by one, and the relations (only when there are).
    if !report.constraints.is_empty() || !report.relations.is_empty() {
        s.push_str("<section id=\"constraints\">\n<h2>Constraints and relations</h2>\n");
        if !report.constraints.is_empty() {
            s.push_str(
                "<table>\n<tr><th>constraint</th><th>kind</th><th>poses</th>\
                 <th>residual rms, nominal</th><th>calibrated</th>\
                 <th>tip spread, nominal</th><th>calibrated</th></tr>\n",
            );
            let opt = |x: Option<f64>| x.map_or_else(|| "–".to_string(), |v| format!("{v:.3e} m"));
            for c in &report.constraints {
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.3e} m</td><td>{:.3e} m</td>\
                     <td>{}</td><td>{}</td></tr>",
                    c.constraint,
                    c.kind,
                    c.poses,
                    c.residual_rms_nominal,
                    c.residual_rms,
                    opt(c.spread_nominal),
                    opt(c.spread)
                );
            }
            s.push_str(
                "</table>\n<p>Spread: RMS distance of a pinned point's predicted tips from \
                 their mean.</p>\n",
            );
        }
        if !report.relations.is_empty() {
            s.push_str(
                "<table>\n<tr><th>relation</th><th>between</th><th>stated</th>\
                 <th>nominal model</th><th>calibrated</th></tr>\n",
            );
            for r in &report.relations {
                let unit = if r.kind == "same_normal" { "rad" } else { "m" };
                let stated = r
                    .value
                    .map_or_else(|| "parallel".to_string(), |v| format!("{v} m"));
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>{}, {}</td><td>{stated}</td><td>{:.6} {unit}</td>\
                     <td>{:.6} {unit}</td></tr>",
                    r.kind, r.between[0], r.between[1], r.nominal, r.calibrated
                );
            }
            s.push_str(
                "</table>\n<p>A pinned point counts as the mean of its predicted tips; \
                 <code>same_normal</code> shows the angle between the normals.</p>\n",
            );
        }
        s.push_str("</section>\n");
    }

    // Residuals and histogram.
    let worst: Vec<usize> = report.worst_poses.iter().map(|w| w.pose).collect();
    s.push_str("<section id=\"residuals\">\n<h2>Residual per pose, before and after</h2>\n");
    let (plot, caption) = residual_plot(data, &worst);
    figure(&mut s, plot, &caption);
    s.push_str("</section>\n<section id=\"histogram\">\n<h2>Residual histogram</h2>\n");
    let (plot, caption) = histogram_plot(data);
    figure(&mut s, plot, &caption);
    s.push_str("</section>\n");

    // Worst poses.
    s.push_str("<section id=\"worst\">\n<h2>Worst poses</h2>\n");
    if report.worst_poses.is_empty() {
        s.push_str("<p>None listed.</p>\n");
    } else {
        s.push_str(
            "<table>\n<tr><th>#</th><th>pose</th><th>CSV line</th><th>residual</th>\
             <th title=\"standardised residual: the residual over the robust scale times the \
             median of a χ distribution with the pose's residual components (about 1 for a \
             typical pose)\">z</th><th>before</th><th>the line</th></tr>\n",
        );
        for (i, w) in report.worst_poses.iter().enumerate() {
            let text = data
                .worst_lines
                .iter()
                .find(|(l, _)| *l == w.line && w.line > 0)
                .map_or_else(
                    || "<span class=\"none\">—</span>".to_string(),
                    |(_, t)| format!("<code>{}</code>", escape(t)),
                );
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
                 <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
                 <td>{text}</td></tr>",
                i + 1,
                w.pose,
                if w.line > 0 {
                    w.line.to_string()
                } else {
                    "—".to_string()
                },
                fmt_len(w.residual.unwrap_or(f64::NAN)),
                w.standardized
                    .map_or_else(|| "—".to_string(), |z| format!("{z:.1}")),
                fmt_len(data.before.get(w.pose).copied().unwrap_or(f64::NAN)),
            );
        }
        s.push_str("</table>\n");
    }
    s.push_str("</section>\n");

    // Measured tips.
    if let Some(t) = &data.tip_errors {
        s.push_str("<section id=\"tip-errors\">\n<h2>Measured tip errors</h2>\n");
        let (plot, caption) = tip_error_plot(t, &worst);
        figure(&mut s, plot, &caption);
        s.push_str("</section>\n");
    }

    // Identifiability.
    s.push_str("<section id=\"identifiability\">\n<h2>Condition and identifiability</h2>\n");
    match report.condition {
        Some(c) => {
            let judgement = if c < 1e4 {
                "well conditioned"
            } else if c < 1e8 {
                "moderately conditioned: some combinations are poorly determined by these poses"
            } else {
                "ill conditioned: some combinations are barely determined by these poses"
            };
            let _ = writeln!(
                s,
                "<p>Condition number of the column-equilibrated, gauge-fixed Jacobian at the \
                 estimate: <strong>{}</strong> ({judgement}).</p>",
                fmt_short(c)
            );
        }
        None => s.push_str("<p>Condition number: not available.</p>\n"),
    }
    let practical: Vec<&String> = report.warnings.iter().filter(|w| is_practical(w)).collect();
    if practical.is_empty() {
        s.push_str("<p>No practical-identifiability warning.</p>\n");
    }
    if report.warnings.is_empty() {
        s.push_str("<p>No warnings.</p>\n");
    } else {
        s.push_str("<h3>Warnings</h3>\n");
        for w in &report.warnings {
            let cls = if is_practical(w) {
                "warn practical"
            } else {
                "warn"
            };
            let _ = writeln!(s, "<p class=\"{cls}\">{}</p>", escape(w));
        }
    }
    s.push_str("</section>\n");

    // Reproducibility.
    s.push_str("<section id=\"reproduce\">\n<h2>Reproducibility</h2>\n");
    let _ = writeln!(
        s,
        "<p>Made by lincal {} with:</p>\n<pre>{}</pre>",
        escape(&prov.version),
        escape(&prov.command)
    );
    if prov.files.is_empty() {
        s.push_str("<p>No input files recorded.</p>\n");
    } else {
        s.push_str("<table>\n<tr><th>input</th><th>path</th><th>bytes</th><th>SHA-256</th></tr>\n");
        for f in &prov.files {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td><code>{}</code></td><td class=\"num\">{}</td>\
                 <td><code>{}</code></td></tr>",
                escape(&f.role),
                escape(&f.path),
                f.bytes,
                escape(&f.sha256)
            );
        }
        s.push_str("</table>\n");
    }
    s.push_str("</section>\n</body>\n</html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{GeneralizedParams, Named, ParamReport, PoseReport};

    fn report(n: usize) -> CalibrateReport {
        CalibrateReport {
            name: "arm <&> \"x\"".to_string(),
            params: Named(vec![
                (
                    "a1".to_string(),
                    ParamReport {
                        value: Some(0.375),
                        std: None,
                        identifiable: false,
                        known: false,
                        held: true,
                    },
                ),
                (
                    "a2".to_string(),
                    ParamReport {
                        value: Some(0.43),
                        std: Some(1e-6),
                        identifiable: true,
                        known: false,
                        held: false,
                    },
                ),
            ]),
            identifiable_count: 1,
            basis_size: 3,
            poses: n,
            rank: 3,
            residual_rms: None,
            method: "linear".to_string(),
            start: "linear".to_string(),
            linear_poses: n,
            condition: Some(12.0),
            worst_poses: (0..n.min(3))
                .map(|l| PoseReport {
                    pose: l,
                    line: l + 2,
                    residual: Some(1e-5),
                    standardized: Some(1.5),
                })
                .collect(),
            robust_scale: None,
            rejected: Vec::new(),
            robust: None,
            constraints: Vec::new(),
            relations: Vec::new(),
            warnings: vec![
                "practically unidentifiable: <b>".to_string(),
                "plain & simple".to_string(),
            ],
            basis: Vec::new(),
            generalized_params: GeneralizedParams::Flat(Vec::new()),
            paper_err_rms: None,
        }
    }

    fn data(before: Vec<f64>, after: Vec<f64>, tips: Option<TipErrors>) -> ReportData {
        ReportData {
            nominal: vec![("a1".to_string(), 0.375), ("a2".to_string(), 0.425)],
            gauge: vec![vec![("a1".to_string(), 1.0), ("a2".to_string(), -0.5)]],
            constraints: vec!["line".to_string()],
            before,
            after,
            tip_errors: tips,
            worst_lines: vec![(2, "0.1,0.2,<x>".to_string())],
        }
    }

    fn prov() -> Provenance {
        Provenance {
            command: "lincal calibrate 'a b.yaml' <d>.csv".to_string(),
            version: "0.1.0".to_string(),
            files: vec![InputFile {
                role: "spec".to_string(),
                path: "a&b.yaml".to_string(),
                bytes: 3,
                sha256: "00".to_string(),
            }],
        }
    }

    fn sections_present(html: &str, tips: bool) {
        for id in SECTIONS {
            let present = html.contains(&format!("<section id=\"{id}\">"));
            assert_eq!(present, id != "tip-errors" || tips, "section {id}");
        }
        assert!(!html.contains("<script"));
        assert!(!html.contains("<b>"));
        assert!(!html.contains("<x>"));
        assert!(!html.contains("<d>"));
    }

    #[test]
    fn escapes_and_has_every_section() {
        let html = calibrate_html(
            &report(5),
            &data(vec![1e-3; 5], vec![1e-6, 2e-6, 0.0, 3e-6, 1e-6], None),
            &prov(),
        );
        sections_present(&html, false);
        assert!(html.contains("arm &lt;&amp;&gt; &quot;x&quot;"));
        assert!(html.contains("warn practical"));
        assert!(html.contains("a&amp;b.yaml"));
        assert!(html.contains("0.1,0.2,&lt;x&gt;"));
        // The worst poses' standardised residuals, in their own column.
        assert!(html.contains(">z</th>"));
        assert!(html.contains("<td class=\"num\">1.5</td>"));
        assert!(html.matches("<svg").count() == 2, "two plots");
        assert!(html.contains("The gauge rule holds <code>a1</code>"));
    }

    #[test]
    fn no_poses_nan_and_huge_do_not_panic() {
        let empty = calibrate_html(&report(0), &data(Vec::new(), Vec::new(), None), &prov());
        sections_present(&empty, false);
        assert!(empty.contains("No plot: no poses."));
        let nan = calibrate_html(
            &report(3),
            &data(vec![f64::NAN; 3], vec![f64::INFINITY; 3], None),
            &prov(),
        );
        assert!(nan.contains("No plot: no finite residual to plot."));
        let zero = calibrate_html(&report(3), &data(vec![0.0; 3], vec![0.0; 3], None), &prov());
        assert_eq!(zero.matches("<svg").count(), 2);
        let n = 200_000;
        let before: Vec<f64> = (0..n).map(|l| 1e-3 * (1.0 + (l % 7) as f64)).collect();
        let mut after: Vec<f64> = (0..n).map(|l| 1e-6 * (1.0 + (l % 5) as f64)).collect();
        after[17] = f64::NAN;
        let tips = TipErrors {
            dim: 3,
            poses: (0..n).collect(),
            errors: (0..3 * n).map(|i| 1e-6 * ((i % 11) as f64 - 5.0)).collect(),
        };
        let big = calibrate_html(&report(n), &data(before, after, Some(tips)), &prov());
        sections_present(&big, true);
        assert!(big.contains("every 10th pose is shown"));
        assert!(big.contains("Non-finite residuals left out: 0 before, 1 after."));
        // At most MAX_PLOT_POINTS (plus the worst) circles per series.
        assert!(big.matches("<circle").count() < 3 * (MAX_PLOT_POINTS + 20) + 10);
        assert!(big.len() < 8 << 20, "{} bytes", big.len());
    }

    #[test]
    fn planar_tip_errors() {
        let tips = TipErrors {
            dim: 2,
            poses: vec![0, 1, 2],
            errors: vec![1e-5, -2e-5, 0.0, 3e-5, f64::NAN, 0.0],
        };
        let html = calibrate_html(
            &report(3),
            &data(vec![1e-3; 3], vec![1e-5; 3], Some(tips)),
            &prov(),
        );
        sections_present(&html, true);
        assert!(html.contains("1 non-finite errors left out"));
        assert!(html.contains("x error (µm)"));
    }

    #[test]
    fn numbers_and_histogram() {
        assert_eq!(fmt_num(0.375), "0.375");
        assert_eq!(fmt_num(f64::NAN), "—");
        assert_eq!(fmt_len(2.5e-5), "25.0000 µm");
        // One decade a bin: 0 (below the range) in the first, 1e-6 in the second, 1e-3 in
        // the last, NaN nowhere.
        assert_eq!(
            histogram(&[1e-6, 1e-3, 0.0, f64::NAN], 1e-7, 1e-2, 5),
            vec![1, 1, 0, 0, 1]
        );
        assert_eq!(sample(10, &[3]).1, 1);
        let (idx, stride) = sample(100_000, &[99_999]);
        assert_eq!(stride, 5);
        assert!(idx.contains(&99_999));
    }

    #[test]
    fn hashes_and_lines() {
        let dir = std::env::temp_dir().join(format!("lincal-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("d.csv");
        std::fs::write(&path, "q1,q2\n1,2\r\n3,4\n").unwrap();
        let f = InputFile::hash("data", &path).unwrap();
        assert_eq!(f.bytes, 15);
        assert_eq!(f.sha256.len(), 64);
        let lines = csv_lines(&path, &[3, 2, 2, 0, 99]).unwrap();
        assert_eq!(lines, vec![(2, "1,2".to_string()), (3, "3,4".to_string())]);
        // The SHA-256 of "abc".
        std::fs::write(&path, "abc").unwrap();
        assert_eq!(
            InputFile::hash("data", &path).unwrap().sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
