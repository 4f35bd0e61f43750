//! Full-pose measurements through the command line (issue 26): `simulate` writes
//! `x, y, z, qw, qx, qy, qz`, `calibrate` reads it (or `rx, ry, rz`) and reports
//! `orientation_rms` beside `residual_rms`, `predict` prints the tool frame, bad orientations
//! are refused by line and column.

use std::path::Path;

use crate::util::{lincal, scratch, write};

fn p(path: &Path) -> String {
    path.display().to_string()
}

/// The numbers of one CSV row.
fn numbers(row: &str) -> Vec<f64> {
    row.split(',')
        .map(|c| c.parse().expect("a number"))
        .collect()
}

fn tracker() -> String {
    p(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("lincal-models/specs/puma560_pose_tracker.yaml"),
    )
}

/// `n` simulated poses of the PUMA pose tracker (seed 4; 20 µm and 50 µrad of noise).
fn simulate_tracker(n: usize) -> crate::util::Run {
    let poses = n.to_string();
    lincal(&[
        "simulate",
        &tracker(),
        "--poses",
        &poses,
        "--seed",
        "4",
        "--noise-measure",
        "2e-5",
        "--noise-orientation",
        "5e-5",
    ])
    .ok()
}

/// The same rows with the quaternion columns replaced by the rotation vector.
fn as_rotation_vectors(csv: &str) -> String {
    let mut out = Vec::new();
    for (i, line) in csv.lines().enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let (head, quat) = cells.split_at(cells.len() - 4);
        if i == 0 {
            out.push(format!("{},rx,ry,rz", head.join(",")));
            continue;
        }
        let q: Vec<f64> = quat.iter().map(|c| c.parse().expect("a number")).collect();
        let s = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let k = if s < 1e-12 {
            2.0
        } else {
            2.0 * s.atan2(q[0]) / s
        };
        out.push(format!(
            "{},{:?},{:?},{:?}",
            head.join(","),
            k * q[1],
            k * q[2],
            k * q[3]
        ));
    }
    out.join("\n") + "\n"
}

#[test]
fn simulated_poses_calibrate_in_both_encodings_and_predict_the_frame() {
    let dir = scratch("pose-cli");
    let s = tracker();
    let sim = simulate_tracker(80);
    assert!(sim
        .stdout
        .starts_with("q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n"));
    let quat = write(&dir, "quat.csv", &sim.stdout);
    let rotv = write(&dir, "rotv.csv", &as_rotation_vectors(&sim.stdout));
    let a = lincal(&["calibrate", &s, &p(&quat), "--format", "json"])
        .ok()
        .json();
    let b = lincal(&["calibrate", &s, &p(&rotv), "--format", "json"])
        .ok()
        .json();
    for r in [&a, &b] {
        let pos = r["residual_rms"].as_f64().expect("residual_rms");
        let ori = r["orientation_rms"].as_f64().expect("orientation_rms");
        // About √3 times the per-axis noise, less the fitted degrees of freedom.
        assert!(pos > 2.0e-5 && pos < 4.5e-5, "{pos}");
        assert!(ori > 5.0e-5 && ori < 1.1e-4, "{ori}");
        assert_eq!(r["pose_noise"]["weight"].as_f64(), Some(0.4));
        assert_eq!(
            (&r["method"], &r["start"]),
            (&"linear+refine".into(), &"nominal".into())
        );
    }
    // The two encodings are the same data.
    for (name, v) in a["params"].as_object().expect("params") {
        let (x, y) = (v["value"].as_f64(), b["params"][name]["value"].as_f64());
        let (x, y) = (x.expect("a value"), y.expect("a value"));
        assert!((x - y).abs() < 1e-8, "{name}: {x} vs {y}");
    }
    let result = write(&dir, "result.json", &a.to_string());
    let pred = lincal(&["predict", &s, "--params", &p(&result), &p(&quat)]).ok();
    let lines: Vec<&str> = pred.stdout.lines().collect();
    assert_eq!(lines[0], "x,y,z,qw,qx,qy,qz");
    assert_eq!(lines.len(), 81);
    // The predicted frame is within the noise of the measured one.
    let data: Vec<&str> = sim.stdout.lines().collect();
    for (pl, dl) in lines[1..].iter().zip(&data[1..]) {
        let pv = numbers(pl);
        let dv = numbers(dl);
        let m = &dv[6..];
        let dx = ((pv[0] - m[0]).powi(2) + (pv[1] - m[1]).powi(2) + (pv[2] - m[2]).powi(2)).sqrt();
        let dot: f64 = (0..4).map(|k| pv[3 + k] * m[3 + k]).sum();
        let angle = 2.0 * dot.abs().min(1.0).acos();
        assert!(dx < 2e-4 && angle < 5e-4, "{dx} m, {angle} rad");
    }
}

