//! The floating-point side of the gauge rule: numerical ranks, the parameter part of the
//! null space of `[∂C/∂p | mixing]`, how well held parameters pin it, the gauge directions
//! in readable form, and the gauge directions a relation removes. Takes columns evaluated
//! at a point, gives directions over the parameters.

use nalgebra::DMatrix;

/// The part of the gauge space `gauge` (sparse vectors over the parameters) that the relation
/// rows `rows` see: the images of the right singular vectors of `rows · gaugeᵀ` with non-zero
/// singular values, each scaled so that its first entry is 1.
pub(super) fn removed_directions(
    gauge: &[Vec<(usize, f64)>],
    rows: &[Vec<f64>],
) -> Vec<Vec<(usize, f64)>> {
    let g = gauge.len();
    if g == 0 || rows.is_empty() {
        return Vec::new();
    }
    let m = DMatrix::from_fn(rows.len().max(g), g, |r, k| {
        rows.get(r)
            .map_or(0.0, |row| gauge[k].iter().map(|&(j, x)| row[j] * x).sum())
    });
    let svd = m.svd(false, true);
    let Some(vt) = svd.v_t else {
        return Vec::new();
    };
    // A direction is removed when the relation changes along it at a rate comparable to
    // its own gradient's size (relative 10⁻⁶, above the near-nominal point's residue).
    let row_norm = rows.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    let dir_norm = gauge
        .iter()
        .map(|g| g.iter().map(|(_, x)| x * x).sum::<f64>().sqrt())
        .fold(0.0f64, f64::max);
    let mx = 1e-3 * row_norm * dir_norm;
    if mx == 0.0 {
        return Vec::new();
    }
    let np = gauge
        .iter()
        .flatten()
        .map(|&(j, _)| j + 1)
        .max()
        .unwrap_or(0);
    let mut out = Vec::new();
    for (s, sv) in svd.singular_values.iter().enumerate() {
        if *sv <= mx {
            continue;
        }
        let mut dir = vec![0.0; np];
        for (k, dirs) in gauge.iter().enumerate() {
            for &(j, x) in dirs {
                dir[j] += vt[(s, k)] * x;
            }
        }
        let big = dir.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // Entries below 10⁻⁶ of the largest are the residue of a near-nominal point.
        let Some(lead) = dir.iter().copied().find(|x| x.abs() > 1e-6 * big) else {
            continue;
        };
        out.push(
            dir.iter()
                .enumerate()
                .filter(|(_, x)| x.abs() > 1e-6 * big)
                .map(|(j, x)| (j, x / lead))
                .collect(),
        );
    }
    out
}

/// Smallest principal cosine between the gauge space (orthonormal columns `n`, one row per
/// parameter, in column-scaled units) and the coordinates of the held parameters: how well
/// holding them pins every gauge direction (1 = perfectly, 0 = not at all).
pub(super) fn pinning(n: &[Vec<f64>], held: &[bool]) -> f64 {
    let rows: Vec<usize> = (0..held.len()).filter(|&j| held[j]).collect();
    let g = n.len();
    if g == 0 || rows.is_empty() {
        return 1.0;
    }
    let m = DMatrix::from_fn(rows.len().max(g), g, |i, k| {
        rows.get(i).map_or(0.0, |&j| n[k][j])
    });
    let sv = m.singular_values();
    let mut v: Vec<f64> = sv.iter().copied().collect();
    v.sort_by(|a, b| b.total_cmp(a));
    // With |held| ≤ g, the |held|-th largest singular value is the one that matters.
    v.get(rows.len().min(g) - 1).copied().unwrap_or(0.0)
}

