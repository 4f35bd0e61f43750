//! Full-pose measurements (`measured_pose`): the data reader's two orientation encodings and
//! its refusals, recovery of a known arm from noise-free poses in both encodings, and the
//! variance-component estimate of the noise levels when the spec does not state them.

use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::data::{DataLayout, Poses};
use lincal_core::error::ErrorClass;
use lincal_core::model::rotation;
use lincal_core::model::CalibModel;
use lincal_core::simulate::{simulate, Noise};
use lincal_core::spec::{self, Spec};
use lincal_core::symbolic::SymbolicModel;

/// A 6R arm (PUMA-like, standard DH) with its tool frame's pose measured in an unknown
/// tracker frame; `{noise}` is the body of `measured_pose`.
fn arm(noise: &str) -> (Spec, SymbolicModel) {
    let text = format!(
        "name: pose6\ndim: 3\njoints:\n  \
         - {{type: revolute, a: a1, alpha: pi/2, d: d1, home: th1, limits: [-2.7, 2.7]}}\n  \
         - {{type: revolute, a: a2, alpha: al2, d: d2, home: th2, limits: [-0.7, 3.9]}}\n  \
         - {{type: revolute, a: a3, alpha: -pi/2, d: d3, home: th3, limits: [-3.9, 0.7]}}\n  \
         - {{type: revolute, a: a4, alpha: pi/2, d: d4, home: th4, limits: [-1.9, 2.9]}}\n  \
         - {{type: revolute, a: a5, alpha: -pi/2, d: d5, home: th5, limits: [-1.7, 1.7]}}\n  \
         - {{type: revolute, a: 0, alpha: 0, d: 0, home: 0, limits: [-4.6, 4.6]}}\n\
         tool: {{x: tx, y: ty, z: tz, roll: tr, pitch: tp, yaw: tw}}\n\
         base: {{x: bx, y: by, z: bz, roll: br, pitch: bp, yaw: bw}}\n\
         params:\n  a1: {{nominal: 0}}\n  d1: {{nominal: 0}}\n  th1: {{nominal: 0}}\n  \
         a2: {{nominal: 0.4318}}\n  al2: {{nominal: 0}}\n  d2: {{nominal: 0}}\n  \
         th2: {{nominal: 0}}\n  a3: {{nominal: 0.0203}}\n  d3: {{nominal: 0.15005}}\n  \
         th3: {{nominal: 0}}\n  a4: {{nominal: 0}}\n  d4: {{nominal: 0.4318}}\n  \
         th4: {{nominal: 0}}\n  a5: {{nominal: 0}}\n  d5: {{nominal: 0}}\n  \
         th5: {{nominal: 0}}\n  tx: {{nominal: 0}}\n  ty: {{nominal: 0}}\n  \
         tz: {{nominal: 0.1}}\n  tr: {{nominal: 0}}\n  tp: {{nominal: 0}}\n  \
         tw: {{nominal: 0}}\n  bx: {{nominal: -1.5}}\n  by: {{nominal: 0.2}}\n  \
         bz: {{nominal: -0.3}}\n  br: {{nominal: 0}}\n  bp: {{nominal: 0}}\n  \
         bw: {{nominal: 0.5}}\n\
         constraint:\n  measured_pose: {noise}\n"
    );
    let spec = spec::from_yaml_str(&text, Some("pose6.yaml")).expect("the test spec loads");
    let model = SymbolicModel::for_fitting(&spec, lincal_core::symbolic::DEFAULT_MAX_TERMS)
        .expect("the model builds");
    (spec, model)
}

