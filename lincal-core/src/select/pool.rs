//! The candidate pool: every candidate's whitened Jacobian block for every draw, stored
//! compactly (one row-major `Vec<f64>` per draw, `P·m·n·D` doubles in all), and the given
//! information.

use nalgebra::{DMatrix, DMatrixView};

use super::types::SelectError;

/// Most rows a candidate's block may have.
pub const MAX_ROWS: usize = 6;

/// Candidates per gathered block when information matrices are accumulated.
const GATHER: usize = 256;

/// The candidates of a selection.
///
/// Candidate `i` has, for each draw `d`, a block `J_dᵢ` of `mᵢ` rows (`1 ≤ mᵢ ≤ 6`, the same
/// for every draw) and `n` columns: its whitened residual Jacobian with respect to the free
/// parameters, evaluated at parameter vector `d` (draw 0 the nominal). Its information is
/// `J_dᵢᵀ J_dᵢ`. Optionally each draw has a given information `G_d` (`n × n`, positive
/// semi-definite) of poses already measured, added to every design.
///
/// Storage: draw `d` is one row-major `Vec<f64>` of `Σᵢ mᵢ` rows of `n` values, candidate
/// `i`'s rows starting at row `Σ_{j<i} m_j`; nothing is quadratic in the pool size.
#[derive(Clone, Debug)]
pub struct Pool {
    n: usize,
    /// `P + 1` row offsets: candidate `i` has rows `start[i]..start[i + 1]`.
    start: Vec<usize>,
    /// One row-major `rows × n` array per draw.
    blocks: Vec<Vec<f64>>,
    /// `G_d`, zero when nothing is given.
    given: Vec<DMatrix<f64>>,
    /// Per draw the pool's mean information `(1/P) Σᵢ J_dᵢᵀJ_dᵢ`, computed once when first
    /// asked for (the regulariser, the baselines and the worth all read it).
    mean: std::sync::OnceLock<Vec<DMatrix<f64>>>,
}

impl Pool {
    /// A pool from row counts and packed blocks: `rows[i] = mᵢ`, and `blocks[d]` holds the
    /// rows of every candidate for draw `d`, candidate after candidate, each row `n` values
    /// (so `blocks[d].len() = n·Σᵢ mᵢ`). No given information.
    ///
    /// # Errors
    /// [`SelectError::Shape`] for `n = 0`, no draw, a row count outside `1..=6` or a block of
    /// the wrong length; [`SelectError::NonFinite`] for a NaN or infinity.
    pub fn new(n: usize, rows: &[usize], blocks: Vec<Vec<f64>>) -> Result<Self, SelectError> {
        if n == 0 {
            return Err(SelectError::Shape("no parameter (n = 0)".into()));
        }
        if blocks.is_empty() {
            return Err(SelectError::Shape("no draw".into()));
        }
        let mut start = Vec::with_capacity(rows.len() + 1);
        start.push(0);
        for (i, &m) in rows.iter().enumerate() {
            if !(1..=MAX_ROWS).contains(&m) {
                return Err(SelectError::Shape(format!(
                    "candidate {i} has {m} rows (1 to {MAX_ROWS} allowed)"
                )));
            }
            start.push(start[i] + m);
        }
        let total = start[rows.len()];
        for (d, b) in blocks.iter().enumerate() {
            if b.len() != total * n {
                return Err(SelectError::Shape(format!(
                    "draw {d} holds {} values, {total} rows of {n} expected",
                    b.len()
                )));
            }
        }
        for (d, b) in blocks.iter().enumerate() {
            for i in 0..rows.len() {
                if b[start[i] * n..start[i + 1] * n]
                    .iter()
                    .any(|v| !v.is_finite())
                {
                    return Err(SelectError::NonFinite {
                        candidate: i,
                        draw: d,
                    });
                }
            }
        }
        let given = vec![DMatrix::zeros(n, n); blocks.len()];
        Ok(Pool {
            n,
            start,
            blocks,
            given,
            mean: std::sync::OnceLock::new(),
        })
    }

