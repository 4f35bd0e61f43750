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
//! [`crate::error::ErrorClass::Input`] error naming the file, the line and
//! the column.

use crate::progress::{NoProgress, Progress, ProgressRead};
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::Path;

use crate::error::{Diagnostic, Error, ErrorClass, Location, Result};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// Rows of one width in one flat vector: a million poses are one allocation, not a million
/// (and about half the memory). A row may be empty (a measured tip left blank on a constraint
/// that is not measured); `rows[l]` is then `&[]`.
///
/// ```
/// use lincal_core::data::Rows;
/// let mut r = Rows::new(2);
/// r.push(&[1.0, 2.0]);
/// r.push(&[]);
/// assert_eq!((r.len(), &r[0], r.get(1)), (2, &[1.0, 2.0][..], Some(&[][..])));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rows {
    width: usize,
    /// Row after row, `width` values each (an empty row stored as zeros).
    data: Vec<f64>,
    /// Which rows are empty; shorter than `len()` (even empty) while the rest are not.
    empty: Vec<bool>,
}

impl Rows {
    /// No rows yet, each to hold `width` values.
    #[must_use]
    pub fn new(width: usize) -> Self {
        Rows {
            width,
            ..Rows::default()
        }
    }

    /// Rows taken over from one flat vector, `width` values each, row after row, with no
    /// copy (how a caller that already holds the readings contiguously, such as a numpy
    /// array, hands them over). `None` when `data.len()` is not a multiple of `width`, or
    /// `width` is 0 and `data` is not empty.
    ///
    /// ```
    /// use lincal_core::data::Rows;
    /// let r = Rows::from_vec(2, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
    /// assert_eq!((r.len(), &r[1]), (2, &[3.0, 4.0][..]));
    /// assert!(Rows::from_vec(2, vec![1.0]).is_none());
    /// ```
    #[must_use]
    pub fn from_vec(width: usize, data: Vec<f64>) -> Option<Self> {
        let fits = if width == 0 {
            data.is_empty()
        } else {
            data.len().is_multiple_of(width)
        };
        fits.then(|| Rows {
            width,
            data,
            empty: Vec::new(),
        })
    }

    /// The values per row.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.data
            .len()
            .checked_div(self.width)
            .unwrap_or(self.empty.len())
    }

    /// Whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends a row of `width` values, or an empty row (`&[]`). The first row of a
    /// collection made with width 0 (`Rows::default()`) sets the width.
    ///
    /// # Panics
    /// If `row` has another length (a programming error: readers check their input).
    pub fn push(&mut self, row: &[f64]) {
        let l = self.len();
        if l == 0 && self.width == 0 {
            // A default (width 0) collection takes the width of its first row.
            self.width = row.len();
        }
        if row.is_empty() && self.width > 0 {
            self.empty.resize(l, false);
            self.empty.push(true);
            self.data.resize(self.data.len() + self.width, 0.0);
            return;
        }
        assert_eq!(row.len(), self.width, "a row of {} values", self.width);
        if self.width == 0 {
            self.empty.push(false);
        } else if !self.empty.is_empty() {
            self.empty.resize(l, false);
            self.empty.push(false);
        }
        self.data.extend_from_slice(row);
    }

    /// Row `l`, if there is one.
    #[must_use]
    pub fn get(&self, l: usize) -> Option<&[f64]> {
        if l >= self.len() {
            return None;
        }
        if self.empty.get(l).copied().unwrap_or(false) {
            return Some(&[]);
        }
        Some(&self.data[l * self.width..(l + 1) * self.width])
    }

    /// Room for `additional` more rows, if the allocator grants it (a hint: nothing fails).
    pub fn reserve(&mut self, additional: usize) {
        let _ = self.data.try_reserve(additional.saturating_mul(self.width));
    }

    /// The first row.
    #[must_use]
    pub fn first(&self) -> Option<&[f64]> {
        self.get(0)
    }

    /// The rows in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[f64]> + '_ {
        (0..self.len()).map(move |l| &self[l])
    }

    /// The rows in order, mutable (an empty row as `&mut []`).
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut [f64]> + '_ {
        let empty = &self.empty;
        self.data
            .chunks_exact_mut(self.width.max(1))
            .enumerate()
            .map(move |(l, row)| {
                if empty.get(l).copied().unwrap_or(false) {
                    &mut row[..0]
                } else {
                    row
                }
            })
    }
}

