//! Bounded exchange (Fedorov / DETMAX style) after the greedy: each pass finds the best swap
//! (one chosen candidate `j` out, one not-chosen `i` in) and applies it when it improves the
//! criterion by more than the tolerance; it stops when no swap does or after the budget.
//!
//! Candidate list: every chosen candidate may leave; the entering ones are the
//! [`SelectOptions::entering`] not-chosen candidates of largest single-addition gain (all
//! of them when 0). A swap's effect follows from the current `M⁻¹` of each draw in `O(m³)`
//! per pair once the cross leverages `H_ij = J̃ᵢM̃⁻¹J̃ⱼᵀ` are known (`O(k·N·m²·n)` per pass
//! and draw): with `K = (I − Hⱼⱼ)⁻¹`, removing `j` gives `M'⁻¹ = M⁻¹ + Aⱼᵀ K Aⱼ`
//! (`Aⱼ = J̃ⱼM̃⁻¹`), so `H'ᵢᵢ = Hᵢᵢ + Hᵢⱼ K Hⱼᵢ` and
//!
//! - D: `Δf = mean_d [log det(I − Hⱼⱼ) + log det(I + H'ᵢᵢ)]`;
//! - tip, with `Xᵢⱼ = AᵢC̃Aⱼᵀ`, `Fᵢᵢ = AᵢC̃Aᵢᵀ`, `Fⱼⱼ = AⱼC̃Aⱼᵀ`:
//!   `F'ᵢᵢ = Fᵢᵢ + XᵢⱼKHⱼᵢ + HᵢⱼKXᵢⱼᵀ + HᵢⱼKFⱼⱼKHⱼᵢ`, and `g` drops by
//!   `mean_d [tr((I + H'ᵢᵢ)⁻¹F'ᵢᵢ) − tr(K Fⱼⱼ)]`.
//!
//! Each pass works from a fresh Cholesky factor of every draw's `M̃` (`O(N·m·n² + n³)`), in
//! square-root form (`H = XᵀX`, `X = L̃⁻¹J̃ᵀ`), so `I − Hⱼⱼ` is accurate even when the design
//! without `j` is nearly singular; an applied swap only changes the design. The entering list
//! comes from the gains of the last renewal ([`State::renew_gains`]): a refresh of the whole
//! state, or after a sampled greedy the gains of a fresh sample (so on a large pool the
//! exchange is a sampled local search, each renewal `O(s·m·n²·D)` instead of a pass over the
//! pool). A renewal happens every 16 swaps and whenever a pass finds no improving swap with a
//! stale list. A pass's pair values are computed per draw, over threads. When a pass with
//! fresh gains finds none, DETMAX excursions of length 2 and 3 are tried (see `excursion`);
//! the exchange ends when they do not improve either (or at the budget, which counts the
//! candidates changed).

use nalgebra::DMatrix;

use super::excursion::excursion;
use super::small::{chol, chol_det, chol_trace, dot};
use super::state::State;
use super::types::{SelectError, SelectOptions};
use crate::numeric::par_chunks;

/// The best swap of a pass.
struct Swap {
    out: usize,
    inn: usize,
    /// Mean improvement (D: `Δf`; tip: decrease of `g`).
    gain: f64,
}

/// Per-draw quantities of one pass.
struct DrawSwap {
    /// Row offsets of the chosen (`rs`) and entering (`re`) candidates' blocks.
    rs: Vec<usize>,
    re: Vec<usize>,
    /// Per chosen `j`: `K = (I − Hⱼⱼ)⁻¹` (`None` when `I − Hⱼⱼ` is not definite), the removal
    /// term (D: `log det(I − Hⱼⱼ)`, tip: `−tr(K Fⱼⱼ)`), and `Fⱼⱼ` (tip).
    k: Vec<Option<[f64; 36]>>,
    rem: Vec<f64>,
    fjj: Vec<[f64; 36]>,
    /// Per entering `i`: `Hᵢᵢ`, `Fᵢᵢ` (tip).
    hii: Vec<[f64; 36]>,
    fii: Vec<[f64; 36]>,
    /// `Hᵢⱼ` for all pairs (`Σmᵢ × Σmⱼ`), and `Xᵢⱼ` (tip).
    hes: DMatrix<f64>,
    xes: Option<DMatrix<f64>>,
}

/// Swaps between two renewals of the gains that choose the entering candidates.
const REFRESH_SWAPS: usize = 16;

