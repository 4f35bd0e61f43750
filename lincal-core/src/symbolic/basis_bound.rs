//! A certified lower bound on `K` without the expansion, so that a fit can tell that the
//! linear method is out of reach (too few poses, or beyond its budget) before paying for
//! the basis.
//!
//! Every constraint function at any parameter values lies in the span of the basis:
//! `h_e(·; p) = Σ_k c_{e,k}(p)·Φ̃_k`. So for readings `q_1 … q_L` and parameter points
//! `p_1 … p_M`, the `(E·M) × L` matrix `H = [h_e(q_l; p_m)]` factors through the `K × L`
//! matrix `[Φ̃_k(q_l)]` and `rank H ≤ K`, always: when `H` reaches rank `L`, `K ≥ L` is
//! proved (exactly, modulo the prime: a rank modulo `p` never exceeds the rank over the
//! rationals of the same integer matrix, and the values are images of rational ones). A rank
//! below `L` proves nothing, and the caller builds the basis to learn `K`.

use super::eval::generic_point_mod;
use super::identify::sampled::{equation_values, readings_mod};
use super::modp::{self, Mp, RankCounter};
use super::slots::SlotPolys;

/// The largest `t` for which [`exceeds`] tries: its elimination costs `O(t³)` (a few
/// milliseconds at 128); beyond, building the basis is the cheaper way to know.
pub const CERTIFY_MAX: usize = 128;

/// The seed of the readings.
const READINGS_SEED: u64 = 0xb0a5_15ee_d000_0001;

/// The seed of the first parameter point (the next ones count up from it).
const POINT_SEED: u64 = 0xb0a5_15ee_d000_1000;

/// Whether `K > t` is proved from the constraint functions' values at `t + 1` readings and
/// fresh random parameter points (see the module docs). `false` means "not proved": `t` at
/// or beyond [`CERTIFY_MAX`], or the values' rank stopped growing below `t + 1`.
#[must_use]
pub fn exceeds(sp: &SlotPolys, t: usize) -> bool {
    if t >= CERTIFY_MAX {
        return false;
    }
    let l = t + 1;
    let mut rng = modp::Rng::new(READINGS_SEED);
    let readings = readings_mod(&sp.vars, l, &mut rng);
    let mut echelon = RankCounter::default();
    for m in 0..=l as u64 {
        let point: Vec<Mp> = generic_point_mod(&sp.vars, POINT_SEED + m)
            .into_iter()
            .map(Mp)
            .collect();
        let before = echelon.rank();
        for row in equation_values(sp, &point, &readings) {
            echelon.insert(row.into_iter().map(|x| x.0).collect());
            if echelon.rank() == l {
                return true;
            }
        }
        // A fresh generic point adding nothing: the span's image is complete, below `l`.
        if echelon.rank() == before {
            return false;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::CalibModel;
    use crate::symbolic::slots::slot_polys;
    use crate::symbolic::SymbolicModel;

    /// For every spec of the test set: `K > t` is proved for every `t < K` within reach and
    /// never for `t ≥ K`.
    #[test]
    fn bound_is_exact_below_k_and_never_above() {
        let mut checked = 0;
        for path in crate::symbolic::testutil::repo_spec_paths(&["tests/specs"]) {
            let spec = crate::symbolic::testutil::repo_spec(&path);
            let Ok(model) = SymbolicModel::from_spec(&spec) else {
                continue;
            };
            let sp = slot_polys(&spec).expect("slots");
            let k = model.basis_size();
            for t in [0, k / 2, k.saturating_sub(1), k, k + 1] {
                if t >= CERTIFY_MAX {
                    continue;
                }
                assert_eq!(exceeds(&sp, t), t < k, "{}: t = {t}, K = {k}", path);
            }
            checked += 1;
        }
        assert!(checked > 5, "only {checked} specs checked");
    }
}
