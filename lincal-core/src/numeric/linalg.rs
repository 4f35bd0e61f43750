//! Dense linear algebra every stage shares: the streamed QR factor of tall matrices, the
//! Cholesky factor of a Gram matrix, and SVDs that cannot loop (bounded iterations, finite
//! input checked) with the numerical-rank rule used throughout.
//!
//! Built on nalgebra; nothing here knows about robots.

use nalgebra::{DMatrix, DVector, SVD};

use crate::error::{Error, Result};

/// Upper-triangular factor `R` of a QR decomposition of every row pushed so far, with
/// `RᵀR = AᵀA` for the matrix `A` of all rows.
///
/// Rows are buffered in blocks; when a block is full, `[R; block]` is factored again with
/// Householder QR, so memory stays `O(cols²)` however many rows are pushed.
///
/// # Example
/// ```
/// use lincal_core::numeric::linalg::StreamingQr;
/// let mut qr = StreamingQr::new(2);
/// for i in 0..1000 {
///     let t = f64::from(i) / 1000.0;
///     qr.push_row(&[1.0, t]);
/// }
/// let r = qr.finish();
/// // RᵀR is the Gram matrix: (0,0) entry = number of rows.
/// assert!(((r.transpose() * &r)[(0, 0)] - 1000.0).abs() < 1e-9);
/// ```
#[derive(Clone, Debug)]
pub struct StreamingQr {
    cols: usize,
    block: usize,
    /// Rows `0..cols` hold `R`; rows `cols..cols+buffered` the pending rows.
    work: DMatrix<f64>,
    buffered: usize,
    rows: usize,
}

impl StreamingQr {
    /// An empty accumulator for rows of length `cols`.
    #[must_use]
    pub fn new(cols: usize) -> Self {
        // Rows buffered before a flush: four times the columns (few flushes), but not beyond
        // 4 096 rows, so a wide basis does not hold five times its `R` (a `K` of 19 683 would
        // take 15.5 GB for the buffer alone).
        let block = (4 * cols).clamp(256, 4096);
        StreamingQr {
            cols,
            block,
            work: DMatrix::zeros(cols + block, cols),
            buffered: 0,
            rows: 0,
        }
    }

    /// Bytes [`StreamingQr::new`] allocates for `cols` columns.
    #[must_use]
    pub fn bytes(cols: usize) -> u64 {
        let block = (4 * cols).clamp(256, 4096) as u64;
        (cols as u64 + block) * cols as u64 * 8
    }

    /// Number of columns.
    #[must_use]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of rows pushed.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Appends one row (`cols` values).
    ///
    /// # Panics
    /// If `row` has the wrong length (a programming error, never user input).
    pub fn push_row(&mut self, row: &[f64]) {
        assert_eq!(row.len(), self.cols, "StreamingQr: row length");
        let i = self.cols + self.buffered;
        for (k, &v) in row.iter().enumerate() {
            self.work[(i, k)] = v;
        }
        self.buffered += 1;
        self.rows += 1;
        if self.buffered == self.block {
            self.flush();
        }
    }

    /// Folds the pending rows into `R`.
    fn flush(&mut self) {
        if self.buffered == 0 {
            return;
        }
        let m = self.cols + self.buffered;
        let stacked = self.work.rows(0, m).into_owned();
        let r = nalgebra::linalg::QR::new(stacked).unpack_r();
        // `r` is min(m, cols) × cols; m ≥ cols here, so it is square.
        self.work.fill(0.0);
        let n = r.nrows().min(self.cols);
        self.work
            .view_mut((0, 0), (n, self.cols))
            .copy_from(&r.rows(0, n));
        self.buffered = 0;
    }

    /// The `cols × cols` upper-triangular factor `R` (rows of zeros when fewer rows than
    /// columns were pushed). The accumulator stays usable.
    #[must_use]
    pub fn finish(&mut self) -> DMatrix<f64> {
        self.flush();
        self.work.rows(0, self.cols).into_owned()
    }
}

/// Column norms of a matrix.
#[must_use]
pub fn col_norms(r: &DMatrix<f64>) -> Vec<f64> {
    (0..r.ncols()).map(|c| r.column(c).norm()).collect()
}

