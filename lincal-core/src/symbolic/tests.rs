//! Engine tests: the paper's examples, and independent numerical checks at random points
//! (numeric DH product vs expanded polynomials, basis·c vs h, sampled ranks, finite-difference
//! Jacobian ranks).
#![cfg(test)]

use super::testutil::*;
use super::SymbolicModel;
use crate::model::CalibModel;
use crate::spec::{Constraint, Convention, ParamRole, Spec};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn pl(names: &[(&str, f64)]) -> Vec<crate::spec::Param> {
    names
        .iter()
        .map(|(n, v)| param(n, *v, ParamRole::Length))
        .collect()
}

/// Every kind of constraint on a mixed spatial arm, plus planar ones.
fn zoo() -> Vec<Spec> {
    let mut v = vec![planar_line(3), planar_point(3)];
    let mut circle = planar_line(2);
    circle.params.retain(|x| !x.name.starts_with('b'));
    circle
        .params
        .extend(pl(&[("cx", 0.2), ("cy", 0.1), ("r", 0.3)]));
    circle.constraints = vec![Constraint::Circle {
        center: [p("cx"), p("cy")],
        radius: p("r"),
    }];
    v.push(circle);
    let mut measured = planar_line(3);
    measured.params.retain(|x| !x.name.starts_with('b'));
    measured.constraints = vec![Constraint::Measured];
    v.push(measured);
    for conv in [Convention::Dh, Convention::Mdh] {
        v.push(spatial_mixed(
            conv,
            Constraint::Plane {
                b: [p("b1"), p("b2"), p("b3")],
            },
            pl(&[("b1", 0.1), ("b2", -0.2), ("b3", -3.0)]),
        ));
    }
    v.push(spatial_mixed(
        Convention::Dh,
        Constraint::Sphere {
            center: [p("cx"), p("cy"), p("cz")],
            radius: p("r"),
        },
        pl(&[("cx", 0.1), ("cy", 0.2), ("cz", 0.3), ("r", 0.4)]),
    ));
    v.push(spatial_mixed(
        Convention::Dh,
        Constraint::Line3 {
            planes: [[p("b1"), p("b2"), p("b3")], [p("e1"), p("e2"), p("e3")]],
        },
        pl(&[
            ("b1", 0.1),
            ("b2", -2.0),
            ("b3", 0.3),
            ("e1", -3.0),
            ("e2", 0.2),
            ("e3", 0.1),
        ]),
    ));
    v.push(spatial_mixed(
        Convention::Mdh,
        Constraint::Point {
            p: vec![p("px"), p("py"), p("pz")],
        },
        pl(&[("px", 0.1), ("py", 0.2), ("pz", 0.3)]),
    ));
    v.push(spatial_mixed(
        Convention::Dh,
        Constraint::Quadric {
            a: vec![
                vec![p("q11"), num("0"), num("0")],
                vec![num("0"), p("q22"), num("0.5")],
                vec![num("0"), num("0.5"), num("1")],
            ],
            b: vec![p("l1"), num("0"), num("-2")],
        },
        pl(&[("q11", 1.0), ("q22", 2.0), ("l1", 0.3)]),
    ));
    v.push(spatial_mixed(Convention::Dh, Constraint::Measured, vec![]));
    // Hayati's tilt: a parameter on the third joint, a known irrational one on the first.
    for conv in [Convention::Dh, Convention::Mdh] {
        let be3 = vec![param("be3", 0.02, ParamRole::Angle)];
        let mut tilted = spatial_mixed(conv, Constraint::Measured, be3);
        tilted.joints[2].beta = p("be3");
        tilted.joints[0].beta = num("0.1");
        tilted.name = format!("mixed_tilted_{conv:?}");
        v.push(tilted);
    }
    v.push(pose_arm());
    // URDF-native rows: origins with unknown, exact and generic known entries, a prismatic
    // joint, a home offset on top; measured tips and a plane.
    for (name, constraint) in [
        ("urdf_native", "constraint: measured"),
        (
            "urdf_native_plane",
            "  b1: {nominal: 0.1}\n  b2: {nominal: -0.2}\n  b3: {nominal: -3}\n\
             constraint: {plane: {b: [b1, b2, b3]}}",
        ),
    ] {
        let text = format!("name: {name}\n{URDF_NATIVE}{constraint}\n");
        v.push(crate::spec::from_yaml_str(&text, None).expect("the URDF-native spec"));
    }
    // A known home offset whose cosine is irrational stays a symbol with its value.
    let mut known = planar_line(3);
    if let Some(t) = known.params.iter_mut().find(|x| x.name == "th3") {
        t.known = true;
        t.nominal = crate::spec::Exact::from_f64(0.0446).unwrap();
    }
    known.name = "planar3_known_th3".into();
    v.push(known);
    let mut list = planar_line(2);
    list.params.extend(pl(&[("e1", 0.5), ("e2", -2.0)]));
    list.constraints.push(Constraint::Line2 {
        b: [p("e1"), p("e2")],
    });
    list.constraint_list = true;
    v.push(list);
    v
}

