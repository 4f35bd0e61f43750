//! The calibration's own predicted uncertainty of the tool position at a target.
//!
//! To first order in the estimate's error `δp = p − p̂`, the tool at the compensated joints
//! `q′` lies at `x(q′; p̂) + J_p·δp`, `J_p = ∂x/∂p` at `(q′, p̂)` (exact, from the chain's
//! twists, [`crate::model::chain::tip_jacobian`]). With the estimate's covariance `Σ_p`, the
//! position's covariance is `J_p·Σ_p·J_pᵀ`, and the reported figure is its root trace
//!
//! `σ = √tr(J_p·Σ_p·J_pᵀ)` (metres; the RMS of the 3-D position error, not one axis's).
//!
//! `Σ_p` is the full covariance when the result file carries one; otherwise it is diagonal,
//! `diag(std_j²)` from the parameters' standard deviations, and correlations between
//! parameters are not included (a correlated pair, such as a base offset and a link length
//! that the data barely separates, can then make `σ` larger or smaller than the truth).
//! Parameters without a standard deviation (held by the gauge rule, known) count as exact.

use crate::model::chain::{self, Factor};

/// The estimate's covariance over the estimated parameters (spec order).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamCovariance {
    /// Nothing known: `σ` is 0 (nominal parameters).
    None,
    /// `diag(std_j²)`: correlations not included.
    Diagonal(Vec<f64>),
    /// The full `P × P` covariance, row-major.
    Full(Vec<f64>),
}

impl ParamCovariance {
    /// A diagonal covariance from standard deviations (`None` or a non-finite value: 0).
    #[must_use]
    pub fn from_std(std: &[Option<f64>]) -> Self {
        ParamCovariance::Diagonal(
            std.iter()
                .map(|s| s.filter(|v| v.is_finite()).map_or(0.0, |v| v * v))
                .collect(),
        )
    }
}

/// Computes `σ` at `q` (see the module docs) with buffers for one chain.
pub struct Sigma {
    dim: usize,
    np: usize,
    tip: [f64; 3],
    jac: Vec<f64>,
    twists: Vec<[f64; 6]>,
}

impl Sigma {
    /// Buffers for a chain of `dim` and `np` estimated parameters.
    #[must_use]
    pub fn new(dim: usize, np: usize) -> Self {
        Sigma {
            dim,
            np,
            tip: [0.0; 3],
            jac: vec![0.0; dim * np],
            twists: vec![[0.0; 6]; np],
        }
    }

    /// `σ = √tr(J_p·Σ_p·J_pᵀ)` at joints `q` and parameters `p`.
    pub fn at(&mut self, factors: &[Factor], q: &[f64], p: &[f64], cov: &ParamCovariance) -> f64 {
        let (dim, np) = (self.dim, self.np);
        if matches!(cov, ParamCovariance::None) || np == 0 {
            return 0.0;
        }
        chain::tip_jacobian(
            factors,
            dim,
            q,
            p,
            &mut self.tip,
            &mut self.jac,
            &mut self.twists,
        );
        let mut trace = 0.0;
        for i in 0..dim {
            let row = &self.jac[i * np..(i + 1) * np];
            trace += match cov {
                ParamCovariance::None => 0.0,
                ParamCovariance::Diagonal(v) => row.iter().zip(v).map(|(a, s)| a * a * s).sum(),
                ParamCovariance::Full(c) => (0..np)
                    .map(|j| row[j] * (0..np).map(|k| c[j * np + k] * row[k]).sum::<f64>())
                    .sum(),
            };
        }
        trace.max(0.0).sqrt()
    }
}