/// A stack of columns `[∂C/∂p | mixing]`, each scaled to unit norm so that the SVD sees
/// directions, not units, with that SVD: what the numerical rank, the gauge rule's null space
/// and the printed gauge directions all read (one SVD for the three).
///
/// The mixing columns `M` are taken out first, block by block (a constraint's mixing columns
/// touch only its rows, [`mixing_blocks`]): a column-pivoted QR `M_b·Π = Q_b·R_b` gives the
/// block's numerical rank `k_b` and `Q_b`, and the SVD is of the parameter columns' part
/// outside `M`'s span, `B`: per block the rows of `Q_bᵀ·J_b` below the first `k_b` (`P⊥J` in
/// rotated coordinates), with the rows no mixing column touches. Then
/// `rank [J | M] = Σ k_b + rank B`, and the parameter part of the null space of `[J | M]`
/// (`{x : J·x ∈ span M}`) is the null space of `B`. The 6-point Panda's stack is
/// `405 × (46 + 54)`: six QRs of 57 to 120 rows by 9 columns and an SVD of 46 columns,
/// 0.84 ms, where it was a QR of the whole stack and an SVD of 100 columns (about 2 ms).
pub(super) struct ScaledStack {
    /// Each column's norm (its parameter's effect per unit change), parameters first.
    norms: Vec<f64>,
    /// Numerical rank of the mixing columns.
    mixing_rank: usize,
    /// The largest singular value of the scaled stack, bounded below by `B`'s and `M`'s
    /// largest (the numerical rank's scale).
    top: f64,
    /// Singular values of `B`.
    singular_values: Vec<f64>,
    /// `Vᵀ` of `B` (`None`: the SVD failed, a non-finite entry).
    v_t: Option<DMatrix<f64>>,
}

impl ScaledStack {
    /// The scaled columns' rank and null space, the first `np` of `cols` the parameters'
    /// (a column of zeros stays zero).
    pub(super) fn new(cols: &[Vec<f64>], np: usize) -> Self {
        let norms: Vec<f64> = cols
            .iter()
            .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
            .collect();
        let failed = ScaledStack {
            norms: norms.clone(),
            mixing_rank: 0,
            top: 0.0,
            singular_values: Vec::new(),
            v_t: None,
        };
        // A non-finite column (a NaN norm) must not pass for a zero one, a null direction.
        if cols.is_empty() || np > cols.len() || norms.iter().any(|n| !n.is_finite()) {
            return failed;
        }
        let (b_rows, mixing_rank, mixing_top) = outside_mixing(cols, np, &norms);
        if np == 0 {
            // Nothing but mixing: no parameter, no null direction to find.
            return ScaledStack {
                norms,
                mixing_rank,
                top: mixing_top,
                singular_values: Vec::new(),
                v_t: Some(DMatrix::zeros(0, 0)),
            };
        }
        // `B`, padded with zero rows to at least `np` (every right singular vector); the SVD
        // takes a tall one's triangular factor first (`checked_svd`).
        let b = DMatrix::from_fn(b_rows.len().max(np), np, |i, c| {
            b_rows.get(i).map_or(0.0, |row| row[c])
        });
        match crate::numeric::linalg::checked_svd(b, false, true) {
            Ok(svd) => {
                let singular_values: Vec<f64> = svd.singular_values.iter().copied().collect();
                let top = singular_values.iter().copied().fold(mixing_top, f64::max);
                ScaledStack {
                    norms,
                    mixing_rank,
                    top,
                    singular_values,
                    v_t: svd.v_t,
                }
            }
            Err(_) => failed,
        }
    }

    /// Numerical rank (relative tolerance 1e-9).
    pub(super) fn rank(&self) -> usize {
        let b = self
            .singular_values
            .iter()
            .filter(|s| **s > 1e-9 * self.top)
            .count();
        self.mixing_rank + b
    }

    /// Orthonormal basis (`dim` vectors over the parameters, in the columns' scaled units) of
    /// the parameter part of the null space of `[∂C/∂p | mixing]`, given its generic rank
    /// `r_all`. With `unscale`, the vectors are in parameter units (for display), else in the
    /// scaled units where every column has unit norm (for conditioning).
    pub(super) fn null_parameter_space(
        &self,
        np: usize,
        r_all: usize,
        dim: usize,
        unscale: bool,
    ) -> Vec<Vec<f64>> {
        let Some(vt) = &self.v_t else {
            return Vec::new();
        };
        if dim == 0 {
            return Vec::new();
        }
        let scale = |j: usize| match self.norms[j] {
            n if n > 0.0 && unscale => 1.0 / n,
            _ => 1.0,
        };
        let mut order: Vec<usize> = (0..self.singular_values.len()).collect();
        order.sort_by(|&x, &y| self.singular_values[x].total_cmp(&self.singular_values[y]));
        // `B`'s null space: `np − (r_all − k)` directions (the generic rank of `B`).
        let null_dim = np.saturating_sub(r_all.saturating_sub(self.mixing_rank));
        let null_p: Vec<Vec<f64>> = order
            .iter()
            .take(null_dim)
            .map(|&i| (0..np).map(|j| vt[(i, j)] * scale(j)).collect())
            .collect();
        if null_p.is_empty() {
            return Vec::new();
        }
        let n = DMatrix::from_fn(np, null_p.len().max(np), |i, j| {
            null_p.get(j).map_or(0.0, |v| v[i])
        });
        let Ok(svd2) = crate::numeric::linalg::checked_svd(n, true, false) else {
            return Vec::new();
        };
        let Some(u) = svd2.u else {
            return Vec::new();
        };
        let mut order2: Vec<usize> = (0..svd2.singular_values.len()).collect();
        order2.sort_by(|&x, &y| svd2.singular_values[y].total_cmp(&svd2.singular_values[x]));
        order2
            .iter()
            .take(dim)
            .map(|&i| (0..np).map(|j| u[(j, i)]).collect())
            .collect()
    }

