//! Every constraint kind of the interface through the symbolic engine's run-time model:
//! noise-free data recovers every free parameter exactly (the held ones, the gauge, are set
//! to the truth, so the free ones have true values), noisy data lands within 3σ.

use super::sim::{simulate, to_csv, SimOptions};
use lincal_core::calibrate::estimate::Estimate;
use lincal_core::calibrate::{calibrate_spec, CalibrateOptions, StartChoice};
use lincal_core::data::Poses;
use lincal_core::numeric::wrap_angle;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;

/// The options of a fit of simulated data whose truth is checked: a fixed prior of
/// `simulate`'s perturbation size (1 cm, 0.01 rad), which fades with the poses, where the
/// default prior is relative to the data and keeps its pull (docs/03-calibrating.md, *The prior*).
fn simulated() -> CalibrateOptions {
    CalibrateOptions {
        prior: lincal_core::calibrate::prior::PriorChoice::fixed(0.01, 0.01),
        ..Default::default()
    }
}

const PLANAR3: &str = "
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.8, 2.8]}
  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}
  - {type: revolute, a: a3, home: th3, limits: [-2.8, 2.8]}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0.02}
  a2: {nominal: 0.3}
  th2: {nominal: -0.03}
  a3: {nominal: 0.2}
  th3: {nominal: 0.05}
";

const PLANAR2: &str = "
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.8, 2.8]}
  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0.02}
  a2: {nominal: 0.3}
  th2: {nominal: -0.03}
";

/// A spatial 3R arm (shoulder twist, two parallel links) with a tool offset.
const SPATIAL3: &str = "
dim: 3
joints:
  - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1, limits: [-2.8, 2.8]}
  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}
  - {type: revolute, a: a3, home: th3, limits: [-2.8, 2.8]}
tool: [0.05, 0, 0]
params:
  a1: {nominal: 0.05}
  d1: {nominal: 0.3}
  th1: {nominal: 0.01}
  a2: {nominal: 0.35}
  th2: {nominal: -0.02}
  a3: {nominal: 0.25}
  th3: {nominal: 0.03}
";

/// A spatial 4R arm (the 3R plus a wrist joint): one degree of redundancy for a pinned tip.
const SPATIAL4: &str = "
dim: 3
joints:
  - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1, limits: [-2.8, 2.8]}
  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}
  - {type: revolute, a: a3, alpha: -pi/2, home: th3, limits: [-2.8, 2.8]}
  - {type: revolute, a: a4, d: d4, home: th4, limits: [-2.8, 2.8]}
tool: [0.05, 0, 0]
params:
  a1: {nominal: 0.05}
  d1: {nominal: 0.3}
  th1: {nominal: 0.01}
  a2: {nominal: 0.35}
  th2: {nominal: -0.02}
  a3: {nominal: 0.05}
  th3: {nominal: 0.03}
  a4: {nominal: 0.1}
  d4: {nominal: 0.25}
  th4: {nominal: -0.01}
";

/// A SCARA (RRP): two horizontal links and a vertical prismatic joint.
const SCARA: &str = "
dim: 3
joints:
  - {type: revolute, a: a1, d: d1, home: th1, limits: [-2.5, 2.5]}
  - {type: revolute, a: a2, alpha: pi, home: th2, limits: [-2.5, 2.5]}
  - {type: prismatic, offset: o3, limits: [0.0, 0.2]}
params:
  a1: {nominal: 0.35}
  d1: {nominal: 0.4}
  th1: {nominal: 0.01}
  a2: {nominal: 0.25}
  th2: {nominal: -0.02}
  o3: {nominal: 0.05}
";

fn spec(name: &str, robot: &str, tail: &str) -> String {
    format!("name: {name}\n{robot}{tail}")
}

struct Run {
    model: SymbolicModel,
    spec: lincal_core::spec::Spec,
    truth: Vec<f64>,
}

