//! The prior's strength choice ([`crate::calibrate::prior::StrengthSelection`]): the
//! cross-validation curve of the single-scale prior, the per-direction prior's figure beside
//! it, and the one chosen.
//!
//! Takes the selection; gives the plot's SVG (or the reason there is none) and its caption.

use plotters::prelude::*;

use super::plot::{house_legend, house_mesh, log_range, svg, DrawResult, AFTER, BEFORE};
use crate::calibrate::prior::{StrengthRule, StrengthSelection};

/// The held-out RMS residual against the tolerance of every joint mounting (log-log), the
/// per-direction prior's as a dashed line, the chosen one marked; and the caption.
pub(crate) fn strength_plot(sel: &StrengthSelection) -> (Result<String, String>, String) {
    let pts: Vec<(f64, f64)> = sel
        .curve
        .iter()
        .filter(|p| p.rms.is_finite() && p.rms > 0.0)
        .map(|p| (p.tolerance, p.rms))
        .collect();
    if pts.len() < 2 {
        return (
            Err("too few poses or placements to cross-validate".to_string()),
            String::new(),
        );
    }
    let rms: Vec<f64> = pts.iter().map(|p| p.1).chain(sel.ard_rms).collect();
    let Some((lo, hi)) = log_range(&[&rms]) else {
        return (
            Err("no finite held-out residual".to_string()),
            String::new(),
        );
    };
    let (t0, t1) = (pts[0].0, pts[pts.len() - 1].0);
    // A tolerance off the grid (from the residual level) is marked on the curve between its
    // neighbours, interpolated on the log-log plot.
    let chosen = sel.tolerance.and_then(|t| {
        pts.windows(2).find_map(|w| {
            let ((a, ra), (b, rb)) = (w[0], w[1]);
            (a <= t && t <= b).then(|| {
                let s = (t / a).ln() / (b / a).ln();
                (t, (ra.ln() + s * (rb / ra).ln()).exp())
            })
        })
    });
    let plot = svg((960, 360), |root| -> DrawResult {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d((t0..t1).log_scale(), (lo * 0.9..hi * 1.5).log_scale())?;
        let f = |v: &f64| format!("{v:.0e}");
        house_mesh(
            &mut chart.configure_mesh(),
            "tolerance of every joint mounting (m, rad)",
            "held-out RMS residual (m)",
        )
        .x_label_formatter(&f)
        .y_label_formatter(&f)
        .draw()?;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), AFTER.stroke_width(2)))?
            .label("one scale")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], AFTER.stroke_width(2)));
        if let Some(a) = sel.ard_rms {
            chart
                .draw_series(DashedLineSeries::new(
                    [(t0, a), (t1, a)],
                    6,
                    4,
                    BEFORE.stroke_width(2),
                ))?
                .label("each direction by its evidence")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], BEFORE.stroke_width(2))
                });
        }
        if let Some(c) = chosen {
            chart
                .draw_series([Circle::new(c, 6, BLACK.filled())])?
                .label("chosen")
                .legend(|(x, y)| Circle::new((x, y), 5, BLACK.filled()));
        }
        house_legend(&mut chart)
    });
    (plot, caption(sel))
}

/// The plot's caption: what it shows and what was chosen.
fn caption(sel: &StrengthSelection) -> String {
    let chose = match (sel.rule, sel.tolerance) {
        (StrengthRule::Residual, Some(t)) => format!(
            "one tolerance of {t:.1e} m and rad from the residual level, σ̂/√(60·10⁻⁴) (the \
             held-out residual was {:.2}× what noise would leave: errors the model cannot hold, \
             shared by the clusters of one placement, so their curve does not choose)",
            sel.lack_of_fit.map_or(f64::NAN, |l| l.ratio)
        ),
        (StrengthRule::Scale, Some(t)) => format!("one tolerance of {t:.1e} m and rad"),
        _ => "each direction by its own evidence".to_string(),
    };
    let rule = if sel.rule == StrengthRule::Residual {
        String::new()
    } else {
        format!(
            " (the start, {:.1e}, stands unless another does better by one standard error and \
             0.5 %; the start is the drawing's tolerance of 1e-2, or MUKCa's relative ridge \
             σ̂/√(N·10⁻⁴) at these poses where that is looser)",
            sel.start
        )
    };
    format!(
        "Held-out RMS residual of the fit with a prior of one tolerance for every joint \
         mounting (blue), and with each direction weighed by its own evidence (orange, \
         dashed), over {} folds by {}. Chosen: {chose}{rule}. Effective directions held by the \
         prior: {:.2} of {}.",
        sel.folds,
        sel.grouping.name(),
        sel.held,
        sel.directions
    )
}
