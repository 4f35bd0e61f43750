//! The expansion's size limits: `--max-terms`, and what the memory this process has left
//! holds ([`crate::memory`]); the error that names the spec, the size and what reduces it.

use super::poly::ProductError;
use crate::error::Error;
use crate::spec::Spec;

/// Bytes of peak memory per term of the largest predicted polynomial, about: the monomial
/// (64 bytes) and its rational coefficient in a hash table, the product being formed beside
/// its factors, the other equations' polynomials, the reduction's copy and the basis.
/// Measured on 9-joint arms with every DH parameter unknown: 280 (a point) to 960 (a
/// measured pose with the tool frame's angles unknown: 12 equations) bytes per predicted
/// term, 1.1 to 3.7 GB at 3.8 million.
pub(super) const BYTES_PER_TERM: u64 = 1000;

/// Bytes the column reduction adds per term of all constraint polynomials together (its
/// entries, row keys and the generalized parameters' tables), checked against the memory
/// left before it starts ([`reduction_fits`]).
pub(super) const REDUCE_BYTES_PER_TERM: u64 = 200;

/// Whether the reduction of `terms` terms in all fits in what the memory this process has
/// left holds; the memory error ([`ProductError::Memory`]) otherwise, not an abort.
pub(super) fn reduction_fits(terms: usize) -> Result<(), ProductError> {
    let need = u64::try_from(terms)
        .unwrap_or(u64::MAX)
        .saturating_mul(REDUCE_BYTES_PER_TERM);
    if need > crate::memory::budget() {
        Err(ProductError::Memory)
    } else {
        Ok(())
    }
}

/// The most terms one polynomial may have in the memory this process has left
/// ([`crate::memory::budget`]).
pub(super) fn memory_terms() -> u64 {
    crate::memory::budget() / BYTES_PER_TERM
}

/// The error of an expansion that would cross `max_terms`.
pub(super) fn too_big(spec: &Spec, predicted: usize, max_terms: usize, at: &str) -> Error {
    let memory = u64::try_from(max_terms).unwrap_or(u64::MAX) >= memory_terms();
    let limit = if memory {
        format!(
            "what the memory this process has left holds ({max_terms} terms of about \
             {BYTES_PER_TERM} bytes; an address-space limit, a cgroup or free memory)"
        )
    } else {
        format!(
            "the limit of {max_terms} terms (`--max-terms`, about {BYTES_PER_TERM} bytes per \
             term)"
        )
    };
    Error::other(format!(
        "spec `{}`: the exact expansion would grow to about {predicted} terms {at}, beyond \
         {limit}; with every \
         length, twist and home offset unknown it grows about fourfold per joint. Make the \
         parameters that drawings fix `known: true`, use a constraint with fewer unknowns, or \
         {} (the parameter-space fit itself needs no expansion)",
        spec.name,
        if memory {
            "give the process more memory"
        } else {
            "raise --max-terms"
        }
    ))
}

/// A product the expansion could not form: an exponent beyond 15, or terms beyond the memory
/// left.
impl From<ProductError> for Error {
    fn from(e: ProductError) -> Self {
        match e {
            ProductError::Degree => Error::other(
                "a monomial exponent exceeded 15: the spec's polynomial degree is too high",
            ),
            ProductError::Memory => Error::other(
                "the exact expansion outgrew what the memory this process has left holds (an \
                 address-space limit, a cgroup or free memory): make the parameters that \
                 drawings fix `known: true`, lower --max-terms, or give the process more \
                 memory (the parameter-space fit itself needs no expansion)",
            ),
        }
    }
}
