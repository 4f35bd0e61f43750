//! The per-candidate kernels of the search state: applying rank-`m` updates to a candidate's
//! blocks, recomputing blocks from a fresh factor, gains, and the split over threads.
//!
//! A candidate's record holds, per draw, `H = J̃M̃⁻¹J̃ᵀ` and (tip) `F = J̃M̃⁻¹C̃M̃⁻¹J̃ᵀ`,
//! `m × m` row-major. Adding candidate `a` (`U = J̃ₐM̃⁻¹`, `I + Hₐₐ = LLᵀ`, `B = L⁻¹U`) makes
//! `M̃⁻¹ ← M̃⁻¹ − BᵀB`; with `Z = J̃Bᵀ` and `Y = J̃M̃⁻¹C̃Bᵀ` (old `M̃⁻¹`) every record follows:
//! `H ← H − ZZᵀ`, `F ← F − ZYᵀ − YZᵀ + Z(BC̃Bᵀ)Zᵀ`. The vectors are kept in raw coordinates
//! (`b = W·B̃ᵀ`), so `Z = J·b` reads the pool directly.

use nalgebra::{DMatrix, DMatrixView};

use super::pool::Pool;
use super::small::{chol, chol_det, chol_trace, dot};
use crate::numeric::par_chunks;

/// Candidates per matrix product in a refresh (ranges split between threads are multiples).
pub(crate) const BLOCK: usize = 256;

