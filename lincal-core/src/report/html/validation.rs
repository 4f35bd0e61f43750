//! The held-out validation and cross-validation section (`id="validation"`), only when
//! `--validate` or `--folds` asked for them, and the distances between pinned points' mean
//! tips.

use std::fmt::Write as _;

use super::format::escape;
use crate::calibrate::validation::{CrossValidation, Evaluation};
use crate::report::CalibrateReport;

fn len(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e} m")
    } else {
        "–".to_string()
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_string(), len)
}

/// The distances between the mean tips of every pair of pinned points (inside the
/// constraints section).
pub(crate) fn point_distances_table(s: &mut String, report: &CalibrateReport) {
    if report.point_distances.is_empty() {
        return;
    }
    s.push_str(
        "<table>\n<tr><th>points</th><th>stated distance</th>\
         <th>distance between mean tips, nominal</th><th>calibrated</th></tr>\n",
    );
    for d in &report.point_distances {
        let _ = writeln!(
            s,
            "<tr><td>{}, {}</td><td>{}</td><td>{:.6} m</td><td>{:.6} m</td></tr>",
            d.between[0],
            d.between[1],
            d.value
                .map_or_else(|| "–".to_string(), |v| format!("{v} m")),
            d.nominal,
            d.calibrated
        );
    }
    s.push_str(
        "</table>\n<p>Distance between the means of the predicted tips of two pinned points \
         (what a user measures between two sockets).</p>\n",
    );
}

/// The validation section, when there is anything to show.
pub(crate) fn validation_section(s: &mut String, report: &CalibrateReport) {
    if report.validation.is_empty() && report.cross_validation.is_none() {
        return;
    }
    s.push_str("<section id=\"validation\">\n<h2>Held-out validation</h2>\n");
    for (i, e) in report.validation.iter().enumerate() {
        evaluation_table(s, i, e);
    }
    if let Some(cv) = &report.cross_validation {
        cross_validation_table(s, cv);
    }
    s.push_str("</section>\n");
}

fn evaluation_table(s: &mut String, i: usize, e: &Evaluation) {
    let _ = writeln!(
        s,
        "<h3>Placement {i}: {}</h3>\n<p>{} poses; residual RMS nominal {}, calibrated {}{}. \
         The unknown constraint values are refitted to the held-out tips (the fixture has \
         moved), the arm's parameters fixed.</p>",
        escape(&e.files.join(", ")),
        e.poses,
        len(e.residual_rms_nominal),
        len(e.residual_rms),
        match (e.spread_pooled_nominal, e.spread_pooled) {
            (Some(a), Some(b)) =>
                format!("; spread pooled over the points {} → {}", len(a), len(b)),
            _ => String::new(),
        }
    );
    s.push_str(
        "<table>\n<tr><th>constraint</th><th>kind</th><th>poses</th>\
         <th>residual rms, nominal</th><th>calibrated</th><th>max, nominal</th>\
         <th>calibrated</th><th>spread, nominal</th><th>calibrated</th></tr>\n",
    );
    for c in &e.constraints {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td></tr>",
            c.constraint,
            c.kind,
            c.poses,
            len(c.residual_rms_nominal),
            len(c.residual_rms),
            len(c.max_residual_nominal),
            len(c.max_residual),
            opt(c.spread_nominal),
            opt(c.spread)
        );
    }
    s.push_str("</table>\n");
    if !e.point_pairs.is_empty() {
        s.push_str(
            "<table>\n<tr><th>points</th><th>stated</th><th>distance of means, nominal</th>\
             <th>calibrated</th><th>error, nominal</th><th>calibrated</th></tr>\n",
        );
        for p in &e.point_pairs {
            let _ = writeln!(
                s,
                "<tr><td>{}, {}</td><td>{}</td><td>{:.6} m</td><td>{:.6} m</td><td>{}</td>\
                 <td>{}</td></tr>",
                p.between[0],
                p.between[1],
                p.value
                    .map_or_else(|| "–".to_string(), |v| format!("{v} m")),
                p.distance_nominal,
                p.distance,
                opt(p.error_nominal),
                opt(p.error)
            );
        }
        s.push_str("</table>\n");
    }
}

fn cross_validation_table(s: &mut String, cv: &CrossValidation) {
    let _ = writeln!(
        s,
        "<h3>Cross-validation, {} folds{} ({})</h3>\n<p>Residual RMS in-sample {}, held-out {} \
         (mean over folds {}). Each fold is fitted on the others with the same options and \
         judged against that fit's constraints.</p>",
        cv.folds,
        if cv.folds < cv.folds_asked {
            format!(" of {} asked", cv.folds_asked)
        } else {
            String::new()
        },
        cv.split,
        len(cv.residual_rms_in_sample),
        len(cv.residual_rms_held_out),
        len(cv.residual_rms_held_out_mean)
    );
    s.push_str(
        "<table>\n<tr><th>fold</th><th>fitted poses</th><th>training rms</th>\
         <th>held-out poses</th><th>held-out rms</th><th>held-out max</th></tr>\n",
    );
    for f in &cv.per_fold {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            f.fold,
            f.train_poses,
            len(f.residual_rms_train),
            f.test_poses,
            len(f.residual_rms_test),
            len(f.max_residual_test)
        );
    }
    for f in &cv.skipped {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td colspan=\"4\">skipped: the fit is undeterminable \
             ({}); {} held-out poses not scored</td></tr>",
            f.fold,
            f.train_poses,
            escape(&f.reason),
            f.test_poses
        );
    }
    s.push_str("</table>\n");
}
