//! Compensation against truths computed here: round trips, the identity, redundancy, each
//! failure class, and targets files.

use super::task::rotation_error;
use super::*;
use crate::data::DataLayout;
use crate::spec::from_yaml_str;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PUMA: &str = include_str!("../../../lincal-models/specs/puma560_pose_tracker.yaml");
const IIWA_POINT: &str = include_str!("../../../lincal-models/specs/kuka_iiwa14_point.yaml");
const PUMA_TIP: &str = include_str!("../../../bench/specs/puma560_mdh_measured.yaml");

/// A 7R arm (the iiwa's table) whose tool frame is measured: pose targets, one redundant joint.
const IIWA_POSE: &str = "name: iiwa_pose\ndim: 3\njoints:\n  \
  - {type: revolute, a: 0, alpha: -pi/2, d: d1, home: th1, limits: [-2.9671, 2.9671]}\n  \
  - {type: revolute, a: 0, alpha: pi/2,  d: 0,  home: th2, limits: [-2.0944, 2.0944]}\n  \
  - {type: revolute, a: 0, alpha: pi/2,  d: d3, home: th3, limits: [-2.9671, 2.9671]}\n  \
  - {type: revolute, a: 0, alpha: -pi/2, d: 0,  home: th4, limits: [-2.0944, 2.0944]}\n  \
  - {type: revolute, a: 0, alpha: -pi/2, d: d5, home: th5, limits: [-2.9671, 2.9671]}\n  \
  - {type: revolute, a: 0, alpha: pi/2,  d: 0,  home: th6, limits: [-2.0944, 2.0944]}\n  \
  - {type: revolute, a: 0, alpha: 0,     d: d7, home: th7, limits: [-3.0543, 3.0543]}\n\
  tool: {x: tx, y: 0, z: tz, roll: 0, pitch: 0, yaw: 0}\n\
  params:\n  d1: {nominal: 0.36}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  \
  d3: {nominal: 0.42}\n  th3: {nominal: 0}\n  th4: {nominal: 0}\n  d5: {nominal: 0.4}\n  \
  th5: {nominal: 0}\n  th6: {nominal: 0}\n  d7: {nominal: 0.126}\n  th7: {nominal: 0}\n  \
  tx: {nominal: 0.05}\n  tz: {nominal: 0.045}\nconstraint: measured_pose\n";

/// A planar 2R arm without limits.
const PLANAR: &str = "name: p2\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
  - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.4}\n  a2: {nominal: 0.3}\n  \
  th1: {nominal: 0}\n  th2: {nominal: 0}\nconstraint: measured\n";

fn spec(text: &str) -> crate::spec::Spec {
    from_yaml_str(text, None).expect("test spec")
}

/// The nominals perturbed by `scale` (metres and radians alike).
fn perturbed(spec: &crate::spec::Spec, scale: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    spec.estimated_params()
        .iter()
        .map(|p| p.nominal.to_f64() + rng.gen_range(-scale..scale))
        .collect()
}

/// Joints drawn within `frac` of each joint's limits (±π without).
fn joints(spec: &crate::spec::Spec, frac: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    spec.joints
        .iter()
        .map(|j| {
            let [lo, hi] = j.limits.unwrap_or([-3.1, 3.1]);
            let (c, h) = ((lo + hi) / 2.0, (hi - lo) / 2.0 * frac);
            rng.gen_range(c - h..c + h)
        })
        .collect()
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    verdict::distance(a, b)
}

