//! Bad rows: named in a warning always, dropped with `--reject-outliers`, and the fit back at
//! the noise level.

use crate::util::{lincal, scratch, write};

/// The model library's AdeptOne spec.
fn spec(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("lincal-models/specs")
        .join(name)
}

/// Simulated AdeptOne line data (10 µm tracking noise) with joint 1 off by 0.5 rad in `bad`
/// rows (0-based pose indices); the CSV path.
fn corrupted(dir: &std::path::Path, name: &str, bad: &[usize]) -> std::path::PathBuf {
    let s = spec("adept_one.yaml");
    let out = lincal(&[
        "simulate",
        &s.display().to_string(),
        "--poses",
        "200",
        "--seed",
        "5",
        "--noise-track",
        "10e-6",
    ])
    .ok();
    let mut lines: Vec<String> = out.stdout.lines().map(str::to_string).collect();
    for &l in bad {
        let mut cells: Vec<String> = lines[l + 1].split(',').map(str::to_string).collect();
        let q1: f64 = cells[0].parse().unwrap();
        cells[0] = format!("{:?}", q1 + 0.5);
        lines[l + 1] = cells.join(",");
    }
    write(dir, name, &(lines.join("\n") + "\n"))
}

fn calibrate(data: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let s = spec("adept_one.yaml").display().to_string();
    let d = data.display().to_string();
    let mut args = vec!["calibrate", &s, &d, "--format", "json"];
    args.extend_from_slice(extra);
    lincal(&args).ok().json()
}

#[test]
fn one_bad_row_is_named_and_dropped() {
    let dir = scratch("outliers-one");
    let data = corrupted(&dir, "one.csv", &[49]);
    let plain = calibrate(&data, &[]);
    let warnings = plain["warnings"].to_string();
    assert!(
        warnings.contains("1 pose(s) lie beyond 5 robust standard deviations")
            && warnings.contains("pose 49 (line 51)"),
        "{warnings}"
    );
    assert_eq!(plain["worst_poses"][0]["pose"], 49);
    let clean = calibrate(&data, &["--reject-outliers"]);
    assert_eq!(clean["poses"], 199);
    assert_eq!(clean["rejected"].as_array().unwrap().len(), 1);
    assert_eq!(clean["rejected"][0]["pose"], 49);
    assert_eq!(clean["rejected"][0]["line"], 51);
    let rms = clean["residual_rms"].as_f64().unwrap();
    assert!(
        rms < 2e-5,
        "residual rms {rms} after rejection (noise 1e-5)"
    );
    // Pose indices stay those of the file.
    assert!(clean["worst_poses"]
        .as_array()
        .unwrap()
        .iter()
        .all(|w| w["pose"] != 49));
}

#[test]
fn five_percent_bad_rows_are_all_dropped_and_the_ratio_comes_back() {
    let dir = scratch("outliers-many");
    let bad = [3, 17, 40, 58, 77, 101, 122, 150, 171, 196];
    let good = corrupted(&dir, "good.csv", &[]);
    let data = corrupted(&dir, "bad.csv", &bad);
    let truth = calibrate(&good, &[]);
    let polluted = calibrate(&data, &[]);
    let clean = calibrate(&data, &["--reject-outliers"]);
    let mut rejected: Vec<u64> = clean["rejected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["pose"].as_u64().unwrap())
        .collect();
    rejected.sort_unstable();
    assert_eq!(rejected, bad.map(|b| b as u64).to_vec());
    let a2 = |v: &serde_json::Value| v["params"]["a2"]["value"].as_f64().unwrap();
    let std = truth["params"]["a2"]["std"].as_f64().unwrap();
    assert!(
        (a2(&polluted) - a2(&truth)).abs() > 100.0 * std,
        "the bad rows matter"
    );
    assert!(
        (a2(&clean) - a2(&truth)).abs() < 3.0 * std,
        "a2 {} vs {} (std {std})",
        a2(&clean),
        a2(&truth)
    );
    // No outliers: no warning, nothing rejected, the same estimate.
    let same = calibrate(&good, &["--reject-outliers"]);
    assert_eq!(same["rejected"].as_array().unwrap().len(), 0);
    assert_eq!(a2(&same), a2(&truth));
}

#[test]
fn robust_losses_recover_the_ratio_and_report_their_constant() {
    let dir = scratch("outliers-robust");
    let bad = [3, 17, 40, 58, 77, 101, 122, 150, 171, 196];
    let good = corrupted(&dir, "good.csv", &[]);
    let data = corrupted(&dir, "bad.csv", &bad);
    let truth = calibrate(&good, &[]);
    let a2 = |v: &serde_json::Value| v["params"]["a2"]["value"].as_f64().unwrap();
    let std = truth["params"]["a2"]["std"].as_f64().unwrap();
    for (loss, c) in [("huber", 1.345), ("cauchy", 2.385)] {
        let r = calibrate(&data, &["--robust", loss]);
        assert_eq!(r["robust"]["loss"], loss);
        assert_eq!(r["robust"]["tuning"].as_f64(), Some(c));
        // The 10 bad rows, and perhaps a Gaussian tail pose or two.
        let down = r["robust"]["downweighted"].as_u64().unwrap();
        assert!((10..=14).contains(&down), "{loss}: {}", r["robust"]);
        let scale = r["robust"]["scale"].as_f64().unwrap();
        assert!(
            (0.5e-5..2e-5).contains(&scale),
            "{loss}: scale {scale} (noise 1e-5)"
        );
        assert!(
            (a2(&r) - a2(&truth)).abs() < 3.0 * std,
            "{loss}: a2 {} vs {} (std {std})",
            a2(&r),
            a2(&truth)
        );
        // Its std comes from the robust scale: near the clean fit's, not inflated.
        let rstd = r["params"]["a2"]["std"].as_f64().unwrap();
        assert!(rstd < 3.0 * std, "{loss}: std {rstd} vs {std}");
    }
    // Without --robust the field is null.
    assert!(truth["robust"].is_null());
}