impl std::ops::IndexMut<usize> for Rows {
    fn index_mut(&mut self, l: usize) -> &mut [f64] {
        let n = self.len();
        assert!(l < n, "row {l} of {n}");
        if self.empty.get(l).copied().unwrap_or(false) {
            return &mut [];
        }
        &mut self.data[l * self.width..(l + 1) * self.width]
    }
}

impl std::ops::Index<usize> for Rows {
    type Output = [f64];
    fn index(&self, l: usize) -> &[f64] {
        match self.get(l) {
            Some(r) => r,
            None => panic!("row {l} of {}", self.len()),
        }
    }
}

impl<'a> IntoIterator for &'a Rows {
    type Item = &'a [f64];
    type IntoIter = Box<dyn Iterator<Item = &'a [f64]> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

impl From<Vec<Vec<f64>>> for Rows {
    /// Rows from nested vectors; the width is the first non-empty row's.
    ///
    /// # Panics
    /// If two non-empty rows differ in length.
    fn from(rows: Vec<Vec<f64>>) -> Self {
        let width = rows.iter().map(Vec::len).find(|&n| n > 0).unwrap_or(0);
        let mut r = Rows::new(width);
        for row in &rows {
            r.push(row);
        }
        r
    }
}

/// Largest magnitude of a cell (radians, metres): beyond it a value is a unit or export error.
pub const MAX_CELL: f64 = 1e9;

/// One non-negative integer per pose (the constraint it lies on, or its line in its file),
/// stored as runs: within a run the value at pose `l` is `first + step·(l − start)`, with
/// `step` 0 for labels and 1 for line numbers. Data as files have them (one constraint, or
/// files one after the other; consecutive lines) take one run for any number of poses, so a
/// million poses do not carry 16 MB of bookkeeping beside their readings. The worst case (a
/// new run at every pose) costs 16 bytes a pose. Runs are kept maximal, so equal columns of
/// the same kind compare equal (a labels column never equals a counting one).
///
/// ```
/// use lincal_core::data::PoseColumn;
/// let mut lines = PoseColumn::counting();
/// for l in [2, 3, 4, 7, 8] {
///     lines.push(l);
/// }
/// assert_eq!((lines.len(), lines.runs(), lines.get(3)), (5, 2, Some(7)));
/// assert_eq!(lines.to_vec(), vec![2, 3, 4, 7, 8]);
/// let labels = PoseColumn::labels_from([0, 0, 1]);
/// assert_eq!((labels.get(2), labels.get(3)), (Some(1), None));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PoseColumn {
    /// 0 (labels) or 1 (counting).
    step: usize,
    /// `(start, first)` of every run, by ascending `start`; the first run starts at 0.
    runs: Vec<(usize, usize)>,
    len: usize,
}

impl Default for PoseColumn {
    /// An empty column of labels.
    fn default() -> Self {
        Self::labels()
    }
}

impl PoseColumn {
    /// An empty column of labels (runs of equal values): constraint indices.
    #[must_use]
    pub fn labels() -> Self {
        PoseColumn {
            step: 0,
            runs: Vec::new(),
            len: 0,
        }
    }

    /// An empty column of counts (runs of consecutive values): line numbers.
    #[must_use]
    pub fn counting() -> Self {
        PoseColumn {
            step: 1,
            ..Self::labels()
        }
    }

    /// A column of labels holding `values`.
    #[must_use]
    pub fn labels_from(values: impl IntoIterator<Item = usize>) -> Self {
        let mut c = Self::labels();
        c.extend(values);
        c
    }

    /// A counting column holding `values`.
    #[must_use]
    pub fn counting_from(values: impl IntoIterator<Item = usize>) -> Self {
        let mut c = Self::counting();
        c.extend(values);
        c
    }

    /// Appends the next pose's value.
    pub fn push(&mut self, value: usize) {
        let follows = self.runs.last().is_some_and(|&(start, first)| {
            first.checked_add(self.step * (self.len - start)) == Some(value)
        });
        if !follows {
            self.runs.push((self.len, value));
        }
        self.len += 1;
    }

