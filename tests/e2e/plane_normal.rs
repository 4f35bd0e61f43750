//! The plane written by normal and offset, `plane: {normal: [n1, n2, n3], offset: d}` (the tip
//! satisfies `n·x = d`), through the binary: recovery of simulated arms on a known plane
//! through the origin (which `b·x + 1 = 0` cannot write) and on an unknown plane (the same
//! answer as the `b` form on the same data), degenerate normals, `--write-spec`.

use crate::util::{lincal, scratch, spec, values, write};
use serde_json::Value;

const TRUTH_ARM: &str = "d1: 0.31\nth1: 0.02\na2: 0.41\nth2: -0.03\na3: 0.345\nth3: 0.015\n";

fn s(p: &std::path::Path) -> String {
    p.to_str().unwrap().to_string()
}

fn simulate(dir: &std::path::Path, spec_file: &str, truth: &str, noise: &str) -> String {
    let t = write(dir, "truth.yaml", truth);
    let out = lincal(&[
        "simulate",
        &s(&spec(spec_file)),
        "--poses",
        "80",
        "--seed",
        "5",
        "--truth",
        &s(&t),
        "--noise-encoder",
        noise,
    ])
    .ok();
    s(&write(dir, "data.csv", &out.stdout))
}

fn calibrate(spec_file: &str, data: &str) -> Value {
    lincal(&[
        "calibrate",
        &s(&spec(spec_file)),
        data,
        "--refine",
        "--format",
        "json",
    ])
    .ok()
    .json()
}

#[test]
fn a_known_plane_through_the_origin_recovers_the_arm() {
    let dir = scratch("plane_normal_origin");
    let data = simulate(&dir, "plane_origin_spatial.yaml", TRUTH_ARM, "0");
    let r = calibrate("plane_origin_spatial.yaml", &data);
    let v = values(&r);
    assert!(r["residual_rms"].as_f64().unwrap() < 1e-12, "{r}");
    // The angles are identifiable on their own; the lengths up to the common scale a plane
    // through the origin cannot see (their ratios are).
    for (name, truth) in [("th1", 0.02), ("th2", -0.03), ("th3", 0.015)] {
        assert!((v[name] - truth).abs() < 1e-9, "{name}: {}", v[name]);
    }
    assert!((v["d1"] / v["a2"] - 0.31 / 0.41).abs() < 1e-9);
    assert!((v["a3"] / v["a2"] - 0.345 / 0.41).abs() < 1e-9);
    // The known plane is reported unit-normalised: n/‖n‖ and d/‖n‖ = 0.
    let plane = &r["planes"][0];
    let norm = (1.0f64 + 0.04 + 0.01).sqrt();
    for (k, n) in [1.0, 0.2, 0.1].iter().enumerate() {
        assert!((plane["normal"][k].as_f64().unwrap() - n / norm).abs() < 1e-12);
    }
    assert_eq!(plane["offset"].as_f64(), Some(0.0));
    assert!((plane["scale"].as_f64().unwrap() - norm).abs() < 1e-12);
}

#[test]
fn an_unknown_plane_by_normal_matches_the_b_form_on_the_same_data() {
    let dir = scratch("plane_normal_unknown");
    let truth = format!("{TRUTH_ARM}b1: -1.45\nb2: -0.85\nb3: 0.62\n");
    let data = simulate(&dir, "plane_spatial.yaml", &truth, "1e-5");
    let rb = calibrate("plane_spatial.yaml", &data);
    let rn = calibrate("plane_normal_spatial.yaml", &data);
    let (vb, vn) = (values(&rb), values(&rn));
    let (eb, en) = (
        rb["residual_rms"].as_f64().unwrap(),
        rn["residual_rms"].as_f64().unwrap(),
    );
    assert!(
        eb < 1e-4 && (eb - en).abs() < 1e-9 * eb.max(1e-12),
        "{eb} {en}"
    );
    // The same arm (the same gauge holds on the arm) ...
    for name in ["d1", "th1", "a2", "th2", "a3", "th3"] {
        assert!(
            (vb[name] - vn[name]).abs() < 1e-8,
            "{name}: {} {}",
            vb[name],
            vn[name]
        );
    }
    // ... near the truth where the data determine it ...
    assert!((vn["th2"] + 0.03).abs() < 1e-3 && (vn["th3"] - 0.015).abs() < 1e-3);
    // ... on the same plane: b·x + 1 = 0 is n̂ = −b/‖b‖, d̂ = 1/‖b‖.
    let b = [vb["b1"], vb["b2"], vb["b3"]];
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    let plane = &rn["planes"][0];
    for (k, bk) in b.iter().enumerate() {
        assert!((plane["normal"][k].as_f64().unwrap() + bk / nb).abs() < 1e-8);
    }
    assert!((plane["offset"].as_f64().unwrap() - 1.0 / nb).abs() < 1e-8);
    // The normal's largest nominal entry holds its scale; the others are fitted.
    assert_eq!(rn["params"]["n1"]["held"], Value::Bool(true), "{rn}");
    assert_eq!(rn["params"]["n2"]["held"], Value::Bool(false));
    assert_eq!(rn["params"]["d"]["held"], Value::Bool(false));
    // The b form's JSON has no `planes`.
    assert!(rb.get("planes").is_none());
}

