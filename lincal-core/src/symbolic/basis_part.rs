//! The `K`-dimensional half of a [`super::SymbolicModel`]: the expansion, its column
//! reduction to the basis `Φ̃(q)` with the generalized parameters `c(p)`, and their compiled
//! evaluators. Everything else a fit needs (identifiability, the gauge rule, the chain, the
//! constraint values) comes from the spec's slots without it, so a run-time model builds this
//! part only when something reads `Φ̃` or `c` (the linear method, `lincal basis`, generated
//! code, a report of `K`).

use super::coef::Coef;
use super::coverage::GridBasis;
use super::eval::{
    factors, fill_joint_values, fill_param_values, mono_value, param_roles, CompiledPoly, ParamRole,
};
use super::expand::{expand_with, expand_within, Expansion, ParamVars};
use super::monomial::Mono;
use super::poly::{Poly, ProductError};
use super::reduce::{reduce_with, Reduction};
use crate::error::Result;
use crate::spec::Spec;
use std::sync::OnceLock;

/// The factors `(variable, exponent)` of each distinct monomial of the basis.
pub(super) type MonoFactors = Vec<Vec<(usize, u32)>>;

/// Each basis function as `(monomial index, coefficient)` terms.
pub(super) type BasisTerms = Vec<Vec<(usize, f64)>>;

pub(super) use super::sketch::KnownBasisSize;

/// The expansion's result for a model: basis, `c(p)` exact and compiled.
#[derive(Clone, Debug)]
pub(super) struct BasisPart {
    /// The expansion, its equations moved into the reduction.
    pub expansion: Expansion,
    /// The column reduction (basis, pivots, generalized parameters).
    pub reduction: Reduction,
    /// `jac[e][k][j] = ∂c_{e,k}/∂p_j`, built on first use: only generated code needs the
    /// polynomials; numbers come from `c` by the product rule ([`CompiledPoly::add_gradient`]).
    pub jac: OnceLock<std::result::Result<Vec<Vec<Vec<Poly>>>, ProductError>>,
    /// Which constraint each equation belongs to.
    pub equation_constraint: Vec<usize>,
    /// Index of the constant function `1` in the basis, when it is a basis function.
    pub constant_index: Option<usize>,
    /// Each basis function displayed in the spec's names.
    pub names: Vec<String>,
    /// The factors of each distinct monomial of the basis.
    pub monos: MonoFactors,
    /// Each basis function over those monomials.
    pub terms: BasisTerms,
    /// `c_{e,k}(p)` compiled, flattened over `(e, k)`: at once for a model that fits with
    /// them, on first use for one built only to report `K`.
    pub c_eval: OnceLock<Vec<CompiledPoly>>,
    /// How each variable depends on the estimated parameters (for `∂c/∂p`).
    pub roles: Vec<ParamRole>,
    /// Terms of all constraint polynomials `h(q; p)` before the reduction; 0 for a full
    /// grid proven without them ([`super::coverage`]).
    pub terms_before_reduction: usize,
    /// Whether `reduction.c` holds the exact `c(p)`; `false` for a basis found from
    /// span-equivalent links ([`super::surrogate`]), whose `c(p)` and `∂c/∂p` come from the
    /// factored kernel.
    pub exact_c: bool,
    /// Where the basis is a set of grid monomials proven without the expansion
    /// ([`super::coverage`]), the size of the grid `Π |Φ_i|` (the basis is the full grid when
    /// they are equal); its `c(p)` and `∂c/∂p` come from the factored kernel too.
    pub proven_grid: Option<usize>,
}

/// The expansion and reduction of `spec` within `max_terms` per polynomial (and, with
/// `max_total`, that many terms over all equations, checked before the reduction, whose cost
/// they set), with `c` not yet compiled ([`BasisPart::compiled`] compiles it on first use, or
/// the caller sets it).
///
/// # Errors
/// As [`expand_with`]; more terms than `max_total`.
pub(super) fn expand_and_reduce(
    spec: &Spec,
    max_terms: usize,
    max_total: Option<usize>,
) -> Result<(BasisPart, std::time::Duration)> {
    expand_and_reduce_with(spec, max_terms, max_total, |_| ())
}

