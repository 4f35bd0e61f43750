//! The error type: every problem carries its place (file, line, column, field path, pose
//! index) and what was expected. Validation collects all problems at once, so one run shows
//! every mistake in a spec.
//!
//! The CLI maps [`ErrorClass::Input`] to exit status 2 and everything else to 1.

use std::fmt;

/// What kind of failure this is, which decides the CLI's exit status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorClass {
    /// Bad input: a spec, data file or option that is wrong (exit 2).
    Input,
    /// Valid input that cannot be calibrated: too few poses, a frozen joint, lost rank (exit 1).
    Degenerate,
    /// Anything else: I/O, a numerical failure (exit 1).
    Other,
}

/// Where a problem is.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Location {
    /// File path, when the input came from a file.
    pub file: Option<String>,
    /// 1-based line.
    pub line: Option<usize>,
    /// 1-based column.
    pub column: Option<usize>,
    /// Field path, e.g. `joints[1].home` or `params.a1.nominal`, or a data column name.
    pub field: Option<String>,
    /// 0-based pose index (data row), for data problems.
    pub pose: Option<usize>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts: Vec<String> = Vec::new();
        let mut head = String::new();
        if let Some(file) = &self.file {
            head.push_str(file);
        }
        if let Some(line) = self.line {
            if !head.is_empty() {
                head.push(':');
            }
            head.push_str(&line.to_string());
            if let Some(col) = self.column {
                head.push(':');
                head.push_str(&col.to_string());
            }
        }
        if !head.is_empty() {
            parts.push(head);
        }
        if let Some(field) = &self.field {
            parts.push(format!("field `{field}`"));
        }
        if let Some(pose) = self.pose {
            parts.push(format!("pose {pose}"));
        }
        f.write_str(&parts.join(": "))
    }
}

/// One located problem.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Where.
    pub location: Location,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for Diagnostic {
    /// `place: message`, every control character but the line feed and tab written as an
    /// escape (`\u{1b}`), so a value echoed from an input can never drive the terminal
    /// (set its title, move the cursor, rewrite a line with a carriage return).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let loc = self.location.to_string();
        if !loc.is_empty() {
            write_printable(f, &loc)?;
            f.write_str(": ")?;
        }
        write_printable(f, &self.message)
    }
}

/// Writes `s` with every control character except `\n` and `\t` escaped.
fn write_printable(f: &mut fmt::Formatter<'_>, s: &str) -> fmt::Result {
    for c in s.chars() {
        if c.is_control() && c != '\n' && c != '\t' {
            write!(f, "{}", c.escape_default())?;
        } else {
            fmt::Write::write_char(f, c)?;
        }
    }
    Ok(())
}

/// Most diagnostics an error shows; the rest are counted (a file with thousands of bad
/// columns gives the first of them and how many more, not megabytes).
pub const MAX_SHOWN: usize = 20;

/// A lincal error: a class and one or more located diagnostics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    class: ErrorClass,
    diagnostics: Vec<Diagnostic>,
}

impl Error {
    /// A bad-input error at a place.
    #[must_use]
    pub fn input(location: Location, message: impl Into<String>) -> Self {
        Self::new(ErrorClass::Input, location, message)
    }

    /// A degenerate-data error (exit 1), with the reason.
    #[must_use]
    pub fn degenerate(message: impl Into<String>) -> Self {
        Self::new(ErrorClass::Degenerate, Location::default(), message)
    }

    /// Any other failure.
    #[must_use]
    pub fn other(message: impl Into<String>) -> Self {
        Self::new(ErrorClass::Other, Location::default(), message)
    }

    /// An error of a class at a place.
    #[must_use]
    pub fn new(class: ErrorClass, location: Location, message: impl Into<String>) -> Self {
        Error {
            class,
            diagnostics: vec![Diagnostic {
                location,
                message: message.into(),
            }],
        }
    }

    /// Several bad-input diagnostics reported together (must not be empty).
    #[must_use]
    pub fn from_diagnostics(class: ErrorClass, diagnostics: Vec<Diagnostic>) -> Self {
        Error { class, diagnostics }
    }

    /// The class, which decides the exit status.
    #[must_use]
    pub fn class(&self) -> ErrorClass {
        self.class
    }

    /// Every located problem.
    #[must_use]
    pub fn diagnostics(&self) -> &[Diagnostic] {
        &self.diagnostics
    }

