//! The Gram matrix of a block of rows, `G += B·Bᵀ`: the one product every linearisation of
//! the fit pays for each pose (`fit::geometric::problem`).
//!
//! A symmetric rank-`k` update of the upper triangle in register tiles of `4 × 8` entries,
//! each tile the sum over the block's `k` rows of an outer product. Compiled twice: for AVX2
//! with fused multiply-add, chosen at run time where the processor has them, and for the
//! baseline instruction set. Nothing is allocated: a general product (nalgebra's `gemm`,
//! that is matrixmultiply) packs both operands into a fresh buffer of about 230 KB per call,
//! and on the fit of a 7-joint arm on six sockets that buffer's first-touch page faults and
//! packing took 17 % of the whole process's time (`perf`, BENCHMARKS.md, issue 48).

use nalgebra::DMatrix;

/// Rows of a register tile.
const TILE_ROWS: usize = 4;
/// Columns of a register tile (two AVX2 vectors).
const TILE_COLS: usize = 8;

/// `G += B·Bᵀ` on the upper triangle (`i ≤ j`), for `G` (`w × w`) and the first `filled`
/// columns of `B` (`w × cols`, one residual row of the Jacobian per column): entry `G[i, j]`
/// gains `Σ_k B[i, k]·B[j, k]`.
///
/// Entries below the diagonal are left in any state; [`mirror_upper`] completes `G` once
/// every block is in.
pub(crate) fn gram_update(g: &mut DMatrix<f64>, b: &DMatrix<f64>, filled: usize) {
    let w = g.nrows();
    debug_assert!(g.ncols() == w && b.nrows() == w && filled <= b.ncols());
    gram_update_rows(g, &b.as_slice()[..w * filled]);
}

/// `G += Σ_k r_k·r_kᵀ` on the upper triangle of `g` (`w × w`), the `r_k` the consecutive
/// length-`w` pieces of `rows` (a pose's residual rows, row-major): [`gram_update`] on a
/// slice. Entries below the diagonal as there; [`mirror_upper`] completes `g`.
pub(crate) fn gram_update_rows(g: &mut DMatrix<f64>, rows: &[f64]) {
    let w = g.nrows();
    debug_assert!(g.ncols() == w && rows.len().is_multiple_of(w.max(1)));
    if w == 0 || rows.len() < w {
        return;
    }
    let rows = &rows[..rows.len() / w * w];
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has both features, just detected.
        unsafe { update_avx2_fma(g.as_mut_slice(), rows, w) };
        return;
    }
    update_upper(g.as_mut_slice(), rows, w, |x, y, acc| x * y + acc);
}

/// [`update_upper`] compiled for AVX2 and FMA (its tiles become vector code).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn update_avx2_fma(g: &mut [f64], rows: &[f64], w: usize) {
    update_upper(g, rows, w, f64::mul_add);
}

/// `g += Σ_k r_k·r_kᵀ` on (at least) the upper triangle of the column-major `w × w` `g`, the
/// `r_k` the consecutive length-`w` pieces of `rows`; `fma(x, y, acc) = x·y + acc`.
///
/// Tiles of [`TILE_ROWS`] × [`TILE_COLS`] cover the upper triangle; where `w` is not a
/// multiple of the tile, the last tile of a row or column overlaps the one before and only
/// its new entries are added, so every tile runs the full-width code.
#[inline(always)]
fn update_upper(g: &mut [f64], rows: &[f64], w: usize, fma: impl Fn(f64, f64, f64) -> f64 + Copy) {
    if w < TILE_COLS {
        for r in rows.chunks_exact(w) {
            for j in 0..w {
                for i in 0..=j {
                    g[i + j * w] = fma(r[i], r[j], g[i + j * w]);
                }
            }
        }
        return;
    }
    let mut j_done = 0;
    while j_done < w {
        let j0 = j_done.min(w - TILE_COLS);
        let j_end = j0 + TILE_COLS;
        let mut i_done = 0;
        while i_done < j_end {
            let i0 = i_done.min(j_end - TILE_ROWS);
            let acc = tile(rows, w, i0, j0, fma);
            for (a, row) in acc.iter().enumerate().skip(i_done - i0) {
                for (d, v) in row.iter().enumerate().skip(j_done - j0) {
                    g[(i0 + a) + (j0 + d) * w] += v;
                }
            }
            i_done = i0 + TILE_ROWS;
        }
        j_done = j_end;
    }
}

/// `Σ_k r_k[i0..i0+4] ⊗ r_k[j0..j0+8]`, held in registers.
#[inline(always)]
fn tile(
    rows: &[f64],
    w: usize,
    i0: usize,
    j0: usize,
    fma: impl Fn(f64, f64, f64) -> f64 + Copy,
) -> [[f64; TILE_COLS]; TILE_ROWS] {
    let mut acc = [[0.0; TILE_COLS]; TILE_ROWS];
    for r in rows.chunks_exact(w) {
        let x: &[f64; TILE_ROWS] = r[i0..i0 + TILE_ROWS].try_into().expect("tile inside w");
        let y: &[f64; TILE_COLS] = r[j0..j0 + TILE_COLS].try_into().expect("tile inside w");
        for (acc_row, &xa) in acc.iter_mut().zip(x) {
            for (a, &yd) in acc_row.iter_mut().zip(y) {
                *a = fma(xa, yd, *a);
            }
        }
    }
    acc
}

/// Copies the upper triangle of the square column-major `g` (`w × w`) onto its lower one,
/// completing a matrix that [`gram_update`] built.
pub(crate) fn mirror_upper(g: &mut [f64], w: usize) {
    for j in 0..w {
        for i in 0..j {
            g[j + i * w] = g[i + j * w];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `B·Bᵀ` added to `G`'s upper triangle and mirrored, against the plain product, for
    /// widths around the tile sizes (the overlapping last tiles) and the scalar path below
    /// them, with both the vector and the portable code.
    #[test]
    fn gram_update_and_mirror_give_b_times_b_transposed() {
        let cases = [
            (1, 1),
            (3, 4),
            (5, 7),
            (7, 9),
            (8, 3),
            (9, 5),
            (12, 17),
            (13, 2),
        ];
        for (w, filled) in cases
            .into_iter()
            .chain([(28, 256), (53, 256), (9, 0), (0, 3)])
        {
            // Three columns beyond `filled`, which must not count.
            let cols = filled + 3;
            let b = DMatrix::from_fn(w, cols, |i, k| {
                (((i + k * w) * 7919 % 113) as f64 - 56.0) / 17.0
            });
            let g0 = DMatrix::from_fn(w, w, |i, j| (i + j * w) as f64 * 0.5);
            let bm = b.columns(0, filled);
            // The starting lower triangle is replaced by the upper one: compare against the
            // symmetric completion of the start plus B·Bᵀ.
            let upper0 = DMatrix::from_fn(w, w, |i, j| g0[(i.min(j), i.max(j))]);
            let want = upper0 + bm * bm.transpose();
            let mut vector = g0.clone();
            gram_update(&mut vector, &b, filled);
            let mut portable = g0.clone();
            if w > 0 {
                let rows = &b.as_slice()[..w * filled];
                update_upper(portable.as_mut_slice(), rows, w, |x, y, a| x * y + a);
            }
            for g in [&mut vector, &mut portable] {
                mirror_upper(g.as_mut_slice(), w);
                for i in 0..w {
                    for j in 0..w {
                        let (a, e) = (g[(i, j)], want[(i, j)]);
                        assert!((a - e).abs() <= 1e-12 * e.abs().max(1.0), "w {w} ({i},{j})");
                    }
                }
            }
        }
    }
}
