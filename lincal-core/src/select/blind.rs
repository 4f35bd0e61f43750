//! Why a choice leaves parameters unseen, and whom to blame: the poses asked for (`-n`) when
//! the whole pool would see every parameter, the candidates themselves when not even all of
//! them would: most often a pool of repeated poses (a logger that wrote one pose many times,
//! a candidates file of one row copied), whose repeats add no information whatever `-n`.

use nalgebra::DMatrix;

use super::pool::Pool;
use super::predicted_std;
use crate::data::Poses;
use crate::error::{Error, ErrorClass, Location, Result};

/// Two candidates on the same constraint whose joint readings all differ by at most this
/// (radians or metres, relative beyond 1) are one pose repeated: near-duplicates.
pub const SAME_POSE: f64 = 1e-9;

/// The number of distinct poses of `pool`: candidates on the same constraint whose readings
/// are all within [`SAME_POSE`] of each other's count once (sorted, so repeats are
/// neighbours; `O(P log P)`).
#[must_use]
pub fn distinct_poses(pool: &Poses) -> usize {
    let q: Vec<&[f64]> = pool.q.iter().collect();
    let c: Vec<usize> = pool.constraint.iter().collect();
    let mut order: Vec<usize> = (0..q.len()).collect();
    order.sort_by(|&a, &b| {
        c.get(a).cmp(&c.get(b)).then_with(|| {
            q[a].iter()
                .zip(q[b])
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    let same = |a: usize, b: usize| {
        c.get(a) == c.get(b)
            && q[a]
                .iter()
                .zip(q[b])
                .all(|(x, y)| (x - y).abs() <= SAME_POSE * x.abs().max(y.abs()).max(1.0))
    };
    let repeats = order.windows(2).filter(|w| same(w[0], w[1])).count();
    q.len() - repeats
}

/// What the error about unseen parameters reads beside the blind names.
pub(super) struct BlindCase<'a> {
    /// The design (the given poses' information and the prior among its given one).
    pub design: &'a Pool,
    /// The prior's information in the scaled columns (taken off: a prior sees nothing).
    pub prior: &'a DMatrix<f64>,
    /// The candidates on the constraint.
    pub pool: &'a Poses,
    /// Residual rows of the chosen poses.
    pub rows: usize,
    /// Residual rows of every candidate.
    pub pool_rows: usize,
    /// The free parameters' count.
    pub params: usize,
    /// Whether poses were given (`--given`).
    pub given: bool,
    /// Whether the pool was generated (`--pool`), not given (`--candidates`).
    pub generated: bool,
}

/// The exit-1 error naming the parameters `blind` the chosen poses leave unseen: blaming
/// `-n` (`count` poses asked, with `draws` parameter draws) when every candidate together
/// would see them, else the candidates (how many are distinct, when some repeat another).
///
/// # Errors
/// The pool's information failing (a bug).
pub(super) fn blind_error(
    case: &BlindCase<'_>,
    blind: &[&str],
    count: usize,
    draws: usize,
) -> Result<Error> {
    let err = |e: super::SelectError| Error::other(e.to_string());
    let every: Vec<usize> = (0..case.design.n_candidates()).collect();
    // As the choice is judged: a parameter is seen when some draw sees it.
    let mut seen = vec![false; case.params];
    for d in 0..case.design.n_draws() {
        let info = case.design.information(d, &every).map_err(err)?;
        let data = predicted_std(&(&info - case.prior)).map_err(err)?;
        seen.iter_mut()
            .zip(&data)
            .for_each(|(s, v)| *s |= v.is_finite());
    }
    let pool_sees = seen.iter().all(|&s| s);
    let given = if case.given {
        ", with the given poses"
    } else {
        ""
    };
    let nominals = draws == 0;
    let at = if nominals { " at the nominals" } else { "" };
    let names = blind.join(", ");
    let msg = if pool_sees {
        format!(
            "{} poses (of {} residual rows{given}) cannot determine all {} free parameters{at}: \
             {names} stay unseen{}",
            count,
            case.rows,
            case.params,
            if nominals {
                " by the poses chosen there: some nominals hide parameters whatever the poses \
                 (plan around them with --draws 3), or there are too few poses (-n)"
            } else {
                " whatever poses are chosen; ask for more poses (-n)"
            }
        )
    } else {
        pool_blind_message(case, &names, at, nominals)
    };
    Ok(Error::new(ErrorClass::Degenerate, Location::default(), msg))
}

/// The message when not even every candidate sees `names`: the candidates are to blame (a
/// generated pool is named as `--pool`).
fn pool_blind_message(case: &BlindCase<'_>, names: &str, at: &str, nominals: bool) -> String {
    let total = case.pool.len();
    let distinct = distinct_poses(case.pool);
    let (source, more) = if case.generated {
        ("the generated pool (--pool)", "a larger pool (--pool)")
    } else {
        ("the candidates", "more candidates")
    };
    let given = if case.given {
        " and the given poses"
    } else {
        ""
    };
    let hint = if nominals {
        "; or some nominals hide them whatever the poses (plan around them with --draws 3)"
    } else {
        ""
    };
    let whatever = "whatever the number asked (-n)";
    if distinct < total {
        format!(
            "{source} hold too few distinct poses: their {total} poses on the constraint are \
             only {distinct} distinct one{} (the other {} are near-duplicates, each within \
             {SAME_POSE:e} rad or m of another in every joint), too few to determine all {} \
             free parameters{at}: {names} stay unseen even with every candidate{given}, \
             {whatever}; give candidates of more varied joint readings (each pose once){hint}",
            if distinct == 1 { "" } else { "s" },
            total - distinct,
            case.params,
        )
    } else if case.pool_rows < case.params && !case.given {
        format!(
            "too few candidates: the {total} poses of {source} give {} residual rows for {} \
             free parameters{at}, so {names} stay unseen even with every candidate, {whatever}; \
             give {more}{hint}",
            case.pool_rows, case.params,
        )
    } else {
        format!(
            "{source} cannot determine all {} free parameters{at}: {names} stay unseen even \
             with every one of their {total} distinct poses{given}, {whatever}; give \
             candidates that move the joints these parameters act on{hint}",
            case.params,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool(rows: &[[f64; 2]]) -> Poses {
        let mut p = Poses {
            q: crate::data::Rows::new(2),
            ..Poses::default()
        };
        for (l, r) in rows.iter().enumerate() {
            p.q.push(r);
            p.constraint.push(0);
            p.line.push(l + 2);
        }
        p
    }

    #[test]
    fn repeats_count_once() {
        assert_eq!(distinct_poses(&pool(&[[0.1, 0.2]; 30])), 1);
        let near = pool(&[
            [0.1, 0.2],
            [0.3, 0.2],
            [0.1 + 1e-12, 0.2],
            [0.3, 0.2 - 1e-13],
        ]);
        assert_eq!(distinct_poses(&near), 2);
        assert_eq!(distinct_poses(&pool(&[[0.1, 0.2], [0.1, 0.2 + 1e-6]])), 2);
        assert_eq!(distinct_poses(&pool(&[])), 0);
    }
}