/// The poses as CSV text, the orientation as a quaternion or a rotation vector.
fn csv(poses: &Poses, rotvec: bool) -> String {
    let mut out = String::from("q1,q2,q3,q4,q5,q6,x,y,z,");
    out.push_str(if rotvec {
        "rx,ry,rz\n"
    } else {
        "qw,qx,qy,qz\n"
    });
    let m = poses.measured.as_ref().expect("measured rows");
    for l in 0..poses.len() {
        let row = &m[l];
        let r: &[f64; 9] = row[3..12].try_into().expect("12 values");
        let o: Vec<f64> = if rotvec {
            rotation::rotation_vector(r).to_vec()
        } else {
            rotation::quaternion_from_matrix(r).to_vec()
        };
        let cells: Vec<String> = poses.q[l]
            .iter()
            .chain(&row[..3])
            .chain(&o)
            .map(|v| format!("{v:?}"))
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

fn read(spec: &Spec, text: &str) -> lincal_core::error::Result<Poses> {
    Poses::from_csv_reader_with(
        text.as_bytes(),
        Some("pose.csv"),
        &DataLayout::of_spec(spec),
    )
}

/// The largest position (m) and orientation (rad) difference of the tool frames of `a` and
/// `b` at `qs`.
fn frame_gap(model: &dyn CalibModel, qs: &[Vec<f64>], a: &[f64], b: &[f64]) -> (f64, f64) {
    let (mut dx, mut da) = (0.0f64, 0.0f64);
    for q in qs {
        let (mut xa, mut ra, mut xb, mut rb) = ([0.0; 3], [0.0; 9], [0.0; 3], [0.0; 9]);
        model.tool_pose(q, a, &mut xa, &mut ra);
        model.tool_pose(q, b, &mut xb, &mut rb);
        let d =
            ((xa[0] - xb[0]).powi(2) + (xa[1] - xb[1]).powi(2) + (xa[2] - xb[2]).powi(2)).sqrt();
        dx = dx.max(d);
        da = da.max(rotation::angle(&rotation::transpose_times(&ra, &rb)));
    }
    (dx, da)
}

fn estimated(est: &lincal_core::calibrate::estimate::Estimate) -> Vec<f64> {
    est.params
        .iter()
        .filter(|p| !p.known)
        .map(|p| p.value)
        .collect()
}

#[test]
fn both_encodings_read_to_the_same_rotation() {
    let (spec, _) = arm("{}");
    let phi = [0.3, -1.2, 2.0];
    let r = rotation::matrix_from_rotation_vector(phi);
    let q = rotation::quaternion_from_matrix(&r);
    let qt = format!(
        "q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n0,0,0,0,0,0,1,2,3,{},{},{},{}\n",
        q[0], q[1], q[2], q[3]
    );
    let rv = format!(
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n0,0,0,0,0,0,1,2,3,{},{},{}\n",
        phi[0], phi[1], phi[2]
    );
    let (a, b) = (read(&spec, &qt).unwrap(), read(&spec, &rv).unwrap());
    let (ma, mb) = (a.measured.unwrap(), b.measured.unwrap());
    assert_eq!(ma[0].len(), 12);
    for k in 0..12 {
        assert!((ma[0][k] - mb[0][k]).abs() < 1e-14, "{k}");
    }
    for k in 0..9 {
        assert!((ma[0][3 + k] - r[k]).abs() < 1e-14);
    }
}

#[test]
fn bad_orientations_are_refused_naming_line_and_column() {
    let (spec, _) = arm("{}");
    let head = "q1,q2,q3,q4,q5,q6,x,y,z";
    let refused = |text: String, want: &[&str]| {
        let e = read(&spec, &text).expect_err("must be refused");
        assert_eq!(e.class(), ErrorClass::Input, "{e}");
        let s = e.to_string();
        for w in want {
            assert!(s.contains(w), "`{w}` not in: {s}");
        }
    };
    // Not a unit quaternion (beyond the tolerance).
    refused(
        format!("{head},qw,qx,qy,qz\n0,0,0,0,0,0,1,2,3,1,0,0,0\n0,0,0,0,0,0,1,2,3,1,0.1,0,0\n"),
        &["pose.csv:3", "qw", "norm"],
    );
    // Within the tolerance it is normalised.
    assert!(read(
        &spec,
        &format!("{head},qw,qx,qy,qz\n0,0,0,0,0,0,1,2,3,1.0002,0,0,0\n")
    )
    .is_ok());
    // Both forms at once.
    refused(
        format!("{head},qw,qx,qy,qz,rx,ry,rz\n0,0,0,0,0,0,1,2,3,1,0,0,0,0,0,0\n"),
        &["pose.csv:1", "both", "rx"],
    );
    // A missing column of a form, no orientation at all.
    refused(
        format!("{head},qw,qx,qy\n0,0,0,0,0,0,1,2,3,1,0,0\n"),
        &["qz", "missing"],
    );
    refused(
        format!("{head}\n0,0,0,0,0,0,1,2,3\n"),
        &["orientation", "qw"],
    );
    // NaN and an empty cell, named by line and column.
    refused(
        format!("{head},rx,ry,rz\n0,0,0,0,0,0,1,2,3,0,NaN,0\n"),
        &["pose.csv:2", "ry"],
    );
    refused(
        format!("{head},rx,ry,rz\n0,0,0,0,0,0,1,2,3,0,,0\n"),
        &["pose.csv:2", "ry", "empty"],
    );
}

#[test]
fn noise_free_poses_recover_the_arm_in_both_encodings() {
    let (spec, model) = arm("{position_std: 2.0e-5, orientation_std: 5.0e-5}");
    let sim = simulate(&model, &spec, 60, 5, None, Noise::default()).unwrap();
    let fresh = simulate(&model, &spec, 200, 99, Some(&sim.truth), Noise::default()).unwrap();
    for rotvec in [false, true] {
        let poses = read(&spec, &csv(&sim.poses, rotvec)).unwrap();
        let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
        let p = estimated(&est);
        let (dx, da) = frame_gap(&model, &fresh.true_q, &p, &sim.truth);
        assert!(
            dx < 1e-9 && da < 1e-9,
            "rotvec {rotvec}: {dx:e} m, {da:e} rad"
        );
        assert!(est.residual_rms < 1e-9, "{}", est.residual_rms);
        assert!(est.orientation_rms.is_some_and(|o| o < 1e-9));
        // Every parameter identifiable on its own comes back.
        for (j, pe) in est.params.iter().filter(|q| !q.known).enumerate() {
            if pe.identifiable {
                assert!(
                    (pe.value - sim.truth[j]).abs() < 1e-9,
                    "{}: {} vs {}",
                    pe.name,
                    pe.value,
                    sim.truth[j]
                );
            }
        }
    }
}

#[test]
fn unstated_noise_levels_are_estimated_by_variance_components() {
    let (spec, model) = arm("{}");
    let noise = Noise {
        measure: 2e-5,
        orientation: 5e-5,
        ..Noise::default()
    };
    let sim = simulate(&model, &spec, 300, 8, None, noise).unwrap();
    let est = calibrate_spec(&model, &spec, &sim.poses, CalibrateOptions::default()).unwrap();
    let n = est.pose_noise.as_ref().expect("the pose noise is reported");
    assert_eq!(n.estimated, vec!["position", "orientation"]);
    assert!(n.rounds >= 2, "{n:?}");
    assert!((n.position_std / 2e-5 - 1.0).abs() < 0.1, "{n:?}");
    assert!((n.orientation_std / 5e-5 - 1.0).abs() < 0.1, "{n:?}");
    assert!((n.weight - n.position_std / n.orientation_std).abs() < 1e-12 * n.weight);
    // The fit is as good as with the levels stated.
    let (spec2, model2) = arm("{position_std: 2.0e-5, orientation_std: 5.0e-5}");
    let stated = calibrate_spec(&model2, &spec2, &sim.poses, CalibrateOptions::default()).unwrap();
    let fresh = simulate(&model, &spec, 200, 99, Some(&sim.truth), Noise::default()).unwrap();
    let (ex, ea) = frame_gap(&model, &fresh.true_q, &estimated(&est), &sim.truth);
    let (sx, sa) = frame_gap(&model, &fresh.true_q, &estimated(&stated), &sim.truth);
    assert!(
        ex < 1.2 * sx + 1e-6 && ea < 1.2 * sa + 1e-6,
        "{ex} {ea} vs {sx} {sa}"
    );
    // The residuals are about the noise: 3 components of 20 µm, of 50 µrad.
    let want_x = 2e-5 * 3f64.sqrt();
    assert!(
        (est.residual_rms / want_x - 1.0).abs() < 0.15,
        "{}",
        est.residual_rms
    );
    let o = est.orientation_rms.unwrap();
    assert!((o / (5e-5 * 3f64.sqrt()) - 1.0).abs() < 0.15, "{o}");
}

#[test]
fn only_the_base_redundancy_is_a_gauge() {
    // 28 parameters. A full pose sees every one of them except along the two directions
    // that joint 1's `d1` and `th1` share with the tracker frame (a shift along and a turn
    // about z0 of the base: Everett and Hollerbach's base redundancy); joint 6 has no
    // parameters, so the tool frame has no redundancy with it.
    let (_, model) = arm("{}");
    assert_eq!(model.param_count(), 28);
    assert_eq!(model.identifiable_count(), 26);
}
