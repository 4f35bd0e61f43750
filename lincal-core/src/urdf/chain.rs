//! The serial chain between two links of a URDF (read by [`super::read`]), and its forward
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

use super::frame::{norm, Iso};
pub(crate) use super::read::at;
use super::read::{JointType, UrdfJoint, UrdfRobot};
use crate::error::{excerpt, Error, Result};

/// Largest magnitude of an origin coordinate or a tool coordinate, in metres (1 000 km):
/// beyond it no robot is meant, and products of such values would overflow.
pub const MAX_LENGTH: f64 = 1e6;

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
        let robot = super::read::read(text, file)?;
        Self::from_robot(&robot, file, base, tip)
    }

    /// [`UrdfChain::from_str`] of a robot already read.
    ///
    /// # Errors
    /// As [`UrdfChain::from_str`], and an input error naming both lines when two joints or
    /// two links share a name, or a name on the chain holds a control character.
    pub fn from_robot(robot: &UrdfRobot, file: &str, base: &str, tip: &str) -> Result<UrdfChain> {
        check_unique(robot, file)?;
        check_links(robot, file, base, tip)?;
        let parent_of = parent_joints(robot, file)?;
        check_acyclic(&parent_of, robot, file)?;
        let path = joint_path(&parent_of, robot.joints.len(), file, base, tip)?;
        let mut elements = Vec::with_capacity(path.len());
        for j in path {
            elements.push(element(j, file, base, tip)?);
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

/// Each joint name and each link name once; no control character in a name (it would
/// break the comments and records written from it). An input error naming both lines.
fn check_unique(robot: &UrdfRobot, file: &str) -> Result<()> {
    let names = robot
        .joints
        .iter()
        .map(|j| ("joint", j.name.as_str(), j.line))
        .chain(robot.links.iter().map(|(n, l)| ("link", n.as_str(), *l)));
    let mut seen: HashMap<(&str, &str), usize> = HashMap::new();
    for (what, name, line) in names {
        if let Some(c) = name.chars().find(|c| c.is_control()) {
            return Err(Error::input(
                at(
                    file,
                    Some(line),
                    format!("{what} `{}`", name.escape_debug()),
                ),
                format!(
                    "the {what} name holds the control character U+{:04X}: a name is written \
                     into specs, data headers and comments, so it must be printable",
                    u32::from(c)
                ),
            ));
        }
        if let Some(first) = seen.insert((what, name), line) {
            return Err(Error::input(
                at(file, Some(line), format!("{what} `{}`", excerpt(name))),
                format!(
                    "a second {what} named `{}` (the first is on line {first}): names must \
                     be unique, or the chain and the written URDF would be ambiguous",
                    excerpt(name)
                ),
            ));
        }
    }
    Ok(())
}

/// `base` and `tip` are links of the robot; an input error (naming the first dozen links)
/// otherwise.
fn check_links(robot: &UrdfRobot, file: &str, base: &str, tip: &str) -> Result<()> {
    let links: Vec<&str> = robot.links.iter().map(|l| l.0.as_str()).collect();
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
fn parent_joints<'r>(robot: &'r UrdfRobot, file: &str) -> Result<HashMap<&'r str, &'r UrdfJoint>> {
    let mut parent_of: HashMap<&str, &UrdfJoint> = HashMap::new();
    for j in &robot.joints {
        if let Some(other) = parent_of.insert(j.child.as_str(), j) {
            return Err(Error::input(
                at(
                    file,
                    Some(j.line),
                    format!("joint `{}`.child", excerpt(&j.name)),
                ),
                format!(
                    "link `{}` is the child of two joints (`{}` and `{}`): a URDF is a tree",
                    excerpt(&j.child),
                    excerpt(&other.name),
                    excerpt(&j.name)
                ),
            ));
        }
    }
    Ok(parent_of)
}

/// An input error naming a joint on a cycle when the joints' parent links go round one
/// anywhere in the file (a URDF is a tree, whatever part of it the chain takes): from each
/// link, going up through parent joints must reach a root within as many steps as there are
/// joints. Links already known to reach a root end a walk early, so each link is walked once.
fn check_acyclic(
    parent_of: &HashMap<&str, &UrdfJoint>,
    robot: &UrdfRobot,
    file: &str,
) -> Result<()> {
    let mut rooted: std::collections::HashSet<&str> = std::collections::HashSet::new();
    for start in &robot.joints {
        let mut walked: Vec<&str> = Vec::new();
        let mut link = start.child.as_str();
        while let Some(j) = parent_of.get(link) {
            if rooted.contains(link) {
                break;
            }
            walked.push(link);
            if walked.len() > robot.joints.len() {
                return Err(Error::input(
                    at(file, Some(j.line), format!("joint `{}`", excerpt(&j.name))),
                    format!(
                        "the joints form a cycle through link `{}`: a URDF is a tree",
                        excerpt(link)
                    ),
                ));
            }
            link = j.parent.as_str();
        }
        rooted.extend(walked);
    }
    Ok(())
}

/// The joints from `base` down to `tip`, base first, walked up from `tip` through
/// `parent_of` (of `n_joints` joints in all); an input error when `base` is not an ancestor
/// of `tip` or the walk goes round a cycle.
fn joint_path<'r>(
    parent_of: &HashMap<&str, &'r UrdfJoint>,
    n_joints: usize,
    file: &str,
    base: &str,
    tip: &str,
) -> Result<Vec<&'r UrdfJoint>> {
    let mut path: Vec<&UrdfJoint> = Vec::new();
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
                at(file, Some(j.line), format!("joint `{}`", excerpt(&j.name))),
                "the joints form a cycle: a URDF is a tree",
            ));
        }
        link = j.parent.as_str();
    }
    path.reverse();
    Ok(path)
}

