//! The chain-factored tables of a model ([`crate::model::factored`]) from its exact
//! reduction: the pivots and `R`'s nonzeros written as one code per joint, beside the chain
//! and the constraints' layout.

use super::basis_part::BasisPart;
use super::monomial::{Mono, Var, VarTable};
use crate::error::{Error, Result};
use crate::model::chain::Factor;
use crate::model::factored::{pack, Tables, MAX_FACTORS, MAX_JOINTS};
use crate::model::geometry::ConstraintKind;

/// Owned [`Tables`]: what a derived model embeds as `static`s, and what the run-time model
/// evaluates through.
#[derive(Clone, Debug, PartialEq)]
pub struct FactoredTables {
    /// Tip coordinates.
    pub dim: usize,
    /// Joints.
    pub joints: usize,
    /// The chain's elementary motions.
    pub chain: Vec<Factor>,
    /// Every constraint's kind.
    pub kinds: Vec<ConstraintKind>,
    /// Start of each constraint's values, and the total.
    pub offsets: Vec<usize>,
    /// The constraint of each equation.
    pub equation_constraint: Vec<usize>,
    /// The estimated parameter of each constraint value, concatenated.
    pub value_params: Vec<Option<usize>>,
    /// Pivot codes, packed ([`pack`]), in colexicographic order (last joint first).
    pub pivots: Vec<u64>,
    /// The basis function of each pivot.
    pub pivot_basis: Vec<u32>,
    /// `R`'s monomials, packed, lexicographic.
    pub term_monomials: Vec<u64>,
    /// How many leading codes each term shares with the one before.
    pub term_shared: Vec<u8>,
    /// The basis function of each term.
    pub term_basis: Vec<u32>,
    /// Each term's coefficient.
    pub term_coefs: Vec<f64>,
    /// Each joint's number of codes when the terms are a full grid ([`Tables::term_grid`]).
    pub term_grid: Vec<u8>,
}

impl FactoredTables {
    /// The borrowed view the kernel evaluates.
    #[must_use]
    pub fn tables(&self) -> Tables<'_> {
        Tables {
            dim: self.dim,
            joints: self.joints,
            chain: &self.chain,
            kinds: &self.kinds,
            offsets: &self.offsets,
            equation_constraint: &self.equation_constraint,
            value_params: &self.value_params,
            pivots: &self.pivots,
            pivot_basis: &self.pivot_basis,
            term_monomials: &self.term_monomials,
            term_shared: &self.term_shared,
            term_basis: &self.term_basis,
            term_coefs: &self.term_coefs,
            term_grid: &self.term_grid,
        }
    }
}

/// Every constraint's values at `p`, concatenated as the kernel's tables `t` read them.
pub(crate) fn kernel_values(
    model: &impl crate::model::CalibModel,
    t: &FactoredTables,
    p: &[f64],
) -> Vec<f64> {
    let mut vals = vec![0.0; t.offsets.last().copied().unwrap_or(0)];
    for (j, w) in t.offsets.windows(2).enumerate() {
        model.constraint_values(j, p, &mut vals[w[0]..w[1]]);
    }
    vals
}

/// `f(tables, every constraint's values at p)` where the kernel evaluates `c(p)`
/// (`SymbolicModel::kernel_evaluates`); NaN where its tables could not be built (a basis
/// from span-equivalent links is built only for a chain the kernel holds): never numbers that
/// look like values.
pub(super) fn with_kernel(
    model: &super::SymbolicModel,
    tables: Option<&FactoredTables>,
    p: &[f64],
    out: &mut [f64],
    f: impl FnOnce(&FactoredTables, &[f64], &mut [f64]),
) {
    match tables {
        Some(t) => f(t, &kernel_values(model, t, p), out),
        None => out.fill(f64::NAN),
    }
}

/// `∂c/∂p` by the kernel's tables `t` at `p`, the constraint values `vals`.
pub(super) fn kernel_jacobian(t: &FactoredTables, p: &[f64], vals: &[f64], out: &mut [f64]) {
    let mut scratch = vec![0.0; crate::model::factored::Tables::scratch_len(&t.chain)];
    t.tables().jacobian(p, vals, &mut scratch, out);
}

/// Each joint's variables: `(cos, sin)` of a revolute joint, the reading of a prismatic one.
#[derive(Clone, Copy)]
enum JointVars {
    Revolute(usize, usize),
    Prismatic(usize),
    Absent,
}

fn joint_vars(vars: &VarTable, joints: usize) -> Vec<JointVars> {
    let mut out = vec![JointVars::Absent; joints];
    let (mut cos, mut sin) = (vec![None; joints], vec![None; joints]);
    for (i, v) in vars.vars.iter().enumerate().take(vars.joint_vars) {
        match v {
            Var::JointCos(j) => cos[*j] = Some(i),
            Var::JointSin(j) => sin[*j] = Some(i),
            Var::JointLinear(j) => out[*j] = JointVars::Prismatic(i),
            _ => {}
        }
    }
    for j in 0..joints {
        if let (Some(c), Some(s)) = (cos[j], sin[j]) {
            out[j] = JointVars::Revolute(c, s);
        }
    }
    out
}

/// A joint monomial as one code per joint (see [`crate::model::factored`]).
fn codes(m: &Mono, joints: &[JointVars]) -> Result<Vec<u8>> {
    let bad = || {
        Error::other("a joint monomial of degree above two: not a chain the factored model holds")
    };
    joints
        .iter()
        .map(|j| match *j {
            JointVars::Revolute(c, s) => match (m.get(c), m.get(s)) {
                (0, 0) => Ok(0),
                (1, 0) => Ok(1),
                (0, 1) => Ok(2),
                (2, 0) => Ok(3),
                (1, 1) => Ok(4),
                _ => Err(bad()),
            },
            JointVars::Prismatic(v) => match m.get(v) {
                e @ 0..=2 => Ok(e as u8),
                _ => Err(bad()),
            },
            JointVars::Absent => Ok(0),
        })
        .collect()
}

