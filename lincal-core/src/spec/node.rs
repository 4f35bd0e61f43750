//! The document tree the spec walker reads, and its YAML adapter.
//!
//! The walker ([`super::load`]) reads a [`Value`] tree whose scalars are already typed (null,
//! boolean, number, string) and finds the source place of any field path in a
//! position index. This module makes both from YAML text in **one** pass of `yaml-rust2`'s
//! event parser, so the positions and the values can never disagree.
//!
//! Why `yaml-rust2`: it is maintained, pure safe Rust (no C library or `unsafe` translation
//! of one underneath, unlike `serde_yaml` 0.9, which is deprecated upstream and carries
//! `unsafe-libyaml`), and its events carry positions, which a spec loader must report. It
//! limits flow nesting itself (255 levels, an error, not a crash).
//!
//! Scalars are typed by the YAML 1.2 core schema, for plain (unquoted) scalars only: `null`,
//! `~` and the empty scalar are null; `true`/`false` booleans; decimal, `0x` and `0o`
//! integers and decimal floats (`.inf`, `.nan` included) numbers; anything else, and every
//! quoted or block scalar, a string. A tagged node (`!custom 2`) is kept as
//! [`Value::Tagged`] for the walker to reject.
//!
//! # Bounds
//! Work is bounded before it is done: nesting deeper than [`MAX_DEPTH`] and documents of more
//! than [`MAX_NODES`] nodes (aliases counted at their full size, so an alias bomb stops at
//! once) are errors at the place where the limit is crossed.

use std::collections::HashMap;
use std::fmt;

use yaml_rust2::parser::{Event, Parser};
use yaml_rust2::scanner::{Marker, TScalarStyle};

use super::locate::{Frame, Pos, SourceIndex};

/// Deepest nesting of lists and mappings a document may have (a spec needs five).
pub const MAX_DEPTH: usize = 64;

/// Most nodes a document may have, aliases expanded (a 20-joint spec has about 400).
pub const MAX_NODES: usize = 100_000;

/// A typed document node.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `null`, `~` or nothing.
    Null,
    /// `true` or `false`.
    Bool(bool),
    /// A number, with its source text.
    Number(Number),
    /// Any other scalar, and every quoted one.
    String(String),
    /// A list.
    Sequence(Vec<Value>),
    /// A mapping, entries in source order.
    Mapping(Mapping),
    /// A node with a YAML tag (`!name value`).
    Tagged(Box<TaggedValue>),
}

/// A number as written (`0.375`, `1e3`, `0x10`) and its value.
#[derive(Clone, Debug, PartialEq)]
pub struct Number {
    text: String,
    value: f64,
    int: Option<i64>,
}

impl Number {
    /// A number from its text by the YAML 1.2 core schema (`-1`, `0.375`, `1e3`, `0x10`,
    /// `.inf`), or `None` when the text is not one. Adapters other than YAML (the derive's
    /// attributes) type their literals with it, so both fronts read numbers alike.
    ///
    /// ```
    /// use lincal_core::spec::node::Number;
    /// assert_eq!(Number::parse("-0.5").and_then(|n| n.as_f64()), Some(-0.5));
    /// assert_eq!(Number::parse("3").and_then(|n| n.as_i64()), Some(3));
    /// assert!(Number::parse("pi/2").is_none());
    /// ```
    #[must_use]
    pub fn parse(text: &str) -> Option<Number> {
        number(text)
    }

    /// The value as `f64` (integers beyond 2⁵³ rounded; `±inf` and NaN as written).
    #[must_use]
    pub fn as_f64(&self) -> Option<f64> {
        Some(self.value)
    }

    /// The value, when it is an integer that fits `i64`.
    #[must_use]
    pub fn as_i64(&self) -> Option<i64> {
        self.int
    }

    /// The value, when it is a non-negative integer.
    #[must_use]
    pub fn as_u64(&self) -> Option<u64> {
        self.int.and_then(|i| u64::try_from(i).ok())
    }
}

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

/// Mapping entries in source order (keys are values: a walker reports non-string keys).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mapping {
    entries: Vec<(Value, Value)>,
}