/// Builds the model and the truth: held parameters at the nominal, free ones perturbed by up
/// to 2% (at least 1 mm or 1 mrad scale).
fn setup(yaml: &str) -> Run {
    let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
    let model = SymbolicModel::from_spec(&spec).unwrap();
    let truth = (0..model.param_count())
        .map(|j| {
            let nom = model.param_nominal(j);
            if model.param_held(j) {
                nom
            } else {
                let s = ((j * 7919 % 13) as f64 / 12.0) * 2.0 - 1.0;
                nom + 0.02 * s * nom.abs().max(0.05)
            }
        })
        .collect();
    Run { model, spec, truth }
}

fn check_exact(run: &Run, est: &Estimate, tol: f64) {
    let m = &run.model;
    for j in 0..m.param_count() {
        let p = est
            .params
            .iter()
            .find(|p| p.name == m.param_name(j))
            .unwrap();
        let w = run.truth[j];
        let d = if m.param_is_angle(j) {
            wrap_angle(p.value - w)
        } else {
            p.value - w
        };
        assert!(
            d.abs() <= tol * w.abs().max(1.0),
            "{}: {} = {}, true {w}, diff {d:e}",
            m.name(),
            p.name,
            p.value
        );
        assert_eq!(p.held, m.param_held(j));
        assert_eq!(p.std.is_none(), p.held);
    }
}

fn check_3sigma(run: &Run, est: &Estimate) {
    let m = &run.model;
    for j in (0..m.param_count()).filter(|&j| !m.param_held(j)) {
        let p = est
            .params
            .iter()
            .find(|p| p.name == m.param_name(j))
            .unwrap();
        let w = run.truth[j];
        let s = p.std.unwrap();
        let d = if m.param_is_angle(j) {
            wrap_angle(p.value - w)
        } else {
            p.value - w
        };
        assert!(
            d.abs() <= 3.0 * s,
            "{}: {} = {}, true {w}, diff {d:e}, std {s:e}",
            m.name(),
            p.name,
            p.value
        );
    }
}

/// Noise-free (exact, linear and refined) then noisy (3σ), through a CSV round trip.
fn exercise(yaml: &str, poses: usize, noisy: SimOptions) {
    let run = setup(yaml);
    let m = &run.model;
    let clean = simulate(m, &run.truth, SimOptions::new(poses, noisy.seed + 1));
    let text = to_csv(m, &clean, run.spec.constraint_list);
    let loaded = Poses::from_csv_str(&text, Some("sim.csv"), m, run.spec.constraint_list).unwrap();
    assert_eq!(loaded.q, clean.q);
    assert_eq!(loaded.constraint, clean.constraint);
    for refine in [false, true] {
        let est = calibrate_spec(
            m,
            &run.spec,
            &loaded,
            CalibrateOptions {
                refine,
                ..simulated()
            },
        )
        .unwrap_or_else(|e| panic!("{}: {e}", m.name()));
        check_exact(&run, &est, 1e-9);
        assert!(
            est.residual_rms < 1e-9,
            "{}: residual {:e}",
            m.name(),
            est.residual_rms
        );
        assert_eq!(est.method, if refine { "linear+refine" } else { "linear" });
        assert_eq!(est.start, "linear");
        // A refinement that ends where it started (exact data) is no rejection.
        assert!(
            est.warnings.iter().all(|w| !w.contains("rejected")),
            "{:?}",
            est.warnings
        );
    }
    // The parameter-space path: fewer poses than K, from the nominals.
    let small = few_poses(m);
    if let Some(small) = small {
        let sub = clean.select(&(0..small).collect::<Vec<_>>());
        let est = calibrate_spec(m, &run.spec, &sub, simulated())
            .unwrap_or_else(|e| panic!("{} at N = {small} < K: {e}", m.name()));
        assert_eq!(est.start, "nominal", "{}: N = {small} < K", m.name());
        assert_eq!(est.method, "linear+refine");
        check_exact(&run, &est, 1e-9);
        assert!(
            est.residual_rms < 1e-9,
            "{}: {:e}",
            m.name(),
            est.residual_rms
        );
    }
    let data = simulate(
        m,
        &run.truth,
        SimOptions {
            poses: 4 * poses,
            ..noisy
        },
    );
    for refine in [false, true] {
        let est = calibrate_spec(
            m,
            &run.spec,
            &data,
            CalibrateOptions {
                refine,
                ..simulated()
            },
        )
        .unwrap_or_else(|e| panic!("{}: {e}", m.name()));
        check_3sigma(&run, &est);
        if let Some(small) = small {
            // Noisy, at N < K (twice the poses the free parameters need), from the nominals.
            let sub = data.select(&(0..(2 * small).min(data.len())).collect::<Vec<_>>());
            let est = calibrate_spec(
                m,
                &run.spec,
                &sub,
                CalibrateOptions {
                    refine,
                    start: StartChoice::Nominal,
                    ..simulated()
                },
            );
            match est {
                Ok(est) => {
                    assert_eq!(est.start, "nominal");
                    check_3sigma(&run, &est);
                }
                // An unknown quadric fits any circle, so a collapsed arm (a zero link) fits
                // noisy data better than the truth: refused, not reported.
                Err(e) => assert!(
                    m.constraint_kind(0) == lincal_core::ConstraintKind::Quadric
                        && e.to_string().contains("collapses the arm"),
                    "{}: {e}",
                    m.name()
                ),
            }
        }
        let held: Vec<&str> = (0..m.param_count())
            .filter(|&j| m.param_held(j))
            .map(|j| m.param_name(j))
            .collect();
        let worst = (0..m.param_count())
            .filter(|&j| !m.param_held(j))
            .map(|j| {
                let p = &est
                    .params
                    .iter()
                    .find(|p| p.name == m.param_name(j))
                    .unwrap();
                (p.value - run.truth[j]).abs() / p.std.unwrap()
            })
            .fold(0.0, f64::max);
        eprintln!(
            "{} (refine {refine}): K {}, E {}, identifiable {}, held {held:?}, rank {}, residual {:.2e}, worst |d|/std {worst:.2}, warnings {:?}",
            m.name(),
            m.basis_size(),
            m.equation_count(),
            m.identifiable_count(),
            est.rank,
            est.residual_rms,
            est.warnings
        );
    }
}

