//! `simulate` → `calibrate` round trips through the binary, for every constraint kind of the
//! interface (point, 2-D line, 3-D line, plane, circle, sphere, quadric, measured, a list of
//! constraints) and a prismatic joint.
//!
//! Recovery is checked two ways:
//! - gauge-invariantly and for any spec: the calibrated generalized parameters `c(p̂)` must
//!   equal the true `c(p*)` modulo the mixing the data cannot see (for one equation its
//!   scale, for several equations of one constraint an invertible mix, none for measured
//!   tips). The identifiable combinations are exactly the functions of `c` modulo mixing, so
//!   this is "every identifiable combination is recovered";
//! - by explicit combinations where they are known in closed form (the paper's ratios and
//!   angles), and every parameter identifiable on its own against its true value.

use std::collections::HashMap;
use std::path::Path;

use lincal::symbolic::SymbolicModel;
use lincal::{CalibModel, ConstraintKind};
use serde_json::Value;

use crate::util::{failed_checks, lincal, scratch, spec, values, write, Check};

/// One round trip.
struct Trip<'a> {
    /// Spec file in tests/specs.
    spec: &'a str,
    poses: usize,
    seed: u64,
    /// Extra `simulate` arguments (noise).
    noise: &'a [&'a str],
    refine: bool,
    /// Gauge-invariant expressions `(expr, is_angle)` checked against their true values.
    checks: &'a [(&'a str, bool)],
}

struct Outcome {
    result: Value,
    truth: HashMap<String, f64>,
    model: SymbolicModel,
    p_hat: Vec<f64>,
    p_true: Vec<f64>,
}

fn run(t: &Trip<'_>, tag: &str) -> Outcome {
    let dir = scratch(&format!(
        "{}-{tag}-seed{}-refine{}",
        t.spec.trim_end_matches(".yaml"),
        t.seed,
        t.refine
    ));
    let spec_path = spec(t.spec);
    let truth_path = dir.join("truth.yaml");
    let mut args: Vec<String> = vec![
        "simulate".into(),
        spec_path.display().to_string(),
        "--poses".into(),
        t.poses.to_string(),
        "--seed".into(),
        t.seed.to_string(),
        "--truth-out".into(),
        truth_path.display().to_string(),
    ];
    args.extend(t.noise.iter().map(|s| (*s).to_string()));
    let sim = lincal(&args).ok();
    let data = write(&dir, "data.csv", &sim.stdout);
    let mut cal: Vec<String> = vec![
        "calibrate".into(),
        spec_path.display().to_string(),
        data.display().to_string(),
        "--format".into(),
        "json".into(),
    ];
    if t.refine {
        cal.push("--refine".into());
    }
    let result = lincal(&cal).ok().json();

    let spec = lincal::spec::from_yaml_file(&spec_path).expect("test spec loads");
    let model = SymbolicModel::from_spec(&spec).expect("test spec expands");
    let p_true = lincal::simulate::truth_from_yaml_file(&truth_path, &model, &spec)
        .expect("truth written by simulate reads back");
    let est = values(&result);
    let p_hat: Vec<f64> = (0..model.param_count())
        .map(|j| est[model.param_name(j)])
        .collect();
    let mut truth: HashMap<String, f64> = spec
        .params
        .iter()
        .map(|p| (p.name.clone(), p.nominal.to_f64()))
        .collect();
    for (j, v) in p_true.iter().enumerate() {
        truth.insert(model.param_name(j).to_string(), *v);
    }

    // The contract's fields.
    assert_eq!(result["poses"].as_u64(), Some(t.poses as u64));
    assert_eq!(
        result["basis_size"].as_u64(),
        Some(model.basis_size() as u64)
    );
    assert_eq!(
        result["identifiable_count"].as_u64(),
        Some(model.identifiable_count() as u64)
    );
    assert!(result["rank"].is_u64() && result["warnings"].is_array());
    let method = if t.refine { "linear+refine" } else { "linear" };
    assert_eq!(
        result["method"], method,
        "{}: {}",
        t.spec, result["warnings"]
    );
    assert_eq!(
        result["params"].as_object().map(|m| m.len()),
        Some(spec.params.len()),
        "{}: every parameter is reported",
        t.spec
    );
    Outcome {
        result,
        truth,
        model,
        p_hat,
        p_true,
    }
}