impl Mapping {
    /// Appends an entry (a repeated key is the adapter's to report: the walker reads the
    /// first).
    pub fn push(&mut self, key: Value, value: Value) {
        self.entries.push((key, value));
    }

    /// The entries, in order, to edit (a tool that rewrites a spec tree).
    pub fn entries_mut(&mut self) -> &mut Vec<(Value, Value)> {
        &mut self.entries
    }

    /// The entries, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&Value, &Value)> {
        self.entries.iter().map(|(k, v)| (k, v))
    }

    /// The values, in order.
    pub fn values(&self) -> impl Iterator<Item = &Value> {
        self.entries.iter().map(|(_, v)| v)
    }

    /// The value of the string key `key`.
    #[must_use]
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.entries
            .iter()
            .find(|(k, _)| matches!(k, Value::String(s) if s == key))
            .map(|(_, v)| v)
    }

    /// Number of entries.
    #[must_use]
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

impl FromIterator<(Value, Value)> for Mapping {
    fn from_iter<I: IntoIterator<Item = (Value, Value)>>(iter: I) -> Self {
        Mapping {
            entries: iter.into_iter().collect(),
        }
    }
}

impl<'a> IntoIterator for &'a Mapping {
    type Item = (&'a Value, &'a Value);
    type IntoIter = std::iter::Map<
        std::slice::Iter<'a, (Value, Value)>,
        fn(&'a (Value, Value)) -> (&'a Value, &'a Value),
    >;
    fn into_iter(self) -> Self::IntoIter {
        self.entries.iter().map(|(k, v)| (k, v))
    }
}

impl Value {
    /// The string, if this is one.
    #[must_use]
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// The number as `f64`, if this is one.
    #[must_use]
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Number(n) => n.as_f64(),
            _ => None,
        }
    }

    /// The number, if this is a non-negative integer.
    #[must_use]
    pub fn as_u64(&self) -> Option<u64> {
        match self {
            Value::Number(n) => n.as_u64(),
            _ => None,
        }
    }
}

/// A tagged node: the tag as written (`!custom`) and the node.
#[derive(Clone, Debug, PartialEq)]
pub struct TaggedValue {
    /// The tag, handle and suffix.
    pub tag: String,
    /// The node it tags.
    pub value: Value,
}

/// Why a YAML text gave no tree.
#[derive(Clone, Debug, PartialEq)]
pub enum YamlError {
    /// Not YAML (the parser's message), or over a bound; at `pos` (character offset `offset`).
    At {
        /// Line and column (1-based).
        pos: Pos,
        /// Character offset from the start of the text (the parser counts characters).
        offset: usize,
        /// What is wrong.
        message: String,
    },
    /// Keys given twice in their mapping: each repeat's field path and position.
    Duplicates(Vec<(String, Pos)>),
}

fn pos(m: Marker) -> Pos {
    // yaml-rust2 counts lines from 1 and columns from 0.
    (m.line(), m.col() + 1)
}

fn at(m: Marker, message: impl Into<String>) -> YamlError {
    YamlError::At {
        pos: pos(m),
        offset: m.index(),
        message: message.into(),
    }
}

/// A collection being built.
enum Open {
    Seq(Vec<Value>, usize),
    /// Entries, the key read and waiting for its value, the anchor.
    Map(Vec<(Value, Value)>, Option<Value>, usize),
}

/// A syntax error, with the collection it happened in (the parser notices an unclosed `{`
/// or `[` only lines later, so its start is what to look at).
fn syntax(e: &yaml_rust2::ScanError, open: &[(Open, Pos)]) -> YamlError {
    let mut message = e.info().to_string();
    if let Some((o, (line, column))) = open.last() {
        let what = match o {
            Open::Seq(..) => "list",
            Open::Map(..) => "mapping",
        };
        message.push_str(&format!(
            ", in the {what} that starts at line {line}, column {column}"
        ));
    }
    at(*e.marker(), message)
}

/// Parses one YAML document into its tree: the YAML adapter's output, for tools that rewrite
/// a spec into another front's form (the derive's equivalence test) or inspect it.
///
/// # Errors
/// As the spec loader: a syntax error, a second document, a bound crossed, repeated keys.
pub fn parse_tree(text: &str) -> Result<Value, YamlError> {
    parse_yaml(text).map(|(v, _)| v)
}

