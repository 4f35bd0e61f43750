//! The streamed reader: a data file's lines, header first, each row's cells parsed and
//! checked and appended to [`Poses`]; the storage sized once from the first lines.

use std::io::Read;

use super::cells::{at, parse_number, split_fields_into, unquote};
use super::layout::{Col, CsvLayout, ORIENTATION_NAMES, TIP_NAMES};
use super::lines::{line_text, read_line};
use super::poses::Poses;
use super::rows::Rows;
use crate::error::{Error, Location, Result};

impl CsvLayout {
    /// Reads the poses; `size`, the input's length in bytes when known, sizes the storage
    /// once from the first lines' mean length (so a million rows are not copied on growth).
    pub(super) fn read<R: Read>(
        &self,
        reader: R,
        file: Option<&str>,
        size: Option<u64>,
    ) -> Result<Poses> {
        // Lines are read one by one (not with the csv crate: its reader skips blank lines
        // and comments without reporting where, so its record line numbers drift); cells are
        // separated by commas, trimmed, and may be wrapped in double quotes.
        let mut reader = std::io::BufReader::new(reader);
        let mut header = self.given_header(file)?;
        let mut poses = Poses {
            q: Rows::new(self.joints),
            measured: self
                .any_measured()
                .then(|| Rows::new(self.measured_width())),
            ..Poses::default()
        };
        let mut row = RowBuf {
            q: vec![0.0; self.joints],
            tip: vec![None; self.dim],
            orientation: [None; 7],
            values: Vec::with_capacity(self.measured_width()),
        };
        let mut buf = Vec::new();
        // Each line's fields, as byte ranges of its text (one buffer for every line).
        let mut spans = Vec::new();
        let mut line = 0usize;
        let mut consumed = 0u64;
        const SAMPLE_LINES: usize = 64;
        loop {
            let read = read_line(&mut reader, &mut buf, file, line + 1)?;
            if read == 0 {
                break;
            }
            line += 1;
            consumed += read as u64;
            if line == SAMPLE_LINES {
                if let Some(size) = size {
                    let rows = size.saturating_sub(consumed) / (consumed / line as u64).max(1);
                    // At most what a file of this size can hold (one byte per row at least).
                    let rows = usize::try_from(rows + rows / 32 + 16).unwrap_or(0);
                    poses.reserve(rows);
                }
            }
            let Some(text) = line_text(&buf, file, line)? else {
                continue;
            };
            split_fields_into(text, &mut spans)
                .map_err(|m| Error::input(at(file, Some(line), None), m))?;
            let Some(columns) = &header else {
                let record: Vec<&str> = spans.iter().map(|r| unquote(&text[r.clone()])).collect();
                header = Some(self.header(&record, line, file)?);
                continue;
            };
            let constraint = self.parse_row(text, &spans, columns, file, line, &mut row)?;
            self.push_row(&mut poses, &mut row, constraint, file, line)?;
        }
        if header.is_none() {
            return Err(Error::input(
                at(file, None, None),
                format!(
                    "no header row: expected the columns {}",
                    self.expected_names().join(", ")
                ),
            ));
        }
        Ok(poses)
    }

