//! The state of a greedy or exchange search: per draw the inverse `M̃⁻¹` of the design's
//! (whitened, regularised) information, and per candidate and draw its leverage block
//! `H = J̃ M̃⁻¹ J̃ᵀ` (`m × m`) and, for the tip criterion, `F = J̃ M̃⁻¹ C̃ M̃⁻¹ J̃ᵀ`
//! (`C̃ = T̃ᵀT̃`), from which every candidate's gain follows in `O(m³)`:
//!
//! - D: adding block `J` changes `log det M` by `log det(I + J M⁻¹ Jᵀ) = log det(I + H)`
//!   (matrix determinant lemma);
//! - tip: it lowers `tr(T M⁻¹ Tᵀ)` by `tr(T M⁻¹Jᵀ(I + H)⁻¹ J M⁻¹Tᵀ) = tr((I + H)⁻¹ F)`.
//!
//! Adding a candidate is a rank-`m` Woodbury update of `M̃⁻¹` (`O(m·n²)` per draw) and of
//! every record (`O(m²·n)` each, see [`super::update`]). The record updates are logged and
//! applied to a candidate when it is brought up to date: all at once by a pass over the pool
//! split over threads by candidate ([`State::sweep_all`]; each candidate's arithmetic does
//! not depend on the split, so neither does the result), or one candidate at a time
//! ([`State::bring`], for the lazy greedy).
//!
//! A sampled search ([`State::new_sampled`], the sampled greedy of [`super::greedy`]) keeps
//! no records: each step evaluates a random sample of candidates exactly from a fresh factor
//! ([`State::sample_gains`]), and only `M̃⁻¹` is kept.
//!
//! Updates subtract large numbers while the design is singular but for the regulariser, so
//! the state is refreshed from scratch (Cholesky of `M̃`, every record by matrix products)
//! when the rows added reach `n`, `2n`, `4n`, … and whenever a caller asks.

use nalgebra::{DMatrix, DMatrixView};

use super::frame::{whitened_information, Frame};
use super::pool::Pool;
use super::small::{chol_factor, chol_logdet, lower_inverse};
use super::types::SelectError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::update::{
    apply_updates, par_ranges, record_gain, refresh_range, subset_gains, Maps, Update,
};
use crate::numeric::par_chunks;

/// Per-draw data of the search.
pub(crate) struct DrawState {
    /// `M̃⁻¹`.
    pub(crate) minv: DMatrix<f64>,
    /// `L̃⁻¹` of the last factorisation (`M̃ = L̃L̃ᵀ`; not updated by Woodbury).
    pub(crate) linv: DMatrix<f64>,
    /// `C̃ = T̃ᵀT̃` and a root `R̃` (`R̃ᵀR̃ = C̃`, at most `n` rows), tip criterion only.
    pub(crate) tip: Option<(DMatrix<f64>, DMatrix<f64>)>,
}

/// The search state (see the module documentation).
pub(crate) struct State<'a> {
    pub(crate) pool: &'a Pool,
    pub(crate) frames: &'a [Frame],
    pub(crate) draws: Vec<DrawState>,
    /// Record width: 1 (H) or 2 (H and F).
    width: usize,
    /// `P + 1` offsets of the candidates' records in `rec`.
    off: Vec<usize>,
    /// Per candidate, per draw: `H` then (tip) `F`, `m × m` row-major.
    rec: Vec<f64>,
    /// Each candidate's gain (D: mean `log det(I + H)`; tip: mean `tr((I + H)⁻¹F)`), `−∞`
    /// for chosen candidates; in a sampled search, the last renewal's sample only (`−∞` for
    /// the rest).
    pub(crate) gains: Vec<f64>,
    pub(crate) in_set: Vec<bool>,
    pub(crate) chosen: Vec<usize>,
    threads: usize,
    /// The updates since the last refresh; candidate `c`'s record has the first `ver[c]`
    /// (both unused, empty and zero, in a sampled search).
    log: Vec<Update>,
    ver: Vec<usize>,
    /// Times every gain was brought up to date at once, by a refresh or a sweep (a lazy
    /// search rebuilds its bounds after one).
    pub(crate) renewals: usize,
    /// Tip criterion only: gains are D gains while the design is singular but for the
    /// regulariser (see [`super::greedy`]).
    pub(crate) d_phase: bool,
    rows_added: usize,
    next_refresh: usize,
    /// Whether the records are kept: off in a sampled search, which evaluates its samples
    /// from a fresh factor instead ([`State::start_sampling`]).
    records: bool,
    /// A sampled search's sample size and random stream.
    sampler: Option<(usize, ChaCha8Rng)>,
}

