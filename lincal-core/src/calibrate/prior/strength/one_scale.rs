//! Every candidate's step on one training set from one eigen-decomposition.
//!
//! For a training set (the Gram matrix `H` of the kept free parameters, its last column the
//! gradient `h`), the one-scale prior `P = Σ⁻¹/τ²` over the arm `a` gives the step
//! `(H + μ·E Σ⁻¹ Eᵀ) δ = −h − μ·E Σ⁻¹ o` with `μ = σ̂²/τ²`, `o` the arm's estimate less its
//! nominals and `E` the arm's columns. With the other kept parameters `b` profiled out,
//! - `C = H_aa − H_ab H_bb⁻¹ H_ba` and `r = −h_a + H_ab H_bb⁻¹ h_b` (the Schur complement),
//! - `Σ⁻¹ = RᵀR` (`R = L⁻¹`) and `δ_a = L y`,
//!
//! the arm's part solves `(LᵀCL + μI) y = Lᵀr − μ·R o`. One eigen-decomposition
//! `LᵀCL = VΛVᵀ` per training set then gives every candidate's
//! `y = V (Λ + μ)⁻¹ (Vᵀ Lᵀ r − μ·Vᵀ R o)` in `O(k²)`, and
//! `δ_b = −H_bb⁻¹(h_b + H_ba δ_a)`: one factorisation per fold where each of the grid's
//! candidates factorised its own normal matrix (25 per fold). The per-direction prior is
//! diagonal in the same eigenbasis: its step takes one `μ_k` per direction
//! ([`OneScale::per_direction_step`]).

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::{ard_variance, Linearized};

/// One training set's factors for every candidate (module docs).
pub(super) struct OneScale {
    /// The kept free parameters' positions: the arm's first (in its order), then `b`.
    kept: Vec<usize>,
    /// The number of free parameters (`δ`'s length).
    n: usize,
    /// `Λ`.
    lambda: DVector<f64>,
    /// `L V`: `δ_a = L V z` for the eigen-coordinates `z`.
    lv: DMatrix<f64>,
    /// `Vᵀ Lᵀ r`.
    data: DVector<f64>,
    /// `Vᵀ R o`.
    offset: DVector<f64>,
    /// The Cholesky factor of `H_bb` (`None`: no other kept parameter).
    hbb: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    /// `H_ba`.
    hba: DMatrix<f64>,
    /// `h_b`.
    hb: DVector<f64>,
}

impl OneScale {
    /// The factors on the training set `aug` (without fold `out`), `None` when `H_bb` is not
    /// positive definite (a parameter only the arm's prior could hold: the candidates then
    /// take their own factorisations, [`Linearized::step`]).
    pub(super) fn new(lin: &Linearized, out: Option<usize>, aug: &DMatrix<f64>) -> Option<Self> {
        let n = aug.nrows() - 1;
        let unseen = lin.unseen(out, aug);
        let others: Vec<usize> = (0..n)
            .filter(|&c| !unseen[c] && !lin.arm.contains(&c))
            .collect();
        let k = lin.arm.len();
        let at = |rows: &[usize], cols: &[usize]| {
            DMatrix::from_fn(rows.len(), cols.len(), |r, c| aug[(rows[r], cols[c])])
        };
        let grad = |rows: &[usize]| DVector::from_fn(rows.len(), |r, _| aug[(rows[r], n)]);
        let (mut c, ha) = (at(&lin.arm, &lin.arm), grad(&lin.arm));
        let mut r = -ha;
        let (hbb, hba, hb) = if others.is_empty() {
            (None, DMatrix::zeros(0, k), DVector::zeros(0))
        } else {
            let hbb = at(&others, &others);
            let chol = hbb.clone().cholesky()?;
            // A pivot lost to rounding (`l_ii² ≪ H_ii`) is a singular block, not a definite one.
            let lost = |i: usize| chol.l_dirty()[(i, i)].powi(2) <= 1e-12 * hbb[(i, i)];
            if (0..others.len()).any(lost) {
                return None;
            }
            let hba = at(&others, &lin.arm);
            let hb = grad(&others);
            // H_bb⁻¹ H_ba and H_bb⁻¹ h_b, for the complement and its right-hand side.
            let x = chol.solve(&hba);
            c -= hba.transpose() * &x;
            r += x.transpose() * &hb;
            (Some(chol), hba, hb)
        };
        let w = lin.l.transpose() * &c * &lin.l;
        let e = SymmetricEigen::new((&w + w.transpose()) * 0.5);
        let lv = &lin.l * &e.eigenvectors;
        let vt = e.eigenvectors.transpose();
        let data = &vt * (lin.l.transpose() * r);
        let offset = &vt * (&lin.linv * &lin.offset);
        let kept = lin.arm.iter().copied().chain(others).collect();
        Some(OneScale {
            kept,
            n,
            lambda: e.eigenvalues,
            lv,
            data,
            offset,
            hbb,
            hba,
            hb,
        })
    }

    /// The step `δ` over the free parameters (0 on those unseen) with the prior `Σ⁻¹/τ²`,
    /// `mu = σ̂²/τ²`; `None` when `LᵀCL + μI` is not positive definite in floating point.
    pub(super) fn step(&self, mu: f64) -> Option<DVector<f64>> {
        self.step_with(|_| mu)
    }