    /// The gauge directions for display: the parameter part of the null space in parameter
    /// units, expressed against the `held` parameters, each parameter's residue compared by
    /// its effect (its Jacobian column's norm).
    pub(super) fn gauge_directions(
        &self,
        np: usize,
        r_all: usize,
        gauge_dim: usize,
        held: &[bool],
    ) -> Vec<Vec<(usize, f64)>> {
        readable_gauge(
            self.null_parameter_space(np, r_all, gauge_dim, true),
            held,
            &self.norms[..np.min(self.norms.len())],
        )
    }
}

/// The rows of `B` (the scaled parameter columns outside the scaled mixing columns' span,
/// [`ScaledStack`]), with the mixing columns' numerical rank and their largest `|R_ii|`:
/// each block of mixing columns ([`mixing_blocks`]) taken out of its own rows by a
/// column-pivoted QR, the rows no mixing column touches as they are.
fn outside_mixing(cols: &[Vec<f64>], np: usize, norms: &[f64]) -> (Vec<Vec<f64>>, usize, f64) {
    let rows = cols.iter().map(Vec::len).max().unwrap_or(0);
    let scaled = |c: usize, i: usize| match norms[c] {
        n if n > 0.0 => cols[c].get(i).copied().unwrap_or(0.0) / n,
        _ => 0.0,
    };
    let mut b_rows: Vec<Vec<f64>> = Vec::with_capacity(rows);
    let (mut mixing_rank, mut mixing_top, mut next) = (0, 0.0f64, 0);
    let take_plain = |b_rows: &mut Vec<Vec<f64>>, to: usize, next: &mut usize| {
        b_rows.extend((*next..to).map(|i| (0..np).map(|c| scaled(c, i)).collect()));
        *next = to;
    };
    for (range, mcols) in mixing_blocks(cols, np, norms) {
        take_plain(&mut b_rows, range.start, &mut next);
        let h = range.len();
        let qr =
            DMatrix::from_fn(h, mcols.len(), |i, a| scaled(mcols[a], range.start + i)).col_piv_qr();
        let r = qr.r();
        let diag: Vec<f64> = (0..r.nrows().min(r.ncols()))
            .map(|i| r[(i, i)].abs())
            .collect();
        let top = diag.iter().copied().fold(0.0, f64::max);
        let k = diag.iter().filter(|&&d| d > 1e-9 * top).count();
        let mut j = DMatrix::from_fn(h, np, |i, c| scaled(c, range.start + i));
        qr.q_tr_mul(&mut j);
        b_rows.extend((k..h).map(|i| j.row(i).iter().copied().collect()));
        (mixing_rank, mixing_top, next) = (mixing_rank + k, mixing_top.max(top), range.end);
    }
    take_plain(&mut b_rows, rows, &mut next);
    (b_rows, mixing_rank, mixing_top)
}

/// The mixing columns (`cols[np..]`) in blocks of overlapping row supports, in row order:
/// each block's rows (from its first nonzero entry to its last) and columns. A constraint's
/// mixing columns touch only its own rows, so each constraint is a block of its own; zero
/// columns belong to none.
fn mixing_blocks(
    cols: &[Vec<f64>],
    np: usize,
    norms: &[f64],
) -> Vec<(std::ops::Range<usize>, Vec<usize>)> {
    let mut supports: Vec<(std::ops::Range<usize>, usize)> = (np..cols.len())
        .filter(|&c| norms[c] > 0.0)
        .filter_map(|c| {
            let first = cols[c].iter().position(|x| *x != 0.0)?;
            let last = cols[c].iter().rposition(|x| *x != 0.0)?;
            Some((first..last + 1, c))
        })
        .collect();
    supports.sort_by_key(|(r, c)| (r.start, *c));
    let mut blocks: Vec<(std::ops::Range<usize>, Vec<usize>)> = Vec::new();
    for (range, c) in supports {
        match blocks.last_mut() {
            Some((r, cs)) if range.start < r.end => {
                r.end = r.end.max(range.end);
                cs.push(c);
            }
            _ => blocks.push((range, vec![c])),
        }
    }
    blocks
}

