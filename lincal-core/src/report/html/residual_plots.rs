//! The residual plots: every pose's residual before and after (log scale), and their
//! histogram; every pose's leverage (log scale).
//!
//! Takes the [`ReportData`] (and the worst poses, always drawn); gives each plot's SVG (or
//! the reason there is none) and its caption.

use std::fmt::Write as _;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::format::rms;
use super::leverage::Leverage;
use super::plot::{
    house_legend, house_mesh, log_range, sample, sampling_note, svg, DrawResult, AFTER, BEFORE,
};
use super::report_data::ReportData;

/// Bins of the residual histogram.
const BINS: usize = 40;

/// The residual-per-pose plot and its caption.
pub(crate) fn residual_plot(
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
    let caption = residual_caption(data, &sampling_note(n, idx.len(), stride), lo);
    let before = points(&data.before, &idx, lo);
    let after = points(&data.after, &idx, lo);
    let plot = svg((960, 380), |root| {
        draw_residuals(root, n, (lo, hi), &before, &after, "residual (m)")
    });
    (plot, caption)
}

/// The plotted points `(pose, value)` of `v` at the sampled poses `idx`: finite values only,
/// those below the axis' lower end `lo` drawn at it.
fn points(v: &[f64], idx: &[usize], lo: f64) -> Vec<(f64, f64)> {
    idx.iter()
        .filter_map(|&l| v.get(l).map(|&r| (l as f64, r)))
        .filter(|(_, r)| r.is_finite())
        .map(|(l, r)| (l, r.max(lo)))
        .collect()
}

/// A measured pose's orientation error per pose, before and after (`before`, `after`:
/// radians), and its caption.
pub(crate) fn orientation_plot(
    before: &[f64],
    after: &[f64],
    worst: &[usize],
) -> (std::result::Result<String, String>, String) {
    let n = before.len().max(after.len());
    let Some((lo, hi)) = log_range(&[before, after]) else {
        return (
            Err("no finite orientation error to plot".to_string()),
            String::new(),
        );
    };
    let (idx, stride) = sample(n, worst);
    let (b, a) = (points(before, &idx, lo), points(after, &idx, lo));
    let plot = svg((960, 380), |root| {
        draw_residuals(root, n, (lo, hi), &b, &a, "orientation error (rad)")
    });
    let caption = format!(
        "Angle of each pose's orientation error ‖log(R_measuredᵀ·R_predicted)‖, with the \
         nominal parameters (orange) and the calibrated ones (blue), log scale. {}",
        sampling_note(n, idx.len(), stride)
    );
    (plot, caption)
}

/// The residual plot's caption: what it shows, the sampling `note`, the non-finite
/// residuals left out, and those drawn at the axis' lower end `lo`.
fn residual_caption(data: &ReportData, note: &str, lo: f64) -> String {
    let (_, bad_before) = rms(&data.before);
    let (_, bad_after) = rms(&data.after);
    let mut caption = format!(
        "Distance of each pose's tip from its constraint, with the nominal parameters (orange) \
         and the calibrated ones (blue), log scale. {note}"
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
    caption
}

/// Draws the residuals `before` and `after` (`(pose, residual)` points) of `n` poses on a
/// log axis from `lo` to a decade above `hi`, with a legend.
fn draw_residuals(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    n: usize,
    (lo, hi): (f64, f64),
    before: &[(f64, f64)],
    after: &[(f64, f64)],
    y_label: &str,
) -> DrawResult {
    let mut chart = ChartBuilder::on(root)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        // A decade on top for the legend.
        .build_cartesian_2d(0f64..(n as f64).max(1.0), (lo..hi * 10.0).log_scale())?;
    let (fx, fy) = (|v: &f64| format!("{v:.0}"), |v: &f64| format!("{v:.0e}"));
    house_mesh(&mut chart.configure_mesh(), "pose (0-based)", y_label)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .draw()?;
    for (pts, color, label) in [
        (before, BEFORE, "before (nominal)"),
        (after, AFTER, "after (calibrated)"),
    ] {
        chart
            .draw_series(
                pts.iter()
                    .map(|&p| Circle::new(p, 2, color.mix(0.55).filled())),
            )?
            .label(label)
            .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
    }
    house_legend(&mut chart)
}

/// The leverage-per-pose plot (the poses of highest leverage marked, the mean `rank/N` as a
/// line) and its caption.
pub(crate) fn leverage_plot(lev: &Leverage) -> (std::result::Result<String, String>, String) {
    let n = lev.values.len();
    if n == 0 {
        return (Err("no poses".to_string()), String::new());
    }
    let Some((lo, hi)) = log_range(&[&lev.values]) else {
        return (Err("no finite leverage to plot".to_string()), String::new());
    };
    let top: Vec<usize> = lev.top.iter().map(|t| t.0).collect();
    let (idx, stride) = sample(n, &top);
    let all = points(&lev.values, &idx, lo);
    let marked = points(&lev.values, &top, lo);
    let kept = lev.values.iter().filter(|v| v.is_finite()).count();
    let mean = lev.rank as f64 / kept.max(1) as f64;
    let plot = svg((960, 380), |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..(n as f64).max(1.0), (lo..hi * 10.0).log_scale())?;
        let (fx, fy) = (|v: &f64| format!("{v:.0}"), |v: &f64| format!("{v:.0e}"));
        house_mesh(&mut chart.configure_mesh(), "pose (0-based)", "leverage h")
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .draw()?;
        chart
            .draw_series(
                all.iter()
                    .map(|&p| Circle::new(p, 2, AFTER.mix(0.55).filled())),
            )?
            .label("leverage of the pose")
            .legend(|(x, y)| Circle::new((x, y), 4, AFTER.filled()));
        chart
            .draw_series(marked.iter().map(|&p| Circle::new(p, 4, BEFORE.filled())))?
            .label("highest leverage")
            .legend(|(x, y)| Circle::new((x, y), 4, BEFORE.filled()));
        chart
            .draw_series(LineSeries::new(
                [(0.0, mean), ((n as f64).max(1.0), mean)],
                BLACK.mix(0.5),
            ))?
            .label("mean (rank/N)")
            .legend(|(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], BLACK.mix(0.5)));
        house_legend(&mut chart)
    });
    let mut caption = format!(
        "Leverage of each pose, h = tr(J_l (JᵀJ)⁻¹ J_lᵀ) over its residual rows J_l at the \
         estimate: how much the fit depends on the pose (an error there moves the parameters \
         most, and shows least in its own residual). The leverages sum to the rank, {} of {} \
         free parameters; their mean is {mean:.3} over {kept} poses. The {} of highest \
         leverage in orange. Log scale. {}",
        lev.rank,
        lev.free,
        top.len(),
        sampling_note(n, idx.len(), stride)
    );
    if kept < n {
        let _ = write!(
            caption,
            " {} poses the fit left out are not shown.",
            n - kept
        );
    }
    (plot, caption)
}

/// Counts of `v` in `bins` log-spaced bins from `lo` to `hi` (values below `lo` in the
/// first, non-finite ones left out).
pub(crate) fn histogram(v: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
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
pub(crate) fn histogram_plot(data: &ReportData) -> (std::result::Result<String, String>, String) {
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
            house_legend(&mut chart)
        });
    (plot, caption)
}
