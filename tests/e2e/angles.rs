//! Data as it comes: a log whose columns are the URDF's joint names and whose revolute
//! readings are degrees (`--angles deg`), refused by default (`--angles auto`).

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::util::{lincal, scratch, write, FIXED_PRIOR};

/// The spec's joints as `(URDF name, prismatic, limits)`, from its `urdf:` record and its
/// joint rows (the text `lincal import` writes).
fn joints(spec: &str) -> Vec<(String, bool, Option<[f64; 2]>)> {
    let names_line = spec
        .lines()
        .find(|l| l.trim_start().starts_with("joints: ["))
        .expect("the urdf record lists the joints");
    let names: Vec<String> = names_line
        .split_once('[')
        .and_then(|(_, r)| r.strip_suffix(']'))
        .expect("a list")
        .split(',')
        .map(|s| s.trim().trim_matches('"').to_string())
        .collect();
    let rows: Vec<&str> = spec
        .lines()
        .filter(|l| l.starts_with("  - {type: "))
        .collect();
    assert_eq!(rows.len(), names.len(), "one URDF name per joint row");
    names
        .into_iter()
        .zip(rows)
        .map(|(n, r)| {
            let limits = r.split_once("limits: [").map(|(_, rest)| {
                let inside = rest.split_once(']').expect("a closed list").0;
                let v: Vec<f64> = inside
                    .split(',')
                    .map(|c| c.trim().parse().expect("a number"))
                    .collect();
                [v[0], v[1]]
            });
            (n, r.contains("type: prismatic"), limits)
        })
        .collect()
}

