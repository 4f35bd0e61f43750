//! The readable reports: what `lincal basis` and `lincal calibrate` print as text.
//!
//! Takes a model (and an estimate); gives the report as lines of text.

use std::fmt::Write as _;

use super::json::known_names;
use crate::calibrate::estimate::Estimate;
use crate::model::CalibModel;
use crate::spec::Constraint;
use crate::symbolic::SymbolicModel;

/// A relation as text, e.g. `distance between constraints 0 and 1 = 0.05 m`.
#[must_use]
pub fn relation_string(r: &crate::model::geometry::Relation) -> String {
    let [i, j] = r.between;
    match r.kind {
        crate::model::geometry::RelationKind::Distance => {
            format!("distance between constraints {i} and {j} = {} m", r.value)
        }
        crate::model::geometry::RelationKind::SameNormal => {
            format!("constraints {i} and {j} parallel (same normal)")
        }
        crate::model::geometry::RelationKind::Offset => {
            format!("constraints {i} and {j} parallel, {} m apart", r.value)
        }
    }
}

/// A gauge direction as text, e.g. `a1 - 0.5·b1`.
fn gauge_string(g: &[(String, f64)]) -> String {
    let mut s = String::new();
    for (i, (name, c)) in g.iter().enumerate() {
        let (sign, mag) = if *c < 0.0 { ("-", -c) } else { ("+", *c) };
        if i == 0 {
            if sign == "-" {
                s.push('-');
            }
        } else {
            let _ = write!(s, " {sign} ");
        }
        if (mag - 1.0).abs() < 1e-12 {
            s.push_str(name);
        } else {
            let _ = write!(s, "{}·{name}", short(mag));
        }
    }
    s
}

/// A number in a short readable form (6 significant digits).
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-4..1e6).contains(&a) {
        let digits = (5 - a.log10().floor() as i32).clamp(0, 12) as usize;
        let s = format!("{v:.digits$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        s
    } else {
        format!("{v:.5e}")
    }
}

/// Which constraint each equation belongs to, as readable labels.
fn equation_labels(model: &SymbolicModel) -> Vec<String> {
    let spec = model.spec();
    let dim = spec.dim;
    let mut labels = Vec::new();
    for (j, c) in spec.constraints.iter().enumerate() {
        let m = c.geometry_kind().equation_count(dim);
        let what = match c {
            Constraint::Point { .. } => vec!["x − p_x", "y − p_y", "z − p_z"],
            Constraint::Measured => vec!["x", "y", "z"],
            Constraint::MeasuredPose { .. } => vec![
                "x", "y", "z", "R11", "R21", "R31", "R12", "R22", "R32", "R13", "R23", "R33",
            ],
            Constraint::Line3 { .. } => vec!["plane 1", "plane 2"],
            _ => vec![""],
        };
        for i in 0..m {
            let mut l = format!("constraint {j} ({})", c.kind_name());
            if m > 1 {
                let _ = write!(l, ", {}", what.get(i).copied().unwrap_or(""));
            }
            labels.push(l);
        }
    }
    labels
}

/// The result of `lincal basis` as a readable report: the identifiability and the gauge
/// directions first (what a spec's author asks, a few lines), then the basis functions and
/// the generalized parameters `c(p)` of each equation (hundreds of lines for a 6-joint arm).
#[must_use]
pub fn basis_text(model: &SymbolicModel) -> String {
    let mut s = String::new();
    basis_header(&mut s, model);
    identifiability_lines(&mut s, model);
    gauge_lines(&mut s, model);
    for w in model.warnings() {
        let _ = writeln!(s, "warning: {w}");
    }
    let _ = writeln!(s);
    basis_functions(&mut s, model);
    s
}

/// The head of the basis report: the spec's name and size, its description, constraints and
/// known parameters, the naive and reduced basis sizes.
fn basis_header(s: &mut String, model: &SymbolicModel) {
    let spec = model.spec();
    let names = model.param_names();
    let _ = writeln!(
        s,
        "{}: dim {}, {} joint(s), {} estimated parameter(s)",
        spec.name,
        spec.dim,
        spec.joints.len(),
        names.len()
    );
    if let Some(d) = &spec.description {
        let _ = writeln!(s, "  {d}");
    }
    let kinds: Vec<&str> = spec.constraints.iter().map(Constraint::kind_name).collect();
    let _ = writeln!(
        s,
        "constraint(s): {} ({} equation(s))",
        kinds.join(", "),
        model.equation_count()
    );
    let known = known_names(spec);
    if !known.is_empty() {
        let _ = writeln!(s, "known (fixed at nominal): {}", known.join(", "));
    }
    let _ = writeln!(
        s,
        "naive size: {} distinct monomials; reduced basis: K = {}",
        model.naive_size(),
        model.basis_names().len()
    );
    let _ = writeln!(s);
}

