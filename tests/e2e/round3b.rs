//! Issue 50, the fourth attack (session 26): each test drives one class of input that gave
//! wrong numbers with exit 0, or a message that blamed the wrong thing.

use serde_json::Value;

use crate::util::{lincal, scratch, spec, write};

/// The example UR5's URDF.
fn ur5() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/robot/ur5.urdf")
}

/// `lincal import` of a UR5 URDF from `base_link` to `tool0`, with `extra` options: the spec.
fn import_ur5(urdf: &std::path::Path, extra: &[&str]) -> String {
    let urdf = urdf.to_str().expect("a path");
    let mut args = vec!["import", urdf, "--base", "base_link", "--tip", "tool0"];
    args.extend_from_slice(extra);
    lincal(&args).ok().stdout
}

/// An edit of a result file's JSON.
type Edit = Box<dyn Fn(&mut Value)>;

/// A result file whose covariance or standard deviations are not those of any estimate is
/// refused by `compensate --params` (exit 2, the field named), where its `sigma` column
/// printed zeros or 10¹⁵⁰ m; a result with no uncertainty at all is read, and said so.
#[test]
fn compensate_refuses_a_covariance_that_is_none() {
    let dir = scratch("round3b-covariance");
    let s = spec("point_planar3.yaml").display().to_string();
    let data = lincal(&[
        "simulate",
        &s,
        "--poses",
        "40",
        "--seed",
        "3",
        "--noise-track",
        "1e-5",
    ])
    .ok();
    let data = write(&dir, "data.csv", &data.stdout).display().to_string();
    let result: Value = lincal(&["calibrate", &s, &data, "--format", "json"])
        .ok()
        .json();
    let targets = "q1,q2,q3\n0.0,2.09,-2.41\n-0.69,2.26,-0.70\n";
    let targets = write(&dir, "targets.csv", targets).display().to_string();
    let run = |name: &str, edit: &dyn Fn(&mut Value)| {
        let mut r = result.clone();
        edit(&mut r);
        let path = write(&dir, name, &r.to_string()).display().to_string();
        lincal(&["compensate", &s, "--params", &path, &targets])
    };
    run("as_written.json", &|_| {}).ok();
    let first = result["covariance"]["params"][0]
        .as_str()
        .expect("a name")
        .to_string();
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "neg.json",
            Box::new(|r| r["covariance"]["matrix"][0][0] = (-1.0).into()),
            "covariance.matrix[0][0]",
        ),
        (
            "huge.json",
            Box::new(|r| r["covariance"]["matrix"][1][1] = 1e300.into()),
            "covariance.matrix[1][1]",
        ),
        (
            "nonsym.json",
            Box::new(|r| r["covariance"]["matrix"][0][1] = 1.0.into()),
            "covariance.matrix[0][1]",
        ),
        (
            "foreign.json",
            Box::new(|r| r["covariance"]["params"][0] = "zz".into()),
            "covariance.params[0]",
        ),
        (
            "twice.json",
            Box::new(|r| r["covariance"]["params"][1] = r["covariance"]["params"][0].clone()),
            "covariance.params[1]",
        ),
    ];
    for (name, edit, field) in cases {
        run(name, &*edit).fails(2, &[field]);
    }
    let without_cov = |r: &mut Value| {
        r.as_object_mut().expect("an object").remove("covariance");
    };
    for (std, name) in [(-1.0, "std_neg.json"), (1e308, "std_huge.json")] {
        let f = first.clone();
        run(name, &move |r: &mut Value| {
            without_cov(r);
            r["params"][&f]["std"] = std.into();
        })
        .fails(2, &[&format!("params.{first}.std")]);
    }
    let bare = run("bare.json", &|r: &mut Value| {
        without_cov(r);
        for (_, p) in r["params"].as_object_mut().expect("params").iter_mut() {
            p.as_object_mut().expect("a param").remove("std");
        }
    })
    .ok();
    assert!(
        bare.stderr.contains("no uncertainty known"),
        "{}",
        bare.stderr
    );
}