/// A number of poses below `K` that still gives more residual components than free
/// parameters (with a margin), when there is one.
fn few_poses(m: &SymbolicModel) -> Option<usize> {
    let dim = m.dim();
    let per_pose = (0..m.constraint_count())
        .map(|j| m.constraint_kind(j).residual_count(dim))
        .min()
        .unwrap_or(1);
    let free = (0..m.param_count()).filter(|&j| !m.param_held(j)).count();
    // Every constraint of a list needs its own poses: the poses come round-robin.
    let need = (free + 4).div_ceil(per_pose).max(2 * m.constraint_count());
    (need < m.basis_size()).then_some(need)
}

fn tracked(seed: u64) -> SimOptions {
    SimOptions {
        track: 20e-6,
        ..SimOptions::new(0, seed)
    }
}

#[test]
fn planar_point() {
    let y = spec(
        "planar3_point",
        PLANAR3,
        "  px: {nominal: 0.35}\n  py: {nominal: 0.25}\nconstraint:\n  point: {p: [px, py]}\n",
    );
    exercise(&y, 40, tracked(100));
}

#[test]
fn planar_circle() {
    let y = spec(
        "planar2_circle",
        PLANAR2,
        "  cx: {nominal: 0.3}\n  cy: {nominal: 0.2}\n  r: {nominal: 0.15}\nconstraint:\n  circle: {center: [cx, cy], radius: r}\n",
    );
    exercise(&y, 60, tracked(200));
}

#[test]
fn planar_quadric() {
    // An ellipse about (0.3, 0.2), semi-axes 0.15 and 0.1, normalised to b·x + ... + 1.
    let y = spec(
        "planar2_ellipse",
        PLANAR2,
        "  q11: {nominal: 6.349206349}\n  q22: {nominal: 14.285714286}\n  q12: {nominal: 0.5}\n  u1: {nominal: -3.809523810}\n  u2: {nominal: -5.714285714}\nconstraint:\n  quadric: {A: [[q11, q12], [q12, q22]], b: [u1, u2]}\n",
    );
    exercise(&y, 80, tracked(300));
}

