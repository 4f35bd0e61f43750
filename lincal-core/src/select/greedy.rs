//! Greedy forward selection: from the given information and the regulariser, add at each
//! step the candidate of largest gain (see [`super::state`]), ties to the lowest index.
//!
//! D criterion: lazy evaluation (Minoux's accelerated greedy), with the same result as
//! evaluating every candidate at every step. `S ↦ log det(M₀ + Σ_{i∈S} JᵢᵀJᵢ)` is
//! submodular — a candidate's gain `log det(I + JM⁻¹Jᵀ)` can only shrink as the design grows,
//! since `M⁻¹` does — and so is its average over draws, so a gain computed at an earlier step
//! bounds the current one from above. Candidates sit in a max-heap by their last computed
//! gain; the top one is brought up to date (its logged rank-`m` updates applied, `O(m²·n)`
//! each) and put back, until the top is up to date: its gain is then at least every other
//! candidate's bound, hence the largest. Ties order by index, as in the plain search. After
//! 64 candidates in one step, the next stale ones are brought up to date in batches of 512
//! over threads; after `P/8`, every candidate is brought up to date in one sweep over
//! threads and the heap rebuilt. A sweep applies only the updates a candidate has not seen,
//! so over the whole search each candidate meets each update at most once (`O(m²·n)`),
//! where a refresh from the factor costs `O(m·n²)` per candidate every time: on large
//! pools, where the bounds of the early, nearly singular steps barely prune, sweeps keep
//! the greedy's cost at that of the plain search's passes instead of a multiple of it.
//!
//! D criterion on a pool large against the count (`(P/N)·ln(1/ε) ≤ P/8`, [`sample_size`]):
//! the sampled greedy of [`run_sampled`] instead, each step the best of a uniform sample of
//! `(P/N)·ln(1/ε)` candidates, evaluated exactly from a fresh factor. On 10⁵ candidates
//! the lazy bounds barely prune (the many near-equivalent poses of a large pool all lose
//! gain at once), so the lazy search costs dozens of passes over the pool; the sampled one
//! costs `N·s` evaluations, about `ln(1/ε) = 4.6` passes in all.
//!
//! Tip criterion: the trace decrease is not submodular in general, so every step brings every
//! candidate up to date (one pass over the pool, over threads). While the design is singular
//! but for the regulariser (smallest eigenvalue of the whitened information below `1000·ε`),
//! `g` is dominated by `1/ε` terms and picks poorly conditioned designs, so those steps use
//! the D gains (from the same records) instead; the tip gains take over once the design is
//! nonsingular.

use std::cmp::Ordering;
use std::collections::binary_heap::PeekMut;
use std::collections::BinaryHeap;

use super::state::State;
use super::types::SelectError;

/// The not-chosen candidate of largest gain (NaN counts as `−∞`), ties to the lowest index;
/// `None` when every candidate is chosen.
pub(crate) fn best_candidate(gains: &[f64], in_set: &[bool]) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (i, (&g, &chosen)) in gains.iter().zip(in_set).enumerate() {
        if chosen {
            continue;
        }
        let g = if g.is_nan() { f64::NEG_INFINITY } else { g };
        match best {
            Some((_, b)) if g <= b => {}
            _ => best = Some((i, g)),
        }
    }
    best.map(|(i, _)| i)
}

/// `ε` of the sampled greedy: in expectation its gain over the empty design,
/// `f(S) − f(∅)`, is at least `(1 − 1/e − ε)` of the best set's.
pub(crate) const SAMPLE_EPSILON: f64 = 1e-2;

/// The sample size of the sampled greedy for `count` of `pool` candidates, `None` when the
/// plain (lazy) greedy is used: `s = ⌈(P/N)·ln(1/ε)⌉`, taken only when `s ≤ P/8` (with
/// `ε = 0.01`: from `N ≥ 37`), that is
/// when a step's sample is at most an eighth of a pass over the pool.
pub(crate) fn sample_size(pool: usize, count: usize) -> Option<usize> {
    if count == 0 {
        return None;
    }
    let s = (pool as f64 / count as f64 * (1.0 / SAMPLE_EPSILON).ln()).ceil() as usize;
    (s.max(1) <= pool / 8).then_some(s.max(1))
}

/// Adds candidates greedily until `count` are chosen: the sampled greedy on a sampled state
/// ([`State::new_sampled`], built when [`sample_size`] says so), else [`run_every`].
pub(crate) fn run(state: &mut State<'_>, count: usize) -> Result<(), SelectError> {
    if state.is_sampled() {
        return run_sampled(state, count);
    }
    run_every(state, count)
}

