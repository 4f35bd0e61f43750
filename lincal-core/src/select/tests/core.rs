//! Rank-m updates, greedy, exchange, invariance, Woodbury accuracy and determinism.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::super::frame::{frames, whitened_information, whitened_tip};
use super::super::greedy::best_candidate;
use super::super::state::State;
use super::super::{evaluate, select, Criterion, Pool, SelectOptions};
use super::{block, close, direct_f, direct_g, random_pool, random_tip};

/// Checks every candidate's gain against the from-scratch difference for `steps` greedy
/// steps (D, or tip when `tip` is given).
fn check_gains(pool: &Pool, ridge: f64, steps: usize, tol: f64, tip: Option<Vec<DMatrix<f64>>>) {
    let fr = frames(pool, ridge).expect("frames");
    let crit = tip.clone().map_or(Criterion::D, Criterion::Tip);
    let tw = whitened_tip(pool, &fr, &crit).expect("tip");
    let mut st = State::new(pool, &fr, tw.as_deref(), 1).expect("state");
    let value = |set: &[usize]| match &tip {
        None => direct_f(pool, set, ridge),
        Some(t) => -direct_g(pool, set, ridge, t),
    };
    for _ in 0..steps {
        st.sweep_all();
        let set = st.chosen.clone();
        let now = value(&set);
        let mut direct = vec![f64::NEG_INFINITY; pool.n_candidates()];
        for (c, dc) in direct.iter_mut().enumerate() {
            if st.in_set[c] {
                assert_eq!(st.gains[c], f64::NEG_INFINITY);
                continue;
            }
            let mut with = set.clone();
            with.push(c);
            *dc = value(&with) - now;
            assert!(
                close(st.gains[c], *dc, tol, 1e-3),
                "candidate {c} after {set:?}: gain {} direct {dc}",
                st.gains[c]
            );
        }
        let best = best_candidate(&st.gains, &st.in_set).expect("a candidate");
        let reported = st.add(best).expect("add");
        assert!(close(reported, direct[best], tol, 1e-3));
    }
}

#[test]
fn greedy_gains_equal_direct_log_det_differences() {
    for m in 1..=3 {
        for draws in [1, 3] {
            let seed = (10 * m + draws) as u64;
            // Well conditioned throughout (given information): exact to 1e-9.
            let pool = random_pool(12, 4, |_| m, draws, seed, true);
            check_gains(&pool, 1e-9, 6, 1e-9, None);
            // No given information, a larger ridge: exact to 1e-9 as well.
            let pool = random_pool(12, 4, |_| m, draws, seed + 100, false);
            check_gains(&pool, 1e-2, 6, 1e-9, None);
            // The default tiny ridge through the singular phase: both sides lose digits
            // there (pivots of size ε), so a looser tolerance.
            check_gains(&pool, 1e-9, 6, 1e-5, None);
        }
    }
    // Mixed block sizes.
    let pool = random_pool(12, 4, |i| 1 + i % 3, 2, 99, true);
    check_gains(&pool, 1e-9, 8, 1e-9, None);
}

#[test]
fn tip_gains_equal_direct_trace_differences() {
    for m in 1..=3 {
        for draws in [1, 3] {
            let pool = random_pool(12, 4, |_| m, draws, (m * 7 + draws) as u64, true);
            let t = random_tip(&pool, 3, 5);
            check_gains(&pool, 1e-9, 6, 1e-9, Some(t));
            let t = random_tip(&pool, 7, 6); // more rows than parameters (compressed root)
            check_gains(&pool, 1e-9, 6, 1e-9, Some(t));
        }
    }
}