/// The basis functions `Φ̃(q)`, then each equation's generalized parameters `c(p)`.
fn basis_functions(s: &mut String, model: &SymbolicModel) {
    let _ = writeln!(s, "basis functions Φ̃(q):");
    let width = model.basis_names().len().to_string().len();
    for (k, b) in model.basis_names().iter().enumerate() {
        let _ = writeln!(s, "  Φ{:<width$}  {b}", k + 1);
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "generalized parameters c(p), h_e(q; p) = Σ_k c_e,k(p)·Φk(q):"
    );
    let labels = equation_labels(model);
    let strings = model.generalized_param_strings();
    if let (None, Some(terms)) = (&strings, model.generalized_param_terms()) {
        let _ = writeln!(
            s,
            "  {} polynomials of {terms} terms in all: not printed (beyond {} terms); the \
             derive's tables (`#[derive(CalibModel)]`) hold them in factored form",
            model.equation_count() * model.basis_size(),
            crate::symbolic::model::REPORT_C_TERMS
        );
    } else if let Some(route) = model.unexpanded_route() {
        let _ = writeln!(
            s,
            "  {} polynomials, not expanded: the basis {route} (the direct \
             expansion was beyond its bound, or c(p) beyond the terms printed); the derive's tables (`#[derive(CalibModel)]`) \
             and the run-time model evaluate c(p) in factored form",
            model.equation_count() * model.basis_size(),
        );
    }
    if let Some(Ok(c)) = model.factored_certificate() {
        // The bound rounded up to a power of ten.
        let bound = 10f64.powi(c.failure_bound.log10().ceil() as i32);
        let what = if c.jacobian {
            "c(p) and ∂c/∂p"
        } else {
            "c(p)"
        };
        let _ = writeln!(
            s,
            "  factored {what} proven: Σ_k c_k(p)·Φ̃_k(q) = h(q; p) for all {} equations, exactly \
             modulo 2⁶¹ − 1 at {} random points (wrong tables pass with probability below \
             {bound:.0e})",
            c.equations, c.points
        );
    }
    for (e, row) in strings.unwrap_or_default().iter().enumerate() {
        let _ = writeln!(
            s,
            "  equation {} — {}:",
            e + 1,
            labels.get(e).map_or("", String::as_str)
        );
        for (k, c) in row.iter().enumerate() {
            let _ = writeln!(s, "    c{:<width$} = {c}", k + 1);
        }
    }
    let _ = writeln!(s);
}

/// How many combinations are identifiable, which parameters are on their own, and which
/// the gauge rule holds.
fn identifiability_lines(s: &mut String, model: &SymbolicModel) {
    let ident = model.identifiability();
    let names = model.param_names();
    let (yes, no) = model.identifiable_split();
    let held: Vec<&str> = names
        .iter()
        .zip(&ident.held)
        .filter(|(_, &h)| h)
        .map(|(n, _)| n.as_str())
        .collect();
    let list = |v: &[String]| {
        if v.is_empty() {
            "(none)".to_string()
        } else {
            v.join(", ")
        }
    };
    let _ = writeln!(s, "identifiable combinations: {}", ident.count);
    let _ = writeln!(s, "  identifiable on their own: {}", list(&yes));
    let _ = writeln!(s, "  not identifiable on their own: {}", list(&no));
    if !held.is_empty() {
        let _ = writeln!(
            s,
            "  gauge rule: held at their nominal values by `calibrate`: {}",
            held.join(", ")
        );
    }
}

/// The gauge directions, then each relation with the gauge directions it removes.
fn gauge_lines(s: &mut String, model: &SymbolicModel) {
    let gauge = model.gauge();
    if gauge.is_empty() {
        let _ = writeln!(s, "gauge directions: none (every parameter is determined)");
    } else {
        let _ = writeln!(
            s,
            "gauge directions (parameter changes the constraint cannot see, at the nominals; \
             d(x + k·y): x by t together with y by k·t):"
        );
        for (i, g) in gauge.iter().enumerate() {
            let _ = writeln!(s, "  {}. d({})", i + 1, gauge_string(g));
        }
    }
    let relations = &model.spec().relations;
    if !relations.is_empty() {
        let _ = writeln!(s, "relations (and the gauge directions each one removes):");
        for (i, (r, removes)) in relations.iter().zip(model.relation_gauge()).enumerate() {
            let _ = writeln!(s, "  {}. {}", i + 1, relation_string(r));
            if removes.is_empty() {
                let _ = writeln!(s, "     removes no gauge direction");
            }
            for g in &removes {
                let _ = writeln!(s, "     removes d({})", gauge_string(g));
            }
        }
    }
}

