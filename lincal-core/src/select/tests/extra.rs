//! The efficiency bound, visiting order, errors, predicted deviations and the baseline.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::super::order::{nearest_neighbour, two_opt};
use super::super::{
    baseline, continuous_design, evaluate, kw_bound, predicted_std, select, tour_length,
    visiting_order, worth, Criterion, Pool, SelectError, SelectOptions,
};
use super::random_pool;

/// `p` random unit vectors of `R^n`, one row each.
fn sphere_pool(p: usize, n: usize, seed: u64) -> Pool {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let blocks = vec![(0..p)
        .map(|_| {
            let v = DMatrix::from_fn(1, n, |_, _| rng.gen_range(-1.0..1.0));
            let norm = v.norm();
            v / norm
        })
        .collect::<Vec<_>>()];
    Pool::from_blocks(n, &blocks).expect("pool")
}

#[test]
fn kw_bound_is_at_most_one_and_tight_for_large_designs() {
    for (seed, given, draws, m) in [(1, false, 1, 1), (2, true, 3, 2), (3, false, 2, 3)] {
        let pool = random_pool(60, 5, |_| m, draws, seed, given);
        for count in [5, 12, 30] {
            let opts = SelectOptions {
                bound_iterations: 30,
                ..SelectOptions::default()
            };
            let s = select(&pool, count, &Criterion::D, &opts).expect("select");
            let b = s.bound.expect("bound");
            assert!(b.efficiency > 0.0 && b.efficiency <= 1.0, "{b:?}");
            assert!(b.upper >= b.log_det - 1e-9);
        }
    }
    let pool = sphere_pool(200, 3, 5);
    let opts = SelectOptions {
        bound_iterations: 300,
        ..SelectOptions::default()
    };
    let s = select(&pool, 60, &Criterion::D, &opts).expect("select");
    let b = s.bound.expect("bound");
    eprintln!("sphere pool, N = 60 of 200, n = 3: {b:?}");
    assert!(b.efficiency >= 0.9 && b.efficiency <= 1.0, "{b:?}");
}

/// A draw where the pool is blind to a parameter (its column zero, as a PUMA's `θ6` at its
/// nominals) is left out of the bound, which is then the bound of the other draws alone.
#[test]
fn kw_bound_leaves_out_a_blind_draw() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (p, n) = (120, 4);
    let seeing: Vec<DMatrix<f64>> = (0..p)
        .map(|_| DMatrix::from_fn(2, n, |_, _| rng.gen_range(-1.0..1.0)))
        .collect();
    let blind: Vec<DMatrix<f64>> = seeing
        .iter()
        .map(|b| DMatrix::from_fn(2, n, |i, j| if j == 0 { 0.0 } else { b[(i, j)] }))
        .collect();
    let both = Pool::from_blocks(n, &[seeing.clone(), blind]).expect("pool");
    let alone = Pool::from_blocks(n, &[seeing]).expect("pool");
    let opts = SelectOptions::default();
    let chosen: Vec<usize> = (0..15).map(|k| 7 * k).collect();
    let b = kw_bound(&both, &chosen, 30, &opts)
        .expect("ok")
        .expect("bound");
    let a = kw_bound(&alone, &chosen, 30, &opts)
        .expect("ok")
        .expect("bound");
    assert_eq!((b.draws, a.draws), (1, 1));
    assert!((b.efficiency - a.efficiency).abs() < 1e-12, "{b:?} {a:?}");
    assert!(b.efficiency > 0.0 && b.efficiency <= 1.0);
}

