//! The page: the document head with its stylesheet, the title and navigation, the plot
//! sections as figures, the reproducibility section, and [`calibrate_html`], which puts the
//! sections together in order.
//!
//! Takes the [`CalibrateReport`], the [`ReportData`] and the [`Provenance`]; gives the
//! HTML document.

use std::fmt::Write as _;

use super::format::{escape, fmt_len, rms};
use super::provenance::Provenance;
use super::report_data::ReportData;
use super::residual_plots::{histogram_plot, leverage_plot, orientation_plot, residual_plot};
use super::tables::{
    constraints_section, gauge_section, identifiability_section, parameters_section,
    planes_section, summary_section, worst_poses_section,
};
use super::tip_plot::tip_error_plot;
use crate::report::CalibrateReport;

/// The report as one HTML document (see the module docs).
#[must_use]
pub fn calibrate_html(report: &CalibrateReport, data: &ReportData, prov: &Provenance) -> String {
    let mut s = String::with_capacity(256 * 1024);
    document_head(&mut s, report, prov);
    let (rms_before, _) = rms(&data.before);
    let (rms_after, _) = rms(&data.after);
    title_and_nav(&mut s, report, data, (rms_before, rms_after));
    summary_section(&mut s, report, data, (rms_before, rms_after));
    parameters_section(&mut s, report, data);
    gauge_section(&mut s, report, data);
    constraints_section(&mut s, report);
    super::validation::validation_section(&mut s, report);
    planes_section(&mut s, report);
    prior_section(&mut s, report);
    let worst: Vec<usize> = report.worst_poses.iter().map(|w| w.pose).collect();
    residual_sections(&mut s, data, &worst);
    worst_poses_section(&mut s, report, data);
    leverage_section(&mut s, data);
    tip_errors_section(&mut s, data, &worst);
    accuracy_section(&mut s, data);
    identifiability_section(&mut s, report);
    reproduce_section(&mut s, prov);
    s.push_str("</body>\n</html>\n");
    s
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

/// The report's stylesheet, inline in its head.
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

/// The document's head: the generator, the title and the stylesheet; the body opened.
fn document_head(s: &mut String, report: &CalibrateReport, prov: &Provenance) {
    let name = escape(&report.name);
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"lincal {}\">\n\
         <title>lincal calibration report: {name}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(&prov.version)
    );
}

/// The title with the headline numbers (`rms` before and after), and the navigation to
/// every section (to the tip errors only when there are).
fn title_and_nav(
    s: &mut String,
    report: &CalibrateReport,
    data: &ReportData,
    (rms_before, rms_after): (f64, f64),
) {
    let name = escape(&report.name);
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
        ("prior", "Prior"),
        ("residuals", "Residuals"),
        ("histogram", "Histogram"),
        ("worst", "Worst poses"),
        ("leverage", "Leverage"),
        ("tip-errors", "Tip errors"),
        ("accuracy", "Accuracy map"),
        ("identifiability", "Identifiability"),
        ("reproduce", "Reproduce"),
    ] {
        let shown = match id {
            "tip-errors" => has_tips,
            "accuracy" => data.accuracy.is_some(),
            "prior" => report.prior.selection.is_some(),
            _ => true,
        };
        if shown {
            let _ = write!(s, "<a href=\"#{id}\">{title}</a>");
        }
    }
    s.push_str("</nav>\n");
}

/// Where the calibration can be trusted: the predicted tip uncertainty along each joint.
fn accuracy_section(s: &mut String, data: &ReportData) {
    let Some(map) = &data.accuracy else {
        return;
    };
    s.push_str("<section id=\"accuracy\">\n<h2>Accuracy map</h2>\n");
    let (plot, caption) = super::accuracy::accuracy_plot(map);
    figure(s, plot, &caption);
    s.push_str("</section>\n");
}

/// How the data chose the prior's strength (the cross-validation curve), when they did.
fn prior_section(s: &mut String, report: &CalibrateReport) {
    let Some(sel) = &report.prior.selection else {
        return;
    };
    s.push_str("<section id=\"prior\">\n<h2>Prior strength chosen from the data</h2>\n");
    let (plot, caption) = super::prior_plot::strength_plot(sel);
    figure(s, plot, &caption);
    s.push_str("</section>\n");
}

/// The residual plot and the histogram, each in its section (`worst`: the poses always
/// drawn).
fn residual_sections(s: &mut String, data: &ReportData, worst: &[usize]) {
    s.push_str("<section id=\"residuals\">\n<h2>Residual per pose, before and after</h2>\n");
    let (plot, caption) = residual_plot(data, worst);
    figure(s, plot, &caption);
    s.push_str("</section>\n<section id=\"histogram\">\n<h2>Residual histogram</h2>\n");
    let (plot, caption) = histogram_plot(data);
    figure(s, plot, &caption);
    s.push_str("</section>\n");
}

/// Every pose's leverage in its section: the plot, the poses of highest leverage (pose,
/// line, leverage, share of the sum) and the sum against the rank.
fn leverage_section(s: &mut String, data: &ReportData) {
    s.push_str("<section id=\"leverage\">\n<h2>Leverage per pose</h2>\n");
    let Some(lev) = &data.leverage else {
        s.push_str(
            "<p class=\"none\">No leverage: the fit's Jacobian could not be formed at the \
             estimate.</p>\n</section>\n",
        );
        return;
    };
    let (plot, caption) = leverage_plot(lev);
    figure(s, plot, &caption);
    let sum: f64 = lev.values.iter().filter(|v| v.is_finite()).sum();
    let _ = writeln!(
        s,
        "<p>The fit depends most on these poses (Σ h = {sum:.6}, the rank {} of {} free \
         parameters):</p>",
        lev.rank, lev.free
    );
    s.push_str(
        "<table>\n<tr><th>pose</th><th>line</th><th>leverage h</th><th>share of Σ h</th></tr>\n",
    );
    for &(pose, line, h) in &lev.top {
        let _ = writeln!(
            s,
            "<tr><td class=\"num\">{pose}</td><td class=\"num\">{line}</td>\
             <td class=\"num\">{h:.4}</td><td class=\"num\">{:.1} %</td></tr>",
            100.0 * h / lev.rank.max(1) as f64
        );
    }
    s.push_str("</table>\n</section>\n");
}

/// The measured tips' error scatter in its section, when the spec has measured tips; for
/// measured poses, the orientation error per pose too.
fn tip_errors_section(s: &mut String, data: &ReportData, worst: &[usize]) {
    if let Some(t) = &data.tip_errors {
        s.push_str("<section id=\"tip-errors\">\n<h2>Measured tip errors</h2>\n");
        let (plot, caption) = tip_error_plot(t, worst);
        figure(s, plot, &caption);
        s.push_str("</section>\n");
    }
    if let Some((before, after)) = &data.orientation {
        s.push_str(
            "<section id=\"orientation\">\n<h2>Orientation error per pose, before and after</h2>\n",
        );
        let (plot, caption) = orientation_plot(before, after, worst);
        figure(s, plot, &caption);
        s.push_str("</section>\n");
    }
}

/// The reproducibility section: the version, the command line, the input files' hashes.
fn reproduce_section(s: &mut String, prov: &Provenance) {
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
    s.push_str("</section>\n");
}