/// The result of `lincal calibrate` as a readable table.
#[must_use]
pub fn calibrate_text(model: &dyn CalibModel, est: &Estimate) -> String {
    let mut s = String::new();
    calibrate_header(&mut s, model, est);
    parameter_table(&mut s, est);
    fit_lines(&mut s, est);
    worst_poses_line(&mut s, est);
    constraint_lines(&mut s, est);
    for (i, e) in est.validation.iter().enumerate() {
        let _ = write!(s, "validation {i}: ");
        s.push_str(&super::validation::evaluation_text(e, "calibrated"));
    }
    if let Some(cv) = &est.cross_validation {
        s.push_str(&super::validation::cross_validation_text(cv));
    }
    plane_lines(&mut s, est);
    if !est.warnings.is_empty() {
        let _ = writeln!(s, "warnings:");
        for warn in &est.warnings {
            let _ = writeln!(s, "  - {warn}");
        }
    }
    s
}

/// The head of the calibration report: the model, poses and method, where the fit started,
/// the basis size, rank, identifiable combinations and condition.
fn calibrate_header(s: &mut String, model: &dyn CalibModel, est: &Estimate) {
    let _ = writeln!(
        s,
        "{}: {} poses, method {}",
        model.name(),
        est.poses,
        est.method
    );
    let start = match est.start.as_str() {
        "linear" if est.linear_poses < est.poses => format!(
            "the linear method (no initial guess), on {} of the {} poses",
            est.linear_poses, est.poses
        ),
        "linear" => "the linear method (no initial guess)".to_string(),
        _ => "the nominals (deterministic restarts)".to_string(),
    };
    let _ = writeln!(s, "start: {start}");
    if let Some(p) = crate::calibrate::prior::summary(&est.prior) {
        let _ = writeln!(s, "prior: {p}");
    }
    let _ = writeln!(
        s,
        "basis K = {}, rank {}, identifiable combinations {}{}",
        est.basis_size.map_or_else(
            || "not built (beyond the report's bound)".to_string(),
            |k| k.to_string()
        ),
        est.rank,
        est.identifiable_count,
        est.condition
            .map_or(String::new(), |c| format!(", condition {c:.3e}"))
    );
    let _ = writeln!(s);
}

/// Each plane by normal and offset, unit-normalised (nothing when the spec has none).
fn plane_lines(s: &mut String, est: &Estimate) {
    for p in &est.planes {
        let [a, b, c] = p.normal;
        let _ = writeln!(
            s,
            "plane (constraint {}), unit-normalised: n = [{a:.9}, {b:.9}, {c:.9}], \
             n·x = {:.9} m (the fitted normal and offset divided by ‖n‖ = {:.6e})",
            p.constraint, p.offset, p.scale
        );
    }
}

/// Every parameter's value, std and status, in a table.
fn parameter_table(s: &mut String, est: &Estimate) {
    let w = est
        .params
        .iter()
        .map(|p| p.name.chars().count())
        .max()
        .unwrap_or(5)
        .max(9);
    let _ = writeln!(
        s,
        "  {:<w$}  {:>18}  {:>11}  status",
        "parameter", "value", "std"
    );
    for p in &est.params {
        let status = if p.known {
            "known (fixed by the spec)"
        } else if p.held {
            "held at nominal (gauge rule)"
        } else if p.identifiable {
            "identifiable"
        } else {
            "fitted (only a combination is identifiable)"
        };
        let std = p
            .std
            .map_or_else(|| "-".to_string(), |v| format!("{v:.3e}"));
        let _ = writeln!(
            s,
            "  {:<w$}  {:>18.12}  {:>11}  {status}",
            p.name, p.value, std
        );
    }
    let _ = writeln!(s);
}