impl<'a> State<'a> {
    /// The state of the empty design (given information and regulariser only).
    pub(crate) fn new(
        pool: &'a Pool,
        frames: &'a [Frame],
        tip: Option<&[DMatrix<f64>]>,
        threads: usize,
    ) -> Result<Self, SelectError> {
        let mut state = Self::blank(pool, frames, tip, threads, true);
        state.refresh()?;
        Ok(state)
    }

    /// The state of the empty design for a sampled search (D criterion): no records at all
    /// (see [`State::start_sampling`]), so no pass over the pool and no `P·m²·D` memory.
    pub(crate) fn new_sampled(
        pool: &'a Pool,
        frames: &'a [Frame],
        threads: usize,
        size: usize,
        seed: u64,
    ) -> Result<Self, SelectError> {
        let mut state = Self::blank(pool, frames, None, threads, false);
        state.start_sampling(size, seed);
        state.refresh_inverse()?;
        Ok(state)
    }

    /// The empty design's state before any factorisation; records allocated when `records`.
    fn blank(
        pool: &'a Pool,
        frames: &'a [Frame],
        tip: Option<&[DMatrix<f64>]>,
        threads: usize,
        records: bool,
    ) -> Self {
        let n = pool.n_params();
        let p = pool.n_candidates();
        let dn = pool.n_draws();
        let width = if tip.is_some() { 2 } else { 1 };
        let mut off = Vec::with_capacity(p + 1);
        off.push(0);
        for i in 0..p {
            let m = pool.rows(i);
            off.push(off[i] + dn * width * m * m);
        }
        let draws = (0..dn)
            .map(|d| DrawState {
                minv: DMatrix::identity(n, n),
                linv: DMatrix::identity(n, n),
                tip: tip.map(|t| tip_root(&t[d])),
            })
            .collect();
        State {
            pool,
            frames,
            draws,
            width,
            rec: if records {
                vec![0.0; off[p]]
            } else {
                Vec::new()
            },
            off,
            gains: vec![f64::NEG_INFINITY; p],
            in_set: vec![false; p],
            chosen: Vec::new(),
            threads: threads.max(1),
            log: Vec::new(),
            ver: vec![0; p],
            renewals: 0,
            d_phase: false,
            rows_added: 0,
            next_refresh: n,
            records,
            sampler: None,
        }
    }

    /// Whether the search is sampled ([`State::start_sampling`]).
    pub(crate) fn is_sampled(&self) -> bool {
        self.sampler.is_some()
    }

    /// The worker threads of the passes over the pool.
    pub(crate) fn threads(&self) -> usize {
        self.threads
    }

    /// Whether the tip criterion is searched.
    pub(crate) fn is_tip(&self) -> bool {
        self.width == 2
    }

    /// Whether the gains are tip gains (tip criterion, design nonsingular).
    pub(crate) fn tip_gains(&self) -> bool {
        self.width == 2 && !self.d_phase
    }

    /// Whether every draw's `M̃` has its smallest eigenvalue above `1000·ε` (so the
    /// regulariser is negligible in every direction), from scratch.
    pub(crate) fn nonsingular(&self) -> bool {
        (0..self.draws.len()).all(|d| {
            let m = whitened_information(self.pool, &self.frames[d], d, &self.chosen, true);
            let low = m.symmetric_eigenvalues().min();
            low > 1e3 * self.frames[d].eps
        })
    }

    /// Candidate `c`'s whitened block for draw `d`, transposed: `J̃ᵀ = WᵀJᵀ` (`n × m`).
    pub(crate) fn whitened_t(&self, d: usize, c: usize) -> DMatrix<f64> {
        let n = self.pool.n_params();
        let jt = DMatrixView::from_slice(self.pool.block(d, c), n, self.pool.rows(c));
        self.frames[d].w.transpose() * jt
    }

