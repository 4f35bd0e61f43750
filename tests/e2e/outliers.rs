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

/// The truth file `lincal simulate --truth-out` wrote: `name: value` lines.
fn truth_values(path: &std::path::Path) -> std::collections::HashMap<String, f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .filter_map(|l| {
            let (k, v) = l.split_once(':')?;
            Some((k.trim().to_string(), v.trim().parse().ok()?))
        })
        .collect()
}

/// The AdeptOne's identifiable combinations (paper sec. 4.1): `a2/a1`, `θh2`, `β + θh1`
/// (`β = atan2(b2, b1)`) and `a1·‖b‖`, from named values.
fn adept_combinations(v: &dyn Fn(&str) -> f64) -> [f64; 4] {
    [
        v("a2") / v("a1"),
        v("th2"),
        crate::util::wrap(v("b2").atan2(v("b1")) + v("th1")),
        v("a1") * v("b1").hypot(v("b2")),
    ]
}

/// One pose in 200 with joint 1 off by 0.5 rad, no refinement: the plain linear solve is
/// pulled far off; `--robust huber` reweights the linear solve itself, and its estimate's
/// identifiable combinations come back to the simulated truth within the noise.
#[test]
fn robust_linear_solve_recovers_the_truth_without_refinement() {
    let dir = scratch("outliers-robust-linear");
    let s = spec("adept_one.yaml").display().to_string();
    let truth_path = dir.join("truth.yaml");
    let out = lincal(&[
        "simulate",
        &s,
        "--poses",
        "200",
        "--seed",
        "21",
        "--noise-track",
        "10e-6",
        "--truth-out",
        &truth_path.display().to_string(),
    ])
    .ok();
    let mut lines: Vec<String> = out.stdout.lines().map(str::to_string).collect();
    let bad = 77;
    let mut cells: Vec<String> = lines[bad + 1].split(',').map(str::to_string).collect();
    let q1: f64 = cells[0].parse().unwrap();
    cells[0] = format!("{:?}", q1 + 0.5);
    lines[bad + 1] = cells.join(",");
    let data = write(&dir, "one-bad.csv", &(lines.join("\n") + "\n"));
    let truth = truth_values(&truth_path);
    let t = adept_combinations(&|n| truth[n]);

    let plain = calibrate(&data, &[]);
    let robust = calibrate(&data, &["--robust", "huber"]);
    assert_eq!(plain["method"], "linear");
    assert_eq!(robust["method"], "linear");
    let r = &robust["robust"];
    assert_eq!(r["loss"], "huber");
    // The linear solve was reweighted, converging before the cap of 20 rounds, and nothing
    // else (no refinement ran); the bad row weighed below ½ (perhaps a noise tail pose too).
    let rounds = r["linear_rounds"].as_u64().unwrap();
    assert!((1..20).contains(&rounds), "{r}");
    assert_eq!(r["rounds"], 0, "{r}");
    let down = r["linear_downweighted"].as_u64().unwrap();
    assert!((1..=3).contains(&down), "{r}");
    assert_eq!(r["downweighted"], r["linear_downweighted"]);
    assert_eq!(robust["worst_poses"][0]["pose"], bad);
    assert!(robust["worst_poses"][0]["standardized"].as_f64().unwrap() > 100.0);

    let v = |j: &serde_json::Value| {
        let j = j.clone();
        adept_combinations(&move |n| j["params"][n]["value"].as_f64().unwrap())
    };
    let (p, q) = (v(&plain), v(&robust));
    let names = ["a2/a1", "th2", "beta+th1", "a1*|b|"];
    for i in 0..4 {
        let (ep, er) = ((p[i] - t[i]).abs(), (q[i] - t[i]).abs());
        eprintln!(
            "{}: truth {:.9}, plain off {ep:.3e}, robust off {er:.3e}",
            names[i], t[i]
        );
        // 10 µm of noise on 200 poses moves each combination by a few 1e-6.
        assert!(er < 2e-5, "{}: robust off by {er:e}", names[i]);
    }
    // Within 3 of its reported standard deviations (from the weighted sandwich, so the bad
    // row does not inflate them): a2 (a1 held) and th2.
    let std = |n: &str| robust["params"][n]["std"].as_f64().unwrap();
    let a1 = robust["params"]["a1"]["value"].as_f64().unwrap();
    assert!(
        std("a2") < 1e-5 && std("th2") < 1e-5,
        "{}",
        robust["params"]
    );
    assert!((q[0] - t[0]).abs() * a1 < 3.0 * std("a2"));
    assert!((q[1] - t[1]).abs() < 3.0 * std("th2"));
    // Much closer: the plain solve's worst error is over 50 times the robust one's.
    let worst = |x: &[f64; 4]| (0..4).map(|i| (x[i] - t[i]).abs()).fold(0.0, f64::max);
    assert!(
        worst(&p) > 50.0 * worst(&q),
        "plain {:e} vs robust {:e}",
        worst(&p),
        worst(&q)
    );
}

/// Exact data (simulated without noise): residuals of rounding, about 10⁻¹⁶ m, whose robust
/// scale is rounding too; no pose is an outlier below a nanometre, so no warning names one,
/// and `--reject-outliers` drops nothing.
#[test]
fn exact_data_has_no_outliers() {
    let dir = scratch("outliers_exact");
    let s = spec("adept_one.yaml").display().to_string();
    let out = lincal(&["simulate", &s, "--poses", "200", "--seed", "6"]).ok();
    let data = write(&dir, "exact.csv", &out.stdout);
    for extra in [&[][..], &["--reject-outliers"][..]] {
        let r = calibrate(&data, extra);
        let warnings = r["warnings"].to_string();
        assert!(
            !warnings.contains("robust standard deviations"),
            "{warnings}"
        );
        assert!(r["rejected"].as_array().is_none_or(Vec::is_empty), "{r}");
        assert!(r["residual_rms"].as_f64().expect("rms") < 1e-12, "{r}");
    }
}