    /// A pool from one matrix per draw and candidate: `blocks[d][i] = J_dᵢ` (`mᵢ × n`).
    ///
    /// # Errors
    /// As [`Pool::new`], and [`SelectError::Shape`] when the draws disagree on the number of
    /// candidates or a candidate's row count, or a block has other than `n` columns.
    pub fn from_blocks(n: usize, blocks: &[Vec<DMatrix<f64>>]) -> Result<Self, SelectError> {
        let Some(first) = blocks.first() else {
            return Err(SelectError::Shape("no draw".into()));
        };
        let rows: Vec<usize> = first.iter().map(DMatrix::nrows).collect();
        let mut packed = Vec::with_capacity(blocks.len());
        for (d, draw) in blocks.iter().enumerate() {
            if draw.len() != rows.len() {
                return Err(SelectError::Shape(format!(
                    "draw {d} has {} candidates, draw 0 has {}",
                    draw.len(),
                    rows.len()
                )));
            }
            let mut v = Vec::with_capacity(rows.iter().sum::<usize>() * n);
            for (i, b) in draw.iter().enumerate() {
                if b.nrows() != rows[i] || b.ncols() != n {
                    return Err(SelectError::Shape(format!(
                        "candidate {i} of draw {d} is {}×{}, {}×{n} expected",
                        b.nrows(),
                        b.ncols(),
                        rows[i]
                    )));
                }
                for r in 0..b.nrows() {
                    v.extend(b.row(r).iter());
                }
            }
            packed.push(v);
        }
        Pool::new(n, &rows, packed)
    }

    /// `Ok` when `count` distinct candidates can be chosen.
    ///
    /// # Errors
    /// [`SelectError::TooFewCandidates`] for `count > P`.
    pub fn check_count(&self, count: usize) -> Result<(), SelectError> {
        let pool = self.n_candidates();
        if count > pool {
            return Err(SelectError::TooFewCandidates {
                wanted: count,
                pool,
            });
        }
        Ok(())
    }

    /// The pool with given information `G_d` (one `n × n` symmetric positive semi-definite
    /// matrix per draw) added to every design.
    ///
    /// # Errors
    /// [`SelectError::Shape`] for the wrong count or size or an asymmetric matrix,
    /// [`SelectError::NonFiniteInput`] for a NaN or infinity.
    pub fn with_given(mut self, given: Vec<DMatrix<f64>>) -> Result<Self, SelectError> {
        if given.len() != self.blocks.len() {
            return Err(SelectError::Shape(format!(
                "{} given matrices for {} draws",
                given.len(),
                self.blocks.len()
            )));
        }
        for (d, g) in given.iter().enumerate() {
            if g.shape() != (self.n, self.n) {
                return Err(SelectError::Shape(format!("given matrix {d} is not n × n")));
            }
            if g.iter().any(|v| !v.is_finite()) {
                return Err(SelectError::NonFiniteInput {
                    what: "given information",
                    index: d,
                });
            }
            let scale = g.amax();
            if (g - g.transpose()).amax() > 1e-9 * scale {
                return Err(SelectError::Shape(format!(
                    "given matrix {d} is not symmetric"
                )));
            }
        }
        self.given = given
            .into_iter()
            .map(|g| (&g + g.transpose()) * 0.5)
            .collect();
        Ok(self)
    }

    /// Number of free parameters `n`.
    #[must_use]
    pub fn n_params(&self) -> usize {
        self.n
    }

    /// Number of candidates `P`.
    #[must_use]
    pub fn n_candidates(&self) -> usize {
        self.start.len() - 1
    }

    /// Number of draws `D`.
    #[must_use]
    pub fn n_draws(&self) -> usize {
        self.blocks.len()
    }

    /// Rows `mᵢ` of candidate `i`'s block.
    ///
    /// # Panics
    /// If `i` is not a candidate.
    #[must_use]
    pub fn rows(&self, i: usize) -> usize {
        self.start[i + 1] - self.start[i]
    }

    /// The first row of candidate `i` in the packed arrays (`i = P` gives the total).
    #[must_use]
    pub(crate) fn row_start(&self, i: usize) -> usize {
        self.start[i]
    }

    /// Candidate `i`'s block for draw `d`, row-major (`mᵢ·n` values).
    ///
    /// # Panics
    /// If `d` is not a draw or `i` not a candidate.
    #[must_use]
    pub fn block(&self, d: usize, i: usize) -> &[f64] {
        &self.blocks[d][self.start[i] * self.n..self.start[i + 1] * self.n]
    }

    /// The packed rows of candidates `range` for draw `d`, row-major.
    pub(crate) fn span(&self, d: usize, range: std::ops::Range<usize>) -> &[f64] {
        &self.blocks[d][self.start[range.start] * self.n..self.start[range.end] * self.n]
    }

