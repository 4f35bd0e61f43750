//! What a [`Plan`] is worth, for a person (the summary `lincal select` prints on stderr) and
//! for a program (the JSON object of `lincal select --format json`, which `lincal.select` in
//! Python hands back too).

use std::fmt::Write as _;

use serde_json::{json, Value};

use super::plan::{Plan, PlanOptions};
use crate::calibrate::prior::{PriorChoice, PriorShape};

/// The criterion's name as the command line spells it: `"d"` or `"tip"`.
#[must_use]
pub fn criterion_name(opts: &PlanOptions) -> &'static str {
    if opts.tip {
        "tip"
    } else {
        "d"
    }
}

/// The notes on a plan, one sentence each: candidates dropped, a choice worth more random
/// poses than the pool holds, parameters the gauge holds, fewer poses than the linear
/// method's basis size `K`, the fit's prior counted.
#[must_use]
pub fn plan_notes(plan: &Plan) -> Vec<String> {
    let mut notes = Vec::new();
    if !plan.dropped.is_empty() {
        notes.push(format!(
            "{} candidate(s) dropped: off their nominal constraint by more than the limit",
            plan.dropped.len()
        ));
    }
    if plan.worth.is_none() {
        notes.push("worth more random poses than the pool holds".to_string());
    }
    if !plan.held.is_empty() {
        notes.push(format!(
            "held by the gauge (no pose choice improves them): {}",
            plan.held.join(", ")
        ));
    }
    if plan.below_basis {
        notes.push(
            "fewer poses than the linear method's basis size K: calibrate will start from the \
             nominals (the parameter-space fit estimates these parameters)"
                .to_string(),
        );
    }
    if !plan.prior_weak.is_empty() {
        notes.push(format!(
            "the data alone leave {} weak, so calibrate will apply its weak-direction prior: \
             the plan counted it (--prior off: the data alone)",
            plan.prior_weak.join(", ")
        ));
    }
    notes
}

/// The JSON object of `lincal select --format json`: the chosen poses (`candidate` index into
/// the candidates as given, `line` in their file when `lines`, `q`), the dropped ones, per
/// free parameter the predicted std beside the median of random picks, the held parameters,
/// the predicted tip RMS, condition, worth, efficiency bound, `log det` of the chosen set and
/// of random picks (the mean over the draws of `log det` of the information), and whether the
/// count is below the basis size `K`, and the [`plan_notes`]. Non-finite numbers are `null`.
#[must_use]
pub fn plan_json(plan: &Plan, opts: &PlanOptions, lines: bool) -> Value {
    let finite = |v: f64| if v.is_finite() { json!(v) } else { json!(null) };
    let s = plan.sigmas;
    json!({
        "count": plan.chosen.len(),
        "pool": plan.pool.len(),
        "criterion": criterion_name(opts),
        "draws": opts.draws,
        "prior": prior_json(plan, opts),
        "sigma": {
            "constraint": s.constraint,
            "measured": s.measured,
            "orientation": s.orientation,
            "encoder": s.encoder,
        },
        "chosen": plan.chosen.iter().map(|&i| json!({
            "candidate": plan.pool_index[i],
            "line": if lines { json!(plan.pool.line.at(i)) } else { json!(null) },
            "q": plan.pool.q[i].to_vec(),
        })).collect::<Vec<_>>(),
        "dropped": plan.dropped.iter().map(|d| json!({
            "candidate": d.pose, "line": d.line, "residual": d.residual,
        })).collect::<Vec<_>>(),
        "params": plan.params.iter().map(|p| json!({
            "name": p.name, "std": finite(p.chosen), "random_std": finite(p.random),
        })).collect::<Vec<_>>(),
        "held": plan.held,
        "tip_rms": finite(plan.tip_rms),
        "random_tip_rms": finite(plan.random_tip_rms),
        "condition": finite(plan.condition),
        "worth": plan.worth,
        "efficiency_bound": plan.efficiency,
        "log_det": finite(plan.log_det.0),
        "random_log_det": finite(plan.log_det.1),
        "below_basis_size": plan.below_basis,
        "notes": plan_notes(plan),
    })
}

