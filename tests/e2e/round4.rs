//! The fifth attack on hostile inputs (session 43): each test drives one input that gave a
//! wrong number with exit 0, a message that blamed the wrong thing, or a silent loss.

use crate::util::{lincal, scratch, spec, write};

/// `measured_spatial.yaml` simulated (`n` poses, seed 3): the CSV text.
fn measured_data(n: usize) -> String {
    let s = spec("measured_spatial.yaml");
    let n = n.to_string();
    let args = [
        "simulate",
        s.to_str().unwrap(),
        "--poses",
        &n,
        "--seed",
        "3",
    ];
    lincal(&args).ok().stdout
}

/// The CSV `text` with the columns `x, y, z` (the last three) scaled by `k`.
fn scaled_tips(text: &str, k: f64) -> String {
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let n = cells.len();
        let row: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(c, v)| match (i, c >= n - 3) {
                (0, _) | (_, false) => (*v).to_string(),
                _ => (v.parse::<f64>().expect("a number") * k).to_string(),
            })
            .collect();
        out += &row.join(",");
        out.push('\n');
    }
    out
}

/// Measured tips in millimetres for metres: the fit makes an arm 1000× its drawing with
/// residuals as small as ever, and a warning says so (it spoke only with `relations:` before).
#[test]
fn measured_tips_in_millimetres_are_warned_about() {
    let dir = scratch("round4-mm");
    let s = spec("measured_spatial.yaml").display().to_string();
    let metres = measured_data(80);
    assert!(metres.starts_with("q1,q2,q3,x,y,z"), "{metres}");
    for (name, k, warned) in [("m.csv", 1.0, false), ("mm.csv", 1000.0, true)] {
        let data = write(&dir, name, &scaled_tips(&metres, k));
        let run = lincal(&[
            "calibrate",
            &s,
            &data.display().to_string(),
            "--format",
            "json",
        ])
        .ok();
        let warnings = run.json()["warnings"].to_string();
        assert_eq!(
            warnings.contains("the size of the nominal one")
                && warnings.contains("the measured columns"),
            warned,
            "{name}: {warnings}"
        );
    }
}

/// Known constraints that hold for no point are refused at their field (exit 2), where the
/// data were blamed ("not finite at pose 0") or a residual of a metre came out with exit 0.
#[test]
fn constraints_with_no_point_are_refused_at_their_field() {
    let dir = scratch("round4-empty");
    let line = std::fs::read_to_string(spec("line3_spatial.yaml")).unwrap();
    let known = |text: &str, names: &[(&str, &str)]| {
        let mut t = text.to_string();
        for (name, value) in names {
            let at = t
                .find(&format!("  {name}: {{nominal:"))
                .expect("the parameter");
            let end = at + t[at..].find('\n').unwrap();
            t.replace_range(
                at..end,
                &format!("  {name}: {{nominal: {value}, known: true}}"),
            );
        }
        t
    };
    let parallel = known(
        &line,
        &[
            ("u1", "2"),
            ("u2", "0"),
            ("u3", "0"),
            ("v1", "-4"),
            ("v2", "0"),
            ("v3", "0"),
        ],
    );
    let parallel = write(&dir, "parallel.yaml", &parallel);
    lincal(&["simulate", &parallel.display().to_string(), "--poses", "5"])
        .fails(2, &["parallel.yaml", "constraint.line.planes", "parallel"]);
    let quadric = std::fs::read_to_string(spec("quadric_planar2.yaml")).unwrap();
    let empty = known(
        &quadric,
        &[
            ("A11", "1"),
            ("A12", "0"),
            ("A22", "2"),
            ("c1", "0"),
            ("c2", "0"),
        ],
    );
    let empty = write(&dir, "empty.yaml", &empty);
    let data = write(&dir, "d.csv", "q1,q2\n0.1,0.2\n");
    lincal(&[
        "calibrate",
        &empty.display().to_string(),
        &data.display().to_string(),
    ])
    .fails(2, &["empty.yaml", "constraint.quadric", "no real point"]);
}