    /// The given information `G_d` (zero when none was given).
    ///
    /// # Panics
    /// If `d` is not a draw.
    #[must_use]
    pub fn given(&self, d: usize) -> &DMatrix<f64> {
        &self.given[d]
    }

    /// Checks that `chosen` names distinct candidates of the pool.
    ///
    /// # Errors
    /// [`SelectError::BadCandidate`] for the first index out of range or repeated.
    pub fn check_chosen(&self, chosen: &[usize]) -> Result<(), SelectError> {
        let mut seen = vec![false; self.n_candidates()];
        for &i in chosen {
            match seen.get_mut(i) {
                Some(s) if !*s => *s = true,
                _ => return Err(SelectError::BadCandidate { index: i }),
            }
        }
        Ok(())
    }

    /// The information of design `chosen` for draw `d`, without regulariser:
    /// `G_d + Σ_{i∈S} J_dᵢᵀ J_dᵢ`. Since the blocks are whitened, its inverse is the
    /// predicted covariance of the parameters (see [`crate::select::predicted_std`]).
    ///
    /// # Errors
    /// [`SelectError::BadCandidate`] for an index out of range or repeated,
    /// [`SelectError::Shape`] for a draw out of range.
    pub fn information(&self, d: usize, chosen: &[usize]) -> Result<DMatrix<f64>, SelectError> {
        if d >= self.n_draws() {
            return Err(SelectError::Shape(format!("no draw {d}")));
        }
        self.check_chosen(chosen)?;
        let mut acc = self.given[d].clone();
        self.accumulate(d, chosen.iter().map(|&i| (i, 1.0)), &mut acc);
        Ok(acc)
    }

    /// The pool's mean information of draw `d`, `M̄_d = (1/P) Σᵢ J_dᵢᵀJ_dᵢ` (zero for an
    /// empty pool), every draw computed on the first call, over threads.
    pub(crate) fn mean_information(&self, d: usize) -> &DMatrix<f64> {
        let all = self.mean.get_or_init(|| {
            let (n, p) = (self.n, self.n_candidates());
            let one = |d: usize| {
                let mut mean = DMatrix::zeros(n, n);
                if p > 0 {
                    let w = 1.0 / p as f64;
                    self.accumulate(d, (0..p).map(|i| (i, w)), &mut mean);
                }
                mean
            };
            if p * self.n_draws() < 2000 {
                return (0..self.n_draws()).map(one).collect();
            }
            // As many parts as cores, each its draws in turn (a helper per draw would pay
            // a thread's start a hundred times).
            let per = self.n_draws().div_ceil(crate::cores::available());
            let parts = (0..self.n_draws())
                .step_by(per.max(1))
                .map(|a| a..(a + per).min(self.n_draws()))
                .collect();
            crate::cores::map_parts(parts, |r: std::ops::Range<usize>| {
                r.map(one).collect::<Vec<_>>()
            })
            .into_iter()
            .flatten()
            .collect()
        });
        &all[d]
    }

    /// `acc += Σ wᵢ J_dᵢᵀ J_dᵢ` over `(i, wᵢ)` (`wᵢ ≥ 0`), by blocks of gathered rows
    /// scaled by `√wᵢ` and one matrix product per block.
    pub(crate) fn accumulate(
        &self,
        d: usize,
        items: impl Iterator<Item = (usize, f64)>,
        acc: &mut DMatrix<f64>,
    ) {
        let n = self.n;
        let mut buf: Vec<f64> = Vec::with_capacity(GATHER * n);
        let mut count = 0;
        let flush = |buf: &mut Vec<f64>, acc: &mut DMatrix<f64>| {
            let rows = buf.len() / n;
            if rows > 0 {
                let xt = DMatrixView::from_slice(buf, n, rows);
                acc.gemm(1.0, &xt, &xt.transpose(), 1.0);
            }
            buf.clear();
        };
        for (i, w) in items {
            let s = w.max(0.0).sqrt();
            buf.extend(self.block(d, i).iter().map(|v| v * s));
            count += 1;
            if count % GATHER == 0 {
                flush(&mut buf, acc);
            }
        }
        flush(&mut buf, acc);
        symmetrize(acc);
    }
}

/// `a ← (a + aᵀ)/2`.
pub(crate) fn symmetrize(a: &mut DMatrix<f64>) {
    let n = a.nrows();
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = v;
            a[(j, i)] = v;
        }
    }
}