/// [`expand_and_reduce`], telling `on_basis_size` `K` and the number of terms before the
/// reduction as soon as the reduction knows `K` ([`super::reduce::reduce_with`]).
///
/// # Errors
/// As [`expand_and_reduce`].
pub(super) fn expand_and_reduce_with(
    spec: &Spec,
    max_terms: usize,
    max_total: Option<usize>,
    on_basis_size: impl FnOnce(KnownBasisSize),
) -> Result<(BasisPart, std::time::Duration)> {
    let clock = std::time::Instant::now();
    let (mut expansion, exact_c) = match route(spec, max_terms, max_total.is_some())? {
        Route::Expanded(e, exact_c) => (e, exact_c),
        Route::Grid(part) => return Ok((*part, clock.elapsed())),
    };
    let expanded = clock.elapsed();
    // The equations' polynomials are read by the reduction only: what later steps need of
    // them is the generalized parameters `c` (and which constraint each came from).
    let (equation_constraint, hs): (Vec<usize>, Vec<Poly>) =
        std::mem::take(&mut expansion.equations)
            .into_iter()
            .map(|e| (e.constraint, e.poly))
            .unzip();
    let terms_before_reduction: usize = hs.iter().map(Poly::len).sum();
    super::limits::reduction_fits(terms_before_reduction)?;
    if let Some(max) = max_total.filter(|&m| terms_before_reduction > m) {
        return Err(crate::error::Error::other(format!(
            "the constraint polynomials have {terms_before_reduction} terms, more than {max}"
        )));
    }
    let mut reduction = reduce_with(hs, expansion.vars.joint_vars, |k| {
        on_basis_size(KnownBasisSize {
            k,
            terms: terms_before_reduction,
        });
    });
    if !exact_c {
        // Polynomials in the links' `λ`s, not in `p` (see `surrogate`).
        reduction.c = Vec::new();
    }
    let part = BasisPart::assembled(expansion, reduction, equation_constraint, exact_c);
    let part = BasisPart {
        terms_before_reduction,
        ..part
    };
    Ok((part, expanded))
}

/// What the reduction reads: an expansion, with whether its `c` is the exact `c(p)`; or
/// the basis half of grid monomials proven without it, which needs none.
enum Route {
    Expanded(Expansion, bool),
    Grid(Box<BasisPart>),
}

/// The route to the basis. A basis of grid monomials is proven in milliseconds (seconds for
/// a quadric at 9 joints, [`super::coverage`]): the expansion then only adds the exact `c(p)`
/// the reports print, so it runs only within the terms they print (`REPORT_C_TERMS` in all;
/// for a basis of single monomials the terms of `c` are those of `h`). Otherwise, beyond the size
/// whose `c(p)` the reports still print ([`super::surrogate::DIRECT_MAX_TERMS`]), the direct
/// expansion would cost seconds and gigabytes that span-equivalent links save where they may
/// stand in ([`super::surrogate::kernel_holds`]); the direct expansion within the whole bound
/// last. Not for a build within a report's bound (`report`): its refusal says `K` is beyond
/// that bound, as the sketch and the build ahead say it, whatever route could find `K`.
///
/// # Errors
/// As [`expand_with`] within `max_terms`.
fn route(spec: &Spec, max_terms: usize, report: bool) -> Result<Route> {
    if report {
        return Ok(Route::Expanded(expand_with(spec, max_terms)?, true));
    }
    let first = max_terms.min(super::surrogate::DIRECT_MAX_TERMS);
    if let Some(proven) = proven_grid(spec)? {
        // The reports' bound on `c(p)` (`REPORT_C_TERMS`, equal, tested in `surrogate`); the
        // sketch says in moments where the expansion would pass it for certain.
        let printed = Some(super::surrogate::DIRECT_MAX_TERMS);
        let beyond = matches!(
            super::sketch::basis_size(spec, first, printed),
            super::sketch::Sketched::Beyond
        );
        if !beyond {
            if let Ok(e) = expand_within(spec, first, printed) {
                return Ok(Route::Expanded(e, true));
            }
        }
        return Ok(Route::Grid(Box::new(grid_part(spec, proven))));
    }
    let refused = match expand_with(spec, first) {
        Ok(e) => return Ok(Route::Expanded(e, true)),
        Err(refused) => refused,
    };
    let surrogate = if super::surrogate::kernel_holds(spec) {
        super::surrogate::expand(spec, max_terms)?
    } else {
        None
    };
    match surrogate {
        Some(e) => Ok(Route::Expanded(e, false)),
        None if first < max_terms => Ok(Route::Expanded(expand_with(spec, max_terms)?, true)),
        None => Err(refused),
    }
}

/// The basis half of a spec whose row space is spanned by grid monomials of the joints,
/// proven by [`super::coverage::grid_basis`] without the expansion: `Φ̃` those monomials in
/// display order, each its own pivot (`R = I`), `c(p)` and `∂c/∂p` from the factored kernel.
fn grid_part(spec: &Spec, proven: GridBasis) -> BasisPart {
    let equation_constraint = spec
        .constraints
        .iter()
        .enumerate()
        .flat_map(|(j, c)| {
            std::iter::repeat_n(j, super::identify::sampled::equation_count(c, spec.dim))
        })
        .collect();
    let reduction = Reduction {
        basis: proven
            .monomials
            .iter()
            .map(|m| vec![(*m, Coef::ONE)])
            .collect(),
        pivots: (0..proven.monomials.len()).collect(),
        monomials: proven.monomials,
        c: Vec::new(),
    };
    let part = BasisPart::assembled(proven.expansion, reduction, equation_constraint, false);
    BasisPart {
        proven_grid: Some(proven.grid),
        ..part
    }
}

