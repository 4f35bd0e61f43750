//! The HTML report of a calibration (`lincal calibrate … --report OUT.html`): one
//! self-contained file, plots as inline SVG drawn by plotters, no script, no stylesheet or
//! image from anywhere else.
//!
//! Sections, each a `<section>` with a fixed `id`:
//! - `summary`: poses, method, start, `K`, rank, the residual RMS before (nominal model) and
//!   after;
//! - `parameters`: every parameter's nominal, calibrated value, change, std, and whether it
//!   is identifiable, held by the gauge rule, or known;
//! - `gauge`: the directions the data cannot see, in words;
//! - `residuals`: the residual of every pose before and after (log scale);
//! - `histogram`: the histogram of both (log-spaced bins, every pose counted);
//! - `orientation` (measured poses only, after `tip-errors`): each pose's orientation error
//!   before and after;
//! - `worst`: the poses farthest from the constraint (by standardised residual `z`, shown
//!   beside the residual) with their CSV lines;
//! - `leverage`: every pose's leverage `h_l = tr(J_l(JᵀJ)⁻¹J_lᵀ)` in the fit (see
//!   [`Leverage`]) as a plot, and the poses of highest leverage, the ones the fit depends on
//!   most, named with their CSV lines;
//! - `tip-errors` (measured tips only): a 3-D scatter (2-D for planar arms) of the error
//!   vectors, calibrated tip minus measured tip;
//! - `validation` (with `--validate` or `--folds` only): each held-out placement's residuals
//!   and spreads, nominal beside calibrated, and the cross-validation's folds;
//! - `identifiability`: the condition number and every warning, the practical-identifiability
//!   ones marked;
//! - `reproduce`: the command, the lincal version and the SHA-256 of every input file.
//!
//! All text from the user (names, warnings, CSV lines, paths, the command) is escaped. Plots
//! show at most [`MAX_PLOT_POINTS`] points per series (an even sample, the worst poses always
//! in) and say so in their caption; non-finite residuals are left out of the plots and
//! counted. No estimate makes the builder panic: zero poses, NaN residuals and a plot that
//! cannot be drawn give a sentence in place of the plot.
//!
//! # Example
//! ```
//! use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
//! use lincal_core::data::Poses;
//! use lincal_core::report::html::{calibrate_html, Provenance, ReportData};
//! use lincal_core::report::CalibrateReport;
//! let yaml = "name: two_link
//! dim: 2
//! joints:
//!   - {type: revolute, a: a1, home: th1}
//!   - {type: revolute, a: a2, home: th2}
//! params: {a1: {nominal: 0.375}, th1: {nominal: 0}, a2: {nominal: 0.4},
//!          th2: {nominal: 0}, b1: {nominal: -1.7}, b2: {nominal: -0.6}}
//! constraint: {line: {b: [b1, b2]}}
//! ";
//! let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
//! let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
//! let (a1, a2, th2, b1, b2) = (0.375_f64, 0.425_f64, 0.0446_f64, -1.79_f64, -0.56_f64);
//! let mut poses = Poses::default();
//! for i in 0..40 {
//!     let q2 = -2.0 + 0.1 * f64::from(i);
//!     let (wx, wy) = (a1 + a2 * (q2 - th2).cos(), a2 * (q2 - th2).sin());
//!     let c = -1.0 / (b1.hypot(b2) * wx.hypot(wy));
//!     if c.abs() < 1.0 {
//!         poses.q.push(&[c.acos() - wy.atan2(wx) + b2.atan2(b1), q2]);
//!         poses.constraint.push(0);
//!     }
//! }
//! let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
//! let data = ReportData::compute(&model, &spec, &poses, &est).unwrap();
//! let prov = Provenance {
//!     command: "lincal calibrate two_link.yaml data.csv --report r.html".to_string(),
//!     version: "0.1.0".to_string(),
//!     files: Vec::new(),
//! };
//! let html = calibrate_html(&CalibrateReport::new(&model, &est), &data, &prov);
//! assert!(html.contains(r#"<section id="parameters">"#));
//! assert!(!html.contains("<script"));
//! ```

mod accuracy;
mod format;
mod leverage;
mod page;
mod plot;
mod prior_plot;
mod provenance;
mod report_data;
mod residual_plots;
mod tables;
mod tip_plot;
mod validation;