    /// Appends every value of `values`.
    pub fn extend(&mut self, values: impl IntoIterator<Item = usize>) {
        for v in values {
            self.push(v);
        }
    }

    /// The value at pose `l`, `None` past the end.
    #[must_use]
    pub fn get(&self, l: usize) -> Option<usize> {
        if l >= self.len {
            return None;
        }
        let (start, first) = match self.runs.as_slice() {
            [one] => *one,
            runs => runs[runs.partition_point(|&(s, _)| s <= l) - 1],
        };
        Some(first + self.step * (l - start))
    }

    /// The value at pose `l`, 0 past the end (for loops over `0..len()`).
    #[must_use]
    pub fn at(&self, l: usize) -> usize {
        self.get(l).unwrap_or(0)
    }

    /// Number of poses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of runs (what the column's memory grows with).
    #[must_use]
    pub fn runs(&self) -> usize {
        self.runs.len()
    }

    /// Every value, in pose order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.runs
            .iter()
            .enumerate()
            .flat_map(move |(i, &(start, first))| {
                let end = self.runs.get(i + 1).map_or(self.len, |r| r.0);
                (0..end - start).map(move |k| first + self.step * k)
            })
    }

    /// Every value, in pose order, as a vector.
    #[must_use]
    pub fn to_vec(&self) -> Vec<usize> {
        self.iter().collect()
    }
}

/// Longest line of a data file, in bytes (a row of 20 joints and a tip is under 1 KiB).
pub const MAX_LINE: usize = 1 << 16;

/// The poses of one data set.
#[derive(Clone, Debug, PartialEq)]
pub struct Poses {
    /// Joint readings, `n` values per pose.
    pub q: Rows,
    /// Measured tips (`x, y(, z)`), one per pose, for `measured` constraints. Present when
    /// any constraint of the model is `measured`; a pose on a constraint that is not measured
    /// may have an empty entry (its `x, y(, z)` cells were left blank).
    pub measured: Option<Rows>,
    /// The constraint each pose lies on (index into the spec's list; all 0 for one constraint).
    pub constraint: PoseColumn,
    /// 1-based line of each pose in its file, for messages.
    pub line: PoseColumn,
}

impl Default for Poses {
    /// No poses; the measured tips absent, the lines counting.
    fn default() -> Self {
        Poses {
            q: Rows::default(),
            measured: None,
            constraint: PoseColumn::labels(),
            line: PoseColumn::counting(),
        }
    }
}

