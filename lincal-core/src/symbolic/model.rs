//! [`SymbolicModel`]: the one result of the symbolic engine, consumed by the CLI (through
//! its [`CalibModel`] implementation, the run-time model) and by the derive (through its
//! exact polynomials, turned into straight-line code).
//!
//! A model has two halves. The identifiability analysis, the chain and the constraint values
//! come from the spec's slots at the cost of the chain (`symbolic/slots.rs`,
//! `symbolic/identify/`). The basis `Φ̃`, `c(p)` and their compiled evaluators come from the
//! expansion and its reduction (`symbolic/basis_part.rs`), whose size grows with `K`. A model
//! built by [`SymbolicModel::from_spec`] has both; one built by
//! [`SymbolicModel::for_fitting`] builds the second half only when something reads it (the
//! linear method, a report of `K`), so a parameter-space fit never pays for it.

use super::basis_part::{expand_and_reduce, BasisPart};
use super::eval::factors;
use super::expand::{Expansion, ParamVars};
use super::expanded::ExpandedEquations;
use super::factored::FactoredTables;
use super::facts::{ReportedBasisSize, SpecFacts};
use super::identify::{identifiability, without_constraints, Identifiability};
use super::monomial::Mono;
use super::poly::{mono_display, Poly};
use super::prefetch::Prefetch;
use super::reduce::Reduction;
use super::relations::relation_slots;
use super::slots::{constraint_slots, slot_polys, SlotPolys};
use crate::error::{Error, Result};
use crate::model::chain;
use crate::model::geometry::ConstraintKind;
use crate::model::{CalibModel, DataGauge};
use crate::spec::chain::Chain;
use crate::spec::kinematics::SlotRef;
use crate::spec::Spec;
use num_rational::BigRational;
use std::sync::OnceLock;

mod named;

/// The largest expansion (terms of all constraint polynomials together, and of each) a
/// run-time model builds only to report `K` after a fit that did not need it: about 0.1 s of
/// the other core. Beyond it the report gives no `K` (`lincal basis` computes it, within
/// `--max-terms`), unless the basis is the full grid, proven without the expansion.
pub const REPORT_MAX_TERMS: usize = 100_000;

/// The most terms of `c(p)` the reports print (about 60 bytes each as text): beyond, the
/// reports say how many there are ([`SymbolicModel::generalized_param_terms`]).
pub const REPORT_C_TERMS: usize = 200_000;

/// How long each stage of [`SymbolicModel::from_spec_profiled`] took, and the sizes it met.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Profile {
    /// Expansion of the chain and constraint into exact polynomials.
    pub expand: std::time::Duration,
    /// Exact column reduction to the basis.
    pub reduce: std::time::Duration,
    /// Compiling `c(p)` for evaluation: zero, as it now runs inside the identifiability
    /// stage, on the other core (kept for the stage table's shape).
    pub compile: std::time::Duration,
    /// Identifiability and the gauge rule.
    pub identify: std::time::Duration,
    /// Everything, the compiled evaluators of the basis included.
    pub whole: std::time::Duration,
    /// Terms of all constraint polynomials `h(q; p)`.
    pub terms: usize,
    /// Distinct joint monomials before reduction.
    pub naive_size: usize,
}