fn random_p(m: &SymbolicModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| {
            if m.param_is_angle(j) {
                rng.gen_range(-3.0..3.0)
            } else {
                rng.gen_range(-1.0..1.0)
            }
        })
        .collect()
}

fn random_q(m: &SymbolicModel, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..m.joint_count())
        .map(|_| rng.gen_range(-3.0..3.0))
        .collect()
}

/// A spatial 3R arm whose tool frame's pose is measured: a tool frame and a base with
/// unknown translations and angles (a known irrational angle among them).
fn pose_arm() -> Spec {
    crate::spec::from_yaml_str(
        "name: pose3\ndim: 3\njoints:\n  \
         - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, alpha: al2, home: th2}\n  \
         - {type: revolute, a: 0.1, alpha: -pi/2, d: d3, home: th3}\n\
         tool: {x: tx, y: 0, z: tz, roll: 0.3, pitch: tp, yaw: ty}\n\
         base: {x: bx, y: 0.1, z: 0, roll: br, pitch: 0, yaw: byaw}\n\
         params:\n  a1: {nominal: 0.1}\n  d1: {nominal: 0.3}\n  th1: {nominal: 0}\n  \
         a2: {nominal: 0.4}\n  al2: {nominal: 0.05}\n  th2: {nominal: 0}\n  \
         d3: {nominal: 0.05}\n  th3: {nominal: 0}\n  tx: {nominal: 0.01}\n  \
         tz: {nominal: 0.1}\n  tp: {nominal: 0.2}\n  ty: {nominal: -0.1}\n  \
         bx: {nominal: -1}\n  br: {nominal: 0.1}\n  byaw: {nominal: 0.5}\n\
         constraint:\n  measured_pose: {}\n",
        None,
    )
    .unwrap()
}

/// h via the numeric DH product and the geometry module: independent of the expansion (a
/// measured pose's rotation entries from the chain's tool frame).
fn h_numeric(m: &SymbolicModel, q: &[f64], p: &[f64]) -> Vec<f64> {
    crate::program::constraint_functions(m, q, p)
}

fn h_via_basis(m: &SymbolicModel, q: &[f64], p: &[f64]) -> Vec<f64> {
    let k = m.basis_size();
    let mut phi = vec![0.0; k];
    m.basis(q, &mut phi);
    let mut c = vec![0.0; k * m.equation_count()];
    m.generalized_params(p, &mut c);
    (0..m.equation_count())
        .map(|e| (0..k).map(|i| c[e * k + i] * phi[i]).sum())
        .collect()
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-12 * scale.max(1.0)
}

#[test]
fn expansion_and_basis_equal_numeric_kinematics() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for spec in zoo() {
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let expanded = m.expanded_equations().unwrap();
        for _ in 0..20 {
            let (q, p) = (random_q(&m, &mut rng), random_p(&m, &mut rng));
            let hn = h_numeric(&m, &q, &p);
            let he = expanded.eval(&q, &p);
            let hb = h_via_basis(&m, &q, &p);
            let scale = hn.iter().fold(1.0f64, |s, x| s.max(x.abs())) * 10.0;
            for e in 0..hn.len() {
                assert!(
                    close(hn[e], he[e], scale),
                    "{}: expanded {} vs numeric {}",
                    spec.name,
                    he[e],
                    hn[e]
                );
                assert!(
                    close(hn[e], hb[e], scale),
                    "{}: basis·c {} vs numeric {}",
                    spec.name,
                    hb[e],
                    hn[e]
                );
            }
        }
    }
}