pub use format::escape;
pub use leverage::{pose_leverage, Leverage, TOP_LEVERAGE};
pub use page::calibrate_html;
pub use plot::MAX_PLOT_POINTS;
pub use provenance::{csv_lines, InputFile, Provenance};
pub use report_data::{ReportData, TipErrors};

/// The section ids of a report, in order (`tip-errors` only for measured tips).
pub const SECTIONS: [&str; 10] = [
    "summary",
    "parameters",
    "gauge",
    "residuals",
    "histogram",
    "worst",
    "leverage",
    "tip-errors",
    "identifiability",
    "reproduce",
];

#[cfg(test)]
mod tests {
    use super::format::{fmt_len, fmt_num};
    use super::plot::sample;
    use super::residual_plots::histogram;
    use super::*;
    use crate::report::{CalibrateReport, GeneralizedParams, Named, ParamReport, PoseReport};

    fn report(n: usize) -> CalibrateReport {
        CalibrateReport {
            name: "arm <&> \"x\"".to_string(),
            params: Named(vec![
                (
                    "a1".to_string(),
                    ParamReport {
                        value: Some(0.375),
                        std: None,
                        identifiable: false,
                        known: false,
                        held: true,
                    },
                ),
                (
                    "a2".to_string(),
                    ParamReport {
                        value: Some(0.43),
                        std: Some(1e-6),
                        identifiable: true,
                        known: false,
                        held: false,
                    },
                ),
            ]),
            identifiable_count: 1,
            basis_size: Some(3),
            poses: n,
            rank: 3,
            residual_rms: None,
            method: "linear".to_string(),
            start: "linear".to_string(),
            prior: crate::calibrate::prior::not_applied(
                crate::calibrate::prior::PriorChoice::Off,
                None,
                0,
            ),
            linear_poses: n,
            condition: Some(12.0),
            worst_poses: (0..n.min(3))
                .map(|l| PoseReport {
                    pose: l,
                    line: l + 2,
                    file: None,
                    residual: Some(1e-5),
                    standardized: Some(1.5),
                    position: None,
                    orientation: None,
                })
                .collect(),
            robust_scale: None,
            rejected: Vec::new(),
            robust: None,
            constraints: Vec::new(),
            relations: Vec::new(),
            point_distances: Vec::new(),
            validation: Vec::new(),
            cross_validation: None,
            orientation_rms: None,
            pose_noise: None,
            covariance: None,
            planes: Vec::new(),
            joint_ranges: Vec::new(),
            warnings: vec![
                "practically unidentifiable: <b>".to_string(),
                "plain & simple".to_string(),
            ],
            basis: Vec::new(),
            generalized_params: GeneralizedParams::Flat(Vec::new()),
            paper_err_rms: None,
        }
    }

    fn data(before: Vec<f64>, after: Vec<f64>, tips: Option<TipErrors>) -> ReportData {
        ReportData {
            nominal: vec![("a1".to_string(), 0.375), ("a2".to_string(), 0.425)],
            gauge: vec![vec![("a1".to_string(), 1.0), ("a2".to_string(), -0.5)]],
            constraints: vec!["line".to_string()],
            before,
            after,
            tip_errors: tips,
            orientation: None,
            leverage: None,
            worst_lines: vec![(2, "0.1,0.2,<x>".to_string())],
            accuracy: None,
        }
    }

    fn prov() -> Provenance {
        Provenance {
            command: "lincal calibrate 'a b.yaml' <d>.csv".to_string(),
            version: "0.1.0".to_string(),
            files: vec![InputFile {
                role: "spec".to_string(),
                path: "a&b.yaml".to_string(),
                bytes: 3,
                sha256: "00".to_string(),
            }],
        }
    }

    fn sections_present(html: &str, tips: bool) {
        for id in SECTIONS {
            let present = html.contains(&format!("<section id=\"{id}\">"));
            assert_eq!(present, id != "tip-errors" || tips, "section {id}");
        }
        assert!(!html.contains("<script"));
        assert!(!html.contains("<b>"));
        assert!(!html.contains("<x>"));
        assert!(!html.contains("<d>"));
    }