/// The symbolic model of a spec: basis `Φ̃(q)`, generalized parameters `c(p)`, `∂c/∂p`,
/// identifiability; and a numeric run-time [`CalibModel`].
///
/// # Example
/// ```
/// let yaml = "
/// name: two_link
/// dim: 2
/// joints:
///   - {type: revolute, a: a1, home: th1}
///   - {type: revolute, a: a2, home: th2}
/// params:
///   a1: {nominal: 0.375}
///   a2: {nominal: 0.425}
///   th1: {nominal: 0}
///   th2: {nominal: 0}
///   b1: {nominal: -1.8}
///   b2: {nominal: -0.5}
/// constraint:
///   line: {b: [b1, b2]}
/// ";
/// use lincal_core::model::CalibModel;
/// let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// // The paper's sec. 4.1 for n = 2: C1, S1, C12, S12 and the constant.
/// assert_eq!(model.basis_size(), 5);
/// assert_eq!(model.identifiability().count, 4);
/// ```
#[derive(Clone, Debug)]
pub struct SymbolicModel {
    spec: Spec,
    /// The spec's slots as polynomials: what the analysis and the basis-size bound read.
    slots: SlotPolys,
    ident: Identifiability,
    /// Which constraint each equation belongs to (constraint order, each kind's count).
    equation_constraint: Vec<usize>,
    chain: Chain,
    constraint_slots: Vec<Vec<SlotRef>>,
    /// The basis half, built at once ([`SymbolicModel::from_spec`]) or on first use
    /// ([`SymbolicModel::for_fitting`]); the error says why it could not be built.
    part: OnceLock<std::result::Result<BasisPart, String>>,
    /// `K` as known from [`SpecFacts`] without a built basis.
    known_k: Option<usize>,
    /// `K` for a report, once decided ([`CalibModel::basis_size_for_report`]).
    reported: OnceLock<ReportedBasisSize>,
    /// Whether [`SymbolicModel::release_exact_polynomials`] dropped `c`'s exact polynomials.
    exact_released: bool,
    /// The expansion's term bound the model was built with.
    max_terms: usize,
    /// The basis half being built ahead on another thread
    /// ([`SymbolicModel::for_fitting_prefetching`]); shared by clones.
    prefetch: Option<std::sync::Arc<Prefetch>>,
    /// The factored tables that evaluate `c(p)` where the basis came from span-equivalent
    /// links ([`super::surrogate`]: no exact `c(p)`), or where they cost less than `c`'s
    /// polynomials ([`SymbolicModel::kernel_evaluates`]), built on first use.
    kernel: OnceLock<Option<FactoredTables>>,
    /// Whether the kernel evaluates an exact `c(p)` too, once decided.
    kernel_cheaper: OnceLock<bool>,
    /// [`SymbolicModel::factored_certificate`], once (the CLI asks before the report does).
    pub(super) certificate: OnceLock<super::certify::Memo>,
}

impl SymbolicModel {
    /// Expands, reduces and analyses a validated spec.
    ///
    /// # Errors
    /// A spec the engine cannot represent (see `expand_with`).
    pub fn from_spec(spec: &Spec) -> Result<Self> {
        Self::from_spec_with(spec, super::expand::DEFAULT_MAX_TERMS)
    }

    /// [`SymbolicModel::from_spec`] with a bound of `max_terms` on every polynomial of the
    /// expansion ([`super::DEFAULT_MAX_TERMS`] by default). The size of each product is
    /// predicted before it is formed, so a spec too large is refused in moments.
    ///
    /// # Errors
    /// As [`SymbolicModel::from_spec`], and an expansion that would cross the bound.
    pub fn from_spec_with(spec: &Spec, max_terms: usize) -> Result<Self> {
        Self::from_spec_profiled(spec, max_terms).map(|(m, _)| m)
    }

    /// [`SymbolicModel::from_spec_with`], and how long each stage took.
    ///
    /// # Errors
    /// As [`SymbolicModel::from_spec_with`].
    pub fn from_spec_profiled(spec: &Spec, max_terms: usize) -> Result<(Self, Profile)> {
        let mut profile = Profile::default();
        let clock = std::time::Instant::now();
        let (part, expanded) = expand_and_reduce(spec, max_terms, None)?;
        profile.expand = expanded;
        profile.reduce = clock.elapsed() - expanded;
        profile.naive_size = part.naive_size();
        profile.terms = part.terms_before_reduction;
        // The analysis samples the chain (no expansion); `c` is compiled on first use.
        let slots = slot_polys(spec)?;
        let relations = relation_slots(spec, &slots.param_vars);
        let ident = identifiability(&slots, &relations, &super::priority::gauge_priority(spec));
        profile.identify = clock.elapsed() - profile.expand - profile.reduce;
        let model = Self::with_part(spec, slots, ident, max_terms, Some(part));
        profile.whole = clock.elapsed();
        Ok((model, profile))
    }

