//! The part of a URDF lincal reads: the robot's name, its links' names and its joints (type,
//! parent, child, `<origin>`, `<axis>`, `<limit>`, whether it mimics), streamed in one pass
//! with `quick-xml`'s pull parser.
//!
//! Why not a document model: a URDF can be tens of megabytes of meshes, materials and
//! plugins, none of which a kinematic chain needs; a tree of it costs tens of times the file
//! (a 47 MB URDF took 2 GB and 13 s through `urdf-rs`). Read this way the memory is the
//! joints and names kept, at most [`MEMORY_PER_BYTE`] times the input, plus one line offset
//! per line; and nesting is bounded ([`MAX_DEPTH`]), so no input can exhaust the stack or
//! take time beyond one linear pass.
//!
//! Entities: only XML's predefined ones and character references are expanded; a `DOCTYPE`
//! is skipped and any other entity in a value read is an error, so neither external entities
//! nor entity expansion bombs reach the reader.

use std::borrow::Cow;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::error::{excerpt, Error, Location, Result};

/// A location in a URDF file: the element's line and a field.
pub(crate) fn at(file: &str, line: Option<usize>, field: impl Into<String>) -> Location {
    Location {
        file: Some(file.to_string()),
        line,
        field: Some(field.into()),
        ..Location::default()
    }
}

/// Deepest element nesting accepted. Real URDFs nest 5-8 deep (robot, link, visual,
/// geometry, mesh; Gazebo plugins a little more); the bound only refuses hostile input.
pub const MAX_DEPTH: usize = 256;

/// Bound on the bytes kept per input byte: every kept name and number comes from at least
/// as many bytes of the text, plus a fixed record per joint of at most 200 bytes for at
/// least 40 bytes of `<joint name="" type=""><parent link=""/><child link=""/></joint>`.
pub const MEMORY_PER_BYTE: usize = 6;

/// A joint type of the URDF format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointType {
    /// `revolute`: rotation about the axis, within limits.
    Revolute,
    /// `continuous`: rotation about the axis, unlimited.
    Continuous,
    /// `prismatic`: translation along the axis.
    Prismatic,
    /// `fixed`: no motion.
    Fixed,
    /// `floating`: six degrees of freedom.
    Floating,
    /// `planar`: motion in a plane.
    Planar,
    /// `spherical`: rotation about a point (read by some tools, not in the URDF standard).
    Spherical,
}

impl JointType {
    fn parse(s: &str) -> Option<JointType> {
        Some(match s {
            "revolute" => JointType::Revolute,
            "continuous" => JointType::Continuous,
            "prismatic" => JointType::Prismatic,
            "fixed" => JointType::Fixed,
            "floating" => JointType::Floating,
            "planar" => JointType::Planar,
            "spherical" => JointType::Spherical,
            _ => return None,
        })
    }

    /// The type's name in URDF.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            JointType::Revolute => "revolute",
            JointType::Continuous => "continuous",
            JointType::Prismatic => "prismatic",
            JointType::Fixed => "fixed",
            JointType::Floating => "floating",
            JointType::Planar => "planar",
            JointType::Spherical => "spherical",
        }
    }
}

/// One `<joint>` of the robot, as written (nothing checked beyond the syntax of its
/// numbers).
#[derive(Clone, Debug, PartialEq)]
pub struct UrdfJoint {
    /// Its `name`.
    pub name: String,
    /// The 1-based line of its start tag.
    pub line: usize,
    /// Its `type`.
    pub joint_type: JointType,
    /// `<parent link>`.
    pub parent: String,
    /// `<child link>`.
    pub child: String,
    /// `<origin xyz>` (zero when absent).
    pub xyz: [f64; 3],
    /// `<origin rpy>` (zero when absent).
    pub rpy: [f64; 3],
    /// `<axis xyz>` as written (`1 0 0` when absent, URDF's default).
    pub axis: [f64; 3],
    /// `<limit lower upper>` (each 0 when absent, as URDF reads them), if there is a
    /// `<limit>`.
    pub limit: Option<[f64; 2]>,
    /// Whether it has a `<mimic>`.
    pub mimic: bool,
}

/// The robot: its name, links and joints in document order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UrdfRobot {
    /// `<robot name>`.
    pub name: String,
    /// Each `<link name>` with the line of its element.
    pub links: Vec<(String, usize)>,
    /// The joints (direct children of `<robot>`).
    pub joints: Vec<UrdfJoint>,
}