/// Runs the exchange on a state holding the greedy design; returns the swaps applied.
pub(crate) fn run(
    state: &mut State<'_>,
    opts: &SelectOptions,
    budget: usize,
) -> Result<usize, SelectError> {
    let p = state.pool.n_candidates();
    if budget == 0 || state.chosen.is_empty() || state.chosen.len() == p {
        return Ok(0);
    }
    state.renew_gains()?;
    let (mut swaps, mut stale) = (0, 0);
    while swaps < budget {
        if stale > 0 {
            state.refresh_inverse()?;
        }
        let entering = top_entering(state, opts.entering);
        let threshold = if state.is_tip() {
            opts.tolerance * tip_value(state)
        } else {
            opts.tolerance
        };
        match best_swap(state, &entering) {
            Some(best) if best.gain > threshold => {
                state.replace(best.out, best.inn);
                swaps += 1;
                stale += 1;
                if stale >= REFRESH_SWAPS {
                    state.renew_gains()?;
                    stale = 0;
                }
            }
            // The entering list came from stale gains: renew them and try again.
            _ if stale > 0 => {
                state.renew_gains()?;
                stale = 0;
            }
            // A local optimum of single swaps: try excursions.
            _ => match try_excursions(state, &entering, threshold, budget - swaps)? {
                Some(changed) => {
                    swaps += changed;
                    stale += 1;
                }
                None => break,
            },
        }
    }
    Ok(swaps)
}

/// Longest excursion tried.
const MAX_EXCURSION: usize = 3;
/// Excursions tried per length and direction: the first move takes the best, second best, …
/// candidate.
const FIRST_MOVES: usize = 4;

/// Tries excursions of length 2 to [`MAX_EXCURSION`] (within `budget` changed candidates),
/// up first and down first, with the [`FIRST_MOVES`] best first moves; applies the first that
/// improves by more than `threshold` and returns the candidates it changed.
fn try_excursions(
    state: &mut State<'_>,
    entering: &[usize],
    threshold: f64,
    budget: usize,
) -> Result<Option<usize>, SelectError> {
    let tries = (2..=MAX_EXCURSION.min(budget))
        .flat_map(|k| (0..FIRST_MOVES).flat_map(move |f| [(k, true, f), (k, false, f)]));
    for (k, up_first, first) in tries {
        let Some((t, gain)) = excursion(state, entering, k, up_first, first)? else {
            continue;
        };
        if gain > threshold {
            let out: Vec<usize> = state
                .chosen
                .iter()
                .copied()
                .filter(|c| !t.contains(c))
                .collect();
            let inn: Vec<usize> = t.iter().copied().filter(|c| !state.in_set[*c]).collect();
            for (&o, &i) in out.iter().zip(&inn) {
                state.replace(o, i);
            }
            return Ok(Some(out.len()));
        }
    }
    Ok(None)
}

/// The current tip criterion `g = mean_d tr(C̃ M̃⁻¹)`.
fn tip_value(state: &State<'_>) -> f64 {
    let sum: f64 = state
        .draws
        .iter()
        .filter_map(|st| st.tip.as_ref().map(|(c, _)| c.dot(&st.minv)))
        .sum();
    sum / state.draws.len() as f64
}

/// The `k` not-chosen candidates of largest gain (all when `k = 0`), ties to the lowest
/// index, in index order; in a sampled search, among the last sample only.
fn top_entering(state: &State<'_>, k: usize) -> Vec<usize> {
    // A sampled search's gains are its last sample's (the rest `−∞`): only those enter.
    let sampled = state.is_sampled();
    let mut idx: Vec<usize> = (0..state.gains.len())
        .filter(|&i| !(state.in_set[i] || sampled && state.gains[i] == f64::NEG_INFINITY))
        .collect();
    let key = |i: usize| {
        let g = state.gains[i];
        if g.is_nan() {
            f64::NEG_INFINITY
        } else {
            g
        }
    };
    let order = |a: &usize, b: &usize| key(*b).total_cmp(&key(*a)).then(a.cmp(b));
    if k > 0 && k < idx.len() {
        idx.select_nth_unstable_by(k - 1, order);
        idx.truncate(k);
    }
    idx.sort_unstable();
    idx
}