#[test]
fn an_unknown_normal_has_one_more_gauge_direction_than_b() {
    let basis = |f: &str| {
        lincal(&["basis", &s(&spec(f)), "--format", "json"])
            .ok()
            .json()
    };
    let (b, n) = (
        basis("plane_spatial.yaml"),
        basis("plane_normal_spatial.yaml"),
    );
    assert_eq!(b["identifiable_count"], n["identifiable_count"]);
    assert_eq!(b["basis_size"], n["basis_size"]);
    let gauges = |v: &Value| v["gauge"].as_array().unwrap().len();
    assert_eq!(gauges(&n), gauges(&b) + 1, "{n}");
    // The scale (n, d) → (λn, λd) is among them: it moves the normal and the offset.
    assert!(n["gauge"]
        .as_array()
        .unwrap()
        .iter()
        .any(|g| g.get("n1").is_some() && g.get("d").is_some()));
}

#[test]
fn degenerate_planes_name_the_field() {
    let dir = scratch("plane_normal_degenerate");
    let origin = std::fs::read_to_string(spec("plane_origin_spatial.yaml")).unwrap();
    let cases = [
        (
            "normal: [1, 0.2, 0.1]",
            "normal: [0, 0, 0]",
            "constraint.plane.normal",
            "known and zero",
        ),
        (
            "normal: [1, 0.2, 0.1]",
            "normal: [0, 0, n3]",
            "constraint.plane.normal",
            "known and zero",
        ),
        (
            "plane: {normal: [1, 0.2, 0.1], offset: 0}",
            "plane: {b: [1, 2, 3], normal: [1, 0, 0], offset: 0}",
            "constraint.plane.normal",
            "not both",
        ),
        (
            ", offset: 0",
            "",
            "constraint.plane.offset",
            "missing field `offset`",
        ),
    ];
    for (i, (from, to, field, why)) in cases.iter().enumerate() {
        let mut text = origin.replace(from, to);
        if to.contains("n3") {
            text = text.replace("params:\n", "params:\n  n3: {nominal: 0, known: true}\n");
        }
        let f = write(&dir, &format!("bad{i}.yaml"), &text);
        // The constraint's line: 17, one more with the added parameter.
        let line = format!("bad{i}.yaml:{}:", 17 + usize::from(to.contains("n3")));
        lincal(&["basis", &s(&f)]).fails(2, &[&line, field, why]);
    }
    // An unknown normal needs a nonzero nominal (its largest entry holds the scale).
    let text = origin
        .replace("normal: [1, 0.2, 0.1]", "normal: [n1, n2, n3]")
        .replace(
            "params:\n",
            "params:\n  n1: {nominal: 0}\n  n2: {nominal: 0}\n  n3: {nominal: 0}\n",
        );
    let f = write(&dir, "zero_nominal.yaml", &text);
    lincal(&["basis", &s(&f)]).fails(2, &["constraint.plane.normal", "nonzero nominal"]);
}

#[test]
fn write_spec_round_trips_the_normal_form() {
    let dir = scratch("plane_normal_write_spec");
    let truth = format!("{TRUTH_ARM}b1: -1.45\nb2: -0.85\nb3: 0.62\n");
    let data = simulate(&dir, "plane_spatial.yaml", &truth, "0");
    let out = dir.join("out.yaml");
    lincal(&[
        "calibrate",
        &s(&spec("plane_normal_spatial.yaml")),
        &data,
        "--refine",
        "--write-spec",
        &s(&out),
    ])
    .ok();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("plane: {normal: [n1, n2, n3], offset: d}"),
        "{text}"
    );
    let first = values(&calibrate("plane_normal_spatial.yaml", &data));
    let again = lincal(&["calibrate", &s(&out), &data, "--refine", "--format", "json"])
        .ok()
        .json();
    let second = values(&again);
    for (name, v) in &first {
        assert!(
            (second[name] - v).abs() < 1e-9,
            "{name}: {v} then {}",
            second[name]
        );
    }
    assert!(again["residual_rms"].as_f64().unwrap() < 1e-12);
}