#[test]
fn reported_value_equals_direct_computation() {
    for (m, draws, given) in [(1, 1, false), (2, 3, false), (3, 1, true), (1, 3, true)] {
        let pool = random_pool(12, 4, |_| m, draws, (m + 10 * draws) as u64, given);
        let opts = SelectOptions::default();
        for count in [2, 4, 6] {
            // Designs singular but for the ridge (pivots of size ε): the LU reference
            // loses digits there.
            let tol = if given || count * m >= 4 { 1e-9 } else { 1e-6 };
            let s = select(&pool, count, &Criterion::D, &opts).expect("select");
            assert_eq!(s.chosen.len(), count);
            let direct = direct_f(&pool, &s.chosen, opts.ridge);
            assert!(close(s.value, direct, tol, 1.0), "{} vs {direct}", s.value);
            assert_eq!(s.value, s.log_det);
            assert!(s.value >= s.greedy_value - 1e-12);
            let e = evaluate(&pool, &s.chosen, &Criterion::D, &opts).expect("evaluate");
            assert!(close(e, direct, tol, 1.0));
            let t = random_tip(&pool, 3, 1);
            let s = select(&pool, count, &Criterion::Tip(t.clone()), &opts).expect("tip");
            let direct = direct_g(&pool, &s.chosen, opts.ridge, &t);
            assert!(close(s.value, direct, tol, 1e-9), "{} vs {direct}", s.value);
            assert!(s.value <= s.greedy_value * (1.0 + 1e-12));
        }
    }
}

/// Every `k`-subset of `0..p`.
fn subsets(p: usize, k: usize) -> Vec<Vec<usize>> {
    if k == 0 {
        return vec![Vec::new()];
    }
    (k - 1..p)
        .flat_map(|last| {
            subsets(last, k - 1).into_iter().map(move |mut s| {
                s.push(last);
                s
            })
        })
        .collect()
}

#[test]
fn exchange_reaches_the_brute_force_optimum() {
    let opts = SelectOptions::default();
    let (mut equal, mut greedy_equal, runs) = (0usize, 0usize, 100u64);
    let (mut worst, mut near): (f64, usize) = (0.0, 0);
    for seed in 0..runs {
        let draws = 1 + (seed % 2) as usize;
        let pool = random_pool(10, 3, |_| 1, draws, 1000 + seed, false);
        let s = select(&pool, 3, &Criterion::D, &opts).expect("select");
        assert!(s.value >= s.greedy_value - 1e-12, "exchange made it worse");
        let best = subsets(10, 3)
            .iter()
            .map(|set| evaluate(&pool, set, &Criterion::D, &opts).expect("evaluate"))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(s.value <= best + 1e-9);
        // No single swap improves the design found (it is a local optimum).
        for out in 0..3 {
            for inn in (0..10).filter(|i| !s.chosen.contains(i)) {
                let mut t = s.chosen.clone();
                t[out] = inn;
                let v = evaluate(&pool, &t, &Criterion::D, &opts).expect("evaluate");
                assert!(
                    v <= s.value + 1e-9,
                    "swap {out}->{inn} improves {} to {v}",
                    s.value
                );
            }
        }
        worst = worst.max(best - s.value);
        // Within 1 % of the optimum in the determinant (f is a log).
        near += usize::from(best - s.value <= 0.01_f64.ln_1p());
        equal += usize::from(best - s.value <= 1e-9);
        greedy_equal += usize::from(best - s.greedy_value <= 1e-9);
    }
    eprintln!(
        "optimum found {equal}/{runs} (greedy alone {greedy_equal}/{runs}), worst gap in f {worst}"
    );
    // Single swaps plus excursions are a local search: on these saturated designs
    // (N = n) a rare seed ends in another local optimum (seed 72: 0.154 below in f).
    assert!(
        near >= 98,
        "within 1 % of the optimum on only {near}/{runs} seeds"
    );
    assert!(equal >= 95, "optimum found only {equal}/{runs} times");
}

#[test]
fn exchange_never_decreases_the_criterion() {
    for seed in 0..10 {
        let pool = random_pool(40, 5, |i| 1 + i % 2, 2, 50 + seed, seed % 2 == 0);
        for entering in [0, 4, 64] {
            let opts = SelectOptions {
                entering,
                ..SelectOptions::default()
            };
            let s = select(&pool, 8, &Criterion::D, &opts).expect("select");
            assert!(s.value >= s.greedy_value - 1e-12);
            let t = random_tip(&pool, 4, seed);
            let s = select(&pool, 8, &Criterion::Tip(t), &opts).expect("tip");
            assert!(s.value <= s.greedy_value * (1.0 + 1e-12));
        }
    }
}

