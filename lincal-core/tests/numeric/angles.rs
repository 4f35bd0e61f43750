//! Data as it comes: revolute readings in degrees (`Angles`), readings that look like degrees
//! refused, and joint columns named by the spec's URDF joint names.

use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::data::{Angles, DataLayout, Poses};
use lincal_core::error::ErrorClass;
use lincal_core::model::CalibModel;
use lincal_core::simulate::{self, Noise};
use lincal_core::spec::{self, Spec};
use lincal_core::symbolic::SymbolicModel;

/// A spatial R-P-R arm with measured tips: joint 1 limited to [-7, 7] (beyond a full turn),
/// joint 2 prismatic (metres), joint 3 without limits.
const RPR: &str = "
name: rpr
dim: 3
joints:
  - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1, limits: [-7, 7]}
  - {type: prismatic, a: a2, alpha: -pi/2, offset: o2}
  - {type: revolute, a: a3, home: th3}
tool: [0, 0, t3]
params:
  a1: {nominal: 0.1}
  d1: {nominal: 0.3}
  th1: {nominal: 0.0}
  a2: {nominal: 0.05}
  o2: {nominal: 0.2}
  a3: {nominal: 0.25}
  th3: {nominal: 0.0}
  t3: {nominal: 0.04}
constraint:
  measured: {}
";

/// The URDF joint names of the test's `urdf:` record, in spec order.
const NAMES: [&str; 3] = ["shoulder", "slide", "wrist"];

fn rpr() -> Spec {
    spec::from_yaml_str(RPR, Some("rpr.yaml")).expect("the test spec loads")
}

/// The spec's layout, read with `angles`, the columns also named by [`NAMES`].
fn layout(spec: &Spec, angles: Angles) -> DataLayout {
    let mut l = DataLayout::of_spec(spec);
    l.angles = angles;
    l.joint_names = NAMES.iter().map(|s| (*s).to_string()).collect();
    l
}

fn read(text: &str, layout: &DataLayout) -> lincal_core::error::Result<Poses> {
    Poses::from_csv_reader_with(text.as_bytes(), Some("data.csv"), layout)
}

fn refused(text: &str, layout: &DataLayout) -> String {
    let e = read(text, layout).expect_err("must be refused");
    assert_eq!(e.class(), ErrorClass::Input, "{e}");
    e.to_string()
}

