//! The linearised problem's rows as Gram matrices: per fold of the cross-validation, and per
//! relation between constraints ([`super::Linearized`] holds them; they are all the choice
//! reads of the data).

use nalgebra::{DMatrix, DVector};

use crate::calibrate::grouping::Folds;
use crate::calibrate::outliers::ROUNDING_FLOOR;
use crate::calibrate::OUTLIER_SIGMAS;
use crate::data::Poses;
use crate::error::Result;
use crate::fit::geometric::pose_jacobians;
use crate::model::CalibModel;
use crate::numeric::gram::{gram_update_rows, mirror_upper};
use crate::numeric::robust::chi_median;

/// Per fold, the Gram matrix of its poses' rows `[J | g]` (`w` square) at `p`, and its row
/// count; the rows made a chunk of poses at a time, so memory does not grow with the data.
/// A pose beyond [`OUTLIER_SIGMAS`] of the noise level `sigma` (on its residual norm, raised
/// by the `χ` median of its components, and beyond [`ROUNDING_FLOOR`]: the outlier warning's
/// rule) is left out: the choice is judged on the poses the noise explains, where one gross
/// outlier, named in the warnings, would decide it alone (a reading off by 0.5 rad among a
/// tracker's 120 poses failed the lack-of-fit test by itself).
pub(super) fn fold_grams(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    w: usize,
    folds: &Folds,
    sigma: f64,
) -> Result<(Vec<DMatrix<f64>>, Vec<usize>)> {
    const CHUNK: usize = 512;
    let mut gram = vec![DMatrix::<f64>::zeros(w, w); folds.folds];
    let mut rows = vec![0; folds.folds];
    for start in (0..poses.len()).step_by(CHUNK) {
        let chunk: Vec<usize> = (start..poses.len().min(start + CHUNK)).collect();
        let jac = pose_jacobians(model, &poses.select(&chunk), p)?;
        for (k, &l) in chunk.iter().enumerate() {
            let r = jac.pose(k);
            let n = r.len() / w;
            // The residual is each row's last entry.
            let norm = r
                .chunks_exact(w)
                .map(|row| row[w - 1].powi(2))
                .sum::<f64>()
                .sqrt();
            if norm > ROUNDING_FLOOR && norm > OUTLIER_SIGMAS * sigma * chi_median(n).max(1.0) {
                continue;
            }
            // In place: a product per pose allocated a `w × w` matrix each time.
            gram_update_rows(&mut gram[folds.fold[l]], r);
            rows[folds.fold[l]] += n;
        }
    }
    for g in &mut gram {
        mirror_upper(g.as_mut_slice(), w);
    }
    Ok((gram, rows))
}

/// Each relation's rows' Gram matrix `[w∇R | wR]ᵀ[w∇R | wR]` over the free parameters
/// `free`, with the constraints it relates; `w` the fit's weight for them from the data's
/// Gram matrices `gram` (the fit's own rule, [`crate::fit::relation::weight`]).
pub(super) fn relation_grams(
    model: &dyn CalibModel,
    p: &[f64],
    free: &[usize],
    gram: &[DMatrix<f64>],
) -> Vec<(DMatrix<f64>, [usize; 2])> {
    let w = free.len() + 1;
    if model.relations().is_empty() {
        return Vec::new();
    }
    let diag: Vec<f64> = (0..free.len())
        .map(|c| gram.iter().map(|g| g[(c, c)]).sum())
        .collect();
    let weight = crate::fit::relation::weight(&diag);
    model
        .relations()
        .iter()
        .map(|rel| {
            let mut out = DMatrix::zeros(w, w);
            for row in crate::fit::relation::relation_rows(model, rel, p) {
                let mut v = DVector::zeros(w);
                for (j, g) in row.gradient {
                    if let Some(c) = free.iter().position(|&f| f == j) {
                        v[c] += weight * g;
                    }
                }
                v[w - 1] = weight * row.residual;
                out += &v * v.transpose();
            }
            (out, rel.between)
        })
        .collect()
}