/// `--reject-outliers --folds`: the pose the fit rejected is not scored held out either (it
/// made the held-out figure 10³ times the in-sample one).
#[test]
fn folds_leave_out_the_poses_the_fit_rejected() {
    let dir = scratch("round3b-folds-rejected");
    let s = spec("point_planar3.yaml").display().to_string();
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "60",
        "--seed",
        "5",
        "--noise-track",
        "1e-5",
    ])
    .ok();
    let mut lines: Vec<String> = sim.stdout.lines().map(str::to_string).collect();
    // One joint reading off by 0.3 rad.
    let mut row: Vec<String> = lines[8].split(',').map(str::to_string).collect();
    let q: f64 = row[1].parse().expect("a reading");
    row[1] = (q + 0.3).to_string();
    lines[8] = row.join(",");
    let data = write(&dir, "data.csv", &(lines.join("\n") + "\n"))
        .display()
        .to_string();
    let json = lincal(&[
        "calibrate",
        &s,
        &data,
        "--reject-outliers",
        "--folds",
        "3",
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(
        json["rejected"].as_array().map(Vec::len),
        Some(1),
        "{}",
        json["rejected"]
    );
    let cv = &json["cross_validation"];
    let held = cv["residual_rms_held_out"].as_f64().expect("held out");
    let in_sample = cv["residual_rms_in_sample"].as_f64().expect("in sample");
    assert!(held < 3.0 * in_sample, "{cv}");
    let scored: u64 = cv["per_fold"]
        .as_array()
        .expect("folds")
        .iter()
        .filter_map(|f| f["test_poses"].as_u64())
        .sum();
    assert_eq!(scored, 59, "{cv}");
}

/// `select --pool` on the socket workflow's own spec (`import --points 3 --distance 0.1`,
/// whose nominal sockets all stand at one guessed point): the pool stands on the nominals
/// moved onto the relations, where it was refused ("the true parameters do not satisfy the
/// spec's relations", with no truth given).
#[test]
fn select_pools_the_imported_socket_spec() {
    let dir = scratch("round3b-select-sockets");
    let urdf = ur5();
    let imported = import_ur5(
        &urdf,
        &[
            "--tool",
            "0.03,0,0.04",
            "--points",
            "3",
            "--distance",
            "0.1",
        ],
    );
    let s = write(&dir, "spec.yaml", &imported).display().to_string();
    let run = lincal(&["select", &s, "-n", "30", "--pool", "300"]).ok();
    assert_eq!(
        run.stdout.lines().count(),
        31,
        "a header and 30 rows:\n{}",
        run.stderr
    );
}

/// The spec's URDF (its `urdf:` record) is an input of `calibrate` even without
/// `--write-urdf`: a `--report` onto it is refused, where it replaced the URDF by HTML.
#[test]
fn a_report_never_replaces_the_specs_urdf() {
    let dir = scratch("round3b-report-urdf");
    let urdf = ur5();
    let text = std::fs::read_to_string(&urdf).expect("the example URDF");
    let local = write(&dir, "my.urdf", &text);
    let imported = import_ur5(&local, &[]);
    let s = write(&dir, "spec.yaml", &imported).display().to_string();
    let data = lincal(&["simulate", &s, "--poses", "60", "--seed", "2"])
        .ok()
        .stdout;
    let data = write(&dir, "data.csv", &data).display().to_string();
    let report = local.display().to_string();
    lincal(&["calibrate", &s, &data, "--report", &report]).fails(2, &["--report", "URDF"]);
    assert_eq!(std::fs::read_to_string(&local).expect("still there"), text);
}

/// Three unknown sockets of a planar 3R arm (`leftovers`' spec) with the relations
/// `relations` (YAML list items).
fn sockets3(relations: &str) -> String {
    format!("{}relations:\n{relations}", crate::leftovers::sockets3(""))
}

/// `select --candidates` on a list of sockets: candidates that miss a socket, or a file
/// without the `constraint` column (every pose then on the first), name the sockets and
/// their values (exit 2), where both read "information matrix … not positive definite".
#[test]
fn select_names_a_socket_without_candidates() {
    let dir = scratch("round3b-select-socket");
    let s = write(
        &dir,
        "s3.yaml",
        &sockets3("  - {distance: [0, 1], value: 0.4}\n"),
    );
    let s = s.display().to_string();
    let sim = lincal(&["simulate", &s, "--poses", "60", "--seed", "3"])
        .ok()
        .stdout;
    let two: String = sim
        .lines()
        .filter(|l| !l.ends_with(",2"))
        .map(|l| format!("{l}\n"))
        .collect();
    let two = write(&dir, "two.csv", &two).display().to_string();
    lincal(&["select", &s, "-n", "10", "--candidates", &two])
        .fails(2, &["constraint(s) 2 (rx, ry)"]);
    let joints: String = sim
        .lines()
        .map(|l| l.rsplit_once(',').map_or(l, |(q, _)| q).to_string() + "\n")
        .collect();
    let joints = write(&dir, "joints.csv", &joints).display().to_string();
    lincal(&["select", &s, "-n", "10", "--candidates", &joints]).fails(
        2,
        &[
            "constraint(s) 1 (qx, qy); 2 (rx, ry)",
            "a `constraint` column",
        ],
    );
}

/// A relation's value in millimetres for metres (1000 for 1 m between two sockets): the fit
/// holds it, and no pose can contradict the 1 km arm that follows, so a warning says how far
/// the calibrated arm reaches against the nominal one. A tiny stated value prints in
/// exponent form, not as 300 zeros.
#[test]
fn a_relation_in_other_units_is_warned_about() {
    let dir = scratch("round3b-relation-units");
    let truth = write(
        &dir,
        "s.yaml",
        &sockets3("  - {distance: [0, 1], value: 0.4}\n"),
    );
    let sim = lincal(&[
        "simulate",
        &truth.display().to_string(),
        "--poses",
        "90",
        "--seed",
        "3",
    ])
    .ok()
    .stdout;
    let data = write(&dir, "d.csv", &sim).display().to_string();
    for (value, warned) in [("0.4", false), ("1000", true), ("1e-300", false)] {
        let s = write(
            &dir,
            &format!("r{value}.yaml"),
            &sockets3(&format!("  - {{distance: [0, 1], value: {value}}}\n")),
        );
        let run = lincal(&["calibrate", &s.display().to_string(), &data]);
        assert_eq!(run.code, 0, "{value}: {}", run.stderr);
        assert_eq!(
            run.stdout.contains("the size of the nominal one"),
            warned,
            "{value}:\n{}",
            run.stdout
        );
        assert!(
            run.stdout
                .lines()
                .all(|l| !l.contains("0.0000000000000000")),
            "{}",
            run.stdout
        );
    }
}

/// A spec whose `urdf:` record holds a tool point beyond 10⁶ m names the spec's field and
/// line (`urdf.tool[0]`), not an option `calibrate` does not have (`--tool`).
#[test]
fn a_urdf_records_tool_is_checked_where_it_is_written() {
    let dir = scratch("round3b-urdf-tool");
    let urdf = ur5();
    let imported = import_ur5(&urdf, &["--tool", "0.03,0,0.04"]);
    assert!(imported.contains("tool: [0.03, 0, 0.04]"), "{imported}");
    let edited = imported.replace("tool: [0.03, 0, 0.04]", "tool: [1e9, 0, 0.04]");
    let good = write(&dir, "good.yaml", &imported).display().to_string();
    let data = lincal(&["simulate", &good, "--poses", "30"]).ok().stdout;
    let data = write(&dir, "d.csv", &data).display().to_string();
    let s = write(&dir, "spec.yaml", &edited).display().to_string();
    let out = dir.join("o.urdf").display().to_string();
    for run in [
        lincal(&["calibrate", &s, &data, "--write-urdf", &out]),
        lincal(&["simulate", &s, "--poses", "3"]),
    ] {
        run.fails(2, &["urdf.tool[0]", "spec.yaml:"]);
    }
}

/// Several data files: the worst poses, the outlier warning and JSON `rejected` name a pose's
/// file beside its line (each file counts its own lines), where `pose 34 (line 8)` left the
/// user three files to look in.
#[test]
fn poses_from_several_files_are_named_with_their_file() {
    let dir = scratch("round3b-pose-files");
    let s = write(
        &dir,
        "s3.yaml",
        &sockets3("  - {distance: [0, 1], value: 0.4}\n"),
    );
    let s = s.display().to_string();
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "60",
        "--seed",
        "3",
        "--noise-track",
        "1e-5",
    ])
    .ok()
    .stdout;
    // One file per socket: its rows without the `constraint` column.
    let strip = |l: &str| l.rsplit_once(',').map_or(l, |(q, _)| q).to_string();
    let header = strip(sim.lines().next().expect("a header"));
    let mut files = Vec::new();
    for c in 0..3 {
        let mut text = format!("{header}\n");
        for (k, l) in sim
            .lines()
            .skip(1)
            .filter(|l| l.ends_with(&format!(",{c}")))
            .enumerate()
        {
            let mut row: Vec<String> = strip(l).split(',').map(str::to_string).collect();
            if c == 1 && k == 6 {
                // Line 8 of the second file: a joint reading off by 0.3 rad.
                let q: f64 = row[0].parse().expect("a reading");
                row[0] = (q + 0.3).to_string();
            }
            text.push_str(&row.join(","));
            text.push('\n');
        }
        files.push(
            write(&dir, &format!("c{c}.csv"), &text)
                .display()
                .to_string(),
        );
    }
    let mut args: Vec<&str> = vec!["calibrate", &s];
    args.extend(files.iter().map(String::as_str));
    let text = lincal(&args).ok().stdout;
    assert!(text.contains("c1.csv line 8)"), "{text}");
    args.extend(["--reject-outliers", "--format", "json"]);
    let json = lincal(&args).ok().json();
    let rejected = &json["rejected"][0];
    assert_eq!(
        (rejected["file"].as_str(), rejected["line"].as_u64()),
        (Some(files[1].as_str()), Some(8)),
        "{json}"
    );
    // One file: no `file` field, as before.
    let whole = write(&dir, "all.csv", &sim).display().to_string();
    let one = lincal(&["calibrate", &s, &whole, "--format", "json"])
        .ok()
        .json();
    assert!(
        one["worst_poses"][0].get("file").is_none(),
        "{}",
        one["worst_poses"]
    );
}