#[test]
fn planar_list_of_lines() {
    let y = spec(
        "planar2_two_lines",
        PLANAR2,
        "  b1: {nominal: -1.8}\n  b2: {nominal: 1.0}\n  c1: {nominal: 1.5}\n  c2: {nominal: 2.2}\nconstraints:\n  - line: {b: [b1, b2]}\n  - line: {b: [c1, c2]}\n",
    );
    exercise(&y, 40, tracked(400));
}

#[test]
fn spatial_plane_and_sphere() {
    let plane = spec(
        "spatial3_plane",
        SPATIAL3,
        "  b1: {nominal: -1.5}\n  b2: {nominal: -0.8}\n  b3: {nominal: -2.0}\nconstraint:\n  plane: {b: [b1, b2, b3]}\n",
    );
    exercise(&plane, 60, tracked(500));
    let sphere = spec(
        "spatial3_sphere",
        SPATIAL3,
        "  cx: {nominal: 0.35}\n  cy: {nominal: 0.1}\n  cz: {nominal: 0.35}\n  r: {nominal: 0.12}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n",
    );
    exercise(&sphere, 80, tracked(600));
}

#[test]
fn spatial_line_and_point() {
    let line = spec(
        "spatial3_line",
        SPATIAL3,
        "  u1: {nominal: -2.0}\n  u2: {nominal: 0.3}\n  u3: {nominal: -0.4}\n  v1: {nominal: 0.2}\n  v2: {nominal: -1.0}\n  v3: {nominal: -1.6}\nconstraint:\n  line: {planes: [[u1, u2, u3], [v1, v2, v3]]}\n",
    );
    exercise(&line, 60, tracked(700));
    let point = spec(
        "spatial4_point",
        SPATIAL4,
        "  px: {nominal: 0.3}\n  py: {nominal: 0.2}\n  pz: {nominal: 0.4}\nconstraint:\n  point: {p: [px, py, pz]}\n",
    );
    exercise(&point, 60, tracked(800));
}

#[test]
fn measured_tips_and_a_prismatic_joint() {
    let noisy = SimOptions {
        measure: 50e-6,
        ..SimOptions::new(0, 900)
    };
    let y = spec(
        "spatial3_measured",
        SPATIAL3,
        "constraint:\n  measured: {}\n",
    );
    exercise(&y, 40, noisy);
    let y = spec("scara_measured", SCARA, "constraint:\n  measured: {}\n");
    exercise(&y, 40, noisy);
    let y = spec(
        "scara_sphere",
        SCARA,
        "  cx: {nominal: 0.3}\n  cy: {nominal: 0.2}\n  cz: {nominal: 0.3}\n  r: {nominal: 0.1}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n",
    );
    exercise(&y, 60, tracked(1000));
}