/// Numerical rank of a matrix with `rows ≥` its size and these (descending) singular values:
/// the count above `max(rows, cols)·ε·σ_max`.
#[must_use]
pub fn numerical_rank(sv: &[f64], rows: usize) -> usize {
    let smax = sv.first().copied().unwrap_or(0.0);
    if smax <= 0.0 {
        return 0;
    }
    let tol = (rows.max(sv.len()) as f64) * f64::EPSILON * smax;
    sv.iter().filter(|&&s| s > tol).count()
}

/// SVD with a bounded iteration count and a finiteness check, singular values descending.
///
/// # Errors
/// [`Error::other`] for a non-finite matrix or when the iteration does not converge.
pub(crate) fn checked_svd(
    m: DMatrix<f64>,
    u: bool,
    v: bool,
) -> Result<SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if m.iter().any(|x| !x.is_finite()) {
        return Err(Error::other("a non-finite value reached an SVD"));
    }
    let m = if u { m } else { triangular_factor(m) };
    let n = m.nrows().max(m.ncols()).max(1);
    SVD::try_new(m, u, v, f64::EPSILON, 200 * n * n)
        .ok_or_else(|| Error::other("the SVD did not converge"))
}

/// `R` of `A = Q·R` for a tall `A` (more than twice as many rows as columns), else `A`: the
/// same singular values and right-singular vectors (`AᵀA = RᵀR`), from a Householder QR
/// (`2mn²` operations) and an SVD of `n × n`, where the SVD of `A` itself would
/// bidiagonalise all `m` rows (`4mn²`). The identifiability analysis's stacked Jacobians are
/// tall: thousands of sampled rows against tens of parameters.
pub(crate) fn triangular_factor(a: DMatrix<f64>) -> DMatrix<f64> {
    if a.nrows() > 2 * a.ncols() {
        a.qr().r()
    } else {
        a
    }
}

/// Singular values (descending) and right-singular vectors (columns) of `R·D⁻¹`.
pub(crate) fn scaled_svd(r: &DMatrix<f64>, scale: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let mut s = r.clone();
    for (c, &d) in scale.iter().enumerate() {
        s.column_mut(c).unscale_mut(d);
    }
    let svd = checked_svd(s, false, true)?;
    let v = svd
        .v_t
        .as_ref()
        .map(DMatrix::transpose)
        .ok_or_else(|| Error::other("SVD without V"))?;
    Ok((svd.singular_values.as_slice().to_vec(), v))
}

/// Least squares `min ‖M x − b‖` by SVD with relative tolerance `max(rows, cols)·ε·σ_max`.
pub(crate) fn lstsq(m: DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>> {
    let rows = m.nrows().max(m.ncols());
    let svd = checked_svd(m, true, true)?;
    let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
    let tol = rows as f64 * f64::EPSILON * smax;
    svd.solve(b, tol).map_err(|e| Error::other(e.to_string()))
}

/// The upper-triangular `R` with `RᵀR = G` (`G` symmetric positive semi-definite), by a
/// Cholesky factorisation of the equilibrated `D⁻¹GD⁻¹`; a pivot that vanishes (a dependent
/// column) gives a zero row, so a rank-deficient `G` still factors.
pub(crate) fn gram_factor(g: &DMatrix<f64>) -> DMatrix<f64> {
    let w = g.nrows();
    let d: Vec<f64> = (0..w)
        .map(|i| {
            let v = g[(i, i)].max(0.0).sqrt();
            if v > 0.0 {
                v
            } else {
                1.0
            }
        })
        .collect();
    let mut a = DMatrix::from_fn(w, w, |i, j| g[(i, j)] / (d[i] * d[j]));
    let mut r = DMatrix::zeros(w, w);
    for k in 0..w {
        let mut pivot = a[(k, k)];
        for i in 0..k {
            pivot -= r[(i, k)] * r[(i, k)];
        }
        // Relative to the equilibrated diagonal (≤ 1): below ε·w the column depends on the
        // previous ones.
        if pivot <= 4.0 * f64::EPSILON * w as f64 {
            continue;
        }
        let rkk = pivot.sqrt();
        r[(k, k)] = rkk;
        for j in k + 1..w {
            let mut v = a[(k, j)];
            for i in 0..k {
                v -= r[(i, k)] * r[(i, j)];
            }
            r[(k, j)] = v / rkk;
        }
    }
    a.fill(0.0);
    for j in 0..w {
        for i in 0..=j {
            r[(i, j)] *= d[j];
        }
    }
    r
}
