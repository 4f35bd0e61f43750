//! Where the joints of a URDF text are: byte spans of each `<joint>` element and of its
//! `<origin>` child, read with `quick-xml`'s pull parser (one pass, no recursion).
//!
//! The export rewrites only the `<origin>` elements of the joints it calibrates, so everything else of the file (comments,
//! meshes, transmissions, Gazebo tags, formatting) stays byte for byte.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

/// One `<joint>` element.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct JointSpan {
    /// Its `name` attribute.
    pub name: String,
    /// Byte offset of its `<`.
    pub start: usize,
    /// Byte offset just after its start tag (`<joint ...>`).
    pub tag_end: usize,
    /// Whether it is an empty element (`<joint .../>`).
    pub empty: bool,
    /// Byte span of its `<origin>` child, if it has one.
    pub origin: Option<(usize, usize)>,
}

/// The joints of a URDF text, in document order.
#[derive(Clone, Debug, Default)]
pub(crate) struct XmlIndex {
    joints: Vec<JointSpan>,
    /// Byte offset just after the XML declaration (0 if none).
    pub prolog_end: usize,
}

fn name_of(e: &BytesStart<'_>) -> Option<String> {
    let a = e.try_get_attribute("name").ok()??;
    a.unescape_value().ok().map(|v| v.into_owned())
}

impl XmlIndex {
    /// Indexes `text`; a malformed text gives the joints read before the fault (the URDF
    /// parser reports the fault itself).
    pub(crate) fn new(text: &str) -> XmlIndex {
        let mut ix = XmlIndex::default();
        let mut reader = Reader::from_str(text);
        // Depth below the open <joint> (None outside one).
        let mut depth: Option<usize> = None;
        let mut level = 0usize;
        // The start of an `<origin>` written with start and end tags, until its end tag.
        let mut open_origin: Option<usize> = None;
        loop {
            let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
            let ev = match reader.read_event() {
                Ok(Event::Eof) | Err(_) => break,
                Ok(ev) => ev,
            };
            let after = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
            match ev {
                Event::Decl(_) => ix.prolog_end = after,
                Event::Start(e) => {
                    if level == 1 && e.name().as_ref() == b"joint" {
                        ix.joints.push(JointSpan {
                            name: name_of(&e).unwrap_or_default(),
                            start: before,
                            tag_end: after,
                            empty: false,
                            origin: None,
                        });
                        depth = Some(0);
                    } else if let Some(d) = depth.as_mut() {
                        if *d == 0 && e.name().as_ref() == b"origin" {
                            open_origin = Some(before);
                        }
                        *d += 1;
                    }
                    level += 1;
                }
                Event::Empty(e) => {
                    if level == 1 && e.name().as_ref() == b"joint" {
                        ix.joints.push(JointSpan {
                            name: name_of(&e).unwrap_or_default(),
                            start: before,
                            tag_end: after,
                            empty: true,
                            origin: None,
                        });
                    } else if depth == Some(0) && e.name().as_ref() == b"origin" {
                        if let Some(j) = ix.joints.last_mut() {
                            j.origin.get_or_insert((before, after));
                        }
                    }
                }
                Event::End(_) => {
                    level = level.saturating_sub(1);
                    if depth == Some(1) {
                        if let (Some(start), Some(j)) = (open_origin.take(), ix.joints.last_mut()) {
                            j.origin.get_or_insert((start, after));
                        }
                    }
                    depth = match depth {
                        Some(0) => None,
                        Some(d) => Some(d - 1),
                        None => None,
                    };
                }
                _ => {}
            }
        }
        ix
    }

    /// The joint named `name`.
    pub(crate) fn joint(&self, name: &str) -> Option<&JointSpan> {
        self.joints.iter().find(|j| j.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_joints_and_their_origins() {
        let text = "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n  <link name=\"a\"/>\n  \
                    <joint name=\"j1\" type=\"fixed\">\n    <origin xyz=\"1 0 0\"/>\n    \
                    <parent link=\"a\"/><child link=\"b\"/>\n  </joint>\n  \
                    <joint name=\"j2\" type=\"fixed\"><parent link=\"b\"/></joint>\n</robot>\n";
        let ix = XmlIndex::new(text);
        let j1 = ix.joint("j1").unwrap();
        let (s, e) = j1.origin.unwrap();
        assert_eq!(&text[s..e], "<origin xyz=\"1 0 0\"/>");
        assert!(text[j1.start..].starts_with("<joint name=\"j1\""));
        assert_eq!(ix.joint("j2").unwrap().origin, None);
        assert_eq!(&text[..ix.prolog_end], "<?xml version=\"1.0\"?>");
    }

    #[test]
    fn an_origin_with_start_and_end_tags_is_one_span() {
        let text = "<robot name=\"r\">\n  <joint name=\"j1\" type=\"fixed\">\n    \
                    <origin xyz=\"1 0 0\"></origin>\n    <parent link=\"a\"/>\n  </joint>\n</robot>";
        let ix = XmlIndex::new(text);
        let (s, e) = ix.joint("j1").unwrap().origin.unwrap();
        assert_eq!(&text[s..e], "<origin xyz=\"1 0 0\"></origin>");
    }
}
