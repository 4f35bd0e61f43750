//! The exact symbolic engine: spec → expanded polynomials → minimal basis → identifiability.
//!
//! Its one public result is [`SymbolicModel`] (with [`Identifiability`] and the
//! [`Profile`] of a build); the stages are private to the crate:
//! - `monomial`, `poly`: exact polynomials in canonical trigonometric form;
//! - `expand`: DH product → tip `x(q; p)` → constraint function(s) `h(q; p)`, bounded by
//!   [`DEFAULT_MAX_TERMS`], over any `chain_poly` ring: the exact polynomials, or `sketch`'s
//!   image of them modulo a prime, which gives `K` alone in a fraction of the time;
//! - `reduce`: exact column reduction to the basis `Φ̃(q)` and `c(p)` (modular, certified);
//! - `identify`: rank of `∂c/∂p` modulo the scale (mixing) of `c`, the gauge rule;
//! - `eval`: compiled evaluation of `Φ̃`, `c` and `∂c/∂p` in `f64`.
//!
//! The straight-line programs the derive prints are built from a [`SymbolicModel`] in
//! [`crate::program`].

pub(crate) mod basis_bound;
pub(crate) mod basis_part;
pub mod certify;
pub(crate) mod chain_poly;
pub(crate) mod coef;
pub(crate) mod coverage;
pub(crate) mod eval;
pub(crate) mod expand;
pub(crate) mod expanded;
pub mod factored;
pub mod facts;
pub(crate) mod identify;
pub(crate) mod kinds;
pub(crate) mod limits;
pub(crate) mod link;
pub mod model;
pub(crate) mod modp;
pub(crate) mod monomial;
pub(crate) mod poly;
pub(crate) mod prefetch;
pub mod priority;
pub(crate) mod reduce;
pub(crate) mod relations;
pub(crate) mod sketch;
pub(crate) mod slots;
pub(crate) mod surrogate;

pub use expand::DEFAULT_MAX_TERMS;
pub use expanded::ExpandedEquations;
pub use facts::{ReportedBasisSize, SpecFacts};
pub use identify::Identifiability;
pub use model::{Profile, SymbolicModel, REPORT_C_TERMS, REPORT_MAX_TERMS};

mod tests;
pub(crate) mod testutil;