/// The joint being read: its start tag's fields, then its children's.
struct Partial {
    name: String,
    line: usize,
    joint_type: String,
    parent: Option<String>,
    child: Option<String>,
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limit: Option<[f64; 2]>,
    mimic: bool,
    /// The lines of its `<parent>`, `<child>`, `<origin>`, `<axis>` and `<limit>` once read
    /// ([`SINGLE`]'s order): a second one is refused, where the last would silently win.
    seen: [Option<usize>; 5],
}

/// The child elements a joint has at most one of.
const SINGLE: [&[u8]; 5] = [b"parent", b"child", b"origin", b"axis", b"limit"];

/// One pass over the text with what a message needs to name a place.
struct Pass<'t> {
    file: &'t str,
    lines: Vec<usize>,
}

impl Pass<'_> {
    fn line(&self, at_byte: usize) -> usize {
        self.lines.partition_point(|&s| s <= at_byte)
    }

    fn err(&self, line: Option<usize>, field: &str, msg: impl Into<String>) -> Error {
        Error::input(at(self.file, line, field), msg)
    }

    /// The unescaped value of attribute `key` of `e`, if present.
    fn attr<'e>(
        &self,
        e: &'e BytesStart<'_>,
        key: &str,
        line: usize,
        field: &str,
    ) -> Result<Option<Cow<'e, str>>> {
        let a = e
            .try_get_attribute(key)
            .map_err(|x| self.err(Some(line), field, format!("not a readable URDF: {x}")))?;
        match a {
            None => Ok(None),
            Some(a) => a.unescape_value().map(Some).map_err(|x| {
                self.err(
                    Some(line),
                    field,
                    format!("the attribute `{key}` cannot be read: {x}"),
                )
            }),
        }
    }

    /// Three numbers separated by white space (`xyz`, `rpy`).
    fn three(
        &self,
        e: &BytesStart<'_>,
        key: &str,
        line: usize,
        field: &str,
    ) -> Result<Option<[f64; 3]>> {
        let Some(v) = self.attr(e, key, line, field)? else {
            return Ok(None);
        };
        let parts: Vec<&str> = v.split_ascii_whitespace().collect();
        let parsed: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
        match <[f64; 3]>::try_from(parsed) {
            Ok(a) if parts.len() == 3 => Ok(Some(a)),
            _ => Err(self.err(
                Some(line),
                field,
                format!(
                    "`{key}=\"{}\"` is not three numbers separated by spaces",
                    excerpt(&v)
                ),
            )),
        }
    }

    /// One number (`lower`, `upper`), 0 when absent.
    fn one(&self, e: &BytesStart<'_>, key: &str, line: usize, field: &str) -> Result<f64> {
        match self.attr(e, key, line, field)? {
            None => Ok(0.0),
            Some(v) => v.trim().parse().map_err(|_| {
                self.err(
                    Some(line),
                    field,
                    format!("`{key}=\"{}\"` is not a number", excerpt(&v)),
                )
            }),
        }
    }
}

/// Reads the robot of URDF `text` (`file` names it in errors).
///
/// # Errors
/// An input error naming the file, line and element for: XML that is not well formed,
/// nesting deeper than [`MAX_DEPTH`], a root that is not `<robot>`, a joint without a name,
/// a known type, a parent or a child, an entity other than XML's own, numbers that are not
/// numbers.
pub fn read(text: &str, file: &str) -> Result<UrdfRobot> {
    let pass = Pass {
        file,
        lines: std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect(),
    };
    let mut reader = Reader::from_str(text);
    let mut robot = UrdfRobot::default();
    let mut depth = 0usize;
    let mut joint: Option<Partial> = None;
    let mut root_seen = false;
    loop {
        let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
        let ev = reader.read_event().map_err(|e| {
            let pos = usize::try_from(reader.error_position()).unwrap_or(0);
            pass.err(
                Some(pass.line(pos)),
                "robot",
                format!("not a readable URDF: {e}"),
            )
        })?;
        let line = pass.line(before);
        let (e, empty) = match ev {
            Event::Eof if depth > 0 => {
                return Err(pass.err(
                    Some(pass.lines.len()),
                    "robot",
                    "not a readable URDF: the text ends inside an element that is not closed",
                ))
            }
            Event::Eof => break,
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                if depth == 1 {
                    if let Some(j) = joint.take() {
                        robot.joints.push(finish(&pass, j)?);
                    }
                }
                continue;
            }
            _ => continue,
        };
        if depth == 0 {
            if e.name().as_ref() != b"robot" || root_seen {
                return Err(pass.err(
                    Some(line),
                    "robot",
                    "not a URDF: the root element is not `<robot>`",
                ));
            }
            root_seen = true;
            robot.name = pass
                .attr(&e, "name", line, "robot")?
                .unwrap_or_default()
                .into_owned();
        } else {
            element(&pass, &e, depth, line, empty, &mut robot, &mut joint)?;
        }
        if !empty {
            depth += 1;
            if depth > MAX_DEPTH {
                return Err(pass.err(
                    Some(line),
                    "robot",
                    format!(
                        "elements nested more than {MAX_DEPTH} deep: not a URDF a robot \
                         description tool writes"
                    ),
                ));
            }
        }
    }
    if !root_seen {
        return Err(pass.err(None, "robot", "not a URDF: no `<robot>` element"));
    }
    Ok(robot)
}