/// The pool with every block multiplied by `a` on the right.
fn transformed(pool: &Pool, a: &DMatrix<f64>) -> Pool {
    let blocks: Vec<Vec<DMatrix<f64>>> = (0..pool.n_draws())
        .map(|d| {
            (0..pool.n_candidates())
                .map(|i| block(pool, d, i) * a)
                .collect()
        })
        .collect();
    Pool::from_blocks(pool.n_params(), &blocks).expect("pool")
}

#[test]
fn choice_is_invariant_under_reparametrisation() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let opts = SelectOptions::default();
    for seed in 0..6 {
        let pool = random_pool(30, 4, |i| 1 + i % 2, 2, 300 + seed, false);
        let scale = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-2, 1.0, 1e2, 3.0]));
        let general = DMatrix::from_fn(4, 4, |i, j| {
            rng.gen_range(-0.5..0.5) + if i == j { 1.5 } else { 0.0 }
        });
        let s0 = select(&pool, 6, &Criterion::D, &opts).expect("select");
        for a in [scale, general] {
            let s1 = select(&transformed(&pool, &a), 6, &Criterion::D, &opts).expect("select");
            assert_eq!(s0.chosen, s1.chosen, "seed {seed}");
            let shift = 2.0 * a.determinant().abs().ln();
            assert!((s1.value - s0.value - shift).abs() < 1e-8 * s0.value.abs().max(1.0));
        }
    }
}

/// Relative Frobenius distance.
fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// Adds 50 greedy candidates, then compares `M̃⁻¹` and the leverages with direct ones.
fn woodbury_after_50(pool: &Pool, refresh: bool) -> f64 {
    let fr = frames(pool, 1e-9).expect("frames");
    let mut st = State::new(pool, &fr, None, 1).expect("state");
    if !refresh {
        st.no_refresh();
    }
    for _ in 0..50 {
        st.sweep_all();
        let b = best_candidate(&st.gains, &st.in_set).expect("candidate");
        st.add(b).expect("add");
    }
    st.sweep_all();
    let mut worst: f64 = 0.0;
    for (d, frame) in fr.iter().enumerate() {
        let m = whitened_information(pool, frame, d, &st.chosen, true);
        let inv = m.clone().try_inverse().expect("inverse");
        worst = worst.max(rel(&st.draws[d].minv, &inv));
        for c in 0..pool.n_candidates() {
            let jt = st.whitened_t(d, c);
            let h = jt.transpose() * &inv * &jt;
            let k = pool.rows(c);
            let r = &st.record(c)[d * k * k..(d + 1) * k * k];
            let got = DMatrix::from_row_slice(k, k, r);
            worst = worst.max(rel(&got, &h));
        }
    }
    worst
}

#[test]
fn woodbury_inverse_stays_accurate() {
    // Pure Woodbury (no refresh) from a well-conditioned start.
    let pool = random_pool(80, 6, |i| 1 + i % 2, 2, 3, true);
    let e = woodbury_after_50(&pool, false);
    assert!(e < 1e-10, "no refresh, given information: {e:e}");
    // No given information: the singular start costs digits, the refreshes restore them.
    let pool = random_pool(80, 6, |i| 1 + i % 2, 2, 4, false);
    let e = woodbury_after_50(&pool, true);
    assert!(e < 1e-10, "with refreshes: {e:e}");
}

#[test]
fn lazy_greedy_equals_plain_greedy() {
    // Small pools, and large ones where steps bring hundreds of candidates up to date (the
    // batches over threads, and the refresh fallback).
    for (seed, p, n, count) in [(40, 600, 7, 25), (41, 600, 7, 25), (42, 4000, 12, 40)] {
        let pool = random_pool(p, n, |i| 1 + i % 3, 2, seed, seed % 2 == 1);
        let fr = frames(&pool, 1e-9).expect("frames");
        let mut lazy = State::new(&pool, &fr, None, 2).expect("state");
        super::super::greedy::run_every(&mut lazy, count).expect("greedy");
        let mut plain = State::new(&pool, &fr, None, 2).expect("state");
        for _ in 0..count {
            plain.sweep_all();
            let b = best_candidate(&plain.gains, &plain.in_set).expect("candidate");
            plain.add(b).expect("add");
        }
        assert_eq!(lazy.chosen, plain.chosen, "seed {seed}");
    }
}