#[test]
fn relations_between_planes_by_normal() {
    let dir = scratch("plane_normal_relations");
    let spec_text = |relation: &str| {
        format!(
            "name: two_planes\ndim: 3\njoints:\n  - {{type: revolute, a: 0, alpha: pi/2, d: 0.3, \
             home: th1}}\n  - {{type: revolute, a: 0.4, home: th2}}\n  - {{type: revolute, a: \
             0.35, home: th3}}\nparams:\n  th1: {{nominal: 0}}\n  th2: {{nominal: 0}}\n  th3: \
             {{nominal: 0}}\n  n1: {{nominal: 0.1}}\n  n2: {{nominal: 1}}\n  d: {{nominal: 0}}\n  \
             e: {{nominal: 0.2}}\n  b1: {{nominal: 0.1}}\n  b2: {{nominal: -2}}\n  b3: {{nominal: \
             0.1}}\nconstraints:\n  - plane: {{normal: [n1, n2, 0], offset: d}}\n  - plane: \
             {{normal: [0, 1, 0], offset: e}}\n  - plane: {{b: [b1, b2, b3]}}\n\
             relations:\n  - {relation}\n"
        )
    };
    let ok = write(&dir, "same.yaml", &spec_text("{same_normal: [0, 2]}"));
    lincal(&["basis", &s(&ok)]).ok();
    // An offset between planes by normal, and between one by normal and one `b·x + 1 = 0`.
    for relation in [
        "{offset: [0, 1], value: 0.1}",
        "{offset: [2, 1], value: 0.1}",
    ] {
        let spec = write(&dir, "offset.yaml", &spec_text(relation));
        lincal(&["basis", &s(&spec)]).ok();
    }
}

/// Two parallel planes by normal, 12 cm apart, their shared normal and both offsets unknown:
/// on planes alone nothing fixes the arm's scale; the offset relation does, so the link
/// lengths are recovered from exact data, and the calibrated planes are 12 cm apart.
#[test]
fn an_offset_between_planes_by_normal_fixes_the_scale() {
    let dir = scratch("plane_normal_offset");
    let spec = write(
        &dir,
        "two.yaml",
        "name: two_planes_by_normal\ndim: 3\njoints:\n  - {type: revolute, a: 0, alpha: pi/2, \
         d: 0.3, home: th1}\n  - {type: revolute, a: a2, home: th2}\n  - {type: revolute, a: a3, \
         home: th3}\nparams:\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  th3: {nominal: 0}\n  \
         a2: {nominal: 0.4}\n  a3: {nominal: 0.35}\n  n1: {nominal: 0.05}\n  n2: {nominal: \
         0.02}\n  n3: {nominal: 1}\n  o1: {nominal: 0.1}\n  o2: {nominal: 0.22}\nconstraints:\n  \
         - plane: {normal: [n1, n2, n3], offset: o1}\n  - plane: {normal: [n1, n2, n3], offset: \
         o2}\nrelations:\n  - {offset: [0, 1], value: 0.12}\n",
    );
    let basis = lincal(&["basis", &s(&spec), "--format", "json"])
        .ok()
        .json();
    for name in ["a2", "a3", "th2", "th3"] {
        assert!(
            basis["identifiable"]
                .as_array()
                .expect("identifiable")
                .iter()
                .any(|v| v == name),
            "{name}: {basis}"
        );
    }
    let truth = dir.join("truth.yaml");
    let truth_arg = truth.display().to_string();
    let data = lincal(&[
        "simulate",
        &s(&spec),
        "--poses",
        "60",
        "--seed",
        "2",
        "--truth-out",
        &truth_arg,
    ])
    .ok()
    .stdout;
    let data = write(&dir, "data.csv", &data);
    let r = lincal(&["calibrate", &s(&spec), &s(&data), "--format", "json"])
        .ok()
        .json();
    for (name, t) in crate::util::truth_values(&truth) {
        if ["a2", "a3", "th2", "th3"].contains(&name.as_str()) {
            let v = r["params"][&name]["value"].as_f64().expect("a value");
            assert!((v - t).abs() < 1e-9, "{name}: {v} vs truth {t}");
        }
    }
    let planes = r["planes"].as_array().expect("planes");
    let offset = |k: usize| planes[k]["offset"].as_f64().expect("an offset");
    assert!(
        ((offset(1) - offset(0)).abs() - 0.12).abs() < 1e-9,
        "{planes:?}"
    );
    assert!(r["residual_rms"].as_f64().expect("residual_rms") < 1e-12);
}