/// Parses one YAML document into its tree and its position index.
///
/// # Errors
/// A syntax error, a second document, a bound crossed ([`MAX_DEPTH`], [`MAX_NODES`]), or
/// repeated keys, each with its place.
pub(crate) fn parse_yaml(text: &str) -> Result<(Value, SourceIndex), YamlError> {
    // A parser panic would be a bug in the parser; it must not take the process down.
    std::panic::catch_unwind(|| build(text)).unwrap_or_else(|_| {
        Err(YamlError::At {
            pos: (1, 1),
            offset: 0,
            message: "the YAML parser failed on this text".into(),
        })
    })
}

/// One pass over the parser's events: the tree and its position index, or the first problem.
fn build(text: &str) -> Result<(Value, SourceIndex), YamlError> {
    let mut parser = Parser::new_from_str(text);
    let mut b = Builder::default();
    loop {
        let (event, mark) = parser.next_token().map_err(|e| syntax(&e, &b.open))?;
        if matches!(event, Event::StreamEnd) {
            break;
        }
        let done = b.event(&event, mark)?;
        if b.nodes > MAX_NODES {
            return Err(at(
                mark,
                format!("the document has more than {MAX_NODES} nodes (aliases expanded)"),
            ));
        }
        if let Some(v) = done {
            b.attach(v);
        }
    }
    b.finish()
}

/// The state of [`build`]: the index being filled and its frames, the collections still
/// open (with where each starts), the anchored nodes, the nodes counted so far (aliases at
/// their full size) and the root once complete.
#[derive(Default)]
struct Builder {
    index: SourceIndex,
    frames: Vec<Frame>,
    open: Vec<(Open, Pos)>,
    anchors: HashMap<usize, Value>,
    nodes: usize,
    root: Option<Value>,
}

impl Builder {
    /// One event (not the stream's end) at `mark`: the node it completes, if any (a scalar,
    /// an alias or a closed collection); an error for a second document or nesting deeper
    /// than [`MAX_DEPTH`].
    fn event(&mut self, event: &Event, mark: Marker) -> Result<Option<Value>, YamlError> {
        Ok(match event {
            Event::StreamEnd | Event::Nothing | Event::StreamStart | Event::DocumentEnd => None,
            Event::DocumentStart => {
                if self.root.is_some() {
                    return Err(at(
                        mark,
                        "a second YAML document starts here: a spec is one document",
                    ));
                }
                None
            }
            Event::Scalar(s, style, anchor, tag) => {
                self.index.place(&mut self.frames, event, pos(mark));
                self.nodes += 1;
                let v = scalar(s, *style);
                let v = match tag {
                    Some(t) => Value::Tagged(Box::new(TaggedValue {
                        tag: format!("{}{}", t.handle, t.suffix),
                        value: v,
                    })),
                    None => v,
                };
                self.anchor(*anchor, &v);
                Some(v)
            }
            Event::Alias(id) => {
                self.index.place(&mut self.frames, event, pos(mark));
                let v = self.anchors.get(id).cloned().unwrap_or(Value::Null);
                self.nodes += size(&v);
                Some(v)
            }
            Event::SequenceStart(anchor, _) | Event::MappingStart(anchor, _) => {
                self.start_collection(event, *anchor, mark)?;
                None
            }
            Event::SequenceEnd | Event::MappingEnd => Some(self.end_collection()),
        })
    }

    /// Keeps `v` under `anchor` for later aliases (`0`: no anchor).
    fn anchor(&mut self, anchor: usize, v: &Value) {
        if anchor != 0 {
            self.anchors.insert(anchor, v.clone());
        }
    }

    /// Opens the list or mapping that `event` starts at `mark`; an error when it nests
    /// deeper than [`MAX_DEPTH`].
    fn start_collection(
        &mut self,
        event: &Event,
        anchor: usize,
        mark: Marker,
    ) -> Result<(), YamlError> {
        self.index.place(&mut self.frames, event, pos(mark));
        self.nodes += 1;
        if self.open.len() >= MAX_DEPTH {
            return Err(at(
                mark,
                format!("lists and mappings nest deeper than {MAX_DEPTH} levels here"),
            ));
        }
        let o = if matches!(event, Event::SequenceStart(..)) {
            Open::Seq(Vec::new(), anchor)
        } else {
            Open::Map(Vec::new(), None, anchor)
        };
        self.open.push((o, pos(mark)));
        Ok(())
    }