/// Robustness survey (slow, run by hand): truths far from the nominals.
#[test]
#[ignore = "survey, run by hand with --nocapture"]
fn survey_far_truths() {
    use rand::{Rng, SeedableRng};
    let specs = [
        spec("planar3_point", PLANAR3, "  px: {nominal: 0.35}\n  py: {nominal: 0.25}\nconstraint:\n  point: {p: [px, py]}\n"),
        spec("planar3_line", PLANAR3, "  b1: {nominal: -1.8}\n  b2: {nominal: 1.0}\nconstraint:\n  line: {b: [b1, b2]}\n"),
        spec("planar2_circle", PLANAR2, "  cx: {nominal: 0.3}\n  cy: {nominal: 0.2}\n  r: {nominal: 0.15}\nconstraint:\n  circle: {center: [cx, cy], radius: r}\n"),
        spec("spatial3_plane", SPATIAL3, "  b1: {nominal: -1.5}\n  b2: {nominal: -0.8}\n  b3: {nominal: -2.0}\nconstraint:\n  plane: {b: [b1, b2, b3]}\n"),
        spec("spatial3_sphere", SPATIAL3, "  cx: {nominal: 0.35}\n  cy: {nominal: 0.1}\n  cz: {nominal: 0.35}\n  r: {nominal: 0.12}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n"),
        spec("spatial3_line", SPATIAL3, "  u1: {nominal: -2.0}\n  u2: {nominal: 0.3}\n  u3: {nominal: -0.4}\n  v1: {nominal: 0.2}\n  v2: {nominal: -1.0}\n  v3: {nominal: -1.6}\nconstraint:\n  line: {planes: [[u1, u2, u3], [v1, v2, v3]]}\n"),
        spec("spatial4_point", SPATIAL4, "  px: {nominal: 0.3}\n  py: {nominal: 0.2}\n  pz: {nominal: 0.4}\nconstraint:\n  point: {p: [px, py, pz]}\n"),
        spec("spatial3_measured", SPATIAL3, "constraint:\n  measured: {}\n"),
        spec("scara_sphere", SCARA, "  cx: {nominal: 0.3}\n  cy: {nominal: 0.2}\n  cz: {nominal: 0.3}\n  r: {nominal: 0.1}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n"),
    ];
    let size: f64 = std::env::var("SURVEY_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.2);
    for y in &specs {
        let run0 = setup(y);
        let m = &run0.model;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        let (mut ok, mut bad, mut skipped, mut restarts) = (0, 0, 0, 0);
        eprintln!(
            "{}: held {:?}",
            m.name(),
            (0..m.param_count())
                .filter(|&j| m.param_held(j))
                .map(|j| m.param_name(j))
                .collect::<Vec<_>>()
        );
        for _trial in 0..20 {
            let truth: Vec<f64> = (0..m.param_count())
                .map(|j| {
                    let nom = m.param_nominal(j);
                    if m.param_held(j) {
                        nom
                    } else if m.param_is_angle(j) {
                        nom + rng.gen_range(-2.0 * size..2.0 * size)
                    } else {
                        nom + rng.gen_range(-size..size) * nom.abs().max(0.05)
                    }
                })
                .collect();
            let t2 = truth.clone();
            let sim = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                simulate(m, &t2, SimOptions::new(60, 7))
            }));
            let Ok(poses) = sim else {
                skipped += 1;
                continue;
            };
            let run = Run {
                model: SymbolicModel::from_spec(&run0.spec).unwrap(),
                spec: run0.spec.clone(),
                truth,
            };
            let lin = lincal_core::fit::solve::solve(&run.model, &poses).unwrap();
            match lincal_core::fit::extract::extract(&run.model, &lin) {
                Ok(ext) => {
                    restarts += ext.restarts;
                    let good = (0..m.param_count()).all(|j| {
                        let d = ext.p[j] - run.truth[j];
                        let d = if m.param_is_angle(j) {
                            wrap_angle(d)
                        } else {
                            d
                        };
                        d.abs() < 1e-8 * run.truth[j].abs().max(1.0)
                    });
                    if good {
                        ok += 1
                    } else {
                        bad += 1;
                        eprintln!(
                            "  {}: wrong, cost {:e}, ratio {:e}",
                            m.name(),
                            ext.cost,
                            ext.fit_ratio
                        );
                        for j in 0..m.param_count() {
                            eprintln!(
                                "    {} got {:.6} true {:.6}",
                                m.param_name(j),
                                ext.p[j],
                                run.truth[j]
                            );
                        }
                    }
                }
                Err(e) => {
                    bad += 1;
                    eprintln!("  {}: error {e}", m.name());
                }
            }
        }
        eprintln!(
            "{}: ok {ok}, wrong {bad}, skipped {skipped}, restarts {restarts}",
            m.name()
        );
    }
}

/// The PUMA 560 of `lincal-models` (K = 271 on a sphere): noise-free recovery of every free
/// parameter and 3σ on noisy data.
#[test]
fn puma_sphere_and_plane() {
    for file in ["puma560_sphere.yaml", "puma560_plane.yaml"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../lincal-models/specs")
            .join(file);
        let yaml = std::fs::read_to_string(&path).unwrap();
        let t = std::time::Instant::now();
        let run = setup(&yaml);
        let m = &run.model;
        let k = m.basis_size();
        let clean = simulate(m, &run.truth, SimOptions::new(2 * k, 31));
        let est = calibrate_spec(m, &run.spec, &clean, simulated())
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        check_exact(&run, &est, 1e-9);
        let noisy = simulate(
            m,
            &run.truth,
            SimOptions {
                poses: 3 * k,
                ..tracked(32)
            },
        );
        let est = calibrate_spec(m, &run.spec, &noisy, simulated()).unwrap();
        check_3sigma(&run, &est);
        eprintln!("{file}: K {k}, {:?}", t.elapsed());
    }
}