    /// The model a fit needs: the identifiability analysis now (from the slots, no
    /// expansion), the basis and `c(p)` on first use. A spec whose expansion would cross
    /// `max_terms` is accepted: the fit runs in parameter space, and the linear method and
    /// the report of `K` say that the basis is beyond the bound
    /// ([`CalibModel::basis_ready`]).
    ///
    /// # Errors
    /// A spec the engine cannot represent (a parameter of the wrong role, too many symbolic
    /// variables).
    pub fn for_fitting(spec: &Spec, max_terms: usize) -> Result<Self> {
        Self::for_fitting_with(spec, max_terms, None)
    }

    /// [`SymbolicModel::for_fitting`] with the spec's facts from an earlier model of the same
    /// spec and bound ([`SymbolicModel::facts`]), which replace the analysis when they fit the
    /// spec's shape ([`SpecFacts::fit`]); otherwise the analysis runs as without them.
    ///
    /// # Errors
    /// As [`SymbolicModel::for_fitting`].
    pub fn for_fitting_with(
        spec: &Spec,
        max_terms: usize,
        facts: Option<SpecFacts>,
    ) -> Result<Self> {
        let slots = slot_polys(spec)?;
        let facts = facts.filter(|f| f.fit(slots.param_names.len(), spec.relations.len()));
        let Some(facts) = facts else {
            let relations = relation_slots(spec, &slots.param_vars);
            let priority = super::priority::gauge_priority(spec);
            let ident = identifiability(&slots, &relations, &priority);
            return Ok(Self::with_part(spec, slots, ident, max_terms, None));
        };
        let mut model = Self::with_part(spec, slots, facts.identifiability, max_terms, None);
        model.known_k = facts.basis_size;
        if facts.reported_basis_size != ReportedBasisSize::Unknown {
            let _ = model.reported.set(facts.reported_basis_size);
        }
        Ok(model)
    }

    /// [`SymbolicModel::for_fitting_with`], with the basis half started at once on another
    /// thread (unless the facts already give `K`), so that the expansion a report of `K` or
    /// the linear method reads overlaps the analysis, the data reading and the fit instead of
    /// following them (`symbolic/prefetch.rs`). The result is the same model; only when the
    /// basis half is built differs.
    ///
    /// # Errors
    /// As [`SymbolicModel::for_fitting`].
    pub fn for_fitting_prefetching(
        spec: &Spec,
        max_terms: usize,
        facts: Option<SpecFacts>,
    ) -> Result<Self> {
        let knows_k = facts
            .as_ref()
            .is_some_and(|f| f.reported_basis_size != ReportedBasisSize::Unknown);
        let bound = REPORT_MAX_TERMS.min(max_terms);
        let prefetch = if knows_k {
            None
        } else {
            Prefetch::start(spec, bound, REPORT_MAX_TERMS)
        };
        let mut model = Self::for_fitting_with(spec, max_terms, facts)?;
        model.prefetch = prefetch.map(std::sync::Arc::new);
        Ok(model)
    }

    /// What this model has learnt about its spec alone: the analysis, and `K` where a build,
    /// the grid certificate or earlier facts gave it ([`SymbolicModel::for_fitting_with`]
    /// takes them back).
    #[must_use]
    pub fn facts(&self) -> SpecFacts {
        let built = match self.part.get() {
            Some(Ok(p)) => Some(p),
            _ => None,
        };
        SpecFacts {
            identifiability: self.ident.clone(),
            basis_size: built
                .map(|p| p.reduction.basis.len())
                .or(self.known_k)
                .or_else(|| self.prefetched_basis_size().map(|b| b.k))
                .or(self.reported.get().and_then(|r| r.known())),
            reported_basis_size: self.reported.get().copied().unwrap_or_else(|| {
                built.map_or(ReportedBasisSize::Unknown, |p| {
                    Self::reported_from(&self.spec, p)
                })
            }),
        }
    }

