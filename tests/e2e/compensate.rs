//! `lincal compensate` (interface.md, third round): simulate a truth, calibrate, compensate
//! joint targets, and drive the model and the truth to the compensated joints; the identity
//! with the nominals; Cartesian pose targets; every failure named with its line; bad input.

use std::path::{Path, PathBuf};

use crate::util::{lincal, scratch, spec, truth_values, write, FIXED_PRIOR};

/// The rows of a CSV (header first), split at commas.
fn table(csv: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = csv.lines().filter(|l| !l.is_empty());
    let header = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn num(s: &str) -> f64 {
    s.parse().unwrap_or_else(|_| panic!("not a number: {s}"))
}

/// `lincal predict SPEC PARAMS FILE`: the tips, one `[x, y, z]` per row.
fn predict(spec: &Path, params: &[&str], file: &Path) -> Vec<Vec<f64>> {
    let mut args: Vec<String> = vec!["predict".into(), spec.display().to_string()];
    args.extend(params.iter().map(|s| s.to_string()));
    args.push(file.display().to_string());
    let (_, rows) = table(&lincal(&args).ok().stdout);
    rows.iter()
        .map(|r| r.iter().map(|v| num(v)).collect())
        .collect()
}

/// `‖a − b‖`, the library's own.
use lincal::lincal_core::calibrate::constraint_fit::distance as dist;

/// A joints file `q1..qn` of `rows`.
fn joints_csv(dir: &Path, name: &str, rows: &[Vec<f64>]) -> PathBuf {
    let n = rows.first().map_or(0, Vec::len);
    let mut text: String = (1..=n)
        .map(|i| format!("q{i}"))
        .collect::<Vec<_>>()
        .join(",");
    text.push('\n');
    for r in rows {
        text += &r
            .iter()
            .map(|v| format!("{v:?}"))
            .collect::<Vec<_>>()
            .join(",");
        text.push('\n');
    }
    write(dir, name, &text)
}

#[test]
fn compensated_joints_put_the_calibrated_tool_on_the_nominal_target() {
    let dir = scratch("compensate_roundtrip");
    let s = spec("measured_spatial.yaml");
    let sp = s.to_str().unwrap();
    let truth = dir.join("truth.yaml");
    let data = lincal(&[
        "simulate",
        sp,
        "--poses",
        "300",
        "--seed",
        "4",
        "--noise-measure",
        "1e-6",
        "--truth-out",
        truth.to_str().unwrap(),
    ])
    .ok()
    .stdout;
    let data = write(&dir, "data.csv", &data);
    let mut args = vec![
        "calibrate",
        sp,
        data.to_str().unwrap(),
        "--refine",
        "--format",
        "json",
    ];
    args.extend(FIXED_PRIOR);
    let cal = lincal(&args).ok().stdout;
    let cal_path = write(&dir, "cal.json", &cal);
    // The truth as a result file, for `predict --params`.
    let truth_json = serde_json::json!({
        "params": truth_values(&truth)
            .into_iter()
            .map(|(n, v)| (n, serde_json::json!({"value": v})))
            .collect::<serde_json::Map<_, _>>()
    });
    let truth_path = write(&dir, "truth.json", &truth_json.to_string());
    // Joint targets over the workspace, the elbow bent (a straight elbow cannot reach a target
    // of a longer nominal arm: `diverged`), the tip away from the axis of joint 1.
    let q: Vec<Vec<f64>> = (0..40)
        .map(|l| {
            let l = f64::from(l);
            vec![-2.0 + 0.1 * l, -1.0 + 0.03 * l, 0.6 + 0.02 * l]
        })
        .collect();
    let targets = joints_csv(&dir, "targets.csv", &q);
    let run = lincal(&[
        "compensate",
        sp,
        "--params",
        cal_path.to_str().unwrap(),
        targets.to_str().unwrap(),
    ])
    .ok();
    let (header, out) = table(&run.stdout);
    assert_eq!(
        header,
        [
            "q1",
            "q2",
            "q3",
            "x",
            "y",
            "z",
            "correction",
            "residual",
            "sigma",
            "status"
        ]
    );
    assert_eq!(out.len(), 40);
    assert!(run.stderr.contains("40 targets: 40 ok"), "{}", run.stderr);
    let qc: Vec<Vec<f64>> = out
        .iter()
        .map(|r| r[..3].iter().map(|v| num(v)).collect())
        .collect();
    let compensated = joints_csv(&dir, "compensated.csv", &qc);
    let cal_arg = cal_path.to_str().unwrap();
    let want = predict(&s, &["--nominal"], &targets);
    let got = predict(&s, &["--params", cal_arg], &compensated);
    let filtered = predict(&s, &["--nominal"], &compensated);
    let truth_arg = truth_path.to_str().unwrap();
    let true_before = predict(&s, &["--params", truth_arg], &targets);
    let true_after = predict(&s, &["--params", truth_arg], &compensated);
    let (mut before, mut after) = (0.0_f64, 0.0_f64);
    for (l, r) in out.iter().enumerate() {
        assert_eq!(r[9], "ok");
        // FK_calibrated(q') = FK_nominal(q).
        assert!(dist(&got[l], &want[l]) < 1e-9, "row {l}");
        assert!(num(&r[7]) < 1e-9);
        // The filtered target is FK_nominal(q').
        let x: Vec<f64> = r[3..6].iter().map(|v| num(v)).collect();
        assert!(dist(&x, &filtered[l]) < 1e-12);
        let corr = dist(&qc[l], &q[l]);
        assert!((num(&r[6]) - corr).abs() < 1e-12);
        assert!(num(&r[8]) > 0.0 && num(&r[8]) < 1e-3, "sigma {}", r[8]);
        before = before.max(dist(&true_before[l], &want[l]));
        after = after.max(dist(&true_after[l], &want[l]));
    }
    // The true robot driven to the compensated joints: from the nominal's millimetres to the
    // calibration's noise level.
    assert!(before > 1e-3, "nominal error {before}");
    assert!(after < 1e-4, "compensated error {after} (nominal {before})");
}

#[test]
fn the_nominals_return_every_seed_and_pose_targets_are_read() {
    let dir = scratch("compensate_identity");
    let s =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/puma560_pose_tracker.yaml");
    let sp = s.to_str().unwrap();
    let q = vec![
        vec![0.1, 0.5, -1.0, 0.3, 0.7, 0.2],
        vec![-0.4, 1.2, -2.0, -0.5, -0.9, 1.0],
    ];
    let targets = joints_csv(&dir, "joints.csv", &q);
    let tips = predict(&s, &["--nominal"], &targets);
    let mut text = String::from("# pose targets\nq1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,_id\n");
    for (l, (qr, t)) in q.iter().zip(&tips).enumerate() {
        let cells: Vec<String> = qr.iter().chain(t).map(|v| format!("{v:?}")).collect();
        text += &format!("{},{l}\n", cells.join(","));
    }
    let poses = write(&dir, "poses.csv", &text);
    for file in [&targets, &poses] {
        let run = lincal(&["compensate", sp, "--nominal", file.to_str().unwrap()]).ok();
        let (header, out) = table(&run.stdout);
        assert_eq!(header.len(), 6 + 7 + 4);
        assert_eq!(&header[9..13], ["qw", "qx", "qy", "qz"]);
        for (r, qr) in out.iter().zip(&q) {
            let got: Vec<f64> = r[..6].iter().map(|v| num(v)).collect();
            assert!(dist(&got, qr) < 1e-12, "{got:?} vs {qr:?}");
            assert_eq!(r[16], "ok");
        }
    }
    let json = lincal(&[
        "compensate",
        sp,
        "--nominal",
        poses.to_str().unwrap(),
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(json["targets"], 2);
    assert_eq!(json["counts"]["ok"], 2);
    assert_eq!(json["failed"], 0);
}

#[test]
fn a_failed_row_is_named_counted_and_sets_the_exit_status() {
    let dir = scratch("compensate_failures");
    let s = spec("measured_spatial.yaml");
    let sp = s.to_str().unwrap();
    // th2 one milliradian up: joint 2 at its upper limit must go past it.
    let cal = serde_json::json!({"params": {
        "a1": {"value": 0.05}, "d1": {"value": 0.3}, "th1": {"value": 0.0},
        "a2": {"value": 0.4}, "th2": {"value": 0.001}, "a3": {"value": 0.35},
        "th3": {"value": 0.0}, "bx": {"value": 0.5}, "by": {"value": -0.2}
    }});
    let cal = write(&dir, "cal.json", &cal.to_string());
    let targets = write(
        &dir,
        "t.csv",
        "q1,q2,q3\n0.1,0.5,1.0\n# the limit\n0.1,3.0,0.2\n",
    );
    let args = [
        "compensate",
        sp,
        "--params",
        cal.to_str().unwrap(),
        targets.to_str().unwrap(),
    ];
    let run = lincal(&args).fails(1, &["line 4", "limit", "joint 2"]);
    let (_, out) = table(&run.stdout);
    assert_eq!(out[0].last().unwrap(), "ok");
    assert_eq!(out[1].last().unwrap(), "limit");
    let mut allowed = args.to_vec();
    allowed.push("--allow-failed");
    lincal(&allowed).ok();
    allowed.extend(["--format", "json"]);
    let json = lincal(&allowed).ok().json();
    assert_eq!(json["counts"]["limit"], 1);
    assert_eq!(json["failures"][0]["line"], 4);
}

#[test]
fn bad_targets_name_file_line_and_field() {
    let dir = scratch("compensate_bad");
    let s = spec("measured_spatial.yaml");
    let sp = s.to_str().unwrap();
    let bad = write(
        &dir,
        "bad.csv",
        "q1,q2,q3,x,y,z\n0.1,0.2,0.3,0.5,0.1,0.2\n0.1,0.2,0.3,0.5,,0.2\n",
    );
    lincal(&["compensate", sp, "--nominal", bad.to_str().unwrap()]).fails(2, &["bad.csv:3", "y"]);
    let pose = write(&dir, "pose.csv", "q1,q2,q3,x,y,z,qw,qx,qy,qz\n");
    lincal(&["compensate", sp, "--nominal", pose.to_str().unwrap()]).fails(2, &["pose.csv", "qw"]);
    let nan = write(&dir, "nan.csv", "q1,q2,q3\n0.1,NaN,0.3\n");
    lincal(&["compensate", sp, "--nominal", nan.to_str().unwrap()]).fails(2, &["nan.csv:2", "q2"]);
    let missing = write(&dir, "missing.csv", "q1,q3\n0.1,0.3\n");
    lincal(&["compensate", sp, "--nominal", missing.to_str().unwrap()])
        .fails(2, &["missing.csv", "q2"]);
}

/// `measured_spatial.yaml` (a `base:` `bx, by` of nominals 0.5, -0.2: a tracker's frame)
/// calibrated on 200 simulated poses in `dir`: the spec, the result file and its JSON.
fn calibrated_spatial(dir: &Path) -> (PathBuf, PathBuf, serde_json::Value) {
    let s = spec("measured_spatial.yaml");
    let sp = s.to_str().unwrap();
    let data = lincal(&[
        "simulate",
        sp,
        "--poses",
        "200",
        "--seed",
        "6",
        "--noise-measure",
        "1e-6",
    ])
    .ok()
    .stdout;
    let data = write(dir, "data.csv", &data);
    let mut args = vec![
        "calibrate",
        sp,
        data.to_str().unwrap(),
        "--refine",
        "--format",
        "json",
    ];
    args.extend(FIXED_PRIOR);
    let cal = lincal(&args).ok().stdout;
    let cal_path = write(dir, "cal.json", &cal);
    (s, cal_path, serde_json::from_str(&cal).unwrap())
}

/// `--intended-base calibrated`: a joint target's intended tool is the nominal arm placed by
/// the calibrated `base:` (the spec's `bx, by`, nominals 0.5, -0.2), for a `base:` that is a
/// tracker's frame.
#[test]
fn the_intended_base_can_be_the_calibrated_one() {
    let dir = scratch("compensate_intended_base");
    let (s, cal_path, cal_json) = calibrated_spatial(&dir);
    let sp = s.to_str().unwrap();
    let value = |n: &str| cal_json["params"][n]["value"].as_f64().unwrap();
    let shift = [value("bx") - 0.5, value("by") + 0.2, 0.0];
    let q: Vec<Vec<f64>> = (0..10)
        .map(|l| {
            let l = f64::from(l);
            vec![-1.0 + 0.2 * l, -0.8 + 0.05 * l, 0.9 + 0.03 * l]
        })
        .collect();
    let targets = joints_csv(&dir, "targets.csv", &q);
    let cal_arg = cal_path.to_str().unwrap();
    let run = lincal(&[
        "compensate",
        sp,
        "--params",
        cal_arg,
        targets.to_str().unwrap(),
        "--intended-base",
        "calibrated",
    ])
    .ok();
    let (_, out) = table(&run.stdout);
    let qc: Vec<Vec<f64>> = out
        .iter()
        .map(|r| r[..3].iter().map(|v| num(v)).collect())
        .collect();
    let compensated = joints_csv(&dir, "compensated.csv", &qc);
    let want = predict(&s, &["--nominal"], &targets);
    let got = predict(&s, &["--params", cal_arg], &compensated);
    for (l, r) in out.iter().enumerate() {
        assert_eq!(r[9], "ok");
        let placed: Vec<f64> = want[l].iter().zip(shift).map(|(a, b)| a + b).collect();
        assert!(dist(&got[l], &placed) < 1e-9, "row {l}");
    }
    lincal(&[
        "compensate",
        sp,
        "--params",
        cal_arg,
        targets.to_str().unwrap(),
        "--intended-base",
        "tracker",
    ])
    .fails(2, &["--intended-base"]);
}

/// Without `--intended-base`, a calibrated `base:` that moves the joint targets' intended
/// tools by more than 1 cm is named in a warning (stderr, JSON `warnings`), and a failure's
/// message points to it: by default the corrections carry that distance. With the option, or
/// with `--nominal`, nothing is said.
#[test]
fn a_calibrated_base_far_from_its_nominal_is_warned_about() {
    let dir = scratch("compensate_base_shift");
    let (s, _, mut cal_json) = calibrated_spatial(&dir);
    let sp = s.to_str().unwrap();
    // The tracker 5 cm further along x than the spec's nominal guess.
    let bx = cal_json["params"]["bx"]["value"].as_f64().unwrap();
    cal_json["params"]["bx"]["value"] = serde_json::json!(bx + 0.05);
    let far = write(&dir, "far.json", &cal_json.to_string());
    let targets = joints_csv(
        &dir,
        "targets.csv",
        &[vec![-0.4, -0.6, 0.9], vec![0.3, -0.5, 1.0]],
    );
    let (far, targets) = (far.to_str().unwrap(), targets.to_str().unwrap());
    let base = ["compensate", sp, "--params", far, targets, "--allow-failed"];
    let run = lincal(&base).ok();
    assert!(
        run.stderr.contains("moves the nominal arm's tool by ")
            && run.stderr.contains("e-2 m (median over the joint targets)")
            && run.stderr.contains("--intended-base calibrated"),
        "{}",
        run.stderr
    );
    let mut json = base.to_vec();
    json.extend(["--format", "json"]);
    let warnings = lincal(&json).ok().json()["warnings"].clone();
    assert_eq!(warnings.as_array().map(Vec::len), Some(1), "{warnings}");
    let mut placed = json.clone();
    placed.extend(["--intended-base", "calibrated"]);
    let run = lincal(&placed).ok();
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    assert_eq!(run.json()["warnings"], serde_json::json!([]));
    let run = lincal(&["compensate", sp, "--nominal", targets]).ok();
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    // Chosen on purpose (a `base:` that is the arm's own mounting error): nothing said.
    let mut nominal = base.to_vec();
    nominal.extend(["--intended-base", "nominal"]);
    let run = lincal(&nominal).ok();
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
}
