//! [`SpecFacts`]: what a run-time model learns about its spec alone (not about the data),
//! the costly part of building it. A caller that sees the same spec again (the command line
//! keeps them in a cache keyed by the spec) hands them back to
//! [`super::SymbolicModel::for_fitting_with`] and skips the analysis; facts that do not fit
//! the spec (lengths, indices) are ignored, never trusted.

use super::identify::Identifiability;

/// `K` as a report after a fit from the nominals gives it
/// ([`crate::model::CalibModel::basis_size_for_report`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ReportedBasisSize {
    /// Not tried yet.
    Unknown,
    /// The basis is beyond [`super::REPORT_MAX_TERMS`] (or the model's bound): no `K`.
    Beyond,
    /// `K`.
    Known(usize),
}

impl ReportedBasisSize {
    /// `K`, where known.
    #[must_use]
    pub fn known(self) -> Option<usize> {
        match self {
            ReportedBasisSize::Known(k) => Some(k),
            _ => None,
        }
    }
}

/// The spec's facts: the identifiability analysis, `K` when some build (or the grid
/// certificate) learnt it, and `K` as the report gives it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpecFacts {
    /// The identifiability analysis (with the gauge rule's choice).
    pub identifiability: Identifiability,
    /// `K`, when known (the planner's test needs only this).
    pub basis_size: Option<usize>,
    /// `K` for a report.
    pub reported_basis_size: ReportedBasisSize,
}

impl SpecFacts {
    /// Whether the facts have the shape of a spec with `np` estimated parameters and
    /// `relations` relations: every per-parameter list of length `np`, every index below it,
    /// coherent counts (the held parameters and the gauge directions as many as `np` minus
    /// the identifiable count, none of them identifiable on its own). Facts from elsewhere (a cache file) are used only when this holds.
    #[must_use]
    pub fn fit(&self, np: usize, relations: usize) -> bool {
        let id = &self.identifiability;
        let directions_ok = |dirs: &[Vec<(usize, f64)>]| {
            dirs.iter()
                .all(|d| d.iter().all(|&(j, c)| j < np && c.is_finite()))
        };
        let k_ok = match (self.basis_size, self.reported_basis_size) {
            (Some(k), ReportedBasisSize::Known(r)) => k == r,
            (None, ReportedBasisSize::Known(_)) => false,
            _ => true,
        };
        // The gauge rule holds exactly the parameters beyond the identifiable count, never one
        // identifiable on its own, and leaves one gauge direction per parameter held.
        let held = id.held.iter().filter(|&&h| h).count();
        let coherent = id.count + held == np
            && id.gauge.len() == held
            && !id.held.iter().zip(&id.identifiable).any(|(&h, &i)| h && i);
        id.identifiable.len() == np
            && id.held.len() == np
            && coherent
            && id.no_effect.len() == np
            && id.count <= np
            && id.relation_removes.len() == relations
            && directions_ok(&id.gauge)
            && id.relation_removes.iter().all(|r| directions_ok(r))
            && self.basis_size != Some(0)
            && k_ok
    }
}
