//! [`SymbolicModel`]: the one result of the symbolic engine, consumed by the CLI (through
//! its [`CalibModel`] implementation, the run-time model) and by the derive (through its
//! exact polynomials, turned into straight-line code).

use super::eval::{
    factors, fill_joint_values, fill_param_values, mono_value, param_roles, CompiledPoly, ParamRole,
};
use super::expand::{Expansion, ParamVars};
use super::identify::{analyse, Identifiability};
use super::monomial::{Mono, VarTable};
use super::poly::{mono_display, DegreeOverflow, Poly};
use super::reduce::{reduce, Reduction};
use super::relations::{RelationSlots, SlotVar};
use crate::error::Result;
use crate::model::chain;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::spec::chain::Chain;
use crate::spec::kinematics::SlotRef;
use crate::spec::Spec;
use num_rational::BigRational;
use std::sync::OnceLock;

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
    expansion: Expansion,
    reduction: Reduction,
    /// `jac[e][k][j] = ∂c_{e,k}/∂p_j`, built on first use: only generated code needs the
    /// polynomials; numbers come from `c` by the product rule ([`CompiledPoly::add_gradient`]).
    jac: OnceLock<std::result::Result<Vec<Vec<Vec<Poly>>>, DegreeOverflow>>,
    ident: Identifiability,
    equation_constraint: Vec<usize>,
    constant_index: Option<usize>,
    basis_names: Vec<String>,
    chain: Chain,
    constraint_slots: Vec<Vec<SlotRef>>,
    // Compiled evaluators.
    basis_monos: Vec<Vec<(usize, u32)>>,
    basis_terms: Vec<Vec<(usize, f64)>>,
    c_eval: Vec<CompiledPoly>,
    roles: Vec<ParamRole>,
    /// Whether [`SymbolicModel::release_exact_polynomials`] dropped `reduction.c`.
    exact_released: bool,
    /// The expansion's term bound the model was built with.
    max_terms: usize,
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
        let mut expansion = super::expand::expand_with(spec, max_terms)?;
        profile.expand = clock.elapsed();
        // The equations' polynomials are read by the reduction only: what later steps need
        // of them is the generalized parameters `c` (and which constraint each came from).
        let (equation_constraint, hs): (Vec<usize>, Vec<Poly>) =
            std::mem::take(&mut expansion.equations)
                .into_iter()
                .map(|e| (e.constraint, e.poly))
                .unzip();
        profile.terms = hs.iter().map(Poly::len).sum();
        let reduction = reduce(hs, expansion.vars.joint_vars);
        profile.reduce = clock.elapsed() - profile.expand;
        profile.naive_size = reduction.monomials.len();
        let roles = param_roles(&expansion.vars);
        // The analysis walks the chain at sampled readings (no expansion); `c` is compiled
        // for evaluation meanwhile.
        let slots = super::slots::slot_polys(spec)?;
        let relations = relation_slots(spec, &slots.param_vars);
        let (ident, c_eval) = analyse(
            &slots,
            &reduction.c,
            &relations,
            &super::priority::gauge_priority(spec),
        );
        profile.identify = clock.elapsed() - profile.expand - profile.reduce;
        let constant_index = reduction
            .basis
            .iter()
            .position(|b| b.len() == 1 && b[0].0 == Mono::ONE);
        let basis_names = basis_names(&reduction, &expansion);
        // Compile evaluators.
        let (basis_monos, basis_terms) = basis_evaluators(&reduction);
        let constraint_slots = constraint_slots(spec);
        let model = SymbolicModel {
            chain: Chain::from_spec(spec),
            spec: spec.clone(),
            expansion,
            reduction,
            jac: OnceLock::new(),
            ident,
            equation_constraint,
            constant_index,
            basis_names,
            constraint_slots,
            basis_monos,
            basis_terms,
            c_eval,
            roles,
            exact_released: false,
            max_terms,
        };
        profile.whole = clock.elapsed();
        Ok((model, profile))
    }

    /// The spec this model was built from.
    #[must_use]
    pub fn spec(&self) -> &Spec {
        &self.spec
    }

    /// The symbolic expansion (variables, tip, constraint polynomials).
    #[must_use]
    pub(crate) fn expansion(&self) -> &Expansion {
        &self.expansion
    }

    /// The column reduction (basis, pivots, generalized parameters).
    #[must_use]
    pub(crate) fn reduction(&self) -> &Reduction {
        &self.reduction
    }

    /// `∂c_{e,k}/∂p_j` as exact polynomials, indexed `[e][k][j]` (built on the first call).
    ///
    /// # Errors
    /// A derivative whose degree overflows the monomial representation.
    pub(crate) fn jacobian_polys(&self) -> Result<&[Vec<Vec<Poly>>]> {
        self.exact_polynomials()?;
        match self
            .jac
            .get_or_init(|| jacobian_polys(&self.expansion, &self.reduction))
        {
            Ok(j) => Ok(j),
            Err(e) => Err((*e).into()),
        }
    }

    /// Releases the exact polynomials `c_{e,k}(p)` (about 7 MB at `K = 729`), keeping their
    /// compiled form: fitting evaluates `c` and `∂c/∂p` from that alone. For a calibration of
    /// many poses, where every megabyte beside the readings counts. Afterwards
    /// [`SymbolicModel::generalized_param_strings`] is `None` and code generation is refused.
    pub fn release_exact_polynomials(&mut self) {
        self.reduction.c = Vec::new();
        self.jac = OnceLock::new();
        self.exact_released = true;
    }

    /// `Ok` while the exact `c_{e,k}(p)` are kept (see
    /// [`SymbolicModel::release_exact_polynomials`]).
    ///
    /// # Errors
    /// They were released.
    pub(crate) fn exact_polynomials(&self) -> Result<()> {
        if self.exact_released {
            return Err(crate::error::Error::other(
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

    /// Number of distinct joint monomials of the constraint function(s) before reduction.
    #[must_use]
    pub fn naive_size(&self) -> usize {
        self.reduction.monomials.len()
    }

    /// Names of the estimated parameters (the vector `p`), spec order.
    #[must_use]
    pub fn param_names(&self) -> &[String] {
        &self.expansion.param_names
    }

    /// Basis function names, e.g. `"c1*c2 - s1*s2"`.
    #[must_use]
    pub fn basis_names(&self) -> &[String] {
        &self.basis_names
    }

    /// `c_{e,k}(p)` as readable strings, `[e][k]`; `None` once
    /// [`SymbolicModel::release_exact_polynomials`] dropped them.
    #[must_use]
    pub fn generalized_param_strings(&self) -> Option<Vec<Vec<String>>> {
        if self.exact_released {
            return None;
        }
        Some(
            self.reduction
                .c
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|p| p.display(&self.expansion.vars, &self.expansion.param_names))
                        .collect()
                })
                .collect(),
        )
    }

    /// The basis function `k` as `(monomial factors over joint variables, coefficient)`.
    #[must_use]
    pub fn basis_terms(&self, k: usize) -> Vec<(Vec<(usize, u32)>, BigRational)> {
        self.reduction.basis[k]
            .iter()
            .map(|(m, c)| (factors(m), c.to_big()))
            .collect()
    }

    /// Display of a monomial.
    #[must_use]
    pub fn mono_string(&self, m: &Mono) -> String {
        mono_display(m, &self.expansion.vars, &self.expansion.param_names)
    }

    /// The gauge directions as `(parameter name, coefficient)` lists.
    #[must_use]
    pub fn gauge(&self) -> Vec<Vec<(String, f64)>> {
        self.ident
            .gauge
            .iter()
            .map(|g| {
                g.iter()
                    .map(|(j, c)| (self.expansion.param_names[*j].clone(), round_sig(*c, 12)))
                    .collect()
            })
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
            .map(|dirs| {
                dirs.iter()
                    .map(|g| {
                        g.iter()
                            .map(|(j, c)| {
                                (self.expansion.param_names[*j].clone(), round_sig(*c, 12))
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect()
    }

    /// Warnings about the spec itself: parameters that cannot affect the constraint.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        self.expansion
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
        for (j, n) in self.expansion.param_names.iter().enumerate() {
            if self.ident.identifiable[j] {
                yes.push(n.clone());
            } else {
                no.push(n.clone());
            }
        }
        (yes, no)
    }

    /// The constraint function(s) `h_e(q; p)` from a fresh expansion of the spec, not through
    /// the reduction: an independent check of `Σ_k c_{e,k}(p)·Φ̃_k(q)`, for tests and
    /// diagnostics. The model does not keep its expanded polynomials (the reduction holds
    /// what fitting reads), so this expands the spec again.
    ///
    /// # Errors
    /// As [`SymbolicModel::from_spec`].
    pub fn expanded_equations(&self) -> Result<ExpandedEquations> {
        let expansion = super::expand::expand_with(&self.spec, self.max_terms)?;
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
}

/// The expanded constraint functions of a spec, compiled (see
/// [`SymbolicModel::expanded_equations`]).
#[derive(Clone, Debug)]
pub struct ExpandedEquations {
    vars: VarTable,
    compiled: Vec<CompiledPoly>,
}

impl ExpandedEquations {
    /// `h_e(q; p)` for every equation `e`.
    #[must_use]
    pub fn eval(&self, q: &[f64], p: &[f64]) -> Vec<f64> {
        let mut vals = vec![0.0; self.vars.vars.len()];
        fill_param_values(&self.vars, p, &mut vals);
        fill_joint_values(&self.vars, q, &mut vals);
        self.compiled.iter().map(|c| c.eval(&vals)).collect()
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
        self.expansion.param_names.len()
    }
    fn param_name(&self, j: usize) -> &str {
        &self.expansion.param_names[j]
    }
    fn param_nominal(&self, j: usize) -> f64 {
        self.expansion.param_nominals[j]
    }
    fn param_is_angle(&self, j: usize) -> bool {
        matches!(self.expansion.param_vars[j], ParamVars::Angle(..))
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
    fn basis_size(&self) -> usize {
        self.reduction.basis.len()
    }
    fn basis_name(&self, k: usize) -> &str {
        &self.basis_names[k]
    }
    fn constant_index(&self) -> Option<usize> {
        self.constant_index
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
        let mut vals = vec![0.0; self.expansion.vars.joint_vars];
        fill_joint_values(&self.expansion.vars, q, &mut vals);
        let mv: Vec<f64> = self
            .basis_monos
            .iter()
            .map(|f| mono_value(f, &vals))
            .collect();
        for (o, terms) in out.iter_mut().zip(&self.basis_terms) {
            *o = terms.iter().map(|&(i, c)| c * mv[i]).sum();
        }
    }
    fn generalized_params(&self, p: &[f64], out: &mut [f64]) {
        let mut vals = vec![0.0; self.expansion.vars.vars.len()];
        fill_param_values(&self.expansion.vars, p, &mut vals);
        for (o, c) in out.iter_mut().zip(&self.c_eval) {
            *o = c.eval(&vals);
        }
    }
    fn jacobian(&self, p: &[f64], out: &mut [f64]) {
        let mut vals = vec![0.0; self.expansion.vars.vars.len()];
        fill_param_values(&self.expansion.vars, p, &mut vals);
        out.iter_mut().for_each(|x| *x = 0.0);
        let np = p.len();
        for (row, c) in out.chunks_exact_mut(np).zip(&self.c_eval) {
            c.add_gradient(&vals, &self.roles, row);
        }
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
}

/// The spec's relations with their constraints' values as the analysis sees them: estimated
/// parameters by their variable, everything else by its value.
fn relation_slots(spec: &Spec, param_vars: &[ParamVars]) -> Vec<RelationSlots> {
    let slot = |s: &crate::spec::Slot| -> SlotVar {
        match SlotRef::resolve(spec, s) {
            SlotRef::Const(x) => SlotVar::Const(x),
            SlotRef::Param(j) => match param_vars.get(j) {
                Some(ParamVars::Length(var)) => SlotVar::Param {
                    param: j,
                    var: *var,
                },
                // Constraint values are lengths; an angle here cannot happen after validation.
                _ => SlotVar::Const(spec.estimated_params()[j].nominal.to_f64()),
            },
        }
    };
    spec.relations
        .iter()
        .filter_map(|r| {
            let [i, j] = r.between;
            let si = spec
                .constraints
                .get(i)?
                .slots()
                .into_iter()
                .map(slot)
                .collect();
            let sj = spec
                .constraints
                .get(j)?
                .slots()
                .into_iter()
                .map(slot)
                .collect();
            Some(RelationSlots {
                relation: *r,
                dim: spec.dim,
                slots: [si, sj],
            })
        })
        .collect()
}

/// Each basis function's name: its polynomial displayed in the spec's names.
fn basis_names(reduction: &Reduction, expansion: &Expansion) -> Vec<String> {
    reduction
        .basis
        .iter()
        .map(|b| {
            let mut p = Poly::zero();
            for (m, c) in b {
                p.terms.insert(*m, c.clone());
            }
            p.display(&expansion.vars, &expansion.param_names)
        })
        .collect()
}

/// The factors `(variable, exponent)` of each distinct monomial of the basis.
type MonoFactors = Vec<Vec<(usize, u32)>>;

/// Each basis function as `(monomial index, coefficient)` terms.
type BasisTerms = Vec<Vec<(usize, f64)>>;

/// The compiled evaluators of the basis: the factors of each distinct monomial, and each
/// basis function as `(monomial index, coefficient)` terms.
fn basis_evaluators(reduction: &Reduction) -> (MonoFactors, BasisTerms) {
    let mut mono_list: Vec<Mono> = Vec::new();
    let mut mono_index: rustc_hash::FxHashMap<Mono, usize> = rustc_hash::FxHashMap::default();
    let mut basis_terms = Vec::new();
    for b in &reduction.basis {
        let mut terms = Vec::new();
        for (m, c) in b {
            let idx = *mono_index.entry(*m).or_insert_with(|| {
                mono_list.push(*m);
                mono_list.len() - 1
            });
            terms.push((idx, c.to_f64()));
        }
        basis_terms.push(terms);
    }
    let basis_monos = mono_list.iter().map(factors).collect();
    (basis_monos, basis_terms)
}

/// Each constraint's value slots, resolved against the spec.
fn constraint_slots(spec: &Spec) -> Vec<Vec<SlotRef>> {
    spec.constraints
        .iter()
        .map(|c| {
            c.slots()
                .into_iter()
                .map(|s| SlotRef::resolve(spec, s))
                .collect()
        })
        .collect()
}

/// `∂c/∂p` as exact polynomials: `d/dℓ` for a length, `−sin θ ∂/∂cos θ + cos θ ∂/∂sin θ` for
/// an angle (reduced on the unit circle by the product).
fn jacobian_polys(
    expansion: &Expansion,
    reduction: &Reduction,
) -> std::result::Result<Vec<Vec<Vec<Poly>>>, DegreeOverflow> {
    let pairs = &expansion.vars.trig_pairs;
    let mut jac = Vec::with_capacity(reduction.c.len());
    for row in &reduction.c {
        let mut jrow = Vec::with_capacity(row.len());
        for c in row {
            let mut d = Vec::with_capacity(expansion.param_vars.len());
            for pv in &expansion.param_vars {
                d.push(match *pv {
                    ParamVars::Length(v) => c.diff(v),
                    ParamVars::Angle(cv, sv) => {
                        let a = Poly::var(sv).mul(&c.diff(cv), pairs)?.neg();
                        let b = Poly::var(cv).mul(&c.diff(sv), pairs)?;
                        a.add(&b)
                    }
                });
            }
            jrow.push(d);
        }
        jac.push(jrow);
    }
    Ok(jac)
}

/// `x` rounded to `digits` significant decimal digits (for readable gauge coefficients).
fn round_sig(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let mag = x.abs().log10().floor() as i32;
    let f = 10f64.powi(digits - 1 - mag);
    (x * f).round() / f
}