/// Gauge directions for display: each one moves one held parameter by 1 (and no other held
/// parameter) with the compensating change of the free ones; when the held set does not
/// pin the space (a degenerate nominal point), a unit-leading reduced form instead.
pub(super) fn readable_gauge(
    mut rows: Vec<Vec<f64>>,
    held: &[bool],
    effect: &[f64],
) -> Vec<Vec<(usize, f64)>> {
    let pivots: Vec<usize> = (0..held.len()).filter(|&j| held[j]).collect();
    if !solve_for_pivots(&mut rows, &pivots) {
        readable(&mut rows);
    }
    // Drop the O(1e-6) residue of the near-nominal point, compared in effect units (so metres,
    // radians and 1/metres are comparable); never a held parameter (its 1 is what the
    // direction is expressed against).
    rows.iter()
        .map(|r| {
            let weighted = |j: usize, x: f64| x.abs() * effect.get(j).copied().unwrap_or(1.0);
            let mx = r
                .iter()
                .enumerate()
                .fold(0.0f64, |m, (j, x)| m.max(weighted(j, *x)));
            r.iter()
                .enumerate()
                .filter(|(j, x)| {
                    // A held parameter is 1 in its own direction and 0 in the others.
                    if held[*j] {
                        (**x - 1.0).abs() < 1e-6
                    } else {
                        weighted(*j, **x) > 1e-5 * mx
                    }
                })
                .map(|(j, x)| (j, *x))
                .collect()
        })
        .collect()
}

/// Transforms the basis `rows` so that row `i` has 1 at `pivots[i]` and 0 at the other
/// pivots. Returns `false` (leaving `rows` untouched) when that submatrix is singular.
fn solve_for_pivots(rows: &mut [Vec<f64>], pivots: &[usize]) -> bool {
    let g = rows.len();
    if pivots.len() != g || g == 0 {
        return false;
    }
    let sub = DMatrix::from_fn(g, g, |i, k| rows[i][pivots[k]]);
    let Some(inv) = sub.clone().try_inverse() else {
        return false;
    };
    if sub.singular_values().min() < 1e-6 * sub.singular_values().max() {
        return false;
    }
    let np = rows[0].len();
    // new_rows = inv(sub)ᵀ-combination: new_i = Σ_r inv[(r, i)] rows_r has entry δ_ik at pivot k.
    let new: Vec<Vec<f64>> = (0..g)
        .map(|i| {
            (0..np)
                .map(|j| (0..g).map(|r| inv[(i, r)] * rows[r][j]).sum())
                .collect()
        })
        .collect();
    for (r, n) in rows.iter_mut().zip(new) {
        *r = n;
    }
    true
}

/// Reduced echelon form with partial pivoting, pivots in parameter order, leading
/// coefficient 1.
fn readable(rows: &mut [Vec<f64>]) {
    let ncols = rows.first().map_or(0, Vec::len);
    let mut r = 0;
    for col in 0..ncols {
        if r == rows.len() {
            break;
        }
        let (best, val) = (r..rows.len())
            .map(|i| (i, rows[i][col].abs()))
            .fold((r, 0.0), |acc, x| if x.1 > acc.1 { x } else { acc });
        if val < 1e-9 {
            continue;
        }
        rows.swap(r, best);
        let piv = rows[r][col];
        for x in &mut rows[r] {
            *x /= piv;
        }
        let pr = rows[r].clone();
        for (i, row) in rows.iter_mut().enumerate() {
            if i != r {
                let f = row[col];
                if f != 0.0 {
                    for (x, y) in row.iter_mut().zip(&pr) {
                        *x -= f * y;
                    }
                }
            }
        }
        r += 1;
    }
}