    /// Adds candidate `c` to the design; returns the criterion's change (D: `Δf`, tip: the
    /// decrease of `g`). The records are brought up to date lazily ([`State::bring`],
    /// [`State::sweep_all`]) unless a scheduled refresh happens; a sampled search keeps no
    /// records, and its scheduled refreshes are of the inverse alone.
    pub(crate) fn add(&mut self, c: usize) -> Result<f64, SelectError> {
        let (upd, gain) = self.factor_update(c)?;
        self.in_set[c] = true;
        self.gains[c] = f64::NEG_INFINITY;
        self.chosen.push(c);
        self.rows_added += self.pool.rows(c);
        if self.rows_added >= self.next_refresh {
            self.next_refresh = self.rows_added.max(1) * 2;
            if self.records {
                self.refresh()?;
            } else {
                self.refresh_inverse()?;
            }
        } else if self.records {
            self.log.push(upd);
        }
        Ok(gain)
    }

    /// Turns the search into a sampled one (D criterion): from here on the records are not
    /// kept, and gains are those of `size` not-chosen candidates drawn uniformly without
    /// replacement by the stream of `seed` ([`State::sample_gains`]).
    pub(crate) fn start_sampling(&mut self, size: usize, seed: u64) {
        self.records = false;
        self.rec = Vec::new();
        self.log.clear();
        self.ver.iter_mut().for_each(|v| *v = 0);
        self.gains.iter_mut().for_each(|g| *g = f64::NEG_INFINITY);
        self.sampler = Some((size.max(1), ChaCha8Rng::seed_from_u64(seed)));
    }

    /// A sampled search's next sample (in index order) with each candidate's gain, evaluated
    /// exactly from a fresh factor of the design (`O(s·m·n²·D)`); empty when every
    /// candidate is chosen or the search is not sampled.
    pub(crate) fn sample_gains(&mut self) -> Result<Vec<(usize, f64)>, SelectError> {
        let p = self.pool.n_candidates();
        let taken = self.chosen.len();
        let Some((size, rng)) = self.sampler.as_mut() else {
            return Ok(Vec::new());
        };
        // Draw `size` more than are chosen, so `size` are left once the chosen are dropped.
        let want = (*size + taken).min(p);
        let mut sample: Vec<usize> = rand::seq::index::sample(rng, p, want)
            .into_iter()
            .filter(|&c| !self.in_set[c])
            .take(*size)
            .collect();
        sample.sort_unstable();
        if sample.is_empty() {
            return Ok(Vec::new());
        }
        self.refresh_inverse()?;
        let maps: Vec<DMatrix<f64>> = (0..self.draws.len()).map(|d| self.map(d)).collect();
        let gains = subset_gains(self.pool, &maps, &sample, self.threads);
        Ok(sample.into_iter().zip(gains).collect())
    }

    /// Renews the gains an exchange reads its entering candidates from: every candidate's
    /// (a [`State::refresh`]), or in a sampled search a fresh sample's (the rest `−∞`).
    pub(crate) fn renew_gains(&mut self) -> Result<(), SelectError> {
        if self.sampler.is_none() {
            return self.refresh();
        }
        let sample = self.sample_gains()?;
        self.gains.iter_mut().for_each(|g| *g = f64::NEG_INFINITY);
        for (c, g) in sample {
            self.gains[c] = g;
        }
        self.renewals += 1;
        Ok(())
    }

    /// `q = L̃⁻¹Wᵀ` of draw `d`'s last factorisation.
    fn map(&self, d: usize) -> DMatrix<f64> {
        &self.draws[d].linv * self.frames[d].w.transpose()
    }

    /// Whether candidate `c`'s record and gain are up to date.
    pub(crate) fn is_current(&self, c: usize) -> bool {
        self.records && self.ver[c] == self.log.len()
    }

    /// Brings candidate `c`'s record and gain up to date (records kept).
    pub(crate) fn bring(&mut self, c: usize) {
        debug_assert!(self.records, "bring in a sampled search");
        let (a, b) = (self.off[c], self.off[c + 1]);
        apply_updates(
            self.pool,
            &self.log[self.ver[c]..],
            self.width,
            c,
            &mut self.rec[a..b],
        );
        self.ver[c] = self.log.len();
        self.gains[c] = if self.in_set[c] {
            f64::NEG_INFINITY
        } else {
            record_gain(
                &self.rec[a..b],
                self.pool.rows(c),
                self.draws.len(),
                self.width,
                self.tip_gains(),
            )
        };
    }