    /// `K` for a report from a built basis, within [`REPORT_MAX_TERMS`] or of grid monomials:
    /// the spec's alone, whatever built it (span-equivalent links pass the report's bound).
    fn reported_from(spec: &Spec, part: &BasisPart) -> ReportedBasisSize {
        let within = part.exact_c && part.terms_before_reduction <= REPORT_MAX_TERMS;
        if part.proven_grid.is_some() || within {
            ReportedBasisSize::Known(part.reduction.basis.len())
        } else {
            super::coverage::grid_basis_size(spec)
                .map_or(ReportedBasisSize::Beyond, ReportedBasisSize::Known)
        }
    }

    fn with_part(
        spec: &Spec,
        slots: SlotPolys,
        ident: Identifiability,
        max_terms: usize,
        part: Option<BasisPart>,
    ) -> Self {
        let equation_constraint = slots
            .constraints
            .iter()
            .enumerate()
            .flat_map(|(j, (c, _))| {
                std::iter::repeat_n(j, super::identify::sampled::equation_count(c, slots.dim))
            })
            .collect();
        let model = SymbolicModel {
            chain: Chain::from_spec(spec),
            spec: spec.clone(),
            slots,
            ident,
            equation_constraint,
            constraint_slots: constraint_slots(spec),
            part: OnceLock::new(),
            known_k: None,
            reported: OnceLock::new(),
            exact_released: false,
            max_terms,
            prefetch: None,
            kernel: OnceLock::new(),
            kernel_cheaper: OnceLock::new(),
            certificate: OnceLock::new(),
        };
        if let Some(part) = part {
            debug_assert_eq!(part.equation_constraint, model.equation_constraint);
            let _ = model.part.set(Ok(part));
        }
        model
    }

    /// The chain-factored tables of the model ([`crate::model::factored`]): the pivots and
    /// the basis's terms as one code per joint, with the chain and the constraints' layout.
    /// The kernel evaluates `Φ̃`, `c(p)` and `∂c/∂p` from them at the cost of the chain.
    ///
    /// # Errors
    /// The basis could not be built (see [`SymbolicModel::for_fitting`]), or the chain is one
    /// the kernel does not hold (more than [`crate::model::factored::MAX_JOINTS`] joints).
    pub fn factored(&self) -> Result<FactoredTables> {
        let part = self.part()?;
        let kinds = (0..self.constraint_count())
            .map(|j| self.constraint_kind(j))
            .collect();
        super::factored::build(
            super::factored::Layout {
                dim: self.spec.dim,
                joints: self.spec.joints.len(),
                chain: &self.chain.factors,
                kinds,
                value_params: &self.chain.value_params,
                equation_constraint: &self.equation_constraint,
            },
            part,
        )
    }

    /// Whether the factored kernel evaluates `c(p)` and `∂c/∂p` (`Some`, with its tables,
    /// `None` in them where they could not be built) in place of the compiled polynomials:
    /// always where `c(p)` has none (span-equivalent links), and where the kernel's work,
    /// about one unit per value of `∂c/∂p` (`K·E·P`), is below half the polynomials' terms
    /// (whether or not they were released). A large `c` is then not differentiated term by term: a 4-joint arm
    /// on an unknown quadric, every parameter unknown, has 1.15·10⁶ terms, whose gradients
    /// were 17 s of its linear start.
    fn kernel_evaluates(&self, part: &BasisPart) -> Option<Option<&FactoredTables>> {
        let tables = || self.kernel.get_or_init(|| self.factored().ok()).as_ref();
        if !part.exact_c {
            return Some(tables());
        }
        let cheaper = *self.kernel_cheaper.get_or_init(|| {
            let values = self.basis_size() * self.equation_count() * self.param_count();
            // The same count whether the exact polynomials were released or not.
            let terms: usize = if part.reduction.c.is_empty() {
                part.compiled()
                    .iter()
                    .map(super::eval::CompiledPoly::len)
                    .sum()
            } else {
                part.reduction.c.iter().flatten().map(Poly::len).sum()
            };
            values.saturating_mul(2) < terms
        });
        cheaper.then(tables).flatten().map(Some)
    }

    /// How the basis was found without `c(p)`'s polynomials (`None`: expanded, or not built).
    pub(crate) fn unexpanded_route(&self) -> Option<String> {
        self.part.get()?.as_ref().ok()?.unexpanded_route()
    }

