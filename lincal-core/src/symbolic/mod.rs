//! The exact symbolic engine: spec → expanded polynomials → minimal basis → identifiability.
//!
//! - [`monomial`], [`poly`]: exact polynomials in canonical trigonometric form.
//! - [`expand`]: DH product → tip `x(q; p)` → constraint function(s) `h(q; p)`.
//! - [`reduce`]: exact column reduction to the basis `Φ̃(q)` and `c(p)`.
//! - [`identify`]: rank of `∂c/∂p` modulo the scale (mixing) of `c`, gauge rule.
//! - [`model`]: [`SymbolicModel`], the one result everything downstream consumes.

pub mod eval;
pub mod expand;
pub mod identify;
pub mod model;
pub mod modp;
pub mod monomial;
pub mod poly;
pub mod program;
pub mod reduce;

pub use model::SymbolicModel;

mod tests;
mod testutil;
