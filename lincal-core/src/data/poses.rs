//! [`Poses`]: the poses of one data set (joint readings, measured tips, constraint and line
//! of each pose); read from CSV files, readers or text (laid out as a model or a
//! [`DataLayout`] says), selected and joined.

use crate::progress::{NoProgress, Progress, ProgressRead};
use std::io::Read;
use std::path::Path;

use super::layout::{CsvLayout, DataLayout};
use super::pose_column::PoseColumn;
use super::rows::Rows;
use crate::error::{Error, Location, Result};
use crate::model::CalibModel;

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
    /// The data files joined, when several: each pose's file, for messages.
    pub files: PoseFiles,
}

/// The data files a set of poses was joined from ([`Poses::files`]), so that a message names
/// the file of a line when several were read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseFiles {
    /// The files' names in the order read; empty when there was one file (or none).
    pub names: Vec<String>,
    /// Each pose's file, an index into `names` (empty with it).
    pub of_pose: PoseColumn,
}

impl PoseFiles {
    /// The file of pose `l` when the poses came from several files.
    #[must_use]
    pub fn name(&self, l: usize) -> Option<&str> {
        if self.names.len() < 2 {
            return None;
        }
        self.of_pose
            .get(l)
            .and_then(|k| self.names.get(k))
            .map(String::as_str)
    }

    /// The poses at `indices`' files.
    fn select(&self, indices: &[usize]) -> PoseFiles {
        if self.names.len() < 2 {
            return self.clone();
        }
        PoseFiles {
            names: self.names.clone(),
            of_pose: PoseColumn::labels_from(indices.iter().map(|&l| self.of_pose.at(l))),
        }
    }
}