/// `--robust` with the default prior: one joint reading off by 0.5 rad among the laser
/// tracker example's 120 poses. The prior's strength is scaled by the noise level, which
/// the outlier must not set (it made the prior 700 times too strong, the arm 20 standard
/// deviations off): the robust fit with the prior now ends where the robust fit without it
/// does, within a standard deviation.
#[test]
fn a_robust_fit_scales_its_prior_by_the_robust_noise() {
    let dir = scratch("round3b-robust-prior");
    let ex = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let urdf = ex.join("robot/ur5.urdf");
    let imported = import_ur5(&urdf, &["--tool", "0.04,0,0.03"]);
    let s = write(&dir, "spec.yaml", &imported).display().to_string();
    let text = std::fs::read_to_string(ex.join("laser_tracker/tracker.csv")).expect("the data");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut row: Vec<String> = lines[1].split(',').map(str::to_string).collect();
    let q: f64 = row[1].parse().expect("a reading");
    row[1] = (q + 0.5).to_string();
    lines[1] = row.join(",");
    let data = write(&dir, "one_bad.csv", &(lines.join("\n") + "\n"))
        .display()
        .to_string();
    let fit = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            &s,
            &data,
            "--robust",
            "cauchy",
            "--format",
            "json",
        ];
        args.extend_from_slice(extra);
        crate::util::values(&lincal(&args).ok().json())
    };
    let (with, without) = (fit(&[]), fit(&["--prior", "off"]));
    let stds = lincal(&[
        "calibrate",
        &s,
        &data,
        "--robust",
        "cauchy",
        "--format",
        "json",
    ])
    .ok()
    .json();
    for name in ["a2", "a3", "d4", "d5"] {
        let std = stds["params"][name]["std"].as_f64().expect("a std");
        assert!(
            (with[name] - without[name]).abs() < std,
            "{name}: {} with the prior, {} without (std {std})",
            with[name],
            without[name]
        );
    }
}