    /// Whether `c(p)` has exact polynomials (always, but for a basis found from
    /// span-equivalent links, [`super::surrogate`]).
    pub(crate) fn c_is_exact(&self) -> bool {
        // What is built already: asking must not build the basis half.
        !matches!(self.part.get(), Some(Ok(p)) if !p.exact_c)
    }

    /// The basis half, built within the model's term bound on first use.
    pub(super) fn part(&self) -> Result<&BasisPart> {
        self.initialised_part()
            .as_ref()
            .map_err(|e| Error::other(e.clone()))
    }

    /// The basis half once decided: the prefetched one when its thread built it (its bounds
    /// only refuse, they never change a result), else built here within the model's bound.
    fn initialised_part(&self) -> &std::result::Result<BasisPart, String> {
        self.part.get_or_init(
            || match self.prefetch.as_deref().and_then(Prefetch::take_part) {
                Some(part) => Ok(part),
                None => self.build_part(self.max_terms),
            },
        )
    }

    /// `K` from the prefetch, if one ran and its thread has sent it (never waits).
    fn prefetched_basis_size(&self) -> Option<super::basis_part::KnownBasisSize> {
        self.prefetch
            .as_deref()
            .and_then(Prefetch::basis_size_received)
    }

    /// `K` for a report, decided once: from a built basis ([`Self::reported_from`]), a basis
    /// of grid monomials proven without the expansion, or a basis built now within
    /// [`REPORT_MAX_TERMS`] (`c` not compiled: only `K` and the names are read).
    fn reported(&self) -> ReportedBasisSize {
        *self.reported.get_or_init(|| match self.part.get() {
            Some(Ok(p)) => Self::reported_from(&self.spec, p),
            Some(Err(_)) => ReportedBasisSize::Beyond,
            // The prefetch builds within the same bounds as the branch below: a failure
            // there is a basis beyond them.
            None if self.prefetch.is_some() => {
                match self.prefetch.as_deref().and_then(Prefetch::basis_size) {
                    Some(b) if b.terms <= REPORT_MAX_TERMS => ReportedBasisSize::Known(b.k),
                    _ => ReportedBasisSize::Beyond,
                }
            }
            None => {
                if let Some(k) = super::coverage::grid_basis_size(&self.spec) {
                    return ReportedBasisSize::Known(k);
                }
                let bound = REPORT_MAX_TERMS.min(self.max_terms);
                match expand_and_reduce(&self.spec, bound, Some(REPORT_MAX_TERMS)) {
                    Ok((p, _)) => {
                        let k = p.reduction.basis.len();
                        let _ = self.part.set(Ok(p));
                        ReportedBasisSize::Known(k)
                    }
                    Err(_) => ReportedBasisSize::Beyond,
                }
            }
        })
    }

    /// The basis half within `bound` terms per polynomial. `c` is compiled when first
    /// evaluated (a planner that only compares `K` never pays for it), so a model built
    /// lazily keeps `c`'s exact form even after [`Self::release_exact_polynomials`].
    fn build_part(&self, bound: usize) -> std::result::Result<BasisPart, String> {
        expand_and_reduce(&self.spec, bound, None)
            .map(|(p, _)| p)
            .map_err(|e| e.to_string())
    }

    /// The spec this model was built from.
    #[must_use]
    pub fn spec(&self) -> &Spec {
        &self.spec
    }

    /// The symbolic expansion (variables, tip, constraint polynomials).
    ///
    /// # Errors
    /// The expansion crosses the model's term bound.
    pub(crate) fn expansion(&self) -> Result<&Expansion> {
        self.part().map(|p| &p.expansion)
    }

    /// The column reduction (basis, pivots, generalized parameters).
    ///
    /// # Errors
    /// The expansion crosses the model's term bound.
    pub(crate) fn reduction(&self) -> Result<&Reduction> {
        self.part().map(|p| &p.reduction)
    }

