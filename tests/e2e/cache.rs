//! The spec-facts cache (`src/facts_cache.rs`) only saves time: every output is the same
//! with the cache cold, warm, corrupted, of the wrong shape or off.

use crate::util::{lincal_with, scratch, spec, write};
use std::ffi::OsStr;
use std::path::Path;

/// `calibrate` JSON of `spec_path` on `data` with the cache in `dir` (or off).
fn calibrate(spec_path: &Path, data: &Path, dir: Option<&Path>, extra: &[&str]) -> String {
    let mut args = vec![
        "calibrate".as_ref(),
        spec_path.as_os_str(),
        data.as_os_str(),
        "--format".as_ref(),
        "json".as_ref(),
    ];
    args.extend(extra.iter().map(OsStr::new));
    let env: Vec<(&str, &OsStr)> = match dir {
        Some(d) => vec![("LINCAL_CACHE_DIR", d.as_os_str())],
        None => vec![("LINCAL_CACHE", OsStr::new("off"))],
    };
    lincal_with(&args, &env).ok().stdout
}

/// The cache's files.
fn files(dir: &Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .map(|r| r.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default()
}

/// One spec and data set through every state of the cache.
fn same_in_every_state(name: &str, spec_path: &Path, poses: &str, extra: &[&str], start: &str) {
    let dir = scratch(name);
    let cache = dir.join("cache");
    let sim = lincal_with(
        &[
            "simulate",
            &spec_path.to_string_lossy(),
            "--poses",
            poses,
            "--seed",
            "5",
        ],
        &[("LINCAL_CACHE", OsStr::new("off"))],
    )
    .ok();
    let data = write(&dir, "data.csv", &sim.stdout);
    let off = calibrate(spec_path, &data, None, extra);
    let v: serde_json::Value = serde_json::from_str(&off).expect("JSON");
    assert_eq!(v["start"], start, "{name}");
    assert!(
        v["basis_size"].as_u64().is_some(),
        "{name}: {}",
        v["basis_size"]
    );
    let cold = calibrate(spec_path, &data, Some(&cache), extra);
    assert_eq!(cold, off, "{name}: cold cache");
    let stored = files(&cache);
    assert_eq!(stored.len(), 1, "{name}: one file per spec");
    let warm = calibrate(spec_path, &data, Some(&cache), extra);
    assert_eq!(warm, off, "{name}: warm cache");
    // Facts of another shape (one parameter fewer) are not used.
    let text = std::fs::read_to_string(&stored[0]).expect("cache file");
    let mut facts: serde_json::Value = serde_json::from_str(&text).expect("cache JSON");
    if let Some(a) = facts["identifiability"]["held"].as_array_mut() {
        a.pop();
    }
    std::fs::write(&stored[0], facts.to_string()).expect("write");
    assert_eq!(
        calibrate(spec_path, &data, Some(&cache), extra),
        off,
        "{name}: wrong shape"
    );
    // Garbage is ignored (and replaced).
    std::fs::write(&stored[0], b"\xff{not json").expect("write");
    assert_eq!(
        calibrate(spec_path, &data, Some(&cache), extra),
        off,
        "{name}: garbage"
    );
    let text = std::fs::read_to_string(&stored[0]).expect("rewritten cache file");
    assert!(
        text.contains("identifiability"),
        "{name}: not rewritten: {text}"
    );
    // A cache directory that cannot be created costs nothing either.
    let blocked = write(&dir, "a-file", "");
    assert_eq!(
        calibrate(spec_path, &data, Some(&blocked.join("sub")), extra),
        off,
        "{name}: unwritable"
    );
}

#[test]
fn a_fit_from_the_nominals_is_the_same_with_the_cache_in_any_state() {
    // 12 measured poses for K > 12: the nominal start, K reported after the fit.
    same_in_every_state(
        "cache-nominal",
        &spec("measured_spatial.yaml"),
        "12",
        &["--refine"],
        "nominal",
    );
}

#[test]
fn a_linear_fit_is_the_same_with_the_cache_in_any_state() {
    same_in_every_state(
        "cache-linear",
        &spec("line_planar4.yaml"),
        "60",
        &[],
        "linear",
    );
}
