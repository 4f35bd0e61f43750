//! The header row of a data file: each name's role, duplicates, missing and unknown columns,
//! a file of another dialect; or the columns given for a file without one (`--columns`).
//! Takes the header's cells, gives the roles and names of the columns.

use std::collections::HashMap;

use super::layout::{Col, CsvLayout, ORIENTATION_NAMES};
use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};

impl CsvLayout {
    /// The header given by `--columns` for files without a header row, if any: errors in
    /// its names name the option (one message), not a line of the file.
    pub(super) fn given_header(
        &self,
        file: Option<&str>,
    ) -> Result<Option<(Vec<Col>, Vec<String>)>> {
        let Some(names) = &self.columns else {
            return Ok(None);
        };
        let record: Vec<&str> = names.iter().map(String::as_str).collect();
        let header = self.header(&record, 0, file).map_err(|e| {
            // At most MAX_SHOWN problems echoed, then how many more (60 000 bad names must
            // not print megabytes).
            let all = e.diagnostics();
            let shown = crate::error::MAX_SHOWN;
            let mut message = all
                .iter()
                .take(shown)
                .map(|d| d.message.clone())
                .collect::<Vec<_>>()
                .join("; ");
            if all.len() > shown {
                let _ = std::fmt::Write::write_fmt(
                    &mut message,
                    format_args!("; … and {} more problems in `--columns`", all.len() - shown),
                );
            }
            Error::input(
                Location {
                    file: file.map(str::to_string),
                    field: Some("--columns".to_string()),
                    ..Location::default()
                },
                message,
            )
        })?;
        Ok(Some(header))
    }

    /// Parses the header row: every column classified, no duplicates, nothing missing.
    pub(super) fn header(
        &self,
        record: &[&str],
        line: usize,
        file: Option<&str>,
    ) -> Result<(Vec<Col>, Vec<String>)> {
        other_dialect(record, line, file)?;
        let mut problems = Vec::new();
        let (cols, names, seen) = self.header_columns(record, line, file, &mut problems);
        self.missing_columns(&seen, line, file, &mut problems);
        if problems.is_empty() {
            Ok((cols, names))
        } else {
            Err(Error::from_diagnostics(ErrorClass::Input, problems))
        }
    }

    /// Each header name's role and name (an unknown column reported and ignored, a repeated
    /// one reported, as is a joint named both ways: `q2` and its URDF name), and the column
    /// of each role, for [`Self::missing_columns`].
    fn header_columns(
        &self,
        record: &[&str],
        line: usize,
        file: Option<&str>,
        problems: &mut Vec<Diagnostic>,
    ) -> (Vec<Col>, Vec<String>, HashMap<Col, usize>) {
        let mut seen: HashMap<Col, usize> = HashMap::new();
        let mut cols = Vec::with_capacity(record.len());
        let mut names = Vec::with_capacity(record.len());
        for (i, &name) in record.iter().enumerate() {
            let place = Location {
                file: file.map(str::to_string),
                line: Some(line),
                field: Some(crate::error::excerpt(name).into_owned()),
                ..Location::default()
            };
            let col = self.classify(name);
            match col {
                None => problems.push(Diagnostic {
                    location: place,
                    message: format!(
                        "unknown column `{}` (column {}): expected {} (extra columns must start with `_`)",
                        crate::error::excerpt(name),
                        i + 1,
                        self.expected_names().join(", ")
                    ),
                }),
                Some(Col::Ignored) => {}
                Some(c) => {
                    if let Some(first) = seen.insert(c, i) {
                        problems.push(Diagnostic {
                            location: place,
                            message: repeated(c, record[first], name, first, i),
                        });
                    }
                }
            }
            cols.push(col.unwrap_or(Col::Ignored));
            names.push(name.to_string());
        }
        (cols, names, seen)
    }

