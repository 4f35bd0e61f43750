//! Calibration data: poses read from CSV (see `shared/interface.md`, "Data (CSV)").
//!
//! The file has a header row, then one pose per row. Columns, in any order:
//! - `q1, …, qn`: the joint readings (radians for revolute joints, metres for prismatic ones);
//! - `x, y(, z)`: the measured tip, required when any constraint of the spec is `measured`;
//! - `constraint`: the 0-based index of the constraint the pose lies on, required exactly when
//!   the spec has a list (`constraints:`).
//!
//! Columns whose name starts with `_` are ignored; any other extra column is an error, and so
//! is a missing one. Lines starting with `#` are comments; blank lines are skipped. Every cell
//! must be a finite number (NaN and infinities are rejected); a bad cell is an
//! [`ErrorClass::Input`](crate::error::ErrorClass::Input) error naming the file, the line and
//! the column.

use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::Path;

use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};
use crate::geometry::ConstraintKind;
use crate::model::CalibModel;

/// The poses of one data set.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Poses {
    /// Joint readings, one `Vec` of `n` values per pose.
    pub q: Vec<Vec<f64>>,
    /// Measured tips (`x, y(, z)`), one per pose, for `measured` constraints. Present when
    /// any constraint of the model is `measured`; a pose on a constraint that is not measured
    /// may have an empty entry (its `x, y(, z)` cells were left blank).
    pub measured: Option<Vec<Vec<f64>>>,
    /// The constraint each pose lies on (index into the spec's list; all 0 for one constraint).
    pub constraint: Vec<usize>,
    /// 1-based line of each pose in its file, for messages.
    pub line: Vec<usize>,
}

impl Poses {
    /// Number of poses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// The poses at `indices` (in that order), with their lines.
    #[must_use]
    pub fn select(&self, indices: &[usize]) -> Poses {
        Poses {
            q: indices.iter().map(|&l| self.q[l].clone()).collect(),
            measured: self
                .measured
                .as_ref()
                .map(|m| indices.iter().map(|&l| m[l].clone()).collect()),
            constraint: indices.iter().map(|&l| self.constraint[l]).collect(),
            line: indices
                .iter()
                .map(|&l| self.line.get(l).copied().unwrap_or(0))
                .collect(),
        }
    }

    /// Reads poses from a CSV file for `model` (see the module docs for the format).
    /// `constraint_list` says whether the spec has a list of constraints (`constraints:`),
    /// which makes the `constraint` column required.
    ///
    /// # Errors
    /// [`ErrorClass::Input`] naming the file, line and column of the first bad cell, a
    /// missing or unknown column, or a file that cannot be read.
    pub fn from_csv_path(
        path: &Path,
        model: &dyn CalibModel,
        constraint_list: bool,
    ) -> Result<Poses> {
        let name = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| {
            Error::input(
                Location {
                    file: Some(name.clone()),
                    ..Location::default()
                },
                format!("cannot read data file: {e}"),
            )
        })?;
        Self::from_csv_reader(file, Some(&name), model, constraint_list)
    }

    /// Parses CSV text (see [`Poses::from_csv_path`]); `file` names the source in errors.
    ///
    /// # Errors
    /// As [`Poses::from_csv_path`].
    pub fn from_csv_str(
        text: &str,
        file: Option<&str>,
        model: &dyn CalibModel,
        constraint_list: bool,
    ) -> Result<Poses> {
        Self::from_csv_reader(text.as_bytes(), file, model, constraint_list)
    }

    /// Parses CSV from any reader (streamed: the text is never held whole in memory).
    ///
    /// # Errors
    /// As [`Poses::from_csv_path`].
    pub fn from_csv_reader<R: Read>(
        reader: R,
        file: Option<&str>,
        model: &dyn CalibModel,
        constraint_list: bool,
    ) -> Result<Poses> {
        CsvLayout::new(model, constraint_list).read(reader, file)
    }
}

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Col {
    Joint(usize),
    Tip(usize),
    Constraint,
    Ignored,
}

/// The columns the model expects.
struct CsvLayout {
    joints: usize,
    dim: usize,
    measured: Vec<bool>,
    constraint_count: usize,
    constraint_list: bool,
}