/// A URDF whose joint origin pitches `1.5707963` (3·10⁻⁸ from π/2), with odd names, a
/// continuous, a prismatic and fixed joints: `--write-urdf` writes it in every convention
/// and kind, where the rpy read off near the gimbal lock put the written tip 2.6·10⁻⁸ m off
/// and the whole calibration was refused as "(a bug)".
#[test]
fn a_urdf_near_the_gimbal_lock_is_written() {
    let dir = scratch("round3b-gimbal");
    let urdf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/gimbal_odd.urdf");
    for convention in ["dh", "mdh", "urdf"] {
        let imported = lincal(&[
            "import",
            urdf.to_str().expect("a path"),
            "--base",
            "world base",
            "--tip",
            "tip\"link",
            "--tool",
            "0.01,0.02,0.03",
            "--convention",
            convention,
        ])
        .ok()
        .stdout;
        let s = write(&dir, &format!("{convention}.yaml"), &imported)
            .display()
            .to_string();
        let data = lincal(&[
            "simulate",
            &s,
            "--poses",
            "150",
            "--seed",
            "3",
            "--noise-measure",
            "1e-5",
        ])
        .ok()
        .stdout;
        let data = write(&dir, &format!("{convention}.csv"), &data)
            .display()
            .to_string();
        let out = dir.join(format!("{convention}.urdf")).display().to_string();
        lincal(&["calibrate", &s, &data, "--write-urdf", &out]).ok();
    }
}