fn numeric_rank(rows: &[Vec<f64>], rel_tol: f64) -> usize {
    let n = rows.len();
    let k = rows[0].len();
    let a = DMatrix::from_fn(n.max(k), k, |i, j| rows.get(i).map_or(0.0, |r| r[j]));
    let sv = a.singular_values();
    let mx = sv.iter().fold(0.0f64, |m, x| m.max(*x));
    sv.iter().filter(|s| **s > rel_tol * mx).count()
}

#[test]
fn basis_is_independent_and_spans_h_by_sampling() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for spec in zoo() {
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let k = m.basis_size();
        // Independence: Φ̃ at many random poses has full column rank.
        let rows: Vec<Vec<f64>> = (0..3 * k + 10)
            .map(|_| {
                let mut phi = vec![0.0; k];
                m.basis(&random_q(&m, &mut rng), &mut phi);
                phi
            })
            .collect();
        assert_eq!(numeric_rank(&rows, 1e-10), k, "{}", spec.name);
        // Dimension of span{h_e(·; p)}: columns are (e, p_j) samples, rows random poses,
        // evaluated by the numeric DH product only.
        let ps: Vec<Vec<f64>> = (0..k + 5).map(|_| random_p(&m, &mut rng)).collect();
        let qs: Vec<Vec<f64>> = (0..2 * k + 10).map(|_| random_q(&m, &mut rng)).collect();
        let rows: Vec<Vec<f64>> = qs
            .iter()
            .map(|q| ps.iter().flat_map(|p| h_numeric(&m, q, p)).collect())
            .collect();
        assert_eq!(
            numeric_rank(&rows, 1e-10),
            k,
            "{}: sampled span of h",
            spec.name
        );
    }
}

/// Identifiable count by finite differences of c(p), independent of the exact analysis.
fn fd_identifiable(m: &SymbolicModel, p: &[f64]) -> usize {
    let k = m.basis_size();
    let ne = m.equation_count();
    let np = m.param_count();
    let c_at = |p: &[f64]| {
        let mut c = vec![0.0; ne * k];
        m.generalized_params(p, &mut c);
        c
    };
    let c0 = c_at(p);
    let mut cols: Vec<Vec<f64>> = (0..np)
        .map(|j| {
            let h = 1e-6;
            let (mut a, mut b) = (p.to_vec(), p.to_vec());
            a[j] += h;
            b[j] -= h;
            c_at(&a)
                .iter()
                .zip(c_at(&b))
                .map(|(x, y)| (x - y) / (2.0 * h))
                .collect()
        })
        .collect();
    let mut mixing = Vec::new();
    for g in 0..m.constraint_count() {
        if m.constraint_kind(g).is_measured() {
            continue;
        }
        let eqs: Vec<usize> = (0..ne).filter(|&e| m.equation_constraint(e) == g).collect();
        for &a in &eqs {
            for &b in &eqs {
                let mut col = vec![0.0; ne * k];
                col[a * k..(a + 1) * k].copy_from_slice(&c0[b * k..(b + 1) * k]);
                mixing.push(col);
            }
        }
    }
    let rank = |cols: &[Vec<f64>]| {
        if cols.is_empty() {
            return 0;
        }
        // rows = columns here; rank is symmetric
        let normed: Vec<Vec<f64>> = cols
            .iter()
            .map(|c| {
                let n = c.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
                c.iter().map(|x| x / n).collect()
            })
            .collect();
        numeric_rank(&normed, 1e-7)
    };
    let rg = rank(&mixing);
    cols.extend(mixing);
    rank(&cols) - rg
}

