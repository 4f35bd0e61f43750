//! The report's tables and lists: summary, parameters, gauge directions, constraints and
//! relations, worst poses, condition and warnings.
//!
//! Takes the [`CalibrateReport`] and the [`ReportData`]; appends each section's HTML.

use std::fmt::Write as _;

use super::format::{escape, fmt_len, fmt_num, fmt_short};
use super::report_data::ReportData;
use crate::report::CalibrateReport;

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

/// A row of the summary table.
fn row(s: &mut String, k: &str, v: String) {
    let _ = writeln!(s, "<tr><th>{k}</th><td>{v}</td></tr>");
}

/// The summary section: poses, constraints, method, start, `K` and rank, the residual RMS
/// before (nominal) and after (calibrated), then the robust fit's rows.
pub(crate) fn summary_section(
    s: &mut String,
    report: &CalibrateReport,
    data: &ReportData,
    (rms_before, rms_after): (f64, f64),
) {
    s.push_str("<section id=\"summary\">\n<h2>Summary</h2>\n<table>\n");
    row(s, "poses", report.poses.to_string());
    row(s, "constraint(s)", escape(&data.constraints.join(", ")));
    row(
        s,
        "method",
        format!("<code>{}</code>", escape(&report.method)),
    );
    row(
        s,
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
        s,
        "basis size K, rank",
        format!(
            "{}, {}",
            report
                .basis_size
                .map_or_else(|| "not built".to_string(), |k| k.to_string()),
            report.rank
        ),
    );
    row(
        s,
        "identifiable combinations",
        report.identifiable_count.to_string(),
    );
    row(s, "residual RMS before (nominal)", fmt_len(rms_before));
    row(
        s,
        "residual RMS after (calibrated)",
        fmt_len(report.residual_rms.unwrap_or(f64::NAN)),
    );
    if rms_before.is_finite() && rms_after > 0.0 {
        row(s, "improvement", format!("{:.3}×", rms_before / rms_after));
    }
    robust_rows(s, report);
}

/// The summary's rows about the robust fit and rejection (and the paper's `err_rms`); the
/// summary closed.
fn robust_rows(s: &mut String, report: &CalibrateReport) {
    row(
        s,
        "robust scale σ",
        fmt_len(report.robust_scale.unwrap_or(f64::NAN)),
    );
    if let Some(e) = report.paper_err_rms {
        row(s, "paper's err_rms (sec. 5)", fmt_len(e));
    }
    if let Some(r) = &report.robust {
        row(
            s,
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
    if let Some(p) = crate::calibrate::prior::summary(&report.prior) {
        row(s, "weak-direction prior", escape(&p));
    }
    if !report.rejected.is_empty() {
        row(
            s,
            "rejected outliers",
            format!("{} poses (listed under warnings)", report.rejected.len()),
        );
    }
    s.push_str("</table>\n</section>\n");
}

/// The parameters section: every parameter's nominal, calibrated value, change, std and
/// flags.
pub(crate) fn parameters_section(s: &mut String, report: &CalibrateReport, data: &ReportData) {
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
}

/// The gauge section: each direction the data cannot see, in words.
pub(crate) fn gauge_section(s: &mut String, report: &CalibrateReport, data: &ReportData) {
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
}

/// A list's constraints one by one, and the relations, in their section (only when there
/// are).
pub(crate) fn constraints_section(s: &mut String, report: &CalibrateReport) {
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
        super::validation::point_distances_table(s, report);
        s.push_str("</section>\n");
    }
}

/// The planes by normal and offset, unit-normalised, in their section (only when there are).
pub(crate) fn planes_section(s: &mut String, report: &CalibrateReport) {
    if report.planes.is_empty() {
        return;
    }
    s.push_str(
        "<section id=\"planes\">\n<h2>Planes</h2>\n<table>\n<tr><th>constraint</th>\
         <th>unit normal n</th><th>n·x =</th><th>‖n‖ of the fit</th></tr>\n",
    );
    for p in &report.planes {
        let [a, b, c] = p.normal;
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>[{a:.6}, {b:.6}, {c:.6}]</td><td>{:.6} m</td><td>{:.4e}</td></tr>",
            p.constraint, p.offset, p.scale
        );
    }
    s.push_str(
        "</table>\n<p>The fitted normal and offset divided by the normal's length: the offset \
         is the plane's signed distance from the base origin.</p>\n</section>\n",
    );
}

/// The worst poses' section: each pose's residual, `z`, residual before, and CSV line.
pub(crate) fn worst_poses_section(s: &mut String, report: &CalibrateReport, data: &ReportData) {
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
                match (w.position, w.orientation) {
                    // A measured pose: its two errors, not their weighted norm.
                    (Some(x), Some(o)) => format!("{} · {o:.3e} rad", fmt_len(x)),
                    _ => fmt_len(w.residual.unwrap_or(f64::NAN)),
                },
                w.standardized
                    .map_or_else(|| "—".to_string(), |z| format!("{z:.1}")),
                fmt_len(data.before.get(w.pose).copied().unwrap_or(f64::NAN)),
            );
        }
        s.push_str("</table>\n");
    }
    s.push_str("</section>\n");
}

/// The identifiability section: the condition number judged, and every warning (the
/// practical-identifiability ones marked).
pub(crate) fn identifiability_section(s: &mut String, report: &CalibrateReport) {
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
}