    /// `∂c_{e,k}/∂p_j` as exact polynomials, indexed `[e][k][j]` (built on the first call).
    ///
    /// # Errors
    /// A derivative whose degree overflows the monomial representation.
    pub(crate) fn jacobian_polys(&self) -> Result<&[Vec<Vec<Poly>>]> {
        self.exact_polynomials()?;
        let part = self.part()?;
        if let Some(route) = part.unexpanded_route() {
            let why = format!("c(p) has no exact polynomials: the basis {route}");
            return Err(Error::other(why));
        }
        match part.jacobian_polys() {
            Ok(j) => Ok(j),
            Err(e) => Err((*e).into()),
        }
    }

    /// Releases the exact polynomials `c_{e,k}(p)` (about 7 MB at `K = 729`), keeping their
    /// compiled form: fitting evaluates `c` and `∂c/∂p` from that alone. For a calibration of
    /// many poses, where every megabyte beside the readings counts. Afterwards
    /// [`SymbolicModel::generalized_param_strings`] is `None` and code generation is refused.
    pub fn release_exact_polynomials(&mut self) {
        if let Some(Ok(part)) = self.part.get_mut() {
            part.compiled();
            part.reduction.c = Vec::new();
            part.jac = OnceLock::new();
        }
        self.exact_released = true;
    }

    /// `Ok` while the exact `c_{e,k}(p)` are kept (see
    /// [`SymbolicModel::release_exact_polynomials`]).
    ///
    /// # Errors
    /// They were released.
    pub(crate) fn exact_polynomials(&self) -> Result<()> {
        if self.exact_released {
            return Err(Error::other(
                "the model's exact polynomials were released (release_exact_polynomials): \
                 build the model again to generate code or print c(p)",
            ));
        }
        Ok(())
    }

    /// The identifiability analysis.
    #[must_use]
    pub fn identifiability(&self) -> &Identifiability {
        &self.ident
    }

    /// Number of distinct joint monomials of the constraint function(s) before reduction
    /// (0 when the basis cannot be built within the model's bound).
    #[must_use]
    pub fn naive_size(&self) -> usize {
        self.part().map_or(0, BasisPart::naive_size)
    }

    /// Names of the estimated parameters (the vector `p`), spec order.
    #[must_use]
    pub fn param_names(&self) -> &[String] {
        &self.slots.param_names
    }

    /// Basis function names, e.g. `"c1*c2 - s1*s2"` (none when the basis cannot be built
    /// within the model's bound).
    #[must_use]
    pub fn basis_names(&self) -> &[String] {
        self.part().map_or(&[], |p| &p.names)
    }

    /// The terms of every exact polynomial of `c(p)` together (`None` when they were
    /// released or the basis is not built). Beyond [`REPORT_C_TERMS`] the reports leave the
    /// polynomials out ([`Self::generalized_param_strings`] is `None`): hundreds of megabytes of
    /// text that no one reads, and memory that a limited process does not have.
    #[must_use]
    pub fn generalized_param_terms(&self) -> Option<usize> {
        if self.exact_released {
            return None;
        }
        let part = self.part().ok()?;
        if !part.exact_c {
            return None;
        }
        Some(part.reduction.c.iter().flatten().map(|p| p.len()).sum())
    }

    /// `c_{e,k}(p)` as readable strings, `[e][k]`; `None` once
    /// [`SymbolicModel::release_exact_polynomials`] dropped them, without a basis, or beyond
    /// Whether the reports print `c(p)` ([`SymbolicModel::generalized_param_strings`] is
    /// `Some`), without formatting it.
    pub(super) fn c_printed(&self) -> bool {
        !self.exact_released
            && self
                .generalized_param_terms()
                .is_some_and(|t| t <= REPORT_C_TERMS)
            && self.part().is_ok()
    }