#[test]
fn identifiable_count_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for spec in zoo() {
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let p = random_p(&m, &mut rng);
        assert_eq!(
            fd_identifiable(&m, &p),
            m.identifiability().count,
            "{}",
            spec.name
        );
        let held = m.identifiability().held.iter().filter(|h| **h).count();
        assert_eq!(
            held,
            m.param_count() - m.identifiability().count,
            "{}",
            spec.name
        );
        // The facts a cache would hand back pass their own coherence check.
        assert!(
            m.facts().fit(m.param_count(), spec.relations.len()),
            "{}",
            spec.name
        );
    }
}

#[test]
fn planar_line_matches_the_paper() {
    for n in 2..=6 {
        let m = SymbolicModel::from_spec(&planar_line(n)).unwrap();
        assert_eq!(m.basis_size(), 2 * n + 1, "n = {n}: {:?}", m.basis_names());
        assert_eq!(m.identifiability().count, 2 * n, "n = {n}");
        // Identifiable on their own: th2..thn only (the paper: β+θh1 and ratios are
        // combinations).
        let (yes, _) = m.identifiable_split();
        let want: Vec<String> = (2..=n).map(|i| format!("th{i}")).collect();
        assert_eq!(yes, want);
        // Gauge rule holds a1 and th1 (the paper's a_i/a1 and β+θh1).
        let held: Vec<&str> = (0..m.param_count())
            .filter(|&j| m.param_held(j))
            .map(|j| m.param_name(j))
            .collect();
        assert_eq!(held, ["a1", "th1"]);
    }
    let m = SymbolicModel::from_spec(&planar_line(2)).unwrap();
    assert_eq!(
        m.basis_names(),
        ["1", "c1", "s1", "c1*c2 - s1*s2", "c1*s2 + s1*c2"]
    );
    let c = m.generalized_param_strings().unwrap();
    assert_eq!(c[0][0], "1");
    assert_eq!(c[0][1], "a1*b1*cos(th1) - a1*b2*sin(th1)");
}

#[test]
fn planar_point_identifies_six() {
    // The issue's pitfall 1: a 3-link arm pinned at an unknown point identifies
    // γ + θh1, θh2, θh3, a2/a1, a3/a1, ‖p‖/a1.
    let m = SymbolicModel::from_spec(&planar_point(3)).unwrap();
    assert_eq!(m.identifiability().count, 6, "{:?}", m.basis_names());
}

#[test]
fn exact_right_angles_give_the_pumas_basis() {
    let spec = puma(
        Constraint::Plane {
            b: [p("b1"), p("b2"), p("b3")],
        },
        pl(&[("b1", 0.0), ("b2", 0.0), ("b3", -3.3)]),
    );
    let m = SymbolicModel::from_spec(&spec).unwrap();
    assert_eq!(m.basis_size(), 195);
    // The same arm with a generic twist instead of pi/2 has a larger basis.
    let mut generic = spec.clone();
    generic.joints[0].alpha = num("1.5");
    let g = SymbolicModel::from_spec(&generic).unwrap();
    assert!(g.basis_size() > m.basis_size());
}

/// The public reference cases: `basis_size` and `identifiable_count` exactly.
#[test]
fn shared_cases_basis_and_identifiability() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut seen = 0;
    for name in crate::symbolic::testutil::repo_spec_paths(&["../shared/cases"]) {
        let spec = crate::symbolic::testutil::repo_spec(&name);
        let case = root.join(&name);
        let case = case.parent().expect("a case folder");
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let expected: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(case.join("expected.json")).unwrap())
                .unwrap();
        assert_eq!(
            m.basis_size() as u64,
            expected["basis_size"].as_u64().unwrap(),
            "{case:?}"
        );
        assert_eq!(
            m.identifiability().count as u64,
            expected["identifiable_count"].as_u64().unwrap(),
            "{case:?}"
        );
        eprintln!("{}: gauge {:?}", spec.name, m.gauge());
        seen += 1;
    }
    assert!(seen >= 2);
}