/// Joint `j` of the chain as an [`Element`]: its kind, origin, unit axis and limits; an
/// input error for a joint type with no single reading, a mimic joint, an origin that is not
/// finite or beyond [`MAX_LENGTH`], or an axis with no direction.
fn element(j: &UrdfJoint, file: &str, base: &str, tip: &str) -> Result<Element> {
    let l = Some(j.line);
    let field = |f: &str| format!("joint `{}`.{f}", excerpt(&j.name));
    let kind = element_kind(j, file, base, tip)?;
    if j.mimic && kind != ElementKind::Fixed {
        return Err(Error::input(
            at(file, l, field("mimic")),
            "a mimic joint on the chain: its reading is not independent, which a \
             calibration spec cannot express",
        ));
    }
    if !finite3(j.xyz) || !finite3(j.rpy) {
        return Err(Error::input(
            at(file, l, field("origin")),
            "the origin has a value that is not a finite number",
        ));
    }
    if j.xyz.iter().any(|v| v.abs() > MAX_LENGTH) {
        return Err(Error::input(
            at(file, l, field("origin")),
            format!(
                "the origin xyz {:?} is beyond {MAX_LENGTH:e} m: no robot is that large (a \
                 unit slip, millimetres for metres?)",
                j.xyz
            ),
        ));
    }
    let axis = element_axis(j.axis, kind, &field, l, file)?;
    let limits = (j.joint_type == JointType::Revolute || kind == ElementKind::Prismatic)
        .then_some(j.limit)
        .flatten()
        // A spec's numbers are at most 10⁹ (metres or radians): a wider limit is none.
        .filter(|[lo, hi]| lo.is_finite() && hi.is_finite() && lo < hi)
        .filter(|[lo, hi]| lo.abs() <= 1e9 && hi.abs() <= 1e9);
    Ok(Element {
        name: j.name.clone(),
        kind,
        origin: Iso::from_xyz_rpy(j.xyz, j.rpy),
        axis,
        limits,
    })
}

/// What joint `j` does; an input error for a type with no single reading (floating,
/// planar, spherical).
fn element_kind(j: &UrdfJoint, file: &str, base: &str, tip: &str) -> Result<ElementKind> {
    Ok(match j.joint_type {
        JointType::Fixed => ElementKind::Fixed,
        JointType::Revolute | JointType::Continuous => ElementKind::Revolute,
        JointType::Prismatic => ElementKind::Prismatic,
        other => {
            return Err(Error::input(
                at(
                    file,
                    Some(j.line),
                    format!("joint `{}`.type", excerpt(&j.name)),
                ),
                format!(
                    "a `{}` joint is on the chain from `{base}` to `{tip}`: only \
                     revolute, continuous, prismatic and fixed joints have one reading \
                     each (choose a base and tip that avoid it)",
                    other.name()
                ),
            ))
        }
    })
}

/// The unit axis of a joint of `kind` from its `<axis>` (x for a fixed joint, whose axis
/// is unused); an input error when a moving joint's axis has no direction. Any finite
/// magnitude is accepted: the vector is scaled by its largest entry before it is
/// normalised, so `1e308 1e308 0` does not overflow and `0 0 1e-300` does not underflow.
fn element_axis(
    axis: [f64; 3],
    kind: ElementKind,
    field: &dyn Fn(&str) -> String,
    l: Option<usize>,
    file: &str,
) -> Result<[f64; 3]> {
    if kind == ElementKind::Fixed {
        return Ok([1.0, 0.0, 0.0]);
    }
    let big = axis.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if !finite3(axis) || big == 0.0 {
        return Err(Error::input(
            at(file, l, field("axis")),
            format!(
                "the axis {axis:?} has no direction (zero or not finite): expected a \
                 non-zero vector"
            ),
        ));
    }
    let scaled = axis.map(|v| v / big);
    let n = norm(scaled);
    Ok(scaled.map(|v| v / n))
}

impl UrdfChain {
    /// Notes for the chain's revolute and prismatic joints whose `<limit>` gives no range
    /// (lower not below upper, or a bound not finite; URDF reads a missing bound as 0) in
    /// `robot`, the URDF it was read from: the spec gets no `limits:` for them, which the
    /// user should know rather than find out.
    pub(crate) fn dropped_limits(&self, robot: &UrdfRobot) -> Vec<String> {
        self.elements
            .iter()
            .filter(|e| e.kind != ElementKind::Fixed && e.limits.is_none())
            .filter_map(|e| {
                let j = robot.joints.iter().find(|j| j.name == e.name)?;
                let [lo, hi] = j.limit.filter(|_| j.joint_type != JointType::Continuous)?;
                Some(format!(
                    "joint `{}` (line {}): its <limit> lower {} upper {} gives no range (empty, \
                     not finite, or beyond 1e9), so the spec has no `limits:` for it",
                    excerpt(&e.name),
                    j.line,
                    super::num(lo),
                    super::num(hi),
                ))
            })
            .collect()
    }
}