    /// An expected column the header lacks (only the joints when only they are read).
    fn missing_columns(
        &self,
        seen: &HashMap<Col, usize>,
        line: usize,
        file: Option<&str>,
        problems: &mut Vec<Diagnostic>,
    ) {
        if self.pose && !self.joints_only {
            self.orientation_columns(seen, line, file, problems);
        }
        for (col, expected) in self.expected_columns() {
            if matches!(col, Col::Orientation(_)) {
                continue; // judged above: either form
            }
            let needed = !self.joints_only || matches!(col, Col::Joint(_));
            if needed && !seen.contains_key(&col) {
                let or = self
                    .alias(col)
                    .map_or(String::new(), |a| format!(" (or `{a}`)"));
                problems.push(Diagnostic {
                    location: Location {
                        file: file.map(str::to_string),
                        line: Some(line),
                        field: Some(expected.clone()),
                        ..Location::default()
                    },
                    message: format!("missing column `{expected}`{or} in the header"),
                });
            }
        }
    }
}

impl CsvLayout {
    /// A measured pose's orientation columns: all of one form, `qw, qx, qy, qz` or
    /// `rx, ry, rz`, not a mix of both, none missing.
    fn orientation_columns(
        &self,
        seen: &HashMap<Col, usize>,
        line: usize,
        file: Option<&str>,
        problems: &mut Vec<Diagnostic>,
    ) {
        let has = |i: usize| seen.contains_key(&Col::Orientation(i));
        let quaternion: Vec<usize> = (0..4).filter(|&i| has(i)).collect();
        let vector: Vec<usize> = (4..7).filter(|&i| has(i)).collect();
        let place = |field: &str| Location {
            file: file.map(str::to_string),
            line: Some(line),
            field: Some(field.to_string()),
            ..Location::default()
        };
        let names = |ix: &[usize]| {
            ix.iter()
                .map(|&i| ORIENTATION_NAMES[i])
                .collect::<Vec<_>>()
                .join(", ")
        };
        match (quaternion.is_empty(), vector.is_empty()) {
            (false, false) => problems.push(Diagnostic {
                location: place(ORIENTATION_NAMES[vector[0]]),
                message: format!(
                    "the orientation is given both as a quaternion ({}) and as a rotation \
                     vector ({}): keep one form, `qw, qx, qy, qz` or `rx, ry, rz`",
                    names(&quaternion),
                    names(&vector)
                ),
            }),
            (true, true) => problems.push(Diagnostic {
                location: place("qw"),
                message: "missing the measured orientation in the header: columns `qw, qx, \
                          qy, qz` (a unit quaternion, scalar first) or `rx, ry, rz` (a rotation \
                          vector, radians)"
                    .into(),
            }),
            (false, true) | (true, false) => {
                let (range, form) = if vector.is_empty() {
                    (0..4, "quaternion")
                } else {
                    (4..7, "rotation vector")
                };
                for i in range.filter(|&i| !has(i)) {
                    problems.push(Diagnostic {
                        location: place(ORIENTATION_NAMES[i]),
                        message: format!(
                            "missing column `{}` of the measured orientation's {form}",
                            ORIENTATION_NAMES[i]
                        ),
                    });
                }
            }
        }
    }
}

/// The message for a second column of role `col`: the same name twice, or a joint named
/// both ways (`q2` and its URDF joint name).
fn repeated(col: Col, first_name: &str, name: &str, first: usize, i: usize) -> String {
    let (a, b) = (
        crate::error::excerpt(first_name),
        crate::error::excerpt(name),
    );
    match col {
        Col::Joint(j) if first_name != name => format!(
            "columns `{a}` (column {}) and `{b}` (column {}) are the same joint q{}: name each \
             joint once, as `q{}` or by its URDF joint name",
            first + 1,
            i + 1,
            j + 1,
            j + 1
        ),
        _ => format!(
            "duplicate column `{b}` (columns {} and {})",
            first + 1,
            i + 1
        ),
    }
}

/// A header of one column that holds the separators of another dialect (semicolons, tabs,
/// bars): an error saying so, rather than "unknown column".
fn other_dialect(record: &[&str], line: usize, file: Option<&str>) -> Result<()> {
    if let [only] = record {
        for (sep, what) in [(';', "semicolons"), ('\t', "tabs"), ('|', "bars")] {
            if only.contains(sep) {
                return Err(Error::input(
                    Location {
                        file: file.map(str::to_string),
                        line: Some(line),
                        ..Location::default()
                    },
                    format!(
                        "the header is one column separated by {what}: lincal reads \
                         comma-separated values (`q1,q2,...`); convert the file (and write \
                         decimals with a point)"
                    ),
                ));
            }
        }
    }
    Ok(())
}