#[test]
fn multiplicative_algorithm_max_d_approaches_n() {
    let pool = random_pool(50, 3, |_| 1, 1, 8, false);
    let opts = SelectOptions::default();
    let few = continuous_design(&pool, 10, 10, false, &opts)
        .expect("ok")
        .expect("design");
    let many = continuous_design(&pool, 10, 2000, false, &opts)
        .expect("ok")
        .expect("design");
    eprintln!("max d after 10: {}, after 2000: {}", few.max_d, many.max_d);
    assert!(many.max_d >= 3.0 * (1.0 - 1e-9));
    assert!(many.max_d < few.max_d);
    assert!(many.max_d <= 3.0 * 1.02, "max d = {}", many.max_d);
    assert!((many.weights.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    // The certificate bounds the continuous optimum from above.
    assert!(many.upper >= many.value - 1e-9);
    // Capped designs keep every weight at most 1/N.
    let capped = continuous_design(&pool, 10, 200, true, &opts)
        .expect("ok")
        .expect("design");
    assert!(capped.weights.iter().all(|&w| w <= 0.1 + 1e-12));
    assert!((capped.weights.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    // A singular chosen design has no bound.
    let one = kw_bound(&pool, &[0], 5, &opts).expect("ok");
    assert!(one.is_none());
}

/// Random joint vectors.
fn joints(p: usize, k: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..p)
        .map(|_| (0..k).map(|_| rng.gen_range(-3.0..3.0)).collect())
        .collect()
}

#[test]
fn visiting_order_is_a_shorter_permutation() {
    for seed in 0..5 {
        let q = joints(40, 6, seed);
        let start = vec![0.0; 6];
        for st in [None, Some(start.as_slice())] {
            let order = visiting_order(&q, st).expect("order");
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..40).collect::<Vec<_>>());
            let nn = nearest_neighbour(&q, st);
            assert!(tour_length(&q, &order, st) <= tour_length(&q, &nn, st));
        }
        // 2-opt never lengthens any tour, e.g. a random one.
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 9);
        let mut order: Vec<usize> = (0..40).collect();
        for i in (1..40).rev() {
            order.swap(i, rng.gen_range(0..=i));
        }
        let before = tour_length(&q, &order, None);
        two_opt(&q, &mut order, None, usize::MAX);
        assert!(tour_length(&q, &order, None) <= before);
    }
    assert_eq!(
        visiting_order(&[], None).expect("empty"),
        Vec::<usize>::new()
    );
    assert_eq!(visiting_order(&[vec![1.0]], None).expect("one"), vec![0]);
}

#[test]
fn bad_input_gives_errors() {
    let pool = random_pool(5, 3, |_| 1, 1, 1, false);
    let opts = SelectOptions::default();
    assert_eq!(
        select(&pool, 6, &Criterion::D, &opts),
        Err(SelectError::TooFewCandidates { wanted: 6, pool: 5 })
    );
    let empty = select(&pool, 0, &Criterion::D, &opts).expect("empty design");
    assert!(empty.chosen.is_empty() && empty.value.is_finite());
    let all = select(&pool, 5, &Criterion::D, &opts).expect("whole pool");
    assert_eq!(all.chosen.len(), 5);
    let mut data = vec![vec![0.5; 12], vec![0.5; 12]];
    data[1][2 * 3 + 1] = f64::NAN;
    assert_eq!(
        Pool::new(3, &[1, 1, 2], data.clone()).err(),
        Some(SelectError::NonFinite {
            candidate: 2,
            draw: 1
        })
    );
    data[1][7] = f64::INFINITY;
    assert!(matches!(
        Pool::new(3, &[1, 1, 2], data).err(),
        Some(SelectError::NonFinite {
            candidate: 2,
            draw: 1
        })
    ));
    assert!(matches!(
        Pool::new(3, &[0], vec![vec![]]),
        Err(SelectError::Shape(_))
    ));
    assert!(matches!(
        Pool::new(1, &[7], vec![vec![0.0; 7]]),
        Err(SelectError::Shape(_))
    ));
    assert!(matches!(
        Pool::new(2, &[1], vec![vec![0.0; 3]]),
        Err(SelectError::Shape(_))
    ));
}