#[test]
fn bad_full_pose_input_is_refused_by_name() {
    let dir = scratch("pose-bad");
    let s = tracker();
    let head = "q1,q2,q3,q4,q5,q6,x,y,z";
    let bad = write(
        &dir,
        "norm.csv",
        &format!("{head},qw,qx,qy,qz\n0,1,-1,0,0.5,0,1,2,3,0.9,0,0,0\n"),
    );
    lincal(&["calibrate", &s, &p(&bad)]).fails(2, &["norm.csv:2", "qw", "unit quaternion"]);
    let mixed = write(
        &dir,
        "mixed.csv",
        &format!("{head},qw,qx,qy,qz,rx\n0,1,-1,0,0.5,0,1,2,3,1,0,0,0,0\n"),
    );
    lincal(&["calibrate", &s, &p(&mixed)]).fails(2, &["mixed.csv:1", "both"]);
    // A rotation vector in degrees (a turn of 120° about y written as 120): no rotation
    // vector turns by more than a full turn.
    let degrees = write(
        &dir,
        "deg.csv",
        &format!(
            "{head},rx,ry,rz\n0,1,-1,0,0.5,0,1,2,3,0.1,0.2,0.3\n0,1,-1,0,0.5,0,1,2,3,0,120,0\n"
        ),
    );
    lincal(&["calibrate", &s, &p(&degrees)]).fails(2, &["deg.csv:3", "ry", "looks like degrees"]);
    // A tool frame in dim 2, measured_pose in dim 2, a rotation parameter nothing sees.
    let planar = write(
        &dir,
        "planar.yaml",
        "name: p\ndim: 2\njoints:\n  - {type: revolute, a: a1}\ntool: {x: 0.1, yaw: 0}\n\
         params:\n  a1: {nominal: 0.3}\nconstraint: measured_pose\n",
    );
    lincal(&["basis", &p(&planar)]).fails(2, &["planar.yaml", "measured_pose", "3-D"]);
    let unseen = write(
        &dir,
        "unseen.yaml",
        "name: u\ndim: 3\njoints:\n  - {type: revolute, a: a1}\n\
         tool: {x: 0.1, roll: tr}\nparams:\n  a1: {nominal: 0.3}\n  tr: {nominal: 0}\n\
         constraint: measured\n",
    );
    lincal(&["basis", &p(&unseen)]).fails(2, &["unseen.yaml:5", "tool.roll", "measured_pose"]);
    let negative = write(
        &dir,
        "neg.yaml",
        "name: n\ndim: 3\njoints:\n  - {type: revolute, a: a1}\nparams:\n  a1: {nominal: 0.3}\n\
         constraint:\n  measured_pose: {position_std: -1e-5}\n",
    );
    lincal(&["basis", &p(&negative)]).fails(2, &["neg.yaml:8", "position_std", "positive"]);
}