/// Measured poses whose quaternions are written scalar-last under a `qw,qx,qy,qz` header (the
/// pose tracker example's data, reordered): a warning says the orientations fit nothing and
/// names the convention to check; the data as written draw none.
#[test]
fn orientations_in_another_convention_are_named() {
    let dir = scratch("round3b-orientation-convention");
    let ex = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let imported = import_ur5(
        &ex.join("robot/ur5.urdf"),
        &["--tool", "0.03,0,0.05", "--constraint", "measured_pose"],
    );
    let s = write(&dir, "spec.yaml", &imported).display().to_string();
    let text = std::fs::read_to_string(ex.join("pose_tracker/poses.csv")).expect("the data");
    let mut lines = text.lines();
    let mut reordered = format!("{}\n", lines.next().expect("a header"));
    for l in lines {
        let c: Vec<&str> = l.split(',').collect();
        let n = c.len();
        let row = [&c[..n - 4], &c[n - 3..], &c[n - 4..n - 3]].concat();
        reordered.push_str(&row.join(","));
        reordered.push('\n');
    }
    let bad = write(&dir, "scalar_last.csv", &reordered)
        .display()
        .to_string();
    let good = ex.join("pose_tracker/poses.csv").display().to_string();
    for (data, warned) in [(good, false), (bad, true)] {
        let out = lincal(&["calibrate", &s, &data]).ok().stdout;
        assert_eq!(
            out.contains("do not fit the calibrated model at all"),
            warned,
            "{out}"
        );
    }
}

/// Joint targets of the laser tracker example's UR5 that the pulled solve stopped short of
/// (3·10⁻¹⁰ to 1.6·10⁻⁴ m after its steps stalled) and called `diverged`, with exit 1: they
/// are within reach, and the undamped steps that follow now reach them.
#[test]
fn reachable_targets_are_reached_not_called_diverged() {
    let dir = scratch("round3b-compensate-polish");
    let ex = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let imported = import_ur5(&ex.join("robot/ur5.urdf"), &["--tool", "0.04,0,0.03"]);
    let s = write(&dir, "spec.yaml", &imported).display().to_string();
    let data = ex.join("laser_tracker/tracker.csv").display().to_string();
    let result = lincal(&["calibrate", &s, &data, "--format", "json"])
        .ok()
        .stdout;
    let result = write(&dir, "result.json", &result).display().to_string();
    let targets = "q1,q2,q3,q4,q5,q6
-1.241851,1.154412,0.952229,1.373876,0.143589,0.858262
-1.226432,-1.399794,-0.412217,-0.860422,0.420895,0.547071
0.426890,1.166474,0.592141,-1.086334,-0.034967,-1.375264
-0.077772,-0.995966,-1.460945,1.467410,0.253167,-0.056068
-1.110221,1.280688,0.277268,-0.215116,0.307125,-0.936512
-1.177695,-1.316866,-0.611141,-1.142426,0.240651,-0.850372
-0.275130,0.839573,1.299402,-0.279949,0.209735,0.442143
";
    let targets = write(&dir, "targets.csv", targets).display().to_string();
    let out = lincal(&[
        "compensate",
        &s,
        "--params",
        &result,
        &targets,
        "--intended-base",
        "calibrated",
    ])
    .ok()
    .stdout;
    let rows: Vec<&str> = out.lines().skip(1).collect();
    assert_eq!(rows.len(), 7, "{out}");
    assert!(rows.iter().all(|r| r.ends_with(",ok")), "{out}");
}