/// The greedy that weighs every candidate at every step: a pass over the pool per step
/// (tip), or the lazy evaluation (D).
pub(crate) fn run_every(state: &mut State<'_>, count: usize) -> Result<(), SelectError> {
    if state.is_tip() {
        state.d_phase = !state.nonsingular();
        while state.chosen.len() < count {
            state.sweep_all();
            let best = best_candidate(&state.gains, &state.in_set).ok_or(too_few(state, count))?;
            state.add(best)?;
            if state.d_phase && state.nonsingular() {
                state.d_phase = false;
            }
        }
        state.d_phase = false;
        return Ok(());
    }
    let limit = (state.pool.n_candidates() / 8).max(64);
    let mut heap = BinaryHeap::new();
    let mut built = None;
    while state.chosen.len() < count {
        let mut evals = 0;
        let best = loop {
            if built != Some(state.renewals) {
                heap = bounds(state);
                built = Some(state.renewals);
            }
            let Some(mut top) = heap.peek_mut() else {
                return Err(too_few(state, count));
            };
            let c = top.1;
            if state.in_set[c] || state.is_current(c) {
                PeekMut::pop(top);
                if state.in_set[c] {
                    continue;
                }
                break c;
            }
            if evals < BATCH_AFTER {
                state.bring(c);
                *top = Key(state.gains[c], c); // sifts down when `top` drops
                drop(top);
                evals += 1;
            } else {
                drop(top);
                evals += bring_batch(state, &mut heap);
            }
            if evals > limit {
                state.sweep_all();
                evals = 0;
            }
        };
        state.add(best)?;
    }
    Ok(())
}

/// The sampled ("lazier than lazy") greedy of Mirzasoleiman et al. (AAAI 2015): each step
/// draws `s` of the not-chosen candidates uniformly without replacement and adds the one of
/// largest gain among them, evaluated exactly from a fresh factor of the design (so
/// `O(s·m·n²·D)` a step and no per-candidate records). For a monotone submodular criterion,
/// as `log det` is here, `s = (P/N)·ln(1/ε)` gives an expected gain over the empty design
/// of at least `(1 − 1/e − ε)` of the best set's, the plain greedy's guarantee less `ε`.
/// The exchange that follows draws its entering candidates from fresh samples too. Ties go
/// to the lowest index within the sample.
fn run_sampled(state: &mut State<'_>, count: usize) -> Result<(), SelectError> {
    while state.chosen.len() < count {
        let mut best: Option<(usize, f64)> = None;
        for (c, g) in state.sample_gains()? {
            let g = if g.is_nan() { f64::NEG_INFINITY } else { g };
            if best.is_none_or(|(_, b)| g > b) {
                best = Some((c, g));
            }
        }
        let Some((c, _)) = best else {
            return Err(too_few(state, count));
        };
        state.add(c)?;
    }
    Ok(())
}

/// Candidates brought up to date one by one in a step before batches of [`BATCH`].
const BATCH_AFTER: usize = 64;
/// Stale candidates brought up to date together (over threads).
const BATCH: usize = 512;

/// Pops up to [`BATCH`] stale candidates off the top of the heap (stopping at an up-to-date
/// one), brings them up to date together and pushes them back; returns how many. The same
/// as bringing them one by one: each candidate's update depends only on the log.
fn bring_batch(state: &mut State<'_>, heap: &mut BinaryHeap<Key>) -> usize {
    let mut batch = Vec::with_capacity(BATCH);
    while batch.len() < BATCH {
        let Some(top) = heap.peek_mut() else { break };
        let c = top.1;
        if state.in_set[c] {
            PeekMut::pop(top);
            continue;
        }
        if state.is_current(c) {
            break;
        }
        batch.push(PeekMut::pop(top).1);
    }
    state.bring_many(&batch);
    heap.extend(batch.iter().map(|&c| Key(state.gains[c], c)));
    batch.len()
}

/// The error for a pool that ran out of candidates.
fn too_few(state: &State<'_>, count: usize) -> SelectError {
    SelectError::TooFewCandidates {
        wanted: count,
        pool: state.pool.n_candidates(),
    }
}

/// The heap of the not-chosen candidates by their current gains.
fn bounds(state: &State<'_>) -> BinaryHeap<Key> {
    let keys: Vec<Key> = (0..state.gains.len())
        .filter(|&c| !state.in_set[c])
        .map(|c| Key(state.gains[c], c))
        .collect();
    BinaryHeap::from(keys)
}

/// A heap entry: larger gain first (NaN as `−∞`), then lower index.
struct Key(f64, usize);

impl Key {
    fn gain(&self) -> f64 {
        if self.0.is_nan() {
            f64::NEG_INFINITY
        } else {
            self.0
        }
    }
}

impl PartialEq for Key {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Key {}

impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Key {
    fn cmp(&self, other: &Self) -> Ordering {
        self.gain()
            .total_cmp(&other.gain())
            .then(other.1.cmp(&self.1))
    }
}