    /// Brings candidates `cands` (distinct, not chosen) up to date, over threads when there
    /// are many; the same as [`State::bring`] on each.
    pub(crate) fn bring_many(&mut self, cands: &[usize]) {
        debug_assert!(self.records, "bring_many in a sampled search");
        let t = if cands.len() >= 64 { self.threads } else { 1 };
        let (pool, width, log, tip) = (self.pool, self.width, &self.log, self.tip_gains());
        let (off, ver, rec) = (&self.off, &self.ver, &self.rec);
        let work = |part: &[usize]| -> Vec<(Vec<f64>, f64)> {
            part.iter()
                .map(|&c| {
                    let mut r = rec[off[c]..off[c + 1]].to_vec();
                    apply_updates(pool, &log[ver[c]..], width, c, &mut r);
                    let g = record_gain(&r, pool.rows(c), pool.n_draws(), width, tip);
                    (r, g)
                })
                .collect()
        };
        let per = if t <= 1 {
            cands.len()
        } else {
            cands.len().div_ceil(t).max(1)
        };
        let out: Vec<(Vec<f64>, f64)> = par_chunks(cands, per, work);
        for (&c, (r, g)) in cands.iter().zip(out) {
            self.rec[self.off[c]..self.off[c + 1]].copy_from_slice(&r);
            self.ver[c] = self.log.len();
            self.gains[c] = g;
        }
    }

    /// Brings every candidate up to date: one pass over the pool, over threads.
    pub(crate) fn sweep_all(&mut self) {
        debug_assert!(self.records, "sweep_all in a sampled search");
        let pool = self.pool;
        let (width, in_set, off, log) = (self.width, &self.in_set, &self.off, &self.log);
        let tip = self.tip_gains();
        let work = |range: std::ops::Range<usize>,
                    rec: &mut [f64],
                    gains: &mut [f64],
                    ver: &mut [usize]| {
            let base = off[range.start];
            for c in range.clone() {
                let k = c - range.start;
                let r = &mut rec[off[c] - base..off[c + 1] - base];
                apply_updates(pool, &log[ver[k]..], width, c, r);
                ver[k] = log.len();
                gains[k] = if in_set[c] {
                    f64::NEG_INFINITY
                } else {
                    record_gain(r, pool.rows(c), pool.n_draws(), width, tip)
                };
            }
        };
        par_ranges(
            self.threads,
            &self.off,
            &mut self.rec,
            &mut self.gains,
            &mut self.ver,
            work,
        );
        self.renewals += 1;
    }

    /// Replaces chosen candidate `out` by `inn` in the design (same place in `chosen`). Only
    /// the design changes: `M̃⁻¹`, the records and the gains are stale until
    /// [`State::refresh_inverse`] and [`State::renew_gains`].
    pub(crate) fn replace(&mut self, out: usize, inn: usize) {
        if let Some(pos) = self.chosen.iter().position(|&c| c == out) {
            self.chosen[pos] = inn;
            self.in_set[out] = false;
            self.in_set[inn] = true;
            self.rows_added += self.pool.rows(inn);
        }
    }