/// The simulated radian CSV rewritten as a real log: the joint columns headed by their URDF
/// names, the revolute readings in degrees (prismatic readings and tips as they are). Also
/// the line and column of the first reading `--angles auto` must refuse.
fn as_degree_log(
    csv: &str,
    joints: &[(String, bool, Option<[f64; 2]>)],
) -> (String, usize, String) {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let joint_of = |h: &str| -> Option<usize> {
        let i: usize = h.strip_prefix('q')?.parse().ok()?;
        Some(i - 1)
    };
    let named: Vec<String> = header
        .iter()
        .map(|h| joint_of(h).map_or(h.to_string(), |i| joints[i].0.clone()))
        .collect();
    let mut out = named.join(",") + "\n";
    let mut first: Option<(usize, String)> = None;
    for (k, l) in lines.enumerate() {
        let cells: Vec<String> = l
            .split(',')
            .zip(&header)
            .map(|(c, h)| match joint_of(h) {
                Some(i) if !joints[i].1 => {
                    let v: f64 = c.parse().expect("a reading");
                    let d = v.to_degrees();
                    let outside = joints[i].2.is_none_or(|[lo, hi]| d < lo || d > hi);
                    if first.is_none() && d.abs() > std::f64::consts::TAU + 1e-9 && outside {
                        first = Some((k + 2, joints[i].0.clone()));
                    }
                    format!("{d:?}")
                }
                _ => c.to_string(),
            })
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    let (line, column) = first.expect("some reading in degrees is beyond a full turn");
    (out, line, column)
}

fn path(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

fn ur5_rail() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/ur5_rail.urdf")
}

#[test]
fn a_degree_log_with_urdf_column_names_fits_as_its_radians() {
    let dir = scratch("angles_deg_log");
    let imported = lincal(&[
        "import",
        path(&ur5_rail()),
        "--base",
        "world",
        "--tip",
        "ee_link",
    ])
    .ok();
    let spec_text = imported.stdout;
    let js = joints(&spec_text);
    assert_eq!(js.len(), 7);
    assert_eq!(js[0].0, "rail_joint");
    assert!(
        js[0].1 && !js[1].1,
        "the rail is prismatic, the arm revolute"
    );
    let columns: Vec<String> = js
        .iter()
        .enumerate()
        .map(|(i, j)| format!("q{} (= {})", i + 1, j.0))
        .collect();
    assert!(
        spec_text.contains(&format!("# Data columns: {}", columns.join(", "))),
        "the imported spec says which column is which joint:\n{spec_text}"
    );
    let spec = write(&dir, "spec.yaml", &spec_text);
    let s = path(&spec);
    let truth = dir.join("truth.yaml");
    let sim = lincal(&[
        "simulate",
        s,
        "--poses",
        "120",
        "--seed",
        "3",
        "--noise-measure",
        "1e-4",
        "--truth-out",
        path(&truth),
    ])
    .ok();
    let rad = write(&dir, "rad.csv", &sim.stdout);
    let (log, line, column) = as_degree_log(&sim.stdout, &js);
    assert!(log.starts_with("rail_joint,shoulder_pan_joint,"), "{log}");
    let deg = write(&dir, "deg.csv", &log);

    let calibrate = |data: &Path, extra: &[&str]| {
        // A fixed prior: the truth is checked (`util::FIXED_PRIOR`).
        let mut args = vec!["calibrate", s, path(data), "--format", "json"];
        args.extend(FIXED_PRIOR);
        args.extend_from_slice(extra);
        lincal(&args)
    };
    let a = calibrate(&rad, &[]).ok().json();
    let b = calibrate(&deg, &["--angles", "deg"]).ok().json();
    same_fit(&a, &b);
    near_truth(
        &b,
        &std::fs::read_to_string(&truth).expect("the truth file"),
    );

    // Without the flag the degrees are refused where they first show.
    calibrate(&deg, &[]).fails(
        2,
        &[
            &format!("deg.csv:{line}"),
            &format!("`{column}`"),
            "these look like degrees: pass --angles deg to convert, or --angles rad to take them as radians",
        ],
    );
    // `predict` reads the log the same way.
    let p_rad = lincal(&["predict", s, "--nominal", path(&rad)]).ok().stdout;
    let p_deg = lincal(&["predict", s, "--nominal", path(&deg), "--angles", "deg"])
        .ok()
        .stdout;
    let (p_rad, p_deg) = (numbers(&p_rad), numbers(&p_deg));
    assert_eq!(p_rad.len(), p_deg.len());
    for (x, y) in p_rad.iter().zip(&p_deg) {
        assert!((x - y).abs() < 1e-12, "predicted tips {x} vs {y}");
    }
    lincal(&["predict", s, "--nominal", path(&deg)]).fails(2, &["these look like degrees"]);
}

/// The same parameters and statistics from the radian file and the degree log.
fn same_fit(a: &Value, b: &Value) {
    assert_eq!(a["poses"], b["poses"]);
    let close = |x: f64, y: f64, tol: f64| (x - y).abs() <= tol * (1e-12 + x.abs());
    let params = a["params"].as_object().expect("params");
    assert!(params.len() > 20);
    for (name, p) in params {
        let q = &b["params"][name];
        let (x, y) = (p["value"].as_f64().unwrap(), q["value"].as_f64().unwrap());
        // The degree log's readings are the radians to within rounding (about 1e-16): the
        // estimates agree to 1e-9, or to a millionth of their std where the data hardly
        // see them (d3's std is 0.34 m beside the UR5's parallel axes).
        let std = p["std"].as_f64().unwrap_or(0.0);
        let tol = (1e-9 * (1.0 + x.abs())).max(1e-6 * std);
        assert!((x - y).abs() <= tol, "{name}: {x} vs {y} (std {std})");
        assert_eq!(p["identifiable"], q["identifiable"], "{name}");
        if let (Some(x), Some(y)) = (p["std"].as_f64(), q["std"].as_f64()) {
            assert!(close(x, y, 1e-5), "{name} std: {x} vs {y}");
        } else {
            assert_eq!(p["std"], q["std"], "{name}");
        }
    }
    let (x, y) = (
        a["residual_rms"].as_f64().unwrap(),
        b["residual_rms"].as_f64().unwrap(),
    );
    assert!(close(x, y, 1e-6), "residual_rms {x} vs {y}");
}

/// Every parameter identifiable on its own within 6 standard deviations of the truth file's.
fn near_truth(fit: &Value, truth: &str) {
    let mut checked = 0;
    for l in truth.lines() {
        let Some((name, v)) = l.split_once(':') else {
            continue;
        };
        let Ok(t) = v.trim().parse::<f64>() else {
            continue;
        };
        let p = &fit["params"][name.trim()];
        if let (Some(true), Some(std)) = (p["identifiable"].as_bool(), p["std"].as_f64()) {
            let mut x = p["value"].as_f64().unwrap();
            // Angles (home offsets, twists, fixed angles, the base's rotation) modulo 2π.
            let angle = [
                "home",
                "alpha",
                "theta",
                "base_roll",
                "base_pitch",
                "base_yaw",
            ]
            .iter()
            .any(|a| name.trim().starts_with(a));
            if angle {
                x = t + (x - t + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
            }
            assert!(
                (x - t).abs() < 6.0 * std + 1e-12,
                "{name}: {x} vs truth {t} (std {std})"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 10,
        "only {checked} parameters checked against the truth"
    );
}

/// Every number of a CSV without its header.
fn numbers(csv: &str) -> Vec<f64> {
    csv.lines()
        .skip(1)
        .flat_map(|l| l.split(',').map(|c| c.parse::<f64>().expect("a number")))
        .collect()
}
