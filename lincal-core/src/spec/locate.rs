//! Where each value of a document is: a field path → (line, column) index.
//!
//! The walker's and the validator's problems name a line. The YAML adapter
//! ([`super::node::parse_yaml`]) feeds this index from the same events that build the tree,
//! and records for every node its field path in the loader's syntax (`joints[1].home`,
//! `params.a1.nominal`, `constraint.line.b[0]`) with:
//! - the position of the value (a scalar's first character, a flow collection's bracket, a
//!   block collection's first entry), and
//! - for mapping entries, the position of the key.
//!
//! Lookups fall back to the nearest indexed ancestor, so a path the index does not hold (a
//! missing field, a node inside an alias) still gets the closest enclosing place. Keys that
//! repeat are recorded as well, so that each repeat can be named. Complex keys (a mapping or
//! a list used as a key) are not indexed: the loader rejects them.

use std::collections::HashMap;

use yaml_rust2::parser::Event;

/// A 1-based (line, column) position.
pub(crate) type Pos = (usize, usize);

/// The path → position index of one YAML document.
#[derive(Debug, Default)]
pub(crate) struct SourceIndex {
    /// Value position of each path.
    values: HashMap<String, Pos>,
    /// Key position of each mapping entry's path.
    keys: HashMap<String, Pos>,
    /// Keys that appear more than once in their mapping: (path, position of the repeat).
    duplicates: Vec<(String, Pos)>,
}

/// An open collection, as the index follows it.
pub(crate) enum Frame {
    /// A mapping at `path` (`None`: not indexed). `key` is `None` while a key is expected,
    /// `Some(k)` once the key was read (`k` is `None` for a complex key).
    Map {
        path: Option<String>,
        key: Option<Option<(String, Pos)>>,
    },
    /// A sequence at `path` with the index of its next entry.
    Seq { path: Option<String>, next: usize },
}

impl SourceIndex {
    /// Closes the innermost open collection.
    pub(crate) fn close(&mut self, stack: &mut Vec<Frame>) {
        stack.pop();
    }

    /// Records the node that starts with `event` at `here` in its parent and returns its path
    /// (`None` when it is a key or inside a complex key).
    pub(crate) fn place(&mut self, stack: &mut Vec<Frame>, event: &Event, here: Pos) {
        let path = self.record(stack, event, here);
        match event {
            Event::SequenceStart(..) => stack.push(Frame::Seq { path, next: 0 }),
            Event::MappingStart(..) => stack.push(Frame::Map { path, key: None }),
            _ => {}
        }
    }

    fn record(&mut self, stack: &mut [Frame], event: &Event, here: Pos) -> Option<String> {
        // A block collection's start marker may come after its first entry: the first child
        // moves the parent's position back.
        let (path, key_pos) = match stack.last_mut() {
            None => (Some(String::new()), None),
            Some(Frame::Map { path, key }) => match key.take() {
                None => {
                    let k = match event {
                        Event::Scalar(s, ..) => Some((s.clone(), here)),
                        _ => None,
                    };
                    *key = Some(k);
                    if let Some(p) = path.as_deref() {
                        self.pull_back(p, here);
                    }
                    // Keys are not nodes of the index; a complex key's insides are skipped.
                    return None;
                }
                Some(k) => match (path.as_deref(), k) {
                    (Some(p), Some((name, kpos))) => (Some(join_key(p, &name)), Some(kpos)),
                    _ => (None, None),
                },
            },
            Some(Frame::Seq { path, next }) => {
                let i = *next;
                *next += 1;
                let p = path.as_deref().map(|p| format!("{p}[{i}]"));
                if let Some(parent) = path.as_deref() {
                    let parent = parent.to_string();
                    self.pull_back(&parent, here);
                }
                (p, None)
            }
        };
        if let Some(p) = &path {
            if let Some(kpos) = key_pos {
                if self.keys.contains_key(p) {
                    self.duplicates.push((p.clone(), kpos));
                    return path;
                }
                self.keys.insert(p.clone(), kpos);
            }
            self.values.insert(p.clone(), here);
        }
        path
    }

    fn pull_back(&mut self, path: &str, here: Pos) {
        if let Some(p) = self.values.get_mut(path) {
            if here < *p {
                *p = here;
            }
        }
    }