/// A known parameter is reported at its nominal, flagged, without std; the rest fit.
#[test]
fn known_parameters() {
    let y = "name: planar2_known
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.8, 2.8]}
  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}
params:
  a1: {nominal: 0.4, known: true}
  th1: {nominal: 0.02}
  a2: {nominal: 0.3}
  th2: {nominal: -0.03}
  b1: {nominal: -1.8}
  b2: {nominal: 1.0}
constraint:
  line: {b: [b1, b2]}
";
    let run = setup(y);
    let m = &run.model;
    assert_eq!(m.param_count(), 5);
    let poses = simulate(m, &run.truth, SimOptions::new(30, 77));
    let est = calibrate_spec(
        m,
        &run.spec,
        &poses,
        CalibrateOptions {
            refine: true,
            ..simulated()
        },
    )
    .unwrap();
    assert_eq!(est.params.len(), 6);
    let a1 = &est.params[0];
    assert_eq!(a1.name, "a1");
    assert!(a1.known && a1.std.is_none() && !a1.held);
    assert_eq!(a1.value, 0.4);
    check_exact(&run, &est, 1e-9);
}

/// A ball bar of known length whose cup stands half a metre from where the spec's nominals
/// put it, fitted from the nominals (fewer poses than `K`): the centre's start comes from the
/// nominal arm's tips with the radius kept (a sphere's values are fitted each on its own), so
/// the fit does not collapse the arm onto a sphere it cannot reach.
#[test]
fn a_known_radius_keeps_the_centre_start_from_the_data() {
    let y = spec(
        "spatial3_ball_bar",
        SPATIAL3,
        "  cx: {nominal: 0}\n  cy: {nominal: 0}\n  cz: {nominal: 0}\n  r: {nominal: 0.12, known: true}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n",
    );
    let mut run = setup(&y);
    let names: Vec<String> = (0..run.model.param_count())
        .map(|j| run.model.param_name(j).to_string())
        .collect();
    for (n, v) in [("cx", 0.35), ("cy", 0.1), ("cz", 0.35)] {
        let j = names.iter().position(|m| m == n).unwrap();
        run.truth[j] = v;
    }
    let poses = simulate(&run.model, &run.truth, SimOptions::new(40, 91));
    let est = calibrate_spec(
        &run.model,
        &run.spec,
        &poses,
        CalibrateOptions {
            refine: true,
            start: StartChoice::Nominal,
            ..simulated()
        },
    )
    .unwrap_or_else(|e| panic!("the fit from the nominals: {e}"));
    check_exact(&run, &est, 1e-7);
}