    /// [`REPORT_C_TERMS`] terms in all.
    #[must_use]
    pub fn generalized_param_strings(&self) -> Option<Vec<Vec<String>>> {
        if !self.c_printed() {
            return None;
        }
        let part = self.part().ok()?;
        Some(
            part.reduction
                .c
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|p| p.display(&part.expansion.vars, &self.slots.param_names))
                        .collect()
                })
                .collect(),
        )
    }

    /// The basis function `k` as `(monomial factors over joint variables, coefficient)`.
    #[must_use]
    pub fn basis_terms(&self, k: usize) -> Vec<(Vec<(usize, u32)>, BigRational)> {
        self.part()
            .ok()
            .and_then(|p| p.reduction.basis.get(k))
            .map_or_else(Vec::new, |b| {
                b.iter().map(|(m, c)| (factors(m), c.to_big())).collect()
            })
    }

    /// Display of a monomial.
    #[must_use]
    pub fn mono_string(&self, m: &Mono) -> String {
        mono_display(m, &self.slots.vars, &self.slots.param_names)
    }

    /// The constraint function(s) `h_e(q; p)` from a fresh expansion of the spec, not through
    /// the reduction: an independent check of `Σ_k c_{e,k}(p)·Φ̃_k(q)`, for tests and
    /// diagnostics. The model does not keep its expanded polynomials (the reduction holds
    /// what fitting reads), so this expands the spec again.
    ///
    /// # Errors
    /// As [`SymbolicModel::from_spec`].
    pub fn expanded_equations(&self) -> Result<ExpandedEquations> {
        ExpandedEquations::of(&self.spec, self.max_terms)
    }
}

