//! The serial chain between two links of a URDF, read with `urdf-rs`, and its forward
//! kinematics.
//!
//! A URDF is a tree of links joined by joints; joint `j` places its child link at
//! `T_parent · O_j · M_j(q_j)`, with `O_j = Tr(xyz)·Rz(y)Ry(p)Rx(r)` its `<origin>` and
//! `M_j(q)` the rotation by `q` about the unit `<axis>` (revolute, continuous), the
//! translation by `q` along it (prismatic), or the identity (fixed). The chain from `base` to
//! `tip` is the path of parent joints walked up from `tip`; it must reach `base`.
//!
//! Every problem is an input error naming the file, the line of the element and the field.

use std::collections::HashMap;

use super::frame::{norm, unit, Iso};
use super::xml::XmlIndex;
use crate::error::{Error, Location, Result};

/// What a joint of the chain does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ElementKind {
    /// `fixed`: no motion; folded into its neighbours.
    Fixed,
    /// `revolute` or `continuous`: rotation about the axis.
    Revolute,
    /// `prismatic`: translation along the axis.
    Prismatic,
}

/// One joint on the path from the base link to the tip link.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// The URDF joint name.
    pub name: String,
    /// Its type.
    pub kind: ElementKind,
    /// `<origin>`: the joint frame in the parent link's frame.
    pub origin: Iso,
    /// `<axis>`, normalised, in the joint frame.
    pub axis: [f64; 3],
    /// `<limit lower upper>` of a revolute or prismatic joint.
    pub limits: Option<[f64; 2]>,
}

/// The chain from `base` to `tip`, base first.
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfChain {
    /// The base link.
    pub base: String,
    /// The tip link.
    pub tip: String,
    /// The joints of the path, base to tip (fixed ones included).
    pub elements: Vec<Element>,
}

/// A location in a URDF file: the element's line and a field.
pub(crate) fn at(file: &str, line: Option<usize>, field: impl Into<String>) -> Location {
    Location {
        file: Some(file.to_string()),
        line,
        field: Some(field.into()),
        ..Location::default()
    }
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl UrdfChain {
    /// Parses URDF text (`file` names it in errors) and extracts the chain from `base` to
    /// `tip`.
    ///
    /// # Errors
    /// An input error naming the file, the joint's line and the field when the text is not
    /// a URDF, a link is missing, `base` is not an ancestor of `tip` (the path is not serial
    /// from base to tip), a joint on the path is `floating` or `planar`, mimics another
    /// joint, or has a zero or non-finite axis or origin.
    pub fn from_str(text: &str, file: &str, base: &str, tip: &str) -> Result<UrdfChain> {
        let robot = urdf_rs::read_from_string(text).map_err(|e| {
            Error::input(at(file, None, "robot"), format!("not a readable URDF: {e}"))
        })?;
        let index = XmlIndex::new(text);
        check_links(&robot, file, base, tip)?;
        let parent_of = parent_joints(&robot, &index, file)?;
        let path = joint_path(&parent_of, robot.joints.len(), &index, file, base, tip)?;
        let mut elements = Vec::with_capacity(path.len());
        for j in path {
            elements.push(element(j, joint_line(&index, &j.name), file, base, tip)?);
        }
        if !elements.iter().any(|e| e.kind != ElementKind::Fixed) {
            return Err(Error::input(
                at(file, None, "--tip"),
                format!("no moving joint between `{base}` and `{tip}`: nothing to calibrate"),
            ));
        }
        Ok(UrdfChain {
            base: base.to_string(),
            tip: tip.to_string(),
            elements,
        })
    }

    /// The moving joints (revolute, continuous, prismatic), base to tip.
    pub fn actuated(&self) -> impl Iterator<Item = &Element> {
        self.elements
            .iter()
            .filter(|e| e.kind != ElementKind::Fixed)
    }

    /// The tip link's frame in the base link's frame at readings `q` (one per moving
    /// joint): `Π_j O_j·M_j(q_j)`.
    #[must_use]
    pub fn tip_frame(&self, q: &[f64]) -> Iso {
        let mut t = Iso::IDENTITY;
        let mut i = 0;
        for e in &self.elements {
            t = t.mul(&e.origin);
            let qi = match e.kind {
                ElementKind::Fixed => continue,
                _ => {
                    i += 1;
                    q.get(i - 1).copied().unwrap_or(0.0)
                }
            };
            let m = match e.kind {
                ElementKind::Prismatic => {
                    Iso::translation([qi * e.axis[0], qi * e.axis[1], qi * e.axis[2]])
                }
                _ => Iso::rotation(e.axis, qi),
            };
            t = t.mul(&m);
        }
        t
    }
}

/// The line of joint `name`'s element in the URDF text, if it is found there.
fn joint_line(index: &XmlIndex, name: &str) -> Option<usize> {
    index.joint(name).map(|j| index.line(j.start))
}

/// `base` and `tip` are links of the robot; an input error (naming the first dozen links)
/// otherwise.
fn check_links(robot: &urdf_rs::Robot, file: &str, base: &str, tip: &str) -> Result<()> {
    let links: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
    for (what, link) in [("--base", base), ("--tip", tip)] {
        if !links.contains(&link) {
            let mut known: Vec<&str> = links.clone();
            known.truncate(12);
            return Err(Error::input(
                at(file, None, what),
                format!(
                    "no link `{}` in the URDF (its links: {}{})",
                    crate::error::excerpt(link),
                    known.join(", "),
                    if links.len() > 12 { ", ..." } else { "" }
                ),
            ));
        }
    }
    Ok(())
}

/// Each link's parent joint; an input error when a link has two (not a tree).
fn parent_joints<'r>(
    robot: &'r urdf_rs::Robot,
    index: &XmlIndex,
    file: &str,
) -> Result<HashMap<&'r str, &'r urdf_rs::Joint>> {
    let mut parent_of: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
    for j in &robot.joints {
        if let Some(other) = parent_of.insert(j.child.link.as_str(), j) {
            return Err(Error::input(
                at(
                    file,
                    joint_line(index, &j.name),
                    format!("joint `{}`.child", j.name),
                ),
                format!(
                    "link `{}` is the child of two joints (`{}` and `{}`): a URDF is a tree",
                    j.child.link, other.name, j.name
                ),
            ));
        }
    }
    Ok(parent_of)
}