/// Solves the small dense system `a·x = b` (`n × n`, row-major) by Gaussian elimination with
/// partial pivoting; `None` when singular.
fn solve_small(mut a: Vec<f64>, mut b: Vec<f64>, n: usize, nrhs: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[piv * n + col].abs() < 1e-300 {
            return None;
        }
        for k in 0..n {
            a.swap(col * n + k, piv * n + k);
        }
        for k in 0..nrhs {
            b.swap(col * nrhs + k, piv * nrhs + k);
        }
        for i in 0..n {
            if i != col {
                let f = a[i * n + col] / a[col * n + col];
                for k in 0..n {
                    a[i * n + k] -= f * a[col * n + k];
                }
                for k in 0..nrhs {
                    b[i * nrhs + k] -= f * b[col * nrhs + k];
                }
            }
        }
    }
    for i in 0..n {
        for k in 0..nrhs {
            b[i * nrhs + k] /= a[i * n + i];
        }
    }
    Some(b)
}

/// The relative distance between `c(p̂)` and `c(p*)` modulo the mixing of each constraint's
/// equations (the largest over constraints): `min_G ‖G·Ĉ_j − C*_j‖ / ‖C*_j‖`, `G` any
/// invertible `m_j × m_j` matrix (identity for measured tips).
fn c_distance(model: &SymbolicModel, p_hat: &[f64], p_true: &[f64]) -> f64 {
    let k = model.basis_size();
    let e_count = model.equation_count();
    let mut c_hat = vec![0.0; e_count * k];
    let mut c_true = vec![0.0; e_count * k];
    model.generalized_params(p_hat, &mut c_hat);
    model.generalized_params(p_true, &mut c_true);
    let mut worst = 0.0f64;
    for j in 0..model.constraint_count() {
        let eqs: Vec<usize> = (0..e_count)
            .filter(|&e| model.equation_constraint(e) == j)
            .collect();
        let m = eqs.len();
        let row = |c: &[f64], a: usize| c[eqs[a] * k..(eqs[a] + 1) * k].to_vec();
        let hat: Vec<Vec<f64>> = (0..m).map(|a| row(&c_hat, a)).collect();
        let tru: Vec<Vec<f64>> = (0..m).map(|a| row(&c_true, a)).collect();
        let mixed: Vec<Vec<f64>> = if model.constraint_kind(j) == ConstraintKind::Measured {
            hat.clone()
        } else {
            // G = C* Ĉᵀ (Ĉ Ĉᵀ)⁻¹, i.e. Gᵀ solves (Ĉ Ĉᵀ) Gᵀ = Ĉ C*ᵀ.
            let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
            let gram: Vec<f64> = (0..m)
                .flat_map(|a| (0..m).map(|b| dot(&hat[a], &hat[b])).collect::<Vec<_>>())
                .collect();
            let rhs: Vec<f64> = (0..m)
                .flat_map(|a| (0..m).map(|b| dot(&hat[a], &tru[b])).collect::<Vec<_>>())
                .collect();
            let Some(gt) = solve_small(gram, rhs, m, m) else {
                return f64::INFINITY;
            };
            (0..m)
                .map(|b| {
                    (0..k)
                        .map(|col| (0..m).map(|a| gt[a * m + b] * hat[a][col]).sum())
                        .collect()
                })
                .collect()
        };
        let mut num = 0.0;
        let mut den = 0.0;
        for a in 0..m {
            for col in 0..k {
                num += (mixed[a][col] - tru[a][col]).powi(2);
                den += tru[a][col].powi(2);
            }
        }
        worst = worst.max((num / den).sqrt());
    }
    worst
}