/// The best swap over the chosen candidates and `entering`, ties to the lowest entering then
/// leaving index; `None` when no swap is feasible.
fn best_swap(state: &State<'_>, entering: &[usize]) -> Option<Swap> {
    let set = state.chosen.clone();
    let tip = state.is_tip();
    // Each draw's pair values on its own (over threads, draws split in contiguous runs),
    // then summed in draw order: the same sums whatever the thread count.
    let one_draw = |d: usize| -> (Vec<f64>, Vec<bool>) {
        let ds = prepare(state, d, &set, entering);
        let mut vals = vec![0.0; entering.len() * set.len()];
        for (ii, &i) in entering.iter().enumerate() {
            for (jj, &j) in set.iter().enumerate() {
                let Some(k) = &ds.k[jj] else { continue };
                let (mi, mj) = (state.pool.rows(i), state.pool.rows(j));
                vals[ii * set.len() + jj] = pair_value(&ds, ii, jj, mi, mj, k, tip);
            }
        }
        (vals, ds.k.iter().map(Option::is_some).collect())
    };
    let dn = state.draws.len();
    let threads = if entering.len() * set.len() >= 1024 {
        state.threads().clamp(1, dn)
    } else {
        1
    };
    let draws: Vec<usize> = (0..dn).collect();
    let per_draw: Vec<(Vec<f64>, Vec<bool>)> = par_chunks(&draws, dn.div_ceil(threads), |ds| {
        ds.iter().map(|&d| one_draw(d)).collect()
    });
    let mut total = vec![0.0; entering.len() * set.len()];
    let mut feasible = vec![true; set.len()];
    for (vals, ok) in &per_draw {
        for (f, &o) in feasible.iter_mut().zip(ok) {
            *f &= o;
        }
        for (t, v) in total.iter_mut().zip(vals) {
            *t += v;
        }
    }
    let mut best: Option<Swap> = None;
    for (ii, &i) in entering.iter().enumerate() {
        for (jj, &j) in set.iter().enumerate() {
            let v = total[ii * set.len() + jj] / state.draws.len() as f64;
            if !feasible[jj] || v.is_nan() {
                continue;
            }
            let better = best
                .as_ref()
                .is_none_or(|b| v > b.gain || (v == b.gain && (i, j) < (b.inn, b.out)));
            if better {
                best = Some(Swap {
                    out: j,
                    inn: i,
                    gain: v,
                });
            }
        }
    }
    best
}

/// Builds the draw-`d` quantities of a pass over chosen `set` and `entering`, in square-root
/// form from the fresh factor (`X = L̃⁻¹J̃ᵀ`, so `H = XᵀX` is accurate even when `I − Hⱼⱼ` is
/// tiny; tip: `Y = R̃L̃⁻ᵀX = R̃M̃⁻¹J̃ᵀ`, `F = YᵀY`, `Xᵢⱼ = YᵢᵀYⱼ`).
fn prepare(state: &State<'_>, d: usize, set: &[usize], entering: &[usize]) -> DrawSwap {
    let pool = state.pool;
    let offsets = |list: &[usize]| {
        let mut o = vec![0];
        for &c in list {
            o.push(o[o.len() - 1] + pool.rows(c));
        }
        o
    };
    let (rs, re) = (offsets(set), offsets(entering));
    let st = &state.draws[d];
    let stack = |list: &[usize], o: &[usize]| {
        let mut m = DMatrix::zeros(pool.n_params(), o[list.len()]);
        for (k, &c) in list.iter().enumerate() {
            m.columns_mut(o[k], pool.rows(c))
                .copy_from(&state.whitened_t(d, c));
        }
        &st.linv * m
    };
    let (xs, xe) = (stack(set, &rs), stack(entering, &re));
    let tq = st.tip.as_ref().map(|(_, r)| r * st.linv.transpose());
    let ys = tq.as_ref().map(|t| (t * &xs, t * &xe));
    let mut ds = DrawSwap {
        k: Vec::with_capacity(set.len()),
        rem: Vec::with_capacity(set.len()),
        fjj: Vec::new(),
        hii: Vec::with_capacity(entering.len()),
        fii: Vec::new(),
        hes: xe.tr_mul(&xs),
        xes: ys.as_ref().map(|(a, b)| b.tr_mul(a)),
        rs,
        re,
    };
    for (jj, &j) in set.iter().enumerate() {
        let m = pool.rows(j);
        let h = col_gram(&xs, &xs, ds.rs[jj], m);
        let f = ys.as_ref().map(|(y, _)| col_gram(y, y, ds.rs[jj], m));
        removal(&mut ds, &h, f, m);
    }
    for (ii, &i) in entering.iter().enumerate() {
        let m = pool.rows(i);
        ds.hii.push(col_gram(&xe, &xe, ds.re[ii], m));
        if let Some((_, y)) = &ys {
            ds.fii.push(col_gram(y, y, ds.re[ii], m));
        }
    }
    ds
}

/// `XᵀY` restricted to columns `r0..r0 + m` of both (same row count), as `m × m`.
fn col_gram(x: &DMatrix<f64>, y: &DMatrix<f64>, r0: usize, m: usize) -> [f64; 36] {
    let n = x.nrows();
    let (xs, ys) = (x.as_slice(), y.as_slice());
    let mut out = [0.0; 36];
    for a in 0..m {
        for b in 0..m {
            let (ca, cb) = ((r0 + a) * n, (r0 + b) * n);
            out[a * m + b] = dot(&xs[ca..ca + n], &ys[cb..cb + n]);
        }
    }
    for a in 0..m {
        for b in 0..a {
            let v = 0.5 * (out[a * m + b] + out[b * m + a]);
            out[a * m + b] = v;
            out[b * m + a] = v;
        }
    }
    out
}