/// A laser tracker standing metres from the arm (its registration, the spec's `base:`, is
/// calibrated far from the nominal 0): placed by the calibrated base, a joint target means the
/// nominal arm where the calibration found it, so the correction is the arm's millimetres,
/// not the tracker's metres, and the filtered target stays in the controller's frame.
#[test]
fn a_tracker_metres_away_is_not_an_error_of_the_arm() {
    let s = spec(PUMA);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut cal = perturbed(&s, 1e-3, &mut rng);
    let names: Vec<String> = s
        .estimated_params()
        .iter()
        .map(|p| p.name.clone())
        .collect();
    let at = |n: &str| names.iter().position(|m| m == n).expect("a base parameter");
    for (n, v) in [("bx", 1.83), ("by", -0.6), ("bz", -0.41), ("byaw", 2.62)] {
        cal[at(n)] += v;
    }
    let c = Compensator::new(&s, cal.clone(), ParamCovariance::None)
        .unwrap()
        .place_by_calibrated_base();
    // The same arm errors with the tracker at the nominal frame.
    let mut home = cal.clone();
    for n in ["bx", "by", "bz", "broll", "bpitch", "byaw"] {
        home[at(n)] = 0.0;
    }
    let c0 = Compensator::new(&s, home, ParamCovariance::None)
        .unwrap()
        .place_by_calibrated_base();
    // By the interface's rule (the nominal `base:`) the same targets are the tracker's
    // metres away.
    let literal = Compensator::new(&s, cal, ParamCovariance::None).unwrap();
    let q = joints(&s, 0.5, &mut rng);
    assert!(dist(&literal.intended_tool(&q).x, &c.intended_tool(&q).x) > 1.0);
    let mut ok = 0;
    for _ in 0..50 {
        let q = joints(&s, 0.7, &mut rng);
        let (o, o0) = (c.compensate(&q, None), c0.compensate(&q, None));
        if o0.verdict.status != Status::Ok {
            continue;
        }
        ok += 1;
        assert_eq!(o.verdict.status, Status::Ok, "{o:?}");
        // The tracker's place changes nothing: the same joints, the same filtered target.
        assert!(dist(&o.q, &o0.q) < 1e-9, "{o:?} {o0:?}");
        assert!(dist(&o.filtered.x, &o0.filtered.x) < 1e-9);
        assert!(dist(&o.filtered.x, &c.nominal_tool(&o.q).x) < 1e-12);
        assert!(o.correction < 0.2, "a correction of {}", o.correction);
    }
    assert!(ok > 40, "only {ok} of 50 regular");
}

#[test]
fn joint_targets_round_trip_to_the_nominal_pose() {
    let s = spec(PUMA);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let cal = perturbed(&s, 2e-3, &mut rng);
    let c = Compensator::new(&s, cal, ParamCovariance::None).unwrap();
    let mut ok = 0;
    for _ in 0..200 {
        let q = joints(&s, 0.8, &mut rng);
        let o = c.compensate(&q, None);
        if o.verdict.status != Status::Ok {
            continue;
        }
        ok += 1;
        let want = c.intended_tool(&q);
        let got = c.calibrated_tool(&o.q);
        assert!(dist(&want.x, &got.x) < 1e-10, "{:?}", o);
        let phi = rotation_error(&want.rot, &got.rot);
        assert!(dist(&phi, &[0.0; 3]) < 1e-10);
        assert!(o.residual < 1e-10 && o.correction > 0.0, "{q:?} {o:?}");
        // `ok` bounds the gain: a correction at most `max_gain` times the error it corrects.
        let start = dist(&c.calibrated_tool(&q).x, &want.x)
            + dist(
                &rotation_error(&want.rot, &c.calibrated_tool(&q).rot),
                &[0.0; 3],
            );
        assert!(o.correction <= c.options.max_gain * start);
        // The filtered target is the nominal tool at the compensated joints.
        assert_eq!(o.filtered, c.nominal_tool(&o.q));
    }
    assert!(ok > 150, "only {ok} of 200 regular");
}