    /// The step with the per-direction prior found from this training set (module docs of
    /// [`super`]): `LᵀCL/σ̂²` is the data's whitened information, so its eigenvalues are
    /// `h_k = λ_k/σ̂²` and the unregularised estimate's coordinates `z_k = (VᵀR o)_k + d_k/λ_k`
    /// (`d = VᵀLᵀr`, the step at `μ = 0`); the prior `V diag(1/s_k²) Vᵀ` in the whitened
    /// coordinates is diagonal in the same basis, so each direction takes its own
    /// `μ_k = σ̂²/s_k²`. `None` as [`Self::step`], or at a zero `σ̂²`.
    pub(super) fn per_direction_step(&self, sigma2: f64) -> Option<DVector<f64>> {
        if sigma2.is_nan() || sigma2 <= 0.0 {
            return None;
        }
        self.step_with(|d| {
            let lambda = self.lambda[d];
            sigma2 / ard_variance(lambda / sigma2, || self.offset[d] + self.data[d] / lambda)
        })
    }

    /// The step with `μ_k` on eigen-direction `k` (module docs).
    fn step_with(&self, mu: impl Fn(usize) -> f64) -> Option<DVector<f64>> {
        let k = self.lambda.len();
        let mut z = DVector::zeros(k);
        for d in 0..k {
            let mu = mu(d);
            let den = self.lambda[d] + mu;
            if den <= 0.0 || !den.is_finite() {
                return None;
            }
            z[d] = (self.data[d] - mu * self.offset[d]) / den;
        }
        let da = &self.lv * z;
        let mut delta = DVector::zeros(self.n);
        for (i, &c) in self.kept[..k].iter().enumerate() {
            delta[c] = da[i];
        }
        if let Some(chol) = &self.hbb {
            let db = -chol.solve(&(&self.hb + &self.hba * &da));
            for (i, &c) in self.kept[k..].iter().enumerate() {
                delta[c] = db[i];
            }
        }
        Some(delta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::grouping::Grouping;
    use rand::{Rng, SeedableRng};

    /// A linearised problem of `n` free parameters, the first `k` the arm, from random rows
    /// (one fold) and a random invertible `L⁻¹`.
    fn problem(n: usize, k: usize, rows: usize, seed: u64) -> Linearized {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let m = DMatrix::from_fn(rows, n + 1, |_, _| rng.gen_range(-1.0..1.0));
        let linv = DMatrix::from_fn(k, k, |r, c| {
            rng.gen_range(-0.3..0.3) + if r == c { 2.0 } else { 0.0 }
        });
        let l = linv.clone().try_inverse().expect("diagonally dominant");
        Linearized {
            arm: (0..k).collect(),
            offset: DVector::from_fn(k, |_, _| rng.gen_range(-0.1..0.1)),
            unit_precision: linv.transpose() * &linv,
            linv,
            l,
            sigma2: 1e-3,
            free: (0..n).collect(),
            gram: vec![m.transpose() * &m],
            fold_rows: vec![rows],
            relations: Vec::new(),
            trained: vec![Vec::new()],
            values: Vec::new(),
            folds: 1,
            grouping: Grouping::Clusters,
        }
    }

    #[test]
    fn the_one_scale_steps_are_the_normal_equations_solutions() {
        // Arm and other parameters, the arm alone; well and barely determined (fewer rows
        // than parameters: only the prior makes the arm's part definite).
        for (n, k, rows) in [(9, 5, 40), (6, 6, 30), (12, 8, 10), (7, 3, 9)] {
            let lin = problem(n, k, rows, (n * 100 + rows) as u64);
            let aug = lin.training(None);
            let fam = OneScale::new(&lin, None, &aug).expect("H_bb definite");
            for t in [1e-6, 1e-3, 1e-2, 1.0] {
                let p = &lin.unit_precision / (t * t);
                let want = lin.step(None, &aug, Some(&p));
                let got = fam.step(lin.sigma2 / (t * t)).expect("definite");
                let scale = want.amax().max(1e-300);
                assert!(
                    (&got - &want).amax() <= 1e-8 * scale,
                    "n {n} k {k} rows {rows} τ {t}: {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn the_per_direction_step_is_the_normal_equations_solution_with_its_prior() {
        // Arm and other parameters, the arm alone; a direction the rows barely see (few
        // rows) keeps the default tolerance.
        for (n, k, rows) in [(9, 5, 40), (6, 6, 30), (12, 8, 10), (7, 3, 9)] {
            let lin = problem(n, k, rows, (n * 100 + rows) as u64 + 1);
            let aug = lin.training(None);
            let fam = OneScale::new(&lin, None, &aug).expect("H_bb definite");
            let p = lin.precision(super::super::Candidate::Ard, None, &aug);
            let want = lin.step(None, &aug, Some(&p));
            let got = fam.per_direction_step(lin.sigma2).expect("definite");
            assert!(
                (&got - &want).amax() <= 1e-7 * want.amax().max(1e-300),
                "n {n} k {k} rows {rows}: {got} against {want}"
            );
        }
    }

    #[test]
    fn a_singular_other_block_is_left_to_the_candidates_own_factorisation() {
        let mut lin = problem(6, 3, 30, 7);
        // Parameter 5 unseen by these rows yet kept: its diagonal is not tiny, its block
        // is singular (a copy of parameter 4's column).
        let g = &mut lin.gram[0];
        for r in 0..7 {
            g[(r, 5)] = g[(r, 4)];
            g[(5, r)] = g[(4, r)];
        }
        g[(5, 5)] = g[(4, 4)];
        let aug = lin.training(None);
        assert!(OneScale::new(&lin, None, &aug).is_none());
    }
}
