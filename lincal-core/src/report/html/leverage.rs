//! Each pose's leverage in the fit: how much the calibrated parameters depend on it.
//!
//! # The leverage of a pose
//! At the estimate, the fit's linearisation stacks every kept pose's residual rows
//! `J_l = ∂g_l/∂p_F` over the free (gauge-fixed) parameters into `J` (the fit's own rows,
//! [`crate::fit::geometric::pose_jacobians`], a measured pose's orientation rows weighted as
//! the fit weighed them). The hat matrix `H = J(JᵀJ)⁺Jᵀ` maps the residuals' noise onto the
//! fitted residuals; pose `l`'s leverage is the sum of its diagonal over the pose's rows,
//!
//! `h_l = tr(J_l (JᵀJ)⁺ J_lᵀ)`,  `0 ≤ h_l ≤ m_l`,  `Σ_l h_l = rank J`,
//!
//! (the number of free parameters the data determine), so the mean is `rank/N`. A pose of
//! high leverage is one the fit depends on most: alone in its region of the workspace, the
//! parameters would move most if it were wrong, and its own residual says least about it
//! (a pose of leverage near `m_l` is fitted whatever its error). A common uniform weight
//! does not change `H`, so the rows need no whitening by a noise level.
//!
//! # Computation
//! Two streamed passes over the poses in chunks (memory `O(chunk + n²)`, not `O(N·n)`):
//! the triangular factor `R` of `J` ([`StreamingQr`], `RᵀR = JᵀJ` without squaring the
//! condition), then with the SVD `R·D⁻¹ = UΣVᵀ` (`D` the column norms, so the parameters'
//! units do not matter), each row `j` gives `‖Σ_r⁻¹V_rᵀD⁻¹jᵀ‖²` over the `r` singular values
//! above the numerical-rank threshold ([`numerical_rank`]). The leverage left out: the
//! prior's and the relations' rows (so `Σ h_l` is the rank of the data alone) and a robust
//! fit's weights.

use nalgebra::DVector;

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::fit::geometric::pose_jacobians;
use crate::model::CalibModel;
use crate::numeric::linalg::{col_norms, numerical_rank, scaled_svd, StreamingQr};

/// Poses named in the report as those of highest leverage.
pub const TOP_LEVERAGE: usize = 10;

/// Poses per chunk of the two passes.
const CHUNK: usize = 4096;

/// Every pose's leverage (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Leverage {
    /// `h_l` of each pose as given; NaN for a pose the fit left out (rejected).
    pub values: Vec<f64>,
    /// `rank J = Σ_l h_l`: the free parameters the data determine.
    pub rank: usize,
    /// The free parameters (columns of `J`).
    pub free: usize,
    /// The poses of highest leverage, highest first: `(pose, line, h_l)`, at most
    /// [`TOP_LEVERAGE`].
    pub top: Vec<(usize, usize, f64)>,
}

/// Each pose's leverage at the parameters `p` (all of the model's, the estimate's values) for
/// the fit of `model` to `poses`, leaving out the poses `left_out` (0-based; rejected).
///
/// # Errors
/// No pose kept, no free parameter, or a residual or Jacobian that is not finite.
pub fn pose_leverage(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    left_out: &[usize],
) -> Result<Leverage> {
    let mut kept = vec![true; poses.len()];
    for &l in left_out {
        if let Some(k) = kept.get_mut(l) {
            *k = false;
        }
    }
    let index: Vec<usize> = (0..poses.len()).filter(|&l| kept[l]).collect();
    let basis = Basis::of(model, poses, p, &index)?;
    // Pass 2: h_l = Σ over the pose's rows of ‖Σ_r⁻¹ V_rᵀ D⁻¹ jᵀ‖².
    let free = basis.d.len();
    let mut values = vec![f64::NAN; poses.len()];
    for chunk in index.chunks(CHUNK) {
        let jac = pose_jacobians(model, &poses.select(chunk), p)?;
        for (k, &l) in chunk.iter().enumerate() {
            let mut h = 0.0;
            for row in jac.pose(k).chunks_exact(jac.width()) {
                let y = DVector::from_iterator(
                    free,
                    row[..free].iter().zip(&basis.d).map(|(a, s)| a / s),
                );
                for &(c, s) in &basis.seen {
                    let z = basis.v.column(c).dot(&y) / s;
                    h += z * z;
                }
            }
            values[l] = h;
        }
    }
    let mut order: Vec<usize> = index;
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    let top = order
        .into_iter()
        .take(TOP_LEVERAGE)
        .map(|l| (l, poses.line.at(l), values[l]))
        .collect();
    Ok(Leverage {
        values,
        rank: basis.seen.len(),
        free,
        top,
    })
}

/// The directions the stacked `J` of the kept poses determines: with `R·D⁻¹ = UΣVᵀ`
/// (`RᵀR = JᵀJ`, `D` the column norms of `R`), `V`'s columns and `Σ`'s values above the
/// numerical-rank threshold.
struct Basis {
    /// The column scale `D` (1 for a zero column).
    d: Vec<f64>,
    /// `V` (columns the right singular vectors).
    v: nalgebra::DMatrix<f64>,
    /// `(column of V, singular value)` above the threshold.
    seen: Vec<(usize, f64)>,
}

