//! Numeric evaluation of exact polynomials: compiled once into flat term lists, evaluated in
//! `f64` (the run-time model) or modulo the prime (exact rank computations).

use super::coef::Coef;
use super::modp;
use super::monomial::{Mono, Var, VarTable};
use super::poly::{display_key, DisplayKey, Poly};

/// A polynomial flattened for fast evaluation: `Σ coef · Π vals[var]^exp`, terms in display
/// order (so the sum runs in a fixed order), all factors in one array (no allocation per term).
///
/// Compact, since a large model holds millions of terms (a 9-joint arm with every DH
/// parameter unknown: 1.7 million, about 30 factors each): a factor is two bytes (a variable
/// is below [`super::monomial::MAX_VARS`] = 128, an exponent at most 15), a term 12 bytes.
#[derive(Clone, Debug, Default)]
pub struct CompiledPoly {
    /// Each term's coefficient.
    coefs: Vec<f64>,
    /// The end of each term's factors in `factors`.
    ends: Vec<u32>,
    /// Every term's factors `(variable, exponent)`, term after term.
    factors: Vec<(u8, u8)>,
}

/// `Π vals[v]^e` over a compiled term's factors.
#[inline]
fn packed_value(factors: &[(u8, u8)], vals: &[f64]) -> f64 {
    let mut x = 1.0;
    for &(v, e) in factors {
        x *= power(vals[usize::from(v)], u32::from(e));
    }
    x
}

/// `b^e` for a small exponent (multiplications up to the fourth power: `powi` is a call).
#[inline]
fn power(b: f64, e: u32) -> f64 {
    match e {
        1 => b,
        2 => b * b,
        3 => b * b * b,
        4 => {
            let s = b * b;
            s * s
        }
        _ => b.powi(e as i32),
    }
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
    let mut v = Vec::with_capacity(m.factor_count());
    v.extend(m.factors());
    v
}

impl CompiledPoly {
    /// Compiles a polynomial.
    #[must_use]
    pub fn new(p: &Poly) -> Self {
        let mut t: Vec<(DisplayKey, &Mono, &Coef)> = p
            .terms
            .iter()
            .map(|(m, c)| (display_key(m), m, c))
            .collect();
        t.sort_unstable_by_key(|x| x.0);
        let mut coefs = Vec::with_capacity(t.len());
        let mut ends = Vec::with_capacity(t.len());
        let mut fs = Vec::with_capacity(t.iter().map(|x| x.1.factor_count()).sum());
        for (_, m, c) in t {
            // Variables are below MAX_VARS = 128 and exponents at most 15 (the nibble layout).
            fs.extend(m.factors().map(|(v, e)| (v as u8, e as u8)));
            coefs.push(c.to_f64());
            ends.push(u32::try_from(fs.len()).unwrap_or(u32::MAX));
        }
        CompiledPoly {
            coefs,
            ends,
            factors: fs,
        }
    }

    /// The terms: each coefficient with its factors.
    fn terms(&self) -> impl Iterator<Item = (f64, &[(u8, u8)])> + '_ {
        let mut start = 0;
        self.coefs.iter().zip(&self.ends).map(move |(&c, &end)| {
            let end = end as usize;
            let f = &self.factors[start..end];
            start = end;
            (c, f)
        })
    }

    /// Value at `vals` (indexed by variable).
    #[must_use]
    pub fn eval(&self, vals: &[f64]) -> f64 {
        self.terms().map(|(c, f)| c * packed_value(f, vals)).sum()
    }

    /// Its terms.
    #[must_use]
    pub fn len(&self) -> usize {
        self.coefs.len()
    }

    /// Its terms and factors: about the multiplications of one evaluation.
    #[must_use]
    pub fn work(&self) -> usize {
        self.coefs.len() + self.factors.len()
    }
}

/// How one variable enters the derivative with respect to the estimated parameters.
///
/// For a length `p_j` the variable is `p_j` itself. For an angle `θ_j` the polynomial sees
/// `cos θ_j` and `sin θ_j`, and `d/dθ f(cos θ, sin θ) = −sin θ ∂f/∂cos + cos θ ∂f/∂sin`:
/// the partial derivative by the variable is weighted by its partner's value (negated for
/// the cosine).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamRole {
    /// The variable does not depend on the estimated parameters.
    None,
    /// `p_j`, a length: weight 1.
    Length(usize),
    /// `cos θ_j`; the index of the variable `sin θ_j` (weight `−sin θ_j`).
    Cos(usize, usize),
    /// `sin θ_j`; the index of the variable `cos θ_j` (weight `cos θ_j`).
    Sin(usize, usize),
}

impl ParamRole {
    /// `(j, ∂var/∂θ_j)` at `vals`, or `None` for a variable no parameter moves.
    #[inline]
    #[must_use]
    pub fn weight(self, vals: &[f64]) -> Option<(usize, f64)> {
        match self {
            ParamRole::None => None,
            ParamRole::Length(j) => Some((j, 1.0)),
            ParamRole::Cos(j, s) => Some((j, -vals[s])),
            ParamRole::Sin(j, c) => Some((j, vals[c])),
        }
    }
}

/// Each variable's [`ParamRole`].
#[must_use]
pub fn param_roles(vars: &VarTable) -> Vec<ParamRole> {
    let mut roles: Vec<ParamRole> = vars
        .vars
        .iter()
        .map(|v| match v {
            Var::ParamLength(j) => ParamRole::Length(*j),
            _ => ParamRole::None,
        })
        .collect();
    for &(c, s) in &vars.trig_pairs {
        if let (Var::ParamCos(j), Var::ParamSin(_)) = (&vars.vars[c], &vars.vars[s]) {
            roles[c] = ParamRole::Cos(*j, s);
            roles[s] = ParamRole::Sin(*j, c);
        }
    }
    roles
}

impl CompiledPoly {
    /// Adds `∂f/∂p_j` at `vals` into `grad[j]` for every estimated parameter `j`, by the
    /// product rule on each term (prefix and suffix products of its factors), with the angle
    /// rule of [`ParamRole`]. On the unit circle this is the value of the derivative of the
    /// unreduced polynomial, so no derivative polynomial is ever built.
    pub fn add_gradient(&self, vals: &[f64], roles: &[ParamRole], grad: &mut [f64]) {
        // A monomial has at most one factor per variable, so its suffix products fit on the
        // stack (URDF-native rows with many unknowns reach 40 factors and more).
        const MAX: usize = super::monomial::MAX_VARS;
        let mut suffix = [1.0f64; MAX + 1];
        for (c, f) in self.terms() {
            if f.iter()
                .all(|&(v, _)| roles[usize::from(v)] == ParamRole::None)
            {
                continue;
            }
            suffix[f.len()] = 1.0;
            for i in (0..f.len()).rev() {
                suffix[i] = suffix[i + 1] * packed_value(&f[i..=i], vals);
            }
            let mut prefix = c;
            for (i, &(v, e)) in f.iter().enumerate() {
                let v = usize::from(v);
                if let Some((j, w)) = roles[v].weight(vals) {
                    let b = vals[v];
                    // ∂(b^e)/∂b = e · b^(e−1)
                    let d = match e {
                        1 => 1.0,
                        2 => 2.0 * b,
                        _ => f64::from(e) * b.powi(i32::from(e) - 1),
                    };
                    grad[j] += prefix * suffix[i + 1] * d * w;
                }
                prefix *= packed_value(&f[i..=i], vals);
            }
        }
    }
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
