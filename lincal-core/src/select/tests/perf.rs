//! Timings (run by hand: `cargo test --release -p lincal-core --lib select::tests::perf --
//! --ignored --nocapture`).

use std::time::Instant;

use super::super::{baseline, kw_bound, select, worth, Criterion, SelectOptions};
use super::{random_pool, random_tip};

fn time(p: usize, n: usize, count: usize, draws: usize, tip: bool) {
    let pool = random_pool(p, n, |_| 1, draws, 1, false);
    let opts = SelectOptions::default();
    let crit = if tip {
        Criterion::Tip(random_tip(&pool, 30, 2))
    } else {
        Criterion::D
    };
    let t = Instant::now();
    let s = select(&pool, count, &crit, &opts).expect("select");
    eprintln!(
        "{} P = {p}, n = {n}, N = {count}, D = {draws}: {:.3} s ({} swaps, {:.4} -> {:.4})",
        if tip { "tip" } else { "D" },
        t.elapsed().as_secs_f64(),
        s.swaps,
        s.greedy_value,
        s.value
    );
    if tip {
        return;
    }
    let t = Instant::now();
    let b = kw_bound(&pool, &s.chosen, 10, &opts).expect("bound");
    eprintln!(
        "  KW bound, 10 iterations: {:.3} s {b:?}",
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let base = baseline(&pool, count, &crit, &opts, 51, 1).expect("baseline");
    let w = worth(&pool, s.log_det, &opts, 51, 1).expect("worth");
    eprintln!(
        "  baseline + worth (51 replicates): {:.3} s (median f {:.3}, worth {w:?})",
        t.elapsed().as_secs_f64(),
        base.value
    );
}

#[test]
#[ignore = "timing, run by hand"]
fn timing() {
    time(10_000, 27, 30, 4, false);
    time(10_000, 27, 30, 4, true);
    time(100_000, 40, 200, 3, false);
}