/// `poses` as CSV under `header` (its joint columns in spec order, then x, y, z), the
/// revolute readings multiplied by `scale` (prismatic readings and tips as they are).
fn csv(poses: &Poses, header: &str, scale: f64) -> String {
    let mut s = format!("# a comment line\n{header}\n");
    for l in 0..poses.len() {
        let q = &poses.q[l];
        let m = &poses.measured.as_ref().expect("measured tips")[l];
        let cells: Vec<String> = [q[0] * scale, q[1], q[2] * scale]
            .iter()
            .chain(m)
            .map(|v| format!("{v:?}"))
            .collect();
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

#[test]
fn degrees_read_with_deg_are_the_radians_and_fit_the_same() {
    let spec = rpr();
    let model = SymbolicModel::from_spec(&spec).expect("the model builds");
    let noise = Noise {
        measure: 1e-4,
        ..Noise::default()
    };
    let sim = simulate::simulate(&model, &spec, 60, 5, None, noise).expect("simulates");
    let rad = csv(&sim.poses, "q1,q2,q3,x,y,z", 1.0);
    let deg = csv(
        &sim.poses,
        "shoulder,slide,wrist,x,y,z",
        180.0 / std::f64::consts::PI,
    );
    let a = read(&rad, &layout(&spec, Angles::Rad)).expect("radians read");
    let b = read(&deg, &layout(&spec, Angles::Deg)).expect("degrees read");
    assert_eq!(a.q, sim.poses.q, "the radian file is the simulation");
    assert_eq!(a.line, b.line);
    assert_eq!(a.measured, b.measured, "tips are never converted");
    let mut beyond_turn = false;
    for l in 0..a.len() {
        assert_eq!(
            a.q[l][1], b.q[l][1],
            "pose {l}: the prismatic reading is untouched"
        );
        for i in [0, 2] {
            let (x, y) = (a.q[l][i], b.q[l][i]);
            assert!(
                (x - y).abs() <= 4.0 * f64::EPSILON * x.abs(),
                "pose {l} q{}: {x} {y}",
                i + 1
            );
        }
        beyond_turn |= a.q[l][0].abs() > std::f64::consts::TAU;
    }
    assert!(
        beyond_turn,
        "the limits [-7, 7] let some readings pass a full turn"
    );
    // The same readings in degrees taken as radians are a different data set.
    let wrong = read(&deg, &layout(&spec, Angles::Rad)).expect("read as radians");
    assert!((wrong.q[0][2] - a.q[0][2]).abs() > 1e-3);
    // Fitted: the same parameters, at the truth within its standard deviations.
    let opts = CalibrateOptions::default();
    let ea = calibrate_spec(&model, &spec, &a, opts).expect("radians fit");
    let eb = calibrate_spec(&model, &spec, &b, opts).expect("degrees fit");
    for (pa, pb) in ea.params.iter().zip(&eb.params) {
        assert_eq!(pa.name, pb.name);
        assert!(
            (pa.value - pb.value).abs() <= 1e-9 * (1.0 + pa.value.abs()),
            "{}: {} vs {}\n{:?}\n{:?}\n{:?}",
            pa.name,
            pa.value,
            pb.value,
            ea,
            eb,
            sim.truth
        );
    }
    let mut checked = 0;
    for (k, t) in sim.truth.iter().enumerate() {
        let name = model.param_name(k);
        let p = eb
            .params
            .iter()
            .find(|p| p.name == name)
            .expect("estimated");
        // Identifiable on their own: the others are held or absorb a held one's gauge.
        if let (Some(std), true) = (p.std, p.identifiable) {
            assert!(
                (p.value - t).abs() < 6.0 * std + 1e-12,
                "{name}: {} vs {t} (std {std})",
                p.value
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 4,
        "{checked} parameters checked against the truth"
    );
}

#[test]
fn auto_refuses_degrees_naming_file_line_and_column() {
    let spec = rpr();
    let auto = layout(&spec, Angles::Auto);
    // Joint 3 (no limits): 45 degrees is 45 "radians", beyond a full turn.
    let text = "# logged in degrees\nq1,slide,wrist,x,y,z\n0.5,0.1,0.2,0,0,0\n\n1.0,0.2,45,0,0,0\n";
    let msg = refused(text, &auto);
    assert!(msg.contains("data.csv:5"), "{msg}");
    assert!(msg.contains("`wrist`"), "{msg}");
    assert!(
        msg.contains(
            "these look like degrees: pass --angles deg to convert, or --angles rad to take \
             them as radians"
        ),
        "{msg}"
    );
    // Radians taken as they are; degrees converted.
    let p = read(text, &layout(&spec, Angles::Rad)).expect("radians");
    assert_eq!(p.q[1][2], 45.0);
    let p = read(text, &layout(&spec, Angles::Deg)).expect("degrees");
    assert!((p.q[1][2] - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    assert_eq!(p.q[1][1], 0.2);
    // The first such reading is named, whatever comes after; a negative one too.
    let msg = refused("q1,q2,q3,x,y,z\n0,0,-7,0,0,0\n90,0,0,0,0,0\n", &auto);
    assert!(msg.contains("data.csv:2") && msg.contains("`q3`"), "{msg}");
    // `--columns` files are refused the same way.
    let mut headerless = auto.clone();
    headerless.columns = Some(
        ["shoulder", "q2", "q3", "x", "y", "z"]
            .map(String::from)
            .to_vec(),
    );
    let msg = refused("1,0,0,0,0,0\n-30,0,0,0,0,0\n", &headerless);
    assert!(
        msg.contains("data.csv:2") && msg.contains("`shoulder`"),
        "{msg}"
    );
}

#[test]
fn auto_takes_readings_the_limits_allow_and_never_checks_metres() {
    let spec = rpr();
    let auto = layout(&spec, Angles::Auto);
    // Joint 1 is limited to [-7, 7]: 6.9 rad is beyond a full turn but within them.
    let p = read("q1,q2,q3,x,y,z\n6.9,0,0,0,0,0\n-6.5,0,1,0,0,0\n", &auto).expect("within limits");
    assert_eq!((p.q[0][0], p.q[1][0]), (6.9, -6.5));
    let msg = refused("q1,q2,q3,x,y,z\n7.5,0,0,0,0,0\n", &auto);
    assert!(msg.contains("data.csv:2") && msg.contains("`q1`"), "{msg}");
    assert!(msg.contains("[-7, 7]"), "{msg}");
    // Joint 3 has no limits: 6.9 there is refused.
    let msg = refused("q1,q2,q3,x,y,z\n0,0,6.9,0,0,0\n", &auto);
    assert!(msg.contains("`q3`"), "{msg}");
    // A full turn exactly is radians; prismatic readings and tips are never angles.
    let tau = std::f64::consts::TAU;
    let text = format!("q1,q2,q3,x,y,z\n0,250,{tau:?},90,-400,12\n");
    let p = read(&text, &auto).expect("metres and a full turn");
    assert_eq!(&p.q[0], &[0.0, 250.0, tau]);
    assert_eq!(&p.measured.expect("tips")[0], &[90.0, -400.0, 12.0]);
}

#[test]
fn urdf_joint_names_head_columns_in_any_order() {
    let spec = rpr();
    let l = layout(&spec, Angles::Rad);
    let named = read("z,wrist,_t,x,slide,shoulder,y\n3,0.3,9,1,0.2,0.1,2\n", &l).expect("names");
    let usual = read("q1,q2,q3,x,y,z\n0.1,0.2,0.3,1,2,3\n", &l).expect("q1..qn");
    assert_eq!(named.q, usual.q);
    assert_eq!(named.measured, usual.measured);
    // The two forms may be mixed across joints.
    let mixed = read("q1,slide,q3,x,y,z\n0.1,0.2,0.3,1,2,3\n", &l).expect("mixed joints");
    assert_eq!(mixed.q, usual.q);
    // Headerless files name their columns the same way.
    let mut headerless = l.clone();
    headerless.columns = Some(
        ["wrist", "slide", "shoulder", "x", "y", "z"]
            .map(String::from)
            .to_vec(),
    );
    let p = read("0.3,0.2,0.1,1,2,3\n", &headerless).expect("--columns by URDF names");
    assert_eq!(p.q, usual.q);
}

#[test]
fn a_joint_named_both_ways_or_an_unknown_name_is_refused() {
    let spec = rpr();
    let l = layout(&spec, Angles::Rad);
    let msg = refused("q1,q2,q3,slide,x,y,z\n0,0,0,0,1,2,3\n", &l);
    assert!(
        msg.contains("data.csv:1") && msg.contains("`slide`"),
        "{msg}"
    );
    assert!(msg.contains("same joint q2"), "{msg}");
    let msg = refused("shoulder,slid,wrist,x,y,z\n0,0,0,1,2,3\n", &l);
    assert!(msg.contains("unknown column `slid`"), "{msg}");
    assert!(
        msg.contains("q1 or shoulder, q2 or slide, q3 or wrist, x, y, z"),
        "the accepted names are listed: {msg}"
    );
    assert!(msg.contains("missing column `q2` (or `slide`)"), "{msg}");
    let msg = refused("shoulder,shoulder,q2,q3,x,y,z\n0,0,0,0,1,2,3\n", &l);
    assert!(msg.contains("duplicate column `shoulder`"), "{msg}");
    let mut headerless = l.clone();
    headerless.columns = Some(
        ["q1", "shoulder", "q2", "q3", "x", "y", "z"]
            .map(String::from)
            .to_vec(),
    );
    let msg = refused("0,0,0,0,1,2,3\n", &headerless);
    assert!(
        msg.contains("--columns") && msg.contains("same joint q1"),
        "{msg}"
    );
    // Without the record's names, URDF names are unknown columns.
    let plain = DataLayout::of_spec(&spec);
    let msg = refused("shoulder,slide,wrist,x,y,z\n0,0,0,1,2,3\n", &plain);
    assert!(msg.contains("unknown column `shoulder`"), "{msg}");
}

#[test]
fn a_urdf_name_that_is_another_columns_name_keeps_its_usual_meaning() {
    let spec = rpr();
    let mut l = layout(&spec, Angles::Rad);
    // Joint 1's URDF name is `q2` and joint 3's is `x`: both stay what they usually are.
    l.joint_names = ["q2", "slide", "x"].map(String::from).to_vec();
    let p = read("q1,q2,q3,x,y,z\n0.1,0.2,0.3,1,2,3\n", &l).expect("usual names");
    assert_eq!(&p.q[0], &[0.1, 0.2, 0.3]);
    assert_eq!(&p.measured.expect("tips")[0], &[1.0, 2.0, 3.0]);
    let msg = refused("q1,q2,slide,q3,x,y,z\n0,0,0,0,1,2,3\n", &l);
    assert!(msg.contains("same joint q2"), "{msg}");
}