    /// Closes the innermost open collection and gives it as a node (anchored if it was).
    fn end_collection(&mut self) -> Value {
        self.index.close(&mut self.frames);
        let (v, anchor) = match self.open.pop() {
            Some((Open::Seq(items, a), _)) => (Value::Sequence(items), a),
            Some((Open::Map(entries, _, a), _)) => (Value::Mapping(Mapping { entries }), a),
            None => (Value::Null, 0),
        };
        self.anchor(anchor, &v);
        v
    }

    /// Puts a completed node in its place: the root, the next item of the open list, or the
    /// key or value of the open mapping's next entry.
    fn attach(&mut self, v: Value) {
        match self.open.last_mut() {
            None => self.root = Some(v),
            Some((Open::Seq(items, _), _)) => items.push(v),
            Some((Open::Map(entries, key, _), _)) => match key.take() {
                None => *key = Some(v),
                Some(k) => entries.push((k, v)),
            },
        }
    }

    /// The tree and its index once the stream ends; the repeated keys, if any.
    fn finish(self) -> Result<(Value, SourceIndex), YamlError> {
        if !self.index.duplicates().is_empty() {
            return Err(YamlError::Duplicates(self.index.duplicates().to_vec()));
        }
        Ok((self.root.unwrap_or(Value::Null), self.index))
    }
}

/// Nodes in `v` (itself included).
fn size(v: &Value) -> usize {
    1 + match v {
        Value::Sequence(items) => items.iter().map(size).sum(),
        Value::Mapping(m) => m.iter().map(|(k, v)| size(k) + size(v)).sum(),
        Value::Tagged(t) => size(&t.value),
        _ => 0,
    }
}

/// A scalar typed by the YAML 1.2 core schema (plain scalars only; see the module docs).
fn scalar(s: &str, style: TScalarStyle) -> Value {
    if style != TScalarStyle::Plain {
        return Value::String(s.to_string());
    }
    match s {
        "" | "~" | "null" | "Null" | "NULL" => return Value::Null,
        "true" | "True" | "TRUE" => return Value::Bool(true),
        "false" | "False" | "FALSE" => return Value::Bool(false),
        _ => {}
    }
    number(s).map_or_else(|| Value::String(s.to_string()), Value::Number)
}

