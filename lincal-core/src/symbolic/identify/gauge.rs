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
pub(super) struct ScaledStack {
    /// Each column's norm (its parameter's effect per unit change).
    norms: Vec<f64>,
    singular_values: Vec<f64>,
    /// `Vᵀ` (`None`: the SVD failed, a non-finite entry).
    v_t: Option<DMatrix<f64>>,
}

impl ScaledStack {
    /// The scaled columns' SVD (a column of zeros stays zero).
    pub(super) fn new(cols: &[Vec<f64>]) -> Self {
        let norms: Vec<f64> = cols
            .iter()
            .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
            .collect();
        let nrows = cols.first().map_or(0, Vec::len).max(cols.len());
        let a = DMatrix::from_fn(nrows, cols.len(), |i, j| {
            let n = norms[j];
            if n > 0.0 {
                cols[j].get(i).copied().unwrap_or(0.0) / n
            } else {
                0.0
            }
        });
        // A non-finite column (a NaN norm) must not pass for a zero one, a null direction.
        let svd = if cols.is_empty() || norms.iter().any(|n| !n.is_finite()) {
            None
        } else {
            crate::numeric::linalg::checked_svd(a, false, true).ok()
        };
        match svd {
            Some(svd) => ScaledStack {
                norms,
                singular_values: svd.singular_values.iter().copied().collect(),
                v_t: svd.v_t,
            },
            None => ScaledStack {
                norms,
                singular_values: Vec::new(),
                v_t: None,
            },
        }
    }

    /// Numerical rank (relative tolerance 1e-9).
    pub(super) fn rank(&self) -> usize {
        let mx = self.singular_values.iter().fold(0.0f64, |m, x| m.max(*x));
        self.singular_values
            .iter()
            .filter(|s| **s > 1e-9 * mx)
            .count()
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
        let null_dim = self.norms.len().saturating_sub(r_all);
        // Parameter parts of the null vectors.
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
