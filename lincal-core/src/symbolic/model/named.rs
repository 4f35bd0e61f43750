//! The names a report reads from a [`SymbolicModel`]: the gauge directions, the
//! identifiable split and the warnings about the spec, in the spec's parameter names.

use super::SymbolicModel;
use crate::symbolic::identify::gauge::round_sig;

impl SymbolicModel {
    /// The gauge directions as `(parameter name, coefficient)` lists.
    #[must_use]
    pub fn gauge(&self) -> Vec<Vec<(String, f64)>> {
        self.ident.gauge.iter().map(|g| self.named(g)).collect()
    }

    fn named(&self, g: &[(usize, f64)]) -> Vec<(String, f64)> {
        g.iter()
            .map(|(j, c)| (self.slots.param_names[*j].clone(), round_sig(*c, 12)))
            .collect()
    }

    /// Per relation of the spec (`relations:`), the gauge directions it removes: directions
    /// of [`SymbolicModel::gauge`]'s form that the spec without the relation leaves free and
    /// the relation fixes (a known distance fixes the scale, for instance).
    #[must_use]
    pub fn relation_gauge(&self) -> Vec<Vec<Vec<(String, f64)>>> {
        self.ident
            .relation_removes
            .iter()
            .map(|dirs| dirs.iter().map(|g| self.named(g)).collect())
            .collect()
    }

    /// Warnings about the spec itself: parameters that cannot affect the constraint.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        self.slots
            .param_names
            .iter()
            .zip(&self.ident.no_effect)
            .filter(|(_, &none)| none)
            .map(|(n, _)| {
                format!(
                    "parameter `{n}` does not affect the constraint at all (check the spec: a \
                     typo, or a link of zero length it acts through); it is held at its nominal"
                )
            })
            .collect()
    }

    /// Names identifiable on their own, and names that are not (estimated parameters).
    #[must_use]
    pub fn identifiable_split(&self) -> (Vec<String>, Vec<String>) {
        let mut yes = Vec::new();
        let mut no = Vec::new();
        for (j, n) in self.slots.param_names.iter().enumerate() {
            if self.ident.identifiable[j] {
                yes.push(n.clone());
            } else {
                no.push(n.clone());
            }
        }
        (yes, no)
    }
}