/// Noise-free data: every identifiable combination exact (to 1e-9).
fn exact(t: &Trip<'_>) {
    let o = run(t, "exact");
    let d = c_distance(&o.model, &o.p_hat, &o.p_true);
    assert!(
        d < 1e-9,
        "{}: c(p̂) differs from c(p*) modulo mixing by {d:e}\nresult: {}",
        t.spec,
        o.result
    );
    let checks: Vec<Check<'_>> = t
        .checks
        .iter()
        .map(|&(expr, rad)| Check {
            expr,
            truth: crate::util::eval(expr, &o.truth).expect("check evaluates on the truth"),
            tol: 1e-9,
            rad,
        })
        .collect();
    let mut bad = failed_checks(&checks, &values(&o.result));
    for j in 0..o.model.param_count() {
        if o.model.param_identifiable(j) {
            let name = o.model.param_name(j);
            let mut diff = o.p_hat[j] - o.p_true[j];
            if o.model.param_is_angle(j) {
                diff = crate::util::wrap(diff);
            }
            if diff.abs() > 1e-9 {
                bad.push(format!("{name}: |p̂ − p*| = {:e}", diff.abs()));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{}:\n{}\nresult: {}",
        t.spec,
        bad.join("\n"),
        o.result
    );
    let rms = o.result["residual_rms"].as_f64().expect("residual_rms");
    assert!(
        rms < 1e-9,
        "{}: residual_rms {rms} on noise-free data",
        t.spec
    );
}

/// Noisy data: every parameter identifiable on its own within 3σ of its reported std, and
/// `c` close (`c_tol`).
fn noisy(t: &Trip<'_>, c_tol: f64) {
    let o = run(t, if t.refine { "noisy-refine" } else { "noisy" });
    let d = c_distance(&o.model, &o.p_hat, &o.p_true);
    assert!(
        d < c_tol,
        "{}: c distance {d:e} > {c_tol:e}\n{}",
        t.spec,
        o.result
    );
    let mut bad = Vec::new();
    let mut checked = 0;
    for j in 0..o.model.param_count() {
        if !o.model.param_identifiable(j) {
            continue;
        }
        let name = o.model.param_name(j);
        let std = o.result["params"][name]["std"]
            .as_f64()
            .unwrap_or_else(|| panic!("{}: identifiable `{name}` has no std", t.spec));
        assert!(std > 0.0 && std.is_finite());
        let mut diff = o.p_hat[j] - o.p_true[j];
        if o.model.param_is_angle(j) {
            diff = crate::util::wrap(diff);
        }
        checked += 1;
        if diff.abs() > 3.0 * std {
            bad.push(format!(
                "{name}: |p̂ − p*| = {:e} > 3σ = {:e}",
                diff.abs(),
                3.0 * std
            ));
        }
    }
    assert!(
        checked > 0,
        "{}: nothing identifiable on its own to check",
        t.spec
    );
    assert!(
        bad.is_empty(),
        "{}:\n{}\n{}",
        t.spec,
        bad.join("\n"),
        o.result
    );
}

const POINT: Trip<'static> = Trip {
    spec: "point_planar3.yaml",
    poses: 40,
    seed: 11,
    noise: &[],
    refine: false,
    checks: &[
        ("a2/a1", false),
        ("a3/a1", false),
        ("th2", true),
        ("th3", true),
        ("atan2(py, px) + th1", true),
        ("hypot(px, py)/a1", false),
    ],
};

const LINE2: Trip<'static> = Trip {
    spec: "line_planar4.yaml",
    poses: 40,
    seed: 12,
    noise: &[],
    refine: false,
    checks: &[
        ("a2/a1", false),
        ("a3/a1", false),
        ("a4/a1", false),
        ("th2", true),
        ("th3", true),
        ("th4", true),
        ("atan2(b2, b1) + th1", true),
        ("a1*hypot(b1, b2)", false),
    ],
};

#[test]
fn point_planar3() {
    exact(&POINT);
}

#[test]
fn line_2d_planar4() {
    exact(&LINE2);
}