impl Basis {
    /// Pass 1 over the poses `index` (chunks of [`CHUNK`]): `R` by the streamed QR, then its
    /// scaled SVD.
    fn of(model: &dyn CalibModel, poses: &Poses, p: &[f64], index: &[usize]) -> Result<Basis> {
        let mut qr: Option<StreamingQr> = None;
        let mut rows = 0;
        for chunk in index.chunks(CHUNK) {
            let jac = pose_jacobians(model, &poses.select(chunk), p)?;
            let free = jac.free.len();
            if free == 0 {
                return Err(Error::other("no free parameter"));
            }
            let qr = qr.get_or_insert_with(|| StreamingQr::new(free));
            for row in jac.rows.chunks_exact(jac.width()) {
                qr.push_row(&row[..free]);
                rows += 1;
            }
        }
        let Some(mut qr) = qr else {
            return Err(Error::other("no pose was kept by the fit"));
        };
        let r = qr.finish();
        let d: Vec<f64> = col_norms(&r)
            .into_iter()
            .map(|v| if v > 0.0 { v } else { 1.0 })
            .collect();
        let (sv, v) = scaled_svd(&r, &d)?;
        // The threshold of [`numerical_rank`], whatever the order of the values.
        let smax = sv.iter().copied().fold(0.0, f64::max);
        let tol = rows.max(sv.len()) as f64 * f64::EPSILON * smax;
        let seen: Vec<(usize, f64)> = sv
            .iter()
            .enumerate()
            .filter(|&(_, &s)| s > tol)
            .map(|(c, &s)| (c, s))
            .collect();
        debug_assert!(smax <= 0.0 || seen.len() == numerical_rank(&sv, rows));
        Ok(Basis { d, v, seen })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;
    use crate::simulate::{simulate, Noise};
    use crate::symbolic::SymbolicModel;

    fn arm() -> (SymbolicModel, crate::spec::Spec) {
        let yaml = "name: point_planar3
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-3.0, 3.0]}
  - {type: revolute, a: a2, home: th2, limits: [-3.0, 3.0]}
  - {type: revolute, a: a3, home: th3, limits: [-3.0, 3.0]}
params: {a1: {nominal: 0.4}, th1: {nominal: 0.0}, a2: {nominal: 0.3}, th2: {nominal: 0.0},
         a3: {nominal: 0.2}, th3: {nominal: 0.0}, px: {nominal: 0.45}, py: {nominal: 0.2}}
constraint:
  point: {p: [px, py]}
";
        let spec = crate::spec::from_yaml_str(yaml, None).expect("spec");
        (SymbolicModel::from_spec(&spec).expect("model"), spec)
    }

    /// Each pose's leverage from the SVD of the whole stacked `J` (`J = UΣVᵀ`, `h_l` the
    /// squared norms of `U`'s rows of the pose over the nonzero singular values).
    fn dense(model: &SymbolicModel, poses: &Poses, p: &[f64]) -> Vec<f64> {
        let jac = pose_jacobians(model, poses, p).expect("jacobians");
        let (n, w) = (jac.free.len(), jac.width());
        let rows: Vec<f64> = jac
            .rows
            .chunks_exact(w)
            .flat_map(|r| r[..n].to_vec())
            .collect();
        let j = DMatrix::from_row_slice(rows.len() / n, n, &rows);
        let svd = j.svd(true, false);
        let u = svd.u.expect("U");
        let smax = svd.singular_values.max();
        (0..poses.len())
            .map(|l| {
                (jac.offsets[l]..jac.offsets[l + 1])
                    .map(|r| {
                        (0..n)
                            .filter(|&k| svd.singular_values[k] > 1e-10 * smax)
                            .map(|k| u[(r, k)] * u[(r, k)])
                            .sum::<f64>()
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn leverages_sum_to_the_rank_and_match_the_hat_matrix() {
        let (model, spec) = arm();
        let noise = Noise {
            track: 1e-5,
            ..Noise::default()
        };
        // Over 4096 poses: two chunks in each pass.
        let sim = simulate(&model, &spec, 4500, 3, None, noise).expect("simulate");
        let p = sim.truth.clone();
        let lev = pose_leverage(&model, &sim.poses, &p, &[]).expect("leverage");
        assert_eq!(lev.free, 6, "a1, th1 held");
        assert_eq!(lev.rank, lev.free);
        let sum: f64 = lev.values.iter().sum();
        assert!((sum - lev.rank as f64).abs() < 1e-6, "Σ h = {sum}");
        let expect = dense(&model, &sim.poses, &p);
        for (a, b) in lev.values.iter().zip(&expect) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
            assert!((0.0..=2.0).contains(a));
        }
        // The top poses, highest first, are the largest leverages.
        let max = expect.iter().copied().fold(0.0, f64::max);
        assert_eq!(lev.top.len(), TOP_LEVERAGE);
        assert!((lev.top[0].2 - max).abs() < 1e-9);
        assert!(lev.top.windows(2).all(|w| w[0].2 >= w[1].2));
        assert_eq!(lev.top[0].1, sim.poses.line.at(lev.top[0].0));
    }

    #[test]
    fn left_out_poses_and_too_few_rows() {
        let (model, spec) = arm();
        let sim = simulate(&model, &spec, 30, 5, None, Noise::default()).expect("simulate");
        let p = sim.truth.clone();
        let lev = pose_leverage(&model, &sim.poses, &p, &[3, 7, 99]).expect("leverage");
        assert!(lev.values[3].is_nan() && lev.values[7].is_nan());
        let sum: f64 = lev.values.iter().filter(|v| v.is_finite()).sum();
        assert!((sum - 6.0).abs() < 1e-6, "Σ h = {sum}");
        assert!(lev.top.iter().all(|t| t.0 != 3 && t.0 != 7));
        // Two poses, four rows, six free parameters: rank 4, each pose fitted exactly.
        let two = sim.poses.select(&[0, 1]);
        let lev = pose_leverage(&model, &two, &p, &[]).expect("leverage");
        assert_eq!(lev.rank, 4);
        for h in &lev.values {
            assert!((h - 2.0).abs() < 1e-6, "{h}");
        }
        assert!(pose_leverage(&model, &two, &p, &[0, 1]).is_err());
    }
}
