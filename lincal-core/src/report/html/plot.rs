//! What every plot shares: the even sample of many poses and its caption sentence, the
//! SVG canvas, the house style of a chart's mesh, the before/after colours, log axes.
//!
//! Takes the values to plot and a drawing closure; gives SVG text or the reason there is
//! none.

use std::error::Error as StdError;

use plotters::coord::Shift;
use plotters::prelude::*;

/// Most points a plot shows per series; beyond it an even sample (plus the worst poses) is
/// drawn and the caption says so.
pub const MAX_PLOT_POINTS: usize = 20_000;

/// The indices to plot of `n` values: all of them, or every `stride`-th plus `always`; and
/// the stride (1 when all are shown).
pub(crate) fn sample(n: usize, always: &[usize]) -> (Vec<usize>, usize) {
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
pub(crate) fn sampling_note(n: usize, shown: usize, stride: usize) -> String {
    if stride <= 1 {
        format!("All {n} poses shown.")
    } else {
        format!(
            "{n} poses: every {stride}th pose is shown ({shown} points, the worst poses \
             included), at most {MAX_PLOT_POINTS} per series."
        )
    }
}

/// What a drawing closure gives: done, or plotters' error.
pub(crate) type DrawResult = std::result::Result<(), Box<dyn StdError>>;

/// Every chart's mesh alike: the axis titles, a faint grid, the report's fonts. The caller
/// adds its tick formatters and draws.
pub(crate) fn house_mesh<'a, 'b, 'm, X, Y, XT, YT, DB>(
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

/// Every chart's legend alike: the series labels at the upper right, on a light box with a
/// faint border, in the report's font.
pub(crate) fn house_legend<'a, DB, CT>(
    chart: &mut plotters::chart::ChartContext<'a, DB, CT>,
) -> DrawResult
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 14))
        .draw()?;
    Ok(())
}

/// Draws into an SVG of `size` with `draw`; the SVG text, or the reason it could not be drawn.
pub(crate) fn svg(
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

/// The colour of the residuals before calibration (nominal parameters).
pub(crate) const BEFORE: RGBColor = RGBColor(230, 120, 30);
/// The colour of the residuals after calibration.
pub(crate) const AFTER: RGBColor = RGBColor(30, 100, 200);

/// Lower and upper end of a log axis holding the positive finite values of `sets` (zeros
/// and smaller values are drawn at the lower end); `None` when there is no finite value.
pub(crate) fn log_range(sets: &[&[f64]]) -> Option<(f64, f64)> {
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