#[test]
fn gauge_rule_holds_parameters_that_fix_the_gauge_at_the_nominals() {
    // PUMA a1 has nominal 0: holding it cannot fix the scale there, so a2 is held instead.
    let spec = puma(
        Constraint::Plane {
            b: [p("b1"), p("b2"), p("b3")],
        },
        pl(&[("b1", 0.0), ("b2", 0.0), ("b3", -3.3)]),
    );
    let m = SymbolicModel::from_spec(&spec).unwrap();
    let held: Vec<&str> = (0..m.param_count())
        .filter(|&j| m.param_held(j))
        .map(|j| m.param_name(j))
        .collect();
    assert!(!held.contains(&"a1"), "{held:?}");
    assert_eq!(held.len(), m.param_count() - m.identifiability().count);
}

#[test]
fn a_parameter_without_effect_is_reported_and_held() {
    // Link 3 has zero length and no tool: its home offset cannot move the tip.
    let mut spec = planar_line(3);
    spec.joints[2].a = num("0");
    spec.params.retain(|x| x.name != "a3");
    let m = SymbolicModel::from_spec(&spec).unwrap();
    let j = (0..m.param_count())
        .find(|&j| m.param_name(j) == "th3")
        .unwrap();
    assert!(m.identifiability().no_effect[j]);
    assert!(m.param_held(j));
    assert_eq!(m.warnings().len(), 1);
    assert!(m.warnings()[0].contains("`th3`"));
    // Nothing else is flagged.
    assert_eq!(
        m.identifiability().no_effect.iter().filter(|x| **x).count(),
        1
    );
}

#[test]
fn gauge_directions_keep_their_held_parameter_at_any_unit_scale() {
    // The paper's arm in units where lengths are ~1e-4 and b ~ 1e3: the held a1 must stay in
    // its gauge direction with coefficient 1.
    let mut spec = planar_line(2);
    for prm in &mut spec.params {
        let v = prm.nominal.to_f64();
        let scaled = match prm.name.as_str() {
            "a1" | "a2" => v * 1e-3,
            "b1" | "b2" => v * 1e3,
            _ => v,
        };
        prm.nominal = crate::spec::Exact::from_f64(scaled).unwrap();
    }
    let m = SymbolicModel::from_spec(&spec).unwrap();
    let gauge = m.gauge();
    assert!(
        gauge
            .iter()
            .any(|g| g.iter().any(|(n, c)| n == "a1" && (c - 1.0).abs() < 1e-9)),
        "{gauge:?}"
    );
    assert!(
        gauge
            .iter()
            .any(|g| g.iter().any(|(n, c)| n == "th1" && (c - 1.0).abs() < 1e-9)),
        "{gauge:?}"
    );
}

/// The chain-factored kernel gives the flat engine's `Φ̃(q)`, `c(p)` and `∂c/∂p` at random
/// points, for every model of the zoo (every constraint kind, prismatic joints, a measured
/// pose with base and tool frames, a constraint list).
#[test]
fn factored_kernel_equals_the_flat_engine() {
    let mut rng = ChaCha8Rng::seed_from_u64(48);
    let mut specs = zoo();
    specs.push(pose_arm());
    for spec in &specs {
        let m = SymbolicModel::from_spec(spec).unwrap();
        let t = m.factored().unwrap();
        let tables = t.tables();
        let (k, e, np) = (m.basis_size(), m.equation_count(), m.param_count());
        for _ in 0..3 {
            let p = random_p(&m, &mut rng);
            let q = random_q(&m, &mut rng);
            let mut vals = vec![0.0; t.offsets.last().copied().unwrap_or(0)];
            for j in 0..m.constraint_count() {
                let (a, b) = (t.offsets[j], t.offsets[j + 1]);
                m.constraint_values(j, &p, &mut vals[a..b]);
            }
            let (mut c0, mut c1) = (vec![0.0; e * k], vec![0.0; e * k]);
            m.generalized_params(&p, &mut c0);
            tables.generalized_params(&p, &vals, &mut c1);
            let scale = c0.iter().fold(1.0f64, |a, b| a.max(b.abs()));
            for i in 0..e * k {
                assert!(
                    close(c0[i], c1[i], scale),
                    "{}: c[{i}] flat {} factored {}",
                    spec.name,
                    c0[i],
                    c1[i]
                );
            }
            let (mut j0, mut j1) = (vec![0.0; e * k * np], vec![0.0; e * k * np]);
            m.jacobian(&p, &mut j0);
            let mut scratch = vec![0.0; crate::model::factored::Tables::scratch_len(&t.chain)];
            tables.jacobian(&p, &vals, &mut scratch, &mut j1);
            let scale = j0.iter().fold(1.0f64, |a, b| a.max(b.abs()));
            for i in 0..e * k * np {
                assert!(
                    (j0[i] - j1[i]).abs() <= 1e-10 * scale,
                    "{}: ∂c[{}]/∂{} flat {} factored {}",
                    spec.name,
                    i / np,
                    m.param_names()[i % np],
                    j0[i],
                    j1[i]
                );
            }
            let (mut b0, mut b1) = (vec![0.0; k], vec![0.0; k]);
            m.basis(&q, &mut b0);
            tables.basis(&q, &mut b1);
            for i in 0..k {
                assert!(
                    close(b0[i], b1[i], 1.0),
                    "{}: Φ̃[{i}] {} {}",
                    spec.name,
                    b0[i],
                    b1[i]
                );
            }
        }
    }
}

