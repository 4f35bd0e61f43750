//! Spec builders for the engine's own tests (no YAML needed).
#![cfg(test)]

use crate::spec::{Constraint, Convention, Exact, Joint, JointKind, Param, ParamRole, Slot, Spec};

pub fn p(name: &str) -> Slot {
    Slot::Param(name.into())
}

pub fn num(x: &str) -> Slot {
    Slot::Const(Exact::parse(x).unwrap())
}

pub fn param(name: &str, nominal: f64, role: ParamRole) -> Param {
    Param {
        name: name.into(),
        nominal: Exact::from_f64(nominal).unwrap(),
        known: false,
        role,
    }
}

pub fn revolute(a: Slot, alpha: Slot, d: Slot, home: Slot) -> Joint {
    Joint {
        kind: JointKind::Revolute,
        a,
        alpha,
        beta: Slot::zero(),
        d,
        home,
        theta: Slot::zero(),
        offset: Slot::zero(),
        limits: None,
        origin: crate::spec::Base::zero(),
    }
}

/// Planar n-link arm (a_i, th_i unknown) on an unknown line b.
pub fn planar_line(n: usize) -> Spec {
    let mut joints = Vec::new();
    let mut params = Vec::new();
    for i in 1..=n {
        joints.push(revolute(
            p(&format!("a{i}")),
            Slot::zero(),
            Slot::zero(),
            p(&format!("th{i}")),
        ));
        params.push(param(
            &format!("a{i}"),
            0.3 + 0.05 * i as f64,
            ParamRole::Length,
        ));
        params.push(param(&format!("th{i}"), 0.0, ParamRole::Angle));
    }
    params.push(param("b1", -1.7, ParamRole::Length));
    params.push(param("b2", 0.6, ParamRole::Length));
    Spec {
        name: format!("planar{n}_line"),
        description: None,
        dim: 2,
        convention: Convention::Dh,
        joints,
        tool: vec![Slot::zero(), Slot::zero()],
        tool_rotation: None,
        base: None,
        params,
        constraints: vec![Constraint::Line2 {
            b: [p("b1"), p("b2")],
        }],
        constraint_list: false,
        relations: Vec::new(),
    }
}

/// Planar n-link arm pinned at an unknown point.
pub fn planar_point(n: usize) -> Spec {
    let mut s = planar_line(n);
    s.params.retain(|x| x.name != "b1" && x.name != "b2");
    s.params.push(param("px", 0.3, ParamRole::Length));
    s.params.push(param("py", 0.2, ParamRole::Length));
    s.constraints = vec![Constraint::Point {
        p: vec![p("px"), p("py")],
    }];
    s
}

/// PUMA 560 (standard DH), all a, d, home unknown, tool known, with the given constraint
/// and extra params.
pub fn puma(constraint: Constraint, extra: Vec<Param>) -> Spec {
    let alpha = ["pi/2", "0", "-pi/2", "pi/2", "-pi/2", "0"];
    let a = [0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0];
    let d = [0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0];
    let mut joints = Vec::new();
    let mut params = Vec::new();
    for i in 0..6 {
        let k = i + 1;
        joints.push(revolute(
            p(&format!("a{k}")),
            num(alpha[i]),
            p(&format!("d{k}")),
            p(&format!("th{k}")),
        ));
        params.push(param(&format!("a{k}"), a[i], ParamRole::Length));
        params.push(param(&format!("d{k}"), d[i], ParamRole::Length));
        params.push(param(&format!("th{k}"), 0.0, ParamRole::Angle));
    }
    params.extend(extra);
    Spec {
        name: "puma560".into(),
        description: None,
        dim: 3,
        convention: Convention::Dh,
        joints,
        tool: vec![num("0"), num("0"), num("0.1")],
        tool_rotation: None,
        base: None,
        params,
        constraints: vec![constraint],
        constraint_list: false,
        relations: Vec::new(),
    }
}

/// A spatial arm with mixed joints: revolute, prismatic, MDH optional, a base and a tool
/// with unknowns, for exercising every slot.
pub fn spatial_mixed(convention: Convention, constraint: Constraint, extra: Vec<Param>) -> Spec {
    let joints = vec![
        revolute(p("a1"), num("pi/2"), p("d1"), p("th1")),
        Joint {
            kind: JointKind::Prismatic,
            a: p("a2"),
            alpha: num("-pi/2"),
            beta: Slot::zero(),
            d: Slot::zero(),
            home: Slot::zero(),
            theta: num("pi/2"),
            offset: p("o2"),
            limits: Some([0.1, 0.5]),
            origin: crate::spec::Base::zero(),
        },
        revolute(p("a3"), p("al3"), num("0.05"), p("th3")),
    ];
    let mut params = vec![
        param("a1", 0.1, ParamRole::Length),
        param("d1", 0.3, ParamRole::Length),
        param("th1", 0.01, ParamRole::Angle),
        param("a2", 0.02, ParamRole::Length),
        param("o2", 0.05, ParamRole::Length),
        param("a3", 0.25, ParamRole::Length),
        param("al3", 0.3, ParamRole::Angle),
        param("th3", -0.02, ParamRole::Angle),
        param("tz", 0.1, ParamRole::Length),
        param("yaw", 0.2, ParamRole::Angle),
    ];
    params.extend(extra);
    Spec {
        name: "mixed".into(),
        description: None,
        dim: 3,
        convention,
        joints,
        tool: vec![num("0.01"), Slot::zero(), p("tz")],
        tool_rotation: None,
        base: Some(crate::spec::Base {
            x: num("0.1"),
            y: Slot::zero(),
            z: Slot::zero(),
            roll: num("0.1"),
            pitch: Slot::zero(),
            yaw: p("yaw"),
        }),
        params,
        constraints: vec![constraint],
        constraint_list: false,
        relations: Vec::new(),
    }
}

/// A spec of the repository, by its path from the repository's root (`tests/specs/…`).
pub fn repo_spec(path: &str) -> Spec {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path);
    crate::spec::from_yaml_file(&file).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Every spec of the repository and of the reference cases beside it: the test set, the large
/// chains, the model library, the bench's and the examples' specs, `../shared/cases`.
pub fn every_repo_spec_path() -> Vec<String> {
    repo_spec_paths(&[
        "tests/specs",
        "tests/large",
        "lincal-models/specs",
        "bench/specs",
        "examples",
        "../shared/cases",
    ])
}

/// Every spec file in `dirs` (paths from the repository's root; a folder holding a
/// `spec.yaml`, as the reference cases do, gives that file), sorted, as paths from the root.
/// A directory that does not exist (`../shared` away from the repository) gives none.
pub fn repo_spec_paths(dirs: &[&str]) -> Vec<String> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    for dir in dirs {
        let Ok(entries) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if e.path().join("spec.yaml").is_file() {
                files.push(format!("{dir}/{name}/spec.yaml"));
            } else if name.ends_with(".yaml") && e.path().is_file() {
                files.push(format!("{dir}/{name}"));
            }
        }
    }
    files.sort();
    files
}
