//! [`Summary`]: the constants of a model that generated code states (names, sizes,
//! identifiability, gauge, constraint layout), read from a [`SymbolicModel`].

use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::symbolic::SymbolicModel;

/// The constants of a model that generated code states (everything but the programs).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The spec's name.
    pub name: String,
    /// 2 or 3.
    pub dim: usize,
    /// Per joint: prismatic.
    pub prismatic: Vec<bool>,
    /// Per joint: limits of the reading.
    pub limits: Vec<Option<[f64; 2]>>,
    /// Estimated parameter names (the vector `p`).
    pub param_names: Vec<String>,
    /// Their nominal values.
    pub param_nominals: Vec<f64>,
    /// Per parameter: an angle.
    pub param_is_angle: Vec<bool>,
    /// Per parameter: identifiable on its own.
    pub identifiable: Vec<bool>,
    /// Per parameter: held at nominal by the gauge rule.
    pub held: Vec<bool>,
    /// Number of independent identifiable combinations.
    pub identifiable_count: usize,
    /// Distinct joint monomials before reduction.
    pub naive_size: usize,
    /// Basis function names (`K` of them).
    pub basis_names: Vec<String>,
    /// Index of the constant basis function.
    pub constant_index: Option<usize>,
    /// Kind of each constraint.
    pub constraint_kinds: Vec<ConstraintKind>,
    /// `constraint_values` output range of constraint `j`: `offsets[j]..offsets[j + 1]`.
    pub constraint_offsets: Vec<usize>,
    /// Constraint of each equation.
    pub equation_constraint: Vec<usize>,
    /// Gauge directions, `(parameter name, coefficient)`.
    pub gauge: Vec<Vec<(String, f64)>>,
    /// The chain of elementary motions and each constraint value's parameter, for the exact
    /// tip Jacobian ([`crate::model::chain`]).
    pub chain: crate::spec::chain::Chain,
    /// The relations between constraints (spec `relations:`).
    pub relations: Vec<crate::model::geometry::Relation>,
}

impl Summary {
    /// Number of joints.
    #[must_use]
    pub fn joints(&self) -> usize {
        self.prismatic.len()
    }

    /// Number of estimated parameters.
    #[must_use]
    pub fn params(&self) -> usize {
        self.param_names.len()
    }

    /// `K`.
    #[must_use]
    pub fn basis_size(&self) -> usize {
        self.basis_names.len()
    }

    /// `E`.
    #[must_use]
    pub fn equations(&self) -> usize {
        self.equation_constraint.len()
    }

    /// Reads the constants of a symbolic model.
    #[must_use]
    pub fn from_model(m: &SymbolicModel) -> Self {
        let n = m.joint_count();
        let np = m.param_count();
        let mut offsets = vec![0];
        for j in 0..m.constraint_count() {
            let len = m.constraint_kind(j).value_count(m.dim());
            offsets.push(offsets[j] + len);
        }
        Summary {
            name: m.name().to_string(),
            dim: m.dim(),
            prismatic: (0..n).map(|i| m.joint_is_prismatic(i)).collect(),
            limits: (0..n).map(|i| m.joint_limits(i)).collect(),
            param_names: m.param_names().to_vec(),
            param_nominals: (0..np).map(|j| m.param_nominal(j)).collect(),
            param_is_angle: (0..np).map(|j| m.param_is_angle(j)).collect(),
            identifiable: (0..np).map(|j| m.param_identifiable(j)).collect(),
            held: (0..np).map(|j| m.param_held(j)).collect(),
            identifiable_count: m.identifiable_count(),
            naive_size: m.naive_size(),
            basis_names: m.basis_names().to_vec(),
            constant_index: CalibModel::constant_index(m),
            constraint_kinds: (0..m.constraint_count())
                .map(|j| m.constraint_kind(j))
                .collect(),
            constraint_offsets: offsets,
            equation_constraint: (0..m.equation_count())
                .map(|e| m.equation_constraint(e))
                .collect(),
            gauge: m.gauge(),
            chain: crate::spec::chain::Chain::from_spec(m.spec()),
            relations: m.spec().relations.clone(),
        }
    }
}