    #[test]
    fn escapes_and_has_every_section() {
        let html = calibrate_html(
            &report(5),
            &data(vec![1e-3; 5], vec![1e-6, 2e-6, 0.0, 3e-6, 1e-6], None),
            &prov(),
        );
        sections_present(&html, false);
        assert!(html.contains("arm &lt;&amp;&gt; &quot;x&quot;"));
        assert!(html.contains("warn practical"));
        assert!(html.contains("a&amp;b.yaml"));
        assert!(html.contains("0.1,0.2,&lt;x&gt;"));
        // The worst poses' standardised residuals, in their own column.
        assert!(html.contains(">z</th>"));
        assert!(html.contains("<td class=\"num\">1.5</td>"));
        assert!(html.matches("<svg").count() == 2, "two plots");
        assert!(html.contains("The gauge rule holds <code>a1</code>"));
    }

    #[test]
    fn no_poses_nan_and_huge_do_not_panic() {
        let empty = calibrate_html(&report(0), &data(Vec::new(), Vec::new(), None), &prov());
        sections_present(&empty, false);
        assert!(empty.contains("No plot: no poses."));
        let nan = calibrate_html(
            &report(3),
            &data(vec![f64::NAN; 3], vec![f64::INFINITY; 3], None),
            &prov(),
        );
        assert!(nan.contains("No plot: no finite residual to plot."));
        let zero = calibrate_html(&report(3), &data(vec![0.0; 3], vec![0.0; 3], None), &prov());
        assert_eq!(zero.matches("<svg").count(), 2);
        let n = 200_000;
        let before: Vec<f64> = (0..n).map(|l| 1e-3 * (1.0 + (l % 7) as f64)).collect();
        let mut after: Vec<f64> = (0..n).map(|l| 1e-6 * (1.0 + (l % 5) as f64)).collect();
        after[17] = f64::NAN;
        let tips = TipErrors {
            dim: 3,
            poses: (0..n).collect(),
            errors: (0..3 * n).map(|i| 1e-6 * ((i % 11) as f64 - 5.0)).collect(),
        };
        let big = calibrate_html(&report(n), &data(before, after, Some(tips)), &prov());
        sections_present(&big, true);
        assert!(big.contains("every 10th pose is shown"));
        assert!(big.contains("Non-finite residuals left out: 0 before, 1 after."));
        // At most MAX_PLOT_POINTS (plus the worst) circles per series.
        assert!(big.matches("<circle").count() < 3 * (MAX_PLOT_POINTS + 20) + 10);
        assert!(big.len() < 8 << 20, "{} bytes", big.len());
    }

    #[test]
    fn planar_tip_errors() {
        let tips = TipErrors {
            dim: 2,
            poses: vec![0, 1, 2],
            errors: vec![1e-5, -2e-5, 0.0, 3e-5, f64::NAN, 0.0],
        };
        let html = calibrate_html(
            &report(3),
            &data(vec![1e-3; 3], vec![1e-5; 3], Some(tips)),
            &prov(),
        );
        sections_present(&html, true);
        assert!(html.contains("1 non-finite errors left out"));
        assert!(html.contains("x error (µm)"));
    }

    #[test]
    fn numbers_and_histogram() {
        assert_eq!(fmt_num(0.375), "0.375");
        assert_eq!(fmt_num(f64::NAN), "—");
        assert_eq!(fmt_len(2.5e-5), "25.0000 µm");
        // One decade a bin: 0 (below the range) in the first, 1e-6 in the second, 1e-3 in
        // the last, NaN nowhere.
        assert_eq!(
            histogram(&[1e-6, 1e-3, 0.0, f64::NAN], 1e-7, 1e-2, 5),
            vec![1, 1, 0, 0, 1]
        );
        assert_eq!(sample(10, &[3]).1, 1);
        let (idx, stride) = sample(100_000, &[99_999]);
        assert_eq!(stride, 5);
        assert!(idx.contains(&99_999));
    }

    #[test]
    fn hashes_and_lines() {
        let dir = std::env::temp_dir().join(format!("lincal-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("d.csv");
        std::fs::write(&path, "q1,q2\n1,2\r\n3,4\n").unwrap();
        let f = InputFile::hash("data", &path).unwrap();
        assert_eq!(f.bytes, 15);
        assert_eq!(f.sha256.len(), 64);
        let lines = csv_lines(&path, &[3, 2, 2, 0, 99]).unwrap();
        assert_eq!(lines, vec![(2, "1,2".to_string()), (3, "3,4".to_string())]);
        // The SHA-256 of "abc".
        std::fs::write(&path, "abc").unwrap();
        assert_eq!(
            InputFile::hash("data", &path).unwrap().sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
