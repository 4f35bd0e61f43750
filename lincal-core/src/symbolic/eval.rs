//! Numeric evaluation of exact polynomials: compiled once into flat term lists, evaluated in
//! `f64` (the run-time model) or modulo the prime (exact rank computations).

use super::modp;
use super::monomial::{Mono, Var, VarTable};
use super::poly::Poly;
use num_traits::ToPrimitive;

/// A polynomial flattened for fast evaluation: `Σ coef · Π vals[var]^exp`.
#[derive(Clone, Debug, Default)]
pub struct CompiledPoly {
    /// `(coefficient, factors)`, factors as `(variable, exponent)`.
    pub terms: Vec<(f64, Vec<(usize, u32)>)>,
}

/// `Π vals[v]^e` over a monomial's factors.
#[must_use]
#[inline]
pub fn mono_value(factors: &[(usize, u32)], vals: &[f64]) -> f64 {
    let mut x = 1.0;
    for &(v, e) in factors {
        let b = vals[v];
        x *= match e {
            1 => b,
            2 => b * b,
            _ => b.powi(e as i32),
        };
    }
    x
}

/// Factor list of a monomial.
#[must_use]
pub fn factors(m: &Mono) -> Vec<(usize, u32)> {
    m.factors().collect()
}

impl CompiledPoly {
    /// Compiles a polynomial.
    #[must_use]
    pub fn new(p: &Poly) -> Self {
        let mut terms: Vec<(f64, Vec<(usize, u32)>)> = p
            .sorted_terms()
            .iter()
            .map(|(m, c)| (c.to_f64().unwrap_or(f64::NAN), factors(m)))
            .collect();
        terms.shrink_to_fit();
        CompiledPoly { terms }
    }

    /// Value at `vals` (indexed by variable).
    #[must_use]
    pub fn eval(&self, vals: &[f64]) -> f64 {
        self.terms
            .iter()
            .map(|(c, f)| c * mono_value(f, vals))
            .sum()
    }
}

/// Value of a polynomial modulo the prime at `vals` (indexed by variable).
#[must_use]
pub fn eval_mod(p: &Poly, vals: &[u64]) -> u64 {
    let mut acc = 0;
    for (m, c) in &p.terms {
        let Some(mut x) = modp::from_rational(c) else {
            continue;
        };
        for (v, e) in m.factors() {
            x = modp::mul(x, modp::pow(vals[v], u64::from(e)));
        }
        acc = modp::add(acc, x);
    }
    acc
}

/// Values of the parameter and constant variables, `f64`, for the estimated parameters `p`;
/// joint variables are left at 0.
#[must_use]
pub fn param_values(vars: &VarTable, p: &[f64]) -> Vec<f64> {
    let mut vals = vec![0.0; vars.vars.len()];
    fill_param_values(vars, p, &mut vals);
    vals
}

/// Writes the parameter and constant variables' values for `p` into `vals`.
pub fn fill_param_values(vars: &VarTable, p: &[f64], vals: &mut [f64]) {
    for (i, v) in vars.vars.iter().enumerate() {
        vals[i] = match v {
            Var::ParamLength(j) => p[*j],
            Var::ParamCos(j) => p[*j].cos(),
            Var::ParamSin(j) => p[*j].sin(),
            Var::ConstCos(x, _) => x.cos(),
            Var::ConstSin(x, _) => x.sin(),
            Var::ConstLength(x, _) => *x,
            _ => vals[i],
        };
    }
}

/// Writes the joint variables' values for readings `q` into `vals`.
pub fn fill_joint_values(vars: &VarTable, q: &[f64], vals: &mut [f64]) {
    for (i, v) in vars.vars.iter().enumerate().take(vars.joint_vars) {
        vals[i] = match v {
            Var::JointCos(j) => q[*j].cos(),
            Var::JointSin(j) => q[*j].sin(),
            Var::JointLinear(j) => q[*j],
            _ => vals[i],
        };
    }
}

/// A generic point modulo the prime for all parameter and constant variables: lengths
/// uniformly random, `(cos, sin)` pairs random points of the unit circle.
#[must_use]
pub fn generic_point_mod(vars: &VarTable, seed: u64) -> Vec<u64> {
    let mut rng = modp::Rng::new(seed);
    let mut vals = vec![0u64; vars.vars.len()];
    for (i, v) in vars.vars.iter().enumerate() {
        if matches!(
            v,
            Var::ParamLength(_) | Var::ConstLength(..) | Var::JointLinear(_)
        ) {
            vals[i] = rng.element();
        }
    }
    for &(c, s) in &vars.trig_pairs {
        let (cv, sv) = rng.circle_point();
        vals[c] = cv;
        vals[s] = sv;
    }
    vals
}