/// A start or empty element `e` at `depth` (1: a child of `<robot>`).
fn element(
    pass: &Pass<'_>,
    e: &BytesStart<'_>,
    depth: usize,
    line: usize,
    empty: bool,
    robot: &mut UrdfRobot,
    joint: &mut Option<Partial>,
) -> Result<()> {
    match (depth, e.name().as_ref()) {
        (1, b"link") => {
            let name = pass.attr(e, "name", line, "link")?.unwrap_or_default();
            robot.links.push((name.into_owned(), line));
        }
        (1, b"joint") => {
            let name = pass.attr(e, "name", line, "joint")?;
            let Some(name) = name.filter(|n| !n.is_empty()) else {
                return Err(pass.err(Some(line), "joint", "a joint without a `name`"));
            };
            let field = format!("joint `{}`.type", excerpt(&name));
            let joint_type = pass.attr(e, "type", line, &field)?.unwrap_or_default();
            let j = Partial {
                name: name.into_owned(),
                line,
                joint_type: joint_type.into_owned(),
                parent: None,
                child: None,
                xyz: [0.0; 3],
                rpy: [0.0; 3],
                axis: [1.0, 0.0, 0.0],
                limit: None,
                mimic: false,
                seen: [None; 5],
            };
            if empty {
                robot.joints.push(finish(pass, j)?);
            } else {
                *joint = Some(j);
            }
        }
        (2, tag) => {
            if let Some(j) = joint.as_mut() {
                joint_child(pass, e, tag, line, j)?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// A child element `tag` of the joint being read.
fn joint_child(
    pass: &Pass<'_>,
    e: &BytesStart<'_>,
    tag: &[u8],
    line: usize,
    j: &mut Partial,
) -> Result<()> {
    let field = |f: &str| format!("joint `{}`.{f}", excerpt(&j.name));
    if let Some(k) = SINGLE.iter().position(|&t| t == tag) {
        let name = String::from_utf8_lossy(tag);
        if let Some(first) = j.seen[k].replace(line) {
            return Err(pass.err(
                Some(line),
                &field(&name),
                format!(
                    "joint `{}` has a second `<{name}>` (line {line}; the first is on line \
                     {first}): a joint has one, remove one of them",
                    excerpt(&j.name)
                ),
            ));
        }
    }
    match tag {
        b"parent" => {
            j.parent = pass
                .attr(e, "link", line, &field("parent"))?
                .map(Cow::into_owned);
        }
        b"child" => {
            j.child = pass
                .attr(e, "link", line, &field("child"))?
                .map(Cow::into_owned);
        }
        b"origin" => {
            let f = field("origin");
            j.xyz = pass.three(e, "xyz", line, &f)?.unwrap_or([0.0; 3]);
            j.rpy = pass.three(e, "rpy", line, &f)?.unwrap_or([0.0; 3]);
        }
        b"axis" => {
            j.axis = pass
                .three(e, "xyz", line, &field("axis"))?
                .unwrap_or([1.0, 0.0, 0.0]);
        }
        b"limit" => {
            let f = field("limit");
            j.limit = Some([
                pass.one(e, "lower", line, &f)?,
                pass.one(e, "upper", line, &f)?,
            ]);
        }
        b"mimic" => j.mimic = true,
        _ => {}
    }
    Ok(())
}

/// The joint read, its type known and its parent and child given.
fn finish(pass: &Pass<'_>, j: Partial) -> Result<UrdfJoint> {
    let field = |f: &str| format!("joint `{}`.{f}", excerpt(&j.name));
    let Some(joint_type) = JointType::parse(&j.joint_type) else {
        return Err(pass.err(
            Some(j.line),
            &field("type"),
            format!(
                "joint type `{}` is not one of URDF's (revolute, continuous, prismatic, fixed, \
                 floating, planar, spherical)",
                excerpt(&j.joint_type)
            ),
        ));
    };
    let (Some(parent), Some(child)) = (j.parent, j.child) else {
        return Err(pass.err(
            Some(j.line),
            &field("parent"),
            "a joint needs both `<parent link=\"…\"/>` and `<child link=\"…\"/>`",
        ));
    };
    Ok(UrdfJoint {
        name: j.name,
        line: j.line,
        joint_type,
        parent,
        child,
        xyz: j.xyz,
        rpy: j.rpy,
        axis: j.axis,
        limit: j.limit,
        mimic: j.mimic,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: &str = "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n  <link name=\"a\"/>\n  \
        <joint name=\"j1\" type=\"revolute\">\n    <origin xyz=\"1 0 0\" rpy=\"0 0 1.5\"/>\n    \
        <parent link=\"a\"/><child link=\"b\"/>\n    <axis xyz=\"0 0 2\"/>\n    \
        <limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>\n  </joint>\n  \
        <link name=\"b\"><visual><geometry><box size=\"1 1 1\"/></geometry></visual></link>\n  \
        <transmission><joint name=\"j1\"/></transmission>\n</robot>\n";

    /// A second `<axis>`, `<limit>`, `<parent>` or `<child>` is refused at its line, naming
    /// the first: the last one read would otherwise win, silently (an axis turned from z to x).
    #[test]
    fn refuses_a_second_single_element() {
        for (tag, extra) in [
            ("axis", "<axis xyz=\"1 0 0\"/>"),
            ("limit", "<limit lower=\"-2\" upper=\"2\"/>"),
            ("parent", "<parent link=\"b\"/>"),
            ("child", "<child link=\"a\"/>"),
        ] {
            let text = TWO.replace("  </joint>", &format!("    {extra}\n  </joint>"));
            let e = read(&text, "t.urdf").unwrap_err().to_string();
            assert!(
                e.contains(&format!("second `<{tag}>` (line 9; the first is on line")),
                "{tag}: {e}"
            );
        }
        assert!(read(TWO, "t.urdf").is_ok());
    }

    #[test]
    fn reads_links_and_joints() {
        let r = read(TWO, "t.urdf").unwrap();
        assert_eq!(r.name, "r");
        assert_eq!(r.links, vec![("a".to_string(), 3), ("b".to_string(), 10)]);
        assert_eq!(r.joints.len(), 1, "the transmission's joint is not a joint");
        let j = &r.joints[0];
        assert_eq!(
            (j.name.as_str(), j.line, j.joint_type),
            ("j1", 4, JointType::Revolute)
        );
        assert_eq!((j.parent.as_str(), j.child.as_str()), ("a", "b"));
        assert_eq!(
            (j.xyz, j.rpy, j.axis),
            ([1.0, 0.0, 0.0], [0.0, 0.0, 1.5], [0.0, 0.0, 2.0])
        );
        assert_eq!(j.limit, Some([-1.0, 1.0]));
    }

    #[test]
    fn refuses_deep_nesting_in_one_linear_pass() {
        let n = 100_000;
        let text = format!(
            "<robot name=\"r\">{}{}</robot>",
            "<x>".repeat(n),
            "</x>".repeat(n)
        );
        let e = read(&text, "deep.urdf").unwrap_err().to_string();
        assert!(e.contains("nested more than 256"), "{e}");
    }

    #[test]
    fn refuses_foreign_entities_and_bad_numbers() {
        let ent = "<!DOCTYPE robot [<!ENTITY x SYSTEM \"file:///etc/passwd\">]>\
                   <robot name=\"&x;\"/>";
        assert!(read(ent, "e.urdf").is_err());
        let bad = TWO.replace("0 0 2", "0 0 two");
        let e = read(&bad, "b.urdf").unwrap_err().to_string();
        assert!(e.contains("b.urdf:7") && e.contains("axis"), "{e}");
        let typ = TWO.replace("revolute", "ball");
        assert!(read(&typ, "t.urdf")
            .unwrap_err()
            .to_string()
            .contains("`ball`"));
        assert!(read("<model/>", "m.urdf").is_err());
        assert!(read("<robot name=\"r\"><link", "u.urdf").is_err());
    }
}