/// The joints from `base` down to `tip`, base first, walked up from `tip` through
/// `parent_of` (of `n_joints` joints in all); an input error when `base` is not an ancestor
/// of `tip` or the walk goes round a cycle.
fn joint_path<'r>(
    parent_of: &HashMap<&str, &'r urdf_rs::Joint>,
    n_joints: usize,
    index: &XmlIndex,
    file: &str,
    base: &str,
    tip: &str,
) -> Result<Vec<&'r urdf_rs::Joint>> {
    let mut path: Vec<&urdf_rs::Joint> = Vec::new();
    let mut link = tip;
    while link != base {
        let Some(j) = parent_of.get(link) else {
            return Err(Error::input(
                at(file, None, "--base"),
                format!(
                    "link `{base}` is not an ancestor of `{tip}`: going up from `{tip}` \
                     reaches the root `{link}` without meeting `{base}`, so the chain from \
                     base to tip is not a serial path down the tree (give a base above the \
                     tip)"
                ),
            ));
        };
        path.push(j);
        if path.len() > n_joints {
            return Err(Error::input(
                at(
                    file,
                    joint_line(index, &j.name),
                    format!("joint `{}`", j.name),
                ),
                "the joints form a cycle: a URDF is a tree",
            ));
        }
        link = j.parent.link.as_str();
    }
    path.reverse();
    Ok(path)
}

/// Joint `j` of the chain (its element at line `l`) as an [`Element`]: its kind, origin,
/// unit axis and limits; an input error for a joint type with no single reading, a mimic
/// joint, or a non-finite origin or axis.
fn element(
    j: &urdf_rs::Joint,
    l: Option<usize>,
    file: &str,
    base: &str,
    tip: &str,
) -> Result<Element> {
    let field = |f: &str| format!("joint `{}`.{f}", j.name);
    let kind = element_kind(j, l, file, base, tip)?;
    if j.mimic.is_some() && kind != ElementKind::Fixed {
        return Err(Error::input(
            at(file, l, field("mimic")),
            "a mimic joint on the chain: its reading is not independent, which a \
             calibration spec cannot express",
        ));
    }
    let xyz = j.origin.xyz.0;
    let rpy = j.origin.rpy.0;
    if !finite3(xyz) || !finite3(rpy) {
        return Err(Error::input(
            at(file, l, field("origin")),
            "the origin has a value that is not a finite number",
        ));
    }
    let axis = element_axis(j.axis.xyz.0, kind, &field, l, file)?;
    let limits = (matches!(j.joint_type, urdf_rs::JointType::Revolute)
        || kind == ElementKind::Prismatic)
        .then_some([j.limit.lower, j.limit.upper])
        .filter(|[lo, hi]| lo.is_finite() && hi.is_finite() && lo < hi);
    Ok(Element {
        name: j.name.clone(),
        kind,
        origin: Iso::from_xyz_rpy(xyz, rpy),
        axis,
        limits,
    })
}

/// What joint `j` does; an input error for a type with no single reading (floating,
/// planar, spherical).
fn element_kind(
    j: &urdf_rs::Joint,
    l: Option<usize>,
    file: &str,
    base: &str,
    tip: &str,
) -> Result<ElementKind> {
    Ok(match j.joint_type {
        urdf_rs::JointType::Fixed => ElementKind::Fixed,
        urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => ElementKind::Revolute,
        urdf_rs::JointType::Prismatic => ElementKind::Prismatic,
        ref other => {
            return Err(Error::input(
                at(file, l, format!("joint `{}`.type", j.name)),
                format!(
                    "a `{}` joint is on the chain from `{base}` to `{tip}`: only \
                     revolute, continuous, prismatic and fixed joints have one reading \
                     each (choose a base and tip that avoid it)",
                    joint_type_name(other)
                ),
            ))
        }
    })
}

/// The unit axis of a joint of `kind` from its `<axis>` (x for a fixed joint, whose axis
/// is unused); an input error when a moving joint's axis has no direction.
fn element_axis(
    axis: [f64; 3],
    kind: ElementKind,
    field: &dyn Fn(&str) -> String,
    l: Option<usize>,
    file: &str,
) -> Result<[f64; 3]> {
    Ok(if kind == ElementKind::Fixed {
        [1.0, 0.0, 0.0]
    } else {
        let n = norm(axis);
        if !finite3(axis) || n.is_nan() || n <= 1e-9 {
            return Err(Error::input(
                at(file, l, field("axis")),
                format!(
                    "the axis {axis:?} has no direction (zero or not finite): expected a \
                     non-zero vector"
                ),
            ));
        }
        unit(axis)
    })
}

fn joint_type_name(t: &urdf_rs::JointType) -> &'static str {
    match t {
        urdf_rs::JointType::Revolute => "revolute",
        urdf_rs::JointType::Continuous => "continuous",
        urdf_rs::JointType::Prismatic => "prismatic",
        urdf_rs::JointType::Fixed => "fixed",
        urdf_rs::JointType::Floating => "floating",
        urdf_rs::JointType::Planar => "planar",
        urdf_rs::JointType::Spherical => "spherical",
    }
}