/// The calibration's prior a plan was made for (`null` when off): its shape, its weight when
/// relative, the tolerances it comes to, whether the plan counted it (`applied`) and the
/// parameters that made it (`weak`).
fn prior_json(plan: &Plan, opts: &PlanOptions) -> Value {
    match plan.prior {
        PriorChoice::Off => Value::Null,
        PriorChoice::On { scale, shape } => {
            let (length, angle) = scale.tolerances(f64::NAN, 1);
            let finite = |v: f64| if v.is_finite() { json!(v) } else { json!(null) };
            json!({
                "shape": shape,
                "weight": opts.prior.weight(),
                "length_tolerance": finite(length),
                "angle_tolerance": finite(angle),
                "applied": !plan.prior_weak.is_empty(),
                "weak": plan.prior_weak,
            })
        }
    }
}

/// The sentence on the fit's prior when the plan counted it.
fn prior_line(plan: &Plan) -> Option<String> {
    let PriorChoice::On { scale, shape } = plan.prior else {
        return None;
    };
    let (length, angle) = scale.tolerances(f64::NAN, 1);
    let of = match shape {
        PriorShape::Frames => "each joint's mounting",
        PriorShape::Params => "each length and angle of the arm",
    };
    (!plan.prior_weak.is_empty()).then(|| {
        format!(
            "the data alone would leave {} weak, so calibrate will apply its prior ({length:.1e} \
             m, {angle:.1e} rad on {of}): planned with it counted (--prior off: the data alone)",
            plan.prior_weak.join(", ")
        )
    })
}

/// The summary for a person: what was chosen from what, the dropped candidates, each free
/// parameter's predicted std beside random picks', the tip RMS, condition, worth, bound, the
/// held parameters and a note when the count is below `K`.
#[must_use]
pub fn plan_text(plan: &Plan, opts: &PlanOptions) -> String {
    let mut s = String::new();
    let sig = plan.sigmas;
    let encoder = if sig.encoder > 0.0 {
        format!(", encoder σ = {:.3e}", sig.encoder)
    } else {
        String::new()
    };
    let _ = writeln!(
        s,
        "lincal select: {} poses of a pool of {} ({} criterion, {} draw(s) besides the nominals), \
         residual σ = {:.3e} m{encoder}",
        plan.chosen.len(),
        plan.pool.len(),
        if opts.tip { "tip" } else { "D" },
        opts.draws,
        sig.constraint
    );
    if let Some(line) = prior_line(plan) {
        let _ = writeln!(s, "  {line}");
    }
    for d in &plan.dropped {
        let _ = writeln!(
            s,
            "  dropped: line {} is {:.3e} m off its nominal constraint",
            d.line, d.residual
        );
    }
    let _ = writeln!(s, "  predicted std     chosen       random picks (median)");
    for p in &plan.params {
        let _ = writeln!(
            s,
            "  {:<16}  {:>11.3e}  {:>11.3e}",
            p.name, p.chosen, p.random
        );
    }
    let _ = writeln!(
        s,
        "  tip RMS over the workspace: {:.3e} m (random picks {:.3e} m); condition {:.3e}",
        plan.tip_rms, plan.random_tip_rms, plan.condition
    );
    let _ = match plan.worth {
        Some(w) => writeln!(s, "  worth about {w} random poses of the same pool"),
        None => writeln!(s, "  worth more random poses than the pool holds"),
    };
    if let Some(e) = plan.efficiency {
        let _ = writeln!(s, "  D-efficiency ≥ {e:.3} of the best design on this pool");
    }
    if !plan.held.is_empty() {
        let _ = writeln!(
            s,
            "  held by the gauge (no pose choice improves them): {}",
            plan.held.join(", ")
        );
    }
    if plan.below_basis {
        let _ = writeln!(
            s,
            "  note: fewer poses than the linear method's basis size K: calibrate will start \
             from the nominals (the parameter-space fit estimates these parameters)"
        );
    }
    s
}
