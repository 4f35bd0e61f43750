//! One sentence on what the prior did, for the text and HTML reports ([`summary`]), where
//! its strength's choice started included.

use super::strength::same_tolerance;
use super::{PriorReport, PriorShape, StrengthRule, StrengthSelection, UNSEEN_TOLERANCE};

/// Where the curve's choice started from MUKCa's relative ridge, looser than the drawing's
/// tolerance ([`super::start_tolerance`]): what it was; else nothing (and nothing for a
/// tolerance from the residual level, which no start decides).
fn start_note(sel: &StrengthSelection) -> String {
    let ridge = sel.start > UNSEEN_TOLERANCE && !same_tolerance(sel.start, UNSEEN_TOLERANCE);
    if sel.rule != StrengthRule::Residual && ridge {
        format!(
            ", starting from {:.1e}, the relative ridge σ̂/√(N·10⁻⁴) at these poses (looser \
             than the drawing's {UNSEEN_TOLERANCE:.0e})",
            sel.start
        )
    } else {
        String::new()
    }
}

/// One sentence on what the prior did, for the text and HTML reports; `None` when it was
/// not applied.
#[must_use]
pub fn summary(report: &PriorReport) -> Option<String> {
    if !report.applied {
        return None;
    }
    let of = match report.shape {
        Some(PriorShape::Params) => "each length and angle of the arm",
        _ => "each joint's mounting (translation, rotation)",
    };
    let how = match (&report.selection, report.weight) {
        (Some(sel), _) => {
            let rule = match sel.tolerance {
                Some(t) if sel.rule == StrengthRule::Residual => format!(
                    "one tolerance of {t:.1e} m and rad for {of}, from the residual level (the \
                     held-out residual is {:.2}× what noise would leave: errors the model cannot \
                     hold, which clusters of one placement share)",
                    sel.lack_of_fit.map_or(f64::NAN, |l| l.ratio)
                ),
                Some(t) => format!("one tolerance of {t:.1e} m and rad for {of}"),
                None => format!(
                    "each direction by its own evidence ({:.1} of {} directions held by it)",
                    sel.held, sel.directions
                ),
            };
            let cv = if sel.rule == StrengthRule::Residual {
                String::new()
            } else if sel.folds >= 2 {
                format!(
                    ", chosen by the least held-out residual over {} folds by {}",
                    sel.folds,
                    sel.grouping.name()
                )
            } else {
                " (too few poses or placements to cross-validate)".to_string()
            };
            format!("{rule}{cv}{}", start_note(sel))
        }
        (None, Some(w)) => format!(
            "{:.1e} m and {:.1e} rad for {of} (weight {w:.1e} against the mean squared \
             residual per pose)",
            report.length_tolerance.unwrap_or(f64::NAN),
            report.angle_tolerance.unwrap_or(f64::NAN)
        ),
        (None, None) => format!(
            "{:.1e} m and {:.1e} rad for {of}",
            report.length_tolerance.unwrap_or(f64::NAN),
            report.angle_tolerance.unwrap_or(f64::NAN)
        ),
    };
    let weak = if report.weak.is_empty() {
        String::new()
    } else {
        format!("; it mattered most for {}", report.weak.join(", "))
    };
    Some(format!(
        "the arm was fitted with a prior around its nominals: {how}, scaled by the noise level \
         {:.3e} m{weak}; `--prior off` leaves it out",
        report.sigma.unwrap_or(f64::NAN)
    ))
}
