//! The measured tips' error scatter: calibrated tip minus measured tip, 3-D (seen
//! obliquely) or 2-D for planar arms, equal axes.
//!
//! Takes the [`TipErrors`] (and the worst poses, always drawn); gives the plot's SVG (or the
//! reason there is none) and its caption.

use std::fmt::Write as _;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::format::{tick, unit};
use super::plot::{house_mesh, sample, sampling_note, svg, DrawResult, AFTER};
use super::report_data::TipErrors;

/// The measured tips' error scatter and its caption.
pub(crate) fn tip_error_plot(
    t: &TipErrors,
    worst: &[usize],
) -> (std::result::Result<String, String>, String) {
    let dim = t.dim.clamp(2, 3);
    let n = t.poses.len();
    let (idx, stride) = sample(n, &worst_positions(t, worst));
    let pts = finite_errors(t, dim, &idx);
    let left_out = idx.len() - pts.len();
    let r = pts
        .iter()
        .flat_map(|e| e.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let (f, u) = unit(r);
    let r = if r > 0.0 { r * f * 1.1 } else { 1.0 };
    let caption = tip_caption(dim, u, &sampling_note(n, idx.len(), stride), left_out);
    let plot = if dim == 3 {
        svg((720, 560), |root| draw_tips_3d(root, &pts, (f, u, r)))
    } else {
        svg((560, 520), |root| draw_tips_2d(root, &pts, (f, u, r)))
    };
    (plot, caption)
}

/// The worst poses, as positions in `t.poses`.
fn worst_positions(t: &TipErrors, worst: &[usize]) -> Vec<usize> {
    worst
        .iter()
        .filter_map(|w| t.poses.binary_search(w).ok())
        .collect()
}

/// The error vectors (`dim` components, the rest 0) of the sampled positions `idx`, the
/// non-finite ones left out.
fn finite_errors(t: &TipErrors, dim: usize, idx: &[usize]) -> Vec<[f64; 3]> {
    let vec = |i: usize| -> [f64; 3] {
        let mut e = [0.0; 3];
        for (k, v) in e.iter_mut().enumerate().take(dim) {
            *v = t.errors.get(i * t.dim + k).copied().unwrap_or(f64::NAN);
        }
        e
    };
    idx.iter()
        .map(|&i| vec(i))
        .filter(|e| e.iter().all(|v| v.is_finite()))
        .collect()
}

/// The scatter's caption: what it shows in unit `u`, the sampling `note`, the errors left
/// out.
fn tip_caption(dim: usize, u: &str, note: &str, left_out: usize) -> String {
    let mut caption = format!(
        "Error of each measured tip, calibrated tip minus measured tip, in {u}{}. {note}",
        if dim == 3 {
            " (a 3-D scatter seen obliquely; the axes are equal)"
        } else {
            " (equal axes)"
        }
    );
    if left_out > 0 {
        let _ = write!(caption, " {left_out} non-finite errors left out.");
    }
    caption
}

/// Draws 3-D error vectors `pts` (scaled by `f` into unit `u`) in a cube of half-side `r`,
/// seen obliquely, the error's z upward.
fn draw_tips_3d(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    pts: &[[f64; 3]],
    (f, u, r): (f64, &str, f64),
) -> DrawResult {
    let style = AFTER.mix(0.55).filled();
    let mut chart = ChartBuilder::on(root)
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
}

/// Draws planar error vectors `pts` (scaled by `f` into unit `u`) in a square of half-side
/// `r`.
fn draw_tips_2d(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    pts: &[[f64; 3]],
    (f, u, r): (f64, &str, f64),
) -> DrawResult {
    let style = AFTER.mix(0.55).filled();
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
}
