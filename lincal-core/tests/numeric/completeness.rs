//! `lincal import` writes a complete parameter set with no redundancy of its own at parallel
//! and nearly parallel axes (issue 47, item 4): on random URDF chains of revolute and
//! prismatic joints, consecutive axes parallel, nearly parallel or generic, the exact
//! identifiability analysis of the imported spec finds the known maximum number of
//! identifiable combinations, `4R + 2P + 6` for a measured pose and `4R + 2P + 3` for a
//! measured position (base frame and tool unknown), and no more unknowns beyond it than the
//! import writes on purpose: frame 0's two freedoms along and about axis 1 (the base holds
//! them), two translations per prismatic joint (its line has no place) and the home of a last
//! revolute joint (the tool holds it). The URDF-native rows (`--convention urdf`, six unknowns
//! per joint origin) reach the same count with the redundancy they carry by design, which the
//! gauge rule holds. The Jacobian at the nominals has the same rank (a table can be complete
//! at a generic point and not at the URDF's geometry), and no length is huge.

use lincal_core::model::chain::{self, Motion};
use lincal_core::model::CalibModel;
use lincal_core::spec::{self, Convention};
use lincal_core::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS};
use lincal_core::urdf::{import, ConstraintChoice, ImportOptions};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

/// How a joint's axis relates to the previous one's.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Relation {
    /// Exactly parallel (the same or the opposite direction).
    Parallel,
    /// Tilted by this angle (radians) off parallel (the same or the opposite direction).
    Near(f64),
    /// A random direction.
    Generic,
}

/// One moving joint of a test chain.
#[derive(Clone, Debug)]
struct TestJoint {
    prismatic: bool,
    relation: Relation,
}