#[test]
fn the_nominal_parameters_return_the_seed() {
    let s = spec(PUMA);
    let nominal: Vec<f64> = s
        .estimated_params()
        .iter()
        .map(|p| p.nominal.to_f64())
        .collect();
    let c = Compensator::new(&s, nominal, ParamCovariance::None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..50 {
        let q = joints(&s, 0.8, &mut rng);
        let o = c.compensate(&q, None);
        assert_eq!(o.q, q);
        assert_eq!(o.correction, 0.0);
        assert_eq!(o.verdict.status, Status::Ok);
    }
}

/// `(I − J⁺J)·v` relative to `‖v‖`: the part of the way from the seed in the null space.
fn null_part(jac: &[f64], m: usize, n: usize, v: &[f64]) -> f64 {
    let j = nalgebra::DMatrix::from_row_slice(m, n, jac);
    let pinv = j.clone().pseudo_inverse(1e-12).unwrap();
    let v = nalgebra::DVector::from_column_slice(v);
    let null = &v - &pinv * (&j * &v);
    null.norm() / v.norm()
}

#[test]
fn a_redundant_arm_keeps_its_self_motion_and_branch() {
    for (text, m) in [(IIWA_POSE, 6), (IIWA_POINT, 3)] {
        let s = spec(text);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let cal = perturbed(&s, 2e-3, &mut rng);
        let c = Compensator::new(&s, cal.clone(), ParamCovariance::None).unwrap();
        let arm = c.arm(super::CALIBRATED);
        let kind = if m == 6 {
            TargetKind::Pose
        } else {
            TargetKind::Position
        };
        let mut regular = 0;
        for _ in 0..60 {
            let q = joints(&s, 0.7, &mut rng);
            let t = c.nominal_tool(&q);
            let goal = Goal {
                x: t.x,
                rot: (m == 6).then_some(t.rot),
            };
            let mut e = [0.0; 6];
            let mut jac = vec![0.0; m * 7];
            // Seeds well away from a singularity (a near-singular one may rightly fail).
            arm.error(
                &q,
                &goal,
                kind,
                &mut e[..m],
                Some(&mut jac),
                &mut task::Scratch::new(7),
            );
            if verdict::sigma_min(&jac, m, 7) < 0.05 {
                continue;
            }
            regular += 1;
            let o = c.compensate(&q, None);
            assert_eq!(o.verdict.status, Status::Ok, "{}", o.verdict.message);
            arm.error(
                &o.q,
                &goal,
                kind,
                &mut e[..m],
                Some(&mut jac),
                &mut task::Scratch::new(7),
            );
            assert!(dist(&e[..m], &[0.0; 6][..m]) < 1e-10);
            let way: Vec<f64> = o.q.iter().zip(&q).map(|(a, b)| a - b).collect();
            // The least-norm solution: no null-space part in the way from the seed.
            assert!(null_part(&jac, m, 7, &way) < 1e-6, "{m}: null part");
            assert!(o.correction < 0.3, "{q:?} {o:?}");
        }
        assert!(regular >= 20, "{m}: {regular} regular seeds");
    }
}

/// Large corrections (a centimetre-off calibration) on tasks with self-motion (a 6R arm's tip
/// position, a 7R arm's): every row that ends `ok` is the least-norm solution from its seed,
/// no null-space part left in the way at `q′` (a solve that wandered along the self-motion is
/// settled back), and almost every target is reached.
#[test]
fn large_corrections_keep_the_seed_s_self_motion() {
    for text in [PUMA_TIP, IIWA_POINT] {
        let s = spec(text);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let cal = perturbed(&s, 1e-2, &mut rng);
        let c = Compensator::new(&s, cal.clone(), ParamCovariance::None).unwrap();
        let n = s.joints.len();
        let arm = c.arm(super::CALIBRATED);
        let (mut ok, mut total) = (0, 0);
        for _ in 0..300 {
            let q = joints(&s, 0.9, &mut rng);
            let o = c.compensate(&q, None);
            total += 1;
            if o.verdict.status != Status::Ok {
                continue;
            }
            ok += 1;
            let t = c.intended_tool(&q);
            let goal = Goal { x: t.x, rot: None };
            let (mut e, mut jac) = ([0.0; 3], vec![0.0; 3 * n]);
            let mut scratch = task::Scratch::new(n);
            arm.error(
                &o.q,
                &goal,
                TargetKind::Position,
                &mut e,
                Some(&mut jac),
                &mut scratch,
            );
            assert!(dist(&e, &[0.0; 3]) < 1e-10, "{o:?}");
            let way: Vec<f64> = o.q.iter().zip(&q).map(|(a, b)| a - b).collect();
            let null = null_part(&jac, 3, n, &way) * dist(&way, &vec![0.0; n]);
            assert!(null < 1e-5, "null-space part {null:e} at {q:?}: {o:?}");
        }
        assert!(ok * 100 >= total * 90, "{}: {ok} of {total} ok", s.name);
    }
}

#[test]
fn a_joint_pushed_past_its_limit_is_named() {
    let s = spec(PUMA);
    let mut cal: Vec<f64> = s
        .estimated_params()
        .iter()
        .map(|p| p.nominal.to_f64())
        .collect();
    // th1 one milliradian up: joint 1 must turn 1 mrad further, past its upper limit.
    let th1 = s
        .estimated_params()
        .iter()
        .position(|p| p.name == "th1")
        .unwrap();
    cal[th1] += 1e-3;
    let c = Compensator::new(&s, cal, ParamCovariance::None).unwrap();
    let q = [2.7925, 0.5, -1.0, 0.3, 0.7, 0.2];
    let o = c.compensate(&q, None);
    assert_eq!(o.verdict.status, Status::Limit, "{}", o.verdict.message);
    assert!(o.verdict.message.contains("joint 1"));
    assert!((o.q[0] - 2.7935).abs() < 1e-9);
}

#[test]
fn a_nearly_straight_arm_is_singular_and_an_unreachable_target_diverges() {
    let s = spec(PLANAR);
    // The calibrated arm 0.1 mm shorter per link: reach 0.6998 m against 0.7 m.
    let cal = vec![0.3999, 0.2999, 0.0, 0.0];
    let c = Compensator::new(&s, cal, ParamCovariance::None).unwrap();
    let bent = c.compensate(&[0.3, 0.9], None);
    assert_eq!(bent.verdict.status, Status::Ok, "{}", bent.verdict.message);
    // At 0.05 rad the elbow must fold to 0.013 rad: a 0.2 mm error, a 0.04 rad correction.
    let straight = c.compensate(&[0.3, 0.05], None);
    assert_eq!(
        straight.verdict.status,
        Status::Singular,
        "{}",
        straight.verdict.message
    );
    assert!(straight.verdict.message.contains("σ_min"));
    assert!(straight.residual < 1e-10 && straight.q[1] > 0.0);
    let out = c.compensate(&[0.3, 0.0], None);
    assert_eq!(
        out.verdict.status,
        Status::Diverged,
        "{}",
        out.verdict.message
    );
}

#[test]
fn the_elbow_keeps_its_side() {
    let s = spec(PLANAR);
    let c = Compensator::new(&s, vec![0.4, 0.3, 0.0, 0.0], ParamCovariance::None).unwrap();
    // The elbow-down arm's tip, solved from an elbow-up seed: the elbow-up solution.
    let target = c.nominal_tool(&[0.3, -0.05]);
    let goal = Goal {
        x: target.x,
        rot: None,
    };
    let o = c.compensate(&[0.3, 0.05], Some((goal, TargetKind::Position)));
    assert_eq!(o.verdict.status, Status::Ok, "{}", o.verdict.message);
    assert!((o.q[1] - 0.05).abs() < 1e-9, "{:?}", o.q);
}

#[test]
fn cartesian_targets_are_read_and_reached() {
    let s = spec(PUMA);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let cal = perturbed(&s, 2e-3, &mut rng);
    let c = Compensator::new(&s, cal, ParamCovariance::None).unwrap();
    let q = [0.1, 0.5, -1.0, 0.3, 0.7, 0.2];
    // A Cartesian target lives in the measurement frame, as a joint target's goal does.
    let t = c.intended_tool(&q);
    let quat = crate::model::rotation::quaternion_from_matrix(&t.rot);
    let layout = DataLayout::of_spec(&s);
    let row = |cols: &[f64]| {
        cols.iter()
            .map(|v| format!("{v:?}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let pose_text = format!(
        "# targets\nq1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,_note\n{},{},{},7\n",
        row(&q),
        row(&t.x),
        row(&quat)
    );
    let targets = Targets::from_csv_text(&pose_text, Some("t.csv"), &layout, true).unwrap();
    assert_eq!(targets.form, TargetForm::Pose);
    let out = c.compensate_all(&targets);
    let joint = c.compensate(&q, None);
    assert!(dist(&out[0].q, &joint.q) < 1e-12);
    let pos_text = format!("x,y,z,q1,q2,q3,q4,q5,q6\n{},{}\n", row(&t.x), row(&q));
    let targets = Targets::from_csv_text(&pos_text, None, &layout, true).unwrap();
    assert_eq!(targets.form, TargetForm::Position);
    let o = &c.compensate_all(&targets)[0];
    assert!(o.residual < 1e-10 && o.verdict.status == Status::Ok);
}

#[test]
fn bad_targets_files_name_line_and_column() {
    let s = spec(IIWA_POINT);
    let layout = DataLayout::of_spec(&s);
    let text = "q1,q2,q3,q4,q5,q6,q7,x,y,z\n0,0,0,0,0,0,0,0.1,0.2,0.3\n0,0,0,0,0,0,0,0.1,,0.3\n";
    let e = Targets::from_csv_text(text, Some("t.csv"), &layout, false).unwrap_err();
    assert!(
        e.to_string().contains("t.csv:3") && e.to_string().contains('y'),
        "{e}"
    );
    let text = "q1,q2,q3,q4,q5,q6,q7,x,y,z,qw,qx,qy,qz\n";
    let e = Targets::from_csv_text(text, Some("t.csv"), &layout, false).unwrap_err();
    assert!(
        e.to_string().contains("qw") && e.to_string().contains("point"),
        "{e}"
    );
    let text = "q1,q2,q3,q4,q5,q6,q7\n0,0,0,nan,0,0,0\n";
    let e = Targets::from_csv_text(text, Some("t.csv"), &layout, false).unwrap_err();
    assert!(
        e.to_string().contains("t.csv:2") && e.to_string().contains("q4"),
        "{e}"
    );
}

#[test]
fn many_targets_in_parallel_keep_their_order() {
    let s = spec(IIWA_POINT);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let cal = perturbed(&s, 1e-3, &mut rng);
    let std = vec![Some(1e-5); cal.len()];
    let c = Compensator::new(&s, cal, ParamCovariance::from_std(&std)).unwrap();
    let mut text = String::from("q1,q2,q3,q4,q5,q6,q7\n");
    let mut qs = Vec::new();
    for _ in 0..500 {
        let q = joints(&s, 0.7, &mut rng);
        text += &q
            .iter()
            .map(|v| format!("{v:?}"))
            .collect::<Vec<_>>()
            .join(",");
        text.push('\n');
        qs.push(q);
    }
    let targets = Targets::from_csv_text(&text, None, &DataLayout::of_spec(&s), false).unwrap();
    let all = c.compensate_all(&targets);
    for (o, q) in all.iter().zip(&qs) {
        assert_eq!(o, &c.compensate(q, None));
        assert!(o.sigma > 0.0 && o.sigma < 1e-4);
    }
    let sum = Summary::new(&all, |l| targets.poses.line.at(l));
    assert_eq!(sum.targets, 500);
    assert_eq!(sum.counts.iter().sum::<usize>(), 500);
    assert!(sum.to_json()["counts"]["ok"].as_u64().is_some());
}