/// A sampled step's gains are exact: the same as a full refresh gives the sampled
/// candidates, at every step of a sampled greedy.
#[test]
fn sampled_gains_equal_the_refreshed_ones() {
    let pool = random_pool(900, 9, |i| 1 + i % 3, 3, 61, true);
    let fr = frames(&pool, 1e-9).expect("frames");
    let mut st = State::new(&pool, &fr, None, 2).expect("state");
    st.start_sampling(120, 5);
    for step in 0..20 {
        let sample = st.sample_gains().expect("sample");
        assert_eq!(sample.len(), 120, "step {step}");
        assert!(sample.iter().all(|&(c, _)| !st.in_set[c]), "step {step}");
        let mut full = State::new(&pool, &fr, None, 1).expect("state");
        for &c in &st.chosen {
            full.add(c).expect("add");
        }
        full.refresh().expect("refresh");
        for &(c, g) in &sample {
            let want = full.gains[c];
            assert!(
                (g - want).abs() <= 1e-9 * want.abs().max(1.0),
                "step {step}, {c}: {g} {want}"
            );
        }
        let best = sample
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
            .expect("best");
        st.add(best.0).expect("add");
    }
}

/// The sampled greedy: the same seed gives the same choice whatever the threads, another
/// seed (generally) another, and its design is within a few per cent of the plain greedy's
/// in D-efficiency (`exp(Δf/n)`), its expected guarantee being the plain one's less `ε`.
#[test]
fn sampled_greedy_is_seeded_and_near_the_plain_one() {
    let (p, n, count) = (6000, 10, 80);
    let pool = random_pool(p, n, |i| 1 + i % 3, 2, 62, false);
    let fr = frames(&pool, 1e-9).expect("frames");
    let s = super::super::greedy::sample_size(p, count).expect("sampled");
    let sampled = |threads: usize, seed: u64| {
        let mut st = State::new_sampled(&pool, &fr, threads, s, seed).expect("state");
        super::super::greedy::run(&mut st, count).expect("greedy");
        st.chosen.clone()
    };
    let one = sampled(1, 7);
    assert_eq!(one, sampled(2, 7));
    assert_ne!(one, sampled(2, 8));
    let mut plain = State::new(&pool, &fr, None, 2).expect("state");
    super::super::greedy::run_every(&mut plain, count).expect("greedy");
    let f = |set: &[usize]| super::super::frame::value(&pool, &fr, None, set).expect("value");
    let (fs, fp) = (f(&one), f(&plain.chosen));
    let efficiency = ((fs - fp) / n as f64).exp();
    assert!(efficiency > 0.97, "sampled {fs}, plain {fp}: {efficiency}");
}

#[test]
fn result_does_not_depend_on_threads() {
    let pool = random_pool(1500, 8, |i| 1 + i % 3, 2, 5, false);
    let t = random_tip(&pool, 5, 9);
    // N = 60 of 1500 takes the sampled greedy and exchange (D), N = 20 the lazy one.
    for (crit, count) in [
        (Criterion::D, 20),
        (Criterion::D, 60),
        (Criterion::Tip(t), 20),
    ] {
        let run = |threads| {
            let opts = SelectOptions {
                threads,
                bound_iterations: 3,
                seed: 11,
                ..SelectOptions::default()
            };
            select(&pool, count, &crit, &opts).expect("select")
        };
        let one = run(1);
        assert_eq!(one, run(2), "{count}");
        assert_eq!(one, run(3), "{count}");
    }
    assert!(super::super::greedy::sample_size(1500, 60).is_some());
    assert!(super::super::greedy::sample_size(1500, 20).is_none());
}