/// Pushes the removal data of a chosen candidate with leverage `h` (and `F`, tip).
fn removal(ds: &mut DrawSwap, h: &[f64; 36], f: Option<[f64; 36]>, m: usize) {
    let mut a = [0.0; 36];
    for i in 0..m {
        for k in 0..m {
            a[i * m + k] = if i == k { 1.0 } else { 0.0 } - h[i * m + k];
        }
    }
    let mut l = a;
    if !chol(&mut l[..m * m], m) {
        ds.k.push(None);
        ds.rem.push(f64::NEG_INFINITY);
        ds.fjj.push(f.unwrap_or([0.0; 36]));
        return;
    }
    let kinv = spd_inverse(&l, m);
    let rem = match &f {
        None => chol_det(&l, m).ln(),
        Some(f) => -chol_trace(&l, m, f),
    };
    ds.k.push(Some(kinv));
    ds.rem.push(rem);
    ds.fjj.push(f.unwrap_or([0.0; 36]));
}

/// `(LLᵀ)⁻¹` from a factor by [`chol`].
fn spd_inverse(l: &[f64; 36], m: usize) -> [f64; 36] {
    let mut out = [0.0; 36];
    for c in 0..m {
        // Solve L y = e_c, then Lᵀ x = y.
        let mut y = [0.0; 6];
        for i in 0..m {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in 0..i {
                s -= l[i * m + k] * y[k];
            }
            y[i] = s / l[i * m + i];
        }
        for i in (0..m).rev() {
            let mut s = y[i];
            for k in i + 1..m {
                s -= l[k * m + i] * out[k * m + c];
            }
            out[i * m + c] = s / l[i * m + i];
        }
    }
    out
}

/// `out = a·b` for row-major `a` (`r × k`) and `b` (`k × c`).
fn mul(a: &[f64], b: &[f64], r: usize, k: usize, c: usize) -> [f64; 36] {
    let mut out = [0.0; 36];
    for i in 0..r {
        for j in 0..c {
            out[i * c + j] = (0..k).map(|t| a[i * k + t] * b[t * c + j]).sum();
        }
    }
    out
}

/// `aᵀ` of a row-major `r × c`.
fn tr(a: &[f64], r: usize, c: usize) -> [f64; 36] {
    let mut out = [0.0; 36];
    for i in 0..r {
        for j in 0..c {
            out[j * r + i] = a[i * c + j];
        }
    }
    out
}

/// The improvement of swapping chosen `jj` for entering `ii` in one draw.
fn pair_value(
    ds: &DrawSwap,
    ii: usize,
    jj: usize,
    mi: usize,
    mj: usize,
    k: &[f64; 36],
    tip: bool,
) -> f64 {
    let block = |m: &DMatrix<f64>| {
        let mut out = [0.0; 36];
        for a in 0..mi {
            for b in 0..mj {
                out[a * mj + b] = m[(ds.re[ii] + a, ds.rs[jj] + b)];
            }
        }
        out
    };
    let hij = block(&ds.hes);
    let hk = mul(&hij, k, mi, mj, mj); // Hᵢⱼ K
    let hji = tr(&hij, mi, mj);
    let mut hp = mul(&hk, &hji, mi, mj, mi);
    let mut a = [0.0; 36];
    for t in 0..mi * mi {
        hp[t] += ds.hii[ii][t];
        a[t] = hp[t] + if t % (mi + 1) == 0 { 1.0 } else { 0.0 };
    }
    if !chol(&mut a[..mi * mi], mi) {
        return f64::NAN;
    }
    if !tip {
        return ds.rem[jj] + chol_det(&a, mi).ln();
    }
    let x = block(ds.xes.as_ref().unwrap_or(&ds.hes));
    let xkh = mul(&mul(&x, k, mi, mj, mj), &hji, mi, mj, mi);
    let kfk = mul(&mul(k, &ds.fjj[jj], mj, mj, mj), k, mj, mj, mj);
    let quad = mul(&mul(&hij, &kfk, mi, mj, mj), &hji, mi, mj, mi);
    let mut fp = [0.0; 36];
    for r in 0..mi {
        for c in 0..mi {
            fp[r * mi + c] =
                ds.fii[ii][r * mi + c] + xkh[r * mi + c] + xkh[c * mi + r] + quad[r * mi + c];
        }
    }
    ds.rem[jj] + chol_trace(&a, mi, &fp)
}