    /// Reads one data row's cells (`record`: the fields' byte ranges in `text`) into `row`
    /// (joint readings, tip coordinates, empty tip cells as `None`) and returns its
    /// constraint index; the row has as many fields as the header, every number parses and
    /// the constraint index is in range.
    fn parse_row(
        &self,
        text: &str,
        record: &[std::ops::Range<usize>],
        (cols, names): &(Vec<Col>, Vec<String>),
        file: Option<&str>,
        line: usize,
        row: &mut RowBuf,
    ) -> Result<usize> {
        if record.len() != cols.len() {
            // A decimal comma splits numbers into more fields than the header has.
            let hint = if record.len() > cols.len() {
                "; a decimal comma (`1,5`)? write decimals with a point, `1.5`"
            } else {
                ""
            };
            return Err(Error::input(
                at(file, Some(line), None),
                format!(
                    "expected {} fields (as in the header), found {}{hint}",
                    cols.len(),
                    record.len()
                ),
            ));
        }
        row.q.fill(0.0);
        row.tip.fill(None);
        row.orientation = [None; 7];
        let mut constraint = self.fixed_constraint.unwrap_or(0);
        // With `--no-header --columns`, a first row of names is the file's own header.
        let header_row = |m: String, cell: &str| {
            let named = names.iter().any(|n| n.eq_ignore_ascii_case(cell));
            if named && self.columns.is_some() {
                format!(
                    "{m}: the row names columns, so the file has a header row: leave out \
                     --no-header (and --columns)"
                )
            } else {
                m
            }
        };
        for ((span, col), name) in record.iter().zip(cols).zip(names) {
            let cell = unquote(&text[span.clone()]);
            let place = || at(file, Some(line), Some(name.as_str()));
            match *col {
                Col::Ignored => {}
                Col::Joint(i) => {
                    let v = parse_number(cell)
                        .map_err(|m| Error::input(place(), header_row(m, cell)))?;
                    row.q[i] = self.joint_reading(i, v, &place)?;
                }
                Col::Tip(i) => {
                    if !cell.is_empty() {
                        row.tip[i] =
                            Some(parse_number(cell).map_err(|m| Error::input(place(), m))?);
                    }
                }
                Col::Orientation(i) => {
                    if !cell.is_empty() {
                        row.orientation[i] =
                            Some(parse_number(cell).map_err(|m| Error::input(place(), m))?);
                    }
                }
                Col::Constraint => constraint = self.constraint_index(cell, &place)?,
            }
        }
        Ok(constraint)
    }

