//! The shared reference cases (`../shared/cases/*/`): `basis` and `calibrate` through the
//! binary, every check of `expected.json` within its tolerance.

use std::path::Path;

use serde_json::Value;

use crate::util::{cases_dir, failed_checks, lincal, values, Check};

/// Every case folder (with `spec.yaml`, `data.csv`, `expected.json`), sorted.
fn cases() -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(cases_dir())
        .expect("../shared/cases is readable")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("expected.json").is_file())
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no reference cases found");
    v
}

fn expected(dir: &Path) -> Value {
    let text = std::fs::read_to_string(dir.join("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("expected.json is JSON")
}

/// The spec's parameter names, in order, read back from `basis` (estimated) — used to check
/// that `calibrate` lists every parameter.
fn spec_param_names(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("spec.yaml")).expect("spec.yaml");
    let spec = lincal::spec::from_yaml_str(&text, None).expect("the case spec loads");
    spec.params.iter().map(|p| p.name.clone()).collect()
}

#[test]
fn basis_matches_expected() {
    for dir in cases() {
        let exp = expected(&dir);
        let spec = dir.join("spec.yaml");
        let b = lincal(&[
            "basis".as_ref(),
            spec.as_os_str(),
            "--format".as_ref(),
            "json".as_ref(),
        ])
        .ok()
        .json();
        let name = dir.display();
        assert_eq!(b["basis_size"], exp["basis_size"], "{name}: basis_size");
        assert_eq!(
            b["identifiable_count"], exp["identifiable_count"],
            "{name}: identifiable_count"
        );
        let k = b["basis_size"].as_u64().unwrap_or(0) as usize;
        assert_eq!(
            b["basis"].as_array().map(Vec::len),
            Some(k),
            "{name}: basis has K strings"
        );
        for field in [
            "name",
            "joints",
            "params",
            "naive_size",
            "identifiable",
            "unidentifiable",
            "gauge",
        ] {
            assert!(!b[field].is_null(), "{name}: basis JSON lacks `{field}`");
        }
        assert!(b["gauge"]
            .as_array()
            .is_some_and(|g| g.iter().all(Value::is_object)));
    }
}

fn run_case(dir: &Path, refine: bool) {
    let exp = expected(dir);
    let spec = dir.join("spec.yaml");
    let data = dir.join("data.csv");
    let mut args = vec![
        "calibrate".as_ref(),
        spec.as_os_str(),
        data.as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ];
    if refine {
        args.push("--refine".as_ref());
    }
    let r = lincal(&args).ok().json();
    let name = format!("{} (refine: {refine})", dir.display());
    assert_eq!(r["basis_size"], exp["basis_size"], "{name}: basis_size");
    assert_eq!(
        r["identifiable_count"], exp["identifiable_count"],
        "{name}: identifiable_count"
    );
    let lines = std::fs::read_to_string(&data)
        .expect("data.csv")
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .count();
    assert_eq!(r["poses"].as_u64(), Some(lines as u64), "{name}: poses");
    assert_eq!(
        r["rank"], exp["basis_size"],
        "{name}: full rank on good data"
    );
    assert!(r["residual_rms"]
        .as_f64()
        .is_some_and(|v| v.is_finite() && v >= 0.0));
    let method = if refine { "linear+refine" } else { "linear" };
    assert_eq!(
        r["method"], method,
        "{name}: method (warnings: {})",
        r["warnings"]
    );
    assert!(r["warnings"].is_array());
    for p in spec_param_names(dir) {
        let e = &r["params"][&p];
        assert!(e["value"].is_f64(), "{name}: params.{p}.value");
        assert!(
            e["std"].is_f64() || e["std"].is_null(),
            "{name}: params.{p}.std"
        );
        assert!(
            e["identifiable"].is_boolean() && e["known"].is_boolean(),
            "{name}: params.{p}"
        );
    }
    let vars = values(&r);
    let checks: Vec<Check<'_>> = exp["checks"]
        .as_array()
        .expect("checks")
        .iter()
        .map(|c| Check {
            expr: c["expr"].as_str().expect("expr"),
            truth: c["true"].as_f64().expect("true"),
            tol: c["tolerance"].as_f64().expect("tolerance"),
            rad: c["unit"] == "rad",
        })
        .collect();
    assert!(!checks.is_empty());
    let bad = failed_checks(&checks, &vars);
    assert!(bad.is_empty(), "{name}: checks failed:\n{}", bad.join("\n"));
}

#[test]
fn calibrate_meets_every_check_linear() {
    for dir in cases() {
        run_case(&dir, false);
    }
}

#[test]
fn calibrate_meets_every_check_refined() {
    for dir in cases() {
        run_case(&dir, true);
    }
}