/// A unit vector ⊥ `u` (unit): the cross product with the axis `u` is least along.
fn perpendicular(u: [f64; 3]) -> [f64; 3] {
    let e = if u[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let c = [
        u[1] * e[2] - u[2] * e[1],
        u[2] * e[0] - u[0] * e[2],
        u[0] * e[1] - u[1] * e[0],
    ];
    let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    [c[0] / n, c[1] / n, c[2] / n]
}

fn unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v: [f64; 3] = [
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if (0.2..=1.0).contains(&n) {
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

/// `v` turned by `angle` about the unit `k` (Rodrigues).
fn turn(v: [f64; 3], k: [f64; 3], angle: f64) -> [f64; 3] {
    let (c, s) = (angle.cos(), angle.sin());
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let x = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    [0, 1, 2].map(|i| v[i] * c + x[i] * s + k[i] * kv * (1.0 - c))
}

/// A URDF of the chain `joints`: every joint origin a random offset with no rotation, so
/// each `<axis>` is the joint's axis in the base frame at zero readings, then a fixed joint
/// to the tip link `tip`.
fn urdf(joints: &[TestJoint], rng: &mut ChaCha8Rng) -> String {
    let mut x = String::from("<robot name=\"random\">\n  <link name=\"l0\"/>\n");
    let mut axis = unit(rng);
    for (i, j) in joints.iter().enumerate() {
        if i > 0 {
            axis = match j.relation {
                Relation::Parallel if rng.gen_bool(0.5) => axis.map(|c| -c),
                Relation::Parallel => axis,
                Relation::Near(delta) => {
                    let k = turn(perpendicular(axis), axis, rng.gen_range(0.0..6.2));
                    let sign = if rng.gen_bool(0.5) { -1.0 } else { 1.0 };
                    turn(axis, k, delta).map(|c| sign * c)
                }
                Relation::Generic => unit(rng),
            };
        }
        let xyz: [f64; 3] = [0; 3].map(|_| rng.gen_range(-0.3..0.3));
        let _ = write!(
            x,
            "  <link name=\"l{}\"/>\n  <joint name=\"j{}\" type=\"{}\">\n    <parent \
             link=\"l{i}\"/><child link=\"l{}\"/>\n    <origin xyz=\"{:e} {:e} {:e}\" rpy=\"0 0 \
             0\"/>\n    <axis xyz=\"{:e} {:e} {:e}\"/>\n    <limit lower=\"-1\" upper=\"1\" \
             effort=\"1\" velocity=\"1\"/>\n  </joint>\n",
            i + 1,
            i + 1,
            if j.prismatic { "prismatic" } else { "revolute" },
            i + 1,
            xyz[0],
            xyz[1],
            xyz[2],
            axis[0],
            axis[1],
            axis[2],
        );
    }
    let n = joints.len();
    let t: [f64; 3] = [0; 3].map(|_| rng.gen_range(-0.2..0.2));
    let _ = write!(
        x,
        "  <link name=\"tip\"/>\n  <joint name=\"flange\" type=\"fixed\">\n    <parent \
         link=\"l{n}\"/><child link=\"tip\"/>\n    <origin xyz=\"{:e} {:e} {:e}\" rpy=\"0.1 0.2 \
         0.3\"/>\n  </joint>\n</robot>\n",
        t[0], t[1], t[2]
    );
    x
}

/// What the analysis finds in the spec `import` writes for `text`.
struct Counts {
    /// Unknown parameters.
    params: usize,
    /// Identifiable combinations at a generic point (the exact analysis).
    generic: usize,
    /// The rank of the measurement's Jacobian at the nominals, over random readings: a
    /// table that cannot take some error of the URDF's own geometry is short here (at a
    /// generic point a plain DH row is complete; at parallel axes it is not).
    nominal: usize,
    /// The largest length among the nominals (metres).
    longest: f64,
}

/// The spec `import` writes for `text`.
fn imported(text: &str, convention: Convention, constraint: ConstraintChoice) -> spec::Spec {
    let opts = ImportOptions {
        path: "random.urdf".into(),
        base: "l0".into(),
        tip: "tip".into(),
        tool: [0.0; 3],
        convention,
        constraint,
        points: 1,
        distances: Vec::new(),
        command: "test".into(),
    };
    let imported = import(text, "random.urdf", &opts)
        .unwrap_or_else(|e| panic!("{e}: {convention:?}\n{text}"));
    spec::from_yaml_str(&imported.yaml, Some("imported.yaml"))
        .unwrap_or_else(|e| panic!("{e}\n{}", imported.yaml))
}

fn counts(text: &str, convention: Convention, constraint: ConstraintChoice) -> Counts {
    let spec = imported(text, convention, constraint);
    let model = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS).expect("the model builds");
    let np = model.param_count();
    let p: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let longest = (0..np)
        .filter(|&j| !model.param_is_angle(j))
        .map(|j| p[j].abs())
        .fold(0.0, f64::max);
    Counts {
        params: np,
        generic: model.identifiability().count,
        nominal: nominal_rank(&model, &p, constraint == ConstraintChoice::MeasuredPose),
        longest,
    }
}

/// The rank of the stacked Jacobian of the tip (`pose`: and the tool frame's rotation) at
/// `p` over 40 random readings, singular values below `10⁻⁹·σ_max` counted as 0.
fn nominal_rank(model: &SymbolicModel, p: &[f64], pose: bool) -> usize {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (np, n) = (p.len(), model.joint_count());
    let factors = model.chain();
    let mut motions = vec![Motion::default(); factors.len()];
    chain::prepare(factors, p, &mut motions);
    let rows = if pose { 6 } else { 3 };
    let mut jac = vec![0.0; 6 * np];
    let mut twists = vec![[0.0; 6]; np];
    let mut stacked = Vec::new();
    for _ in 0..40 {
        let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let (mut tip, mut rot) = ([0.0; 3], [0.0; 9]);
        chain::pose_jacobian_prepared(
            factors,
            &motions,
            q.as_slice(),
            &mut tip,
            &mut rot,
            &mut jac,
            &mut twists,
        );
        stacked.extend_from_slice(&jac[..rows * np]);
    }
    let m = DMatrix::from_row_slice(stacked.len() / np, np, &stacked);
    let sv = m.singular_values();
    let top = sv.max();
    sv.iter().filter(|&&s| s > 1e-9 * top).count()
}

/// Checks the spec imported from `joints` (a URDF drawn with `rng`) in every convention (DH,
/// modified DH and URDF-native rows), for a measured pose and a measured position.
fn check_chain(joints: &[TestJoint], rng: &mut ChaCha8Rng) {
    let text = urdf(joints, rng);
    let r = joints.iter().filter(|j| !j.prismatic).count();
    let p = joints.len() - r;
    let last_revolute = joints.last().is_some_and(|j| !j.prismatic);
    // Frame 0's offset and angle about axis 1, two translations per prismatic joint, and a
    // last revolute joint's home: the duplicates the import writes on purpose.
    let dh_duplicates = 2 + 2 * p + usize::from(last_revolute);
    // URDF-native rows: six per joint, of which a revolute joint's turn about and shift along
    // its axis, a prismatic joint's shift in any direction and turn about its axis, and the
    // first origin against the base (six) are redundant.
    let urdf_duplicates = 2 * r + 4 * p + 6;
    for convention in [Convention::Dh, Convention::Mdh, Convention::Urdf] {
        let duplicates = if convention == Convention::Urdf {
            urdf_duplicates
        } else {
            dh_duplicates
        };
        for (constraint, tool) in [
            (ConstraintChoice::MeasuredPose, 6),
            (ConstraintChoice::Measured, 3),
        ] {
            let c = counts(&text, convention, constraint);
            let want = 4 * r + 2 * p + tool;
            let case = format!("{joints:?}, {convention:?}, {constraint:?}");
            assert_eq!(c.generic, want, "not complete: {case}\n{text}");
            assert_eq!(
                c.nominal, want,
                "not complete at the nominals: {case}\n{text}"
            );
            assert_eq!(
                c.params - c.generic,
                duplicates,
                "redundant: {case}\n{text}"
            );
            // The joint origins are within 0.52 m of each other's, the tool 0.35 m from the
            // last: no bounded table needs lengths of more than a few metres.
            assert!(
                c.longest < 10.0,
                "a length of {} m: {case}\n{text}",
                c.longest
            );
        }
    }
}

/// Chains with a prismatic joint before a parallel (or nearly parallel) one, whose tilt
/// about the perpendicular to their normal the table did not take (issue 47), and revolute
/// pairs parallel and nearly parallel in a row.
fn hand_picked() -> Vec<Vec<TestJoint>> {
    let j = |prismatic, relation| TestJoint {
        prismatic,
        relation,
    };
    use Relation::{Generic, Near, Parallel};
    vec![
        vec![
            j(false, Generic),
            j(true, Generic),
            j(false, Parallel),
            j(false, Generic),
        ],
        vec![j(true, Generic), j(false, Parallel), j(false, Generic)],
        vec![
            j(false, Generic),
            j(true, Generic),
            j(true, Parallel),
            j(false, Generic),
        ],
        vec![
            j(false, Generic),
            j(true, Generic),
            j(false, Near(0.02)),
            j(false, Generic),
        ],
        vec![
            j(false, Generic),
            j(false, Parallel),
            j(false, Parallel),
            j(false, Generic),
        ],
        vec![
            j(false, Generic),
            j(false, Near(3e-3)),
            j(false, Near(0.05)),
            j(false, Generic),
        ],
        // Either side of `NEAR_PARALLEL` (sine 0.1): Hayati's row, then the common normal.
        vec![
            j(true, Generic),
            j(false, Near(0.095)),
            j(false, Near(0.11)),
            j(true, Generic),
        ],
    ]
}

#[test]
fn a_revolute_axis_parallel_to_a_prismatic_one_keeps_its_tilt() {
    let mut rng = ChaCha8Rng::seed_from_u64(47);
    for joints in &hand_picked() {
        check_chain(joints, &mut rng);
    }
}

/// The exact expansion of the imported rows (Hayati's after a prismatic joint, its `theta` a
/// decimal constant; nonzero tilts) equals the numeric chain near the nominals.
#[test]
fn the_exact_engine_takes_the_imported_rows_as_the_chain_does() {
    let mut rng = ChaCha8Rng::seed_from_u64(48);
    for joints in &hand_picked() {
        let text = urdf(joints, &mut rng);
        for convention in [Convention::Dh, Convention::Mdh] {
            let m =
                SymbolicModel::from_spec(&imported(&text, convention, ConstraintChoice::Measured))
                    .expect("the exact engine expands the imported spec");
            let k = m.basis_size();
            let (mut phi, mut c) = (vec![0.0; k], vec![0.0; 3 * k]);
            for _ in 0..10 {
                let p: Vec<f64> = (0..m.param_count())
                    .map(|j| m.param_nominal(j) + rng.gen_range(-0.05..0.05))
                    .collect();
                let q: Vec<f64> = (0..joints.len())
                    .map(|_| rng.gen_range(-2.0..2.0))
                    .collect();
                let mut tip = [0.0; 3];
                m.tip(&q, &p, &mut tip);
                m.basis(&q, &mut phi);
                m.generalized_params(&p, &mut c);
                for (e, x) in tip.iter().enumerate() {
                    let h: f64 = (0..k).map(|i| c[e * k + i] * phi[i]).sum();
                    assert!(
                        (h - x).abs() < 1e-9,
                        "{h} vs {x}: {joints:?}, {convention:?}"
                    );
                }
            }
        }
    }
}

/// Random chains of 3 to 5 joints, about a third prismatic, each axis parallel, nearly
/// parallel or unrelated to the previous one.
#[test]
fn imported_specs_are_complete_and_add_no_redundancy_on_random_chains() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x47_c0de);
    for _ in 0..40 {
        let n = rng.gen_range(3..=5);
        let joints: Vec<TestJoint> = (0..n)
            .map(|_| TestJoint {
                prismatic: rng.gen_bool(0.35),
                relation: match rng.gen_range(0..6) {
                    0 | 1 => Relation::Parallel,
                    2 => Relation::Near(10f64.powf(rng.gen_range(-3.0..-1.2))),
                    _ => Relation::Generic,
                },
            })
            .collect();
        check_chain(&joints, &mut rng);
    }
}