    /// A measured pose's rotation matrix (column-major) from the row's orientation cells
    /// (a rotation vector turning by more than
    /// [`MAX_ROTATION_VECTOR`](crate::model::rotation::MAX_ROTATION_VECTOR) refused as degrees):
    /// the quaternion (refused unless of unit norm within
    /// [`QUATERNION_NORM_TOLERANCE`](crate::model::rotation::QUATERNION_NORM_TOLERANCE),
    /// then normalised) or the rotation vector; `None` when a cell is empty.
    fn orientation(
        &self,
        row: &RowBuf,
        file: Option<&str>,
        line: usize,
    ) -> Result<Option<[f64; 9]>> {
        use crate::model::rotation;
        let o = &row.orientation;
        if o[..4].iter().any(Option::is_some) {
            let Some(q) = o[..4].iter().copied().collect::<Option<Vec<f64>>>() else {
                let i = o[..4].iter().position(Option::is_none).unwrap_or(0);
                return self.empty_orientation(file, line, i);
            };
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > rotation::QUATERNION_NORM_TOLERANCE {
                return Err(Error::input(
                    at(file, Some(line), Some("qw")),
                    format!(
                        "the quaternion (qw, qx, qy, qz) = ({}, {}, {}, {}) has norm {norm}, \
                         not 1 (within {:e}): the orientation must be a unit quaternion, \
                         scalar first",
                        q[0],
                        q[1],
                        q[2],
                        q[3],
                        rotation::QUATERNION_NORM_TOLERANCE
                    ),
                ));
            }
            return Ok(Some(rotation::matrix_from_quaternion([
                q[0], q[1], q[2], q[3],
            ])));
        }
        if o[4..].iter().any(Option::is_some) {
            let Some(v) = o[4..].iter().copied().collect::<Option<Vec<f64>>>() else {
                let i = 4 + o[4..].iter().position(Option::is_none).unwrap_or(0);
                return self.empty_orientation(file, line, i);
            };
            // A rotation vector's norm is its angle: at most π as any writer normalises it,
            // a full turn at the very most. Beyond it the vector is in degrees (or not a
            // rotation vector at all), and taken as radians it would be a wrong orientation.
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm > rotation::MAX_ROTATION_VECTOR {
                let worst = (0..3).max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()));
                return Err(Error::input(
                    at(
                        file,
                        Some(line),
                        Some(ORIENTATION_NAMES[4 + worst.unwrap_or(0)]),
                    ),
                    format!(
                        "the rotation vector (rx, ry, rz) = ({}, {}, {}) turns by {norm:.4} rad, \
                         beyond a full turn (2π): it looks like degrees; give the axis times \
                         the angle in radians",
                        v[0], v[1], v[2]
                    ),
                ));
            }
            return Ok(Some(rotation::matrix_from_rotation_vector([
                v[0], v[1], v[2],
            ])));
        }
        if self.joints_only {
            Ok(None)
        } else {
            self.empty_orientation(file, line, 0)
        }
    }

    /// The error for an empty orientation cell (column `i` of the orientation names), or
    /// `None` where only the joints are read.
    fn empty_orientation(
        &self,
        file: Option<&str>,
        line: usize,
        i: usize,
    ) -> Result<Option<[f64; 9]>> {
        if self.joints_only {
            return Ok(None);
        }
        Err(Error::input(
            at(file, Some(line), Some(ORIENTATION_NAMES[i])),
            "empty cell: the measured orientation is required on a measured pose",
        ))
    }

    /// A `constraint` cell: an integer index of one of the spec's constraints.
    fn constraint_index(&self, cell: &str, place: &dyn Fn() -> Location) -> Result<usize> {
        let constraint = cell.parse::<usize>().map_err(|_| {
            Error::input(
                place(),
                format!(
                    "`{}` is not a constraint index (an integer from 0 to {})",
                    crate::error::excerpt(cell),
                    self.constraint_count.saturating_sub(1)
                ),
            )
        })?;
        if constraint >= self.constraint_count {
            return Err(Error::input(
                place(),
                format!(
                    "constraint index {constraint} is out of range: the spec has {} constraint(s), indices 0 to {}",
                    self.constraint_count,
                    self.constraint_count.saturating_sub(1)
                ),
            ));
        }
        Ok(constraint)
    }

    /// Appends the parsed `row` to `poses`. A measured tip is required on a measured
    /// constraint (unless only the joints are read); elsewhere a complete tip is kept and
    /// an incomplete one stored as an empty row, so that rows stay aligned.
    fn push_row(
        &self,
        poses: &mut Poses,
        row: &mut RowBuf,
        constraint: usize,
        file: Option<&str>,
        line: usize,
    ) -> Result<()> {
        let rotation = if self.pose {
            self.orientation(row, file, line)?
        } else {
            None
        };
        if let Some(measured) = &mut poses.measured {
            let values = &mut row.values;
            values.clear();
            values.extend(row.tip.iter().flatten().copied());
            if self.pose {
                match rotation {
                    Some(r) if values.len() == self.dim => values.extend_from_slice(&r),
                    // An incomplete pose (joints only): no measured row.
                    _ => values.clear(),
                }
            }
            if self.measured[constraint] && !self.joints_only {
                if let Some(i) = row.tip.iter().position(Option::is_none) {
                    return Err(Error::input(
                        at(file, Some(line), Some(TIP_NAMES[i])),
                        "empty cell: the measured tip coordinate is required on a measured constraint",
                    ));
                }
                measured.push(values);
            } else if values.len() == self.measured_width() {
                measured.push(values);
            } else {
                measured.push(&[]);
            }
        }
        poses.q.push(&row.q);
        poses.constraint.push(constraint);
        poses.line.push(line);
        Ok(())
    }
}

/// The buffers one data row is read into, reused from row to row.
struct RowBuf {
    /// Joint readings.
    q: Vec<f64>,
    /// Tip coordinates, `None` for an empty cell.
    tip: Vec<Option<f64>>,
    /// A measured pose's orientation cells (`qw, qx, qy, qz, rx, ry, rz`), `None` for
    /// empty or absent.
    orientation: [Option<f64>; 7],
    /// The tip's non-empty coordinates.
    values: Vec<f64>,
}
