//! URDF in and out, `predict`, `--write-spec`, several data files and headerless logs.
//!
//! The URDF's forward kinematics is computed here from its parsed origins and axes (4×4
//! products, Rodrigues rotations), independently of lincal's import; `lincal predict` gives
//! the spec's tips (lincal's own DH evaluation), and the two must agree to 1e-12 m.

use std::path::{Path, PathBuf};

use crate::util::{
    calibrate_refined, lincal, scratch, simulate, spec, truth_values, within_5_std, write,
};

type M4 = [[f64; 4]; 4];

fn mul(a: &M4, b: &M4) -> M4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            r[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

fn rot(u: [f64; 3], t: f64) -> M4 {
    let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let [x, y, z] = [u[0] / n, u[1] / n, u[2] / n];
    let (s, c) = t.sin_cos();
    let v = 1.0 - c;
    [
        [c + x * x * v, x * y * v - z * s, x * z * v + y * s, 0.0],
        [y * x * v + z * s, c + y * y * v, y * z * v - x * s, 0.0],
        [z * x * v - y * s, z * y * v + x * s, c + z * z * v, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn tr(p: [f64; 3]) -> M4 {
    [
        [1.0, 0.0, 0.0, p[0]],
        [0.0, 1.0, 0.0, p[1]],
        [0.0, 0.0, 1.0, p[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// The tip point of the URDF chain `base → tip` at readings `q` (moving joints in order).
fn urdf_tip(path: &Path, base: &str, tip: &str, tool: [f64; 3], q: &[f64]) -> [f64; 3] {
    let robot = urdf_rs::read_file(path).expect("the URDF parses");
    let mut chain = Vec::new();
    let mut link = tip.to_string();
    while link != base {
        let j = robot
            .joints
            .iter()
            .find(|j| j.child.link == link)
            .expect("a parent joint");
        chain.push(j.clone());
        link = j.parent.link.clone();
    }
    chain.reverse();
    let mut t = tr([0.0; 3]);
    let mut i = 0;
    for j in &chain {
        let [r, p, y] = j.origin.rpy.0;
        let o = mul(
            &mul(
                &mul(&tr(j.origin.xyz.0), &rot([0.0, 0.0, 1.0], y)),
                &rot([0.0, 1.0, 0.0], p),
            ),
            &rot([1.0, 0.0, 0.0], r),
        );
        t = mul(&t, &o);
        let a = j.axis.xyz.0;
        match j.joint_type {
            urdf_rs::JointType::Fixed => {}
            urdf_rs::JointType::Prismatic => {
                let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                t = mul(&t, &tr([q[i] * a[0] / n, q[i] * a[1] / n, q[i] * a[2] / n]));
                i += 1;
            }
            _ => {
                t = mul(&t, &rot(a, q[i]));
                i += 1;
            }
        }
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        *xk = t[k][0] * tool[0] + t[k][1] * tool[1] + t[k][2] * tool[2] + t[k][3];
    }
    x
}

fn test_urdf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/ur5_rail.urdf")
}

/// Deterministic pseudo-random readings in [-3, 3].
fn readings(n: usize, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..count)
        .map(|_| {
            (0..n)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    (s >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
                })
                .collect()
        })
        .collect()
}

fn joints_csv(qs: &[Vec<f64>], header: bool) -> String {
    let n = qs[0].len();
    let mut s = String::new();
    if header {
        let h: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
        s.push_str(&h.join(","));
        s.push('\n');
    }
    for q in qs {
        let r: Vec<String> = q.iter().map(|v| format!("{v:?}")).collect();
        s.push_str(&r.join(","));
        s.push('\n');
    }
    s
}

fn tips(csv: &str) -> Vec<Vec<f64>> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
        .collect()
}

/// `‖a − b‖`, the library's own.
use lincal::lincal_core::calibrate::constraint_fit::distance as dist;

/// Imports a chain and returns the spec's path.
use crate::util::import_rail as import;

#[test]
fn imported_specs_reproduce_the_urdf_at_random_readings() {
    let dir = scratch("urdf_import_fk");
    let urdf = test_urdf();
    // (base, tip, tool, convention): the rail (axis along -x) with the arm, the arm alone with
    // a tool off every axis, the arm to a link reached through a fixed joint with a rotation.
    let cases: &[(&str, &str, [f64; 3], &str)] = &[
        ("world", "ee_link", [0.0; 3], "dh"),
        ("world", "ee_link", [0.0; 3], "mdh"),
        ("base_link", "tool0", [0.03, -0.02, 0.11], "dh"),
        ("base_link", "tool0", [0.03, -0.02, 0.11], "mdh"),
        ("carriage", "upper_arm_link", [0.1, 0.2, 0.3], "dh"),
        ("world", "ee_link", [0.0; 3], "urdf"),
        ("base_link", "tool0", [0.03, -0.02, 0.11], "urdf"),
    ];
    for (k, &(base, tip, tool, conv)) in cases.iter().enumerate() {
        let t = format!("{},{},{}", tool[0], tool[1], tool[2]);
        let spec = import(
            &dir,
            &format!("s{k}.yaml"),
            &[
                "--base",
                base,
                "--tip",
                tip,
                "--tool",
                &t,
                "--convention",
                conv,
            ],
        );
        let text = std::fs::read_to_string(&spec).unwrap();
        assert!(text.contains(&format!("convention: {conv}")), "{text}");
        let n = text.matches("  - {type:").count();
        let qs = readings(n, 50, 7 + k as u64);
        let data = write(&dir, &format!("q{k}.csv"), &joints_csv(&qs, true));
        let run = lincal(&[
            "predict",
            spec.to_str().unwrap(),
            "--nominal",
            data.to_str().unwrap(),
        ])
        .ok();
        let got = tips(&run.stdout);
        assert_eq!(got.len(), qs.len());
        for (q, x) in qs.iter().zip(&got) {
            let want = urdf_tip(&urdf, base, tip, tool, q);
            let d = dist(x, &want);
            assert!(d < 1e-12, "{base}->{tip} {conv}: tip off by {d:e} at {q:?}");
        }
    }
}

#[test]
fn import_names_every_parameter_and_records_the_source() {
    let dir = scratch("urdf_import_record");
    let spec = import(&dir, "s.yaml", &["--base", "world", "--tip", "ee_link"]);
    let text = std::fs::read_to_string(&spec).unwrap();
    // The rail is prismatic, the wrist's last joint continuous (a revolute joint here).
    assert!(
        text.contains("{type: prismatic, a: a1, alpha: alpha1, theta: theta1, offset: offset1"),
        "{text}"
    );
    assert!(text.contains("joints: [\"rail_joint\", \"shoulder_pan_joint\", \"shoulder_lift_joint\", \"elbow_joint\", \"wrist_1_joint\", \"wrist_2_joint\", \"wrist_3_joint\"]"), "{text}");
    assert!(text.contains("tip: \"ee_link\""));
    assert!(text.contains(
        "Fixed joints folded into base, frames and tool: carriage_to_base, ee_fixed_joint"
    ));
    assert!(
        text.contains("parallel axes"),
        "the UR5's three parallel axes are noted"
    );
    // Each parallel pair's normal takes Hayati's tilt in place of the redundant offset.
    assert!(text.contains("beta3: {nominal: 0}") && text.contains("beta4: {nominal: 0}"));
    assert!(!text.contains("d3:") && !text.contains("d4:"), "{text}");
    // Every parameter is estimated (none known) and the basis is computable (the two tilts'
    // angles take it past the default bound of the exact expansion, which a calibration
    // does not need).
    assert!(!text.contains("known"));
    let run = lincal(&[
        "basis",
        spec.to_str().unwrap(),
        "--format",
        "json",
        "--max-terms",
        "2000000",
    ])
    .ok();
    let v = run.json();
    assert_eq!(v["joints"], 7);
    // 4 per joint but the last (its home only), the base's 6 and the tool's 3 (a tilt in
    // place of each parallel pair's offset).
    assert_eq!(v["params"].as_array().unwrap().len(), 4 * 6 + 1 + 6 + 3);
    // Other constraint blocks load and have fresh parameters.
    for kind in ["point", "plane", "sphere", "line"] {
        let s = import(
            &dir,
            &format!("{kind}.yaml"),
            &[
                "--base",
                "base_link",
                "--tip",
                "ee_link",
                "--constraint",
                kind,
            ],
        );
        let run = lincal(&["basis", s.to_str().unwrap(), "--format", "json"]).ok();
        assert!(
            run.json()["identifiable_count"].as_u64().unwrap() > 0,
            "{kind}"
        );
    }
}

#[test]
fn calibrate_writes_a_spec_and_a_urdf_that_reproduce_the_calibrated_tips() {
    calibrate_and_write("dh");
}

/// The URDF-native rows (every joint origin's six entries unknown, the truth moving every
/// one of them, held ones included) fit exact data exactly and write back the URDF's own
/// frames, for the rail whose axis is −x and the arm whose frames `import` turned.
#[test]
fn urdf_native_rows_fit_exactly_and_write_the_urdf_back() {
    calibrate_and_write("urdf");
}

/// Import with `convention`, simulate exact data from a perturbed truth, calibrate with
/// `--write-spec` and `--write-urdf`, and compare the three calibrated models' tips.
fn calibrate_and_write(convention: &str) {
    let dir = scratch(&format!("urdf_write_{convention}"));
    let urdf = test_urdf();
    let spec = crate::util::import_rail_chain(&dir, "s.yaml", convention);
    let s = spec.to_str().unwrap();
    let truth = dir.join("truth.yaml");
    let sim = lincal(&[
        "simulate",
        s,
        "--poses",
        "150",
        "--seed",
        "11",
        "--truth-out",
        truth.to_str().unwrap(),
    ])
    .ok();
    let data = write(&dir, "d.csv", &sim.stdout);
    let d = data.to_str().unwrap();
    let (out_spec, out_urdf) = (dir.join("cal.yaml"), dir.join("cal.urdf"));
    let run = lincal(&[
        "calibrate",
        s,
        d,
        "--format",
        "json",
        "--write-spec",
        out_spec.to_str().unwrap(),
        "--write-urdf",
        out_urdf.to_str().unwrap(),
    ])
    .ok();
    let result = write(&dir, "result.json", &run.stdout);
    let rms = run.json()["residual_rms"].as_f64().unwrap();
    assert!(rms < 1e-9, "exact data fit to {rms}");

    // The tips of the calibrated model, three ways: the result's parameters, the written
    // spec's nominals, the written URDF's own kinematics.
    let qs = readings(7, 40, 99);
    let qcsv = write(&dir, "q.csv", &joints_csv(&qs, true));
    let q = qcsv.to_str().unwrap();
    let by_params = tips(
        &lincal(&["predict", s, "--params", result.to_str().unwrap(), q])
            .ok()
            .stdout,
    );
    let by_spec = tips(
        &lincal(&["predict", out_spec.to_str().unwrap(), "--nominal", q])
            .ok()
            .stdout,
    );
    let nominal = tips(&lincal(&["predict", s, "--nominal", q]).ok().stdout);
    let mut moved: f64 = 0.0;
    for (k, qk) in qs.iter().enumerate() {
        let from_urdf = urdf_tip(&out_urdf, "world", "ee_link", [0.0; 3], qk);
        assert!(
            dist(&by_params[k], &by_spec[k]) < 1e-12,
            "written spec at pose {k}"
        );
        let d = dist(&by_params[k], &from_urdf);
        assert!(d < 1e-12, "written URDF off by {d:e} at pose {k}");
        moved = moved.max(dist(&by_params[k], &nominal[k]));
    }
    assert!(moved > 1e-3, "the calibration changed the model ({moved})");

    // The written spec keeps the original's comments, order and record; only numbers change.
    let before = std::fs::read_to_string(&spec).unwrap();
    let after = std::fs::read_to_string(&out_spec).unwrap();
    let keys = |t: &str| -> Vec<String> {
        t.lines()
            .map(|l| l.split(':').next().unwrap_or("").to_string())
            .collect()
    };
    assert_eq!(keys(&before), keys(&after));
    assert!(after.starts_with("# Written by `lincal import"));
    assert!(after.contains("urdf:\n  path: "));
    // Everything outside the URDF's rewritten origins is as it was.
    let u0 = std::fs::read_to_string(&urdf).unwrap();
    let u1 = std::fs::read_to_string(&out_urdf).unwrap();
    for l in u0.lines().filter(|l| !l.contains("<origin")) {
        assert!(u1.contains(l), "line lost: {l}");
    }
    assert!(
        u1.contains("<origin xyz=\"0.0 0.0 0.1\" rpy=\"0.0 0.0 3.141592653589793\"/>"),
        "the fixed joint inside the chain is kept"
    );
    // A second round from the written spec: write-urdf works from it too (the record stays).
    let run = lincal(&[
        "calibrate",
        out_spec.to_str().unwrap(),
        d,
        "--write-urdf",
        dir.join("again.urdf").to_str().unwrap(),
    ]);
    run.ok();
}

#[test]
fn write_urdf_needs_an_imported_spec_and_a_place_for_the_tip() {
    let dir = scratch("urdf_write_errors");
    let data = write(
        &dir,
        "d.csv",
        &lincal(&[
            "simulate",
            spec("plane_spatial.yaml").to_str().unwrap(),
            "--poses",
            "60",
        ])
        .ok()
        .stdout,
    );
    let out = dir.join("x.urdf");
    lincal(&[
        "calibrate",
        spec("plane_spatial.yaml").to_str().unwrap(),
        data.to_str().unwrap(),
        "--write-urdf",
        out.to_str().unwrap(),
    ])
    .fails(
        2,
        &[
            "plane_spatial.yaml",
            "field `urdf`",
            "did not come from `lincal import`",
        ],
    );
    assert!(!out.exists());
    // The tip link is the child of the last moving joint: a moved tool has nowhere to go.
    let s = import(
        &dir,
        "w3.yaml",
        &[
            "--base",
            "base_link",
            "--tip",
            "wrist_3_link",
            "--tool",
            "0,0.1,0.05",
        ],
    );
    let sim = lincal(&[
        "simulate",
        s.to_str().unwrap(),
        "--poses",
        "80",
        "--seed",
        "5",
    ])
    .ok();
    let d = write(&dir, "w3.csv", &sim.stdout);
    lincal(&[
        "calibrate",
        s.to_str().unwrap(),
        d.to_str().unwrap(),
        "--write-urdf",
        out.to_str().unwrap(),
    ])
    .fails(
        1,
        &["no fixed joint between it and the tip link `wrist_3_link`"],
    );
    // A record whose link is not in the URDF names the spec's record, not `import`'s option.
    let text = std::fs::read_to_string(&s).unwrap();
    let renamed = write(
        &dir,
        "renamed.yaml",
        &text.replace("  base: \"base_link\"", "  base: \"no_such_link\""),
    );
    lincal(&[
        "calibrate",
        renamed.to_str().unwrap(),
        d.to_str().unwrap(),
        "--write-urdf",
        out.to_str().unwrap(),
    ])
    .fails(2, &["urdf.base (the spec's record)", "no_such_link"]);
}

#[test]
fn import_errors_name_the_place() {
    let u = test_urdf();
    let u = u.to_str().unwrap();
    lincal(&["import", u, "--base", "world", "--tip", "nowhere"])
        .fails(2, &["ur5_rail.urdf", "field `--tip`", "no link `nowhere`"]);
    lincal(&["import", u, "--base", "ee_link", "--tip", "base_link"]).fails(
        2,
        &[
            "field `--base`",
            "`ee_link` is not an ancestor of `base_link`",
            "not a serial path",
        ],
    );
    lincal(&["import", u, "--base", "base_link", "--tip", "target_object"]).fails(
        2,
        &[
            "ur5_rail.urdf:102",
            "field `joint `object_joint`.type`",
            "`floating` joint",
        ],
    );
    lincal(&["import", u, "--base", "world", "--tip", "cart"])
        .fails(2, &["ur5_rail.urdf:106", "`planar` joint"]);
    lincal(&[
        "import", u, "--base", "world", "--tip", "ee_link", "--tool", "1,2",
    ])
    .fails(2, &["field `--tool`"]);
    let dir = scratch("urdf_import_errors");
    let broken = write(&dir, "b.urdf", "<robot name=\"r\"><link name=\"a\"/>");
    lincal(&[
        "import",
        broken.to_str().unwrap(),
        "--base",
        "a",
        "--tip",
        "a",
    ])
    .fails(2, &["b.urdf", "not a readable URDF"]);
    let zero = write(
        &dir,
        "z.urdf",
        "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 0 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint></robot>",
    );
    lincal(&[
        "import",
        zero.to_str().unwrap(),
        "--base",
        "a",
        "--tip",
        "b",
    ])
    .fails(2, &["z.urdf:2", "joint `j`.axis", "no direction"]);
    // A cycle off the chain taken (`j2` makes the base a child of its own child): not a tree.
    let cyclic = write(
        &dir,
        "cyc.urdf",
        "<robot name=\"c\">\n<link name=\"b\"/><link name=\"l1\"/><link name=\"t\"/>\n\
         <joint name=\"j1\" type=\"revolute\"><parent link=\"b\"/><child link=\"l1\"/><axis \
         xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/></joint>\n\
         <joint name=\"j2\" type=\"revolute\"><parent link=\"l1\"/><child link=\"b\"/><axis \
         xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/></joint>\n\
         <joint name=\"j3\" type=\"revolute\"><parent link=\"l1\"/><child link=\"t\"/><origin \
         xyz=\"0.2 0 0\"/><axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" \
         velocity=\"1\"/></joint>\n</robot>\n",
    );
    lincal(&[
        "import",
        cyclic.to_str().unwrap(),
        "--base",
        "b",
        "--tip",
        "t",
    ])
    .fails(2, &["cyc.urdf:", "form a cycle", "a URDF is a tree"]);
}

/// A `<limit>` that gives no range (lower above upper; bounds left out, which URDF reads as
/// 0) is not carried into the spec, and the import says so for each joint instead of
/// dropping it silently; a good one is kept.
#[test]
fn limits_without_a_range_are_named_not_dropped_silently() {
    let dir = scratch("urdf-limits");
    let joint = |name: &str, parent: &str, child: &str, limit: &str| {
        format!(
            "<joint name=\"{name}\" type=\"revolute\"><parent link=\"{parent}\"/><child \
             link=\"{child}\"/><origin xyz=\"0.2 0 0\"/><axis xyz=\"0 0 1\"/>{limit}</joint>\n"
        )
    };
    let urdf = write(
        &dir,
        "l.urdf",
        &format!(
            "<robot name=\"l\">\n<link name=\"b\"/><link name=\"l1\"/><link name=\"l2\"/>\
             <link name=\"l3\"/><link name=\"t\"/>\n{}{}{}{}</robot>\n",
            joint(
                "good",
                "b",
                "l1",
                "<limit lower=\"-2\" upper=\"2\" effort=\"1\" velocity=\"1\"/>"
            ),
            joint(
                "swapped",
                "l1",
                "l2",
                "<limit lower=\"1\" upper=\"-1\" effort=\"1\" velocity=\"1\"/>"
            ),
            joint("bare", "l2", "l3", "<limit effort=\"1\" velocity=\"1\"/>"),
            joint(
                "wide",
                "l3",
                "t",
                "<limit lower=\"-1e10\" upper=\"1e10\" effort=\"1\" velocity=\"1\"/>",
            ),
        ),
    );
    let run = lincal(&[
        "import",
        urdf.to_str().unwrap(),
        "--base",
        "b",
        "--tip",
        "t",
    ])
    .ok();
    // A limit beyond 10⁹ (no number of a spec is) is none either, where the import failed
    // as "(a bug)".
    for (name, lo, hi) in [
        ("swapped", "1.0", "-1.0"),
        ("bare", "0", "0"),
        ("wide", "-10000000000.0", "10000000000.0"),
    ] {
        let note = format!("joint `{name}` (line ");
        assert!(run.stderr.contains(&note), "{}", run.stderr);
        assert!(
            run.stderr
                .contains(&format!("lower {lo} upper {hi} gives no range (")),
            "{}",
            run.stderr
        );
        assert!(run.stdout.contains(&note), "{}", run.stdout);
    }
    assert!(!run.stderr.contains("joint `good`"), "{}", run.stderr);
    let limited: Vec<&str> = run
        .stdout
        .lines()
        .filter(|l| l.starts_with("  - {") && l.contains("limits:"))
        .collect();
    assert_eq!(limited.len(), 1, "{}", run.stdout);
    assert!(limited[0].contains("limits: [-2.0, 2.0]"), "{}", limited[0]);
}

#[test]
fn predict_gives_the_chains_tips() {
    let dir = scratch("predict");
    // A planar 2R arm: x = a1 cos θ1 + a2 cos(θ1 + θ2), θi = qi − homei.
    let s = write(
        &dir,
        "p.yaml",
        "name: p\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: h1}\n  - {type: revolute, a: 0.5}\n\
         params:\n  a1: {nominal: 0.3}\n  h1: {nominal: 0.1}\nconstraint: {point: {p: [0.2, 0.1]}}\n",
    );
    let data = write(&dir, "d.csv", "q2,q1\n0.5,0.25\n-1,2\n");
    let res = write(
        &dir,
        "r.json",
        "{\"params\": {\"a1\": {\"value\": 0.31}, \"h1\": {\"value\": -0.2}}}",
    );
    for (args, a1, h1) in [
        (vec!["--nominal"], 0.3, 0.1),
        (vec!["--params", res.to_str().unwrap()], 0.31, -0.2),
    ] {
        let mut all = vec!["predict", s.to_str().unwrap()];
        all.extend(args);
        all.push(data.to_str().unwrap());
        let run = lincal(&all).ok();
        assert!(run.stdout.starts_with("x,y\n"));
        let got = tips(&run.stdout);
        for (row, (q1, q2)) in got.iter().zip([(0.25f64, 0.5f64), (2.0, -1.0)]) {
            let t1 = q1 - h1;
            let want = [
                a1 * t1.cos() + 0.5 * (t1 + q2).cos(),
                a1 * t1.sin() + 0.5 * (t1 + q2).sin(),
            ];
            assert!(dist(row, &want) < 1e-15, "{row:?} vs {want:?}");
        }
    }
    let bad = write(
        &dir,
        "bad.json",
        "{\"params\": {\"a1\": {\"value\": 0.31}}}",
    );
    lincal(&[
        "predict",
        s.to_str().unwrap(),
        "--params",
        bad.to_str().unwrap(),
        data.to_str().unwrap(),
    ])
    .fails(2, &["bad.json", "field `params.h1.value`", "missing"]);
    let other = write(&dir, "other.json", "{\"params\": {\"zz\": {\"value\": 1}}}");
    lincal(&[
        "predict",
        s.to_str().unwrap(),
        "--params",
        other.to_str().unwrap(),
        data.to_str().unwrap(),
    ])
    .fails(2, &["field `params.zz`", "another spec"]);
}

#[test]
fn one_headerless_file_per_constraint_gives_the_same_fit() {
    let dir = scratch("multi_file");
    let s = spec("lines_list.yaml");
    let s = s.to_str().unwrap();
    let sim = lincal(&["simulate", s, "--poses", "80", "--seed", "4"]).ok();
    let one = write(&dir, "all.csv", &sim.stdout);
    let mut lines = sim.stdout.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let ci = header.iter().position(|h| *h == "constraint").unwrap();
    let (mut f0, mut f1) = (String::new(), String::new());
    for l in lines {
        let cells: Vec<&str> = l.split(',').collect();
        let row: Vec<&str> = cells
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != ci)
            .map(|(_, c)| *c)
            .collect();
        let out = if cells[ci] == "0" { &mut f0 } else { &mut f1 };
        out.push_str(&row.join(","));
        out.push('\n');
    }
    let cols: Vec<&str> = header
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != ci)
        .map(|(_, c)| *c)
        .collect();
    let cols = cols.join(",");
    let (a, b) = (
        write(&dir, "hole_0.csv", &f0),
        write(&dir, "hole_1.csv", &f1),
    );
    let whole = lincal(&["calibrate", s, one.to_str().unwrap(), "--format", "json"])
        .ok()
        .json();
    let split = lincal(&[
        "calibrate",
        s,
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--no-header",
        "--columns",
        &cols,
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(whole["poses"], split["poses"]);
    for (name, p) in whole["params"].as_object().unwrap() {
        let (x, y) = (
            p["value"].as_f64().unwrap(),
            split["params"][name]["value"].as_f64().unwrap(),
        );
        assert!((x - y).abs() < 1e-9 * (1.0 + x.abs()), "{name}: {x} vs {y}");
    }
    // The wrong number of files, and a bad column name, are located errors.
    lincal(&[
        "calibrate",
        s,
        a.to_str().unwrap(),
        "--no-header",
        "--columns",
        &cols,
    ])
    .fails(2, &["hole_0.csv", "missing column `constraint`"]);
    lincal(&[
        "calibrate",
        s,
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        a.to_str().unwrap(),
        "--no-header",
        "--columns",
        &cols,
    ])
    .fails(
        2,
        &["field `DATA`", "3 data files for a list of 2 constraints"],
    );
    lincal(&[
        "calibrate",
        s,
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--no-header",
        "--columns",
        "q1,qq",
    ])
    .fails(
        2,
        &["hole_0.csv", "field `--columns`", "unknown column `qq`"],
    );
    // A bad cell names its file and line (1-based, no header).
    let broken = write(
        &dir,
        "hole_1b.csv",
        &f1.replacen(',', ",abc,", 1).replacen(",abc,", ",abc", 1),
    );
    let run = lincal(&[
        "calibrate",
        s,
        a.to_str().unwrap(),
        broken.to_str().unwrap(),
        "--no-header",
        "--columns",
        &cols,
    ]);
    run.fails(2, &["hole_1b.csv:1"]);
}

#[test]
fn a_urdf_with_pi_rounded_to_four_decimals_imports_with_snapped_axes() {
    let dir = scratch("urdf_rounded_pi");
    let text = std::fs::read_to_string(test_urdf())
        .unwrap()
        .replace("3.141592653589793", "3.1416")
        .replace("1.570796325", "1.5708")
        // The elbow turned by Rz(π)·Rx(π) = Ry(π) about its own (parallel) axis, written
        // with π rounded: its axis is then ~10⁻⁵ rad off the shoulder's.
        .replace(
            r#"xyz="0.0 -0.1197 0.425" rpy="0.0 0.0 0.0""#,
            r#"xyz="0.0 -0.1197 0.425" rpy="3.1416 0.0 3.1416""#,
        );
    assert!(text.contains("1.5708") && text.contains("3.1416 0.0 3.1416"));
    let urdf = write(&dir, "rounded.urdf", &text);
    let u = urdf.to_str().unwrap();
    let run = lincal(&["import", u, "--base", "world", "--tip", "ee_link"]).ok();
    assert!(
        run.stdout.contains("made") && run.stdout.contains("exactly parallel"),
        "{}",
        run.stdout
    );
    let spec = write(&dir, "s.yaml", &run.stdout);
    let n = run.stdout.matches("  - {type:").count();
    let qs = readings(n, 50, 11);
    let data = write(&dir, "q.csv", &joints_csv(&qs, true));
    let run = lincal(&[
        "predict",
        spec.to_str().unwrap(),
        "--nominal",
        data.to_str().unwrap(),
    ])
    .ok();
    let got = tips(&run.stdout);
    assert_eq!(got.len(), qs.len());
    // The rounding tilts axes by ~4e-6 rad; over a few metres of reach and travel the
    // snapped spec's tips stay within 1e-4 m of the rounded URDF's.
    let mut worst = 0.0f64;
    for (q, x) in qs.iter().zip(&got) {
        worst = worst.max(dist(x, &urdf_tip(&urdf, "world", "ee_link", [0.0; 3], q)));
    }
    assert!(worst < 1e-4, "tip off by {worst:e}");
}

#[test]
fn a_tilted_parallel_pair_is_recovered_through_its_beta() {
    // The UR5's shoulder, elbow and wrist-1 axes are parallel in its URDF; a real arm's are
    // tilted a little within their plane, which no DH table takes and Hayati's `beta` does.
    // A truth drawn around the nominals (the tilts up to ±0.02 rad), tips measured with
    // 10 µm noise: the calibration with its default options recovers both tilts.
    let dir = scratch("urdf_hayati");
    let s = import(&dir, "s.yaml", &["--base", "world", "--tip", "ee_link"]);
    let (s, truth) = (s.to_str().unwrap(), dir.join("truth.yaml"));
    let sim = simulate(s, 300, 4, ["--noise-measure", "1e-5"], &truth);
    let data = write(&dir, "data.csv", &sim);
    let fit = calibrate_refined(s, &data);
    let tilts: Vec<(String, f64)> = truth_values(&truth)
        .into_iter()
        .filter(|(name, _)| name.starts_with("beta"))
        .collect();
    assert_eq!(tilts.len(), 2, "{tilts:?}");
    for (name, want) in tilts {
        assert!(
            want.abs() > 1e-3,
            "{name}: the truth is not tilted ({want})"
        );
        within_5_std(&fit, &name, want, 1e-4);
    }
    assert!(
        fit["residual_rms"].as_f64().unwrap() < 2e-5,
        "{}",
        fit["residual_rms"]
    );
}
