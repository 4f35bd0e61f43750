//! The commands' output: `demo`, text reports, basis JSON extras.

use crate::util::{cases_dir, lincal, spec};

#[test]
fn demo_prints_the_papers_table_beside_ours() {
    let r = lincal(&["demo"]).ok();
    let out = &r.stdout;
    for needle in [
        "AdeptOne",
        "1.13333",
        "1.13323",
        "1.13338",
        "0.0446",
        "0.0445",
        "32.20",
        "35.68",
        "not published",
        "simulated",
        "a2/a1",
        "θh2",
        "err_rms",
    ] {
        assert!(out.contains(needle), "demo output lacks {needle:?}:\n{out}");
    }
    // Our a2/a1 on both data sets within 5e-5 of the simulation's truth 1.13323.
    let numbers = |l: &str| -> Vec<f64> {
        l.split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    let row = out
        .lines()
        .find(|l| l.starts_with("a2/a1") && numbers(l).len() == 5)
        .expect("a2/a1 row with 5 numbers");
    let nums = numbers(row);
    for ours in &nums[3..] {
        assert!((ours - 1.13323).abs() < 5e-5, "{row}");
    }
    let err = out
        .lines()
        .find(|l| l.starts_with("err_rms") && numbers(l).len() == 4)
        .expect("err_rms row with 4 numbers");
    let nums = numbers(err);
    for ours in &nums[2..] {
        assert!((25.0..45.0).contains(ours), "{err}");
    }
}

#[test]
fn basis_text_is_a_readable_table() {
    let s = cases_dir().join("adept_line/spec.yaml");
    let r = lincal(&["basis".as_ref(), s.as_os_str()]).ok();
    for needle in [
        "basis functions",
        "K = 5",
        "c1*c2 - s1*s2",
        "identifiable combinations: 4",
        "gauge directions",
        "th2",
    ] {
        assert!(r.stdout.contains(needle), "lacks {needle:?}:\n{}", r.stdout);
    }
}

#[test]
fn basis_json_extras() {
    let s = spec("point_planar3.yaml");
    let b = lincal(&[
        "basis".as_ref(),
        s.as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ])
    .ok()
    .json();
    assert_eq!(b["name"], "point_planar3");
    assert_eq!(b["joints"], 3);
    assert_eq!(b["equations"], 2);
    assert_eq!(b["identifiable_count"], 6);
    assert_eq!(b["params"].as_array().map(Vec::len), Some(8));
    let k = b["basis_size"].as_u64().expect("K") as usize;
    let gp = b["generalized_params"]
        .as_array()
        .expect("generalized_params");
    assert_eq!(gp.len(), 2);
    assert!(gp.iter().all(|row| row.as_array().map(Vec::len) == Some(k)));
    // Known parameters are not estimated.
    let m = lincal(&[
        "basis".as_ref(),
        spec("measured_spatial.yaml").as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ])
    .ok()
    .json();
    assert_eq!(m["gauge"].as_array().map(Vec::len), Some(0));
    assert_eq!(m["unidentifiable"].as_array().map(Vec::len), Some(0));
}

#[test]
fn calibrate_text_is_a_readable_table() {
    let dir = cases_dir().join("adept_line");
    let r = lincal(&[
        "calibrate".as_ref(),
        dir.join("spec.yaml").as_os_str(),
        dir.join("data.csv").as_os_str(),
    ])
    .ok();
    for needle in [
        "parameter",
        "value",
        "std",
        "th2",
        "held at nominal",
        "residual rms",
        "err_rms",
    ] {
        assert!(r.stdout.contains(needle), "lacks {needle:?}:\n{}", r.stdout);
    }
}

#[test]
fn known_params_are_reported_with_null_std() {
    let dir = crate::util::scratch("known-param");
    let text = std::fs::read_to_string(spec("circle_planar3.yaml"))
        .expect("spec")
        .replace("r: {nominal: 0.3}", "r: {nominal: 0.3, known: true}");
    let s = crate::util::write(&dir, "spec.yaml", &text);
    let sim = lincal(&[
        "simulate".as_ref(),
        s.as_os_str(),
        "--poses".as_ref(),
        "40".as_ref(),
    ])
    .ok();
    let d = crate::util::write(&dir, "data.csv", &sim.stdout);
    let r = lincal(&[
        "calibrate".as_ref(),
        s.as_os_str(),
        d.as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ])
    .ok()
    .json();
    let rp = &r["params"]["r"];
    assert_eq!(rp["known"], true);
    assert!(rp["std"].is_null());
    assert_eq!(rp["value"], 0.3);
    // With the radius known, the scale is fixed: a1 becomes identifiable.
    assert_eq!(r["params"]["a1"]["identifiable"], true);
}

/// The weak-direction prior's size: a weight against the mean squared residual (the default,
/// tolerances `σ̂/√(N·W)`) or fixed tolerances, not both; each a positive number.
#[test]
fn prior_weight_and_tolerances_are_one_or_the_other() {
    let dir = cases_dir().join("adept_line");
    let (s, d) = (dir.join("spec.yaml"), dir.join("data.csv"));
    let run = |extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "calibrate".as_ref(),
            s.as_os_str(),
            d.as_os_str(),
            "--format".as_ref(),
            "json".as_ref(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        lincal(&args)
    };
    let prior = |extra: &[&str]| run(extra).ok().json()["prior"].clone();
    // By default the data choose the strength: no weight.
    let chosen = prior(&["--refine"]);
    assert!(chosen["weight"].is_null(), "{chosen}");
    assert!(chosen["applied"].as_bool().unwrap_or(false), "{chosen}");
    assert_eq!(
        chosen["selection"]["curve"].as_array().map(Vec::len),
        Some(25)
    );
    let default = prior(&["--prior-weight", "1e-4"]);
    assert_eq!(default["weight"].as_f64(), Some(1e-4), "{default}");
    let four = prior(&["--prior-weight", "4e-4"]);
    assert_eq!(four["weight"].as_f64(), Some(4e-4), "{four}");
    let tolerance = |p: &serde_json::Value| p["length_tolerance"].as_f64().expect("tolerance");
    let (a, b) = (tolerance(&default), tolerance(&four));
    let sigma = default["sigma"].as_f64().expect("sigma");
    // Four times the weight, half the tolerance; both from the same noise level, `σ̂/√(N·W)`.
    assert!((a - 2.0 * b).abs() < 1e-12 * a, "{a} {b}");
    assert_eq!(default["angle_tolerance"].as_f64(), Some(a));
    let n = default_poses(&d);
    assert!(
        (a - sigma / (n * 1e-4).sqrt()).abs() < 1e-12 * a,
        "{a} {sigma} {n}"
    );
    let fixed = prior(&["--tolerance-length", "0.02"]);
    assert!(fixed["weight"].is_null(), "{fixed}");
    assert_eq!(fixed["length_tolerance"].as_f64(), Some(0.02));
    assert_eq!(fixed["angle_tolerance"].as_f64(), Some(0.01));
    run(&["--prior-weight", "1e-4", "--tolerance-length", "0.01"])
        .fails(2, &["--prior-weight", "--tolerance-length"]);
    for bad in [
        "--prior-weight=-1",
        "--prior-weight=0",
        "--prior-weight=nan",
        "--prior-weight=1e300",
        "--prior-weight=1e-13",
    ] {
        run(&[bad]).fails(2, &["--prior-weight"]);
    }
}

/// The poses of a data file with a header row.
fn default_poses(data: &std::path::Path) -> f64 {
    let text = std::fs::read_to_string(data).expect("data");
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .count() as f64
}