/// A joint monomial of the expansion's variables `vars` as one code per joint, for a chain of
/// `joints` joints (the tables' form, for the derive's certificate).
pub(super) fn codes_of(m: &Mono, vars: &VarTable, joints: usize) -> Result<Vec<u8>> {
    codes(m, &joint_vars(vars, joints))
}

/// Indices `0..rows` sorted by their codes read from the last joint: pivots that share a
/// suffix of the chain come together.
fn colexicographic(codes: &[Vec<u8>]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..codes.len()).collect();
    order.sort_by(|&a, &b| codes[a].iter().rev().cmp(codes[b].iter().rev()));
    order
}

/// The chain and constraint layout a [`FactoredTables`] starts from.
pub(super) struct Layout<'a> {
    pub dim: usize,
    pub joints: usize,
    pub chain: &'a [Factor],
    pub kinds: Vec<ConstraintKind>,
    pub value_params: &'a [Vec<Option<usize>>],
    pub equation_constraint: &'a [usize],
}

/// The tables of a reduced model.
///
/// # Errors
/// A chain the kernel does not hold: more than [`MAX_JOINTS`] joints, a joint in no factor
/// or in several, joints out of order, a monomial of degree above two in a joint.
pub(super) fn build(layout: Layout<'_>, part: &BasisPart) -> Result<FactoredTables> {
    let n = layout.joints;
    if n > MAX_JOINTS {
        return Err(Error::other(format!(
            "{n} joints: the factored model holds at most {MAX_JOINTS}"
        )));
    }
    if layout.chain.len() > MAX_FACTORS {
        return Err(Error::other(format!(
            "a chain of {} elementary motions: the factored model holds at most {MAX_FACTORS}",
            layout.chain.len()
        )));
    }
    let mut seen = 0;
    for f in layout.chain {
        if let Some(j) = f.joint {
            if j != seen {
                return Err(Error::other(
                    "the chain's joints are not one factor each, in joint order",
                ));
            }
            seen += 1;
        }
    }
    if seen != n {
        return Err(Error::other("a joint has no factor in the chain"));
    }
    let jv = joint_vars(&part.expansion.vars, n);
    let red = &part.reduction;
    let pivot_codes: Vec<Vec<u8>> = red
        .pivots
        .iter()
        .map(|&c| codes(&red.monomials[c], &jv))
        .collect::<Result<_>>()?;
    let order = colexicographic(&pivot_codes);
    let mut terms: Vec<(Vec<u8>, u32, f64)> = Vec::new();
    for (k, b) in red.basis.iter().enumerate() {
        for (m, c) in b {
            terms.push((codes(m, &jv)?, k as u32, c.to_f64()));
        }
    }
    terms.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    let term_grid = full_grid(&terms, red.basis.len(), n);
    let mut offsets = vec![0];
    for vs in layout.value_params {
        offsets.push(offsets.last().copied().unwrap_or(0) + vs.len());
    }
    Ok(FactoredTables {
        dim: layout.dim,
        joints: n,
        chain: layout.chain.to_vec(),
        kinds: layout.kinds,
        offsets,
        equation_constraint: layout.equation_constraint.to_vec(),
        value_params: layout.value_params.iter().flatten().copied().collect(),
        pivots: order.iter().map(|&i| pack(&pivot_codes[i])).collect(),
        pivot_basis: order.iter().map(|&i| i as u32).collect(),
        term_monomials: terms.iter().map(|t| pack(&t.0)).collect(),
        term_shared: (0..terms.len())
            .map(|t| {
                let shared = match t.checked_sub(1) {
                    Some(prev) => terms[t]
                        .0
                        .iter()
                        .zip(&terms[prev].0)
                        .take_while(|(a, b)| a == b)
                        .count(),
                    None => 0,
                };
                shared as u8
            })
            .collect(),
        term_basis: terms.iter().map(|t| t.1).collect(),
        term_coefs: terms.iter().map(|t| t.2).collect(),
        term_grid,
    })
}

/// Each joint's number of codes when `terms` (sorted) are the full grid
/// `Π_j {0 … g_j − 1}` in lexicographic order, each of coefficient 1 and its own basis
/// function (of `k` in all); otherwise empty ([`Tables::term_grid`]).
pub(super) fn full_grid(terms: &[(Vec<u8>, u32, f64)], k: usize, joints: usize) -> Vec<u8> {
    if joints == 0 || terms.len() != k || terms.iter().any(|t| t.2 != 1.0) {
        return Vec::new();
    }
    let mut seen = vec![false; k];
    for t in terms {
        let b = t.1 as usize;
        if b >= k || std::mem::replace(&mut seen[b], true) {
            return Vec::new();
        }
    }
    let grid: Vec<u8> = (0..joints)
        .map(|j| terms.iter().map(|t| t.0[j]).max().unwrap_or(0) + 1)
        .collect();
    let count = grid
        .iter()
        .try_fold(1usize, |a, &g| a.checked_mul(usize::from(g)));
    if count != Some(terms.len()) {
        return Vec::new();
    }
    // Sorted, distinct and within the grid, as many as the grid holds: the grid itself.
    let distinct = terms.windows(2).all(|w| w[0].0 < w[1].0);
    let within = terms
        .iter()
        .all(|t| t.0.len() == joints && t.0.iter().zip(&grid).all(|(c, g)| c < g));
    if distinct && within {
        grid
    } else {
        Vec::new()
    }
}