/// A prismatic reading of 10⁹ m (limits [0.3, 0.9]) ends the fit before it starts as a lost
/// combination of angles; the message now names the row and the limits, which the warnings
/// of a fit that ran would have.
#[test]
fn a_failed_fit_names_the_readings_outside_the_limits() {
    let dir = scratch("round4-prismatic");
    let s = spec("prismatic_scara.yaml").display().to_string();
    let text = lincal(&["simulate", &s, "--poses", "60", "--seed", "2"])
        .ok()
        .stdout;
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let yaml = std::fs::read_to_string(spec("prismatic_scara.yaml")).unwrap();
    let prismatic = yaml
        .lines()
        .filter(|l| l.trim_start().starts_with("- {type:"))
        .position(|l| l.contains("prismatic"))
        .expect("a prismatic joint");
    let column = header
        .iter()
        .position(|h| *h == format!("q{}", prismatic + 1))
        .unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut row: Vec<String> = lines[4].split(',').map(str::to_string).collect();
    row[column] = "1e9".into();
    lines[4] = row.join(",");
    let data = write(&dir, "big.csv", &(lines.join("\n") + "\n"));
    lincal(&["calibrate", &s, &data.display().to_string()]).fails(
        1,
        &[
            "do not determine",
            "outside the spec's limits",
            "(line 5): q3 = 1e9",
        ],
    );
}

/// Limits written in degrees (`[-170, 170]` on a revolute joint, 27 turns) vouch for no
/// reading: degree data are refused under `--angles auto`, the limits named as degrees too.
#[test]
fn degree_limits_vouch_for_no_reading() {
    let dir = scratch("round4-degree-limits");
    let yaml = std::fs::read_to_string(spec("measured_spatial.yaml"))
        .unwrap()
        .replace("limits: [-3.0, 3.0]", "limits: [-170, 170]")
        .replace("home: th1}", "home: th1, limits: [-170, 170]}");
    let s = write(&dir, "deg.yaml", &yaml).display().to_string();
    let degrees: String = measured_data(20)
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return format!("{l}\n");
            }
            let c: Vec<String> = l
                .split(',')
                .enumerate()
                .map(|(k, v)| match k {
                    0..=2 => (v.parse::<f64>().unwrap().to_degrees()).to_string(),
                    _ => v.to_string(),
                })
                .collect();
            c.join(",") + "\n"
        })
        .collect();
    let data = write(&dir, "deg.csv", &degrees).display().to_string();
    lincal(&["predict", &s, "--nominal", &data]).fails(2, &["deg.csv", "limits are radians"]);
    lincal(&["calibrate", &s, &data, "--angles", "deg"]).ok();
}

/// A measured pose copied (a file given twice, rows written twice) is named in a warning:
/// each copy counts as a measurement and the standard deviations shrink as if it were.
#[test]
fn copied_measurements_are_warned_about() {
    let dir = scratch("round4-copies");
    let s = spec("measured_spatial.yaml").display().to_string();
    let text = measured_data(40);
    let data = write(&dir, "d.csv", &text).display().to_string();
    let copy = write(&dir, "copy.csv", &text).display().to_string();
    let warnings = |args: &[&str]| {
        let mut all = vec!["calibrate", &s];
        all.extend_from_slice(args);
        all.extend(["--format", "json"]);
        lincal(&all).ok().json()["warnings"].to_string()
    };
    assert!(!warnings(&[&data]).contains("repeat"));
    let twice = warnings(&[&data, &data]);
    assert!(
        twice.contains("40 measured pose(s) repeat an earlier one"),
        "{twice}"
    );
    assert!(twice.contains("(argument 2) repeats"), "{twice}");
    let other = warnings(&[&data, &copy]);
    assert!(other.contains("copy.csv (argument 2) repeats"), "{other}");
    let mut rows: Vec<&str> = text.lines().collect();
    rows.push(rows[3]);
    let doubled = write(&dir, "doubled.csv", &(rows.join("\n") + "\n"));
    let one = warnings(&[&doubled.display().to_string()]);
    assert!(
        one.contains("pose 40 (line 42) repeats pose 2 (line 4)"),
        "{one}"
    );
}

