//! Held-out validation through the CLI (issue 22, items 6 and 8): `lincal evaluate`,
//! `calibrate --validate` and `calibrate --folds`, on a planar arm with a ball in two sockets
//! 50 mm apart, the part at two placements, data one headerless file per socket.

use crate::util::{lincal, scratch, write};
use serde_json::Value;
use std::path::{Path, PathBuf};

const SPEC: &str = "name: sockets_planar3
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-3.0, 3.0]}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0.0}
  a2: {nominal: 0.3}
  th2: {nominal: 0.0}
  a3: {nominal: 0.2}
  th3: {nominal: 0.0}
  p0x: {nominal: 0.45}
  p0y: {nominal: 0.2}
  p1x: {nominal: 0.45}
  p1y: {nominal: 0.25}
constraints:
  - point: {p: [p0x, p0y]}
  - point: {p: [p1x, p1y]}
relations:
  - {distance: [0, 1], value: 0.05}
";

/// The true arm (a1, th2 off their nominals) with the sockets at `p`.
fn truth(p: [f64; 4]) -> String {
    format!(
        "a1: 0.41\nth1: 0.0\na2: 0.295\nth2: 0.02\na3: 0.205\nth3: -0.015\n\
         p0x: {}\np0y: {}\np1x: {}\np1y: {}\n",
        p[0], p[1], p[2], p[3]
    )
}

/// Simulates a placement and writes one headerless file per socket (`name_0.csv`,
/// `name_1.csv`, columns q1,q2,q3).
fn placement(dir: &Path, name: &str, sockets: [f64; 4], seed: u64, noise: f64) -> Vec<PathBuf> {
    let spec = dir.join("spec.yaml");
    let t = write(dir, &format!("{name}_truth.yaml"), &truth(sockets));
    let run = lincal(&[
        "simulate".as_ref(),
        spec.as_os_str(),
        "--poses".as_ref(),
        "40".as_ref(),
        "--seed".as_ref(),
        seed.to_string().as_ref(),
        "--truth".as_ref(),
        t.as_os_str(),
        "--noise-track".as_ref(),
        noise.to_string().as_ref(),
    ])
    .ok();
    let mut files = [String::new(), String::new()];
    for line in run.stdout.lines().skip(1) {
        let (q, c) = line.rsplit_once(',').expect("q…,constraint");
        let c: usize = c.parse().expect("a constraint index");
        files[c].push_str(q);
        files[c].push('\n');
    }
    files
        .iter()
        .enumerate()
        .map(|(i, text)| write(dir, &format!("{name}_{i}.csv"), text))
        .collect()
}

fn setup(name: &str, noise: f64) -> (PathBuf, Vec<PathBuf>, Vec<PathBuf>) {
    let dir = scratch(name);
    write(&dir, "spec.yaml", SPEC);
    let train = placement(&dir, "hole", [0.45, 0.2, 0.45, 0.25], 3, noise);
    // The part moved: the sockets elsewhere, still 50 mm apart.
    let held = placement(&dir, "moved", [0.30, 0.20, 0.33, 0.24], 4, noise);
    (dir, train, held)
}

const HEADERLESS: [&str; 3] = ["--no-header", "--columns", "q1,q2,q3"];