    /// Renames the field `from` to `to` on every diagnostic that names it (an option of one
    /// command that another reads from a file: `--base` of `import` is the spec's
    /// `urdf.base` for `--write-urdf`).
    #[must_use]
    pub fn field_renamed(mut self, from: &str, to: &str) -> Self {
        for d in &mut self.diagnostics {
            if d.location.field.as_deref() == Some(from) {
                d.location.field = Some(to.to_string());
            }
        }
        self
    }

    /// Adds `note` to the last diagnostic's message (what else the input holds that may
    /// explain the failure: joint readings far outside the spec's limits behind a fit that
    /// cannot determine its parameters).
    #[must_use]
    pub fn with_note(mut self, note: &str) -> Self {
        if let Some(d) = self.diagnostics.last_mut() {
            d.message = format!("{}; {note}", d.message);
        }
        self
    }

    /// Sets the file on every diagnostic that has none.
    #[must_use]
    pub fn in_file(mut self, file: &str) -> Self {
        for d in &mut self.diagnostics {
            if d.location.file.is_none() {
                d.location.file = Some(file.to_string());
            }
        }
        self
    }
}

impl fmt::Display for Error {
    /// One diagnostic a line, at most [`MAX_SHOWN`] of them, then how many more there are.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().take(MAX_SHOWN).enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        let more = self.diagnostics.len().saturating_sub(MAX_SHOWN);
        if more > 0 {
            write!(
                f,
                "\n… and {more} more problem{} of the same run (the first {MAX_SHOWN} are shown)",
                if more == 1 { "" } else { "s" }
            )?;
        }
        Ok(())
    }
}

impl std::error::Error for Error {}

/// Reads a whole input file of at most `limit` bytes (never more: `/dev/zero` or a stray
/// multi-gigabyte file stops at the limit); a failure is an input error naming the file and
/// `what` it is.
///
/// # Errors
/// [`ErrorClass::Input`] when the file cannot be read, is longer than `limit` bytes, or is
/// not UTF-8 (with the byte offset and line of the first bad byte).
pub fn read_input_file(path: &std::path::Path, what: &str, limit: usize) -> Result<String> {
    use std::io::Read;
    let place = |line: Option<usize>| Location {
        file: Some(path.display().to_string()),
        line,
        ..Location::default()
    };
    let fail =
        |e: std::io::Error| Error::input(place(None), format!("cannot read the {what}: {e}"));
    let file = std::fs::File::open(path).map_err(fail)?;
    let mut bytes = Vec::new();
    file.take(limit as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(fail)?;
    if bytes.len() > limit {
        return Err(Error::input(
            place(None),
            format!("the {what} is longer than {limit} bytes, the most a {what} may have"),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::input(
            place(Some(line)),
            format!("the {what} is not UTF-8 text: invalid byte at offset {at}"),
        )
    })
}

/// At most the first 40 characters of a value echoed in a message (with `…` when cut), so a
/// megabyte-long cell or string never floods the terminal.
#[must_use]
pub fn excerpt(s: &str) -> std::borrow::Cow<'_, str> {
    const MAX: usize = 40;
    match s.char_indices().nth(MAX) {
        Some((i, _)) => std::borrow::Cow::Owned(format!("{}…", &s[..i])),
        None => std::borrow::Cow::Borrowed(s),
    }
}

/// `Result` with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_errors_capped() {
        let place = Location {
            file: Some("a\rb.csv".into()),
            field: Some("\u{1b}]0;t\u{7}".into()),
            ..Location::default()
        };
        let e = Error::input(place, "line one\nline two\u{9b}");
        let s = e.to_string();
        assert!(!s.chars().any(|c| c.is_control() && c != '\n'), "{s:?}");
        assert!(
            s.contains("a\\rb.csv") && s.contains("\\u{1b}]0;t\\u{7}"),
            "{s}"
        );
        assert!(s.contains("line one\nline two\\u{9b}"), "{s}");
        let many: Vec<Diagnostic> = (0..1000)
            .map(|i| Diagnostic {
                location: Location::default(),
                message: format!("problem {i}"),
            })
            .collect();
        let s = Error::from_diagnostics(ErrorClass::Input, many).to_string();
        assert_eq!(s.lines().count(), MAX_SHOWN + 1);
        assert!(s.ends_with("… and 980 more problems of the same run (the first 20 are shown)"));
    }
}