/// `--write-urdf` after a tracker calibration: by default the spec's `base:` goes in at its
/// calibrated value (the tracker's frame in the first joint's origin), and a `base:` moved
/// beyond 1 cm from its nominal is named in a warning; `--urdf-base urdf` leaves it out,
/// even where the spec's nominal guessed the tracker's place, so the URDF's `base_link` is the
/// robot's (its first origin as the original's, to the arm's own calibration).
#[test]
fn the_written_urdf_can_leave_the_trackers_frame_out() {
    let dir = scratch("round4-urdf-base");
    let urdf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/robot/ur5.urdf");
    let import = [
        "import",
        urdf.to_str().unwrap(),
        "--base",
        "base_link",
        "--tip",
        "tool0",
        "--tool",
        "0.04,0,0.03",
    ];
    let yaml = lincal(&import).ok().stdout;
    // The tracker stands 1.5 m along x; the spec's nominal guessed 1.3 m.
    let at = |x: &str| yaml.replace("base_x: {nominal: 0}", &format!("base_x: {{nominal: {x}}}"));
    let truth = write(&dir, "truth.yaml", &at("1.5")).display().to_string();
    let data = lincal(&["simulate", &truth, "--poses", "60", "--seed", "4"])
        .ok()
        .stdout;
    let data = write(&dir, "d.csv", &data).display().to_string();
    let guessed = at("1.3");
    assert_ne!(guessed, yaml);
    let s = write(&dir, "spec.yaml", &guessed).display().to_string();
    let first_origin = |extra: &[&str]| {
        let out = dir.join("out.urdf").display().to_string();
        let mut args = vec![
            "calibrate",
            &s,
            &data,
            "--write-urdf",
            &out,
            "--format",
            "json",
        ];
        args.extend_from_slice(extra);
        let warnings = lincal(&args).ok().json()["warnings"].to_string();
        let text = std::fs::read_to_string(&out).unwrap();
        let joint = text.find("<joint name=\"shoulder_pan_joint\"").unwrap();
        let at = joint + text[joint..].find("xyz=\"").unwrap() + 5;
        let xyz: Vec<f64> = text[at..at + text[at..].find('"').unwrap()]
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        (warnings, xyz)
    };
    let (warned, placed) = first_origin(&[]);
    assert!(
        warned.contains("--urdf-base urdf") && warned.contains("base_x +0.2"),
        "{warned}"
    );
    let (quiet, own) = first_origin(&["--urdf-base", "urdf"]);
    assert!(!quiet.contains("--urdf-base"), "{quiet}");
    let (chosen, _) = first_origin(&["--urdf-base", "calibrated"]);
    assert!(!chosen.contains("--urdf-base"), "{chosen}");
    // The robot's own frame: the shoulder 0.089 m above `base_link`, as drawn, to the
    // calibration's millimetres; in the tracker's frame, 1.5 m along x (the truth drawn
    // about it).
    let own_frame = (own[2] - 0.089159).abs() < 0.01 && own[0].abs() < 0.01;
    assert!(own_frame, "{own:?}");
    assert!((placed[0] - 1.5).abs() < 0.05, "{placed:?}");
    lincal(&["calibrate", &s, &data, "--urdf-base", "urdf"]).fails(2, &["--write-urdf"]);
}

/// A truth file whose values leave the constraint with no point (`b = 0`) is refused naming
/// the truth and the constraint's field, where `simulate` asked whether the constraint
/// crosses the workspace.
#[test]
fn a_truth_that_empties_the_constraint_is_named() {
    let dir = scratch("round4-truth");
    let s = spec("line_planar4.yaml").display().to_string();
    let zero = write(&dir, "zero.yaml", "b1: 0\nb2: 0\n")
        .display()
        .to_string();
    lincal(&["simulate", &s, "--poses", "3", "--truth", &zero]).fails(
        2,
        &["zero.yaml", "with the truth's values", "constraint.line.b"],
    );
    let fine = write(&dir, "fine.yaml", "b1: -1\n").display().to_string();
    lincal(&["simulate", &s, "--poses", "3", "--truth", &fine]).ok();
}
