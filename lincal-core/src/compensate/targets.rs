//! A targets file (`lincal compensate`): the data format of `calibrate` and `predict` (header
//! row, columns in any order, URDF joint names, `--angles`, `#` comments, `_`-prefixed extra
//! columns, `--no-header --columns`), with
//! - `q1 … qn` alone: joint targets;
//! - `q1 … qn` and `x, y(, z)`: position targets with their seed joints;
//! - `q1 … qn`, `x, y, z` and `qw, qx, qy, qz` or `rx, ry, rz`: pose targets (the spec's tool
//!   must be a frame, `measured_pose`).
//!
//! The header decides the form of the whole file; a Cartesian file needs every target cell on
//! every row (an empty cell is an error naming its line and column).

use super::task::{Goal, TargetKind};
use crate::data::{DataLayout, Poses};
use crate::error::{Error, Location, Result};

/// What the rows of a targets file are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetForm {
    /// Joint targets: the intended tool is the nominal model's at the joints.
    Joints,
    /// Tool positions with seed joints.
    Position,
    /// Tool poses (position and orientation) with seed joints.
    Pose,
}

/// The targets of one file: seeds, Cartesian goals when given, CSV lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// The rows: `q` the seeds, `measured` the goals (`x, y(, z)`, then the rotation
    /// column-major for poses), `line` each row's line.
    pub poses: Poses,
    /// The form of every row.
    pub form: TargetForm,
    /// 2 or 3.
    pub dim: usize,
}

const TIP: [&str; 3] = ["x", "y", "z"];
const ORIENTATION: [&str; 7] = ["qw", "qx", "qy", "qz", "rx", "ry", "rz"];

impl Targets {
    /// Number of targets.
    #[must_use]
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The goal of target `l` and its kind; `None` for a joint target.
    #[must_use]
    pub fn goal(&self, l: usize) -> Option<(Goal, TargetKind)> {
        let row = &self.poses.measured.as_ref()?[l];
        let mut x = [0.0; 3];
        x[..self.dim].copy_from_slice(&row[..self.dim]);
        match self.form {
            TargetForm::Joints => None,
            TargetForm::Position => Some((Goal { x, rot: None }, TargetKind::Position)),
            TargetForm::Pose => {
                let mut rot = [0.0; 9];
                rot.copy_from_slice(row.get(3..12)?);
                Some((Goal { x, rot: Some(rot) }, TargetKind::Pose))
            }
        }
    }

    /// Reads a targets file's text (`file` names it in errors) laid out as `layout` says
    /// (the spec's joints, URDF names, `--angles`, `--columns`); `pose_tool` says whether the
    /// spec's tool is a frame (pose targets allowed). The text is read whole by the caller, so
    /// a pipe is read once.
    ///
    /// # Errors
    /// An input error naming the file, line and column of the first bad cell or column.
    pub fn from_csv_text(
        text: &str,
        file: Option<&str>,
        layout: &DataLayout,
        pose_tool: bool,
    ) -> Result<Self> {
        let names = match &layout.columns {
            Some(c) => c.clone(),
            None => first_record(text.lines()),
        };
        let (layout, form) = target_layout(layout, &names, pose_tool, file)?;
        let poses = Poses::from_csv_reader_with(text.as_bytes(), file, &layout)?;
        Ok(Targets {
            poses,
            form,
            dim: layout.dim,
        })
    }
}

/// The header's names (its first line that is neither blank nor a `#` comment), split at
/// commas, blanks and quotes taken off: enough to know the file's form; the reader judges the
/// header itself.
fn first_record<S: AsRef<str>>(lines: impl Iterator<Item = S>) -> Vec<String> {
    for l in lines {
        let t = l.as_ref().trim().trim_start_matches('\u{feff}').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        return t
            .split(',')
            .map(|c| c.trim().trim_matches('"').trim().to_string())
            .collect();
    }
    Vec::new()
}

/// The layout that reads a targets file whose header has `names`, and its form.
fn target_layout(
    base: &DataLayout,
    names: &[String],
    pose_tool: bool,
    file: Option<&str>,
) -> Result<(DataLayout, TargetForm)> {
    let has = |n: &str| names.iter().any(|c| c == n);
    let tip = TIP[..base.dim].iter().any(|n| has(n));
    let orientation = ORIENTATION.iter().find(|n| has(n));
    let place = |field: &str| Location {
        file: file.map(str::to_string),
        field: Some(field.to_string()),
        ..Location::default()
    };
    if let Some(o) = orientation {
        if !pose_tool || base.dim != 3 {
            return Err(Error::input(
                place(o),
                format!(
                    "column `{o}`: the spec's tool is a point, so targets are positions \
                     (x, y{}) only; an orientation needs a tool frame (`measured_pose`)",
                    if base.dim == 3 { ", z" } else { "" }
                ),
            ));
        }
        if !tip {
            return Err(Error::input(
                place("x"),
                "missing columns `x, y, z`: a pose target needs its position beside its \
                 orientation",
            ));
        }
    }
    let form = match (tip, orientation.is_some()) {
        (false, _) => TargetForm::Joints,
        (true, false) => TargetForm::Position,
        (true, true) => TargetForm::Pose,
    };
    let mut layout = base.clone();
    layout.measured = vec![tip];
    layout.pose = form == TargetForm::Pose;
    layout.constraint_list = false;
    layout.constraint = None;
    layout.joints_only = !tip;
    Ok((layout, form))
}
