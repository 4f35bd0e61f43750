//! Spec text with new nominals: `lincal calibrate --write-spec`.
//!
//! Only the numbers change: each `params.NAME.nominal` scalar is found with the position
//! index the loader builds ([`super::node`]), and its characters are replaced by the new
//! value (shortest decimal that reads back as the same `f64`). Comments, key order, flow or
//! block style, the `urdf:` record and every other byte stay as written. The result is
//! loaded again and each rewritten nominal compared with its value, so a spec the rewrite
//! cannot handle (a nominal behind an alias, a multi-line scalar) is an error, never a
//! silently different spec.

use super::node::parse_yaml;
use crate::error::{Error, Location, Result};

/// `text` with the nominal of each `(name, value)` replaced; `file` names it in errors.
///
/// # Errors
/// An input error when the text is not a spec; an error naming the parameter whose nominal
/// cannot be rewritten in place.
///
/// # Example
/// ```
/// use lincal_core::spec::write::with_nominals;
/// let text = "name: x  # a comment\ndim: 2\njoints:\n  - {type: revolute, a: a1}\n\
///             params:\n  a1: {nominal: 0.375}   # from the drawing\n\
///             constraint: {point: {p: [1, 0]}}\n";
/// let out = with_nominals(text, None, &[("a1".into(), 0.3751)]).unwrap();
/// assert!(out.contains("a1: {nominal: 0.3751}   # from the drawing"));
/// assert!(out.starts_with("name: x  # a comment"));
/// ```
pub fn with_nominals(text: &str, file: Option<&str>, values: &[(String, f64)]) -> Result<String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let place = |field: &str, message: String| {
        Error::input(
            Location {
                file: file.map(str::to_string),
                field: Some(field.to_string()),
                ..Location::default()
            },
            message,
        )
    };
    let (_, index) = parse_yaml(text).map_err(|_| place("", "the spec is not YAML".into()))?;
    let lines = line_starts(text);
    let mut edits: Vec<(usize, usize, String)> = Vec::new();
    for (name, v) in values {
        let field = format!("params.{name}.nominal");
        if !v.is_finite() {
            return Err(place(&field, format!("the value {v} is not finite")));
        }
        let Some((line, col)) = index.value_exact(&field) else {
            let at = index.value(&format!("params.{name}")).map(|(l, _)| l);
            return Err(place(&field, unwritten(name, at)));
        };
        let start_line = lines.get(line - 1).copied().unwrap_or(text.len());
        let rest = &text[start_line..];
        let start = start_line
            + rest
                .char_indices()
                .nth(col - 1)
                .map_or(rest.len(), |(i, _)| i);
        // A node with an anchor (`&n 0.375`) may be aliased elsewhere: not rewritten.
        let before = text[start_line..start].trim_end();
        let tagged = before
            .rsplit([' ', '\t', '{', ','])
            .next()
            .is_some_and(|t| t.starts_with('&') || t.starts_with('!'));
        let end = scalar_end(text, start)
            .filter(|_| !tagged)
            .ok_or_else(|| place(&field, "the nominal cannot be rewritten in place".into()))?;
        edits.push((start, end, num_exact(*v)));
    }
    edits.sort_by_key(|e| e.0);
    let mut out = String::with_capacity(text.len() + 16 * edits.len());
    let mut at = 0;
    for (s, e, new) in edits {
        if s < at {
            continue;
        }
        out.push_str(&text[at..s]);
        out.push_str(&new);
        at = e;
    }
    out.push_str(&text[at..]);
    // Read back: every rewritten nominal must be its value, every other one unchanged.
    let old = super::from_yaml_str(text, file)?;
    let spec = super::from_yaml_str(&out, file)?;
    for p in &old.params {
        let want = values
            .iter()
            .find(|(n, _)| *n == p.name)
            .map_or(p.nominal.to_f64(), |(_, v)| *v);
        let got = spec.param(&p.name).map(|q| q.nominal.to_f64());
        if got != Some(want) {
            return Err(place(
                &format!("params.{}.nominal", p.name),
                format!("the rewritten nominal reads back as {got:?}, not {want}"),
            ));
        }
    }
    Ok(out)
}

/// Byte offset of each line start, YAML's line breaks counted as the parser counts them:
/// `\n`, `\r\n` and a lone `\r` (a file saved with old Mac line ends).
fn line_starts(text: &str) -> Vec<usize> {
    let b = text.as_bytes();
    std::iter::once(0)
        .chain((0..b.len()).filter_map(|i| match b[i] {
            b'\n' => Some(i + 1),
            b'\r' if b.get(i + 1) != Some(&b'\n') => Some(i + 1),
            _ => None,
        }))
        .collect()
}

