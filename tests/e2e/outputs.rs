//! Outputs never overwrite an input or each other, and a run that fails writes nothing
//! (issue 25, class 1; `src/outputs.rs`).

use crate::util::{lincal, scratch, spec, write};
use std::path::{Path, PathBuf};

fn p(path: &Path) -> String {
    path.display().to_string()
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).expect("file")
}

/// A scratch directory, the planar line spec and 60 simulated poses of it.
fn line_data(name: &str) -> (PathBuf, PathBuf, PathBuf) {
    let dir = scratch(name);
    let s = spec("line_planar4.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "60", "--seed", "2"]).ok();
    let d = write(&dir, "data.csv", &sim.stdout);
    (dir, s, d)
}

#[test]
fn an_output_that_is_an_input_or_another_output_is_refused_before_the_fit() {
    let (dir, s, d) = line_data("outputs-distinct");
    let before = read(&d);
    // The report over the data, by its own name and by another spelling.
    let dotted = dir.join(".").join("data.csv");
    for target in [&d, &dotted] {
        lincal(&["calibrate", &p(&s), &p(&d), "--report", &p(target)])
            .fails(2, &["--report", "data file", "same file"]);
        assert_eq!(read(&d), before, "the data were overwritten");
    }
    // The calibrated spec over the data; one output over another.
    lincal(&["calibrate", &p(&s), &p(&d), "--write-spec", &p(&d)])
        .fails(2, &["--write-spec", "data file"]);
    let o = dir.join("o");
    lincal(&[
        "calibrate",
        &p(&s),
        &p(&d),
        "--write-spec",
        &p(&o),
        "--report",
        &p(&o),
    ])
    .fails(2, &["--report", "--write-spec"]);
    assert!(!o.exists(), "an output was written by a refused run");
    assert_eq!(read(&d), before);
    // The truth over the spec it simulates.
    let copy = write(
        &dir,
        "spec.yaml",
        &String::from_utf8(read(&s)).expect("utf-8"),
    );
    let spec_before = read(&copy);
    lincal(&[
        "simulate",
        &p(&copy),
        "--poses",
        "3",
        "--truth-out",
        &p(&copy),
    ])
    .fails(2, &["--truth-out", "spec"]);
    assert_eq!(read(&copy), spec_before, "the spec was overwritten");
}

#[test]
fn a_check_that_fails_after_the_fit_writes_nothing() {
    // `--write-urdf` without the spec's `urdf:` record: refused before the fit, so the
    // calibrated spec asked for beside it is not written either.
    let (dir, s, d) = line_data("outputs-nothing-written");
    let out_spec = dir.join("calibrated.yaml");
    let out_urdf = dir.join("calibrated.urdf");
    lincal(&[
        "calibrate",
        &p(&s),
        &p(&d),
        "--write-spec",
        &p(&out_spec),
        "--write-urdf",
        &p(&out_urdf),
    ])
    .fails(2, &["urdf"]);
    assert!(!out_spec.exists() && !out_urdf.exists());
    // Without the URDF, the spec is written, whole, and no temporary file is left.
    lincal(&["calibrate", &p(&s), &p(&d), "--write-spec", &p(&out_spec)]).ok();
    let text = std::fs::read_to_string(&out_spec).expect("written spec");
    assert!(text.contains("constraint"), "{text}");
    let tmp: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(tmp.is_empty(), "temporary files left: {tmp:?}");
}

#[test]
fn a_simulation_that_places_no_pose_leaves_no_truth_file_and_no_header() {
    let dir = scratch("outputs-simulate-unreachable");
    // The planar 3R arm reaches 0.9 m at most: a nominal point 5 m away cannot be placed.
    let text = std::fs::read_to_string(spec("point_planar3.yaml")).expect("spec");
    let far = write(
        &dir,
        "far.yaml",
        &text.replace("px: {nominal: 0.45}", "px: {nominal: 5.0}"),
    );
    let truth = dir.join("truth.yaml");
    let run = lincal(&[
        "simulate",
        &p(&far),
        "--poses",
        "3",
        "--truth-out",
        &p(&truth),
    ])
    .fails(1, &["could place only 0 of 3 poses"]);
    assert_eq!(run.stdout, "", "a header-only CSV was written");
    assert!(!truth.exists(), "a truth file was left for data never made");
    // A run that places its poses writes both, the truth first.
    let sim = lincal(&[
        "simulate",
        &p(&spec("point_planar3.yaml")),
        "--poses",
        "3",
        "--truth-out",
        &p(&truth),
    ])
    .ok();
    assert_eq!(sim.stdout.lines().count(), 4, "header and 3 rows");
    assert!(truth.exists(), "the truth file");
}