const TIP_NAMES: [&str; 3] = ["x", "y", "z"];

impl CsvLayout {
    fn new(model: &dyn CalibModel, constraint_list: bool) -> Self {
        let constraint_count = model.constraint_count();
        CsvLayout {
            joints: model.joint_count(),
            dim: model.dim(),
            measured: (0..constraint_count)
                .map(|j| model.constraint_kind(j) == ConstraintKind::Measured)
                .collect(),
            constraint_count,
            constraint_list,
        }
    }

    fn any_measured(&self) -> bool {
        self.measured.iter().any(|&m| m)
    }

    /// The expected role of a header name, or `None` for an unknown column.
    fn classify(&self, name: &str) -> Option<Col> {
        if name.starts_with('_') {
            return Some(Col::Ignored);
        }
        if let Some(rest) = name.strip_prefix('q') {
            if let Ok(i) = rest.parse::<usize>() {
                if i >= 1 && i <= self.joints && rest == i.to_string() {
                    return Some(Col::Joint(i - 1));
                }
            }
        }
        if self.any_measured() {
            if let Some(i) = TIP_NAMES[..self.dim].iter().position(|&t| t == name) {
                return Some(Col::Tip(i));
            }
        }
        if self.constraint_list && name == "constraint" {
            return Some(Col::Constraint);
        }
        None
    }

    fn expected_names(&self) -> Vec<String> {
        let mut names: Vec<String> = (1..=self.joints).map(|i| format!("q{i}")).collect();
        if self.any_measured() {
            names.extend(TIP_NAMES[..self.dim].iter().map(|s| (*s).to_string()));
        }
        if self.constraint_list {
            names.push("constraint".to_string());
        }
        names
    }

    fn read<R: Read>(&self, reader: R, file: Option<&str>) -> Result<Poses> {
        let loc = |line: Option<usize>, field: Option<&str>| Location {
            file: file.map(str::to_string),
            line,
            field: field.map(str::to_string),
            ..Location::default()
        };
        // Lines are read one by one (not with the csv crate: its reader skips blank lines
        // and comments without reporting where, so its record line numbers drift); cells are
        // separated by commas, trimmed, and may be wrapped in double quotes.
        let mut reader = std::io::BufReader::new(reader);
        let mut columns: Option<Vec<Col>> = None;
        let mut header_names: Vec<String> = Vec::new();
        let mut poses = Poses {
            measured: self.any_measured().then(Vec::new),
            ..Poses::default()
        };
        let mut buf = Vec::new();
        let mut line = 0usize;
        loop {
            buf.clear();
            let read = reader.read_until(b'\n', &mut buf).map_err(|e| {
                Error::input(
                    loc(Some(line + 1), None),
                    format!("cannot read the data: {e}"),
                )
            })?;
            if read == 0 {
                break;
            }
            line += 1;
            let text = std::str::from_utf8(&buf)
                .map_err(|_| Error::input(loc(Some(line), None), "the line is not valid UTF-8"))?;
            let text = if line == 1 {
                text.trim_start_matches('\u{feff}')
            } else {
                text
            };
            let text = text.trim();
            // Blank lines are skipped; a line starting with `#` is a comment.
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let record: Vec<&str> = text.split(',').map(unquote).collect();
            let Some(cols) = &columns else {
                let (cols, names) = self.header(&record, line, file)?;
                columns = Some(cols);
                header_names = names;
                continue;
            };
            if record.len() != cols.len() {
                return Err(Error::input(
                    loc(Some(line), None),
                    format!(
                        "expected {} fields (as in the header), found {}",
                        cols.len(),
                        record.len()
                    ),
                ));
            }
            let mut q = vec![0.0; self.joints];
            let mut tip = vec![None; self.dim];
            let mut constraint = 0usize;
            for ((&cell, col), name) in record.iter().zip(cols).zip(&header_names) {
                match *col {
                    Col::Ignored => {}
                    Col::Joint(i) => {
                        q[i] = parse_number(cell)
                            .map_err(|m| Error::input(loc(Some(line), Some(name)), m))?
                    }
                    Col::Tip(i) => {
                        if !cell.is_empty() {
                            tip[i] = Some(
                                parse_number(cell)
                                    .map_err(|m| Error::input(loc(Some(line), Some(name)), m))?,
                            );
                        }
                    }
                    Col::Constraint => {
                        constraint = cell.parse::<usize>().map_err(|_| {
                            Error::input(
                                loc(Some(line), Some(name)),
                                format!(
                                    "`{cell}` is not a constraint index (an integer from 0 to {})",
                                    self.constraint_count.saturating_sub(1)
                                ),
                            )
                        })?;
                        if constraint >= self.constraint_count {
                            return Err(Error::input(
                                loc(Some(line), Some(name)),
                                format!(
                                    "constraint index {constraint} is out of range: the spec has {} constraint(s), indices 0 to {}",
                                    self.constraint_count,
                                    self.constraint_count.saturating_sub(1)
                                ),
                            ));
                        }
                    }
                }
            }
            if let Some(measured) = &mut poses.measured {
                let values: Vec<f64> = tip.iter().flatten().copied().collect();
                if self.measured[constraint] {
                    if let Some(i) = tip.iter().position(Option::is_none) {
                        return Err(Error::input(
                            loc(Some(line), Some(TIP_NAMES[i])),
                            "empty cell: the measured tip coordinate is required on a measured constraint",
                        ));
                    }
                    measured.push(values);
                } else if values.len() == self.dim {
                    measured.push(values);
                } else {
                    measured.push(Vec::new());
                }
            }
            poses.q.push(q);
            poses.constraint.push(constraint);
            poses.line.push(line);
        }
        if columns.is_none() {
            return Err(Error::input(
                loc(None, None),
                format!(
                    "no header row: expected the columns {}",
                    self.expected_names().join(", ")
                ),
            ));
        }
        Ok(poses)
    }