#[test]
fn bad_options_and_inputs_give_errors() {
    let pool = random_pool(5, 3, |_| 1, 1, 1, false);
    let opts = SelectOptions::default();
    let bad = SelectOptions {
        ridge: 0.0,
        ..SelectOptions::default()
    };
    assert!(matches!(
        select(&pool, 2, &Criterion::D, &bad),
        Err(SelectError::BadOption(_))
    ));
    let tip = Criterion::Tip(vec![DMatrix::zeros(2, 4)]);
    assert!(matches!(
        select(&pool, 2, &tip, &opts),
        Err(SelectError::Shape(_))
    ));
    assert_eq!(
        evaluate(&pool, &[1, 1], &Criterion::D, &opts),
        Err(SelectError::BadCandidate { index: 1 })
    );
    assert!(matches!(
        pool.clone().with_given(vec![DMatrix::zeros(2, 2)]),
        Err(SelectError::Shape(_))
    ));
    assert!(matches!(
        visiting_order(&[vec![0.0, 1.0], vec![0.0]], None),
        Err(SelectError::Shape(_))
    ));
    assert!(matches!(
        visiting_order(&[vec![f64::NAN]], None),
        Err(SelectError::NonFiniteInput { .. })
    ));
    assert!(matches!(
        predicted_std(&DMatrix::zeros(2, 3)),
        Err(SelectError::Shape(_))
    ));
    assert!(baseline(&pool, 6, &Criterion::D, &opts, 3, 1).is_err());
    assert!(!format!(
        "{}",
        SelectError::NonFinite {
            candidate: 2,
            draw: 0
        }
    )
    .is_empty());
}

#[test]
fn predicted_std_full_and_deficient() {
    let pool = random_pool(20, 5, |_| 2, 1, 4, false);
    let info = pool
        .information(0, &(0..20).collect::<Vec<_>>())
        .expect("info");
    let inv = info.clone().try_inverse().expect("inverse");
    let s = predicted_std(&info).expect("std");
    for (j, v) in s.iter().enumerate() {
        assert!((v - inv[(j, j)].sqrt()).abs() < 1e-12 * v);
    }
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 4.0, 0.0]));
    assert_eq!(
        predicted_std(&d).expect("std"),
        vec![1.0, 0.5, f64::INFINITY]
    );
    let c = DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 4.0]);
    let s = predicted_std(&c).expect("std");
    assert!(s[0].is_infinite() && s[1].is_infinite() && (s[2] - 0.5).abs() < 1e-12);
    let z = predicted_std(&DMatrix::zeros(2, 2)).expect("std");
    assert!(z.iter().all(|v| v.is_infinite()));
}

#[test]
fn baseline_and_worth() {
    let pool = random_pool(300, 6, |_| 1, 2, 21, false);
    let opts = SelectOptions::default();
    let s = select(&pool, 12, &Criterion::D, &opts).expect("select");
    let b = baseline(&pool, 12, &Criterion::D, &opts, 51, 7).expect("baseline");
    assert_eq!(
        b,
        baseline(&pool, 12, &Criterion::D, &opts, 51, 7).expect("again")
    );
    assert!(b.value < s.value);
    assert_eq!(b.std.len(), 6);
    assert!(b.std.iter().all(|v| v.is_finite() && *v > 0.0));
    let chosen_std = predicted_std(&pool.information(0, &s.chosen).expect("info")).expect("std");
    let better = chosen_std.iter().zip(&b.std).filter(|(c, b)| c < b).count();
    assert!(better >= 4, "{chosen_std:?} vs {:?}", b.std);
    let w = worth(&pool, s.log_det, &opts, 51, 7)
        .expect("worth")
        .expect("reachable");
    eprintln!("12 chosen poses are worth {w} random ones");
    assert!(w > 12 && w <= 300);
    let lower = worth(&pool, b.value, &opts, 51, 7)
        .expect("worth")
        .expect("reachable");
    assert!(lower <= w);
    let f0 = evaluate(&pool, &[], &Criterion::D, &opts).expect("empty");
    assert_eq!(worth(&pool, f0 - 1.0, &opts, 5, 1), Ok(Some(0)));
    assert_eq!(worth(&pool, 1e9, &opts, 5, 1), Ok(None));
    let t = super::random_tip(&pool, 3, 2);
    let tb = baseline(&pool, 12, &Criterion::Tip(t.clone()), &opts, 11, 3).expect("tip");
    let ts = select(&pool, 12, &Criterion::Tip(t), &opts).expect("tip select");
    assert!(ts.value < tb.value);
}
