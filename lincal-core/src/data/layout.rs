//! The columns of a data file: [`DataLayout`] (public: the shape of a spec's data and how a
//! file departs from the usual form) and the reader's `CsvLayout` (the columns a model
//! expects, each header name's role, the names expected).

use super::angles::{revolute_reading, Angles};
use crate::error::{Error, Location, Result};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Col {
    Joint(usize),
    Tip(usize),
    /// A measured orientation: `qw, qx, qy, qz` (0-3) or `rx, ry, rz` (4-6).
    Orientation(usize),
    Constraint,
    Ignored,
}

/// The columns the model expects.
pub(super) struct CsvLayout {
    pub(super) joints: usize,
    pub(super) dim: usize,
    pub(super) measured: Vec<bool>,
    /// The measured constraint is `measured_pose`: an orientation beside the tip.
    pub(super) pose: bool,
    pub(super) constraint_count: usize,
    pub(super) constraint_list: bool,
    /// Every pose lies on this constraint (one file per constraint): no `constraint` column.
    pub(super) fixed_constraint: Option<usize>,
    /// The column names of a file without a header row.
    pub(super) columns: Option<Vec<String>>,
    /// Only the joint columns are required (tips and constraint indices may be absent).
    pub(super) joints_only: bool,
    /// How revolute readings are given.
    pub(super) angles: Angles,
    /// Whether each joint is prismatic (empty: all revolute).
    pub(super) prismatic: Vec<bool>,
    /// Each joint's limits, if any (empty: none).
    pub(super) limits: Vec<Option<[f64; 2]>>,
    /// The other accepted name of each joint's column (a URDF joint name), if any.
    pub(super) aliases: Vec<Option<String>>,
}

/// What a data file holds, for [`Poses::from_csv_path_with`]: the shape of the spec's data
/// and how this file departs from the usual form.
///
/// [`Poses::from_csv_path_with`]: super::Poses::from_csv_path_with
#[derive(Clone, Debug, PartialEq)]
pub struct DataLayout {
    /// Joints `n` (columns `q1 … qn`).
    pub joints: usize,
    /// 2 or 3 (columns `x, y(, z)` when measured).
    pub dim: usize,
    /// For each constraint, whether it is `measured` (or `measured_pose`).
    pub measured: Vec<bool>,
    /// The measured constraint is `measured_pose`: each row also holds the orientation, as
    /// `qw, qx, qy, qz` (a unit quaternion, scalar first) or `rx, ry, rz` (a rotation vector,
    /// radians), and the measured row is `x, y, z` then the rotation matrix column-major.
    pub pose: bool,
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
    /// How the revolute joints' readings are given (`--angles`): radians (the default),
    /// degrees converted as read, or radians with readings that look like degrees refused.
    pub angles: Angles,
    /// Whether each joint is prismatic (metres: never converted nor checked as an angle);
    /// empty: every joint revolute.
    pub prismatic: Vec<bool>,
    /// Each joint's limits `[min, max]` on its reading, if any (read by [`Angles::Auto`]);
    /// empty: none.
    pub limits: Vec<Option<[f64; 2]>>,
    /// Another name of each joint's column, beside `q1 … qn`: the URDF joint names of the
    /// spec's `urdf:` record (`joint_names[i]` names joint `i + 1`); empty: `q1 … qn` only.
    /// A name that is another column's name (`q2` for joint 1, `x`, `constraint`, a name
    /// starting with `_`, or another joint's name) is not taken.
    pub joint_names: Vec<String>,
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
            pose: l.pose,
            constraint_list,
            constraint: None,
            columns: None,
            joints_only: false,
            angles: Angles::Rad,
            prismatic: (0..l.joints).map(|i| model.joint_is_prismatic(i)).collect(),
            limits: (0..l.joints).map(|i| model.joint_limits(i)).collect(),
            joint_names: Vec::new(),
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
                .map(|c| {
                    matches!(
                        c,
                        crate::spec::Constraint::Measured
                            | crate::spec::Constraint::MeasuredPose { .. }
                    )
                })
                .collect(),
            pose: spec.is_measured_pose(),
            constraint_list: spec.constraint_list,
            constraint: None,
            columns: None,
            joints_only: false,
            angles: Angles::Rad,
            prismatic: spec.prismatic_joints(),
            limits: spec.joints.iter().map(|j| j.limits).collect(),
            joint_names: Vec::new(),
        }
    }
}

pub(super) const TIP_NAMES: [&str; 3] = ["x", "y", "z"];

/// The orientation columns of a measured pose: a quaternion (0-3), a rotation vector (4-6).
pub(super) const ORIENTATION_NAMES: [&str; 7] = ["qw", "qx", "qy", "qz", "rx", "ry", "rz"];

impl CsvLayout {
    pub(super) fn new(model: &dyn CalibModel, constraint_list: bool) -> Self {
        let constraint_count = model.constraint_count();
        CsvLayout {
            joints: model.joint_count(),
            dim: model.dim(),
            measured: (0..constraint_count)
                .map(|j| model.constraint_kind(j).is_measured())
                .collect(),
            pose: (0..constraint_count)
                .any(|j| model.constraint_kind(j) == ConstraintKind::MeasuredPose),
            constraint_count,
            constraint_list,
            fixed_constraint: None,
            columns: None,
            joints_only: false,
            angles: Angles::Rad,
            prismatic: (0..model.joint_count())
                .map(|i| model.joint_is_prismatic(i))
                .collect(),
            limits: (0..model.joint_count())
                .map(|i| model.joint_limits(i))
                .collect(),
            aliases: Vec::new(),
        }
    }