/// A URDF of two or three revolute joints: joint 1 about z at the origin, joint 2 about
/// `axis2` at `p2`, joint 3 about x at 0.3 m beyond it.
fn three_joints(p2: [f64; 3], axis2: [f64; 3]) -> String {
    let joint = |k: usize, xyz: [f64; 3], axis: [f64; 3]| {
        format!(
            "  <link name=\"l{k}\"/>\n  <joint name=\"j{k}\" type=\"revolute\">\n    <parent \
             link=\"l{}\"/><child link=\"l{k}\"/>\n    <origin xyz=\"{} {} {}\"/>\n    <axis \
             xyz=\"{} {} {}\"/>\n    <limit lower=\"-1\" upper=\"1\" effort=\"1\" \
             velocity=\"1\"/>\n  </joint>\n",
            k - 1,
            xyz[0],
            xyz[1],
            xyz[2],
            axis[0],
            axis[1],
            axis[2]
        )
    };
    format!(
        "<robot name=\"three\">\n  <link name=\"l0\"/>\n{}{}{}  <link name=\"tip\"/>\n  <joint \
         name=\"flange\" type=\"fixed\">\n    <parent link=\"l3\"/><child link=\"tip\"/>\n    \
         <origin xyz=\"0 0 0.1\"/>\n  </joint>\n</robot>\n",
        joint(1, [0.0; 3], [0.0, 0.0, 1.0]),
        joint(2, p2, axis2),
        joint(3, [0.0, 0.0, 0.3], [1.0, 0.0, 0.0]),
    )
}