    /// Parses the header row: every column classified, no duplicates, nothing missing.
    fn header(
        &self,
        record: &[&str],
        line: usize,
        file: Option<&str>,
    ) -> Result<(Vec<Col>, Vec<String>)> {
        let mut problems = Vec::new();
        let mut seen: HashMap<String, usize> = HashMap::new();
        let mut cols = Vec::with_capacity(record.len());
        let mut names = Vec::with_capacity(record.len());
        for (i, &name) in record.iter().enumerate() {
            let place = Location {
                file: file.map(str::to_string),
                line: Some(line),
                field: Some(name.to_string()),
                ..Location::default()
            };
            let col = self.classify(name);
            match col {
                None => problems.push(Diagnostic {
                    location: place,
                    message: format!(
                        "unknown column `{name}` (column {}): expected {} (extra columns must start with `_`)",
                        i + 1,
                        self.expected_names().join(", ")
                    ),
                }),
                Some(Col::Ignored) => {}
                Some(_) => {
                    if let Some(first) = seen.insert(name.to_string(), i) {
                        problems.push(Diagnostic {
                            location: place,
                            message: format!(
                                "duplicate column `{name}` (columns {} and {})",
                                first + 1,
                                i + 1
                            ),
                        });
                    }
                }
            }
            cols.push(col.unwrap_or(Col::Ignored));
            names.push(name.to_string());
        }
        for expected in self.expected_names() {
            if !seen.contains_key(&expected) {
                problems.push(Diagnostic {
                    location: Location {
                        file: file.map(str::to_string),
                        line: Some(line),
                        field: Some(expected.clone()),
                        ..Location::default()
                    },
                    message: format!("missing column `{expected}` in the header"),
                });
            }
        }
        if problems.is_empty() {
            Ok((cols, names))
        } else {
            Err(Error::from_diagnostics(ErrorClass::Input, problems))
        }
    }
}

/// A cell without its surrounding blanks and double quotes.
fn unquote(cell: &str) -> &str {
    let c = cell.trim();
    c.strip_prefix('"')
        .and_then(|c| c.strip_suffix('"'))
        .map_or(c, str::trim)
}

/// A finite number, or a message saying why not.
fn parse_number(cell: &str) -> std::result::Result<f64, String> {
    if cell.is_empty() {
        return Err("empty cell: expected a number".to_string());
    }
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!(
            "`{cell}` is not a finite number (NaN and inf are rejected)"
        )),
        Err(_) => Err(format!("`{cell}` is not a number")),
    }
}