/// A data file opened for reading: the file, its name for messages, its size when known.
fn open_data(path: &Path) -> Result<(std::fs::File, String, Option<u64>)> {
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
    let size = file.metadata().ok().map(|m| m.len());
    Ok((file, name, size))
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

    /// Room for `additional` more poses, if the allocator grants it (a hint: nothing fails).
    pub fn reserve(&mut self, additional: usize) {
        self.q.reserve(additional);
        if let Some(m) = &mut self.measured {
            m.reserve(additional);
        }
    }

    /// The poses at `indices` (in that order), with their lines.
    #[must_use]
    pub fn select(&self, indices: &[usize]) -> Poses {
        let pick = |rows: &Rows| {
            let mut out = Rows::new(rows.width());
            for &l in indices {
                out.push(&rows[l]);
            }
            out
        };
        Poses {
            q: pick(&self.q),
            measured: self.measured.as_ref().map(pick),
            constraint: PoseColumn::labels_from(indices.iter().map(|&l| self.constraint.at(l))),
            // Lines unknown (poses handed over without them) stay unknown.
            line: if self.line.is_empty() {
                PoseColumn::counting()
            } else {
                PoseColumn::counting_from(indices.iter().map(|&l| self.line.at(l)))
            },
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
        Self::from_csv_path_progress(path, model, constraint_list, &NoProgress)
    }

    /// [`Poses::from_csv_path`], telling `progress` how far the reading got: one stage
    /// `reading FILE` whose length is the file's size in bytes.
    ///
    /// # Errors
    /// As [`Poses::from_csv_path`].
    pub fn from_csv_path_progress(
        path: &Path,
        model: &dyn CalibModel,
        constraint_list: bool,
        progress: &dyn Progress,
    ) -> Result<Poses> {
        let (file, name, size) = open_data(path)?;
        progress.stage(&format!("reading {name}"), size);
        let file = ProgressRead::new(file, progress);
        CsvLayout::new(model, constraint_list).read(file, Some(&name), size)
    }

    /// Reads poses from a CSV file laid out as `layout` says: without a header row (its
    /// columns given), or all on one constraint of a list (one file per constraint).
    ///
    /// # Errors
    /// As [`Poses::from_csv_path`]; errors in the given column names name `--columns`.
    pub fn from_csv_path_with(path: &Path, layout: &DataLayout) -> Result<Poses> {
        Self::from_csv_path_with_progress(path, layout, &NoProgress)
    }

    /// [`Poses::from_csv_path_with`], telling `progress` how far the reading got.
    ///
    /// # Errors
    /// As [`Poses::from_csv_path_with`].
    pub fn from_csv_path_with_progress(
        path: &Path,
        layout: &DataLayout,
        progress: &dyn Progress,
    ) -> Result<Poses> {
        let (file, name, size) = open_data(path)?;
        progress.stage(&format!("reading {name}"), size);
        let file = ProgressRead::new(file, progress);
        CsvLayout::from_layout(layout).read(file, Some(&name), size)
    }

    /// Parses CSV from any reader laid out as `layout` says (see
    /// [`Poses::from_csv_path_with`]), streamed; `file` names the source in errors.
    ///
    /// # Example
    /// ```
    /// use lincal_core::data::{DataLayout, Poses};
    /// let layout = DataLayout {
    ///     joints: 2,
    ///     dim: 2,
    ///     measured: vec![false],
    ///     constraint_list: false,
    ///     constraint: None,
    ///     columns: None,
    ///     joints_only: false,
    /// };
    /// let poses = Poses::from_csv_reader_with(&b"q1,q2\n0.1,0.2\n"[..], None, &layout).unwrap();
    /// assert_eq!(poses.len(), 1);
    /// assert_eq!(poses.line.to_vec(), vec![2]);
    /// let bad = Poses::from_csv_reader_with(&b"q1,q2\n0.1,x\n"[..], Some("d.csv"), &layout);
    /// assert!(bad.unwrap_err().to_string().contains("d.csv:2"));
    /// ```
    ///
    /// # Errors
    /// As [`Poses::from_csv_path_with`].
    pub fn from_csv_reader_with<R: Read>(
        reader: R,
        file: Option<&str>,
        layout: &DataLayout,
    ) -> Result<Poses> {
        CsvLayout::from_layout(layout).read(reader, file, None)
    }

    /// Reads one or several files: one file as [`Poses::from_csv_path_with`]; several
    /// files of a spec with a list of constraints are one per constraint, in order (file `k`
    /// holds the poses on constraint `k`, without a `constraint` column); several files of a
    /// spec with one constraint are joined. Pose indices count across the files in order;
    /// each pose keeps the line of its own file.
    ///
    /// # Errors
    /// Each file's errors (naming it); an input error naming `DATA` when a list gets another
    /// number of files than it has constraints.
    pub fn from_csv_paths(paths: &[&Path], layout: &DataLayout) -> Result<Poses> {
        Self::from_csv_paths_progress(paths, layout, &NoProgress)
    }

    /// [`Poses::from_csv_paths`], telling `progress` how far the reading of each file got.
    ///
    /// # Errors
    /// As [`Poses::from_csv_paths`].
    pub fn from_csv_paths_progress(
        paths: &[&Path],
        layout: &DataLayout,
        progress: &dyn Progress,
    ) -> Result<Poses> {
        if paths.len() == 1 {
            return Self::from_csv_path_with_progress(paths[0], layout, progress);
        }
        let count = layout.measured.len();
        if layout.constraint_list && paths.len() != count {
            return Err(Error::input(
                Location {
                    field: Some("DATA".to_string()),
                    ..Location::default()
                },
                format!(
                    "{} data files for a list of {count} constraints: give one file per \
                     constraint, in the list's order (or one file with a `constraint` column)",
                    paths.len()
                ),
            ));
        }
        let mut all = Poses::default();
        for (k, p) in paths.iter().enumerate() {
            let mut l = layout.clone();
            if layout.constraint_list {
                l.constraint = Some(k);
            }
            let poses = Self::from_csv_path_with_progress(p, &l, progress)?;
            all.append(poses)
                .map_err(|e| e.in_file(&p.display().to_string()))?;
        }
        Ok(all)
    }

    /// Appends `other`'s poses (lines stay those of `other`'s file).
    ///
    /// # Errors
    /// An input error when one has measured tips and the other not, or widths differ.
    pub fn append(&mut self, other: Poses) -> Result<()> {
        let same = self.q.width() == other.q.width() || self.is_empty();
        let measured_same = self.measured.is_some() == other.measured.is_some();
        if !same || !measured_same {
            return Err(Error::input(
                Location::default(),
                "data files of different shapes cannot be joined",
            ));
        }
        if self.is_empty() {
            *self = other;
            return Ok(());
        }
        for l in 0..other.len() {
            self.q.push(&other.q[l]);
            if let (Some(m), Some(o)) = (&mut self.measured, &other.measured) {
                m.push(&o[l]);
            }
        }
        self.constraint.extend(other.constraint.iter());
        self.line.extend(other.line.iter());
        Ok(())
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
        CsvLayout::new(model, constraint_list).read(reader, file, None)
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
    /// Every pose lies on this constraint (one file per constraint): no `constraint` column.
    fixed_constraint: Option<usize>,
    /// The column names of a file without a header row.
    columns: Option<Vec<String>>,
    /// Only the joint columns are required (tips and constraint indices may be absent).
    joints_only: bool,
}

/// What a data file holds, for [`Poses::from_csv_path_with`]: the shape of the spec's data
/// and how this file departs from the usual form.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataLayout {
    /// Joints `n` (columns `q1 … qn`).
    pub joints: usize,
    /// 2 or 3 (columns `x, y(, z)` when measured).
    pub dim: usize,
    /// For each constraint, whether it is `measured`.
    pub measured: Vec<bool>,
    /// The spec has a list of constraints (`constraints:`).
    pub constraint_list: bool,
    /// Every pose of this file lies on constraint `k` (0-based): one file per constraint
    /// of a list, with no `constraint` column.
    pub constraint: Option<usize>,
    /// The file has no header row; these are its columns, in order (`--no-header
    /// --columns q1,q2,…`).
    pub columns: Option<Vec<String>>,
    /// Only the joint readings are needed (`lincal predict`): the tip and `constraint`
    /// columns are read when present, not required.
    pub joints_only: bool,
}

impl DataLayout {
    /// The usual layout of `model`'s data (a header row; a `constraint` column for lists).
    #[must_use]
    pub fn of_model(model: &dyn CalibModel, constraint_list: bool) -> Self {
        let l = CsvLayout::new(model, constraint_list);
        DataLayout {
            joints: l.joints,
            dim: l.dim,
            measured: l.measured,
            constraint_list,
            constraint: None,
            columns: None,
            joints_only: false,
        }
    }

    /// The usual layout of `spec`'s data, without building its model.
    #[must_use]
    pub fn of_spec(spec: &crate::spec::Spec) -> Self {
        DataLayout {
            joints: spec.joints.len(),
            dim: spec.dim,
            measured: spec
                .constraints
                .iter()
                .map(|c| matches!(c, crate::spec::Constraint::Measured))
                .collect(),
            constraint_list: spec.constraint_list,
            constraint: None,
            columns: None,
            joints_only: false,
        }
    }
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
            fixed_constraint: None,
            columns: None,
            joints_only: false,
        }
    }

    fn from_layout(l: &DataLayout) -> Self {
        CsvLayout {
            joints: l.joints,
            dim: l.dim,
            measured: l.measured.clone(),
            constraint_count: l.measured.len(),
            constraint_list: l.constraint_list,
            fixed_constraint: l.constraint,
            columns: l.columns.clone(),
            joints_only: l.joints_only,
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
        if self.constraint_list && self.fixed_constraint.is_none() && name == "constraint" {
            return Some(Col::Constraint);
        }
        None
    }

    fn expected_names(&self) -> Vec<String> {
        let mut names: Vec<String> = (1..=self.joints).map(|i| format!("q{i}")).collect();
        if self.any_measured() {
            names.extend(TIP_NAMES[..self.dim].iter().map(|s| (*s).to_string()));
        }
        if self.constraint_list && self.fixed_constraint.is_none() {
            names.push("constraint".to_string());
        }
        names
    }

    /// Reads the poses; `size`, the input's length in bytes when known, sizes the storage
    /// once from the first lines' mean length (so a million rows are not copied on growth).
    fn read<R: Read>(&self, reader: R, file: Option<&str>, size: Option<u64>) -> Result<Poses> {
        // Lines are read one by one (not with the csv crate: its reader skips blank lines
        // and comments without reporting where, so its record line numbers drift); cells are
        // separated by commas, trimmed, and may be wrapped in double quotes.
        let mut reader = std::io::BufReader::new(reader);
        let mut header = self.given_header(file)?;
        let mut poses = Poses {
            q: Rows::new(self.joints),
            measured: self.any_measured().then(|| Rows::new(self.dim)),
            ..Poses::default()
        };
        let mut row = RowBuf {
            q: vec![0.0; self.joints],
            tip: vec![None; self.dim],
            values: Vec::with_capacity(self.dim),
        };
        let mut buf = Vec::new();
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
            let record: Vec<&str> = text.split(',').map(unquote).collect();
            let Some(columns) = &header else {
                header = Some(self.header(&record, line, file)?);
                continue;
            };
            let constraint = self.parse_row(&record, columns, file, line, &mut row)?;
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

    /// The header given by `--columns` for files without a header row, if any: errors in
    /// its names name the option (one message), not a line of the file.
    fn given_header(&self, file: Option<&str>) -> Result<Option<(Vec<Col>, Vec<String>)>> {
        let Some(names) = &self.columns else {
            return Ok(None);
        };
        let record: Vec<&str> = names.iter().map(String::as_str).collect();
        let header = self.header(&record, 0, file).map_err(|e| {
            let message = e
                .diagnostics()
                .iter()
                .map(|d| d.message.clone())
                .collect::<Vec<_>>()
                .join("; ");
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

    /// Reads one data row's cells into `row` (joint readings, tip coordinates, empty tip
    /// cells as `None`) and returns its constraint index; the row has as many fields as the
    /// header, every number parses and the constraint index is in range.
    fn parse_row(
        &self,
        record: &[&str],
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
        let mut constraint = self.fixed_constraint.unwrap_or(0);
        for ((&cell, col), name) in record.iter().zip(cols).zip(names) {
            let place = || at(file, Some(line), Some(name.as_str()));
            match *col {
                Col::Ignored => {}
                Col::Joint(i) => {
                    row.q[i] = parse_number(cell).map_err(|m| Error::input(place(), m))?
                }
                Col::Tip(i) => {
                    if !cell.is_empty() {
                        row.tip[i] =
                            Some(parse_number(cell).map_err(|m| Error::input(place(), m))?);
                    }
                }
                Col::Constraint => constraint = self.constraint_index(cell, &place)?,
            }
        }
        Ok(constraint)
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
        if let Some(measured) = &mut poses.measured {
            let values = &mut row.values;
            values.clear();
            values.extend(row.tip.iter().flatten().copied());
            if self.measured[constraint] && !self.joints_only {
                if let Some(i) = row.tip.iter().position(Option::is_none) {
                    return Err(Error::input(
                        at(file, Some(line), Some(TIP_NAMES[i])),
                        "empty cell: the measured tip coordinate is required on a measured constraint",
                    ));
                }
                measured.push(values);
            } else if values.len() == self.dim {
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

    /// Parses the header row: every column classified, no duplicates, nothing missing.
    fn header(
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
    /// one reported), and the column of each name with a role, for [`Self::missing_columns`].
    fn header_columns(
        &self,
        record: &[&str],
        line: usize,
        file: Option<&str>,
        problems: &mut Vec<Diagnostic>,
    ) -> (Vec<Col>, Vec<String>, HashMap<String, usize>) {
        let mut seen: HashMap<String, usize> = HashMap::new();
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
                Some(_) => {
                    if let Some(first) = seen.insert(name.to_string(), i) {
                        problems.push(Diagnostic {
                            location: place,
                            message: format!(
                                "duplicate column `{}` (columns {} and {})",
                                crate::error::excerpt(name),
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
        (cols, names, seen)
    }

    /// An expected column the header lacks (only the joints when only they are read).
    fn missing_columns(
        &self,
        seen: &HashMap<String, usize>,
        line: usize,
        file: Option<&str>,
        problems: &mut Vec<Diagnostic>,
    ) {
        for expected in self.expected_names() {
            let needed = !self.joints_only || expected.starts_with('q');
            if needed && !seen.contains_key(&expected) {
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

/// The buffers one data row is read into, reused from row to row.
struct RowBuf {
    /// Joint readings.
    q: Vec<f64>,
    /// Tip coordinates, `None` for an empty cell.
    tip: Vec<Option<f64>>,
    /// The tip's non-empty coordinates.
    values: Vec<f64>,
}

/// The place `line` (1-based) and `field` of `file`.
fn at(file: Option<&str>, line: Option<usize>, field: Option<&str>) -> Location {
    Location {
        file: file.map(str::to_string),
        line,
        field: field.map(str::to_string),
        ..Location::default()
    }
}

/// Reads the next line into `buf` (cleared first), never more than [`MAX_LINE`] bytes of
/// it; returns the bytes read, 0 at the end. `line` is the number the line will have.
fn read_line<R: BufRead>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    file: Option<&str>,
    line: usize,
) -> Result<usize> {
    buf.clear();
    let read = reader
        .take(MAX_LINE as u64 + 1)
        .read_until(b'\n', buf)
        .map_err(|e| {
            Error::input(
                at(file, Some(line), None),
                format!("cannot read the data: {e}"),
            )
        })?;
    if read != 0 && buf.len() > MAX_LINE && buf.last() != Some(&b'\n') {
        return Err(Error::input(
            at(file, Some(line), None),
            format!("the line is longer than {MAX_LINE} bytes, the most a data row may have"),
        ));
    }
    Ok(read)
}

/// The text of line `line`: valid UTF-8, without a leading byte-order mark (first line)
/// and surrounding blanks; `None` for a blank line or a `#` comment, which are skipped.
fn line_text<'b>(buf: &'b [u8], file: Option<&str>, line: usize) -> Result<Option<&'b str>> {
    let text = std::str::from_utf8(buf)
        .map_err(|_| Error::input(at(file, Some(line), None), "the line is not valid UTF-8"))?;
    let text = if line == 1 {
        text.trim_start_matches('\u{feff}')
    } else {
        text
    };
    let text = text.trim();
    Ok((!text.is_empty() && !text.starts_with('#')).then_some(text))
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
    use super::*;

    #[test]
    fn rows_keep_empty_rows_in_place_and_select_keeps_them() {
        let mut r = Rows::new(3);
        r.push(&[1.0, 2.0, 3.0]);
        r.push(&[4.0, 5.0, 6.0]);
        r.push(&[]);
        r.push(&[7.0, 8.0, 9.0]);
        assert_eq!(r.len(), 4);
        assert_eq!(&r[1], &[4.0, 5.0, 6.0]);
        assert!(r[2].is_empty());
        assert_eq!(&r[3], &[7.0, 8.0, 9.0]);
        assert_eq!(r.get(4), None);
        for row in r.iter_mut() {
            for v in row {
                *v *= 2.0;
            }
        }
        r[0][0] = -1.0;
        let collected: Vec<Vec<f64>> = r.iter().map(<[f64]>::to_vec).collect();
        assert_eq!(
            collected,
            vec![
                vec![-1.0, 4.0, 6.0],
                vec![8.0, 10.0, 12.0],
                vec![],
                vec![14.0, 16.0, 18.0]
            ]
        );
        assert_eq!(Rows::from(collected), r);
        let poses = Poses {
            q: r.clone(),
            measured: Some(r),
            constraint: PoseColumn::labels_from([0, 1, 2, 3]),
            line: PoseColumn::counting_from([2, 3, 4, 5]),
        };
        let s = poses.select(&[2, 0]);
        assert_eq!(s.len(), 2);
        assert!(s.q[0].is_empty());
        assert_eq!(&s.q[1], &[-1.0, 4.0, 6.0]);
        assert_eq!(
            (s.constraint.to_vec(), s.line.to_vec()),
            (vec![2, 0], vec![4, 2])
        );
    }

    #[test]
    fn a_default_collection_takes_the_first_rows_width() {
        let mut r = Rows::default();
        r.push(&[1.0, 2.0]);
        r.push(&[3.0, 4.0]);
        assert_eq!((r.width(), r.len()), (2, 2));
    }
}