fn import_opts(convention: Convention) -> ImportOptions {
    ImportOptions {
        path: "three.urdf".into(),
        base: "l0".into(),
        tip: "tip".into(),
        tool: [0.0; 3],
        convention,
        constraint: ConstraintChoice::Measured,
        points: 1,
        distances: Vec::new(),
        command: "test".into(),
    }
}

/// Axes 0.03 rad from parallel, 0.4 m apart: their common normal would lie about 13 m away.
/// The import writes Hayati's row instead, its tilt the pair's own (nominal nonzero, at most
/// the angle), no offset along the pair, and a note naming both joints.
#[test]
fn nearly_parallel_axes_get_hayatis_row_with_their_own_tilt() {
    let (s, c) = (0.03f64.sin(), 0.03f64.cos());
    // Tilted about the axis (1, 1, 0)/√2, so that both perpendiculars see part of it.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let text = three_joints([0.4, 0.0, 0.2], [h * s, -h * s, c]);
    for (convention, row) in [(Convention::Dh, 1), (Convention::Mdh, 2)] {
        let out = import(&text, "three.urdf", &import_opts(convention)).expect("imports");
        let spec = spec::from_yaml_str(&out.yaml, None).expect("loads");
        let beta = spec
            .params
            .iter()
            .find(|p| p.name == format!("beta{row}"))
            .unwrap_or_else(|| panic!("beta{row}: {}", out.yaml))
            .nominal
            .to_f64();
        assert!(
            beta.abs() > 1e-3 && beta.abs() <= 0.03 + 1e-12,
            "{beta}: {}",
            out.yaml
        );
        assert!(!out.yaml.contains("d: d1"), "{}", out.yaml);
        assert!(
            out.notes
                .iter()
                .any(|n| n.contains("`j1` and `j2`") && n.contains("from parallel")),
            "{:?}",
            out.notes
        );
        assert!(out.check < 1e-9, "{}", out.check);
    }
}

/// Axes 0.2 rad from parallel (beyond Hayati's row) that meet 2.5 km away: no bounded table
/// holds them; the error names both joints, where the axis is and what to check.
#[test]
fn a_common_normal_a_kilometre_away_is_refused_naming_both_joints() {
    let (s, c) = (0.2f64.sin(), 0.2f64.cos());
    let text = three_joints([0.0, 500.0, 0.0], [0.0, -s, c]);
    for convention in [Convention::Dh, Convention::Mdh] {
        let e = import(&text, "three.urdf", &import_opts(convention))
            .expect_err("a normal 2.5 km away is refused")
            .to_string();
        for part in ["three.urdf:", "`j1` and `j2`", "lies 2.5", "in metres"] {
            assert!(e.contains(part), "{part}: {e}");
        }
    }
}
