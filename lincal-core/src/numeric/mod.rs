//! Shared numerics, below every stage that fits: the streamed QR, Gram factor and bounded SVDs
//! (`linalg`), the Gram matrix of a block of rows (`gram`), the one Levenberg-Marquardt core (`lm`), robust statistics (`robust`: the
//! losses, the χ medians and the exact median that scale estimates use), and the one way
//! work is split over threads (`par_chunks`).
//!
//! Takes slices and matrices, gives factors, steps and scales; knows nothing of specs, poses
//! or reports (only the [`crate::model::CalibModel`] trait, for LM's parameter metadata).

pub(crate) mod gram;
pub mod linalg;
pub(crate) mod lm;
pub mod robust;

/// `a` wrapped into `(−π, π]`.
///
/// `w = a − 2π·⌊(a + π)/2π⌋ ∈ [−π, π)`, then `−π ↦ π`.
#[must_use]
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a - 2.0 * PI * ((a + PI) / (2.0 * PI)).floor();
    // w is in [−π, π); move −π to π.
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// `work` on consecutive chunks of `per` items (a thread each when there is more than one
/// chunk), the outputs concatenated in order: the same as `work(items)` whenever `work` maps
/// each item on its own.
pub(crate) fn par_chunks<T, R, F>(items: &[T], per: usize, work: F) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&[T]) -> Vec<R> + Sync,
{
    if per == 0 || per >= items.len() {
        return work(items);
    }
    crate::cores::map_parts(items.chunks(per).collect(), work)
        .into_iter()
        .flatten()
        .collect()
}