/// A three-joint chain in `convention: urdf` (the zoo adds its constraint).
const URDF_NATIVE: &str = "dim: 3\nconvention: urdf\njoints:
  - {type: revolute, x: 0.1, z: z1, roll: pi/2, yaw: yw1}
  - {type: prismatic, x: x2, y: y2, z: 0.2, roll: r2, pitch: 0.3, yaw: yw2}
  - {type: revolute, x: x3, y: 0.05, z: z3, roll: r3, pitch: p3, yaw: -pi/2, home: h3}
tool: [0.01, ty, tz]
base: {x: bx, yaw: byaw}
params:
  z1: {nominal: 0.3}
  yw1: {nominal: 0.1}
  x2: {nominal: 0.05}
  y2: {nominal: -0.02}
  r2: {nominal: 0.2}
  yw2: {nominal: -0.1}
  x3: {nominal: 0.25}
  z3: {nominal: 0.01}
  r3: {nominal: 0.05}
  p3: {nominal: -0.3}
  h3: {nominal: 0.02}
  ty: {nominal: 0.03}
  tz: {nominal: 0.1}
  bx: {nominal: 0.2}
  byaw: {nominal: 0.1}
";

/// A chain whose every parameter is unknown has the full grid of joint monomials as its basis
/// (`R` a permutation): the kernel forms it as a tensor product ([`Tables::term_grid`]), and
/// that equals the flat engine's `Φ̃(q)` and the kernel's general path at random readings,
/// for a pinned point and a measured pose.
///
/// [`Tables::term_grid`]: crate::model::factored::Tables::term_grid
#[test]
fn a_full_grid_basis_is_the_tensor_product_of_the_joint_functions() {
    let chain = "dim: 3\njoints:
  - {type: revolute, a: a1, alpha: al1, d: d1, home: h1}
  - {type: revolute, a: a2, alpha: al2, d: t2, home: o2}
  - {type: revolute, a: a3, alpha: al3, d: d3, home: h3}
  - {type: revolute, a: a4, alpha: al4, d: d4, home: h4}
tool: [tx, ty, tz]
params:
  a1: {nominal: 0.1}
  al1: {nominal: 1.2}
  d1: {nominal: 0.3}
  h1: {nominal: 0.05}
  a2: {nominal: 0.02}
  al2: {nominal: -0.7}
  t2: {nominal: 0.4}
  o2: {nominal: 0.1}
  a3: {nominal: 0.25}
  al3: {nominal: 0.9}
  d3: {nominal: 0.04}
  h3: {nominal: -0.1}
  a4: {nominal: 0.2}
  al4: {nominal: -1.1}
  d4: {nominal: 0.03}
  h4: {nominal: 0.2}
  tx: {nominal: 0.05}
  ty: {nominal: 0.01}
  tz: {nominal: 0.1}
";
    let mut rng = ChaCha8Rng::seed_from_u64(4848);
    for constraint in ["  px: {nominal: 0.5}\n  py: {nominal: 0.1}\n  pz: {nominal: 0.2}\nconstraint:\n  point: {p: [px, py, pz]}\n", "constraint:\n  measured_pose: {}\n"] {
        let yaml = format!("name: grid\n{chain}{constraint}");
        let spec = crate::spec::from_yaml_str(&yaml, None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let mut t = m.factored().unwrap();
        assert_eq!(t.term_grid, vec![3, 3, 3, 3], "{yaml}");
        assert_eq!(m.basis_size(), 81);
        let k = m.basis_size();
        for _ in 0..5 {
            let q = random_q(&m, &mut rng);
            let (mut flat, mut grid, mut trie) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
            m.basis(&q, &mut flat);
            t.tables().basis(&q, &mut grid);
            let full = std::mem::take(&mut t.term_grid);
            t.tables().basis(&q, &mut trie);
            t.term_grid = full;
            for i in 0..k {
                assert!(close(flat[i], grid[i], 1.0), "Φ̃[{i}] flat {} grid {}", flat[i], grid[i]);
                assert!(close(trie[i], grid[i], 1.0), "Φ̃[{i}] trie {} grid {}", trie[i], grid[i]);
            }
        }
    }
}

/// A basis refused within a smaller bound than the model's (an automatic start's) is not kept
/// as refused: the model's own bound still builds it for `lincal basis`, `--start linear` or
/// a Python `Spec` asked for its basis after a fit.
#[test]
fn a_refusal_within_a_smaller_bound_is_not_kept() {
    let spec = repo_spec("tests/specs/plane_spatial.yaml");
    let m = SymbolicModel::for_fitting(&spec, super::DEFAULT_MAX_TERMS).unwrap();
    assert!(m.basis_ready_within(10).is_err());
    assert!(m.basis_ready().is_ok());
    assert!(
        m.basis_ready_within(10).is_ok(),
        "built now, whatever the bound"
    );
    assert_eq!(
        m.basis_size(),
        SymbolicModel::from_spec(&spec).unwrap().basis_size()
    );
}

/// Where the factored kernel costs less than `c`'s polynomials (a spatial arm on an unknown
/// quadric, every parameter unknown: `K·E·P` = 2 875 values against tens of thousands of
/// terms), it evaluates `c(p)` and `∂c/∂p` for the fit, equal to the exact polynomials at
/// random points.
#[test]
fn the_kernel_evaluates_a_large_c_as_its_polynomials() {
    let spec = repo_spec("tests/specs/quadric_spatial3.yaml");
    let model = SymbolicModel::from_spec(&spec).unwrap();
    let (k, e, np) = (
        model.basis_size(),
        model.equation_count(),
        model.param_count(),
    );
    assert_eq!(
        model.jacobian_work(),
        Some(k * e * np),
        "the kernel is chosen"
    );
    let vars = super::slots::slot_polys(&spec).unwrap().vars;
    let c: Vec<super::eval::CompiledPoly> = model
        .reduction()
        .unwrap()
        .c
        .iter()
        .flatten()
        .map(super::eval::CompiledPoly::new)
        .collect();
    let jac = model.jacobian_polys().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(48);
    for _ in 0..3 {
        let p: Vec<f64> = (0..np).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let vals = super::eval::param_values(&vars, &p);
        let (mut got, mut dgot) = (vec![0.0; k * e], vec![0.0; k * e * np]);
        model.generalized_params(&p, &mut got);
        model.jacobian(&p, &mut dgot);
        for (i, ci) in c.iter().enumerate() {
            let want = ci.eval(&vals);
            assert!(
                (got[i] - want).abs() <= 1e-9 * want.abs().max(1.0),
                "c[{i}]"
            );
        }
        let flat: Vec<f64> = jac
            .iter()
            .flatten()
            .flatten()
            .map(|d| super::eval::CompiledPoly::new(d).eval(&vals))
            .collect();
        assert_eq!(flat.len(), dgot.len());
        let scale = flat.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        for (i, (g, w)) in dgot.iter().zip(&flat).enumerate() {
            assert!((g - w).abs() <= 1e-9 * scale, "∂c[{i}]: {g} against {w}");
        }
    }
}