/// The residual RMS, the paper's `err_rms` when there is one, and the robust fit's summary.
fn fit_lines(s: &mut String, est: &Estimate) {
    if let Some(o) = est.orientation_rms {
        let _ = writeln!(
            s,
            "residual rms (position error of the calibrated tool frame): {:.4e} m ({:.3} µm)",
            est.residual_rms,
            est.residual_rms * 1e6
        );
        let _ = writeln!(
            s,
            "orientation rms (angle of the calibrated tool frame's error): {o:.4e} rad ({:.3} µrad)",
            o * 1e6
        );
        if let Some(n) = &est.pose_noise {
            let how = if n.estimated.is_empty() {
                "as stated".to_string()
            } else {
                format!(
                    "{} estimated from the data (variance components, {} rounds)",
                    n.estimated.join(" and "),
                    n.rounds
                )
            };
            let held = n.held_ratio.map_or(String::new(), |r| {
                format!(" (held at the bound of its range; the levels' ratio is {r:.3e})")
            });
            let _ = writeln!(
                s,
                "pose noise: position {:.3e} m, orientation {:.3e} rad per axis ({how}); \
                 orientation weighed {:.4} m/rad{held}",
                n.position_std, n.orientation_std, n.weight
            );
        }
    } else {
        let _ = writeln!(
            s,
            "residual rms (distance of the calibrated tips from the constraint): {:.4e} m ({:.3} µm)",
            est.residual_rms,
            est.residual_rms * 1e6
        );
    }
    if let Some(e) = est.paper_err_rms {
        let _ = writeln!(
            s,
            "paper's err_rms (sec. 5, scatter of the tips about their best line): {:.4e} m ({:.3} µm)",
            e,
            e * 1e6
        );
    }
    if let Some(r) = &est.robust {
        let _ = writeln!(
            s,
            "robust fit: {} loss, c = {} robust σ (σ̂ = {:.3e} m); linear solve reweighted {} \
             rounds ({} below ½); parameter-space fit {} rounds; {} poses down-weighted",
            r.loss,
            r.tuning,
            r.scale,
            r.linear_rounds,
            r.linear_downweighted,
            r.rounds,
            r.downweighted
        );
    }
}

/// The worst poses (at most five), with their standardised residuals when defined.
fn worst_poses_line(s: &mut String, est: &Estimate) {
    if !est.worst_poses.is_empty() {
        let shown: Vec<String> = est
            .worst_poses
            .iter()
            .take(5)
            .map(|w| {
                let z = w
                    .standardized
                    .map_or(String::new(), |z| format!(", z = {z:.1}"));
                match w.pose_parts {
                    // A measured pose: its two errors, not their weighted norm.
                    Some((x, a)) => format!(
                        "pose {} ({}) position {x:.3e} m, orientation {a:.3e} rad{z}",
                        w.pose,
                        w.place()
                    ),
                    None => format!("pose {} ({}) {:.3e} m{z}", w.pose, w.place(), w.residual),
                }
            })
            .collect();
        let _ = writeln!(
            s,
            "worst poses{}: {}",
            if est.worst_poses.iter().any(|w| w.standardized.is_some()) {
                " (ranked by z, the standardised residual)"
            } else {
                ""
            },
            shown.join("; ")
        );
    }
}

/// A list's constraints one by one, and the relations' stated and achieved values.
fn constraint_lines(s: &mut String, est: &Estimate) {
    if !est.constraints.is_empty() {
        let _ = writeln!(
            s,
            "per constraint (nominal → calibrated): residual rms; spread of the tips (points)"
        );
        for c in &est.constraints {
            let spread = match (c.spread_nominal, c.spread) {
                (Some(a), Some(b)) => format!("; spread {a:.3e} → {b:.3e} m"),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "  {} {} ({} poses): {:.3e} → {:.3e} m{spread}",
                c.constraint, c.kind, c.poses, c.residual_rms_nominal, c.residual_rms
            );
        }
    }
    if !est.relations.is_empty() {
        let _ = writeln!(s, "relations (stated; nominal → calibrated):");
        for r in &est.relations {
            let [i, j] = r.between;
            let (what, unit) = if r.kind == "same_normal" {
                ("angle between normals".to_string(), "rad")
            } else {
                (
                    format!("{} {}", r.kind, super::stated(r.value.unwrap_or(f64::NAN))),
                    "m",
                )
            };
            let _ = writeln!(
                s,
                "  {i}–{j} {what}: {:.6} → {:.6} {unit}",
                r.nominal, r.calibrated
            );
        }
    }
    if !est.point_distances.is_empty() {
        let _ = writeln!(
            s,
            "distance between the mean tips of two points (nominal → calibrated):"
        );
        for d in &est.point_distances {
            let [i, j] = d.between;
            let stated = d
                .value
                .map_or_else(String::new, |v| format!(" (stated {} m)", super::stated(v)));
            let _ = writeln!(
                s,
                "  {i}–{j}{stated}: {:.6} → {:.6} m",
                d.nominal, d.calibrated
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::json::{gauge_object, to_value};

    #[test]
    fn short_numbers() {
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(-2.0), "-2");
        assert_eq!(short(1.0 / 3.0), "0.333333");
        assert_eq!(short(1.5e-7), "1.50000e-7");
    }

    #[test]
    fn gauge_strings() {
        let g = vec![("a1".to_string(), 1.0), ("b1".to_string(), -0.5)];
        assert_eq!(gauge_string(&g), "a1 - 0.5·b1");
        assert_eq!(to_value(&gauge_object(&g))["b1"], -0.5);
    }
}