/// One rank-`mₐ` addition, as the records need it.
pub(crate) struct Update {
    /// Rows of the added block.
    pub(crate) ma: usize,
    /// Per draw: rows of `B·Wᵀ` (`mₐ × n`), rows of `(W·M̃⁻¹C̃Bᵀ)ᵀ` (tip), `BC̃Bᵀ` (tip).
    pub(crate) draws: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

/// Runs `work(range, records, gains, versions)` over candidate ranges, in parallel when
/// `threads > 1`; range boundaries are multiples of [`BLOCK`], and the slices start at the
/// range's first candidate.
pub(crate) fn par_ranges<F>(
    threads: usize,
    off: &[usize],
    rec: &mut [f64],
    gains: &mut [f64],
    ver: &mut [usize],
    work: F,
) where
    F: Fn(std::ops::Range<usize>, &mut [f64], &mut [f64], &mut [usize]) + Sync,
{
    let p = gains.len();
    let blocks = p.div_ceil(BLOCK);
    let t = threads.min(blocks).max(1);
    if t <= 1 {
        work(0..p, rec, gains, ver);
        return;
    }
    let per = blocks.div_ceil(t) * BLOCK;
    let mut parts = Vec::new();
    let (mut rec, mut gains, mut ver) = (rec, gains, ver);
    let mut start = 0;
    while start < p {
        let end = (start + per).min(p);
        let (r, rest) = rec.split_at_mut(off[end] - off[start]);
        let (g, grest) = gains.split_at_mut(end - start);
        let (v, vrest) = ver.split_at_mut(end - start);
        (rec, gains, ver) = (rest, grest, vrest);
        parts.push((start..end, r, g, v));
        start = end;
    }
    crate::cores::map_parts(parts, |(range, r, g, v)| work(range, r, g, v));
}

/// The maps of a refresh for one draw: `q` (`q·Jᵀ = L̃⁻¹J̃ᵀ`) and, tip, `tq`
/// (`tq·q·Jᵀ = R̃M̃⁻¹J̃ᵀ`).
pub(crate) type Maps = (DMatrix<f64>, Option<DMatrix<f64>>);

/// Recomputes the records and gains of candidates `range` (slices from `range.start`):
/// `H = XᵀX` with `X = q·Jᵀ`, `F = YᵀY` with `Y = tq·X`, by one matrix product per block.
#[allow(clippy::too_many_arguments)]
pub(crate) fn refresh_range(
    pool: &Pool,
    maps: &[Maps],
    width: usize,
    tip: bool,
    in_set: &[bool],
    range: std::ops::Range<usize>,
    rec: &mut [f64],
    gains: &mut [f64],
) {
    let n = pool.n_params();
    let dn = pool.n_draws();
    let mut pos = 0;
    let mut a = range.start;
    while a < range.end {
        let b = (a + BLOCK).min(range.end);
        let rows = pool.row_start(b) - pool.row_start(a);
        for (d, (q, tq)) in maps.iter().enumerate() {
            let jt = DMatrixView::from_slice(pool.span(d, a..b), n, rows);
            let xt = q * jt;
            let yt = tq.as_ref().map(|t| t * &xt);
            let mut p = pos;
            for c in a..b {
                let m = pool.rows(c);
                let r0 = pool.row_start(c) - pool.row_start(a);
                let at = p + d * width * m * m;
                gram(xt.as_slice(), xt.nrows(), r0, m, &mut rec[at..at + m * m]);
                if let Some(y) = &yt {
                    let at = at + m * m;
                    gram(y.as_slice(), y.nrows(), r0, m, &mut rec[at..at + m * m]);
                }
                p += dn * width * m * m;
            }
        }
        for c in a..b {
            let m = pool.rows(c);
            let len = dn * width * m * m;
            gains[c - range.start] = if in_set[c] {
                f64::NEG_INFINITY
            } else {
                record_gain(&rec[pos..pos + len], m, dn, width, tip)
            };
            pos += len;
        }
        a = b;
    }
}

/// The D gains of candidates `cands` (not chosen) from fresh maps `q` per draw
/// (`q·Jᵀ = L̃⁻¹J̃ᵀ`, so `H = (qJᵀ)ᵀ(qJᵀ)`): each candidate's blocks gathered by [`BLOCK`],
/// one matrix product per gathered block and draw, over threads. A candidate's arithmetic
/// does not depend on the split, so neither do the gains.
pub(crate) fn subset_gains(
    pool: &Pool,
    maps: &[DMatrix<f64>],
    cands: &[usize],
    threads: usize,
) -> Vec<f64> {
    let n = pool.n_params();
    let dn = maps.len();
    let work = |part: &[usize]| -> Vec<f64> {
        let mut out = Vec::with_capacity(part.len());
        let mut jt: Vec<f64> = Vec::with_capacity(BLOCK * super::pool::MAX_ROWS * n);
        let mut rec = vec![0.0; dn * 36];
        let mut hs: Vec<f64> = Vec::new();
        for chunk in part.chunks(BLOCK) {
            let rows: usize = chunk.iter().map(|&c| pool.rows(c)).sum();
            hs.clear();
            hs.resize(chunk.len() * dn * 36, 0.0);
            for (d, q) in maps.iter().enumerate() {
                jt.clear();
                for &c in chunk {
                    jt.extend_from_slice(pool.block(d, c));
                }
                let xt = q * DMatrixView::from_slice(&jt, n, rows);
                let mut r0 = 0;
                for (k, &c) in chunk.iter().enumerate() {
                    let m = pool.rows(c);
                    let at = (k * dn + d) * 36;
                    gram(xt.as_slice(), xt.nrows(), r0, m, &mut hs[at..at + m * m]);
                    r0 += m;
                }
            }
            for (k, &c) in chunk.iter().enumerate() {
                let m = pool.rows(c);
                let rec = &mut rec[..dn * m * m];
                for d in 0..dn {
                    let at = (k * dn + d) * 36;
                    rec[d * m * m..(d + 1) * m * m].copy_from_slice(&hs[at..at + m * m]);
                }
                out.push(record_gain(rec, m, dn, 1, false));
            }
        }
        out
    };
    let t = threads.clamp(1, cands.len().div_ceil(BLOCK).max(1));
    let per = cands.len().div_ceil(BLOCK).div_ceil(t) * BLOCK;
    par_chunks(cands, per, work)
}

/// The Gram matrix of columns `r0..r0 + m` of a column-major matrix with `k` rows.
fn gram(x: &[f64], k: usize, r0: usize, m: usize, out: &mut [f64]) {
    for r in 0..m {
        for s in 0..=r {
            let v = dot(
                &x[(r0 + r) * k..(r0 + r + 1) * k],
                &x[(r0 + s) * k..(r0 + s + 1) * k],
            );
            out[r * m + s] = v;
            out[s * m + r] = v;
        }
    }
}

/// Applies `updates` in order to candidate `c`'s record `r` (all draws).
pub(crate) fn apply_updates(
    pool: &Pool,
    updates: &[Update],
    width: usize,
    c: usize,
    r: &mut [f64],
) {
    let n = pool.n_params();
    let m = pool.rows(c);
    for upd in updates {
        let ma = upd.ma;
        for (d, (b, y, bc)) in upd.draws.iter().enumerate() {
            let j = pool.block(d, c);
            let mut z = [0.0; 36];
            for i in 0..m {
                for t in 0..ma {
                    z[i * ma + t] = dot(&j[i * n..(i + 1) * n], &b[t * n..(t + 1) * n]);
                }
            }
            let at = d * width * m * m;
            let h = &mut r[at..at + m * m];
            for i in 0..m {
                for k in 0..=i {
                    let v: f64 = (0..ma).map(|t| z[i * ma + t] * z[k * ma + t]).sum();
                    h[i * m + k] -= v;
                    h[k * m + i] = h[i * m + k];
                }
            }
            if width == 2 {
                let f = &mut r[at + m * m..at + 2 * m * m];
                tip_update(&j[..m * n], n, ma, &z, y, bc, f);
            }
        }
    }
}

/// The tip part of [`apply_updates`]: `F ← F − ZYᵀ − YZᵀ + Z(BC̃Bᵀ)Zᵀ` (`j`: the `m` rows).
fn tip_update(j: &[f64], n: usize, ma: usize, z: &[f64; 36], y: &[f64], bc: &[f64], f: &mut [f64]) {
    let m = j.len() / n;
    let mut yc = [0.0; 36];
    for i in 0..m {
        for t in 0..ma {
            yc[i * ma + t] = dot(&j[i * n..(i + 1) * n], &y[t * n..(t + 1) * n]);
        }
    }
    for i in 0..m {
        for k in 0..=i {
            let mut v = 0.0;
            for t in 0..ma {
                v -= z[i * ma + t] * yc[k * ma + t] + yc[i * ma + t] * z[k * ma + t];
                for u in 0..ma {
                    v += z[i * ma + t] * bc[t * ma + u] * z[k * ma + u];
                }
            }
            f[i * m + k] += v;
            f[k * m + i] = f[i * m + k];
        }
    }
}

/// A candidate's gain from its record (`width` 1: `H` per draw; 2: `H` and `F`): with `tip`,
/// the mean over draws of `tr((I + H)⁻¹F)`; otherwise the mean of `log det(I + H)`.
pub(crate) fn record_gain(r: &[f64], m: usize, draws: usize, width: usize, tip: bool) -> f64 {
    let mut a = [0.0; 36];
    let stride = width * m * m;
    if tip {
        let mut sum = 0.0;
        for d in 0..draws {
            let h = &r[d * stride..d * stride + m * m];
            let f = &r[d * stride + m * m..d * stride + 2 * m * m];
            sum += if m == 1 {
                f[0] / (1.0 + h[0])
            } else {
                identity_plus(h, m, &mut a);
                if chol(&mut a[..m * m], m) {
                    chol_trace(&a, m, f)
                } else {
                    0.0
                }
            };
        }
        return sum / draws as f64;
    }
    // Σ_d ln det(I + H_d) as the log of a product, renormalised against overflow.
    let (mut prod, mut logs) = (1.0_f64, 0.0);
    for d in 0..draws {
        let h = &r[d * stride..d * stride + m * m];
        let mut det = if m == 1 {
            1.0 + h[0]
        } else {
            identity_plus(h, m, &mut a);
            if chol(&mut a[..m * m], m) {
                chol_det(&a, m)
            } else {
                0.0
            }
        };
        if det.is_nan() || det < f64::MIN_POSITIVE {
            det = f64::MIN_POSITIVE;
        }
        prod *= det;
        if !(1e-200..=1e200).contains(&prod) {
            logs += prod.ln();
            prod = 1.0;
        }
    }
    (logs + prod.ln()) / draws as f64
}

/// `a ← I + h` (`m × m`, row-major).
fn identity_plus(h: &[f64], m: usize, a: &mut [f64; 36]) {
    for i in 0..m {
        for k in 0..m {
            a[i * m + k] = h[i * m + k] + if i == k { 1.0 } else { 0.0 };
        }
    }
}