/// [`super::coverage::grid_basis`] where the factored kernel holds the chain (`c(p)` comes
/// from it alone); `None` elsewhere, or where the certificate proves nothing.
///
/// # Errors
/// A spec the engine cannot represent.
fn proven_grid(spec: &Spec) -> Result<Option<GridBasis>> {
    if !super::surrogate::kernel_chain(spec) {
        return Ok(None);
    }
    super::coverage::grid_basis(spec)
}

impl BasisPart {
    /// The part of an expansion (its equations moved out) and its reduction: the basis'
    /// names and evaluators, `c` compiled on first use; no terms counted, not a full grid.
    fn assembled(
        expansion: Expansion,
        reduction: Reduction,
        equation_constraint: Vec<usize>,
        exact_c: bool,
    ) -> BasisPart {
        let constant_index = reduction
            .basis
            .iter()
            .position(|b| b.len() == 1 && b[0].0 == Mono::ONE);
        let names = basis_names(&reduction, &expansion);
        let (monos, terms) = basis_evaluators(&reduction);
        let roles = param_roles(&expansion.vars);
        BasisPart {
            expansion,
            reduction,
            jac: OnceLock::new(),
            equation_constraint,
            constant_index,
            names,
            monos,
            terms,
            c_eval: OnceLock::new(),
            roles,
            terms_before_reduction: 0,
            exact_c,
            proven_grid: None,
        }
    }

    /// How the basis was found without `c(p)`'s polynomials (`None`: they were expanded).
    pub(super) fn unexpanded_route(&self) -> Option<String> {
        let k = self.reduction.basis.len();
        match self.proven_grid {
            Some(g) if g == k => Some(
                "is the full grid of joint functions, proven stage by stage along the chain".into(),
            ),
            Some(g) => Some(format!(
                "is the {k} products of joint functions that can arise (of the {g} in the grid), \
                 proven stage by stage along the chain"
            )),
            None if !self.exact_c => Some("was found from span-equivalent links".into()),
            None => None,
        }
    }

    /// `c` compiled for evaluation (compiled on this thread at the first call).
    pub(super) fn compiled(&self) -> &[CompiledPoly] {
        self.c_eval.get_or_init(|| {
            self.reduction
                .c
                .iter()
                .flatten()
                .map(CompiledPoly::new)
                .collect()
        })
    }

    /// `Φ̃(q)`: each distinct monomial once, then each basis function over them.
    pub(super) fn eval_basis(&self, q: &[f64], out: &mut [f64]) {
        let mut vals = vec![0.0; self.expansion.vars.joint_vars];
        fill_joint_values(&self.expansion.vars, q, &mut vals);
        let mv: Vec<f64> = self.monos.iter().map(|f| mono_value(f, &vals)).collect();
        for (o, terms) in out.iter_mut().zip(&self.terms) {
            *o = terms.iter().map(|&(i, c)| c * mv[i]).sum();
        }
    }

    /// `c(p)` from the compiled exact polynomials.
    pub(super) fn eval_c(&self, p: &[f64], out: &mut [f64]) {
        let mut vals = vec![0.0; self.expansion.vars.vars.len()];
        fill_param_values(&self.expansion.vars, p, &mut vals);
        for (o, c) in out.iter_mut().zip(self.compiled()) {
            *o = c.eval(&vals);
        }
    }

    /// `∂c/∂p` from the compiled exact polynomials, by the product rule.
    pub(super) fn eval_jacobian(&self, p: &[f64], out: &mut [f64]) {
        let mut vals = vec![0.0; self.expansion.vars.vars.len()];
        fill_param_values(&self.expansion.vars, p, &mut vals);
        out.iter_mut().for_each(|x| *x = 0.0);
        let np = p.len();
        if np == 0 {
            return; // nothing estimated: no columns
        }
        for (row, c) in out.chunks_exact_mut(np).zip(self.compiled()) {
            c.add_gradient(&vals, &self.roles, row);
        }
    }

    /// The number of distinct joint monomials of the constraint polynomials before the
    /// reduction.
    pub(super) fn naive_size(&self) -> usize {
        self.reduction.monomials.len()
    }

    /// `∂c_{e,k}/∂p_j` as exact polynomials (built on first use).
    pub(super) fn jacobian_polys(&self) -> &std::result::Result<Vec<Vec<Vec<Poly>>>, ProductError> {
        self.jac
            .get_or_init(|| jacobian_polys(&self.expansion, &self.reduction))
    }
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

/// `∂c/∂p` as exact polynomials: `d/dℓ` for a length, `−sin θ ∂/∂cos θ + cos θ ∂/∂sin θ` for
/// an angle (reduced on the unit circle by the product).
fn jacobian_polys(
    expansion: &Expansion,
    reduction: &Reduction,
) -> std::result::Result<Vec<Vec<Vec<Poly>>>, ProductError> {
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