/// `x` rounded to `digits` significant decimal digits (for readable gauge coefficients).
pub(crate) fn round_sig(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let mag = x.abs().log10().floor() as i32;
    let f = 10f64.powi(digits - 1 - mag);
    (x * f).round() / f
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The rank and the parameter part of the null space, with the mixing columns taken out
    /// by the pivoted QR, against the SVD of the whole scaled stack `[J | M]` (the way
    /// before): stacks whose parameter columns partly lie in the mixing columns' span, whose
    /// mixing columns are themselves dependent, with zero columns, and with fewer rows than
    /// columns.
    #[test]
    fn the_mixing_columns_taken_out_keep_rank_and_null_space() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // (rows, parameters, mixing columns, mixing rank, parameter directions inside M's span)
        for (rows, np, nm, mr, inside) in [
            (40, 8, 6, 6, 2),
            (40, 8, 6, 4, 3),
            (30, 10, 0, 0, 0),
            (12, 9, 9, 5, 1),
            (60, 12, 18, 18, 4),
        ] {
            let mut g =
                |r: usize, c: usize| DMatrix::from_fn(r, c, |_, _| rng.gen_range(-1.0..1.0));
            let m = &g(rows, mr) * g(mr, nm);
            // Parameters: `inside` columns mixing-only combinations, two exact duplicates of
            // others (a gauge direction), the rest generic; a zero column last.
            let generic = g(rows, np);
            let from_m = &m * g(nm, np);
            let mut j = DMatrix::from_fn(rows, np, |i, c| {
                if c < inside {
                    from_m[(i, c)]
                } else {
                    generic[(i, c)]
                }
            });
            let c1 = j.column(inside).into_owned();
            j.set_column(np - 2, &(c1 * 3.0));
            j.column_mut(np - 1).fill(0.0);
            let cols: Vec<Vec<f64>> = (0..np)
                .map(|c| j.column(c).iter().copied().collect())
                .chain((0..nm).map(|c| m.column(c).iter().copied().collect()))
                .collect();
            // The reference: the whole scaled stack's SVD.
            let whole = DMatrix::from_fn(rows.max(np + nm), np + nm, |i, c| {
                let n = cols[c].iter().map(|x| x * x).sum::<f64>().sqrt();
                if n > 0.0 && i < rows {
                    cols[c][i] / n
                } else {
                    0.0
                }
            });
            let svd = whole.clone().svd(false, true);
            let smax = svd.singular_values.max();
            let r_all = svd
                .singular_values
                .iter()
                .filter(|s| **s > 1e-9 * smax)
                .count();
            let stack = ScaledStack::new(&cols, np);
            assert_eq!(stack.rank(), r_all, "rows {rows} np {np} nm {nm}");
            let m_rank = mr.min(rows);
            let gauge_dim = np - (r_all - m_rank);
            let null = stack.null_parameter_space(np, r_all, gauge_dim, false);
            assert_eq!(null.len(), gauge_dim);
            // Each direction is null for `[J | M]` up to a mixing part: `J_s·x` in M's span.
            let vt = svd.v_t.as_ref().expect("V");
            for x in &null {
                let xs = DMatrix::from_fn(np, 1, |c, _| x[c]);
                let jx = DMatrix::from_fn(rows.max(np + nm), np, |i, c| whole[(i, c)]) * xs;
                // Residual after projecting on the span of the scaled mixing columns.
                let ms = DMatrix::from_fn(rows.max(np + nm), nm, |i, c| whole[(i, np + c)]);
                let resid = if nm == 0 {
                    jx.norm()
                } else {
                    let fit = ms.clone().svd(true, true).solve(&jx, 1e-12).expect("lstsq");
                    (&ms * fit - &jx).norm()
                };
                assert!(resid < 1e-9, "rows {rows} np {np}: residual {resid}");
            }
            // The same space as the whole stack's: its parameter parts of null vectors.
            let null_whole: Vec<Vec<f64>> = (0..np + nm)
                .filter(|&i| svd.singular_values[i] <= 1e-9 * smax)
                .map(|i| (0..np).map(|c| vt[(i, c)]).collect())
                .collect();
            let basis = DMatrix::from_fn(np, null.len(), |c, k| null[k][c]);
            for v in &null_whole {
                let v = DMatrix::from_fn(np, 1, |c, _| v[c]);
                let outside = &v - &basis * (basis.transpose() * &v);
                assert!(
                    outside.norm() < 1e-9,
                    "rows {rows} np {np}: {}",
                    outside.norm()
                );
            }
        }
    }
}