/// Honesty of the reported std (slow, run by hand): mean of z² over replicates, per kind.
#[test]
#[ignore = "survey, run by hand with --nocapture"]
fn survey_std() {
    let specs = [
        spec("planar3_point", PLANAR3, "  px: {nominal: 0.35}\n  py: {nominal: 0.25}\nconstraint:\n  point: {p: [px, py]}\n"),
        spec("planar2_circle", PLANAR2, "  cx: {nominal: 0.3}\n  cy: {nominal: 0.2}\n  r: {nominal: 0.15}\nconstraint:\n  circle: {center: [cx, cy], radius: r}\n"),
        spec("planar2_ellipse", PLANAR2, "  q11: {nominal: 6.349206349}\n  q22: {nominal: 14.285714286}\n  q12: {nominal: 0.5}\n  u1: {nominal: -3.809523810}\n  u2: {nominal: -5.714285714}\nconstraint:\n  quadric: {A: [[q11, q12], [q12, q22]], b: [u1, u2]}\n"),
        spec("spatial3_sphere", SPATIAL3, "  cx: {nominal: 0.35}\n  cy: {nominal: 0.1}\n  cz: {nominal: 0.35}\n  r: {nominal: 0.12}\nconstraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n"),
        spec("spatial3_line", SPATIAL3, "  u1: {nominal: -2.0}\n  u2: {nominal: 0.3}\n  u3: {nominal: -0.4}\n  v1: {nominal: 0.2}\n  v2: {nominal: -1.0}\n  v3: {nominal: -1.6}\nconstraint:\n  line: {planes: [[u1, u2, u3], [v1, v2, v3]]}\n"),
    ];
    let only = std::env::var("SURVEY_ONLY").unwrap_or_default();
    let reps: u64 = std::env::var("SURVEY_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let poses: usize = std::env::var("SURVEY_POSES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(150);
    for y in specs.iter().filter(|y| y.contains(only.as_str())) {
        let run = setup(y);
        let m = &run.model;
        for refine in [false, true] {
            let mut z2 = vec![0.0; m.param_count()];
            let mut zm = vec![0.0; m.param_count()];
            for r in 0..reps {
                let data = simulate(
                    m,
                    &run.truth,
                    SimOptions {
                        poses,
                        ..tracked(5000 + r)
                    },
                );
                let est = calibrate_spec(
                    m,
                    &run.spec,
                    &data,
                    CalibrateOptions {
                        refine,
                        ..simulated()
                    },
                )
                .unwrap();
                for j in (0..m.param_count()).filter(|&j| !m.param_held(j)) {
                    let p = est
                        .params
                        .iter()
                        .find(|p| p.name == m.param_name(j))
                        .unwrap();
                    let z = (p.value - run.truth[j]) / p.std.unwrap();
                    z2[j] += z * z / reps as f64;
                    zm[j] += z / reps as f64;
                }
            }
            let s: Vec<String> = (0..m.param_count())
                .filter(|&j| !m.param_held(j))
                .map(|j| format!("{} {:.2} (mean z {:.2})", m.param_name(j), z2[j], zm[j]))
                .collect();
            eprintln!("{} refine {refine}: mean z²: {}", m.name(), s.join(", "));
        }
    }
}

/// The linear method's std is honest on a 3-D line, where the two plane equations carry
/// different algebraic scales (a pooled σ̂²(JᵀJ)⁻¹ over-reported one parameter about 2× and
/// under-reported another). The sandwich covariance brings every mean z² near 1; measured
/// over 200 replicates the worst is 1.56 (std under-reported by about 20 %, the finite-sample
/// bias of the robust estimator), while `--refine`'s geometric covariance gives 0.85–1.28.
/// `REPS=200` and `REFINE=1` rerun those surveys.
#[test]
fn linear_std_is_honest_on_a_3d_line() {
    let y = spec(
        "spatial3_line",
        SPATIAL3,
        "  u1: {nominal: -2.0}\n  u2: {nominal: 0.3}\n  u3: {nominal: -0.4}\n  v1: {nominal: 0.2}\n  v2: {nominal: -5.0}\n  v3: {nominal: -1.6}\nconstraint:\n  line: {planes: [[u1, u2, u3], [v1, v2, v3]]}\n",
    );
    let run = setup(&y);
    let m = &run.model;
    let reps: u64 = std::env::var("REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(40);
    let refine = std::env::var_os("REFINE").is_some();
    let mut z2 = vec![0.0; m.param_count()];
    for r in 0..reps {
        let data = simulate(
            m,
            &run.truth,
            SimOptions {
                poses: 150,
                ..tracked(7000 + r)
            },
        );
        let est = calibrate_spec(
            m,
            &run.spec,
            &data,
            CalibrateOptions {
                refine,
                ..simulated()
            },
        )
        .unwrap();
        for j in (0..m.param_count()).filter(|&j| !m.param_held(j)) {
            let p = est
                .params
                .iter()
                .find(|p| p.name == m.param_name(j))
                .unwrap();
            let z = (p.value - run.truth[j]) / p.std.unwrap();
            z2[j] += z * z / reps as f64;
        }
    }
    eprintln!(
        "{:?}",
        (0..m.param_count())
            .map(|j| (m.param_name(j), z2[j]))
            .collect::<Vec<_>>()
    );
    for j in (0..m.param_count()).filter(|&j| !m.param_held(j)) {
        assert!(
            (0.45..=2.5).contains(&z2[j]),
            "{}: mean z² {:.2} over {reps} replicates",
            m.param_name(j),
            z2[j]
        );
    }
}