impl Default for Poses {
    /// No poses; the measured tips absent, the lines counting.
    fn default() -> Self {
        Poses {
            q: Rows::default(),
            measured: None,
            constraint: PoseColumn::labels(),
            line: PoseColumn::counting(),
            files: PoseFiles::default(),
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
    // A pipe or FIFO has no size (its metadata says 0).
    let size = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    Ok((file, name, size))
}

/// One data input opened for reading: the reader, its name for messages, its size when
/// known (for the progress bar and the row estimate).
pub struct DataSource<'r> {
    /// The bytes of the CSV.
    pub reader: Box<dyn Read + 'r>,
    /// The name errors give it (the path as given).
    pub name: String,
    /// Its size in bytes, when known (a regular file).
    pub size: Option<u64>,
}

impl DataSource<'static> {
    /// The data file at `path`, opened.
    ///
    /// # Errors
    /// An input error naming the file when it cannot be opened.
    pub fn open(path: &Path) -> Result<Self> {
        let (file, name, size) = open_data(path)?;
        Ok(DataSource {
            reader: Box::new(file),
            name,
            size,
        })
    }
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
            files: self.files.select(indices),
        }
    }

    /// Where pose `l` was read, for messages: `line 8`, or `c1.csv line 8` when the poses
    /// were joined from several files.
    #[must_use]
    pub fn place(&self, l: usize) -> String {
        let line = self.line.get(l).unwrap_or(0);
        match self.files.name(l) {
            Some(f) => format!("{f} line {line}"),
            None => format!("line {line}"),
        }
    }

    /// Reads poses from a CSV file for `model` (see the module docs for the format).
    /// `constraint_list` says whether the spec has a list of constraints (`constraints:`),
    /// which makes the `constraint` column required.
    ///
    /// # Errors
    /// [`ErrorClass::Input`] naming the file, line and column of the first bad cell, a
    /// missing or unknown column, or a file that cannot be read.
    ///
    /// [`ErrorClass::Input`]: crate::error::ErrorClass::Input
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
    /// use lincal_core::data::{Angles, DataLayout, Poses};
    /// let mut layout = DataLayout {
    ///     joints: 2,
    ///     dim: 2,
    ///     measured: vec![false],
    ///     pose: false,
    ///     constraint_list: false,
    ///     constraint: None,
    ///     columns: None,
    ///     joints_only: false,
    ///     angles: Angles::Rad,
    ///     prismatic: vec![false, true],
    ///     limits: vec![],
    ///     joint_names: vec!["shoulder".into(), "slide".into()],
    /// };
    /// let poses = Poses::from_csv_reader_with(&b"q1,q2\n0.1,0.2\n"[..], None, &layout).unwrap();
    /// assert_eq!(poses.len(), 1);
    /// assert_eq!(poses.line.to_vec(), vec![2]);
    /// let bad = Poses::from_csv_reader_with(&b"q1,q2\n0.1,x\n"[..], Some("d.csv"), &layout);
    /// assert!(bad.unwrap_err().to_string().contains("d.csv:2"));
    /// // Degrees, the columns named by the URDF: the revolute joint converted, the slide not.
    /// layout.angles = Angles::Deg;
    /// let text = &b"slide,shoulder\n0.5,90\n"[..];
    /// let poses = Poses::from_csv_reader_with(text, None, &layout).unwrap();
    /// assert_eq!(&poses.q[0], &[std::f64::consts::FRAC_PI_2, 0.5]);
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
        let sources = paths
            .iter()
            .map(|p| DataSource::open(p))
            .collect::<Result<Vec<_>>>()?;
        Self::from_csv_sources(sources, layout, progress)
    }

    /// [`Poses::from_csv_paths_progress`] from inputs already opened, each read once, in
    /// order (a caller that also hashes what it reads, or reads a pipe, opens them itself).
    ///
    /// # Errors
    /// As [`Poses::from_csv_paths`].
    pub fn from_csv_sources(
        sources: Vec<DataSource<'_>>,
        layout: &DataLayout,
        progress: &dyn Progress,
    ) -> Result<Poses> {
        let count = layout.measured.len();
        if sources.len() > 1 && layout.constraint_list && sources.len() != count {
            return Err(Error::input(
                Location {
                    field: Some("DATA".to_string()),
                    ..Location::default()
                },
                format!(
                    "{} data files for a list of {count} constraints: give one file per \
                     constraint, in the list's order (or one file with a `constraint` column)",
                    sources.len()
                ),
            ));
        }
        let several = sources.len() > 1;
        let mut all = Poses::default();
        let mut names = Vec::with_capacity(sources.len());
        for (k, src) in sources.into_iter().enumerate() {
            let mut l = layout.clone();
            if several && layout.constraint_list {
                l.constraint = Some(k);
            }
            progress.stage(&format!("reading {}", src.name), src.size);
            let reader = ProgressRead::new(src.reader, progress);
            let poses = CsvLayout::from_layout(&l).read(reader, Some(&src.name), src.size)?;
            if !several {
                return Ok(poses);
            }
            let n = poses.len();
            all.append(poses).map_err(|e| e.in_file(&src.name))?;
            all.files.of_pose.extend(std::iter::repeat_n(k, n));
            names.push(src.name);
        }
        all.files.names = names;
        Ok(all)
    }

    /// Appends `other`'s poses (lines stay those of `other`'s file).
    ///
    /// # Errors
    /// An input error when one has measured tips and the other not, or widths differ.
    pub fn append(&mut self, other: Poses) -> Result<()> {
        // Nothing read yet (the first file, or files without rows before it): `other` as it
        // is. Compared with an empty default first, every file of measured tips was refused.
        if self.is_empty() {
            *self = other;
            return Ok(());
        }
        let differ = |what: String| {
            Err(Error::input(
                Location::default(),
                format!("data files of different shapes cannot be joined: {what}"),
            ))
        };
        if self.q.width() != other.q.width() {
            return differ(format!(
                "{} joint readings per row here, {} in the files before",
                other.q.width(),
                self.q.width()
            ));
        }
        if self.measured.is_some() != other.measured.is_some() {
            return differ(
                if other.measured.is_some() {
                    "measured tip columns here and none in the files before"
                } else {
                    "no measured tip columns here and some in the files before"
                }
                .to_string(),
            );
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
            files: Default::default(),
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
}
