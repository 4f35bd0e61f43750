//! Small dense kernels: dot products, and Cholesky factors of the `m × m` (`m ≤ 6`) blocks
//! of the rank-`m` updates, stored row-major in slices.

use nalgebra::DMatrix;

/// `Σₖ aₖ bₖ` over the shorter length, with four accumulators (vectorises).
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    let mut s = [0.0; 4];
    for (x, y) in ca.zip(cb) {
        s[0] += x[0] * y[0];
        s[1] += x[1] * y[1];
        s[2] += x[2] * y[2];
        s[3] += x[3] * y[3];
    }
    let mut t = (s[0] + s[2]) + (s[1] + s[3]);
    for (x, y) in ra.iter().zip(rb) {
        t += x * y;
    }
    t
}

/// In-place Cholesky factor of the symmetric `m × m` row-major `a` (lower triangle read):
/// `a = L Lᵀ` with `L` left in the lower triangle and the strict upper triangle zeroed.
/// `false` when `a` is not (numerically) positive definite.
pub(crate) fn chol(a: &mut [f64], m: usize) -> bool {
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let ljj = d.sqrt();
        a[j * m + j] = ljj;
        for i in j + 1..m {
            let mut s = a[i * m + j];
            for k in 0..j {
                s -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = s / ljj;
        }
        for i in 0..j {
            a[i * m + j] = 0.0;
        }
    }
    true
}

/// `det(L Lᵀ) = Πₖ L_kk²` of a factor from [`chol`].
pub(crate) fn chol_det(l: &[f64], m: usize) -> f64 {
    (0..m).map(|k| l[k * m + k] * l[k * m + k]).product()
}

/// `tr((L Lᵀ)⁻¹ F) = tr(L⁻¹ F L⁻ᵀ)` for a factor from [`chol`] and a symmetric row-major `F`.
pub(crate) fn chol_trace(l: &[f64], m: usize, f: &[f64]) -> f64 {
    // Rows of L⁻¹, by forward substitution on the identity.
    let mut inv = [0.0; 36];
    for c in 0..m {
        for i in c..m {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in c..i {
                s -= l[i * m + k] * inv[k * m + c];
            }
            inv[i * m + c] = s / l[i * m + i];
        }
    }
    let mut t = 0.0;
    for i in 0..m {
        for a in 0..=i {
            for b in 0..=i {
                t += inv[i * m + a] * f[a * m + b] * inv[i * m + b];
            }
        }
    }
    t
}

/// The lower Cholesky factor of a symmetric positive definite matrix (`None` otherwise).
pub(crate) fn chol_factor(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    nalgebra::Cholesky::new(a.clone()).map(|c| c.l())
}

/// `log det(L Lᵀ) = 2 Σₖ ln L_kk`.
pub(crate) fn chol_logdet(l: &DMatrix<f64>) -> f64 {
    2.0 * l.diagonal().iter().map(|v| v.ln()).sum::<f64>()
}

/// `L⁻¹` of a lower-triangular `L` with a positive diagonal.
pub(crate) fn lower_inverse(l: &DMatrix<f64>) -> DMatrix<f64> {
    let n = l.nrows();
    let mut inv = DMatrix::<f64>::identity(n, n);
    // Column by column forward substitution; L's diagonal is positive, so it cannot fail.
    for c in 0..n {
        for i in c..n {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in c..i {
                s -= l[(i, k)] * inv[(k, c)];
            }
            inv[(i, c)] = s / l[(i, i)];
        }
    }
    inv
}