#[test]
fn line_3d_spatial() {
    exact(&Trip {
        spec: "line3_spatial.yaml",
        poses: 60,
        seed: 13,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn plane_spatial() {
    exact(&Trip {
        spec: "plane_spatial.yaml",
        poses: 50,
        seed: 14,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn circle_planar3() {
    exact(&Trip {
        spec: "circle_planar3.yaml",
        poses: 50,
        seed: 15,
        noise: &[],
        refine: false,
        checks: &[
            ("a2/a1", false),
            ("a3/a1", false),
            ("th2", true),
            ("th3", true),
            ("atan2(cy, cx) + th1", true),
            ("hypot(cx, cy)/a1", false),
            ("r/a1", false),
        ],
    });
}

#[test]
fn sphere_mdh_tool() {
    exact(&Trip {
        spec: "sphere_mdh.yaml",
        poses: 60,
        seed: 16,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn quadric_planar2() {
    exact(&Trip {
        spec: "quadric_planar2.yaml",
        poses: 50,
        seed: 17,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn measured_spatial_base() {
    exact(&Trip {
        spec: "measured_spatial.yaml",
        poses: 40,
        seed: 18,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn list_of_lines() {
    exact(&Trip {
        spec: "lines_list.yaml",
        poses: 40,
        seed: 19,
        noise: &[],
        refine: false,
        checks: &[
            ("a2/a1", false),
            ("th2", true),
            ("atan2(b2, b1) + th1", true),
            ("a1*hypot(b1, b2)", false),
            ("atan2(e2, e1) + th1", true),
            ("a1*hypot(e1, e2)", false),
        ],
    });
}

/// URDF-native rows (`convention: urdf`), a prismatic joint among them, on a sphere: the
/// linear method from exact data, no initial guess.
#[test]
fn urdf_native_rows_on_a_sphere() {
    exact(&Trip {
        spec: "urdf_native_sphere.yaml",
        poses: 80,
        seed: 21,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn prismatic_scara_plane() {
    exact(&Trip {
        spec: "prismatic_scara.yaml",
        poses: 40,
        seed: 20,
        noise: &[],
        refine: false,
        checks: &[],
    });
}

#[test]
fn refine_keeps_exact_data_exact() {
    exact(&Trip {
        refine: true,
        ..POINT
    });
    exact(&Trip {
        spec: "sphere_mdh.yaml",
        poses: 60,
        seed: 21,
        noise: &[],
        refine: true,
        checks: &[],
    });
}

#[test]
fn noisy_line_within_three_sigma() {
    for refine in [false, true] {
        noisy(
            &Trip {
                poses: 300,
                seed: 31,
                noise: &["--noise-track", "30e-6"],
                refine,
                ..LINE2
            },
            1e-3,
        );
    }
}

#[test]
fn noisy_measured_within_three_sigma() {
    for refine in [false, true] {
        noisy(
            &Trip {
                spec: "measured_spatial.yaml",
                poses: 200,
                seed: 32,
                noise: &["--noise-measure", "50e-6"],
                refine,
                checks: &[],
            },
            1e-3,
        );
    }
}

#[test]
fn noisy_sphere_within_three_sigma() {
    noisy(
        &Trip {
            spec: "sphere_mdh.yaml",
            poses: 300,
            seed: 33,
            noise: &["--noise-track", "20e-6"],
            refine: true,
            checks: &[],
        },
        1e-3,
    );
}

#[test]
fn simulate_is_deterministic_and_on_the_constraint() {
    let s = spec("line_planar4.yaml");
    let args = [
        "simulate",
        &s.display().to_string(),
        "--poses",
        "7",
        "--seed",
        "5",
    ]
    .map(str::to_string);
    let a = lincal(&args).ok();
    let b = lincal(&args).ok();
    assert_eq!(a.stdout, b.stdout);
    let mut lines = a.stdout.lines();
    assert_eq!(lines.next(), Some("q1,q2,q3,q4"));
    assert_eq!(lines.count(), 7);
    let other = lincal(&[
        "simulate",
        &s.display().to_string(),
        "--poses",
        "7",
        "--seed",
        "6",
    ])
    .ok();
    assert_ne!(a.stdout, other.stdout);
    // A truth file pins the parameters; the readings stay inside the limits.
    let dir = scratch("simulate-truth");
    let truth = write(&dir, "truth.yaml", "a1: 0.35\nth1: 0.01\na2: 0.3\nth2: -0.02\na3: 0.25\nth3: 0.03\na4: 0.15\nth4: 0.0\nb1: -1.6\nb2: 0.9\n");
    let r = lincal(&[
        "simulate",
        &s.display().to_string(),
        "--poses",
        "30",
        "--truth",
        &truth.display().to_string(),
    ])
    .ok();
    let spec = lincal::spec::from_yaml_file(&s).expect("spec");
    let model = SymbolicModel::from_spec(&spec).expect("model");
    let p = lincal::simulate::truth_from_yaml_file(&truth, &model, &spec).expect("truth");
    for line in r.stdout.lines().skip(1) {
        let q: Vec<f64> = line
            .split(',')
            .map(|c| c.parse().expect("number"))
            .collect();
        assert!(q.iter().all(|v| v.abs() <= 2.8), "{line}");
        let mut x = [0.0; 2];
        model.tip(&q, &p, &mut x);
        let h = -1.6 * x[0] + 0.9 * x[1] + 1.0;
        assert!(h.abs() < 1e-12, "h = {h}");
    }
}

#[test]
fn simulate_writes_measured_and_constraint_columns() {
    let s = spec("measured_spatial.yaml");
    let r = lincal(&["simulate", &s.display().to_string(), "--poses", "3"]).ok();
    assert_eq!(r.stdout.lines().next(), Some("q1,q2,q3,x,y,z"));
    let s = spec("lines_list.yaml");
    let r = lincal(&["simulate", &s.display().to_string(), "--poses", "4"]).ok();
    let rows: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(rows[0], "q1,q2,constraint");
    let tags: Vec<&str> = rows[1..]
        .iter()
        .map(|l| l.rsplit(',').next().unwrap_or(""))
        .collect();
    assert_eq!(tags, ["0", "1", "0", "1"]);
    assert!(Path::new(&s).is_file());
}

/// Every shipped model's nominal constraint crosses its workspace within the joint limits:
/// `simulate` places poses on it (a model whose nominal plane lies beyond reach could not be
/// simulated, planned or started from its nominals).
#[test]
fn every_shipped_model_simulates() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs");
    let mut specs: Vec<_> = std::fs::read_dir(&dir)
        .expect("the model specs")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    specs.sort();
    assert!(specs.len() > 10, "{specs:?}");
    for spec in specs {
        let spec = spec.display().to_string();
        let run = crate::util::lincal(&["simulate", &spec, "--poses", "20", "--seed", "1"]);
        assert_eq!(run.code, 0, "{spec}: {}", run.stderr);
        assert_eq!(run.stdout.lines().count(), 21, "{spec}");
    }
}