#[test]
fn an_imported_urdf_measures_the_tip_links_frame() {
    let dir = scratch("pose-import");
    let urdf = p(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/iiwa14.urdf"));
    let run = lincal(&[
        "import",
        &urdf,
        "--base",
        "iiwa_link_0",
        "--tip",
        "iiwa_link_ee",
        "--tool",
        "0,0,0.05",
        "--constraint",
        "measured_pose",
    ])
    .ok();
    assert!(run.stdout.contains("--constraint measured_pose`"));
    assert!(run.stdout.contains(
        "tool: {x: tool_x, y: tool_y, z: tool_z, roll: tool_roll, pitch: tool_pitch, yaw: tool_yaw}"
    ));
    assert!(run.stdout.contains("constraint: measured_pose"));
    let spec = write(&dir, "iiwa_pose.yaml", &run.stdout);
    // Noise-free poses of the nominal arm: the nominal fits them exactly.
    let data = lincal(&[
        "simulate",
        &p(&spec),
        "--poses",
        "40",
        "--seed",
        "3",
        "--truth",
        &p(&spec),
    ])
    .ok();
    let csv = write(&dir, "iiwa.csv", &data.stdout);
    let r = lincal(&["calibrate", &p(&spec), &p(&csv), "--format", "json"])
        .ok()
        .json();
    assert!(r["residual_rms"].as_f64().is_some_and(|v| v < 1e-9), "{r}");
    assert!(
        r["orientation_rms"].as_f64().is_some_and(|v| v < 1e-9),
        "{r}"
    );
}

#[test]
fn write_urdf_carries_the_calibrated_tool_frame() {
    let dir = scratch("pose-write-urdf");
    let urdf = p(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/iiwa14.urdf"));
    let import = |path: &str| {
        lincal(&[
            "import",
            path,
            "--base",
            "iiwa_link_0",
            "--tip",
            "iiwa_link_ee",
            "--tool",
            "0,0,0.05",
            "--constraint",
            "measured_pose",
        ])
        .ok()
        .stdout
    };
    let spec = write(&dir, "iiwa_pose.yaml", &import(&urdf));
    // A perturbed true arm (the seed's truth), noise-free poses.
    let data = lincal(&["simulate", &p(&spec), "--poses", "120", "--seed", "6"]).ok();
    let csv = write(&dir, "iiwa.csv", &data.stdout);
    let out = dir.join("calibrated.urdf");
    let r = lincal(&[
        "calibrate",
        &p(&spec),
        &p(&csv),
        "--format",
        "json",
        "--write-urdf",
        &p(&out),
    ])
    .ok()
    .json();
    assert!(
        r["orientation_rms"].as_f64().is_some_and(|v| v < 1e-9),
        "{r}"
    );
    let result = write(&dir, "result.json", &r.to_string());
    // The written URDF, imported again, has the calibrated tool frames at its nominals.
    let again = write(&dir, "again.yaml", &import(&p(&out)));
    let a = lincal(&["predict", &p(&spec), "--params", &p(&result), &p(&csv)]).ok();
    let b = lincal(&["predict", &p(&again), "--nominal", &p(&csv)]).ok();
    for (la, lb) in a.stdout.lines().zip(b.stdout.lines()).skip(1) {
        let va = numbers(la);
        let vb = numbers(lb);
        for k in 0..7 {
            assert!((va[k] - vb[k]).abs() < 1e-9, "{la} vs {lb}");
        }
    }
}

/// Orientations without noise (simulated with `--noise-measure` alone) and levels left to
/// estimate: the variance components would weigh the exact orientations by `σ_p/σ_o ≈ 10¹¹`
/// and drown every direction only the positions see (`θ2 − θ3` along the parallel axes).
/// The weight is held at the top of its range, with a warning, and the fit recovers the
/// truth.
#[test]
fn exact_orientations_do_not_drown_the_positions() {
    let dir = scratch("pose-exact-orientation");
    let spec = frames_with(&dir, "measured_pose: {}");
    let truth = dir.join("truth.yaml");
    let sim = crate::util::simulate(&p(&spec), 100, 3, ["--noise-measure", "2e-5"], &truth);
    let data = write(&dir, "data.csv", &sim);
    let r = lincal(&["calibrate", &p(&spec), &p(&data), "--format", "json"])
        .ok()
        .json();
    assert_eq!(r["pose_noise"]["weight"].as_f64(), Some(1e4));
    let ratio = r["pose_noise"]["held_ratio"].as_f64().expect("held_ratio");
    assert!(ratio > 1e6, "{ratio}");
    let warnings = r["warnings"].to_string();
    assert!(warnings.contains("as if they were exact"), "{warnings}");
    let pos = r["residual_rms"].as_f64().expect("residual_rms");
    assert!(pos > 1.5e-5 && pos < 4.5e-5, "{pos}");
    for (name, t) in crate::util::truth_values(&truth) {
        if r["params"][&name]["identifiable"] == true {
            crate::util::within_5_std(&r, &name, t, 1e-3);
        }
    }
}

/// Stated levels whose ratio (the orientation residual's weight) would overflow are refused
/// at the spec's field, not blamed on a data line after the fit starts.
#[test]
fn stated_levels_with_an_absurd_ratio_are_refused_at_the_spec() {
    let dir = scratch("pose-absurd-ratio");
    let spec = frames_with(
        &dir,
        "measured_pose: {position_std: 1.0e9, orientation_std: 1.0e-300}",
    );
    lincal(&["basis", &p(&spec)]).fails(
        2,
        &[
            "frames.yaml",
            "measured_pose",
            "position_std / orientation_std",
        ],
    );
}

/// `lincal-models`' PUMA with measured frames, its `measured_pose` line replaced by `line`,
/// written to `dir/frames.yaml`.
fn frames_with(dir: &Path, line: &str) -> std::path::PathBuf {
    let frames =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/puma560_pose_frames.yaml");
    let text = std::fs::read_to_string(frames).expect("the spec");
    let changed = text.replace(
        "measured_pose: {position_std: 2.0e-5, orientation_std: 5.0e-5}",
        line,
    );
    assert_ne!(changed, text, "the spec's measured_pose line moved");
    write(dir, "frames.yaml", &changed)
}

/// `evaluate` (and `--validate`) on held-out full poses reports the orientation error beside
/// the position's: the same poses with every orientation turned by 0.5 rad about x read
/// 0.5 rad, where the untouched ones read micro-radians; the position figures stay.
#[test]
fn held_out_orientations_are_judged() {
    let dir = scratch("pose-evaluate");
    let s =
        p(&Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("lincal-models/specs/puma560_pose_frames.yaml"));
    // One truth for both sets: the fit's, written and read back.
    let truth = p(&dir.join("truth.yaml"));
    let sim = |poses: &str, seed: &str, truth_arg: &str| {
        lincal(&[
            "simulate",
            &s,
            "--poses",
            poses,
            "--seed",
            seed,
            "--noise-measure",
            "1e-6",
            truth_arg,
            &truth,
        ])
        .ok()
        .stdout
    };
    let fit = write(&dir, "fit.csv", &sim("400", "1", "--truth-out"));
    let result = lincal(&["calibrate", &s, &p(&fit), "--format", "json"])
        .ok()
        .stdout;
    let result = write(&dir, "result.json", &result);
    let held = sim("50", "2", "--truth");
    // Every quaternion q turned: q ⊗ (cos 0.25, sin 0.25, 0, 0), 0.5 rad about the tool's x.
    let (c, sn) = (0.25f64.cos(), 0.25f64.sin());
    let mut turned = Vec::new();
    for (i, line) in held.lines().enumerate() {
        if i == 0 {
            turned.push(line.to_string());
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let (head, q) = cells.split_at(cells.len() - 4);
        let q: Vec<f64> = q.iter().map(|v| v.parse().expect("a number")).collect();
        let r = [
            q[0] * c - q[1] * sn,
            q[0] * sn + q[1] * c,
            q[2] * c + q[3] * sn,
            -q[2] * sn + q[3] * c,
        ];
        turned.push(format!(
            "{},{:?},{:?},{:?},{:?}",
            head.join(","),
            r[0],
            r[1],
            r[2],
            r[3]
        ));
    }
    let held_path = write(&dir, "held.csv", &held);
    let turned_path = write(&dir, "turned.csv", &(turned.join("\n") + "\n"));
    let judge = |data: &Path| {
        lincal(&[
            "evaluate",
            &s,
            "--params",
            &p(&result),
            &p(data),
            "--format",
            "json",
        ])
        .ok()
        .json()
    };
    let (a, b) = (judge(&held_path), judge(&turned_path));
    let ori = |e: &serde_json::Value| {
        e["orientation"]["orientation_rms"]
            .as_f64()
            .expect("orientation_rms")
    };
    assert!(ori(&a) < 1e-4, "{a}");
    assert!((ori(&b) - 0.5).abs() < 1e-3, "{b}");
    assert_eq!(
        a["residual_rms"], b["residual_rms"],
        "the positions are the same"
    );
    assert!(
        b["orientation"]["pose_rms"].as_f64().unwrap()
            > a["orientation"]["pose_rms"].as_f64().unwrap()
    );
    let text = lincal(&["evaluate", &s, "--params", &p(&result), &p(&turned_path)])
        .ok()
        .stdout;
    assert!(
        text.contains("orientation rms (50 measured poses)"),
        "{text}"
    );
}

/// A spec that states its instrument's noise levels while the data carry others: the fit
/// says which level the residuals contradict (the reported standard deviations take the
/// stated balance as true), and stays quiet when the data agree with what is stated.
#[test]
fn misstated_noise_levels_are_named() {
    let dir = scratch("pose-misstated");
    let s = p(&Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("lincal-models/specs/puma560_pose_tracker.yaml"));
    let warns = |noise: &str| -> Vec<String> {
        let sim = lincal(&[
            "simulate",
            &s,
            "--poses",
            "100",
            "--seed",
            "4",
            "--noise-measure",
            noise,
            "--noise-orientation",
            "5e-5",
        ])
        .ok();
        let data = write(&dir, &format!("d{noise}.csv"), &sim.stdout);
        let run = lincal(&["calibrate", &s, &p(&data), "--format", "json"]).ok();
        run.json()["warnings"]
            .as_array()
            .expect("warnings")
            .iter()
            .filter_map(|w| w.as_str().map(str::to_string))
            .collect()
    };
    // The spec states 20 µm and 50 µrad.
    let off = warns("5e-5");
    assert!(
        off.iter()
            .any(|w| w.contains("position") && w.contains("against the stated 2.000e-5 m")),
        "{off:?}"
    );
    let agreed = warns("2e-5");
    assert!(
        !agreed.iter().any(|w| w.contains("against the stated")),
        "{agreed:?}"
    );
}

/// Held-out poses are judged at the fit's own orientation weight (estimated here: the
/// imported spec states no noise levels), in `--validate` and in `evaluate --params`, not at
/// the model's default of 1 m/rad.
#[test]
fn held_out_pose_rms_uses_the_fits_weight() {
    let dir = scratch("pose-weight");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = lincal(&[
        "import",
        &p(&root.join("tests/urdf/ur5_rail.urdf")),
        "--base",
        "world",
        "--tip",
        "ee_link",
        "--constraint",
        "measured_pose",
    ])
    .ok();
    let s = p(&write(&dir, "s.yaml", &spec.stdout));
    let truth = p(&dir.join("truth.yaml"));
    let sim = |seed: &str, truth_arg: &str| {
        let run = lincal(&[
            "simulate",
            &s,
            "--poses",
            "80",
            "--seed",
            seed,
            "--noise-measure",
            "2e-5",
            "--noise-orientation",
            "5e-5",
            truth_arg,
            &truth,
        ])
        .ok();
        p(&write(&dir, &format!("d{seed}.csv"), &run.stdout))
    };
    let (fit, held) = (sim("1", "--truth-out"), sim("2", "--truth"));
    let run = lincal(&[
        "calibrate",
        &s,
        &fit,
        "--validate",
        &held,
        "--format",
        "json",
    ])
    .ok();
    let j = run.json();
    let w = j["pose_noise"]["weight"].as_f64().expect("weight");
    assert!(
        (w - 1.0).abs() > 0.1,
        "an estimated weight away from 1: {w}"
    );
    let v = j["validation"][0]["orientation"]["weight"]
        .as_f64()
        .expect("validation");
    assert_eq!(v, w);
    let res = p(&write(&dir, "r.json", &run.stdout));
    let e = lincal(&["evaluate", &s, "--params", &res, &held, "--format", "json"]).ok();
    assert_eq!(e.json()["orientation"]["weight"].as_f64(), Some(w));
}

/// A pose whose orientation alone is off is listed with its two errors, position in metres
/// and orientation in radians, not their weighted norm read as metres.
#[test]
fn a_worst_pose_lists_its_position_and_orientation_errors() {
    let dir = scratch("pose-worst-parts");
    let s = tracker();
    let sim = simulate_tracker(60);
    // Pose 7's measured orientation turned by 0.02 rad about x: q' = q ⊗ (cos 0.01, sin 0.01, 0, 0).
    let mut rows: Vec<String> = sim.stdout.lines().map(str::to_string).collect();
    let row = 1
        + rows
            .iter()
            .skip(1)
            .take_while(|l| l.starts_with('#'))
            .count()
        + 7;
    let mut v = numbers(&rows[row]);
    let n = v.len();
    let (w, x, y, z) = (v[n - 4], v[n - 3], v[n - 2], v[n - 1]);
    let (c, s1) = (0.01f64.cos(), 0.01f64.sin());
    let turned = [
        w * c - x * s1,
        x * c + w * s1,
        y * c + z * s1,
        z * c - y * s1,
    ];
    v[n - 4..].copy_from_slice(&turned);
    rows[row] = v
        .iter()
        .map(|a| format!("{a:?}"))
        .collect::<Vec<_>>()
        .join(",");
    let data = write(&dir, "turned.csv", &(rows.join("\n") + "\n"));
    let r = lincal(&["calibrate", &s, &p(&data), "--format", "json"])
        .ok()
        .json();
    let worst = &r["worst_poses"][0];
    assert_eq!(worst["pose"], 7, "{worst}");
    let ori = worst["orientation"].as_f64().expect("orientation");
    let pos = worst["position"].as_f64().expect("position");
    assert!((ori - 0.02).abs() < 0.004, "{worst}");
    assert!(pos < 2e-4, "{worst}");
    let text = lincal(&["calibrate", &s, &p(&data)]).ok().stdout;
    let line = text
        .lines()
        .find(|l| l.starts_with("worst poses"))
        .expect("a worst-poses line");
    assert!(
        line.contains("pose 7 (line") && line.contains(" rad"),
        "{line}"
    );
}