/// Why the nominal of `name` (its entry at line `at`) cannot be rewritten: loaded, but not
/// written where its key is, behind a YAML alias or merge key.
fn unwritten(name: &str, at: Option<usize>) -> String {
    let at = at.map_or(String::new(), |l| format!(" (line {l})"));
    format!(
        "the nominal of `{name}`{at} is not written as a value in the spec's text (a YAML \
         alias or merge key?): --write-spec rewrites each nominal where it is written, so \
         write it out"
    )
}

/// The end of the scalar starting at byte `start`: a quoted scalar's closing quote, or a
/// plain scalar up to `,`, `}`, `]`, ` #` or the end of the line (trailing blanks left).
/// `None` for an alias, an anchor or a block scalar.
fn scalar_end(text: &str, start: usize) -> Option<usize> {
    let rest = &text[start..];
    let first = rest.chars().next()?;
    match first {
        '*' | '&' | '|' | '>' | '!' => None,
        '"' => {
            let mut escaped = false;
            for (i, c) in rest.char_indices().skip(1) {
                if escaped {
                    escaped = false;
                } else if c == '\\' {
                    escaped = true;
                } else if c == '"' {
                    return Some(start + i + 1);
                } else if c == '\n' || c == '\r' {
                    return None;
                }
            }
            None
        }
        '\'' => {
            let b = rest.as_bytes();
            let mut i = 1;
            while i < b.len() {
                if b[i] == b'\'' {
                    if b.get(i + 1) == Some(&b'\'') {
                        i += 2;
                        continue;
                    }
                    return Some(start + i + 1);
                }
                if b[i] == b'\n' || b[i] == b'\r' {
                    return None;
                }
                i += 1;
            }
            None
        }
        _ => {
            let mut end = rest.len();
            let mut prev_blank = false;
            for (i, c) in rest.char_indices() {
                if c == '\n'
                    || c == '\r'
                    || c == ','
                    || c == '}'
                    || c == ']'
                    || (c == '#' && prev_blank)
                {
                    end = i;
                    break;
                }
                prev_blank = c == ' ' || c == '\t';
            }
            Some(start + rest[..end].trim_end().len())
        }
    }
}

/// A number as spec and URDF text: the shortest decimal that reads back as exactly `v`.
#[must_use]
pub fn num_exact(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v:?}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = "# head comment\nname: two\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  - type: revolute\n    a: a2\nparams:\n  a1: {nominal: 0.375}   # drawing\n  th1:\n    nominal: \"pi/2\"  # quoted\n  a2: {nominal: 0.425, known: true}\nconstraint:\n  line: {b: [-2, -0.5]}\n";

    #[test]
    fn rewrites_only_the_numbers() {
        let out = with_nominals(
            SPEC,
            None,
            &[("a1".into(), 0.1 + 0.2), ("th1".into(), -1.5e-7)],
        )
        .unwrap();
        assert_eq!(
            out,
            SPEC.replace("0.375", "0.30000000000000004")
                .replace("\"pi/2\"", "-1.5e-7")
        );
    }

    /// Windows (`\r\n`) and old Mac (`\r`) line ends are line ends, as the YAML parser
    /// counts them: each nominal is found on its own line and rewritten in place.
    #[test]
    fn every_kind_of_line_end() {
        for end in ["\r\n", "\r"] {
            let text = SPEC.replace('\n', end);
            let out = with_nominals(&text, None, &[("a1".into(), 0.5), ("th1".into(), 2.0)])
                .unwrap_or_else(|e| panic!("{end:?}: {e}"));
            assert_eq!(
                out,
                text.replace("0.375", "0.5").replace("\"pi/2\"", "2.0"),
                "{end:?}"
            );
        }
    }

    #[test]
    fn refuses_what_it_cannot_place() {
        let err = with_nominals(SPEC, Some("s.yaml"), &[("zz".into(), 1.0)]).unwrap_err();
        assert!(err.to_string().contains("params.zz.nominal"), "{err}");
        let aliased = SPEC.replace("{nominal: 0.375}", "{nominal: &n 0.375}");
        assert!(with_nominals(&aliased, None, &[("a1".into(), 1.0)]).is_err());
    }
}