    /// Updates every draw's `M̃⁻¹` for adding candidate `c`; returns the records' update and
    /// the mean change of the criterion.
    fn factor_update(&mut self, c: usize) -> Result<(Update, f64), SelectError> {
        let ma = self.pool.rows(c);
        let mut draws = Vec::with_capacity(self.draws.len());
        let mut total = 0.0;
        for d in 0..self.draws.len() {
            let jt = self.whitened_t(d, c);
            let w = &self.frames[d].w;
            let st = &mut self.draws[d];
            let ut = &st.minv * &jt; // Uᵀ = M̃⁻¹J̃ᵀ
            let a = DMatrix::identity(ma, ma) + jt.transpose() * &ut;
            let l = chol_factor(&a).ok_or(SelectError::NotPositiveDefinite { draw: d })?;
            let bmat = l
                .solve_lower_triangular(&ut.transpose())
                .ok_or(SelectError::NotPositiveDefinite { draw: d })?; // B = L⁻¹U
            let bt = bmat.transpose();
            let (mut y, mut bc) = (Vec::new(), Vec::new());
            total += match &st.tip {
                None => chol_logdet(&l),
                Some((cm, _)) => {
                    let cbt = cm * &bt;
                    y = (w * (&st.minv * &cbt)).as_slice().to_vec();
                    let bcb = &bmat * cbt;
                    bc = bcb.as_slice().to_vec();
                    // tr(TM⁻¹Jᵀ(I + H)⁻¹JM⁻¹Tᵀ) = tr(BC̃Bᵀ).
                    bcb.trace()
                }
            };
            st.minv.gemm(-1.0, &bt, &bmat, 1.0);
            super::pool::symmetrize(&mut st.minv);
            // (B·Wᵀ)ᵀ = W·Bᵀ, n × mₐ: its columns are the rows of B·Wᵀ.
            draws.push(((w * &bt).as_slice().to_vec(), y, bc));
        }
        let upd = Update { ma, draws };
        Ok((upd, total / self.draws.len() as f64))
    }

    /// Recomputes every draw's `L̃⁻¹` and `M̃⁻¹ = L̃⁻ᵀL̃⁻¹` from the Cholesky factor of `M̃`
    /// (`O(N·m·n² + n³)` per draw; the candidates' blocks are left as they are).
    pub(crate) fn refresh_inverse(&mut self) -> Result<(), SelectError> {
        for d in 0..self.draws.len() {
            let m = whitened_information(self.pool, &self.frames[d], d, &self.chosen, true);
            let l = chol_factor(&m).ok_or(SelectError::NotPositiveDefinite { draw: d })?;
            let linv = lower_inverse(&l);
            let st = &mut self.draws[d];
            st.minv = linv.transpose() * &linv;
            st.linv = linv;
        }
        Ok(())
    }

    /// Recomputes every draw's `M̃⁻¹` from the Cholesky factor of `M̃`, and every candidate's
    /// blocks and gain by matrix products.
    pub(crate) fn refresh(&mut self) -> Result<(), SelectError> {
        self.refresh_inverse()?;
        let total = self.off[self.pool.n_candidates()];
        if self.rec.len() != total {
            self.rec = vec![0.0; total];
        }
        let mut maps: Vec<Maps> = Vec::with_capacity(self.draws.len());
        for d in 0..self.draws.len() {
            let st = &self.draws[d];
            // q·Jᵀ = L̃⁻¹J̃ᵀ, so H = (qJᵀ)ᵀ(qJᵀ); tq·(qJᵀ) = R̃M̃⁻¹J̃ᵀ, so F = its Gram.
            let q = self.map(d);
            let tq = st.tip.as_ref().map(|(_, r)| r * st.linv.transpose());
            maps.push((q, tq));
        }
        let pool = self.pool;
        let (width, in_set, tip) = (self.width, &self.in_set, self.tip_gains());
        let work = |range: std::ops::Range<usize>,
                    rec: &mut [f64],
                    gains: &mut [f64],
                    ver: &mut [usize]| {
            refresh_range(pool, &maps, width, tip, in_set, range, rec, gains);
            ver.iter_mut().for_each(|v| *v = 0);
        };
        par_ranges(
            self.threads,
            &self.off,
            &mut self.rec,
            &mut self.gains,
            &mut self.ver,
            work,
        );
        self.log.clear();
        self.records = true;
        self.renewals += 1;
        Ok(())
    }
}

/// `C̃ = T̃ᵀT̃` and a root with at most `n` rows (`T̃` itself, or QR's `R` when taller).
fn tip_root(t: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let c = t.transpose() * t;
    let root = if t.nrows() > t.ncols() {
        t.clone().qr().r()
    } else {
        t.clone()
    };
    (c, root)
}

#[cfg(test)]
impl State<'_> {
    /// Candidate `c`'s record (all draws).
    pub(crate) fn record(&self, c: usize) -> &[f64] {
        &self.rec[self.off[c]..self.off[c + 1]]
    }

    /// Turns the scheduled refreshes off (pure Woodbury updates).
    pub(crate) fn no_refresh(&mut self) {
        self.next_refresh = usize::MAX;
    }
}