/// A core-schema number: `[-+]?[0-9]+`, `0x…`, `0o…`, decimal floats with an optional
/// exponent, `[-+]?.inf`, `.nan` (with their capitalised spellings).
fn number(s: &str) -> Option<Number> {
    let make = |value: f64, int: Option<i64>| Number {
        text: s.to_string(),
        value,
        int,
    };
    let (sign, body) = match s.as_bytes().first()? {
        b'-' => (-1.0, &s[1..]),
        b'+' => (1.0, &s[1..]),
        _ => (1.0, s),
    };
    match body {
        ".inf" | ".Inf" | ".INF" => return Some(make(sign * f64::INFINITY, None)),
        ".nan" | ".NaN" | ".NAN" if sign > 0.0 && body.len() == s.len() => {
            return Some(make(f64::NAN, None))
        }
        _ => {}
    }
    if body.len() == s.len() {
        for (prefix, radix) in [("0x", 16), ("0o", 8)] {
            if let Some(digits) = s.strip_prefix(prefix) {
                // Digits of the base only (`from_str_radix` would take a sign).
                if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
                    return None;
                }
                let v = i64::from_str_radix(digits, radix).ok()?;
                return Some(make(v as f64, Some(v)));
            }
        }
    }
    let b = body.as_bytes();
    let digits = |from: usize| b[from..].iter().take_while(|c| c.is_ascii_digit()).count();
    let mut i = digits(0);
    let int_digits = i;
    let mut frac_digits = 0;
    if b.get(i) == Some(&b'.') {
        frac_digits = digits(i + 1);
        i += 1 + frac_digits;
    }
    if int_digits + frac_digits == 0 {
        return None;
    }
    let mut integral = i == int_digits;
    if matches!(b.get(i), Some(b'e' | b'E')) {
        let mut j = i + 1;
        if matches!(b.get(j), Some(b'+' | b'-')) {
            j += 1;
        }
        let e = digits(j);
        if e == 0 {
            return None;
        }
        i = j + e;
        integral = false;
    }
    if i != b.len() {
        return None;
    }
    let value: f64 = s.parse().ok()?;
    let int = if integral {
        s.parse::<i64>().ok()
    } else {
        None
    };
    Some(make(value, int))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(s: &str) -> Option<(f64, Option<i64>)> {
        number(s).map(|n| (n.value, n.int))
    }

    #[test]
    fn types_plain_scalars_by_the_core_schema() {
        assert_eq!(num("42"), Some((42.0, Some(42))));
        assert_eq!(num("-0.375"), Some((-0.375, None)));
        assert_eq!(num("1e3"), Some((1000.0, None)));
        assert_eq!(num(".5"), Some((0.5, None)));
        assert_eq!(num("5."), Some((5.0, None)));
        assert_eq!(num("0x1F"), Some((31.0, Some(31))));
        assert_eq!(num("0o17"), Some((15.0, Some(15))));
        assert_eq!(num("-.inf"), Some((f64::NEG_INFINITY, None)));
        assert!(num(".nan").is_some_and(|(v, _)| v.is_nan()));
        for s in [
            "pi", "1e", "e3", ".", "-", "1.2.3", "inf", "NaN", "1_000", "0x", "--1",
        ] {
            assert_eq!(num(s), None, "{s}");
        }
        assert_eq!(scalar("~", TScalarStyle::Plain), Value::Null);
        assert_eq!(scalar("True", TScalarStyle::Plain), Value::Bool(true));
        assert_eq!(
            scalar("0.5", TScalarStyle::DoubleQuoted),
            Value::String("0.5".into())
        );
    }

    #[test]
    fn builds_the_tree_and_the_index_in_one_pass() {
        let text = "a: [1, {b: x}]\nc: &k\n  d: 2\ne: *k\nf: !custom 3\n";
        let (v, ix) = parse_yaml(text).unwrap();
        let Value::Mapping(m) = &v else {
            panic!("{v:?}")
        };
        assert_eq!(m.len(), 4);
        assert_eq!(m.get("e"), m.get("c"));
        assert!(matches!(m.get("f"), Some(Value::Tagged(t)) if t.tag == "!custom"));
        assert_eq!(ix.value("a[1].b"), Some((1, 12)));
        assert_eq!(ix.value("c.d"), Some((3, 6)));
        assert_eq!(parse_yaml("").unwrap().0, Value::Null);
    }

    #[test]
    fn refuses_depth_size_repeats_and_a_second_document_at_their_place() {
        // Flow nesting stops in the scanner (255 levels), block and mixed nesting here.
        let deep = "[".repeat(100_000);
        let Err(YamlError::At { pos, message, .. }) = parse_yaml(&deep) else {
            panic!()
        };
        assert!(pos.1 <= 256, "{message}");
        let deep = format!("x: {}", "{a: ".repeat(100_000));
        let Err(YamlError::At { pos, message, .. }) = parse_yaml(&deep) else {
            panic!()
        };
        assert!(message.contains("64 levels") && pos.1 < 300, "{message}");
        let block: String = (0..1000)
            .map(|i| format!("{}a:\n", " ".repeat(i)))
            .collect();
        assert!(matches!(parse_yaml(&block), Err(YamlError::At { .. })));
        let bomb = "a: &a [1,1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a,*a]\n\
                    c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b,*b]\nd: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c,*c]\n\
                    e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d,*d]\n";
        assert!(
            matches!(parse_yaml(bomb), Err(YamlError::At { message, .. })
            if message.contains("nodes"))
        );
        assert_eq!(
            parse_yaml("a: 1\nb: 2\na: 3\n").err(),
            Some(YamlError::Duplicates(vec![("a".into(), (3, 1))]))
        );
        let Err(YamlError::At {
            pos,
            offset,
            message,
        }) = parse_yaml("a: 1\n---\nb: 2\n")
        else {
            panic!()
        };
        assert_eq!((pos, offset), ((2, 1), 5), "{message}");
    }
}
