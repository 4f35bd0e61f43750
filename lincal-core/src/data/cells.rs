//! The cells of a data file: a line split into fields (RFC 4180 quotes), a cell unquoted, parsed as a finite number of at most [`MAX_CELL`] in
//! magnitude (or a message saying why not), and its place (file, line, column) for errors.

use crate::error::Location;

/// Largest magnitude of a cell (radians, metres): beyond it a value is a unit or export error.
pub const MAX_CELL: f64 = 1e9;

/// The place `line` (1-based) and `field` of `file`.
pub(super) fn at(file: Option<&str>, line: Option<usize>, field: Option<&str>) -> Location {
    Location {
        file: file.map(str::to_string),
        line,
        field: field.map(str::to_string),
        ..Location::default()
    }
}

/// The fields of one line, split at the commas outside double quotes (RFC 4180: a field
/// may be wrapped in `"`, inside which `,` is text and `""` is one quote), into `spans`
/// (cleared first): each field's byte range in `text`, as written (quotes included;
/// [`unquote`] takes them off). A line without quotes is split at every comma, the fast path
/// of almost every file. One buffer serves every line of a file: no allocation per line.
///
/// # Errors
/// A message when a quote opened on this line is not closed on it (a row is one line, so a
/// quoted field cannot hold a line break), or text follows a closing quote.
pub(super) fn split_fields_into(
    text: &str,
    spans: &mut Vec<std::ops::Range<usize>>,
) -> std::result::Result<(), String> {
    spans.clear();
    let bytes = text.as_bytes();
    if !text.contains('"') {
        let mut start = 0;
        for (i, _) in bytes.iter().enumerate().filter(|(_, &b)| b == b',') {
            spans.push(start..i);
            start = i + 1;
        }
        spans.push(start..bytes.len());
        return Ok(());
    }
    let mut start = 0;
    let mut i = 0;
    loop {
        // Blanks, then a quoted field or an unquoted one, up to the next comma or the end.
        while i < bytes.len() && (bytes[i] == b' ' || bytes[i] == b'\t') {
            i += 1;
        }
        if bytes.get(i) == Some(&b'"') {
            i += 1;
            loop {
                match bytes.get(i) {
                    None => {
                        return Err(format!(
                            "a quoted field opened at column {} is not closed on this line (a \
                             row is one line; a field cannot hold a line break)",
                            spans.len() + 1
                        ))
                    }
                    Some(b'"') if bytes.get(i + 1) == Some(&b'"') => i += 2,
                    Some(b'"') => break,
                    Some(_) => i += 1,
                }
            }
            i += 1;
            while i < bytes.len() && (bytes[i] == b' ' || bytes[i] == b'\t') {
                i += 1;
            }
            if i < bytes.len() && bytes[i] != b',' {
                return Err(format!(
                    "text after the closing quote of field {} (a quote inside a quoted field \
                     is written `\"\"`)",
                    spans.len() + 1
                ));
            }
        } else {
            while i < bytes.len() && bytes[i] != b',' {
                i += 1;
            }
        }
        spans.push(start..i);
        if i >= bytes.len() {
            return Ok(());
        }
        i += 1;
        start = i;
    }
}

/// A cell without its surrounding blanks and double quotes.
pub(super) fn unquote(cell: &str) -> &str {
    let c = cell.trim();
    c.strip_prefix('"')
        .and_then(|c| c.strip_suffix('"'))
        .map_or(c, str::trim)
}

/// A finite number, or a message saying why not.
pub(super) fn parse_number(cell: &str) -> std::result::Result<f64, String> {
    if cell.is_empty() {
        return Err("empty cell: expected a number".to_string());
    }
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() && v.abs() > MAX_CELL => Err(format!(
            "`{}` is out of range: readings are radians or metres, at most {MAX_CELL:e} in magnitude",
            crate::error::excerpt(cell)
        )),
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!(
            "`{}` is not a finite number (NaN and inf are rejected)",
            crate::error::excerpt(cell)
        )),
        Err(_) => Err(format!("`{}` is not a number", crate::error::excerpt(cell))),
    }
}

#[cfg(test)]
mod tests {
    use super::{split_fields_into, unquote};

    /// The fields of `text` as string slices.
    fn split_fields(text: &str) -> Result<Vec<&str>, String> {
        let mut spans = Vec::new();
        split_fields_into(text, &mut spans)?;
        Ok(spans.into_iter().map(|r| &text[r]).collect())
    }

    #[test]
    fn splits_at_commas_outside_quotes() {
        fn f(t: &str) -> Result<Vec<&str>, String> {
            split_fields(t).map(|v| v.into_iter().map(unquote).collect())
        }
        assert_eq!(f("1,2,3").unwrap(), ["1", "2", "3"]);
        assert_eq!(f("1,\"left, right\",3").unwrap(), ["1", "left, right", "3"]);
        assert_eq!(f("\"a \"\"b\"\"\" , 2,").unwrap(), ["a \"\"b\"\"", "2", ""]);
        assert_eq!(f(" \"1.5\" ,2").unwrap(), ["1.5", "2"]);
        assert!(f("1,\"open").unwrap_err().contains("not closed"));
        assert!(f("\"a\"b,2")
            .unwrap_err()
            .contains("after the closing quote"));
    }
}
