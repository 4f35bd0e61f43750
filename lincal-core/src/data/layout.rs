//! The columns of a data file: [`DataLayout`] (public: the shape of a spec's data and how a
//! file departs from the usual form) and the reader's `CsvLayout` (the columns a model
//! expects, each header name's role, the names expected).

use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Col {
    Joint(usize),
    Tip(usize),
    Constraint,
    Ignored,
}

/// The columns the model expects.
pub(super) struct CsvLayout {
    pub(super) joints: usize,
    pub(super) dim: usize,
    pub(super) measured: Vec<bool>,
    pub(super) constraint_count: usize,
    pub(super) constraint_list: bool,
    /// Every pose lies on this constraint (one file per constraint): no `constraint` column.
    pub(super) fixed_constraint: Option<usize>,
    /// The column names of a file without a header row.
    pub(super) columns: Option<Vec<String>>,
    /// Only the joint columns are required (tips and constraint indices may be absent).
    pub(super) joints_only: bool,
}

/// What a data file holds, for [`Poses::from_csv_path_with`]: the shape of the spec's data
/// and how this file departs from the usual form.
///
/// [`Poses::from_csv_path_with`]: super::Poses::from_csv_path_with
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

pub(super) const TIP_NAMES: [&str; 3] = ["x", "y", "z"];

impl CsvLayout {
    pub(super) fn new(model: &dyn CalibModel, constraint_list: bool) -> Self {
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

    pub(super) fn from_layout(l: &DataLayout) -> Self {
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

    pub(super) fn any_measured(&self) -> bool {
        self.measured.iter().any(|&m| m)
    }

    /// The expected role of a header name, or `None` for an unknown column.
    pub(super) fn classify(&self, name: &str) -> Option<Col> {
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

    pub(super) fn expected_names(&self) -> Vec<String> {
        let mut names: Vec<String> = (1..=self.joints).map(|i| format!("q{i}")).collect();
        if self.any_measured() {
            names.extend(TIP_NAMES[..self.dim].iter().map(|s| (*s).to_string()));
        }
        if self.constraint_list && self.fixed_constraint.is_none() {
            names.push("constraint".to_string());
        }
        names
    }
}