    /// Position of the value at `path`, or of its nearest indexed ancestor.
    pub(crate) fn value(&self, path: &str) -> Option<Pos> {
        let mut p = path;
        loop {
            if let Some(v) = self.values.get(p) {
                return Some(*v);
            }
            p = parent(p)?;
        }
    }

    /// Position of the value at exactly `path` (no ancestor fallback).
    pub(crate) fn value_exact(&self, path: &str) -> Option<Pos> {
        self.values.get(path).copied()
    }

    /// Position of the key of the mapping entry at `path`, else of its value (or ancestor).
    pub(crate) fn key(&self, path: &str) -> Option<Pos> {
        self.keys.get(path).copied().or_else(|| self.value(path))
    }

    /// Repeated keys: (path, position of the repeat), in document order.
    pub(crate) fn duplicates(&self) -> &[(String, Pos)] {
        &self.duplicates
    }
}

/// `parent.key`, or `key` at the root: the field path of a mapping entry, as every located
/// error names it (`params.a1.nominal`).
pub fn join_key(parent: &str, key: &str) -> String {
    if parent.is_empty() {
        key.to_string()
    } else {
        format!("{parent}.{key}")
    }
}

/// `parent[i]`: the field path of a list item (`joints[1]`).
#[must_use]
pub fn join_index(parent: &str, i: usize) -> String {
    format!("{parent}[{i}]")
}

/// The enclosing path: `a.b[2]` → `a.b`, `a.b` → `a`, `a` → `` (root), root → `None`. An
/// adapter places a path it has no place for at its nearest ancestor that it has.
#[must_use]
pub fn parent(path: &str) -> Option<&str> {
    if path.is_empty() {
        return None;
    }
    if path.ends_with(']') {
        if let Some(i) = path.rfind('[') {
            return Some(&path[..i]);
        }
    }
    Some(path.rfind('.').map_or("", |i| &path[..i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
name: x
joints:
  - {type: revolute, a: a1}
  - type: prismatic
    offset: \"pi/2\"
params:
  a1: {nominal: 1}
q: [1, [2, 3]]
";

    #[test]
    fn indexes_block_and_flow_nodes() {
        let ix = crate::spec::node::parse_yaml(TEXT).unwrap().1;
        assert_eq!(ix.value("name"), Some((1, 7)));
        assert_eq!(ix.key("name"), Some((1, 1)));
        assert_eq!(ix.value("joints"), Some((3, 3)));
        assert_eq!(ix.value("joints[0]"), Some((3, 5)));
        assert_eq!(ix.value("joints[0].a"), Some((3, 25)));
        assert_eq!(ix.key("joints[0].a"), Some((3, 22)));
        assert_eq!(ix.value("joints[1]"), Some((4, 5)));
        assert_eq!(ix.value("joints[1].offset"), Some((5, 13)));
        assert_eq!(ix.value("params"), Some((7, 3)));
        assert_eq!(ix.value("params.a1.nominal"), Some((7, 17)));
        assert_eq!(ix.value("q[1][1]"), Some((8, 12)));
        assert_eq!(ix.value(""), Some((1, 1)));
    }

    #[test]
    fn falls_back_to_the_nearest_ancestor() {
        let ix = crate::spec::node::parse_yaml(TEXT).unwrap().1;
        assert_eq!(ix.value("joints[1].home"), Some((4, 5)));
        assert_eq!(ix.value("params.zz.nominal"), Some((7, 3)));
        assert_eq!(ix.key("joints[1].home"), Some((4, 5)));
    }

    #[test]
    fn skips_complex_keys_and_indexes_nothing_in_an_empty_document() {
        let ix = crate::spec::node::parse_yaml("").unwrap().1;
        assert_eq!(ix.value("a"), None);
        let ix = crate::spec::node::parse_yaml("{[1, 2]: 3, b: 4}")
            .unwrap()
            .1;
        assert_eq!(ix.value("b"), Some((1, 16)));
    }

    #[test]
    fn parent_paths() {
        assert_eq!(parent("a.b[2]"), Some("a.b"));
        assert_eq!(parent("a.b"), Some("a"));
        assert_eq!(parent("a"), Some(""));
        assert_eq!(parent(""), None);
        assert_eq!(parent("q[1][1]"), Some("q[1]"));
    }
}
