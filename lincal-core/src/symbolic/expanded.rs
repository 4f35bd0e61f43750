//! The expanded constraint functions of a spec, compiled: `h_e(q; p)` evaluated straight
//! from the exact expansion, for tests and diagnostics
//! ([`super::SymbolicModel::expanded_equations`]).

use super::eval::{fill_joint_values, fill_param_values, CompiledPoly};
use super::monomial::VarTable;
use crate::error::Result;
use crate::spec::Spec;

/// The expanded constraint functions of a spec, compiled.
#[derive(Clone, Debug)]
pub struct ExpandedEquations {
    vars: VarTable,
    compiled: Vec<CompiledPoly>,
}

impl ExpandedEquations {
    /// The spec expanded again within `max_terms` and compiled.
    ///
    /// # Errors
    /// As [`super::SymbolicModel::from_spec`].
    pub fn of(spec: &Spec, max_terms: usize) -> Result<Self> {
        let expansion = super::expand::expand_with(spec, max_terms)?;
        let compiled = expansion
            .equations
            .iter()
            .map(|e| CompiledPoly::new(&e.poly))
            .collect();
        Ok(ExpandedEquations {
            vars: expansion.vars,
            compiled,
        })
    }

    /// `h_e(q; p)` for every equation `e`.
    #[must_use]
    pub fn eval(&self, q: &[f64], p: &[f64]) -> Vec<f64> {
        let mut vals = vec![0.0; self.vars.vars.len()];
        fill_param_values(&self.vars, p, &mut vals);
        fill_joint_values(&self.vars, q, &mut vals);
        self.compiled.iter().map(|c| c.eval(&vals)).collect()
    }
}
