//! One cell of a data file: unquoted, parsed as a finite number of at most [`MAX_CELL`] in
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