impl CalibModel for SymbolicModel {
    fn name(&self) -> &str {
        &self.spec.name
    }
    fn dim(&self) -> usize {
        self.spec.dim
    }
    fn joint_count(&self) -> usize {
        self.spec.joints.len()
    }
    fn joint_is_prismatic(&self, i: usize) -> bool {
        self.spec.joints[i].kind == crate::spec::JointKind::Prismatic
    }
    fn joint_limits(&self, i: usize) -> Option<[f64; 2]> {
        self.spec.joints[i].limits
    }
    fn param_count(&self) -> usize {
        self.slots.param_names.len()
    }
    fn param_name(&self, j: usize) -> &str {
        &self.slots.param_names[j]
    }
    fn param_nominal(&self, j: usize) -> f64 {
        self.slots.param_nominals[j]
    }
    fn param_is_angle(&self, j: usize) -> bool {
        matches!(self.slots.param_vars[j], ParamVars::Angle(..))
    }
    fn param_identifiable(&self, j: usize) -> bool {
        self.ident.identifiable[j]
    }
    fn param_held(&self, j: usize) -> bool {
        self.ident.held[j]
    }
    fn identifiable_count(&self) -> usize {
        self.ident.count
    }
    fn identifiability_without(&self, unseen: &[bool], rel: bool) -> Option<DataGauge> {
        Some(without_constraints(&self.slots, &self.spec, unseen, rel))
    }
    fn basis_ready(&self) -> std::result::Result<(), &str> {
        self.initialised_part()
            .as_ref()
            .map(|_| ())
            .map_err(String::as_str)
    }
    fn basis_ready_within(&self, max_terms: usize) -> std::result::Result<(), &str> {
        // A refusal within a smaller bound is not kept: the model's own may still build it.
        if max_terms < self.max_terms && self.part.get().is_none() {
            let part = self.prefetch.as_deref().and_then(Prefetch::take_part);
            match part.map_or_else(|| self.build_part(max_terms), Ok) {
                Ok(part) => drop(self.part.set(Ok(part))),
                Err(_) => return Err("more terms of expansion than the smaller bound asked for"),
            }
        }
        self.basis_ready()
    }
    fn basis_exceeds(&self, t: usize) -> Option<bool> {
        let sent = self.prefetched_basis_size();
        match (self.part.get(), self.known_k, sent) {
            (Some(Ok(p)), _, _) => Some(p.reduction.basis.len() > t),
            (_, Some(k), _) | (_, _, Some(super::basis_part::KnownBasisSize { k, .. })) => {
                // Known, or sent by the build ahead: no proof needed.
                Some(k > t)
            }
            _ if super::basis_bound::exceeds(&self.slots, t) => Some(true),
            // Not proved from samples: the prefetch's `K`, when it has one, decides.
            _ => self
                .prefetch
                .as_deref()
                .and_then(Prefetch::basis_size)
                .map(|b| b.k > t),
        }
    }
    fn basis_exceeds_pending(&self, t: usize) -> bool {
        // When `basis_exceeds` would reach the sampled proof while a build ahead runs (not
        // after a failed build: then the proof is the only quick answer).
        self.prefetch.as_deref().is_some_and(Prefetch::size_pending)
            && self.part.get().is_none()
            && self.known_k.is_none()
            && t < super::basis_bound::CERTIFY_MAX
    }
    fn basis_size_for_report(&self) -> Option<usize> {
        self.reported().known()
    }
    fn basis_size(&self) -> usize {
        self.part().map_or(0, |p| p.reduction.basis.len())
    }
    fn basis_name(&self, k: usize) -> &str {
        self.part()
            .ok()
            .and_then(|p| p.names.get(k))
            .map_or("", String::as_str)
    }
    fn constant_index(&self) -> Option<usize> {
        self.part().ok().and_then(|p| p.constant_index)
    }
    fn constraint_count(&self) -> usize {
        self.spec.constraints.len()
    }
    fn constraint_kind(&self, j: usize) -> ConstraintKind {
        self.spec.constraints[j].geometry_kind()
    }
    fn constraint_values(&self, j: usize, p: &[f64], out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.constraint_slots[j]) {
            *o = s.value(p);
        }
    }
    fn equation_count(&self) -> usize {
        self.equation_constraint.len()
    }
    fn equation_constraint(&self, e: usize) -> usize {
        self.equation_constraint[e]
    }
    fn basis(&self, q: &[f64], out: &mut [f64]) {
        if let Ok(part) = self.part() {
            part.eval_basis(q, out);
        }
    }
    fn generalized_params(&self, p: &[f64], out: &mut [f64]) {
        let Ok(part) = self.part() else { return };
        if let Some(tables) = self.kernel_evaluates(part) {
            return super::factored::with_kernel(self, tables, p, out, |t, v, o| {
                t.tables().generalized_params(p, v, o);
            });
        }
        part.eval_c(p, out);
    }
    fn jacobian(&self, p: &[f64], out: &mut [f64]) {
        let Ok(part) = self.part() else { return };
        if let Some(tables) = self.kernel_evaluates(part) {
            return super::factored::with_kernel(self, tables, p, out, |t, v, o| {
                super::factored::kernel_jacobian(t, p, v, o);
            });
        }
        part.eval_jacobian(p, out);
    }
    fn jacobian_work(&self) -> Option<usize> {
        let part = self.part().ok()?;
        if self.kernel_evaluates(part).is_some() {
            // The kernel's `∂c/∂p` costs about one unit per value (measured on the derived
            // models: 1.2 ms for `K·E·P` = 59 000 values).
            let values = self.basis_size() * self.equation_count() * self.param_count();
            return Some(values);
        }
        let c = part.compiled();
        Some(c.iter().map(super::eval::CompiledPoly::work).sum())
    }
    fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
        // The chain of elementary motions: the DH product without 4×4 matrix products
        // (equal to `Kinematics::tip` to rounding, see the chain's tests).
        chain::tip(&self.chain.factors, self.spec.dim, q, p, out);
    }
    fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]) {
        // Scratch on the stack for ordinary arms; the heap beyond.
        const STACK: usize = 64;
        let np = p.len();
        let dim = self.spec.dim;
        if np <= STACK {
            let mut tw = [[0.0; 6]; STACK];
            chain::tip_jacobian(&self.chain.factors, dim, q, p, tip, jac, &mut tw[..np]);
        } else {
            let mut tw = vec![[0.0; 6]; np];
            chain::tip_jacobian(&self.chain.factors, dim, q, p, tip, jac, &mut tw);
        }
    }
    fn constraint_value_param(&self, j: usize, v: usize) -> Option<usize> {
        self.chain.value_params[j][v]
    }
    fn chain(&self) -> &[chain::Factor] {
        &self.chain.factors
    }
    fn relations(&self) -> &[crate::model::geometry::Relation] {
        &self.spec.relations
    }
    fn orientation_weight(&self) -> f64 {
        match self.spec.pose_noise() {
            Some((Some(sp), Some(so))) => sp / so,
            _ => crate::model::geometry::DEFAULT_ORIENTATION_WEIGHT,
        }
    }
}