fn args(parts: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<std::ffi::OsString> {
    parts.iter().map(|p| p.as_ref().to_os_string()).collect()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn calibrate_validate_and_folds_on_noise_free_data() {
    let (dir, train, held) = setup("validation_exact", 0.0);
    let spec = dir.join("spec.yaml");
    let report = dir.join("report.html");
    let placement = format!("{},{}", held[0].display(), held[1].display());
    let mut a = args(&[&"calibrate", &spec, &train[0], &train[1], &"--refine"]);
    a.extend(args(&[&HEADERLESS[0], &HEADERLESS[1], &HEADERLESS[2]]));
    a.extend(args(&[
        &"--validate",
        &placement,
        &"--folds",
        &"4",
        &"--report",
        &report,
    ]));
    let mut json = a.clone();
    json.extend(args(&[&"--format", &"json"]));
    let r = lincal(&json).ok().json();
    // Item 8: the distance between the mean tips, its own field.
    let d = &r["point_distances"][0];
    assert_eq!(d["between"], serde_json::json!([0, 1]));
    assert!((f(&d["calibrated"]) - 0.05).abs() < 1e-9, "{d}");
    assert!((f(&d["nominal"]) - 0.05).abs() > 1e-4, "{d}");
    // The held-out placement: unknown sockets refitted, residual ~0, the true distance.
    let v = &r["validation"][0];
    assert_eq!(v["poses"], 40);
    assert_eq!(v["files"].as_array().unwrap().len(), 2);
    assert!(f(&v["residual_rms"]) < 1e-9, "{v}");
    assert!(f(&v["residual_rms_nominal"]) > 1e-4, "{v}");
    assert!(f(&v["spread_pooled"]) < 1e-9);
    let pair = &v["point_pairs"][0];
    assert!((f(&pair["distance"]) - 0.05).abs() < 1e-9, "{pair}");
    assert!(f(&pair["error"]).abs() < 1e-9);
    for c in v["constraints"].as_array().unwrap() {
        assert!(
            f(&c["spread"]) < 1e-9 && f(&c["residual_rms"]) < 1e-9,
            "{c}"
        );
    }
    let m = &v["constraints"][0]["mean"];
    assert!(
        (f(&m[0]) - 0.30).abs() < 1e-9 && (f(&m[1]) - 0.20).abs() < 1e-9,
        "{m}"
    );
    // Cross-validation: every pose held out once, ~0 held out.
    let cv = &r["cross_validation"];
    assert_eq!(cv["folds"], 4);
    assert_eq!(cv["per_fold"].as_array().unwrap().len(), 4);
    assert!(f(&cv["residual_rms_held_out"]) < 1e-9, "{cv}");
    let html = std::fs::read_to_string(&report).expect("the report");
    assert!(html.contains("<section id=\"validation\">") && html.contains("Cross-validation"));
    assert!(html.contains("distance between mean tips"));
    // Text: the sections.
    let text = lincal(&a).ok().stdout;
    assert!(text.contains("validation 0: held-out poses: 40"), "{text}");
    assert!(
        text.contains("cross-validation (4 folds, joint-space clusters)"),
        "{text}"
    );
    assert!(
        text.contains("distance between the mean tips of two points"),
        "{text}"
    );
    // Without the options: no new field.
    let mut plain = args(&[&"calibrate", &spec, &train[0], &train[1], &"--refine"]);
    plain.extend(args(&[
        &HEADERLESS[0],
        &HEADERLESS[1],
        &HEADERLESS[2],
        &"--format",
        &"json",
    ]));
    let p = lincal(&plain).ok().json();
    assert!(p.get("validation").is_none() && p.get("cross_validation").is_none());
    // `evaluate` on the result: the same figures; with --nominal, both sides nominal.
    let result = write(&dir, "result.json", &serde_json::to_string(&p).unwrap());
    let mut ev = args(&[&"evaluate", &spec, &"--params", &result, &held[0], &held[1]]);
    ev.extend(args(&[
        &HEADERLESS[0],
        &HEADERLESS[1],
        &HEADERLESS[2],
        &"--format",
        &"json",
    ]));
    let e = lincal(&ev).ok().json();
    assert!(f(&e["residual_rms"]) < 1e-9, "{e}");
    assert_eq!(e["residual_rms_nominal"], v["residual_rms_nominal"]);
    assert!((f(&e["point_pairs"][0]["distance"]) - 0.05).abs() < 1e-9);
    let mut nom = args(&[&"evaluate", &spec, &"--nominal", &held[0], &held[1]]);
    nom.extend(args(&[
        &HEADERLESS[0],
        &HEADERLESS[1],
        &HEADERLESS[2],
        &"--format",
        &"json",
    ]));
    let n = lincal(&nom).ok().json();
    assert_eq!(n["params"], "nominal");
    assert_eq!(n["residual_rms"], n["residual_rms_nominal"]);
    let mut text = args(&[&"evaluate", &spec, &"--nominal", &held[0], &held[1]]);
    text.extend(args(&[&HEADERLESS[0], &HEADERLESS[1], &HEADERLESS[2]]));
    let t = lincal(&text).ok().stdout;
    assert!(
        t.contains("distance between the mean tips of 0 and 1 (stated 0.05 m)"),
        "{t}"
    );
}

#[test]
fn folds_on_noisy_data_hold_out_about_the_noise() {
    let sigma = 2e-4;
    let (dir, train, _) = setup("validation_noisy", sigma);
    let spec = dir.join("spec.yaml");
    let mut a = args(&[
        &"calibrate",
        &spec,
        &train[0],
        &train[1],
        &"--refine",
        &"--folds",
        &"5",
    ]);
    a.extend(args(&[
        &HEADERLESS[0],
        &HEADERLESS[1],
        &HEADERLESS[2],
        &"--format",
        &"json",
    ]));
    let r = lincal(&a).ok().json();
    let cv = &r["cross_validation"];
    let (held, ins) = (
        f(&cv["residual_rms_held_out"]),
        f(&cv["residual_rms_in_sample"]),
    );
    assert_eq!(ins, f(&r["residual_rms"]));
    assert!(held >= 0.95 * ins, "held out {held} vs in-sample {ins}");
    let level = sigma * 2f64.sqrt();
    assert!(
        held > 0.5 * level && held < 2.0 * level,
        "{held} vs {level}"
    );
}

#[test]
fn bad_validation_input_exits_2_naming_the_place() {
    let (dir, train, held) = setup("validation_errors", 0.0);
    let spec = dir.join("spec.yaml");
    let base = || {
        let mut a = args(&[&"calibrate", &spec, &train[0], &train[1]]);
        a.extend(args(&[&HEADERLESS[0], &HEADERLESS[1], &HEADERLESS[2]]));
        a
    };
    let missing = dir.join("nowhere.csv");
    let mut a = base();
    a.extend(args(&[
        &"--validate",
        &format!("{},{}", held[0].display(), missing.display()),
    ]));
    lincal(&a).fails(2, &["nowhere.csv"]);
    for k in ["1", "0", "41"] {
        let mut a = base();
        a.extend(args(&[&"--folds", &k]));
        lincal(&a).fails(2, &["--folds"]);
    }
    let mut a = base();
    a.extend(args(&[&"--validate", &format!("{},", held[0].display())]));
    lincal(&a).fails(2, &["--validate"]);
    let mut ev = args(&[&"evaluate", &spec, &"--nominal", &missing]);
    ev.extend(args(&[&HEADERLESS[0], &HEADERLESS[1], &HEADERLESS[2]]));
    lincal(&ev).fails(2, &["nowhere.csv"]);
    let bad = write(&dir, "bad.json", "{\"params\": {\"zz\": {\"value\": 1}}}");
    let ev = args(&[&"evaluate", &spec, &"--params", &bad, &held[0], &held[1]]);
    lincal(&ev).fails(2, &["bad.json"]);
}

/// Held-out poses that the refitted constraint values fit exactly whatever the arm (three
/// poses on an unknown plane) give a residual of 0 that says nothing: `evaluate` reports the
/// residual components left after the refit (`residual_dof`, 0 there) and says so in text;
/// twelve poses leave nine.
#[test]
fn held_out_poses_the_refit_fits_exactly_are_marked_as_saying_nothing() {
    let dir = scratch("validation-dof");
    let spec = crate::util::spec("plane_spatial.yaml");
    let spec = spec.to_str().unwrap();
    let sim = |poses: &str, seed: &str| {
        lincal(&[
            "simulate",
            spec,
            "--poses",
            poses,
            "--seed",
            seed,
            "--noise-track",
            "1e-5",
        ])
        .ok()
        .stdout
    };
    let data = write(&dir, "fit.csv", &sim("60", "3"));
    let fit = lincal(&[
        "calibrate",
        spec,
        data.to_str().unwrap(),
        "--format",
        "json",
    ])
    .ok();
    let result = write(&dir, "result.json", &fit.stdout);
    let result = result.to_str().unwrap();
    for (poses, dof) in [("3", 0), ("12", 9)] {
        let held = write(&dir, &format!("held{poses}.csv"), &sim(poses, "11"));
        let held = held.to_str().unwrap();
        let e = lincal(&[
            "evaluate", spec, "--params", result, held, "--format", "json",
        ])
        .ok()
        .json();
        assert_eq!(e["constraints"][0]["residual_dof"], dof, "{e}");
        if dof == 0 {
            assert!(f(&e["residual_rms"]) < 1e-12, "{e}");
        } else {
            assert!(f(&e["residual_rms"]) > 1e-7, "{e}");
        }
        let text = lincal(&["evaluate", spec, "--params", result, held])
            .ok()
            .stdout;
        assert_eq!(text.contains("says nothing"), dof == 0, "{text}");
    }
    // The three poses repeated five times carry no more information: still 0, still said.
    let three = sim("3", "11");
    let mut lines = three.lines();
    let header = lines.next().expect("a header");
    let rows: Vec<&str> = lines.collect();
    let repeated = format!("{header}\n{}\n", vec![rows.join("\n"); 5].join("\n"));
    let held = write(&dir, "held_repeated.csv", &repeated);
    let held = held.to_str().unwrap();
    let e = lincal(&[
        "evaluate", spec, "--params", result, held, "--format", "json",
    ])
    .ok()
    .json();
    assert_eq!(e["constraints"][0]["residual_dof"], 0, "{e}");
    let text = lincal(&["evaluate", spec, "--params", result, held])
        .ok()
        .stdout;
    assert!(text.contains("says nothing"), "{text}");
}

/// Four touch planes whose size is fixed only by an `offset` relation between two of them
/// (`examples/touch_planes`): a fold without one of those planes cannot determine the arm,
/// so the folds are clusters in joint space, and the report says why instead of failing.
#[test]
fn folds_fall_back_to_clusters_when_a_placement_holds_the_arm_s_size() {
    let ex = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/touch_planes");
    let mut a: Vec<std::ffi::OsString> = vec!["calibrate".into(), ex.join("spec.yaml").into()];
    a.extend((0..4).map(|j| ex.join(format!("plane_{j}.csv")).into_os_string()));
    a.extend(["--folds", "4", "--format", "json"].map(Into::into));
    let out: Value = serde_json::from_str(&lincal(&a).ok().stdout).unwrap();
    let cv = &out["cross_validation"];
    assert_eq!(cv["split"], "joint-space clusters");
    let note = cv["split_note"].as_str().unwrap_or_default();
    assert!(note.starts_with("not by placements"), "{cv}");
    let held_out = cv["residual_rms_held_out"].as_f64().unwrap();
    let in_sample = cv["residual_rms_in_sample"].as_f64().unwrap();
    assert!(held_out > in_sample && held_out < 3.0 * in_sample, "{cv}");
}

/// `calibrate` records each joint's range over its poses (`joint_ranges`), and `predict`,
/// `evaluate` and `compensate` name the poses beyond it by more than the margin (0.05 rad,
/// 0.01 m): a UR5 on a rail (a prismatic joint first), a pose moved 5 cm along the rail
/// beyond the data and another turned 0.03 rad beyond on its second joint (inside the
/// margin). The calibration's own poses raise nothing, and neither does `--nominal`.
#[test]
fn poses_beyond_the_calibrated_joint_ranges_are_named() {
    let dir = scratch("validation-joint-ranges");
    let spec = crate::util::import_rail_chain(&dir, "rail.yaml", "dh");
    let s = spec.to_str().unwrap();
    let sim = lincal(&[
        "simulate",
        s,
        "--poses",
        "60",
        "--seed",
        "3",
        "--noise-measure",
        "1e-5",
    ])
    .ok();
    let data = write(&dir, "data.csv", &sim.stdout);
    let d = data.to_str().unwrap();
    let result = lincal(&["calibrate", s, d, "--format", "json"]).ok();
    let res = write(&dir, "result.json", &result.stdout);
    let r = res.to_str().unwrap();
    // The ranges are the data's own least and greatest readings.
    let mut lines = sim.stdout.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let joints = header.iter().filter(|h| h.starts_with('q')).count();
    let ranges = result.json()["joint_ranges"].as_array().unwrap().clone();
    assert_eq!(ranges.len(), joints);
    for (i, range) in ranges.iter().enumerate() {
        let lo = rows.iter().map(|r| r[i]).fold(f64::INFINITY, f64::min);
        let hi = rows.iter().map(|r| r[i]).fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(
            (range["min"].as_f64(), range["max"].as_f64()),
            (Some(lo), Some(hi)),
            "q{}",
            i + 1
        );
    }
    let own = lincal(&["predict", s, "--params", r, d]).ok();
    assert!(!own.stderr.contains("beyond the range"), "{}", own.stderr);
    // Pose 0 along the rail 5 cm beyond, pose 1 at 0.03 rad beyond on q2.
    let mut moved = rows.clone();
    let rail_max = ranges[0]["max"].as_f64().unwrap();
    let q2_max = ranges[1]["max"].as_f64().unwrap();
    moved[0][0] = rail_max + 0.05;
    moved[1][1] = q2_max + 0.03;
    let held = write(&dir, "held.csv", &csv(&header, &moved, header.len()));
    let h = held.to_str().unwrap();
    let needle = format!("1 of {} poses have a joint beyond the range", rows.len());
    let run = lincal(&["predict", s, "--params", r, h]).ok();
    assert!(
        run.stderr.contains(&needle)
            && run.stderr.contains("pose 0 (line 2): q1 =")
            && run.stderr.contains(" m against ["),
        "{}",
        run.stderr
    );
    let eval = lincal(&["evaluate", s, h, "--params", r, "--format", "json"]).ok();
    assert!(eval.stderr.contains(&needle), "{}", eval.stderr);
    let beyond = &eval.json()["beyond_ranges"];
    assert_eq!(
        (
            beyond["poses"].as_u64(),
            beyond["farthest"]["joint"].as_u64()
        ),
        (Some(1), Some(1))
    );
    // `compensate`'s joints for those readings as targets: the rail's stays beyond.
    let t = write(&dir, "targets.csv", &csv(&header, &moved, joints));
    let comp = lincal(&[
        "compensate",
        s,
        "--params",
        r,
        t.to_str().unwrap(),
        "--allow-failed",
    ])
    .ok();
    assert!(
        comp.stderr.contains("poses have a joint beyond the range") && comp.stderr.contains("q1 ="),
        "{}",
        comp.stderr
    );
    let comp_json = lincal(&[
        "compensate",
        s,
        "--params",
        r,
        t.to_str().unwrap(),
        "--allow-failed",
        "--format",
        "json",
    ])
    .ok();
    assert_eq!(
        comp_json.json()["beyond_ranges"]["farthest"]["joint"].as_u64(),
        Some(1),
        "{}",
        comp_json.stdout
    );
    // `calibrate --validate` says it among its warnings.
    let validated = lincal(&["calibrate", s, d, "--validate", h, "--format", "json"]).ok();
    let warnings = validated.json()["warnings"].to_string();
    assert!(
        warnings.contains("--validate") && warnings.contains(&needle),
        "{warnings}"
    );
    // A result without ranges (an older one) judges nothing.
    let mut bare = result.json();
    bare.as_object_mut().map(|o| o.remove("joint_ranges"));
    let old = write(&dir, "old.json", &bare.to_string());
    let quiet = lincal(&["predict", s, "--params", old.to_str().unwrap(), h]).ok();
    assert!(
        !quiet.stderr.contains("beyond the range"),
        "{}",
        quiet.stderr
    );
    let nominal = lincal(&["predict", s, "--nominal", h]).ok();
    assert!(
        !nominal.stderr.contains("beyond the range"),
        "{}",
        nominal.stderr
    );
}

/// CSV text of the first `width` columns of `header` and `rows` (shortest round-trip
/// decimals).
fn csv(header: &[&str], rows: &[Vec<f64>], width: usize) -> String {
    let mut text = header[..width].join(",") + "\n";
    for row in rows {
        let cells: Vec<String> = row[..width].iter().map(|v| format!("{v:?}")).collect();
        text += &(cells.join(",") + "\n");
    }
    text
}