    pub(super) fn from_layout(l: &DataLayout) -> Self {
        CsvLayout {
            joints: l.joints,
            dim: l.dim,
            measured: l.measured.clone(),
            pose: l.pose,
            constraint_count: l.measured.len(),
            constraint_list: l.constraint_list,
            fixed_constraint: l.constraint,
            columns: l.columns.clone(),
            joints_only: l.joints_only,
            angles: l.angles,
            prismatic: l.prismatic.clone(),
            limits: l.limits.clone(),
            aliases: aliases(&l.joint_names, l.joints),
        }
    }

    /// Joint `i`'s reading `v` as stored: a prismatic reading as it is, a revolute one as
    /// [`Angles`] says (converted from degrees, or refused as likely degrees with `place`,
    /// the cell's file, line and column).
    pub(super) fn joint_reading(
        &self,
        i: usize,
        v: f64,
        place: &dyn Fn() -> Location,
    ) -> Result<f64> {
        if self.prismatic.get(i).copied().unwrap_or(false) {
            return Ok(v);
        }
        let limits = self.limits.get(i).copied().flatten();
        revolute_reading(self.angles, i, v, limits).map_err(|m| Error::input(place(), m))
    }

    pub(super) fn any_measured(&self) -> bool {
        self.measured.iter().any(|&m| m)
    }

    /// The width of a pose's measured row: the tip, and for a measured pose the rotation
    /// matrix (9 more).
    pub(super) fn measured_width(&self) -> usize {
        if self.pose {
            12
        } else {
            self.dim
        }
    }

    /// The expected role of a header name, or `None` for an unknown column.
    pub(super) fn classify(&self, name: &str) -> Option<Col> {
        if name.starts_with('_') {
            return Some(Col::Ignored);
        }
        if let Some(i) = generic_joint(name).filter(|&i| i < self.joints) {
            return Some(Col::Joint(i));
        }
        if let Some(i) = self.aliases.iter().position(|a| a.as_deref() == Some(name)) {
            return Some(Col::Joint(i));
        }
        if self.any_measured() {
            if let Some(i) = TIP_NAMES[..self.dim].iter().position(|&t| t == name) {
                return Some(Col::Tip(i));
            }
        }
        if self.pose {
            if let Some(i) = ORIENTATION_NAMES.iter().position(|&t| t == name) {
                return Some(Col::Orientation(i));
            }
        }
        if self.constraint_list && self.fixed_constraint.is_none() && name == "constraint" {
            return Some(Col::Constraint);
        }
        None
    }

    /// The columns expected, each with its usual name (`q1`, `x`, `constraint`).
    pub(super) fn expected_columns(&self) -> Vec<(Col, String)> {
        let mut cols: Vec<(Col, String)> = (0..self.joints)
            .map(|i| (Col::Joint(i), format!("q{}", i + 1)))
            .collect();
        if self.any_measured() {
            cols.extend(
                TIP_NAMES[..self.dim]
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (Col::Tip(i), (*s).to_string())),
            );
        }
        // The quaternion form, for messages (the rotation-vector form is accepted instead;
        // the header check knows both).
        if self.pose {
            cols.extend(
                ORIENTATION_NAMES[..4]
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (Col::Orientation(i), (*s).to_string())),
            );
        }
        if self.constraint_list && self.fixed_constraint.is_none() {
            cols.push((Col::Constraint, "constraint".to_string()));
        }
        cols
    }

    /// The other accepted name of a joint's column (its URDF joint name), if any.
    pub(super) fn alias(&self, col: Col) -> Option<&str> {
        match col {
            Col::Joint(i) => self.aliases.get(i).and_then(Option::as_deref),
            _ => None,
        }
    }

    /// The names expected, for messages: `q1` (or `q1 or rail_joint`), `x`, `constraint`.
    pub(super) fn expected_names(&self) -> Vec<String> {
        self.expected_columns()
            .into_iter()
            .map(|(col, name)| match self.alias(col) {
                Some(alias) => format!("{name} or {alias}"),
                None if col == Col::Orientation(3) => format!("{name} (or rx, ry, rz)"),
                None => name,
            })
            .collect()
    }
}

/// The joint index of a usual joint column name `q1, q2, …` (0-based; any number).
fn generic_joint(name: &str) -> Option<usize> {
    let rest = name.strip_prefix('q')?;
    let i = rest.parse::<usize>().ok()?;
    (i >= 1 && rest == i.to_string()).then(|| i - 1)
}

/// The other accepted name of each of the `joints` columns from `names` (the URDF joint
/// names): none where a name is missing, empty, ignored (`_…`), another column's usual name
/// (`q2` for joint 1, `x`, `y`, `z`, `constraint`), the joint's own usual name, or shared by
/// two joints; such a name keeps its usual meaning.
fn aliases(names: &[String], joints: usize) -> Vec<Option<String>> {
    (0..joints)
        .map(|i| {
            let name = names.get(i)?;
            let reserved = name.is_empty()
                || name.starts_with('_')
                || generic_joint(name).is_some()
                || TIP_NAMES.contains(&name.as_str())
                || ORIENTATION_NAMES.contains(&name.as_str())
                || name == "constraint";
            let shared = names[..joints.min(names.len())]
                .iter()
                .enumerate()
                .any(|(j, other)| j != i && other == name);
            (!reserved && !shared).then(|| name.clone())
        })
        .collect()
}
